//! Recording topics of a ROS 2 network to a session file without running the model, as
//! `ros2 bag record` does, for users who record the raw robot and re-evaluate later.

use crate::msgs::{DiagnosticArray, JointState, LegForce, ModelParams, RosMessage, WrenchStamped};
use crate::node::dds::{subscription, tool_node};
use crate::record::RecordOptions;
use crate::record::recorder::{Record, Recorder, now_ns};
use anyhow::{Context as _, Result, anyhow, bail};
use ros2_client::Node;
use std::future::Future;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

/// The message types the recorder knows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// `sensor_msgs/JointState`.
    Joints,
    /// `geometry_msgs/WrenchStamped`.
    Wrench,
    /// `terzaghi_msgs/LegForce`.
    Force,
    /// `terzaghi_msgs/ModelParams`.
    Params,
    /// `diagnostic_msgs/DiagnosticArray`.
    Diag,
}

/// A topic to record, `/name` or `/name:pkg/msg/Type`; without a type, it is told from the
/// name (joint_states, wrench or ft, leg_force, model_params, diagnostics).
pub fn kind_of(spec: &str) -> Result<(String, Kind)> {
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

/// What a recording wrote.
#[derive(Debug, Clone, Copy)]
pub struct Recorded {
    /// Messages written.
    pub written: u64,
    /// Messages dropped (the recorder's queue was full).
    pub dropped: u64,
}

/// Records `topics` to `output` (which must not exist) until `stop` resolves; `started` is
/// called once the subscriptions are made. Runs on the calling thread's tokio runtime.
pub async fn record_topics(
    topics: &[(String, Kind)],
    output: &Path,
    stop: impl Future<Output = ()>,
    started: impl FnOnce(),
) -> Result<Recorded> {
    let recorder = Arc::new(
        Recorder::start(output, RecordOptions::default(), 1 << 16)
            .with_context(|| format!("cannot record to {}", output.display()))?,
    );
    let mut node = tool_node(&format!("terzaghi_record_{}", std::process::id())).context(
        crate::session::Failure("cannot create the recorder node".into()),
    )?;
    let mut tasks = Vec::new();
    for (topic, kind) in topics {
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
    started();
    stop.await;
    for t in &tasks {
        t.abort();
    }
    for t in tasks {
        let _ = t.await;
    }
    node.stop_spinner();
    let _ = tokio::time::timeout(Duration::from_secs(1), spin).await;
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
    Ok(Recorded { written, dropped })
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
