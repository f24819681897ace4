//! Everything the candidate corrections are built from, per sample: the measured forces, the
//! unit model's forces (`b_k = a = 1`), the submerged geometry, the swept area of the current
//! immersion, speed, acceleration, stroke and fold.

use super::kinematics::Kinematics;
use crate::ident::Sample;
use crate::model::HipMotion;
use crate::model::corrections::{
    TermInputs, moved_unit_model, stronger_unit_model, submerged_geometry,
};
use crate::model::{FittingWidth, Regime, TerzaghiModel};
use std::f64::consts::TAU;

/// One analysed sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    pub t_s: f64,
    /// Attack angle wrapped to `[0, 2pi)`.
    pub beta_rad: f64,
    /// Measured drag and lift (N).
    pub y_n: [f64; 2],
    /// Unit model's drag and lift (`b_e = b`), nominal hip height (N).
    pub unit_n: [f64; 2],
    /// How the unit model's drag and lift change with the medium's internal friction angle
    /// `phi` (N/deg, a one-degree difference): a denser bed is a stronger one in this way.
    pub unit_per_phi_n_deg: [f64; 2],
    pub regime: Regime,
    pub submerged_m: f64,
    /// Distance from the hip to where the submerged part begins (m).
    pub inner_radius_m: f64,
    pub depth_m: f64,
    /// Submerged area of the plate's face (m^2).
    pub area_m2: f64,
    /// `int b r dr` over the submerged part (m^3): first moment about the hip.
    pub moment1_m3: f64,
    /// `int b r^2 dr` over the submerged part (m^4): second moment about the hip.
    pub moment2_m4: f64,
    /// Area swept by the submerged plate since it entered the medium in this immersion (m^2).
    pub swept_m2: f64,
    /// Angular speed along the direction of travel (rad/s, >= 0 when turning forward).
    pub speed_rad_s: f64,
    /// The session's typical speed in the medium (median of |speed| over the points in the
    /// medium; the same for every point): what `rate` measures speed against.
    pub typical_speed_rad_s: f64,
    /// Angular acceleration along the direction of travel (rad/s^2).
    pub accel_rad_s2: f64,
    pub stroke: usize,
    /// Stroke position in the session, 0 (first) to 1 (last).
    pub session_frac: f64,
    pub fold: usize,
    /// The hip's height above the surface where the robot's state placed it (m); `None` at the
    /// nominal model's height.
    pub hip_height_m: Option<f64>,
    /// The attack angle at which the tip reaches the surface at this point's hip height.
    pub entry_beta_rad: f64,
}

impl Point {
    /// What the correction terms read at this point.
    pub fn terms(&self) -> TermInputs {
        TermInputs {
            beta_rad: self.beta_rad,
            regime: self.regime,
            submerged_m: self.submerged_m,
            inner_radius_m: self.inner_radius_m,
            area_m2: self.area_m2,
            moment1_m3: self.moment1_m3,
            swept_m2: self.swept_m2,
            speed_rad_s: self.speed_rad_s,
            typical_speed_rad_s: self.typical_speed_rad_s,
            accel_rad_s2: self.accel_rad_s2,
            session_frac: self.session_frac,
            unit_per_phi_n_deg: self.unit_per_phi_n_deg,
        }
    }

    pub fn in_medium(&self) -> bool {
        self.regime != Regime::OutOfMedium
    }
    pub fn extraction(&self) -> bool {
        self.regime.is_extraction()
    }
}

/// The analysed session: points in time order, with the nominal model.
#[derive(Debug, Clone)]
pub struct Context {
    pub model: TerzaghiModel,
    pub points: Vec<Point>,
    pub folds: usize,
    pub strokes: usize,
}

impl Context {
    /// Each stroke's median angular speed in the medium (rad/s), where it has at least
    /// `min_points` points there.
    pub fn stroke_speeds_rad_s(&self, min_points: usize) -> Vec<Option<f64>> {
        let strokes = self.strokes.max(1);
        let mut speeds: Vec<Vec<f64>> = vec![Vec::new(); strokes];
        for p in self.points.iter().filter(|p| p.in_medium()) {
            speeds[p.stroke.min(strokes - 1)].push(p.speed_rad_s.abs());
        }
        speeds
            .iter()
            .map(|v| (!v.is_empty() && v.len() >= min_points).then(|| median(v)))
            .collect()
    }

    /// The same points in two folds: the strokes from `first_test` on (fold 0) and those before
    /// them (fold 1), so that fold 0 is predicted from the earlier strokes alone.
    pub fn forward_split(&self, first_test: usize) -> Context {
        let mut c = self.clone();
        for p in &mut c.points {
            p.fold = usize::from(p.stroke < first_test);
        }
        c.folds = 2;
        c
    }

    /// The strokes `keep` (in increasing order) as a session of their own: renumbered from 0,
    /// `folds` folds of whole strokes (one stroke: its samples alternately in two folds).
    pub fn sub_session(&self, keep: &[usize], folds: usize) -> Context {
        let mut renumber: Vec<Option<usize>> = vec![None; self.strokes.max(1)];
        for (new, &old) in keep.iter().enumerate() {
            if let Some(r) = renumber.get_mut(old) {
                *r = Some(new);
            }
        }
        let points = self
            .points
            .iter()
            .filter_map(|p| Some((renumber.get(p.stroke).copied()??, p)))
            .enumerate()
            .map(|(i, (stroke, p))| Point {
                stroke,
                fold: if keep.len() == 1 {
                    i % 2
                } else {
                    stroke % folds
                },
                ..*p
            })
            .collect();
        Context {
            model: self.model.clone(),
            points,
            folds,
            strokes: keep.len(),
        }
    }

    /// The typical speed in the medium the rate term's columns are scaled by (rad/s).
    pub fn typical_speed_rad_s(&self) -> f64 {
        self.points.first().map_or(0.0, |p| p.typical_speed_rad_s)
    }

    /// Scales the rate term's columns by `speed_rad_s` (another context's typical speed), so
    /// that a fit here is the same model as there.
    pub fn set_typical_speed(&mut self, speed_rad_s: f64) {
        for p in &mut self.points {
            p.typical_speed_rad_s = speed_rad_s;
        }
    }

    /// Share of the points in the medium (0 to 1; 0 for no points): out of it the baseline
    /// predicts no force, so gaps of two sessions compare per sample in the medium.
    pub fn in_medium_frac(&self) -> f64 {
        let inside = self.points.iter().filter(|p| p.in_medium()).count();
        inside as f64 / self.points.len().max(1) as f64
    }

    /// Builds the context from finite samples (the caller drops non-finite ones), their
    /// kinematics, and the unit model (its fitting width is ignored). Every `stride`-th sample is
    /// kept (1: all). Where `hips` (one per sample, or empty) places a sample's hip, its point is
    /// evaluated at that hip's height and at the joint's angle plus the body's pitch (the
    /// attack angle), as the node predicts a leg the robot's state places.
    pub fn new(
        model: &TerzaghiModel,
        samples: &[Sample],
        hips: &[Option<HipMotion>],
        kin: &Kinematics,
        folds: usize,
        stride: usize,
    ) -> Context {
        let unit = model.with_fitting_width(FittingWidth::CONVENTIONAL);
        let plate = *unit.plate();
        let nominal_entry = plate.entry_beta_rad().unwrap_or(0.0);
        // The unit model in a medium one degree stronger in friction, for `unit_per_phi_n_deg`
        // (none where `phi` is at its limit).
        let stronger = stronger_unit_model(&unit);
        let strokes = kin.strokes();
        let direction = {
            let total = kin.unwrapped_rad.last().unwrap_or(&0.0)
                - kin.unwrapped_rad.first().unwrap_or(&0.0);
            if total < 0.0 { -1.0 } else { 1.0 }
        };
        let mut points = Vec::with_capacity(samples.len() / stride.max(1) + 1);
        let mut swept = 0.0;
        let mut prev_u: Option<f64> = None;
        for (i, s) in samples.iter().enumerate() {
            // The point's own unit model where the robot's state placed its hip.
            let placed = hips.get(i).copied().flatten().and_then(|h| {
                let m = unit.with_hip_height_m(h.height_m).ok()?;
                Some((m, h))
            });
            let (unit, plate, beta) = match &placed {
                Some((m, h)) => (m, *m.plate(), (s.beta_rad + h.pitch_rad).rem_euclid(TAU)),
                None => (&unit, plate, s.beta_rad.rem_euclid(TAU)),
            };
            let u = kin.unwrapped_rad[i];
            let f = unit.evaluate(beta).ok();
            let submerged = f.as_ref().map_or(0.0, |f| f.submerged_m.max(0.0));
            let (r_in, l) = (plate.length_m() - submerged, plate.length_m());
            // Swept area of the submerged part: integral of (l^2 - r_in^2) / 2 d(beta).
            if submerged > 0.0 {
                let d = prev_u.map_or(0.0, |p| ((u - p) * direction).max(0.0));
                swept += 0.5 * (l * l - r_in * r_in) * d;
            } else {
                swept = 0.0;
            }
            prev_u = Some(u);
            if i % stride.max(1) != 0 {
                continue;
            }
            // At a placed hip, the stronger model at that height (its medium's constants kept).
            let stronger_here = match &placed {
                Some((m, _)) => stronger
                    .as_ref()
                    .and_then(|s| s.with_hip_height_m(m.plate().hip_height_m()).ok()),
                None => stronger.clone(),
            };
            let per_phi = match (
                &f,
                stronger_here.as_ref().and_then(|m| m.evaluate(beta).ok()),
            ) {
                (Some(f), Some(g)) if f.regime != Regime::OutOfMedium => {
                    [g.drag_n - f.drag_n, g.lift_n - f.lift_n]
                }
                _ => [0.0, 0.0],
            };
            let (_, area, moment1, moment2) = submerged_geometry(&plate, submerged);
            let stroke = kin.stroke[i];
            points.push(Point {
                t_s: s.t_s.unwrap_or(i as f64),
                beta_rad: beta,
                y_n: [s.drag_n, s.lift_n],
                unit_n: f.as_ref().map_or([0.0, 0.0], |f| [f.drag_n, f.lift_n]),
                unit_per_phi_n_deg: per_phi,
                regime: f.as_ref().map_or(Regime::OutOfMedium, |f| f.regime),
                submerged_m: submerged,
                inner_radius_m: r_in,
                depth_m: f.as_ref().map_or(0.0, |f| f.depth_m),
                area_m2: area,
                moment1_m3: moment1,
                moment2_m4: moment2,
                swept_m2: swept,
                speed_rad_s: kin.speed_rad_s[i] * direction,
                typical_speed_rad_s: 0.0,
                accel_rad_s2: kin.accel_rad_s2[i] * direction,
                stroke,
                session_frac: if strokes > 1 {
                    stroke as f64 / (strokes - 1) as f64
                } else {
                    0.0
                },
                fold: stroke % folds.max(1),
                hip_height_m: placed.as_ref().map(|(m, _)| m.plate().hip_height_m()),
                entry_beta_rad: match &placed {
                    Some((m, _)) => m.plate().entry_beta_rad().unwrap_or(0.0),
                    None => nominal_entry,
                },
            });
        }
        let mut speeds: Vec<f64> = points
            .iter()
            .filter(|p| p.in_medium())
            .map(|p| p.speed_rad_s.abs())
            .collect();
        let typical = if speeds.is_empty() {
            0.0
        } else {
            let mid = speeds.len() / 2;
            *speeds.select_nth_unstable_by(mid, f64::total_cmp).1
        };
        for p in &mut points {
            p.typical_speed_rad_s = typical;
        }
        Context {
            model: unit,
            points,
            folds: folds.max(1),
            strokes,
        }
    }

    /// The unit model's drag and lift for every point with the hip `dh_m` higher above the
    /// surface than configured (the surface that much lower).
    pub fn unit_forces_with_hip_offset(&self, dh_m: f64) -> Vec<[f64; 2]> {
        if dh_m == 0.0 {
            return self.points.iter().map(|p| p.unit_n).collect();
        }
        let m = moved_unit_model(&self.model, dh_m);
        self.points
            .iter()
            .map(|p| {
                let placed = p.hip_height_m.and_then(|h| {
                    let at_hip = self.model.with_hip_height_m(h).ok()?;
                    Some(moved_unit_model(&at_hip, dh_m))
                });
                placed
                    .as_ref()
                    .unwrap_or(&m)
                    .evaluate(p.beta_rad)
                    .map_or([0.0, 0.0], |f| [f.drag_n, f.lift_n])
            })
            .collect()
    }

    /// Points where the leg is well out of the medium (at least `margin_rad` beyond entry and
    /// exit): only sensor noise (and a sensor offset) is measured there.
    pub fn out_of_medium(&self, margin_rad: f64) -> impl Iterator<Item = &Point> {
        self.points.iter().filter(move |p| {
            let (lo, hi) = (
                p.entry_beta_rad - margin_rad,
                std::f64::consts::PI - p.entry_beta_rad + margin_rad,
            );
            !p.in_medium() && (p.beta_rad < lo || p.beta_rad > hi)
        })
    }

    /// Points in the middle half of the leg's swing through the air, farthest from the medium
    /// (the swing runs from `pi - entry` to `2 pi + entry`, its middle at `3 pi / 2`). Only a
    /// sensor offset puts force on the sensor there; near the surface, a leg whose real shape
    /// reaches the grains before the model's plate does (a C-leg), or grains thrown up by a
    /// fast stroke, can put force on it too.
    pub fn far_from_medium(&self) -> impl Iterator<Item = &Point> {
        use std::f64::consts::PI;
        self.points.iter().filter(move |p| {
            let entry = p.entry_beta_rad.clamp(0.0, PI / 2.0);
            !p.in_medium() && (p.beta_rad - 1.5 * PI).abs() <= (PI + 2.0 * entry) / 4.0
        })
    }
}

/// The upper median (0 for none).
pub fn median(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    let mut v = x.to_vec();
    let mid = v.len() / 2;
    *v.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// The lowest of `speeds` (rad/s) where they span a factor two and it is above zero: what
/// separates a speed's effect from the rest.
pub fn lowest_of_twofold_span(speeds: impl IntoIterator<Item = f64>) -> Option<f64> {
    let (lo, hi) = speeds
        .into_iter()
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), w| {
            (lo.min(w), hi.max(w))
        });
    (lo > 0.0 && hi >= 2.0 * lo).then_some(lo)
}
