#[cfg(feature = "cli")]
mod cli;
#[cfg(feature = "cli")]
mod demo;

use std::process::ExitCode;

// The node's messages are allocated on its thread and freed on the DDS threads; glibc's malloc
// takes an arena lock for such frees, a wait in the processing-time tail. mimalloc frees
// across threads without a lock.
#[cfg(feature = "cli")]
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

#[cfg(not(feature = "cli"))]
fn main() -> ExitCode {
    eprintln!(
        "error: terzaghi was built without its command line (the cli feature): build it with the default features"
    );
    ExitCode::from(2)
}

#[cfg(feature = "cli")]
fn main() -> ExitCode {
    use clap::Parser;
    let cli = cli::Cli::parse();
    match cli::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", cli::worded(&e));
            ExitCode::from(cli::exit_code(&e))
        }
    }
}
