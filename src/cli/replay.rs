//! `terzaghi replay`: republish a session over DDS with its recorded timing (like `ros2 bag
//! play`), or re-evaluate it offline through the model and the estimator (`--reevaluate`).

use super::mcap_tools::{progress, read_file};
use super::write_atomically;
use crate::config::{NodeConfig, RosArgs, load_params};
use crate::model::Regime;
use crate::msgs::{DiagnosticArray, JointState, LegForce, ModelParams, RosMessage, WrenchStamped};
use crate::node::dds::{publisher, tool_node};
use crate::record::read::{IndexedFile, Scan, Source, read_session, same_type, scan};
use crate::record::reevaluate::{Output, Row, recorded_params, reevaluate, reevaluate_rows};
use crate::record::{OfferedQos, RecordOptions, SessionWriter};
use anyhow::{Context as _, Result, anyhow, bail};
use clap::Args;
use ros2_client::Publisher;
use std::path::PathBuf;
use std::time::{Duration, Instant};

#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// The MCAP session (ours, or any ROS 2 MCAP with JointState and WrenchStamped).
    pub file: PathBuf,
    /// Run the recorded joint states and F/T through the model and estimator offline, as fast as
    /// possible, instead of republishing.
    #[arg(long)]
    pub reevaluate: bool,
    /// --reevaluate: node parameters to use instead of the recorded ones.
    #[arg(long, value_name = "FILE")]
    pub params_file: Option<PathBuf>,
    /// --reevaluate: write to this file, .mcap (inputs and new outputs) or .csv (predictions next
    /// to measurements); default: CSV on standard output.
    #[arg(short, long, value_name = "OUT")]
    pub output: Option<PathBuf>,
    /// --reevaluate -o OUT.mcap: replace OUT.mcap if it exists (an existing recording is
    /// refused; a CSV output is replaced).
    #[arg(long)]
    pub overwrite: bool,
    /// Replay speed factor.
    #[arg(long, default_value_t = 1.0, conflicts_with = "as_fast_as_possible")]
    pub rate: f64,
    /// Replay without waiting.
    #[arg(long)]
    pub as_fast_as_possible: bool,
    /// Replay only these topics.
    #[arg(long, num_args = 1..)]
    pub topics: Vec<String>,
    /// Start again at the end, until interrupted.
    #[arg(long = "loop")]
    pub repeat: bool,
}

pub fn run(a: ReplayArgs) -> Result<()> {
    if a.reevaluate {
        return run_reevaluate(&a);
    }
    if a.params_file.is_some() || a.output.is_some() {
        bail!("--params-file and --output go with --reevaluate");
    }
    if !(a.rate.is_finite() && a.rate > 0.0) {
        bail!("--rate must be a positive number, got {}", a.rate);
    }
    run_dds(&a)
}

/// The CSV header of `replay --reevaluate`.
const CSV_HEADER: &str = "t_s,leg,beta_rad,regime,measured_drag_n,measured_lift_n,predicted_drag_n,predicted_lift_n,predicted_hip_torque_nm,b_k,a,identified\n";

/// Rows of `replay --reevaluate` as CSV. Written by hand rather than with the csv crate: every
/// field but the leg's name is a number, a fixed word or empty, and the csv crate's per-field
/// quoting checks and ryu were two thirds of the time of a long re-evaluation. Floats are in
/// their shortest exact form (zmij); legs' names are quoted by the csv crate, once.
struct CsvRows {
    /// Each leg's field, quoted as needed, with its comma.
    legs: Vec<Field>,
    /// By [`Regime::code`], with its comma.
    regimes: Vec<Field>,
    floats: FloatText,
}

/// A field's text, zero-padded to at least [`PIECE`] bytes for [`put`], and its length.
struct Field {
    padded: Vec<u8>,
    len: usize,
}

impl Field {
    fn new(text: &[u8]) -> Self {
        let mut padded = text.to_vec();
        padded.resize(text.len().max(PIECE), 0);
        Field {
            padded,
            len: text.len(),
        }
    }

    fn put(&self, out: &mut Vec<u8>) {
        put(out, &self.padded, self.len);
    }
}

/// Copies the first `len` bytes of `text` to `out`. A text of at most [`PIECE`] bytes is copied
/// as a fixed-size block and the excess cut off again: a copy of constant size is a few moves,
/// where one of variable size is a call to memmove, which was a tenth of a re-evaluation's time.
fn put(out: &mut Vec<u8>, text: &[u8], len: usize) {
    match text.first_chunk::<PIECE>() {
        Some(block) if len <= PIECE => {
            let end = out.len() + len;
            out.extend_from_slice(block);
            out.truncate(end);
        }
        _ => out.extend_from_slice(&text[..len]),
    }
}

const PIECE: usize = 32;

/// The text of recently written floats, with their comma, by bit pattern in a small
/// direct-mapped table. Many values of a session repeat from row to row (the time of an
/// instant for all legs, one attack angle for the legs of a tripod, a leg's width while it is
/// out of the medium, the zero forces out of it), and looking their text up costs much less
/// than formatting it again. The text is the same either way.
struct FloatText {
    slots: Vec<FloatSlot>,
    float: zmij::Buffer,
}

#[derive(Clone, Copy)]
struct FloatSlot {
    bits: u64,
    /// 0 while the slot is empty (no float formats to nothing).
    len: u8,
    text: [u8; PIECE],
}

impl FloatText {
    const SLOTS_LOG2: u32 = 9;

    fn new() -> Self {
        let empty = FloatSlot {
            bits: 0,
            len: 0,
            text: [0; PIECE],
        };
        FloatText {
            slots: vec![empty; 1 << Self::SLOTS_LOG2],
            float: zmij::Buffer::new(),
        }
    }

    /// Writes `v` and a comma.
    fn put(&mut self, out: &mut Vec<u8>, v: f64) {
        let bits = v.to_bits();
        // Fibonacci hashing: the top bits of the product mix all of the value's bits.
        let i = (bits.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> (64 - Self::SLOTS_LOG2)) as usize;
        let slot = &mut self.slots[i];
        if slot.bits != bits || slot.len == 0 {
            // zmij writes at most 24 bytes (its buffer's size), so the text and its comma fit.
            let s = self.float.format(v).as_bytes();
            slot.text[..s.len()].copy_from_slice(s);
            slot.text[s.len()] = b',';
            slot.len = s.len() as u8 + 1;
            slot.bits = bits;
        }
        put(out, &slot.text, usize::from(slot.len));
    }
}

impl CsvRows {
    fn new(legs: &[String]) -> Result<Self> {
        let legs = legs
            .iter()
            .map(|name| {
                let mut w = csv::WriterBuilder::new()
                    .terminator(csv::Terminator::Any(b','))
                    .from_writer(Vec::new());
                w.write_field(name)?;
                w.write_record(None::<&[u8]>)?;
                Ok(Field::new(&w.into_inner().map_err(|e| anyhow!("{e}"))?))
            })
            .collect::<Result<_>>()?;
        let regimes = Regime::ALL
            .iter()
            .map(|r| Field::new(format!("{},", r.as_str()).as_bytes()))
            .collect();
        Ok(CsvRows {
            legs,
            regimes,
            floats: FloatText::new(),
        })
    }

    fn push(&mut self, out: &mut Vec<u8>, r: &Row) {
        self.floats.put(out, r.t_s);
        self.legs[r.leg].put(out);
        self.floats.put(out, r.beta_rad);
        self.regimes[usize::from(r.regime.code())].put(out);
        for m in [r.measured_drag_n, r.measured_lift_n] {
            match m {
                Some(v) => self.floats.put(out, v),
                None => out.push(b','),
            }
        }
        for v in [
            r.predicted_drag_n,
            r.predicted_lift_n,
            r.predicted_hip_torque_nm,
            r.b_k,
            r.a,
        ] {
            self.floats.put(out, v);
        }
        out.extend_from_slice(if r.identified { b"true\n" } else { b"false\n" });
    }
}

/// The configuration to re-evaluate with: `--params-file`, else the recorded parameters.
pub fn reevaluation_config(
    a_params: &Option<PathBuf>,
    s: &Scan,
    file: &std::path::Path,
) -> Result<NodeConfig> {
    Ok(reevaluation_params(a_params, s, file)?.0)
}

/// [`reevaluation_config`] with the parameters it was made from.
fn reevaluation_params(
    a_params: &Option<PathBuf>,
    s: &Scan,
    file: &std::path::Path,
) -> Result<(NodeConfig, crate::config::ParamMap)> {
    let recorded = recorded_params(s);
    let (node, ns) = recorded
        .as_ref()
        .map(|r| (r.1.clone(), r.2.clone()))
        .unwrap_or(("terzaghi".into(), "/".into()));
    let params = match (a_params, recorded) {
        (Some(path), _) => {
            let ros = RosArgs {
                params_files: vec![path.clone()],
                ..Default::default()
            };
            load_params(&ros, &node, &ns)?
        }
        (None, Some((p, _, _))) => p,
        (None, None) => bail!(
            "{} has no recorded node parameters (it was not recorded by terzaghi node): pass --params-file",
            file.display()
        ),
    };
    let cfg = NodeConfig::from_params(&params, &node, &ns, &[])?;
    Ok((cfg, params))
}

fn run_reevaluate(a: &ReplayArgs) -> Result<()> {
    // A finished file is read as far as its summary, and then chunk by chunk; a cut-off one is
    // read whole, and scanned for its topics and parameters.
    let indexed =
        IndexedFile::open(&a.file).with_context(|| format!("cannot read {}", a.file.display()))?;
    let whole;
    let (source, head): (Source, Scan) = match &indexed {
        Some(f) => (f.into(), f.head().clone()),
        None => {
            whole = read_file(&a.file)?;
            let head = scan(&whole, |_, _| {}).with_context(|| a.file.display().to_string())?;
            ((&whole).into(), head)
        }
    };
    let (cfg, params) = reevaluation_params(&a.params_file, &head, &a.file)?;
    let legs: Vec<String> = cfg.legs.iter().map(|l| l.name.clone()).collect();
    let out_kind = a
        .output
        .as_ref()
        .and_then(|p| p.extension())
        .and_then(|e| e.to_str())
        .map(str::to_lowercase);
    // Progress counts the inputs read (joint states and F/T), which is what takes the time.
    let inputs: u64 = head
        .topics
        .iter()
        .filter(|t| {
            t.topic == cfg.joint_states_topic
                || cfg
                    .legs
                    .iter()
                    .any(|l| l.ft_topic.as_deref() == Some(&t.topic))
        })
        .map(|t| t.count)
        .sum();
    let pb = progress(inputs, "re-evaluating");
    let mut n = 0u64;
    let summary;
    match out_kind.as_deref() {
        Some("mcap") => {
            let path = a.output.clone().unwrap_or_default();
            super::refuse_existing_recording(&path, a.overwrite)?;
            let mut result = None;
            write_atomically(&path, |w| {
                // The parameters it was re-evaluated with, so that it can be re-run in turn.
                let opts = RecordOptions::with_node_params(&params, &cfg.node_name, &cfg.namespace);
                let mut writer = SessionWriter::new(w, opts)?;
                let mut err: Option<anyhow::Error> = None;
                let resolve = |rel: &str| {
                    crate::config::resolve_topic(rel, &cfg.namespace, &cfg.node_name, &[])
                };
                let wr_topics: Vec<String> = legs
                    .iter()
                    .map(|l| resolve(&format!("{l}/predicted_wrench")))
                    .collect();
                let lf_topics: Vec<String> = legs
                    .iter()
                    .map(|l| resolve(&format!("{l}/leg_force")))
                    .collect();
                let mp_topics: Vec<String> = legs
                    .iter()
                    .map(|l| resolve(&format!("{l}/model_params")))
                    .collect();
                let s = reevaluate(
                    source,
                    cfg.clone(),
                    |_| {},
                    |o| {
                        if err.is_some() {
                            return;
                        }
                        if let Output::Input(..) = o {
                            n += 1;
                            if n.is_multiple_of(50_000) {
                                pb.set_position(n);
                            }
                        }
                        let r = match o {
                            Output::Input(scan, m) => {
                                let t = &scan.topics[m.topic];
                                writer
                                    .channel_with_metadata(
                                        &t.topic,
                                        &t.type_name,
                                        &t.schema_text,
                                        OfferedQos::BEST_EFFORT,
                                        t.channel_metadata.clone(),
                                    )
                                    .and_then(|id| {
                                        writer.write_cdr(
                                            id,
                                            &t.topic,
                                            m.data,
                                            m.log_time_ns,
                                            m.publish_time_ns,
                                        )
                                    })
                            }
                            Output::Prediction(log, o) => {
                                let stamp = o.wrench.header.stamp.to_nanos().max(0) as u64;
                                writer
                                    .write_output(
                                        &wr_topics[o.leg],
                                        OfferedQos::RELIABLE,
                                        &o.wrench,
                                        log,
                                        stamp,
                                    )
                                    .and_then(|_| {
                                        writer.write_output(
                                            &lf_topics[o.leg],
                                            OfferedQos::RELIABLE,
                                            &o.force,
                                            log,
                                            stamp,
                                        )
                                    })
                            }
                            Output::Params(log, leg, p) => {
                                let stamp = p.header.stamp.to_nanos().max(0) as u64;
                                writer.write_output(
                                    &mp_topics[leg],
                                    OfferedQos::RELIABLE,
                                    p,
                                    log,
                                    stamp,
                                )
                            }
                        };
                        if let Err(e) = r {
                            err = Some(e.into());
                        }
                    },
                )?;
                if let Some(e) = err {
                    return Err(e);
                }
                writer.finish()?;
                result = Some(s);
                Ok(())
            })?;
            summary = result.ok_or_else(|| anyhow!("nothing re-evaluated"))?;
        }
        Some("csv") | None => {
            // Rows are written as they come (a 10-minute session makes half a gigabyte of CSV),
            // formatted on a second thread in batches: formatting is about as much work as the
            // re-evaluation itself.
            let mut run = |w: &mut (dyn std::io::Write + Send)| -> Result<_> {
                const BATCH: usize = 4096;
                let mut rows = CsvRows::new(&legs)?;
                std::thread::scope(|scope| {
                    let (tx, rx) = std::sync::mpsc::sync_channel::<Vec<Row>>(8);
                    let writer = scope.spawn(move || -> std::io::Result<()> {
                        let mut text = Vec::with_capacity(BATCH * 256);
                        w.write_all(CSV_HEADER.as_bytes())?;
                        for batch in rx {
                            text.clear();
                            for r in &batch {
                                rows.push(&mut text, r);
                            }
                            w.write_all(&text)?;
                        }
                        w.flush()
                    });
                    let mut batch = Vec::with_capacity(BATCH);
                    let send = |batch: &mut Vec<Row>| {
                        // A writer that failed has hung up; its error is reported below.
                        let _ = tx.send(std::mem::replace(batch, Vec::with_capacity(BATCH)));
                    };
                    let s = reevaluate_rows(
                        source,
                        cfg.clone(),
                        |r| {
                            batch.push(*r);
                            if batch.len() == BATCH {
                                send(&mut batch);
                            }
                        },
                        |o| {
                            if let Output::Input(..) = o {
                                n += 1;
                                if n.is_multiple_of(50_000) {
                                    pb.set_position(n);
                                }
                            }
                        },
                    );
                    send(&mut batch);
                    drop(tx);
                    let written = writer
                        .join()
                        .map_err(|_| anyhow!("the CSV writer thread failed"))?;
                    let s = s?;
                    written?;
                    Ok(s)
                })
            };
            summary = match &a.output {
                Some(path) => {
                    let mut result = None;
                    write_atomically(path, |w| {
                        result = Some(run(w)?);
                        Ok(())
                    })?;
                    result.ok_or_else(|| anyhow!("nothing re-evaluated"))?
                }
                None => {
                    let mut stdout = std::io::BufWriter::new(std::io::stdout());
                    match run(&mut stdout) {
                        Ok(s) => s,
                        // A reader that stopped early (`| head`) is not an error.
                        Err(e)
                            if e.downcast_ref::<std::io::Error>()
                                .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe) =>
                        {
                            return Ok(());
                        }
                        Err(e) => return Err(e),
                    }
                }
            };
        }
        Some(other) => bail!("--output: unknown kind .{other}: use .mcap or .csv"),
    }
    pb.finish_and_clear();
    if !summary.skipped_topics.is_empty() {
        eprintln!(
            "note: topics not used by this configuration, skipped: {}",
            summary.skipped_topics.join(", ")
        );
    }
    if summary.undecodable > 0 {
        eprintln!(
            "note: {} messages did not decode and were skipped",
            summary.undecodable
        );
    }
    if !summary.complete {
        eprintln!(
            "note: {} is cut off ({}); re-evaluated what it holds",
            a.file.display(),
            summary.stopped.as_deref().unwrap_or("no summary")
        );
    }
    if summary.joint_states == 0 {
        bail!(
            "{}: no JointState on {} (topics: {}); check the parameters (joint_states_topic)",
            a.file.display(),
            cfg.joint_states_topic,
            head.topics
                .iter()
                .map(|t| t.topic.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let est: Vec<String> = summary
        .estimates
        .iter()
        .zip(&legs)
        .filter_map(|(e, l)| {
            e.map(|e| {
                format!(
                    "{l}: b_k {:.4} a {:.4} (converged: {})",
                    e.b_k, e.a, e.converged
                )
            })
        })
        .collect();
    eprintln!(
        "re-evaluated {} joint states and {} F/T samples into {} rows{}{}",
        summary.joint_states,
        summary.ft_samples,
        summary.rows,
        if est.is_empty() {
            String::new()
        } else {
            "; final estimates: ".to_string()
        },
        est.join("; ")
    );
    Ok(())
}

enum AnyPub {
    Joints(Publisher<JointState>),
    Wrench(Publisher<WrenchStamped>),
    Force(Publisher<LegForce>),
    Params(Publisher<ModelParams>),
    Diag(Publisher<DiagnosticArray>),
}

fn run_dds(a: &ReplayArgs) -> Result<()> {
    let bytes = read_file(&a.file)?;
    let mut session = read_session(&bytes).with_context(|| a.file.display().to_string())?;
    // Played in log-time order: chunks may overlap in time (the node's outputs are in chunks of
    // their own, and other tools interleave too). Stable, so ties keep the file's order.
    session.messages.sort_by_key(|m| m.log_time_ns);
    let wanted = |t: &str| a.topics.is_empty() || a.topics.iter().any(|w| w == t);
    let rt = super::runtime()?;
    rt.block_on(async {
        let mut node = tool_node(&format!("terzaghi_replay_{}", std::process::id()))
            .context("cannot create the replay node")?;
        let mut pubs: Vec<Option<AnyPub>> = Vec::new();
        let mut skipped = Vec::new();
        for t in &session.topics {
            let p = if !wanted(&t.topic) || t.encoding != "cdr" {
                None
            } else if same_type(&t.type_name, &JointState::type_name()) {
                Some(AnyPub::Joints(publisher(&mut node, &t.topic)?))
            } else if same_type(&t.type_name, &WrenchStamped::type_name()) {
                Some(AnyPub::Wrench(publisher(&mut node, &t.topic)?))
            } else if same_type(&t.type_name, &LegForce::type_name()) {
                Some(AnyPub::Force(publisher(&mut node, &t.topic)?))
            } else if same_type(&t.type_name, &ModelParams::type_name()) {
                Some(AnyPub::Params(publisher(&mut node, &t.topic)?))
            } else if same_type(&t.type_name, &DiagnosticArray::type_name()) {
                Some(AnyPub::Diag(publisher(&mut node, &t.topic)?))
            } else {
                None
            };
            if p.is_none() && wanted(&t.topic) {
                skipped.push(format!("{} ({})", t.topic, t.type_name));
            }
            pubs.push(p);
        }
        if !skipped.is_empty() {
            eprintln!(
                "note: not replayed (unknown type or encoding): {}",
                skipped.join(", ")
            );
        }
        let spin = tokio::spawn(node.spinner()?.spin());
        // Let subscribers discover the publishers before the first message.
        tokio::time::sleep(Duration::from_secs(2)).await;
        let pb = progress(session.messages.len() as u64, "replaying");
        let (mut sent, mut undecodable) = (0u64, 0u64);
        let stop = tokio::signal::ctrl_c();
        tokio::pin!(stop);
        'outer: loop {
            let t0 = session.messages.first().map(|m| m.log_time_ns).unwrap_or(0);
            let start = Instant::now();
            for (i, m) in session.messages.iter().enumerate() {
                let Some(p) = &pubs[m.topic] else { continue };
                if !a.as_fast_as_possible {
                    let due = start
                        + Duration::from_secs_f64(
                            m.log_time_ns.saturating_sub(t0) as f64 * 1e-9 / a.rate,
                        );
                    tokio::select! {
                        _ = tokio::time::sleep_until(due.into()) => {}
                        _ = &mut stop => break 'outer,
                    }
                }
                let ok = match p {
                    AnyPub::Joints(p) => session.decode(m).map(|x| p.publish(x).is_ok()),
                    AnyPub::Wrench(p) => session.decode(m).map(|x| p.publish(x).is_ok()),
                    AnyPub::Force(p) => session.decode(m).map(|x| p.publish(x).is_ok()),
                    AnyPub::Params(p) => session.decode(m).map(|x| p.publish(x).is_ok()),
                    AnyPub::Diag(p) => session.decode(m).map(|x| p.publish(x).is_ok()),
                };
                match ok {
                    Ok(_) => sent += 1,
                    Err(_) => undecodable += 1,
                }
                if i % 1000 == 0 {
                    pb.set_position(i as u64);
                }
            }
            if !a.repeat {
                break;
            }
        }
        pb.finish_and_clear();
        node.stop_spinner();
        let _ = tokio::time::timeout(Duration::from_secs(1), spin).await;
        eprintln!("replayed {sent} messages ({undecodable} did not decode and were skipped)");
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Regime;

    /// The hand-written rows read back with the csv crate: the header names the fields in
    /// order, a leg's name with a comma or a quote is quoted, a missing measurement is an empty
    /// field, and floats come back exactly (non-finite ones as NaN and inf).
    #[test]
    fn csv_rows_read_back_field_for_field() {
        let legs = ["front_left".to_string(), "odd, \"leg\"".to_string()];
        let mut rows = CsvRows::new(&legs).unwrap();
        let mut text = CSV_HEADER.as_bytes().to_vec();
        let row = |leg, measured: Option<f64>, predicted: f64| Row {
            t_s: 1_700_000_000.001,
            leg,
            beta_rad: 0.1 + 0.2,
            regime: Regime::Penetration,
            measured_drag_n: measured,
            measured_lift_n: measured.map(|m| -m),
            predicted_drag_n: predicted,
            predicted_lift_n: 1e-300,
            predicted_hip_torque_nm: -2.5e21,
            b_k: 32.61,
            a: 2.3,
            identified: leg == 1,
        };
        let mut written = [
            row(0, Some(12.345678901234567), 0.0),
            row(1, None, f64::NAN),
            row(1, Some(-0.0), f64::INFINITY),
        ];
        // Two rows of one instant, then another instant.
        written[2].t_s = 1_700_000_000.002;
        for r in &written {
            rows.push(&mut text, r);
        }
        let mut rdr = csv::Reader::from_reader(&text[..]);
        let header: Vec<String> = rdr.headers().unwrap().iter().map(String::from).collect();
        assert_eq!(header.len(), 12);
        assert_eq!(header[0], "t_s");
        assert_eq!(header[11], "identified");
        let back: Vec<csv::StringRecord> = rdr.records().map(|r| r.unwrap()).collect();
        assert_eq!(back.len(), written.len());
        for (b, w) in back.iter().zip(&written) {
            assert_eq!(b.len(), 12, "{b:?}");
            let num = |i: usize| b[i].parse::<f64>().unwrap();
            assert_eq!(num(0), w.t_s);
            assert_eq!(&b[1], legs[w.leg].as_str());
            assert_eq!(num(2), w.beta_rad);
            assert_eq!(&b[3], "penetration");
            match w.measured_drag_n {
                Some(m) => {
                    assert_eq!(num(4).to_bits(), m.to_bits());
                    assert_eq!(num(5), -m);
                }
                None => assert!(b[4].is_empty() && b[5].is_empty()),
            }
            let p = num(6);
            assert!(p == w.predicted_drag_n || (p.is_nan() && w.predicted_drag_n.is_nan()));
            assert_eq!(num(7), 1e-300);
            assert_eq!(num(8), -2.5e21);
            assert_eq!((num(9), num(10)), (32.61, 2.3));
            assert_eq!(&b[11], if w.identified { "true" } else { "false" });
        }
    }

    /// Values that repeat, in a pool larger than the table of float texts (so that slots are
    /// taken over by other values and then wanted back), read back bit for bit, and every
    /// regime reads back as its name.
    #[test]
    fn csv_rows_with_repeated_values_read_back_exactly() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(0x2545_f491_4f6c_dd1d);
        let mut next = || rng.random::<u64>();
        let pool: Vec<f64> = (0..3000)
            .map(|i| match i % 3 {
                0 => f64::from_bits(next() >> 2), // any magnitude
                1 => (next() % 1_000_000) as f64 / 1000.0 - 500.0,
                _ => -((next() % 7) as f64),
            })
            .collect();
        let legs = ["a".to_string(), "b".to_string()];
        let mut rows = CsvRows::new(&legs).unwrap();
        let mut text = CSV_HEADER.as_bytes().to_vec();
        let mut written = Vec::new();
        for i in 0..20_000 {
            let mut v = || pool[(next() % pool.len() as u64) as usize];
            let r = Row {
                t_s: v(),
                leg: i % 2,
                beta_rad: v(),
                regime: Regime::ALL[i % Regime::ALL.len()],
                measured_drag_n: Some(v()),
                measured_lift_n: Some(v()),
                predicted_drag_n: v(),
                predicted_lift_n: v(),
                predicted_hip_torque_nm: v(),
                b_k: v(),
                a: v(),
                identified: false,
            };
            rows.push(&mut text, &r);
            written.push(r);
        }
        let mut rdr = csv::Reader::from_reader(&text[..]);
        let back: Vec<csv::StringRecord> = rdr.records().map(|r| r.unwrap()).collect();
        assert_eq!(back.len(), written.len());
        for (b, w) in back.iter().zip(&written) {
            let bits = |i: usize| b[i].parse::<f64>().unwrap().to_bits();
            let want = [
                w.t_s,
                w.beta_rad,
                w.measured_drag_n.unwrap(),
                w.measured_lift_n.unwrap(),
                w.predicted_drag_n,
                w.predicted_lift_n,
                w.predicted_hip_torque_nm,
                w.b_k,
                w.a,
            ];
            for (i, v) in [0, 2, 4, 5, 6, 7, 8, 9, 10].into_iter().zip(want) {
                assert_eq!(bits(i), v.to_bits(), "field {i} of {b:?}");
            }
            assert_eq!(&b[3], w.regime.as_str());
        }
    }
}
