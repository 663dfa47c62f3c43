//! An interrupted `atrium record` leaves nothing behind: neither the output nor its `.partial`.

#![cfg(unix)]

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn interrupt_record(signal: &str, tag: &str) {
    let dir = std::env::temp_dir().join(format!("atrium-interrupt-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("run.mcap");
    let partial = dir.join("run.mcap.partial");
    // The tour is long (minutes of simulated time): it is still recording when signalled.
    let mut child = Command::new(env!("CARGO_BIN_EXE_atrium"))
        .arg("record")
        .arg(repo().join("scenarios/tour.toml"))
        .arg("-o")
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Waits until the recording has begun writing (a condition, not a fixed delay); the
    // deadline only stops a broken build from hanging the suite.
    let deadline = Instant::now() + Duration::from_secs(120);
    while std::fs::metadata(&partial).map_or(true, |m| m.len() == 0) {
        assert!(
            child.try_wait().unwrap().is_none(),
            "record ended before it was interrupted"
        );
        assert!(
            Instant::now() < deadline,
            "no {} appeared",
            partial.display()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let killed = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("removed unfinished"), "{stderr}");
    assert!(!partial.exists(), "{} left behind", partial.display());
    assert!(
        !out.exists(),
        "{} written by an interrupted run",
        out.display()
    );
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn sigint_removes_the_partial_recording() {
    interrupt_record("-INT", "int");
}

#[test]
fn sigterm_removes_the_partial_recording() {
    interrupt_record("-TERM", "term");
}
