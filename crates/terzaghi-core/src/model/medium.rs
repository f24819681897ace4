//! Granular media: soil values for the Terzaghi model and the paper's identified fitting widths.

use super::{ModelError, finite, positive};
use serde::Serialize;

/// Soil values of a granular medium, as the Terzaghi model needs them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Medium {
    unit_weight_n_m3: f64,
    phi_rad: f64,
    delta_rad: f64,
}

/// The least internal friction angle a medium takes (deg).
pub const MIN_PHI_DEG: f64 = 0.001;

impl Medium {
    /// `unit_weight_n_m3` (`lambda`, N/m^3) > 0; internal friction `phi` in [0.001, 90) deg;
    /// plate–medium friction `delta` in [0, 90) deg.
    ///
    /// ```
    /// use terzaghi_core::model::Medium;
    /// assert!(Medium::new(16170.0, 32.0, 19.0).is_ok());
    /// assert!(Medium::new(16170.0, 95.0, 19.0).unwrap_err().to_string().contains("95"));
    /// ```
    pub fn new(unit_weight_n_m3: f64, phi_deg: f64, delta_deg: f64) -> Result<Self, ModelError> {
        positive("unit weight (N/m^3)", unit_weight_n_m3)?;
        let phi = finite("internal friction angle phi (deg)", phi_deg)?;
        // Below a thousandth of a degree the log spiral's 1 / (4 tan phi) runs out of floating
        // point (at 1e-308 deg it is infinite, and a term of the force NaN); no granular medium
        // is near it.
        if !(MIN_PHI_DEG..90.0).contains(&phi) {
            return Err(ModelError::AngleOutOfRange {
                name: "internal friction angle phi",
                range: "[0.001, 90)",
                value_deg: phi,
            });
        }
        let delta = finite("plate friction angle delta (deg)", delta_deg)?;
        if !(0.0..90.0).contains(&delta) {
            return Err(ModelError::AngleOutOfRange {
                name: "plate friction angle delta",
                range: "[0, 90)",
                value_deg: delta,
            });
        }
        Ok(Medium {
            unit_weight_n_m3,
            phi_rad: phi.to_radians(),
            delta_rad: delta.to_radians(),
        })
    }

    /// The medium's unit weight (N/m^3).
    pub fn unit_weight_n_m3(&self) -> f64 {
        self.unit_weight_n_m3
    }
    /// The internal friction angle `phi` (rad).
    pub fn phi_rad(&self) -> f64 {
        self.phi_rad
    }
    /// The soil–plate friction angle `delta` (rad).
    pub fn delta_rad(&self) -> f64 {
        self.delta_rad
    }
    /// The internal friction angle `phi` (deg).
    pub fn phi_deg(&self) -> f64 {
        self.phi_rad.to_degrees()
    }
    /// The soil–plate friction angle `delta` (deg).
    pub fn delta_deg(&self) -> f64 {
        self.delta_rad.to_degrees()
    }

    /// The same medium with another plate friction angle (validated like [`Medium::new`]).
    pub fn with_delta_deg(&self, delta_deg: f64) -> Result<Self, ModelError> {
        Medium::new(self.unit_weight_n_m3, self.phi_deg(), delta_deg)
    }
}

/// The fitting width of Eq. (11), `b_e = b_k b a^(-beta)` (`beta` in rad). `b_k = a = 1` is the
/// conventional model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FittingWidth {
    b_k: f64,
    a: f64,
}

impl FittingWidth {
    /// The conventional model: `b_e = b`.
    pub const CONVENTIONAL: FittingWidth = FittingWidth { b_k: 1.0, a: 1.0 };

    /// `b_k > 0` and `a > 0`, both finite.
    pub fn new(b_k: f64, a: f64) -> Result<Self, ModelError> {
        positive("b_k", b_k)?;
        positive("a", a)?;
        Ok(FittingWidth { b_k, a })
    }
    /// The coefficient `b_k`.
    pub fn b_k(&self) -> f64 {
        self.b_k
    }
    /// The exponent base `a`.
    pub fn a(&self) -> f64 {
        self.a
    }
    /// `b_e / b = b_k a^(-beta)`.
    ///
    /// ```
    /// use terzaghi_core::model::FittingWidth;
    /// let w = FittingWidth::new(2.0, 1.5).unwrap();
    /// assert!((w.factor(1.0) - 2.0 / 1.5).abs() < 1e-12);
    /// ```
    pub fn factor(&self, beta_rad: f64) -> f64 {
        self.b_k * (-beta_rad * self.a.ln()).exp()
    }
}

/// Where a preset's soil values come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Provenance {
    /// Given in the source.
    Measured,
    /// Some values given in the source, the others assumed (the note says which).
    PartlyMeasured,
    /// Approximated from the literature (the note says how).
    Approximated,
}

/// Which RFT coefficients describe a preset's medium.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RftSet {
    /// Loosely packed poppy seeds (Li, Zhang and Goldman).
    PoppyLp,
    /// Closely packed poppy seeds.
    PoppyCp,
}

/// A named medium with its provenance.
#[derive(Debug, Clone, Serialize)]
pub struct MediumPreset {
    /// The name a user gives (`medium: NAME`).
    pub name: &'static str,
    /// What the medium is.
    pub description: &'static str,
    /// Unit weight (N/m^3).
    pub unit_weight_n_m3: f64,
    /// Internal friction angle (deg).
    pub phi_deg: f64,
    /// Soil–plate friction angle (deg).
    pub delta_deg: f64,
    /// Where the soil values come from: measured, or approximated from the literature.
    pub soil_values: Provenance,
    /// Where the values come from, in words.
    pub note: &'static str,
    /// Identified `(b_k, a)` valid for any plate width (Table 3), if any.
    pub fit: Option<(f64, f64)>,
    /// Identified `(width_m, b_k, a)` per plate width (Table 1), used when the width matches.
    pub fits_by_width: &'static [(f64, f64, f64)],
    /// RFT coefficients measured in the same medium, if any.
    pub rft: Option<RftSet>,
}

/// Grain unit weight `rho_s g omega_f` (Eq. 27) with `g = 9.8` N/kg as in the paper.
const fn unit_weight(grain_density_kg_m3: f64, volume_fraction: f64) -> f64 {
    grain_density_kg_m3 * 9.8 * volume_fraction
}

const APPROX_NOTE_POPPY: &str = "Table 2 of the paper is lost: unit weight = rho_s g omega_f (Eq. 27) \
with grain density 1100 kg/m^3 and the packing fraction of Li et al.; phi from the angle of repose; \
delta from mu = 0.27 for aluminium (Section 4.3). Approximations; b_k, a from Table 3.";
const APPROX_NOTE_GLASS: &str = "Table 2 of the paper is lost: unit weight = rho_s g omega_f (Eq. 27) \
with glass density 2500 kg/m^3 and the packing fraction of Li et al.; phi from the angle of repose; \
delta about 20 deg for glass (Section 4.3). Approximations; b_k, a from Table 3.";

static PRESETS: [MediumPreset; 6] = [
    MediumPreset {
        name: "hit_sand",
        description: "the paper's test sand (Section 4.1)",
        unit_weight_n_m3: 16170.0,
        phi_deg: 32.0,
        delta_deg: 19.0,
        soil_values: Provenance::PartlyMeasured,
        note: "unit weight 16170 N/m^3 and delta 19 deg measured (Section 4.1); phi = 32 deg is an \
assumption (the paper does not give it). b_k, a from Table 1 for plate widths 20-100 mm.",
        fit: None,
        fits_by_width: &[
            (0.020, 0.24, 0.26),
            (0.040, 4.45, 1.61),
            (0.060, 22.40, 7.78),
            (0.080, 11.06, 5.31),
            (0.100, 6.66, 3.58),
        ],
        rft: None,
    },
    MediumPreset {
        name: "poppy_lp",
        description: "loosely packed poppy seeds (Li et al.)",
        unit_weight_n_m3: unit_weight(1100.0, 0.58),
        phi_deg: 25.0,
        delta_deg: 15.0,
        soil_values: Provenance::Approximated,
        note: APPROX_NOTE_POPPY,
        fit: Some((32.61, 2.30)),
        fits_by_width: &[],
        rft: Some(RftSet::PoppyLp),
    },
    MediumPreset {
        name: "poppy_cp",
        description: "closely packed poppy seeds (Li et al.)",
        unit_weight_n_m3: unit_weight(1100.0, 0.62),
        phi_deg: 28.0,
        delta_deg: 15.0,
        soil_values: Provenance::Approximated,
        note: APPROX_NOTE_POPPY,
        fit: Some((186.1, 4.50)),
        fits_by_width: &[],
        rft: Some(RftSet::PoppyCp),
    },
    MediumPreset {
        name: "glass_beads_lp",
        description: "loosely packed glass beads, 0.3 mm (Li et al.)",
        unit_weight_n_m3: unit_weight(2500.0, 0.58),
        phi_deg: 22.0,
        delta_deg: 20.0,
        soil_values: Provenance::Approximated,
        note: APPROX_NOTE_GLASS,
        fit: Some((3.46, 1.42)),
        fits_by_width: &[],
        rft: None,
    },
    MediumPreset {
        name: "glass_beads_cp",
        description: "closely packed glass beads, 0.3 mm (Li et al.)",
        unit_weight_n_m3: unit_weight(2500.0, 0.62),
        phi_deg: 25.0,
        delta_deg: 20.0,
        soil_values: Provenance::Approximated,
        note: APPROX_NOTE_GLASS,
        fit: Some((20.81, 2.45)),
        fits_by_width: &[],
        rft: None,
    },
    MediumPreset {
        name: "glass_spheres_cp",
        description: "closely packed glass spheres, 3 mm (Li et al.)",
        unit_weight_n_m3: unit_weight(2500.0, 0.62),
        phi_deg: 22.0,
        delta_deg: 20.0,
        soil_values: Provenance::Approximated,
        note: APPROX_NOTE_GLASS,
        fit: Some((1.50, 1.37)),
        fits_by_width: &[],
        rft: None,
    },
];

/// Every preset, in a fixed order.
pub fn presets() -> &'static [MediumPreset] {
    &PRESETS
}

/// The preset called `name`, or an error that lists the known names.
pub fn preset(name: &str) -> Result<&'static MediumPreset, ModelError> {
    PRESETS
        .iter()
        .find(|p| p.name == name)
        .ok_or_else(|| ModelError::UnknownMedium {
            name: name.to_string(),
            known: preset_names().join(", "),
        })
}

/// The presets' names.
pub fn preset_names() -> Vec<&'static str> {
    PRESETS.iter().map(|p| p.name).collect()
}

impl MediumPreset {
    /// The preset's medium constants.
    pub fn medium(&self) -> Result<Medium, ModelError> {
        Medium::new(self.unit_weight_n_m3, self.phi_deg, self.delta_deg)
    }

    /// The identified fitting width for a plate of `width_m`: Table 3's single fit, or the
    /// Table 1 entry whose width is within 1 mm; `None` when the source has none.
    pub fn fitting_width_for(&self, width_m: f64) -> Option<FittingWidth> {
        let (b_k, a) = self.fit.or_else(|| {
            self.fits_by_width
                .iter()
                .find(|(w, _, _)| (w - width_m).abs() <= 1e-3)
                .map(|&(_, b_k, a)| (b_k, a))
        })?;
        FittingWidth::new(b_k, a).ok()
    }

    /// The plate widths (m) that have a fit of their own, as a list for a message.
    pub fn fitted_widths_m(&self) -> String {
        self.fits_by_width
            .iter()
            .map(|w| w.0.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_preset_is_valid_and_has_a_fit_or_says_why_not() {
        for p in presets() {
            p.medium().unwrap();
            assert!(p.fit.is_some() || !p.fits_by_width.is_empty(), "{}", p.name);
            assert!(!p.note.is_empty());
        }
    }

    #[test]
    fn unknown_medium_names_the_known_ones() {
        let e = preset("mud").unwrap_err().to_string();
        assert!(e.contains("mud") && e.contains("poppy_lp"), "{e}");
    }

    #[test]
    fn hit_sand_fit_follows_plate_width() {
        let p = preset("hit_sand").unwrap();
        assert_eq!(p.fitting_width_for(0.06).unwrap().b_k(), 22.40);
        assert!(p.fitting_width_for(0.07).is_none());
        assert_eq!(
            preset("poppy_lp")
                .unwrap()
                .fitting_width_for(0.5)
                .unwrap()
                .a(),
            2.30
        );
    }

    #[test]
    fn rejects_bad_fitting_width_and_friction() {
        assert!(FittingWidth::new(0.0, 1.0).is_err());
        assert!(FittingWidth::new(1.0, -1.0).is_err());
        assert!(FittingWidth::new(f64::INFINITY, 1.0).is_err());
        assert!(Medium::new(16170.0, 0.0, 19.0).is_err());
        // A friction angle so small that the log spiral's 1 / (4 tan phi) is infinite (found
        // by tests/properties.rs: a term of the force came out NaN), refused by name.
        let e = Medium::new(16170.0, 1.4e-308, 19.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("phi") && e.contains("[0.001, 90)"), "{e}");
        assert!(Medium::new(16170.0, MIN_PHI_DEG, 19.0).is_ok());
        assert!(Medium::new(16170.0, 32.0, 90.0).is_err());
        assert!(Medium::new(16170.0, 32.0, -1.0).is_err());
        assert!(Medium::new(0.0, 32.0, 19.0).is_err());
        assert!(Medium::new(16170.0, 32.0, 0.0).is_ok());
    }
}
