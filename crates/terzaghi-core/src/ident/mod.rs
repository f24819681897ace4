//! Identification of the fitting width `b_k, a` (Eq. 11), and optionally `delta`, from measured
//! drag and lift; online, also of a corrected model's coefficients ([`corrected`]). Pure:
//! samples in, estimates out.
//!
//! Every Terzaghi force is `b_k a^(-beta) F_unit(beta)`, and `delta` enters only through
//! `F_pT = F_pN tan(delta)`, so a prediction at a sample needs just the unit normal force
//! `N(beta)`: `D = s N (sin b - t cos b)`, `L = s N (cos b + t sin b)`, `s = b_k a^(-b)`,
//! `t = tan(delta)`. [`UnitSample`] carries that.

pub mod batch;
pub mod corrected;
pub mod metrics;
pub mod online;
pub mod rft_shape;
pub mod scale;
pub mod scatter;
pub mod sheared;
pub mod sinkage;
pub mod sinkage_online;
pub mod surface;

pub use batch::{BatchFit, BatchOptions, fit_batch};
pub use corrected::{Coefficient, CorrectedEstimator};
pub use metrics::{ComponentFit, FitSums, GoodnessOfFit, goodness_of_fit};
pub use online::{Estimate, OnlineEstimator, OnlineOptions};
pub use scale::ScaleEstimator;
pub use sinkage_online::{SinkageEstimator, SinkageOptions};
pub use surface::{SurfaceEstimate, SurfaceEstimator};

use crate::model::{ModelError, Regime, TerzaghiModel};

/// One measurement: attack angle and the forces the medium exerted on the plate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time (s), if the log has one: the online estimator's forgetting and the diagnosis's
    /// speeds need it.
    pub t_s: Option<f64>,
    /// Attack angle (rad).
    pub beta_rad: f64,
    /// Measured drag, in the hip frame (N).
    pub drag_n: f64,
    /// Measured lift, in the hip frame (N).
    pub lift_n: f64,
}

/// What is wrong with a set of samples.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IdentError {
    /// Too few samples a fit can use.
    #[error(
        "too few usable samples: {usable} of {total} (need at least {needed}; {non_finite} non-finite, {outside} outside the fitted regimes or out of the medium)"
    )]
    TooFewSamples {
        /// Samples the fit can use.
        usable: usize,
        /// Samples given.
        total: usize,
        /// Samples a fit needs.
        needed: usize,
        /// Samples with a non-finite value.
        non_finite: usize,
        /// Samples outside the fitted regimes or out of the medium.
        outside: usize,
    },
    /// Every measured force is zero.
    #[error("the measured forces are all zero: nothing to fit")]
    NoForce,
    /// The fit ran off to a value that is not a number: the samples do not determine it.
    #[error(
        "the fit does not converge (b_k = {b_k}, a = {a}, delta = {delta_deg} deg): the {samples} usable samples do not determine the width law; check the log's units (radians, newtons) and its attack angles"
    )]
    NoFit {
        /// `b_k` where the fit stopped.
        b_k: f64,
        /// `a` where the fit stopped.
        a: f64,
        /// The plate friction angle where the fit stopped (deg).
        delta_deg: f64,
        /// Samples the fit used.
        samples: usize,
    },
    /// The model refused an input.
    #[error(transparent)]
    Model(#[from] ModelError),
}

/// A sample paired with the unit model's normal force at its angle (`b_k = a = 1`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnitSample {
    /// Attack angle (rad).
    pub beta_rad: f64,
    /// `sin beta`.
    pub sin_beta: f64,
    /// `cos beta`.
    pub cos_beta: f64,
    /// `F_pN` with `b_e = b`, N.
    pub normal_unit_n: f64,
    /// Measured drag (N).
    pub drag_n: f64,
    /// Measured lift (N).
    pub lift_n: f64,
    /// The unit model's regime at the angle.
    pub regime: Regime,
}

impl UnitSample {
    /// Pairs a sample with `unit_model` (a model with `b_k = a = 1`); `None` if any value is
    /// non-finite.
    pub fn new(unit_model: &TerzaghiModel, s: &Sample) -> Option<UnitSample> {
        if !(s.beta_rad.is_finite() && s.drag_n.is_finite() && s.lift_n.is_finite()) {
            return None;
        }
        let f = unit_model.evaluate(s.beta_rad).ok()?;
        let (sin_beta, cos_beta) = f.beta_rad.sin_cos();
        Some(UnitSample {
            beta_rad: f.beta_rad,
            sin_beta,
            cos_beta,
            normal_unit_n: f.normal_n,
            drag_n: s.drag_n,
            lift_n: s.lift_n,
            regime: f.regime,
        })
    }

    /// Predicted `(drag, lift)` for `b_k a^(-beta)` = `scale` and `tan(delta)` = `tan_delta`.
    pub fn predict(&self, scale: f64, tan_delta: f64) -> (f64, f64) {
        let n = scale * self.normal_unit_n;
        (
            n * (self.sin_beta - tan_delta * self.cos_beta),
            n * (self.cos_beta + tan_delta * self.sin_beta),
        )
    }
}
