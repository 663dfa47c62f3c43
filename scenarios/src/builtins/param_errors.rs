//! A localizer kind's parameter check, turned into a [`ScenarioError`] that names the field:
//! `localizers[NAME].FIELD` of the scenario file when the check's message starts with one of
//! the parameters' fields, the table itself otherwise. Every built-in kind reports this way.

use crate::error::ScenarioError;
use atrium_localization::LocalizationError;
use serde::Serialize;
use std::path::Path;

/// The field a parameter check's message starts with, when it is one of `params`' fields:
/// `validate` messages begin with the field (`max_beams: ...`, `alpha[2] must ...`,
/// `fspf.eta must ...`). Returns the field path and the rest of the message.
pub(crate) fn split_field<'m, P: Serialize>(
    params: &P,
    msg: &'m str,
) -> Option<(&'m str, &'m str)> {
    let end = msg.find([' ', ':'])?;
    let (path, rest) = msg.split_at(end);
    let base = path.split(['[', '.']).next().unwrap_or(path);
    let fields = serde_json::to_value(params).ok()?;
    fields.as_object()?.contains_key(base).then(|| {
        let rest = rest.strip_prefix(':').unwrap_or(rest).trim_start();
        (path, rest)
    })
}

/// A parameter check's message as an error at `localizers[NAME].FIELD` of `file` (`prefix` is
/// `localizers[NAME]`), or at the table itself when the message does not start with a field
/// of `params`.
pub(crate) fn param_error<P: Serialize>(
    file: &Path,
    prefix: &str,
    params: &P,
    msg: &str,
) -> ScenarioError {
    match split_field(params, msg) {
        Some((field, rest)) => ScenarioError::field(file, format!("{prefix}.{field}"), rest),
        None => ScenarioError::field(file, prefix, msg),
    }
}

/// [`param_error`] for a localization error: a parameter's message names its field.
pub(crate) fn localization_error<P: Serialize>(
    file: &Path,
    prefix: &str,
    params: &P,
    e: LocalizationError,
) -> ScenarioError {
    match e {
        LocalizationError::InvalidParameter(msg) => param_error(file, prefix, params, &msg),
        e => ScenarioError::field(file, prefix, e.to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use atrium_localization::mcl::MclParams;

    #[test]
    fn a_check_message_is_placed_at_its_field() {
        let p = MclParams::default();
        let at =
            |msg: &str| param_error(Path::new("s.toml"), "localizers[mcl]", &p, msg).to_string();
        assert_eq!(
            at("max_beams: 7 is more than the limit of 5 (L)"),
            "s.toml: localizers[mcl].max_beams: 7 is more than the limit of 5 (L)"
        );
        assert_eq!(
            at("alpha[2] must be finite and >= 0, got -1"),
            "s.toml: localizers[mcl].alpha[2]: must be finite and >= 0, got -1"
        );
        // Not a field of the parameters: the message stays at the table.
        assert_eq!(
            at("the MclMap was built for other parameters"),
            "s.toml: localizers[mcl]: the MclMap was built for other parameters"
        );
        let cgr = atrium_localization::CgrParams::default();
        assert_eq!(
            split_field(&cgr, "fspf.eta must be >= 1, got 0"),
            Some(("fspf.eta", "must be >= 1, got 0"))
        );
    }
}
