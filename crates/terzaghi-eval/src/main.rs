//! `terzaghi-eval`: the checks of terzaghi's diagnosis and models (the figures of its docs).

use clap::{Parser, Subcommand};

#[derive(Debug, Parser)]
#[command(
    name = "terzaghi-eval",
    version,
    about = "The checks of terzaghi's diagnosis and models: generated sessions with withheld effects, the closed loop on held-out strokes, the DEM campaign"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Check the diagnosis on generated sessions whose hidden effect it is not told (and on
    /// the DEM campaign's cases), close the loop on held-out strokes, or learn the corrections
    /// online
    DiagnoseEval(terzaghi_eval::diagnose_eval::DiagnoseEvalArgs),
    /// The models against a DEM campaign: the testbed's checks, fidelity of the improved and
    /// conventional models and of RFT, the variations
    DemReport(terzaghi_eval::dem_report::DemReportArgs),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let r = match cli.command {
        Command::DiagnoseEval(a) => terzaghi_eval::diagnose_eval::run_cmd(a),
        Command::DemReport(a) => terzaghi_eval::dem_report::report(a),
    };
    match r {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::from(terzaghi::error::exit_code(&e))
        }
    }
}
