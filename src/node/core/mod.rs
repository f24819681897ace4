//! What the node does with each message, without DDS or a clock: joint angles in, predicted
//! wrenches out; measured wrenches in, identified parameters out. Every transport (DDS, the
//! in-memory demo, the offline re-evaluation of a recording) hands its messages to
//! [`NodeCore::handle`] and publishes, records or tabulates the [`Outputs`] it fills.

mod gap;
mod robot_state;
mod status;
mod trough;

pub use gap::GapJob;
pub use robot_state::{FrameId, NoState, TfTree};

use super::matcher::{FtMatcher, Match, NoAngle, usable_stamp_ns};
use crate::config::{ModelKind, NodeConfig};
use crate::diagnose::Turns;
use crate::ident::{
    CorrectedEstimator, Estimate, OnlineEstimator, Sample, ScaleEstimator, SinkageEstimator,
    SurfaceEstimator,
};
use crate::model::corrections::{
    CorrectedModel, CorrectedPrediction, Effect, MOTION_WINDOW_S, Motion, MotionTracker,
    SampleHold, SensorLagFilter,
};
use crate::model::sinkage::PressedDepth;
use crate::model::{
    FittingWidth, ForceModel, HipMotion, Plate, Prediction, Regime, TerzaghiModel, wrap_beta_rad,
};
use crate::msgs::{
    Header, JointState, LegForce, ModelParams, PoseStamped, TfMessage, Time, Vector3, Wrench,
    WrenchStamped,
};
use std::collections::VecDeque;

pub use super::matcher::Matched;

/// Counters of one leg, since start.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct LegCounters {
    /// JointStates that named the leg's joint.
    pub joint_states: u64,
    /// Predictions published.
    pub predictions: u64,
    /// JointStates that did not name this leg's joint.
    pub missing_joint: u64,
    /// Non-finite joint positions, or a model that could not evaluate.
    pub invalid_position: u64,
    /// JointState stamps older than the last one used.
    pub stamps_backwards: u64,
    /// F/T samples received.
    pub ft_received: u64,
    /// F/T samples with no joint angle within `max_match_dt_s`.
    pub ft_unmatched: u64,
    /// F/T samples with a non-finite value or an invalid stamp.
    pub ft_invalid: u64,
    /// Predictions with the hip placed by the robot's state (`<leg>.hip_frame`).
    pub state_used: u64,
    /// Predictions of a leg with a `hip_frame` at its configured height instead: no transform
    /// linked the hip to the world frame (or it was invalid).
    pub state_missing: u64,
    /// The same, because the transforms were older than `robot_state.max_age_s`.
    pub state_stale: u64,
}

/// Node-wide counters, since start.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct NodeCounters {
    /// JointStates received.
    pub joint_states: u64,
    /// JointStates whose arrays disagree in length, or whose stamp is invalid.
    pub invalid_joint_states: u64,
}

struct Leg {
    model: ForceModel,
    /// The corrected model, for a leg with `<leg>.corrections`: it predicts instead of `model`.
    corrected: Option<CorrectedLeg>,
    /// `<leg>_hip`, the frame of the predictions (made once, not per message).
    hip_frame: String,
    estimator: Option<Learner>,
    /// The estimate currently used for predictions (converged and `use_identified`).
    identified: Option<Estimate>,
    last_params_ns: Option<i64>,
    counters: LegCounters,
    /// Counters at the last diagnostics, for rates.
    at_last_diag: LegCounters,
    /// Its recent strokes, for the node's own diagnosis.
    gap: gap::GapWatch,
    /// Its angle made continuous across turns, its last stamp and continuous angle, for its
    /// rotation rate, and that rate.
    turns: Turns,
    last_angle: Option<(i64, f64)>,
    omega_rad_s: f64,
    /// The surface's level, learnt online (`estimator.fit_surface`).
    surface: Option<SurfaceEstimator>,
    /// Where its own strokes dug the ground (`<leg>.trough_depth_m`).
    troughs: trough::Troughs,
    /// The hips a log gave it ([`Input::Hip`]), by stamp, oldest first.
    given_hips: std::collections::VecDeque<(i64, HipMotion)>,
    /// The F/T sensor's sample-and-hold (`<leg>.sensor_hold_s`), its instants anchored where its
    /// value was last seen to change.
    hold: SampleHold,
    /// The last F/T force and torque received, to see the sensor update.
    last_ft: Option<[f64; 6]>,
    /// The expected readings held at recent angles, by their stamps, for a re-evaluation's rows.
    held: VecDeque<(i64, [f64; 2])>,
    /// A sinkage leg's deepest point pressed in its present intrusion.
    pressed: PressedDepth,
    /// A sinkage leg's recent angles (by stamp) at which it moved down through sand it had
    /// already pressed: reloading, not the law's loading.
    reloads: VecDeque<(i64, bool)>,
}

/// Hips kept per leg from a log's columns, for the F/T samples matched to their angles.
const GIVEN_HIPS: usize = 256;

impl Leg {
    /// The surface's level it learns: a sinkage leg's estimator learns it with the medium's
    /// scale, a flat leg's surface estimator alone (`estimator.fit_surface`).
    fn surface_estimate(&self) -> Option<crate::ident::SurfaceEstimate> {
        match (&self.estimator, &self.surface) {
            (Some(Learner::Sinkage(e)), _) => Some(*e.surface()),
            (_, Some(s)) => Some(*s.estimate()),
            _ => None,
        }
    }

    /// The scale RFT's prediction is multiplied by: the learnt one while it is converged (and
    /// used); `None` for a leg that does not learn one.
    fn rft_scale(&self, use_identified: bool) -> Option<f64> {
        match (&self.estimator, &self.identified, use_identified) {
            (Some(Learner::RftScale(_) | Learner::Sinkage(_)), Some(e), true) => Some(e.b_k),
            _ => None,
        }
    }
}

/// Keeps `value` for the angle stamped `stamp_ns` in `ring`, the oldest dropped past `cap`:
/// what a leg made at its recent angles, for the F/T samples matched to them later.
fn keep_recent<T>(ring: &mut VecDeque<(i64, T)>, cap: usize, stamp_ns: i64, value: T) {
    if ring.len() >= cap {
        ring.pop_front();
    }
    ring.push_back((stamp_ns, value));
}

/// The value `ring` keeps for the angle stamped `stamp_ns` (the newest, if several).
fn kept_at<T: Copy>(ring: &VecDeque<(i64, T)>, stamp_ns: i64) -> Option<T> {
    ring.iter()
        .rev()
        .find(|(t, _)| *t == stamp_ns)
        .map(|(_, v)| *v)
}

/// Predictions kept per corrected leg for the rows of a re-evaluation, by their angle's stamp.
const RECENT_PREDICTIONS: usize = 1024;

/// Motions kept per corrected leg, by their angle's stamp, for the F/T samples matched to them.
const RECENT_MOTIONS: usize = 256;

/// A leg's online identification: of the bare model's fitting width, of its corrected model
/// (`b_k`, `a` and the corrections' coefficients), or of RFT's scale (its estimate's `b_k`).
enum Learner {
    Bare(Box<OnlineEstimator>),
    Corrected(Box<CorrectedEstimator>),
    RftScale(Box<ScaleEstimator>),
    /// A sinkage leg's: the medium's scale under the plate and the surface's level.
    Sinkage(Box<SinkageEstimator>),
}

impl Learner {
    fn estimate(&self) -> &Estimate {
        match self {
            Learner::Bare(e) => e.estimate(),
            Learner::Corrected(e) => e.estimate(),
            Learner::RftScale(e) => e.estimate(),
            Learner::Sinkage(e) => e.estimate(),
        }
    }
}

/// A leg predicted by the corrected model: the model, the leg's motion followed from its angles,
/// the sensor's lag, and its recent predictions.
struct CorrectedLeg {
    model: CorrectedModel,
    tracker: MotionTracker,
    lag: SensorLagFilter,
    recent: VecDeque<(i64, RowPrediction)>,
    /// The leg's motion at its recent angles, by their stamps: what the online identification
    /// of the corrections reads at a matched F/T sample.
    motions: VecDeque<(i64, Motion)>,
}

impl CorrectedLeg {
    fn new(model: CorrectedModel) -> CorrectedLeg {
        CorrectedLeg {
            model,
            tracker: MotionTracker::new(MOTION_WINDOW_S),
            lag: SensorLagFilter::default(),
            recent: VecDeque::with_capacity(RECENT_PREDICTIONS),
            motions: VecDeque::with_capacity(RECENT_MOTIONS),
        }
    }

    /// The corrected prediction for the angle `beta_rad` stamped `stamp_ns`, the sensor's side
    /// through its lag; the recent ones are kept for [`NodeCore::row_prediction`].
    fn step(
        &mut self,
        stamp_ns: i64,
        beta_rad: f64,
        hip: Option<&HipMotion>,
    ) -> Option<CorrectedPrediction> {
        let t_s = stamp_ns as f64 * 1e-9;
        let plate = *self.model.plate();
        // The plate where the robot's state placed its hip, at the attack angle there.
        let submerged = match hip {
            Some(h) => Plate::new(plate.length_m(), plate.width_m(), h.height_m.max(0.0))
                .map_or(0.0, |p| {
                    p.submerged_length_m(wrap_beta_rad(beta_rad + h.pitch_rad))
                }),
            None => plate.submerged_length_m(wrap_beta_rad(beta_rad)),
        };
        let motion = self
            .tracker
            .update(t_s, beta_rad, submerged, plate.length_m());
        keep_recent(&mut self.motions, RECENT_MOTIONS, stamp_ns, motion);
        let mut p = self.model.evaluate_at(beta_rad, &motion, hip).ok()?;
        let c = self.model.corrections();
        if c.has(Effect::SensorLag) {
            let bias = [p.sensor_drag_n - p.drag_n, p.sensor_lift_n - p.lift_n];
            let y = self.lag.step(t_s, [p.drag_n, p.lift_n], c.nonlinear.lag_s);
            p.sensor_drag_n = y[0] + bias[0];
            p.sensor_lift_n = y[1] + bias[1];
        }
        keep_recent(
            &mut self.recent,
            RECENT_PREDICTIONS,
            stamp_ns,
            RowPrediction::corrected(&p),
        );
        Some(p)
    }
}

/// A prediction as a re-evaluation's row gives it: the medium's force (corrected where the leg
/// has corrections), the bare model's, and what the sensor is expected to read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowPrediction {
    /// The medium's force (with every correction of the medium).
    pub medium: Prediction,
    /// The bare model's drag and lift (N).
    pub bare_n: [f64; 2],
    /// What the F/T sensor is expected to read, drag and lift (N).
    pub sensor_n: [f64; 2],
}

impl RowPrediction {
    fn corrected(p: &CorrectedPrediction) -> RowPrediction {
        RowPrediction {
            medium: Prediction {
                beta_rad: p.bare.beta_rad,
                submerged_m: p.submerged_m,
                depth_m: p.depth_m,
                drag_n: p.drag_n,
                lift_n: p.lift_n,
                hip_torque_nm: p.hip_torque_nm,
                side_n: 0.0,
                roll_moment_nm: 0.0,
                yaw_moment_nm: 0.0,
                regime: p.regime,
            },
            bare_n: [p.bare.drag_n, p.bare.lift_n],
            sensor_n: [p.sensor_drag_n, p.sensor_lift_n],
        }
    }

    fn bare(p: Prediction) -> RowPrediction {
        RowPrediction {
            medium: p,
            bare_n: [p.drag_n, p.lift_n],
            sensor_n: [p.drag_n, p.lift_n],
        }
    }
}

/// The leg force message of prediction `p` by `model` with fitting width and friction
/// `(b_k, a, delta_deg)`; the bare force and the expected reading are the prediction's own (a
/// leg with corrections sets them).
fn leg_force(
    header: Header,
    p: &Prediction,
    model: &str,
    (b_k, a, delta_deg): (f64, f64, f64),
    identified: bool,
) -> LegForce {
    LegForce {
        header,
        attack_angle_rad: p.beta_rad,
        submerged_length_m: p.submerged_m,
        depth_m: p.depth_m,
        drag_n: p.drag_n,
        lift_n: p.lift_n,
        hip_torque_nm: p.hip_torque_nm,
        regime: p.regime.code(),
        model: model.to_string(),
        b_k,
        a,
        delta_deg,
        identified,
        bare_drag_n: p.drag_n,
        bare_lift_n: p.lift_n,
        correction_names: Vec::new(),
        correction_drag_n: Vec::new(),
        correction_lift_n: Vec::new(),
        sensor_drag_n: p.drag_n,
        sensor_lift_n: p.lift_n,
        hip_height_m: 0.0,
        body_pitch_rad: 0.0,
        hip_forward_m_s: 0.0,
        hip_up_m_s: 0.0,
        robot_state: false,
        rft_scale: 1.0,
        side_n: p.side_n,
        roll_moment_nm: p.roll_moment_nm,
        yaw_moment_nm: p.yaw_moment_nm,
        hip_lateral_m_s: 0.0,
    }
}

/// A message for the node, as a transport hands it over.
#[derive(Debug, Clone, Copy)]
pub enum Input<'m> {
    /// The robot's joint states: every configured leg found in it is predicted.
    Joints(&'m JointState),
    /// A measured wrench of the leg with this index.
    Wrench(usize, &'m WrenchStamped),
    /// `/tf` (`false`) or `/tf_static` (`true`).
    Tf(&'m TfMessage, bool),
    /// The body's pose (`robot_state.pose_topic`).
    Pose(&'m PoseStamped),
    /// The hip of the leg with this index at a stamp (ns), as a log's columns give it (a CSV
    /// log's `hip_height_m`): for a leg without a `hip_frame`, it places the hip at that
    /// stamp's angle instead of the configured height.
    Hip(usize, i64, HipMotion),
}

/// What the core made of the inputs handed to it since the transport last emptied this:
/// the transport publishes or records each part, or drops what it has no use for.
#[derive(Debug, Clone, Default)]
pub struct Outputs {
    /// One per leg predicted, for each JointState.
    pub legs: Vec<LegOutput>,
    /// Identified parameters due for publication, with their leg.
    pub params: Vec<(usize, ModelParams)>,
    /// The F/T samples matched to a joint angle, with their leg: what a re-evaluation puts next
    /// to the prediction there.
    pub matches: Vec<MatchedRow>,
}

/// An F/T sample matched to a joint angle of a leg, with what the leg predicted there before
/// it learnt from the sample (when the core keeps it, [`NodeCore::keep_row_predictions`]): a
/// re-evaluation's row is a prediction, not a fit to the row itself.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MatchedRow {
    /// The leg.
    pub leg: usize,
    /// The sample and its angle.
    pub matched: Matched,
    /// The prediction at the sample before it was learnt from, and the fitting width then in
    /// use (`b_k`, `a`, whether identified; [`NodeCore::width_in_use`]).
    pub before: Option<(RowPrediction, (f64, f64, bool))>,
}

impl Outputs {
    /// Empties every leg's outputs, keeping their memory for the next message.
    pub fn clear(&mut self) {
        self.legs.clear();
        self.params.clear();
        self.matches.clear();
    }
}

/// The outputs of one leg for one JointState.
#[derive(Debug, Clone, PartialEq)]
pub struct LegOutput {
    /// The leg, by index in the configuration.
    pub leg: usize,
    /// The predicted wrench on the leg, in its hip frame.
    pub wrench: WrenchStamped,
    /// The leg's force, with what it came from.
    pub force: LegForce,
}

/// The node's state: configuration, per-leg models, estimators and counters.
pub struct NodeCore {
    cfg: NodeConfig,
    legs: Vec<Leg>,
    /// Parameters to publish, from the F/T samples of the input being handled.
    params_out: Vec<(usize, ModelParams)>,
    counters: NodeCounters,
    last_diag_ns: Option<i64>,
    matcher: FtMatcher,
    /// F/T samples decided by the matcher, waiting to be used.
    decided: Vec<Match>,
    /// The F/T samples matched while the input was handled.
    matches: Vec<MatchedRow>,
    /// Whether each match keeps the prediction before it is learnt from.
    keep_row_predictions: bool,
    /// Diagnoses due, for [`NodeCore::take_gap_jobs`].
    gap_jobs: Vec<GapJob>,
    /// The robot's state from `/tf` and `/tf_static`.
    tf: TfTree,
    /// `robot_state.world_frame` and each leg's `hip_frame` in `tf`, numbered once per
    /// configuration.
    world_frame: FrameId,
    hip_frames: Vec<Option<FrameId>>,
    /// [`TfTree::invalid`] at the previous `/diagnostics` report.
    tf_invalid_at_last_diag: u64,
}

/// `cfg`'s world frame and each leg's hip frame (if it has one), numbered in `tf`.
fn state_frames(tf: &mut TfTree, cfg: &NodeConfig) -> (FrameId, Vec<Option<FrameId>>) {
    let hips = cfg
        .legs
        .iter()
        .map(|l| l.hip_frame.as_deref().map(|f| tf.frame(f)))
        .collect();
    (tf.frame(&cfg.robot_state.world_frame), hips)
}

impl NodeCore {
    /// Makes every matched F/T sample keep the prediction its leg made there before learning
    /// from it ([`MatchedRow::before`]), as a re-evaluation's rows need.
    pub fn keep_row_predictions(mut self) -> NodeCore {
        self.keep_row_predictions = true;
        self
    }

    /// The core of the node configured by `cfg`, before any message.
    pub fn new(cfg: NodeConfig) -> NodeCore {
        let mut tf = TfTree::default();
        let (world_frame, hip_frames) = state_frames(&mut tf, &cfg);
        let mut core = NodeCore {
            legs: Vec::new(),
            params_out: Vec::new(),
            matcher: FtMatcher::new(&cfg),
            cfg,
            counters: NodeCounters::default(),
            last_diag_ns: None,
            decided: Vec::new(),
            matches: Vec::new(),
            keep_row_predictions: false,
            gap_jobs: Vec::new(),
            tf,
            world_frame,
            hip_frames,
            tf_invalid_at_last_diag: 0,
        };
        core.legs = (0..core.cfg.legs.len()).map(|i| core.new_leg(i)).collect();
        core.install_hip_offsets();
        core
    }

    /// The hips placed in the body by `<leg>.hip_offset_m`, as fixed transforms from
    /// `robot_state.body_frame`; the world's and the hips' frames numbered.
    fn install_hip_offsets(&mut self) {
        self.tf.place_hips(&self.cfg);
        (self.world_frame, self.hip_frames) = state_frames(&mut self.tf, &self.cfg);
    }

    /// Handles one message: what it gives is appended to `out`.
    pub fn handle(&mut self, input: Input<'_>, out: &mut Outputs) {
        match input {
            Input::Joints(js) => self.on_joint_state(js, &mut out.legs),
            Input::Wrench(leg, w) => self.on_wrench(leg, w),
            Input::Tf(tf, fixed) => self.on_tf(tf, fixed),
            Input::Pose(p) => self.on_pose(p),
            Input::Hip(leg, stamp_ns, hip) => self.on_hip(leg, stamp_ns, hip),
        }
        out.params.append(&mut self.params_out);
        out.matches.append(&mut self.matches);
    }

    /// Takes the body's pose (`robot_state.pose_topic`), for a robot without TF: the pose of
    /// `robot_state.body_frame` in the message's frame (the world frame if it names none).
    fn on_pose(&mut self, msg: &PoseStamped) {
        self.tf.insert_pose(msg, &self.cfg.robot_state);
    }

    /// Keeps a hip a log gives for `leg` at `stamp_ns` (the newest [`GIVEN_HIPS`]); a
    /// non-finite height or velocity is counted and skipped.
    fn on_hip(&mut self, leg: usize, stamp_ns: i64, hip: HipMotion) {
        let Some(l) = self.legs.get_mut(leg) else {
            return;
        };
        if !robot_state::plausible_hip(&hip) {
            l.counters.state_missing += 1;
            return;
        }
        if l.given_hips.back().is_some_and(|(t, _)| *t >= stamp_ns) {
            l.given_hips.retain(|(t, _)| *t < stamp_ns);
        }
        l.given_hips.push_back((stamp_ns, hip));
        if l.given_hips.len() > GIVEN_HIPS {
            l.given_hips.pop_front();
        }
    }

    /// The hip a log gave leg `i` nearest `stamp_ns` (within `robot_state.max_age_s`), turning
    /// at `omega_rad_s`; `None` if the log gives the leg no hip.
    fn given_hip(
        &self,
        i: usize,
        stamp_ns: i64,
        omega_rad_s: f64,
    ) -> Option<Result<HipMotion, NoState>> {
        let hips = &self.legs.get(i)?.given_hips;
        if hips.is_empty() {
            return None;
        }
        let max_age_ns = (self.cfg.robot_state.max_age_s * 1e9) as u64;
        // Kept in stamp order: the nearest is at the first stamp not before `stamp_ns`, or
        // the one before it. Stamps are any i64 a log holds: their distance is taken unsigned.
        let i = hips.partition_point(|(t, _)| *t < stamp_ns);
        let nearest = [i.checked_sub(1), Some(i)]
            .into_iter()
            .flatten()
            .filter_map(|k| hips.get(k))
            .min_by_key(|(t, _)| t.abs_diff(stamp_ns))
            .filter(|(t, _)| t.abs_diff(stamp_ns) <= max_age_ns);
        Some(match nearest {
            Some((_, h)) => Ok(HipMotion { omega_rad_s, ..*h }),
            None => Err(NoState::Stale),
        })
    }

    fn new_leg(&self, i: usize) -> Leg {
        let lc = &self.cfg.legs[i];
        let corrected = self.corrected_model(i);
        // A sinkage leg learns its medium's scale and the surface's level; a leg predicted by
        // RFT (a plate or another shape) RFT's scale.
        let model = self.model_for(i, None);
        let estimator = lc.ft_topic.as_ref().and_then(|_| {
            if let ForceModel::Sinkage(leg) = &model {
                return SinkageEstimator::new(
                    leg.model().clone(),
                    *leg.shape(),
                    crate::ident::SinkageOptions {
                        converge_rel_std: self
                            .cfg
                            .estimator
                            .converge_rel_std
                            .max(crate::ident::SinkageOptions::default().converge_rel_std),
                        huber_k: self.cfg.estimator.huber_k,
                        ..Default::default()
                    },
                )
                .ok()
                .map(|e| Learner::Sinkage(Box::new(e)));
            }
            if self.cfg.model == ModelKind::Rft && lc.rft.is_some() {
                return Some(Learner::RftScale(Box::new(ScaleEstimator::new(
                    self.cfg.estimator,
                ))));
            }
            if lc.profile.is_some() {
                return None;
            }
            if let Some(m) = &corrected {
                let opts = crate::ident::OnlineOptions {
                    fit_delta: false,
                    forgetting: crate::ident::online::Forgetting::Strokes(
                        self.cfg.corrections_memory_strokes,
                    ),
                    ..self.cfg.estimator
                };
                return CorrectedEstimator::new(m.clone(), opts)
                    .ok()
                    .map(|e| Learner::Corrected(Box::new(e)));
            }
            let base = TerzaghiModel::conventional(lc.plate, lc.medium);
            let opts = crate::ident::OnlineOptions {
                initial_b_k: lc.width.b_k().clamp(
                    self.cfg.estimator.b_k_range.0,
                    self.cfg.estimator.b_k_range.1,
                ),
                initial_a: lc
                    .width
                    .a()
                    .clamp(self.cfg.estimator.a_range.0, self.cfg.estimator.a_range.1),
                ..self.cfg.estimator
            };
            OnlineEstimator::new(&base, opts)
                .ok()
                .map(|e| Learner::Bare(Box::new(e)))
        });
        Leg {
            model,
            corrected: corrected.map(CorrectedLeg::new),
            hip_frame: format!("{}_hip", lc.name),
            estimator,
            identified: None,
            last_params_ns: None,
            counters: LegCounters::default(),
            at_last_diag: LegCounters::default(),
            gap: gap::GapWatch::default(),
            turns: Turns::default(),
            last_angle: None,
            omega_rad_s: 0.0,
            surface: self.surface_estimator(i),
            troughs: trough::Troughs::default(),
            given_hips: std::collections::VecDeque::new(),
            hold: SampleHold::default(),
            last_ft: None,
            held: VecDeque::new(),
            pressed: PressedDepth::new(&crate::model::sinkage::RegimeOptions::default()),
            reloads: VecDeque::new(),
        }
    }

    /// The surface estimator of leg `i`: a flat leg of the Terzaghi models with F/T and no
    /// corrections (whose `hip_height` term is the surface's), when `estimator.fit_surface`.
    fn surface_estimator(&self, i: usize) -> Option<SurfaceEstimator> {
        let lc = &self.cfg.legs[i];
        let flat_terzaghi =
            !matches!(self.cfg.model, ModelKind::Rft | ModelKind::Sinkage) && lc.profile.is_none();
        (self.cfg.fit_surface && flat_terzaghi && lc.ft_topic.is_some() && lc.corrections.is_none())
            .then(|| {
                SurfaceEstimator::new(
                    &TerzaghiModel::new(lc.plate, lc.medium, lc.width),
                    self.cfg.estimator,
                )
            })
    }

    /// The corrected model of leg `i`, if it has corrections (validated with the configuration).
    fn corrected_model(&self, i: usize) -> Option<CorrectedModel> {
        let lc = &self.cfg.legs[i];
        CorrectedModel::new(lc.plate, lc.medium, lc.corrections.clone()?).ok()
    }

    /// The leg's model with the configured parameters, or with an identified estimate.
    fn model_for(&self, i: usize, identified: Option<&Estimate>) -> ForceModel {
        let lc = &self.cfg.legs[i];
        let (width, delta) =
            match identified.and_then(|e| e.fitting_width().ok().map(|w| (w, e.delta_deg))) {
                Some((w, d)) => (w, self.cfg.estimator.fit_delta.then_some(d)),
                None => (lc.width, None),
            };
        self.cfg
            .leg_model(i, width, delta)
            .or_else(|_| self.cfg.leg_model(i, lc.width, None))
            .unwrap_or_else(|_| {
                ForceModel::Terzaghi(TerzaghiModel::new(
                    lc.plate,
                    lc.medium,
                    FittingWidth::CONVENTIONAL,
                ))
            })
    }

    /// The leg's model after its identified estimate changed. While the estimate moves only the
    /// fitting width (delta not fitted, the improved model of the configured plate and medium),
    /// the model keeps its medium's constants, which is the same model as [`Self::model_for`]
    /// makes without the trigonometry, once per F/T sample.
    fn follow_identified(&mut self, i: usize) {
        let lc = &self.cfg.legs[i];
        let id = self.legs[i].identified;
        if let (Some(e), false, ModelKind::Improved, ForceModel::Terzaghi(m)) = (
            id,
            self.cfg.estimator.fit_delta,
            self.cfg.model,
            &self.legs[i].model,
        ) && *m.medium() == lc.medium
            && *m.plate() == lc.plate
            && let Ok(width) = e.fitting_width()
        {
            self.legs[i].model = ForceModel::Terzaghi(m.with_fitting_width(width));
            return;
        }
        self.legs[i].model = self.model_for(i, id.as_ref());
    }

    /// The configuration the node runs with.
    pub fn config(&self) -> &NodeConfig {
        &self.cfg
    }

    /// Takes a new configuration (a parameter change): models are rebuilt; a leg whose plate,
    /// medium or estimator options changed starts its identification again.
    pub fn set_config(&mut self, cfg: NodeConfig) {
        self.matcher.set_config(&cfg);
        let old = std::mem::replace(&mut self.cfg, cfg);
        self.install_hip_offsets();
        for i in 0..self.legs.len().min(self.cfg.legs.len()) {
            let (o, n) = (&old.legs[i], &self.cfg.legs[i]);
            let relearn = o.plate != n.plate
                || o.medium != n.medium
                || o.ft_topic != n.ft_topic
                || o.corrections != n.corrections
                || old.estimator != self.cfg.estimator
                || old.corrections_memory_strokes != self.cfg.corrections_memory_strokes;
            if relearn || old.fit_surface != self.cfg.fit_surface {
                let fresh = self.new_leg(i);
                let leg = &mut self.legs[i];
                leg.estimator = fresh.estimator;
                leg.identified = None;
                leg.surface = fresh.surface;
            }
            let identified = if self.cfg.use_identified {
                self.legs[i].identified
            } else {
                None
            };
            self.legs[i].model = self.model_for(i, identified.as_ref());
            self.legs[i].hip_frame = format!("{}_hip", n.name);
            // New corrections take effect at once; the leg's motion is followed on.
            let configured = o.corrections != n.corrections || o.plate != n.plate;
            match (self.corrected_model(i), &mut self.legs[i].corrected) {
                (Some(m), Some(c)) => {
                    if configured {
                        c.model = m;
                        c.lag.reset();
                        c.recent.clear();
                    }
                }
                (m, c) => *c = m.map(CorrectedLeg::new),
            }
        }
    }

    /// Takes a `/tf` (`fixed` false) or `/tf_static` message: the robot's state, read by the legs
    /// with a `hip_frame`.
    fn on_tf(&mut self, msg: &TfMessage, fixed: bool) {
        self.tf.insert(msg, fixed);
    }

    /// Transforms of `/tf` refused (non-finite, zero rotation, invalid stamp or frames).
    pub fn tf_invalid(&self) -> u64 {
        self.tf.invalid
    }

    /// Where leg `i`'s hip is at `stamp_ns`, from the robot's state, for a leg with a
    /// `hip_frame`; counted when it falls back to the configured height (`None`).
    fn hip_motion(&mut self, i: usize, stamp_ns: i64, beta_rad: f64) -> Option<HipMotion> {
        // Continuous across turns: a stroke that passes 2 pi does not jump back.
        let (angle, _) = self.legs[i].turns.push(beta_rad);
        let omega = match self.legs[i].last_angle.replace((stamp_ns, angle)) {
            Some((t0, a0)) if stamp_ns > t0 => (angle - a0) / ((stamp_ns - t0) as f64 * 1e-9),
            _ => 0.0,
        };
        self.legs[i].omega_rad_s = omega;
        let state = self.state_hip(i, stamp_ns, omega)?;
        let c = &mut self.legs[i].counters;
        match state {
            Ok(h) => {
                c.state_used += 1;
                Some(h)
            }
            Err(NoState::Stale) => {
                c.state_stale += 1;
                None
            }
            Err(NoState::Unknown | NoState::Invalid) => {
                c.state_missing += 1;
                None
            }
        }
    }

    /// Where leg `leg`'s hip was at `stamp_ns` (an angle a measurement was matched with), for a
    /// leg the robot's state places; not counted (its prediction was).
    fn hip_at(&self, leg: usize, stamp_ns: i64, beta_rad: f64) -> Option<HipMotion> {
        let omega = self.legs.get(leg)?.omega_rad_s;
        let hip = self.state_hip(leg, stamp_ns, omega).and_then(Result::ok);
        self.in_trough(leg, hip, beta_rad).0
    }

    /// Leg `i`'s hip at `stamp_ns` from the robot's state (`None`: the leg has no
    /// `hip_frame`), turning at `omega_rad_s`.
    fn state_hip(
        &self,
        i: usize,
        stamp_ns: i64,
        omega_rad_s: f64,
    ) -> Option<Result<HipMotion, NoState>> {
        let Some(hip) = self.hip_frames.get(i).copied().flatten() else {
            return self.given_hip(i, stamp_ns, omega_rad_s);
        };
        Some(self.tf.hip_motion_of(
            &self.cfg.robot_state,
            self.world_frame,
            hip,
            stamp_ns,
            omega_rad_s,
        ))
    }

    /// `hip` (the robot's state's, or the configured still hip at position 0 when `None`)
    /// higher above the surface by the trough earlier strokes of leg `i` left under its
    /// submerged part at `beta_rad` (`<leg>.trough_depth_m`, `trough_exit_depth_m`; lower over
    /// a heap); and that part's span.
    fn in_trough(
        &self,
        i: usize,
        hip: Option<HipMotion>,
        beta_rad: f64,
    ) -> (Option<HipMotion>, Option<trough::Span>) {
        let lc = &self.cfg.legs[i];
        if lc.trough_depth_m == 0.0 && lc.trough_exit_depth_m == 0.0 {
            return (hip, None);
        }
        let base = hip.unwrap_or_else(|| self.configured_hip(i));
        let span = trough::Span::of_leg(
            base.forward_position_m,
            base.height_m,
            beta_rad + base.pitch_rad,
            lc.plate.length_m(),
        );
        let Some(depth_m) =
            self.legs[i]
                .troughs
                .depth_m(span, lc.trough_depth_m, lc.trough_exit_depth_m)
        else {
            return (hip, span);
        };
        // A heap never raises the surface above the hip.
        let hip = HipMotion {
            height_m: (base.height_m + depth_m).max(0.0),
            ..base
        };
        (Some(hip), span)
    }

    /// Leg `i`'s hip where configured, still; turning at the leg's rate where RFT's speed law
    /// needs it (elsewhere the rate would only change a curved leg's intrusion directions).
    fn configured_hip(&self, i: usize) -> HipMotion {
        let leg = &self.legs[i];
        HipMotion {
            omega_rad_s: if leg.model.rft_speed_law().is_some() {
                leg.omega_rad_s
            } else {
                0.0
            },
            ..HipMotion::still(self.cfg.legs[i].plate.hip_height_m())
        }
    }

    /// The surface's offset leg `i` predicts with: the learnt one once converged (and used).
    fn surface_offset_m(&self, i: usize) -> Option<f64> {
        let e = self.legs.get(i)?.surface_estimate()?;
        (e.converged && self.cfg.use_identified).then_some(e.offset_m)
    }

    /// `hip` (the robot's state's, or the configured still hip when `None`) with the learnt
    /// surface: that much lower above it. A leg predicted by RFT with a speed law is given its
    /// rotation rate at the configured height too.
    fn with_surface(&self, i: usize, hip: Option<HipMotion>) -> Option<HipMotion> {
        let offset = self.surface_offset_m(i);
        // RFT with a speed law needs the leg's rotation rate even at the configured height.
        let speed = self.legs[i].model.rft_speed_law().is_some();
        if offset.is_none() && (hip.is_some() || !speed) {
            return hip;
        }
        let base = hip.unwrap_or_else(|| self.configured_hip(i));
        Some(HipMotion {
            height_m: base.height_m - offset.unwrap_or(0.0),
            ..base
        })
    }

    /// Predicts every configured leg found in `msg`; appends one output per leg predicted.
    fn on_joint_state(&mut self, msg: &JointState, out: &mut Vec<LegOutput>) {
        self.counters.joint_states += 1;
        let Some(stamp_ns) = usable_stamp_ns(msg) else {
            self.counters.invalid_joint_states += 1;
            return;
        };
        self.tf.saw_joint_state(stamp_ns);
        for i in 0..self.legs.len() {
            self.legs[i].counters.joint_states += 1;
            let mut decided = std::mem::take(&mut self.decided);
            let angle = self.matcher.on_angle(i, msg, stamp_ns, |m| decided.push(m));
            for m in decided.drain(..) {
                self.use_match(i, m);
            }
            self.decided = decided;
            let beta = match angle {
                Ok(beta) => beta,
                Err(e) => {
                    let c = &mut self.legs[i].counters;
                    match e {
                        NoAngle::MissingJoint => c.missing_joint += 1,
                        NoAngle::InvalidPosition => c.invalid_position += 1,
                        NoAngle::StampBackwards => c.stamps_backwards += 1,
                    }
                    continue;
                }
            };
            let hip = self.hip_motion(i, stamp_ns, beta);
            let from_state = hip.is_some();
            // A leg without a trough has no span, and its memory stays empty.
            let (hip, span) = self.in_trough(i, hip, beta);
            self.legs[i].troughs.observe(span);
            let hip = self.with_surface(i, hip);
            let corrected = self.legs[i]
                .corrected
                .as_mut()
                .map(|c| c.step(stamp_ns, beta, hip.as_ref()));
            let (lc, leg) = (&self.cfg.legs[i], &mut self.legs[i]);
            let header = Header {
                stamp: msg.header.stamp,
                frame_id: leg.hip_frame.clone(),
            };
            let model = self.cfg.model.as_str();
            let force = match corrected {
                Some(Some(p)) => {
                    let c = leg.corrected.as_ref().map(|c| c.model.corrections());
                    let (b_k, a) = c.map_or((0.0, 0.0), |c| (c.b_k, c.a));
                    let medium = RowPrediction::corrected(&p).medium;
                    let h = hip.unwrap_or_else(|| HipMotion::still(lc.plate.hip_height_m()));
                    LegForce {
                        bare_drag_n: p.bare.drag_n,
                        bare_lift_n: p.bare.lift_n,
                        correction_names: p.parts.iter().map(|(e, _)| e.name().into()).collect(),
                        correction_drag_n: p.parts.iter().map(|(_, v)| v[0]).collect(),
                        correction_lift_n: p.parts.iter().map(|(_, v)| v[1]).collect(),
                        sensor_drag_n: p.sensor_drag_n,
                        sensor_lift_n: p.sensor_lift_n,
                        robot_state: from_state,
                        hip_height_m: h.height_m,
                        body_pitch_rad: h.pitch_rad,
                        hip_forward_m_s: h.forward_m_s,
                        hip_up_m_s: h.up_m_s,
                        hip_lateral_m_s: h.lateral_m_s,
                        ..leg_force(
                            header,
                            &medium,
                            model,
                            (b_k, a, lc.medium.delta_deg()),
                            false,
                        )
                    }
                }
                Some(None) => {
                    leg.counters.invalid_position += 1;
                    continue;
                }
                None => {
                    let p = match &hip {
                        Some(h) => leg.model.predict_moving(beta, h),
                        None => leg.model.predict(beta),
                    };
                    let Ok(mut p) = p else {
                        leg.counters.invalid_position += 1;
                        continue;
                    };
                    // A plate moving down through sand it already pressed reloads it: the
                    // rig's force, not the law's loading. So does a body pressed down where it
                    // stands (not moving along, nor turning), pushed again into its own rut,
                    // until it passes the deepest point; moving along, it meets fresh sand.
                    let pressing = match (&leg.model, &hip) {
                        (ForceModel::Sinkage(_), _) => Some(true),
                        (ForceModel::Body(b), Some(h)) => {
                            let min = crate::model::BodyLeg::MIN_SPEED_M_S;
                            let along = h.forward_m_s.hypot(h.lateral_m_s);
                            Some(along < min && (h.omega_rad_s * b.body().reach_m()).abs() < min)
                        }
                        _ => None,
                    };
                    if let Some(pressing) = pressing {
                        // Moving along forgets the pressed depth (sand not pressed before).
                        let reloading = !leg.pressed.press(if pressing { p.depth_m } else { 0.0 });
                        if reloading && p.regime == Regime::Penetration {
                            p.regime = Regime::Unloading;
                        }
                        if matches!(leg.model, ForceModel::Sinkage(_)) {
                            keep_recent(&mut leg.reloads, RECENT_PREDICTIONS, stamp_ns, reloading);
                        }
                    }
                    let rft_scale = leg.rft_scale(self.cfg.use_identified);
                    if let Some(s) = rft_scale {
                        p = p.scaled(s);
                    }
                    // An RFT or sinkage leg learns a scale, never a Terzaghi b_k.
                    let is_rft = matches!(
                        leg.estimator,
                        Some(Learner::RftScale(_) | Learner::Sinkage(_))
                    );
                    let width = match (&leg.identified, self.cfg.use_identified && !is_rft) {
                        (Some(e), true) => (
                            e.b_k,
                            e.a,
                            if self.cfg.estimator.fit_delta {
                                e.delta_deg
                            } else {
                                lc.medium.delta_deg()
                            },
                        ),
                        _ => (lc.width.b_k(), lc.width.a(), lc.medium.delta_deg()),
                    };
                    let identified = leg.identified.is_some() && self.cfg.use_identified;
                    let mut f = leg_force(header, &p, model, width, identified);
                    f.rft_scale = rft_scale.unwrap_or(1.0);
                    let h = hip.unwrap_or_else(|| HipMotion::still(lc.plate.hip_height_m()));
                    f.robot_state = from_state;
                    f.hip_height_m = h.height_m;
                    f.body_pitch_rad = h.pitch_rad;
                    f.hip_forward_m_s = h.forward_m_s;
                    f.hip_up_m_s = h.up_m_s;
                    f.hip_lateral_m_s = h.lateral_m_s;
                    f
                }
            };
            let mut force = force;
            // What a sample-and-hold sensor reads: the expected reading at its last instant.
            if lc.sensor_hold_s > 0.0 {
                let held = leg.hold.step(
                    stamp_ns as f64 * 1e-9,
                    [force.sensor_drag_n, force.sensor_lift_n],
                    lc.sensor_hold_s,
                );
                [force.sensor_drag_n, force.sensor_lift_n] = held;
                keep_recent(&mut leg.held, RECENT_PREDICTIONS, stamp_ns, held);
            }
            // The last guard: a force that is no number is never published (an input the
            // checks above let through, at the edge of what the model can evaluate).
            let values = [
                force.drag_n,
                force.lift_n,
                force.hip_torque_nm,
                force.depth_m,
                force.submerged_length_m,
                force.sensor_drag_n,
                force.sensor_lift_n,
                force.bare_drag_n,
                force.bare_lift_n,
                force.side_n,
                force.roll_moment_nm,
                force.yaw_moment_nm,
            ];
            if values.iter().any(|v| !v.is_finite()) {
                leg.counters.invalid_position += 1;
                continue;
            }
            leg.counters.predictions += 1;
            out.push(LegOutput {
                leg: i,
                wrench: WrenchStamped {
                    header: force.header.clone(),
                    wrench: Wrench {
                        force: Vector3 {
                            x: -force.drag_n,
                            y: force.side_n,
                            z: force.lift_n,
                        },
                        torque: Vector3 {
                            x: force.roll_moment_nm,
                            y: force.hip_torque_nm,
                            z: force.yaw_moment_nm,
                        },
                    },
                },
                force,
            });
        }
    }

    /// Feeds a measured wrench of leg `leg` to its estimator. A wrench newer than the newest
    /// joint angle waits (bounded) for the angle after it, so that the nearest angle in time is
    /// used. Parameters to publish (at most `model_params_rate_hz`, and at once on convergence or
    /// a detected change) go to [`Outputs::params`].
    fn on_wrench(&mut self, leg: usize, msg: &WrenchStamped) {
        let Some(l) = self.legs.get_mut(leg) else {
            return;
        };
        l.counters.ft_received += 1;
        // A sample-and-hold sensor updated where its value changes: its instants fall from there.
        if self.cfg.legs[leg].sensor_hold_s > 0.0 {
            let (f, t) = (&msg.wrench.force, &msg.wrench.torque);
            let v = [f.x, f.y, f.z, t.x, t.y, t.z];
            if l.last_ft.is_some_and(|last| last != v) {
                l.hold.updated_at(msg.header.stamp.to_secs());
            }
            l.last_ft = Some(v);
        }
        let mut decided = std::mem::take(&mut self.decided);
        if !self.matcher.on_wrench(leg, msg, |m| decided.push(m)) {
            self.legs[leg].counters.ft_invalid += 1;
        }
        for m in decided.drain(..) {
            self.use_match(leg, m);
        }
        self.decided = decided;
    }

    /// An F/T sample of `leg` the matcher decided on: counted if unmatched, else fed to the
    /// leg's estimator (and kept, when re-evaluating).
    fn use_match(&mut self, leg: usize, m: Match) {
        match m {
            Match::Unmatched => self.legs[leg].counters.ft_unmatched += 1,
            Match::Matched(mt) => {
                let before = if self.keep_row_predictions {
                    self.row_prediction(leg, &mt).zip(self.width_in_use(leg))
                } else {
                    None
                };
                self.matches.push(MatchedRow {
                    leg,
                    matched: mt,
                    before,
                });
                // Where the robot's state put the hip at the matched angle, once for both.
                let state_hip = self.hip_at(leg, mt.angle_t_ns, mt.beta_rad);
                self.watch_gap(leg, &mt, state_hip);
                // An estimate that is no number is never published (the estimator's own guard
                // is its reset; this is the last one).
                if let Some(p) = self.learn(leg, &mt, state_hip)
                    && p.b_k.is_finite()
                    && p.a.is_finite()
                {
                    self.params_out.push((leg, p));
                }
            }
        }
    }

    /// Keeps a matched sample for the leg's own diagnosis; makes the job when one is due (one
    /// waiting per leg at most).
    fn watch_gap(&mut self, leg: usize, mt: &Matched, hip: Option<HipMotion>) {
        let g = self.cfg.gap_check;
        // The diagnosis is of a flat plate's gap: a leg of another shape is not watched. A leg
        // the robot's state places is diagnosed at its hips.
        let lc = &self.cfg.legs[leg];
        if lc.profile.is_some() || self.cfg.model == ModelKind::Sinkage {
            return;
        }
        let Some(l) = self.legs.get_mut(leg) else {
            return;
        };
        let s = Sample {
            t_s: Some(mt.t_ns as f64 * 1e-9),
            beta_rad: mt.beta_rad,
            drag_n: mt.drag_n,
            lift_n: mt.lift_n,
        };
        if !l.gap.push(
            gap::Watched::new(s, hip.as_ref()),
            g.every_strokes,
            g.window_strokes,
        ) {
            return;
        }
        let lc = &self.cfg.legs[leg];
        let job = GapJob {
            leg,
            strokes_samples: l.gap.blocks(),
            model: TerzaghiModel::conventional(lc.plate, lc.medium),
            stamp_ns: mt.t_ns,
            strokes: l.gap.strokes(),
            min_gap_n: g.min_gap_n,
        };
        match self.gap_jobs.iter_mut().find(|j| j.leg == leg) {
            Some(waiting) => {
                *waiting = job;
                self.legs[leg].gap.superseded += 1;
            }
            None => self.gap_jobs.push(job),
        }
    }

    /// Updates the estimator of `leg` with a matched sample; the parameters to publish when
    /// they are due (at most `model_params_rate_hz`, and at once on convergence or a detected
    /// change).
    fn learn(
        &mut self,
        leg: usize,
        mt: &Matched,
        state_hip: Option<HipMotion>,
    ) -> Option<ModelParams> {
        let period_ns = (1e9 / self.cfg.model_params_rate_hz) as i64;
        let stamp = Time::from_nanos(mt.t_ns).unwrap_or_default();
        let t_ns = mt.t_ns;
        let hip = self.with_surface(leg, state_hip);
        let nominal_height =
            state_hip.map_or(self.cfg.legs[leg].plate.hip_height_m(), |h| h.height_m);
        let l = self.legs.get_mut(leg)?;
        let sample = Sample {
            t_s: Some(stamp.to_secs()),
            beta_rad: mt.beta_rad,
            drag_n: mt.drag_n,
            lift_n: mt.lift_n,
        };
        let surface_before = l.surface_estimate();
        if let Some(s) = l.surface.as_mut() {
            let _ = s.update(&sample, nominal_height);
        }
        let est = l.estimator.as_mut()?;
        let before = *est.estimate();
        match est {
            Learner::Bare(e) => {
                let _ = e.update_at(&sample, hip.as_ref());
            }
            Learner::Corrected(e) => {
                // The motion at the angle the sample was matched with (the newest, should it
                // have left the buffer).
                let motions = l.corrected.as_ref().map(|c| &c.motions);
                let motion = motions
                    .and_then(|ms| kept_at(ms, mt.angle_t_ns).or(ms.back().map(|(_, m)| *m)))
                    .unwrap_or_default();
                let _ = e.update_at(&sample, &motion, hip.as_ref());
            }
            Learner::RftScale(e) => {
                // RFT's own prediction at the angle (and hip) the sample was matched with.
                let unit = match &hip {
                    Some(h) => l.model.predict_moving(mt.beta_rad, h),
                    None => l.model.predict(mt.beta_rad),
                };
                if let Ok(u) = unit {
                    let _ = e.update(&sample, [u.drag_n, u.lift_n]);
                }
            }
            Learner::Sinkage(e) => {
                // The regime and depth at the hip as given: the learnt surface is the
                // estimator's own to apply.
                let given = state_hip
                    .unwrap_or_else(|| HipMotion::still(self.cfg.legs[leg].plate.hip_height_m()));
                let reloading = kept_at(&l.reloads, mt.angle_t_ns).unwrap_or(false);
                match l.model.predict_moving(mt.beta_rad, &given) {
                    // A plate held, unloaded, rising or reloading pressed sand bears what the
                    // rig gives it, not the law's force: it teaches nothing of the medium.
                    Ok(u) if u.regime == Regime::Penetration && !reloading => {
                        let _ = e.update(-given.height_m, sample.lift_n);
                    }
                    Ok(_) => e.left_medium(-given.height_m),
                    Err(_) => {}
                }
            }
        }
        let e = *est.estimate();
        let surface_now = l.surface_estimate();
        let surface_event = surface_before.zip(surface_now).is_some_and(|(b, n)| {
            b.converged != n.converged || b.changes_detected != n.changes_detected
        });
        let event = e.converged != before.converged
            || e.changes_detected != before.changes_detected
            || surface_event;
        // Predictions follow the estimate while it is converged.
        let now_identified = e.converged.then_some(e);
        let changed = now_identified.map(|x| (x.b_k, x.a, x.delta_deg))
            != l.identified.map(|x| (x.b_k, x.a, x.delta_deg));
        if changed {
            l.identified = now_identified;
        }
        let due = l
            .last_params_ns
            .is_none_or(|last| t_ns - last >= period_ns || t_ns < last);
        if changed && self.cfg.use_identified {
            self.follow_identified(leg);
        }
        let l = &mut self.legs[leg];
        // The surface's G(beta) follows the identified width.
        if let (true, Some(s), ForceModel::Terzaghi(m)) = (changed, l.surface.as_mut(), &l.model) {
            s.set_model(m);
        }
        // The corrected model predicts with what is learnt while it is converged.
        if let (Some(Learner::Corrected(e)), Some(c), Some(x), true) = (
            &l.estimator,
            &mut l.corrected,
            &l.identified,
            changed && self.cfg.use_identified,
        ) {
            c.model
                .set_linear(x.b_k, x.a, e.coefficients().iter().map(|c| c.value));
        }
        if !(due || event) {
            return None;
        }
        let coefficients = match &l.estimator {
            Some(Learner::Corrected(e)) => e.coefficients(),
            _ => &[],
        };
        // An RFT leg's estimate is of its scale; its b_k and a are the configured ones.
        let lc = &self.cfg.legs[leg];
        let (b_k, a, std_b_k, rft_scale, std_rft_scale) = match &l.estimator {
            Some(Learner::RftScale(_) | Learner::Sinkage(_)) => {
                (lc.width.b_k(), lc.width.a(), 0.0, e.b_k, e.std_b_k)
            }
            _ => (e.b_k, e.a, e.std_b_k, 1.0, 0.0),
        };
        l.last_params_ns = Some(t_ns);
        Some(ModelParams {
            header: Header {
                stamp,
                frame_id: format!("{}_hip", lc.name),
            },
            b_k,
            a,
            delta_deg: e.delta_deg,
            std_b_k,
            std_a: e.std_a,
            std_delta_deg: e.std_delta_deg,
            samples_used: e.samples_used,
            samples_rejected: e.samples_non_finite
                + e.samples_not_excited
                + e.samples_stuck
                + l.counters.ft_unmatched
                + l.counters.ft_invalid,
            innovation_rms_n: e.innovation_rms_n,
            converged: e.converged,
            changes_detected: e.changes_detected.min(u32::MAX as u64) as u32,
            correction_params: coefficients.iter().map(|c| c.name()).collect(),
            correction_values: coefficients.iter().map(|c| c.value).collect(),
            correction_stds: coefficients.iter().map(|c| c.std).collect(),
            rft_scale,
            std_rft_scale,
            surface_offset_m: surface_now.map_or(0.0, |s| s.offset_m),
            std_surface_offset_m: surface_now.map_or(0.0, |s| s.std_offset_m),
            surface_converged: surface_now.is_some_and(|s| s.converged),
        })
    }

    /// The prediction of `leg`'s current model at `beta_rad` (the bare model's, for a leg with
    /// corrections: theirs depend on the leg's motion, see [`Self::row_prediction`]).
    pub fn predict(&self, leg: usize, beta_rad: f64) -> Option<Prediction> {
        self.legs.get(leg)?.model.predict(beta_rad).ok()
    }

    /// The prediction next to a matched F/T sample of `leg` when re-evaluating: for a leg with
    /// corrections, the one made for the joint angle it was matched with; else the current
    /// model's at its angle.
    pub fn row_prediction(&self, leg: usize, mt: &Matched) -> Option<RowPrediction> {
        let l = self.legs.get(leg)?;
        let mut row = self.row_prediction_unheld(leg, mt)?;
        // A sample-and-hold sensor's reading, as predicted at the angle.
        if let Some(held) = kept_at(&l.held, mt.angle_t_ns) {
            row.sensor_n = held;
        }
        Some(row)
    }

    fn row_prediction_unheld(&self, leg: usize, mt: &Matched) -> Option<RowPrediction> {
        let l = self.legs.get(leg)?;
        match &l.corrected {
            Some(c) => kept_at(&c.recent, mt.angle_t_ns),
            None => {
                let p =
                    match self.with_surface(leg, self.hip_at(leg, mt.angle_t_ns, mt.beta_rad)) {
                        Some(h) => l.model.predict_moving(mt.beta_rad, &h),
                        None => l.model.predict(mt.beta_rad),
                    }
                    .ok()?;
                let mut p = match l.rft_scale(self.cfg.use_identified) {
                    Some(s) => p.scaled(s),
                    None => p,
                };
                if p.regime == Regime::Penetration
                    && kept_at(&l.reloads, mt.angle_t_ns).unwrap_or(false)
                {
                    p.regime = Regime::Unloading;
                }
                Some(RowPrediction::bare(p))
            }
        }
    }

    /// The fitting width `leg` predicts with now (an RFT or sinkage leg's scale as `b_k`, with
    /// `a` 1), and whether it is identified.
    pub fn width_in_use(&self, leg: usize) -> Option<(f64, f64, bool)> {
        let l = self.legs.get(leg)?;
        if let Some(c) = &l.corrected {
            let c = c.model.corrections();
            return Some((c.b_k, c.a, false));
        }
        // An RFT, sinkage or body leg's estimate is its scale: 1 until learnt, never a Terzaghi
        // b_k.
        let scale_only = matches!(
            l.model,
            ForceModel::Rft(_) | ForceModel::Sinkage(_) | ForceModel::Body(_)
        );
        Some(match (&l.identified, self.cfg.use_identified) {
            (Some(e), true) => (e.b_k, e.a, true),
            _ if scale_only => (1.0, 1.0, false),
            _ => (
                self.cfg.legs[leg].width.b_k(),
                self.cfg.legs[leg].width.a(),
                false,
            ),
        })
    }

    /// How many legs the node predicts for.
    pub fn legs(&self) -> usize {
        self.legs.len()
    }

    /// The name of leg `leg`, as the parameter `legs` gives it.
    pub fn leg_name(&self, leg: usize) -> Option<&str> {
        self.cfg.legs.get(leg).map(|l| l.name.as_str())
    }

    /// Counters of `leg` (by index), if the node has it.
    pub fn leg_counters(&self, leg: usize) -> Option<LegCounters> {
        self.legs.get(leg).map(|l| l.counters)
    }

    /// The node's counters.
    pub fn counters(&self) -> NodeCounters {
        self.counters
    }

    /// The surface's estimate of `leg`, for a leg that learns it.
    pub fn surface_estimate(&self, leg: usize) -> Option<crate::ident::SurfaceEstimate> {
        self.legs.get(leg)?.surface_estimate()
    }

    /// The online estimate of `leg` (by index), if the node has it.
    pub fn estimate(&self, leg: usize) -> Option<Estimate> {
        self.legs
            .get(leg)?
            .estimator
            .as_ref()
            .map(|e| *e.estimate())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{defaults, parse_params_yaml};
    use crate::msgs::{DiagnosticArray, DiagnosticStatus};

    /// The node of a params YAML file's text.
    fn config_of(yaml: &str) -> NodeConfig {
        let mut p = defaults();
        p.extend(parse_params_yaml(yaml, "t", "terzaghi", "/").unwrap());
        NodeConfig::from_params(&p, "terzaghi", "/", &[]).unwrap()
    }

    fn config(extra: &str) -> NodeConfig {
        let yaml = format!(
            "/**:\n  ros__parameters:\n    legs: [fl, fr]\n    fl:\n      joint: hip_fl\n      length_m: 0.25\n      width_m: 0.06\n      hip_height_m: 0.15\n      unit_weight_n_m3: 16170\n      phi_deg: 32.0\n      delta_deg: 19.0\n      b_k: 2.0\n      a: 1.5\n      ft_topic: fl/ft\n{extra}    fr:\n      length_m: 0.25\n      width_m: 0.06\n      hip_height_m: 0.15\n      medium: hit_sand\n      direction: -1\n"
        );
        config_of(&yaml)
    }

    fn js(t_ns: i64, names: &[&str], pos: &[f64]) -> JointState {
        JointState {
            header: Header {
                stamp: Time::from_nanos(t_ns).unwrap(),
                frame_id: String::new(),
            },
            name: names.iter().map(|s| s.to_string()).collect(),
            position: pos.to_vec(),
            velocity: vec![],
            effort: vec![],
        }
    }

    #[test]
    fn a_wheel_legs_estimate_is_its_scale_not_its_mediums_b_k() {
        // hit_sand has a fitted b_k for a 60 mm plate, which a wheel 60 mm wide must not show.
        let yaml = "/**:\n  ros__parameters:\n    model: rft\n    legs: [w]\n    w:\n      shape: wheel\n      wheel:\n        radius_m: 0.058\n      width_m: 0.06\n      hip_height_m: 0.033\n      medium: hit_sand\n      rft_coeffs: poppy_lp\n      ft_topic: w/ft\n";
        let cfg = config_of(yaml);
        assert_ne!(cfg.legs[0].width.b_k(), 1.0);
        let core = NodeCore::new(cfg);
        assert_eq!(core.width_in_use(0), Some((1.0, 1.0, false)));
    }

    /// A hip moving across the robot's forward (a log's hip_vy_m_s, or /tf) gives an RFT leg and
    /// a wheel their side force, roll and yaw moments, published as the wrench's y force and x
    /// and z torques in the hip frame (+y the robot's right: moving left, a leg is pushed right).
    #[test]
    fn a_hip_moving_sideways_publishes_the_full_wrench() {
        let yaml = "/**:\n  ros__parameters:\n    model: rft\n    legs: [p, w]\n    p:\n      length_m: 0.25\n      width_m: 0.06\n      hip_height_m: 0.15\n      medium: poppy_lp\n      rft_coeffs: poppy_lp\n    w:\n      shape: wheel\n      wheel:\n        radius_m: 0.058\n      width_m: 0.05\n      hip_height_m: 0.033\n      medium: poppy_lp\n      rft_coeffs: poppy_lp\n";
        let cfg = config_of(yaml);
        for lateral_m_s in [0.0, 0.05, -0.05] {
            let mut core = NodeCore::new(cfg.clone());
            let mut out = Outputs::default();
            for (leg, height_m) in [(0, 0.15), (1, 0.033)] {
                let hip = HipMotion {
                    height_m,
                    forward_m_s: 0.02,
                    lateral_m_s,
                    ..HipMotion::default()
                };
                core.handle(Input::Hip(leg, 1_000, hip), &mut out);
            }
            let angles = [60f64.to_radians(), 0.0];
            core.handle(Input::Joints(&js(1_000, &["p", "w"], &angles)), &mut out);
            assert_eq!(out.legs.len(), 2, "{lateral_m_s}");
            for o in &out.legs {
                let (f, w) = (&o.force, &o.wrench.wrench);
                let case = format!("leg {} moving {lateral_m_s} m/s left: {f:?}", o.leg);
                assert_eq!(f.hip_lateral_m_s, lateral_m_s, "{case}");
                assert!(f.drag_n.hypot(f.lift_n) > 0.5, "{case}");
                assert_eq!(
                    [w.force.y, w.torque.x, w.torque.z],
                    [f.side_n, f.roll_moment_nm, f.yaw_moment_nm],
                    "{case}"
                );
                if lateral_m_s == 0.0 {
                    assert_eq!(f.side_n, 0.0, "{case}");
                } else {
                    assert_eq!(f.side_n.signum(), lateral_m_s.signum(), "{case}");
                    assert!(f.side_n.abs() > 0.01 * f.drag_n.hypot(f.lift_n), "{case}");
                }
            }
        }
    }

    /// A wheel pressed down, eased back and pressed again into its own rut reloads sand it
    /// already pressed until it passes its deepest point (regime unloading, counted apart from
    /// the law's loading); rolled along, it meets fresh sand.
    #[test]
    fn a_wheel_pressed_again_into_its_own_rut_reloads_it() {
        let yaml = "/**:\n  ros__parameters:\n    model: rft\n    legs: [w]\n    w:\n      shape: wheel\n      wheel:\n        radius_m: 0.058\n      width_m: 0.05\n      hip_height_m: 0.05\n      medium: poppy_lp\n      rft_coeffs: poppy_lp\n";
        let cfg = config_of(yaml);
        let mut core = NodeCore::new(cfg);
        let mut out = Outputs::default();
        // Depth (mm) at 2 mm/s down or up: to 20, back to 10, down to 30.
        let mut depths: Vec<f64> = (0..=20).map(f64::from).collect();
        depths.extend((10..20).rev().map(f64::from));
        depths.extend((11..=30).map(f64::from));
        let mut regimes = Vec::new();
        for (i, d) in depths.iter().enumerate() {
            let t = 1_000 + 500_000_000 * i as i64;
            let up = match (i.checked_sub(1).map(|j| depths[j]), d) {
                (Some(before), d) if *d < before => 0.002,
                _ => -0.002,
            };
            let hip = HipMotion {
                height_m: 0.058 - d * 1e-3,
                up_m_s: up,
                ..HipMotion::default()
            };
            core.handle(Input::Hip(0, t, hip), &mut out);
            core.handle(Input::Joints(&js(t, &["w"], &[0.0])), &mut out);
            let f = &out.legs.last().unwrap().force;
            regimes.push((*d, up < 0.0, Regime::from_code(f.regime).unwrap(), f.lift_n));
        }
        let mut deepest = 0.0f64;
        for &(d, down, regime, lift) in &regimes[1..] {
            let case = format!("{d} mm, {}: {regimes:?}", if down { "down" } else { "up" });
            assert!(lift > 0.0, "{case}");
            // Down through sand not pressed before: the law's loading; back up, or down
            // again above the deepest point (20 mm, within 0.5 mm): unloading.
            let virgin = down && d >= deepest - 0.5;
            deepest = deepest.max(d);
            let want = if virgin {
                Regime::Penetration
            } else {
                Regime::Unloading
            };
            assert_eq!(regime, want, "{case}");
        }
        assert!(
            regimes
                .iter()
                .filter(|r| r.1 && r.2 == Regime::Unloading)
                .count()
                >= 8
        );
        // Rolled along at the same depth, it meets fresh sand and presses it as new.
        let t = 1_000 + 500_000_000 * depths.len() as i64;
        let hip = HipMotion {
            height_m: 0.058 - 0.025,
            forward_m_s: 0.01,
            up_m_s: -0.002,
            ..HipMotion::default()
        };
        core.handle(Input::Hip(0, t, hip), &mut out);
        core.handle(Input::Joints(&js(t, &["w"], &[0.0])), &mut out);
        let rolled = &out.legs.last().unwrap().force;
        assert_eq!(rolled.regime, Regime::Penetration.code());
    }

    #[test]
    fn predicts_each_leg_in_its_hip_frame() {
        let mut core = NodeCore::new(config(""));
        let mut out = Vec::new();
        core.on_joint_state(
            &js(
                1_000,
                &["fr", "hip_fl"],
                &[-60f64.to_radians(), 60f64.to_radians()],
            ),
            &mut out,
        );
        assert_eq!(out.len(), 2);
        let fl = &out[0];
        assert_eq!(fl.wrench.header.frame_id, "fl_hip");
        assert!(
            (fl.force.drag_n - 39.674130 * 2.0 * 1.5f64.powf(-60f64.to_radians())).abs() < 1e-5
        );
        assert_eq!(fl.wrench.wrench.force.x, -fl.force.drag_n);
        assert_eq!(fl.wrench.wrench.torque.y, fl.force.hip_torque_nm);
        // direction -1 maps -60 deg to +60 deg.
        assert!((out[1].force.attack_angle_rad - 60f64.to_radians()).abs() < 1e-12);
    }

    /// An RFT leg with a speed law is predicted at the rate its joint turns, also at the
    /// configured height and across the angle's wrap at 2 pi.
    #[test]
    fn an_rft_leg_with_a_speed_law_is_predicted_at_its_turning_rate() {
        use std::f64::consts::TAU;
        let yaml = "/**:\n  ros__parameters:\n    legs: [fl]\n    model: rft\n    fl:\n      length_m: 0.25\n      width_m: 0.06\n      hip_height_m: 0.15\n      medium: poppy_lp\n      rft_coeffs: poppy_lp\n      rft_speed_file: tests/dem/campaign/rft_entry.csv\n";
        let cfg = config_of(yaml);
        let law = cfg.legs[0].rft_speed.unwrap().law;
        let core_rft_elements = cfg.rft_elements;
        let mut core = NodeCore::new(cfg);
        let mut out = Vec::new();
        // 4 rad/s: 0.04 rad every 10 ms, through 2 pi and on to 1 rad.
        let mut beta = TAU - 0.1;
        for k in 0..30 {
            core.on_joint_state(
                &js(1_000_000_000 + 10_000_000 * k, &["fl"], &[beta]),
                &mut out,
            );
            assert!(
                (core.legs[0].omega_rad_s - 4.0).abs() < 1e-6 || k == 0,
                "{k}: {}",
                core.legs[0].omega_rad_s
            );
            beta = (beta + 0.04) % TAU;
        }
        let last = out.last().unwrap();
        let rft = crate::model::RftModel::new(
            Plate::new(0.25, 0.06, 0.15).unwrap(),
            crate::model::RftCoefficients::Fit(crate::model::RftFit::POPPY_LP),
            core_rft_elements,
        )
        .unwrap();
        let hip = HipMotion {
            omega_rad_s: 4.0,
            ..HipMotion::still(0.15)
        };
        let want = rft
            .clone()
            .with_speed_law(Some(law))
            .evaluate_moving(last.force.attack_angle_rad, &hip)
            .unwrap();
        let quasi_static = rft.evaluate(last.force.attack_angle_rad).unwrap();
        assert!((last.force.drag_n - want.drag_n).abs() < 1e-9 * want.drag_n.abs().max(1.0));
        assert!(
            want.drag_n > 1.2 * quasi_static.drag_n,
            "{want:?} {quasi_static:?}"
        );
    }

    fn hip_tf(t_ns: i64, z_m: f64, pitch_rad: f64) -> TfMessage {
        use crate::msgs::{Quaternion, Transform, TransformStamped};
        let (s, c) = (pitch_rad / 2.0).sin_cos();
        TfMessage {
            transforms: vec![TransformStamped {
                header: Header {
                    stamp: Time::from_nanos(t_ns).unwrap(),
                    frame_id: "odom".into(),
                },
                child_frame_id: "fl_hip".into(),
                transform: Transform {
                    translation: Vector3 {
                        x: 0.0,
                        y: 0.0,
                        z: z_m,
                    },
                    rotation: Quaternion {
                        x: 0.0,
                        y: s,
                        z: 0.0,
                        w: c,
                    },
                },
            }],
        }
    }

    /// robot_state_publisher sends a JointState before the /tf of its stamp: the prediction is
    /// the same as with /tf first (to the second order of the hip's motion over one period),
    /// and the hip's velocity never reads zero for it.
    #[test]
    fn the_order_of_joint_states_and_tf_of_one_stamp_does_not_change_a_prediction() {
        let beta = 60f64.to_radians();
        let run = |tf_first: bool| {
            let mut core = NodeCore::new(config("      hip_frame: fl_hip\n"));
            let mut forces = Vec::new();
            for k in 0..400i64 {
                let t_ns = 1_000_000_000 + k * 5_000_000;
                // The hip heaves 2 cm at 1.5 Hz.
                let t = t_ns as f64 * 1e-9;
                let tf = hip_tf(
                    t_ns,
                    0.13 + 0.02 * (std::f64::consts::TAU * 1.5 * t).sin(),
                    0.0,
                );
                let mut out = Vec::new();
                if tf_first {
                    core.on_tf(&tf, false);
                }
                core.on_joint_state(&js(t_ns, &["hip_fl"], &[beta]), &mut out);
                if !tf_first {
                    core.on_tf(&tf, false);
                }
                forces.push(out[0].force.clone());
            }
            forces
        };
        let (a, b) = (run(true), run(false));
        let mut zero_velocity = 0;
        // From the third stamp on, both orders know two transforms.
        for (x, y) in a.iter().zip(&b).skip(2) {
            assert!(x.robot_state && y.robot_state);
            assert!(
                (x.hip_height_m - y.hip_height_m).abs() < 2e-4,
                "{} {}",
                x.hip_height_m,
                y.hip_height_m
            );
            assert!((x.hip_up_m_s - y.hip_up_m_s).abs() < 0.01 + 0.05 * x.hip_up_m_s.abs());
            let scale = x.lift_n.abs().max(1.0);
            assert!(
                (x.lift_n - y.lift_n).abs() < 0.01 * scale,
                "{} {}",
                x.lift_n,
                y.lift_n
            );
            zero_velocity += usize::from(y.hip_up_m_s == 0.0);
        }
        assert_eq!(zero_velocity, 0);
    }

    #[test]
    fn a_leg_with_a_hip_frame_predicts_where_tf_puts_its_hip_and_counts_when_it_cannot() {
        let mut core = NodeCore::new(config("      hip_frame: fl_hip\n"));
        let mut out = Vec::new();
        let beta = 60f64.to_radians();
        // No transform yet: the configured height, counted.
        core.on_joint_state(&js(1_000_000, &["hip_fl"], &[beta]), &mut out);
        let fixed = out[0].force.clone();
        assert!(!fixed.robot_state);
        assert_eq!(fixed.hip_height_m, 0.15);
        assert_eq!(core.leg_counters(0).unwrap().state_missing, 1);
        // The hip 2 cm lower and the body pitched 3 deg nose down: the model at 0.13 m and
        // 63 deg.
        let pitch = 3f64.to_radians();
        core.on_tf(&hip_tf(2_000_000, 0.13, pitch), false);
        out.clear();
        core.on_joint_state(&js(2_000_000, &["hip_fl"], &[beta]), &mut out);
        let f = &out[0].force;
        let want = TerzaghiModel::new(
            crate::model::Plate::new(0.25, 0.06, 0.13).unwrap(),
            core.config().legs[0].medium,
            FittingWidth::new(2.0, 1.5).unwrap(),
        )
        .evaluate(beta + pitch)
        .unwrap();
        assert!(f.robot_state);
        assert!((f.hip_height_m - 0.13).abs() < 1e-12);
        assert!((f.body_pitch_rad - pitch).abs() < 1e-12);
        assert!(
            (f.drag_n - want.drag_n).abs() < 1e-9,
            "{} {}",
            f.drag_n,
            want.drag_n
        );
        assert!((f.lift_n - want.lift_n).abs() < 1e-9);
        assert!(f.drag_n > fixed.drag_n);
        // A second later the transform is stale: the configured height again, counted.
        out.clear();
        core.on_joint_state(&js(1_002_000_000, &["hip_fl"], &[beta]), &mut out);
        assert!(!out[0].force.robot_state);
        let c = core.leg_counters(0).unwrap();
        assert_eq!((c.state_used, c.state_missing, c.state_stale), (1, 1, 1));
        let d = core.diagnostics(1_003_000_000, 0, &[]);
        let fl = &d.status[1];
        assert_eq!(fl.level, DiagnosticStatus::WARN);
        assert!(
            fl.values
                .iter()
                .any(|k| k.key == "state_stale" && k.value == "1")
        );
        // The leg without a hip frame never reads /tf.
        assert_eq!(core.leg_counters(1).unwrap().state_missing, 0);
        // A NaN transform (skipped) and one stamped a year ahead (kept beside the true ones):
        // the hip where it was, the node's status a WARN that counts the NaN one, OK again once
        // such transforms stop.
        let mut nan = hip_tf(1_003_000_000, 0.13, pitch);
        nan.transforms[0].transform.translation.z = f64::NAN;
        core.on_tf(&nan, false);
        core.on_tf(&hip_tf(365 * 86_400 * 1_000_000_000, 0.5, 0.0), false);
        core.on_tf(&hip_tf(1_003_000_000, 0.13, pitch), false);
        out.clear();
        core.on_joint_state(&js(1_003_000_000, &["hip_fl"], &[beta]), &mut out);
        assert!(out[0].force.robot_state);
        assert!((out[0].force.hip_height_m - 0.13).abs() < 1e-12);
        let node = |d: &DiagnosticArray| {
            let n = d.status[0].clone();
            let v = n
                .values
                .iter()
                .find(|k| k.key == "invalid_transforms")
                .map(|k| k.value.clone());
            (n.level, v)
        };
        let d = core.diagnostics(1_004_000_000, 0, &[]);
        assert_eq!(
            node(&d),
            (DiagnosticStatus::WARN, Some("1".to_string())),
            "{:?}",
            d.status[0]
        );
        let d = core.diagnostics(1_005_000_000, 0, &[]);
        assert_eq!(node(&d), (DiagnosticStatus::OK, Some("1".to_string())));
    }

    #[test]
    fn a_body_pose_places_the_hips_given_in_the_body() {
        use crate::msgs::{Point, Pose, Quaternion};
        let mut core = NodeCore::new(config("      hip_offset_m: [0.2, 0.1, 0.0]\n"));
        let mut out = Vec::new();
        // The body 0.17 m up, pitched 5 deg nose down: the hip 0.2 m ahead sits 0.2 sin 5 deg
        // lower.
        let pitch = 5f64.to_radians();
        let (s, c) = (pitch / 2.0).sin_cos();
        core.on_pose(&PoseStamped {
            header: Header {
                stamp: Time::from_nanos(1_000).unwrap(),
                frame_id: String::new(),
            },
            pose: Pose {
                position: Point {
                    x: 1.0,
                    y: 0.0,
                    z: 0.17,
                },
                orientation: Quaternion {
                    x: 0.0,
                    y: s,
                    z: 0.0,
                    w: c,
                },
            },
        });
        core.on_joint_state(&js(1_000, &["hip_fl"], &[1.0]), &mut out);
        let f = &out[0].force;
        assert!(f.robot_state);
        assert!(
            (f.hip_height_m - (0.17 - 0.2 * pitch.sin())).abs() < 1e-12,
            "{f:?}"
        );
        assert!((f.body_pitch_rad - pitch).abs() < 1e-12);
        let bad = "/**:\n  ros__parameters:\n    legs: [fl]\n    fl:\n      length_m: 0.25\n      width_m: 0.06\n      hip_height_m: 0.15\n      medium: hit_sand\n      hip_offset_m: [0.2, 0.1]\n";
        let mut p = defaults();
        p.extend(parse_params_yaml(bad, "t", "terzaghi", "/").unwrap());
        let e = NodeConfig::from_params(&p, "terzaghi", "/", &[])
            .unwrap_err()
            .to_string();
        assert!(e.contains("fl.hip_offset_m"), "{e}");
    }

    #[test]
    fn a_corrected_leg_placed_by_tf_predicts_at_its_hip() {
        let extra = "      hip_frame: fl_hip\n      corrections:\n        effects: [cohesion, sensor_bias]\n        cohesion: {normal_pa: 300.0, tangential_pa: 100.0}\n        sensor_bias: {drag_n: 1.0, lift_n: 0.5}\n";
        let mut core = NodeCore::new(config(extra));
        let mut out = Vec::new();
        let (beta, pitch) = (60f64.to_radians(), 3f64.to_radians());
        core.on_tf(&hip_tf(2_000_000, 0.13, pitch), false);
        core.on_joint_state(&js(2_000_000, &["hip_fl"], &[beta]), &mut out);
        let f = &out[0].force.clone();
        // The same corrected model built for a plate whose hip is 0.13 m up, at beta + pitch.
        let lc = &core.config().legs[0];
        let corrections = lc.corrections.clone().unwrap();
        let at_hip = CorrectedModel::new(
            crate::model::Plate::new(0.25, 0.06, 0.13).unwrap(),
            lc.medium,
            corrections,
        )
        .unwrap();
        let want = at_hip.evaluate(beta + pitch, &Motion::default()).unwrap();
        assert!(f.robot_state);
        assert!((f.hip_height_m - 0.13).abs() < 1e-12);
        assert!((f.body_pitch_rad - pitch).abs() < 1e-12);
        for (have, want) in [
            (f.drag_n, want.drag_n),
            (f.lift_n, want.lift_n),
            (f.bare_drag_n, want.bare.drag_n),
            (f.sensor_lift_n, want.sensor_lift_n),
        ] {
            assert!((have - want).abs() < 1e-9, "{have} against {want}: {f:?}");
        }
        assert_eq!(f.correction_names, vec!["cohesion".to_string()]);
        // At the configured height (no transform) the forces are smaller: the hip is higher.
        let mut fixed = NodeCore::new(config(extra));
        out.clear();
        fixed.on_joint_state(&js(2_000_000, &["hip_fl"], &[beta]), &mut out);
        assert!(!out[0].force.robot_state);
        assert!(out[0].force.drag_n < f.drag_n);
    }

    #[test]
    fn counts_every_kind_of_bad_input() {
        let mut core = NodeCore::new(config(""));
        let mut out = Vec::new();
        core.on_joint_state(&js(10, &["hip_fl", "fr"], &[1.0]), &mut out); // unequal arrays
        core.on_joint_state(&js(20, &["other"], &[1.0]), &mut out); // missing joints
        core.on_joint_state(
            &js(30, &["hip_fl", "fr"], &[f64::NAN, f64::INFINITY]),
            &mut out,
        );
        core.on_joint_state(&js(40, &["hip_fl", "fr"], &[1.0, 1.0]), &mut out);
        core.on_joint_state(&js(35, &["hip_fl", "fr"], &[1.0, 1.0]), &mut out); // backwards
        assert_eq!(out.len(), 2);
        assert_eq!(core.counters().invalid_joint_states, 1);
        let c = core.leg_counters(0).unwrap();
        assert_eq!(
            (
                c.missing_joint,
                c.invalid_position,
                c.stamps_backwards,
                c.predictions
            ),
            (1, 1, 1, 1)
        );
        // An F/T sample far before any joint angle, and a NaN one; one far after waits.
        let w = |t: i64, x: f64| WrenchStamped {
            header: Header {
                stamp: Time::from_nanos(t).unwrap(),
                frame_id: "ft".into(),
            },
            wrench: Wrench {
                force: Vector3 { x, y: 0.0, z: 1.0 },
                torque: Vector3::default(),
            },
        };
        core.on_wrench(0, &w(-5_000_000_000, -1.0));
        core.on_wrench(0, &w(40, f64::NAN));
        core.on_wrench(7, &w(40, 1.0));
        core.on_wrench(0, &w(5_000_000_000, -1.0));
        let mut params = Vec::new();
        params.append(&mut core.params_out);
        assert!(params.is_empty());
        let c = core.leg_counters(0).unwrap();
        assert_eq!((c.ft_unmatched, c.ft_invalid), (1, 1));
        // The waiting one is matched (and found too far) when a later angle arrives.
        core.on_joint_state(&js(6_000_000_000, &["hip_fl", "fr"], &[1.0, 1.0]), &mut out);
        assert_eq!(core.leg_counters(0).unwrap().ft_unmatched, 2);
        let d = core.diagnostics(1_000_000_000, 3, &[]);
        assert_eq!(d.status.len(), 3);
        assert_eq!(d.status[0].level, DiagnosticStatus::WARN);
        assert!(
            d.status[1]
                .values
                .iter()
                .any(|k| k.key == "ft_unmatched" && k.value == "2")
        );
    }

    #[test]
    fn leg_frame_wrench_converts_to_hip_frame() {
        let mut core = NodeCore::new(config("      ft_frame: leg\n"));
        let mut out = Vec::new();
        let beta = 70f64.to_radians();
        core.on_joint_state(&js(1_000_000, &["hip_fl", "fr"], &[beta, 0.0]), &mut out);
        let (d, l) = (out[0].force.drag_n, out[0].force.lift_n);
        // The same force expressed in the leg frame: rotate (F_x, F_z) = (-d, l) by beta - pi/2.
        let (s, c) = beta.sin_cos();
        let (fx, fz) = (-d, l);
        let (fxl, fzl) = (fx * s - fz * c, fx * c + fz * s);
        let m = WrenchStamped {
            header: out[0].wrench.header.clone(),
            wrench: Wrench {
                force: Vector3 {
                    x: fxl,
                    y: 0.0,
                    z: fzl,
                },
                torque: Vector3::default(),
            },
        };
        core.on_wrench(0, &m);
        let mut params = Vec::new();
        params.append(&mut core.params_out);
        assert_eq!(params[0].1.samples_used, 1);
        // The log-linear start-up sees the exact force: b_k a^-beta is recovered at this angle.
        let e = core.estimate(0).unwrap();
        assert!(
            (e.b_k * e.a.powf(-beta) - 2.0 * 1.5f64.powf(-beta)).abs() < 0.2,
            "{e:?}"
        );
    }
}
