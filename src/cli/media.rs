//! `terzaghi media`: the presets and where their values come from.

use super::print_out;
use anyhow::Result;
use clap::Args;
use terzaghi::model::medium::presets;
use terzaghi::session::plate_test::MediumFile;

#[derive(Debug, Args)]
pub struct MediaArgs {
    /// Medium files (written by `terzaghi calibrate`) to list after the presets, with where
    /// each value came from.
    #[arg(value_name = "MEDIUM_FILE")]
    pub files: Vec<std::path::PathBuf>,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

pub fn run(a: MediaArgs) -> Result<()> {
    let files = a
        .files
        .iter()
        .map(|f| MediumFile::read(f))
        .collect::<Result<Vec<_>>>()?;
    if a.json {
        let v = serde_json::json!({ "presets": presets(), "files": files });
        return print_out(&(serde_json::to_string_pretty(&v)? + "\n"));
    }
    let mut s = format!(
        "{:<17} {:>10} {:>7} {:>9} {:>14}  {:<15} {}\n",
        "name", "lambda", "phi", "delta", "b_k / a", "soil values", "description"
    );
    s += &format!(
        "{:<17} {:>10} {:>7} {:>9} {:>14}\n",
        "", "N/m^3", "deg", "deg", "(Eq. 11)"
    );
    for p in presets() {
        let fit = match p.fit {
            Some((b_k, a)) => format!("{b_k} / {a}"),
            None => "by width".to_string(),
        };
        let prov = serde_json::to_value(p.soil_values)?
            .as_str()
            .unwrap_or("")
            .to_string();
        s += &format!(
            "{:<17} {:>10.1} {:>7.1} {:>9.1} {:>14}  {:<15} {}\n",
            p.name, p.unit_weight_n_m3, p.phi_deg, p.delta_deg, fit, prov, p.description
        );
    }
    s += "\nNotes:\n";
    for p in presets() {
        s += &format!("  {}: {}\n", p.name, p.note);
        for (w, b_k, a) in p.fits_by_width {
            s += &format!("      width {:.3} m: b_k {b_k}, a {a}\n", w);
        }
    }
    for (f, m) in a.files.iter().zip(&files) {
        s += &format!(
            "\n{} ({}): plate-sinkage law {}, unit weight {:.0} N/m^3\n",
            m.name,
            f.display(),
            m.law.name(),
            m.unit_weight_n_m3
        );
        for (name, v) in &m.params {
            let sd = m.std_dev.get(name).copied().unwrap_or(f64::NAN);
            s += &format!("  {name:<12} {v:>14.6} +- {sd:.6}\n");
        }
        s += &format!(
            "  serves:      {}\n",
            if m.law == terzaghi::model::sinkage::SinkageLaw::RftDepthPower || m.rft_shape.is_some()
            {
                "model sinkage (a plate pushed straight down) and model rft (any leg shape: RFT's stress in depth)"
            } else {
                "model sinkage (a plate pushed straight down); model rft takes the rft_depth_power law only"
            }
        );
        s += &format!("  RFT's shape: {}\n", m.rft_shape_text());
        if let Some(b) = &m.sheared_bearing {
            s += &format!("  sheared:     {}\n", b.text());
        }
        if let Some(shape) = &m.rft_shape {
            s += &format!(
                "  RFT's coefficients (N/cm^3 at 1 cm, +- one standard deviation): {}\n",
                terzaghi::medium_file::RFT_COEFFICIENT_NAMES
                    .iter()
                    .map(|n| format!(
                        "{n} {:.4} +- {:.4}",
                        shape
                            .coefficients_n_cm3
                            .get(*n)
                            .copied()
                            .unwrap_or(f64::NAN),
                        shape.std_dev_n_cm3.get(*n).copied().unwrap_or(f64::NAN)
                    ))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
            s += &format!(
                "  RFT's depth exponent {:.3} +- {:.3}; R^2 fx {:.3}, fz {:.3} over {} intrusion tests\n",
                shape.depth_exponent,
                shape.std_depth_exponent,
                shape.r2_fx,
                shape.r2_fz,
                shape.tests.len()
            );
        }
        s += &format!("  fitted by:   {}\n", m.source.command);
        s += &format!("  unit weight: {}\n", m.source.unit_weight);
        s += &format!(
            "  depth:       {}; R^2 over every test {:.3}\n",
            m.source.depth_column, m.source.r2
        );
        for t in &m.source.tests {
            s += &format!(
                "  test {} ({}, {} loaded rows): R^2 {:.3}, RMSE {:.2} N\n",
                t.file, t.plate, t.loaded_rows, t.r2, t.rmse_n
            );
        }
    }
    print_out(&s)
}
