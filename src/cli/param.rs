//! `terzaghi param get|set`: read and change a running node's parameters over its parameter
//! services, as `ros2 param` does, without a ROS installation (the client is
//! [`terzaghi::node::param_client`]).

use anyhow::{Result, bail};
use clap::{Args, Subcommand};
use std::time::Duration;
use terzaghi::node::param_client::ParamClient;

#[derive(Debug, Args)]
pub struct ParamArgs {
    #[command(subcommand)]
    pub action: ParamAction,
    /// Seconds to wait for the node's services.
    #[arg(long, default_value_t = 10.0, global = true)]
    pub timeout_s: f64,
}

#[derive(Debug, Subcommand)]
pub enum ParamAction {
    /// Print parameter values.
    Get {
        /// The node, e.g. /terzaghi or /robot/terzaghi.
        node: String,
        /// The parameters to print, e.g. front_left.b_k use_identified.
        names: Vec<String>,
    },
    /// Set one parameter; the node validates it and says why if it refuses.
    Set {
        /// The node, e.g. /terzaghi or /robot/terzaghi.
        node: String,
        /// The parameter, e.g. front_left.b_k.
        name: String,
        /// The value, typed as on the command line of ROS: true, 3, 0.5, [a, b], text.
        #[arg(allow_hyphen_values = true)]
        value: String,
    },
}

pub fn run(a: ParamArgs) -> Result<()> {
    if !(a.timeout_s.is_finite() && a.timeout_s > 0.0) {
        bail!("--timeout-s must be a positive number, got {}", a.timeout_s);
    }
    let timeout = Duration::from_secs_f64(a.timeout_s);
    let rt = terzaghi::node::dds::runtime()?;
    rt.block_on(async move {
        let mut client = ParamClient::new(timeout)?;
        let result = match &a.action {
            ParamAction::Get {
                node: target,
                names,
            } => match client.get(target, names).await {
                Ok(values) => {
                    let mut out = String::new();
                    for (name, v) in names.iter().zip(values) {
                        let shown = v.map_or_else(|| "(not set)".to_string(), |v| v.to_string());
                        out += &format!("{name}: {shown}\n");
                    }
                    super::print_out(&out)
                }
                Err(e) => Err(e),
            },
            ParamAction::Set {
                node: target,
                name,
                value,
            } => match client.set(target, name, value).await {
                Ok(()) => super::print_out(&format!("set {name} = {value}\n")),
                Err(e) => Err(e),
            },
        };
        client.close().await;
        result
    })
}
