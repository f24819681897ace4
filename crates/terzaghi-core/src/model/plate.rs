//! The leg: a flat rectangular plate rotating about a fixed hip axis above the medium.

use super::{ModelError, PlateField, finite, positive};
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
    /// use terzaghi_core::model::Plate;
    /// let plate = Plate::new(0.25, 0.06, 0.15).unwrap();
    /// assert!((plate.max_depth_m() - 0.10).abs() < 1e-12);
    /// assert!(Plate::new(0.25, -0.06, 0.15).is_err());
    /// ```
    pub fn new(length_m: f64, width_m: f64, hip_height_m: f64) -> Result<Self, ModelError> {
        let bad = |field| {
            move |e| ModelError::BadPlate {
                field,
                problem: Box::new(e),
            }
        };
        positive("plate length (m)", length_m).map_err(bad(PlateField::LengthM))?;
        positive("plate width (m)", width_m).map_err(bad(PlateField::WidthM))?;
        if finite("hip height (m)", hip_height_m).map_err(bad(PlateField::HipHeightM))? < 0.0 {
            return Err(bad(PlateField::HipHeightM)(ModelError::NegativeHipHeight {
                value_m: hip_height_m,
            }));
        }
        Ok(Plate {
            length_m,
            width_m,
            hip_height_m,
        })
    }

    /// This plate with its hip at `hip_height_m`, which the caller has checked to be finite and
    /// not negative: the per-sample path, which need not check the length and width again.
    #[inline]
    pub(crate) fn at_checked_hip_height(&self, hip_height_m: f64) -> Plate {
        debug_assert!(hip_height_m.is_finite() && hip_height_m >= 0.0);
        Plate {
            hip_height_m,
            ..*self
        }
    }

    /// The plate's length from the hip to its tip (m).
    pub fn length_m(&self) -> f64 {
        self.length_m
    }
    /// The plate's width (m).
    pub fn width_m(&self) -> f64 {
        self.width_m
    }
    /// The hip's height above the surface (m).
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
    #[inline]
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
/// use terzaghi_core::model::wrap_beta_rad;
/// assert!((wrap_beta_rad(std::f64::consts::TAU + 1.0) - 1.0).abs() < 1e-12);
/// ```
#[inline]
pub fn wrap_beta_rad(beta_rad: f64) -> f64 {
    if (0.0..TAU).contains(&beta_rad) {
        return beta_rad; // the common case, without a division
    }
    // A leg that keeps turning (a wheel-leg) sends angles of many turns. Taking the turns off
    // with one fused multiply-add gives what `rem_euclid` gives (`beta - k 2pi`, rounded once;
    // exact for a positive angle), without its software fmod, which divides bit by bit and was
    // 4 % of a re-evaluation's main thread. Below 2^52 rad the count of turns `k` is exact or,
    // next to a whole turn where the division rounds, off by one: then the result is outside
    // one turn, and `rem_euclid` below answers.
    if beta_rad.abs() < 4.5e15 {
        let k = (beta_rad / TAU).floor();
        let w = (-k).mul_add(TAU, beta_rad);
        if (0.0..TAU).contains(&w) {
            return w;
        }
    }
    let w = beta_rad.rem_euclid(TAU);
    // rem_euclid can round up to exactly TAU for tiny negative inputs.
    if w >= TAU { 0.0 } else { w }
}

/// `true` while the plate is on its way down (`beta <= pi/2`).
pub(crate) fn is_penetration(beta_rad: f64) -> bool {
    beta_rad <= FRAC_PI_2 + VERTICAL_TOLERANCE_RAD
}

/// An attack angle this close above pi/2 is the vertical leg, still penetrating: a log that
/// writes pi/2 with six decimals (1.570796 or 1.570797) labels each row alike.
pub const VERTICAL_TOLERANCE_RAD: f64 = 1e-6;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    // The values are a log's roundings of pi/2, which this test is about.
    #[allow(clippy::approx_constant)]
    fn pi_over_2_as_a_log_rounds_it_is_one_regime() {
        for beta in [1.570796, 1.570797, FRAC_PI_2] {
            assert!(is_penetration(beta), "{beta}");
        }
        assert!(!is_penetration(1.5708));
    }

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

    /// The fast wrap gives `rem_euclid`'s result, bit for bit, for angles of any number of
    /// turns, at and next to whole turns, tiny, and huge (except the sign of a zero).
    #[test]
    fn wrapping_agrees_with_rem_euclid() {
        let reference = |b: f64| {
            let w = b.rem_euclid(TAU);
            if w >= TAU { 0.0 } else { w }
        };
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(0x9e37_79b9_7f4a_7c15);
        let mut next = || rng.random::<u64>();
        let mut angles = vec![
            -1e-300,
            -1e-17,
            -TAU,
            TAU,
            2.0 * TAU,
            -3.0 * TAU,
            1e15,
            -1e15,
        ];
        for _ in 0..200_000 {
            let turns = (next() % 2_000_001) as f64 - 1_000_000.0;
            let frac = (next() >> 11) as f64 / (1u64 << 53) as f64;
            let b = (turns + frac) * TAU;
            angles.push(b);
            // Whole turns and their neighbours, where the count of turns is most often off.
            let whole = turns * TAU;
            angles.extend([whole, whole.next_up(), whole.next_down()]);
            angles.push(f64::from_bits(next() >> 2) * if next() % 2 == 0 { 1.0 } else { -1.0 });
        }
        for b in angles {
            let (got, want) = (wrap_beta_rad(b), reference(b));
            assert!((0.0..TAU).contains(&got), "{b} -> {got}");
            if want == 0.0 {
                assert_eq!(got, 0.0, "{b}");
            } else {
                assert_eq!(got.to_bits(), want.to_bits(), "{b}: {got} against {want}");
            }
        }
    }
}
