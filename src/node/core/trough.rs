//! Where a leg's own strokes have dug the bed. A flat leg's stroke leaves a trough along the
//! stretch of ground it swept, lower and looser than the settled bed around it; the next stroke
//! that enters it meets the surface lower than configured (`<leg>.trough_depth_m`).
//!
//! The stretch a stroke swept is where the leg crossed the surface while it was in the medium,
//! along the robot's forward axis in the world frame (the robot's state places the hip there).
//! A robot that turns leaves troughs this one-dimensional memory does not place.

use std::collections::VecDeque;

/// Strokes remembered: older troughs are behind a walking robot.
const REMEMBERED: usize = 8;

/// The stretches of ground a leg's finished strokes swept, and the one it is sweeping.
#[derive(Debug, Clone, Default)]
pub struct Troughs {
    past: VecDeque<(f64, f64)>,
    current: Option<(f64, f64)>,
}

impl Troughs {
    /// Where along the forward axis a leg of `length_m` at attack angle `beta_rad` (the body's
    /// pitch included) crosses the surface, its hip `height_m` above it at `hip_position_m`;
    /// `None` while the leg is out of the medium. The leg points along `(-cos b, -sin b)` from
    /// the hip in the leg's frame, whose x is the robot's backward, so it crosses the surface
    /// `height cot b` ahead of the hip.
    pub fn crossing_m(
        hip_position_m: f64,
        height_m: f64,
        beta_rad: f64,
        length_m: f64,
    ) -> Option<f64> {
        let (s, c) = beta_rad.sin_cos();
        (height_m > 0.0 && s > 0.0 && length_m * s > height_m && hip_position_m.is_finite())
            .then(|| hip_position_m + height_m * c / s)
    }

    /// Takes the leg's crossing at one sample (`None`: out of the medium); a stroke ends, and
    /// its stretch is remembered, when the leg leaves the medium.
    pub fn observe(&mut self, crossing_m: Option<f64>) {
        match (crossing_m, self.current) {
            (Some(x), None) => self.current = Some((x, x)),
            (Some(x), Some((lo, hi))) => self.current = Some((lo.min(x), hi.max(x))),
            (None, Some(stretch)) => {
                self.current = None;
                if self.past.len() == REMEMBERED {
                    self.past.pop_front();
                }
                self.past.push_back(stretch);
            }
            (None, None) => {}
        }
    }

    /// Whether `crossing_m` lies in a stretch an earlier stroke swept.
    pub fn dug(&self, crossing_m: Option<f64>) -> bool {
        crossing_m.is_some_and(|x| self.past.iter().any(|&(lo, hi)| lo <= x && x <= hi))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn a_stroke_digs_where_it_crossed_and_the_next_finds_it() {
        let mut t = Troughs::default();
        // A 0.1 m leg, its hip 0.04 m up at x = 0: it crosses from sqrt(0.1^2 - 0.04^2) ahead
        // to as far behind.
        let reach = (0.1f64.powi(2) - 0.04f64.powi(2)).sqrt();
        let mut first = Vec::new();
        for k in 0..=360 {
            let beta = k as f64 * PI / 180.0;
            let x = Troughs::crossing_m(0.0, 0.04, beta, 0.1);
            if let Some(x) = x {
                first.push(x);
            }
            assert!(!t.dug(x), "{k}");
            t.observe(x);
        }
        let (lo, hi) = first
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
        assert!(
            (hi - reach).abs() < 2e-3 && (lo + reach).abs() < 2e-3,
            "{lo} {hi}"
        );
        // The next stroke from 3 cm further on: in the trough until it crosses past its end.
        let at = |beta_deg: f64| Troughs::crossing_m(0.03, 0.04, beta_deg.to_radians(), 0.1);
        assert!(!t.dug(at(30.0)), "{:?}", at(30.0));
        assert!(t.dug(at(60.0)) && t.dug(at(120.0)));
        assert!(!t.dug(None));
        // Out of the medium: no crossing, and a hip below the surface or not finite neither.
        assert_eq!(Troughs::crossing_m(0.0, 0.04, 0.2, 0.1), None);
        assert_eq!(Troughs::crossing_m(0.0, -0.01, 1.0, 0.1), None);
        assert_eq!(Troughs::crossing_m(f64::NAN, 0.04, 1.0, 0.1), None);
    }

    #[test]
    fn the_memory_is_bounded() {
        let mut t = Troughs::default();
        for k in 0..20 {
            let x = k as f64;
            t.observe(Some(x));
            t.observe(None);
        }
        assert_eq!(t.past.len(), REMEMBERED);
        assert!(t.dug(Some(19.0)) && !t.dug(Some(5.0)));
    }
}
