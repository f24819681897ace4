//! `terzaghi import-dem`: DEM testbed runs as a ROS 2 session.

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;
use terzaghi::dem::import_runs;

#[derive(Debug, Args)]
pub struct ImportDemArgs {
    /// Runs of the DEM testbed (tests/dem/campaign.py): '# key: value' lines, then
    /// t_s,beta_rad,drag_n,lift_n,hip_torque_nm in the hip frame. Several runs of the same
    /// leg, geometry, medium and speed become one session of several strokes, in order.
    #[arg(required = true, num_args = 1..)]
    pub runs: Vec<PathBuf>,
    /// The session to write (ROS 2 MCAP).
    #[arg(short, long, value_name = "OUT.mcap")]
    pub output: PathBuf,
    /// Replace OUT.mcap if it exists (by default an existing file is refused).
    #[arg(long)]
    pub overwrite: bool,
}

pub fn import(a: ImportDemArgs) -> Result<()> {
    let inputs: Vec<&std::path::Path> = a.runs.iter().map(|r| r.as_path()).collect();
    terzaghi::session::files::refuse_output_over_input(&a.output, &inputs)?;
    let run = import_runs(&a.runs, &a.output, a.overwrite)?;
    eprintln!(
        "{} samples of run {} written to {}",
        run.samples.len(),
        run.name,
        a.output.display()
    );
    Ok(())
}
