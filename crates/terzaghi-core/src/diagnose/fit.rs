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
                let row = &cols[i * 2 * p..(i + 1) * 2 * p];
                let yd: f64 = row[..p].iter().zip(&c.coef).map(|(x, c)| x * c).sum();
                let yl: f64 = row[p..].iter().zip(&c.coef).map(|(x, c)| x * c).sum();
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
    let mut cols = Vec::new();
    let mut out = Vec::new();
    for (setting, ks) in groups {
        let unit = ctx.unit_forces_with_hip_offset(setting.surface_drop_m);
        let parts = Parts::new(ctx, effects, &setting, &unit);
        // sse[k][grid index]
        let mut sse = vec![vec![f64::INFINITY; grid.len()]; k_all + 1];
        for (gi, &ln_a) in grid.iter().enumerate() {
            let sums = fold_sums(ctx, &parts, ln_a, &setting, &mut cols);
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
                let sums = fold_sums(ctx, &parts, x, &setting, &mut cols);
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
            let sums = fold_sums(ctx, &parts, ln_a, &setting, &mut cols);
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

/// Per-fold sums (index `folds`: the total) of the design at `ln_a` (its columns from
/// `parts`).
fn fold_sums(
    ctx: &Context,
    parts: &Parts,
    ln_a: f64,
    nl: &Nonlinear,
    cols: &mut Vec<f64>,
) -> Vec<Sums> {
    parts.columns(ctx, ln_a, nl, cols);
    let p = parts.p;
    let mut sums = vec![Sums::zero(p); ctx.folds + 1];
    // Accumulate the upper triangles in flat buffers (nalgebra indexing per element is slow).
    let mut xtx = vec![vec![0.0; p * p]; ctx.folds];
    let mut xty = vec![vec![0.0; p]; ctx.folds];
    let mut yty = vec![0.0; ctx.folds];
    for (i, pt) in ctx.points.iter().enumerate() {
        let f = pt.fold;
        for c in 0..2 {
            let row = &cols[(2 * i + c) * p..(2 * i + c + 1) * p];
            let y = pt.y_n[c];
            let (m, v) = (&mut xtx[f], &mut xty[f]);
            for r in 0..p {
                let xr = row[r];
                if xr == 0.0 {
                    continue;
                }
                for (acc, x) in m[r * p + r..(r + 1) * p].iter_mut().zip(&row[r..]) {
                    *acc += xr * x;
                }
                v[r] += xr * y;
            }
            yty[f] += y * y;
        }
    }
    for f in 0..ctx.folds {
        for r in 0..p {
            for s in r..p {
                sums[f].xtx[(r, s)] = xtx[f][r * p + s];
                sums[f].xtx[(s, r)] = xtx[f][r * p + s];
            }
            sums[f].xty[r] = xty[f][r];
        }
        sums[f].yty = yty[f];
        let own = sums[f].clone();
        let total = &mut sums[ctx.folds];
        total.xtx += &own.xtx;
        total.xty += &own.xty;
        total.yty += own.yty;
    }
    sums
}

/// The design's columns at every point: `cols[(2 i + c) p + j]` for point `i`, component `c`
/// (drag, lift), column `j`.
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
            cols[2 * i * p + j] = v[0];
            cols[(2 * i + 1) * p + j] = v[1];
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
        Parts { p, fixed, scaled }
    }

    /// The columns at `ln_a`, the sensor's lag of `nl` applied.
    fn columns(&self, ctx: &Context, ln_a: f64, nl: &Nonlinear, cols: &mut Vec<f64>) {
        let q = 2 * self.p;
        cols.clear();
        cols.resize(self.fixed.len(), 0.0);
        for (i, pt) in ctx.points.iter().enumerate() {
            let w = (-ln_a * pt.beta_rad).exp();
            let r = i * q..(i + 1) * q;
            for ((c, f), s) in cols[r.clone()]
                .iter_mut()
                .zip(&self.fixed[r.clone()])
                .zip(&self.scaled[r])
            {
                *c = f + s * w;
            }
        }
        if nl.lag_s > 0.0 {
            lag(ctx, nl.lag_s, self.p, cols);
        }
    }
}

/// The sensor's first-order lag with time constant `tau` on every column ([`lag_step`]). In
/// place: the previous point's raw input is kept aside.
fn lag(ctx: &Context, tau: f64, p: usize, cols: &mut [f64]) {
    let n = ctx.points.len();
    if n == 0 {
        return;
    }
    let mut raw_prev: Vec<f64> = cols[..2 * p].to_vec();
    for i in 1..n {
        let dt = ctx.points[i].t_s - ctx.points[i - 1].t_s;
        // lag_step's, its exponential once per point.
        let decay = (-dt / tau).exp();
        let forward = dt > 0.0 && dt.is_finite();
        for q in 0..2 * p {
            let (x0, x1, y0) = (raw_prev[q], cols[2 * i * p + q], cols[2 * (i - 1) * p + q]);
            raw_prev[q] = x1;
            cols[2 * i * p + q] = if forward {
                let g = (x1 - x0) / dt;
                x1 - g * tau + (y0 - x0 + g * tau) * decay
            } else {
                y0
            };
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
        let mut cols: Vec<f64> = ctx.points.iter().flat_map(|p| [p.t_s, p.t_s]).collect();
        lag(&ctx, 0.02, 1, &mut cols);
        for (i, p) in ctx.points.iter().enumerate().skip(500) {
            assert!(
                (cols[2 * i] - (p.t_s - 0.02)).abs() < 1e-9,
                "{} at {}",
                cols[2 * i],
                p.t_s
            );
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
            parts.columns(&ctx, ln_a, &nl, &mut split);
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
        let mut cols: Vec<f64> = ctx
            .points
            .iter()
            .flat_map(|p| [p.t_s.sin(), p.t_s])
            .collect();
        let raw = cols.clone();
        lag(&ctx, 0.01, 1, &mut cols);
        let mut y = raw[0];
        for i in 1..ctx.points.len() {
            let dt = ctx.points[i].t_s - ctx.points[i - 1].t_s;
            y = crate::model::corrections::lag_step(raw[2 * (i - 1)], raw[2 * i], y, dt, 0.01);
            assert_eq!(cols[2 * i], y, "point {i}");
        }
    }
}
