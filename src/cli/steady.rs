//! `terzaghi steady`: a wheel's or a foot's steady sinkage, drawbar pull, side force and drive
//! torque under each run's load, speed, rotation rate and slip angle (the work is
//! [`terzaghi::session::steady`]).

use super::print_out;
use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use std::path::PathBuf;
use terzaghi::medium_file::MediumFile;
use terzaghi::model::{Body, Grousers};
use terzaghi::session::steady::{
    BodySpec, INPUT_COLUMNS, OUTPUT_COLUMNS, Solve, build_body, steady_runs,
};

/// The body's shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum BodyShape {
    /// A wheel: --radius-m, --width-m, and grousers if --grouser-count is given.
    Wheel,
    /// A disc foot, its axis vertical: --radius-m, --thickness-m.
    Disc,
    /// A sphere foot: --radius-m.
    Sphere,
    /// A box foot: --size-m X,Y,Z (along the heading, across it, up).
    Box,
    /// A closed triangle mesh: --mesh-file (STL, binary or ASCII), --mesh-scale.
    Mesh,
}

impl BodyShape {
    /// Its name, as the flag spells it (`wheel`, `disc`, ...).
    pub fn name(self) -> String {
        self.to_possible_value()
            .map_or(String::new(), |v| v.get_name().to_string())
    }
}

/// What a body's shape takes (`--shape wheel|disc|sphere|box|mesh`), but its width: `terzaghi
/// steady`'s and `terzaghi predict`'s.
#[derive(Debug, Clone, Args)]
pub struct BodyArgs {
    /// The wheel's rim radius, or the disc's or sphere's (m).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub radius_m: Option<f64>,
    /// The disc's thickness (m).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub thickness_m: Option<f64>,
    /// The box's size along the heading, across it and up (m).
    #[arg(
        long,
        value_name = "X,Y,Z",
        value_delimiter = ',',
        allow_negative_numbers = true
    )]
    pub size_m: Option<Vec<f64>>,
    /// The STL file of a closed mesh, its hub at the file's origin, x the heading, y to the
    /// left, z up.
    #[arg(long, value_name = "FILE.stl")]
    pub mesh_file: Option<PathBuf>,
    /// Metres per unit of the mesh file (default 1: metres, as ROS gives meshes; 0.001 for a
    /// CAD part in millimetres).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub mesh_scale: Option<f64>,
    /// A foot's or a mesh's elements: their longest edge (m; default 0.002).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub element_m: Option<f64>,
    /// Grousers (lugs): how many, evenly spaced around the rim.
    #[arg(long, value_name = "N", requires_all = ["grouser_height_m", "grouser_thickness_m"])]
    pub grouser_count: Option<usize>,
    /// How far each grouser stands out of the rim (m).
    #[arg(
        long,
        value_name = "M",
        requires = "grouser_count",
        allow_negative_numbers = true
    )]
    pub grouser_height_m: Option<f64>,
    /// Each grouser's thickness along the rim (m).
    #[arg(
        long,
        value_name = "M",
        requires = "grouser_count",
        allow_negative_numbers = true
    )]
    pub grouser_thickness_m: Option<f64>,
    /// Elements of a wheel's rim (at least 360; default 720).
    #[arg(long, value_name = "N")]
    pub rim_elements: Option<usize>,
}

impl BodyArgs {
    /// The body of `shape` and `width_m` in words, as the flags give it (`wheel radius 0.058 m
    /// width 0.05 m with 12 grousers`).
    pub fn text(&self, shape: BodyShape, width_m: Option<f64>) -> String {
        let mut text = shape.name();
        if let Some(r) = self.radius_m {
            text += &format!(" radius {r} m");
        }
        if let Some(w) = width_m {
            text += &format!(" width {w} m");
        }
        if let Some(n) = self.grouser_count {
            text += &format!(" with {n} grousers");
        }
        text
    }

    /// The flags given that only a body takes.
    pub fn given(&self) -> Vec<&'static str> {
        [
            ("--radius-m", self.radius_m.is_some()),
            ("--thickness-m", self.thickness_m.is_some()),
            ("--size-m", self.size_m.is_some()),
            ("--mesh-file", self.mesh_file.is_some()),
            ("--mesh-scale", self.mesh_scale.is_some()),
            ("--element-m", self.element_m.is_some()),
            ("--grouser-count", self.grouser_count.is_some()),
            ("--rim-elements", self.rim_elements.is_some()),
        ]
        .into_iter()
        .filter_map(|(flag, given)| given.then_some(flag))
        .collect()
    }

    /// The body of `shape` (`wheel`, `disc`, ...) and `width_m` (a wheel's) the flags describe;
    /// a flag of another shape is an error naming it.
    pub fn body(&self, shape: &str, width_m: Option<f64>) -> Result<Body> {
        let grousers = match (
            self.grouser_count,
            self.grouser_height_m,
            self.grouser_thickness_m,
        ) {
            (Some(count), Some(height_m), Some(thickness_m)) => Some(Grousers {
                count,
                height_m,
                thickness_m,
            }),
            _ => None,
        };
        build_body(
            &BodySpec {
                shape: shape.to_string(),
                radius_m: self.radius_m,
                width_m,
                thickness_m: self.thickness_m,
                size_m: self.size_m.clone(),
                mesh_file: self.mesh_file.clone(),
                mesh_scale: self.mesh_scale,
                element_m: self.element_m,
                grousers,
                rim_elements: self.rim_elements,
            },
            |name| format!("--{}", name.replace('_', "-")),
        )
    }
}

#[derive(Debug, Args)]
pub struct SteadyArgs {
    /// The runs: a CSV with columns load_n (N, the load the sand bears), hub_vx_m_s (the hub's
    /// speed over the ground along its travel), omega_rad_s (+ rolling forward) and
    /// slip_angle_deg (the heading's angle from the travel, + the travel toward the wheel's
    /// left); other columns are passed through, a measured sinkage_m, drawbar_n, side_n or
    /// torque_nm as measured_<name>, and compared.
    #[arg(value_name = "RUNS.csv")]
    pub runs: PathBuf,
    /// The body.
    #[arg(long, value_enum, default_value = "wheel")]
    pub shape: BodyShape,
    /// The wheel's width (m).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub width_m: Option<f64>,
    #[command(flatten)]
    pub body: BodyArgs,
    /// The medium: a medium file (terzaghi calibrate): its RFT shape, law in depth and speed
    /// law where it was calibrated on intrusion tests, else poppy_lp's shape under its
    /// rft_depth_power law.
    #[arg(long, value_name = "FILE")]
    pub medium_file: PathBuf,
    /// Hold each run at the sinkage (m) of this column instead of solving for it (a measured
    /// sinkage_m, say): the load the sand bears there is the outcome (load_borne_n, compared
    /// with the run's load_n where it has one), to tell which force the model misses.
    #[arg(long, value_name = "COLUMN")]
    pub at_sinkage: Option<String>,
    /// Also print, per value of this column of the runs (a slip, say), the measured and
    /// predicted means of each output the runs measured.
    #[arg(long, value_name = "COLUMN")]
    pub group_by: Option<String>,
    /// Add the band of the sand's trial-to-trial scatter from --medium-file (terzaghi
    /// calibrate writes it from three plate tests or more): each run solved again in sand at
    /// the band's low and high scale, between which 90 % of further trials of the sand so
    /// prepared lie (columns sinkage_low_m, sinkage_high_m, drawbar_low_n, drawbar_high_n; with
    /// --at-sinkage load_borne_low_n, load_borne_high_n).
    #[arg(long)]
    pub band: bool,
    /// Write the runs with their steady states here (CSV); without, to standard output.
    #[arg(short = 'o', long, value_name = "OUT.csv")]
    pub out: Option<PathBuf>,
}

pub fn run(a: SteadyArgs) -> Result<()> {
    let medium = MediumFile::read(&a.medium_file)?;
    let law = medium.rft_law(None)?;
    let body = a.body.body(&a.shape.name(), a.width_m)?;
    let text = std::fs::read_to_string(&a.runs)
        .with_context(|| format!("cannot read {}", a.runs.display()))?;
    let solve = match &a.at_sinkage {
        Some(c) => Solve::AtSinkage(c.clone()),
        None => Solve::Sinkage,
    };
    let table = if a.band {
        let band = medium.band(&a.medium_file)?;
        terzaghi::session::steady::steady_runs_in_band(&a.runs, &text, &body, &law, &solve, band)?
    } else {
        steady_runs(&a.runs, &text, &body, &law, &solve)?
    };
    let csv = table.to_csv()?;
    match &a.out {
        Some(out) => {
            std::fs::write(out, &csv).with_context(|| format!("cannot write {}", out.display()))?
        }
        None => print_out(std::str::from_utf8(&csv)?)?,
    }
    let mut summary = format!(
        "{} runs of {}: {} from {}; medium {:?}, RFT's shape {}\n",
        table.runs.len(),
        a.runs.display(),
        OUTPUT_COLUMNS.join(", "),
        match &a.at_sinkage {
            None => INPUT_COLUMNS.join(", "),
            Some(c) => format!("{c} (held there), {}", INPUT_COLUMNS[1..].join(", ")),
        },
        medium.name,
        medium.rft_shape_text()
    );
    for g in table.agreement() {
        summary += &format!(
            "  {:<12} R^2 {:8.3}   RMSE {:.4}   against {} over {} runs\n",
            g.column, g.r2, g.rmse, g.measured, g.runs
        );
    }
    if let Some(column) = &a.group_by {
        let groups = table.groups(column)?;
        let w = column.len().max(10);
        // Lengths in mm, forces in N.
        let shown = |c: &str| {
            c.strip_suffix("_m")
                .map_or(c.to_string(), |s| format!("{s}_mm"))
        };
        if let Some(first) = groups.first() {
            summary += &format!("{column:>w$}  runs");
            for (c, _, _) in &first.means {
                summary += &format!("  {:>23}", format!("{} meas / pred", shown(c)));
            }
            summary += "\n";
        }
        for g in &groups {
            summary += &format!("{:>w$}  {:>4}", g.value, g.runs);
            for (c, m, p) in &g.means {
                let k = if c.ends_with("_m") { 1e3 } else { 1.0 };
                summary += &format!("  {:>11.2} / {:>9.2}", m * k, p * k);
            }
            summary += "\n";
        }
    }
    if let (true, Some(b)) = (a.band, &medium.scatter) {
        summary += &format!("  band: {}\n", b.text());
    }
    if let Some(b) = &medium.sheared_bearing {
        summary += &format!("  {}\n", b.text());
        if b.slip_sweep.as_ref().is_some_and(|w| {
            terzaghi::session::files::same_file(std::path::Path::new(&w.file), &a.runs)
        }) {
            summary += "  (in sample: the sheared bearing was fitted on these runs)\n";
        }
    }
    let not_borne = table.not_borne();
    for r in &not_borne {
        summary += &format!(
            "  not borne: {} line {}: the sand bears at most {:.1} N of this body, buried to its top ({:.4} m), under a load of {} N (its row says borne false)\n",
            a.runs.display(),
            r.line,
            r.steady.load_n,
            r.steady.sinkage_m,
            r.load_n.unwrap_or(f64::NAN)
        );
    }
    if let Some(out) = &a.out {
        summary += &format!("written: {}\n", out.display());
    }
    eprint!("{summary}");
    if !not_borne.is_empty() {
        return Err(terzaghi::session::NotBorne(format!(
            "{} of {} runs of {} are not borne within the body's height (every run was written; exit code 3)",
            not_borne.len(),
            table.runs.len(),
            a.runs.display()
        ))
        .into());
    }
    Ok(())
}
