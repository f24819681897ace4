//! Medium files: a plate-sinkage law calibrated from measurements (`terzaghi calibrate` writes
//! them), with where each value came from; `terzaghi media` lists them and a leg of `model:
//! sinkage` or `model: rft` names one as its `<leg>.medium`. Calibrated from intrusion tests
//! in any direction, a file also carries RFT's angular shape, its law in depth and its speed
//! law ([`MediumRftShape`]), which every RFT leg naming the file uses; a file without them
//! lends an RFT leg its depth law on `poppy_lp`'s shape, and says the shape is a preset's.

use crate::ident::rft_shape::{RftShapeFit, ShapeForm};
use crate::ident::sinkage::SinkageFit;
use crate::model::sinkage::{SinkageLaw, SinkageModel};
use crate::model::{RftCoefficients, RftDepthLaw, RftFit, RftSpeedLaw};
use anyhow::{Context, Result, bail};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The RFT coefficient set a medium file's `rft_alpha_z_n_cm3` is taken from (calibration), and
/// the one an RFT leg naming the file uses unless it names another.
pub const RFT_SET: &str = "poppy_lp";

/// A medium file: a sinkage law with its values, and where each came from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MediumFile {
    /// The medium's name.
    pub name: String,
    /// The law.
    pub law: SinkageLaw,
    /// Its parameters by name.
    pub params: std::collections::BTreeMap<String, f64>,
    /// Their standard deviations by name.
    pub std_dev: std::collections::BTreeMap<String, f64>,
    /// The unit weight (N/m^3).
    pub unit_weight_n_m3: f64,
    /// RFT's `alpha_z` for a plate moving down that the RFT law scales (N/cm^3).
    pub rft_alpha_z_n_cm3: f64,
    /// Where the values came from.
    pub source: MediumSource,
    /// RFT's shape measured from intrusion tests, where the file was calibrated on any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rft_shape: Option<MediumRftShape>,
    /// The bearing of the sand a body shears, where the file has it (`terzaghi calibrate
    /// --slip-sweep`); without it, RFT's stress of sand at rest alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sheared_bearing: Option<MediumShearedBearing>,
    /// The sand's scatter from trial to trial, where its plate tests tell it (three or more):
    /// the band `--band` gives.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scatter: Option<MediumScatter>,
}

/// The bearing of the sand a body shears ([`crate::model::ShearedBearing`]), with where its
/// values came from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumShearedBearing {
    /// `tan delta_w`: the inclination's tangent up to which the sand bears fully.
    pub interface_tan: f64,
    /// `m`: the power of the loss past it.
    pub exponent: f64,
    /// Their standard deviations (jackknife over the sweep's runs; 0 for the physics alone).
    pub std_dev: BTreeMap<String, f64>,
    /// Where the values came from, in words.
    pub source: String,
    /// The slip sweep they were fitted to, where they were.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slip_sweep: Option<MediumSlipSweep>,
}

/// A slip sweep a medium file's sheared bearing was fitted to.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumSlipSweep {
    /// Its file.
    pub file: String,
    /// Its body, as `calibrate`'s flags gave it.
    pub body: String,
    /// Its runs.
    pub runs: usize,
    /// R^2 of the sinkage and the drawbar over them, with the fitted values.
    pub r2_sinkage: f64,
    /// See [`Self::r2_sinkage`].
    pub r2_drawbar: f64,
    /// The same with RFT's sand at rest alone (nothing from the sweep).
    pub r2_sinkage_at_rest: f64,
    /// See [`Self::r2_sinkage_at_rest`].
    pub r2_drawbar_at_rest: f64,
}

impl MediumShearedBearing {
    /// The law, checked: each value within its physical range, else an error naming it.
    pub fn bearing(&self) -> Result<crate::model::ShearedBearing> {
        Ok(crate::model::ShearedBearing::new(
            self.interface_tan,
            self.exponent,
        )?)
    }

    /// In words, for `media` and the node's start-up line.
    pub fn text(&self) -> String {
        let sd = |k: &str| {
            self.std_dev
                .get(k)
                .filter(|v| **v > 0.0)
                .map_or(String::new(), |v| format!(" +- {v:.3}"))
        };
        format!(
            "sheared sand bears (tan delta_w / tan delta)^m past tan delta_w {:.3}{}, m {:.2}{} ({})",
            self.interface_tan,
            sd("interface_tan"),
            self.exponent,
            sd("exponent"),
            self.source
        )
    }
}

/// RFT's angular shape, law in depth and speed law, fitted to intrusion tests
/// ([`crate::ident::rft_shape`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumRftShape {
    /// `li_nine` (the nine coefficients free) or `preset_scaled` (a preset's shape times one
    /// scale: the tests did not tell the nine apart).
    pub form: ShapeForm,
    /// Why the reduced form, where it is.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reduced_because: Option<String>,
    /// Li, Zhang and Goldman's coefficients by name (`A00`, `A10`, `B11`, `B01`, `B-11`,
    /// `C11`, `C01`, `C-11`, `D10`), N/cm^3: the stress per depth at 1 cm.
    pub coefficients_n_cm3: BTreeMap<String, f64>,
    /// Their standard deviations (jackknife over tests).
    pub std_dev_n_cm3: BTreeMap<String, f64>,
    /// The exponent `n` of the law in depth: an element at depth `z` feels the stress at
    /// `1 cm (z / 1 cm)^n`.
    pub depth_exponent: f64,
    /// Its standard deviation.
    pub std_depth_exponent: f64,
    /// The law's surface offset (m): the stress at depth `z` is that at `z` plus it (a bed of
    /// coarse grains bears a plate from its first millimetre).
    #[serde(default)]
    pub surface_offset_m: f64,
    /// Its standard deviation (m).
    #[serde(default)]
    pub std_surface_offset_m: f64,
    /// The speed of the tests the shape was fitted to (m/s).
    pub reference_speed_m_s: f64,
    /// R^2 of the horizontal and vertical force over the rows fitted.
    pub r2_fx: f64,
    /// See [`Self::r2_fx`].
    pub r2_fz: f64,
    /// The speed law, where tests ran at two or more speeds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_law: Option<MediumSpeedLaw>,
    /// The tests.
    pub tests: Vec<MediumIntrusionTest>,
    /// Where the shape was borrowed from, where it was (`terzaghi calibrate --shape-from`):
    /// another medium file's shape, scaled to this file's plate-sinkage law. Its tests are that
    /// medium's, not this one's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub borrowed_from: Option<String>,
}

/// RFT's speed law of a medium file: an element moving at `v` above `ref_speed_m_s` is as if
/// `k (v - ref_speed_m_s)` deeper, `k` per direction of motion.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumSpeedLaw {
    /// The calibration's speed (m/s).
    pub ref_speed_m_s: f64,
    /// The fastest speed measured (m/s): the law is not extrapolated past it.
    pub max_speed_m_s: f64,
    /// `k` (s) per direction (deg below the horizontal; negative: up).
    pub gains: Vec<MediumSpeedGain>,
    /// The share of the force's change with speed the law explains.
    pub explained: f64,
}

/// One direction's gain of a [`MediumSpeedLaw`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumSpeedGain {
    /// The direction of motion below the horizontal (deg).
    pub direction_deg: f64,
    /// The depth the dynamic stress is worth per m/s (s).
    pub depth_per_speed_s: f64,
    /// Its standard deviation (s; jackknife over the faster tests).
    #[serde(default = "nan")]
    pub std_depth_per_speed_s: f64,
}

fn nan() -> f64 {
    f64::NAN
}

/// An intrusion test a medium file's shape was fitted to.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumIntrusionTest {
    /// Its file.
    pub file: String,
    /// Its plate's chord angle (deg).
    pub chord_angle_deg: f64,
    /// Its direction of motion below the horizontal (deg; negative: up).
    pub direction_deg: f64,
    /// Its speed (m/s).
    pub speed_m_s: f64,
    /// Rows fitted (0: a faster test, for the speed law).
    pub rows_fitted: usize,
    /// Its measured `alpha_x`, `alpha_z` (N/cm^3).
    pub alpha_x_n_cm3: f64,
    /// See [`Self::alpha_x_n_cm3`].
    pub alpha_z_n_cm3: f64,
}

/// The names of Li's nine coefficients, in [`RftFit`]'s order.
pub const RFT_COEFFICIENT_NAMES: [&str; 9] = [
    "A00", "A10", "B11", "B01", "B-11", "C11", "C01", "C-11", "D10",
];

/// What an RFT leg takes from a medium file: the coefficients, the law in depth and the speed
/// law, and whether the shape was measured.
#[derive(Debug, Clone, PartialEq)]
pub struct RftLaw {
    /// The coefficients.
    pub coefficients: RftCoefficients,
    /// The law in depth.
    pub depth_law: RftDepthLaw,
    /// The speed law, where the file has one.
    pub speed_law: Option<RftSpeedLaw>,
    /// The shape was fitted, coefficient by coefficient, to intrusion tests in several
    /// directions (not a preset's).
    pub shape_measured: bool,
    /// The bearing of the sand a body shears, where the file has it.
    pub sheared: Option<crate::model::ShearedBearing>,
}

impl RftLaw {
    /// The law in sand `scale` times as stiff: every stress at a depth times `scale` (the
    /// band's ends, [`MediumFile::band`]).
    pub fn scaled(&self, scale: f64) -> RftLaw {
        let mut law = self.clone();
        law.depth_law.scale *= scale;
        law
    }
}

impl MediumRftShape {
    /// The shape of a fit, its tests' files in the order of `fit.tests`.
    pub fn of_fit(fit: &RftShapeFit, files: &[PathBuf]) -> MediumRftShape {
        let named = |f: &RftFit| {
            RFT_COEFFICIENT_NAMES
                .iter()
                .zip(f.to_array())
                .map(|(n, v)| (n.to_string(), v))
                .collect()
        };
        MediumRftShape {
            form: fit.form,
            reduced_because: fit.reduced_because.clone(),
            coefficients_n_cm3: named(&fit.coefficients),
            std_dev_n_cm3: named(&fit.std_dev),
            depth_exponent: fit.depth_exponent,
            std_depth_exponent: fit.depth_exponent_std,
            surface_offset_m: fit.surface_offset_m,
            std_surface_offset_m: fit.surface_offset_std_m,
            reference_speed_m_s: fit.reference_speed_m_s,
            r2_fx: fit.r2[0],
            r2_fz: fit.r2[1],
            speed_law: fit.speed.as_ref().map(|s| MediumSpeedLaw {
                ref_speed_m_s: s.law.ref_speed_m_s,
                max_speed_m_s: s.law.max_speed_m_s,
                gains: s
                    .law
                    .gains()
                    .iter()
                    .enumerate()
                    .map(|(i, &(g, k))| MediumSpeedGain {
                        direction_deg: g.to_degrees() + 0.0,
                        depth_per_speed_s: k,
                        std_depth_per_speed_s: fit
                            .speed_gain_std_s
                            .get(i)
                            .copied()
                            .unwrap_or(f64::NAN),
                    })
                    .collect(),
                explained: s.explained,
            }),
            tests: fit
                .tests
                .iter()
                .zip(files)
                .map(|(t, f)| MediumIntrusionTest {
                    file: f.display().to_string(),
                    chord_angle_deg: t.chord_angle_deg,
                    direction_deg: t.direction_deg,
                    speed_m_s: t.speed_m_s,
                    rows_fitted: t.rows_fitted,
                    alpha_x_n_cm3: t.measured_alpha_n_cm3[0],
                    alpha_z_n_cm3: t.measured_alpha_n_cm3[1],
                })
                .collect(),
            borrowed_from: None,
        }
    }

    /// The coefficients, checked: each of the nine present and finite, no other.
    pub fn coefficients(&self) -> Result<RftFit> {
        let mut v = [0.0; 9];
        for (slot, name) in v.iter_mut().zip(RFT_COEFFICIENT_NAMES) {
            let x = *self.coefficients_n_cm3.get(name).with_context(|| {
                format!(
                    "rft_shape.coefficients_n_cm3 lacks {name} (it holds {})",
                    RFT_COEFFICIENT_NAMES.join(", ")
                )
            })?;
            if !x.is_finite() {
                bail!("rft_shape.coefficients_n_cm3.{name} is {x}: it must be finite");
            }
            *slot = x;
        }
        if let Some(extra) = self
            .coefficients_n_cm3
            .keys()
            .find(|k| !RFT_COEFFICIENT_NAMES.contains(&k.as_str()))
        {
            bail!(
                "rft_shape.coefficients_n_cm3 has no coefficient {extra:?} (its coefficients: {})",
                RFT_COEFFICIENT_NAMES.join(", ")
            );
        }
        let f = RftFit::from_array(v);
        let down = f.alpha(0.0, std::f64::consts::FRAC_PI_2).1;
        if down.is_nan() || down <= 0.0 {
            bail!(
                "rft_shape's coefficients give {down} N/cm^3 for a plate pushed straight down: a medium's must be > 0"
            );
        }
        Ok(f)
    }

    /// The speed law, checked, where there is one.
    pub fn speed_law(&self) -> Result<Option<RftSpeedLaw>> {
        let Some(s) = &self.speed_law else {
            return Ok(None);
        };
        let gains: Vec<(f64, f64)> = s
            .gains
            .iter()
            .map(|g| (g.direction_deg.to_radians(), g.depth_per_speed_s))
            .collect();
        Ok(Some(
            RftSpeedLaw::by_direction(s.ref_speed_m_s, &gains, s.max_speed_m_s)
                .context("rft_shape.speed_law")?,
        ))
    }

    /// The law in depth, checked.
    pub fn depth_law(&self) -> Result<RftDepthLaw> {
        RftDepthLaw::new(1.0, self.depth_exponent)
            .context("rft_shape.depth_exponent")?
            .with_offset(self.surface_offset_m)
            .context("rft_shape.surface_offset_m")
    }
}

/// Where a medium file's values came from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MediumSource {
    /// The command that wrote the file.
    pub command: String,
    /// Where the unit weight came from.
    pub unit_weight: String,
    /// The depth column of the tests.
    pub depth_column: String,
    /// R^2 of the force over every test's loaded rows together.
    pub r2: f64,
    /// Each test, with its own R^2 and RMSE under the fitted law.
    pub tests: Vec<MediumSourceTest>,
}

/// A test a medium file was calibrated on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MediumSourceTest {
    /// Its file.
    pub file: String,
    /// Its plate.
    pub plate: String,
    /// Loaded rows used.
    pub loaded_rows: usize,
    /// R^2 of its force.
    pub r2: f64,
    /// RMSE of its force (N).
    pub rmse_n: f64,
    /// Depth samples skipped as a potentiometer's spikes (absent: none).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub spikes_skipped: usize,
    /// The test's own scale against the law: its force over the law's (the geometric mean over
    /// its rows deeper than 3 mm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<f64>,
}

/// The sand's scatter from trial to trial ([`crate::ident::scatter::TrialScatter`]): the band a
/// further trial of the same preparation lies in, as a scale on the law's force.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumScatter {
    /// The trials it was told from.
    pub trials: usize,
    /// The degrees of freedom of its spread.
    pub degrees_of_freedom: usize,
    /// The standard deviation of the logarithm of a trial's scale.
    pub sd_ln_scale: f64,
    /// The softest and the stiffest trial's scale against the law.
    pub trial_scales: [f64; 2],
    /// The share of further trials the band holds (0.9).
    pub level: f64,
    /// The band's low scale: a further trial's force at a depth over the law's.
    pub low: f64,
    /// The band's high scale.
    pub high: f64,
}

impl MediumScatter {
    /// The file's scatter of a fit's.
    pub fn of(s: &crate::ident::scatter::TrialScatter) -> MediumScatter {
        MediumScatter {
            trials: s.trials,
            degrees_of_freedom: s.degrees_of_freedom,
            sd_ln_scale: s.sd_ln_scale,
            trial_scales: [s.lowest_scale, s.highest_scale],
            level: s.level,
            low: s.low,
            high: s.high,
        }
    }

    /// The band checked: `0 < low <= high`, finite, a level in (0, 1).
    pub fn check(&self) -> Result<()> {
        if !(self.low.is_finite()
            && self.high.is_finite()
            && self.low > 0.0
            && self.low <= self.high)
        {
            bail!(
                "scatter: the band's low {} and high {} must be finite with 0 < low <= high",
                self.low,
                self.high
            );
        }
        if !(self.level > 0.0 && self.level < 1.0) {
            bail!("scatter.level must lie in (0, 1), got {}", self.level);
        }
        Ok(())
    }

    /// In words, for tables.
    pub fn text(&self) -> String {
        format!(
            "{:.0} % of further trials of this preparation between {:.3} and {:.3} times the law's force (from {} trials, {:.3} to {:.3}; sd of ln scale {:.3})",
            self.level * 100.0,
            self.low,
            self.high,
            self.trials,
            self.trial_scales[0],
            self.trial_scales[1],
            self.sd_ln_scale
        )
    }
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

impl MediumFile {
    /// The medium file of a fit.
    /// The medium file of `fit`, calibrated on the tests of `files` (in the order of
    /// `fit.tests`) by their `depth_column`.
    pub fn of_fit(
        name: &str,
        fit: &SinkageFit,
        files: &[PathBuf],
        depth_column: &str,
        command: &str,
        unit_weight_source: &str,
    ) -> MediumFile {
        let names = fit.model.law.param_names();
        MediumFile {
            name: name.to_string(),
            law: fit.model.law,
            params: names
                .iter()
                .zip(&fit.model.params)
                .map(|(n, v)| (n.to_string(), *v))
                .collect(),
            std_dev: names
                .iter()
                .zip(&fit.std_dev)
                .map(|(n, v)| (n.to_string(), *v))
                .collect(),
            unit_weight_n_m3: fit.model.unit_weight_n_m3,
            rft_alpha_z_n_cm3: fit.model.rft_alpha_z_n_cm3,
            source: MediumSource {
                command: command.to_string(),
                unit_weight: unit_weight_source.to_string(),
                depth_column: depth_column.to_string(),
                r2: fit.r2,
                tests: files
                    .iter()
                    .zip(&fit.tests)
                    .map(|(file, f)| MediumSourceTest {
                        file: file.display().to_string(),
                        plate: f.plate.clone(),
                        loaded_rows: f.rows,
                        r2: f.r2,
                        rmse_n: f.rmse_n,
                        spikes_skipped: 0,
                        scale: f.scale,
                    })
                    .collect(),
            },
            rft_shape: None,
            sheared_bearing: None,
            scatter: fit.scatter.as_ref().map(MediumScatter::of),
        }
    }

    /// The medium file of intrusion tests alone: its shape, and as its plate-sinkage law the
    /// shape's own for a horizontal plate pushed straight down (`rft_depth_power` with `xi` 1,
    /// against the shape's `alpha_z`, and its depth exponent): a sinkage leg naming the file
    /// presses as an RFT plate does, but for the shape's surface offset, which the sinkage law
    /// does not have.
    pub fn of_shape(
        name: &str,
        fit: &RftShapeFit,
        files: &[PathBuf],
        unit_weight_n_m3: f64,
        command: &str,
        unit_weight_source: &str,
    ) -> MediumFile {
        let [down, down_sd] = fit.alpha_z_down_n_cm3;
        MediumFile {
            name: name.to_string(),
            law: SinkageLaw::RftDepthPower,
            params: [
                ("xi".to_string(), 1.0),
                ("n".to_string(), fit.depth_exponent),
            ]
            .into(),
            std_dev: [
                ("xi".to_string(), down_sd / down),
                ("n".to_string(), fit.depth_exponent_std),
            ]
            .into(),
            unit_weight_n_m3,
            rft_alpha_z_n_cm3: down,
            source: MediumSource {
                command: command.to_string(),
                unit_weight: unit_weight_source.to_string(),
                depth_column: "depth_m".to_string(),
                r2: fit.r2[1],
                tests: Vec::new(),
            },
            rft_shape: Some(MediumRftShape::of_fit(fit, files)),
            sheared_bearing: None,
            scatter: None,
        }
    }

    /// This file's plate-sinkage law (`rft_depth_power`) with the angular shape of `other`, a
    /// medium file whose shape was calibrated from intrusion tests (`other_name` names it):
    /// its coefficients scaled so that a horizontal plate pushed straight down feels this
    /// file's law, and this file's depth exponent, no surface offset and no speed law (plates
    /// pushed at one speed straight down measure neither). For sand with plate-sinkage tests
    /// alone, whose shape a lab's or a DEM bed's intrusion tests stand in for.
    pub fn with_shape_from(mut self, other: &MediumFile, other_name: &str) -> Result<MediumFile> {
        if self.law != SinkageLaw::RftDepthPower {
            bail!(
                "a borrowed shape is scaled to the rft_depth_power law, and this file holds the {} law (give --law rft_depth_power)",
                self.law.name()
            );
        }
        let Some(shape) = &other.rft_shape else {
            bail!(
                "{other_name} carries no RFT shape (it was calibrated from plates pushed straight down: calibrate it with intrusion tests)"
            );
        };
        let theirs = RftCoefficients::Fit(shape.coefficients().context(other_name.to_string())?)
            .alpha_z_down_n_cm3();
        let ours = self.params["xi"] * self.rft_alpha_z_n_cm3;
        let scale = ours / theirs;
        if !(scale.is_finite() && scale > 0.0) {
            bail!(
                "{other_name}'s shape gives {theirs} N/cm^3 for a plate pushed straight down, and these plates {ours}: no scale between them"
            );
        }
        let scaled =
            |m: &BTreeMap<String, f64>| m.iter().map(|(k, v)| (k.clone(), v * scale)).collect();
        self.rft_shape = Some(MediumRftShape {
            coefficients_n_cm3: scaled(&shape.coefficients_n_cm3),
            std_dev_n_cm3: scaled(&shape.std_dev_n_cm3),
            depth_exponent: self.params["n"],
            std_depth_exponent: self.std_dev.get("n").copied().unwrap_or(f64::NAN),
            surface_offset_m: 0.0,
            std_surface_offset_m: 0.0,
            speed_law: None,
            borrowed_from: Some(match &shape.borrowed_from {
                // Borrowed twice: where it was measured stays said.
                Some(first) => format!(
                    "{other_name} (medium {:?}, itself from {first})",
                    other.name
                ),
                None => format!("{other_name} (medium {:?})", other.name),
            }),
            ..shape.clone()
        });
        Ok(self)
    }

    /// What an RFT leg naming this file uses. With a measured shape: its coefficients, law in
    /// depth and speed law (a coefficient set named beside it, `explicit`, is refused: the file
    /// carries its own). Without: `explicit` or `poppy_lp`'s shape, with the file's
    /// `rft_depth_power` law ([`Self::rft_depth_law`]) and no speed law.
    pub fn rft_law(&self, explicit: Option<(&str, RftCoefficients)>) -> Result<RftLaw> {
        let sheared = self.sheared()?;
        match (&self.rft_shape, explicit) {
            (Some(_), Some((name, _))) => bail!(
                "medium {:?} carries its own RFT shape, measured from intrusion tests; a coefficient set ({name}) cannot be named beside it (leave rft_coeffs out, or name a medium file without a shape)",
                self.name
            ),
            (Some(shape), None) => Ok(RftLaw {
                coefficients: RftCoefficients::Fit(
                    shape
                        .coefficients()
                        .with_context(|| format!("medium {:?}", self.name))?,
                ),
                depth_law: shape
                    .depth_law()
                    .with_context(|| format!("medium {:?}", self.name))?,
                speed_law: shape
                    .speed_law()
                    .with_context(|| format!("medium {:?}", self.name))?,
                shape_measured: shape.form == ShapeForm::LiNine && shape.borrowed_from.is_none(),
                sheared,
            }),
            (None, explicit) => {
                let coefficients = match explicit {
                    Some((_, c)) => c,
                    None => RftCoefficients::by_name(RFT_SET, None)?,
                };
                Ok(RftLaw {
                    depth_law: self.rft_depth_law(&coefficients)?,
                    coefficients,
                    speed_law: None,
                    shape_measured: false,
                    sheared,
                })
            }
        }
    }

    /// The bearing of the sand a body shears, where the file has it, checked (a value outside
    /// its physical range is an error naming it).
    pub fn sheared(&self) -> Result<Option<crate::model::ShearedBearing>> {
        self.sheared_bearing
            .as_ref()
            .map(|b| {
                b.bearing()
                    .with_context(|| format!("medium {:?}", self.name))
            })
            .transpose()
    }

    /// Where an RFT leg's angular shape comes from, in words.
    pub fn rft_shape_text(&self) -> String {
        match &self.rft_shape {
            Some(s) if s.borrowed_from.is_some() => format!(
                "borrowed from {} ({} intrusion tests there), scaled to this file's plates pushed straight down, depth exponent {:.3}",
                s.borrowed_from.as_deref().unwrap_or_default(),
                s.tests.len(),
                s.depth_exponent,
            ),
            Some(s) if s.form == ShapeForm::LiNine => format!(
                "measured: Li's nine coefficients fitted to {} intrusion tests, depth exponent {:.3}{}",
                s.tests.len(),
                s.depth_exponent,
                match &s.speed_law {
                    Some(l) => format!(
                        ", speed law from {:.2} to {:.2} m/s",
                        l.ref_speed_m_s, l.max_speed_m_s
                    ),
                    None => ", no speed law (no test at a second speed)".to_string(),
                }
            ),
            Some(s) => format!(
                "a preset's, scaled: {}",
                s.reduced_because
                    .as_deref()
                    .unwrap_or("the tests did not tell the nine terms apart")
            ),
            None => format!(
                "{RFT_SET}'s (a preset, not measured: the file was calibrated from plates pushed straight down; calibrate it with intrusion tests to measure it)"
            ),
        }
    }

    /// The law with its values, checked (a NaN or negative value is an error naming it).
    pub fn model(&self) -> Result<SinkageModel> {
        let mut params = Vec::new();
        for name in self.law.param_names() {
            params.push(*self.params.get(*name).with_context(|| {
                format!(
                    "medium {:?}: law {} needs parameter {name} (has: {})",
                    self.name,
                    self.law.name(),
                    self.params.keys().cloned().collect::<Vec<_>>().join(", ")
                )
            })?);
        }
        if let Some(extra) = self
            .params
            .keys()
            .find(|k| !self.law.param_names().contains(&k.as_str()))
        {
            bail!(
                "medium {:?}: law {} has no parameter {extra:?} (its parameters: {})",
                self.name,
                self.law.name(),
                self.law.param_names().join(", ")
            );
        }
        SinkageModel::new(
            self.law,
            params,
            self.unit_weight_n_m3,
            self.rft_alpha_z_n_cm3,
        )
        .with_context(|| format!("medium {:?}", self.name))
    }

    /// The law in depth an RFT leg of `coefficients` takes from this medium: the file's
    /// `rft_depth_power` law (`xi`, `n`), its scale carried from the `alpha_z` it was calibrated
    /// against to `coefficients`' own for a horizontal plate moving down. A file of another law
    /// is refused by name: its pressure is not RFT's stress.
    pub fn rft_depth_law(
        &self,
        coefficients: &crate::model::RftCoefficients,
    ) -> Result<crate::model::RftDepthLaw> {
        if self.law != SinkageLaw::RftDepthPower {
            bail!(
                "medium {:?} holds the {} law; an RFT leg takes the rft_depth_power law (write one with terzaghi calibrate --law rft_depth_power)",
                self.name,
                self.law.name()
            );
        }
        let (xi, n) = (self.params["xi"], self.params["n"]);
        let own = coefficients.alpha_z_down_n_cm3();
        if !(own.is_finite() && own > 0.0) {
            bail!("these RFT coefficients give no stress for a plate moving down ({own} N/cm^3)");
        }
        crate::model::RftDepthLaw::new(xi * self.rft_alpha_z_n_cm3 / own, n)
            .with_context(|| format!("medium {:?}", self.name))
    }

    /// The band of the sand's trial-to-trial scatter (`--band`): its low and high scales on
    /// the law's force; a file without one is refused, saying why it has none.
    pub fn band(&self, file: &Path) -> Result<(f64, f64)> {
        match &self.scatter {
            Some(b) => Ok((b.low, b.high)),
            None => bail!(
                "{} has no trial-to-trial scatter to give a band: terzaghi calibrate writes one from three plate tests or more (four for a law with a width term); this file {}",
                file.display(),
                if self.source.tests.is_empty() {
                    "was calibrated on intrusion tests alone".to_string()
                } else {
                    format!(
                        "was calibrated on {} plate tests, or before the band was written",
                        self.source.tests.len()
                    )
                }
            ),
        }
    }

    /// The file as YAML, with a header that says what it is.
    pub fn to_yaml(&self) -> Result<String> {
        Ok(format!(
            "# A terzaghi medium file: a plate-sinkage law calibrated from measurements.\n# Written by: {}\n{}",
            // One comment line, whatever the command held (the field below keeps it as it was).
            self.source.command.replace(['\n', '\r'], " "),
            serde_yaml_ng::to_string(self)?
        ))
    }

    /// Reads a medium file, checked.
    pub fn read(file: &Path) -> Result<MediumFile> {
        let text = std::fs::read_to_string(file)
            .with_context(|| format!("cannot read {}", file.display()))?;
        MediumFile::parse(file, &text)
    }

    /// [`MediumFile::read`] on a text already read (`file` names it in messages).
    pub fn parse(file: &Path, text: &str) -> Result<MediumFile> {
        let m: MediumFile = serde_yaml_ng::from_str(text)
            .with_context(|| format!("{} is not a medium file", file.display()))?;
        m.model().with_context(|| format!("{}", file.display()))?;
        m.sheared().with_context(|| format!("{}", file.display()))?;
        if let Some(b) = &m.scatter {
            b.check().with_context(|| format!("{}", file.display()))?;
        }
        if m.rft_shape.is_some() {
            m.rft_law(None)
                .with_context(|| format!("{}", file.display()))?;
        }
        Ok(m)
    }
}
