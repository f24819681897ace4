//! Online identification of a plate pushed into a calibrated medium: the medium's scale under
//! this plate (how much stronger or weaker this patch of ground is than the calibration) and
//! the surface's level (where the plate first meets the ground, which a robot or a testbed
//! knows only to a millimetre or two).
//!
//! The measurement is the logarithm of the vertical force, `ln F = ln s + ln L(z + dz)`: `L` the
//! calibrated law at the plate's depth `z` as given (the hip's), `s` the scale and `dz` the
//! surface's height above where the hip's height puts it (positive: the plate is deeper). A
//! relative error is a granular force's: it scatters in proportion to its size.
//!
//! Why both: in the first millimetres the law's force is near zero while the plate already
//! bears a newton or two, because the surface is higher than the depth's zero says (0.1-1 mm on
//! the shared plate-sinkage runs). A scale alone reads that as a medium 30 times stronger; the
//! surface's level explains it, and then the first rows teach the scale too.
//!
//! The state is `x = (ln s, dz)`, a Kalman filter's with the calibration as its prior: `ln s`
//! is 0 with [`SinkageOptions::prior_scale_rel_std`] (tests of one sand scatter by about 10 %
//! from run to run), `dz` is 0 with [`SinkageOptions::prior_surface_std_m`]. The scale walks
//! ([`SinkageOptions::scale_walk_per_sqrt_mm`]) because the law's ratio to the force drifts slowly
//! with depth within one intrusion; the surface does not. The measurement is strongly
//! nonlinear in `dz` near the surface (`d ln L / dz = n / (z + dz)`), so each row is an iterated
//! update (Gauss-Newton on the row's posterior), not a single linearisation. Innovations past
//! [`SinkageOptions::huber_k`] standard deviations are weighted down (a sensor's spikes).
//!
//! Converged means the force is known well enough to predict with: the scale itself to
//! [`SinkageOptions::converge_rel_std`], or the force at the plate's present depth to that
//! share, after [`SinkageOptions::converge_min_updates`] rows. Lifted clear of the surface
//! ([`SinkageEstimator::left_medium`]), the plate keeps its scale and forgets the surface's
//! level: the next intrusion may meet the ground elsewhere.
//!
//! Rows the law does not predict teach nothing: the caller passes only loaded rows (the plate
//! moving down), and the estimator skips a force under [`SinkageOptions::min_force_n`] and a
//! reading that repeats the one before it exactly (a sample-and-hold sensor's held value).

use super::Estimate;
use super::online::Skip;
use super::surface::SurfaceEstimate;
use crate::model::ModelError;
use crate::model::sinkage::{PlateShape, SinkageModel};
use nalgebra::{Matrix2, Vector2};

/// The options of a [`SinkageEstimator`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SinkageOptions {
    /// Prior relative standard deviation of the scale: how far a test of the calibrated sand
    /// may stand from the calibration.
    pub prior_scale_rel_std: f64,
    /// Prior standard deviation of the surface's level (m).
    pub prior_surface_std_m: f64,
    /// Standard deviation of the scale's relative walk per square root of a millimetre the
    /// plate sinks: the law's ratio to the force drifts with depth, not with time, so a plate
    /// held still or a faster sensor does not loosen it.
    pub scale_walk_per_sqrt_mm: f64,
    /// Relative standard deviation of a row's force about the law.
    pub rel_noise: f64,
    /// Innovations beyond this many standard deviations are weighted down (Huber).
    pub huber_k: f64,
    /// Relative standard deviation of the scale, or of the force at the present depth, below
    /// which the estimate is used.
    pub converge_rel_std: f64,
    /// Rows before the estimate may be used: one more than the two values it holds.
    pub converge_min_updates: u64,
    /// Measured forces below this (N) teach nothing: the sensor's noise, not the medium.
    pub min_force_n: f64,
    /// A plate this far above the learnt surface (m) has left the medium.
    pub clear_of_surface_m: f64,
}

impl Default for SinkageOptions {
    fn default() -> Self {
        SinkageOptions {
            prior_scale_rel_std: 0.10,
            prior_surface_std_m: 0.002,
            scale_walk_per_sqrt_mm: 0.03,
            rel_noise: 0.05,
            huber_k: 2.5,
            converge_rel_std: 0.05,
            converge_min_updates: 3,
            min_force_n: 0.5,
            clear_of_surface_m: 0.005,
        }
    }
}

impl SinkageOptions {
    /// Checks every option: finite and positive (the minimum force may be 0).
    pub fn validate(&self) -> Result<(), ModelError> {
        for (what, v) in [
            ("prior_scale_rel_std", self.prior_scale_rel_std),
            ("prior_surface_std_m", self.prior_surface_std_m),
            ("scale_walk_per_sqrt_mm", self.scale_walk_per_sqrt_mm),
            ("rel_noise", self.rel_noise),
            ("huber_k", self.huber_k),
            ("converge_rel_std", self.converge_rel_std),
            ("clear_of_surface_m", self.clear_of_surface_m),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(ModelError::OutOfRange {
                    what,
                    value: v,
                    range: "> 0".into(),
                });
            }
        }
        if !(self.min_force_n.is_finite() && self.min_force_n >= 0.0) {
            return Err(ModelError::OutOfRange {
                what: "min_force_n",
                value: self.min_force_n,
                range: ">= 0".into(),
            });
        }
        Ok(())
    }
}

/// Bounds of the scale.
const SCALE_RANGE: (f64, f64) = (0.05, 20.0);
/// The surface is learnt within this of where the hip's height puts it (m).
const MAX_SURFACE_OFFSET_M: f64 = 0.05;
/// The law is evaluated no shallower than this (m): its logarithm falls without bound at the
/// surface.
const MIN_DEPTH_M: f64 = 1e-5;
/// Iterations of a row's update at most.
const ITERATIONS: usize = 20;

/// The estimator of one plate.
#[derive(Debug, Clone)]
pub struct SinkageEstimator {
    law: SinkageModel,
    shape: PlateShape,
    opts: SinkageOptions,
    x: Vector2<f64>,
    p: Matrix2<f64>,
    updates: u64,
    /// The last lift read, to skip a held value.
    last_lift_n: Option<f64>,
    /// The depth of the last row learnt from (m, as given).
    last_depth_m: f64,
    est: Estimate,
    surface: SurfaceEstimate,
}

impl SinkageEstimator {
    /// The estimator of a plate of `shape` in the medium of `law`, starting from the law as
    /// calibrated and the surface where the hip's height puts it.
    pub fn new(
        law: SinkageModel,
        shape: PlateShape,
        opts: SinkageOptions,
    ) -> Result<Self, ModelError> {
        opts.validate()?;
        let mut e = SinkageEstimator {
            law,
            shape,
            opts,
            x: Vector2::zeros(),
            p: Matrix2::from_diagonal(&Vector2::new(
                opts.prior_scale_rel_std.powi(2),
                opts.prior_surface_std_m.powi(2),
            )),
            updates: 0,
            last_lift_n: None,
            last_depth_m: 0.0,
            est: Estimate {
                b_k: 1.0,
                a: 1.0,
                std_b_k: opts.prior_scale_rel_std,
                ..Estimate::default()
            },
            surface: SurfaceEstimate::default(),
        };
        e.refresh();
        Ok(e)
    }

    /// The estimate in the flat plate's terms: `b_k` is the scale (and `std_b_k` its standard
    /// deviation), `a` is 1; `converged` says whether it is used.
    pub fn estimate(&self) -> &Estimate {
        &self.est
    }

    /// The surface's level as learnt (its `converged` is the scale's).
    pub fn surface(&self) -> &SurfaceEstimate {
        &self.surface
    }

    /// The scale and the surface's offset (m) to predict with.
    pub fn scale_and_offset(&self) -> (f64, f64) {
        (self.x[0].exp(), self.x[1])
    }

    /// `ln L` at depth `z_m` (the law's force, floored at a micro-newton) and its derivative by
    /// depth.
    fn ln_law(&self, z_m: f64) -> (f64, f64) {
        let ln = |z: f64| self.law.force_n(&self.shape, z).max(1e-6).ln();
        let z = z_m.max(MIN_DEPTH_M);
        let h = z * 1e-4;
        let d = (ln(z + h) - ln(z - h)) / (2.0 * h);
        (ln(z), d)
    }

    /// Feeds one loaded row: the plate's depth below the surface as the hip's height gives it
    /// (m) and the measured upward force (N).
    pub fn update(&mut self, depth_m: f64, lift_n: f64) -> Result<(), Skip> {
        let r = self.update_inner(depth_m, lift_n);
        match r {
            Ok(()) => self.est.samples_used += 1,
            Err(Skip::NonFinite) => self.est.samples_non_finite += 1,
            Err(Skip::NotExcited) => self.est.samples_not_excited += 1,
            Err(Skip::Stuck) => self.est.samples_stuck += 1,
        }
        r
    }

    fn update_inner(&mut self, depth_m: f64, lift_n: f64) -> Result<(), Skip> {
        if !(depth_m.is_finite() && lift_n.is_finite()) {
            return Err(Skip::NonFinite);
        }
        let held = self.last_lift_n == Some(lift_n);
        self.last_lift_n = Some(lift_n);
        if held {
            return Err(Skip::Stuck);
        }
        if lift_n < self.opts.min_force_n.max(f64::MIN_POSITIVE)
            || depth_m + self.x[1] <= -self.opts.prior_surface_std_m
        {
            return Err(Skip::NotExcited);
        }
        let o = self.opts;
        // The scale walks with the depth sunk since the last row; the surface stays.
        let p = self.p + self.walk(depth_m);
        let x_prior = self.x;
        let y = lift_n.ln();
        let r_var = o.rel_noise.powi(2);
        let mut x = x_prior;
        let mut gain = Vector2::zeros();
        let mut h = Vector2::zeros();
        for _ in 0..ITERATIONS {
            let (ln_l, d) = self.ln_law(depth_m + x[1]);
            h = Vector2::new(1.0, d);
            let s = (h.transpose() * p * h)[0] + r_var;
            // The row's residual about the linearisation at x (an iterated update).
            let r = y - (x[0] + ln_l) - (h.transpose() * (x_prior - x))[0];
            let z = r / s.sqrt();
            let w = if z.abs() <= o.huber_k {
                1.0
            } else {
                o.huber_k / z.abs()
            };
            gain = p * h / (s / w);
            let mut next = x_prior + gain * r;
            next[0] = next[0].clamp(SCALE_RANGE.0.ln(), SCALE_RANGE.1.ln());
            // The plate stays below the surface it is measured in.
            next[1] = next[1].clamp(
                (MIN_DEPTH_M - depth_m).max(-MAX_SURFACE_OFFSET_M),
                MAX_SURFACE_OFFSET_M,
            );
            let step = (next - x).abs().max();
            x = next;
            if step < 1e-10 {
                break;
            }
        }
        let p = p - gain * (h.transpose() * p);
        self.p = (p + p.transpose()) * 0.5;
        // The scale is known no worse than the calibration.
        if self.p[(0, 0)] > o.prior_scale_rel_std.powi(2) {
            let k = o.prior_scale_rel_std / self.p[(0, 0)].sqrt();
            self.p[(0, 0)] *= k * k;
            self.p[(0, 1)] *= k;
            self.p[(1, 0)] *= k;
        }
        self.x = x;
        self.updates += 1;
        self.last_depth_m = depth_m;
        let predicted = x[0].exp() * self.law.force_n(&self.shape, depth_m + x[1]);
        // The noise assumed of the row, in newtons: relative to the force there.
        self.est.noise_n = o.rel_noise * predicted;
        let e = lift_n - predicted;
        self.est.innovation_rms_n = if self.updates == 1 {
            e.abs()
        } else {
            (0.9 * self.est.innovation_rms_n.powi(2) + 0.1 * e * e).sqrt()
        };
        self.refresh();
        Ok(())
    }

    /// Tells the estimator where the plate is while it is not loading: lifted `clear_of_surface_m`
    /// above the learnt surface, it has left the medium, and the surface's level is learnt
    /// afresh in the next intrusion (the scale is kept).
    pub fn left_medium(&mut self, depth_m: f64) {
        if !depth_m.is_finite() || depth_m + self.x[1] > -self.opts.clear_of_surface_m {
            return;
        }
        self.x[1] = 0.0;
        self.p[(0, 1)] = 0.0;
        self.p[(1, 0)] = 0.0;
        self.p[(1, 1)] = self.opts.prior_surface_std_m.powi(2);
        self.last_lift_n = None;
        self.refresh();
    }

    /// The scale's walk (its variance) from the last row learnt to depth `depth_m`.
    fn walk(&self, depth_m: f64) -> Matrix2<f64> {
        let sunk_mm = if self.updates == 0 {
            0.0
        } else {
            ((depth_m - self.last_depth_m) * 1e3).max(0.0)
        };
        Matrix2::new(
            self.opts.scale_walk_per_sqrt_mm.powi(2) * sunk_mm,
            0.0,
            0.0,
            0.0,
        )
    }

    fn refresh(&mut self) {
        let o = &self.opts;
        let sd_ln_s = self.p[(0, 0)].max(0.0).sqrt();
        let s = self.x[0].exp();
        // The force at the present depth: the scale's and the surface's uncertainties with
        // their correlation.
        let (_, d) = self.ln_law(self.last_depth_m + self.x[1]);
        let h = Vector2::new(1.0, d);
        let sd_force = (h.transpose() * self.p * h)[0].max(0.0).sqrt();
        let e = &mut self.est;
        e.b_k = s;
        e.std_b_k = s * sd_ln_s;
        e.converged = self.updates >= o.converge_min_updates
            && (sd_ln_s < o.converge_rel_std || sd_force < o.converge_rel_std);
        self.surface = SurfaceEstimate {
            offset_m: self.x[1],
            std_offset_m: self.p[(1, 1)].max(0.0).sqrt(),
            samples_used: e.samples_used,
            samples_skipped: e.samples_non_finite + e.samples_not_excited + e.samples_stuck,
            converged: e.converged,
            changes_detected: 0,
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::sinkage::SinkageLaw;
    use rand::{Rng, SeedableRng};

    fn law() -> SinkageModel {
        SinkageModel::new(
            SinkageLaw::DepthWidthPower,
            vec![2800.0, 1.3, 1.0],
            13_000.0,
            0.254,
        )
        .unwrap()
    }

    fn disc() -> PlateShape {
        PlateShape::disc(0.08).unwrap()
    }

    /// An intrusion from the surface to 40 mm in rows 0.3 mm apart, the ground `s` times the
    /// law and `dz` higher than the depth's zero, with 3 % relative noise.
    fn intrusion(s: f64, dz: f64, seed: u64) -> Vec<(f64, f64)> {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        (1..=130)
            .map(|i| {
                let z = 0.3e-3 * f64::from(i);
                let f =
                    s * law().force_n(&disc(), z + dz) * (1.0 + 0.03 * rng.random_range(-1.7..1.7));
                (z, f)
            })
            .collect()
    }

    #[test]
    fn the_scale_and_the_surface_are_found() {
        for (s, dz) in [(1.0, 0.0), (1.15, 0.8e-3), (0.9, -0.5e-3), (1.2, 1.5e-3)] {
            let mut e = SinkageEstimator::new(law(), disc(), SinkageOptions::default()).unwrap();
            for (z, f) in intrusion(s, dz, 3) {
                let _ = e.update(z, f);
            }
            let (got_s, got_dz) = e.scale_and_offset();
            assert!((got_s / s - 1.0).abs() < 0.03, "scale {got_s} for {s}");
            assert!((got_dz - dz).abs() < 0.3e-3, "surface {got_dz} for {dz}");
            assert!(e.estimate().converged);
        }
    }

    /// The first rows of an intrusion whose surface is 1 mm higher: the force there is known
    /// to 5 % within a few rows, though the law alone gives a tenth of it.
    #[test]
    fn a_higher_surface_is_learnt_in_the_first_rows() {
        let mut e = SinkageEstimator::new(law(), disc(), SinkageOptions::default()).unwrap();
        let rows = intrusion(1.0, 1e-3, 5);
        let mut first_converged = None;
        for (i, (z, f)) in rows.iter().enumerate() {
            let _ = e.update(*z, *f);
            if e.estimate().converged && first_converged.is_none() {
                first_converged = Some(i);
            }
        }
        let i = first_converged.unwrap();
        assert!(i < 10, "converged at row {i}");
    }

    #[test]
    fn spikes_and_held_values_do_not_move_it() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let mut clean = SinkageEstimator::new(law(), disc(), SinkageOptions::default()).unwrap();
        let mut spiky = clean.clone();
        for (z, f) in intrusion(1.1, 0.5e-3, 7) {
            let _ = clean.update(z, f);
            let f = if rng.random_bool(0.01) { f * 10.0 } else { f };
            let _ = spiky.update(z, f);
            // Held: the same reading again.
            let _ = spiky.update(z + 0.1e-3, f);
        }
        let (a, b) = (clean.scale_and_offset().0, spiky.scale_and_offset().0);
        assert!((a / b - 1.0).abs() < 0.03, "{a} against {b}");
        assert!(spiky.estimate().samples_stuck > 100);
    }

    #[test]
    fn leaving_the_medium_keeps_the_scale_and_forgets_the_surface() {
        let mut e = SinkageEstimator::new(law(), disc(), SinkageOptions::default()).unwrap();
        for (z, f) in intrusion(1.2, 1e-3, 9) {
            let _ = e.update(z, f);
        }
        let s = e.scale_and_offset().0;
        e.left_medium(-0.002);
        assert!(e.surface().offset_m != 0.0, "2 mm above is not clear of it");
        e.left_medium(-0.05);
        assert_eq!(e.scale_and_offset(), (s, 0.0));
        assert!(e.estimate().converged, "the scale is still known");
    }

    #[test]
    fn bad_rows_are_skipped_and_counted() {
        let mut e = SinkageEstimator::new(law(), disc(), SinkageOptions::default()).unwrap();
        assert_eq!(e.update(f64::NAN, 3.0), Err(Skip::NonFinite));
        assert_eq!(e.update(0.01, f64::INFINITY), Err(Skip::NonFinite));
        assert_eq!(e.update(0.01, 0.1), Err(Skip::NotExcited));
        assert_eq!(e.update(-0.5, 30.0), Err(Skip::NotExcited));
        assert_eq!(e.estimate().samples_non_finite, 2);
        assert_eq!(e.estimate().samples_not_excited, 2);
        assert_eq!(e.scale_and_offset(), (1.0, 0.0));
        let bad = SinkageOptions {
            rel_noise: f64::NAN,
            ..SinkageOptions::default()
        };
        let err = SinkageEstimator::new(law(), disc(), bad).unwrap_err();
        assert!(err.to_string().contains("rel_noise"), "{err}");
    }
}
