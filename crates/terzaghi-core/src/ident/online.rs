//! Online identification of `b_k, a` (and optionally `delta`), sample by sample.
//!
//! The state is `theta = (ln b_k, ln a, delta)`; every sample gives two rows, drag and lift:
//! `D = s N (sin b - tan(delta) cos b)`, `L = s N (cos b + tan(delta) sin b)`,
//! `s = exp(theta_0 - beta theta_1)`, `N` the unit-width normal force of the model at `beta`.
//! The update is a recursive Gauss–Newton (extended Kalman) step on the raw forces:
//! `K = P H^T (H P H^T + R)^-1`, `theta += K e`, `P = (I - K H) P (I - K H)^T + K R K^T`, then
//! forgetting `P /= lambda`. `P` is the covariance of `theta` (it carries the noise variance), so
//! the reported standard deviations come straight from it.
//!
//! Until `startup_samples` samples have been used, a log-linear RLS (`ln(F / F_unit) =
//! ln b_k - beta ln a`, linear in `theta`) runs instead: it cannot overshoot from a far start, but
//! is biased where forces are small, so it only initialises the Gauss–Newton step.
//!
//! Robustness, each an option of [`OnlineOptions`]:
//! - forgetting by the angle swept while updating (memory in strokes, whatever the sample rate
//!   or speed), or a fixed factor per sample; `P` is bounded so it cannot wind up;
//! - an excitation gate: only penetration samples whose unit-width force is above a threshold;
//! - Huber weights on standardized innovations, and detection of a stuck sensor;
//! - bounds on `b_k`, `a`, `delta` (projection), and non-finite samples skipped and counted;
//! - change detection: a CUSUM of clipped squared standardized innovations, standardized by the
//!   sensor noise measured from the start-up's residuals (and followed after); on an alarm the
//!   covariance is re-opened and the event reported.
//!
//! Convergence rule: `converged` is true when at least `converge_min_updates` updates have been
//! made since the start (or the last detected change), and the relative standard deviations of
//! `b_k` and `a` (that is, of `ln b_k` and `ln a`) are both below `converge_rel_std`, and the
//! CUSUM statistic is below half its alarm level.

use super::Sample;
use crate::model::{FittingWidth, HipMotion, ModelError, Regime, TerzaghiModel};
use nalgebra::{Matrix2, Matrix3, Matrix3x2, Vector2, Vector3};
use serde::Serialize;
use std::f64::consts::FRAC_PI_2;

/// The share of a stroke's penetration span the start-up's samples must cover before `a` is
/// fitted (and the Gauss–Newton step takes over).
pub const STARTUP_SPAN_FRAC: f64 = 0.25;

/// How far a start-up reading's log residual must lie from a robust fit of all of them, in
/// median absolute deviations (scaled to a standard deviation), to be left out as a spike: a
/// reading ten times the force lies some hundred away, a noisy or misfitted one a few.
const START_OUTLIER_MADS: f64 = 8.0;

/// Rows kept to measure the sensor noise from (the newest): see [`NoiseRows`].
const NOISE_ROWS_KEPT: usize = 512;

/// How old information fades.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Forgetting {
    /// Memory in strokes: each update forgets `exp(-dbeta / (strokes * span))`, `dbeta` the
    /// angle swept since the previous sample and `span` the penetration span of one stroke.
    Strokes(f64),
    /// A fixed factor per update (`lambda` in `(0, 1]`), as in textbook RLS.
    PerSample(f64),
}

/// Options of the online estimator. Defaults suit a leg turning at 0.5–4 rad/s sampled at
/// 100 Hz–1 kHz with a sensor noise of a few percent of the peak force.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct OnlineOptions {
    /// Estimate `delta` too (observable from the drag/lift ratio).
    pub fit_delta: bool,
    /// Forgetting; default: a memory of three strokes.
    pub forgetting: Forgetting,
    /// Excitation gate: skip samples whose unit-width model force (`b_e = b`) is below this (N).
    pub min_unit_force_n: f64,
    /// Huber threshold on the standardized innovation (in standard deviations).
    pub huber_k: f64,
    /// Consecutive identical measurements that mark the sensor as stuck.
    pub stuck_samples: usize,
    /// Bounds on `b_k`.
    pub b_k_range: (f64, f64),
    /// Bounds on `a`.
    pub a_range: (f64, f64),
    /// Bounds on `delta` (deg).
    pub delta_range_deg: (f64, f64),
    /// Initial guess of `b_k` (default: the conventional model, 1).
    pub initial_b_k: f64,
    /// Initial guess of `a` (default 1).
    pub initial_a: f64,
    /// Initial standard deviation of `ln b_k` and `ln a`.
    pub initial_std_ln: f64,
    /// Initial standard deviation of `delta` (deg).
    pub initial_std_delta_deg: f64,
    /// Upper bound on the standard deviation of `ln b_k`, `ln a` (no wind-up beyond this).
    pub max_std_ln: f64,
    /// Initial sensor noise standard deviation (N): it weighs the start-up's samples; at the
    /// hand-over the noise is measured from the start-up's residuals, then followed from the
    /// innovations.
    pub initial_noise_n: f64,
    /// Samples used by the log-linear start-up before the Gauss–Newton step takes over.
    pub startup_samples: usize,
    /// Convergence rule: relative std of `b_k` and `a` below this ...
    pub converge_rel_std: f64,
    /// ... after at least this many updates.
    pub converge_min_updates: u64,
    /// CUSUM drift per sample (in units of squared standardized innovation).
    pub cusum_drift: f64,
    /// CUSUM alarm level (in the same units).
    pub cusum_alarm: f64,
}

impl Default for OnlineOptions {
    fn default() -> Self {
        OnlineOptions {
            fit_delta: false,
            forgetting: Forgetting::Strokes(3.0),
            min_unit_force_n: 0.5,
            huber_k: 2.5,
            stuck_samples: 8,
            b_k_range: (1e-3, 1e4),
            a_range: (0.05, 100.0),
            delta_range_deg: (0.0, 80.0),
            initial_b_k: 1.0,
            initial_a: 1.0,
            initial_std_ln: 2.0,
            initial_std_delta_deg: 10.0,
            max_std_ln: 3.0,
            initial_noise_n: 1.0,
            startup_samples: 40,
            converge_rel_std: 0.02,
            converge_min_updates: 50,
            cusum_drift: 1.0,
            cusum_alarm: 60.0,
        }
    }
}

/// What is wrong with the options; names the option and its value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OnlineOptionsError {
    /// An option outside what it can be.
    #[error("{name} = {value} is out of range: {expected}")]
    OutOfRange {
        /// The option's name.
        name: &'static str,
        /// The value given.
        value: f64,
        /// What it must be.
        expected: &'static str,
    },
}

impl OnlineOptions {
    /// Every option checked; the first one out of range is named with its value.
    pub fn validate(&self) -> Result<(), OnlineOptionsError> {
        let check = |name, value: f64, ok: bool, expected| {
            if value.is_finite() && ok {
                Ok(())
            } else {
                Err(OnlineOptionsError::OutOfRange {
                    name,
                    value,
                    expected,
                })
            }
        };
        match self.forgetting {
            Forgetting::Strokes(m) => check("forgetting memory (strokes)", m, m > 0.0, "> 0")?,
            Forgetting::PerSample(l) => {
                check("forgetting factor", l, l > 0.0 && l <= 1.0, "in (0, 1]")?
            }
        }
        let pos = |name, v: f64| check(name, v, v > 0.0, "> 0");
        check(
            "min_unit_force_n",
            self.min_unit_force_n,
            self.min_unit_force_n >= 0.0,
            ">= 0",
        )?;
        pos("huber_k", self.huber_k)?;
        pos("initial_b_k", self.initial_b_k)?;
        pos("initial_a", self.initial_a)?;
        pos("initial_std_ln", self.initial_std_ln)?;
        pos("initial_std_delta_deg", self.initial_std_delta_deg)?;
        pos("max_std_ln", self.max_std_ln)?;
        pos("initial_noise_n", self.initial_noise_n)?;
        pos("converge_rel_std", self.converge_rel_std)?;
        pos("cusum_alarm", self.cusum_alarm)?;
        check(
            "cusum_drift",
            self.cusum_drift,
            self.cusum_drift >= 0.0,
            ">= 0",
        )?;
        for (name, (lo, hi)) in [("b_k range", self.b_k_range), ("a range", self.a_range)] {
            check(
                name,
                lo,
                lo > 0.0 && hi > lo && hi.is_finite(),
                "0 < low < high",
            )?;
        }
        let (dlo, dhi) = self.delta_range_deg;
        check(
            "delta range (deg)",
            dlo,
            dlo >= 0.0 && dhi > dlo && dhi < 90.0,
            "0 <= low < high < 90",
        )?;
        let inside = |name, v: f64, (lo, hi): (f64, f64)| {
            check(name, v, v >= lo && v <= hi, "inside its range")
        };
        inside("initial_b_k", self.initial_b_k, self.b_k_range)?;
        inside("initial_a", self.initial_a, self.a_range)?;
        if self.stuck_samples < 2 {
            return Err(OnlineOptionsError::OutOfRange {
                name: "stuck_samples",
                value: self.stuck_samples as f64,
                expected: ">= 2",
            });
        }
        Ok(())
    }
}

/// Why a sample did not update the estimate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Skip {
    /// A non-finite angle or force.
    NonFinite,
    /// Outside the excitation gate (not penetration, or too little force to learn from).
    NotExcited,
    /// The sensor repeats the same value: stuck.
    Stuck,
}

/// A detected change of the medium.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ChangeEvent {
    /// The time of the sample that raised it (s), if the samples have times.
    pub t_s: Option<f64>,
    /// `b_k` just before the change was declared.
    pub b_k_before: f64,
    /// `a` just before the change was declared.
    pub a_before: f64,
}

/// The estimate after a sample, as the node publishes it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Estimate {
    /// The fitting width's coefficient `b_k`.
    pub b_k: f64,
    /// The fitting width's exponent base `a`.
    pub a: f64,
    /// The soil–plate friction angle (deg): the medium's unless it is fitted.
    pub delta_deg: f64,
    /// Standard deviation of `b_k`.
    pub std_b_k: f64,
    /// Standard deviation of `a`.
    pub std_a: f64,
    /// Standard deviation of `delta` (deg); 0 when it is not fitted.
    pub std_delta_deg: f64,
    /// Samples that updated the estimate.
    pub samples_used: u64,
    /// Samples skipped for a non-finite angle, force or time.
    pub samples_non_finite: u64,
    /// Samples skipped below the excitation gate (out of the medium, or too little force).
    pub samples_not_excited: u64,
    /// Samples skipped while the sensor repeated one value.
    pub samples_stuck: u64,
    /// RMS of recent innovations (measured minus predicted force), N.
    pub innovation_rms_n: f64,
    /// Estimated sensor noise standard deviation, N.
    pub noise_n: f64,
    /// Whether the estimate has converged (its deviations small, no change building up).
    pub converged: bool,
    /// Changes of the medium detected since the start.
    pub changes_detected: u64,
}

impl Estimate {
    /// The fitting width `b_e = b_k b a^(-beta)` of the estimate.
    pub fn fitting_width(&self) -> Result<FittingWidth, ModelError> {
        FittingWidth::new(self.b_k, self.a)
    }
}

/// The online estimator for one leg.
#[derive(Debug, Clone)]
pub struct OnlineEstimator {
    unit: TerzaghiModel,
    opts: OnlineOptions,
    /// Penetration span of one stroke (rad), for forgetting by strokes.
    span_rad: f64,
    theta: Vector3<f64>,
    p: Matrix3<f64>,
    innov: Innovations,
    updates_since_reset: u64,
    /// Start-up samples still to be taken by the log-linear fit.
    startup_left: usize,
    prev_beta: Option<f64>,
    stuck: StuckDetector,
    // Log-linear start-up: information matrix and vector in (ln b_k, ln a).
    start_info: Matrix2<f64>,
    start_vec: Vector2<f64>,
    /// Attack angles the start-up's samples span (rad): until they span
    /// [`STARTUP_SPAN_FRAC`] of a stroke's penetration, `ln a` is held where it started.
    start_span: (f64, f64),
    /// `ln b_k` and `ln a` when the start-up began.
    start_ln_b_k: f64,
    start_ln_a: f64,
    /// The start-up's samples: angle, the unit model's drag and lift, the measured ones. At the
    /// hand-over the sensor noise is measured from their residuals against the start-up's
    /// estimate.
    start_rows: NoiseRows<5>,
    est: Estimate,
    changes: Vec<ChangeEvent>,
    converged_at_s: Option<f64>,
}

impl OnlineEstimator {
    /// An estimator for `model`'s plate and medium (its fitting width is ignored: the estimate
    /// starts from `opts.initial_b_k, opts.initial_a` and the medium's `delta`).
    pub fn new(model: &TerzaghiModel, opts: OnlineOptions) -> Result<Self, OnlineOptionsError> {
        opts.validate()?;
        let plate = model.plate();
        let span_rad = FRAC_PI_2 - plate.entry_beta_rad().unwrap_or(0.0);
        let mut s = OnlineEstimator {
            unit: model.with_fitting_width(FittingWidth::CONVENTIONAL),
            opts,
            span_rad: span_rad.max(0.05),
            theta: Vector3::zeros(),
            p: Matrix3::zeros(),
            innov: Innovations::new(opts.initial_noise_n),
            updates_since_reset: 0,
            startup_left: 0,
            prev_beta: None,
            stuck: StuckDetector::default(),
            start_info: Matrix2::zeros(),
            start_vec: Vector2::zeros(),
            start_span: (f64::INFINITY, f64::NEG_INFINITY),
            start_ln_b_k: 0.0,
            start_ln_a: 0.0,
            start_rows: NoiseRows::default(),
            est: Estimate {
                b_k: 0.0,
                a: 0.0,
                delta_deg: 0.0,
                std_b_k: 0.0,
                std_a: 0.0,
                std_delta_deg: 0.0,
                samples_used: 0,
                samples_non_finite: 0,
                samples_not_excited: 0,
                samples_stuck: 0,
                innovation_rms_n: 0.0,
                noise_n: 0.0,
                converged: false,
                changes_detected: 0,
            },
            changes: Vec::new(),
            converged_at_s: None,
        };
        s.reset();
        Ok(s)
    }

    /// Back to the initial guess; counters and change history are cleared too.
    pub fn reset(&mut self) {
        let o = &self.opts;
        self.theta = Vector3::new(
            o.initial_b_k.ln(),
            o.initial_a.ln(),
            self.unit.medium().delta_rad(),
        );
        self.innov = Innovations::new(o.initial_noise_n);
        self.prev_beta = None;
        self.stuck = StuckDetector::default();
        self.restart();
        self.changes.clear();
        self.converged_at_s = None;
        self.est.samples_used = 0;
        self.est.samples_non_finite = 0;
        self.est.samples_not_excited = 0;
        self.est.samples_stuck = 0;
        self.est.changes_detected = 0;
        self.refresh_estimate();
    }

    /// Opens the covariance and runs the log-linear start-up again from the current estimate.
    fn restart(&mut self) {
        let o = &self.opts;
        self.p = self.initial_p();
        self.innov.disarm();
        self.updates_since_reset = 0;
        self.startup_left = o.startup_samples;
        self.start_info = Matrix2::from_diagonal_element(1.0 / o.initial_std_ln.powi(2));
        self.start_vec = self.start_info * Vector2::new(self.theta[0], self.theta[1]);
        self.start_span = (f64::INFINITY, f64::NEG_INFINITY);
        self.start_ln_b_k = self.theta[0];
        self.start_ln_a = self.theta[1];
        self.start_rows.clear();
    }

    /// At the hand-over: where some of the start-up's readings are far off every other (a
    /// sensor's spike, ten times the force), the start-up's estimate is fitted again without
    /// them, and they are left out of the noise measured next. The start-up's log fit weighs a
    /// reading by its size squared, so one spike outweighs a hundred readings; the noise, a
    /// mean square, would take the spike's square too and let every later spike through the
    /// Huber weights. Readings are told off by their log residual against a robust fit of all of
    /// them (Huber's, its scale the residuals' median absolute deviation), beyond
    /// [`START_OUTLIER_MADS`] deviations. Where none is, nothing changes.
    fn drop_start_up_outliers(&mut self) {
        // (beta, ln(meas / unit)) of every component clear of zero, as the log fit takes them.
        let sigma = self.innov.noise_var.sqrt();
        let mut pts: Vec<(f64, f64, usize)> = Vec::new();
        for (i, &[beta, unit_d, unit_l, meas_d, meas_l]) in self.start_rows.rows().enumerate() {
            for (unit, meas) in [(unit_d, meas_d), (unit_l, meas_l)] {
                if unit * meas > 0.0 && meas.abs() >= 3.0 * sigma {
                    pts.push((beta, (meas / unit).ln(), i));
                }
            }
        }
        if pts.len() < 10 {
            return;
        }
        let fit = |w: &[f64]| -> Option<Vector2<f64>> {
            let mut info = Matrix2::from_diagonal_element(1e-9);
            let mut vec = Vector2::zeros();
            for (&(beta, z, _), &wi) in pts.iter().zip(w) {
                let h = Vector2::new(1.0, -beta);
                info += wi * h * h.transpose();
                vec += wi * z * h;
            }
            info.try_inverse().map(|c| c * vec)
        };
        let residuals = |th: &Vector2<f64>| -> Vec<f64> {
            pts.iter()
                .map(|&(beta, z, _)| z - th[0] + beta * th[1])
                .collect()
        };
        let mad = |r: &[f64]| -> f64 {
            let mut a: Vec<f64> = r.iter().map(|x| x.abs()).collect();
            a.sort_by(f64::total_cmp);
            1.4826 * a[a.len() / 2]
        };
        let mut w = vec![1.0; pts.len()];
        let Some(mut th) = fit(&w) else { return };
        for _ in 0..10 {
            let r = residuals(&th);
            let scale = mad(&r).max(1e-6);
            for (wi, ri) in w.iter_mut().zip(&r) {
                let z = ri.abs() / scale;
                *wi = if z <= 1.5 { 1.0 } else { 1.5 / z };
            }
            match fit(&w) {
                Some(t) => th = t,
                None => return,
            }
        }
        let r = residuals(&th);
        let scale = mad(&r).max(1e-6);
        let mut outlier = vec![false; self.start_rows.rows().count()];
        for (p, ri) in pts.iter().zip(&r) {
            if ri.abs() > START_OUTLIER_MADS * scale {
                outlier[p.2] = true;
            }
        }
        if !outlier.contains(&true) {
            return;
        }
        // The start-up's fit again, as it weighs its readings, without the outliers' rows.
        let o = self.opts;
        let kept: Vec<[f64; 5]> = self
            .start_rows
            .rows()
            .zip(&outlier)
            .filter(|(_, out)| !**out)
            .map(|(row, _)| *row)
            .collect();
        self.start_info = Matrix2::from_diagonal_element(1.0 / o.initial_std_ln.powi(2));
        self.start_vec = self.start_info * Vector2::new(self.start_ln_b_k, self.start_ln_a);
        self.theta[0] = self.start_ln_b_k;
        self.theta[1] = self.start_ln_a;
        self.start_rows.clear();
        for row in kept {
            let [beta, unit_d, unit_l, meas_d, meas_l] = row;
            let s = Sample {
                t_s: None,
                beta_rad: beta,
                drag_n: meas_d,
                lift_n: meas_l,
            };
            self.startup_update(beta, unit_d, unit_l, &s);
            self.start_rows.push(row);
        }
    }

    /// The sensor noise from the start-up's residuals against its estimate. Run once, at the
    /// hand-over to the Gauss–Newton step.
    fn noise_from_start_up(&mut self) {
        let (ln_b_k, ln_a) = (self.theta[0], self.theta[1]);
        let var = self
            .start_rows
            .noise_var(2, |&[beta, unit_d, unit_l, meas_d, meas_l]| {
                let scale = (ln_b_k - beta * ln_a).exp();
                [meas_d - scale * unit_d, meas_l - scale * unit_l]
            });
        if let Some(var) = var {
            self.innov.set_noise(var);
        }
    }

    /// Whether the start-up's samples span enough attack angles to tell `b_k` from `a`.
    fn start_spread(&self) -> bool {
        self.start_span.1 - self.start_span.0 >= STARTUP_SPAN_FRAC * self.span_rad
    }

    fn initial_p(&self) -> Matrix3<f64> {
        let o = &self.opts;
        let d = if o.fit_delta {
            o.initial_std_delta_deg.to_radians().powi(2)
        } else {
            0.0
        };
        Matrix3::from_diagonal(&Vector3::new(
            o.initial_std_ln.powi(2),
            o.initial_std_ln.powi(2),
            d,
        ))
    }

    /// The options it runs with.
    pub fn options(&self) -> &OnlineOptions {
        &self.opts
    }

    /// The current estimate.
    pub fn estimate(&self) -> &Estimate {
        &self.est
    }

    /// Changes of the medium detected so far.
    pub fn changes(&self) -> &[ChangeEvent] {
        &self.changes
    }

    /// Time of the first sample at which `converged` became true (since the last reset).
    pub fn converged_at_s(&self) -> Option<f64> {
        self.converged_at_s
    }

    /// Feeds one sample; `Ok(())` if it updated the estimate, otherwise why not.
    pub fn update(&mut self, s: &Sample) -> Result<(), Skip> {
        self.update_at(s, None)
    }

    /// [`Self::update`] for a sample taken with the hip where the robot's state put it (its
    /// height and the body's pitch), instead of the configured plate's.
    pub fn update_at(&mut self, s: &Sample, hip: Option<&HipMotion>) -> Result<(), Skip> {
        let r = self.update_inner(s, hip);
        match r {
            Ok(()) => self.est.samples_used += 1,
            Err(Skip::NonFinite) => self.est.samples_non_finite += 1,
            Err(Skip::NotExcited) => self.est.samples_not_excited += 1,
            Err(Skip::Stuck) => self.est.samples_stuck += 1,
        }
        r
    }

    fn update_inner(&mut self, s: &Sample, hip: Option<&HipMotion>) -> Result<(), Skip> {
        if !(s.beta_rad.is_finite() && s.drag_n.is_finite() && s.lift_n.is_finite())
            || s.t_s.is_some_and(|t| !t.is_finite())
        {
            return Err(Skip::NonFinite);
        }
        let stuck = self.stuck.see(s.drag_n, s.lift_n) >= self.opts.stuck_samples;
        let f = match hip {
            Some(h) => self
                .unit
                .evaluate_at_height(s.beta_rad + h.pitch_rad, h.height_m),
            None => self.unit.evaluate(s.beta_rad),
        }
        .map_err(|_| Skip::NonFinite)?;
        let dbeta = self
            .prev_beta
            .map(|p| angle_step(p, f.beta_rad))
            .unwrap_or(0.0);
        self.prev_beta = Some(f.beta_rad);
        if stuck {
            return Err(Skip::Stuck);
        }
        let unit_mag = f.drag_n.hypot(f.lift_n);
        if f.regime != Regime::Penetration || unit_mag < self.opts.min_unit_force_n {
            return Err(Skip::NotExcited);
        }
        let (sin_b, cos_b) = f.beta_rad.sin_cos();
        if self.startup_left > 0 || !self.start_spread() {
            self.startup_left = self.startup_left.saturating_sub(1);
            self.startup_update(f.beta_rad, f.drag_n, f.lift_n, s);
            self.start_rows
                .push([f.beta_rad, f.drag_n, f.lift_n, s.drag_n, s.lift_n]);
        } else {
            if !self.start_rows.is_empty() {
                self.drop_start_up_outliers();
                self.noise_from_start_up();
            }
            self.gauss_newton_update(f.beta_rad, sin_b, cos_b, f.normal_n, s, dbeta);
        }
        self.updates_since_reset += 1;
        self.refresh_estimate();
        if self.est.converged {
            self.innov.arm();
            if self.converged_at_s.is_none() {
                self.converged_at_s = s.t_s;
            }
        }
        Ok(())
    }

    /// Log-linear RLS: `ln(meas / unit) = ln b_k - beta ln a`, for the rows whose measured and
    /// unit forces share a sign and are clear of zero. Relative noise `sigma / |meas|`.
    fn startup_update(&mut self, beta: f64, unit_d: f64, unit_l: f64, s: &Sample) {
        let sigma = self.innov.noise_var.sqrt();
        for (unit, meas) in [(unit_d, s.drag_n), (unit_l, s.lift_n)] {
            if unit * meas <= 0.0 || meas.abs() < 3.0 * sigma {
                continue;
            }
            let z = (meas / unit).ln();
            let w = (meas / sigma).powi(2).min(1e6); // 1 / var(ln meas)
            let h = Vector2::new(1.0, -beta);
            self.start_info += w * h * h.transpose();
            self.start_vec += w * z * h;
        }
        self.start_span = (self.start_span.0.min(beta), self.start_span.1.max(beta));
        // Samples over a narrow range of angles tell only `b_k a^(-beta)` there, not `a`: a
        // local slope of the force's ratio to the model's (the DEM's force builds sooner at
        // entry) would throw `a` to a bound. Until they spread, `ln a` stays where it was.
        let mut info = self.start_info;
        let mut vec = self.start_vec;
        if !self.start_spread() {
            let hold = 1.0 / 0.01f64.powi(2);
            info[(1, 1)] += hold;
            vec[1] += hold * self.start_ln_a;
        }
        if let Some(cov) = info.try_inverse() {
            let th = cov * vec;
            self.theta[0] = th[0];
            self.theta[1] = th[1];
            self.project();
            // Hand over a covariance no tighter than the log fit's, which is biased.
            let floor = 0.05f64.powi(2);
            self.p[(0, 0)] = cov[(0, 0)].max(floor);
            self.p[(1, 1)] = cov[(1, 1)].max(floor);
            self.p[(0, 1)] = cov[(0, 1)];
            self.p[(1, 0)] = cov[(1, 0)];
        }
    }

    fn gauss_newton_update(
        &mut self,
        beta: f64,
        sin_b: f64,
        cos_b: f64,
        normal_unit: f64,
        s: &Sample,
        dbeta: f64,
    ) {
        let o = self.opts;
        let th = self.theta;
        let scale = (th[0] - beta * th[1]).exp();
        let (t, sec2) = (th[2].tan(), 1.0 / th[2].cos().powi(2));
        let n = scale * normal_unit;
        let (pd, pl) = (n * (sin_b - t * cos_b), n * (cos_b + t * sin_b));
        let dd = if o.fit_delta { -n * cos_b * sec2 } else { 0.0 };
        let dl = if o.fit_delta { n * sin_b * sec2 } else { 0.0 };
        // H: 2 x 3 Jacobian of (drag, lift) in theta, stored transposed.
        let ht = Matrix3x2::new(pd, pl, -beta * pd, -beta * pl, dd, dl);
        let e = Vector2::new(s.drag_n - pd, s.lift_n - pl);

        let hp = ht.transpose() * self.p;
        let hph = hp * ht;
        let mut r = Matrix2::zeros();
        let mut nis = 0.0;
        for i in 0..2 {
            let (r_i, nis_i) = self.innov.row(e[i], hph[(i, i)], &o);
            r[(i, i)] = r_i;
            nis += nis_i;
        }
        self.innov.floor_noise();

        let Some(s_inv) = (hph + r).try_inverse() else {
            return;
        };
        let k = self.p * ht * s_inv; // 3 x 2
        self.theta += k * e;
        let ikh = Matrix3::identity() - k * ht.transpose();
        self.p = ikh * self.p * ikh.transpose() + k * r * k.transpose();
        self.p /= forgetting_factor(&o, dbeta, self.span_rad);
        self.p = 0.5 * (self.p + self.p.transpose());
        self.bound_covariance();
        self.project();

        if self.innov.change_alarm(nis, 2.0, &o) {
            self.changes.push(ChangeEvent {
                t_s: s.t_s,
                b_k_before: self.theta[0].exp(),
                a_before: self.theta[1].exp(),
            });
            self.est.changes_detected += 1;
            self.restart();
        }
    }

    fn bound_covariance(&mut self) {
        let max_var = self.opts.max_std_ln.powi(2);
        let worst = self.p[(0, 0)].max(self.p[(1, 1)]);
        if worst > max_var {
            self.p *= max_var / worst;
        }
    }

    /// Keeps the parameters inside their bounds.
    fn project(&mut self) {
        let o = &self.opts;
        self.theta[0] = self.theta[0].clamp(o.b_k_range.0.ln(), o.b_k_range.1.ln());
        self.theta[1] = self.theta[1].clamp(o.a_range.0.ln(), o.a_range.1.ln());
        let (dlo, dhi) = o.delta_range_deg;
        self.theta[2] = self.theta[2].clamp(dlo.to_radians(), dhi.to_radians());
    }

    fn refresh_estimate(&mut self) {
        let (b_k, a) = (self.theta[0].exp(), self.theta[1].exp());
        let (sd0, sd1) = (
            self.p[(0, 0)].max(0.0).sqrt(),
            self.p[(1, 1)].max(0.0).sqrt(),
        );
        let o = &self.opts;
        let spread = self.start_spread();
        let e = &mut self.est;
        e.b_k = b_k;
        e.a = a;
        e.delta_deg = self.theta[2].to_degrees();
        e.std_b_k = b_k * sd0;
        e.std_a = a * sd1;
        e.std_delta_deg = self.p[(2, 2)].max(0.0).sqrt().to_degrees();
        e.innovation_rms_n = self.innov.innov_ms.sqrt();
        e.noise_n = self.innov.noise_var.sqrt();
        e.converged = self.updates_since_reset >= o.converge_min_updates
            && self.startup_left == 0
            && spread
            && sd0 < o.converge_rel_std
            && sd1 < o.converge_rel_std
            && self.innov.cusum < 0.5 * o.cusum_alarm;
    }
}

/// What the estimators learn from their innovations (measured minus predicted force): the sensor
/// noise, the recent RMS, Huber weights, and the CUSUM of change detection.
#[derive(Debug, Clone)]
pub(crate) struct Innovations {
    /// The sensor noise's variance, followed over the last few hundred rows: it standardizes
    /// the innovations (Huber, change detection) and weights the rows of [`Innovations::row`].
    pub(crate) noise_var: f64,
    /// The same noise followed over strokes: it weights the rows of
    /// [`Innovations::row_over_strokes`].
    pub(crate) stroke_noise_var: f64,
    pub(crate) innov_ms: f64,
    pub(crate) cusum: f64,
    /// The CUSUM runs once the estimate has converged since the last reset or change.
    armed: bool,
}

impl Innovations {
    pub(crate) fn new(initial_noise_n: f64) -> Innovations {
        Innovations {
            noise_var: initial_noise_n.powi(2),
            stroke_noise_var: initial_noise_n.powi(2),
            innov_ms: 0.0,
            cusum: 0.0,
            armed: false,
        }
    }

    /// After a reset or a detected change: the CUSUM starts again, unarmed.
    pub(crate) fn disarm(&mut self) {
        self.cusum = 0.0;
        self.armed = false;
    }

    pub(crate) fn arm(&mut self) {
        self.armed = true;
    }

    pub(crate) fn armed(&self) -> bool {
        self.armed
    }

    /// One row's innovation `e` with the prediction's variance `hph` there: its noise variance
    /// for the update (a large standardized innovation counts as noisier, Huber) and its clipped
    /// squared standardized innovation.
    pub(crate) fn row(&mut self, e: f64, hph: f64, o: &OnlineOptions) -> (f64, f64) {
        let r = self.noise_var / self.huber_weight(e, hph, o);
        (r, self.follow(e, hph, o, None))
    }

    /// [`Innovations::row`] with the row weighted by the noise followed over strokes (`keep`:
    /// the share of it this row keeps, a memory of some strokes) rather than over the last few
    /// hundred rows. Where the model's misfit runs through one part of every stroke (a term's
    /// form that is not the medium's), the fast noise rises in that part and weighs it less
    /// than the rest; the learnt coefficients then settle away from the batch diagnosis's,
    /// which weighs every sample alike.
    pub(crate) fn row_over_strokes(
        &mut self,
        e: f64,
        hph: f64,
        o: &OnlineOptions,
        keep: f64,
    ) -> (f64, f64) {
        let r = self.stroke_noise_var / self.huber_weight(e, hph, o);
        (r, self.follow(e, hph, o, Some(keep)))
    }

    /// The Huber weight of innovation `e`, standardized by the fast noise.
    fn huber_weight(&self, e: f64, hph: f64, o: &OnlineOptions) -> f64 {
        let z = e / (hph + self.noise_var).sqrt();
        if z.abs() <= o.huber_k {
            1.0
        } else {
            o.huber_k / z.abs()
        }
    }

    /// Follows the noise with innovation `e` (and over strokes with `keep`, if given); returns
    /// the clipped squared standardized innovation.
    fn follow(&mut self, e: f64, hph: f64, o: &OnlineOptions, keep: Option<f64>) -> f64 {
        let var = hph + self.noise_var;
        let z = e / var.sqrt();
        let nis = (z * z).min(o.huber_k * o.huber_k);
        // Noise variance from clipped innovations, slowly, and not while the CUSUM builds up: a
        // change of the medium must not pass for noise.
        if self.cusum < 0.25 * o.cusum_alarm {
            let clipped = e.abs().min(o.huber_k * var.sqrt());
            let sq = (clipped * clipped - hph).max(0.0);
            self.noise_var = 0.998 * self.noise_var + 0.002 * sq;
            if let Some(k) = keep {
                self.stroke_noise_var = k * self.stroke_noise_var + (1.0 - k) * sq;
            }
        }
        self.innov_ms = 0.99 * self.innov_ms + 0.01 * e * e;
        nis
    }

    /// Both noises start from (or are reset to) the variance `var`.
    pub(crate) fn set_noise(&mut self, var: f64) {
        self.noise_var = var;
        self.stroke_noise_var = var;
    }

    /// Both noises raised to the variance `var` where that is more, never lowered: measured from
    /// the rows of less than a stroke, a noise can miss a misfit that grows later in the stroke
    /// (on a DEM stroke whose surface was where configured, a lowered noise raised a change).
    /// Returns the factor the variance grew by (1 where it did not), by which a covariance
    /// learnt with the noise assumed so far grows too.
    pub(crate) fn raise_noise(&mut self, var: f64) -> f64 {
        if var > self.noise_var {
            let grew = var / self.noise_var;
            self.set_noise(var);
            grew
        } else {
            1.0
        }
    }

    pub(crate) fn floor_noise(&mut self) {
        self.noise_var = self.noise_var.max(1e-12);
        self.stroke_noise_var = self.stroke_noise_var.max(1e-12);
    }

    /// The CUSUM of clipped NIS over `rows` rows (mean `rows` without a change), once armed:
    /// before that, large innovations are the estimate still moving, not the medium. True on an
    /// alarm.
    pub(crate) fn change_alarm(&mut self, nis: f64, rows: f64, o: &OnlineOptions) -> bool {
        if !self.armed {
            return false;
        }
        self.cusum = (self.cusum + nis - rows - o.cusum_drift).max(0.0);
        self.cusum > o.cusum_alarm
    }
}

/// The newest rows an estimator saw before its change detection is armed (at most
/// [`NOISE_ROWS_KEPT`]), to measure the sensor noise from their residuals against a
/// least-squares fit of the same rows (not against the recursive estimate, which can lag them: a
/// noise configured too low makes the Huber weights hold it back while its covariance shrinks).
/// The change detection then judges innovations against the noise the sensor has, not against
/// the configured `initial_noise_n`: a sensor noisier than that raised false changes in most
/// sessions of a steady medium.
#[derive(Debug, Clone)]
pub(crate) struct NoiseRows<const N: usize> {
    rows: std::collections::VecDeque<[f64; N]>,
}

impl<const N: usize> Default for NoiseRows<N> {
    fn default() -> Self {
        NoiseRows {
            rows: std::collections::VecDeque::new(),
        }
    }
}

impl<const N: usize> NoiseRows<N> {
    /// Keeps a row (finite values), dropping the oldest beyond [`NOISE_ROWS_KEPT`].
    pub(crate) fn push(&mut self, row: [f64; N]) {
        if self.rows.len() == NOISE_ROWS_KEPT {
            self.rows.pop_front();
        }
        self.rows.push_back(row);
    }

    pub(crate) fn rows(&self) -> impl Iterator<Item = &[f64; N]> {
        self.rows.iter()
    }

    pub(crate) fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    pub(crate) fn clear(&mut self) {
        self.rows.clear();
    }

    /// The noise variance from the rows' residuals against an estimate fitted on them
    /// (`residuals` gives a row's, in force units): their mean square over the residuals less
    /// the `fitted` values of the estimate. `None` below ten finite residuals or with none but
    /// zeros. The rows are used up. A spike or a misfit of the model counts as noise here, which
    /// errs on the side of fewer false changes.
    pub(crate) fn noise_var<const M: usize>(
        &mut self,
        fitted: usize,
        residuals: impl Fn(&[f64; N]) -> [f64; M],
    ) -> Option<f64> {
        let (mut sse, mut count) = (0.0, 0usize);
        for row in self.rows.drain(..) {
            let e = residuals(&row);
            if e.iter().all(|x| x.is_finite()) {
                sse += e.iter().map(|x| x * x).sum::<f64>();
                count += M;
            }
        }
        (count >= 10 && count > fitted && sse > 0.0).then(|| sse / (count - fitted) as f64)
    }
}

/// Counts how many times in a row the sensor gave the same reading.
#[derive(Debug, Clone, Default)]
pub(crate) struct StuckDetector {
    last: Option<(f64, f64)>,
    repeats: usize,
}

impl StuckDetector {
    /// The reading `(drag, lift)`; how many times in a row it has now been seen.
    pub(crate) fn see(&mut self, drag_n: f64, lift_n: f64) -> usize {
        if self.last == Some((drag_n, lift_n)) {
            self.repeats += 1;
        } else {
            self.repeats = 1;
            self.last = Some((drag_n, lift_n));
        }
        self.repeats
    }
}

/// The forgetting factor of one update that swept `dbeta` (rad), for a stroke whose penetration
/// spans `span_rad`.
pub(crate) fn forgetting_factor(o: &OnlineOptions, dbeta: f64, span_rad: f64) -> f64 {
    match o.forgetting {
        Forgetting::Strokes(m) => stroke_memory_keep(m, dbeta, span_rad),
        Forgetting::PerSample(l) => l,
    }
}

/// The share kept, at one update that swept `dbeta` (rad), by a memory of `strokes` strokes
/// whose penetration spans `span_rad`.
pub(crate) fn stroke_memory_keep(strokes: f64, dbeta: f64, span_rad: f64) -> f64 {
    (-dbeta.min(0.2) / (strokes * span_rad)).exp()
}

/// Angle swept between two wrapped angles, the short way round.
pub(crate) fn angle_step(from: f64, to: f64) -> f64 {
    let d = (to - from).abs();
    d.min(std::f64::consts::TAU - d)
}
