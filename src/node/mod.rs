//! The ROS 2 node: [`core`] is what it does with each message (pure), [`dds`] connects it to a
//! ROS 2 network through ros2-client, [`latency`] keeps its processing-time statistics.

pub mod core;
pub mod dds;
pub mod handle;
pub mod latency;

pub use core::{LegOutput, NodeCore};
