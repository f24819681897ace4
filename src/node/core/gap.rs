//! The node watching its own gap: each leg's matched F/T samples of its last strokes are kept
//! (bounded), and every few strokes handed out as a job for the diagnosis, which the transport
//! runs off the message path ([`NodeCore::take_gap_jobs`]); its report comes back
//! ([`NodeCore::on_gap_report`]) as a `Gap` message and, where it finds an effect the leg's model
//! does not correct, a warning on `/diagnostics`. The node never changes its model by itself.

use super::NodeCore;
use crate::diagnose::{DiagnoseOptions, Report, diagnose_placed};
use crate::ident::Sample;
use crate::model::corrections::unwrap_after;
use crate::model::{HipMotion, TerzaghiModel};
use crate::msgs::{Gap, Header, Time};
use std::collections::VecDeque;
use std::f64::consts::TAU;
use std::sync::Arc;

/// Most F/T samples a leg keeps for its diagnosis, whatever the rate: the memory bound.
pub const MAX_WINDOW_SAMPLES: usize = 60_000;

/// Most samples one diagnosis is given, joined from the strokes' blocks on the worker.
pub const JOB_SAMPLES: usize = 16_000;

/// Most samples one diagnosis analyses (longer windows are thinned evenly).
pub const GAP_MAX_POINTS: usize = 4_000;

/// One leg's recent strokes, for a diagnosis.
#[derive(Debug, Clone)]
pub struct GapJob {
    /// The leg, by index in the configuration.
    pub leg: usize,
    /// The strokes' samples, a shared block per stroke: handing them over copies nothing on
    /// the message path; [`GapJob::samples`] joins them, on the worker.
    pub strokes_samples: Vec<Arc<Vec<Watched>>>,
    /// The leg's conventional model (plate and medium; the diagnosis fits the width).
    pub model: TerzaghiModel,
    /// Stamp of the newest sample (ns).
    pub stamp_ns: i64,
    /// Strokes in the job.
    pub strokes: usize,
    /// The smallest gap a verdict may explain (N; `gap_check.min_gap_n`).
    pub min_gap_n: f64,
}

impl GapJob {
    /// Samples in the job.
    pub fn len(&self) -> usize {
        self.strokes_samples.iter().map(|s| s.len()).sum()
    }

    /// Whether the job has no sample.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The samples, evenly thinned to at most `JOB_SAMPLES` (the diagnosis thins to
    /// `GAP_MAX_POINTS` anyway, after taking speed and acceleration from what it is given),
    /// and where the robot's state placed the hip at each (empty for a leg at a fixed height).
    pub fn samples(&self) -> (Vec<Sample>, Vec<Option<HipMotion>>) {
        let stride = self.len().div_ceil(JOB_SAMPLES).max(1);
        let kept = self
            .strokes_samples
            .iter()
            .flat_map(|s| s.iter())
            .step_by(stride);
        let (samples, hips): (Vec<Sample>, Vec<Option<HipMotion>>) =
            kept.map(|w| (w.sample, w.hip())).unzip();
        let placed = hips.iter().any(Option::is_some);
        (samples, if placed { hips } else { Vec::new() })
    }

    /// Runs the diagnosis of the job: what a worker does, off the message path.
    pub fn run(&self) -> Result<Report, String> {
        // The watch reports effects and shares, not a corrected model's values: no refit on
        // denser points.
        let opts = DiagnoseOptions {
            max_points: GAP_MAX_POINTS,
            max_fit_points: GAP_MAX_POINTS,
            forward_share: false,
            min_gap_n: self.min_gap_n,
            ..Default::default()
        };
        let (samples, hips) = self.samples();
        diagnose_placed(&self.model, &samples, &hips, &opts)
            .map(|d| d.report)
            .map_err(|e| e.to_string())
    }
}

/// A matched sample the gap watch keeps, with the hip's height and the body's pitch where the
/// robot's state placed them (for a leg with a `hip_frame`; single precision, since a leg
/// keeps tens of thousands of samples and the diagnosis reads nothing else of the hip).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Watched {
    pub sample: Sample,
    hip: Option<[f32; 2]>,
}

impl Watched {
    pub fn new(sample: Sample, hip: Option<&HipMotion>) -> Watched {
        Watched {
            sample,
            hip: hip.map(|h| [h.height_m as f32, h.pitch_rad as f32]),
        }
    }

    fn hip(&self) -> Option<HipMotion> {
        self.hip.map(|[height, pitch]| HipMotion {
            height_m: f64::from(height),
            pitch_rad: f64::from(pitch),
            ..HipMotion::default()
        })
    }
}

/// A leg's recent strokes: each finished stroke's samples in a block of its own, and the
/// stroke under way.
#[derive(Debug, Clone, Default)]
pub(super) struct GapWatch {
    finished: VecDeque<(usize, Arc<Vec<Watched>>)>,
    current: Vec<Watched>,
    held: usize,
    start_rad: Option<f64>,
    last_rad: Option<f64>,
    stroke: usize,
    next_check: usize,
    /// Diagnoses due that were never run: a newer one of the leg came while they waited for the
    /// worker.
    pub superseded: u64,
    /// Diagnoses made.
    pub reports: u64,
    /// The latest report's effects the leg's model does not correct, with their share and
    /// basis (empty: nothing to warn of).
    pub warning: Option<String>,
    pub last_verdict: Option<String>,
}

impl GapWatch {
    /// Keeps `s` (a matched sample); `true` when a diagnosis is due: every `every` strokes,
    /// once at least four finished strokes are held (of the last `window`).
    pub(super) fn push(&mut self, s: Watched, every: usize, window: usize) -> bool {
        if every == 0 {
            return false;
        }
        let b = s.sample.beta_rad.rem_euclid(TAU);
        let u = self.last_rad.map_or(b, |p| unwrap_after(p, b));
        self.last_rad = Some(u);
        let start = *self.start_rad.get_or_insert(u);
        let stroke = ((u - start) / TAU).floor().max(0.0) as usize;
        if self.next_check == 0 {
            self.next_check = 4.max(every);
        }
        if stroke != self.stroke && !self.current.is_empty() {
            // The stroke is finished: its block is kept as it is, moved, not copied.
            let capacity = self.current.len();
            let block = std::mem::replace(&mut self.current, Vec::with_capacity(capacity));
            self.finished.push_back((self.stroke, Arc::new(block)));
        }
        self.stroke = stroke;
        self.current.push(s);
        self.held += 1;
        while self
            .finished
            .front()
            .is_some_and(|(k, _)| k + window <= stroke)
            || (self.held > MAX_WINDOW_SAMPLES && !self.finished.is_empty())
        {
            if let Some((_, f)) = self.finished.pop_front() {
                self.held -= f.len();
            }
        }
        if self.current.len() > MAX_WINDOW_SAMPLES {
            // A leg that never finishes a stroke: its oldest samples go.
            let n = self.current.len() / 2;
            self.current.drain(..n);
            self.held -= n;
        }
        if stroke >= self.next_check && self.finished.len() >= 4 {
            self.next_check = stroke + every;
            return true;
        }
        false
    }

    /// The finished strokes, shared.
    pub(super) fn blocks(&self) -> Vec<Arc<Vec<Watched>>> {
        self.finished.iter().map(|f| f.1.clone()).collect()
    }

    pub(super) fn strokes(&self) -> usize {
        self.finished.len()
    }
}

impl NodeCore {
    /// The diagnoses due, one per leg at most, for a transport that runs them in line (see
    /// [`GapJob::run`]); the node's transports hand them to a worker instead, as it takes them
    /// ([`NodeCore::next_gap_job`]).
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

    /// Diagnoses of the leg's own strokes made, and those superseded while they waited for the
    /// worker.
    pub fn gap_counts(&self, leg: usize) -> (u64, u64) {
        self.legs
            .get(leg)
            .map_or((0, 0), |l| (l.gap.reports, l.gap.superseded))
    }

    /// The oldest diagnosis waiting, for the transport's worker.
    pub fn next_gap_job(&mut self) -> Option<GapJob> {
        (!self.gap_jobs.is_empty()).then(|| self.gap_jobs.remove(0))
    }

    /// A job the worker could not take yet: it waits again, first in line, unless a newer one
    /// of its leg came meanwhile.
    pub fn return_gap_job(&mut self, job: GapJob) {
        if !self.gap_jobs.iter().any(|j| j.leg == job.leg) {
            self.gap_jobs.insert(0, job);
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
            samples: job.len() as u64,
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
                msg.verdict = r.verdict.effect.to_string();
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
            if w.push(Watched::new(s, None), 3, 5) {
                due.push(w.stroke);
                assert!(w.strokes() >= 4 && w.strokes() <= 5, "{}", w.strokes());
            }
        }
        // 40 rad: six strokes; due at stroke 4, then 7 is not reached.
        assert_eq!(due, vec![4]);
        // The window holds the last five strokes with the one under way: four finished ones, of
        // 2 pi / 2 rad/s at 1 kHz each.
        let held: usize = w.blocks().iter().map(|b| b.len()).sum();
        assert_eq!(w.strokes(), 4);
        assert!((held as f64 - 4.0 * 3141.6).abs() < 10.0, "{held}");
        let mut off = GapWatch::default();
        assert!(!(0..20_000).any(|i| off.push(
            Watched::new(
                Sample {
                    t_s: Some(i as f64),
                    beta_rad: i as f64,
                    drag_n: 0.0,
                    lift_n: 0.0
                },
                None
            ),
            0,
            5
        )));
    }
}
