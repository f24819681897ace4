//! `terzaghi fit`: batch identification of b_k, a (and delta) from a CSV log.

use super::{MediumArgs, PlateArgs, print_out, terzaghi_model};
use crate::dataset::read_samples_csv;
use crate::ident::{BatchFit, BatchOptions, GoodnessOfFit, fit_batch};
use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct FitArgs {
    /// CSV with a header naming at least beta_rad,drag_n,lift_n (and optionally t_s).
    pub data: PathBuf,
    #[command(flatten)]
    pub plate: PlateArgs,
    #[command(flatten)]
    pub medium: MediumArgs,
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
    let plate = a.plate.plate()?;
    let chosen = a.medium.medium()?;
    let samples = read_samples_csv(&a.data)?;
    let model = terzaghi_model(plate, &chosen, None);
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
