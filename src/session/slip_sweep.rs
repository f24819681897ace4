//! A wheel's slip sweep as a calibration test of the medium (`terzaghi calibrate ...
//! --slip-sweep RUNS.csv`): the two coefficients of the bearing of sheared sand
//! ([`crate::model::ShearedBearing`]) fitted to the runs' measured sinkage and drawbar, the
//! body and the rest of the medium given; or the physics alone, from the sand's angle of
//! repose.

use crate::ident::sheared::{SweepRun, fit_sheared, slip};
use crate::medium_file::{MediumFile, MediumShearedBearing, MediumSlipSweep};
use crate::model::{Body, Drive, ShearedBearing, Stress};
use crate::session::files::{csv_number, csv_table};
use crate::session::steady::{Solve, steady_runs};
use anyhow::{Context as _, Result, bail};
use std::collections::BTreeMap;
use std::path::Path;

/// The columns a slip sweep's run must have: a run of `terzaghi steady` with its measured
/// sinkage and drawbar.
pub const SWEEP_COLUMNS: [&str; 6] = [
    "load_n",
    "hub_vx_m_s",
    "omega_rad_s",
    "slip_angle_deg",
    "sinkage_m",
    "drawbar_n",
];

/// The runs of a slip sweep (`text`, the CSV named `file`), each value checked: a value
/// missing or no number, a load not above 0, a sinkage below 0 or a slip angle other than 0
/// is an error naming the file, the line and the value.
pub fn read_sweep(file: &Path, text: &str) -> Result<Vec<SweepRun>> {
    read_runs(file, text, true)
}

/// The runs of a wheel's test at any slip angle (what `terzaghi diagnose` judges), checked as
/// [`read_sweep`] checks them, a slip angle of any value.
pub fn read_test_runs(file: &Path, text: &str) -> Result<Vec<SweepRun>> {
    read_runs(file, text, false)
}

fn read_runs(file: &Path, text: &str, slip_angle_zero: bool) -> Result<Vec<SweepRun>> {
    let name = file.display().to_string();
    let (mut rdr, headers) = csv_table(&name, text)?;
    let mut index = [0usize; 6];
    for (k, c) in SWEEP_COLUMNS.iter().enumerate() {
        index[k] = headers.iter().position(|h| h == c).with_context(|| {
            format!(
                "{name}: header lacks column {c:?} (a slip sweep's run has {}; found: {})",
                SWEEP_COLUMNS.join(", "),
                headers.join(",")
            )
        })?;
    }
    let mut runs = Vec::new();
    for (row, record) in rdr.records().enumerate() {
        let record = record.with_context(|| format!("{name}: run {} is not CSV", row + 1))?;
        let line = record.position().map_or(row + 2, |p| p.line() as usize);
        let mut v = [0.0; 6];
        for (k, c) in SWEEP_COLUMNS.iter().enumerate() {
            v[k] = csv_number(&name, line, c, record.get(index[k]).unwrap_or(""))?;
        }
        let [
            load_n,
            hub_vx_m_s,
            omega_rad_s,
            slip_angle_deg,
            sinkage_m,
            drawbar_n,
        ] = v;
        if load_n <= 0.0 {
            bail!("{name} line {line}: load_n is {load_n}: a wheel on sand carries a load > 0 N");
        }
        if sinkage_m < 0.0 {
            bail!("{name} line {line}: sinkage_m is {sinkage_m}: a sinkage is 0 m or deeper");
        }
        if slip_angle_zero && slip_angle_deg != 0.0 {
            bail!(
                "{name} line {line}: slip_angle_deg is {slip_angle_deg}: a slip sweep calibrates at slip angle 0 (the other slip angles are what the medium then predicts)"
            );
        }
        runs.push(SweepRun {
            load_n,
            drive: Drive {
                speed_m_s: hub_vx_m_s,
                omega_rad_s,
                slip_angle_rad: slip_angle_deg.to_radians(),
            },
            sinkage_m,
            drawbar_n,
        });
    }
    Ok(runs)
}

/// The physics alone: the interface's friction `2/3` of the sand's angle of repose (deg),
/// Meyerhof's square; `source` says where the angle came from.
pub fn sheared_of_repose(angle_of_repose_deg: f64, source: &str) -> Result<MediumShearedBearing> {
    let b = ShearedBearing::of_repose(angle_of_repose_deg)?;
    Ok(MediumShearedBearing {
        interface_tan: b.interface_tan,
        exponent: b.exponent,
        std_dev: BTreeMap::from([("interface_tan".into(), 0.0), ("exponent".into(), 0.0)]),
        source: format!(
            "the physics alone: tan(2/3 x the angle of repose {angle_of_repose_deg} deg, {source}), Meyerhof's square; nothing from a wheel"
        ),
        slip_sweep: None,
    })
}

/// R^2 of the sinkage and the drawbar of `runs_file` settled through `terzaghi steady`'s own
/// code for `body` in `medium`.
fn sweep_r2(medium: &MediumFile, runs_file: &Path, text: &str, body: &Body) -> Result<(f64, f64)> {
    let law = medium.rft_law(None)?;
    let table = steady_runs(runs_file, text, body, &law, &Solve::Sinkage)?;
    let agreement = table.agreement();
    let r2 = |c: &str| {
        agreement
            .iter()
            .find(|a| a.column == c)
            .map_or(f64::NAN, |a| a.r2)
    };
    Ok((r2("sinkage_m"), r2("drawbar_n")))
}

/// The sheared bearing the slip sweep `runs_file` gives for `body` (`body_text` says what it
/// is) in `medium` (its sheared bearing, if any, left out), with the sweep's R^2 before and
/// after through `terzaghi steady`'s code.
pub fn sheared_of_sweep(
    medium: &MediumFile,
    runs_file: &Path,
    body: &Body,
    body_text: &str,
) -> Result<MediumShearedBearing> {
    let name = runs_file.display();
    let text = std::fs::read_to_string(runs_file).with_context(|| format!("cannot read {name}"))?;
    let runs = read_sweep(runs_file, &text)?;
    let at_rest = MediumFile {
        sheared_bearing: None,
        ..medium.clone()
    };
    let law = at_rest
        .rft_law(None)
        .context("the slip sweep settles the wheel in the medium's RFT law")?;
    let stress = Stress {
        coefficients: &law.coefficients,
        depth_law: Some(&law.depth_law),
        speed_law: law.speed_law.as_ref(),
        sheared: None,
    };
    let fit = fit_sheared(body, &stress, &runs).map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
    let reach = body.reach_m();
    let mut slips: Vec<f64> = runs.iter().map(|r| slip(&r.drive, reach)).collect();
    slips.sort_by(f64::total_cmp);
    let bearing = MediumShearedBearing {
        interface_tan: fit.bearing.interface_tan,
        exponent: fit.bearing.exponent,
        std_dev: BTreeMap::from([
            ("interface_tan".into(), fit.std_dev[0]),
            ("exponent".into(), fit.std_dev[1]),
        ]),
        source: format!(
            "fitted to the slip sweep {name} ({} runs at slip angle 0, slips {:.2} to {:.2}; {} of them sheared past tan delta_w){}",
            runs.len(),
            slips[0],
            slips[slips.len() - 1],
            fit.runs_sheared,
            match fit.on_bound {
                Some((what, bound)) => format!("; {what} on its bound {bound}"),
                None => String::new(),
            }
        ),
        slip_sweep: None,
    };
    let with = MediumFile {
        sheared_bearing: Some(bearing.clone()),
        ..medium.clone()
    };
    let (r2_sinkage_at_rest, r2_drawbar_at_rest) = sweep_r2(&at_rest, runs_file, &text, body)?;
    let (r2_sinkage, r2_drawbar) = sweep_r2(&with, runs_file, &text, body)?;
    Ok(MediumShearedBearing {
        slip_sweep: Some(MediumSlipSweep {
            file: name.to_string(),
            body: body_text.to_string(),
            runs: runs.len(),
            r2_sinkage,
            r2_drawbar,
            r2_sinkage_at_rest,
            r2_drawbar_at_rest,
        }),
        ..bearing
    })
}
