//! `terzaghi record`: record topics this project knows to an MCAP file, without running the
//! model (the work is [`terzaghi::session::record`]).

use anyhow::{Result, bail};
use clap::Args;
use std::path::PathBuf;
use std::time::Duration;
use terzaghi::session::files::{recording_name, refuse_existing_recording};
use terzaghi::session::record::{kind_of, record_topics};

#[derive(Debug, Args)]
pub struct RecordArgs {
    /// Topics, as /name or /name:pkg/msg/Type. Known types: sensor_msgs/msg/JointState,
    /// geometry_msgs/msg/WrenchStamped, terzaghi_msgs/msg/LegForce, terzaghi_msgs/msg/ModelParams,
    /// diagnostic_msgs/msg/DiagnosticArray; without a type, it is guessed from the name
    /// (joint_states, wrench or ft, predicted_wrench, leg_force, model_params, diagnostics).
    #[arg(long, num_args = 1.., required = true)]
    pub topics: Vec<String>,
    /// The MCAP file to write (default: terzaghi_YYYY_MM_DD-HH_MM_SS.mcap from the start time,
    /// UTC). An existing file is refused.
    #[arg(short, long, value_name = "FILE.mcap")]
    pub output: Option<PathBuf>,
    /// Replace the output file if it exists.
    #[arg(long)]
    pub overwrite: bool,
    /// Stop after this many seconds (default: at Ctrl-C or SIGTERM).
    #[arg(long)]
    pub duration_s: Option<f64>,
}

pub fn run(a: RecordArgs) -> Result<()> {
    let topics: Vec<_> = a.topics.iter().map(|t| kind_of(t)).collect::<Result<_>>()?;
    if let Some(d) = a.duration_s
        && !(d.is_finite() && d > 0.0)
    {
        bail!("--duration-s must be a positive number, got {d}");
    }
    let output = a.output.clone().unwrap_or_else(|| {
        recording_name(
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs()),
        )
    });
    refuse_existing_recording(&output, a.overwrite)?;
    let rt = terzaghi::node::dds::runtime()?;
    let recorded = rt.block_on(async {
        let stop = async {
            let wait = async {
                match a.duration_s {
                    Some(d) => tokio::time::sleep(Duration::from_secs_f64(d)).await,
                    None => std::future::pending::<()>().await,
                }
            };
            tokio::select! {
                _ = wait => {}
                _ = super::node::shutdown_signal() => {}
            }
        };
        record_topics(&topics, &output, stop, || {
            eprintln!(
                "recording {} topics to {} (Ctrl-C to stop)",
                topics.len(),
                output.display()
            )
        })
        .await
    })?;
    eprintln!(
        "recorded {} messages to {} ({} dropped)",
        recorded.written,
        output.display(),
        recorded.dropped
    );
    Ok(())
}
