//! ROS 1 bags (format 2.0): the line `#ROSBAG V2.0`, a bag header record giving the index's
//! position and the numbers of connections and chunks, then chunk records (bz2, lz4 or
//! uncompressed, each holding connection and message data records) each followed by index
//! data records, then the index: one connection record per connection (topic, type, md5sum,
//! message definition) and one chunk info record per chunk (with the message count of each
//! connection in it). Every record is a length-prefixed header of `name=value` fields and a
//! length-prefixed data part.
//!
//! Decompression and record parsing are the `rosbag` crate's (v0.6). That crate trusts the
//! file where it should not: the bag header's index position slices its memory map unchecked
//! (a truncated bag panics), and a chunk's stated size is allocated before the data is read
//! (a damaged size asks for up to 4 GiB). So before it sees the file, this module walks every
//! top-level record itself (reading headers only, seeking over data) and checks that each
//! record lies within the file, that the chunk section ends exactly at the index, that each
//! chunk's size is at most [`MAX_CHUNK_BYTES`] with a known compression, and that the index
//! has as many connections and chunks as the bag header says. A truncated bag is an error
//! naming the file and the byte where it is cut, and how many whole chunks precede the cut:
//! no caller silently gets half a log. (Those whole chunks are not decoded: the `rosbag`
//! crate only reads a bag whose index position lies inside the file.)
//!
//! Reading messages checks in turn that each message's connection is in the index and that
//! each connection read has as many messages as the index counts for it.

use crate::FormatError;
use rosbag::record_types::Chunk;
use rosbag::{ChunkRecord, IndexRecord, MessageRecord, RosBag};
use std::collections::HashMap;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// The first line of a ROS 1 bag.
pub const MAGIC: &[u8] = b"#ROSBAG V2.0\n";

/// The largest uncompressed chunk read (256 MiB). ROS 1 writes chunks of 768 KiB by default
/// and exceeds that only by its last message; a larger size is a damaged header.
pub const MAX_CHUNK_BYTES: u32 = 256 << 20;

const OP_MESSAGE_DATA: u8 = 0x02;
const OP_BAG_HEADER: u8 = 0x03;
const OP_INDEX_DATA: u8 = 0x04;
const OP_CHUNK: u8 = 0x05;
const OP_CHUNK_INFO: u8 = 0x06;
const OP_CONNECTION: u8 = 0x07;

/// A connection (a publisher's topic) of a bag, with its message count from the index.
#[derive(Debug, Clone, PartialEq)]
pub struct Connection {
    pub id: u32,
    pub topic: String,
    /// The ROS 1 type name, `pkg/Type`.
    pub msg_type: String,
    /// The type's MD5 sum, 32 lowercase hex digits.
    pub md5sum: String,
    pub message_definition: String,
    pub caller_id: String,
    pub latching: bool,
    pub count: u64,
}

/// One message: its connection's index in [`Ros1Bag::connections`], its receive time and its
/// ROS 1 serialized bytes.
#[derive(Debug, Clone, PartialEq)]
pub struct Ros1Message {
    pub connection: usize,
    pub time_ns: u64,
    pub time: f64,
    pub data: Vec<u8>,
}

/// An opened ROS 1 bag, its structure and index checked.
pub struct Ros1Bag {
    path: PathBuf,
    bag: RosBag,
    connections: Vec<Connection>,
    /// Connection id -> index in `connections`.
    by_id: HashMap<u32, usize>,
    /// Each chunk's file offset and (connection id, message count) entries, from the index.
    chunks: Vec<ChunkEntry>,
}

/// A chunk as the index describes it.
#[derive(Debug, Clone)]
struct ChunkEntry {
    pos: u64,
    counts: Vec<(u32, u32)>,
}

impl std::fmt::Debug for Ros1Bag {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ros1Bag")
            .field("path", &self.path)
            .field("connections", &self.connections)
            .finish_non_exhaustive()
    }
}

/// Seconds of a nanosecond time, as a header stamp is computed (whole seconds plus scaled
/// nanoseconds), so that equal times give bit-identical values.
pub fn seconds(ns: u64) -> f64 {
    (ns / 1_000_000_000) as f64 + (ns % 1_000_000_000) as f64 * 1e-9
}

impl Ros1Bag {
    /// Opens the bag at `path`: checks its structure, then reads its index.
    pub fn open(path: &Path) -> Result<Ros1Bag, FormatError> {
        let file = std::fs::File::open(path).map_err(|e| FormatError::io(path, e))?;
        let len = file.metadata().map_err(|e| FormatError::io(path, e))?.len();
        let layout = scan(&mut BufReader::new(file), len)
            .map_err(|(field, msg)| FormatError::field(path, field, msg))?;
        let bag = RosBag::new(path).map_err(|e| FormatError::io(path, e))?;
        let (connections, by_id, chunks) = read_index(&bag, &layout, path)?;
        Ok(Ros1Bag {
            path: path.to_path_buf(),
            bag,
            connections,
            by_id,
            chunks,
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Every connection, ordered by id.
    pub fn connections(&self) -> &[Connection] {
        &self.connections
    }

    /// Calls `f` with each message of the connections on `topics`, in file order, with the
    /// bytes borrowed from the decompressed chunk; then checks that every such connection had
    /// as many messages as the index counts.
    ///
    /// Only the chunks the index says hold such messages are decompressed (a latched topic
    /// costs one chunk, not the bag), and on a machine with more than one core a second
    /// thread decompresses every other chunk (bz2 decompression is most of the time).
    pub fn for_each_message(
        &self,
        topics: &[&str],
        mut f: impl FnMut(&Connection, u64, &[u8]) -> Result<(), FormatError>,
    ) -> Result<(), FormatError> {
        let wanted: Vec<bool> = self
            .connections
            .iter()
            .map(|c| topics.contains(&c.topic.as_str()))
            .collect();
        let wanted_id = |id: u32| self.by_id.get(&id).is_some_and(|&i| wanted[i]);
        let todo: Vec<u64> = self
            .chunks
            .iter()
            .filter(|c| c.counts.iter().any(|&(id, n)| n > 0 && wanted_id(id)))
            .map(|c| c.pos)
            .collect();
        let mut counts = vec![0u64; self.connections.len()];
        let mut take = |at: u64, chunk: Chunk<'_>| -> Result<(), FormatError> {
            for m in chunk.messages() {
                let MessageRecord::MessageData(m) = m.map_err(|e| {
                    FormatError::field(
                        &self.path,
                        format!("chunk at byte {at}"),
                        format!("a record in it is damaged: {e}"),
                    )
                })?
                else {
                    continue;
                };
                let Some(&i) = self.by_id.get(&m.conn_id) else {
                    return Err(FormatError::field(
                        &self.path,
                        format!("chunk at byte {at}"),
                        format!(
                            "holds a message on connection {}, which the index does not define",
                            m.conn_id
                        ),
                    ));
                };
                if wanted[i] {
                    counts[i] += 1;
                    f(&self.connections[i], m.time, m.data)?;
                }
            }
            Ok(())
        };
        let parallel =
            todo.len() > 1 && std::thread::available_parallelism().is_ok_and(|n| n.get() > 1);
        std::thread::scope(|scope| -> Result<(), FormatError> {
            // The helper decompresses the odd-numbered chunks, in order, a few ahead.
            let (tx, rx) = std::sync::mpsc::sync_channel(2);
            if parallel {
                let odd: Vec<u64> = todo.iter().skip(1).step_by(2).copied().collect();
                scope.spawn(move || {
                    for at in odd {
                        // A closed channel: the reader stopped at an error.
                        if tx.send(self.read_chunk(at)).is_err() {
                            break;
                        }
                    }
                });
            } else {
                drop(tx);
            }
            for (k, &at) in todo.iter().enumerate() {
                let chunk = if parallel && k % 2 == 1 {
                    rx.recv().map_err(|_| {
                        FormatError::field(
                            &self.path,
                            format!("chunk at byte {at}"),
                            "the decompressing thread stopped",
                        )
                    })??
                } else {
                    self.read_chunk(at)?
                };
                take(at, chunk)?;
            }
            Ok(())
        })?;
        for (i, c) in self.connections.iter().enumerate() {
            if wanted[i] && counts[i] != c.count {
                return Err(FormatError::field(
                    &self.path,
                    format!("topic {} (connection {})", c.topic, c.id),
                    format!(
                        "the index counts {} messages, the chunks hold {}: the bag is damaged",
                        c.count, counts[i]
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The chunk record at `at` (a position the structure walk and the index agree on),
    /// decompressed.
    fn read_chunk(&self, at: u64) -> Result<Chunk<'_>, FormatError> {
        let err = |msg: String| FormatError::field(&self.path, format!("chunk at byte {at}"), msg);
        let mut records = self.bag.chunk_records();
        records.seek(at).map_err(|e| err(e.to_string()))?;
        match records.next() {
            Some(Ok(ChunkRecord::Chunk(c))) => Ok(c),
            Some(Ok(_)) => Err(err("is not a chunk record".into())),
            Some(Err(e)) => Err(err(format!("cannot be read: {e}"))),
            None => Err(err("is missing".into())),
        }
    }

    /// The messages on `topics`, in time order (receive time; a stable sort, so messages of
    /// equal time keep the file's order).
    pub fn messages(&self, topics: &[&str]) -> Result<Vec<Ros1Message>, FormatError> {
        let mut out = Vec::new();
        self.for_each_message(topics, |c, time_ns, data| {
            out.push(Ros1Message {
                connection: self.by_id.get(&c.id).copied().unwrap_or(0),
                time_ns,
                time: seconds(time_ns),
                data: data.to_vec(),
            });
            Ok(())
        })?;
        out.sort_by_key(|m| m.time_ns);
        Ok(out)
    }
}

/// Where the records of a bag lie, as [`scan`] found them.
#[derive(Debug, Default)]
struct Layout {
    conn_count: u32,
    chunk_count: u32,
    /// Offsets of the chunk records only.
    chunks: Vec<u64>,
    /// Offsets of the index section's records.
    index: Vec<u64>,
}

/// An error of the structure walk: (field, message).
type ScanError = (String, String);

/// One top-level record's header fields, and where its data lies.
struct RecordHead {
    op: u8,
    fields: Vec<(String, Vec<u8>)>,
    /// Where the record ends (its data's end).
    end: u64,
}

impl RecordHead {
    fn field(&self, name: &str) -> Option<&[u8]> {
        self.fields
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }
}

/// The largest record header read (1 MiB): headers hold a few short fields; a connection's
/// message definition is in its data, not its header.
const MAX_HEADER_BYTES: u32 = 1 << 20;

fn read_u32(r: &mut impl Read) -> std::io::Result<u32> {
    let mut b = [0u8; 4];
    r.read_exact(&mut b)?;
    Ok(u32::from_le_bytes(b))
}

/// The `name=value` fields of a record header.
fn parse_fields(mut h: &[u8]) -> Result<Vec<(String, Vec<u8>)>, String> {
    let mut fields = Vec::new();
    while !h.is_empty() {
        let Some((len, rest)) = h.split_first_chunk::<4>() else {
            return Err("a header field's length is cut short".into());
        };
        let n = u32::from_le_bytes(*len) as usize;
        let Some(field) = rest.get(..n) else {
            return Err(format!("a header field of {n} bytes runs past the header"));
        };
        let Some(eq) = field.iter().position(|&b| b == b'=') else {
            return Err("a header field has no '='".into());
        };
        let name = std::str::from_utf8(&field[..eq])
            .map_err(|_| "a header field's name is not text".to_string())?;
        fields.push((name.to_string(), field[eq + 1..].to_vec()));
        h = &rest[n..];
    }
    Ok(fields)
}

/// Reads the record at `at` (the reader positioned there), checking it ends by `limit`.
fn read_record<R: Read + Seek>(r: &mut R, at: u64, limit: u64) -> Result<RecordHead, String> {
    let cut = |what: &str| format!("is cut short in its {what} (the file ends at byte {limit})");
    if at + 4 > limit {
        return Err(cut("header length"));
    }
    let hlen = read_u32(r).map_err(|_| cut("header length"))?;
    if hlen > MAX_HEADER_BYTES {
        return Err(format!(
            "claims a header of {hlen} bytes: the file is damaged"
        ));
    }
    if at + 4 + u64::from(hlen) + 4 > limit {
        return Err(cut("header"));
    }
    let mut header = vec![0u8; hlen as usize];
    r.read_exact(&mut header).map_err(|_| cut("header"))?;
    let fields = parse_fields(&header).map_err(|e| format!("has a damaged header: {e}"))?;
    let op = match fields.iter().find(|(n, _)| n == "op") {
        Some((_, v)) if v.len() == 1 => v[0],
        _ => return Err("has no valid op field in its header".into()),
    };
    let data_len = u64::from(read_u32(r).map_err(|_| cut("data length"))?);
    let end = at + 4 + u64::from(hlen) + 4 + data_len;
    if end > limit {
        return Err(format!(
            "claims {data_len} bytes of data, which run past the end of the file at byte {limit}"
        ));
    }
    r.seek(SeekFrom::Start(end))
        .map_err(|e| format!("cannot be skipped: {e}"))?;
    Ok(RecordHead { op, fields, end })
}

fn u32_field(h: &RecordHead, name: &str) -> Result<u32, String> {
    match h.field(name) {
        Some(v) if v.len() == 4 => Ok(u32::from_le_bytes([v[0], v[1], v[2], v[3]])),
        _ => Err(format!("has no valid {name} field")),
    }
}

fn u64_field(h: &RecordHead, name: &str) -> Result<u64, String> {
    match h.field(name).and_then(|v| <[u8; 8]>::try_from(v).ok()) {
        Some(b) => Ok(u64::from_le_bytes(b)),
        None => Err(format!("has no valid {name} field")),
    }
}

/// Checks a chunk record's header before the `rosbag` crate decompresses it.
fn check_chunk(h: &RecordHead) -> Result<(), String> {
    let size = u32_field(h, "size")?;
    if size > MAX_CHUNK_BYTES {
        return Err(format!(
            "claims an uncompressed size of {size} bytes, more than the limit of {MAX_CHUNK_BYTES} (MAX_CHUNK_BYTES): the header is damaged"
        ));
    }
    match h.field("compression") {
        Some(b"none") | Some(b"bz2") | Some(b"lz4") => Ok(()),
        Some(other) => Err(format!(
            "uses compression {:?}; only bz2, lz4 and none are read",
            String::from_utf8_lossy(other)
        )),
        None => Err("has no compression field".into()),
    }
}

fn op_name(op: u8) -> &'static str {
    match op {
        OP_MESSAGE_DATA => "message data",
        OP_BAG_HEADER => "bag header",
        OP_INDEX_DATA => "index data",
        OP_CHUNK => "chunk",
        OP_CHUNK_INFO => "chunk info",
        OP_CONNECTION => "connection",
        _ => "unknown",
    }
}

/// Walks every top-level record of a bag of `len` bytes (headers only).
fn scan<R: Read + Seek>(r: &mut R, len: u64) -> Result<Layout, ScanError> {
    let err = |field: String, msg: String| (field, msg);
    let mut magic = [0u8; MAGIC.len()];
    if r.read_exact(&mut magic).is_err() || magic != MAGIC {
        return Err(err(
            "file".into(),
            "not a ROS 1 bag (version 2.0): it does not start with \"#ROSBAG V2.0\"".into(),
        ));
    }
    let start = MAGIC.len() as u64;
    let head = read_record(r, start, len)
        .map_err(|e| err(format!("bag header record at byte {start}"), e))?;
    if head.op != OP_BAG_HEADER {
        return Err(err(
            format!("record at byte {start}"),
            format!("is a {} record, not the bag header", op_name(head.op)),
        ));
    }
    let field = |e: String| err("bag header".into(), e);
    let index_pos = u64_field(&head, "index_pos").map_err(field)?;
    let mut layout = Layout {
        conn_count: u32_field(&head, "conn_count").map_err(field)?,
        chunk_count: u32_field(&head, "chunk_count").map_err(field)?,
        ..Layout::default()
    };

    // The chunk section: up to the index, or when the index lies beyond the file's end (or
    // was never written), as far as the records are whole, to say where the bag is cut.
    let indexed = index_pos != 0 && index_pos <= len && index_pos >= head.end;
    let limit = if indexed { index_pos } else { len };
    let mut at = head.end;
    while at < limit {
        let rec = match read_record(r, at, limit) {
            Ok(rec) => rec,
            Err(e) if !indexed => return Err(truncated(index_pos, len, at, &layout, e)),
            Err(e) => return Err(err(format!("record at byte {at}"), e)),
        };
        let place = format!("{} record at byte {at}", op_name(rec.op));
        match rec.op {
            OP_CHUNK => {
                check_chunk(&rec).map_err(|e| err(place, e))?;
                layout.chunks.push(at);
            }
            OP_INDEX_DATA => {}
            // An index the header does not point to: where the chunk section ends.
            OP_CONNECTION | OP_CHUNK_INFO if !indexed => break,
            _ => return Err(err(place, "does not belong in the chunk section".into())),
        }
        at = rec.end;
    }
    if !indexed {
        return Err(truncated(index_pos, len, at, &layout, String::new()));
    }

    while at < len {
        let rec = read_record(r, at, len).map_err(|e| {
            err(
                format!("index record at byte {at}"),
                format!("{e}: the bag is truncated or damaged"),
            )
        })?;
        if !matches!(rec.op, OP_CONNECTION | OP_CHUNK_INFO) {
            return Err(err(
                format!("{} record at byte {at}", op_name(rec.op)),
                "does not belong in the index section".into(),
            ));
        }
        layout.index.push(at);
        at = rec.end;
    }
    Ok(layout)
}

/// The error for a bag whose index is missing: where it is cut and what precedes the cut.
fn truncated(index_pos: u64, len: u64, at: u64, layout: &Layout, why: String) -> ScanError {
    let whole = layout.chunks.len();
    let of = layout.chunk_count;
    let what = if index_pos == 0 {
        "has no index (the recording was not closed; `rosbag reindex` rebuilds it)".to_string()
    } else {
        format!(
            "is truncated: it has {len} bytes, but its header puts the index at byte {index_pos}"
        )
    };
    let cut = if why.is_empty() {
        format!("the chunk section ends at byte {at}")
    } else {
        format!("the record at byte {at} {why}")
    };
    (
        "file".into(),
        format!(
            "{what}; {cut}, after {whole} whole chunks (of {of} the header counts); the bag is not read"
        ),
    )
}

/// The connections (ordered by id), connection id -> position among them, and the chunks.
type Index = (Vec<Connection>, HashMap<u32, usize>, Vec<ChunkEntry>);

/// The connections from the index, with their message counts, checked against the bag
/// header and the chunk section.
fn read_index(bag: &RosBag, layout: &Layout, path: &Path) -> Result<Index, FormatError> {
    let mut connections: Vec<Connection> = Vec::new();
    let mut counts: HashMap<u32, u64> = HashMap::new();
    let mut chunks: Vec<ChunkEntry> = Vec::new();
    for (k, record) in bag.index_records().enumerate() {
        let at = layout.index.get(k).copied().unwrap_or(0);
        let record = record.map_err(|e| {
            FormatError::field(path, format!("index record at byte {at}"), e.to_string())
        })?;
        match record {
            IndexRecord::Connection(c) => {
                if connections.iter().any(|o| o.id == c.id) {
                    continue; // written once per chunk section and index by some tools
                }
                connections.push(Connection {
                    id: c.id,
                    topic: c.storage_topic.to_string(),
                    msg_type: c.tp.to_string(),
                    md5sum: c.md5sum.iter().map(|b| format!("{b:02x}")).collect(),
                    message_definition: c.message_definition.to_string(),
                    caller_id: c.caller_id.to_string(),
                    latching: c.latching,
                    count: 0,
                });
            }
            IndexRecord::ChunkInfo(info) => {
                let entries: Vec<(u32, u32)> =
                    info.entries().map(|e| (e.conn_id, e.count)).collect();
                for &(id, n) in &entries {
                    *counts.entry(id).or_default() += u64::from(n);
                }
                chunks.push(ChunkEntry {
                    pos: info.chunk_pos,
                    counts: entries,
                });
            }
            IndexRecord::IndexData(_) => {}
        }
    }
    let bad = |msg: String| Err(FormatError::field(path, "index", msg));
    if connections.len() != layout.conn_count as usize {
        return bad(format!(
            "holds {} connections, the bag header counts {}: the bag is damaged",
            connections.len(),
            layout.conn_count
        ));
    }
    if chunks.len() != layout.chunk_count as usize || layout.chunks.len() != chunks.len() {
        return bad(format!(
            "describes {} chunks, the bag header counts {} and the file holds {}: the bag is damaged",
            chunks.len(),
            layout.chunk_count,
            layout.chunks.len()
        ));
    }
    if let Some((p, c)) = chunks
        .iter()
        .map(|c| c.pos)
        .zip(layout.chunks.iter().copied())
        .find(|(p, c)| p != c)
    {
        return bad(format!(
            "puts a chunk at byte {p}, but the file's chunk is at byte {c}: the bag is damaged"
        ));
    }
    connections.sort_by_key(|c| c.id);
    let mut by_id = HashMap::new();
    for (i, c) in connections.iter_mut().enumerate() {
        c.count = counts.remove(&c.id).unwrap_or(0);
        by_id.insert(c.id, i);
    }
    if let Some(id) = counts.keys().next() {
        return bad(format!(
            "counts messages on connection {id}, which it does not define: the bag is damaged"
        ));
    }
    Ok((connections, by_id, chunks))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../datasets")
            .join(name)
    }

    fn field(name: &str, value: &[u8]) -> Vec<u8> {
        let mut f = ((name.len() + 1 + value.len()) as u32)
            .to_le_bytes()
            .to_vec();
        f.extend(name.as_bytes());
        f.push(b'=');
        f.extend(value);
        f
    }

    fn record(fields: &[Vec<u8>], data: &[u8]) -> Vec<u8> {
        let header: Vec<u8> = fields.concat();
        let mut r = (header.len() as u32).to_le_bytes().to_vec();
        r.extend(header);
        r.extend((data.len() as u32).to_le_bytes());
        r.extend(data);
        r
    }

    fn time(ns: u64) -> Vec<u8> {
        let mut t = ((ns / 1_000_000_000) as u32).to_le_bytes().to_vec();
        t.extend(((ns % 1_000_000_000) as u32).to_le_bytes());
        t
    }

    fn connection(id: u32, topic: &str) -> Vec<u8> {
        let data = [
            field("topic", topic.as_bytes()),
            field("type", b"std_msgs/String"),
            field("md5sum", b"992ce8a1687cec8c8bd883ec73ca41d1"),
            field("message_definition", b"string data\n"),
        ]
        .concat();
        record(
            &[
                field("op", &[OP_CONNECTION]),
                field("conn", &id.to_le_bytes()),
                field("topic", topic.as_bytes()),
            ],
            &data,
        )
    }

    /// A bag with one chunk holding `messages` (connection, time ns, bytes) on connections
    /// 0 ("/a") and 1 ("/b").
    fn bag(messages: &[(u32, u64, &[u8])]) -> Vec<u8> {
        let mut chunk = connection(0, "/a");
        chunk.extend(connection(1, "/b"));
        for (c, t, d) in messages {
            chunk.extend(record(
                &[
                    field("op", &[OP_MESSAGE_DATA]),
                    field("conn", &c.to_le_bytes()),
                    field("time", &time(*t)),
                ],
                d,
            ));
        }
        let header_len = 4096;
        let chunk_at = (MAGIC.len() + header_len) as u64;
        let chunk_rec = record(
            &[
                field("op", &[OP_CHUNK]),
                field("compression", b"none"),
                field("size", &(chunk.len() as u32).to_le_bytes()),
            ],
            &chunk,
        );
        let index_pos = chunk_at + chunk_rec.len() as u64;
        let mut counts = [0u32; 2];
        for (c, _, _) in messages {
            counts[*c as usize] += 1;
        }
        let mut entries = Vec::new();
        for (c, n) in counts.iter().enumerate() {
            entries.extend((c as u32).to_le_bytes());
            entries.extend(n.to_le_bytes());
        }
        let info = record(
            &[
                field("op", &[OP_CHUNK_INFO]),
                field("ver", &1u32.to_le_bytes()),
                field("chunk_pos", &chunk_at.to_le_bytes()),
                field("start_time", &time(0)),
                field("end_time", &time(0)),
                field("count", &2u32.to_le_bytes()),
            ],
            &entries,
        );
        let head_fields = [
            field("op", &[OP_BAG_HEADER]),
            field("index_pos", &index_pos.to_le_bytes()),
            field("conn_count", &2u32.to_le_bytes()),
            field("chunk_count", &1u32.to_le_bytes()),
        ];
        let head_len: usize = head_fields.iter().map(Vec::len).sum::<usize>() + 8;
        let head = record(&head_fields, &vec![b' '; header_len - head_len]);
        let mut out = MAGIC.to_vec();
        out.extend(head);
        assert_eq!(out.len() as u64, chunk_at);
        out.extend(chunk_rec);
        out.extend(connection(0, "/a"));
        out.extend(connection(1, "/b"));
        out.extend(info);
        out
    }

    fn scratch(name: &str) -> PathBuf {
        std::env::temp_dir().join(format!("atrium-ros1-{}-{name}.bag", std::process::id()))
    }

    /// Opens `bytes` written to a scratch file and reads every topic.
    fn read_bytes(name: &str, bytes: &[u8]) -> Result<usize, FormatError> {
        let p = scratch(name);
        std::fs::write(&p, bytes).unwrap();
        let r = Ros1Bag::open(&p).and_then(|b| {
            let topics: Vec<String> = b.connections().iter().map(|c| c.topic.clone()).collect();
            let topics: Vec<&str> = topics.iter().map(String::as_str).collect();
            b.messages(&topics).map(|m| m.len())
        });
        std::fs::remove_file(&p).unwrap();
        r
    }

    #[test]
    fn a_hand_written_bag_reads_back_in_time_order() {
        let bytes = bag(&[
            (0, 3_000_000_000, b"x"),
            (1, 1_500_000_000, b"yy"),
            (0, 2, b""),
        ]);
        let p = scratch("small");
        std::fs::write(&p, &bytes).unwrap();
        let b = Ros1Bag::open(&p).unwrap();
        assert_eq!(b.connections().len(), 2);
        let a = &b.connections()[0];
        assert_eq!(
            (a.topic.as_str(), a.msg_type.as_str(), a.count),
            ("/a", "std_msgs/String", 2)
        );
        assert_eq!(a.md5sum, "992ce8a1687cec8c8bd883ec73ca41d1");
        let m = b.messages(&["/a", "/b"]).unwrap();
        let times: Vec<u64> = m.iter().map(|m| m.time_ns).collect();
        assert_eq!(times, vec![2, 1_500_000_000, 3_000_000_000]);
        assert_eq!(
            (m[1].connection, m[1].data.as_slice(), m[1].time),
            (1, &b"yy"[..], 1.5)
        );
        assert_eq!(b.messages(&["/b"]).unwrap().len(), 1);
        std::fs::remove_file(&p).unwrap();
    }

    #[test]
    fn damaged_hand_written_bags_are_errors_naming_the_byte() {
        let good = bag(&[(0, 1, b"abc"), (1, 2, b"de")]);
        assert_eq!(read_bytes("good", &good).unwrap(), 2);
        // Every cut: the header, the chunk, the index.
        for n in 0..good.len() {
            let e = read_bytes("cut", &good[..n]).unwrap_err().to_string();
            assert!(e.contains(".bag: "), "cut at {n}: {e}");
        }
        let e = read_bytes("cut", &good[..4200]).unwrap_err().to_string();
        assert!(
            e.contains("is truncated: it has 4200 bytes, but its header puts the index at byte"),
            "{e}"
        );
        // Not indexed (index_pos 0).
        let mut b = good.clone();
        let at = b.windows(10).position(|w| w == b"index_pos=").unwrap() + 10;
        b[at..at + 8].fill(0);
        let e = read_bytes("unindexed", &b).unwrap_err().to_string();
        assert!(
            e.contains("has no index") && e.contains("after 1 whole chunks"),
            "{e}"
        );
        // A chunk claiming 4 GiB uncompressed.
        let mut b = good.clone();
        let at = b.windows(5).position(|w| w == b"size=").unwrap() + 5;
        b[at..at + 4].fill(0xff);
        let e = read_bytes("huge", &b).unwrap_err().to_string();
        assert!(
            e.contains("chunk record at byte 4109: claims an uncompressed size"),
            "{e}"
        );
        // Every single byte flipped: an error or the same messages, never a panic.
        for i in 0..good.len() {
            let mut b = good.clone();
            b[i] ^= 0x41;
            if let Ok(n) = read_bytes("flip", &b) {
                assert!(n <= 2, "byte {i}");
            }
        }
    }

    #[test]
    fn the_bundled_bags_are_read_and_their_damage_is_caught() {
        for (name, chunks) in [
            ("fr079/fr079.orig.bag", "bz2"),
            ("fixtures/fr079_head_lz4.bag", "lz4"),
        ] {
            let path = data(name);
            let good = std::fs::read(&path).unwrap();
            let b = Ros1Bag::open(&path).unwrap();
            let topics: Vec<&str> = b.connections().iter().map(|c| c.topic.as_str()).collect();
            let n = b.messages(&topics).unwrap().len();
            let total: u64 = b.connections().iter().map(|c| c.count).sum();
            assert_eq!(n as u64, total, "{name}");
            assert!(
                good.windows(15)
                    .any(|w| w == format!("compression={chunks}").as_bytes()),
                "{name}"
            );
            let len = good.len();
            for cut in [
                0,
                13,
                100,
                4200,
                len / 3,
                len / 2,
                len - 5000,
                len - 10,
                len - 1,
            ] {
                let e = read_bytes("real-cut", &good[..cut]);
                assert!(e.is_err(), "{name} cut at {cut}");
            }
            for k in [4200, len / 4, len / 2, 3 * len / 4, len - 2000] {
                let mut b = good.clone();
                for x in &mut b[k..k + 16] {
                    *x ^= 0xa5;
                }
                if let Ok(n2) = read_bytes("real-flip", &b) {
                    assert_eq!(n2, n, "{name} flipped at {k}");
                }
            }
        }
    }
}
