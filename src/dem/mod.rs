//! Runs of the DEM testbed (`tests/dem/`): a leg rotating through a bed of simulated grains,
//! written by the campaign script as CSV, `t_s,beta_rad,drag_n,lift_n,hip_torque_nm` in the hip
//! frame, after `# key: value` lines that describe the run (engine, geometry, the medium's
//! constants measured in the bed, how well the bed settled).
//!
//! [`parse_run`] reads and checks a run: one whose leg never touched the bed, one with a
//! non-finite force, or one whose bed did not settle is refused with the reason, so that it is
//! never written as a session. [`DemRun::write_session`] writes an accepted run as a ROS 2 MCAP
//! session through the project's [`SessionWriter`], with the node's parameters, so that every
//! command that reads a recording (`info`, `fit`, `identify`, `replay --reevaluate`,
//! `diagnose`) reads it. The models against a campaign's runs, and the diagnosis on sessions
//! built from them, are checked in the `terzaghi-eval` crate.

use crate::config::{ParamMap, ParamValue, TF_TOPIC, defaults};
use crate::ident::Sample;
use crate::model::{Medium, ModelError, Plate};
use crate::msgs::{
    Header, JointState, Quaternion, TfMessage, Time, Transform, TransformStamped, Vector3, Wrench,
    WrenchStamped,
};
use crate::record::{OfferedQos, RecordError, RecordOptions, SessionWriter};
use std::collections::BTreeMap;
use std::io::{Seek, Write};
use std::path::Path;

/// A bed counts as settled when its kinetic energy is below this fraction of `N m g d` (every
/// grain's weight lifted by one diameter).
pub const SETTLED_KE_RATIO_MAX: f64 = 1e-4;

/// A run whose largest force stays below this never touched the bed.
pub const CONTACT_FORCE_MIN_N: f64 = 1e-3;

/// The leg's name in a run's session.
pub const LEG: &str = "leg";
/// The leg's joint in a run's session.
pub const JOINT: &str = "hip";
/// The leg's F/T topic in a run's session.
pub const FT_TOPIC: &str = "/ft_sensor/wrench";
/// The joint states' topic in a run's session.
pub const JOINT_STATES_TOPIC: &str = "/joint_states";

/// What a run's file gets wrong.
#[derive(Debug, thiserror::Error)]
pub enum DemError {
    /// The file cannot be read.
    #[error("cannot read {path}: {error}")]
    Io {
        /// The file.
        path: String,
        /// The system's error.
        error: std::io::Error,
    },
    /// A description line the run must have.
    #[error("{path}: the run does not say its {key} (a line '# {key}: VALUE' before the header)")]
    MissingKey {
        /// The file.
        path: String,
        /// The key it lacks.
        key: &'static str,
    },
    /// A description value that is not a number.
    #[error("{path}: {key} = {value:?} is not a number")]
    BadValue {
        /// The file.
        path: String,
        /// The key.
        key: &'static str,
        /// Its value, as written.
        value: String,
    },
    /// A geometry or medium the model refuses.
    #[error("{path}: {error}")]
    Model {
        /// The file.
        path: String,
        /// The model's refusal.
        error: ModelError,
    },
    /// A line that is not a record of the header's columns.
    #[error("{path} line {line}: {message}")]
    Malformed {
        /// The file.
        path: String,
        /// The line (from 1).
        line: usize,
        /// What is wrong with it.
        message: String,
    },
    /// A bed still moving when the stroke began.
    #[error(
        "{path}: its bed did not settle (kinetic energy {ratio:e} of N m g d, at most {max:e}); settle it longer before a stroke: not written as a session"
    )]
    Unsettled {
        /// The file.
        path: String,
        /// The bed's kinetic energy over `N m g d`.
        ratio: f64,
        /// The most that counts as settled.
        max: f64,
    },
    /// A run whose leg never touched the bed.
    #[error(
        "{path}: the leg never touched the bed (largest force {max_n:.2e} N over {samples} samples); check the hip height against the bed's surface: not written as a session"
    )]
    NoContact {
        /// The file.
        path: String,
        /// The largest force (N).
        max_n: f64,
        /// The samples read.
        samples: usize,
    },
    /// A value that is not a finite number.
    #[error(
        "{path} line {line}: {column} is {value}, not a finite number: not written as a session"
    )]
    NonFinite {
        /// The file.
        path: String,
        /// The line (from 1).
        line: usize,
        /// The column.
        column: &'static str,
        /// The value.
        value: f64,
    },
}

/// One force sample of a run, in the hip frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DemSample {
    /// Time since the stroke began (s).
    pub t_s: f64,
    /// The attack angle, unwrapped over several strokes.
    pub beta_rad: f64,
    /// Horizontal force resisting the travel (N).
    pub drag_n: f64,
    /// Vertical force, up (N).
    pub lift_n: f64,
    /// Moment about the hip axis, resisting the rotation (N m).
    pub hip_torque_nm: f64,
    /// Where the hip was, for a run whose hip moves (columns `hip_x_m,hip_z_m`): its travel
    /// forward from its start and its height above the surface (m).
    pub hip_m: Option<[f64; 2]>,
}

/// The world frame of a session whose hip moves: the bed's surface at `z = 0`, `x` the robot's
/// forward; the hip's frame is `<leg>_hip` ([`LEG`]).
pub const WORLD_FRAME: &str = "odom";

/// The leg's shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LegShape {
    /// A flat plate, the model's leg.
    Flat,
    /// A half circle on the chord from the hip to the tip (a RHex-like C-leg), its convex side
    /// toward the travel.
    CLeg,
}

/// A checked run.
#[derive(Debug, Clone)]
pub struct DemRun {
    /// The run's name (its file's stem).
    pub name: String,
    /// Every `# key: value` line, as written.
    pub meta: BTreeMap<String, String>,
    /// The leg's shape.
    pub shape: LegShape,
    /// The geometry the model is told (for a C-leg, `length_m` is the chord).
    pub plate: Plate,
    /// Unit weight from the bed's packing, internal friction from its angle of repose, delta
    /// from the grain-plate contact friction.
    pub medium: Medium,
    /// The leg's rotation rate (rad/s).
    pub omega_rad_s: f64,
    /// The force samples, in time order.
    pub samples: Vec<DemSample>,
}

impl DemRun {
    /// A description value as a number, if the run has it.
    pub fn meta_f64(&self, key: &str) -> Option<f64> {
        self.meta.get(key).and_then(|v| v.parse().ok())
    }

    /// The samples as the identification takes them.
    pub fn samples(&self) -> Vec<Sample> {
        self.samples
            .iter()
            .map(|s| Sample {
                t_s: Some(s.t_s),
                beta_rad: s.beta_rad,
                drag_n: s.drag_n,
                lift_n: s.lift_n,
            })
            .collect()
    }

    /// The node's parameters for this run: one leg with the run's geometry and medium, its
    /// F/T sensor in the hip frame, the improved model starting from `b_k = a = 1`.
    pub fn node_params(&self) -> ParamMap {
        let mut p = defaults();
        let mut put = |k: &str, v: ParamValue| {
            p.insert(k.to_string(), v);
        };
        put("legs", ParamValue::StringArray(vec![LEG.to_string()]));
        put(
            "joint_states_topic",
            ParamValue::String(JOINT_STATES_TOPIC.into()),
        );
        let leg = |k: &str| format!("{LEG}.{k}");
        put(&leg("joint"), ParamValue::String(JOINT.into()));
        put(&leg("length_m"), ParamValue::Double(self.plate.length_m()));
        put(&leg("width_m"), ParamValue::Double(self.plate.width_m()));
        put(
            &leg("hip_height_m"),
            ParamValue::Double(self.plate.hip_height_m()),
        );
        put(
            &leg("unit_weight_n_m3"),
            ParamValue::Double(self.medium.unit_weight_n_m3()),
        );
        put(&leg("phi_deg"), ParamValue::Double(self.medium.phi_deg()));
        put(
            &leg("delta_deg"),
            ParamValue::Double(self.medium.delta_deg()),
        );
        put(&leg("b_k"), ParamValue::Double(1.0));
        put(&leg("a"), ParamValue::Double(1.0));
        put(&leg("ft_topic"), ParamValue::String(FT_TOPIC.into()));
        put(&leg("ft_frame"), ParamValue::String("hip".into()));
        p
    }

    /// Writes the run as a session: `sensor_msgs/JointState` (the joint's angle and speed) and
    /// `geometry_msgs/WrenchStamped` (force on the leg and torque about the hip, in the hip
    /// frame `leg_hip`: `F_x = -drag`, `F_z = lift`, `M_y = hip torque`) at each sample's time,
    /// for a moving hip its pose on `/tf` (`leg_hip` in [`WORLD_FRAME`]), the node's parameters
    /// (the fixed hip height the run states), and the run's description as the metadata record
    /// `dem_run`.
    pub fn write_session<W: Write + Seek>(&self, w: W) -> Result<W, RecordError> {
        let opts = RecordOptions::with_node_params(&self.node_params(), "terzaghi", "/");
        let mut s = SessionWriter::new(w, opts)?;
        s.write_metadata("dem_run", self.meta.clone())?;
        for smp in &self.samples {
            let t_ns = (smp.t_s * 1e9).round() as u64;
            let stamp = Time::from_nanos(t_ns as i64).unwrap_or_default();
            let joints = JointState {
                header: Header {
                    stamp,
                    frame_id: String::new(),
                },
                name: vec![JOINT.to_string()],
                position: vec![smp.beta_rad],
                velocity: vec![self.omega_rad_s],
                effort: vec![],
            };
            s.write(
                JOINT_STATES_TOPIC,
                OfferedQos::RELIABLE,
                &joints,
                t_ns,
                t_ns,
            )?;
            let wrench = WrenchStamped {
                header: Header {
                    stamp,
                    frame_id: format!("{LEG}_hip"),
                },
                wrench: Wrench {
                    force: Vector3 {
                        x: -smp.drag_n,
                        y: 0.0,
                        z: smp.lift_n,
                    },
                    torque: Vector3 {
                        x: 0.0,
                        y: smp.hip_torque_nm,
                        z: 0.0,
                    },
                },
            };
            s.write(FT_TOPIC, OfferedQos::BEST_EFFORT, &wrench, t_ns, t_ns)?;
            if let Some([x, z]) = smp.hip_m {
                let tf = TfMessage {
                    transforms: vec![TransformStamped {
                        header: Header {
                            stamp,
                            frame_id: WORLD_FRAME.into(),
                        },
                        child_frame_id: format!("{LEG}_hip"),
                        transform: Transform {
                            translation: Vector3 { x, y: 0.0, z },
                            rotation: Quaternion::default(),
                        },
                    }],
                };
                s.write(TF_TOPIC, OfferedQos::RELIABLE, &tf, t_ns, t_ns)?;
            }
        }
        s.finish()
    }
}

/// Runs of one leg, geometry, medium and speed joined into one run of several strokes, as a
/// wheel-leg turns: between two runs the leg swings on through the air at the run's speed (zero
/// force, one sample per sample period) to where the next run starts, a turn later.
pub fn join_runs(runs: Vec<DemRun>) -> Result<DemRun, DemError> {
    let mut it = runs.into_iter();
    let Some(mut out) = it.next() else {
        return Err(DemError::Malformed {
            path: String::new(),
            line: 0,
            message: "no run to join".into(),
        });
    };
    for r in it {
        if r.plate != out.plate
            || r.medium != out.medium
            || r.omega_rad_s != out.omega_rad_s
            || r.shape != out.shape
        {
            return Err(DemError::Malformed {
                path: r.name.clone(),
                line: 0,
                message: format!(
                    "cannot join it to {}: the geometry, medium, speed or shape differ",
                    out.name
                ),
            });
        }
        let (Some(last), Some(first)) = (out.samples.last().copied(), r.samples.first().copied())
        else {
            continue;
        };
        let period = match out.samples.len() {
            n if n >= 2 => last.t_s - out.samples[n - 2].t_s,
            _ => 1e-3,
        };
        let turn = 2.0 * std::f64::consts::PI;
        let dbeta = ((last.beta_rad - first.beta_rad) / turn).ceil() * turn;
        // The leg swings on through the air at the run's speed to where the next stroke starts:
        // out of the bed, the force is zero.
        let gap_rad = first.beta_rad + dbeta - last.beta_rad;
        let steps = (gap_rad / (out.omega_rad_s.abs() * period)).ceil().max(1.0) as usize;
        for k in 1..steps {
            out.samples.push(DemSample {
                t_s: last.t_s + k as f64 * period,
                beta_rad: last.beta_rad + gap_rad * k as f64 / steps as f64,
                drag_n: 0.0,
                lift_n: 0.0,
                hip_torque_nm: 0.0,
                hip_m: last.hip_m,
            });
        }
        let dt = last.t_s + steps as f64 * period - first.t_s;
        out.samples.extend(r.samples.iter().map(|s| DemSample {
            t_s: s.t_s + dt,
            beta_rad: s.beta_rad + dbeta,
            ..*s
        }));
        out.name = format!("{}+{}", out.name, r.name);
    }
    out.meta.insert("run".into(), out.name.clone());
    Ok(out)
}

/// A campaign as `tests/dem/campaign.py` writes it: `campaign.json` (engine, scene, the beds
/// and the medium measured in them, the time it took), `runs/*.csv`, `rft_grid.csv` (the
/// intrusions' stresses) and `rft_entry.csv` (its element moved into, across and out of the bed
/// at several speeds).
#[derive(Debug, Clone)]
pub struct Campaign {
    /// `campaign.json` as written.
    pub manifest: serde_json::Value,
    /// The runs, checked.
    pub runs: Vec<DemRun>,
    /// `(beta_r, gamma, alpha_x, alpha_z)`, N/cm^3.
    pub rft_grid: Vec<(f64, f64, f64, f64)>,
    /// The intrusions from the surface at several speeds, where the campaign has them.
    pub rft_entry: Option<crate::model::RftSpeedTable>,
}

impl Campaign {
    /// The run named `name`, if the campaign has it.
    pub fn run(&self, name: &str) -> Option<&DemRun> {
        self.runs.iter().find(|r| r.name == name)
    }
}

/// Reads a campaign's directory; every run is checked as [`read_run`] checks it.
pub fn read_campaign(dir: &Path) -> Result<Campaign, DemError> {
    let io = |p: &Path| {
        let path = p.display().to_string();
        move |error| DemError::Io { path, error }
    };
    let manifest_path = dir.join("campaign.json");
    let text = std::fs::read_to_string(&manifest_path).map_err(io(&manifest_path))?;
    let manifest: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| DemError::Malformed {
            path: manifest_path.display().to_string(),
            line: e.line(),
            message: e.to_string(),
        })?;
    let runs_dir = dir.join("runs");
    let mut names: Vec<_> = std::fs::read_dir(&runs_dir)
        .map_err(io(&runs_dir))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "csv"))
        .collect();
    names.sort();
    let runs = names
        .iter()
        .map(|p| read_run(p))
        .collect::<Result<Vec<_>, _>>()?;
    let grid_path = dir.join("rft_grid.csv");
    let rft_grid = match std::fs::read_to_string(&grid_path) {
        Ok(text) => parse_grid(&text, &grid_path.display().to_string())?,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
        Err(e) => return Err(io(&grid_path)(e)),
    };
    let entry_path = dir.join("rft_entry.csv");
    let rft_entry = match std::fs::read_to_string(&entry_path) {
        Ok(text) => Some(
            crate::model::RftSpeedTable::parse(&text).map_err(|message| DemError::Malformed {
                path: entry_path.display().to_string(),
                line: 0,
                message,
            })?,
        ),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(io(&entry_path)(e)),
    };
    Ok(Campaign {
        manifest,
        runs,
        rft_grid,
        rft_entry,
    })
}

fn parse_grid(text: &str, path: &str) -> Result<Vec<(f64, f64, f64, f64)>, DemError> {
    crate::model::RftGrid::parse(text)
        .map(|g| g.points())
        .map_err(|message| DemError::Malformed {
            path: path.to_string(),
            line: 0,
            message,
        })
}

const COLUMNS: [&str; 5] = ["t_s", "beta_rad", "drag_n", "lift_n", "hip_torque_nm"];
/// The columns after [`COLUMNS`] of a run whose hip moves.
const HIP_COLUMNS: [&str; 2] = ["hip_x_m", "hip_z_m"];

/// Reads and checks a run's file.
pub fn read_run(path: &Path) -> Result<DemRun, DemError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|error| DemError::Io {
        path: name.clone(),
        error,
    })?;
    parse_run(&text, &name)
}

/// Parses and checks a run; `path` names it in errors.
pub fn parse_run(text: &str, path: &str) -> Result<DemRun, DemError> {
    let mut meta = BTreeMap::new();
    let mut lines = text.lines().enumerate().peekable();
    while let Some((_, line)) = lines.peek() {
        let Some(rest) = line.strip_prefix('#') else {
            break;
        };
        if let Some((k, v)) = rest.split_once(':') {
            meta.insert(k.trim().to_string(), v.trim().to_string());
        }
        lines.next();
    }
    let num = |key: &'static str| -> Result<f64, DemError> {
        let v = meta.get(key).ok_or(DemError::MissingKey {
            path: path.to_string(),
            key,
        })?;
        v.parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| DemError::BadValue {
                path: path.to_string(),
                key,
                value: v.clone(),
            })
    };
    let model = |error| DemError::Model {
        path: path.to_string(),
        error,
    };
    let plate =
        Plate::new(num("length_m")?, num("width_m")?, num("hip_height_m")?).map_err(model)?;
    let medium =
        Medium::new(num("unit_weight_n_m3")?, num("phi_deg")?, num("delta_deg")?).map_err(model)?;
    let omega_rad_s = num("omega_rad_s")?;
    let shape = match meta.get("shape").map(String::as_str) {
        Some("flat") | None => LegShape::Flat,
        Some("c") | Some("c_leg") => LegShape::CLeg,
        Some(other) => {
            return Err(DemError::BadValue {
                path: path.to_string(),
                key: "shape",
                value: other.to_string(),
            });
        }
    };
    let ratio = num("bed_settled_ke_ratio")?;
    if ratio > SETTLED_KE_RATIO_MAX {
        return Err(DemError::Unsettled {
            path: path.to_string(),
            ratio,
            max: SETTLED_KE_RATIO_MAX,
        });
    }
    let Some((header_at, header)) = lines.next() else {
        return Err(DemError::Malformed {
            path: path.to_string(),
            line: text.lines().count() + 1,
            message: format!("no header (expected {})", COLUMNS.join(",")),
        });
    };
    let found: Vec<&str> = header.split(',').map(str::trim).collect();
    let columns: Vec<&str> = COLUMNS.iter().chain(&HIP_COLUMNS).copied().collect();
    let columns = if found == COLUMNS {
        &columns[..COLUMNS.len()]
    } else if found == columns {
        &columns[..]
    } else {
        return Err(DemError::Malformed {
            path: path.to_string(),
            line: header_at + 1,
            message: format!(
                "header {:?}, expected {} (and {} for a moving hip)",
                header.trim(),
                COLUMNS.join(","),
                HIP_COLUMNS.join(",")
            ),
        });
    };
    let mut samples = Vec::new();
    for (i, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != columns.len() {
            return Err(DemError::Malformed {
                path: path.to_string(),
                line: i + 1,
                message: format!("{} fields, expected {}", cells.len(), columns.len()),
            });
        }
        let mut v = [0.0; 7];
        for (k, cell) in cells.iter().enumerate() {
            let x: f64 = cell.parse().map_err(|_| DemError::Malformed {
                path: path.to_string(),
                line: i + 1,
                message: format!("{} = {cell:?} is not a number", columns[k]),
            })?;
            if k == 0 && x < 0.0 {
                return Err(DemError::Malformed {
                    path: path.to_string(),
                    line: i + 1,
                    message: format!("t_s = {x} is before the run's start (0 s)"),
                });
            }
            if !x.is_finite() {
                return Err(DemError::NonFinite {
                    path: path.to_string(),
                    line: i + 1,
                    column: columns[k],
                    value: x,
                });
            }
            v[k] = x;
        }
        samples.push(DemSample {
            t_s: v[0],
            beta_rad: v[1],
            drag_n: v[2],
            lift_n: v[3],
            hip_torque_nm: v[4],
            hip_m: (columns.len() > COLUMNS.len()).then_some([v[5], v[6]]),
        });
    }
    if let Some(w) = samples.windows(2).position(|w| w[1].t_s <= w[0].t_s) {
        return Err(DemError::Malformed {
            path: path.to_string(),
            line: header_at + 2 + w + 1,
            message: "time does not increase".into(),
        });
    }
    let max_n = samples
        .iter()
        .map(|s| s.drag_n.abs().max(s.lift_n.abs()))
        .fold(0.0, f64::max);
    if max_n < CONTACT_FORCE_MIN_N {
        return Err(DemError::NoContact {
            path: path.to_string(),
            max_n,
            samples: samples.len(),
        });
    }
    let name = meta.get("run").cloned().unwrap_or_else(|| path.to_string());
    Ok(DemRun {
        name,
        meta,
        shape,
        plate,
        medium,
        omega_rad_s,
        samples,
    })
}

/// Reads the runs `paths`, joins them in order and writes them as one session to `output`
/// (refused if it exists, unless `overwrite`); returns the joined run.
pub fn import_runs(
    paths: &[std::path::PathBuf],
    output: &Path,
    overwrite: bool,
) -> anyhow::Result<DemRun> {
    use anyhow::Context as _;
    crate::session::files::refuse_existing_recording(output, overwrite)?;
    let runs = paths
        .iter()
        .map(|p| read_run(p))
        .collect::<Result<Vec<_>, _>>()?;
    let run = join_runs(runs)?;
    crate::session::files::write_atomically(output, |w| {
        run.write_session(w)
            .with_context(|| crate::session::files::cannot_write(output))?;
        Ok(())
    })?;
    Ok(run)
}

/// The run a campaign's checks and variations are compared with: the scene's plate width and
/// hip height, `qs_bWWW_hHHH` (mm).
pub fn default_baseline(c: &Campaign) -> anyhow::Result<String> {
    let s = &c.manifest["scene"];
    let (Some(w), Some(h)) = (s["width_m"].as_f64(), s["hip_height_m"].as_f64()) else {
        anyhow::bail!("campaign.json names no scene width_m and hip_height_m");
    };
    Ok(format!(
        "qs_b{:03}_h{:03}",
        (w * 1000.0).round() as i64,
        (h * 1000.0).round() as i64
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run_text(settled: &str, rows: &str) -> String {
        format!(
            "# run: t\n# shape: flat\n# length_m: 0.1\n# width_m: 0.04\n# hip_height_m: 0.04\n# omega_rad_s: 1\n# unit_weight_n_m3: 14000\n# phi_deg: 30\n# delta_deg: 19\n# bed_settled_ke_ratio: {settled}\nt_s,beta_rad,drag_n,lift_n,hip_torque_nm\n{rows}"
        )
    }

    #[test]
    fn a_good_run_parses_with_its_geometry_and_medium() {
        let r = parse_run(
            &run_text("1e-6", "0.002,0.5,1.5,2.0,0.1\n0.004,0.502,1.6,2.1,0.1\n"),
            "t.csv",
        )
        .unwrap();
        assert_eq!(r.samples.len(), 2);
        assert_eq!(r.plate.width_m(), 0.04);
        assert!((r.medium.phi_deg() - 30.0).abs() < 1e-9);
        assert_eq!(r.shape, LegShape::Flat);
    }

    #[test]
    fn refusals_name_what_is_wrong() {
        let e = parse_run(&run_text("0.01", "0.002,0.5,1.5,2.0,0.1\n"), "t.csv").unwrap_err();
        assert!(matches!(e, DemError::Unsettled { .. }), "{e}");
        assert!(e.to_string().contains("did not settle"), "{e}");
        let e = parse_run(
            &run_text("1e-6", "0.002,0.5,0,0,0\n0.004,0.6,0,1e-5,0\n"),
            "t.csv",
        )
        .unwrap_err();
        assert!(matches!(e, DemError::NoContact { .. }), "{e}");
        let e = parse_run(&run_text("1e-6", "0.002,0.5,1,NaN,0\n"), "t.csv").unwrap_err();
        assert!(
            matches!(
                e,
                DemError::NonFinite {
                    line: 12,
                    column: "lift_n",
                    ..
                }
            ),
            "{e}"
        );
        let e = parse_run(&run_text("1e-6", "0.002,0.5,1,inf,0\n"), "t.csv").unwrap_err();
        assert!(matches!(e, DemError::NonFinite { .. }), "{e}");
        let e = parse_run(&run_text("1e-6", "-0.002,0.5,1,1,0\n"), "t.csv").unwrap_err();
        assert!(e.to_string().contains("before the run's start"), "{e}");
        let e = parse_run(&run_text("nan", "0.002,0.5,1,1,0\n"), "t.csv").unwrap_err();
        assert!(matches!(e, DemError::BadValue { .. }), "{e}");
        let text = run_text("1e-6", "0.002,0.5,1,1,0\n").replace("# phi_deg: 30\n", "");
        let e = parse_run(&text, "t.csv").unwrap_err();
        assert!(e.to_string().contains("phi_deg"), "{e}");
    }
}
