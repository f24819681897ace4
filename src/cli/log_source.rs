//! The log a fitting command reads: a CSV with the leg's geometry and medium as flags, or a
//! recorded session whose parameters carry them.

use super::{MediumArgs, OptionalPlateArgs, terzaghi_model};
use anyhow::{Result, bail};
use clap::Args;
use std::path::PathBuf;
use terzaghi::dataset::read_samples_csv;
use terzaghi::ident::Sample;
use terzaghi::model::TerzaghiModel;
use terzaghi::session::files::is_mcap;
use terzaghi::session::legs::{LegsFrom, one_leg};

#[derive(Debug, Args)]
pub struct LogArgs {
    /// CSV with a header naming at least beta_rad,drag_n,lift_n (and t_s for timing), or an MCAP
    /// session with the node's parameters (recorded by `terzaghi node`, or `terzaghi import-dem`).
    pub data: PathBuf,
    #[command(flatten)]
    pub plate: OptionalPlateArgs,
    #[command(flatten)]
    pub medium: MediumArgs,
    /// MCAP session: the leg (default: its only leg with an F/T topic).
    #[arg(long, value_name = "NAME")]
    pub leg: Option<String>,
    /// MCAP session: node parameters to use instead of the recorded ones.
    #[arg(long, value_name = "FILE")]
    pub params_file: Option<PathBuf>,
}

impl LogArgs {
    /// The files this log is read from: the log, and the parameters file if given.
    pub fn inputs(&self) -> Vec<&std::path::Path> {
        std::iter::once(self.data.as_path())
            .chain(self.params_file.as_deref())
            .collect()
    }

    /// The leg's model (conventional: `b_k = a = 1`) and its measured samples.
    pub fn load(&self) -> Result<(TerzaghiModel, Vec<Sample>)> {
        if is_mcap(&self.data)? {
            from_session(self)
        } else {
            from_csv(self)
        }
    }
}

fn from_csv(a: &LogArgs) -> Result<(TerzaghiModel, Vec<Sample>)> {
    if a.leg.is_some() || a.params_file.is_some() {
        bail!(
            "{} is not an MCAP session: --leg and --params-file are for sessions",
            a.data.display()
        );
    }
    let Some(plate) = a.plate.all() else {
        bail!("a CSV log needs the leg's geometry: --length-m, --width-m and --hip-height-m");
    };
    let plate = plate.plate()?;
    let chosen = a.medium.medium()?;
    let samples = read_samples_csv(&a.data)?;
    Ok((terzaghi_model(plate, &chosen, None), samples))
}

/// The leg's plate and medium from the session's parameters, its F/T samples matched with
/// joint angles as the node matches them.
fn from_session(a: &LogArgs) -> Result<(TerzaghiModel, Vec<Sample>)> {
    if a.plate.any() {
        bail!(
            "{} is a session: its geometry and medium come from its parameters (change them with --params-file)",
            a.data.display()
        );
    }
    if a.medium.medium.is_some() || a.medium.unit_weight_n_m3.is_some() {
        bail!(
            "{} is a session: its medium comes from its parameters (change it with --params-file)",
            a.data.display()
        );
    }
    let from = match &a.params_file {
        Some(p) => LegsFrom::ParamsFile(p.clone()),
        None => LegsFrom::Recorded,
    };
    let leg = one_leg(&a.data, &from, a.leg.as_deref())?;
    // The fit takes every sample at the configured hip height; say so where the recording
    // placed the hip elsewhere (a body that heaves or pitches), rather than fit it silently.
    let fixed_m = leg.model.plate().hip_height_m();
    let moved = leg
        .hips
        .iter()
        .flatten()
        .filter(|h| (h.height_m - fixed_m).abs() > 1e-3 || h.pitch_rad.abs() > 1e-3)
        .count();
    if moved > 0 {
        eprintln!(
            "warning: in {} of {} samples the recording places {}'s hip off its configured height of {} m, or pitched (its /tf or body pose); this command fits at the configured height, while terzaghi diagnose places each sample's hip",
            moved,
            leg.samples.len(),
            leg.name,
            fixed_m
        );
    }
    Ok((leg.model, leg.samples))
}
