//! The node over an in-memory transport: messages come in through a bounded queue, in order,
//! and go through the same core and the same code path after it ([`super::handle`]) as on DDS:
//! predictions, the estimator, publications (to a [`Publish`] sink), the recorder. Used by the
//! demo, which needs no network.

use super::core::{Input, NodeCore, Outputs};
use super::gap_worker::GapWorker;
use super::handle::{Publish, Topics, diagnostics_done, gap_done, joint_state_done, wrench_done};
use crate::config::{NodeConfig, ParamMap};
use crate::msgs::{JointState, WrenchStamped};
use crate::record::RecordOptions;
use crate::record::recorder::Recorder;
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};

/// A message for the node, owned while it waits in the queue ([`Message::input`] is what the
/// core takes).
pub enum Message {
    /// A joint state.
    Joints(JointState),
    /// A wrench of the leg of this index.
    Wrench(usize, WrenchStamped),
}

impl Message {
    /// The core's input of the message.
    pub fn input(&self) -> Input<'_> {
        match self {
            Message::Joints(js) => Input::Joints(js),
            Message::Wrench(leg, w) => Input::Wrench(*leg, w),
        }
    }
}

/// What a run through the in-memory transport did.
#[derive(Debug, Clone, Default)]
pub struct MemoryRun {
    /// Joint states taken.
    pub joint_states: u64,
    /// Wrenches taken.
    pub wrenches: u64,
    /// Messages recorded.
    pub recorded: u64,
    /// Messages the recorder dropped.
    pub recording_dropped: u64,
    /// The recorder's error, where it had one.
    pub recording_error: Option<String>,
}

/// The sending end of the transport (blocking when the queue is full: the in-memory robot
/// waits for the node rather than lose a message).
pub type Sender = SyncSender<Message>;

/// A bounded queue to the node.
pub fn queue(depth: usize) -> (Sender, Receiver<Message>) {
    sync_channel(depth.max(1))
}

/// Runs the node on every input of `rx` until the senders are gone; `between` is called after
/// every message with the core (for a live view). Records to `cfg.record` if set, with the
/// node's parameters as metadata.
pub fn run<P: Publish>(
    cfg: NodeConfig,
    params: &ParamMap,
    rx: Receiver<Message>,
    out: &P,
    mut between: impl FnMut(&NodeCore, &Message),
) -> Result<MemoryRun, crate::record::RecordError> {
    let topics = Topics::new(&cfg);
    let recorder = match &cfg.record {
        Some(path) => {
            let opts = RecordOptions::with_node_params(params, &cfg.node_name, &cfg.namespace);
            // The inputs are simulated: they wait for the disk, and the session is whole
            // whatever the machine's load.
            Some(Recorder::start(path, opts, 1 << 16)?.lossless())
        }
        None => None,
    };
    let period_ns = (cfg.diagnostics_period_s * 1e9) as i64;
    let mut core = NodeCore::new(cfg);
    let mut outputs = Outputs::default();
    let mut run = MemoryRun::default();
    let mut next_diag_ns: Option<i64> = None;
    // The node's own diagnoses, off the message path as on DDS.
    let worker = if core.config().gap_check.every_strokes > 0 {
        Some(GapWorker::start()?)
    } else {
        None
    };
    let mut done = Vec::new();
    for input in rx {
        // The transport's clock is the messages' own: a simulated robot runs faster than real time.
        let stamp_ns = match &input {
            Message::Joints(js) => js.header.stamp.to_nanos(),
            Message::Wrench(_, w) => w.header.stamp.to_nanos(),
        };
        let log_ns = stamp_ns.max(0) as u64;
        core.handle(input.input(), &mut outputs);
        match &input {
            Message::Joints(js) => {
                run.joint_states += 1;
                joint_state_done(
                    recorder.as_ref(),
                    &topics,
                    js.clone(),
                    &mut outputs,
                    log_ns,
                    out,
                    || {},
                );
            }
            Message::Wrench(leg, w) => {
                run.wrenches += 1;
                if let Some(g) = &worker {
                    g.offer(&mut core);
                }
                wrench_done(
                    recorder.as_ref(),
                    &topics,
                    *leg,
                    w.clone(),
                    &mut outputs,
                    log_ns,
                    out,
                );
            }
        }
        if next_diag_ns.is_none_or(|t| stamp_ns >= t) {
            if next_diag_ns.is_some() {
                let d = core.diagnostics(stamp_ns, 0, &[]);
                diagnostics_done(recorder.as_ref(), &topics, d, log_ns, out);
            }
            next_diag_ns = Some(stamp_ns + period_ns);
        }
        if let Some(g) = &worker {
            g.done(&mut done);
            for (job, result) in done.drain(..) {
                gap_done(
                    recorder.as_ref(),
                    &topics,
                    &mut core,
                    &job,
                    &result,
                    log_ns,
                    out,
                );
            }
        }
        between(&core, &input);
    }
    if let Some(r) = recorder {
        let status = r.status.clone();
        run.recording_error = r.finish();
        run.recorded = status.written.load(std::sync::atomic::Ordering::Relaxed);
        run.recording_dropped = status.dropped.load(std::sync::atomic::Ordering::Relaxed);
    }
    Ok(run)
}
