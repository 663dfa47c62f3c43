//! World generators: a world from a few parameters instead of wall by wall.
//!
//! A generator file is TOML with a `generator` key naming the kind and, beside it, that
//! kind's parameters as flat keys (so a sweep can vary `world.<parameter>`):
//!
//! ```toml
//! generator = "office_atrium"
//! seed = 7
//! atrium_width = 20.0
//! glass_fraction = 0.4
//! ```
//!
//! A generator turns the parameters into the explicit world TOML text, and that text is parsed
//! by the normal loader ([`World::from_toml_str`]): a generated world is held to exactly the
//! rules of a hand-written one, and can be written out (`atrium generate world`) and loaded
//! again unchanged. Kinds are registered by name in a [`GeneratorRegistry`]; the bundled
//! [`office_atrium`] registers exactly as a user's own kind would.
//!
//! Parameter errors name the parameter as the field (`atrium_width: ...`), with the line of
//! the generator file it came from, or `(from --set)` when it was overridden.

mod kind;
pub mod office_atrium;
mod rng;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::error::WorldError;
use crate::world::World;

pub use kind::{ParamError, WorldGenerator};
pub use office_atrium::{generate, GeneratorParams, OfficeAtrium};

/// Generator kinds by name.
#[derive(Clone, Default)]
pub struct GeneratorRegistry {
    kinds: BTreeMap<String, Arc<dyn WorldGenerator>>,
}

impl GeneratorRegistry {
    /// A registry without any kind.
    pub fn empty() -> Self {
        Self::default()
    }

    /// The bundled kinds: `office_atrium`.
    pub fn with_builtins() -> Self {
        let mut r = Self::empty();
        r.register("office_atrium", Arc::new(OfficeAtrium))
            .expect("fresh registry");
        r
    }

    /// Adds a kind; a name already taken is refused (a silent replacement would change what
    /// existing generator files make).
    pub fn register(
        &mut self,
        name: &str,
        generator: Arc<dyn WorldGenerator>,
    ) -> Result<(), String> {
        if name.trim().is_empty() {
            return Err("a generator name must not be empty".into());
        }
        if self.kinds.contains_key(name) {
            return Err(format!("generator {name:?} is already registered"));
        }
        self.kinds.insert(name.to_string(), generator);
        Ok(())
    }

    pub fn get(&self, name: &str) -> Option<&Arc<dyn WorldGenerator>> {
        self.kinds.get(name)
    }

    pub fn names(&self) -> Vec<&str> {
        self.kinds.keys().map(String::as_str).collect()
    }
}

/// Where a parameter's value came from, for messages.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Origin {
    /// 1-based line in the generator file.
    Line(usize),
    Set,
}

/// A parsed generator file: the kind and its parameters, possibly overridden.
#[derive(Debug, Clone)]
pub struct GeneratorFile {
    pub file: PathBuf,
    pub generator: String,
    params: BTreeMap<String, (toml::Value, Origin)>,
    generator_line: Option<usize>,
}

/// Whether TOML `text` is a generator file (it has a top-level `generator` key) rather than
/// an explicit world. Text that is not TOML is no generator file.
///
/// A scan of the top-level lines (before the first `[table]`) decides first, so an explicit
/// world is not parsed twice on its way to the loader; only a candidate is parsed in full.
pub fn is_generator_text(text: &str) -> bool {
    let mut candidate = false;
    for line in text.lines() {
        let line = line.trim_start();
        if line.starts_with('[') {
            break;
        }
        let rest = ["generator", "\"generator\"", "'generator'"]
            .iter()
            .find_map(|k| line.strip_prefix(k));
        if rest.is_some_and(|r| r.trim_start().starts_with('=')) {
            candidate = true;
            break;
        }
    }
    candidate && toml::from_str::<toml::Table>(text).is_ok_and(|t| t.contains_key("generator"))
}

fn line_of(text: &str, offset: usize) -> usize {
    1 + text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|&&c| c == b'\n')
        .count()
}

impl GeneratorFile {
    /// Reads a generator file.
    pub fn load(path: &Path) -> Result<Self, WorldError> {
        let text = std::fs::read_to_string(path).map_err(|err| WorldError::Io {
            file: path.to_path_buf(),
            err,
        })?;
        Self::parse(&text, path)
    }

    /// Reads `path` and parses it as a generator file if it is one ([`is_generator_text`]);
    /// `None` for anything else (an explicit world, for the world loader to read).
    pub fn load_if_generator(path: &Path) -> Result<Option<Self>, WorldError> {
        let text = std::fs::read_to_string(path).map_err(|err| WorldError::Io {
            file: path.to_path_buf(),
            err,
        })?;
        if is_generator_text(&text) {
            Self::parse(&text, path).map(Some)
        } else {
            Ok(None)
        }
    }

    /// Parses generator file text; `file` is used in messages only.
    pub fn parse(text: &str, file: &Path) -> Result<Self, WorldError> {
        let raw: BTreeMap<String, toml::Spanned<toml::Value>> =
            toml::from_str(text).map_err(|e| WorldError::Parse {
                file: file.to_path_buf(),
                msg: e.to_string().trim_end().to_string(),
            })?;
        let mut generator = None;
        let mut params = BTreeMap::new();
        for (key, value) in raw {
            // The value's line: for a flat `key = value` it is the key's line too.
            let line = line_of(text, value.span().start);
            let value = value.into_inner();
            if key == "generator" {
                match value {
                    toml::Value::String(s) => generator = Some((s, line)),
                    other => {
                        return Err(field(
                            file,
                            "generator",
                            format!(
                                "must be a string naming the kind, got {} (line {line})",
                                other.type_str()
                            ),
                        ))
                    }
                }
            } else {
                params.insert(key, (value, Origin::Line(line)));
            }
        }
        let Some((generator, line)) = generator else {
            return Err(field(
                file,
                "generator",
                "required: the kind of generator, e.g. generator = \"office_atrium\"",
            ));
        };
        Ok(Self {
            file: file.to_path_buf(),
            generator,
            params,
            generator_line: Some(line),
        })
    }

    /// Overrides one parameter. The key must be one of the kind's parameters (checked when
    /// generating, where the kind is known).
    pub fn set(&mut self, key: &str, value: toml::Value) -> Result<(), WorldError> {
        let key = key.trim();
        if key.is_empty() {
            return Err(field(&self.file, "--set", "empty parameter name"));
        }
        if key == "generator" {
            return Err(field(
                &self.file,
                "generator",
                "cannot be changed by --set; write another generator file",
            ));
        }
        self.params.insert(key.to_string(), (value, Origin::Set));
        Ok(())
    }

    /// Overrides one parameter from a `KEY=VALUE` argument. VALUE is read as a TOML value
    /// (`20`, `0.5`, `"office"`); text that is not one is taken as a string, so
    /// `name=office` works without shell-quoted quotes.
    pub fn set_arg(&mut self, arg: &str) -> Result<(), WorldError> {
        let Some((key, value)) = arg.split_once('=') else {
            return Err(field(
                &self.file,
                "--set",
                format!("expected KEY=VALUE, got {arg:?}"),
            ));
        };
        self.set(key, parse_value(value))
    }

    /// The current value of a parameter as written or set (defaults not included).
    pub fn get(&self, key: &str) -> Option<&toml::Value> {
        self.params.get(key).map(|(v, _)| v)
    }

    fn located(&self, e: ParamError) -> WorldError {
        let msg = match self.params.get(&e.param) {
            Some((_, Origin::Line(l))) => format!("{} (line {l})", e.msg),
            Some((_, Origin::Set)) => format!("{} (from --set)", e.msg),
            None => e.msg,
        };
        field(&self.file, e.param, msg)
    }

    /// The explicit world TOML text this file makes with the kinds of `registry`.
    pub fn generate_toml(&self, registry: &GeneratorRegistry) -> Result<String, WorldError> {
        let Some(kind) = registry.get(&self.generator) else {
            let at = self
                .generator_line
                .map(|l| format!(" (line {l})"))
                .unwrap_or_default();
            return Err(field(
                &self.file,
                "generator",
                format!(
                    "unknown generator {:?} (known: {}){at}",
                    self.generator,
                    registry.names().join(", ")
                ),
            ));
        };
        let defaults = kind.defaults();
        let mut table = toml::Table::new();
        for (key, (value, _)) in &self.params {
            if !defaults.contains_key(key) {
                let known: Vec<&str> = defaults.keys().map(String::as_str).collect();
                return Err(self.located(ParamError::new(
                    key.clone(),
                    format!(
                        "unknown parameter of generator {:?} (known: {})",
                        self.generator,
                        known.join(", ")
                    ),
                )));
            }
            table.insert(key.clone(), value.clone());
        }
        kind.generate_toml(&table).map_err(|e| self.located(e))
    }

    /// Generates and loads the world, validated by the loader's rules. A generator whose text
    /// the loader refuses is a bug in that generator; the message says so.
    pub fn generate(&self, registry: &GeneratorRegistry) -> Result<World, WorldError> {
        self.generate_with_text(registry).map(|(_, w)| w)
    }

    /// [`GeneratorFile::generate`] plus the explicit world text it loaded (what
    /// `atrium generate world` writes).
    pub fn generate_with_text(
        &self,
        registry: &GeneratorRegistry,
    ) -> Result<(String, World), WorldError> {
        let text = self.generate_toml(registry)?;
        let world = World::from_toml_str(&text, &self.generated_name()).map_err(|e| {
            field(
                &self.file,
                "generator",
                format!(
                    "generator {:?} made a world the loader refuses (a bug in the \
                     generator): {e}",
                    self.generator
                ),
            )
        })?;
        Ok((text, world))
    }

    /// How the generated text is named in messages: `<file> (generated)`.
    fn generated_name(&self) -> PathBuf {
        let mut s = self.file.as_os_str().to_owned();
        s.push(" (generated)");
        PathBuf::from(s)
    }
}

/// A `--set` value: TOML if it is a TOML value, otherwise the text as a string.
fn parse_value(text: &str) -> toml::Value {
    let text = text.trim();
    toml::from_str::<toml::Table>(&format!("v = {text}"))
        .ok()
        .and_then(|mut t| t.remove("v"))
        .unwrap_or_else(|| toml::Value::String(text.to_string()))
}

fn field(file: &Path, field: impl Into<String>, msg: impl Into<String>) -> WorldError {
    WorldError::Field {
        file: file.to_path_buf(),
        field: field.into(),
        msg: msg.into(),
    }
}

/// Loads `path` as a world: a generator file (top-level `generator` key) is generated with
/// the bundled kinds, anything else is loaded as an explicit world. Either way the world has
/// passed the loader's validation.
pub fn load_world_or_generator(path: &Path) -> Result<World, WorldError> {
    load_world_or_generator_with(path, &GeneratorRegistry::with_builtins())
}

/// [`load_world_or_generator`] with the generator kinds of `registry`.
pub fn load_world_or_generator_with(
    path: &Path,
    registry: &GeneratorRegistry,
) -> Result<World, WorldError> {
    let text = std::fs::read_to_string(path).map_err(|err| WorldError::Io {
        file: path.to_path_buf(),
        err,
    })?;
    world_from_text(&text, path, registry)
}

/// The world of file text: generated if it is a generator file, else parsed as an explicit
/// world; `file` is used in messages only.
pub fn world_from_text(
    text: &str,
    file: &Path,
    registry: &GeneratorRegistry,
) -> Result<World, WorldError> {
    if is_generator_text(text) {
        GeneratorFile::parse(text, file)?.generate(registry)
    } else {
        World::from_toml_str(text, file)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_values_are_toml_or_strings() {
        assert_eq!(parse_value("20"), toml::Value::Integer(20));
        assert_eq!(parse_value(" 0.5 "), toml::Value::Float(0.5));
        assert!(parse_value("nan").as_float().unwrap().is_nan());
        assert_eq!(parse_value("\"a b\""), toml::Value::String("a b".into()));
        assert_eq!(parse_value("office"), toml::Value::String("office".into()));
        assert_eq!(parse_value("0,5"), toml::Value::String("0,5".into()));
    }

    #[test]
    fn generator_key_is_required_and_a_string() {
        let p = Path::new("g.toml");
        let e = GeneratorFile::parse("seed = 1\n", p)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("g.toml: generator: required"), "{e}");
        let e = GeneratorFile::parse("seed = 1\ngenerator = 3\n", p)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "g.toml: generator: must be a string naming the kind, got integer (line 2)"
        );
        let g = GeneratorFile::parse("generator = \"nope\"\n", p).unwrap();
        let e = g
            .generate_toml(&GeneratorRegistry::with_builtins())
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "g.toml: generator: unknown generator \"nope\" (known: office_atrium) (line 1)"
        );
        assert!(is_generator_text("generator = \"x\""));
        assert!(!is_generator_text("name = \"x\"\nceiling_height = 3.0"));
        assert!(!is_generator_text("generator = = \"x\""));
        assert!(is_generator_text(
            "# a comment\n\"generator\" = \"x\"\nseed = 1"
        ));
        // Only top-level keys count, and only real ones (not text in a string).
        assert!(!is_generator_text(
            "name = \"w\"\n[materials.generator]\nlaser = \"opaque\""
        ));
        assert!(!is_generator_text("[t]\ngenerator = \"x\""));
        assert!(!is_generator_text("s = \"\"\"\ngenerator = 1\n\"\"\"\n"));
    }

    #[test]
    fn registry_refuses_a_taken_name() {
        let mut r = GeneratorRegistry::with_builtins();
        let e = r
            .register("office_atrium", Arc::new(OfficeAtrium))
            .unwrap_err();
        assert!(e.contains("already registered"), "{e}");
        assert_eq!(r.names(), vec!["office_atrium"]);
    }
}
