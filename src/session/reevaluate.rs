//! Offline re-evaluation of a session: the recorded joint states and F/T samples go through the
//! node's own core (model and estimator), as fast as possible, with the recorded parameters or
//! new ones; predictions come out next to the measurements.

use super::Opened;
use super::csv_rows::{CSV_HEADER, CsvRows};
use super::files::{refuse_existing_recording, write_atomically};
use super::inputs::{Read, input_count, scan_inputs, session_config_with};
use crate::config::{NodeConfig, ParamMap, RosArgs, load_params};
use crate::diagnose::Turns;
use crate::ident::{Estimate, FitSums, Sample};
use crate::model::{HipMotion, Regime};
use crate::msgs::{Gap, JointState, LegForce, ModelParams, Time, WrenchStamped};
use crate::node::core::{GapJob, Input, LegOutput, NodeCore, Outputs};
use crate::record::read::{MessageView, Scan, Source};
use crate::record::{OfferedQos, RecordError, RecordOptions, SessionWriter};
use anyhow::{Context as _, Result, anyhow, bail};
use std::path::{Path, PathBuf};

/// One prediction, with the measurement it is next to (if the leg has F/T).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Row {
    /// Time of the JointState (log clock, s).
    pub t_s: f64,
    /// The leg, by index.
    pub leg: usize,
    /// The attack angle (rad).
    pub beta_rad: f64,
    /// The regime of the prediction.
    pub regime: Regime,
    /// The measured drag next to it (N), if the leg has F/T.
    pub measured_drag_n: Option<f64>,
    /// The measured lift (N), if the leg has F/T.
    pub measured_lift_n: Option<f64>,
    /// The predicted drag (N).
    pub predicted_drag_n: f64,
    /// The predicted lift (N).
    pub predicted_lift_n: f64,
    /// The predicted hip torque (N m).
    pub predicted_hip_torque_nm: f64,
    /// The `b_k` predicted with.
    pub b_k: f64,
    /// The `a` predicted with.
    pub a: f64,
    /// Whether `b_k`, `a` (or RFT's scale) were learnt.
    pub identified: bool,
    /// The bare improved model (no corrections), and what the F/T sensor is expected to read
    /// (the prediction through the sensor's corrections); both equal the prediction for a leg
    /// without corrections.
    pub bare_drag_n: f64,
    /// The bare model's lift (N).
    pub bare_lift_n: f64,
    /// What the sensor is expected to read, drag (N).
    pub expected_reading_drag_n: f64,
    /// What the sensor is expected to read, lift (N).
    pub expected_reading_lift_n: f64,
    /// The predicted side force (N; `LegForce`'s `side_n`, along the hip frame's y): zero for a
    /// leg moving in its plane.
    pub predicted_side_n: f64,
    /// The predicted moment about the heading at the hip (N m).
    pub predicted_roll_moment_nm: f64,
    /// The predicted moment about the vertical at the hip (N m).
    pub predicted_yaw_moment_nm: f64,
}

/// How far one leg's predictions lie from its measurements, over the rows that have one: the
/// bare model's and the expected F/T reading's (the corrected model's, for a leg with
/// corrections), drag and lift each.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RowErrors {
    /// Errors of the bare model, drag and lift.
    pub bare: [FitSums; 2],
    /// Errors of the expected reading, drag and lift.
    pub expected: [FitSums; 2],
    /// Rows of a sinkage leg held, unloaded or rising ([`Regime::Unloading`]), left out of the
    /// sums: the rig, not the medium, sets their force.
    pub unloading_rows: u64,
}

impl RowErrors {
    /// Adds row `r`, where it has a measurement.
    pub fn add(&mut self, r: &Row) {
        let (Some(d), Some(l)) = (r.measured_drag_n, r.measured_lift_n) else {
            return;
        };
        self.bare[0].add(r.bare_drag_n, d);
        self.bare[1].add(r.bare_lift_n, l);
        self.expected[0].add(r.expected_reading_drag_n, d);
        self.expected[1].add(r.expected_reading_lift_n, l);
    }

    /// Rows with a measurement.
    pub fn samples(&self) -> u64 {
        self.bare[0].samples()
    }

    /// RMSE over drag and lift together (N) of `sums` (`bare` or `expected`).
    pub fn rmse_n(sums: &[FitSums; 2]) -> f64 {
        let (d, l) = (sums[0].fit().rmse, sums[1].fit().rmse);
        (0.5 * (d * d + l * l)).sqrt()
    }
}

/// What the re-evaluation produces besides rows, for an MCAP output.
pub enum Output<'a> {
    /// A recorded input, as it was.
    Input(&'a Scan, &'a MessageView<'a>),
    /// A leg's prediction, at a log time (ns).
    Prediction(u64, &'a LegOutput),
    /// A leg's model parameters (log time in ns, the leg's index).
    Params(u64, usize, &'a ModelParams),
    /// The node's own diagnosis of a leg's recent strokes (run in line here, in the background
    /// in the node).
    Gap(u64, usize, &'a Gap),
}

/// What a re-evaluation did.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct Summary {
    /// JointStates read.
    pub joint_states: u64,
    /// F/T samples read.
    pub ft_samples: u64,
    /// Rows predicted.
    pub rows: u64,
    /// Topics of the file that the configuration does not use.
    pub skipped_topics: Vec<String>,
    /// Messages that did not decode (counted, skipped).
    pub undecodable: u64,
    /// Samples of a CSV log without a usable time (counted, skipped).
    pub skipped_samples: u64,
    /// Whether the whole input was read.
    pub complete: bool,
    /// Why it stopped early, if it did.
    pub stopped: Option<String>,
    /// Final estimate per leg with F/T.
    pub estimates: Vec<Option<Estimate>>,
    /// Final surface estimate per leg that learns it (`estimator.fit_surface`).
    pub surfaces: Vec<Option<crate::ident::SurfaceEstimate>>,
    /// Per leg, how far its predictions lie from its measurements.
    #[serde(skip)]
    pub errors: Vec<RowErrors>,
    /// Per leg, the same stroke by stroke (full turns, numbered as the diagnosis numbers them:
    /// [`Turns`]): where a session's error lies.
    #[serde(skip)]
    pub stroke_errors: Vec<Vec<RowErrors>>,
}

impl Summary {
    /// The counts of reading the inputs, for `legs` legs (rows and estimates still to come).
    fn of_read(r: Read, legs: usize) -> Summary {
        Summary {
            joint_states: r.joint_states,
            ft_samples: r.ft_samples,
            skipped_topics: r.skipped_topics,
            undecodable: r.undecodable,
            complete: r.complete,
            stopped: r.stopped,
            estimates: vec![None; legs],
            ..Default::default()
        }
    }
}

/// Runs the session in `bytes` through a node with `cfg`. `on_row` gets every prediction next
/// to its measurement; `on_output` gets inputs and outputs for an MCAP copy.
pub fn reevaluate<'a>(
    source: impl Into<Source<'a>>,
    cfg: NodeConfig,
    on_row: impl FnMut(&Row),
    on_output: impl FnMut(Output),
) -> Result<Summary, RecordError> {
    run_core(
        source.into(),
        NodeCore::new(cfg).keep_row_predictions(),
        on_row,
        on_output,
    )
}

/// [`reevaluate`] for rows only: the node's own diagnoses of its legs' gaps (`gap_check`),
/// which a session re-evaluated into a new recording carries, are not run.
pub fn reevaluate_rows<'a>(
    source: impl Into<Source<'a>>,
    mut cfg: NodeConfig,
    on_row: impl FnMut(&Row),
    on_output: impl FnMut(Output),
) -> Result<Summary, RecordError> {
    cfg.gap_check.every_strokes = 0;
    run_core(
        source.into(),
        NodeCore::new(cfg).keep_row_predictions(),
        on_row,
        on_output,
    )
}

/// The node core run offline: inputs in, rows and output messages out.
struct Driver {
    core: NodeCore,
    has_ft: Vec<bool>,
    rows: u64,
    errors: Vec<RowErrors>,
    turns: Vec<Turns>,
    stroke_errors: Vec<Vec<RowErrors>>,
    outputs: Outputs,
    jobs: Vec<GapJob>,
}

impl Driver {
    fn new(core: NodeCore) -> Driver {
        Driver {
            has_ft: core
                .config()
                .legs
                .iter()
                .map(|l| l.ft_topic.is_some())
                .collect(),
            errors: vec![RowErrors::default(); core.legs()],
            turns: vec![Turns::default(); core.legs()],
            stroke_errors: vec![Vec::new(); core.legs()],
            core,
            rows: 0,
            outputs: Outputs::default(),
            jobs: Vec::new(),
        }
    }

    /// One input, received at `log_ns`: `on_row` gets every prediction next to its measurement,
    /// `on_output` every prediction and parameter message.
    fn input(
        &mut self,
        input: Input,
        log_ns: u64,
        on_row: &mut impl FnMut(&Row),
        on_output: &mut impl FnMut(Output),
    ) {
        let core = &mut self.core;
        self.outputs.clear();
        core.handle(input, &mut self.outputs);
        // A leg with F/T has its rows at its matched samples, below; the others at each angle.
        for o in &self.outputs.legs {
            on_output(Output::Prediction(log_ns, o));
            if !self.has_ft[o.leg] {
                let f = &o.force;
                self.rows += 1;
                on_row(&Row {
                    t_s: f.header.stamp.to_secs(),
                    leg: o.leg,
                    beta_rad: f.attack_angle_rad,
                    regime: regime_of(f),
                    measured_drag_n: None,
                    measured_lift_n: None,
                    predicted_drag_n: f.drag_n,
                    predicted_lift_n: f.lift_n,
                    predicted_hip_torque_nm: f.hip_torque_nm,
                    b_k: f.b_k,
                    a: f.a,
                    identified: f.identified,
                    bare_drag_n: f.bare_drag_n,
                    bare_lift_n: f.bare_lift_n,
                    expected_reading_drag_n: f.sensor_drag_n,
                    expected_reading_lift_n: f.sensor_lift_n,
                    predicted_side_n: f.side_n,
                    predicted_roll_moment_nm: f.roll_moment_nm,
                    predicted_yaw_moment_nm: f.yaw_moment_nm,
                });
            }
        }
        for (leg, p) in &self.outputs.params {
            on_output(Output::Params(log_ns, *leg, p));
        }
        core.take_gap_jobs(&mut self.jobs);
        for job in self.jobs.drain(..) {
            let result = job.run();
            let msg = core.on_gap_report(&job, &result);
            on_output(Output::Gap(log_ns, job.leg, &msg));
        }
        for m in &self.outputs.matches {
            // What the leg predicted before it learnt from the sample.
            let (leg, mt) = (m.leg, m.matched);
            let Some((r, (b_k, a, identified))) = m.before else {
                continue;
            };
            let p = r.medium;
            self.rows += 1;
            let row = Row {
                t_s: mt.t_ns as f64 * 1e-9,
                leg,
                beta_rad: mt.beta_rad,
                regime: p.regime,
                measured_drag_n: Some(mt.drag_n),
                measured_lift_n: Some(mt.lift_n),
                predicted_drag_n: p.drag_n,
                predicted_lift_n: p.lift_n,
                predicted_hip_torque_nm: p.hip_torque_nm,
                b_k,
                a,
                identified,
                bare_drag_n: r.bare_n[0],
                bare_lift_n: r.bare_n[1],
                expected_reading_drag_n: r.sensor_n[0],
                expected_reading_lift_n: r.sensor_n[1],
                predicted_side_n: p.side_n,
                predicted_roll_moment_nm: p.roll_moment_nm,
                predicted_yaw_moment_nm: p.yaw_moment_nm,
            };
            // A plate held or unloaded bears what the rig gives it: its rows are not the law's
            // to answer for, and are counted apart.
            if row.regime == Regime::Unloading {
                self.errors[leg].unloading_rows += 1;
                on_row(&row);
                continue;
            }
            self.errors[leg].add(&row);
            let (_, k) = self.turns[leg].push(row.beta_rad);
            let per = &mut self.stroke_errors[leg];
            if per.len() <= k {
                per.resize(k + 1, RowErrors::default());
            }
            per[k].add(&row);
            on_row(&row);
        }
    }

    /// The summary's rows and final estimates.
    fn finish(self, mut sum: Summary) -> Summary {
        sum.rows = self.rows;
        sum.errors = self.errors;
        sum.stroke_errors = self.stroke_errors;
        sum.estimates = (0..self.core.legs())
            .map(|i| self.core.estimate(i))
            .collect();
        sum.surfaces = (0..self.core.legs())
            .map(|i| self.core.surface_estimate(i))
            .collect();
        sum
    }
}

/// Runs the inputs of `source` through `core`: `on_row` gets every prediction next to its
/// measurement, `on_output` every input, prediction and parameter message.
fn run_core(
    source: Source,
    core: NodeCore,
    mut on_row: impl FnMut(&Row),
    mut on_output: impl FnMut(Output),
) -> Result<Summary, RecordError> {
    let cfg = core.config().clone();
    let mut driver = Driver::new(core);
    let read = scan_inputs(source, &cfg, |input, scan, m| {
        on_output(Output::Input(scan, m));
        driver.input(input, m.log_time_ns, &mut on_row, &mut on_output);
    })?;
    Ok(driver.finish(Summary::of_read(read, cfg.legs.len())))
}

/// Runs the samples of one leg (a CSV log's: time, attack angle, measured drag and lift in the
/// hip frame) through a node with `cfg`, as the joint states and F/T samples they stand for: a
/// JointState of the leg's joint and a wrench in its hip frame at each sample's time. `leg` is
/// the leg of `cfg` they belong to (given an F/T topic if it has none). Samples without a
/// finite time, angle or force are counted as the node counts such messages.
pub fn reevaluate_samples(
    samples: &[Sample],
    cfg: NodeConfig,
    leg: usize,
    on_row: impl FnMut(&Row),
) -> Result<Summary, RecordError> {
    reevaluate_samples_with(samples, cfg, leg, on_row, |_| {})
}

/// [`reevaluate_samples`], with the node's other outputs (its predictions and parameters; its
/// own diagnoses of the leg's gap are not run).
pub fn reevaluate_samples_with(
    samples: &[Sample],
    cfg: NodeConfig,
    leg: usize,
    on_row: impl FnMut(&Row),
    on_output: impl FnMut(Output),
) -> Result<Summary, RecordError> {
    reevaluate_log(samples, None, cfg, leg, on_row, on_output)
}

/// [`reevaluate_samples_with`] for a log whose hip moves: `hips[i]` is the hip at `samples[i]`
/// (its height negative below the surface), handed to the node before that sample's angle.
pub fn reevaluate_log(
    samples: &[Sample],
    hips: Option<&[HipMotion]>,
    mut cfg: NodeConfig,
    leg: usize,
    mut on_row: impl FnMut(&Row),
    mut on_output: impl FnMut(Output),
) -> Result<Summary, RecordError> {
    let Some(lc) = cfg.legs.get_mut(leg) else {
        return Ok(Summary::default());
    };
    if lc.ft_topic.is_none() {
        lc.ft_topic = Some(format!("/{}/ft", lc.name));
    }
    lc.ft_frame = crate::config::FtFrame::Hip;
    let (joint, direction, offset) = (lc.joint.clone(), lc.direction, lc.angle_offset_rad);
    // A leg's rows are the node's predictions; its own diagnosis of its gap is not part of
    // them (and would run in line here, every few strokes).
    cfg.gap_check.every_strokes = 0;
    let mut driver = Driver::new(NodeCore::new(cfg).keep_row_predictions());
    let mut js = JointState {
        name: vec![joint],
        position: vec![0.0],
        ..Default::default()
    };
    let mut w = WrenchStamped::default();
    let mut sum = Summary {
        estimates: vec![None; driver.core.legs()],
        complete: true,
        ..Default::default()
    };
    for (k, s) in samples.iter().enumerate() {
        let stamp = s
            .t_s
            .filter(|t| t.is_finite() && *t >= 0.0)
            .and_then(|t| Time::from_nanos((t * 1e9).round() as i64));
        let Some(stamp) = stamp else {
            sum.skipped_samples += 1;
            continue;
        };
        let log_ns = stamp.to_nanos().max(0) as u64;
        if let Some(h) = hips.and_then(|h| h.get(k)) {
            driver.input(
                Input::Hip(leg, stamp.to_nanos(), *h),
                log_ns,
                &mut on_row,
                &mut on_output,
            );
        }
        js.header.stamp = stamp;
        js.position[0] = direction * s.beta_rad + offset;
        sum.joint_states += 1;
        driver.input(Input::Joints(&js), log_ns, &mut on_row, &mut on_output);
        w.header.stamp = stamp;
        w.wrench.force.x = -s.drag_n;
        w.wrench.force.z = s.lift_n;
        sum.ft_samples += 1;
        driver.input(Input::Wrench(leg, &w), log_ns, &mut on_row, &mut on_output);
    }
    Ok(driver.finish(sum))
}

/// The hip of each row of a log: its columns, with the vertical velocity (where the log does
/// not give it) from the height's own timeline, a central difference over the rows' times.
/// Rows without a finite time or height keep a NaN the node counts and skips.
pub fn hip_motions(samples: &[Sample], rows: &[crate::dataset::HipRow]) -> Vec<HipMotion> {
    let t = |i: usize| samples.get(i).and_then(|s| s.t_s).unwrap_or(f64::NAN);
    let n = rows.len().min(samples.len());
    (0..n)
        .map(|i| {
            let r = rows[i];
            let up_m_s = r.vz_m_s.unwrap_or_else(|| {
                let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
                let dt = t(b) - t(a);
                if dt > 0.0 {
                    (rows[b].height_m - rows[a].height_m) / dt
                } else {
                    0.0
                }
            });
            HipMotion {
                height_m: r.height_m,
                pitch_rad: r.pitch_rad.unwrap_or(0.0),
                forward_m_s: r.vx_m_s.unwrap_or(0.0),
                lateral_m_s: r.vy_m_s.unwrap_or(0.0),
                up_m_s,
                ..HipMotion::default()
            }
        })
        .collect()
}

/// The regime of a leg force message (an unknown code as extraction, the last regime).
fn regime_of(f: &LegForce) -> Regime {
    Regime::from_code(f.regime).unwrap_or(Regime::Extraction)
}

/// How to re-evaluate a recording.
#[derive(Default)]
pub struct ReevaluateOptions {
    /// Node parameters (a ROS 2 parameter file) to use instead of the recorded ones.
    pub params_file: Option<PathBuf>,
    /// Parameters set over those (`-p name:=value`), in order.
    pub params: Vec<(String, crate::config::ParamValue)>,
    /// Called now and then with the inputs (joint states and F/T) read so far and in all.
    pub progress: Option<Box<dyn FnMut(u64, u64)>>,
}

/// What a re-evaluation of a file did.
#[derive(Debug, Clone)]
pub struct Reevaluation {
    /// What it did.
    pub summary: Summary,
    /// The configuration it ran with.
    pub config: NodeConfig,
    /// The topics of the file.
    pub topics: Vec<String>,
}

impl Reevaluation {
    /// An error naming the topics when no JointState of the configuration was in the file
    /// (the usual cause: another `joint_states_topic`).
    pub fn check_inputs_found(&self, file: &Path) -> Result<()> {
        if self.summary.joint_states == 0 {
            bail!(
                "{}: no JointState on {} (topics: {}); check the parameters (joint_states_topic)",
                file.display(),
                self.config.joint_states_topic,
                self.topics.join(", ")
            );
        }
        Ok(())
    }
}

/// A log opened for re-evaluation, with its configuration.
struct Prepared {
    log: Log,
    cfg: NodeConfig,
    params: ParamMap,
    inputs: u64,
}

/// What a re-evaluated log is.
enum Log {
    Mcap(Box<Opened>),
    /// A CSV log of one leg (`t_s,beta_rad,drag_n,lift_n`, and its hip where the log gives
    /// it), the leg of the configuration it belongs to.
    Csv(Vec<Sample>, Option<Vec<HipMotion>>, usize),
}

fn prepare(file: &Path, opts: &ReevaluateOptions) -> Result<Prepared> {
    let Some(opened) = Opened::mcap(file)? else {
        return prepare_csv(file, opts);
    };
    let (cfg, params) = session_config_with(
        opts.params_file.as_deref(),
        &opts.params,
        opened.head(),
        file,
    )?;
    // Progress counts the inputs read (joint states and F/T), which is what takes the time.
    let inputs = input_count(&cfg, opened.head());
    Ok(Prepared {
        log: Log::Mcap(Box::new(opened)),
        cfg,
        params,
        inputs,
    })
}

/// A CSV log of one leg with the parameters of `opts.params_file` (a CSV log carries none): the
/// leg is the configuration's only one, or the one named as the file.
fn prepare_csv(file: &Path, opts: &ReevaluateOptions) -> Result<Prepared> {
    let Some(params_file) = opts.params_file.as_deref() else {
        bail!(super::Refusal::CsvWithoutParameters {
            file: file.to_path_buf()
        });
    };
    let log = crate::dataset::read_log(file)?;
    let hips = log.hips.as_ref().map(|h| hip_motions(&log.samples, h));
    let samples = log.samples;
    let ros = RosArgs {
        params_files: vec![params_file.to_path_buf()],
        params: opts.params.clone(),
        ..Default::default()
    };
    let params = load_params(&ros, "terzaghi", "/")?;
    let cfg = NodeConfig::from_params(&params, "terzaghi", "/", &[])?;
    let stem = file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let leg = match cfg.legs.len() {
        1 => 0,
        _ => cfg.legs.iter().position(|l| l.name == stem).ok_or_else(|| {
            anyhow!(
                "{} is a CSV log of one leg, and {} has several ({}): name the log after its leg",
                file.display(),
                params_file.display(),
                cfg.legs
                    .iter()
                    .map(|l| l.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })?,
    };
    Ok(Prepared {
        inputs: 2 * samples.len() as u64,
        log: Log::Csv(samples, hips, leg),
        cfg,
        params,
    })
}

impl Prepared {
    fn done(self, summary: Summary) -> Reevaluation {
        Reevaluation {
            summary,
            config: self.cfg,
            topics: match &self.log {
                Log::Mcap(opened) => opened
                    .head()
                    .topics
                    .iter()
                    .map(|t| t.topic.clone())
                    .collect(),
                Log::Csv(..) => Vec::new(),
            },
        }
    }

    /// Re-evaluates the log into rows; `input` is called once per input read.
    fn rows(
        &self,
        on_row: impl FnMut(&Row),
        mut input: impl FnMut(),
    ) -> Result<Summary, RecordError> {
        match &self.log {
            Log::Mcap(opened) => reevaluate_rows(opened.source(), self.cfg.clone(), on_row, |o| {
                if let Output::Input(..) = o {
                    input();
                }
            }),
            Log::Csv(samples, hips, leg) => {
                let s = reevaluate_log(
                    samples,
                    hips.as_deref(),
                    self.cfg.clone(),
                    *leg,
                    on_row,
                    |_| {},
                );
                (0..2 * samples.len()).for_each(|_| input());
                s
            }
        }
    }
}

/// Counts inputs and reports progress every 50,000 of them.
struct Progress<'a> {
    n: u64,
    total: u64,
    report: Option<&'a mut Box<dyn FnMut(u64, u64)>>,
}

impl Progress<'_> {
    fn input(&mut self) {
        self.n += 1;
        if self.n.is_multiple_of(50_000)
            && let Some(f) = self.report.as_mut()
        {
            f(self.n, self.total);
        }
    }
}

/// Re-evaluates the recording `file` and hands every prediction, next to its measurement, to
/// `on_row`.
pub fn reevaluate_file(
    file: &Path,
    mut opts: ReevaluateOptions,
    on_row: impl FnMut(&Row),
) -> Result<Reevaluation> {
    let p = prepare(file, &opts)?;
    let mut progress = Progress {
        n: 0,
        total: p.inputs,
        report: opts.progress.as_mut(),
    };
    let s = p
        .rows(on_row, || progress.input())
        .with_context(|| file.display().to_string())?;
    Ok(p.done(s))
}

/// Re-evaluates the recording `file` into CSV rows on `w` (header [`CSV_HEADER`]), written as
/// they come: a 10-minute session makes half a gigabyte of CSV. Rows are formatted on a second
/// thread in batches, formatting being about as much work as the re-evaluation itself.
pub fn reevaluate_to_csv(
    file: &Path,
    mut opts: ReevaluateOptions,
    w: &mut (dyn std::io::Write + Send),
) -> Result<Reevaluation> {
    const BATCH: usize = 4096;
    let p = prepare(file, &opts)?;
    let legs: Vec<String> = p.cfg.legs.iter().map(|l| l.name.clone()).collect();
    let mut rows = CsvRows::new(&legs)?;
    let mut progress = Progress {
        n: 0,
        total: p.inputs,
        report: opts.progress.as_mut(),
    };
    let s = std::thread::scope(|scope| {
        let (tx, rx) = std::sync::mpsc::sync_channel::<Vec<Row>>(8);
        let writer = scope.spawn(move || -> std::io::Result<()> {
            let mut text = Vec::with_capacity(BATCH * 256);
            w.write_all(CSV_HEADER.as_bytes())?;
            for batch in rx {
                text.clear();
                for r in &batch {
                    rows.push(&mut text, r);
                }
                w.write_all(&text)?;
            }
            w.flush()
        });
        let mut batch = Vec::with_capacity(BATCH);
        let send = |batch: &mut Vec<Row>| {
            // A writer that failed has hung up; its error is reported below.
            let _ = tx.send(std::mem::replace(batch, Vec::with_capacity(BATCH)));
        };
        let s = p.rows(
            |r| {
                batch.push(*r);
                if batch.len() == BATCH {
                    send(&mut batch);
                }
            },
            || progress.input(),
        );
        send(&mut batch);
        drop(tx);
        let written = writer
            .join()
            .map_err(|_| anyhow!("the CSV writer thread failed"))?;
        let s = s.with_context(|| file.display().to_string())?;
        written?;
        anyhow::Ok(s)
    })?;
    Ok(p.done(s))
}

/// Re-evaluates the recording `file` into a new session at `out`: its inputs as they were and
/// the node's outputs made anew, with the parameters it was re-evaluated with, so that it can
/// be re-run in turn. An existing `out` is refused unless `overwrite`.
pub fn reevaluate_to_mcap(
    file: &Path,
    out: &Path,
    overwrite: bool,
    mut opts: ReevaluateOptions,
) -> Result<Reevaluation> {
    refuse_existing_recording(out, overwrite)?;
    let p = prepare(file, &opts)?;
    let Log::Mcap(opened) = &p.log else {
        bail!(
            "{} is a CSV log: it re-evaluates into CSV rows (-o OUT.csv), not into a session",
            file.display()
        );
    };
    let cfg = &p.cfg;
    let topics = crate::config::OutputTopics::of(cfg, &[]);
    let mut progress = Progress {
        n: 0,
        total: p.inputs,
        report: opts.progress.as_mut(),
    };
    let mut result = None;
    write_atomically(out, |w| {
        let ropts = RecordOptions::with_node_params(&p.params, &cfg.node_name, &cfg.namespace);
        let mut writer = SessionWriter::new(w, ropts)?;
        let mut err: Option<RecordError> = None;
        let s = reevaluate(
            opened.source(),
            cfg.clone(),
            |_| {},
            |o| {
                if err.is_some() {
                    return;
                }
                let r = match o {
                    Output::Input(scan, m) => {
                        progress.input();
                        let t = &scan.topics[m.topic];
                        writer
                            .channel_with_metadata(
                                &t.topic,
                                &t.type_name,
                                &t.schema_text,
                                OfferedQos::BEST_EFFORT,
                                t.channel_metadata.clone(),
                            )
                            .and_then(|id| {
                                writer.write_cdr(
                                    id,
                                    &t.topic,
                                    m.data,
                                    m.log_time_ns,
                                    m.publish_time_ns,
                                )
                            })
                    }
                    Output::Prediction(log, o) => {
                        let stamp = o.wrench.header.stamp.to_nanos().max(0) as u64;
                        let leg = &topics.legs[o.leg];
                        writer
                            .write_output(&leg.wrench, OfferedQos::RELIABLE, &o.wrench, log, stamp)
                            .and_then(|_| {
                                writer.write_output(
                                    &leg.force,
                                    OfferedQos::RELIABLE,
                                    &o.force,
                                    log,
                                    stamp,
                                )
                            })
                    }
                    Output::Params(log, leg, m) => {
                        let stamp = m.header.stamp.to_nanos().max(0) as u64;
                        writer.write_output(
                            &topics.legs[leg].params,
                            OfferedQos::RELIABLE,
                            m,
                            log,
                            stamp,
                        )
                    }
                    Output::Gap(log, leg, m) => {
                        let stamp = m.header.stamp.to_nanos().max(0) as u64;
                        writer.write_output(
                            &topics.legs[leg].gap,
                            OfferedQos::RELIABLE,
                            m,
                            log,
                            stamp,
                        )
                    }
                };
                if let Err(e) = r {
                    err = Some(e);
                }
            },
        )
        .with_context(|| file.display().to_string())?;
        if let Some(e) = err {
            return Err(anyhow::Error::new(e).context(super::files::cannot_write(out)));
        }
        writer.finish()?;
        result = Some(s);
        Ok(())
    })?;
    let s = result.ok_or_else(|| anyhow!("nothing re-evaluated"))?;
    Ok(p.done(s))
}

#[cfg(test)]
mod tests {
    use crate::diagnose::{Turns, kinematics};
    use crate::ident::Sample;

    /// The re-evaluation numbers strokes as the diagnosis does: full turns from the first angle,
    /// across the wrap at 2 pi, backwards and through a non-finite angle.
    #[test]
    fn strokes_are_counted_as_the_diagnosis_counts_them() {
        let mut angles: Vec<f64> = (0..900).map(|i| 0.3 + 0.021 * i as f64).collect();
        let last = angles[899];
        angles.extend((0..100).map(|i| last - 0.01 * i as f64));
        let wrapped: Vec<f64> = angles
            .iter()
            .map(|a| a.rem_euclid(std::f64::consts::TAU))
            .collect();
        let samples: Vec<Sample> = wrapped
            .iter()
            .enumerate()
            .map(|(i, &b)| Sample {
                t_s: Some(i as f64 * 0.002),
                beta_rad: b,
                drag_n: 0.0,
                lift_n: 0.0,
            })
            .collect();
        let expected = kinematics(&samples, 5).stroke;
        let mut c = Turns::default();
        let counted: Vec<usize> = wrapped.iter().map(|&b| c.push(b).1).collect();
        assert_eq!(counted, expected);
        assert_eq!(counted.iter().max(), Some(&3));
        // A non-finite angle counts in the stroke before it and moves nothing.
        let before = c.push(wrapped[999]).1;
        assert_eq!(c.push(f64::NAN).1, before);
        assert_eq!(c.push(wrapped[999]).1, before);
    }
}
