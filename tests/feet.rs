//! Feet and meshes under load through `terzaghi steady`: a box foot given as `--shape box` and
//! as an STL file a CAD tool would write (binary, in millimetres) settle at the same sinkage
//! with the same forces; a sphere dragged at a slip angle is pushed against its sideways motion;
//! and meshes that are no closed body are refused, naming the triangle or edge.

#[path = "common/mod.rs"]
mod common;

use common::{ok, refused, repo, terzaghi};
use std::path::Path;
use std::process::Command;

const MEDIUM: &str = "tests/data/medium_without_shape.yaml";

/// A box of `size` (mm) centred at the origin, as binary STL triangles in mm.
fn box_triangles(size: [f32; 3]) -> Vec<[[f32; 3]; 3]> {
    terzaghi::model::box_triangles(size.map(f64::from), [0.0; 3])
        .iter()
        .map(|t| t.map(|v| v.map(|x| x as f32)))
        .collect()
}

/// Binary STL: an 80-byte header, the count, and per triangle a normal, three vertices and two
/// attribute bytes.
fn write_stl(path: &Path, triangles: &[[[f32; 3]; 3]]) {
    let mut b = vec![0u8; 80];
    b[..14].copy_from_slice(b"terzaghi tests");
    b.extend((triangles.len() as u32).to_le_bytes());
    for t in triangles {
        b.extend([0f32; 3].iter().flat_map(|v| v.to_le_bytes()));
        for v in t {
            b.extend(v.iter().flat_map(|c| c.to_le_bytes()));
        }
        b.extend([0u8; 2]);
    }
    std::fs::write(path, b).unwrap();
}

fn steady(runs: &Path, shape: &[&str]) -> Vec<Vec<f64>> {
    let out = Command::new(terzaghi())
        .current_dir(repo())
        .arg("steady")
        .arg(runs)
        .args(shape)
        .args(["--medium-file", MEDIUM])
        .output()
        .unwrap();
    let text = ok(&out);
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let want = [
        "sinkage_m",
        "drawbar_n",
        "side_n",
        "torque_nm",
        "load_borne_n",
    ];
    let at: Vec<usize> = want
        .iter()
        .map(|w| head.iter().position(|h| h == w).unwrap())
        .collect();
    lines
        .map(|l| {
            let v: Vec<&str> = l.split(',').collect();
            at.iter().map(|&i| v[i].parse().unwrap()).collect()
        })
        .collect()
}

fn runs(dir: &Path) -> std::path::PathBuf {
    let p = dir.join("runs.csv");
    std::fs::write(
        &p,
        "load_n,hub_vx_m_s,omega_rad_s,slip_angle_deg\n4,0.01,0,0\n8,0.01,0,0\n8,0.01,0,15\n8,0.01,0,-15\n",
    )
    .unwrap();
    p
}

#[test]
fn a_box_foot_from_an_stl_in_mm_settles_as_the_box_shape_does() {
    let dir = tempfile::tempdir().unwrap();
    let runs = runs(dir.path());
    let stl = dir.path().join("foot.stl");
    write_stl(&stl, &box_triangles([60.0, 40.0, 30.0]));
    let from_stl = steady(
        &runs,
        &[
            "--shape",
            "mesh",
            "--mesh-file",
            stl.to_str().unwrap(),
            "--mesh-scale",
            "0.001",
        ],
    );
    let shape = steady(&runs, &["--shape", "box", "--size-m", "0.06,0.04,0.03"]);
    for (a, b) in from_stl.iter().zip(&shape) {
        for (x, y) in a.iter().zip(b) {
            assert!(
                (x - y).abs() <= 1e-6 * (1.0 + y.abs()),
                "{a:?} against {b:?}"
            );
        }
    }
    // More load sinks it deeper and drags harder; the sand bears the load asked.
    let (light, heavy) = (&shape[0], &shape[1]);
    assert!(
        heavy[0] > light[0] && heavy[1] < light[1] && light[1] < 0.0,
        "{shape:?}"
    );
    for (r, load) in shape.iter().zip([4.0, 8.0, 8.0, 8.0]) {
        assert!((r[4] - load).abs() < 0.01 * load, "{r:?}");
    }
    // At a slip angle either way: the same side force, against the sideways motion.
    let (left, right) = (&shape[2], &shape[3]);
    assert!(
        left[2] > 0.0 && (left[2] - right[2]).abs() < 1e-6 * left[2],
        "{shape:?}"
    );
}

#[test]
fn a_sphere_foot_is_pushed_against_its_sideways_motion() {
    let dir = tempfile::tempdir().unwrap();
    let runs = runs(dir.path());
    let r = steady(&runs, &["--shape", "sphere", "--radius-m", "0.03"]);
    assert!(r[0][2].abs() < 1e-9 * r[0][4] && r[1][2].abs() < 1e-9 * r[1][4]);
    assert!(r[2][2] > 0.05 * r[2][4], "{r:?}");
    assert!((r[2][2] - r[3][2]).abs() < 0.01 * r[2][2], "{r:?}");
    // A disc of the same radius, thick enough to bear the load.
    let d = steady(
        &runs,
        &[
            "--shape",
            "disc",
            "--radius-m",
            "0.03",
            "--thickness-m",
            "0.05",
        ],
    );
    assert!(d.iter().all(|row| row[0] > 0.0 && row[0] < 0.05), "{d:?}");
}

#[test]
fn a_mesh_that_is_no_closed_body_or_no_stl_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let runs = runs(dir.path());
    let stl = dir.path().join("open.stl");
    let mut t = box_triangles([60.0, 40.0, 30.0]);
    t.remove(4);
    write_stl(&stl, &t);
    let args = |f: &Path| -> Vec<std::ffi::OsString> {
        [
            "steady".into(),
            runs.clone().into_os_string(),
            "--shape".into(),
            "mesh".into(),
            "--mesh-file".into(),
            f.as_os_str().to_owned(),
            "--mesh-scale".into(),
            "0.001".into(),
            "--medium-file".into(),
            repo().join(MEDIUM).into_os_string(),
        ]
        .to_vec()
    };
    let refused_with = |f: &Path, words: &[&str]| {
        let a = args(f);
        let a: Vec<&std::ffi::OsStr> = a.iter().map(|s| s.as_os_str()).collect();
        refused(&a, words);
    };
    refused_with(&stl, &["open.stl is no body", "not closed", "of triangle"]);
    let mut flat = box_triangles([60.0, 40.0, 30.0]);
    flat[6][2] = flat[6][1];
    write_stl(&stl, &flat);
    refused_with(&stl, &["triangle 6", "has no area"]);
    let cut = dir.path().join("cut.stl");
    let bytes = std::fs::read(&stl).unwrap();
    std::fs::write(&cut, &bytes[..bytes.len() - 20]).unwrap();
    refused_with(&cut, &["cut.stl is no STL file", "12 triangles"]);
    // In mm without its scale: a body 60 m long is none.
    write_stl(&stl, &box_triangles([60.0, 40.0, 30.0]));
    let a = args(&stl);
    let mut a: Vec<&std::ffi::OsStr> = a.iter().map(|s| s.as_os_str()).collect();
    a[7] = std::ffi::OsStr::new("1");
    refused(&a, &["78.102 m corner to corner", "scale of 0.001"]);
    // A flag of another shape.
    let a = [
        "steady",
        runs.to_str().unwrap(),
        "--shape",
        "sphere",
        "--radius-m",
        "0.03",
        "--thickness-m",
        "0.01",
        "--medium-file",
        MEDIUM,
    ]
    .map(std::ffi::OsStr::new);
    let out = Command::new(terzaghi())
        .current_dir(repo())
        .args(a)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--shape sphere takes no --thickness-m"));
}

/// docs/bodies.md shows the sphere foot's runs as the command prints them today.
#[test]
fn the_docs_sphere_foot_is_what_the_command_prints() {
    let out = Command::new(terzaghi())
        .current_dir(repo())
        .args([
            "steady",
            "tests/data/feet/runs.csv",
            "--shape",
            "sphere",
            "--radius-m",
            "0.03",
            "--medium-file",
            MEDIUM,
        ])
        .output()
        .unwrap();
    let csv = ok(&out);
    let doc = std::fs::read_to_string(repo().join("docs/bodies.md")).unwrap();
    assert!(
        doc.contains(&csv),
        "docs/bodies.md's sphere foot is stale; the command prints:\n{csv}"
    );
}

/// The testbed's LIGGGHTS: a box foot 50 x 20 x 50 mm dragged through its bed at slip angles
/// of 20 and 40 degrees, its bottom 20, 30 and 40 mm deep (`tests/dem/campaign.py
/// --side-force`), against `terzaghi steady` held at each drag's depth in the medium the bed's
/// own intrusion tests calibrated (nothing fitted to the foot): the side force at R^2 >= 0.8,
/// pushing against the sideways motion in every drag, as docs/bodies.md shows it.
#[test]
fn a_box_foot_at_two_slip_angles_meets_the_dem_side_force() {
    let out = Command::new(terzaghi())
        .current_dir(repo())
        .args([
            "steady",
            "tests/dem/campaign/side_force_runs.csv",
            "--shape",
            "box",
            "--size-m",
            "0.05,0.02,0.05",
            "--medium-file",
            "tests/dem/campaign/medium_from_intrusions.yaml",
            "--at-sinkage",
            "sinkage_m",
            "--group-by",
            "slip_angle_deg",
        ])
        .output()
        .unwrap();
    let csv = ok(&out);
    let summary = String::from_utf8_lossy(&out.stderr).to_string();
    let r2 = |column: &str| -> f64 {
        let line = summary
            .lines()
            .find(|l| l.trim_start().starts_with(column))
            .unwrap_or_else(|| panic!("no {column} in:\n{summary}"));
        line.split_whitespace().nth(2).unwrap().parse().unwrap()
    };
    assert!(r2("side_n") >= 0.8, "{summary}");
    let mut lines = csv.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| head.iter().position(|h| *h == n).unwrap();
    let (measured, predicted) = (col("measured_side_n"), col("side_n"));
    let mut drags = 0;
    for l in lines {
        // (the name column is skipped, and the last, borne, is true)
        assert!(l.ends_with(",true"), "{l}");
        let v: Vec<f64> = l
            .split(',')
            .skip(1)
            .take(head.len() - 2)
            .map(|x| x.parse().unwrap())
            .collect();
        assert!(v[measured - 1] > 0.0 && v[predicted - 1] > 0.0, "{l}");
        drags += 1;
    }
    assert_eq!(drags, 6);
    let doc = std::fs::read_to_string(repo().join("docs/bodies.md")).unwrap();
    assert!(
        doc.contains(summary.trim_end()),
        "docs/bodies.md's DEM foot is stale; the command prints:\n{summary}"
    );
}
