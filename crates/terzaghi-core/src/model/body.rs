//! Closed bodies that carry a load: a wheel (smooth or with grousers) driven through sand, by
//! resistive force theory over its outline, and the depth at which the sand bears a given load.
//!
//! A body here is a prism (a closed outline in the plane of travel, `x` along the hub's heading,
//! `z` up, both from the hub, extruded over its width) or a closed triangle mesh ([`Body::mesh`]: a
//! foot, any part). Unlike a leg's mid-line (a thin plate whose two faces both meet sand), only
//! a body's *leading* elements bear stress: those whose velocity has a component along their
//! outward normal, as Li, Zhang & Goldman (2013) integrate a closed intruder; and a face that
//! slides along itself with sand beneath it (a flat sole dragged level), which bears on that
//! sand as a plate dragged along itself does. The sand is level ahead of the body; behind the body's lowest
//! point it is the body's own rut, at the depth the body has reached (a rigid body leaves no sand
//! above its lowest point behind it).
//!
//! [`Body::forces`] gives the sand's force and moment on the body at a given hub height and
//! motion; [`steady_sinkage`] finds the sinkage at which the sand bears a given load.

use super::batch::{Isa, LANES};
use super::rft::{RftCoefficients, RftDepthLaw, RftFit, RftSpeedLaw};
use super::sheared::ShearedBearing;
use super::{HipMotion, ModelError, Plate, Prediction, Regime};

mod mesh;
pub use mesh::{Triangle, box_triangles, place};

const N_CM3_TO_N_M3: f64 = 1e6;

/// A wheel's grousers (lugs): straight plates standing out of the rim, evenly spaced.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grousers {
    /// How many, evenly spaced around the rim.
    pub count: usize,
    /// How far each stands out of the rim (m).
    pub height_m: f64,
    /// Each one's thickness along the rim (m).
    pub thickness_m: f64,
}

/// One surface element of a body: its centre from the hub `p` (m, body frame: `x` the heading,
/// `y` the axle to the left, `z` up), its outward unit normal `n`, and its area (m^2).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Element {
    p: [f64; 3],
    n: [f64; 3],
    area: f64,
}

/// A rigid body's surface, cut into elements, in its own frame about its hub: `x` its heading,
/// `y` its axle (to the left), `z` up, as ROS orders a body's axes.
#[derive(Debug, Clone, PartialEq)]
pub struct Body {
    /// The elements of a body moving in its own plane (no velocity along its axle): a prism's
    /// outline, each element across its whole width (its side faces' normals lie along the
    /// axle, so such a motion presses none of them); none for a mesh, which takes `spatial`.
    planar: Vec<Element>,
    /// Per [`LANES`] elements of `planar` in turn: a circle about them all in the `x`-`z` plane,
    /// `[x, z, radius]` (m), whose lowest point above the sand lets the sum skip them.
    planar_blocks: Vec<[f64; 3]>,
    /// The elements of a body moving in any direction: a prism's outline cut across its width
    /// too (a yawed body's rut begins along a slanted line, which cuts an element across), and
    /// its side faces; a mesh's every element.
    spatial: Vec<Element>,
    /// Per [`LANES`] elements of `spatial` in turn, a circle about them as `planar_blocks`.
    spatial_blocks: Vec<[f64; 3]>,
    /// How many of `spatial`'s first elements stand each for [`Body::STRIPS`] strips across
    /// the prism's width (`strip_width_m`): its outline's elements, the sum splitting each only
    /// where the rut's start cuts across it (strips that meet sand of one depth feel one
    /// stress). None for a mesh.
    strips: usize,
    /// The prism's width (m); 0 for a mesh.
    strip_width_m: f64,
    /// The lowest point's depth below the hub (m): the body's reach.
    reach_m: f64,
    /// The highest point's height above the hub (m).
    top_m: f64,
    /// The body's corners (`x, y, z` from the hub: a prism's outline, a mesh's vertices), where
    /// turning the body moves its lowest point.
    points: Vec<[f64; 3]>,
    /// Every point of the outline at one distance from the hub (a smooth wheel): turning it
    /// changes nothing.
    round: bool,
}

/// Below this speed (m/s) an element's speed may square to zero: [`Body::forces`] sums the
/// motion scaled by [`SLOW_SCALE`].
const SLOW_M_S: f64 = 1e-140;

/// 2^600: scales the slowest motion there is (5e-324 m/s) to one whose square does not
/// underflow (4e-286), and the fastest one below [`SLOW_M_S`] to one whose square does not
/// overflow (2e81). A power of two: scaling is exact.
const SLOW_SCALE: f64 = 4.149515568880993e180;

/// How a body's hub moves: its height above the undisturbed surface, its velocity, and the
/// body's rotation rate about its axle.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HubMotion {
    /// The hub's height above the undisturbed surface (m).
    pub height_m: f64,
    /// The hub's velocity in the body's frame (m/s: `x` along the heading, `y` along the axle
    /// to the left, `z` up).
    pub velocity_m_s: [f64; 3],
    /// The rotation rate about the axle (rad/s, + rolling forward: the lowest point moves
    /// backward).
    pub omega_rad_s: f64,
    /// How far the body has turned about its axle from its outline as built (rad, + rolling
    /// forward): where a wheel's grousers are. A round body is the same at every angle.
    pub angle_rad: f64,
}

/// The sand's force and moment on a body, at its hub, in the body's frame.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct BodyForce {
    /// The force (N): `x` along the heading (+ forward, the drawbar pull), `y` along the axle
    /// (+ left), `z` up (the load the sand bears).
    pub force_n: [f64; 3],
    /// The moment about the hub (N m), about the same axes.
    pub moment_nm: [f64; 3],
    /// The lowest point's depth below the undisturbed surface (m).
    pub sinkage_m: f64,
}

impl BodyForce {
    /// The torque a drive applies to keep the rotation against the sand (N m, + along a
    /// forward roll): the sand's moment about the axle, reversed.
    pub fn drive_torque_nm(&self) -> f64 {
        -self.moment_nm[1]
    }
}

/// A body in steady motion under a load, in the terms of a wheel test.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct Steady {
    /// The lowest point's depth below the undisturbed surface at which the sand bears the load
    /// (m).
    pub sinkage_m: f64,
    /// The force along the heading (N, + forward: propulsive).
    pub drawbar_n: f64,
    /// The force along the axle (N, + opposing the hub's sideways motion; + toward the right
    /// where it has none).
    pub side_n: f64,
    /// The drive torque (N m, + along a forward roll).
    pub torque_nm: f64,
    /// The load the sand bears there (N): the load asked, to the bisection's tolerance.
    pub load_n: f64,
}

impl Body {
    /// Elements of a wheel's rim, at the least.
    const MIN_RIM_ELEMENTS: usize = 360;
    /// Rings of each side face.
    const SIDE_RINGS: usize = 8;
    /// Strips across a prism's width, for motion out of its plane.
    const STRIPS: usize = 8;

    /// A wheel of `radius_m` and `width_m`, smooth or with `grousers`, its rim cut into about
    /// `rim_elements` elements (at least 360), its two side faces into rings.
    pub fn wheel(
        radius_m: f64,
        width_m: f64,
        grousers: Option<Grousers>,
        rim_elements: usize,
    ) -> Result<Body, ModelError> {
        positive("wheel radius (m)", radius_m, 10.0)?;
        positive("wheel width (m)", width_m, 10.0)?;
        let n = rim_elements.clamp(Self::MIN_RIM_ELEMENTS, 100_000);
        let mut outline: Vec<(f64, f64)> = Vec::new();
        let at = |r: f64, a: f64| (r * a.sin(), -r * a.cos());
        match grousers {
            None => {
                for i in 0..n {
                    outline.push(at(radius_m, std::f64::consts::TAU * i as f64 / n as f64));
                }
            }
            Some(g) => {
                if g.count == 0 || g.count > 360 {
                    return Err(ModelError::OutOfRange {
                        what: "grouser count",
                        value: g.count as f64,
                        range: "[1, 360]".into(),
                    });
                }
                positive("grouser height (m)", g.height_m, radius_m)?;
                let pitch = std::f64::consts::TAU / g.count as f64;
                let half = g.thickness_m / (2.0 * radius_m);
                if !(g.thickness_m.is_finite() && g.thickness_m > 0.0 && 2.0 * half < pitch) {
                    return Err(ModelError::OutOfRange {
                        what: "grouser thickness (m)",
                        value: g.thickness_m,
                        range: format!("(0, {:.4}) (the rim between grousers)", pitch * radius_m),
                    });
                }
                // Each pitch: the grouser's trailing face out, its tip, its leading face in,
                // then the rim to the next one.
                let rim_points = (n / g.count).max(4);
                let tip = radius_m + g.height_m;
                for k in 0..g.count {
                    let c = pitch * k as f64;
                    outline.push(at(radius_m, c - half));
                    outline.push(at(tip, c - half));
                    outline.push(at(tip, c + half));
                    outline.push(at(radius_m, c + half));
                    for j in 1..rim_points {
                        let a = c + half + (pitch - 2.0 * half) * j as f64 / rim_points as f64;
                        outline.push(at(radius_m, a));
                    }
                }
            }
        }
        // One element per edge of the rim: a rim turning about its hub moves along each chord at
        // the chord's middle, and along no sub-element of it (whose velocity would have a
        // spurious part along the normal, which a spinning wheel's nearly tangential motion
        // feels).
        Body::prism(
            &outline,
            width_m,
            std::f64::consts::TAU * radius_m / n as f64,
        )
    }

    /// A prism: the closed polygon `outline` (points `(x, z)` from the hub, counter-clockwise
    /// seen with `x` right and `z` up, every point seen from the hub without crossing an edge:
    /// a wheel, with or without grousers) extruded over `width_m` about the hub, its edges cut
    /// into elements no longer than `element_m` (m) and its two side faces into rings.
    pub fn prism(outline: &[(f64, f64)], width_m: f64, element_m: f64) -> Result<Body, ModelError> {
        positive("body element length (m)", element_m, 10.0)?;
        positive("body width (m)", width_m, 10.0)?;
        if outline.len() < 3 {
            return Err(ModelError::BadBody {
                problem: format!("an outline needs 3 points or more, not {}", outline.len()),
            });
        }
        let mut elements = Vec::with_capacity(outline.len());
        let mut fans = Vec::with_capacity(outline.len());
        let (mut reach, mut top) = (f64::INFINITY, f64::NEG_INFINITY);
        let half_width = width_m / 2.0;
        for (i, &(x, z)) in outline.iter().enumerate() {
            for (what, v) in [("x", x), ("z", z)] {
                if !v.is_finite() {
                    return Err(ModelError::BadBody {
                        problem: format!("outline point {i}'s {what} is {v}"),
                    });
                }
            }
        }
        for (i, &(x0, z0)) in outline.iter().enumerate() {
            let (x1, z1) = outline[(i + 1) % outline.len()];
            let (dx, dz) = (x1 - x0, z1 - z0);
            let len = dx.hypot(dz);
            // Twice the area the edge spans about the hub: > 0 where the hub sees the edge
            // counter-clockwise.
            let twice_fan = x0 * z1 - x1 * z0;
            // A radial edge (a grouser's face) spans none; rounding may make it a hair below.
            let radius = x0.hypot(z0).max(x1.hypot(z1));
            if len <= 0.0 || !len.is_finite() || twice_fan < -1e-9 * len * radius {
                return Err(ModelError::BadBody {
                    problem: format!(
                        "outline edge {i} from ({x0}, {z0}) to ({x1}, {z1}) {}",
                        if len > 0.0 {
                            "turns clockwise about the hub (an outline runs counter-clockwise, x right and z up, and the hub sees all of it)"
                        } else {
                            "has no length"
                        }
                    ),
                });
            }
            // Counter-clockwise: the outside is on the right of the direction of travel.
            let (nx, nz) = (dz / len, -dx / len);
            // At most 10^5 elements along any edge.
            let per_edge = (len / element_m).ceil().clamp(1.0, 1e5) as usize;
            for j in 0..per_edge {
                let f = (j as f64 + 0.5) / per_edge as f64;
                elements.push(Element {
                    p: [x0 + f * dx, 0.0, z0 + f * dz],
                    n: [nx, 0.0, nz],
                    area: width_m * len / per_edge as f64,
                });
            }
            // The side faces: the fan triangle (hub, p0, p1), cut below into rings.
            fans.push((x0, z0, x1, z1, twice_fan / 2.0));
            reach = reach.min(z0);
            top = top.max(z0);
        }
        let r0 = outline[0].0.hypot(outline[0].1);
        let round = outline
            .iter()
            .all(|&(x, z)| (x.hypot(z) - r0).abs() <= 1e-9 * r0);
        // The side faces ring by ring (each ring's elements side by side, so that a block of
        // them lies close together, and one above the sand is skipped whole): each fan
        // triangle in rings of the radius fraction.
        let mut spatial = elements.clone();
        for k in 0..Self::SIDE_RINGS {
            let (t0, t1) = (
                k as f64 / Self::SIDE_RINGS as f64,
                (k + 1) as f64 / Self::SIDE_RINGS as f64,
            );
            // The centroid of the trapezoid between t0 and t1 of the triangle.
            let tc = 2.0 / 3.0 * (t1.powi(3) - t0.powi(3)) / (t1 * t1 - t0 * t0);
            for &(x0, z0, x1, z1, fan) in fans.iter().filter(|f| f.4 > 0.0) {
                let (cx, cz) = (tc * (x0 + x1) / 2.0, tc * (z0 + z1) / 2.0);
                let area = fan * (t1 * t1 - t0 * t0);
                for side in [1.0, -1.0] {
                    spatial.push(Element {
                        p: [cx, side * half_width, cz],
                        n: [0.0, side, 0.0],
                        area,
                    });
                }
            }
        }
        Ok(Body {
            planar_blocks: circles_about(&elements),
            spatial_blocks: circles_about(&spatial),
            strips: elements.len(),
            strip_width_m: width_m,
            planar: elements,
            spatial,
            reach_m: -reach,
            top_m: top,
            points: outline.iter().map(|&(x, z)| [x, 0.0, z]).collect(),
            round,
        })
    }

    /// The lowest point's depth below the hub (m).
    pub fn reach_m(&self) -> f64 {
        self.reach_m
    }

    /// The lowest point's depth below the hub with the body turned by `angle_rad` (+ rolling
    /// forward) from its outline as built (m).
    pub fn reach_at_m(&self, angle_rad: f64) -> f64 {
        if self.round || angle_rad == 0.0 || !angle_rad.is_finite() {
            return self.reach_m;
        }
        let (s, c) = angle_rad.sin_cos();
        -self
            .points
            .iter()
            .map(|&[x, _, z]| -x * s + z * c)
            .fold(f64::INFINITY, f64::min)
    }

    /// The lowest point's horizontal place from the hub (`x`, `y`, m) with the body turned by
    /// `angle_rad`: where its rut begins. A round body's is under its hub.
    /// `reach_m` is [`Body::reach_at_m`] at that angle (the lowest point's depth, found once).
    fn lowest_xy_at(&self, angle_rad: f64, reach_m: f64) -> (f64, f64) {
        if self.round {
            return (0.0, 0.0);
        }
        let (s, c) = if angle_rad.is_finite() {
            angle_rad.sin_cos()
        } else {
            (0.0, 1.0)
        };
        // The middle of the lowest points (a box's bottom face, a wheel's bottom line).
        let low = -reach_m;
        let (mut sx, mut sy, mut n) = (0.0, 0.0, 0.0);
        for &[x, y, z] in &self.points {
            if -x * s + z * c <= low + 1e-9 {
                sx += x * c + z * s;
                sy += y;
                n += 1.0;
            }
        }
        (sx / n, sy / n)
    }

    /// The body's extent across its heading, along `y` (m), as built.
    pub fn width_m(&self) -> f64 {
        let (lo, hi) = self
            .points
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p[1]), hi.max(p[1]))
            });
        if hi > lo {
            hi - lo
        } else {
            // A prism's outline lies in its mid-plane; its width is its elements'.
            self.spatial
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), e| {
                    (lo.min(e.p[1]), hi.max(e.p[1]))
                })
                .1
                .max(0.0)
                * 2.0
        }
    }

    /// The body's height: from its lowest point to its highest (m).
    pub fn height_m(&self) -> f64 {
        self.reach_m + self.top_m
    }

    /// How many surface elements the body has.
    pub fn element_count(&self) -> usize {
        self.spatial.len()
    }

    /// The sand's force and moment on the body with its hub moving as `hub`: RFT's stress of
    /// `coefficients` through `depth_law` (and `speed_law`'s dynamic part, where given) on every
    /// leading element below the sand's surface.
    ///
    /// In three dimensions each element's stress is the medium's two-dimensional law in the
    /// vertical plane of its normal (Treers et al., RA-L 2021): the part of its velocity in that
    /// plane meets the element at its attack and intrusion angles there; the part across it
    /// (along the element's surface, horizontal) shears it as a horizontal plate dragged along
    /// itself is sheared. Each part is weighted by its share of the element's speed. An element
    /// whose normal and velocity lie in the `x`-`z` plane (a planar body) feels the planar law
    /// alone.
    pub fn forces(
        &self,
        coefficients: &RftCoefficients,
        depth_law: Option<&RftDepthLaw>,
        speed_law: Option<&RftSpeedLaw>,
        hub: &HubMotion,
    ) -> BodyForce {
        self.forces_of(
            &Stress {
                coefficients,
                depth_law,
                speed_law,
                sheared: None,
            },
            hub,
        )
    }

    /// [`Body::forces`] in the medium's whole stress: RFT's, and where the medium has one, the
    /// bearing of the sand the body shears ([`ShearedBearing`]) on the vertical stress.
    pub fn forces_of(&self, stress: &Stress, hub: &HubMotion) -> BodyForce {
        let (mut at, sinkage) = self.place(hub);
        // A motion so slow that an element's speed would square to zero (below 1e-154 m/s) is
        // summed at a scale where it does not: the stress takes its direction alone, the speed
        // law the real speed (scaled back).
        let fastest = hub
            .velocity_m_s
            .into_iter()
            .chain([hub.omega_rad_s])
            .fold(0.0f64, |a, v| a.max(v.abs()));
        let hub = &if fastest > 0.0 && fastest < SLOW_M_S {
            at.per_scale = 1.0 / SLOW_SCALE;
            HubMotion {
                velocity_m_s: hub.velocity_m_s.map(|v| v * SLOW_SCALE),
                omega_rad_s: hub.omega_rad_s * SLOW_SCALE,
                ..*hub
            }
        } else {
            *hub
        };
        let hy = hub.velocity_m_s[1];
        let (f, m, vertical_m) = if hy == 0.0 && !self.planar.is_empty() {
            self.planar_sum(stress, hub, &at)
        } else {
            Self::general_sum(self.spatial_surface(), stress, hub, &at)
        };
        let (f, m) = match stress.sheared {
            Some(sheared) => sheared.apply(f, m, vertical_m),
            None => (f, m),
        };
        BodyForce {
            force_n: f,
            moment_nm: m,
            sinkage_m: sinkage,
        }
    }

    /// Where the body is for its elements at the hub's place and motion, and its sinkage (m).
    fn place(&self, hub: &HubMotion) -> (Place, f64) {
        // Turned by the angle (a round body is the same at every angle): a point (x, z) of the
        // outline as built is at (x c + z s, -x s + z c), as rolling forward carries it.
        let turned = !self.round && hub.angle_rad != 0.0 && hub.angle_rad.is_finite();
        let angle = if turned { hub.angle_rad } else { 0.0 };
        let (sin_a, cos_a) = if turned { angle.sin_cos() } else { (0.0, 1.0) };
        let reach = self.reach_at_m(angle);
        let sinkage = reach - hub.height_m;
        // Behind the body along its travel the sand is its rut, from its lowest point on.
        let [hx, hy, _] = hub.velocity_m_s;
        let travel = hx.hypot(hy);
        let place = Place {
            turned,
            sin_a,
            cos_a,
            lowest_xy: self.lowest_xy_at(angle, reach),
            rut: -sinkage.max(0.0),
            height_m: hub.height_m,
            travel: if travel > 0.0 {
                (hx / travel, hy / travel)
            } else {
                (0.0, 0.0)
            },
            moving: travel > 0.0,
            per_scale: 1.0,
        };
        (place, sinkage)
    }

    /// The most the sand bears of the body with its hub `height_m` above the surface, turned by
    /// `angle_rad`: its vertical force pressed straight down there (N, never below 0), with no
    /// speed law and no shear. A body held still, lifted or creeping is borne so.
    pub fn pressed_lift_n(&self, stress: &Stress, height_m: f64, angle_rad: f64) -> f64 {
        let pressed = self.forces_of(
            &Stress {
                speed_law: None,
                sheared: None,
                ..*stress
            },
            &HubMotion {
                height_m,
                velocity_m_s: [0.0, 0.0, -1.0],
                omega_rad_s: 0.0,
                angle_rad,
            },
        );
        pressed.force_n[2].max(0.0)
    }

    /// The elements a body moving in any direction sums ([`Body::general_sum`]).
    fn spatial_surface(&self) -> Surface<'_> {
        Surface {
            elements: &self.spatial,
            blocks: &self.spatial_blocks,
            strips: self.strips,
            strip_width_m: self.strip_width_m,
        }
    }

    /// [`Body::forces`]'s sum over a surface's elements, in any motion: those of the blocks
    /// whose circle stays above the sand skipped (a rut only lies lower than the surface; a
    /// height that is no number skips none); an element that stands for strips across a
    /// prism's width summed as one element per depth its strips meet (the sand ahead, the rut
    /// behind), at their middle: strips of one depth feel one stress, and their moments about
    /// the hub add up to that of their middle.
    fn general_sum(
        surface: Surface<'_>,
        stress: &Stress,
        hub: &HubMotion,
        at: &Place,
    ) -> ([f64; 3], [f64; 3], [f64; 2]) {
        let Stress {
            coefficients,
            depth_law,
            speed_law,
            ..
        } = *stress;
        let [hx, hy, hz] = hub.velocity_m_s;
        let w = hub.omega_rad_s;
        let ((lx, ly), (tx, ty)) = (at.lowest_xy, at.travel);
        // A horizontal plate dragged along itself: the shear across an element's plane.
        let shear = coefficients.alpha_along((1.0, 0.0), (1.0, 0.0)).0;
        let (mut f, mut m, mut vertical_m) = ([0.0; 3], [0.0; 3], [0.0; 2]);
        // The strips' places across the width, from the middle (m).
        let strip_y: [f64; Body::STRIPS] = std::array::from_fn(|j| {
            ((j as f64 + 0.5) / Body::STRIPS as f64 - 0.5) * surface.strip_width_m
        });
        let in_reach = surface
            .elements
            .chunks(LANES)
            .zip(surface.blocks)
            .enumerate()
            .filter(move |&(_, (_, &[x, z, r]))| {
                let z = if at.turned { at.turn(x, z).1 } else { z };
                let above = at.height_m + z - r >= 0.0;
                !above
            })
            .flat_map(|(b, (block, _))| {
                block
                    .iter()
                    .enumerate()
                    .map(move |(j, e)| (b * LANES + j, e))
            });
        let keep = |&(i, e): &(usize, &Element), lanes: &mut StressLanes<'_, [f64; 11], _>| {
            let ([px, py, pz], [nx, ny, nz]) = if at.turned {
                let (px, pz) = at.turn(e.p[0], e.p[2]);
                let (nx, nz) = at.turn(e.n[0], e.n[2]);
                ([px, e.p[1], pz], [nx, e.n[1], nz])
            } else {
                (e.p, e.n)
            };
            // The sand ahead is at the surface, the rut behind at `at.rut`: an element is in
            // neither where its lowest depth (the sand's) is not below it.
            if at.height_m + pz >= 0.0 {
                return;
            }
            // The hub's velocity plus the rotation's about y: (w z, 0, -w x).
            let v = [hx + w * pz, hy, hz - w * px];
            // Only a leading element pushes on sand; one sliding along itself with sand beneath
            // it (a flat sole dragged level) bears on that sand as a plate dragged along itself.
            let vn = v[0] * nx + v[1] * ny + v[2] * nz;
            if vn <= 0.0 && nz >= 0.0 {
                return;
            }
            let speed = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            if vn <= 0.0 && !(speed > 0.0 && -vn <= 1e-9 * speed) {
                return;
            }
            let mut push = |py: f64, behind: bool, area: f64| {
                let depth = if behind { at.rut } else { 0.0 } - (at.height_m + pz);
                // A height that is no number gives a depth that is none, and forces that are
                // none, as it should.
                if depth > 0.0 || depth.is_nan() {
                    lanes.push(
                        depth,
                        [px, py, pz, nx, ny, nz, v[0], v[1], v[2], speed, area],
                    );
                }
            };
            let behind_at = |py: f64| at.moving && (px - lx) * tx + (py - ly) * ty < 0.0;
            if i >= surface.strips {
                push(py, behind_at(py), e.area);
                return;
            }
            // The strips behind the rut's start and those ahead: each set at its middle.
            let (mut n_behind, mut y_behind, mut y_ahead) = (0usize, 0.0, 0.0);
            for &y in &strip_y {
                if behind_at(py + y) {
                    n_behind += 1;
                    y_behind += y;
                } else {
                    y_ahead += y;
                }
            }
            let strip_area = e.area / Body::STRIPS as f64;
            let n_ahead = Body::STRIPS - n_behind;
            match n_behind {
                0 => push(py, false, e.area),
                Body::STRIPS => push(py, true, e.area),
                _ => {
                    push(
                        py + y_ahead / n_ahead as f64,
                        false,
                        strip_area * n_ahead as f64,
                    );
                    push(
                        py + y_behind / n_behind as f64,
                        true,
                        strip_area * n_behind as f64,
                    );
                }
            }
        };
        each_pushed(in_reach, depth_law, keep, |state, stressed| {
            let [px, py, pz, nx, ny, nz, v0, v1, v2, speed, area] = state;
            let v = [v0, v1, v2];
            // The vertical plane of the normal: e2 its horizontal part (the horizontal velocity
            // for a horizontal element), e1 = e2 x z across it.
            let nh = (nx * nx + ny * ny).sqrt();
            let (e2x, e2y) = if nh > 1e-12 {
                (nx / nh, ny / nh)
            } else {
                let vh = (v[0] * v[0] + v[1] * v[1]).sqrt();
                if vh > 0.0 {
                    (v[0] / vh, v[1] / vh)
                } else {
                    (1.0, 0.0)
                }
            };
            let (e1x, e1y) = (e2y, -e2x);
            let v1 = v[0] * e1x + v[1] * e1y;
            let v2 = (v[0] * e2x + v[1] * e2y, v[2]);
            let extra = speed_law.map_or(0.0, |law| {
                law.extra_depth_of_velocity_m(
                    (v[0] * v[0] + v[1] * v[1]).sqrt() * at.per_scale,
                    v[2] * at.per_scale,
                )
            });
            let k = N_CM3_TO_N_M3 * (stressed + extra) * area / speed;
            let (mut fx, mut fy, mut fz) = (0.0, 0.0, 0.0);
            let in_plane = (v2.0 * v2.0 + v2.1 * v2.1).sqrt();
            if in_plane > 0.0 {
                // The element in its plane: normal (n.e2, nz), tangent along it.
                let n2 = (nx * e2x + ny * e2y, nz);
                let mirror = if v2.0 < 0.0 { -1.0 } else { 1.0 };
                let (ax, az) =
                    coefficients.alpha_along((mirror * -n2.1, n2.0), (mirror * v2.0, v2.1));
                let (f2, fv) = (-mirror * ax * k * in_plane, az * k * in_plane);
                fx += f2 * e2x;
                fy += f2 * e2y;
                fz += fv;
            }
            if v1 != 0.0 {
                let f1 = -v1.signum() * shear * k * v1.abs();
                fx += f1 * e1x;
                fy += f1 * e1y;
            }
            f[0] += fx;
            f[1] += fy;
            f[2] += fz;
            m[0] += py * fz - pz * fy;
            m[1] += pz * fx - px * fz;
            m[2] += px * fy - py * fx;
            vertical_m[0] += py * fz;
            vertical_m[1] -= px * fz;
        });
        (f, m, vertical_m)
    }

    /// [`Body::general_sum`] over a prism's planar elements (normals in the `x`-`z` plane, at
    /// `y` = 0) for a motion in that plane: the same law, with what the plane makes constant
    /// taken out (no velocity across an element, the element's speed its in-plane speed, which
    /// cancels from the stress), so that an element in the sand costs one square root, one
    /// division and its depth law, where the general sum takes four and eight. It agrees with
    /// the general sum to rounding (a test checks it).
    fn planar_sum(
        &self,
        stress: &Stress,
        hub: &HubMotion,
        at: &Place,
    ) -> ([f64; 3], [f64; 3], [f64; 2]) {
        // Compiled for the processor's vector instructions where it has them: the same
        // operations (none fused), the same values.
        #[cfg(target_arch = "x86_64")]
        match Isa::detected() {
            // SAFETY: the processor has the instructions it was detected to have.
            Isa::Avx512 => return unsafe { self.planar_sum_avx512(stress, hub, at) },
            // SAFETY: as above.
            Isa::Avx2 => return unsafe { self.planar_sum_avx2(stress, hub, at) },
            Isa::Baseline => {}
        }
        self.planar_sum_any(stress, hub, at)
    }

    /// [`Body::planar_sum`] compiled for AVX-512F.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,popcnt")]
    fn planar_sum_avx512(
        &self,
        stress: &Stress,
        hub: &HubMotion,
        at: &Place,
    ) -> ([f64; 3], [f64; 3], [f64; 2]) {
        self.planar_sum_any(stress, hub, at)
    }

    /// [`Body::planar_sum`] compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt")]
    fn planar_sum_avx2(
        &self,
        stress: &Stress,
        hub: &HubMotion,
        at: &Place,
    ) -> ([f64; 3], [f64; 3], [f64; 2]) {
        self.planar_sum_any(stress, hub, at)
    }

    /// The planar elements that may be below the sand at `at`: all but those of the blocks whose
    /// circle stays above the surface (a rut only lies lower than the surface's level; a height
    /// that is no number skips none, and its forces come out no number, as the sum's).
    #[inline(always)]
    fn planar_in_reach<'a>(&'a self, at: &'a Place) -> impl Iterator<Item = &'a Element> + 'a {
        self.planar
            .chunks(LANES)
            .zip(&self.planar_blocks)
            .filter(move |&(_, &[x, z, r])| {
                let z = if at.turned { at.turn(x, z).1 } else { z };
                let above = at.height_m + z - r >= 0.0;
                !above
            })
            .flat_map(|(block, _)| block)
    }

    /// [`Body::planar_sum`] for any processor.
    #[inline(always)]
    fn planar_sum_any(
        &self,
        stress: &Stress,
        hub: &HubMotion,
        at: &Place,
    ) -> ([f64; 3], [f64; 3], [f64; 2]) {
        let Stress {
            coefficients,
            depth_law,
            speed_law,
            ..
        } = *stress;
        let [hx, _, hz] = hub.velocity_m_s;
        let w = hub.omega_rad_s;
        let (lx, tx) = (at.lowest_xy.0, at.travel.0);
        let (mut fx_sum, mut fz_sum) = (0.0, 0.0);
        let (mut my, mut vertical_my) = (0.0, 0.0);
        let keep = |e: &Element| {
            let ((px, pz), (nx, nz)) = if at.turned {
                (at.turn(e.p[0], e.p[2]), at.turn(e.n[0], e.n[2]))
            } else {
                ((e.p[0], e.p[2]), (e.n[0], e.n[2]))
            };
            let behind = at.moving && (px - lx) * tx < 0.0;
            let depth = if behind { at.rut } else { 0.0 } - (at.height_m + pz);
            if depth <= 0.0 {
                return None;
            }
            let (vx, vz) = (hx + w * pz, hz - w * px);
            let vn = vx * nx + vz * nz;
            if vn <= 0.0 && nz >= 0.0 {
                return None;
            }
            let speed = (vx * vx + vz * vz).sqrt();
            if vn <= 0.0 && !(speed > 0.0 && -vn <= 1e-9 * speed) {
                return None;
            }
            Some((depth, [px, pz, nx, nz, vx, vz, speed, e.area]))
        };
        if let (RftCoefficients::Fit(fit), None) = (coefficients, speed_law) {
            // A fitted law without a speed law (a medium file's): sixteen elements' stresses
            // at once, each lane the operations of the loop below.
            let mut keep = keep;
            let mut elements = self.planar_in_reach(at);
            let mut depth = [0.01; LANES];
            let mut states = [[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0]; LANES];
            loop {
                let n = next_lanes(&mut elements, &mut keep, &mut depth, &mut states);
                if n == 0 {
                    break;
                }
                let stressed = match depth_law {
                    Some(law) => law.effective_depths_m(&depth),
                    None => depth,
                };
                let (fx, fz) = fit_lanes(fit, &states, &stressed);
                for l in 0..n {
                    let [px, pz, ..] = states[l];
                    fx_sum += fx[l];
                    fz_sum += fz[l];
                    my += pz * fx[l] - px * fz[l];
                    vertical_my -= px * fz[l];
                }
                if n < LANES {
                    break;
                }
            }
            return ([fx_sum, 0.0, fz_sum], [0.0, my, 0.0], [0.0, vertical_my]);
        }
        each_stressed(
            self.planar_in_reach(at),
            depth_law,
            keep,
            |state, stressed| {
                let [px, pz, nx, nz, vx, vz, speed, area] = state;
                // The normal's horizontal direction (the velocity's for a horizontal element).
                let e2x = if nx.abs() > 1e-12 {
                    nx.signum()
                } else if vx != 0.0 {
                    vx.signum()
                } else {
                    1.0
                };
                let extra = speed_law.map_or(0.0, |law| {
                    law.extra_depth_of_velocity_m(vx.abs() * at.per_scale, vz * at.per_scale)
                });
                // The stress times the area; the in-plane speed cancels from it.
                let k = N_CM3_TO_N_M3 * (stressed + extra) * area;
                let v2x = vx * e2x;
                let mirror = if v2x < 0.0 { -1.0 } else { 1.0 };
                // The element's tangent and its unit motion in RFT's frame (moving toward +x).
                let per_speed = 1.0 / speed;
                let (ax, az) = coefficients.alpha_unit(
                    (mirror * -nz, nx * e2x),
                    (mirror * v2x * per_speed, vz * per_speed),
                );
                let (fx, fz) = (-mirror * ax * k * e2x, az * k);
                fx_sum += fx;
                fz_sum += fz;
                my += pz * fx - px * fz;
                vertical_my -= px * fz;
            },
        );
        ([fx_sum, 0.0, fz_sum], [0.0, my, 0.0], [0.0, vertical_my])
    }
}

/// The elements of a sum: `elements`, their blocks' circles, and how many of the first stand
/// for a prism's strips (`Body`'s `strips`).
#[derive(Clone, Copy)]
struct Surface<'a> {
    elements: &'a [Element],
    blocks: &'a [[f64; 3]],
    strips: usize,
    strip_width_m: f64,
}

/// Elements in the sand, each with its depth and what else a sum computed, handed to `finish`
/// with their depth through `law` ([`each_pushed`]).
struct StressLanes<'l, S, F> {
    law: Option<&'l RftDepthLaw>,
    depth: [f64; LANES],
    states: [S; LANES],
    n: usize,
    finish: F,
}

impl<S: Copy + Default, F: FnMut(S, f64)> StressLanes<'_, S, F> {
    /// One element `depth` (m) below the sand.
    #[inline(always)]
    fn push(&mut self, depth: f64, state: S) {
        if self.law.is_none() {
            (self.finish)(state, depth);
            return;
        }
        (self.depth[self.n], self.states[self.n]) = (depth, state);
        self.n += 1;
        if self.n == LANES {
            self.flush();
        }
    }

    /// The elements pushed and not yet finished, finished.
    #[inline(always)]
    fn flush(&mut self) {
        if let Some(law) = self.law
            && self.n > 0
        {
            // Lanes past `n` keep a depth they held (1 cm at first): any number the power takes.
            let stressed = law.effective_depths_m(&self.depth);
            for (state, stressed) in self.states.iter().zip(stressed).take(self.n) {
                (self.finish)(*state, stressed);
            }
            self.n = 0;
        }
    }
}

/// `finish(state, stressed depth)` for every element `keep` pushes (its depth below the sand
/// and what else it computed; none, one or more per item), in their order: the depth through
/// `law`, whose power is taken sixteen elements at a time in the lanes
/// ([`RftDepthLaw::effective_depths_m`]; the power, one per element in the sand, was half of a
/// wheel's time), or as it is.
#[inline(always)]
fn each_pushed<I, S: Copy + Default, F: FnMut(S, f64)>(
    items: impl IntoIterator<Item = I>,
    law: Option<&RftDepthLaw>,
    mut keep: impl FnMut(&I, &mut StressLanes<'_, S, F>),
    finish: F,
) {
    let mut lanes = StressLanes {
        law,
        depth: [0.01; LANES],
        states: [S::default(); LANES],
        n: 0,
        finish,
    };
    for item in items {
        keep(&item, &mut lanes);
    }
    lanes.flush();
}

/// [`each_pushed`] where `keep` keeps an element or not.
#[inline(always)]
fn each_stressed<'a, E: 'a, S: Copy + Default>(
    elements: impl IntoIterator<Item = &'a E>,
    law: Option<&RftDepthLaw>,
    mut keep: impl FnMut(&E) -> Option<(f64, S)>,
    finish: impl FnMut(S, f64),
) {
    each_pushed(
        elements,
        law,
        |e, lanes| {
            if let Some((depth, state)) = keep(e) {
                lanes.push(depth, state);
            }
        },
        finish,
    );
}

/// Per [`LANES`] elements in turn, a circle about their points in the `x`-`z` plane: `[x, z,
/// radius]` (m), the radius a nanometre more than the farthest point's distance (rounding of
/// a turned point must not leave it).
fn circles_about(elements: &[Element]) -> Vec<[f64; 3]> {
    elements
        .chunks(LANES)
        .map(|block| {
            let (lo, hi) = block.iter().fold(
                ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
                |(lo, hi), e| {
                    (
                        [lo[0].min(e.p[0]), lo[1].min(e.p[2])],
                        [hi[0].max(e.p[0]), hi[1].max(e.p[2])],
                    )
                },
            );
            let (x, z) = (0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]));
            let r = block
                .iter()
                .fold(0.0f64, |r, e| r.max((e.p[0] - x).hypot(e.p[2] - z)));
            [x, z, r + 1e-9]
        })
        .collect()
}

/// The next elements that `keep` keeps, up to [`LANES`] of them, into `depth` and `states`
/// (their depth below the sand and what else it computed): how many. A lane past them keeps
/// what it held, a state the lanes may compute with and must not add.
#[inline(always)]
fn next_lanes<'a, E: 'a>(
    elements: &mut impl Iterator<Item = &'a E>,
    keep: &mut impl FnMut(&E) -> Option<(f64, [f64; 8])>,
    depth: &mut [f64; LANES],
    states: &mut [[f64; 8]; LANES],
) -> usize {
    let mut n = 0;
    for e in elements.by_ref() {
        if let Some((d, state)) = keep(e) {
            (depth[n], states[n]) = (d, state);
            n += 1;
            if n == LANES {
                break;
            }
        }
    }
    n
}

/// The drag and lift of [`LANES`] planar elements (states `[px, pz, nx, nz, vx, vz, speed,
/// area]` as [`Body::planar_sum`] keeps them, at their stressed depths) under the fitted law
/// `fit`: each lane the operations of the planar sum's loop for one element, in lanes.
#[inline(always)]
fn fit_lanes(
    fit: &RftFit,
    states: &[[f64; 8]; LANES],
    stressed: &[f64; LANES],
) -> ([f64; LANES], [f64; LANES]) {
    let (mut fx, mut fz) = ([0.0; LANES], [0.0; LANES]);
    for l in 0..LANES {
        let [_, _, nx, nz, vx, vz, speed, area] = states[l];
        let e2x = if nx.abs() > 1e-12 {
            nx.signum()
        } else if vx != 0.0 {
            vx.signum()
        } else {
            1.0
        };
        // As the loop's `stressed + extra`, without a speed law.
        let k = N_CM3_TO_N_M3 * (stressed[l] + 0.0) * area;
        let v2x = vx * e2x;
        let mirror = if v2x < 0.0 { -1.0 } else { 1.0 };
        let per_speed = 1.0 / speed;
        // `RftCoefficients::alpha_unit` of the loop, for a fitted law.
        let (tx, tz) = (mirror * -nz, nx * e2x);
        let (ax, az) = fit.alpha_trig(
            (tx * tx - tz * tz, 2.0 * tx * tz),
            (mirror * v2x * per_speed, -(vz * per_speed)),
        );
        (fx[l], fz[l]) = (-mirror * ax * k * e2x, az * k);
    }
    (fx, fz)
}

/// Where a body is, for its elements: turned by an angle, its rut behind its lowest point.
struct Place {
    turned: bool,
    sin_a: f64,
    cos_a: f64,
    /// The lowest point's horizontal place from the hub (m).
    lowest_xy: (f64, f64),
    /// The rut's height relative to the undisturbed surface (m, <= 0).
    rut: f64,
    height_m: f64,
    /// The travel's horizontal direction (a unit vector, or zero).
    travel: (f64, f64),
    /// Whether the hub travels at all (the rut is behind it).
    moving: bool,
    /// Multiplies the sums' velocities back to m/s for the speed law: 1, or 2^-600 where the
    /// motion was scaled up ([`Body::forces`]).
    per_scale: f64,
}

impl Place {
    /// A point (x, z) of the outline as built, turned: (x c + z s, -x s + z c), as rolling
    /// forward carries it.
    #[inline]
    fn turn(&self, x: f64, z: f64) -> (f64, f64) {
        (
            x * self.cos_a + z * self.sin_a,
            -x * self.sin_a + z * self.cos_a,
        )
    }
}

/// Why no depth bears a load.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SteadyError {
    /// A load, speed or rate that is no number, or a load that is not positive.
    #[error("{what} is {value}: {why}")]
    BadInput {
        /// The input.
        what: &'static str,
        /// Its value.
        value: f64,
        /// What it must be.
        why: &'static str,
    },
    /// The sand does not bear the load before the body is buried to its top.
    #[error(
        "the sand bears at most {max_load_n:.1} N of this body, buried to its top ({height_m:.4} m): a load of {load_n} N sinks it"
    )]
    TooHeavy {
        /// The load (N).
        load_n: f64,
        /// The most the sand bears within the body's height (N).
        max_load_n: f64,
        /// The body's height (m).
        height_m: f64,
    },
}

/// How a body is driven in a wheel test: its hub's speed over the ground, its rotation rate,
/// and its heading's angle from its travel.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Drive {
    /// The hub's speed over the ground along its travel (m/s).
    pub speed_m_s: f64,
    /// The rotation rate about the axle (rad/s, + rolling forward).
    pub omega_rad_s: f64,
    /// The heading's angle from the travel (rad, in [-pi/2, pi/2]; + the travel toward the
    /// body's left).
    pub slip_angle_rad: f64,
}

impl Drive {
    /// The hub's velocity in the body's frame, checked.
    fn velocity(&self) -> Result<[f64; 3], SteadyError> {
        for (what, value) in [
            ("hub speed (m/s)", self.speed_m_s),
            ("rotation rate (rad/s)", self.omega_rad_s),
            ("slip angle (rad)", self.slip_angle_rad),
        ] {
            if !value.is_finite() {
                return Err(SteadyError::BadInput {
                    what,
                    value,
                    why: "a finite number is needed",
                });
            }
        }
        if self.slip_angle_rad.abs() > std::f64::consts::FRAC_PI_2 {
            return Err(SteadyError::BadInput {
                what: "slip angle (rad)",
                value: self.slip_angle_rad,
                why: "a slip angle is in [-pi/2, pi/2] (a body travelling backward has a negative speed)",
            });
        }
        let (sin_a, cos_a) = self.slip_angle_rad.sin_cos();
        Ok([self.speed_m_s * cos_a, self.speed_m_s * sin_a, 0.0])
    }
}

/// A medium's RFT stress: its coefficients, its law in depth and its speed law, where it has
/// them.
#[derive(Debug, Clone, Copy)]
pub struct Stress<'a> {
    /// The angular shape and scale.
    pub coefficients: &'a RftCoefficients,
    /// The law in depth, where it is not RFT's linear one.
    pub depth_law: Option<&'a RftDepthLaw>,
    /// The dynamic stress of speed, if any.
    pub speed_law: Option<&'a RftSpeedLaw>,
    /// The bearing of the sand the body shears, where the medium has it.
    pub sheared: Option<&'a ShearedBearing>,
}

/// `body` driven as `drive` with its lowest point `sinkage_m` below the undisturbed surface: the
/// forces there, in a wheel test's terms (the load the sand bears there as `load_n`).
pub fn state_at_sinkage(
    body: &Body,
    stress: &Stress,
    sinkage_m: f64,
    drive: &Drive,
) -> Result<Steady, SteadyError> {
    let velocity = drive.velocity()?;
    if !sinkage_m.is_finite() || sinkage_m > body.height_m() {
        return Err(SteadyError::BadInput {
            what: "sinkage (m)",
            value: sinkage_m,
            why: "a sinkage is a number no deeper than the body's height",
        });
    }
    let height_m = body.reach_m - sinkage_m;
    // At rest, or creeping (slower than a leg's hold at its reach), no element leads: the body
    // is borne as the sand pressed straight down bears it there, as a held leg is, with no
    // drag, side force or torque.
    let along = drive
        .speed_m_s
        .abs()
        .max((drive.omega_rad_s * body.reach_m).abs());
    if along < BodyLeg::MIN_SPEED_M_S {
        return Ok(Steady {
            sinkage_m,
            drawbar_n: 0.0,
            side_n: 0.0,
            torque_nm: 0.0,
            load_n: body.pressed_lift_n(stress, height_m, 0.0),
        });
    }
    let f = body.forces_of(
        stress,
        &HubMotion {
            height_m,
            velocity_m_s: velocity,
            omega_rad_s: drive.omega_rad_s,
            angle_rad: 0.0,
        },
    );
    // Side: + opposing the hub's sideways motion, toward the right (-y) where it has none.
    // (+ 0.0: no side force is 0, not -0.)
    let side = if velocity[1] < 0.0 {
        f.force_n[1]
    } else {
        -f.force_n[1]
    } + 0.0;
    Ok(Steady {
        sinkage_m,
        drawbar_n: f.force_n[0],
        side_n: side,
        torque_nm: f.drive_torque_nm(),
        load_n: f.force_n[2],
    })
}

/// The sinkage at which the sand bears `load_n` (N, > 0) of `body` driven as `drive`, found by
/// bisection on the sinkage to 1 um, with the forces there.
pub fn steady_sinkage(
    body: &Body,
    stress: &Stress,
    load_n: f64,
    drive: &Drive,
) -> Result<Steady, SteadyError> {
    drive.velocity()?;
    if !(load_n.is_finite() && load_n > 0.0) {
        return Err(SteadyError::BadInput {
            what: "load (N)",
            value: load_n,
            why: "a body on sand carries a load > 0 N",
        });
    }
    let at = |sinkage: f64| state_at_sinkage(body, stress, sinkage, drive);
    let deepest = body.height_m();
    let (mut lo, mut hi) = (0.0, deepest);
    if stress.sheared.is_some() {
        // Sheared sand's bearing need not grow with the depth (a deeper skid leans its
        // resultant further): the body settles at the first depth that bears it, the
        // bracket about it found in steps of a hundredth of its height.
        let mut most = f64::NEG_INFINITY;
        let mut found = false;
        for k in 1..=SCAN_STEPS {
            let s = (deepest * k as f64 / SCAN_STEPS as f64).min(deepest);
            let borne = at(s)?.load_n;
            if borne.is_nan() {
                most = f64::NAN;
                break;
            }
            most = most.max(borne);
            if borne >= load_n {
                (lo, hi) = (deepest * (k - 1) as f64 / SCAN_STEPS as f64, s);
                found = true;
                break;
            }
        }
        if !found {
            return Err(SteadyError::TooHeavy {
                load_n,
                max_load_n: most,
                height_m: deepest,
            });
        }
    } else {
        let bottom = at(deepest)?;
        // (A load borne that is no number is no bearing either.)
        if bottom.load_n.is_nan() || bottom.load_n < load_n {
            return Err(SteadyError::TooHeavy {
                load_n,
                max_load_n: bottom.load_n,
                height_m: deepest,
            });
        }
    }
    while hi - lo > 1e-6 {
        let mid = 0.5 * (lo + hi);
        if at(mid)?.load_n >= load_n {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    at(hi)
}

/// Steps of a body's height in which [`steady_sinkage`] looks for the first depth that bears a
/// load, where the sand's bearing need not grow with the depth.
const SCAN_STEPS: usize = 100;

fn positive(what: &'static str, v: f64, max: f64) -> Result<(), ModelError> {
    if v.is_finite() && v > 0.0 && v <= max {
        Ok(())
    } else {
        Err(ModelError::OutOfRange {
            what,
            value: v,
            range: format!("(0, {max}]"),
        })
    }
}

/// A body as a robot's leg: a [`Body`] on the hip's motion, in the medium's stress, as the node,
/// `replay --reevaluate` and `predict` evaluate a leg.
///
/// The hub is the hip; its height, its velocity (forward and up) and the joint's rotation rate
/// drive the body. A body that moves into sand (down, along, or turning, at
/// [`BodyLeg::MIN_SPEED_M_S`] or faster at its reach) feels RFT's stress on its leading
/// elements ([`Regime::Penetration`]). A body that holds still or is lifted without moving along
/// ([`Regime::Unloading`]) has no leading element, yet the sand still bears it until it leaves:
/// it is given the sand's reaction as it would be pressed straight down at that depth, the most
/// the sand bears there, upward and with no drag (as the sinkage leg's unloading regime).
#[derive(Debug, Clone)]
pub struct BodyLeg {
    body: Body,
    coefficients: RftCoefficients,
    depth_law: Option<RftDepthLaw>,
    speed_law: Option<RftSpeedLaw>,
    plate: Plate,
    sheared: Option<ShearedBearing>,
}

impl BodyLeg {
    /// A body moving slower than this at its reach (m/s) holds still, as a plate does
    /// ([`super::sinkage::RegimeOptions`]'s speed).
    pub const MIN_SPEED_M_S: f64 = 0.5e-3;

    /// `body` in a medium of `coefficients`, `depth_law` and `speed_law`; `plate` is the leg's
    /// configured geometry (its length the body's reach, its hip height where it stands).
    pub fn new(
        body: Body,
        coefficients: RftCoefficients,
        depth_law: Option<RftDepthLaw>,
        speed_law: Option<RftSpeedLaw>,
        plate: Plate,
    ) -> BodyLeg {
        BodyLeg {
            body,
            coefficients,
            depth_law,
            speed_law,
            plate,
            sheared: None,
        }
    }

    /// The leg with the bearing of the sand it shears ([`ShearedBearing`]), or without.
    pub fn with_sheared_bearing(mut self, sheared: Option<ShearedBearing>) -> BodyLeg {
        self.sheared = sheared;
        self
    }

    /// The body.
    pub fn body(&self) -> &Body {
        &self.body
    }

    /// The configured geometry.
    pub fn plate(&self) -> &Plate {
        &self.plate
    }

    /// The medium's speed law, where it has one.
    pub fn speed_law(&self) -> Option<&RftSpeedLaw> {
        self.speed_law.as_ref()
    }

    /// The sand's force and moment on the body turned by `angle_rad` (the joint's angle, +
    /// rolling forward: where its grousers are) at the hip `hip` (its height that of the hub
    /// above the surface; `forward_m_s` along the body's heading, `lateral_m_s` along its axle
    /// to the left, `up_m_s` up, `omega_rad_s` + rolling forward), with the regime: the full wrench at the hub, in the body's frame. An
    /// angle, height, velocity or rate that is no number is an error naming it.
    pub fn wrench(
        &self,
        angle_rad: f64,
        hip: &HipMotion,
    ) -> Result<(BodyForce, Regime), ModelError> {
        for (name, v) in [
            ("joint angle (rad)", angle_rad),
            ("hip height (m)", hip.height_m),
            ("hip forward velocity (m/s)", hip.forward_m_s),
            ("hip vertical velocity (m/s)", hip.up_m_s),
            ("leg rotation rate (rad/s)", hip.omega_rad_s),
            ("hip lateral velocity (m/s)", hip.lateral_m_s),
        ] {
            if !v.is_finite() {
                return Err(ModelError::NotFinite { name, value: v });
            }
        }
        let sinkage = self.body.reach_at_m(angle_rad) - hip.height_m;
        if sinkage <= 0.0 {
            return Ok((
                BodyForce {
                    sinkage_m: sinkage,
                    ..BodyForce::default()
                },
                Regime::OutOfMedium,
            ));
        }
        // The fastest a point of the body moves along or into the sand.
        let along = (hip.forward_m_s.hypot(hip.lateral_m_s))
            .max((hip.omega_rad_s * self.body.reach_m).abs());
        let moving = along >= Self::MIN_SPEED_M_S || -hip.up_m_s >= Self::MIN_SPEED_M_S;
        if moving {
            let f = self.body.forces_of(
                &Stress {
                    coefficients: &self.coefficients,
                    depth_law: self.depth_law.as_ref(),
                    speed_law: self.speed_law.as_ref(),
                    sheared: self.sheared.as_ref(),
                },
                &HubMotion {
                    height_m: hip.height_m,
                    velocity_m_s: [hip.forward_m_s, hip.lateral_m_s, hip.up_m_s],
                    omega_rad_s: hip.omega_rad_s,
                    angle_rad,
                },
            );
            return Ok((f, Regime::Penetration));
        }
        // Held or lifted: the sand's reaction pressed straight down there, upward only.
        let pressed = self.body.pressed_lift_n(
            &Stress {
                coefficients: &self.coefficients,
                depth_law: self.depth_law.as_ref(),
                speed_law: None,
                sheared: None,
            },
            hip.height_m,
            angle_rad,
        );
        Ok((
            BodyForce {
                force_n: [0.0, 0.0, pressed],
                moment_nm: [0.0; 3],
                sinkage_m: sinkage,
            },
            Regime::Unloading,
        ))
    }

    /// The leg's prediction at the hip `hip`: [`BodyLeg::wrench`] in a leg's terms, `drag_n` the
    /// force along the body's heading (+ forward, as a leg's drag pushes the robot forward),
    /// `lift_n` up, `hip_torque_nm` the drive torque (+ along a forward roll), `depth_m` the
    /// sinkage. The joint angle turns the body (a smooth wheel is the same at every angle).
    pub fn predict(&self, beta_rad: f64, hip: &HipMotion) -> Result<Prediction, ModelError> {
        let (f, regime) = self.wrench(beta_rad, hip)?;
        let depth_m = f.sinkage_m.max(0.0);
        Ok(Prediction {
            beta_rad,
            submerged_m: depth_m.min(self.body.height_m()),
            depth_m,
            drag_n: f.force_n[0] + 0.0,
            lift_n: f.force_n[2] + 0.0,
            hip_torque_nm: f.drive_torque_nm() + 0.0,
            // The hip frame's x is the body's backward and y its right: the body's left and
            // its moment about its heading change sign.
            side_n: -f.force_n[1] + 0.0,
            roll_moment_nm: -f.moment_nm[0] + 0.0,
            yaw_moment_nm: f.moment_nm[2] + 0.0,
            regime,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{RftFit, rft::RftGrid};

    fn sand() -> (RftCoefficients, RftDepthLaw) {
        // The real-plate-sinkage runs' rft_depth_power law on poppy_lp's shape.
        (
            RftCoefficients::Fit(RftFit::POPPY_LP),
            RftDepthLaw::new(4.546, 1.219).unwrap(),
        )
    }

    fn steady(body: &Body, load: f64, omega: f64, slip_deg: f64) -> Result<Steady, SteadyError> {
        let (c, law) = sand();
        let stress = Stress {
            coefficients: &c,
            depth_law: Some(&law),
            speed_law: None,
            sheared: None,
        };
        let drive = Drive {
            speed_m_s: 0.01,
            omega_rad_s: omega,
            slip_angle_rad: slip_deg.to_radians(),
        };
        steady_sinkage(body, &stress, load, &drive)
    }

    #[test]
    fn a_wheel_going_straight_has_no_side_force_roll_or_yaw() {
        let (c, law) = sand();
        let wheel = Body::wheel(0.058, 0.05, None, 720).unwrap();
        for omega in [0.0, 0.17, 1.7] {
            let f = wheel.forces(
                &c,
                Some(&law),
                None,
                &HubMotion {
                    height_m: 0.04,
                    velocity_m_s: [0.01, 0.0, 0.0],
                    omega_rad_s: omega,
                    angle_rad: 0.0,
                },
            );
            assert!(f.force_n[2] > 1.0, "{f:?}");
            for v in [f.force_n[1], f.moment_nm[0], f.moment_nm[2]] {
                assert!(v.abs() < 1e-12, "{f:?}");
            }
        }
    }

    #[test]
    fn a_yawed_wheel_is_pushed_against_its_sideways_motion_the_same_either_way() {
        let wheel = Body::wheel(0.058, 0.05, None, 720).unwrap();
        let straight = steady(&wheel, 20.0, 0.172, 0.0).unwrap();
        let mut last = 0.0;
        for deg in [5.0, 10.0, 20.0, 30.0] {
            let left = steady(&wheel, 20.0, 0.172, deg).unwrap();
            let right = steady(&wheel, 20.0, 0.172, -deg).unwrap();
            // + opposing the sideways motion, growing with the angle, mirrored exactly.
            assert!(left.side_n > last, "{deg}: {left:?}");
            assert!(
                (left.side_n - right.side_n).abs() < 1e-9,
                "{left:?} {right:?}"
            );
            assert!((left.sinkage_m - right.sinkage_m).abs() < 1e-12);
            last = left.side_n;
        }
        assert!(straight.side_n.abs() < 1e-12);
        // The hub moving toward the left (+y): the sand pushes it toward the right (-y).
        let (c, law) = sand();
        let f = wheel.forces(
            &c,
            Some(&law),
            None,
            &HubMotion {
                height_m: 0.058 - straight.sinkage_m,
                velocity_m_s: [0.0098, 0.0017, 0.0],
                omega_rad_s: 0.172,
                angle_rad: 0.0,
            },
        );
        assert!(f.force_n[1] < 0.0, "{f:?}");
    }

    /// A body moving too slowly for its speed to square (below 1e-154 m/s) feels what it feels
    /// moving the same way at a speed the law does not tell from it: the stress takes the
    /// motion's direction alone (it was no number at 1e-200 m/s, and `terzaghi steady` said the
    /// sand bore at most NaN N).
    #[test]
    fn a_body_moving_too_slowly_to_square_feels_its_motions_direction() {
        let (c, law) = sand();
        let speed_law = RftSpeedLaw::new(0.01, 0.05, 1.0).unwrap();
        let wheel = Body::wheel(0.058, 0.05, None, 360).unwrap();
        // Rolling with slip in its plane (the planar sum), the same and sideways (the general
        // sum), and skidding sideways without turning.
        for (v, omega) in [
            ([1.0, 0.0, -0.2], 10.0),
            ([1.0, 0.3, -0.2], 10.0),
            ([0.0, 1.0, 0.0], 0.0),
        ] {
            let at = |speed: f64, by_speed: Option<&RftSpeedLaw>| {
                wheel.forces(
                    &c,
                    Some(&law),
                    by_speed,
                    &HubMotion {
                        height_m: 0.035,
                        velocity_m_s: v.map(|x| x * speed),
                        omega_rad_s: omega * speed,
                        angle_rad: 0.0,
                    },
                )
            };
            for by_speed in [None, Some(&speed_law)] {
                // The speed law adds depth with speed: at 1e-100 m/s, none that shows.
                let want = at(1e-100, by_speed);
                // The slowest motion there is: finite (its parts round to other directions).
                let slowest = at(5e-324, by_speed);
                assert!(
                    slowest
                        .force_n
                        .iter()
                        .chain(&slowest.moment_nm)
                        .all(|v| v.is_finite()),
                    "{slowest:?}"
                );
                for speed in [1e-150, 1e-200, 1e-300, 1e-305] {
                    let got = at(speed, by_speed);
                    for (g, w) in got
                        .force_n
                        .iter()
                        .chain(&got.moment_nm)
                        .zip(want.force_n.iter().chain(&want.moment_nm))
                    {
                        assert!(
                            (g - w).abs() <= 1e-9 * (1.0 + w.abs()),
                            "{v:?} at {speed} m/s: {got:?} against {want:?}"
                        );
                    }
                }
                // Sand that pushes: not a sum of nothing.
                assert!(want.force_n.iter().any(|f| f.abs() > 1.0), "{want:?}");
            }
        }
    }

    #[test]
    fn a_heavier_load_sinks_deeper_and_too_heavy_a_load_is_refused_by_name() {
        let wheel = Body::wheel(0.058, 0.05, None, 720).unwrap();
        let mut last = 0.0;
        for load in [5.0, 10.0, 20.0, 40.0, 80.0] {
            let s = steady(&wheel, load, 0.172, 0.0).unwrap();
            assert!(s.sinkage_m > last, "{load} N: {s:?}");
            assert!((s.load_n - load).abs() < 0.01 * load, "{s:?}");
            last = s.sinkage_m;
        }
        let e = steady(&wheel, 1e7, 0.172, 0.0).unwrap_err();
        assert!(
            matches!(e, SteadyError::TooHeavy { load_n, .. } if load_n == 1e7),
            "{e}"
        );
        assert!(e.to_string().contains("10000000 N"), "{e}");
        for (load, omega, slip) in [
            (f64::NAN, 0.1, 0.0),
            (10.0, f64::INFINITY, 0.0),
            (-1.0, 0.1, 0.0),
            (10.0, 0.1, 100.0),
        ] {
            let e = steady(&wheel, load, omega, slip).unwrap_err();
            assert!(matches!(e, SteadyError::BadInput { .. }), "{e}");
        }
    }

    #[test]
    fn grousers_drive_a_slipping_wheel_harder_than_a_smooth_rim() {
        let smooth = Body::wheel(0.058, 0.05, None, 720).unwrap();
        let lugs = Body::wheel(
            0.058,
            0.05,
            Some(Grousers {
                count: 12,
                height_m: 0.005,
                thickness_m: 0.002,
            }),
            720,
        )
        .unwrap();
        let (a, b) = (
            steady(&smooth, 20.0, 0.69, 0.0).unwrap(),
            steady(&lugs, 20.0, 0.69, 0.0).unwrap(),
        );
        assert!(b.drawbar_n > a.drawbar_n, "{a:?} {b:?}");
    }

    #[test]
    fn an_outline_that_is_no_body_is_refused_naming_the_edge() {
        let square = [(-0.01, -0.01), (0.01, -0.01), (0.01, 0.01), (-0.01, 0.01)];
        assert!(Body::prism(&square, 0.02, 0.002).is_ok());
        let mut clockwise = square;
        clockwise.reverse();
        let e = Body::prism(&clockwise, 0.02, 0.002)
            .unwrap_err()
            .to_string();
        assert!(e.contains("edge 0") && e.contains("clockwise"), "{e}");
        let mut nan = square;
        nan[2].1 = f64::NAN;
        let e = Body::prism(&nan, 0.02, 0.002).unwrap_err().to_string();
        assert!(e.contains("point 2") && e.contains("NaN"), "{e}");
        let e = Body::prism(&square[..2], 0.02, 0.002)
            .unwrap_err()
            .to_string();
        assert!(e.contains("3 points"), "{e}");
        assert!(Body::wheel(0.058, f64::NAN, None, 10).is_err());
        let e = Body::wheel(
            0.058,
            0.05,
            Some(Grousers {
                count: 12,
                height_m: 0.005,
                thickness_m: 0.05,
            }),
            10,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("grouser thickness"), "{e}");
    }

    fn wheel_leg() -> BodyLeg {
        let (c, law) = sand();
        BodyLeg::new(
            Body::wheel(0.058, 0.05, None, 720).unwrap(),
            c,
            Some(law),
            None,
            Plate::new(0.058, 0.05, 0.03).unwrap(),
        )
    }

    #[test]
    fn a_wheel_leg_pressed_held_lifted_and_out_of_the_sand() {
        let leg = wheel_leg();
        let hip = |height_m: f64, forward_m_s: f64, up_m_s: f64, omega_rad_s: f64| HipMotion {
            height_m,
            forward_m_s,
            up_m_s,
            omega_rad_s,
            ..HipMotion::default()
        };
        // Pressed straight down 30 mm: the sand pushes it up, and no more one way than the other.
        let pressed = leg.predict(0.0, &hip(0.028, 0.0, -0.002, 0.0)).unwrap();
        assert_eq!(pressed.regime, Regime::Penetration);
        assert!(pressed.lift_n > 50.0, "{pressed:?}");
        assert!(pressed.drag_n.abs() < 1e-6 * pressed.lift_n, "{pressed:?}");
        assert!((pressed.depth_m - 0.030).abs() < 1e-12);
        // Held there, or backing off: the same reaction upward, no drag, no torque.
        for up in [0.0, 0.0004, 0.002] {
            let held = leg.predict(0.0, &hip(0.028, 0.0, up, 0.0)).unwrap();
            assert_eq!(held.regime, Regime::Unloading, "up {up}");
            assert_eq!((held.drag_n, held.hip_torque_nm), (0.0, 0.0));
            assert!((held.lift_n - pressed.lift_n).abs() < 1e-9 * pressed.lift_n);
        }
        // Dragged forward locked at the same depth: a drag against the travel, and lift.
        let locked = leg.predict(0.0, &hip(0.028, 0.01, 0.0, 0.0)).unwrap();
        assert_eq!(locked.regime, Regime::Penetration);
        assert!(locked.drag_n < -1.0 && locked.lift_n > 0.0, "{locked:?}");
        // Spinning in place: the sand pushes it forward, and the drive works against the sand.
        let spinning = leg.predict(0.0, &hip(0.028, 0.0, 0.0, 1.0)).unwrap();
        assert!(
            spinning.drag_n > 1.0 && spinning.hip_torque_nm > 0.0,
            "{spinning:?}"
        );
        // Out of the sand: nothing.
        let out = leg.predict(0.0, &hip(0.06, 0.0, 0.01, 0.0)).unwrap();
        assert_eq!(out.regime, Regime::OutOfMedium);
        assert_eq!((out.drag_n, out.lift_n, out.hip_torque_nm), (0.0, 0.0, 0.0));
        // A hip that is no number is refused by name.
        let e = leg
            .predict(0.0, &hip(0.03, f64::NAN, 0.0, 0.0))
            .unwrap_err()
            .to_string();
        assert!(e.contains("hip forward velocity"), "{e}");
    }

    #[test]
    fn a_hub_height_that_is_no_number_gives_forces_that_are_no_number() {
        // `Body::forces` takes what its callers checked; a NaN it is given must not come out
        // as a number (the blocks of the rim above the sand are skipped only for a number).
        let (fit, law) = sand();
        let wheel = Body::wheel(0.058, 0.05, None, 360).unwrap();
        let hub = HubMotion {
            height_m: f64::NAN,
            velocity_m_s: [0.01, 0.0, 0.0],
            omega_rad_s: 0.345,
            angle_rad: 0.0,
        };
        let f = wheel.forces(&fit, Some(&law), None, &hub);
        assert!(f.force_n[0].is_nan() && f.force_n[2].is_nan(), "{f:?}");
    }

    /// A prism moving across its plane sums each outline element once per depth its strips
    /// meet, and skips blocks above the sand: what the sum over every strip and side element,
    /// none skipped, gives, to rounding; with the rut's start cutting across elements (a
    /// wheel sideways, a turned grousered wheel and bar), for both medium forms and laws.
    #[test]
    fn the_strips_summed_together_are_the_strips_summed_one_by_one() {
        let (fit, law) = sand();
        let speed = RftSpeedLaw::new(0.01, 0.05, 1.0).unwrap();
        let grid = RftCoefficients::Grid(RftGrid::poppy_lp());
        let lugs = Some(Grousers {
            count: 8,
            height_m: 0.01,
            thickness_m: 0.004,
        });
        let bodies = [
            Body::wheel(0.058, 0.05, None, 360).unwrap(),
            Body::wheel(0.058, 0.05, lugs, 360).unwrap(),
            Body::prism(
                &[(-0.03, -0.04), (0.03, -0.04), (0.03, 0.01), (-0.03, 0.01)],
                0.04,
                0.002,
            )
            .unwrap(),
        ];
        let (mut compared, mut split) = (0, 0);
        for body in &bodies {
            // Every strip its own element, as the sum's elements were laid out before.
            let mut each: Vec<Element> = Vec::new();
            for e in &body.spatial[..body.strips] {
                for &y in &std::array::from_fn::<f64, { Body::STRIPS }, _>(|j| {
                    ((j as f64 + 0.5) / Body::STRIPS as f64 - 0.5) * body.strip_width_m
                }) {
                    each.push(Element {
                        p: [e.p[0], y, e.p[2]],
                        n: e.n,
                        area: e.area / Body::STRIPS as f64,
                    });
                }
            }
            each.extend_from_slice(&body.spatial[body.strips..]);
            let never_skipped = vec![[0.0, 0.0, f64::INFINITY]; each.len().div_ceil(LANES)];
            let one_by_one = Surface {
                elements: &each,
                blocks: &never_skipped,
                strips: 0,
                strip_width_m: 0.0,
            };
            for coefficients in [&fit, &grid] {
                for (depth_law, speed_law) in
                    [(None, None), (Some(&law), None), (Some(&law), Some(&speed))]
                {
                    for (v, omega, angle, height) in [
                        ([0.01, 0.005, 0.0], 0.345, 0.0, 0.033),
                        ([0.01, -0.01, -0.002], 0.0, 0.4, 0.02),
                        ([0.0, 0.02, 0.0], 0.0, 1.1, 0.045),
                        ([-0.02, 0.003, 0.005], -1.0, -0.7, 0.03),
                        ([0.05, 0.05, -0.01], 2.0, 2.0, 0.01),
                    ] {
                        let hub = HubMotion {
                            height_m: height,
                            velocity_m_s: v,
                            omega_rad_s: omega,
                            angle_rad: angle,
                        };
                        let (at, _) = body.place(&hub);
                        let stress = Stress {
                            coefficients,
                            depth_law,
                            speed_law,
                            sheared: None,
                        };
                        let got = body.forces(coefficients, depth_law, speed_law, &hub);
                        let (f, m, _) = Body::general_sum(one_by_one, &stress, &hub, &at);
                        let scale = f.iter().chain(&m).fold(1e-6f64, |a, x| a.max(x.abs()));
                        for k in 0..3 {
                            assert!(
                                (got.force_n[k] - f[k]).abs() <= 1e-12 * scale
                                    && (got.moment_nm[k] - m[k]).abs() <= 1e-12 * scale,
                                "{v:?} {angle}: {:?} {:?} against {f:?} {m:?}",
                                got.force_n,
                                got.moment_nm
                            );
                        }
                        compared += usize::from(f[2].abs() > 1e-3);
                        // Somewhere the rut's start cuts across an element's strips.
                        let cut = body.spatial[..body.strips].iter().any(|e| {
                            let (px, pz) = if at.turned {
                                at.turn(e.p[0], e.p[2])
                            } else {
                                (e.p[0], e.p[2])
                            };
                            let side = |y: f64| {
                                (px - at.lowest_xy.0) * at.travel.0
                                    + (y - at.lowest_xy.1) * at.travel.1
                                    < 0.0
                            };
                            at.height_m + pz < 0.0
                                && side(-body.strip_width_m / 2.0) != side(body.strip_width_m / 2.0)
                        });
                        split += usize::from(cut);
                    }
                }
            }
        }
        assert!(
            compared >= 60 && split >= 20,
            "{compared} in the sand, {split} cut"
        );
    }

    #[test]
    fn the_planar_sum_is_the_general_sum_of_the_same_elements() {
        // The shortcut a body moving in its own plane takes must give what the general sum
        // gives over the same elements, for every medium form and motion the node meets.
        let (fit, law) = sand();
        let speed = RftSpeedLaw::new(0.01, 0.05, 1.0).unwrap();
        let grid = RftCoefficients::Grid(RftGrid::poppy_lp());
        let smooth = Body::wheel(0.058, 0.05, None, 360).unwrap();
        let lugs = Body::wheel(
            0.058,
            0.05,
            Some(Grousers {
                count: 8,
                height_m: 0.01,
                thickness_m: 0.004,
            }),
            360,
        )
        .unwrap();
        let bar = Body::prism(
            &[(-0.03, -0.04), (0.03, -0.04), (0.03, 0.01), (-0.03, 0.01)],
            0.04,
            0.002,
        )
        .unwrap();
        let (mut compared, mut pressing) = (0, 0);
        for body in [&smooth, &lugs, &bar] {
            for coefficients in [&fit, &grid] {
                for (depth_law, speed_law) in [
                    (None, None),
                    (Some(&law), None),
                    (None, Some(&speed)),
                    (Some(&law), Some(&speed)),
                ] {
                    for (v, omega, angle) in [
                        ([0.01, 0.0, 0.0], 0.345, 0.0),
                        ([0.01, 0.0, 0.0], 0.0, 0.3),
                        ([-0.02, 0.0, 0.005], -1.0, 1.1),
                        ([0.0, 0.0, -0.003], 0.0, 0.0),
                        ([0.0, 0.0, 0.003], 0.0, 2.0),
                        ([0.05, 0.0, -0.01], 2.0, -0.7),
                        ([0.0, 0.0, 0.0], 1.5, 0.0),
                    ] {
                        let hub = HubMotion {
                            height_m: 0.03,
                            velocity_m_s: v,
                            omega_rad_s: omega,
                            angle_rad: angle,
                        };
                        let fast = body.forces(coefficients, depth_law, speed_law, &hub);
                        let (at, _) = body.place(&hub);
                        let stress = Stress {
                            coefficients,
                            depth_law,
                            speed_law,
                            sheared: None,
                        };
                        let planar = Surface {
                            elements: &body.planar,
                            blocks: &body.planar_blocks,
                            strips: 0,
                            strip_width_m: 0.0,
                        };
                        let (f, m, vertical_m) = Body::general_sum(planar, &stress, &hub, &at);
                        // Every build of the planar sum the processor runs: the same values.
                        let any = body.planar_sum_any(&stress, &hub, &at);
                        assert_eq!((fast.force_n, fast.moment_nm), (any.0, any.1), "{hub:?}");

                        #[cfg(target_arch = "x86_64")]
                        if std::arch::is_x86_feature_detected!("avx2")
                            && std::arch::is_x86_feature_detected!("fma")
                            && std::arch::is_x86_feature_detected!("popcnt")
                        {
                            // SAFETY: the processor has the instructions.
                            let avx2 = unsafe { body.planar_sum_avx2(&stress, &hub, &at) };
                            assert_eq!(any, avx2, "{hub:?}");
                        }
                        let scale = f.iter().chain(&m).fold(1e-9, |a: f64, x| a.max(x.abs()));
                        pressing += usize::from(scale > 1e-3);
                        // The vertical stresses' moment, the general sum's to rounding.
                        assert!(
                            (any.2[1] - vertical_m[1]).abs() <= 1e-12 * scale,
                            "{hub:?}: {:?} against {vertical_m:?}",
                            any.2
                        );
                        for (a, b) in fast
                            .force_n
                            .iter()
                            .zip(&f)
                            .chain(fast.moment_nm.iter().zip(&m))
                        {
                            assert!((a - b).abs() <= 1e-12 * scale, "{a} against {b}: {hub:?}");
                        }
                        compared += 1;
                    }
                }
            }
        }
        assert_eq!(compared, 3 * 2 * 4 * 7);
        // All but the lifts press sand (a grousered wheel's lugs may be lifted against it).
        assert!(pressing >= compared - 3 * 2 * 4, "{pressing} of {compared}");
    }

    #[test]
    fn grousers_turn_with_the_joint_and_a_smooth_wheel_is_the_same_at_every_angle() {
        let (c, law) = sand();
        let leg = |g: Option<Grousers>| {
            BodyLeg::new(
                Body::wheel(0.058, 0.05, g, 720).unwrap(),
                c.clone(),
                Some(law),
                None,
                Plate::new(0.058, 0.05, 0.03).unwrap(),
            )
        };
        let hip = HipMotion {
            height_m: 0.045,
            forward_m_s: 0.01,
            omega_rad_s: 0.3,
            ..HipMotion::default()
        };
        let grousers = leg(Some(Grousers {
            count: 8,
            height_m: 0.01,
            thickness_m: 0.004,
        }));
        let pitch = std::f64::consts::TAU / 8.0;
        let at = |l: &BodyLeg, a: f64| l.predict(a, &hip).unwrap();
        let (g0, g_half, g_full) = (
            at(&grousers, 0.0),
            at(&grousers, pitch / 2.0),
            at(&grousers, pitch),
        );
        // A grouser straight down digs deeper than two astride the bottom.
        assert!(g0.depth_m > g_half.depth_m + 1e-3, "{g0:?} {g_half:?}");
        assert!(
            (g0.drag_n - g_half.drag_n).abs() > 0.01,
            "{g0:?} {g_half:?}"
        );
        for (a, b) in [
            (g0.drag_n, g_full.drag_n),
            (g0.lift_n, g_full.lift_n),
            (g0.depth_m, g_full.depth_m),
        ] {
            assert!((a - b).abs() <= 1e-9 * (1.0 + a.abs()), "{a} {b}");
        }
        let smooth = leg(None);
        let (s0, s1) = (at(&smooth, 0.0), at(&smooth, 1.234));
        assert_eq!((s0.drag_n, s0.lift_n), (s1.drag_n, s1.lift_n));
    }
}
