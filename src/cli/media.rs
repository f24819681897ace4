//! `terzaghi media`: the presets and where their values come from.

use super::print_out;
use crate::model::medium::presets;
use anyhow::Result;
use clap::Args;

#[derive(Debug, Args)]
pub struct MediaArgs {
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

pub fn run(a: MediaArgs) -> Result<()> {
    if a.json {
        return print_out(&(serde_json::to_string_pretty(presets())? + "\n"));
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
    print_out(&s)
}
