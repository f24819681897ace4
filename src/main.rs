mod cli;
mod demo;

use clap::Parser;
use std::process::ExitCode;

// The node's messages are allocated on its thread and freed on the DDS threads; glibc's malloc
// takes an arena lock for such frees, a wait in the processing-time tail. mimalloc frees
// across threads without a lock.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> ExitCode {
    let cli = cli::Cli::parse();
    match cli::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", cli::worded(&e));
            ExitCode::from(cli::exit_code(&e))
        }
    }
}
