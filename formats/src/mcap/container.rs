//! The MCAP container read with every check its format allows before a byte of it is
//! trusted: a recording copied between machines may have flipped bits, a cut tail or a
//! length field that claims terabytes, and each of these must end in an error naming the
//! file and the offset, never in an abort, a hang or silently wrong readings.
//!
//! - Every length is checked against the bytes that remain (of the file, or of the chunk it
//!   lies in) before anything is read or allocated; a chunk's uncompressed size also against
//!   [`MAX_CHUNK_BYTES`], and decompression never produces more than the size a chunk states,
//!   so memory grows with the data actually there, not with what a header claims.
//! - Chunk CRCs are checked on the whole decompressed chunk before any of its records is
//!   handed out, and the data-section and summary-section CRCs when those records are
//!   reached. The official Python reader (`make_reader(validate_crcs=True)`, what CI runs)
//!   checks chunk CRCs, and its streaming reader the data-section CRC too; a stored CRC of 0
//!   means "not computed" there and here.
//! - Chunks compressed with zstd (what Atrium and most writers use), lz4 (the LZ4 frame
//!   format, rosbag2's other choice) or uncompressed are read.
//! - Records are parsed here too, every string and map length checked against the record's
//!   own length: the `mcap` crate's parser (through `binrw`) reserves a string's stated
//!   length before reading it, so one damaged length prefix asks for up to 4 GiB. Only the
//!   records a reader of recordings uses are parsed (header, schema, channel, message,
//!   metadata, data end, footer); index, statistics and attachment records are skipped
//!   unread (their bytes are covered by the data-section or summary CRC).
//!
//! The `mcap` crate's in-memory readers check none of the CRCs by default and bound no
//! length inside a chunk (a record inside a chunk claiming 2^60 bytes aborts the process
//! with a failed allocation), hence this reader.

use crate::FormatError;
use mcap::records::{self, op, Record};
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};

/// The largest uncompressed chunk read, in bytes (256 MiB). One chunk is held decompressed
/// at a time. Writers aim at much smaller chunks (Atrium and the `mcap` crate 1 MiB, the
/// mcap CLI and ROS 2 4 MiB); a chunk exceeds its writer's target only by its last message,
/// and the largest messages one meets are raw camera images (a 4K RGBA frame is 33 MiB), so
/// a larger size is a damaged header, not data.
pub const MAX_CHUNK_BYTES: u64 = 256 << 20;

/// Opcode and length in front of every record.
const RECORD_HEADER: usize = 1 + 8;
/// A footer's summary start and summary offset start: what its summary CRC covers.
const FOOTER_CRC_FIELDS: usize = 16;

/// Where a record lies: its byte offset in the file, or for a record inside a chunk, the
/// chunk's offset in the file and the record's offset among the chunk's uncompressed
/// records.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Place {
    File(u64),
    Chunk { chunk: u64, offset: u64 },
}

impl Place {
    /// "chunk record at byte 41", "message record at byte 9 of the chunk at byte 41".
    fn of(self, opcode: u8) -> String {
        format!("{} {self}", op_name(opcode))
    }
}

impl std::fmt::Display for Place {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Place::File(at) => write!(f, "record at byte {at}"),
            Place::Chunk { chunk, offset } => {
                write!(f, "record at byte {offset} of the chunk at byte {chunk}")
            }
        }
    }
}

fn op_name(opcode: u8) -> &'static str {
    match opcode {
        op::HEADER => "header",
        op::FOOTER => "footer",
        op::SCHEMA => "schema",
        op::CHANNEL => "channel",
        op::MESSAGE => "message",
        op::CHUNK => "chunk",
        op::MESSAGE_INDEX => "message index",
        op::CHUNK_INDEX => "chunk index",
        op::ATTACHMENT => "attachment",
        op::ATTACHMENT_INDEX => "attachment index",
        op::STATISTICS => "statistics",
        op::METADATA => "metadata",
        op::METADATA_INDEX => "metadata index",
        op::SUMMARY_OFFSET => "summary offset",
        op::DATA_END => "data end",
        _ => "unknown",
    }
}

/// Little-endian fields of one record body, every read checked against its end.
struct Fields<'b> {
    buf: &'b [u8],
    pos: usize,
    /// Where `buf` starts in the record (a map's entries are read from a sub-slice), and
    /// the record's length, for error messages.
    base: usize,
    record_len: usize,
}

impl<'b> Fields<'b> {
    fn new(buf: &'b [u8]) -> Self {
        Fields {
            buf,
            pos: 0,
            base: 0,
            record_len: buf.len(),
        }
    }

    fn take(&mut self, n: u64, what: &str) -> Result<&'b [u8], String> {
        self.take_from(self.pos, n, what)
    }

    /// `n` bytes from here, for a field that started at `field` (its length prefix).
    fn take_from(&mut self, field: usize, n: u64, what: &str) -> Result<&'b [u8], String> {
        let left = self.buf.len() - self.pos;
        if n > left as u64 {
            return Err(format!(
                "its {what} of {n} bytes at byte {} runs past the record's end ({} bytes)",
                self.base + field,
                self.record_len
            ));
        }
        let b = &self.buf[self.pos..self.pos + n as usize];
        self.pos += n as usize;
        Ok(b)
    }

    fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N], String> {
        let b = self.take(N as u64, what)?;
        Ok(b.try_into().expect("take gives N bytes"))
    }

    fn u16(&mut self, what: &str) -> Result<u16, String> {
        self.array(what).map(u16::from_le_bytes)
    }

    fn u32(&mut self, what: &str) -> Result<u32, String> {
        self.array(what).map(u32::from_le_bytes)
    }

    fn u64(&mut self, what: &str) -> Result<u64, String> {
        self.array(what).map(u64::from_le_bytes)
    }

    fn string(&mut self, what: &str) -> Result<String, String> {
        let field = self.pos;
        let n = self.u32(what)?;
        let b = self.take_from(field, u64::from(n), what)?;
        String::from_utf8(b.to_vec()).map_err(|_| format!("its {what} is not UTF-8"))
    }

    /// A map of strings, its length in bytes first.
    fn map(&mut self, what: &str) -> Result<BTreeMap<String, String>, String> {
        let field = self.pos;
        let n = self.u32(what)?;
        let entries = self.take_from(field, u64::from(n), what)?;
        let mut inner = Fields {
            buf: entries,
            pos: 0,
            base: self.base + self.pos - entries.len(),
            record_len: self.record_len,
        };
        let mut map = BTreeMap::new();
        while inner.pos < inner.buf.len() {
            let k = inner.string(what)?;
            let v = inner.string(what)?;
            if map.contains_key(&k) {
                return Err(format!("its {what} has the key {k:?} twice"));
            }
            map.insert(k, v);
        }
        Ok(map)
    }

    fn rest(&mut self) -> &'b [u8] {
        let b = &self.buf[self.pos..];
        self.pos = self.buf.len();
        b
    }
}

/// The record with `opcode` and `body`, or `None` for a kind this reader skips.
fn parse(opcode: u8, body: &[u8]) -> Result<Option<Record<'_>>, String> {
    let mut f = Fields::new(body);
    Ok(Some(match opcode {
        op::HEADER => Record::Header(records::Header {
            profile: f.string("profile")?,
            library: f.string("library")?,
        }),
        op::SCHEMA => {
            let header = records::SchemaHeader {
                id: f.u16("id")?,
                name: f.string("name")?,
                encoding: f.string("encoding")?,
            };
            let field = f.pos;
            let n = f.u32("data")?;
            let data = Cow::Borrowed(f.take_from(field, u64::from(n), "data")?);
            Record::Schema { header, data }
        }
        op::CHANNEL => Record::Channel(records::Channel {
            id: f.u16("id")?,
            schema_id: f.u16("schema id")?,
            topic: f.string("topic")?,
            message_encoding: f.string("message encoding")?,
            metadata: f.map("metadata")?,
        }),
        op::MESSAGE => Record::Message {
            header: records::MessageHeader {
                channel_id: f.u16("channel id")?,
                sequence: f.u32("sequence")?,
                log_time: f.u64("log time")?,
                publish_time: f.u64("publish time")?,
            },
            data: Cow::Borrowed(f.rest()),
        },
        op::METADATA => Record::Metadata(records::Metadata {
            name: f.string("name")?,
            metadata: f.map("metadata")?,
        }),
        op::DATA_END => Record::DataEnd(records::DataEnd {
            data_section_crc: f.u32("data section CRC")?,
        }),
        op::FOOTER => Record::Footer(records::Footer {
            summary_start: f.u64("summary start")?,
            summary_offset_start: f.u64("summary offset start")?,
            summary_crc: f.u32("summary CRC")?,
        }),
        _ => return Ok(None),
    }))
}

/// A chunk record's header and its (compressed) records.
fn parse_chunk(body: &[u8]) -> Result<(records::ChunkHeader, &[u8]), String> {
    let mut f = Fields::new(body);
    let header = records::ChunkHeader {
        message_start_time: f.u64("start time")?,
        message_end_time: f.u64("end time")?,
        uncompressed_size: f.u64("uncompressed size")?,
        uncompressed_crc: f.u32("uncompressed CRC")?,
        compression: f.string("compression")?,
        compressed_size: f.u64("compressed size")?,
    };
    let data = f.take(header.compressed_size, "records")?;
    Ok((header, data))
}

/// A chunk's records, decompressed and checked.
struct OpenChunk<'a> {
    at: u64,
    data: Cow<'a, [u8]>,
    pos: usize,
}

/// The records of an MCAP file in file order, chunks unpacked (the chunk records themselves
/// are not handed out), each with its [`Place`]. Records from the file itself borrow from it,
/// records from compressed chunks own their bytes. The first error ends the iteration.
pub struct Records<'a> {
    path: PathBuf,
    bytes: &'a [u8],
    pos: usize,
    /// Where the footer's end magic starts.
    end: usize,
    chunk: Option<OpenChunk<'a>>,
    /// The data end record was read: every byte before it matched its CRC.
    data_end_seen: bool,
    footer_seen: bool,
    done: bool,
}

impl<'a> Records<'a> {
    /// Checks the magic bytes at both ends; the records are checked as they are read.
    pub fn new(bytes: &'a [u8], path: &Path) -> Result<Records<'a>, FormatError> {
        let magic = mcap::MAGIC.len();
        if !bytes.starts_with(mcap::MAGIC) {
            return Err(bad(
                path,
                "file",
                "not an MCAP file (it does not start with the MCAP magic bytes)",
            ));
        }
        if bytes.len() < 2 * magic || !bytes[magic..].ends_with(mcap::MAGIC) {
            return Err(bad(
                path,
                "file",
                "truncated MCAP file: it does not end with the footer's magic bytes (was the recording interrupted?)",
            ));
        }
        Ok(Records {
            path: path.to_path_buf(),
            bytes,
            pos: magic,
            end: bytes.len() - magic,
            chunk: None,
            data_end_seen: false,
            footer_seen: false,
            done: false,
        })
    }

    fn err(&self, place: impl std::fmt::Display, msg: impl Into<String>) -> FormatError {
        bad(&self.path, place.to_string(), msg)
    }

    /// The next record of the open chunk, if one is open and has records left.
    fn next_in_chunk(&mut self) -> Option<Result<(Place, Record<'a>), FormatError>> {
        loop {
            let chunk = self.chunk.as_mut()?;
            let (at, start) = (chunk.at, chunk.pos);
            let place = Place::Chunk {
                chunk: at,
                offset: start as u64,
            };
            let data: &[u8] = &chunk.data;
            if start == data.len() {
                self.chunk = None;
                return None;
            }
            let Some((opcode, len)) = record_header(&data[start..]) else {
                let left = data.len() - start;
                return Some(Err(self.err(
                    place,
                    format!("is cut short: {left} bytes are left in the chunk, a record header takes {RECORD_HEADER}"),
                )));
            };
            let left = (data.len() - start - RECORD_HEADER) as u64;
            if len > left {
                return Some(Err(self.err(
                    place.of(opcode),
                    format!("claims {len} bytes, but only {left} bytes remain in the chunk"),
                )));
            }
            let body = start + RECORD_HEADER..start + RECORD_HEADER + len as usize;
            chunk.pos = body.end;
            let parsed = match &chunk.data {
                // Uncompressed chunks are slices of the file: hand out borrowed records.
                Cow::Borrowed(b) => {
                    let b: &'a [u8] = b;
                    parse(opcode, &b[body])
                }
                Cow::Owned(v) => parse(opcode, &v[body]).map(|r| r.map(Record::into_owned)),
            };
            match parsed {
                Ok(Some(r)) => return Some(Ok((place, r))),
                Ok(None) => continue,
                Err(e) => {
                    return Some(Err(self.err(place.of(opcode), format!("is malformed: {e}"))))
                }
            }
        }
    }

    /// Decompresses and checks the chunk whose record body is `body`, at `at` in the file.
    fn open_chunk(&self, at: u64, body: &'a [u8]) -> Result<OpenChunk<'a>, FormatError> {
        let place = format!("chunk at byte {at}");
        let (header, data) =
            parse_chunk(body).map_err(|e| self.err(&place, format!("is malformed: {e}")))?;
        let size = header.uncompressed_size;
        if size > MAX_CHUNK_BYTES {
            return Err(self.err(
                &place,
                format!(
                    "claims an uncompressed size of {size} bytes, more than the limit of {MAX_CHUNK_BYTES} bytes (MAX_CHUNK_BYTES): the header is damaged"
                ),
            ));
        }
        let records: Cow<'a, [u8]> = match header.compression.as_str() {
            "" => Cow::Borrowed(data),
            "zstd" => {
                // Grows with what the data holds, never past the stated size (+1 to see
                // whether there is more): a damaged size costs no memory it does not need.
                let mut out = Vec::with_capacity(size.min(data.len() as u64 * 8 + 4096) as usize);
                zstd::stream::read::Decoder::with_buffer(data)
                    .and_then(|d| d.take(size + 1).read_to_end(&mut out))
                    .map_err(|e| {
                        self.err(
                            &place,
                            format!("cannot be decompressed (zstd): {e}: the file is damaged"),
                        )
                    })?;
                Cow::Owned(out)
            }
            "lz4" => {
                let mut out = Vec::with_capacity(size.min(data.len() as u64 * 8 + 4096) as usize);
                lz4_flex::frame::FrameDecoder::new(data)
                    .take(size + 1)
                    .read_to_end(&mut out)
                    .map_err(|e| {
                        self.err(
                            &place,
                            format!("cannot be decompressed (lz4): {e}: the file is damaged"),
                        )
                    })?;
                Cow::Owned(out)
            }
            other => {
                return Err(self.err(
                    &place,
                    format!(
                    "uses compression {other:?}; only zstd, lz4 and uncompressed chunks are read"
                ),
                ))
            }
        };
        if records.len() as u64 != size {
            let got = if records.len() as u64 > size {
                "more than that".to_string()
            } else {
                format!("{} bytes", records.len())
            };
            return Err(self.err(
                &place,
                format!("states an uncompressed size of {size} bytes, but its data holds {got}: the file is damaged"),
            ));
        }
        let stored = header.uncompressed_crc;
        if stored != 0 {
            let computed = crc32fast::hash(&records);
            if computed != stored {
                return Err(self.err(
                    &place,
                    format!(
                        "CRC mismatch: the chunk stores {stored:08x}, its records give {computed:08x}: the file is damaged"
                    ),
                ));
            }
        }
        Ok(OpenChunk {
            at,
            data: records,
            pos: 0,
        })
    }

    fn next_record(&mut self) -> Option<Result<(Place, Record<'a>), FormatError>> {
        loop {
            if let Some(r) = self.next_in_chunk() {
                return Some(r);
            }
            let at = self.pos;
            if at == self.end {
                if self.footer_seen {
                    return None;
                }
                return Some(Err(self.err(
                    "file",
                    "has no footer record: the file is truncated or damaged",
                )));
            }
            let place = Place::File(at as u64);
            let bytes: &'a [u8] = self.bytes;
            let Some((opcode, len)) = record_header(&bytes[at..self.end]) else {
                return Some(Err(self.err(
                    place,
                    format!(
                        "is cut short: {} bytes are left before the end magic, a record header takes {RECORD_HEADER}",
                        self.end - at
                    ),
                )));
            };
            let left = (self.end - at - RECORD_HEADER) as u64;
            if len > left {
                return Some(Err(self.err(
                    place.of(opcode),
                    format!(
                        "claims {len} bytes, but only {left} bytes remain before the end of the file ({} bytes)",
                        bytes.len()
                    ),
                )));
            }
            if self.footer_seen {
                return Some(Err(self.err(
                    place,
                    "follows the footer: the file has bytes after its last record",
                )));
            }
            let body = &bytes[at + RECORD_HEADER..at + RECORD_HEADER + len as usize];
            self.pos = at + RECORD_HEADER + len as usize;
            match opcode {
                op::CHUNK => match self.open_chunk(at as u64, body) {
                    Ok(c) => self.chunk = Some(c),
                    Err(e) => return Some(Err(e)),
                },
                op::DATA_END => {
                    let r = parse(opcode, body);
                    if let Ok(Some(Record::DataEnd(d))) = &r {
                        // The CRC of every byte before this record, magic included.
                        let computed = crc32fast::hash(&bytes[..at]);
                        let stored = d.data_section_crc;
                        if stored != 0 && stored != computed {
                            return Some(Err(self.err(
                                place.of(opcode),
                                format!(
                                    "data section CRC mismatch: the file stores {stored:08x}, the bytes before it give {computed:08x}: the file is damaged"
                                ),
                            )));
                        }
                    }
                    if self.data_end_seen {
                        return Some(Err(self.err(place.of(opcode), "is the second one")));
                    }
                    self.data_end_seen = true;
                    return Some(self.parsed(place, opcode, r));
                }
                op::FOOTER => {
                    // Without the data end record the data section's CRC was never checked
                    // (a flipped opcode turns that record into an unknown one).
                    if !self.data_end_seen {
                        return Some(Err(self.err(
                            place.of(opcode),
                            "comes without a data end record before it: the file is damaged",
                        )));
                    }
                    let r = parse(opcode, body);
                    if let Ok(Some(Record::Footer(f))) = &r {
                        if let Err(e) = self.check_footer(at, f) {
                            return Some(Err(e));
                        }
                    }
                    self.footer_seen = true;
                    return Some(self.parsed(place, opcode, r));
                }
                _ => match parse(opcode, body) {
                    Ok(None) => {} // a kind nothing here reads
                    r => return Some(self.parsed(place, opcode, r)),
                },
            }
        }
    }

    fn parsed(
        &self,
        place: Place,
        opcode: u8,
        r: Result<Option<Record<'a>>, String>,
    ) -> Result<(Place, Record<'a>), FormatError> {
        match r {
            Ok(Some(r)) => Ok((place, r)),
            Ok(None) => unreachable!("data end and footer records are always parsed"),
            Err(e) => Err(self.err(place.of(opcode), format!("is malformed: {e}"))),
        }
    }

    /// The footer at `at` ends the records, and its summary CRC matches the bytes from the
    /// summary's start (the footer itself when there is no summary) up to the CRC field.
    fn check_footer(&self, at: usize, f: &mcap::records::Footer) -> Result<(), FormatError> {
        let place = Place::File(at as u64).of(op::FOOTER);
        if self.pos != self.end {
            return Err(self.err(
                &place,
                format!(
                    "is followed by {} bytes before the end magic",
                    self.end - self.pos
                ),
            ));
        }
        let start = match f.summary_start {
            0 => at as u64,
            s => s,
        };
        if start < mcap::MAGIC.len() as u64 || start > at as u64 {
            return Err(self.err(
                &place,
                format!(
                    "puts the summary section at byte {start}, outside the file's records (bytes {}..{at})",
                    mcap::MAGIC.len()
                ),
            ));
        }
        let stored = f.summary_crc;
        let computed =
            crc32fast::hash(&self.bytes[start as usize..at + RECORD_HEADER + FOOTER_CRC_FIELDS]);
        if stored != 0 && stored != computed {
            return Err(self.err(
                &place,
                format!(
                    "summary section CRC mismatch: the file stores {stored:08x}, the summary gives {computed:08x}: the file is damaged"
                ),
            ));
        }
        Ok(())
    }
}

impl<'a> Iterator for Records<'a> {
    type Item = Result<(Place, Record<'a>), FormatError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let r = self.next_record();
        if !matches!(r, Some(Ok(_))) {
            self.done = true;
        }
        r
    }
}

/// A channel as [`Messages`] hands it out with each message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Channel {
    pub id: u16,
    pub topic: String,
    /// The schema's name ("" for none).
    pub schema: String,
    pub message_encoding: String,
    pub metadata: BTreeMap<String, String>,
}

/// A message of [`Messages`]: where it lies, its channel, header and payload.
pub type Message<'a> = (
    Place,
    std::sync::Arc<Channel>,
    records::MessageHeader,
    Cow<'a, [u8]>,
);

/// The messages of an MCAP file with their channels, read through [`Records`] (every check
/// of this module): a channel must be defined before its messages, its schema before it, and
/// a schema or channel defined twice must be defined the same way. For readers of foreign
/// MCAP files that need messages only (`atrium score`'s estimates).
pub struct Messages<'a> {
    records: Records<'a>,
    schemas: std::collections::HashMap<u16, (String, String, Vec<u8>)>,
    channels: std::collections::HashMap<u16, std::sync::Arc<Channel>>,
}

impl<'a> Messages<'a> {
    pub fn new(bytes: &'a [u8], path: &Path) -> Result<Messages<'a>, FormatError> {
        Ok(Messages {
            records: Records::new(bytes, path)?,
            schemas: Default::default(),
            channels: Default::default(),
        })
    }

    fn take(&mut self, place: Place, r: Record<'a>) -> Result<Option<Message<'a>>, FormatError> {
        match r {
            Record::Schema { header, data } => {
                let new = (header.name, header.encoding, data.into_owned());
                if self.schemas.get(&header.id).is_some_and(|old| *old != new) {
                    return Err(self.records.err(
                        place.of(op::SCHEMA),
                        format!("defines schema {} a second time, differently", header.id),
                    ));
                }
                self.schemas.insert(header.id, new);
            }
            Record::Channel(c) => {
                let schema = match c.schema_id {
                    0 => String::new(),
                    id => match self.schemas.get(&id) {
                        Some(s) => s.0.clone(),
                        None => {
                            return Err(self.records.err(
                                place.of(op::CHANNEL),
                                format!("topic {} refers to schema {id}, which no schema record before it defines", c.topic),
                            ))
                        }
                    },
                };
                let new = Channel {
                    id: c.id,
                    topic: c.topic,
                    schema,
                    message_encoding: c.message_encoding,
                    metadata: c.metadata,
                };
                if self.channels.get(&c.id).is_some_and(|old| **old != new) {
                    return Err(self.records.err(
                        place.of(op::CHANNEL),
                        format!("defines channel {} a second time, differently", c.id),
                    ));
                }
                self.channels.insert(c.id, std::sync::Arc::new(new));
            }
            Record::Message { header, data } => {
                let Some(ch) = self.channels.get(&header.channel_id) else {
                    return Err(self.records.err(
                        place.of(op::MESSAGE),
                        format!(
                            "is on channel {}, which no channel record before it defines",
                            header.channel_id
                        ),
                    ));
                };
                return Ok(Some((place, ch.clone(), header, data)));
            }
            _ => {}
        }
        Ok(None)
    }
}

impl<'a> Iterator for Messages<'a> {
    type Item = Result<Message<'a>, FormatError>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            let (place, r) = match self.records.next()? {
                Ok(r) => r,
                Err(e) => return Some(Err(e)),
            };
            match self.take(place, r) {
                Ok(Some(m)) => return Some(Ok(m)),
                Ok(None) => {}
                Err(e) => {
                    self.records.done = true;
                    return Some(Err(e));
                }
            }
        }
    }
}

/// Opcode and length of the record starting `bytes`, if its header is whole.
fn record_header(bytes: &[u8]) -> Option<(u8, u64)> {
    let h = bytes.get(..RECORD_HEADER)?;
    let len = u64::from_le_bytes(h[1..].try_into().ok()?);
    Some((h[0], len))
}

fn bad(file: &Path, what: impl Into<String>, msg: impl Into<String>) -> FormatError {
    FormatError::field(file, what, msg)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    /// A small file: one schema, one channel, `n` messages, with the given chunking.
    fn file(compression: Option<mcap::Compression>, chunked: bool, n: u32) -> Vec<u8> {
        let mut out = std::io::Cursor::new(Vec::new());
        let mut w = mcap::WriteOptions::new()
            .compression(compression)
            .use_chunks(chunked)
            .create(&mut out)
            .unwrap();
        let s = w.add_schema("s", "jsonschema", b"{}").unwrap();
        let c = w.add_channel(s, "/t", "json", &BTreeMap::new()).unwrap();
        for k in 0..n {
            let header = mcap::records::MessageHeader {
                channel_id: c,
                sequence: k + 1,
                log_time: u64::from(k),
                publish_time: u64::from(k),
            };
            w.write_to_known_channel(&header, format!("{{\"k\":{k}}}").as_bytes())
                .unwrap();
        }
        w.finish().unwrap();
        drop(w);
        out.into_inner()
    }

    fn read(bytes: &[u8]) -> Result<Vec<(Place, Record<'_>)>, FormatError> {
        Records::new(bytes, Path::new("t.mcap"))?.collect()
    }

    fn messages(bytes: &[u8]) -> usize {
        read(bytes)
            .unwrap()
            .iter()
            .filter(|(_, r)| matches!(r, Record::Message { .. }))
            .count()
    }

    /// Offset of the first chunk record.
    fn first_chunk(bytes: &[u8]) -> usize {
        let mut at = mcap::MAGIC.len();
        while bytes[at] != op::CHUNK {
            let (_, len) = record_header(&bytes[at..]).unwrap();
            at += RECORD_HEADER + len as usize;
        }
        at
    }

    #[test]
    fn every_layout_reads_back_whole() {
        for (compression, chunked) in [
            (Some(mcap::Compression::Zstd), true),
            (Some(mcap::Compression::Lz4), true),
            (None, true),
            (None, false),
        ] {
            let bytes = file(compression, chunked, 50);
            assert_eq!(messages(&bytes), 50, "{compression:?} {chunked}");
            let places: Vec<Place> = read(&bytes).unwrap().into_iter().map(|p| p.0).collect();
            assert_eq!(
                places.iter().any(|p| matches!(p, Place::Chunk { .. })),
                chunked
            );
        }
    }

    #[test]
    fn a_flipped_bit_anywhere_is_an_error_that_names_the_place() {
        let bytes = file(Some(mcap::Compression::Zstd), true, 50);
        // Every bit of every byte: whatever it hits (a length, compressed data, a CRC, a
        // string, an opcode), the file reads as damaged.
        let mut clean = 0;
        for i in 0..bytes.len() {
            for bit in 0..8 {
                let mut b = bytes.clone();
                b[i] ^= 1 << bit;
                match read(&b) {
                    Err(e) => {
                        let e = e.to_string();
                        assert!(e.starts_with("t.mcap: "), "{e}");
                    }
                    Ok(records) => {
                        clean += 1;
                        assert_eq!(
                            records
                                .iter()
                                .filter(|(_, r)| matches!(r, Record::Message { .. }))
                                .count(),
                            50,
                            "byte {i} bit {bit}"
                        );
                    }
                }
            }
        }
        // Chunks, the data section, the summary and the footer are all covered by a CRC.
        assert_eq!(
            clean,
            0,
            "{clean} of {} flips went unnoticed",
            bytes.len() * 8
        );
    }

    #[test]
    fn a_chunk_crc_mismatch_names_the_chunk() {
        let mut bytes = file(None, true, 5);
        let at = first_chunk(&bytes);
        // The first message's payload, inside the uncompressed chunk: only the CRC can tell.
        let payload = bytes.windows(7).position(|w| w == b"{\"k\":0}").unwrap();
        bytes[payload + 5] = b'7';
        let e = read(&bytes).unwrap_err().to_string();
        assert!(
            e.contains(&format!("chunk at byte {at}: CRC mismatch")),
            "{e}"
        );
    }

    #[test]
    fn absurd_sizes_are_refused_before_anything_is_allocated() {
        let good = file(Some(mcap::Compression::Zstd), true, 5);
        let at = first_chunk(&good);
        // Uncompressed size: 9 bytes into the chunk record, after start and end times.
        let size_at = at + RECORD_HEADER + 16;
        for (size, needle) in [
            (u64::MAX, "more than the limit of 268435456 bytes"),
            (MAX_CHUNK_BYTES, "its data holds"),
            (3, "more than that"),
        ] {
            let mut b = good.clone();
            b[size_at..size_at + 8].copy_from_slice(&size.to_le_bytes());
            let e = read(&b).unwrap_err().to_string();
            assert!(
                e.contains(&format!("chunk at byte {at}")) && e.contains(needle),
                "{e}"
            );
        }
        // A record length of 2^62 at the top level and inside an uncompressed chunk.
        let mut b = good.clone();
        b[at + 1..at + 9].copy_from_slice(&(1u64 << 62).to_le_bytes());
        let e = read(&b).unwrap_err().to_string();
        assert!(
            e.contains(&format!(
                "chunk record at byte {at}: claims 4611686018427387904 bytes"
            )),
            "{e}"
        );
        let plain = file(None, true, 5);
        let at = first_chunk(&plain);
        let (header, _) = parse_chunk(&plain[at + RECORD_HEADER..]).unwrap();
        let records = at + RECORD_HEADER + 8 * 3 + 4 + 4 + header.compression.len() + 8;
        let mut b = plain.clone();
        b[records + 1..records + 9].copy_from_slice(&(1u64 << 62).to_le_bytes());
        // Zero the chunk CRC, so the length itself is what is read and refused.
        b[at + RECORD_HEADER + 24..at + RECORD_HEADER + 28].fill(0);
        let e = read(&b).unwrap_err().to_string();
        assert!(
            e.contains(&format!("record at byte 0 of the chunk at byte {at}"))
                && e.contains("claims 4611686018427387904 bytes"),
            "{e}"
        );
    }

    #[test]
    fn string_and_map_lengths_are_checked_against_the_record() {
        let good = file(None, false, 5);
        // The channel's topic "/t" and its length prefix, 4 bytes into the channel record.
        let topic = good.windows(6).position(|w| w == b"\x02\0\0\0/t").unwrap();
        let mut b = good.clone();
        b[topic..topic + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        let e = read(&b).unwrap_err().to_string();
        assert!(
            e.contains("channel record at byte")
                && e.contains("its topic of 4294967295 bytes at byte 4 runs past the record's end"),
            "{e}"
        );
        // The metadata map's byte length, right after the topic and the message encoding.
        let map = topic + 6 + 4 + "json".len();
        let mut b = good.clone();
        b[map..map + 4].copy_from_slice(&0x7f7f_7f7fu32.to_le_bytes());
        let e = read(&b).unwrap_err().to_string();
        assert!(
            e.contains("its metadata of 2139062143 bytes at byte 18"),
            "{e}"
        );
    }

    #[test]
    fn messages_come_with_their_channels() {
        let bytes = file(Some(mcap::Compression::Zstd), true, 7);
        let got: Vec<_> = Messages::new(&bytes, Path::new("t.mcap"))
            .unwrap()
            .map(|m| m.unwrap())
            .collect();
        assert_eq!(got.len(), 7);
        let (_, ch, h, data) = &got[3];
        assert_eq!((ch.topic.as_str(), ch.schema.as_str()), ("/t", "s"));
        assert_eq!((h.sequence, h.log_time), (4, 3));
        assert_eq!(&data[..], b"{\"k\":3}");
        // A message on a channel never defined.
        let mut b = file(None, false, 1);
        let m = records_at(&b, op::MESSAGE)[0];
        b[m + RECORD_HEADER] = 9;
        let e = Messages::new(&b, Path::new("t.mcap"))
            .unwrap()
            .find_map(Result::err)
            .unwrap()
            .to_string();
        assert!(
            e.contains("is on channel 9, which no channel record before it defines"),
            "{e}"
        );
    }

    /// Offsets of the top-level records with `opcode`.
    fn records_at(bytes: &[u8], opcode: u8) -> Vec<usize> {
        let mut at = mcap::MAGIC.len();
        let mut found = Vec::new();
        while at < bytes.len() - mcap::MAGIC.len() {
            let (op, len) = record_header(&bytes[at..]).unwrap();
            if op == opcode {
                found.push(at);
            }
            at += RECORD_HEADER + len as usize;
        }
        found
    }

    #[test]
    fn data_section_and_summary_crcs_are_checked() {
        let good = file(Some(mcap::Compression::Zstd), true, 5);
        let footer = good.len() - mcap::MAGIC.len() - RECORD_HEADER - 20;
        assert_eq!(good[footer], op::FOOTER);
        let summary_crc = footer + RECORD_HEADER + 16;
        let mut b = good.clone();
        b[summary_crc] ^= 1;
        let e = read(&b).unwrap_err().to_string();
        assert!(e.contains("summary section CRC mismatch"), "{e}");
        // The header's library string lies in the data section, outside any chunk.
        let mut b = good.clone();
        let lib = b.windows(4).position(|w| w == b"mcap").unwrap();
        b[lib] = b'M';
        let e = read(&b).unwrap_err().to_string();
        assert!(e.contains("data section CRC mismatch"), "{e}");
        // Cut: no footer, or bytes missing before it.
        let mut cut = good[..good.len() / 2].to_vec();
        cut.extend_from_slice(mcap::MAGIC);
        assert!(read(&cut).is_err());
    }
}
