//! The demo: a simulated six-legged robot walks on poppy seeds; its joint states and F/T go
//! through the node (in memory, or over DDS), which predicts every leg's forces, learns the
//! medium online and records the session; the summary then sets what the online estimate and
//! the diagnosis of the recording found against what the simulation hid. `terzaghi demo` runs
//! it and draws the live view.

use anyhow::{Result, bail};
use std::path::Path;
use std::time::{Duration, Instant};
use terzaghi::config::{NodeConfig, OutputTopics, ParamMap};
use terzaghi::ident::Estimate;
use terzaghi::msgs::{LegForce, ModelParams, WrenchStamped};
use terzaghi::node::NodeCore;
use terzaghi::node::handle::Publish;
use terzaghi::node::memory::{self, Message};
use terzaghi::sim::robot::{DEMO_RATE_HZ, Session, Truth, demo_truth, joint_state, wrench};

/// What watches the walk: the node's outputs as they are published, and each joint state the
/// node has handled (its index in the session).
pub trait Watch: Publish {
    fn after_joints(&self, k: usize);
}

/// The legs the demo's robot walks on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Legs {
    /// Flat plates, the improved Terzaghi model (`launch_configs/rhex.yaml`).
    #[default]
    Plate,
    /// RHex's C-legs, half circles predicted by RFT whose scale the node learns online.
    C,
}

/// Waits until the robot's clock at `t_s` is due at `speed`.
fn pace(start: Instant, t_s: f64, speed: f64) {
    let due = Duration::from_secs_f64(t_s / speed);
    let now = start.elapsed();
    if due > now {
        std::thread::sleep(due - now);
    }
}

/// Per leg: the latest online estimate (b_k, a, converged) the node published; for a curved
/// leg, (RFT's scale, a, converged).
pub type Estimates = Vec<Option<(f64, f64, bool)>>;

fn run_memory(
    cfg: &NodeConfig,
    params: &ParamMap,
    session: &Session,
    t0_ns: i64,
    speed: f64,
    view: &impl Watch,
) -> Result<(Estimates, u64)> {
    let (tx, rx) = memory::queue(cfg.queue_depth);
    let producer = {
        let (cfg, session) = (cfg.clone(), session.clone());
        std::thread::spawn(move || {
            let start = Instant::now();
            for k in 0..session.t_s.len() {
                pace(start, session.t_s[k], speed);
                if tx
                    .send(Message::Joints(joint_state(&cfg, &session, k, t0_ns)))
                    .is_err()
                {
                    return;
                }
                for leg in 0..cfg.legs.len() {
                    if tx
                        .send(Message::Wrench(leg, wrench(&cfg, &session, leg, k, t0_ns)))
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
        if let Message::Joints(_) = input {
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
        return Err(anyhow::Error::new(terzaghi::session::Failure(format!(
            "recording the session failed: {e}"
        ))));
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
    params: &ParamMap,
    session: &Session,
    t0_ns: i64,
    speed: f64,
    view: &impl Watch,
) -> Result<(Estimates, u64)> {
    use terzaghi::node::dds::{NodeSetup, publisher, subscription, tool_node};
    let rt = terzaghi::node::dds::runtime()?;
    let (domain, local) = terzaghi::node::dds::network_from_env()?;
    let setup = NodeSetup {
        params: params.clone(),
        config: cfg.clone(),
        domain_id: domain,
        localhost_only: local,
        log: Default::default(),
        foxglove: None,
    };
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    let node_task = rt.spawn(terzaghi::node::dds::run(setup, async {
        let _ = stop_rx.await;
    }));
    // The robot: a publisher of joint states and F/T; and a listener to the node's outputs.
    let mut robot = tool_node("terzaghi_demo_robot")?;
    let js_pub = publisher::<terzaghi::msgs::JointState>(&mut robot, &cfg.joint_states_topic)?;
    let ft_pubs = cfg
        .legs
        .iter()
        .map(|l| publisher::<WrenchStamped>(&mut robot, l.ft_topic.as_deref().unwrap_or("/ft")))
        .collect::<Result<Vec<_>>>()?;
    let topics = OutputTopics::of(cfg, &cfg.remaps);
    let force_subs = topics
        .legs
        .iter()
        .map(|l| subscription::<LegForce>(&mut robot, &l.force))
        .collect::<Result<Vec<_>>>()?;
    let param_subs = topics
        .legs
        .iter()
        .map(|l| subscription::<ModelParams>(&mut robot, &l.params))
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
                    // A curved leg's estimate is RFT's scale.
                    let first = if cfg.legs[leg].profile.is_some() {
                        m.rft_scale
                    } else {
                        m.b_k
                    };
                    last[leg] = Some((first, m.a, m.converged));
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

/// The demo's summary: a table for people and the same as JSON.
pub struct Summary {
    pub text: String,
    pub json: serde_json::Value,
}

/// What the online estimate and the diagnosis found against what the simulation hid.
#[allow(clippy::too_many_arguments)]
pub fn summarize(
    cfg: &NodeConfig,
    truth: &Truth,
    online: &Estimates,
    reports: &[serde_json::Value],
    out: &Path,
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
        out.join("session.mcap").display(),
        recorded,
        out.join("diagnosis").join("report.html").display(),
        out.join("summary.json").display(),
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
        // The values corrected.yaml holds (the corrected model refitted on every sample), not
        // the search's last step (fitted on the thinned points it searched on).
        let corrected = r
            .filter(|r| r["steps"].as_array().is_some_and(|s| !s.is_empty()))
            .map(|r| {
                (
                    r["corrected_model"]["b_k"].as_f64().unwrap_or(f64::NAN),
                    r["corrected_model"]["a"].as_f64().unwrap_or(f64::NAN),
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
                "session": out.join("session.mcap"),
                "diagnosis": out.join("diagnosis").join("report.html"),
            },
            "recorded_messages": recorded,
            "run_s": run_s,
            "diagnose_s": diagnose_s,
        }),
    }
}

/// A demo walk, simulated and ready to run through the node.
pub struct Demo {
    pub params: ParamMap,
    /// The shipped six-legged robot, recording to `<out>/session.mcap`.
    pub cfg: NodeConfig,
    pub truth: Truth,
    pub session: Session,
    pub out: std::path::PathBuf,
    pub legs: Legs,
}

/// What the walk through the node gave.
pub struct Walked {
    pub estimates: Estimates,
    /// Messages in the recording.
    pub recorded: u64,
    pub run_s: f64,
}

impl Demo {
    /// Re-runs the recording through the node as it ran and with the corrections the diagnosis
    /// wrote (`corrected`), and adds each leg's prediction error of both to the summary.
    fn rerun(&self, corrected: &Path, summary: &mut Summary) -> Result<()> {
        use terzaghi::session::reevaluate::{ReevaluateOptions, RowErrors, reevaluate_file};
        let session = self.out.join("session.mcap");
        let as_ran = reevaluate_file(&session, ReevaluateOptions::default(), |_| {})?;
        let with = reevaluate_file(
            &session,
            ReevaluateOptions {
                params_file: Some(corrected.to_path_buf()),
                ..Default::default()
            },
            |_| {},
        )?;
        summary.text += &format!(
            "\nThe recording re-run through the node with the corrections the diagnosis wrote\n\
             (terzaghi replay {} --reevaluate --params-file {}):\n\
             {:<13} {:>26} {:>24}\n",
            session.display(),
            corrected.display(),
            "leg",
            "as it ran (online b_k, a)",
            "with the corrections"
        );
        let mut legs = Vec::new();
        for (i, leg) in self.cfg.legs.iter().enumerate() {
            let (Some(b), Some(c)) = (as_ran.summary.errors.get(i), with.summary.errors.get(i))
            else {
                continue;
            };
            if b.samples() == 0 || c.samples() == 0 {
                continue;
            }
            let (before, after) = (
                RowErrors::rmse_n(&b.expected),
                RowErrors::rmse_n(&c.expected),
            );
            summary.text += &format!("{:<13} {:>24.3} N {:>22.3} N\n", leg.name, before, after);
            legs.push(serde_json::json!({
                "leg": leg.name, "rmse_as_ran_n": before, "rmse_corrected_n": after,
                "samples": c.samples(),
            }));
        }
        summary.text += "(in sample: the corrections were fitted on this recording; `terzaghi-eval diagnose-eval --closed-loop`\n\
             measures them on strokes they were not fitted on)\n";
        summary.json["rerun"] = serde_json::json!({
            "params_file": corrected,
            "legs": legs,
        });
        Ok(())
    }

    /// A walk on C-legs: per leg, the scale of RFT the node learnt online against the scale
    /// that fits the whole walk best (least squares of the measured forces on RFT's from the
    /// node's coefficients), and the recording re-run through the node with nothing fitted
    /// (`-p use_identified:=false`: RFT from the coefficients alone) and as it ran (the scale
    /// learnt as the strokes came), RMSE and R^2 of drag and lift.
    pub fn summarize_curved(&self, walked: &Walked) -> Result<Summary> {
        use terzaghi::config::ParamValue;
        use terzaghi::session::reevaluate::{ReevaluateOptions, reevaluate_file};
        let started = Instant::now();
        let session = self.out.join("session.mcap");
        let as_ran = reevaluate_file(&session, ReevaluateOptions::default(), |_| {})?;
        let bare = reevaluate_file(
            &session,
            ReevaluateOptions {
                params: vec![("use_identified".into(), ParamValue::Bool(false))],
                ..Default::default()
            },
            |_| {},
        )?;
        let rerun_s = started.elapsed().as_secs_f64();
        let mut text = format!(
            "\nThe walk ran in {:.1} s, its re-evaluation in {rerun_s:.1} s.\n\
             files:\n  session   {} ({} messages: open it in Foxglove, or `terzaghi info` / `terzaghi replay` it)\n  \
             summary   {}\n\n\
             hidden by the simulation: the medium is {:.2} times RFT over the measured grid of poppy seeds\n\
             (poppy_lp_grid); the node predicts from Li et al.'s fitted coefficients (poppy_lp) and learns\n\
             one scale online. Beside it, the single scale that fits the whole walk best (least squares,\n\
             offline) and its error: the bound on what one scale can do.\n\n\
             {:<13} {:>12} {:>18} {:>26} {:>26}\n",
            walked.run_s,
            session.display(),
            walked.recorded,
            self.out.join("summary.json").display(),
            self.truth.rft_scale,
            "leg",
            "last online",
            "best scale, RMSE",
            "nothing fitted: RMSE, R^2",
            "as it ran: RMSE, R^2",
        );
        let mut legs = Vec::new();
        for (i, leg) in self.cfg.legs.iter().enumerate() {
            let (Some(b), Some(r)) = (bare.summary.errors.get(i), as_ran.summary.errors.get(i))
            else {
                continue;
            };
            if b.samples() == 0 || r.samples() == 0 {
                continue;
            }
            let scale = walked.estimates.get(i).copied().flatten();
            let best = self.best_rft_scale(i);
            let fits = |e: &terzaghi::session::reevaluate::RowErrors| {
                let (d, l) = (e.expected[0].fit(), e.expected[1].fit());
                (
                    terzaghi::session::reevaluate::RowErrors::rmse_n(&e.expected),
                    d.r2,
                    l.r2,
                )
            };
            let (fb, fr) = (fits(b), fits(r));
            let cell = |f: (f64, f64, f64)| format!("{:.3} N, {:.3}/{:.3}", f.0, f.1, f.2);
            text += &format!(
                "{:<13} {:>12} {:>18} {:>26} {:>26}\n",
                leg.name,
                scale.map_or("-".into(), |s| format!("{:.3}", s.0)),
                format!("{:.3}, {:.3} N", best.0, best.1),
                cell(fb),
                cell(fr),
            );
            legs.push(serde_json::json!({
                "leg": leg.name,
                "online_rft_scale": scale.map(|s| s.0),
                "best_rft_scale": best.0,
                "best_rft_scale_rmse_n": best.1,
                "converged": scale.map(|s| s.2),
                "nothing_fitted": {"rmse_n": fb.0, "r2_drag": fb.1, "r2_lift": fb.2},
                "as_ran": {"rmse_n": fr.0, "r2_drag": fr.1, "r2_lift": fr.2},
                "samples": r.samples(),
            }));
        }
        text += &format!(
            "(R^2 drag/lift over every sample, in and out of the sand; re-run with\n \
             terzaghi replay {} --reevaluate [-p use_identified:=false] -o rows.csv.\n \
             Where RFT's shape of the force over the stroke is off, the online scale swings within a\n \
             stroke, so its last value says less than the error as it ran)\n",
            session.display()
        );
        Ok(Summary {
            text,
            json: serde_json::json!({
                "legs_shape": "c_leg",
                "truth": {"rft_scale": self.truth.rft_scale},
                "legs": legs,
                "files": {"session": session},
                "recorded_messages": walked.recorded,
                "run_s": walked.run_s,
                "rerun_s": rerun_s,
            }),
        })
    }

    /// The single scale of leg `i`'s RFT (the node's coefficients) that fits its measured
    /// forces over the whole walk best, `sum(p m) / sum(p p)` over drag and lift, and the RMSE
    /// (N) of drag and lift with it. NaN when the leg never entered the medium.
    fn best_rft_scale(&self, i: usize) -> (f64, f64) {
        let Ok(model) = self.cfg.leg_model(i, self.cfg.legs[i].width, None) else {
            return (f64::NAN, f64::NAN);
        };
        let pairs: Vec<([f64; 2], [f64; 2])> = self
            .session
            .legs
            .get(i)
            .into_iter()
            .flatten()
            .filter_map(|s| {
                let p = model.predict(s.beta_rad).ok()?;
                Some(([p.drag_n, p.lift_n], [s.drag_n, s.lift_n]))
            })
            .collect();
        let (mut pm, mut pp) = (0.0, 0.0);
        for (p, m) in &pairs {
            pm += p[0] * m[0] + p[1] * m[1];
            pp += p[0] * p[0] + p[1] * p[1];
        }
        if pp <= 0.0 {
            return (f64::NAN, f64::NAN);
        }
        let s = pm / pp;
        let sse: f64 = pairs
            .iter()
            .map(|(p, m)| (s * p[0] - m[0]).powi(2) + (s * p[1] - m[1]).powi(2))
            .sum();
        (s, (sse / (2 * pairs.len()) as f64).sqrt())
    }

    /// Simulates `seconds` of walking (seed `seed`) on `legs` into the directory `out`
    /// (created).
    pub fn new(seconds: f64, seed: u64, out: &Path, legs: Legs) -> Result<Demo> {
        if !(seconds.is_finite() && seconds > 0.0) {
            bail!("demo walk of {seconds} s: must be a positive number of seconds");
        }
        std::fs::create_dir_all(out).map_err(|e| {
            anyhow::Error::new(e).context(terzaghi::session::Failure(format!(
                "cannot create {}",
                out.display()
            )))
        })?;
        let (params, mut cfg) = match legs {
            Legs::Plate => terzaghi::sim::robot::rhex()?,
            Legs::C => terzaghi::sim::robot::rhex_c_legs()?,
        };
        cfg.record = Some(out.join("session.mcap"));
        let truth = demo_truth();
        let gait = terzaghi::sim::robot::Gait {
            seconds,
            rate_hz: DEMO_RATE_HZ,
            mean_speed_rad_s: 4.0,
            seed,
        };
        let session = terzaghi::sim::robot::simulate(&cfg, &truth, &gait);
        Ok(Demo {
            params,
            cfg,
            truth,
            session,
            out: out.to_path_buf(),
            legs,
        })
    }

    /// Plays the walk through the node at `speed` times the robot's clock, over DDS or in
    /// memory, with `view` watching.
    pub fn walk(&self, dds: bool, speed: f64, view: &impl Watch) -> Result<Walked> {
        if !(speed.is_finite() && speed > 0.0) {
            bail!("demo speed {speed}: must be a positive number");
        }
        let t0_ns = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_nanos() as i64)
            .unwrap_or(0);
        let started = Instant::now();
        let (estimates, recorded) = if dds {
            run_dds(&self.cfg, &self.params, &self.session, t0_ns, speed, view)?
        } else {
            run_memory(&self.cfg, &self.params, &self.session, t0_ns, speed, view)?
        };
        let run_s = started.elapsed().as_secs_f64();
        // What the recording holds, from its summary (without reading the whole file).
        let session_path = self.out.join("session.mcap");
        let recorded = terzaghi::record::read::IndexedFile::open(&session_path)?
            .map_or(recorded, |f| f.head().messages);
        Ok(Walked {
            estimates,
            recorded,
            run_s,
        })
    }

    /// Diagnoses the recording into `<out>/diagnosis` and writes `<out>/summary.json`. The
    /// diagnosis's terms are the flat plate's: a walk on C-legs is re-evaluated instead, with
    /// RFT's scale as the node learnt it and with nothing fitted ([`Demo::summarize_curved`]).
    pub fn diagnose(&self, walked: &Walked) -> Result<Summary> {
        use terzaghi::session::diagnose::{DiagnoseFileOptions, diagnose_file, write_reports};
        if self.legs == Legs::C {
            let summary = self.summarize_curved(walked)?;
            terzaghi::session::files::write_text(
                &self.out.join("summary.json"),
                &(serde_json::to_string_pretty(&summary.json)? + "\n"),
            )?;
            return Ok(summary);
        }
        let started = Instant::now();
        let diagnosed = diagnose_file(
            &self.out.join("session.mcap"),
            &DiagnoseFileOptions::default(),
        )?;
        let done = write_reports(&diagnosed, &self.out.join("diagnosis"))?;
        if !done.failed.is_empty() {
            bail!("the diagnosis failed: {}", done.failed.join("; "));
        }
        let reports: Vec<serde_json::Value> = done.reports.iter().map(|(_, r)| r.clone()).collect();
        let mut summary = summarize(
            &self.cfg,
            &self.truth,
            &walked.estimates,
            &reports,
            &self.out,
            walked.recorded,
            walked.run_s,
            started.elapsed().as_secs_f64(),
        );
        if let Some(corrected) = &done.corrected {
            self.rerun(corrected, &mut summary)?;
        }
        terzaghi::session::files::write_text(
            &self.out.join("summary.json"),
            &(serde_json::to_string_pretty(&summary.json)? + "\n"),
        )?;
        Ok(summary)
    }
}
