use clap::Parser;
use std::process::ExitCode;

// The node's messages are allocated on its thread and freed on the DDS threads; glibc's malloc
// takes an arena lock for such frees, a wait in the processing-time tail. mimalloc frees
// across threads without a lock.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> ExitCode {
    let cli = terzaghi::command_line::Cli::parse();
    match terzaghi::command_line::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", terzaghi::command_line::worded(&e));
            ExitCode::from(terzaghi::command_line::exit_code(&e))
        }
    }
}
