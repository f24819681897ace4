//! `terzaghi diagnose`: where the model and the measurements part, which unmodelled effect is
//! responsible, and how far the gap shrinks with it. Reads an MCAP session or a CSV log, hands
//! the samples to the pure analysis, writes `report.json` and `report.html`.

use super::mcap_tools::read_file;
use super::replay::reevaluation_config;
use super::{MediumArgs, diagnose_report, print_out, write_atomically};
use crate::config::{NodeConfig, ParamValue, defaults};
use crate::dataset::read_samples_csv;
use crate::diagnose::{DiagnoseOptions, Diagnosis, Report, diagnose};
use crate::ident::Sample;
use crate::model::{Plate, TerzaghiModel};
use crate::record::read::{IndexedFile, Scan, Source, scan};
use crate::record::reevaluate::measured_samples;
use anyhow::{Context as _, Result, bail};
use clap::Args;
use std::io::Write;
use std::path::{Path, PathBuf};

#[derive(Debug, Args)]
pub struct DiagnoseArgs {
    /// The session: an MCAP file (recorded by `terzaghi node`, or any ROS 2 MCAP with JointState
    /// and WrenchStamped) or a CSV with t_s,beta_rad,drag_n,lift_n.
    pub log: PathBuf,
    /// Directory for report.json and report.html (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// The leg to diagnose (default: every leg with an F/T topic, each in DIR/<leg>/).
    #[arg(long, value_name = "NAME")]
    pub leg: Option<String>,
    /// Node parameters for the legs (default: the ones recorded in the MCAP session).
    #[arg(long, value_name = "FILE")]
    pub params_file: Option<PathBuf>,
    /// A ROS 2 MCAP without our parameters: the leg's joint in the JointState messages (with
    /// --wrench-topic and the geometry and medium flags).
    #[arg(long, value_name = "NAME", requires = "wrench_topic")]
    pub joint: Option<String>,
    /// With --joint: the leg's measured F/T topic (geometry_msgs/WrenchStamped).
    #[arg(long, value_name = "TOPIC", requires = "joint")]
    pub wrench_topic: Option<String>,
    /// With --joint: the JointState topic.
    #[arg(long, value_name = "TOPIC", default_value = "/joint_states")]
    pub joint_states_topic: String,
    /// With --joint: frame of the F/T data, `hip` or `leg` (rotating with the joint).
    #[arg(long, value_name = "FRAME", default_value = "hip")]
    pub ft_frame: String,
    /// With --joint: `beta = direction * (position - angle_offset_rad)`.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub direction: f64,
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub angle_offset_rad: f64,
    /// Plate length from the hip axis to the tip (m) (CSV logs and --joint).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub length_m: Option<f64>,
    /// Plate width (m).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub width_m: Option<f64>,
    /// Height of the hip axis above the free surface (m).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub hip_height_m: Option<f64>,
    #[command(flatten)]
    pub medium: MediumArgs,
    /// Folds of whole strokes for the held-out scores.
    #[arg(long, default_value_t = 5)]
    pub folds: usize,
    /// Print the report(s) as JSON instead of a text summary.
    #[arg(long)]
    pub json: bool,
}

/// A leg to diagnose: name, unit model, samples.
struct LegLog {
    name: String,
    model: TerzaghiModel,
    samples: Vec<Sample>,
}

pub fn run(a: DiagnoseArgs) -> Result<()> {
    let done = diagnose_to_dir(&a)?;
    if a.json {
        let v = match (done.single, done.reports.as_slice()) {
            (true, [one]) => one.clone(),
            _ => serde_json::Value::Array(done.reports.clone()),
        };
        print_out(&(serde_json::to_string_pretty(&v)? + "\n"))?;
    } else {
        print_out(&done.text)?;
    }
    if !done.failed.is_empty() {
        bail!("cannot diagnose {}", done.failed.join("; "));
    }
    Ok(())
}

/// What a diagnosis wrote: the text summary, each leg's report.json value, the legs that
/// failed with their reason.
pub struct Done {
    pub single: bool,
    pub text: String,
    pub reports: Vec<serde_json::Value>,
    pub failed: Vec<String>,
}

/// Reads the log, diagnoses its legs and writes the reports into `a.out`.
pub fn diagnose_to_dir(a: &DiagnoseArgs) -> Result<Done> {
    if a.folds < 2 {
        bail!("--folds must be at least 2, got {}", a.folds);
    }
    let opts = DiagnoseOptions {
        folds: a.folds,
        ..Default::default()
    };
    // A finished MCAP file is read chunk by chunk from its summary; anything else whole.
    let indexed =
        IndexedFile::open(&a.log).with_context(|| format!("cannot read {}", a.log.display()))?;
    let legs = match &indexed {
        Some(file) => from_mcap(a, file.into(), file.head().clone())?,
        None => {
            let bytes = read_file(&a.log)?;
            if bytes.starts_with(b"\x89MCAP") {
                // Cut off (no summary): scanned for its topics and parameters, to say why.
                let head = scan(&bytes, |_, _| {}).with_context(|| a.log.display().to_string())?;
                from_mcap(a, (&bytes).into(), head)?
            } else {
                from_csv(a)?
            }
        }
    };
    drop(indexed);
    let results = diagnose_all(&legs, &opts);
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create the output directory {}", a.out.display()))?;
    let single = legs.len() == 1;
    let mut done = Done {
        single,
        text: String::new(),
        reports: Vec::new(),
        failed: Vec::new(),
    };
    for (leg, result) in legs.iter().zip(results) {
        let dir = if single {
            a.out.clone()
        } else {
            a.out.join(&leg.name)
        };
        match result {
            Ok(d) => {
                std::fs::create_dir_all(&dir)
                    .with_context(|| format!("cannot create {}", dir.display()))?;
                let doc = LegReport {
                    leg: &leg.name,
                    log: &a.log.display().to_string(),
                    report: &d.report,
                };
                let body = serde_json::to_string_pretty(&doc)? + "\n";
                write_atomically(&dir.join("report.json"), |w| {
                    Ok(w.write_all(body.as_bytes())?)
                })?;
                let page = diagnose_report::html(&leg.name, &d)?;
                write_atomically(&dir.join("report.html"), |w| {
                    Ok(w.write_all(page.as_bytes())?)
                })?;
                done.text += &render(&leg.name, &d.report, &dir);
                done.reports.push(serde_json::to_value(&doc)?);
            }
            Err(e) => done.failed.push(format!("leg {}: {e}", leg.name)),
        }
    }
    if !single && !done.reports.is_empty() {
        write_index(&a.out, &legs, &done.reports)?;
    }
    Ok(done)
}

#[derive(serde::Serialize)]
struct LegReport<'a> {
    leg: &'a str,
    log: &'a str,
    #[serde(flatten)]
    report: &'a Report,
}

/// Diagnoses every leg, two at a time on a two-core machine.
fn diagnose_all(legs: &[LegLog], opts: &DiagnoseOptions) -> Vec<Result<Diagnosis, String>> {
    let threads = std::thread::available_parallelism()
        .map_or(2, |n| n.get())
        .min(legs.len().max(1));
    let next = std::sync::atomic::AtomicUsize::new(0);
    let out: Vec<std::sync::Mutex<Option<Result<Diagnosis, String>>>> =
        legs.iter().map(|_| std::sync::Mutex::new(None)).collect();
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some(leg) = legs.get(i) else { break };
                    let r = diagnose(&leg.model, &leg.samples, opts).map_err(|e| e.to_string());
                    *out[i].lock().expect("one writer per slot") = Some(r);
                }
            });
        }
    });
    out.into_iter()
        .map(|m| {
            m.into_inner()
                .ok()
                .flatten()
                .unwrap_or_else(|| Err("not run".to_string()))
        })
        .collect()
}

fn render(leg: &str, r: &Report, dir: &Path) -> String {
    let mut s = format!(
        "leg {leg}: verdict {}{}\n",
        r.verdict.effect,
        if r.steps.is_empty() {
            String::new()
        } else {
            format!(
                " (closes {:.0} % of the gap; held-out Psi {:.3} -> {:.3})",
                r.verdict.gap_closed_pct, r.verdict.heldout_psi_before, r.verdict.heldout_psi_after
            )
        }
    );
    s += &format!(
        "  baseline b_k {:.4}, a {:.4}; held-out RMSE {:.3} N against noise {:.3} N\n",
        r.baseline.b_k,
        r.baseline.a,
        r.baseline.rmse_n,
        r.gap.noise_var_n2.sqrt()
    );
    for st in r.steps.iter().skip(1) {
        s += &format!(
            "  then {}: {:.0} % of the gap closed in all\n",
            st.effect, st.gap_closed_pct
        );
    }
    s += &format!("  report: {}\n", dir.join("report.html").display());
    s
}

fn write_index(out: &Path, legs: &[LegLog], reports: &[serde_json::Value]) -> Result<()> {
    let index: Vec<serde_json::Value> = reports
        .iter()
        .map(|r| {
            serde_json::json!({
                "leg": r["leg"],
                "verdict": r["verdict"],
                "report": format!("{}/report.json", r["leg"].as_str().unwrap_or("")),
            })
        })
        .collect();
    let body = serde_json::to_string_pretty(&serde_json::json!({ "legs": index }))? + "\n";
    write_atomically(&out.join("report.json"), |w| {
        Ok(w.write_all(body.as_bytes())?)
    })?;
    let mut page = String::from(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>terzaghi diagnosis</title></head><body style=\"font-family:sans-serif\">\n<h1>Sim-to-real gap, every leg</h1>\n<ul>\n",
    );
    for r in reports {
        let leg = r["leg"].as_str().unwrap_or("");
        page += &format!(
            "<li><a href=\"{leg}/report.html\">{leg}</a>: {}</li>\n",
            r["verdict"]["effect"].as_str().unwrap_or("")
        );
    }
    page += &format!("</ul><p>{} legs.</p></body></html>\n", legs.len());
    write_atomically(&out.join("report.html"), |w| {
        Ok(w.write_all(page.as_bytes())?)
    })
}

fn plate_from_flags(a: &DiagnoseArgs) -> Result<Plate> {
    match (a.length_m, a.width_m, a.hip_height_m) {
        (Some(l), Some(b), Some(h)) => Ok(Plate::new(l, b, h)?),
        _ => bail!(
            "give the leg's geometry: --length-m, --width-m and --hip-height-m (and the medium: --medium or --unit-weight-n-m3 --phi-deg --delta-deg)"
        ),
    }
}

fn from_csv(a: &DiagnoseArgs) -> Result<Vec<LegLog>> {
    if a.joint.is_some() || a.params_file.is_some() {
        bail!(
            "{} is not an MCAP file: --joint, --wrench-topic and --params-file are for MCAP sessions; a CSV log takes the geometry and medium flags",
            a.log.display()
        );
    }
    let plate = plate_from_flags(a)?;
    let medium = a.medium.medium()?.medium;
    let samples = read_samples_csv(&a.log)?;
    Ok(vec![LegLog {
        name: a.leg.clone().unwrap_or_else(|| {
            a.log
                .file_stem()
                .map_or("leg".to_string(), |s| s.to_string_lossy().into_owned())
        }),
        model: TerzaghiModel::conventional(plate, medium),
        samples,
    }])
}

fn from_mcap(a: &DiagnoseArgs, source: Source, head: Scan) -> Result<Vec<LegLog>> {
    if !head.complete {
        bail!(
            "{} is cut off ({}): recover it first with `terzaghi recover {} -o FIXED.mcap`",
            a.log.display(),
            head.stopped.as_deref().unwrap_or("no footer"),
            a.log.display()
        );
    }
    let cfg = match &a.joint {
        Some(joint) => joint_config(a, joint)?,
        None => {
            if a.length_m.is_some() || a.width_m.is_some() || a.hip_height_m.is_some() {
                bail!(
                    "the geometry flags go with --joint (or a CSV log); for a recorded session, change the geometry with --params-file"
                );
            }
            reevaluation_config(&a.params_file, &head, &a.log)?
        }
    };
    let chosen: Vec<usize> = match &a.leg {
        Some(name) => match cfg.legs.iter().position(|l| &l.name == name) {
            Some(i) => vec![i],
            None => bail!(
                "no leg named {name:?} in the parameters (legs: {})",
                cfg.legs
                    .iter()
                    .map(|l| l.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        },
        None => (0..cfg.legs.len())
            .filter(|&i| cfg.legs[i].ft_topic.is_some())
            .collect(),
    };
    if chosen.is_empty() || chosen.iter().any(|&i| cfg.legs[i].ft_topic.is_none()) {
        bail!(
            "no leg to diagnose has an F/T topic in the parameters (set <leg>.ft_topic, or use --joint and --wrench-topic)"
        );
    }
    let (mut samples, read) =
        measured_samples(source, cfg.clone()).with_context(|| a.log.display().to_string())?;
    if !read.complete {
        bail!(
            "{} is damaged ({}): recover it first with `terzaghi recover {} -o FIXED.mcap`",
            a.log.display(),
            read.stopped.as_deref().unwrap_or("reading stopped early"),
            a.log.display()
        );
    }
    let topics: Vec<String> = head.topics.iter().map(|t| t.topic.clone()).collect();
    let mut legs = Vec::new();
    for i in chosen {
        let leg = &cfg.legs[i];
        let s = std::mem::take(&mut samples[i]);
        if s.is_empty() {
            bail!(
                "leg {}: no F/T sample on {} matched a joint angle of {} on {} (topics in the file: {})",
                leg.name,
                leg.ft_topic.as_deref().unwrap_or("?"),
                leg.joint,
                cfg.joint_states_topic,
                topics.join(", ")
            );
        }
        legs.push(LegLog {
            name: leg.name.clone(),
            model: TerzaghiModel::conventional(leg.plate, leg.medium),
            samples: s,
        });
    }
    Ok(legs)
}

/// One leg from the flags, for a ROS 2 MCAP without our parameters.
fn joint_config(a: &DiagnoseArgs, joint: &str) -> Result<NodeConfig> {
    let plate = plate_from_flags(a)?;
    let chosen = a.medium.medium()?;
    let name = a.leg.clone().unwrap_or_else(|| "leg".to_string());
    let mut p = defaults();
    let mut put = |k: String, v: ParamValue| {
        p.insert(k, v);
    };
    put("legs".into(), ParamValue::StringArray(vec![name.clone()]));
    put(
        "joint_states_topic".into(),
        ParamValue::String(a.joint_states_topic.clone()),
    );
    put(
        format!("{name}.joint"),
        ParamValue::String(joint.to_string()),
    );
    put(format!("{name}.direction"), ParamValue::Double(a.direction));
    put(
        format!("{name}.angle_offset_rad"),
        ParamValue::Double(a.angle_offset_rad),
    );
    put(
        format!("{name}.length_m"),
        ParamValue::Double(plate.length_m()),
    );
    put(
        format!("{name}.width_m"),
        ParamValue::Double(plate.width_m()),
    );
    put(
        format!("{name}.hip_height_m"),
        ParamValue::Double(plate.hip_height_m()),
    );
    let m = chosen.medium;
    put(
        format!("{name}.unit_weight_n_m3"),
        ParamValue::Double(m.unit_weight_n_m3()),
    );
    put(format!("{name}.phi_deg"), ParamValue::Double(m.phi_deg()));
    put(
        format!("{name}.delta_deg"),
        ParamValue::Double(m.delta_deg()),
    );
    put(
        format!("{name}.ft_topic"),
        ParamValue::String(a.wrench_topic.clone().unwrap_or_default()),
    );
    put(
        format!("{name}.ft_frame"),
        ParamValue::String(a.ft_frame.clone()),
    );
    Ok(NodeConfig::from_params(&p, "terzaghi", "/", &[])?)
}
