//! Reading logs back (`hardbody inspect`, resuming, exporting, tests):
//! complete logs, logs cut off mid-write, and damaged logs, each up to its
//! last intact record.
//!
//! Nothing read from the file is trusted: every record length is bounded by
//! the bytes that remain, a chunk's stated uncompressed size by a multiple
//! of its compressed size (and allocated fallibly), and every chunk's CRC
//! is checked before any of its messages is read. A record where MCAP puts
//! none (a chunk or metadata record whose opcode is damaged reads as one)
//! and a message out of hardbody's numbering 1, 2, 3, ... are damage too,
//! so a cut-off log, which has no data-section CRC, never skips a record
//! unread. The first damaged record ends the reading: what came before it
//! is returned, with a [`Damage`] that says where the damage is.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use mcap::records::{Record, op};

use super::{FailureRecord, LogError, StateRecord, Stats};

/// Where a log is damaged and how.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Damage {
    /// Byte offset of the damaged record in the file (for a record inside
    /// a chunk, the chunk's offset).
    pub offset: u64,
    /// What is wrong there.
    pub what: Fault,
}

/// What is wrong with a damaged record.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Fault {
    /// The bytes end inside a record's 9-byte header.
    #[error("a record header of 9 bytes, {left} bytes left")]
    CutHeader {
        /// Bytes left.
        left: usize,
    },
    /// The bytes end inside a record's body.
    #[error("a record of {length} bytes, {left} bytes left in the file")]
    CutRecord {
        /// The body's stated length.
        length: u64,
        /// Bytes left.
        left: u64,
    },
    /// The CRC of the data section does not match its bytes.
    #[error(
        "the data section's CRC does not match (stored {stored:08x}, computed {computed:08x}): every chunk is intact, a record outside them (header, schema, channel, metadata, index) is damaged"
    )]
    DataCrc {
        /// As stored.
        stored: u32,
        /// Of the bytes read.
        computed: u32,
    },
    /// A data end record too short to hold its CRC.
    #[error("a data end record without its CRC")]
    DataEndWithoutCrc,
    /// A chunk that cannot be opened.
    #[error("chunk: {0}")]
    Chunk(ChunkFault),
    /// A chunk whose messages' times are not those its header states.
    #[error("chunk: its header states message times {stated:?}, its messages have {found:?}")]
    ChunkTimes {
        /// As the header states.
        stated: (u64, u64),
        /// As its messages have them.
        found: (u64, u64),
    },
    /// A fault of a record inside a chunk.
    #[error("inside the chunk: {0}")]
    InsideChunk(Box<Fault>),
    /// A record of an opcode neither hardbody nor MCAP writes.
    #[error("unknown record (opcode {0:#04x})")]
    UnknownRecord(u8),
    /// A record where MCAP never puts one: a summary record or footer
    /// before the data end, a second header, anything but a schema,
    /// channel or message inside a chunk, a message index not after a
    /// chunk. Most often a chunk or metadata record whose opcode is
    /// damaged, which would otherwise be skipped unread.
    #[error("a record of opcode {0:#04x} where the data section holds none")]
    Misplaced(u8),
    /// A message whose sequence number is not the next one: hardbody
    /// numbers its messages 1, 2, 3, ... in file order, so messages were
    /// lost (or repeated) with a record whose damage was not otherwise seen.
    #[error(
        "message numbered {found} where {expected} comes next: messages are missing or repeated"
    )]
    OutOfSequence {
        /// The sequence number the next message has.
        expected: u32,
        /// The one this message has.
        found: u32,
    },
    /// A record the MCAP parser refuses.
    #[error("record (opcode {opcode:#04x}): {reason}")]
    Unparsable {
        /// The record's opcode.
        opcode: u8,
        /// The parser's reason.
        reason: String,
    },
    /// A message on a channel no record declared.
    #[error("message {sequence} on channel {channel}, which was never declared")]
    UndeclaredChannel {
        /// The message's sequence number.
        sequence: u32,
        /// Its channel id.
        channel: u16,
    },
    /// A message whose contents cannot be a hardbody record.
    #[error("{topic} message: {reason}")]
    Message {
        /// Its topic.
        topic: String,
        /// Why it cannot be read.
        reason: String,
    },
}

/// Why a chunk cannot be opened.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ChunkFault {
    /// The MCAP parser refuses its header.
    #[error("{0}")]
    Unparsable(String),
    /// Its uncompressed size is beyond what its compressed size allows.
    #[error("states {stated} uncompressed bytes for {compressed} compressed")]
    Oversized {
        /// As stated.
        stated: u64,
        /// The compressed bytes.
        compressed: usize,
    },
    /// Memory for its uncompressed bytes cannot be had.
    #[error("cannot hold its {0} uncompressed bytes")]
    CannotHold(usize),
    /// Its compressed bytes do not decompress.
    #[error("does not decompress: {0}")]
    Decompress(String),
    /// A compression hardbody does not read.
    #[error("unknown compression {0:?}")]
    UnknownCompression(String),
    /// Its uncompressed bytes are not as many as stated.
    #[error("holds {found} uncompressed bytes, its header says {stated}")]
    Size {
        /// As decompressed.
        found: usize,
        /// As stated.
        stated: usize,
    },
    /// The CRC of its uncompressed bytes does not match.
    #[error("CRC mismatch (stored {stored:08x}, computed {computed:08x})")]
    Crc {
        /// As stored.
        stored: u32,
        /// Of the bytes read.
        computed: u32,
    },
}

impl std::fmt::Display for Damage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "damaged at byte {}: {}", self.offset, self.what)
    }
}

/// What a log holds.
#[derive(Debug, Clone, PartialEq)]
pub struct LogContents {
    /// The `hardbody` metadata record (version, scene text, log time).
    pub metadata: BTreeMap<String, String>,
    /// What each stage run into this log was built with, by stage index
    /// (JSON; the `hardbody.stage` metadata records, the last of an index
    /// where a resume wrote it again).
    pub stage_plans: BTreeMap<usize, String>,
    /// Messages per topic.
    pub counts: BTreeMap<String, u64>,
    /// Every `/stats` message, with its log time.
    pub stats: Vec<(u64, Stats)>,
    /// The last complete `/state`, with its log time.
    pub last_state: Option<(u64, StateRecord)>,
    /// Every `/state` (only when asked for).
    pub states: Vec<(u64, StateRecord)>,
    /// Why the run failed, if it did (`/failure`).
    pub failure: Option<(u64, FailureRecord)>,
    /// Whether the file ended before the MCAP footer (a killed run); it is
    /// read up to its last complete record.
    pub truncated: bool,
    /// The first damaged record, if any; nothing after it was read.
    pub damage: Option<Damage>,
    /// Every intact message in file order (only when asked for).
    pub messages: Vec<RawMessage>,
}

impl LogContents {
    /// The scene text the log was written from.
    pub fn scene_text(&self) -> Option<&str> {
        self.metadata.get("scene").map(String::as_str)
    }
}

/// What to keep of a log besides its metadata, counts, `/stats`, last
/// `/state` and `/failure`.
#[derive(Debug, Clone, Copy, Default)]
pub struct ReadOptions {
    /// Every `/state`, decoded.
    pub all_states: bool,
    /// Every message as stored.
    pub messages: bool,
}

/// One message as stored: topic, log time, bytes.
pub type RawMessage = (String, u64, Vec<u8>);

/// Reads `path`; with `all_states`, keeps every `/state` (else the last).
pub fn read_log(path: &Path, all_states: bool) -> Result<LogContents, LogError> {
    read_log_with(
        path,
        ReadOptions {
            all_states,
            messages: false,
        },
    )
}

/// Reads `path`, keeping what `options` asks for.
pub fn read_log_with(path: &Path, options: ReadOptions) -> Result<LogContents, LogError> {
    // A FIFO would block the read, a device (/dev/zero) fill the memory.
    super::file::check_input(path).map_err(|e| LogError::Content {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let buf = std::fs::read(path).map_err(|source| LogError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    read_log_bytes(&buf, path, options)
}

/// Reads a log held in memory (`path` names it in errors).
pub fn read_log_bytes(
    buf: &[u8],
    path: &Path,
    options: ReadOptions,
) -> Result<LogContents, LogError> {
    let content = |message: String| LogError::Content {
        path: PathBuf::from(path),
        message,
    };
    if !buf.starts_with(mcap::MAGIC) {
        return Err(content(
            "not an MCAP file (no MCAP magic at the start)".into(),
        ));
    }
    let mut contents = LogContents {
        metadata: BTreeMap::new(),
        stage_plans: BTreeMap::new(),
        counts: BTreeMap::new(),
        stats: Vec::new(),
        last_state: None,
        states: Vec::new(),
        failure: None,
        truncated: false,
        damage: None,
        messages: Vec::new(),
    };
    let mut metadata = None;
    let end = scan(buf, |item| match item {
        Item::Metadata(m) => {
            if m.name == "hardbody" {
                metadata = Some(m.metadata);
            } else if m.name == super::STAGE_PLAN_METADATA
                && let (Some(index), Some(plan)) = (
                    m.metadata.get("index").and_then(|i| i.parse().ok()),
                    m.metadata.get("plan"),
                )
            {
                contents.stage_plans.insert(index, plan.clone());
            }
            Ok(())
        }
        Item::Message {
            topic,
            log_time,
            data,
        } => {
            let decode_error = |reason: DecodeError| Fault::Message {
                topic: topic.to_string(),
                reason: reason.to_string(),
            };
            match topic {
                "/stats" => {
                    let s: Stats = decode(data).map_err(decode_error)?;
                    contents.stats.push((log_time, s));
                }
                "/state" => {
                    let s: StateRecord = decode(data).map_err(decode_error)?;
                    s.check_consistent().map_err(|why| Fault::Message {
                        topic: topic.to_string(),
                        reason: why.to_string(),
                    })?;
                    if options.all_states {
                        contents.states.push((log_time, s.clone()));
                    }
                    contents.last_state = Some((log_time, s));
                }
                "/failure" => {
                    let f: FailureRecord = decode(data).map_err(decode_error)?;
                    contents.failure = Some((log_time, f));
                }
                _ => {}
            }
            *contents.counts.entry(topic.to_string()).or_default() += 1;
            if options.messages {
                contents
                    .messages
                    .push((topic.to_string(), log_time, data.to_vec()));
            }
            Ok(())
        }
    });
    contents.truncated = end.truncated;
    contents.damage = end.damage;
    match metadata {
        Some(m) => contents.metadata = m,
        None => {
            let why = match &contents.damage {
                Some(d) => format!("no hardbody metadata record before the damage ({d})"),
                None => "not a hardbody log (no hardbody metadata record)".into(),
            };
            return Err(content(why));
        }
    }
    Ok(contents)
}

/// What [`scan`] hands its visitor, in file order.
enum Item<'a> {
    Metadata(mcap::records::Metadata),
    Message {
        topic: &'a str,
        log_time: u64,
        data: &'a [u8],
    },
}

/// How a scan ended.
struct ScanEnd {
    truncated: bool,
    damage: Option<Damage>,
}

/// Largest ratio of a chunk's stated uncompressed size to its compressed
/// size that is believed (JSON frames compress about 3:1, zstd reaches a
/// few hundred to one on uniform data), and the size believed regardless.
const MAX_CHUNK_RATIO: u64 = 1024;
const MIN_CHUNK_BOUND: u64 = 64 << 20;

/// Walks the records of an MCAP file, opening chunks after checking their
/// sizes and CRCs, and hands each metadata record and message to `visit`.
/// Stops at the data end, at the end of the bytes (a cut-off file), or at
/// the first damaged record, or where `visit` refuses a message (its
/// reason becomes the damage).
fn scan(buf: &[u8], mut visit: impl FnMut(Item<'_>) -> Result<(), Fault>) -> ScanEnd {
    let mut walk = Walk {
        channels: BTreeMap::new(),
        next_sequence: 1,
    };
    // Whether the previous record is a chunk or one of its message indexes.
    let mut after_chunk = false;
    let complete_file = buf.len() >= 2 * mcap::MAGIC.len() && buf.ends_with(mcap::MAGIC);
    let damaged = |offset: usize, what: Fault| ScanEnd {
        truncated: !complete_file,
        damage: Some(Damage {
            offset: offset as u64,
            what,
        }),
    };
    let mut at = mcap::MAGIC.len();
    loop {
        let record = match next_record(buf, at) {
            Next::Record(r) => r,
            Next::End => {
                return ScanEnd {
                    truncated: true,
                    damage: None,
                };
            }
            Next::CutOff(what) => {
                // A complete file cannot end mid-record: that is damage.
                return if complete_file {
                    damaged(at, what)
                } else {
                    ScanEnd {
                        truncated: true,
                        damage: None,
                    }
                };
            }
        };
        let offset = at;
        at = record.next;
        let follows_chunk = std::mem::replace(&mut after_chunk, false);
        match record.opcode {
            op::DATA_END => {
                // The CRC of every byte before this record (zero: none).
                let stored = record
                    .body
                    .get(..4)
                    .map(|b| u32::from_le_bytes(b.try_into().expect("four bytes")));
                let computed = crc32fast::hash(&buf[..offset]);
                return match stored {
                    Some(crc) if crc == 0 || crc == computed => ScanEnd {
                        truncated: !complete_file,
                        damage: None,
                    },
                    Some(stored) => damaged(offset, Fault::DataCrc { stored, computed }),
                    None => damaged(offset, Fault::DataEndWithoutCrc),
                };
            }
            op::CHUNK => {
                let (chunk, stated_times) = match open_chunk(record.body) {
                    Ok(c) => c,
                    Err(what) => return damaged(offset, Fault::Chunk(what)),
                };
                // Its messages' times must be those its header states
                // (the header is outside the CRC) before any is read.
                if let Some(found) = message_times(&chunk)
                    && found != stated_times
                {
                    return damaged(
                        offset,
                        Fault::ChunkTimes {
                            stated: stated_times,
                            found,
                        },
                    );
                }
                let mut inner = 0;
                loop {
                    let r = match next_record(&chunk, inner) {
                        Next::Record(r) => r,
                        Next::End => break,
                        Next::CutOff(what) => {
                            return damaged(offset, Fault::InsideChunk(Box::new(what)));
                        }
                    };
                    inner = r.next;
                    // A chunk holds schemas, channels and messages only.
                    let fault = match r.opcode {
                        op::SCHEMA | op::CHANNEL | op::MESSAGE => walk.visit(r, &mut visit).err(),
                        other => Some(Fault::Misplaced(other)),
                    };
                    if let Some(what) = fault {
                        return damaged(offset, Fault::InsideChunk(Box::new(what)));
                    }
                }
                after_chunk = true;
            }
            op::MESSAGE_INDEX => {
                if let Err(what) = walk.check_message_index(record, follows_chunk) {
                    return damaged(offset, what);
                }
                after_chunk = true;
            }
            op::HEADER if offset == mcap::MAGIC.len() => {}
            _ => {
                if let Err(what) = walk.visit(record, &mut visit) {
                    return damaged(offset, what);
                }
            }
        }
    }
}

/// What a scan has learnt of the records before the one it reads.
struct Walk {
    /// Topic of each declared channel.
    channels: BTreeMap<u16, String>,
    /// The sequence number the next message must have.
    next_sequence: u32,
}

impl Walk {
    /// A message index belongs right after its chunk (or another index of
    /// that chunk) and names a declared channel.
    fn check_message_index(&self, record: RawRecord<'_>, follows_chunk: bool) -> Result<(), Fault> {
        if !follows_chunk {
            return Err(Fault::Misplaced(op::MESSAGE_INDEX));
        }
        match parse(&record)? {
            Record::MessageIndex(index) if self.channels.contains_key(&index.channel_id) => Ok(()),
            _ => Err(Fault::Misplaced(op::MESSAGE_INDEX)),
        }
    }

    /// Parses one record of the data section (other than a chunk, a
    /// message index or the data end) and hands what matters to `visit`.
    fn visit(
        &mut self,
        record: RawRecord<'_>,
        visit: &mut impl FnMut(Item<'_>) -> Result<(), Fault>,
    ) -> Result<(), Fault> {
        match record.opcode {
            op::SCHEMA | op::CHANNEL | op::MESSAGE | op::METADATA | op::ATTACHMENT => {}
            // Known to MCAP, but never here: the header starts the file,
            // the footer and summary records follow the data end.
            op::HEADER..=op::DATA_END => return Err(Fault::Misplaced(record.opcode)),
            // Not written by hardbody, nor by MCAP's current writers.
            other => return Err(Fault::UnknownRecord(other)),
        }
        match parse(&record)? {
            Record::Channel(c) => {
                self.channels.insert(c.id, c.topic);
                Ok(())
            }
            Record::Metadata(m) => visit(Item::Metadata(m)),
            Record::Message { header, data } => {
                let topic =
                    self.channels
                        .get(&header.channel_id)
                        .ok_or(Fault::UndeclaredChannel {
                            sequence: header.sequence,
                            channel: header.channel_id,
                        })?;
                if header.sequence != self.next_sequence {
                    return Err(Fault::OutOfSequence {
                        expected: self.next_sequence,
                        found: header.sequence,
                    });
                }
                self.next_sequence = self.next_sequence.wrapping_add(1);
                visit(Item::Message {
                    topic,
                    log_time: header.log_time,
                    data: &data,
                })
            }
            _ => Ok(()),
        }
    }
}

/// One record parsed by the MCAP parser, or why not.
fn parse<'a>(record: &RawRecord<'a>) -> Result<Record<'a>, Fault> {
    mcap::read::parse_record(record.opcode, record.body).map_err(|e| Fault::Unparsable {
        opcode: record.opcode,
        reason: e.to_string(),
    })
}

/// The least and greatest log time of the messages among `records`, if
/// any (a message body starts with channel id u16, sequence u32, log time
/// u64).
fn message_times(records: &[u8]) -> Option<(u64, u64)> {
    let mut at = 0;
    let mut times: Option<(u64, u64)> = None;
    while let Next::Record(r) = next_record(records, at) {
        at = r.next;
        if r.opcode == op::MESSAGE
            && let Some(t) = r.body.get(6..14)
        {
            let t = u64::from_le_bytes(t.try_into().expect("eight bytes"));
            times = Some(times.map_or((t, t), |(a, b)| (a.min(t), b.max(t))));
        }
    }
    times
}

/// One record's place in a buffer.
struct RawRecord<'a> {
    opcode: u8,
    body: &'a [u8],
    /// Offset of the record after it.
    next: usize,
}

enum Next<'a> {
    Record(RawRecord<'a>),
    /// The buffer ends exactly here.
    End,
    /// The buffer ends inside the record that starts here.
    CutOff(Fault),
}

/// The record at `at` of `buf`: an opcode, a little-endian u64 length, a
/// body of that length (bounded by what remains).
fn next_record(buf: &[u8], at: usize) -> Next<'_> {
    let rest = &buf[at.min(buf.len())..];
    if rest.is_empty() {
        return Next::End;
    }
    if rest.len() < 9 {
        return Next::CutOff(Fault::CutHeader { left: rest.len() });
    }
    let length = u64::from_le_bytes(rest[1..9].try_into().expect("eight bytes"));
    let room = (rest.len() - 9) as u64;
    if length > room {
        return Next::CutOff(Fault::CutRecord { length, left: room });
    }
    let body_end = 9 + length as usize;
    Next::Record(RawRecord {
        opcode: rest[0],
        body: &rest[9..body_end],
        next: at + body_end,
    })
}

/// A chunk's records, decompressed, after checking the stated sizes and
/// the CRC of the uncompressed records.
/// Also returns the message times the header states.
fn open_chunk(body: &[u8]) -> Result<(Vec<u8>, (u64, u64)), ChunkFault> {
    let Record::Chunk { header, data } = mcap::read::parse_record(op::CHUNK, body)
        .map_err(|e| ChunkFault::Unparsable(e.to_string()))?
    else {
        return Err(ChunkFault::Unparsable("not a chunk".into()));
    };
    let bound = (data.len() as u64)
        .saturating_mul(MAX_CHUNK_RATIO)
        .max(MIN_CHUNK_BOUND);
    if header.uncompressed_size > bound {
        return Err(ChunkFault::Oversized {
            stated: header.uncompressed_size,
            compressed: data.len(),
        });
    }
    let size = header.uncompressed_size as usize;
    let records = match header.compression.as_str() {
        "" => data.to_vec(),
        "zstd" => {
            let mut out = Vec::new();
            out.try_reserve_exact(size)
                .map_err(|_| ChunkFault::CannotHold(size))?;
            zstd::bulk::Decompressor::new()
                .and_then(|mut d| d.decompress_to_buffer(&data[..], &mut out))
                .map_err(|e| ChunkFault::Decompress(e.to_string()))?;
            out
        }
        other => return Err(ChunkFault::UnknownCompression(other.to_string())),
    };
    if records.len() != size {
        return Err(ChunkFault::Size {
            found: records.len(),
            stated: size,
        });
    }
    let crc = crc32fast::hash(&records);
    if header.uncompressed_crc != 0 && crc != header.uncompressed_crc {
        return Err(ChunkFault::Crc {
            stored: header.uncompressed_crc,
            computed: crc,
        });
    }
    Ok((
        records,
        (header.message_start_time, header.message_end_time),
    ))
}

/// A JSON message decoded, or why not with the field and the place:
/// `angular_velocities[3][0]: number out of range at line 1 column 345`.
fn decode<T: serde::de::DeserializeOwned>(data: &[u8]) -> Result<T, DecodeError> {
    let mut json = serde_json::Deserializer::from_slice(data);
    let value = serde_path_to_error::deserialize(&mut json)?;
    json.end().map_err(DecodeError::Trailing)?;
    Ok(value)
}

/// Why a message's JSON does not decode.
#[derive(Debug, thiserror::Error)]
enum DecodeError {
    /// A field is missing or of the wrong type (named by its path).
    #[error("{0}")]
    Field(#[from] serde_path_to_error::Error<serde_json::Error>),
    /// Something follows the message's one value.
    #[error("{0}")]
    Trailing(serde_json::Error),
}
