//! Where a leg's own strokes have dug the bed. A flat leg's stroke leaves a trough along the
//! stretch of ground it swept: it digs where it enters and pushes the grains back to where it
//! leaves. A later stroke there meets the surface lower than configured near the earlier
//! stroke's entry (`<leg>.trough_depth_m`) and at `<leg>.trough_exit_depth_m` near its exit
//! (negative: a heap), linearly in between. A stroke reshapes the ground it sweeps, so where
//! several strokes passed, the newest sets the surface.
//!
//! Positions are along the robot's forward axis in the world frame (the robot's state places
//! the hip there). A stroke's stretch is the ground its submerged part covered, from where the
//! leg crosses the surface to its tip; its entry and exit are where that part's middle was when
//! it entered and left the medium. The leg meets the trough's depth averaged over its own
//! submerged part, so that a leg half over undisturbed ground meets half the depth. A robot that
//! turns leaves troughs this one-dimensional memory does not place.

use std::collections::VecDeque;

/// Strokes remembered: older troughs are behind a walking robot.
const REMEMBERED: usize = 8;

/// Where along the forward axis a leg's submerged part lies (m): from its crossing of the
/// surface to its tip.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Span {
    crossing_m: f64,
    tip_m: f64,
}

impl Span {
    /// The submerged part of a leg of `length_m` at attack angle `beta_rad` (the body's pitch
    /// included), its hip `height_m` above the surface at `hip_position_m`; `None` while the
    /// leg is out of the medium. The leg points along `(-cos b, -sin b)` from the hip in the
    /// leg's frame, whose x is the robot's backward: it crosses the surface `height cot b` and
    /// ends `length cos b` ahead of the hip.
    pub fn of_leg(
        hip_position_m: f64,
        height_m: f64,
        beta_rad: f64,
        length_m: f64,
    ) -> Option<Span> {
        let (s, c) = beta_rad.sin_cos();
        (height_m > 0.0 && s > 0.0 && length_m * s > height_m && hip_position_m.is_finite()).then(
            || Span {
                crossing_m: hip_position_m + height_m * c / s,
                tip_m: hip_position_m + length_m * c,
            },
        )
    }

    fn lo_m(&self) -> f64 {
        self.crossing_m.min(self.tip_m)
    }

    fn hi_m(&self) -> f64 {
        self.crossing_m.max(self.tip_m)
    }

    fn middle_m(&self) -> f64 {
        0.5 * (self.crossing_m + self.tip_m)
    }
}

/// The ground one stroke's submerged part covered, and where its middle entered and left.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Stretch {
    entry_m: f64,
    exit_m: f64,
    lo_m: f64,
    hi_m: f64,
}

impl Stretch {
    /// The trough's depth at `x_m` within the stretch (m): `entry_depth_m` at the entry and
    /// `exit_depth_m` at the exit, linearly in between and constant beyond.
    fn depth_at_m(&self, x_m: f64, entry_depth_m: f64, exit_depth_m: f64) -> f64 {
        let span_m = self.exit_m - self.entry_m;
        // A stretch of one point is its entry.
        let u = if span_m.abs() > f64::EPSILON {
            ((x_m - self.entry_m) / span_m).clamp(0.0, 1.0)
        } else {
            0.0
        };
        entry_depth_m + (exit_depth_m - entry_depth_m) * u
    }

    /// The integral over `[lo_m, hi_m]` of the trough's depth (m^2), zero outside the
    /// stretch.
    fn depth_integral_m2(
        &self,
        lo_m: f64,
        hi_m: f64,
        entry_depth_m: f64,
        exit_depth_m: f64,
    ) -> f64 {
        let (a, b) = (lo_m.max(self.lo_m), hi_m.min(self.hi_m));
        if b < a {
            return 0.0;
        }
        let depth_at = |x_m: f64| self.depth_at_m(x_m, entry_depth_m, exit_depth_m);
        // Piecewise linear: exact by the trapezoid over the pieces the clamps make.
        let mut knots = [a, self.entry_m.clamp(a, b), self.exit_m.clamp(a, b), b];
        knots.sort_by(f64::total_cmp);
        knots
            .windows(2)
            .map(|w| 0.5 * (w[1] - w[0]) * (depth_at(w[0]) + depth_at(w[1])))
            .sum()
    }
}

/// The stretches of ground a leg's finished strokes swept, and the one it is sweeping.
#[derive(Debug, Clone, Default)]
pub struct Troughs {
    past: VecDeque<Stretch>,
    current: Option<Stretch>,
}

impl Troughs {
    /// Takes the leg's submerged part at one sample (`None`: out of the medium); a stroke ends,
    /// and its stretch is remembered, when the leg leaves the medium.
    pub fn observe(&mut self, span: Option<Span>) {
        match (span, self.current.as_mut()) {
            (Some(p), None) => {
                self.current = Some(Stretch {
                    entry_m: p.middle_m(),
                    exit_m: p.middle_m(),
                    lo_m: p.lo_m(),
                    hi_m: p.hi_m(),
                })
            }
            (Some(p), Some(s)) => {
                s.exit_m = p.middle_m();
                s.lo_m = s.lo_m.min(p.lo_m());
                s.hi_m = s.hi_m.max(p.hi_m());
            }
            (None, Some(&mut stretch)) => {
                self.current = None;
                if self.past.len() == REMEMBERED {
                    self.past.pop_front();
                }
                self.past.push_back(stretch);
            }
            (None, None) => {}
        }
    }

    /// How much lower than configured the surface is under the submerged part `span` (m;
    /// negative: higher), averaged over it, as the newest earlier stroke that swept any of it
    /// left it; `None` where no earlier stroke dug.
    pub fn depth_m(
        &self,
        span: Option<Span>,
        entry_depth_m: f64,
        exit_depth_m: f64,
    ) -> Option<f64> {
        let p = span?;
        let (lo, hi) = (p.lo_m(), p.hi_m());
        // A stroke reshapes the ground it sweeps: the newest one there sets the surface.
        let s = self
            .past
            .iter()
            .rev()
            .find(|s| s.lo_m <= hi && lo <= s.hi_m)?;
        let width_m = hi - lo;
        Some(if width_m > 1e-9 {
            s.depth_integral_m2(lo, hi, entry_depth_m, exit_depth_m) / width_m
        } else {
            // A leg just entering covers a point: the depth there.
            s.depth_at_m(lo, entry_depth_m, exit_depth_m)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// One stroke of a 0.1 m leg whose hip is 0.04 m up at `hip_m`, degree by degree.
    fn stroke(t: &mut Troughs, hip_m: f64) {
        for k in 0..=360 {
            t.observe(Span::of_leg(hip_m, 0.04, k as f64 * PI / 180.0, 0.1));
        }
    }

    #[test]
    fn a_stroke_digs_where_it_entered_and_heaps_where_it_left() {
        let mut t = Troughs::default();
        // The first stroke meets no trough, not even its own.
        for k in 0..=360 {
            let span = Span::of_leg(0.0, 0.04, k as f64 * PI / 180.0, 0.1);
            assert_eq!(t.depth_m(span, 0.02, -0.016), None, "{k}");
            t.observe(span);
        }
        // The leg enters and leaves sqrt(0.1^2 - 0.04^2) ahead of and behind the hip.
        let reach = (0.1f64.powi(2) - 0.04f64.powi(2)).sqrt();
        let s = t.past[0];
        assert!(
            (s.entry_m - reach).abs() < 2e-3 && (s.exit_m + reach).abs() < 2e-3,
            "{s:?}"
        );
        assert!(
            (s.hi_m - reach).abs() < 2e-3 && (s.lo_m + reach).abs() < 2e-3,
            "{s:?}"
        );
        // The same stroke again: deep where it enters, a heap where it leaves, the depth
        // averaged over the submerged part.
        let at = |deg: f64| t.depth_m(Span::of_leg(0.0, 0.04, deg.to_radians(), 0.1), 0.02, -0.016);
        let (early, middle, late) = (at(30.0).unwrap(), at(90.0).unwrap(), at(150.0).unwrap());
        assert!(early > 0.01 && late < -0.01, "{early} {middle} {late}");
        // Straight down the part spans from the hip's foot to the tip, both at x = 0: the
        // middle of the profile.
        assert!((middle - 0.002).abs() < 1e-3, "{middle}");
        // One depth at both ends: that depth everywhere in the trough.
        let flat = t
            .depth_m(Span::of_leg(0.0, 0.04, 1.0, 0.1), 0.007, 0.007)
            .unwrap();
        assert!((flat - 0.007).abs() < 1e-12, "{flat}");
        // Out of the medium: no span, and a hip below the surface or not finite neither.
        assert_eq!(Span::of_leg(0.0, 0.04, 0.2, 0.1), None);
        assert_eq!(Span::of_leg(0.0, -0.01, 1.0, 0.1), None);
        assert_eq!(Span::of_leg(f64::NAN, 0.04, 1.0, 0.1), None);
        assert_eq!(t.depth_m(None, 0.02, -0.016), None);
    }

    #[test]
    fn a_leg_half_over_settled_ground_meets_half_the_depth() {
        let mut t = Troughs::default();
        stroke(&mut t, 0.0);
        // One depth of 10 mm. From 0.2 m on, the leg's part is beyond the trough.
        let depth = |hip_m: f64, deg: f64| {
            t.depth_m(Span::of_leg(hip_m, 0.04, deg.to_radians(), 0.1), 0.01, 0.01)
        };
        assert_eq!(depth(0.2, 60.0), None);
        // At 60 deg the part spans from 0.04 cot 60 to 0.1 cos 60 ahead of the hip: place it
        // so that the trough's front edge cuts it in half.
        let (c, tip) = (0.04 / 60f64.to_radians().tan(), 0.05);
        let hip_m = t.past[0].hi_m - 0.5 * (c + tip);
        let half = depth(hip_m, 60.0).unwrap();
        assert!((half - 0.005).abs() < 1e-6, "{half}");
    }

    #[test]
    fn the_newest_stroke_over_the_ground_sets_its_surface() {
        let mut t = Troughs::default();
        stroke(&mut t, 0.0);
        stroke(&mut t, 0.0);
        assert_eq!(t.past.len(), 2);
        let p = Span::of_leg(0.0, 0.04, 0.6, 0.1);
        let one = Troughs {
            past: t.past.iter().take(1).copied().collect(),
            current: None,
        };
        assert_eq!(t.depth_m(p, 0.02, -0.016), one.depth_m(p, 0.02, -0.016));
        // A later stroke 0.5 m on does not cover this ground: the one before still does.
        stroke(&mut t, 0.5);
        assert_eq!(t.depth_m(p, 0.02, -0.016), one.depth_m(p, 0.02, -0.016));
    }

    #[test]
    fn the_memory_is_bounded() {
        let mut t = Troughs::default();
        for k in 0..20 {
            stroke(&mut t, k as f64);
        }
        assert_eq!(t.past.len(), REMEMBERED);
        let p = |hip_m: f64| Span::of_leg(hip_m, 0.04, 1.0, 0.1);
        assert!(t.depth_m(p(19.0), 0.01, 0.01).is_some());
        assert!(t.depth_m(p(5.0), 0.01, 0.01).is_none());
    }
}
