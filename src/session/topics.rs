//! A recording's topics as tables, for analysis outside ROS (the Python package's
//! `read_topics`): one row per message, one column per value, in the recording's order.
//!
//! The types read are the node's and its inputs': `sensor_msgs/JointState` (a column per joint
//! and field, `position.<joint>`, ...), `geometry_msgs/WrenchStamped`,
//! `geometry_msgs/PoseStamped`, `terzaghi_msgs/LegForce` and `terzaghi_msgs/ModelParams`. Every
//! table has `log_time_s` (when the message was logged) and `stamp_s` (its header's stamp),
//! seconds since the Unix epoch. A topic of another type is listed with its count, unread; a
//! message that does not decode is counted and skipped.

use crate::msgs::{JointState, LegForce, ModelParams, PoseStamped, RosMessage, WrenchStamped};
use crate::record::read::{Scan, same_type, scan};
use anyhow::{Context, Result};
use std::collections::HashMap;
use std::path::Path;

/// One topic of a recording as a table.
#[derive(Debug, Clone, PartialEq)]
pub struct TopicTable {
    /// The topic.
    pub topic: String,
    /// Its type, as recorded (`pkg/msg/Type`).
    pub type_name: String,
    /// Whether its type is one the tables read; `false`: only `messages` is counted.
    pub read: bool,
    /// Messages on the topic.
    pub messages: u64,
    /// Messages that did not decode as the type (skipped).
    pub undecodable: u64,
    /// The columns, each with a value per row (NaN where a message lacks it: a joint one
    /// JointState does not name).
    pub columns: Vec<(String, Vec<f64>)>,
    /// Rows (messages decoded).
    pub rows: usize,
}

/// A table filled row by row, a column made when a value first appears (earlier rows NaN).
#[derive(Default)]
struct Builder {
    columns: Vec<(String, Vec<f64>)>,
    index: HashMap<String, usize>,
    rows: usize,
}

impl Builder {
    fn set(&mut self, name: &str, value: f64) {
        let i = match self.index.get(name) {
            Some(&i) => i,
            None => {
                self.columns
                    .push((name.to_string(), vec![f64::NAN; self.rows]));
                self.index.insert(name.to_string(), self.columns.len() - 1);
                self.columns.len() - 1
            }
        };
        let col = &mut self.columns[i].1;
        if col.len() == self.rows {
            col.push(value);
        } else {
            // The same name twice in one message (a JointState naming a joint twice): the last.
            *col.last_mut().expect("a row begun") = value;
        }
    }

    fn end_row(&mut self) {
        self.rows += 1;
        for (_, c) in &mut self.columns {
            c.resize(self.rows, f64::NAN);
        }
    }
}

/// The types read, by the index of [`kind_of`].
#[derive(Clone, Copy)]
enum Kind {
    Joints,
    Wrench,
    Pose,
    Force,
    Params,
}

fn kind_of(type_name: &str) -> Option<Kind> {
    [
        (JointState::type_name(), Kind::Joints),
        (WrenchStamped::type_name(), Kind::Wrench),
        (PoseStamped::type_name(), Kind::Pose),
        (LegForce::type_name(), Kind::Force),
        (ModelParams::type_name(), Kind::Params),
    ]
    .into_iter()
    .find(|(t, _)| same_type(t, type_name))
    .map(|(_, k)| k)
}

fn b(v: bool) -> f64 {
    if v { 1.0 } else { 0.0 }
}

/// One message's values into `t`; `false` if it does not decode.
fn add(t: &mut Builder, kind: Kind, scan: &Scan, topic: usize, data: &[u8], log_ns: u64) -> bool {
    macro_rules! decode {
        ($ty:ty) => {
            match scan.decode_checked::<$ty>(topic, data) {
                Ok(m) => m,
                Err(_) => return false,
            }
        };
    }
    let start = |t: &mut Builder, stamp: crate::msgs::Time| {
        t.set("log_time_s", log_ns as f64 * 1e-9);
        t.set("stamp_s", stamp.to_secs());
    };
    match kind {
        Kind::Joints => {
            let m = decode!(JointState);
            start(t, m.header.stamp);
            for (field, values) in [
                ("position", &m.position),
                ("velocity", &m.velocity),
                ("effort", &m.effort),
            ] {
                for (name, v) in m.name.iter().zip(values) {
                    t.set(&format!("{field}.{name}"), *v);
                }
            }
        }
        Kind::Wrench => {
            let m = decode!(WrenchStamped);
            start(t, m.header.stamp);
            let (f, q) = (m.wrench.force, m.wrench.torque);
            for (n, v) in [
                ("force_x_n", f.x),
                ("force_y_n", f.y),
                ("force_z_n", f.z),
                ("torque_x_nm", q.x),
                ("torque_y_nm", q.y),
                ("torque_z_nm", q.z),
            ] {
                t.set(n, v);
            }
        }
        Kind::Pose => {
            let m = decode!(PoseStamped);
            start(t, m.header.stamp);
            let (p, q) = (m.pose.position, m.pose.orientation);
            for (n, v) in [
                ("x_m", p.x),
                ("y_m", p.y),
                ("z_m", p.z),
                ("qx", q.x),
                ("qy", q.y),
                ("qz", q.z),
                ("qw", q.w),
            ] {
                t.set(n, v);
            }
        }
        Kind::Force => {
            let m = decode!(LegForce);
            start(t, m.header.stamp);
            for (n, v) in [
                ("attack_angle_rad", m.attack_angle_rad),
                ("submerged_length_m", m.submerged_length_m),
                ("depth_m", m.depth_m),
                ("drag_n", m.drag_n),
                ("lift_n", m.lift_n),
                ("hip_torque_nm", m.hip_torque_nm),
                ("regime", f64::from(m.regime)),
                ("b_k", m.b_k),
                ("a", m.a),
                ("delta_deg", m.delta_deg),
                ("identified", b(m.identified)),
                ("bare_drag_n", m.bare_drag_n),
                ("bare_lift_n", m.bare_lift_n),
                ("sensor_drag_n", m.sensor_drag_n),
                ("sensor_lift_n", m.sensor_lift_n),
                ("hip_height_m", m.hip_height_m),
                ("body_pitch_rad", m.body_pitch_rad),
                ("hip_forward_m_s", m.hip_forward_m_s),
                ("hip_up_m_s", m.hip_up_m_s),
                ("robot_state", b(m.robot_state)),
                ("rft_scale", m.rft_scale),
                ("side_n", m.side_n),
                ("roll_moment_nm", m.roll_moment_nm),
                ("yaw_moment_nm", m.yaw_moment_nm),
                ("hip_lateral_m_s", m.hip_lateral_m_s),
            ] {
                t.set(n, v);
            }
        }
        Kind::Params => {
            let m = decode!(ModelParams);
            start(t, m.header.stamp);
            for (n, v) in [
                ("b_k", m.b_k),
                ("a", m.a),
                ("delta_deg", m.delta_deg),
                ("std_b_k", m.std_b_k),
                ("std_a", m.std_a),
                ("std_delta_deg", m.std_delta_deg),
                ("samples_used", m.samples_used as f64),
                ("samples_rejected", m.samples_rejected as f64),
                ("innovation_rms_n", m.innovation_rms_n),
                ("converged", b(m.converged)),
                ("changes_detected", f64::from(m.changes_detected)),
                ("rft_scale", m.rft_scale),
                ("std_rft_scale", m.std_rft_scale),
                ("surface_offset_m", m.surface_offset_m),
                ("std_surface_offset_m", m.std_surface_offset_m),
                ("surface_converged", b(m.surface_converged)),
            ] {
                t.set(n, v);
            }
        }
    }
    t.end_row();
    true
}

/// The topics of the recording at `path` as tables, in the order their channels appear;
/// `only` keeps the topics it names (an unknown one is an error naming the topics there are).
pub fn read_topics(path: &Path, only: Option<&[String]>) -> Result<Vec<TopicTable>> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut tables: Vec<(Builder, Option<Kind>, u64, u64)> = Vec::new();
    let mut wanted: Vec<bool> = Vec::new();
    let found = scan(&bytes, |s, m| {
        while tables.len() < s.topics.len() {
            let t = &s.topics[tables.len()];
            wanted.push(only.is_none_or(|o| o.contains(&t.topic)));
            tables.push((Builder::default(), kind_of(&t.type_name), 0, 0));
        }
        if !wanted[m.topic] {
            return;
        }
        let (b, kind, messages, bad) = &mut tables[m.topic];
        *messages += 1;
        if let Some(k) = *kind
            && !add(b, k, s, m.topic, m.data, m.log_time_ns)
        {
            *bad += 1;
        }
    })
    .with_context(|| format!("{} is not a recording", path.display()))?;
    if let Some(o) = only {
        for w in o {
            if !found.topics.iter().any(|t| t.topic == *w) {
                anyhow::bail!(
                    "{}: no topic {w} (its topics: {})",
                    path.display(),
                    found
                        .topics
                        .iter()
                        .map(|t| t.topic.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                );
            }
        }
    }
    Ok(found
        .topics
        .iter()
        .enumerate()
        .filter(|(_, t)| only.is_none_or(|o| o.contains(&t.topic)))
        .map(|(i, t)| {
            let (b, kind, messages, bad) =
                tables.get_mut(i).map(std::mem::take).unwrap_or_default();
            TopicTable {
                topic: t.topic.clone(),
                type_name: t.type_name.clone(),
                read: kind.is_some(),
                messages,
                undecodable: bad,
                rows: b.rows,
                columns: b.columns,
            }
        })
        .collect())
}
