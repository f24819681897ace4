//! The legs of a log, each with its model and its measured samples: from a ROS 2 MCAP session
//! (F/T samples matched with joint angles as the node matches them, the legs' plates and media
//! from the recorded parameters, a parameter file, or a [`JointLeg`] description), or from a CSV
//! log of one leg.

use super::Opened;
use super::inputs::{measured_samples_placed, session_config};
use crate::config::{FtFrame, LegConfig, NodeConfig, resolve_topic};
use crate::dataset::read_samples_csv;
use crate::ident::Sample;
use crate::model::{HipMotion, Medium, Plate, TerzaghiModel};
use anyhow::{Context as _, Result, bail};
use std::path::{Path, PathBuf};

/// One leg of a log: its name, its conventional model (plate and medium), its measured samples
/// (drag and lift in the hip frame against the attack angle).
#[derive(Debug, Clone)]
pub struct LegLog {
    /// The leg's name.
    pub name: String,
    /// The leg's model (plate and medium).
    pub model: TerzaghiModel,
    /// Its samples.
    pub samples: Vec<Sample>,
    /// For a leg the recorded robot's state places (`<leg>.hip_frame`): where its hip was at
    /// each sample (`None` where the state had no place; empty for other legs).
    pub hips: Vec<Option<HipMotion>>,
}

/// A leg of a ROS 2 session recorded without our parameters: which joint turns it, which
/// topic carries its F/T, and its geometry and medium.
#[derive(Debug, Clone)]
pub struct JointLeg {
    /// The leg's name.
    pub name: String,
    /// The joint's name in the JointState messages.
    pub joint: String,
    /// The JointState topic.
    pub joint_states_topic: String,
    /// The leg's measured F/T topic (geometry_msgs/WrenchStamped).
    pub wrench_topic: String,
    /// How the F/T sensor is mounted.
    pub ft_frame: FtFrame,
    /// `beta = direction * (position - angle_offset_rad)`; `direction` is `1` or `-1`.
    pub direction: f64,
    /// The joint position at which the attack angle is 0 (rad).
    pub angle_offset_rad: f64,
    /// The leg's plate and hip height.
    pub plate: Plate,
    /// The leg's medium.
    pub medium: Medium,
}

impl JointLeg {
    /// The node's configuration for this one leg.
    pub fn config(&self) -> Result<NodeConfig> {
        if self.direction != 1.0 && self.direction != -1.0 {
            bail!("direction {}: expected 1 or -1", self.direction);
        }
        if !self.angle_offset_rad.is_finite() {
            bail!(
                "angle offset {} rad: expected a finite number",
                self.angle_offset_rad
            );
        }
        if self.wrench_topic.is_empty() {
            bail!("the leg's F/T topic is empty");
        }
        let mut leg = LegConfig::new(&self.name, &self.joint, self.plate, self.medium);
        leg.direction = self.direction;
        leg.angle_offset_rad = self.angle_offset_rad;
        leg.ft_topic_given = self.wrench_topic.clone();
        leg.ft_topic = Some(resolve_topic(&self.wrench_topic, "/", "terzaghi", &[]));
        leg.ft_frame = self.ft_frame;
        Ok(NodeConfig::with_legs(vec![leg], &self.joint_states_topic)?)
    }
}

/// Where the legs of a session are described.
#[derive(Debug, Clone, Default)]
pub enum LegsFrom {
    /// The parameters recorded in the session by `terzaghi node`.
    #[default]
    Recorded,
    /// A ROS 2 parameter file, as the node reads one.
    ParamsFile(PathBuf),
    /// One leg described in full.
    Joint(Box<JointLeg>),
}

impl LegsFrom {
    /// The configuration of the session's legs.
    fn config(&self, opened: &Opened, file: &Path) -> Result<NodeConfig> {
        Ok(match self {
            LegsFrom::Recorded => session_config(None, opened.head(), file)?.0,
            LegsFrom::ParamsFile(p) => session_config(Some(p), opened.head(), file)?.0,
            LegsFrom::Joint(j) => j.config()?,
        })
    }
}

/// The legs of the session `file` that `legs_from` describes, read with that configuration:
/// `leg`, or else every leg with an F/T topic. A session cut off, a leg that is not there or
/// has no F/T, and a session whose legs have none are refused.
pub fn mcap_legs(
    file: &Path,
    opened: &Opened,
    legs_from: &LegsFrom,
    leg: Option<&str>,
) -> Result<(Vec<LegLog>, NodeConfig)> {
    let (cfg, chosen) = configured(file, opened, legs_from, leg)?;
    Ok((session_legs(file, opened, &cfg, &chosen)?, cfg))
}

/// The configuration of `opened`'s legs and the legs chosen in it (see [`mcap_legs`]).
fn configured(
    file: &Path,
    opened: &Opened,
    legs_from: &LegsFrom,
    leg: Option<&str>,
) -> Result<(NodeConfig, Vec<usize>)> {
    opened.refuse_cut_off(file)?;
    let cfg = legs_from.config(opened, file)?;
    let chosen = choose_legs(&cfg, leg)?;
    if chosen.is_empty() {
        bail!(super::Refusal::NoLegWithFt);
    }
    Ok((cfg, chosen))
}

/// The leg named `leg`, or else every leg with an F/T topic (none, if none has one); an error
/// names the legs there are when `leg` is not one of them or has no F/T.
fn choose_legs(cfg: &NodeConfig, leg: Option<&str>) -> Result<Vec<usize>> {
    let names = || {
        cfg.legs
            .iter()
            .map(|l| l.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let chosen: Vec<usize> = match leg {
        Some(name) => match cfg.legs.iter().position(|l| l.name == name) {
            Some(i) if cfg.legs[i].ft_topic.is_some() => vec![i],
            Some(_) => bail!("leg {name:?} has no F/T topic in the parameters"),
            None => bail!(
                "no leg named {name:?} in the parameters (legs: {})",
                names()
            ),
        },
        None => (0..cfg.legs.len())
            .filter(|&i| cfg.legs[i].ft_topic.is_some())
            .collect(),
    };
    Ok(chosen)
}

/// The measured samples of the legs `chosen` of the complete session `file`
/// ([`Opened::refuse_cut_off`]), with `cfg`. A damaged file is refused with the command that
/// mends it; a leg without a matched sample is refused with the topics the file has.
fn session_legs(
    file: &Path,
    opened: &Opened,
    cfg: &NodeConfig,
    chosen: &[usize],
) -> Result<Vec<LegLog>> {
    let head = opened.head();
    let (mut placed, read) = measured_samples_placed(opened.source(), cfg.clone())
        .with_context(|| file.display().to_string())?;
    if !read.complete {
        bail!(
            "{} is damaged ({}): recover it first with `terzaghi recover {} -o FIXED.mcap`",
            file.display(),
            read.stopped.as_deref().unwrap_or("reading stopped early"),
            file.display()
        );
    }
    let topics: Vec<&str> = head.topics.iter().map(|t| t.topic.as_str()).collect();
    let mut legs = Vec::new();
    for &i in chosen {
        let leg = &cfg.legs[i];
        let s = std::mem::take(&mut placed.samples[i]);
        if s.is_empty() {
            bail!(
                "leg {}: no F/T sample on {} matched a joint angle of {} on {} (topics in the file: {})",
                leg.name,
                leg.ft_topic.as_deref().unwrap_or("?"),
                leg.joint,
                cfg.joint_states_topic,
                topics.join(", ")
            );
        }
        legs.push(LegLog {
            name: leg.name.clone(),
            model: TerzaghiModel::conventional(leg.plate, leg.medium),
            samples: s,
            hips: std::mem::take(&mut placed.hips[i]),
        });
    }
    Ok(legs)
}

/// The one leg of a CSV log (`t_s,beta_rad,drag_n,lift_n`), named `name`.
pub fn csv_leg(file: &Path, name: &str, plate: Plate, medium: Medium) -> Result<LegLog> {
    Ok(LegLog {
        name: name.to_string(),
        model: TerzaghiModel::conventional(plate, medium),
        samples: read_samples_csv(file)?,
        hips: Vec::new(),
    })
}

/// The one leg of the session `file` that a fit reads: `leg`, or else its only leg with an F/T
/// topic (several are refused, naming them).
pub fn one_leg(file: &Path, legs_from: &LegsFrom, leg: Option<&str>) -> Result<LegLog> {
    let Some(opened) = Opened::mcap(file)? else {
        bail!("{} is not an MCAP file", file.display());
    };
    let (cfg, chosen) = configured(file, &opened, legs_from, leg)?;
    if chosen.len() > 1 {
        bail!(super::Refusal::SeveralLegs {
            legs: cfg.legs.iter().map(|l| l.name.clone()).collect()
        });
    }
    let mut legs = session_legs(file, &opened, &cfg, &chosen)?;
    Ok(legs.remove(0))
}
