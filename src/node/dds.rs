//! The node on a ROS 2 network, through ros2-client (RustDDS): subscriptions feed a bounded
//! queue, one task runs [`NodeCore`] on it and publishes; parameter services run, and a change
//! of a parameter is validated as a whole configuration before it takes effect.

use super::clock::NodeClock;
use super::core::{Input, NodeCore, Outputs};
use super::handle::{
    Publish, Topics, diagnostics_done, gap_done, joint_state_done, pose_done, tf_done, wrench_done,
};
use super::latency::Histogram;
use super::live::Live as LiveView;
use super::log::{LogSettings, NodeLog};
use crate::config::{LogLevel, NodeConfig, ParamMap, ParamValue, STARTUP_ONLY};
use crate::log_site;
use crate::msgs::{
    DiagnosticArray, Gap, JointState, LegForce, ModelParams, PoseStamped, RosMessage, TfMessage,
    WrenchStamped,
};
use crate::record::RecordOptions;
use crate::record::recorder::Recorder;
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
    /// The parameters as given, which the node serves.
    pub params: ParamMap,
    /// The configuration validated from them.
    pub config: NodeConfig,
    /// The DDS domain (`ROS_DOMAIN_ID`).
    pub domain_id: u16,
    /// Whether discovery stays on this machine (`ROS_LOCALHOST_ONLY`).
    pub localhost_only: bool,
    /// `--log-level`, `--disable-rosout-logs`, `--disable-stdout-logs`.
    pub log: LogSettings,
    /// `--foxglove ADDR:PORT`: serve the live view there.
    pub foxglove: Option<std::net::SocketAddr>,
}

/// What a run did, printed at shutdown.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct RunSummary {
    /// JointStates taken off DDS.
    pub joint_states: u64,
    /// Leg predictions published.
    pub predictions: u64,
    /// Messages dropped at the bounded input queue.
    pub dropped: u64,
    /// Samples that did not decode as their topic's type (truncated, oversized for their
    /// fields, garbage), skipped.
    pub undecodable: u64,
    /// From taking a JointState off DDS to having published every leg's outputs.
    pub processing_p50_ns: u64,
    /// 99th percentile of the processing time (ns).
    pub processing_p99_ns: u64,
    /// Longest processing time (ns).
    pub processing_max_ns: u64,
    /// JointStates whose processing was timed.
    pub processing_count: u64,
}

/// What the message tasks share.
struct Shared {
    core: Mutex<Core>,
    /// Runs the node's own diagnoses off the message path (none when `gap_check` is off).
    gap: Option<super::gap_worker::GapWorker>,
    hist: Mutex<Histogram>,
    dropped: AtomicU64,
    /// Samples that did not decode, skipped.
    undecodable: AtomicU64,
    log: Arc<NodeLog>,
    clock: Arc<NodeClock>,
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
    gap: Vec<Publisher<Gap>>,
    diagnostics: Publisher<DiagnosticArray>,
    errors: Arc<AtomicU64>,
    /// Asked, before each write, whether anyone subscribes: writing to nobody costs a DDS
    /// write per message, skipped.
    node: Arc<Node>,
    /// The live view, with `--foxglove`.
    live: Option<Arc<LiveView>>,
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
        if let Some(l) = &self.live {
            l.wrench[leg].log(&msg);
        }
        self.send(&self.wrench[leg], msg);
    }
    fn force(&self, leg: usize, msg: LegForce) {
        if let Some(l) = &self.live {
            l.force[leg].log(&msg);
        }
        self.send(&self.force[leg], msg);
    }
    fn params(&self, leg: usize, msg: ModelParams) {
        if let Some(l) = &self.live {
            l.params[leg].log(&msg);
        }
        self.send(&self.params[leg], msg);
    }
    fn gap(&self, leg: usize, msg: Gap) {
        self.send(&self.gap[leg], msg);
    }
    fn diagnostics(&self, msg: DiagnosticArray) {
        if let Some(l) = &self.live {
            l.diagnostics.log(&msg);
        }
        if self.diagnostics.publish(msg).is_err() {
            self.errors.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// The next sample of `sub`: one that does not decode is counted (`undecodable`) and skipped;
/// the samples missing before it (gaps in its writer's sequence numbers) are counted as dropped.
async fn next_sample<M: serde::de::DeserializeOwned + 'static>(
    sub: &Subscription<M>,
    gaps: &mut SequenceGaps,
    sh: &Shared,
) -> M {
    loop {
        match sub.async_take().await {
            Ok((msg, info)) => {
                sh.dropped.fetch_add(gaps.lost(&info), Ordering::Relaxed);
                return msg;
            }
            Err(_) => {
                sh.undecodable.fetch_add(1, Ordering::Relaxed);
            }
        }
    }
}

/// Samples lost before they reached us: gaps in each writer's sequence numbers.
#[derive(Default)]
pub struct SequenceGaps(HashMap<ros2_client::Gid, i64>);

impl SequenceGaps {
    /// How many samples of this sample's writer were lost since the last one taken from it.
    pub fn lost(&mut self, info: &ros2_client::MessageInfo) -> u64 {
        let seq = info.sequence_number();
        match self.0.insert(info.publisher_gid(), seq) {
            Some(prev) if seq > prev + 1 => (seq - prev - 1) as u64,
            _ => 0,
        }
    }
}

/// The QoS of the node's subscriptions: best effort (which matches every publisher), a deep history.
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

/// [`qos_out`], transient local, keeping the last sample: a subscriber that joins late
/// (transient local, as a planner started after the node asks) gets the latest at once.
pub fn qos_latched() -> QosProfile {
    qos_out()
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
}

fn topic_name(full: &str) -> Result<Name> {
    Name::parse(full).map_err(|e| anyhow!("bad topic name {full:?}: {e:?}"))
}

fn message_type<M: RosMessage>() -> MessageTypeName {
    MessageTypeName::new(M::TYPE.0, M::TYPE.1)
}

/// A publisher of `M` on `topic` with [`qos_out`].
pub fn publisher<M: RosMessage>(node: &mut Node, topic: &str) -> Result<Publisher<M>> {
    publisher_with_qos(node, topic, qos_out())
}

/// A publisher of `M` on `topic` with `qos`.
pub fn publisher_with_qos<M: RosMessage>(
    node: &mut Node,
    topic: &str,
    qos: QosProfile,
) -> Result<Publisher<M>> {
    let t = node
        .create_topic(&topic_name(topic)?, message_type::<M>(), &qos)
        .with_context(|| crate::error::Failure(format!("cannot create topic {topic}")))?;
    node.create_publisher::<M>(&t, Some(qos))
        .with_context(|| format!("cannot publish {topic}"))
}

/// A subscription to `M` on `topic` with [`qos_in`].
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
        .with_context(|| crate::error::Failure(format!("cannot create topic {topic}")))?;
    node.create_subscription::<M>(&t, Some(qos))
        .with_context(|| format!("cannot subscribe to {topic}"))
}

/// A parameter value as ros2-client serves it.
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

/// A parameter value from ros2-client; `None` for a type the node has no parameter of.
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
        .context(crate::error::Failure("cannot create a ROS 2 node".into()))
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
    let log = Arc::new(NodeLog::new(&cfg.namespace, &cfg.node_name, setup.log));
    let topics = Arc::new(Topics::new(&cfg));
    let live = match setup.foxglove {
        Some(addr) => {
            let l = LiveView::start(addr, &format!("terzaghi {}", log.name()), &topics).await?;
            log.attach_live(l.rosout.clone());
            Some(Arc::new(l))
        }
        None => None,
    };
    let mut node = context
        .new_node(
            node_name,
            node_options(&setup.params, Arc::new(live_tx), log.clone()),
        )
        .context(crate::error::Failure("cannot create the ROS 2 node".into()))?;
    log.attach(node.logging_handle());
    log.log(LogLevel::Info, &startup_line(&setup), log_site!());
    if let Some(l) = &live {
        log.log(
            LogLevel::Info,
            &format!(
                "live view on ws://{} (Foxglove WebSocket; layout in launch_configs/)",
                l.server.addr
            ),
            log_site!(),
        );
    }
    let spinner = node.spinner().context("cannot start the node's spinner")?;
    let spin_task = tokio::spawn(spinner.spin());
    let (wrench, force, params, gap, diagnostics) = publishers(&mut node, &cfg)?;

    let subs = subscriptions(&mut node, &cfg)?;
    // From here on the node is shared: the message tasks ask it who subscribes, and the clock
    // asks it the time.
    let node = Arc::new(node);
    let clock = Arc::new(NodeClock::new(node.clone()));

    // Each message is handled in the task that takes it off DDS (no hand-off, which would add a
    // thread wake-up to every JointState). The DDS reader's KeepLast history is the bounded
    // queue: under a flood the oldest samples go, and the gaps in the writers' sequence numbers
    // count them.
    let shared = Arc::new(Shared {
        core: Mutex::new(Core {
            core: NodeCore::new(cfg.clone()),
            live: live_rx,
        }),
        gap: if cfg.gap_check.every_strokes > 0 {
            Some(
                super::gap_worker::GapWorker::start()
                    .context("cannot start the diagnosis thread")?,
            )
        } else {
            None
        },
        hist: Mutex::new(Histogram::default()),
        dropped: AtomicU64::new(0),
        undecodable: AtomicU64::new(0),
        log: log.clone(),
        clock: clock.clone(),
    });
    let pubs = Arc::new(Pubs {
        wrench,
        force,
        params,
        gap,
        diagnostics,
        errors: Arc::new(AtomicU64::new(0)),
        node: node.clone(),
        live: live.clone(),
    });
    let (recorder, record_error) = start_recorder(&cfg, &setup.params, &log);
    let tasks = spawn_tasks(subs, &shared, &pubs, &recorder, &topics);
    let mut diag_tick = tokio::time::interval(Duration::from_secs_f64(cfg.diagnostics_period_s));
    diag_tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut watch = Watch::default();
    tokio::pin!(shutdown);
    loop {
        tokio::select! {
            _ = &mut shutdown => break,
            _ = diag_tick.tick() => {
                on_tick(&shared, &pubs, &recorder, record_error.as_deref(), &topics, &mut watch, &cfg);
            }
        }
    }

    for t in &tasks {
        t.abort();
    }
    for t in tasks {
        let _ = t.await;
    }
    let summary = run_summary(&shared, cfg.legs.len());
    log_gap_counts(&shared, cfg.legs.len(), &log);
    log.log(LogLevel::Info, &summary_line(&summary), log_site!());
    if let Some(r) = recorder.and_then(|r| Arc::try_unwrap(r).ok()) {
        finish_recording(r, &log);
    }
    node.stop_spinner();
    let _ = tokio::time::timeout(Duration::from_secs(2), spin_task).await;
    // Dropping the node and context tells DDS peers that we left.
    drop(pubs);
    drop(shared);
    drop(clock);
    drop(log);
    drop(node);
    drop(context);
    Ok(summary)
}

/// The node's subscriptions: joint states, the robot's state (`/tf`, `/tf_static`, a body pose)
/// where a leg needs it, and each leg's F/T.
struct Subscriptions {
    joint_states: Subscription<JointState>,
    /// `(static, subscription)` of `/tf` and `/tf_static`.
    tf: Vec<(bool, Subscription<TfMessage>)>,
    pose: Option<(Arc<str>, Subscription<PoseStamped>)>,
    /// `(leg index, subscription)`.
    ft: Vec<(usize, Subscription<WrenchStamped>)>,
}

fn subscriptions(node: &mut Node, cfg: &NodeConfig) -> Result<Subscriptions> {
    let depth = cfg.queue_depth;
    let joint_states = subscription_with_depth::<JointState>(node, &cfg.joint_states_topic, depth)?;
    // The robot's state, for the legs it places: /tf as any input, /tf_static reliable and
    // transient local, as tf2's static broadcaster offers it (so that transforms sent before
    // the node started reach it).
    let mut tf_subs = Vec::new();
    if cfg.legs.iter().any(|l| l.hip_frame.is_some()) {
        use crate::config::{TF_STATIC_TOPIC, TF_TOPIC};
        tf_subs.push((
            false,
            subscription_with_depth::<TfMessage>(node, TF_TOPIC, depth)?,
        ));
        let latched = QosProfile::subscription_default()
            .reliability_reliable(WhenFull::DEFAULT)
            .durability(Durability::TransientLocal)
            .history(History::KeepLast { depth: 100 });
        let t = node
            .create_topic(
                &topic_name(TF_STATIC_TOPIC)?,
                message_type::<TfMessage>(),
                &latched,
            )
            .context(crate::error::Failure("cannot create /tf_static".into()))?;
        tf_subs.push((
            true,
            node.create_subscription::<TfMessage>(&t, Some(latched))
                .context("cannot subscribe to /tf_static")?,
        ));
    }
    let pose_sub = match &cfg.robot_state.pose_topic {
        Some(topic) => Some((
            Arc::<str>::from(topic.as_str()),
            subscription_with_depth::<PoseStamped>(node, topic, depth)?,
        )),
        None => None,
    };
    let mut ft_subs = Vec::new();
    for (i, leg) in cfg.legs.iter().enumerate() {
        if let Some(topic) = &leg.ft_topic {
            ft_subs.push((
                i,
                subscription_with_depth::<WrenchStamped>(node, topic, depth)?,
            ));
        }
    }
    Ok(Subscriptions {
        joint_states,
        tf: tf_subs,
        pose: pose_sub,
        ft: ft_subs,
    })
}

/// A task per subscription, each handling its messages as it takes them off DDS.
fn spawn_tasks(
    subs: Subscriptions,
    shared: &Arc<Shared>,
    pubs: &Arc<Pubs>,
    recorder: &Option<Arc<Recorder>>,
    topics: &Arc<Topics>,
) -> Vec<tokio::task::JoinHandle<()>> {
    let mut tasks = vec![tokio::spawn(joint_states_task(
        subs.joint_states,
        shared.clone(),
        pubs.clone(),
        recorder.clone(),
        topics.clone(),
    ))];
    for (fixed, sub) in subs.tf {
        tasks.push(tokio::spawn(tf_task(
            fixed,
            sub,
            shared.clone(),
            recorder.clone(),
        )));
    }
    if let Some((topic, sub)) = subs.pose {
        tasks.push(tokio::spawn(pose_task(
            topic,
            sub,
            shared.clone(),
            recorder.clone(),
        )));
    }
    for (i, sub) in subs.ft {
        tasks.push(tokio::spawn(wrench_task(
            i,
            sub,
            shared.clone(),
            pubs.clone(),
            recorder.clone(),
            topics.clone(),
        )));
    }

    tasks
}

/// The diagnostics' tick: the node's own diagnoses that are done published, `/diagnostics`
/// published and recorded, and the watch on inputs reported.
fn on_tick(
    shared: &Shared,
    pubs: &Pubs,
    recorder: &Option<Arc<Recorder>>,
    record_error: Option<&str>,
    topics: &Topics,
    watch: &mut Watch,
    cfg: &NodeConfig,
) {
    let (log, clock) = (&shared.log, &shared.clock);
    if let Some(worker) = &shared.gap {
        let mut done = Vec::new();
        worker.done(&mut done);
        let now = clock.log_time_ns();
        for (job, result) in &done {
            let warning = {
                let core = &mut shared.lock_core().core;
                gap_done(recorder.as_deref(), topics, core, job, result, now, pubs)
            };
            if let Some(w) = warning {
                log.log(LogLevel::Warn, &w, log_site!());
            }
        }
    }
    let d = node_status(shared, &pubs.errors, recorder, record_error);
    watch.report(shared, recorder.as_deref(), cfg);
    let now = clock.log_time_ns();
    diagnostics_done(recorder.as_deref(), topics, d, now, pubs);
}

/// At shutdown, how many of its own diagnoses the node made and how many were superseded.
fn log_gap_counts(shared: &Shared, legs: usize, log: &NodeLog) {
    if shared.gap.is_some() {
        let (made, skipped) = {
            let guard = shared.core.lock().unwrap_or_else(|p| p.into_inner());
            (0..legs).fold((0, 0), |(m, s), i| {
                let (a, b) = guard.core.gap_counts(i);
                (m + a, s + b)
            })
        };
        log.log(
            LogLevel::Info,
            &format!(
                "the node's own diagnoses: {made} of recent strokes, {skipped} superseded while waiting for the diagnosis thread"
            ),
            log_site!(),
        );
    }
}

/// The first line the node logs: who it is and what it listens to, and the speed law each RFT
/// leg fitted to its table.
fn startup_line(setup: &NodeSetup) -> String {
    let c = &setup.config;
    let shapes: String = c
        .legs
        .iter()
        .filter_map(|l| {
            Some(format!(
                "; {}: RFT's shape {}",
                l.name,
                l.rft_shape_text.as_ref()?
            ))
        })
        .collect();
    let speed_laws: String = c
        .legs
        .iter()
        .filter_map(|l| {
            let f = l.rft_speed?;
            Some(format!(
                "; {}: RFT's elements k (v - {} m/s) deeper up to {} m/s, k {} (by direction of motion below the horizontal), from its intrusions at speed ({:.0} % of the change)",
                l.name,
                f.law.ref_speed_m_s,
                f.law.max_speed_m_s,
                f.law.gains_text(),
                100.0 * f.explained
            ))
        })
        .collect();
    format!(
        "terzaghi node {}/{}: {} legs ({}), model {}, joint states on {}, domain {}{}{speed_laws}{shapes}",
        c.namespace.trim_end_matches('/'),
        c.node_name,
        c.legs.len(),
        c.legs
            .iter()
            .map(|l| l.name.as_str())
            .collect::<Vec<_>>()
            .join(", "),
        c.model.as_str(),
        c.joint_states_topic,
        setup.domain_id,
        if setup.localhost_only {
            ", localhost only"
        } else {
            ""
        }
    )
}

/// The last line the node logs: what it did.
fn summary_line(s: &RunSummary) -> String {
    format!(
        "terzaghi node stopped: {} joint states, {} predictions, {} inputs dropped, {} samples that did not decode skipped; processing p50 {:.1} us, p99 {:.1} us, max {:.1} us",
        s.joint_states,
        s.predictions,
        s.dropped,
        s.undecodable,
        s.processing_p50_ns as f64 / 1e3,
        s.processing_p99_ns as f64 / 1e3,
        s.processing_max_ns as f64 / 1e3
    )
}

/// What the diagnostics tick says in the log when it changed: inputs dropped, the clock going
/// back, the recording stopping.
#[derive(Default)]
struct Watch {
    dropped: u64,
    jumps_back: u64,
    recording_failed: bool,
}

impl Watch {
    fn report(&mut self, shared: &Shared, recorder: Option<&Recorder>, cfg: &NodeConfig) {
        let log = &shared.log;
        let dropped = shared.dropped.load(Ordering::Relaxed);
        if dropped > self.dropped {
            log.log(
                LogLevel::Warn,
                &format!(
                    "{} inputs dropped since the last diagnostics ({dropped} since start): \
                     the node falls behind its inputs (queue_depth {})",
                    dropped - self.dropped,
                    cfg.queue_depth
                ),
                log_site!(),
            );
            self.dropped = dropped;
        }
        let jumps = shared.clock.jumps_back();
        if jumps > self.jumps_back {
            log.log(
                LogLevel::Warn,
                &format!(
                    "the node's time went back {} times since the last diagnostics{}: \
                     stamps and receive times follow it",
                    jumps - self.jumps_back,
                    if shared.clock.simulated() {
                        " (/clock, use_sim_time)"
                    } else {
                        " (the system clock)"
                    }
                ),
                log_site!(),
            );
            self.jumps_back = jumps;
        }
        // A recording that could not start was logged then; this is one that stopped since.
        if let Some(r) = recorder.filter(|r| r.status.failed.load(Ordering::Relaxed))
            && !self.recording_failed
        {
            let e = r.status.error.lock().ok().and_then(|e| e.clone());
            log.log(
                LogLevel::Error,
                &format!(
                    "recording to {} stopped: {}",
                    r.path.display(),
                    e.as_deref().unwrap_or("write failed")
                ),
                log_site!(),
            );
            self.recording_failed = true;
        }
    }
}

/// The node's options: rosout, its parameters declared, and a change of a parameter validated
/// as a whole configuration before it is sent to the message tasks on `live`; changes and
/// refusals are logged.
fn node_options(
    params: &ParamMap,
    live: Arc<watch::Sender<Live>>,
    log: Arc<NodeLog>,
) -> NodeOptions {
    let mut opts = NodeOptions::new().enable_rosout(true);
    for (name, value) in params {
        opts = opts.declare_parameter(name, to_ros(value));
    }
    let check = live.clone();
    let check_log = log.clone();
    opts.parameter_validator(Box::new(move |name, value| {
        candidate(&check.borrow(), name, value)
            .map(|_| ())
            .inspect_err(|e| {
                check_log.log(
                    LogLevel::Warn,
                    &format!("parameter {name} not set to {}: {e}", show(value)),
                    log_site!(),
                )
            })
    }))
    .parameter_set_action(Box::new(move |name, value| {
        let changed = from_ros(value).as_ref() != live.borrow().params.get(name);
        let next = candidate(&live.borrow(), name, value)?;
        live.send_replace(next);
        if changed {
            log.log(
                LogLevel::Info,
                &format!("parameter {name} set to {}", show(value)),
                log_site!(),
            );
        }
        Ok(())
    }))
}

/// A parameter value as `ros2 param` shows it.
fn show(v: &ParameterValue) -> String {
    match from_ros(v) {
        Some(p) => p.to_string(),
        None => format!("{v:?}"),
    }
}

type Publishers = (
    Vec<Publisher<WrenchStamped>>,
    Vec<Publisher<LegForce>>,
    Vec<Publisher<ModelParams>>,
    Vec<Publisher<Gap>>,
    Publisher<DiagnosticArray>,
);

/// Every leg's publishers (predicted wrench, leg force, model parameters) and `/diagnostics`.
fn publishers(node: &mut Node, cfg: &NodeConfig) -> Result<Publishers> {
    let topics = crate::config::OutputTopics::of(cfg, &cfg.remaps);
    let (mut wrench, mut force, mut params, mut gap) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for leg in &topics.legs {
        wrench.push(publisher::<WrenchStamped>(node, &leg.wrench)?);
        force.push(publisher::<LegForce>(node, &leg.force)?);
        // The latest estimate, for subscribers that join later.
        params.push(publisher_with_qos::<ModelParams>(
            node,
            &leg.params,
            qos_latched(),
        )?);
        // The latest diagnosis of the leg's own strokes, for subscribers that join later.
        gap.push(publisher_with_qos::<Gap>(node, &leg.gap, qos_latched())?);
    }
    let diagnostics = publisher::<DiagnosticArray>(node, &topics.diagnostics)?;
    Ok((wrench, force, params, gap, diagnostics))
}

/// The recorder, if the configuration asks for one; a failure to start is reported (and shown
/// on `/diagnostics`), and the node runs on.
fn start_recorder(
    cfg: &NodeConfig,
    params: &ParamMap,
    log: &NodeLog,
) -> (Option<Arc<Recorder>>, Option<String>) {
    let Some(path) = &cfg.record else {
        return (None, None);
    };
    let opts = RecordOptions::with_node_params(params, &cfg.node_name, &cfg.namespace);
    match Recorder::start(path, opts, 1 << 16) {
        Ok(r) => {
            log.log(
                LogLevel::Info,
                &format!("recording to {}", path.display()),
                log_site!(),
            );
            (Some(Arc::new(r)), None)
        }
        Err(e) => {
            let msg = format!("cannot record to {}: {e}", path.display());
            log.log(
                LogLevel::Error,
                &format!("{msg}; the node runs without recording"),
                log_site!(),
            );
            (None, Some(msg))
        }
    }
}

/// At most one line per second for each kind of skipped input: a flood of bad messages costs a
/// counter each, not a line each.
const LOG_THROTTLE: Duration = Duration::from_secs(1);

/// JointStates skipped, whole or for a leg, since start.
fn skipped_joint_states(core: &NodeCore) -> u64 {
    let legs: u64 = (0..core.legs())
        .filter_map(|i| core.leg_counters(i))
        .map(|c| c.missing_joint + c.invalid_position + c.stamps_backwards)
        .sum();
    core.counters().invalid_joint_states + legs
}

fn skipped_joint_state_line(sh: &Shared) -> String {
    let c = sh.lock_core();
    let core = &c.core;
    let mut parts = vec![format!(
        "{} malformed (arrays of unequal length, invalid stamp)",
        core.counters().invalid_joint_states
    )];
    for i in 0..core.legs() {
        if let (Some(l), Some(name)) = (core.leg_counters(i), core.leg_name(i)) {
            parts.push(format!(
                "{name}: {} without its joint, {} non-finite positions, {} stamps older than the last",
                l.missing_joint, l.invalid_position, l.stamps_backwards
            ));
        }
    }
    format!("joint states skipped, since start: {}", parts.join("; "))
}

/// F/T samples of `leg` skipped since start.
fn skipped_wrenches(core: &NodeCore, leg: usize) -> u64 {
    core.leg_counters(leg)
        .map(|c| c.ft_invalid + c.ft_unmatched)
        .unwrap_or(0)
}

fn skipped_wrench_line(sh: &Shared, leg: usize) -> String {
    let c = sh.lock_core();
    let core = &c.core;
    let name = core.leg_name(leg).unwrap_or("?");
    match core.leg_counters(leg) {
        Some(l) => format!(
            "F/T samples of {name} skipped, since start: {} non-finite or with an invalid stamp, \
             {} without a joint angle within max_match_dt_s",
            l.ft_invalid, l.ft_unmatched
        ),
        None => format!("F/T samples of {name} skipped"),
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
    let mut outputs = Outputs::default();
    loop {
        let msg = next_sample(&sub, &mut gaps, &sh).await;
        let received = Instant::now();
        if let Some(l) = &pubs.live {
            l.joints.log(&msg);
        }
        let log_ns = sh.clock.log_time_ns();
        let skipped = {
            let core = &mut sh.lock_core().core;
            let before = skipped_joint_states(core);
            core.handle(Input::Joints(&msg), &mut outputs);
            skipped_joint_states(core) - before
        };
        if skipped > 0 {
            sh.log
                .throttled(LogLevel::Warn, LOG_THROTTLE, log_site!(), || {
                    skipped_joint_state_line(&sh)
                });
        }
        joint_state_done(
            rec.as_deref(),
            &topics,
            msg,
            &mut outputs,
            log_ns,
            &*pubs,
            || {
                let ns = received.elapsed().as_nanos() as u64;
                sh.hist.lock().unwrap_or_else(|p| p.into_inner()).record(ns);
            },
        );
    }
}

/// Takes `/tf` (or `/tf_static`, `fixed`) off DDS into the core's transform tree, and records
/// it.
async fn tf_task(
    fixed: bool,
    sub: Subscription<TfMessage>,
    sh: Arc<Shared>,
    rec: Option<Arc<Recorder>>,
) {
    use crate::config::{TF_STATIC_TOPIC, TF_TOPIC};
    let topic: Arc<str> = if fixed { TF_STATIC_TOPIC } else { TF_TOPIC }.into();
    let mut gaps = SequenceGaps::default();
    let mut outputs = Outputs::default();
    loop {
        let msg = next_sample(&sub, &mut gaps, &sh).await;
        let log_ns = sh.clock.log_time_ns();
        // The robot's state gives no outputs of its own: it places the next predictions.
        sh.lock_core()
            .core
            .handle(Input::Tf(&msg, fixed), &mut outputs);
        outputs.clear();
        tf_done(rec.as_deref(), &topic, msg, log_ns);
    }
}

/// Takes the body's pose off DDS (`robot_state.pose_topic`) into the core's transform tree, and
/// records it.
async fn pose_task(
    topic: Arc<str>,
    sub: Subscription<PoseStamped>,
    sh: Arc<Shared>,
    rec: Option<Arc<Recorder>>,
) {
    let mut gaps = SequenceGaps::default();
    let mut outputs = Outputs::default();
    loop {
        let msg = next_sample(&sub, &mut gaps, &sh).await;
        let log_ns = sh.clock.log_time_ns();
        sh.lock_core().core.handle(Input::Pose(&msg), &mut outputs);
        outputs.clear();
        pose_done(rec.as_deref(), &topic, msg, log_ns);
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
    let mut outputs = Outputs::default();
    loop {
        let msg = next_sample(&sub, &mut gaps, &sh).await;
        if let Some(ch) = pubs.live.as_ref().and_then(|l| l.ft[leg].as_ref()) {
            ch.log(&msg);
        }
        let log_ns = sh.clock.log_time_ns();
        let skipped = {
            let core = &mut sh.lock_core().core;
            let before = skipped_wrenches(core, leg);
            core.handle(Input::Wrench(leg, &msg), &mut outputs);
            if let Some(g) = &sh.gap {
                g.offer(core);
            }
            skipped_wrenches(core, leg) - before
        };
        if skipped > 0 {
            sh.log
                .throttled(LogLevel::Warn, LOG_THROTTLE, log_site!(), || {
                    skipped_wrench_line(&sh, leg)
                });
        }
        wrench_done(
            rec.as_deref(),
            &topics,
            leg,
            msg,
            &mut outputs,
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
    values.push((
        "clock".to_string(),
        if shared.clock.simulated() {
            "/clock (use_sim_time)".to_string()
        } else {
            "system".to_string()
        },
    ));
    values.push((
        "clock_jumps_back".to_string(),
        shared.clock.jumps_back().to_string(),
    ));
    values.push((
        "undecodable_samples".to_string(),
        shared.undecodable.load(Ordering::Relaxed).to_string(),
    ));
    let mut d = shared.lock_core().core.diagnostics(
        shared.clock.now_ns(),
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
        undecodable: shared.undecodable.load(Ordering::Relaxed),
        processing_p50_ns: hist.quantile_ns(0.5),
        processing_p99_ns: hist.quantile_ns(0.99),
        processing_max_ns: hist.max_ns(),
        processing_count: hist.count(),
    }
}

/// Closes the recording and says what it holds.
fn finish_recording(r: Recorder, log: &NodeLog) {
    let path = r.path.clone();
    let written = r.status.written.load(Ordering::Relaxed);
    let dropped = r.status.dropped.load(Ordering::Relaxed);
    match r.finish() {
        None => log.log(
            LogLevel::Info,
            &format!(
                "recorded {written} messages to {} ({dropped} dropped)",
                path.display()
            ),
            log_site!(),
        ),
        Some(e) => log.log(
            LogLevel::Error,
            &format!("recording to {} stopped: {e}", path.display()),
            log_site!(),
        ),
    }
}
