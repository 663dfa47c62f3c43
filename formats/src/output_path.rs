//! Where an output may go. Outputs are written under a temporary name and renamed over the
//! final one, which replaces whatever had that name: a device (`-o /dev/null` turned
//! `/dev/null` into a regular file for every process on the machine), a FIFO or a socket must
//! be refused instead.

use std::path::Path;

/// An error when `path` exists and is neither a regular file nor a folder (nor a link to
/// one): a device, a FIFO or a socket, which renaming a finished file over would replace.
pub fn check_replaceable(path: &Path) -> std::io::Result<()> {
    let Ok(meta) = std::fs::metadata(path) else {
        return Ok(());
    };
    let t = meta.file_type();
    if t.is_file() || t.is_dir() {
        return Ok(());
    }
    Err(std::io::Error::other(format!(
        "{} is a device, FIFO or socket, not a file: outputs are written whole under a \
         temporary name and renamed over it, which would replace it; name a regular file",
        path.display()
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_are_refused_files_and_new_names_are_not() {
        let e = check_replaceable(Path::new("/dev/null")).unwrap_err();
        assert!(e.to_string().contains("/dev/null is a device"), "{e}");
        assert!(check_replaceable(Path::new("/definitely/not/there.yaml")).is_ok());
        assert!(check_replaceable(Path::new(env!("CARGO_MANIFEST_DIR"))).is_ok());
        assert!(
            check_replaceable(&Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml")).is_ok()
        );
    }
}
