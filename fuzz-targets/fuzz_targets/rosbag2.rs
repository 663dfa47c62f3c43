//! The rosbag2 reader: metadata.yaml and its storage file (sqlite3 or MCAP), then every
//! topic decoded (CDR) through the robot-log interface the log scenarios use. The input is
//! the metadata and the storage bytes (see `common::split`); the storage is written under
//! both names the seeds' metadata use.
#![no_main]

#[path = "common.rs"]
mod common;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((meta, storage)) = common::split(data) else {
        return;
    };
    let dir = common::scratch().join("bag");
    let _ = std::fs::create_dir_all(&dir);
    std::fs::write(dir.join("metadata.yaml"), meta).unwrap();
    // A database left from the previous input must not be reused half-written.
    let _ = std::fs::remove_file(dir.join("bag.db3-journal"));
    std::fs::write(dir.join("bag.db3"), storage).unwrap();
    std::fs::write(dir.join("bag.mcap"), storage).unwrap();
    common::walk_log(&dir);
});
