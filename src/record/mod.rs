//! Sessions as ROS 2 MCAP files, as `ros2 bag record` writes them, so that `ros2 bag play`,
//! Foxglove and rosbags open them: profile `ros2`, one channel per topic with a `ros2msg` schema
//! carrying the full definition, `cdr` messages with their encapsulation header,
//! `offered_qos_profiles` channel metadata, zstd chunks, a `rosbag2` metadata record, and the
//! node's parameters in a `terzaghi_params` metadata record.
//!
//! [`SessionWriter`] is generic over `Write + Seek` and reads no clock: times come in with each
//! message, and [`SessionWriter::maybe_flush`] closes the open chunk once `flush_period` of
//! log time has passed, so that a killed process loses at most that much. The node's outputs
//! ([`SessionWriter::write_output`]) go to chunks of their own, which readers of the inputs skip
//! ([`read::scan_topics`]). [`read`] reads files
//! written by any ROS 2 tool, cut off or not; [`recover`](fn@recover) rewrites a cut-off file whole.

pub mod read;
#[cfg(feature = "node")]
pub(crate) mod recorder;
pub mod recover;

use crate::msgs::RosMessage;
use std::collections::{BTreeMap, HashMap};
use std::io::{Seek, Write};

pub use read::{MessageRef, Session, TopicInfo, read_session};
pub use recover::recover;

/// What went wrong with a recording.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    // Not `#[from]`, which would make the inner error the source as well, and `{e:#}` would
    // print its text twice.
    #[error("MCAP: {0}")]
    /// The MCAP writer's error.
    Mcap(mcap::McapError),
    #[error("cannot encode a message on {topic}: {error}")]
    /// A message that does not encode as CDR.
    Encode {
        /// The topic.
        topic: String,
        /// Why it does not encode.
        error: String,
    },
    #[error(transparent)]
    /// The file's input or output failed.
    Io(#[from] std::io::Error),
}

impl From<mcap::McapError> for RecordError {
    fn from(e: mcap::McapError) -> Self {
        RecordError::Mcap(e)
    }
}

/// The QoS a topic was offered with, as rosbag2 records it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OfferedQos {
    /// Whether the publisher was reliable (else best effort).
    pub reliable: bool,
    /// Its history depth.
    pub depth: u32,
}

impl OfferedQos {
    /// Reliable, depth 10: what ROS publishers offer by default.
    pub const RELIABLE: OfferedQos = OfferedQos {
        reliable: true,
        depth: 10,
    };
    /// Best effort, depth 10: what sensor publishers offer.
    pub const BEST_EFFORT: OfferedQos = OfferedQos {
        reliable: false,
        depth: 10,
    };

    /// The YAML list rosbag2 stores in the channel metadata `offered_qos_profiles`.
    pub fn yaml(self) -> String {
        let inf = "\n    sec: 2147483647\n    nsec: 4294967295";
        format!(
            "- history: 1\n  depth: {}\n  reliability: {}\n  durability: 2\n  deadline:{inf}\n  lifespan:{inf}\n  liveliness: 1\n  liveliness_lease_duration:{inf}\n  avoid_ros_namespace_conventions: false",
            self.depth,
            if self.reliable { 1 } else { 2 }
        )
    }
}

/// Appends `msg` as CDR (little-endian, with its encapsulation header) to `out`; on an error,
/// `out` is left as it was.
fn append_cdr<M: RosMessage>(out: &mut Vec<u8>, topic: &str, msg: &M) -> Result<(), RecordError> {
    let start = out.len();
    out.extend_from_slice(&[0x00, 0x01, 0x00, 0x00]);
    cdr_encoding::to_writer::<_, byteorder::LittleEndian, _>(&mut *out, msg).map_err(|e| {
        out.truncate(start);
        RecordError::Encode {
            topic: topic.to_string(),
            error: e.to_string(),
        }
    })
}

/// Options of a recording.
#[derive(Debug, Clone)]
pub struct RecordOptions {
    /// Close the open chunk when this much log time has passed since the last flush (ns).
    pub flush_period_ns: u64,
    /// zstd level (1 is fast and already compresses ROS messages about 4x).
    pub compression_level: u32,
    /// Stored as the `terzaghi_params` metadata record (name -> YAML value).
    pub params: BTreeMap<String, String>,
}

impl Default for RecordOptions {
    fn default() -> Self {
        RecordOptions {
            flush_period_ns: 1_000_000_000,
            compression_level: 1,
            params: BTreeMap::new(),
        }
    }
}

impl RecordOptions {
    /// The default options, with a node's parameters (and its name and namespace) to store as
    /// the session's `terzaghi_params` metadata, so that the session can be re-run exactly.
    pub fn with_node_params(
        params: &crate::config::ParamMap,
        node_name: &str,
        namespace: &str,
    ) -> Self {
        let mut meta: BTreeMap<String, String> = params
            .iter()
            .map(|(k, v)| (k.clone(), v.to_string()))
            .collect();
        meta.insert("__node".into(), node_name.to_string());
        meta.insert("__ns".into(), namespace.to_string());
        RecordOptions {
            params: meta,
            ..Default::default()
        }
    }
}

struct Channel {
    id: u16,
    type_name: String,
    qos: OfferedQos,
    count: u64,
}

/// Output messages held back for chunks of their own (see [`SessionWriter::write_output`]).
#[derive(Default)]
struct Apart {
    data: Vec<u8>,
    /// channel, sequence, log time, publish time, end of its bytes in `data`.
    messages: Vec<(u16, u32, u64, u64, usize)>,
}

/// Held-back outputs go to their chunks at the latest when they reach this size.
const APART_BYTES: usize = 4 * 1024 * 1024;

/// Writes a session, message by message.
pub struct SessionWriter<W: Write + Seek> {
    mcap: mcap::Writer<W>,
    apart: Apart,
    channels: HashMap<String, Channel>,
    schemas: HashMap<String, u16>,
    last_flush_ns: Option<u64>,
    first_ns: Option<u64>,
    last_ns: u64,
    opts: RecordOptions,
    buf: Vec<u8>,
}

impl<W: Write + Seek> SessionWriter<W> {
    /// A session writer into `w`, with `opts`.
    pub fn new(w: W, opts: RecordOptions) -> Result<Self, RecordError> {
        let mcap = mcap::WriteOptions::new()
            .profile("ros2")
            .library(format!("terzaghi {}", env!("CARGO_PKG_VERSION")))
            .compression(Some(mcap::Compression::Zstd))
            .compression_level(opts.compression_level)
            .chunk_size(Some(4 * 1024 * 1024))
            .create(w)?;
        let mut s = SessionWriter {
            mcap,
            apart: Apart::default(),
            channels: HashMap::new(),
            schemas: HashMap::new(),
            last_flush_ns: None,
            first_ns: None,
            last_ns: 0,
            opts,
            buf: Vec::with_capacity(1024),
        };
        if !s.opts.params.is_empty() {
            s.mcap.write_metadata(&mcap::records::Metadata {
                name: "terzaghi_params".into(),
                metadata: s.opts.params.clone(),
            })?;
        }
        Ok(s)
    }

    /// The channel of `topic` (added on first use) for messages of type `M`.
    pub fn channel<M: RosMessage>(
        &mut self,
        topic: &str,
        qos: OfferedQos,
    ) -> Result<u16, RecordError> {
        self.channel_raw(topic, &M::type_name(), &M::schema_text(), qos)
    }

    /// The channel of `topic` for a type given by name and schema text.
    pub fn channel_raw(
        &mut self,
        topic: &str,
        type_name: &str,
        schema: &str,
        qos: OfferedQos,
    ) -> Result<u16, RecordError> {
        let meta = BTreeMap::from([("offered_qos_profiles".to_string(), qos.yaml())]);
        self.channel_with_metadata(topic, type_name, schema, qos, meta)
    }

    /// The channel of `topic` with the given channel metadata (kept as it was, when recovering).
    pub fn channel_with_metadata(
        &mut self,
        topic: &str,
        type_name: &str,
        schema: &str,
        qos: OfferedQos,
        meta: BTreeMap<String, String>,
    ) -> Result<u16, RecordError> {
        if let Some(c) = self.channels.get(topic) {
            return Ok(c.id);
        }
        let schema_id = match self.schemas.get(type_name) {
            Some(&id) => id,
            None => {
                let id = self
                    .mcap
                    .add_schema(type_name, "ros2msg", schema.as_bytes())?;
                self.schemas.insert(type_name.to_string(), id);
                id
            }
        };
        let id = self.mcap.add_channel(schema_id, topic, "cdr", &meta)?;
        self.channels.insert(
            topic.to_string(),
            Channel {
                id,
                type_name: type_name.to_string(),
                qos,
                count: 0,
            },
        );
        Ok(id)
    }

    /// Writes `msg` on `topic`: `log_time_ns` is when it was received, `publish_time_ns` its stamp.
    pub fn write<M: RosMessage>(
        &mut self,
        topic: &str,
        qos: OfferedQos,
        msg: &M,
        log_time_ns: u64,
        publish_time_ns: u64,
    ) -> Result<(), RecordError> {
        let id = self.channel::<M>(topic, qos)?;
        self.buf.clear();
        append_cdr(&mut self.buf, topic, msg)?;
        let data = std::mem::take(&mut self.buf);
        let r = self.write_cdr(id, topic, &data, log_time_ns, publish_time_ns);
        self.buf = data;
        r
    }

    /// Writes an output of the node (a prediction, parameters, diagnostics) like [`Self::write`],
    /// but in chunks apart from the inputs: they are held back and written as chunks of their
    /// own at each flush, so that a reader that wants only the inputs (a re-evaluation, a
    /// diagnosis) skips the outputs' chunks without decompressing them. A killed process loses
    /// no more of them than of the inputs (one flush period).
    pub fn write_output<M: RosMessage>(
        &mut self,
        topic: &str,
        qos: OfferedQos,
        msg: &M,
        log_time_ns: u64,
        publish_time_ns: u64,
    ) -> Result<(), RecordError> {
        let id = self.channel::<M>(topic, qos)?;
        append_cdr(&mut self.apart.data, topic, msg)?;
        let seq = self.next_sequence(id, topic)?;
        let end = self.apart.data.len();
        self.apart
            .messages
            .push((id, seq, log_time_ns, publish_time_ns, end));
        self.first_ns.get_or_insert(log_time_ns);
        self.last_ns = self.last_ns.max(log_time_ns);
        if self.apart.data.len() >= APART_BYTES {
            self.flush_apart()?;
        }
        self.maybe_flush(log_time_ns)
    }

    /// Closes the open chunk, then writes the held-back outputs as chunks of their own.
    fn flush_apart(&mut self) -> Result<(), RecordError> {
        self.mcap.flush()?;
        if self.apart.messages.is_empty() {
            return Ok(());
        }
        let mut start = 0;
        for &(channel_id, sequence, log_time, publish_time, end) in &self.apart.messages {
            self.mcap.write_to_known_channel(
                &mcap::records::MessageHeader {
                    channel_id,
                    sequence,
                    log_time,
                    publish_time,
                },
                &self.apart.data[start..end],
            )?;
            start = end;
        }
        self.apart.messages.clear();
        self.apart.data.clear();
        self.mcap.flush()?;
        Ok(())
    }

    /// The next sequence number on `channel` (which must be `topic`'s), counting the message.
    fn next_sequence(&mut self, channel: u16, topic: &str) -> Result<u32, RecordError> {
        let c = self.channels.get_mut(topic).filter(|c| c.id == channel);
        let Some(c) = c else {
            return Err(RecordError::Mcap(mcap::McapError::UnknownChannel(
                0, channel,
            )));
        };
        c.count += 1;
        Ok(c.count as u32)
    }

    /// Writes CDR bytes (with their encapsulation header) on a channel of this writer.
    pub fn write_cdr(
        &mut self,
        channel: u16,
        topic: &str,
        cdr: &[u8],
        log_time_ns: u64,
        publish_time_ns: u64,
    ) -> Result<(), RecordError> {
        let seq = self.next_sequence(channel, topic)?;
        self.mcap.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: channel,
                sequence: seq,
                log_time: log_time_ns,
                publish_time: publish_time_ns,
            },
            cdr,
        )?;
        self.first_ns.get_or_insert(log_time_ns);
        self.last_ns = self.last_ns.max(log_time_ns);
        self.maybe_flush(log_time_ns)
    }

    /// Closes the open chunk if `flush_period` has passed since the last flush (by `now_ns`).
    pub fn maybe_flush(&mut self, now_ns: u64) -> Result<(), RecordError> {
        match self.last_flush_ns {
            None => self.last_flush_ns = Some(now_ns),
            Some(last) if now_ns.saturating_sub(last) >= self.opts.flush_period_ns => {
                self.flush_apart()?;
                self.last_flush_ns = Some(now_ns);
            }
            _ => {}
        }
        Ok(())
    }

    /// Writes a metadata record.
    pub fn write_metadata(
        &mut self,
        name: &str,
        metadata: BTreeMap<String, String>,
    ) -> Result<(), RecordError> {
        self.mcap.write_metadata(&mcap::records::Metadata {
            name: name.to_string(),
            metadata,
        })?;
        Ok(())
    }

    /// Messages written per topic.
    pub fn counts(&self) -> BTreeMap<String, u64> {
        self.channels
            .iter()
            .map(|(t, c)| (t.clone(), c.count))
            .collect()
    }

    /// Writes the `rosbag2` metadata and the summary, and returns the underlying writer.
    pub fn finish(mut self) -> Result<W, RecordError> {
        self.flush_apart()?;
        let meta = self.rosbag2_metadata();
        self.mcap.write_metadata(&mcap::records::Metadata {
            name: "rosbag2".into(),
            metadata: BTreeMap::from([("serialized_metadata".to_string(), meta)]),
        })?;
        self.mcap.finish()?;
        Ok(self.mcap.into_inner())
    }

    /// rosbag2's bag metadata (YAML), as its MCAP storage plugin stores it.
    fn rosbag2_metadata(&self) -> String {
        let start = self.first_ns.unwrap_or(0);
        let total: u64 = self.channels.values().map(|c| c.count).sum();
        let mut topics: Vec<(&String, &Channel)> = self.channels.iter().collect();
        topics.sort_by_key(|(t, _)| t.as_str());
        let mut s = format!(
            "rosbag2_bagfile_information:\n  version: 9\n  storage_identifier: mcap\n  duration:\n    nanoseconds: {}\n  starting_time:\n    nanoseconds_since_epoch: {}\n  message_count: {}\n  topics_with_message_count:\n",
            self.last_ns.saturating_sub(start),
            start,
            total
        );
        for (topic, c) in topics {
            let qos = c.qos.yaml().replace('\n', "\n        ");
            s += &format!(
                "    - topic_metadata:\n        name: {topic}\n        type: {}\n        serialization_format: cdr\n        offered_qos_profiles:\n          {}\n        type_description_hash: \"\"\n      message_count: {}\n",
                c.type_name,
                qos.replace("\n        ", "\n          "),
                c.count
            );
        }
        s += "  compression_format: \"\"\n  compression_mode: \"\"\n  relative_file_paths: []\n  files: []\n  custom_data: ~\n  ros_distro: jazzy\n";
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msgs::{Header, JointState, Time};

    #[test]
    fn writes_a_file_that_reads_back_and_flushes_by_time() {
        let mut w =
            SessionWriter::new(std::io::Cursor::new(Vec::new()), RecordOptions::default()).unwrap();
        for i in 0..2500u64 {
            let t = 1_000_000_000 + i * 1_000_000;
            let m = JointState {
                header: Header {
                    stamp: Time::from_nanos(t as i64).unwrap(),
                    frame_id: String::new(),
                },
                name: vec!["hip".into()],
                position: vec![i as f64],
                velocity: vec![],
                effort: vec![],
            };
            w.write("/joint_states", OfferedQos::BEST_EFFORT, &m, t + 5, t)
                .unwrap();
        }
        let bytes = w.finish().unwrap().into_inner();
        let session = read_session(&bytes).unwrap();
        assert!(session.complete);
        assert_eq!(session.messages.len(), 2500);
        assert_eq!(session.topics[0].count, 2500);
        let m: JointState = session.decode(&session.messages[10]).unwrap();
        assert_eq!(m.position, vec![10.0]);
        // 2.5 s of log time with a 1 s flush period: at least two chunks closed before the end.
        let chunks = mcap::read::LinearReader::new(&bytes)
            .unwrap()
            .filter(|r| matches!(r, Ok(mcap::records::Record::Chunk { .. })))
            .count();
        assert!(chunks >= 3, "{chunks} chunks");
    }

    /// Outputs go to chunks of their own; a reader of the inputs alone skips those chunks and
    /// gets the same inputs, in order, as a full scan; a cut-off copy reads the same way too.
    #[test]
    fn outputs_are_chunked_apart_and_skipped_by_a_reader_of_inputs() {
        let mut w =
            SessionWriter::new(std::io::Cursor::new(Vec::new()), RecordOptions::default()).unwrap();
        let joints = |i: u64, t: u64| JointState {
            header: Header {
                stamp: Time::from_nanos(t as i64).unwrap(),
                frame_id: String::new(),
            },
            name: vec!["hip".into()],
            position: vec![i as f64],
            velocity: vec![],
            effort: vec![],
        };
        for i in 0..3000u64 {
            let t = 1_000_000_000 + i * 1_000_000;
            w.write(
                "/joint_states",
                OfferedQos::BEST_EFFORT,
                &joints(i, t),
                t,
                t,
            )
            .unwrap();
            w.write_output("/out", OfferedQos::RELIABLE, &joints(i, t), t + 1, t)
                .unwrap();
        }
        let bytes = w.finish().unwrap().into_inner();
        // Every chunk holds inputs only or outputs only.
        let summary = mcap::read::Summary::read(&bytes).unwrap().unwrap();
        let input_id = summary
            .channels
            .values()
            .find(|c| c.topic == "/joint_states")
            .unwrap()
            .id;
        let mut kinds = summary.chunk_indexes.iter().map(|c| {
            let has_input = c.message_index_offsets.contains_key(&input_id);
            assert!(!has_input || c.message_index_offsets.len() == 1);
            has_input
        });
        assert!(kinds.any(|k| k) && kinds.any(|k| !k));

        let read = |source: read::Source| {
            let mut got = Vec::new();
            let s = read::scan_topics(
                source,
                |t| t.topic == "/joint_states",
                |s, m| {
                    let js: JointState = s.decode_checked(m.topic, m.data).unwrap();
                    got.push((m.log_time_ns, js.position[0]));
                },
            )
            .unwrap();
            (s, got)
        };
        let (s, got) = read((&bytes).into());
        assert!(s.complete);
        assert_eq!(s.topics.len(), 2);
        assert_eq!(got.len(), 3000);
        assert!(
            got.windows(2)
                .all(|w| w[0].0 < w[1].0 && w[1].1 == w[0].1 + 1.0)
        );
        let full = read_session(&bytes).unwrap();
        assert_eq!(full.messages.len(), 6000);

        // Cut off: no summary, read linearly; what it holds is a prefix of the inputs.
        let (s, cut) = read(bytes[..bytes.len() * 2 / 3].into());
        assert!(!s.complete);
        assert!(!cut.is_empty() && cut.len() < 3000);
        assert_eq!(cut[..], got[..cut.len()]);

        // From the file on disk, chunk by chunk: the same head and the same inputs.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.mcap");
        std::fs::write(&path, &bytes).unwrap();
        let file = read::IndexedFile::open(&path).unwrap().unwrap();
        assert_eq!(*file.head(), read::summary_head(&bytes).unwrap());
        assert_eq!(file.head().metadata.keys().count(), 1, "{:?}", file.head());
        let (s, from_file) = read((&file).into());
        assert!(s.complete);
        assert_eq!(from_file, got);
        // A file without a summary (cut off), or not MCAP, is to be read whole.
        std::fs::write(&path, &bytes[..bytes.len() - 100]).unwrap();
        assert!(read::IndexedFile::open(&path).unwrap().is_none());
        std::fs::write(
            &path,
            b"not an mcap file, but long enough to have a footer: 0123456789",
        )
        .unwrap();
        assert!(read::IndexedFile::open(&path).unwrap().is_none());
        // A file cut short after its summary was read: the scan stops and says so.
        std::fs::write(&path, &bytes).unwrap();
        let file = read::IndexedFile::open(&path).unwrap().unwrap();
        std::fs::OpenOptions::new()
            .write(true)
            .open(&path)
            .unwrap()
            .set_len(bytes.len() as u64 / 2)
            .unwrap();
        let (s, half) = read((&file).into());
        assert!(!s.complete);
        assert!(
            s.stopped.as_deref().unwrap().contains("past the end"),
            "{s:?}"
        );
        assert_eq!(half[..], got[..half.len()]);
    }

    /// An error's text appears once in `{:#}` (how the CLI prints errors), not once more as its
    /// own source.
    #[test]
    fn record_errors_say_what_is_wrong_once() {
        let e = anyhow::Error::from(read::scan(b"not mcap", |_, _| {}).unwrap_err());
        let text = format!("{e:#}");
        assert_eq!(text.matches("not an MCAP file").count(), 1, "{text}");
        let e = anyhow::Error::from(RecordError::from(mcap::McapError::BadMagic));
        let text = format!("{e:#}");
        assert!(text.starts_with("MCAP: "), "{text}");
        assert_eq!(
            text.matches(&mcap::McapError::BadMagic.to_string()).count(),
            1,
            "{text}"
        );
    }

    #[test]
    fn qos_yaml_is_a_list() {
        let y = OfferedQos::RELIABLE.yaml();
        assert!(y.starts_with("- history: 1\n  depth: 10\n  reliability: 1"));
        let v: serde_yaml_ng::Value = serde_yaml_ng::from_str(&y).unwrap();
        assert_eq!(v[0]["deadline"]["sec"].as_i64(), Some(2147483647));
    }
}
