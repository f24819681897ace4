//! The diagnosis checked on physics nobody here wrote: sessions built from a DEM campaign's
//! runs, each a controlled variation (speed, cohesion, density, surface level, disturbed ground,
//! sensor offset, sensor delay) with the effect the diagnosis must name, and the base case,
//! where the verdict is free but the model's own misfit must be reported.
//!
//! A case joins several runs into one session of whole strokes, the leg swinging on through
//! the air between them (zero force, its speed changing smoothly from one stroke's to the
//! next's), and adds what a real F/T sensor adds: white noise of 2 % of the session's peak
//! force, and for the sensor cases an offset or a transport delay. The surface case tells the
//! diagnosis a hip 10 mm higher than the engine's (the surface 10 mm higher than configured).
//!
//! The truth of the share of the gap the named effect closes: the same case without the
//! variation (its counterpart: the base runs of the same beds, the same noise) leaves a
//! baseline gap; the measured share is `1 - (mse_without - noise^2) / (mse_with - noise^2)`,
//! as for the generated cases.

use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use terzaghi::dem::{Campaign, DemRun};
use terzaghi::diagnose::{
    DiagnoseOptions, Effect, VerdictEffect, baseline_heldout, diagnose, in_medium_frac,
};
use terzaghi::ident::Sample;
use terzaghi::model::{Plate, TerzaghiModel};

/// The sensor's additions and the geometry the diagnosis is told.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Sensor {
    /// Offset on drag and lift, as a fraction of the session's peak force.
    pub bias_frac: f64,
    /// Pure transport delay of the F/T signal (s).
    pub delay_s: f64,
    /// The hip told this much higher than it was (m): the surface that much higher than
    /// configured.
    pub told_hip_offset_m: f64,
}

/// One DEM case.
#[derive(Debug, Clone)]
pub struct DemCase {
    pub name: &'static str,
    /// What was varied.
    pub variation: &'static str,
    /// The effect the diagnosis must name (as its verdict or a significant effect); `None` for
    /// the base case.
    pub expected: Option<Effect>,
    pub runs: &'static [&'static str],
    /// The same strokes without the variation, for the truth of the gap closed.
    pub counterpart: &'static [&'static str],
    pub sensor: Sensor,
}

const BASE: &[&str] = &["qs_b030_h040", "dx_base_s1", "dx_base_s2", "dx_base_s3"];
/// A robot that speeds up from stroke to stroke.
const SPEED: &[&str] = &[
    "qs_b030_h040",
    "dx_base_s1",
    "dx_fast_w025_s1",
    "dx_fast_w050_s2",
    "dx_fast_w075_s3",
    "var_fast",
];
/// The C-leg at 1 rad/s on four beds, as `BASE` is the flat plate: the flat-plate model
/// misfits it badly. Each stroke is the engine's own, so that no stroke the diagnosis holds out
/// has its twin among those it fits.
const CLEG: &[&str] = &["cleg", "dx_cleg_s1", "dx_cleg_s2", "dx_cleg_s3"];
/// The C-leg speeding up from stroke to stroke: 1, 1, 2.5, 5 and 7.5 rad/s.
const CLEG_SPEED: &[&str] = &[
    "cleg",
    "dx_cleg_s1",
    "dx_cleg_w025_s1",
    "dx_cleg_w050_s2",
    "dx_cleg_w075_s3",
];

/// The cases, from the campaign's committed runs (`tests/dem/campaign.py --diagnosis` adds the
/// independent beds they need).
pub fn cases() -> Vec<DemCase> {
    let none = Sensor::default();
    vec![
        DemCase {
            name: "base",
            variation: "none: four levelled beds at 1 rad/s",
            expected: None,
            runs: BASE,
            counterpart: BASE,
            sensor: none,
        },
        DemCase {
            name: "speed",
            variation: "strokes at 1, 1, 2.5, 5, 7.5 and 10 rad/s",
            expected: Some(Effect::Rate),
            runs: SPEED,
            counterpart: &[
                "qs_b030_h040",
                "dx_base_s1",
                "dx_base_s1",
                "dx_base_s2",
                "dx_base_s3",
                "qs_b030_h040",
            ],
            sensor: none,
        },
        DemCase {
            name: "cohesion",
            variation: "cohesive grains (cohesion energy density 1e5 J/m^3)",
            expected: Some(Effect::Cohesion),
            runs: &[
                "var_cohesive",
                "dx_cohesive_s1",
                "dx_cohesive_s2",
                "dx_cohesive_s3",
            ],
            counterpart: BASE,
            sensor: none,
        },
        DemCase {
            name: "density",
            variation: "three strokes in the loose bed, then three in a denser one (solid fraction 0.58 -> 0.64)",
            expected: Some(Effect::Compaction),
            runs: &[
                "qs_b030_h040",
                "dx_base_s1",
                "dx_base_s2",
                "var_dense",
                "dx_dense_s1",
                "dx_dense_s2",
            ],
            counterpart: &[
                "qs_b030_h040",
                "dx_base_s1",
                "dx_base_s2",
                "qs_b030_h040",
                "dx_base_s1",
                "dx_base_s2",
            ],
            sensor: none,
        },
        DemCase {
            name: "surface_level",
            variation: "the surface 10 mm higher than configured",
            expected: Some(Effect::HipHeight),
            runs: BASE,
            counterpart: BASE,
            sensor: Sensor {
                told_hip_offset_m: 0.010,
                ..none
            },
        },
        DemCase {
            name: "disturbed",
            variation: "four strokes through the same trough, never levelled",
            expected: Some(Effect::Compaction),
            runs: &["dx_disturbed_s1"],
            counterpart: &["dx_base_s1", "dx_base_s1", "dx_base_s1", "dx_base_s1"],
            sensor: none,
        },
        DemCase {
            name: "sensor_bias",
            variation: "F/T offset of 10 % of the peak force",
            expected: Some(Effect::SensorBias),
            runs: BASE,
            counterpart: BASE,
            sensor: Sensor {
                bias_frac: 0.10,
                ..none
            },
        },
        DemCase {
            name: "sensor_delay_20ms",
            variation: "F/T delayed by 20 ms",
            expected: Some(Effect::SensorLag),
            runs: BASE,
            counterpart: BASE,
            sensor: Sensor {
                delay_s: 0.020,
                ..none
            },
        },
        DemCase {
            name: "cleg_sensor_bias",
            variation: "C-leg told as a flat plate (a large misfit), F/T offset of 10 % of the peak force",
            expected: Some(Effect::SensorBias),
            runs: CLEG,
            counterpart: CLEG,
            sensor: Sensor {
                bias_frac: 0.10,
                ..none
            },
        },
        DemCase {
            name: "cleg_sensor_delay",
            variation: "C-leg told as a flat plate (a large misfit), F/T delayed by 20 ms",
            expected: Some(Effect::SensorLag),
            runs: CLEG,
            counterpart: CLEG,
            sensor: Sensor {
                delay_s: 0.020,
                ..none
            },
        },
        DemCase {
            name: "cleg_speed",
            variation: "none: the C-leg told as a flat plate at 1 to 7.5 rad/s",
            expected: None,
            runs: CLEG_SPEED,
            counterpart: CLEG_SPEED,
            sensor: none,
        },
        DemCase {
            name: "cleg_speed_sensor_delay",
            variation: "C-leg told as a flat plate (a large misfit) at 1 to 7.5 rad/s, F/T delayed by 20 ms",
            expected: Some(Effect::SensorLag),
            runs: CLEG_SPEED,
            counterpart: CLEG_SPEED,
            sensor: Sensor {
                delay_s: 0.020,
                ..none
            },
        },
        DemCase {
            name: "speed_sensor_delay",
            variation: "strokes at 1 to 10 rad/s, F/T delayed by 20 ms",
            expected: Some(Effect::SensorLag),
            runs: SPEED,
            counterpart: SPEED,
            sensor: Sensor {
                delay_s: 0.020,
                ..none
            },
        },
        DemCase {
            name: "sensor_delay_30ms",
            variation: "F/T delayed by 30 ms",
            expected: Some(Effect::SensorLag),
            runs: BASE,
            counterpart: BASE,
            sensor: Sensor {
                delay_s: 0.030,
                ..none
            },
        },
    ]
}

/// What the diagnosis said of a case.
#[derive(Debug, Clone, serde::Serialize)]
pub struct DemOutcome {
    pub case: &'static str,
    pub variation: &'static str,
    pub expected: Option<Effect>,
    pub strokes: usize,
    pub verdict: String,
    /// The significant effects, in order, with the share of the gap each adds (%).
    pub effects: Vec<(Effect, f64)>,
    /// Whether the expected effect is the verdict or one of the significant effects.
    pub found: bool,
    /// Where the expected effect is reported, the share of the gap the report gives it, %: its
    /// direct share where a direct signature shows it, the share it closes alone otherwise.
    pub reported_pct: Option<f64>,
    /// The share measured against the counterpart, %.
    pub measured_pct: Option<f64>,
    /// Share of the gap no significant effect explains, %.
    pub unexplained_pct: f64,
    /// The offset the sensor added to drag and lift (N; 0 but for the offset cases): the truth
    /// of the report's direct signature of an offset.
    pub sensor_offset_n: f64,
    /// Held-out Psi of the baseline (drag, lift).
    pub baseline_psi: [f64; 2],
    /// The whole report, as `terzaghi diagnose` writes it.
    pub report: terzaghi::diagnose::Report,
}

/// Why a case could not be built.
#[derive(Debug, thiserror::Error)]
pub enum CaseError {
    #[error(
        "the campaign has no run {run} (case {case}); add it with `python3 tests/dem/campaign.py --out DIR --diagnosis`"
    )]
    MissingRun { case: &'static str, run: String },
    #[error("case {case}: {message}")]
    Invalid { case: &'static str, message: String },
}

/// Noise of the F/T sensor, as a fraction of the session's peak force.
pub const NOISE_FRAC: f64 = 0.02;

/// A session of `runs` joined as strokes with `sensor`'s additions (noise from `seed`), and the
/// model told the runs' geometry (with the told hip offset). Returns the samples, the model and
/// the noise level (N).
pub fn compose(
    runs: &[&DemRun],
    sensor: &Sensor,
    seed: u64,
) -> Result<(Vec<Sample>, TerzaghiModel, f64), String> {
    let first = runs.first().ok_or("no run")?;
    for r in runs {
        // The swings through the air between and after the runs take their speeds.
        if !(r.omega_rad_s.is_finite() && r.omega_rad_s != 0.0) {
            return Err(format!(
                "{} turns at omega_rad_s = {}: a session's strokes need a speed",
                r.name, r.omega_rad_s
            ));
        }
        if r.plate != first.plate || r.medium != first.medium || r.shape != first.shape {
            return Err(format!(
                "{} and {} differ in geometry, medium or shape",
                first.name, r.name
            ));
        }
    }
    let mut t_s: Vec<f64> = Vec::new();
    let mut beta: Vec<f64> = Vec::new();
    let mut force: Vec<[f64; 2]> = Vec::new();
    let turn = std::f64::consts::TAU;
    // The last run's sample period (s).
    let mut period = 0.0;
    for (i, r) in runs.iter().enumerate() {
        let s = &r.samples;
        if s.len() < 2 {
            return Err(format!("{} has fewer than two samples", r.name));
        }
        period = (s[s.len() - 1].t_s - s[0].t_s) / (s.len() - 1) as f64;
        if i > 0 {
            // Through the air to where this run starts, a turn later, the speed changing
            // linearly from the last run's to this one's.
            let b_end = *beta.last().expect("a run was added");
            let target = s[0].beta_rad + ((b_end - s[0].beta_rad) / turn).ceil() * turn;
            let target = if target - b_end < 1.0 {
                target + turn
            } else {
                target
            };
            let w = (runs[i - 1].omega_rad_s.abs(), r.omega_rad_s.abs());
            let t_next = swing(&mut t_s, &mut beta, &mut force, target, w, period);
            let (shift_t, shift_b) = (t_next - s[0].t_s, target - s[0].beta_rad);
            for x in s {
                t_s.push(x.t_s + shift_t);
                beta.push(x.beta_rad + shift_b);
                force.push([x.drag_n, x.lift_n]);
            }
        } else {
            for x in s {
                t_s.push(x.t_s);
                beta.push(x.beta_rad);
                force.push([x.drag_n, x.lift_n]);
            }
        }
    }
    // The last stroke whole as well: through the air on to where the next stroke would begin
    // (strokes are counted in whole turns from the session's first sample), so that the last
    // strokes (those a held-out check predicts) hold their share of the air as every other
    // stroke does. A run of several strokes ends inside its last one too.
    let (start, b_end) = (beta[0], *beta.last().expect("a run was added"));
    let end = start + ((b_end - start) / turn).ceil() * turn;
    if end - b_end > 1e-9 {
        let last = runs[runs.len() - 1].omega_rad_s.abs();
        swing(&mut t_s, &mut beta, &mut force, end, (last, last), period);
    }
    let peak = force
        .iter()
        .flat_map(|f| [f[0].abs(), f[1].abs()])
        .fold(0.0, f64::max);
    let sigma = NOISE_FRAC * peak;
    let noise = Normal::new(0.0, sigma).map_err(|e| format!("noise of {sigma} N: {e}"))?;
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let period = (t_s[t_s.len() - 1] - t_s[0]) / (t_s.len() - 1) as f64;
    let delay = (sensor.delay_s / period).round() as usize;
    let bias = sensor.bias_frac * peak;
    let samples = (0..t_s.len())
        .map(|i| {
            let f = if i >= delay {
                force[i - delay]
            } else {
                [0.0, 0.0]
            };
            Sample {
                t_s: Some(t_s[i]),
                beta_rad: beta[i],
                drag_n: f[0] + bias + noise.sample(&mut rng),
                lift_n: f[1] + bias + noise.sample(&mut rng),
            }
        })
        .collect();
    let p = first.plate;
    let plate = Plate::new(
        p.length_m(),
        p.width_m(),
        p.hip_height_m() + sensor.told_hip_offset_m,
    )
    .map_err(|e| e.to_string())?;
    Ok((
        samples,
        TerzaghiModel::conventional(plate, first.medium),
        sigma,
    ))
}

/// Swings the leg through the air (zero force) from the last sample on to `target` (rad), its
/// speed changing linearly over the swing from `w.0` to `w.1` (rad/s), sampled every
/// `period_s`; the samples stop one period short of `target`. Returns the time the leg reaches
/// `target` (s).
fn swing(
    t_s: &mut Vec<f64>,
    beta: &mut Vec<f64>,
    force: &mut Vec<[f64; 2]>,
    target: f64,
    w: (f64, f64),
    period_s: f64,
) -> f64 {
    let (t_end, b_end) = (
        *t_s.last().expect("a run was added"),
        *beta.last().expect("a run was added"),
    );
    let (w0, w1) = w;
    let sweep = target - b_end;
    let duration = 2.0 * sweep / (w0 + w1).max(1e-6);
    let steps = (duration / period_s).ceil().max(1.0) as usize;
    let dt = duration / steps as f64;
    for k in 1..steps {
        let t = k as f64 * dt;
        t_s.push(t_end + t);
        beta.push(b_end + w0 * t + (w1 - w0) * t * t / (2.0 * duration));
        force.push([0.0, 0.0]);
    }
    t_end + duration
}

fn runs_of<'a>(
    campaign: &'a Campaign,
    case: &'static str,
    names: &[&str],
) -> Result<Vec<&'a DemRun>, CaseError> {
    names
        .iter()
        .map(|n| {
            campaign.run(n).ok_or_else(|| CaseError::MissingRun {
                case,
                run: n.to_string(),
            })
        })
        .collect()
}

/// The session of one case (noise seeded by `seed`): its samples, the model the diagnosis is
/// told, and the noise level (N).
pub fn case_session(
    campaign: &Campaign,
    case: &DemCase,
    seed: u64,
) -> Result<(Vec<Sample>, TerzaghiModel, f64), CaseError> {
    let runs = runs_of(campaign, case.name, case.runs)?;
    compose(&runs, &case.sensor, seed).map_err(|message| CaseError::Invalid {
        case: case.name,
        message,
    })
}

/// Diagnoses one case (noise seeded by `seed`).
pub fn run_case(
    campaign: &Campaign,
    case: &DemCase,
    seed: u64,
    opts: &DiagnoseOptions,
) -> Result<DemOutcome, CaseError> {
    let invalid = |message: String| CaseError::Invalid {
        case: case.name,
        message,
    };
    let (samples, model, sigma) = case_session(campaign, case, seed)?;
    let d = diagnose(&model, &samples, opts).map_err(|e| invalid(e.to_string()))?;
    let r = &d.report;
    let effects: Vec<(Effect, f64)> = r
        .steps
        .iter()
        .map(|s| (s.effect, s.share_of_gap_pct))
        .collect();
    let found = case.expected.is_some_and(|e| {
        r.verdict.effect == VerdictEffect::Effect(e) || effects.iter().any(|(x, _)| *x == e)
    });
    // Where the effect is reported: its direct share where a direct signature shows it, else
    // its contrast with the strokes it does not reach where it reaches only some, else the
    // share it closes alone (its candidate's, as the generated cases score the verdict's).
    let reported_pct = case.expected.filter(|_| found).and_then(|e| {
        let step = r.steps.iter().find(|s| s.effect == e);
        step.and_then(|s| {
            s.direct_share_of_gap_pct
                .or(s.contrast.as_ref().map(|c| c.share_of_gap_pct))
        })
        .or_else(|| {
            r.candidates
                .iter()
                .find(|c| c.effect == e)
                .and_then(|c| c.gap_closed_pct)
        })
    });
    let measured_pct = match case.expected {
        Some(_) => {
            let cf = runs_of(campaign, case.name, case.counterpart)?;
            let clean = Sensor {
                bias_frac: 0.0,
                delay_s: 0.0,
                told_hip_offset_m: 0.0,
            };
            let (without, cf_model, _) = compose(&cf, &clean, seed).map_err(invalid)?;
            let without = baseline_heldout(&cf_model, &without, opts)
                .map_err(|e| invalid(format!("its counterpart: {e}")))?;
            // Per sample in the medium (where the leg truly is, not where the model is told):
            // the counterpart's strokes may spend longer in the air (slower turns between
            // them), which would dilute a per-sample gap.
            let inside =
                in_medium_frac(&cf_model, &samples, opts).map_err(|e| invalid(e.to_string()))?;
            let var = sigma * sigma;
            let gap_with = (r.gap.heldout_mse_n2 - var) / inside.max(1e-9);
            let gap_without = (without.mse_n2 - var) / without.in_medium_frac.max(1e-9);
            (gap_with > 0.0).then(|| 100.0 * (1.0 - gap_without / gap_with))
        }
        None => None,
    };
    Ok(DemOutcome {
        case: case.name,
        variation: case.variation,
        expected: case.expected,
        strokes: r.strokes,
        verdict: r.verdict.effect.to_string(),
        effects,
        found,
        reported_pct,
        measured_pct,
        unexplained_pct: r.unexplained.as_ref().map_or(0.0, |u| u.share_of_gap_pct),
        sensor_offset_n: case.sensor.bias_frac * sigma / NOISE_FRAC,
        baseline_psi: [r.baseline.psi_drag, r.baseline.psi_lift],
        report: d.report.clone(),
    })
}

/// Every case of [`cases`], in parallel.
pub fn run_all(
    campaign: &Campaign,
    seed: u64,
    opts: &DiagnoseOptions,
) -> Vec<Result<DemOutcome, CaseError>> {
    use rayon::prelude::*;
    cases()
        .par_iter()
        .map(|c| run_case(campaign, c, seed, opts))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use terzaghi::dem::{DemSample, LegShape};
    use terzaghi::model::Medium;

    fn run(name: &str, omega: f64) -> DemRun {
        let samples = (0..200)
            .map(|i| DemSample {
                t_s: i as f64 * 0.002,
                beta_rad: 0.3 + omega * i as f64 * 0.002,
                drag_n: if (50..150).contains(&i) { 5.0 } else { 0.0 },
                lift_n: 0.0,
                hip_torque_nm: 0.0,
                hip_m: None,
            })
            .collect();
        DemRun {
            name: name.into(),
            meta: Default::default(),
            shape: LegShape::Flat,
            plate: Plate::new(0.1, 0.03, 0.04).unwrap(),
            medium: Medium::new(14000.0, 23.0, 19.0).unwrap(),
            omega_rad_s: omega,
            samples,
        }
    }

    #[test]
    fn runs_join_a_turn_apart_in_time_order_and_the_sensor_adds_what_it_is_told() {
        let (a, b) = (run("a", 1.0), run("b", 2.0));
        let clean = Sensor::default();
        let (s, _, sigma) = compose(&[&a, &b], &clean, 1).unwrap();
        assert!((sigma - 0.1).abs() < 1e-12, "2 % of the 5 N peak");
        assert!(s.windows(2).all(|w| w[1].t_s > w[0].t_s));
        assert!(s.windows(2).all(|w| w[1].beta_rad > w[0].beta_rad));
        // Two whole strokes: b starts a turn after a, and the session ends through the air
        // one sample short of a turn after b's start.
        let tau = std::f64::consts::TAU;
        let last = s.last().unwrap().beta_rad;
        assert!(
            last < 0.3 + 2.0 * tau && last > 0.3 + 2.0 * tau - 2.0 * 0.002 * 1.01,
            "{last}"
        );
        assert_eq!(terzaghi::diagnose::kinematics(&s, 5).strokes(), 2);
        // A run of several turns (3.2 at 50 rad/s) ends whole too: four strokes.
        let (long, _, _) = compose(&[&run("c", 50.0)], &clean, 1).unwrap();
        let last = long.last().unwrap().beta_rad;
        assert!(
            last < 0.3 + 4.0 * tau && last > 0.3 + 4.0 * tau - 0.11,
            "{last}"
        );
        assert_eq!(terzaghi::diagnose::kinematics(&long, 5).strokes(), 4);
        // An offset of 10 % of the peak on every sample; a delay moves the force later.
        let biased = Sensor {
            bias_frac: 0.1,
            ..clean
        };
        let (sb, _, _) = compose(&[&a, &b], &biased, 1).unwrap();
        let mean_diff: f64 = s
            .iter()
            .zip(&sb)
            .map(|(x, y)| y.drag_n - x.drag_n)
            .sum::<f64>()
            / s.len() as f64;
        assert!((mean_diff - 0.5).abs() < 1e-9, "{mean_diff}");
        let late = Sensor {
            delay_s: 0.01,
            ..clean
        };
        let (sl, _, _) = compose(&[&a], &late, 1).unwrap();
        let onset = |v: &[Sample]| v.iter().position(|x| x.drag_n > 2.5).unwrap();
        let (s1, _, _) = compose(&[&a], &clean, 1).unwrap();
        assert_eq!(onset(&sl) - onset(&s1), 5);
        let told = Sensor {
            told_hip_offset_m: 0.01,
            ..clean
        };
        let (_, m, _) = compose(&[&a], &told, 1).unwrap();
        assert!((m.plate().hip_height_m() - 0.05).abs() < 1e-12);
    }

    #[test]
    fn runs_of_another_geometry_are_refused() {
        let mut b = run("b", 1.0);
        b.plate = Plate::new(0.1, 0.04, 0.04).unwrap();
        assert!(compose(&[&run("a", 1.0), &b], &Sensor::default(), 1).is_err());
    }

    #[test]
    fn a_run_without_a_speed_is_refused_not_swung_for_ever() {
        let mut still = run("still", 1.0);
        still.omega_rad_s = 0.0;
        let e = compose(&[&still], &Sensor::default(), 1).unwrap_err();
        assert!(e.contains("still") && e.contains("omega_rad_s = 0"), "{e}");
    }
}
