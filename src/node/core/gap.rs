//! The node watching its own gap: each leg's matched F/T samples of its last strokes are kept
//! (bounded), and every few strokes handed out as a job for the diagnosis, which the transport
//! runs off the message path ([`NodeCore::take_gap_jobs`]); its report comes back
//! ([`NodeCore::on_gap_report`]) as a `Gap` message and, where it finds an effect the leg's model
//! does not correct, a warning on `/diagnostics`. The node never changes its model by itself.

use super::NodeCore;
use crate::diagnose::{DiagnoseOptions, Report, diagnose};
use crate::ident::Sample;
use crate::model::TerzaghiModel;
use crate::msgs::{Gap, Header, Time};
use std::collections::VecDeque;
use std::f64::consts::{PI, TAU};

/// Most F/T samples a leg keeps for its diagnosis, whatever the rate: the memory bound.
pub const MAX_WINDOW_SAMPLES: usize = 60_000;

/// Most samples handed to one diagnosis.
pub const JOB_SAMPLES: usize = 16_000;

/// Most samples one diagnosis analyses (longer windows are thinned evenly).
pub const GAP_MAX_POINTS: usize = 4_000;

/// One leg's recent strokes, for a diagnosis.
#[derive(Debug, Clone)]
pub struct GapJob {
    pub leg: usize,
    pub samples: Vec<Sample>,
    /// The leg's conventional model (plate and medium; the diagnosis fits the width).
    pub model: TerzaghiModel,
    /// Stamp of the newest sample (ns).
    pub stamp_ns: i64,
    pub strokes: usize,
}

impl GapJob {
    /// Runs the diagnosis of the job: what a worker does, off the message path.
    pub fn run(&self) -> Result<Report, String> {
        let opts = DiagnoseOptions {
            max_points: GAP_MAX_POINTS,
            ..Default::default()
        };
        diagnose(&self.model, &self.samples, &opts)
            .map(|d| d.report)
            .map_err(|e| e.to_string())
    }
}

/// A leg's window of matched samples, by stroke.
#[derive(Debug, Clone, Default)]
pub(super) struct GapWatch {
    window: VecDeque<(usize, Sample)>,
    start_rad: Option<f64>,
    last_rad: Option<f64>,
    stroke: usize,
    next_check: usize,
    /// Jobs the transport could not take (its worker busy).
    pub skipped: u64,
    /// Diagnoses made.
    pub reports: u64,
    /// The latest report's effects the leg's model does not correct, with their share and
    /// basis (empty: nothing to warn of).
    pub warning: Option<String>,
    pub last_verdict: Option<String>,
}

impl GapWatch {
    /// Keeps `s` (a matched sample); `true` when a diagnosis is due (every `every` strokes,
    /// once `window` strokes... at least four are held).
    pub(super) fn push(&mut self, s: Sample, every: usize, window: usize) -> bool {
        if every == 0 {
            return false;
        }
        let b = s.beta_rad.rem_euclid(TAU);
        let u = match self.last_rad {
            Some(p) => {
                let mut d = b - p.rem_euclid(TAU);
                if d < -PI {
                    d += TAU;
                } else if d > PI {
                    d -= TAU;
                }
                p + d
            }
            None => b,
        };
        self.last_rad = Some(u);
        let start = *self.start_rad.get_or_insert(u);
        self.stroke = ((u - start) / TAU).floor().max(0.0) as usize;
        if self.next_check == 0 {
            self.next_check = 4.max(every);
        }
        self.window.push_back((self.stroke, s));
        while self
            .window
            .front()
            .is_some_and(|(k, _)| k + window <= self.stroke)
            || self.window.len() > MAX_WINDOW_SAMPLES
        {
            self.window.pop_front();
        }
        let held = self.stroke - self.window.front().map_or(self.stroke, |w| w.0);
        if self.stroke >= self.next_check && held >= 4 {
            self.next_check = self.stroke + every;
            return true;
        }
        false
    }

    /// The window's samples, evenly thinned to at most [`JOB_SAMPLES`]: the copy is made on the
    /// message path, and the diagnosis thins to [`GAP_MAX_POINTS`] anyway (after taking speed
    /// and acceleration from what it is given).
    pub(super) fn samples(&self) -> Vec<Sample> {
        let stride = self.window.len().div_ceil(JOB_SAMPLES).max(1);
        self.window.iter().step_by(stride).map(|w| w.1).collect()
    }

    pub(super) fn strokes(&self) -> usize {
        self.stroke - self.window.front().map_or(self.stroke, |w| w.0)
    }
}

impl NodeCore {
    /// The diagnoses due since the last call, one per leg at most, for the transport to run off
    /// the message path (see [`GapJob::run`]).
    pub fn take_gap_jobs(&mut self, out: &mut Vec<GapJob>) {
        out.append(&mut self.gap_jobs);
    }

    /// The leg's current warning: the effects its own diagnosis finds that its model does not
    /// correct ("" for none).
    pub fn gap_warning(&self, leg: usize) -> String {
        self.legs
            .get(leg)
            .and_then(|l| l.gap.warning.clone())
            .unwrap_or_default()
    }

    /// A job the transport could not run (its worker busy): counted.
    pub fn gap_job_skipped(&mut self, leg: usize) {
        if let Some(l) = self.legs.get_mut(leg) {
            l.gap.skipped += 1;
        }
    }

    /// The diagnosis of `job` came back: its `Gap` message. An effect it finds significant that
    /// the leg's model does not correct is named in `new_effects` and warned of on
    /// `/diagnostics` until a later diagnosis no longer finds it.
    pub fn on_gap_report(&mut self, job: &GapJob, result: &Result<Report, String>) -> Gap {
        let leg = job.leg;
        let header = Header {
            stamp: Time::from_nanos(job.stamp_ns).unwrap_or_default(),
            frame_id: format!(
                "{}_hip",
                self.cfg.legs.get(leg).map_or("", |l| l.name.as_str())
            ),
        };
        let mut msg = Gap {
            header,
            strokes: job.strokes.min(u32::MAX as usize) as u32,
            samples: job.samples.len() as u64,
            ..Default::default()
        };
        let corrected: Vec<crate::model::Effect> = self
            .cfg
            .legs
            .get(leg)
            .and_then(|l| l.corrections.as_ref())
            .map(|c| c.terms.iter().map(|t| t.effect).collect())
            .unwrap_or_default();
        match result {
            Ok(r) => {
                msg.heldout_rmse_n = r.baseline.rmse_n;
                msg.noise_n = r.gap.noise_var_n2.sqrt();
                msg.gap_real = r.gap.real;
                msg.verdict = r.verdict.effect.clone();
                for st in &r.steps {
                    msg.effects.push(st.effect.name().into());
                    msg.share_of_gap_pct.push(st.share_of_gap_pct);
                    msg.basis.push(
                        serde_json::to_value(st.basis)
                            .ok()
                            .and_then(|v| v.as_str().map(String::from))
                            .unwrap_or_default(),
                    );
                    msg.claim.push(st.claim.clone());
                    if !corrected.contains(&st.effect) {
                        msg.new_effects.push(st.effect.name().into());
                    }
                }
            }
            Err(e) => msg.error = e.clone(),
        }
        if let Some(l) = self.legs.get_mut(leg) {
            l.gap.reports += 1;
            l.gap.last_verdict = Some(if msg.error.is_empty() {
                msg.verdict.clone()
            } else {
                format!("not diagnosed: {}", msg.error)
            });
            l.gap.warning = (!msg.new_effects.is_empty()).then(|| {
                msg.effects
                    .iter()
                    .zip(&msg.share_of_gap_pct)
                    .zip(&msg.basis)
                    .filter(|((e, _), _)| msg.new_effects.contains(e))
                    .map(|((e, p), b)| format!("{e} {p:.0} % of the gap ({b})"))
                    .collect::<Vec<_>>()
                    .join(", ")
            });
        }
        msg
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_window_holds_the_last_strokes_and_is_due_every_few() {
        let mut w = GapWatch::default();
        let mut due = Vec::new();
        for i in 0..20_000 {
            let t = i as f64 * 0.001;
            let s = Sample {
                t_s: Some(t),
                beta_rad: (2.0 * t).rem_euclid(TAU),
                drag_n: 0.0,
                lift_n: 0.0,
            };
            if w.push(s, 3, 5) {
                due.push(w.stroke);
                assert!(w.strokes() >= 4 && w.strokes() <= 5, "{}", w.strokes());
            }
        }
        // 40 rad: six strokes; due at stroke 4, then 7 is not reached.
        assert_eq!(due, vec![4]);
        assert!(w.samples().len() <= MAX_WINDOW_SAMPLES);
        let mut off = GapWatch::default();
        assert!(!(0..20_000).any(|i| off.push(
            Sample {
                t_s: Some(i as f64),
                beta_rad: i as f64,
                drag_n: 0.0,
                lift_n: 0.0
            },
            0,
            5
        )));
    }
}
