//! The node's log, as ROS 2 nodes log: each line at or above the level `--log-level` sets goes
//! to stderr (`[WARN] [1700000000.123456789] [robot.terzaghi]: ...`) and, as an
//! `rcl_interfaces/msg/Log` with the logger's name, level, file, function and line, to
//! `/rosout`, where `ros2 topic echo /rosout`, rqt_console and Foxglove's log panel show it.
//!
//! A line that an input can cause once per message is throttled per call site, as
//! `RCLCPP_WARN_THROTTLE` does: at most one per period, carrying the count of those it held
//! back. A flood of bad messages then costs a counter increment each, not a line each.

use crate::config::LogLevel;
use ros2_client::builtin_interfaces::Time;
use ros2_client::log::LogLevel as RosLogLevel;
use ros2_client::{NodeLoggingHandle, RosoutRaw};
use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

/// Where a log line was written in the source.
#[derive(Debug, Clone, Copy)]
pub struct Site {
    /// The source file.
    pub file: &'static str,
    /// The module path (rosout's `function`).
    pub function: &'static str,
    /// The line.
    pub line: u32,
}

/// The site (file, line and module) of the macro's caller, for its log lines.
#[macro_export]
macro_rules! log_site {
    () => {
        $crate::node::log::Site {
            file: file!(),
            function: module_path!(),
            line: line!(),
        }
    };
}

/// What `--ros-args` asked of the log.
#[derive(Debug, Clone, Copy)]
pub struct LogSettings {
    /// The lowest level written.
    pub level: LogLevel,
    /// Lines go to standard error.
    pub stderr: bool,
    /// Lines go to `/rosout`.
    pub rosout: bool,
}

impl Default for LogSettings {
    fn default() -> Self {
        LogSettings {
            level: LogLevel::Info,
            stderr: true,
            rosout: true,
        }
    }
}

struct Throttled {
    last: Instant,
    held_back: u64,
}

/// The node's logger. Lines written before [`NodeLog::attach`] go to stderr only.
pub struct NodeLog {
    /// The logger's name: the namespace and the node's name joined by dots (`robot.terzaghi`),
    /// as rclcpp and rclpy name a node's logger.
    name: String,
    settings: LogSettings,
    rosout: OnceLock<NodeLoggingHandle>,
    /// The live view's `/rosout`, with `--foxglove`.
    live: OnceLock<super::live::LiveChannel>,
    throttle: Mutex<HashMap<(&'static str, u32), Throttled>>,
}

impl NodeLog {
    /// The log of the node `node_name` in `namespace`.
    pub fn new(namespace: &str, node_name: &str, settings: LogSettings) -> NodeLog {
        NodeLog {
            name: logger_name(namespace, node_name),
            settings,
            rosout: OnceLock::new(),
            live: OnceLock::new(),
            throttle: Mutex::new(HashMap::new()),
        }
    }

    /// From now on, lines go to `/rosout` as well (unless `--disable-rosout-logs`).
    pub fn attach(&self, handle: NodeLoggingHandle) {
        if self.settings.rosout {
            let _ = self.rosout.set(handle);
        }
    }

    /// From now on, lines go to the live view's `/rosout` as well (unless
    /// `--disable-rosout-logs`).
    pub fn attach_live(&self, channel: super::live::LiveChannel) {
        if self.settings.rosout {
            let _ = self.live.set(channel);
        }
    }

    /// The logger's name (`namespace.node`, as rosout names it).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Whether a line at `level` would be written.
    pub fn enabled(&self, level: LogLevel) -> bool {
        level >= self.settings.level
    }

    /// Writes `msg` at `level` from `site`, where the settings ask for it.
    pub fn log(&self, level: LogLevel, msg: &str, site: Site) {
        if !self.enabled(level) {
            return;
        }
        // Log lines are stamped with the system time, as rcutils stamps them.
        let stamp = Time::now();
        if self.settings.stderr {
            let ns = stamp.to_nanos();
            eprintln!(
                "[{}] [{}.{:09}] [{}]: {msg}",
                level.as_str(),
                ns.div_euclid(1_000_000_000),
                ns.rem_euclid(1_000_000_000),
                self.name
            );
        }
        if let Some(ch) = self.live.get() {
            ch.log(&crate::msgs::RosLog {
                stamp: crate::msgs::Time::from_nanos(stamp.to_nanos()).unwrap_or_default(),
                level: level as u8,
                name: self.name.clone(),
                msg: msg.to_string(),
                file: site.file.to_string(),
                function: site.function.to_string(),
                line: site.line,
            });
        }
        if let Some(h) = self.rosout.get() {
            h.rosout_raw(
                stamp,
                ros_level(level),
                &self.name,
                msg,
                site.file,
                site.function,
                site.line,
            );
        }
    }

    /// Logs at most one line per `period` from `site`; the line says how many were held back
    /// since the last one. `msg` is only made when a line is written.
    pub fn throttled(
        &self,
        level: LogLevel,
        period: Duration,
        site: Site,
        msg: impl FnOnce() -> String,
    ) {
        if !self.enabled(level) {
            return;
        }
        let now = Instant::now();
        let held_back = {
            let mut t = self.throttle.lock().unwrap_or_else(|p| p.into_inner());
            // Keyed by call site: a fixed, small set, so the map stays bounded.
            match t.entry((site.file, site.line)) {
                std::collections::hash_map::Entry::Occupied(mut e) => {
                    let s = e.get_mut();
                    if now.duration_since(s.last) < period {
                        s.held_back += 1;
                        return;
                    }
                    s.last = now;
                    std::mem::take(&mut s.held_back)
                }
                std::collections::hash_map::Entry::Vacant(e) => {
                    e.insert(Throttled {
                        last: now,
                        held_back: 0,
                    });
                    0
                }
            }
        };
        let mut line = msg();
        if held_back > 0 {
            line.push_str(&format!(
                " ({held_back} more like this since the last such line)"
            ));
        }
        self.log(level, &line, site);
    }
}

/// `robot.terzaghi` for node `terzaghi` in namespace `/robot`; `terzaghi` in `/`.
pub fn logger_name(namespace: &str, node_name: &str) -> String {
    namespace
        .split('/')
        .filter(|s| !s.is_empty())
        .chain(std::iter::once(node_name))
        .collect::<Vec<_>>()
        .join(".")
}

fn ros_level(l: LogLevel) -> RosLogLevel {
    match l {
        LogLevel::Debug => RosLogLevel::Debug,
        LogLevel::Info => RosLogLevel::Info,
        LogLevel::Warn => RosLogLevel::Warn,
        LogLevel::Error => RosLogLevel::Error,
        LogLevel::Fatal => RosLogLevel::Fatal,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn logger_names_follow_rclcpp() {
        assert_eq!(logger_name("/", "terzaghi"), "terzaghi");
        assert_eq!(logger_name("/robot/front", "t"), "robot.front.t");
    }

    #[test]
    fn a_repeated_line_is_held_back_and_counted() {
        let log = NodeLog::new(
            "/",
            "t",
            LogSettings {
                level: LogLevel::Info,
                stderr: false,
                rosout: false,
            },
        );
        let mut made = Vec::new();
        for i in 0..1000 {
            log.throttled(
                LogLevel::Warn,
                Duration::from_secs(60),
                crate::log_site!(),
                || {
                    made.push(i);
                    format!("bad {i}")
                },
            );
        }
        // One line made, the rest counted without formatting anything.
        assert_eq!(made, vec![0]);
        let t = log.throttle.lock().unwrap();
        assert_eq!(t.values().map(|s| s.held_back).sum::<u64>(), 999);
        drop(t);
        // Below the level: nothing made, nothing counted.
        log.throttled(LogLevel::Debug, Duration::ZERO, crate::log_site!(), || {
            panic!("made a debug line at level info")
        });
    }
}
