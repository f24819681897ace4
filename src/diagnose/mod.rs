//! Diagnosis of the sim-to-real gap (pure analysis: samples in, a report value out).
//!
//! 1. [`kinematics`]: strokes from the angle; angular speed and acceleration by smoothed
//!    differentiation.
//! 2. Baseline: `b_k, a` (Eq. 26) fitted on training strokes, scored on held-out strokes (folds of
//!    whole strokes, round-robin; nothing is scored on what was fitted), over every sample, in and
//!    out of the medium.
//! 3. Noise: the sensor noise measured where the leg is well out of the medium (robust: median
//!    absolute deviation). The gap is the held-out mean squared residual in excess of it.
//! 4. Where: the squared residual by attack angle, depth, speed, acceleration, regime and stroke;
//!    each bin's share of the gap, with a chi-square test against the noise.
//! 5. Which effect: every candidate of [`effects`] fitted with the baseline on the training
//!    strokes and scored on the held-out ones, with a penalty per parameter; greedy steps while
//!    another effect still closes a real part of the gap.
//! 6. A verdict: the best effect if it closes at least half the gap; `none` if the gap is at the
//!    noise level; `unexplained` if no candidate closes half of a real gap.

pub mod context;
pub mod effects;
pub mod fit;
pub mod kinematics;
pub mod report;

pub use context::{Context, Point};
pub use effects::Effect;
pub use kinematics::{Kinematics, kinematics};
pub use report::{Diagnosis, Report};

use crate::ident::Sample;
use crate::model::TerzaghiModel;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiagnoseOptions {
    /// Folds of whole strokes.
    pub folds: usize,
    /// Fewest strokes a log must hold.
    pub min_strokes: usize,
    /// Most samples analysed (longer logs are thinned evenly; speed and acceleration come from
    /// every sample first).
    pub max_points: usize,
    /// A gap is real when the held-out mean squared residual exceeds the noise variance by this
    /// fraction (and the excess is significant).
    pub min_excess_ratio: f64,
    /// A candidate must close this share of the gap (%) to be named.
    pub accept_pct: f64,
    /// A further greedy step must close this share (%) of the baseline's gap.
    pub step_pct: f64,
    /// Penalty per parameter, in units of `noise variance x ln(residuals) / residuals`.
    pub penalty: f64,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            folds: 5,
            min_strokes: 6,
            max_points: 40_000,
            min_excess_ratio: 0.1,
            accept_pct: 50.0,
            step_pct: 15.0,
            penalty: 2.0,
        }
    }
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DiagnoseError {
    #[error("the log has {found} usable samples; a diagnosis needs at least {needed}")]
    TooFewSamples { found: usize, needed: usize },
    #[error("samples need a time stamp (t_s) to give speed and acceleration")]
    NoTime,
    #[error(
        "the log holds {found} full strokes of the leg; a diagnosis needs at least {needed} (it holds whole strokes out)"
    )]
    TooFewStrokes { found: usize, needed: usize },
    #[error(
        "{in_medium} of {total} samples are in the medium with this geometry: nothing to diagnose (check hip height and leg length)"
    )]
    OutOfMedium { in_medium: usize, total: usize },
    #[error("the measured forces are all zero: is the F/T topic the right one?")]
    NoForce,
}

/// Diagnoses the gap between `model`'s plate and medium (its fitting width is fitted) and the
/// measured `samples` of one leg.
pub fn diagnose(
    model: &TerzaghiModel,
    samples: &[Sample],
    opts: &DiagnoseOptions,
) -> Result<Diagnosis, DiagnoseError> {
    let (ctx, skipped, stride) = prepare(model, samples, opts)?;
    Ok(report::analyse(&ctx, opts, skipped, stride))
}

/// The baseline's held-out mean squared residual per component (N^2) alone, without the search
/// for effects.
pub fn baseline_heldout_mse(
    model: &TerzaghiModel,
    samples: &[Sample],
    opts: &DiagnoseOptions,
) -> Result<f64, DiagnoseError> {
    let (ctx, ..) = prepare(model, samples, opts)?;
    Ok(fit::fit(&ctx, &fit::Design::baseline(ctx.folds), None).heldout_mse())
}

/// Checks the log and builds the analysed points: returns them with the count of skipped
/// samples and the thinning stride.
fn prepare(
    model: &TerzaghiModel,
    samples: &[Sample],
    opts: &DiagnoseOptions,
) -> Result<(Context, usize, usize), DiagnoseError> {
    let total = samples.len();
    let mut usable: Vec<Sample> = samples
        .iter()
        .filter(|s| {
            s.beta_rad.is_finite()
                && s.drag_n.is_finite()
                && s.lift_n.is_finite()
                && s.t_s.is_some_and(f64::is_finite)
        })
        .copied()
        .collect();
    if usable.is_empty() && samples.iter().any(|s| s.t_s.is_none()) {
        return Err(DiagnoseError::NoTime);
    }
    usable.sort_by(|a, b| a.t_s.unwrap_or(0.0).total_cmp(&b.t_s.unwrap_or(0.0)));
    usable.dedup_by(|a, b| a.t_s == b.t_s);
    let needed = 100;
    if usable.len() < needed {
        return Err(DiagnoseError::TooFewSamples {
            found: usable.len(),
            needed,
        });
    }
    if usable.iter().all(|s| s.drag_n == 0.0 && s.lift_n == 0.0) {
        return Err(DiagnoseError::NoForce);
    }
    let dt = median_step(&usable);
    let half_window = ((0.015 / dt).round() as usize).clamp(3, 50);
    let kin = kinematics(&usable, half_window);
    if kin.strokes() < opts.min_strokes {
        return Err(DiagnoseError::TooFewStrokes {
            found: kin.strokes(),
            needed: opts.min_strokes,
        });
    }
    let stride = usable.len().div_ceil(opts.max_points.max(1000));
    let ctx = Context::new(model, &usable, &kin, opts.folds, stride);
    let in_medium = ctx.points.iter().filter(|p| p.in_medium()).count();
    if in_medium < 50 || in_medium * 50 < ctx.points.len() {
        return Err(DiagnoseError::OutOfMedium {
            in_medium: in_medium * stride,
            total,
        });
    }
    Ok((ctx, total - usable.len(), stride))
}

fn median_step(s: &[Sample]) -> f64 {
    let mut d: Vec<f64> = s
        .windows(2)
        .map(|w| w[1].t_s.unwrap_or(0.0) - w[0].t_s.unwrap_or(0.0))
        .filter(|d| *d > 0.0)
        .collect();
    if d.is_empty() {
        return 1e-3;
    }
    let mid = d.len() / 2;
    *d.select_nth_unstable_by(mid, f64::total_cmp).1
}
