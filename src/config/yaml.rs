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

/// `params` as a params file for every node (`/**:` then `ros__parameters:`), dotted names
/// nested again, after the comment lines `header` (each written with `# `). Doubles always
/// carry a decimal point, so that ROS reads them as doubles (`2.0`, `1.0e-5`).
pub fn params_yaml(params: &ParamMap, header: &str) -> String {
    let mut out = String::new();
    for line in header.lines() {
        out += &format!("# {line}\n").replace("# \n", "#\n");
    }
    out += "/**:\n  ros__parameters:\n";
    // Names in order nest as a tree; a level is opened where a name leaves the previous one's.
    let mut open: Vec<&str> = Vec::new();
    for (name, value) in params {
        let parts: Vec<&str> = name.split('.').collect();
        let (path, leaf) = parts.split_at(parts.len() - 1);
        let common = open.iter().zip(path).take_while(|(a, b)| a == b).count();
        open.truncate(common);
        for p in &path[common..] {
            out += &format!("{}{p}:\n", "  ".repeat(2 + open.len()));
            open.push(p);
        }
        out += &format!(
            "{}{}: {}\n",
            "  ".repeat(2 + open.len()),
            leaf[0],
            yaml_value(value)
        );
    }
    out
}

fn yaml_f64(v: f64) -> String {
    let s = format!("{v:?}");
    match s.find('e') {
        Some(i) if !s[..i].contains('.') => format!("{}.0{}", &s[..i], &s[i..]),
        _ => s,
    }
}

fn yaml_value(v: &super::ParamValue) -> String {
    use super::ParamValue as P;
    let quoted = |s: &str| serde_json::to_string(s).unwrap_or_else(|_| "\"\"".into());
    let list = |items: Vec<String>| format!("[{}]", items.join(", "));
    match v {
        P::Bool(b) => b.to_string(),
        P::Int(i) => i.to_string(),
        P::Double(x) => yaml_f64(*x),
        P::String(s) => quoted(s),
        P::BoolArray(v) => list(v.iter().map(|b| b.to_string()).collect()),
        P::IntArray(v) => list(v.iter().map(|i| i.to_string()).collect()),
        P::DoubleArray(v) => list(v.iter().map(|x| yaml_f64(*x)).collect()),
        P::StringArray(v) => list(v.iter().map(|s| quoted(s)).collect()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::ParamValue;

    #[test]
    fn a_written_params_file_reads_back_as_the_same_parameters() {
        let mut p = ParamMap::new();
        p.insert(
            "legs".into(),
            ParamValue::StringArray(vec!["fl".into(), "a \"b\"".into()]),
        );
        p.insert("fl.b_k".into(), ParamValue::Double(2.0));
        p.insert(
            "fl.corrections.effects".into(),
            ParamValue::StringArray(vec!["rate".into()]),
        );
        p.insert(
            "fl.corrections.rate.speed_exponent".into(),
            ParamValue::Double(1e-5),
        );
        p.insert("fl.corrections.rate.x".into(), ParamValue::Double(-2.5e21));
        p.insert("fl.corrections.session_strokes".into(), ParamValue::Int(20));
        p.insert("fl.length_m".into(), ParamValue::Double(0.25));
        p.insert("fr.medium".into(), ParamValue::String("poppy_lp".into()));
        p.insert("use_identified".into(), ParamValue::Bool(false));
        let text = params_yaml(&p, "made by a test\n\nsecond line");
        assert!(
            text.starts_with("# made by a test\n#\n# second line\n/**:\n"),
            "{text}"
        );
        assert!(text.contains("speed_exponent: 1.0e-5\n"), "{text}");
        let back = parse_params_yaml(&text, "t", "terzaghi", "/").unwrap();
        assert_eq!(back, p, "{text}");
    }
}
