//! A wheel's test (runs in `terzaghi steady`'s format with their measured `sinkage_m` and
//! `drawbar_n`, at any slip and slip angle) judged against a calibrated medium: `terzaghi
//! diagnose RUNS.csv --shape wheel ... --medium-file M` (the analysis is
//! [`crate::diagnose::wheel`]). Where the effect named is the bearing of sheared sand, the
//! medium file with it is written beside the report.

use crate::diagnose::wheel::{WheelDiagnoseOptions, WheelDiagnosis, diagnose_wheel};
use crate::medium_file::{MediumFile, MediumShearedBearing};
use crate::model::{Body, Stress};
use anyhow::{Context as _, Result};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Whether `file` is a body's runs (a CSV whose header has `load_n` and `hub_vx_m_s`).
pub fn is_wheel_test(file: &Path) -> bool {
    super::files::header_columns(file).is_some_and(|cols| {
        cols.iter().any(|c| c == "load_n") && cols.iter().any(|c| c == "hub_vx_m_s")
    })
}

/// A wheel's test diagnosed.
#[derive(Debug, Clone, Serialize)]
pub struct WheelTestDiagnosis {
    /// The runs' file.
    pub file: PathBuf,
    /// The medium file judged, and its name.
    pub medium_file: PathBuf,
    /// See [`Self::medium_file`].
    pub medium: String,
    /// The body, in words.
    pub body: String,
    /// Whether the medium already held a sheared bearing (the model judged has it).
    pub medium_has_sheared_bearing: bool,
    /// The analysis.
    #[serde(flatten)]
    pub diagnosis: WheelDiagnosis,
    /// The medium file with the effect named, where it is one a medium file takes as it stands
    /// (the sheared bearing): `corrected_medium.yaml` beside the report.
    #[serde(skip)]
    pub corrected: Option<MediumFile>,
}

/// Diagnoses the runs of `runs_file` for `body` (`body_text` says what it is) against the
/// medium of `medium_file`.
pub fn diagnose_runs(
    runs_file: &Path,
    medium_file: &Path,
    body: &Body,
    body_text: &str,
    opts: &WheelDiagnoseOptions,
) -> Result<WheelTestDiagnosis> {
    let name = runs_file.display();
    let text = std::fs::read_to_string(runs_file).with_context(|| format!("cannot read {name}"))?;
    let runs = super::slip_sweep::read_test_runs(runs_file, &text)?;
    let medium = MediumFile::read(medium_file)?;
    let law = medium.rft_law(None).with_context(|| {
        format!(
            "a wheel's test is judged in the medium's RFT law, and {} has none (calibrate it with --law rft_depth_power)",
            medium_file.display()
        )
    })?;
    let stress = Stress {
        coefficients: &law.coefficients,
        depth_law: Some(&law.depth_law),
        speed_law: law.speed_law.as_ref(),
        sheared: law.sheared.as_ref(),
    };
    let diagnosis =
        diagnose_wheel(body, &stress, &runs, opts).map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
    let corrected = (diagnosis.verdict.effect == "sheared_bearing").then(|| {
        let c = &diagnosis.candidates[0].coefficients;
        MediumFile {
            sheared_bearing: Some(MediumShearedBearing {
                interface_tan: c[0].value,
                exponent: c[1].value,
                std_dev: BTreeMap::from([
                    ("interface_tan".into(), c[0].std_dev),
                    ("exponent".into(), c[1].std_dev),
                ]),
                source: format!(
                    "found by terzaghi diagnose on {name} ({} runs, {body_text}): closes {:.0} % of the gap held out run by run",
                    runs.len(),
                    100.0 * diagnosis.verdict.share_closed
                ),
                slip_sweep: None,
            }),
            ..medium.clone()
        }
    });
    Ok(WheelTestDiagnosis {
        file: runs_file.to_path_buf(),
        medium_file: medium_file.to_path_buf(),
        medium: medium.name.clone(),
        body: body_text.to_string(),
        medium_has_sheared_bearing: medium.sheared_bearing.is_some(),
        diagnosis,
        corrected,
    })
}

/// Writes `report.json` (and `corrected_medium.yaml`, where there is one) into `out`; the
/// report's JSON text.
pub fn write_wheel_report(d: &WheelTestDiagnosis, out: &Path) -> Result<String> {
    let inputs = [d.file.as_path(), d.medium_file.as_path()];
    let report = out.join("report.json");
    let medium = out.join("corrected_medium.yaml");
    for p in [out, report.as_path(), medium.as_path()] {
        super::files::refuse_output_over_input(p, &inputs)?;
    }
    let json = serde_json::to_string_pretty(d)? + "\n";
    std::fs::create_dir_all(out)
        .map_err(anyhow::Error::from)
        .context(super::files::cannot_write(out))?;
    super::files::write_text(&report, &json).context(super::files::cannot_write(&report))?;
    if let Some(m) = &d.corrected {
        super::files::write_text(&medium, &m.to_yaml()?)
            .context(super::files::cannot_write(&medium))?;
    }
    Ok(json)
}

/// A wheel's test's diagnosis in words.
pub fn wheel_diagnosis_text(d: &WheelTestDiagnosis, out: &Path) -> String {
    let w = &d.diagnosis;
    let b = &w.baseline;
    let mut s = format!(
        "{} ({}, {} runs) against medium {}{}\n",
        d.file.display(),
        d.body,
        w.runs.len(),
        d.medium,
        if d.medium_has_sheared_bearing {
            " (with its sheared bearing)"
        } else {
            ""
        }
    );
    s += &format!(
        "  the model: sinkage R^2 {:.3} (RMSE {:.2} mm), drawbar R^2 {:.3} (RMSE {:.2} N){}\n",
        b.r2_sinkage,
        b.rmse_sinkage_m * 1e3,
        b.r2_drawbar,
        b.rmse_drawbar_n,
        if b.not_borne > 0 {
            format!("; {} runs not borne within the body's height", b.not_borne)
        } else {
            String::new()
        }
    );
    s += "  where they part (sheared: runs whose resultant leans past the refitted tan delta_w; load share:\n  the load over what the sand at rest bears at the measured sinkage):\n";
    s += "    slip angle  slip          runs  parted  sheared  load share  sinkage error  drawbar error\n";
    for g in &w.groups {
        s += &format!(
            "    {:>7.1} deg  {:<12}  {:>4}  {:>6}  {:>7}  {:>10.2}  {:>10.1} mm  {:>10.2} N\n",
            g.slip_angle_deg,
            g.slip_class,
            g.runs,
            g.parted,
            g.sheared,
            g.median_load_share,
            g.mean_sinkage_error_m * 1e3,
            g.mean_drawbar_error_n
        );
    }
    let e = &w.evidence;
    s += &format!(
        "  the load share follows the rim's lean (r {:+.2}), the slip's size (r {:+.2}), its sign (r {:+.2}){}\n",
        e.r_with_lean,
        e.r_with_slip_size,
        e.r_with_slip,
        match (e.median_share_sheared, e.median_share_unsheared) {
            (Some(a), Some(b)) => format!(
                "; median {a:.2} where the resultant leans past tan delta_w, {b:.2} where it does not"
            ),
            (Some(a), None) =>
                format!("; median {a:.2} where the resultant leans past tan delta_w"),
            _ => String::new(),
        }
    );
    s += "  candidates, each fitted with every run but one and scored on that one:\n";
    for c in &w.candidates {
        match (&c.held_out, &c.refused) {
            (Some(h), _) => {
                let coef: Vec<String> = c
                    .coefficients
                    .iter()
                    .map(|k| format!("{} {:.4} +- {:.4}", k.name, k.value, k.std_dev))
                    .collect();
                s += &format!(
                    "    {:<16} closes {:>4.0} %: sinkage R^2 {:.3}, drawbar {:.3} ({})\n",
                    c.effect,
                    100.0 * c.share_closed,
                    h.r2_sinkage,
                    h.r2_drawbar,
                    coef.join(", ")
                );
            }
            (None, Some(why)) => s += &format!("    {:<16} not fitted: {why}\n", c.effect),
            (None, None) => {}
        }
    }
    s += &format!("verdict {}: {}\n", w.verdict.effect, w.verdict.claim);
    if let Some(m) = &d.corrected
        && let Some(sb) = &m.sheared_bearing
    {
        s += &format!(
            "  as the medium file takes it:\n    sheared_bearing:\n      interface_tan: {}\n      exponent: {}\n",
            sb.interface_tan, sb.exponent
        );
        s += &format!(
            "  wrote {} (the medium with it)\n",
            out.join("corrected_medium.yaml").display()
        );
    }
    s += &format!("wrote {}\n", out.join("report.json").display());
    s
}
