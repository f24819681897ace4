//! The library of candidate corrections: physically motivated terms with few parameters, each
//! added to the baseline `b_k a^(-beta) F_unit(beta)`. Most are linear in their parameters (extra
//! columns of a least-squares design); `rate`, `hip_height` and `sensor_lag` have one nonlinear
//! parameter, searched over a grid (for `rate`, the data choose how resistance grows with speed).

use super::context::{Context, Point};
use super::fit::Nonlinear;
use std::fmt;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Effect {
    /// Speed-dependent resistance growing as `(omega r)^n` over the submerged plate (every element
    /// moves at `omega r` across it), normal to the plate and along it, against the session's
    /// typical speed. `n = 2` is inertial drag `~ rho v^2 A`; granular media often show less
    /// (`n` near 1): `n` is fitted between 0.5 and 2. With it, the quasi-static force's scale
    /// and `ln a` (how force grows with the angle) move with `(|omega| / omega_typ)^n - 1`.
    Rate,
    /// A force proportional to the angular acceleration (added mass of grains moved with the plate).
    Inertia,
    /// Grains piling up ahead of the plate: an overburden growing with the area swept in the
    /// current immersion (the paper's "rising part").
    Surcharge,
    /// The extraction phase (beta > 90 deg) failing differently from the passive model: its own
    /// scale for drag and lift, changing with the angle past vertical.
    Extraction,
    /// The medium's strength changing over the session: a steady drift, and a change from one
    /// stroke on (the ground compacted, loosened or disturbed), its stroke chosen by the data:
    /// of drag, of lift, of `ln a` (a denser bed's force also grows differently with the angle)
    /// and of the friction angle `phi` (its grains interlock more, which reshapes the profile).
    Compaction,
    /// A strength term proportional to the submerged area (normal and along the plate).
    Cohesion,
    /// The free surface at another level than the configured hip height.
    HipHeight,
    /// A constant offset on the measured drag and lift.
    SensorBias,
    /// The measured forces delayed and low-passed against the joint angles (first order).
    SensorLag,
}

pub const ALL: [Effect; 9] = [
    Effect::Rate,
    Effect::Inertia,
    Effect::Surcharge,
    Effect::Extraction,
    Effect::Compaction,
    Effect::Cohesion,
    Effect::HipHeight,
    Effect::SensorBias,
    Effect::SensorLag,
];

impl Effect {
    pub fn name(self) -> &'static str {
        match self {
            Effect::Rate => "rate",
            Effect::Inertia => "inertia",
            Effect::Surcharge => "surcharge",
            Effect::Extraction => "extraction",
            Effect::Compaction => "compaction",
            Effect::Cohesion => "cohesion",
            Effect::HipHeight => "hip_height",
            Effect::SensorBias => "sensor_bias",
            Effect::SensorLag => "sensor_lag",
        }
    }

    pub fn from_name(name: &str) -> Option<Effect> {
        ALL.into_iter().find(|e| e.name() == name)
    }

    /// An effect of the F/T sensor rather than of the medium.
    pub fn is_sensor(self) -> bool {
        matches!(self, Effect::SensorBias | Effect::SensorLag)
    }

    /// Names (with units) of the linear parameters, in column order.
    pub fn linear_params(self) -> &'static [&'static str] {
        match self {
            Effect::Rate => &[
                "normal_kg_m3",
                "tangential_kg_m3",
                "ln_a_per_speed_excess",
                "scale_per_speed_excess",
            ],
            Effect::Inertia => &["normal_kg_m2", "tangential_kg_m2"],
            Effect::Surcharge => &["normal_n_m4", "tangential_n_m4"],
            Effect::Extraction => &["drag_scale", "lift_scale", "slope_per_rad"],
            Effect::Compaction => &[
                "linear",
                "change_drag",
                "change_lift",
                "change_ln_a",
                "change_phi_deg",
            ],
            Effect::Cohesion => &["normal_pa", "tangential_pa"],
            Effect::HipHeight | Effect::SensorLag => &[],
            Effect::SensorBias => &["drag_n", "lift_n"],
        }
    }

    /// Name and grid of the nonlinear parameter, if any.
    pub fn nonlinear(self, ctx: &Context) -> Option<(&'static str, Vec<f64>)> {
        match self {
            Effect::Rate => Some(("speed_exponent", RATE_EXPONENTS.to_vec())),
            Effect::Compaction => Some((
                "change_at_session_frac",
                // Where in the session the strength changes: at a stroke, or a tenth of the way
                // (sessions of many strokes).
                if ctx.strokes <= 10 {
                    (1..ctx.strokes)
                        .map(|k| (k as f64 - 0.5) / (ctx.strokes - 1).max(1) as f64)
                        .collect()
                } else {
                    (1..10).map(|k| k as f64 / 10.0).collect()
                },
            )),
            Effect::HipHeight => {
                let depth = ctx.model.plate().max_depth_m();
                let grid = [-0.4, -0.25, -0.15, -0.08, 0.08, 0.15, 0.25, 0.4];
                Some(("surface_drop_m", grid.iter().map(|g| g * depth).collect()))
            }
            Effect::SensorLag => Some((
                "time_constant_s",
                vec![0.002, 0.005, 0.01, 0.02, 0.035, 0.06, 0.1],
            )),
            _ => None,
        }
    }

    /// The parameter count the penalty charges.
    pub fn parameter_count(self) -> usize {
        self.linear_params().len()
            + usize::from(matches!(
                self,
                Effect::Rate | Effect::Compaction | Effect::HipHeight | Effect::SensorLag
            ))
    }

    /// Appends this effect's columns at one point. `base` is the baseline column
    /// `a^(-beta) F_unit(beta)` at that point; `nl` holds the nonlinear values (the speed
    /// exponent of `rate`); `a_factor` is the baseline's `a^(-beta)` there.
    pub fn push_columns(
        self,
        p: &Point,
        base: [f64; 2],
        a_factor: f64,
        nl: &Nonlinear,
        out: &mut Vec<[f64; 2]>,
    ) {
        let (s, c) = p.beta_rad.sin_cos();
        match self {
            Effect::Rate => {
                let q = rate_term(p, nl.speed_exponent);
                out.push(normal(q, s, c));
                out.push(tangential(q, s, c));
                // Faster, the whole quasi-static force grows, and it grows differently with the
                // angle (the DEM's does): its scale and `ln a` moving with the speed's excess over
                // the typical one, `(|omega| / omega_typ)^n - 1`, linearised.
                let n = if nl.speed_exponent > 0.0 {
                    nl.speed_exponent
                } else {
                    2.0
                };
                let excess = if p.typical_speed_rad_s > 1e-6 {
                    (p.speed_rad_s.abs() / p.typical_speed_rad_s).powf(n) - 1.0
                } else {
                    0.0
                };
                let w = -excess * p.beta_rad;
                out.push([w * base[0], w * base[1]]);
                out.push([excess * base[0], excess * base[1]]);
            }
            Effect::Inertia => {
                let q = p.accel_rad_s2 * p.moment1_m3;
                out.push(normal(q, s, c));
                out.push(tangential(q, s, c));
            }
            Effect::Surcharge => {
                let q = p.swept_m2 * p.submerged_m;
                out.push(normal(q, s, c));
                out.push(tangential(q, s, c));
            }
            Effect::Extraction => {
                let e = f64::from(u8::from(p.extraction()));
                let x = Context::past_vertical_rad(p);
                out.push([e * base[0], 0.0]);
                out.push([0.0, e * base[1]]);
                out.push([e * x * base[0], e * x * base[1]]);
            }
            Effect::Compaction => {
                let u = p.session_frac;
                // A stroke exactly at the change counts as half changed.
                let at = nl.change_at_session_frac;
                let changed = if (u - at).abs() < 1e-9 {
                    0.5
                } else {
                    f64::from(u8::from(u > at))
                };
                out.push([u * base[0], u * base[1]]);
                out.push([changed * base[0], 0.0]);
                out.push([0.0, changed * base[1]]);
                // A denser or looser bed changes how force grows with the angle as well as its
                // scale: `a^(-beta)` with `ln a` moved by a small amount, linearised.
                let w = -changed * p.beta_rad;
                out.push([w * base[0], w * base[1]]);
                // And its grains interlock more: a higher friction angle, which reshapes the
                // whole profile (linearised, per degree).
                let g = changed * a_factor;
                out.push([g * p.unit_per_phi_n_deg[0], g * p.unit_per_phi_n_deg[1]]);
            }
            Effect::Cohesion => {
                out.push(normal(p.area_m2, s, c));
                out.push(tangential(p.area_m2, s, c));
            }
            Effect::SensorBias => {
                out.push([1.0, 0.0]);
                out.push([0.0, 1.0]);
            }
            Effect::HipHeight | Effect::SensorLag => {}
        }
    }
}

/// The speed exponents `n` of `rate` the fit chooses from.
pub const RATE_EXPONENTS: [f64; 4] = [0.5, 1.0, 1.5, 2.0];

/// `(|omega|^n - omega_typ^n) int_submerged b r^n dr` (m^(n+2)/s^n): the submerged plate's
/// elements moving at `omega r`, each resisting as its speed to the power `n`, measured against
/// the session's typical speed `omega_typ`. The resistance at the typical speed is part of the
/// medium's strength (the baseline's `b_k` and the other terms): `rate` claims only how force
/// changes with speed, so a session at one speed cannot show it.
fn rate_term(p: &Point, n: f64) -> f64 {
    if p.submerged_m <= 0.0 {
        return 0.0;
    }
    let b = p.area_m2 / p.submerged_m;
    let (r0, r1) = (p.inner_radius_m, p.inner_radius_m + p.submerged_m);
    let n = if n > 0.0 { n } else { 2.0 };
    (p.speed_rad_s.abs().powf(n) - p.typical_speed_rad_s.powf(n))
        * b
        * (r1.powf(n + 1.0) - r0.powf(n + 1.0))
        / (n + 1.0)
}

/// Drag and lift of a force `q` normal to the plate (resisting its travel).
fn normal(q: f64, sin_beta: f64, cos_beta: f64) -> [f64; 2] {
    [q * sin_beta, q * cos_beta]
}

/// Drag and lift of a force `q` along the plate, toward the hip (as the model's `F_pT`).
fn tangential(q: f64, sin_beta: f64, cos_beta: f64) -> [f64; 2] {
    [-q * cos_beta, q * sin_beta]
}

impl fmt::Display for Effect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
