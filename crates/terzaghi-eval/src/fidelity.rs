//! How well the models describe a DEM campaign, with no I/O: the testbed's own checks (a run
//! against the baseline with one numerical choice changed), and for each quasi-static flat-plate
//! run the improved model (`b_k`, `a`, `delta` fitted), the conventional model (`b_e = b`, the
//! bed's `delta`) and RFT calibrated from the DEM's own intrusions; `b_k, a` fitted on one plate
//! width predicting the others (the paper's claim); and the C-leg against RFT.
//!
//! Fits and scores use the penetration phase (`beta <= 90 deg`, submerged), the regime the
//! paper validates; the whole stroke's R^2 of the improved model stands beside them.

use std::f64::consts::{FRAC_PI_2, PI};
use terzaghi::dem::{DemRun, LegShape};
use terzaghi::ident::metrics::goodness_of_fit;
use terzaghi::ident::{BatchOptions, GoodnessOfFit, IdentError, Sample, fit_batch};
use terzaghi::model::{
    FittingWidth, Plate, RftCoefficients, RftFit, RftModel, TerzaghiModel, rft_leg, wrap_beta_rad,
};

/// RFT elements along the plate.
const RFT_ELEMENTS: usize = 100;

/// The samples of the penetration phase: submerged, `beta <= pi/2`.
pub fn penetration(samples: &[Sample], plate: &Plate) -> Vec<Sample> {
    samples
        .iter()
        .filter(|s| {
            let b = wrap_beta_rad(s.beta_rad);
            b <= FRAC_PI_2 && plate.submerged_length_m(b) > 0.0
        })
        .copied()
        .collect()
}

/// The submerged samples of the whole stroke.
pub fn submerged(samples: &[Sample], plate: &Plate) -> Vec<Sample> {
    samples
        .iter()
        .filter(|s| plate.submerged_length_m(wrap_beta_rad(s.beta_rad)) > 0.0)
        .copied()
        .collect()
}

/// Drag and lift of a Terzaghi model at `beta` (NaN where it cannot be evaluated, which the
/// goodness of fit then counts against it).
fn terzaghi_at(m: &TerzaghiModel, beta: f64) -> (f64, f64) {
    m.evaluate(beta)
        .map_or((f64::NAN, f64::NAN), |f| (f.drag_n, f.lift_n))
}

fn score(pred: impl Fn(f64) -> (f64, f64), samples: &[Sample]) -> GoodnessOfFit {
    let p: Vec<(f64, f64)> = samples.iter().map(|s| pred(s.beta_rad)).collect();
    let m: Vec<(f64, f64)> = samples.iter().map(|s| (s.drag_n, s.lift_n)).collect();
    goodness_of_fit(&p, &m)
}

/// One quasi-static run's fidelity.
#[derive(Debug, Clone, serde::Serialize)]
pub struct RunFidelity {
    pub run: String,
    pub width_m: f64,
    pub hip_height_m: f64,
    /// Penetration samples scored.
    pub samples: usize,
    pub b_k: f64,
    pub a: f64,
    pub delta_deg: f64,
    pub improved: GoodnessOfFit,
    pub conventional: GoodnessOfFit,
    pub rft: GoodnessOfFit,
    /// The fitted improved model over every submerged sample of the stroke (extraction too).
    pub improved_whole_stroke: GoodnessOfFit,
}

/// Fits and scores the three models on a run.
pub fn run_fidelity(run: &DemRun, rft: &RftCoefficients) -> Result<RunFidelity, IdentError> {
    let all = run.samples();
    let pen = penetration(&all, &run.plate);
    let conventional = TerzaghiModel::conventional(run.plate, run.medium);
    let fit = fit_batch(
        &conventional,
        &pen,
        &BatchOptions {
            fit_delta: true,
            ..Default::default()
        },
    )?;
    let improved = fitted_model(run, &fit)?;
    let rft_model =
        RftModel::new(run.plate, rft.clone(), RFT_ELEMENTS).map_err(IdentError::from)?;
    let eval_rft = |b: f64| {
        rft_model
            .evaluate(b)
            .map_or((f64::NAN, f64::NAN), |p| (p.drag_n, p.lift_n))
    };
    Ok(RunFidelity {
        run: run.name.clone(),
        width_m: run.plate.width_m(),
        hip_height_m: run.plate.hip_height_m(),
        samples: pen.len(),
        b_k: fit.b_k,
        a: fit.a,
        delta_deg: fit.delta_deg,
        improved: fit.improved,
        conventional: fit.conventional,
        rft: score(eval_rft, &pen),
        improved_whole_stroke: score(|b| terzaghi_at(&improved, b), &submerged(&all, &run.plate)),
    })
}

fn fitted_model(
    run: &DemRun,
    fit: &terzaghi::ident::BatchFit,
) -> Result<TerzaghiModel, IdentError> {
    let medium = run
        .medium
        .with_delta_deg(fit.delta_deg)
        .map_err(IdentError::from)?;
    let width = FittingWidth::new(fit.b_k, fit.a).map_err(IdentError::from)?;
    Ok(TerzaghiModel::new(run.plate, medium, width))
}

/// `b_k, a, delta` fitted on one run predicting another of another plate width.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Transfer {
    pub train: String,
    pub test: String,
    pub train_width_m: f64,
    pub test_width_m: f64,
    pub hip_height_m: f64,
    /// The test run's own fit, for comparison.
    pub own: GoodnessOfFit,
    pub transferred: GoodnessOfFit,
}

/// Every ordered pair of runs at the same hip height with different widths.
pub fn width_transfer(runs: &[&DemRun]) -> Result<Vec<Transfer>, IdentError> {
    let opts = BatchOptions {
        fit_delta: true,
        ..Default::default()
    };
    let mut fits = Vec::new();
    for r in runs {
        let pen = penetration(&r.samples(), &r.plate);
        let fit = fit_batch(&TerzaghiModel::conventional(r.plate, r.medium), &pen, &opts)?;
        fits.push((pen, fit));
    }
    let mut out = Vec::new();
    for (i, train) in runs.iter().enumerate() {
        for (j, test) in runs.iter().enumerate() {
            if i == j
                || train.plate.hip_height_m() != test.plate.hip_height_m()
                || train.plate.width_m() == test.plate.width_m()
            {
                continue;
            }
            let f = &fits[i].1;
            let medium = test
                .medium
                .with_delta_deg(f.delta_deg)
                .map_err(IdentError::from)?;
            let width = FittingWidth::new(f.b_k, f.a).map_err(IdentError::from)?;
            let m = TerzaghiModel::new(test.plate, medium, width);
            let transferred = score(|b| terzaghi_at(&m, b), &fits[j].0);
            out.push(Transfer {
                train: train.name.clone(),
                test: test.name.clone(),
                train_width_m: train.plate.width_m(),
                test_width_m: test.plate.width_m(),
                hip_height_m: test.plate.hip_height_m(),
                own: fits[j].1.improved,
                transferred,
            });
        }
    }
    Ok(out)
}

/// A run against the baseline over the penetration phase: the change of the mean drag and
/// mean lift (the criterion of the testbed's checks: a DEM stroke's force fluctuates from
/// sample to sample, its mean much less), and the shape: forces binned by attack angle in
/// 5-degree bins, the RMS of the difference of the bin means relative to the RMS of the
/// baseline's; and the change of the peak bin of drag.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Change {
    pub run: String,
    pub mean_drag_change: f64,
    pub mean_lift_change: f64,
    pub shape_drag_change: f64,
    pub shape_lift_change: f64,
    pub peak_drag_change: f64,
    pub bins: usize,
}

const BIN_RAD: f64 = 5.0 * PI / 180.0;

fn binned(samples: &[Sample], plate: &Plate) -> std::collections::BTreeMap<i64, (f64, f64, f64)> {
    let mut bins = std::collections::BTreeMap::new();
    for s in penetration(samples, plate) {
        let k = (wrap_beta_rad(s.beta_rad) / BIN_RAD).floor() as i64;
        let e = bins.entry(k).or_insert((0.0, 0.0, 0.0));
        e.0 += s.drag_n;
        e.1 += s.lift_n;
        e.2 += 1.0;
    }
    bins
}

/// How much `run` differs from `base` (the same geometry told to the model), over the bins
/// both have; `None` when they share no bin with force in it.
pub fn change(base: &DemRun, run: &DemRun) -> Option<Change> {
    let a = binned(&base.samples(), &base.plate);
    let b = binned(&run.samples(), &base.plate);
    let (mut dd, mut dl, mut nd, mut nl, mut n) = (0.0, 0.0, 0.0, 0.0, 0);
    let (mut sum_da, mut sum_la, mut sum_db, mut sum_lb) = (0.0, 0.0, 0.0, 0.0);
    let (mut peak_a, mut peak_b) = (0.0f64, 0.0f64);
    for (k, &(da, la, ca)) in &a {
        let Some(&(db, lb, cb)) = b.get(k) else {
            continue;
        };
        let (da, la, db, lb) = (da / ca, la / ca, db / cb, lb / cb);
        dd += (db - da).powi(2);
        dl += (lb - la).powi(2);
        nd += da * da;
        nl += la * la;
        sum_da += da;
        sum_la += la;
        sum_db += db;
        sum_lb += lb;
        peak_a = peak_a.max(da);
        peak_b = peak_b.max(db);
        n += 1;
    }
    if n == 0 || nd == 0.0 || nl == 0.0 || sum_da == 0.0 || sum_la == 0.0 || peak_a <= 0.0 {
        return None;
    }
    Some(Change {
        run: run.name.clone(),
        mean_drag_change: sum_db / sum_da - 1.0,
        mean_lift_change: sum_lb / sum_la - 1.0,
        shape_drag_change: (dd / nd).sqrt(),
        shape_lift_change: (dl / nl).sqrt(),
        peak_drag_change: peak_b / peak_a - 1.0,
        bins: n,
    })
}

/// The C-leg's measured forces against RFT from the DEM, and against the flat-plate improved
/// model fitted to it (the chord as the plate), over the whole submerged stroke.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CLegFidelity {
    pub run: String,
    pub samples: usize,
    pub rft: GoodnessOfFit,
    pub flat_plate_fit: GoodnessOfFit,
    pub measured_peak_drag_n: f64,
    pub rft_peak_drag_n: f64,
}

/// The C-leg's mid-line in its frame: a half circle on the chord, convex side toward the travel
/// (the campaign's mesh, `tests/dem/campaign.py`).
pub fn c_leg_line(chord_m: f64, segments: usize) -> Vec<(f64, f64)> {
    terzaghi::model::c_leg_profile(chord_m / 2.0, PI, segments)
}

pub fn c_leg_fidelity(run: &DemRun, rft: &RftCoefficients) -> Result<CLegFidelity, IdentError> {
    let line = c_leg_line(run.plate.length_m(), 16);
    let (b, h) = (run.plate.width_m(), run.plate.hip_height_m());
    let all = run.samples();
    // Every sample where the leg may touch the bed: the arc reaches as deep as the chord.
    let used: Vec<Sample> = all
        .iter()
        .filter(|s| {
            let p = rft_leg(rft, &line, b, h, s.beta_rad, 8);
            p.0 != 0.0 || p.1 != 0.0 || s.drag_n.abs() > 0.0
        })
        .copied()
        .collect();
    let pred = |beta: f64| {
        let p = rft_leg(rft, &line, b, h, beta, 8);
        (p.0, p.1)
    };
    let flat = fit_batch(
        &TerzaghiModel::conventional(run.plate, run.medium),
        &penetration(&all, &run.plate),
        &BatchOptions {
            fit_delta: true,
            ..Default::default()
        },
    )?;
    Ok(CLegFidelity {
        run: run.name.clone(),
        samples: used.len(),
        rft: score(pred, &used),
        flat_plate_fit: flat.improved,
        measured_peak_drag_n: used.iter().map(|s| s.drag_n).fold(f64::MIN, f64::max),
        rft_peak_drag_n: used
            .iter()
            .map(|s| pred(s.beta_rad).0)
            .fold(f64::MIN, f64::max),
    })
}

/// RFT coefficients from an intrusion grid `(beta_r, gamma, alpha_x, alpha_z)`.
pub fn rft_from_grid(points: &[(f64, f64, f64, f64)]) -> Option<RftCoefficients> {
    RftFit::fit_to_points(points).map(RftCoefficients::Fit)
}

/// A flat-plate run.
pub fn is_flat(run: &DemRun) -> bool {
    run.shape == LegShape::Flat
}

/// Everything `docs/dem.md` ("Checked against DEM") shows, from one campaign.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CampaignReport {
    pub baseline: String,
    /// The RFT coefficients fitted to the intrusion grid (N/cm^3), if the campaign has one.
    pub rft_fit: Option<RftFit>,
    pub rft_grid_points: usize,
    /// The RFT fit's R^2 on the grid's own points, for alpha_x and alpha_z.
    pub rft_grid_r2: Option<(f64, f64)>,
    /// `check_*` runs against the baseline.
    pub checks: Vec<Change>,
    /// `var_*` runs against the baseline.
    pub variations: Vec<Change>,
    /// Runs that share no penetration bin with force with the baseline, so are not compared.
    pub not_compared: Vec<String>,
    /// Quasi-static runs (`qs_*`).
    pub fidelity: Vec<RunFidelity>,
    pub transfer: Vec<Transfer>,
    pub c_leg: Option<CLegFidelity>,
}

/// The report of a campaign whose baseline run is `baseline`.
pub fn campaign_report(
    c: &terzaghi::dem::Campaign,
    baseline: &str,
) -> Result<CampaignReport, FidelityError> {
    let base = c.run(baseline).ok_or_else(|| FidelityError::NoBaseline {
        name: baseline.to_string(),
    })?;
    let rft_fit = RftFit::fit_to_points(&c.rft_grid);
    let rft_grid_r2 = rft_fit.map(|f| {
        let r2 = |pick: fn((f64, f64)) -> f64, meas: fn(&(f64, f64, f64, f64)) -> f64| {
            let pred: Vec<f64> = c.rft_grid.iter().map(|p| pick(f.alpha(p.0, p.1))).collect();
            let m: Vec<f64> = c.rft_grid.iter().map(meas).collect();
            terzaghi::ident::metrics::component_fit(&pred, &m).r2
        };
        (r2(|a| a.0, |p| p.2), r2(|a| a.1, |p| p.3))
    });
    let by_prefix = |p: &'static str| c.runs.iter().filter(move |r| r.name.starts_with(p));
    let qs: Vec<&DemRun> = by_prefix("qs_").filter(|r| is_flat(r)).collect();
    let fidelity = match rft_fit {
        Some(f) => qs
            .iter()
            .map(|r| run_fidelity(r, &RftCoefficients::Fit(f)))
            .collect::<Result<Vec<_>, _>>()?,
        None => Vec::new(),
    };
    let c_leg = match (rft_fit, c.runs.iter().find(|r| r.shape == LegShape::CLeg)) {
        (Some(f), Some(r)) => Some(c_leg_fidelity(r, &RftCoefficients::Fit(f))?),
        _ => None,
    };
    let mut not_compared = Vec::new();
    let mut compare = |prefix: &'static str| {
        let mut out = Vec::new();
        for r in by_prefix(prefix) {
            match change(base, r) {
                Some(c) => out.push(c),
                None => not_compared.push(r.name.clone()),
            }
        }
        out
    };
    let checks = compare("check_");
    let variations = compare("var_");
    Ok(CampaignReport {
        baseline: baseline.to_string(),
        rft_fit,
        rft_grid_points: c.rft_grid.len(),
        rft_grid_r2,
        checks,
        variations,
        not_compared,
        fidelity,
        transfer: width_transfer(&qs)?,
        c_leg,
    })
}

/// Why a campaign cannot be reported.
#[derive(Debug, thiserror::Error)]
pub enum FidelityError {
    #[error("the campaign has no baseline run {name:?}")]
    NoBaseline { name: String },
    #[error(transparent)]
    Ident(#[from] IdentError),
}

#[cfg(test)]
mod tests {
    use super::*;
    use terzaghi::dem::parse_run;

    fn run(rows: &str) -> DemRun {
        let text = format!(
            "# run: r\n# length_m: 0.1\n# width_m: 0.03\n# hip_height_m: 0.04\n# omega_rad_s: 1\n# unit_weight_n_m3: 14000\n# phi_deg: 23\n# delta_deg: 19\n# bed_settled_ke_ratio: 1e-7\nt_s,beta_rad,drag_n,lift_n,hip_torque_nm\n{rows}"
        );
        parse_run(&text, "r.csv").unwrap()
    }

    #[test]
    fn a_run_with_no_penetration_force_in_common_is_not_compared_rather_than_nan() {
        let base = run("0.01,1.0,2.0,1.0,0.1\n0.02,1.2,3.0,1.5,0.1\n");
        let same = change(&base, &base).unwrap();
        assert_eq!((same.mean_drag_change, same.bins), (0.0, 2));
        // Force only in extraction (beta > 90 deg): no penetration bin to compare.
        let late = run("0.01,2.0,2.0,1.0,0.1\n0.02,2.1,3.0,1.5,0.1\n");
        assert!(change(&base, &late).is_none());
        assert!(change(&late, &base).is_none());
    }
}
