//! The CARMEN log reader, plain and gzipped, through the robot-log interface the log
//! scenarios use: every topic read back, every refusal naming the file.
#![no_main]

#[path = "common.rs"]
mod common;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // Never the magic of a ROS 1 bag or MCAP file: those go to their own targets.
    if data.starts_with(b"#ROSBAG") || data.starts_with(b"\x89MCAP") {
        return;
    }
    let path = common::put("log.clf", data);
    common::walk_log(&path);
});
