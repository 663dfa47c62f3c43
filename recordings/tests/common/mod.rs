//! Helpers shared by the integration tests.

use std::path::PathBuf;

/// A fresh, empty temporary folder for one test (`tag` keeps tests apart, the process id
/// keeps concurrent test runs apart).
pub fn tmpdir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("atrium-test-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}
