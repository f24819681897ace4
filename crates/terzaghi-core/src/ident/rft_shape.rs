//! RFT's angular shape measured: Li, Zhang and Goldman's nine coefficients and a law in depth,
//! fitted to intrusion tests of a small flat plate moving in any direction in the x-z plane
//! (down, obliquely, across, up), with their standard deviations; and RFT's speed law from the
//! same tests run at several speeds. Pure: tests in, a fit out.
//!
//! A test is a log of the plate centre's horizontal position `x` and depth below the free
//! surface (positive down), and the force of the medium on the plate along `+x` and up, with the
//! plate's chord (in the plane of motion), width (across it) and chord angle `a` (the chord lies
//! along `(cos a, sin a)`, z up). The direction of motion comes from the log: each row's
//! velocity is the centred difference over half a millimetre of travel either side.
//!
//! The model of a row: the plate cut into [`ShapeOptions::elements`] elements along its chord,
//! each below the surface feels `alpha(beta, gamma) z_ref (z / z_ref)^n dA` (`z_ref` 1 cm; the
//! stress RFT gives at depth `z` when `n` is 1), `beta` the chord's attack angle and `gamma` the
//! motion's angle below the horizontal in RFT's frame (the motion toward `+x`: a test moving
//! toward `-x` is mirrored). `alpha_z`'s five coefficients and `alpha_x`'s four are linear in the
//! row's force for a given `n`, so the fit is linear least squares inside a one-dimensional search
//! of `n` and a surface offset. Residuals are stresses (a row's force over its test's mean depth
//! times area), each test's rows weighed by one over the square root of their count: every test
//! weighs by its stresses, as Li et al. fitted theirs, whatever its length.
//!
//! A plate pushed from rest through a hole cut for it meets grains that have not yet jammed: a
//! test that starts with the whole plate below the surface is fitted from
//! [`ShapeOptions::buried_start_chords`] chords of travel on; one that starts above the surface
//! is fitted from its first row in the medium, its entry being part of what RFT describes.
//!
//! Where the tests do not tell the nine terms apart (plates pushed straight down only, say), the
//! shape is the preset's ([`ShapeOptions::preset`]) times one scale, and the fit says so
//! ([`ShapeForm::PresetScaled`]). Standard deviations are the jackknife's over tests (each test
//! left out in turn): a test's rows are not independent of each other, the tests are.

use crate::model::{RftCoefficients, RftFit, RftSpeedFit, RftSpeedTable};
use nalgebra::{DMatrix, DVector};

use serde::Serialize;
use std::f64::consts::FRAC_PI_2;

/// N/cm^3 to N/m^3.
const N_CM3_TO_N_M3: f64 = 1e6;
/// The depth law's reference depth (m): coefficients are the stress per depth at 1 cm.
pub const REF_DEPTH_M: f64 = 0.01;
/// A row's velocity is the centred difference over this much travel either side (m).
const VELOCITY_BASE_M: f64 = 5e-4;
/// The depth exponents searched.
const EXPONENT_RANGE: (f64, f64) = (0.4, 2.5);

/// One row of an intrusion test.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct IntrusionRow {
    /// Time (s).
    pub t_s: f64,
    /// The plate centre's horizontal position (m).
    pub x_m: f64,
    /// The plate centre's depth below the free surface (m; negative above it).
    pub depth_m: f64,
    /// The medium's force on the plate along +x (N).
    pub fx_n: f64,
    /// The medium's force on the plate, up (N).
    pub fz_n: f64,
}

/// An intrusion test: a small flat plate moved through the medium, and its force.
#[derive(Debug, Clone, PartialEq)]
pub struct IntrusionTest {
    /// What the test is called in tables (its file's name).
    pub name: String,
    /// The plate's chord, in the plane of motion (m).
    pub chord_m: f64,
    /// The plate's width, across the plane of motion (m).
    pub width_m: f64,
    /// The chord's angle: it lies along `(cos a, sin a)` in the x-z plane, z up (rad).
    pub chord_angle_rad: f64,
    /// The rows, in time order.
    pub rows: Vec<IntrusionRow>,
}

impl IntrusionTest {
    /// A test, checked: a positive chord and width, a chord angle within +-180 deg, at least two
    /// rows, every value finite, time increasing. An error names the value.
    pub fn new(
        name: &str,
        chord_m: f64,
        width_m: f64,
        chord_angle_rad: f64,
        rows: Vec<IntrusionRow>,
    ) -> Result<IntrusionTest, String> {
        for (what, v) in [("plate_chord_m", chord_m), ("plate_width_m", width_m)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("{name}: {what} must be a number > 0, got {v}"));
            }
        }
        if !(chord_angle_rad.is_finite() && chord_angle_rad.abs() <= std::f64::consts::PI + 1e-12) {
            return Err(format!(
                "{name}: chord_angle_deg must be within [-180, 180] deg, got {}",
                chord_angle_rad.to_degrees()
            ));
        }
        if rows.len() < 2 {
            return Err(format!(
                "{name}: {} rows; a test needs at least two",
                rows.len()
            ));
        }
        for (i, r) in rows.iter().enumerate() {
            let cells = [r.t_s, r.x_m, r.depth_m, r.fx_n, r.fz_n];
            if let Some(k) = cells.iter().position(|v| !v.is_finite()) {
                return Err(format!(
                    "{name}: row {} has {} = {} (every value must be finite)",
                    i + 1,
                    ["t_s", "x_m", "depth_m", "fx_n", "fz_n"][k],
                    cells[k]
                ));
            }
            if i > 0 && r.t_s <= rows[i - 1].t_s {
                return Err(format!(
                    "{name}: row {} has t_s {} after {}: time must increase",
                    i + 1,
                    r.t_s,
                    rows[i - 1].t_s
                ));
            }
        }
        Ok(IntrusionTest {
            name: name.to_string(),
            chord_m,
            width_m,
            chord_angle_rad,
            rows,
        })
    }

    /// Whether the whole plate is below the surface at the first row (pushed from rest through
    /// a hole cut for it).
    pub fn starts_buried(&self) -> bool {
        self.rows[0].depth_m - 0.5 * self.chord_m * self.chord_angle_rad.sin().abs() > 0.0
    }
}

/// Options of the fit.
#[derive(Debug, Clone, PartialEq)]
pub struct ShapeOptions {
    /// A test that starts buried is fitted from this many chords of travel on.
    pub buried_start_chords: f64,
    /// Elements a plate is cut into along its chord.
    pub elements: usize,
    /// The shape of the reduced form, where the tests do not tell the nine terms apart.
    pub preset: RftFit,
    /// Its name, in reports.
    pub preset_name: &'static str,
    /// A test whose speed is within this factor of the slowest test's is quasi-static: it
    /// serves the shape; faster ones serve the speed law.
    pub reference_speed_factor: f64,
    /// The depth exponents searched (a single value holds it).
    pub exponent_range: (f64, f64),
    /// The surface offsets searched (m; a single value holds it).
    pub offset_range_m: (f64, f64),
    /// Only tests that start buried serve the shape (those that start above the surface serve
    /// the speed law alone).
    pub shape_from_buried_only: bool,
}

impl Default for ShapeOptions {
    fn default() -> Self {
        ShapeOptions {
            buried_start_chords: 0.6,
            elements: 20,
            preset: RftFit::POPPY_LP,
            preset_name: "poppy_lp",
            reference_speed_factor: 1.25,
            exponent_range: EXPONENT_RANGE,
            offset_range_m: OFFSET_RANGE,
            shape_from_buried_only: false,
        }
    }
}

/// Which form the shape was fitted in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShapeForm {
    /// Li, Zhang and Goldman's nine coefficients, each free.
    LiNine,
    /// A preset's shape times one scale: the tests do not tell the nine terms apart.
    PresetScaled,
}

impl ShapeForm {
    /// Its name in files and tables.
    pub fn name(self) -> &'static str {
        match self {
            ShapeForm::LiNine => "li_nine",
            ShapeForm::PresetScaled => "preset_scaled",
        }
    }
}

/// What one test is in the fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TestSummary {
    /// The test's name.
    pub name: String,
    /// Its plate's chord angle (deg).
    pub chord_angle_deg: f64,
    /// Its direction of motion below the horizontal, in RFT's frame (deg; negative: up), the
    /// median over its rows in the medium.
    pub direction_deg: f64,
    /// Whether it moves toward -x (mirrored into RFT's frame).
    pub toward_minus_x: bool,
    /// Its speed (m/s), the median over its rows in the medium.
    pub speed_m_s: f64,
    /// Rows in the medium and moving.
    pub rows_in_medium: usize,
    /// Of those, the rows the shape was fitted to (0: a faster test, for the speed law).
    pub rows_fitted: usize,
    /// It started buried (its first chords of travel are left out).
    pub starts_buried: bool,
    /// Its measured `alpha_x, alpha_z` (N/cm^3 at 1 cm): the least-squares stress per stressed
    /// depth of its fitted rows (of all its rows in the medium for a faster test).
    pub measured_alpha_n_cm3: [f64; 2],
    /// The same of the fitted shape's forces over the same rows.
    pub fitted_alpha_n_cm3: [f64; 2],
}

/// The shape fitted to intrusion tests.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RftShapeFit {
    /// The form.
    pub form: ShapeForm,
    /// Why the reduced form, where it is.
    pub reduced_because: Option<String>,
    /// The coefficients (N/cm^3: the stress per depth at 1 cm).
    pub coefficients: RftFit,
    /// Their standard deviations (jackknife over tests; 0 where not free).
    pub std_dev: RftFit,
    /// The depth exponent `n`.
    pub depth_exponent: f64,
    /// Its standard deviation.
    pub depth_exponent_std: f64,
    /// The surface offset `z_0` of the law in depth (m): the stress is that at `z + z_0`.
    pub surface_offset_m: f64,
    /// Its standard deviation.
    pub surface_offset_std_m: f64,
    /// `alpha_z` of a horizontal plate moving straight down (N/cm^3) and its standard deviation.
    pub alpha_z_down_n_cm3: [f64; 2],
    /// The speed of the tests the shape was fitted to (m/s): the slowest.
    pub reference_speed_m_s: f64,
    /// R^2 of the horizontal and the vertical force over the fitted rows.
    pub r2: [f64; 2],
    /// RMSE of the horizontal and the vertical force over the fitted rows (N).
    pub rmse_n: [f64; 2],
    /// Rows fitted, over every test.
    pub rows: usize,
    /// Each test.
    pub tests: Vec<TestSummary>,
    /// The speed law, where tests of one plate, angle, direction and start ran at two or more
    /// speeds.
    pub speed: Option<RftSpeedFit>,
    /// The standard deviation of each direction's gain (s), in the law's order (jackknife over
    /// the faster tests).
    pub speed_gain_std_s: Vec<f64>,
    /// Why there is no speed law, where there is none.
    pub no_speed_law_because: Option<String>,
}

/// A fit with one test left out: its coefficients, exponent, offset and `alpha_z` straight
/// down.
type LeaveOut = ([f64; 9], f64, f64, f64);

/// The law in depth: its exponent `n` and surface offset `z_0` (m).
type Depth = (f64, f64);

/// The surface offsets searched (m), from none to two of a coarse bed's grains.
const OFFSET_RANGE: (f64, f64) = (0.0, 0.015);

/// A row made ready: what the fit needs of it at any exponent.
#[derive(Debug, Clone)]
struct Prepared {
    /// The test's index.
    test: usize,
    /// The submerged elements' depths (m), each of area `dA` (m^2).
    depths: Vec<f64>,
    area_m2: f64,
    /// `alpha_z`'s five basis values and `alpha_x`'s four.
    phi_z: [f64; 5],
    phi_x: [f64; 4],
    /// The targets: `fz`, and `-m fx` (the force resisting the motion's horizontal part).
    y_z: f64,
    y_x: f64,
    /// `m`: -1 where the motion is toward -x.
    mirror: f64,
    /// In the shape's fit (quasi-static, past a buried start's transient).
    fitted: bool,
    /// Its gain under RFT's linear law ([`Prepared::gain`] at `n` 1 and no offset).
    ref_gain: f64,
    /// Its index in its test.
    row: usize,
    /// The depth of its centre, the velocity's direction (rad) and speed.
    centre_depth_m: f64,
    gamma_rad: f64,
    speed_m_s: f64,
}

impl Prepared {
    /// `sum dA z_ref ((z + z_0) / z_ref)^n` times 1e6: N per (N/cm^3) of stress, `d` being
    /// `(n, z_0)`.
    fn gain(&self, d: Depth) -> f64 {
        N_CM3_TO_N_M3
            * self.area_m2
            * self
                .depths
                .iter()
                .map(|&z| REF_DEPTH_M * ((z + d.1) / REF_DEPTH_M).powf(d.0))
                .sum::<f64>()
    }
}

/// Every row of `tests` in the medium and moving, made ready; and per test its speed, direction
/// and whether it moves toward -x.
fn prepare(tests: &[IntrusionTest], o: &ShapeOptions) -> (Vec<Prepared>, Vec<(f64, f64, bool)>) {
    let mut out = Vec::new();
    let mut per_test = Vec::new();
    for (ti, t) in tests.iter().enumerate() {
        let (sa, ca) = t.chord_angle_rad.sin_cos();
        let e = o.elements.max(1);
        let ds = t.chord_m / e as f64;
        let buried = t.starts_buried();
        let p0 = (t.rows[0].x_m, t.rows[0].depth_m);
        let mut travel = 0.0;
        let mut last = p0;
        let start = out.len();
        for (i, r) in t.rows.iter().enumerate() {
            travel += (r.x_m - last.0).hypot(r.depth_m - last.1);
            last = (r.x_m, r.depth_m);
            let Some((vx, vz)) = velocity(&t.rows, i) else {
                continue;
            };
            let depths: Vec<f64> = (0..e)
                .map(|k| r.depth_m - ((k as f64 + 0.5) * ds - 0.5 * t.chord_m) * sa)
                .filter(|&z| z > 0.0)
                .collect();
            if depths.is_empty() {
                continue;
            }
            let m = if vx < 0.0 { -1.0 } else { 1.0 };
            // RFT's frame: the motion toward +x; the chord mirrored with it.
            let (tx, tz) = (m * ca, sa);
            let (c2b, s2b) = (tx * tx - tz * tz, 2.0 * tx * tz);
            let v = vx.hypot(vz);
            let (cg, sg) = (m * vx / v, -vz / v);
            let sin_plus = s2b * cg + c2b * sg;
            let sin_minus = sg * c2b - s2b * cg;
            let cos_plus = c2b * cg - s2b * sg;
            let cos_minus = c2b * cg + s2b * sg;
            let area_m2 = ds * t.width_m;
            let ref_gain = N_CM3_TO_N_M3 * area_m2 * depths.iter().sum::<f64>();
            out.push(Prepared {
                test: ti,
                depths,
                area_m2,
                ref_gain,
                row: i,
                phi_z: [1.0, c2b, sin_plus, sg, sin_minus],
                phi_x: [cos_plus, cg, cos_minus, s2b],
                y_z: r.fz_n,
                y_x: -m * r.fx_n,
                mirror: m,
                fitted: if buried {
                    travel >= o.buried_start_chords * t.chord_m
                } else {
                    !o.shape_from_buried_only
                },
                centre_depth_m: r.depth_m,
                gamma_rad: sg.atan2(cg),
                speed_m_s: v,
            });
        }
        let mine = &out[start..];
        let speed = median(mine.iter().map(|p| p.speed_m_s).collect());
        let gamma = median(mine.iter().map(|p| p.gamma_rad).collect());
        let minus = mine.iter().filter(|p| p.mirror < 0.0).count() * 2 > mine.len();
        per_test.push((speed, gamma, minus));
    }
    (out, per_test)
}

/// The velocity `(vx, vz)` (z up) of row `i`: the centred difference to the nearest rows at
/// [`VELOCITY_BASE_M`] of travel either side (one side at a log's ends); none where the plate
/// does not move that far.
fn velocity(rows: &[IntrusionRow], i: usize) -> Option<(f64, f64)> {
    const WINDOW: usize = 2000;
    let at = |j: usize| (rows[j].x_m, -rows[j].depth_m);
    let dist = |j: usize| {
        let (a, b) = (at(i), at(j));
        (a.0 - b.0).hypot(a.1 - b.1)
    };
    let before = (i.saturating_sub(WINDOW)..i)
        .rev()
        .find(|&j| dist(j) >= VELOCITY_BASE_M);
    let after = (i + 1..rows.len().min(i + 1 + WINDOW)).find(|&j| dist(j) >= VELOCITY_BASE_M);
    let (a, b) = match (before, after) {
        (Some(a), Some(b)) => (a, b),
        (Some(a), None) => (a, i),
        (None, Some(b)) => (i, b),
        (None, None) => return None,
    };
    let dt = rows[b].t_s - rows[a].t_s;
    let (pa, pb) = (at(a), at(b));
    let v = ((pb.0 - pa.0) / dt, (pb.1 - pa.1) / dt);
    (v.0.is_finite() && v.1.is_finite() && (v.0 != 0.0 || v.1 != 0.0)).then_some(v)
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The coefficients of one solve, and its weighted sum of squares.
#[derive(Debug, Clone, Copy)]
struct Solve {
    fit: RftFit,
    sse: f64,
}

/// Least squares of the form at exponent `n` over the rows `use_row` takes, each test weighed
/// alike (its rows by one over the square root of their count, and relative to its mean
/// stressed depth); `None` where the rows do not determine it. By normal equations: the
/// designs have five and four columns over thousands of rows.
fn solve(
    rows: &[Prepared],
    use_row: &dyn Fn(&Prepared) -> bool,
    n: Depth,
    form: ShapeForm,
    preset: &RftFit,
) -> Option<Solve> {
    solve_gains(rows, use_row, &|_, r| r.gain(n), form, preset)
}

/// [`solve`] with each row's gain (row index, row) given: [`DepthLogs`] gives them for one
/// surface offset at any exponent.
fn solve_gains(
    rows: &[Prepared],
    use_row: &dyn Fn(&Prepared) -> bool,
    gain: &dyn Fn(usize, &Prepared) -> f64,
    form: ShapeForm,
    preset: &RftFit,
) -> Option<Solve> {
    let tests = rows.iter().map(|r| r.test).max().map_or(0, |m| m + 1);
    let mut count = vec![0usize; tests];
    let mut ref_gain = vec![0.0; tests];
    let gains: Vec<f64> = rows
        .iter()
        .enumerate()
        .map(|(i, r)| {
            if use_row(r) {
                count[r.test] += 1;
                ref_gain[r.test] += r.ref_gain;
                gain(i, r)
            } else {
                0.0
            }
        })
        .collect();
    // Each test's residuals in stress (its force over its mean depth times area, RFT's linear
    // law's: the same whatever law in depth is searched), and its rows by one over the square
    // root of their count: every test weighs by its stresses, as Li et al. fitted theirs,
    // whatever its plate's size or its length.
    let weight = |i: usize| {
        let t = rows[i].test;
        if gains[i] == 0.0 || count[t] == 0 || ref_gain[t] <= 0.0 {
            0.0
        } else {
            let mean = ref_gain[t] / count[t] as f64;
            1.0 / (mean * (count[t] as f64).sqrt())
        }
    };
    let (mut zz, mut zy, mut xx, mut xy, mut yy) = (
        nalgebra::Matrix5::<f64>::zeros(),
        nalgebra::Vector5::<f64>::zeros(),
        nalgebra::Matrix4::<f64>::zeros(),
        nalgebra::Vector4::<f64>::zeros(),
        0.0,
    );
    let (mut pp, mut py) = (0.0, 0.0);
    let mut any = false;
    for (i, r) in rows.iter().enumerate() {
        let w = weight(i);
        if w == 0.0 {
            continue;
        }
        any = true;
        let g = w * gains[i];
        let (yz, yx) = (w * r.y_z, w * r.y_x);
        yy += yz * yz + yx * yx;
        match form {
            ShapeForm::LiNine => {
                let az = nalgebra::Vector5::from_fn(|c, _| g * r.phi_z[c]);
                let ax = nalgebra::Vector4::from_fn(|c, _| g * r.phi_x[c]);
                zz += az * az.transpose();
                zy += az * yz;
                xx += ax * ax.transpose();
                xy += ax * yx;
            }
            ShapeForm::PresetScaled => {
                let (ax, az) = alpha_of(preset, r);
                pp += (g * ax).powi(2) + (g * az).powi(2);
                py += g * ax * yx + g * az * yz;
            }
        }
    }
    if !any {
        return None;
    }
    match form {
        ShapeForm::LiNine => {
            let cz = normal_solve(
                &DMatrix::from_column_slice(5, 5, zz.as_slice()),
                zy.as_slice(),
            )?;
            let cx = normal_solve(
                &DMatrix::from_column_slice(4, 4, xx.as_slice()),
                xy.as_slice(),
            )?;
            let quad = |m: &DMatrix<f64>, b: &[f64], c: &DVector<f64>| {
                let b = DVector::from_column_slice(b);
                (c.transpose() * m * c)[(0, 0)] - 2.0 * c.dot(&b)
            };
            let sse =
                yy + quad(
                    &DMatrix::from_column_slice(5, 5, zz.as_slice()),
                    zy.as_slice(),
                    &cz,
                ) + quad(
                    &DMatrix::from_column_slice(4, 4, xx.as_slice()),
                    xy.as_slice(),
                    &cx,
                );
            Some(Solve {
                fit: RftFit::from_array([
                    cz[0], cz[1], cz[2], cz[3], cz[4], cx[0], cx[1], cx[2], cx[3],
                ]),
                sse: sse.max(0.0),
            })
        }
        ShapeForm::PresetScaled => {
            if pp.is_nan() || pp <= 0.0 {
                return None;
            }
            let s = py / pp;
            Some(Solve {
                fit: preset.scaled(s),
                sse: (yy - 2.0 * s * py + s * s * pp).max(0.0),
            })
        }
    }
}

/// The solution of the normal equations `m x = b`, or `None` where `m` (scaled to a unit
/// diagonal) is nearly singular: the rows do not tell the terms apart.
fn normal_solve(m: &DMatrix<f64>, b: &[f64]) -> Option<DVector<f64>> {
    let k = m.nrows();
    let d: Vec<f64> = (0..k).map(|i| m[(i, i)].sqrt()).collect();
    if d.iter().any(|&v| !(v.is_finite() && v > 0.0)) {
        return None;
    }
    let scaled = DMatrix::from_fn(k, k, |r, c| m[(r, c)] / (d[r] * d[c]));
    let eig = scaled.clone().symmetric_eigen();
    let (lo, hi) = (eig.eigenvalues.min(), eig.eigenvalues.max());
    // The design's condition number is the square root of this one's.
    if lo.is_nan() || lo <= CONDITION_FLOOR * CONDITION_FLOOR * hi {
        return None;
    }
    let rhs = DVector::from_fn(k, |r, _| b[r] / d[r]);
    let y = scaled.cholesky()?.solve(&rhs);
    Some(DVector::from_fn(k, |r, _| y[r] / d[r]))
}

/// `(alpha_x, alpha_z)` of `fit` at a prepared row's angles.
fn alpha_of(fit: &RftFit, p: &Prepared) -> (f64, f64) {
    let z = fit.a00 * p.phi_z[0]
        + fit.a10 * p.phi_z[1]
        + fit.b11 * p.phi_z[2]
        + fit.b01 * p.phi_z[3]
        + fit.bm11 * p.phi_z[4];
    let x =
        fit.c11 * p.phi_x[0] + fit.c01 * p.phi_x[1] + fit.cm11 * p.phi_x[2] + fit.d10 * p.phi_x[3];
    (x, z)
}

/// The smallest singular value of the column-scaled design, relative to the largest, that
/// tells the terms apart.
const CONDITION_FLOOR: f64 = 1e-3;

/// The logarithms `ln((z + z_0) / z_ref)` of every element's depth in the rows a fit takes, at
/// one surface offset `z_0`: a row's gain at any exponent `n` is then a sum of `exp(n ln)`,
/// where [`Prepared::gain`] takes a `pow` per element (the search over `n` at one offset makes
/// thirty of them).
struct DepthLogs {
    /// Row `i`'s elements: `ln[start[i]..start[i + 1]]` (none for a row not taken), each with
    /// its `(z + z_0) / z_ref`: where that is not positive (an element above the offset
    /// surface) the gain takes its `pow`, as [`Prepared::gain`] does.
    start: Vec<usize>,
    ln: Vec<f64>,
    base: Vec<f64>,
}

impl DepthLogs {
    fn new(rows: &[Prepared], use_row: &dyn Fn(&Prepared) -> bool, z0: f64) -> DepthLogs {
        let mut start = Vec::with_capacity(rows.len() + 1);
        let mut base = Vec::new();
        start.push(0);
        for r in rows {
            if use_row(r) {
                base.extend(r.depths.iter().map(|&z| (z + z0) / REF_DEPTH_M));
            }
            start.push(base.len());
        }
        let ln = base.iter().map(|b| b.ln()).collect();
        DepthLogs { start, ln, base }
    }

    /// [`Prepared::gain`] of row `i` at exponent `n` and this offset.
    fn gain(&self, i: usize, r: &Prepared, n: f64) -> f64 {
        let at = self.start[i]..self.start[i + 1];
        let power = |(l, b): (&f64, &f64)| if *b > 0.0 { (n * l).exp() } else { b.powf(n) };
        N_CM3_TO_N_M3
            * r.area_m2
            * (self.ln[at.clone()].iter())
                .zip(&self.base[at])
                .map(|lb| REF_DEPTH_M * power(lb))
                .sum::<f64>()
    }
}

/// The exponent (in [`EXPONENT_RANGE`]) that minimises the weighted sum of squares at the
/// surface offset `z0`, by golden section, and the solve there.
fn best_exponent_at(
    rows: &[Prepared],
    use_row: &dyn Fn(&Prepared) -> bool,
    form: ShapeForm,
    o: &ShapeOptions,
    z0: f64,
) -> Option<(Depth, Solve)> {
    let preset = &o.preset;
    let logs = DepthLogs::new(rows, use_row, z0);
    let at = |n: f64| solve_gains(rows, use_row, &|i, r| logs.gain(i, r, n), form, preset);
    let f = |n: f64| at(n).map_or(f64::INFINITY, |s| s.sse);
    let (mut a, mut b) = o.exponent_range;
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..30 {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = f(d);
        }
        if b - a < 1e-4 {
            break;
        }
    }
    let n = 0.5 * (a + b);
    at(n).map(|s| ((n, z0), s))
}

/// The law in depth (exponent and surface offset) that minimises the weighted sum of squares:
/// the offset on a millimetre grid over [`OFFSET_RANGE`], refined by the parabola through the
/// best and its neighbours, the exponent by golden section at each; and the solve there.
fn best_depth(
    rows: &[Prepared],
    use_row: &dyn Fn(&Prepared) -> bool,
    form: ShapeForm,
    o: &ShapeOptions,
) -> Option<(Depth, Solve)> {
    let step = 1e-3;
    let range = o.offset_range_m;
    let grid: Vec<f64> = (0..)
        .map(|k| range.0 + k as f64 * step)
        .take_while(|z| *z <= range.1 + 1e-12)
        .collect();
    let at: Vec<Option<(Depth, Solve)>> = grid
        .iter()
        .map(|&z0| best_exponent_at(rows, use_row, form, o, z0))
        .collect();
    let sse = |k: usize| at[k].as_ref().map_or(f64::INFINITY, |b| b.1.sse);
    let k = (0..grid.len()).min_by(|&a, &b| sse(a).total_cmp(&sse(b)))?;
    at[k].as_ref()?;
    if k == 0 || k + 1 == grid.len() {
        return at[k];
    }
    let (a, b, c) = (sse(k - 1), sse(k), sse(k + 1));
    let curvature = a - 2.0 * b + c;
    if !(curvature.is_finite() && curvature > 0.0) {
        return at[k];
    }
    let z0 = grid[k] + 0.5 * step * (a - c) / curvature;
    match best_exponent_at(rows, use_row, form, o, z0) {
        Some(r) if r.1.sse <= b => Some(r),
        _ => at[k],
    }
}

/// [`best_depth`] for rows close to those whose best law in depth is `d`: the vertex of the
/// parabola through the sums of squares at `n` and `n +- 0.05`, then at the offset and 1 mm
/// either side (a test left out moves each a little), within the ranges searched.
fn near_depth(
    rows: &[Prepared],
    use_row: &dyn Fn(&Prepared) -> bool,
    form: ShapeForm,
    o: &ShapeOptions,
    d: Depth,
) -> Option<(Depth, Solve)> {
    let preset = &o.preset;
    let vertex = |x: f64, h: f64, f: &dyn Fn(f64) -> Option<f64>, range: (f64, f64)| {
        let lo = (x - h).max(range.0);
        let hi = lo + 2.0 * h;
        let mid = lo + h;
        let (a, b, c) = (f(lo)?, f(mid)?, f(hi)?);
        let curvature = a - 2.0 * b + c;
        let v = if curvature > 0.0 {
            mid + 0.5 * h * (a - c) / curvature
        } else {
            mid
        };
        Some(v.clamp(range.0, range.1))
    };
    let n = vertex(
        d.0,
        0.05,
        &|x| solve(rows, use_row, (x, d.1), form, preset).map(|s| s.sse),
        o.exponent_range,
    )?;
    let z0 = vertex(
        d.1,
        1e-3,
        &|x| solve(rows, use_row, (n, x), form, preset).map(|s| s.sse),
        o.offset_range_m,
    )?;
    solve(rows, use_row, (n, z0), form, preset).map(|s| ((n, z0), s))
}

/// The shape, its depth exponent and the speed law fitted to `tests`, with standard deviations
/// (see the module's text). An error says what is missing: no test with rows in the medium and
/// moving, or none the shape can be fitted to.
pub fn fit_shape(tests: &[IntrusionTest], o: &ShapeOptions) -> Result<RftShapeFit, String> {
    if tests.is_empty() {
        return Err("no intrusion test".into());
    }
    let (rows, per_test) = prepare(tests, o);
    if let Some(t) = tests
        .iter()
        .enumerate()
        .find_map(|(i, t)| (!rows.iter().any(|r| r.test == i)).then_some(t))
    {
        return Err(format!(
            "{}: no row with the plate in the medium and moving (is depth_m positive below the surface, and does the plate move?)",
            t.name
        ));
    }
    let slowest = per_test.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
    let quasi_static: Vec<bool> = per_test
        .iter()
        .map(|p| p.0 <= o.reference_speed_factor * slowest)
        .collect();
    let use_row = |r: &Prepared| r.fitted && quasi_static[r.test];
    if !rows.iter().any(use_row) {
        return Err(
            "no row to fit the shape to: every test that starts buried ends before its transient (give it more travel)".into(),
        );
    }
    let (form, reduced_because, (n, best)) = match best_depth(&rows, &use_row, ShapeForm::LiNine, o)
    {
        Some(b) => (ShapeForm::LiNine, None, b),
        None => {
            let b = best_depth(&rows, &use_row, ShapeForm::PresetScaled, o)
                .ok_or("the tests' rows determine no stress (every force is zero?)")?;
            (
                ShapeForm::PresetScaled,
                Some(format!(
                    "the tests do not tell Li's nine terms apart (directions and attack angles too few or too alike): the shape is {}'s, scaled",
                    o.preset_name
                )),
                b,
            )
        }
    };
    // Jackknife over the tests that carry fitted rows.
    let carriers: Vec<usize> = (0..tests.len())
        .filter(|&i| rows.iter().any(|r| r.test == i && use_row(r)))
        .collect();
    let mut leave_outs: Vec<LeaveOut> = Vec::new();
    if carriers.len() >= 2 {
        for &out in &carriers {
            let keep = |r: &Prepared| use_row(r) && r.test != out;
            if let Some((di, s)) = near_depth(&rows, &keep, form, o, n) {
                leave_outs.push((s.fit.to_array(), di.0, di.1, alpha_down(&s.fit)));
            }
        }
    }
    let jack = |get: &dyn Fn(&LeaveOut) -> f64| -> f64 {
        let k = leave_outs.len() as f64;
        if leave_outs.len() < 2 {
            return f64::NAN;
        }
        let mean = leave_outs.iter().map(get).sum::<f64>() / k;
        ((k - 1.0) / k
            * leave_outs
                .iter()
                .map(|l| (get(l) - mean).powi(2))
                .sum::<f64>())
        .sqrt()
    };
    let std_coeffs: [f64; 9] = std::array::from_fn(|c| jack(&|l| l.0[c]));
    let std_dev = RftFit::from_array(std_coeffs);
    let depth_exponent_std = jack(&|l| l.1);
    let surface_offset_std = jack(&|l| l.2);
    let alpha_down_std = jack(&|l| l.3);
    // Goodness of fit and each test's alphas.
    let (mut sse, mut sum, mut sum2, mut count) = ([0.0; 2], [0.0; 2], [0.0; 2], 0usize);
    for r in rows.iter().filter(|r| use_row(r)) {
        let (ax, az) = alpha_of(&best.fit, r);
        let g = r.gain(n);
        for (k, (y, p)) in [(r.y_x, ax * g), (r.y_z, az * g)].into_iter().enumerate() {
            sse[k] += (y - p).powi(2);
            sum[k] += y;
            sum2[k] += y * y;
        }
        count += 1;
    }
    let r2: [f64; 2] = std::array::from_fn(|k| {
        let sst = sum2[k] - sum[k] * sum[k] / count as f64;
        if sst > 0.0 {
            1.0 - sse[k] / sst
        } else {
            f64::NAN
        }
    });
    let rmse_n: [f64; 2] = std::array::from_fn(|k| (sse[k] / count as f64).sqrt());
    let summaries: Vec<TestSummary> = tests
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let fitted = rows.iter().filter(|r| r.test == i && use_row(r)).count();
            let mine: Vec<&Prepared> = rows
                .iter()
                .filter(|r| r.test == i && (use_row(r) || (fitted == 0 && r.fitted)))
                .collect();
            let (measured, predicted) = test_alphas(&mine, &best.fit, n);
            TestSummary {
                name: t.name.clone(),
                chord_angle_deg: t.chord_angle_rad.to_degrees(),
                direction_deg: per_test[i].1.to_degrees(),
                toward_minus_x: per_test[i].2,
                speed_m_s: per_test[i].0,
                rows_in_medium: rows.iter().filter(|r| r.test == i).count(),
                rows_fitted: fitted,
                starts_buried: t.starts_buried(),
                measured_alpha_n_cm3: measured,
                fitted_alpha_n_cm3: predicted,
            }
        })
        .collect();
    // A fit that ran off to values that are no number (rows of absurd depth or force) is no
    // shape: say so rather than hand it on.
    let fitted = best.fit.to_array();
    if let Some(v) = fitted.iter().chain([&n.0, &n.1]).find(|v| !v.is_finite()) {
        return Err(format!(
            "the fit does not converge (a value {v}): check the tests' units (metres, newtons) and their rows"
        ));
    }
    let (speed, speed_gain_std_s, no_speed_law_because) =
        match speed_law(tests, &rows, &per_test, &best.fit, slowest) {
            Ok((s, std)) => (Some(s), std, None),
            Err(e) => (None, Vec::new(), Some(e)),
        };
    Ok(RftShapeFit {
        form,
        reduced_because,
        coefficients: best.fit,
        std_dev,
        depth_exponent: n.0,
        depth_exponent_std,
        surface_offset_m: n.1,
        surface_offset_std_m: surface_offset_std,
        alpha_z_down_n_cm3: [alpha_down(&best.fit), alpha_down_std],
        reference_speed_m_s: slowest,
        r2,
        rmse_n,
        rows: count,
        tests: summaries,
        speed,
        speed_gain_std_s,
        no_speed_law_because,
    })
}

/// `alpha_z` of a horizontal plate moving straight down (N/cm^3).
fn alpha_down(f: &RftFit) -> f64 {
    f.alpha(0.0, FRAC_PI_2).1
}

/// The least-squares stress per stressed depth of `rows`' measured and `fit`'s forces:
/// `[alpha_x, alpha_z]` each.
fn test_alphas(rows: &[&Prepared], fit: &RftFit, n: Depth) -> ([f64; 2], [f64; 2]) {
    let (mut gg, mut gx, mut gz, mut px, mut pz) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for r in rows {
        let g = r.gain(n);
        let (ax, az) = alpha_of(fit, r);
        gg += g * g;
        gx += g * r.y_x;
        gz += g * r.y_z;
        px += g * g * ax;
        pz += g * g * az;
    }
    if gg <= 0.0 {
        return ([f64::NAN; 2], [f64::NAN; 2]);
    }
    ([gx / gg, gz / gg], [px / gg, pz / gg])
}

/// RFT's speed law from the tests: each faster test against the slowest test of the same plate,
/// chord angle, direction and start ([`RftSpeedTable::fit`], against the fitted shape).
fn speed_law(
    tests: &[IntrusionTest],
    rows: &[Prepared],
    per_test: &[(f64, f64, bool)],
    shape: &RftFit,
    slowest: f64,
) -> Result<(RftSpeedFit, Vec<f64>), String> {
    // Where a test's plate was at time 0: its first row less its motion since (a faster test's
    // first sample is further along).
    let start = |i: usize| {
        let (v, g, minus) = per_test[i];
        let m = if minus { -1.0 } else { 1.0 };
        let r = &tests[i].rows[0];
        (
            r.x_m - m * v * g.cos() * r.t_s,
            r.depth_m - v * g.sin() * r.t_s,
        )
    };
    // Tests alike but for their speed: the same plate and chord angle, direction (within 3 deg)
    // and start (within 1 mm).
    // The same element: plate, chord angle and direction of motion.
    let same_element = |i: usize, j: usize| {
        let (a, b) = (&tests[i], &tests[j]);
        (a.chord_m - b.chord_m).abs() < 1e-4
            && (a.width_m - b.width_m).abs() < 1e-4
            && (a.chord_angle_rad - b.chord_angle_rad).abs() < 0.5f64.to_radians()
            && (per_test[i].1 - per_test[j].1).abs() < 3f64.to_radians()
            && per_test[i].2 == per_test[j].2
    };
    let alike = |i: usize, j: usize| {
        let (sa, sb) = (start(i), start(j));
        same_element(i, j) && (sa.0 - sb.0).abs() < 1e-3 && (sa.1 - sb.1).abs() < 1e-3
    };
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for i in 0..tests.len() {
        match groups.iter_mut().find(|g| alike(g[0], i)) {
            Some(g) => g.push(i),
            None => groups.push(vec![i]),
        }
    }
    // A group serves where its slowest test is at the reference speed and another is faster.
    // Each test's rows, and whether it is a faster one.
    let mut table: Vec<(bool, Vec<[f64; 8]>)> = Vec::new();
    // One start per element and direction: the speed table keys intrusions by them.
    let mut elements_seen: Vec<usize> = Vec::new();
    for members in &groups {
        let reference = members
            .iter()
            .copied()
            .filter(|&i| per_test[i].0 <= 1.25 * slowest)
            .min_by(|&a, &b| per_test[a].0.total_cmp(&per_test[b].0));
        let Some(reference) = reference else { continue };
        let faster: Vec<usize> = members
            .iter()
            .copied()
            .filter(|&i| per_test[i].0 > 1.25 * slowest)
            .collect();
        if faster.is_empty() || elements_seen.iter().any(|&j| same_element(reference, j)) {
            continue;
        }
        elements_seen.push(reference);
        for &i in std::iter::once(&reference).chain(&faster) {
            let t = &tests[i];
            // Every row in the medium from the start of the motion, as the table compares them
            // at the same share of their travel; the attack angle and direction in RFT's frame.
            let m = if per_test[i].2 { -1.0 } else { 1.0 };
            let beta = wrap_half_pi((t.chord_angle_rad.sin()).atan2(m * t.chord_angle_rad.cos()));
            let speed = if i == reference {
                slowest
            } else {
                per_test[i].0
            };
            let chunk: Vec<[f64; 8]> = rows
                .iter()
                .filter(|r| r.test == i)
                .map(|r| {
                    [
                        speed,
                        beta,
                        per_test[reference].1,
                        t.chord_m,
                        t.width_m,
                        r.centre_depth_m,
                        r.y_x,
                        r.y_z,
                    ]
                })
                .collect();
            table.push((i != reference, chunk));
        }
    }
    if table.is_empty() {
        return Err(
            "no test ran at two or more speeds with the same plate, angle, direction and start"
                .into(),
        );
    }
    let coefficients = RftCoefficients::Fit(*shape);
    let fit_without = |left_out: Option<usize>| {
        let rows: Vec<[f64; 8]> = table
            .iter()
            .enumerate()
            .filter(|(k, _)| Some(*k) != left_out)
            .flat_map(|(_, c)| c.1.iter().copied())
            .collect();
        RftSpeedTable::from_rows(rows)?.fit(&coefficients)
    };
    let full = fit_without(None)?;
    // The jackknife over the faster tests: each direction's gain with each left out in turn.
    let gains = full.law.gains().to_vec();
    let mut samples: Vec<Vec<f64>> = vec![Vec::new(); gains.len()];
    for (k, _) in table.iter().enumerate().filter(|(_, c)| c.0) {
        let Ok(f) = fit_without(Some(k)) else {
            continue;
        };
        for (slot, &(g, _)) in samples.iter_mut().zip(&gains) {
            if let Some(&(_, v)) = f.law.gains().iter().find(|(x, _)| (x - g).abs() < 1e-6) {
                slot.push(v);
            }
        }
    }
    let std: Vec<f64> = samples
        .iter()
        .map(|v| {
            let n = v.len() as f64;
            if v.len() < 2 {
                return f64::NAN;
            }
            let mean = v.iter().sum::<f64>() / n;
            ((n - 1.0) / n * v.iter().map(|x| (x - mean).powi(2)).sum::<f64>()).sqrt()
        })
        .collect();
    Ok((full, std))
}

/// An angle folded into `[-pi/2, pi/2]` by half turns.
fn wrap_half_pi(a: f64) -> f64 {
    let mut a = a;
    while a > FRAC_PI_2 {
        a -= std::f64::consts::PI;
    }
    while a < -FRAC_PI_2 {
        a += std::f64::consts::PI;
    }
    a
}

/// The forces `(fx, fz)` (N, the medium's on the plate along +x and up) that `fit`'s shape and
/// law in depth (quasi-static: its speed law is not applied) give each row of `test` in the
/// medium and moving, with the row's index; rows out of the medium or still are left out.
pub fn predict_test(
    fit: &RftShapeFit,
    test: &IntrusionTest,
    o: &ShapeOptions,
) -> Vec<(usize, f64, f64)> {
    let (rows, _) = prepare(std::slice::from_ref(test), o);
    let d = (fit.depth_exponent, fit.surface_offset_m);
    rows.iter()
        .map(|r| {
            let (ax, az) = alpha_of(&fit.coefficients, r);
            let g = r.gain(d);
            // y_x is -m fx: the force resisting the motion's horizontal part.
            (r.row, -r.mirror * ax * g, az * g)
        })
        .collect()
}

/// One test predicted from the others: its measured and predicted stresses per depth.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HeldOutIntrusion {
    /// The test.
    pub test: TestSummary,
    /// Its `alpha_x, alpha_z` of the shape fitted to the other tests (N/cm^3).
    pub predicted_alpha_n_cm3: [f64; 2],
    /// RMSE of its horizontal and vertical force under that shape (N).
    pub rmse_n: [f64; 2],
    /// The form of the shape fitted without it.
    pub form: ShapeForm,
}

/// Each quasi-static test predicted by the shape fitted to the others (the others' exponent
/// too), `full` being [`fit_shape`] of all `tests` with `o` (its form and law in depth start
/// each search; it is not fitted again). A test without which the rest cannot be fitted in any
/// form is left out, by name in the error list returned beside.
pub fn cross_validate_shape(
    tests: &[IntrusionTest],
    o: &ShapeOptions,
    full: &RftShapeFit,
) -> Result<(Vec<HeldOutIntrusion>, Vec<String>), String> {
    if full.tests.len() != tests.len() {
        return Err(format!(
            "the fit given is of {} tests, not these {}",
            full.tests.len(),
            tests.len()
        ));
    }
    let (rows, _) = prepare(tests, o);
    let slowest = full.reference_speed_m_s;
    let quasi: Vec<bool> = full
        .tests
        .iter()
        .map(|t| t.speed_m_s <= o.reference_speed_factor * slowest)
        .collect();
    let mut held = Vec::new();
    let mut skipped = Vec::new();
    for (i, summary) in full.tests.iter().enumerate() {
        if !quasi[i] || summary.rows_fitted == 0 {
            continue;
        }
        let keep = |r: &Prepared| r.fitted && quasi[r.test] && r.test != i;
        let n0 = (full.depth_exponent, full.surface_offset_m);
        let solved = near_depth(&rows, &keep, ShapeForm::LiNine, o, n0)
            .map(|b| (ShapeForm::LiNine, b))
            .or_else(|| {
                near_depth(&rows, &keep, ShapeForm::PresetScaled, o, n0)
                    .map(|b| (ShapeForm::PresetScaled, b))
            });
        let Some((form, (n, s))) = solved else {
            skipped.push(summary.name.clone());
            continue;
        };
        let mine: Vec<&Prepared> = rows
            .iter()
            .filter(|r| r.test == i && r.fitted && quasi[r.test])
            .collect();
        // Measured alphas at the held-out fit's exponent, as its prediction.
        let (measured, predicted) = test_alphas(&mine, &s.fit, n);
        let mut sse = [0.0; 2];
        for r in &mine {
            let (ax, az) = alpha_of(&s.fit, r);
            let g = r.gain(n);
            sse[0] += (r.y_x - ax * g).powi(2);
            sse[1] += (r.y_z - az * g).powi(2);
        }
        let rmse_n: [f64; 2] = std::array::from_fn(|k| (sse[k] / mine.len().max(1) as f64).sqrt());
        let mut test = summary.clone();
        test.measured_alpha_n_cm3 = measured;
        held.push(HeldOutIntrusion {
            test,
            predicted_alpha_n_cm3: predicted,
            rmse_n,
            form,
        });
    }
    Ok((held, skipped))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::RftDepthLaw;

    /// A test of a plate moved in a straight line through a medium whose stress is `truth` at
    /// depth exponent `n`, sampled every `dt`.
    #[allow(clippy::too_many_arguments)]
    fn synthetic(
        name: &str,
        truth: &RftFit,
        n: f64,
        chord_angle_deg: f64,
        gamma_deg: f64,
        toward_minus_x: bool,
        start_depth_m: f64,
        travel_m: f64,
        speed: f64,
    ) -> IntrusionTest {
        let (chord, width) = (0.025, 0.025);
        let a = chord_angle_deg.to_radians();
        let g = gamma_deg.to_radians();
        let m = if toward_minus_x { -1.0 } else { 1.0 };
        let (vx, vz) = (m * speed * g.cos(), -speed * g.sin());
        let dt = 2e-3;
        let steps = (travel_m / speed / dt).round() as usize;
        let law = RftDepthLaw::new(1.0, n).unwrap();
        let rows = (0..=steps)
            .map(|k| {
                let t = k as f64 * dt;
                let (x, depth) = (vx * t, start_depth_m - vz * t);
                // The plate's force by elements, as the node's RFT integrates it.
                let (mut fx, mut fz) = (0.0, 0.0);
                let e = 50;
                let ds = chord / e as f64;
                for i in 0..e {
                    let s = (i as f64 + 0.5) * ds - 0.5 * chord;
                    let z = depth - s * a.sin();
                    if z <= 0.0 {
                        continue;
                    }
                    let (ax, az) = RftCoefficients::Fit(*truth)
                        .alpha_along((m * a.cos(), a.sin()), (m * vx, vz));
                    let stress = law.effective_depth_m(z) * 1e6 * ds * width;
                    fx += -m * ax * stress;
                    fz += az * stress;
                }
                IntrusionRow {
                    t_s: t,
                    x_m: x,
                    depth_m: depth,
                    fx_n: fx,
                    fz_n: fz,
                }
            })
            .collect();
        IntrusionTest::new(name, chord, width, a, rows).unwrap()
    }

    fn campaign(truth: &RftFit, n: f64) -> Vec<IntrusionTest> {
        let mut v = Vec::new();
        for b in [-60.0, -30.0, 0.0, 30.0, 60.0, 90.0] {
            for g in [-90.0, -45.0, 0.0, 45.0, 90.0] {
                v.push(synthetic(
                    &format!("b{b}_g{g}"),
                    truth,
                    n,
                    b,
                    g,
                    false,
                    0.04,
                    0.03,
                    0.05,
                ));
            }
        }
        v
    }

    /// The search's gains from the depths' logarithms are the rows' own (a `pow` per element),
    /// at exponents and offsets across the ranges searched; a row the fit does not take has
    /// none.
    #[test]
    fn the_gains_from_logarithms_are_the_rows_gains() {
        let (rows, _) = prepare(&campaign(&RftFit::POPPY_CP, 1.3), &ShapeOptions::default());
        let taken = |r: &Prepared| !r.row.is_multiple_of(3);
        for z0 in [-0.004, 0.0, 0.003] {
            let logs = DepthLogs::new(&rows, &taken, z0);
            for n in [0.6, 1.0, 1.37, 2.2] {
                let mut compared = 0;
                for (i, r) in rows.iter().enumerate() {
                    let got = logs.gain(i, r, n);
                    if !taken(r) {
                        assert_eq!(got, 0.0);
                        continue;
                    }
                    let want = r.gain((n, z0));
                    // An element above the offset surface: no stress law there, either way.
                    if want.is_nan() {
                        assert!(got.is_nan(), "row {i} at n {n}, z0 {z0}: {got}");
                        continue;
                    }
                    assert!(
                        (got - want).abs() <= 1e-12 * want.abs(),
                        "row {i} at n {n}, z0 {z0}: {got} against {want}"
                    );
                    compared += usize::from(want > 0.0);
                }
                assert!(compared > 100, "{compared} rows with a gain");
            }
        }
    }

    #[test]
    fn the_nine_coefficients_and_the_exponent_come_back() {
        let truth = RftFit::POPPY_CP;
        let fit = fit_shape(&campaign(&truth, 1.3), &ShapeOptions::default()).unwrap();
        assert_eq!(fit.form, ShapeForm::LiNine);
        for (a, b) in fit.coefficients.to_array().iter().zip(truth.to_array()) {
            assert!((a - b).abs() < 2e-3, "{:?}", fit.coefficients);
        }
        assert!(
            (fit.depth_exponent - 1.3).abs() < 0.01,
            "{}",
            fit.depth_exponent
        );
        assert!(fit.r2[0] > 0.999 && fit.r2[1] > 0.999, "{:?}", fit.r2);
    }

    #[test]
    fn a_test_toward_minus_x_is_the_mirror_of_one_toward_plus_x() {
        let truth = RftFit::POPPY_LP;
        let plus = synthetic("p", &truth, 1.0, 30.0, 45.0, false, 0.04, 0.03, 0.05);
        let minus = synthetic("m", &truth, 1.0, 150.0, 45.0, true, 0.04, 0.03, 0.05);
        for (a, b) in plus.rows.iter().zip(&minus.rows) {
            assert!((a.fx_n + b.fx_n).abs() < 1e-9 && (a.fz_n - b.fz_n).abs() < 1e-9);
        }
        let mut tests = campaign(&truth, 1.0);
        tests.push(minus);
        let fit = fit_shape(&tests, &ShapeOptions::default()).unwrap();
        let last = fit.tests.last().unwrap();
        assert!(last.toward_minus_x);
        assert!(
            (last.direction_deg - 45.0).abs() < 0.1,
            "{}",
            last.direction_deg
        );
        for k in 0..2 {
            assert!(
                (last.measured_alpha_n_cm3[k] - last.fitted_alpha_n_cm3[k]).abs() < 1e-4,
                "{last:?}"
            );
        }
    }

    #[test]
    fn plates_pushed_straight_down_give_the_preset_scaled_and_say_so() {
        let truth = RftFit::POPPY_LP.scaled(2.0);
        let tests: Vec<_> = (0..3)
            .map(|i| {
                synthetic(
                    &format!("d{i}"),
                    &truth,
                    1.2,
                    0.0,
                    90.0,
                    false,
                    -0.002,
                    0.04,
                    0.05,
                )
            })
            .collect();
        let fit = fit_shape(&tests, &ShapeOptions::default()).unwrap();
        assert_eq!(fit.form, ShapeForm::PresetScaled);
        assert!(fit.reduced_because.as_deref().unwrap().contains("poppy_lp"));
        assert!((fit.coefficients.a00 / RftFit::POPPY_LP.a00 - 2.0).abs() < 1e-3);
        assert!((fit.depth_exponent - 1.2).abs() < 0.01);
    }

    #[test]
    fn the_speed_law_comes_from_tests_at_two_speeds() {
        let truth = RftFit::POPPY_LP;
        let mut tests = campaign(&truth, 1.0);
        for (v, k) in [(0.05, 0.0), (0.4, 0.03)] {
            // Faster: every element as if k (v - 0.05) deeper.
            let mut t = synthetic(
                &format!("s{v}"),
                &truth,
                1.0,
                0.0,
                90.0,
                false,
                -0.002,
                0.04,
                v,
            );
            let slow = synthetic("ref", &truth, 1.0, 0.0, 90.0, false, -0.002, 0.04, 0.05);
            if k > 0.0 {
                let extra = k * (v - 0.05);
                let az = truth.alpha(0.0, FRAC_PI_2).1;
                for r in &mut t.rows {
                    let sub = (r.depth_m > 0.0) as u8 as f64;
                    r.fz_n += sub * az * 1e6 * extra * 0.025 * 0.025;
                }
            } else {
                t = slow;
                t.name = format!("s{v}");
            }
            tests.push(t);
        }
        let fit = fit_shape(&tests, &ShapeOptions::default()).unwrap();
        let law = fit.speed.expect("a speed law").law;
        assert!(
            (law.depth_per_speed_s(FRAC_PI_2) - 0.03).abs() < 3e-3,
            "{law:?}"
        );
        assert!((fit.reference_speed_m_s - 0.05).abs() < 1e-6);
    }

    #[test]
    fn refusals_name_the_value() {
        let row = |t| IntrusionRow {
            t_s: t,
            x_m: 0.0,
            depth_m: 0.01,
            fx_n: 0.0,
            fz_n: 1.0,
        };
        let e = IntrusionTest::new("a", 0.025, 0.025, 4.0, vec![row(0.0), row(1.0)]).unwrap_err();
        assert!(e.contains("chord_angle_deg") && e.contains("229"), "{e}");
        let mut bad = vec![row(0.0), row(1.0)];
        bad[1].fz_n = f64::NAN;
        let e = IntrusionTest::new("a", 0.025, 0.025, 0.0, bad).unwrap_err();
        assert!(e.contains("row 2") && e.contains("fz_n"), "{e}");
        let e = IntrusionTest::new("a", -0.025, 0.025, 0.0, vec![row(0.0), row(1.0)]).unwrap_err();
        assert!(e.contains("plate_chord_m"), "{e}");
        // Never in the medium.
        let above: Vec<_> = (0..10)
            .map(|i| IntrusionRow {
                t_s: i as f64,
                x_m: i as f64 * 0.01,
                depth_m: -0.05,
                fx_n: 0.0,
                fz_n: 0.0,
            })
            .collect();
        let t = IntrusionTest::new("above", 0.025, 0.025, 0.0, above).unwrap();
        let e = fit_shape(&[t], &ShapeOptions::default()).unwrap_err();
        assert!(e.contains("above") && e.contains("no row"), "{e}");
    }

    #[test]
    fn each_test_is_predicted_from_the_others() {
        let truth = RftFit::POPPY_CP;
        let (tests, o) = (campaign(&truth, 1.1), ShapeOptions::default());
        let (held, skipped) =
            cross_validate_shape(&tests, &o, &fit_shape(&tests, &o).unwrap()).unwrap();
        assert!(skipped.is_empty());
        assert_eq!(held.len(), 30);
        for h in &held {
            for k in 0..2 {
                let (m, p) = (h.test.measured_alpha_n_cm3[k], h.predicted_alpha_n_cm3[k]);
                assert!((m - p).abs() < 2e-3, "{h:?}");
            }
        }
    }
}
