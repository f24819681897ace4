//! The ROS 2 environment variables the node honours.

use super::ConfigError;

/// `ROS_DOMAIN_ID`: 0 when unset; 0–232 (the ports of higher ones collide).
pub fn domain_id_from_env(value: Option<&str>) -> Result<u16, ConfigError> {
    match value.map(str::trim) {
        None | Some("") => Ok(0),
        Some(v) => match v.parse::<u16>() {
            Ok(d) if d <= 232 => Ok(d),
            _ => Err(ConfigError::Env {
                name: "ROS_DOMAIN_ID",
                value: v.to_string(),
                reason: "expected a whole number from 0 to 232",
            }),
        },
    }
}

/// Whether DDS must stay on loopback: `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` (or `OFF`), or
/// the older `ROS_LOCALHOST_ONLY=1`.
pub fn localhost_only_from_env(
    range: Option<&str>,
    localhost_only: Option<&str>,
) -> Result<bool, ConfigError> {
    match range.map(str::trim) {
        Some("LOCALHOST") | Some("OFF") => return Ok(true),
        Some("SUBNET") | Some("SYSTEM_DEFAULT") | Some("") | None => {}
        Some(other) => {
            return Err(ConfigError::Env {
                name: "ROS_AUTOMATIC_DISCOVERY_RANGE",
                value: other.to_string(),
                reason: "expected SUBNET, LOCALHOST, OFF or SYSTEM_DEFAULT",
            });
        }
    }
    Ok(matches!(localhost_only.map(str::trim), Some("1")))
}
