//! The gap of a wheel's test (a slip sweep, or runs at slip angles) against a calibrated medium:
//! where the measured sinkage and drawbar part from the model's (by slip and slip angle), which
//! unmodelled effect is responsible, and how far the gap shrinks once it is added, each
//! candidate scored on the runs it was not fitted to (leave one run out).
//!
//! The candidates weighed, each a correction a medium file takes:
//! - `sheared_bearing`: the bearing of sheared sand ([`crate::model::ShearedBearing`], two
//!   coefficients): the sand bears less where the rim's resultant leans past the interface's
//!   friction, so the loss grows with the shear the rim mobilises, in either sense of slip.
//! - `medium_scale`: the sand softer or harder than its tests said, every stress by one factor.
//! - `surface_level`: the sinkage read from another zero (the rig's surface, its compliance).
//! - `drawbar_bias`: a constant on the drawbar (the sensor's zero, a rolling resistance the
//!   model lacks).
//!
//! The evidence beside the scores: the load each run carries against what the sand at rest
//! bears at its measured sinkage (1: the model bears it as measured; below 1: the sand bears
//! less than the model says), and how that share follows the lean of the rim's resultant (the
//! shear it mobilises), the slip's size and its sign.

use crate::ident::metrics::component_fit;
use crate::ident::sheared::{ShearedFitError, SweepRun, SweepTable, fit_sheared, slip};
use crate::model::{Body, ShearedBearing, Stress};
use serde::Serialize;

/// What counts as a gap.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WheelDiagnoseOptions {
    /// The smallest sinkage gap (m, RMS over the runs) worth explaining.
    pub min_gap_sinkage_m: f64,
    /// The smallest drawbar gap (N, RMS over the runs) worth explaining.
    pub min_gap_drawbar_n: f64,
    /// The share of the gap (of `(1 - R^2)` of the sinkage plus that of the drawbar, held out)
    /// an effect must close to be named.
    pub min_share_closed: f64,
}

impl Default for WheelDiagnoseOptions {
    fn default() -> Self {
        WheelDiagnoseOptions {
            min_gap_sinkage_m: 1e-3,
            min_gap_drawbar_n: 0.5,
            min_share_closed: 0.3,
        }
    }
}

/// One run against the model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunGap {
    /// The run (from 1, in the file's order).
    pub run: usize,
    /// Its slip (`(omega r - v) / max(v, omega r)`).
    pub slip: f64,
    /// Its slip angle (deg).
    pub slip_angle_deg: f64,
    /// Its load (N).
    pub load_n: f64,
    /// Measured sinkage (m) and the model's (`None`: the sand bears it nowhere within the
    /// body's height).
    pub sinkage_m: f64,
    /// See [`Self::sinkage_m`].
    pub predicted_sinkage_m: Option<f64>,
    /// Measured drawbar (N) and the model's.
    pub drawbar_n: f64,
    /// See [`Self::drawbar_n`].
    pub predicted_drawbar_n: Option<f64>,
    /// What the sand at rest bears at the measured sinkage under the run's drive (N).
    pub borne_at_rest_n: f64,
    /// The load over [`Self::borne_at_rest_n`]: 1 where the sand bears what the model says.
    pub load_share: f64,
    /// `|horizontal| / vertical` of the sand at rest there: the shear the rim mobilises.
    pub lean: f64,
    /// Whether model and measurement part on this run (its sinkage or drawbar off by more than
    /// the gap's floor and a quarter of the measurement).
    pub parts: bool,
}

/// The runs of one class of slip at one slip angle.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GroupGap {
    /// `locked`, `skidding`, `rolling free` or `driving`.
    pub slip_class: &'static str,
    /// The slip angle (deg, rounded to 0.1).
    pub slip_angle_deg: f64,
    /// Runs in the group, and of them, where model and measurement part.
    pub runs: usize,
    /// See [`Self::runs`].
    pub parted: usize,
    /// Runs whose resultant, of the sand at rest at the measured sinkage, leans past the
    /// refitted sheared bearing's `tan delta_w`: where that effect acts (0 where it was not
    /// fitted).
    pub sheared: usize,
    /// The median of the runs' [`RunGap::load_share`].
    pub median_load_share: f64,
    /// The mean of predicted minus measured sinkage (m) and drawbar (N), over runs borne.
    pub mean_sinkage_error_m: f64,
    /// See [`Self::mean_sinkage_error_m`].
    pub mean_drawbar_error_n: f64,
}

/// Agreement over the runs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Agreement {
    /// R^2 of the sinkage and of the drawbar.
    pub r2_sinkage: f64,
    /// See [`Self::r2_sinkage`].
    pub r2_drawbar: f64,
    /// RMSE of the sinkage (m) and of the drawbar (N).
    pub rmse_sinkage_m: f64,
    /// See [`Self::rmse_sinkage_m`].
    pub rmse_drawbar_n: f64,
    /// Runs the sand bears nowhere within the body's height (scored buried to its top).
    pub not_borne: usize,
    /// `(1 - R^2)` of the sinkage plus that of the drawbar: the gap the candidates close.
    pub misfit: f64,
}

/// A coefficient as a medium file takes it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Coefficient {
    /// Its name.
    pub name: &'static str,
    /// Its value, fitted on every run.
    pub value: f64,
    /// Its standard deviation (jackknife over the runs).
    pub std_dev: f64,
}

/// One candidate effect, fitted and scored.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Candidate {
    /// `sheared_bearing`, `medium_scale`, `surface_level` or `drawbar_bias`.
    pub effect: &'static str,
    /// What it stands for.
    pub means: &'static str,
    /// Its coefficients fitted on every run (empty where it cannot be fitted).
    pub coefficients: Vec<Coefficient>,
    /// The agreement of each run predicted by the fit on the other runs.
    pub held_out: Option<Agreement>,
    /// The share of the gap it closes, held out (`1 - misfit after / misfit before`).
    pub share_closed: f64,
    /// Why it could not be fitted, where it could not.
    pub refused: Option<String>,
}

/// How the load share follows the candidates' causes (Pearson's r over the runs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ShareEvidence {
    /// The load share against the rim's lean.
    pub r_with_lean: f64,
    /// Against the slip's size.
    pub r_with_slip_size: f64,
    /// Against the slip (its sign counted: the drawbar's shape).
    pub r_with_slip: f64,
    /// The median share of the runs that lean past the named bearing's interface (where one is
    /// named), and of the others.
    pub median_share_sheared: Option<f64>,
    /// See [`Self::median_share_sheared`].
    pub median_share_unsheared: Option<f64>,
}

/// The verdict.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WheelVerdict {
    /// The candidate named, `none` (nothing to explain) or `unexplained`.
    pub effect: String,
    /// The claim in a sentence.
    pub claim: String,
    /// The share of the gap closed, held out (0 for `none`).
    pub share_closed: f64,
}

/// The diagnosis of a wheel's test.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WheelDiagnosis {
    /// Each run.
    pub runs: Vec<RunGap>,
    /// The runs by slip class and slip angle.
    pub groups: Vec<GroupGap>,
    /// The model as the medium gives it.
    pub baseline: Agreement,
    /// Whether the gap is beyond the floor ([`WheelDiagnoseOptions`]).
    pub gap_to_explain: bool,
    /// The candidates, best first.
    pub candidates: Vec<Candidate>,
    /// The load share's evidence.
    pub evidence: ShareEvidence,
    /// The verdict.
    pub verdict: WheelVerdict,
}

/// Why a wheel's test cannot be diagnosed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WheelDiagnoseError {
    /// Too few runs to hold any out.
    #[error("a wheel's test needs {0} runs or more to hold one out; it has {1}")]
    TooFew(usize, usize),
    /// The tabulation failed.
    #[error("{0}")]
    Table(ShearedFitError),
}

/// Runs a diagnosis needs.
pub const MIN_RUNS: usize = 5;

/// `(sinkage, drawbar, borne)` of each run under a settle function; a run not borne is scored
/// buried to its top (the body's height, the drawbar there).
fn settled(
    table: &SweepTable,
    settle: impl Fn(usize) -> Option<(f64, f64)>,
) -> Vec<(f64, f64, bool)> {
    let deepest = table.deepest_m();
    (0..table.runs().len())
        .map(|i| match settle(i) {
            Some((s, d)) => (s, d, true),
            None => (deepest, table.at_depth(i, deepest)[1], false),
        })
        .collect()
}

fn agreement(runs: &[SweepRun], pred: &[(f64, f64, bool)]) -> Agreement {
    let ps: Vec<f64> = pred.iter().map(|p| p.0).collect();
    let pd: Vec<f64> = pred.iter().map(|p| p.1).collect();
    let ms: Vec<f64> = runs.iter().map(|r| r.sinkage_m).collect();
    let md: Vec<f64> = runs.iter().map(|r| r.drawbar_n).collect();
    let (s, d) = (component_fit(&ps, &ms), component_fit(&pd, &md));
    Agreement {
        r2_sinkage: s.r2,
        r2_drawbar: d.r2,
        rmse_sinkage_m: s.rmse,
        rmse_drawbar_n: d.rmse,
        not_borne: pred.iter().filter(|p| !p.2).count(),
        misfit: (1.0 - s.r2) + (1.0 - d.r2),
    }
}

fn pearson(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len().min(y.len()) as f64;
    if n < 3.0 {
        return 0.0;
    }
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        sxy += (a - mx) * (b - my);
        sxx += (a - mx).powi(2);
        syy += (b - my).powi(2);
    }
    if sxx > 0.0 && syy > 0.0 {
        sxy / (sxx * syy).sqrt()
    } else {
        0.0
    }
}

fn median_of(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    })
}

/// The scale of the sand's stress (under the medium's own sheared bearing, if any) that fits
/// `which` best (golden section on its logarithm, 0.05 to 20).
fn best_scale(table: &SweepTable, which: &[usize], bearing: Option<&ShearedBearing>) -> f64 {
    let misfit = |ln_k: f64| {
        let k = ln_k.exp();
        let pred = settled(table, |i| table.settle_scaled(i, k, bearing));
        let runs: Vec<SweepRun> = which.iter().map(|&i| table.runs()[i]).collect();
        let p: Vec<(f64, f64, bool)> = which.iter().map(|&i| pred[i]).collect();
        agreement(&runs, &p).misfit
    };
    // A coarse scan first (the misfit need not be unimodal), then golden section about it.
    let (lo, hi) = (0.05f64.ln(), 20f64.ln());
    let steps = 40;
    let at = |k: usize| lo + (hi - lo) * k as f64 / steps as f64;
    let best_k = (0..=steps)
        .map(|k| (misfit(at(k)), k))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map_or(steps / 2, |b| b.1);
    let (mut a, mut b) = (at(best_k.saturating_sub(1)), at((best_k + 1).min(steps)));
    let g = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..30 {
        let (c, d) = (b - g * (b - a), a + g * (b - a));
        if misfit(c) < misfit(d) {
            b = d;
        } else {
            a = c;
        }
    }
    (0.5 * (a + b)).exp()
}

fn sd_of(each: &[f64]) -> f64 {
    let n = each.len() as f64;
    let mean = each.iter().sum::<f64>() / n;
    ((n - 1.0) / n * each.iter().map(|v| (v - mean).powi(2)).sum::<f64>()).sqrt()
}

/// A candidate from its fit on every run and its fit with each run left out: `fit(which)`
/// gives the coefficients, `predict(coefficients, i)` run `i`'s sinkage and drawbar.
fn scored(
    table: &SweepTable,
    effect: &'static str,
    means: &'static str,
    names: &[&'static str],
    fit: impl Fn(&[usize]) -> Vec<f64>,
    predict: impl Fn(&[f64], usize) -> Option<(f64, f64)>,
    base_misfit: f64,
) -> Candidate {
    let n = table.runs().len();
    let all: Vec<usize> = (0..n).collect();
    let whole = fit(&all);
    let each: Vec<Vec<f64>> = (0..n)
        .map(|out| {
            fit(&all
                .iter()
                .copied()
                .filter(|&i| i != out)
                .collect::<Vec<_>>())
        })
        .collect();
    let held = settled(table, |i| predict(&each[i], i));
    let a = agreement(table.runs(), &held);
    let coefficients = names
        .iter()
        .enumerate()
        .map(|(c, name)| Coefficient {
            name,
            value: whole[c],
            std_dev: sd_of(&each.iter().map(|e| e[c]).collect::<Vec<_>>()),
        })
        .collect();
    Candidate {
        effect,
        means,
        coefficients,
        share_closed: share_closed(base_misfit, a.misfit),
        held_out: Some(a),
        refused: None,
    }
}

fn share_closed(before: f64, after: f64) -> f64 {
    if before > 0.0 && after.is_finite() {
        1.0 - after / before
    } else {
        0.0
    }
}

/// The slip class of a run.
fn slip_class(s: f64) -> &'static str {
    if s <= -0.95 {
        "locked"
    } else if s < -0.05 {
        "skidding"
    } else if s <= 0.05 {
        "rolling free"
    } else {
        "driving"
    }
}

/// Diagnoses `runs` of `body` against the medium's `stress` (with its own sheared bearing, if
/// it has one: that is the model judged).
pub fn diagnose_wheel(
    body: &Body,
    stress: &Stress,
    runs: &[SweepRun],
    opts: &WheelDiagnoseOptions,
) -> Result<WheelDiagnosis, WheelDiagnoseError> {
    if runs.len() < MIN_RUNS {
        return Err(WheelDiagnoseError::TooFew(MIN_RUNS, runs.len()));
    }
    let table = SweepTable::new(body, stress, runs).map_err(WheelDiagnoseError::Table)?;
    let reach = body.reach_m();
    let base_pred = settled(&table, |i| {
        table.settle(i, stress.sheared).map(|(s, d, _)| (s, d))
    });
    let baseline = agreement(runs, &base_pred);
    let gap_to_explain = baseline.rmse_sinkage_m > opts.min_gap_sinkage_m
        || baseline.rmse_drawbar_n > opts.min_gap_drawbar_n
        || baseline.not_borne > 0;

    let run_gaps: Vec<RunGap> = runs
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let f = table.at_depth(i, r.sinkage_m);
            let (ps, pd, borne) = base_pred[i];
            let off_s = (ps - r.sinkage_m).abs();
            let off_d = (pd - r.drawbar_n).abs();
            RunGap {
                run: i + 1,
                slip: slip(&r.drive, reach),
                slip_angle_deg: r.drive.slip_angle_rad.to_degrees(),
                load_n: r.load_n,
                sinkage_m: r.sinkage_m,
                predicted_sinkage_m: borne.then_some(ps),
                drawbar_n: r.drawbar_n,
                predicted_drawbar_n: borne.then_some(pd),
                borne_at_rest_n: f[0],
                load_share: if f[0] > 0.0 { r.load_n / f[0] } else { 0.0 },
                lean: if f[0] > 0.0 { f[2] / f[0] } else { 0.0 },
                parts: !borne
                    || off_s > opts.min_gap_sinkage_m.max(0.25 * r.sinkage_m)
                    || off_d > opts.min_gap_drawbar_n.max(0.25 * r.drawbar_n.abs()),
            }
        })
        .collect();
    let mut candidates = vec![sheared_candidate(
        body,
        stress,
        runs,
        &table,
        baseline.misfit,
    )];
    let interface_tan = candidates[0].coefficients.first().map(|c| c.value);
    let groups = groups_of(&run_gaps, &base_pred, interface_tan);
    candidates.push(scored(
        &table,
        "medium_scale",
        "the sand softer or harder than its tests said: every stress by one factor",
        &["stress_scale"],
        |which| vec![best_scale(&table, which, stress.sheared)],
        |c, i| table.settle_scaled(i, c[0], stress.sheared),
        baseline.misfit,
    ));
    let mean_off = |which: &[usize], get: &dyn Fn(usize) -> f64| {
        which.iter().map(|&i| get(i)).sum::<f64>() / which.len().max(1) as f64
    };
    candidates.push(scored(
        &table,
        "surface_level",
        "the sinkage read from another zero: the rig's surface, its compliance",
        &["sinkage_offset_m"],
        |which| vec![mean_off(which, &|i| runs[i].sinkage_m - base_pred[i].0)],
        |c, i| Some((base_pred[i].0 + c[0], base_pred[i].1)),
        baseline.misfit,
    ));
    candidates.push(scored(
        &table,
        "drawbar_bias",
        "a constant on the drawbar: the sensor's zero, a rolling resistance the model lacks",
        &["drawbar_offset_n"],
        |which| vec![mean_off(which, &|i| runs[i].drawbar_n - base_pred[i].1)],
        |c, i| Some((base_pred[i].0, base_pred[i].1 + c[0])),
        baseline.misfit,
    ));
    candidates.sort_by(|a, b| b.share_closed.total_cmp(&a.share_closed));

    let evidence = evidence_of(
        &run_gaps,
        candidates.iter().find(|c| c.effect == "sheared_bearing"),
    );
    let verdict = verdict_of(&baseline, gap_to_explain, &candidates, &groups, opts);
    Ok(WheelDiagnosis {
        runs: run_gaps,
        groups,
        baseline,
        gap_to_explain,
        candidates,
        evidence,
        verdict,
    })
}

/// The sheared bearing refitted on the runs (the medium's own, if any, replaced).
fn sheared_candidate(
    body: &Body,
    stress: &Stress,
    runs: &[SweepRun],
    table: &SweepTable,
    base_misfit: f64,
) -> Candidate {
    let means = "the bearing of sheared sand: the sand bears less where the rim's resultant leans past the interface's friction";
    match fit_sheared(body, stress, runs) {
        Ok(fit) => {
            let held = settled(table, |i| {
                table
                    .settle(i, Some(&fit.leave_one_out[i]))
                    .map(|(s, d, _)| (s, d))
            });
            let a = agreement(runs, &held);
            Candidate {
                effect: "sheared_bearing",
                means,
                coefficients: vec![
                    Coefficient {
                        name: "interface_tan",
                        value: fit.bearing.interface_tan,
                        std_dev: fit.std_dev[0],
                    },
                    Coefficient {
                        name: "exponent",
                        value: fit.bearing.exponent,
                        std_dev: fit.std_dev[1],
                    },
                ],
                share_closed: share_closed(base_misfit, a.misfit),
                held_out: Some(a),
                refused: None,
            }
        }
        Err(e) => Candidate {
            effect: "sheared_bearing",
            means,
            coefficients: vec![],
            held_out: None,
            share_closed: 0.0,
            refused: Some(e.to_string()),
        },
    }
}

fn groups_of(
    runs: &[RunGap],
    pred: &[(f64, f64, bool)],
    interface_tan: Option<f64>,
) -> Vec<GroupGap> {
    let mut keys: Vec<(&'static str, f64)> = Vec::new();
    let key = |r: &RunGap| (slip_class(r.slip), (r.slip_angle_deg * 10.0).round() / 10.0);
    for r in runs {
        if !keys.contains(&key(r)) {
            keys.push(key(r));
        }
    }
    let order = |c: &str| {
        ["locked", "skidding", "rolling free", "driving"]
            .iter()
            .position(|x| *x == c)
    };
    keys.sort_by(|a, b| a.1.total_cmp(&b.1).then(order(a.0).cmp(&order(b.0))));
    keys.into_iter()
        .map(|k| {
            let members: Vec<usize> = (0..runs.len()).filter(|&i| key(&runs[i]) == k).collect();
            let borne: Vec<usize> = members.iter().copied().filter(|&i| pred[i].2).collect();
            let mean = |get: &dyn Fn(usize) -> f64| {
                borne.iter().map(|&i| get(i)).sum::<f64>() / borne.len().max(1) as f64
            };
            GroupGap {
                slip_class: k.0,
                slip_angle_deg: k.1,
                runs: members.len(),
                parted: members.iter().filter(|&&i| runs[i].parts).count(),
                sheared: interface_tan
                    .map_or(0, |t| members.iter().filter(|&&i| runs[i].lean > t).count()),
                median_load_share: median_of(members.iter().map(|&i| runs[i].load_share).collect())
                    .unwrap_or(f64::NAN),
                mean_sinkage_error_m: mean(&|i| pred[i].0 - runs[i].sinkage_m),
                mean_drawbar_error_n: mean(&|i| pred[i].1 - runs[i].drawbar_n),
            }
        })
        .collect()
}

fn evidence_of(runs: &[RunGap], sheared: Option<&Candidate>) -> ShareEvidence {
    let share: Vec<f64> = runs.iter().map(|r| r.load_share).collect();
    let lean: Vec<f64> = runs.iter().map(|r| r.lean).collect();
    let size: Vec<f64> = runs.iter().map(|r| r.slip.abs()).collect();
    let signed: Vec<f64> = runs.iter().map(|r| r.slip).collect();
    let tan = sheared
        .and_then(|c| c.coefficients.first())
        .map(|c| c.value);
    let (past, within): (Vec<&RunGap>, Vec<&RunGap>) = match tan {
        Some(t) => runs.iter().partition(|r| r.lean > t),
        None => (vec![], vec![]),
    };
    ShareEvidence {
        r_with_lean: pearson(&share, &lean),
        r_with_slip_size: pearson(&share, &size),
        r_with_slip: pearson(&share, &signed),
        median_share_sheared: tan.and(median_of(past.iter().map(|r| r.load_share).collect())),
        median_share_unsheared: tan.and(median_of(within.iter().map(|r| r.load_share).collect())),
    }
}

fn verdict_of(
    baseline: &Agreement,
    gap_to_explain: bool,
    candidates: &[Candidate],
    groups: &[GroupGap],
    opts: &WheelDiagnoseOptions,
) -> WheelVerdict {
    if !gap_to_explain {
        return WheelVerdict {
            effect: "none".into(),
            claim: format!(
                "nothing to explain: the model meets every run (sinkage RMSE {:.2} mm, drawbar RMSE {:.2} N, within the floor of {:.2} mm and {:.2} N)",
                baseline.rmse_sinkage_m * 1e3,
                baseline.rmse_drawbar_n,
                opts.min_gap_sinkage_m * 1e3,
                opts.min_gap_drawbar_n
            ),
            share_closed: 0.0,
        };
    }
    let parted: Vec<String> = groups
        .iter()
        .filter(|g| g.parted > 0)
        .map(|g| {
            format!(
                "{} of {} {} at slip angle {} deg",
                g.parted, g.runs, g.slip_class, g.slip_angle_deg
            )
        })
        .collect();
    let best = &candidates[0];
    if best.share_closed >= opts.min_share_closed {
        let coefficients: Vec<String> = best
            .coefficients
            .iter()
            .map(|c| format!("{} {:.4} +- {:.4}", c.name, c.value, c.std_dev))
            .collect();
        let held = best.held_out.expect("a scored candidate");
        let acts = if best.effect == "sheared_bearing" {
            let on: Vec<String> = groups
                .iter()
                .filter(|g| g.sheared > 0)
                .map(|g| {
                    format!(
                        "{} of {} {} at slip angle {} deg",
                        g.sheared, g.runs, g.slip_class, g.slip_angle_deg
                    )
                })
                .collect();
            format!(
                "; it acts on the runs whose resultant leans past tan delta_w: {}",
                on.join(", ")
            )
        } else {
            String::new()
        };
        WheelVerdict {
            effect: best.effect.into(),
            claim: format!(
                "{} ({}) closes {:.0} % of the gap, held out run by run: sinkage R^2 {:.3} -> {:.3}, drawbar {:.3} -> {:.3}{acts}; model and measurement part on {}",
                best.effect,
                coefficients.join(", "),
                100.0 * best.share_closed,
                baseline.r2_sinkage,
                held.r2_sinkage,
                baseline.r2_drawbar,
                held.r2_drawbar,
                parted.join(", ")
            ),
            share_closed: best.share_closed,
        }
    } else {
        WheelVerdict {
            effect: "unexplained".into(),
            claim: format!(
                "no candidate closes {:.0} % of the gap (the best, {}, {:.0} %); model and measurement part on {}",
                100.0 * opts.min_share_closed,
                best.effect,
                100.0 * best.share_closed,
                parted.join(", ")
            ),
            share_closed: best.share_closed.max(0.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Drive, RftCoefficients, RftDepthLaw, RftFit, steady_sinkage};

    fn wheel() -> Body {
        Body::wheel(0.058, 0.05, None, 360).unwrap()
    }

    /// A sweep the model settles in `law` (with `truth`'s bearing where given).
    fn generated(law: &RftDepthLaw, truth: Option<&ShearedBearing>) -> Vec<SweepRun> {
        let c = RftCoefficients::Fit(RftFit::POPPY_LP);
        let stress = Stress {
            coefficients: &c,
            depth_law: Some(law),
            speed_law: None,
            sheared: truth,
        };
        [0.0, 2.0, 4.0, 6.0, 8.0, 10.0, 12.0, 20.0, 40.0]
            .iter()
            .map(|rim_mm_s| {
                let drive = Drive {
                    speed_m_s: 0.01,
                    omega_rad_s: rim_mm_s * 1e-3 / 0.058,
                    slip_angle_rad: 0.0,
                };
                let s = steady_sinkage(&wheel(), &stress, 22.0, &drive).unwrap();
                SweepRun {
                    load_n: 22.0,
                    drive,
                    sinkage_m: s.sinkage_m,
                    drawbar_n: s.drawbar_n,
                }
            })
            .collect()
    }

    fn diagnose(runs: &[SweepRun]) -> WheelDiagnosis {
        let c = RftCoefficients::Fit(RftFit::POPPY_LP);
        let law = RftDepthLaw::new(4.546, 1.219).unwrap();
        let stress = Stress {
            coefficients: &c,
            depth_law: Some(&law),
            speed_law: None,
            sheared: None,
        };
        diagnose_wheel(&wheel(), &stress, runs, &WheelDiagnoseOptions::default()).unwrap()
    }

    #[test]
    fn a_sweep_of_the_model_itself_has_nothing_to_explain() {
        let law = RftDepthLaw::new(4.546, 1.219).unwrap();
        let d = diagnose(&generated(&law, None));
        assert_eq!(d.verdict.effect, "none", "{:?}", d.verdict);
        assert!(d.verdict.claim.starts_with("nothing to explain"));
        assert!(d.runs.iter().all(|r| !r.parts), "{:?}", d.runs);
    }

    #[test]
    fn a_sweep_of_sheared_sand_names_the_sheared_bearing_with_its_coefficients() {
        let law = RftDepthLaw::new(4.546, 1.219).unwrap();
        let truth = ShearedBearing::new(0.35, 2.0).unwrap();
        let d = diagnose(&generated(&law, Some(&truth)));
        assert_eq!(d.verdict.effect, "sheared_bearing", "{:?}", d.verdict);
        let c = &d.candidates[0].coefficients;
        assert!((c[0].value / 0.35 - 1.0).abs() < 0.05, "{c:?}");
        // The skidding runs part; the load borne falls with the lean, not the sign of slip.
        assert!(
            d.groups
                .iter()
                .any(|g| g.slip_class == "skidding" && g.parted > 0)
        );
        assert!(
            d.groups
                .iter()
                .any(|g| g.slip_class == "skidding" && g.sheared > 0)
        );
        assert!(
            d.verdict.claim.contains("it acts on"),
            "{}",
            d.verdict.claim
        );
        assert!(d.evidence.r_with_lean < -0.5, "{:?}", d.evidence);
    }

    #[test]
    fn a_softer_sand_names_the_medium_scale_not_the_sheared_bearing() {
        let soft = RftDepthLaw::new(4.546 * 0.5, 1.219).unwrap();
        let d = diagnose(&generated(&soft, None));
        assert_eq!(d.verdict.effect, "medium_scale", "{:?}", d.candidates);
        let k = d.candidates[0].coefficients[0].value;
        assert!((k - 0.5).abs() < 0.03, "{k}");
    }

    #[test]
    fn too_few_runs_are_refused() {
        let law = RftDepthLaw::new(4.546, 1.219).unwrap();
        let runs = generated(&law, None);
        let c = RftCoefficients::Fit(RftFit::POPPY_LP);
        let stress = Stress {
            coefficients: &c,
            depth_law: Some(&law),
            speed_law: None,
            sheared: None,
        };
        let e = diagnose_wheel(&wheel(), &stress, &runs[..4], &Default::default()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "a wheel's test needs 5 runs or more to hold one out; it has 4"
        );
    }
}
