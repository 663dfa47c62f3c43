//! An interrupted `atrium record` leaves nothing behind: neither the output nor its `.partial`.

#![cfg(unix)]

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn interrupt_record(signal: &str, tag: &str) {
    interrupt_record_as(signal, tag, "foxglove")
}

/// `profile` `ros2` writes a bag folder, `<out>.partial/` until complete: the interrupt must
/// remove the folder, not just the MCAP file in it (issue 45 found it left empty).
fn interrupt_record_as(signal: &str, tag: &str, profile: &str) {
    let dir = std::env::temp_dir().join(format!("atrium-interrupt-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let ros2 = profile == "ros2";
    let out = dir.join(if ros2 { "run" } else { "run.mcap" });
    let partial = dir.join(if ros2 {
        "run.partial"
    } else {
        "run.mcap.partial"
    });
    // What shows that recording has begun: the partial file with bytes in it, or the bag's
    // partial folder with its MCAP file.
    let begun = || {
        if ros2 {
            partial.join("run_0.mcap").exists()
        } else {
            std::fs::metadata(&partial).is_ok_and(|m| m.len() > 0)
        }
    };
    // The tour is long (minutes of simulated time): it is still recording when signalled.
    let mut child = Command::new(env!("CARGO_BIN_EXE_atrium"))
        .arg("record")
        .arg(repo().join("scenarios/tour.toml"))
        .arg("-o")
        .arg(&out)
        .args(["--profile", profile])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Waits until the recording has begun writing (a condition, not a fixed delay); the
    // deadline only stops a broken build from hanging the suite.
    let deadline = Instant::now() + Duration::from_secs(120);
    while !begun() {
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

#[test]
fn sigint_removes_the_partial_bag_folder() {
    interrupt_record_as("-INT", "ros2-int", "ros2");
}

#[test]
fn sigterm_removes_the_partial_bag_folder() {
    interrupt_record_as("-TERM", "ros2-term", "ros2");
}
