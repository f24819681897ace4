//! Goodness of fit: the paper's Psi (Eq. 28), and R^2 and RMSE, which a large mean force does
//! not inflate.

use serde::Serialize;

/// Per-component goodness of fit of predicted against measured drag and lift.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GoodnessOfFit {
    /// Psi of drag (Eq. 28).
    pub psi_drag: f64,
    /// Psi of lift.
    pub psi_lift: f64,
    /// R^2 of drag.
    pub r2_drag: f64,
    /// R^2 of lift.
    pub r2_lift: f64,
    /// RMSE of drag (N).
    pub rmse_drag_n: f64,
    /// RMSE of lift (N).
    pub rmse_lift_n: f64,
}

/// Psi, R^2 and RMSE of one component.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ComponentFit {
    /// `1 - sum (pred - meas)^2 / sum meas^2` (Eq. 28).
    pub psi: f64,
    /// `1 - sum (pred - meas)^2 / sum (meas - mean)^2`.
    pub r2: f64,
    /// Root mean squared error, in the measurement's unit.
    pub rmse: f64,
}

/// Goodness of fit of one component. Zero denominators (no force, constant force) give 0 for Psi
/// or R^2 rather than a NaN; an empty input gives all zeros.
pub fn component_fit(pred: &[f64], meas: &[f64]) -> ComponentFit {
    let mut sums = FitSums::default();
    for (p, m) in pred.iter().zip(meas) {
        sums.add(*p, *m);
    }
    sums.fit()
}

/// The sums behind [`component_fit`], added sample by sample: for a stream of predictions
/// next to measurements that is not kept (a re-evaluated session). The measurements' spread
/// is summed about their running mean (Welford), which a large mean force does not spoil.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FitSums {
    n: u64,
    sse: f64,
    ss: f64,
    mean: f64,
    sst: f64,
}

impl FitSums {
    /// Adds one prediction next to its measurement.
    pub fn add(&mut self, pred: f64, meas: f64) {
        self.n += 1;
        self.sse += (pred - meas) * (pred - meas);
        self.ss += meas * meas;
        let d = meas - self.mean;
        self.mean += d / self.n as f64;
        self.sst += d * (meas - self.mean);
    }

    /// The pairs added.
    pub fn samples(&self) -> u64 {
        self.n
    }

    /// Psi, R^2 and RMSE of the pairs added (all zeros for none).
    pub fn fit(&self) -> ComponentFit {
        if self.n == 0 {
            return ComponentFit {
                psi: 0.0,
                r2: 0.0,
                rmse: 0.0,
            };
        }
        let ratio = |den: f64| if den > 0.0 { 1.0 - self.sse / den } else { 0.0 };
        ComponentFit {
            psi: ratio(self.ss),
            r2: ratio(self.sst),
            rmse: (self.sse / self.n as f64).sqrt(),
        }
    }
}

/// Goodness of fit over `(drag, lift)` pairs.
///
/// ```
/// use terzaghi_core::ident::goodness_of_fit;
/// let g = goodness_of_fit(&[(1.0, 2.0), (2.0, 4.0)], &[(1.0, 2.0), (2.0, 4.0)]);
/// assert_eq!((g.psi_drag, g.r2_lift, g.rmse_drag_n), (1.0, 1.0, 0.0));
/// ```
pub fn goodness_of_fit(pred: &[(f64, f64)], meas: &[(f64, f64)]) -> GoodnessOfFit {
    let split = |v: &[(f64, f64)]| -> (Vec<f64>, Vec<f64>) { v.iter().copied().unzip() };
    let ((pd, pl), (md, ml)) = (split(pred), split(meas));
    let (d, l) = (component_fit(&pd, &md), component_fit(&pl, &ml));
    GoodnessOfFit {
        psi_drag: d.psi,
        psi_lift: l.psi,
        r2_drag: d.r2,
        r2_lift: l.r2,
        rmse_drag_n: d.rmse,
        rmse_lift_n: l.rmse,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn psi_is_inflated_by_a_mean_that_r2_ignores() {
        // A constant offset prediction of a large, nearly constant force.
        let meas: Vec<f64> = (0..100).map(|i| 100.0 + (i as f64 * 0.3).sin()).collect();
        let pred = vec![100.0; 100];
        let f = component_fit(&pred, &meas);
        assert!(f.psi > 0.999 && f.r2 < 0.01, "{f:?}");
        assert!((f.rmse - (0.5f64).sqrt()).abs() < 0.05);
    }

    #[test]
    fn degenerate_inputs_give_numbers_not_nan() {
        let f = component_fit(&[1.0, 1.0], &[0.0, 0.0]);
        assert_eq!((f.psi, f.r2), (0.0, 0.0));
        assert_eq!(component_fit(&[], &[]).rmse, 0.0);
    }
}
