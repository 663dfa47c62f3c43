//! The files a sweep's trials read, and the hash over their contents that identifies the
//! sweep: `--resume` and `sweep merge` refuse results written under another hash, so a world,
//! robot, training scenario or error map edited between runs never mixes rows of two inputs.
//!
//! Collected while the sweep is validated (every cell's scenario is built then): each cell
//! scenario's own files ([`Scenario::input_files`]: scenario, world, robot, sensor file),
//! every path a factory resolved through `BuildContext::path`, and every string parameter of
//! a localizer that names an existing file beside the scenario (or in the localizer's `cwd`):
//! a chooser's `training` and `error_map`, WiFi's `training` and `graph`, a process
//! localizer's script. A file named so that is a scenario (training runs) adds its own files
//! the same way. Hashing a file no trial reads only makes the check stricter.

use atrium_scenarios::error::ScenarioError;
use atrium_scenarios::scenario::Scenario;
use std::collections::{BTreeSet, HashSet};
use std::path::{Component, Path, PathBuf};
use std::sync::Mutex;

/// One file the trials read: its name (relative to the sweep file's folder, so that shards
/// run from other folders or machines agree) and the hash of its content.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct InputFile {
    pub file: String,
    pub hash: String,
}

/// FNV-1a 64 over `parts` with a separator, printed as hex: stable across machines and
/// Rust versions (unlike `DefaultHasher`).
pub fn fnv_hex(parts: &[&[u8]]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for p in parts {
        for &b in p.iter().chain(std::iter::once(&0u8)) {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    }
    format!("{h:016x}")
}

/// Longest string parameter taken for a file name (longer ones are not paths).
const MAX_NAME: usize = 4096;

/// The files seen while validating (shared by the validating threads).
#[derive(Default)]
pub struct Collector {
    files: Mutex<BTreeSet<PathBuf>>,
    /// (folder, string) pairs already looked at, and scenarios already scanned: cells repeat
    /// the same parameters, so each is looked up on disk once.
    seen: Mutex<HashSet<(PathBuf, String)>>,
    scenarios: Mutex<HashSet<PathBuf>>,
}

impl Collector {
    pub fn add_file(&self, p: &Path) {
        let known = |files: &BTreeSet<PathBuf>| files.contains(p);
        // Every cell names the same few files: look each up on disk once.
        if known(&self.files.lock().unwrap_or_else(|e| e.into_inner())) || !p.is_file() {
            return;
        }
        self.files
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .insert(p.to_path_buf());
    }

    /// `scenario`'s own files and the files its localizers name.
    pub fn add_scenario(&self, scenario: &Scenario) {
        for f in &scenario.input_files {
            self.add_file(f);
        }
        let dir = scenario.file.parent().unwrap_or(Path::new("."));
        for spec in &scenario.localizers {
            let mut dirs = vec![dir.to_path_buf()];
            if let Some(cwd) = spec.params.get("cwd").and_then(|v| v.as_str()) {
                dirs.push(dir.join(cwd));
            }
            for s in strings(&toml::Value::Table(spec.params.clone())) {
                for d in &dirs {
                    self.add_named(d, s);
                }
            }
        }
    }

    fn add_named(&self, dir: &Path, s: &str) {
        if s.is_empty() || s.len() > MAX_NAME || s.contains('\0') {
            return;
        }
        let fresh = self
            .seen
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .insert((dir.to_path_buf(), s.to_string()));
        if !fresh {
            return;
        }
        let p = dir.join(s);
        if !p.is_file() {
            return;
        }
        self.add_file(&p);
        let is_toml = p.extension().is_some_and(|e| e == "toml");
        let first = is_toml
            && self
                .scenarios
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .insert(p.clone());
        // A training or survey scenario: its world, robot and localizers' files count too.
        // A TOML file that is no scenario is only hashed.
        if first {
            if let Ok(s) = Scenario::load(&p) {
                self.add_scenario(&s);
            }
        }
    }

    /// Every file collected, sorted.
    pub fn files(&self) -> Vec<PathBuf> {
        self.files
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .iter()
            .cloned()
            .collect()
    }
}

/// Every string in `v` (tables and arrays searched).
fn strings(v: &toml::Value) -> Vec<&str> {
    match v {
        toml::Value::String(s) => vec![s.as_str()],
        toml::Value::Array(a) => a.iter().flat_map(strings).collect(),
        toml::Value::Table(t) => t.values().flat_map(strings).collect(),
        _ => Vec::new(),
    }
}

/// `p` with `.` dropped and `..` applied to the component before it where there is one.
fn normalize(p: &Path) -> PathBuf {
    let mut out: Vec<Component> = Vec::new();
    for c in p.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => match out.last() {
                Some(Component::Normal(_)) => {
                    out.pop();
                }
                Some(Component::RootDir) | Some(Component::Prefix(_)) => {}
                _ => out.push(c),
            },
            c => out.push(c),
        }
    }
    out.iter().collect()
}

/// `file` as named from folder `dir` (both taken lexically): relative when both are
/// relative or both absolute, with `/` separators; else `file` itself.
pub fn name_from(dir: &Path, file: &Path) -> String {
    let (d, f) = (normalize(dir), normalize(file));
    if d.is_absolute() != f.is_absolute() {
        return f.to_string_lossy().replace('\\', "/");
    }
    let dc: Vec<Component> = d.components().collect();
    let fc: Vec<Component> = f.components().collect();
    let common = dc.iter().zip(&fc).take_while(|(a, b)| a == b).count();
    if dc[common..]
        .iter()
        .any(|c| matches!(c, Component::ParentDir))
    {
        return f.to_string_lossy().replace('\\', "/");
    }
    let mut parts: Vec<String> = vec!["..".to_string(); dc.len() - common];
    parts.extend(
        fc[common..]
            .iter()
            .map(|c| c.as_os_str().to_string_lossy().into_owned()),
    );
    parts.join("/")
}

/// The content hash of each of `files`, named from `dir`, sorted by name. Folder and files
/// are canonicalized first, so the names (and the sweep's hash) do not depend on how the
/// sweep file's path was typed: `small.toml` and `/abs/small.toml` holding absolute paths
/// name their inputs alike (issue 45: shards run from another folder were refused).
pub fn hash_files(dir: &Path, files: &[PathBuf]) -> Result<Vec<InputFile>, ScenarioError> {
    let canonical = |p: &Path| {
        let p = if p.as_os_str().is_empty() {
            Path::new(".")
        } else {
            p
        };
        p.canonicalize().unwrap_or_else(|_| p.to_path_buf())
    };
    let dir = canonical(dir);
    let mut out = Vec::with_capacity(files.len());
    for f in files {
        let bytes = std::fs::read(f).map_err(|err| ScenarioError::Io {
            file: f.clone(),
            err,
        })?;
        out.push(InputFile {
            file: name_from(&dir, &canonical(f)),
            hash: fnv_hex(&[&bytes]),
        });
    }
    out.sort_by(|a, b| a.file.cmp(&b.file));
    out.dedup_by(|a, b| a.file == b.file);
    Ok(out)
}

/// The sweep's hash: its own text and every input's name and content hash.
pub fn sweep_hash(text: &str, inputs: &[InputFile]) -> String {
    let mut parts: Vec<&[u8]> = vec![text.as_bytes()];
    for i in inputs {
        parts.push(i.file.as_bytes());
        parts.push(i.hash.as_bytes());
    }
    fnv_hex(&parts)
}

/// What differs between the inputs recorded with earlier results and these: the files
/// changed, added or gone.
pub fn describe_changes(old: &[InputFile], new: &[InputFile]) -> Vec<String> {
    let mut out = Vec::new();
    for n in new {
        match old.iter().find(|o| o.file == n.file) {
            Some(o) if o.hash != n.hash => out.push(format!("{} changed", n.file)),
            Some(_) => {}
            None => out.push(format!("{} is new", n.file)),
        }
    }
    for o in old {
        if !new.iter().any(|n| n.file == o.file) {
            out.push(format!("{} is no longer read", o.file));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hash_depends_on_every_part() {
        assert_ne!(fnv_hex(&[b"ab", b"c"]), fnv_hex(&[b"a", b"bc"]));
        assert_eq!(fnv_hex(&[b"x"]), fnv_hex(&[b"x"]));
    }

    /// Issue 45: `atrium sweep small.toml` (from its folder) and `atrium sweep
    /// /abs/small.toml` of a sweep naming absolute paths must hash alike, or merge and
    /// `--resume` refuse a shard run from another folder.
    #[test]
    fn names_do_not_depend_on_how_the_folder_is_typed() {
        let dir = std::env::temp_dir()
            .canonicalize()
            .unwrap()
            .join(format!("atrium-inputs-typed-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("sweeps")).unwrap();
        let input = dir.join("base.toml");
        std::fs::write(&input, "x").unwrap();
        let abs_dir = dir.join("sweeps");
        // The same folder typed relative to the working directory, through `..` to the root.
        let cwd = std::env::current_dir().unwrap().canonicalize().unwrap();
        let mut rel = PathBuf::new();
        for _ in cwd.components().skip(1) {
            rel.push("..");
        }
        rel.push(abs_dir.strip_prefix("/").unwrap());
        let a = hash_files(&abs_dir, std::slice::from_ref(&input)).unwrap();
        let b = hash_files(&rel, std::slice::from_ref(&input)).unwrap();
        assert_eq!(a, b);
        assert_eq!(a[0].file, "../base.toml");
        assert_eq!(sweep_hash("t", &a), sweep_hash("t", &b));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn names_are_relative_to_the_sweep_folder() {
        let n = |d: &str, f: &str| name_from(Path::new(d), Path::new(f));
        assert_eq!(n("/a/b", "/a/b/../w/campus.toml"), "../w/campus.toml");
        assert_eq!(n("/a/b", "/a/b/x.toml"), "x.toml");
        assert_eq!(n("", "base.toml"), "base.toml");
        assert_eq!(n("sweeps", "sweeps/../s/../base.toml"), "../base.toml");
        assert_eq!(n("sweeps", "/abs/base.toml"), "/abs/base.toml");
        assert_eq!(n("../x", "a.toml"), "a.toml");
    }

    #[test]
    fn files_named_by_localizers_and_training_scenarios_are_collected() {
        let dir = std::env::temp_dir().join(format!("atrium-inputs-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        let root = atrium_scenarios::bundled_scenarios_dir().join("..");
        std::fs::copy(root.join("worlds/lab.toml"), dir.join("train_world.toml")).unwrap();
        let scenario = |world: &str, params: &str| {
            format!(
                "name = \"s\"\nduration_s = 1.0\nworld = {world:?}\nrobot = {:?}\nseed = 1\n\
                 [start]\npose = [1.0, 1.0, 0.0]\n[route]\nwaypoints = [[1.5, 1.0]]\n\
                 [[localizers]]\nname = \"l\"\nkind = \"dead_reckoning\"\n{params}",
                root.join("robots/urdf/pioneer3dx.urdf")
            )
        };
        std::fs::write(
            dir.join("train.toml"),
            scenario("train_world.toml", "graph = \"graph.json\"\n"),
        )
        .unwrap();
        std::fs::write(dir.join("graph.json"), "{}").unwrap();
        std::fs::write(dir.join("map.csv"), "x").unwrap();
        std::fs::write(dir.join("sub/loc.py"), "x").unwrap();
        let text = scenario(
            &root.join("worlds/lab.toml").to_string_lossy(),
            "training = \"train.toml\"\nerror_map = \"map.csv\"\ncwd = \"sub\"\n\
             command = [\"python3\", \"loc.py\"]\nnot_a_file = \"mcl\"\n",
        );
        let s = Scenario::from_toml_str(&text, &dir.join("base.toml")).unwrap();
        let c = Collector::default();
        c.add_scenario(&s);
        let names: Vec<String> = c.files().iter().map(|f| name_from(&dir, f)).collect();
        for want in [
            "train.toml",
            "train_world.toml",
            "graph.json",
            "map.csv",
            "sub/loc.py",
        ] {
            assert!(names.iter().any(|n| n == want), "{want} not in {names:?}");
        }
        assert!(names.iter().any(|n| n.ends_with("pioneer3dx.sensors.toml")));
        // base.toml does not exist on disk (the text was given): not a file read.
        assert!(!names.iter().any(|n| n == "base.toml"), "{names:?}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn changes_name_the_files() {
        let f = |n: &str, h: &str| InputFile {
            file: n.into(),
            hash: h.into(),
        };
        let old = [f("a", "1"), f("b", "2"), f("c", "3")];
        let new = [f("a", "1"), f("b", "9"), f("d", "4")];
        assert_eq!(
            describe_changes(&old, &new),
            ["b changed", "d is new", "c is no longer read"]
        );
        assert_ne!(sweep_hash("t", &old), sweep_hash("t", &new));
    }
}
