//! `terzaghi calibrate`: a medium's plate-sinkage laws fitted to plate-sinkage tests, a medium
//! file written, and (with --cross-validate) each plate size predicted from the others (the
//! work is [`crate::session::plate_test`]).

use super::print_out;
use crate::model::sinkage::{PlateShape, RegimeOptions, SinkageLaw};
use crate::session::plate_test::{
    DepthColumn, HeldOut, MediumFile, PlateTest, STRESS_DEPTH_M, by_size, calibrate,
    cross_validate, read_test, unit_weight_of,
};
use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use std::path::PathBuf;

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum DepthArg {
    /// depth_comp_m where the run has it: the testbed's compliance taken out.
    Compensated,
    /// depth_m, the testbed's position as logged.
    AsLogged,
}

#[derive(Debug, Args)]
pub struct CalibrateArgs {
    /// Plate-sinkage tests: CSV files in the shared runs' layout (time_s, depth_m, fz_n, ...,
    /// with the JSON of the same name beside each), or plain logs of t_s, depth_m, force_n
    /// (with the plate's size given by flag).
    #[arg(required = true, value_name = "TEST")]
    pub tests: Vec<PathBuf>,
    /// The plate of plain logs: a disc of this diameter (m).
    #[arg(long, value_name = "M", allow_negative_numbers = true, conflicts_with_all = ["plate_width_m", "plate_length_m"])]
    pub plate_diameter_m: Option<f64>,
    /// The plate of plain logs: a rectangle of this width (m), with --plate-length-m.
    #[arg(
        long,
        value_name = "M",
        allow_negative_numbers = true,
        requires = "plate_length_m"
    )]
    pub plate_width_m: Option<f64>,
    /// The plate of plain logs: a rectangle of this length (m), with --plate-width-m.
    #[arg(
        long,
        value_name = "M",
        allow_negative_numbers = true,
        requires = "plate_width_m"
    )]
    pub plate_length_m: Option<f64>,
    /// Which depth of a shared run to use.
    #[arg(long, value_enum, default_value = "as-logged")]
    pub depth: DepthArg,
    /// The medium's unit weight (N/m^3) (default: the tests' bulk density times g).
    #[arg(long, value_name = "N_M3")]
    pub unit_weight_n_m3: Option<f64>,
    /// The law written to the medium file (default: the one with the best R^2).
    #[arg(long, value_name = "LAW", value_parser = law_names())]
    pub law: Option<String>,
    /// Write the medium file here (YAML).
    #[arg(short, long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// The medium's name in the file.
    #[arg(long, default_value = "calibrated")]
    pub name: String,
    /// Predict each plate size from the laws calibrated on the other sizes, and print the
    /// table (R^2 and RMSE per test, depth exponent and change of stress with size).
    #[arg(long)]
    pub cross_validate: bool,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

fn law_names() -> clap::builder::PossibleValuesParser {
    clap::builder::PossibleValuesParser::new(SinkageLaw::ALL.map(|l| l.name()))
}

pub fn read_tests(a: &CalibrateArgs) -> Result<Vec<PlateTest>> {
    let plate = match (a.plate_diameter_m, a.plate_width_m, a.plate_length_m) {
        (Some(d), _, _) => Some(PlateShape::disc(d)?),
        (None, Some(w), Some(l)) => Some(PlateShape::rectangle(w, l)?),
        _ => None,
    };
    let depth = match a.depth {
        DepthArg::Compensated => DepthColumn::Compensated,
        DepthArg::AsLogged => DepthColumn::AsLogged,
    };
    a.tests
        .iter()
        .map(|f| read_test(f, plate, depth, &RegimeOptions::default()))
        .collect()
}

pub fn run(a: CalibrateArgs) -> Result<()> {
    let inputs: Vec<&std::path::Path> = a.tests.iter().map(|p| p.as_path()).collect();
    crate::session::files::refuse_stdout_over_input(&inputs)?;
    if let Some(out) = &a.out {
        crate::session::files::refuse_output_over_input(out, &inputs)?;
    }
    if let Some(w) = a.unit_weight_n_m3
        && !(w.is_finite() && w > 0.0)
    {
        bail!("--unit-weight-n-m3 must be a number > 0, got {w}");
    }
    let tests = read_tests(&a)?;
    let (unit_weight, unit_weight_source) = unit_weight_of(&tests, a.unit_weight_n_m3)?;
    let (fits, failed) = calibrate(&tests, unit_weight);
    let chosen = match &a.law {
        Some(name) => fits
            .iter()
            .find(|f| f.model.law.name() == name)
            .with_context(|| {
                let why = failed
                    .iter()
                    .find(|(l, _)| l.name() == name)
                    .map(|(_, e)| e.clone())
                    .unwrap_or_default();
                format!("{name} could not be fitted: {why}")
            })?,
        None => fits.first().context(
            "no law could be fitted to these tests: ".to_string()
                + &failed
                    .iter()
                    .map(|(_, e)| e.clone())
                    .collect::<Vec<_>>()
                    .join("; "),
        )?,
    };
    let held = if a.cross_validate {
        Some(cross_validate(&tests, unit_weight)?)
    } else {
        None
    };
    let command = std::iter::once("terzaghi".to_string())
        .chain(std::env::args().skip(1))
        .collect::<Vec<_>>()
        .join(" ");
    let files: Vec<PathBuf> = tests.iter().map(|t| t.file.clone()).collect();
    let depth_column = tests.first().map_or("depth_m", |t| t.depth_column);
    let medium = MediumFile::of_fit(
        &a.name,
        chosen,
        &files,
        depth_column,
        &command,
        &unit_weight_source,
    );
    if let Some(out) = &a.out {
        crate::session::files::write_text(out, &medium.to_yaml()?)
            .context(crate::session::files::cannot_write(out))?;
    }
    if a.json {
        let v = serde_json::json!({
            "tests": tests.iter().map(|t| serde_json::json!({
                "file": t.file, "plate": t.plate.label(), "depth_column": t.depth_column,
                "rows": t.rows.len(), "loaded_rows": t.loaded().rows.len(),
                "skipped_rows": t.skipped_rows,
            })).collect::<Vec<_>>(),
            "unit_weight_n_m3": unit_weight,
            "fits": fits,
            "not_fitted": failed.iter().map(|(l, e)| serde_json::json!({"law": l.name(), "error": e})).collect::<Vec<_>>(),
            "medium": medium,
            "cross_validation": held,
            "cross_validation_by_size": held.as_deref().map(by_size),
        });
        return print_out(&(serde_json::to_string_pretty(&v)? + "\n"));
    }
    let mut s = String::new();
    s += &format!(
        "{} tests, depth from {}, unit weight {:.0} N/m^3 ({})\n",
        tests.len(),
        tests.first().map(|t| t.depth_column).unwrap_or("depth_m"),
        unit_weight,
        unit_weight_source
    );
    for t in &tests {
        s += &format!(
            "  {:<28} {:<12} {:>4} rows, {:>4} loaded, deepest {:>5.1} mm{}\n",
            t.name(),
            t.plate.label(),
            t.rows.len(),
            t.loaded().rows.len(),
            t.deepest_m() * 1e3,
            if t.skipped_rows > 0 {
                format!(", {} skipped (not finite)", t.skipped_rows)
            } else {
                String::new()
            }
        );
    }
    s += "\nEvery law fitted to all loaded rows (force, least squares), best first\n";
    s += &format!(
        "{:<18} {:>7} {:>9}  parameters (+- one standard deviation)\n",
        "law", "R^2", "RMSE N"
    );
    for f in &fits {
        let params = f
            .model
            .law
            .param_names()
            .iter()
            .zip(f.model.params.iter().zip(&f.std_dev))
            .map(|(n, (v, sd))| {
                if *sd == 0.0 && f.width_held {
                    format!("{n} {} (held: one plate size)", sig(*v))
                } else {
                    format!("{n} {} +- {}", sig(*v), sig(*sd))
                }
            })
            .collect::<Vec<_>>()
            .join(", ");
        s += &format!(
            "{:<18} {:>7.3} {:>9.2}  {params}\n",
            f.model.law.name(),
            f.r2,
            f.rmse_n
        );
    }
    for (l, e) in &failed {
        s += &format!("{:<18} not fitted: {e}\n", l.name());
    }
    s += &format!(
        "\nPer test under {} (R^2, RMSE N)\n",
        chosen.model.law.name()
    );
    for t in &chosen.tests {
        s += &format!(
            "  {:<28} {:<12} R^2 {:>6.3}  RMSE {:>6.2} N  peak {:>6.1} N\n",
            t.name, t.plate, t.r2, t.rmse_n, t.peak_force_n
        );
    }
    if let Some(held) = &held {
        s += &render_cross_validation(held);
    }
    if let Some(out) = &a.out {
        s += &format!(
            "\nwrote {} (law {})\n",
            out.display(),
            chosen.model.law.name()
        );
    }
    print_out(&s)
}

fn sig(v: f64) -> String {
    if v == 0.0 || (1e-2..1e5).contains(&v.abs()) {
        format!("{v:.4}")
    } else {
        format!("{v:.4e}")
    }
}

/// The cross-validation table: each test predicted by each law calibrated on the other sizes.
pub fn render_cross_validation(held: &[HeldOut]) -> String {
    let mut s = format!(
        "\nEach plate size predicted from the laws calibrated on the other sizes (nothing fitted to it)\n\
         exponent: slope of ln F on ln z over the loaded rows deeper than 3 mm; stress ratio: the\n\
         test's stress at {:.0} mm over the calibration tests' mean\n",
        STRESS_DEPTH_M * 1e3
    );
    s += &format!(
        "{:<18} {:<28} {:>7} {:>8} {:>9} {:>9} {:>9} {:>9}\n",
        "law", "test", "R^2", "RMSE N", "exp meas", "exp pred", "str meas", "str pred"
    );
    let mut last = None;
    for h in held {
        if last.is_some_and(|l| l != h.law) {
            s.push('\n');
        }
        last = Some(h.law);
        s += &format!(
            "{:<18} {:<28} {:>7.3} {:>8.2} {:>9.3} {:>9.3} {:>9.3} {:>9.3}\n",
            h.law.name(),
            h.fit.name,
            h.fit.r2,
            h.fit.rmse_n,
            h.measured_exponent,
            h.predicted_exponent,
            h.measured_stress_ratio,
            h.predicted_stress_ratio
        );
    }
    s += "\nThe same, per plate size (means over its tests)\n";
    s += &format!(
        "{:<18} {:<12} {:>5} {:>9} {:>9} {:>9} {:>9} {:>9}\n",
        "law", "plate", "tests", "worst R^2", "exp meas", "exp pred", "str meas", "str pred"
    );
    for z in by_size(held) {
        s += &format!(
            "{:<18} {:<12} {:>5} {:>9.3} {:>9.3} {:>9.3} {:>9.3} {:>9.3}\n",
            z.law.name(),
            z.plate,
            z.tests,
            z.worst_r2,
            z.measured_exponent,
            z.predicted_exponent,
            z.measured_stress_ratio,
            z.predicted_stress_ratio
        );
    }
    s
}
