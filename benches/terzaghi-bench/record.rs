//! `terzaghi-bench record`: how fast sessions are written and re-evaluated on this machine.
//!
//! It writes a synthetic session of the node's traffic for the RHex configuration (6 legs,
//! JointState and F/T at `--rate-hz`, with every leg's predicted wrench, leg force, and model
//! parameters at 10 Hz; with `--inputs-only`, JointState and F/T alone) through the recorder's
//! writer on one thread, timing it; then it runs `terzaghi replay --reevaluate` (the `terzaghi`
//! binary beside this one) on the file and times that.

use crate::print_out;
use anyhow::{Context, Result, bail};
use clap::Args;
use std::io::BufWriter;
use std::time::Instant;
use terzaghi::msgs::{Header, JointState, Time, Vector3, Wrench, WrenchStamped};
use terzaghi::node::{Input, NodeCore, Outputs};
use terzaghi::record::{OfferedQos, RecordOptions, SessionWriter};

#[derive(Debug, Args)]
pub struct BenchRecordArgs {
    /// Length of the session (minutes).
    #[arg(long, default_value_t = 10.0)]
    pub minutes: f64,
    /// JointState and F/T rate (Hz).
    #[arg(long, default_value_t = 1000.0)]
    pub rate_hz: f64,
    /// Keep the session file here instead of a temporary one.
    #[arg(long, value_name = "FILE.mcap")]
    pub keep: Option<std::path::PathBuf>,
    /// Times to run the re-evaluation (the median is reported, with the range).
    #[arg(long, default_value_t = 3)]
    pub runs: usize,
    /// Record only the robot's topics (JointState and F/T), as `terzaghi record` of a robot
    /// without the node does, instead of the node's session with every output.
    #[arg(long)]
    pub inputs_only: bool,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, serde::Serialize)]
struct Report {
    minutes: f64,
    /// The session has only the robot's topics, not the node's outputs.
    inputs_only: bool,
    legs: usize,
    rate_hz: f64,
    messages: u64,
    write_s: f64,
    write_messages_per_s: f64,
    file_bytes: u64,
    file_mb_per_minute: f64,
    /// Median over the runs.
    reevaluate_s: f64,
    reevaluate_min_s: f64,
    reevaluate_max_s: f64,
    reevaluate_runs: usize,
    reevaluate_times_real_time: f64,
    /// Median CPU time (user and system, all threads) of a run: at most twice the wall time on
    /// two cores.
    reevaluate_cpu_s: f64,
    /// Peak resident memory of the re-evaluating process.
    reevaluate_peak_mb: f64,
}

pub fn run(a: BenchRecordArgs) -> Result<()> {
    if !(a.minutes.is_finite() && a.minutes > 0.0 && a.minutes <= 600.0) {
        bail!("--minutes must be in (0, 600], got {}", a.minutes);
    }
    if !(a.rate_hz.is_finite() && a.rate_hz > 0.0 && a.rate_hz <= 10_000.0) {
        bail!("--rate-hz must be in (0, 10000], got {}", a.rate_hz);
    }
    if !(1..=100).contains(&a.runs) {
        bail!("--runs must be in 1..=100, got {}", a.runs);
    }
    let (params, cfg) = terzaghi::sim::robot::rhex()?;
    let legs = cfg.legs.len();
    let dir = std::env::temp_dir().join(format!("terzaghi-bench-record-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let path = a.keep.clone().unwrap_or_else(|| dir.join("session.mcap"));

    // The session: the node's own core makes the outputs, so the traffic is the node's.
    let meta = params
        .iter()
        .map(|(k, v)| (k.clone(), v.to_string()))
        .collect();
    let file = std::fs::File::create(&path)
        .with_context(|| format!("cannot create {}", path.display()))?;
    let mut w = SessionWriter::new(
        BufWriter::with_capacity(1 << 20, file),
        RecordOptions {
            params: meta,
            ..Default::default()
        },
    )?;
    let mut core = NodeCore::new(cfg.clone());
    let names: Vec<String> = cfg.legs.iter().map(|l| l.joint.clone()).collect();
    let ft_topics: Vec<String> = cfg
        .legs
        .iter()
        .map(|l| l.ft_topic.clone().unwrap_or_default())
        .collect();
    let out_topics: Vec<(String, String, String)> =
        terzaghi::config::OutputTopics::of(&cfg, &cfg.remaps)
            .legs
            .into_iter()
            .map(|l| (l.wrench, l.force, l.params))
            .collect();
    let n = (a.minutes * 60.0 * a.rate_hz) as u64;
    let dt_ns = (1e9 / a.rate_hz) as u64;
    let t0: u64 = 1_700_000_000_000_000_000;
    let mut outputs = Outputs::default();
    let mut predicted = Vec::new();
    let mut messages = 0u64;
    let omega = 3.0; // rad/s
    let start = Instant::now();
    for k in 0..n {
        let t = t0 + k * dt_ns;
        let stamp = Time::from_nanos(t as i64).unwrap_or_default();
        let beta = omega * (k as f64 / a.rate_hz);
        let positions: Vec<f64> = cfg
            .legs
            .iter()
            .enumerate()
            .map(|(i, l)| {
                l.direction
                    * (beta
                        + if i % 2 == 0 {
                            0.0
                        } else {
                            std::f64::consts::PI
                        })
            })
            .collect();
        let js = JointState {
            header: Header {
                stamp,
                frame_id: String::new(),
            },
            name: names.clone(),
            position: positions,
            velocity: vec![],
            effort: vec![],
        };
        outputs.clear();
        core.handle(Input::Joints(&js), &mut outputs);
        predicted.clear();
        predicted.append(&mut outputs.legs);
        w.write("/joint_states", OfferedQos::BEST_EFFORT, &js, t, t)?;
        messages += 1;
        for o in &predicted {
            if !a.inputs_only {
                w.write_output(
                    &out_topics[o.leg].0,
                    OfferedQos::RELIABLE,
                    &o.wrench,
                    t + 20_000,
                    t,
                )?;
                w.write_output(
                    &out_topics[o.leg].1,
                    OfferedQos::RELIABLE,
                    &o.force,
                    t + 20_000,
                    t,
                )?;
                messages += 2;
            }
            // The leg's F/T: the predicted force with a little noise, as the leg's sensor reads
            // it (in its configured frame).
            let wobble = ((k * 7919 + o.leg as u64 * 104_729) % 1000) as f64 * 1e-3 - 0.5;
            let (fx, fz) = terzaghi::sim::robot::ft_components(
                cfg.legs[o.leg].ft_frame,
                o.wrench.wrench.force.x + wobble,
                o.wrench.wrench.force.z - wobble,
                o.force.attack_angle_rad,
            );
            let ft = WrenchStamped {
                header: Header {
                    stamp,
                    frame_id: format!("{}_ft", cfg.legs[o.leg].name),
                },
                wrench: Wrench {
                    force: Vector3 {
                        x: fx,
                        y: 0.0,
                        z: fz,
                    },
                    torque: Vector3::default(),
                },
            };
            w.write(
                &ft_topics[o.leg],
                OfferedQos::BEST_EFFORT,
                &ft,
                t + 10_000,
                t,
            )?;
            messages += 1;
            core.handle(Input::Wrench(o.leg, &ft), &mut outputs);
        }
        if a.inputs_only {
            outputs.params.clear();
        }
        for (leg, p) in outputs.params.drain(..) {
            w.write_output(&out_topics[leg].2, OfferedQos::RELIABLE, &p, t + 30_000, t)?;
            messages += 1;
        }
    }
    w.finish()?;
    let write_s = start.elapsed().as_secs_f64();
    let file_bytes = std::fs::metadata(&path)?.len();

    let exe = crate::terzaghi_exe()?;
    let csv = dir.join("reevaluated.csv");
    let mut times_s = Vec::new();
    let mut cpu_s = Vec::new();
    for _ in 0..a.runs {
        // The session and the last run's CSV go to disk first, so that their writeback does not
        // share the cores with this run.
        let _ = std::fs::remove_file(&csv);
        sync_disks();
        let cpu_before_s = children_usage().map_or(0.0, |u| u.cpu_s);
        let start = Instant::now();
        let status = std::process::Command::new(&exe)
            .arg("replay")
            .arg(&path)
            .arg("--reevaluate")
            .arg("-o")
            .arg(&csv)
            .stderr(std::process::Stdio::null())
            .status()?;
        times_s.push(start.elapsed().as_secs_f64());
        cpu_s.push(children_usage().map_or(0.0, |u| u.cpu_s) - cpu_before_s);
        if !status.success() {
            bail!("replay --reevaluate failed on the benchmark session");
        }
    }
    let peak_mb = children_usage().map_or(0.0, |u| u.peak_rss_kb as f64 / 1024.0);
    times_s.sort_by(f64::total_cmp);
    cpu_s.sort_by(f64::total_cmp);
    let reevaluate_s = times_s[times_s.len() / 2];
    let _ = std::fs::remove_file(&csv);
    if a.keep.is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
    let r = Report {
        minutes: a.minutes,
        inputs_only: a.inputs_only,
        legs,
        rate_hz: a.rate_hz,
        messages,
        write_s,
        write_messages_per_s: messages as f64 / write_s,
        file_bytes,
        file_mb_per_minute: file_bytes as f64 / 1e6 / a.minutes,
        reevaluate_s,
        reevaluate_min_s: times_s[0],
        reevaluate_max_s: times_s[times_s.len() - 1],
        reevaluate_runs: times_s.len(),
        reevaluate_times_real_time: a.minutes * 60.0 / reevaluate_s,
        reevaluate_cpu_s: cpu_s[cpu_s.len() / 2],
        reevaluate_peak_mb: peak_mb,
    };
    if a.json {
        return print_out(&(serde_json::to_string_pretty(&r)? + "\n"));
    }
    print_out(&format!(
        "session: {} min, {} legs, JointState and F/T at {} Hz, {}: {} messages\n\
         write (one thread, zstd): {:.1} s, {:.0} messages/s\n\
         file: {:.1} MB, {:.1} MB per minute\n\
         replay --reevaluate to CSV: {:.2} s, {:.0}x real time (median of {}; {:.2}-{:.2} s), CPU {:.2} s (user and system, median), peak memory {:.0} MB\n",
        r.minutes,
        r.legs,
        r.rate_hz,
        if r.inputs_only {
            "the robot's topics only"
        } else {
            "with the node's outputs"
        },
        r.messages,
        r.write_s,
        r.write_messages_per_s,
        r.file_bytes as f64 / 1e6,
        r.file_mb_per_minute,
        r.reevaluate_s,
        r.reevaluate_times_real_time,
        r.reevaluate_runs,
        r.reevaluate_min_s,
        r.reevaluate_max_s,
        r.reevaluate_cpu_s,
        r.reevaluate_peak_mb
    ))
}

/// Flushes every file to disk (`sync(2)`).
fn sync_disks() {
    // SAFETY: sync takes no arguments and cannot fail.
    unsafe { libc::sync() }
}

/// What the child processes waited for so far used (`getrusage(RUSAGE_CHILDREN)`).
struct ChildrenUsage {
    /// User and system time, summed over the children.
    cpu_s: f64,
    /// The largest peak resident set of any of them.
    peak_rss_kb: i64,
}

fn children_usage() -> Option<ChildrenUsage> {
    let mut usage = std::mem::MaybeUninit::<libc::rusage>::zeroed();
    // SAFETY: `usage` is a valid, writable rusage for the call to fill.
    let ok = unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, usage.as_mut_ptr()) } == 0;
    if !ok {
        return None;
    }
    // SAFETY: getrusage succeeded and filled it.
    let u = unsafe { usage.assume_init() };
    let secs = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    Some(ChildrenUsage {
        cpu_s: secs(u.ru_utime) + secs(u.ru_stime),
        peak_rss_kb: u.ru_maxrss,
    })
}
