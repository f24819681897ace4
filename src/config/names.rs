//! ROS names: resolution of topic names under a namespace and node with remapping, checks
//! of node and namespace names, and the topics the node publishes.

use super::ConfigError;

/// Resolves a topic name as ROS does: absolute stays, `~/x` is under the node, relative is
/// under the namespace; then the first matching remap rule applies.
pub fn resolve_topic(
    name: &str,
    namespace: &str,
    node: &str,
    remaps: &[(String, String)],
) -> String {
    let ns = namespace.trim_end_matches('/');
    let full = if name.starts_with('/') {
        name.to_string()
    } else if let Some(rest) = name.strip_prefix("~/") {
        format!("{ns}/{node}/{rest}")
    } else {
        format!("{ns}/{name}")
    };
    for (from, to) in remaps {
        let from_full = resolve_topic(from, namespace, node, &[]);
        if from_full == full {
            return resolve_topic(to, namespace, node, &[]);
        }
    }
    full
}

/// Checks a node or namespace name for characters ROS does not allow.
pub(super) fn check_name(what: &str, name: &str, allow_slash: bool) -> Result<(), ConfigError> {
    let ok = !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || (allow_slash && c == '/'))
        && !name.starts_with(|c: char| c.is_ascii_digit());
    if ok {
        Ok(())
    } else {
        Err(ConfigError::RosArgs(format!(
            "{what} {name:?}: use letters, digits and _ (not starting with a digit)"
        )))
    }
}

/// The topics one leg's outputs are published on.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LegTopics {
    /// `<leg>/predicted_wrench` (geometry_msgs/WrenchStamped).
    pub wrench: String,
    /// `<leg>/leg_force` (terzaghi_msgs/LegForce).
    pub force: String,
    /// `<leg>/model_params` (terzaghi_msgs/ModelParams).
    pub params: String,
    /// `<leg>/gap` (terzaghi_msgs/Gap).
    pub gap: String,
}

/// Every topic the node publishes, resolved under its namespace and node name with `remaps`
/// applied: the one place these names are made.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OutputTopics {
    /// By leg, in the order of the `legs` parameter.
    pub legs: Vec<LegTopics>,
    /// `/diagnostics` (diagnostic_msgs/DiagnosticArray).
    pub diagnostics: String,
}

impl OutputTopics {
    /// The topics of the node configured by `cfg`, with `remaps` applied.
    pub fn of(cfg: &super::NodeConfig, remaps: &[(String, String)]) -> OutputTopics {
        let resolve = |rel: &str| resolve_topic(rel, &cfg.namespace, &cfg.node_name, remaps);
        OutputTopics {
            legs: cfg
                .legs
                .iter()
                .map(|l| LegTopics {
                    wrench: resolve(&format!("{}/predicted_wrench", l.name)),
                    force: resolve(&format!("{}/leg_force", l.name)),
                    params: resolve(&format!("{}/model_params", l.name)),
                    gap: resolve(&format!("{}/gap", l.name)),
                })
                .collect(),
            diagnostics: resolve("/diagnostics"),
        }
    }
}

/// The robot's transforms, as tf2 publishes them (absolute names: not in the node's namespace).
pub const TF_TOPIC: &str = "/tf";
/// Transforms that do not change (transient local).
pub const TF_STATIC_TOPIC: &str = "/tf_static";
