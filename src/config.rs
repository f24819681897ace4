//! Node parameters as a ROS user gives them: a params YAML file (`/**:` or the node's name, then
//! `ros__parameters:`, nested keys flattened with dots) and `--ros-args` (`-p name:=value`,
//! `--params-file FILE`, `-r __node:=NAME`, `-r __ns:=/NS`, `-r from:=to`). Parsed and validated
//! here, once, into a [`NodeConfig`]; every error names the parameter and its value.

use crate::ident::OnlineOptions;
use crate::ident::online::Forgetting;
use crate::model::medium::{self, MediumPreset, RftSet};
use crate::model::{
    FittingWidth, ForceModel, Medium, ModelError, Plate, RftCoefficients, RftModel, TerzaghiModel,
};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A parameter value, as ROS 2 types them.
#[derive(Debug, Clone, PartialEq)]
pub enum ParamValue {
    Bool(bool),
    Int(i64),
    Double(f64),
    String(String),
    BoolArray(Vec<bool>),
    IntArray(Vec<i64>),
    DoubleArray(Vec<f64>),
    StringArray(Vec<String>),
}

impl std::fmt::Display for ParamValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParamValue::Bool(v) => write!(f, "{v}"),
            ParamValue::Int(v) => write!(f, "{v}"),
            ParamValue::Double(v) => write!(f, "{v:?}"),
            ParamValue::String(v) => write!(f, "{v:?}"),
            ParamValue::BoolArray(v) => write!(f, "{v:?}"),
            ParamValue::IntArray(v) => write!(f, "{v:?}"),
            ParamValue::DoubleArray(v) => write!(f, "{v:?}"),
            ParamValue::StringArray(v) => write!(f, "{v:?}"),
        }
    }
}

/// Flat parameter names to values.
pub type ParamMap = BTreeMap<String, ParamValue>;

/// What is wrong with the parameters or the command line; names the culprit.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("parameter {name} = {value}: {reason}")]
    Invalid {
        name: String,
        value: String,
        reason: String,
    },
    #[error("parameter {name} is required: {hint}")]
    Missing { name: String, hint: String },
    #[error("parameter {name}: {error}")]
    Model { name: String, error: ModelError },
    #[error("cannot read params file {path}: {error}")]
    ReadFile { path: String, error: std::io::Error },
    #[error("params file {path}: {reason}")]
    BadFile { path: String, reason: String },
    #[error("--ros-args: {0}")]
    RosArgs(String),
    #[error("{name}={value}: {reason}")]
    Env {
        name: &'static str,
        value: String,
        reason: &'static str,
    },
}

fn invalid(name: &str, value: &impl std::fmt::Display, reason: impl Into<String>) -> ConfigError {
    ConfigError::Invalid {
        name: name.to_string(),
        value: value.to_string(),
        reason: reason.into(),
    }
}

/// What `--ros-args` said.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RosArgs {
    /// `-p name:=value`, in order (later wins).
    pub params: Vec<(String, ParamValue)>,
    pub params_files: Vec<PathBuf>,
    pub node_name: Option<String>,
    pub namespace: Option<String>,
    /// `-r from:=to` topic remappings.
    pub remaps: Vec<(String, String)>,
}

/// Splits `args` into the program's own arguments and what `--ros-args ... [--]` says.
pub fn parse_ros_args(args: &[String]) -> Result<(Vec<String>, RosArgs), ConfigError> {
    let mut own = Vec::new();
    let mut ros = RosArgs::default();
    let mut i = 0;
    let mut in_ros = false;
    let need = |i: usize, flag: &str| -> Result<String, ConfigError> {
        args.get(i + 1)
            .cloned()
            .ok_or_else(|| ConfigError::RosArgs(format!("{flag} needs a value")))
    };
    while i < args.len() {
        let a = args[i].as_str();
        if !in_ros {
            if a == "--ros-args" {
                in_ros = true;
            } else {
                own.push(args[i].clone());
            }
            i += 1;
            continue;
        }
        match a {
            "--" => in_ros = false,
            "--ros-args" => {}
            "-p" | "--param" => {
                let v = need(i, a)?;
                let (name, value) = v.split_once(":=").ok_or_else(|| {
                    ConfigError::RosArgs(format!("{a} {v:?}: expected name:=value"))
                })?;
                if name.is_empty() {
                    return Err(ConfigError::RosArgs(format!(
                        "{a} {v:?}: empty parameter name"
                    )));
                }
                ros.params.push((name.to_string(), parse_value(value)));
                i += 1;
            }
            "--params-file" => {
                ros.params_files.push(PathBuf::from(need(i, a)?));
                i += 1;
            }
            "-r" | "--remap" => {
                let v = need(i, a)?;
                let (from, to) = v
                    .split_once(":=")
                    .ok_or_else(|| ConfigError::RosArgs(format!("{a} {v:?}: expected from:=to")))?;
                // `node:from:=to` targets one node; we are the only node in this process.
                let from = from.rsplit_once(':').map(|(_, f)| f).unwrap_or(from);
                match from {
                    "__node" | "__name" => ros.node_name = Some(to.to_string()),
                    "__ns" => ros.namespace = Some(to.to_string()),
                    _ if from.is_empty() || to.is_empty() => {
                        return Err(ConfigError::RosArgs(format!("{a} {v:?}: empty name")));
                    }
                    _ => ros.remaps.push((from.to_string(), to.to_string())),
                }
                i += 1;
            }
            "--log-level" | "-e" | "--enclave" => i += 1, // accepted; nothing to configure
            "--disable-rosout-logs"
            | "--disable-stdout-logs"
            | "--enable-rosout-logs"
            | "--enable-stdout-logs" => {}
            other => {
                return Err(ConfigError::RosArgs(format!(
                    "unknown argument {other:?} (known: -p, --param, --params-file, -r, --remap, --log-level, --)"
                )));
            }
        }
        i += 1;
    }
    Ok((own, ros))
}

/// A command-line parameter value, typed as ROS does: YAML syntax (`true`, `3`, `0.5`,
/// `[a, b]`), anything else a string.
pub fn parse_value(text: &str) -> ParamValue {
    match serde_yaml_ng::from_str::<serde_yaml_ng::Value>(text) {
        Ok(v) => yaml_to_param(&v).unwrap_or_else(|| ParamValue::String(text.to_string())),
        Err(_) => ParamValue::String(text.to_string()),
    }
}

fn yaml_to_param(v: &serde_yaml_ng::Value) -> Option<ParamValue> {
    use serde_yaml_ng::Value as Y;
    Some(match v {
        Y::Bool(b) => ParamValue::Bool(*b),
        Y::Number(n) if n.is_i64() => ParamValue::Int(n.as_i64()?),
        Y::Number(n) => ParamValue::Double(n.as_f64()?),
        Y::String(s) => ParamValue::String(s.clone()),
        Y::Sequence(items) => {
            if items.iter().all(|i| matches!(i, Y::Bool(_))) && !items.is_empty() {
                ParamValue::BoolArray(items.iter().filter_map(Y::as_bool).collect())
            } else if items.iter().all(|i| i.as_i64().is_some()) && !items.is_empty() {
                ParamValue::IntArray(items.iter().filter_map(Y::as_i64).collect())
            } else if items.iter().all(|i| i.as_f64().is_some()) && !items.is_empty() {
                ParamValue::DoubleArray(items.iter().filter_map(Y::as_f64).collect())
            } else if items.iter().all(|i| i.is_string()) {
                ParamValue::StringArray(
                    items
                        .iter()
                        .filter_map(|i| i.as_str().map(String::from))
                        .collect(),
                )
            } else {
                return None;
            }
        }
        _ => return None,
    })
}

/// The parameters a params file gives this node (`/**`, the node's name or its fully
/// qualified name, then `ros__parameters`), flattened with dots.
pub fn parse_params_yaml(
    text: &str,
    path: &str,
    node_name: &str,
    namespace: &str,
) -> Result<ParamMap, ConfigError> {
    let bad = |reason: String| ConfigError::BadFile {
        path: path.to_string(),
        reason,
    };
    let doc: serde_yaml_ng::Value =
        serde_yaml_ng::from_str(text).map_err(|e| bad(format!("not YAML: {e}")))?;
    let top = doc
        .as_mapping()
        .ok_or_else(|| bad("expected a mapping of node names (e.g. /**:) at the top".into()))?;
    let fqn = format!("{}/{}", namespace.trim_end_matches('/'), node_name);
    let mut out = ParamMap::new();
    let mut matched = false;
    for (key, body) in top {
        let key = key.as_str().unwrap_or("");
        let ours = matches!(key, "/**" | "**")
            || key == node_name
            || key == fqn
            || key.strip_prefix("/**/") == Some(node_name)
            || key.trim_start_matches('/') == node_name && namespace == "/";
        if !ours {
            continue;
        }
        matched = true;
        let params = body
            .get("ros__parameters")
            .ok_or_else(|| bad(format!("{key}: expected ros__parameters: under it")))?;
        flatten("", params, &mut out).map_err(bad)?;
    }
    if !matched {
        return Err(bad(format!(
            "no section for this node: expected /**: or {node_name}: (or {fqn}:) at the top"
        )));
    }
    Ok(out)
}

fn flatten(prefix: &str, v: &serde_yaml_ng::Value, out: &mut ParamMap) -> Result<(), String> {
    if let Some(map) = v.as_mapping() {
        for (k, child) in map {
            let k = match k {
                serde_yaml_ng::Value::String(s) => s.clone(),
                other => serde_yaml_ng::to_string(other)
                    .unwrap_or_default()
                    .trim()
                    .to_string(),
            };
            let name = if prefix.is_empty() {
                k
            } else {
                format!("{prefix}.{k}")
            };
            flatten(&name, child, out)?;
        }
        return Ok(());
    }
    let value = yaml_to_param(v)
        .ok_or_else(|| format!("{prefix}: unsupported value (mixed list or null)"))?;
    out.insert(prefix.to_string(), value);
    Ok(())
}

/// Which model the node evaluates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelKind {
    Improved,
    Conventional,
    Rft,
}

impl ModelKind {
    pub fn as_str(self) -> &'static str {
        match self {
            ModelKind::Improved => "improved",
            ModelKind::Conventional => "conventional",
            ModelKind::Rft => "rft",
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

/// One leg, validated.
#[derive(Debug, Clone)]
pub struct LegConfig {
    pub name: String,
    /// `ft_topic` as given (before resolution), and the RFT set's name ("" for none).
    pub ft_topic_given: String,
    pub rft_name: String,
    pub joint: String,
    /// `+1` or `-1`: `beta = direction * (position - angle_offset_rad)`.
    pub direction: f64,
    pub angle_offset_rad: f64,
    pub plate: Plate,
    pub medium: Medium,
    pub preset: Option<&'static MediumPreset>,
    /// The configured fitting width (used until identification converges).
    pub width: FittingWidth,
    /// Resolved F/T topic, if the leg has a sensor.
    pub ft_topic: Option<String>,
    pub ft_frame: FtFrame,
    pub rft: Option<RftCoefficients>,
}

/// The whole node, validated.
#[derive(Debug, Clone)]
pub struct NodeConfig {
    pub node_name: String,
    pub namespace: String,
    pub model: ModelKind,
    /// Resolved JointState topic.
    pub joint_states_topic: String,
    pub use_identified: bool,
    pub legs: Vec<LegConfig>,
    pub estimator: OnlineOptions,
    pub rft_elements: usize,
    pub diagnostics_period_s: f64,
    /// Largest time between an F/T sample and the joint angle it is matched with.
    pub max_match_dt_s: f64,
    /// Bound of the input queue: beyond it the oldest message is dropped and counted.
    pub queue_depth: usize,
    pub model_params_rate_hz: f64,
    /// MCAP file to record the session to, if any.
    pub record: Option<PathBuf>,
    /// `-r from:=to`, resolved.
    pub remaps: Vec<(String, String)>,
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
pub const LEG_KEYS: [&str; 16] = [
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
];

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
    let mem = match d.forgetting {
        Forgetting::Strokes(m) => m,
        Forgetting::PerSample(_) => 3.0,
    };
    put("estimator.memory_strokes", ParamValue::Double(mem));
    put("estimator.forgetting_factor", ParamValue::Double(0.0));
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

fn model_err(name: &str) -> impl Fn(ModelError) -> ConfigError + '_ {
    move |error| ConfigError::Model {
        name: name.to_string(),
        error,
    }
}

/// Resolves a topic name as ROS does: absolute stays, `~/x` is under the node, relative is
/// under the namespace; then the first matching remap rule applies.
pub fn resolve_topic(
    name: &str,
    namespace: &str,
    node: &str,
    remaps: &[(String, String)],
) -> String {
    let ns = namespace.trim_end_matches('/');
    let full = if name.starts_with('/') {
        name.to_string()
    } else if let Some(rest) = name.strip_prefix("~/") {
        format!("{ns}/{node}/{rest}")
    } else {
        format!("{ns}/{name}")
    };
    for (from, to) in remaps {
        let from_full = resolve_topic(from, namespace, node, &[]);
        if from_full == full {
            return resolve_topic(to, namespace, node, &[]);
        }
    }
    full
}

/// Checks a node or namespace name for characters ROS does not allow.
fn check_name(what: &str, name: &str, allow_slash: bool) -> Result<(), ConfigError> {
    let ok = !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || (allow_slash && c == '/'))
        && !name.starts_with(|c: char| c.is_ascii_digit());
    if ok {
        Ok(())
    } else {
        Err(ConfigError::RosArgs(format!(
            "{what} {name:?}: use letters, digits and _ (not starting with a digit)"
        )))
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
            other => {
                return Err(invalid(
                    "model",
                    &other,
                    "expected improved, conventional or rft",
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
                && leg != "estimator"
                && leg_names.iter().any(|l| l == leg)
                && !LEG_KEYS.contains(&k)
            {
                return Err(invalid(
                    key,
                    &params[key],
                    format!("unknown leg parameter; known: {}", LEG_KEYS.join(", ")),
                ));
            }
        }
        let rft_elements = g.count("rft_elements", 1, RftModel::MAX_ELEMENTS as i64)?;
        let mut legs = Vec::new();
        for name in &leg_names {
            legs.push(leg_config(&g, name, model, &namespace, node_name, remaps)?);
        }
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
        Ok(NodeConfig {
            node_name: node_name.to_string(),
            namespace: namespace.clone(),
            model,
            joint_states_topic: resolve_topic(&topic, &namespace, node_name, remaps),
            use_identified: g.bool("use_identified")?.unwrap_or(true),
            legs,
            estimator: est,
            rft_elements,
            diagnostics_period_s: positive("diagnostics_period_s")?,
            max_match_dt_s: positive("max_match_dt_s")?,
            queue_depth: g.count("queue_depth", 1, 1_000_000)?,
            model_params_rate_hz: positive("model_params_rate_hz")?,
            record,
            remaps: remaps.to_vec(),
        })
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
            let frame = match l.ft_frame {
                FtFrame::Hip => "hip",
                FtFrame::Leg => "leg",
            };
            put("ft_frame", ParamValue::String(frame.into()));
            put("rft_coeffs", ParamValue::String(l.rft_name.clone()));
            put("rft_zeta", ParamValue::Double(0.0));
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
            ModelKind::Rft => match &leg.rft {
                Some(c) => ForceModel::Rft(RftModel::new(leg.plate, c.clone(), self.rft_elements)?),
                None => ForceModel::Terzaghi(TerzaghiModel::new(leg.plate, medium, width)),
            },
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
    let geom_hint = "each leg needs length_m, width_m and hip_height_m";
    let length = g.need_f64(&k("length_m"), geom_hint)?;
    let width = g.need_f64(&k("width_m"), geom_hint)?;
    let height = g.need_f64(&k("hip_height_m"), geom_hint)?;
    let plate = Plate::new(length, width, height).map_err(|e| {
        let which = match &e {
            ModelError::NegativeHipHeight { .. } => "hip_height_m",
            ModelError::NotPositive { name, .. } | ModelError::NotFinite { name, .. }
                if name.contains("width") =>
            {
                "width_m"
            }
            ModelError::NotFinite { name, .. } if name.contains("hip") => "hip_height_m",
            _ => "length_m",
        };
        model_err(&k(which))(e)
    })?;
    let direction = g.f64(&k("direction"))?.unwrap_or(1.0);
    if direction != 1.0 && direction != -1.0 {
        return Err(invalid(&k("direction"), &direction, "expected 1 or -1"));
    }
    let (medium, preset) = match g.str(&k("medium"))? {
        Some(name) if !name.is_empty() => {
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
        _ => {
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
    let fit = preset.and_then(|p| p.fitting_width_for(width));
    let b_k = g.f64(&k("b_k"))?.or(fit.map(|f| f.b_k())).unwrap_or(1.0);
    let a = g.f64(&k("a"))?.or(fit.map(|f| f.a())).unwrap_or(1.0);
    let width_fit = FittingWidth::new(b_k, a).map_err(model_err(&k("b_k")))?;
    let ft_topic = g
        .str(&k("ft_topic"))?
        .filter(|t| !t.is_empty())
        .map(|t| resolve_topic(&t, namespace, node, remaps));
    let ft_frame = match g.str(&k("ft_frame"))?.as_deref().unwrap_or("hip") {
        "hip" => FtFrame::Hip,
        "leg" => FtFrame::Leg,
        other => return Err(invalid(&k("ft_frame"), &other, "expected hip or leg")),
    };
    let rft_name = g
        .str(&k("rft_coeffs"))?
        .filter(|s| !s.is_empty())
        .or_else(|| {
            preset.and_then(|p| p.rft).map(|s| match s {
                RftSet::PoppyLp => "poppy_lp".to_string(),
                RftSet::PoppyCp => "poppy_cp".to_string(),
            })
        });
    let zeta = g.f64(&k("rft_zeta"))?.filter(|z| *z != 0.0); // 0: not set
    let rft = match rft_name.clone() {
        Some(n) => Some(RftCoefficients::by_name(&n, zeta).map_err(model_err(&k("rft_coeffs")))?),
        None if model == ModelKind::Rft => {
            return Err(ConfigError::Missing {
                name: k("rft_coeffs"),
                hint: "model rft needs RFT coefficients (poppy_lp, poppy_cp, poppy_lp_grid, generic with rft_zeta) or a medium that has them".into(),
            });
        }
        None => None,
    };
    let joint = g
        .str(&k("joint"))?
        .filter(|j| !j.is_empty())
        .unwrap_or_else(|| leg.to_string());
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
    })
}

/// Defaults, then each params file in order, then `-p` overrides: the parameters of one node.
pub fn load_params(
    ros: &RosArgs,
    node_name: &str,
    namespace: &str,
) -> Result<ParamMap, ConfigError> {
    let mut params = defaults();
    for path in &ros.params_files {
        params.extend(read_params_file(path, node_name, namespace)?);
    }
    for (name, value) in &ros.params {
        params.insert(name.clone(), value.clone());
    }
    Ok(params)
}

fn read_params_file(
    path: &Path,
    node_name: &str,
    namespace: &str,
) -> Result<ParamMap, ConfigError> {
    let shown = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|error| ConfigError::ReadFile {
        path: shown.clone(),
        error,
    })?;
    parse_params_yaml(&text, &shown, node_name, namespace)
}

/// `ROS_DOMAIN_ID`: 0 when unset; 0–232 (the ports of higher ones collide).
pub fn domain_id_from_env(value: Option<&str>) -> Result<u16, ConfigError> {
    match value.map(str::trim) {
        None | Some("") => Ok(0),
        Some(v) => match v.parse::<u16>() {
            Ok(d) if d <= 232 => Ok(d),
            _ => Err(ConfigError::Env {
                name: "ROS_DOMAIN_ID",
                value: v.to_string(),
                reason: "expected a whole number from 0 to 232",
            }),
        },
    }
}

/// Whether DDS must stay on loopback: `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` (or `OFF`), or
/// the older `ROS_LOCALHOST_ONLY=1`.
pub fn localhost_only_from_env(
    range: Option<&str>,
    localhost_only: Option<&str>,
) -> Result<bool, ConfigError> {
    match range.map(str::trim) {
        Some("LOCALHOST") | Some("OFF") => return Ok(true),
        Some("SUBNET") | Some("SYSTEM_DEFAULT") | Some("") | None => {}
        Some(other) => {
            return Err(ConfigError::Env {
                name: "ROS_AUTOMATIC_DISCOVERY_RANGE",
                value: other.to_string(),
                reason: "expected SUBNET, LOCALHOST, OFF or SYSTEM_DEFAULT",
            });
        }
    }
    Ok(matches!(localhost_only.map(str::trim), Some("1")))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(s: &str) -> Vec<String> {
        s.split_whitespace().map(String::from).collect()
    }

    const YAML: &str = "
/**:
  ros__parameters:
    model: improved
    legs: [left, right]
    left:
      length_m: 0.25
      width_m: 0.06
      hip_height_m: 0.15
      medium: hit_sand
      ft_topic: left/ft
    right:
      length_m: 0.25
      width_m: 0.04
      hip_height_m: 0.15
      unit_weight_n_m3: 16170
      phi_deg: 32.0
      delta_deg: 19.0
      b_k: 4.45
      a: 1.61
      direction: -1
    estimator:
      fit_delta: true
other_node:
  ros__parameters:
    model: rft
";

    fn load(extra: &str) -> Result<NodeConfig, ConfigError> {
        let mut p = defaults();
        p.extend(parse_params_yaml(YAML, "t.yaml", "terzaghi", "/").unwrap());
        let (_, ros) = parse_ros_args(&args(&format!("--ros-args {extra}")))?;
        for (k, v) in ros.params {
            p.insert(k, v);
        }
        NodeConfig::from_params(
            &p,
            ros.node_name.as_deref().unwrap_or("terzaghi"),
            ros.namespace.as_deref().unwrap_or("/"),
            &ros.remaps,
        )
    }

    #[test]
    fn params_file_and_overrides() {
        let c = load("-p left.b_k:=3 -p left.a:=1.2 -r __ns:=/robot -r left/ft:=/sensors/left")
            .unwrap();
        assert_eq!(c.legs.len(), 2);
        assert_eq!(c.namespace, "/robot");
        assert_eq!(c.joint_states_topic, "/robot/joint_states");
        assert_eq!(c.legs[0].ft_topic.as_deref(), Some("/sensors/left"));
        assert_eq!((c.legs[0].width.b_k(), c.legs[0].width.a()), (3.0, 1.2));
        assert_eq!(c.legs[1].direction, -1.0);
        assert_eq!(c.legs[1].joint, "right");
        assert!(c.estimator.fit_delta);
        // The preset's Table 1 fit for a 60 mm plate when no b_k is given.
        let c = load("").unwrap();
        assert_eq!(c.legs[0].width.b_k(), 22.40);
    }

    #[test]
    fn bad_values_name_parameter_and_value() {
        let cases = [
            ("-p left.width_m:=-1", "left.width_m"),
            ("-p model:=fancy", "fancy"),
            ("-p right.direction:=2", "right.direction"),
            ("-p left.medium:=mud", "mud"),
            ("-p left.ft_frame:=base", "base"),
            ("-p left.lenght_m:=1", "left.lenght_m"),
            ("-p queue_depth:=0", "queue_depth"),
            ("-p estimator.forgetting_factor:=1.5", "forgetting"),
            ("-p right.phi_deg:=95", "95"),
            ("-p left.length_m:=abc", "abc"),
            ("-r __node:=9bad", "9bad"),
        ];
        for (extra, needle) in cases {
            let e = load(extra).unwrap_err().to_string();
            assert!(e.contains(needle), "{extra}: {e}");
        }
        let e = parse_ros_args(&args("--ros-args -p nonsense"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("name:=value"), "{e}");
        let e = parse_ros_args(&args("--ros-args --frobnicate"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("frobnicate"), "{e}");
    }

    #[test]
    fn ros_args_split_from_own_args() {
        let (own, ros) = parse_ros_args(&args(
            "--record x.mcap --ros-args -p a:=1 --params-file f.yaml -- --other",
        ))
        .unwrap();
        assert_eq!(own, args("--record x.mcap --other"));
        assert_eq!(ros.params, vec![("a".to_string(), ParamValue::Int(1))]);
        assert_eq!(ros.params_files, vec![PathBuf::from("f.yaml")]);
        assert_eq!(
            parse_value("[a, b]"),
            ParamValue::StringArray(vec!["a".into(), "b".into()])
        );
        assert_eq!(parse_value("0.5"), ParamValue::Double(0.5));
        assert_eq!(parse_value("hip"), ParamValue::String("hip".into()));
    }

    #[test]
    fn node_sections_and_names() {
        let y = "terzaghi:\n  ros__parameters:\n    legs: [a]\n";
        assert!(
            parse_params_yaml(y, "f", "terzaghi", "/")
                .unwrap()
                .contains_key("legs")
        );
        let y2 = "/robot/terzaghi:\n  ros__parameters:\n    legs: [a]\n";
        assert!(parse_params_yaml(y2, "f", "terzaghi", "/robot").is_ok());
        let e =
            parse_params_yaml("other:\n  ros__parameters: {}\n", "f", "terzaghi", "/").unwrap_err();
        assert!(e.to_string().contains("no section"), "{e}");
        assert!(parse_params_yaml("- 1\n", "f", "terzaghi", "/").is_err());
        assert!(parse_params_yaml(":\n  :", "f", "terzaghi", "/").is_err());
        assert_eq!(resolve_topic("~/x", "/r", "n", &[]), "/r/n/x");
        assert_eq!(
            resolve_topic("x", "/", "n", &[("/x".into(), "y".into())]),
            "/y"
        );
    }

    #[test]
    fn environment() {
        assert_eq!(domain_id_from_env(None).unwrap(), 0);
        assert_eq!(domain_id_from_env(Some("42")).unwrap(), 42);
        assert!(
            domain_id_from_env(Some("300"))
                .unwrap_err()
                .to_string()
                .contains("300")
        );
        assert!(localhost_only_from_env(Some("LOCALHOST"), None).unwrap());
        assert!(localhost_only_from_env(None, Some("1")).unwrap());
        assert!(!localhost_only_from_env(Some("SUBNET"), None).unwrap());
        assert!(localhost_only_from_env(Some("MOON"), None).is_err());
    }
}
