//! A session's inputs as the node reads them: the configuration to read it with (the
//! parameters recorded in it, or a parameter file), the role of each of its topics, its decoded
//! messages, and each leg's F/T samples matched to a joint angle, with where the robot's state
//! put the hip. The re-evaluation feeds these messages to the node's core; the diagnosis, the
//! fits and the identification read the matched samples.

use crate::config::{NodeConfig, ParamMap, RosArgs, defaults, load_params, parse_value};
use crate::config::{TF_STATIC_TOPIC, TF_TOPIC};
use crate::ident::Sample;
use crate::model::HipMotion;
use crate::msgs::{
    DecodeInto, JointState, PoseStamped, RosMessage, TfMessage, WrenchStamped, from_cdr,
};
use crate::node::core::{Input, TfTree};
use crate::node::matcher::{FtMatcher, Match, usable_stamp_ns};
use crate::record::RecordError;
use crate::record::read::{MessageView, Scan, Source, TopicInfo, same_type, scan_topics};
use anyhow::{Result, bail};
use std::path::Path;

/// What reading a session's inputs found.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct Read {
    /// JointStates read.
    pub joint_states: u64,
    /// F/T samples read.
    pub ft_samples: u64,
    /// F/T samples matched to a joint angle, over every leg.
    pub matched: u64,
    /// Topics of the file that the configuration does not use.
    pub skipped_topics: Vec<String>,
    /// Messages that did not decode (counted, skipped).
    pub undecodable: u64,
    /// Whether the file was read to its end.
    pub complete: bool,
    /// Why reading stopped early, if it did.
    pub stopped: Option<String>,
}

/// The node parameters recorded in a session, if any (`terzaghi_params` metadata), with the
/// node's name and namespace.
pub fn recorded_params(s: &Scan) -> Option<(ParamMap, String, String)> {
    let md = s.metadata.get("terzaghi_params")?;
    let mut p = defaults();
    let (mut node, mut ns) = ("terzaghi".to_string(), "/".to_string());
    for (k, v) in md {
        match k.as_str() {
            "__node" => node = v.trim_matches('"').to_string(),
            "__ns" => ns = v.trim_matches('"').to_string(),
            _ => {
                p.insert(k.clone(), parse_value(v));
            }
        }
    }
    Some((p, node, ns))
}

/// The configuration to re-evaluate a session with: `params_file`, else the parameters
/// recorded in it. Also gives the parameters it was made from.
pub fn session_config(
    params_file: Option<&Path>,
    head: &Scan,
    file: &Path,
) -> Result<(NodeConfig, ParamMap)> {
    session_config_with(params_file, &[], head, file)
}

/// [`session_config`] with the parameters `set` over the file's or the recording's.
pub fn session_config_with(
    params_file: Option<&Path>,
    set: &[(String, crate::config::ParamValue)],
    head: &Scan,
    file: &Path,
) -> Result<(NodeConfig, ParamMap)> {
    let recorded = recorded_params(head);
    let (node, ns) = recorded
        .as_ref()
        .map(|r| (r.1.clone(), r.2.clone()))
        .unwrap_or(("terzaghi".into(), "/".into()));
    let mut params = match (params_file, recorded) {
        (Some(path), _) => {
            let ros = RosArgs {
                params_files: vec![path.to_path_buf()],
                ..Default::default()
            };
            load_params(&ros, &node, &ns)?
        }
        (None, Some((p, _, _))) => p,
        (None, None) => bail!(super::Refusal::NoRecordedParameters {
            file: file.to_path_buf()
        }),
    };
    for (name, value) in set {
        params.insert(name.clone(), value.clone());
    }
    let cfg = NodeConfig::from_params(&params, &node, &ns, &[])?;
    Ok((cfg, params))
}

/// How many messages of `head`'s topics the configuration reads: what reading the inputs
/// takes its time over.
pub fn input_count(cfg: &NodeConfig, head: &Scan) -> u64 {
    let role = role_of(cfg);
    head.topics
        .iter()
        .filter(|t| role(t) != Role::Skip)
        .map(|t| t.count)
        .sum()
}

/// What a topic of a session is to a configuration.
#[derive(Clone, Copy, PartialEq)]
enum Role {
    Joints,
    Ft(usize),
    /// `/tf` (false) or `/tf_static` (true), for the legs with a `hip_frame`.
    Tf(bool),
    /// The body's pose (`robot_state.pose_topic`).
    Pose,
    Skip,
}

/// The role of each topic: the configuration's JointState topic, a leg's F/T topic (of the
/// right types), or neither.
fn role_of(cfg: &NodeConfig) -> impl Fn(&TopicInfo) -> Role + '_ {
    move |t: &TopicInfo| {
        if t.topic == cfg.joint_states_topic && same_type(&t.type_name, &JointState::type_name()) {
            Role::Joints
        } else if let Some(i) = cfg
            .legs
            .iter()
            .position(|l| l.ft_topic.as_deref() == Some(t.topic.as_str()))
            && same_type(&t.type_name, &WrenchStamped::type_name())
        {
            Role::Ft(i)
        } else if cfg.legs.iter().any(|l| l.hip_frame.is_some())
            && (t.topic == TF_TOPIC || t.topic == TF_STATIC_TOPIC)
            && same_type(&t.type_name, &TfMessage::type_name())
        {
            Role::Tf(t.topic == TF_STATIC_TOPIC)
        } else if cfg.robot_state.pose_topic.as_deref() == Some(t.topic.as_str())
            && same_type(&t.type_name, &PoseStamped::type_name())
        {
            Role::Pose
        } else {
            Role::Skip
        }
    }
}

/// Reads the inputs of `cfg` in `source` (its JointState topic, the legs' F/T topics, and the
/// robot's state where a leg reads it), each decoded into a reused message and handed to
/// `on_input` with the record it came from; a message that does not decode is counted and
/// skipped.
pub(super) fn scan_inputs(
    source: Source,
    cfg: &NodeConfig,
    mut on_input: impl FnMut(Input, &Scan, &MessageView),
) -> Result<Read, RecordError> {
    let legs = cfg.legs.len();
    let mut sum = Read::default();
    let role = role_of(cfg);
    let mut roles: Vec<Option<Role>> = Vec::new();
    // Decoded into, message after message; one F/T message per leg, so that its frame is the
    // one already held.
    let mut js = JointState::default();
    let mut ws = vec![WrenchStamped::default(); legs];
    let scan_result = scan_topics(
        source,
        |t| role(t) != Role::Skip,
        |scan, m| {
            if roles.len() < scan.topics.len() {
                roles.resize(scan.topics.len(), None);
            }
            match *roles[m.topic].get_or_insert_with(|| role(&scan.topics[m.topic])) {
                Role::Joints => {
                    if js.decode_into(m.data).is_err() {
                        sum.undecodable += 1;
                        return;
                    }
                    sum.joint_states += 1;
                    on_input(Input::Joints(&js), scan, &m);
                }
                Role::Ft(leg) => {
                    let w = &mut ws[leg];
                    if w.decode_into(m.data).is_err() {
                        sum.undecodable += 1;
                        return;
                    }
                    sum.ft_samples += 1;
                    on_input(Input::Wrench(leg, w), scan, &m);
                }
                Role::Tf(fixed) => match from_cdr::<TfMessage>(m.data) {
                    Ok(tf) => on_input(Input::Tf(&tf, fixed), scan, &m),
                    Err(_) => sum.undecodable += 1,
                },
                Role::Pose => match from_cdr::<PoseStamped>(m.data) {
                    Ok(p) => on_input(Input::Pose(&p), scan, &m),
                    Err(_) => sum.undecodable += 1,
                },
                Role::Skip => {}
            }
        },
    )?;
    sum.complete = scan_result.complete;
    sum.stopped = scan_result.stopped.clone();
    sum.skipped_topics = scan_result
        .topics
        .iter()
        .filter(|t| role(t) == Role::Skip)
        .map(|t| t.topic.clone())
        .collect();
    Ok(sum)
}

/// The measured F/T samples of every leg, each with the joint angle nearest in time (as the
/// node matches them; F/T in the leg frame turned into the hip frame), without
/// running the model: what the diagnosis and the fits read. Legs without F/T get none.
pub fn measured_samples<'a>(
    source: impl Into<Source<'a>>,
    cfg: NodeConfig,
) -> Result<(Vec<Vec<Sample>>, Read), RecordError> {
    let (placed, sum) = measured_samples_placed(source, cfg)?;
    Ok((placed.samples, sum))
}

/// A leg's hip at each of its samples, where the robot's state placed it.
pub type HipPlaces = Vec<Option<HipMotion>>;

/// Every leg's measured samples, and where the robot's state placed its hip at each.
pub struct Placed {
    /// Each leg's measured samples.
    pub samples: Vec<Vec<Sample>>,
    /// Where the robot's state placed each leg's hip at its samples.
    pub hips: Vec<HipPlaces>,
}

/// [`measured_samples`], and for each sample of a leg with a `hip_frame` where the recorded
/// robot's state (`/tf`, `/tf_static`, the body's pose) put its hip at the joint angle's stamp,
/// as the node reads it (`None` where it could not: the node then uses the configured height).
/// Legs without a `hip_frame` get no places.
pub fn measured_samples_placed<'a>(
    source: impl Into<Source<'a>>,
    cfg: NodeConfig,
) -> Result<(Placed, Read), RecordError> {
    let legs = cfg.legs.len();
    let mut out = vec![Vec::new(); legs];
    let mut hips: Vec<HipPlaces> = vec![Vec::new(); legs];
    let mut matcher = FtMatcher::new(&cfg);
    let mut tree = TfTree::default();
    tree.place_hips(&cfg);
    let rs = cfg.robot_state.clone();
    let frames: Vec<Option<String>> = cfg.legs.iter().map(|l| l.hip_frame.clone()).collect();
    let mut keep = |tree: &TfTree, leg: usize, m: Match| {
        if let Match::Matched(mt) = m {
            out[leg].push(Sample {
                t_s: Some(mt.t_ns as f64 * 1e-9),
                beta_rad: mt.beta_rad,
                drag_n: mt.drag_n,
                lift_n: mt.lift_n,
            });
            if let Some(frame) = &frames[leg] {
                hips[leg].push(tree.hip_motion(&rs, frame, mt.angle_t_ns, 0.0).ok());
            }
        }
    };
    let mut sum = scan_inputs(source.into(), &cfg, |input, _, _| match input {
        Input::Joints(js) => {
            if let Some(stamp_ns) = usable_stamp_ns(js) {
                tree.saw_joint_state(stamp_ns);
                for leg in 0..legs {
                    let _ = matcher.on_angle(leg, js, stamp_ns, |m| keep(&tree, leg, m));
                }
            }
        }
        Input::Wrench(leg, w) => {
            matcher.on_wrench(leg, w, |m| keep(&tree, leg, m));
        }
        Input::Tf(msg, fixed) => tree.insert(msg, fixed),
        Input::Pose(msg) => tree.insert_pose(msg, &rs),
        // A recording's inputs carry no log's hip columns.
        Input::Hip(..) => {}
    })?;
    sum.matched = out.iter().map(|s| s.len() as u64).sum();
    Ok((Placed { samples: out, hips }, sum))
}
