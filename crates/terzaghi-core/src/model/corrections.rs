//! The corrected force model: the improved model's baseline `b_k a^(-beta) F_unit(beta)` plus
//! correction terms for what it leaves out, each with few parameters.
//!
//! One implementation serves both sides: the diagnosis fits the terms' coefficients
//! ([`Effect::push_columns`] gives a term's columns of the least-squares design), and the node
//! evaluates them with those coefficients ([`CorrectedModel::evaluate`], the same columns times
//! the coefficients). Most terms are linear in their parameters; `rate`, `hip_height`,
//! `compaction` and `sensor_lag` have one nonlinear parameter each ([`Nonlinear`]), which the
//! diagnosis searches over a grid.
//!
//! Medium terms change the force the medium exerts; sensor terms (`sensor_bias`, `sensor_lag`)
//! change only what the F/T sensor reads of it, so a corrected prediction has two sides: the
//! medium's force ([`CorrectedPrediction::drag_n`]) and the reading the sensor is expected to give
//! ([`CorrectedPrediction::sensor_drag_n`]).
//!
//! A term is zero wherever it is undefined (out of the medium, at zero speed, before the first
//! stroke), never NaN. Everything here is pure: time comes in as an argument.

use super::{HipMotion, Medium, ModelError, Plate, Prediction, Regime, TerzaghiModel};
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::fmt;

/// The values of `ln a` a fit of the corrected model searches, `(low, high, count)`: from -2.58
/// to 3.4 in steps of 0.46 (`a` from 0.08 to 30). The paper's media have `a` of 0.5 to 20; a DEM
/// bed of coarse grains fits below 0.3 where `delta` is held at the contact friction.
pub const LN_A_GRID: (f64, f64, usize) = (-2.58, 3.4, 14);

/// The values of [`LN_A_GRID`], low to high.
pub fn ln_a_grid() -> impl Iterator<Item = f64> {
    let (lo, hi, steps) = LN_A_GRID;
    (0..steps).map(move |i| lo + (hi - lo) * i as f64 / (steps - 1) as f64)
}

/// An effect the baseline leaves out, and its correction term.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
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

/// Every effect, in the order reports list them.
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

/// The speed exponents `n` of `rate` the fit chooses from.
pub const RATE_EXPONENTS: [f64; 4] = [0.5, 1.0, 1.5, 2.0];

impl Effect {
    /// The effect's name, as parameter files and `report.json` write it.
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

    /// The effect of that name; `None` for a name no effect has.
    pub fn from_name(name: &str) -> Option<Effect> {
        ALL.into_iter().find(|e| e.name() == name)
    }

    /// An effect of the F/T sensor rather than of the medium.
    pub fn is_sensor(self) -> bool {
        matches!(self, Effect::SensorBias | Effect::SensorLag)
    }

    /// The name of this term's parameter `param` (one of [`Effect::linear_params`] or its
    /// [`Effect::nonlinear_param`]), `<effect>.<param>`: the node's parameter under
    /// `<leg>.corrections`, and how `model_params` and the evaluations name a learnt value.
    pub fn value_name(self, param: &str) -> String {
        format!("{self}.{param}")
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

    /// Name (with unit) of the nonlinear parameter, if the effect has one.
    pub fn nonlinear_param(self) -> Option<&'static str> {
        match self {
            Effect::Rate => Some("speed_exponent"),
            Effect::Compaction => Some("change_at_session_frac"),
            Effect::HipHeight => Some("surface_drop_m"),
            Effect::SensorLag => Some("time_constant_s"),
            _ => None,
        }
    }

    /// The parameter count the diagnosis's penalty charges.
    pub fn parameter_count(self) -> usize {
        self.linear_params().len() + usize::from(self.nonlinear_param().is_some())
    }

    /// The largest magnitude a linear parameter may take: far beyond what a medium or a sensor
    /// shows, so that only a value that cannot be physical (or a unit mistaken by orders of
    /// magnitude) is refused.
    pub fn linear_bound(self, param: &str) -> f64 {
        match (self, param) {
            (Effect::Rate, "ln_a_per_speed_excess") | (Effect::Compaction, "change_ln_a") => 10.0,
            (Effect::Rate, "scale_per_speed_excess")
            | (Effect::Compaction, "linear" | "change_drag" | "change_lift")
            | (Effect::Extraction, "drag_scale" | "lift_scale") => 100.0,
            (Effect::Extraction, "slope_per_rad") => 1e3,
            (Effect::Compaction, "change_phi_deg") => 30.0,
            (Effect::SensorBias, _) => 1e4,
            _ => 1e9,
        }
    }

    /// The range the nonlinear parameter must lie in, for a plate of `length_m`.
    pub fn nonlinear_range(self, length_m: f64) -> (f64, f64) {
        match self {
            Effect::Rate => (RATE_EXPONENTS[0], RATE_EXPONENTS[RATE_EXPONENTS.len() - 1]),
            // Past 1 no stroke of the session counts as changed (a fold without a change).
            Effect::Compaction => (0.0, 2.0),
            Effect::HipHeight => (-length_m, length_m),
            Effect::SensorLag => (1e-4, 1.0),
            _ => (0.0, 0.0),
        }
    }

    /// Appends this effect's columns (drag, lift) at one sample. `base` is the baseline column
    /// `a^(-beta) F_unit(beta)` there (at the corrected surface level); `a_factor` is `a^(-beta)`;
    /// `nl` holds the nonlinear values. `hip_height` and `sensor_lag` have no columns of their
    /// own: the one moves the baseline, the other filters every column.
    pub fn push_columns(
        self,
        x: &TermInputs,
        base: [f64; 2],
        a_factor: f64,
        nl: &Nonlinear,
        out: &mut Vec<[f64; 2]>,
    ) {
        let (s, c) = x.beta_rad.sin_cos();
        match self {
            Effect::Rate => {
                let q = rate_term(x, nl.speed_exponent);
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
                let excess = if x.typical_speed_rad_s > 1e-6 {
                    (x.speed_rad_s.abs() / x.typical_speed_rad_s).powf(n) - 1.0
                } else {
                    0.0
                };
                let w = -excess * x.beta_rad;
                out.push([w * base[0], w * base[1]]);
                out.push([excess * base[0], excess * base[1]]);
            }
            Effect::Inertia => {
                let q = x.accel_rad_s2 * x.moment1_m3;
                out.push(normal(q, s, c));
                out.push(tangential(q, s, c));
            }
            Effect::Surcharge => {
                let q = x.swept_m2 * x.submerged_m;
                out.push(normal(q, s, c));
                out.push(tangential(q, s, c));
            }
            Effect::Extraction => {
                let e = f64::from(u8::from(x.regime.is_extraction()));
                let past = if x.regime.is_extraction() {
                    (x.beta_rad - FRAC_PI_2).max(0.0)
                } else {
                    0.0
                };
                out.push([e * base[0], 0.0]);
                out.push([0.0, e * base[1]]);
                out.push([e * past * base[0], e * past * base[1]]);
            }
            Effect::Compaction => {
                let u = x.session_frac;
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
                let w = -changed * x.beta_rad;
                out.push([w * base[0], w * base[1]]);
                // And its grains interlock more: a higher friction angle, which reshapes the
                // whole profile (linearised, per degree).
                let g = changed * a_factor;
                out.push([g * x.unit_per_phi_n_deg[0], g * x.unit_per_phi_n_deg[1]]);
            }
            Effect::Cohesion => {
                out.push(normal(x.area_m2, s, c));
                out.push(tangential(x.area_m2, s, c));
            }
            Effect::SensorBias => {
                out.push([1.0, 0.0]);
                out.push([0.0, 1.0]);
            }
            Effect::HipHeight | Effect::SensorLag => {}
        }
    }
}

impl fmt::Display for Effect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(self.name())
    }
}

/// Values of the nonlinear parameters (0: effect absent).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct Nonlinear {
    /// How much lower the surface is than configured (m; negative: higher).
    pub surface_drop_m: f64,
    /// Time constant of the sensor's first-order lag (s).
    pub lag_s: f64,
    /// How `rate` grows with speed: `omega^n` (0: the effect is absent).
    pub speed_exponent: f64,
    /// Where in the session (0 to 1) `compaction`'s change sets in.
    pub change_at_session_frac: f64,
}

impl Nonlinear {
    /// These values with `effect`'s nonlinear parameter set to `value` (unchanged for an effect
    /// without one).
    pub fn with(mut self, effect: Effect, value: f64) -> Self {
        match effect {
            Effect::HipHeight => self.surface_drop_m = value,
            Effect::SensorLag => self.lag_s = value,
            Effect::Rate => self.speed_exponent = value,
            Effect::Compaction => self.change_at_session_frac = value,
            _ => {}
        }
        self
    }

    /// `effect`'s nonlinear parameter (0 for an effect without one).
    pub fn get(&self, effect: Effect) -> f64 {
        match effect {
            Effect::HipHeight => self.surface_drop_m,
            Effect::SensorLag => self.lag_s,
            Effect::Rate => self.speed_exponent,
            Effect::Compaction => self.change_at_session_frac,
            _ => 0.0,
        }
    }
}

/// Everything a correction term reads at one sample, besides its coefficients: the plate's
/// submerged geometry at the configured surface, the leg's motion, and where the sample lies in
/// the session.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TermInputs {
    /// Attack angle wrapped to `[0, 2pi)`.
    pub beta_rad: f64,
    /// Which phase of the stroke the plate is in.
    pub regime: Regime,
    /// Length of the plate below the surface (m).
    pub submerged_m: f64,
    /// Distance from the hip to where the submerged part begins (m).
    pub inner_radius_m: f64,
    /// Submerged area of the plate's face (m^2).
    pub area_m2: f64,
    /// `int b r dr` over the submerged part (m^3): first moment about the hip.
    pub moment1_m3: f64,
    /// Area swept by the submerged plate since it entered the medium in this immersion (m^2).
    pub swept_m2: f64,
    /// Angular speed along the direction of travel (rad/s).
    pub speed_rad_s: f64,
    /// The typical speed in the medium of the session the terms were fitted on (rad/s): what
    /// `rate` measures speed against.
    pub typical_speed_rad_s: f64,
    /// Angular acceleration along the direction of travel (rad/s^2).
    pub accel_rad_s2: f64,
    /// Stroke position in the session, 0 (first) to 1 (last).
    pub session_frac: f64,
    /// How the unit model's drag and lift change with one degree more of the medium's internal
    /// friction angle (N/deg).
    pub unit_per_phi_n_deg: [f64; 2],
}

/// The submerged part of a plate of `plate`'s length and width whose submerged length is
/// `submerged_m`: `(inner_radius_m, area_m2, moment1_m3, moment2_m4)`, moments about the hip
/// (all but the inner radius zero out of the medium).
pub fn submerged_geometry(plate: &Plate, submerged_m: f64) -> (f64, f64, f64, f64) {
    let (l, b) = (plate.length_m(), plate.width_m());
    let s = submerged_m.max(0.0);
    let r_in = l - s;
    let inside = f64::from(u8::from(s > 0.0));
    (
        r_in,
        s * b,
        inside * b * (l * l - r_in * r_in) / 2.0,
        inside * b * (l.powi(3) - r_in.powi(3)) / 3.0,
    )
}

/// `(|omega|^n - omega_typ^n) int_submerged b r^n dr` (m^(n+2)/s^n): the submerged plate's
/// elements moving at `omega r`, each resisting as its speed to the power `n`, measured against
/// the session's typical speed `omega_typ`. The resistance at the typical speed is part of the
/// medium's strength (the baseline's `b_k` and the other terms): `rate` claims only how force
/// changes with speed, so a session at one speed cannot show it.
fn rate_term(x: &TermInputs, n: f64) -> f64 {
    if x.submerged_m <= 0.0 {
        return 0.0;
    }
    let b = x.area_m2 / x.submerged_m;
    let (r0, r1) = (x.inner_radius_m, x.inner_radius_m + x.submerged_m);
    let n = if n > 0.0 { n } else { 2.0 };
    (x.speed_rad_s.abs().powf(n) - x.typical_speed_rad_s.powf(n))
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

/// One step of a first-order lag with time constant `tau_s`, exact for an input linear between
/// samples: `y1 = x1 - g tau + (y0 - x0 + g tau) e^(-dt/tau)`, `g` the input's slope. A step
/// that does not move forward in time keeps the output `y0`.
pub fn lag_step(x0: f64, x1: f64, y0: f64, dt_s: f64, tau_s: f64) -> f64 {
    if !(dt_s > 0.0 && dt_s.is_finite()) {
        return y0;
    }
    let g = (x1 - x0) / dt_s;
    x1 - g * tau_s + (y0 - x0 + g * tau_s) * (-dt_s / tau_s).exp()
}

/// One correction term and its fitted linear coefficients (in the order of
/// [`Effect::linear_params`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Term {
    /// The effect the term models.
    pub effect: Effect,
    /// Its linear coefficients, with the units [`Effect::linear_params`] names.
    pub coefficients: Vec<f64>,
}

/// A fitted corrected model of one leg: the baseline's `b_k, a` fitted with the terms, the terms
/// and their coefficients, the nonlinear values, and what the terms are measured against.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Corrections {
    /// The fitting width's coefficient `b_k`, fitted with the terms.
    pub b_k: f64,
    /// The fitting width's exponent base `a`, fitted with the terms.
    pub a: f64,
    /// The correction terms, each effect once.
    pub terms: Vec<Term>,
    /// The terms' nonlinear values (speed exponent, surface level, lag, the change's stroke).
    pub nonlinear: Nonlinear,
    /// The typical speed in the medium of the fitted session (rad/s), for `rate`.
    pub typical_speed_rad_s: f64,
    /// Full strokes of the fitted session, for `compaction` (its stroke position).
    pub session_strokes: usize,
}

/// What is wrong with a set of corrections; names the parameter and its value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CorrectionsError {
    /// A coefficient outside its physical bounds.
    #[error("{effect}.{param} = {value} is outside its physical bounds [{lo}, {hi}]")]
    OutOfBounds {
        /// The term's effect.
        effect: Effect,
        /// The coefficient's name, with its unit.
        param: String,
        /// The value given.
        value: f64,
        /// The lower bound.
        lo: f64,
        /// The upper bound.
        hi: f64,
    },
    /// A term with the wrong number of coefficients.
    #[error("{effect} has {found} coefficients, it needs {needed} ({names})")]
    Coefficients {
        /// The term's effect.
        effect: Effect,
        /// The coefficients given.
        found: usize,
        /// The coefficients the term has.
        needed: usize,
        /// Their names, in order.
        names: String,
    },
    /// An effect with two terms.
    #[error("{effect} appears twice")]
    Twice {
        /// The effect.
        effect: Effect,
    },
    /// A value outside what it can be (`b_k`, `a`, a nonlinear value).
    #[error("{name} = {value} must be {expected}")]
    Invalid {
        /// The value's name.
        name: &'static str,
        /// The value given.
        value: f64,
        /// What it must be.
        expected: &'static str,
    },
}

impl Corrections {
    /// No correction: the improved model with `b_k, a`.
    pub fn none(b_k: f64, a: f64) -> Corrections {
        Corrections {
            b_k,
            a,
            terms: Vec::new(),
            nonlinear: Nonlinear::default(),
            typical_speed_rad_s: 0.0,
            session_strokes: 0,
        }
    }

    /// Every term's linear coefficients by name (`<effect>.<param>`, [`Effect::value_name`]),
    /// in the order of the terms and of their columns: the order the online estimator learns
    /// them in.
    pub fn linear_values(&self) -> Vec<(String, f64)> {
        self.terms
            .iter()
            .flat_map(|t| {
                let e = t.effect;
                e.linear_params()
                    .iter()
                    .zip(&t.coefficients)
                    .map(move |(p, v)| (e.value_name(p), *v))
            })
            .collect()
    }

    /// The same terms and nonlinear values with nothing learnt: `b_k = a = 1` (the conventional
    /// model) and every coefficient 0, where an online identification from scratch starts.
    pub fn unlearnt(&self) -> Corrections {
        let mut c = self.clone();
        c.b_k = 1.0;
        c.a = 1.0;
        for t in &mut c.terms {
            t.coefficients.iter_mut().for_each(|v| *v = 0.0);
        }
        c
    }

    /// Whether a term models `e`.
    pub fn has(&self, e: Effect) -> bool {
        self.terms.iter().any(|t| t.effect == e)
    }

    /// Checks every value against its bounds for a plate of `length_m`.
    pub fn validate(&self, length_m: f64) -> Result<(), CorrectionsError> {
        let positive = |name, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(CorrectionsError::Invalid {
                    name,
                    value,
                    expected: "a finite number > 0",
                })
            }
        };
        positive("b_k", self.b_k)?;
        positive("a", self.a)?;
        for (i, t) in self.terms.iter().enumerate() {
            if self.terms[..i].iter().any(|o| o.effect == t.effect) {
                return Err(CorrectionsError::Twice { effect: t.effect });
            }
            let names = t.effect.linear_params();
            if t.coefficients.len() != names.len() {
                return Err(CorrectionsError::Coefficients {
                    effect: t.effect,
                    found: t.coefficients.len(),
                    needed: names.len(),
                    names: names.join(", "),
                });
            }
            for (name, &v) in names.iter().zip(&t.coefficients) {
                let bound = t.effect.linear_bound(name);
                if !(v.is_finite() && v.abs() <= bound) {
                    return Err(CorrectionsError::OutOfBounds {
                        effect: t.effect,
                        param: name.to_string(),
                        value: v,
                        lo: -bound,
                        hi: bound,
                    });
                }
            }
            if let Some(name) = t.effect.nonlinear_param() {
                let v = self.nonlinear.get(t.effect);
                let (lo, hi) = t.effect.nonlinear_range(length_m);
                if !(v.is_finite() && v >= lo && v <= hi) {
                    return Err(CorrectionsError::OutOfBounds {
                        effect: t.effect,
                        param: name.to_string(),
                        value: v,
                        lo,
                        hi,
                    });
                }
            }
        }
        if self.has(Effect::Rate) {
            positive("typical_speed_rad_s", self.typical_speed_rad_s)?;
        }
        if self.has(Effect::Compaction) && self.session_strokes < 2 {
            return Err(CorrectionsError::Invalid {
                name: "session_strokes",
                value: self.session_strokes as f64,
                expected: "at least 2 (compaction is measured over the strokes of a session)",
            });
        }
        Ok(())
    }
}

/// The leg's motion at one sample, as [`MotionTracker`] follows it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Motion {
    /// Angular speed along the travel (rad/s).
    pub speed_rad_s: f64,
    /// Angular acceleration along the travel (rad/s^2).
    pub accel_rad_s2: f64,
    /// Area swept by the submerged plate since it entered the medium in this immersion (m^2).
    pub swept_m2: f64,
    /// Full strokes (turns) since the first sample.
    pub stroke: usize,
}

/// Window of the slopes that give a corrected leg's speed and acceleration (s): the node's and
/// the online identification's.
pub const MOTION_WINDOW_S: f64 = 0.03;

/// Each part of a corrected prediction.
#[derive(Debug, Clone, PartialEq)]
pub struct CorrectedPrediction {
    /// The improved model with the corrections' `b_k, a` at the configured surface: what the
    /// corrections are added to.
    pub bare: Prediction,
    /// Each medium term's part (drag, lift), N; `hip_height`'s is the baseline at the corrected
    /// surface less the bare force.
    pub parts: Vec<(Effect, [f64; 2])>,
    /// The medium's force with every medium correction (N).
    pub drag_n: f64,
    /// The medium's lift with every medium correction (N).
    pub lift_n: f64,
    /// Hip torque of the baseline at the corrected surface (N m): the terms are fitted on drag
    /// and lift, not on torque.
    pub hip_torque_nm: f64,
    /// Submerged length at the corrected surface (m).
    pub submerged_m: f64,
    /// The tip's depth below the corrected surface (m).
    pub depth_m: f64,
    /// The regime at the corrected surface.
    pub regime: Regime,
    /// What the F/T sensor is expected to read (N): the medium's force through its lag, plus its
    /// offset. Equal to the medium's without sensor terms.
    pub sensor_drag_n: f64,
    /// The lift the F/T sensor is expected to read (N).
    pub sensor_lift_n: f64,
}

/// The unit models of a [`CorrectedModel`] at a hip the robot's state placed.
struct PlacedUnits {
    unit: TerzaghiModel,
    moved: Option<TerzaghiModel>,
    stronger: Option<TerzaghiModel>,
}

/// The corrected model of one leg, ready to evaluate sample by sample.
#[derive(Debug, Clone)]
pub struct CorrectedModel {
    corrections: Corrections,
    /// The unit model (`b_k = a = 1`) at the configured surface.
    unit: TerzaghiModel,
    /// The unit model at the corrected surface (`hip_height`).
    moved: Option<TerzaghiModel>,
    /// The unit model one degree stronger in friction (`compaction`'s `phi` column).
    stronger: Option<TerzaghiModel>,
}

impl CorrectedModel {
    /// The corrected model of a plate in a medium. The corrections are validated.
    pub fn new(
        plate: Plate,
        medium: Medium,
        corrections: Corrections,
    ) -> Result<CorrectedModel, CorrectionsError> {
        corrections.validate(plate.length_m())?;
        let unit = TerzaghiModel::conventional(plate, medium);
        let moved = corrections
            .has(Effect::HipHeight)
            .then(|| moved_unit_model(&unit, corrections.nonlinear.surface_drop_m));
        let stronger = corrections
            .has(Effect::Compaction)
            .then(|| stronger_unit_model(&unit))
            .flatten();
        Ok(CorrectedModel {
            corrections,
            unit,
            moved,
            stronger,
        })
    }

    /// The corrections it predicts with.
    pub fn corrections(&self) -> &Corrections {
        &self.corrections
    }

    /// The unit, moved and stronger models: the placed ones, else the configured ones.
    fn units<'a>(
        &'a self,
        placed: Option<&'a PlacedUnits>,
    ) -> (
        &'a TerzaghiModel,
        Option<&'a TerzaghiModel>,
        Option<&'a TerzaghiModel>,
    ) {
        match placed {
            Some(p) => (&p.unit, p.moved.as_ref(), p.stronger.as_ref()),
            None => (&self.unit, self.moved.as_ref(), self.stronger.as_ref()),
        }
    }

    /// The plate and hip height it is for.
    pub fn plate(&self) -> &Plate {
        self.unit.plate()
    }

    /// The medium's constants.
    pub fn medium(&self) -> &Medium {
        self.unit.medium()
    }

    /// The unit models at a hip the robot's state placed `hip.height_m` above the surface
    /// (`None` without a hip: the configured ones), and the attack angle of `beta_rad` there.
    fn units_at(
        &self,
        beta_rad: f64,
        hip: Option<&HipMotion>,
    ) -> Result<(Option<PlacedUnits>, f64), ModelError> {
        let Some(h) = hip else {
            return Ok((None, beta_rad));
        };
        let unit = self.unit.with_hip_height_m(h.height_m)?;
        let moved = self
            .moved
            .as_ref()
            .map(|_| moved_unit_model(&unit, self.corrections.nonlinear.surface_drop_m));
        let stronger = match &self.stronger {
            Some(m) => Some(m.with_hip_height_m(h.height_m)?),
            None => None,
        };
        Ok((
            Some(PlacedUnits {
                unit,
                moved,
                stronger,
            }),
            super::finite("attack angle beta (rad)", beta_rad)? + h.pitch_rad,
        ))
    }

    /// The inputs of the terms at `beta_rad` with the leg moving as `motion`, and the unit
    /// model's force there (`None` where it cannot evaluate).
    pub fn inputs(
        &self,
        beta_rad: f64,
        motion: &Motion,
    ) -> Result<(TermInputs, super::TerzaghiForce), ModelError> {
        self.inputs_with(&self.unit, self.stronger.as_ref(), beta_rad, motion)
    }

    fn inputs_with(
        &self,
        unit: &TerzaghiModel,
        stronger: Option<&TerzaghiModel>,
        beta_rad: f64,
        motion: &Motion,
    ) -> Result<(TermInputs, super::TerzaghiForce), ModelError> {
        let f = unit.evaluate(beta_rad)?;
        let c = &self.corrections;
        let (r_in, area, m1, _) = submerged_geometry(unit.plate(), f.submerged_m);
        let per_phi = match stronger {
            Some(m) if f.regime != Regime::OutOfMedium => m
                .evaluate(f.beta_rad)
                .map_or([0.0, 0.0], |g| [g.drag_n - f.drag_n, g.lift_n - f.lift_n]),
            _ => [0.0, 0.0],
        };
        let session_frac = if c.session_strokes > 1 {
            (motion.stroke as f64 / (c.session_strokes - 1) as f64).min(1.0)
        } else {
            0.0
        };
        let x = TermInputs {
            beta_rad: f.beta_rad,
            regime: f.regime,
            submerged_m: f.submerged_m.max(0.0),
            inner_radius_m: r_in,
            area_m2: area,
            moment1_m3: m1,
            swept_m2: motion.swept_m2,
            speed_rad_s: motion.speed_rad_s,
            typical_speed_rad_s: c.typical_speed_rad_s,
            accel_rad_s2: motion.accel_rad_s2,
            session_frac,
            unit_per_phi_n_deg: per_phi,
        };
        Ok((x, f))
    }

    /// The design row at `beta_rad` with the leg moving as `motion` and the baseline's `a`, as
    /// the diagnosis fits it: the prediction is `b_k row[0] + sum_j c_j row[1 + j]`, the `c_j`
    /// the terms' coefficients in order. `row[0]` is `a^(-beta) F_unit(beta)` at the corrected
    /// surface. Into `fixed` goes the part of each column that does not scale with
    /// `a^(-beta)`: a column's derivative in `ln a` is `-beta (row - fixed)`. Returns the wrapped
    /// angle and the regime at the configured surface.
    pub fn design_row(
        &self,
        beta_rad: f64,
        motion: &Motion,
        a: f64,
        row: &mut Vec<[f64; 2]>,
        fixed: &mut Vec<[f64; 2]>,
    ) -> Result<(f64, Regime), ModelError> {
        self.design_row_at(beta_rad, motion, None, a, row, fixed)
    }

    /// [`Self::design_row`] with the hip where the robot's state placed it (`None`: the
    /// configured plate): the terms at its height and at the joint's angle plus the body's
    /// pitch, as the diagnosis fits a recording whose hips it placed.
    pub fn design_row_at(
        &self,
        beta_rad: f64,
        motion: &Motion,
        hip: Option<&HipMotion>,
        a: f64,
        row: &mut Vec<[f64; 2]>,
        fixed: &mut Vec<[f64; 2]>,
    ) -> Result<(f64, Regime), ModelError> {
        let (placed, beta_rad) = self.units_at(beta_rad, hip)?;
        let (unit, moved, stronger) = self.units(placed.as_ref());
        let (x, f) = self.inputs_with(unit, stronger, beta_rad, motion)?;
        let w = (-a.ln() * x.beta_rad).exp();
        let g = match moved {
            Some(m) => m.evaluate(x.beta_rad)?,
            None => f,
        };
        let base = [w * g.drag_n, w * g.lift_n];
        row.clear();
        fixed.clear();
        row.push(base);
        fixed.push([0.0, 0.0]);
        let nl = &self.corrections.nonlinear;
        for t in &self.corrections.terms {
            t.effect.push_columns(&x, base, w, nl, row);
            t.effect.push_columns(&x, [0.0, 0.0], 0.0, nl, fixed);
        }
        Ok((x.beta_rad, f.regime))
    }

    /// The same model with other linear values: the baseline's `b_k, a` and the terms'
    /// coefficients in order (as many as the terms have), each kept inside its bound.
    pub fn set_linear(&mut self, b_k: f64, a: f64, coefficients: impl IntoIterator<Item = f64>) {
        let c = &mut self.corrections;
        c.b_k = b_k;
        c.a = a;
        let mut k = coefficients.into_iter();
        for t in &mut c.terms {
            for (v, name) in t.coefficients.iter_mut().zip(t.effect.linear_params()) {
                if let Some(x) = k.next()
                    && x.is_finite()
                {
                    let bound = t.effect.linear_bound(name);
                    *v = x.clamp(-bound, bound);
                }
            }
        }
    }

    /// The corrected prediction at `beta_rad` with the leg moving as `motion`. The sensor's lag,
    /// which needs the samples before, is applied by a [`SensorLagFilter`]: here the sensor side
    /// holds the medium's force plus the offset.
    pub fn evaluate(
        &self,
        beta_rad: f64,
        motion: &Motion,
    ) -> Result<CorrectedPrediction, ModelError> {
        self.evaluate_at(beta_rad, motion, None)
    }

    /// [`Self::evaluate`] with the hip where the robot's state placed it (`None`: the
    /// configured plate): the baseline and every term at the hip's height, at the joint's angle
    /// plus the body's pitch.
    pub fn evaluate_at(
        &self,
        beta_rad: f64,
        motion: &Motion,
        hip: Option<&HipMotion>,
    ) -> Result<CorrectedPrediction, ModelError> {
        let (placed, beta_rad) = self.units_at(beta_rad, hip)?;
        let (unit, moved, stronger) = self.units(placed.as_ref());
        let (x, f) = self.inputs_with(unit, stronger, beta_rad, motion)?;
        let c = &self.corrections;
        let w = (-c.a.ln() * x.beta_rad).exp();
        let g = match moved {
            Some(m) => m.evaluate(x.beta_rad)?,
            None => f,
        };
        let base = [w * g.drag_n, w * g.lift_n];
        let bare = [c.b_k * w * f.drag_n, c.b_k * w * f.lift_n];
        let mut parts = Vec::with_capacity(c.terms.len() + 1);
        if moved.is_some() {
            parts.push((
                Effect::HipHeight,
                [c.b_k * base[0] - bare[0], c.b_k * base[1] - bare[1]],
            ));
        }
        let mut cols: Vec<[f64; 2]> = Vec::with_capacity(5);
        let mut bias = [0.0; 2];
        for t in &c.terms {
            cols.clear();
            t.effect.push_columns(&x, base, w, &c.nonlinear, &mut cols);
            if cols.is_empty() {
                continue;
            }
            let mut part = [0.0; 2];
            for (col, k) in cols.iter().zip(&t.coefficients) {
                part[0] += k * col[0];
                part[1] += k * col[1];
            }
            if t.effect.is_sensor() {
                bias[0] += part[0];
                bias[1] += part[1];
            } else {
                parts.push((t.effect, part));
            }
        }
        let (mut drag, mut lift) = (bare[0], bare[1]);
        for (_, p) in &parts {
            drag += p[0];
            lift += p[1];
        }
        let zero = |v: f64| if v.is_finite() { v } else { 0.0 };
        let (drag, lift) = (zero(drag), zero(lift));
        Ok(CorrectedPrediction {
            bare: Prediction {
                beta_rad: f.beta_rad,
                submerged_m: f.submerged_m,
                depth_m: f.depth_m,
                drag_n: bare[0],
                lift_n: bare[1],
                hip_torque_nm: c.b_k * w * f.hip_torque_nm,
                side_n: 0.0,
                roll_moment_nm: 0.0,
                yaw_moment_nm: 0.0,
                regime: f.regime,
            },
            parts,
            drag_n: drag,
            lift_n: lift,
            hip_torque_nm: zero(c.b_k * w * g.hip_torque_nm),
            submerged_m: g.submerged_m,
            depth_m: g.depth_m,
            regime: g.regime,
            sensor_drag_n: drag + bias[0],
            sensor_lift_n: lift + bias[1],
        })
    }
}

/// The unit model (`b_k = a = 1`) with the surface `surface_drop_m` lower than configured (the
/// hip that much higher above it), the hip kept within the plate's reach. It keeps `unit`'s
/// medium constants: called per sample for a hip the robot's state places.
pub fn moved_unit_model(unit: &TerzaghiModel, surface_drop_m: f64) -> TerzaghiModel {
    let plate = unit.plate();
    let h = (plate.hip_height_m() + surface_drop_m).clamp(0.0, 0.95 * plate.length_m());
    unit.with_hip_height_m(h).unwrap_or_else(|_| unit.clone())
}

/// The unit model in a medium one degree stronger in friction (none where `phi` is at its
/// limit).
pub fn stronger_unit_model(unit: &TerzaghiModel) -> Option<TerzaghiModel> {
    let m = unit.medium();
    Medium::new(m.unit_weight_n_m3(), m.phi_deg() + 1.0, m.delta_deg())
        .ok()
        .map(|s| TerzaghiModel::conventional(*unit.plate(), s))
}

/// The sensor's first-order lag on a leg's predicted force, sample after sample.
#[derive(Debug, Clone, Default)]
pub struct SensorLagFilter {
    /// The previous sample's time (s), input and output (drag, lift).
    prev: Option<(f64, [f64; 2], [f64; 2])>,
}

impl SensorLagFilter {
    /// The lagged force at `t_s` for the input `x` (drag, lift); the first sample passes as it
    /// is, a time going back restarts the filter.
    pub fn step(&mut self, t_s: f64, x: [f64; 2], tau_s: f64) -> [f64; 2] {
        let y = match self.prev {
            Some((t0, x0, y0)) if t_s >= t0 && tau_s > 0.0 => [
                lag_step(x0[0], x[0], y0[0], t_s - t0, tau_s),
                lag_step(x0[1], x[1], y0[1], t_s - t0, tau_s),
            ],
            _ => x,
        };
        let y = if y[0].is_finite() && y[1].is_finite() {
            y
        } else {
            x
        };
        self.prev = Some((t_s, x, y));
        y
    }

    /// Forgets the previous sample: the next one passes as it is.
    pub fn reset(&mut self) {
        self.prev = None;
    }
}

/// How early, in periods, [`SampleHold`] takes an instant due.
const HOLD_SLACK_PERIODS: f64 = 0.1;

/// A sample-and-hold F/T sensor's reading: the force at the last instant the sensor sampled,
/// held until the next. Its instants fall every `period_s` from an anchor: the last time its
/// value was seen to change (the sensor's own update, [`SampleHold::updated_at`]), or else the
/// first sample.
#[derive(Debug, Clone, Default)]
pub struct SampleHold {
    anchor_s: Option<f64>,
    /// The period of the last step (s).
    period_s: f64,
    /// The instant held (its index from the anchor, the anchor) and the value sampled then.
    held: Option<(f64, f64, [f64; 2])>,
}

impl SampleHold {
    /// Marks `t_s` as a time the sensor updated its value: its instants fall from there.
    pub fn updated_at(&mut self, t_s: f64) {
        if !t_s.is_finite() {
            return;
        }
        // The update the last instant taken stood for (within the slack): that instant is
        // the update's, not a reason to sample again.
        if let (Some((k, a, v)), true) = (self.held, self.period_s > 0.0) {
            let taken_s = a + k * self.period_s;
            if (t_s - taken_s).abs() <= HOLD_SLACK_PERIODS * self.period_s {
                self.held = Some((0.0, t_s, v));
            }
        }
        self.anchor_s = Some(t_s);
    }

    /// The reading at `t_s` of a sensor that samples every `period_s` the force `x` (drag,
    /// lift) there: `x` itself at the first sample past an instant, the value held since
    /// otherwise. A period that is not positive, a time not finite or a non-finite force pass
    /// `x` as it is.
    pub fn step(&mut self, t_s: f64, x: [f64; 2], period_s: f64) -> [f64; 2] {
        let usable = period_s > 0.0 && period_s.is_finite() && t_s.is_finite();
        if !(usable && x[0].is_finite() && x[1].is_finite()) {
            return x;
        }
        self.period_s = period_s;
        let anchor = *self.anchor_s.get_or_insert(t_s);
        // An instant is taken up to a tenth of a period before it is due: the period is a
        // measured one, and stamps jitter. The anchor moves with each update seen, so the slack
        // does not add up.
        let instant = ((t_s - anchor) / period_s + HOLD_SLACK_PERIODS).floor();
        match self.held {
            Some((k, a, v)) if k == instant && a == anchor => v,
            _ => {
                self.held = Some((instant, anchor, x));
                x
            }
        }
    }
}

/// Follows a leg's motion from its attack angles and their times, causally (each value from the
/// samples up to it): the angle made continuous across turns, the stroke count, the angular
/// speed and acceleration as least-squares slopes over a short window, and the area swept since
/// the plate entered the medium.
#[derive(Debug, Clone)]
pub struct MotionTracker {
    window_s: f64,
    /// Recent `(t_s, unwrapped angle)` and `(t_s, speed)`, oldest first.
    angles: std::collections::VecDeque<(f64, f64)>,
    speeds: std::collections::VecDeque<(f64, f64)>,
    start_rad: Option<f64>,
    last: Option<(f64, f64)>,
    swept_m2: f64,
}

impl MotionTracker {
    /// Slopes over the last `window_s` seconds (at least two samples).
    pub fn new(window_s: f64) -> MotionTracker {
        MotionTracker {
            window_s: if window_s > 0.0 { window_s } else { 0.03 },
            angles: Default::default(),
            speeds: Default::default(),
            start_rad: None,
            last: None,
            swept_m2: 0.0,
        }
    }

    /// The motion at `t_s` with attack angle `beta_rad`, the plate `submerged_m` deep in length
    /// (0 out of the medium) and `length_m` long. A time that goes back restarts the slopes.
    pub fn update(&mut self, t_s: f64, beta_rad: f64, submerged_m: f64, length_m: f64) -> Motion {
        let b = beta_rad.rem_euclid(TAU);
        if !(t_s.is_finite() && b.is_finite()) {
            return self.motion();
        }
        let u = match self.last {
            Some((t0, p)) => {
                if t_s < t0 {
                    // A time that goes back: the slopes start again from here.
                    self.angles.clear();
                    self.speeds.clear();
                }
                unwrap_after(p, b)
            }
            None => b,
        };
        self.start_rad.get_or_insert(u);
        if submerged_m > 0.0 {
            let d = self.last.map_or(0.0, |(_, p)| (u - p).max(0.0));
            let r_in = length_m - submerged_m;
            self.swept_m2 += 0.5 * (length_m * length_m - r_in * r_in) * d;
        } else {
            self.swept_m2 = 0.0;
        }
        self.last = Some((t_s, u));
        push_window(&mut self.angles, (t_s, u), self.window_s);
        let speed = slope(&self.angles);
        push_window(&mut self.speeds, (t_s, speed), self.window_s);
        self.motion()
    }

    fn motion(&self) -> Motion {
        let speed = self.speeds.back().map_or(0.0, |s| s.1);
        let stroke = match (self.start_rad, self.last) {
            (Some(s), Some((_, u))) => ((u - s) / TAU).floor().max(0.0) as usize,
            _ => 0,
        };
        Motion {
            speed_rad_s: speed,
            accel_rad_s2: slope(&self.speeds),
            swept_m2: self.swept_m2,
            stroke,
        }
    }
}

/// The angle `beta_rad` (any turn) made continuous after the unwrapped angle `prev_rad`: the
/// short way round.
pub fn unwrap_after(prev_rad: f64, beta_rad: f64) -> f64 {
    let mut d = beta_rad.rem_euclid(TAU) - prev_rad.rem_euclid(TAU);
    if d < -PI {
        d += TAU;
    } else if d > PI {
        d -= TAU;
    }
    prev_rad + d
}

fn push_window(w: &mut std::collections::VecDeque<(f64, f64)>, p: (f64, f64), window_s: f64) {
    w.push_back(p);
    while w.len() > 2 && w.front().is_some_and(|f| p.0 - f.0 > window_s) {
        w.pop_front();
    }
}

/// Least-squares slope of `y` against `t` (0 for fewer than two distinct times).
fn slope(w: &std::collections::VecDeque<(f64, f64)>) -> f64 {
    let n = w.len() as f64;
    if n < 2.0 {
        return 0.0;
    }
    let (st, sy) = w.iter().fold((0.0, 0.0), |(a, b), p| (a + p.0, b + p.1));
    let (mt, my) = (st / n, sy / n);
    let (num, den) = w.iter().fold((0.0, 0.0), |(a, b), p| {
        (a + (p.0 - mt) * (p.1 - my), b + (p.0 - mt) * (p.0 - mt))
    });
    if den > 0.0 && (num / den).is_finite() {
        num / den
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_held_reading_changes_only_at_the_sensors_instants() {
        let mut h = SampleHold::default();
        // A 100 Hz stream of a ramp, read by a 12.5 Hz sensor anchored at 0.
        h.updated_at(0.0);
        let read: Vec<f64> = (0..40)
            .map(|i| {
                let t = f64::from(i) * 0.01;
                h.step(t, [0.0, t], 0.08)[1]
            })
            .collect();
        for (i, r) in read.iter().enumerate() {
            let t = i as f64 * 0.01;
            let instant = (t / 0.08 + 1e-9).floor() * 0.08;
            assert!(
                (r - instant).abs() < 0.0101,
                "at {t}: {r} against {instant}"
            );
        }
        let changes = read.windows(2).filter(|w| w[0] != w[1]).count();
        assert_eq!(changes, 4);
        // The sensor seen updating re-anchors the instants.
        h.updated_at(0.405);
        assert_eq!(h.step(0.41, [0.0, 9.0], 0.08), [0.0, 9.0]);
        assert_eq!(h.step(0.47, [0.0, 10.0], 0.08), [0.0, 9.0]);
        // An instant taken as it fell due, then the sensor seen updating then: the instant
        // stands for that update, and the value is not sampled again.
        let mut h = SampleHold::default();
        h.updated_at(0.0);
        assert_eq!(h.step(0.0, [0.0, 1.0], 0.1), [0.0, 1.0]);
        assert_eq!(h.step(0.095, [0.0, 2.0], 0.1), [0.0, 2.0]);
        h.updated_at(0.1);
        assert_eq!(h.step(0.105, [0.0, 3.0], 0.1), [0.0, 2.0]);
        assert_eq!(h.step(0.195, [0.0, 4.0], 0.1), [0.0, 4.0]);
        // No period: the force as it is.
        assert_eq!(h.step(0.48, [1.0, 2.0], 0.0), [1.0, 2.0]);
        assert_eq!(h.step(f64::NAN, [1.0, 2.0], 0.08), [1.0, 2.0]);
    }

    fn plate() -> Plate {
        Plate::new(0.25, 0.06, 0.15).unwrap()
    }
    fn medium() -> Medium {
        Medium::new(16170.0, 32.0, 19.0).unwrap()
    }

    #[test]
    fn linear_values_are_named_by_effect_and_parameter_in_column_order() {
        let mut c = Corrections::none(2.0, 1.5);
        c.terms = vec![
            Term {
                effect: Effect::Rate,
                coefficients: vec![1.0, 2.0, 3.0, 4.0],
            },
            Term {
                effect: Effect::SensorBias,
                coefficients: vec![5.0, 6.0],
            },
        ];
        let names: Vec<String> = [Effect::Rate, Effect::SensorBias]
            .iter()
            .flat_map(|e| e.linear_params().iter().map(move |p| format!("{e}.{p}")))
            .collect();
        let values = c.linear_values();
        assert_eq!(
            values.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>(),
            names
        );
        assert_eq!(
            values.iter().map(|(_, v)| *v).collect::<Vec<_>>(),
            [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]
        );
        assert_eq!(names[0], "rate.normal_kg_m3");
        assert_eq!(names[5], "sensor_bias.lift_n");
    }

    #[test]
    fn without_terms_it_is_the_improved_model() {
        let m = CorrectedModel::new(plate(), medium(), Corrections::none(2.0, 1.5)).unwrap();
        let p = m.evaluate(60f64.to_radians(), &Motion::default()).unwrap();
        let d = 39.674130 * 2.0 * 1.5f64.powf(-60f64.to_radians());
        assert!((p.drag_n - d).abs() < 1e-5, "{}", p.drag_n);
        assert_eq!((p.drag_n, p.lift_n), (p.bare.drag_n, p.bare.lift_n));
        assert_eq!((p.sensor_drag_n, p.sensor_lift_n), (p.drag_n, p.lift_n));
        assert!(p.parts.is_empty());
    }

    #[test]
    fn every_term_is_zero_out_of_the_medium_and_never_nan() {
        let mut c = Corrections::none(2.0, 1.5);
        for e in ALL {
            c.terms.push(Term {
                effect: e,
                coefficients: vec![1.0; e.linear_params().len()],
            });
        }
        c.nonlinear = Nonlinear {
            surface_drop_m: 0.01,
            lag_s: 0.02,
            speed_exponent: 1.0,
            change_at_session_frac: 0.5,
        };
        c.typical_speed_rad_s = 2.0;
        c.session_strokes = 10;
        let m = CorrectedModel::new(plate(), medium(), c).unwrap();
        // Out of the medium (pointing up, and just above the surface): only the offset.
        for beta in [-1.0, 0.3, 4.0] {
            let p = m.evaluate(beta, &Motion::default()).unwrap();
            assert_eq!((p.drag_n, p.lift_n), (0.0, 0.0), "beta {beta}");
            assert_eq!((p.sensor_drag_n, p.sensor_lift_n), (1.0, 1.0));
        }
        // Zero speed, before the first stroke, in the medium: finite.
        let p = m.evaluate(1.2, &Motion::default()).unwrap();
        assert!(p.drag_n.is_finite() && p.lift_n.is_finite());
        assert!(
            p.parts
                .iter()
                .all(|(_, v)| v[0].is_finite() && v[1].is_finite())
        );
        // The parts add up to the medium's force.
        let sum: f64 = p.bare.drag_n + p.parts.iter().map(|(_, v)| v[0]).sum::<f64>();
        assert!((sum - p.drag_n).abs() < 1e-9);
    }

    #[test]
    fn a_coefficient_beyond_its_bounds_is_refused_by_name() {
        let mut c = Corrections::none(2.0, 1.5);
        c.terms.push(Term {
            effect: Effect::SensorLag,
            coefficients: vec![],
        });
        c.nonlinear.lag_s = 5.0;
        let e = CorrectedModel::new(plate(), medium(), c).unwrap_err();
        assert!(
            e.to_string().contains("sensor_lag.time_constant_s = 5"),
            "{e}"
        );
        let mut c = Corrections::none(2.0, 1.5);
        c.terms.push(Term {
            effect: Effect::Surcharge,
            coefficients: vec![f64::NAN, 0.0],
        });
        let e = c.validate(0.25).unwrap_err();
        assert!(e.to_string().contains("surcharge.normal_n_m4 = NaN"), "{e}");
    }

    #[test]
    fn the_tracker_follows_a_steady_turn_across_the_wrap() {
        let mut t = MotionTracker::new(0.03);
        let mut m = Motion::default();
        for i in 0..4000 {
            let ts = i as f64 * 0.001;
            m = t.update(ts, 0.2 + 2.5 * ts, 0.0, 0.25);
        }
        // 10 rad in 4 s: one full turn (from 0.2 rad).
        assert_eq!(m.stroke, 1);
        assert!((m.speed_rad_s - 2.5).abs() < 1e-9, "{}", m.speed_rad_s);
        assert!(m.accel_rad_s2.abs() < 1e-6);
    }

    #[test]
    fn the_lag_follows_a_ramp_one_time_constant_behind() {
        let mut f = SensorLagFilter::default();
        let mut y = [0.0; 2];
        for i in 0..1000 {
            let t = i as f64 * 0.002;
            y = f.step(t, [t, 2.0 * t], 0.02);
        }
        let t = 999.0 * 0.002;
        assert!((y[0] - (t - 0.02)).abs() < 1e-9, "{y:?}");
        assert!((y[1] - 2.0 * (t - 0.02)).abs() < 1e-9, "{y:?}");
    }
}
