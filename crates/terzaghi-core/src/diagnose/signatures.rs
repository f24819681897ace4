//! Direct signatures of three effects, read off the session itself rather than from how much a
//! candidate term improves the fit: each is evidence that does not depend on the model's own
//! misfit being small.
//!
//! - A sensor offset shows where the leg is far out of the medium: the force there should be
//!   zero.
//! - A delay of the F/T signal shows in the time shift that best aligns the measured force with
//!   the predicted one.
//! - A surface at another level than configured shows in the angle at which force first
//!   appears in each stroke.
//!
//! Every test is made stroke by stroke, so that a signature must hold in every stroke, not only
//! on average: a model that misfits one stroke cannot fake it.

use super::context::{Context, lowest_of_twofold_span};
use std::f64::consts::FRAC_PI_2;

/// The three signatures of a session.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Signatures {
    /// A force where the leg is out of the medium: a sensor offset.
    pub sensor_offset: Offset,
    /// A time shift between measured and predicted force: a sensor delay.
    pub delay: Delay,
    /// The angle force appears at: a surface at another level.
    pub onset: Onset,
}

/// The mean force where the leg is far out of the medium: the middle half of its swing through
/// the air.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Offset {
    /// Mean drag out of the medium (N).
    pub drag_n: f64,
    /// Mean lift out of the medium (N).
    pub lift_n: f64,
    /// Out-of-medium samples it is measured on.
    pub samples: usize,
    /// The larger of the two components' mean over its standard error (noise / sqrt(samples)).
    pub z: f64,
    /// The same, from the stroke-to-stroke scatter of the per-stroke means (a t statistic: it
    /// does not assume the noise is white).
    pub t_strokes: f64,
    /// Whether the offset is beyond chance.
    pub significant: bool,
}

/// The time shift of the predicted force that best matches the measured one.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Delay {
    /// Positive: the measurement lags the prediction.
    pub lag_s: f64,
    /// Share of the squared residual that the shift removes, %.
    pub residual_reduction_pct: f64,
    /// Paired t over strokes of the per-stroke reduction.
    pub t_strokes: f64,
    /// The delay seen in how the onset angle moves with speed (a delay `L` moves it by
    /// `omega L`; a misfit of the model in angle does not grow with speed), s, and its t.
    /// Zero where the strokes' speeds vary less than twofold.
    pub onset_slope_s: f64,
    /// The t statistic of `onset_slope_s`.
    pub onset_slope_t: f64,
    /// Where the strokes' speeds span a factor two: each stroke's best-aligning shift split
    /// into a part in time and a part in angle (not used to decide; see [`TimingSplit`]).
    pub timing_split: Option<TimingSplit>,
    /// Whether the delay is beyond chance.
    pub significant: bool,
}

/// Each stroke's best-aligning shift `lag_k` (s) fitted over the strokes as
/// `time_shift + angle_shift / omega_k`, `omega_k` the stroke's median speed in the medium: a
/// sensor delay is the same time at every speed, a misfit of the model in angle (an encoder
/// offset, a surface at another level) a shift that shrinks as the leg goes faster. The medium's
/// own response can lead the quasi-static model in time as well (on the DEM it does, by more
/// the faster the leg), so `time_shift_s` is a sensor delay only net of that lead.
#[derive(Debug, Clone, serde::Serialize)]
pub struct TimingSplit {
    /// Positive: the measurement late (s).
    pub time_shift_s: f64,
    /// The t statistic of `time_shift_s`.
    pub time_shift_t: f64,
    /// Positive: the measured force appears later in angle than predicted (deg).
    pub angle_shift_deg: f64,
    /// `(median speed rad/s, best shift s)` of each stroke whose best shift lies inside the
    /// range tried.
    pub strokes: Vec<(f64, f64)>,
}

/// The angle at which force first appears in a stroke, measured against predicted.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Onset {
    /// Median over strokes of measured minus predicted onset (deg; negative: force appears
    /// earlier than the model expects, as over a surface higher than configured).
    pub shift_deg: f64,
    /// The surface level that shift corresponds to (m below the configured one; negative:
    /// higher).
    pub surface_drop_m: f64,
    /// Strokes where both onsets were found.
    pub strokes: usize,
    /// How many of them share the median's sign.
    pub strokes_agreeing: usize,
    /// Whether the shift is beyond chance.
    pub significant: bool,
}

/// Reads the three signatures. `fitted_n` is the baseline fitted on every stroke; `noise_n` the
/// sensor noise per component.
pub fn read(ctx: &Context, fitted_n: &[[f64; 2]], noise_n: [f64; 2]) -> Signatures {
    Signatures {
        sensor_offset: offset(ctx, noise_n),
        delay: delay(ctx, fitted_n, noise_n),
        onset: onset(ctx, fitted_n, noise_n),
    }
}

fn offset(ctx: &Context, noise_n: [f64; 2]) -> Offset {
    let mut per_stroke: Vec<([f64; 2], usize)> = vec![([0.0; 2], 0); ctx.strokes.max(1)];
    let (mut sum, mut n) = ([0.0; 2], 0usize);
    for p in ctx.far_from_medium() {
        let s = &mut per_stroke[p.stroke.min(ctx.strokes.max(1) - 1)];
        for (c, y) in p.y_n.iter().enumerate() {
            s.0[c] += y;
            sum[c] += y;
        }
        s.1 += 1;
        n += 1;
    }
    let mean = [sum[0] / n.max(1) as f64, sum[1] / n.max(1) as f64];
    let z = (0..2)
        .map(|c| mean[c].abs() / (noise_n[c].max(1e-12) / (n.max(1) as f64).sqrt()))
        .fold(0.0, f64::max);
    // Per-stroke means; the component with the larger z is tested for consistency.
    let c = if mean[0].abs() / noise_n[0].max(1e-12) >= mean[1].abs() / noise_n[1].max(1e-12) {
        0
    } else {
        1
    };
    let means: Vec<f64> = per_stroke
        .iter()
        .filter(|s| s.1 >= 5)
        .map(|s| s.0[c] / s.1 as f64)
        .collect();
    let t_strokes = t_statistic(&means);
    // Material: at least a fifth of the noise, so that a well-measured but negligible offset
    // is not reported.
    let material = mean[c].abs() >= 0.2 * noise_n[c];
    Offset {
        drag_n: mean[0],
        lift_n: mean[1],
        samples: n,
        z,
        t_strokes,
        significant: n >= 20 && z > 5.0 && t_strokes.abs() > 4.0 && material,
    }
}

/// The shifts tried (s): positive, the measurement is late.
const LAGS_S: [f64; 19] = [
    -0.12, -0.09, -0.06, -0.04, -0.03, -0.02, -0.015, -0.01, -0.005, 0.0, 0.005, 0.01, 0.015, 0.02,
    0.03, 0.04, 0.06, 0.08, 0.1,
];

/// The shifts tried for samples `dt_s` apart: [`LAGS_S`], and on past its end in steps of half a
/// sample period out to four periods, so that a slow sensor's delay (a few of its periods: 12 Hz
/// and a hold put it beyond 0.1 s) lies inside the range, where it can be found.
fn lags_s(dt_s: f64) -> Vec<f64> {
    let mut v = LAGS_S.to_vec();
    let last = LAGS_S[LAGS_S.len() - 1];
    if dt_s.is_finite() && dt_s > 0.0 {
        let mut l = last + 0.5 * dt_s;
        while l <= 4.0 * dt_s + 1e-12 && v.len() < 64 {
            v.push(l);
            l += 0.5 * dt_s;
        }
    }
    v
}

fn delay(ctx: &Context, fitted_n: &[[f64; 2]], noise_n: [f64; 2]) -> Delay {
    let (onset_slope_s, onset_slope_t) = onset_slope(&onset_shifts(ctx, fitted_n, noise_n));
    let by_onset = onset_slope_s >= 0.002 && onset_slope_t > 4.0;
    let none = Delay {
        lag_s: if by_onset { onset_slope_s } else { 0.0 },
        residual_reduction_pct: 0.0,
        t_strokes: 0.0,
        onset_slope_s,
        onset_slope_t,
        timing_split: None,
        significant: by_onset,
    };
    let pts = &ctx.points;
    if pts.len() < 10 {
        return none;
    }
    let times: Vec<f64> = pts.iter().map(|p| p.t_s).collect();
    // Per-stroke squared residual of the prediction shifted by `lag` (the prediction at t - lag),
    // with one gain refitted so that the shift is not judged against a fit made at zero lag.
    let per_stroke = |lag: f64| -> Vec<f64> {
        let shifted: Vec<[f64; 2]> = times
            .iter()
            .map(|&t| interpolate(&times, fitted_n, t - lag))
            .collect();
        let (mut yp, mut pp) = (0.0, 0.0);
        for (p, q) in pts.iter().zip(&shifted) {
            for (y, x) in p.y_n.iter().zip(q) {
                yp += y * x;
                pp += x * x;
            }
        }
        let k = if pp > 0.0 { yp / pp } else { 1.0 };
        let mut sse = vec![0.0; ctx.strokes.max(1)];
        for (p, q) in pts.iter().zip(&shifted) {
            let s = &mut sse[p.stroke.min(ctx.strokes.max(1) - 1)];
            for (y, x) in p.y_n.iter().zip(q) {
                *s += (y - k * x).powi(2);
            }
        }
        sse
    };
    let dt = median_step(&times);
    let lags = lags_s(dt);
    let all: Vec<Vec<f64>> = lags.iter().map(|&l| per_stroke(l)).collect();
    let totals: Vec<f64> = all.iter().map(|s| s.iter().sum()).collect();
    let zero = lags.iter().position(|l| *l == 0.0).unwrap_or(0);
    let best = (0..lags.len())
        .min_by(|&a, &b| totals[a].total_cmp(&totals[b]))
        .unwrap_or(zero);
    let diffs: Vec<f64> = all[zero]
        .iter()
        .zip(&all[best])
        .map(|(a, b)| a - b)
        .collect();
    let t = t_statistic(&diffs);
    let reduction = if totals[zero] > 0.0 {
        100.0 * (totals[zero] - totals[best]) / totals[zero]
    } else {
        0.0
    };
    let lag = lags[best];
    // An interior minimum (not the edge of the range), the measurement late by more than two
    // sample periods, in every stroke's favour, and removing a real part of the residual.
    let interior = best > 0 && best + 1 < lags.len();
    let by_alignment = interior && lag >= 2.0 * dt && t > 4.0 && reduction > 2.0;
    Delay {
        lag_s: if by_alignment || !by_onset {
            lag
        } else {
            onset_slope_s
        },
        residual_reduction_pct: reduction,
        t_strokes: t,
        onset_slope_s,
        onset_slope_t,
        timing_split: timing_split(ctx, &lags, &all),
        significant: by_alignment || by_onset,
    }
}

/// [`TimingSplit`] from the per-shift, per-stroke squared residuals `sse[l][k]` of
/// `lags`: each stroke's best shift refined by a parabola through its neighbours, then
/// `lag = time + angle / omega` by least squares over the strokes. `None` unless four strokes
/// or more have their best shift inside the range and their speeds span a factor two.
fn timing_split(ctx: &Context, lags: &[f64], sse: &[Vec<f64>]) -> Option<TimingSplit> {
    let mut found: Vec<(f64, f64)> = Vec::new();
    for (k, omega) in ctx.stroke_speeds_rad_s(10).into_iter().enumerate() {
        let Some(omega) = omega else { continue };
        let best = (0..lags.len()).min_by(|&a, &b| sse[a][k].total_cmp(&sse[b][k]))?;
        if best == 0 || best + 1 == lags.len() || omega <= 0.0 {
            continue;
        }
        found.push((
            omega,
            parabola_min(
                &lags[best - 1..=best + 1],
                [sse[best - 1][k], sse[best][k], sse[best + 1][k]],
            ),
        ));
    }
    if found.len() < 4 || lowest_of_twofold_span(found.iter().map(|p| p.0)).is_none() {
        return None;
    }
    // lag = time + angle * x, x = 1 / omega.
    let n = found.len() as f64;
    let xs: Vec<f64> = found.iter().map(|p| 1.0 / p.0).collect();
    let mx = xs.iter().sum::<f64>() / n;
    let my = found.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
    let sxy: f64 = xs
        .iter()
        .zip(&found)
        .map(|(x, p)| (x - mx) * (p.1 - my))
        .sum();
    let angle = sxy / sxx;
    let time = my - angle * mx;
    let resid: f64 = xs
        .iter()
        .zip(&found)
        .map(|(x, p)| (p.1 - time - angle * x).powi(2))
        .sum();
    // Standard error of the intercept.
    let se = (resid / (n - 2.0) * (1.0 / n + mx * mx / sxx)).sqrt();
    let time_shift_t = if se > 0.0 {
        time / se
    } else {
        1e6 * time.signum()
    };
    Some(TimingSplit {
        time_shift_s: time,
        time_shift_t,
        angle_shift_deg: angle.to_degrees(),
        strokes: found,
    })
}

/// The abscissa of the minimum of the parabola through three points (`x` increasing, the
/// middle one the lowest), kept within the outer two.
fn parabola_min(x: &[f64], y: [f64; 3]) -> f64 {
    let (x0, x1, x2) = (x[0], x[1], x[2]);
    let d01 = (y[1] - y[0]) / (x1 - x0);
    let d12 = (y[2] - y[1]) / (x2 - x1);
    let curv = (d12 - d01) / (x2 - x0);
    if curv <= 0.0 {
        return x1;
    }
    // Newton's form y0 + d01 (x - x0) + curv (x - x0) (x - x1) is flat where
    // d01 + curv (2x - x0 - x1) = 0.
    (0.5 * (x0 + x1) - d01 / (2.0 * curv)).clamp(x0, x2)
}

/// Least-squares slope of onset shift (rad) on speed (rad/s) over strokes, and its t: the
/// delay in seconds. Zero unless there are four strokes or more whose speeds span a factor two.
fn onset_slope(points: &[(f64, f64)]) -> (f64, f64) {
    let n = points.len();
    if n < 4 || lowest_of_twofold_span(points.iter().map(|p| p.1)).is_none() {
        return (0.0, 0.0);
    }
    let mx = points.iter().map(|p| p.1).sum::<f64>() / n as f64;
    let my = points.iter().map(|p| p.0).sum::<f64>() / n as f64;
    let sxx: f64 = points.iter().map(|p| (p.1 - mx).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.1 - mx) * (p.0 - my)).sum();
    let slope = sxy / sxx;
    let resid: f64 = points
        .iter()
        .map(|p| (p.0 - my - slope * (p.1 - mx)).powi(2))
        .sum();
    let se = (resid / (n - 2) as f64 / sxx).sqrt();
    let t = if se > 0.0 {
        slope / se
    } else {
        1e6 * slope.signum()
    };
    (slope, t)
}

/// Per stroke where both are found: measured minus predicted onset angle (rad), and the speed
/// at the measured onset (rad/s). The onset is the first angle of the penetration half at which
/// drag exceeds a fifth of the stroke's peak (and six times the noise).
fn onset_shifts(ctx: &Context, fitted_n: &[[f64; 2]], noise_n: [f64; 2]) -> Vec<(f64, f64)> {
    let strokes = ctx.strokes.max(1);
    let mut peak = vec![[0.0f64; 2]; strokes];
    for (p, q) in ctx.points.iter().zip(fitted_n) {
        if p.beta_rad < FRAC_PI_2 {
            let s = &mut peak[p.stroke.min(strokes - 1)];
            s[0] = s[0].max(p.y_n[0].abs());
            s[1] = s[1].max(q[0].abs());
        }
    }
    let mut first: Vec<[Option<(f64, f64)>; 2]> = vec![[None, None]; strokes];
    for (p, q) in ctx.points.iter().zip(fitted_n) {
        if p.beta_rad >= FRAC_PI_2 {
            continue;
        }
        let s = p.stroke.min(strokes - 1);
        let thr = |k: usize| (0.2 * peak[s][k]).max(6.0 * noise_n[0]);
        for (k, v) in [p.y_n[0], q[0]].into_iter().enumerate() {
            if first[s][k].is_none() && v.abs() > thr(k) && peak[s][k] > 0.0 {
                first[s][k] = Some((p.beta_rad, p.speed_rad_s.abs()));
            }
        }
    }
    first
        .iter()
        .filter_map(|f| {
            let (m, w) = f[0]?;
            Some((m - f[1]?.0, w))
        })
        .collect()
}

fn onset(ctx: &Context, fitted_n: &[[f64; 2]], noise_n: [f64; 2]) -> Onset {
    let shifts: Vec<f64> = onset_shifts(ctx, fitted_n, noise_n)
        .into_iter()
        .map(|(d, _)| d)
        .collect();
    let plate = ctx.model.plate();
    let entry = plate.entry_beta_rad().unwrap_or(0.0);
    if shifts.is_empty() {
        return Onset {
            shift_deg: 0.0,
            surface_drop_m: 0.0,
            strokes: 0,
            strokes_agreeing: 0,
            significant: false,
        };
    }
    let mut sorted = shifts.clone();
    sorted.sort_by(f64::total_cmp);
    let med = sorted[sorted.len() / 2];
    let agreeing = shifts
        .iter()
        .filter(|s| s.signum() == med.signum() && **s != 0.0)
        .count();
    // The tip reaches the surface at sin(beta) = h / l: a surface lower by dz moves the entry by
    // dz / (l cos(beta_entry)).
    let drop = med * plate.length_m() * entry.cos();
    let step = ctx
        .points
        .windows(2)
        .map(|w| (w[1].beta_rad - w[0].beta_rad).abs())
        .filter(|d| *d > 0.0 && *d < 0.5)
        .fold(f64::INFINITY, f64::min);
    Onset {
        shift_deg: med.to_degrees(),
        surface_drop_m: drop,
        strokes: shifts.len(),
        strokes_agreeing: agreeing,
        significant: shifts.len() >= 3
            && agreeing == shifts.len()
            && med.abs() > (2.0 * step).max(1f64.to_radians()),
    }
}

/// Linear interpolation of `y` at time `t` over increasing `times` (held at the ends).
pub(super) fn interpolate(times: &[f64], y: &[[f64; 2]], t: f64) -> [f64; 2] {
    let i = times.partition_point(|&x| x < t);
    if i == 0 {
        return y[0];
    }
    if i >= times.len() {
        return y[times.len() - 1];
    }
    let (t0, t1) = (times[i - 1], times[i]);
    let w = if t1 > t0 { (t - t0) / (t1 - t0) } else { 0.0 };
    [
        y[i - 1][0] + w * (y[i][0] - y[i - 1][0]),
        y[i - 1][1] + w * (y[i][1] - y[i - 1][1]),
    ]
}

/// The median positive step between `times` (1 ms for none).
pub(crate) fn median_step(times: &[f64]) -> f64 {
    let mut d: Vec<f64> = times
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 0.0)
        .collect();
    if d.is_empty() {
        return 1e-3;
    }
    let mid = d.len() / 2;
    *d.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// One-sample t statistic of `x` against zero (large when every value agrees; 0 for fewer
/// than two values).
pub fn t_statistic(x: &[f64]) -> f64 {
    let n = x.len();
    if n < 2 {
        return 0.0;
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    let se = (var / n as f64).sqrt();
    if se > 0.0 {
        mean / se
    } else if mean == 0.0 {
        0.0
    } else {
        // Every stroke agrees exactly: as strong as a t can say with these strokes.
        1e6 * mean.signum()
    }
}

/// The one-sided 5 % critical value of Student's t with `df` degrees of freedom (a table,
/// interpolated in 1/df; 0 degrees of freedom: infinite).
pub fn t_critical_5pct(df: usize) -> f64 {
    const TABLE: [(usize, f64); 16] = [
        (1, 6.314),
        (2, 2.920),
        (3, 2.353),
        (4, 2.132),
        (5, 2.015),
        (6, 1.943),
        (7, 1.895),
        (8, 1.860),
        (9, 1.833),
        (10, 1.812),
        (12, 1.782),
        (15, 1.753),
        (20, 1.725),
        (30, 1.697),
        (60, 1.671),
        (120, 1.658),
    ];
    if df == 0 {
        return f64::INFINITY;
    }
    let mut prev = TABLE[0];
    for &(d, t) in &TABLE {
        if df == d {
            return t;
        }
        if df < d {
            let w =
                (1.0 / prev.0 as f64 - 1.0 / df as f64) / (1.0 / prev.0 as f64 - 1.0 / d as f64);
            return prev.1 + w * (t - prev.1);
        }
        prev = (d, t);
    }
    // Beyond 120: toward the normal's 1.645.
    let w = 120.0 / df as f64;
    1.645 + w * (1.658 - 1.645)
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_t_table_is_monotone_and_exact_at_its_entries() {
        assert_eq!(t_critical_5pct(3), 2.353);
        assert_eq!(t_critical_5pct(20), 1.725);
        let v: Vec<f64> = (1..400).map(t_critical_5pct).collect();
        assert!(v.windows(2).all(|w| w[1] <= w[0]), "{v:?}");
        assert!(t_critical_5pct(13) < 1.782 && t_critical_5pct(13) > 1.753);
        assert!((t_critical_5pct(100_000) - 1.645).abs() < 0.001);
    }

    use super::*;

    #[test]
    fn t_is_large_for_agreeing_values_and_small_for_scattered_ones() {
        assert!(t_statistic(&[1.0, 1.1, 0.9, 1.0]) > 10.0);
        assert!(t_statistic(&[1.0, -1.2, 0.9, -0.8]).abs() < 1.0);
        assert_eq!(t_statistic(&[3.0]), 0.0);
    }

    #[test]
    fn the_parabola_finds_a_vertex_between_unequal_steps() {
        // y = (x - 0.004)^2 through -0.01, 0.0, 0.02.
        let f = |x: f64| (x - 0.004f64).powi(2);
        let x = [-0.01, 0.0, 0.02];
        let v = parabola_min(&x, [f(x[0]), f(x[1]), f(x[2])]);
        assert!((v - 0.004).abs() < 1e-12, "{v}");
        // No curvature: the middle point.
        assert_eq!(parabola_min(&x, [1.0, 1.0, 1.0]), 0.0);
    }

    #[test]
    fn interpolation_holds_at_the_ends() {
        let t = [0.0, 1.0, 2.0];
        let y = [[0.0, 0.0], [1.0, 2.0], [3.0, 4.0]];
        assert_eq!(interpolate(&t, &y, 0.5), [0.5, 1.0]);
        assert_eq!(interpolate(&t, &y, -1.0), [0.0, 0.0]);
        assert_eq!(interpolate(&t, &y, 9.0), [3.0, 4.0]);
    }
}
