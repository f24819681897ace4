//! `terzaghi param get|set`: read and change a running node's parameters over its parameter
//! services, as `ros2 param` does, without a ROS installation.

use crate::config::{ParamValue, parse_value};
use crate::node::dds::{from_ros, to_ros, tool_node};
use anyhow::{Context as _, Result, anyhow, bail};
use clap::{Args, Subcommand};
use ros2_client::rcl_interfaces::{
    GetParametersRequest, GetParametersResponse, SetParametersRequest, SetParametersResponse,
};
use ros2_client::{
    Message, Name, Parameter, ParameterValue, QosProfile, ServiceMapping, ServiceTypeName,
    qos::History, service::Client,
};
use std::time::Duration;

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
        names: Vec<String>,
    },
    /// Set one parameter; the node validates it and says why if it refuses.
    Set {
        node: String,
        name: String,
        /// The value, typed as on the command line of ROS: true, 3, 0.5, [a, b], text.
        #[arg(allow_hyphen_values = true)]
        value: String,
    },
}

fn service_name(node: &str, service: &str) -> Result<Name> {
    let node = node.trim_end_matches('/');
    if !node.starts_with('/') {
        bail!("node {node:?}: give its full name, e.g. /terzaghi");
    }
    Name::new(node, service).map_err(|e| anyhow!("node {node:?}: {e:?}"))
}

/// Sends `request` and waits for the answer. A reply sent before the node has discovered our
/// reply reader is lost (DDS discovery is not symmetric), so a request unanswered for 2 s is
/// sent again; get and set are idempotent.
async fn call<Req: Message + Clone + 'static, Resp: Message + 'static>(
    node: &ros2_client::Node,
    client: &Client<Req, Resp>,
    request: Req,
    timeout: Duration,
) -> Result<Resp> {
    const RETRY: Duration = Duration::from_secs(2);
    tokio::time::timeout(timeout, async {
        client.wait_for_service(node).await;
        loop {
            let id = client
                .async_send_request(request.clone())
                .await
                .map_err(|e| anyhow!("cannot send the request: {e:?}"))?;
            if let Ok(reply) = tokio::time::timeout(RETRY, client.async_receive_response(id)).await
            {
                return reply.map_err(|e| anyhow!("no response: {e:?}"));
            }
        }
    })
    .await
    .map_err(|_| {
        anyhow!(
            "the node did not answer within {} s (is it running, on this domain?)",
            timeout.as_secs_f64()
        )
    })?
}

fn show(v: &ParameterValue) -> String {
    from_ros(v)
        .map(|p| p.to_string())
        .unwrap_or_else(|| "(not set)".into())
}

pub fn run(a: ParamArgs) -> Result<()> {
    if !(a.timeout_s.is_finite() && a.timeout_s > 0.0) {
        bail!("--timeout-s must be a positive number, got {}", a.timeout_s);
    }
    let timeout = Duration::from_secs_f64(a.timeout_s);
    let rt = super::runtime()?;
    rt.block_on(async move {
        let mut node = tool_node(&format!("terzaghi_param_{}", std::process::id()))
            .context("cannot create the client node")?;
        let spin = tokio::spawn(node.spinner()?.spin());
        let qos = QosProfile::publisher_default().history(History::KeepLast { depth: 1 });
        let result = match a.action {
            ParamAction::Get {
                node: target,
                names,
            } => {
                if names.is_empty() {
                    bail!("name at least one parameter");
                }
                let client = node.create_client::<GetParametersRequest, GetParametersResponse>(
                    ServiceMapping::Enhanced,
                    &service_name(&target, "get_parameters")?,
                    &ServiceTypeName::new("rcl_interfaces", "GetParameters"),
                    qos.clone(),
                    qos,
                )?;
                let resp = call(
                    &node,
                    &client,
                    GetParametersRequest {
                        names: names.clone(),
                    },
                    timeout,
                )
                .await?;
                let mut out = String::new();
                for (name, v) in names.iter().zip(resp.values) {
                    out += &format!("{name}: {}\n", show(&ParameterValue::from(v)));
                }
                super::print_out(&out)
            }
            ParamAction::Set {
                node: target,
                name,
                value,
            } => {
                // Learn the declared type first, so that `1` sets a double parameter to 1.0.
                let getter = node.create_client::<GetParametersRequest, GetParametersResponse>(
                    ServiceMapping::Enhanced,
                    &service_name(&target, "get_parameters")?,
                    &ServiceTypeName::new("rcl_interfaces", "GetParameters"),
                    qos.clone(),
                    qos.clone(),
                )?;
                let request = GetParametersRequest {
                    names: vec![name.clone()],
                };
                let current = call(&node, &getter, request, timeout)
                    .await?
                    .values
                    .into_iter()
                    .next()
                    .map(ParameterValue::from);
                let mut new_value = parse_value(&value);
                if let (Some(ParameterValue::Double(_)), ParamValue::Int(i)) =
                    (&current, &new_value)
                {
                    new_value = ParamValue::Double(*i as f64);
                }
                let client = node.create_client::<SetParametersRequest, SetParametersResponse>(
                    ServiceMapping::Enhanced,
                    &service_name(&target, "set_parameters")?,
                    &ServiceTypeName::new("rcl_interfaces", "SetParameters"),
                    qos.clone(),
                    qos,
                )?;
                let p = Parameter {
                    name: name.clone(),
                    value: to_ros(&new_value),
                };
                let resp = call(
                    &node,
                    &client,
                    SetParametersRequest {
                        parameter: vec![p.into()],
                    },
                    timeout,
                )
                .await?;
                match resp.results.first() {
                    Some(r) if r.successful => super::print_out(&format!("set {name} = {value}\n")),
                    Some(r) => bail!("the node refused {name} = {value}: {}", r.reason),
                    None => bail!("the node gave no result"),
                }
            }
        };
        node.stop_spinner();
        let _ = tokio::time::timeout(Duration::from_secs(1), spin).await;
        result
    })
}
