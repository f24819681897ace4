//! Diagnosis of a session on disk: its legs are read ([`super::legs`]), diagnosed in parallel
//! by the pure analysis ([`crate::diagnose`]), and their reports written as `report.json` and
//! `report.html` (one directory per leg, with an index, when there are several).

use super::files::write_text;
use super::legs::{LegLog, LegsFrom, csv_leg, mcap_legs};
use super::{Opened, Refusal};
use crate::config::corrections::corrections_params;
use crate::config::{LegConfig, NodeConfig, ParamMap, ParamValue, params_yaml};
use crate::diagnose::{DiagnoseOptions, Diagnosis, Report, diagnose_placed};
use crate::model::Corrections;
use crate::model::{Medium, Plate};
use anyhow::{Context as _, Result, bail};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// What to diagnose in a log, and how.
#[derive(Debug, Clone, Default)]
pub struct DiagnoseFileOptions {
    /// Where the legs of an MCAP session are described.
    pub legs_from: LegsFrom,
    /// Only this leg (default: every leg with an F/T topic). For a CSV log, the leg's name
    /// (default: the file's stem).
    pub leg: Option<String>,
    /// A CSV log's plate and medium (a CSV log carries neither).
    pub csv_leg: Option<(Plate, Medium)>,
    /// Options of the analysis (folds of whole strokes, thresholds).
    pub analysis: DiagnoseOptions,
}

/// One leg's diagnosis, or why it could not be made.
#[derive(Debug)]
pub struct LegDiagnosis {
    /// The leg's name.
    pub leg: String,
    /// Its diagnosis, or why none could be made.
    pub result: Result<Diagnosis, String>,
    /// How the leg's F/T sensor delivers its values (its effective rate and hold, from the
    /// spacing of changes of the lift it measured), if it changes often enough to tell.
    pub sensor: Option<crate::diagnose::sinkage::SensorHabits>,
}

/// The habits of the sensor of `samples` (their times and measured lift).
fn sensor_of(samples: &[crate::ident::Sample]) -> Option<crate::diagnose::sinkage::SensorHabits> {
    let (t, lift): (Vec<f64>, Vec<f64>) = samples
        .iter()
        .filter_map(|s| s.t_s.map(|t| (t, s.lift_n)))
        .unzip();
    crate::diagnose::sinkage::sensor_habits(&t, &lift)
}

/// The diagnosis of a log, leg by leg.
#[derive(Debug)]
pub struct Diagnosed {
    /// The log diagnosed.
    pub log: PathBuf,
    /// Each leg's diagnosis.
    pub legs: Vec<LegDiagnosis>,
    /// The node configuration of the log's legs (for a CSV log, its one leg's), which the
    /// corrected parameters complete.
    pub config: NodeConfig,
}

/// Reads `log` (a ROS 2 MCAP session, or a CSV log of one leg) and diagnoses its legs, several
/// at a time.
pub fn diagnose_file(log: &Path, opts: &DiagnoseFileOptions) -> Result<Diagnosed> {
    if opts.analysis.folds < 2 {
        bail!("folds of strokes: at least 2, got {}", opts.analysis.folds);
    }
    // The file's first bytes say what it is, here alone; options for the other kind are refused.
    let (legs, config) = match Opened::mcap(log)? {
        Some(opened) => {
            if opts.csv_leg.is_some() {
                bail!(Refusal::GeometryForSession {
                    file: log.to_path_buf()
                });
            }
            mcap_legs(log, &opened, &opts.legs_from, opts.leg.as_deref())?
        }
        None => {
            if !matches!(opts.legs_from, LegsFrom::Recorded) {
                bail!(Refusal::SessionOptionsForCsv {
                    file: log.to_path_buf()
                });
            }
            let Some((plate, medium)) = opts.csv_leg else {
                bail!(Refusal::CsvWithoutGeometry {
                    file: log.to_path_buf()
                });
            };
            let name = opts.leg.clone().unwrap_or_else(|| {
                log.file_stem()
                    .map_or("leg".to_string(), |s| s.to_string_lossy().into_owned())
            });
            let leg = csv_leg(log, &name, plate, medium)?;
            let cfg = NodeConfig::with_legs(
                vec![LegConfig::new(&name, &name, plate, medium)],
                "joint_states",
            )?;
            (vec![leg], cfg)
        }
    };
    // A leg the session ran with another model or shape than the flat Terzaghi plate gets no
    // verdict: the analysis judges that plate, and would judge a model the leg never used.
    let (judged, not_judged): (Vec<LegLog>, Vec<LegLog>) = legs
        .into_iter()
        .partition(|l| not_a_flat_terzaghi_leg(&config, &l.name).is_none());
    let mut diagnosed = diagnose_legs(&judged, &opts.analysis);
    diagnosed.extend(not_judged.iter().map(|l| LegDiagnosis {
        leg: l.name.clone(),
        result: Err(not_a_flat_terzaghi_leg(&config, &l.name).unwrap_or_default()),
        sensor: sensor_of(&l.samples),
    }));
    Ok(Diagnosed {
        log: log.to_path_buf(),
        legs: diagnosed,
        config,
    })
}

/// Why leg `name` of `config` is not the flat Terzaghi plate the diagnosis judges, if it is not.
fn not_a_flat_terzaghi_leg(config: &NodeConfig, name: &str) -> Option<String> {
    use crate::config::ModelKind;
    let lc = config.legs.iter().find(|l| l.name == name)?;
    let shape = lc.profile.as_ref().map(|p| p.shape);
    match (config.model, shape) {
        (ModelKind::Improved | ModelKind::Conventional, None) => None,
        (model, shape) => Some(format!(
            "leg {name} ran with model {}{}: the diagnosis judges the Terzaghi model of a flat plate, and gives no verdict on a model the session did not use",
            model.as_str(),
            shape.map(|s| format!(" and shape {s}")).unwrap_or_default()
        )),
    }
}

/// Diagnoses every leg, in parallel.
pub fn diagnose_legs(legs: &[LegLog], opts: &DiagnoseOptions) -> Vec<LegDiagnosis> {
    legs.par_iter()
        .map(|leg| LegDiagnosis {
            leg: leg.name.clone(),
            result: diagnose_placed(&leg.model, &leg.samples, &leg.hips, opts)
                .map_err(|e| e.to_string()),
            sensor: sensor_of(&leg.samples),
        })
        .collect()
}

/// A leg's `report.json`: the leg, the log, and the report's fields.
#[derive(serde::Serialize)]
pub struct LegReport<'a> {
    /// The leg's name.
    pub leg: &'a str,
    /// The log, as given.
    pub log: &'a str,
    /// The sensor's habits: its effective rate and hold.
    pub sensor: Option<&'a crate::diagnose::sinkage::SensorHabits>,
    #[serde(flatten)]
    /// The report's fields.
    pub report: &'a Report,
}

/// What [`write_reports`] wrote.
#[derive(Debug, Clone)]
pub struct Written {
    /// Whether the log had one leg (its report is in the directory itself).
    pub single: bool,
    /// Each diagnosed leg's directory and `report.json` value, in the order of the legs.
    pub reports: Vec<(PathBuf, serde_json::Value)>,
    /// The legs that could not be diagnosed, with the reason.
    pub failed: Vec<String>,
    /// The node's parameters with every diagnosed leg's corrected model (`corrected.yaml` in
    /// the output directory), if a leg was diagnosed.
    pub corrected: Option<PathBuf>,
}

/// The files [`write_reports`] may write into `out`: each leg's `report.json`, `report.html`
/// and `corrected.yaml`, and the index's.
pub fn report_paths(d: &Diagnosed, out: &Path) -> Vec<PathBuf> {
    std::iter::once(out.to_path_buf())
        .chain(d.legs.iter().map(|l| out.join(&l.leg)))
        .flat_map(|dir| ["report.json", "report.html", "corrected.yaml"].map(|n| dir.join(n)))
        .collect()
}

/// Writes `report.json` and `report.html` of each diagnosed leg into `out` (into `out/<leg>/`
/// when there are several legs, with an index of them in `out`), and `corrected.yaml`. None of
/// them may be the log diagnosed: that is refused before anything is written.
pub fn write_reports(d: &Diagnosed, out: &Path) -> Result<Written> {
    for path in report_paths(d, out) {
        super::files::refuse_output_over_input(&path, &[&d.log])?;
    }
    std::fs::create_dir_all(out).with_context(|| {
        super::Failure(format!(
            "cannot create the output directory {}",
            out.display()
        ))
    })?;
    let single = d.legs.len() == 1;
    let log = d.log.display().to_string();
    let mut written = Written {
        single,
        reports: Vec::new(),
        failed: Vec::new(),
        corrected: None,
    };
    let mut all = d.config.effective_params(&ParamMap::new());
    for leg in &d.legs {
        let dir = if single {
            out.to_path_buf()
        } else {
            out.join(&leg.leg)
        };
        match &leg.result {
            Ok(diag) => {
                std::fs::create_dir_all(&dir)
                    .with_context(|| super::Failure(format!("cannot create {}", dir.display())))?;
                let doc = LegReport {
                    leg: &leg.leg,
                    log: &log,
                    sensor: leg.sensor.as_ref(),
                    report: &diag.report,
                };
                write_text(
                    &dir.join("report.json"),
                    &(serde_json::to_string_pretty(&doc)? + "\n"),
                )?;
                write_text(
                    &dir.join("report.html"),
                    &super::report_html::html(&leg.leg, diag)?,
                )?;
                let leg_params = corrected_params(
                    &d.config,
                    &leg.leg,
                    &diag.report.corrected_model,
                    leg.sensor.as_ref(),
                );
                if !single {
                    write_text(
                        &dir.join("corrected.yaml"),
                        &params_yaml(
                            &leg_params,
                            &corrected_header(&log, &leg.leg, &diag.report, false),
                        ),
                    )?;
                }
                let own = format!("{}.corrections.", leg.leg);
                all.retain(|k, _| !k.starts_with(&own));
                all.extend(leg_params);
                written.reports.push((dir, serde_json::to_value(&doc)?));
            }
            Err(e) => written.failed.push(format!("leg {}: {e}", leg.leg)),
        }
    }
    if !single && !written.reports.is_empty() {
        write_index(out, d.legs.len(), &written.reports)?;
    }
    if !written.reports.is_empty() {
        let path = out.join("corrected.yaml");
        let cfg = &d.config;
        all.insert(
            "legs".into(),
            ParamValue::StringArray(cfg.legs.iter().map(|l| l.name.clone()).collect()),
        );
        all.insert("model".into(), ParamValue::String("improved".into()));
        all.insert(
            "joint_states_topic".into(),
            ParamValue::String(cfg.joint_states_topic.clone()),
        );
        let header = match (single, d.legs.iter().find_map(|l| l.result.as_ref().ok())) {
            (true, Some(diag)) => corrected_header(&log, &d.legs[0].leg, &diag.report, true),
            _ => format!(
                "The node's parameters for the legs of {log}, each diagnosed leg with the corrected\nmodel its diagnosis found (written by terzaghi diagnose):\n  terzaghi node --ros-args --params-file corrected.yaml\nEach leg's own file, <leg>/corrected.yaml, holds its corrections alone."
            ),
        };
        write_text(&path, &params_yaml(&all, &header))?;
        written.corrected = Some(path);
    }
    Ok(written)
}

/// A log whose F/T values are each held for this many rows or more comes from a sensor that
/// samples slower than it publishes: the node is told its period (`<leg>.sensor_hold_s`).
const HELD_ROWS_PER_VALUE: f64 = 1.5;

/// The parameters of leg `leg`'s corrected model, with `fitted_for` the leg's configuration;
/// with `sensor` habits that hold each value, the sensor's sample period.
fn corrected_params(
    cfg: &NodeConfig,
    leg: &str,
    c: &Corrections,
    sensor: Option<&crate::diagnose::sinkage::SensorHabits>,
) -> ParamMap {
    let Some(l) = cfg.legs.iter().find(|l| l.name == leg) else {
        return ParamMap::new();
    };
    let mut p: ParamMap = corrections_params(leg, &l.plate, &l.medium, c)
        .into_iter()
        .collect();
    // A diagnosis that kept no term has the baseline alone: its b_k and a.
    if c.terms.is_empty() {
        p.retain(|k, _| !k.contains(".corrections."));
    }
    if let Some(h) = sensor
        .filter(|h| h.rows_per_value >= HELD_ROWS_PER_VALUE && h.hold_s > 0.0 && h.hold_s <= 1.0)
    {
        p.insert(format!("{leg}.sensor_hold_s"), ParamValue::Double(h.hold_s));
    }
    p
}

/// The comment at the top of a leg's `corrected.yaml`: where it comes from, what it holds, and
/// how a node uses it (`whole`: the node's parameters too).
fn corrected_header(log: &str, leg: &str, r: &Report, whole: bool) -> String {
    let terms: Vec<&str> = r
        .corrected_model
        .terms
        .iter()
        .map(|t| t.effect.name())
        .collect();
    let mut s = format!(
        "Leg {leg} of {log}: the corrected model its diagnosis found (written by terzaghi diagnose).\nBaseline b_k, a fitted with {}; verdict {}.\n",
        corrections_said(&terms, r.verdict.effect, &r.corrected_model_left_out),
        r.verdict.effect
    );
    s += if whole {
        "  terzaghi node --ros-args --params-file corrected.yaml"
    } else {
        "With the robot's own parameters:\n  terzaghi node --ros-args --params-file ROBOT.yaml --params-file corrected.yaml"
    };
    s
}

/// What a `corrected.yaml`'s header says of its corrections, in agreement with the report: the
/// terms it holds; or, without any, why the verdict's effect is not among them (its fit left the
/// terms' bounds, or it did not predict held-out strokes better beside the baseline), or that no
/// term was significant.
fn corrections_said(
    terms: &[&str],
    verdict: crate::diagnose::VerdictEffect,
    left_out: &[String],
) -> String {
    use crate::diagnose::VerdictEffect;
    if !terms.is_empty() {
        return format!("the corrections {}", terms.join(", "));
    }
    match verdict {
        VerdictEffect::Effect(e) => {
            let why = left_out
                .iter()
                .find(|l| l.starts_with(e.name()))
                .map_or_else(
                    || "its term did not predict held-out strokes better".to_string(),
                    |l| format!("left out: {l}"),
                );
            format!(
                "no correction (the verdict's {} is not in it, {why}; report.json: corrected_model_left_out)",
                e.name()
            )
        }
        VerdictEffect::None | VerdictEffect::Unexplained => {
            "no correction (no term was significant)".to_string()
        }
    }
}

fn write_index(out: &Path, legs: usize, reports: &[(PathBuf, serde_json::Value)]) -> Result<()> {
    let index: Vec<serde_json::Value> = reports
        .iter()
        .map(|(_, r)| {
            serde_json::json!({
                "leg": r["leg"],
                "verdict": r["verdict"],
                "report": format!("{}/report.json", r["leg"].as_str().unwrap_or("")),
            })
        })
        .collect();
    write_text(
        &out.join("report.json"),
        &(serde_json::to_string_pretty(&serde_json::json!({ "legs": index }))? + "\n"),
    )?;
    let mut page = String::from(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>terzaghi diagnosis</title></head><body style=\"font-family:sans-serif\">\n<h1>Sim-to-real gap, every leg</h1>\n<ul>\n",
    );
    for (_, r) in reports {
        let leg = r["leg"].as_str().unwrap_or("");
        page += &format!(
            "<li><a href=\"{leg}/report.html\">{leg}</a>: {}</li>\n",
            r["verdict"]["effect"].as_str().unwrap_or("")
        );
    }
    page += &format!("</ul><p>{legs} legs.</p></body></html>\n");
    write_text(&out.join("report.html"), &page)
}

#[cfg(test)]
mod tests {
    use super::corrections_said;
    use crate::diagnose::{Effect, VerdictEffect};

    /// The header never says no term was significant while the verdict names one.
    #[test]
    fn the_header_agrees_with_the_verdict() {
        let cohesion = VerdictEffect::Effect(Effect::Cohesion);
        assert_eq!(
            corrections_said(&["cohesion", "rate"], cohesion, &[]),
            "the corrections cohesion, rate"
        );
        let left = ["cohesion (c_pa -40 below 0)".to_string()];
        let said = corrections_said(&[], cohesion, &left);
        assert!(!said.contains("no term was significant"), "{said}");
        assert!(said.contains("cohesion (c_pa -40 below 0)"), "{said}");
        let said = corrections_said(&[], cohesion, &[]);
        assert!(said.contains("cohesion is not in it"), "{said}");
        assert!(
            corrections_said(&[], VerdictEffect::None, &[]).contains("no term was significant")
        );
    }
}
