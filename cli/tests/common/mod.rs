//! Helpers shared by the CLI-level integration tests.

use std::path::PathBuf;
use std::process::{Command, Output};

/// Runs the `atrium` binary built for these tests.
pub fn atrium(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_atrium"))
        .args(args)
        .output()
        .expect("run atrium")
}

/// A fresh, empty temporary folder for one test (`tag` keeps tests apart, the process id
/// keeps concurrent test runs apart).
pub fn tmpdir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("atrium-test-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A path under the repository's `datasets/` folder, as a string for command lines and
/// scenario files.
#[allow(dead_code)] // not every test binary reads the datasets
pub fn datasets(rel: &str) -> String {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../datasets")
        .join(rel)
        .to_string_lossy()
        .into_owned()
}
