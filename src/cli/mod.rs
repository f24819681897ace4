//! The `terzaghi` command line: each command parses its flags, calls the library (mostly
//! [`terzaghi::session`]), prints what it returns, and maps errors to the exit code 2.

mod calibrate;
mod dem;
mod demo;
mod diagnose;
mod fit;
mod identify;
mod log_source;
mod mcap_tools;
mod media;
mod node;
mod param;
mod predict;
mod record;
mod replay;
mod simulate;
mod simulate_robot;
mod steady;

use anyhow::Result;
use clap::{Args, Parser, Subcommand};
use terzaghi::model::{FittingWidth, Plate};

/// Forces on flat legs rotating through sand and other granular media.
#[derive(Debug, Parser)]
#[command(name = "terzaghi", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    /// The command to run.
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// The whole job in one command: a simulated six-legged robot walks, the node predicts and
    /// learns the medium online and records the session, the recording is diagnosed.
    Demo(demo::DemoArgs),
    /// Write a run of the DEM testbed (tests/dem/campaign.py) as a ROS 2 MCAP session; a run
    /// that never touched the bed, has a non-finite force or whose bed did not settle is refused.
    ImportDem(dem::ImportDemArgs),
    /// Predict drag, lift and hip torque over a range of attack angles.
    Predict(predict::PredictArgs),
    /// Fit b_k and a (and delta) to measured forces in a CSV file, batch (Eq. 26).
    Fit(fit::FitArgs),
    /// Identify b_k and a (and delta) from a CSV log: batch, or replayed through the online
    /// estimator with --online.
    Identify(identify::IdentifyArgs),
    /// Run the ROS 2 node: joint angles in, predicted wrenches out, online identification from
    /// F/T topics.
    Node(node::NodeArgs),
    /// Get or set a running node's parameters (like `ros2 param`).
    Param(param::ParamArgs),
    /// Topics, types, message counts, duration of an MCAP session, and whether it is complete.
    Info(mcap_tools::InfoArgs),
    /// Write a valid copy of a cut-off MCAP file, keeping every complete message.
    Recover(mcap_tools::RecoverArgs),
    /// Record topics this project knows to an MCAP file, without running the model.
    Record(record::RecordArgs),
    /// Republish a session over DDS with its recorded timing, or re-evaluate it offline
    /// (--reevaluate) through the model and the estimator.
    Replay(replay::ReplayArgs),
    /// List the medium presets with their values and provenance, and any medium files given.
    Media(media::MediaArgs),
    /// Fit a medium's plate-sinkage laws (Terzaghi's footing, Bekker, Reece, RFT with a depth
    /// exponent, a power law in depth and width) to plate-sinkage tests and write a medium file.
    Calibrate(calibrate::CalibrateArgs),
    /// A wheel's or a foot's steady sinkage, drawbar pull, side force and drive torque under
    /// each run's load, hub speed, rotation rate and slip angle (CSV in, CSV out). Every run is
    /// a row; a run the sand does not bear within the body's height says so (`borne` false,
    /// named on standard error), and the command then exits 3.
    Steady(steady::SteadyArgs),
    /// Write a synthetic session (one leg in continuous rotation, with sensor noise) as CSV.
    Simulate(simulate::SimulateArgs),
    /// Write a recording (MCAP) of the simulated six-legged robot walking with a heaving,
    /// pitching, advancing body, its hips on /tf.
    SimulateRobot(simulate_robot::SimulateRobotArgs),
    /// Diagnose the sim-to-real gap of a session: where model and measurement part, which
    /// unmodelled effect causes it, how far the gap shrinks with it (report.json, report.html).
    Diagnose(diagnose::DiagnoseArgs),
    /// Print every command's flags as the Markdown reference of docs/command-line.md.
    #[command(hide = true)]
    HelpMarkdown,
}

/// Every command and its flags, from clap's own definitions, as Markdown: the reference in
/// `docs/command-line.md` (a test keeps the two the same).
pub fn help_markdown() -> String {
    use clap::CommandFactory;
    fn cell(s: &str) -> String {
        s.split_whitespace()
            .collect::<Vec<_>>()
            .join(" ")
            .replace('|', "\\|")
    }
    fn one(cmd: &clap::Command, path: &str, out: &mut String) {
        let subs: Vec<&clap::Command> = cmd
            .get_subcommands()
            .filter(|c| !c.is_hide_set() && c.get_name() != "help")
            .collect();
        if !subs.is_empty() {
            for c in subs {
                one(c, &format!("{path} {}", c.get_name()), out);
            }
            return;
        }
        out.push_str(&format!("### `{path}`\n\n"));
        if let Some(about) = cmd.get_about() {
            out.push_str(&format!("{}\n\n", cell(&about.to_string())));
        }
        out.push_str("| argument | meaning |\n|---|---|\n");
        for a in cmd.get_arguments() {
            let id = a.get_id().as_str();
            if a.is_hide_set() || id == "help" || id == "version" {
                continue;
            }
            let value = a
                .get_value_names()
                .map(|v| {
                    v.iter()
                        .map(|n| format!("<{n}>"))
                        .collect::<Vec<_>>()
                        .join(" ")
                })
                .unwrap_or_default();
            let takes_value = a.get_num_args().is_some_and(|n| n.takes_values());
            let name = match (a.get_long(), a.get_short()) {
                (Some(l), Some(s)) => format!("-{s}, --{l}"),
                (Some(l), None) => format!("--{l}"),
                (None, Some(s)) => format!("-{s}"),
                (None, None) => String::new(),
            };
            let shown = match (name.is_empty(), takes_value) {
                (true, _) => value.clone(),
                (false, true) => format!("{name} {value}"),
                (false, false) => name,
            };
            let mut meaning = a
                .get_help()
                .map(|h| cell(&h.to_string()))
                .unwrap_or_default();
            let defaults: Vec<String> = a
                .get_default_values()
                .iter()
                .map(|d| d.to_string_lossy().into_owned())
                .collect();
            let possible: Vec<String> = a
                .get_possible_values()
                .iter()
                .filter(|p| !p.is_hide_set())
                .map(|p| format!("`{}`", p.get_name()))
                .collect();
            if !possible.is_empty() && takes_value {
                meaning.push_str(&format!(" (one of {})", possible.join(", ")));
            }
            if !defaults.is_empty() && takes_value {
                meaning.push_str(&format!(" (default: {})", cell(&defaults.join(", "))));
            }
            out.push_str(&format!("| `{}` | {meaning} |\n", shown.trim()));
        }
        out.push('\n');
    }
    let mut out = String::new();
    let mut cli = Cli::command();
    cli.build();
    one(&cli, "terzaghi", &mut out);
    out
}

/// Runs a parsed command. Errors are for the user: `main` prints them on one line, exit code 2.
/// An error as the command line prints it: its chain joined by ": ", as `{:#}` prints it, with
/// each [`Refusal`](terzaghi::session::Refusal) of the library worded in the flag that answers it.
pub fn worded(e: &anyhow::Error) -> String {
    use terzaghi::session::Refusal;
    e.chain()
        .map(|c| match c.downcast_ref::<Refusal>() {
            Some(Refusal::RecordingExists { path }) => format!(
                "{} exists: a recording is not overwritten (pass --overwrite to replace it)",
                path.display()
            ),
            Some(Refusal::NoRecordedParameters { file }) => format!(
                "{} has no recorded node parameters (it was not recorded by terzaghi node): pass --params-file",
                file.display()
            ),
            Some(Refusal::CsvWithoutParameters { file }) => format!(
                "{} is a CSV log, which carries no node parameters: pass --params-file (a corrected.yaml of terzaghi diagnose, or the robot's parameters)",
                file.display()
            ),
            Some(Refusal::CsvWithoutGeometry { file }) => format!(
                "{} is a CSV log: give the leg's geometry (--length-m, --width-m, --hip-height-m) and medium (--medium, or --unit-weight-n-m3 --phi-deg --delta-deg)",
                file.display()
            ),
            Some(Refusal::GeometryForSession { .. }) => "the geometry flags go with --joint (or a CSV log); for a recorded session, change the geometry with --params-file".to_string(),
            Some(Refusal::SessionOptionsForCsv { file }) => format!(
                "{} is not an MCAP file: --joint, --wrench-topic and --params-file are for MCAP sessions; a CSV log takes the geometry and medium flags",
                file.display()
            ),
            Some(Refusal::NoLegWithFt) => "no leg has an F/T topic in the parameters (set <leg>.ft_topic, or use --joint and --wrench-topic)".to_string(),
            Some(Refusal::SeveralLegs { legs }) => format!(
                "the session has several legs with F/T topics ({}): choose one with --leg",
                legs.join(", ")
            ),
            Some(r @ (Refusal::OutputIsInput { .. } | Refusal::StdoutIsInput { .. })) => {
                r.to_string()
            }
            None => c.to_string(),
        })
        .collect::<Vec<_>>()
        .join(": ")
}

pub use terzaghi::error::exit_code;

/// Runs one `terzaghi` command: what `main` does after parsing.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::HelpMarkdown => print_out(&help_markdown()),
        Command::Demo(a) => demo::run(a),
        Command::ImportDem(a) => dem::import(a),
        Command::Predict(a) => predict::run(a),
        Command::Fit(a) => fit::run(a),
        Command::Identify(a) => identify::run(a),
        Command::Info(a) => mcap_tools::info(a),
        Command::Recover(a) => mcap_tools::recover_cmd(a),
        Command::Record(a) => record::run(a),
        Command::Replay(a) => replay::run(a),
        Command::Media(a) => media::run(a),
        Command::Calibrate(a) => calibrate::run(a),
        Command::Steady(a) => steady::run(a),
        Command::Node(a) => node::run(a),
        Command::Param(a) => param::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::SimulateRobot(a) => simulate_robot::run(a),
        Command::Diagnose(a) => diagnose::run(a),
    }
}

/// The leg's geometry.
#[derive(Debug, Clone, Args)]
pub struct PlateArgs {
    /// Plate length from the hip axis to the tip (m).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub length_m: f64,
    /// Plate width (m).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub width_m: f64,
    /// Height of the hip axis above the free surface (m); 0 puts the axis on the surface.
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub hip_height_m: f64,
}

impl PlateArgs {
    pub fn plate(&self) -> Result<Plate> {
        terzaghi::model_spec::plate(self.length_m, self.width_m, self.hip_height_m)
    }
}

/// The leg's geometry where a log may carry it instead (a session's parameters): a CSV log
/// needs all three flags.
#[derive(Debug, Clone, Args)]
pub struct OptionalPlateArgs {
    /// Plate length from the hip axis to the tip (m), for a CSV log.
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub length_m: Option<f64>,
    /// Plate width (m), for a CSV log.
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub width_m: Option<f64>,
    /// Height of the hip axis above the free surface (m), for a CSV log; 0 puts the axis on
    /// the surface.
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub hip_height_m: Option<f64>,
}

impl OptionalPlateArgs {
    /// Whether any of the three was given.
    pub fn any(&self) -> bool {
        self.length_m.is_some() || self.width_m.is_some() || self.hip_height_m.is_some()
    }

    /// All three, as [`PlateArgs`]; `None` unless all three were given.
    pub fn all(&self) -> Option<PlateArgs> {
        Some(PlateArgs {
            length_m: self.length_m?,
            width_m: self.width_m?,
            hip_height_m: self.hip_height_m?,
        })
    }
}

/// The medium: a preset, or custom soil values.
#[derive(Debug, Clone, Args)]
pub struct MediumArgs {
    /// A medium preset (see `terzaghi media`).
    #[arg(long, value_name = "NAME", conflicts_with_all = ["unit_weight_n_m3", "phi_deg", "delta_deg"])]
    pub medium: Option<String>,
    /// Custom medium: unit weight lambda (N/m^3).
    #[arg(long, value_name = "W", requires_all = ["phi_deg", "delta_deg"], allow_negative_numbers = true)]
    pub unit_weight_n_m3: Option<f64>,
    /// Custom medium: internal friction angle phi (deg).
    #[arg(long, value_name = "DEG", requires_all = ["unit_weight_n_m3", "delta_deg"], allow_negative_numbers = true)]
    pub phi_deg: Option<f64>,
    /// Custom medium: plate-medium friction angle delta (deg).
    #[arg(long, value_name = "DEG", requires_all = ["unit_weight_n_m3", "phi_deg"], allow_negative_numbers = true)]
    pub delta_deg: Option<f64>,
}

pub use terzaghi::model_spec::ChosenMedium;

impl MediumArgs {
    /// The medium spec the flags name (clap has checked that they go together).
    pub fn spec(&self) -> terzaghi::model_spec::MediumSpec {
        terzaghi::model_spec::MediumSpec {
            preset: self.medium.clone(),
            unit_weight_n_m3: self.unit_weight_n_m3,
            phi_deg: self.phi_deg,
            delta_deg: self.delta_deg,
            file: None,
        }
    }

    pub fn medium(&self) -> Result<ChosenMedium> {
        self.spec().medium()
    }
}

/// `--bk` and `--a`, given together.
#[derive(Debug, Clone, Args)]
pub struct WidthArgs {
    /// Fitting width parameter b_k of Eq. (11) (default: the medium preset's).
    #[arg(
        long = "bk",
        value_name = "K",
        requires = "a",
        allow_negative_numbers = true
    )]
    pub b_k: Option<f64>,
    /// Fitting width parameter a of Eq. (11) (default: the medium preset's).
    #[arg(
        long,
        value_name = "A",
        requires = "b_k",
        allow_negative_numbers = true
    )]
    pub a: Option<f64>,
}

impl WidthArgs {
    /// The fitting width from the flags, else from the preset for this plate width.
    pub fn fitting_width(&self, chosen: &ChosenMedium, plate: &Plate) -> Result<FittingWidth> {
        terzaghi::model_spec::fitting_width(self.b_k, self.a, chosen, plate)
    }
}

pub use terzaghi::model_spec::terzaghi_model;

pub use terzaghi::session::files::print_out;

#[cfg(test)]
mod tests {
    use super::*;
    use terzaghi::session::Refusal;

    /// The library's refusals carry no flag; the command line names the one that answers each,
    /// also under a context.
    #[test]
    fn refusals_are_worded_in_the_flags_that_answer_them() {
        let e = anyhow::Error::from(Refusal::SeveralLegs {
            legs: vec!["front_left".into(), "rear_left".into()],
        });
        assert!(!e.to_string().contains("--leg"), "{e}");
        assert_eq!(
            worded(&e),
            "the session has several legs with F/T topics (front_left, rear_left): choose one with --leg"
        );
        let e = anyhow::Error::from(Refusal::RecordingExists {
            path: "out.mcap".into(),
        })
        .context("cannot record");
        assert!(!format!("{e:#}").contains("--overwrite"));
        assert_eq!(
            worded(&e),
            "cannot record: out.mcap exists: a recording is not overwritten (pass --overwrite to replace it)"
        );
        // Every refusal: the library's words name no flag, the command line's name one.
        let all = [
            Refusal::RecordingExists { path: "a".into() },
            Refusal::NoRecordedParameters { file: "a".into() },
            Refusal::CsvWithoutParameters { file: "a".into() },
            Refusal::CsvWithoutGeometry { file: "a".into() },
            Refusal::GeometryForSession { file: "a".into() },
            Refusal::SessionOptionsForCsv { file: "a".into() },
            Refusal::NoLegWithFt,
            Refusal::SeveralLegs {
                legs: vec!["a".into(), "b".into()],
            },
        ];
        for r in all {
            assert!(!r.to_string().contains("--"), "{r}");
            let cli = worded(&anyhow::Error::from(r.clone()));
            assert!(cli.contains(" --"), "{r:?}: {cli}");
        }
        let plain = anyhow::anyhow!("disk full").context("cannot write x.csv");
        assert_eq!(worded(&plain), format!("{plain:#}"));
    }
}
