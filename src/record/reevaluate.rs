//! Offline re-evaluation of a session: the recorded joint states and F/T samples go through the
//! node's own core (model and estimator), as fast as possible, with the recorded parameters or
//! new ones; predictions come out next to the measurements.

use super::RecordError;
use super::read::{MessageView, Scan, Source, TopicInfo, same_type, scan_topics};
use crate::config::{NodeConfig, ParamMap, defaults, parse_value};
use crate::ident::Estimate;
use crate::model::Regime;
use crate::msgs::{DecodeInto, JointState, LegForce, ModelParams, RosMessage, WrenchStamped};
use crate::node::core::{LegOutput, Matched, NodeCore};

/// One prediction, with the measurement it is next to (if the leg has F/T).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Row {
    pub t_s: f64,
    pub leg: usize,
    pub beta_rad: f64,
    pub regime: Regime,
    pub measured_drag_n: Option<f64>,
    pub measured_lift_n: Option<f64>,
    pub predicted_drag_n: f64,
    pub predicted_lift_n: f64,
    pub predicted_hip_torque_nm: f64,
    pub b_k: f64,
    pub a: f64,
    pub identified: bool,
}

/// What the re-evaluation produces besides rows, for an MCAP output.
pub enum Output<'a> {
    /// A recorded input, as it was.
    Input(&'a Scan, &'a MessageView<'a>),
    Prediction(u64, &'a LegOutput),
    Params(u64, usize, &'a ModelParams),
}

#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct Summary {
    pub joint_states: u64,
    pub ft_samples: u64,
    pub rows: u64,
    /// Topics of the file that the configuration does not use.
    pub skipped_topics: Vec<String>,
    /// Messages that did not decode (counted, skipped).
    pub undecodable: u64,
    pub complete: bool,
    pub stopped: Option<String>,
    /// Final estimate per leg with F/T.
    pub estimates: Vec<Option<Estimate>>,
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

/// Runs the session in `bytes` through a node with `cfg`. `on_row` gets every prediction next
/// to its measurement; `on_output` gets inputs and outputs for an MCAP copy.
pub fn reevaluate<'a>(
    source: impl Into<Source<'a>>,
    cfg: NodeConfig,
    on_row: impl FnMut(&Row),
    on_output: impl FnMut(Output),
) -> Result<Summary, RecordError> {
    modelled(source.into(), cfg, true, on_row, on_output)
}

/// [`reevaluate`] for rows only: the node's output messages of legs with F/T are not made
/// (their rows come from the matched samples either way), which saves a model evaluation and
/// two messages per leg and joint state. `on_output` then gets the inputs, the parameters and
/// the predictions of legs without F/T.
pub fn reevaluate_rows<'a>(
    source: impl Into<Source<'a>>,
    cfg: NodeConfig,
    on_row: impl FnMut(&Row),
    on_output: impl FnMut(Output),
) -> Result<Summary, RecordError> {
    modelled(source.into(), cfg, false, on_row, on_output)
}

fn modelled(
    source: Source,
    cfg: NodeConfig,
    outputs_for_ft_legs: bool,
    on_row: impl FnMut(&Row),
    on_output: impl FnMut(Output),
) -> Result<Summary, RecordError> {
    let mut core = NodeCore::new(cfg);
    core.keep_matches(true);
    core.outputs_for_ft_legs(outputs_for_ft_legs);
    run_core(source, core, true, on_row, on_output)
}

/// The measured F/T samples of every leg, each with the joint angle nearest in time (as the
/// node matches them; F/T in the leg frame turned into the hip frame), without running the
/// model: what the diagnosis reads. Legs without F/T get none.
pub fn measured_samples<'a>(
    source: impl Into<Source<'a>>,
    cfg: NodeConfig,
) -> Result<(Vec<Vec<crate::ident::Sample>>, Summary), RecordError> {
    let mut out = vec![Vec::new(); cfg.legs.len()];
    let core = NodeCore::matching_only(cfg);
    let sum = run_core(
        source.into(),
        core,
        false,
        |r| {
            if let (Some(d), Some(l)) = (r.measured_drag_n, r.measured_lift_n) {
                out[r.leg].push(crate::ident::Sample {
                    t_s: Some(r.t_s),
                    beta_rad: r.beta_rad,
                    drag_n: d,
                    lift_n: l,
                });
            }
        },
        |_| {},
    )?;
    Ok((out, sum))
}

fn run_core(
    source: Source,
    mut core: NodeCore,
    predict: bool,
    mut on_row: impl FnMut(&Row),
    mut on_output: impl FnMut(Output),
) -> Result<Summary, RecordError> {
    let cfg = core.config().clone();
    let legs = cfg.legs.len();
    let js_topic = cfg.joint_states_topic.clone();
    let ft_topics: Vec<Option<String>> = cfg.legs.iter().map(|l| l.ft_topic.clone()).collect();
    let has_ft: Vec<bool> = ft_topics.iter().map(Option::is_some).collect();
    let mut sum = Summary {
        estimates: vec![None; legs],
        ..Default::default()
    };
    // What a topic of the file is to us.
    #[derive(Clone, Copy, PartialEq)]
    enum Role {
        Joints,
        Ft(usize),
        Skip,
    }
    let role_of = |t: &TopicInfo| {
        if t.topic == js_topic && same_type(&t.type_name, &JointState::type_name()) {
            Role::Joints
        } else if let Some(i) = ft_topics
            .iter()
            .position(|f| f.as_deref() == Some(t.topic.as_str()))
            && same_type(&t.type_name, &WrenchStamped::type_name())
        {
            Role::Ft(i)
        } else {
            Role::Skip
        }
    };
    let mut roles: Vec<Option<Role>> = Vec::new();
    let mut outputs: Vec<LegOutput> = Vec::new();
    let mut params = Vec::new();
    let mut matches: Vec<Matched> = Vec::new();
    let wanted = |t: &TopicInfo| role_of(t) != Role::Skip;
    // Decoded into, message after message; one F/T message per leg, so that its frame is
    // the one already held.
    let mut js = JointState::default();
    let mut ws = vec![WrenchStamped::default(); legs];
    let scan_result = scan_topics(source, wanted, |scan, m| {
        if roles.len() < scan.topics.len() {
            roles.resize(scan.topics.len(), None);
        }
        let role = *roles[m.topic].get_or_insert_with(|| role_of(&scan.topics[m.topic]));
        let log = m.log_time_ns;
        match role {
            Role::Joints => {
                if js.decode_into(m.data).is_err() {
                    sum.undecodable += 1;
                    return;
                }
                on_output(Output::Input(scan, &m));
                sum.joint_states += 1;
                outputs.clear();
                core.on_joint_state(&js, &mut outputs);
                for o in &outputs {
                    on_output(Output::Prediction(log, o));
                    if !has_ft[o.leg] {
                        let f = &o.force;
                        sum.rows += 1;
                        on_row(&Row {
                            t_s: f.header.stamp.to_secs(),
                            leg: o.leg,
                            beta_rad: f.attack_angle_rad,
                            regime: regime_of(f),
                            measured_drag_n: None,
                            measured_lift_n: None,
                            predicted_drag_n: f.drag_n,
                            predicted_lift_n: f.lift_n,
                            predicted_hip_torque_nm: f.hip_torque_nm,
                            b_k: f.b_k,
                            a: f.a,
                            identified: f.identified,
                        });
                    }
                }
            }
            Role::Ft(leg) => {
                let w = &mut ws[leg];
                if w.decode_into(m.data).is_err() {
                    sum.undecodable += 1;
                    return;
                }
                on_output(Output::Input(scan, &m));
                sum.ft_samples += 1;
                core.on_wrench(leg, w);
            }
            Role::Skip => return,
        }
        core.take_params(&mut params);
        for (leg, p) in params.drain(..) {
            on_output(Output::Params(log, leg, &p));
        }
        // An F/T sample can only match for its own leg; a joint state for any (the samples that
        // waited for it).
        let from_legs = match role {
            Role::Ft(leg) => leg..leg + 1,
            _ => 0..legs,
        };
        for leg in from_legs.filter(|&l| has_ft[l]) {
            core.take_matches(leg, &mut matches);
            for mt in matches.drain(..) {
                if !predict {
                    // Measurements only: the row's prediction fields stay empty.
                    sum.rows += 1;
                    on_row(&Row {
                        t_s: mt.t_ns as f64 * 1e-9,
                        leg,
                        beta_rad: mt.beta_rad,
                        regime: Regime::OutOfMedium,
                        measured_drag_n: Some(mt.drag_n),
                        measured_lift_n: Some(mt.lift_n),
                        predicted_drag_n: f64::NAN,
                        predicted_lift_n: f64::NAN,
                        predicted_hip_torque_nm: f64::NAN,
                        b_k: f64::NAN,
                        a: f64::NAN,
                        identified: false,
                    });
                    continue;
                }
                let Some(p) = core.predict(leg, mt.beta_rad) else {
                    continue;
                };
                let (b_k, a, identified) = core.width_in_use(leg).unwrap_or((0.0, 0.0, false));
                sum.rows += 1;
                on_row(&Row {
                    t_s: mt.t_ns as f64 * 1e-9,
                    leg,
                    beta_rad: mt.beta_rad,
                    regime: p.regime,
                    measured_drag_n: Some(mt.drag_n),
                    measured_lift_n: Some(mt.lift_n),
                    predicted_drag_n: p.drag_n,
                    predicted_lift_n: p.lift_n,
                    predicted_hip_torque_nm: p.hip_torque_nm,
                    b_k,
                    a,
                    identified,
                });
            }
        }
    })?;
    sum.complete = scan_result.complete;
    sum.stopped = scan_result.stopped.clone();
    sum.skipped_topics = scan_result
        .topics
        .iter()
        .filter(|t| role_of(t) == Role::Skip)
        .map(|t| t.topic.clone())
        .collect();
    sum.estimates = (0..legs).map(|i| core.estimate(i)).collect();
    Ok(sum)
}

fn regime_of(f: &LegForce) -> Regime {
    match f.regime {
        0 => Regime::OutOfMedium,
        1 => Regime::Penetration,
        2 => Regime::ExtractionSpiral,
        3 => Regime::ExtractionTriangle,
        _ => Regime::Extraction,
    }
}
