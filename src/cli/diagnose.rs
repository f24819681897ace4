//! `terzaghi diagnose`: where the model and the measurements part, which unmodelled effect is
//! responsible, and how far the gap shrinks with it (the work is [`terzaghi::session::diagnose`]).

use super::{MediumArgs, OptionalPlateArgs, print_out};
use anyhow::{Result, bail};
use clap::Args;
use std::path::{Path, PathBuf};
use terzaghi::config::FtFrame;
use terzaghi::diagnose::{DiagnoseOptions, Report};
use terzaghi::model::Plate;
use terzaghi::session::diagnose::{
    DiagnoseFileOptions, Diagnosed, Written, diagnose_file, write_reports,
};
use terzaghi::session::legs::{JointLeg, LegsFrom};

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
    /// The leg's geometry: for a CSV log, and for a session's leg with --joint.
    #[command(flatten)]
    pub plate: OptionalPlateArgs,
    #[command(flatten)]
    pub medium: MediumArgs,
    /// Folds of whole strokes for the held-out scores.
    #[arg(long, default_value_t = 5)]
    pub folds: usize,
    /// The medium is known to be cohesive (moist sand, clay): a cohesion term found by its form
    /// alone is reported as cohesion, rather than as "cohesion, or the model's own misfit".
    #[arg(long)]
    pub cohesive: bool,
    /// The smallest gap a verdict may explain (N, RMS beyond the noise): a smaller gap, or one
    /// within the sensor's quantisation step, is "no gap to explain" (verdict none).
    #[arg(long, value_name = "N", allow_negative_numbers = true, default_value_t = DiagnoseOptions::default().min_gap_n)]
    pub min_gap_n: f64,
    /// Print the report(s) as JSON instead of a text summary.
    #[arg(long)]
    pub json: bool,
    /// For a plate-sinkage test (a CSV of `terzaghi calibrate`'s kinds): the medium file it is
    /// judged against, calibrated on other tests.
    #[arg(long, value_name = "FILE")]
    pub medium_file: Option<PathBuf>,
    /// For a plate-sinkage test that is a plain log: its plate, a disc of this diameter (m).
    #[arg(
        long,
        value_name = "M",
        allow_negative_numbers = true,
        requires = "medium_file"
    )]
    pub plate_diameter_m: Option<f64>,
    /// For a wheel's or a foot's test (a CSV of `terzaghi steady`'s runs with the measured
    /// sinkage_m and drawbar_n, at any slip and slip angle): its body (with --radius-m,
    /// --width-m, grousers, as `terzaghi steady` takes them), judged against --medium-file.
    #[arg(long, value_enum, value_name = "SHAPE")]
    pub shape: Option<super::steady::BodyShape>,
    #[command(flatten)]
    pub body: super::steady::BodyArgs,
}

pub fn run(a: DiagnoseArgs) -> Result<()> {
    if a.shape.is_some() || terzaghi::session::wheel_test::is_wheel_test(&a.log) {
        return wheel_test(&a);
    }
    if !a.body.given().is_empty() {
        bail!(
            "{} describe a body: give its --shape, for a wheel's or a foot's runs",
            a.body.given().join(", ")
        );
    }
    if terzaghi::session::plate_test::is_plate_test(&a.log) {
        return plate_test(&a);
    }
    if a.medium_file.is_some() {
        bail!(
            "--medium-file is for a plate-sinkage test (a CSV of time_s, depth_m, fz_n or t_s, depth_m, force_n); {} is not one",
            a.log.display()
        );
    }
    let (diagnosed, written) = diagnose_to_dir(&a)?;
    let reports: Vec<serde_json::Value> = written.reports.iter().map(|(_, r)| r.clone()).collect();
    if a.json {
        let v = match (written.single, reports.as_slice()) {
            (true, [one]) => one.clone(),
            _ => serde_json::Value::Array(reports.clone()),
        };
        print_out(&(serde_json::to_string_pretty(&v)? + "\n"))?;
    } else {
        print_out(&summary_text(&diagnosed, &written))?;
    }
    if !written.failed.is_empty() {
        bail!("cannot diagnose {}", written.failed.join("; "));
    }
    Ok(())
}

/// The options the flags ask for; flags that do not go together are refused here.
fn options(a: &DiagnoseArgs) -> Result<DiagnoseFileOptions> {
    if a.folds < 2 {
        bail!("--folds must be at least 2, got {}", a.folds);
    }
    if !(a.min_gap_n.is_finite() && a.min_gap_n >= 0.0) {
        bail!("--min-gap-n must be a number >= 0 (N), got {}", a.min_gap_n);
    }
    let geometry_given = a.plate.any();
    let mut opts = DiagnoseFileOptions {
        leg: a.leg.clone(),
        analysis: DiagnoseOptions {
            folds: a.folds,
            cohesive_medium: a.cohesive,
            min_gap_n: a.min_gap_n,
            ..Default::default()
        },
        ..Default::default()
    };
    // Which kind of file the log is, the library tells (and refuses the other kind's flags).
    opts.legs_from = match (&a.joint, &a.params_file) {
        (Some(joint), _) => {
            let Some(ft_frame) = FtFrame::from_name(&a.ft_frame) else {
                bail!("--ft-frame {:?}: expected hip or leg", a.ft_frame);
            };
            LegsFrom::Joint(Box::new(JointLeg {
                name: a.leg.clone().unwrap_or_else(|| "leg".to_string()),
                joint: joint.clone(),
                joint_states_topic: a.joint_states_topic.clone(),
                wrench_topic: a.wrench_topic.clone().unwrap_or_default(),
                ft_frame,
                direction: a.direction,
                angle_offset_rad: a.angle_offset_rad,
                plate: plate_from_flags(a)?,
                medium: a.medium.medium()?.medium,
            }))
        }
        (None, Some(p)) => LegsFrom::ParamsFile(p.clone()),
        (None, None) => LegsFrom::Recorded,
    };
    if a.joint.is_none() && geometry_given {
        // A CSV log's leg; a session refuses it.
        opts.csv_leg = Some((plate_from_flags(a)?, a.medium.medium()?.medium));
    }
    Ok(opts)
}

/// Diagnoses the log the flags name and writes its reports into `--out`.
pub fn diagnose_to_dir(a: &DiagnoseArgs) -> Result<(Diagnosed, Written)> {
    let inputs: Vec<&Path> = std::iter::once(a.log.as_path())
        .chain(a.params_file.as_deref())
        .collect();
    terzaghi::session::files::refuse_output_over_input(&a.out, &inputs)?;
    if a.json {
        terzaghi::session::files::refuse_stdout_over_input(&inputs)?;
    }
    let d = diagnose_file(&a.log, &options(a)?)?;
    // The log is checked against the reports by write_reports; the parameters file here.
    if let Some(params) = &a.params_file {
        for path in terzaghi::session::diagnose::report_paths(&d, &a.out) {
            terzaghi::session::files::refuse_output_over_input(&path, &[params])?;
        }
    }
    let w = write_reports(&d, &a.out)?;
    Ok((d, w))
}

/// A few lines per diagnosed leg, and where its report is.
pub fn summary_text(d: &Diagnosed, w: &Written) -> String {
    let diagnosed = d
        .legs
        .iter()
        .filter_map(|l| l.result.as_ref().ok().map(|r| (&l.leg, r)));
    diagnosed
        .zip(&w.reports)
        .map(|((leg, r), (dir, _))| render(leg, &r.report, dir))
        .collect()
}

fn render(leg: &str, r: &Report, dir: &Path) -> String {
    let mut s = format!(
        "leg {leg}: verdict {}{}\n",
        r.verdict.effect,
        if r.steps.is_empty() {
            if r.verdict.effect == terzaghi::diagnose::VerdictEffect::None {
                format!(" ({})", r.verdict.claim)
            } else {
                String::new()
            }
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
    if r.hip_placed_points > 0 {
        s += &format!(
            "  the hip where the recorded robot's state put it at {} of {} analysed samples\n",
            r.hip_placed_points, r.analysed
        );
    }
    if !r.steps.is_empty() {
        s += &format!(
            "  significant effects: {}\n",
            r.steps
                .iter()
                .map(|st| format!("{} {:.0} % ({})", st.effect, st.share_of_gap_pct, st.claim))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    if let Some(u) = &r.unexplained {
        s += &format!(
            "  unexplained: {:.0} % of the gap (held-out RMSE {:.3} N once the effects are modelled)\n",
            u.share_of_gap_pct, u.heldout_rmse_n
        );
    }
    s += &format!("  report: {}\n", dir.join("report.html").display());
    if !r.corrected_model_left_out.is_empty() {
        s += &format!(
            "  left out of the corrected model: {}\n",
            r.corrected_model_left_out.join("; ")
        );
    }
    if let Some(why) = &r.corrected_model_refit_refused {
        s += &format!(
            "  corrected model: its fit on every sample was refused ({why}); the values fitted on the {} samples analysed are written\n",
            r.corrected_model_fit_samples
        );
    }
    s
}

fn plate_from_flags(a: &DiagnoseArgs) -> Result<Plate> {
    // No warning for a plate that never reaches the medium: the diagnosis refuses it anyway.
    match a.plate.all() {
        Some(p) => Ok(Plate::new(p.length_m, p.width_m, p.hip_height_m)?),
        None => bail!(
            "give all of the leg's geometry: --length-m, --width-m and --hip-height-m (and the medium: --medium or --unit-weight-n-m3 --phi-deg --delta-deg), for a CSV log or a session's leg with --joint"
        ),
    }
}

/// A plate-sinkage test judged against a calibrated medium; report.json in --out.
fn plate_test(a: &DiagnoseArgs) -> Result<()> {
    use terzaghi::model::sinkage::PlateShape;
    use terzaghi::session::plate_test::{diagnose_test_to_dir, diagnosis_text};
    let Some(medium_file) = &a.medium_file else {
        bail!(
            "{} is a plate-sinkage test: give the medium to judge it against with --medium-file (written by terzaghi calibrate on other tests)",
            a.log.display()
        );
    };
    if a.json {
        terzaghi::session::files::refuse_stdout_over_input(&[
            a.log.as_path(),
            medium_file.as_path(),
        ])?;
    }
    let plate = a.plate_diameter_m.map(PlateShape::disc).transpose()?;
    let (d, json) = diagnose_test_to_dir(&a.log, medium_file, plate, &a.out)?;
    if a.json {
        print_out(&json)
    } else {
        print_out(
            &(diagnosis_text(&d) + &format!("wrote {}\n", a.out.join("report.json").display())),
        )
    }
}

/// A wheel's or a foot's runs judged against a calibrated medium; report.json (and the medium
/// with the effect found, where a medium file takes it) in --out.
fn wheel_test(a: &DiagnoseArgs) -> Result<()> {
    use terzaghi::session::wheel_test::{diagnose_runs, wheel_diagnosis_text, write_wheel_report};
    let Some(shape) = a.shape else {
        bail!(
            "{} is a body's runs (load_n, hub_vx_m_s, ...): give its body with --shape wheel --radius-m R --width-m B (and grousers), and the medium with --medium-file",
            a.log.display()
        );
    };
    let Some(medium_file) = &a.medium_file else {
        bail!(
            "{} is a body's runs: give the medium to judge it against with --medium-file (written by terzaghi calibrate)",
            a.log.display()
        );
    };
    for (flag, given) in [
        ("--length-m", a.plate.length_m.is_some()),
        ("--hip-height-m", a.plate.hip_height_m.is_some()),
        ("--plate-diameter-m", a.plate_diameter_m.is_some()),
        ("--params-file", a.params_file.is_some()),
        ("--joint", a.joint.is_some()),
    ] {
        if given {
            bail!("{flag} is for a leg's session or a plate test, not a body's runs (--shape)");
        }
    }
    if a.json {
        terzaghi::session::files::refuse_stdout_over_input(&[
            a.log.as_path(),
            medium_file.as_path(),
        ])?;
    }
    let body = a.body.body(&shape.name(), a.plate.width_m)?;
    let text = a.body.text(shape, a.plate.width_m);
    let d = diagnose_runs(&a.log, medium_file, &body, &text, &Default::default())?;
    let json = write_wheel_report(&d, &a.out)?;
    if a.json {
        print_out(&json)
    } else {
        print_out(&wheel_diagnosis_text(&d, &a.out))
    }
}
