//! Strokes, angular speed and acceleration from a log of attack angles.

use crate::ident::Sample;
use std::f64::consts::{PI, TAU};

/// Per-sample kinematics of a log (same length and order as the samples).
#[derive(Debug, Clone, PartialEq)]
pub struct Kinematics {
    /// The attack angle made continuous across turns (rad).
    pub unwrapped_rad: Vec<f64>,
    /// Index of the stroke (full turn) each sample belongs to, counted from the first sample.
    pub stroke: Vec<usize>,
    /// Angular speed (rad/s), smoothed.
    pub speed_rad_s: Vec<f64>,
    /// Angular acceleration (rad/s^2), smoothed.
    pub accel_rad_s2: Vec<f64>,
}

impl Kinematics {
    /// The number of strokes begun.
    pub fn strokes(&self) -> usize {
        self.stroke.last().map_or(0, |s| s + 1)
    }
}

/// Unwraps the angles, splits them into strokes at each full turn, and differentiates twice
/// with a local least-squares line over `±half_window` samples (a Savitzky–Golay first
/// derivative), which smooths without lagging. Samples need `t_s`, in time order; a sample
/// without a finite time or angle takes its neighbours' values.
pub fn kinematics(samples: &[Sample], half_window: usize) -> Kinematics {
    let mut turns = Turns::default();
    let (unwrapped, stroke): (Vec<f64>, Vec<usize>) =
        samples.iter().map(|s| turns.push(s.beta_rad)).unzip();
    let times: Vec<f64> = samples.iter().map(|s| s.t_s.unwrap_or(f64::NAN)).collect();
    let speed = derivative(&times, &unwrapped, half_window);
    let accel = derivative(&times, &speed, half_window);
    Kinematics {
        unwrapped_rad: unwrapped,
        stroke,
        speed_rad_s: speed,
        accel_rad_s2: accel,
    }
}

/// A leg's angle made continuous across turns and numbered by stroke (full turns from its first
/// angle), one sample at a time: [`kinematics`] over a log, and the re-evaluation of a session
/// row by row, count strokes alike.
#[derive(Debug, Clone, Copy, Default)]
pub struct Turns {
    /// The first angle (continuous), the previous one, and the whole turns added to the wrapped
    /// angle (rad).
    start_rad: Option<f64>,
    prev_rad: f64,
    offset_rad: f64,
}

impl Turns {
    /// The next angle made continuous, and its stroke (from 0). A non-finite angle repeats the
    /// previous one (0 for a first).
    pub fn push(&mut self, beta_rad: f64) -> (f64, usize) {
        let b = if beta_rad.is_finite() {
            beta_rad
        } else {
            self.prev_rad
        }
        .rem_euclid(TAU);
        if self.start_rad.is_some() {
            let d = b + self.offset_rad - self.prev_rad;
            if d < -PI {
                self.offset_rad += TAU;
            } else if d > PI {
                self.offset_rad -= TAU;
            }
        }
        let u = b + self.offset_rad;
        self.prev_rad = u;
        let start = *self.start_rad.get_or_insert(u);
        (u, ((u - start) / TAU).floor().max(0.0) as usize)
    }
}

/// Slope of a least-squares line through the points within `±h` samples of each one.
fn derivative(t: &[f64], y: &[f64], h: usize) -> Vec<f64> {
    let n = t.len();
    (0..n)
        .map(|i| {
            let (lo, hi) = (i.saturating_sub(h), (i + h + 1).min(n));
            let pts = (lo..hi).filter(|&j| t[j].is_finite() && y[j].is_finite());
            let (mut k, mut st, mut sy) = (0.0, 0.0, 0.0);
            for j in pts.clone() {
                k += 1.0;
                st += t[j];
                sy += y[j];
            }
            if k < 2.0 {
                return 0.0;
            }
            let (mt, my) = (st / k, sy / k);
            let (mut num, mut den) = (0.0, 0.0);
            for j in pts {
                num += (t[j] - mt) * (y[j] - my);
                den += (t[j] - mt) * (t[j] - mt);
            }
            if den > 0.0 { num / den } else { 0.0 }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rotation(omega: impl Fn(f64) -> f64, seconds: f64, rate: f64) -> Vec<Sample> {
        let mut beta: f64 = 0.3;
        let dt = 1.0 / rate;
        (0..(seconds * rate) as usize)
            .map(|i| {
                let t = i as f64 * dt;
                let s = Sample {
                    t_s: Some(t),
                    beta_rad: beta.rem_euclid(TAU),
                    drag_n: 0.0,
                    lift_n: 0.0,
                };
                beta += omega(t) * dt;
                s
            })
            .collect()
    }

    #[test]
    fn strokes_and_speed_of_a_steady_rotation() {
        let s = rotation(|_| 2.0, 20.0, 250.0);
        let k = kinematics(&s, 10);
        // 40 rad in 20 s: 6 full turns and part of a seventh.
        assert_eq!(k.strokes(), 7);
        for v in &k.speed_rad_s[20..s.len() - 20] {
            assert!((v - 2.0).abs() < 1e-6, "{v}");
        }
        for a in &k.accel_rad_s2[40..s.len() - 40] {
            assert!(a.abs() < 1e-3, "{a}");
        }
    }

    #[test]
    fn acceleration_of_a_speeding_leg() {
        let s = rotation(|t| 1.0 + 0.5 * t, 4.0, 500.0);
        let k = kinematics(&s, 15);
        for (i, x) in s.iter().enumerate().take(s.len() - 100).skip(100) {
            let t = x.t_s.unwrap();
            assert!(
                (k.speed_rad_s[i] - (1.0 + 0.5 * t)).abs() < 0.01,
                "speed at {t}"
            );
            assert!(
                (k.accel_rad_s2[i] - 0.5).abs() < 0.02,
                "accel at {t}: {}",
                k.accel_rad_s2[i]
            );
        }
    }

    #[test]
    fn non_finite_angles_do_not_break_it() {
        let mut s = rotation(|_| 3.0, 5.0, 100.0);
        s[50].beta_rad = f64::NAN;
        s[60].t_s = None;
        let k = kinematics(&s, 5);
        assert!(k.speed_rad_s.iter().all(|v| v.is_finite()));
        assert_eq!(k.stroke.len(), s.len());
    }
}
