//! Medium files: a plate-sinkage law calibrated from measurements (`terzaghi calibrate` writes
//! them), with where each value came from; `terzaghi media` lists them and a leg of `model:
//! sinkage` names one as its `<leg>.medium`.

use crate::ident::sinkage::SinkageFit;
use crate::model::sinkage::{SinkageLaw, SinkageModel};
use anyhow::{Context, Result, bail};
use serde::{Deserialize, Serialize};
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
                    })
                    .collect(),
            },
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

    /// The file as YAML, with a header that says what it is.
    pub fn to_yaml(&self) -> Result<String> {
        Ok(format!(
            "# A terzaghi medium file: a plate-sinkage law calibrated from measurements.\n# Written by: {}\n{}",
            self.source.command,
            serde_yaml_ng::to_string(self)?
        ))
    }

    /// Reads a medium file, checked.
    pub fn read(file: &Path) -> Result<MediumFile> {
        let text = std::fs::read_to_string(file)
            .with_context(|| format!("cannot read {}", file.display()))?;
        let m: MediumFile = serde_yaml_ng::from_str(&text)
            .with_context(|| format!("{} is not a medium file", file.display()))?;
        m.model().with_context(|| format!("{}", file.display()))?;
        Ok(m)
    }
}
