//! Intrusion tests on disk: a small flat plate moved through the medium in any direction of the
//! x-z plane (down, obliquely, across, up), as labs and simulations run them to measure RFT's
//! stresses; read for `terzaghi calibrate`, which fits RFT's angular shape, law in depth and
//! speed law to them ([`crate::ident::rft_shape`]).
//!
//! The format, so that any lab or simulation can write it: a CSV with the columns
//! `t_s, x_m, depth_m, fx_n, fz_n` (the plate centre's horizontal position, its depth below the
//! free surface, positive down and negative above it; the force of the medium on the plate
//! along +x and upward), and beside it a JSON of the same name:
//!
//! ```json
//! { "plate_chord_m": 0.025, "plate_width_m": 0.025, "chord_angle_deg": 30,
//!   "unit_weight_n_m3": 14268, "speed_m_s": 0.05, "description": "..." }
//! ```
//!
//! `plate_chord_m` lies in the plane of motion, `plate_width_m` across it, and the chord along
//! `(cos a, sin a)` in the x-z plane with z up, `a` = `chord_angle_deg` in [-180, 180].
//! `unit_weight_n_m3`, `speed_m_s` (checked against the log's own) and `description` are
//! optional; any other key is refused by name. The direction of motion comes from the log.

use crate::ident::rft_shape::{
    HeldOutIntrusion, IntrusionRow, IntrusionTest, RftShapeFit, ShapeOptions, cross_validate_shape,
    fit_shape,
};
use anyhow::{Context, Result, bail};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The columns of an intrusion test's CSV, in this order.
pub const COLUMNS: [&str; 5] = ["t_s", "x_m", "depth_m", "fx_n", "fz_n"];

/// A log's speed may differ from its JSON's `speed_m_s` by this factor at most.
const SPEED_TOLERANCE: f64 = 1.25;

/// The JSON beside an intrusion test.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IntrusionSidecar {
    /// The plate's chord, in the plane of motion (m).
    pub plate_chord_m: f64,
    /// The plate's width, across the plane of motion (m).
    pub plate_width_m: f64,
    /// The chord's angle: along `(cos a, sin a)` in the x-z plane, z up (deg).
    pub chord_angle_deg: f64,
    /// The medium's unit weight (N/m^3).
    #[serde(default)]
    pub unit_weight_n_m3: Option<f64>,
    /// The speed the plate was driven at (m/s).
    #[serde(default)]
    pub speed_m_s: Option<f64>,
    /// Where the test comes from, in words.
    #[serde(default)]
    pub description: Option<String>,
}

/// An intrusion test read from disk.
#[derive(Debug, Clone, PartialEq)]
pub struct IntrusionFile {
    /// The CSV file.
    pub file: PathBuf,
    /// Its JSON.
    pub sidecar: IntrusionSidecar,
    /// The test.
    pub test: IntrusionTest,
}

/// Whether `file`'s header (its first line that is not a `#` comment) names the columns of an
/// intrusion test. Reads the header alone.
pub fn is_intrusion_test(file: &Path) -> bool {
    super::files::header_columns(file)
        .is_some_and(|cols| cols.iter().any(|c| c == "x_m") && cols.iter().any(|c| c == "fx_n"))
}

/// Reads an intrusion test: its CSV and the JSON of the same name beside it. A missing or
/// unknown column or key, a cell that is not a finite number, time that does not increase, a
/// plate size that is not positive and a chord angle outside [-180, 180] deg are refused,
/// naming the file, the line and the value.
pub fn read_intrusion_test(file: &Path) -> Result<IntrusionFile> {
    let text =
        std::fs::read_to_string(file).with_context(|| format!("cannot read {}", file.display()))?;
    let json_file = file.with_extension("json");
    let json = std::fs::read_to_string(&json_file).with_context(|| {
        format!(
            "cannot read {} (an intrusion test has its JSON beside its CSV: plate_chord_m, plate_width_m, chord_angle_deg)",
            json_file.display()
        )
    })?;
    parse_intrusion_test(file, &text, &json)
}

/// [`read_intrusion_test`] on texts already read: the CSV `text` of the test named `file` and
/// its JSON `json`. Nothing is read from disk.
pub fn parse_intrusion_test(file: &Path, text: &str, json: &str) -> Result<IntrusionFile> {
    let name = file.display().to_string();
    let json_file = file.with_extension("json");
    let sidecar: IntrusionSidecar = serde_json::from_str(json)
        .with_context(|| format!("{} is not an intrusion test's JSON", json_file.display()))?;
    if let Some(w) = sidecar.unit_weight_n_m3
        && !(w.is_finite() && w > 0.0)
    {
        bail!(
            "{}: unit_weight_n_m3 must be a number > 0, got {w}",
            json_file.display()
        );
    }
    if let Some(v) = sidecar.speed_m_s
        && !(v.is_finite() && v > 0.0)
    {
        bail!(
            "{}: speed_m_s must be a number > 0, got {v}",
            json_file.display()
        );
    }
    let (mut rdr, headers) = crate::session::files::csv_table(&name, text)?;
    if let Some(h) = headers.iter().find(|h| !COLUMNS.contains(&h.as_str())) {
        bail!(
            "{name}: unknown column {h:?}; an intrusion test has {}",
            COLUMNS.join(", ")
        );
    }
    let idx: Vec<usize> = COLUMNS
        .iter()
        .map(|c| {
            headers.iter().position(|h| h == c).with_context(|| {
                format!(
                    "{name}: header lacks column {c:?} (found: {}; an intrusion test has {})",
                    headers.join(","),
                    COLUMNS.join(", ")
                )
            })
        })
        .collect::<Result<_>>()?;
    let mut rows = Vec::new();
    for rec in rdr.records() {
        let rec = rec.with_context(|| format!("{name}: malformed CSV"))?;
        let line = rec.position().map(|p| p.line()).unwrap_or(0);
        let mut v = [0.0; 5];
        for (slot, (&i, col)) in v.iter_mut().zip(idx.iter().zip(COLUMNS)) {
            let cell = rec.get(i).unwrap_or("");
            let x: f64 = cell
                .parse()
                .ok()
                .filter(|x: &f64| x.is_finite())
                .with_context(|| {
                    format!("{name} line {line}, column {col}: {cell:?} is not a finite number")
                })?;
            *slot = x;
        }
        rows.push(IntrusionRow {
            t_s: v[0],
            x_m: v[1],
            depth_m: v[2],
            fx_n: v[3],
            fz_n: v[4],
        });
    }
    let test = IntrusionTest::new(
        &stem(file),
        sidecar.plate_chord_m,
        sidecar.plate_width_m,
        sidecar.chord_angle_deg.to_radians(),
        rows,
    )
    .map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
    Ok(IntrusionFile {
        file: file.to_path_buf(),
        sidecar,
        test,
    })
}

fn stem(file: &Path) -> String {
    file.file_stem().map_or_else(
        || file.display().to_string(),
        |s| s.to_string_lossy().into(),
    )
}

/// The shape fitted to `tests` ([`fit_shape`]), each test's JSON speed checked against its log.
pub fn calibrate_shape(tests: &[IntrusionFile], o: &ShapeOptions) -> Result<RftShapeFit> {
    let plain: Vec<IntrusionTest> = tests.iter().map(|t| t.test.clone()).collect();
    let fit = fit_shape(&plain, o).map_err(|e| anyhow::anyhow!(e))?;
    for (t, s) in tests.iter().zip(&fit.tests) {
        if let Some(given) = t.sidecar.speed_m_s {
            let ratio = s.speed_m_s / given;
            if !(1.0 / SPEED_TOLERANCE..=SPEED_TOLERANCE).contains(&ratio) {
                bail!(
                    "{}: its JSON gives speed_m_s {given}, but the log moves at {:.4} m/s in the medium (x_m and depth_m over t_s)",
                    t.file.display(),
                    s.speed_m_s
                );
            }
        }
    }
    Ok(fit)
}

/// Each quasi-static test predicted from the others ([`cross_validate_shape`]), `fit` being
/// [`calibrate_shape`] of the same tests and options.
pub fn cross_validate_tests(
    tests: &[IntrusionFile],
    o: &ShapeOptions,
    fit: &RftShapeFit,
) -> Result<(Vec<HeldOutIntrusion>, Vec<String>)> {
    let plain: Vec<IntrusionTest> = tests.iter().map(|t| t.test.clone()).collect();
    cross_validate_shape(&plain, o, fit).map_err(|e| anyhow::anyhow!(e))
}

/// The tests' unit weight: `given`, or the one their JSONs agree on (within 1 %), with where it
/// came from; `None` where neither says.
pub fn unit_weight_of_tests(
    tests: &[IntrusionFile],
    given: Option<f64>,
) -> Result<Option<(f64, String)>> {
    if let Some(w) = given {
        return Ok(Some((w, "--unit-weight-n-m3".into())));
    }
    let stated: Vec<(&IntrusionFile, f64)> = tests
        .iter()
        .filter_map(|t| Some((t, t.sidecar.unit_weight_n_m3?)))
        .collect();
    let Some(&(first, w)) = stated.first() else {
        return Ok(None);
    };
    if let Some((t, other)) = stated.iter().find(|(_, v)| (v / w - 1.0).abs() > 0.01) {
        bail!(
            "the tests disagree on the unit weight: {} gives {w} N/m^3, {} gives {other} N/m^3 (give --unit-weight-n-m3, or calibrate one medium at a time)",
            first.file.display(),
            t.file.display()
        );
    }
    Ok(Some((
        w,
        format!(
            "unit_weight_n_m3 in {}",
            first.file.with_extension("json").display()
        ),
    )))
}
