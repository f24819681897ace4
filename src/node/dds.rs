//! The node on a ROS 2 network, through ros2-client (RustDDS): subscriptions feed a bounded
//! queue, one task runs [`NodeCore`] on it and publishes; parameter services run, and a change
//! of a parameter is validated as a whole configuration before it takes effect.

use super::core::{LegOutput, NodeCore};
use super::latency::Histogram;
use super::queue::DropOldest;
use crate::config::{NodeConfig, ParamMap, ParamValue, STARTUP_ONLY};
use crate::msgs::{DiagnosticArray, JointState, LegForce, ModelParams, RosMessage, WrenchStamped};
use anyhow::{Context as _, Result, anyhow};
use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::{
    Context, MessageTypeName, Name, Node, NodeName, NodeOptions, ParameterValue, Publisher,
    QosProfile, Subscription,
    qos::{Durability, History, Reliability},
};
use std::collections::HashMap;
use std::future::Future;
use std::net::{IpAddr, Ipv4Addr};
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// Everything the node needs to start.
pub struct NodeSetup {
    pub params: ParamMap,
    pub config: NodeConfig,
    pub domain_id: u16,
    pub localhost_only: bool,
    /// Write the processing-time summary here as JSON at shutdown (for benchmarks).
    pub latency_report: Option<PathBuf>,
}

/// What a run did, printed at shutdown.
#[derive(Debug, Clone, serde::Serialize)]
pub struct RunSummary {
    pub joint_states: u64,
    pub predictions: u64,
    pub dropped: u64,
    /// From taking a JointState off DDS to having published every leg's outputs.
    pub processing_p50_ns: u64,
    pub processing_p99_ns: u64,
    pub processing_max_ns: u64,
    pub processing_count: u64,
    /// Peak resident memory of the process (kB), if the OS tells.
    pub peak_rss_kb: Option<u64>,
}

enum Input {
    Joints(JointState, Instant),
    Wrench(usize, WrenchStamped),
}

pub fn qos_in() -> QosProfile {
    // Best effort matches every publisher; a deep history rides out bursts.
    QosProfile::subscription_default()
        .reliability(Reliability::BestEffort)
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 1000 })
}

pub fn qos_out() -> QosProfile {
    QosProfile::publisher_default().history(History::KeepLast { depth: 10 })
}

fn topic_name(full: &str) -> Result<Name> {
    Name::parse(full).map_err(|e| anyhow!("bad topic name {full:?}: {e:?}"))
}

fn message_type<M: RosMessage>() -> MessageTypeName {
    MessageTypeName::new(M::TYPE.0, M::TYPE.1)
}

pub fn publisher<M: RosMessage>(node: &mut Node, topic: &str) -> Result<Publisher<M>> {
    let t = node
        .create_topic(&topic_name(topic)?, message_type::<M>(), &qos_out())
        .with_context(|| format!("cannot create topic {topic}"))?;
    node.create_publisher::<M>(&t, Some(qos_out()))
        .with_context(|| format!("cannot publish {topic}"))
}

pub fn subscription<M: RosMessage>(node: &mut Node, topic: &str) -> Result<Subscription<M>> {
    let t = node
        .create_topic(&topic_name(topic)?, message_type::<M>(), &qos_in())
        .with_context(|| format!("cannot create topic {topic}"))?;
    node.create_subscription::<M>(&t, Some(qos_in()))
        .with_context(|| format!("cannot subscribe to {topic}"))
}

pub fn to_ros(v: &ParamValue) -> ros2_client::ParameterValue {
    match v.clone() {
        ParamValue::Bool(b) => ParameterValue::Boolean(b),
        ParamValue::Int(i) => ParameterValue::Integer(i),
        ParamValue::Double(d) => ParameterValue::Double(d),
        ParamValue::String(s) => ParameterValue::String(s),
        ParamValue::BoolArray(v) => ParameterValue::BooleanArray(v),
        ParamValue::IntArray(v) => ParameterValue::IntegerArray(v),
        ParamValue::DoubleArray(v) => ParameterValue::DoubleArray(v),
        ParamValue::StringArray(v) => ParameterValue::StringArray(v),
    }
}

pub fn from_ros(v: &ParameterValue) -> Option<ParamValue> {
    Some(match v.clone() {
        ParameterValue::Boolean(b) => ParamValue::Bool(b),
        ParameterValue::Integer(i) => ParamValue::Int(i),
        ParameterValue::Double(d) => ParamValue::Double(d),
        ParameterValue::String(s) => ParamValue::String(s),
        ParameterValue::BooleanArray(v) => ParamValue::BoolArray(v),
        ParameterValue::IntegerArray(v) => ParamValue::IntArray(v),
        ParameterValue::DoubleArray(v) => ParamValue::DoubleArray(v),
        ParameterValue::StringArray(v) => ParamValue::StringArray(v),
        ParameterValue::NotSet | ParameterValue::ByteArray(_) => return None,
    })
}

/// Parameters as they stand, with a version bumped on every accepted change.
struct LiveParams {
    map: Mutex<ParamMap>,
    version: AtomicU64,
}

fn candidate(
    live: &LiveParams,
    cfg: &NodeConfig,
    name: &str,
    value: &ParameterValue,
) -> Result<NodeConfig, String> {
    let v = from_ros(value).ok_or_else(|| format!("{name}: unsupported parameter type"))?;
    // Declaring a parameter (and setting it to what it is) changes nothing.
    if live
        .map
        .lock()
        .map_err(|_| "parameters unavailable".to_string())?
        .get(name)
        == Some(&v)
    {
        return Ok(cfg.clone());
    }
    if STARTUP_ONLY.contains(&name) {
        return Err(format!(
            "{name} takes effect at start-up only: restart the node"
        ));
    }
    if name.ends_with(".ft_topic") {
        return Err(format!(
            "{name} takes effect at start-up only: restart the node"
        ));
    }
    let mut map = live
        .map
        .lock()
        .map_err(|_| "parameters unavailable".to_string())?
        .clone();
    map.insert(name.to_string(), v);
    NodeConfig::from_params(&map, &cfg.node_name, &cfg.namespace, &cfg.remaps)
        .map_err(|e| e.to_string())
}

/// A ROS 2 context on `domain_id`, on loopback only if asked.
pub fn dds_context(domain_id: u16, localhost_only: bool) -> Result<Context> {
    let mut dpb = DomainParticipantBuilder::new(domain_id);
    if localhost_only {
        dpb = dpb.with_only_networks([IpAddr::V4(Ipv4Addr::LOCALHOST)]);
    }
    let participant = dpb.build().context("cannot start DDS")?;
    Context::from_domain_participant(participant).context("cannot start ROS 2 context")
}

/// The context the environment asks for (`ROS_DOMAIN_ID`, localhost-only settings).
pub fn dds_context_from_env() -> Result<Context> {
    let domain = crate::config::domain_id_from_env(std::env::var("ROS_DOMAIN_ID").ok().as_deref())?;
    let local = crate::config::localhost_only_from_env(
        std::env::var("ROS_AUTOMATIC_DISCOVERY_RANGE")
            .ok()
            .as_deref(),
        std::env::var("ROS_LOCALHOST_ONLY").ok().as_deref(),
    )?;
    dds_context(domain, local)
}

fn unix_now_ns() -> i64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_nanos() as i64)
        .unwrap_or(0)
}

/// Peak resident set size from /proc (Linux), in kB.
pub fn peak_rss_kb() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    s.lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
}

/// Runs the node until `shutdown` resolves; then leaves the network cleanly and returns what
/// it did. Called from a tokio runtime.
pub async fn run(setup: NodeSetup, shutdown: impl Future<Output = ()>) -> Result<RunSummary> {
    let cfg = setup.config.clone();
    let context = dds_context(setup.domain_id, setup.localhost_only)?;

    let live = Arc::new(LiveParams {
        map: Mutex::new(setup.params.clone()),
        version: AtomicU64::new(0),
    });
    let mut opts = NodeOptions::new().enable_rosout(true);
    for (name, value) in &setup.params {
        opts = opts.declare_parameter(name, to_ros(value));
    }
    let cfg_for_check = Arc::new(Mutex::new(cfg.clone()));
    {
        let (live, cfgc) = (live.clone(), cfg_for_check.clone());
        opts = opts.parameter_validator(Box::new(move |name, value| {
            let cfg = cfgc
                .lock()
                .map_err(|_| "configuration unavailable".to_string())?
                .clone();
            candidate(&live, &cfg, name, value).map(|_| ())
        }));
    }
    {
        let (live, cfgc) = (live.clone(), cfg_for_check.clone());
        opts = opts.parameter_set_action(Box::new(move |name, value| {
            let cfg = cfgc
                .lock()
                .map_err(|_| "configuration unavailable".to_string())?
                .clone();
            let new_cfg = candidate(&live, &cfg, name, value)?;
            if let (Ok(mut map), Some(v)) = (live.map.lock(), from_ros(value)) {
                map.insert(name.to_string(), v);
            }
            if let Ok(mut c) = cfgc.lock() {
                *c = new_cfg;
            }
            live.version.fetch_add(1, Ordering::SeqCst);
            Ok(())
        }));
    }
    let node_name = NodeName::new(&cfg.namespace, &cfg.node_name)
        .map_err(|e| anyhow!("bad node name {}/{}: {e:?}", cfg.namespace, cfg.node_name))?;
    let mut node = context
        .new_node(node_name, opts)
        .context("cannot create the ROS 2 node")?;
    let spinner = node.spinner().context("cannot start the node's spinner")?;
    let spin_task = tokio::spawn(spinner.spin());

    let ns = cfg.namespace.trim_end_matches('/').to_string();
    let resolve =
        |rel: &str| crate::config::resolve_topic(rel, &cfg.namespace, &cfg.node_name, &cfg.remaps);
    let mut wrench_pubs = Vec::new();
    let mut force_pubs = Vec::new();
    let mut param_pubs = Vec::new();
    for leg in &cfg.legs {
        wrench_pubs.push(publisher::<WrenchStamped>(
            &mut node,
            &resolve(&format!("{}/predicted_wrench", leg.name)),
        )?);
        force_pubs.push(publisher::<LegForce>(
            &mut node,
            &resolve(&format!("{}/leg_force", leg.name)),
        )?);
        param_pubs.push(publisher::<ModelParams>(
            &mut node,
            &resolve(&format!("{}/model_params", leg.name)),
        )?);
    }
    let diag_pub = publisher::<DiagnosticArray>(&mut node, &resolve("/diagnostics"))?;
    let _ = ns;

    let queue = Arc::new(DropOldest::<Input>::new(cfg.queue_depth));
    let mut readers = Vec::new();
    {
        let sub = subscription::<JointState>(&mut node, &cfg.joint_states_topic)?;
        let q = queue.clone();
        readers.push(tokio::spawn(async move {
            let mut last_seq: HashMap<ros2_client::Gid, i64> = HashMap::new();
            loop {
                match sub.async_take().await {
                    Ok((msg, info)) => {
                        let seq = info.sequence_number();
                        if let Some(prev) = last_seq.insert(info.publisher_gid(), seq)
                            && seq > prev + 1
                        {
                            q.count_lost((seq - prev - 1) as u64);
                        }
                        q.push(Input::Joints(msg, Instant::now()));
                    }
                    Err(_) => q.count_lost(1), // undecodable sample: counted, skipped
                }
            }
        }));
    }
    for (i, leg) in cfg.legs.iter().enumerate() {
        let Some(topic) = &leg.ft_topic else { continue };
        let sub = subscription::<WrenchStamped>(&mut node, topic)?;
        let q = queue.clone();
        readers.push(tokio::spawn(async move {
            loop {
                match sub.async_take().await {
                    Ok((msg, _)) => q.push(Input::Wrench(i, msg)),
                    Err(_) => q.count_lost(1),
                }
            }
        }));
    }

    let mut core = NodeCore::new(cfg.clone());
    let mut seen_version = 0;
    let mut hist = Histogram::default();
    let mut batch = Vec::new();
    let mut outputs: Vec<LegOutput> = Vec::new();
    let mut params_out = Vec::new();
    let mut diag_tick = tokio::time::interval(Duration::from_secs_f64(cfg.diagnostics_period_s));
    diag_tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    tokio::pin!(shutdown);
    let mut publish_errors = 0u64;
    loop {
        tokio::select! {
            _ = &mut shutdown => break,
            _ = diag_tick.tick() => {
                let lat = vec![
                    ("processing_p50_us".to_string(), format!("{:.1}", hist.quantile_ns(0.5) as f64 / 1e3)),
                    ("processing_p99_us".to_string(), format!("{:.1}", hist.quantile_ns(0.99) as f64 / 1e3)),
                    ("processing_max_us".to_string(), format!("{:.1}", hist.max_ns() as f64 / 1e3)),
                    ("publish_errors".to_string(), publish_errors.to_string()),
                ];
                let d = core.diagnostics(unix_now_ns(), queue.dropped(), &lat);
                if diag_pub.publish(d).is_err() { publish_errors += 1; }
            }
            _ = queue.drain(&mut batch) => {
                let v = live.version.load(Ordering::SeqCst);
                if v != seen_version {
                    seen_version = v;
                    if let Ok(c) = cfg_for_check.lock() {
                        core.set_config(c.clone());
                    }
                }
                for input in batch.drain(..) {
                    match input {
                        Input::Joints(msg, received) => {
                            outputs.clear();
                            core.on_joint_state(&msg, &mut outputs);
                            for o in outputs.drain(..) {
                                if wrench_pubs[o.leg].publish(o.wrench).is_err() { publish_errors += 1; }
                                if force_pubs[o.leg].publish(o.force).is_err() { publish_errors += 1; }
                            }
                            hist.record(received.elapsed().as_nanos() as u64);
                        }
                        Input::Wrench(leg, msg) => core.on_wrench(leg, &msg),
                    }
                    core.take_params(&mut params_out);
                    for (leg, p) in params_out.drain(..) {
                        if param_pubs[leg].publish(p).is_err() { publish_errors += 1; }
                    }
                }
            }
        }
    }

    for r in &readers {
        r.abort();
    }
    node.stop_spinner();
    let _ = tokio::time::timeout(Duration::from_secs(2), spin_task).await;
    let predictions = (0..cfg.legs.len())
        .filter_map(|i| core.leg_counters(i))
        .map(|c| c.predictions)
        .sum();
    let summary = RunSummary {
        joint_states: core.counters().joint_states,
        predictions,
        dropped: queue.dropped(),
        processing_p50_ns: hist.quantile_ns(0.5),
        processing_p99_ns: hist.quantile_ns(0.99),
        processing_max_ns: hist.max_ns(),
        processing_count: hist.count(),
        peak_rss_kb: peak_rss_kb(),
    };
    // Dropping the node and context tells DDS peers that we left.
    drop(wrench_pubs);
    drop(force_pubs);
    drop(param_pubs);
    drop(diag_pub);
    drop(node);
    drop(context);
    if let Some(path) = &setup.latency_report {
        let text = serde_json::to_string_pretty(&summary)?;
        std::fs::write(path, text + "\n")
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    Ok(summary)
}
