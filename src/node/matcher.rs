//! Matching each leg's measured F/T samples with its joint angle nearest in time, as the node
//! and the offline readers of a session (re-evaluation, diagnosis, fits) all do: a leg's attack
//! angle from each JointState, a short history of them, and F/T samples newer than the newest
//! angle held (bounded) until the angle after them arrives. Drag and lift come out in the hip
//! frame.

use crate::config::{FtFrame, LegConfig, NodeConfig};
use crate::model::wrap_beta_rad;
use crate::msgs::{JointState, WrenchStamped};
use std::collections::VecDeque;

/// The largest force an F/T reading may have (N); beyond it the sample is invalid, counted.
pub const MAX_FORCE_N: f64 = 1e6;

/// Joint angles kept per leg for matching F/T samples by time.
const ANGLE_HISTORY: usize = 1024;
/// F/T samples held per leg until a joint angle at or after their stamp arrives.
const PENDING_WRENCHES: usize = 64;

/// A measured wrench matched with a joint angle: drag and lift in the hip frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Matched {
    /// Stamp of the F/T sample.
    pub t_ns: i64,
    /// Stamp of the joint angle it was matched with.
    pub angle_t_ns: i64,
    /// The leg's attack angle at the matched joint angle (rad).
    pub beta_rad: f64,
    /// The measured drag (N).
    pub drag_n: f64,
    /// The measured lift (N).
    pub lift_n: f64,
}

/// Why a JointState gave a leg no angle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoAngle {
    /// The message does not name the leg's joint.
    MissingJoint,
    /// The joint's position is not finite.
    InvalidPosition,
    /// The stamp is older than the last one used.
    StampBackwards,
}

/// What became of an F/T sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Match {
    Matched(Matched),
    /// No joint angle within the largest matching interval.
    Unmatched,
}

/// One leg's matching state.
#[derive(Debug, Clone)]
struct LegMatcher {
    joint: String,
    direction: f64,
    angle_offset_rad: f64,
    frame: FtFrame,
    /// Where the joint was in the last JointState (it usually stays there).
    joint_index: usize,
    last_stamp_ns: Option<i64>,
    history: VecDeque<(i64, f64)>,
    /// F/T samples newer than the newest joint angle, waiting for it.
    pending: VecDeque<WrenchStamped>,
}

impl LegMatcher {
    fn new(lc: &LegConfig) -> LegMatcher {
        LegMatcher {
            joint: lc.joint.clone(),
            direction: lc.direction,
            angle_offset_rad: lc.angle_offset_rad,
            frame: lc.ft_frame,
            joint_index: 0,
            last_stamp_ns: None,
            history: VecDeque::with_capacity(ANGLE_HISTORY),
            pending: VecDeque::new(),
        }
    }

    /// Matches `msg` with the angle nearest its stamp.
    fn matched(&self, msg: &WrenchStamped, max_dt_ns: i64) -> Match {
        let t_ns = msg.header.stamp.to_nanos();
        let Some((angle_t_ns, beta)) = nearest(&self.history, t_ns, max_dt_ns) else {
            return Match::Unmatched;
        };
        let f = &msg.wrench.force;
        // The force on the leg in the hip frame: drag = -F_x, lift = F_z.
        let (fx, fz) = match self.frame {
            FtFrame::Hip => (f.x, f.z),
            FtFrame::Leg => {
                let (s, c) = beta.sin_cos();
                (f.x * s + f.z * c, -f.x * c + f.z * s)
            }
        };
        Match::Matched(Matched {
            t_ns,
            angle_t_ns,
            beta_rad: beta,
            drag_n: -fx,
            lift_n: fz,
        })
    }
}

/// The F/T matching of every leg of a configuration.
#[derive(Debug, Clone)]
pub struct FtMatcher {
    legs: Vec<LegMatcher>,
    max_dt_ns: i64,
}

impl FtMatcher {
    pub fn new(cfg: &NodeConfig) -> FtMatcher {
        FtMatcher {
            legs: cfg.legs.iter().map(LegMatcher::new).collect(),
            max_dt_ns: (cfg.max_match_dt_s * 1e9) as i64,
        }
    }

    /// Follows a new configuration of the same legs (joint, direction, offset, frame, largest
    /// interval); the angles and waiting samples are kept.
    pub fn set_config(&mut self, cfg: &NodeConfig) {
        self.max_dt_ns = (cfg.max_match_dt_s * 1e9) as i64;
        for (m, lc) in self.legs.iter_mut().zip(&cfg.legs) {
            m.joint.clone_from(&lc.joint);
            m.direction = lc.direction;
            m.angle_offset_rad = lc.angle_offset_rad;
            m.frame = lc.ft_frame;
        }
    }

    /// Takes the angle of `leg` from `msg` (a usable JointState, [`usable_stamp_ns`], whose
    /// stamp is `stamp_ns`) and keeps it; then hands the leg's waiting F/T samples at or before
    /// it to `matched`, in order.
    pub fn on_angle(
        &mut self,
        leg: usize,
        msg: &JointState,
        stamp_ns: i64,
        mut matched: impl FnMut(Match),
    ) -> Result<f64, NoAngle> {
        let max_dt_ns = self.max_dt_ns;
        let Some(m) = self.legs.get_mut(leg) else {
            return Err(NoAngle::MissingJoint);
        };
        let idx = if msg.name.get(m.joint_index) == Some(&m.joint) {
            m.joint_index
        } else {
            msg.name
                .iter()
                .position(|n| *n == m.joint)
                .ok_or(NoAngle::MissingJoint)?
        };
        m.joint_index = idx;
        let position = msg.position.get(idx).copied().unwrap_or(f64::NAN);
        if !position.is_finite() {
            return Err(NoAngle::InvalidPosition);
        }
        if m.last_stamp_ns.is_some_and(|last| stamp_ns < last) {
            return Err(NoAngle::StampBackwards);
        }
        m.last_stamp_ns = Some(stamp_ns);
        let beta = wrap_beta_rad(m.direction * (position - m.angle_offset_rad));
        if m.history.len() == ANGLE_HISTORY {
            m.history.pop_front();
        }
        m.history.push_back((stamp_ns, beta));
        while m
            .pending
            .front()
            .is_some_and(|w| w.header.stamp.to_nanos() <= stamp_ns)
        {
            if let Some(w) = m.pending.pop_front() {
                matched(m.matched(&w, max_dt_ns));
            }
        }
        Ok(beta)
    }

    /// Takes a measured wrench of `leg`; `false` (and nothing taken) if its stamp is invalid or
    /// its force not finite. One newer than the leg's newest angle waits for the angle after it,
    /// so that the nearest angle in time is used; when too many wait (the angles stopped), the
    /// oldest is matched with what there is. What is decided now goes to `matched`.
    pub fn on_wrench(
        &mut self,
        leg: usize,
        msg: &WrenchStamped,
        mut matched: impl FnMut(Match),
    ) -> bool {
        let f = &msg.wrench.force;
        // A reading beyond a meganewton is a broken sensor or message, not a leg in sand: its
        // square would overflow the estimator's sums.
        let plausible = |v: f64| v.is_finite() && v.abs() <= MAX_FORCE_N;
        if !(msg.header.stamp.is_valid() && plausible(f.x) && plausible(f.z)) {
            return false;
        }
        let max_dt_ns = self.max_dt_ns;
        let Some(m) = self.legs.get_mut(leg) else {
            return true;
        };
        let t_ns = msg.header.stamp.to_nanos();
        let newest = m.history.back().map(|h| h.0);
        if newest.is_none_or(|n| n < t_ns) {
            m.pending.push_back(msg.clone());
            if m.pending.len() > PENDING_WRENCHES
                && let Some(old) = m.pending.pop_front()
            {
                matched(m.matched(&old, max_dt_ns));
            }
            return true;
        }
        matched(m.matched(msg, max_dt_ns));
        true
    }
}

/// The stamp (ns) of a JointState the matcher can use: its names and positions pair up and its
/// stamp is valid. `None` for one that is refused.
pub fn usable_stamp_ns(msg: &JointState) -> Option<i64> {
    (msg.name.len() == msg.position.len() && msg.header.stamp.is_valid())
        .then(|| msg.header.stamp.to_nanos())
}

/// The angle whose stamp is nearest `t_ns`, with that stamp, if within `max_dt_ns`. History is
/// in time order.
fn nearest(history: &VecDeque<(i64, f64)>, t_ns: i64, max_dt_ns: i64) -> Option<(i64, f64)> {
    // Where `t_ns` goes in the (sorted) history. A sample is nearly always matched against the
    // last angles, so look there before searching the whole history.
    let n = history.len();
    let i = match (n.checked_sub(2).map(|j| history[j].0), history.back()) {
        (Some(before_last), Some(&(last, _))) if before_last < t_ns => {
            n - usize::from(last >= t_ns)
        }
        _ => history.partition_point(|&(t, _)| t < t_ns),
    };
    let before = i.checked_sub(1).map(|j| history[j]);
    let (t, beta) = match (before, history.get(i)) {
        (Some(b), Some(&a)) if (a.0 - t_ns).abs() < (b.0 - t_ns).abs() => a,
        (Some(b), _) => b,
        (None, Some(&a)) => a,
        (None, None) => return None,
    };
    ((t - t_ns).abs() <= max_dt_ns).then_some((t, beta))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_angle_by_stamp() {
        let h: VecDeque<(i64, f64)> = [(10, 1.0), (20, 2.0), (30, 3.0)].into();
        assert_eq!(nearest(&h, 24, 5), Some((20, 2.0)));
        assert_eq!(nearest(&h, 26, 5), Some((30, 3.0)));
        assert_eq!(nearest(&h, 100, 5), None);
        assert_eq!(nearest(&VecDeque::new(), 1, 5), None);
        // Against every entry of the history: the nearest stamp, the earlier one on a tie.
        for h in [
            vec![10],
            vec![10, 20],
            vec![10, 20, 20, 30],
            vec![10, 20, 30, 40],
        ] {
            let h: VecDeque<(i64, f64)> = h.iter().map(|&t| (t, t as f64)).collect();
            for t in 0..=50 {
                let brute = h
                    .iter()
                    .min_by_key(|&&(s, _)| (s - t).abs())
                    .filter(|&&(s, _)| (s - t).abs() <= 4)
                    .map(|&(_, b)| b);
                assert_eq!(nearest(&h, t, 4).map(|x| x.1), brute, "{h:?} at {t}");
            }
        }
    }
}
