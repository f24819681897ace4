//! Wheel tests as a terramechanics lab runs them: a body under a given load, travelling at a hub
//! speed, turning at a rate and yawed by a slip angle, sinks until the sand bears it. Each row of
//! a CSV of runs (`load_n, hub_vx_m_s, omega_rad_s, slip_angle_deg`, other columns passed
//! through) gets its steady sinkage, drawbar pull, side force and drive torque
//! ([`crate::model::steady_sinkage`]); where the runs carry measured values under the same
//! names, they are kept beside the predictions as `measured_<name>` and compared.

use crate::medium_file::RftLaw;
use crate::model::{Body, Drive, Steady, SteadyError, Stress, state_at_sinkage, steady_sinkage};
use anyhow::{Context as _, Result, bail};
use std::path::Path;

/// The columns a run must have.
pub const INPUT_COLUMNS: [&str; 4] = ["load_n", "hub_vx_m_s", "omega_rad_s", "slip_angle_deg"];

/// The columns the steady state adds to each run: the sinkage, drawbar pull, side force and
/// drive torque, and the load the sand bears there (the run's own `load_n` where the sinkage is
/// solved for; the outcome where the sinkage is given, [`Solve::AtSinkage`]).
pub const OUTPUT_COLUMNS: [&str; 5] = [
    "sinkage_m",
    "drawbar_n",
    "side_n",
    "torque_nm",
    "load_borne_n",
];

/// What a run's state is solved for.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum Solve {
    /// The sinkage at which the sand bears the run's `load_n` (a wheel test).
    #[default]
    Sinkage,
    /// Nothing: the body is held at the sinkage (m) of this column (a measured one, say), and
    /// the load the sand bears there is the outcome; `load_n` may be left out.
    AtSinkage(String),
}

/// A body as a wheel test names it: its shape (`wheel`, `disc`, `sphere`, `box` or `mesh`) and
/// what that shape takes, as `terzaghi steady`'s flags and Python's `steady` give them.
#[derive(Debug, Clone, Default)]
pub struct BodySpec {
    /// `wheel`, `disc`, `sphere`, `box` or `mesh`.
    pub shape: String,
    /// A wheel's rim radius, a disc's or a sphere's (m).
    pub radius_m: Option<f64>,
    /// A wheel's width (m).
    pub width_m: Option<f64>,
    /// A disc's thickness (m).
    pub thickness_m: Option<f64>,
    /// A box's size along the heading, across it and up (m).
    pub size_m: Option<Vec<f64>>,
    /// A mesh's STL file: its hub at the file's origin, `x` the heading, `y` to the left, `z` up.
    pub mesh_file: Option<std::path::PathBuf>,
    /// Metres per unit of the mesh file (default [`MESH_SCALE`]).
    pub mesh_scale: Option<f64>,
    /// A foot's or a mesh's elements: their longest edge (m; default [`ELEMENT_M`]).
    pub element_m: Option<f64>,
    /// A wheel's grousers.
    pub grousers: Option<crate::model::Grousers>,
    /// Elements of a wheel's rim (at least 360; default [`RIM_ELEMENTS`]).
    pub rim_elements: Option<usize>,
}

/// A mesh file's metres per unit where none is given: metres, as ROS gives meshes.
pub const MESH_SCALE: f64 = 1.0;
/// A foot's or a mesh's longest element edge where none is given (m).
pub const ELEMENT_M: f64 = 0.002;
/// A wheel's rim elements where none is given.
pub const RIM_ELEMENTS: usize = 720;

/// The body `spec` describes, its hub at the body's centre (a mesh's at the file's origin).
/// A value of another shape, or one the shape needs and lacks, is an error naming it as
/// `name` spells a field (`--radius-m` on the command line, `radius_m` in Python).
pub fn build_body(spec: &BodySpec, name: impl Fn(&str) -> String) -> Result<Body> {
    let shape = spec.shape.as_str();
    let given = [
        ("radius_m", spec.radius_m.is_some()),
        ("width_m", spec.width_m.is_some()),
        ("thickness_m", spec.thickness_m.is_some()),
        ("size_m", spec.size_m.is_some()),
        ("mesh_file", spec.mesh_file.is_some()),
        ("mesh_scale", spec.mesh_scale.is_some()),
        ("element_m", spec.element_m.is_some()),
        ("grouser_count", spec.grousers.is_some()),
        ("rim_elements", spec.rim_elements.is_some()),
    ];
    let takes: &[&str] = match shape {
        "wheel" => &["radius_m", "width_m", "grouser_count", "rim_elements"],
        "disc" => &["radius_m", "thickness_m", "element_m"],
        "sphere" => &["radius_m", "element_m"],
        "box" => &["size_m", "element_m"],
        "mesh" => &["mesh_file", "mesh_scale", "element_m"],
        other => bail!("no body shape {other:?}: expected wheel, disc, sphere, box or mesh"),
    };
    if let Some((field, _)) = given.iter().find(|(f, g)| *g && !takes.contains(f)) {
        bail!(
            "{} {shape} takes no {} (it takes {})",
            name("shape"),
            name(field),
            takes.iter().map(|t| name(t)).collect::<Vec<_>>().join(", ")
        );
    }
    let needed = |v: Option<f64>, field: &str| {
        v.ok_or_else(|| anyhow::anyhow!("{} {shape} needs {}", name("shape"), name(field)))
    };
    // A foot's rim: segments (rings of a sphere) about as long as its elements.
    let element_m = spec.element_m.unwrap_or(ELEMENT_M);
    let around = |r: f64| ((std::f64::consts::TAU * r / element_m).ceil() as usize).clamp(12, 4096);
    Ok(match shape {
        "wheel" => Body::wheel(
            needed(spec.radius_m, "radius_m")?,
            needed(spec.width_m, "width_m")?,
            spec.grousers,
            spec.rim_elements.unwrap_or(RIM_ELEMENTS),
        )?,
        "disc" => {
            let r = needed(spec.radius_m, "radius_m")?;
            Body::disc(
                r,
                needed(spec.thickness_m, "thickness_m")?,
                [0.0; 3],
                around(r.abs().min(10.0)),
                element_m,
            )?
        }
        "sphere" => {
            let r = needed(spec.radius_m, "radius_m")?;
            Body::sphere(r, [0.0; 3], around(r.abs().min(10.0)) / 2, element_m)?
        }
        "box" => {
            let s = spec.size_m.as_deref().unwrap_or_default();
            let s = <[f64; 3]>::try_from(s).map_err(|_| {
                anyhow::anyhow!(
                    "{} box needs {} X,Y,Z: three sizes (m), not {}",
                    name("shape"),
                    name("size_m"),
                    s.len()
                )
            })?;
            Body::cuboid(s, [0.0; 3], element_m)?
        }
        _ => crate::mesh_file::read_body(
            spec.mesh_file.as_deref().ok_or_else(|| {
                anyhow::anyhow!("{} mesh needs {}", name("shape"), name("mesh_file"))
            })?,
            spec.mesh_scale.unwrap_or(MESH_SCALE),
            [0.0; 3],
            [0.0; 3],
            element_m,
        )?,
    })
}

/// Most rows a file of runs may hold (each is a bisection of some thousand RFT evaluations).
pub const MAX_RUNS: usize = 100_000;

/// One run: what it asks, and the steady state.
#[derive(Debug, Clone, PartialEq)]
pub struct SteadyRun {
    /// The run's fields as read (measured outputs renamed, see [`SteadyTable::headers`]).
    pub fields: Vec<String>,
    /// The load (N, + up: what the sand must bear); `None` where the sinkage was given.
    pub load_n: Option<f64>,
    /// The hub's speed over the ground along its travel (m/s).
    pub hub_vx_m_s: f64,
    /// The rotation rate (rad/s, + rolling forward).
    pub omega_rad_s: f64,
    /// The heading's angle from the travel (deg, + the travel toward the body's left).
    pub slip_angle_deg: f64,
    /// The steady state; for a run the sand does not bear within the body's height, the body
    /// buried to its top, `load_n` the most the sand bears there.
    pub steady: crate::model::Steady,
    /// Whether the sand bears the run's load within the body's height (always, for a run held
    /// at a given sinkage).
    pub borne: bool,
    /// The file's line of the run.
    pub line: usize,
}

/// A file of runs with each run's steady state.
#[derive(Debug, Clone, PartialEq)]
pub struct SteadyTable {
    /// The input's columns, in order; one named as an output is `measured_<name>` here.
    pub headers: Vec<String>,
    /// What the runs were solved for.
    pub solve: Solve,
    /// The runs, in the file's order.
    pub runs: Vec<SteadyRun>,
    /// Columns of the band of the sand's trial-to-trial scatter ([`steady_runs_in_band`]), each
    /// with a value per run: written after the outputs.
    pub band: Vec<(String, Vec<f64>)>,
}

/// How well a predicted column follows a measured one over the runs that have it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Agreement {
    /// The output column.
    pub column: &'static str,
    /// The runs' column it is compared with.
    pub measured: String,
    /// Runs with a measured value.
    pub runs: usize,
    /// R^2 of the prediction against the measurement.
    pub r2: f64,
    /// RMS error, in the column's unit.
    pub rmse: f64,
}

/// The runs that share one value of a column, their measured and predicted means.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Group {
    /// The column's value, as written.
    pub value: String,
    /// How many runs have it.
    pub runs: usize,
    /// Per output the runs also measured: the column, the measured mean and the predicted mean.
    pub means: Vec<(&'static str, f64, f64)>,
}

/// A run's steady state and whether the sand bears it: where it does not within the body's
/// height (`solved` is [`SteadyError::TooHeavy`]), the body buried to its top, its forces there
/// and the most the sand bears as its load, `false`. A bearing that is no number, or any other
/// error, stays an error.
pub fn borne_or_deepest(
    body: &Body,
    stress: &Stress,
    drive: &Drive,
    solved: Result<Steady, SteadyError>,
) -> Result<(Steady, bool), SteadyError> {
    match solved {
        Err(SteadyError::TooHeavy { max_load_n, .. }) if max_load_n.is_finite() => {
            let deepest = state_at_sinkage(body, stress, body.height_m(), drive)?;
            Ok((
                Steady {
                    load_n: max_load_n,
                    ..deepest
                },
                false,
            ))
        }
        other => Ok((other?, true)),
    }
}

/// Every run of `text` (the CSV of runs named `file`) brought to its steady state for `body` in
/// the medium `law`. A run with a value missing or no number is an error naming the run and the
/// value: a table of runs is a test's record, and a run left out would be lost without a word.
/// A run whose load the sand does not bear within the body's height is a row all the same,
/// the body buried to its top and `borne` false ([`SteadyTable::not_borne`]).
pub fn steady_runs(
    file: &Path,
    text: &str,
    body: &Body,
    law: &RftLaw,
    solve: &Solve,
) -> Result<SteadyTable> {
    let name = file.display().to_string();
    let (mut rdr, mut headers) = crate::session::files::csv_table(&name, text)?;
    let col = |c: &str| headers.iter().position(|h| h == c);
    let mut index = [None; 4];
    for (i, c) in INPUT_COLUMNS.iter().enumerate() {
        index[i] = col(c);
        if index[i].is_none() && !(i == 0 && *solve != Solve::Sinkage) {
            bail!(
                "{name}: header lacks column {c:?} (a run has {}; found: {})",
                INPUT_COLUMNS.join(", "),
                headers.join(",")
            );
        }
    }
    if headers.iter().any(|h| h == "borne") {
        bail!(
            "{name}: column \"borne\" is one terzaghi steady writes (whether the sand bears the run); rename it"
        );
    }
    for h in headers.iter_mut() {
        if OUTPUT_COLUMNS.contains(&h.as_str()) {
            *h = format!("measured_{h}");
        }
    }
    for (i, h) in headers.iter().enumerate() {
        if headers[..i].contains(h) {
            bail!(
                "{name}: column {h:?} appears twice (a measured column named as an output, sinkage_m say, is kept as measured_sinkage_m)"
            );
        }
    }
    let at_column = match solve {
        Solve::Sinkage => None,
        Solve::AtSinkage(c) => {
            let renamed = format!("measured_{c}");
            let c = if OUTPUT_COLUMNS.contains(&c.as_str()) {
                &renamed
            } else {
                c
            };
            Some((
                c.clone(),
                headers.iter().position(|h| h == c).with_context(|| {
                    format!(
                        "{name}: no column {c:?} to take the sinkage from (found: {})",
                        headers.join(",")
                    )
                })?,
            ))
        }
    };
    let stress = Stress {
        coefficients: &law.coefficients,
        depth_law: Some(&law.depth_law),
        speed_law: law.speed_law.as_ref(),
        sheared: law.sheared.as_ref(),
    };
    let mut runs = Vec::new();
    for (row, record) in rdr.records().enumerate() {
        let record = record.with_context(|| format!("{name}: run {} is not CSV", row + 1))?;
        if runs.len() == MAX_RUNS {
            bail!("{name}: more than {MAX_RUNS} runs");
        }
        let line = record.position().map_or(row + 2, |p| p.line() as usize);
        let parse = |what: &str, i: usize| -> Result<f64> {
            crate::session::files::csv_number(&name, line, what, record.get(i).unwrap_or(""))
        };
        let value = |i: usize| parse(INPUT_COLUMNS[i], index[i].unwrap_or(usize::MAX));
        let (hub_vx_m_s, omega_rad_s, slip_angle_deg) = (value(1)?, value(2)?, value(3)?);
        let drive = Drive {
            speed_m_s: hub_vx_m_s,
            omega_rad_s,
            slip_angle_rad: slip_angle_deg.to_radians(),
        };
        let (load_n, steady) = match &at_column {
            None => {
                let load_n = value(0)?;
                let s = steady_sinkage(body, &stress, load_n, &drive);
                (Some(load_n), s)
            }
            Some((c, i)) => {
                let sinkage_m = parse(c, *i)?;
                (None, state_at_sinkage(body, &stress, sinkage_m, &drive))
            }
        };
        let (steady, borne) = borne_or_deepest(body, &stress, &drive, steady)
            .with_context(|| format!("{name} line {line}"))?;
        runs.push(SteadyRun {
            borne,
            line,
            fields: record.iter().map(str::to_string).collect(),
            load_n,
            hub_vx_m_s,
            omega_rad_s,
            slip_angle_deg,
            steady,
        });
    }
    if runs.is_empty() {
        bail!("{name}: no runs (a header and no rows)");
    }
    Ok(SteadyTable {
        headers,
        runs,
        solve: solve.clone(),
        band: Vec::new(),
    })
}

/// [`steady_runs`] with the band of the sand's trial-to-trial scatter (`(low, high)`, the
/// medium file's [`crate::medium_file::MediumFile::band`]): each run solved again in sand at the
/// band's low and at its high scale, and its columns added: `sinkage_low_m`, `sinkage_high_m`,
/// `drawbar_low_n`, `drawbar_high_n` where the sinkage is solved for (low: the softer sand, the
/// deeper sinkage; a run the softer sand does not bear has the body buried to its top there),
/// `load_borne_low_n`, `load_borne_high_n` where it is held.
pub fn steady_runs_in_band(
    file: &Path,
    text: &str,
    body: &Body,
    law: &RftLaw,
    solve: &Solve,
    (low, high): (f64, f64),
) -> Result<SteadyTable> {
    let mut table = steady_runs(file, text, body, law, solve)?;
    let ends = [
        (
            "low",
            steady_runs(file, text, body, &law.scaled(low), solve)?,
        ),
        (
            "high",
            steady_runs(file, text, body, &law.scaled(high), solve)?,
        ),
    ];
    let columns: &[(&str, &str, usize)] = match solve {
        Solve::Sinkage => &[("sinkage", "m", 0), ("drawbar", "n", 1)],
        Solve::AtSinkage(_) => &[("load_borne", "n", 4)],
    };
    for &(name, unit, k) in columns {
        for (end, t) in &ends {
            table.band.push((
                format!("{name}_{end}_{unit}"),
                t.runs.iter().map(|r| outputs(&r.steady)[k]).collect(),
            ));
        }
    }
    Ok(table)
}

/// A run's outputs, in the order of [`OUTPUT_COLUMNS`].
fn outputs(s: &crate::model::Steady) -> [f64; 5] {
    [s.sinkage_m, s.drawbar_n, s.side_n, s.torque_nm, s.load_n]
}

impl SteadyTable {
    /// Each output with a measured counterpart in the runs that is not the run's own input:
    /// its index in [`OUTPUT_COLUMNS`], the measured column's index, and its name.
    fn measured(&self) -> Vec<(usize, usize, &'static str)> {
        OUTPUT_COLUMNS
            .iter()
            .enumerate()
            .filter_map(|(k, c)| {
                let name = match (&self.solve, *c) {
                    // Given: the sinkage where it is held, the load where it is solved for.
                    (Solve::AtSinkage(_), "sinkage_m") | (Solve::Sinkage, "load_borne_n") => {
                        return None;
                    }
                    (Solve::AtSinkage(_), "load_borne_n") => "load_n".to_string(),
                    _ => format!("measured_{c}"),
                };
                self.headers
                    .iter()
                    .position(|h| *h == name)
                    .map(|j| (k, j, *c))
            })
            .collect()
    }

    /// The runs the sand does not bear within the body's height.
    pub fn not_borne(&self) -> Vec<&SteadyRun> {
        self.runs.iter().filter(|r| !r.borne).collect()
    }

    /// The table as CSV: the runs' columns, then [`OUTPUT_COLUMNS`] and `borne` (`true`, or
    /// `false` for a run the sand does not bear within the body's height).
    pub fn to_csv(&self) -> Result<Vec<u8>> {
        let mut w = csv::Writer::from_writer(Vec::new());
        let mut head = self.headers.clone();
        head.extend(OUTPUT_COLUMNS.iter().map(|s| s.to_string()));
        head.push("borne".to_string());
        head.extend(self.band.iter().map(|(c, _)| c.clone()));
        w.write_record(&head)?;
        for (i, r) in self.runs.iter().enumerate() {
            let s = &r.steady;
            let mut rec = r.fields.clone();
            rec.extend(outputs(s).iter().map(|v| v.to_string()));
            rec.push(r.borne.to_string());
            rec.extend(self.band.iter().map(|(_, v)| v[i].to_string()));
            w.write_record(&rec)?;
        }
        w.into_inner().map_err(|e| anyhow::anyhow!("{e}"))
    }

    /// The runs grouped by the value of `column` (numeric order where every value is a number,
    /// else the order of first appearance), with the means of each output they measured.
    pub fn groups(&self, column: &str) -> Result<Vec<Group>> {
        let Some(i) = self.headers.iter().position(|h| h == column) else {
            bail!(
                "no column {column:?} to group by (the runs have: {})",
                self.headers.join(",")
            );
        };
        let measured = self.measured();
        let mut values: Vec<&str> = Vec::new();
        for r in &self.runs {
            if !values.contains(&r.fields[i].as_str()) {
                values.push(&r.fields[i]);
            }
        }
        if let Ok(mut numbers) = values
            .iter()
            .map(|v| v.parse::<f64>().map(|x| (x, *v)))
            .collect::<Result<Vec<_>, _>>()
        {
            numbers.sort_by(|a, b| a.0.total_cmp(&b.0));
            values = numbers.into_iter().map(|(_, v)| v).collect();
        }
        Ok(values
            .into_iter()
            .map(|value| {
                let runs: Vec<&SteadyRun> =
                    self.runs.iter().filter(|r| r.fields[i] == value).collect();
                let means = measured
                    .iter()
                    .map(|&(k, j, c)| {
                        let pairs: Vec<(f64, f64)> = runs
                            .iter()
                            .filter_map(|r| {
                                let m =
                                    r.fields[j].parse::<f64>().ok().filter(|v| v.is_finite())?;
                                let s = &r.steady;
                                Some((m, outputs(s)[k]))
                            })
                            .collect();
                        let n = pairs.len().max(1) as f64;
                        (
                            c,
                            pairs.iter().map(|p| p.0).sum::<f64>() / n,
                            pairs.iter().map(|p| p.1).sum::<f64>() / n,
                        )
                    })
                    .collect();
                Group {
                    value: value.to_string(),
                    runs: runs.len(),
                    means,
                }
            })
            .collect())
    }

    /// R^2 and RMS error of each output the runs also measured (`measured_<name>`, numbers
    /// only: a run with the field empty is left out of that column's figure).
    pub fn agreement(&self) -> Vec<Agreement> {
        let mut out = Vec::new();
        for (k, i, column) in self.measured() {
            let (mut pred, mut meas) = (Vec::new(), Vec::new());
            for r in &self.runs {
                if let Some(m) = r.fields[i].parse::<f64>().ok().filter(|v| v.is_finite()) {
                    let s = &r.steady;
                    pred.push(outputs(s)[k]);
                    meas.push(m);
                }
            }
            if pred.len() < 2 {
                continue;
            }
            let fit = crate::ident::metrics::component_fit(&pred, &meas);
            // Measured values so large that their squares overflow give no figure.
            if !(fit.r2.is_finite() && fit.rmse.is_finite()) {
                continue;
            }
            out.push(Agreement {
                column,
                measured: self.headers[i].clone(),
                runs: pred.len(),
                r2: fit.r2,
                rmse: fit.rmse,
            });
        }
        out
    }
}
