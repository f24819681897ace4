//! Reading sessions: our own recordings and any ROS 2 MCAP (rosbag2, rosbags, Foxglove), whole or
//! cut off. Reading stops at the first damaged record and says so; nothing here panics on bad
//! bytes.

use super::RecordError;
use crate::msgs::{CdrError, RosMessage, from_cdr};
use std::collections::BTreeMap;

/// A topic of a session.
#[derive(Debug, Clone, PartialEq)]
pub struct TopicInfo {
    pub topic: String,
    /// `pkg/msg/Type`
    pub type_name: String,
    pub schema_text: String,
    /// `cdr` for ROS 2; other encodings are listed but their messages are not decoded.
    pub encoding: String,
    pub channel_metadata: BTreeMap<String, String>,
    pub count: u64,
}

/// One message, as stored.
#[derive(Debug, Clone, PartialEq)]
pub struct MessageRef {
    pub topic: usize,
    pub log_time_ns: u64,
    pub publish_time_ns: u64,
    pub data: Vec<u8>,
}

/// One message during a scan, borrowing its bytes (no copy per message).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MessageView<'a> {
    pub topic: usize,
    pub log_time_ns: u64,
    pub publish_time_ns: u64,
    pub data: &'a [u8],
}

impl MessageView<'_> {
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
    pub topics: Vec<TopicInfo>,
    /// Metadata records by name.
    pub metadata: BTreeMap<String, BTreeMap<String, String>>,
    pub messages: u64,
    pub start_ns: Option<u64>,
    pub end_ns: Option<u64>,
    /// The file ends as a finished MCAP does (footer, summary, end magic).
    pub complete: bool,
    /// Why reading stopped early, if it did.
    pub stopped: Option<String>,
}

impl Scan {
    pub fn duration_s(&self) -> f64 {
        match (self.start_ns, self.end_ns) {
            (Some(a), Some(b)) => b.saturating_sub(a) as f64 * 1e-9,
            _ => 0.0,
        }
    }

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
    let reader = mcap::read::LinearReader::new_with_options(bytes, opts)?;
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
            for r in mcap::read::LinearReader::sans_magic(&records) {
                match r.map_err(|e| e.to_string()).and_then(|r| handle(r, &mut s)) {
                    Ok(()) => {}
                    Err(e) => {
                        s.stopped = Some(e);
                        break 'records;
                    }
                }
            }
        } else if let Err(e) = handle(rec, &mut s) {
            s.stopped = Some(e);
            break;
        }
    }
    // Not mcap::Summary::read: it trusts the offsets in the footer, which may be damaged.
    s.complete = s.stopped.is_none() && footer && bytes.ends_with(mcap::MAGIC);
    Ok(s)
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
    pub scan: Scan,
    pub messages: Vec<MessageRef>,
}

impl std::ops::Deref for Session {
    type Target = Scan;
    fn deref(&self) -> &Scan {
        &self.scan
    }
}

/// Reads every complete message of `bytes`.
pub fn read_session(bytes: &[u8]) -> Result<Session, RecordError> {
    let mut messages = Vec::new();
    let scan = scan(bytes, |_, m| messages.push(m.to_owned()))?;
    Ok(Session { scan, messages })
}

/// Why a message could not be decoded as the type asked for.
#[derive(Debug, thiserror::Error)]
pub enum DecodeError {
    #[error("{topic} carries {found}, not {wanted}")]
    WrongType {
        topic: String,
        found: String,
        wanted: String,
    },
    #[error("{topic}: {error}")]
    Cdr { topic: String, error: CdrError },
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
    let summary = mcap::read::Summary::read(bytes).ok()??;
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
        let md = mcap::read::metadata(bytes, index).ok()?;
        s.metadata.insert(md.name, md.metadata);
    }
    Some(s)
}
