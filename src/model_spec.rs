//! A leg's force model from plain values, as a user names it: its kind, plate, medium (a preset
//! or custom soil values), fitting width and RFT coefficients. `terzaghi predict` and
//! `simulate`, and the Python package, build their models here, so that the same values give
//! the same model whichever face they come through.

use crate::model::medium as presets;
use crate::model::rft::RFT_SET_NAMES;
use crate::model::{
    FittingWidth, ForceModel, Medium, Plate, RftCoefficients, RftModel, TerzaghiModel,
};
use anyhow::{Context, Result, bail};

/// Which model to evaluate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ModelKind {
    /// The improved Terzaghi model, with the fitting width `b_e = b_k b a^(-beta)`.
    #[default]
    Improved,
    /// The conventional Terzaghi model (`b_e = b`).
    Conventional,
    /// Resistive force theory (Li, Zhang & Goldman 2013).
    Rft,
    /// A horizontal plate pushed straight down, by the plate-sinkage law of a medium file
    /// (`terzaghi calibrate` writes one): its depth is the hip's height below the surface.
    Sinkage,
}

impl ModelKind {
    /// The kind of that name: `improved`, `conventional`, `rft` or `sinkage`.
    pub fn by_name(name: &str) -> Result<ModelKind> {
        Ok(match name {
            "improved" => ModelKind::Improved,
            "conventional" => ModelKind::Conventional,
            "rft" => ModelKind::Rft,
            "sinkage" => ModelKind::Sinkage,
            other => bail!("model {other:?}: expected improved, conventional, rft or sinkage"),
        })
    }
}

/// The medium: a preset by name, or the three soil values.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MediumSpec {
    /// A preset's name (see `terzaghi media`).
    pub preset: Option<String>,
    /// Custom medium: unit weight (N/m^3).
    pub unit_weight_n_m3: Option<f64>,
    /// Custom medium: internal friction angle (deg).
    pub phi_deg: Option<f64>,
    /// Custom medium: plate-medium friction angle (deg).
    pub delta_deg: Option<f64>,
    /// A medium file (a plate-sinkage law calibrated from measurements), for the sinkage
    /// model.
    pub file: Option<std::path::PathBuf>,
}

/// A medium and the preset it came from, if any (whose identified fitting widths the improved
/// model may use).
#[derive(Debug, Clone, Copy)]
pub struct ChosenMedium {
    /// The soil values.
    pub medium: Medium,
    /// The preset, if the medium is one.
    pub preset: Option<&'static presets::MediumPreset>,
}

impl MediumSpec {
    /// The medium: the preset, or the three custom values (all of them, and no preset).
    pub fn medium(&self) -> Result<ChosenMedium> {
        if let Some(f) = &self.file {
            bail!(
                "the medium file {} is a plate-sinkage law: it predicts model sinkage (a plate pushed straight down), not a turning leg's soil values",
                f.display()
            );
        }
        let custom = [self.unit_weight_n_m3, self.phi_deg, self.delta_deg];
        match (&self.preset, custom) {
            (Some(name), [None, None, None]) => {
                let preset = presets::preset(name)?;
                Ok(ChosenMedium {
                    medium: preset.medium()?,
                    preset: Some(preset),
                })
            }
            (Some(name), _) => bail!(
                "medium {name:?} is a preset: give it or unit_weight_n_m3, phi_deg and delta_deg, not both"
            ),
            (None, [Some(w), Some(phi), Some(delta)]) => Ok(ChosenMedium {
                medium: Medium::new(w, phi, delta)?,
                preset: None,
            }),
            (None, [None, None, None]) => bail!(
                "no medium given: name a preset (one of {}) or give unit_weight_n_m3, phi_deg and delta_deg",
                presets::preset_names().join(", ")
            ),
            (None, _) => bail!(
                "a custom medium needs all of unit_weight_n_m3, phi_deg and delta_deg (got {:?}, {:?}, {:?})",
                self.unit_weight_n_m3,
                self.phi_deg,
                self.delta_deg
            ),
        }
    }
}

/// A plate that enters the medium somewhere in its turn.
pub fn plate(length_m: f64, width_m: f64, hip_height_m: f64) -> Result<Plate> {
    let plate = Plate::new(length_m, width_m, hip_height_m)?;
    if plate.never_submerged() {
        bail!(
            "hip height {hip_height_m} m >= length {length_m} m (--hip-height-m, --length-m): the plate never enters the medium (every force would be 0)"
        );
    }
    Ok(plate)
}

/// The improved model's fitting width: `b_k` and `a` given together, else the preset's
/// identified one for this plate's width.
pub fn fitting_width(
    b_k: Option<f64>,
    a: Option<f64>,
    chosen: &ChosenMedium,
    plate: &Plate,
) -> Result<FittingWidth> {
    match (b_k, a) {
        (Some(b_k), Some(a)) => return Ok(FittingWidth::new(b_k, a)?),
        (None, None) => {}
        _ => bail!("b_k and a (--bk, --a) go together: got b_k {b_k:?}, a {a:?}"),
    }
    let Some(preset) = chosen.preset else {
        bail!("the improved model needs b_k and a (--bk, --a) for a custom medium");
    };
    preset.fitting_width_for(plate.width_m()).with_context(|| {
        format!(
            "medium {} has identified b_k, a only for plate widths {} m, not {} m; give b_k and a (--bk, --a)",
            preset.name,
            preset.fitted_widths_m(),
            plate.width_m()
        )
    })
}

/// A Terzaghi model with a fitting width, or the conventional one without.
pub fn terzaghi_model(
    plate: Plate,
    chosen: &ChosenMedium,
    width: Option<FittingWidth>,
) -> TerzaghiModel {
    match width {
        Some(w) => TerzaghiModel::new(plate, chosen.medium, w),
        None => TerzaghiModel::conventional(plate, chosen.medium),
    }
}

/// A leg's shape: a flat plate, RHex's C-leg (an arc whose chord is the plate's length), or
/// any mid-line; RFT integrates the curved ones element by element.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum LegShape {
    /// A flat plate.
    #[default]
    Plate,
    /// An arc from the hip to the tip.
    CLeg {
        /// The arc's radius (m; default half the length: a half circle).
        radius_m: Option<f64>,
        /// The arc's span (deg; default 180).
        span_deg: Option<f64>,
    },
    /// A mid-line `[(s, q)]` in metres, from the hip: `s` along the chord toward the tip, `q`
    /// toward the travel (the node's `<leg>.shape: polyline` and `<leg>.profile`).
    Polyline {
        /// The points, hip side first.
        line: Vec<(f64, f64)>,
    },
    /// A rigid body about the hip, its hub (a wheel, a foot, a mesh): three-dimensional RFT
    /// over its surface ([`crate::model::BodyLeg`]).
    Body(Box<crate::model::Body>),
}

/// Segments of a C-leg's mid-line (the node's `<leg>.shape: c_leg`).
pub const C_LEG_SEGMENTS: usize = 32;

/// A C-leg's value that does not make an arc from the hip to the tip.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("C-leg {name} {value}: {why}")]
pub struct BadCLeg {
    /// The value's name: `radius_m` or `span_deg`.
    pub name: &'static str,
    /// The value.
    pub value: f64,
    /// Why it does not do.
    pub why: String,
}

/// A C-leg's mid-line, `[(s, q)]` from the hip along the chord and toward the travel, for a
/// chord of `length_m`: the arc of `radius_m` (default `length_m / 2`) over `span_deg`
/// (default 180). The error names the value that does not make one (`radius_m` or `span_deg`),
/// and why.
pub fn c_leg_line(
    length_m: f64,
    radius_m: Option<f64>,
    span_deg: Option<f64>,
) -> Result<Vec<(f64, f64)>, BadCLeg> {
    let radius = radius_m.unwrap_or(length_m / 2.0);
    let span_deg = span_deg.unwrap_or(180.0);
    if !(radius.is_finite() && radius > 0.0) {
        return Err(BadCLeg {
            name: "radius_m",
            value: radius,
            why: "must be > 0".into(),
        });
    }
    if !(span_deg > 0.0 && span_deg < 360.0) {
        return Err(BadCLeg {
            name: "span_deg",
            value: span_deg,
            why: "must lie in (0, 360)".into(),
        });
    }
    let chord = 2.0 * radius * (span_deg.to_radians() / 2.0).sin();
    if (chord - length_m).abs() > 0.01 * length_m {
        return Err(BadCLeg {
            name: "radius_m",
            value: radius,
            why: format!(
                "the arc's chord, 2 radius sin(span / 2) = {chord:.4} m, must be length_m ({length_m} m), the hip-to-tip distance"
            ),
        });
    }
    Ok(crate::model::c_leg_profile(
        radius,
        span_deg.to_radians(),
        C_LEG_SEGMENTS,
    ))
}

/// A leg's force model, as a user names it.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelSpec {
    /// Which model.
    pub kind: ModelKind,
    /// Plate length from the hip axis to the tip (m).
    pub length_m: f64,
    /// Plate width (m).
    pub width_m: f64,
    /// Height of the hip axis above the free surface (m).
    pub hip_height_m: f64,
    /// The medium.
    pub medium: MediumSpec,
    /// The improved model's `b_k` (with `a`; default: the preset's).
    pub b_k: Option<f64>,
    /// The improved model's `a` (with `b_k`).
    pub a: Option<f64>,
    /// RFT's coefficient set (`poppy_lp`, `poppy_cp`, `poppy_lp_grid`, `generic`; default: the
    /// medium preset's).
    pub rft_coeffs: Option<String>,
    /// RFT's scale factor for the generic coefficients (N/cm^3).
    pub rft_zeta: Option<f64>,
    /// RFT's elements over the submerged length.
    pub rft_elements: usize,
    /// The leg's shape (a C-leg needs the RFT model).
    pub shape: LegShape,
    /// Whether a planar leg (plate, C-leg, polyline) takes its medium file's bearing of
    /// sheared sand (a body always does).
    pub planar_sheared_bearing: bool,
}

impl ModelSpec {
    /// The RFT model of this leg's shape on `plate` with `coeffs`.
    fn rft_leg(&self, plate: Plate, coeffs: RftCoefficients) -> Result<RftModel> {
        Ok(match &self.shape {
            LegShape::Plate => RftModel::new(plate, coeffs, self.rft_elements)?,
            LegShape::CLeg { radius_m, span_deg } => {
                let line = c_leg_line(self.length_m, *radius_m, *span_deg)?;
                RftModel::with_profile(plate, coeffs, self.rft_elements, line)?
            }
            LegShape::Polyline { line } => {
                RftModel::with_profile(plate, coeffs, self.rft_elements, line.clone())?
            }
            LegShape::Body(_) => unreachable!("a body is no mid-line: rft_model builds it"),
        })
    }

    /// The RFT model of this leg's shape on `plate` in a medium of `coeffs` and its laws.
    fn rft_model(
        &self,
        plate: Plate,
        coeffs: RftCoefficients,
        depth_law: Option<crate::model::RftDepthLaw>,
        speed_law: Option<crate::model::RftSpeedLaw>,
        sheared: Option<crate::model::ShearedBearing>,
    ) -> Result<ForceModel> {
        Ok(match &self.shape {
            LegShape::Body(body) => ForceModel::Body(Box::new(
                crate::model::BodyLeg::new((**body).clone(), coeffs, depth_law, speed_law, plate)
                    .with_sheared_bearing(sheared),
            )),
            _ => ForceModel::Rft(
                self.rft_leg(plate, coeffs)?
                    .with_depth_law(depth_law)
                    .with_speed_law(speed_law)
                    .with_sheared_bearing(sheared.filter(|_| self.planar_sheared_bearing)),
            ),
        })
    }

    /// The model; every value that does not make one is refused by name.
    pub fn build(&self) -> Result<ForceModel> {
        if self.kind != ModelKind::Improved && (self.b_k.is_some() || self.a.is_some()) {
            bail!("b_k and a (--bk, --a) apply to the improved model only");
        }
        if self.kind != ModelKind::Rft && self.shape != LegShape::Plate {
            bail!(
                "a curved leg (C-leg, polyline) or a body (wheel, foot, mesh) is predicted by RFT only (model rft), not the {:?} model",
                self.kind
            );
        }
        if self.kind == ModelKind::Sinkage {
            let Some(file) = &self.medium.file else {
                bail!("model sinkage needs a medium file (terzaghi calibrate writes one)");
            };
            if self.medium.preset.is_some() || self.medium.unit_weight_n_m3.is_some() {
                bail!(
                    "model sinkage takes its medium from the medium file, not a preset or soil values"
                );
            }
            // The plate's own height is where it stands without a hip given; it sinks by the
            // hip's height below the surface of each prediction.
            let plate = Plate::new(self.length_m, self.width_m, self.hip_height_m.max(0.0))?;
            let (_, leg) = sinkage_leg(file, self.length_m, self.width_m, plate)?;
            return Ok(ForceModel::Sinkage(leg));
        }
        let plate = plate(self.length_m, self.width_m, self.hip_height_m)?;
        match self.kind {
            ModelKind::Improved | ModelKind::Conventional => {
                if self.medium.file.is_some() {
                    bail!(
                        "a medium file (a plate-sinkage law) serves the sinkage and RFT models; the Terzaghi models take a preset or soil values"
                    );
                }
                let chosen = self.medium.medium()?;
                let width = match self.kind {
                    ModelKind::Improved => Some(fitting_width(self.b_k, self.a, &chosen, &plate)?),
                    _ => None,
                };
                Ok(ForceModel::Terzaghi(terzaghi_model(plate, &chosen, width)))
            }
            ModelKind::Rft => {
                // A medium file gives the leg its law: a measured shape, or a set's shape with
                // the file's law in depth.
                if let Some(file) = &self.medium.file {
                    let medium = crate::medium_file::MediumFile::read(file)?;
                    let explicit = match &self.rft_coeffs {
                        Some(set) => {
                            Some((set.as_str(), RftCoefficients::by_name(set, self.rft_zeta)?))
                        }
                        None => None,
                    };
                    let law = medium
                        .rft_law(explicit)
                        .with_context(|| format!("{}", file.display()))?;
                    return self.rft_model(
                        plate,
                        law.coefficients,
                        Some(law.depth_law),
                        law.speed_law,
                        law.sheared,
                    );
                }
                let set = match (&self.rft_coeffs, &self.medium.preset) {
                    (Some(s), _) => s.clone(),
                    // A medium file's RFT law was calibrated against poppy_lp's stress.
                    (None, _) if self.medium.file.is_some() => crate::medium_file::RFT_SET.into(),
                    (None, Some(name)) => match presets::preset(name)?.rft {
                        Some(presets::RftSet::PoppyLp) => "poppy_lp".into(),
                        Some(presets::RftSet::PoppyCp) => "poppy_cp".into(),
                        None => bail!(
                            "medium {name} has no RFT coefficients; name a set (rft_coeffs, --rft-coeffs: {})",
                            RFT_SET_NAMES.join(", ")
                        ),
                    },
                    (None, None) => bail!(
                        "RFT needs a coefficient set (rft_coeffs, --rft-coeffs: {}) or a medium preset that has one",
                        RFT_SET_NAMES.join(", ")
                    ),
                };
                if set == "generic" && self.rft_zeta.is_none() {
                    bail!(
                        "the generic RFT coefficients need the medium's scale (rft_zeta, --rft-zeta, N/cm^3)"
                    );
                }
                let coeffs = RftCoefficients::by_name(&set, self.rft_zeta)?;
                self.rft_model(plate, coeffs, None, None, None)
            }
            ModelKind::Sinkage => unreachable!("built above"),
        }
    }
}

/// The sinkage leg of a medium file: a disc of diameter `width_m` when `length_m` equals it,
/// else a `width_m` x `length_m` rectangle, pressing by the file's law; `plate` is its
/// configured geometry. Returns the file too (what `terzaghi media` shows of it).
pub fn sinkage_leg(
    file: &std::path::Path,
    length_m: f64,
    width_m: f64,
    plate: Plate,
) -> Result<(
    crate::medium_file::MediumFile,
    crate::model::sinkage::SinkageLeg,
)> {
    use crate::model::sinkage::{PlateShape, SinkageLeg};
    let medium = crate::medium_file::MediumFile::read(file)?;
    let law = medium.model()?;
    let shape = if (length_m - width_m).abs() <= 1e-12 {
        PlateShape::disc(width_m)
    } else {
        PlateShape::rectangle(width_m, length_m)
    }?;
    Ok((medium, SinkageLeg::new(law, shape, plate)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> ModelSpec {
        ModelSpec {
            kind: ModelKind::Improved,
            length_m: 0.1,
            width_m: 0.025,
            hip_height_m: 0.0,
            medium: MediumSpec {
                preset: Some("poppy_lp".into()),
                ..Default::default()
            },
            b_k: None,
            a: None,
            rft_coeffs: None,
            rft_zeta: None,
            rft_elements: 100,
            shape: LegShape::Plate,
            planar_sheared_bearing: false,
        }
    }

    #[test]
    fn bad_values_are_refused_by_name() {
        let mut s = spec();
        s.hip_height_m = 0.2;
        let e = s.build().unwrap_err().to_string();
        assert!(
            e.contains("hip height 0.2 m") && e.contains("never enters"),
            "{e}"
        );
        let mut s = spec();
        s.b_k = Some(1.0);
        let e = s.build().unwrap_err().to_string();
        assert!(e.contains("go together"), "{e}");
        let mut s = spec();
        s.medium.phi_deg = Some(30.0);
        let e = s.build().unwrap_err().to_string();
        assert!(e.contains("is a preset"), "{e}");
        let mut s = spec();
        s.kind = ModelKind::Conventional;
        s.b_k = Some(1.0);
        s.a = Some(2.0);
        assert!(
            s.build()
                .unwrap_err()
                .to_string()
                .contains("improved model only")
        );
        assert!(ModelKind::by_name("improvd").is_err());
        let mut s = spec();
        s.shape = LegShape::CLeg {
            radius_m: Some(0.03),
            span_deg: None,
        };
        s.kind = ModelKind::Rft;
        let e = s.build().unwrap_err().to_string();
        assert!(e.contains("radius_m 0.03") && e.contains("chord"), "{e}");
    }
}
