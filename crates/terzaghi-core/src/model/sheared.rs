//! Sand that a body shears bears less: the bearing of a load inclined by the shear it carries.
//!
//! RFT gives each element the stress of sand at rest. A body that carries its load while it
//! shears the sand under it (a wheel that skids, a foot sliding in stance, a leg turning under
//! the robot's weight) transmits a resultant inclined from the vertical, and a footing whose
//! load is inclined bears less than one pressed straight down: Meyerhof (1963) takes the
//! bearing capacity times `(1 - delta / phi)^2`, Hansen (1970) and Vesic (1975) a power of
//! `1 - H / V`. Here the inclination is that of the sand's resultant at rest, `tan delta = |H| /
//! V` (RFT's horizontal force over its vertical one at that state), and the sand bears fully
//! while it stays within the friction the sand can mobilise on the body's surface,
//! `tan delta_w` (the interface's friction: Coulomb's wall friction, `2/3` of the sand's
//! friction angle, where nothing else is known); past it the vertical stress of every element
//! in the sand is scaled by
//!
//! ```text
//! i = (tan delta_w / tan delta)^m        (tan delta > tan delta_w; 1 below)
//! ```
//!
//! the exponent `m` Meyerhof's square where nothing else is known. The horizontal stresses are
//! RFT's: the sand ahead of a skidding wheel is still pushed. A body held still, or pressed
//! straight down, carries no shear and loses nothing; the loss grows from there with the
//! shear it mobilises, on the skidding side of a wheel (whose resultant leans back) and not on
//! the driving side, where the rim's traction and the sand's resistance cancel.

use super::ModelError;

/// The bearing of sand that a body shears ([module docs](self)): the interface's friction
/// `tan delta_w` and the exponent `m`.
///
/// Built by [`ShearedBearing::new`] or [`ShearedBearing::of_repose`], which hold each value in
/// its physical range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShearedBearing {
    /// `tan delta_w`: the inclination's tangent up to which the sand bears fully.
    pub interface_tan: f64,
    /// `m`: the power of the loss past it.
    pub exponent: f64,
}

impl ShearedBearing {
    /// The physical range of `interface_tan`: above 0 (no friction would bear no inclined load
    /// at all), at most `tan 60 deg` (beyond the friction of any sand).
    pub const INTERFACE_TAN_RANGE: (f64, f64) = (0.01, 1.7320508075688772);
    /// The physical range of `exponent`: Meyerhof's square lies within it.
    pub const EXPONENT_RANGE: (f64, f64) = (0.25, 8.0);

    /// The bearing, checked: each value in its range ([`Self::INTERFACE_TAN_RANGE`],
    /// [`Self::EXPONENT_RANGE`]), else an error naming it.
    pub fn new(interface_tan: f64, exponent: f64) -> Result<ShearedBearing, ModelError> {
        for (what, value, (lo, hi)) in [
            (
                "the sheared bearing's interface_tan",
                interface_tan,
                Self::INTERFACE_TAN_RANGE,
            ),
            (
                "the sheared bearing's exponent",
                exponent,
                Self::EXPONENT_RANGE,
            ),
        ] {
            if !(value.is_finite() && (lo..=hi).contains(&value)) {
                return Err(ModelError::OutOfRange {
                    what,
                    value,
                    range: format!("[{lo}, {hi}]"),
                });
            }
        }
        Ok(ShearedBearing {
            interface_tan,
            exponent,
        })
    }

    /// The physics alone, from the sand's angle of repose (deg, its friction at the critical
    /// state): the interface's friction Coulomb's `2/3` of it, and Meyerhof's square.
    pub fn of_repose(angle_of_repose_deg: f64) -> Result<ShearedBearing, ModelError> {
        if !(angle_of_repose_deg.is_finite() && (5.0..=60.0).contains(&angle_of_repose_deg)) {
            return Err(ModelError::OutOfRange {
                what: "the angle of repose (deg)",
                value: angle_of_repose_deg,
                range: "[5, 60]".to_string(),
            });
        }
        ShearedBearing::new((angle_of_repose_deg * 2.0 / 3.0).to_radians().tan(), 2.0)
    }

    /// The share of its vertical stress the sand keeps under a resultant at rest of
    /// `horizontal_n` (its magnitude) over `vertical_n` (N): 1 where the sand does not bear
    /// the body (`vertical_n` not above 0) or the inclination is within the interface's
    /// friction; a number in (0, 1) past it. A force that is no number gives a share that is
    /// none.
    pub fn share(&self, horizontal_n: f64, vertical_n: f64) -> f64 {
        if horizontal_n.is_nan() || vertical_n.is_nan() {
            return f64::NAN;
        }
        if vertical_n <= 0.0 {
            return 1.0;
        }
        let tan = horizontal_n.abs() / vertical_n;
        if tan <= self.interface_tan {
            1.0
        } else {
            (self.interface_tan / tan).powf(self.exponent)
        }
    }

    /// `force_n` and `moment_nm` (about the hub) of the sand at rest on a body, with
    /// `vertical_moment_nm` the part of the moment that its vertical stresses give, brought to
    /// the sheared bearing: the vertical force, and its moments, times [`Self::share`].
    pub fn apply(
        &self,
        force_n: [f64; 3],
        moment_nm: [f64; 3],
        vertical_moment_nm: [f64; 2],
    ) -> ([f64; 3], [f64; 3]) {
        let share = self.share(force_n[0].hypot(force_n[1]), force_n[2]);
        if share == 1.0 {
            return (force_n, moment_nm);
        }
        let lost = 1.0 - share;
        (
            [force_n[0], force_n[1], force_n[2] * share],
            [
                moment_nm[0] - lost * vertical_moment_nm[0],
                moment_nm[1] - lost * vertical_moment_nm[1],
                moment_nm[2],
            ],
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sand_bears_fully_within_the_interfaces_friction_and_less_past_it() {
        let b = ShearedBearing::new(0.35, 2.0).unwrap();
        assert_eq!(b.share(0.0, 10.0), 1.0);
        assert_eq!(b.share(3.5, 10.0), 1.0);
        assert_eq!(b.share(-3.5, 10.0), 1.0);
        // tan delta 0.7: (0.35 / 0.7)^2.
        assert!((b.share(7.0, 10.0) - 0.25).abs() < 1e-15);
        // Falls steadily with the inclination.
        let mut last = 1.0;
        for k in 1..100 {
            let s = b.share(k as f64 * 0.1, 1.0);
            assert!(s <= last && s > 0.0);
            last = s;
        }
        // Not borne, or no number.
        assert_eq!(b.share(5.0, 0.0), 1.0);
        assert_eq!(b.share(5.0, -2.0), 1.0);
        assert!(b.share(f64::NAN, 1.0).is_nan());
        assert!(b.share(1.0, f64::NAN).is_nan());
    }

    #[test]
    fn the_loss_takes_the_vertical_force_and_its_moments_only() {
        let b = ShearedBearing::new(0.5, 1.0).unwrap();
        // tan delta = hypot(3, 4) / 5 = 1: share 0.5.
        let (f, m) = b.apply([3.0, 4.0, 5.0], [1.0, 2.0, 3.0], [0.4, -0.6]);
        assert_eq!(f, [3.0, 4.0, 2.5]);
        assert!((m[0] - 0.8).abs() < 1e-15 && (m[1] - 2.3).abs() < 1e-15 && m[2] == 3.0);
    }

    #[test]
    fn values_outside_their_physical_range_are_refused_by_name() {
        for (t, m, name) in [
            (0.0, 2.0, "interface_tan"),
            (-0.3, 2.0, "interface_tan"),
            (2.0, 2.0, "interface_tan"),
            (f64::NAN, 2.0, "interface_tan"),
            (0.3, 0.1, "exponent"),
            (0.3, 9.0, "exponent"),
            (0.3, f64::INFINITY, "exponent"),
        ] {
            let e = ShearedBearing::new(t, m).unwrap_err().to_string();
            assert!(e.contains(name), "{e}");
        }
        // Coulomb's 2/3 of a repose of 29 deg, Meyerhof's square.
        let p = ShearedBearing::of_repose(29.0).unwrap();
        assert!((p.interface_tan - (29.0f64 * 2.0 / 3.0).to_radians().tan()).abs() < 1e-15);
        assert_eq!(p.exponent, 2.0);
        assert!(ShearedBearing::of_repose(90.0).is_err());
    }
}
