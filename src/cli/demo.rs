//! `terzaghi demo`: the whole job in one command. A simulated six-legged robot walks on poppy
//! seeds; its joint states and F/T go through the node (in memory, or over DDS with `--dds`),
//! which predicts every leg's forces, learns the medium online and records the session; then the
//! recording is diagnosed, and the summary compares what the diagnosis found with what the
//! simulation hid.

use super::bench_diagnose::rhex;
use super::diagnose::{DiagnoseArgs, diagnose_to_dir};
use super::{MediumArgs, print_out, write_atomically};
use crate::config::NodeConfig;
use crate::ident::Estimate;
use crate::msgs::{DiagnosticArray, LegForce, ModelParams, WrenchStamped};
use crate::node::NodeCore;
use crate::node::handle::Publish;
use crate::node::memory::{self, Input};
use crate::sim::robot::{Gait, Session, Truth, joint_state, simulate, wrench};
use crate::withheld::generator::Hidden;
use anyhow::{Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::cell::RefCell;
use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::time::{Duration, Instant};

#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Simulated seconds of walking.
    #[arg(long, default_value_t = 60.0)]
    pub seconds: f64,
    /// Directory for the session (session.mcap), the diagnosis and the summary.
    #[arg(long, value_name = "DIR", default_value = "terzaghi-demo")]
    pub out: PathBuf,
    /// Run over real DDS on the ROS 2 network of this machine (ROS_DOMAIN_ID, and
    /// ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST to stay on loopback) instead of in memory.
    #[arg(long)]
    pub dds: bool,
    /// Speed against the robot's clock: 5 plays 60 s in 12 s. At most 20.
    #[arg(long, default_value_t = 5.0)]
    pub speed: f64,
    /// Seed of the walk and of the sensors.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// What the simulation hides: the medium's true fitting width and two effects.
fn truth() -> Truth {
    Truth {
        b_k: 24.0,
        a: 1.9,
        effects: vec![Hidden::Surcharge, Hidden::Extraction],
        magnitude: 0.5,
        noise_frac: 0.015,
    }
}

const RATE_HZ: f64 = 500.0;

pub fn run(a: DemoArgs) -> Result<()> {
    if !(a.seconds.is_finite() && (10.0..=3600.0).contains(&a.seconds)) {
        bail!("--seconds must be in [10, 3600], got {}", a.seconds);
    }
    if !(a.speed.is_finite() && a.speed > 0.0 && a.speed <= 20.0) {
        bail!("--speed must be in (0, 20], got {}", a.speed);
    }
    std::fs::create_dir_all(&a.out)
        .map_err(|e| anyhow::anyhow!("cannot create {}: {e}", a.out.display()))?;
    let session_path = a.out.join("session.mcap");
    let (params, mut cfg) = rhex()?;
    cfg.record = Some(session_path.clone());
    let truth = truth();
    let gait = Gait {
        seconds: a.seconds,
        rate_hz: RATE_HZ,
        mean_speed_rad_s: 4.0,
        seed: a.seed,
    };
    let session = simulate(&cfg, &truth, &gait);
    let t0_ns = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as i64)
        .unwrap_or(0);
    eprintln!(
        "a six-legged robot walks {:.0} s on {} ({} Hz joint states and F/T, {} playback); the node {}:",
        a.seconds,
        cfg.legs[0].preset.map_or("its medium", |p| p.name),
        RATE_HZ,
        format_args!("{}x", a.speed),
        if a.dds {
            "runs over DDS"
        } else {
            "runs in memory"
        }
    );
    let view = LiveView::new(&cfg, &session, &truth);
    let started = Instant::now();
    let (estimates, recorded) = if a.dds {
        run_dds(&cfg, &params, &session, t0_ns, a.speed, &view)?
    } else {
        run_memory(&cfg, &params, &session, t0_ns, a.speed, &view)?
    };
    view.finish();
    let run_s = started.elapsed().as_secs_f64();
    // What the recording holds, from its summary (without reading the whole file).
    let recorded = crate::record::read::IndexedFile::open(&session_path)?
        .map_or(recorded, |f| f.head().messages);

    eprintln!("diagnosing the recording...");
    let started = Instant::now();
    let diag_dir = a.out.join("diagnosis");
    let done = diagnose_to_dir(&DiagnoseArgs {
        log: session_path.clone(),
        out: diag_dir.clone(),
        leg: None,
        params_file: None,
        joint: None,
        wrench_topic: None,
        joint_states_topic: "/joint_states".into(),
        ft_frame: "hip".into(),
        direction: 1.0,
        angle_offset_rad: 0.0,
        length_m: None,
        width_m: None,
        hip_height_m: None,
        medium: MediumArgs {
            medium: None,
            unit_weight_n_m3: None,
            phi_deg: None,
            delta_deg: None,
        },
        folds: 5,
        json: false,
    })?;
    if !done.failed.is_empty() {
        bail!("the diagnosis failed: {}", done.failed.join("; "));
    }
    let diagnose_s = started.elapsed().as_secs_f64();
    let summary = summarize(
        &cfg,
        &truth,
        &estimates,
        &done.reports,
        &a,
        recorded,
        run_s,
        diagnose_s,
    );
    let body = serde_json::to_string_pretty(&summary.json)? + "\n";
    write_atomically(&a.out.join("summary.json"), |w| {
        Ok(w.write_all(body.as_bytes())?)
    })?;
    print_out(&summary.text)
}

/// The latest prediction and estimate of every leg, for the live view.
struct LiveView {
    bar: ProgressBar,
    truth: Truth,
    names: Vec<String>,
    /// Per leg: latest predicted (drag, lift), running squared error and count over the last
    /// second of the robot's clock, and the latest estimate.
    state: RefCell<Vec<LegView>>,
    last_draw: RefCell<Instant>,
    session: Session,
}

#[derive(Clone, Default)]
struct LegView {
    predicted: Option<(f64, f64)>,
    sq_err: f64,
    n: f64,
    rms_first: Option<f64>,
    rms: f64,
    estimate: Option<(f64, f64, bool)>,
}

impl LiveView {
    fn new(cfg: &NodeConfig, session: &Session, truth: &Truth) -> LiveView {
        let bar = if std::io::stderr().is_terminal() {
            ProgressBar::new(session.t_s.len() as u64)
        } else {
            ProgressBar::hidden()
        };
        bar.set_style(
            ProgressStyle::with_template("{bar:40} {percent:>3}% of the walk, {elapsed}\n{msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        LiveView {
            bar,
            truth: truth.clone(),
            names: cfg.legs.iter().map(|l| l.name.clone()).collect(),
            state: RefCell::new(vec![LegView::default(); cfg.legs.len()]),
            last_draw: RefCell::new(Instant::now()),
            session: session.clone(),
        }
    }

    /// After the node handled JointState `k`: compare each leg's prediction with what its
    /// sensor measured at that instant.
    fn after_joints(&self, k: usize) {
        let mut st = self.state.borrow_mut();
        for (leg, v) in st.iter_mut().enumerate() {
            if let (Some((d, l)), Some(m)) = (v.predicted, self.session.legs[leg].get(k)) {
                v.sq_err += (d - m.drag_n).powi(2) + (l - m.lift_n).powi(2);
                v.n += 2.0;
            }
            // A window of two seconds of the walk (more than a stroke).
            if v.n >= 4.0 * RATE_HZ {
                v.rms = (v.sq_err / v.n).sqrt();
                v.rms_first.get_or_insert(v.rms);
                v.sq_err = 0.0;
                v.n = 0.0;
            }
        }
        drop(st);
        if self.last_draw.borrow().elapsed() > Duration::from_millis(200) {
            *self.last_draw.borrow_mut() = Instant::now();
            self.bar.set_position(k as u64 + 1);
            self.bar.set_message(self.table());
        }
    }

    fn table(&self) -> String {
        let mut s = format!(
            "{:<13} {:>9} {:>7} {:>10}   prediction RMS error (last 2 s, first 2 s)\n",
            "leg", "b_k", "a", "converged"
        );
        for (name, v) in self.names.iter().zip(self.state.borrow().iter()) {
            let (b_k, a, conv) = v.estimate.unwrap_or((f64::NAN, f64::NAN, false));
            s += &format!(
                "{:<13} {:>9.2} {:>7.3} {:>10}   {:.2} N ({:.2} N)\n",
                name,
                b_k,
                a,
                if conv { "yes" } else { "no" },
                v.rms,
                v.rms_first.unwrap_or(f64::NAN)
            );
        }
        s += &format!(
            "(the medium as simulated: b_k {:.2}, a {:.3}, plus effects the model leaves out)",
            self.truth.b_k, self.truth.a
        );
        s
    }

    fn finish(&self) {
        self.bar.finish_and_clear();
        eprintln!("{}", self.table());
    }
}

impl Publish for LiveView {
    fn wrench(&self, _leg: usize, _msg: WrenchStamped) {}
    fn force(&self, leg: usize, msg: LegForce) {
        if let Some(v) = self.state.borrow_mut().get_mut(leg) {
            v.predicted = Some((msg.drag_n, msg.lift_n));
        }
    }
    fn params(&self, leg: usize, msg: ModelParams) {
        if let Some(v) = self.state.borrow_mut().get_mut(leg) {
            v.estimate = Some((msg.b_k, msg.a, msg.converged));
        }
    }
    fn diagnostics(&self, _msg: DiagnosticArray) {}
}

/// Waits until the robot's clock at `t_s` is due at `speed`.
fn pace(start: Instant, t_s: f64, speed: f64) {
    let due = Duration::from_secs_f64(t_s / speed);
    let now = start.elapsed();
    if due > now {
        std::thread::sleep(due - now);
    }
}

type Estimates = Vec<Option<(f64, f64, bool)>>;

fn run_memory(
    cfg: &NodeConfig,
    params: &crate::config::ParamMap,
    session: &Session,
    t0_ns: i64,
    speed: f64,
    view: &LiveView,
) -> Result<(Estimates, u64)> {
    let (tx, rx) = memory::queue(cfg.queue_depth);
    let producer = {
        let (cfg, session) = (cfg.clone(), session.clone());
        std::thread::spawn(move || {
            let start = Instant::now();
            for k in 0..session.t_s.len() {
                pace(start, session.t_s[k], speed);
                if tx
                    .send(Input::Joints(joint_state(&cfg, &session, k, t0_ns)))
                    .is_err()
                {
                    return;
                }
                for leg in 0..cfg.legs.len() {
                    if tx
                        .send(Input::Wrench(leg, wrench(&cfg, &session, leg, k, t0_ns)))
                        .is_err()
                    {
                        return;
                    }
                }
            }
        })
    };
    let mut joints = 0usize;
    let mut last: Vec<Option<Estimate>> = vec![None; cfg.legs.len()];
    let run = memory::run(cfg.clone(), params, rx, view, |core: &NodeCore, input| {
        if let Input::Joints(_) = input {
            view.after_joints(joints);
            joints += 1;
            if joints.is_multiple_of(250) {
                for (i, e) in last.iter_mut().enumerate() {
                    *e = core.estimate(i);
                }
            }
        }
    })?;
    let _ = producer.join();
    if let Some(e) = &run.recording_error {
        bail!("recording the session failed: {e}");
    }
    if run.recording_dropped > 0 {
        bail!(
            "the recorder dropped {} messages: run with a lower --speed",
            run.recording_dropped
        );
    }
    Ok((
        last.iter()
            .map(|e| e.map(|e| (e.b_k, e.a, e.converged)))
            .collect(),
        run.recorded,
    ))
}

fn run_dds(
    cfg: &NodeConfig,
    params: &crate::config::ParamMap,
    session: &Session,
    t0_ns: i64,
    speed: f64,
    view: &LiveView,
) -> Result<(Estimates, u64)> {
    use crate::node::dds::{NodeSetup, publisher, subscription, tool_node};
    let rt = super::runtime()?;
    let (domain, local) = crate::node::dds::network_from_env()?;
    let setup = NodeSetup {
        params: params.clone(),
        config: cfg.clone(),
        domain_id: domain,
        localhost_only: local,
        latency_report: None,
    };
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    let node_task = rt.spawn(crate::node::dds::run(setup, async {
        let _ = stop_rx.await;
    }));
    // The robot: a publisher of joint states and F/T; and a listener to the node's outputs.
    let mut robot = tool_node("terzaghi_demo_robot")?;
    let js_pub = publisher::<crate::msgs::JointState>(&mut robot, &cfg.joint_states_topic)?;
    let ft_pubs = cfg
        .legs
        .iter()
        .map(|l| publisher::<WrenchStamped>(&mut robot, l.ft_topic.as_deref().unwrap_or("/ft")))
        .collect::<Result<Vec<_>>>()?;
    let force_subs = cfg
        .legs
        .iter()
        .map(|l| subscription::<LegForce>(&mut robot, &format!("/{}/leg_force", l.name)))
        .collect::<Result<Vec<_>>>()?;
    let param_subs = cfg
        .legs
        .iter()
        .map(|l| subscription::<ModelParams>(&mut robot, &format!("/{}/model_params", l.name)))
        .collect::<Result<Vec<_>>>()?;
    let last = rt.block_on(async {
        let spin = tokio::spawn(robot.spinner()?.spin());
        // Wait until the node is discovered (its subscription to the joint states matches).
        let wait = Instant::now();
        while js_pub.get_subscription_count(&robot) == 0 {
            if wait.elapsed() > Duration::from_secs(30) {
                bail!("the node did not appear on DDS within 30 s");
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        tokio::time::sleep(Duration::from_secs(1)).await;
        let start = tokio::time::Instant::now();
        let mut last: Estimates = vec![None; cfg.legs.len()];
        for k in 0..session.t_s.len() {
            tokio::time::sleep_until(start + Duration::from_secs_f64(session.t_s[k] / speed)).await;
            let _ = js_pub.publish(joint_state(cfg, session, k, t0_ns));
            for (leg, p) in ft_pubs.iter().enumerate() {
                let _ = p.publish(wrench(cfg, session, leg, k, t0_ns));
            }
            for (leg, s) in force_subs.iter().enumerate() {
                while let Ok(Some((m, _))) = s.take() {
                    view.force(leg, m);
                }
            }
            for (leg, s) in param_subs.iter().enumerate() {
                while let Ok(Some((m, _))) = s.take() {
                    last[leg] = Some((m.b_k, m.a, m.converged));
                    view.params(leg, m);
                }
            }
            view.after_joints(k);
        }
        tokio::time::sleep(Duration::from_secs(1)).await;
        robot.stop_spinner();
        let _ = tokio::time::timeout(Duration::from_secs(2), spin).await;
        anyhow::Ok(last)
    })?;
    let _ = stop_tx.send(());
    let summary = rt.block_on(node_task)??;
    drop(robot);
    Ok((last, summary.joint_states))
}

struct Summary {
    text: String,
    json: serde_json::Value,
}

#[allow(clippy::too_many_arguments)]
fn summarize(
    cfg: &NodeConfig,
    truth: &Truth,
    online: &Estimates,
    reports: &[serde_json::Value],
    a: &DemoArgs,
    recorded: u64,
    run_s: f64,
    diagnose_s: f64,
) -> Summary {
    let hidden: Vec<&str> = truth.effects.iter().map(|e| e.name()).collect();
    let err = |v: f64, t: f64| 100.0 * (v / t - 1.0);
    let mut text = format!(
        "\nThe walk ran in {run_s:.1} s, the diagnosis in {diagnose_s:.1} s.\n\
         files:\n  session   {} ({} messages: open it in Foxglove, or `terzaghi info` / `terzaghi replay` it)\n  \
         diagnosis {} (one report per leg in its directory)\n  summary   {}\n\n\
         hidden by the simulation: b_k {:.2}, a {:.3}, and the effects {}\n\n\
         {:<13} {:>22} {:>13} {:>24}\n",
        a.out.join("session.mcap").display(),
        recorded,
        a.out.join("diagnosis").join("report.html").display(),
        a.out.join("summary.json").display(),
        truth.b_k,
        truth.a,
        hidden.join(" and "),
        "leg",
        "online b_k, a (error)",
        "verdict",
        "corrected b_k, a (error)"
    );
    let mut legs = Vec::new();
    for (i, leg) in cfg.legs.iter().enumerate() {
        let r = reports.iter().find(|r| r["leg"] == leg.name.as_str());
        let verdict = r
            .and_then(|r| r["verdict"]["effect"].as_str())
            .unwrap_or("-");
        let steps: Vec<String> = r
            .and_then(|r| r["steps"].as_array())
            .map(|s| {
                s.iter()
                    .filter_map(|x| x["effect"].as_str().map(String::from))
                    .collect()
            })
            .unwrap_or_default();
        let corrected = r
            .and_then(|r| r["steps"].as_array())
            .and_then(|s| s.last())
            .map(|s| {
                (
                    s["params"]["b_k"].as_f64().unwrap_or(f64::NAN),
                    s["params"]["a"].as_f64().unwrap_or(f64::NAN),
                )
            });
        let on = online.get(i).copied().flatten();
        let cell = |p: Option<(f64, f64)>| match p {
            Some((b, x)) => format!(
                "{b:.2}, {x:.3} ({:+.0} %, {:+.0} %)",
                err(b, truth.b_k),
                err(x, truth.a)
            ),
            None => "-".into(),
        };
        text += &format!(
            "{:<13} {:>22} {:>13} {:>24}{}\n",
            leg.name,
            cell(on.map(|o| (o.0, o.1))),
            verdict,
            cell(corrected),
            if steps.len() > 1 {
                format!("  (steps: {})", steps.join(", "))
            } else {
                String::new()
            }
        );
        legs.push(serde_json::json!({
            "leg": leg.name,
            "online": on.map(|o| serde_json::json!({"b_k": o.0, "a": o.1, "converged": o.2})),
            "verdict": verdict,
            "steps": steps,
            "corrected": corrected.map(|c| serde_json::json!({"b_k": c.0, "a": c.1})),
        }));
    }
    let named: Vec<&serde_json::Value> = legs
        .iter()
        .filter(|l| hidden.contains(&l["verdict"].as_str().unwrap_or("")))
        .collect();
    text += &format!(
        "\nThe diagnosis named a hidden effect on {} of {} legs. The online estimate takes the hidden effects\n\
         into b_k and a; with the effects the diagnosis found added to the model, the fit of the recording\n\
         recovers the medium's parameters (corrected column).\n",
        named.len(),
        legs.len()
    );
    Summary {
        text,
        json: serde_json::json!({
            "truth": {"b_k": truth.b_k, "a": truth.a, "effects": hidden},
            "legs": legs,
            "files": {
                "session": a.out.join("session.mcap"),
                "diagnosis": a.out.join("diagnosis").join("report.html"),
            },
            "recorded_messages": recorded,
            "run_s": run_s,
            "diagnose_s": diagnose_s,
        }),
    }
}
