//! Online identification of a corrected model's linear values: the baseline's `b_k` and `a`, and
//! each kept correction's coefficients, sample by sample.
//!
//! The corrected model predicts `y = b_k X_0(a) + sum_j c_j X_j(a)` (the design of the
//! diagnosis, [`CorrectedModel::design_row`]): linear in `b_k` and the `c_j`, and in `a` only
//! through `a^(-beta)`. The state is `theta = (b_k, ln a, c_1 .. c_m)`; the update is the same
//! recursive Gauss–Newton (extended Kalman) step as [`super::OnlineEstimator`]'s, on the raw drag
//! and lift, with the same options: forgetting by strokes, Huber weights, a stuck sensor, bounds
//! (`b_k_range`, `a_range`, each coefficient's [`Effect::linear_bound`]) and the CUSUM of change
//! detection. The nonlinear values (speed exponent,
//! surface level, lag, the change's stroke) and the set of terms stay as configured.
//!
//! What differs from the bare estimator, and why:
//! - The start-up is a least squares over the first [`STARTUP_TURNS`] turns, for every `ln a`
//!   of the diagnosis's grid at once (at another `a` a column's `a^(-beta)` part only scales),
//!   then one Gauss–Newton step in all values from the best grid point: the state and its
//!   covariance handed over are the diagnosis's own fit of those strokes. Coefficients come in
//!   every unit, and no prior could be scaled for them all.
//! - Every sample in the medium updates (the terms act in extraction too), and out of it every
//!   sample that the sensor's terms reach (its offset, the tail of its lag). Out of the medium
//!   the innovations are the sensor's noise alone; they are kept apart, and only in-medium
//!   innovations feed change detection, which waits a turn after the start-up.
//! - A coefficient whose column was zero through the start-up (a term that has not acted yet)
//!   opens its covariance when the column first shows, to the size that lets the column alone
//!   explain the largest force seen.
//! - With a kept `sensor_lag`, every column goes through the sensor's lag, as in the diagnosis.
//! - Each row is weighted by the noise followed over the last [`NOISE_MEMORY_STROKES`] strokes,
//!   not over the last few hundred samples as the bare estimator weighs it: a term's form that
//!   is not the medium's leaves a misfit in one part of every stroke (the fastest part, say),
//!   where a noise followed sample by sample rises and weighs those samples less than the
//!   diagnosis's least squares does, so that the coefficients settle elsewhere (rate's, 23 %
//!   off the batch value on `diagnose-eval --online`'s session). Huber's standardization and
//!   change detection keep the fast noise.
//! - A change alarm is tested before it is taken: the start-up's least squares runs again over
//!   the turns after it, beside the estimate, which goes on learning. The change is confirmed,
//!   and the refit takes over as a start-up's would, only when the estimate predicted those
//!   turns with twice the refit's sum of squares or more; otherwise the alarm is dismissed.
//!   Where a term's form parts from the medium for some strokes (the fastest ones, say), the
//!   CUSUM rises as it would for a change, but a refit does no better, and a converged estimate
//!   is not thrown away for it.
//!
//! Convergence: the relative standard deviations of `b_k` and `a` below `converge_rel_std`, and
//! each seen coefficient's contribution (its standard deviation times the largest its column has
//! been) below `converge_rel_std` of the largest force seen; after `converge_min_updates` updates
//! and with the CUSUM below half its alarm level.

use super::Sample;
use super::online::{
    ChangeEvent, Estimate, Innovations, OnlineOptions, OnlineOptionsError, Skip, StuckDetector,
    angle_step, forgetting_factor, stroke_memory_keep,
};
use crate::model::corrections::{
    CorrectedModel, Effect, MOTION_WINDOW_S, Motion, MotionTracker, lag_step, ln_a_grid,
};
use crate::model::{HipMotion, Regime, wrap_beta_rad};
use serde::Serialize;
use std::f64::consts::{FRAC_PI_2, TAU};

/// Turns of the leg the start-up's least squares takes before the Gauss–Newton step.
pub const STARTUP_TURNS: f64 = 2.0;

/// Strokes over which the noise that weights each row is followed (the bare estimator's default
/// memory): long enough that a stroke's parts weigh alike, short enough to follow a sensor
/// whose noise changes.
pub const NOISE_MEMORY_STROKES: f64 = 3.0;

/// How much wider than the start-up's least squares claim the handed-over covariance is: its
/// `ln a` lies on a grid and its residuals are not white.
const STARTUP_INFLATION: f64 = 4.0;

/// Standard deviation of `ln a` handed over: half a step of the grid.
const STARTUP_STD_LN_A: f64 = 0.23;

/// A change alarm is confirmed when, over the start-up's turns after it, the estimate's own
/// prediction errors exceed the start-up's least squares refitted on the same samples by this
/// factor (sums of squares). A real change of the medium leaves the old estimate far off; an
/// alarm raised where the terms' forms part from the medium for a while leaves it as good as a
/// refit.
const CONFIRM_SSE_RATIO: f64 = 2.0;

/// The start-up: for every `ln a` of a grid, the sums of a Gauss–Newton step in the linear
/// values (`b_k`, then the coefficients) and `ln a`, accumulated over the samples. With `x` a
/// sample's design row and `d` its part that scales with `a^(-beta)`, the column of `ln a` is
/// `-beta d . theta`: its products need `sum beta x d^T`, `sum beta^2 d d^T` and `sum beta d y`.
#[derive(Debug, Clone)]
struct Startup {
    grid: Vec<f64>,
    m: usize,
    xtx: Vec<f64>,
    xty: Vec<f64>,
    yty: Vec<f64>,
    /// `sum beta x d^T`, `sum beta^2 d d^T` (upper triangle), `sum beta d y`.
    bxd: Vec<f64>,
    bdd: Vec<f64>,
    bdy: Vec<f64>,
    samples: usize,
    swept_rad: f64,
    /// The lag's state per grid point and component: raw input and output of the row and of
    /// `beta d`; the previous sample's time.
    lag: Vec<f64>,
    lag_t_s: Option<f64>,
    x: Vec<f64>,
    d: Vec<f64>,
}

/// The start-up's solution at one point of its grid.
struct StartupFit {
    sse: f64,
    /// The linear values, then `ln a`.
    theta: Vec<f64>,
    /// The inverse of the Gauss–Newton information over the same values.
    cov: nalgebra::DMatrix<f64>,
    seen: Vec<bool>,
}

impl Startup {
    /// The grid of the diagnosis and `ln_a_now`, for `m` linear values.
    fn new(ln_a_now: f64, m: usize) -> Startup {
        let mut grid: Vec<f64> = ln_a_grid().collect();
        grid.push(ln_a_now);
        let g = grid.len();
        Startup {
            grid,
            m,
            xtx: vec![0.0; g * m * m],
            xty: vec![0.0; g * m],
            yty: vec![0.0; g],
            bxd: vec![0.0; g * m * m],
            bdd: vec![0.0; g * m * m],
            bdy: vec![0.0; g * m],
            samples: 0,
            swept_rad: 0.0,
            lag: vec![0.0; g * 2 * 4 * m],
            lag_t_s: None,
            x: vec![0.0; m],
            d: vec![0.0; m],
        }
    }

    /// One sample at `t_s`: its design row at `ln_a_now` and the part of it that does not
    /// scale with `a^(-beta)`; at another `ln a` the rest scales by
    /// `exp(-(ln a - ln_a_now) beta)`. With a lag of `lag_s` (0: none), the row at every point of
    /// the grid goes through it, as the sensor's reading does.
    #[allow(clippy::too_many_arguments)]
    fn add(
        &mut self,
        row: &[[f64; 2]],
        fixed: &[[f64; 2]],
        beta: f64,
        ln_a_now: f64,
        y: [f64; 2],
        t_s: f64,
        lag_s: f64,
    ) {
        let m = self.m;
        self.samples += 1;
        let dt = self.lag_t_s.map(|t0| t_s - t0);
        self.lag_t_s = Some(t_s);
        for (g, &ln_a) in self.grid.iter().enumerate() {
            let k = (-(ln_a - ln_a_now) * beta).exp();
            let mm = g * m * m..(g + 1) * m * m;
            let (xtx, bxd, bdd) = (
                &mut self.xtx[mm.clone()],
                &mut self.bxd[mm.clone()],
                &mut self.bdd[mm],
            );
            let xty = &mut self.xty[g * m..(g + 1) * m];
            let bdy = &mut self.bdy[g * m..(g + 1) * m];
            for c in 0..2 {
                // The row and `beta d` (the column of ln a is `-theta . beta d`), lagged.
                for (j, (r, f)) in row.iter().zip(fixed).enumerate() {
                    let d = k * (r[c] - f[c]);
                    self.x[j] = f[c] + d;
                    self.d[j] = beta * d;
                }
                if lag_s > 0.0 {
                    let state = &mut self.lag[(g * 2 + c) * 4 * m..(g * 2 + c + 1) * 4 * m];
                    for j in 0..m {
                        for (v, q) in [(&mut self.x[j], j), (&mut self.d[j], m + j)] {
                            let (x0, y0) = (state[2 * q], state[2 * q + 1]);
                            let out = match dt {
                                Some(dt) if dt >= 0.0 => lag_step(x0, *v, y0, dt, lag_s),
                                _ => *v,
                            };
                            state[2 * q] = *v;
                            state[2 * q + 1] = out;
                            *v = out;
                        }
                    }
                }
                for i in 0..m {
                    let (xi, di) = (self.x[i], self.d[i]);
                    if xi != 0.0 {
                        for j in i..m {
                            xtx[i * m + j] += xi * self.x[j];
                        }
                        xty[i] += xi * y[c];
                    }
                    if di != 0.0 {
                        for j in 0..m {
                            bxd[j * m + i] += self.x[j] * di;
                        }
                        for j in i..m {
                            bdd[i * m + j] += di * self.d[j];
                        }
                        bdy[i] += di * y[c];
                    }
                }
                self.yty[g] += y[c] * y[c];
            }
        }
    }

    /// The solution at the grid point with the least squared residual.
    fn best_fit(&self) -> Option<StartupFit> {
        (0..self.grid.len())
            .filter_map(|g| self.solve(g))
            .min_by(|a, b| a.sse.total_cmp(&b.sse))
    }

    /// The least squares at grid point `g`, and one Gauss–Newton step from there in the linear
    /// values and `ln a` together (so that `ln a` leaves the grid).
    fn solve(&self, g: usize) -> Option<StartupFit> {
        use nalgebra::{DMatrix, DVector};
        let m = self.m;
        let mm = g * m * m;
        let sym = |v: &[f64], i: usize, j: usize| v[mm + i.min(j) * m + i.max(j)];
        let a = DMatrix::from_fn(m, m, |i, j| sym(&self.xtx, i, j));
        let b = DVector::from_column_slice(&self.xty[g * m..(g + 1) * m]);
        let seen: Vec<bool> = (0..m).map(|i| a[(i, i)] > 0.0).collect();
        let mut a_reg = a.clone();
        for i in 0..m {
            a_reg[(i, i)] = if seen[i] {
                a[(i, i)] * (1.0 + 1e-9)
            } else {
                1.0
            };
        }
        let x = a_reg.clone().cholesky()?.solve(&b);
        let sse = self.yty[g] - 2.0 * x.dot(&b) + x.dot(&(&a * &x));
        // The column of ln a, -beta d . theta, against the others, itself and the residual.
        let bxd = DMatrix::from_fn(m, m, |j, k| self.bxd[mm + j * m + k]);
        let bdd = DMatrix::from_fn(m, m, |i, j| sym(&self.bdd, i, j));
        let bdy = DVector::from_column_slice(&self.bdy[g * m..(g + 1) * m]);
        let ha_x = -(&bxd * &x);
        let ha_ha = x.dot(&(&bdd * &x));
        let ha_r = -(x.dot(&bdy) - x.dot(&(bxd.transpose() * &x)));
        let mut info = a_reg.clone().insert_row(m, 0.0).insert_column(m, 0.0);
        for j in 0..m {
            info[(m, j)] = ha_x[j];
            info[(j, m)] = ha_x[j];
        }
        info[(m, m)] = ha_ha.max(0.0) + 1e-12;
        let cov = info.cholesky()?.inverse();
        // The linear values are least squares at this `ln a`: their gradient is zero.
        let mut grad = DVector::zeros(m + 1);
        grad[m] = ha_r;
        let step = &cov * grad;
        let ln_a = self.grid[g] + step[m].clamp(-STARTUP_STD_LN_A, STARTUP_STD_LN_A);
        let mut theta: Vec<f64> = x.iter().copied().collect();
        let scale = if step[m].abs() > STARTUP_STD_LN_A {
            STARTUP_STD_LN_A / step[m].abs()
        } else {
            1.0
        };
        for (t, s) in theta.iter_mut().zip(step.iter()) {
            *t += scale * s;
        }
        theta.push(ln_a);
        (sse.is_finite() && theta.iter().all(|v| v.is_finite())).then_some(StartupFit {
            sse,
            theta,
            cov,
            seen,
        })
    }
}

/// A change alarm under test: the start-up's least squares run again beside the estimate, over
/// the samples after the alarm, with the estimate's own prediction errors over the same samples.
#[derive(Debug, Clone)]
struct Suspected {
    alarm: ChangeEvent,
    startup: Startup,
    col_max: Vec<f64>,
    force_max_n: f64,
    /// The estimate's squared prediction errors (before each update), drag and lift (N^2).
    sse_estimate_n2: f64,
}

/// One learnt coefficient of a correction.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Coefficient {
    /// The term's effect.
    pub effect: Effect,
    /// Its name with unit, as [`Effect::linear_params`] gives it.
    pub param: &'static str,
    /// The current value.
    pub value: f64,
    /// Standard deviation from the covariance; `|value|` until its column has been seen.
    pub std: f64,
}

impl Coefficient {
    /// Its name, `<effect>.<param>` ([`Effect::value_name`]).
    pub fn name(&self) -> String {
        self.effect.value_name(self.param)
    }
}

/// The online estimator of a corrected leg.
#[derive(Debug, Clone)]
pub struct CorrectedEstimator {
    model: CorrectedModel,
    opts: OnlineOptions,
    span_rad: f64,
    /// `(b_k, ln a, c_1 .. c_m)`.
    theta: Vec<f64>,
    /// Covariance of `theta`, row-major `n x n`.
    p: Vec<f64>,
    /// The state's starting value (the configured corrections), for a reset.
    theta0: Vec<f64>,
    /// Whether each coefficient's column has been non-zero since the last (re)start.
    seen: Vec<bool>,
    /// Largest magnitude of each column since the last (re)start.
    col_max: Vec<f64>,
    /// Largest measured force since the last (re)start (N).
    force_max_n: f64,
    /// The largest variance of a prediction (drag or lift, before its update) over about the
    /// last stroke (N^2): each update keeps `exp(-dbeta / span)` of it.
    pred_var_n2: f64,
    /// Innovations of the samples in the medium (they alone feed change detection) and out of
    /// it (the sensor's offset and lag tail, far smaller: one noise for both would make every
    /// in-medium innovation look like a change).
    innov: Innovations,
    innov_out: Innovations,
    stuck: StuckDetector,
    updates_since_reset: u64,
    /// Angle swept since the start-up handed over (rad): change detection waits a turn, until
    /// the noise in the medium is learnt from the step's own innovations.
    swept_since_startup_rad: f64,
    prev_beta: Option<f64>,
    /// The start-up's sums, until it hands over to the Gauss–Newton step.
    startup: Option<Startup>,
    /// A change alarm not yet confirmed or dismissed.
    suspected: Option<Suspected>,
    /// Change alarms dismissed: the estimate predicted the strokes after them as well as a refit.
    alarms_dismissed: u64,
    /// The sensor's lag on the columns: the previous sample's time, raw and lagged values.
    lag_prev: Option<(f64, Vec<f64>, Vec<f64>)>,
    est: Estimate,
    coefficients: Vec<Coefficient>,
    changes: Vec<ChangeEvent>,
    // Scratch, so that an update does not allocate.
    row: Vec<[f64; 2]>,
    fixed: Vec<[f64; 2]>,
    raw: Vec<f64>,
    h: [Vec<f64>; 2],
    u: [Vec<f64>; 2],
}

impl CorrectedEstimator {
    /// An estimator that starts from `model`'s corrections (its `b_k, a` and coefficients) and
    /// learns them with `opts` (`fit_delta` does not apply: `delta` stays the medium's).
    pub fn new(
        model: CorrectedModel,
        opts: OnlineOptions,
    ) -> Result<CorrectedEstimator, OnlineOptionsError> {
        opts.validate()?;
        let c = model.corrections();
        let mut theta0 = vec![c.b_k, c.a.ln()];
        let mut coefficients = Vec::new();
        for t in &c.terms {
            for (v, name) in t.coefficients.iter().zip(t.effect.linear_params()) {
                theta0.push(*v);
                coefficients.push(Coefficient {
                    effect: t.effect,
                    param: name,
                    value: *v,
                    std: v.abs(),
                });
            }
        }
        let n = theta0.len();
        let span_rad = FRAC_PI_2 - model.plate().entry_beta_rad().unwrap_or(0.0);
        let mut s = CorrectedEstimator {
            model,
            opts,
            span_rad: span_rad.max(0.05),
            theta: theta0.clone(),
            p: vec![0.0; n * n],
            theta0,
            seen: vec![false; n],
            col_max: vec![0.0; n],
            force_max_n: 0.0,
            pred_var_n2: 0.0,
            innov: Innovations::new(opts.initial_noise_n),
            innov_out: Innovations::new(opts.initial_noise_n),
            stuck: StuckDetector::default(),
            updates_since_reset: 0,
            swept_since_startup_rad: 0.0,
            prev_beta: None,
            startup: None,
            suspected: None,
            alarms_dismissed: 0,
            lag_prev: None,
            est: Estimate::default(),
            coefficients,
            changes: Vec::new(),
            row: Vec::with_capacity(n),
            fixed: Vec::with_capacity(n),
            raw: Vec::with_capacity(4 * n),
            h: [vec![0.0; n], vec![0.0; n]],
            u: [vec![0.0; n], vec![0.0; n]],
        };
        s.reset();
        Ok(s)
    }

    /// Back to the configured corrections; counters and change history are cleared too.
    pub fn reset(&mut self) {
        self.theta.clone_from(&self.theta0);
        self.innov = Innovations::new(self.opts.initial_noise_n);
        self.innov_out = Innovations::new(self.opts.initial_noise_n);
        self.stuck = StuckDetector::default();
        self.prev_beta = None;
        self.lag_prev = None;
        self.changes.clear();
        self.suspected = None;
        self.alarms_dismissed = 0;
        self.est = Estimate::default();
        self.restart();
        self.refresh_estimate();
    }

    /// Starts again from the current estimate with the start-up's least squares.
    fn restart(&mut self) {
        let n = self.theta.len();
        self.hand_to_startup(Startup::new(self.theta[1], n - 1), vec![0.0; n], 0.0);
    }

    /// Forgets what the Gauss–Newton step learnt and hands the estimate to `startup` (a new one,
    /// or a suspected change's refit with the columns and force it has seen).
    fn hand_to_startup(&mut self, startup: Startup, col_max: Vec<f64>, force_max_n: f64) {
        self.p.iter_mut().for_each(|v| *v = 0.0);
        self.seen.iter_mut().for_each(|v| *v = false);
        self.col_max = col_max;
        self.force_max_n = force_max_n;
        self.pred_var_n2 = 0.0;
        self.updates_since_reset = startup.samples as u64;
        self.startup = Some(startup);
        self.innov.disarm();
        self.swept_since_startup_rad = 0.0;
    }

    /// The options it runs with.
    pub fn options(&self) -> &OnlineOptions {
        &self.opts
    }

    /// The current estimate of `b_k` and `a` (`delta` the medium's, with no deviation).
    pub fn estimate(&self) -> &Estimate {
        &self.est
    }

    /// The current coefficients, in the order of the terms and their parameters.
    pub fn coefficients(&self) -> &[Coefficient] {
        &self.coefficients
    }

    /// The corrected model with the current estimate.
    pub fn model(&self) -> &CorrectedModel {
        &self.model
    }

    /// The confirmed changes of the medium, each at its alarm.
    pub fn changes(&self) -> &[ChangeEvent] {
        &self.changes
    }

    /// Change alarms dismissed: over the start-up's turns after each, the estimate predicted
    /// the samples with less than twice the sum of squares of the start-up's refit of them.
    pub fn alarms_dismissed(&self) -> u64 {
        self.alarms_dismissed
    }

    /// Whether a change alarm is under test: raised, and its start-up's turns not all in yet.
    /// The estimate meanwhile is the one before the alarm, still learning. The test counts the
    /// angle the leg sweeps (either way), so a leg that stops keeps it open until it turns again;
    /// a stopped leg gives the estimate nothing to learn meanwhile.
    pub fn alarm_under_test(&self) -> bool {
        self.suspected.is_some()
    }

    /// Feeds one sample with the leg's motion at its angle; `Ok(())` if it updated the
    /// estimate, otherwise why not.
    pub fn update(&mut self, s: &Sample, motion: &Motion) -> Result<(), Skip> {
        self.update_at(s, motion, None)
    }

    /// [`Self::update`] for a sample whose hip the robot's state placed (`None`: at the
    /// configured height): the model's columns at that hip's height and attack angle.
    pub fn update_at(
        &mut self,
        s: &Sample,
        motion: &Motion,
        hip: Option<&HipMotion>,
    ) -> Result<(), Skip> {
        let r = self.update_inner(s, motion, hip);
        match r {
            Ok(()) => self.est.samples_used += 1,
            Err(Skip::NonFinite) => self.est.samples_non_finite += 1,
            Err(Skip::NotExcited) => self.est.samples_not_excited += 1,
            Err(Skip::Stuck) => self.est.samples_stuck += 1,
        }
        r
    }

    fn update_inner(
        &mut self,
        s: &Sample,
        motion: &Motion,
        hip: Option<&HipMotion>,
    ) -> Result<(), Skip> {
        if !(s.beta_rad.is_finite() && s.drag_n.is_finite() && s.lift_n.is_finite())
            || s.t_s.is_some_and(|t| !t.is_finite())
        {
            return Err(Skip::NonFinite);
        }
        let stuck = self.stuck.see(s.drag_n, s.lift_n) >= self.opts.stuck_samples;
        let (beta, regime) = self.columns(s, motion, hip).ok_or(Skip::NonFinite)?;
        let dbeta = self.prev_beta.map_or(0.0, |p| angle_step(p, beta));
        self.prev_beta = Some(beta);
        if stuck {
            return Err(Skip::Stuck);
        }
        // Out of the medium, a sample tells only the sensor's side: its offset, and the force
        // still coming through its lag.
        let excited = regime != Regime::OutOfMedium
            || self.model.corrections().has(Effect::SensorBias)
            || self.h.iter().flatten().any(|v| *v != 0.0);
        if !excited {
            return Err(Skip::NotExcited);
        }
        let c = self.model.corrections();
        let lag_s = if c.has(Effect::SensorLag) {
            c.nonlinear.lag_s
        } else {
            0.0
        };
        let y = [s.drag_n, s.lift_n];
        let t_s = s.t_s.unwrap_or(0.0);
        if let Some(st) = &mut self.startup {
            st.add(&self.row, &self.fixed, beta, self.theta[1], y, t_s, lag_s);
            st.swept_rad += dbeta;
            let done =
                st.swept_rad >= STARTUP_TURNS * TAU && st.samples >= self.opts.startup_samples;
            for (m, col) in self.col_max[2..].iter_mut().zip(&self.row[1..]) {
                *m = m.max(col[0].abs()).max(col[1].abs());
            }
            self.force_max_n = self.force_max_n.max(s.drag_n.abs()).max(s.lift_n.abs());
            if done {
                self.finish_startup();
            }
        } else {
            self.swept_since_startup_rad += dbeta;
            // The columns are at the `a` before this update.
            let ln_a_row = self.theta[1];
            // `compaction` measures the medium against the session's first stroke: while its
            // strokes last, forgetting them would leave its drift and change indistinguishable
            // from `b_k`, so the estimate remembers the session whole until then.
            let c = self.model.corrections();
            let remember = c.has(Effect::Compaction) && motion.stroke + 1 < c.session_strokes;
            let sq_err_n2 = self.step(s, dbeta, regime != Regime::OutOfMedium, remember);
            if let Some(sus) = &mut self.suspected {
                sus.startup
                    .add(&self.row, &self.fixed, beta, ln_a_row, y, t_s, lag_s);
                sus.startup.swept_rad += dbeta;
                sus.sse_estimate_n2 += sq_err_n2;
                for (m, col) in sus.col_max[2..].iter_mut().zip(&self.row[1..]) {
                    *m = m.max(col[0].abs()).max(col[1].abs());
                }
                sus.force_max_n = sus.force_max_n.max(y[0].abs()).max(y[1].abs());
                if sus.startup.swept_rad >= STARTUP_TURNS * TAU
                    && sus.startup.samples >= self.opts.startup_samples
                {
                    self.decide_suspected();
                }
            }
        }
        self.updates_since_reset += 1;
        self.refresh_estimate();
        if self.est.converged && self.swept_since_startup_rad >= TAU && self.suspected.is_none() {
            self.innov.arm();
        }
        Ok(())
    }

    /// A suspected change, its start-up's turns done: confirmed when the estimate predicted them
    /// [`CONFIRM_SSE_RATIO`] times worse than their refit, and the refit then takes over as a
    /// start-up's would; otherwise dismissed, the estimate kept.
    fn decide_suspected(&mut self) {
        let Some(sus) = self.suspected.take() else {
            return;
        };
        let refit_sse_n2 = sus.startup.best_fit().map(|f| f.sse);
        let confirmed =
            refit_sse_n2.is_some_and(|r| sus.sse_estimate_n2 > CONFIRM_SSE_RATIO * r.max(0.0));
        if !confirmed {
            self.alarms_dismissed += 1;
            return;
        }
        self.changes.push(sus.alarm);
        self.est.changes_detected += 1;
        self.hand_to_startup(sus.startup, sus.col_max, sus.force_max_n);
        self.finish_startup();
    }

    /// The Jacobian rows `h` (drag, lift) at this sample, through the sensor's lag when kept.
    fn columns(
        &mut self,
        s: &Sample,
        motion: &Motion,
        hip: Option<&HipMotion>,
    ) -> Option<(f64, Regime)> {
        let a = self.theta[1].exp();
        let (beta, regime) = self
            .model
            .design_row_at(s.beta_rad, motion, hip, a, &mut self.row, &mut self.fixed)
            .ok()?;
        let n = self.theta.len();
        // Raw values: the columns of b_k and the coefficients, then the derivative in ln a of
        // the prediction, for drag and lift.
        self.raw.clear();
        for c in 0..2 {
            let mut d_ln_a = 0.0;
            for (j, (col, fix)) in self.row.iter().zip(&self.fixed).enumerate() {
                let k = if j == 0 {
                    self.theta[0]
                } else {
                    self.theta[j + 1]
                };
                d_ln_a -= beta * k * (col[c] - fix[c]);
            }
            self.raw.push(self.row[0][c]);
            self.raw.push(d_ln_a);
            self.raw.extend(self.row[1..].iter().map(|col| col[c]));
        }
        let tau = self.model.corrections().nonlinear.lag_s;
        let t = s.t_s.unwrap_or(0.0);
        if self.model.corrections().has(Effect::SensorLag) && tau > 0.0 {
            match &mut self.lag_prev {
                Some((t0, x0, y0)) if t >= *t0 => {
                    for q in 0..2 * n {
                        let y = lag_step(x0[q], self.raw[q], y0[q], t - *t0, tau);
                        x0[q] = self.raw[q];
                        y0[q] = y;
                        self.raw[q] = y;
                    }
                    *t0 = t;
                }
                _ => self.lag_prev = Some((t, self.raw.clone(), self.raw.clone())),
            }
        }
        for c in 0..2 {
            self.h[c].copy_from_slice(&self.raw[c * n..(c + 1) * n]);
        }
        self.h[0]
            .iter()
            .chain(&self.h[1])
            .all(|v| v.is_finite())
            .then_some((beta, regime))
    }

    // Index loops over the state: the update reads as its formulas.
    #[allow(clippy::needless_range_loop)]
    /// One update; returns the squared prediction errors before it (drag and lift, N^2).
    /// `remember`: forget nothing at this update.
    fn step(&mut self, s: &Sample, dbeta: f64, in_medium: bool, remember: bool) -> f64 {
        let o = self.opts;
        let n = self.theta.len();
        let y = [s.drag_n, s.lift_n];
        self.force_max_n = self.force_max_n.max(y[0].abs()).max(y[1].abs());
        let force_scale = self.force_max_n.max(3.0 * self.innov.noise_var.sqrt());
        // The prediction, from the columns: b_k h[0] + sum c_j h[j + 1] (h[1] is ln a's).
        let mut e = [0.0; 2];
        for c in 0..2 {
            let h = &self.h[c];
            let mut pred = self.theta[0] * h[0];
            for j in 2..n {
                pred += self.theta[j] * h[j];
            }
            e[c] = y[c] - pred;
        }
        // Coefficients seen for the first time: their covariance opens.
        for j in 2..n {
            let mag = self.h[0][j].abs().max(self.h[1][j].abs());
            self.col_max[j] = self.col_max[j].max(mag);
            if !self.seen[j] && mag > 0.0 {
                self.seen[j] = true;
                self.p[j * n + j] = (force_scale / mag).powi(2);
            }
        }
        // u_c = P h_c; S = H P H^T + R.
        for c in 0..2 {
            for i in 0..n {
                let row = &self.p[i * n..(i + 1) * n];
                self.u[c][i] = row.iter().zip(&self.h[c]).map(|(a, b)| a * b).sum();
            }
        }
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let mut hph = [[0.0; 2]; 2];
        for a in 0..2 {
            for b in 0..2 {
                hph[a][b] = dot(&self.h[a], &self.u[b]);
            }
        }
        self.pred_var_n2 = (self.pred_var_n2 * stroke_memory_keep(1.0, dbeta, self.span_rad))
            .max(hph[0][0])
            .max(hph[1][1]);
        let mut nis = 0.0;
        let mut r = [0.0; 2];
        let innov = if in_medium {
            &mut self.innov
        } else {
            &mut self.innov_out
        };
        let keep = stroke_memory_keep(NOISE_MEMORY_STROKES, dbeta, self.span_rad);
        for c in 0..2 {
            let (r_c, nis_c) = innov.row_over_strokes(e[c], hph[c][c], &o, keep);
            r[c] = r_c;
            nis += nis_c;
        }
        innov.floor_noise();
        let s00 = hph[0][0] + r[0];
        let s11 = hph[1][1] + r[1];
        let s01 = 0.5 * (hph[0][1] + hph[1][0]);
        let det = s00 * s11 - s01 * s01;
        let sq_err_n2 = e[0] * e[0] + e[1] * e[1];
        if !(det.is_finite() && det > 0.0) {
            return sq_err_n2;
        }
        let si = [[s11 / det, -s01 / det], [-s01 / det, s00 / det]];
        // K = U S^-1: theta += K e, P -= U S^-1 U^T.
        let g = [
            si[0][0] * e[0] + si[0][1] * e[1],
            si[1][0] * e[0] + si[1][1] * e[1],
        ];
        for i in 0..n {
            self.theta[i] += self.u[0][i] * g[0] + self.u[1][i] * g[1];
        }
        let lambda = if remember {
            1.0
        } else {
            forgetting_factor(&o, dbeta, self.span_rad)
        };
        for i in 0..n {
            let ki = [
                self.u[0][i] * si[0][0] + self.u[1][i] * si[1][0],
                self.u[0][i] * si[0][1] + self.u[1][i] * si[1][1],
            ];
            for j in i..n {
                let v = (self.p[i * n + j] - ki[0] * self.u[0][j] - ki[1] * self.u[1][j]) / lambda;
                self.p[i * n + j] = v;
                self.p[j * n + i] = v;
            }
        }
        // Unseen directions stay closed.
        for j in 2..n {
            if !self.seen[j] {
                for i in 0..n {
                    self.p[i * n + j] = 0.0;
                    self.p[j * n + i] = 0.0;
                }
            }
        }
        for i in 0..n {
            if self.p[i * n + i] < 0.0 {
                self.p[i * n + i] = 0.0;
            }
        }
        self.bound_covariance();
        self.project();

        if in_medium && self.innov.change_alarm(nis, 2.0, &o) {
            // Under test until the start-up's turns after it are in (decide_suspected).
            self.innov.disarm();
            self.suspected = Some(Suspected {
                alarm: ChangeEvent {
                    t_s: s.t_s,
                    b_k_before: self.theta[0],
                    a_before: self.theta[1].exp(),
                },
                startup: Startup::new(self.theta[1], n - 1),
                col_max: vec![0.0; n],
                force_max_n: 0.0,
                sse_estimate_n2: 0.0,
            });
        }
        sq_err_n2
    }

    /// The start-up's least squares: at the `ln a` of the grid with the least squared residual,
    /// one Gauss–Newton step, and its covariance.
    fn finish_startup(&mut self) {
        let Some(st) = self.startup.take() else {
            return;
        };
        let n = self.theta.len();
        let m = n - 1;
        let Some(fit) = st.best_fit() else {
            // Nothing to solve (no force seen): start again.
            self.startup = Some(Startup::new(self.theta[1], m));
            return;
        };
        let rows = (2 * st.samples).saturating_sub(n).max(1);
        let noise_var = (fit.sse / rows as f64).max(1e-12);
        self.innov.set_noise(noise_var);
        self.innov_out.set_noise(noise_var);
        // State index of the start-up's value `i` (the linear values, then ln a).
        let index = |i: usize| match i {
            0 => 0,
            i if i == m => 1,
            i => i + 1,
        };
        let seen = |i: usize| i == m || fit.seen[i];
        for i in 0..=m {
            self.seen[index(i)] = seen(i);
            if seen(i) {
                self.theta[index(i)] = fit.theta[i];
            }
        }
        for i in 0..=m {
            for j in 0..=m {
                if seen(i) && seen(j) {
                    self.p[index(i) * n + index(j)] =
                        STARTUP_INFLATION * noise_var * fit.cov[(i, j)];
                }
            }
        }
        self.project();
    }

    /// No wind-up: `b_k` and `a` within `max_std_ln` (relative), each coefficient's contribution
    /// within `max_std_ln` of the largest force.
    fn bound_covariance(&mut self) {
        let n = self.theta.len();
        let max = self.opts.max_std_ln.powi(2);
        let mut worst = self.p[0] / self.theta[0].powi(2).max(1e-300) / max;
        worst = worst.max(self.p[n + 1] / max);
        let force = self.force_max_n.max(1e-9);
        for j in 2..n {
            if self.seen[j] && self.col_max[j] > 0.0 {
                worst = worst.max(self.p[j * n + j] * (self.col_max[j] / force).powi(2) / max);
            }
        }
        if worst > 1.0 {
            self.p.iter_mut().for_each(|v| *v /= worst);
        }
    }

    fn project(&mut self) {
        let o = &self.opts;
        self.theta[0] = self.theta[0].clamp(o.b_k_range.0, o.b_k_range.1);
        self.theta[1] = self.theta[1].clamp(o.a_range.0.ln(), o.a_range.1.ln());
        for (v, c) in self.theta[2..].iter_mut().zip(&self.coefficients) {
            let bound = c.effect.linear_bound(c.param);
            *v = v.clamp(-bound, bound);
        }
    }

    fn refresh_estimate(&mut self) {
        let n = self.theta.len();
        let o = &self.opts;
        let (b_k, a) = (self.theta[0], self.theta[1].exp());
        // During the start-up nothing is learnt yet: the deviations are the prior's.
        let starting = self.startup.is_some();
        let prior = [o.initial_std_ln * b_k, o.initial_std_ln];
        let sd = |i: usize| match (starting, i) {
            (true, 0 | 1) => prior[i],
            (true, _) => self.theta[i].abs(),
            _ => self.p[i * n + i].max(0.0).sqrt(),
        };
        let force = self.force_max_n.max(1e-9);
        // The coefficients are known when each one's part of the force is, or when the force
        // they predict together is, over the last turn: terms that nearly share a form (a
        // change of the medium's scale and of its friction, say) leave each coefficient loose
        // while their sum is held by every sample.
        let prediction_known = !starting
            && self.swept_since_startup_rad >= TAU
            && self.pred_var_n2.sqrt() < o.converge_rel_std * force;
        let mut coefficients_known = true;
        for (j, c) in (2..n).zip(self.coefficients.iter_mut()) {
            c.value = self.theta[j];
            let seen = self.seen[j] && !starting;
            c.std = if seen { sd(j) } else { c.value.abs() };
            if seen && sd(j) * self.col_max[j] >= o.converge_rel_std * force {
                coefficients_known = false;
            }
        }
        self.model
            .set_linear(b_k, a, self.theta[2..].iter().copied());
        let e = &mut self.est;
        e.b_k = b_k;
        e.a = a;
        e.delta_deg = self.model.medium().delta_deg();
        e.std_b_k = sd(0);
        e.std_a = a * sd(1);
        e.std_delta_deg = 0.0;
        e.innovation_rms_n = self.innov.innov_ms.sqrt();
        e.noise_n = self.innov.noise_var.sqrt();
        e.converged = self.updates_since_reset >= o.converge_min_updates
            && self.startup.is_none()
            && sd(0) < o.converge_rel_std * b_k
            && sd(1) < o.converge_rel_std
            && (coefficients_known || prediction_known)
            && self.innov.cusum < 0.5 * o.cusum_alarm;
    }
}

/// Feeds one leg's samples to `est` in the order given, the leg's motion followed from their own
/// angles and times as the node follows it from its joint angles ([`MOTION_WINDOW_S`]). Samples
/// without a time are fed with the motion of the last timed one.
pub fn learn_samples(est: &mut CorrectedEstimator, samples: &[Sample]) {
    let plate = *est.model().plate();
    let mut tracker = MotionTracker::new(MOTION_WINDOW_S);
    let mut motion = Motion::default();
    for s in samples {
        if let Some(t) = s.t_s {
            let submerged = plate.submerged_length_m(wrap_beta_rad(s.beta_rad));
            motion = tracker.update(t, s.beta_rad, submerged, plate.length_m());
        }
        let _ = est.update(s, &motion);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ident::online::Forgetting;
    use crate::model::corrections::{Corrections, Nonlinear, Term};
    use crate::model::{Medium, Plate};

    fn model(b_k: f64, a: f64, cohesion: [f64; 2], bias: [f64; 2]) -> CorrectedModel {
        let c = Corrections {
            b_k,
            a,
            terms: vec![
                Term {
                    effect: Effect::Cohesion,
                    coefficients: cohesion.to_vec(),
                },
                Term {
                    effect: Effect::SensorBias,
                    coefficients: bias.to_vec(),
                },
            ],
            nonlinear: Nonlinear::default(),
            typical_speed_rad_s: 2.0,
            session_strokes: 10,
        };
        CorrectedModel::new(
            Plate::new(0.25, 0.06, 0.15).unwrap(),
            Medium::new(16170.0, 32.0, 19.0).unwrap(),
            c,
        )
        .unwrap()
    }

    /// A leg turning at 2 rad/s, sampled at 500 Hz: what `truth`'s sensor reads, with a small
    /// deterministic wobble.
    fn session(truth: &CorrectedModel, turns: f64) -> Vec<Sample> {
        let (omega, dt) = (2.0, 0.002);
        let mut tracker = MotionTracker::new(MOTION_WINDOW_S);
        (0..(turns * TAU / omega / dt) as usize)
            .map(|i| {
                let (t, beta) = (i as f64 * dt, 0.3 + i as f64 * dt * omega);
                let sub = truth.plate().submerged_length_m(wrap_beta_rad(beta));
                let m = tracker.update(t, beta, sub, truth.plate().length_m());
                let p = truth.evaluate(beta, &m).unwrap();
                let wobble = 0.05 * ((i * 7919) % 13) as f64 / 13.0 - 0.025;
                Sample {
                    t_s: Some(t),
                    beta_rad: beta,
                    drag_n: p.sensor_drag_n + wobble,
                    lift_n: p.sensor_lift_n - wobble,
                }
            })
            .collect()
    }

    #[test]
    fn learns_a_corrected_model_from_scratch_and_skips_bad_samples() {
        let truth = model(2.5, 1.6, [3000.0, 500.0], [1.5, -2.0]);
        let mut samples = session(&truth, 12.0);
        for k in (100..samples.len()).step_by(997) {
            samples[k].drag_n = f64::NAN;
        }
        let nan = samples.iter().filter(|s| s.drag_n.is_nan()).count() as u64;
        let scratch = model(1.0, 1.0, [0.0, 0.0], [0.0, 0.0]);
        let mut est = CorrectedEstimator::new(scratch, OnlineOptions::default()).unwrap();
        learn_samples(&mut est, &samples);
        let e = est.estimate();
        assert!(e.converged, "{e:?}");
        assert_eq!(e.samples_non_finite, nan);
        assert!((e.b_k / 2.5 - 1.0).abs() < 0.01, "{e:?}");
        assert!((e.a / 1.6 - 1.0).abs() < 0.01, "{e:?}");
        let want = [3000.0, 500.0, 1.5, -2.0];
        for (c, w) in est.coefficients().iter().zip(want) {
            assert!((c.value - w).abs() < 0.02 * w.abs(), "{c:?} against {w}");
            assert!(c.std.is_finite() && c.std > 0.0);
        }
        // The model it holds predicts with what it learnt.
        assert_eq!(est.model().corrections().b_k, e.b_k);
    }

    #[test]
    fn a_step_of_the_medium_is_detected_and_followed() {
        let before = model(2.5, 1.6, [3000.0, 500.0], [1.5, -2.0]);
        let after = model(3.5, 1.6, [3000.0, 500.0], [1.5, -2.0]);
        let first = session(&before, 10.0);
        let t_end = first.last().unwrap().t_s.unwrap();
        let second: Vec<Sample> = session(&after, 10.0)
            .into_iter()
            .map(|s| Sample {
                t_s: s.t_s.map(|t| t + t_end + 0.002),
                beta_rad: s.beta_rad + 10.0 * TAU,
                ..s
            })
            .collect();
        let scratch = model(1.0, 1.0, [0.0, 0.0], [0.0, 0.0]);
        let mut est = CorrectedEstimator::new(scratch, OnlineOptions::default()).unwrap();
        learn_samples(&mut est, &first);
        assert_eq!(est.estimate().changes_detected, 0);
        learn_samples(&mut est, &second);
        let e = est.estimate();
        assert_eq!(e.changes_detected, 1, "{e:?}");
        let t_change = est.changes()[0].t_s.unwrap();
        assert!(
            t_change > t_end && t_change < t_end + TAU / 2.0,
            "{t_change}"
        );
        assert!(e.converged && (e.b_k / 3.5 - 1.0).abs() < 0.01, "{e:?}");
    }

    /// A passing disturbance (a quarter turn through something 60 % stronger, a stone) raises a
    /// change alarm; over the turns after it the estimate predicts as well as a refit, so the
    /// alarm is dismissed and the converged estimate kept, not thrown away for a new start-up.
    #[test]
    fn a_passing_disturbance_is_not_taken_for_a_change() {
        let truth = model(2.5, 1.6, [3000.0, 500.0], [1.5, -2.0]);
        let mut samples = session(&truth, 16.0);
        let per_turn = samples.len() / 16;
        // In the medium, during the tenth turn.
        let burst: Vec<usize> = (9 * per_turn..10 * per_turn)
            .filter(|&k| samples[k].drag_n.abs() > 5.0)
            .take(per_turn / 4)
            .collect();
        assert!(burst.len() > 50, "{}", burst.len());
        for &k in &burst {
            samples[k].drag_n *= 1.6;
            samples[k].lift_n *= 1.6;
        }
        let scratch = model(1.0, 1.0, [0.0, 0.0], [0.0, 0.0]);
        let mut est = CorrectedEstimator::new(scratch, OnlineOptions::default()).unwrap();
        learn_samples(&mut est, &samples[..9 * per_turn]);
        assert!(est.estimate().converged, "{:?}", est.estimate());
        learn_samples(&mut est, &samples[9 * per_turn..]);
        let e = est.estimate();
        assert_eq!(est.alarms_dismissed(), 1, "{e:?}");
        assert_eq!(e.changes_detected, 0, "{e:?}");
        assert!(e.converged && (e.b_k / 2.5 - 1.0).abs() < 0.01, "{e:?}");
    }

    /// A medium that strengthens over the session, saturating (not the term's form, as on a
    /// robot), learnt with `compaction`: while the session's strokes last the estimate forgets
    /// none of them, whatever its memory, since the term is measured from the first; after them
    /// the memory applies again. Its change's coefficients nearly share one form, so the
    /// estimate converges on the force they predict together.
    #[test]
    fn compaction_is_learnt_over_the_whole_session_while_its_strokes_last() {
        let strokes = 14;
        let compacting = |b_k: f64, coefficients: [f64; 5]| {
            let c = Corrections {
                b_k,
                a: 1.6,
                terms: vec![Term {
                    effect: Effect::Compaction,
                    coefficients: coefficients.to_vec(),
                }],
                nonlinear: Nonlinear::default().with(Effect::Compaction, 0.3),
                typical_speed_rad_s: 2.0,
                session_strokes: strokes,
            };
            let plate = Plate::new(0.25, 0.06, 0.15).unwrap();
            CorrectedModel::new(plate, Medium::new(16170.0, 32.0, 19.0).unwrap(), c).unwrap()
        };
        let bare = compacting(2.5, [0.0; 5]);
        let mut samples = session(&bare, 20.0);
        let per_turn = samples.len() / 20;
        for (k, s) in samples.iter_mut().enumerate() {
            let turn = (k / per_turn) as f64;
            let gain = 1.0 + 0.4 * (1.0 - (-turn / 3.0).exp());
            s.drag_n *= gain;
            s.lift_n *= gain;
        }
        let learnt = |memory_strokes: f64, upto: usize| {
            let opts = OnlineOptions {
                forgetting: Forgetting::Strokes(memory_strokes),
                ..Default::default()
            };
            let mut est = CorrectedEstimator::new(compacting(1.0, [0.0; 5]), opts).unwrap();
            learn_samples(&mut est, &samples[..upto]);
            let mut values = vec![est.estimate().b_k, est.estimate().a];
            values.extend(est.coefficients().iter().map(|c| c.value));
            (values, est.estimate().converged)
        };
        let within_session = (strokes - 1) * per_turn;
        let (short, converged) = learnt(3.0, within_session);
        let (long, _) = learnt(1e12, within_session);
        for (x, y) in short.iter().zip(&long) {
            assert!(
                (x - y).abs() <= 1e-6 * y.abs().max(1.0),
                "{short:?} {long:?}"
            );
        }
        assert!(converged, "{short:?}");
        let (short, _) = learnt(3.0, samples.len());
        let (long, _) = learnt(1e12, samples.len());
        assert!(
            short
                .iter()
                .zip(&long)
                .any(|(x, y)| (x - y).abs() > 1e-4 * y.abs()),
            "{short:?} {long:?}"
        );
    }
}
