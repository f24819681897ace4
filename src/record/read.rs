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

/// Scans `bytes` from the start, calling `visit(scan, message)` for every complete message, in
/// file order. An error only if `bytes` is not MCAP at all.
pub fn scan(bytes: &[u8], mut visit: impl FnMut(&Scan, MessageRef)) -> Result<Scan, RecordError> {
    if bytes.len() < mcap::MAGIC.len() || &bytes[..mcap::MAGIC.len()] != mcap::MAGIC {
        return Err(RecordError::Io(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            "not an MCAP file (no MCAP magic at the start)",
        )));
    }
    let mut s = Scan::default();
    let mut by_channel: BTreeMap<u16, usize> = BTreeMap::new();
    let opts = mcap::read::Options::IgnoreEndMagic.into();
    let stream = mcap::MessageStream::new_with_options(bytes, opts)?;
    for m in stream {
        let m = match m {
            Ok(m) => m,
            Err(e) => {
                s.stopped = Some(e.to_string());
                break;
            }
        };
        let idx = match by_channel.get(&m.channel.id) {
            Some(&i) => i,
            None => {
                let schema = m.channel.schema.as_ref();
                s.topics.push(TopicInfo {
                    topic: m.channel.topic.clone(),
                    type_name: schema.map(|x| x.name.clone()).unwrap_or_default(),
                    schema_text: schema
                        .map(|x| String::from_utf8_lossy(&x.data).into_owned())
                        .unwrap_or_default(),
                    encoding: m.channel.message_encoding.clone(),
                    channel_metadata: m.channel.metadata.clone(),
                    count: 0,
                });
                by_channel.insert(m.channel.id, s.topics.len() - 1);
                s.topics.len() - 1
            }
        };
        s.topics[idx].count += 1;
        s.messages += 1;
        s.start_ns = Some(s.start_ns.map_or(m.log_time, |v| v.min(m.log_time)));
        s.end_ns = Some(s.end_ns.map_or(m.log_time, |v| v.max(m.log_time)));
        visit(
            &s,
            MessageRef {
                topic: idx,
                log_time_ns: m.log_time,
                publish_time_ns: m.publish_time,
                data: m.data.into_owned(),
            },
        );
    }
    // Metadata records (outside chunks), up to the first damage.
    if let Ok(reader) = mcap::read::LinearReader::new_with_options(bytes, opts) {
        for r in reader {
            match r {
                Ok(mcap::records::Record::Metadata(md)) => {
                    s.metadata.insert(md.name, md.metadata);
                }
                Ok(_) => {}
                Err(_) => break,
            }
        }
    }
    s.complete = s.stopped.is_none()
        && bytes.ends_with(mcap::MAGIC)
        && matches!(mcap::Summary::read(bytes), Ok(Some(_)));
    Ok(s)
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
    let scan = scan(bytes, |_, m| messages.push(m))?;
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
        from_cdr::<M>(&m.data).map_err(|error| DecodeError::Cdr {
            topic: t.topic.clone(),
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
