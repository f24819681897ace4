//! Params files (`/**:` or the node's name, then `ros__parameters:`, nested keys flattened
//! with dots), and the parameters of one node: defaults, then files, then `-p`.

use super::params::yaml_to_param;
use super::{ConfigError, ParamMap, RosArgs, defaults};
use std::path::Path;

/// The parameters a params file gives this node (`/**`, the node's name or its fully
/// qualified name, then `ros__parameters`), flattened with dots.
pub fn parse_params_yaml(
    text: &str,
    path: &str,
    node_name: &str,
    namespace: &str,
) -> Result<ParamMap, ConfigError> {
    let bad = |reason: String| ConfigError::BadFile {
        path: path.to_string(),
        reason,
    };
    let doc: serde_yaml_ng::Value =
        serde_yaml_ng::from_str(text).map_err(|e| bad(format!("not YAML: {e}")))?;
    let top = doc
        .as_mapping()
        .ok_or_else(|| bad("expected a mapping of node names (e.g. /**:) at the top".into()))?;
    let fqn = format!("{}/{}", namespace.trim_end_matches('/'), node_name);
    let mut out = ParamMap::new();
    let mut matched = false;
    for (key, body) in top {
        let key = key.as_str().unwrap_or("");
        let ours = matches!(key, "/**" | "**")
            || key == node_name
            || key == fqn
            || key.strip_prefix("/**/") == Some(node_name)
            || key.trim_start_matches('/') == node_name && namespace == "/";
        if !ours {
            continue;
        }
        matched = true;
        let params = body
            .get("ros__parameters")
            .ok_or_else(|| bad(format!("{key}: expected ros__parameters: under it")))?;
        flatten("", params, &mut out).map_err(bad)?;
    }
    if !matched {
        return Err(bad(format!(
            "no section for this node: expected /**: or {node_name}: (or {fqn}:) at the top"
        )));
    }
    Ok(out)
}

fn flatten(prefix: &str, v: &serde_yaml_ng::Value, out: &mut ParamMap) -> Result<(), String> {
    if let Some(map) = v.as_mapping() {
        for (k, child) in map {
            let k = match k {
                serde_yaml_ng::Value::String(s) => s.clone(),
                other => serde_yaml_ng::to_string(other)
                    .unwrap_or_default()
                    .trim()
                    .to_string(),
            };
            let name = if prefix.is_empty() {
                k
            } else {
                format!("{prefix}.{k}")
            };
            flatten(&name, child, out)?;
        }
        return Ok(());
    }
    let value = yaml_to_param(v)
        .ok_or_else(|| format!("{prefix}: unsupported value (mixed list or null)"))?;
    out.insert(prefix.to_string(), value);
    Ok(())
}

/// Defaults, then each params file in order, then `-p` overrides: the parameters of one node.
pub fn load_params(
    ros: &RosArgs,
    node_name: &str,
    namespace: &str,
) -> Result<ParamMap, ConfigError> {
    let mut params = defaults();
    for path in &ros.params_files {
        params.extend(read_params_file(path, node_name, namespace)?);
    }
    for (name, value) in &ros.params {
        params.insert(name.clone(), value.clone());
    }
    Ok(params)
}

fn read_params_file(
    path: &Path,
    node_name: &str,
    namespace: &str,
) -> Result<ParamMap, ConfigError> {
    let shown = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|error| ConfigError::ReadFile {
        path: shown.clone(),
        error,
    })?;
    parse_params_yaml(&text, &shown, node_name, namespace)
}
