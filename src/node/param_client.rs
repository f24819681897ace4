//! A client of a running node's parameter services, as `ros2 param` is: read parameters, and
//! set one (the node validates it and says why it refuses).

use super::dds::{from_ros, to_ros, tool_node};
use crate::config::{ParamValue, parse_value};
use anyhow::{Context as _, Result, anyhow, bail};
use ros2_client::rcl_interfaces::{
    GetParametersRequest, GetParametersResponse, SetParametersRequest, SetParametersResponse,
};
use ros2_client::{
    Message, Name, Node, Parameter, ParameterValue, QosProfile, ServiceMapping, ServiceTypeName,
    qos::History, service::Client,
};
use std::time::Duration;

fn service_name(node: &str, service: &str) -> Result<Name> {
    let node = node.trim_end_matches('/');
    if !node.starts_with('/') {
        bail!("node {node:?}: give its full name, e.g. /terzaghi");
    }
    Name::new(node, service).map_err(|e| anyhow!("node {node:?}: {e:?}"))
}

/// Sends `request` to `service` and waits at most `timeout` for the answer.
///
/// - The wait for the service re-checks the match state every 250 ms: ros2-client wakes the
///   waiter by an event on a bounded channel, and an event dropped while the channel was full
///   would otherwise leave it waiting although the service had been found.
/// - A reply sent before the node has discovered our reply reader is lost (DDS discovery is not
///   symmetric), and a node's reply writer may refuse a reply while an earlier reader has not
///   acknowledged the last one; so a request unanswered for 1 s is sent again, and a reply to any
///   copy is taken (get and set are idempotent).
async fn call<Req: Message + Clone + 'static, Resp: Message + 'static>(
    node: &ros2_client::Node,
    client: &Client<Req, Resp>,
    service: &Name,
    request: Req,
    timeout: Duration,
) -> Result<Resp> {
    const RECHECK: Duration = Duration::from_millis(250);
    const RESEND: Duration = Duration::from_secs(1);
    const POLL: Duration = Duration::from_millis(10);
    let deadline = tokio::time::Instant::now() + timeout;
    let found = tokio::time::timeout_at(deadline, async {
        while tokio::time::timeout(RECHECK, client.wait_for_service(node))
            .await
            .is_err()
        {}
    })
    .await;
    if found.is_err() {
        bail!(
            "no service {service} found within {} s (is the node running, on this domain?)",
            timeout.as_secs_f64()
        );
    }
    let mut sent = Vec::new();
    let mut unreadable = None;
    while tokio::time::Instant::now() < deadline {
        // A request the writer could not take now is sent again at the next turn.
        if let Ok(id) = client.async_send_request(request.clone()).await {
            sent.push(id);
        }
        let resend_at = (tokio::time::Instant::now() + RESEND).min(deadline);
        while tokio::time::Instant::now() < resend_at {
            match client.receive_response() {
                Ok(Some((id, reply))) if sent.contains(&id) => return Ok(reply),
                Ok(Some(_)) => {} // a reply to another client
                Ok(None) => tokio::time::sleep(POLL).await,
                Err(e) => {
                    // Not ours to judge: the reply topic is shared by every client.
                    unreadable = Some(format!("{e:?}"));
                    tokio::time::sleep(POLL).await
                }
            }
        }
    }
    bail!(
        "the node's service {service} was found but answered none of {} requests within {} s{}",
        sent.len(),
        timeout.as_secs_f64(),
        unreadable.map_or(String::new(), |e| format!(
            " (a reply could not be read: {e})"
        ))
    )
}

/// A ROS 2 node that talks to other nodes' parameter services.
pub struct ParamClient {
    node: Node,
    spin: tokio::task::JoinHandle<()>,
    timeout: Duration,
}

impl ParamClient {
    /// Starts the client node; every call waits at most `timeout` for an answer. Runs on the
    /// calling thread's tokio runtime.
    pub fn new(timeout: Duration) -> Result<ParamClient> {
        let mut node = tool_node(&format!("terzaghi_param_{}", std::process::id())).context(
            crate::error::Failure("cannot create the client node".into()),
        )?;
        let spinner = node.spinner()?;
        let spin = tokio::spawn(async move {
            let _ = spinner.spin().await;
        });
        Ok(ParamClient {
            node,
            spin,
            timeout,
        })
    }

    /// A client of the service `service` (type `rcl_interfaces/<type_name>`) of node `target`.
    fn client<Req: Message + Clone + 'static, Resp: Message + 'static>(
        &mut self,
        target: &str,
        service: &str,
        type_name: &str,
    ) -> Result<(Client<Req, Resp>, Name)> {
        // A history of a few samples: a resent request is not held back by an earlier copy
        // that the node has not acknowledged yet.
        let qos = QosProfile::publisher_default().history(History::KeepLast { depth: 8 });
        let name = service_name(target, service)?;
        let client = self.node.create_client::<Req, Resp>(
            ServiceMapping::Enhanced,
            &name,
            &ServiceTypeName::new("rcl_interfaces", type_name),
            qos.clone(),
            qos,
        )?;
        Ok((client, name))
    }

    /// The values of `names` on the node `target` (e.g. `/terzaghi`); `None` for a parameter
    /// it does not have.
    pub async fn get(&mut self, target: &str, names: &[String]) -> Result<Vec<Option<ParamValue>>> {
        if names.is_empty() {
            bail!("name at least one parameter");
        }
        let (client, service) = self.client::<GetParametersRequest, GetParametersResponse>(
            target,
            "get_parameters",
            "GetParameters",
        )?;
        let request = GetParametersRequest {
            names: names.to_vec(),
        };
        let resp = call(&self.node, &client, &service, request, self.timeout).await?;
        Ok(resp
            .values
            .into_iter()
            .map(|v| from_ros(&ParameterValue::from(v)))
            .collect())
    }

    /// Sets `name` on the node `target` to `value`, typed as on the command line of ROS
    /// (`true`, `3`, `0.5`, `[a, b]`, text); an integer for a double parameter is taken as a
    /// double. An error gives the node's reason when it refuses.
    pub async fn set(&mut self, target: &str, name: &str, value: &str) -> Result<()> {
        // Learn the declared type first, so that `1` sets a double parameter to 1.0.
        let current = self
            .get(target, &[name.to_string()])
            .await?
            .into_iter()
            .next()
            .flatten();
        let mut new_value = parse_value(value);
        if let (Some(ParamValue::Double(_)), ParamValue::Int(i)) = (&current, &new_value) {
            new_value = ParamValue::Double(*i as f64);
        }
        let (client, service) = self.client::<SetParametersRequest, SetParametersResponse>(
            target,
            "set_parameters",
            "SetParameters",
        )?;
        let p = Parameter {
            name: name.to_string(),
            value: to_ros(&new_value),
        };
        let request = SetParametersRequest {
            parameter: vec![p.into()],
        };
        let resp = call(&self.node, &client, &service, request, self.timeout).await?;
        match resp.results.first() {
            Some(r) if r.successful => Ok(()),
            Some(r) => bail!("the node refused {name} = {value}: {}", r.reason),
            None => bail!("the node gave no result"),
        }
    }

    /// Leaves the network.
    pub async fn close(self) {
        self.node.stop_spinner();
        let _ = tokio::time::timeout(Duration::from_secs(1), self.spin).await;
    }
}
