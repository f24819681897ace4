//! Plate-sinkage tests on disk, and the calibration of a medium from them: reading a test (a
//! plain `t_s, depth_m, force_n` log with its plate given, or a run in the layout of the
//! shared real runs, a CSV with a JSON beside it), telling its loaded rows from its holds and
//! unloading, fitting the sinkage laws ([`calibrate`]), checking one plate size against a
//! medium calibrated on the others ([`cross_validate`]), and the medium file
//! ([`MediumFile`]) that `terzaghi calibrate` writes and `terzaghi media` reads.

use crate::ident::sinkage::{LoadedTest, SinkageFit, TestFit, fit_sinkage, judge};
pub use crate::medium_file::{MediumFile, MediumSource, MediumSourceTest};
use crate::model::sinkage::{
    G_M_S2, PlateShape, RegimeOptions, SinkageLaw, SinkageRegime, sinkage_regimes,
};
use anyhow::{Context, Result, bail};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// A depth that falls back by more than this before the test's deepest point is not one
/// intrusion (m).
pub const DEPTH_BACK_TOLERANCE_M: f64 = 2e-3;
/// The offset against a zero file is read where the plate is at least this far above the
/// surface (m): closer, an uneven surface may already touch it.
pub const OUT_OF_MEDIUM_M: f64 = 5e-3;
/// The depth at which [`cross_validate`] compares the stress of plate sizes (m).
pub const STRESS_DEPTH_M: f64 = 0.01;

/// One row of a test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TestRow {
    /// Time (s).
    pub t_s: f64,
    /// The plate's sinkage below the surface (m; negative above it).
    pub depth_m: f64,
    /// The medium's upward force on the plate, offsets removed (N).
    pub force_n: f64,
    /// The depth as the rig logged its position (m): the same as `depth_m` unless the test's
    /// depth has the rig's compliance taken out. The regimes are told from it, since a
    /// compensated depth moves when the load does (an unloading at a standing rig would read
    /// as the plate going deeper).
    pub rig_depth_m: f64,
    /// The sensor's vertical reading as it came, offsets included, if the test has it (N).
    pub raw_force_n: Option<f64>,
}

/// What a shared run's JSON says about the sensor and the sand.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunSidecar {
    /// The JSON file.
    pub file: PathBuf,
    /// The sand's bulk density (kg/m^3).
    pub bulk_density_kg_m3: Option<f64>,
    /// The sand's angle of repose (deg), where the JSON gives it.
    pub angle_of_repose_deg: Option<f64>,
    /// The vertical mean of the run's zero file (N, as the sensor reads).
    pub zero_fz_n: Option<f64>,
    /// The vertical mean in the air before the run (N, as the sensor reads).
    pub in_air_fz_n: Option<f64>,
    /// When the testbed starts to move (s).
    pub t_motion_start_s: Option<f64>,
}

/// A plate-sinkage test read from disk.
#[derive(Debug, Clone, PartialEq)]
pub struct PlateTest {
    /// The CSV file.
    pub file: PathBuf,
    /// The plate.
    pub plate: PlateShape,
    /// The depth column used (`depth_m`, or `depth_comp_m`: the testbed's compliance taken out).
    pub depth_column: &'static str,
    /// Its rows, in time order; rows with a non-finite value are counted in `skipped_rows`.
    pub rows: Vec<TestRow>,
    /// Rows skipped: a depth, force or time that is not a finite number.
    pub skipped_rows: usize,
    /// Rows skipped as a potentiometer's spikes ([`spikes`]).
    pub spike_rows: usize,
    /// The regime of each row.
    pub regimes: Vec<SinkageRegime>,
    /// The JSON beside a shared run, if there is one.
    pub sidecar: Option<RunSidecar>,
}

impl PlateTest {
    /// The test's name in tables: its file's stem.
    pub fn name(&self) -> String {
        self.file
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    }

    /// The loaded rows: the plate moving down into medium it had not pressed.
    pub fn loaded(&self) -> LoadedTest {
        LoadedTest {
            name: self.name(),
            plate: self.plate,
            rows: self
                .rows
                .iter()
                .zip(&self.regimes)
                .filter(|(_, g)| **g == SinkageRegime::Loading)
                .map(|(r, _)| (r.depth_m, r.force_n))
                .collect(),
        }
    }

    /// Intrusions in the test: stretches below the surface, each left (at least
    /// [`OUT_OF_MEDIUM_M`] above it) before the next.
    pub fn intrusions(&self) -> usize {
        intrusions(&self.rows).len()
    }

    /// The deepest sinkage reached (m).
    pub fn deepest_m(&self) -> f64 {
        self.rows
            .iter()
            .map(|r| r.depth_m)
            .fold(f64::NEG_INFINITY, f64::max)
    }
}

/// Which depth column of a shared run to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DepthColumn {
    /// `depth_comp_m` where the run has it (the testbed's compliance taken out), else `depth_m`.
    Compensated,
    /// `depth_m`: the testbed's position as it logged it (the depth the source's own processing
    /// used).
    #[default]
    AsLogged,
}

const PLAIN_COLUMNS: [&str; 3] = ["t_s", "depth_m", "force_n"];
const SHARED_COLUMNS: [&str; 10] = [
    "time_s",
    "depth_m",
    "fx_n",
    "fz_n",
    "fy_n",
    "depth_comp_m",
    "fx_raw_n",
    "fy_raw_n",
    "fz_raw_n",
    "in_paper_window",
];

/// Reads a plate-sinkage test. A CSV with `time_s, depth_m, fz_n` is a run in the shared
/// layout, with its plate and sensor values in the JSON of the same name beside it; a CSV with
/// `t_s, depth_m, force_n` is a plain log, whose plate is `plate`. Any other column is refused
/// by name. Time that goes back, a depth that goes back before the deepest point, and a test
/// with no loaded row are refused with the values.
pub fn read_test(
    file: &Path,
    plate: Option<PlateShape>,
    depth: DepthColumn,
    regimes: &RegimeOptions,
) -> Result<PlateTest> {
    let text =
        std::fs::read_to_string(file).with_context(|| format!("cannot read {}", file.display()))?;
    // Read where it exists; whether the test needs it is known from its header.
    let json = std::fs::read_to_string(file.with_extension("json")).ok();
    parse_test(file, &text, json.as_deref(), plate, depth, regimes)
}

/// [`read_test`] on texts already read: the CSV `text` of the test named `file`, and the text of
/// the JSON beside it, if there is one (a run in the shared layout needs it). Nothing is read
/// from disk.
pub fn parse_test(
    file: &Path,
    text: &str,
    json: Option<&str>,
    plate: Option<PlateShape>,
    depth: DepthColumn,
    regimes: &RegimeOptions,
) -> Result<PlateTest> {
    let name = file.display().to_string();
    // A bevameter's export: free text, a header of force and sinkage with units, no time.
    if let Some(e) = super::plate_export::parse_export(&name, text, plate)? {
        // The flags' plate, else the one its free text names.
        let Some(plate) = plate.or(e.plate) else {
            bail!(
                "{name} is a bevameter's export (force and sinkage, no time) whose text names no plate (as \"Plate: disc 45 mm\"): give its plate (--plate-diameter-m, or --plate-width-m and --plate-length-m)"
            );
        };
        let rows = e
            .rows
            .iter()
            .enumerate()
            .map(|(k, &(depth_m, force_n, _))| TestRow {
                t_s: k as f64 * super::plate_export::ROW_STEP_S,
                depth_m,
                force_n,
                rig_depth_m: depth_m,
                raw_force_n: None,
            })
            .collect();
        return finish(file, plate, "sinkage", rows, 0, None, regimes);
    }
    let (mut rdr, headers) = crate::session::files::csv_table(&name, text)?;
    if headers.iter().any(|h| h == "z_raw_mm") {
        bail!(
            "{name} is a run's kinematics log (time_s, z_raw_mm, depth_m), not a test: give the run's force CSV (its depth is already in it)"
        );
    }
    let shared = headers.iter().any(|h| h == "time_s");
    let known: &[&str] = if shared {
        &SHARED_COLUMNS
    } else {
        &PLAIN_COLUMNS
    };
    for h in &headers {
        if !known.contains(&h.as_str()) {
            bail!(
                "{name}: unknown column {h:?}; a plate-sinkage test has {} (a plain log) or the shared runs' {}",
                PLAIN_COLUMNS.join(", "),
                SHARED_COLUMNS.join(", ")
            );
        }
    }
    let col = |c: &str| headers.iter().position(|h| h == c);
    let need = |c: &'static str| {
        col(c).with_context(|| {
            format!(
                "{name}: header lacks column {c:?} (found: {})",
                headers.join(",")
            )
        })
    };
    let (it, iz, iforce, iraw) = if shared {
        let iz = match (depth, col("depth_comp_m")) {
            (DepthColumn::Compensated, Some(i)) => i,
            _ => need("depth_m")?,
        };
        (need("time_s")?, iz, need("fz_n")?, col("fz_raw_n"))
    } else {
        (need("t_s")?, need("depth_m")?, need("force_n")?, None)
    };
    let irig = need("depth_m")?;
    let depth_column = if headers[iz] == "depth_comp_m" {
        "depth_comp_m"
    } else {
        "depth_m"
    };
    let json_file = file.with_extension("json");
    let json = match (shared, json) {
        (false, _) => None,
        (true, Some(text)) => Some(
            serde_json::from_str::<serde_json::Value>(text)
                .with_context(|| format!("{} is not JSON", json_file.display()))?,
        ),
        (true, None) => bail!(
            "cannot read {} (a run in the shared layout has its JSON beside its CSV)",
            json_file.display()
        ),
    };
    let sidecar = json.as_ref().map(|j| sidecar_of(&json_file, j));
    let plate = match (plate, &sidecar, &json) {
        (Some(p), _, _) => p,
        (None, Some(s), Some(json)) => {
            let d = json
                .get("plate_diameter_m")
                .and_then(|v| v.as_f64())
                .with_context(|| format!("{} has no plate_diameter_m", s.file.display()))?;
            PlateShape::disc(d).with_context(|| format!("{}", s.file.display()))?
        }
        (None, _, _) => bail!(
            "{name} is a plain log: give its plate (--plate-diameter-m, or --plate-width-m and --plate-length-m)"
        ),
    };
    let mut rows = Vec::new();
    let mut skipped_rows = 0;
    let mut last_t = f64::NEG_INFINITY;
    for rec in rdr.records() {
        let rec = rec.with_context(|| format!("{name}: malformed CSV"))?;
        let line = rec.position().map(|p| p.line()).unwrap_or(0);
        let cell = |i: usize| -> Result<f64> {
            let v = rec.get(i).unwrap_or("");
            v.parse::<f64>().with_context(|| {
                format!(
                    "{name} line {line}, column {}: {v:?} is not a number",
                    headers[i]
                )
            })
        };
        let row = TestRow {
            t_s: cell(it)?,
            depth_m: cell(iz)?,
            force_n: cell(iforce)?,
            rig_depth_m: cell(irig)?,
            raw_force_n: iraw.map(cell).transpose()?,
        };
        if !(row.t_s.is_finite()
            && row.depth_m.is_finite()
            && row.force_n.is_finite()
            && row.rig_depth_m.is_finite())
        {
            skipped_rows += 1;
            continue;
        }
        if row.t_s < last_t {
            bail!(
                "{name} line {line}: time goes back from {last_t} s to {} s",
                row.t_s
            );
        }
        last_t = row.t_s;
        rows.push(row);
    }
    finish(
        file,
        plate,
        depth_column,
        rows,
        skipped_rows,
        sidecar,
        regimes,
    )
}

/// A test's rows, read: potentiometer spikes skipped and counted, then checked (a loaded part,
/// a depth that does not go back before an intrusion's deepest point) and told into regimes.
fn finish(
    file: &Path,
    plate: PlateShape,
    depth_column: &'static str,
    rows: Vec<TestRow>,
    skipped_rows: usize,
    sidecar: Option<RunSidecar>,
    regimes: &RegimeOptions,
) -> Result<PlateTest> {
    let name = file.display().to_string();
    let spike = spikes(&rows.iter().map(|r| r.rig_depth_m).collect::<Vec<_>>());
    let spike_rows = spike.iter().filter(|s| **s).count();
    let rows: Vec<TestRow> = rows
        .into_iter()
        .zip(&spike)
        .filter(|(_, s)| !**s)
        .map(|(r, _)| r)
        .collect();
    let deepest = rows
        .iter()
        .map(|r| r.depth_m)
        .fold(f64::NEG_INFINITY, f64::max);
    if rows.is_empty() || deepest <= 0.0 {
        bail!(
            "{name}: no loaded part: the plate never goes below the surface (deepest {}; {} rows)",
            if rows.is_empty() {
                "none".to_string()
            } else {
                format!("{:.2} mm", deepest * 1e3)
            },
            rows.len()
        );
    }
    // Each intrusion pushes down once: before its deepest point the depth may wobble but not
    // go back. A log may hold several, each leaving the medium before the next.
    for range in intrusions(&rows) {
        let part = &rows[range];
        let deepest = part
            .iter()
            .map(|r| r.depth_m)
            .fold(f64::NEG_INFINITY, f64::max);
        let i_deepest = part.iter().position(|r| r.depth_m >= deepest).unwrap_or(0);
        let mut max_so_far = f64::NEG_INFINITY;
        for r in &part[..i_deepest] {
            if r.depth_m > 0.0 && r.depth_m < max_so_far - DEPTH_BACK_TOLERANCE_M {
                bail!(
                    "{name}: the depth goes back from {:.2} mm to {:.2} mm at t = {} s, and stays back, before the intrusion's deepest point ({:.2} mm): the plate was raised and pushed again within one intrusion; a plate-sinkage test pushes down once per intrusion, and leaves the medium (at least {} mm above the surface) before the next: split the test there, or lift the plate clear between pushes",
                    max_so_far * 1e3,
                    r.depth_m * 1e3,
                    r.t_s,
                    deepest * 1e3,
                    OUT_OF_MEDIUM_M * 1e3
                );
            }
            max_so_far = max_so_far.max(r.depth_m);
        }
    }
    let pairs: Vec<(f64, f64)> = rows.iter().map(|r| (r.t_s, r.rig_depth_m)).collect();
    let regimes = sinkage_regimes(&pairs, regimes);
    let loaded = regimes
        .iter()
        .filter(|g| **g == SinkageRegime::Loading)
        .count();
    if loaded == 0 {
        bail!(
            "{name}: no loaded part: the plate reaches {:.2} mm but never moves down faster than {} mm/s below the surface",
            deepest * 1e3,
            regimes_speed_mm_s(&RegimeOptions::default())
        );
    }
    Ok(PlateTest {
        file: file.to_path_buf(),
        plate,
        depth_column,
        rows,
        skipped_rows,
        spike_rows,
        regimes,
        sidecar,
    })
}

/// Which depth samples are a potentiometer's spikes: a sample (or two together) that leaves
/// the samples about it, which agree with each other, by far more than the rig moves between
/// samples (ten times the test's median step, and at least 2 mm).
pub fn spikes(depth_m: &[f64]) -> Vec<bool> {
    let n = depth_m.len();
    let mut out = vec![false; n];
    if n < 5 {
        return out;
    }
    let mut steps: Vec<f64> = depth_m.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    steps.sort_by(f64::total_cmp);
    let jump = (10.0 * steps[steps.len() / 2]).max(SPIKE_MIN_M);
    for i in 0..n {
        // Two samples each side, skipping a neighbour that is itself far (a spike of two).
        let around: Vec<f64> = [
            i.wrapping_sub(3),
            i.wrapping_sub(2),
            i.wrapping_sub(1),
            i + 1,
            i + 2,
            i + 3,
        ]
        .into_iter()
        .filter(|&j| j < n)
        .map(|j| depth_m[j])
        .collect();
        let mut a = around.clone();
        a.sort_by(f64::total_cmp);
        let mid = a[a.len() / 2];
        let close = a.iter().filter(|v| (**v - mid).abs() <= 0.5 * jump).count();
        if (depth_m[i] - mid).abs() > jump && close + 2 >= a.len() {
            out[i] = true;
        }
    }
    out
}

/// The least a spike leaves its neighbours by (m).
const SPIKE_MIN_M: f64 = 2e-3;

/// The rows of each intrusion: the maximal stretches between rows at least
/// [`OUT_OF_MEDIUM_M`] above the surface that go below it.
fn intrusions(rows: &[TestRow]) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let mut start = None;
    for (i, r) in rows.iter().enumerate() {
        if r.rig_depth_m < -OUT_OF_MEDIUM_M {
            if let Some(s) = start.take() {
                out.push(s..i);
            }
        } else if start.is_none() {
            start = Some(i);
        }
    }
    if let Some(s) = start {
        out.push(s..rows.len());
    }
    out.retain(|r| rows[r.clone()].iter().any(|row| row.depth_m > 0.0));
    out
}

/// The stretches of rows at least [`OUT_OF_MEDIUM_M`] above the surface, each with the
/// intrusion of `parts` ([`intrusions`]) it comes before (0-based; `parts.len()` for one after
/// the last).
fn out_of_medium(
    rows: &[TestRow],
    parts: &[std::ops::Range<usize>],
) -> Vec<(std::ops::Range<usize>, usize)> {
    let mut out = Vec::new();
    let mut start = None;
    for i in 0..=rows.len() {
        let out_here = rows
            .get(i)
            .is_some_and(|r| r.rig_depth_m < -OUT_OF_MEDIUM_M);
        match (out_here, start) {
            (true, None) => start = Some(i),
            (false, Some(s)) => {
                let next = parts.iter().filter(|p| p.start < s).count();
                out.push((s..i, next));
                start = None;
            }
            _ => {}
        }
    }
    out
}

fn regimes_speed_mm_s(o: &RegimeOptions) -> f64 {
    o.min_speed_m_s * 1e3
}

fn sidecar_of(file: &Path, json: &serde_json::Value) -> RunSidecar {
    let num = |ptr: &str| json.pointer(ptr).and_then(|v| v.as_f64());
    RunSidecar {
        file: file.to_path_buf(),
        bulk_density_kg_m3: num("/medium/bulk_density_kg_m3"),
        angle_of_repose_deg: num("/medium/angle_of_repose_deg"),
        zero_fz_n: num("/offsets/zero_bag_mean_F_N/2"),
        in_air_fz_n: num("/offsets/in_air_mean_F_N/2"),
        t_motion_start_s: num("/offsets/t_motion_start_s"),
    }
}

/// RFT's `alpha_z` for a horizontal plate moving straight down (N/cm^3), from the `poppy_lp`
/// coefficients: what the RFT law scales.
pub fn rft_alpha_z_down_n_cm3() -> f64 {
    use crate::model::RftCoefficients;
    RftCoefficients::by_name(crate::medium_file::RFT_SET, None)
        .expect("a built-in set")
        .alpha_z_down_n_cm3()
}

/// The unit weight the tests give (N/m^3): their bulk density times g, the same in every test
/// that gives one; `fallback` where none does.
pub fn unit_weight_of(tests: &[PlateTest], fallback: Option<f64>) -> Result<(f64, String)> {
    if let Some(w) = fallback {
        return Ok((w, "given (--unit-weight-n-m3)".into()));
    }
    let densities: Vec<(f64, &Path)> = tests
        .iter()
        .filter_map(|t| {
            t.sidecar
                .as_ref()
                .and_then(|s| s.bulk_density_kg_m3.map(|d| (d, s.file.as_path())))
        })
        .collect();
    let Some(&(d, file)) = densities.first() else {
        bail!("no test gives the sand's bulk density: pass --unit-weight-n-m3");
    };
    if let Some((other, f2)) = densities.iter().find(|(o, _)| (o - d).abs() > 1e-9) {
        bail!(
            "the tests give different bulk densities ({d} kg/m^3 in {}, {other} in {}): calibrate one sand at a time",
            file.display(),
            f2.display()
        );
    }
    Ok((
        d * G_M_S2,
        format!("bulk density {d} kg/m^3 in {} times g", file.display()),
    ))
}

/// Every law fitted to the tests' loaded rows, best R^2 first; a law that cannot be fitted is
/// left out with its reason.
pub fn calibrate(
    tests: &[PlateTest],
    unit_weight_n_m3: f64,
) -> (Vec<SinkageFit>, Vec<(SinkageLaw, String)>) {
    let loaded: Vec<LoadedTest> = tests.iter().map(PlateTest::loaded).collect();
    let alpha = rft_alpha_z_down_n_cm3();
    let mut fits = Vec::new();
    let mut failed = Vec::new();
    for law in SinkageLaw::ALL {
        match crate::ident::scatter::fit_over_trials(law, &loaded, unit_weight_n_m3, alpha) {
            Ok(f) => fits.push(f),
            Err(e) => failed.push((law, e.to_string())),
        }
    }
    fits.sort_by(|a, b| b.r2.total_cmp(&a.r2));
    (fits, failed)
}

/// One test predicted by a law calibrated on the tests of the other plate sizes.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HeldOut {
    /// The law.
    pub law: SinkageLaw,
    /// The held-out test's fit, with nothing fitted to it.
    pub fit: TestFit,
    /// The depth exponent the test measures: slope of `ln F` on `ln z` over its loaded rows
    /// deeper than 3 mm.
    pub measured_exponent: f64,
    /// The same slope of the law's predictions over the same rows.
    pub predicted_exponent: f64,
    /// The test's stress at [`STRESS_DEPTH_M`] over the mean of the calibration tests' (each
    /// from its own log-log line), as measured.
    pub measured_stress_ratio: f64,
    /// The same ratio as the law predicts it.
    pub predicted_stress_ratio: f64,
    /// What the fold's fit held, in words: its width term where the training set has one plate
    /// size, a value on its physical bound. Empty: nothing.
    pub held: Vec<String>,
}

fn log_line(rows: &[(f64, f64)]) -> Option<(f64, f64)> {
    let pts: Vec<(f64, f64)> = rows
        .iter()
        .filter(|&&(z, f)| z > 3e-3 && f > 0.0)
        .map(|&(z, f)| (z.ln(), f.ln()))
        .collect();
    if pts.len() < 3 {
        return None;
    }
    let n = pts.len() as f64;
    let (mx, my) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let slope = sxy / sxx;
    Some((slope, my - slope * mx))
}

fn stress_at(test: &LoadedTest, depth_m: f64) -> Option<f64> {
    log_line(&test.rows).map(|(n, c)| (c + n * depth_m.ln()).exp() / test.plate.area_m2())
}

/// Each test predicted by each law calibrated on the tests of the other plate sizes (needs
/// three sizes or more for a law with a width term to see two).
pub fn cross_validate(tests: &[PlateTest], unit_weight_n_m3: f64) -> Result<Vec<HeldOut>> {
    let loaded: Vec<LoadedTest> = tests.iter().map(PlateTest::loaded).collect();
    let mut sizes: Vec<String> = loaded.iter().map(|t| t.plate.label()).collect();
    sizes.sort();
    sizes.dedup();
    if sizes.len() < 2 {
        bail!(
            "cross-validation by plate size needs tests of at least two plate sizes (got {})",
            sizes.join(", ")
        );
    }
    let alpha = rft_alpha_z_down_n_cm3();
    let mut out = Vec::new();
    for law in SinkageLaw::ALL {
        for size in &sizes {
            let train: Vec<LoadedTest> = loaded
                .iter()
                .filter(|t| &t.plate.label() != size)
                .cloned()
                .collect();
            let fit = fit_sinkage(law, &train, unit_weight_n_m3, alpha)
                .with_context(|| format!("{} calibrated without {size}", law.name()))?;
            let train_stress: Vec<f64> = train
                .iter()
                .filter_map(|t| stress_at(t, STRESS_DEPTH_M))
                .collect();
            let train_mean = train_stress.iter().sum::<f64>() / train_stress.len().max(1) as f64;
            let predicted_train = train
                .iter()
                .map(|t| fit.model.pressure_pa(&t.plate, STRESS_DEPTH_M))
                .sum::<f64>()
                / train.len().max(1) as f64;
            let mut held: Vec<String> = fit
                .on_bound
                .iter()
                .map(|(name, bound)| format!("{name} on its bound {bound}"))
                .collect();
            if fit.width_held
                && let Some((i, neutral)) = law.width_param()
            {
                held.push(format!(
                    "{} held at {neutral}: the training set has one plate size",
                    law.param_names()[i]
                ));
            }
            for test in loaded.iter().filter(|t| &t.plate.label() == size) {
                let judged = judge(&fit.model, std::slice::from_ref(test)).remove(0);
                let predicted_rows: Vec<(f64, f64)> = test
                    .rows
                    .iter()
                    .map(|&(z, _)| (z, fit.model.force_n(&test.plate, z)))
                    .collect();
                out.push(HeldOut {
                    law,
                    fit: judged,
                    measured_exponent: log_line(&test.rows).map_or(f64::NAN, |l| l.0),
                    predicted_exponent: log_line(&predicted_rows).map_or(f64::NAN, |l| l.0),
                    measured_stress_ratio: stress_at(test, STRESS_DEPTH_M)
                        .map_or(f64::NAN, |s| s / train_mean),
                    predicted_stress_ratio: fit.model.pressure_pa(&test.plate, STRESS_DEPTH_M)
                        / predicted_train,
                    held: held.clone(),
                });
            }
        }
    }
    Ok(out)
}

/// A held-out plate size's figures: the means over its tests.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HeldOutSize {
    /// The law.
    pub law: SinkageLaw,
    /// The plate size.
    pub plate: String,
    /// Tests of that size.
    pub tests: usize,
    /// The lowest R^2 of its tests.
    pub worst_r2: f64,
    /// Mean measured depth exponent.
    pub measured_exponent: f64,
    /// Mean predicted depth exponent.
    pub predicted_exponent: f64,
    /// Mean measured stress ratio.
    pub measured_stress_ratio: f64,
    /// Mean predicted stress ratio.
    pub predicted_stress_ratio: f64,
}

/// [`cross_validate`]'s rows summarised per law and plate size.
pub fn by_size(held: &[HeldOut]) -> Vec<HeldOutSize> {
    let mut out: Vec<HeldOutSize> = Vec::new();
    for h in held {
        let i = match out
            .iter()
            .position(|s| s.law == h.law && s.plate == h.fit.plate)
        {
            Some(i) => i,
            None => {
                out.push(HeldOutSize {
                    law: h.law,
                    plate: h.fit.plate.clone(),
                    tests: 0,
                    worst_r2: f64::INFINITY,
                    measured_exponent: 0.0,
                    predicted_exponent: 0.0,
                    measured_stress_ratio: 0.0,
                    predicted_stress_ratio: 0.0,
                });
                out.len() - 1
            }
        };
        let s = &mut out[i];
        s.tests += 1;
        s.worst_r2 = s.worst_r2.min(h.fit.r2);
        s.measured_exponent += h.measured_exponent;
        s.predicted_exponent += h.predicted_exponent;
        s.measured_stress_ratio += h.measured_stress_ratio;
        s.predicted_stress_ratio += h.predicted_stress_ratio;
    }
    for s in &mut out {
        let n = s.tests as f64;
        s.measured_exponent /= n;
        s.predicted_exponent /= n;
        s.measured_stress_ratio /= n;
        s.predicted_stress_ratio /= n;
    }
    out
}

/// Whether a CSV file's header is a plate-sinkage test's (a shared run's `time_s, depth_m,
/// fz_n`, or a plain log's `t_s, depth_m, force_n`).
pub fn is_plate_test(file: &Path) -> bool {
    let Some(cols) = super::files::header_columns(file) else {
        return false;
    };
    let has = |c: &str| cols.iter().any(|h| h == c);
    (has("time_s") && has("fz_n")) || (has("depth_m") && has("force_n")) || is_export(file)
}

/// Whether `file` is a bevameter's export ([`super::plate_export`]): a header of force and
/// sinkage after lines of free text. One that names itself so but does not read is one too
/// (its reader then says what is wrong with it).
fn is_export(file: &Path) -> bool {
    const MAX_BYTES: u64 = 64 << 20;
    if std::fs::metadata(file).map_or(true, |m| m.len() > MAX_BYTES) {
        return false;
    }
    let Ok(text) = std::fs::read_to_string(file) else {
        return false;
    };
    !matches!(
        super::plate_export::parse_export(&file.display().to_string(), &text, None),
        Ok(None)
    )
}

/// The sensor's offset against its zero file, read where the plate is out of the medium: at
/// least [`OUT_OF_MEDIUM_M`] above the surface before each intrusion, and after the last if the
/// log leaves the medium.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OffsetReading {
    /// The intrusion it is read before (1 for the first), or `None` after the last.
    pub before_intrusion: Option<usize>,
    /// The first and last time of its rows (s).
    pub from_s: f64,
    /// The last time (s).
    pub to_s: f64,
    /// Mean reading minus the zero file's mean (N).
    pub offset_n: f64,
    /// Rows it is the mean of.
    pub rows: usize,
}

/// The offsets of a test against its zero file.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Offsets {
    /// The zero file's mean (N, as the sensor reads).
    pub zero_n: f64,
    /// Each stretch out of the medium, in time order.
    pub readings: Vec<OffsetReading>,
    /// The last reading minus the first (N), with two readings or more: how far the offset
    /// drifted over the log.
    pub drift_n: Option<f64>,
}

/// A plate-sinkage test's diagnosis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TestDiagnosis {
    /// The test's file.
    pub file: PathBuf,
    /// The plate.
    pub plate: String,
    /// The medium file's name and law.
    pub medium: String,
    /// Intrusions in the log (each leaves the medium before the next).
    pub intrusions: usize,
    /// The fit of bias, surface and scale, the sensor's habits, the gap by depth and speed.
    pub gap: crate::diagnose::sinkage::SinkageDiagnosis,
    /// The sensor's offset against its zero file, where the test has the raw reading and a
    /// zero file's mean.
    pub offsets: Option<Offsets>,
}

/// Diagnoses a test against a calibrated medium.
pub fn diagnose_test(test: &PlateTest, medium: &MediumFile) -> Result<TestDiagnosis> {
    use crate::diagnose::sinkage::{TestSample, diagnose_sinkage};
    let model = medium.model()?;
    let samples: Vec<TestSample> = test
        .rows
        .iter()
        .zip(&test.regimes)
        .map(|(r, g)| TestSample {
            t_s: r.t_s,
            depth_m: r.depth_m,
            force_n: r.force_n,
            regime: *g,
        })
        .collect();
    let gap = diagnose_sinkage(&model, &test.plate, &samples)
        .with_context(|| format!("{}", test.file.display()))?;
    let parts = intrusions(&test.rows);
    let offsets = test
        .sidecar
        .as_ref()
        .and_then(|sc| sc.zero_fz_n)
        .map(|zero| {
            let mut readings: Vec<OffsetReading> = Vec::new();
            for (range, next) in out_of_medium(&test.rows, &parts) {
                let rows = &test.rows[range];
                let raw: Vec<f64> = rows.iter().filter_map(|r| r.raw_force_n).collect();
                if raw.is_empty() {
                    continue;
                }
                let before_intrusion = (next < parts.len()).then_some(next + 1);
                let (from_s, to_s) = (rows[0].t_s, rows[rows.len() - 1].t_s);
                let sum: f64 = raw.iter().sum();
                match readings.last_mut() {
                    // Stretches with no intrusion between them are one reading.
                    Some(last) if last.before_intrusion == before_intrusion => {
                        let n = last.rows + raw.len();
                        last.offset_n =
                            ((last.offset_n + zero) * last.rows as f64 + sum) / n as f64 - zero;
                        last.rows = n;
                        last.to_s = to_s;
                    }
                    _ => readings.push(OffsetReading {
                        before_intrusion,
                        from_s,
                        to_s,
                        offset_n: sum / raw.len() as f64 - zero,
                        rows: raw.len(),
                    }),
                }
            }
            let drift_n = (readings.len() >= 2)
                .then(|| readings[readings.len() - 1].offset_n - readings[0].offset_n);
            Offsets {
                zero_n: zero,
                readings,
                drift_n,
            }
        });
    Ok(TestDiagnosis {
        file: test.file.clone(),
        plate: test.plate.label(),
        medium: format!("{} ({})", medium.name, medium.law.name()),
        intrusions: parts.len(),
        gap,
        offsets,
    })
}

/// Diagnoses the test `file` (its plate from its JSON, else `plate`) against the medium file
/// `medium_file`, and writes the diagnosis as `report.json` into `out` (made if missing); an
/// output that would overwrite either input is refused before anything is read. Returns the
/// diagnosis and the JSON written.
pub fn diagnose_test_to_dir(
    file: &Path,
    medium_file: &Path,
    plate: Option<PlateShape>,
    out: &Path,
) -> Result<(TestDiagnosis, String)> {
    let inputs = [file, medium_file];
    super::files::refuse_output_over_input(out, &inputs)?;
    let report = out.join("report.json");
    super::files::refuse_output_over_input(&report, &inputs)?;
    let medium = MediumFile::read(medium_file)?;
    let test = read_test(
        file,
        plate,
        DepthColumn::AsLogged,
        &RegimeOptions::default(),
    )?;
    let d = diagnose_test(&test, &medium)?;
    let json = serde_json::to_string_pretty(&d)? + "\n";
    std::fs::create_dir_all(out)
        .map_err(anyhow::Error::from)
        .context(super::files::cannot_write(out))?;
    super::files::write_text(&report, &json).context(super::files::cannot_write(&report))?;
    Ok((d, json))
}

/// A test's diagnosis in words.
pub fn diagnosis_text(d: &TestDiagnosis) -> String {
    let g = &d.gap;
    let mut s = format!(
        "{} ({}) against medium {}: {} intrusion{}, {} rows, {} used (loading, and above the surface before it)\n",
        d.file.display(),
        d.plate,
        d.medium,
        d.intrusions,
        if d.intrusions == 1 { "" } else { "s" },
        g.rows,
        g.rows_used
    );
    match &g.sensor {
        Some(h) => {
            s += &format!(
                "sensor: rows at {:.1} Hz, the value changes at {:.1} Hz (held {:.0} ms, {:.1} rows per value)\n",
                h.stream_rate_hz,
                h.update_rate_hz,
                h.hold_s * 1e3,
                h.rows_per_value
            )
        }
        None => s += "sensor: too few changes of value to tell its rate\n",
    }
    if let Some(o) = &d.offsets {
        s += &format!(
            "offset against the zero file ({:.3} N), read at least {:.0} mm above the surface:\n",
            o.zero_n,
            OUT_OF_MEDIUM_M * 1e3
        );
        for r in &o.readings {
            s += &format!(
                "  {:<22} {:>+8.3} N  ({} rows, t {:.1} s to {:.1} s)\n",
                match r.before_intrusion {
                    Some(k) => format!("before intrusion {k}"),
                    None => "after the last".to_string(),
                },
                r.offset_n,
                r.rows,
                // No "-0.0" for a stretch that starts a millisecond before zero.
                (r.from_s * 10.0).round() / 10.0 + 0.0,
                r.to_s
            );
        }
        if let Some(d) = o.drift_n {
            s += &format!("  drift over the log      {d:>+8.3} N\n");
        }
        if o.readings
            .last()
            .is_some_and(|r| r.before_intrusion.is_some())
        {
            s += "  none after (the log ends in the medium)\n";
        }
    }
    s += &format!(
        "bias on the force: {:+.3} +- {:.3} N\nsurface: {:+.2} +- {:.2} mm to add to the depth\nmedium scale: {:.3} +- {:.3} of the calibrated law\n",
        g.bias_n.value,
        g.bias_n.std_dev,
        g.depth_shift_m.value * 1e3,
        g.depth_shift_m.std_dev * 1e3,
        g.scale.value,
        g.scale.std_dev
    );
    s += &format!(
        "loaded rows: R^2 {:.3} (RMSE {:.2} N) as calibrated, {:.3} (RMSE {:.2} N) with bias, surface and scale\n",
        g.r2_as_calibrated, g.rmse_as_calibrated_n, g.r2_corrected, g.rmse_corrected_n
    );
    s += "gap as calibrated (measured - predicted), by depth:\n";
    for b in &g.gap_by_depth {
        s += &format!(
            "  {:>6.1} - {:>6.1} mm   {:>4} rows  {:>+8.2} N\n",
            b.from, b.to, b.rows, b.mean_gap_n
        );
    }
    s += "by downward speed:\n";
    for b in &g.gap_by_speed {
        s += &format!(
            "  {:>6.1} - {:>6.1} mm/s {:>4} rows  {:>+8.2} N\n",
            b.from, b.to, b.rows, b.mean_gap_n
        );
    }
    s
}
