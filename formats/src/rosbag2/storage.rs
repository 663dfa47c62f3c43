//! The messages of a rosbag2 folder: `metadata.yaml` (read and checked by
//! [`super::metadata`]) and its storage files, in one of rosbag2's two storages:
//!
//! - `mcap`: read through the checked container reader [`crate::mcap::container`] (lengths,
//!   CRCs, chunk decompression), each channel's message encoding must be `cdr` and its schema
//!   name the type the metadata gives its topic;
//! - `sqlite3`: opened read-only, its integrity checked (`PRAGMA quick_check`) and its schema
//!   checked to have the `topics` and `messages` tables with the columns read; a file that is
//!   not a database, or a damaged one, is an error naming it.
//!
//! Messages compressed one by one (`compression_mode: MESSAGE`, zstd) are decompressed. The
//! messages of the topics asked for come in time order (log time; a stable sort, so messages
//! of equal time keep the storage's order), the storage files read in the metadata's order.
//! For every topic read, the number of messages found must be the number `metadata.yaml`
//! gives: fewer means a storage file lost messages, and the caller must not get half a log.

use super::metadata::{self, Metadata};
use crate::mcap::container;
use crate::FormatError;
use std::collections::{BTreeMap, HashMap};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The largest message decompressed from a message-compressed bag (256 MiB, as the MCAP
/// reader's chunk limit): more is a damaged frame, not data.
pub const MAX_MESSAGE_BYTES: u64 = 256 << 20;

/// One message of a rosbag2 bag.
#[derive(Debug, Clone, PartialEq)]
pub struct BagMessage {
    pub topic: Arc<str>,
    /// The ROS 2 type name, `pkg/msg/Type`.
    pub msg_type: Arc<str>,
    /// Log (receive) time, nanoseconds since the epoch, and the same in seconds.
    pub time_ns: u64,
    pub time: f64,
    /// The CDR bytes, encapsulation header included.
    pub data: Vec<u8>,
}

/// An opened rosbag2 folder: its metadata checked and its storage files found.
#[derive(Debug, Clone)]
pub struct Rosbag2 {
    dir: PathBuf,
    metadata_path: PathBuf,
    metadata: Metadata,
    files: Vec<PathBuf>,
}

impl Rosbag2 {
    /// Reads `dir/metadata.yaml` and finds every storage file it lists.
    pub fn open(dir: &Path) -> Result<Rosbag2, FormatError> {
        let metadata_path = dir.join("metadata.yaml");
        let metadata = metadata::read(&metadata_path)?;
        let files = metadata
            .relative_file_paths
            .iter()
            .enumerate()
            .map(|(i, p)| storage_file(dir, &metadata_path, i, p))
            .collect::<Result<_, _>>()?;
        Ok(Rosbag2 {
            dir: dir.to_path_buf(),
            metadata_path,
            metadata,
            files,
        })
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    pub fn metadata(&self) -> &Metadata {
        &self.metadata
    }

    /// The storage files, in the metadata's order.
    pub fn storage_files(&self) -> &[PathBuf] {
        &self.files
    }

    /// The messages of `topics` (every one must be in the metadata), in time order.
    pub fn messages(&self, topics: &[&str]) -> Result<Vec<BagMessage>, FormatError> {
        let mut wanted: HashMap<&str, (Arc<str>, Arc<str>)> = HashMap::new();
        for &t in topics {
            let Some(info) = self.metadata.topic(t) else {
                return Err(FormatError::field(
                    &self.metadata_path,
                    "topics_with_message_count",
                    format!("the bag has no topic {t}"),
                ));
            };
            wanted.insert(t, (t.into(), info.topic_metadata.msg_type.as_str().into()));
        }
        let mut out = Vec::new();
        for file in &self.files {
            match self.metadata.storage_identifier.as_str() {
                "mcap" => read_mcap(file, &wanted, &mut out)?,
                _ => read_sqlite(file, &wanted, &mut out)?,
            }
        }
        if let Some(format) = self.metadata.message_compression() {
            for m in &mut out {
                m.data = decompress(&m.data, format).map_err(|e| {
                    FormatError::field(
                        &self.dir,
                        format!("topic {} message at {} ns", m.topic, m.time_ns),
                        e,
                    )
                })?;
            }
        }
        self.check_counts(topics, &out)?;
        out.sort_by_key(|m| m.time_ns);
        Ok(out)
    }

    fn check_counts(&self, topics: &[&str], got: &[BagMessage]) -> Result<(), FormatError> {
        let mut counts: BTreeMap<&str, u64> = topics.iter().map(|&t| (t, 0)).collect();
        for m in got {
            if let Some(c) = counts.get_mut(&*m.topic) {
                *c += 1;
            }
        }
        for (topic, n) in counts {
            let want = self.metadata.topic(topic).map_or(0, |t| t.message_count);
            if n != want {
                return Err(FormatError::field(
                    &self.dir,
                    format!("topic {topic}"),
                    format!(
                        "metadata.yaml counts {want} messages, the storage holds {n}: a storage file is damaged or incomplete"
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// The storage file listed as `relative_file_paths[i] = p`. Older rosbag2 versions wrote the
/// bag folder's own name in front (`bag/bag_0.db3`): that form is found too.
fn storage_file(dir: &Path, meta: &Path, i: usize, p: &str) -> Result<PathBuf, FormatError> {
    let rel = Path::new(p);
    let direct = dir.join(rel);
    if direct.is_file() {
        return Ok(direct);
    }
    if let Some(name) = rel.file_name() {
        let inside = dir.join(name);
        if inside.is_file() {
            return Ok(inside);
        }
    }
    Err(FormatError::field(
        meta,
        format!("relative_file_paths[{i}]"),
        format!("storage file {} does not exist", direct.display()),
    ))
}

fn decompress(data: &[u8], format: &str) -> Result<Vec<u8>, String> {
    if format != "zstd" {
        return Err(format!("compression {format:?} is not read"));
    }
    let mut out = Vec::new();
    zstd::stream::read::Decoder::new(data)
        .and_then(|d| d.take(MAX_MESSAGE_BYTES + 1).read_to_end(&mut out))
        .map_err(|e| format!("cannot be decompressed (zstd): {e}"))?;
    if out.len() as u64 > MAX_MESSAGE_BYTES {
        return Err(format!(
            "decompresses to more than {MAX_MESSAGE_BYTES} bytes: the data is damaged"
        ));
    }
    Ok(out)
}

/// Seconds of a nanosecond time, computed as a message header's stamp is (whole seconds plus
/// the nanoseconds scaled), so that equal times give bit-identical values.
fn seconds(ns: u64) -> f64 {
    (ns / 1_000_000_000) as f64 + (ns % 1_000_000_000) as f64 * 1e-9
}

fn read_mcap(
    file: &Path,
    wanted: &HashMap<&str, (Arc<str>, Arc<str>)>,
    out: &mut Vec<BagMessage>,
) -> Result<(), FormatError> {
    let bytes = std::fs::read(file).map_err(|e| FormatError::io(file, e))?;
    // Channels are checked once, on their first message.
    let mut checked: std::collections::HashSet<u16> = Default::default();
    for m in container::Messages::new(&bytes, file)? {
        let (place, channel, header, data) = m?;
        let Some((topic, msg_type)) = wanted.get(channel.topic.as_str()) else {
            continue;
        };
        if !checked.contains(&channel.id) {
            if channel.message_encoding != "cdr" {
                return Err(FormatError::field(
                    file,
                    format!("topic {topic} ({place})"),
                    format!(
                        "its messages are encoded as {:?}, not cdr",
                        channel.message_encoding
                    ),
                ));
            }
            if !channel.schema.is_empty() && channel.schema != **msg_type {
                return Err(FormatError::field(
                    file,
                    format!("topic {topic} ({place})"),
                    format!(
                        "its schema is {}, but metadata.yaml gives the type {msg_type}",
                        channel.schema
                    ),
                ));
            }
            checked.insert(channel.id);
        }
        out.push(BagMessage {
            topic: topic.clone(),
            msg_type: msg_type.clone(),
            time_ns: header.log_time,
            time: seconds(header.log_time),
            data: data.into_owned(),
        });
    }
    Ok(())
}

/// The columns read from each table, which the schema must have.
const TOPICS_COLUMNS: [&str; 4] = ["id", "name", "type", "serialization_format"];
const MESSAGES_COLUMNS: [&str; 4] = ["id", "topic_id", "timestamp", "data"];

fn read_sqlite(
    file: &Path,
    wanted: &HashMap<&str, (Arc<str>, Arc<str>)>,
    out: &mut Vec<BagMessage>,
) -> Result<(), FormatError> {
    use rusqlite::{Connection, OpenFlags};
    let db_err = |what: &str, e: rusqlite::Error| FormatError::field(file, what, e.to_string());
    let db = Connection::open_with_flags(
        file,
        OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX,
    )
    .map_err(|e| db_err("database", e))?;
    let integrity: String = db
        .query_row("PRAGMA quick_check(1)", [], |r| r.get(0))
        .map_err(|e| db_err("database", e))?;
    if integrity != "ok" {
        return Err(FormatError::field(
            file,
            "database",
            format!("the SQLite database is damaged (quick_check: {integrity})"),
        ));
    }
    check_columns(&db, file, "topics", &TOPICS_COLUMNS)?;
    check_columns(&db, file, "messages", &MESSAGES_COLUMNS)?;

    // topic id -> the wanted topic's names.
    let mut ids: HashMap<i64, (Arc<str>, Arc<str>)> = HashMap::new();
    {
        let mut q = db
            .prepare("SELECT id, name, type, serialization_format FROM topics")
            .map_err(|e| db_err("topics", e))?;
        let mut rows = q.query([]).map_err(|e| db_err("topics", e))?;
        while let Some(r) = rows.next().map_err(|e| db_err("topics", e))? {
            let row = |e| db_err("topics", e);
            let id: i64 = r.get(0).map_err(row)?;
            let name: String = r.get(1).map_err(row)?;
            let Some((topic, msg_type)) = wanted.get(name.as_str()) else {
                continue;
            };
            let ty: String = r.get(2).map_err(row)?;
            let format: String = r.get(3).map_err(row)?;
            let field = format!("topics row {id} ({name})");
            if format != "cdr" {
                return Err(FormatError::field(
                    file,
                    field,
                    format!("serialized as {format:?}, not cdr"),
                ));
            }
            if ty != **msg_type {
                return Err(FormatError::field(
                    file,
                    field,
                    format!("has the type {ty}, but metadata.yaml gives {msg_type}"),
                ));
            }
            ids.insert(id, (topic.clone(), msg_type.clone()));
        }
    }
    if ids.is_empty() {
        return Ok(());
    }
    let mut q = db
        .prepare("SELECT id, topic_id, timestamp, data FROM messages ORDER BY timestamp, id")
        .map_err(|e| db_err("messages", e))?;
    let mut rows = q.query([]).map_err(|e| db_err("messages", e))?;
    while let Some(r) = rows.next().map_err(|e| db_err("messages", e))? {
        let row = |e| db_err("messages", e);
        let topic_id: i64 = r.get(1).map_err(row)?;
        let Some((topic, msg_type)) = ids.get(&topic_id) else {
            continue;
        };
        let id: i64 = r.get(0).map_err(row)?;
        let field = || format!("messages row {id}");
        let stamp: i64 = r
            .get(2)
            .map_err(|e| FormatError::field(file, field(), e.to_string()))?;
        let time_ns = u64::try_from(stamp).map_err(|_| {
            FormatError::field(file, field(), format!("negative timestamp {stamp}"))
        })?;
        let data = r
            .get_ref(3)
            .and_then(|v| v.as_blob().map_err(Into::into))
            .map_err(|e| FormatError::field(file, field(), format!("data: {e}")))?;
        out.push(BagMessage {
            topic: topic.clone(),
            msg_type: msg_type.clone(),
            time_ns,
            time: seconds(time_ns),
            data: data.to_vec(),
        });
    }
    Ok(())
}

fn check_columns(
    db: &rusqlite::Connection,
    file: &Path,
    table: &str,
    columns: &[&str],
) -> Result<(), FormatError> {
    let mut have = Vec::new();
    db.pragma(None, "table_info", table, |r| {
        have.push(r.get::<_, String>(1)?);
        Ok(())
    })
    .map_err(|e| FormatError::field(file, table, e.to_string()))?;
    if have.is_empty() {
        return Err(FormatError::field(
            file,
            table,
            "the database has no such table: not a rosbag2 sqlite3 storage file",
        ));
    }
    for c in columns {
        if !have.iter().any(|h| h == c) {
            return Err(FormatError::field(
                file,
                table,
                format!("the table has no column {c}: not a rosbag2 sqlite3 storage file"),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn datasets() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../datasets")
    }

    /// A scratch folder for one test, removed first if a former run left it.
    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("atrium-rosbag2-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn copy_bag(from: &Path, to: &Path) {
        for e in std::fs::read_dir(from).unwrap() {
            let e = e.unwrap();
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }

    #[test]
    fn both_storages_give_the_same_messages_for_the_first_minute() {
        let mcap = Rosbag2::open(&datasets().join("fr079/fr079_ros2")).unwrap();
        let sqlite = Rosbag2::open(&datasets().join("fixtures/fr079_head_sqlite3")).unwrap();
        assert_eq!(mcap.storage_files().len(), 1);
        let topics = ["/scan", "/odom", "/tf_static"];
        let a = mcap.messages(&topics).unwrap();
        let b = sqlite.messages(&topics).unwrap();
        assert_eq!(a.len(), 4934 + 8951 + 1);
        assert_eq!(b.len(), 279 + 504 + 1);
        assert!(a.windows(2).all(|w| w[0].time_ns <= w[1].time_ns));
        assert_eq!(&a[..b.len()], &b[..]);
        assert_eq!(&*b[0].msg_type, "tf2_msgs/msg/TFMessage");
        assert_eq!(b[0].time, 1211.0 + 520_329_000.0 * 1e-9);
    }

    #[test]
    fn unknown_topics_and_missing_files_are_errors() {
        let bag = Rosbag2::open(&datasets().join("fixtures/fr079_head_sqlite3")).unwrap();
        let e = bag.messages(&["/nope"]).unwrap_err().to_string();
        assert!(e.contains("the bag has no topic /nope"), "{e}");
        let dir = scratch("missing");
        std::fs::copy(
            datasets().join("fixtures/fr079_head_sqlite3/metadata.yaml"),
            dir.join("metadata.yaml"),
        )
        .unwrap();
        let e = Rosbag2::open(&dir).unwrap_err().to_string();
        assert!(
            e.contains("relative_file_paths[0]: storage file") && e.contains("does not exist"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_damaged_or_foreign_database_is_refused() {
        let src = datasets().join("fixtures/fr079_head_sqlite3");
        let db_name = "fr079_head_sqlite3.db3";
        let good = std::fs::read(src.join(db_name)).unwrap();
        let dir = scratch("damaged");
        copy_bag(&src, &dir);
        let read = || {
            Rosbag2::open(&dir).and_then(|b| b.messages(&["/scan", "/odom", "/tf", "/tf_static"]))
        };
        let whole = read().unwrap();
        assert_eq!(whole.len(), 1288);
        // Cut at several points, garbage, an empty file: an error naming the file. Bytes
        // flipped: an error, or a read of every message (SQLite has no checksums: a flip
        // inside a message's data or an unused part of a page goes unnoticed here, and is
        // left to the message decoders).
        let mut variants: Vec<(String, Vec<u8>)> =
            [0, 100, 4096, good.len() / 2, good.len() - 4096]
                .iter()
                .map(|&n| (format!("cut at {n}"), good[..n].to_vec()))
                .collect();
        variants.push(("garbage".into(), vec![b'x'; 8192]));
        for k in [20usize, 4096 + 10, good.len() / 3, good.len() - 100] {
            let mut b = good.clone();
            for x in &mut b[k..k + 64] {
                *x ^= 0x5a;
            }
            variants.push((format!("flipped at {k}"), b));
        }
        let mut errors = 0;
        for (what, v) in &variants {
            std::fs::write(dir.join(db_name), v).unwrap();
            match read() {
                Err(e) => {
                    errors += 1;
                    let e = e.to_string();
                    assert!(e.contains(db_name) || e.contains("topic /"), "{what}: {e}");
                }
                Ok(m) => assert!(
                    m.len() == whole.len() && what.starts_with("flipped"),
                    "{what}"
                ),
            }
        }
        assert!(errors >= 6, "{errors}");
        // A database of another program.
        std::fs::remove_file(dir.join(db_name)).unwrap();
        let other = rusqlite::Connection::open(dir.join(db_name)).unwrap();
        other
            .execute_batch("CREATE TABLE topics(id INTEGER, name TEXT);")
            .unwrap();
        drop(other);
        let e = read().unwrap_err().to_string();
        assert!(e.contains("topics: the table has no column type"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_damaged_mcap_storage_is_an_error() {
        let src = datasets().join("fr079/fr079_ros2");
        let name = "fr079_ros2.mcap";
        let good = std::fs::read(src.join(name)).unwrap();
        let dir = scratch("mcap");
        copy_bag(&src, &dir);
        for n in [0, 8, 1000, good.len() / 2, good.len() - 1] {
            std::fs::write(dir.join(name), &good[..n]).unwrap();
            let r = Rosbag2::open(&dir).and_then(|b| b.messages(&["/scan"]));
            assert!(r.is_err(), "cut at {n}");
        }
        let mut b = good.clone();
        b[good.len() / 3] ^= 0x10;
        std::fs::write(dir.join(name), &b).unwrap();
        let e = Rosbag2::open(&dir)
            .and_then(|b| b.messages(&["/scan"]))
            .unwrap_err()
            .to_string();
        assert!(e.contains(name), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn message_compression_is_undone() {
        let data = b"\x00\x01\x00\x00hello".to_vec();
        let packed = zstd::bulk::compress(&data, 3).unwrap();
        assert_eq!(decompress(&packed, "zstd").unwrap(), data);
        assert!(decompress(&data, "zstd").is_err());
        assert!(decompress(&packed, "lz4").is_err());
    }
}
