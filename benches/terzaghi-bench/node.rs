//! `terzaghi-bench node`: the node's latency on this machine, for 6 legs at 1 kHz.
//!
//! It starts `terzaghi node` (the RHex launch configuration) and a bare echo node over the same
//! DDS, then, as an external client, publishes JointStates at the given rate in alternating
//! blocks to each: the round trip to the node is from publishing a JointState to receiving the
//! last leg's predicted wrench; to the echo, from publishing to receiving the echo. The node's
//! own processing time (from taking the JointState off DDS to having published every leg's
//! outputs) comes from what it prints when it stops; its peak memory from /proc. Run it inside
//! a private network namespace.
//!
//! With `--tf-hz N --against-fixed-height` the second target is not the echo but the same node
//! without `/tf` (its hips at their configured heights, in namespace `/fixed`): the cost of
//! placing every hip by `/tf` is then a ratio of two processing times measured in the same
//! run, which the machine's drift between runs does not reach.
//!
//! `terzaghi-bench echo` (hidden) is the bare echo: JointState in, the same JointState out.

use crate::print_out;
use anyhow::{Context as _, Result, anyhow, bail};
use clap::Args;
use terzaghi::msgs::{Header, JointState, LegForce, TfMessage, Time, WrenchStamped};
use terzaghi::node::dds::{RunSummary, SequenceGaps, publisher, subscription, tool_node};
use terzaghi::node::latency::Histogram;

use std::collections::HashMap;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

#[derive(Debug, Args)]
pub struct EchoArgs {
    /// Topic to read JointStates from.
    #[arg(long, default_value = "/bench/echo_in")]
    pub input: String,
    /// Topic to write them to.
    #[arg(long, default_value = "/bench/echo_out")]
    pub output: String,
    /// Pin the echo to this CPU.
    #[arg(long, value_name = "CPU")]
    pub cpu: Option<usize>,
}

#[derive(Debug, Args)]
pub struct BenchNodeArgs {
    /// Measuring time per target (s), split into alternating blocks of one second.
    #[arg(long, default_value_t = 10)]
    pub seconds: u32,
    /// JointState rate (Hz).
    #[arg(long, default_value_t = 1000.0)]
    pub rate_hz: f64,
    /// Load test instead: JointStates only to the node, at --rate-hz for --seconds, watching its
    /// memory; reports what it processed, dropped and its peak resident memory.
    #[arg(long)]
    pub load: bool,
    /// Start the node with --realtime-priority (SCHED_FIFO), as a real-time robot would.
    #[arg(long, value_name = "PRIORITY")]
    pub node_realtime_priority: Option<i32>,
    /// Start the node with --cpu (pinned to this CPU, its DDS threads with it); the echo is
    /// pinned there too, and this client to the other CPUs, so that the node and the echo each
    /// have that core in their blocks, as a control node on a core of its own.
    #[arg(long, value_name = "CPU")]
    pub node_cpu: Option<usize>,
    /// With --load: the first leg's joint position is NaN in every JointState, so that the
    /// node skips that leg of each message and warns (a log storm it must throttle).
    #[arg(long, requires = "load")]
    pub bad_leg: bool,
    /// An argument for `terzaghi node` (repeatable), e.g. --node-arg=--foxglove=127.0.0.1:8765.
    #[arg(long, value_name = "ARG", allow_hyphen_values = true)]
    pub node_arg: Vec<String>,
    /// A further parameters file for the node, read after the RHex configuration's, whose
    /// values it overrides (repeatable): `launch_configs/rhex_wheels.yaml` makes the six legs
    /// wheels.
    #[arg(long, value_name = "PATH")]
    pub params_file: Vec<std::path::PathBuf>,
    /// Also publish every leg's F/T with each JointState to the node (the model's force at the
    /// leg's angle, in its sensor's frame, with noise), so that the node identifies and watches
    /// its gap as on a robot with sensors.
    #[arg(long)]
    pub ft: bool,
    /// Also place every hip by `/tf`, as a walking robot does: the hips in the body on
    /// `/tf_static` once, and the body's pose (heaving 1 cm, pitching 3 deg) on `/tf` at this
    /// rate, stamped on the JointStates' clock; the node is started with each leg's
    /// `hip_frame`. JointStates are then stamped one period apart.
    #[arg(long, value_name = "HZ")]
    pub tf_hz: Option<f64>,
    /// Set the node's gap_check.every_strokes (0: no diagnosis of its own strokes).
    #[arg(long, value_name = "N")]
    pub gap_check_every: Option<usize>,
    /// Run this terzaghi as the node instead of the one beside the benchmark (the previous
    /// release, say, to compare in one run).
    #[arg(long, value_name = "PATH")]
    pub node_exe: Option<std::path::PathBuf>,
    /// With --tf-hz: measure the cost of `/tf` in one run, against the same node at its fixed
    /// hip heights. A second node (the same executable and options, without `hip_frame`, in
    /// namespace `/fixed`) takes the echo's place, the blocks alternate between the two, and
    /// `/tf` is sent in the first one's blocks only; both nodes' processing and their ratio are
    /// reported. The machine's drift between runs then falls on both alike.
    #[arg(long, requires = "tf_hz", conflicts_with = "load")]
    pub against_fixed_height: bool,
    /// With --against-fixed-height: run this terzaghi as the node at fixed heights (the
    /// release before the node took `/tf`, say), so that the node placing its hips by `/tf`
    /// is compared with it in one run.
    #[arg(long, value_name = "PATH", requires = "against_fixed_height")]
    pub fixed_height_exe: Option<std::path::PathBuf>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

/// Runs the bare echo until SIGINT/SIGTERM.
pub fn run_echo(a: EchoArgs) -> Result<()> {
    if let Some(cpu) = a.cpu {
        terzaghi::node::realtime::pin_to_cpus(&[cpu]).context("--cpu")?;
    }
    let rt = terzaghi::node::dds::runtime()?;
    rt.block_on(async move {
        let mut node = tool_node("terzaghi_echo").context("cannot create the echo node")?;
        let out = publisher::<JointState>(&mut node, &a.output)?;
        let sub = subscription::<JointState>(&mut node, &a.input)?;
        let spin = tokio::spawn(node.spinner()?.spin());
        let echo = async {
            while let Ok((msg, _)) = sub.async_take().await {
                let _ = out.publish(msg);
            }
        };
        tokio::select! {
            _ = echo => {}
            _ = tokio::signal::ctrl_c() => {}
        }
        node.stop_spinner();
        let _ = tokio::time::timeout(Duration::from_secs(1), spin).await;
        Ok(())
    })
}

#[derive(Debug, serde::Serialize)]
struct Figures {
    p50_us: f64,
    p99_us: f64,
    max_us: f64,
    count: u64,
}

/// The processing time a node printed when it stopped.
impl From<&RunSummary> for Figures {
    fn from(s: &RunSummary) -> Self {
        Figures {
            p50_us: s.processing_p50_ns as f64 / 1e3,
            p99_us: s.processing_p99_ns as f64 / 1e3,
            max_us: s.processing_max_ns as f64 / 1e3,
            count: s.processing_count,
        }
    }
}

impl From<&Histogram> for Figures {
    fn from(h: &Histogram) -> Self {
        Figures {
            p50_us: h.quantile_ns(0.5) as f64 / 1e3,
            p99_us: h.quantile_ns(0.99) as f64 / 1e3,
            max_us: h.max_ns() as f64 / 1e3,
            count: h.count(),
        }
    }
}

#[derive(Debug, serde::Serialize)]
struct Report {
    legs: usize,
    rate_hz: f64,
    seconds_each: u32,
    node_processing: Figures,
    node_round_trip: Figures,
    echo_round_trip: Figures,
    round_trip_ratio_p50: f64,
    round_trip_ratio_p99: f64,
    node_dropped: u64,
    node_lost_replies: u64,
    /// Of the node's wrenches, those lost on the way back to the benchmark's client (gaps in
    /// their writers' sequence numbers): a reply lost with one of them is the transport's loss,
    /// not the node's.
    node_reply_gaps: u64,
    echo_lost_replies: u64,
    /// As `node_reply_gaps`, for the second target's replies (the fixed-height node's wrenches
    /// or the echo's joint states).
    echo_reply_gaps: u64,
    /// The fixed-height node's count of its inputs lost on the way to it; none for the echo,
    /// which does not count them.
    echo_dropped: Option<u64>,
    /// The node's diagnoses of its own strokes during the run, and those superseded by a newer
    /// one of their leg while they waited for its diagnosis thread; none from a node without
    /// them.
    node_gap_checks: Option<(u64, u64)>,
    /// With `--tf-hz`: its rate, and of the first leg's `leg_force` messages, how many placed
    /// the hip by `/tf` and how many were received.
    tf_hz: Option<f64>,
    tf_placed: Option<(u64, u64)>,
    /// With `--against-fixed-height`: the second node's processing (its hips at their
    /// configured heights, no `/tf`), and the ratios of the first's p50 and p99 to it.
    fixed_height_processing: Option<Figures>,
    /// The fixed-height node's executable, when it is not the node's (`--fixed-height-exe`).
    fixed_height_exe: Option<std::path::PathBuf>,
    tf_ratio_p50: Option<f64>,
    tf_ratio_p99: Option<f64>,
    /// The node's write calls (`/proc/PID/io`'s `syscw`, all its threads, from its start) per
    /// JointState it processed: the wake-ups of DDS's event loop by the node's writes are
    /// among them.
    node_write_calls_per_joint_state: Option<f64>,
    /// Whether the node exited with success within 15 s of SIGINT, and the fixed-height node
    /// (`--against-fixed-height`).
    node_exit_clean: bool,
    fixed_height_exit_clean: Option<bool>,
}

/// The block the client's second target takes: the bare echo, or (`--against-fixed-height`)
/// the node again in namespace `/fixed` without `/tf`.
enum Second {
    Echo,
    Node {
        joint_states: String,
        wrenches: Vec<String>,
    },
}

/// The namespace of `--against-fixed-height`'s second node.
const FIXED_NS: &str = "/fixed";

struct Killer(Vec<Child>);

impl Drop for Killer {
    fn drop(&mut self) {
        for c in &mut self.0 {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

fn sigint(child: &mut Child) {
    // SAFETY-free: `kill` from the shell is enough here and avoids a libc dependency.
    let _ = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status();
}

pub fn run(a: BenchNodeArgs) -> Result<()> {
    if !(a.rate_hz.is_finite() && a.rate_hz > 0.0 && a.rate_hz <= 100_000.0) {
        bail!("--rate-hz must be in (0, 100000], got {}", a.rate_hz);
    }
    if a.seconds == 0 {
        bail!("--seconds must be at least 1");
    }
    if let Some(hz) = a.tf_hz
        && !(hz.is_finite() && hz > 0.0 && hz <= a.rate_hz)
    {
        bail!(
            "--tf-hz must be in (0, --rate-hz = {}], got {hz}",
            a.rate_hz
        );
    }
    let exe = match &a.node_exe {
        Some(p) if p.exists() => p.clone(),
        Some(p) => bail!("--node-exe {}: no such file", p.display()),
        None => crate::terzaghi_exe()?,
    };
    let fixed_exe = match &a.fixed_height_exe {
        Some(p) if p.exists() => p.clone(),
        Some(p) => bail!("--fixed-height-exe {}: no such file", p.display()),
        None => exe.clone(),
    };
    let bench_exe = std::env::current_exe().context("cannot find the terzaghi-bench executable")?;
    let dir = tempdir()?;
    let params = dir.join("rhex.yaml");
    std::fs::write(&params, include_str!("../../launch_configs/rhex.yaml"))?;
    let node_log = dir.join("node.log");
    // The node's legs, joints and output topics, as it reads them from the same file.
    let (_, cfg) = terzaghi::sim::robot::rhex()?;
    let legs = RobotTopics {
        ft: if a.ft { Some(cfg.clone()) } else { None },
        tf: a.tf_hz.map(|hz| (cfg.clone(), hz)),
        first_force: terzaghi::config::OutputTopics::of(&cfg, &cfg.remaps)
            .legs
            .first()
            .map(|l| l.force.clone()),
        joint_states: cfg.joint_states_topic.clone(),
        joints: cfg.legs.iter().map(|l| l.joint.clone()).collect(),
        wrenches: terzaghi::config::OutputTopics::of(&cfg, &cfg.remaps)
            .legs
            .into_iter()
            .map(|l| l.wrench)
            .collect(),
        second: if a.against_fixed_height {
            // The same parameters, loaded as the second node loads them in its namespace.
            let (params, _) = terzaghi::sim::robot::rhex()?;
            let fixed =
                terzaghi::config::NodeConfig::from_params(&params, &cfg.node_name, FIXED_NS, &[])?;
            Second::Node {
                joint_states: terzaghi::config::resolve_topic(
                    &fixed.joint_states_topic,
                    &fixed.namespace,
                    &fixed.node_name,
                    &fixed.remaps,
                ),
                wrenches: terzaghi::config::OutputTopics::of(&fixed, &fixed.remaps)
                    .legs
                    .into_iter()
                    .map(|l| l.wrench)
                    .collect(),
            }
        } else {
            Second::Echo
        },
    };
    // The node, and with --against-fixed-height the same node (or --fixed-height-exe) without
    // /tf in FIXED_NS.
    let node_command =
        |exe: &std::path::Path, with_tf: bool, namespace: Option<&str>, log: &std::path::Path| {
            let mut c = Command::new(exe);
            c.arg("node")
                .args(
                    a.node_realtime_priority
                        .map(|p| format!("--realtime-priority={p}")),
                )
                .args(a.node_cpu.map(|c| format!("--cpu={c}")))
                .args(&a.node_arg)
                .args(["--ros-args", "--params-file"])
                .arg(&params)
                .args(
                    a.params_file
                        .iter()
                        .flat_map(|f| [std::ffi::OsStr::new("--params-file"), f.as_os_str()]),
                )
                .args(
                    a.gap_check_every
                        .map(|n| ["-p".to_string(), format!("gap_check.every_strokes:={n}")])
                        .into_iter()
                        .flatten(),
                )
                .args(cfg.legs.iter().filter(|_| with_tf).flat_map(|l| {
                    [
                        "-p".to_string(),
                        format!(
                            "{}.hip_frame:={}",
                            l.name,
                            terzaghi::sim::robot::hip_frame(&l.name)
                        ),
                    ]
                }))
                .args(
                    namespace
                        .map(|ns| ["-r".to_string(), format!("__ns:={ns}")])
                        .into_iter()
                        .flatten(),
                )
                .stderr(std::fs::File::create(log)?);
            c.spawn().context("cannot start terzaghi node")
        };
    let mut children = Killer(Vec::new());
    children
        .0
        .push(node_command(&exe, a.tf_hz.is_some(), None, &node_log)?);
    let fixed_log = dir.join("fixed.log");
    if a.against_fixed_height {
        children
            .0
            .push(node_command(&fixed_exe, false, Some(FIXED_NS), &fixed_log)?);
    } else if !a.load {
        children.0.push(
            Command::new(&bench_exe)
                .arg("echo")
                .args(a.node_cpu.map(|c| format!("--cpu={c}")))
                .stderr(Stdio::null())
                .spawn()
                .context("cannot start terzaghi echo")?,
        );
    }
    let node_pid = children.0[0].id();
    if let Some(cpu) = a.node_cpu {
        let online = std::thread::available_parallelism().map_or(1, |n| n.get());
        let others: Vec<usize> = (0..online).filter(|&c| c != cpu).collect();
        if others.is_empty() {
            bail!("--node-cpu needs a second CPU for the client; this machine has {online}");
        }
        terzaghi::node::realtime::pin_to_cpus(&others)?;
    }

    let rt = terzaghi::node::dds::runtime()?;
    let (node_rt, echo_rt, lost_node, lost_echo, load) = rt.block_on(client(
        &legs,
        a.rate_hz,
        a.seconds,
        a.load.then_some(node_pid),
        a.bad_leg,
    ))?;
    // The node's peak memory and its write calls, read before it is asked to stop.
    let node_peak_rss_kb = peak_rss_kb(node_pid);
    let node_write_calls = write_calls(node_pid);
    for c in children.0.iter_mut() {
        sigint(c);
    }
    let deadline = Instant::now() + Duration::from_secs(15);
    let exited_clean = |child: &mut Child| loop {
        match child.try_wait() {
            Ok(Some(status)) => break status.success(),
            Ok(None) if Instant::now() < deadline => std::thread::sleep(Duration::from_millis(50)),
            _ => break false,
        }
    };
    let node_exit_clean = exited_clean(&mut children.0[0]);
    let text = std::fs::read_to_string(&node_log).context("the node's log is missing")?;
    let summary = stop_line(&text).with_context(|| {
        format!("the node did not report its run at shutdown; its log:\n{text}")
    })?;
    let fixed_exit_clean = a
        .against_fixed_height
        .then(|| exited_clean(&mut children.0[1]));
    let fixed = if a.against_fixed_height {
        let text = std::fs::read_to_string(&fixed_log)
            .context("the fixed-height node's log is missing")?;
        Some(stop_line(&text).with_context(|| {
            format!("the fixed-height node did not report its run at shutdown; its log:\n{text}")
        })?)
    } else {
        None
    };
    let _ = std::fs::remove_dir_all(&dir);

    if a.load {
        let r = LoadReport {
            legs: legs.joints.len(),
            rate_hz: a.rate_hz,
            seconds: a.seconds,
            sent: load.sent,
            node_joint_states: summary.joint_states,
            node_dropped_counted: summary.dropped,
            node_predictions: summary.predictions,
            node_peak_rss_kb,
            node_rss_kb_per_second: load.rss_kb,
            node_exit_clean,
            node_processing: Figures::from(&summary),
            node_log_lines: text.lines().count(),
        };
        if a.json {
            return print_out(&(serde_json::to_string_pretty(&r)? + "\n"));
        }
        let peak = r
            .node_peak_rss_kb
            .map(|v| v.to_string())
            .unwrap_or_else(|| "?".into());
        return print_out(&format!(
            "load: {} legs, JointState at {} Hz for {} s\n\
             sent {}, node processed {} and counted {} dropped; {} predictions\n\
             node resident memory: peak {} kB; each second {:?} kB; clean exit: {}\n\
             node processing p50 {:.1} us, p99 {:.1} us, max {:.1} us; {} lines on its stderr\n",
            r.legs,
            r.rate_hz,
            r.seconds,
            r.sent,
            r.node_joint_states,
            r.node_dropped_counted,
            r.node_predictions,
            peak,
            r.node_rss_kb_per_second,
            r.node_exit_clean,
            r.node_processing.p50_us,
            r.node_processing.p99_us,
            r.node_processing.max_us,
            r.node_log_lines
        ));
    }
    let nr = Figures::from(&node_rt);
    let er = Figures::from(&echo_rt);
    let node_processing = Figures::from(&summary);
    let fixed_height_processing = fixed.as_ref().map(Figures::from);
    let ratio = |q: fn(&Figures) -> f64| {
        fixed_height_processing
            .as_ref()
            .map(|f| q(&node_processing) / q(f).max(1e-9))
    };
    let node_write_calls_per_joint_state =
        node_write_calls.map(|w| w as f64 / node_processing.count.max(1) as f64);
    let report = Report {
        tf_ratio_p50: ratio(|f| f.p50_us),
        tf_ratio_p99: ratio(|f| f.p99_us),
        fixed_height_processing,
        fixed_height_exe: a.fixed_height_exe.clone(),
        legs: legs.joints.len(),
        rate_hz: a.rate_hz,
        seconds_each: a.seconds,
        node_processing,
        round_trip_ratio_p50: nr.p50_us / er.p50_us.max(1e-9),
        round_trip_ratio_p99: nr.p99_us / er.p99_us.max(1e-9),
        node_round_trip: nr,
        echo_round_trip: er,
        node_dropped: summary.dropped,
        node_lost_replies: lost_node,
        node_reply_gaps: load.node_reply_gaps,
        echo_lost_replies: lost_echo,
        echo_reply_gaps: load.echo_reply_gaps,
        echo_dropped: fixed.as_ref().map(|f| f.dropped),
        node_gap_checks: gap_line(&text),
        tf_hz: a.tf_hz,
        tf_placed: a.tf_hz.map(|_| (load.tf_placed, load.forces_seen)),
        node_write_calls_per_joint_state,
        node_exit_clean,
        fixed_height_exit_clean: fixed_exit_clean,
    };
    if a.json {
        return print_out(&(serde_json::to_string_pretty(&report)? + "\n"));
    }
    let row = |name: &str, f: &Figures| {
        format!(
            "{:<44} {:>9.1} {:>9.1} {:>9.1} {:>8}\n",
            name, f.p50_us, f.p99_us, f.max_us, f.count
        )
    };
    let mut s = format!(
        "{} legs, JointState at {} Hz, {} s per target (alternating 1 s blocks)\n{:<44} {:>9} {:>9} {:>9} {:>8}\n",
        report.legs, report.rate_hz, report.seconds_each, "", "p50 us", "p99 us", "max us", "count"
    );
    s += &row("node processing (inside the node)", &report.node_processing);
    s += &row(
        "round trip: client -> node -> all 6 wrenches",
        &report.node_round_trip,
    );
    match &report.fixed_height_processing {
        Some(f) => {
            s += &row(
                "round trip: client -> fixed-height node -> 6",
                &report.echo_round_trip,
            );
            s += &row("fixed-height node processing (no /tf)", f);
            if let Some(p) = &report.fixed_height_exe {
                s += &format!("the fixed-height node: {}\n", p.display());
            }
        }
        None => {
            s += &row(
                "round trip: client -> bare echo -> client",
                &report.echo_round_trip,
            )
        }
    }
    if let (Some(hz), Some((placed, seen))) = (report.tf_hz, report.tf_placed) {
        s += &format!(
            "hips placed by /tf at {hz} Hz: {placed} of {seen} of the first leg's leg_force\n"
        );
    }
    if let Some((made, skipped)) = report.node_gap_checks {
        s += &format!(
            "the node's own diagnoses during the run: {made} ({skipped} superseded while waiting)\n"
        );
    }
    let second = if a.against_fixed_height {
        "fixed-height node"
    } else {
        "echo"
    };
    if let Some(w) = report.node_write_calls_per_joint_state {
        s += &format!("the node's write calls per JointState (all threads): {w:.2}\n");
    }
    let yes_no = |clean: bool| if clean { "yes" } else { "NO" };
    s += &format!("clean exit: node {}", yes_no(report.node_exit_clean));
    if let Some(clean) = report.fixed_height_exit_clean {
        s += &format!(", fixed-height node {}", yes_no(clean));
    }
    s += "\n";
    if let (Some(p50), Some(p99)) = (report.tf_ratio_p50, report.tf_ratio_p99) {
        s += &format!("processing with /tf / at fixed heights: p50 {p50:.2}x, p99 {p99:.2}x\n");
    }
    s += &format!(
        "round trip node / {}: p50 {:.2}x, p99 {:.2}x; node dropped {} inputs; replies lost: node {} ({} wrenches lost on the way back), {} {} ({} lost on the way back)\n",
        second,
        report.round_trip_ratio_p50,
        report.round_trip_ratio_p99,
        report.node_dropped,
        report.node_lost_replies,
        report.node_reply_gaps,
        second,
        report.echo_lost_replies,
        report.echo_reply_gaps
    );
    print_out(&s)
}

fn tempdir() -> Result<std::path::PathBuf> {
    let d = std::env::temp_dir().join(format!("terzaghi-bench-{}", std::process::id()));
    std::fs::create_dir_all(&d).with_context(|| format!("cannot create {}", d.display()))?;
    Ok(d)
}

type Sent = Arc<Mutex<HashMap<i64, Instant>>>;

/// Publishes to the node and to the echo in alternating one-second blocks; returns the round
/// trips and how many replies never came.
/// What the client publishes to and listens on.
struct RobotTopics {
    /// With `--ft`: the robot's configuration, whose legs' F/T topics, frames and models the
    /// client's simulated sensors follow.
    ft: Option<terzaghi::config::NodeConfig>,
    joint_states: String,
    joints: Vec<String>,
    /// Each leg's predicted wrench.
    wrenches: Vec<String>,
    /// With `--tf-hz`: the robot (whose hips go on `/tf_static`) and the rate of `/tf`.
    tf: Option<(terzaghi::config::NodeConfig, f64)>,
    /// The first leg's `leg_force`, which says whether the node placed its hip by `/tf`.
    first_force: Option<String>,
    /// The target of every other block.
    second: Second,
}

async fn client(
    legs: &RobotTopics,
    rate_hz: f64,
    seconds: u32,
    load: Option<u32>,
    bad_leg: bool,
) -> Result<(Histogram, Histogram, u64, u64, LoadFigures)> {
    let mut node = tool_node("terzaghi_bench_client").context("cannot create the client node")?;
    let to_node = publisher::<JointState>(&mut node, &legs.joint_states)?;
    // Each leg's F/T: its publisher, model, frame, direction and offset.
    let mut sensors = Vec::new();
    if let Some(cfg) = &legs.ft {
        for (i, l) in cfg.legs.iter().enumerate() {
            let Some(topic) = &l.ft_topic else { continue };
            sensors.push((
                i,
                publisher::<WrenchStamped>(&mut node, topic)?,
                cfg.leg_model(i, l.width, None)?,
                l.ft_frame,
                l.direction,
                l.angle_offset_rad,
            ));
        }
    }
    let mut noise = 0x9E37_79B9_7F4A_7C15u64;
    // The robot's state: the hips in the body once on /tf_static (latched, as tf2's static
    // broadcaster), the body's pose on /tf.
    let tf_pubs = match &legs.tf {
        Some((cfg, hz)) => {
            let statics = terzaghi::node::dds::publisher_with_qos::<TfMessage>(
                &mut node,
                terzaghi::config::TF_STATIC_TOPIC,
                terzaghi::node::dds::qos_latched(),
            )?;
            statics.publish(terzaghi::sim::robot::hips_tf(cfg, 0))?;
            let h0 = cfg.legs.first().map_or(0.15, |l| l.plate.hip_height_m());
            let every = (rate_hz / hz).round().max(1.0) as u64;
            Some((
                statics,
                publisher::<TfMessage>(&mut node, terzaghi::config::TF_TOPIC)?,
                h0,
                every,
            ))
        }
        None => None,
    };
    let placed = Arc::new(Mutex::new((0u64, 0u64)));
    if let Some(topic) = &legs.first_force {
        let sub = subscription::<LegForce>(&mut node, topic)?;
        let placed = placed.clone();
        tokio::spawn(async move {
            while let Ok((f, _)) = sub.async_take().await {
                let mut p = placed.lock().unwrap_or_else(|p| p.into_inner());
                p.0 += u64::from(f.robot_state);
                p.1 += 1;
            }
        });
    }
    let (to_echo, from_echo, second_wrench_subs) = match &legs.second {
        Second::Echo => (
            publisher::<JointState>(&mut node, "/bench/echo_in")?,
            Some(subscription::<JointState>(&mut node, "/bench/echo_out")?),
            Vec::new(),
        ),
        Second::Node {
            joint_states,
            wrenches,
        } => {
            let mut subs = Vec::new();
            for topic in wrenches {
                subs.push(subscription::<WrenchStamped>(&mut node, topic)?);
            }
            (
                publisher::<JointState>(&mut node, joint_states)?,
                None,
                subs,
            )
        }
    };
    let mut wrench_subs = Vec::new();
    for topic in &legs.wrenches {
        wrench_subs.push(subscription::<WrenchStamped>(&mut node, topic)?);
    }
    let spin = tokio::spawn(node.spinner()?.spin());

    let node_sent: Sent = Arc::default();
    let echo_sent: Sent = Arc::default();
    let node_hist = Arc::new(Mutex::new(Histogram::default()));
    let echo_hist = Arc::new(Mutex::new(Histogram::default()));
    let n_legs = legs.joints.len();
    let node_reply_gaps = Arc::new(std::sync::atomic::AtomicU64::new(0));
    let echo_reply_gaps = Arc::new(std::sync::atomic::AtomicU64::new(0));
    let mut tasks = collect_wrenches(
        wrench_subs,
        n_legs,
        node_sent.clone(),
        node_hist.clone(),
        node_reply_gaps.clone(),
    );
    tasks.extend(collect_wrenches(
        second_wrench_subs,
        n_legs,
        echo_sent.clone(),
        echo_hist.clone(),
        echo_reply_gaps.clone(),
    ));
    if let Some(from_echo) = from_echo {
        let (sent, hist) = (echo_sent.clone(), echo_hist.clone());
        let gaps_seen = echo_reply_gaps.clone();
        tasks.push(tokio::spawn(async move {
            let mut gaps = SequenceGaps::default();
            while let Ok((m, info)) = from_echo.async_take().await {
                let now = Instant::now();
                gaps_seen.fetch_add(gaps.lost(&info), std::sync::atomic::Ordering::Relaxed);
                if let Some(t) = sent
                    .lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .remove(&m.header.stamp.to_nanos())
                {
                    hist.lock()
                        .unwrap_or_else(|p| p.into_inner())
                        .record((now - t).as_nanos() as u64);
                }
            }
        }));
    }

    // Discovery, then a warm-up second to each target.
    tokio::time::sleep(Duration::from_secs(3)).await;
    let names: Vec<String> = legs.joints.clone();
    let period = Duration::from_secs_f64(1.0 / rate_hz);
    let mut stamp_ns: i64 = 1_000_000_000_000;
    let mut k: u64 = 0;
    let mut figures = LoadFigures::default();
    let blocks = if load.is_some() {
        seconds + 1
    } else {
        2 * seconds + 2
    };
    for block in 0..blocks {
        let warmup = load.is_none() && block < 2;
        let to_echo_now = load.is_none() && block % 2 == 1;
        if let Some(pid) = load {
            figures.rss_kb.push(rss_kb(pid).unwrap_or(0));
        }
        let mut tick = tokio::time::interval(period);
        // Timers tick in milliseconds: above 1 kHz, missed ticks burst to keep the mean rate.
        tick.set_missed_tick_behavior(if rate_hz > 1000.0 {
            tokio::time::MissedTickBehavior::Burst
        } else {
            tokio::time::MissedTickBehavior::Skip
        });
        let end = Instant::now() + Duration::from_secs(1);
        while Instant::now() < end {
            tick.tick().await;
            // With /tf the stamps are the robot's clock (the hips' velocities are taken over
            // 20 ms of it); without, any unique stamp does.
            stamp_ns += if tf_pubs.is_some() {
                (1e9 / rate_hz) as i64
            } else {
                1_000
            };
            k += 1;
            // The robot's state goes to the node that uses it, in its blocks only.
            if let Some((_, tf, h0, every)) = &tf_pubs
                && !to_echo_now
                && k.is_multiple_of(*every)
            {
                let t_s = (stamp_ns - 1_000_000_000_000) as f64 * 1e-9;
                let phase = std::f64::consts::TAU * 2.0 * t_s;
                let pose = terzaghi::sim::robot::BodyPose {
                    x_m: 0.1 * t_s,
                    z_m: h0 + 0.01 * phase.sin(),
                    pitch_rad: 3f64.to_radians() * phase.cos(),
                };
                let _ = tf.publish(terzaghi::sim::robot::body_pose_tf(&pose, stamp_ns));
            }
            // Both legs of every tripod move; positions sweep through the stroke.
            let beta = (k as f64 * 0.004) % std::f64::consts::TAU;
            let msg = JointState {
                header: Header {
                    stamp: Time::from_nanos(stamp_ns).unwrap_or_default(),
                    frame_id: String::new(),
                },
                name: names.clone(),
                position: (0..names.len())
                    .map(|i| match i {
                        0 if bad_leg => f64::NAN,
                        _ if i < 3 => beta,
                        _ => -beta,
                    })
                    .collect(),
                velocity: vec![],
                effort: vec![],
            };
            let (publ, sent) = if to_echo_now {
                (&to_echo, &echo_sent)
            } else {
                (&to_node, &node_sent)
            };
            if !warmup {
                sent.lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .insert(stamp_ns, Instant::now());
            }
            let positions = msg.position.clone();
            if publ.publish(msg).is_ok() {
                figures.sent += 1;
            }
            if !to_echo_now {
                for (i, p, model, frame, direction, offset) in &sensors {
                    let beta = direction * (positions[*i] - offset);
                    let Ok(f) = model.predict(beta) else { continue };
                    // Noise of about 0.3 N from a xorshift: the client needs no generator.
                    let mut n = || {
                        noise ^= noise << 13;
                        noise ^= noise >> 7;
                        noise ^= noise << 17;
                        (noise >> 11) as f64 / (1u64 << 53) as f64 - 0.5
                    };
                    let (fx, fz) = (-f.drag_n + 0.6 * n(), f.lift_n + 0.6 * n());
                    let (wx, wz) = terzaghi::sim::robot::ft_components(*frame, fx, fz, f.beta_rad);
                    let w = WrenchStamped {
                        header: Header {
                            stamp: Time::from_nanos(stamp_ns).unwrap_or_default(),
                            frame_id: String::new(),
                        },
                        wrench: terzaghi::msgs::Wrench {
                            force: terzaghi::msgs::Vector3 {
                                x: wx,
                                y: 0.0,
                                z: wz,
                            },
                            torque: terzaghi::msgs::Vector3::default(),
                        },
                    };
                    let _ = p.publish(w);
                }
            }
        }
    }
    tokio::time::sleep(Duration::from_millis(500)).await;
    (figures.tf_placed, figures.forces_seen) = *placed.lock().unwrap_or_else(|p| p.into_inner());
    drop(tf_pubs);
    for t in &tasks {
        t.abort();
    }
    node.stop_spinner();
    let _ = tokio::time::timeout(Duration::from_secs(1), spin).await;
    figures.node_reply_gaps = node_reply_gaps.load(std::sync::atomic::Ordering::Relaxed);
    figures.echo_reply_gaps = echo_reply_gaps.load(std::sync::atomic::Ordering::Relaxed);
    let lost_node = node_sent.lock().map(|m| m.len() as u64).unwrap_or(0);
    let lost_echo = echo_sent.lock().map(|m| m.len() as u64).unwrap_or(0);
    let nh = node_hist
        .lock()
        .map(|h| h.clone())
        .map_err(|_| anyhow!("poisoned"))?;
    let eh = echo_hist
        .lock()
        .map(|h| h.clone())
        .map_err(|_| anyhow!("poisoned"))?;
    Ok((nh, eh, lost_node, lost_echo, figures))
}

/// Times each stamp from its `sent` instant to the last of `n_legs` predicted wrenches on
/// `subs`, into `hist`; adds to `gaps_seen` the wrenches lost on the way from their writers
/// (gaps in each writer's sequence numbers).
fn collect_wrenches(
    subs: Vec<ros2_client::Subscription<WrenchStamped>>,
    n_legs: usize,
    sent: Sent,
    hist: Arc<Mutex<Histogram>>,
    gaps_seen: Arc<std::sync::atomic::AtomicU64>,
) -> Vec<tokio::task::JoinHandle<()>> {
    // Per stamp, how many legs answered so far.
    let answers: Arc<Mutex<HashMap<i64, usize>>> = Arc::default();
    subs.into_iter()
        .map(|sub| {
            let (sent, hist, answers) = (sent.clone(), hist.clone(), answers.clone());
            let gaps_seen = gaps_seen.clone();
            tokio::spawn(async move {
                let mut gaps = SequenceGaps::default();
                while let Ok((w, info)) = sub.async_take().await {
                    let now = Instant::now();
                    gaps_seen.fetch_add(gaps.lost(&info), std::sync::atomic::Ordering::Relaxed);
                    let stamp = w.header.stamp.to_nanos();
                    let mut ans = answers.lock().unwrap_or_else(|p| p.into_inner());
                    let n = ans.entry(stamp).or_insert(0);
                    *n += 1;
                    if *n == n_legs {
                        ans.remove(&stamp);
                        if let Some(t) = sent
                            .lock()
                            .unwrap_or_else(|p| p.into_inner())
                            .remove(&stamp)
                        {
                            hist.lock()
                                .unwrap_or_else(|p| p.into_inner())
                                .record((now - t).as_nanos() as u64);
                        }
                    }
                }
            })
        })
        .collect()
}

/// What the load test saw from outside the node.
#[derive(Debug, Default, serde::Serialize)]
struct LoadFigures {
    sent: u64,
    /// The node's wrenches lost on the way to this client: gaps in the sequence numbers of
    /// their writers (a best-effort reader's datagrams the loaded loopback drops).
    node_reply_gaps: u64,
    /// The same for the second target's replies.
    echo_reply_gaps: u64,
    /// With `/tf`: the first leg's `leg_force` messages received, and those whose hip the node
    /// placed by `/tf`.
    forces_seen: u64,
    tf_placed: u64,
    /// The node's resident memory at the start of each second (kB).
    rss_kb: Vec<u64>,
}

/// Resident memory of process `pid` now (kB), from /proc (Linux).
fn rss_kb(pid: u32) -> Option<u64> {
    proc_field(pid, "status", "VmRSS:")
}

#[derive(Debug, serde::Serialize)]
struct LoadReport {
    legs: usize,
    rate_hz: f64,
    seconds: u32,
    sent: u64,
    node_joint_states: u64,
    node_dropped_counted: u64,
    node_predictions: u64,
    node_peak_rss_kb: Option<u64>,
    node_rss_kb_per_second: Vec<u64>,
    node_exit_clean: bool,
    node_processing: Figures,
    /// Lines the node wrote to stderr in the whole run (its log).
    node_log_lines: usize,
}

/// What the node said of its run when it stopped (its last log line on stderr, after the
/// `[INFO] [STAMP] [LOGGER]: ` prefix: "terzaghi node stopped: J joint states, P predictions,
/// D inputs dropped; processing p50 X us, p99 Y us, max Z us").
fn stop_line(log: &str) -> Option<RunSummary> {
    let line = log.lines().rev().find_map(|l| {
        let msg = l.split_once("]: ").map_or(l, |(_, m)| m);
        msg.strip_prefix("terzaghi node stopped:")
    })?;
    let numbers: Vec<f64> = line
        .split(|c: char| !(c.is_ascii_digit() || c == '.'))
        .filter_map(|w| w.trim_matches('.').parse().ok())
        .collect();
    // "p50" and "p99" carry numbers of their own.
    let [js, pred, dropped, undecodable, _, p50, _, p99, max] = numbers[..] else {
        return None;
    };
    Some(RunSummary {
        joint_states: js as u64,
        predictions: pred as u64,
        dropped: dropped as u64,
        undecodable: undecodable as u64,
        processing_p50_ns: (p50 * 1e3) as u64,
        processing_p99_ns: (p99 * 1e3) as u64,
        processing_max_ns: (max * 1e3) as u64,
        processing_count: js as u64,
    })
}

/// The node's count of its own diagnoses, from its log: "the node's own diagnoses: N of recent
/// strokes, M skipped ...".
fn gap_line(log: &str) -> Option<(u64, u64)> {
    let line = log
        .lines()
        .find_map(|l| l.split_once("the node's own diagnoses: ").map(|x| x.1))?;
    let n: Vec<u64> = line
        .split(|c: char| !c.is_ascii_digit())
        .filter_map(|w| w.parse().ok())
        .collect();
    Some((*n.first()?, *n.get(1)?))
}

/// The write calls (`write`, `writev` and their kind, not socket sends) process `pid` has made
/// so far, all its threads (`syscw` of `/proc/PID/io`): among them, the wake-ups of DDS's
/// event loop by its writers.
fn write_calls(pid: u32) -> Option<u64> {
    proc_field(pid, "io", "syscw:")
}

/// Peak resident memory of process `pid` (kB), from /proc (Linux).
fn peak_rss_kb(pid: u32) -> Option<u64> {
    proc_field(pid, "status", "VmHWM:")
}

/// The number after `key` in `/proc/PID/FILE` (a unit after it, as `kB`, dropped).
fn proc_field(pid: u32, file: &str, key: &str) -> Option<u64> {
    let s = std::fs::read_to_string(format!("/proc/{pid}/{file}")).ok()?;
    s.lines()
        .find_map(|l| l.strip_prefix(key))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_node_stop_line_reads_back() {
        let s = super::stop_line(
            "noise\n[INFO] [1795445050.756860069] [robot.terzaghi]: terzaghi node stopped: 10000 joint states, 60000 predictions, 3 inputs dropped, 7 samples that did not decode skipped; processing p50 16.4 us, p99 45.1 us, max 120.0 us\n",
        )
        .unwrap();
        assert_eq!(
            (s.joint_states, s.predictions, s.dropped, s.undecodable),
            (10_000, 60_000, 3, 7)
        );
        assert_eq!(
            (
                s.processing_p50_ns,
                s.processing_p99_ns,
                s.processing_max_ns
            ),
            (16_400, 45_100, 120_000)
        );
    }
}
