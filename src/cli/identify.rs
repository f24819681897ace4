//! `terzaghi identify`: batch or online identification of a log, with a trace and its plot
//! (the online replay is [`terzaghi::session::identify`]).

use super::log_source::LogArgs;
use super::print_out;
use anyhow::{Context as _, Result, bail};
use clap::Args;
use std::io::Write;
use std::path::PathBuf;
use terzaghi::ident::online::Forgetting;
use terzaghi::ident::{BatchOptions, OnlineOptions, fit_batch};
use terzaghi::session::files::write_atomically;
use terzaghi::session::identify::{identify_online, plot_trace_svg, write_trace_csv};

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
    let inputs = a.log.inputs();
    terzaghi::session::files::refuse_stdout_over_input(&inputs)?;
    for out in a.trace.iter().chain(&a.trace_plot) {
        terzaghi::session::files::refuse_output_over_input(out, &inputs)?;
    }
    let (base, samples) = a.log.load()?;
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
    let found = identify_online(&base, samples, opts, a.all_regimes)
        .with_context(|| a.log.data.display().to_string())?;
    if found.times_are_sample_numbers {
        eprintln!(
            "note: {} has no t_s column: times are sample numbers",
            a.log.data.display()
        );
    }
    let (report, trace) = (&found.report, &found.trace);
    if let Some(path) = &a.trace {
        write_trace_csv(path, trace)?;
    }
    if let Some(path) = &a.trace_plot {
        let svg = plot_trace_svg(trace)?;
        write_atomically(path, |w| Ok(w.write_all(svg.as_bytes())?))?;
    }
    if a.json {
        return print_out(&(serde_json::to_string_pretty(report)? + "\n"));
    }
    let t0 = found.t0_s;
    let e = report;
    let mut s = format!(
        "online estimate after {} samples ({} used, {} non-finite, {} outside the gate, {} stuck)\n",
        found.samples, e.samples_used, e.samples_non_finite, e.samples_not_excited, e.samples_stuck
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
    s += &match report.converged_at_s {
        Some(t) => format!(
            "converged at t = {t:.3} s ({:.3} s after the first sample); converged now: {}\n",
            t - t0,
            e.converged
        ),
        None => "not converged\n".to_string(),
    };
    for c in &report.changes {
        s += &format!(
            "change of the medium detected at t = {:.3} s (estimate before: b_k {:.4}, a {:.4})\n",
            c.t_s.unwrap_or(f64::NAN),
            c.b_k_before,
            c.a_before
        );
    }
    s += &format!("\nfinal model on the {} scored samples:\n", report.samples);
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
