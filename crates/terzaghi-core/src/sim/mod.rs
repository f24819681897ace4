//! Synthetic sessions: a leg in continuous rotation, sampled at a fixed rate, with forces from any
//! model plus Gaussian sensor noise. Used by tests, benchmarks and the demo. The random generator
//! is passed in, so a seed reproduces a session. The six-legged robot, which speaks the node's
//! messages, is `terzaghi::sim::robot`.

pub mod generator;

use crate::ident::Sample;
use rand::Rng;
use rand_distr::{Distribution, Normal};
use std::f64::consts::TAU;

/// How the leg turns: one stroke is one full turn (`2pi`) at a speed drawn per stroke.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rotation {
    /// Samples per second.
    pub sample_rate_hz: f64,
    /// Angular speed range (rad/s); each stroke draws its speed uniformly from it: the lowest.
    pub speed_min_rad_s: f64,
    /// The highest.
    pub speed_max_rad_s: f64,
    /// Attack angle at `t = 0` (rad).
    pub start_beta_rad: f64,
}

impl Default for Rotation {
    fn default() -> Self {
        Rotation {
            sample_rate_hz: 250.0,
            speed_min_rad_s: 0.5,
            speed_max_rad_s: 4.0,
            start_beta_rad: 0.0,
        }
    }
}

/// Times and attack angles (unwrapped) of `strokes` full turns.
pub fn rotate<R: Rng>(rot: &Rotation, strokes: usize, rng: &mut R) -> Vec<(f64, f64)> {
    let dt = 1.0 / rot.sample_rate_hz;
    let mut out = Vec::new();
    let (mut t, mut beta) = (0.0, rot.start_beta_rad);
    for k in 0..strokes {
        let omega = if rot.speed_max_rad_s > rot.speed_min_rad_s {
            rng.random_range(rot.speed_min_rad_s..rot.speed_max_rad_s)
        } else {
            rot.speed_min_rad_s
        };
        let end = rot.start_beta_rad + TAU * (k + 1) as f64;
        while beta < end {
            out.push((t, beta));
            t += dt;
            beta += omega * dt;
        }
    }
    out
}

/// Samples with forces from `force(t, beta) -> (drag, lift)` plus Gaussian noise of
/// `noise_frac` times the peak force magnitude of the session.
pub fn measure<R: Rng>(
    angles: &[(f64, f64)],
    noise_frac: f64,
    rng: &mut R,
    mut force: impl FnMut(f64, f64) -> (f64, f64),
) -> Vec<Sample> {
    let clean: Vec<(f64, f64, f64, f64)> = angles
        .iter()
        .map(|&(t, b)| {
            let (d, l) = force(t, b);
            (t, b, d, l)
        })
        .collect();
    let peak = clean
        .iter()
        .map(|c| c.2.abs().max(c.3.abs()))
        .fold(0.0, f64::max);
    let sigma = (noise_frac * peak).max(0.0);
    let noise = Normal::new(0.0, sigma)
        .unwrap_or_else(|_| Normal::new(0.0, 0.0).expect("zero sigma is valid"));
    clean
        .into_iter()
        .map(|(t, b, d, l)| Sample {
            t_s: Some(t),
            beta_rad: b,
            drag_n: d + noise.sample(rng),
            lift_n: l + noise.sample(rng),
        })
        .collect()
}

/// CSV text `t_s,beta_rad,drag_n,lift_n` of samples.
pub fn to_csv(samples: &[Sample]) -> String {
    let mut s = String::from("t_s,beta_rad,drag_n,lift_n\n");
    for x in samples {
        s += &format!(
            "{},{},{},{}\n",
            x.t_s.unwrap_or(f64::NAN),
            x.beta_rad,
            x.drag_n,
            x.lift_n
        );
    }
    s
}
