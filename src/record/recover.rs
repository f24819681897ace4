//! Recovery of a cut-off recording: every complete message is written again to a valid file,
//! with its schema, channel metadata and the metadata records that survive.

use super::read::scan;
use super::{OfferedQos, RecordError, RecordOptions, SessionWriter};
use std::io::{Seek, Write};

/// What a recovery kept.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Recovered {
    /// Messages written again.
    pub messages: u64,
    /// Topics written again.
    pub topics: usize,
    /// Whether the input ended where a complete file ends (nothing was cut off).
    pub input_complete: bool,
    /// Why reading the input stopped, if it was damaged.
    pub stopped: Option<String>,
}

/// Reads `input` (an MCAP file, cut off at any byte or not) and writes its complete messages to
/// `out`. `progress` is called with the number of messages written so far.
pub fn recover<W: Write + Seek>(
    input: &[u8],
    out: W,
    mut progress: impl FnMut(u64),
) -> Result<(W, Recovered), RecordError> {
    let mut writer = SessionWriter::new(out, RecordOptions::default())?;
    let mut ids: Vec<Option<u16>> = Vec::new();
    let mut result: Result<(), RecordError> = Ok(());
    let mut written = 0u64;
    let s = scan(input, |scan, m| {
        if result.is_err() {
            return;
        }
        if ids.len() < scan.topics.len() {
            ids.resize(scan.topics.len(), None);
        }
        let t = &scan.topics[m.topic];
        let id = match ids[m.topic] {
            Some(id) => id,
            None => match writer.channel_with_metadata(
                &t.topic,
                &t.type_name,
                &t.schema_text,
                OfferedQos::RELIABLE,
                t.channel_metadata.clone(),
            ) {
                Ok(id) => {
                    ids[m.topic] = Some(id);
                    id
                }
                Err(e) => {
                    result = Err(e);
                    return;
                }
            },
        };
        result = writer.write_cdr(id, &t.topic, m.data, m.log_time_ns, m.publish_time_ns);
        written += 1;
        if written.is_multiple_of(10_000) {
            progress(written);
        }
    })?;
    result?;
    for (name, md) in &s.metadata {
        if name != "rosbag2" {
            writer.write_metadata(name, md.clone())?;
        }
    }
    progress(written);
    let out = writer.finish()?;
    Ok((
        out,
        Recovered {
            messages: written,
            topics: s.topics.len(),
            input_complete: s.complete,
            stopped: s.stopped,
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msgs::{Header, Time, WrenchStamped};
    use crate::record::read_session;

    fn session(n: u64) -> Vec<u8> {
        let opts = RecordOptions {
            flush_period_ns: 100_000_000,
            ..Default::default()
        };
        let mut w = SessionWriter::new(std::io::Cursor::new(Vec::new()), opts).unwrap();
        for i in 0..n {
            let t = 1_000_000_000 + i * 1_000_000;
            let m = WrenchStamped {
                header: Header {
                    stamp: Time::from_nanos(t as i64).unwrap(),
                    frame_id: "ft".into(),
                },
                ..Default::default()
            };
            w.write("/leg/ft", OfferedQos::BEST_EFFORT, &m, t, t)
                .unwrap();
        }
        w.finish().unwrap().into_inner()
    }

    #[test]
    fn a_cut_file_keeps_every_complete_chunk() {
        let full = session(1000);
        let cut = &full[..full.len() * 2 / 3];
        let (out, r) = recover(cut, std::io::Cursor::new(Vec::new()), |_| {}).unwrap();
        assert!(!r.input_complete);
        assert!(r.messages >= 500 && r.messages < 1000, "{r:?}");
        let fixed = read_session(&out.into_inner()).unwrap();
        assert!(fixed.complete);
        assert_eq!(fixed.messages.len() as u64, r.messages);
    }

    #[test]
    fn not_mcap_is_an_error_and_any_cut_is_not_a_panic() {
        assert!(
            recover(
                b"hello world, not mcap",
                std::io::Cursor::new(Vec::new()),
                |_| {}
            )
            .is_err()
        );
        let full = session(300);
        for cut in (0..full.len()).step_by(97) {
            let _ = recover(&full[..cut], std::io::Cursor::new(Vec::new()), |_| {});
        }
    }
}
