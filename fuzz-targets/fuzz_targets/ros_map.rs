//! The ROS map reader: a map_server YAML and its PGM or PNG image (see `common::split`).
//! An accepted map has a positive finite resolution and cell count of its image.
#![no_main]

#[path = "common.rs"]
mod common;

use atrium_formats::ros_map;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((yaml, image)) = common::split(data) else {
        return;
    };
    let yaml_path = common::put("map.yaml", yaml);
    common::put("map.pgm", image);
    common::put("map.png", image);
    match ros_map::read_map(&yaml_path) {
        Ok(g) => {
            assert!(g.resolution.is_finite() && g.resolution > 0.0);
            assert_eq!(g.cells.len(), g.width * g.height);
        }
        Err(e) => {
            let text = e.to_string();
            assert!(text.contains("map."), "the error names no file: {text}");
        }
    }
});
