//! rosbag2's `metadata.yaml`: one mapping `rosbag2_bagfile_information` that names the
//! storage plugin (`mcap` or `sqlite3`), the storage files, each topic with its type,
//! serialization and message count, the compression, and the bag's start and duration.
//!
//! Read with a real YAML parser (serde_yaml_ng), so whatever rosbag2 (yaml-cpp) and the Python
//! `rosbags` package (ruamel) write is read, folded plain scalars included. Accepted: versions 1
//! to 9; `offered_qos_profiles` as a string (versions 4 to 8: a YAML document inside a string)
//! or a list (version 9); fields a version does not have defaulted, and `null` read as empty.
//! [`Metadata::check`] refuses what the readers of this crate cannot read, naming the field:
//! an unknown storage, file-level compression (`compression_mode: FILE`, where each storage
//! file is compressed whole), a compression other than zstd, a topic not serialized as CDR,
//! and a bag without storage files.
//!
//! [`to_yaml`] writes the fields rosbag2 requires for the metadata's version, in the form that
//! version expects, so that `ros2 bag info` accepts the result.

use crate::FormatError;
use serde::{Deserialize, Deserializer, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// The newest metadata version read (rosbag2 in ROS 2 Jazzy writes 9).
pub const NEWEST_VERSION: u32 = 9;

/// The contents of `metadata.yaml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Metadata {
    pub version: u32,
    pub storage_identifier: String,
    #[serde(default, deserialize_with = "null_as_default")]
    pub relative_file_paths: Vec<String>,
    pub duration: Duration,
    pub starting_time: StartingTime,
    pub message_count: u64,
    #[serde(default, deserialize_with = "null_as_default")]
    pub topics_with_message_count: Vec<TopicInformation>,
    #[serde(default, deserialize_with = "null_as_default")]
    pub compression_format: String,
    #[serde(default, deserialize_with = "null_as_default")]
    pub compression_mode: String,
    /// Per storage file (version 5 on).
    #[serde(default, deserialize_with = "null_as_default")]
    pub files: Vec<FileInformation>,
    /// Version 6 on.
    #[serde(default, deserialize_with = "null_as_default")]
    pub custom_data: BTreeMap<String, String>,
    /// Version 8 on.
    #[serde(default, deserialize_with = "null_as_default")]
    pub ros_distro: String,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Duration {
    pub nanoseconds: u64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct StartingTime {
    pub nanoseconds_since_epoch: u64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TopicInformation {
    pub topic_metadata: TopicMetadata,
    pub message_count: u64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TopicMetadata {
    pub name: String,
    /// The ROS 2 type name, `pkg/msg/Type`.
    #[serde(rename = "type")]
    pub msg_type: String,
    pub serialization_format: String,
    #[serde(default, deserialize_with = "null_as_default")]
    pub offered_qos_profiles: QosProfiles,
    /// Version 7 on.
    #[serde(default, deserialize_with = "null_as_default")]
    pub type_description_hash: String,
}

/// The QoS profiles a topic was offered with: a YAML document inside a string up to version
/// 8, a list from version 9. Kept as written; not interpreted here.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum QosProfiles {
    Text(String),
    List(Vec<serde_yaml_ng::Value>),
}

impl Default for QosProfiles {
    fn default() -> Self {
        QosProfiles::Text(String::new())
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FileInformation {
    pub path: String,
    pub starting_time: StartingTime,
    pub duration: Duration,
    pub message_count: u64,
}

#[derive(Serialize, Deserialize)]
struct Document {
    rosbag2_bagfile_information: Metadata,
}

/// `null` (or `~`, or an empty value) read as the type's default, as rosbag2 does.
fn null_as_default<'de, D, T>(d: D) -> Result<T, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de> + Default,
{
    Ok(Option::<T>::deserialize(d)?.unwrap_or_default())
}

impl Metadata {
    /// The bag's first message time, seconds since the epoch.
    pub fn starting_seconds(&self) -> f64 {
        self.starting_time.nanoseconds_since_epoch as f64 * 1e-9
    }

    /// The compression of each message's data, if any: `Some("zstd")` for
    /// `compression_mode: MESSAGE`, `None` for none.
    pub fn message_compression(&self) -> Option<&str> {
        let mode = self.compression_mode.trim();
        (mode.eq_ignore_ascii_case("message")).then_some(self.compression_format.as_str())
    }

    /// Refuses what this crate's readers cannot read, naming the field (`path` is the
    /// metadata file, for the error).
    pub fn check(&self, path: &Path) -> Result<(), FormatError> {
        let bad = |field: &str, msg: String| Err(FormatError::field(path, field, msg));
        if self.version == 0 || self.version > NEWEST_VERSION {
            return bad(
                "version",
                format!(
                    "metadata version {} is not one this reader knows (1 to {NEWEST_VERSION})",
                    self.version
                ),
            );
        }
        if !matches!(self.storage_identifier.as_str(), "mcap" | "sqlite3") {
            return bad(
                "storage_identifier",
                format!(
                    "storage {:?} is not read; only \"mcap\" and \"sqlite3\" are",
                    self.storage_identifier
                ),
            );
        }
        let mode = self.compression_mode.trim();
        if mode.eq_ignore_ascii_case("file") {
            return bad(
                "compression_mode",
                "FILE: each storage file is compressed whole, which is not read; convert the bag \
                 first (`ros2 bag convert` to no compression or MESSAGE compression)"
                    .into(),
            );
        }
        if mode.eq_ignore_ascii_case("message") {
            if self.compression_format != "zstd" {
                return bad(
                    "compression_format",
                    format!(
                        "{:?}: only zstd message compression is read",
                        self.compression_format
                    ),
                );
            }
        } else if !(mode.is_empty() || mode.eq_ignore_ascii_case("none")) {
            return bad(
                "compression_mode",
                format!("{mode:?} is not a rosbag2 compression mode (none, FILE or MESSAGE)"),
            );
        }
        for (i, t) in self.topics_with_message_count.iter().enumerate() {
            let m = &t.topic_metadata;
            if m.serialization_format != "cdr" {
                return bad(
                    &format!("topics_with_message_count[{i}].topic_metadata.serialization_format"),
                    format!(
                        "topic {} is serialized as {:?}; only \"cdr\" is read",
                        m.name, m.serialization_format
                    ),
                );
            }
        }
        if self.relative_file_paths.is_empty() {
            return bad("relative_file_paths", "lists no storage file".into());
        }
        Ok(())
    }

    /// The topic named `name`, if the bag has it.
    pub fn topic(&self, name: &str) -> Option<&TopicInformation> {
        self.topics_with_message_count
            .iter()
            .find(|t| t.topic_metadata.name == name)
    }
}

/// `metadata.yaml`'s text parsed (not checked: see [`Metadata::check`]); `path` names the file
/// in errors.
pub fn parse(text: &str, path: &Path) -> Result<Metadata, FormatError> {
    serde_yaml_ng::from_str::<Document>(text)
        .map(|d| d.rosbag2_bagfile_information)
        .map_err(|e| FormatError::field(path, "metadata", e.to_string()))
}

/// Reads, parses and checks the `metadata.yaml` at `path`.
pub fn read(path: &Path) -> Result<Metadata, FormatError> {
    let text = std::fs::read_to_string(path).map_err(|e| FormatError::io(path, e))?;
    let m = parse(&text, path)?;
    m.check(path)?;
    Ok(m)
}

/// A `metadata.yaml` for `m` that rosbag2 reads: every field its version requires, QoS
/// profiles as a string before version 9 and as a list from 9 on.
pub fn to_yaml(m: &Metadata) -> String {
    let mut m = m.clone();
    for t in &mut m.topics_with_message_count {
        let q = &mut t.topic_metadata.offered_qos_profiles;
        *q = qos_for_version(std::mem::take(q), m.version);
    }
    let doc = Document {
        rosbag2_bagfile_information: m,
    };
    // Plain data of strings, numbers, lists and maps: serializing cannot fail.
    serde_yaml_ng::to_string(&doc).unwrap_or_default()
}

fn qos_for_version(q: QosProfiles, version: u32) -> QosProfiles {
    match q {
        QosProfiles::Text(s) if version >= 9 => {
            if s.trim().is_empty() {
                return QosProfiles::List(Vec::new());
            }
            // A version 8 string is itself a YAML list: carry it over as the list.
            match serde_yaml_ng::from_str::<Vec<serde_yaml_ng::Value>>(&s) {
                Ok(list) => QosProfiles::List(list),
                Err(_) => QosProfiles::List(Vec::new()),
            }
        }
        QosProfiles::List(list) if version < 9 => {
            if list.is_empty() {
                QosProfiles::Text(String::new())
            } else {
                QosProfiles::Text(serde_yaml_ng::to_string(&list).unwrap_or_default())
            }
        }
        q => q,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// As rosbag2 (yaml-cpp) writes version 5: QoS as a string holding YAML.
    const ROSBAG2_V5: &str = r#"
rosbag2_bagfile_information:
  version: 5
  storage_identifier: sqlite3
  relative_file_paths:
    - demo_0.db3
  duration:
    nanoseconds: 2500000000
  starting_time:
    nanoseconds_since_epoch: 1700000000123456789
  message_count: 30
  topics_with_message_count:
    - topic_metadata:
        name: /scan
        type: sensor_msgs/msg/LaserScan
        serialization_format: cdr
        offered_qos_profiles: "- history: 3\n  depth: 0\n  reliability: 1\n"
      message_count: 20
    - topic_metadata:
        name: /odom
        type: nav_msgs/msg/Odometry
        serialization_format: cdr
        offered_qos_profiles: ""
      message_count: 10
  compression_format: ""
  compression_mode: ""
  files:
    - path: demo_0.db3
      starting_time:
        nanoseconds_since_epoch: 1700000000123456789
      duration:
        nanoseconds: 2500000000
      message_count: 30
"#;

    /// As the `rosbags` package writes version 9: a folded type hash, QoS as a list.
    const ROSBAGS_V9: &str = "rosbag2_bagfile_information:
  compression_format: ''
  compression_mode: ''
  custom_data: null
  duration:
    nanoseconds: 10
  files: []
  message_count: 1
  relative_file_paths:
  - b.mcap
  ros_distro: rosbags
  starting_time:
    nanoseconds_since_epoch: 5
  storage_identifier: mcap
  topics_with_message_count:
  - message_count: 1
    topic_metadata:
      name: /tf_static
      offered_qos_profiles:
      - depth: 1
        durability: transient_local
      serialization_format: cdr
      type: tf2_msgs/msg/TFMessage
      type_description_hash: 
        RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087
  version: 9
";

    fn p() -> &'static Path {
        Path::new("bag/metadata.yaml")
    }

    #[test]
    fn what_rosbag2_and_rosbags_write_is_read() {
        let m = parse(ROSBAG2_V5, p()).unwrap();
        m.check(p()).unwrap();
        assert_eq!((m.version, m.storage_identifier.as_str()), (5, "sqlite3"));
        assert_eq!(m.relative_file_paths, vec!["demo_0.db3"]);
        assert_eq!(m.duration.nanoseconds, 2_500_000_000);
        assert_eq!(
            m.starting_time.nanoseconds_since_epoch,
            1_700_000_000_123_456_789
        );
        assert_eq!(m.topics_with_message_count[0].message_count, 20);
        let scan = &m.topic("/scan").unwrap().topic_metadata;
        assert_eq!(scan.msg_type, "sensor_msgs/msg/LaserScan");
        assert!(matches!(&scan.offered_qos_profiles, QosProfiles::Text(s) if s.contains("depth")));
        assert_eq!(m.files[0].message_count, 30);
        assert!(m.custom_data.is_empty() && m.ros_distro.is_empty());
        assert_eq!(m.message_compression(), None);

        let m = parse(ROSBAGS_V9, p()).unwrap();
        m.check(p()).unwrap();
        let tf = &m.topics_with_message_count[0].topic_metadata;
        // The folded plain scalar is one string, without the line break.
        assert_eq!(
            tf.type_description_hash,
            "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"
        );
        assert!(matches!(&tf.offered_qos_profiles, QosProfiles::List(l) if l.len() == 1));
        assert_eq!(m.ros_distro, "rosbags");
    }

    #[test]
    fn the_bundled_bags_metadata_is_read() {
        for dir in ["fr079/fr079_ros2", "fixtures/fr079_head_sqlite3"] {
            let path = Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../datasets")
                .join(dir)
                .join("metadata.yaml");
            let m = read(&path).unwrap();
            assert_eq!(m.topics_with_message_count.len(), 4, "{dir}");
            assert_eq!(m.starting_time.nanoseconds_since_epoch, 1_211_520_329_000);
        }
    }

    #[test]
    fn what_cannot_be_read_is_refused_naming_the_field() {
        let cases = [
            (
                ROSBAG2_V5.replace("compression_mode: \"\"", "compression_mode: FILE"),
                "compression_mode: FILE",
            ),
            (
                ROSBAG2_V5.replace(
                    "compression_mode: \"\"",
                    "compression_mode: MESSAGE",
                ),
                "compression_format: \"\": only zstd",
            ),
            (
                ROSBAG2_V5.replacen("serialization_format: cdr", "serialization_format: json", 1),
                "topics_with_message_count[0].topic_metadata.serialization_format: topic /scan is serialized as \"json\"",
            ),
            (
                ROSBAG2_V5.replace("storage_identifier: sqlite3", "storage_identifier: hdf5"),
                "storage_identifier: storage \"hdf5\" is not read",
            ),
            (
                ROSBAG2_V5.replace("version: 5", "version: 42"),
                "version: metadata version 42",
            ),
        ];
        for (text, want) in cases {
            let e = parse(&text, p())
                .unwrap()
                .check(p())
                .unwrap_err()
                .to_string();
            assert!(
                e.starts_with("bag/metadata.yaml: ") && e.contains(want),
                "{e}"
            );
        }
        let m = parse(
            &ROSBAG2_V5
                .replace("compression_mode: \"\"", "compression_mode: MESSAGE")
                .replace("compression_format: \"\"", "compression_format: zstd"),
            p(),
        )
        .unwrap();
        m.check(p()).unwrap();
        assert_eq!(m.message_compression(), Some("zstd"));
        // Broken YAML and a missing field: serde_yaml_ng's message, which says where.
        let e = parse("rosbag2_bagfile_information: [", p())
            .unwrap_err()
            .to_string();
        assert!(e.contains("metadata: ") && e.contains("line"), "{e}");
        let e = parse(
            &ROSBAG2_V5.replace("    nanoseconds: 2500000000\n", ""),
            p(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("nanoseconds"), "{e}");
    }

    #[test]
    fn to_yaml_round_trips_and_writes_what_each_version_requires() {
        for text in [ROSBAG2_V5, ROSBAGS_V9] {
            let m = parse(text, p()).unwrap();
            let out = to_yaml(&m);
            assert_eq!(parse(&out, p()).unwrap(), m, "{out}");
            for field in [
                "version:",
                "storage_identifier:",
                "relative_file_paths:",
                "duration:",
                "starting_time:",
                "message_count:",
                "topics_with_message_count:",
                "compression_format:",
                "compression_mode:",
                "files:",
                "custom_data:",
                "ros_distro:",
                "offered_qos_profiles:",
                "type_description_hash:",
            ] {
                assert!(out.contains(field), "{field} missing in\n{out}");
            }
        }
        // A version 8 bag's string QoS becomes a list when written as version 9, and back.
        let mut m = parse(ROSBAG2_V5, p()).unwrap();
        m.version = 9;
        let v9 = parse(&to_yaml(&m), p()).unwrap();
        let q = &v9.topics_with_message_count[0]
            .topic_metadata
            .offered_qos_profiles;
        assert!(matches!(q, QosProfiles::List(l) if l.len() == 1), "{q:?}");
        let q = &v9.topics_with_message_count[1]
            .topic_metadata
            .offered_qos_profiles;
        assert_eq!(q, &QosProfiles::List(vec![]));
        let mut back = v9.clone();
        back.version = 8;
        let v8 = parse(&to_yaml(&back), p()).unwrap();
        let q = &v8.topics_with_message_count[0]
            .topic_metadata
            .offered_qos_profiles;
        assert!(
            matches!(q, QosProfiles::Text(s) if s.contains("history: 3")),
            "{q:?}"
        );
    }
}
