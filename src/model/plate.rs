//! The leg: a flat rectangular plate rotating about a fixed hip axis above the medium.

use super::{ModelError, finite, positive};
use std::f64::consts::{FRAC_PI_2, TAU};

/// A flat plate of length `l` (hip axis to tip) and width `b`, hip axis at height `h` above the
/// free surface. Built only through [`Plate::new`], so its values are always valid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plate {
    length_m: f64,
    width_m: f64,
    hip_height_m: f64,
}

impl Plate {
    /// Checks `l > 0`, `b > 0`, `h >= 0`, all finite. A hip at or above the tip's reach
    /// (`h >= l`) is valid but never submerged: see [`Plate::never_submerged`].
    ///
    /// ```
    /// use terzaghi::model::Plate;
    /// let plate = Plate::new(0.25, 0.06, 0.15).unwrap();
    /// assert!((plate.max_depth_m() - 0.10).abs() < 1e-12);
    /// assert!(Plate::new(0.25, -0.06, 0.15).is_err());
    /// ```
    pub fn new(length_m: f64, width_m: f64, hip_height_m: f64) -> Result<Self, ModelError> {
        positive("plate length (m)", length_m)?;
        positive("plate width (m)", width_m)?;
        if finite("hip height (m)", hip_height_m)? < 0.0 {
            return Err(ModelError::NegativeHipHeight {
                value_m: hip_height_m,
            });
        }
        Ok(Plate {
            length_m,
            width_m,
            hip_height_m,
        })
    }

    pub fn length_m(&self) -> f64 {
        self.length_m
    }
    pub fn width_m(&self) -> f64 {
        self.width_m
    }
    pub fn hip_height_m(&self) -> f64 {
        self.hip_height_m
    }

    /// True when the tip cannot reach the surface (`h >= l`): every prediction is zero.
    pub fn never_submerged(&self) -> bool {
        self.hip_height_m >= self.length_m
    }

    /// Deepest point of the tip, `l - h`, reached at `beta = pi/2` (0 if never submerged).
    pub fn max_depth_m(&self) -> f64 {
        (self.length_m - self.hip_height_m).max(0.0)
    }

    /// Attack angle at which the tip enters the medium, `asin(h/l)`; `None` if never submerged.
    pub fn entry_beta_rad(&self) -> Option<f64> {
        (!self.never_submerged()).then(|| (self.hip_height_m / self.length_m).asin())
    }

    /// Submerged length `l_s = l - h / sin(beta)` for a wrapped `beta` in `[0, 2pi)`, clamped
    /// at 0: the plate is out of the medium when `sin(beta) <= 0` (pointing up) or `l_s <= 0`.
    pub fn submerged_length_m(&self, beta_rad: f64) -> f64 {
        self.submerged_length_at_sin_m(beta_rad.sin())
    }

    /// [`Self::submerged_length_m`] from `sin(beta)`, for a caller that has it already.
    pub(crate) fn submerged_length_at_sin_m(&self, s: f64) -> f64 {
        if s <= 0.0 {
            return 0.0;
        }
        (self.length_m - self.hip_height_m / s).max(0.0)
    }
}

/// Wraps any attack angle to `[0, 2pi)`, the rotation it means: `-0.1` rad is the plate
/// pointing up just before it swings down, `2pi + 1` rad is `1` rad one turn later.
///
/// ```
/// use terzaghi::model::wrap_beta_rad;
/// assert!((wrap_beta_rad(std::f64::consts::TAU + 1.0) - 1.0).abs() < 1e-12);
/// ```
pub fn wrap_beta_rad(beta_rad: f64) -> f64 {
    if (0.0..TAU).contains(&beta_rad) {
        return beta_rad; // the common case, without a division
    }
    let w = beta_rad.rem_euclid(TAU);
    // rem_euclid can round up to exactly TAU for tiny negative inputs.
    if w >= TAU { 0.0 } else { w }
}

/// `true` while the plate is on its way down (`beta <= pi/2`).
pub(crate) fn is_penetration(beta_rad: f64) -> bool {
    beta_rad <= FRAC_PI_2
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_each_bad_dimension_with_its_value() {
        let e = Plate::new(0.0, 0.06, 0.1).unwrap_err().to_string();
        assert!(e.contains("length") && e.contains('0'), "{e}");
        let e = Plate::new(0.25, f64::NAN, 0.1).unwrap_err().to_string();
        assert!(e.contains("width") && e.contains("NaN"), "{e}");
        let e = Plate::new(0.25, 0.06, -0.01).unwrap_err().to_string();
        assert!(e.contains("-0.01"), "{e}");
    }

    #[test]
    fn submerged_length_is_zero_above_surface_and_outside_entry_angles() {
        let p = Plate::new(0.25, 0.06, 0.15).unwrap();
        let entry = p.entry_beta_rad().unwrap();
        assert_eq!(p.submerged_length_m(entry - 1e-3), 0.0);
        assert!(p.submerged_length_m(entry + 1e-3) > 0.0);
        assert_eq!(p.submerged_length_m(4.0), 0.0);
        assert!((p.submerged_length_m(FRAC_PI_2) - 0.10).abs() < 1e-12);
    }

    #[test]
    fn never_submerged_plate_is_valid_and_flagged() {
        let p = Plate::new(0.1, 0.05, 0.1).unwrap();
        assert!(p.never_submerged());
        assert_eq!(p.submerged_length_m(FRAC_PI_2), 0.0);
        assert_eq!(p.entry_beta_rad(), None);
    }

    #[test]
    fn wrapping_keeps_angles_in_one_turn() {
        for b in [-7.0, -0.1, 0.0, 3.0, 6.3, 100.0] {
            let w = wrap_beta_rad(b);
            assert!((0.0..TAU).contains(&w), "{b} -> {w}");
            assert!(((w - b) / TAU - ((w - b) / TAU).round()).abs() < 1e-9);
        }
        assert_eq!(wrap_beta_rad(-1e-300), 0.0);
    }
}
