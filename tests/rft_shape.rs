//! RFT's shape measured from intrusion tests (`terzaghi calibrate` on tests of a small plate
//! moving in any direction): the format's refusals, a medium file of the DEM testbed's bed
//! calibrated from its own intrusion tests, the testbed's C-leg and flat plate predicted from it
//! through the node with nothing fitted to the legs, upward motion, and the file read alike by
//! the node and `predict` (the Python package's own test compares it with `predict`).

#[path = "common/mod.rs"]
mod common;

use common::{ok, refused, repo, terzaghi};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The campaign's intrusion tests (tests/dem/campaign/intrusions).
fn dem_tests() -> Vec<PathBuf> {
    let dir = repo().join("tests/dem/campaign/intrusions");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "csv"))
        .collect();
    v.sort();
    assert_eq!(
        v.len(),
        90,
        "the campaign's 90 intrusion tests ship with the repository"
    );
    v
}

/// The committed medium file the docs' figures use.
const DEM_MEDIUM: &str = "tests/dem/campaign/medium_from_intrusions.yaml";

/// A plate 25 mm square at `chord_deg` pushed at 0.05 m/s in the direction `gamma_deg` below
/// the horizontal from `depth0` (m), with a force that grows with depth.
fn intrusion_csv(depth0: f64, gamma_deg: f64) -> String {
    let mut s = String::from("t_s,x_m,depth_m,fx_n,fz_n\n");
    let g = gamma_deg.to_radians();
    for i in 0..200 {
        let t = i as f64 * 0.004;
        let d = depth0 + 0.05 * t * g.sin();
        let f = if d > 0.0 { 3000.0 * d } else { 0.0 };
        s += &format!("{t},{},{d},{},{}\n", 0.05 * t * g.cos(), -0.5 * f, f);
    }
    s
}

#[test]
fn bad_intrusion_tests_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, csv: &str, json: &str| {
        let p = dir.path().join(format!("{name}.csv"));
        std::fs::write(&p, csv).unwrap();
        std::fs::write(p.with_extension("json"), json).unwrap();
        p
    };
    let good_json = r#"{"plate_chord_m": 0.025, "plate_width_m": 0.025, "chord_angle_deg": 0, "unit_weight_n_m3": 14000}"#;
    let calibrate = |p: &Path, words: &[&str]| {
        refused(&["calibrate".as_ref(), p.as_os_str()], words);
    };
    // A JSON key missing, one misspelt, the angle out of range, a size not positive.
    let missing = write(
        "missing",
        &intrusion_csv(0.01, 90.0),
        r#"{"plate_chord_m": 0.025, "chord_angle_deg": 0}"#,
    );
    calibrate(&missing, &["missing.json", "plate_width_m"]);
    let misspelt = write(
        "misspelt",
        &intrusion_csv(0.01, 90.0),
        r#"{"plate_chord_m": 0.025, "plate_width_m": 0.025, "chord_angle": 0}"#,
    );
    calibrate(&misspelt, &["misspelt.json", "chord_angle"]);
    let angle = write(
        "angle",
        &intrusion_csv(0.01, 90.0),
        r#"{"plate_chord_m": 0.025, "plate_width_m": 0.025, "chord_angle_deg": 270}"#,
    );
    calibrate(&angle, &["angle.csv", "chord_angle_deg", "270"]);
    let size = write(
        "size",
        &intrusion_csv(0.01, 90.0),
        r#"{"plate_chord_m": 0, "plate_width_m": 0.025, "chord_angle_deg": 0}"#,
    );
    calibrate(&size, &["size.csv", "plate_chord_m", "0"]);
    // No JSON at all.
    let bare = dir.path().join("bare.csv");
    std::fs::write(&bare, intrusion_csv(0.01, 90.0)).unwrap();
    calibrate(&bare, &["bare.json", "plate_chord_m"]);
    // A NaN force, a word, time going back.
    let mut lines: Vec<String> = intrusion_csv(0.01, 90.0)
        .lines()
        .map(str::to_string)
        .collect();
    let cells: Vec<String> = lines[5].split(',').map(str::to_string).collect();
    lines[5] = format!("{},{},{},{},NaN", cells[0], cells[1], cells[2], cells[3]);
    let nan = write("nan", &(lines.join("\n") + "\n"), good_json);
    calibrate(&nan, &["nan.csv line 6", "fz_n", "NaN"]);
    let back = write(
        "back",
        "t_s,x_m,depth_m,fx_n,fz_n\n0,0,0.01,0,1\n1,0,0.02,0,2\n0.5,0,0.03,0,3\n",
        good_json,
    );
    calibrate(&back, &["back.csv", "row 3", "t_s 0.5"]);
    // An unknown column.
    let column = write(
        "column",
        "t_s,x_m,depth_m,fx_n,fz_n,fy_n\n0,0,0.01,0,1,0\n1,0,0.02,0,2,0\n",
        good_json,
    );
    // A CSV with x_m and fx_n is an intrusion test: its unknown column is named.
    calibrate(&column, &["column.csv", "fy_n"]);
    // A plate that never enters the medium: no loaded row.
    let above = write("above", &intrusion_csv(-0.05, 0.0), good_json);
    calibrate(&above, &["above", "no row with the plate in the medium"]);
    // A JSON speed the log does not move at.
    let fast = write(
        "fast",
        &intrusion_csv(0.01, 90.0),
        r#"{"plate_chord_m": 0.025, "plate_width_m": 0.025, "chord_angle_deg": 0, "speed_m_s": 0.5, "unit_weight_n_m3": 14000}"#,
    );
    calibrate(&fast, &["fast.csv", "speed_m_s 0.5", "0.0500 m/s"]);
    // Intrusion tests alone with no unit weight anywhere.
    let no_weight = write(
        "no_weight",
        &intrusion_csv(0.01, 90.0),
        r#"{"plate_chord_m": 0.025, "plate_width_m": 0.025, "chord_angle_deg": 0}"#,
    );
    calibrate(&no_weight, &["unit_weight_n_m3", "--unit-weight-n-m3"]);
    // --law is a plate-sinkage law's choice.
    let good = write("good", &intrusion_csv(0.01, 90.0), good_json);
    refused(
        &[
            "calibrate".as_ref(),
            good.as_os_str(),
            "--law".as_ref(),
            "bekker".as_ref(),
        ],
        &["--law", "intrusion test"],
    );
    // Pushed straight down alone: a medium, whose shape is the preset's, scaled, and says so.
    let out = dir.path().join("down.yaml");
    let printed = ok(&Command::new(terzaghi())
        .arg("calibrate")
        .arg(&good)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap());
    assert!(printed.contains("form preset_scaled"), "{printed}");
    let listed = ok(&Command::new(terzaghi())
        .arg("media")
        .arg(&out)
        .output()
        .unwrap());
    assert!(
        listed.contains("RFT's shape: a preset's, scaled"),
        "{listed}"
    );
}

/// A medium file written before media carried a shape (the plate-sinkage runs' `rft_depth_power`
/// law, as `calibrate` wrote it then) still loads, and says its shape is a preset's.
#[test]
fn a_medium_file_without_a_shape_still_loads_and_says_so() {
    let file = repo().join("tests/data/medium_without_shape.yaml");
    let listed = ok(&Command::new(terzaghi())
        .arg("media")
        .arg(&file)
        .output()
        .unwrap());
    assert!(
        listed.contains("RFT's shape: poppy_lp's (a preset, not measured"),
        "{listed}"
    );
    let printed = ok(&Command::new(terzaghi())
        .args([
            "predict",
            "--model",
            "rft",
            "--shape",
            "c-leg",
            "--length-m",
            "0.1",
            "--width-m",
            "0.03",
            "--hip-height-m",
            "0.04",
            "--beta-deg",
            "60:60:1",
            "--medium-file",
        ])
        .arg(&file)
        .output()
        .unwrap());
    assert!(printed.lines().count() == 2, "{printed}");
}

/// `terzaghi replay SESSION --reevaluate --params-file PARAMS EXTRA... -o /dev/null` from the
/// repository's root: its printed `RMSE ... (R^2 drag ..., lift ...)` as (RMSE, R^2 drag, R^2
/// lift).
fn reevaluated(session: &str, params: &str, extra: &[&str]) -> (f64, f64, f64) {
    let out = Command::new(terzaghi())
        .current_dir(repo())
        .args([
            "replay",
            session,
            "--reevaluate",
            "--params-file",
            params,
            "-o",
            "/dev/null",
        ])
        .args(extra)
        .output()
        .unwrap();
    let printed = ok(&out) + &String::from_utf8_lossy(&out.stderr);
    let after = |what: &str| -> f64 {
        let at = printed.find(what).unwrap_or_else(|| panic!("{printed}")) + what.len();
        printed[at..]
            .split([',', ')', ' '])
            .next()
            .unwrap()
            .trim()
            .parse()
            .unwrap_or_else(|e| panic!("{what}: {e} in {printed}"))
    };
    (after("RMSE "), after("R^2 drag "), after("lift "))
}

fn cell(e: (f64, f64, f64)) -> String {
    format!("`RMSE {:.3} N (R^2 drag {:.3}, lift {:.3})`", e.0, e.1, e.2)
}

/// The testbed's C-leg from its bed's own intrusion tests, nothing fitted to the leg: the
/// medium file `calibrate` writes from the campaign's 90 tests (the committed one, which the
/// command remakes to 1e-9) predicts every stroke speed of the campaign at R^2 0.85 or more for
/// drag and lift through the node's own code, with a smaller error than the same bed calibrated
/// from its vertical tests alone (poppy_lp's shape, scaled) and than the grid of buried
/// intrusions with its speed law. The flat plate's rows are printed as the docs give them.
#[test]
fn the_testbeds_legs_are_predicted_from_the_beds_own_intrusion_tests() {
    let dir = tempfile::tempdir().unwrap();
    let remade = dir.path().join("remade.yaml");
    let rel: Vec<String> = dem_tests()
        .iter()
        .map(|p| p.strip_prefix(repo()).unwrap().display().to_string())
        .collect();
    let printed = ok(&Command::new(terzaghi())
        .current_dir(repo())
        .arg("calibrate")
        .args(&rel)
        .arg("--cross-validate")
        .arg("-o")
        .arg(&remade)
        .arg("--report")
        .arg(dir.path().join("shape.html"))
        .output()
        .unwrap());
    assert!(printed.contains("form li_nine"), "{printed}");
    // The report a lab reads: a plot per direction of motion, measured against fitted and
    // held-out stresses over the attack angle.
    let html = std::fs::read_to_string(dir.path().join("shape.html")).unwrap();
    for d in [-90, -45, 0, 45, 90] {
        assert!(
            html.contains(&format!("<h2>Moving {d} deg below the horizontal</h2>")),
            "{d} deg"
        );
    }
    assert_eq!(html.matches("<svg").count(), 5);
    // The docs' two blocks of its output, line by line.
    let page = std::fs::read_to_string(repo().join("docs/calibration.md")).unwrap();
    let blocks: Vec<&str> = page
        .split("```text\n")
        .skip(2)
        .take(2)
        .map(|b| b.split("```").next().unwrap())
        .collect();
    assert_eq!(blocks.len(), 2);
    for line in blocks.iter().flat_map(|b| b.lines()) {
        assert!(
            printed.contains(line),
            "calibrate no longer prints {line:?}:\n{printed}"
        );
    }
    let yaml = |p: &Path| -> serde_yaml_ng::Value {
        serde_yaml_ng::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    let (a, b) = (yaml(&remade), yaml(&repo().join(DEM_MEDIUM)));
    let (sa, sb) = (&a["rft_shape"], &b["rft_shape"]);
    for name in [
        "A00", "A10", "B11", "B01", "B-11", "C11", "C01", "C-11", "D10",
    ] {
        let (x, y) = (
            sa["coefficients_n_cm3"][name].as_f64().unwrap(),
            sb["coefficients_n_cm3"][name].as_f64().unwrap(),
        );
        assert!((x - y).abs() < 1e-9, "{name}: {x} remade, {y} committed");
    }
    for key in ["depth_exponent", "surface_offset_m"] {
        let (x, y) = (sa[key].as_f64().unwrap(), sb[key].as_f64().unwrap());
        assert!((x - y).abs() < 1e-9, "{key}: {x} remade, {y} committed");
    }
    assert_eq!(
        sa["speed_law"]["gains"].as_sequence().unwrap().len(),
        5,
        "a gain for each of down, oblique, across, up obliquely, up"
    );
    // The same bed from its tests moving straight down alone: the preset's shape, scaled.
    let vertical = dir.path().join("vertical.yaml");
    let vertical_tests: Vec<&String> = rel.iter().filter(|p| p.contains("_b+00_g+90")).collect();
    assert_eq!(vertical_tests.len(), 5);
    let printed = ok(&Command::new(terzaghi())
        .current_dir(repo())
        .arg("calibrate")
        .args(&vertical_tests)
        .arg("-o")
        .arg(&vertical)
        .output()
        .unwrap());
    assert!(printed.contains("form preset_scaled"), "{printed}");
    let vertical_medium = format!("leg.medium:={}", vertical.display());
    let docs = common::docs_text();
    let measured_cfg = "launch_configs/dem_cleg_from_tests.yaml";
    let grid_cfg = "launch_configs/dem_cleg.yaml";
    for run in [
        "cleg",
        "dx_cleg_w025_s1",
        "dx_cleg_w050_s2",
        "dx_cleg_w075_s3",
    ] {
        let session = format!("tests/dem/campaign/runs/{run}.mcap");
        let preset = reevaluated(&session, measured_cfg, &["-p", &vertical_medium]);
        let grid = reevaluated(&session, grid_cfg, &["-p", "use_identified:=false"]);
        let measured = reevaluated(&session, measured_cfg, &[]);
        let row = format!(
            "| `{run}` | {} | {} | {} |",
            cell(preset),
            cell(grid),
            cell(measured)
        );
        println!("{row}");
        assert!(docs.contains(&row), "the docs lack {row}");
        assert!(
            measured.1 >= 0.85 && measured.2 >= 0.85,
            "{run}: {measured:?}"
        );
        assert!(
            measured.0 < preset.0 && measured.0 < grid.0,
            "{run}: measured {measured:?}, preset {preset:?}, grid {grid:?}"
        );
    }
    // The flat plate, the same files (`-p leg.shape:=plate`): as printed, where it loses too.
    for run in [
        "qs_b030_h040",
        "dx_fast_w025_s1",
        "dx_fast_w050_s2",
        "dx_fast_w075_s3",
    ] {
        let session = format!("tests/dem/campaign/runs/{run}.mcap");
        let plate = ["-p", "leg.shape:=plate"];
        let preset = reevaluated(
            &session,
            measured_cfg,
            &["-p", "leg.shape:=plate", "-p", &vertical_medium],
        );
        let grid = reevaluated(
            &session,
            grid_cfg,
            &["-p", "use_identified:=false", "-p", "leg.shape:=plate"],
        );
        let measured = reevaluated(&session, measured_cfg, &plate);
        let row = format!(
            "| `{run}` (plate) | {} | {} | {} |",
            cell(preset),
            cell(grid),
            cell(measured)
        );
        println!("{row}");
        assert!(docs.contains(&row), "the docs lack {row}");
        assert!(measured.1 >= 0.85, "{run}: {measured:?}");
    }
}

/// The same medium file read by the node (`replay --reevaluate` of a C-leg turning slower than
/// the shape's reference speed, so that the speed law adds nothing) and by `predict`: equal to
/// 1e-12 N at every angle. (The Python package's test compares its `predict`, `LegBatch` and
/// `Node` with `predict` to 1e-12.)
#[test]
fn the_node_and_predict_read_a_measured_medium_alike() {
    let dir = tempfile::tempdir().unwrap();
    let medium = repo().join(DEM_MEDIUM);
    // 1 deg a second: the C-leg's tip at under 2 mm/s.
    let log = dir.path().join("slow.csv");
    let mut text = String::from("t_s,beta_rad,drag_n,lift_n\n");
    for k in 0..=200 {
        let beta = (-20.0 + f64::from(k)).to_radians();
        text += &format!("{},{beta},0,0\n", f64::from(k));
    }
    std::fs::write(&log, text).unwrap();
    let params = dir.path().join("leg.yaml");
    std::fs::write(
        &params,
        format!(
            "/**:\n  ros__parameters:\n    model: rft\n    legs: [leg]\n    use_identified: false\n    leg:\n      joint: hip\n      length_m: 0.1\n      width_m: 0.03\n      hip_height_m: 0.04\n      shape: c_leg\n      medium: {}\n      ft_topic: /leg/ft\n",
            medium.display()
        ),
    )
    .unwrap();
    let rows = dir.path().join("rows.csv");
    ok(&Command::new(terzaghi())
        .args(["replay", "--reevaluate"])
        .arg(&log)
        .arg("--params-file")
        .arg(&params)
        .arg("-o")
        .arg(&rows)
        .output()
        .unwrap());
    let predicted = ok(&Command::new(terzaghi())
        .args([
            "predict",
            "--model",
            "rft",
            "--shape",
            "c-leg",
            "--length-m",
            "0.1",
            "--width-m",
            "0.03",
            "--hip-height-m",
            "0.04",
            "--beta-deg",
            "-20:180:1",
            "--format",
            "json",
            "--medium-file",
        ])
        .arg(&medium)
        .output()
        .unwrap());
    let predicted: Vec<serde_json::Value> = serde_json::from_str(&predicted).unwrap();
    let mut rdr = csv::Reader::from_path(&rows).unwrap();
    let h = rdr.headers().unwrap().clone();
    let col = |c: &str| h.iter().position(|x| x == c).unwrap();
    let (id, il) = (col("predicted_drag_n"), col("predicted_lift_n"));
    let node: Vec<(f64, f64)> = rdr
        .records()
        .map(|r| {
            let r = r.unwrap();
            (r[id].parse().unwrap(), r[il].parse().unwrap())
        })
        .collect();
    assert_eq!(node.len(), predicted.len());
    let mut loaded = 0;
    for (n, p) in node.iter().zip(&predicted) {
        let (d, l) = (p["drag_n"].as_f64().unwrap(), p["lift_n"].as_f64().unwrap());
        assert!(
            (n.0 - d).abs() < 1e-12 && (n.1 - l).abs() < 1e-12,
            "node {n:?}, predict ({d}, {l})"
        );
        loaded += usize::from(l.abs() > 1.0);
    }
    assert!(loaded > 50, "{loaded} angles with a force");
}

/// Upward motion is measured, not borrowed: each DEM test of the plate pulled straight up
/// through the bed, predicted by the shape fitted to every other test (the other upward ones
/// among them), against the shape fitted to the tests that do not move up at all. With upward
/// tests in the fit, the held-out plate's vertical force is predicted with its sign (the bed
/// holds it down) and a smaller error.
#[test]
fn a_plate_pulled_up_is_predicted_from_the_other_tests() {
    use terzaghi::ident::rft_shape::{ShapeOptions, fit_shape, predict_test};
    use terzaghi::session::intrusion_test::read_intrusion_test;
    let tests: Vec<_> = dem_tests()
        .iter()
        .map(|p| read_intrusion_test(p).unwrap().test)
        .collect();
    let o = ShapeOptions::default();
    let up = |t: &terzaghi::ident::rft_shape::IntrusionTest| t.name.ends_with("_g-90");
    let slow = |t: &terzaghi::ident::rft_shape::IntrusionTest| t.name.contains("_v005_");
    let without_up: Vec<_> = tests
        .iter()
        .filter(|t| !up(t) && !t.name.ends_with("_g-45"))
        .cloned()
        .collect();
    let no_up_fit = fit_shape(&without_up, &o).unwrap();
    let (mut with_sse, mut without_sse, mut rows, mut sign_right) = (0.0, 0.0, 0usize, 0usize);
    let held: Vec<_> = tests.iter().filter(|t| up(t) && slow(t)).collect();
    assert_eq!(held.len(), 9);
    for t in &held {
        let others: Vec<_> = tests.iter().filter(|o| o.name != t.name).cloned().collect();
        let fit = fit_shape(&others, &o).unwrap();
        let with = predict_test(&fit, t, &o);
        let without = predict_test(&no_up_fit, t, &o);
        let (mut measured_sum, mut predicted_sum) = (0.0, 0.0);
        for ((i, _, fz), (_, _, fz0)) in with.iter().zip(&without) {
            let m = t.rows[*i].fz_n;
            with_sse += (fz - m).powi(2);
            without_sse += (fz0 - m).powi(2);
            measured_sum += m;
            predicted_sum += fz;
            rows += 1;
        }
        sign_right += usize::from(measured_sum < 0.0 && predicted_sum < 0.0);
    }
    let (with_rmse, without_rmse) = (
        (with_sse / rows as f64).sqrt(),
        (without_sse / rows as f64).sqrt(),
    );
    println!(
        "plates pulled up, held out: fz RMSE {with_rmse:.3} N with the other upward tests, {without_rmse:.3} N without any ({rows} rows, {sign_right} of 9 pulled down)"
    );
    assert_eq!(sign_right, 9);
    assert!(
        with_rmse < without_rmse,
        "{with_rmse} against {without_rmse}"
    );
    let line = format!(
        "plates pulled up, held out: fz RMSE {with_rmse:.3} N with the other upward tests, {without_rmse:.3} N without any ({rows} rows, {sign_right} of 9 pulled down)"
    );
    assert!(common::docs_text().contains(&line), "the docs lack {line}");
}

/// The nine plate-sinkage runs of the real sand, as `tests/data/medium_without_shape.yaml` was
/// calibrated on (from the repository's top).
fn plate_runs() -> Vec<String> {
    [
        "run1_D60mm",
        "run2_D60mm",
        "run3_D60mm",
        "run4_D100mm",
        "run5_D100mm",
        "run6_D100mm",
        "run7_D80mm",
        "run8_D80mm",
        "run9_D80mm",
    ]
    .iter()
    .map(|r| format!("tests/data/real-plate-sinkage/plate_smallbox_{r}.csv"))
    .collect()
}

/// A shape borrowed from another medium (`calibrate PLATES --shape-from MEDIUM`): the real
/// sand's plates with the DEM bed's measured shape. The command remakes the committed file
/// (`tests/data/medium_dem_shape.yaml`, docs/bodies.md's figures) to 1e-9; the shape is the
/// bed's, every coefficient times one scale; a foot pressed straight down feels the plates' law
/// exactly as the file without a shape gives it; the file says where its shape came from and
/// that it was not measured in this sand. A medium without a shape, intrusion tests beside the
/// plates, or another law are refused by name.
#[test]
fn a_shape_borrowed_from_another_medium_is_scaled_to_the_plates() {
    let dir = tempfile::tempdir().unwrap();
    let remade = dir.path().join("borrowed.yaml");
    let calibrate = |extra: &[&str], out: &Path| {
        Command::new(terzaghi())
            .current_dir(repo())
            .arg("calibrate")
            .args(plate_runs())
            .args(extra)
            .arg("-o")
            .arg(out)
            .output()
            .unwrap()
    };
    let printed = ok(&calibrate(
        &["--shape-from", DEM_MEDIUM, "--name", "plate_runs_dem_shape"],
        &remade,
    ));
    assert!(printed.contains("RFT's shape borrowed from"), "{printed}");
    let yaml = |p: &Path| -> serde_yaml_ng::Value {
        serde_yaml_ng::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    let committed = repo().join("tests/data/medium_dem_shape.yaml");
    let (a, b, bed) = (
        yaml(&remade),
        yaml(&committed),
        yaml(&repo().join(DEM_MEDIUM)),
    );
    let coefficient = |v: &serde_yaml_ng::Value, name: &str| {
        v["rft_shape"]["coefficients_n_cm3"][name].as_f64().unwrap()
    };
    let scale = coefficient(&a, "A00") / coefficient(&bed, "A00");
    assert!(scale > 1.0 && scale.is_finite(), "{scale}");
    for name in [
        "A00", "A10", "B11", "B01", "B-11", "C11", "C01", "C-11", "D10",
    ] {
        let (x, y) = (coefficient(&a, name), coefficient(&b, name));
        assert!((x - y).abs() < 1e-9, "{name}: {x} remade, {y} committed");
        let z = coefficient(&bed, name);
        assert!(
            (x - scale * z).abs() <= 1e-12 * x.abs(),
            "{name}: {x} against {z}"
        );
    }
    // The plates' law in depth, no offset or speed law of the bed's.
    let shape = &a["rft_shape"];
    assert_eq!(shape["depth_exponent"], a["params"]["n"]);
    assert_eq!(shape["surface_offset_m"].as_f64(), Some(0.0));
    assert!(shape["speed_law"].is_null());
    assert!(
        shape["borrowed_from"]
            .as_str()
            .unwrap()
            .contains(DEM_MEDIUM),
        "{shape:?}"
    );
    // Pressed straight down: the plates' law, as the file without a shape gives it.
    let pressed = |medium: &str| -> f64 {
        let out = ok(&Command::new(terzaghi())
            .current_dir(repo())
            .args([
                "predict",
                "--model",
                "rft",
                "--shape",
                "disc",
                "--radius-m",
                "0.04",
                "--thickness-m",
                "0.005",
                "--hip-height-m",
                "-0.02",
                "--up-m-s",
                "-0.005",
                "--beta-deg",
                "0:0:1",
                "--medium-file",
                medium,
            ])
            .output()
            .unwrap());
        let row = out.lines().nth(1).unwrap();
        row.split(',').nth(4).unwrap().parse().unwrap()
    };
    let (borrowed, plates) = (
        pressed("tests/data/medium_dem_shape.yaml"),
        pressed("tests/data/medium_without_shape.yaml"),
    );
    assert!(
        plates > 50.0 && (borrowed - plates).abs() <= 1e-9 * plates,
        "{borrowed} N with the borrowed shape, {plates} N with the plates' preset"
    );
    let listed = ok(&Command::new(terzaghi())
        .arg("media")
        .arg(&committed)
        .output()
        .unwrap());
    assert!(
        listed
            .contains("RFT's shape: borrowed from tests/dem/campaign/medium_from_intrusions.yaml"),
        "{listed}"
    );
    // Refused by name.
    let refusal = |extra: &[&str], words: &[&str]| {
        let out = calibrate(extra, &dir.path().join("refused.yaml"));
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{extra:?}: {err}");
        for w in words {
            assert!(err.contains(w), "{w:?} not in: {err}");
        }
        assert!(!err.contains("panicked"), "{err}");
    };
    refusal(
        &["--shape-from", "tests/data/medium_without_shape.yaml"],
        &["medium_without_shape.yaml", "carries no RFT shape"],
    );
    refusal(
        &["--shape-from", DEM_MEDIUM, "--law", "bekker"],
        &["--shape-from", "--law is bekker"],
    );
    refusal(
        &[
            "--shape-from",
            DEM_MEDIUM,
            "tests/dem/campaign/intrusions/it_buried_v005_b+00_g+00.csv",
        ],
        &["--shape-from", "9 plate-sinkage and 1 intrusion tests"],
    );
    refusal(
        &["--shape-from", "tests/data/no-such-medium.yaml"],
        &["no-such-medium.yaml"],
    );
    assert!(!dir.path().join("refused.yaml").exists());
    // Borrowed again, from the borrowed file: where the shape was measured stays said.
    let again = dir.path().join("again.yaml");
    ok(&calibrate(
        &["--shape-from", "tests/data/medium_dem_shape.yaml"],
        &again,
    ));
    let chain = yaml(&again)["rft_shape"]["borrowed_from"]
        .as_str()
        .unwrap()
        .to_string();
    assert!(
        chain.starts_with("tests/data/medium_dem_shape.yaml") && chain.contains(DEM_MEDIUM),
        "{chain}"
    );
    // Scaled to the same plates again: the same coefficients (to rounding).
    let (x, y) = (coefficient(&yaml(&again), "A00"), coefficient(&a, "A00"));
    assert!((x - y).abs() <= 1e-12 * y, "{x} against {y}");
}

/// The DEM bed's C-leg, turning through fresh sand, with the bed's medium and the bearing of
/// sheared sand of its own friction angle (`tan(2/3 x 23.446 deg)`, `m` 2, the physics alone):
/// a planar leg takes it only when `<leg>.sheared_bearing` asks (the figure without is the
/// one of the bed's file alone, to the digit), and with it the C-leg's lift is lost where the
/// bed keeps it; docs/bodies.md shows both.
#[test]
fn a_c_leg_takes_the_sheared_bearing_only_when_asked_and_loses_lift_with_it() {
    let dir = tempfile::tempdir().unwrap();
    let medium = dir.path().join("sheared.yaml");
    let tan = (2.0f64 / 3.0 * 23.446f64).to_radians().tan();
    std::fs::write(
        &medium,
        std::fs::read_to_string(repo().join(DEM_MEDIUM)).unwrap()
            + &format!(
                "sheared_bearing:\n  interface_tan: {tan}\n  exponent: 2.0\n  std_dev:\n    interface_tan: 0.0\n    exponent: 0.0\n  source: the physics alone, tan(2/3 x the bed's friction angle 23.446 deg), m 2\n"
            ),
    )
    .unwrap();
    let m = format!("leg.medium:={}", medium.display());
    let run = "tests/dem/campaign/runs/cleg.mcap";
    let params = "launch_configs/dem_cleg_from_tests.yaml";
    let alone = reevaluated(run, params, &[]);
    let unasked = reevaluated(run, params, &["-p", &m]);
    assert_eq!(cell(unasked), cell(alone));
    let asked = reevaluated(run, params, &["-p", &m, "-p", "leg.sheared_bearing:=true"]);
    println!("cleg: {} without, {} with", cell(alone), cell(asked));
    assert_eq!(
        cell(asked).split("drag").nth(1).map(|s| &s[..6]),
        cell(alone).split("drag").nth(1).map(|s| &s[..6])
    );
    assert!(asked.2 < alone.2, "{asked:?} against {alone:?}");
    let docs = std::fs::read_to_string(repo().join("docs/bodies.md")).unwrap();
    for c in [cell(alone), cell(asked)] {
        assert!(docs.contains(&c), "docs/bodies.md lacks {c}");
    }
}
