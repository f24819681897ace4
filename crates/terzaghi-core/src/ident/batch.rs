//! Batch identification by Eq. (26): least squares over drag and lift together,
//! `min over (b_k, a[, delta]) of sum (D_pred - D_meas)^2 + (L_pred - L_meas)^2`.
//!
//! Parameters are `p = (ln b_k, ln a[, delta])`, which keeps `b_k, a > 0`. A coarse scan over
//! `ln a` (with the optimal `b_k` for each, which is linear) starts a Levenberg–Marquardt
//! iteration on the analytic Jacobian. Two or three parameters and closed-form derivatives make
//! a dedicated solver shorter than adapting a general one; the tests pin its results.

use super::{GoodnessOfFit, IdentError, Sample, UnitSample, goodness_of_fit};
use crate::model::{FittingWidth, Regime, TerzaghiModel};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// Which samples and which parameters to fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BatchOptions {
    /// Fit the plate friction angle `delta` as well (default: keep the medium's).
    pub fit_delta: bool,
    /// Use every submerged sample (default: penetration only, `beta <= pi/2`, as the paper).
    pub all_regimes: bool,
    /// Levenberg–Marquardt iterations at most.
    pub max_iterations: usize,
}

impl Default for BatchOptions {
    fn default() -> Self {
        BatchOptions {
            fit_delta: false,
            all_regimes: false,
            max_iterations: 200,
        }
    }
}

/// The fitted parameters and how well the improved and conventional models match.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BatchFit {
    /// The fitting width's coefficient `b_k`.
    pub b_k: f64,
    /// The fitting width's exponent base `a`.
    pub a: f64,
    /// The soil–plate friction angle (deg): fitted, or the medium's.
    pub delta_deg: f64,
    /// The fitted improved model on the samples used.
    pub improved: GoodnessOfFit,
    /// The conventional model (`b_k = a = 1`, the medium's `delta`) on the same samples.
    pub conventional: GoodnessOfFit,
    /// Samples used.
    pub samples: usize,
    /// Samples skipped for a non-finite angle or force.
    pub skipped_non_finite: usize,
    /// Samples skipped for their regime (out of the medium, or extraction unless asked for).
    pub skipped_regime: usize,
    /// Gauss–Newton iterations taken.
    pub iterations: usize,
}

/// Fewest samples a fit accepts.
pub const MIN_SAMPLES: usize = 5;

/// Fits `b_k, a` (and `delta` if asked) of `model`'s plate and medium to `samples`.
pub fn fit_batch(
    model: &TerzaghiModel,
    samples: &[Sample],
    opts: &BatchOptions,
) -> Result<BatchFit, IdentError> {
    let unit = model.with_fitting_width(FittingWidth::CONVENTIONAL);
    let (used, non_finite, outside) = select(&unit, samples, opts.all_regimes);
    if used.len() < MIN_SAMPLES {
        return Err(IdentError::TooFewSamples {
            usable: used.len(),
            total: samples.len(),
            needed: MIN_SAMPLES,
            non_finite,
            outside,
        });
    }
    if used.iter().all(|s| s.drag_n == 0.0 && s.lift_n == 0.0) {
        return Err(IdentError::NoForce);
    }
    let delta0 = model.medium().delta_rad();
    let (p, iterations) = solve(&used, delta0, opts);
    let (b_k, a) = (p[0].exp(), p[1].exp());
    let delta = if opts.fit_delta { p[2] } else { delta0 };
    if !(b_k.is_finite() && b_k > 0.0 && a.is_finite() && a > 0.0 && delta.is_finite()) {
        return Err(IdentError::NoFit {
            b_k,
            a,
            delta_deg: delta.to_degrees(),
            samples: used.len(),
        });
    }

    let meas: Vec<(f64, f64)> = used.iter().map(|s| (s.drag_n, s.lift_n)).collect();
    let improved: Vec<(f64, f64)> = used
        .iter()
        .map(|s| s.predict(b_k * a.powf(-s.beta_rad), delta.tan()))
        .collect();
    let conventional: Vec<(f64, f64)> = used.iter().map(|s| s.predict(1.0, delta0.tan())).collect();
    Ok(BatchFit {
        b_k,
        a,
        delta_deg: delta.to_degrees(),
        improved: goodness_of_fit(&improved, &meas),
        conventional: goodness_of_fit(&conventional, &meas),
        samples: used.len(),
        skipped_non_finite: non_finite,
        skipped_regime: outside,
        iterations,
    })
}

/// The samples to fit, with the counts of those skipped as non-finite and as outside the regimes.
pub fn select(
    unit: &TerzaghiModel,
    samples: &[Sample],
    all_regimes: bool,
) -> (Vec<UnitSample>, usize, usize) {
    let (mut used, mut non_finite, mut outside) = (Vec::with_capacity(samples.len()), 0, 0);
    for s in samples {
        match UnitSample::new(unit, s) {
            None => non_finite += 1,
            Some(u) if u.regime == Regime::OutOfMedium => outside += 1,
            Some(u) if !all_regimes && u.regime != Regime::Penetration => outside += 1,
            Some(u) => used.push(u),
        }
    }
    (used, non_finite, outside)
}

/// Largest plate friction angle a fit may reach, rad (just under 90 deg, where tan blows up).
const DELTA_MAX_RAD: f64 = 1.5;

fn cost(used: &[UnitSample], p: &DVector<f64>, delta0: f64) -> f64 {
    let t = p.get(2).copied().unwrap_or(delta0).tan();
    used.iter()
        .map(|s| {
            let (d, l) = s.predict((p[0] - s.beta_rad * p[1]).exp(), t);
            (d - s.drag_n).powi(2) + (l - s.lift_n).powi(2)
        })
        .sum()
}

/// Best `ln b_k` for a given `ln a` and `tan(delta)`: the forces are linear in `b_k`.
fn best_ln_bk(used: &[UnitSample], ln_a: f64, tan_delta: f64) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for s in used {
        let (d, l) = s.predict((-s.beta_rad * ln_a).exp(), tan_delta);
        num += d * s.drag_n + l * s.lift_n;
        den += d * d + l * l;
    }
    if num > 0.0 && den > 0.0 {
        (num / den).ln()
    } else {
        0.0
    }
}

fn solve(used: &[UnitSample], delta0: f64, opts: &BatchOptions) -> (DVector<f64>, usize) {
    let n = if opts.fit_delta { 3 } else { 2 };
    // Start: scan ln a over a wide range (a from 0.05 to 50), b_k optimal for each.
    let mut p = DVector::zeros(n);
    if opts.fit_delta {
        p[2] = delta0;
    }
    let mut best = f64::INFINITY;
    for i in 0..=60 {
        let ln_a = -3.0 + 7.0 * i as f64 / 60.0;
        let mut q = p.clone();
        q[1] = ln_a;
        q[0] = best_ln_bk(used, ln_a, delta0.tan());
        let c = cost(used, &q, delta0);
        if c < best {
            best = c;
            p = q;
        }
    }
    let mut mu = 1e-3;
    let mut iterations = 0;
    while iterations < opts.max_iterations {
        iterations += 1;
        let (jtj, jtr) = normal_equations(used, &p, delta0);
        let mut improved = false;
        for _ in 0..30 {
            let mut a = jtj.clone();
            for k in 0..n {
                a[(k, k)] += mu * jtj[(k, k)].max(1e-12);
            }
            let Some(step) = a.cholesky().map(|c| c.solve(&(-&jtr))) else {
                mu *= 10.0;
                continue;
            };
            let mut q = &p + &step;
            if n == 3 {
                q[2] = q[2].clamp(0.0, DELTA_MAX_RAD);
            }
            let c = cost(used, &q, delta0);
            if c.is_finite() && c < best {
                let rel = (best - c) / best.max(f64::MIN_POSITIVE);
                p = q;
                best = c;
                mu = (mu / 3.0).max(1e-12);
                improved = rel > 1e-14;
                break;
            }
            mu *= 4.0;
        }
        if !improved {
            break;
        }
    }
    (p, iterations)
}

/// `J^T J` and `J^T r` of the residuals `r = pred - meas` at `p`.
fn normal_equations(
    used: &[UnitSample],
    p: &DVector<f64>,
    delta0: f64,
) -> (DMatrix<f64>, DVector<f64>) {
    let n = p.len();
    let delta = p.get(2).copied().unwrap_or(delta0);
    let (t, sec2) = (delta.tan(), 1.0 / delta.cos().powi(2));
    let mut jtj = DMatrix::zeros(n, n);
    let mut jtr = DVector::zeros(n);
    let mut row = [0.0; 3];
    for s in used {
        let scale = (p[0] - s.beta_rad * p[1]).exp();
        let (d, l) = s.predict(scale, t);
        let sn = scale * s.normal_unit_n;
        for (pred, meas, d_delta) in [
            (d, s.drag_n, -sn * s.cos_beta * sec2),
            (l, s.lift_n, sn * s.sin_beta * sec2),
        ] {
            row[0] = pred;
            row[1] = -s.beta_rad * pred;
            row[2] = d_delta;
            let r = pred - meas;
            for i in 0..n {
                jtr[i] += row[i] * r;
                for j in 0..n {
                    jtj[(i, j)] += row[i] * row[j];
                }
            }
        }
    }
    (jtj, jtr)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Medium, Plate};

    fn model() -> TerzaghiModel {
        TerzaghiModel::conventional(
            Plate::new(0.25, 0.06, 0.15).unwrap(),
            Medium::new(16170.0, 32.0, 19.0).unwrap(),
        )
    }

    fn synthetic(b_k: f64, a: f64, delta_deg: f64) -> Vec<Sample> {
        let m = TerzaghiModel::new(
            *model().plate(),
            model().medium().with_delta_deg(delta_deg).unwrap(),
            FittingWidth::new(b_k, a).unwrap(),
        );
        (0..200)
            .map(|i| {
                let beta = 0.2 + 2.8 * i as f64 / 199.0;
                let f = m.evaluate(beta).unwrap();
                Sample {
                    t_s: None,
                    beta_rad: beta,
                    drag_n: f.drag_n,
                    lift_n: f.lift_n,
                }
            })
            .collect()
    }

    #[test]
    fn exact_data_gives_exact_parameters() {
        let fit = fit_batch(
            &model(),
            &synthetic(2.0, 1.5, 19.0),
            &BatchOptions::default(),
        )
        .unwrap();
        assert!(
            (fit.b_k - 2.0).abs() < 1e-6 && (fit.a - 1.5).abs() < 1e-6,
            "{fit:?}"
        );
        assert!(fit.improved.psi_drag > 0.999_999);
        assert!(fit.conventional.psi_drag < fit.improved.psi_drag);
    }

    #[test]
    fn far_parameters_and_delta_are_found() {
        let opts = BatchOptions {
            fit_delta: true,
            all_regimes: true,
            ..Default::default()
        };
        let fit = fit_batch(&model(), &synthetic(186.1, 4.5, 25.0), &opts).unwrap();
        assert!((fit.b_k / 186.1 - 1.0).abs() < 1e-6, "{fit:?}");
        assert!((fit.a / 4.5 - 1.0).abs() < 1e-6, "{fit:?}");
        assert!((fit.delta_deg - 25.0).abs() < 1e-6, "{fit:?}");
    }

    #[test]
    fn counts_what_it_skips_and_refuses_too_little() {
        let mut s = synthetic(2.0, 1.5, 19.0);
        s[100].drag_n = f64::NAN;
        let fit = fit_batch(&model(), &s, &BatchOptions::default()).unwrap();
        assert_eq!(fit.skipped_non_finite, 1);
        assert_eq!(
            fit.samples + fit.skipped_non_finite + fit.skipped_regime,
            s.len()
        );
        let e = fit_batch(&model(), &s[..3], &BatchOptions::default()).unwrap_err();
        assert!(matches!(e, IdentError::TooFewSamples { .. }), "{e}");
        let zeros: Vec<Sample> = s
            .iter()
            .map(|x| Sample {
                drag_n: 0.0,
                lift_n: 0.0,
                ..*x
            })
            .collect();
        assert_eq!(
            fit_batch(&model(), &zeros, &BatchOptions::default()).unwrap_err(),
            IdentError::NoForce
        );
    }
}
