//! The `atrium_msgs` ROS 2 interface package in `ros/atrium_msgs` (issue 42) defines exactly the
//! `atrium_msgs` types Atrium writes into its bags: one `.msg` file per type with the same
//! fields, every file listed in `CMakeLists.txt`, and `package.xml` naming the package and its
//! one dependency. (That the definitions inside recorded bags equal these files is checked
//! where bags are written: `recordings/tests/ros2_bag.rs`.)

use atrium_formats::rosbag2::schemas;
use std::path::PathBuf;

fn package() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../ros/atrium_msgs")
}

#[test]
fn every_atrium_type_has_its_msg_file_with_the_same_fields() {
    let dir = package().join("msg");
    let mut files: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    let mut types: Vec<String> = schemas::atrium_msgs_types()
        .map(|t| format!("{}.msg", t.rsplit('/').next().unwrap()))
        .collect();
    types.sort();
    assert_eq!(files, types, "msg files vs the types Atrium writes");
    for t in schemas::atrium_msgs_types() {
        let file = dir.join(format!("{}.msg", t.rsplit('/').next().unwrap()));
        let text = std::fs::read_to_string(&file).unwrap();
        assert_eq!(
            schemas::msg_without_comments(&text),
            schemas::own_definition(t).unwrap(),
            "{}",
            file.display()
        );
    }
}

#[test]
fn cmake_lists_every_msg_file_and_package_xml_names_the_package() {
    let cmake = std::fs::read_to_string(package().join("CMakeLists.txt")).unwrap();
    assert!(cmake.contains("project(atrium_msgs)"));
    let listed: Vec<&str> = cmake
        .lines()
        .map(str::trim)
        .filter(|l| l.starts_with("\"msg/"))
        .map(|l| l.trim_matches('"'))
        .collect();
    let mut want: Vec<String> = schemas::atrium_msgs_types()
        .map(|t| format!("msg/{}.msg", t.rsplit('/').next().unwrap()))
        .collect();
    want.sort();
    let mut got: Vec<String> = listed.iter().map(|s| s.to_string()).collect();
    got.sort();
    assert_eq!(got, want);
    assert!(cmake.contains("DEPENDENCIES std_msgs"));
    let xml = std::fs::read_to_string(package().join("package.xml")).unwrap();
    for needed in [
        "<name>atrium_msgs</name>",
        "<depend>std_msgs</depend>",
        "<member_of_group>rosidl_interface_packages</member_of_group>",
        "<buildtool_depend>rosidl_default_generators</buildtool_depend>",
        "<build_type>ament_cmake</build_type>",
    ] {
        assert!(xml.contains(needed), "package.xml lacks {needed}");
    }
}
