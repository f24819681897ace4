//! `terzaghi record`: record topics this project knows to an MCAP file, without running the
//! model (for users who record the raw robot and re-evaluate later).

use crate::msgs::{DiagnosticArray, JointState, LegForce, ModelParams, RosMessage, WrenchStamped};
use crate::node::dds::{subscription, tool_node};
use crate::record::RecordOptions;
use crate::record::recorder::{Record, Recorder};
use anyhow::{Context as _, Result, anyhow, bail};
use clap::Args;
use ros2_client::Node;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

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

#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Joints,
    Wrench,
    Force,
    Params,
    Diag,
}

fn kind_of(spec: &str) -> Result<(String, Kind)> {
    let (topic, ty) = match spec.split_once(':') {
        Some((t, ty)) => (t.to_string(), Some(ty)),
        None => (spec.to_string(), None),
    };
    if !topic.starts_with('/') {
        bail!("topic {topic:?}: give the full name, e.g. /joint_states");
    }
    let norm = |t: &str| t.replace("/msg/", "/");
    let kind = match ty.map(norm).as_deref() {
        Some("sensor_msgs/JointState") => Kind::Joints,
        Some("geometry_msgs/WrenchStamped") => Kind::Wrench,
        Some("terzaghi_msgs/LegForce") => Kind::Force,
        Some("terzaghi_msgs/ModelParams") => Kind::Params,
        Some("diagnostic_msgs/DiagnosticArray") => Kind::Diag,
        Some(other) => bail!("{spec}: type {other} is not one this recorder knows (see --help)"),
        None => {
            let last = topic.rsplit('/').next().unwrap_or("");
            match last {
                "joint_states" => Kind::Joints,
                "leg_force" => Kind::Force,
                "model_params" => Kind::Params,
                "diagnostics" => Kind::Diag,
                l if l.contains("wrench") || l == "ft" => Kind::Wrench,
                _ => bail!(
                    "{spec}: cannot tell the type from the name; write it as {topic}:pkg/msg/Type"
                ),
            }
        }
    };
    Ok((topic, kind))
}

fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0)
}

fn spawn<M: RosMessage + Sync>(
    node: &mut Node,
    topic: &str,
    rec: Arc<Recorder>,
    wrap: fn(Arc<str>, M, u64) -> Record,
) -> Result<tokio::task::JoinHandle<()>> {
    let sub = subscription::<M>(node, topic)?;
    let name: Arc<str> = topic.into();
    Ok(tokio::spawn(async move {
        while let Ok((m, _)) = sub.async_take().await {
            rec.record(wrap(name.clone(), m, now_ns()));
        }
    }))
}

pub fn run(a: RecordArgs) -> Result<()> {
    let topics: Vec<(String, Kind)> = a.topics.iter().map(|t| kind_of(t)).collect::<Result<_>>()?;
    if let Some(d) = a.duration_s
        && !(d.is_finite() && d > 0.0)
    {
        bail!("--duration-s must be a positive number, got {d}");
    }
    let output = a.output.clone().unwrap_or_else(|| {
        super::recording_name(
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs()),
        )
    });
    super::refuse_existing_recording(&output, a.overwrite)?;
    let recorder = Arc::new(
        Recorder::start(&output, RecordOptions::default(), 1 << 16)
            .with_context(|| format!("cannot record to {}", output.display()))?,
    );
    let rt = super::runtime()?;
    rt.block_on(async {
        let mut node = tool_node(&format!("terzaghi_record_{}", std::process::id()))
            .context("cannot create the recorder node")?;
        let mut tasks = Vec::new();
        for (topic, kind) in &topics {
            let r = recorder.clone();
            tasks.push(match kind {
                Kind::Joints => spawn::<JointState>(&mut node, topic, r, Record::Joints)?,
                Kind::Wrench => spawn::<WrenchStamped>(&mut node, topic, r, Record::Wrench)?,
                Kind::Force => spawn::<LegForce>(&mut node, topic, r, Record::Force)?,
                Kind::Params => spawn::<ModelParams>(&mut node, topic, r, Record::Params)?,
                Kind::Diag => spawn::<DiagnosticArray>(&mut node, topic, r, Record::Diagnostics)?,
            });
        }
        let spin = tokio::spawn(node.spinner()?.spin());
        eprintln!(
            "recording {} topics to {} (Ctrl-C to stop)",
            topics.len(),
            output.display()
        );
        let wait = async {
            match a.duration_s {
                Some(d) => tokio::time::sleep(Duration::from_secs_f64(d)).await,
                None => std::future::pending::<()>().await,
            }
        };
        #[cfg(unix)]
        let mut term = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())?;
        #[cfg(unix)]
        let term_recv = term.recv();
        #[cfg(not(unix))]
        let term_recv = std::future::pending::<Option<()>>();
        tokio::select! {
            _ = wait => {}
            _ = tokio::signal::ctrl_c() => {}
            _ = term_recv => {}
        }
        for t in &tasks {
            t.abort();
        }
        for t in tasks {
            let _ = t.await;
        }
        node.stop_spinner();
        let _ = tokio::time::timeout(Duration::from_secs(1), spin).await;
        Ok::<(), anyhow::Error>(())
    })?;
    let rec = Arc::try_unwrap(recorder).map_err(|_| anyhow!("the recorder is still in use"))?;
    let written = rec
        .status
        .written
        .load(std::sync::atomic::Ordering::Relaxed);
    let dropped = rec
        .status
        .dropped
        .load(std::sync::atomic::Ordering::Relaxed);
    if let Some(e) = rec.finish() {
        bail!("recording to {} stopped: {e}", output.display());
    }
    eprintln!(
        "recorded {written} messages to {} ({dropped} dropped)",
        output.display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn types_from_names_or_given() {
        assert_eq!(kind_of("/joint_states").unwrap().1, Kind::Joints);
        assert_eq!(kind_of("/fl/ft/wrench").unwrap().1, Kind::Wrench);
        assert_eq!(kind_of("/fl/leg_force").unwrap().1, Kind::Force);
        assert_eq!(
            kind_of("/x:geometry_msgs/msg/WrenchStamped").unwrap().1,
            Kind::Wrench
        );
        assert!(kind_of("/chatter").is_err());
        assert!(kind_of("joint_states").is_err());
        assert!(kind_of("/x:std_msgs/msg/String").is_err());
    }
}
