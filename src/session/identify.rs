//! Identification of a leg's medium from a log replayed in time order through the online
//! estimator, as the node would have learnt it: the final estimate, its trace, and the
//! goodness of fit of the identified and conventional models.

use super::files::write_atomically;
use crate::ident::batch::select;
use crate::ident::online::ChangeEvent;
use crate::ident::{GoodnessOfFit, OnlineEstimator, OnlineOptions, Sample, goodness_of_fit};
use crate::model::{FittingWidth, TerzaghiModel};
use anyhow::{Result, bail};
use serde::Serialize;
use std::path::Path;

/// One row of the trace: the estimate after an update.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct TracePoint {
    /// Time of the update (log clock, s).
    pub t_s: f64,
    /// Estimated `b_k`.
    pub b_k: f64,
    /// Estimated `a`.
    pub a: f64,
    /// Estimated plate-medium friction angle (deg).
    pub delta_deg: f64,
    /// Standard deviation of `b_k`.
    pub std_b_k: f64,
    /// Standard deviation of `a`.
    pub std_a: f64,
    /// RMS of recent innovations (N).
    pub innovation_rms_n: f64,
    /// Whether the estimate has converged.
    pub converged: bool,
}

#[derive(Debug, Clone, Serialize)]
/// What the online identification of a log found: the final estimate, its fit, and its samples
/// and changes.
pub struct OnlineReport {
    /// Final `b_k`.
    pub b_k: f64,
    /// Final `a`.
    pub a: f64,
    /// Final plate-medium friction angle (deg).
    pub delta_deg: f64,
    /// How the improved model with the final estimate fits the log.
    pub improved: GoodnessOfFit,
    /// How the conventional model (`b_e = b`) fits the log.
    pub conventional: GoodnessOfFit,
    /// Samples scored (the same selection as `fit`).
    pub samples: usize,
    /// Standard deviation of `b_k`.
    pub std_b_k: f64,
    /// Standard deviation of `a`.
    pub std_a: f64,
    /// Standard deviation of the friction angle (deg).
    pub std_delta_deg: f64,
    /// Whether the estimate converged.
    pub converged: bool,
    /// Time stamp of the first sample at which the estimate was converged (log clock, s).
    pub converged_at_s: Option<f64>,
    /// Changes of the medium detected.
    pub changes_detected: u64,
    /// Each change detected.
    pub changes: Vec<ChangeEvent>,
    /// Samples that updated the estimate.
    pub samples_used: u64,
    /// Samples skipped as not finite.
    pub samples_non_finite: u64,
    /// Samples skipped outside the excitation gate.
    pub samples_not_excited: u64,
    /// Samples skipped as a stuck sensor's.
    pub samples_stuck: u64,
}

/// What [`identify_online`] found.
#[derive(Debug, Clone)]
pub struct OnlineIdentification {
    /// The report.
    pub report: OnlineReport,
    /// The estimate after every update.
    pub trace: Vec<TracePoint>,
    /// The samples had no time stamps: their order numbers were used as times.
    pub times_are_sample_numbers: bool,
    /// Samples replayed.
    pub samples: usize,
    /// Time of the first sample (s).
    pub t0_s: f64,
    /// The excitation gate in force (least unit-width model force, N).
    pub min_unit_force_n: f64,
}

/// Replays `samples` in time order (row order when they have no time stamps) through an online
/// estimator of `base`'s plate and medium; scores on the samples a batch fit would use (every
/// submerged one with `all_regimes`). An error when no sample passed the excitation gate.
pub fn identify_online(
    base: &TerzaghiModel,
    mut samples: Vec<Sample>,
    opts: OnlineOptions,
    all_regimes: bool,
) -> Result<OnlineIdentification> {
    let mut est = OnlineEstimator::new(base, opts)?;
    let with_t = samples.iter().filter(|s| s.t_s.is_some()).count();
    let times_are_sample_numbers = with_t == 0;
    if times_are_sample_numbers {
        for (i, s) in samples.iter_mut().enumerate() {
            s.t_s = Some(i as f64);
        }
    }
    samples.sort_by(|x, y| {
        x.t_s
            .unwrap_or(f64::NAN)
            .total_cmp(&y.t_s.unwrap_or(f64::NAN))
    });
    let mut trace = Vec::new();
    let mut converged_at_s = None;
    for s in &samples {
        if est.update(s).is_ok() {
            let e = est.estimate();
            if e.converged && converged_at_s.is_none() {
                converged_at_s = s.t_s;
            }
            trace.push(TracePoint {
                t_s: s.t_s.unwrap_or(f64::NAN),
                b_k: e.b_k,
                a: e.a,
                delta_deg: e.delta_deg,
                std_b_k: e.std_b_k,
                std_a: e.std_a,
                innovation_rms_n: e.innovation_rms_n,
                converged: e.converged,
            });
        }
    }
    let e = *est.estimate();
    if trace.is_empty() {
        bail!(
            "no sample passed the excitation gate ({} non-finite, {} not in penetration or below {} N of unit force, {} stuck)",
            e.samples_non_finite,
            e.samples_not_excited,
            est.options().min_unit_force_n,
            e.samples_stuck
        );
    }
    let medium = base.medium().with_delta_deg(e.delta_deg)?;
    let fitted = TerzaghiModel::new(*base.plate(), medium, FittingWidth::new(e.b_k, e.a)?);
    let (improved, conventional, scored) = score(base, &fitted, &samples, all_regimes);
    let report = OnlineReport {
        b_k: e.b_k,
        a: e.a,
        delta_deg: e.delta_deg,
        improved,
        conventional,
        samples: scored,
        std_b_k: e.std_b_k,
        std_a: e.std_a,
        std_delta_deg: e.std_delta_deg,
        converged: e.converged,
        converged_at_s,
        changes_detected: e.changes_detected,
        changes: est.changes().to_vec(),
        samples_used: e.samples_used,
        samples_non_finite: e.samples_non_finite,
        samples_not_excited: e.samples_not_excited,
        samples_stuck: e.samples_stuck,
    };
    Ok(OnlineIdentification {
        report,
        trace,
        times_are_sample_numbers,
        samples: samples.len(),
        t0_s: samples.first().and_then(|s| s.t_s).unwrap_or(0.0),
        min_unit_force_n: est.options().min_unit_force_n,
    })
}

/// Goodness of fit of the fitted and conventional models on the samples `fit` would use.
fn score(
    base: &TerzaghiModel,
    fitted: &TerzaghiModel,
    samples: &[Sample],
    all_regimes: bool,
) -> (GoodnessOfFit, GoodnessOfFit, usize) {
    let (used, _, _) = select(base, samples, all_regimes);
    let meas: Vec<(f64, f64)> = used.iter().map(|u| (u.drag_n, u.lift_n)).collect();
    let predict = |m: &TerzaghiModel| -> Vec<(f64, f64)> {
        used.iter()
            .map(|u| {
                m.evaluate(u.beta_rad)
                    .map(|f| (f.drag_n, f.lift_n))
                    .unwrap_or((0.0, 0.0))
            })
            .collect()
    };
    (
        goodness_of_fit(&predict(fitted), &meas),
        goodness_of_fit(&predict(base), &meas),
        used.len(),
    )
}

/// Writes the trace as CSV (one row per update, header from [`TracePoint`]'s fields).
pub fn write_trace_csv(path: &Path, trace: &[TracePoint]) -> Result<()> {
    write_atomically(path, |w| {
        let mut csv = csv::Writer::from_writer(w);
        for p in trace {
            csv.serialize(p)?;
        }
        csv.flush()?;
        Ok(())
    })
}

/// Most points a plotted line keeps; longer traces are thinned evenly.
const MAX_PLOT_POINTS: usize = 2000;

/// SVG of b_k and a over time, each with its +-2 sigma band.
pub fn plot_trace_svg(trace: &[TracePoint]) -> Result<String> {
    use plotters::prelude::*;
    let stride = trace.len().div_ceil(MAX_PLOT_POINTS).max(1);
    let thinned: Vec<TracePoint> = trace.iter().step_by(stride).copied().collect();
    let trace = &thinned[..];
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (900, 600)).into_drawing_area();
        root.fill(&WHITE)?;
        let panels = root.split_evenly((2, 1));
        let t0 = trace.first().map(|p| p.t_s).unwrap_or(0.0);
        let t1 = trace.last().map(|p| p.t_s).unwrap_or(1.0).max(t0 + 1e-9);
        type Get = fn(&TracePoint) -> (f64, f64);
        let series: [(&str, Get); 2] = [("b_k", |p| (p.b_k, p.std_b_k)), ("a", |p| (p.a, p.std_a))];
        for (area, (name, get)) in panels.iter().zip(series) {
            // Range from the converged part when there is one, so that the start does not
            // flatten the band.
            let conv: Vec<&TracePoint> = trace.iter().filter(|p| p.converged).collect();
            let basis: Vec<&TracePoint> = if conv.len() > 10 {
                conv
            } else {
                trace.iter().collect()
            };
            let (lo, hi) = basis
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                    let (v, s) = get(p);
                    (lo.min(v - 3.0 * s), hi.max(v + 3.0 * s))
                });
            let pad = ((hi - lo) * 0.1).max(1e-6);
            let mut chart = ChartBuilder::on(area)
                .caption(
                    format!("{name} (online estimate, band: +-2 sigma)"),
                    ("sans-serif", 18),
                )
                .margin(10)
                .x_label_area_size(30)
                .y_label_area_size(60)
                .build_cartesian_2d(t0..t1, (lo - pad)..(hi + pad))?;
            chart.configure_mesh().x_desc("t (s)").y_desc(name).draw()?;
            let clamp = |v: f64| v.clamp(lo - pad, hi + pad);
            let upper: Vec<(f64, f64)> = trace
                .iter()
                .map(|p| {
                    let (v, s) = get(p);
                    (p.t_s, clamp(v + 2.0 * s))
                })
                .collect();
            let lower: Vec<(f64, f64)> = trace
                .iter()
                .rev()
                .map(|p| {
                    let (v, s) = get(p);
                    (p.t_s, clamp(v - 2.0 * s))
                })
                .collect();
            let band: Vec<(f64, f64)> = upper.into_iter().chain(lower).collect();
            chart.draw_series(std::iter::once(Polygon::new(band, BLUE.mix(0.2).filled())))?;
            chart.draw_series(LineSeries::new(
                trace.iter().map(|p| (p.t_s, clamp(get(p).0))),
                BLUE.stroke_width(2),
            ))?;
        }
        root.present()?;
    }
    Ok(svg)
}
