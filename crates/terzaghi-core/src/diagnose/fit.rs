//! Fitting a design (the baseline plus some effects) by whole-stroke folds.
//!
//! The prediction is `y = b_k X_0(a) + sum_j c_j X_j(a)`, with `X_0 = a^(-beta) F_unit(beta)` and
//! the effects' columns. For a given `a` (and nonlinear parameters) it is linear: least squares
//! gives `b_k` and the `c_j`. `ln a` is searched on a grid, then refined by a parabola through the
//! three best grid points. One pass over the points gives the normal equations of every fold at
//! once (the training sums of fold `k` are the total minus fold `k`'s own), so the search costs
//! the same for five folds as for one. A fold's held-out points are predicted with the parameters
//! fitted without them.

use super::context::Context;
use super::effects::{Effect, nonlinear_grid};
pub use crate::model::corrections::Nonlinear;
#[cfg(doc)]
use crate::model::corrections::lag_step;
use crate::model::corrections::{LN_A_GRID, ln_a_grid};
use nalgebra::{DMatrix, DVector};

/// A design: the effects added to the baseline, and the nonlinear values of the ones already
/// chosen (per fold, and at index `folds` for the fit on everything).
#[derive(Debug, Clone)]
pub struct Design {
    pub effects: Vec<Effect>,
    pub fixed: Vec<Nonlinear>,
}

impl Design {
    pub fn baseline(folds: usize) -> Design {
        Design {
            effects: Vec::new(),
            fixed: vec![Nonlinear::default(); folds + 1],
        }
    }
    pub fn columns(&self) -> usize {
        1 + self
            .effects
            .iter()
            .map(|e| e.linear_params().len())
            .sum::<usize>()
    }
}

/// A fitted design.
#[derive(Debug, Clone)]
pub struct Fit {
    pub design: Design,
    /// Held-out predictions (drag, lift), N, one per point.
    pub heldout_n: Vec<[f64; 2]>,
    /// Predictions of the fit on every stroke (for plots).
    pub fitted_n: Vec<[f64; 2]>,
    /// Fit on everything: `a`, then the coefficients (`b_k` first), and nonlinear values.
    pub a: f64,
    pub coefficients: Vec<f64>,
    /// Nonlinear values per fold and (last) for the fit on everything.
    pub nonlinear: Vec<Nonlinear>,
    /// Held-out sum of squared residuals over drag and lift (N^2).
    pub heldout_sse: f64,
    /// Standard deviations of `a` and of the coefficients: the delete-a-fold jackknife over
    /// the folds' fits (each on every stroke but its fold's), `sqrt((k-1)/k sum (x_i - mean)^2)`,
    /// the nonlinear values as each fold chose them. Whole strokes leave together, so strokes
    /// that differ widen it as they should. `None` with fewer than two folds.
    pub std: Option<FitStd>,
}

/// The standard deviations of a [`Fit`]'s values.
#[derive(Debug, Clone, PartialEq)]
pub struct FitStd {
    /// Of `a`.
    pub a: f64,
    /// Of each coefficient, in the order of [`Fit::coefficients`].
    pub coefficients: Vec<f64>,
}

/// The delete-a-group jackknife's standard deviation of values `x` from `k >= 2` fits, each
/// leaving one group out.
fn jackknife_std(x: impl Iterator<Item = f64> + Clone) -> f64 {
    let k = x.clone().count() as f64;
    let mean = x.clone().sum::<f64>() / k;
    ((k - 1.0) / k * x.map(|v| (v - mean).powi(2)).sum::<f64>()).sqrt()
}

impl Fit {
    /// Held-out mean squared residual per component (N^2).
    pub fn heldout_mse(&self) -> f64 {
        self.heldout_sse / (2 * self.heldout_n.len().max(1)) as f64
    }
}

/// Fits `design` plus, if given, `search`: a new effect (its nonlinear parameter, if any, is
/// chosen per fold on the training strokes from its grid).
pub fn fit(ctx: &Context, design: &Design, search: Option<Effect>) -> Fit {
    let mut design = design.clone();
    if let Some(e) = search {
        design.effects.push(e);
    }
    let grid: Vec<Option<(Effect, f64)>> =
        match search.and_then(|e| nonlinear_grid(e, ctx).map(|g| (e, g))) {
            Some((e, (_, values))) => values.into_iter().map(|v| Some((e, v))).collect(),
            None => vec![None],
        };
    let k_all = ctx.folds;
    let mut best: Vec<Option<Candidate>> = vec![None; k_all + 1];
    // A change in the session is fitted only where the fold's training strokes lie on both
    // sides of it: otherwise its column is the baseline's own on the training strokes, and the
    // held-out strokes before it would be predicted from an arbitrary split of the two.
    // Only a search for `compaction` needs the spans: a pass over the points per fold.
    let span: Vec<(f64, f64)> = if search == Some(Effect::Compaction) {
        (0..=k_all)
            .map(|k| {
                ctx.points
                    .iter()
                    .filter(|p| k == k_all || p.fold != k)
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                        (lo.min(p.session_frac), hi.max(p.session_frac))
                    })
            })
            .collect()
    } else {
        Vec::new()
    };
    let usable = |k: usize, g: &Option<(Effect, f64)>| match g {
        Some((Effect::Compaction, v)) => span[k].0 < *v && *v < span[k].1,
        _ => true,
    };
    for g in &grid {
        let nl: Vec<Nonlinear> = design
            .fixed
            .iter()
            .map(|f| g.map_or(*f, |(e, v)| f.with(e, v)))
            .collect();
        for cand in fit_ln_a(ctx, &design.effects, &nl) {
            let k = cand.k;
            if !usable(k, g) {
                continue;
            }
            if best[k]
                .as_ref()
                .is_none_or(|b| cand.train_sse < b.train_sse)
            {
                best[k] = Some(cand);
            }
        }
    }
    // The training strokes say only between which two of them the change lies: it is put
    // halfway, so that a held-out stroke between them counts as half changed rather than
    // falling to one side by rounding.
    if let Some(Effect::Compaction) = search {
        let mut nl: Vec<Nonlinear> = best
            .iter()
            .zip(&design.fixed)
            .map(|(b, f)| b.as_ref().map_or(*f, |b| b.nl))
            .collect();
        for (k, v) in nl.iter_mut().enumerate() {
            let at = v.change_at_session_frac;
            let (below, above) = ctx
                .points
                .iter()
                .filter(|p| k == k_all || p.fold != k)
                .fold((f64::NEG_INFINITY, f64::INFINITY), |(lo, hi), p| {
                    let u = p.session_frac;
                    (
                        if u < at { lo.max(u) } else { lo },
                        if u > at { hi.min(u) } else { hi },
                    )
                });
            if below.is_finite() && above.is_finite() {
                *v = v.with(Effect::Compaction, 0.5 * (below + above));
            }
        }
        for c in fit_ln_a(ctx, &design.effects, &nl) {
            let k = c.k;
            best[k] = Some(c);
        }
    }
    // A fold with no usable change point (its training strokes all on one side of every one)
    // is fitted with the change at the session's end, where no stroke counts as changed.
    for k in 0..=k_all {
        if best[k].is_none() {
            let mut nl = design.fixed.clone();
            nl[k] = nl[k].with(Effect::Compaction, 2.0);
            best[k] = fit_ln_a(ctx, &design.effects, &nl)
                .into_iter()
                .find(|c| c.k == k);
        }
    }
    let best: Vec<Candidate> = best
        .into_iter()
        .map(|b| b.expect("every fold is fitted"))
        .collect();
    // Held-out predictions: each fold from its own fit (the lag filter runs over all points).
    let n = ctx.points.len();
    let mut heldout = vec![[0.0; 2]; n];
    let mut fitted = vec![[0.0; 2]; n];
    let mut cols = Vec::new();
    for c in &best {
        let unit = ctx.unit_forces_with_hip_offset(c.nl.surface_drop_m);
        build(ctx, &design.effects, c.ln_a.exp(), &c.nl, &unit, &mut cols);
        let p = design.columns();
        for (i, pt) in ctx.points.iter().enumerate() {
            if c.k == k_all || pt.fold == c.k {
                let cols = &cols;
                let at = |c0: usize| (0..p).map(move |j| cols[(c0 + j) * n + i]);
                let yd: f64 = at(0).zip(&c.coef).map(|(x, c)| x * c).sum();
                let yl: f64 = at(p).zip(&c.coef).map(|(x, c)| x * c).sum();
                if c.k == k_all {
                    fitted[i] = [yd, yl];
                } else {
                    heldout[i] = [yd, yl];
                }
            }
        }
    }
    let heldout_sse = ctx
        .points
        .iter()
        .zip(&heldout)
        .map(|(p, h)| (p.y_n[0] - h[0]).powi(2) + (p.y_n[1] - h[1]).powi(2))
        .sum();
    let all = &best[k_all];
    let folds = &best[..k_all];
    let std = (k_all >= 2).then(|| FitStd {
        a: jackknife_std(folds.iter().map(|c| c.ln_a.exp())),
        coefficients: (0..all.coef.len())
            .map(|j| jackknife_std(folds.iter().map(|c| c.coef[j])))
            .collect(),
    });
    design.fixed = best.iter().map(|c| c.nl).collect();
    Fit {
        std,
        nonlinear: design.fixed.clone(),
        design,
        heldout_n: heldout,
        fitted_n: fitted,
        a: all.ln_a.exp(),
        coefficients: all.coef.clone(),
        heldout_sse,
    }
}

/// One fold's fit at one nonlinear setting.
#[derive(Debug, Clone)]
struct Candidate {
    k: usize,
    ln_a: f64,
    nl: Nonlinear,
    coef: Vec<f64>,
    train_sse: f64,
}

/// Per-fold sums of the normal equations.
#[derive(Clone)]
struct Sums {
    xtx: DMatrix<f64>,
    xty: DVector<f64>,
    yty: f64,
}

impl Sums {
    fn zero(p: usize) -> Sums {
        Sums {
            xtx: DMatrix::zeros(p, p),
            xty: DVector::zeros(p),
            yty: 0.0,
        }
    }
    fn minus(&self, o: &Sums) -> Sums {
        Sums {
            xtx: &self.xtx - &o.xtx,
            xty: &self.xty - &o.xty,
            yty: self.yty - o.yty,
        }
    }
    /// Least squares with columns scaled to unit norm and a tiny ridge (collinear columns of a
    /// design must not blow up); returns coefficients and the sum of squared residuals.
    fn solve(&self) -> (Vec<f64>, f64) {
        let p = self.xty.len();
        let d: Vec<f64> = (0..p)
            .map(|j| {
                let v = self.xtx[(j, j)];
                if v > 0.0 { 1.0 / v.sqrt() } else { 0.0 }
            })
            .collect();
        let mut m = DMatrix::from_fn(p, p, |i, j| self.xtx[(i, j)] * d[i] * d[j]);
        for j in 0..p {
            m[(j, j)] += 1e-9;
        }
        let rhs = DVector::from_fn(p, |i, _| self.xty[i] * d[i]);
        let z = m
            .clone()
            .cholesky()
            .map(|c| c.solve(&rhs))
            .or_else(|| m.lu().solve(&rhs))
            .unwrap_or_else(|| DVector::zeros(p));
        let c = DVector::from_fn(p, |i, _| z[i] * d[i]);
        let sse = self.yty - 2.0 * c.dot(&self.xty) + (c.transpose() * &self.xtx * &c)[(0, 0)];
        (c.iter().copied().collect(), sse.max(0.0))
    }
}

/// Searches `ln a` for every fold `k` (and `k = folds`: everything) with nonlinear values `nl[k]`.
fn fit_ln_a(ctx: &Context, effects: &[Effect], nl: &[Nonlinear]) -> Vec<Candidate> {
    let (lo, hi, steps) = LN_A_GRID;
    let grid: Vec<f64> = ln_a_grid().collect();
    let k_all = ctx.folds;
    // Folds sharing a nonlinear setting share the passes.
    let mut groups: Vec<(Nonlinear, Vec<usize>)> = Vec::new();
    for (k, v) in nl.iter().enumerate() {
        match groups.iter_mut().find(|(g, _)| g == v) {
            Some((_, ks)) => ks.push(k),
            None => groups.push((*v, vec![k])),
        }
    }
    let mut buf = Buffers::default();
    let mut out = Vec::new();
    for (setting, ks) in groups {
        let unit = ctx.unit_forces_with_hip_offset(setting.surface_drop_m);
        let parts = Parts::new(ctx, effects, &setting, &unit);
        // sse[k][grid index]
        let mut sse = vec![vec![f64::INFINITY; grid.len()]; k_all + 1];
        for (gi, &ln_a) in grid.iter().enumerate() {
            let sums = fold_sums(ctx, &parts, ln_a, &mut buf);
            for &k in &ks {
                sse[k][gi] = train(&sums, k, k_all).solve().1;
            }
        }
        // Closer looks, shared by the folds: two points a third, a ninth, then a 27th of a step
        // either side of the folds' median estimate so far, each fold's parabola through its
        // three best neighbouring points after each. One look left `a` 1-2 % off where the sum
        // of squares is not a parabola over a third of a step, and the baseline then misfit
        // noise-free forces of its own model by a few hundredths of a newton.
        let h = (hi - lo) / (steps - 1) as f64;
        let mut xs: Vec<f64> = grid.clone();
        let mut ys: Vec<Vec<f64>> = sse.clone();
        let sorted = |xs: &[f64]| {
            let mut order: Vec<usize> = (0..xs.len()).collect();
            order.sort_by(|&a, &b| xs[a].total_cmp(&xs[b]));
            order
        };
        for div in [3.0, 9.0, 27.0] {
            let order = sorted(&xs);
            let x_sorted: Vec<f64> = order.iter().map(|&i| xs[i]).collect();
            let mut est: Vec<f64> = ks
                .iter()
                .map(|&k| {
                    let y: Vec<f64> = order.iter().map(|&i| ys[k][i]).collect();
                    refine(&x_sorted, &y)
                })
                .collect();
            est.sort_by(f64::total_cmp);
            let mid = est[est.len() / 2];
            for x in [mid - h / div, mid + h / div] {
                if x <= lo || x >= hi {
                    continue;
                }
                let sums = fold_sums(ctx, &parts, x, &mut buf);
                xs.push(x);
                for (k, y) in ys.iter_mut().enumerate() {
                    y.push(if ks.contains(&k) {
                        train(&sums, k, k_all).solve().1
                    } else {
                        f64::INFINITY
                    });
                }
            }
        }
        let order = sorted(&xs);
        let xs: Vec<f64> = order.iter().map(|&i| xs[i]).collect();
        for &k in &ks {
            let y: Vec<f64> = order.iter().map(|&i| ys[k][i]).collect();
            let ln_a = refine(&xs, &y);
            let sums = fold_sums(ctx, &parts, ln_a, &mut buf);
            let (coef, train_sse) = train(&sums, k, k_all).solve();
            out.push(Candidate {
                k,
                ln_a,
                nl: setting,
                coef,
                train_sse,
            });
        }
    }
    out
}

/// Training sums of fold `k` from per-fold sums (last entry: the total).
fn train(sums: &[Sums], k: usize, k_all: usize) -> Sums {
    if k == k_all {
        sums[k_all].clone()
    } else {
        sums[k_all].minus(&sums[k])
    }
}

/// Minimum of the parabola through the best of the increasing points `x` and its neighbours
/// (the best point itself at the ends).
fn refine(x: &[f64], y: &[f64]) -> f64 {
    let j = (0..y.len())
        .min_by(|&a, &b| y[a].total_cmp(&y[b]))
        .unwrap_or(0);
    if j == 0 || j + 1 >= y.len() {
        return x[j];
    }
    let (x0, x1, x2) = (x[j - 1], x[j], x[j + 1]);
    let (y0, y1, y2) = (y[j - 1], y[j], y[j + 1]);
    let num = (x1 - x0).powi(2) * (y1 - y2) - (x1 - x2).powi(2) * (y1 - y0);
    let den = (x1 - x0) * (y1 - y2) - (x1 - x2) * (y1 - y0);
    if den == 0.0 || !(num / den).is_finite() {
        return x1;
    }
    (x1 - 0.5 * num / den).clamp(x0, x2)
}

/// Scratch space of [`fold_sums`], kept between its calls.
#[derive(Default)]
struct Buffers {
    /// The columns in time order (when the sensor's lag needs them so).
    cols: Vec<f64>,
    /// `a^(-beta)` at the points that count, in their order (without the sensor's lag).
    w: Vec<f64>,
    /// A chunk of one fold's points, column by column ([`CHUNK`] values a column).
    chunk: Vec<f64>,
}

/// How many of a fold's points [`fold_sums`] takes at once: their columns stay in the fastest
/// cache while every product of two columns is summed over them.
const CHUNK: usize = 128;

/// Per-fold sums (index `folds`: the total) of the design at `ln_a` (its columns from
/// `parts`). A fold's points are taken a chunk at a time, their columns gathered side by side,
/// so that each entry of the normal equations is a dot product over contiguous memory. Without
/// the sensor's lag no column is written out for the whole session: a chunk's are made from
/// `parts` as they are gathered.
fn fold_sums(ctx: &Context, parts: &Parts, ln_a: f64, buf: &mut Buffers) -> Vec<Sums> {
    let (p, n) = (parts.p, ctx.points.len());
    let mut sums = vec![Sums::zero(p); ctx.folds + 1];
    if n == 0 {
        return sums;
    }
    let lagged = parts.lag_s > 0.0;
    if lagged {
        parts.columns(ctx, ln_a, &mut buf.cols);
    } else {
        // At the points that count, in their order.
        buf.w.clear();
        buf.w
            .extend((parts.order.iter()).map(|&i| (-ln_a * parts.beta_rad[i]).exp()));
    }
    buf.chunk.resize(2 * p * CHUNK, 0.0);
    let mut xtx = vec![0.0; p * p];
    let mut xty = vec![0.0; p];
    for (f, range) in parts.fold_ranges.iter().enumerate() {
        xtx.fill(0.0);
        xty.fill(0.0);
        for start in range.clone().step_by(CHUNK) {
            let idx = &parts.order[start..(start + CHUNK).min(range.end)];
            let m = idx.len();
            for (q, dst) in buf.chunk.chunks_exact_mut(CHUNK).enumerate() {
                let dst = &mut dst[..m];
                let col = q * n..(q + 1) * n;
                if lagged {
                    let src = &buf.cols[col];
                    for (d, &i) in dst.iter_mut().zip(idx) {
                        *d = src[i];
                    }
                } else {
                    let (fixed, scaled) = (&parts.fixed[col.clone()], &parts.scaled[col]);
                    let w = &buf.w[start..start + m];
                    for ((d, &i), w) in dst.iter_mut().zip(idx).zip(w) {
                        *d = fixed[i] + scaled[i] * w;
                    }
                }
            }
            for c in 0..2 {
                let col = |j: usize| &buf.chunk[(c * p + j) * CHUNK..][..m];
                let y = &parts.y_by_fold[c * parts.order.len() + start..][..m];
                for j in 0..p {
                    let xj = col(j);
                    for k in j..p {
                        xtx[j * p + k] += dot(xj, col(k));
                    }
                    xty[j] += dot(xj, y);
                }
            }
        }
        let s = &mut sums[f];
        for j in 0..p {
            for k in j..p {
                s.xtx[(j, k)] = xtx[j * p + k];
                s.xtx[(k, j)] = xtx[j * p + k];
            }
            s.xty[j] = xty[j];
        }
        s.yty = parts.yty[f];
        let own = s.clone();
        let total = &mut sums[ctx.folds];
        total.xtx += &own.xtx;
        total.xty += &own.xty;
        total.yty += own.yty;
    }
    sums
}

/// `sum a_i b_i`, in four running sums (which the compiler keeps in vector registers).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| x * y)
        .sum();
    let mut acc = [0.0; 4];
    for (x, y) in ca.zip(cb) {
        for k in 0..4 {
            acc[k] += x[k] * y[k];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// The design's columns at every point, column by column: `cols[(c p + j) n + i]` for point
/// `i` of `n`, component `c` (drag, lift), column `j`.
/// `unit` is the unit model's forces at every point for `nl`'s surface level
/// ([`Context::unit_forces_with_hip_offset`]), computed once per setting by the caller.
fn build(
    ctx: &Context,
    effects: &[Effect],
    a: f64,
    nl: &Nonlinear,
    unit: &[[f64; 2]],
    cols: &mut Vec<f64>,
) {
    let ln_a = a.ln();
    let p = columns_at(
        ctx,
        effects,
        nl,
        unit,
        |pt| (-ln_a * pt.beta_rad).exp(),
        cols,
    );
    if nl.lag_s > 0.0 {
        lag(ctx, nl.lag_s, p, cols);
    }
}

/// The columns, before the sensor's lag, with the factor `a^(-beta)` given per point by `w`;
/// returns how many columns a component has.
fn columns_at(
    ctx: &Context,
    effects: &[Effect],
    nl: &Nonlinear,
    unit: &[[f64; 2]],
    w: impl Fn(&super::context::Point) -> f64,
    cols: &mut Vec<f64>,
) -> usize {
    let p = 1 + effects
        .iter()
        .map(|e| e.linear_params().len())
        .sum::<usize>();
    let n = ctx.points.len();
    cols.clear();
    cols.resize(2 * n * p, 0.0);
    let mut row: Vec<[f64; 2]> = Vec::with_capacity(p);
    for (i, pt) in ctx.points.iter().enumerate() {
        let w = w(pt);
        let base = [w * unit[i][0], w * unit[i][1]];
        row.clear();
        row.push(base);
        for e in effects {
            e.push_columns(&pt.terms(), base, w, nl, &mut row);
        }
        for (j, v) in row.iter().enumerate() {
            cols[j * n + i] = v[0];
            cols[(p + j) * n + i] = v[1];
        }
    }
    p
}

/// A design's columns at one nonlinear setting, split by how they depend on `a`: every column
/// is `fixed + scaled a^(-beta)` at each point (the baseline and every term built on it scale
/// with `a^(-beta)`; the others do not see `a`). The search over `a` then costs one
/// exponential and a multiply-add per column and point, instead of the terms' evaluation.
struct Parts {
    p: usize,
    fixed: Vec<f64>,
    scaled: Vec<f64>,
    /// The indices of the points that count, fold by fold (in time order within a fold), and
    /// each fold's range of them.
    order: Vec<usize>,
    fold_ranges: Vec<std::ops::Range<usize>>,
    /// The measured drag, then lift, in `order`; and each fold's sum of their squares over
    /// all of its points.
    y_by_fold: Vec<f64>,
    yty: Vec<f64>,
    /// The points' attack angles (rad), in time order.
    beta_rad: Vec<f64>,
    /// The sensor's time constant of the setting (s; 0: no lag), and its steps between points
    /// ([`lag_steps`]).
    lag_s: f64,
    lag_steps: Vec<(f64, f64, bool)>,
}

impl Parts {
    fn new(ctx: &Context, effects: &[Effect], nl: &Nonlinear, unit: &[[f64; 2]]) -> Parts {
        let mut fixed = Vec::new();
        let mut scaled = Vec::new();
        let p = columns_at(ctx, effects, nl, unit, |_| 0.0, &mut fixed);
        columns_at(ctx, effects, nl, unit, |_| 1.0, &mut scaled);
        for (s, f) in scaled.iter_mut().zip(&fixed) {
            *s -= f;
        }
        let n = ctx.points.len();
        // Without the sensor's lag, a point whose columns are all zero (out of the medium, for
        // most designs) adds to no sum but its measurement's square: it is left out of `order`.
        let lagged = nl.lag_s > 0.0;
        let counts = |i: usize| {
            lagged || (0..2 * p).any(|q| fixed[q * n + i] != 0.0 || scaled[q * n + i] != 0.0)
        };
        let mut order: Vec<usize> = (0..n)
            .filter(|&i| ctx.points[i].fold < ctx.folds && counts(i))
            .collect();
        order.sort_by_key(|&i| ctx.points[i].fold);
        let mut fold_ranges = Vec::with_capacity(ctx.folds);
        let mut start = 0;
        for f in 0..ctx.folds {
            let end = start
                + order[start..]
                    .iter()
                    .take_while(|&&i| ctx.points[i].fold == f)
                    .count();
            fold_ranges.push(start..end);
            start = end;
        }
        let y_by_fold = (order.iter().map(|&i| ctx.points[i].y_n[0]))
            .chain(order.iter().map(|&i| ctx.points[i].y_n[1]))
            .collect();
        let mut yty = vec![0.0; ctx.folds];
        for pt in ctx.points.iter().filter(|pt| pt.fold < ctx.folds) {
            yty[pt.fold] += pt.y_n[0].powi(2) + pt.y_n[1].powi(2);
        }
        Parts {
            p,
            fixed,
            scaled,
            order,
            fold_ranges,
            y_by_fold,
            yty,
            beta_rad: ctx.points.iter().map(|pt| pt.beta_rad).collect(),
            lag_s: nl.lag_s,
            lag_steps: if lagged {
                lag_steps(ctx, nl.lag_s)
            } else {
                Vec::new()
            },
        }
    }

    /// The columns at `ln_a`, the setting's sensor lag applied.
    fn columns(&self, ctx: &Context, ln_a: f64, cols: &mut Vec<f64>) {
        let n = ctx.points.len();
        if n == 0 {
            cols.clear();
            return;
        }
        let w: Vec<f64> = self.beta_rad.iter().map(|b| (-ln_a * b).exp()).collect();
        // Every value is written below: a buffer of the right length is not cleared first.
        cols.resize(self.fixed.len(), 0.0);
        for ((c, f), s) in cols
            .chunks_exact_mut(n)
            .zip(self.fixed.chunks_exact(n))
            .zip(self.scaled.chunks_exact(n))
        {
            for (((c, f), s), w) in c.iter_mut().zip(f).zip(s).zip(&w) {
                *c = f + s * w;
            }
        }
        if self.lag_s > 0.0 {
            lag_with(&self.lag_steps, self.lag_s, self.p, cols);
        }
    }
}

/// The sensor's first-order lag with time constant `tau` on every column ([`lag_step`]) of
/// `cols` (column by column, as [`columns_at`] lays them out), in place.
fn lag(ctx: &Context, tau: f64, p: usize, cols: &mut [f64]) {
    lag_with(&lag_steps(ctx, tau), tau, p, cols);
}

/// What [`lag`] needs of each step between points: `lag_step`'s `dt`, its exponential (taken
/// once per step), and whether time moved forward.
fn lag_steps(ctx: &Context, tau: f64) -> Vec<(f64, f64, bool)> {
    ctx.points
        .windows(2)
        .map(|w| {
            let dt = w[1].t_s - w[0].t_s;
            (dt, (-dt / tau).exp(), dt > 0.0 && dt.is_finite())
        })
        .collect()
}

/// [`lag`] with its steps given.
fn lag_with(steps: &[(f64, f64, bool)], tau: f64, p: usize, cols: &mut [f64]) {
    let n = steps.len() + 1;
    if n < 2 {
        return;
    }
    for col in cols.chunks_exact_mut(n).take(2 * p) {
        // The previous point's raw input, before it was overwritten by its lagged value.
        let mut x0 = col[0];
        for (i, &(dt, decay, forward)) in steps.iter().enumerate() {
            let (x1, y0) = (col[i + 1], col[i]);
            col[i + 1] = if forward {
                let g = (x1 - x0) / dt;
                x1 - g * tau + (y0 - x0 + g * tau) * decay
            } else {
                y0
            };
            x0 = x1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::{Context, kinematics};
    use crate::ident::Sample;
    use crate::model::{Medium, Plate, TerzaghiModel};

    #[test]
    fn an_uneven_parabola_finds_the_minimum_of_a_quadratic() {
        let x = [0.0, 0.4, 0.5, 1.0, 2.0];
        let y: Vec<f64> = x.iter().map(|v| (v - 0.62f64).powi(2) + 3.0).collect();
        assert!((refine(&x, &y) - 0.62).abs() < 1e-12);
        // At the edge of the points, the edge.
        let y: Vec<f64> = x.iter().map(|v| (v - 5.0f64).powi(2)).collect();
        assert_eq!(refine(&x, &y), 2.0);
    }

    #[test]
    fn the_lag_filter_follows_a_ramp_one_time_constant_behind() {
        let samples: Vec<Sample> = (0..2000)
            .map(|i| Sample {
                t_s: Some(i as f64 * 0.002),
                beta_rad: 0.3 + i as f64 * 0.004,
                drag_n: 0.0,
                lift_n: 0.0,
            })
            .collect();
        let model = TerzaghiModel::conventional(
            Plate::new(0.25, 0.06, 0.15).unwrap(),
            Medium::new(16170.0, 32.0, 19.0).unwrap(),
        );
        let ctx = Context::new(&model, &samples, &[], &kinematics(&samples, 5), 2, 1);
        // One column, the time itself, lagged by 20 ms: y = t - tau once settled.
        let n = ctx.points.len();
        let mut cols: Vec<f64> = ctx
            .points
            .iter()
            .map(|p| p.t_s)
            .collect::<Vec<_>>()
            .repeat(2);
        lag(&ctx, 0.02, 1, &mut cols);
        for (i, p) in ctx.points.iter().enumerate().skip(500) {
            for c in 0..2 {
                let v = cols[c * n + i];
                assert!((v - (p.t_s - 0.02)).abs() < 1e-9, "{v} at {}", p.t_s);
            }
        }
    }

    /// Each fold's normal equations, as the search sums them a chunk of points at a time, are
    /// those of the columns built directly: with and without the sensor's lag, for folds of
    /// whole strokes and for one stroke's samples alternately in two folds.
    #[test]
    fn the_fold_sums_are_the_normal_equations_of_the_built_columns() {
        let samples: Vec<Sample> = (0..2000)
            .map(|i| {
                let t = i as f64 * 0.004;
                Sample {
                    t_s: Some(t),
                    beta_rad: (4.0 * t).rem_euclid(std::f64::consts::TAU),
                    drag_n: 10.0 * (3.0 * t).sin(),
                    lift_n: 4.0 + (5.0 * t).cos(),
                }
            })
            .collect();
        let model = TerzaghiModel::conventional(
            Plate::new(0.25, 0.06, 0.15).unwrap(),
            Medium::new(16170.0, 32.0, 19.0).unwrap(),
        );
        let whole = Context::new(&model, &samples, &[], &kinematics(&samples, 5), 3, 1);
        assert!(whole.strokes >= 3, "{} strokes", whole.strokes);
        let alternate = whole.sub_session(&[1], 2);
        // With a sensor's bias every point counts; without it, those out of the medium do not.
        let designs = [
            &[Effect::Rate, Effect::Surcharge, Effect::SensorBias][..],
            &[Effect::Rate, Effect::Surcharge][..],
        ];
        for (ctx, effects, lag_s) in [&whole, &alternate]
            .into_iter()
            .flat_map(|c| designs.map(|e| (c, e)))
            .flat_map(|(c, e)| [0.0, 0.015].map(|l| (c, e, l)))
        {
            let n = ctx.points.len();
            {
                let nl = Nonlinear {
                    lag_s,
                    ..Nonlinear::default()
                };
                let unit = ctx.unit_forces_with_hip_offset(nl.surface_drop_m);
                let parts = Parts::new(ctx, effects, &nl, &unit);
                let p = parts.p;
                let skipped = effects.len() == 2 && lag_s == 0.0;
                assert_eq!(
                    parts.order.len() < n,
                    skipped,
                    "{} of {n}",
                    parts.order.len()
                );
                let ln_a = 0.7;
                let sums = fold_sums(ctx, &parts, ln_a, &mut Buffers::default());
                let mut cols = Vec::new();
                build(ctx, effects, f64::exp(ln_a), &nl, &unit, &mut cols);
                for (f, got) in sums.iter().enumerate() {
                    let mine = |pt: &super::super::context::Point| f == ctx.folds || pt.fold == f;
                    let mut want = Sums::zero(p);
                    for (i, pt) in ctx.points.iter().enumerate().filter(|(_, pt)| mine(pt)) {
                        for c in 0..2 {
                            let x = |j: usize| cols[(c * p + j) * n + i];
                            for j in 0..p {
                                for k in 0..p {
                                    want.xtx[(j, k)] += x(j) * x(k);
                                }
                                want.xty[j] += x(j) * pt.y_n[c];
                            }
                            want.yty += pt.y_n[c].powi(2);
                        }
                    }
                    let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1.0);
                    assert!(want.yty > 0.0 && close(got.yty, want.yty), "fold {f}");
                    for j in 0..p {
                        assert!(close(got.xty[j], want.xty[j]), "fold {f} xty {j}");
                        for k in 0..p {
                            let (g, w) = (got.xtx[(j, k)], want.xtx[(j, k)]);
                            assert!(
                                close(g, w),
                                "fold {f} lag {lag_s}: ({j}, {k}) {g} against {w}"
                            );
                        }
                    }
                }
            }
        }
    }

    /// The search's columns, split into a part that does not see `a` and one scaled by
    /// `a^(-beta)`, are the columns built directly at every `a`, every effect in the design and
    /// the sensor's lag applied (whose exponential is taken once per point: it is `lag_step`'s).
    #[test]
    fn the_split_columns_are_the_columns_built_at_each_a() {
        let samples: Vec<Sample> = (0..600)
            .map(|i| {
                let t = i as f64 * 0.004;
                Sample {
                    t_s: Some(t),
                    beta_rad: 1.2 * (2.0 * t).sin() + 1.6,
                    drag_n: 0.0,
                    lift_n: 0.0,
                }
            })
            .collect();
        let model = TerzaghiModel::conventional(
            Plate::new(0.25, 0.06, 0.15).unwrap(),
            Medium::new(16170.0, 32.0, 19.0).unwrap(),
        );
        let ctx = Context::new(&model, &samples, &[], &kinematics(&samples, 5), 3, 1);
        let effects = [
            Effect::Rate,
            Effect::Inertia,
            Effect::Surcharge,
            Effect::Extraction,
            Effect::Compaction,
            Effect::Cohesion,
            Effect::SensorBias,
        ];
        let nl = Nonlinear {
            surface_drop_m: 0.004,
            lag_s: 0.015,
            speed_exponent: 1.5,
            change_at_session_frac: 0.4,
        };
        let unit = ctx.unit_forces_with_hip_offset(nl.surface_drop_m);
        let parts = Parts::new(&ctx, &effects, &nl, &unit);
        let (mut direct, mut split) = (Vec::new(), Vec::new());
        for ln_a in [-2.0, 0.0, 0.7, 3.1] {
            build(&ctx, &effects, f64::exp(ln_a), &nl, &unit, &mut direct);
            parts.columns(&ctx, ln_a, &mut split);
            assert_eq!(direct.len(), split.len());
            let scale = direct.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            assert!(scale > 0.0);
            for (j, (d, s)) in direct.iter().zip(&split).enumerate() {
                assert!(
                    (d - s).abs() <= 1e-12 * scale,
                    "column {j} at ln a {ln_a}: {d} against {s}"
                );
            }
        }
        // The lag as lag_step gives it, on a ramp of uneven steps.
        let n = ctx.points.len();
        let mut cols: Vec<f64> = (ctx.points.iter().map(|p| p.t_s.sin()))
            .chain(ctx.points.iter().map(|p| p.t_s))
            .collect();
        let raw = cols.clone();
        lag(&ctx, 0.01, 1, &mut cols);
        for c in 0..2 {
            let mut y = raw[c * n];
            for i in 1..n {
                let dt = ctx.points[i].t_s - ctx.points[i - 1].t_s;
                let (x0, x1) = (raw[c * n + i - 1], raw[c * n + i]);
                y = crate::model::corrections::lag_step(x0, x1, y, dt, 0.01);
                assert_eq!(cols[c * n + i], y, "column {c}, point {i}");
            }
        }
    }
}
