//! `terzaghi calibrate`: a medium's plate-sinkage laws fitted to plate-sinkage tests, and RFT's
//! angular shape, law in depth and speed law fitted to intrusion tests in any direction; a
//! medium file written, and (with --cross-validate) each plate size and each intrusion test
//! predicted from the others (the work is [`terzaghi::session::plate_test`] and
//! [`terzaghi::session::intrusion_test`]).

use super::print_out;
use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use std::path::PathBuf;
use terzaghi::ident::rft_shape::{HeldOutIntrusion, RftShapeFit, ShapeForm, ShapeOptions};
use terzaghi::medium_file::{MediumRftShape, RFT_COEFFICIENT_NAMES};
use terzaghi::model::sinkage::{PlateShape, RegimeOptions, SinkageLaw};
use terzaghi::session::intrusion_test::{
    IntrusionFile, calibrate_shape, cross_validate_tests, is_intrusion_test, read_intrusion_test,
    unit_weight_of_tests,
};
use terzaghi::session::plate_test::{
    DepthColumn, HeldOut, MediumFile, PlateTest, STRESS_DEPTH_M, by_size, calibrate,
    cross_validate, read_test, unit_weight_of,
};

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum DepthArg {
    /// depth_comp_m where the run has it: the testbed's compliance taken out.
    Compensated,
    /// depth_m, the testbed's position as logged.
    AsLogged,
}

#[derive(Debug, Args)]
pub struct CalibrateArgs {
    /// Plate-sinkage tests: CSV files in the shared runs' layout (time_s, depth_m, fz_n, ...,
    /// with the JSON of the same name beside each), or plain logs of t_s, depth_m, force_n
    /// (with the plate's size given by flag). Intrusion tests in any direction: CSV files of
    /// t_s, x_m, depth_m, fx_n, fz_n with a JSON of the same name beside each (plate_chord_m,
    /// plate_width_m, chord_angle_deg; docs/calibration.md gives the format). Any mix.
    #[arg(required = true, value_name = "TEST")]
    pub tests: Vec<PathBuf>,
    /// The plate of plain logs: a disc of this diameter (m).
    #[arg(long, value_name = "M", allow_negative_numbers = true, conflicts_with_all = ["plate_width_m", "plate_length_m"])]
    pub plate_diameter_m: Option<f64>,
    /// The plate of plain logs: a rectangle of this width (m), with --plate-length-m.
    #[arg(
        long,
        value_name = "M",
        allow_negative_numbers = true,
        requires = "plate_length_m"
    )]
    pub plate_width_m: Option<f64>,
    /// The plate of plain logs: a rectangle of this length (m), with --plate-width-m.
    #[arg(
        long,
        value_name = "M",
        allow_negative_numbers = true,
        requires = "plate_width_m"
    )]
    pub plate_length_m: Option<f64>,
    /// Which depth of a shared run to use.
    #[arg(long, value_enum, default_value = "as-logged")]
    pub depth: DepthArg,
    /// The medium's unit weight (N/m^3) (default: the tests' bulk density times g).
    #[arg(long, value_name = "N_M3")]
    pub unit_weight_n_m3: Option<f64>,
    /// The law written to the medium file (default: the one with the best R^2).
    #[arg(long, value_name = "LAW", value_parser = law_names())]
    pub law: Option<String>,
    /// Write the medium file here (YAML).
    #[arg(short, long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// The medium's name in the file.
    #[arg(long, default_value = "calibrated")]
    pub name: String,
    /// Predict each plate size from the laws calibrated on the other sizes, and print the
    /// table (R^2 and RMSE per test, depth exponent and change of stress with size); and each
    /// intrusion test from the shape fitted to the others, with the measured and predicted
    /// alpha_x, alpha_z per direction of motion (which directions the tests have not measured).
    #[arg(long)]
    pub cross_validate: bool,
    /// An intrusion test that starts with its plate buried is fitted from this many plate
    /// chords of travel on (the stress builds as the grains ahead of a plate pushed from rest
    /// jam).
    #[arg(long, value_name = "CHORDS", default_value_t = 0.6)]
    pub buried_start_chords: f64,
    /// Hold the intrusion tests' depth exponent at this value (default: fitted, 0.4-2.5).
    #[arg(long, value_name = "N")]
    pub depth_exponent: Option<f64>,
    /// Hold the intrusion tests' surface offset at this depth (m; default: fitted, 0-15 mm).
    #[arg(long, value_name = "M")]
    pub surface_offset_m: Option<f64>,
    /// RFT's shape from the intrusion tests that start buried alone; those that start above the
    /// surface serve the speed law only (a plate entering from the surface pushes a heap of
    /// grains ahead of it, which RFT does not describe).
    #[arg(long)]
    pub shape_from_buried: bool,
    /// RFT's angular shape from this medium file (one calibrated from intrusion tests: a lab's,
    /// a DEM bed's), scaled so that the plate-sinkage tests given (and no intrusion test) set
    /// its stress pushed straight down and its depth exponent: for a medium whose plates alone
    /// were pushed. The law written is rft_depth_power.
    #[arg(long, value_name = "MEDIUM_FILE")]
    pub shape_from: Option<PathBuf>,
    /// Write an HTML report of RFT's shape here: per direction of motion, each intrusion test's
    /// measured alpha_x, alpha_z against the fitted shape over the attack angle (and, with
    /// --cross-validate, each test as the shape fitted to the others predicts it).
    #[arg(long, value_name = "FILE.html")]
    pub report: Option<PathBuf>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// A wheel's slip sweep at slip angle 0 (a CSV of terzaghi steady's runs with the measured
    /// sinkage_m and drawbar_n): fit the bearing of the sand a body shears to it, two
    /// coefficients (tan delta_w and m) and their standard deviations, into the medium file.
    /// Needs the body (--shape, --radius-m, --width-m, grousers) and the rft_depth_power law.
    #[arg(long, value_name = "RUNS.csv", conflicts_with = "sheared_from_repose")]
    pub slip_sweep: Option<PathBuf>,
    /// Write the bearing of sheared sand from the physics alone: tan delta_w = tan(2/3 of the
    /// angle of repose), Meyerhof's square; nothing from a wheel.
    #[arg(long)]
    pub sheared_from_repose: bool,
    /// The sand's angle of repose (deg), for --sheared-from-repose; default: the plate tests'
    /// JSON (medium.angle_of_repose_deg).
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub angle_of_repose_deg: Option<f64>,
    /// The slip sweep's body.
    #[arg(long, value_enum, default_value = "wheel", requires = "slip_sweep")]
    pub shape: super::steady::BodyShape,
    /// The slip sweep's wheel width (m).
    #[arg(
        long,
        value_name = "M",
        allow_negative_numbers = true,
        requires = "slip_sweep"
    )]
    pub width_m: Option<f64>,
    #[command(flatten)]
    pub body: super::steady::BodyArgs,
}

/// `medium` with the bearing of sheared sand that `--slip-sweep` fits or
/// `--sheared-from-repose` gives.
fn with_sheared(
    a: &CalibrateArgs,
    mut medium: MediumFile,
    plates: Option<&PlatePart>,
) -> Result<MediumFile> {
    use terzaghi::session::slip_sweep::{sheared_of_repose, sheared_of_sweep};
    if a.slip_sweep.is_none() && !a.body.given().is_empty() {
        bail!(
            "{} describe the slip sweep's body: give --slip-sweep RUNS.csv",
            a.body.given().join(", ")
        );
    }
    if let Some(r) = a.angle_of_repose_deg
        && !a.sheared_from_repose
    {
        bail!("--angle-of-repose-deg {r} serves --sheared-from-repose");
    }
    if let Some(sweep) = &a.slip_sweep {
        if let Some(out) = &a.out {
            terzaghi::session::files::refuse_output_over_input(out, &[sweep.as_path()])?;
        }
        let body = a.body.body(&a.shape.name(), a.width_m)?;
        let text = a.body.text(a.shape, a.width_m);
        medium.sheared_bearing = Some(sheared_of_sweep(&medium, sweep, &body, &text)?);
    } else if a.sheared_from_repose {
        let (deg, source) = match a.angle_of_repose_deg {
            Some(d) => (d, "given (--angle-of-repose-deg)".to_string()),
            None => plates
                .and_then(|p| {
                    p.tests.iter().find_map(|t| {
                        let s = t.sidecar.as_ref()?;
                        Some((s.angle_of_repose_deg?, s.file.display().to_string()))
                    })
                })
                .context(
                    "no plate test's JSON gives the sand's angle of repose (medium.angle_of_repose_deg): give --angle-of-repose-deg",
                )?,
        };
        medium.sheared_bearing = Some(sheared_of_repose(deg, &source)?);
        // Only an RFT leg takes it: a file of another law would carry it unread.
        medium
            .rft_law(None)
            .context("--sheared-from-repose acts on RFT's stress, and the file has no RFT law (give --law rft_depth_power)")?;
    }
    Ok(medium)
}

fn law_names() -> clap::builder::PossibleValuesParser {
    clap::builder::PossibleValuesParser::new(SinkageLaw::ALL.map(|l| l.name()))
}

pub fn read_tests(a: &CalibrateArgs, files: &[PathBuf]) -> Result<Vec<PlateTest>> {
    let plate = match (a.plate_diameter_m, a.plate_width_m, a.plate_length_m) {
        (Some(d), _, _) => Some(PlateShape::disc(d)?),
        (None, Some(w), Some(l)) => Some(PlateShape::rectangle(w, l)?),
        _ => None,
    };
    let depth = match a.depth {
        DepthArg::Compensated => DepthColumn::Compensated,
        DepthArg::AsLogged => DepthColumn::AsLogged,
    };
    files
        .iter()
        .map(|f| read_test(f, plate, depth, &RegimeOptions::default()))
        .collect()
}

/// The plate-sinkage part of a calibration.
struct PlatePart {
    tests: Vec<PlateTest>,
    unit_weight: f64,
    unit_weight_source: String,
    fits: Vec<terzaghi::ident::sinkage::SinkageFit>,
    failed: Vec<(SinkageLaw, String)>,
    chosen: usize,
    held: Option<Vec<HeldOut>>,
}

fn plate_part(a: &CalibrateArgs, files: &[PathBuf]) -> Result<PlatePart> {
    let tests = read_tests(a, files)?;
    let (unit_weight, unit_weight_source) = unit_weight_of(&tests, a.unit_weight_n_m3)?;
    let (fits, failed) = calibrate(&tests, unit_weight);
    // A borrowed shape is scaled to RFT's law in depth.
    let law = (a.law.as_deref()).or(a.shape_from.as_ref().map(|_| "rft_depth_power"));
    let chosen = match law {
        Some(name) => fits
            .iter()
            .position(|f| f.model.law.name() == name)
            .with_context(|| {
                let why = failed
                    .iter()
                    .find(|(l, _)| l.name() == name)
                    .map(|(_, e)| e.clone())
                    .unwrap_or_default();
                format!("{name} could not be fitted: {why}")
            })?,
        None if fits.is_empty() => bail!(
            "no law could be fitted to these tests: {}",
            failed
                .iter()
                .map(|(_, e)| e.clone())
                .collect::<Vec<_>>()
                .join("; ")
        ),
        None => 0,
    };
    let held = if a.cross_validate {
        Some(cross_validate(&tests, unit_weight)?)
    } else {
        None
    };
    Ok(PlatePart {
        tests,
        unit_weight,
        unit_weight_source,
        fits,
        failed,
        chosen,
        held,
    })
}

pub fn run(a: CalibrateArgs) -> Result<()> {
    let inputs: Vec<&std::path::Path> = a.tests.iter().map(|p| p.as_path()).collect();
    terzaghi::session::files::refuse_stdout_over_input(&inputs)?;
    for out in a.out.iter().chain(&a.report) {
        terzaghi::session::files::refuse_output_over_input(out, &inputs)?;
    }
    if let Some(w) = a.unit_weight_n_m3
        && !(w.is_finite() && w > 0.0)
    {
        bail!("--unit-weight-n-m3 must be a number > 0, got {w}");
    }
    if !(a.buried_start_chords.is_finite() && a.buried_start_chords >= 0.0) {
        bail!(
            "--buried-start-chords must be a number >= 0, got {}",
            a.buried_start_chords
        );
    }
    let (intrusion_files, plate_files): (Vec<PathBuf>, Vec<PathBuf>) =
        a.tests.iter().cloned().partition(|f| is_intrusion_test(f));
    if a.law.is_some() && plate_files.is_empty() {
        bail!(
            "--law chooses among plate-sinkage laws, and every test given is an intrusion test (its law in depth is fitted with its shape)"
        );
    }
    let shape_from = match &a.shape_from {
        None => None,
        Some(_) if plate_files.is_empty() || !intrusion_files.is_empty() => bail!(
            "--shape-from scales another medium's shape to plate-sinkage tests alone ({} plate-sinkage and {} intrusion tests given)",
            plate_files.len(),
            intrusion_files.len()
        ),
        Some(_) if a.law.as_deref().is_some_and(|l| l != "rft_depth_power") => bail!(
            "--shape-from scales a shape to the rft_depth_power law, and --law is {}",
            a.law.as_deref().unwrap_or_default()
        ),
        Some(f) => Some((MediumFile::read(f)?, f.display().to_string())),
    };
    let plates = if plate_files.is_empty() {
        None
    } else {
        Some(plate_part(&a, &plate_files)?)
    };
    let intrusions: Vec<IntrusionFile> = intrusion_files
        .iter()
        .map(|f| read_intrusion_test(f))
        .collect::<Result<_>>()?;
    let defaults = ShapeOptions::default();
    if let Some(n) = a.depth_exponent
        && !(n.is_finite() && (0.1..=5.0).contains(&n))
    {
        bail!("--depth-exponent must be a number in [0.1, 5], got {n}");
    }
    if let Some(z) = a.surface_offset_m
        && !(z.is_finite() && (0.0..=0.1).contains(&z))
    {
        bail!("--surface-offset-m must be a number in [0, 0.1] m, got {z}");
    }
    let options = ShapeOptions {
        buried_start_chords: a.buried_start_chords,
        exponent_range: a.depth_exponent.map_or(defaults.exponent_range, |n| (n, n)),
        offset_range_m: a
            .surface_offset_m
            .map_or(defaults.offset_range_m, |z| (z, z)),
        shape_from_buried_only: a.shape_from_buried,
        ..defaults
    };
    let shape = if intrusions.is_empty() {
        None
    } else {
        Some(calibrate_shape(&intrusions, &options)?)
    };
    let shape_held = match &shape {
        Some(fit) if a.cross_validate => Some(cross_validate_tests(&intrusions, &options, fit)?),
        _ => None,
    };
    let command = std::iter::once("terzaghi".to_string())
        .chain(std::env::args().skip(1))
        .collect::<Vec<_>>()
        .join(" ");
    let medium = match (&plates, &shape) {
        (Some(p), shape) => {
            let files: Vec<PathBuf> = p.tests.iter().map(|t| t.file.clone()).collect();
            let depth_column = p.tests.first().map_or("depth_m", |t| t.depth_column);
            let mut m = MediumFile::of_fit(
                &a.name,
                &p.fits[p.chosen],
                &files,
                depth_column,
                &command,
                &p.unit_weight_source,
            );
            for (t, test) in m.source.tests.iter_mut().zip(&p.tests) {
                t.spikes_skipped = test.spike_rows;
            }
            m.rft_shape = shape
                .as_ref()
                .map(|s| MediumRftShape::of_fit(s, &intrusion_files));
            match &shape_from {
                Some((other, name)) => m.with_shape_from(other, name)?,
                None => m,
            }
        }
        (None, Some(s)) => {
            let (w, source) = unit_weight_of_tests(&intrusions, a.unit_weight_n_m3)?.context(
                "no intrusion test's JSON gives unit_weight_n_m3: give --unit-weight-n-m3 (a medium file carries it for the legs that take a Terzaghi medium)",
            )?;
            MediumFile::of_shape(&a.name, s, &intrusion_files, w, &command, &source)
        }
        (None, None) => bail!("no test given"),
    };
    let medium = with_sheared(&a, medium, plates.as_ref())?;
    if let Some(out) = &a.out {
        terzaghi::session::files::write_text(out, &medium.to_yaml()?)
            .context(terzaghi::session::files::cannot_write(out))?;
    }
    if let Some(report) = &a.report {
        let Some(fit) = &shape else {
            bail!("--report draws RFT's shape, and no intrusion test was given");
        };
        let html = terzaghi::session::calibration_html::html(
            fit,
            shape_held.as_ref().map(|(h, _)| h.as_slice()),
        )?;
        terzaghi::session::files::write_text(report, &html)
            .context(terzaghi::session::files::cannot_write(report))?;
    }
    if a.json {
        let mut v = serde_json::json!({ "medium": medium });
        if let Some(p) = &plates {
            v["tests"] =
                serde_json::json!(p.tests.iter().map(|t| serde_json::json!({
                "file": t.file, "plate": t.plate.label(), "depth_column": t.depth_column,
                "rows": t.rows.len(), "loaded_rows": t.loaded().rows.len(),
                "skipped_rows": t.skipped_rows, "spike_rows": t.spike_rows,
            })).collect::<Vec<_>>());
            v["unit_weight_n_m3"] = serde_json::json!(p.unit_weight);
            v["fits"] = serde_json::json!(p.fits);
            v["not_fitted"] = serde_json::json!(
                p.failed
                    .iter()
                    .map(|(l, e)| serde_json::json!({"law": l.name(), "error": e}))
                    .collect::<Vec<_>>()
            );
            v["cross_validation"] = serde_json::json!(p.held);
            v["cross_validation_by_size"] = serde_json::json!(p.held.as_deref().map(by_size));
        }
        if let Some(s) = &shape {
            v["rft_shape"] = serde_json::json!(s);
        }
        if let Some((held, skipped)) = &shape_held {
            v["rft_shape_cross_validation"] = serde_json::json!(held);
            v["rft_shape_cross_validation_by_direction"] = serde_json::json!(by_direction(held));
            v["rft_shape_cross_validation_skipped"] = serde_json::json!(skipped);
        }
        return print_out(&(serde_json::to_string_pretty(&v)? + "\n"));
    }
    let mut s = String::new();
    if let Some(p) = &plates {
        s += &render_plate_part(p);
    }
    if let Some(fit) = &shape {
        if plates.is_some() {
            s.push('\n');
        }
        s += &render_shape(fit, &options);
    }
    if let Some((held, skipped)) = &shape_held {
        s += &render_shape_cross_validation(held, skipped);
    }
    if let Some(b) = &medium.sheared_bearing {
        s += &format!("\n{}\n", b.text());
        if let Some(w) = &b.slip_sweep {
            s += &format!(
                "  the sweep's {} runs through terzaghi steady (in sample: the two values were fitted on them): sinkage R^2 {:.3}, drawbar R^2 {:.3}; with the sand at rest {:.3}, {:.3}\n",
                w.runs, w.r2_sinkage, w.r2_drawbar, w.r2_sinkage_at_rest, w.r2_drawbar_at_rest
            );
        }
    }
    if let Some(out) = &a.out {
        s += &format!(
            "\nwrote {} (law {}; RFT's shape {})\n",
            out.display(),
            medium.law.name(),
            match &medium.rft_shape {
                Some(r) if r.borrowed_from.is_some() => medium.rft_shape_text(),
                Some(r) => r.form.name().to_string(),
                None => "poppy_lp's, not measured".to_string(),
            }
        );
    }
    print_out(&s)
}

fn render_plate_part(p: &PlatePart) -> String {
    let (tests, fits, failed, chosen) = (&p.tests, &p.fits, &p.failed, &p.fits[p.chosen]);
    let mut s = String::new();
    s += &format!(
        "{} tests, depth from {}, unit weight {:.0} N/m^3 ({})\n",
        tests.len(),
        tests.first().map(|t| t.depth_column).unwrap_or("depth_m"),
        p.unit_weight,
        p.unit_weight_source
    );
    for t in tests {
        s += &format!(
            "  {:<28} {:<12} {:>4} rows, {:>4} loaded, deepest {:>5.1} mm{}\n",
            t.name(),
            t.plate.label(),
            t.rows.len(),
            t.loaded().rows.len(),
            t.deepest_m() * 1e3,
            if t.skipped_rows > 0 {
                format!(", {} skipped (not finite)", t.skipped_rows)
            } else {
                String::new()
            } + &if t.spike_rows > 0 {
                format!(", {} skipped (depth spikes)", t.spike_rows)
            } else {
                String::new()
            }
        );
    }
    s += "\nEvery law fitted to all loaded rows (force, least squares), best first\n";
    s += &format!(
        "{:<18} {:>7} {:>9}  parameters (+- one standard deviation)\n",
        "law", "R^2", "RMSE N"
    );
    for f in fits {
        let params = f
            .model
            .law
            .param_names()
            .iter()
            .zip(f.model.params.iter().zip(&f.std_dev))
            .map(|(n, (v, sd))| {
                if f.on_bound.iter().any(|(b, _)| b == n) {
                    format!("{n} {} (on its bound: the best fit lies beyond)", sig(*v))
                } else if *sd == 0.0 && f.width_held {
                    format!("{n} {} (held: one plate size)", sig(*v))
                } else {
                    format!("{n} {} +- {}", sig(*v), sig(*sd))
                }
            })
            .collect::<Vec<_>>()
            .join(", ");
        s += &format!(
            "{:<18} {:>7.3} {:>9.2}  {params}\n",
            f.model.law.name(),
            f.r2,
            f.rmse_n
        );
    }
    for (l, e) in failed {
        s += &format!("{:<18} not fitted: {e}\n", l.name());
    }
    if fits.iter().any(|f| f.std_dev_over_trials) {
        s += "(a standard deviation is the larger of the rows' and the trials', each test left out once)\n";
    }
    s += &format!(
        "\nPer test under {} (R^2, RMSE N, the trial's own scale against the law)\n",
        chosen.model.law.name()
    );
    for t in &chosen.tests {
        s += &format!(
            "  {:<28} {:<12} R^2 {:>6.3}  RMSE {:>6.2} N  peak {:>6.1} N  scale {}\n",
            t.name,
            t.plate,
            t.r2,
            t.rmse_n,
            t.peak_force_n,
            t.scale.map_or("-".to_string(), |v| format!("{v:.3}"))
        );
    }
    s += &match &chosen.scatter {
        Some(b) => format!(
            "Trial to trial: {} (predict --band, steady --band)\n",
            terzaghi::medium_file::MediumScatter::of(b).text()
        ),
        None => format!(
            "Trial to trial: no band ({} tests; a band needs {} degrees of freedom: three trials, four with a width term)\n",
            chosen.tests.len(),
            terzaghi::ident::scatter::MIN_BAND_DEGREES_OF_FREEDOM
        ),
    };
    if let Some(held) = &p.held {
        s += &render_cross_validation(held);
    }
    s
}

/// The shape's fit: its coefficients with their deviations, its depth and speed laws, and each
/// test's measured and fitted stresses.
pub fn render_shape(fit: &RftShapeFit, o: &ShapeOptions) -> String {
    let mut s = format!(
        "RFT's shape from {} intrusion tests ({} rows fitted, at {:.3} m/s; a test that starts buried is fitted from {} chords of travel on)\n",
        fit.tests.len(),
        fit.rows,
        fit.reference_speed_m_s,
        o.buried_start_chords
    );
    match fit.form {
        ShapeForm::LiNine => {
            s += "form li_nine: Li, Zhang and Goldman's nine coefficients, each fitted\n"
        }
        ShapeForm::PresetScaled => {
            s += &format!(
                "form preset_scaled: {}\n",
                fit.reduced_because.as_deref().unwrap_or("")
            )
        }
    }
    s += "coefficients (N/cm^3 at 1 cm, +- one standard deviation, jackknife over tests):\n";
    let (c, d) = (fit.coefficients.to_array(), fit.std_dev.to_array());
    for (i, name) in RFT_COEFFICIENT_NAMES.iter().enumerate() {
        s += &format!("  {name:<5} {:>8.4} +- {:.4}\n", c[i], d[i]);
    }
    s += &format!(
        "depth: the stress at 1 cm ((z + z_0) / 1 cm)^n, n {:.3} +- {:.3}, z_0 {:.1} +- {:.1} mm; straight down alpha_z {:.4} +- {:.4} N/cm^3\n",
        fit.depth_exponent,
        fit.depth_exponent_std,
        fit.surface_offset_m * 1e3,
        fit.surface_offset_std_m * 1e3,
        fit.alpha_z_down_n_cm3[0],
        fit.alpha_z_down_n_cm3[1]
    );
    s += &format!(
        "fitted rows: R^2 fx {:.3}, fz {:.3}; RMSE fx {:.3} N, fz {:.3} N\n",
        fit.r2[0], fit.r2[1], fit.rmse_n[0], fit.rmse_n[1]
    );
    match (&fit.speed, &fit.no_speed_law_because) {
        (Some(sp), _) => {
            let gains = sp
                .law
                .gains()
                .iter()
                .zip(&fit.speed_gain_std_s)
                .rev()
                .map(|(&(g, k), sd)| {
                    format!("{k:.4} +- {sd:.4} s at {:.0} deg", g.to_degrees() + 0.0)
                })
                .collect::<Vec<_>>()
                .join(", ");
            s += &format!(
                "speed law: elements k (v - {:.3} m/s) deeper, up to {:.3} m/s; k {}; from {} faster tests ({:.0} % of the change with speed explained; one k for every direction {:.0} %)\n",
                sp.law.ref_speed_m_s,
                sp.law.max_speed_m_s,
                gains,
                sp.intrusions,
                100.0 * sp.explained,
                100.0 * sp.one_gain_explained
            )
        }
        (None, why) => {
            s += &format!(
                "speed law: none ({})\n",
                why.as_deref().unwrap_or("no test at a second speed")
            )
        }
    }
    s += "\nPer test (direction of motion below the horizontal in RFT's frame, the motion toward +x; alpha in N/cm^3)\n";
    s += &format!(
        "{:<28} {:>6} {:>6} {:>7} {:>5} {:>9} {:>9} {:>9} {:>9}\n",
        "test", "chord", "dir", "m/s", "rows", "ax meas", "ax fit", "az meas", "az fit"
    );
    for t in &fit.tests {
        s += &format!(
            "{:<28} {:>6.0} {:>6.0} {:>7.3} {:>5} {:>9.4} {:>9.4} {:>9.4} {:>9.4}{}\n",
            t.name,
            t.chord_angle_deg + 0.0,
            t.direction_deg + 0.0,
            t.speed_m_s,
            t.rows_fitted,
            t.measured_alpha_n_cm3[0],
            t.fitted_alpha_n_cm3[0],
            t.measured_alpha_n_cm3[1],
            t.fitted_alpha_n_cm3[1],
            if t.rows_fitted == 0 {
                "  (faster: speed law)"
            } else {
                ""
            }
        );
    }
    s
}

/// Held-out intrusion tests grouped by direction of motion (to the degree).
#[derive(Debug, Clone, serde::Serialize)]
pub struct HeldOutDirection {
    /// The direction below the horizontal (deg; negative: up).
    pub direction_deg: f64,
    /// Tests.
    pub tests: usize,
    /// Means of the measured and predicted `alpha_x, alpha_z` (N/cm^3).
    pub measured_alpha_n_cm3: [f64; 2],
    /// See [`Self::measured_alpha_n_cm3`].
    pub predicted_alpha_n_cm3: [f64; 2],
    /// The mean RMSE of the horizontal and vertical force over its tests (N).
    pub rmse_n: [f64; 2],
}

/// [`HeldOutDirection`] of each direction, from up to down.
pub fn by_direction(held: &[HeldOutIntrusion]) -> Vec<HeldOutDirection> {
    let mut dirs: Vec<f64> = held.iter().map(|h| h.test.direction_deg.round()).collect();
    dirs.sort_by(f64::total_cmp);
    dirs.dedup();
    dirs.into_iter()
        .map(|d| {
            let mine: Vec<&HeldOutIntrusion> = held
                .iter()
                .filter(|h| h.test.direction_deg.round() == d)
                .collect();
            let n = mine.len() as f64;
            let mean =
                |f: &dyn Fn(&HeldOutIntrusion) -> f64| mine.iter().map(|h| f(h)).sum::<f64>() / n;
            let rmse = |k: usize| mine.iter().map(|h| h.rmse_n[k]).sum::<f64>() / n;
            HeldOutDirection {
                direction_deg: d,
                tests: mine.len(),
                measured_alpha_n_cm3: [
                    mean(&|h| h.test.measured_alpha_n_cm3[0]),
                    mean(&|h| h.test.measured_alpha_n_cm3[1]),
                ],
                predicted_alpha_n_cm3: [
                    mean(&|h| h.predicted_alpha_n_cm3[0]),
                    mean(&|h| h.predicted_alpha_n_cm3[1]),
                ],
                rmse_n: [rmse(0), rmse(1)],
            }
        })
        .collect()
}

/// Each intrusion test predicted by the shape fitted to the others, and the same per direction.
pub fn render_shape_cross_validation(held: &[HeldOutIntrusion], skipped: &[String]) -> String {
    let mut s = String::from(
        "\nEach intrusion test predicted from the shape fitted to the others (nothing fitted to it; alpha in N/cm^3)\n",
    );
    s += &format!(
        "{:<28} {:>6} {:>6} {:>9} {:>9} {:>9} {:>9} {:>7} {:>7}  {}\n",
        "test",
        "chord",
        "dir",
        "ax meas",
        "ax pred",
        "az meas",
        "az pred",
        "R^2 fx",
        "R^2 fz",
        "form"
    );
    for h in held {
        s += &format!(
            "{:<28} {:>6.0} {:>6.0} {:>9.4} {:>9.4} {:>9.4} {:>9.4} {:>7.3} {:>7.3}  {}\n",
            h.test.name,
            h.test.chord_angle_deg + 0.0,
            h.test.direction_deg + 0.0,
            h.test.measured_alpha_n_cm3[0],
            h.predicted_alpha_n_cm3[0],
            h.test.measured_alpha_n_cm3[1],
            h.predicted_alpha_n_cm3[1],
            h.rmse_n[0],
            h.rmse_n[1],
            h.form.name()
        );
    }
    for name in skipped {
        s += &format!("{name:<28} not predicted: the others alone determine no shape\n");
    }
    s += "\nThe same, per direction of motion (deg below the horizontal; means over its tests)\n";
    s += &format!(
        "{:>6} {:>5} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9}\n",
        "dir", "tests", "ax meas", "ax pred", "az meas", "az pred", "RMSE fx", "RMSE fz"
    );
    for d in by_direction(held) {
        s += &format!(
            "{:>6.0} {:>5} {:>9.4} {:>9.4} {:>9.4} {:>9.4} {:>9.3} {:>9.3}\n",
            d.direction_deg + 0.0,
            d.tests,
            d.measured_alpha_n_cm3[0],
            d.predicted_alpha_n_cm3[0],
            d.measured_alpha_n_cm3[1],
            d.predicted_alpha_n_cm3[1],
            d.rmse_n[0],
            d.rmse_n[1]
        );
    }
    s
}

fn sig(v: f64) -> String {
    if v == 0.0 || (1e-2..1e5).contains(&v.abs()) {
        format!("{v:.4}")
    } else {
        format!("{v:.4e}")
    }
}

/// The cross-validation table: each test predicted by each law calibrated on the other sizes.
pub fn render_cross_validation(held: &[HeldOut]) -> String {
    let mut s = format!(
        "\nEach plate size predicted from the laws calibrated on the other sizes (nothing fitted to it)\n\
         exponent: slope of ln F on ln z over the loaded rows deeper than 3 mm; stress ratio: the\n\
         test's stress at {:.0} mm over the calibration tests' mean\n",
        STRESS_DEPTH_M * 1e3
    );
    s += &format!(
        "{:<18} {:<28} {:>7} {:>8} {:>9} {:>9} {:>9} {:>9}\n",
        "law", "test", "R^2", "RMSE N", "exp meas", "exp pred", "str meas", "str pred"
    );
    let mut last = None;
    for h in held {
        if last.is_some_and(|l| l != h.law) {
            s.push('\n');
        }
        last = Some(h.law);
        s += &format!(
            "{:<18} {:<28} {:>7.3} {:>8.2} {:>9.3} {:>9.3} {:>9.3} {:>9.3}\n",
            h.law.name(),
            h.fit.name,
            h.fit.r2,
            h.fit.rmse_n,
            h.measured_exponent,
            h.predicted_exponent,
            h.measured_stress_ratio,
            h.predicted_stress_ratio
        );
    }
    s += "\nThe same, per plate size (means over its tests)\n";
    s += &format!(
        "{:<18} {:<12} {:>5} {:>9} {:>9} {:>9} {:>9} {:>9}\n",
        "law", "plate", "tests", "worst R^2", "exp meas", "exp pred", "str meas", "str pred"
    );
    for z in by_size(held) {
        s += &format!(
            "{:<18} {:<12} {:>5} {:>9.3} {:>9.3} {:>9.3} {:>9.3} {:>9.3}\n",
            z.law.name(),
            z.plate,
            z.tests,
            z.worst_r2,
            z.measured_exponent,
            z.predicted_exponent,
            z.measured_stress_ratio,
            z.predicted_stress_ratio
        );
    }
    // What each fold held, once per law and held-out size.
    let mut said: Vec<(SinkageLaw, String)> = Vec::new();
    for h in held.iter().filter(|h| !h.held.is_empty()) {
        let key = (h.law, h.fit.plate.clone());
        if said.contains(&key) {
            continue;
        }
        if said.is_empty() {
            s += "
Held in the folds
";
        }
        s += &format!(
            "{:<18} without {:<12} {}
",
            h.law.name(),
            h.fit.plate,
            h.held.join("; ")
        );
        said.push(key);
    }
    s
}
