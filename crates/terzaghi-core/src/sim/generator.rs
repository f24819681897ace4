//! Sessions with a hidden effect, for checking the diagnosis on data whose effect it is not told.
//!
//! This generator shares nothing with `diagnose` but the base physics (the Terzaghi model with
//! the case's own `b_k, a`). Its effects are written in forms of their own, not the candidate
//! terms' formulas: a quadratic drag integrated over the plate's speed profile, an added mass
//! growing with the submerged length squared, a grain pile that builds and flows away, an
//! extraction that fades by a tanh, a saturating compaction, Terzaghi-style cohesion with a
//! bearing factor and adhesion, a shifted surface, a sensor offset that drifts, and a pure
//! transport delay. Two effects lie outside the library on purpose: the leg's structural
//! vibration and buried stones.

use crate::ident::Sample;
use crate::model::{FittingWidth, Medium, Plate, TerzaghiModel};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// A hidden effect (the library's effects, and two outside it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Hidden {
    /// Quadratic drag on the horizontal speed.
    Rate,
    /// An added mass growing with the submerged length squared.
    Inertia,
    /// A pile of grains that builds ahead of the plate and flows away.
    Surcharge,
    /// Extraction's force fading by a tanh.
    Extraction,
    /// A bed that compacts, saturating, over the session.
    Compaction,
    /// Cohesion with a bearing term.
    Cohesion,
    /// The hip higher or lower than configured.
    HipHeight,
    /// An offset of the F/T sensor.
    SensorBias,
    /// A first-order lag of the F/T sensor.
    SensorLag,
    /// Outside the library: the leg ringing at its structural frequency.
    Vibration,
    /// Outside the library: stones buried at random places.
    Stones,
}

/// The hidden effects the diagnosis has a term for.
pub const IN_LIBRARY: [Hidden; 9] = [
    Hidden::Rate,
    Hidden::Inertia,
    Hidden::Surcharge,
    Hidden::Extraction,
    Hidden::Compaction,
    Hidden::Cohesion,
    Hidden::HipHeight,
    Hidden::SensorBias,
    Hidden::SensorLag,
];
/// The hidden effects it has none for.
pub const OUTSIDE: [Hidden; 2] = [Hidden::Vibration, Hidden::Stones];

impl Hidden {
    /// The name the diagnosis should give (the library's names; `vibration` and `stones` are
    /// not among them).
    pub fn name(self) -> &'static str {
        match self {
            Hidden::Rate => "rate",
            Hidden::Inertia => "inertia",
            Hidden::Surcharge => "surcharge",
            Hidden::Extraction => "extraction",
            Hidden::Compaction => "compaction",
            Hidden::Cohesion => "cohesion",
            Hidden::HipHeight => "hip_height",
            Hidden::SensorBias => "sensor_bias",
            Hidden::SensorLag => "sensor_lag",
            Hidden::Vibration => "vibration",
            Hidden::Stones => "stones",
        }
    }

    /// Whether the diagnosis has a term for it.
    pub fn in_library(self) -> bool {
        !OUTSIDE.contains(&self)
    }

    /// The library's effect of the same name; none for the two outside it.
    pub fn effect(self) -> Option<crate::model::corrections::Effect> {
        use crate::model::corrections::Effect;
        Some(match self {
            Hidden::Rate => Effect::Rate,
            Hidden::Inertia => Effect::Inertia,
            Hidden::Surcharge => Effect::Surcharge,
            Hidden::Extraction => Effect::Extraction,
            Hidden::Compaction => Effect::Compaction,
            Hidden::Cohesion => Effect::Cohesion,
            Hidden::HipHeight => Effect::HipHeight,
            Hidden::SensorBias => Effect::SensorBias,
            Hidden::SensorLag => Effect::SensorLag,
            Hidden::Vibration | Hidden::Stones => return None,
        })
    }
}

/// A generated case: what the user would configure (plate and medium), the hidden truth, and
/// the seed that makes the session.
#[derive(Debug, Clone)]
pub struct Case {
    /// The seed of the session's noise and motion.
    pub seed: u64,
    /// The plate and hip height the user would configure.
    pub plate: Plate,
    /// The medium's constants the user would configure.
    pub medium: Medium,
    /// The true fitting width's `b_k`.
    pub b_k: f64,
    /// The true fitting width's `a`.
    pub a: f64,
    /// The hidden effects (none for a clean case).
    pub effects: Vec<Hidden>,
    /// Size of each effect, relative (see [`generate`]).
    pub magnitude: f64,
    /// The sensor noise's standard deviation, as a share of the RMS force in the medium.
    pub noise_frac: f64,
    /// Samples per second.
    pub rate_hz: f64,
    /// Full strokes in the session.
    pub strokes: usize,
    /// The leg's mean angular speed (rad/s); it varies within strokes.
    pub mean_speed_rad_s: f64,
}

/// Draws a case: `effects` are chosen by the caller; geometry, medium, truth, magnitude, noise,
/// speed and length of the session at random.
pub fn draw_case(seed: u64, effects: Vec<Hidden>) -> Case {
    let mut rng = StdRng::seed_from_u64(seed ^ 0x5eed_cafe);
    let l = rng.random_range(0.15..0.30);
    let h = l * rng.random_range(0.35..0.65);
    let plate = Plate::new(l, rng.random_range(0.03..0.09), h).expect("valid plate");
    let medium = Medium::new(
        rng.random_range(14000.0..17500.0),
        rng.random_range(28.0..36.0),
        rng.random_range(16.0..23.0),
    )
    .expect("valid medium");
    Case {
        seed,
        plate,
        medium,
        b_k: rng.random_range(1.0..4.0),
        a: rng.random_range(1.1..3.0),
        effects,
        magnitude: rng.random_range(0.0..1.0),
        noise_frac: rng.random_range(0.008..0.025),
        rate_hz: if rng.random_bool(0.5) { 250.0 } else { 500.0 },
        strokes: rng.random_range(16..28),
        mean_speed_rad_s: rng.random_range(1.5..5.0),
    }
}

/// One sample of a leg's motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionSample {
    /// Time (s).
    pub t_s: f64,
    /// Attack angle, unwrapped (rad).
    pub beta_rad: f64,
    /// Angular speed (rad/s).
    pub omega_rad_s: f64,
    /// Angular acceleration (rad/s^2).
    pub alpha_rad_s2: f64,
    /// The stroke (full turn) the sample belongs to, from 0.
    pub stroke: usize,
    /// The hip's height above the plate's configured one (m), and the body's pitch added to the
    /// attack angle (rad): a body that heaves and pitches (`terzaghi::sim::robot::Body`).
    pub hip_dz_m: f64,
    /// The body's pitch, added to the attack angle (rad).
    pub pitch_rad: f64,
}

/// The leg's motion of `case`: per stroke a speed around the mean, modulated within the stroke
/// (gait phases), sampled at `case.rate_hz`.
pub fn motion(case: &Case) -> Vec<MotionSample> {
    let mut rng = StdRng::seed_from_u64(case.seed);
    let dt = 1.0 / case.rate_hz;
    let (mod_depth, mod_hz, mod_phase) = (
        rng.random_range(0.15..0.4),
        rng.random_range(0.6..1.8),
        rng.random_range(0.0..TAU),
    );
    let mut out = Vec::new();
    let (mut t, mut beta) = (0.0, rng.random_range(3.5..5.5));
    let start = beta;
    for k in 0..case.strokes {
        let w_stroke = case.mean_speed_rad_s * rng.random_range(0.5..1.5);
        while beta < start + TAU * (k + 1) as f64 {
            let phase = TAU * mod_hz * t + mod_phase;
            let omega = w_stroke * (1.0 + mod_depth * phase.sin());
            let alpha = w_stroke * mod_depth * TAU * mod_hz * phase.cos();
            out.push(MotionSample {
                t_s: t,
                beta_rad: beta,
                omega_rad_s: omega,
                alpha_rad_s2: alpha,
                stroke: k,
                hip_dz_m: 0.0,
                pitch_rad: 0.0,
            });
            t += dt;
            beta += omega * dt;
        }
    }
    out
}

/// The session of `case` with all its effects except `omit` (same motion and noise), and the
/// true noise standard deviation (N).
pub fn generate(case: &Case, omit: &[Hidden]) -> (Vec<Sample>, f64) {
    measure(case, &motion(case), omit)
}

/// What the F/T sensor of a leg moving along `motion` reads under `case`'s truth, with all its
/// effects except `omit`; and the noise standard deviation (N). Random draws (stones, sensor
/// offsets, delays, noise) come from the case's seed.
pub fn measure(case: &Case, motion: &[MotionSample], omit: &[Hidden]) -> (Vec<Sample>, f64) {
    let mut rng = StdRng::seed_from_u64(case.seed ^ 0x0ff5e7);
    let on = |e: Hidden| case.effects.contains(&e) && !omit.contains(&e);
    let m = case.magnitude;
    let dt = motion
        .get(1)
        .map_or(1.0 / case.rate_hz, |x| x.t_s - motion[0].t_s)
        .max(1e-6);
    let strokes = motion.last().map_or(1, |x| x.stroke + 1);
    // Stones: per stroke, maybe one at a random angle within the immersion.
    let entry = case.plate.entry_beta_rad().unwrap_or(0.3);
    let stones: Vec<Option<(f64, f64)>> = (0..strokes)
        .map(|_| {
            rng.random_bool(0.5).then(|| {
                (
                    rng.random_range(entry + 0.1..PI - entry - 0.1),
                    rng.random_range(0.6..1.2),
                )
            })
        })
        .collect();
    let (vib_hz, vib_depth) = (rng.random_range(12.0..30.0), rng.random_range(0.25..0.5));
    let bias = [
        sign(&mut rng) * rng.random_range(0.5..1.0),
        sign(&mut rng) * rng.random_range(0.5..1.0),
    ];
    let delay_s = rng.random_range(0.008..0.03);
    let dh = sign(&mut rng) * rng.random_range(0.12..0.25) * case.plate.max_depth_m();
    let noise_draws: Vec<[f64; 2]> = {
        let unit = Normal::new(0.0, 1.0).expect("unit normal");
        motion
            .iter()
            .map(|_| [unit.sample(&mut rng), unit.sample(&mut rng)])
            .collect()
    };

    let width = FittingWidth::new(case.b_k, case.a).expect("valid width");
    let truth = TerzaghiModel::new(case.plate, case.medium, width);
    let surface_plate = if on(Hidden::HipHeight) {
        let p = case.plate;
        Plate::new(p.length_m(), p.width_m(), (p.hip_height_m() + dh).max(0.0))
            .expect("valid plate")
    } else {
        case.plate
    };
    let felt = TerzaghiModel::new(surface_plate, case.medium, width);
    let (l, b) = (case.plate.length_m(), case.plate.width_m());
    let gamma = case.medium.unit_weight_n_m3();
    let phi = case.medium.phi_rad();
    let k_p = (PI / 4.0 + phi / 2.0).tan().powi(2);
    // A scale for the additive effects: the truth's RMS force in the medium.
    let scale = rms_in_medium(&truth, motion);
    let size = 0.12 + 0.18 * m; // 12-30 % of the RMS force

    // The clean, effect-laden force at every motion sample.
    let mut pile_m = 0.0;
    let mut prev_in = false;
    let mut clean: Vec<[f64; 2]> = Vec::with_capacity(motion.len());
    let mut raw_effects: Vec<Vec<[f64; 2]>> = Vec::new();
    for x in motion {
        // The leg's attack angle in the world is the joint's plus the body's pitch.
        let (t, beta, omega, alpha, stroke) = (
            x.t_s,
            x.beta_rad + x.pitch_rad,
            x.omega_rad_s,
            x.alpha_rad_s2,
            x.stroke,
        );
        let f = if x.hip_dz_m != 0.0 {
            felt.with_hip_height_m(felt.plate().hip_height_m() + x.hip_dz_m)
                .and_then(|m| m.evaluate(beta))
        } else {
            felt.evaluate(beta)
        }
        .expect("finite angle and hip");
        let (mut d, mut li) = (f.drag_n, f.lift_n);
        let (s, c) = beta.rem_euclid(TAU).sin_cos();
        let l_s = f.submerged_m.max(0.0);
        let inside = l_s > 0.0;
        let r_in = l - l_s;
        let mut extra: Vec<[f64; 2]> = Vec::new();
        if on(Hidden::Rate) {
            // Quadratic drag on the horizontal component of each element's speed.
            let n = 16;
            let mut fx = 0.0;
            for i in 0..n {
                let r = r_in + (i as f64 + 0.5) * l_s / n as f64;
                let vx = omega * r * s;
                fx += vx * vx.abs() * b * l_s / n as f64;
            }
            extra.push([fx, 0.25 * fx * c]);
        }
        if on(Hidden::Inertia) {
            let mass = b * l_s * l_s; // a half-cylinder of grains, up to constants
            let a_tip = alpha * (l + r_in) / 2.0;
            extra.push([mass * a_tip * s, mass * a_tip * c]);
        }
        if on(Hidden::Surcharge) {
            // The pile grows with the volume swept and flows away with a time constant.
            if inside {
                pile_m += l_s * (l + r_in) / 2.0 * omega.abs() * dt / 0.3 - pile_m * dt / 0.8;
            } else if prev_in {
                pile_m = 0.0;
            }
            let q = gamma * pile_m;
            let fnorm = k_p * q * l_s * b;
            extra.push([fnorm * s, fnorm * c]);
        }
        if on(Hidden::Cohesion) {
            // Every additive effect has an entry at every sample (zero out of the medium).
            let n_c = (k_p - 1.0) / phi.tan();
            let (fnorm, fadh) = (n_c * l_s * b, 0.6 * l_s * b);
            extra.push([fnorm * s - fadh * c, fnorm * c + fadh * s]);
        }
        if on(Hidden::Extraction) && inside && beta.rem_euclid(TAU) > FRAC_PI_2 {
            let x = beta.rem_euclid(TAU) - FRAC_PI_2;
            let fade = (0.5 + 0.4 * m) * (x / 0.35).tanh();
            d *= 1.0 - fade;
            li *= 1.0 - fade;
        }
        if on(Hidden::Compaction) {
            let n0 = strokes as f64 * 0.5;
            let gain = (0.25 + 0.35 * m) * (1.0 - (-(stroke as f64) / n0).exp()) - 0.15;
            d *= 1.0 + gain;
            li *= 1.0 + gain;
        }
        if on(Hidden::Vibration) && inside {
            let v = 1.0 + vib_depth * (TAU * vib_hz * t).sin();
            d *= v;
            li *= v;
        }
        if on(Hidden::Stones)
            && inside
            && let Some((at, height)) = stones[stroke]
        {
            let bump =
                height * (-(beta.rem_euclid(TAU) - at).powi(2) / (2.0 * 0.05f64.powi(2))).exp();
            d += bump * scale;
            li += 0.5 * bump * scale;
        }
        prev_in = inside;
        clean.push([d, li]);
        raw_effects.push(extra);
    }
    // Every additive effect at its share of the RMS force.
    add_effects(&mut clean, &raw_effects, &truth, motion, size * scale);
    let sigma = case.noise_frac * scale * 2.5;
    let times: Vec<f64> = motion.iter().map(|x| x.t_s).collect();
    let samples = motion
        .iter()
        .enumerate()
        .map(|(i, x)| {
            let (t, beta) = (x.t_s, x.beta_rad);
            let mut y = if on(Hidden::SensorLag) {
                interpolate(&times, &clean, t - delay_s)
            } else {
                clean[i]
            };
            if on(Hidden::SensorBias) {
                let drift = 1.0 + 0.3 * t / times.last().copied().unwrap_or(1.0).max(1e-9);
                y[0] += bias[0] * size * scale * drift;
                y[1] += bias[1] * size * scale * drift;
            }
            Sample {
                t_s: Some(t),
                beta_rad: beta.rem_euclid(TAU),
                drag_n: y[0] + sigma * noise_draws[i][0],
                lift_n: y[1] + sigma * noise_draws[i][1],
            }
        })
        .collect();
    (samples, sigma)
}

/// The truth's RMS force over the samples of `motion` in the medium (N).
fn rms_in_medium(truth: &TerzaghiModel, motion: &[MotionSample]) -> f64 {
    let (mut s, mut k) = (0.0, 0usize);
    for x in motion {
        if let Ok(f) = truth.evaluate(x.beta_rad)
            && f.submerged_m > 0.0
        {
            s += f.drag_n * f.drag_n + f.lift_n * f.lift_n;
            k += 2;
        }
    }
    (s / k.max(1) as f64).sqrt()
}

/// Adds to `clean` each additive effect of `raw_effects` (per sample, per effect), scaled so
/// that its RMS over the medium's samples is `share_n`.
fn add_effects(
    clean: &mut [[f64; 2]],
    raw_effects: &[Vec<[f64; 2]>],
    truth: &TerzaghiModel,
    motion: &[MotionSample],
    share_n: f64,
) {
    let count = raw_effects.first().map_or(0, Vec::len);
    // The effects' RMS is over the whole session, in and out of the medium; the force's only in it.
    let in_share = motion
        .iter()
        .filter(|x| {
            truth
                .evaluate(x.beta_rad)
                .is_ok_and(|f| f.submerged_m > 0.0)
        })
        .count() as f64
        / motion.len().max(1) as f64;
    for j in 0..count {
        let rms = (raw_effects
            .iter()
            .map(|e| e[j][0] * e[j][0] + e[j][1] * e[j][1])
            .sum::<f64>()
            / (2 * raw_effects.len().max(1)) as f64)
            .sqrt();
        let k = if rms > 0.0 {
            share_n * in_share.sqrt() / rms
        } else {
            0.0
        };
        for (c, e) in clean.iter_mut().zip(raw_effects) {
            c[0] += k * e[j][0];
            c[1] += k * e[j][1];
        }
    }
}

fn sign(rng: &mut StdRng) -> f64 {
    if rng.random_bool(0.5) { 1.0 } else { -1.0 }
}

/// Linear interpolation of `y` at time `t` (the first value before the start).
fn interpolate(times: &[f64], y: &[[f64; 2]], t: f64) -> [f64; 2] {
    let i = times.partition_point(|&x| x <= t);
    if i == 0 {
        return y[0];
    }
    if i >= times.len() {
        return y[times.len() - 1];
    }
    let w = (t - times[i - 1]) / (times[i] - times[i - 1]);
    [
        y[i - 1][0] + w * (y[i][0] - y[i - 1][0]),
        y[i - 1][1] + w * (y[i][1] - y[i - 1][1]),
    ]
}
