//! Closed triangle meshes as bodies (a foot, or any part drawn in CAD and exported as STL), and
//! the feet robots are built with: a disc, a sphere, a box.
//!
//! A mesh is given in the body's frame about its hub (m; `x` the heading, `y` to the left, `z`
//! up, as ROS orders a body's axes), each triangle's vertices counter-clockwise seen from outside
//! (as STL lists them). It must be closed (every edge shared by exactly two triangles, which run
//! it opposite ways), with no triangle of no area, and enclose a positive volume; the error of a
//! mesh that is not names the triangle, the edge or the value. Each triangle is cut into equal
//! elements no longer than the element length asked, on which [`Body::forces`] takes RFT's
//! stress as on a prism's.

use super::{Body, Element};
use crate::model::ModelError;
use std::collections::HashMap;

/// A triangle: its three vertices (m, `x, y, z`), counter-clockwise seen from outside.
pub type Triangle = [[f64; 3]; 3];

/// At most this many elements in a body (its triangles cut to the element length).
const MAX_ELEMENTS: usize = 2_000_000;

/// Moves `triangles` to the pose `xyz_m` (m) and `rpy_rad` (rad: roll, pitch and yaw about the
/// fixed `x`, `y` and `z` axes, applied in that order, as URDF's `origin` gives a part's pose):
/// each vertex `v` becomes `R v + xyz`, `R = Rz(yaw) Ry(pitch) Rx(roll)`.
pub fn place(triangles: &mut [Triangle], xyz_m: [f64; 3], rpy_rad: [f64; 3]) {
    let (sr, cr) = rpy_rad[0].sin_cos();
    let (sp, cp) = rpy_rad[1].sin_cos();
    let (sy, cy) = rpy_rad[2].sin_cos();
    let r = [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ];
    for t in triangles.iter_mut() {
        for v in t.iter_mut() {
            let p = *v;
            for (i, row) in r.iter().enumerate() {
                v[i] = row[0] * p[0] + row[1] * p[1] + row[2] * p[2] + xyz_m[i];
            }
        }
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

fn bad(problem: String) -> ModelError {
    ModelError::BadBody { problem }
}

fn shown(p: [f64; 3]) -> String {
    format!("({}, {}, {})", p[0], p[1], p[2])
}

impl Body {
    /// A closed triangle mesh (see the module's page): each triangle cut into `k^2` equal
    /// elements, `k` the least that makes their edges no longer than `element_m` (m).
    pub fn mesh(triangles: &[Triangle], element_m: f64) -> Result<Body, ModelError> {
        if !(element_m.is_finite() && element_m > 0.0 && element_m <= 10.0) {
            return Err(ModelError::OutOfRange {
                what: "body element length (m)",
                value: element_m,
                range: "(0, 10]".into(),
            });
        }
        if triangles.len() < 4 {
            return Err(bad(format!(
                "a closed mesh has 4 triangles or more, not {}",
                triangles.len()
            )));
        }
        // Every vertex a number, and the mesh's size (for what "no area" means).
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for (i, t) in triangles.iter().enumerate() {
            for (k, v) in t.iter().enumerate() {
                if v.iter().any(|c| !c.is_finite()) {
                    return Err(bad(format!("triangle {i}'s vertex {k} is {}", shown(*v))));
                }
                for j in 0..3 {
                    lo[j] = lo[j].min(v[j]);
                    hi[j] = hi[j].max(v[j]);
                }
            }
        }
        let size = norm(sub(hi, lo));
        if size > 10.0 {
            return Err(bad(format!(
                "it spans {size:.3} m corner to corner (a body here is at most 10 m: a mesh in mm needs a scale of 0.001)"
            )));
        }
        // Vertices shared by value (-0 and +0 one vertex), then every edge's two triangles.
        let mut index: HashMap<[u64; 3], usize> = HashMap::new();
        let mut points: Vec<[f64; 3]> = Vec::new();
        let mut corners: Vec<[usize; 3]> = Vec::with_capacity(triangles.len());
        for t in triangles {
            let mut c = [0; 3];
            for (k, v) in t.iter().enumerate() {
                let key = v.map(|x| (x + 0.0).to_bits());
                c[k] = *index.entry(key).or_insert_with(|| {
                    points.push(*v);
                    points.len() - 1
                });
            }
            corners.push(c);
        }
        let mut edges: HashMap<(usize, usize), usize> = HashMap::with_capacity(3 * triangles.len());
        let mut volume6 = 0.0;
        for (i, (t, c)) in triangles.iter().zip(&corners).enumerate() {
            let twice_area = norm(cross(sub(t[1], t[0]), sub(t[2], t[0])));
            if c[0] == c[1] || c[1] == c[2] || c[0] == c[2] || twice_area <= 1e-12 * size * size {
                return Err(bad(format!(
                    "triangle {i} ({}, {}, {}) has no area",
                    shown(t[0]),
                    shown(t[1]),
                    shown(t[2])
                )));
            }
            volume6 += dot(t[0], cross(t[1], t[2]));
            for k in 0..3 {
                let e = (c[k], c[(k + 1) % 3]);
                if let Some(j) = edges.insert(e, i) {
                    return Err(bad(format!(
                        "the edge from {} to {} runs the same way in triangles {j} and {i}: one of them faces inward, or more than two triangles meet there",
                        shown(points[e.0]),
                        shown(points[e.1])
                    )));
                }
            }
        }
        // Reported in the triangles' order, so the same mesh names the same edge.
        let mut open: Vec<(usize, (usize, usize))> = edges
            .iter()
            .filter(|(e, _)| !edges.contains_key(&(e.1, e.0)))
            .map(|(e, i)| (*i, *e))
            .collect();
        open.sort_unstable();
        if let Some(&(i, (a, b))) = open.first() {
            return Err(bad(format!(
                "it is not closed: the edge from {} to {} of triangle {i} is on no other triangle ({} open edges in all)",
                shown(points[a]),
                shown(points[b]),
                open.len()
            )));
        }
        if volume6 <= 0.0 {
            return Err(bad(format!(
                "its triangles face inward (the volume they enclose is {:.3e} m^3): each triangle's vertices run counter-clockwise seen from outside",
                volume6 / 6.0
            )));
        }
        // The elements: each triangle on a k-by-k grid of its own.
        let cuts: Vec<usize> = triangles
            .iter()
            .map(|t| {
                let longest = (0..3)
                    .map(|k| norm(sub(t[(k + 1) % 3], t[k])))
                    .fold(0.0, f64::max);
                (longest / element_m).ceil().clamp(1.0, 1e4) as usize
            })
            .collect();
        let count: usize = cuts.iter().map(|k| k * k).sum();
        if count > MAX_ELEMENTS {
            return Err(bad(format!(
                "cut into elements of {element_m} m it has {count} elements, more than {MAX_ELEMENTS}: give a longer element length"
            )));
        }
        let mut elements = Vec::with_capacity(count);
        for (t, &k) in triangles.iter().zip(&cuts) {
            let c = cross(sub(t[1], t[0]), sub(t[2], t[0]));
            let twice = norm(c);
            let n = c.map(|x| x / twice);
            let area = 0.5 * twice / (k * k) as f64;
            let (u, v) = (sub(t[1], t[0]), sub(t[2], t[0]));
            let at = |i: f64, j: f64| {
                let (a, b) = (i / k as f64, j / k as f64);
                [
                    t[0][0] + a * u[0] + b * v[0],
                    t[0][1] + a * u[1] + b * v[1],
                    t[0][2] + a * u[2] + b * v[2],
                ]
            };
            for i in 0..k {
                for j in 0..k - i {
                    let (fi, fj) = (i as f64, j as f64);
                    // The grid's upward triangle at (i, j), then its downward one.
                    elements.push(Element {
                        p: at(fi + 1.0 / 3.0, fj + 1.0 / 3.0),
                        n,
                        area,
                    });
                    if i + j + 1 < k {
                        elements.push(Element {
                            p: at(fi + 2.0 / 3.0, fj + 2.0 / 3.0),
                            n,
                            area,
                        });
                    }
                }
            }
        }
        Ok(Body {
            planar: Vec::new(),
            planar_blocks: Vec::new(),
            spatial_blocks: super::circles_about(&elements),
            strips: 0,
            strip_width_m: 0.0,
            spatial: elements,
            reach_m: -lo[2],
            top_m: hi[2],
            points,
            round: false,
        })
    }

    /// A disc foot: a flat cylinder of `radius_m` and `thickness_m`, its axis vertical, its
    /// centre at `centre_m` from the hub (m), its rim cut into `segments` (at least 12).
    pub fn disc(
        radius_m: f64,
        thickness_m: f64,
        centre_m: [f64; 3],
        segments: usize,
        element_m: f64,
    ) -> Result<Body, ModelError> {
        dimension("disc radius (m)", radius_m)?;
        dimension("disc thickness (m)", thickness_m)?;
        let n = segments.clamp(12, 4096);
        let (h, c) = (thickness_m / 2.0, centre_m);
        let ring = |k: usize, z: f64| {
            let a = std::f64::consts::TAU * (k % n) as f64 / n as f64;
            [
                c[0] + radius_m * a.cos(),
                c[1] + radius_m * a.sin(),
                c[2] + z,
            ]
        };
        let (top, bottom) = ([c[0], c[1], c[2] + h], [c[0], c[1], c[2] - h]);
        let mut t = Vec::with_capacity(4 * n);
        for k in 0..n {
            let (a0, a1) = (ring(k, h), ring(k + 1, h));
            let (b0, b1) = (ring(k, -h), ring(k + 1, -h));
            t.push([top, a0, a1]);
            t.push([bottom, b1, b0]);
            t.push([b0, b1, a1]);
            t.push([b0, a1, a0]);
        }
        Body::mesh(&t, element_m)
    }

    /// A sphere foot of `radius_m` centred at `centre_m` from the hub (m): a sphere of
    /// `rings` bands of latitude (6 to 256) and twice as many of longitude.
    pub fn sphere(
        radius_m: f64,
        centre_m: [f64; 3],
        rings: usize,
        element_m: f64,
    ) -> Result<Body, ModelError> {
        dimension("sphere radius (m)", radius_m)?;
        // At most 256 rings (260,100 triangles): a finer sphere is refused by the element
        // count anyway, after its triangles were built.
        let (m, n) = (rings.clamp(6, 256), 2 * rings.clamp(6, 256));
        let c = centre_m;
        let at = |i: usize, k: usize| {
            let (st, ct) = (std::f64::consts::PI * i as f64 / m as f64).sin_cos();
            let (sp, cp) = (std::f64::consts::TAU * (k % n) as f64 / n as f64).sin_cos();
            [
                c[0] + radius_m * st * cp,
                c[1] + radius_m * st * sp,
                c[2] + radius_m * ct,
            ]
        };
        let (north, south) = ([c[0], c[1], c[2] + radius_m], [c[0], c[1], c[2] - radius_m]);
        let mut t = Vec::with_capacity(2 * m * n);
        for k in 0..n {
            t.push([north, at(1, k), at(1, k + 1)]);
            t.push([south, at(m - 1, k + 1), at(m - 1, k)]);
            for i in 1..m - 1 {
                t.push([at(i, k), at(i + 1, k), at(i + 1, k + 1)]);
                t.push([at(i, k), at(i + 1, k + 1), at(i, k + 1)]);
            }
        }
        Body::mesh(&t, element_m)
    }

    /// A box foot of `size_m` (m, along `x`, `y`, `z`) centred at `centre_m` from the hub (m).
    pub fn cuboid(
        size_m: [f64; 3],
        centre_m: [f64; 3],
        element_m: f64,
    ) -> Result<Body, ModelError> {
        for (what, v) in [
            ("box length (m)", size_m[0]),
            ("box width (m)", size_m[1]),
            ("box height (m)", size_m[2]),
        ] {
            dimension(what, v)?;
        }
        let t = box_triangles(size_m, centre_m);
        Body::mesh(&t, element_m)
    }
}

/// A box's twelve triangles (two a face, counter-clockwise seen from outside: a closed mesh for
/// [`Body::mesh`]), of `size_m` along `x`, `y`, `z` centred at `centre_m`. The faces in the order
/// bottom (`z-`), top, `y-`, `y+`, `x-`, `x+`.
pub fn box_triangles(size_m: [f64; 3], centre_m: [f64; 3]) -> Vec<Triangle> {
    let corner = |i: usize| {
        let s = |bit: usize, j: usize| {
            centre_m[j] + if i >> bit & 1 == 1 { 0.5 } else { -0.5 } * size_m[j]
        };
        [s(0, 0), s(1, 1), s(2, 2)]
    };
    // Corner bits: x, y, z.
    let faces = [
        [0, 2, 3, 1], // bottom, z-
        [4, 5, 7, 6], // top, z+
        [0, 1, 5, 4], // y-
        [2, 6, 7, 3], // y+
        [0, 4, 6, 2], // x-
        [1, 3, 7, 5], // x+
    ];
    faces
        .iter()
        .flat_map(|f| {
            [
                [corner(f[0]), corner(f[1]), corner(f[2])],
                [corner(f[0]), corner(f[2]), corner(f[3])],
            ]
        })
        .collect()
}

fn dimension(what: &'static str, v: f64) -> Result<(), ModelError> {
    if v.is_finite() && v > 0.0 && v <= 10.0 {
        Ok(())
    } else {
        Err(ModelError::OutOfRange {
            what,
            value: v,
            range: "(0, 10]".into(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::body::HubMotion;
    use crate::model::{RftCoefficients, RftDepthLaw, RftFit};

    fn sand() -> (RftCoefficients, RftDepthLaw) {
        (
            RftCoefficients::Fit(RftFit::POPPY_LP),
            RftDepthLaw::new(4.546, 1.219).unwrap(),
        )
    }

    fn forces(body: &Body, height_m: f64, v: [f64; 3], omega: f64) -> super::super::BodyForce {
        let (c, law) = sand();
        body.forces(
            &c,
            Some(&law),
            None,
            &HubMotion {
                height_m,
                velocity_m_s: v,
                omega_rad_s: omega,
                angle_rad: 0.0,
            },
        )
    }

    /// A wheel's outline (x right, z up, counter-clockwise) as a closed mesh of its rim and its
    /// two side faces, fanned from the hub.
    fn wheel_triangles(outline: &[(f64, f64)], width_m: f64) -> Vec<Triangle> {
        let h = width_m / 2.0;
        let mut t = Vec::new();
        for i in 0..outline.len() {
            let (x0, z0) = outline[i];
            let (x1, z1) = outline[(i + 1) % outline.len()];
            let (a, b, c, d) = ([x0, -h, z0], [x1, -h, z1], [x1, h, z1], [x0, h, z0]);
            t.push([a, c, b]);
            t.push([a, d, c]);
            t.push([[0.0, h, 0.0], c, d]);
            t.push([[0.0, -h, 0.0], a, b]);
        }
        t
    }

    fn circle(r: f64, n: usize) -> Vec<(f64, f64)> {
        (0..n)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                (r * a.sin(), -r * a.cos())
            })
            .collect()
    }

    /// The same wheel as a prism and as a mesh of triangles: the same forces and moments where
    /// it rolls, skids, spins and is yawed, to the elements' resolution.
    #[test]
    fn a_wheel_drawn_as_a_mesh_feels_what_the_prism_feels() {
        let (r, w) = (0.058, 0.05);
        let prism = Body::wheel(r, w, None, 360).unwrap();
        let mesh = Body::mesh(&wheel_triangles(&circle(r, 360), w), 0.004).unwrap();
        assert!((mesh.reach_m() - r).abs() < 1e-12 && (mesh.height_m() - 2.0 * r).abs() < 1e-12);
        for (v, omega) in [
            ([0.01, 0.0, 0.0], 0.0),
            ([0.01, 0.0, 0.0], 0.01 / r * 0.5),
            ([0.01, 0.0, 0.0], 0.01 / r * 3.0),
            ([0.01 * 0.94, 0.01 * 0.34, 0.0], 0.01 / r),
            ([0.0, 0.0, -0.01], 0.0),
        ] {
            let (a, b) = (
                forces(&prism, r - 0.02, v, omega),
                forces(&mesh, r - 0.02, v, omega),
            );
            let scale = a.force_n.iter().fold(0.0f64, |m, f| m.max(f.abs()));
            for k in 0..3 {
                assert!(
                    (a.force_n[k] - b.force_n[k]).abs() < 0.01 * scale,
                    "{v:?} {omega}: force {k}: prism {:?} mesh {:?}",
                    a.force_n,
                    b.force_n
                );
                assert!(
                    (a.moment_nm[k] - b.moment_nm[k]).abs() < 0.01 * scale * r,
                    "{v:?} {omega}: moment {k}: prism {:?} mesh {:?}",
                    a.moment_nm,
                    b.moment_nm
                );
            }
        }
    }

    /// Pressed straight down, a box bears on its bottom face alone what RFT's horizontal plate
    /// moving down bears at that depth, over that area; it has no drag, side force or moment.
    #[test]
    fn a_box_pressed_down_bears_what_a_flat_plate_does() {
        let (c, law) = sand();
        let size = [0.08, 0.05, 0.03];
        let body = Body::cuboid(size, [0.0, 0.0, -0.1], 0.01).unwrap();
        assert!((body.reach_m() - 0.115).abs() < 1e-12);
        let depth = 0.02;
        let f = forces(&body, 0.115 - depth, [0.0, 0.0, -0.01], 0.0);
        let (_, az) = c.alpha_along((1.0, 0.0), (0.0, -1.0));
        let plate = az * law.effective_depth_m(depth) * 1e6 * size[0] * size[1];
        assert!(plate > 0.0);
        assert!(
            (f.force_n[2] - plate).abs() < 1e-9 * plate,
            "{f:?} against {plate}"
        );
        for k in [0, 1] {
            assert!(f.force_n[k].abs() < 1e-9 * plate, "{f:?}");
        }
        assert!(f.moment_nm[0].abs() < 1e-9 * plate && f.moment_nm[2].abs() < 1e-9 * plate);
        // The bottom is 0.1 m below the hub but centred under it: no moment about the axle.
        assert!(f.moment_nm[1].abs() < 1e-9 * plate, "{f:?}");
    }

    /// A sphere dragged along its heading has no side force, roll or yaw; it bears more the
    /// deeper it goes; a finer sphere agrees with a coarser one; turned by a yaw of 90 degrees,
    /// a box dragged along x is the box as long as it was wide.
    #[test]
    fn a_sphere_is_symmetric_and_converges_and_a_placed_box_turns() {
        let coarse = Body::sphere(0.03, [0.0; 3], 24, 0.003).unwrap();
        let fine = Body::sphere(0.03, [0.0; 3], 48, 0.002).unwrap();
        let (a, b) = (
            forces(&coarse, 0.01, [0.01, 0.0, -0.005], 0.0),
            forces(&fine, 0.01, [0.01, 0.0, -0.005], 0.0),
        );
        assert!(a.force_n[2] > 0.0 && a.force_n[0] < 0.0, "{a:?}");
        for f in [&a, &b] {
            let s = f.force_n[2];
            assert!(f.force_n[1].abs() < 1e-6 * s, "{f:?}");
            // (A sphere's triangles split its quads one way: mirror symmetric to their size.)
            let m = 1e-3 * s * 0.03;
            assert!(
                f.moment_nm[0].abs() < m && f.moment_nm[2].abs() < m,
                "{f:?}"
            );
        }
        for k in [0, 2] {
            assert!(
                (a.force_n[k] - b.force_n[k]).abs() < 0.03 * b.force_n[k].abs(),
                "{a:?} against {b:?}"
            );
        }
        let deeper = forces(&fine, 0.0, [0.01, 0.0, -0.005], 0.0);
        assert!(deeper.force_n[2] > 1.5 * b.force_n[2]);

        let wide = Body::cuboid([0.05, 0.08, 0.03], [0.0; 3], 0.005).unwrap();
        // The long box's triangles, turned a quarter about z.
        let mut t = box_triangles([0.08, 0.05, 0.03], [0.0; 3]);
        place(&mut t, [0.0; 3], [0.0, 0.0, std::f64::consts::FRAC_PI_2]);
        let turned = Body::mesh(&t, 0.005).unwrap();
        let (p, q) = (
            forces(&wide, 0.0, [0.01, 0.0, 0.0], 0.0),
            forces(&turned, 0.0, [0.01, 0.0, 0.0], 0.0),
        );
        for k in 0..3 {
            assert!(
                (p.force_n[k] - q.force_n[k]).abs() < 1e-9,
                "{p:?} against {q:?}"
            );
        }
    }

    /// Every way a mesh can fail to be a body is refused, naming the triangle, edge or value.
    #[test]
    fn a_mesh_that_is_no_closed_body_is_refused_naming_what_is_wrong() {
        let good = box_triangles([0.02; 3], [0.0; 3]);
        assert!(Body::mesh(&good, 0.005).is_ok());
        let err = |t: &[Triangle]| Body::mesh(t, 0.005).unwrap_err().to_string();

        let open = &good[..11];
        let e = err(open);
        assert!(
            e.contains("not closed") && e.contains("on no other triangle"),
            "{e}"
        );

        let mut flipped = good.clone();
        flipped[5].swap(1, 2);
        let e = err(&flipped);
        assert!(e.contains("runs the same way in triangles"), "{e}");

        let mut inward = good.clone();
        for t in &mut inward {
            t.swap(1, 2);
        }
        let e = err(&inward);
        assert!(e.contains("face inward"), "{e}");

        let mut flat = good.clone();
        flat[3] = [flat[3][0], flat[3][1], flat[3][1]];
        let e = err(&flat);
        assert!(e.contains("triangle 3") && e.contains("has no area"), "{e}");

        let mut nan = good.clone();
        nan[7][2][1] = f64::NAN;
        let e = err(&nan);
        assert!(
            e.contains("triangle 7's vertex 2") && e.contains("NaN"),
            "{e}"
        );

        let mut mm = good.clone();
        place(&mut mm, [0.0; 3], [0.0; 3]);
        for t in &mut mm {
            for v in t.iter_mut() {
                *v = v.map(|x| x * 1e3);
            }
        }
        let e = err(&mm);
        assert!(e.contains("0.001"), "{e}");

        let e = Body::mesh(&good, 1e-6).unwrap_err().to_string();
        assert!(
            e.contains("elements of 0.000001 m") && e.contains("more than 2000000"),
            "{e}"
        );
        assert!(err(&good[..3]).contains("4 triangles or more"));
        for (e, what) in [
            (Body::sphere(-1.0, [0.0; 3], 12, 0.01), "sphere radius"),
            (
                Body::disc(0.02, f64::NAN, [0.0; 3], 32, 0.01),
                "disc thickness",
            ),
            (Body::cuboid([0.1, 0.0, 0.1], [0.0; 3], 0.01), "box width"),
        ] {
            let e = e.unwrap_err().to_string();
            assert!(e.contains(what), "{e}");
        }
    }
}
