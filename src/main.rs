use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = terzaghi::cli::Cli::parse();
    match terzaghi::cli::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}
