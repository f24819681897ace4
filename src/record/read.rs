//! Reading sessions: our own recordings and any ROS 2 MCAP (rosbag2, rosbags, Foxglove), whole or
//! cut off. Reading stops at the first damaged record and says so; nothing here panics on bad
//! bytes.

use super::RecordError;
use crate::msgs::{CdrError, RosMessage, from_cdr};
use std::collections::BTreeMap;

/// A topic of a session.
#[derive(Debug, Clone, PartialEq)]
pub struct TopicInfo {
    /// The topic's name.
    pub topic: String,
    /// `pkg/msg/Type`
    pub type_name: String,
    /// The schema's definition, as recorded (`ros2msg` text for ROS 2).
    pub schema_text: String,
    /// `cdr` for ROS 2; other encodings are listed but their messages are not decoded.
    pub encoding: String,
    /// The channel's metadata (rosbag2's offered QoS among it).
    pub channel_metadata: BTreeMap<String, String>,
    /// Messages on the topic.
    pub count: u64,
}

/// One message, as stored.
#[derive(Debug, Clone, PartialEq)]
pub struct MessageRef {
    /// The topic, by index in [`Scan::topics`].
    pub topic: usize,
    /// When the message was logged (ns since the epoch).
    pub log_time_ns: u64,
    /// When it was published (ns since the epoch).
    pub publish_time_ns: u64,
    /// The message's bytes (CDR for ROS 2).
    pub data: Vec<u8>,
}

/// One message during a scan, borrowing its bytes (no copy per message).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MessageView<'a> {
    /// The topic, by index in [`Scan::topics`].
    pub topic: usize,
    /// When the message was logged (ns since the epoch).
    pub log_time_ns: u64,
    /// When it was published (ns since the epoch).
    pub publish_time_ns: u64,
    /// The message's bytes.
    pub data: &'a [u8],
}

impl MessageView<'_> {
    /// The message with its bytes copied.
    pub fn to_owned(&self) -> MessageRef {
        MessageRef {
            topic: self.topic,
            log_time_ns: self.log_time_ns,
            publish_time_ns: self.publish_time_ns,
            data: self.data.to_vec(),
        }
    }
}

/// What a scan found, besides the messages it handed on.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Scan {
    /// The topics, in the order their channels appear.
    pub topics: Vec<TopicInfo>,
    /// Metadata records by name.
    pub metadata: BTreeMap<String, BTreeMap<String, String>>,
    /// Messages in the file.
    pub messages: u64,
    /// Log time of the first message (ns), if any.
    pub start_ns: Option<u64>,
    /// Log time of the last message (ns), if any.
    pub end_ns: Option<u64>,
    /// The file ends as a finished MCAP does (footer, summary, end magic).
    pub complete: bool,
    /// Why reading stopped early, if it did.
    pub stopped: Option<String>,
}

impl Scan {
    /// Time from the first message to the last (s); 0 without messages.
    pub fn duration_s(&self) -> f64 {
        match (self.start_ns, self.end_ns) {
            (Some(a), Some(b)) => b.saturating_sub(a) as f64 * 1e-9,
            _ => 0.0,
        }
    }

    /// The index of `topic` in [`Self::topics`], if the file has it.
    pub fn topic_index(&self, topic: &str) -> Option<usize> {
        self.topics.iter().position(|t| t.topic == topic)
    }
}

/// Largest chunk this reader decompresses (ours are 4 MiB; rosbag2's default is 768 KiB).
const MAX_CHUNK_BYTES: u64 = 1 << 30;

/// Scans `bytes` from the start, calling `visit(scan, message)` for every complete message, in
/// file order. An error only if `bytes` is not MCAP at all.
///
/// Records are read one by one (chunks whole), and each chunk's declared sizes are checked
/// before it is decompressed: a damaged size would otherwise ask for an absurd allocation.
pub fn scan(bytes: &[u8], mut visit: impl FnMut(&Scan, MessageView)) -> Result<Scan, RecordError> {
    use mcap::records::Record;
    if bytes.len() < mcap::MAGIC.len() || &bytes[..mcap::MAGIC.len()] != mcap::MAGIC {
        return Err(RecordError::Io(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            "not an MCAP file (no MCAP magic at the start)",
        )));
    }
    let mut s = Scan::default();
    let mut by_channel: BTreeMap<u16, usize> = BTreeMap::new();
    let mut acc: mcap::read::ChannelAccumulator<'static> = Default::default();
    let opts = mcap::read::Options::IgnoreEndMagic.into();
    let mut handle = |rec: Record, s: &mut Scan| -> Result<(), String> {
        match rec {
            Record::Schema { header, data } => acc
                .add_schema(header, std::borrow::Cow::Owned(data.into_owned()))
                .map_err(|e| e.to_string()),
            Record::Channel(c) => acc.add_channel(c).map_err(|e| e.to_string()),
            Record::Metadata(md) => {
                s.metadata.insert(md.name, md.metadata);
                Ok(())
            }
            Record::Message { header, data } => {
                let channel = acc
                    .get(header.channel_id)
                    .ok_or_else(|| format!("message on unknown channel {}", header.channel_id))?;
                let idx = match by_channel.get(&channel.id) {
                    Some(&i) => i,
                    None => {
                        let schema = channel.schema.as_ref();
                        s.topics.push(TopicInfo {
                            topic: channel.topic.clone(),
                            type_name: schema.map(|x| x.name.clone()).unwrap_or_default(),
                            schema_text: schema
                                .map(|x| String::from_utf8_lossy(&x.data).into_owned())
                                .unwrap_or_default(),
                            encoding: channel.message_encoding.clone(),
                            channel_metadata: channel.metadata.clone(),
                            count: 0,
                        });
                        by_channel.insert(channel.id, s.topics.len() - 1);
                        s.topics.len() - 1
                    }
                };
                s.topics[idx].count += 1;
                s.messages += 1;
                let t = header.log_time;
                s.start_ns = Some(s.start_ns.map_or(t, |v| v.min(t)));
                s.end_ns = Some(s.end_ns.map_or(t, |v| v.max(t)));
                visit(
                    s,
                    MessageView {
                        topic: idx,
                        log_time_ns: t,
                        publish_time_ns: header.publish_time,
                        data: &data,
                    },
                );
                Ok(())
            }
            _ => Ok(()),
        }
    };
    // The mcap crate (0.26) panics on an attachment record too short for its own fields: such a
    // record ends the file here, as damage does.
    let bad_attachment = malformed_attachment(&bytes[mcap::MAGIC.len()..]);
    let readable = bad_attachment.map_or(bytes, |at| &bytes[..mcap::MAGIC.len() + at]);
    let reader = mcap::read::LinearReader::new_with_options(readable, opts)?;
    let mut footer = false;
    'records: for rec in reader {
        let rec = match rec {
            Ok(r) => r,
            Err(e) => {
                s.stopped = Some(e.to_string());
                break;
            }
        };
        footer |= matches!(rec, Record::Footer(_));
        if let Record::Chunk { header, data } = rec {
            let declared = header.uncompressed_size;
            if declared > MAX_CHUNK_BYTES
                || declared > header.compressed_size.saturating_mul(1000) + (1 << 20)
            {
                s.stopped = Some(format!(
                    "a chunk declares {declared} bytes uncompressed: damaged"
                ));
                break;
            }
            let records = match decompress_chunk(&header, &data) {
                Ok(r) => r,
                Err(e) => {
                    s.stopped = Some(e);
                    break;
                }
            };
            let bad = malformed_attachment(&records);
            for r in mcap::read::LinearReader::sans_magic(&records[..bad.unwrap_or(records.len())])
            {
                match r.map_err(|e| e.to_string()).and_then(|r| handle(r, &mut s)) {
                    Ok(()) => {}
                    Err(e) => {
                        s.stopped = Some(e);
                        break 'records;
                    }
                }
            }
            if let Some(at) = bad {
                s.stopped = Some(format!(
                    "a chunk holds a malformed attachment record at byte {at} of its records"
                ));
                break;
            }
        } else if let Err(e) = handle(rec, &mut s) {
            s.stopped = Some(e);
            break;
        }
    }
    if let (Some(at), None) = (bad_attachment, &s.stopped) {
        s.stopped = Some(format!(
            "a malformed attachment record at byte {}",
            mcap::MAGIC.len() + at
        ));
    }
    // Not mcap::Summary::read: it trusts the offsets in the footer, which may be damaged.
    s.complete = s.stopped.is_none() && footer && bytes.ends_with(mcap::MAGIC);
    Ok(s)
}

/// The offset in `records` (a stream of MCAP records: opcode, u64 length, body) of the first
/// attachment record whose body is too short for its own fields (times, name, media type,
/// data length, data and CRC), if any before the stream ends or is cut off.
fn malformed_attachment(records: &[u8]) -> Option<usize> {
    const ATTACHMENT: u8 = 0x09;
    let u32_at = |b: &[u8], i: usize| -> Option<u64> {
        Some(u32::from_le_bytes(b.get(i..i + 4)?.try_into().ok()?) as u64)
    };
    let u64_at = |b: &[u8], i: usize| -> Option<u64> {
        Some(u64::from_le_bytes(b.get(i..i + 8)?.try_into().ok()?))
    };
    let fits = |body: &[u8]| -> Option<()> {
        // log_time, create_time, then two strings, then the data's length and the data, and a CRC.
        let mut at = 16u64;
        for _ in 0..2 {
            at = at.checked_add(4 + u32_at(body, at as usize)?)?;
        }
        let data_len = u64_at(body, at as usize)?;
        let end = at.checked_add(8)?.checked_add(data_len)?.checked_add(4)?;
        (end <= body.len() as u64).then_some(())
    };
    let mut at = 0usize;
    while let (Some(&op), Some(len)) = (records.get(at), u64_at(records, at + 1)) {
        let start = at + 9;
        let end = usize::try_from(len)
            .ok()
            .and_then(|l| start.checked_add(l))?;
        let body = records.get(start..end)?;
        if op == ATTACHMENT && fits(body).is_none() {
            return Some(at);
        }
        at = end;
    }
    None
}

/// The records of a chunk, decompressed into a buffer of the declared size (already checked to
/// be sane) and checked against the chunk's CRC. Done here rather than by mcap's ChunkReader,
/// which sets no limit on the length of the records inside a chunk: a damaged length there asks
/// for an absurd allocation; `LinearReader::sans_magic` over the buffer bounds it.
fn decompress_chunk(header: &mcap::records::ChunkHeader, data: &[u8]) -> Result<Vec<u8>, String> {
    let size = header.uncompressed_size as usize;
    let out = match header.compression.as_str() {
        "" => data.to_vec(),
        "zstd" => zstd::bulk::decompress(data, size)
            .map_err(|e| format!("a chunk does not decompress: {e}"))?,
        other => {
            return Err(format!(
                "chunks compressed with {other:?} are not supported (zstd or none)"
            ));
        }
    };
    if out.len() != size {
        return Err(format!(
            "a chunk decompresses to {} bytes, not the {size} it declares",
            out.len()
        ));
    }
    if header.uncompressed_crc != 0 && crc32fast::hash(&out) != header.uncompressed_crc {
        return Err("a chunk fails its CRC check: damaged".into());
    }
    Ok(out)
}

/// A whole session in memory: topics, metadata and messages.
#[derive(Debug, Clone, Default)]
pub struct Session {
    /// The topics and metadata.
    pub scan: Scan,
    /// The messages, in log-time order.
    pub messages: Vec<MessageRef>,
}

impl std::ops::Deref for Session {
    type Target = Scan;
    fn deref(&self) -> &Scan {
        &self.scan
    }
}

/// Reads every complete message of `bytes`, in file order (which need not be log-time order).
pub fn read_session(bytes: &[u8]) -> Result<Session, RecordError> {
    let mut messages = Vec::new();
    let scan = scan(bytes, |_, m| messages.push(m.to_owned()))?;
    Ok(Session { scan, messages })
}

/// Why a message could not be decoded as the type asked for.
#[derive(Debug, thiserror::Error)]
pub enum DecodeError {
    #[error("{topic} carries {found}, not {wanted}")]
    /// A topic whose schema is not the type read.
    WrongType {
        /// The topic.
        topic: String,
        /// The type it carries.
        found: String,
        /// The type read.
        wanted: String,
    },
    #[error("{topic}: {error}")]
    /// A message that does not decode.
    Cdr {
        /// The topic.
        topic: String,
        /// Why it does not decode.
        error: CdrError,
    },
}

impl Scan {
    /// Decodes a message of this scan as `M`, checking the topic's type.
    pub fn decode<M: RosMessage>(&self, m: &MessageRef) -> Result<M, DecodeError> {
        let t = &self.topics[m.topic];
        if !same_type(&t.type_name, &M::type_name()) {
            return Err(DecodeError::WrongType {
                topic: t.topic.clone(),
                found: t.type_name.clone(),
                wanted: M::type_name(),
            });
        }
        self.decode_checked::<M>(m.topic, &m.data)
    }

    /// Decodes the bytes of a message on `topic` whose type the caller has checked once.
    pub fn decode_checked<M: RosMessage>(
        &self,
        topic: usize,
        data: &[u8],
    ) -> Result<M, DecodeError> {
        from_cdr::<M>(data).map_err(|error| DecodeError::Cdr {
            topic: self.topics[topic].topic.clone(),
            error,
        })
    }
}

/// `pkg/msg/Type` and `pkg/Type` name the same type (rosbag2 writes the former, some tools the
/// latter).
pub fn same_type(a: &str, b: &str) -> bool {
    let norm = |s: &str| s.replace("/msg/", "/");
    norm(a) == norm(b)
}

/// The file's topics, counts and metadata from its summary section, without reading the
/// messages: `None` when the file has no readable summary (cut off, or written without one);
/// then [`scan`] is the way.
pub fn summary_head(bytes: &[u8]) -> Option<Scan> {
    head_of(&mcap::read::Summary::read(bytes).ok()??, |i| {
        metadata_in(bytes, i)
    })
}

/// The metadata record that `index` points to in a file in memory, if it is there.
fn metadata_in(
    bytes: &[u8],
    index: &mcap::records::MetadataIndex,
) -> Option<mcap::records::Metadata> {
    let end = index.offset.checked_add(index.length)?;
    if end > bytes.len() as u64 {
        return None;
    }
    mcap::read::metadata(bytes, index).ok()
}

/// [`summary_head`] from a summary already read, with its metadata records from `metadata`.
fn head_of(
    summary: &mcap::read::Summary,
    metadata: impl Fn(&mcap::records::MetadataIndex) -> Option<mcap::records::Metadata>,
) -> Option<Scan> {
    let stats = summary.stats.as_ref()?;
    let mut s = Scan {
        complete: true,
        messages: stats.message_count,
        start_ns: Some(stats.message_start_time),
        end_ns: Some(stats.message_end_time),
        ..Default::default()
    };
    let mut ids: Vec<&u16> = summary.channels.keys().collect();
    ids.sort();
    for id in ids {
        let c = &summary.channels[id];
        let schema = c.schema.as_ref();
        s.topics.push(TopicInfo {
            topic: c.topic.clone(),
            type_name: schema.map(|x| x.name.clone()).unwrap_or_default(),
            schema_text: schema
                .map(|x| String::from_utf8_lossy(&x.data).into_owned())
                .unwrap_or_default(),
            encoding: c.message_encoding.clone(),
            channel_metadata: c.metadata.clone(),
            count: stats.channel_message_counts.get(id).copied().unwrap_or(0),
        });
    }
    for index in &summary.metadata_indexes {
        let md = metadata(index)?;
        s.metadata.insert(md.name, md.metadata);
    }
    Some(s)
}

/// What [`scan_topics`] reads: a session in memory, or an [`IndexedFile`].
#[derive(Clone, Copy)]
pub enum Source<'a> {
    /// A whole file in memory.
    Bytes(&'a [u8]),
    /// A file read through its index.
    Indexed(&'a IndexedFile),
}

impl<'a> From<&'a [u8]> for Source<'a> {
    fn from(b: &'a [u8]) -> Self {
        Source::Bytes(b)
    }
}

impl<'a> From<&'a Vec<u8>> for Source<'a> {
    fn from(b: &'a Vec<u8>) -> Self {
        Source::Bytes(b)
    }
}

impl<'a> From<&'a IndexedFile> for Source<'a> {
    fn from(f: &'a IndexedFile) -> Self {
        Source::Indexed(f)
    }
}

/// A finished session file of which only the summary (and the metadata records it points to)
/// is read up front; [`scan_topics`] reads the chunks it wants from the file as it goes. A long
/// session then needs neither its size in memory nor the time to read chunks that are passed
/// over.
pub struct IndexedFile {
    file: std::fs::File,
    /// The file's length when it was opened.
    len: u64,
    indexed: Indexed,
}

impl IndexedFile {
    /// `None` if the file has no readable summary (a cut-off file, or not MCAP): read it whole.
    pub fn open(path: &std::path::Path) -> std::io::Result<Option<IndexedFile>> {
        use mcap::sans_io::{SummaryReadEvent, SummaryReader, SummaryReaderOptions};
        use std::io::{Read, Seek};
        use std::os::unix::fs::FileExt;
        let mut file = std::fs::File::open(path)?;
        let len = file.metadata()?.len();
        let mut reader =
            SummaryReader::new_with_options(SummaryReaderOptions::default().with_file_size(len));
        while let Some(event) = reader.next_event() {
            match event {
                Ok(SummaryReadEvent::ReadRequest(n)) => {
                    let got = file.read(reader.insert(n))?;
                    reader.notify_read(got);
                }
                Ok(SummaryReadEvent::SeekRequest(to)) => {
                    let at = file.seek(to)?;
                    reader.notify_seeked(at);
                }
                Err(_) => return Ok(None),
            }
        }
        let Some(summary) = reader.finish() else {
            return Ok(None);
        };
        // Each metadata record, read on its own and parsed as if it began the file.
        let metadata = |i: &mcap::records::MetadataIndex| {
            let end = i.offset.checked_add(i.length)?;
            if end > len || i.length > MAX_CHUNK_BYTES {
                return None;
            }
            let mut record = vec![0u8; i.length as usize];
            file.read_exact_at(&mut record, i.offset).ok()?;
            let at_start = mcap::records::MetadataIndex {
                offset: 0,
                ..i.clone()
            };
            mcap::read::metadata(&record, &at_start).ok()
        };
        let Some(head) = head_of(&summary, metadata) else {
            return Ok(None);
        };
        Ok(Some(IndexedFile {
            indexed: indexed_from(summary, head),
            file,
            len,
        }))
    }

    /// The session's topics, counts and metadata, from its summary.
    pub fn head(&self) -> &Scan {
        &self.indexed.0
    }
}

/// Like [`scan`], but hands on only the messages of the topics `wanted` picks, and reads only
/// the chunks that hold any: with the file's summary, chunks without a wanted channel (the
/// node's outputs, which the recorder writes in chunks of their own) are skipped without being
/// decompressed, and the next chunk is decompressed on a second thread while this one is read.
/// Without a readable summary (a cut-off file), it is [`scan`] with the unwanted messages
/// dropped. The returned scan lists every topic of the file.
pub fn scan_topics<'a>(
    source: impl Into<Source<'a>>,
    wanted: impl Fn(&TopicInfo) -> bool,
    mut visit: impl FnMut(&Scan, MessageView),
) -> Result<Scan, RecordError> {
    let (bytes, file, indexed): (&[u8], _, _) = match source.into() {
        Source::Bytes(b) => (b, None, indexed(b)),
        Source::Indexed(f) => (&[], Some((&f.file, f.len)), Some(f.indexed.clone())),
    };
    let Some((mut s, chunks, topic_of_channel)) = indexed else {
        let mut want: Vec<Option<bool>> = Vec::new();
        return scan(bytes, |s, m| {
            if want.len() < s.topics.len() {
                want.resize(s.topics.len(), None);
            }
            if *want[m.topic].get_or_insert_with(|| wanted(&s.topics[m.topic])) {
                visit(s, m);
            }
        });
    };
    let want: Vec<bool> = s.topics.iter().map(&wanted).collect();
    // Per channel id: the topic index, if its messages are wanted.
    let route: Vec<Option<usize>> = topic_of_channel
        .iter()
        .map(|t| t.filter(|&i| want[i]))
        .collect();
    let chunks: Vec<&mcap::records::ChunkIndex> = chunks
        .iter()
        .filter(|c| {
            c.message_index_offsets.is_empty()
                || c.message_index_offsets
                    .keys()
                    .any(|&id| route.get(id as usize).copied().flatten().is_some())
        })
        .collect();
    let mut stopped: Option<String> = None;
    std::thread::scope(|scope| {
        let (tx, rx) = std::sync::mpsc::sync_channel::<Result<Vec<u8>, String>>(2);
        scope.spawn(move || {
            let mut record = Vec::new();
            for c in chunks {
                let r = match file {
                    Some(f) => read_chunk(f, c, &mut record).and_then(|()| chunk_records(&record)),
                    None => chunk_at(bytes, c).and_then(chunk_records),
                };
                let failed = r.is_err();
                if tx.send(r).is_err() || failed {
                    return;
                }
            }
        });
        for records in rx {
            let records = match records {
                Ok(r) => r,
                Err(e) => {
                    stopped = Some(e);
                    break;
                }
            };
            if let Err(e) =
                message_records(&records, |channel, log_time_ns, publish_time_ns, data| {
                    if let Some(Some(topic)) = route.get(channel as usize) {
                        visit(
                            &s,
                            MessageView {
                                topic: *topic,
                                log_time_ns,
                                publish_time_ns,
                                data,
                            },
                        );
                    }
                })
            {
                stopped = Some(e);
                break;
            }
        }
    });
    if stopped.is_some() {
        s.complete = false;
        s.stopped = stopped;
    }
    Ok(s)
}

type Indexed = (Scan, Vec<mcap::records::ChunkIndex>, Vec<Option<usize>>);

/// The file's head from its summary, its chunk indexes in file order, and per channel id the
/// index of its topic in the head.
fn indexed(bytes: &[u8]) -> Option<Indexed> {
    let summary = mcap::read::Summary::read(bytes).ok()??;
    let head = head_of(&summary, |i| metadata_in(bytes, i))?;
    Some(indexed_from(summary, head))
}

fn indexed_from(summary: mcap::read::Summary, head: Scan) -> Indexed {
    let mut ids: Vec<&u16> = summary.channels.keys().collect();
    ids.sort();
    let mut topic_of_channel = vec![None; ids.last().map_or(0, |&&id| id as usize + 1)];
    for (i, &&id) in ids.iter().enumerate() {
        topic_of_channel[id as usize] = Some(i);
    }
    let mut chunks = summary.chunk_indexes;
    chunks.sort_by_key(|c| c.chunk_start_offset);
    (head, chunks, topic_of_channel)
}

/// The chunk record that `index` points to in a file in memory.
fn chunk_at<'b>(bytes: &'b [u8], index: &mcap::records::ChunkIndex) -> Result<&'b [u8], String> {
    let start = usize::try_from(index.chunk_start_offset).unwrap_or(usize::MAX);
    let end = usize::try_from(index.chunk_length)
        .ok()
        .and_then(|l| start.checked_add(l))
        .filter(|&e| e <= bytes.len())
        .ok_or_else(|| "a chunk index points past the end of the file: damaged".to_string())?;
    Ok(&bytes[start..end])
}

/// The chunk record that `index` points to, read from `file` into `record`.
/// `file_len` is the file's length when it was opened: an index past it is refused before
/// anything is allocated for it.
fn read_chunk(
    (file, file_len): (&std::fs::File, u64),
    index: &mcap::records::ChunkIndex,
    record: &mut Vec<u8>,
) -> Result<(), String> {
    use std::os::unix::fs::FileExt;
    let past_end = || "a chunk index points past the end of the file: damaged".to_string();
    let end = index.chunk_start_offset.checked_add(index.chunk_length);
    if end.is_none_or(|e| e > file_len) {
        return Err(past_end());
    }
    let len = usize::try_from(index.chunk_length)
        .ok()
        .filter(|&l| l as u64 <= MAX_CHUNK_BYTES)
        .ok_or_else(|| {
            format!(
                "a chunk index declares a chunk of {} bytes: damaged",
                index.chunk_length
            )
        })?;
    record.resize(len, 0);
    file.read_exact_at(record, index.chunk_start_offset)
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::UnexpectedEof => past_end(),
            _ => format!("cannot read a chunk: {e}"),
        })
}

/// The decompressed records of a chunk record, with the same checks as [`scan`].
fn chunk_records(record: &[u8]) -> Result<Vec<u8>, String> {
    use mcap::records::Record;
    let body = record
        .get(9..)
        .filter(|_| record[0] == mcap::records::op::CHUNK)
        .ok_or_else(|| "a chunk index points at no chunk: damaged".to_string())?;
    match mcap::read::parse_record(mcap::records::op::CHUNK, body) {
        Ok(Record::Chunk { header, data }) => {
            let declared = header.uncompressed_size;
            if declared > MAX_CHUNK_BYTES
                || declared > header.compressed_size.saturating_mul(1000) + (1 << 20)
            {
                return Err(format!(
                    "a chunk declares {declared} bytes uncompressed: damaged"
                ));
            }
            decompress_chunk(&header, &data)
        }
        Err(e) => Err(e.to_string()),
        Ok(_) => Err("a chunk index points at no chunk: damaged".into()),
    }
}

/// Calls `f(channel, log_time, publish_time, data)` for every message record in the
/// decompressed records of a chunk; other records (schemas, channels) are passed over. Every
/// length is checked against the buffer.
///
/// Hand-written beside mcap's record reader because a message record is a fixed 22-byte header
/// and its data, which needs no generic parse: `cargo bench --bench session` measures the two on
/// the same chunk (`docs/benchmarks.md`), and a property test (`tests/properties.rs`) checks that
/// they read the same messages.
pub fn message_records(
    records: &[u8],
    mut f: impl FnMut(u16, u64, u64, &[u8]),
) -> Result<(), String> {
    const MESSAGE: u8 = 0x05;
    let damaged = || "a record in a chunk runs past the chunk's end: damaged".to_string();
    let mut rest = records;
    while !rest.is_empty() {
        let (&op, after_op) = rest.split_first().ok_or_else(damaged)?;
        let len_bytes: [u8; 8] = after_op
            .get(..8)
            .and_then(|b| b.try_into().ok())
            .ok_or_else(damaged)?;
        let len = usize::try_from(u64::from_le_bytes(len_bytes)).map_err(|_| damaged())?;
        let body = after_op
            .get(8..)
            .and_then(|b| b.get(..len))
            .ok_or_else(damaged)?;
        rest = &after_op[8 + len..];
        if op == MESSAGE {
            if body.len() < 22 {
                return Err("a message record is shorter than its header: damaged".into());
            }
            let u64_at = |i: usize| {
                let mut b = [0u8; 8];
                b.copy_from_slice(&body[i..i + 8]);
                u64::from_le_bytes(b)
            };
            let channel = u16::from_le_bytes([body[0], body[1]]);
            f(channel, u64_at(6), u64_at(14), &body[22..]);
        }
    }
    Ok(())
}
