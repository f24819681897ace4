//! `terzaghi fit`: batch identification of b_k, a (and delta) from a CSV log or a recorded
//! session.

use super::log_source::LogArgs;
use super::print_out;
use crate::ident::{BatchFit, BatchOptions, GoodnessOfFit, fit_batch};
use anyhow::Result;
use clap::Args;

#[derive(Debug, Args)]
pub struct FitArgs {
    #[command(flatten)]
    pub log: LogArgs,
    /// Fit the plate-medium friction angle delta as well.
    #[arg(long)]
    pub fit_delta: bool,
    /// Use every submerged sample, not only penetration (beta <= 90 deg).
    #[arg(long)]
    pub all_regimes: bool,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn run(a: FitArgs) -> Result<()> {
    crate::session::files::refuse_stdout_over_input(&a.log.inputs())?;
    let (model, samples) = a.log.load()?;
    let opts = BatchOptions {
        fit_delta: a.fit_delta,
        all_regimes: a.all_regimes,
        ..Default::default()
    };
    let fit = fit_batch(&model, &samples, &opts)?;
    if a.json {
        return print_out(&(serde_json::to_string_pretty(&fit)? + "\n"));
    }
    print_out(&render(&fit, a.fit_delta))
}

pub fn render(fit: &BatchFit, fit_delta: bool) -> String {
    let mut s = format!(
        "samples used: {} (skipped: {} non-finite, {} outside the fitted regimes)\n",
        fit.samples, fit.skipped_non_finite, fit.skipped_regime
    );
    s += &format!(
        "b_k = {:.4}   a = {:.4}   delta = {:.2} deg{}\n\n",
        fit.b_k,
        fit.a,
        fit.delta_deg,
        if fit_delta { " (fitted)" } else { " (fixed)" }
    );
    s += &format!(
        "{:<13} {:>8} {:>8} {:>8} {:>8} {:>12} {:>12}\n",
        "model", "psi_drag", "psi_lift", "r2_drag", "r2_lift", "rmse_drag_n", "rmse_lift_n"
    );
    let row = |name: &str, g: &GoodnessOfFit| {
        format!(
            "{:<13} {:>8.4} {:>8.4} {:>8.4} {:>8.4} {:>12.4} {:>12.4}\n",
            name, g.psi_drag, g.psi_lift, g.r2_drag, g.r2_lift, g.rmse_drag_n, g.rmse_lift_n
        )
    };
    s += &row("improved", &fit.improved);
    s += &row("conventional", &fit.conventional);
    s
}
