//! The ROS 2 node: [`core`] is what it does with each message (pure), [`dds`] connects it to a
//! ROS 2 network through ros2-client, `memory` runs it over an in-memory transport, [`handle`]
//! is the code path after the core that both share, [`latency`] keeps its processing-time
//! statistics, `log` writes its log to stderr and `/rosout`, `clock` is its time (the
//! wall clock, or `/clock` with `use_sim_time`), [`live`] serves its topics to Foxglove.

pub(crate) mod clock;
pub mod core;
pub mod dds;
pub(crate) mod gap_worker;
pub mod handle;
pub mod latency;
pub mod live;
pub(crate) mod log;
pub(crate) mod matcher;
pub(crate) mod memory;
pub(crate) mod param_client;
pub mod realtime;

pub use core::{Input, LegOutput, NodeCore, Outputs};
