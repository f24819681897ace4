//! The loop closed, measured on strokes the diagnosis did not see: a session's first strokes
//! are diagnosed, and the rest are predicted by the node (its own core, fed the joint states and
//! F/T samples the session stands for) twice: with the bare model the diagnosis fitted (its
//! baseline `b_k, a`) and with the corrected model it wrote. The share of the gap the
//! corrections close there is set against the share the diagnosis reported.
//!
//! Sessions: the demo's six legs, the generated cases of [`crate::withheld`], and the DEM
//! campaign's cases ([`crate::dem_cases`]).

use terzaghi::config::{DEFAULT_CORRECTIONS_MEMORY_STROKES, LegConfig, NodeConfig};
use terzaghi::diagnose::{DiagnoseOptions, Effect, diagnose, kinematics, median};
use terzaghi::ident::corrected::learn_samples;
use terzaghi::ident::online::Forgetting;
use terzaghi::ident::{CorrectedEstimator, OnlineOptions, Sample};
use terzaghi::model::corrections::{CorrectedModel, Corrections};
use terzaghi::model::{FittingWidth, Medium, Plate};
use terzaghi::session::reevaluate::{RowErrors, reevaluate_samples};

/// Prediction errors of one model on the held-out strokes.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct HeldOutFit {
    /// RMSE over drag and lift (N).
    pub rmse_n: f64,
    pub r2_drag: f64,
    pub r2_lift: f64,
    /// Mean squared residual per component (N^2).
    pub mse_n2: f64,
}

impl HeldOutFit {
    fn of(e: &RowErrors) -> HeldOutFit {
        let rmse = RowErrors::rmse_n(&e.expected);
        HeldOutFit {
            rmse_n: rmse,
            r2_drag: e.expected[0].fit().r2,
            r2_lift: e.expected[1].fit().r2,
            mse_n2: rmse * rmse,
        }
    }
}

/// One stroke of a session, predicted by both models: where along the session, and at what
/// speed, the corrected model gains or loses.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct StrokeFit {
    /// Index of the stroke in the session.
    pub stroke: usize,
    /// Median angular speed over the stroke (rad/s, its magnitude).
    pub speed_rad_s: f64,
    /// Whether the stroke is one of the held-out ones (else the diagnosis saw it).
    pub held_out: bool,
    /// Samples with a measurement.
    pub samples: u64,
    /// Mean squared residual per component of the bare and of the corrected model (N^2).
    pub bare_mse_n2: f64,
    pub corrected_mse_n2: f64,
}

/// One session: diagnosed on its first strokes, predicted on the rest.
#[derive(Debug, Clone, serde::Serialize)]
pub struct HeldOut {
    /// `demo`, `generated` or `dem`.
    pub source: &'static str,
    pub case: String,
    /// What the session hides (`none`, effects joined by `+`), as far as it is known.
    pub truth: String,
    pub train_strokes: usize,
    pub test_strokes: usize,
    pub test_samples: u64,
    /// The diagnosis of the first strokes: its verdict and the effects it kept.
    pub verdict: String,
    pub kept: Vec<Effect>,
    /// Share of the gap the steps it wrote into the corrected model close, as it reported (%).
    pub reported_pct: f64,
    /// The share the diagnosis reported its corrected model carries forward: fitted on its
    /// earlier strokes, scored on its own last third (%; `None` where it gives none).
    pub reported_forward_pct: Option<f64>,
    /// The bare model's mean squared residual per component on the diagnosed strokes, held out
    /// by the diagnosis's folds (N^2): set against `bare.mse_n2`, how much harder the held-out
    /// strokes are.
    pub diagnosed_bare_mse_n2: f64,
    pub bare: HeldOutFit,
    pub corrected: HeldOutFit,
    /// Share of the held-out gap (the bare model's squared residual in excess of the noise the
    /// diagnosis measured) the corrected model closes, %; `None` where the bare model is within
    /// a tenth of the noise (no gap to close).
    pub measured_pct: Option<f64>,
    /// The corrected model at least as good on the held-out strokes as the diagnosis reported,
    /// within 10 points (a session whose diagnosis kept nothing is predicted alike both ways).
    pub holds: bool,
    /// Every stroke, the diagnosed ones too.
    pub strokes: Vec<StrokeFit>,
}

/// Why a session could not be checked.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{case}: {message}")]
pub struct HeldOutError {
    pub case: String,
    pub message: String,
}

/// The target's rule: a measured share of the gap (%) holds against a share the diagnosis
/// reported (%) when it is at most 10 points below it.
pub fn closes_share(measured_pct: f64, reported_pct: f64) -> bool {
    measured_pct >= reported_pct - 10.0
}

/// Share of the strokes diagnosed; the rest are predicted.
pub const TRAIN_FRAC: f64 = 2.0 / 3.0;

/// Diagnoses the first strokes of `samples` (one leg of `plate` in `medium`; at least
/// `TRAIN_FRAC` of them, and three) and predicts the rest through the node with the bare and
/// the corrected model.
pub fn held_out(
    source: &'static str,
    case: &str,
    truth: &str,
    plate: Plate,
    medium: Medium,
    samples: &[Sample],
) -> Result<HeldOut, HeldOutError> {
    let err = |message: String| HeldOutError {
        case: case.to_string(),
        message,
    };
    let mut sorted: Vec<Sample> = samples
        .iter()
        .filter(|s| s.t_s.is_some_and(f64::is_finite) && s.beta_rad.is_finite())
        .copied()
        .collect();
    sorted.sort_by(|a, b| a.t_s.unwrap_or(0.0).total_cmp(&b.t_s.unwrap_or(0.0)));
    let kin = kinematics(&sorted, 5);
    let strokes = kin.strokes();
    if strokes < 4 {
        return Err(err(format!(
            "{strokes} strokes: at least 4 are needed (three to diagnose, one to predict)"
        )));
    }
    let train = ((strokes as f64 * TRAIN_FRAC).ceil() as usize).clamp(3, strokes - 1);
    let split = kin
        .stroke
        .iter()
        .position(|&k| k >= train)
        .unwrap_or(sorted.len());
    let opts = DiagnoseOptions {
        min_strokes: 3,
        ..Default::default()
    };
    let model = terzaghi::model::TerzaghiModel::conventional(plate, medium);
    let d = diagnose(&model, &sorted[..split], &opts).map_err(|e| err(e.to_string()))?;
    let r = &d.report;
    let base = FittingWidth::new(r.baseline.b_k, r.baseline.a)
        .map_err(|e| err(format!("the baseline: {e}")))?;
    let c = &r.corrected_model;
    let corrected_width =
        FittingWidth::new(c.b_k, c.a).map_err(|e| err(format!("the corrected model: {e}")))?;
    let times: Vec<f64> = sorted.iter().map(|s| s.t_s.unwrap_or(0.0)).collect();
    // The errors on the held-out strokes, and on each stroke.
    let run =
        |width: FittingWidth, corrections| -> Result<(RowErrors, Vec<RowErrors>), HeldOutError> {
            let mut leg = LegConfig::new("leg", "leg", plate, medium);
            leg.width = width;
            leg.corrections = corrections;
            let mut cfg =
                NodeConfig::with_legs(vec![leg], "joint_states").map_err(|e| err(e.to_string()))?;
            // The node predicts with the model it is given, not with its online estimate.
            cfg.use_identified = false;
            let mut e = RowErrors::default();
            let mut per_stroke = vec![RowErrors::default(); strokes];
            reevaluate_samples(&sorted, cfg, 0, |row| {
                // A row answers the sample of its stamp (the node answers each F/T sample; the
                // stamp is the sample's time to the nanosecond): its stroke is the nearest
                // sample's.
                let i = times.partition_point(|&t| t < row.t_s);
                let i = match i.checked_sub(1) {
                    Some(j) if i == times.len() || row.t_s - times[j] < times[i] - row.t_s => j,
                    _ => i,
                };
                let Some(&k) = kin.stroke.get(i) else { return };
                if k >= train {
                    e.add(row);
                }
                if let Some(sums) = per_stroke.get_mut(k) {
                    sums.add(row);
                }
            })
            .map_err(|e| err(e.to_string()))?;
            Ok((e, per_stroke))
        };
    let (bare_e, bare_strokes) = run(base, None)?;
    c.validate(plate.length_m())
        .map_err(|e| err(format!("the corrected model is refused: {e}")))?;
    let (corr_e, corr_strokes) = run(corrected_width, Some(c.clone()))?;
    let mut speeds = vec![Vec::new(); strokes];
    for (&k, w) in kin.stroke.iter().zip(&kin.speed_rad_s) {
        if let Some(v) = speeds.get_mut(k) {
            v.push(w.abs());
        }
    }
    let stroke_fits = (0..strokes)
        .filter(|&k| bare_strokes[k].samples() > 0)
        .map(|k| StrokeFit {
            stroke: k,
            speed_rad_s: median(&speeds[k]),
            held_out: k >= train,
            samples: bare_strokes[k].samples(),
            bare_mse_n2: RowErrors::rmse_n(&bare_strokes[k].expected).powi(2),
            corrected_mse_n2: RowErrors::rmse_n(&corr_strokes[k].expected).powi(2),
        })
        .collect();
    let (bare, corrected) = (HeldOutFit::of(&bare_e), HeldOutFit::of(&corr_e));
    let var = r.gap.noise_var_n2;
    let excess = bare.mse_n2 - var;
    let measured_pct =
        (excess > 0.1 * var).then(|| 100.0 * (bare.mse_n2 - corrected.mse_n2) / excess);
    let reported_pct = r.corrected_model_gap_closed_pct;
    let kept: Vec<Effect> = c.terms.iter().map(|t| t.effect).collect();
    let holds = kept.is_empty()
        || match measured_pct {
            Some(m) => closes_share(m, reported_pct),
            // No gap left to close on the held-out strokes: the corrections cannot show more.
            None => corrected.mse_n2 <= bare.mse_n2 * 1.01 || corrected.mse_n2 <= 1.1 * var,
        };
    Ok(HeldOut {
        source,
        case: case.to_string(),
        truth: truth.to_string(),
        train_strokes: train,
        test_strokes: strokes - train,
        test_samples: corr_e.samples(),
        verdict: r.verdict.effect.to_string(),
        kept,
        reported_pct,
        reported_forward_pct: r.corrected_model_forward_gap_closed_pct,
        diagnosed_bare_mse_n2: r.gap.heldout_mse_n2,
        bare,
        corrected,
        measured_pct,
        holds,
        strokes: stroke_fits,
    })
}

/// The demo's six legs (the walk `terzaghi demo` simulates, `seconds` long, seed `seed`).
pub fn demo_sessions(seconds: f64, seed: u64) -> Vec<Result<HeldOut, HeldOutError>> {
    use rayon::prelude::*;
    let (_, cfg) = match terzaghi::sim::robot::rhex() {
        Ok(x) => x,
        Err(e) => {
            return vec![Err(HeldOutError {
                case: "demo".into(),
                message: e.to_string(),
            })];
        }
    };
    let truth = terzaghi::sim::robot::demo_truth();
    let gait = terzaghi::sim::robot::Gait {
        seconds,
        rate_hz: terzaghi::sim::robot::DEMO_RATE_HZ,
        mean_speed_rad_s: 4.0,
        seed,
    };
    let walk = terzaghi::sim::robot::simulate(&cfg, &truth, &gait);
    let hidden: Vec<&str> = truth.effects.iter().map(|e| e.name()).collect();
    cfg.legs
        .par_iter()
        .zip(&walk.legs)
        .map(|(leg, samples)| {
            held_out(
                "demo",
                &leg.name,
                &hidden.join("+"),
                leg.plate,
                leg.medium,
                samples,
            )
        })
        .collect()
}

/// The first `n` generated cases of [`crate::withheld`] (seed `seed`).
pub fn generated_sessions(n: usize, seed: u64) -> Vec<Result<HeldOut, HeldOutError>> {
    use rayon::prelude::*;
    (0..n)
        .into_par_iter()
        .map(|i| {
            let (case, samples) = crate::withheld::case_session(i, seed);
            let truth = if case.effects.is_empty() {
                "none".to_string()
            } else {
                case.effects
                    .iter()
                    .map(|e| e.name())
                    .collect::<Vec<_>>()
                    .join("+")
            };
            held_out(
                "generated",
                &format!("case {i}"),
                &truth,
                case.plate,
                case.medium,
                &samples,
            )
        })
        .collect()
}

/// The DEM campaign's cases (noise seeded by `seed`).
pub fn dem_sessions(
    campaign: &terzaghi::dem::Campaign,
    seed: u64,
) -> Vec<Result<HeldOut, HeldOutError>> {
    use rayon::prelude::*;
    crate::dem_cases::cases()
        .par_iter()
        .map(|case| {
            let (samples, model, _) = crate::dem_cases::case_session(campaign, case, seed)
                .map_err(|e| HeldOutError {
                    case: case.name.into(),
                    message: e.to_string(),
                })?;
            held_out(
                "dem",
                case.name,
                case.expected.map_or("none", Effect::name),
                *model.plate(),
                *model.medium(),
                &samples,
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use terzaghi::model::TerzaghiModel;
    use terzaghi::sim;

    /// A session with a sensor offset: diagnosed on its first strokes, the corrected model
    /// closes the gap on the rest, as reported.
    #[test]
    fn an_offset_found_on_the_first_strokes_closes_the_gap_on_the_rest() {
        let plate = Plate::new(0.25, 0.06, 0.15).unwrap();
        let medium = Medium::new(16170.0, 32.0, 19.0).unwrap();
        let truth = TerzaghiModel::new(plate, medium, FittingWidth::new(2.0, 1.5).unwrap());
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        let angles = sim::rotate(&sim::Rotation::default(), 12, &mut rng);
        let s = sim::measure(&angles, 0.01, &mut rng, |_, b| {
            let f = truth.evaluate(b).unwrap();
            (f.drag_n + 3.0, f.lift_n - 2.0)
        });
        let h = held_out("test", "offset", "sensor_bias", plate, medium, &s).unwrap();
        assert_eq!(h.kept, vec![Effect::SensorBias], "{h:?}");
        assert_eq!((h.train_strokes, h.test_strokes), (8, 4));
        assert!(h.holds, "{h:?}");
        let m = h.measured_pct.unwrap();
        assert!(m > 90.0 && h.reported_pct > 90.0, "{h:?}");
        assert!(h.corrected.rmse_n < 0.5 * h.bare.rmse_n, "{h:?}");
    }
}

/// The generated cases `diagnose-eval --online` learns: one of each kind with a single hidden
/// effect of the library.
pub const ONLINE_CASES: std::ops::RangeInclusive<usize> = 1..=9;
/// The cases followed by a stronger medium, and how much stronger.
pub const STEP_CASES: [usize; 4] = [3, 4, 6, 8];
pub const STEP_FACTOR: f64 = 1.4;

/// One linear value of a corrected model: as the diagnosis fitted it on a whole session, and as
/// the node's online identification had it at the session's end.
#[derive(Debug, Clone, serde::Serialize)]
pub struct LearntValue {
    /// `b_k`, `a`, or `<effect>.<param>`.
    pub name: String,
    pub batch: f64,
    pub online: f64,
    /// The online standard deviation.
    pub std: f64,
}

impl LearntValue {
    /// Whether the session determines the value: `b_k` and `a` always; a coefficient whose batch
    /// value is more than three online standard deviations from zero.
    pub fn determined(&self) -> bool {
        matches!(self.name.as_str(), "b_k" | "a") || self.batch.abs() > 3.0 * self.std
    }

    /// The online value within 10 % of the batch one.
    pub fn within_10_pct(&self) -> bool {
        (self.online - self.batch).abs() <= 0.1 * self.batch.abs()
    }

    pub fn diff_pct(&self) -> f64 {
        100.0 * (self.online - self.batch) / self.batch.abs().max(f64::MIN_POSITIVE)
    }
}

/// A session's corrected model learnt online from the conventional start (`b_k = a = 1`, every
/// coefficient 0) against the batch diagnosis.
#[derive(Debug, Clone, serde::Serialize)]
pub struct LearntOnline {
    pub case: String,
    pub truth: String,
    pub strokes: usize,
    pub values: Vec<LearntValue>,
    pub converged: bool,
    pub changes_detected: u64,
    /// Change alarms dismissed: the estimate predicted the strokes after them as well as a refit.
    pub alarms_dismissed: u64,
    /// A change alarm still under test at the session's end.
    pub alarm_under_test: bool,
    /// Changes the bare estimator (`b_k, a`, the node's defaults) detects in the same session,
    /// which has none: what its change detection makes of the same misfit.
    pub bare_changes_detected: u64,
}

impl LearntOnline {
    /// Converged at the end, and every value the session determines within 10 % of the batch
    /// one.
    pub fn holds(&self) -> bool {
        self.converged
            && self
                .values
                .iter()
                .all(|v| !v.determined() || v.within_10_pct())
    }
}

/// The values of `batch` against an estimator's.
fn learnt_values(batch: &Corrections, est: &CorrectedEstimator) -> Vec<LearntValue> {
    let e = est.estimate();
    let mut values = vec![
        LearntValue {
            name: "b_k".into(),
            batch: batch.b_k,
            online: e.b_k,
            std: e.std_b_k,
        },
        LearntValue {
            name: "a".into(),
            batch: batch.a,
            online: e.a,
            std: e.std_a,
        },
    ];
    let batch_coefficients = batch.terms.iter().flat_map(|t| t.coefficients.iter());
    for (c, b) in est.coefficients().iter().zip(batch_coefficients) {
        values.push(LearntValue {
            name: c.name(),
            batch: *b,
            online: c.value,
            std: c.std,
        });
    }
    values
}

/// The node's online options for a leg with corrections (its default parameters).
fn online_options() -> OnlineOptions {
    OnlineOptions {
        forgetting: Forgetting::Strokes(DEFAULT_CORRECTIONS_MEMORY_STROKES),
        ..Default::default()
    }
}

/// Generated case `i` of a run seeded with `seed` ([`crate::withheld`]): diagnosed whole, then
/// its corrected model learnt online from scratch over the same session.
pub fn learnt_online(i: usize, seed: u64) -> Result<LearntOnline, HeldOutError> {
    let (case, samples) = crate::withheld::case_session(i, seed);
    let err = |message: String| HeldOutError {
        case: format!("case {i}"),
        message,
    };
    let model = terzaghi::model::TerzaghiModel::conventional(case.plate, case.medium);
    let d =
        diagnose(&model, &samples, &DiagnoseOptions::default()).map_err(|e| err(e.to_string()))?;
    let batch = d.report.corrected_model.clone();
    let start = CorrectedModel::new(case.plate, case.medium, batch.unlearnt())
        .map_err(|e| err(format!("the corrected model is refused: {e}")))?;
    let mut est =
        CorrectedEstimator::new(start, online_options()).map_err(|e| err(e.to_string()))?;
    learn_samples(&mut est, &samples);
    let mut bare = terzaghi::ident::OnlineEstimator::new(&model, OnlineOptions::default())
        .map_err(|e| err(e.to_string()))?;
    for s in &samples {
        let _ = bare.update(s);
    }
    Ok(LearntOnline {
        case: format!("case {i}"),
        truth: truth_of(&case),
        strokes: case.strokes,
        values: learnt_values(&batch, &est),
        converged: est.estimate().converged,
        changes_detected: est.estimate().changes_detected,
        alarms_dismissed: est.alarms_dismissed(),
        alarm_under_test: est.alarm_under_test(),
        bare_changes_detected: bare.estimate().changes_detected,
    })
}

fn truth_of(case: &terzaghi::sim::generator::Case) -> String {
    if case.effects.is_empty() {
        return "none".to_string();
    }
    case.effects
        .iter()
        .map(|e| e.name())
        .collect::<Vec<_>>()
        .join("+")
}

/// A medium that changes: generated case `i`'s session, then the same motion again in a medium
/// `factor` times as strong (`b_k` scaled). Each part is diagnosed alone; the corrected model
/// (the first part's terms) is learnt online from scratch over both.
#[derive(Debug, Clone, serde::Serialize)]
pub struct LearntStep {
    /// The first part against its diagnosis, at the step.
    pub before: LearntOnline,
    /// The whole session's end against the second part's diagnosis.
    pub after: LearntOnline,
    /// Strokes from the step to the first change the estimator detected after it.
    pub detected_after_strokes: Option<f64>,
}

/// How precisely a session determines a value of its batch diagnosis: the stroke jackknife.
/// The diagnosis is run again with each stroke left out in turn; the spread of a value over
/// those runs is its standard error as the session's strokes give it. The online standard
/// deviation treats every sample as independent, but where a term's form is not the medium's the
/// misfit runs through a whole stroke, so that deviation understates what the strokes allow.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Jackknife {
    pub case: String,
    pub truth: String,
    /// The value (`b_k`, `a` or `<effect>.<param>`) and its batch value on the whole session.
    pub name: String,
    pub batch: f64,
    /// The jackknife's standard error of the batch value, over the runs that kept the whole
    /// session's terms (`runs` of `strokes`); `None` with fewer than two such runs.
    pub std_error: Option<f64>,
    pub runs: usize,
    pub strokes: usize,
}

/// The stroke jackknife of the batch value `name` of generated case `i` (see [`Jackknife`]).
pub fn jackknife(i: usize, seed: u64, name: &str) -> Result<Jackknife, HeldOutError> {
    let (case, samples) = crate::withheld::case_session(i, seed);
    let err = |message: String| HeldOutError {
        case: format!("case {i}"),
        message,
    };
    let model = terzaghi::model::TerzaghiModel::conventional(case.plate, case.medium);
    let opts = DiagnoseOptions::default();
    let value_of = |c: &Corrections| -> Option<f64> {
        let mut values = vec![("b_k".to_string(), c.b_k), ("a".to_string(), c.a)];
        values.extend(c.linear_values());
        values.into_iter().find(|(n, _)| n == name).map(|(_, v)| v)
    };
    let whole = diagnose(&model, &samples, &opts).map_err(|e| err(e.to_string()))?;
    let full = whole.report.corrected_model;
    let batch = value_of(&full).ok_or_else(|| err(format!("the diagnosis has no value {name}")))?;
    let effects = |c: &Corrections| c.terms.iter().map(|t| t.effect).collect::<Vec<_>>();
    let stroke_of = kinematics(&samples, 5).stroke;
    let strokes = stroke_of.last().map_or(0, |s| s + 1);
    let mut values = Vec::new();
    for k in 0..strokes {
        let kept: Vec<Sample> = samples
            .iter()
            .zip(&stroke_of)
            .filter(|(_, s)| **s != k)
            .map(|(x, _)| *x)
            .collect();
        let Ok(d) = diagnose(&model, &kept, &opts) else {
            continue;
        };
        let c = d.report.corrected_model;
        if effects(&c) == effects(&full)
            && let Some(v) = value_of(&c)
        {
            values.push(v);
        }
    }
    let m = values.len() as f64;
    let std_error = (values.len() >= 2).then(|| {
        let mean = values.iter().sum::<f64>() / m;
        ((m - 1.0) / m * values.iter().map(|v| (v - mean).powi(2)).sum::<f64>()).sqrt()
    });
    Ok(Jackknife {
        case: format!("case {i}"),
        truth: truth_of(&case),
        name: name.to_string(),
        batch,
        std_error,
        runs: values.len(),
        strokes,
    })
}

/// See [`LearntStep`].
pub fn learnt_step(i: usize, seed: u64, factor: f64) -> Result<LearntStep, HeldOutError> {
    let (case, first) = crate::withheld::case_session(i, seed);
    let err = |message: String| HeldOutError {
        case: format!("case {i} with a step"),
        message,
    };
    let mut stronger = case.clone();
    stronger.b_k *= factor;
    let (second, _) = terzaghi::sim::generator::generate(&stronger, &[]);
    // The second part goes on where the first ended: time after it, whole turns further on.
    let (t_end, beta_end) = first
        .last()
        .map_or((0.0, 0.0), |s| (s.t_s.unwrap_or(0.0), s.beta_rad));
    let dt = first
        .get(1)
        .and_then(|s| Some(s.t_s? - first[0].t_s?))
        .unwrap_or(0.004);
    let turns =
        ((beta_end - second.first().map_or(0.0, |s| s.beta_rad)) / std::f64::consts::TAU).ceil();
    let shifted: Vec<Sample> = second
        .iter()
        .map(|s| Sample {
            t_s: s.t_s.map(|t| t + t_end + dt),
            beta_rad: s.beta_rad + turns * std::f64::consts::TAU,
            ..*s
        })
        .collect();
    let model = terzaghi::model::TerzaghiModel::conventional(case.plate, case.medium);
    let opts = DiagnoseOptions::default();
    let batch_first = diagnose(&model, &first, &opts)
        .map_err(|e| err(e.to_string()))?
        .report
        .corrected_model;
    let batch_second = diagnose(&model, &shifted, &opts)
        .map_err(|e| err(e.to_string()))?
        .report
        .corrected_model;
    let start = CorrectedModel::new(case.plate, case.medium, batch_first.unlearnt())
        .map_err(|e| err(format!("the corrected model is refused: {e}")))?;
    let mut est =
        CorrectedEstimator::new(start, online_options()).map_err(|e| err(e.to_string()))?;
    learn_samples(&mut est, &first);
    let part = |name: &str, batch: &Corrections, est: &CorrectedEstimator| LearntOnline {
        case: format!("case {i}, {name}"),
        truth: truth_of(&case),
        strokes: case.strokes,
        values: learnt_values(batch, est),
        converged: est.estimate().converged,
        changes_detected: est.estimate().changes_detected,
        alarms_dismissed: est.alarms_dismissed(),
        alarm_under_test: est.alarm_under_test(),
        bare_changes_detected: 0,
    };
    let before = part("before the step", &batch_first, &est);
    let changes_before = est.changes().len();
    learn_samples(&mut est, &shifted);
    let stroke_s = t_end / case.strokes.max(1) as f64;
    let detected_after_strokes = est.changes()[changes_before..]
        .first()
        .and_then(|c| c.t_s)
        .map(|t| (t - t_end) / stroke_s);
    // The second part's diagnosis may keep other terms: compare what both models have.
    let after = if batch_second
        .terms
        .iter()
        .map(|t| t.effect)
        .eq(batch_first.terms.iter().map(|t| t.effect))
    {
        part("after the step", &batch_second, &est)
    } else {
        let mut p = part("after the step", &batch_second, &est);
        p.values.truncate(2);
        p
    };
    Ok(LearntStep {
        before,
        after,
        detected_after_strokes,
    })
}
