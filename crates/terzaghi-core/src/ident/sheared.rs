//! The bearing of sheared sand ([`ShearedBearing`]) fitted to a wheel's slip sweep: the runs'
//! measured sinkage and drawbar pull under their loads, the body and the medium's RFT stress
//! given. At most two coefficients come from the sweep, `tan delta_w` and `m`; everything else
//! is the medium's own.
//!
//! The sheared bearing scales the vertical force of the sand at rest by a share that depends on
//! that force and the horizontal one alone, so each run's forces at rest are tabulated once,
//! depth by depth ([`SweepTable`]), and every trial of the fit settles each run in its table:
//! at the first depth whose bearing reaches the run's load, the drawbar interpolated there.
//! The fit minimises `(1 - R^2)` of the sinkage plus that of the drawbar, over a grid of the
//! two coefficients within their physical ranges and then a finer one about its best;
//! standard deviations by jackknife over the runs.

use crate::ident::metrics::component_fit;
use crate::model::{Body, Drive, ShearedBearing, SteadyError, Stress, state_at_sinkage};

/// One run of a slip sweep: its load and drive, and what was measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepRun {
    /// The load the sand bears (N).
    pub load_n: f64,
    /// How the body is driven.
    pub drive: Drive,
    /// The measured sinkage (m).
    pub sinkage_m: f64,
    /// The measured drawbar pull (N, + forward).
    pub drawbar_n: f64,
}

/// Each run's forces of the sand at rest, depth by depth: the vertical force, the drawbar and
/// the horizontal force's magnitude.
#[derive(Debug, Clone)]
pub struct SweepTable {
    depths_m: Vec<f64>,
    /// Per run, per depth: `[vertical, drawbar, |horizontal|]` (N).
    forces: Vec<Vec<[f64; 3]>>,
    runs: Vec<SweepRun>,
}

/// Depths a run's forces are tabulated at, over the body's height.
const TABLE_DEPTHS: usize = 400;

impl SweepTable {
    /// The table of `runs` for `body` in `stress` (its own sheared bearing left out); a run
    /// whose drive is no drive is an error naming it.
    pub fn new(
        body: &Body,
        stress: &Stress,
        runs: &[SweepRun],
    ) -> Result<SweepTable, ShearedFitError> {
        let at_rest = Stress {
            sheared: None,
            ..*stress
        };
        let height = body.height_m();
        let depths_m: Vec<f64> = (1..=TABLE_DEPTHS)
            .map(|k| (height * k as f64 / TABLE_DEPTHS as f64).min(height))
            .collect();
        let mut forces = Vec::with_capacity(runs.len());
        for (i, run) in runs.iter().enumerate() {
            let mut row = Vec::with_capacity(TABLE_DEPTHS);
            for &d in &depths_m {
                let s = state_at_sinkage(body, &at_rest, d, &run.drive)
                    .map_err(|error| ShearedFitError::Run { run: i + 1, error })?;
                row.push([s.load_n, s.drawbar_n, s.drawbar_n.hypot(s.side_n)]);
            }
            forces.push(row);
        }
        Ok(SweepTable {
            depths_m,
            forces,
            runs: runs.to_vec(),
        })
    }

    /// Run `i` settled under `bearing` (none: the sand at rest): its sinkage and drawbar, and
    /// whether the bearing took anything from it there; `None` where no depth of the body
    /// bears it.
    pub fn settle(&self, i: usize, bearing: Option<&ShearedBearing>) -> Option<(f64, f64, bool)> {
        let load = self.runs[i].load_n;
        let borne = |f: &[f64; 3]| match bearing {
            Some(b) => f[0] * b.share(f[2], f[0]),
            None => f[0],
        };
        let row = &self.forces[i];
        let (mut last_d, mut last_v, mut last_h) = (0.0, 0.0, 0.0);
        for (k, f) in row.iter().enumerate() {
            let v = borne(f);
            if v >= load {
                let t = if v > last_v {
                    (load - last_v) / (v - last_v)
                } else {
                    1.0
                };
                let d = last_d + t * (self.depths_m[k] - last_d);
                let h = last_h + t * (f[1] - last_h);
                let shared = bearing.is_some_and(|b| b.share(f[2], f[0]) < 1.0);
                return Some((d, h, shared));
            }
            (last_d, last_v, last_h) = (self.depths_m[k], v, f[1]);
        }
        None
    }

    /// Run `i` settled with the sand's every stress scaled by `scale` (a medium softer or
    /// harder than its tests said), under `bearing` (none: the sand at rest): its sinkage and
    /// drawbar; `None` where no depth of the body bears it.
    pub fn settle_scaled(
        &self,
        i: usize,
        scale: f64,
        bearing: Option<&ShearedBearing>,
    ) -> Option<(f64, f64)> {
        let load = self.runs[i].load_n;
        let (mut last_d, mut last_v, mut last_h) = (0.0, 0.0, 0.0);
        for (k, f) in self.forces[i].iter().enumerate() {
            // The share depends on the resultant's lean alone, which a scale leaves as it is.
            let share = bearing.map_or(1.0, |b| b.share(f[2], f[0]));
            let (v, h) = (scale * f[0] * share, scale * f[1]);
            if v >= load {
                let t = if v > last_v {
                    (load - last_v) / (v - last_v)
                } else {
                    1.0
                };
                return Some((
                    last_d + t * (self.depths_m[k] - last_d),
                    last_h + t * (h - last_h),
                ));
            }
            (last_d, last_v, last_h) = (self.depths_m[k], v, h);
        }
        None
    }

    /// Run `i`'s forces of the sand at rest at `depth_m` (interpolated in the table; 0 above
    /// the surface, the deepest row's below the body's height): `[vertical, drawbar,
    /// |horizontal|]` (N).
    pub fn at_depth(&self, i: usize, depth_m: f64) -> [f64; 3] {
        let row = &self.forces[i];
        let k = self.depths_m.partition_point(|&d| d < depth_m);
        if k >= row.len() {
            return row[row.len() - 1];
        }
        let (d0, f0) = if k == 0 {
            (0.0, [0.0; 3])
        } else {
            (self.depths_m[k - 1], row[k - 1])
        };
        let t = if self.depths_m[k] > d0 {
            ((depth_m - d0) / (self.depths_m[k] - d0)).clamp(0.0, 1.0)
        } else {
            1.0
        };
        std::array::from_fn(|c| f0[c] + t * (row[k][c] - f0[c]))
    }

    /// The runs tabulated.
    pub fn runs(&self) -> &[SweepRun] {
        &self.runs
    }

    /// The body's height the table reaches (m).
    pub fn deepest_m(&self) -> f64 {
        self.depths_m[self.depths_m.len() - 1]
    }

    /// `(1 - R^2)` of the sinkage plus that of the drawbar over the runs `which`, settled
    /// under `bearing`; infinite where one of them is not borne.
    pub fn misfit(&self, bearing: Option<&ShearedBearing>, which: &[usize]) -> f64 {
        let (mut ps, mut ms, mut pd, mut md) = (vec![], vec![], vec![], vec![]);
        for &i in which {
            let Some((s, d, _)) = self.settle(i, bearing) else {
                return f64::INFINITY;
            };
            ps.push(s);
            pd.push(d);
            ms.push(self.runs[i].sinkage_m);
            md.push(self.runs[i].drawbar_n);
        }
        let a = component_fit(&ps, &ms).r2;
        let b = component_fit(&pd, &md).r2;
        let m = (1.0 - a) + (1.0 - b);
        if m.is_finite() { m } else { f64::INFINITY }
    }
}

/// The sheared bearing a sweep gives.
#[derive(Debug, Clone, PartialEq)]
pub struct ShearedFit {
    /// The values fitted.
    pub bearing: ShearedBearing,
    /// Their standard deviations (jackknife over the runs): `interface_tan`, `exponent`.
    pub std_dev: [f64; 2],
    /// The misfit there ([`SweepTable::misfit`]), and with the sand at rest.
    pub misfit: f64,
    /// See [`Self::misfit`].
    pub misfit_at_rest: f64,
    /// Runs from whose bearing the fitted law takes anything at their sinkage.
    pub runs_sheared: usize,
    /// A value the best fit sits on the bound of, with that bound.
    pub on_bound: Option<(&'static str, f64)>,
    /// The fit with each run left out in turn (run `i` at index `i`): what predicts run `i`
    /// held out.
    pub leave_one_out: Vec<ShearedBearing>,
}

/// Why a sweep gives no sheared bearing.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ShearedFitError {
    /// Too few runs, or one slip.
    #[error("{0}")]
    TooLittle(String),
    /// No trial value bears every run.
    #[error("no value of tan delta_w and m within their ranges bears every run of the sweep")]
    NotBorne,
    /// The best fit takes nothing from any run: the sweep does not load the sand past the
    /// interface's friction, and cannot tell the two values.
    #[error(
        "the sweep does not tell the sheared bearing: at the best fit no run's resultant leans past tan delta_w (its runs' drawbar is too small beside their load: a sweep needs skidding runs, a locked wheel among them)"
    )]
    NotIdentified,
    /// The tabulation failed on a run.
    #[error("run {run}: {error}")]
    Run {
        /// The run (from 1).
        run: usize,
        /// What failed.
        error: SteadyError,
    },
}

/// Runs a sweep needs, at the least.
pub const MIN_RUNS: usize = 5;

/// A run's slip as wheel labs define it, `(omega r - v) / max(v, omega r)` for a wheel of
/// reach `r` (0 for a body at rest).
pub fn slip(drive: &Drive, reach_m: f64) -> f64 {
    let (v, w) = (drive.speed_m_s, drive.omega_rad_s * reach_m);
    let most = v.abs().max(w.abs());
    if most > 0.0 { (w - v) / most } else { 0.0 }
}

/// The best value on a grid of `n_t` values of `interface_tan` (geometric) by `n_m` of
/// `exponent` (geometric) within the given bounds, starting from `best`.
fn grid(
    table: &SweepTable,
    which: &[usize],
    t: (f64, f64),
    m: (f64, f64),
    (n_t, n_m): (usize, usize),
    mut best: (f64, ShearedBearing),
) -> (f64, ShearedBearing) {
    let at = |lo: f64, hi: f64, k: usize, n: usize| lo * (hi / lo).powf(k as f64 / (n - 1) as f64);
    for i in 0..n_t {
        for j in 0..n_m {
            let b = ShearedBearing {
                interface_tan: at(t.0, t.1, i, n_t),
                exponent: at(m.0, m.1, j, n_m),
            };
            let f = table.misfit(Some(&b), which);
            if f < best.0 {
                best = (f, b);
            }
        }
    }
    best
}

/// The best fit over the runs `which`: a coarse grid over the physical ranges, then finer grids
/// about the best.
fn best_over(
    table: &SweepTable,
    which: &[usize],
    start: Option<ShearedBearing>,
) -> (f64, ShearedBearing) {
    let (tr, mr) = (
        ShearedBearing::INTERFACE_TAN_RANGE,
        ShearedBearing::EXPONENT_RANGE,
    );
    let mut best = match start {
        Some(b) => (table.misfit(Some(&b), which), b),
        None => grid(
            table,
            which,
            tr,
            mr,
            (48, 32),
            (
                f64::INFINITY,
                ShearedBearing {
                    interface_tan: tr.0,
                    exponent: mr.0,
                },
            ),
        ),
    };
    // Finer grids about the best, each a fifth as wide.
    let mut span = if start.is_some() { 1.15f64 } else { 1.3f64 };
    for _ in 0..6 {
        let b = best.1;
        let t = (
            (b.interface_tan / span).max(tr.0),
            (b.interface_tan * span).min(tr.1),
        );
        let m = ((b.exponent / span).max(mr.0), (b.exponent * span).min(mr.1));
        best = grid(table, which, t, m, (11, 11), best);
        span = span.powf(0.4);
    }
    best
}

/// The sheared bearing `runs` give for `body` in `stress` (without its own sheared bearing).
pub fn fit_sheared(
    body: &Body,
    stress: &Stress,
    runs: &[SweepRun],
) -> Result<ShearedFit, ShearedFitError> {
    if runs.len() < MIN_RUNS {
        return Err(ShearedFitError::TooLittle(format!(
            "a slip sweep needs {MIN_RUNS} runs or more, at two slips or more; it has {}",
            runs.len()
        )));
    }
    let reach = body.reach_m();
    let first = slip(&runs[0].drive, reach);
    if runs
        .iter()
        .all(|r| (slip(&r.drive, reach) - first).abs() < 1e-3)
    {
        return Err(ShearedFitError::TooLittle(format!(
            "a slip sweep needs runs at two slips or more; every run's is {first:.3}"
        )));
    }
    let table = SweepTable::new(body, stress, runs)?;
    let all: Vec<usize> = (0..runs.len()).collect();
    let (misfit, bearing) = best_over(&table, &all, None);
    if !misfit.is_finite() {
        return Err(ShearedFitError::NotBorne);
    }
    let runs_sheared = all
        .iter()
        .filter(|&&i| table.settle(i, Some(&bearing)).is_some_and(|s| s.2))
        .count();
    if runs_sheared == 0 {
        return Err(ShearedFitError::NotIdentified);
    }
    // Jackknife: each run left out in turn, the fit started from the whole sweep's.
    let n = runs.len() as f64;
    let mut each = Vec::with_capacity(runs.len());
    for out in 0..runs.len() {
        let rest: Vec<usize> = all.iter().copied().filter(|&i| i != out).collect();
        each.push(best_over(&table, &rest, Some(bearing)).1);
    }
    let sd = |get: fn(&ShearedBearing) -> f64| {
        let mean = each.iter().map(get).sum::<f64>() / n;
        ((n - 1.0) / n * each.iter().map(|b| (get(b) - mean).powi(2)).sum::<f64>()).sqrt()
    };
    let (tr, mr) = (
        ShearedBearing::INTERFACE_TAN_RANGE,
        ShearedBearing::EXPONENT_RANGE,
    );
    let near = |v: f64, b: f64| (v - b).abs() <= 1e-9 * b.abs().max(1.0);
    let on_bound = [
        ("interface_tan", bearing.interface_tan, tr),
        ("exponent", bearing.exponent, mr),
    ]
    .into_iter()
    .find_map(|(name, v, (lo, hi))| {
        if near(v, lo) {
            Some((name, lo))
        } else if near(v, hi) {
            Some((name, hi))
        } else {
            None
        }
    });
    Ok(ShearedFit {
        bearing,
        std_dev: [sd(|b| b.interface_tan), sd(|b| b.exponent)],
        misfit,
        misfit_at_rest: table.misfit(None, &all),
        runs_sheared,
        on_bound,
        leave_one_out: each,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{RftCoefficients, RftDepthLaw, RftFit, steady_sinkage};

    fn medium() -> (RftCoefficients, RftDepthLaw) {
        (
            RftCoefficients::Fit(RftFit::POPPY_LP),
            RftDepthLaw::new(4.546, 1.219).unwrap(),
        )
    }

    /// The plate runs' law on `poppy_lp`'s shape, at rest.
    fn at_rest<'a>(c: &'a RftCoefficients, law: &'a RftDepthLaw) -> Stress<'a> {
        Stress {
            coefficients: c,
            depth_law: Some(law),
            speed_law: None,
            sheared: None,
        }
    }

    /// A sweep the model itself settles under `truth`, at rim speeds 0-100 mm/s.
    fn generated(body: &Body, stress: &Stress, truth: &ShearedBearing) -> Vec<SweepRun> {
        let with = Stress {
            sheared: Some(truth),
            ..*stress
        };
        [0.0, 3.0, 5.0, 8.0, 10.0, 20.0, 40.0]
            .iter()
            .map(|rim_mm_s| {
                let drive = Drive {
                    speed_m_s: 0.01,
                    omega_rad_s: rim_mm_s * 1e-3 / 0.058,
                    slip_angle_rad: 0.0,
                };
                let s = steady_sinkage(body, &with, 20.0, &drive).unwrap();
                SweepRun {
                    load_n: 20.0,
                    drive,
                    sinkage_m: s.sinkage_m,
                    drawbar_n: s.drawbar_n,
                }
            })
            .collect()
    }

    #[test]
    fn a_sweep_the_model_settled_gives_back_its_bearing() {
        let body = Body::wheel(0.058, 0.05, None, 360).unwrap();
        let (c, law) = medium();
        let stress = at_rest(&c, &law);
        let truth = ShearedBearing::new(0.35, 2.0).unwrap();
        let runs = generated(&body, &stress, &truth);
        let fit = fit_sheared(&body, &stress, &runs).unwrap();
        assert!(
            (fit.bearing.interface_tan / 0.35 - 1.0).abs() < 0.03
                && (fit.bearing.exponent / 2.0 - 1.0).abs() < 0.1,
            "{fit:?}"
        );
        assert!(fit.misfit < 1e-3 && fit.misfit_at_rest > 0.1, "{fit:?}");
        assert!(fit.runs_sheared >= 2 && fit.on_bound.is_none(), "{fit:?}");
        // The table settles each run where steady_sinkage does, to its depth step.
        let table = SweepTable::new(&body, &stress, &runs).unwrap();
        for (i, r) in runs.iter().enumerate() {
            let (s, d, _) = table.settle(i, Some(&truth)).unwrap();
            assert!(
                (s - r.sinkage_m).abs() < 0.5e-3,
                "{s} against {}",
                r.sinkage_m
            );
            assert!(
                (d - r.drawbar_n).abs() < 0.05 * r.drawbar_n.abs() + 0.1,
                "{d} against {}",
                r.drawbar_n
            );
        }
    }

    #[test]
    fn too_little_a_sweep_is_refused() {
        let body = Body::wheel(0.058, 0.05, None, 360).unwrap();
        let (c, law) = medium();
        let stress = at_rest(&c, &law);
        let runs = generated(&body, &stress, &ShearedBearing::new(0.35, 2.0).unwrap());
        let e = fit_sheared(&body, &stress, &runs[..4]).unwrap_err();
        assert!(e.to_string().contains("5 runs or more"), "{e}");
        let one_slip = vec![runs[0]; 6];
        let e = fit_sheared(&body, &stress, &one_slip).unwrap_err();
        assert!(e.to_string().contains("two slips"), "{e}");
        // Driving runs alone lean no resultant past the interface: nothing to tell.
        let driving: Vec<SweepRun> = runs
            .iter()
            .copied()
            .filter(|r| slip(&r.drive, 0.058) > 0.0)
            .collect();
        let more: Vec<SweepRun> = driving
            .iter()
            .chain(&driving)
            .chain(&driving)
            .copied()
            .collect();
        let e = fit_sheared(&body, &stress, &more).unwrap_err();
        assert_eq!(e, ShearedFitError::NotIdentified);
    }
}
