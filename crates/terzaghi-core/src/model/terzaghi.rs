//! The improved Terzaghi model (Yang et al. 2020, Sections 2–3) for a plate rotating through a
//! granular medium, and the conventional model it improves on (`b_e = b`).
//!
//! With `theta = 3pi/4 + phi/2 - beta` (Eq. 13), `k = tan(phi)`, `alpha = pi/4 - phi/2`,
//! `K_p = tan^2(pi/4 + phi/2)`, unit weight `lambda` (N/m^3), fitting width `b_e` (Eq. 11) and
//! submerged length `l_s = l - h/sin(beta)`, the passive zone in front of the plate is a
//! logarithmic-spiral sector `O A B` plus a right triangle under the surface. Moments about the
//! surface point `O` (Assumption 3) give the normal passive force (Eqs. 20–21):
//! `F_pN = (G_t d_tg + F_l d_l + G_lg d_lg) / d_perp`, `d_perp = 2/3 l_s`, and
//! `F_pT = F_pN tan(delta)` along the plate toward the hip (Eq. 22a). Resolved (Eq. 22b):
//! `D = F_pN sin(beta) - F_pT cos(beta)`, `L = F_pN cos(beta) + F_pT sin(beta)`,
//! hip torque `tau = F_pN (h/sin(beta) + d_perp)`.
//!
//! Every force is proportional to `b_e`: `F = b_k a^(-beta) F_unit(beta)`.

use super::plate::is_penetration;
use super::{FittingWidth, Medium, ModelError, Plate, Prediction, Regime, finite, wrap_beta_rad};
use serde::Serialize;
use std::f64::consts::{FRAC_PI_4, PI};

/// The terms the passive force is built from (all with the fitting width applied).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Terms {
    /// Weight of the spiral sector, Eq. (14), N.
    pub g_lg_n: f64,
    /// Signed horizontal arm of the spiral sector's centroid about `O`, Eqs. (15)–(16), m.
    pub d_lg_m: f64,
    /// Weight of the triangle, Eq. (17) (Eq. 24 in the triangle-only regime), N.
    pub g_t_n: f64,
    /// Arm of the triangle's weight, Eq. (18) (Eq. 24), m.
    pub d_tg_m: f64,
    /// Lateral Rankine force, Eq. (19) (Eq. 25), N.
    pub f_l_n: f64,
    /// Arm of the lateral force, Eq. (19) (Eq. 25), m.
    pub d_l_m: f64,
    /// Arm of the normal passive force, `2/3 l_s`, Eq. (21), m.
    pub d_perp_m: f64,
}

/// The full output of the Terzaghi model at one attack angle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TerzaghiForce {
    /// Attack angle after wrapping to `[0, 2pi)`.
    pub beta_rad: f64,
    /// Length of the plate below the surface, `l_s` (m).
    pub submerged_m: f64,
    /// Depth of the tip below the surface, `l_s sin(beta)`.
    pub depth_m: f64,
    /// Fitting width `b_e` used, Eq. (11), m.
    pub effective_width_m: f64,
    /// Force against the direction of travel, in the hip frame (N).
    pub drag_n: f64,
    /// Upward force, in the hip frame (N).
    pub lift_n: f64,
    /// Normal passive force on the plate, `F_pN`, N.
    pub normal_n: f64,
    /// Tangential passive force along the plate toward the hip, `F_pT`, N.
    pub tangential_n: f64,
    /// Torque of the medium's force about the hip (N m).
    pub hip_torque_nm: f64,
    /// Which phase of the stroke the plate is in.
    pub regime: Regime,
    /// The terms the forces are made of.
    pub terms: Terms,
}

impl TerzaghiForce {
    /// The parts every model gives.
    #[inline]
    pub fn prediction(&self) -> Prediction {
        Prediction {
            beta_rad: self.beta_rad,
            submerged_m: self.submerged_m,
            depth_m: self.depth_m,
            drag_n: self.drag_n,
            lift_n: self.lift_n,
            hip_torque_nm: self.hip_torque_nm,
            side_n: 0.0,
            roll_moment_nm: 0.0,
            yaw_moment_nm: 0.0,
            regime: self.regime,
        }
    }
}

/// Constants of a medium, computed once so that an evaluation costs a few transcendental calls.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct MediumConstants {
    pub(crate) lambda: f64,
    /// `k = tan(phi)`
    pub(crate) k: f64,
    /// `3pi/4 + phi/2`: the spiral vanishes beyond this attack angle.
    pub(crate) theta_end: f64,
    pub(crate) cos_phi: f64,
    pub(crate) sin_alpha: f64,
    pub(crate) cos_alpha: f64,
    /// `K_p = tan^2(pi/4 + phi/2)`
    pub(crate) k_p: f64,
    /// `1 / (3 (1 + 9 k^2))`
    pub(crate) inv_spiral_den: f64,
    /// `1 / (4 k)`
    pub(crate) inv_4k: f64,
    pub(crate) tan_delta: f64,
}

impl MediumConstants {
    fn new(m: &Medium) -> Self {
        let phi = m.phi_rad();
        let k = phi.tan();
        let alpha = FRAC_PI_4 - phi / 2.0;
        MediumConstants {
            lambda: m.unit_weight_n_m3(),
            k,
            theta_end: 3.0 * FRAC_PI_4 + phi / 2.0,
            cos_phi: phi.cos(),
            sin_alpha: alpha.sin(),
            cos_alpha: alpha.cos(),
            k_p: (FRAC_PI_4 + phi / 2.0).tan().powi(2),
            inv_spiral_den: 1.0 / (3.0 * (1.0 + 9.0 * k * k)),
            inv_4k: 1.0 / (4.0 * k),
            tan_delta: m.delta_rad().tan(),
        }
    }
}

/// The improved Terzaghi model for one plate in one medium with one fitting width.
#[derive(Debug, Clone, PartialEq)]
pub struct TerzaghiModel {
    plate: Plate,
    medium: Medium,
    width: FittingWidth,
    c: MediumConstants,
    ln_a: f64,
    /// Attack angles outside which the plate is out of the medium for certain (see
    /// [`submerged_range_rad`]).
    submerged_rad: (f64, f64),
}

/// The attack angles `[lo, hi]` outside which `sin(beta) < h / l`, that is, the submerged
/// length is zero, whatever the rounding of `asin` and `sin`: `[asin(h/l), pi - asin(h/l)]`
/// widened by 1e-6 rad. Outside it, an evaluation skips the trigonometry: most of a stride's
/// swing is there. Empty for a plate that is never submerged.
fn submerged_range_rad(plate: &Plate) -> (f64, f64) {
    const MARGIN_RAD: f64 = 1e-6;
    match plate.entry_beta_rad() {
        Some(entry) => (entry - MARGIN_RAD, PI - entry + MARGIN_RAD),
        None => (f64::INFINITY, f64::NEG_INFINITY),
    }
}

impl TerzaghiModel {
    /// The improved model with fitting width `width` (Eq. 11).
    pub fn new(plate: Plate, medium: Medium, width: FittingWidth) -> Self {
        TerzaghiModel {
            plate,
            medium,
            width,
            c: MediumConstants::new(&medium),
            ln_a: width.a().ln(),
            submerged_rad: submerged_range_rad(&plate),
        }
    }

    /// The conventional model: the same equations with `b_e = b`.
    pub fn conventional(plate: Plate, medium: Medium) -> Self {
        Self::new(plate, medium, FittingWidth::CONVENTIONAL)
    }

    /// The plate and hip height.
    pub fn plate(&self) -> &Plate {
        &self.plate
    }
    /// The medium's constants.
    pub fn medium(&self) -> &Medium {
        &self.medium
    }
    /// The fitting width `b_k, a`.
    pub fn fitting_width(&self) -> FittingWidth {
        self.width
    }

    /// The medium's constants and `ln a`, as a batch of legs evaluates them
    /// ([`super::batch`]).
    pub(crate) fn batch_constants(&self) -> (MediumConstants, f64) {
        (self.c, self.ln_a)
    }

    /// The same plate and medium with another fitting width (cheap: constants are kept).
    pub fn with_fitting_width(&self, width: FittingWidth) -> Self {
        TerzaghiModel {
            width,
            ln_a: width.a().ln(),
            ..self.clone()
        }
    }

    /// The same plate with its hip at `hip_height_m` above the surface (the medium's constants
    /// kept): the model of a hip the robot's state places, sample by sample. A hip below the
    /// surface is clamped to it (the model's plate rotates above the medium).
    pub fn with_hip_height_m(&self, hip_height_m: f64) -> Result<Self, ModelError> {
        let h = finite("hip height (m)", hip_height_m)?.max(0.0);
        let plate = self.plate.at_checked_hip_height(h);
        Ok(TerzaghiModel {
            plate,
            submerged_rad: submerged_range_rad(&plate),
            ..self.clone()
        })
    }

    /// Forces at attack angle `beta_rad` (wrapped to `[0, 2pi)`); an error only for a
    /// non-finite angle.
    ///
    /// ```
    /// use terzaghi_core::model::{FittingWidth, Medium, Plate, TerzaghiModel};
    /// let model = TerzaghiModel::conventional(
    ///     Plate::new(0.25, 0.06, 0.15).unwrap(),
    ///     Medium::new(16170.0, 32.0, 19.0).unwrap(),
    /// );
    /// let f = model.evaluate(60f64.to_radians()).unwrap();
    /// assert!((f.drag_n - 39.674130).abs() < 1e-5);
    /// assert!((f.lift_n - 45.639865).abs() < 1e-5);
    /// ```
    pub fn evaluate(&self, beta_rad: f64) -> Result<TerzaghiForce, ModelError> {
        let beta = wrap_beta_rad(finite("attack angle beta (rad)", beta_rad)?);
        self.checked(self.evaluate_wrapped(beta))
    }

    /// Forces at attack angle `beta_rad` with the hip at `hip_height_m` above the surface: what
    /// `with_hip_height_m(hip_height_m)?.evaluate(beta_rad)` gives, without building that
    /// model (the node's path for a hip the robot's state places, every sample of every leg).
    #[inline]
    pub fn evaluate_at_height(
        &self,
        beta_rad: f64,
        hip_height_m: f64,
    ) -> Result<TerzaghiForce, ModelError> {
        let h = finite("hip height (m)", hip_height_m)?.max(0.0);
        let plate = self.plate.at_checked_hip_height(h);
        let beta = wrap_beta_rad(finite("attack angle beta (rad)", beta_rad)?);
        // The trigonometry is skipped only where the plate points up; the submerged length
        // decides the rest, as the entry angle's range would (without its asin).
        self.checked(self.evaluate_wrapped_on(&plate, (0.0, PI), beta))
    }

    /// `f`, or the overflow error of its angle where a force is not finite.
    #[inline]
    fn checked(&self, f: TerzaghiForce) -> Result<TerzaghiForce, ModelError> {
        if f.hip_torque_nm.is_finite() && f.drag_n.is_finite() && f.lift_n.is_finite() {
            Ok(f)
        } else {
            Err(ModelError::Overflow {
                beta_deg: f.beta_rad.to_degrees(),
                phi_deg: self.medium.phi_deg(),
            })
        }
    }

    /// [`TerzaghiModel::evaluate`] for an angle already wrapped to `[0, 2pi)`.
    fn evaluate_wrapped(&self, beta: f64) -> TerzaghiForce {
        self.evaluate_wrapped_on(&self.plate, self.submerged_rad, beta)
    }

    /// The forces on `plate` (this model's, or its hip elsewhere) at a wrapped `beta`; the
    /// trigonometry skipped outside `submerged_rad`, where the plate is out of the medium.
    #[inline]
    fn evaluate_wrapped_on(
        &self,
        plate: &Plate,
        submerged_rad: (f64, f64),
        beta: f64,
    ) -> TerzaghiForce {
        let (lo, hi) = submerged_rad;
        let (sin_b, cos_b) = if (lo..=hi).contains(&beta) {
            beta.sin_cos()
        } else {
            (0.0, 1.0) // out of the medium for certain; only l_s <= 0 is used
        };
        let l_s = plate.submerged_length_at_sin_m(sin_b);
        if l_s <= 0.0 {
            return TerzaghiForce {
                beta_rad: beta,
                submerged_m: 0.0,
                depth_m: 0.0,
                effective_width_m: 0.0,
                drag_n: 0.0,
                lift_n: 0.0,
                normal_n: 0.0,
                tangential_n: 0.0,
                hip_torque_nm: 0.0,
                regime: Regime::OutOfMedium,
                terms: Terms::default(),
            };
        }
        let c = &self.c;
        let b_e = plate.width_m() * self.width.b_k() * (-beta * self.ln_a).exp();
        let w = b_e * c.lambda; // N/m^3 * m = N/m^2 per unit side-view area
        let theta = c.theta_end - beta; // Eq. (13)
        let d_perp = 2.0 / 3.0 * l_s; // Eq. (21)

        // The log spiral's moment is kept as computed: G_lg d_lg again would cost a division.
        let (regime, terms, moment_lg) = if theta > 0.0 {
            let e1 = (theta * c.k).exp();
            let r_b = l_s * e1; // |OB|
            // Eq. (14): sector area l_s^2 (e^{2 theta k} - 1) / (4k); exp_m1 keeps it exact near
            // theta = 0, where e1^2 - 1 would cancel (a third exp only there).
            let e2_m1 = if theta * c.k < 1e-3 {
                (2.0 * theta * c.k).exp_m1()
            } else {
                e1 * e1 - 1.0
            };
            let g_lg = w * l_s * l_s * e2_m1 * c.inv_4k;
            // Eqs. (15)-(16): G_lg d_lg = w l_s^3 f / (3 (1 + 9k^2)), with
            // f = sin b + 3k cos b + e^{3 theta k} [3k cos(pi + b + theta) - sin(b + theta)],
            // and b + theta = 3pi/4 + phi/2 = pi - alpha, so cos(pi+b+theta) = cos(alpha),
            // sin(b+theta) = sin(alpha).
            let f =
                sin_b + 3.0 * c.k * cos_b + e1 * e1 * e1 * (3.0 * c.k * c.cos_alpha - c.sin_alpha);
            let moment_lg = w * l_s * l_s * l_s * f * c.inv_spiral_den;
            let d_lg = if g_lg > 0.0 { moment_lg / g_lg } else { 0.0 };
            let terms = Terms {
                g_lg_n: g_lg,
                d_lg_m: d_lg,
                g_t_n: 0.25 * w * r_b * r_b * c.cos_phi, // Eq. (17)
                d_tg_m: 2.0 / 3.0 * r_b * c.cos_alpha,   // Eq. (18)
                f_l_n: 0.5 * w * (r_b * c.sin_alpha).powi(2) * c.k_p, // Eq. (19)
                d_l_m: 2.0 / 3.0 * r_b * c.sin_alpha,    // Eq. (19)
                d_perp_m: d_perp,
            };
            let regime = if is_penetration(beta) {
                Regime::Penetration
            } else {
                Regime::ExtractionSpiral
            };
            (regime, terms, if g_lg > 0.0 { moment_lg } else { 0.0 })
        } else {
            // Eqs. (24)-(25), with the typo "b gamma" read as b_e lambda.
            let terms = Terms {
                g_lg_n: 0.0,
                d_lg_m: 0.0,
                g_t_n: -0.5 * w * l_s * l_s * sin_b * cos_b,
                d_tg_m: -2.0 / 3.0 * l_s * cos_b,
                f_l_n: 0.5 * w * (l_s * sin_b).powi(2) * c.k_p,
                d_l_m: 2.0 / 3.0 * l_s * sin_b,
                d_perp_m: d_perp,
            };
            (Regime::ExtractionTriangle, terms, 0.0)
        };

        let moment = terms.g_t_n * terms.d_tg_m + terms.f_l_n * terms.d_l_m + moment_lg;
        let normal = moment / d_perp; // Eq. (21)
        let tangential = normal * c.tan_delta; // Eq. (22a)
        TerzaghiForce {
            beta_rad: beta,
            submerged_m: l_s,
            depth_m: l_s * sin_b,
            effective_width_m: b_e,
            drag_n: normal * sin_b - tangential * cos_b, // Eq. (22b)
            lift_n: normal * cos_b + tangential * sin_b,
            normal_n: normal,
            tangential_n: tangential,
            // h / sin(beta) = l - l_s: the arm of F_pN about the hip.
            hip_torque_nm: normal * (plate.length_m() - l_s + d_perp),
            regime,
            terms,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, TAU};

    fn case_a(b_k: f64, a: f64) -> TerzaghiModel {
        TerzaghiModel::new(
            Plate::new(0.25, 0.06, 0.15).unwrap(),
            Medium::new(16170.0, 32.0, 19.0).unwrap(),
            FittingWidth::new(b_k, a).unwrap(),
        )
    }

    fn case_c() -> TerzaghiModel {
        TerzaghiModel::conventional(
            Plate::new(0.10, 0.04, 0.0).unwrap(),
            Medium::new(16170.0, 30.0, 19.0).unwrap(),
        )
    }

    /// Outside the range where the trigonometry is skipped, the plate is out of the medium
    /// however close to the entry angle: the skip changes no result. Plates from a hip at the
    /// surface to one just short of the tip's reach, and past it.
    #[test]
    fn angles_outside_the_submerged_range_are_out_of_the_medium() {
        for h_m in [0.0, 0.05, 0.15, 0.2499999, 0.25, 0.3] {
            let plate = Plate::new(0.25, 0.06, h_m).unwrap();
            let (lo, hi) = submerged_range_rad(&plate);
            let mut betas: Vec<f64> = (0..=20_000).map(|i| i as f64 * TAU / 20_000.0).collect();
            for edge in [lo, hi] {
                if edge.is_finite() {
                    betas.extend((-1000..=1000).map(|i| edge + i as f64 * 1e-9));
                }
            }
            let model =
                TerzaghiModel::conventional(plate, Medium::new(16170.0, 32.0, 19.0).unwrap());
            let mut skipped = 0;
            for beta in betas.into_iter().filter(|b| (0.0..TAU).contains(b)) {
                if (lo..=hi).contains(&beta) {
                    continue;
                }
                skipped += 1;
                assert_eq!(plate.submerged_length_m(beta), 0.0, "h {h_m} beta {beta}");
                let f = model.evaluate(beta).unwrap();
                assert_eq!(f.regime, Regime::OutOfMedium);
                assert_eq!((f.drag_n, f.lift_n, f.hip_torque_nm), (0.0, 0.0, 0.0));
            }
            assert!(skipped > 10_000, "h {h_m}: only {skipped} angles skipped");
        }
    }

    /// A hip placed sample by sample: the same forces, bit for bit, as the model built for that
    /// height, and its errors for a bad height or angle.
    #[test]
    fn evaluating_at_a_height_is_the_model_built_for_it() {
        let model = case_a(1.3, 0.7);
        for h_m in [-0.01, 0.0, 0.02, 0.15, 0.2499999, 0.25, 0.4] {
            let built = model.with_hip_height_m(h_m).unwrap();
            for i in -100..=800 {
                let beta = i as f64 * TAU / 700.0;
                let (got, want) = (
                    model.evaluate_at_height(beta, h_m).unwrap(),
                    built.evaluate(beta).unwrap(),
                );
                assert_eq!(
                    format!("{got:?}"),
                    format!("{want:?}"),
                    "h {h_m} beta {beta}"
                );
            }
        }
        assert!(model.evaluate_at_height(1.0, f64::NAN).is_err());
        assert!(model.evaluate_at_height(f64::INFINITY, 0.1).is_err());
    }

    fn assert_rel(got: f64, want: f64, what: &str) {
        let rel = (got - want).abs() / want.abs().max(1e-12);
        // The check values are printed to 6 decimals; allow that rounding as well as 1e-6 relative.
        assert!(
            rel <= 1e-6 || (got - want).abs() <= 5e-7,
            "{what}: got {got}, want {want}"
        );
    }

    fn check(m: &TerzaghiModel, beta_deg: f64, want: [f64; 3], regime: Regime) {
        let f = m.evaluate(beta_deg.to_radians()).unwrap();
        assert_rel(f.drag_n, want[0], &format!("drag at {beta_deg}"));
        assert_rel(f.lift_n, want[1], &format!("lift at {beta_deg}"));
        assert_rel(f.hip_torque_nm, want[2], &format!("torque at {beta_deg}"));
        assert_eq!(f.regime, regime, "regime at {beta_deg}");
    }

    #[test]
    fn case_a_check_values() {
        use Regime::*;
        let m = case_a(1.0, 1.0);
        let rows = [
            (
                45.0,
                0.037868,
                [10.464665, 21.455744, 5.357877],
                Penetration,
            ),
            (
                60.0,
                0.076795,
                [39.674130, 45.639865, 12.831005],
                Penetration,
            ),
            (
                75.0,
                0.094709,
                [46.971523, 31.682693, 11.701559],
                Penetration,
            ),
            (
                90.0,
                0.100000,
                [36.680578, 12.630136, 7.947458],
                Penetration,
            ),
            (
                105.0,
                0.094709,
                [21.115737, 1.476556, 4.371684],
                ExtractionSpiral,
            ),
            (
                120.0,
                0.076795,
                [8.122418, -1.578838, 1.755638],
                ExtractionSpiral,
            ),
            (
                135.0,
                0.037868,
                [1.022777, -0.498842, 0.255405],
                ExtractionSpiral,
            ),
        ];
        for (beta, l_s, want, regime) in rows {
            check(&m, beta, want, regime);
            let f = m.evaluate(f64::to_radians(beta)).unwrap();
            assert!((f.submerged_m - l_s).abs() < 5e-7, "l_s at {beta}");
        }
    }

    #[test]
    fn case_b_check_values() {
        let m = case_a(2.5, 1.6);
        check(
            &m,
            60.0,
            [60.630824, 69.747784, 19.608607],
            Regime::Penetration,
        );
        check(
            &m,
            105.0,
            [22.308833, 1.559986, 4.618696],
            Regime::ExtractionSpiral,
        );
    }

    #[test]
    fn case_c_check_values() {
        let m = case_c();
        check(
            &m,
            60.0,
            [35.059339, 40.331155, 3.368524],
            Regime::Penetration,
        );
        check(
            &m,
            150.0,
            [1.936026, -1.682961, 0.161700],
            Regime::ExtractionTriangle,
        );
        check(
            &m,
            170.0,
            [0.305312, -0.550797, 0.039696],
            Regime::ExtractionTriangle,
        );
    }

    /// Eq. (9) integrated numerically and rotated by Eq. (10), against the closed form (15)-(16).
    #[test]
    fn spiral_centroid_closed_form_matches_direct_integration() {
        for (phi_deg, beta_deg) in [
            (32.0, 20.0),
            (32.0, 60.0),
            (25.0, 100.0),
            (40.0, 140.0),
            (30.0, 5.0),
        ] {
            let m = TerzaghiModel::conventional(
                Plate::new(0.25, 0.06, 0.0).unwrap(),
                Medium::new(16170.0, phi_deg, 19.0).unwrap(),
            );
            let beta = f64::to_radians(beta_deg);
            let f = m.evaluate(beta).unwrap();
            let (phi, l) = (f64::to_radians(phi_deg), 0.25);
            let (k, theta_r) = (phi.tan(), 3.0 * PI / 4.0 + phi / 2.0 - beta);
            // Simpson's rule over the sector: dA = r^2/2 dt, centroid of each slice at 2r/3.
            let n = 20_000;
            let (mut area, mut mx, mut mz) = (0.0, 0.0, 0.0);
            for i in 0..=n {
                let t = theta_r * i as f64 / n as f64;
                let wgt = if i == 0 || i == n {
                    1.0
                } else if i % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                let r = l * (t * k).exp();
                area += wgt * r * r / 2.0;
                mx += wgt * r * r * r / 3.0 * t.cos();
                mz += wgt * r * r * r / 3.0 * t.sin();
            }
            let (xp, zp) = (mx / area, mz / area);
            let x = (PI - beta).cos() * xp + (PI - beta).sin() * zp; // Eq. (10)
            assert!(
                (f.terms.d_lg_m - x).abs() < 1e-9,
                "phi {phi_deg} beta {beta_deg}: closed {} numeric {x}",
                f.terms.d_lg_m
            );
            let area_closed = f.terms.g_lg_n / (0.06 * 16170.0);
            assert!((area_closed - area * theta_r / (3.0 * n as f64)).abs() < 1e-9);
        }
    }

    #[test]
    fn spiral_arm_is_signed() {
        // With a small phi the spiral barely grows, and at small beta most of the sector lies
        // behind O: its centroid is at negative x. With phi = 32 deg it is always in front.
        let loose = TerzaghiModel::conventional(
            Plate::new(0.25, 0.06, 0.0).unwrap(),
            Medium::new(16170.0, 5.0, 19.0).unwrap(),
        );
        assert!(loose.evaluate(0.1).unwrap().terms.d_lg_m < 0.0);
        assert!(loose.evaluate(1.2).unwrap().terms.d_lg_m > 0.0);
        assert!(case_c().evaluate(0.1).unwrap().terms.d_lg_m > 0.0);
    }

    #[test]
    fn continuous_at_the_triangle_boundary_and_at_entry() {
        let m = case_c();
        let boundary = 3.0 * PI / 4.0 + f64::to_radians(30.0) / 2.0;
        let (lo, hi) = (
            m.evaluate(boundary - 1e-9).unwrap(),
            m.evaluate(boundary + 1e-9).unwrap(),
        );
        assert_eq!(lo.regime, Regime::ExtractionSpiral);
        assert_eq!(hi.regime, Regime::ExtractionTriangle);
        for (a, b) in [
            (lo.drag_n, hi.drag_n),
            (lo.lift_n, hi.lift_n),
            (lo.hip_torque_nm, hi.hip_torque_nm),
        ] {
            assert!((a - b).abs() < 1e-6 * a.abs().max(1.0), "{a} vs {b}");
        }
        // Entry: forces go to zero as the tip reaches the surface.
        let a = case_a(1.0, 1.0);
        let entry = a.plate().entry_beta_rad().unwrap();
        let f = a.evaluate(entry + 1e-7).unwrap();
        assert!(f.drag_n.abs() < 1e-6 && f.lift_n.abs() < 1e-6);
        // Penetration to extraction at pi/2 is the same equation: continuous.
        let (p, e) = (
            a.evaluate(FRAC_PI_2).unwrap(),
            a.evaluate(FRAC_PI_2 + 1e-9).unwrap(),
        );
        assert!((p.drag_n - e.drag_n).abs() < 1e-6);
    }

    #[test]
    fn every_force_is_linear_in_the_fitting_width() {
        let base = case_a(1.0, 1.0);
        let fitted = case_a(2.0, 1.5);
        for beta_deg in [40.0, 60.0, 90.0, 120.0] {
            let beta = f64::to_radians(beta_deg);
            let (u, f) = (base.evaluate(beta).unwrap(), fitted.evaluate(beta).unwrap());
            let s = 2.0 * 1.5f64.powf(-beta);
            for (x, y) in [
                (u.drag_n, f.drag_n),
                (u.lift_n, f.lift_n),
                (u.hip_torque_nm, f.hip_torque_nm),
                (u.normal_n, f.normal_n),
            ] {
                assert!((x * s - y).abs() <= 1e-12 * y.abs().max(1.0));
            }
            assert!((f.effective_width_m - 0.06 * s).abs() < 1e-15);
        }
    }

    #[test]
    fn zero_force_out_of_the_medium() {
        let m = case_a(2.0, 1.5);
        for beta_deg in [0.0, 10.0, 30.0, 150.0, 180.0, 200.0, 359.0, -20.0] {
            let f = m.evaluate(f64::to_radians(beta_deg)).unwrap();
            assert_eq!(f.regime, Regime::OutOfMedium, "{beta_deg}");
            assert_eq!((f.drag_n, f.lift_n, f.hip_torque_nm), (0.0, 0.0, 0.0));
        }
    }

    #[test]
    fn angles_wrap_to_the_rotation_they_mean() {
        let m = case_a(1.0, 1.0);
        let f = m.evaluate(f64::to_radians(60.0) + 2.0 * PI).unwrap();
        assert!((f.drag_n - 39.674130).abs() < 1e-5);
        assert!((f.beta_rad - f64::to_radians(60.0)).abs() < 1e-12);
        assert!(m.evaluate(f64::NAN).is_err());
        assert!(
            m.evaluate(f64::INFINITY)
                .unwrap_err()
                .to_string()
                .contains("inf")
        );
    }

    #[test]
    fn overflow_near_phi_90_is_an_error_not_a_nan() {
        let m = TerzaghiModel::conventional(
            Plate::new(0.25, 0.06, 0.0).unwrap(),
            Medium::new(16170.0, 89.9, 19.0).unwrap(),
        );
        let e = m.evaluate(0.3).unwrap_err();
        assert!(matches!(e, ModelError::Overflow { .. }), "{e}");
    }

    #[test]
    fn depth_is_deepest_when_vertical() {
        let m = case_a(1.0, 1.0);
        let f = m.evaluate(FRAC_PI_2).unwrap();
        assert!((f.depth_m - 0.10).abs() < 1e-12);
    }
}
