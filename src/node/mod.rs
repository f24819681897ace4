//! The ROS 2 node: [`core`] is what it does with each message (pure), [`dds`] connects it to a
//! ROS 2 network through ros2-client, [`memory`] runs it over an in-memory transport, [`handle`]
//! is the code path after the core that both share, [`latency`] keeps its processing-time
//! statistics, [`log`] writes its log to stderr and `/rosout`, `clock` is its time (the
//! wall clock, or `/clock` with `use_sim_time`), [`live`] serves its topics to Foxglove,
//! [`param_client`] reads and sets a running node's parameters.

#[cfg(feature = "node")]
pub(crate) mod clock;
pub mod core;
#[cfg(feature = "node")]
pub mod dds;
#[cfg(feature = "node")]
pub(crate) mod gap_worker;
#[cfg(feature = "node")]
pub mod handle;
pub mod latency;
#[cfg(feature = "node")]
pub mod live;
#[cfg(feature = "node")]
pub mod log;
pub(crate) mod matcher;
#[cfg(feature = "node")]
pub mod memory;
#[cfg(feature = "node")]
pub mod param_client;
#[cfg(feature = "node")]
pub mod realtime;

pub use core::{Input, LegOutput, NodeCore, Outputs};
