//! Process-wide memo of parsed world and robot files. A sweep validates every cell by loading
//! its scenario, and every cell names the same world and URDF: parsing and validating them
//! again per cell was 93 % of validating a 10,000-cell sweep.
//!
//! The file is read on every call and the memo is keyed by its path and its full text (never
//! a hash, so a key cannot collide): an edited file is parsed afresh, and a hit returns exactly
//! what parsing would. Only successful parses are kept (an error is cheap to find again and
//! must name the file as read now). The memo holds at most [`CAPACITY`] files of each kind.

use atrium_robots::{RobotError, RobotModel};
use atrium_worlds::{GeneratorRegistry, World, WorldError};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

/// Distinct files kept per kind; a sweep names one world and one robot, a test binary a few
/// dozen. When full the memo is emptied (simplest bound; a miss only costs a parse).
const CAPACITY: usize = 64;

type Memo<T> = Mutex<HashMap<(PathBuf, String), T>>;

fn lookup_or_parse<T: Clone, E>(
    memo: &'static OnceLock<Memo<T>>,
    path: &Path,
    text: String,
    parse: impl FnOnce(&str) -> Result<T, E>,
) -> Result<T, E> {
    let memo = memo.get_or_init(|| Mutex::new(HashMap::new()));
    let key = (path.to_path_buf(), text);
    if let Some(hit) = memo.lock().unwrap_or_else(|p| p.into_inner()).get(&key) {
        return Ok(hit.clone());
    }
    // Parsed outside the lock: other files proceed meanwhile; two threads parsing the same
    // file at once both get equal values.
    let value = parse(&key.1)?;
    let mut map = memo.lock().unwrap_or_else(|p| p.into_inner());
    if map.len() >= CAPACITY {
        map.clear();
    }
    map.insert(key, value.clone());
    Ok(value)
}

/// The world of a world or generator file ([`atrium_worlds::world_from_text`] with the
/// bundled generator kinds), memoised by path and content: a sweep over one generator file
/// generates its world once.
pub fn world(path: &Path) -> Result<World, WorldError> {
    static MEMO: OnceLock<Memo<World>> = OnceLock::new();
    let text = std::fs::read_to_string(path).map_err(|err| WorldError::Io {
        file: path.to_path_buf(),
        err,
    })?;
    lookup_or_parse(&MEMO, path, text, |t| {
        atrium_worlds::world_from_text(t, path, &GeneratorRegistry::with_builtins())
    })
}

/// The world of generator file `path` with `params` set ([`GeneratorFile::set`]) before
/// generating: a scenario's `[world_params]`, which is how a sweep's `world.<parameter>` axis
/// reaches the generator without writing a file. Memoised by path, content and parameters,
/// so the cells of a sweep that make the same world generate it once, and cells that make
/// different worlds never share one.
///
/// A file that is not a generator file is refused under the field `generator` (only a
/// generated world has parameters); a parameter the kind does not take, or a value that
/// cannot make a world, under the parameter's name (the generator's own messages).
pub fn world_with_params(path: &Path, params: &toml::Table) -> Result<World, WorldError> {
    static MEMO: OnceLock<Memo<World>> = OnceLock::new();
    let text = std::fs::read_to_string(path).map_err(|err| WorldError::Io {
        file: path.to_path_buf(),
        err,
    })?;
    if !atrium_worlds::generate::is_generator_text(&text) {
        return Err(WorldError::Field {
            file: path.to_path_buf(),
            field: "generator".into(),
            msg: "is not a generator file (no top-level `generator` key): only a generated \
                  world has parameters to set"
                .into(),
        });
    }
    // The parameters are part of the key: TOML text of a table, after the file's text and a
    // separator no TOML file holds (a raw NUL is not allowed in TOML).
    let key = format!("{text}\n\u{0}\n{params}");
    lookup_or_parse(&MEMO, path, key, |_| {
        let mut generator = atrium_worlds::GeneratorFile::parse(&text, path)?;
        for (k, v) in params {
            generator.set(k, v.clone())?;
        }
        generator.generate(&GeneratorRegistry::with_builtins())
    })
}

/// [`RobotModel::from_urdf`], memoised by path and content.
pub fn robot(path: &Path) -> Result<RobotModel, RobotError> {
    static MEMO: OnceLock<Memo<RobotModel>> = OnceLock::new();
    let text = std::fs::read_to_string(path).map_err(|err| RobotError::Io {
        source_name: path.display().to_string(),
        err,
    })?;
    lookup_or_parse(&MEMO, path, text, |t| {
        RobotModel::from_urdf_str(t, &path.display().to_string())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bundled(rel: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
    }

    #[test]
    fn a_hit_equals_a_fresh_parse() {
        let w = bundled("../worlds/campus.toml");
        assert_eq!(world(&w).unwrap(), World::load(&w).unwrap());
        assert_eq!(world(&w).unwrap(), World::load(&w).unwrap());
    }

    #[test]
    fn an_edited_file_is_parsed_again() {
        let dir = std::env::temp_dir().join(format!("atrium-load-cache-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("w.toml");
        let text = std::fs::read_to_string(bundled("../worlds/campus.toml")).unwrap();
        std::fs::write(&file, &text).unwrap();
        assert_eq!(world(&file).unwrap().name, "campus");
        let renamed = text.replacen("name = \"campus\"", "name = \"renamed campus\"", 1);
        std::fs::write(&file, renamed).unwrap();
        assert_eq!(world(&file).unwrap().name, "renamed campus");
        std::fs::write(&file, "not a world").unwrap();
        let err = world(&file).unwrap_err().to_string();
        assert!(err.contains("w.toml"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
