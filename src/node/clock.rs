//! The node's clock: the wall clock, or with the parameter `use_sim_time` the time `/clock`
//! (`rosgraph_msgs/msg/Clock`) last gave, as every ROS 2 node keeps it (0 until the first
//! `/clock` arrives). It stamps the diagnostics and the recorder's receive times, and
//! ros2-client stamps the parameter events with the same time.
//!
//! A clock that goes back (a log played again from its start, a simulator reset) is followed,
//! as ROS follows it, and counted, so that the node can say so.

use ros2_client::Node;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

pub struct NodeClock {
    node: Arc<Node>,
    /// The last time read: a later read that is earlier is a jump back.
    last_ns: Mutex<i64>,
    jumps_back: AtomicU64,
}

impl NodeClock {
    pub fn new(node: Arc<Node>) -> NodeClock {
        NodeClock {
            node,
            last_ns: Mutex::new(i64::MIN),
            jumps_back: AtomicU64::new(0),
        }
    }

    /// The node's time now, in ns since the epoch (of the simulation, with `use_sim_time`).
    pub fn now_ns(&self) -> i64 {
        // Read under the lock, so that two tasks reading at once cannot see each other's
        // reads out of order and call it a jump.
        let mut last = self.last_ns.lock().unwrap_or_else(|p| p.into_inner());
        let now = self.node.time_now().to_nanos();
        if now < *last {
            self.jumps_back.fetch_add(1, Ordering::Relaxed);
        }
        *last = now;
        now
    }

    /// [`NodeClock::now_ns`] as a recording's log time: a time before the epoch (a simulation
    /// clock set so) reads 0.
    pub fn log_time_ns(&self) -> u64 {
        self.now_ns().max(0) as u64
    }

    /// Whether the time follows `/clock` (the parameter `use_sim_time`).
    pub fn simulated(&self) -> bool {
        matches!(
            self.node.get_parameter("use_sim_time"),
            Some(ros2_client::ParameterValue::Boolean(true))
        )
    }

    /// How often the time went back, since the start.
    pub fn jumps_back(&self) -> u64 {
        self.jumps_back.load(Ordering::Relaxed)
    }
}
