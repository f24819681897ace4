//! `terzaghi predict`: one row per attack angle.

use super::{MediumArgs, PlateArgs, WidthArgs, print_out};
use crate::model::{ForceModel, Prediction};
use anyhow::{Result, bail};
use clap::{Args, ValueEnum};
use serde::Serialize;

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ModelKind {
    /// Improved Terzaghi model with the fitting width b_e = b_k b a^(-beta).
    Improved,
    /// Conventional Terzaghi model (b_e = b).
    Conventional,
    /// Resistive force theory (Li, Zhang & Goldman 2013).
    Rft,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Format {
    Csv,
    Json,
}

#[derive(Debug, Args)]
pub struct PredictArgs {
    /// Which model to evaluate.
    #[arg(long, value_enum, default_value = "improved")]
    pub model: ModelKind,
    #[command(flatten)]
    pub plate: PlateArgs,
    #[command(flatten)]
    pub medium: MediumArgs,
    #[command(flatten)]
    pub width: WidthArgs,
    /// RFT: number of elements over the submerged length.
    #[arg(long, value_name = "N", default_value_t = 100)]
    pub rft_elements: usize,
    /// RFT coefficients: poppy_lp, poppy_cp, poppy_lp_grid (measured) or generic (needs
    /// --rft-zeta). Default: the medium preset's, if it has one.
    #[arg(long, value_name = "SET")]
    pub rft_coeffs: Option<String>,
    /// RFT: the medium's scale factor zeta for the generic coefficients (N/cm^3).
    #[arg(long, value_name = "N_CM3", allow_negative_numbers = true)]
    pub rft_zeta: Option<f64>,
    /// Attack angles in degrees: FROM:TO:STEP (both ends included) or a single angle.
    #[arg(long, value_name = "FROM:TO:STEP", allow_hyphen_values = true)]
    pub beta_deg: String,
    /// Output format.
    #[arg(long, value_enum, default_value = "csv")]
    pub format: Format,
}

/// Most rows one call prints.
const MAX_ROWS: usize = 1_000_000;

/// Parses `FROM:TO:STEP` or a single angle into the list of angles (degrees).
pub fn parse_range(text: &str) -> Result<Vec<f64>> {
    let parts: Vec<&str> = text.split(':').collect();
    let num = |s: &str| -> Result<f64> {
        match s.trim().parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => bail!("--beta-deg {text:?}: {s:?} is not a finite number"),
        }
    };
    match parts.as_slice() {
        [one] => Ok(vec![num(one)?]),
        [from, to, step] => {
            let (from, to, step) = (num(from)?, num(to)?, num(step)?);
            if step == 0.0 || (to - from) * step < 0.0 {
                bail!("--beta-deg {text:?}: STEP must be non-zero and lead from FROM to TO");
            }
            let n = ((to - from) / step + 1e-9).floor() + 1.0;
            if n > MAX_ROWS as f64 {
                bail!("--beta-deg {text:?} gives {n} angles; at most {MAX_ROWS}");
            }
            // Rounded to 1e-9 deg so that 0.1-steps print as 0.3, not 0.30000000000000004.
            Ok((0..n as usize)
                .map(|i| ((from + i as f64 * step) * 1e9).round() / 1e9)
                .collect())
        }
        _ => bail!("--beta-deg {text:?}: expected FROM:TO:STEP or a single angle"),
    }
}

#[derive(Serialize)]
struct Row {
    beta_deg: f64,
    submerged_m: f64,
    depth_m: f64,
    drag_n: f64,
    lift_n: f64,
    hip_torque_nm: f64,
    regime: &'static str,
}

pub fn build_model(a: &PredictArgs) -> Result<ForceModel> {
    crate::model_spec::ModelSpec {
        kind: match a.model {
            ModelKind::Improved => crate::model_spec::ModelKind::Improved,
            ModelKind::Conventional => crate::model_spec::ModelKind::Conventional,
            ModelKind::Rft => crate::model_spec::ModelKind::Rft,
        },
        length_m: a.plate.length_m,
        width_m: a.plate.width_m,
        hip_height_m: a.plate.hip_height_m,
        medium: a.medium.spec(),
        b_k: a.width.b_k,
        a: a.width.a,
        rft_coeffs: a.rft_coeffs.clone(),
        rft_zeta: a.rft_zeta,
        rft_elements: a.rft_elements,
        shape: crate::model_spec::LegShape::Plate,
    }
    .build()
}

pub fn run(a: PredictArgs) -> Result<()> {
    let betas = parse_range(&a.beta_deg)?;
    let model = build_model(&a)?;
    let rows: Vec<Row> = betas
        .iter()
        .map(|&deg| {
            let p: Prediction = model.predict(deg.to_radians())?;
            Ok(Row {
                beta_deg: deg,
                submerged_m: p.submerged_m,
                depth_m: p.depth_m,
                drag_n: p.drag_n,
                lift_n: p.lift_n,
                hip_torque_nm: p.hip_torque_nm,
                regime: p.regime.as_str(),
            })
        })
        .collect::<Result<_>>()?;
    let text = match a.format {
        Format::Json => serde_json::to_string_pretty(&rows)? + "\n",
        Format::Csv => {
            let mut s =
                String::from("beta_deg,submerged_m,depth_m,drag_n,lift_n,hip_torque_nm,regime\n");
            for r in &rows {
                s += &format!(
                    "{},{:.6},{:.6},{:.6},{:.6},{:.6},{}\n",
                    r.beta_deg,
                    r.submerged_m,
                    r.depth_m,
                    r.drag_n,
                    r.lift_n,
                    r.hip_torque_nm,
                    r.regime
                );
            }
            s
        }
    };
    print_out(&text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_include_both_ends_and_reject_nonsense() {
        assert_eq!(
            parse_range("40:90:10").unwrap(),
            vec![40.0, 50.0, 60.0, 70.0, 80.0, 90.0]
        );
        assert_eq!(parse_range("0:0.3:0.1").unwrap(), vec![0.0, 0.1, 0.2, 0.3]);
        assert_eq!(parse_range("90:80:-5").unwrap(), vec![90.0, 85.0, 80.0]);
        assert_eq!(parse_range("-10").unwrap(), vec![-10.0]);
        for bad in [
            "",
            "a:b:c",
            "0:10:0",
            "0:10:-1",
            "0:1e9:1e-6",
            "nan",
            "1:2",
            "0:inf:1",
        ] {
            assert!(parse_range(bad).is_err(), "{bad}");
        }
    }
}
