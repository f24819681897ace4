//! The baseline of a diagnosis: the improved model with `b_k, a` (Eq. 26) fitted on training
//! strokes and scored on held-out strokes. Strokes go to folds round-robin (stroke `s` to fold
//! `s % folds`); each fold is predicted by the model fitted on all the others.

use super::kinematics::Kinematics;
use crate::ident::{BatchOptions, GoodnessOfFit, IdentError, Sample, fit_batch, goodness_of_fit};
use crate::model::{FittingWidth, Regime, TerzaghiModel};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BaselineOptions {
    /// Folds of whole strokes (at most one per stroke).
    pub folds: usize,
    /// Fit `delta` too.
    pub fit_delta: bool,
}

impl Default for BaselineOptions {
    fn default() -> Self {
        BaselineOptions {
            folds: 5,
            fit_delta: false,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum BaselineError {
    #[error("too few strokes to hold any out: {found} (need at least {needed})")]
    TooFewStrokes { found: usize, needed: usize },
    #[error("fold {fold}: {error}")]
    Fit { fold: usize, error: IdentError },
    #[error("the kinematics do not belong to these samples ({kin} against {samples})")]
    Mismatch { kin: usize, samples: usize },
}

/// The baseline: parameters fitted on everything (to report), and for every sample the
/// prediction of the model that did not see its stroke.
#[derive(Debug, Clone, PartialEq)]
pub struct Baseline {
    pub b_k: f64,
    pub a: f64,
    pub delta_deg: f64,
    pub folds: usize,
    /// Held-out predictions `(drag, lift)`, `None` where the sample is non-finite.
    pub heldout: Vec<Option<(f64, f64)>>,
    /// Regime of each sample under the model.
    pub regime: Vec<Regime>,
    /// Goodness of fit of the held-out predictions on penetration samples (as the paper scores).
    pub heldout_fit: GoodnessOfFit,
    /// Held-out RMSE over drag and lift together, penetration samples (N).
    pub heldout_rmse_n: f64,
}

pub fn cross_validated_baseline(
    model: &TerzaghiModel,
    samples: &[Sample],
    kin: &Kinematics,
    opts: &BaselineOptions,
) -> Result<Baseline, BaselineError> {
    if kin.stroke.len() != samples.len() {
        return Err(BaselineError::Mismatch {
            kin: kin.stroke.len(),
            samples: samples.len(),
        });
    }
    let strokes = kin.strokes();
    let folds = opts.folds.min(strokes);
    if folds < 2 {
        return Err(BaselineError::TooFewStrokes {
            found: strokes,
            needed: 2,
        });
    }
    let bopts = BatchOptions {
        fit_delta: opts.fit_delta,
        ..Default::default()
    };
    let mut heldout = vec![None; samples.len()];
    let mut regime = vec![Regime::OutOfMedium; samples.len()];
    for fold in 0..folds {
        let train: Vec<Sample> = samples
            .iter()
            .zip(&kin.stroke)
            .filter(|(_, s)| *s % folds != fold)
            .map(|(x, _)| *x)
            .collect();
        let fit =
            fit_batch(model, &train, &bopts).map_err(|error| BaselineError::Fit { fold, error })?;
        let fitted = fitted_model(model, fit.b_k, fit.a, fit.delta_deg);
        for (i, (x, s)) in samples.iter().zip(&kin.stroke).enumerate() {
            if *s % folds != fold || !(x.drag_n.is_finite() && x.lift_n.is_finite()) {
                continue;
            }
            if let Ok(f) = fitted.evaluate(x.beta_rad) {
                heldout[i] = Some((f.drag_n, f.lift_n));
                regime[i] = f.regime;
            }
        }
    }
    let all = fit_batch(model, samples, &bopts)
        .map_err(|error| BaselineError::Fit { fold: folds, error })?;
    let (pred, meas): (Pairs, Pairs) = heldout
        .iter()
        .zip(samples)
        .zip(&regime)
        .filter(|(_, r)| **r == Regime::Penetration)
        .filter_map(|((p, s), _)| p.map(|p| (p, (s.drag_n, s.lift_n))))
        .unzip();
    let heldout_fit = goodness_of_fit(&pred, &meas);
    let sse: f64 = pred
        .iter()
        .zip(&meas)
        .map(|(p, m)| (p.0 - m.0).powi(2) + (p.1 - m.1).powi(2))
        .sum();
    let heldout_rmse_n = if pred.is_empty() {
        0.0
    } else {
        (sse / (2 * pred.len()) as f64).sqrt()
    };
    Ok(Baseline {
        b_k: all.b_k,
        a: all.a,
        delta_deg: all.delta_deg,
        folds,
        heldout,
        regime,
        heldout_fit,
        heldout_rmse_n,
    })
}

/// `(drag, lift)` pairs.
type Pairs = Vec<(f64, f64)>;

fn fitted_model(model: &TerzaghiModel, b_k: f64, a: f64, delta_deg: f64) -> TerzaghiModel {
    let width = FittingWidth::new(b_k, a).unwrap_or(FittingWidth::CONVENTIONAL);
    let medium = model
        .medium()
        .with_delta_deg(delta_deg)
        .unwrap_or(*model.medium());
    TerzaghiModel::new(*model.plate(), medium, width)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::kinematics;
    use crate::model::{Medium, Plate};
    use crate::sim;
    use rand::SeedableRng;

    fn truth() -> TerzaghiModel {
        TerzaghiModel::new(
            Plate::new(0.25, 0.06, 0.15).unwrap(),
            Medium::new(16170.0, 32.0, 19.0).unwrap(),
            FittingWidth::new(2.0, 1.5).unwrap(),
        )
    }

    fn session(effect: impl Fn(f64, f64, f64) -> (f64, f64)) -> (Vec<Sample>, Kinematics, f64) {
        let mut rng = rand::rngs::StdRng::seed_from_u64(9);
        let angles = sim::rotate(&sim::Rotation::default(), 12, &mut rng);
        let m = truth();
        // The "measurement": the model, changed by `effect(drag, lift, speed)`.
        let speeds: Vec<f64> = angles
            .windows(2)
            .map(|w| (w[1].1 - w[0].1) / (w[1].0 - w[0].0))
            .collect();
        let mut i = 0;
        let samples = sim::measure(&angles, 0.02, &mut rng, |_, b| {
            let f = m.evaluate(b).unwrap();
            let v = speeds.get(i).copied().unwrap_or(2.0);
            i += 1;
            effect(f.drag_n, f.lift_n, v)
        });
        let peak = angles
            .iter()
            .map(|&(_, b)| {
                let f = m.evaluate(b).unwrap();
                f.drag_n.abs().max(f.lift_n.abs())
            })
            .fold(0.0, f64::max);
        let kin = kinematics(&samples, 5);
        (samples, kin, 0.02 * peak)
    }

    fn base() -> TerzaghiModel {
        TerzaghiModel::conventional(
            Plate::new(0.25, 0.06, 0.15).unwrap(),
            Medium::new(16170.0, 32.0, 19.0).unwrap(),
        )
    }

    #[test]
    fn without_an_effect_the_heldout_error_is_the_noise() {
        let (s, kin, sigma) = session(|d, l, _| (d, l));
        let b = cross_validated_baseline(&base(), &s, &kin, &BaselineOptions::default()).unwrap();
        assert_eq!(b.folds, 5);
        assert!(
            (b.b_k / 2.0 - 1.0).abs() < 0.02 && (b.a / 1.5 - 1.0).abs() < 0.02,
            "{} {}",
            b.b_k,
            b.a
        );
        assert!(
            (b.heldout_rmse_n / sigma - 1.0).abs() < 0.15,
            "rmse {} noise {sigma}",
            b.heldout_rmse_n
        );
        assert!(b.heldout.iter().filter(|p| p.is_some()).count() > s.len() / 2);
    }

    #[test]
    fn a_speed_effect_shows_as_heldout_error_above_the_noise() {
        // 40 % more drag above 2.5 rad/s: the model cannot follow it.
        let (s, kin, sigma) = session(|d, l, v| (if v > 2.5 { 1.4 * d } else { d }, l));
        let b = cross_validated_baseline(&base(), &s, &kin, &BaselineOptions::default()).unwrap();
        assert!(
            b.heldout_rmse_n > 1.5 * sigma,
            "rmse {} noise {sigma}",
            b.heldout_rmse_n
        );
    }

    #[test]
    fn one_stroke_is_too_few() {
        let (s, kin, _) = session(|d, l, _| (d, l));
        let first: Vec<Sample> = s
            .iter()
            .zip(&kin.stroke)
            .filter(|(_, k)| **k == 0)
            .map(|(x, _)| *x)
            .collect();
        let k1 = kinematics(&first, 5);
        let e = cross_validated_baseline(&base(), &first, &k1, &BaselineOptions::default())
            .unwrap_err();
        assert!(
            matches!(e, BaselineError::TooFewStrokes { found: 1, .. }),
            "{e}"
        );
    }
}
