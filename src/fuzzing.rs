//! What the fuzz targets (`fuzz/`, `cargo fuzz`) run on each input, and what
//! `tests/fuzz_inputs.rs` replays from their committed corpora and regressions: one function per
//! format that reaches the product from outside. Each takes any bytes, reads them as the product
//! reads that format, and panics only where the product breaks a promise: a panic inside it, a
//! non-finite number handed on as a value, a count that does not add up, a file written that
//! does not read back. Not an API.

use crate::config::{
    NodeConfig, ParamMap, defaults, params_yaml, parse_params_yaml, parse_ros_args,
};
use crate::medium_file::MediumFile;
use crate::model::HipMotion;
use crate::msgs::{
    self, Clock, DecodeInto, Header, JointState, PoseStamped, TfMessage, Time, Transform,
    TransformStamped, Vector3, Wrench, WrenchStamped,
};
use crate::node::{Input, NodeCore, Outputs};
use arbitrary::{Arbitrary, Unstructured};
use std::path::Path;
use std::sync::OnceLock;

/// Splits `data` at its first zero byte: a text and what follows it (the second file of a
/// two-file format, or the arguments).
fn split_at_nul(data: &[u8]) -> (&[u8], Option<&[u8]>) {
    match data.iter().position(|&b| b == 0) {
        Some(i) => (&data[..i], Some(&data[i + 1..])),
        None => (data, None),
    }
}

fn text(bytes: &[u8]) -> Option<&str> {
    std::str::from_utf8(bytes).ok()
}

fn finite(what: &str, v: f64) {
    assert!(v.is_finite(), "{what} = {v} handed on");
}

// ----------------------------------------------------------------------------------------------
// The node: CDR from any participant, through the node's own core.

/// The two nodes the wire target runs: flat legs of the improved model with F/T, hips from
/// `/tf`, and RFT C-legs with the body's pose on a topic.
const NODE_YAML: [&str; 2] = [
    "/**:\n  ros__parameters:\n    legs: [fl, fr]\n    model: improved\n    fl:\n      joint: hip_fl\n      length_m: 0.25\n      width_m: 0.06\n      hip_height_m: 0.15\n      medium: hit_sand\n      ft_topic: fl/ft\n      hip_frame: fl_hip\n    fr:\n      joint: hip_fr\n      length_m: 0.25\n      width_m: 0.06\n      hip_height_m: 0.15\n      medium: hit_sand\n      direction: -1\n      ft_topic: fr/ft\n",
    "/**:\n  ros__parameters:\n    legs: [fl, fr]\n    model: rft\n    robot_state:\n      pose_topic: /body_pose\n    fl:\n      joint: hip_fl\n      length_m: 0.1\n      width_m: 0.03\n      hip_height_m: 0.04\n      unit_weight_n_m3: 14208.0\n      phi_deg: 23.0\n      delta_deg: 19.0\n      rft_coeffs: poppy_lp\n      shape: c_leg\n      ft_topic: fl/ft\n      hip_frame: fl_hip\n    fr:\n      joint: hip_fr\n      length_m: 0.1\n      width_m: 0.03\n      hip_height_m: 0.04\n      unit_weight_n_m3: 14208.0\n      phi_deg: 23.0\n      delta_deg: 19.0\n      rft_coeffs: poppy_lp\n      ft_topic: fr/ft\n",
];

fn node_config(which: usize) -> NodeConfig {
    static CONFIGS: OnceLock<Vec<NodeConfig>> = OnceLock::new();
    CONFIGS.get_or_init(|| {
        NODE_YAML
            .iter()
            .map(|yaml| {
                let mut p = defaults();
                p.extend(parse_params_yaml(yaml, "fuzz.yaml", "terzaghi", "/").expect("params"));
                NodeConfig::from_params(&p, "terzaghi", "/", &[]).expect("config")
            })
            .collect()
    })[which % NODE_YAML.len()]
    .clone()
}

const FRAMES: [&str; 6] = ["odom", "base_link", "fl_hip", "fr_hip", "", "map"];
const JOINTS: [&str; 4] = ["hip_fl", "hip_fr", "knee", ""];

/// A number as the wire may carry it: mostly of a robot's scale, sometimes any bits at all.
#[derive(Debug, Clone, Copy)]
pub struct Num(pub f64);

impl<'a> Arbitrary<'a> for Num {
    fn arbitrary(u: &mut Unstructured<'a>) -> arbitrary::Result<Self> {
        Ok(Num(match u.int_in_range(0u8..=7)? {
            0 => f64::arbitrary(u)?,
            1 => {
                [0.0, -0.0, f64::NAN, f64::INFINITY, f64::MIN_POSITIVE, 1e300][u.choose_index(6)?]
            }
            _ => f64::from(i16::arbitrary(u)?) * 1e-3,
        }))
    }
}

/// A stamp near the session's start, or any.
#[derive(Debug, Clone, Copy)]
pub struct Stamp(pub Time);

impl<'a> Arbitrary<'a> for Stamp {
    fn arbitrary(u: &mut Unstructured<'a>) -> arbitrary::Result<Self> {
        Ok(Stamp(if u.ratio(1u8, 8)? {
            Time {
                sec: i32::arbitrary(u)?,
                nanosec: u32::arbitrary(u)?,
            }
        } else {
            Time {
                sec: 100 + i32::from(u.int_in_range(0u8..=20)?),
                nanosec: u.int_in_range(0u32..=999_999_999)?,
            }
        }))
    }
}

/// A transform of `/tf`: parent and child (indices into the frames), stamp, translation,
/// rotation.
pub type WireTransform = (u8, u8, Stamp, [Num; 3], [Num; 4]);

/// One input on the node's wire: raw bytes on one of its topics, or a well-formed message of
/// any values (encoded to CDR and decoded, as a peer's would be).
#[derive(Debug, Arbitrary)]
pub enum WireInput {
    /// Bytes on topic `topic` (JointState, each leg's F/T, `/tf`, `/tf_static`, the body's pose,
    /// `/clock`).
    Raw {
        /// Which topic.
        topic: u8,
        /// The sample's bytes, encapsulation header included.
        bytes: Vec<u8>,
    },
    /// A JointState.
    Joints {
        /// Its stamp.
        stamp: Stamp,
        /// Name (an index into the joints), position, velocity (if given).
        joints: Vec<(u8, Num, Option<Num>)>,
    },
    /// A leg's F/T.
    Wrench {
        /// The leg.
        leg: u8,
        /// Its stamp.
        stamp: Stamp,
        /// Force and torque.
        values: [Num; 6],
    },
    /// `/tf` or `/tf_static`.
    Tf {
        /// `/tf_static`.
        is_static: bool,
        /// The transforms.
        transforms: Vec<WireTransform>,
    },
    /// The body's pose.
    Pose {
        /// Its frame (an index).
        frame: u8,
        /// Its stamp.
        stamp: Stamp,
        /// Position and orientation.
        values: [Num; 7],
    },
    /// A log's hip row.
    Hip {
        /// The leg.
        leg: u8,
        /// Stamp (ns).
        t_ns: i64,
        /// Height, pitch, rate, forward and up velocity, forward position, lateral velocity.
        values: [Num; 7],
    },
}

fn header(stamp: Stamp, frame: &str) -> Header {
    Header {
        stamp: stamp.0,
        frame_id: frame.into(),
    }
}

fn v3(v: &[Num]) -> Vector3 {
    Vector3 {
        x: v[0].0,
        y: v[1].0,
        z: v[2].0,
    }
}

/// Encodes `m`, decodes it as the node would, and checks that it comes back the same.
fn through_cdr<M>(m: &M) -> M
where
    M: serde::Serialize + for<'de> serde::Deserialize<'de> + std::fmt::Debug,
{
    let bytes = msgs::to_cdr(m).expect("a message encodes");
    let back: M = msgs::from_cdr(&bytes).expect("an encoded message decodes");
    assert_eq!(
        format!("{back:?}"),
        format!("{m:?}"),
        "a message changed through CDR"
    );
    back
}

/// The hand-written decoder agrees with serde's on any bytes.
fn decoders_agree<M>(bytes: &[u8]) -> Option<M>
where
    M: DecodeInto + Default + serde::Serialize + for<'de> serde::Deserialize<'de> + std::fmt::Debug,
{
    let serde: Result<M, _> = msgs::from_cdr(bytes);
    let mut reused = M::default();
    let ours = reused.decode_into(bytes);
    match (&serde, &ours) {
        (Ok(a), Ok(())) => assert_eq!(
            format!("{a:?}"),
            format!("{reused:?}"),
            "the decoders disagree"
        ),
        (Err(_), Err(_)) => {}
        _ => panic!("one decoder takes what the other refuses: serde {serde:?}, ours {ours:?}"),
    }
    serde.ok()
}

fn check_outputs(out: &Outputs) {
    for l in &out.legs {
        let w = &l.wrench.wrench;
        for (what, v) in [
            ("force.x", w.force.x),
            ("force.y", w.force.y),
            ("force.z", w.force.z),
            ("torque.x", w.torque.x),
            ("torque.y", w.torque.y),
            ("torque.z", w.torque.z),
            ("drag_n", l.force.drag_n),
            ("lift_n", l.force.lift_n),
            ("hip_torque_nm", l.force.hip_torque_nm),
            ("depth_m", l.force.depth_m),
            ("submerged_length_m", l.force.submerged_length_m),
            ("attack_angle_rad", l.force.attack_angle_rad),
        ] {
            finite(&format!("leg {} {what}", l.leg), v);
        }
        assert!(
            l.wrench.header.stamp.is_valid(),
            "leg {} published with an invalid stamp {:?}",
            l.leg,
            l.wrench.header.stamp
        );
    }
    for (leg, p) in &out.params {
        finite(&format!("leg {leg} b_k"), p.b_k);
        finite(&format!("leg {leg} a"), p.a);
    }
}

/// The node's core fed a sequence of wire inputs: every sample decodes or is refused (both
/// decoders alike), and every force, wrench and parameter it hands on is finite.
pub fn node_wire(data: &[u8]) {
    let mut u = Unstructured::new(data);
    let Ok(which) = u8::arbitrary(&mut u) else {
        return;
    };
    let Ok(inputs) = Vec::<WireInput>::arbitrary_take_rest(u) else {
        return;
    };
    let mut core = NodeCore::new(node_config(which as usize));
    let legs = core.legs();
    let mut out = Outputs::default();
    for input in inputs {
        match input {
            WireInput::Raw { topic, bytes } => match topic % 7 {
                0 => {
                    if let Some(m) = decoders_agree::<JointState>(&bytes) {
                        core.handle(Input::Joints(&m), &mut out);
                    }
                }
                t @ (1 | 2) => {
                    if let Some(m) = decoders_agree::<WrenchStamped>(&bytes) {
                        core.handle(Input::Wrench(t as usize - 1, &m), &mut out);
                    }
                }
                t @ (3 | 4) => {
                    if let Ok(m) = msgs::from_cdr::<TfMessage>(&bytes) {
                        core.handle(Input::Tf(&m, t == 4), &mut out);
                    }
                }
                5 => {
                    if let Ok(m) = msgs::from_cdr::<PoseStamped>(&bytes) {
                        core.handle(Input::Pose(&m), &mut out);
                    }
                }
                _ => {
                    let _ = msgs::from_cdr::<Clock>(&bytes);
                }
            },
            WireInput::Joints { stamp, joints } => {
                let m = through_cdr(&JointState {
                    header: header(stamp, ""),
                    name: joints
                        .iter()
                        .map(|j| JOINTS[j.0 as usize % JOINTS.len()].to_string())
                        .collect(),
                    position: joints.iter().map(|j| j.1.0).collect(),
                    velocity: if joints.iter().all(|j| j.2.is_some()) {
                        joints.iter().filter_map(|j| j.2.map(|v| v.0)).collect()
                    } else {
                        Vec::new()
                    },
                    effort: Vec::new(),
                });
                core.handle(Input::Joints(&m), &mut out);
            }
            WireInput::Wrench { leg, stamp, values } => {
                let m = through_cdr(&WrenchStamped {
                    header: header(stamp, "ft"),
                    wrench: Wrench {
                        force: v3(&values[..3]),
                        torque: v3(&values[3..]),
                    },
                });
                core.handle(Input::Wrench(leg as usize % legs, &m), &mut out);
            }
            WireInput::Tf {
                is_static,
                transforms,
            } => {
                let m = through_cdr(&TfMessage {
                    transforms: transforms
                        .iter()
                        .map(|(p, c, s, t, q)| TransformStamped {
                            header: header(*s, FRAMES[*p as usize % FRAMES.len()]),
                            child_frame_id: FRAMES[*c as usize % FRAMES.len()].into(),
                            transform: Transform {
                                translation: v3(t),
                                rotation: msgs::Quaternion {
                                    x: q[0].0,
                                    y: q[1].0,
                                    z: q[2].0,
                                    w: q[3].0,
                                },
                            },
                        })
                        .collect(),
                });
                core.handle(Input::Tf(&m, is_static), &mut out);
            }
            WireInput::Pose {
                frame,
                stamp,
                values: v,
            } => {
                let m = through_cdr(&PoseStamped {
                    header: header(stamp, FRAMES[frame as usize % FRAMES.len()]),
                    pose: msgs::Pose {
                        position: msgs::Point {
                            x: v[0].0,
                            y: v[1].0,
                            z: v[2].0,
                        },
                        orientation: msgs::Quaternion {
                            x: v[3].0,
                            y: v[4].0,
                            z: v[5].0,
                            w: v[6].0,
                        },
                    },
                });
                core.handle(Input::Pose(&m), &mut out);
            }
            WireInput::Hip {
                leg,
                t_ns,
                values: v,
            } => {
                let hip = HipMotion {
                    height_m: v[0].0,
                    pitch_rad: v[1].0,
                    omega_rad_s: v[2].0,
                    forward_m_s: v[3].0,
                    up_m_s: v[4].0,
                    forward_position_m: v[5].0,
                    lateral_m_s: v[6].0,
                };
                core.handle(Input::Hip(leg as usize % legs, t_ns, hip), &mut out);
            }
        }
        check_outputs(&out);
        out.clear();
    }
}

// ----------------------------------------------------------------------------------------------
// Parameters: a params file and `--ros-args`.

/// A params file, then (after a zero byte) `--ros-args` and the rest of a command line, one
/// argument per line: a node configured from them, or an error. A configuration written back
/// as a params file reads as the same configuration, and the node it makes predicts finite
/// forces for a sweep of angles.
pub fn params(data: &[u8]) {
    let (yaml, args) = split_at_nul(data);
    let Some(yaml) = text(yaml) else { return };
    let args: Vec<String> = match args.map(text) {
        Some(Some(a)) => a.lines().map(str::to_string).collect(),
        Some(None) => return,
        None => Vec::new(),
    };
    let Ok((_, ros)) = parse_ros_args(&args) else {
        return;
    };
    let name = ros.node_name.clone().unwrap_or_else(|| "terzaghi".into());
    let namespace = ros.namespace.clone().unwrap_or_else(|| "/".into());
    let mut p = defaults();
    match parse_params_yaml(yaml, "fuzz.yaml", &name, &namespace) {
        Ok(file) => p.extend(file),
        Err(_) => return,
    }
    for (k, v) in &ros.params {
        p.insert(k.clone(), v.clone());
    }
    let Ok(cfg) = NodeConfig::from_params(&p, &name, &namespace, &ros.remaps) else {
        return;
    };
    // What `record` writes into a session and `replay` reads back.
    let written = params_yaml(&cfg.effective_params(&p), "fuzz");
    let mut again: ParamMap = defaults();
    again.extend(
        parse_params_yaml(&written, "written.yaml", &name, &namespace)
            .unwrap_or_else(|e| panic!("a written params file does not read: {e}\n{written}")),
    );
    let cfg2 = NodeConfig::from_params(&again, &name, &namespace, &ros.remaps)
        .unwrap_or_else(|e| panic!("a written params file is refused: {e}\n{written}"));
    assert_eq!(
        format!("{cfg2:?}"),
        format!("{cfg:?}"),
        "a configuration changed when written and read back:\n{written}"
    );
    let mut core = NodeCore::new(cfg);
    let mut out = Outputs::default();
    let names: Vec<String> = core.config().legs.iter().map(|l| l.joint.clone()).collect();
    for (i, beta) in [-2.0, -0.5, 0.0, 0.3, 1.2, 3.0].iter().enumerate() {
        let m = JointState {
            header: Header {
                stamp: Time {
                    sec: 100,
                    nanosec: i as u32 * 10_000_000,
                },
                frame_id: String::new(),
            },
            name: names.clone(),
            position: vec![*beta; names.len()],
            velocity: vec![1.0; names.len()],
            effort: Vec::new(),
        };
        core.handle(Input::Joints(&m), &mut out);
        check_outputs(&out);
        out.clear();
    }
}

// ----------------------------------------------------------------------------------------------
// Files.

/// A CSV force log: read (a non-finite cell is kept, to be counted where it is used) or
/// refused; then fitted in batch and diagnosed as `fit` and `diagnose` do: finite values, or
/// an error, and every sample counted as used or skipped.
pub fn csv_log(data: &[u8]) {
    use crate::diagnose::{DiagnoseOptions, diagnose};
    use crate::ident::{BatchOptions, fit_batch};
    use crate::model::{Medium, Plate, TerzaghiModel};
    let Ok(log) = crate::dataset::read_log_from(data, "fuzz.csv") else {
        return;
    };
    if let Some(h) = &log.hips {
        assert_eq!(h.len(), log.samples.len(), "a hip row per sample");
    }
    let model = TerzaghiModel::conventional(
        Plate::new(0.25, 0.06, 0.15).expect("a plate"),
        Medium::new(16170.0, 32.0, 19.0).expect("a medium"),
    );
    for fit_delta in [false, true] {
        let opts = BatchOptions {
            fit_delta,
            ..Default::default()
        };
        if let Ok(f) = fit_batch(&model, &log.samples, &opts) {
            finite("b_k", f.b_k);
            finite("a", f.a);
            finite("delta_deg", f.delta_deg);
            assert_eq!(
                f.samples + f.skipped_non_finite + f.skipped_regime,
                log.samples.len(),
                "a sample neither used nor counted as skipped"
            );
        }
    }
    let opts = DiagnoseOptions {
        max_points: 2_000,
        forward_share: false,
        ..Default::default()
    };
    if let Ok(d) = diagnose(&model, &log.samples, &opts) {
        finite("baseline b_k", d.report.baseline.b_k);
        finite("baseline a", d.report.baseline.a);
        finite("gap", d.report.gap.heldout_mse_n2);
        assert!(
            d.report.analysed + d.report.skipped_non_finite <= d.report.samples,
            "more samples analysed and skipped than given"
        );
    }
}

/// A wheel test's runs for `terzaghi steady`: its CSV. The first byte picks the wheel (smooth,
/// or with grousers) and what is solved for (the sinkage under each run's load, or the load
/// borne at its `sinkage_m`). Every run brought to a steady state has finite outputs no deeper
/// than the wheel, the table written reads back run for run, and its figures are numbers.
pub fn steady_runs(data: &[u8]) {
    use crate::medium_file::RftLaw;
    use crate::model::{Body, Grousers, RftCoefficients, RftDepthLaw, RftFit};
    use crate::session::steady::{Solve, steady_runs};
    let Some((&first, rest)) = data.split_first() else {
        return;
    };
    let Some(csv) = text(rest) else {
        return;
    };
    // Each run is a bisection over the body: a few dozen runs per input keep a run fast.
    if csv.lines().count() > 40 {
        return;
    }
    let grousers = (first & 1 == 1).then_some(Grousers {
        count: 12,
        height_m: 0.005,
        thickness_m: 0.003,
    });
    let body = Body::wheel(0.058, 0.05, grousers, 360).expect("a wheel");
    let law = RftLaw {
        coefficients: RftCoefficients::Fit(RftFit::POPPY_LP),
        depth_law: RftDepthLaw::new(4.546, 1.219).expect("the plate runs' law"),
        speed_law: None,
        shape_measured: false,
        // The bearing of sheared sand on half the inputs: its first-depth search too.
        sheared: (first & 4 == 4)
            .then(|| crate::model::ShearedBearing::new(0.35, 2.0).expect("a bearing in range")),
    };
    let solve = if first & 2 == 0 {
        Solve::Sinkage
    } else {
        Solve::AtSinkage("sinkage_m".into())
    };
    let Ok(table) = steady_runs(Path::new("fuzz.csv"), csv, &body, &law, &solve) else {
        return;
    };
    for r in &table.runs {
        assert_eq!(r.fields.len(), table.headers.len(), "a field per column");
        let s = &r.steady;
        finite("sinkage_m", s.sinkage_m);
        finite("drawbar_n", s.drawbar_n);
        finite("side_n", s.side_n);
        finite("torque_nm", s.torque_nm);
        finite("load_borne_n", s.load_n);
        assert!(
            s.sinkage_m <= body.height_m() + 1e-9,
            "a sinkage below the body's top: {s:?}"
        );
    }
    // The table written reads back, run for run.
    let out = table.to_csv().expect("the table as CSV");
    let back = csv::Reader::from_reader(&out[..]).records().count();
    assert_eq!(back, table.runs.len(), "runs written and read back");
    for a in table.agreement() {
        finite("R^2", a.r2);
        finite("RMSE", a.rmse);
    }
    if let Some(h) = table.headers.first() {
        let _ = table.groups(h).expect("a column of the runs groups them");
    }
}

/// A plate-sinkage test: its CSV, then (after a zero byte) its JSON. The first byte picks a
/// plain log's plate (a 60 mm disc, or none given) and the depth column. Read with finite rows
/// and a regime per row, then calibrated (every law fitted, or left out with its reason).
pub fn plate_test(data: &[u8]) {
    use crate::model::sinkage::{PlateShape, RegimeOptions};
    use crate::session::plate_test::{DepthColumn, calibrate, parse_test};
    let Some((&first, rest)) = data.split_first() else {
        return;
    };
    let (csv, json) = split_at_nul(rest);
    let (Some(csv), json) = (text(csv), json.map(text)) else {
        return;
    };
    let json = match json {
        Some(None) => return,
        Some(Some(j)) => Some(j),
        None => None,
    };
    let plate = (first & 1 == 1).then(|| PlateShape::disc(0.06).expect("a disc"));
    let depth = if first & 2 == 2 {
        DepthColumn::Compensated
    } else {
        DepthColumn::AsLogged
    };
    let Ok(test) = parse_test(
        Path::new("fuzz.csv"),
        csv,
        json,
        plate,
        depth,
        &RegimeOptions::default(),
    ) else {
        return;
    };
    assert_eq!(test.regimes.len(), test.rows.len(), "a regime per row");
    for r in &test.rows {
        finite("t_s", r.t_s);
        finite("depth_m", r.depth_m);
        finite("force_n", r.force_n);
    }
    let (fits, _) = calibrate(std::slice::from_ref(&test), 16_000.0);
    for f in &fits {
        for (i, v) in f.model.params.iter().enumerate() {
            finite(&format!("{} parameter {i}", f.model.law.name()), *v);
        }
        finite("R^2 of a fit", f.r2);
    }
}

/// An intrusion test: its CSV, then (after a zero byte) its JSON. Read with finite rows, then
/// RFT's shape fitted to it (or refused) with finite coefficients and predictions.
pub fn intrusion_test(data: &[u8]) {
    use crate::ident::rft_shape::{ShapeOptions, fit_shape, predict_test};
    use crate::session::intrusion_test::parse_intrusion_test;
    let (csv, json) = split_at_nul(data);
    let (Some(csv), Some(Some(json))) = (text(csv), json.map(text)) else {
        return;
    };
    let Ok(t) = parse_intrusion_test(Path::new("fuzz.csv"), csv, json) else {
        return;
    };
    for r in &t.test.rows {
        for v in [r.t_s, r.x_m, r.depth_m, r.fx_n, r.fz_n] {
            finite("an intrusion row's value", v);
        }
    }
    let o = ShapeOptions::default();
    let Ok(fit) = fit_shape(std::slice::from_ref(&t.test), &o) else {
        return;
    };
    for v in fit.coefficients.to_array() {
        finite("a shape coefficient", v);
    }
    finite("depth exponent", fit.depth_exponent);
    finite("surface offset", fit.surface_offset_m);
    for (_, x, z) in predict_test(&fit, &t.test, &o) {
        finite("predicted fx", x);
        finite("predicted fz", z);
    }
}

/// A medium file: read (checked), or refused; a medium read predicts finite forces on a plate
/// at every depth, and finite RFT stresses in every direction.
pub fn medium_file(data: &[u8]) {
    use crate::model::sinkage::PlateShape;
    let Some(t) = text(data) else { return };
    let Ok(m) = MediumFile::parse(Path::new("fuzz.yaml"), t) else {
        return;
    };
    let model = m.model().expect("a medium file read has a model");
    for plate in [
        PlateShape::disc(0.06).expect("a disc"),
        PlateShape::rectangle(0.03, 0.1).expect("a rectangle"),
    ] {
        for depth in [0.0, 1e-4, 0.005, 0.03, 0.2] {
            finite("pressure_pa", model.pressure_pa(&plate, depth));
            finite("force_n", model.force_n(&plate, depth));
        }
    }
    let again = m.to_yaml().expect("a medium file writes");
    let back = MediumFile::parse(Path::new("written.yaml"), &again)
        .unwrap_or_else(|e| panic!("a written medium file does not read: {e:#}\n{again}"));
    assert_eq!(
        format!("{back:?}"),
        format!("{m:?}"),
        "a medium file changed when written and read back"
    );
    // An RFT leg takes the file's law or is refused by name (a sinkage law of another kind, a
    // scale of 0); a law it takes gives finite stresses.
    let Ok(law) = m.rft_law(None) else {
        return;
    };
    for beta in [-1.5, -0.4, 0.0, 0.7, 1.5] {
        for gamma in [-1.5, -0.3, 0.0, 0.9, 1.5] {
            let (ax, az) = law.coefficients.alpha(beta, gamma);
            finite("alpha_x", ax);
            finite("alpha_z", az);
        }
    }
    for depth in [0.0, 0.001, 0.05] {
        finite("effective depth", law.depth_law.effective_depth_m(depth));
    }
}

// ----------------------------------------------------------------------------------------------
// Recordings.

/// An MCAP file from anywhere: scanned, read as a session, and recovered. What `recover` writes
/// reads back with every message it says it wrote, and recovering that again changes nothing.
pub fn mcap(data: &[u8]) {
    use crate::record::read::{read_session, scan, summary_head};
    use crate::record::recover::recover;
    let _ = summary_head(data);
    let mut seen = 0u64;
    let scanned = scan(data, |_, _| seen += 1);
    if let Ok(s) = read_session(data) {
        for m in &s.messages {
            let _ = s.decode::<JointState>(m);
            let _ = s.decode::<WrenchStamped>(m);
            let _ = s.decode::<TfMessage>(m);
        }
    }
    let _ = scanned;
    let Ok((out, rec)) = recover(data, std::io::Cursor::new(Vec::new()), |_| {}) else {
        return;
    };
    let bytes = out.into_inner();
    let session = read_session(&bytes)
        .unwrap_or_else(|e| panic!("a recovered file does not read: {e} ({rec:?})"));
    assert_eq!(
        session.messages.len() as u64,
        rec.messages,
        "a recovered file holds another count of messages than recover says"
    );
    let (out2, rec2) = recover(&bytes, std::io::Cursor::new(Vec::new()), |_| {})
        .unwrap_or_else(|e| panic!("a recovered file does not recover: {e}"));
    assert_eq!(
        rec2.messages, rec.messages,
        "recovering twice loses messages"
    );
    assert!(rec2.input_complete, "a recovered file is complete");
    let again = read_session(&out2.into_inner()).expect("recovered twice reads");
    assert_eq!(again.messages.len(), session.messages.len());
}

/// An STL file (`fuzz/corpus/mesh_file`): read as `terzaghi steady --shape mesh` reads it (its
/// first byte picks metres or millimetres); a mesh that makes a body has a finite reach and
/// height, and finite forces wherever it is and however it moves; a load is borne at a finite
/// sinkage no deeper than the body, or refused.
pub fn mesh_file(data: &[u8]) {
    use crate::model::{
        Body, Drive, HubMotion, RftCoefficients, RftDepthLaw, RftFit, Stress, place, steady_sinkage,
    };
    let Some((&first, rest)) = data.split_first() else {
        return;
    };
    let scale = if first & 1 == 0 { 1.0 } else { 0.001 };
    let Ok(mut triangles) = crate::mesh_file::parse_stl(Path::new("fuzz.stl"), rest, scale) else {
        return;
    };
    // Each triangle is at least one element: a few thousand keep a run fast.
    if triangles.len() > 4000 {
        return;
    }
    place(
        &mut triangles,
        [0.0, 0.0, 0.0],
        [0.0, f64::from(first >> 1) * 0.1, 0.0],
    );
    let Ok(body) = Body::mesh(&triangles, 0.5) else {
        return;
    };
    finite("reach_m", body.reach_m());
    finite("height_m", body.height_m());
    assert!(body.element_count() > 0, "a body has elements");
    let c = RftCoefficients::Fit(RftFit::POPPY_LP);
    let law = RftDepthLaw::new(4.546, 1.219).expect("the plate runs' law");
    for (height, v, omega, angle) in [
        (0.0, [0.01, 0.0, 0.0], 0.0, 0.0),
        (body.reach_m() * 0.5, [0.01, 0.004, -0.002], 0.3, 0.7),
        (-body.height_m(), [0.0, 0.0, -0.01], 0.0, -2.0),
    ] {
        let f = body.forces(
            &c,
            Some(&law),
            None,
            &HubMotion {
                height_m: height,
                velocity_m_s: v,
                omega_rad_s: omega,
                angle_rad: angle,
            },
        );
        for x in f.force_n.iter().chain(&f.moment_nm) {
            finite("body force or moment", *x);
        }
    }
    let stress = Stress {
        coefficients: &c,
        depth_law: Some(&law),
        speed_law: None,
        sheared: None,
    };
    let drive = Drive {
        speed_m_s: 0.01,
        omega_rad_s: 0.0,
        slip_angle_rad: 0.2,
    };
    if let Ok(s) = steady_sinkage(&body, &stress, 1.0, &drive) {
        finite("sinkage_m", s.sinkage_m);
        finite("drawbar_n", s.drawbar_n);
        finite("side_n", s.side_n);
        assert!(
            s.sinkage_m <= body.height_m() + 1e-9,
            "sinkage within the body"
        );
    }
}

// ----------------------------------------------------------------------------------------------
// The batch kernel: the arrays Python's `LegBatch.forces` hands it.

/// A batch of legs as `LegBatch.forces` gives them (any numbers, float64 or float32, a fitting
/// width per leg or not, a chunk's offset): improved-model plates, RFT C-legs (in poppy seeds,
/// or in the plate runs' medium with its law in depth), RFT plates or wheels.
/// The kernel on the processor's instructions and on the baseline's agree, the same leg named
/// where one refuses; every force given is finite; and with inputs of a robot's size each leg's
/// float64 forces are `predict_moving`'s (or the improved model's at its own width). And as
/// `LegBatch.wrenches` gives them, the hips moving sideways too: every value given is finite,
/// a refusal names a leg of the batch, and with a robot's inputs each leg's whole wrench is
/// `predict_moving`'s.
pub fn batch_legs(data: &[u8]) {
    use crate::model::batch::{Isa, LegKernel};
    let mut u = Unstructured::new(data);
    let (Ok(kind), Ok(float32), Ok(widths), Ok(n)) = (
        u.int_in_range(0u8..=4),
        u.arbitrary::<bool>(),
        u.arbitrary::<bool>(),
        u.int_in_range(0usize..=80),
    ) else {
        return;
    };
    // A wheel costs tens of microseconds a leg moving sideways: a few keep the runs many.
    let n = if kind == 4 { n.min(6) } else { n };
    let Ok(first) = u.int_in_range(0..=n) else {
        return;
    };
    let model = batch_model(kind);
    let widths = widths && kind == 0;
    // Each value a robot's (a byte over its range) or any number at all.
    let mut value = |lo: f64, hi: f64| -> Option<f64> {
        let tag = u.arbitrary::<u8>().ok()?;
        if tag < 200 {
            Some(lo + (hi - lo) * f64::from(tag) / 199.0)
        } else {
            u.arbitrary::<f64>().ok()
        }
    };
    let ranges = [
        (-7.0, 13.0),  // beta
        (-0.02, 0.12), // hip height
        (-0.3, 0.3),   // pitch
        (-9.0, 9.0),   // omega
        (-0.5, 0.5),   // forward
        (-0.2, 0.2),   // up
        (0.5, 60.0),   // b_k
        (1.05, 4.0),   // a
        (-0.2, 0.2),   // lateral
    ];
    let mut cols: Vec<Vec<f64>> = (0..9).map(|_| Vec::with_capacity(n)).collect();
    for _ in 0..n {
        for (col, &(lo, hi)) in cols.iter_mut().zip(&ranges) {
            let Some(v) = value(lo, hi) else {
                return;
            };
            col.push(v);
        }
    }
    let robot = cols
        .iter()
        .zip(&ranges)
        .all(|(c, &(lo, hi))| c.iter().all(|v| (lo..=hi).contains(v)));
    let kernel = LegKernel::new(model.clone());
    let baseline = LegKernel::new(model.clone())
        .on(Isa::Baseline)
        .expect("the baseline");
    if float32 {
        let cols: Vec<Vec<f32>> = cols
            .iter()
            .map(|c| c.iter().map(|&v| v as f32).collect())
            .collect();
        batch_agree::<f32>(&kernel, &baseline, &cols, first, widths, 1e-4);
    } else {
        if !widths {
            batch_wrenches(&kernel, &model, &cols, first, robot);
        }
        let got = batch_agree::<f64>(&kernel, &baseline, &cols, first, widths, 1e-9);
        if let (Some(got), true) = (got, robot) {
            batch_is_predict(&model, &cols, first, widths, &got);
        }
    }
}

/// The batch's model of fuzz kind `kind`: improved-model plates (0), RFT C-legs in poppy seeds
/// (1) or in the plate runs' medium with its law in depth (3), RFT wheels (4), RFT plates.
fn batch_model(kind: u8) -> crate::model::ForceModel {
    use crate::model::{
        FittingWidth, ForceModel, Medium, Plate, RftCoefficients, RftFit, RftModel, TerzaghiModel,
        c_leg_profile,
    };
    let plate = Plate::new(0.1, 0.025, 0.0).expect("a plate");
    let fit = RftCoefficients::Fit(RftFit::POPPY_LP);
    // The plate runs' law in depth (their medium file's).
    let plate_runs = crate::model::RftDepthLaw::new(4.546, 1.219).expect("the plate runs' law");
    match kind {
        0 => ForceModel::Terzaghi(TerzaghiModel::new(
            plate,
            Medium::new(13000.0, 30.0, 20.0).expect("a medium"),
            FittingWidth::new(30.0, 2.3).expect("a width"),
        )),
        1 | 3 => ForceModel::Rft(
            RftModel::with_profile(
                plate,
                fit,
                96,
                c_leg_profile(0.05, std::f64::consts::PI, 32),
            )
            .expect("a C-leg")
            .with_depth_law((kind == 3).then_some(plate_runs)),
        ),
        4 => ForceModel::Body(Box::new(crate::model::body::BodyLeg::new(
            crate::model::Body::wheel(0.058, 0.05, None, 360).expect("a wheel"),
            fit,
            Some(plate_runs),
            None,
            Plate::new(0.058, 0.05, 0.0).expect("the wheel's plate"),
        ))),
        _ => ForceModel::Rft(RftModel::new(plate, fit, 50).expect("an RFT plate")),
    }
}

/// Each leg's float64 forces of a robot's batch (`got`, the legs from `first`) are
/// `predict_moving`'s, or the improved model's at the leg's own fitting width (`widths`).
fn batch_is_predict(
    model: &crate::model::ForceModel,
    cols: &[Vec<f64>],
    first: usize,
    widths: bool,
    got: &[[f64; 3]],
) {
    use crate::model::{FittingWidth, ForceModel};
    let scale = got.iter().flatten().fold(1e-9f64, |a, f| a.max(f.abs()));
    for (k, f) in got.iter().enumerate() {
        let i = first + k;
        let c = |j: usize| cols[j][i];
        let want = match (model, widths) {
            (ForceModel::Terzaghi(m), true) => {
                let w = FittingWidth::new(c(6), c(7)).expect("a width in range");
                let r = m
                    .with_fitting_width(w)
                    .evaluate_at_height(c(0) + c(2), c(1))
                    .expect("a leg of a robot's size");
                [r.drag_n, r.lift_n, r.hip_torque_nm]
            }
            _ => {
                let p = model
                    .predict_moving(c(0), &batch_leg_hip(cols, i, false))
                    .expect("a leg of a robot's size");
                [p.drag_n, p.lift_n, p.hip_torque_nm]
            }
        };
        for (g, w) in f.iter().zip(want) {
            assert!(
                (g - w).abs() <= 1e-9 * scale,
                "leg {i}: the batch gives {f:?}, predict {want:?}"
            );
        }
    }
}

/// Leg `i`'s hip in the columns (height, pitch, omega, forward, up; sideways at column 8
/// where `lateral`).
fn batch_leg_hip(cols: &[Vec<f64>], i: usize, lateral: bool) -> HipMotion {
    let c = |j: usize| cols[j][i];
    HipMotion {
        height_m: c(1),
        pitch_rad: c(2),
        omega_rad_s: c(3),
        forward_m_s: c(4),
        up_m_s: c(5),
        lateral_m_s: if lateral { c(8) } else { 0.0 },
        ..HipMotion::default()
    }
}

/// `LegKernel::wrenches` of the legs from `first`, the hips moving sideways at column 8:
/// finite where given, a refusal naming a leg of the batch, and with a robot's inputs
/// (`robot`) each leg's whole wrench `predict_moving`'s.
fn batch_wrenches(
    kernel: &crate::model::batch::LegKernel,
    model: &crate::model::ForceModel,
    cols: &[Vec<f64>],
    first: usize,
    robot: bool,
) {
    use crate::model::ForceModel;
    use crate::model::batch::{LegForcesOut, LegSideOut, Legs};
    let n = cols[0].len();
    let m = n - first;
    let mut o = vec![vec![0.0; m]; 6];
    let [d, l, t, s, r, y] = &mut o[..] else {
        unreachable!("six outputs")
    };
    let legs = Legs::moving(std::array::from_fn(|k| &cols[k][..]));
    let got = kernel.wrenches(
        &legs,
        Some(&cols[8]),
        first,
        LegForcesOut {
            drag_n: d,
            lift_n: l,
            hip_torque_nm: t,
        },
        LegSideOut {
            side_n: s,
            roll_moment_nm: r,
            yaw_moment_nm: y,
        },
    );
    if let Err(e) = got {
        assert!(
            (first..n).contains(&e.index),
            "{e} is not a leg of the batch"
        );
        let leg: Vec<f64> = cols.iter().map(|c| c[e.index]).collect();
        assert!(
            !robot,
            "a robot's legs refused: {e}: {leg:?} (beta, h, pitch, omega, forward, up, b_k, a, lateral) of {model:?}"
        );
        return;
    }
    let scale = o.iter().flatten().fold(1e-9f64, |a, f| a.max(f.abs()));
    for k in 0..m {
        let i = first + k;
        let f: Vec<f64> = o.iter().map(|c| c[k]).collect();
        for v in &f {
            finite("a batch's wrench", *v);
        }
        if !robot {
            continue;
        }
        let p = model
            .predict_moving(cols[0][i], &batch_leg_hip(cols, i, true))
            .expect("a leg of a robot's size");
        let want = p.wrench();
        // A planar leg moving in its plane takes the kernel (to rounding), the rest
        // predict_moving itself; the flat-plate models have no side force.
        let planar = matches!(model, ForceModel::Terzaghi(_));
        for (j, (g, w)) in f.iter().zip(want).enumerate() {
            let w = if planar && j >= 3 { 0.0 } else { w };
            assert!(
                (g - w).abs() <= 1e-9 * scale,
                "leg {i}: the batch's wrench {f:?}, predict's {want:?}"
            );
        }
    }
}

/// Runs both kernels on the legs from `first`: they agree (the same error, or forces within
/// `tol` of the largest: the fused, estimated and rounded operations of one against the
/// other's), every force is finite; the forces, where given.
fn batch_agree<T: crate::model::batch::Real>(
    kernel: &crate::model::batch::LegKernel,
    baseline: &crate::model::batch::LegKernel,
    cols: &[Vec<T>],
    first: usize,
    widths: bool,
    tol: f64,
) -> Option<Vec<[f64; 3]>> {
    use crate::model::batch::{LegForcesOut, LegKernel, Legs};
    let n = cols[0].len();
    let run = |k: &LegKernel| {
        let m = n - first;
        let (mut d, mut l, mut t) = (vec![T::ZERO; m], vec![T::ZERO; m], vec![T::ZERO; m]);
        let legs = Legs {
            b_k: widths.then_some(&cols[6][..]),
            a: widths.then_some(&cols[7][..]),
            ..Legs::moving(std::array::from_fn(|k| &cols[k][..]))
        };
        let out = LegForcesOut {
            drag_n: &mut d,
            lift_n: &mut l,
            hip_torque_nm: &mut t,
        };
        k.forces(&legs, first, out).map(|()| {
            (0..m)
                .map(|i| [d[i].to_f64(), l[i].to_f64(), t[i].to_f64()])
                .collect::<Vec<_>>()
        })
    };
    match (run(kernel), run(baseline)) {
        (Ok(a), Ok(b)) => {
            let scale = a.iter().flatten().fold(1e-9f64, |s, f| s.max(f.abs()));
            for (i, (x, y)) in a.iter().zip(&b).enumerate() {
                for (p, q) in x.iter().zip(y) {
                    finite("a batch's force", *p);
                    assert!(
                        (p - q).abs() <= tol * scale,
                        "leg {}: {x:?} on {:?}, {y:?} on the baseline",
                        first + i,
                        kernel.isa()
                    );
                }
            }
            Some(a)
        }
        (Err(a), Err(b)) => {
            assert_eq!(
                a.index,
                b.index,
                "{a} on {:?}, {b} on the baseline",
                kernel.isa()
            );
            assert!(
                (first..n).contains(&a.index),
                "{a} is not a leg of the batch"
            );
            None
        }
        (Err(e), _) | (_, Err(e)) => {
            let leg: Vec<f64> = cols.iter().map(|c| c[e.index].to_f64()).collect();
            panic!(
                "{:?} on {:?}, {:?} on the baseline: leg {} {leg:?} (beta, h, pitch, omega, forward, up, b_k, a)",
                run(kernel).err(),
                kernel.isa(),
                run(baseline).err(),
                e.index
            )
        }
    }
}
