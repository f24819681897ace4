//! `terzaghi-bench`: how fast `terzaghi` is on this machine. Kept apart from the product's
//! binary; each subcommand measures what the README's performance table reports.
//!
//! - `model`: one evaluation of each model, and RFT against the improved model in one run.
//! - `node`: the node's latency for 6 legs at 1 kHz against a bare DDS echo (`echo`), or a load
//!   test; run it inside a private network namespace.
//! - `record`: writing sessions and re-evaluating them.
//! - `diagnose`: the diagnosis of a long six-legged session.

mod diagnose;
mod model;
mod node;
mod record;

use anyhow::{Context as _, Result};
use clap::{Parser, Subcommand};
use std::process::ExitCode;
// Writes to stdout as `terzaghi` does: a closed pipe (`| head`) ends the command quietly.
use terzaghi::session::files::print_out;

#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Measures terzaghi on this machine: the model, the node, the recorder and the diagnosis, as the
/// README's Benchmarks table reports them.
#[derive(Debug, Parser)]
#[command(name = "terzaghi-bench", version)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// The speed of one model evaluation, and RFT against the improved model in one run.
    Model(model::BenchArgs),
    /// The node's latency for 6 legs at 1 kHz against a bare DDS echo, or a load test (run it
    /// inside a private network namespace or on a network you may load).
    Node(node::BenchNodeArgs),
    /// A bare DDS echo node, for `node`.
    #[command(hide = true)]
    Echo(node::EchoArgs),
    /// Writing sessions and re-evaluating them: messages per second, file size per minute, and
    /// `terzaghi replay --reevaluate` against real time.
    Record(record::BenchRecordArgs),
    /// How long `terzaghi diagnose` takes on a long six-legged session.
    Diagnose(diagnose::BenchDiagnoseArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let r = match cli.command {
        Command::Model(a) => model::run(a),
        Command::Node(a) => node::run(a),
        Command::Echo(a) => node::run_echo(a),
        Command::Record(a) => record::run(a),
        Command::Diagnose(a) => diagnose::run(a),
    };
    match r {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(terzaghi::error::exit_code(&e))
        }
    }
}

/// The `terzaghi` executable built beside this one.
fn terzaghi_exe() -> Result<std::path::PathBuf> {
    let me = std::env::current_exe().context("cannot find the terzaghi-bench executable")?;
    let exe = me.with_file_name(format!("terzaghi{}", std::env::consts::EXE_SUFFIX));
    if !exe.exists() {
        anyhow::bail!(
            "{} is missing: build both binaries (cargo build --release)",
            exe.display()
        );
    }
    Ok(exe)
}
