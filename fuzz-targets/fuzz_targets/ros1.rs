//! The ROS 1 bag reader (records, connections, index, bz2/lz4 chunks) and the message
//! decoders behind it, through the robot-log interface the log scenarios use.
#![no_main]

#[path = "common.rs"]
mod common;

use libfuzzer_sys::fuzz_target;

const MAGIC: &[u8] = b"#ROSBAG V2.0\n";

fuzz_target!(|data: &[u8]| {
    // Always a bag: the magic is given, the mutations go to what follows it.
    let mut bytes = MAGIC.to_vec();
    bytes.extend_from_slice(data.strip_prefix(MAGIC).unwrap_or(data));
    let path = common::put("log.bag", &bytes);
    common::walk_log(&path);
});
