//! What the node does with each message after its core has handled it, whatever carries the
//! messages (DDS, or the in-memory transport of the demo): record the outputs, publish them,
//! record the input. Both transports call these, so both run the same code path.

use super::core::{GapJob, NodeCore, Outputs};
use crate::config::NodeConfig;
use crate::diagnose::Report;
use crate::msgs::{
    DiagnosticArray, Gap, JointState, LegForce, ModelParams, PoseStamped, TfMessage, WrenchStamped,
};
use crate::record::recorder::{Record, Recorder};
use std::sync::Arc;

/// Where the node's outputs go.
pub trait Publish {
    /// Publishes `leg`'s predicted wrench.
    fn wrench(&self, leg: usize, msg: WrenchStamped);
    /// Publishes `leg`'s force.
    fn force(&self, leg: usize, msg: LegForce);
    /// Publishes `leg`'s model parameters.
    fn params(&self, leg: usize, msg: ModelParams);
    /// Publishes the node's diagnostics.
    fn diagnostics(&self, msg: DiagnosticArray);
    /// Publishes what the node's diagnosis of `leg` found.
    fn gap(&self, leg: usize, msg: Gap);
}

/// Topic names of what the node reads and writes, resolved once.
pub struct Topics {
    /// The JointState topic.
    pub joints: Arc<str>,
    /// Each leg's F/T topic (empty for a leg without one).
    pub ft: Vec<Arc<str>>,
    /// Each leg's predicted wrench topic.
    pub wrench: Vec<Arc<str>>,
    /// Each leg's force topic.
    pub force: Vec<Arc<str>>,
    /// Each leg's model parameters topic.
    pub params: Vec<Arc<str>>,
    /// Each leg's gap topic.
    pub gap: Vec<Arc<str>>,
    /// The diagnostics topic.
    pub diagnostics: Arc<str>,
}

impl Topics {
    /// The topics of the node configured by `cfg`.
    pub fn new(cfg: &NodeConfig) -> Topics {
        let out = crate::config::OutputTopics::of(cfg, &cfg.remaps);
        let per_leg = |f: fn(&crate::config::LegTopics) -> &String| -> Vec<Arc<str>> {
            out.legs.iter().map(|l| f(l).as_str().into()).collect()
        };
        Topics {
            joints: cfg.joint_states_topic.as_str().into(),
            ft: cfg
                .legs
                .iter()
                .map(|l| l.ft_topic.clone().unwrap_or_default().into())
                .collect(),
            wrench: per_leg(|l| &l.wrench),
            force: per_leg(|l| &l.force),
            params: per_leg(|l| &l.params),
            gap: per_leg(|l| &l.gap),
            diagnostics: out.diagnostics.as_str().into(),
        }
    }
}

/// After the core took a JointState: records its outputs and the parameters it produced,
/// publishes every leg's predicted wrench, calls `published` (the processing-time clock stops
/// there: a controller waits for the wrenches), then publishes the leg forces and parameters
/// and records the input. `outputs` is emptied (the live node has no use for its matches).
#[allow(clippy::too_many_arguments)]
pub fn joint_state_done(
    rec: Option<&Recorder>,
    topics: &Topics,
    msg: JointState,
    outputs: &mut Outputs,
    log_ns: u64,
    out: &impl Publish,
    published: impl FnOnce(),
) {
    if let Some(r) = rec {
        for o in outputs.legs.iter() {
            r.record(Record::Prediction(
                topics.wrench[o.leg].clone(),
                o.wrench.clone(),
                log_ns,
            ));
            r.record(Record::Force(
                topics.force[o.leg].clone(),
                o.force.clone(),
                log_ns,
            ));
        }
        for (leg, p) in outputs.params.iter() {
            r.record(Record::Params(
                topics.params[*leg].clone(),
                p.clone(),
                log_ns,
            ));
        }
    }
    // Wrenches first: they are what a controller waits for.
    for o in outputs.legs.iter_mut() {
        out.wrench(o.leg, std::mem::take(&mut o.wrench));
    }
    published();
    for o in outputs.legs.drain(..) {
        out.force(o.leg, o.force);
    }
    for (leg, p) in outputs.params.drain(..) {
        out.params(leg, p);
    }
    outputs.clear();
    if let Some(r) = rec {
        r.record(Record::Joints(topics.joints.clone(), msg, log_ns));
    }
}

/// After the core took leg `leg`'s measured wrench: records and publishes the parameters it
/// produced, then records the input. `outputs` is emptied.
pub fn wrench_done(
    rec: Option<&Recorder>,
    topics: &Topics,
    leg: usize,
    msg: WrenchStamped,
    outputs: &mut Outputs,
    log_ns: u64,
    out: &impl Publish,
) {
    if let Some(r) = rec {
        for (l, p) in outputs.params.iter() {
            r.record(Record::Params(topics.params[*l].clone(), p.clone(), log_ns));
        }
        r.record(Record::Wrench(topics.ft[leg].clone(), msg, log_ns));
    }
    for (l, p) in outputs.params.drain(..) {
        out.params(l, p);
    }
    outputs.clear();
}

/// After the core took a `/tf` or `/tf_static` message: records it.
pub fn tf_done(rec: Option<&Recorder>, topic: &Arc<str>, msg: TfMessage, log_ns: u64) {
    if let Some(r) = rec {
        r.record(Record::Tf(topic.clone(), msg, log_ns));
    }
}

/// After the core took the body's pose: records it.
pub fn pose_done(rec: Option<&Recorder>, topic: &Arc<str>, msg: PoseStamped, log_ns: u64) {
    if let Some(r) = rec {
        r.record(Record::Pose(topic.clone(), msg, log_ns));
    }
}

/// Records and publishes a diagnostics message.
pub fn diagnostics_done(
    rec: Option<&Recorder>,
    topics: &Topics,
    msg: DiagnosticArray,
    log_ns: u64,
    out: &impl Publish,
) {
    if let Some(r) = rec {
        r.record(Record::Diagnostics(
            topics.diagnostics.clone(),
            msg.clone(),
            log_ns,
        ));
    }
    out.diagnostics(msg);
}

/// A diagnosis of the node's own recent strokes came back: the core makes its `Gap` message,
/// which is recorded and published. Returns the leg's warning when this report starts one (an
/// effect the leg's model does not correct), for the log.
pub fn gap_done(
    rec: Option<&Recorder>,
    topics: &Topics,
    core: &mut NodeCore,
    job: &GapJob,
    result: &Result<Report, String>,
    log_ns: u64,
    out: &impl Publish,
) -> Option<String> {
    let had = !core.gap_warning(job.leg).is_empty();
    let msg = core.on_gap_report(job, result);
    let warning = core.gap_warning(job.leg);
    if let Some(r) = rec {
        r.record(Record::Gap(
            topics.gap[job.leg].clone(),
            msg.clone(),
            log_ns,
        ));
    }
    out.gap(job.leg, msg);
    (!had && !warning.is_empty()).then(|| {
        format!(
            "leg {}: its own diagnosis finds {warning}, which the model does not correct",
            core.leg_name(job.leg).unwrap_or("?")
        )
    })
}
