//! The node's status for `/diagnostics`: one entry for the node and one per leg, with counters,
//! rates since the previous report and the estimate, at the levels a ROS user expects (OK,
//! WARN for bad inputs, STALE for a leg without joint angles).

use super::NodeCore;
use crate::msgs::{DiagnosticArray, DiagnosticStatus, Header, KeyValue, Time};

impl NodeCore {
    /// One status per leg plus one for the node, with rates since the previous call.
    /// `dropped` is what the transport dropped from its bounded queues, `latency` the node's
    /// processing-time summary, both reported as they are.
    pub fn diagnostics(
        &mut self,
        now_ns: i64,
        dropped: u64,
        latency: &[(String, String)],
    ) -> DiagnosticArray {
        let dt_s = self
            .last_diag_ns
            .map(|t| ((now_ns - t) as f64 * 1e-9).max(1e-9))
            .unwrap_or(self.cfg.diagnostics_period_s);
        self.last_diag_ns = Some(now_ns);
        let kv = |k: &str, v: String| KeyValue {
            key: k.to_string(),
            value: v,
        };
        let mut status = Vec::new();
        let mut node_values = vec![
            kv("joint_states", self.counters.joint_states.to_string()),
            kv(
                "invalid_joint_states",
                self.counters.invalid_joint_states.to_string(),
            ),
            kv("dropped_queue_full", dropped.to_string()),
            kv("model", self.cfg.model.as_str().to_string()),
        ];
        // Transforms of the robot's state refused (NaN, zero rotation, bad frames): a WARN
        // while they grow.
        let tf_invalid = self.tf_invalid();
        let tf_invalid_new = tf_invalid - self.tf_invalid_at_last_diag.min(tf_invalid);
        self.tf_invalid_at_last_diag = tf_invalid;
        if tf_invalid > 0 || self.cfg.legs.iter().any(|l| l.hip_frame.is_some()) {
            node_values.push(kv("invalid_transforms", tf_invalid.to_string()));
        }
        node_values.extend(latency.iter().map(|(k, v)| kv(k, v.clone())));
        status.push(DiagnosticStatus {
            level: if dropped > 0 || self.counters.invalid_joint_states > 0 || tf_invalid_new > 0 {
                DiagnosticStatus::WARN
            } else {
                DiagnosticStatus::OK
            },
            name: format!("{}: node", self.cfg.node_name),
            message: if dropped > 0 {
                format!("{dropped} inputs dropped (queue full)")
            } else if tf_invalid_new > 0 {
                format!("{tf_invalid_new} invalid transforms of /tf skipped")
            } else {
                "running".into()
            },
            hardware_id: String::new(),
            values: node_values,
        });
        for (i, l) in self.legs.iter_mut().enumerate() {
            let c = l.counters;
            let p = l.at_last_diag;
            l.at_last_diag = c;
            let rate = |now: u64, before: u64| format!("{:.1}", (now - before) as f64 / dt_s);
            let mut values = vec![
                kv("joint_state_rate_hz", rate(c.predictions, p.predictions)),
                kv("predictions", c.predictions.to_string()),
                kv("missing_joint", c.missing_joint.to_string()),
                kv("invalid_position", c.invalid_position.to_string()),
                kv("stamps_backwards", c.stamps_backwards.to_string()),
                kv("ft_rate_hz", rate(c.ft_received, p.ft_received)),
                kv("ft_unmatched", c.ft_unmatched.to_string()),
                kv("ft_invalid", c.ft_invalid.to_string()),
            ];
            if self.cfg.legs[i].hip_frame.is_some() {
                values.extend([
                    kv("state_used", c.state_used.to_string()),
                    kv("state_missing", c.state_missing.to_string()),
                    kv("state_stale", c.state_stale.to_string()),
                ]);
            }
            let mut message = String::from("predicting");
            if let Some(super::Learner::RftScale(s)) = &l.estimator {
                let e = s.estimate();
                let (scale, std) = s.scale();
                values.extend([
                    kv("rft_scale", format!("{scale:.6}")),
                    kv("std_rft_scale", format!("{std:.6}")),
                    kv("samples_used", e.samples_used.to_string()),
                    kv("converged", e.converged.to_string()),
                    kv("changes_detected", e.changes_detected.to_string()),
                ]);
                message = if e.converged {
                    "identified".into()
                } else {
                    "identifying".into()
                };
            } else if let Some(e) = l.estimator.as_ref().map(|e| *e.estimate()) {
                values.extend([
                    kv("b_k", format!("{:.6}", e.b_k)),
                    kv("a", format!("{:.6}", e.a)),
                    kv("delta_deg", format!("{:.4}", e.delta_deg)),
                    kv("std_b_k", format!("{:.6}", e.std_b_k)),
                    kv("std_a", format!("{:.6}", e.std_a)),
                    kv("samples_used", e.samples_used.to_string()),
                    kv("converged", e.converged.to_string()),
                    kv("changes_detected", e.changes_detected.to_string()),
                ]);
                if let Some(super::Learner::Corrected(c)) = &l.estimator {
                    values.extend([
                        kv("change_alarms_dismissed", c.alarms_dismissed().to_string()),
                        kv("change_alarm_under_test", c.alarm_under_test().to_string()),
                    ]);
                }
                message = if e.converged {
                    "identified".into()
                } else {
                    "identifying".into()
                };
            }
            if let Some(s) = l.surface.as_ref().map(|s| *s.estimate()) {
                values.extend([
                    kv("surface_offset_m", format!("{:.5}", s.offset_m)),
                    kv("std_surface_offset_m", format!("{:.5}", s.std_offset_m)),
                    kv("surface_converged", s.converged.to_string()),
                    kv("surface_changes_detected", s.changes_detected.to_string()),
                ]);
            }
            if self.cfg.gap_check.every_strokes > 0 && self.cfg.legs[i].ft_topic.is_some() {
                values.extend([
                    kv("gap_checks", l.gap.reports.to_string()),
                    kv("gap_checks_superseded", l.gap.superseded.to_string()),
                    kv(
                        "gap_verdict",
                        l.gap.last_verdict.clone().unwrap_or_else(|| "-".into()),
                    ),
                ]);
            }
            let bad_now = c.invalid_position > p.invalid_position
                || c.missing_joint > p.missing_joint
                || c.stamps_backwards > p.stamps_backwards
                || c.ft_invalid > p.ft_invalid
                || c.state_missing > p.state_missing
                || c.state_stale > p.state_stale;
            let silent = c.predictions == p.predictions;
            let level = if silent {
                DiagnosticStatus::STALE
            } else if bad_now || l.gap.warning.is_some() {
                DiagnosticStatus::WARN
            } else {
                DiagnosticStatus::OK
            };
            if silent {
                message = "no joint angles".into();
            } else if let Some(w) = &l.gap.warning {
                message = format!(
                    "gap: {w}, which the model does not correct (adopt a correction with <leg>.corrections, see terzaghi diagnose)"
                );
            }
            status.push(DiagnosticStatus {
                level,
                name: format!("{}: leg {}", self.cfg.node_name, self.cfg.legs[i].name),
                message,
                hardware_id: self.cfg.legs[i].joint.clone(),
                values,
            });
        }
        DiagnosticArray {
            header: Header {
                stamp: Time::from_nanos(now_ns).unwrap_or_default(),
                frame_id: String::new(),
            },
            status,
        }
    }
}
