//! `terzaghi node`: the ROS 2 node.

use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::PathBuf;
use terzaghi::config::{LogLevel, NodeConfig, ParamValue, load_params, parse_ros_args};
use terzaghi::node::dds::{NodeSetup, run as run_node};
use terzaghi::node::log::LogSettings;

#[derive(Debug, Args)]
#[command(
    after_help = "ROS arguments: --ros-args [-p NAME:=VALUE]... [--params-file FILE]... \
[-r __node:=NAME] [-r __ns:=/NAMESPACE] [-r FROM:=TO]... [--log-level LEVEL] \
[--disable-rosout-logs] [--disable-stdout-logs] [--]\n\
Environment: ROS_DOMAIN_ID (0-232), ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST or \
ROS_LOCALHOST_ONLY=1 (DDS on loopback only).\n\
Simulated time: -p use_sim_time:=true, and the node's time (diagnostics, parameter events, \
recorded receive times) follows /clock (rosgraph_msgs/msg/Clock).\n\
Parameters: see launch_configs/ and docs/node.md.\n\
Built by colcon (docs/node.md, in a colcon workspace): ros2 run terzaghi terzaghi node ...; \
ros2 launch terzaghi rhex.launch.xml, rhex.launch.yaml, testbed.launch.xml or \
testbed.launch.yaml (params_file:=FILE); parameter files in \
$(ros2 pkg prefix terzaghi)/share/terzaghi/launch_configs/."
)]
pub struct NodeArgs {
    /// Record the session (inputs and outputs) to this MCAP file (or the parameter `record`).
    #[arg(long, value_name = "FILE.mcap")]
    pub record: Option<PathBuf>,
    /// Replace the recording (--record or the parameter `record`) if it exists; by default an
    /// existing file is refused.
    #[arg(long)]
    pub overwrite: bool,
    /// Run the message handling under SCHED_FIFO with this priority (1-99), as real-time
    /// control nodes do, so that other threads do not preempt it (needs CAP_SYS_NICE or root).
    #[arg(long, value_name = "PRIORITY")]
    pub realtime_priority: Option<i32>,
    /// Pin the node (every thread it starts, DDS's included) to this CPU, as real-time control
    /// nodes are given a core of their own. With --realtime-priority, the DDS threads then
    /// send what the node published right after it, instead of preempting it.
    #[arg(long, value_name = "CPU")]
    pub cpu: Option<usize>,
    /// Serve the node's topics live to Foxglove or Lichtblick (Foxglove WebSocket protocol) on
    /// ADDR:PORT; default 127.0.0.1:8765 (this machine only). Open
    /// launch_configs/testbed.foxglove.json in the app for plots of predicted against measured
    /// forces.
    #[arg(long, value_name = "ADDR:PORT", num_args = 0..=1, default_missing_value = "127.0.0.1:8765")]
    pub foxglove: Option<String>,
    /// ROS arguments, after --ros-args.
    #[arg(
        trailing_var_arg = true,
        allow_hyphen_values = true,
        value_name = "--ros-args ..."
    )]
    pub ros_args: Vec<String>,
}

/// Resolves when SIGINT or SIGTERM arrives.
pub async fn shutdown_signal() {
    #[cfg(unix)]
    {
        use tokio::signal::unix::{SignalKind, signal};
        match signal(SignalKind::terminate()) {
            Ok(mut term) => {
                tokio::select! {
                    _ = tokio::signal::ctrl_c() => {}
                    _ = term.recv() => {}
                }
            }
            Err(_) => {
                let _ = tokio::signal::ctrl_c().await;
            }
        }
    }
    #[cfg(not(unix))]
    {
        let _ = tokio::signal::ctrl_c().await;
    }
}

/// Reads the parameters and the environment into a setup, without starting anything.
pub fn setup(a: &NodeArgs) -> Result<NodeSetup> {
    let (own, ros) = parse_ros_args(&a.ros_args)?;
    if let Some(first) = own.first() {
        bail!("unexpected argument {first:?} (ROS arguments go after --ros-args)");
    }
    let node_name = ros
        .node_name
        .clone()
        .unwrap_or_else(|| "terzaghi".to_string());
    let namespace = ros.namespace.clone().unwrap_or_else(|| "/".to_string());
    let mut params = load_params(&ros, &node_name, &namespace)?;
    if let Some(path) = &a.record {
        params.insert(
            "record".into(),
            ParamValue::String(path.display().to_string()),
        );
    }
    let config = NodeConfig::from_params(&params, &node_name, &namespace, &ros.remaps)?;
    if let Some(path) = &config.record {
        let inputs: Vec<&std::path::Path> = ros.params_files.iter().map(|p| p.as_path()).collect();
        terzaghi::session::files::refuse_output_over_input(path, &inputs)?;
        terzaghi::session::files::refuse_existing_recording(path, a.overwrite)?;
    }
    let params = config.effective_params(&params);
    let (domain_id, localhost_only) = terzaghi::node::dds::network_from_env()?;
    let foxglove = match &a.foxglove {
        None => None,
        Some(s) => Some(s.parse::<std::net::SocketAddr>().map_err(|_| {
            anyhow::anyhow!("--foxglove {s:?}: expected ADDR:PORT, e.g. 127.0.0.1:8765")
        })?),
    };
    Ok(NodeSetup {
        params,
        config,
        domain_id,
        localhost_only,
        log: LogSettings {
            level: ros.log_level.unwrap_or(LogLevel::Info),
            stderr: !ros.stdout_logs_disabled,
            rosout: !ros.rosout_logs_disabled,
        },
        foxglove,
    })
}

pub fn run(a: NodeArgs) -> Result<()> {
    let setup = setup(&a)?;
    // One thread: each message is handled where it is taken off DDS, and on two cores more
    // threads only add wake-ups and preemption to the processing time.
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .context(terzaghi::session::Failure(
            "cannot start the async runtime".into(),
        ))?;
    // Before DDS starts its threads, so that they inherit both.
    if let Some(cpu) = a.cpu {
        terzaghi::node::realtime::pin_to_cpus(&[cpu]).context("--cpu")?;
    }
    if let Some(priority) = a.realtime_priority {
        terzaghi::node::realtime::set_realtime(priority).context("--realtime-priority")?;
    }
    // The node logs its start and what it did at the end (stderr and /rosout).
    rt.block_on(run_node(setup, shutdown_signal()))?;
    rt.shutdown_timeout(std::time::Duration::from_secs(2));
    Ok(())
}
