//! A live view of the node in Foxglove or Lichtblick: `terzaghi node --foxglove [ADDR:PORT]`
//! serves what the node reads and writes over the Foxglove WebSocket protocol
//! (`foxglove.websocket.v1`, the `foxglove` crate's server), each topic with its ROS 2 schema
//! (`ros2msg`) and CDR messages, as the Foxglove bridge serves a ROS graph. The app then plots
//! predicted against measured forces as they happen.
//!
//! Nothing is serialized for a topic no client subscribes to: with no client connected, a
//! message costs the node one atomic load per topic. A client that stops reading loses the
//! oldest messages of its queue (bounded, `BACKLOG` messages), and is dropped if its control
//! queue fills; the node never waits for it.

use super::handle::Topics;
use crate::msgs::{
    DiagnosticArray, JointState, LegForce, ModelParams, RosLog, RosMessage, WrenchStamped, to_cdr,
};
use anyhow::{Context as _, Result};
use foxglove::{ChannelBuilder, Context, PartialMetadata, RawChannel, Schema, WebSocketServer};
use std::net::SocketAddr;
use std::sync::Arc;

/// Messages queued per client before its oldest are dropped.
const BACKLOG: usize = 4096;

/// One topic of the live view.
#[derive(Clone)]
pub struct LiveChannel(Arc<RawChannel>);

impl LiveChannel {
    /// Sends `msg` to the clients subscribed to this topic, stamped with the time now.
    #[inline]
    pub fn log<M: RosMessage>(&self, msg: &M) {
        if !self.0.has_sinks() {
            return;
        }
        if let Ok(bytes) = to_cdr(msg) {
            self.0.log_with_meta(&bytes, PartialMetadata::default());
        }
    }
}

/// The node's topics in the live view: what it reads (joint states, each leg's F/T) and what it
/// writes (each leg's predicted wrench, leg force and parameters, `/diagnostics`, `/rosout`).
pub struct Live {
    /// The WebSocket server.
    pub server: LiveServer,
    /// The joint states the node reads.
    pub joints: LiveChannel,
    /// Per leg; `None` for a leg without an F/T topic.
    pub ft: Vec<Option<LiveChannel>>,
    /// Per leg, its predicted wrench.
    pub wrench: Vec<LiveChannel>,
    /// Per leg, its force.
    pub force: Vec<LiveChannel>,
    /// Per leg, its model parameters.
    pub params: Vec<LiveChannel>,
    /// `/diagnostics`.
    pub diagnostics: LiveChannel,
    /// `/rosout`.
    pub rosout: LiveChannel,
}

impl Live {
    /// Serves `topics` on `addr`, as server `name`.
    pub async fn start(addr: SocketAddr, name: &str, topics: &Topics) -> Result<Live> {
        let server = LiveServer::start(addr, name).await?;
        let per_leg = |names: &[Arc<str>], f: &dyn Fn(&str) -> Result<LiveChannel>| {
            names.iter().map(|t| f(t)).collect::<Result<Vec<_>>>()
        };
        let ft = topics
            .ft
            .iter()
            .map(|t| {
                (!t.is_empty())
                    .then(|| server.channel::<WrenchStamped>(t))
                    .transpose()
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Live {
            joints: server.channel::<JointState>(&topics.joints)?,
            ft,
            wrench: per_leg(&topics.wrench, &|t| server.channel::<WrenchStamped>(t))?,
            force: per_leg(&topics.force, &|t| server.channel::<LegForce>(t))?,
            params: per_leg(&topics.params, &|t| server.channel::<ModelParams>(t))?,
            diagnostics: server.channel::<DiagnosticArray>(&topics.diagnostics)?,
            rosout: server.channel::<RosLog>("/rosout")?,
            server,
        })
    }
}

/// The server and its context; dropped, it stops.
pub struct LiveServer {
    context: Arc<Context>,
    server: Option<foxglove::WebSocketServerHandle>,
    /// The address the server listens on.
    pub addr: SocketAddr,
}

impl LiveServer {
    /// Serves on `addr` (port 0: any free port; [`LiveServer::addr`] says which). Called from a
    /// tokio runtime, on which the server runs.
    pub async fn start(addr: SocketAddr, name: &str) -> Result<LiveServer> {
        let context = Context::new();
        let server = WebSocketServer::new()
            .name(name)
            .bind(addr.ip().to_string(), addr.port())
            .message_backlog_size(BACKLOG)
            .context(&context)
            .start()
            .await
            .with_context(|| format!("cannot serve the Foxglove live view on {addr}"))?;
        let addr = SocketAddr::new(addr.ip(), server.port());
        Ok(LiveServer {
            context,
            server: Some(server),
            addr,
        })
    }

    /// The channel of `topic`, carrying messages of type `M`.
    pub fn channel<M: RosMessage>(&self, topic: &str) -> Result<LiveChannel> {
        let schema = Schema::new(M::type_name(), "ros2msg", M::schema_text().into_bytes());
        let ch = ChannelBuilder::new(topic)
            .message_encoding("cdr")
            .schema(schema)
            .context(&self.context)
            .build_raw()
            .with_context(|| format!("cannot add {topic} to the live view"))?;
        Ok(LiveChannel(ch))
    }

    /// How many clients are connected.
    pub fn clients(&self) -> usize {
        self.server.as_ref().map_or(0, |s| s.client_count())
    }
}

impl Drop for LiveServer {
    fn drop(&mut self) {
        if let Some(s) = self.server.take() {
            // The shutdown handle finishes in the background.
            drop(s.stop());
        }
    }
}
