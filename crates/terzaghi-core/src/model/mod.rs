//! Force models for a leg rotating about a hip axis through a granular medium: a flat plate,
//! and (by RFT) a leg of any profile in the plane of rotation, a C-leg say; and for a closed body
//! that carries a load, a wheel.
//!
//! - [`terzaghi`]: the improved Terzaghi model of Yang et al. (2020), Eqs. (1)–(25), with the
//!   fitting width of Eq. (11); the conventional model is the same with `b_e = b`.
//! - [`rft`]: resistive force theory (Li, Zhang & Goldman 2013), the reference users know, for
//!   a plate or over a leg's mid-line ([`RftModel::with_profile`], [`c_leg_profile`]).
//! - [`medium`]: soil values and the paper's identified fitting widths, as named presets.
//! - [`plate`]: the leg's geometry, the attack angle and the submerged length.
//! - [`sinkage`]: a horizontal plate pushed straight down (the plate-sinkage test): Terzaghi's
//!   footing, Bekker, Reece, RFT with a depth exponent, and a power law in depth and width.
//! - [`body`]: a closed body (a wheel, smooth or with grousers) by RFT on its leading elements
//!   in three dimensions, and the sinkage at which the sand bears its load.
//! - [`corrections`]: the corrected model: the improved model plus terms for what it leaves out
//!   (speed, added mass, surcharge, extraction, compaction, cohesion, surface level, and the F/T
//!   sensor's offset and lag), fitted by the diagnosis and evaluated by the node.
//!
//! Conventions (`docs/model.md`): `beta` is the attack angle in radians,
//! `x` points along the travel of the submerged tip, `z` up; drag is positive when the medium
//! pushes the plate along `-x`, lift positive up, hip torque positive when it resists the
//! rotation. [`HipMotion`] places a hip the robot's state gives (height, pitch, velocity).
//! Everything here is pure: no I/O, no clock.

pub mod batch;
pub mod body;
pub mod corrections;
pub mod medium;
pub mod plate;
pub mod rft;
pub mod sheared;
pub mod sinkage;
pub mod terzaghi;

pub use body::{
    Body, BodyForce, BodyLeg, Drive, Grousers, HubMotion, Steady, SteadyError, Stress, Triangle,
    box_triangles, place, state_at_sinkage, steady_sinkage,
};
pub use corrections::{CorrectedModel, CorrectedPrediction, Corrections, Effect};
pub use medium::{FittingWidth, Medium, MediumPreset, Provenance};
pub use plate::{Plate, wrap_beta_rad};
pub use rft::{
    MAX_PROFILE_POINTS, RftCoefficients, RftDepthLaw, RftFit, RftGrid, RftModel, RftSpeedFit,
    RftSpeedLaw, RftSpeedTable, c_leg_profile, check_profile, rft_leg, rft_leg_moving,
};
pub use sheared::ShearedBearing;
pub use terzaghi::{Terms, TerzaghiForce, TerzaghiModel};

use serde::Serialize;

/// A field of [`Plate::new`], as [`ModelError::BadPlate`] names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlateField {
    /// The plate's length (m).
    LengthM,
    /// The plate's width (m).
    WidthM,
    /// The hip's height above the surface (m).
    HipHeightM,
}

/// What went wrong with a model input; every variant names the bad value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelError {
    /// A plate's length, width or hip height that is no plate's: which one, and why.
    #[error("{problem}")]
    BadPlate {
        /// The field.
        field: PlateField,
        /// What is wrong with its value.
        problem: Box<ModelError>,
    },
    /// A value that is not a finite number.
    #[error("{name} must be a finite number, got {value}")]
    NotFinite {
        /// The value's name, with its unit.
        name: &'static str,
        /// The value given.
        value: f64,
    },
    /// A value that must be positive.
    #[error("{name} must be greater than 0, got {value}")]
    NotPositive {
        /// The value's name, with its unit.
        name: &'static str,
        /// The value given.
        value: f64,
    },
    /// A hip below the surface.
    #[error("hip height must be >= 0 m, got {value_m} m")]
    NegativeHipHeight {
        /// The height given (m).
        value_m: f64,
    },
    /// An angle outside the range the model takes.
    #[error("{name} must lie in {range} deg, got {value_deg} deg")]
    AngleOutOfRange {
        /// The angle's name.
        name: &'static str,
        /// The range it must lie in (deg).
        range: &'static str,
        /// The angle given (deg).
        value_deg: f64,
    },
    /// A medium preset that does not exist.
    #[error("unknown medium {name:?}; known media: {known}")]
    UnknownMedium {
        /// The name given.
        name: String,
        /// The presets there are.
        known: String,
    },
    /// A number of RFT elements out of range.
    #[error("RFT element count must be between 1 and {max}, got {value}")]
    RftElements {
        /// The count given.
        value: usize,
        /// The largest count taken.
        max: usize,
    },
    /// The Terzaghi model's failure surface grows beyond a finite force.
    #[error(
        "the model overflows at beta = {beta_deg} deg with phi = {phi_deg} deg (the failure surface grows as exp(3 theta tan phi)); use a smaller phi"
    )]
    Overflow {
        /// The attack angle (deg).
        beta_deg: f64,
        /// The medium's internal friction angle (deg).
        phi_deg: f64,
    },
    /// An RFT coefficient set that does not exist.
    #[error("unknown RFT coefficient set {name:?}; known: {known}")]
    UnknownRftSet {
        /// The name given.
        name: String,
        /// The sets there are.
        known: String,
    },
    /// A value outside the range the model takes.
    #[error("{what} must lie in {range}, got {value}")]
    OutOfRange {
        /// The value's name, with its unit.
        what: &'static str,
        /// The value given.
        value: f64,
        /// The range it must lie in.
        range: String,
    },
    /// A leg's mid-line that is no leg: too few or too many points, a segment of zero length,
    /// or segments that cross.
    #[error("leg profile: {problem}")]
    BadProfile {
        /// What is wrong with it.
        problem: String,
    },
    /// A body's outline or mesh that is no closed body (see [`body::Body::prism`] and
    /// [`body::Body::mesh`]).
    #[error("{problem}")]
    BadBody {
        /// What is wrong with it.
        problem: String,
    },
}

#[inline]
pub(crate) fn finite(name: &'static str, value: f64) -> Result<f64, ModelError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(ModelError::NotFinite { name, value })
    }
}

pub(crate) fn positive(name: &'static str, value: f64) -> Result<f64, ModelError> {
    if finite(name, value)? > 0.0 {
        Ok(value)
    } else {
        Err(ModelError::NotPositive { name, value })
    }
}

/// Which failure mechanism the prediction comes from, so that consumers can weigh it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Regime {
    /// Submerged length <= 0: every force is zero.
    #[default]
    OutOfMedium,
    /// `beta <= pi/2`: the regime the paper validates.
    Penetration,
    /// `pi/2 < beta < 3pi/4 + phi/2`: same equations, which the paper calls unreliable here.
    ExtractionSpiral,
    /// `beta >= 3pi/4 + phi/2`: the spiral sector is gone, Eqs. (23)–(25).
    ExtractionTriangle,
    /// `beta > pi/2` for a model without a failure surface (RFT).
    Extraction,
    /// A plate pushed straight down that holds still, is unloaded at constant depth, or rises
    /// ([`sinkage`]): the rig, not the medium's law, sets the force; the prediction is the
    /// law's at that depth, the most the medium bears there.
    Unloading,
}

impl Regime {
    /// Every regime, in the order of [`Regime::code`].
    pub const ALL: [Regime; 6] = [
        Regime::OutOfMedium,
        Regime::Penetration,
        Regime::ExtractionSpiral,
        Regime::ExtractionTriangle,
        Regime::Extraction,
        Regime::Unloading,
    ];

    /// The regime's name, as logs and CSV files write it.
    pub fn as_str(self) -> &'static str {
        match self {
            Regime::OutOfMedium => "out_of_medium",
            Regime::Penetration => "penetration",
            Regime::ExtractionSpiral => "extraction_spiral",
            Regime::ExtractionTriangle => "extraction_triangle",
            Regime::Extraction => "extraction",
            Regime::Unloading => "unloading",
        }
    }

    /// Small integer code, as carried in ROS messages (`0` out of medium ... `4` extraction, `5`
    /// unloading).
    pub fn code(self) -> u8 {
        self as u8
    }

    /// The regime a ROS message's code stands for; `None` for a code no regime has.
    pub fn from_code(code: u8) -> Option<Regime> {
        Regime::ALL.get(usize::from(code)).copied()
    }

    /// Whether the plate is coming out of the medium (any of the three extraction regimes).
    pub fn is_extraction(self) -> bool {
        matches!(
            self,
            Regime::ExtractionSpiral | Regime::ExtractionTriangle | Regime::Extraction
        )
    }
}

impl std::fmt::Display for Regime {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The prediction every model gives: what a controller consumes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Prediction {
    /// Attack angle after wrapping to `[0, 2pi)`.
    pub beta_rad: f64,
    /// Length of the plate below the surface (m).
    pub submerged_m: f64,
    /// Depth of the plate's tip below the surface (m).
    pub depth_m: f64,
    /// Force against the direction of travel, in the hip frame (N).
    pub drag_n: f64,
    /// Upward force, in the hip frame (N).
    pub lift_n: f64,
    /// Torque of the medium's force about the hip (N m).
    pub hip_torque_nm: f64,
    /// Horizontal force across the travel, along the hip frame's `y` (N). The hip frame is
    /// right-handed: `x` along the submerged tip's travel (the robot's backward), `z` up, so
    /// `y` is the robot's right. Zero for a leg moving in its own plane, and for the flat-plate
    /// models (planar by construction); RFT's legs and bodies feel it when the hip moves across
    /// ([`HipMotion::lateral_m_s`]).
    pub side_n: f64,
    /// The medium's moment about the hip frame's `x` axis, at the hip (N m).
    pub roll_moment_nm: f64,
    /// The medium's moment about the hip frame's `z` axis (up), at the hip (N m).
    pub yaw_moment_nm: f64,
    /// Which phase of the stroke the plate is in.
    pub regime: Regime,
}

impl Prediction {
    /// The prediction in a medium `scale` times as stiff: every force and moment times
    /// `scale`, the geometry and regime as they are (a learnt scale, a trial's band).
    pub fn scaled(self, scale: f64) -> Prediction {
        Prediction {
            drag_n: self.drag_n * scale,
            lift_n: self.lift_n * scale,
            hip_torque_nm: self.hip_torque_nm * scale,
            side_n: self.side_n * scale,
            roll_moment_nm: self.roll_moment_nm * scale,
            yaw_moment_nm: self.yaw_moment_nm * scale,
            ..self
        }
    }

    /// The whole wrench at the hip, in the order of the batch's outputs: drag, lift (N), hip
    /// torque (N m), side force (N), roll and yaw moments (N m).
    pub fn wrench(&self) -> [f64; 6] {
        [
            self.drag_n,
            self.lift_n,
            self.hip_torque_nm,
            self.side_n,
            self.roll_moment_nm,
            self.yaw_moment_nm,
        ]
    }
}

/// Which model to evaluate: the improved or conventional Terzaghi model, or RFT.
#[derive(Debug, Clone)]
pub enum ForceModel {
    /// The improved (or conventional) Terzaghi model of a flat plate.
    Terzaghi(TerzaghiModel),
    /// Resistive force theory over a leg's mid-line.
    Rft(RftModel),
    /// A horizontal plate pushed straight down, by a calibrated plate-sinkage law.
    Sinkage(sinkage::SinkageLeg),
    /// A closed body in three dimensions (a wheel), by RFT over its surface.
    Body(Box<body::BodyLeg>),
}

/// Where a leg's hip is and how it moves at one sample, as the robot's state tells it (the
/// configured plate is a hip at a fixed height that does not move).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct HipMotion {
    /// The hip axis's height above the surface (m).
    pub height_m: f64,
    /// The body's pitch, added to the joint's attack angle (rad; ROS's pitch, about the hip
    /// frame's y axis, positive nose down, which turns the leg the way its stroke does).
    pub pitch_rad: f64,
    /// The leg's rotation rate (rad/s, positive as the attack angle grows).
    pub omega_rad_s: f64,
    /// The hip's velocity along the robot's forward, horizontal (m/s).
    pub forward_m_s: f64,
    /// The hip's vertical velocity, up (m/s).
    pub up_m_s: f64,
    /// Where the hip is along the robot's forward, horizontal, in the world frame (m): where
    /// on the ground the leg strokes (0 where the robot's state does not tell).
    pub forward_position_m: f64,
    /// The hip's horizontal velocity across the robot's forward, toward its left (m/s; ROS's
    /// `y` of the body): a robot crabbing or turning, a leg yawed to its travel. The flat-plate
    /// models ignore it; RFT's legs and bodies feel a side force from it.
    pub lateral_m_s: f64,
}

impl HipMotion {
    /// A hip at `height_m` that does not move, on a level body.
    pub fn still(height_m: f64) -> HipMotion {
        HipMotion {
            height_m,
            ..HipMotion::default()
        }
    }

    /// The hip's velocity in the leg's frame, `[x, z]`: x along the submerged tip's travel, the
    /// robot's backward.
    pub fn leg_frame_velocity_m_s(&self) -> [f64; 2] {
        [-self.forward_m_s, self.up_m_s]
    }

    /// The hip's velocity along the leg frame's `y` (m/s): the robot's right, since `x` is its
    /// backward and `z` up.
    pub fn leg_frame_lateral_m_s(&self) -> f64 {
        -self.lateral_m_s
    }
}

impl ForceModel {
    /// The prediction at attack angle `beta_rad`, the hip at the configured height.
    pub fn predict(&self, beta_rad: f64) -> Result<Prediction, ModelError> {
        match self {
            ForceModel::Terzaghi(m) => m.evaluate(beta_rad).map(|f| f.prediction()),
            ForceModel::Rft(m) => m.evaluate(beta_rad),
            ForceModel::Sinkage(m) => {
                m.predict(beta_rad, &HipMotion::still(m.plate().hip_height_m()))
            }
            ForceModel::Body(m) => m.predict(beta_rad, &HipMotion::still(m.plate().hip_height_m())),
        }
    }

    /// The prediction with the hip where the robot's state puts it: the flat-plate model at
    /// `hip.height_m` and the attack angle shifted by the body's pitch (it is quasi-static: the
    /// hip's velocity does not enter it); RFT with each element's own velocity as well.
    #[inline]
    pub fn predict_moving(&self, beta_rad: f64, hip: &HipMotion) -> Result<Prediction, ModelError> {
        match self {
            ForceModel::Terzaghi(m) => m
                .evaluate_at_height(
                    finite("attack angle beta (rad)", beta_rad)? + hip.pitch_rad,
                    hip.height_m,
                )
                .map(|f| f.prediction()),
            ForceModel::Rft(m) => m.evaluate_moving(beta_rad, hip),
            ForceModel::Sinkage(m) => m.predict(beta_rad, hip),
            ForceModel::Body(m) => m.predict(beta_rad, hip),
        }
    }

    /// RFT's speed law, where the model is RFT with one.
    pub fn rft_speed_law(&self) -> Option<&RftSpeedLaw> {
        match self {
            ForceModel::Terzaghi(_) | ForceModel::Sinkage(_) => None,
            ForceModel::Rft(m) => m.speed_law(),
            ForceModel::Body(m) => m.speed_law(),
        }
    }

    /// The plate (for a curved leg, its chord's) and hip height the model is for.
    pub fn plate(&self) -> &Plate {
        match self {
            ForceModel::Terzaghi(m) => m.plate(),
            ForceModel::Rft(m) => m.plate(),
            ForceModel::Sinkage(m) => m.plate(),
            ForceModel::Body(m) => m.plate(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Regime;

    #[test]
    fn a_regime_code_reads_back_as_its_regime() {
        for r in Regime::ALL {
            assert_eq!(Regime::from_code(r.code()), Some(r));
        }
        assert_eq!(Regime::from_code(Regime::ALL.len() as u8), None);
    }
}
