//! `terzaghi predict`: one row per attack angle (or, for a plate pushed down, per depth).

use super::steady::BodyArgs;
use super::{MediumArgs, WidthArgs, print_out};
use anyhow::{Result, bail};
use clap::{Args, ValueEnum};
use serde::Serialize;
use terzaghi::model::{ForceModel, Prediction};

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ModelKind {
    /// Improved Terzaghi model with the fitting width b_e = b_k b a^(-beta).
    Improved,
    /// Conventional Terzaghi model (b_e = b).
    Conventional,
    /// Resistive force theory (Li, Zhang & Goldman 2013).
    Rft,
    /// A horizontal plate pushed straight down, by the plate-sinkage law of --medium-file (a
    /// disc when --length-m equals --width-m, else a rectangle); rows per --depth-m, loading.
    Sinkage,
}

/// The leg's shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Shape {
    /// A flat plate.
    Plate,
    /// RHex's C-leg: an arc whose chord is --length-m (RFT only).
    CLeg,
    /// Any mid-line, given by --profile (RFT only).
    Polyline,
    /// A wheel about the hip, its hub: --radius-m, --width-m, and grousers if --grouser-count
    /// is given (RFT only, as every body).
    Wheel,
    /// A disc foot at the hip, its axis vertical: --radius-m, --thickness-m.
    Disc,
    /// A sphere foot at the hip: --radius-m.
    Sphere,
    /// A box foot at the hip: --size-m X,Y,Z (along the heading, across it, up).
    Box,
    /// A closed triangle mesh about the hip: --mesh-file (STL), --mesh-scale.
    Mesh,
}

impl Shape {
    /// A body's shape name (`wheel`, ...), or `None` for a leg's mid-line.
    fn body_name(self) -> Option<&'static str> {
        match self {
            Shape::Plate | Shape::CLeg | Shape::Polyline => None,
            Shape::Wheel => Some("wheel"),
            Shape::Disc => Some("disc"),
            Shape::Sphere => Some("sphere"),
            Shape::Box => Some("box"),
            Shape::Mesh => Some("mesh"),
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Format {
    Csv,
    Json,
}

#[derive(Debug, Args)]
pub struct PredictArgs {
    /// Which model to evaluate.
    #[arg(long, value_enum, default_value = "improved")]
    pub model: ModelKind,
    /// Plate length from the hip axis to the tip (m); a body's reach below its hub comes from
    /// its shape (given, it must agree).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub length_m: Option<f64>,
    /// Plate width (m), or a wheel's; a foot's comes from its shape (given, it must agree).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub width_m: Option<f64>,
    /// Height of the hip axis (a body's hub) above the free surface (m); 0 puts the axis on
    /// the surface; a body's hub may be below it (negative).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub hip_height_m: f64,
    #[command(flatten)]
    pub medium: MediumArgs,
    #[command(flatten)]
    pub width: WidthArgs,
    /// RFT: number of elements over a leg's submerged length (default 100; a body is cut by
    /// --element-m or --rim-elements).
    #[arg(long, value_name = "N")]
    pub rft_elements: Option<usize>,
    /// A planar leg (plate, C-leg, polyline) takes the medium file's bearing of sheared sand
    /// (a body always does): its lift, and the lift's hip torque, times the share the
    /// resultant's lean leaves. Off by default: a leg turning through fresh sand loses lift it
    /// keeps (the DEM bed's C-leg, docs/bodies.md).
    #[arg(long)]
    pub planar_sheared_bearing: bool,
    /// RFT coefficients: poppy_lp, poppy_cp, poppy_lp_grid (measured) or generic (needs
    /// --rft-zeta). Default: the medium preset's, if it has one.
    #[arg(long, value_name = "SET")]
    pub rft_coeffs: Option<String>,
    /// RFT: the medium's scale factor zeta for the generic coefficients (N/cm^3).
    #[arg(long, value_name = "N_CM3", allow_negative_numbers = true)]
    pub rft_zeta: Option<f64>,
    /// The leg's shape (curved legs are RFT's).
    #[arg(long, value_enum, default_value = "plate")]
    pub shape: Shape,
    /// --shape c-leg: the arc's radius (m; default half of --length-m, a half circle).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub c_leg_radius_m: Option<f64>,
    /// --shape c-leg: the arc's span (deg; default 180).
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub c_leg_span_deg: Option<f64>,
    /// --shape polyline: the leg's mid-line S0,Q0,S1,Q1,... in metres from the hip (S along
    /// the chord toward the tip, Q toward the travel), as the node's <leg>.profile.
    #[arg(long, value_name = "S0,Q0,S1,Q1,...", allow_hyphen_values = true)]
    pub profile: Option<String>,
    /// --model sinkage: the medium file (written by terzaghi calibrate); --model rft: a medium
    /// file calibrated from intrusion tests, whose measured RFT shape, depth law and speed law
    /// RFT takes, or one of the rft_depth_power law, whose scale and depth exponent RFT's
    /// stresses take on poppy_lp's shape.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["medium", "unit_weight_n_m3"])]
    pub medium_file: Option<std::path::PathBuf>,
    /// Attack angles in degrees: FROM:TO:STEP (both ends included) or a single angle.
    #[arg(
        long,
        value_name = "FROM:TO:STEP",
        allow_hyphen_values = true,
        required_unless_present = "depth_m",
        conflicts_with = "depth_m"
    )]
    pub beta_deg: Option<String>,
    /// --model sinkage: the plate's depths below the surface (m), FROM:TO:STEP or one depth.
    #[arg(long, value_name = "FROM:TO:STEP", allow_hyphen_values = true)]
    pub depth_m: Option<String>,
    #[command(flatten)]
    pub body: BodyArgs,
    /// The hip's velocity along the robot's heading (m/s, + forward). With any of the four
    /// motion flags each row is predicted with the hip so moving (the others 0): RFT on each
    /// element's own velocity. Without, a leg turns quasi-statically about a still hip and a
    /// body is held (the sand's reaction to it, no drag).
    #[arg(long, value_name = "M_S", allow_negative_numbers = true)]
    pub forward_m_s: Option<f64>,
    /// The hip's velocity to the robot's left (m/s); a leg or body moving sideways adds the
    /// columns side_n, roll_moment_nm and yaw_moment_nm.
    #[arg(long, value_name = "M_S", allow_negative_numbers = true)]
    pub lateral_m_s: Option<f64>,
    /// The hip's velocity up (m/s; a body pressed into the sand: negative).
    #[arg(long, value_name = "M_S", allow_negative_numbers = true)]
    pub up_m_s: Option<f64>,
    /// The leg's rotation rate about its axis (rad/s, + as the attack angle grows: a wheel
    /// rolling forward).
    #[arg(long, value_name = "RAD_S", allow_negative_numbers = true)]
    pub omega_rad_s: Option<f64>,
    /// Add the band of the sand's trial-to-trial scatter from --medium-file (terzaghi
    /// calibrate writes it from three plate tests or more): drag, lift and hip torque at the
    /// band's low and high scale (columns *_low_*, *_high_*), between which 90 % of further
    /// trials of the sand so prepared lie. At a given depth every stress scales with the sand's
    /// scale, so each is the prediction times the band's scale.
    #[arg(long, requires = "medium_file")]
    pub band: bool,
    /// Output format.
    #[arg(long, value_enum, default_value = "csv")]
    pub format: Format,
}

impl PredictArgs {
    /// The hip's motion at `height_m`, where a motion flag is given.
    fn motion(&self) -> Option<terzaghi::model::HipMotion> {
        let flags = [
            self.forward_m_s,
            self.lateral_m_s,
            self.up_m_s,
            self.omega_rad_s,
        ];
        flags
            .iter()
            .any(Option::is_some)
            .then(|| terzaghi::model::HipMotion {
                forward_m_s: self.forward_m_s.unwrap_or(0.0),
                lateral_m_s: self.lateral_m_s.unwrap_or(0.0),
                up_m_s: self.up_m_s.unwrap_or(0.0),
                omega_rad_s: self.omega_rad_s.unwrap_or(0.0),
                ..terzaghi::model::HipMotion::still(self.hip_height_m)
            })
    }

    /// Whether the rows carry the side force and the moments about the heading and the
    /// vertical: a body's, or a leg's moving sideways.
    fn full_wrench(&self) -> bool {
        self.shape.body_name().is_some() || self.lateral_m_s.is_some_and(|v| v != 0.0)
    }
}

/// The speed a sinkage plate of `--depth-m` is pressed at (m/s): loading.
const LOADING_M_S: f64 = 1e-3;

/// Most rows one call prints.
const MAX_ROWS: usize = 1_000_000;

/// Parses `FROM:TO:STEP` or a single angle into the list of angles (degrees).
pub fn parse_range(text: &str) -> Result<Vec<f64>> {
    parse_range_of("--beta-deg", text)
}

/// [`parse_range`] for the values of `flag`.
fn parse_range_of(flag: &str, text: &str) -> Result<Vec<f64>> {
    let parts: Vec<&str> = text.split(':').collect();
    let num = |s: &str| -> Result<f64> {
        match s.trim().parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => bail!("{flag} {text:?}: {s:?} is not a finite number"),
        }
    };
    match parts.as_slice() {
        [one] => Ok(vec![num(one)?]),
        [from, to, step] => {
            let (from, to, step) = (num(from)?, num(to)?, num(step)?);
            if step == 0.0 || (to - from) * step < 0.0 {
                bail!("{flag} {text:?}: STEP must be non-zero and lead from FROM to TO");
            }
            let n = ((to - from) / step + 1e-9).floor() + 1.0;
            if n > MAX_ROWS as f64 {
                bail!("{flag} {text:?} gives {n} values; at most {MAX_ROWS}");
            }
            // Rounded to 1e-9 deg so that 0.1-steps print as 0.3, not 0.30000000000000004.
            Ok((0..n as usize)
                .map(|i| ((from + i as f64 * step) * 1e9).round() / 1e9)
                .collect())
        }
        _ => bail!("{flag} {text:?}: expected FROM:TO:STEP or a single value"),
    }
}

#[derive(Serialize)]
struct Row {
    beta_deg: f64,
    submerged_m: f64,
    depth_m: f64,
    drag_n: f64,
    lift_n: f64,
    hip_torque_nm: f64,
    regime: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    side_n: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    roll_moment_nm: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    yaw_moment_nm: Option<f64>,
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    band: Option<BandColumns>,
}

/// A row's forces at the band's low and high scale.
#[derive(Serialize)]
struct BandColumns {
    drag_low_n: f64,
    drag_high_n: f64,
    lift_low_n: f64,
    lift_high_n: f64,
    hip_torque_low_nm: f64,
    hip_torque_high_nm: f64,
}

impl BandColumns {
    fn of(p: &Prediction, (low, high): (f64, f64)) -> BandColumns {
        let (lo, hi) = (p.scaled(low), p.scaled(high));
        BandColumns {
            drag_low_n: lo.drag_n,
            drag_high_n: hi.drag_n,
            lift_low_n: lo.lift_n,
            lift_high_n: hi.lift_n,
            hip_torque_low_nm: lo.hip_torque_nm,
            hip_torque_high_nm: hi.hip_torque_nm,
        }
    }

    const HEADER: &str =
        "drag_low_n,drag_high_n,lift_low_n,lift_high_n,hip_torque_low_nm,hip_torque_high_nm";

    fn values(&self) -> [f64; 6] {
        [
            self.drag_low_n,
            self.drag_high_n,
            self.lift_low_n,
            self.lift_high_n,
            self.hip_torque_low_nm,
            self.hip_torque_high_nm,
        ]
    }
}

pub fn build_model(a: &PredictArgs) -> Result<ForceModel> {
    use terzaghi::model_spec::LegShape;
    let body = match a.shape.body_name() {
        Some(name) => Some(
            a.body
                .body(name, a.width_m.filter(|_| a.shape == Shape::Wheel))?,
        ),
        None => {
            if let Some(flag) = a.body.given().first() {
                bail!("{flag} is for a body (--shape wheel, disc, sphere, box or mesh)");
            }
            None
        }
    };
    if body.is_some() && a.rft_elements.is_some() {
        bail!(
            "--rft-elements is for a leg's mid-line: a body is cut by --element-m or --rim-elements"
        );
    }
    let shape = match (a.shape, &a.profile, body) {
        (_, Some(_), _) if a.shape != Shape::Polyline => bail!("--profile is for --shape polyline"),
        (_, _, Some(body)) => LegShape::Body(Box::new(body)),
        (Shape::Plate, None, None) => LegShape::Plate,
        (Shape::CLeg, None, None) => LegShape::CLeg {
            radius_m: a.c_leg_radius_m,
            span_deg: a.c_leg_span_deg,
        },
        (Shape::Polyline, Some(text), None) => LegShape::Polyline {
            line: parse_profile(text)?,
        },
        (Shape::Polyline, None, None) => {
            bail!("--shape polyline needs --profile S0,Q0,S1,Q1,... (the leg's mid-line in metres)")
        }
        (_, _, None) => unreachable!("every body shape has a body"),
    };
    if a.shape != Shape::CLeg && (a.c_leg_radius_m.is_some() || a.c_leg_span_deg.is_some()) {
        bail!("--c-leg-radius-m and --c-leg-span-deg are for --shape c-leg");
    }
    if (a.model == ModelKind::Sinkage) != a.depth_m.is_some() {
        bail!("--depth-m goes with --model sinkage, --beta-deg with the turning leg's models");
    }
    // A body's reach and width are its shape's; given ones must agree.
    let (length_m, width_m) = match &shape {
        LegShape::Body(b) => {
            let (reach, width) = (b.reach_m(), b.width_m());
            for (flag, given, own) in [
                ("--length-m", a.length_m, reach),
                ("--width-m", a.width_m, width),
            ] {
                if let Some(v) = given.filter(|v| (v - own).abs() > 1e-9 * own.abs().max(1.0)) {
                    bail!(
                        "{flag} {v} is not the body's own ({own} m, from its shape): leave it out"
                    );
                }
            }
            (reach, width)
        }
        _ => match (a.length_m, a.width_m) {
            (Some(l), Some(w)) => (l, w),
            (None, _) => bail!("--length-m is needed (the leg's length from the hip axis, m)"),
            (_, None) => bail!("--width-m is needed (the leg's width, m)"),
        },
    };
    terzaghi::model_spec::ModelSpec {
        kind: match a.model {
            ModelKind::Improved => terzaghi::model_spec::ModelKind::Improved,
            ModelKind::Conventional => terzaghi::model_spec::ModelKind::Conventional,
            ModelKind::Rft => terzaghi::model_spec::ModelKind::Rft,
            ModelKind::Sinkage => terzaghi::model_spec::ModelKind::Sinkage,
        },
        length_m,
        width_m,
        // A body's hub may be in the sand (a foot sunk past its middle): its height is the
        // motion's (see run), the configured one at most the surface.
        hip_height_m: match a.shape.body_name() {
            Some(_) => a.hip_height_m.max(0.0),
            None => a.hip_height_m,
        },
        medium: terzaghi::model_spec::MediumSpec {
            file: a.medium_file.clone(),
            ..a.medium.spec()
        },
        b_k: a.width.b_k,
        a: a.width.a,
        rft_coeffs: a.rft_coeffs.clone(),
        rft_zeta: a.rft_zeta,
        rft_elements: a.rft_elements.unwrap_or(100),
        shape,
        planar_sheared_bearing: a.planar_sheared_bearing,
    }
    .build()
}

/// `S0,Q0,S1,Q1,...` as points; an odd count or a value that is no finite number is refused.
fn parse_profile(text: &str) -> Result<Vec<(f64, f64)>> {
    let v: Vec<f64> = text
        .split(',')
        .map(|s| match s.trim().parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => bail!("--profile {text:?}: {s:?} is not a finite number"),
        })
        .collect::<Result<_>>()?;
    if !v.len().is_multiple_of(2) {
        bail!(
            "--profile {text:?}: {} values, an odd count; give S,Q pairs",
            v.len()
        );
    }
    Ok(v.chunks(2).map(|p| (p[0], p[1])).collect())
}

pub fn run(a: PredictArgs) -> Result<()> {
    let model = build_model(&a)?;
    let band = match (&a.medium_file, a.band) {
        (Some(f), true) => {
            if !matches!(a.model, ModelKind::Sinkage | ModelKind::Rft) {
                bail!("--band is the medium file's scatter: it goes with --model sinkage or rft");
            }
            Some(terzaghi::medium_file::MediumFile::read(f)?.band(f)?)
        }
        _ => None,
    };
    // A medium's sheared bearing acts on a planar leg only when asked: say so.
    if a.shape.body_name().is_none()
        && !a.planar_sheared_bearing
        && let Some(f) = &a.medium_file
        && terzaghi::medium_file::MediumFile::read(f)?
            .sheared_bearing
            .is_some()
    {
        eprintln!(
            "note: {}'s sheared bearing is not applied to a planar leg unless --planar-sheared-bearing is given",
            f.display()
        );
    }
    // A sinkage plate at each depth, pressed down (loading); a turning leg at each angle.
    let (values, sinkage) = match (&a.depth_m, &a.beta_deg) {
        (Some(d), _) => (parse_range_of("--depth-m", d)?, true),
        (None, Some(b)) => (parse_range(b)?, false),
        (None, None) => bail!("give --beta-deg (or --depth-m with --model sinkage)"),
    };
    if sinkage && a.motion().is_some() {
        bail!(
            "--model sinkage presses the plate down at each --depth-m; the motion flags are for --beta-deg"
        );
    }
    // A body is evaluated at its hub's height as given, held where no motion is.
    let motion = a.motion().or_else(|| {
        a.shape
            .body_name()
            .map(|_| terzaghi::model::HipMotion::still(a.hip_height_m))
    });
    let full = a.full_wrench();
    let rows: Vec<Row> = values
        .iter()
        .map(|&v| {
            let (deg, p): (f64, Prediction) = if sinkage {
                let hip = terzaghi::model::HipMotion {
                    up_m_s: -LOADING_M_S,
                    ..terzaghi::model::HipMotion::still(-v)
                };
                (0.0, model.predict_moving(0.0, &hip)?)
            } else {
                match &motion {
                    Some(hip) => (v, model.predict_moving(v.to_radians(), hip)?),
                    None => (v, model.predict(v.to_radians())?),
                }
            };
            let side = |x: f64| full.then_some(x);
            Ok(Row {
                beta_deg: deg,
                submerged_m: p.submerged_m,
                depth_m: p.depth_m,
                drag_n: p.drag_n,
                lift_n: p.lift_n,
                hip_torque_nm: p.hip_torque_nm,
                regime: p.regime.as_str(),
                side_n: side(p.side_n),
                roll_moment_nm: side(p.roll_moment_nm),
                yaw_moment_nm: side(p.yaw_moment_nm),
                band: band.map(|b| BandColumns::of(&p, b)),
            })
        })
        .collect::<Result<_>>()?;
    let text = match a.format {
        Format::Json => serde_json::to_string_pretty(&rows)? + "\n",
        Format::Csv => {
            let mut s =
                String::from("beta_deg,submerged_m,depth_m,drag_n,lift_n,hip_torque_nm,regime");
            if full {
                s += ",side_n,roll_moment_nm,yaw_moment_nm";
            }
            if band.is_some() {
                s += ",";
                s += BandColumns::HEADER;
            }
            s += "\n";
            for r in &rows {
                s += &format!(
                    "{},{:.6},{:.6},{:.6},{:.6},{:.6},{}",
                    r.beta_deg,
                    r.submerged_m,
                    r.depth_m,
                    r.drag_n,
                    r.lift_n,
                    r.hip_torque_nm,
                    r.regime
                );
                for v in [r.side_n, r.roll_moment_nm, r.yaw_moment_nm]
                    .into_iter()
                    .flatten()
                {
                    s += &format!(",{v:.6}");
                }
                for v in r.band.iter().flat_map(BandColumns::values) {
                    s += &format!(",{v:.6}");
                }
                s += "\n";
            }
            s
        }
    };
    print_out(&text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_include_both_ends_and_reject_nonsense() {
        assert_eq!(
            parse_range("40:90:10").unwrap(),
            vec![40.0, 50.0, 60.0, 70.0, 80.0, 90.0]
        );
        assert_eq!(parse_range("0:0.3:0.1").unwrap(), vec![0.0, 0.1, 0.2, 0.3]);
        assert_eq!(parse_range("90:80:-5").unwrap(), vec![90.0, 85.0, 80.0]);
        assert_eq!(parse_range("-10").unwrap(), vec![-10.0]);
        for bad in [
            "",
            "a:b:c",
            "0:10:0",
            "0:10:-1",
            "0:1e9:1e-6",
            "nan",
            "1:2",
            "0:inf:1",
        ] {
            assert!(parse_range(bad).is_err(), "{bad}");
        }
    }
}
