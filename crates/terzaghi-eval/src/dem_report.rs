//! `terzaghi-eval dem-report`: the models against a DEM campaign.

use crate::fidelity::{CampaignReport, Change, campaign_report};
use anyhow::{Context, Result};
use clap::Args;
use std::path::PathBuf;
use terzaghi::dem::{default_baseline, read_campaign};
use terzaghi::ident::GoodnessOfFit;
use terzaghi::session::files::print_out;

#[derive(Debug, Args)]
pub struct DemReportArgs {
    /// The campaign's directory (campaign.json, runs/, rft_grid.csv).
    pub campaign: PathBuf,
    /// The baseline run the checks and variations are compared with (default: the scene's
    /// plate width and hip height, qs_bWWW_hHHH).
    #[arg(long, value_name = "RUN")]
    pub baseline: Option<String>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn report(a: DemReportArgs) -> Result<()> {
    let c = read_campaign(&a.campaign)?;
    let baseline = match &a.baseline {
        Some(b) => b.clone(),
        None => default_baseline(&c)
            .with_context(|| format!("{}: pass --baseline", a.campaign.display()))?,
    };
    let r = campaign_report(&c, &baseline)?;
    if a.json {
        return print_out(&(serde_json::to_string_pretty(&r)? + "\n"));
    }
    // The speed law as a leg calibrated by the campaign's grid fits it (rft_grid_file).
    let speed = match (
        &c.rft_entry,
        terzaghi::model::RftFit::fit_to_points(&c.rft_grid),
    ) {
        (Some(t), Some(grid)) => Some(
            t.fit(&terzaghi::model::RftCoefficients::Fit(grid))
                .map_err(|e| anyhow::anyhow!("{}/rft_entry.csv: {e}", a.campaign.display()))?,
        ),
        _ => None,
    };
    print_out(&render(&c.manifest, &r, speed.as_ref()))
}

fn pct(x: f64) -> String {
    format!("{:+.1} %", 100.0 * x)
}

fn render_change(s: &mut String, ch: &Change, limit: Option<f64>) {
    let worst = ch.mean_drag_change.abs().max(ch.mean_lift_change.abs());
    let verdict = match limit {
        Some(l) if worst < l => format!("within {:.0} %", 100.0 * l),
        Some(l) => format!(
            "MISSES {:.0} % by {:.1} points",
            100.0 * l,
            100.0 * (worst - l)
        ),
        None => String::new(),
    };
    *s += &format!(
        "{:<20} {:>9} {:>9} {:>9} {:>9} {:>10}  {}\n",
        ch.run,
        pct(ch.mean_drag_change),
        pct(ch.mean_lift_change),
        format!("{:.1} %", 100.0 * ch.shape_drag_change),
        format!("{:.1} %", 100.0 * ch.shape_lift_change),
        pct(ch.peak_drag_change),
        verdict
    );
}

fn gof(g: &GoodnessOfFit) -> String {
    format!(
        "{:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>7.3}",
        g.psi_drag, g.psi_lift, g.r2_drag, g.r2_lift, g.rmse_drag_n, g.rmse_lift_n
    )
}

fn render(
    m: &serde_json::Value,
    r: &CampaignReport,
    speed: Option<&terzaghi::model::RftSpeedFit>,
) -> String {
    let mut s = format!(
        "engine: {}\ncampaign: {} runs, {:.1} min ({})\n",
        m["engine"].as_str().unwrap_or("?"),
        m["runs"]
            .as_array()
            .map_or(0, |v| v.len())
            .saturating_sub(m["diagnosis"]["runs"].as_array().map_or(0, |v| v.len())),
        m["seconds"].as_f64().unwrap_or(0.0) / 60.0,
        m["command"].as_str().unwrap_or("")
    );
    let dx = &m["diagnosis"];
    if let Some(runs) = dx["runs"].as_array() {
        s += &format!(
            "diagnosis part: {} runs on beds levelled from {} more fill seeds, {:.1} min ({})\n",
            runs.len(),
            dx["seeds"]
                .as_array()
                .map_or(0, |v| v.len().saturating_sub(1)),
            dx["seconds"].as_f64().unwrap_or(0.0) / 60.0,
            dx["command"].as_str().unwrap_or("")
        );
        // Runs added or run again later, each batch with the command that made it and why.
        let added = dx["added"].as_array().map_or(&[][..], |v| v.as_slice());
        if !added.is_empty() {
            s.pop();
            s += "; later:\n";
            for a in added {
                s += &format!(
                    "  {} runs, {:.1} min ({}){}\n",
                    a["runs"].as_array().map_or(0, |v| v.len()),
                    a["seconds"].as_f64().unwrap_or(0.0) / 60.0,
                    a["command"].as_str().unwrap_or(""),
                    a["note"]
                        .as_str()
                        .map_or(String::new(), |n| format!(": {n}"))
                );
            }
        }
    }
    // The RFT calibration, where it was run again on its own.
    let rft = &m["rft"];
    if let Some(n) = rft["intrusions"].as_u64() {
        let bed = &m["beds"]["bed_rft"];
        s += &format!(
            "RFT calibration: {n} intrusions of {:.0} mm, alpha fitted past {:.0} mm, in a bed of {} grains {:.2} x {:.2} x {:.2} m, {:.1} min ({})\n",
            1000.0 * rft["travel_m"].as_f64().unwrap_or(f64::NAN),
            1000.0
                * rft["fitted_over_travel_from_m"]
                    .as_f64()
                    .unwrap_or(f64::NAN),
            bed["grains"],
            2.0 * bed["hx"].as_f64().unwrap_or(f64::NAN),
            2.0 * bed["hy"].as_f64().unwrap_or(f64::NAN),
            bed["depth"].as_f64().unwrap_or(f64::NAN),
            rft["seconds"].as_f64().unwrap_or(0.0) / 60.0,
            rft["command"].as_str().unwrap_or("")
        );
    }
    // RFT's speed law, from the grid's element intruded from the surface at several speeds.
    if let Some(f) = speed {
        let at = &m["rft_entry"];
        let speeds: Vec<String> = at["speeds_m_s"]
            .as_array()
            .map_or(&[][..], |v| v.as_slice())
            .iter()
            .filter_map(|v| v.as_f64())
            .map(|v| format!("{v}"))
            .collect();
        s += &format!(
            "RFT speed law: {} intrusions into, across and out of the bed at {} m/s against the grid's element at {} m/s ({} samples); elements k (v - {} m/s) deeper, k {}: {:.0} % of the change explained (one k for every direction: {:.0} %; in v^2 - v0^2: {:.0} %; a factor on the stress: {:.0} %), {:.1} min ({})\n",
            f.intrusions,
            speeds.get(1..).map_or(String::new(), |v| v.join(", ")),
            f.law.ref_speed_m_s,
            f.samples,
            f.law.ref_speed_m_s,
            f.law.gains_text(),
            100.0 * f.explained,
            100.0 * f.one_gain_explained,
            100.0 * f.quadratic_explained,
            100.0 * f.factor_law_explained,
            at["seconds"].as_f64().unwrap_or(0.0) / 60.0,
            at["command"].as_str().unwrap_or("")
        );
    }
    let base = &m["beds"]["bed_base"];
    let med = &m["medium"];
    s += &format!(
        "bed: {} grains of radius {} m (0.8-1.2 x), solid fraction {:.3}, surface spread {:.1} mm, KE ratio {:.1e}\n",
        base["grains"],
        m["scene"]["r"],
        base["solid_fraction"].as_f64().unwrap_or(f64::NAN),
        1000.0 * base["surface_spread_m"].as_f64().unwrap_or(f64::NAN),
        base["settled_ke_ratio"].as_f64().unwrap_or(f64::NAN)
    );
    s += &format!(
        "medium from the bed: unit weight {:.0} N/m^3, phi {:.1} deg (static angle of repose, a drained bed), delta {:.1} deg (grain-plate contact friction)\n\n",
        med["unit_weight_n_m3"].as_f64().unwrap_or(f64::NAN),
        med["phi_deg"].as_f64().unwrap_or(f64::NAN),
        med["delta_deg"].as_f64().unwrap_or(f64::NAN)
    );
    s += &format!(
        "checks against the baseline {} over penetration: change of the mean drag and lift (the criterion), RMS change of the 5-deg bins (shape), peak drag:\n",
        r.baseline
    );
    s += &format!(
        "{:<20} {:>9} {:>9} {:>9} {:>9} {:>10}  criterion\n",
        "run", "mean D", "mean L", "shape D", "shape L", "peak D"
    );
    for ch in &r.checks {
        let limit = if ch.run.contains("dt") || ch.run.contains("damping") {
            0.05
        } else {
            0.10
        };
        render_change(&mut s, ch, Some(limit));
    }
    s += "\nvariations against the baseline:\n";
    for ch in &r.variations {
        render_change(&mut s, ch, None);
    }
    if !r.not_compared.is_empty() {
        s += &format!(
            "not compared (no penetration force in common with the baseline): {}\n",
            r.not_compared.join(", ")
        );
    }
    if let Some(f) = &r.rft_fit {
        s += &format!(
            "\nRFT from {} intrusions (N/cm^3): A00 {:.4} A10 {:.4} B11 {:.4} B01 {:.4} B-11 {:.4} C11 {:.4} C01 {:.4} C-11 {:.4} D10 {:.4}; R^2 on the grid: alpha_x {:.3}, alpha_z {:.3}\n",
            r.rft_grid_points,
            f.a00,
            f.a10,
            f.b11,
            f.b01,
            f.bm11,
            f.c11,
            f.c01,
            f.cm11,
            f.d10,
            r.rft_grid_r2.map_or(f64::NAN, |x| x.0),
            r.rft_grid_r2.map_or(f64::NAN, |x| x.1)
        );
    }
    s += "\nfidelity, penetration phase (psi_d psi_l r2_d r2_l rmse_d rmse_l):\n";
    s += &format!(
        "{:<14} {:>5} {:>7} {:>6} {:>5}  {:<47}  {:<47}  {:<47}  {:>9}\n",
        "run", "n", "b_k", "a", "delta", "improved", "conventional", "RFT from DEM", "r2 whole"
    );
    for f in &r.fidelity {
        s += &format!(
            "{:<14} {:>5} {:>7.3} {:>6.3} {:>5.1}  {}  {}  {}  {:>4.2}/{:>4.2}\n",
            f.run,
            f.samples,
            f.b_k,
            f.a,
            f.delta_deg,
            gof(&f.improved),
            gof(&f.conventional),
            gof(&f.rft),
            f.improved_whole_stroke.r2_drag,
            f.improved_whole_stroke.r2_lift
        );
    }
    s += "\nwidth transfer (b_k, a, delta fitted on one width, R^2 drag/lift on another; its own fit beside):\n";
    for t in &r.transfer {
        s += &format!(
            "{:<14} -> {:<14} h {:.3}: transferred {:>6.3}/{:>6.3}, own fit {:>6.3}/{:>6.3}\n",
            t.train,
            t.test,
            t.hip_height_m,
            t.transferred.r2_drag,
            t.transferred.r2_lift,
            t.own.r2_drag,
            t.own.r2_lift
        );
    }
    if let Some(c) = &r.c_leg {
        s += &format!(
            "\nC-leg ({} samples): RFT from DEM R^2 drag {:.3}, lift {:.3}, RMSE {:.2}/{:.2} N, peak drag {:.2} N (measured {:.2} N); the flat-plate model fitted to it: R^2 {:.3}/{:.3}\n",
            c.samples,
            c.rft.r2_drag,
            c.rft.r2_lift,
            c.rft.rmse_drag_n,
            c.rft.rmse_lift_n,
            c.rft_peak_drag_n,
            c.measured_peak_drag_n,
            c.flat_plate_fit.r2_drag,
            c.flat_plate_fit.r2_lift
        );
    }
    s
}
