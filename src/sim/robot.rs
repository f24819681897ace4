//! A simulated six-legged robot with rotating flat legs (RHex-like): two alternating tripods
//! whose legs turn together, the stride speed varying from stride to stride and within a
//! stride. Each leg's F/T sensor reads a truth that the node does not see: its own `b_k, a`,
//! sensor noise, and hidden effects written by the independent generator of
//! [`crate::sim::generator`]. Pure: the session is built in memory.

use crate::config::{FtFrame, NodeConfig};
use crate::ident::Sample;
use crate::msgs::{
    Header, JointState, Point, Pose, PoseStamped, Quaternion, TfMessage, Time, Transform,
    TransformStamped, Vector3, Wrench, WrenchStamped,
};
use crate::sim::generator::{Case, Hidden, MotionSample, measure};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::f64::consts::{PI, TAU};

/// What the simulation hides from the node.
#[derive(Debug, Clone, PartialEq)]
pub struct Truth {
    /// The medium's true `b_k`.
    pub b_k: f64,
    /// The medium's true `a`.
    pub a: f64,
    /// The effects the model lacks, added to the forces.
    pub effects: Vec<Hidden>,
    /// Size of the effects, 0-1 (see the generator).
    pub magnitude: f64,
    /// Sensor noise, as a fraction of the RMS force in the medium (times 2.5, as the generator).
    pub noise_frac: f64,
    /// For curved legs (RFT): the medium's true forces against RFT's from the configured
    /// coefficients, the single scale the node learns online. Flat plates ignore it.
    pub rft_scale: f64,
}

/// How the robot walks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gait {
    /// Length of the session (s).
    pub seconds: f64,
    /// JointState rate (Hz).
    pub rate_hz: f64,
    /// Mean leg speed (rad/s); each stride draws 0.6-1.4 times it.
    pub mean_speed_rad_s: f64,
    /// Seed of the strides' random speeds and the sensor noise.
    pub seed: u64,
}

/// How the robot's body moves while it walks. All zero (the default): a level body at the
/// legs' hip height that stays put, what a node with a fixed `hip_height_m` assumes.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Body {
    /// The body rises and falls by this much (m), twice per turn of the legs (once per tripod).
    pub heave_m: f64,
    /// It pitches by this much (rad; ROS's pitch, positive nose down), a quarter period after
    /// the heave.
    pub pitch_rad: f64,
    /// It moves forward at this speed (m/s).
    pub forward_m_s: f64,
}

impl Body {
    /// Whether the body neither heaves, pitches nor moves.
    pub fn is_still(&self) -> bool {
        *self == Body::default()
    }
}

/// The body's pose at one sample, in the world frame `odom` (the surface at z = 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyPose {
    /// Forward position (m).
    pub x_m: f64,
    /// Height of the body's origin above the surface (m).
    pub z_m: f64,
    /// Pitch (rad; ROS's pitch, positive nose down).
    pub pitch_rad: f64,
}

/// The frame of the body (`base_link`, REP 105) and of the world the surface is level in.
pub const BODY_FRAME: &str = "base_link";
/// The world frame the surface is level in.
pub const WORLD_FRAME: &str = "odom";

/// Where a leg's hip sits in the body frame, from its name (the shipped robot's): `front`,
/// `middle` or `rear` along x (+-0.12 m), `left` or `right` along y (+-0.08 m); z is the leg's
/// hip height less the body's (the first leg's), which the caller adds.
pub fn hip_offset_m(leg_name: &str) -> [f64; 3] {
    let x = if leg_name.contains("front") {
        0.12
    } else if leg_name.contains("rear") {
        -0.12
    } else {
        0.0
    };
    let y = if leg_name.contains("left") {
        0.08
    } else if leg_name.contains("right") {
        -0.08
    } else {
        0.0
    };
    [x, y, 0.0]
}

/// The hip frame's name that [`write_recording`] gives leg `leg_name` on `/tf`.
pub fn hip_frame(leg_name: &str) -> String {
    format!("{leg_name}_hip")
}

/// The simulated session: sample times, and per leg the unwrapped attack angle and what its
/// F/T sensor reads (drag, lift).
#[derive(Debug, Clone)]
pub struct Session {
    /// Time of each sample (s).
    pub t_s: Vec<f64>,
    /// Each leg's samples, by time.
    pub legs: Vec<Vec<Sample>>,
    /// True sensor noise per leg (N).
    pub noise_n: Vec<f64>,
    /// The body's pose at each sample (empty for a still body), its frame `base_link` at the
    /// first leg's hip height when level.
    pub body: Vec<BodyPose>,
}

/// Tripod of a leg: legs 0, 2 and 4 of the configuration (front left, rear left, middle right
/// in the shipped RHex parameters) turn together; the others half a turn apart.
fn tripod_phase(leg: usize) -> f64 {
    if leg.is_multiple_of(2) { 0.0 } else { PI }
}

/// Simulates the robot of `cfg` walking by `gait` on the medium `truth`: each leg's angle and
/// the forces its F/T sensor reads.
pub fn simulate(cfg: &NodeConfig, truth: &Truth, gait: &Gait) -> Session {
    simulate_moving(cfg, truth, gait, &Body::default())
}

/// [`simulate`] with a body that heaves, pitches and moves forward: each leg's sensor reads the
/// force at its hip's true height and attack angle (the joint's plus the pitch), while the joint
/// angles are the same as a still body's.
pub fn simulate_moving(cfg: &NodeConfig, truth: &Truth, gait: &Gait, body: &Body) -> Session {
    let mut rng = StdRng::seed_from_u64(gait.seed);
    let dt = 1.0 / gait.rate_hz;
    let n = (gait.seconds * gait.rate_hz).round().max(1.0) as usize;
    // The shared rotation of the gait: a speed per stride, modulated within it.
    let (depth, hz) = (rng.random_range(0.15..0.3), rng.random_range(0.7..1.3));
    let mut theta = rng.random_range(0.0..TAU);
    let start = theta;
    let mut stride_speed = gait.mean_speed_rad_s * rng.random_range(0.6..1.4);
    let mut stride = 0usize;
    let mut rot: Vec<(f64, f64, f64, f64)> = Vec::with_capacity(n); // t, theta, omega, alpha
    for k in 0..n {
        let t = k as f64 * dt;
        if theta - start >= TAU * (stride + 1) as f64 {
            stride += 1;
            stride_speed = gait.mean_speed_rad_s * rng.random_range(0.6..1.4);
        }
        let phase = TAU * hz * t;
        let omega = stride_speed * (1.0 + depth * phase.sin());
        let alpha = stride_speed * depth * TAU * hz * phase.cos();
        rot.push((t, theta, omega, alpha));
        theta += omega * dt;
    }
    let h0 = cfg.legs.first().map_or(0.0, |l| l.plate.hip_height_m());
    let poses: Vec<BodyPose> = if body.is_still() {
        Vec::new()
    } else {
        rot.iter()
            .map(|&(t, th, _, _)| BodyPose {
                x_m: body.forward_m_s * t,
                z_m: h0 + body.heave_m * (2.0 * th).sin(),
                pitch_rad: body.pitch_rad * (2.0 * th).cos(),
            })
            .collect()
    };
    let mut legs = Vec::with_capacity(cfg.legs.len());
    let mut noise = Vec::with_capacity(cfg.legs.len());
    for (i, leg) in cfg.legs.iter().enumerate() {
        let offset = tripod_phase(i);
        let first = rot.first().map_or(0.0, |r| r.1 + offset);
        let [hx, _, _] = hip_offset_m(&leg.name);
        // A leg whose hip is higher or lower than the first one's sits that much off the body.
        let hz = leg.plate.hip_height_m() - h0;
        let motion: Vec<MotionSample> = rot
            .iter()
            .enumerate()
            .map(|(k, &(t, th, w, al))| {
                // The hip's height in the world: the body's, plus its offset turned by the pitch
                // (nose down lowers the front hips).
                let (dz, pitch) = poses.get(k).map_or((0.0, 0.0), |p| {
                    let (s, c) = p.pitch_rad.sin_cos();
                    (
                        p.z_m - hx * s + hz * c - leg.plate.hip_height_m(),
                        p.pitch_rad,
                    )
                });
                MotionSample {
                    t_s: t,
                    beta_rad: th + offset,
                    omega_rad_s: w,
                    alpha_rad_s2: al,
                    stroke: ((th + offset - first) / TAU).floor().max(0.0) as usize,
                    hip_dz_m: dz,
                    pitch_rad: pitch,
                }
            })
            .collect();
        let case = Case {
            seed: gait.seed.wrapping_mul(31).wrapping_add(i as u64 + 1),
            plate: leg.plate,
            medium: leg.medium,
            b_k: truth.b_k,
            a: truth.a,
            effects: truth.effects.clone(),
            magnitude: truth.magnitude,
            noise_frac: truth.noise_frac,
            rate_hz: gait.rate_hz,
            strokes: motion.last().map_or(1, |m| m.stroke + 1),
            mean_speed_rad_s: gait.mean_speed_rad_s,
        };
        let (samples, sigma) = if leg.profile.is_some() {
            measure_curved(cfg, i, truth, &motion, body.forward_m_s, case.seed)
        } else {
            measure(&case, &motion, &[])
        };
        legs.push(samples);
        noise.push(sigma);
    }
    Session {
        t_s: rot.iter().map(|r| r.0).collect(),
        legs,
        noise_n: noise,
        body: poses,
    }
}

/// A curved leg's F/T (`<leg>.shape` `c_leg` or `polyline`): RFT of its shape over the
/// measured grid of loosely packed poppy seeds (`poppy_lp_grid`, interpolated; the shipped
/// robot's node predicts from Li et al.'s fitted coefficients instead, `poppy_lp`) times the
/// truth's `rft_scale`, at the hip's true height, pitch and velocity, with sensor noise as the
/// generator draws it. The flat plate's hidden effects are terms of the improved model and are
/// not added here.
fn measure_curved(
    cfg: &NodeConfig,
    i: usize,
    truth: &Truth,
    motion: &[MotionSample],
    forward_m_s: f64,
    seed: u64,
) -> (Vec<Sample>, f64) {
    use crate::model::{ForceModel, HipMotion, RftCoefficients, RftGrid, RftModel};
    let leg = &cfg.legs[i];
    let Some(Ok(model)) = leg.profile.as_ref().map(|p| {
        RftModel::with_profile(
            leg.plate,
            RftCoefficients::Grid(RftGrid::poppy_lp()),
            cfg.rft_elements,
            p.line.clone(),
        )
        .map(ForceModel::Rft)
    }) else {
        return (Vec::new(), 0.0);
    };
    let h0 = leg.plate.hip_height_m();
    let clean: Vec<[f64; 2]> = motion
        .iter()
        .enumerate()
        .map(|(k, m)| {
            // The hip's vertical velocity, by central differences of its height.
            let (a, b) = (
                &motion[k.saturating_sub(1)],
                &motion[(k + 1).min(motion.len() - 1)],
            );
            let up_m_s = if b.t_s > a.t_s {
                (b.hip_dz_m - a.hip_dz_m) / (b.t_s - a.t_s)
            } else {
                0.0
            };
            let hip = HipMotion {
                height_m: h0 + m.hip_dz_m,
                pitch_rad: m.pitch_rad,
                omega_rad_s: m.omega_rad_s,
                forward_m_s,
                up_m_s,
                forward_position_m: 0.0,
                lateral_m_s: 0.0,
            };
            model
                .predict_moving(m.beta_rad, &hip)
                .map_or([0.0, 0.0], |p| {
                    [truth.rft_scale * p.drag_n, truth.rft_scale * p.lift_n]
                })
        })
        .collect();
    let (sum, n) = clean
        .iter()
        .filter(|c| c[0] != 0.0 || c[1] != 0.0)
        .fold((0.0, 0usize), |(s, n), c| {
            (s + c[0] * c[0] + c[1] * c[1], n + 2)
        });
    let sigma = truth.noise_frac * (sum / n.max(1) as f64).sqrt() * 2.5;
    let mut rng = StdRng::seed_from_u64(seed ^ 0xc1e6);
    let unit = rand_distr::Normal::new(0.0, 1.0).expect("unit normal");
    let samples = motion
        .iter()
        .zip(&clean)
        .map(|(m, c)| {
            use rand_distr::Distribution;
            Sample {
                t_s: Some(m.t_s),
                beta_rad: m.beta_rad.rem_euclid(TAU),
                drag_n: c[0] + sigma * unit.sample(&mut rng),
                lift_n: c[1] + sigma * unit.sample(&mut rng),
            }
        })
        .collect();
    (samples, sigma)
}

/// Nanoseconds of the session's clock at `t_s` (the session starts at `t0_ns`).
pub fn stamp_ns(t0_ns: i64, t_s: f64) -> i64 {
    t0_ns + (t_s * 1e9).round() as i64
}

/// The JointState the robot publishes at sample `k`: every leg's joint position.
pub fn joint_state(cfg: &NodeConfig, s: &Session, k: usize, t0_ns: i64) -> JointState {
    JointState {
        header: Header {
            stamp: Time::from_nanos(stamp_ns(t0_ns, s.t_s[k])).unwrap_or_default(),
            frame_id: String::new(),
        },
        name: cfg.legs.iter().map(|l| l.joint.clone()).collect(),
        position: cfg
            .legs
            .iter()
            .zip(&s.legs)
            .map(|(l, samples)| samples[k].beta_rad / l.direction + l.angle_offset_rad)
            .collect(),
        velocity: Vec::new(),
        effort: Vec::new(),
    }
}

/// What leg `leg`'s F/T sensor publishes at sample `k`, in its configured frame.
/// A hip-frame force (`fx`, `fz`) as an F/T sensor in `frame` reads it at attack angle `beta_rad`
/// (the leg frame turns with the joint).
pub fn ft_components(frame: FtFrame, fx: f64, fz: f64, beta_rad: f64) -> (f64, f64) {
    match frame {
        FtFrame::Hip => (fx, fz),
        FtFrame::Leg => {
            let (sn, cs) = beta_rad.sin_cos();
            (fx * sn - fz * cs, fx * cs + fz * sn)
        }
    }
}

/// The F/T reading of `leg` at sample `k` as the sensor's `WrenchStamped` (stamped from
/// `t0_ns`).
pub fn wrench(cfg: &NodeConfig, s: &Session, leg: usize, k: usize, t0_ns: i64) -> WrenchStamped {
    let x = &s.legs[leg][k];
    let lc = &cfg.legs[leg];
    // Hip frame: F_x = -drag, F_z = lift. The leg frame turns with the joint.
    let (fx, fz) = (-x.drag_n, x.lift_n);
    let (wx, wz) = ft_components(lc.ft_frame, fx, fz, x.beta_rad);
    WrenchStamped {
        header: Header {
            stamp: Time::from_nanos(stamp_ns(t0_ns, s.t_s[k])).unwrap_or_default(),
            frame_id: format!("{}_ft", lc.name),
        },
        wrench: Wrench {
            force: Vector3 {
                x: wx,
                y: 0.0,
                z: wz,
            },
            torque: Vector3::default(),
        },
    }
}

fn transform(
    parent: &str,
    child: &str,
    t_ns: i64,
    xyz: [f64; 3],
    pitch_rad: f64,
) -> TransformStamped {
    let (s, c) = (pitch_rad / 2.0).sin_cos();
    TransformStamped {
        header: Header {
            stamp: Time::from_nanos(t_ns).unwrap_or_default(),
            frame_id: parent.into(),
        },
        child_frame_id: child.into(),
        transform: Transform {
            translation: Vector3 {
                x: xyz[0],
                y: xyz[1],
                z: xyz[2],
            },
            rotation: Quaternion {
                x: 0.0,
                y: s,
                z: 0.0,
                w: c,
            },
        },
    }
}

/// The body's pose at sample `k` on `/tf` (`odom` to `base_link`), for a moving body.
pub fn body_tf(s: &Session, k: usize, t0_ns: i64) -> Option<TfMessage> {
    let p = s.body.get(k)?;
    Some(body_pose_tf(p, stamp_ns(t0_ns, s.t_s[k])))
}

/// A body's pose as `/tf` carries it (`odom` to `base_link`, stamped `t_ns`).
pub fn body_pose_tf(p: &BodyPose, t_ns: i64) -> TfMessage {
    TfMessage {
        transforms: vec![transform(
            WORLD_FRAME,
            BODY_FRAME,
            t_ns,
            [p.x_m, 0.0, p.z_m],
            p.pitch_rad,
        )],
    }
}

/// Every hip in the body, as `/tf_static` carries it (`base_link` to `<leg>_hip`).
pub fn hips_tf(cfg: &NodeConfig, t0_ns: i64) -> TfMessage {
    let h0 = cfg.legs.first().map_or(0.0, |l| l.plate.hip_height_m());
    TfMessage {
        transforms: cfg
            .legs
            .iter()
            .map(|l| {
                let [x, y, _] = hip_offset_m(&l.name);
                let z = l.plate.hip_height_m() - h0;
                transform(BODY_FRAME, &hip_frame(&l.name), t0_ns, [x, y, z], 0.0)
            })
            .collect(),
    }
}

/// The shipped six-legged robot (`launch_configs/rhex.yaml`): its parameters and its
/// configuration.
pub fn rhex() -> Result<(crate::config::ParamMap, NodeConfig), crate::config::ConfigError> {
    let mut params = crate::config::defaults();
    params.extend(crate::config::parse_params_yaml(
        include_str!("../../launch_configs/rhex.yaml"),
        "rhex.yaml",
        "terzaghi",
        "/",
    )?);
    let cfg = NodeConfig::from_params(&params, "terzaghi", "/", &[])?;
    Ok((params, cfg))
}

/// The shipped robot with RHex's C-legs instead of flat plates: each leg a half circle whose
/// chord is its length (`<leg>.shape: c_leg`), predicted by RFT with loosely packed poppy
/// seeds' coefficients (`model: rft`, `<leg>.rft_coeffs: poppy_lp`), RFT's scale learnt online
/// from each leg's F/T.
pub fn rhex_c_legs() -> Result<(crate::config::ParamMap, NodeConfig), crate::config::ConfigError> {
    use crate::config::ParamValue;
    let (mut params, cfg) = rhex()?;
    params.insert("model".into(), ParamValue::String("rft".into()));
    for l in &cfg.legs {
        params.insert(
            format!("{}.shape", l.name),
            ParamValue::String("c_leg".into()),
        );
        params.insert(
            format!("{}.rft_coeffs", l.name),
            ParamValue::String("poppy_lp".into()),
        );
    }
    let cfg = NodeConfig::from_params(&params, "terzaghi", "/", &[])?;
    Ok((params, cfg))
}

/// Writes `session` as the robot's own recording would hold it: JointState on
/// `/joint_states` and every leg's F/T on its topic, for a moving body its pose (on `/tf`, the
/// hips on `/tf_static`; or, when `params` name a `robot_state.pose_topic`, as PoseStamped
/// there), stamped from `t0_ns`, with the node's parameters `params` as metadata (so that `terzaghi diagnose` and `replay --reevaluate` find
/// the legs). Returns the number of messages written.
pub fn write_recording<W: std::io::Write + std::io::Seek>(
    w: W,
    params: &crate::config::ParamMap,
    cfg: &NodeConfig,
    session: &Session,
    t0_ns: i64,
) -> Result<u64, crate::record::RecordError> {
    use crate::record::{OfferedQos, RecordOptions, SessionWriter};
    let mut w = SessionWriter::new(
        w,
        RecordOptions {
            params: params
                .iter()
                .map(|(k, v)| (k.clone(), v.to_string()))
                .collect(),
            ..Default::default()
        },
    )?;
    let ft_topics: Vec<String> = cfg
        .legs
        .iter()
        .map(|l| l.ft_topic.clone().unwrap_or_default())
        .collect();
    // The body's pose on the topic the parameters name, else on /tf.
    let pose_topic = match params.get("robot_state.pose_topic") {
        Some(crate::config::ParamValue::String(t)) if !t.is_empty() => Some(t.clone()),
        _ => None,
    };
    let mut messages = 0u64;
    for k in 0..session.t_s.len() {
        let t = stamp_ns(t0_ns, session.t_s[k]) as u64;
        w.write(
            &cfg.joint_states_topic,
            OfferedQos::BEST_EFFORT,
            &joint_state(cfg, session, k, t0_ns),
            t,
            t,
        )?;
        for (leg, topic) in ft_topics.iter().enumerate() {
            w.write(
                topic,
                OfferedQos::BEST_EFFORT,
                &wrench(cfg, session, leg, k, t0_ns),
                t + 5_000,
                t,
            )?;
        }
        messages += 1 + ft_topics.len() as u64;
        if let (Some(topic), Some(p)) = (&pose_topic, session.body.get(k)) {
            // A robot without TF: the body's pose alone (the node places the hips).
            let (s, c) = (p.pitch_rad / 2.0).sin_cos();
            let pose = PoseStamped {
                header: Header {
                    stamp: Time::from_nanos(stamp_ns(t0_ns, session.t_s[k])).unwrap_or_default(),
                    frame_id: WORLD_FRAME.into(),
                },
                pose: Pose {
                    position: Point {
                        x: p.x_m,
                        y: 0.0,
                        z: p.z_m,
                    },
                    orientation: Quaternion {
                        x: 0.0,
                        y: s,
                        z: 0.0,
                        w: c,
                    },
                },
            };
            w.write(topic, OfferedQos::BEST_EFFORT, &pose, t, t)?;
            messages += 1;
        } else if let Some(tf) = body_tf(session, k, t0_ns) {
            if k == 0 {
                w.write(
                    crate::config::TF_STATIC_TOPIC,
                    OfferedQos::RELIABLE,
                    &hips_tf(cfg, t0_ns),
                    t,
                    t,
                )?;
                messages += 1;
            }
            w.write(crate::config::TF_TOPIC, OfferedQos::RELIABLE, &tf, t, t)?;
            messages += 1;
        }
    }
    w.finish()?;
    Ok(messages)
}

/// The demo's robot (`terzaghi demo`): what its simulation hides, the medium's true fitting
/// width and two effects.
pub fn demo_truth() -> Truth {
    Truth {
        b_k: 24.0,
        a: 1.9,
        effects: vec![Hidden::Surcharge, Hidden::Extraction],
        magnitude: 0.5,
        noise_frac: 0.015,
        rft_scale: 1.3,
    }
}

/// The demo's robot: joint states and F/T per second.
pub const DEMO_RATE_HZ: f64 = 500.0;

/// The walk of the diagnosis's benchmark (`terzaghi-bench diagnose`) and its tests: `seconds`
/// of the robot at `rate_hz` on a medium of `b_k` 30, `a` 2.2, with surcharge hidden at half
/// strength and sensor noise of 1.5 % (times 2.5) of the RMS force; stride seed 7.
pub fn surcharge_walk(seconds: f64, rate_hz: f64) -> (Truth, Gait) {
    let truth = Truth {
        b_k: 30.0,
        a: 2.2,
        effects: vec![Hidden::Surcharge],
        magnitude: 0.5,
        noise_frac: 0.015,
        rft_scale: 1.0,
    };
    let gait = Gait {
        seconds,
        rate_hz,
        mean_speed_rad_s: 4.0,
        seed: 7,
    };
    (truth, gait)
}
