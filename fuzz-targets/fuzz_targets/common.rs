//! What the targets share: a scratch folder per process (in /dev/shm when it exists, as the
//! readers take paths), the split of one input into two files, and the log walk.

#![allow(dead_code)] // each target uses part of it

use atrium_formats::robot_log::RobotLog;
use atrium_formats::ros_msgs::MessageKind;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// This process's scratch folder, emptied of a previous run's files.
pub fn scratch() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let base = if Path::new("/dev/shm").is_dir() {
            PathBuf::from("/dev/shm")
        } else {
            std::env::temp_dir()
        };
        let dir = base.join(format!("atrium-fuzz-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    })
}

/// Writes `bytes` to `name` in the scratch folder.
pub fn put(name: &str, bytes: &[u8]) -> PathBuf {
    let p = scratch().join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// Two files in one input: a little-endian u16 length, that many bytes, then the rest
/// (`scripts/fuzz_seeds.py` writes the seeds this way).
pub fn split(data: &[u8]) -> Option<(&[u8], &[u8])> {
    let n = u16::from_le_bytes(data.get(..2)?.try_into().ok()?) as usize;
    let rest = &data[2..];
    (n <= rest.len()).then(|| rest.split_at(n))
}

/// An error must name the file (or the folder) it is about.
pub fn names(err: &dyn std::fmt::Display, path: &Path) {
    let text = err.to_string();
    let name = path.file_name().unwrap().to_string_lossy();
    assert!(
        text.contains(name.as_ref()),
        "the error does not name {name}: {text}"
    );
}

/// Opens the log at `path` and reads every topic as its type, as `atrium` would.
pub fn walk_log(path: &Path) {
    let log = match RobotLog::open(path) {
        Ok(l) => l,
        Err(e) => return names(&e, path),
    };
    let topics: Vec<_> = log.topics().to_vec();
    for t in &topics {
        let r = match t.kind() {
            Some(MessageKind::LaserScan) => log.scans(&t.name).map(|m| {
                for s in &m {
                    assert!(s.ranges.len() < 1 << 24);
                }
            }),
            Some(MessageKind::Odometry) => log.odometry(&t.name).map(drop),
            Some(MessageKind::PoseStamped | MessageKind::PoseWithCovarianceStamped) => {
                log.poses(&t.name).map(drop)
            }
            Some(MessageKind::TfMessage) => log.transforms(&t.name).map(drop),
            _ => Ok(()),
        };
        if let Err(e) = r {
            names(&e, path);
        }
    }
    if let Err(e) = log.static_transforms() {
        names(&e, path);
    }
}
