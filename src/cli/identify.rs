//! `terzaghi identify`: batch or online identification of a log, with a trace and its plot.

use super::log_source::LogArgs;
use super::{print_out, write_atomically};
use crate::ident::batch::select;
use crate::ident::online::{ChangeEvent, Forgetting};
use crate::ident::{
    BatchOptions, GoodnessOfFit, OnlineEstimator, OnlineOptions, Sample, fit_batch, goodness_of_fit,
};
use crate::model::{FittingWidth, TerzaghiModel};
use anyhow::{Result, bail};
use clap::Args;
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};

#[derive(Debug, Args)]
pub struct IdentifyArgs {
    #[command(flatten)]
    pub log: LogArgs,
    /// Replay the samples in time order through the online estimator (default: batch fit).
    #[arg(long)]
    pub online: bool,
    /// Estimate delta too.
    #[arg(long)]
    pub fit_delta: bool,
    /// Score (and, in batch, fit) every submerged sample, not only penetration.
    #[arg(long)]
    pub all_regimes: bool,
    /// Online: forgetting factor per update, in (0, 1] (default: a memory of --memory-strokes).
    #[arg(
        long,
        value_name = "F",
        allow_negative_numbers = true,
        conflicts_with = "memory_strokes"
    )]
    pub forgetting: Option<f64>,
    /// Online: memory of the forgetting, in strokes.
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub memory_strokes: Option<f64>,
    /// Online: excitation gate, least unit-width model force to learn from (N).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub min_unit_force_n: Option<f64>,
    /// Online: write the estimate after every update to this CSV file.
    #[arg(long, value_name = "OUT.csv")]
    pub trace: Option<PathBuf>,
    /// Online: plot b_k and a over time with their +-2 sigma band to this SVG file.
    #[arg(long, value_name = "OUT.svg")]
    pub trace_plot: Option<PathBuf>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

/// One row of the trace: the estimate after an update.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct TracePoint {
    pub t_s: f64,
    pub b_k: f64,
    pub a: f64,
    pub delta_deg: f64,
    pub std_b_k: f64,
    pub std_a: f64,
    pub innovation_rms_n: f64,
    pub converged: bool,
}

#[derive(Debug, Serialize)]
struct OnlineReport {
    b_k: f64,
    a: f64,
    delta_deg: f64,
    improved: GoodnessOfFit,
    conventional: GoodnessOfFit,
    /// Samples scored (the same selection as `fit`).
    samples: usize,
    std_b_k: f64,
    std_a: f64,
    std_delta_deg: f64,
    converged: bool,
    /// Time stamp of the first sample at which the estimate was converged (log clock, s).
    converged_at_s: Option<f64>,
    changes_detected: u64,
    changes: Vec<ChangeEvent>,
    samples_used: u64,
    samples_non_finite: u64,
    samples_not_excited: u64,
    samples_stuck: u64,
}

pub fn run(a: IdentifyArgs) -> Result<()> {
    if !a.online
        && (a.trace.is_some()
            || a.trace_plot.is_some()
            || a.forgetting.is_some()
            || a.memory_strokes.is_some()
            || a.min_unit_force_n.is_some())
    {
        bail!(
            "--trace, --trace-plot, --forgetting, --memory-strokes and --min-unit-force-n need --online"
        );
    }
    let (base, mut samples) = a.log.load()?;
    if !a.online {
        let opts = BatchOptions {
            fit_delta: a.fit_delta,
            all_regimes: a.all_regimes,
            ..Default::default()
        };
        let fit = fit_batch(&base, &samples, &opts)?;
        return if a.json {
            print_out(&(serde_json::to_string_pretty(&fit)? + "\n"))
        } else {
            print_out(&super::fit::render(&fit, a.fit_delta))
        };
    }

    let mut opts = OnlineOptions {
        fit_delta: a.fit_delta,
        ..Default::default()
    };
    if let Some(f) = a.forgetting {
        opts.forgetting = Forgetting::PerSample(f);
    }
    if let Some(m) = a.memory_strokes {
        opts.forgetting = Forgetting::Strokes(m);
    }
    if let Some(n) = a.min_unit_force_n {
        opts.min_unit_force_n = n;
    }
    let mut est = OnlineEstimator::new(&base, opts)?;

    // Time order. A log without time stamps keeps its row order, with sample numbers as times.
    let with_t = samples.iter().filter(|s| s.t_s.is_some()).count();
    if with_t == 0 {
        for (i, s) in samples.iter_mut().enumerate() {
            s.t_s = Some(i as f64);
        }
        eprintln!(
            "note: {} has no t_s column: times are sample numbers",
            a.log.data.display()
        );
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
            "{}: no sample passed the excitation gate ({} non-finite, {} not in penetration or below {} N of unit force, {} stuck)",
            a.log.data.display(),
            e.samples_non_finite,
            e.samples_not_excited,
            est.options().min_unit_force_n,
            e.samples_stuck
        );
    }
    let medium = base.medium().with_delta_deg(e.delta_deg)?;
    let fitted = TerzaghiModel::new(*base.plate(), medium, FittingWidth::new(e.b_k, e.a)?);
    let (improved, conventional, scored) = score(&base, &fitted, &samples, a.all_regimes);
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
    if let Some(path) = &a.trace {
        write_trace_csv(path, &trace)?;
    }
    if let Some(path) = &a.trace_plot {
        let svg = plot_trace_svg(&trace)?;
        write_atomically(path, |w| Ok(w.write_all(svg.as_bytes())?))?;
    }
    if a.json {
        return print_out(&(serde_json::to_string_pretty(&report)? + "\n"));
    }
    let t0 = samples.first().and_then(|s| s.t_s).unwrap_or(0.0);
    let mut s = format!(
        "online estimate after {} samples ({} used, {} non-finite, {} outside the gate, {} stuck)\n",
        samples.len(),
        e.samples_used,
        e.samples_non_finite,
        e.samples_not_excited,
        e.samples_stuck
    );
    s += &format!(
        "b_k = {:.4} +- {:.4}   a = {:.4} +- {:.4}   delta = {:.2} deg{}\n",
        e.b_k,
        e.std_b_k,
        e.a,
        e.std_a,
        e.delta_deg,
        if a.fit_delta {
            format!(" +- {:.2}", e.std_delta_deg)
        } else {
            " (fixed)".into()
        }
    );
    s += &match converged_at_s {
        Some(t) => format!(
            "converged at t = {t:.3} s ({:.3} s after the first sample); converged now: {}\n",
            t - t0,
            e.converged
        ),
        None => "not converged\n".to_string(),
    };
    for c in est.changes() {
        s += &format!(
            "change of the medium detected at t = {:.3} s (estimate before: b_k {:.4}, a {:.4})\n",
            c.t_s.unwrap_or(f64::NAN),
            c.b_k_before,
            c.a_before
        );
    }
    s += &format!("\nfinal model on the {scored} scored samples:\n");
    s += &format!(
        "{:<13} {:>8} {:>8} {:>8} {:>8} {:>12} {:>12}\n",
        "model", "psi_drag", "psi_lift", "r2_drag", "r2_lift", "rmse_drag_n", "rmse_lift_n"
    );
    for (name, g) in [
        ("improved", &report.improved),
        ("conventional", &report.conventional),
    ] {
        s += &format!(
            "{:<13} {:>8.4} {:>8.4} {:>8.4} {:>8.4} {:>12.4} {:>12.4}\n",
            name, g.psi_drag, g.psi_lift, g.r2_drag, g.r2_lift, g.rmse_drag_n, g.rmse_lift_n
        );
    }
    print_out(&s)
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

fn write_trace_csv(path: &Path, trace: &[TracePoint]) -> Result<()> {
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
