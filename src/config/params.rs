//! Parameter values, as ROS 2 types them, and their text on the command line.

use std::collections::BTreeMap;

/// A parameter value, as ROS 2 types them.
#[derive(Debug, Clone, PartialEq)]
pub enum ParamValue {
    /// `bool`.
    Bool(bool),
    /// `integer` (64-bit).
    Int(i64),
    /// `double`.
    Double(f64),
    /// `string`.
    String(String),
    /// `bool[]`.
    BoolArray(Vec<bool>),
    /// `integer[]`.
    IntArray(Vec<i64>),
    /// `double[]`.
    DoubleArray(Vec<f64>),
    /// `string[]`.
    StringArray(Vec<String>),
}

impl std::fmt::Display for ParamValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParamValue::Bool(v) => write!(f, "{v}"),
            ParamValue::Int(v) => write!(f, "{v}"),
            ParamValue::Double(v) => write!(f, "{v:?}"),
            ParamValue::String(v) => write!(f, "{v:?}"),
            ParamValue::BoolArray(v) => write!(f, "{v:?}"),
            ParamValue::IntArray(v) => write!(f, "{v:?}"),
            ParamValue::DoubleArray(v) => write!(f, "{v:?}"),
            ParamValue::StringArray(v) => write!(f, "{v:?}"),
        }
    }
}

/// Flat parameter names to values.
pub type ParamMap = BTreeMap<String, ParamValue>;

/// A command-line parameter value, typed as ROS does: YAML syntax (`true`, `3`, `0.5`,
/// `[a, b]`), anything else a string.
pub fn parse_value(text: &str) -> ParamValue {
    match serde_yaml_ng::from_str::<serde_yaml_ng::Value>(text) {
        Ok(v) => yaml_to_param(&v).unwrap_or_else(|| ParamValue::String(text.to_string())),
        Err(_) => ParamValue::String(text.to_string()),
    }
}

pub(super) fn yaml_to_param(v: &serde_yaml_ng::Value) -> Option<ParamValue> {
    use serde_yaml_ng::Value as Y;
    Some(match v {
        Y::Bool(b) => ParamValue::Bool(*b),
        Y::Number(n) if n.is_i64() => ParamValue::Int(n.as_i64()?),
        Y::Number(n) => ParamValue::Double(n.as_f64()?),
        Y::String(s) => ParamValue::String(s.clone()),
        Y::Sequence(items) => {
            if items.iter().all(|i| matches!(i, Y::Bool(_))) && !items.is_empty() {
                ParamValue::BoolArray(items.iter().filter_map(Y::as_bool).collect())
            } else if items.iter().all(|i| i.as_i64().is_some()) && !items.is_empty() {
                ParamValue::IntArray(items.iter().filter_map(Y::as_i64).collect())
            } else if items.iter().all(|i| i.as_f64().is_some()) && !items.is_empty() {
                ParamValue::DoubleArray(items.iter().filter_map(Y::as_f64).collect())
            } else if items.iter().all(|i| i.is_string()) {
                ParamValue::StringArray(
                    items
                        .iter()
                        .filter_map(|i| i.as_str().map(String::from))
                        .collect(),
                )
            } else {
                return None;
            }
        }
        _ => return None,
    })
}
