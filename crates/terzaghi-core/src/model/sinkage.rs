//! A horizontal plate pushed straight down into the medium: the plate-sinkage (bevameter) test
//! labs run to calibrate their sand before they predict a wheel or a leg. The pressure under the
//! plate at sinkage `z` (m) by one of five laws:
//!
//! - [`SinkageLaw::TerzaghiFooting`]: Terzaghi's bearing capacity of a shallow footing, a depth
//!   term and a width term, `p = gamma z N_q + s_gamma 0.5 gamma B N_gamma` (dry sand: no
//!   cohesion term), `B` the plate's width (a disc's diameter), `s_gamma` 0.6 for a disc and
//!   `1 - 0.4 B/L` for a rectangle.
//! - [`SinkageLaw::Bekker`]: `p = (k_c / b + k_phi) z^n`, `b` the smaller dimension of the
//!   plate (a disc's radius, a rectangle's width).
//! - [`SinkageLaw::Reece`]: `p = gamma b k'_phi (z / b)^n`, Reece's form without its cohesion
//!   term: the width enters as `b^(1 - n)`.
//! - [`SinkageLaw::RftDepthPower`]: RFT's vertical stress for a horizontal plate moving down,
//!   `xi alpha_z(0, down) z_ref (z / z_ref)^n`, `z_ref` 1 cm: `n = 1`, `xi = 1` is RFT as
//!   published; a depth law beyond linear where the data ask for it. No width term.
//! - [`SinkageLaw::DepthWidthPower`]: `p = k (z / z_ref)^n (b / b_ref)^m`, `z_ref = b_ref`
//!   1 cm: a power law in depth and in width, which holds Bekker's exponent form (`m = 0`) and
//!   Reece's (`m = 1 - n`) as special cases.
//!
//! The laws give the plate's resistance while it loads virgin medium, moving down at or below
//! the deepest point it has reached. Held still, or unloaded at constant depth, the plate is in
//! a regime of its own ([`SinkageRegime::Unloading`]): the force then depends on the load the
//! rig applies, not on the medium's law, and none of the laws predicts it. [`sinkage_regimes`]
//! tells the regimes of a test's rows apart.

use super::{HipMotion, ModelError, Plate, Prediction, Regime};
use serde::{Deserialize, Serialize};

/// Standard gravity (m/s^2), to turn a bulk density into a unit weight.
pub const G_M_S2: f64 = 9.80665;
/// The deepest a [`SinkageLeg`] is predicted at (m); deeper is a bad hip height, refused.
pub const MAX_DEPTH_M: f64 = 1.0;
/// The reference depth and width of the power laws (m).
pub const REF_LENGTH_M: f64 = 0.01;

/// The plate's shape, seen from above.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "shape", rename_all = "snake_case")]
pub enum PlateShape {
    /// A disc.
    Disc {
        /// Its diameter (m).
        diameter_m: f64,
    },
    /// A rectangle.
    Rectangle {
        /// Its width, the smaller side (m).
        width_m: f64,
        /// Its length, the larger side (m).
        length_m: f64,
    },
}

impl PlateShape {
    /// A disc of `diameter_m`, checked.
    pub fn disc(diameter_m: f64) -> Result<Self, ModelError> {
        positive("plate diameter (m)", diameter_m)?;
        Ok(PlateShape::Disc { diameter_m })
    }

    /// A rectangle, checked; the smaller side is its width whichever order they come in.
    pub fn rectangle(a_m: f64, b_m: f64) -> Result<Self, ModelError> {
        positive("plate width (m)", a_m)?;
        positive("plate length (m)", b_m)?;
        Ok(PlateShape::Rectangle {
            width_m: a_m.min(b_m),
            length_m: a_m.max(b_m),
        })
    }

    /// The area pressed on the medium (m^2).
    pub fn area_m2(&self) -> f64 {
        match *self {
            PlateShape::Disc { diameter_m } => std::f64::consts::PI * diameter_m * diameter_m / 4.0,
            PlateShape::Rectangle { width_m, length_m } => width_m * length_m,
        }
    }

    /// Bekker's and Reece's `b`: the smaller dimension, a disc's radius or a rectangle's width (m).
    pub fn bekker_b_m(&self) -> f64 {
        match *self {
            PlateShape::Disc { diameter_m } => diameter_m / 2.0,
            PlateShape::Rectangle { width_m, .. } => width_m,
        }
    }

    /// The footing's width `B`, a disc's diameter or a rectangle's width (m), and Terzaghi's
    /// shape factor of the width term.
    pub fn footing_b_m(&self) -> (f64, f64) {
        match *self {
            PlateShape::Disc { diameter_m } => (diameter_m, 0.6),
            PlateShape::Rectangle { width_m, length_m } => {
                (width_m, 1.0 - 0.4 * width_m / length_m)
            }
        }
    }

    /// Words for a table: `disc 60 mm`, `rectangle 50 x 200 mm`.
    pub fn label(&self) -> String {
        match *self {
            PlateShape::Disc { diameter_m } => format!("disc {:.0} mm", diameter_m * 1e3),
            PlateShape::Rectangle { width_m, length_m } => {
                format!("rectangle {:.0} x {:.0} mm", width_m * 1e3, length_m * 1e3)
            }
        }
    }
}

fn positive(name: &'static str, value: f64) -> Result<f64, ModelError> {
    if !value.is_finite() {
        return Err(ModelError::NotFinite { name, value });
    }
    if value <= 0.0 {
        return Err(ModelError::NotPositive { name, value });
    }
    Ok(value)
}

/// A plate-sinkage law, by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SinkageLaw {
    /// Terzaghi's shallow footing: `N_q`, `N_gamma`.
    TerzaghiFooting,
    /// Bekker: `k_c` (N/m^(n+1)), `k_phi` (N/m^(n+2)), `n`.
    Bekker,
    /// Reece without cohesion: `k_phi_prime` (dimensionless), `n`.
    Reece,
    /// RFT's vertical stress with a depth exponent: `xi` (scale of RFT's `alpha_z`), `n`.
    RftDepthPower,
    /// A power law in depth and width: `k_pa` (Pa at 1 cm depth, 1 cm width), `n`, `m`.
    DepthWidthPower,
}

impl SinkageLaw {
    /// Every law, in the order tables list them.
    pub const ALL: [SinkageLaw; 5] = [
        SinkageLaw::TerzaghiFooting,
        SinkageLaw::Bekker,
        SinkageLaw::Reece,
        SinkageLaw::RftDepthPower,
        SinkageLaw::DepthWidthPower,
    ];

    /// The name users write (`bekker`, `depth_width_power`, ...).
    pub fn name(self) -> &'static str {
        match self {
            SinkageLaw::TerzaghiFooting => "terzaghi_footing",
            SinkageLaw::Bekker => "bekker",
            SinkageLaw::Reece => "reece",
            SinkageLaw::RftDepthPower => "rft_depth_power",
            SinkageLaw::DepthWidthPower => "depth_width_power",
        }
    }

    /// The law of a name.
    pub fn by_name(name: &str) -> Result<Self, ModelError> {
        Self::ALL
            .into_iter()
            .find(|l| l.name() == name)
            .ok_or_else(|| ModelError::UnknownMedium {
                name: format!("sinkage law {name}"),
                known: Self::ALL.map(|l| l.name()).join(", "),
            })
    }

    /// The names of its parameters, with their units, in the order of [`SinkageModel::params`].
    pub fn param_names(self) -> &'static [&'static str] {
        match self {
            SinkageLaw::TerzaghiFooting => &["n_q", "n_gamma"],
            SinkageLaw::Bekker => &["k_c", "k_phi", "n"],
            SinkageLaw::Reece => &["k_phi_prime", "n"],
            SinkageLaw::RftDepthPower => &["xi", "n"],
            SinkageLaw::DepthWidthPower => &["k_pa", "n", "m"],
        }
    }

    /// The physical range of each parameter, in the order of [`Self::param_names`]: the one
    /// definition that the medium file's readers check ([`SinkageModel::new`]) and the fit
    /// keeps to (`ident::sinkage::fit_sinkage`). The moduli and bearing factors are
    /// not negative; the exponents of depth lie in `(0, MAX_EXPONENT]`, the width exponent in
    /// `(-MAX_EXPONENT, MAX_EXPONENT]`.
    pub fn param_ranges(self) -> &'static [ParamRange] {
        const NOT_NEGATIVE: ParamRange = ParamRange {
            lo: 0.0,
            hi: f64::INFINITY,
            lo_open: false,
        };
        const DEPTH_EXPONENT: ParamRange = ParamRange {
            lo: 0.0,
            hi: MAX_EXPONENT,
            lo_open: true,
        };
        const WIDTH_EXPONENT: ParamRange = ParamRange {
            lo: -MAX_EXPONENT,
            hi: MAX_EXPONENT,
            lo_open: true,
        };
        match self {
            SinkageLaw::TerzaghiFooting => &[NOT_NEGATIVE, NOT_NEGATIVE],
            SinkageLaw::Bekker => &[NOT_NEGATIVE, NOT_NEGATIVE, DEPTH_EXPONENT],
            SinkageLaw::Reece | SinkageLaw::RftDepthPower => &[NOT_NEGATIVE, DEPTH_EXPONENT],
            SinkageLaw::DepthWidthPower => &[NOT_NEGATIVE, DEPTH_EXPONENT, WIDTH_EXPONENT],
        }
    }

    /// The parameter that scales the law's pressure in proportion (the one an online estimator
    /// learns as the medium's scale), as an index into its parameters; Bekker's two moduli
    /// scale together.
    pub fn scale_params(self) -> &'static [usize] {
        match self {
            SinkageLaw::TerzaghiFooting => &[0, 1],
            SinkageLaw::Bekker => &[0, 1],
            SinkageLaw::Reece | SinkageLaw::RftDepthPower | SinkageLaw::DepthWidthPower => &[0],
        }
    }

    /// The parameter that says how the pressure changes with the plate's width, if the law has
    /// one that a single plate size cannot tell (it is then held at the value given here).
    pub fn width_param(self) -> Option<(usize, f64)> {
        match self {
            SinkageLaw::Bekker => Some((0, 0.0)),
            SinkageLaw::DepthWidthPower => Some((2, 0.0)),
            _ => None,
        }
    }
}

/// The range a sinkage parameter must lie in: `lo..=hi`, or `lo` left out where `lo_open`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamRange {
    /// The lower bound.
    pub lo: f64,
    /// The upper bound (infinite: none).
    pub hi: f64,
    /// Whether `lo` itself lies outside.
    pub lo_open: bool,
}

impl ParamRange {
    /// Whether `v` lies in the range.
    pub fn contains(&self, v: f64) -> bool {
        (if self.lo_open {
            v > self.lo
        } else {
            v >= self.lo
        }) && v <= self.hi
    }

    /// The range in words: `>= 0`, `(0, 5]`.
    pub fn text(&self) -> String {
        match (self.hi.is_finite(), self.lo_open) {
            (false, false) => format!(">= {}", self.lo),
            (false, true) => format!("> {}", self.lo),
            (true, open) => format!("{}{}, {}]", if open { "(" } else { "[" }, self.lo, self.hi),
        }
    }

    /// The value of the range nearest `v`: `v` itself inside it; at an open bound, a
    /// thousandth of the range's width (or of 1) inside.
    pub fn nearest(&self, v: f64) -> f64 {
        if self.contains(v) {
            return v;
        }
        if v > self.hi {
            return self.hi;
        }
        if self.lo_open {
            let width = if self.hi.is_finite() {
                self.hi - self.lo
            } else {
                1.0
            };
            self.lo + 1e-3 * width
        } else {
            self.lo
        }
    }
}

/// A medium's plate-sinkage law with its values: what `terzaghi calibrate` fits.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SinkageModel {
    /// The law.
    pub law: SinkageLaw,
    /// Its parameters, in the order of [`SinkageLaw::param_names`].
    pub params: Vec<f64>,
    /// The medium's unit weight (N/m^3), which Terzaghi's and Reece's laws use.
    pub unit_weight_n_m3: f64,
    /// RFT's `alpha_z` for a horizontal plate moving straight down (N/cm^3 per cm), which the
    /// RFT law scales.
    pub rft_alpha_z_n_cm3: f64,
}

/// The largest exponent of depth or width a sinkage law may have.
pub const MAX_EXPONENT: f64 = 5.0;

impl SinkageModel {
    /// A model, checked: every value finite, the right count, positive exponents, unit weight
    /// and `alpha_z`, and a pressure that is not negative over the plates and depths a test
    /// reaches.
    pub fn new(
        law: SinkageLaw,
        params: Vec<f64>,
        unit_weight_n_m3: f64,
        rft_alpha_z_n_cm3: f64,
    ) -> Result<Self, ModelError> {
        let names = law.param_names();
        if params.len() != names.len() {
            return Err(ModelError::OutOfRange {
                what: "count of sinkage parameters",
                value: params.len() as f64,
                range: format!("{} ({})", names.len(), names.join(", ")),
            });
        }
        for (v, name) in params.iter().zip(names) {
            if !v.is_finite() {
                return Err(ModelError::NotFinite {
                    name: param_label(name),
                    value: *v,
                });
            }
        }
        positive("unit weight (N/m^3)", unit_weight_n_m3)?;
        positive("RFT alpha_z (N/cm^3)", rft_alpha_z_n_cm3)?;
        let m = SinkageModel {
            law,
            params,
            unit_weight_n_m3,
            rft_alpha_z_n_cm3,
        };
        // Every value within its physical range (exponents within what any soil shows, with
        // room: a law that rises as z^1e17 has a pressure that is no number a metre down).
        for ((v, name), range) in m.params.iter().zip(names).zip(law.param_ranges()) {
            if !range.contains(*v) {
                return Err(ModelError::OutOfRange {
                    what: param_label(name),
                    value: *v,
                    range: range.text(),
                });
            }
        }
        // Finite at the deepest and widest a leg or plate of this crate reaches: 1 m down
        // under a plate 1 m across, and at 1 mm under one of 1 mm.
        for (b, z) in [(1.0, 1.0), (1e-3, 1e-3)] {
            let plate = PlateShape::rectangle(b, b)?;
            let p = m.pressure_pa(&plate, z);
            if !p.is_finite() {
                return Err(ModelError::OutOfRange {
                    what: "sinkage pressure (Pa) of these parameters",
                    value: p,
                    range: format!("finite at {z} m under a plate {b} m wide"),
                });
            }
        }
        Ok(m)
    }

    /// The pressure under `plate` at sinkage `depth_m` (Pa) while it loads: 0 above the surface.
    pub fn pressure_pa(&self, plate: &PlateShape, depth_m: f64) -> f64 {
        if depth_m.is_nan() || depth_m <= 0.0 {
            return 0.0;
        }
        let p = &self.params;
        let z = depth_m;
        let gamma = self.unit_weight_n_m3;
        let pressure = match self.law {
            SinkageLaw::TerzaghiFooting => {
                let (b, s_gamma) = plate.footing_b_m();
                gamma * z * p[0] + s_gamma * 0.5 * gamma * b * p[1]
            }
            SinkageLaw::Bekker => (p[0] / plate.bekker_b_m() + p[1]) * z.powf(p[2]),
            SinkageLaw::Reece => {
                let b = plate.bekker_b_m();
                gamma * b * p[0] * (z / b).powf(p[1])
            }
            SinkageLaw::RftDepthPower => {
                // alpha_z (N/cm^3) at 1 cm is alpha_z * 1e6 N/m^3 * 0.01 m.
                p[0] * self.rft_alpha_z_n_cm3 * 1e6 * REF_LENGTH_M * (z / REF_LENGTH_M).powf(p[1])
            }
            SinkageLaw::DepthWidthPower => {
                p[0] * (z / REF_LENGTH_M).powf(p[1])
                    * (plate.bekker_b_m() / REF_LENGTH_M).powf(p[2])
            }
        };
        pressure.max(0.0)
    }

    /// The vertical force on `plate` at sinkage `depth_m` (N, up) while it loads.
    pub fn force_n(&self, plate: &PlateShape, depth_m: f64) -> f64 {
        self.pressure_pa(plate, depth_m) * plate.area_m2()
    }

    /// The model with every parameter that scales its pressure multiplied by `scale`.
    pub fn scaled(&self, scale: f64) -> SinkageModel {
        let mut m = self.clone();
        for &i in self.law.scale_params() {
            m.params[i] *= scale;
        }
        m
    }

    /// The sinkage exponent the law implies between depths `z1_m` and `z2_m` on `plate`:
    /// `d ln F / d ln z` from the two forces.
    pub fn depth_exponent(&self, plate: &PlateShape, z1_m: f64, z2_m: f64) -> f64 {
        (self.force_n(plate, z2_m) / self.force_n(plate, z1_m)).ln() / (z2_m / z1_m).ln()
    }
}

fn param_label(name: &str) -> &'static str {
    match name {
        "n_q" => "N_q",
        "n_gamma" => "N_gamma",
        "k_c" => "k_c (N/m^(n+1))",
        "k_phi" => "k_phi (N/m^(n+2))",
        "n" => "sinkage exponent n",
        "k_phi_prime" => "k'_phi",
        "xi" => "RFT scale xi",
        "k_pa" => "k (Pa)",
        "m" => "width exponent m",
        _ => "sinkage parameter",
    }
}

/// A leg that is a horizontal plate pushed straight down (a test's plate, a foot that does not
/// turn): its depth is the hip's height below the surface, its joint angle plays no part.
#[derive(Debug, Clone, PartialEq)]
pub struct SinkageLeg {
    model: SinkageModel,
    shape: PlateShape,
    plate: Plate,
    min_speed_m_s: f64,
}

impl SinkageLeg {
    /// The leg of `shape`, pressing by `model`; `plate` is its configured geometry and hip
    /// height (where a leg without a robot's state stands). It loads while its hip moves down at
    /// `RegimeOptions::default().min_speed_m_s` or faster.
    pub fn new(model: SinkageModel, shape: PlateShape, plate: Plate) -> SinkageLeg {
        SinkageLeg {
            model,
            shape,
            plate,
            min_speed_m_s: RegimeOptions::default().min_speed_m_s,
        }
    }

    /// The law.
    pub fn model(&self) -> &SinkageModel {
        &self.model
    }

    /// The plate's shape.
    pub fn shape(&self) -> &PlateShape {
        &self.shape
    }

    /// The configured geometry.
    pub fn plate(&self) -> &Plate {
        &self.plate
    }

    /// The prediction with the hip at `hip` (its height negative below the surface): the law's
    /// upward force at the plate's depth, in the regime its vertical velocity gives (loading as
    /// [`Regime::Penetration`], otherwise [`Regime::Unloading`]). The joint angle is only
    /// passed through. A non-finite height or velocity is an error naming it.
    pub fn predict(&self, beta_rad: f64, hip: &HipMotion) -> Result<Prediction, ModelError> {
        for (name, v) in [
            ("hip height (m)", hip.height_m),
            ("hip vertical velocity (m/s)", hip.up_m_s),
        ] {
            if !v.is_finite() {
                return Err(ModelError::NotFinite { name, value: v });
            }
        }
        let depth_m = -hip.height_m;
        if depth_m > MAX_DEPTH_M {
            return Err(ModelError::OutOfRange {
                what: "plate depth below the surface (m)",
                value: depth_m,
                range: format!(
                    "up to {MAX_DEPTH_M} m (a plate sinks centimetres: a bad hip height?)"
                ),
            });
        }
        let regime = if depth_m <= 0.0 {
            Regime::OutOfMedium
        } else if -hip.up_m_s >= self.min_speed_m_s {
            Regime::Penetration
        } else {
            Regime::Unloading
        };
        let lift_n = self.model.force_n(&self.shape, depth_m);
        Ok(Prediction {
            beta_rad: if beta_rad.is_finite() { beta_rad } else { 0.0 },
            submerged_m: if depth_m > 0.0 {
                self.shape.footing_b_m().0
            } else {
                0.0
            },
            depth_m: depth_m.max(0.0),
            drag_n: 0.0,
            lift_n,
            hip_torque_nm: 0.0,
            side_n: 0.0,
            roll_moment_nm: 0.0,
            yaw_moment_nm: 0.0,
            regime,
        })
    }
}

/// The regime of a row of a plate-sinkage test or of a leg pushed down.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SinkageRegime {
    /// The plate is above the surface (or on it): no force from the medium.
    Above,
    /// The plate moves down into medium it has not yet pressed: the law applies.
    Loading,
    /// The plate holds still, is unloaded at constant depth, rises, or moves within depth it
    /// has already pressed: the force is the rig's to set, not the law's.
    Unloading,
}

/// How [`sinkage_regimes`] tells the regimes apart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RegimeOptions {
    /// A plate moving down slower than this holds still (m/s).
    pub min_speed_m_s: f64,
    /// How far above the deepest point reached so far a plate still presses virgin medium (m).
    pub depth_tolerance_m: f64,
}

impl Default for RegimeOptions {
    fn default() -> Self {
        RegimeOptions {
            min_speed_m_s: 0.5e-3,
            depth_tolerance_m: 0.5e-3,
        }
    }
}

/// The deepest point a plate has pressed in its present intrusion, followed sample by sample,
/// as [`sinkage_regimes`] follows it over a test's rows: a plate moving down within what it has
/// already pressed reloads sand the law does not describe; only past the deepest point (within
/// `depth_tolerance_m`) does it load virgin medium again. Out of the medium, it forgets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PressedDepth {
    deepest_m: f64,
    tolerance_m: f64,
}

impl PressedDepth {
    /// Nothing pressed yet; `opts.depth_tolerance_m` as [`sinkage_regimes`] takes it.
    pub fn new(opts: &RegimeOptions) -> PressedDepth {
        PressedDepth {
            deepest_m: f64::NEG_INFINITY,
            tolerance_m: opts.depth_tolerance_m,
        }
    }

    /// The plate at `depth_m` below the surface: whether it is at or past the deepest point
    /// pressed before (virgin medium), which it then remembers. A depth that is not finite
    /// changes nothing and is not virgin.
    pub fn press(&mut self, depth_m: f64) -> bool {
        if !depth_m.is_finite() {
            return false;
        }
        if depth_m <= 0.0 {
            self.deepest_m = f64::NEG_INFINITY;
            return true;
        }
        let virgin = depth_m >= self.deepest_m - self.tolerance_m;
        self.deepest_m = self.deepest_m.max(depth_m);
        virgin
    }

    /// The deepest point pressed in this intrusion (m), if any.
    pub fn deepest_m(&self) -> Option<f64> {
        self.deepest_m.is_finite().then_some(self.deepest_m)
    }
}

/// The regime of every row of `(t_s, depth_m)`, in order. The speed is the depth's own central
/// difference on its own timeline; a row with a non-finite time or depth is `Unloading` (never
/// `Loading`), and is not used for its neighbours' speeds. A log may hold several intrusions:
/// once the plate is above the surface again, the deepest point pressed is forgotten.
pub fn sinkage_regimes(rows: &[(f64, f64)], opts: &RegimeOptions) -> Vec<SinkageRegime> {
    let finite: Vec<usize> = (0..rows.len())
        .filter(|&i| rows[i].0.is_finite() && rows[i].1.is_finite())
        .collect();
    let mut out = vec![SinkageRegime::Unloading; rows.len()];
    let mut deepest = f64::NEG_INFINITY;
    for (k, &i) in finite.iter().enumerate() {
        let (_, z) = rows[i];
        let before = finite[k.saturating_sub(1)];
        let after = finite[(k + 1).min(finite.len() - 1)];
        let dt = rows[after].0 - rows[before].0;
        let speed_down = if dt > 0.0 {
            (rows[after].1 - rows[before].1) / dt
        } else {
            0.0
        };
        out[i] = if z <= 0.0 {
            SinkageRegime::Above
        } else if speed_down >= opts.min_speed_m_s && z >= deepest - opts.depth_tolerance_m {
            SinkageRegime::Loading
        } else {
            SinkageRegime::Unloading
        };
        // Out of the medium, the next intrusion meets ground it has not pressed (a foot's next
        // step, a rig's bed prepared again).
        deepest = if z <= 0.0 {
            f64::NEG_INFINITY
        } else {
            deepest.max(z)
        };
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Down to 20 mm, back to 10 mm, down to 30 mm: the second push reloads pressed sand until
    /// it passes 20 mm (within half a millimetre); out of the sand, it forgets.
    #[test]
    fn a_plate_reloading_pressed_sand_is_not_virgin_loading() {
        let mut p = PressedDepth::new(&RegimeOptions::default());
        for z in [0.005, 0.01, 0.02] {
            assert!(p.press(z));
        }
        // Rising back (the caller's regime says unloading), then pushed down again.
        assert!(!p.press(0.015) && !p.press(0.01));
        assert!(!p.press(0.015));
        assert!(!p.press(0.019));
        assert!(p.press(0.0196));
        assert!(p.press(0.03));
        assert_eq!(p.deepest_m(), Some(0.03));
        assert!(!p.press(f64::NAN));
        assert!(p.press(-0.001));
        assert_eq!(p.deepest_m(), None);
        assert!(p.press(0.002));
    }

    fn model(law: SinkageLaw, params: &[f64]) -> SinkageModel {
        SinkageModel::new(law, params.to_vec(), 13_000.0, 0.2).unwrap()
    }

    #[test]
    fn laws_scale_with_depth_and_width_as_their_forms_say() {
        let small = PlateShape::disc(0.06).unwrap();
        let large = PlateShape::disc(0.12).unwrap();
        let dw = model(SinkageLaw::DepthWidthPower, &[5000.0, 1.3, 1.0]);
        // Twice the width, twice the pressure (m = 1); twice the depth, 2^1.3.
        let r = dw.pressure_pa(&large, 0.02) / dw.pressure_pa(&small, 0.02);
        assert!((r - 2.0).abs() < 1e-12, "{r}");
        assert!((dw.depth_exponent(&small, 0.01, 0.02) - 1.3).abs() < 1e-12);
        // Reece: width enters as b^(1-n).
        let reece = model(SinkageLaw::Reece, &[50.0, 1.3]);
        let r = reece.pressure_pa(&large, 0.02) / reece.pressure_pa(&small, 0.02);
        assert!((r - 2f64.powf(-0.3)).abs() < 1e-12, "{r}");
        // RFT with n = 1 is alpha_z * depth, whatever the width.
        let rft = model(SinkageLaw::RftDepthPower, &[1.0, 1.0]);
        assert!((rft.pressure_pa(&small, 0.03) - 0.2e6 * 0.03).abs() < 1e-6);
        assert_eq!(rft.pressure_pa(&small, 0.03), rft.pressure_pa(&large, 0.03));
        // Terzaghi's footing bears its width term at the surface.
        let t = model(SinkageLaw::TerzaghiFooting, &[10.0, 20.0]);
        assert!((t.pressure_pa(&small, 1e-9) - 0.6 * 0.5 * 13_000.0 * 0.06 * 20.0).abs() < 1e-3);
        for m in [&dw, &reece, &rft, &t] {
            assert_eq!(m.force_n(&small, -0.01), 0.0);
            assert_eq!(m.force_n(&small, f64::NAN), 0.0);
        }
    }

    #[test]
    fn bad_values_are_named() {
        let e =
            SinkageModel::new(SinkageLaw::Bekker, vec![1.0, f64::NAN, 1.0], 13e3, 0.2).unwrap_err();
        assert!(
            e.to_string().contains("k_phi") && e.to_string().contains("NaN"),
            "{e}"
        );
        let e = SinkageModel::new(SinkageLaw::DepthWidthPower, vec![-5.0, 1.0, 0.0], 13e3, 0.2)
            .unwrap_err();
        assert!(
            e.to_string().contains("k (Pa)") && e.to_string().contains("-5"),
            "{e}"
        );
        let e = SinkageModel::new(SinkageLaw::Reece, vec![1.0], 13e3, 0.2).unwrap_err();
        assert!(e.to_string().contains("k_phi_prime, n"), "{e}");
        assert!(PlateShape::disc(-0.06).is_err());
        assert!(
            SinkageLaw::by_name("bekkr")
                .unwrap_err()
                .to_string()
                .contains("bekker")
        );
    }

    #[test]
    fn a_hold_and_an_unloading_at_constant_depth_are_not_loading() {
        // Down at 5 mm/s to 20 mm, hold 2 s, rise.
        let mut rows = Vec::new();
        let mut t = 0.0;
        while t < 10.0 {
            let z = if t < 2.0 {
                -0.01 + 0.005 * t
            } else if t < 6.0 {
                0.005 * (t - 2.0)
            } else if t < 8.0 {
                0.02
            } else {
                0.02 - 0.005 * (t - 8.0)
            };
            rows.push((t, z));
            t += 0.08;
        }
        let r = sinkage_regimes(&rows, &RegimeOptions::default());
        for (i, &(t, _)) in rows.iter().enumerate() {
            let want = if t < 2.0 - 1e-9 {
                SinkageRegime::Above
            } else if t < 2.0 + 0.08 {
                continue;
            } else if t < 6.0 - 0.08 {
                SinkageRegime::Loading
            } else if t > 6.0 + 0.08 && t < 8.0 + 0.16 {
                SinkageRegime::Unloading
            } else {
                continue;
            };
            assert_eq!(r[i], want, "t = {t}");
        }
        // Rising is never loading, nor moving down again within pressed depth.
        assert!(
            rows.iter()
                .zip(&r)
                .all(|(&(t, _), &g)| t < 8.2 || g != SinkageRegime::Loading)
        );
    }

    #[test]
    fn a_second_intrusion_after_leaving_the_medium_loads_again() {
        // Down to 20 mm, up to 10 mm above the surface and down again: the second descent loads
        // (fresh ground); up to 12 mm only and down again, it presses its own hole and does not.
        let path = |t: f64, leave: bool| {
            if t < 4.0 {
                -0.005 + 0.00625 * t
            } else if t < 8.0 {
                0.02 - if leave { 0.0075 } else { 0.002 } * (t - 4.0)
            } else {
                0.02 - if leave { 0.03 } else { 0.008 } + 0.005 * (t - 8.0)
            }
        };
        for leave in [true, false] {
            let rows: Vec<(f64, f64)> = (0..200)
                .map(|k| k as f64 * 0.08)
                .map(|t| (t, path(t, leave)))
                .collect();
            let r = sinkage_regimes(&rows, &RegimeOptions::default());
            let second = rows
                .iter()
                .zip(&r)
                .filter(|((t, z), _)| *t > 8.3 && *z > 0.001 && *z < 0.019)
                .map(|(_, g)| *g)
                .collect::<Vec<_>>();
            assert!(!second.is_empty());
            let want = if leave {
                SinkageRegime::Loading
            } else {
                SinkageRegime::Unloading
            };
            assert!(
                second.iter().all(|g| *g == want),
                "leave {leave}: {second:?}"
            );
        }
    }
}
