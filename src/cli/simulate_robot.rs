//! `terzaghi simulate-robot`: a recording of the simulated six-legged robot walking, its body
//! heaving, pitching and moving forward, with `/tf`.

use anyhow::{Result, bail};
use clap::Args;
use std::path::PathBuf;
use terzaghi::config::ParamValue;
use terzaghi::session::files::{refuse_existing_recording, write_atomically};
use terzaghi::sim::generator::IN_LIBRARY;
use terzaghi::sim::robot::{
    Body, Gait, Truth, hip_frame, hip_offset_m, rhex, simulate_moving, write_recording,
};

#[derive(Debug, Args)]
pub struct SimulateRobotArgs {
    /// Simulated seconds of walking.
    #[arg(long, default_value_t = 20.0)]
    pub seconds: f64,
    /// The body rises and falls by this much (m), once per tripod.
    #[arg(long, default_value_t = 0.01)]
    pub heave_m: f64,
    /// The body pitches by this much (deg), a quarter period after the heave.
    #[arg(long, default_value_t = 3.0)]
    pub pitch_deg: f64,
    /// The body moves forward at this speed (m/s).
    #[arg(long, default_value_t = 0.1)]
    pub forward_m_s: f64,
    /// Mean leg speed (rad/s).
    #[arg(long, default_value_t = 4.0)]
    pub speed_rad_s: f64,
    /// Sensor noise, as a fraction of the RMS force in the medium (times 2.5).
    #[arg(long, default_value_t = 0.015)]
    pub noise_frac: f64,
    /// Seed of the walk and of the sensors.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// An effect the model leaves out, hidden in the sensors' readings as the generated cases
    /// hide it (repeatable): rate, inertia, surcharge, extraction, compaction, cohesion,
    /// hip_height, sensor_bias or sensor_lag (an offset of a stated size: --offset-n).
    #[arg(long = "hidden", value_name = "EFFECT")]
    pub hidden: Vec<String>,
    /// Strength of the hidden effects, as the generated cases scale them.
    #[arg(long, default_value_t = 0.5)]
    pub magnitude: f64,
    /// An F/T offset of this many newtons on every leg's drag and lift, of any size (0.001 N
    /// or 50 N): a sensor whose zero has moved. Beside `--hidden sensor_bias`, it replaces the
    /// generator's own offset (12-30 % of the RMS force).
    #[arg(
        long,
        value_name = "N",
        allow_negative_numbers = true,
        default_value_t = 0.0
    )]
    pub offset_n: f64,
    /// The offset grows by this many newtons per second of the recording, from `--offset-n`
    /// (0 by default) at its start: a zero drifting while the robot walks. A fleet's offset
    /// that grows from day to day is `--offset-n` set per day's recording.
    #[arg(
        long,
        value_name = "N_PER_S",
        allow_negative_numbers = true,
        default_value_t = 0.0
    )]
    pub offset_growth_n_per_s: f64,
    /// The medium is this many times as strong as the robot is told (its b_k scaled): a fleet's
    /// robot on other ground.
    #[arg(long, value_name = "X", default_value_t = 1.0)]
    pub medium_scale: f64,
    /// When the recording starts (Unix time, s): its messages' stamps and log times begin here.
    #[arg(long, value_name = "S", default_value_t = 1_700_000_000.0)]
    pub start_unix_s: f64,
    /// Publish the body's pose as geometry_msgs/PoseStamped on this topic (a robot without TF;
    /// the recorded parameters place each hip in the body, <leg>.hip_offset_m) instead of /tf.
    #[arg(long, value_name = "TOPIC")]
    pub pose_topic: Option<String>,
    /// The recording to write (ROS 2 MCAP).
    #[arg(short, long, value_name = "OUT.mcap")]
    pub output: PathBuf,
    /// Replace OUT.mcap if it exists.
    #[arg(long)]
    pub overwrite: bool,
}

pub fn run(a: SimulateRobotArgs) -> Result<()> {
    let checks = [
        (
            "--seconds",
            a.seconds,
            a.seconds > 0.0 && a.seconds <= 3600.0,
        ),
        ("--heave-m", a.heave_m, a.heave_m.abs() < 0.05),
        ("--pitch-deg", a.pitch_deg, a.pitch_deg.abs() <= 30.0),
        ("--forward-m-s", a.forward_m_s, a.forward_m_s.abs() <= 5.0),
        (
            "--speed-rad-s",
            a.speed_rad_s,
            a.speed_rad_s > 0.0 && a.speed_rad_s <= 50.0,
        ),
        (
            "--noise-frac",
            a.noise_frac,
            (0.0..=1.0).contains(&a.noise_frac),
        ),
        (
            "--magnitude",
            a.magnitude,
            (0.0..=2.0).contains(&a.magnitude),
        ),
        (
            "--medium-scale",
            a.medium_scale,
            a.medium_scale > 0.0 && a.medium_scale <= 10.0,
        ),
        (
            "--start-unix-s",
            a.start_unix_s,
            (0.0..=4e9).contains(&a.start_unix_s),
        ),
        ("--offset-n", a.offset_n, a.offset_n.abs() <= 1e4),
        (
            "--offset-growth-n-per-s",
            a.offset_growth_n_per_s,
            a.offset_growth_n_per_s.abs() <= 1e3,
        ),
    ];
    for (flag, v, ok) in checks {
        if !(v.is_finite() && ok) {
            bail!(
                "{flag} {v}: out of range (seconds in (0, 3600], |heave| < 0.05 m, |pitch| <= 30 deg, |forward| <= 5 m/s, speed in (0, 50] rad/s, noise in [0, 1], magnitude in [0, 2], medium scale in (0, 10], start in [0, 4e9] s, |offset| <= 1e4 N, |offset growth| <= 1e3 N/s)"
            );
        }
    }
    refuse_existing_recording(&a.output, a.overwrite)?;
    let (mut params, cfg) = rhex()?;
    // The medium is what the robot is told (its preset's fit): what differs is the body.
    let w = cfg.legs[0].width;
    let mut effects = Vec::new();
    for name in &a.hidden {
        let Some(e) = IN_LIBRARY.into_iter().find(|e| e.name() == name) else {
            bail!(
                "--hidden {name}: unknown effect; one of {}",
                IN_LIBRARY.map(|e| e.name()).join(", ")
            );
        };
        if !effects.contains(&e) {
            effects.push(e);
        }
    }
    // An offset of a stated size replaces the generator's, which it scales with the force.
    let offset_given = a.offset_n != 0.0 || a.offset_growth_n_per_s != 0.0;
    if offset_given {
        effects.retain(|e| *e != terzaghi::sim::generator::Hidden::SensorBias);
    }
    let truth = Truth {
        b_k: w.b_k() * a.medium_scale,
        a: w.a(),
        magnitude: if effects.is_empty() { 0.0 } else { a.magnitude },
        effects,
        noise_frac: a.noise_frac,
        rft_scale: 1.0,
    };
    let gait = Gait {
        seconds: a.seconds,
        rate_hz: terzaghi::sim::robot::DEMO_RATE_HZ,
        mean_speed_rad_s: a.speed_rad_s,
        seed: a.seed,
    };
    let body = Body {
        heave_m: a.heave_m,
        pitch_rad: a.pitch_deg.to_radians(),
        forward_m_s: a.forward_m_s,
    };
    let mut walk = simulate_moving(&cfg, &truth, &gait, &body);
    if offset_given {
        for leg in &mut walk.legs {
            for s in leg.iter_mut() {
                let o = a.offset_n + a.offset_growth_n_per_s * s.t_s.unwrap_or(0.0);
                s.drag_n += o;
                s.lift_n += o;
            }
        }
    }
    // The recorded node reads every hip from /tf, or places it in the body whose pose it reads.
    if !body.is_still() {
        let h0 = cfg.legs[0].plate.hip_height_m();
        for l in &cfg.legs {
            match &a.pose_topic {
                Some(_) => {
                    let [x, y, _] = hip_offset_m(&l.name);
                    params.insert(
                        format!("{}.hip_offset_m", l.name),
                        ParamValue::DoubleArray(vec![x, y, l.plate.hip_height_m() - h0]),
                    );
                }
                None => {
                    params.insert(
                        format!("{}.hip_frame", l.name),
                        ParamValue::String(hip_frame(&l.name)),
                    );
                }
            }
        }
        if let Some(t) = &a.pose_topic {
            if t.is_empty() || !t.starts_with('/') {
                bail!("--pose-topic {t:?}: expected an absolute topic name, e.g. /body_pose");
            }
            params.insert(
                "robot_state.pose_topic".into(),
                ParamValue::String(t.clone()),
            );
        }
    }
    // Whole microseconds: a float's rounding does not reach the stamps.
    let t0_ns = (a.start_unix_s * 1e6).round() as i64 * 1000;
    let mut messages = 0;
    write_atomically(&a.output, |f| {
        messages = write_recording(f, &params, &cfg, &walk, t0_ns)?;
        Ok(())
    })?;
    let noise = |f: fn(f64, f64) -> f64, init: f64| walk.noise_n.iter().copied().fold(init, f);
    eprintln!(
        "{messages} messages of {} s of walking written to {} (legs' hips on /tf: {}); the F/T sensors' noise {:.3}-{:.3} N",
        a.seconds,
        a.output.display(),
        if body.is_still() {
            "no, the body is still"
        } else {
            "yes"
        },
        noise(f64::min, f64::INFINITY),
        noise(f64::max, 0.0),
    );
    Ok(())
}
