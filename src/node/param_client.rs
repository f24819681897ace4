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
        let mut node = tool_node(&format!("terzaghi_param_{}", std::process::id()))
            .context("cannot create the client node")?;
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
    ) -> Result<Client<Req, Resp>> {
        let qos = QosProfile::publisher_default().history(History::KeepLast { depth: 1 });
        Ok(self.node.create_client::<Req, Resp>(
            ServiceMapping::Enhanced,
            &service_name(target, service)?,
            &ServiceTypeName::new("rcl_interfaces", type_name),
            qos.clone(),
            qos,
        )?)
    }

    /// The values of `names` on the node `target` (e.g. `/terzaghi`); `None` for a parameter
    /// it does not have.
    pub async fn get(&mut self, target: &str, names: &[String]) -> Result<Vec<Option<ParamValue>>> {
        if names.is_empty() {
            bail!("name at least one parameter");
        }
        let client = self.client::<GetParametersRequest, GetParametersResponse>(
            target,
            "get_parameters",
            "GetParameters",
        )?;
        let request = GetParametersRequest {
            names: names.to_vec(),
        };
        let resp = call(&self.node, &client, request, self.timeout).await?;
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
        let client = self.client::<SetParametersRequest, SetParametersResponse>(
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
        let resp = call(&self.node, &client, request, self.timeout).await?;
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
