//! `--ros-args`: `-p name:=value`, `--params-file FILE`, `-r __node:=NAME`, `-r __ns:=/NS`,
//! `-r from:=to`, `--log-level [LOGGER:=]LEVEL`, `--disable-rosout-logs`,
//! `--disable-stdout-logs`, as `ros2 run` passes them.

use super::{ConfigError, ParamValue, parse_value};
use std::path::PathBuf;

/// What `--ros-args` said.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RosArgs {
    /// `-p name:=value`, in order (later wins).
    pub params: Vec<(String, ParamValue)>,
    /// `--params-file FILE`, in order.
    pub params_files: Vec<PathBuf>,
    /// `-r __node:=NAME`.
    pub node_name: Option<String>,
    /// `-r __ns:=NAMESPACE`.
    pub namespace: Option<String>,
    /// `-r from:=to` topic remappings.
    pub remaps: Vec<(String, String)>,
    /// `--log-level LEVEL`, or `--log-level LOGGER:=LEVEL` for the node's own logger.
    pub log_level: Option<LogLevel>,
    /// `--disable-rosout-logs`: no log lines on `/rosout`.
    pub rosout_logs_disabled: bool,
    /// `--disable-stdout-logs`: no log lines on the console (stderr).
    pub stdout_logs_disabled: bool,
}

/// ROS 2 log severities, with the values of `rcl_interfaces/msg/Log`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum LogLevel {
    /// Debugging detail.
    Debug = 10,
    /// Normal operation.
    Info = 20,
    /// Something needs attention.
    Warn = 30,
    /// Something failed.
    Error = 40,
    /// The node cannot go on.
    Fatal = 50,
}

impl LogLevel {
    /// As `--log-level` takes it: `debug`, `info`, `warn`, `error`, `fatal`, any case.
    pub fn parse(s: &str) -> Option<LogLevel> {
        Some(match s.to_ascii_lowercase().as_str() {
            "debug" => LogLevel::Debug,
            "info" => LogLevel::Info,
            "warn" | "warning" => LogLevel::Warn,
            "error" => LogLevel::Error,
            "fatal" => LogLevel::Fatal,
            _ => return None,
        })
    }

    /// The severity's name as ROS prints it (`INFO`).
    pub fn as_str(self) -> &'static str {
        match self {
            LogLevel::Debug => "DEBUG",
            LogLevel::Info => "INFO",
            LogLevel::Warn => "WARN",
            LogLevel::Error => "ERROR",
            LogLevel::Fatal => "FATAL",
        }
    }
}

/// Splits `args` into the program's own arguments and what `--ros-args ... [--]` says.
pub fn parse_ros_args(args: &[String]) -> Result<(Vec<String>, RosArgs), ConfigError> {
    let mut own = Vec::new();
    let mut ros = RosArgs::default();
    let mut i = 0;
    let mut in_ros = false;
    let need = |i: usize, flag: &str| -> Result<String, ConfigError> {
        args.get(i + 1)
            .cloned()
            .ok_or_else(|| ConfigError::RosArgs(format!("{flag} needs a value")))
    };
    while i < args.len() {
        let a = args[i].as_str();
        if !in_ros {
            if a == "--ros-args" {
                in_ros = true;
            } else {
                own.push(args[i].clone());
            }
            i += 1;
            continue;
        }
        match a {
            "--" => in_ros = false,
            "--ros-args" => {}
            "-p" | "--param" => {
                let v = need(i, a)?;
                let (name, value) = v.split_once(":=").ok_or_else(|| {
                    ConfigError::RosArgs(format!("{a} {v:?}: expected name:=value"))
                })?;
                if name.is_empty() {
                    return Err(ConfigError::RosArgs(format!(
                        "{a} {v:?}: empty parameter name"
                    )));
                }
                ros.params.push((name.to_string(), parse_value(value)));
                i += 1;
            }
            "--params-file" => {
                ros.params_files.push(PathBuf::from(need(i, a)?));
                i += 1;
            }
            "-r" | "--remap" => {
                let v = need(i, a)?;
                let (from, to) = v
                    .split_once(":=")
                    .ok_or_else(|| ConfigError::RosArgs(format!("{a} {v:?}: expected from:=to")))?;
                // `node:from:=to` targets one node; we are the only node in this process.
                let from = from.rsplit_once(':').map(|(_, f)| f).unwrap_or(from);
                match from {
                    "__node" | "__name" => ros.node_name = Some(to.to_string()),
                    "__ns" => ros.namespace = Some(to.to_string()),
                    _ if from.is_empty() || to.is_empty() => {
                        return Err(ConfigError::RosArgs(format!("{a} {v:?}: empty name")));
                    }
                    _ => ros.remaps.push((from.to_string(), to.to_string())),
                }
                i += 1;
            }
            "--log-level" => {
                let v = need(i, a)?;
                // `LOGGER:=LEVEL` sets one logger; this node has one, its own.
                let level = v.split_once(":=").map(|(_, l)| l).unwrap_or(&v);
                ros.log_level = Some(LogLevel::parse(level).ok_or_else(|| {
                    ConfigError::RosArgs(format!(
                        "{a} {v:?}: unknown level (debug, info, warn, error, fatal)"
                    ))
                })?);
                i += 1;
            }
            "-e" | "--enclave" => i += 1, // accepted; security enclaves are not supported
            "--disable-rosout-logs" => ros.rosout_logs_disabled = true,
            "--disable-stdout-logs" => ros.stdout_logs_disabled = true,
            "--enable-rosout-logs" => ros.rosout_logs_disabled = false,
            "--enable-stdout-logs" => ros.stdout_logs_disabled = false,
            other => {
                return Err(ConfigError::RosArgs(format!(
                    "unknown argument {other:?} (known: -p, --param, --params-file, -r, --remap, --log-level, --)"
                )));
            }
        }
        i += 1;
    }
    Ok((own, ros))
}
