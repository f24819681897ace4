//! The node's configuration, validated once from its parameters; every error names the
//! parameter and its value.

use super::corrections::{corrections_params, leg_corrections};
use super::names::{check_name, resolve_topic};
use super::{ConfigError, ParamMap, ParamValue, invalid, model_err};
use crate::ident::OnlineOptions;
use crate::ident::online::Forgetting;
use crate::model::medium::{self, MediumPreset, RftSet};
use crate::model::{
    Corrections, FittingWidth, ForceModel, Medium, ModelError, Plate, PlateField, RftCoefficients,
    RftModel, TerzaghiModel,
};
use std::path::PathBuf;

/// Which model the node evaluates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelKind {
    /// The improved Terzaghi model (fitting width `b_e = b_k b a^(-beta)`).
    Improved,
    /// The conventional Terzaghi model (`b_e = b`).
    Conventional,
    /// Resistive force theory, element by element.
    Rft,
    /// A horizontal plate pushed straight down, by the plate-sinkage law of a medium file.
    Sinkage,
}

impl ModelKind {
    /// The name as the `model` parameter takes it.
    pub fn as_str(self) -> &'static str {
        match self {
            ModelKind::Improved => "improved",
            ModelKind::Conventional => "conventional",
            ModelKind::Rft => "rft",
            ModelKind::Sinkage => "sinkage",
        }
    }
}

/// The frame a leg's F/T sensor reports in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FtFrame {
    /// The hip frame: x along the tip's travel, z up.
    Hip,
    /// The leg frame, turning with the joint: x normal to the plate along its travel, z along the
    /// plate from tip to hip; it equals the hip frame when the leg is vertical.
    Leg,
}

impl FtFrame {
    /// The frame's name in the parameters: `hip` or `leg`.
    pub fn as_str(self) -> &'static str {
        match self {
            FtFrame::Hip => "hip",
            FtFrame::Leg => "leg",
        }
    }

    /// The frame a parameter value names; `None` for another word.
    pub fn from_name(name: &str) -> Option<FtFrame> {
        [FtFrame::Hip, FtFrame::Leg]
            .into_iter()
            .find(|f| f.as_str() == name)
    }
}

/// One leg, validated.
#[derive(Debug, Clone)]
pub struct LegConfig {
    /// The leg's name, as `legs` lists it.
    pub name: String,
    /// `ft_topic` as given (before resolution).
    pub ft_topic_given: String,
    /// The name of the leg's RFT coefficient set (`""` for none).
    pub rft_name: String,
    /// The JointState name of the leg's hip joint.
    pub joint: String,
    /// `+1` or `-1`: `beta = direction * (position - angle_offset_rad)`.
    pub direction: f64,
    /// The joint position at which the attack angle is 0 (rad).
    pub angle_offset_rad: f64,
    /// The leg's plate (for a curved leg, its chord) and configured hip height.
    pub plate: Plate,
    /// The leg's medium.
    pub medium: Medium,
    /// The medium preset the leg names, if it names one.
    pub preset: Option<&'static MediumPreset>,
    /// The configured fitting width (used until identification converges).
    pub width: FittingWidth,
    /// Resolved F/T topic, if the leg has a sensor.
    pub ft_topic: Option<String>,
    /// How the leg's F/T sensor is mounted, and its readings turned into drag and lift.
    pub ft_frame: FtFrame,
    /// The leg's RFT coefficients, for the RFT model.
    pub rft: Option<RftCoefficients>,
    /// RFT's speed law, fitted to `<leg>.rft_speed_file`'s intrusions at several speeds.
    pub rft_speed: Option<crate::model::RftSpeedFit>,
    /// RFT's stress in depth from the leg's medium file (`<leg>.medium`, model rft), where it
    /// is not RFT's linear one.
    pub rft_depth: Option<crate::model::RftDepthLaw>,
    /// The bearing of the sand the leg shears, from the leg's medium file where it has one (a
    /// planar leg's only with `<leg>.sheared_bearing: true`).
    pub rft_sheared: Option<crate::model::ShearedBearing>,
    /// Where the leg's RFT shape comes from, in words, for a leg whose medium is a file (a
    /// measured shape, or a preset's that the file's depth law scales).
    pub rft_shape_text: Option<String>,
    /// How much lower the surface is where the leg's own earlier strokes entered the medium
    /// (m); 0 with `trough_exit_depth_m` 0: the surface is where it was. The robot's state
    /// (`hip_frame`) places the strokes; without it the hip stays where configured, as on a
    /// testbed.
    pub trough_depth_m: f64,
    /// How much lower the surface is where those strokes left the medium (m; negative: the
    /// heap of grains they pushed back), linearly between entry and exit.
    pub trough_exit_depth_m: f64,
    /// The F/T sensor's sample period (s): it holds each value this long, and the node's
    /// expected reading (`leg_force.sensor_*`) is the force held so. 0: it updates with every
    /// message.
    pub sensor_hold_s: f64,
    /// The leg's shape: `None` for a flat plate, else its mid-line (`<leg>.shape` `c_leg` or
    /// `polyline`), which only RFT predicts.
    pub profile: Option<LegProfile>,
    /// The corrected model's terms (`<leg>.corrections.*`), with `width` as its baseline.
    pub corrections: Option<Corrections>,
    /// The hip's frame in `/tf` (`<leg>.hip_frame`): its height, the body's pitch and the hip's
    /// velocity come from the robot's state; `None`, the fixed `hip_height_m`.
    pub hip_frame: Option<String>,
    /// The hip's place in the body's frame (`<leg>.hip_offset_m`, m), for a robot whose state
    /// gives the body's pose only: the node adds it as a fixed transform from
    /// `robot_state.body_frame` to the hip's frame (`<leg>_hip` unless `hip_frame` names one).
    pub hip_offset_m: Option<[f64; 3]>,
    /// For model `sinkage`: the plate (a disc of diameter `width_m`, or a `width_m` by
    /// `length_m` rectangle) and the law of its medium file (`<leg>.medium`).
    pub sinkage: Option<crate::model::sinkage::SinkageLeg>,
    /// A closed body in three dimensions (`<leg>.shape: wheel`), which RFT predicts over its
    /// surface: its hub is the hip, its reach the leg's length.
    pub body: Option<crate::model::Body>,
}

impl LegConfig {
    /// A leg of `plate` in `medium`, turned by `joint` (`beta` = the joint's position), with the
    /// conventional fitting width and no F/T sensor.
    pub fn new(name: &str, joint: &str, plate: Plate, medium: Medium) -> LegConfig {
        LegConfig {
            name: name.to_string(),
            ft_topic_given: String::new(),
            rft_name: String::new(),
            joint: joint.to_string(),
            direction: 1.0,
            angle_offset_rad: 0.0,
            plate,
            medium,
            preset: None,
            width: FittingWidth::CONVENTIONAL,
            hip_frame: None,
            hip_offset_m: None,
            ft_topic: None,
            ft_frame: FtFrame::Hip,
            rft: None,
            rft_speed: None,
            rft_depth: None,
            rft_sheared: None,
            rft_shape_text: None,
            trough_depth_m: 0.0,
            trough_exit_depth_m: 0.0,
            sensor_hold_s: 0.0,
            profile: None,
            corrections: None,
            sinkage: None,
            body: None,
        }
    }
}

/// The default memory (strokes) of the online identification of a leg with corrections.
pub const DEFAULT_CORRECTIONS_MEMORY_STROKES: f64 = 30.0;

/// A leg that is not a flat plate.
#[derive(Debug, Clone, PartialEq)]
pub struct LegProfile {
    /// `c_leg` or `polyline`, as configured.
    pub shape: &'static str,
    /// Its mid-line in the leg's frame: `s` along the chord from the hip, `q` toward the travel.
    pub line: Vec<(f64, f64)>,
}

/// The whole node, validated.
#[derive(Debug, Clone)]
pub struct NodeConfig {
    /// The node's name.
    pub node_name: String,
    /// The node's namespace.
    pub namespace: String,
    /// Which model the node evaluates.
    pub model: ModelKind,
    /// Resolved JointState topic.
    pub joint_states_topic: String,
    /// Whether a leg predicts with its identified `b_k`, `a` once they converge.
    pub use_identified: bool,
    /// The legs, in the order of the `legs` parameter.
    pub legs: Vec<LegConfig>,
    /// The online estimator's options.
    pub estimator: OnlineOptions,
    /// Memory (strokes) of the online identification of a leg with corrections: it learns more
    /// values than the bare model's two, from effects that show in some strokes only. A leg with
    /// `compaction` forgets nothing until its fitted session's strokes have passed.
    pub corrections_memory_strokes: f64,
    /// Identify the surface's level online too (`estimator.fit_surface`), for flat legs of the
    /// Terzaghi models with F/T.
    pub fit_surface: bool,
    /// Elements per leg for RFT.
    pub rft_elements: usize,
    /// Period of `/diagnostics` (s).
    pub diagnostics_period_s: f64,
    /// Largest time between an F/T sample and the joint angle it is matched with.
    pub max_match_dt_s: f64,
    /// Bound of the input queue: beyond it the oldest message is dropped and counted.
    pub queue_depth: usize,
    /// Rate of each leg's `model_params` (Hz).
    pub model_params_rate_hz: f64,
    /// MCAP file to record the session to, if any.
    pub record: Option<PathBuf>,
    /// The node's own diagnosis of each leg's recent strokes.
    pub gap_check: GapCheck,
    /// Where the robot's state (`/tf`) is read from, for the legs with a `hip_frame`.
    pub robot_state: RobotStateConfig,
    /// `-r from:=to`, resolved.
    pub remaps: Vec<(String, String)>,
}

/// How the node diagnoses each leg's recent strokes while it runs (`gap_check.*`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GapCheck {
    /// A diagnosis every this many strokes of a leg (0: none).
    pub every_strokes: usize,
    /// Of the last this many strokes (at least 4).
    pub window_strokes: usize,
    /// The smallest gap a verdict may explain (N; `DiagnoseOptions::min_gap_n`): below it the
    /// leg's gap is `none`, "no gap to explain".
    pub min_gap_n: f64,
}

impl Default for GapCheck {
    fn default() -> Self {
        GapCheck {
            every_strokes: 3,
            window_strokes: 10,
            min_gap_n: crate::diagnose::DiagnoseOptions::default().min_gap_n,
        }
    }
}

/// How the hips' state is read from `/tf` (`robot_state.*`).
#[derive(Debug, Clone, PartialEq)]
pub struct RobotStateConfig {
    /// The frame the surface is level in (`odom` by default).
    pub world_frame: String,
    /// The surface: the plane `z = surface_height_m` of the world frame.
    pub surface_height_m: f64,
    /// A transform older (or newer) than this at a JointState's stamp is stale: the leg falls
    /// back to its configured height, counted in `/diagnostics`.
    pub max_age_s: f64,
    /// For robots without TF: the body's pose as `geometry_msgs/msg/PoseStamped` on this topic
    /// (resolved; `None`: not read), the pose of `body_frame` in the message's frame (the world
    /// frame when it names none).
    pub pose_topic: Option<String>,
    /// The body's frame, whose pose `pose_topic` carries.
    pub body_frame: String,
}

impl Default for RobotStateConfig {
    fn default() -> Self {
        RobotStateConfig {
            world_frame: "odom".into(),
            surface_height_m: 0.0,
            max_age_s: 0.05,
            pose_topic: None,
            body_frame: "base_link".into(),
        }
    }
}

/// Parameters whose change needs a restart (subscriptions and the recorder are made once).
pub const STARTUP_ONLY: [&str; 5] = [
    "legs",
    "joint_states_topic",
    "queue_depth",
    "record",
    "rft_elements",
];

/// Names of the per-leg parameters (`<leg>.<name>`).
pub const LEG_KEYS: [&str; 41] = [
    "joint",
    "direction",
    "angle_offset_rad",
    "length_m",
    "width_m",
    "hip_height_m",
    "medium",
    "unit_weight_n_m3",
    "phi_deg",
    "delta_deg",
    "b_k",
    "a",
    "ft_topic",
    "ft_frame",
    "rft_coeffs",
    "rft_zeta",
    "rft_grid_file",
    "rft_speed_file",
    "shape",
    "profile",
    "c_leg.radius_m",
    "c_leg.span_deg",
    "wheel.radius_m",
    "wheel.grouser_count",
    "wheel.grouser_height_m",
    "wheel.grouser_thickness_m",
    "wheel.rim_elements",
    "foot.radius_m",
    "foot.thickness_m",
    "foot.size_m",
    "mesh.file",
    "mesh.scale",
    "body.xyz_m",
    "body.rpy_rad",
    "body.element_m",
    "hip_frame",
    "hip_offset_m",
    "trough_depth_m",
    "trough_exit_depth_m",
    "sensor_hold_s",
    "sheared_bearing",
];

/// The longest sample period `<leg>.sensor_hold_s` takes (s): a sensor slower than 1 Hz does
/// not follow a leg's stroke.
const MAX_SENSOR_HOLD_S: f64 = 1.0;

/// Node-wide parameters that have no default: the list of legs, and ROS's own simulated time.
const GLOBAL_KEYS_WITHOUT_DEFAULT: [&str; 2] = ["legs", "use_sim_time"];

/// Every key of `params` is one the node knows: a node-wide parameter (one of [`defaults`],
/// `legs` or ROS's `use_sim_time`), or `<leg>.<key>` for a leg of `legs` and a key of
/// [`LEG_KEYS`] (its `corrections.*` are checked with the corrections). An unknown key, at any
/// level, is refused with the nearest known name: a misspelled parameter never falls back to
/// its default unseen. The node, `replay` and every reader of node parameters go through here.
pub fn check_keys(params: &ParamMap, legs: &[String]) -> Result<(), ConfigError> {
    let globals = defaults();
    let known_global =
        |k: &str| globals.contains_key(k) || GLOBAL_KEYS_WITHOUT_DEFAULT.contains(&k);
    for key in params.keys() {
        if known_global(key) {
            continue;
        }
        if let Some((leg, k)) = key.split_once('.')
            && legs.iter().any(|l| l == leg)
        {
            if LEG_KEYS.contains(&k) || k.starts_with("corrections.") {
                continue;
            }
            return Err(invalid(
                key,
                &params[key],
                format!(
                    "unknown leg parameter{}; known: {}",
                    did_you_mean(k, LEG_KEYS.iter().copied()),
                    LEG_KEYS.join(", ")
                ),
            ));
        }
        let every = globals
            .keys()
            .cloned()
            .chain(GLOBAL_KEYS_WITHOUT_DEFAULT.map(String::from))
            .chain(
                legs.iter()
                    .flat_map(|l| LEG_KEYS.iter().map(move |k| format!("{l}.{k}"))),
            )
            .collect::<Vec<_>>();
        let reason = match key.split_once('.') {
            Some((group, _)) if !globals.keys().any(|g| g.starts_with(&format!("{group}."))) => {
                format!(
                    "unknown parameter{} ({group} is not a leg of legs [{}] nor a group of the node's)",
                    did_you_mean(key, every.iter().map(String::as_str)),
                    legs.join(", ")
                )
            }
            _ => format!(
                "unknown parameter{}",
                did_you_mean(key, every.iter().map(String::as_str))
            ),
        };
        return Err(invalid(key, &params[key], reason));
    }
    Ok(())
}

/// `: did you mean X?` for the known name nearest `name` (by edit distance, within a third of
/// its length), else nothing.
fn did_you_mean<'a>(name: &str, known: impl Iterator<Item = &'a str>) -> String {
    known
        .map(|k| (strsim::levenshtein(name, k), k))
        .filter(|(d, _)| *d <= name.len().div_ceil(3).max(2))
        .min()
        .map(|(_, k)| format!(" (did you mean {k}?)"))
        .unwrap_or_default()
}

/// Global parameters and their defaults.
pub fn defaults() -> ParamMap {
    let d = OnlineOptions::default();
    let mut m = ParamMap::new();
    let mut put = |k: &str, v: ParamValue| {
        m.insert(k.to_string(), v);
    };
    put("model", ParamValue::String("improved".into()));
    put(
        "joint_states_topic",
        ParamValue::String("joint_states".into()),
    );
    put("use_identified", ParamValue::Bool(true));
    put("rft_elements", ParamValue::Int(100));
    put("diagnostics_period_s", ParamValue::Double(1.0));
    put("max_match_dt_s", ParamValue::Double(0.02));
    put("queue_depth", ParamValue::Int(2000));
    put("model_params_rate_hz", ParamValue::Double(10.0));
    put("record", ParamValue::String(String::new()));
    put("estimator.fit_delta", ParamValue::Bool(d.fit_delta));
    put("estimator.fit_surface", ParamValue::Bool(false));
    let mem = match d.forgetting {
        Forgetting::Strokes(m) => m,
        Forgetting::PerSample(_) => 3.0,
    };
    put("estimator.memory_strokes", ParamValue::Double(mem));
    put("estimator.forgetting_factor", ParamValue::Double(0.0));
    put(
        "estimator.corrections_memory_strokes",
        ParamValue::Double(DEFAULT_CORRECTIONS_MEMORY_STROKES),
    );
    put(
        "estimator.min_unit_force_n",
        ParamValue::Double(d.min_unit_force_n),
    );
    put("estimator.huber_k", ParamValue::Double(d.huber_k));
    put(
        "estimator.converge_rel_std",
        ParamValue::Double(d.converge_rel_std),
    );
    put("estimator.cusum_alarm", ParamValue::Double(d.cusum_alarm));
    let r = RobotStateConfig::default();
    put("robot_state.world_frame", ParamValue::String(r.world_frame));
    put(
        "robot_state.surface_height_m",
        ParamValue::Double(r.surface_height_m),
    );
    put("robot_state.max_age_s", ParamValue::Double(r.max_age_s));
    put("robot_state.pose_topic", ParamValue::String(String::new()));
    put("robot_state.body_frame", ParamValue::String(r.body_frame));
    let g = GapCheck::default();
    put(
        "gap_check.every_strokes",
        ParamValue::Int(g.every_strokes as i64),
    );
    put(
        "gap_check.window_strokes",
        ParamValue::Int(g.window_strokes as i64),
    );
    put("gap_check.min_gap_n", ParamValue::Double(g.min_gap_n));
    m
}

struct Get<'a>(&'a ParamMap);

impl Get<'_> {
    fn str(&self, name: &str) -> Result<Option<String>, ConfigError> {
        match self.0.get(name) {
            None => Ok(None),
            Some(ParamValue::String(s)) => Ok(Some(s.clone())),
            Some(v) => Err(invalid(name, v, "expected a string")),
        }
    }
    fn f64(&self, name: &str) -> Result<Option<f64>, ConfigError> {
        match self.0.get(name) {
            None => Ok(None),
            Some(ParamValue::Double(x)) if x.is_finite() => Ok(Some(*x)),
            Some(ParamValue::Int(x)) => Ok(Some(*x as f64)),
            Some(v) => Err(invalid(name, v, "expected a finite number")),
        }
    }
    fn bool(&self, name: &str) -> Result<Option<bool>, ConfigError> {
        match self.0.get(name) {
            None => Ok(None),
            Some(ParamValue::Bool(b)) => Ok(Some(*b)),
            Some(v) => Err(invalid(name, v, "expected true or false")),
        }
    }
    fn need_f64(&self, name: &str, hint: &str) -> Result<f64, ConfigError> {
        self.f64(name)?.ok_or_else(|| ConfigError::Missing {
            name: name.to_string(),
            hint: hint.to_string(),
        })
    }
    fn count(&self, name: &str, lo: i64, hi: i64) -> Result<usize, ConfigError> {
        match self.0.get(name) {
            Some(ParamValue::Int(x)) if (lo..=hi).contains(x) => Ok(*x as usize),
            Some(v) => Err(invalid(
                name,
                v,
                format!("expected a whole number from {lo} to {hi}"),
            )),
            None => Err(ConfigError::Missing {
                name: name.into(),
                hint: "no default".into(),
            }),
        }
    }
}

impl NodeConfig {
    /// Validates `params` (defaults already merged) for a node called `node_name` in `namespace`.
    pub fn from_params(
        params: &ParamMap,
        node_name: &str,
        namespace: &str,
        remaps: &[(String, String)],
    ) -> Result<NodeConfig, ConfigError> {
        check_name("node name", node_name, false)?;
        let namespace = if namespace.starts_with('/') {
            namespace.to_string()
        } else {
            format!("/{namespace}")
        };
        if namespace != "/" {
            check_name("namespace", namespace.trim_start_matches('/'), true)?;
        }
        let g = Get(params);
        let model = match g.str("model")?.as_deref().unwrap_or("improved") {
            "improved" => ModelKind::Improved,
            "conventional" => ModelKind::Conventional,
            "rft" => ModelKind::Rft,
            "sinkage" => ModelKind::Sinkage,
            other => {
                return Err(invalid(
                    "model",
                    &other,
                    "expected improved, conventional, rft or sinkage",
                ));
            }
        };
        let leg_names = match params.get("legs") {
            Some(ParamValue::StringArray(v)) if !v.is_empty() => v.clone(),
            Some(ParamValue::String(s)) if !s.is_empty() => vec![s.clone()],
            Some(v) => return Err(invalid("legs", v, "expected a non-empty list of leg names")),
            None => {
                return Err(ConfigError::Missing {
                    name: "legs".into(),
                    hint: "list the legs, e.g. legs: [front_left] in a params file, with <leg>.length_m and so on".into(),
                });
            }
        };
        for (i, n) in leg_names.iter().enumerate() {
            check_name("leg name", n, false).map_err(|_| {
                invalid(
                    "legs",
                    &format!("{leg_names:?}"),
                    format!("leg name {n:?}: use letters, digits and _"),
                )
            })?;
            if leg_names[..i].contains(n) {
                return Err(invalid(
                    "legs",
                    &format!("{leg_names:?}"),
                    format!("{n} appears twice"),
                ));
            }
        }
        for key in params.keys() {
            if let Some((leg, k)) = key.split_once('.')
                && !leg_names.iter().any(|l| l == leg)
                && k.starts_with("corrections.")
            {
                return Err(invalid(
                    key,
                    &params[key],
                    format!(
                        "corrections for a leg {leg:?} the node does not have (legs: {}): a correction file of another robot?",
                        leg_names.join(", ")
                    ),
                ));
            }
        }
        check_keys(params, &leg_names)?;
        let rft_elements = g.count("rft_elements", 1, RftModel::MAX_ELEMENTS as i64)?;
        let mut legs = Vec::new();
        for name in &leg_names {
            legs.push(leg_config(&g, name, model, &namespace, node_name, remaps)?);
        }
        Self::globals(&g, node_name, &namespace, remaps, model, legs, rft_elements)
    }

    /// The node-wide part of the configuration from `g`, with `legs` already made.
    fn globals(
        g: &Get,
        node_name: &str,
        namespace: &str,
        remaps: &[(String, String)],
        model: ModelKind,
        legs: Vec<LegConfig>,
        rft_elements: usize,
    ) -> Result<NodeConfig, ConfigError> {
        let positive = |name: &str| -> Result<f64, ConfigError> {
            let v = g.need_f64(name, "no default")?;
            if v > 0.0 {
                Ok(v)
            } else {
                Err(invalid(name, &v, "must be > 0"))
            }
        };
        let mut est = OnlineOptions {
            fit_delta: g.bool("estimator.fit_delta")?.unwrap_or(false),
            ..Default::default()
        };
        let factor = g.f64("estimator.forgetting_factor")?.unwrap_or(0.0);
        est.forgetting = if factor > 0.0 {
            Forgetting::PerSample(factor)
        } else {
            Forgetting::Strokes(positive("estimator.memory_strokes")?)
        };
        est.min_unit_force_n = g.need_f64("estimator.min_unit_force_n", "no default")?;
        est.huber_k = positive("estimator.huber_k")?;
        est.converge_rel_std = positive("estimator.converge_rel_std")?;
        est.cusum_alarm = positive("estimator.cusum_alarm")?;
        est.validate()
            .map_err(|e| invalid("estimator", &e, "the estimator options are out of range"))?;
        let record = g
            .str("record")?
            .filter(|s| !s.is_empty())
            .map(PathBuf::from);
        let topic = g
            .str("joint_states_topic")?
            .unwrap_or_else(|| "joint_states".into());
        if topic.is_empty() {
            return Err(invalid("joint_states_topic", &topic, "must not be empty"));
        }
        let world_frame = g
            .str("robot_state.world_frame")?
            .unwrap_or_else(|| "odom".into());
        if world_frame.trim_start_matches('/').is_empty() {
            return Err(invalid(
                "robot_state.world_frame",
                &world_frame,
                "must name a frame",
            ));
        }
        let body_frame = g
            .str("robot_state.body_frame")?
            .unwrap_or_else(|| "base_link".into())
            .trim_start_matches('/')
            .to_string();
        if body_frame.is_empty() || body_frame.chars().any(char::is_whitespace) {
            return Err(invalid(
                "robot_state.body_frame",
                &body_frame,
                "must name a frame (no spaces)",
            ));
        }
        let pose_topic = g
            .str("robot_state.pose_topic")?
            .filter(|t| !t.is_empty())
            .map(|t| resolve_topic(&t, namespace, node_name, remaps));
        let robot_state = RobotStateConfig {
            world_frame,
            surface_height_m: g.need_f64("robot_state.surface_height_m", "no default")?,
            max_age_s: positive("robot_state.max_age_s")?,
            pose_topic,
            body_frame,
        };
        Ok(NodeConfig {
            node_name: node_name.to_string(),
            namespace: namespace.to_string(),
            model,
            joint_states_topic: resolve_topic(&topic, namespace, node_name, remaps),
            use_identified: g.bool("use_identified")?.unwrap_or(true),
            legs,
            estimator: est,
            corrections_memory_strokes: positive("estimator.corrections_memory_strokes")?,
            fit_surface: g.bool("estimator.fit_surface")?.unwrap_or(false),
            rft_elements,
            diagnostics_period_s: positive("diagnostics_period_s")?,
            max_match_dt_s: positive("max_match_dt_s")?,
            queue_depth: g.count("queue_depth", 1, 1_000_000)?,
            model_params_rate_hz: positive("model_params_rate_hz")?,
            record,
            gap_check: GapCheck {
                every_strokes: g.count("gap_check.every_strokes", 0, 1_000_000)?,
                window_strokes: g.count("gap_check.window_strokes", 4, 1000)?,
                min_gap_n: {
                    let v = g.need_f64("gap_check.min_gap_n", "no default")?;
                    if v.is_finite() && v >= 0.0 {
                        v
                    } else {
                        return Err(invalid(
                            "gap_check.min_gap_n",
                            &v,
                            "must be a number >= 0 (N)",
                        ));
                    }
                },
            },
            robot_state,
            remaps: remaps.to_vec(),
        })
    }

    /// The node with its default parameters and these legs, reading joint angles from
    /// `joint_states_topic`: for a session recorded by another ROS 2 tool, whose legs are
    /// described by flags rather than by parameters.
    pub fn with_legs(
        legs: Vec<LegConfig>,
        joint_states_topic: &str,
    ) -> Result<NodeConfig, ConfigError> {
        if legs.is_empty() {
            return Err(ConfigError::Missing {
                name: "legs".into(),
                hint: "give at least one leg".into(),
            });
        }
        if joint_states_topic.is_empty() {
            return Err(invalid(
                "joint_states_topic",
                &joint_states_topic,
                "must not be empty",
            ));
        }
        let params = defaults();
        let g = Get(&params);
        let mut cfg = Self::globals(&g, "terzaghi", "/", &[], ModelKind::Improved, legs, 100)?;
        cfg.joint_states_topic = resolve_topic(joint_states_topic, "/", "terzaghi", &[]);
        Ok(cfg)
    }

    /// `given` completed with the value in force of every leg parameter, so that each can be
    /// read and set through the parameter services.
    pub fn effective_params(&self, given: &ParamMap) -> ParamMap {
        let mut m = given.clone();
        for l in &self.legs {
            let mut put = |key: &str, v: ParamValue| {
                m.entry(format!("{}.{key}", l.name)).or_insert(v);
            };
            put("joint", ParamValue::String(l.joint.clone()));
            put("direction", ParamValue::Double(l.direction));
            put("angle_offset_rad", ParamValue::Double(l.angle_offset_rad));
            put("length_m", ParamValue::Double(l.plate.length_m()));
            put("width_m", ParamValue::Double(l.plate.width_m()));
            put("hip_height_m", ParamValue::Double(l.plate.hip_height_m()));
            let preset = l.preset.map(|p| p.name.to_string()).unwrap_or_default();
            put("medium", ParamValue::String(preset));
            put(
                "unit_weight_n_m3",
                ParamValue::Double(l.medium.unit_weight_n_m3()),
            );
            put("phi_deg", ParamValue::Double(l.medium.phi_deg()));
            put("delta_deg", ParamValue::Double(l.medium.delta_deg()));
            put("b_k", ParamValue::Double(l.width.b_k()));
            put("a", ParamValue::Double(l.width.a()));
            put("ft_topic", ParamValue::String(l.ft_topic_given.clone()));
            put("ft_frame", ParamValue::String(l.ft_frame.as_str().into()));
            put("rft_coeffs", ParamValue::String(l.rft_name.clone()));
            put("rft_zeta", ParamValue::Double(0.0));
            put(
                "hip_frame",
                ParamValue::String(l.hip_frame.clone().unwrap_or_default()),
            );
            if let Some(o) = l.hip_offset_m {
                put("hip_offset_m", ParamValue::DoubleArray(o.to_vec()));
            }
            if let Some(c) = &l.corrections {
                for (k, v) in corrections_params(&l.name, &l.plate, &l.medium, c) {
                    m.entry(k).or_insert(v);
                }
            }
        }
        m
    }

    /// The model of leg `i` with fitting width `width` (and plate friction `delta_deg`).
    pub fn leg_model(
        &self,
        i: usize,
        width: FittingWidth,
        delta_deg: Option<f64>,
    ) -> Result<ForceModel, ModelError> {
        let leg = &self.legs[i];
        let medium = match delta_deg {
            Some(d) => leg.medium.with_delta_deg(d)?,
            None => leg.medium,
        };
        Ok(match self.model {
            ModelKind::Improved => {
                ForceModel::Terzaghi(TerzaghiModel::new(leg.plate, medium, width))
            }
            ModelKind::Conventional => {
                ForceModel::Terzaghi(TerzaghiModel::conventional(leg.plate, medium))
            }
            ModelKind::Rft => match (&leg.rft, &leg.profile) {
                (Some(c), _) if leg.body.is_some() => ForceModel::Body(Box::new(
                    crate::model::BodyLeg::new(
                        leg.body.clone().expect("checked"),
                        c.clone(),
                        leg.rft_depth,
                        leg.rft_speed.map(|f| f.law),
                        leg.plate,
                    )
                    .with_sheared_bearing(leg.rft_sheared),
                )),
                (Some(c), Some(p)) => ForceModel::Rft(
                    RftModel::with_profile(
                        leg.plate,
                        c.clone(),
                        self.rft_elements,
                        p.line.clone(),
                    )?
                    .with_speed_law(leg.rft_speed.map(|f| f.law))
                    .with_depth_law(leg.rft_depth)
                    .with_sheared_bearing(leg.rft_sheared),
                ),
                (Some(c), None) => ForceModel::Rft(
                    RftModel::new(leg.plate, c.clone(), self.rft_elements)?
                        .with_speed_law(leg.rft_speed.map(|f| f.law))
                        .with_depth_law(leg.rft_depth)
                        .with_sheared_bearing(leg.rft_sheared),
                ),
                (None, _) => ForceModel::Terzaghi(TerzaghiModel::new(leg.plate, medium, width)),
            },
            ModelKind::Sinkage => {
                match &leg.sinkage {
                    Some(s) => ForceModel::Sinkage(s.clone()),
                    None => {
                        return Err(ModelError::UnknownMedium {
                        name: format!("(none, for leg {})", leg.name),
                        known: "model sinkage needs <leg>.medium: a medium file of terzaghi calibrate".into(),
                    });
                    }
                }
            }
        })
    }
}

fn leg_config(
    g: &Get,
    leg: &str,
    model: ModelKind,
    namespace: &str,
    node: &str,
    remaps: &[(String, String)],
) -> Result<LegConfig, ConfigError> {
    let k = |s: &str| format!("{leg}.{s}");
    let (plate, width, length, body) = leg_geometry(g, leg, model)?;
    let direction = g.f64(&k("direction"))?.unwrap_or(1.0);
    if direction != 1.0 && direction != -1.0 {
        return Err(invalid(&k("direction"), &direction, "expected 1 or -1"));
    }
    let LegMedia {
        sinkage_file,
        rft_medium_file,
        medium,
        preset,
    } = leg_media(g, leg, model, width, length, &plate)?;
    let fit = preset.and_then(|p| p.fitting_width_for(width));
    let (given_b_k, given_a) = (g.f64(&k("b_k"))?, g.f64(&k("a"))?);
    // The improved model's b_k, a come from the parameters, the preset's fit for this width,
    // or the leg's own F/T (identified online from the conventional b_k = a = 1), as `terzaghi
    // predict` asks for them; never silently from nowhere.
    let has_ft = g.str(&k("ft_topic"))?.is_some_and(|t| !t.is_empty());
    if model == ModelKind::Improved
        && fit.is_none()
        && (given_b_k.is_none() || given_a.is_none())
        && !has_ft
    {
        let name = k(if given_b_k.is_none() { "b_k" } else { "a" });
        let hint = match preset {
            Some(p) => format!(
                "medium {} has identified b_k, a only for plate widths {} m, not {width} m: give {} and {}, or an ft_topic to identify them online",
                p.name,
                p.fitted_widths_m(),
                k("b_k"),
                k("a")
            ),
            None => format!(
                "the improved model needs b_k and a for a medium without a preset: give {} and {}, or an ft_topic to identify them online",
                k("b_k"),
                k("a")
            ),
        };
        return Err(ConfigError::Missing { name, hint });
    }
    let b_k = given_b_k.or(fit.map(|f| f.b_k())).unwrap_or(1.0);
    let a = given_a.or(fit.map(|f| f.a())).unwrap_or(1.0);
    let width_fit = FittingWidth::new(b_k, a).map_err(model_err(&k("b_k")))?;
    let corrections = leg_corrections(g.0, leg, &plate, &medium, b_k, a)?;
    if corrections.is_some() && model != ModelKind::Improved {
        return Err(invalid(
            &k("corrections.effects"),
            &model.as_str(),
            "corrections are terms of the improved model: set model to improved, or leave the corrections out",
        ));
    }
    let ft_topic = g
        .str(&k("ft_topic"))?
        .filter(|t| !t.is_empty())
        .map(|t| resolve_topic(&t, namespace, node, remaps));
    let frame = g.str(&k("ft_frame"))?;
    let frame = frame.as_deref().unwrap_or("hip");
    let ft_frame = FtFrame::from_name(frame)
        .ok_or_else(|| invalid(&k("ft_frame"), &frame, "expected hip or leg"))?;
    let LegRft {
        rft_name,
        rft,
        rft_depth,
        rft_speed,
        rft_sheared,
        rft_shape_text,
    } = leg_rft(
        g,
        leg,
        model,
        rft_medium_file.as_ref(),
        preset,
        body.is_some(),
    )?;
    let profile = leg_profile(g, leg, &plate)?;
    if let Some(p) = &profile
        && model != ModelKind::Rft
    {
        return Err(invalid(
            &k("shape"),
            &p.shape,
            format!(
                "a {} leg is not a flat plate: the {} model is a flat plate's; set model to rft",
                p.shape,
                model.as_str()
            ),
        ));
    }
    let joint = g
        .str(&k("joint"))?
        .filter(|j| !j.is_empty())
        .unwrap_or_else(|| leg.to_string());
    let (hip_offset_m, hip_frame) = leg_hip(g, leg)?;
    let (trough_depth_m, trough_exit_depth_m, sensor_hold_s) =
        leg_trough_and_sensor(g, leg, &plate)?;
    Ok(LegConfig {
        name: leg.to_string(),
        ft_topic_given: g.str(&k("ft_topic"))?.unwrap_or_default(),
        rft_name: rft_name.unwrap_or_default(),
        joint,
        direction,
        angle_offset_rad: g.f64(&k("angle_offset_rad"))?.unwrap_or(0.0),
        plate,
        medium,
        preset,
        width: width_fit,
        ft_topic,
        ft_frame,
        rft,
        rft_speed,
        rft_depth,
        rft_sheared,
        rft_shape_text,
        trough_depth_m,
        trough_exit_depth_m,
        sensor_hold_s,
        profile,
        corrections,
        hip_frame,
        hip_offset_m,
        sinkage: sinkage_file.map(|(_, s)| s),
        body: body.map(|(b, _)| b),
    })
}

/// A leg's body where it is a foot or a wheel, with its reach below the hub (m).
type LegBody = Option<(crate::model::Body, f64)>;

/// A leg's plate (its length, width and hip height) with its width and length, and its body
/// where the leg is a foot or a wheel.
fn leg_geometry(
    g: &Get,
    leg: &str,
    model: ModelKind,
) -> Result<(Plate, f64, f64, LegBody), ConfigError> {
    let k = |s: &str| format!("{leg}.{s}");
    let geom_hint = "each leg needs length_m, width_m and hip_height_m";
    let foot = leg_foot(g, leg, model)?;
    let width = match &foot {
        Some((_, _, width_m)) => *width_m,
        None => g.need_f64(&k("width_m"), geom_hint)?,
    };
    let body = match foot {
        Some((body, reach_m, _)) => Some((body, reach_m)),
        None => leg_wheel(g, leg, model, width)?,
    };
    // A sinkage leg is a disc of diameter width_m unless a length makes it a rectangle; a
    // wheel's length is its rim's radius.
    let length = match (model, &body) {
        (_, Some((_, radius_m))) => *radius_m,
        (ModelKind::Sinkage, None) => g.f64(&k("length_m"))?.unwrap_or(width),
        _ => g.need_f64(&k("length_m"), geom_hint)?,
    };
    let height = g.need_f64(&k("hip_height_m"), geom_hint)?;
    let plate = Plate::new(length, width, height).map_err(|e| {
        let which = match &e {
            ModelError::BadPlate {
                field: PlateField::WidthM,
                ..
            } => "width_m",
            ModelError::BadPlate {
                field: PlateField::HipHeightM,
                ..
            } => "hip_height_m",
            _ => "length_m",
        };
        model_err(&k(which))(e)
    })?;
    Ok((plate, width, length, body))
}

/// A leg's media: its medium file (a sinkage leg's, or an RFT leg's law in depth), and the
/// Terzaghi medium with its preset.
struct LegMedia {
    sinkage_file: Option<(
        crate::medium_file::MediumFile,
        crate::model::sinkage::SinkageLeg,
    )>,
    rft_medium_file: Option<(String, crate::medium_file::MediumFile)>,
    medium: Medium,
    preset: Option<&'static MediumPreset>,
}

fn leg_media(
    g: &Get,
    leg: &str,
    model: ModelKind,
    width: f64,
    length: f64,
    plate: &Plate,
) -> Result<LegMedia, ConfigError> {
    let k = |s: &str| format!("{leg}.{s}");
    let sinkage_file = match model {
        ModelKind::Sinkage => Some(sinkage_medium(g, leg, width, length, plate)?),
        _ => None,
    };
    // A medium file of an RFT leg: its law in depth and scale (see `rft_depth` below).
    let rft_medium_file = match (model, g.str(&k("medium"))?) {
        (ModelKind::Rft, Some(v)) if is_medium_file(&v) => Some((
            v.clone(),
            crate::medium_file::MediumFile::read(std::path::Path::new(&v))
                .map_err(|e| invalid(&k("medium"), &v, format!("{e:#}")))?,
        )),
        (ModelKind::Improved | ModelKind::Conventional, Some(v)) if is_medium_file(&v) => {
            return Err(invalid(
                &k("medium"),
                &v,
                "a medium file serves model sinkage and model rft; the Terzaghi models take a preset or soil values",
            ));
        }
        _ => None,
    };
    // A leg whose medium is a file (sinkage, or RFT's stresses in depth).
    let medium_file = sinkage_file
        .as_ref()
        .map(|(f, _)| f)
        .or(rft_medium_file.as_ref().map(|(_, f)| f));
    let (medium, preset) = match (g.str(&k("medium"))?, medium_file) {
        (_, Some(file)) => {
            // The Terzaghi medium of a leg with a medium file is the file's unit weight; its
            // friction angles play no part in the file's law.
            let m = Medium::new(
                file.unit_weight_n_m3,
                g.f64(&k("phi_deg"))?.unwrap_or(30.0),
                g.f64(&k("delta_deg"))?.unwrap_or(0.0),
            )
            .map_err(model_err(&k("medium")))?;
            (m, None)
        }
        (Some(name), None) if !name.is_empty() => {
            let p = medium::preset(&name).map_err(model_err(&k("medium")))?;
            // Explicit soil values override the preset's.
            let m = Medium::new(
                g.f64(&k("unit_weight_n_m3"))?.unwrap_or(p.unit_weight_n_m3),
                g.f64(&k("phi_deg"))?.unwrap_or(p.phi_deg),
                g.f64(&k("delta_deg"))?.unwrap_or(p.delta_deg),
            )
            .map_err(model_err(&k("medium")))?;
            (m, Some(p))
        }
        (_, None) => {
            let hint = "give <leg>.medium (a preset) or unit_weight_n_m3, phi_deg and delta_deg";
            let m = Medium::new(
                g.need_f64(&k("unit_weight_n_m3"), hint)?,
                g.need_f64(&k("phi_deg"), hint)?,
                g.need_f64(&k("delta_deg"), hint)?,
            )
            .map_err(model_err(&k("medium")))?;
            (m, None)
        }
    };
    Ok(LegMedia {
        sinkage_file,
        rft_medium_file,
        medium,
        preset,
    })
}

/// A leg's RFT: its coefficients (by name, grid file or a medium file's measured shape), law in
/// depth, speed law and bearing of sheared sand, and how the start-up line names them.
struct LegRft {
    rft_name: Option<String>,
    rft: Option<RftCoefficients>,
    rft_depth: Option<crate::model::RftDepthLaw>,
    rft_speed: Option<crate::model::RftSpeedFit>,
    rft_sheared: Option<crate::model::ShearedBearing>,
    rft_shape_text: Option<String>,
}

fn leg_rft(
    g: &Get,
    leg: &str,
    model: ModelKind,
    rft_medium_file: Option<&(String, crate::medium_file::MediumFile)>,
    preset: Option<&'static MediumPreset>,
    is_body: bool,
) -> Result<LegRft, ConfigError> {
    let k = |s: &str| format!("{leg}.{s}");
    // A medium file that carries its measured RFT shape gives the leg its coefficients, law in
    // depth and speed law; a coefficient set, grid or speed file beside it is refused.
    let file_law = match rft_medium_file {
        Some((path, file)) if file.rft_shape.is_some() => {
            for key in ["rft_coeffs", "rft_grid_file", "rft_speed_file"] {
                if let Some(v) = g.str(&k(key))?.filter(|s| !s.is_empty()) {
                    return Err(invalid(
                        &k(key),
                        &v,
                        format!(
                            "the leg's medium file {path} carries its own RFT shape and speed law, measured from intrusion tests: leave {} out, or name a medium file without a shape",
                            k(key)
                        ),
                    ));
                }
            }
            Some(
                file.rft_law(None)
                    .map_err(|e| invalid(&k("medium"), path, format!("{e:#}")))?,
            )
        }
        _ => None,
    };
    // The bearing of sheared sand acts on a body's resultant, and on a planar leg's where
    // `<leg>.sheared_bearing` asks for it (a leg turning through fresh sand loses lift it
    // should not: docs/bodies.md); the start-up line says which.
    let sheared_wanted = g.bool(&k("sheared_bearing"))?.unwrap_or(is_body);
    let rft_shape_text = rft_medium_file.map(|(_, f)| match &f.sheared_bearing {
        Some(b) if sheared_wanted => format!("{}; {}", f.rft_shape_text(), b.text()),
        Some(_) => format!(
            "{}; the file's sheared bearing is not applied to this leg (set {}: true to apply it)",
            f.rft_shape_text(),
            k("sheared_bearing")
        ),
        None => f.rft_shape_text(),
    });
    let rft_sheared = match rft_medium_file {
        Some((path, file)) => file
            .sheared()
            .map_err(|e| invalid(&k("medium"), path, format!("{e:#}")))?
            .filter(|_| sheared_wanted),
        None => None,
    };
    let rft_name = g
        .str(&k("rft_coeffs"))?
        .filter(|s| !s.is_empty())
        // A medium file's RFT law was calibrated against poppy_lp's stress.
        .or_else(|| {
            rft_medium_file
                .filter(|_| file_law.is_none())
                .map(|_| crate::medium_file::RFT_SET.to_string())
        })
        .or_else(|| {
            preset.and_then(|p| p.rft).map(|s| match s {
                RftSet::PoppyLp => "poppy_lp".to_string(),
                RftSet::PoppyCp => "poppy_cp".to_string(),
            })
        });
    let zeta = g.f64(&k("rft_zeta"))?.filter(|z| *z != 0.0); // 0: not set
    let grid_file = g.str(&k("rft_grid_file"))?.filter(|f| !f.is_empty());
    let rft_name = match (&grid_file, rft_name) {
        (Some(f), _) => Some(format!("grid file {f}")),
        (None, n) => n,
    };
    let rft = match (&grid_file, rft_name.clone()) {
        _ if file_law.is_some() => file_law.as_ref().map(|l| l.coefficients.clone()),
        (Some(f), _) => Some(rft_from_grid_file(&k("rft_grid_file"), f)?),
        (None, Some(n)) => {
            Some(RftCoefficients::by_name(&n, zeta).map_err(model_err(&k("rft_coeffs")))?)
        }
        (None, None) if model == ModelKind::Rft => {
            return Err(ConfigError::Missing {
                name: k("rft_coeffs"),
                hint: "model rft needs RFT coefficients (poppy_lp, poppy_cp, poppy_lp_grid, generic with rft_zeta, or rft_grid_file) or a medium that has them".into(),
            });
        }
        (None, None) => None,
    };
    let rft_depth = match (rft_medium_file, &rft) {
        _ if file_law.is_some() => file_law.as_ref().map(|l| l.depth_law),
        (Some((path, file)), Some(c)) => Some(
            file.rft_depth_law(c)
                .map_err(|e| invalid(&k("medium"), path, format!("{e:#}")))?,
        ),
        _ => None,
    };
    let rft_speed = match (g.str(&k("rft_speed_file"))?.filter(|f| !f.is_empty()), &rft) {
        _ if file_law.is_some() => {
            let explained = rft_medium_file
                .and_then(|(_, f)| f.rft_shape.as_ref()?.speed_law.as_ref())
                .map_or(f64::NAN, |l| l.explained);
            file_law
                .as_ref()
                .and_then(|l| l.speed_law)
                .map(|law| crate::model::RftSpeedFit {
                    law,
                    explained,
                    one_gain_explained: f64::NAN,
                    quadratic_explained: f64::NAN,
                    factor_law_explained: f64::NAN,
                    intrusions: 0,
                    samples: 0,
                })
        }
        (None, _) => None,
        (Some(_), None) => {
            return Err(invalid(
                &k("rft_speed_file"),
                &model.as_str(),
                "a speed law is RFT's: give RFT coefficients (rft_coeffs or rft_grid_file) and set model to rft",
            ));
        }
        (Some(f), Some(c)) => Some(rft_speed_from_file(&k("rft_speed_file"), &f, c)?),
    };
    Ok(LegRft {
        rft_name,
        rft,
        rft_depth,
        rft_speed,
        rft_sheared,
        rft_shape_text,
    })
}

/// Where a leg's hip is for `/tf`: its offset in the body's frame and its frame's name.
fn leg_hip(g: &Get, leg: &str) -> Result<(Option<[f64; 3]>, Option<String>), ConfigError> {
    let k = |s: &str| format!("{leg}.{s}");
    let hip_offset_m = match g.0.get(&k("hip_offset_m")) {
        None => None,
        Some(ParamValue::DoubleArray(v)) if v.len() == 3 && v.iter().all(|x| x.is_finite()) => {
            Some([v[0], v[1], v[2]])
        }
        Some(v) => {
            return Err(invalid(
                &k("hip_offset_m"),
                v,
                "expected [x, y, z] in metres, the hip in the body's frame",
            ));
        }
    };
    let hip_frame = g
        .str(&k("hip_frame"))?
        .filter(|f| !f.is_empty())
        .map(|f| f.trim_start_matches('/').to_string())
        .or_else(|| hip_offset_m.map(|_| format!("{leg}_hip")));
    if let Some(f) = &hip_frame
        && (f.is_empty() || f.chars().any(char::is_whitespace))
    {
        return Err(invalid(
            &k("hip_frame"),
            f,
            "expected a frame name of /tf (no spaces)",
        ));
    }
    Ok((hip_offset_m, hip_frame))
}

/// A leg's trough (how much deeper its own strokes dug where they entered and where they left)
/// and its F/T sensor's sample period.
fn leg_trough_and_sensor(
    g: &Get,
    leg: &str,
    plate: &Plate,
) -> Result<(f64, f64, f64), ConfigError> {
    let k = |s: &str| format!("{leg}.{s}");
    let trough_depth_m = g.f64(&k("trough_depth_m"))?.unwrap_or(0.0);
    if !(trough_depth_m.is_finite() && (0.0..plate.length_m()).contains(&trough_depth_m)) {
        return Err(invalid(
            &k("trough_depth_m"),
            &trough_depth_m,
            format!(
                "expected a depth in metres from 0 up to the leg's length, {} m",
                plate.length_m()
            ),
        ));
    }
    // Unset, the trough is as deep where the earlier stroke left as where it entered.
    let trough_exit_depth_m = g.f64(&k("trough_exit_depth_m"))?.unwrap_or(trough_depth_m);
    let length_m = plate.length_m();
    if !(trough_exit_depth_m.is_finite() && trough_exit_depth_m.abs() < length_m) {
        return Err(invalid(
            &k("trough_exit_depth_m"),
            &trough_exit_depth_m,
            format!(
                "expected a depth in metres within the leg's length, {length_m} m, of 0 \
                 (negative: a heap)"
            ),
        ));
    }
    let sensor_hold_s = g.f64(&k("sensor_hold_s"))?.unwrap_or(0.0);
    if !(sensor_hold_s.is_finite() && (0.0..=MAX_SENSOR_HOLD_S).contains(&sensor_hold_s)) {
        return Err(invalid(
            &k("sensor_hold_s"),
            &sensor_hold_s,
            format!(
                "expected the F/T sensor's sample period in seconds, from 0 (it updates with every message) up to {MAX_SENSOR_HOLD_S}"
            ),
        ));
    }
    Ok((trough_depth_m, trough_exit_depth_m, sensor_hold_s))
}

/// Whether a `<leg>.medium` value names a medium file rather than a preset: a path (a `/`) or a
/// YAML file's name.
fn is_medium_file(value: &str) -> bool {
    value.contains('/') || value.ends_with(".yaml") || value.ends_with(".yml")
}

/// The medium file and plate of a leg of model `sinkage` (`<leg>.medium` names the file).
fn sinkage_medium(
    g: &Get,
    leg: &str,
    width_m: f64,
    length_m: f64,
    plate: &Plate,
) -> Result<
    (
        crate::medium_file::MediumFile,
        crate::model::sinkage::SinkageLeg,
    ),
    ConfigError,
> {
    use crate::model::sinkage::PlateShape;
    let name = format!("{leg}.medium");
    let Some(path) = g.str(&name)?.filter(|p| !p.is_empty()) else {
        return Err(ConfigError::Missing {
            name,
            hint: "model sinkage needs a medium file (written by terzaghi calibrate)".into(),
        });
    };
    // The shape's refusal names the width; the file's its path.
    if (length_m - width_m).abs() <= 1e-12 {
        PlateShape::disc(width_m)
    } else {
        PlateShape::rectangle(width_m, length_m)
    }
    .map_err(model_err(&format!("{leg}.width_m")))?;
    crate::model_spec::sinkage_leg(std::path::Path::new(&path), length_m, width_m, *plate)
        .map_err(|e| invalid(&name, &path, format!("{e:#}")))
}

/// RFT coefficients fitted to a calibration grid: a CSV of `beta_rad,gamma_rad,alpha_x,alpha_z`
/// rows (N/cm^3), the format of the DEM campaign's `rft_grid.csv`.
fn rft_from_grid_file(name: &str, path: &str) -> Result<RftCoefficients, ConfigError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| invalid(name, &path, format!("cannot read it: {e}")))?;
    let points = crate::model::RftGrid::parse(&text)
        .map_err(|e| invalid(name, &path, format!("not an RFT grid: {e}")))?
        .points();
    crate::model::RftFit::fit_to_points(&points)
        .map(RftCoefficients::Fit)
        .ok_or_else(|| {
            invalid(
                name,
                &path,
                format!(
                    "{} points do not determine RFT's coefficients (at least 5, spread over beta and gamma)",
                    points.len()
                ),
            )
        })
}

/// RFT's speed law fitted to intrusions from the surface at several speeds against the leg's
/// RFT coefficients: a CSV of `speed_m_s,beta_rad,gamma_rad,length_m,width_m,depth_m,drag_n,lift_n`
/// rows, the format of the DEM campaign's `rft_entry.csv` (its slowest speed the calibration's).
fn rft_speed_from_file(
    name: &str,
    path: &str,
    coefficients: &RftCoefficients,
) -> Result<crate::model::RftSpeedFit, ConfigError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| invalid(name, &path, format!("cannot read it: {e}")))?;
    crate::model::RftSpeedTable::parse(&text)
        .and_then(|t| t.fit(coefficients))
        .map_err(|e| invalid(name, &path, format!("no RFT speed law: {e}")))
}

/// A wheel leg (`<leg>.shape: wheel`): `wheel.radius_m` (its rim), `width_m`, optional grousers
/// (`wheel.grouser_count`, `wheel.grouser_height_m`, `wheel.grouser_thickness_m`, all three or
/// none) and `wheel.rim_elements` (default 360). RFT predicts it (model rft); its length is its
/// rim's radius (a `length_m` given must be that). Returns the body and the radius.
fn leg_wheel(
    g: &Get,
    leg: &str,
    model: ModelKind,
    width_m: f64,
) -> Result<Option<(crate::model::Body, f64)>, ConfigError> {
    let k = |s: &str| format!("{leg}.{s}");
    if g.str(&k("shape"))?.as_deref() != Some("wheel") {
        for key in [
            "wheel.radius_m",
            "wheel.grouser_count",
            "wheel.grouser_height_m",
            "wheel.grouser_thickness_m",
            "wheel.rim_elements",
        ] {
            if g.0.contains_key(&k(key)) {
                return Err(invalid(
                    &k(key),
                    &"(given)",
                    format!("only a wheel has it: set {} to wheel", k("shape")),
                ));
            }
        }
        return Ok(None);
    }
    if model != ModelKind::Rft {
        return Err(invalid(
            &k("shape"),
            &"wheel",
            format!(
                "a wheel is a body that RFT predicts over its surface, not the {} model's flat plate: set model to rft",
                model.as_str()
            ),
        ));
    }
    let radius_m = g.need_f64(
        &k("wheel.radius_m"),
        "shape wheel needs the rim's radius in metres",
    )?;
    let count = g.f64(&k("wheel.grouser_count"))?;
    let height = g.f64(&k("wheel.grouser_height_m"))?;
    let thickness = g.f64(&k("wheel.grouser_thickness_m"))?;
    let grousers = match (count, height, thickness) {
        (None, None, None) => None,
        (Some(c), Some(h), Some(t)) => {
            if !(c >= 1.0 && c.fract() == 0.0 && c <= 360.0) {
                return Err(invalid(
                    &k("wheel.grouser_count"),
                    &c,
                    "expected a whole number of grousers from 1 to 360",
                ));
            }
            Some(crate::model::Grousers {
                count: c as usize,
                height_m: h,
                thickness_m: t,
            })
        }
        _ => {
            return Err(ConfigError::Missing {
                name: k("wheel.grouser_count"),
                hint: "grousers need all three of wheel.grouser_count, wheel.grouser_height_m and wheel.grouser_thickness_m".into(),
            });
        }
    };
    let rim = g.f64(&k("wheel.rim_elements"))?.unwrap_or(360.0);
    if !(rim.fract() == 0.0 && (360.0..=100_000.0).contains(&rim)) {
        return Err(invalid(
            &k("wheel.rim_elements"),
            &rim,
            "expected a whole number of rim elements from 360 to 100000",
        ));
    }
    let body =
        crate::model::Body::wheel(radius_m, width_m, grousers, rim as usize).map_err(|e| {
            let which = match &e {
                ModelError::OutOfRange { what, .. } if what.contains("grouser count") => {
                    "wheel.grouser_count"
                }
                ModelError::OutOfRange { what, .. } if what.contains("grouser thickness") => {
                    "wheel.grouser_thickness_m"
                }
                e if e.to_string().contains("grouser height") => "wheel.grouser_height_m",
                e if e.to_string().contains("width") => "width_m",
                _ => "wheel.radius_m",
            };
            model_err(&k(which))(e)
        })?;
    if let Some(given) = g.f64(&k("length_m"))?
        && (given - radius_m).abs() > 1e-9
    {
        return Err(invalid(
            &k("length_m"),
            &given,
            format!(
                "a wheel's length is its rim's radius, wheel.radius_m = {radius_m} m: leave length_m out"
            ),
        ));
    }
    Ok(Some((body, radius_m)))
}

/// The keys of a foot or mesh leg, and which shapes take each.
const FOOT_KEYS: [(&str, &[&str]); 8] = [
    ("foot.radius_m", &["disc", "sphere"]),
    ("foot.thickness_m", &["disc"]),
    ("foot.size_m", &["box"]),
    ("mesh.file", &["mesh"]),
    ("mesh.scale", &["mesh"]),
    ("body.xyz_m", &["disc", "sphere", "box", "mesh"]),
    ("body.rpy_rad", &["mesh"]),
    ("body.element_m", &["disc", "sphere", "box", "mesh"]),
];

/// `[x, y, z]` of `key`, where given.
fn triple(g: &Get, key: &str, what: &str) -> Result<Option<[f64; 3]>, ConfigError> {
    let v: Option<Vec<f64>> = match g.0.get(key) {
        None => return Ok(None),
        Some(ParamValue::DoubleArray(v)) => Some(v.clone()),
        Some(ParamValue::IntArray(v)) => Some(v.iter().map(|&x| x as f64).collect()),
        Some(_) => None,
    };
    match v {
        Some(v) if v.len() == 3 && v.iter().all(|x| x.is_finite()) => Ok(Some([v[0], v[1], v[2]])),
        _ => Err(invalid(
            key,
            &g.0.get(key).map(|v| v.to_string()).unwrap_or_default(),
            format!("expected [x, y, z]: {what}"),
        )),
    }
}

/// A foot or a part drawn in CAD as a leg (`<leg>.shape: disc | sphere | box | mesh`): the
/// shape's sizes (`foot.radius_m`, `foot.thickness_m`, `foot.size_m`) or its STL file
/// (`mesh.file`, in metres unless `mesh.scale` says how many metres a unit is), placed at
/// `body.xyz_m` from the hip (the foot's centre, the mesh's origin; `x` the robot's forward, `y`
/// its left, `z` up, at joint angle 0) and, for a mesh, turned by `body.rpy_rad`; its triangles
/// cut into elements no longer than `body.element_m` (default 5 mm). RFT predicts it (model
/// rft); its length is its reach below the hip and its width its extent across, both at joint
/// angle 0 (a `length_m` or `width_m` given must be those). Returns the body, its reach and its
/// width; `None` for another shape (refusing a foot's keys there).
fn leg_foot(
    g: &Get,
    leg: &str,
    model: ModelKind,
) -> Result<Option<(crate::model::Body, f64, f64)>, ConfigError> {
    let k = |s: &str| format!("{leg}.{s}");
    let shape = g.str(&k("shape"))?.unwrap_or_else(|| "plate".into());
    for (key, shapes) in FOOT_KEYS {
        if g.0.contains_key(&k(key)) && !shapes.contains(&shape.as_str()) {
            return Err(invalid(
                &k(key),
                &"(given)",
                format!(
                    "only a leg of shape {} has it ({} is {shape})",
                    shapes.join(" or "),
                    k("shape")
                ),
            ));
        }
    }
    if !["disc", "sphere", "box", "mesh"].contains(&shape.as_str()) {
        return Ok(None);
    }
    if model != ModelKind::Rft {
        return Err(invalid(
            &k("shape"),
            &shape,
            format!(
                "a {shape} is a body that RFT predicts over its surface, not the {} model's flat plate: set model to rft",
                model.as_str()
            ),
        ));
    }
    let xyz = triple(
        g,
        &k("body.xyz_m"),
        "the body's place from the hip in metres",
    )?
    .unwrap_or([0.0; 3]);
    let element_m = g.f64(&k("body.element_m"))?.unwrap_or(0.005);
    if !(element_m.is_finite() && (1e-4..=1.0).contains(&element_m)) {
        return Err(invalid(
            &k("body.element_m"),
            &element_m,
            "expected an element length from 0.0001 to 1 m",
        ));
    }
    let need = |key: &str, hint: &str| g.need_f64(&k(key), hint);
    // A foot's rim: segments (rings of a sphere) about as long as its elements.
    let around = |r: f64| ((std::f64::consts::TAU * r / element_m).ceil() as usize).clamp(12, 4096);
    let built = match shape.as_str() {
        "disc" => {
            let r = need(
                "foot.radius_m",
                "shape disc needs foot.radius_m and foot.thickness_m",
            )?;
            let t = need(
                "foot.thickness_m",
                "shape disc needs foot.radius_m and foot.thickness_m",
            )?;
            crate::model::Body::disc(r, t, xyz, around(r.abs().min(10.0)), element_m).map_err(
                |e| {
                    model_err(&k(if e.to_string().contains("thickness") {
                        "foot.thickness_m"
                    } else {
                        "foot.radius_m"
                    }))(e)
                },
            )?
        }
        "sphere" => {
            let r = need("foot.radius_m", "shape sphere needs foot.radius_m")?;
            crate::model::Body::sphere(r, xyz, around(r.abs().min(10.0)) / 2, element_m)
                .map_err(model_err(&k("foot.radius_m")))?
        }
        "box" => {
            let size = triple(
                g,
                &k("foot.size_m"),
                "the box's length, width and height in metres",
            )?
            .ok_or_else(|| ConfigError::Missing {
                name: k("foot.size_m"),
                hint: "shape box needs foot.size_m: [x, y, z] in metres".into(),
            })?;
            crate::model::Body::cuboid(size, xyz, element_m)
                .map_err(model_err(&k("foot.size_m")))?
        }
        _ => {
            let file = g
                .str(&k("mesh.file"))?
                .filter(|f| !f.is_empty())
                .ok_or_else(|| ConfigError::Missing {
                    name: k("mesh.file"),
                    hint: "shape mesh needs mesh.file: an STL file (binary or ASCII)".into(),
                })?;
            let scale = g.f64(&k("mesh.scale"))?.unwrap_or(1.0);
            let rpy = triple(g, &k("body.rpy_rad"), "roll, pitch and yaw in radians")?
                .unwrap_or([0.0; 3]);
            crate::mesh_file::read_body(std::path::Path::new(&file), scale, xyz, rpy, element_m)
                .map_err(|e| {
                    let key = if matches!(e, crate::mesh_file::MeshFileError::Scale(_)) {
                        "mesh.scale"
                    } else {
                        "mesh.file"
                    };
                    invalid(&k(key), &file, e.to_string())
                })?
        }
    };
    let reach_m = built.reach_m();
    if reach_m.is_nan() || reach_m <= 0.0 {
        return Err(invalid(
            &k("body.xyz_m"),
            &format!("{xyz:?}"),
            format!(
                "the {shape}'s lowest point is {:.4} m above the hip: a leg's body reaches below it",
                -reach_m
            ),
        ));
    }
    let width_m = built.width_m();
    for (key, value) in [("length_m", reach_m), ("width_m", width_m)] {
        if let Some(given) = g.f64(&k(key))?
            && (given - value).abs() > 1e-9 * value.max(1.0)
        {
            return Err(invalid(
                &k(key),
                &given,
                format!(
                    "a {shape} leg's {} is its body's, {value} m: leave {key} out",
                    if key == "length_m" {
                        "length (its reach below the hip)"
                    } else {
                        "width (its extent across)"
                    }
                ),
            ));
        }
    }
    Ok(Some((built, reach_m, width_m)))
}

/// `<leg>.shape` and what it needs: `plate` (the default), `c_leg` (`c_leg.radius_m`, default
/// half of `length_m`, and `c_leg.span_deg`, default 180: an arc whose chord must be `length_m`),
/// or `polyline` (`profile`: `[s0, q0, s1, q1, ...]` in metres).
fn leg_profile(g: &Get, leg: &str, plate: &Plate) -> Result<Option<LegProfile>, ConfigError> {
    let k = |s: &str| format!("{leg}.{s}");
    let shape = g.str(&k("shape"))?.unwrap_or_else(|| "plate".into());
    match shape.as_str() {
        // A wheel or a foot is a body, not a mid-line: `leg_wheel` and `leg_foot` read it.
        "plate" | "wheel" | "disc" | "sphere" | "box" | "mesh" => Ok(None),
        "c_leg" => {
            let line = crate::model_spec::c_leg_line(
                plate.length_m(),
                g.f64(&k("c_leg.radius_m"))?,
                g.f64(&k("c_leg.span_deg"))?,
            )
            .map_err(|e| invalid(&k(&format!("c_leg.{}", e.name)), &e.value, e.why))?;
            Ok(Some(LegProfile {
                shape: "c_leg",
                line,
            }))
        }
        "polyline" => {
            let v = match g.0.get(&k("profile")) {
                Some(ParamValue::DoubleArray(v)) => v.clone(),
                Some(v) => {
                    return Err(invalid(
                        &k("profile"),
                        v,
                        "expected [s0, q0, s1, q1, ...] in metres",
                    ));
                }
                None => {
                    return Err(ConfigError::Missing {
                        name: k("profile"),
                        hint: "shape polyline needs the leg's mid-line as [s0, q0, s1, q1, ...] in metres (s from the hip along the chord, q toward the travel)".into(),
                    });
                }
            };
            if v.len() < 4 || v.len() % 2 != 0 || v.iter().any(|x| !x.is_finite()) {
                return Err(invalid(
                    &k("profile"),
                    &format!("{v:?}"),
                    "expected an even number (at least 4) of finite coordinates: [s0, q0, s1, q1, ...]",
                ));
            }
            let line: Vec<(f64, f64)> = v.chunks(2).map(|p| (p[0], p[1])).collect();
            crate::model::check_profile(&line)
                .map_err(|problem| invalid(&k("profile"), &format!("{v:?}"), problem))?;
            Ok(Some(LegProfile {
                shape: "polyline",
                line,
            }))
        }
        other => Err(invalid(
            &k("shape"),
            &other,
            "expected plate, c_leg, polyline, wheel, disc, sphere, box or mesh",
        )),
    }
}
