//! `terzaghi fit`: batch identification of b_k, a (and delta) from a CSV log or a recorded
//! session.

use super::log_source::LogArgs;
use super::print_out;
use anyhow::{Result, bail};
use clap::Args;
use terzaghi::ident::{BatchFit, BatchOptions, GoodnessOfFit, fit_batch};

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
    /// DATA is a plate-sinkage test (a shared run's CSV with its JSON, or a plain log of t_s,
    /// depth_m, force_n): fit this medium file's law to it, its scale with the surface's level
    /// and the sensor's bias (written by terzaghi calibrate).
    #[arg(long, value_name = "FILE")]
    pub medium_file: Option<std::path::PathBuf>,
    /// A plain plate-sinkage log's plate: a disc of this diameter (m), with --medium-file.
    #[arg(
        long,
        value_name = "M",
        requires = "medium_file",
        allow_negative_numbers = true
    )]
    pub plate_diameter_m: Option<f64>,
}

pub fn run(a: FitArgs) -> Result<()> {
    if let Some(medium_file) = &a.medium_file {
        return fit_test(&a, medium_file);
    }
    terzaghi::session::files::refuse_stdout_over_input(&a.log.inputs())?;
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

/// `fit --medium-file`: the medium file's law fitted to a plate-sinkage test (its scale, the
/// surface's level and the sensor's bias), as the diagnosis of a test fits it.
fn fit_test(a: &FitArgs, medium_file: &std::path::Path) -> Result<()> {
    use terzaghi::model::sinkage::{PlateShape, RegimeOptions};
    use terzaghi::session::plate_test::{DepthColumn, diagnose_test, read_test};
    let l = &a.log;
    if l.plate.any() || l.medium.medium.is_some() || l.medium.unit_weight_n_m3.is_some() {
        bail!(
            "--medium-file fits a plate-sinkage test: its plate comes from the run's JSON or --plate-diameter-m, its medium from the file, not from --length-m, --width-m, --hip-height-m or --medium"
        );
    }
    if l.leg.is_some() || l.params_file.is_some() || a.fit_delta || a.all_regimes {
        bail!(
            "--medium-file fits a plate-sinkage test, which has no leg, node parameters, delta or regimes to choose"
        );
    }
    terzaghi::session::files::refuse_stdout_over_input(&[l.data.as_path(), medium_file])?;
    let medium = terzaghi::medium_file::MediumFile::read(medium_file)?;
    let plate = a.plate_diameter_m.map(PlateShape::disc).transpose()?;
    let test = read_test(
        &l.data,
        plate,
        DepthColumn::AsLogged,
        &RegimeOptions::default(),
    )?;
    let d = diagnose_test(&test, &medium)?;
    let g = &d.gap;
    if a.json {
        return print_out(
            &(serde_json::to_string_pretty(&serde_json::json!({
                "file": d.file,
                "plate": d.plate,
                "medium": d.medium,
                "rows_used": g.rows_used,
                "scale": g.scale,
                "surface_above_depth_zero_m": g.depth_shift_m,
                "bias_n": g.bias_n,
                "r2_as_calibrated": g.r2_as_calibrated,
                "rmse_as_calibrated_n": g.rmse_as_calibrated_n,
                "r2_fitted": g.r2_corrected,
                "rmse_fitted_n": g.rmse_corrected_n,
            }))? + "\n"),
        );
    }
    print_out(&format!(
        "{} ({}) against medium {}: {} rows used (loading, and above the surface before it)\n\
         scale = {:.4} +- {:.4} of the law   surface {:+.2} +- {:.2} mm above the depth's zero   bias {:+.3} +- {:.3} N\n\
         as calibrated: R^2 {:.4}, RMSE {:.3} N   fitted: R^2 {:.4}, RMSE {:.3} N\n",
        d.file.display(),
        d.plate,
        d.medium,
        g.rows_used,
        g.scale.value,
        g.scale.std_dev,
        g.depth_shift_m.value * 1e3,
        g.depth_shift_m.std_dev * 1e3,
        g.bias_n.value,
        g.bias_n.std_dev,
        g.r2_as_calibrated,
        g.rmse_as_calibrated_n,
        g.r2_corrected,
        g.rmse_corrected_n,
    ))
}
