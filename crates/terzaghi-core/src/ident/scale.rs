//! Online identification of RFT's overall scale: the single factor by which a medium's RFT
//! stresses are scaled (Li, Zhang and Goldman fit one per medium), learnt from measured drag and
//! lift as the flat plate's `b_k` is, with the same safeguards: Huber weights on the
//! innovations, an excitation gate, a stuck-sensor check, forgetting over strokes, bounds, a
//! convergence gate and CUSUM change detection ([`super::online`]'s shared parts).
//!
//! The measurement is `y = s p`, `p` RFT's unit-scale prediction of drag and lift at the sample
//! (which the caller evaluates: the leg's shape, its hip and velocities are the model's); the
//! state is `ln s`, so that the scale stays positive.

use super::Sample;
use super::online::{
    Estimate, Innovations, NoiseRows, OnlineOptions, Skip, StuckDetector, angle_step,
    forgetting_factor,
};

/// Bounds of the scale.
pub const SCALE_RANGE: (f64, f64) = (0.05, 20.0);
/// Prior standard deviation of `ln s` (RFT's coefficients are the start: `s = 1`), and the
/// covariance's ceiling.
const INITIAL_STD_LN: f64 = 1.0;
/// A stroke's penetration, for forgetting over strokes (about a third of a turn for the legs
/// RFT serves).
const SPAN_RAD: f64 = 2.0;

/// The estimator of one leg.
#[derive(Debug, Clone)]
pub struct ScaleEstimator {
    opts: OnlineOptions,
    ln_s: f64,
    p: f64,
    innov: Innovations,
    /// Rows since the start or the last change (RFT's unit drag and lift, the measured ones):
    /// the sensor noise is measured from them once the scale converges, before the change
    /// detection is armed.
    noise_rows: NoiseRows<4>,
    stuck: StuckDetector,
    prev_beta: Option<f64>,
    updates_since_reset: u64,
    est: Estimate,
}

impl ScaleEstimator {
    /// Starts at `s = 1`, RFT's coefficients as given; `opts` as the flat plate's estimator
    /// takes them (its `b_k`, `a` and `delta` options do not apply).
    pub fn new(opts: OnlineOptions) -> ScaleEstimator {
        let mut e = ScaleEstimator {
            opts,
            ln_s: 0.0,
            p: INITIAL_STD_LN.powi(2),
            innov: Innovations::new(opts.initial_noise_n),
            noise_rows: NoiseRows::default(),
            stuck: StuckDetector::default(),
            prev_beta: None,
            updates_since_reset: 0,
            est: Estimate {
                b_k: 1.0,
                a: 1.0,
                delta_deg: 0.0,
                std_b_k: INITIAL_STD_LN,
                std_a: 0.0,
                std_delta_deg: 0.0,
                samples_used: 0,
                samples_non_finite: 0,
                samples_not_excited: 0,
                samples_stuck: 0,
                innovation_rms_n: 0.0,
                noise_n: opts.initial_noise_n,
                converged: false,
                changes_detected: 0,
            },
        };
        e.refresh();
        e
    }

    /// The current scale and its standard deviation.
    pub fn scale(&self) -> (f64, f64) {
        (self.est.b_k, self.est.std_b_k)
    }

    /// The estimate in the flat plate's terms: `b_k` is the scale (and `std_b_k` its standard
    /// deviation), `a` is 1; the counters and the convergence as the plate's.
    pub fn estimate(&self) -> &Estimate {
        &self.est
    }

    /// Feeds one measured sample with RFT's unit-scale prediction `unit_n = [drag, lift]` there.
    pub fn update(&mut self, s: &Sample, unit_n: [f64; 2]) -> Result<(), Skip> {
        let r = self.update_inner(s, unit_n);
        match r {
            Ok(()) => self.est.samples_used += 1,
            Err(Skip::NonFinite) => self.est.samples_non_finite += 1,
            Err(Skip::NotExcited) => self.est.samples_not_excited += 1,
            Err(Skip::Stuck) => self.est.samples_stuck += 1,
        }
        r
    }

    fn update_inner(&mut self, s: &Sample, unit_n: [f64; 2]) -> Result<(), Skip> {
        let values = [s.beta_rad, s.drag_n, s.lift_n, unit_n[0], unit_n[1]];
        if values.iter().any(|v| !v.is_finite()) || s.t_s.is_some_and(|t| !t.is_finite()) {
            return Err(Skip::NonFinite);
        }
        let stuck = self.stuck.see(s.drag_n, s.lift_n) >= self.opts.stuck_samples;
        let beta = s.beta_rad.rem_euclid(std::f64::consts::TAU);
        let dbeta = self.prev_beta.map_or(0.0, |p| angle_step(p, beta));
        self.prev_beta = Some(beta);
        if stuck {
            return Err(Skip::Stuck);
        }
        if unit_n[0].hypot(unit_n[1]) < self.opts.min_unit_force_n {
            return Err(Skip::NotExcited);
        }
        let o = self.opts;
        let scale = self.ln_s.exp();
        let mut nis = 0.0;
        for (y, u) in [(s.drag_n, unit_n[0]), (s.lift_n, unit_n[1])] {
            // d(s u)/d(ln s) = s u, at the scale before this sample.
            let h = scale * u;
            let e = y - scale * u;
            let hph = h * h * self.p;
            let (r, nis_i) = self.innov.row(e, hph, &o);
            nis += nis_i;
            let k = self.p * h / (hph + r);
            self.ln_s += k * e;
            self.p *= 1.0 - k * h;
        }
        self.innov.floor_noise();
        self.p /= forgetting_factor(&o, dbeta, SPAN_RAD);
        self.p = self.p.clamp(1e-12, INITIAL_STD_LN.powi(2));
        self.ln_s = self.ln_s.clamp(SCALE_RANGE.0.ln(), SCALE_RANGE.1.ln());
        self.updates_since_reset += 1;
        if self.innov.change_alarm(nis, 2.0, &o) {
            // The medium changed: learn the scale again from where it is.
            self.est.changes_detected += 1;
            self.p = INITIAL_STD_LN.powi(2);
            self.innov.disarm();
            self.noise_rows.clear();
            self.updates_since_reset = 0;
        }
        self.refresh();
        if !self.innov.armed() {
            self.noise_rows
                .push([unit_n[0], unit_n[1], s.drag_n, s.lift_n]);
            if self.est.converged {
                self.measure_noise();
            }
        }
        Ok(())
    }

    /// At convergence, before the change detection is armed: the scale becomes the one the
    /// kept rows hold by least squares (the Huber weights of a noise assumed too low hold the
    /// recursive one back), and the noise is raised to their residuals'
    /// ([`Innovations::raise_noise`]), the covariance with it. Converged still, the change
    /// detection is armed; if not, rows are kept again until it is.
    fn measure_noise(&mut self) {
        let (uy, uu) = self
            .noise_rows
            .rows()
            .fold((0.0, 0.0), |(uy, uu), &[ud, ul, d, l]| {
                (uy + ud * d + ul * l, uu + ud * ud + ul * ul)
            });
        let scale = uy / uu;
        let var = self
            .noise_rows
            .noise_var(1, |&[unit_d, unit_l, drag, lift]| {
                [drag - scale * unit_d, lift - scale * unit_l]
            });
        if let Some(var) = var.filter(|_| scale > 0.0) {
            self.ln_s = scale.ln().clamp(SCALE_RANGE.0.ln(), SCALE_RANGE.1.ln());
            let grew = self.innov.raise_noise(var);
            self.p = (self.p * grew).clamp(1e-12, INITIAL_STD_LN.powi(2));
            self.refresh();
        }
        if self.est.converged {
            self.innov.arm();
        }
    }

    fn refresh(&mut self) {
        let o = &self.opts;
        let sd = self.p.max(0.0).sqrt();
        let e = &mut self.est;
        e.b_k = self.ln_s.exp();
        e.std_b_k = e.b_k * sd;
        e.innovation_rms_n = self.innov.innov_ms.sqrt();
        e.noise_n = self.innov.noise_var.sqrt();
        e.converged = self.updates_since_reset >= o.converge_min_updates
            && sd < o.converge_rel_std
            && self.innov.cusum < 0.5 * o.cusum_alarm;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// A leg whose medium is 1.4 times as strong as RFT's coefficients say, then (after a step)
    /// 0.8 times: learnt to 2 %, the step detected and followed.
    #[test]
    fn learns_the_scale_and_follows_a_step() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let mut est = ScaleEstimator::new(OnlineOptions::default());
        let mut t = 0.0;
        let mut run = |est: &mut ScaleEstimator, truth: f64, turns: usize| {
            for _ in 0..turns * 400 {
                t += 0.0025;
                let beta = (3.0 * t) % std::f64::consts::TAU;
                // A unit prediction that is in the medium for a third of a turn.
                let inside = beta < 2.0;
                let unit = if inside {
                    [8.0 * beta.sin(), 5.0 * (1.0 + beta.cos())]
                } else {
                    [0.0, 0.0]
                };
                let s = Sample {
                    t_s: Some(t),
                    beta_rad: beta,
                    drag_n: truth * unit[0] + rng.random_range(-0.3..0.3),
                    lift_n: truth * unit[1] + rng.random_range(-0.3..0.3),
                };
                let _ = est.update(&s, unit);
            }
        };
        run(&mut est, 1.4, 6);
        let (s, sd) = est.scale();
        assert!((s - 1.4).abs() < 0.02 * 1.4, "{s} +- {sd}");
        assert!(
            est.estimate().converged && sd < 0.02 * s,
            "{:?}",
            est.estimate()
        );
        assert!(est.estimate().samples_not_excited > 0);
        run(&mut est, 0.8, 6);
        let (s, _) = est.scale();
        assert!(est.estimate().changes_detected >= 1, "{:?}", est.estimate());
        assert!((s - 0.8).abs() < 0.02 * 0.8, "{s}");
        // A non-finite sample is counted and skipped, the scale unchanged.
        let before = est.scale();
        let bad = Sample {
            t_s: Some(t),
            beta_rad: 0.5,
            drag_n: f64::NAN,
            lift_n: 1.0,
        };
        assert_eq!(est.update(&bad, [1.0, 1.0]), Err(Skip::NonFinite));
        assert_eq!(est.scale(), before);
    }

    /// A sensor noisier than configured: the noise is measured before the change detection is
    /// armed, so that a steady medium raises no change, and a step still does (also where the
    /// noise is configured higher than it is).
    /// Without that, a noise of 2 % of the peak force (1.95 N) against the configured 1 N raised
    /// a change in 96 of 100 such sessions.
    #[test]
    fn the_noise_is_measured_so_that_no_change_is_raised_on_a_steady_medium() {
        use crate::model::{FittingWidth, Medium, Plate, TerzaghiModel};
        use rand_distr::{Distribution, Normal};
        let unit = TerzaghiModel::new(
            Plate::new(0.25, 0.06, 0.15).unwrap(),
            Medium::new(16170.0, 32.0, 19.0).unwrap(),
            FittingWidth::new(3.0, 1.8).unwrap(),
        );
        // 250 Hz at 4 rad/s; the scale 1.3 (a peak force of 97 N), or 0.9 from mid-session.
        let session = |est: &mut ScaleEstimator, seed: u64, strokes: f64, step: bool| {
            let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
            let noise = Normal::new(0.0, 1.95).unwrap();
            let n = (strokes * std::f64::consts::TAU / 4.0 * 250.0) as usize;
            for k in 0..n {
                let truth = if step && k > n / 2 { 0.9 } else { 1.3 };
                let beta = (4.0 * k as f64 / 250.0).rem_euclid(std::f64::consts::TAU);
                let p = unit.evaluate(beta).unwrap().prediction();
                let s = Sample {
                    t_s: Some(k as f64 / 250.0),
                    beta_rad: beta,
                    drag_n: truth * p.drag_n + noise.sample(&mut rng),
                    lift_n: truth * p.lift_n + noise.sample(&mut rng),
                };
                let _ = est.update(&s, [p.drag_n, p.lift_n]);
            }
        };
        for initial_noise_n in [0.3, 1.0, 5.0] {
            let opts = OnlineOptions {
                initial_noise_n,
                ..OnlineOptions::default()
            };
            for seed in 0..8 {
                let mut est = ScaleEstimator::new(opts);
                session(&mut est, seed, 8.0, false);
                let e = est.estimate();
                let what = format!("configured {initial_noise_n} N, seed {seed}: {e:?}");
                assert_eq!(e.changes_detected, 0, "{what}");
                assert!(e.converged && (e.b_k / 1.3 - 1.0).abs() < 0.02, "{what}");
                if initial_noise_n < 1.95 {
                    assert!((e.noise_n / 1.95 - 1.0).abs() < 0.2, "{what}");
                }
            }
            let mut est = ScaleEstimator::new(opts);
            session(&mut est, 9, 16.0, true);
            let e = est.estimate();
            let what = format!("configured {initial_noise_n} N, a step: {e:?}");
            assert_eq!(e.changes_detected, 1, "{what}");
            assert!(e.converged && (e.b_k / 0.9 - 1.0).abs() < 0.02, "{what}");
        }
    }
}
