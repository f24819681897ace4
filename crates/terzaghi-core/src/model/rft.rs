//! Resistive force theory (Li, Zhang & Goldman, Science 2013) for the rotating plate.
//!
//! A plate element at depth `|z|` with area `dA` feels the stress `alpha(beta_r, gamma) |z| dA`,
//! `alpha` in N/cm^3, where `beta_r` is the element's attack angle in `[-pi/2, pi/2]` and
//! `gamma` the angle of its velocity below the horizontal. From the fit of Li et al.:
//! `alpha_z = A00 + A10 cos 2b + B11 sin(2b+g) + B01 sin g + B-11 sin(-2b+g)`,
//! `alpha_x = C11 cos(2b+g) + C01 cos g + C-11 cos(-2b+g) + D10 sin 2b`. `alpha_x` is the
//! resisting drag, `alpha_z` the lift. For the rotating plate, `gamma = pi/2 - beta` and
//! `beta_r = beta` (`beta <= pi/2`) or `beta - pi`.
//!
//! The integration is element-wise, as RFT is defined: each element's attack angle and velocity
//! direction come from its own tangent and its own velocity about the hip, so that the same
//! routine serves a plate, and every element may look up the measured grid.

use super::{
    HipMotion, ModelError, Plate, Prediction, Regime, ShearedBearing, finite, positive,
    wrap_beta_rad,
};
use std::f64::consts::{FRAC_PI_2, PI};
use std::sync::OnceLock;

/// N/cm^3 to N/m^3.
pub(crate) const N_CM3_TO_N_M3: f64 = 1e6;

/// The nine coefficients of the RFT fit, in N/cm^3: Li, Zhang and Goldman's discrete Fourier
/// form, as the module's formula writes it (`bm11` is `B-11`, `cm11` is `C-11`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct RftFit {
    /// `A00`.
    pub a00: f64,
    /// `A10`.
    pub a10: f64,
    /// `B11`.
    pub b11: f64,
    /// `B01`.
    pub b01: f64,
    /// `B-11`.
    pub bm11: f64,
    /// `C11`.
    pub c11: f64,
    /// `C01`.
    pub c01: f64,
    /// `C-11`.
    pub cm11: f64,
    /// `D10`.
    pub d10: f64,
}

impl RftFit {
    /// The generic (dimensionless) coefficients of Li et al.; scale with [`RftFit::generic`].
    pub const GENERIC_SHAPE: RftFit = RftFit {
        a00: 0.206,
        a10: 0.169,
        b11: 0.212,
        b01: 0.358,
        bm11: 0.055,
        c11: -0.124,
        c01: 0.253,
        cm11: 0.007,
        d10: 0.088,
    };
    /// Loosely packed poppy seeds, N/cm^3.
    pub const POPPY_LP: RftFit = RftFit {
        a00: 0.051,
        a10: 0.047,
        b11: 0.053,
        b01: 0.083,
        bm11: 0.020,
        c11: -0.026,
        c01: 0.057,
        cm11: 0.0,
        d10: 0.025,
    };
    /// Closely packed poppy seeds, N/cm^3.
    pub const POPPY_CP: RftFit = RftFit {
        a00: 0.094,
        a10: 0.092,
        b11: 0.092,
        b01: 0.151,
        bm11: 0.035,
        c11: -0.039,
        c01: 0.086,
        cm11: 0.018,
        d10: 0.046,
    };

    /// The generic coefficients times a medium's scale factor `zeta` (N/cm^3, > 0).
    pub fn generic(zeta_n_cm3: f64) -> Result<RftFit, ModelError> {
        let z = positive("RFT scale factor zeta (N/cm^3)", zeta_n_cm3)?;
        Ok(Self::GENERIC_SHAPE.scaled(z))
    }

    /// The nine coefficients in the order of the struct (`A00, A10, B11, B01, B-11, C11, C01,
    /// C-11, D10`).
    pub fn to_array(&self) -> [f64; 9] {
        [
            self.a00, self.a10, self.b11, self.b01, self.bm11, self.c11, self.c01, self.cm11,
            self.d10,
        ]
    }

    /// The coefficients of [`Self::to_array`]'s order.
    pub fn from_array(a: [f64; 9]) -> RftFit {
        RftFit {
            a00: a[0],
            a10: a[1],
            b11: a[2],
            b01: a[3],
            bm11: a[4],
            c11: a[5],
            c01: a[6],
            cm11: a[7],
            d10: a[8],
        }
    }

    /// Every coefficient times `s`: the same shape, another scale.
    pub fn scaled(&self, s: f64) -> RftFit {
        Self::from_array(self.to_array().map(|v| v * s))
    }

    /// `(alpha_x, alpha_z)` in N/cm^3.
    pub fn alpha(&self, beta_r: f64, gamma: f64) -> (f64, f64) {
        let (b2, g) = (2.0 * beta_r, gamma);
        let az = self.a00
            + self.a10 * b2.cos()
            + self.b11 * (b2 + g).sin()
            + self.b01 * g.sin()
            + self.bm11 * (-b2 + g).sin();
        let ax = self.c11 * (b2 + g).cos()
            + self.c01 * g.cos()
            + self.cm11 * (-b2 + g).cos()
            + self.d10 * b2.sin();
        (ax, az)
    }

    /// [`RftFit::alpha`] from the cosine and sine of twice the attack angle (`c2b`, `s2b`)
    /// and of the intrusion angle (`cg`, `sg`): the sums of angles by their addition formulas,
    /// so that no trigonometric function is evaluated.
    #[inline(always)]
    pub(crate) fn alpha_trig(&self, (c2b, s2b): (f64, f64), (cg, sg): (f64, f64)) -> (f64, f64) {
        let sin_plus = s2b * cg + c2b * sg; // sin(2 beta + gamma)
        let sin_minus = sg * c2b - s2b * cg; // sin(-2 beta + gamma)
        let cos_plus = c2b * cg - s2b * sg; // cos(2 beta + gamma)
        let cos_minus = c2b * cg + s2b * sg; // cos(-2 beta + gamma)
        let az =
            self.a00 + self.a10 * c2b + self.b11 * sin_plus + self.b01 * sg + self.bm11 * sin_minus;
        let ax = self.c11 * cos_plus + self.c01 * cg + self.cm11 * cos_minus + self.d10 * s2b;
        (ax, az)
    }

    /// The nine coefficients fitted by least squares to measured stresses
    /// `(beta_r, gamma, alpha_x, alpha_z)` (N/cm^3), as Li et al. fitted them to their
    /// intrusion experiments: `alpha_z`'s five terms and `alpha_x`'s four are each linear in
    /// their coefficients. `None` with fewer than five points or a grid that cannot tell the
    /// terms apart.
    ///
    /// ```
    /// use terzaghi_core::model::RftFit;
    /// let truth = RftFit::POPPY_LP;
    /// let mut pts = Vec::new();
    /// for b in [-60.0f64, -30.0, 0.0, 30.0, 60.0, 90.0] {
    ///     for g in [-90.0f64, -45.0, 0.0, 45.0, 90.0] {
    ///         let (ax, az) = truth.alpha(b.to_radians(), g.to_radians());
    ///         pts.push((b.to_radians(), g.to_radians(), ax, az));
    ///     }
    /// }
    /// let fit = RftFit::fit_to_points(&pts).unwrap();
    /// assert!((fit.b01 - truth.b01).abs() < 1e-9 && (fit.c01 - truth.c01).abs() < 1e-9);
    /// ```
    pub fn fit_to_points(points: &[(f64, f64, f64, f64)]) -> Option<RftFit> {
        use nalgebra::{DMatrix, DVector};
        let pts: Vec<_> = points
            .iter()
            .filter(|p| [p.0, p.1, p.2, p.3].iter().all(|v| v.is_finite()))
            .collect();
        if pts.len() < 5 {
            return None;
        }
        let n = pts.len();
        let z_rows = DMatrix::from_fn(n, 5, |i, j| {
            let (b2, g) = (2.0 * pts[i].0, pts[i].1);
            [1.0, b2.cos(), (b2 + g).sin(), g.sin(), (-b2 + g).sin()][j]
        });
        let x_rows = DMatrix::from_fn(n, 4, |i, j| {
            let (b2, g) = (2.0 * pts[i].0, pts[i].1);
            [(b2 + g).cos(), g.cos(), (-b2 + g).cos(), b2.sin()][j]
        });
        let az = DVector::from_fn(n, |i, _| pts[i].3);
        let ax = DVector::from_fn(n, |i, _| pts[i].2);
        let solve = |a: DMatrix<f64>, y: DVector<f64>| {
            let svd = a.svd(true, true);
            let s = &svd.singular_values;
            let (max, min) = (s.max(), s.min());
            if min.is_nan() || min <= 1e-9 * max {
                return None;
            }
            svd.solve(&y, 1e-12).ok()
        };
        let cz = solve(z_rows, az)?;
        let cx = solve(x_rows, ax)?;
        Some(RftFit::from_array([
            cz[0], cz[1], cz[2], cz[3], cz[4], cx[0], cx[1], cx[2], cx[3],
        ]))
    }
}

/// A measured `alpha` table on a rectilinear `(beta_r, gamma)` grid, looked up bilinearly.
#[derive(Debug, Clone, PartialEq)]
pub struct RftGrid {
    betas: Vec<f64>,
    gammas: Vec<f64>,
    /// `[gamma index][beta index]`
    alpha_x: Vec<Vec<f64>>,
    alpha_z: Vec<Vec<f64>>,
}

impl RftGrid {
    /// Parses `beta_rad,gamma_rad,alpha_x,alpha_z` rows (`#` comments, one header line) that
    /// cover a full rectilinear grid.
    pub fn parse(text: &str) -> Result<RftGrid, String> {
        let rows = numeric_rows::<4>(text, "beta_rad", "beta_rad,gamma_rad,alpha_x,alpha_z")
            .map_err(|e| format!("RFT grid {e}"))?;
        let axis = |col: usize| {
            let mut v: Vec<f64> = rows.iter().map(|r| r[col]).collect();
            v.sort_by(f64::total_cmp);
            v.dedup();
            v
        };
        let (betas, gammas) = (axis(0), axis(1));
        if betas.len() < 2 || gammas.len() < 2 || betas.len() * gammas.len() != rows.len() {
            return Err(format!(
                "RFT grid is not rectilinear: {} rows for {} x {} axes",
                rows.len(),
                betas.len(),
                gammas.len()
            ));
        }
        let mut alpha_x = vec![vec![f64::NAN; betas.len()]; gammas.len()];
        let mut alpha_z = alpha_x.clone();
        for r in &rows {
            let bi = betas.iter().position(|&b| b == r[0]).unwrap_or(0);
            let gi = gammas.iter().position(|&g| g == r[1]).unwrap_or(0);
            alpha_x[gi][bi] = r[2];
            alpha_z[gi][bi] = r[3];
        }
        if alpha_x.iter().flatten().any(|v| v.is_nan()) {
            return Err("RFT grid has duplicate or missing points".into());
        }
        Ok(RftGrid {
            betas,
            gammas,
            alpha_x,
            alpha_z,
        })
    }

    /// Every grid point as `(beta_r, gamma, alpha_x, alpha_z)`.
    pub fn points(&self) -> Vec<(f64, f64, f64, f64)> {
        let mut out = Vec::with_capacity(self.betas.len() * self.gammas.len());
        for (gi, &g) in self.gammas.iter().enumerate() {
            for (bi, &b) in self.betas.iter().enumerate() {
                out.push((b, g, self.alpha_x[gi][bi], self.alpha_z[gi][bi]));
            }
        }
        out
    }

    /// The measured grid for loosely packed poppy seeds shipped with the crate.
    pub fn poppy_lp() -> &'static RftGrid {
        static GRID: OnceLock<RftGrid> = OnceLock::new();
        GRID.get_or_init(|| {
            // The shipped file is checked by a unit test; a parse failure here is a build defect.
            RftGrid::parse(include_str!("data/rft_poppy_lp_alpha_grid.csv"))
                .unwrap_or_else(|e| panic!("shipped RFT grid is corrupt: {e}"))
        })
    }

    /// Bilinear `(alpha_x, alpha_z)` in N/cm^3; angles outside the grid are clamped to it.
    pub fn alpha(&self, beta_r: f64, gamma: f64) -> (f64, f64) {
        let (bi, tb) = bracket(&self.betas, beta_r);
        let (gi, tg) = bracket(&self.gammas, gamma);
        let lerp2 = |t: &Vec<Vec<f64>>| {
            let lo = t[gi][bi] * (1.0 - tb) + t[gi][bi + 1] * tb;
            let hi = t[gi + 1][bi] * (1.0 - tb) + t[gi + 1][bi + 1] * tb;
            lo * (1.0 - tg) + hi * tg
        };
        (lerp2(&self.alpha_x), lerp2(&self.alpha_z))
    }
}

/// The rows of a CSV table of `N` finite numbers (`#` comments, a header line starting with
/// `header`); an error names the line and the columns expected (`columns`).
fn numeric_rows<const N: usize>(
    text: &str,
    header: &str,
    columns: &str,
) -> Result<Vec<[f64; N]>, String> {
    let mut rows = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') || line.starts_with(header) {
            continue;
        }
        let cells: Vec<f64> = line
            .split(',')
            .map(|c| c.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|e| format!("line {}: {e}", i + 1))?;
        match <[f64; N]>::try_from(cells) {
            Ok(row) if row.iter().all(|c| c.is_finite()) => rows.push(row),
            _ => {
                return Err(format!(
                    "line {}: expected {N} finite numbers ({columns})",
                    i + 1
                ));
            }
        }
    }
    Ok(rows)
}

/// Index `i` and fraction `t` with `x = axis[i] + t (axis[i+1] - axis[i])`, clamped to the axis.
fn bracket(axis: &[f64], x: f64) -> (usize, f64) {
    let last = axis.len() - 2;
    let i = axis[1..=last].partition_point(|&a| a <= x).min(last);
    let t = ((x - axis[i]) / (axis[i + 1] - axis[i])).clamp(0.0, 1.0);
    (i, t)
}

/// RFT's speed law: an element moving at `v` above `ref_speed_m_s` (the speed its coefficients
/// were calibrated at) feels its quasi-static stress `alpha |z|` plus a dynamic one,
/// `alpha k (v - v_ref)`, the same at every depth: as if it were `k (v - v_ref)` deeper. Measured
/// by moving an element through the bed at several speeds ([`RftSpeedTable`]): into it from
/// the surface, the extra force of speed appears from the first millimetres on and hardly grows
/// with depth, which a factor on the stress (zero at the surface) cannot give; and it grows
/// about in proportion to the speed (the table's fit compares the forms). The gain `k` depends
/// on the direction of motion, the intrusion angle `gamma` below the horizontal (in the DEM's
/// medium it is largest pushed straight down and smallest rising at 45 deg). `k` is measured
/// per direction and taken linearly in `sin gamma` between them (the nearest one's beyond): the
/// sine is the velocity's own downward share, so that an element's gain needs no angle
/// computed. Above the fastest speed it was measured at the law is not extrapolated: the
/// dynamic stress stays at that speed's (a joint stamp glitch that reads as thousands of rad/s
/// must not make an element metres deeper).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RftSpeedLaw {
    /// The speed of the calibration the coefficients come from (m/s).
    pub ref_speed_m_s: f64,
    /// `(gamma_rad, k_s)`: `k` (the depth the dynamic stress is worth per m/s above the
    /// calibration speed, m per m/s: s) measured moving at `gamma` below the horizontal;
    /// ascending in `gamma`, the first `directions` of them.
    gains: [(f64, f64); MAX_SPEED_LAW_DIRECTIONS],
    /// `sin gamma` of each.
    sines: [f64; MAX_SPEED_LAW_DIRECTIONS],
    directions: usize,
    /// The fastest speed the law was measured at (m/s).
    pub max_speed_m_s: f64,
}

/// As written out: the gains measured, without the table's unused slots.
impl serde::Serialize for RftSpeedLaw {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut s = serializer.serialize_struct("RftSpeedLaw", 3)?;
        s.serialize_field("ref_speed_m_s", &self.ref_speed_m_s)?;
        s.serialize_field("gains_gamma_rad_s", self.gains())?;
        s.serialize_field("max_speed_m_s", &self.max_speed_m_s)?;
        s.end()
    }
}

/// Directions of motion a speed law's gain can be given for, at most.
pub const MAX_SPEED_LAW_DIRECTIONS: usize = 8;

impl RftSpeedLaw {
    /// The largest gain taken (s): a metre of depth per m/s is no medium's.
    pub const MAX_DEPTH_PER_SPEED_S: f64 = 1.0;

    /// A law calibrated at `ref_speed_m_s` (> 0) with `depth_per_speed_s` in
    /// `[0, MAX_DEPTH_PER_SPEED_S]` whatever the direction, measured up to `max_speed_m_s` (at
    /// least `ref_speed_m_s`).
    pub fn new(
        ref_speed_m_s: f64,
        depth_per_speed_s: f64,
        max_speed_m_s: f64,
    ) -> Result<RftSpeedLaw, ModelError> {
        Self::by_direction(ref_speed_m_s, &[(0.0, depth_per_speed_s)], max_speed_m_s)
    }

    /// A law whose gain was measured per direction: `(gamma_rad, depth_per_speed_s)`, each
    /// `gamma` in `[-pi/2, pi/2]` and each gain in `[0, MAX_DEPTH_PER_SPEED_S]`, one to
    /// [`MAX_SPEED_LAW_DIRECTIONS`] distinct directions in any order.
    pub fn by_direction(
        ref_speed_m_s: f64,
        gains: &[(f64, f64)],
        max_speed_m_s: f64,
    ) -> Result<RftSpeedLaw, ModelError> {
        let ref_speed_m_s = positive("RFT calibration speed (m/s)", ref_speed_m_s)?;
        let max_speed_m_s = finite("RFT speed law's fastest speed (m/s)", max_speed_m_s)?;
        if max_speed_m_s < ref_speed_m_s {
            return Err(ModelError::OutOfRange {
                what: "RFT speed law's fastest speed (m/s)",
                value: max_speed_m_s,
                range: format!("[{ref_speed_m_s}, inf)"),
            });
        }
        if gains.is_empty() || gains.len() > MAX_SPEED_LAW_DIRECTIONS {
            return Err(ModelError::OutOfRange {
                what: "RFT speed law's directions",
                value: gains.len() as f64,
                range: format!("[1, {MAX_SPEED_LAW_DIRECTIONS}]"),
            });
        }
        let mut table = [(0.0, 0.0); MAX_SPEED_LAW_DIRECTIONS];
        for (slot, &(gamma, k)) in table.iter_mut().zip(gains) {
            let gamma = finite("RFT speed law's direction gamma (rad)", gamma)?;
            if gamma.abs() > FRAC_PI_2 + 1e-9 {
                return Err(ModelError::OutOfRange {
                    what: "RFT speed law's direction gamma (rad)",
                    value: gamma,
                    range: "[-pi/2, pi/2]".into(),
                });
            }
            let k = finite("RFT speed gain (s)", k)?;
            if !(0.0..=Self::MAX_DEPTH_PER_SPEED_S).contains(&k) {
                return Err(ModelError::OutOfRange {
                    what: "RFT speed gain (s)",
                    value: k,
                    range: format!("[0, {}]", Self::MAX_DEPTH_PER_SPEED_S),
                });
            }
            *slot = (gamma, k);
        }
        let given = &mut table[..gains.len()];
        given.sort_by(|a, b| a.0.total_cmp(&b.0));
        if let Some(w) = given.windows(2).find(|w| w[1].0 - w[0].0 < 1e-9) {
            return Err(ModelError::OutOfRange {
                what: "RFT speed law's direction gamma (rad), given twice",
                value: w[0].0,
                range: "distinct directions".into(),
            });
        }
        let mut sines = [0.0; MAX_SPEED_LAW_DIRECTIONS];
        for (s, g) in sines.iter_mut().zip(&table) {
            *s = g.0.sin();
        }
        Ok(RftSpeedLaw {
            ref_speed_m_s,
            gains: table,
            sines,
            directions: gains.len(),
            max_speed_m_s,
        })
    }

    /// The gains as measured: `(gamma_rad, depth_per_speed_s)`, ascending in `gamma`.
    pub fn gains(&self) -> &[(f64, f64)] {
        &self.gains[..self.directions]
    }

    /// `k` (s) for a motion at `gamma_rad` below the horizontal: linear in `sin gamma` between
    /// the directions measured, the nearest one's beyond them.
    pub fn depth_per_speed_s(&self, gamma_rad: f64) -> f64 {
        self.gain_at_sine(gamma_rad.clamp(-FRAC_PI_2, FRAC_PI_2).sin())
    }

    /// `k` (s) for a motion whose downward share of the speed is `sine`.
    fn gain_at_sine(&self, sine: f64) -> f64 {
        let (sines, g) = (&self.sines[..self.directions], self.gains());
        let i = sines.partition_point(|&a| a <= sine);
        match (i.checked_sub(1), i < sines.len()) {
            (Some(j), true) => {
                g[j].1 + (sine - sines[j]) / (sines[i] - sines[j]) * (g[i].1 - g[j].1)
            }
            (Some(j), false) => g[j].1,
            (None, true) => g[0].1,
            (None, false) => 0.0,
        }
    }

    /// The depth (m) the dynamic stress of an element moving at `speed_m_s` in the direction
    /// `gamma_rad` below the horizontal is worth: 0 at or below the calibration speed, and for a
    /// speed or direction that is not finite (none is known); above the fastest speed
    /// measured, that speed's.
    pub fn extra_depth_m(&self, speed_m_s: f64, gamma_rad: f64) -> f64 {
        self.extra_at_sine_m(speed_m_s, gamma_rad.clamp(-FRAC_PI_2, FRAC_PI_2).sin())
    }

    /// [`Self::extra_depth_m`] of a velocity `(vx, vz)` (z up).
    pub fn extra_depth_of_velocity_m(&self, vx: f64, vz: f64) -> f64 {
        let speed = vx.hypot(vz);
        self.extra_at_sine_m(speed, (-vz / speed).clamp(-1.0, 1.0))
    }

    /// [`Self::extra_depth_m`] for a motion whose downward share of the speed is `sine`.
    fn extra_at_sine_m(&self, speed_m_s: f64, sine: f64) -> f64 {
        if speed_m_s.is_finite() && sine.is_finite() && speed_m_s > self.ref_speed_m_s {
            let v = speed_m_s.min(self.max_speed_m_s);
            self.gain_at_sine(sine) * (v - self.ref_speed_m_s)
        } else {
            0.0
        }
    }

    /// The gains for people: "0.0290 s moving at 90 deg, ..., 0.0051 s at -90 deg" (below the
    /// horizontal; negative: upward, out of the bed).
    pub fn gains_text(&self) -> String {
        self.gains()
            .iter()
            .rev()
            .map(|&(g, k)| format!("{k:.4} s at {:.0} deg", g.to_degrees() + 0.0))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// A plate element moved through the bed at several speeds, sample by sample: rows of
/// `speed_m_s,beta_rad,gamma_rad,length_m,width_m,depth_m,drag_n,lift_n` (the DEM campaign's
/// `rft_entry.csv`: into the bed from its surface, across it and out of it): the element's
/// attack angle, intrusion angle below the horizontal (negative: upward), length and width, its
/// centre's depth below the surface, and the force on it (drag resisting the motion's
/// horizontal part, lift up). Each intrusion's rows run in order from the start of its motion,
/// at a constant speed and sampling rate. The slowest speed is the calibration's: every faster
/// intrusion is compared with the slowest of the same element and angles at the same share of
/// its travel.
#[derive(Debug, Clone, PartialEq)]
pub struct RftSpeedTable {
    rows: Vec<[f64; 8]>,
}

/// What [`RftSpeedTable::fit`] found.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct RftSpeedFit {
    /// The law.
    pub law: RftSpeedLaw,
    /// The share of the force's change from the calibration speed that the law (its gain per
    /// direction) explains, over every faster intrusion.
    pub explained: f64,
    /// The same share with one gain for every direction: the law's form without the direction.
    pub one_gain_explained: f64,
    /// The same share for the other forms, each with one gain fitted alike: a dynamic stress
    /// growing with `v^2 - v_ref^2` instead (inertia's), and a factor `1 + g (v - v_ref)` on
    /// the stress.
    pub quadratic_explained: f64,
    /// See [`Self::quadratic_explained`].
    pub factor_law_explained: f64,
    /// Faster intrusions compared with their reference.
    pub intrusions: usize,
    /// Their samples with the element in the medium.
    pub samples: usize,
}

impl RftSpeedTable {
    /// The columns of a row.
    pub const COLUMNS: &str = "speed_m_s,beta_rad,gamma_rad,length_m,width_m,depth_m,drag_n,lift_n";

    /// Parses the table (`#` comments, one header line); every row finite, speeds and sizes
    /// positive.
    pub fn parse(text: &str) -> Result<RftSpeedTable, String> {
        let rows = numeric_rows::<8>(text, "speed_m_s", Self::COLUMNS)?;
        if let Some(r) = rows
            .iter()
            .find(|r| r[0] <= 0.0 || r[3] <= 0.0 || r[4] <= 0.0)
        {
            return Err(format!(
                "the row at beta {} rad, gamma {} rad, depth {} m has speed {} m/s, length {} m, width {} m: each must be > 0",
                r[1], r[2], r[5], r[0], r[3], r[4]
            ));
        }
        Ok(RftSpeedTable { rows })
    }

    /// A table of rows already read (`COLUMNS` each), checked as [`Self::parse`] checks them.
    pub fn from_rows(rows: Vec<[f64; 8]>) -> Result<RftSpeedTable, String> {
        if let Some(r) = rows
            .iter()
            .find(|r| r.iter().any(|v| !v.is_finite()) || r[0] <= 0.0 || r[3] <= 0.0 || r[4] <= 0.0)
        {
            return Err(format!(
                "the row at beta {} rad, gamma {} rad, depth {} m has speed {} m/s, length {} m, width {} m: each must be finite, and speed and size > 0",
                r[1], r[2], r[5], r[0], r[3], r[4]
            ));
        }
        Ok(RftSpeedTable { rows })
    }

    /// The law's gain for each direction of motion in the table, by least squares over both
    /// components of every sample of its faster intrusions with the element in the medium,
    /// against the slowest intrusion of the same element at the same share of its travel
    /// (interpolated):
    /// `F(v) - F(v_ref) = alpha w l k (v - v_ref)`, `alpha` from `coefficients` and `l` the
    /// element's submerged length. A direction where speed lowers the force gets no dynamic
    /// stress (`k` = 0). An error says what is missing: a slowest intrusion for some element, a
    /// faster one, or more directions than a law holds.
    pub fn fit(&self, coefficients: &RftCoefficients) -> Result<RftSpeedFit, String> {
        let v_ref = self.rows.iter().map(|r| r[0]).fold(f64::INFINITY, f64::min);
        let v_max = self.rows.iter().map(|r| r[0]).fold(0.0, f64::max);
        let same = |a: &[f64; 8], b: &[f64; 8]| (1..5).all(|k| (a[k] - b[k]).abs() < 1e-6);
        // Intrusions: runs of rows of one speed and element, in file order.
        let mut intrusions: Vec<Vec<[f64; 8]>> = Vec::new();
        for r in &self.rows {
            match intrusions.last_mut() {
                Some(run) if run[0][0] == r[0] && same(&run[0], r) => run.push(*r),
                _ => intrusions.push(vec![*r]),
            }
        }
        // Per component of each faster sample: the columns of the law, of the quadratic law
        // and of the factor law, and the change.
        let mut samples: Vec<[f64; 4]> = Vec::new();
        // The direction (gamma) of each sample pair's intrusion.
        let mut directions: Vec<f64> = Vec::new();
        let mut compared = 0;
        for run in intrusions.iter().filter(|run| run[0][0] > v_ref) {
            let e = run[0];
            // Both move at a constant speed from the same start, sampled at a constant rate: a
            // row's share of its intrusion's rows is its share of the travel. (Depth would not
            // tell the points of a motion across the bed apart.)
            let along = |rows: &[[f64; 8]]| -> Vec<[f64; 3]> {
                let last = rows.len().saturating_sub(1).max(1) as f64;
                rows.iter()
                    .enumerate()
                    .map(|(k, q)| [k as f64 / last, q[6], q[7]])
                    .collect()
            };
            let reference: Vec<[f64; 3]> = intrusions
                .iter()
                .find(|q| q[0][0] == v_ref && same(&q[0], &e))
                .map_or_else(Vec::new, |q| along(q));
            if reference.len() < 2 {
                return Err(format!(
                    "no intrusion at the reference speed {v_ref} m/s for the element at beta {} rad, gamma {} rad, {} x {} m",
                    e[1], e[2], e[3], e[4]
                ));
            }
            let (ax, az) = coefficients.alpha(e[1], e[2]);
            let (v, len, width) = (e[0], e[3], e[4]);
            let mut used = false;
            for (r, at) in run.iter().zip(along(run)) {
                let submerged = submerged_length_m(len, e[1], r[5]);
                let Some([d0, l0]) = interpolate_along(&reference, at[0]) else {
                    continue;
                };
                if submerged <= 0.0 {
                    continue;
                }
                let area = N_CM3_TO_N_M3 * width * submerged;
                let (lin, quad) = (area * (v - v_ref), area * (v * v - v_ref * v_ref));
                samples.push([ax * lin, ax * quad, (v - v_ref) * d0, r[6] - d0]);
                samples.push([az * lin, az * quad, (v - v_ref) * l0, r[7] - l0]);
                directions.extend([e[2], e[2]]);
                used = true;
            }
            compared += usize::from(used);
        }
        let sst: f64 = samples.iter().map(|t| t[3] * t[3]).sum();
        let share = |sse: f64| if sst > 0.0 { 1.0 - sse / sst } else { 0.0 };
        // The gain of column `c` by least squares over the samples `keep` takes.
        let gain_of = |c: usize, keep: &dyn Fn(usize) -> bool| {
            let (sxx, sxy) = samples
                .iter()
                .enumerate()
                .filter(|(i, _)| keep(*i))
                .fold((0.0, 0.0), |(xx, xy), (_, t)| {
                    (xx + t[c] * t[c], xy + t[c] * t[3])
                });
            (sxx > 0.0).then(|| sxy / sxx)
        };
        // One gain for every sample, and the share of the change it explains.
        let slope = |c: usize| {
            let g = gain_of(c, &|_| true)?;
            Some(share(
                samples.iter().map(|t| (t[3] - g * t[c]).powi(2)).sum(),
            ))
        };
        let (Some(one_gain), Some(quadratic), Some(factor)) = (slope(0), slope(1), slope(2)) else {
            return Err(format!(
                "no intrusion faster than the reference speed {v_ref} m/s with the element in the medium"
            ));
        };
        // A gain per direction.
        let mut gammas: Vec<f64> = Vec::new();
        for &g in &directions {
            if !gammas.iter().any(|&x| (x - g).abs() < 1e-6) {
                gammas.push(g);
            }
        }
        if gammas.len() > MAX_SPEED_LAW_DIRECTIONS {
            return Err(format!(
                "intrusions in {} directions: a speed law holds at most {MAX_SPEED_LAW_DIRECTIONS}",
                gammas.len()
            ));
        }
        let gains: Vec<(f64, f64)> = gammas
            .iter()
            .filter_map(|&g| {
                let k = gain_of(0, &|i| (directions[i] - g).abs() < 1e-6)?;
                Some((g, k.clamp(0.0, RftSpeedLaw::MAX_DEPTH_PER_SPEED_S)))
            })
            .collect();
        let gain_at = |g: f64| {
            gains
                .iter()
                .find(|(x, _)| (x - g).abs() < 1e-6)
                .map_or(0.0, |p| p.1)
        };
        let explained = share(
            samples
                .iter()
                .zip(&directions)
                .map(|(t, &g)| (t[3] - gain_at(g) * t[0]).powi(2))
                .sum(),
        );
        let law = RftSpeedLaw::by_direction(v_ref, &gains, v_max).map_err(|e| e.to_string())?;
        Ok(RftSpeedFit {
            law,
            explained,
            one_gain_explained: one_gain,
            quadratic_explained: quadratic,
            factor_law_explained: factor,
            intrusions: compared,
            samples: samples.len() / 2,
        })
    }
}

/// The length (m) of a plate element of length `length_m` at attack angle `beta_r`, its centre
/// `depth_m` below the surface, that is below it.
fn submerged_length_m(length_m: f64, beta_r: f64, depth_m: f64) -> f64 {
    let half_drop = 0.5 * length_m * beta_r.sin().abs();
    if half_drop < 1e-12 {
        return if depth_m > 0.0 { length_m } else { 0.0 };
    }
    length_m * ((depth_m + half_drop) / (2.0 * half_drop)).clamp(0.0, 1.0)
}

/// `[drag, lift]` of rows `[x, drag, lift]` (sorted by `x`: the share of the travel) at `x`,
/// linearly; none outside them.
fn interpolate_along(rows: &[[f64; 3]], x: f64) -> Option<[f64; 2]> {
    let i = rows.partition_point(|r| r[0] < x);
    if i == 0 || i == rows.len() {
        return (i < rows.len() && rows[i][0] == x).then(|| [rows[i][1], rows[i][2]]);
    }
    let (a, b) = (rows[i - 1], rows[i]);
    let t = if b[0] > a[0] {
        (x - a[0]) / (b[0] - a[0])
    } else {
        0.0
    };
    Some([a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])])
}

/// Which stress law RFT uses.
#[derive(Debug, Clone, PartialEq)]
pub enum RftCoefficients {
    /// The nine-coefficient fit.
    Fit(RftFit),
    /// A measured grid, looked up bilinearly.
    Grid(&'static RftGrid),
}

/// The coefficient sets users can name.
pub const RFT_SET_NAMES: [&str; 4] = ["poppy_lp", "poppy_cp", "poppy_lp_grid", "generic"];

impl RftCoefficients {
    /// `poppy_lp`, `poppy_cp`, `poppy_lp_grid`, or `generic` (which needs `zeta_n_cm3`).
    pub fn by_name(name: &str, zeta_n_cm3: Option<f64>) -> Result<Self, ModelError> {
        match name {
            "poppy_lp" => Ok(RftCoefficients::Fit(RftFit::POPPY_LP)),
            "poppy_cp" => Ok(RftCoefficients::Fit(RftFit::POPPY_CP)),
            "poppy_lp_grid" => Ok(RftCoefficients::Grid(RftGrid::poppy_lp())),
            "generic" => Ok(RftCoefficients::Fit(RftFit::generic(
                zeta_n_cm3.unwrap_or(f64::NAN),
            )?)),
            _ => Err(ModelError::UnknownRftSet {
                name: name.to_string(),
                known: RFT_SET_NAMES.join(", "),
            }),
        }
    }

    /// `(alpha_x, alpha_z)` in N/cm^3 for an element at attack angle `beta_r` moving at
    /// `gamma` below the horizontal (in the direction of +x).
    pub fn alpha(&self, beta_r: f64, gamma: f64) -> (f64, f64) {
        match self {
            RftCoefficients::Fit(f) => f.alpha(beta_r, gamma),
            RftCoefficients::Grid(g) => g.alpha(beta_r, gamma),
        }
    }

    /// `alpha_z` (N/cm^3) for a horizontal plate moving straight down: the stress per unit
    /// depth a plate-sinkage test measures of RFT.
    pub fn alpha_z_down_n_cm3(&self) -> f64 {
        // Moving straight down is an intrusion angle of pi/2 below the horizontal.
        self.alpha(0.0, FRAC_PI_2)
            .1
            .abs()
            .max(self.alpha(0.0, -FRAC_PI_2).1.abs())
    }

    /// [`Self::alpha`] for an element along `(tx, tz)` moving along `(vx, vz)` (neither zero),
    /// both in RFT's frame (the motion toward +x): its attack angle is the tangent's, folded
    /// into `[-pi/2, pi/2]`, and its intrusion angle the motion's below the horizontal. Twice
    /// the attack angle does not see the fold, so a fitted law needs only the vectors' ratios
    /// (no trigonometric function: RFT evaluates it for every element of every sample).
    pub fn alpha_along(&self, (tx, tz): (f64, f64), (vx, vz): (f64, f64)) -> (f64, f64) {
        match self {
            RftCoefficients::Fit(f) => {
                let l2 = tx * tx + tz * tz;
                // `speed_m_s`: a motion so slow that its square underflows (below 1e-154 m/s)
                // still has a speed, and a direction.
                let v = speed_m_s(vx, vz);
                f.alpha_trig(
                    ((tx * tx - tz * tz) / l2, 2.0 * tx * tz / l2),
                    (vx / v, -vz / v),
                )
            }
            RftCoefficients::Grid(g) => g.alpha(wrap_half_pi(tz.atan2(tx)), (-vz).atan2(vx)),
        }
    }
}

impl RftCoefficients {
    /// [`Self::alpha_along`] for a tangent and a motion that are unit vectors already (to
    /// rounding): a fitted law then needs no square root or division.
    #[inline]
    pub(crate) fn alpha_unit(&self, (tx, tz): (f64, f64), (vx, vz): (f64, f64)) -> (f64, f64) {
        match self {
            RftCoefficients::Fit(f) => f.alpha_trig((tx * tx - tz * tz, 2.0 * tx * tz), (vx, -vz)),
            RftCoefficients::Grid(g) => g.alpha(wrap_half_pi(tz.atan2(tx)), (-vz).atan2(vx)),
        }
    }
}

/// An [`RftModel`]'s parts, as [`RftModel::batch_parts`] lends them.
pub(crate) struct RftParts<'a> {
    pub coefficients: &'a RftCoefficients,
    pub elements: usize,
    pub profile_elements: Option<&'a [[f64; 7]]>,
    pub has_speed_law: bool,
}

/// RFT for the rotating plate, integrated over `elements` equal elements of the submerged length.
#[derive(Debug, Clone, PartialEq)]
pub struct RftModel {
    plate: Plate,
    coefficients: RftCoefficients,
    elements: usize,
    /// A leg that is not a flat plate: its mid-line `(s, q)` in the leg's frame (see
    /// [`rft_leg`]); `None` for the plate itself.
    profile: Option<Vec<(f64, f64)>>,
    /// The profile cut into this model's elements, once.
    profile_elements: Option<Box<LegElements>>,
    /// The dynamic stress of the element's speed; `None`: quasi-static.
    speed_law: Option<Box<RftSpeedLaw>>,
    /// The stress's law in depth, where it is not RFT's linear one (boxed: most legs have
    /// none, and a model is held by value).
    depth_law: Option<Box<RftDepthLaw>>,
    /// The bearing of sheared sand; `None`: the sand at rest.
    sheared: Option<Box<ShearedBearing>>,
}

/// A medium's stress in depth beyond RFT's linear one, calibrated on plate-sinkage tests (a
/// medium file's `rft_depth_power` law) or intrusion tests (its measured shape): an element at
/// depth `z` below the surface feels the stress RFT gives at the depth
/// `scale z_ref ((z + z_0) / z_ref)^exponent`, `z_ref` 1 cm, `z_0` the law's surface offset (0
/// unless intrusion tests measured one: a bed of coarse grains bears a plate from its first
/// millimetre, as if its surface were `z_0` higher for the stress, not for the geometry). With
/// `scale` and `exponent` 1 and no offset it is RFT itself.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RftDepthLaw {
    /// The factor on RFT's stress at 1 cm.
    pub scale: f64,
    /// The exponent of depth.
    pub exponent: f64,
    /// The surface offset `z_0` (m, >= 0).
    pub offset_m: f64,
}

impl RftDepthLaw {
    /// The reference depth (m).
    pub const REF_DEPTH_M: f64 = 0.01;

    /// The law, checked: a scale in (0, 1e6] and an exponent in (0, 5] (as a sinkage law's,
    /// [`super::sinkage::MAX_EXPONENT`]): beyond them the stress a metre down is no number.
    pub fn new(scale: f64, exponent: f64) -> Result<Self, ModelError> {
        for (what, v, max) in [
            ("RFT depth law's scale", scale, 1e6),
            (
                "RFT depth law's exponent",
                exponent,
                super::sinkage::MAX_EXPONENT,
            ),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= max) {
                return Err(ModelError::OutOfRange {
                    what,
                    value: v,
                    range: format!("(0, {max}]"),
                });
            }
        }
        Ok(RftDepthLaw {
            scale,
            exponent,
            offset_m: 0.0,
        })
    }

    /// The law with the surface offset `offset_m` (m: finite, in `[0, 0.1]`).
    pub fn with_offset(self, offset_m: f64) -> Result<Self, ModelError> {
        if !(offset_m.is_finite() && (0.0..=0.1).contains(&offset_m)) {
            return Err(ModelError::OutOfRange {
                what: "RFT depth law's surface offset (m)",
                value: offset_m,
                range: "[0, 0.1]".into(),
            });
        }
        Ok(RftDepthLaw { offset_m, ..self })
    }

    /// The depth (m) whose linear RFT stress an element at `depth_m` feels.
    #[inline]
    pub fn effective_depth_m(&self, depth_m: f64) -> f64 {
        self.scale
            * Self::REF_DEPTH_M
            * ((depth_m + self.offset_m) / Self::REF_DEPTH_M).powf(self.exponent)
    }

    /// [`Self::effective_depth_m`] of [`LANES`](super::batch::LANES) depths at once, the power
    /// in the lanes ([`super::batch::powf_lanes`]: within 1e-14 of the power).
    #[inline]
    pub fn effective_depths_m(
        &self,
        depth_m: &[f64; super::batch::LANES],
    ) -> [f64; super::batch::LANES] {
        let x = depth_m.map(|d| (d + self.offset_m) / Self::REF_DEPTH_M);
        super::batch::powf_lanes(&x, self.exponent).map(|p| self.scale * Self::REF_DEPTH_M * p)
    }
}

/// `depth_m` through `law`, or as it is.
#[inline]
fn stressed_depth_m(law: Option<&RftDepthLaw>, depth_m: f64) -> f64 {
    law.map_or(depth_m, |l| l.effective_depth_m(depth_m))
}

impl RftModel {
    /// The most elements a model takes.
    pub const MAX_ELEMENTS: usize = 100_000;

    /// RFT for the flat plate `plate`, in `elements` elements.
    pub fn new(
        plate: Plate,
        coefficients: RftCoefficients,
        elements: usize,
    ) -> Result<Self, ModelError> {
        if elements == 0 || elements > Self::MAX_ELEMENTS {
            return Err(ModelError::RftElements {
                value: elements,
                max: Self::MAX_ELEMENTS,
            });
        }
        Ok(RftModel {
            plate,
            coefficients,
            elements,
            profile: None,
            profile_elements: None,
            speed_law: None,
            depth_law: None,
            sheared: None,
        })
    }

    /// The model with each element's dynamic stress of `law` added to its quasi-static one. The
    /// speed comes from the leg's rotation rate (and the hip's velocity) of
    /// [`Self::evaluate_moving`]; where neither is known ([`Self::evaluate`]) the stress is the
    /// quasi-static one.
    pub fn with_speed_law(mut self, law: Option<RftSpeedLaw>) -> Self {
        self.speed_law = law.map(Box::new);
        self
    }

    /// The speed law, if any.
    pub fn speed_law(&self) -> Option<&RftSpeedLaw> {
        self.speed_law.as_deref()
    }

    /// The model with its stress in depth following `law` instead of RFT's linear one.
    pub fn with_depth_law(mut self, law: Option<RftDepthLaw>) -> Self {
        self.depth_law = law.map(Box::new);
        self
    }

    /// The law in depth, if any.
    pub fn depth_law(&self) -> Option<&RftDepthLaw> {
        self.depth_law.as_deref()
    }

    /// RFT for a leg whose mid-line is `profile` (at least two points, in the leg's frame: `s`
    /// along the chord from the hip, `q` toward the travel; [`c_leg_profile`] for a C-leg), of
    /// `plate`'s width, its hip `plate`'s hip height above the surface; about `elements`
    /// elements in all.
    pub fn with_profile(
        plate: Plate,
        coefficients: RftCoefficients,
        elements: usize,
        profile: Vec<(f64, f64)>,
    ) -> Result<Self, ModelError> {
        for &(s, q) in &profile {
            finite("leg profile coordinate (m)", s)?;
            finite("leg profile coordinate (m)", q)?;
        }
        check_profile(&profile).map_err(|problem| ModelError::BadProfile { problem })?;
        let mut m = RftModel::new(plate, coefficients, elements)?;
        let per_segment = (elements / (profile.len() - 1)).max(1);
        m.profile_elements = Some(Box::new(LegElements::new(&profile, per_segment)));
        m.profile = Some(profile);
        Ok(m)
    }

    /// The plate (for a curved leg, its chord's length and width) and hip height.
    pub fn plate(&self) -> &Plate {
        &self.plate
    }

    /// What a batch of legs needs to integrate this model without [`Self::evaluate_moving`]:
    /// the coefficients, the element count over a plate's submerged length, the profile's
    /// elements (`[s, q, length, cos 2t, sin 2t, ds, dq]` each, [`LegElements`]), and whether a
    /// speed law applies.
    pub(crate) fn batch_parts(&self) -> RftParts<'_> {
        RftParts {
            coefficients: &self.coefficients,
            elements: self.elements,
            profile_elements: self
                .profile_elements
                .as_deref()
                .map(|e| e.elements.as_slice()),
            has_speed_law: self.speed_law.is_some(),
        }
    }

    /// The leg's mid-line, where it is not a flat plate.
    pub fn profile(&self) -> Option<&[(f64, f64)]> {
        self.profile.as_deref()
    }

    /// [`Self::evaluate`] for a leg of another shape: RFT element by element over its mid-line.
    fn evaluate_profile(
        &self,
        beta: f64,
        line: &[(f64, f64)],
        elements: &LegElements,
        hip: &HipMotion,
    ) -> Prediction {
        // (evaluate_moving refused a lateral velocity that is no number)
        let lateral = hip.leg_frame_lateral_m_s();
        let across = Across::new(
            &self.coefficients,
            if hip.omega_rad_s.is_finite() {
                lateral
            } else {
                0.0
            },
        );
        let [drag, lift, torque, side, roll, yaw, lift_moment] = rft_elements_moving(
            &self.coefficients,
            elements,
            self.plate.width_m(),
            hip.height_m,
            beta,
            (hip.omega_rad_s, hip.leg_frame_velocity_m_s()),
            self.speed_law.as_deref(),
            self.depth_law.as_deref(),
            across.as_ref(),
        );
        // Depth of the lowest point, and the length of the mid-line below the surface.
        let (sin_b, cos_b) = beta.sin_cos();
        let depth_at = |(s, q): (f64, f64)| s * sin_b + q * cos_b - hip.height_m;
        let depth = line.iter().map(|p| depth_at(*p)).fold(0.0f64, f64::max);
        let submerged: f64 = elements
            .segments
            .iter()
            .filter(|&&(s, q, _)| depth_at((s, q)) > 0.0)
            .map(|&(_, _, len)| len)
            .sum();
        let regime = if depth <= 0.0 {
            Regime::OutOfMedium
        } else if beta <= FRAC_PI_2 || beta > 3.0 * FRAC_PI_2 {
            // Past 270 deg the leg is entering, before the chord's own entry.
            Regime::Penetration
        } else {
            Regime::Extraction
        };
        self.sheared_bearing(
            Prediction {
                beta_rad: beta,
                submerged_m: submerged,
                depth_m: depth,
                drag_n: drag,
                lift_n: lift,
                hip_torque_nm: torque,
                side_n: side,
                roll_moment_nm: roll,
                yaw_moment_nm: yaw,
                regime,
            },
            lift_moment,
        )
    }

    /// Drag, lift and hip torque at attack angle `beta_rad` (wrapped to `[0, 2pi)`).
    ///
    /// ```
    /// use terzaghi_core::model::{Plate, RftCoefficients, RftFit, RftModel};
    /// let rft = RftModel::new(Plate::new(0.25, 0.06, 0.15).unwrap(),
    ///     RftCoefficients::Fit(RftFit::POPPY_LP), 100).unwrap();
    /// let p = rft.evaluate(60f64.to_radians()).unwrap();
    /// assert!((p.drag_n - 14.3).abs() < 0.05 && (p.lift_n - 11.6).abs() < 0.05);
    /// ```
    pub fn evaluate(&self, beta_rad: f64) -> Result<Prediction, ModelError> {
        self.evaluate_moving(beta_rad, &HipMotion::still(self.plate.hip_height_m()))
    }

    /// [`Self::evaluate`] with the hip where the robot says it is: `hip.height_m` above the
    /// surface (instead of the plate's), the body's pitch added to `beta_rad`, and each element
    /// intruding along its own velocity, the leg's rotation at `hip.omega_rad_s` plus the hip's.
    pub fn evaluate_moving(
        &self,
        beta_rad: f64,
        hip: &HipMotion,
    ) -> Result<Prediction, ModelError> {
        let beta = wrap_beta_rad(finite("attack angle beta (rad)", beta_rad)? + hip.pitch_rad);
        let h = finite("hip height (m)", hip.height_m)?;
        let lateral = finite("hip lateral velocity (m/s)", hip.leg_frame_lateral_m_s())?;
        if let (Some(line), Some(elements)) = (&self.profile, &self.profile_elements) {
            return Ok(self.evaluate_profile(beta, line, elements, hip));
        }
        let plate = Plate::new(self.plate.length_m(), self.plate.width_m(), h.max(0.0))?;
        let l_s = plate.submerged_length_m(beta);
        if l_s <= 0.0 {
            return Ok(Prediction {
                beta_rad: beta,
                submerged_m: 0.0,
                depth_m: 0.0,
                drag_n: 0.0,
                lift_n: 0.0,
                hip_torque_nm: 0.0,
                side_n: 0.0,
                roll_moment_nm: 0.0,
                yaw_moment_nm: 0.0,
                regime: Regime::OutOfMedium,
            });
        }
        let l = self.plate.length_m();
        let ds = l_s / self.elements as f64;
        let area = self.plate.width_m() * ds;
        // Unit vector from the hip along the plate, and the element velocity direction for a
        // rotation that increases beta (the tip travels along +x at beta = pi/2).
        let (sin_b, cos_b) = beta.sin_cos();
        let (ux, uz) = (-cos_b, -sin_b);
        let (nx, nz) = (sin_b, -cos_b);
        let v_hip = hip.leg_frame_velocity_m_s();
        let moving = (v_hip != [0.0, 0.0] || lateral != 0.0) && hip.omega_rad_s.is_finite();
        let across = Across::new(&self.coefficients, if moving { lateral } else { 0.0 });
        // A plate turning about a still hip: every element moves along n (against it for a
        // rotation backward), so every element's stress law is the same.
        let turn = if hip.omega_rad_s < 0.0 { -1.0 } else { 1.0 };
        let (tx, tz) = (turn * nx, turn * nz);
        let m_still = if tx < 0.0 { -1.0 } else { 1.0 };
        let still = (!moving && (nx != 0.0 || nz != 0.0)).then(|| {
            (
                m_still,
                self.coefficients
                    .alpha_along((m_still * ux, uz), (m_still * tx, tz)),
            )
        });
        let (mut drag, mut lift, mut torque, mut lift_moment) = (0.0, 0.0, 0.0, 0.0);
        let mut side = [0.0; 3];
        for i in 0..self.elements {
            let r = (l - l_s) + (i as f64 + 0.5) * ds; // distance from the hip
            let depth = -(h + r * uz); // below the free surface at z = 0 (hip at z = h)
            if depth <= 0.0 {
                continue;
            }
            // The element's velocity: the rotation's (along n), plus the hip's when it moves.
            let (vx, vz) = if moving {
                (
                    hip.omega_rad_s * r * nx + v_hip[0],
                    hip.omega_rad_s * r * nz + v_hip[1],
                )
            } else {
                (tx, tz)
            };
            let depth = stressed_depth_m(self.depth_law.as_deref(), depth);
            if let Some(a) = &across {
                // Moving across its plane too: the planar law weighted by its share of the
                // speed, and the shear across it.
                let (w, across, extra) = a.shares(self.speed_law.as_deref(), vx, vz);
                let f = a.side_n(depth + extra, area, across);
                side[0] += f;
                side[1] -= r * uz * f;
                side[2] += r * ux * f;
                if w == 0.0 {
                    continue;
                }
                let m = if vx < 0.0 { -1.0 } else { 1.0 };
                let (ax, az) = self.coefficients.alpha_along((m * ux, uz), (m * vx, vz));
                let k = N_CM3_TO_N_M3 * (depth + extra) * area * w;
                let (d_drag, d_lift) = (m * ax * k, az * k);
                drag += d_drag;
                lift += d_lift;
                torque += r * (d_drag * nx - d_lift * nz);
                lift_moment -= r * d_lift * nz;
                continue;
            }
            if vx == 0.0 && vz == 0.0 {
                continue;
            }
            // Mirror x when the element moves toward -x (RFT's frame moves toward +x); the
            // element's own attack angle (along the plate) and intrusion angle.
            let (m, (ax, az)) = match still {
                Some(law) => law,
                None => {
                    let m = if vx < 0.0 { -1.0 } else { 1.0 };
                    (m, self.coefficients.alpha_along((m * ux, uz), (m * vx, vz)))
                }
            };
            // A turning leg's element moves at |omega| r about a still hip.
            let extra = match (self.speed_law.as_deref(), moving) {
                (None, _) => 0.0,
                (Some(law), true) => law.extra_depth_of_velocity_m(vx, vz),
                // Along the turn's direction at |omega| r.
                (Some(law), false) => {
                    let w = hip.omega_rad_s.abs() * r;
                    law.extra_depth_of_velocity_m(w * vx, w * vz)
                }
            };
            let (d_drag, d_lift) = (
                m * ax * N_CM3_TO_N_M3 * (depth + extra) * area,
                az * N_CM3_TO_N_M3 * (depth + extra) * area,
            );
            drag += d_drag;
            lift += d_lift;
            // Resisting moment: the component of the element force against the rotation.
            torque += r * (d_drag * nx - d_lift * nz);
            lift_moment -= r * d_lift * nz;
        }
        let prediction = Prediction {
            beta_rad: beta,
            submerged_m: l_s,
            depth_m: l_s * sin_b,
            drag_n: drag,
            lift_n: lift,
            hip_torque_nm: torque,
            side_n: side[0],
            roll_moment_nm: side[1],
            yaw_moment_nm: side[2],
            regime: if beta <= FRAC_PI_2 {
                Regime::Penetration
            } else {
                Regime::Extraction
            },
        };
        Ok(self.sheared_bearing(prediction, lift_moment))
    }

    /// `p` (the sand at rest) brought to the model's sheared bearing, if it has one: the lift,
    /// and the part of the hip torque its vertical stresses give (`lift_moment_nm`), times
    /// the share the resultant's lean leaves ([`ShearedBearing::share`]).
    fn sheared_bearing(&self, p: Prediction, lift_moment_nm: f64) -> Prediction {
        let Some(b) = self.sheared.as_deref() else {
            return p;
        };
        let share = b.share(p.drag_n.hypot(p.side_n), p.lift_n);
        if share == 1.0 {
            return p;
        }
        Prediction {
            lift_n: p.lift_n * share,
            hip_torque_nm: p.hip_torque_nm - (1.0 - share) * lift_moment_nm,
            ..p
        }
    }

    /// The model with the bearing of sheared sand: its lift (and the lift's hip torque) times
    /// the share the resultant of the sand at rest leaves (a foot sliding in stance, a C-leg
    /// turning under the robot's weight); `None`: the sand at rest, as before.
    pub fn with_sheared_bearing(mut self, bearing: Option<ShearedBearing>) -> Self {
        self.sheared = bearing.map(Box::new);
        self
    }

    /// The sheared bearing, if any.
    pub fn sheared(&self) -> Option<&ShearedBearing> {
        self.sheared.as_deref()
    }
}

/// A planar leg's elements moving across their plane as well (the hip moving sideways: a
/// robot crabbing or turning, a leg yawed to its travel), as a body's elements do
/// ([`super::body::Body::forces`]): each element's stress is the planar law of its velocity in
/// the leg's plane, weighted by that part's share of its speed, plus the shear of the part
/// across (along the plate's surface), as a horizontal plate dragged along itself is sheared.
/// `None` for a leg moving in its plane, which keeps the planar law alone, bit for bit.
#[derive(Debug, Clone, Copy)]
struct Across {
    /// The velocity along the leg frame's `y` (m/s), not zero.
    vy: f64,
    /// A horizontal plate dragged along itself: RFT's `alpha_x` there (N/cm^3).
    shear_n_cm3: f64,
}

impl Across {
    fn new(coefficients: &RftCoefficients, vy: f64) -> Option<Across> {
        (vy != 0.0 && vy.is_finite()).then(|| Across {
            vy,
            shear_n_cm3: coefficients.alpha_along((1.0, 0.0), (1.0, 0.0)).0,
        })
    }

    /// For an element at in-plane velocity `(vx, vz)`: the share of its speed in the leg's
    /// plane, the share across it, and the speed law's extra depth for the whole velocity (m).
    fn shares(&self, speed_law: Option<&RftSpeedLaw>, vx: f64, vz: f64) -> (f64, f64, f64) {
        // `speed_m_s`: a speed of 1e-160 m/s or less would square to zero, and its shares to
        // no number.
        let in_plane = speed_m_s(vx, vz);
        let speed = speed_m_s(in_plane, self.vy);
        let extra = speed_law.map_or(0.0, |law| {
            law.extra_depth_of_velocity_m(speed_m_s(vx, self.vy), vz)
        });
        (in_plane / speed, self.vy.abs() / speed, extra)
    }

    /// The shear's force along `y` on an element of `area_m2` at stressed depth `depth_m`
    /// whose share of speed across the plane is `across` (N): against the motion across.
    fn side_n(&self, depth_m: f64, area_m2: f64, across: f64) -> f64 {
        -self.vy.signum() * self.shear_n_cm3 * N_CM3_TO_N_M3 * depth_m * area_m2 * across
    }
}

/// RFT for a leg of any shape in the plane of rotation (a C-leg, say), element by element as
/// [`RftModel`] integrates a plate. The leg's mid-line is the polyline `line` of points
/// `(s, q)` in the leg's frame: `s` along the chord from the hip toward the tip, `q` toward the
/// travel. At attack angle `beta_rad` of the chord, the chord points along
/// `u = (-cos beta, -sin beta)` from the hip, the travel `n = (sin beta, -cos beta)`, and a point
/// `s u + q n` moves along `s n - q u`. Each segment is cut into `per_segment` elements of
/// width `width_m`; the hip is `hip_height_m` above the surface. An element that moves toward
/// -x is mirrored into RFT's frame (motion toward +x) and back. Returns drag, lift and hip
/// torque (N, N, N m) in the project's convention.
pub fn rft_leg(
    coefficients: &RftCoefficients,
    line: &[(f64, f64)],
    width_m: f64,
    hip_height_m: f64,
    beta_rad: f64,
    per_segment: usize,
) -> (f64, f64, f64) {
    rft_leg_moving(
        coefficients,
        line,
        width_m,
        hip_height_m,
        beta_rad,
        per_segment,
        (1.0, [0.0, 0.0]),
        None,
    )
}

/// [`rft_leg`] for a leg turning at `omega_rad_s` about a hip that moves at
/// `hip_velocity_m_s = [x, z]` in the leg's frame (x along the submerged tip's travel, which is
/// backward for a robot walking forward; z up): each element's intrusion direction is its own
/// velocity, the rotation's plus the hip's, and with `speed_law` it feels the dynamic stress of
/// that velocity's magnitude too. A leg that neither turns nor moves is evaluated as if turning
/// forward at its angle, quasi-statically.
#[allow(clippy::too_many_arguments)]
pub fn rft_leg_moving(
    coefficients: &RftCoefficients,
    line: &[(f64, f64)],
    width_m: f64,
    hip_height_m: f64,
    beta_rad: f64,
    per_segment: usize,
    motion: (f64, [f64; 2]),
    speed_law: Option<&RftSpeedLaw>,
) -> (f64, f64, f64) {
    let [drag, lift, torque, ..] = rft_elements_moving(
        coefficients,
        &LegElements::new(line, per_segment),
        width_m,
        hip_height_m,
        beta_rad,
        motion,
        speed_law,
        None,
        None,
    );
    (drag, lift, torque)
}

/// A leg's mid-line cut into RFT elements: what each element needs of the line, in the leg's
/// frame, computed once for the leg rather than for every element of every prediction.
#[derive(Debug, Clone, PartialEq)]
struct LegElements {
    /// Per element: its middle `(s, q)`, its length (m), the cosine and sine of twice its
    /// segment's direction (`(ds + i dq)^2 / |ds + i dq|^2`), and that direction as a unit
    /// vector `(ds, dq)`.
    elements: Vec<[f64; 7]>,
    /// Per segment: its middle `(s, q)` and its length (m).
    segments: Vec<(f64, f64, f64)>,
}

impl LegElements {
    /// `line`'s segments, each cut into `per_segment` (at least 1) equal elements.
    fn new(line: &[(f64, f64)], per_segment: usize) -> Self {
        let per = per_segment.max(1);
        let mut elements = Vec::with_capacity(per * line.len().saturating_sub(1));
        let mut segments = Vec::with_capacity(line.len().saturating_sub(1));
        for seg in line.windows(2) {
            let (ds, dq) = (seg[1].0 - seg[0].0, seg[1].1 - seg[0].1);
            let l2 = ds * ds + dq * dq;
            let l = l2.sqrt();
            let (c2, s2) = ((ds * ds - dq * dq) / l2, 2.0 * ds * dq / l2);
            for k in 0..per {
                let t = (k as f64 + 0.5) / per as f64;
                elements.push([
                    seg[0].0 + t * ds,
                    seg[0].1 + t * dq,
                    l / per as f64,
                    c2,
                    s2,
                    ds / l,
                    dq / l,
                ]);
            }
            segments.push((seg[0].0 + 0.5 * ds, seg[0].1 + 0.5 * dq, l));
        }
        LegElements { elements, segments }
    }
}

/// [`rft_leg_moving`] over a line already cut into `elements`, moving `across` its plane too
/// where given: drag, lift, hip torque, side force, roll and yaw moments (N, N m).
#[allow(clippy::too_many_arguments)]
fn rft_elements_moving(
    coefficients: &RftCoefficients,
    elements: &LegElements,
    width_m: f64,
    hip_height_m: f64,
    beta_rad: f64,
    (omega_rad_s, hip_velocity_m_s): (f64, [f64; 2]),
    speed_law: Option<&RftSpeedLaw>,
    depth_law: Option<&RftDepthLaw>,
    across: Option<&Across>,
) -> [f64; 7] {
    let still = omega_rad_s == 0.0 && hip_velocity_m_s == [0.0, 0.0] && across.is_none();
    let (omega, v_hip) = if still || !omega_rad_s.is_finite() {
        (1.0, [0.0, 0.0])
    } else {
        (omega_rad_s, hip_velocity_m_s)
    };
    // Quasi-static where the leg neither turns nor moves (its speed is not known).
    let speed_law = speed_law.filter(|_| !still && omega_rad_s.is_finite());
    let (sin_b, cos_b) = beta_rad.sin_cos();
    let (u, n) = ((-cos_b, -sin_b), (sin_b, -cos_b));
    // A point `s u + q n` is `-(s + i q) e^(i beta)` in the plane (x + i z), so a segment's
    // direction turns with the chord, and twice its angle by `e^(2 i beta)`.
    let (c2b, s2b) = (cos_b * cos_b - sin_b * sin_b, 2.0 * sin_b * cos_b);
    let (mut drag, mut lift, mut torque, mut lift_moment) = (0.0, 0.0, 0.0, 0.0);
    let mut side = [0.0; 3];
    for &[s, q, len, c2, s2, ds, dq] in &elements.elements {
        let p = (s * u.0 + q * n.0, s * u.1 + q * n.1);
        let depth = -(hip_height_m + p.1);
        if depth <= 0.0 {
            continue;
        }
        let (vx, vz) = (
            omega * (s * n.0 - q * u.0) + v_hip[0],
            omega * (s * n.1 - q * u.1) + v_hip[1],
        );
        // Moving across its plane too: the shear across, and the planar law weighted by its
        // share of the speed.
        let (w, across_extra) = match across {
            Some(a) => {
                let (w, across, extra) = a.shares(speed_law, vx, vz);
                let f = a.side_n(
                    stressed_depth_m(depth_law, depth) + extra,
                    width_m * len,
                    across,
                );
                side[0] += f;
                side[1] -= p.1 * f;
                side[2] += p.0 * f;
                (w, Some(extra))
            }
            None => (1.0, None),
        };
        if vx == 0.0 && vz == 0.0 {
            continue;
        }
        let speed = speed_m_s(vx, vz);
        // Mirror x when the element moves toward -x (the mirror flips the sine of twice the
        // element's angle).
        let m = if vx < 0.0 { -1.0 } else { 1.0 };
        let (ax, az) = match coefficients {
            RftCoefficients::Fit(f) => f.alpha_trig(
                (c2 * c2b - s2 * s2b, m * (c2 * s2b + s2 * c2b)),
                (m * vx / speed, -vz / speed),
            ),
            RftCoefficients::Grid(_) => coefficients.alpha_along(
                (-m * (ds * cos_b - dq * sin_b), -(ds * sin_b + dq * cos_b)),
                (m * vx, vz),
            ),
        };
        let extra = across_extra.unwrap_or_else(|| {
            speed_law.map_or(0.0, |law| {
                law.extra_at_sine_m(speed, (-vz / speed).clamp(-1.0, 1.0))
            })
        });
        let mut k = N_CM3_TO_N_M3 * (stressed_depth_m(depth_law, depth) + extra) * width_m * len;
        if across.is_some() {
            k *= w;
        }
        // alpha_x resists the motion's horizontal part: F_x = -m ax k.
        let (fx, fz) = (-m * ax * k, az * k);
        drag -= fx;
        lift += fz;
        torque += p.1 * fx - p.0 * fz;
        lift_moment -= p.0 * fz;
    }
    [drag, lift, torque, side[0], side[1], side[2], lift_moment]
}

/// The speed of a velocity `(vx, vz)`: the square root of the sum of squares,
/// and `hypot` (several times slower, the most of an RFT element's cost) only where the squares
/// would overflow or underflow.
#[inline]
fn speed_m_s(vx: f64, vz: f64) -> f64 {
    let v2 = vx * vx + vz * vz;
    if v2.is_finite() && v2 > 1e-290 {
        v2.sqrt()
    } else {
        vx.hypot(vz)
    }
}

/// The mid-line of a C-leg (an arc of `radius_m` spanning `span_rad`, from the hip to the tip,
/// its convex side toward the travel) in the leg's frame of [`rft_leg`], as `segments + 1`
/// points. A half circle (`span_rad` = pi) is the DEM testbed's C-leg, its chord `2 radius_m`.
pub fn c_leg_profile(radius_m: f64, span_rad: f64, segments: usize) -> Vec<(f64, f64)> {
    let half = span_rad / 2.0;
    let (cx, cq) = (radius_m * half.sin(), -radius_m * half.cos());
    (0..=segments.max(1))
        .map(|i| {
            let alpha = FRAC_PI_2 + half - span_rad * i as f64 / segments.max(1) as f64;
            (cx + radius_m * alpha.cos(), cq + radius_m * alpha.sin())
        })
        .collect()
}

/// Most points a leg's mid-line may have: each segment is at least one RFT element per
/// prediction, so a profile of thousands of points would make every prediction slow.
pub const MAX_PROFILE_POINTS: usize = 256;

/// Why `line` (finite points) is no leg's mid-line: fewer than two or more than
/// [`MAX_PROFILE_POINTS`] points, a segment shorter than a micrometre, or two segments that
/// cross or touch (other than neighbours at their shared point).
pub fn check_profile(line: &[(f64, f64)]) -> Result<(), String> {
    if line.len() < 2 {
        return Err(format!(
            "needs at least two points (hip side to tip), got {}",
            line.len()
        ));
    }
    if line.len() > MAX_PROFILE_POINTS {
        return Err(format!(
            "has {} points, at most {MAX_PROFILE_POINTS}",
            line.len()
        ));
    }
    const MIN_SEGMENT_M: f64 = 1e-6;
    for (i, w) in line.windows(2).enumerate() {
        if (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1) < MIN_SEGMENT_M {
            return Err(format!(
                "points {i} and {} coincide ({:?}, {:?}): a segment of zero length",
                i + 1,
                w[0],
                w[1]
            ));
        }
    }
    // Segments i and j > i + 1 must not meet (neighbours share only their common point, unless
    // the line folds back on itself along one direction, which the overlap test below finds).
    let cross = |p: (f64, f64), q: (f64, f64), r: (f64, f64)| {
        (q.0 - p.0) * (r.1 - p.1) - (q.1 - p.1) * (r.0 - p.0)
    };
    let on = |p: (f64, f64), q: (f64, f64), r: (f64, f64)| {
        r.0 >= p.0.min(q.0) && r.0 <= p.0.max(q.0) && r.1 >= p.1.min(q.1) && r.1 <= p.1.max(q.1)
    };
    let meet = |a: (f64, f64), b: (f64, f64), c: (f64, f64), d: (f64, f64)| {
        let (d1, d2) = (cross(c, d, a), cross(c, d, b));
        let (d3, d4) = (cross(a, b, c), cross(a, b, d));
        (((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
            && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0)))
            || (d1 == 0.0 && on(c, d, a))
            || (d2 == 0.0 && on(c, d, b))
            || (d3 == 0.0 && on(a, b, c))
            || (d4 == 0.0 && on(a, b, d))
    };
    let n = line.len() - 1;
    for i in 0..n {
        // A neighbour folding straight back over segment i lies along it.
        if i + 1 < n {
            let (a, b, c) = (line[i], line[i + 1], line[i + 2]);
            let turn = cross(a, b, c);
            let back = (b.0 - a.0) * (c.0 - b.0) + (b.1 - a.1) * (c.1 - b.1) < 0.0;
            if turn.abs() <= 1e-12 * (1.0 + (b.0 - a.0).hypot(b.1 - a.1)).powi(2) && back {
                return Err(format!(
                    "segment {} turns straight back over segment {i}: the line overlaps itself",
                    i + 1
                ));
            }
        }
        for j in i + 2..n {
            if meet(line[i], line[i + 1], line[j], line[j + 1]) {
                return Err(format!(
                    "segment {i} ({:?} to {:?}) and segment {j} ({:?} to {:?}) cross: the line crosses itself",
                    line[i],
                    line[i + 1],
                    line[j],
                    line[j + 1]
                ));
            }
        }
    }
    Ok(())
}

/// A line's angle folded into `[-pi/2, pi/2]` (a plate has no head or tail).
/// Both ends, `-pi/2` and `pi/2`, are the same vertical plate and give the same stress.
fn wrap_half_pi(angle: f64) -> f64 {
    (angle + FRAC_PI_2).rem_euclid(PI) - FRAC_PI_2
}

#[cfg(test)]
mod sheared_tests {
    use super::*;

    /// A plate and a C-leg with the bearing of sheared sand: the drag as at rest, the lift
    /// times the share the resultant's lean leaves, and the hip torque less the lift's part of
    /// it (for a flat plate, the lift's arm lies on the submerged length, `r cos beta`).
    #[test]
    fn a_planar_leg_bears_less_where_its_resultant_leans_and_the_same_where_it_does_not() {
        let plate = Plate::new(0.1, 0.02, 0.05).unwrap();
        let c = RftCoefficients::Fit(RftFit::POPPY_LP);
        let b = ShearedBearing::new(0.35, 2.0).unwrap();
        let flat = RftModel::new(plate, c.clone(), 100).unwrap();
        let curved = RftModel::with_profile(plate, c, 100, c_leg_profile(0.05, PI, 24)).unwrap();
        for rest in [flat, curved] {
            let sheared = rest.clone().with_sheared_bearing(Some(b));
            let (mut lost, mut kept) = (0, 0);
            for deg in (30..=150).step_by(10) {
                let beta = f64::from(deg).to_radians();
                let (p0, p1) = (
                    rest.evaluate(beta).unwrap(),
                    sheared.evaluate(beta).unwrap(),
                );
                let share = b.share(p0.drag_n.hypot(p0.side_n), p0.lift_n);
                assert_eq!(p1.drag_n, p0.drag_n);
                assert!((p1.lift_n - p0.lift_n * share).abs() <= 1e-12 * p0.lift_n.abs());
                if share < 1.0 {
                    lost += 1;
                    assert!(p1.lift_n < p0.lift_n && p1.lift_n > 0.0);
                    if rest.profile().is_none() {
                        // The lift's arm about the hip: on the submerged length.
                        let arm = (p0.hip_torque_nm - p1.hip_torque_nm) / (p0.lift_n - p1.lift_n);
                        let (l, l_s) = (0.1, p0.submerged_m);
                        let c = beta.cos();
                        let (lo, hi) = ((l - l_s) * c, l * c);
                        assert!(
                            arm >= lo.min(hi) - 1e-12 && arm <= lo.max(hi) + 1e-12,
                            "{deg} deg: arm {arm} outside {lo}..{hi}"
                        );
                    }
                } else {
                    kept += 1;
                    assert_eq!(p1, p0);
                }
            }
            assert!(lost > 0 && kept > 0, "{lost} lost, {kept} kept");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A horizontal plate pushed straight down with a law in depth feels RFT's stress at the
    /// law's depth, `scale z_ref (z / z_ref)^n`, everywhere along it; without it, RFT's own.
    #[test]
    fn a_depth_law_sets_the_stress_at_each_depth() {
        let plate = Plate::new(0.08, 0.05, 0.0).unwrap();
        let line = vec![(0.0, 0.0), (0.08, 0.0)];
        let coeffs = RftCoefficients::Fit(RftFit::POPPY_LP);
        let linear = RftModel::with_profile(plate, coeffs.clone(), 40, line).unwrap();
        let law = RftDepthLaw::new(1.7, 1.25).unwrap();
        let powered = linear.clone().with_depth_law(Some(law));
        // Straight down: at beta 0 the chord is horizontal; the hip moves down, the leg does not
        // turn.
        let down = |depth_m: f64| HipMotion {
            height_m: -depth_m,
            omega_rad_s: 0.0,
            up_m_s: -0.01,
            ..HipMotion::still(-depth_m)
        };
        let per_m = linear.evaluate_moving(0.0, &down(0.01)).unwrap().lift_n / 0.01;
        assert!(per_m > 0.0);
        for z in [0.003, 0.01, 0.025] {
            let p = powered.evaluate_moving(0.0, &down(z)).unwrap();
            let at = linear
                .evaluate_moving(0.0, &down(law.effective_depth_m(z)))
                .unwrap();
            assert!(
                (p.lift_n / at.lift_n - 1.0).abs() < 1e-9,
                "{z}: {p:?} against {at:?}"
            );
            // RFT's own stress grows linearly with depth.
            let q = linear.evaluate_moving(0.0, &down(z)).unwrap();
            assert!((q.lift_n / (per_m * z) - 1.0).abs() < 1e-9, "{z}: {q:?}");
        }
        assert!((law.effective_depth_m(0.01) - 0.017).abs() < 1e-15);
        assert!(RftDepthLaw::new(f64::NAN, 1.0).is_err());
        assert!(RftDepthLaw::new(1.0, -1.0).is_err());
    }
    use std::f64::consts::{FRAC_PI_4, PI};

    fn plate() -> Plate {
        Plate::new(0.25, 0.06, 0.15).unwrap()
    }

    #[test]
    fn a_plate_turning_backward_about_a_still_hip_is_pushed_as_it_moves() {
        // A still hip and a hip creeping forward by a hair must give the same forces: the
        // plate's elements move against n either way (the still hip's case took n's
        // direction whatever the sign of the rotation).
        let m = RftModel::new(plate(), RftCoefficients::Fit(RftFit::POPPY_LP), 100).unwrap();
        for beta_deg in [30.0f64, 70.0, 110.0, 150.0] {
            let beta = beta_deg.to_radians();
            let at = |fwd: f64| {
                let hip = HipMotion {
                    height_m: 0.05,
                    omega_rad_s: -3.0,
                    forward_m_s: fwd,
                    ..HipMotion::default()
                };
                m.evaluate_moving(beta, &hip).unwrap()
            };
            let (still, creeping) = (at(0.0), at(1e-12));
            assert!(still.lift_n.abs() > 0.1, "{beta_deg} deg: in the medium");
            for (a, b) in [
                (still.drag_n, creeping.drag_n),
                (still.lift_n, creeping.lift_n),
                (still.hip_torque_nm, creeping.hip_torque_nm),
            ] {
                assert!(
                    (a - b).abs() < 1e-9 * (1.0 + b.abs()),
                    "{beta_deg} deg: {a} against {b}"
                );
            }
        }
    }

    /// A leg yawed to its travel (the hip moving across the leg's plane) is pushed back against
    /// its sideways motion, and turned the way its submerged part's place says, with the signs
    /// `docs/bodies.md` gives; moving in its plane it has none, and its drag and lift are
    /// today's, bit for bit.
    /// A leg moving across its plane at a speed whose square is below the smallest number
    /// (found by fuzzing the batch: a C-leg at 1.6e-306 m/s sideways gave a drag of no number)
    /// has finite forces, those of its motion in the plane.
    #[test]
    fn a_leg_moving_sideways_too_slowly_to_square_has_finite_forces() {
        let c = RftCoefficients::Fit(RftFit::POPPY_LP);
        let c_leg = RftModel::with_profile(plate(), c, 96, c_leg_profile(0.125, PI, 16)).unwrap();
        let hip = |lateral_m_s: f64, forward_m_s: f64| HipMotion {
            height_m: 0.05,
            forward_m_s,
            up_m_s: forward_m_s,
            lateral_m_s,
            ..HipMotion::default()
        };
        let flat = RftModel::new(plate(), RftCoefficients::Fit(RftFit::POPPY_LP), 50).unwrap();
        // And a plate moving across at 0.2 m/s, in its plane at 1e-219 m/s (found so too).
        let p = flat
            .evaluate_moving(
                1.5,
                &HipMotion {
                    omega_rad_s: -3.7e-219,
                    forward_m_s: -9.9e-234,
                    up_m_s: 3.7e-317,
                    ..hip(-0.2, 0.0)
                },
            )
            .unwrap();
        assert!(
            p.side_n.abs() > 0.1 && p.roll_moment_nm.is_finite(),
            "{p:?}"
        );
        for v in [p.drag_n, p.lift_n, p.hip_torque_nm] {
            assert!(v.is_finite() && v.abs() < 1e-100, "{p:?}");
        }
        for (lateral, forward) in [(1.6e-306, 2.8e-173), (1e-200, 0.0), (1e-170, 0.05)] {
            let p = c_leg.evaluate_moving(1.2, &hip(lateral, forward)).unwrap();
            for v in [
                p.drag_n,
                p.lift_n,
                p.hip_torque_nm,
                p.side_n,
                p.roll_moment_nm,
            ] {
                assert!(v.is_finite(), "{lateral} {forward}: {p:?}");
            }
            // Moving in its plane far faster than across it, it is borne as in its plane;
            // moving across it alone, it is pushed sideways alone.
            let (borne, pushed) = (p.lift_n.abs() > 0.1, p.side_n.abs() > 0.1);
            assert!(
                if forward > 1e3 * lateral {
                    borne && !pushed
                } else {
                    pushed && !borne
                },
                "{lateral} {forward}: {p:?}"
            );
        }
    }

    #[test]
    fn a_yawed_planar_leg_has_the_side_force_and_moments_the_docs_give() {
        let c = RftCoefficients::Fit(RftFit::POPPY_LP);
        let flat = RftModel::new(plate(), c.clone(), 100).unwrap();
        let c_leg = RftModel::with_profile(plate(), c, 96, c_leg_profile(0.125, PI, 16)).unwrap();
        for (leg, what) in [(&flat, "plate"), (&c_leg, "C-leg")] {
            for beta_deg in [60.0f64, 90.0, 120.0] {
                let hip = |lateral_m_s: f64| HipMotion {
                    height_m: 0.15,
                    omega_rad_s: 1.0,
                    forward_m_s: 0.05,
                    lateral_m_s,
                    ..HipMotion::default()
                };
                let at = |h: HipMotion| leg.evaluate_moving(beta_deg.to_radians(), &h).unwrap();
                let (planar, left, right, hair) =
                    (at(hip(0.0)), at(hip(0.05)), at(hip(-0.05)), at(hip(1e-9)));
                let case = format!("{what} at beta {beta_deg} deg: {left:?}");
                let in_plane = |p: &Prediction| p.drag_n.hypot(p.lift_n);
                assert!(in_plane(&planar) > 1.0, "{case}");
                assert_eq!(
                    [planar.side_n, planar.roll_moment_nm, planar.yaw_moment_nm],
                    [0.0; 3],
                    "{case}"
                );
                // Moving left (+lateral): pushed right, along the hip frame's +y.
                assert!(left.side_n > 0.01 * in_plane(&planar), "{case}");
                // The submerged part below the hip: the push to the right rolls it about +x.
                assert!(left.roll_moment_nm > 0.0, "{case}");
                // Turned about z by the push at the submerged part's x: behind the hip along
                // the travel (beta < 90 deg: ahead along the robot's forward) it turns
                // clockwise seen from above, in front of it anticlockwise.
                let submerged_x = -(beta_deg.to_radians().cos());
                if what == "plate" && beta_deg != 90.0 {
                    assert_eq!(left.yaw_moment_nm.signum(), submerged_x.signum(), "{case}");
                } else if what == "plate" {
                    assert!(left.yaw_moment_nm.abs() < 1e-12, "{case}");
                }
                // Mirror images: the same drag and lift, the side force and moments reversed.
                for (a, b) in [
                    (left.drag_n, right.drag_n),
                    (left.lift_n, right.lift_n),
                    (left.side_n, -right.side_n),
                    (left.roll_moment_nm, -right.roll_moment_nm),
                    (left.yaw_moment_nm, -right.yaw_moment_nm),
                ] {
                    assert!((a - b).abs() <= 1e-12 * in_plane(&planar), "{case}");
                }
                // Sliding across takes a share of the speed from the planar law.
                assert!(in_plane(&left) < in_plane(&planar), "{case}");
                // And a hair of it changes nothing measurable.
                assert!((hair.drag_n - planar.drag_n).abs() < 1e-6, "{case}");
                assert!((hair.lift_n - planar.lift_n).abs() < 1e-6, "{case}");
            }
        }
    }

    /// For a flat plate, alpha is the same on every element, so the integral is
    /// `alpha b sin(beta) l_s^2 / 2`.
    fn closed_form(fit: &RftFit, beta: f64) -> (f64, f64) {
        let l_s = plate().submerged_length_m(beta);
        let beta_r = if beta <= FRAC_PI_2 { beta } else { beta - PI };
        let (ax, az) = fit.alpha(beta_r, FRAC_PI_2 - beta);
        let k = N_CM3_TO_N_M3 * 0.06 * beta.sin() * l_s * l_s / 2.0;
        (ax * k, az * k)
    }

    #[test]
    fn alpha_along_vectors_is_alpha_at_their_angles() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        for c in [
            RftCoefficients::Fit(RftFit::POPPY_LP),
            RftCoefficients::Fit(RftFit::POPPY_CP),
            RftCoefficients::Grid(RftGrid::poppy_lp()),
        ] {
            for _ in 0..10_000 {
                let t: (f64, f64) = (rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
                let v: (f64, f64) = (rng.random_range(0.0..1.0), rng.random_range(-1.0..1.0));
                if t.0.hypot(t.1) < 1e-3 || v.0.hypot(v.1) < 1e-3 {
                    continue;
                }
                let want = c.alpha(wrap_half_pi(t.1.atan2(t.0)), (-v.1).atan2(v.0));
                let got = c.alpha_along(t, v);
                assert!(
                    (got.0 - want.0).abs() < 1e-12 && (got.1 - want.1).abs() < 1e-12,
                    "{t:?} {v:?}: {got:?} against {want:?}"
                );
            }
        }
    }

    #[test]
    fn a_profile_that_is_no_leg_is_refused_naming_why() {
        let ok = c_leg_profile(0.05, PI, 32);
        assert_eq!(check_profile(&ok), Ok(()));
        assert_eq!(
            check_profile(&[(0.0, 0.0), (0.1, 0.02), (0.2, 0.0)]),
            Ok(())
        );
        let cases: [(Vec<(f64, f64)>, &str); 5] = [
            (vec![(0.0, 0.0)], "at least two points"),
            // A figure of eight: the fourth segment crosses the first.
            (
                vec![(0.0, 0.0), (0.1, 0.1), (0.1, 0.0), (0.0, 0.1)],
                "crosses itself",
            ),
            (vec![(0.0, 0.0), (0.1, 0.0), (0.1, 0.0)], "zero length"),
            (vec![(0.0, 0.0), (0.1, 0.0), (0.05, 0.0)], "straight back"),
            (
                (0..=MAX_PROFILE_POINTS)
                    .map(|i| (i as f64 * 1e-3, 0.0))
                    .collect(),
                "at most 256",
            ),
        ];
        for (line, needle) in cases {
            let e = check_profile(&line).unwrap_err();
            assert!(e.contains(needle), "{line:?}: {e}");
            let m = RftModel::with_profile(
                plate(),
                RftCoefficients::Fit(RftFit::POPPY_LP),
                30,
                line.clone(),
            );
            assert!(matches!(m, Err(ModelError::BadProfile { .. })), "{m:?}");
        }
    }

    #[test]
    fn a_half_circle_c_leg_profile_is_the_dem_testbeds() {
        let p = c_leg_profile(0.05, PI, 16);
        assert!(p[0].0.abs() < 1e-12 && p[0].1.abs() < 1e-12, "{p:?}");
        assert!(
            (p[16].0 - 0.1).abs() < 1e-12 && p[16].1.abs() < 1e-12,
            "{p:?}"
        );
        assert!(
            (p[8].0 - 0.05).abs() < 1e-12 && (p[8].1 - 0.05).abs() < 1e-12,
            "{p:?}"
        );
        // A profile model predicts what rft_leg does over it, and nothing out of the medium.
        let c = RftCoefficients::Fit(RftFit::POPPY_LP);
        let plate = Plate::new(0.1, 0.03, 0.04).unwrap();
        let m = RftModel::with_profile(plate, c.clone(), 160, p.clone()).unwrap();
        let beta = 40f64.to_radians();
        let (d, l, _) = rft_leg(&c, &p, 0.03, 0.04, beta, 10);
        let q = m.evaluate(beta).unwrap();
        assert_eq!((q.drag_n, q.lift_n), (d, l));
        assert_eq!(q.regime, Regime::Penetration);
        let air = m.evaluate(-40f64.to_radians()).unwrap();
        assert_eq!((air.drag_n, air.regime), (0.0, Regime::OutOfMedium));
        assert!(RftModel::with_profile(plate, c, 160, vec![(0.0, 0.0)]).is_err());
    }

    #[test]
    fn rft_leg_of_a_straight_line_agrees_with_the_plate_model() {
        let plate = plate();
        let c = RftCoefficients::Fit(RftFit::POPPY_CP);
        let m = RftModel::new(plate, c.clone(), 4000).unwrap();
        for deg in [40.0f64, 60.0, 90.0, 110.0, 140.0] {
            let beta = deg.to_radians();
            let p = m.evaluate(beta).unwrap();
            let (d, l, t) = rft_leg(&c, &[(0.0, 0.0), (0.25, 0.0)], 0.06, 0.15, beta, 4000);
            for (a, b) in [(d, p.drag_n), (l, p.lift_n), (t, p.hip_torque_nm)] {
                assert!(
                    (a - b).abs() <= 2e-3 * p.drag_n.abs().max(1e-3),
                    "{deg}: {a} vs {b}"
                );
            }
        }
    }

    #[test]
    fn rft_coefficients_come_back_from_their_own_stresses_and_noise_stays_small() {
        let truth = RftFit::POPPY_CP;
        let mut pts = Vec::new();
        let mut k = 0u32;
        for b in [-60.0f64, -30.0, 0.0, 30.0, 60.0, 90.0] {
            for g in [-90.0f64, -45.0, 0.0, 45.0, 90.0] {
                let (ax, az) = truth.alpha(b.to_radians(), g.to_radians());
                k += 1;
                let wiggle = 0.002 * ((k * 7919 % 13) as f64 / 6.0 - 1.0);
                pts.push((b.to_radians(), g.to_radians(), ax + wiggle, az - wiggle));
            }
        }
        let fit = RftFit::fit_to_points(&pts).unwrap();
        assert!((fit.a00 - truth.a00).abs() < 0.005, "{fit:?}");
        assert!((fit.c01 - truth.c01).abs() < 0.005, "{fit:?}");
        assert!(RftFit::fit_to_points(&pts[..4]).is_none());
        // One attack angle only: cos 2b and the constant cannot be told apart.
        let one: Vec<_> = pts.iter().copied().filter(|p| p.0 == 0.0).collect();
        assert!(RftFit::fit_to_points(&one).is_none());
    }

    #[test]
    fn poppy_lp_reference_values() {
        let m = RftModel::new(plate(), RftCoefficients::Fit(RftFit::POPPY_LP), 100).unwrap();
        let p60 = m.evaluate(60f64.to_radians()).unwrap();
        assert!((p60.drag_n - 14.3).abs() < 0.05, "{}", p60.drag_n);
        assert!((p60.lift_n - 11.6).abs() < 0.05, "{}", p60.lift_n);
        let p90 = m.evaluate(90f64.to_radians()).unwrap();
        assert!((p90.drag_n - 24.9).abs() < 0.05, "{}", p90.drag_n);
        assert!((p90.lift_n - 1.2).abs() < 0.05, "{}", p90.lift_n);
    }

    #[test]
    fn element_integration_matches_closed_form_for_a_flat_plate() {
        for fit in [
            RftFit::POPPY_LP,
            RftFit::POPPY_CP,
            RftFit::generic(0.5).unwrap(),
        ] {
            let m = RftModel::new(plate(), RftCoefficients::Fit(fit), 7).unwrap();
            for beta_deg in [40.0, 60.0, 90.0, 110.0, 130.0] {
                let beta = f64::to_radians(beta_deg);
                let p = m.evaluate(beta).unwrap();
                let (d, l) = closed_form(&fit, beta);
                assert!(
                    (p.drag_n - d).abs() < 1e-9 * d.abs().max(1.0),
                    "{beta_deg}: {} {d}",
                    p.drag_n
                );
                assert!(
                    (p.lift_n - l).abs() < 1e-9 * l.abs().max(1.0),
                    "{beta_deg}: {} {l}",
                    p.lift_n
                );
            }
        }
    }

    #[test]
    fn torque_is_drag_and_lift_resolved_against_the_velocity() {
        let m = RftModel::new(plate(), RftCoefficients::Fit(RftFit::POPPY_LP), 1000).unwrap();
        let beta = 70f64.to_radians();
        let p = m.evaluate(beta).unwrap();
        // Forces act at 2/3 of the submerged length below O (stress grows linearly with depth).
        let arm = 0.25 - p.submerged_m + 2.0 / 3.0 * p.submerged_m;
        let want = arm * (p.drag_n * beta.sin() + p.lift_n * beta.cos());
        assert!(
            (p.hip_torque_nm - want).abs() < 1e-3 * want,
            "{} {want}",
            p.hip_torque_nm
        );
    }

    #[test]
    // The grid's nodes are tabulated to five digits (1.0472, 1.5708): data, not pi/3 or pi/2.
    #[allow(clippy::approx_constant)]
    fn shipped_grid_parses_and_interpolates_at_its_nodes() {
        let g = RftGrid::poppy_lp();
        assert_eq!((g.betas.len(), g.gammas.len()), (7, 13));
        let (ax, az) = g.alpha(1.0472, -0.7854);
        assert!((ax - 0.046233).abs() < 1e-12 && (az - 0.0092621).abs() < 1e-12);
        // Halfway between two nodes in beta: the mean.
        let (ax2, _) = g.alpha((1.0472 + 0.5236) / 2.0, -0.7854);
        assert!((ax2 - (0.046233 + -0.0051974) / 2.0).abs() < 1e-9);
        // Clamped outside.
        assert_eq!(g.alpha(9.0, 9.0), g.alpha(1.5708, 1.5708));
    }

    #[test]
    fn grid_is_close_to_the_fit_where_both_apply() {
        let fit = RftModel::new(plate(), RftCoefficients::Fit(RftFit::POPPY_LP), 50).unwrap();
        let grid = RftModel::new(
            plate(),
            RftCoefficients::by_name("poppy_lp_grid", None).unwrap(),
            50,
        )
        .unwrap();
        let (a, b) = (fit.evaluate(1.2).unwrap(), grid.evaluate(1.2).unwrap());
        assert!(
            (a.lift_n - b.lift_n).abs() < 0.35 * a.lift_n.abs(),
            "{} {}",
            a.lift_n,
            b.lift_n
        );
        assert!(
            (a.drag_n - b.drag_n).abs() < 0.35 * a.drag_n.abs(),
            "{} {}",
            a.drag_n,
            b.drag_n
        );
    }

    #[test]
    fn bad_grids_and_settings_are_errors() {
        assert!(RftGrid::parse("beta_rad,gamma_rad,alpha_x,alpha_z\n0,0,1,x\n").is_err());
        assert!(RftGrid::parse("0,0,1,1\n1,0,1,1\n0,1,1,1\n").is_err());
        assert!(RftModel::new(plate(), RftCoefficients::Fit(RftFit::POPPY_LP), 0).is_err());
        assert!(RftCoefficients::by_name("generic", None).is_err());
        assert!(
            RftCoefficients::by_name("mud", None)
                .unwrap_err()
                .to_string()
                .contains("poppy_lp")
        );
    }

    #[test]
    fn zero_out_of_medium() {
        let m = RftModel::new(plate(), RftCoefficients::Fit(RftFit::POPPY_LP), 10).unwrap();
        let p = m.evaluate(0.2).unwrap();
        assert_eq!(
            (p.drag_n, p.lift_n, p.regime),
            (0.0, 0.0, Regime::OutOfMedium)
        );
    }

    #[test]
    fn the_speed_law_adds_depth_above_its_calibration_speed_only() {
        let law = RftSpeedLaw::new(0.05, 0.04, 1.0).unwrap();
        for gamma in [-FRAC_PI_2, 0.0, 1.0] {
            assert_eq!(law.extra_depth_m(0.0, gamma), 0.0);
            assert_eq!(law.extra_depth_m(0.05, gamma), 0.0);
            assert!((law.extra_depth_m(0.85, gamma) - 0.04 * 0.8).abs() < 1e-12);
            assert_eq!(law.extra_depth_m(f64::NAN, gamma), 0.0);
            // Not extrapolated past its fastest speed: a glitch's 1000 m/s is 1 m/s.
            assert_eq!(
                law.extra_depth_m(1000.0, gamma),
                law.extra_depth_m(1.0, gamma)
            );
        }
        assert_eq!(law.extra_depth_m(0.85, f64::NAN), 0.0);
        let e = RftSpeedLaw::new(0.05, -0.2, 1.0).unwrap_err().to_string();
        assert!(e.contains("speed gain") && e.contains("-0.2"), "{e}");
        assert!(RftSpeedLaw::new(0.0, 0.5, 1.0).is_err());
        assert!(RftSpeedLaw::new(0.05, 1.5, 1.0).is_err());
        let e = RftSpeedLaw::new(0.05, 0.04, 0.01).unwrap_err().to_string();
        assert!(e.contains("fastest speed") && e.contains("0.01"), "{e}");
    }

    #[test]
    fn a_gain_measured_per_direction_is_taken_linearly_in_its_sine_between_them() {
        // Into the bed at 0.03 s, across at 0.02 s, out of it at none; given in any order.
        let law = RftSpeedLaw::by_direction(
            0.05,
            &[(0.0, 0.02), (-FRAC_PI_2, 0.0), (FRAC_PI_2, 0.03)],
            0.8,
        )
        .unwrap();
        assert_eq!(
            law.gains(),
            &[(-FRAC_PI_2, 0.0), (0.0, 0.02), (FRAC_PI_2, 0.03)]
        );
        // Linear in the sine of the direction: at 45 deg down, 0.707 of the way from across to
        // straight down.
        let half = FRAC_PI_4.sin();
        assert!((law.depth_per_speed_s(FRAC_PI_4) - (0.02 + 0.01 * half)).abs() < 1e-12);
        assert!((law.depth_per_speed_s(-FRAC_PI_4) - (0.02 - 0.02 * half)).abs() < 1e-12);
        let (vx, vz) = (0.45 * half, -0.45 * half);
        assert!(
            (law.extra_depth_of_velocity_m(vx, vz) - law.extra_depth_m(0.45, FRAC_PI_4)).abs()
                < 1e-12
        );
        // A velocity's direction: straight down, horizontal either way, straight up.
        let v = 0.45;
        assert!((law.extra_depth_of_velocity_m(0.0, -v) - 0.03 * 0.4).abs() < 1e-12);
        assert!((law.extra_depth_of_velocity_m(v, 0.0) - 0.02 * 0.4).abs() < 1e-12);
        assert!((law.extra_depth_of_velocity_m(-v, 0.0) - 0.02 * 0.4).abs() < 1e-12);
        assert_eq!(law.extra_depth_of_velocity_m(0.0, v), 0.0);
        assert_eq!(
            law.gains_text(),
            "0.0300 s at 90 deg, 0.0200 s at 0 deg, 0.0000 s at -90 deg"
        );
        // No direction, one given twice, one beyond straight down, a negative gain.
        assert!(RftSpeedLaw::by_direction(0.05, &[], 0.8).is_err());
        let e = RftSpeedLaw::by_direction(0.05, &[(0.3, 0.01), (0.3, 0.02)], 0.8)
            .unwrap_err()
            .to_string();
        assert!(e.contains("given twice") && e.contains("0.3"), "{e}");
        assert!(RftSpeedLaw::by_direction(0.05, &[(2.0, 0.01)], 0.8).is_err());
        assert!(RftSpeedLaw::by_direction(0.05, &[(0.0, -0.01)], 0.8).is_err());
    }

    /// Intrusions from the surface of one element whose force follows RFT at depth plus
    /// `dynamic(v)` times its submerged length (N/m): the table written as the campaign writes it.
    fn entry_table(c: &RftCoefficients, dynamic: impl Fn(f64, f64) -> f64) -> String {
        table_in(
            c,
            &[
                (0.0, FRAC_PI_2),
                (FRAC_PI_4, FRAC_PI_4),
                (FRAC_PI_2, FRAC_PI_2),
            ],
            |v, depth, _| dynamic(v, depth),
        )
    }

    /// [`entry_table`] for elements `(beta, gamma)`, the dynamic stress depending on `gamma`
    /// too.
    fn table_in(
        c: &RftCoefficients,
        elements: &[(f64, f64)],
        dynamic: impl Fn(f64, f64, f64) -> f64,
    ) -> String {
        let mut text = format!("# made here\n{}\n", RftSpeedTable::COLUMNS);
        let (len, width) = (0.025, 0.025);
        for v in [0.05, 0.2, 0.8] {
            for &(b, g) in elements {
                let (ax, az) = c.alpha(b, g);
                for i in 0..60 {
                    let depth = -0.01 + 0.001 * i as f64;
                    // The submerged part's depth integral and length, by small pieces.
                    let (mut iz, mut ls) = (0.0, 0.0);
                    for k in 0..1000 {
                        let z = depth - (k as f64 + 0.5 - 500.0) / 1000.0 * len * b.sin();
                        if z > 0.0 {
                            iz += z * len / 1000.0;
                            ls += len / 1000.0;
                        }
                    }
                    let q = N_CM3_TO_N_M3 * width * iz + dynamic(v, depth, g) * ls;
                    text += &format!("{v},{b},{g},{len},{width},{depth},{},{}\n", ax * q, az * q);
                }
            }
        }
        text
    }

    #[test]
    fn a_speed_table_gives_back_the_law_it_was_made_with_and_tells_the_forms_apart() {
        let c = RftCoefficients::Fit(RftFit::POPPY_LP);
        let k = 0.03;
        // A dynamic stress alpha k (v - v_ref), the same at every depth.
        let text = entry_table(&c, |v, _| N_CM3_TO_N_M3 * 0.025 * k * (v - 0.05));
        let fit = RftSpeedTable::parse(&text).unwrap().fit(&c).unwrap();
        for &(_, gain) in fit.law.gains() {
            assert!((gain - k).abs() < 1e-3 * k, "{fit:?}");
        }
        assert_eq!(
            (fit.law.ref_speed_m_s, fit.law.max_speed_m_s, fit.intrusions),
            (0.05, 0.8, 6)
        );
        assert!(fit.explained > 0.999, "{fit:?}");
        assert!(fit.factor_law_explained < 0.9, "{fit:?}");
        assert!(fit.quadratic_explained < 0.99, "{fit:?}");
        // One that grows with the speed squared: the quadratic form explains it better.
        let quad = entry_table(&c, |v, _| N_CM3_TO_N_M3 * 0.025 * k * (v * v - 0.0025));
        let q = RftSpeedTable::parse(&quad).unwrap().fit(&c).unwrap();
        assert!(q.quadratic_explained > 0.999 && q.explained < 0.99, "{q:?}");
        // A stress that grows with speed in proportion to depth: the factor law's form.
        let factor = entry_table(&c, |v, depth| {
            N_CM3_TO_N_M3 * 0.025 * 0.5 * (v - 0.05) * depth.max(0.0)
        });
        let f = RftSpeedTable::parse(&factor).unwrap().fit(&c).unwrap();
        assert!(f.factor_law_explained > f.explained, "{f:?}");
    }

    #[test]
    fn a_speed_table_in_several_directions_gives_each_its_gain() {
        let c = RftCoefficients::Fit(RftFit::POPPY_LP);
        // Into the bed and across it at 0.03 s; pulled out of it, none.
        let text = table_in(
            &c,
            &[(0.0, FRAC_PI_2), (FRAC_PI_4, 0.0), (0.0, -FRAC_PI_2)],
            |v, _, g| {
                let k = if g < 0.0 { 0.0 } else { 0.03 };
                N_CM3_TO_N_M3 * 0.025 * k * (v - 0.05)
            },
        );
        let fit = RftSpeedTable::parse(&text).unwrap().fit(&c).unwrap();
        let g = fit.law.gains();
        assert_eq!(g.len(), 3, "{fit:?}");
        assert!(g[0].0 == -FRAC_PI_2 && g[0].1 < 1e-6, "{fit:?}");
        assert!(
            (g[1].1 - 0.03).abs() < 3e-5 && (g[2].1 - 0.03).abs() < 3e-5,
            "{fit:?}"
        );
        assert!(
            fit.explained > 0.999 && fit.one_gain_explained < 0.97,
            "{fit:?}"
        );
        // Where speed lowers the force, the law adds nothing (not a negative depth).
        let lower = table_in(&c, &[(0.0, FRAC_PI_2), (0.0, -FRAC_PI_2)], |v, _, g| {
            N_CM3_TO_N_M3 * 0.025 * 0.03 * (v - 0.05) * g.signum()
        });
        let fit = RftSpeedTable::parse(&lower).unwrap().fit(&c).unwrap();
        assert_eq!(fit.law.depth_per_speed_s(-FRAC_PI_2), 0.0, "{fit:?}");
    }

    #[test]
    fn a_speed_table_that_cannot_give_a_law_says_why() {
        let c = RftCoefficients::Fit(RftFit::POPPY_LP);
        let row = |v: f64, b: f64, depth: f64| format!("{v},{b},1.5,0.025,0.025,{depth},1,2\n");
        // A faster intrusion without its reference.
        let text = row(0.05, 0.0, 0.01) + &row(0.05, 0.0, 0.02) + &row(0.4, 0.3, 0.01);
        let e = RftSpeedTable::parse(&text).unwrap().fit(&c).unwrap_err();
        assert!(e.contains("beta 0.3"), "{e}");
        // Only the reference speed.
        let e = RftSpeedTable::parse(&(row(0.05, 0.0, 0.01) + &row(0.05, 0.0, 0.02)))
            .unwrap()
            .fit(&c)
            .unwrap_err();
        assert!(e.contains("no intrusion faster"), "{e}");
        // A row of six cells, a speed of zero, a width of zero.
        let e = RftSpeedTable::parse("0.05,0,0,1,1,1\n").unwrap_err();
        assert!(e.contains("line 1") && e.contains("depth_m"), "{e}");
        let e = RftSpeedTable::parse(&row(0.0, 0.0, 0.01)).unwrap_err();
        assert!(e.contains("speed 0 m/s"), "{e}");
        let e = RftSpeedTable::parse("0.05,0,1.5,0.025,0,0.01,1,2\n").unwrap_err();
        assert!(e.contains("width 0 m"), "{e}");
    }

    #[test]
    fn with_a_speed_law_a_faster_leg_is_pushed_harder_and_an_unknown_speed_is_quasi_static() {
        let law = RftSpeedLaw::new(0.05, 0.03, 1.0).unwrap();
        let c = RftCoefficients::Fit(RftFit::POPPY_LP);
        let plain = RftModel::new(plate(), c.clone(), 200).unwrap();
        let fast = RftModel::new(plate(), c.clone(), 200)
            .unwrap()
            .with_speed_law(Some(law));
        let beta = 60f64.to_radians();
        let still = plain.evaluate(beta).unwrap();
        // No rotation rate known: the quasi-static stress.
        assert_eq!(fast.evaluate(beta).unwrap().drag_n, still.drag_n);
        // At 4 rad/s every submerged element (0.15-0.25 m from the hip) moves at 0.6-1 m/s: it
        // is 17-29 mm deeper, against a mean depth of the submerged part of 43 mm here.
        let hip = HipMotion {
            omega_rad_s: 4.0,
            ..HipMotion::still(plate().hip_height_m())
        };
        let p = fast.evaluate_moving(beta, &hip).unwrap();
        let ratio = p.drag_n / still.drag_n;
        assert!(ratio > 1.0 + 0.2 && ratio < 1.0 + 0.8, "{ratio}");
        assert!((p.lift_n / still.lift_n - ratio).abs() < 1e-9);
        // A C-leg likewise, and quasi-static when it neither turns nor moves.
        let line = c_leg_profile(0.05, PI, 16);
        let q = |omega: f64, law: Option<&RftSpeedLaw>| {
            rft_leg_moving(&c, &line, 0.03, 0.04, 2.0, 4, (omega, [0.0, 0.0]), law).0
        };
        assert!(q(7.5, Some(&law)) > 1.2 * q(7.5, None));
        assert_eq!(q(0.0, Some(&law)), q(0.0, None));
    }

    /// The dynamic stress is there from the first millimetre: just past the surface a fast
    /// plate is pushed many times harder than a slow one, deep in the bed only somewhat harder.
    #[test]
    fn the_dynamic_stress_weighs_most_where_the_leg_enters() {
        let law = RftSpeedLaw::new(0.05, 0.03, 1.0).unwrap();
        let c = RftCoefficients::Fit(RftFit::POPPY_LP);
        let fast = RftModel::new(plate(), c.clone(), 400)
            .unwrap()
            .with_speed_law(Some(law));
        let plain = RftModel::new(plate(), c, 400).unwrap();
        let hip = HipMotion {
            omega_rad_s: 4.0,
            ..HipMotion::still(plate().hip_height_m())
        };
        let entry = plate().entry_beta_rad().unwrap() + 2f64.to_radians();
        let ratio = |beta: f64| {
            fast.evaluate_moving(beta, &hip).unwrap().drag_n
                / plain.evaluate_moving(beta, &hip).unwrap().drag_n
        };
        assert!(
            ratio(entry) > 3.0 * (ratio(FRAC_PI_2) - 1.0) + 1.0,
            "{} {}",
            ratio(entry),
            ratio(FRAC_PI_2)
        );
    }

    /// The element sum with each element's segment and direction precomputed in the leg's frame
    /// (the batch's path) gives what a plain sum gives, element by element, with the angles
    /// taken by atan2 from the element's world direction and velocity: C-legs and random
    /// polylines, fitted and gridded coefficients, turning, moving and still, with and without
    /// a speed law.
    #[test]
    fn the_precomputed_element_sum_is_the_plain_one() {
        use rand::{Rng, SeedableRng};
        let plain = |c: &RftCoefficients,
                     line: &[(f64, f64)],
                     h: f64,
                     beta: f64,
                     per: usize,
                     (omega, v_hip): (f64, [f64; 2]),
                     law: Option<&RftSpeedLaw>| {
            let still = omega == 0.0 && v_hip == [0.0, 0.0];
            let (omega, v_hip) = if still {
                (1.0, [0.0, 0.0])
            } else {
                (omega, v_hip)
            };
            let law = law.filter(|_| !still);
            let world = |(s, q): (f64, f64)| {
                (
                    -s * beta.cos() + q * beta.sin(),
                    -s * beta.sin() - q * beta.cos(),
                )
            };
            let (mut drag, mut lift, mut torque) = (0.0, 0.0, 0.0);
            for seg in line.windows(2) {
                let (a, b) = (world(seg[0]), world(seg[1]));
                for k in 0..per {
                    let t = (k as f64 + 0.5) / per as f64;
                    let sq = (
                        seg[0].0 + t * (seg[1].0 - seg[0].0),
                        seg[0].1 + t * (seg[1].1 - seg[0].1),
                    );
                    let p = world(sq);
                    let depth = -(h + p.1);
                    if depth <= 0.0 {
                        continue;
                    }
                    // The velocity of a point: omega times the point turned a quarter ahead.
                    let ahead = world((-sq.1, sq.0));
                    let (vx, vz) = (omega * ahead.0 + v_hip[0], omega * ahead.1 + v_hip[1]);
                    let m = if vx < 0.0 { -1.0 } else { 1.0 };
                    let beta_r = wrap_half_pi((b.1 - a.1).atan2(m * (b.0 - a.0)));
                    let (ax, az) = c.alpha(beta_r, (-vz).atan2(m * vx));
                    let extra = law.map_or(0.0, |l| l.extra_depth_of_velocity_m(vx, vz));
                    let len = (b.0 - a.0).hypot(b.1 - a.1) / per as f64;
                    let f = N_CM3_TO_N_M3 * (depth + extra) * 0.03 * len;
                    let (fx, fz) = (-m * ax * f, az * f);
                    drag -= fx;
                    lift += fz;
                    torque += p.1 * fx - p.0 * fz;
                }
            }
            (drag, lift, torque)
        };
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let law = RftSpeedLaw::new(0.05, 0.03, 1.0).unwrap();
        let mut compared = 0;
        for c in [
            RftCoefficients::Fit(RftFit::POPPY_LP),
            RftCoefficients::Grid(RftGrid::poppy_lp()),
        ] {
            for trial in 0..300 {
                let line = if trial % 2 == 0 {
                    c_leg_profile(0.05, rng.random_range(1.0..PI), rng.random_range(1..40))
                } else {
                    // A random walk forward along the chord, bending either way.
                    let mut pts = vec![(0.0, 0.0)];
                    for _ in 0..rng.random_range(1..8) {
                        let &(s, q) = pts.last().unwrap();
                        pts.push((
                            s + rng.random_range(0.005..0.03),
                            q + rng.random_range(-0.02..0.02),
                        ));
                    }
                    pts
                };
                let per = rng.random_range(1..6);
                let h = rng.random_range(-0.02..0.08);
                let beta = rng.random_range(0.0..std::f64::consts::TAU);
                let motion = match trial % 3 {
                    0 => (0.0, [0.0, 0.0]),
                    1 => (rng.random_range(-8.0..8.0), [0.0, 0.0]),
                    _ => (
                        rng.random_range(-8.0..8.0),
                        [rng.random_range(-0.3..0.3), rng.random_range(-0.1..0.1)],
                    ),
                };
                let law = (trial % 4 == 0).then_some(&law);
                let got = rft_leg_moving(&c, &line, 0.03, h, beta, per, motion, law);
                let want = plain(&c, &line, h, beta, per, motion, law);
                let scale = want.0.abs().max(want.1.abs()).max(1e-6);
                for (g, w) in [(got.0, want.0), (got.1, want.1), (got.2, want.2)] {
                    assert!(
                        (g - w).abs() <= 1e-9 * scale,
                        "{line:?} h {h} beta {beta} {motion:?}: {got:?} against {want:?}"
                    );
                }
                compared += usize::from(want.1 != 0.0);
            }
        }
        assert!(compared > 200, "only {compared} legs in the medium");
    }
}
