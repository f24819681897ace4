//! The node on a ROS 2 network, through ros2-client (RustDDS): subscriptions feed a bounded
//! queue, one task runs [`NodeCore`] on it and publishes; parameter services run, and a change
//! of a parameter is validated as a whole configuration before it takes effect.

use super::core::{LegOutput, NodeCore};
use super::handle::{Publish, Topics, diagnostics_done, joint_state_done, wrench_done};
use super::latency::Histogram;
use crate::config::{NodeConfig, ParamMap, ParamValue, STARTUP_ONLY};
use crate::msgs::{DiagnosticArray, JointState, LegForce, ModelParams, RosMessage, WrenchStamped};
use crate::record::RecordOptions;
use crate::record::recorder::{Recorder, now_ns};
use anyhow::{Context as _, Result, anyhow};
use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::{
    Context, MessageTypeName, Name, Node, NodeName, NodeOptions, ParameterValue, Publisher,
    QosProfile, Subscription,
    qos::{Durability, History, Reliability, WhenFull},
};
use std::collections::HashMap;
use std::future::Future;
use std::net::{IpAddr, Ipv4Addr};

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tokio::sync::watch;

/// Everything the node needs to start.
pub struct NodeSetup {
    pub params: ParamMap,
    pub config: NodeConfig,
    pub domain_id: u16,
    pub localhost_only: bool,
}

/// What a run did, printed at shutdown.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct RunSummary {
    pub joint_states: u64,
    pub predictions: u64,
    pub dropped: u64,
    /// From taking a JointState off DDS to having published every leg's outputs.
    pub processing_p50_ns: u64,
    pub processing_p99_ns: u64,
    pub processing_max_ns: u64,
    pub processing_count: u64,
}

/// What the message tasks share.
struct Shared {
    core: Mutex<Core>,
    hist: Mutex<Histogram>,
    dropped: AtomicU64,
}

/// The node's core and the parameters it follows.
struct Core {
    core: NodeCore,
    live: watch::Receiver<Live>,
}

impl Shared {
    /// The core, with the latest accepted parameters applied.
    fn lock_core(&self) -> std::sync::MutexGuard<'_, Core> {
        let mut c = self.core.lock().unwrap_or_else(|p| p.into_inner());
        if c.live.has_changed().unwrap_or(false) {
            let cfg = c.live.borrow_and_update().config.clone();
            c.core.set_config(cfg);
        }
        c
    }
}

struct Pubs {
    wrench: Vec<Publisher<WrenchStamped>>,
    force: Vec<Publisher<LegForce>>,
    params: Vec<Publisher<ModelParams>>,
    diagnostics: Publisher<DiagnosticArray>,
    errors: Arc<AtomicU64>,
    /// Asked, before each write, whether anyone subscribes: writing to nobody costs a DDS
    /// write per message, skipped.
    node: Arc<Node>,
}

impl Pubs {
    fn send<M: serde::Serialize>(&self, p: &Publisher<M>, msg: M) {
        if p.get_subscription_count(&self.node) > 0 && p.publish(msg).is_err() {
            self.errors.fetch_add(1, Ordering::Relaxed);
        }
    }
}

impl Publish for Pubs {
    fn wrench(&self, leg: usize, msg: WrenchStamped) {
        self.send(&self.wrench[leg], msg);
    }
    fn force(&self, leg: usize, msg: LegForce) {
        self.send(&self.force[leg], msg);
    }
    fn params(&self, leg: usize, msg: ModelParams) {
        self.send(&self.params[leg], msg);
    }
    fn diagnostics(&self, msg: DiagnosticArray) {
        if self.diagnostics.publish(msg).is_err() {
            self.errors.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// The next sample of `sub`: one that does not decode is counted as dropped and skipped, and
/// so are the samples missing before it (gaps in its writer's sequence numbers).
async fn next_sample<M: serde::de::DeserializeOwned + 'static>(
    sub: &Subscription<M>,
    gaps: &mut SequenceGaps,
    dropped: &AtomicU64,
) -> M {
    loop {
        match sub.async_take().await {
            Ok((msg, info)) => {
                dropped.fetch_add(gaps.lost(&info), Ordering::Relaxed);
                return msg;
            }
            Err(_) => {
                dropped.fetch_add(1, Ordering::Relaxed);
            }
        }
    }
}

/// Samples lost before they reached us: gaps in each writer's sequence numbers.
#[derive(Default)]
struct SequenceGaps(HashMap<ros2_client::Gid, i64>);

impl SequenceGaps {
    fn lost(&mut self, info: &ros2_client::MessageInfo) -> u64 {
        let seq = info.sequence_number();
        match self.0.insert(info.publisher_gid(), seq) {
            Some(prev) if seq > prev + 1 => (seq - prev - 1) as u64,
            _ => 0,
        }
    }
}

pub fn qos_in() -> QosProfile {
    // Best effort matches every publisher; a deep history rides out bursts.
    QosProfile::subscription_default()
        .reliability(Reliability::BestEffort)
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 1000 })
}

/// Reliable, but never blocking: when a slow subscriber fills the send window, the sample is
/// dropped for it and counted, and the node goes on (a controller's data must not wait).
pub fn qos_out() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Fail)
        .history(History::KeepLast { depth: 10 })
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
    subscription_with_depth(node, topic, 1000)
}

/// A best-effort subscription keeping the last `depth` samples.
pub fn subscription_with_depth<M: RosMessage>(
    node: &mut Node,
    topic: &str,
    depth: usize,
) -> Result<Subscription<M>> {
    let qos = qos_in().history(History::KeepLast {
        depth: depth.max(1),
    });
    let t = node
        .create_topic(&topic_name(topic)?, message_type::<M>(), &qos)
        .with_context(|| format!("cannot create topic {topic}"))?;
    node.create_subscription::<M>(&t, Some(qos))
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

/// The parameters in force and the configuration made from them. A change of a parameter is
/// validated as a whole configuration, then sent on a watch channel to the message tasks.
#[derive(Clone)]
struct Live {
    params: ParamMap,
    config: NodeConfig,
}

/// The parameters and configuration after setting `name` to `value`, or why not.
fn candidate(live: &Live, name: &str, value: &ParameterValue) -> Result<Live, String> {
    let v = from_ros(value).ok_or_else(|| format!("{name}: unsupported parameter type"))?;
    // Declaring a parameter (and setting it to what it is) changes nothing.
    if live.params.get(name) == Some(&v) {
        return Ok(live.clone());
    }
    if STARTUP_ONLY.contains(&name) || name.ends_with(".ft_topic") {
        return Err(format!(
            "{name} takes effect at start-up only: restart the node"
        ));
    }
    let mut params = live.params.clone();
    params.insert(name.to_string(), v);
    let cfg = &live.config;
    let config = NodeConfig::from_params(&params, &cfg.node_name, &cfg.namespace, &cfg.remaps)
        .map_err(|e| e.to_string())?;
    Ok(Live { params, config })
}

/// Adds the recorder's state to the diagnostics values; returns its error, if it failed.
fn recording_state(
    recorder: &Option<Arc<Recorder>>,
    start_error: Option<&str>,
    kv: &mut Vec<(String, String)>,
) -> Option<String> {
    if let Some(e) = start_error {
        kv.push(("recording".into(), "failed".into()));
        return Some(e.to_string());
    }
    let r = recorder.as_ref()?;
    kv.push(("recording".into(), r.path.display().to_string()));
    kv.push((
        "recorded_messages".into(),
        r.status.written.load(Ordering::Relaxed).to_string(),
    ));
    kv.push((
        "recording_dropped".into(),
        r.status.dropped.load(Ordering::Relaxed).to_string(),
    ));
    if r.status.failed.load(Ordering::Relaxed) {
        return r
            .status
            .error
            .lock()
            .ok()
            .and_then(|e| e.clone())
            .or(Some("write failed".into()));
    }
    None
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

/// The DDS domain and the localhost-only setting the environment asks for (`ROS_DOMAIN_ID`,
/// `ROS_AUTOMATIC_DISCOVERY_RANGE`, `ROS_LOCALHOST_ONLY`).
pub fn network_from_env() -> Result<(u16, bool)> {
    let domain = crate::config::domain_id_from_env(std::env::var("ROS_DOMAIN_ID").ok().as_deref())?;
    let local = crate::config::localhost_only_from_env(
        std::env::var("ROS_AUTOMATIC_DISCOVERY_RANGE")
            .ok()
            .as_deref(),
        std::env::var("ROS_LOCALHOST_ONLY").ok().as_deref(),
    )?;
    Ok((domain, local))
}

/// The context the environment asks for (`ROS_DOMAIN_ID`, localhost-only settings).
pub fn dds_context_from_env() -> Result<Context> {
    let (domain, local) = network_from_env()?;
    dds_context(domain, local)
}

/// A plain node for the command-line tools (no rosout, no parameter services), on the domain
/// the environment asks for. The node keeps its context alive.
pub fn tool_node(name: &str) -> Result<Node> {
    let context = dds_context_from_env()?;
    let name = NodeName::new("/", name).map_err(|e| anyhow!("bad node name {name:?}: {e:?}"))?;
    let options = NodeOptions::new()
        .enable_rosout(false)
        .start_parameter_services(false);
    context
        .new_node(name, options)
        .context("cannot create a ROS 2 node")
}

/// The async runtime of the DDS tools: two worker threads, for a two-core robot computer.
pub fn runtime() -> Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .context("cannot start the async runtime")
}

/// Runs the node until `shutdown` resolves; then leaves the network cleanly and returns what
/// it did. Called from a tokio runtime.
pub async fn run(setup: NodeSetup, shutdown: impl Future<Output = ()>) -> Result<RunSummary> {
    let cfg = setup.config.clone();
    let context = dds_context(setup.domain_id, setup.localhost_only)?;
    let (live_tx, live_rx) = watch::channel(Live {
        params: setup.params.clone(),
        config: cfg.clone(),
    });
    let node_name = NodeName::new(&cfg.namespace, &cfg.node_name)
        .map_err(|e| anyhow!("bad node name {}/{}: {e:?}", cfg.namespace, cfg.node_name))?;
    let mut node = context
        .new_node(node_name, node_options(&setup.params, Arc::new(live_tx)))
        .context("cannot create the ROS 2 node")?;
    let spinner = node.spinner().context("cannot start the node's spinner")?;
    let spin_task = tokio::spawn(spinner.spin());
    let (wrench, force, params, diagnostics) = publishers(&mut node, &cfg)?;

    // Each message is handled in the task that takes it off DDS (no hand-off, which would add a
    // thread wake-up to every JointState). The DDS reader's KeepLast history is the bounded
    // queue: under a flood the oldest samples go, and the gaps in the writers' sequence numbers
    // count them.
    let shared = Arc::new(Shared {
        core: Mutex::new(Core {
            core: NodeCore::new(cfg.clone()),
            live: live_rx,
        }),
        hist: Mutex::new(Histogram::default()),
        dropped: AtomicU64::new(0),
    });
    let depth = cfg.queue_depth;
    let js_sub = subscription_with_depth::<JointState>(&mut node, &cfg.joint_states_topic, depth)?;
    let mut ft_subs = Vec::new();
    for (i, leg) in cfg.legs.iter().enumerate() {
        if let Some(topic) = &leg.ft_topic {
            ft_subs.push((
                i,
                subscription_with_depth::<WrenchStamped>(&mut node, topic, depth)?,
            ));
        }
    }
    // From here on the node is shared: the message tasks ask it who subscribes.
    let node = Arc::new(node);
    let publish_errors = Arc::new(AtomicU64::new(0));
    let pubs = Arc::new(Pubs {
        wrench,
        force,
        params,
        diagnostics,
        errors: publish_errors.clone(),
        node: node.clone(),
    });
    let (recorder, record_error) = start_recorder(&cfg, &setup.params);
    let topics = Arc::new(Topics::new(&cfg));
    let mut tasks = vec![tokio::spawn(joint_states_task(
        js_sub,
        shared.clone(),
        pubs.clone(),
        recorder.clone(),
        topics.clone(),
    ))];
    for (i, sub) in ft_subs {
        tasks.push(tokio::spawn(wrench_task(
            i,
            sub,
            shared.clone(),
            pubs.clone(),
            recorder.clone(),
            topics.clone(),
        )));
    }

    let mut diag_tick = tokio::time::interval(Duration::from_secs_f64(cfg.diagnostics_period_s));
    diag_tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    tokio::pin!(shutdown);
    loop {
        tokio::select! {
            _ = &mut shutdown => break,
            _ = diag_tick.tick() => {
                let d = node_status(&shared, &publish_errors, &recorder, record_error.as_deref());
                diagnostics_done(recorder.as_deref(), &topics, d, now_ns(), &*pubs);
            }
        }
    }

    for t in &tasks {
        t.abort();
    }
    for t in tasks {
        let _ = t.await;
    }
    node.stop_spinner();
    let _ = tokio::time::timeout(Duration::from_secs(2), spin_task).await;
    let summary = run_summary(&shared, cfg.legs.len());
    // Dropping the node and context tells DDS peers that we left.
    drop(pubs);
    if let Some(r) = recorder.and_then(|r| Arc::try_unwrap(r).ok()) {
        finish_recording(r);
    }
    drop(node);
    drop(context);
    Ok(summary)
}

/// The node's options: rosout, its parameters declared, and a change of a parameter validated
/// as a whole configuration before it is sent to the message tasks on `live`.
fn node_options(params: &ParamMap, live: Arc<watch::Sender<Live>>) -> NodeOptions {
    let mut opts = NodeOptions::new().enable_rosout(true);
    for (name, value) in params {
        opts = opts.declare_parameter(name, to_ros(value));
    }
    let check = live.clone();
    opts.parameter_validator(Box::new(move |name, value| {
        candidate(&check.borrow(), name, value).map(|_| ())
    }))
    .parameter_set_action(Box::new(move |name, value| {
        let next = candidate(&live.borrow(), name, value)?;
        live.send_replace(next);
        Ok(())
    }))
}

type Publishers = (
    Vec<Publisher<WrenchStamped>>,
    Vec<Publisher<LegForce>>,
    Vec<Publisher<ModelParams>>,
    Publisher<DiagnosticArray>,
);

/// Every leg's publishers (predicted wrench, leg force, model parameters) and `/diagnostics`.
fn publishers(node: &mut Node, cfg: &NodeConfig) -> Result<Publishers> {
    let topics = crate::config::OutputTopics::of(cfg, &cfg.remaps);
    let (mut wrench, mut force, mut params) = (Vec::new(), Vec::new(), Vec::new());
    for leg in &topics.legs {
        wrench.push(publisher::<WrenchStamped>(node, &leg.wrench)?);
        force.push(publisher::<LegForce>(node, &leg.force)?);
        params.push(publisher::<ModelParams>(node, &leg.params)?);
    }
    let diagnostics = publisher::<DiagnosticArray>(node, &topics.diagnostics)?;
    Ok((wrench, force, params, diagnostics))
}

/// The recorder, if the configuration asks for one; a failure to start is reported (and shown
/// on `/diagnostics`), and the node runs on.
fn start_recorder(cfg: &NodeConfig, params: &ParamMap) -> (Option<Arc<Recorder>>, Option<String>) {
    let Some(path) = &cfg.record else {
        return (None, None);
    };
    let opts = RecordOptions::with_node_params(params, &cfg.node_name, &cfg.namespace);
    match Recorder::start(path, opts, 1 << 16) {
        Ok(r) => (Some(Arc::new(r)), None),
        Err(e) => {
            let msg = format!("cannot record to {}: {e}", path.display());
            eprintln!("error: {msg}; the node runs without recording");
            (None, Some(msg))
        }
    }
}

/// Takes joint states off DDS, predicts, publishes and records, timing each from its arrival
/// to the last leg's predicted wrench.
async fn joint_states_task(
    sub: Subscription<JointState>,
    sh: Arc<Shared>,
    pubs: Arc<Pubs>,
    rec: Option<Arc<Recorder>>,
    topics: Arc<Topics>,
) {
    let mut gaps = SequenceGaps::default();
    let mut outputs: Vec<LegOutput> = Vec::new();
    let mut params_out = Vec::new();
    loop {
        let msg = next_sample(&sub, &mut gaps, &sh.dropped).await;
        let received = Instant::now();
        let log_ns = now_ns();
        {
            let core = &mut sh.lock_core().core;
            core.on_joint_state(&msg, &mut outputs);
            core.take_params(&mut params_out);
        }
        joint_state_done(
            rec.as_deref(),
            &topics,
            msg,
            &mut outputs,
            &mut params_out,
            log_ns,
            &*pubs,
            || {
                let ns = received.elapsed().as_nanos() as u64;
                sh.hist.lock().unwrap_or_else(|p| p.into_inner()).record(ns);
            },
        );
    }
}

/// Takes leg `leg`'s measured wrenches off DDS into its estimator; publishes and records the
/// parameters that come of them, and records the wrench.
async fn wrench_task(
    leg: usize,
    sub: Subscription<WrenchStamped>,
    sh: Arc<Shared>,
    pubs: Arc<Pubs>,
    rec: Option<Arc<Recorder>>,
    topics: Arc<Topics>,
) {
    let mut gaps = SequenceGaps::default();
    let mut params_out = Vec::new();
    loop {
        let msg = next_sample(&sub, &mut gaps, &sh.dropped).await;
        let log_ns = now_ns();
        {
            let core = &mut sh.lock_core().core;
            core.on_wrench(leg, &msg);
            core.take_params(&mut params_out);
        }
        wrench_done(
            rec.as_deref(),
            &topics,
            leg,
            msg,
            &mut params_out,
            log_ns,
            &*pubs,
        );
    }
}

/// The node's `/diagnostics`: the core's status with the processing time, publish errors and
/// the recorder's state; an error status when recording stopped.
fn node_status(
    shared: &Shared,
    publish_errors: &AtomicU64,
    recorder: &Option<Arc<Recorder>>,
    record_error: Option<&str>,
) -> DiagnosticArray {
    let mut values = {
        let h = shared.hist.lock().unwrap_or_else(|p| p.into_inner());
        let us = |ns: u64| format!("{:.1}", ns as f64 / 1e3);
        vec![
            ("processing_p50_us".to_string(), us(h.quantile_ns(0.5))),
            ("processing_p99_us".to_string(), us(h.quantile_ns(0.99))),
            ("processing_max_us".to_string(), us(h.max_ns())),
            (
                "publish_errors".to_string(),
                publish_errors.load(Ordering::Relaxed).to_string(),
            ),
        ]
    };
    let rec_error = recording_state(recorder, record_error, &mut values);
    let mut d = shared.lock_core().core.diagnostics(
        now_ns() as i64,
        shared.dropped.load(Ordering::Relaxed),
        &values,
    );
    if let (Some(e), Some(node_status)) = (rec_error, d.status.first_mut()) {
        node_status.level = crate::msgs::DiagnosticStatus::ERROR;
        node_status.message = format!("recording stopped: {e}");
    }
    d
}

/// What the run did, from the core's counters and the processing-time histogram.
fn run_summary(shared: &Shared, legs: usize) -> RunSummary {
    let guard = shared.core.lock().unwrap_or_else(|p| p.into_inner());
    let core = &guard.core;
    let hist = shared.hist.lock().unwrap_or_else(|p| p.into_inner());
    RunSummary {
        joint_states: core.counters().joint_states,
        predictions: (0..legs)
            .filter_map(|i| core.leg_counters(i))
            .map(|c| c.predictions)
            .sum(),
        dropped: shared.dropped.load(Ordering::Relaxed),
        processing_p50_ns: hist.quantile_ns(0.5),
        processing_p99_ns: hist.quantile_ns(0.99),
        processing_max_ns: hist.max_ns(),
        processing_count: hist.count(),
    }
}

/// Closes the recording and says what it holds.
fn finish_recording(r: Recorder) {
    let path = r.path.clone();
    let written = r.status.written.load(Ordering::Relaxed);
    let dropped = r.status.dropped.load(Ordering::Relaxed);
    match r.finish() {
        None => eprintln!(
            "recorded {written} messages to {} ({dropped} dropped)",
            path.display()
        ),
        Some(e) => eprintln!("error: recording to {} stopped: {e}", path.display()),
    }
}
