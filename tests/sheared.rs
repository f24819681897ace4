//! Sand that a body shears bears less (`sheared_bearing` in a medium file): the real wheel's
//! slip sweep (tests/data/real-wheel, MIT) through `terzaghi steady` with the two coefficients
//! `calibrate --slip-sweep` fits to it and with the physics alone, held out by rim speed; every
//! run answered, a body at rest borne, and bad sweeps refused by name.

#[path = "common/mod.rs"]
mod common;

use common::{ok, repo};
use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Command, Output};

/// The plate runs and the sweep's coefficients (`calibrate --slip-sweep`).
const SWEEP: &str = "tests/data/medium_slip_sweep.yaml";
/// The plate runs and the physics alone (`calibrate --sheared-from-repose`).
const PHYSICS: &str = "tests/data/medium_sheared_physics.yaml";
const WHEEL: [&str; 6] = [
    "--shape",
    "wheel",
    "--radius-m",
    "0.058",
    "--width-m",
    "0.05",
];

fn run(args: &[&str]) -> Output {
    Command::new(common::terzaghi())
        .current_dir(repo())
        .args(args)
        .output()
        .unwrap()
}

/// `terzaghi calibrate` of the nine plate runs with `extra`, under the rft_depth_power law where
/// `extra` names none.
fn calibrate(extra: &[&str]) -> Output {
    let plates: Vec<String> = [
        "1_D60", "2_D60", "3_D60", "4_D100", "5_D100", "6_D100", "7_D80", "8_D80", "9_D80",
    ]
    .iter()
    .map(|r| format!("tests/data/real-plate-sinkage/plate_smallbox_run{r}mm.csv"))
    .collect();
    let mut args = vec!["calibrate"];
    args.extend(plates.iter().map(String::as_str));
    if !extra.contains(&"--law") {
        args.extend(["--law", "rft_depth_power"]);
    }
    args.extend(extra);
    run(&args)
}

/// `terzaghi steady RUNS` of the wheel in `medium`, grouped by rim speed: its rows and summary.
fn steady(runs: &str, medium: &str, out: &Path) -> (Vec<BTreeMap<String, String>>, String) {
    let mut args = vec!["steady", runs];
    args.extend(WHEEL);
    args.extend(["--medium-file", medium, "--group-by", "vry_cmd_mm_s", "-o"]);
    args.push(out.to_str().unwrap());
    let o = run(&args);
    ok(&o);
    (rows(out), String::from_utf8_lossy(&o.stderr).into_owned())
}

/// The R^2 the summary prints for `column`.
fn r2_of(summary: &str, column: &str) -> f64 {
    let line = summary
        .lines()
        .find(|l| l.trim_start().starts_with(column) && l.contains("R^2"))
        .unwrap_or_else(|| panic!("no R^2 of {column}:\n{summary}"));
    line.split_whitespace().nth(2).unwrap().parse().unwrap()
}

/// The figures: with the sweep's two coefficients, sinkage R^2 of 0.85 or more and
/// drawbar of 0.9 or more over the 27 runs, the locked wheel's sinkage and drawbar within 15 %;
/// the physics alone printed beside them; docs/bodies.md shows both outputs.
#[test]
fn the_shared_slip_sweep_with_the_sheared_bearing() {
    let dir = tempfile::tempdir().unwrap();
    let docs = std::fs::read_to_string(repo().join("docs/bodies.md")).unwrap();
    for medium in [SWEEP, PHYSICS] {
        let out = dir.path().join("steady.csv");
        let (table, summary) = steady("tests/data/real-wheel/slip_sweep_runs.csv", medium, &out);
        assert_eq!(table.len(), 27);
        assert!(table.iter().all(|r| r["borne"] == "true"), "{summary}");
        let (sinkage, drawbar) = (r2_of(&summary, "sinkage_m"), r2_of(&summary, "drawbar_n"));
        if medium == SWEEP {
            assert!(sinkage >= 0.85 && drawbar >= 0.9, "{summary}");
            let locked: Vec<_> = table
                .iter()
                .filter(|r| num(r, "vry_cmd_mm_s") == 0.0)
                .collect();
            assert_eq!(locked.len(), 3);
            let mean = |c: &str| locked.iter().map(|r| num(r, c)).sum::<f64>() / 3.0;
            for c in ["sinkage_m", "drawbar_n"] {
                let (p, m) = (mean(c), mean(&format!("measured_{c}")));
                assert!((p / m - 1.0).abs() <= 0.15, "locked {c}: {p} against {m}");
            }
        }
        for line in summary.lines().filter(|l| !l.starts_with("written:")) {
            assert!(
                docs.contains(line.trim_end()),
                "docs/bodies.md lacks this line of `terzaghi steady` in {medium}:\n{line}"
            );
        }
    }
}

/// The committed medium files are what `calibrate` writes from the shared data today.
#[test]
fn calibrate_remakes_the_media_of_the_sheared_bearing() {
    let dir = tempfile::tempdir().unwrap();
    for (file, extra, name) in [
        (
            SWEEP,
            vec!["--slip-sweep", "tests/data/real-wheel/slip_sweep_runs.csv"],
            "plate_runs_slip_sweep",
        ),
        (
            PHYSICS,
            vec!["--sheared-from-repose"],
            "plate_runs_sheared_physics",
        ),
    ] {
        let out = dir.path().join("m.yaml");
        let mut args = vec!["--name", name];
        args.extend(&extra);
        if extra[0] == "--slip-sweep" {
            args.extend(WHEEL);
        }
        args.extend(["-o", out.to_str().unwrap()]);
        ok(&calibrate(&args));
        let read = |p: &Path| -> serde_yaml_ng::Value {
            serde_yaml_ng::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
        };
        let (made, kept) = (read(&out), read(&repo().join(file)));
        let (a, b) = (&made["sheared_bearing"], &kept["sheared_bearing"]);
        for k in ["interface_tan", "exponent"] {
            let (x, y) = (a[k].as_f64().unwrap(), b[k].as_f64().unwrap());
            assert!(
                (x - y).abs() <= 1e-9 * y.abs(),
                "{file} {k}: {x} against {y}"
            );
        }
        // Within their physical ranges, and read back by the readers.
        let o = run(&["media", file]);
        let listed = ok(&o);
        assert!(listed.contains("sheared:"), "{listed}");
    }
}

/// Held out within the shared data: the coefficients fitted on rim speeds 0-10 mm/s predict
/// the runs at 12-100 mm/s; the reverse cannot be fitted (the driving runs lean no resultant
/// past the interface's friction: calibrate says so), and the physics alone predicts 0-10.
#[test]
fn held_out_by_rim_speed() {
    let dir = tempfile::tempdir().unwrap();
    let fitted = dir.path().join("slow.yaml");
    let fit_on = |sweep: &str, out: &Path| {
        let mut args = vec!["--slip-sweep", sweep];
        args.extend(WHEEL);
        args.extend(["-o", out.to_str().unwrap()]);
        calibrate(&args)
    };
    ok(&fit_on(
        "tests/data/real-wheel/slip_sweep_rim_slow.csv",
        &fitted,
    ));
    let out = dir.path().join("fast.csv");
    let (table, summary) = steady(
        "tests/data/real-wheel/slip_sweep_rim_fast.csv",
        fitted.to_str().unwrap(),
        &out,
    );
    assert_eq!(table.len(), 12);
    let rmse = |c: &str| {
        (table
            .iter()
            .map(|r| (num(r, c) - num(r, &format!("measured_{c}"))).powi(2))
            .sum::<f64>()
            / 12.0)
            .sqrt()
    };
    assert!(
        rmse("sinkage_m") < 3e-3 && rmse("drawbar_n") < 2.0,
        "{summary}"
    );
    let o = fit_on(
        "tests/data/real-wheel/slip_sweep_rim_fast.csv",
        &dir.path().join("fast.yaml"),
    );
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("slip_sweep_rim_fast.csv") && err.contains("does not tell"),
        "{err}"
    );
    let (table, summary) = steady(
        "tests/data/real-wheel/slip_sweep_rim_slow.csv",
        PHYSICS,
        &out,
    );
    assert_eq!(table.len(), 15);
    assert!(r2_of(&summary, "sinkage_m") > 0.85, "{summary}");
}

/// A run the sand does not bear within the body's height is a row that says so, named on
/// standard error with exit code 3; the other runs are answered as ever.
#[test]
fn every_run_is_answered() {
    let dir = tempfile::tempdir().unwrap();
    let runs = dir.path().join("runs.csv");
    std::fs::write(
        &runs,
        "load_n,hub_vx_m_s,omega_rad_s,slip_angle_deg\n20,0.01,0.172,0\n5000,0.01,0.172,0\n",
    )
    .unwrap();
    let out = dir.path().join("out.csv");
    let mut args = vec!["steady", runs.to_str().unwrap()];
    args.extend(WHEEL);
    args.extend(["--medium-file", SWEEP, "-o", out.to_str().unwrap()]);
    let o = run(&args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(
        err.contains("not borne") && err.contains("line 3") && !err.contains("line 2:"),
        "{err}"
    );
    let table = rows(&out);
    assert_eq!(table.len(), 2);
    assert_eq!(
        (table[0]["borne"].as_str(), table[1]["borne"].as_str()),
        ("true", "false")
    );
    assert!((num(&table[0], "load_borne_n") - 20.0).abs() < 0.1);
    // Buried to its top, the most the sand bears there.
    assert!((num(&table[1], "sinkage_m") - 0.116).abs() < 1e-9);
    assert!(num(&table[1], "load_borne_n") < 5000.0);
}

/// A body at rest (no speed, no rotation) under its load settles where the sand pressed
/// straight down bears it: the node's held body at that depth carries the load.
#[test]
fn a_body_at_rest_settles_as_pressed_straight_down() {
    let dir = tempfile::tempdir().unwrap();
    let runs = dir.path().join("rest.csv");
    std::fs::write(
        &runs,
        "load_n,hub_vx_m_s,omega_rad_s,slip_angle_deg\n20,0,0,0\n",
    )
    .unwrap();
    for (shape, reach) in [
        (
            &[
                "--shape",
                "wheel",
                "--radius-m",
                "0.058",
                "--width-m",
                "0.05",
            ][..],
            0.058,
        ),
        (
            &[
                "--shape",
                "disc",
                "--radius-m",
                "0.03",
                "--thickness-m",
                "0.01",
            ][..],
            0.005,
        ),
        (&["--shape", "sphere", "--radius-m", "0.03"][..], 0.03),
    ] {
        let out = dir.path().join("out.csv");
        let mut args = vec!["steady", runs.to_str().unwrap()];
        args.extend(shape);
        args.extend(["--medium-file", SWEEP, "-o", out.to_str().unwrap()]);
        ok(&run(&args));
        let row = &rows(&out)[0];
        assert_eq!(row["borne"], "true", "{shape:?}");
        assert_eq!(num(row, "drawbar_n"), 0.0);
        let sinkage = num(row, "sinkage_m");
        assert!(sinkage > 0.0 && sinkage < 0.03, "{shape:?}: {sinkage}");
        let height = format!("{}", reach - sinkage);
        let mut p = vec!["predict", "--model", "rft"];
        p.extend(shape);
        p.extend([
            "--medium-file",
            SWEEP,
            "--hip-height-m",
            &height,
            "--beta-deg",
            "0",
        ]);
        let text = ok(&run(&p));
        let line = text.lines().nth(1).unwrap();
        let lift: f64 = line.split(',').nth(4).unwrap().parse().unwrap();
        assert!(
            (lift - 20.0).abs() < 0.1,
            "{shape:?}: held at {height} m: {line}"
        );
    }
}

/// Sweeps that cannot be fitted, and coefficients outside their physical range, are refused
/// naming the file, the line and the value.
#[test]
fn bad_sweeps_and_coefficients_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let sweep =
        std::fs::read_to_string(repo().join("tests/data/real-wheel/slip_sweep_runs.csv")).unwrap();
    let lines: Vec<&str> = sweep.lines().collect();
    let head = lines[0];
    let cols: Vec<&str> = head.split(',').collect();
    let at = |c: &str| cols.iter().position(|h| *h == c).unwrap();
    let with = |row: usize, c: &str, v: &str| {
        let mut out = lines
            .clone()
            .into_iter()
            .map(String::from)
            .collect::<Vec<_>>();
        let mut f: Vec<String> = out[row].split(',').map(String::from).collect();
        f[at(c)] = v.to_string();
        out[row] = f.join(",");
        out.join("\n") + "\n"
    };
    let first_slip: Vec<&str> = std::iter::once(head)
        .chain(
            lines[1..]
                .iter()
                .copied()
                .filter(|l| l.split(',').nth(at("vry_cmd_mm_s")) == Some("0")),
        )
        .collect();
    let cases: Vec<(String, Vec<&str>)> = vec![
        (
            lines[..5].join("\n") + "\n",
            vec!["5 runs or more", "it has 4"],
        ),
        (
            [first_slip.clone(), first_slip[1..].to_vec()]
                .concat()
                .join("\n")
                + "\n",
            vec!["two slips"],
        ),
        (
            with(4, "sinkage_m", ""),
            vec!["line 5", "sinkage_m is \"\""],
        ),
        (
            with(7, "drawbar_n", "x1"),
            vec!["line 8", "drawbar_n is \"x1\""],
        ),
        (
            with(3, "slip_angle_deg", "15"),
            vec!["line 4", "slip_angle_deg is 15"],
        ),
        (with(2, "load_n", "-3"), vec!["line 3", "load_n is -3"]),
    ];
    for (text, words) in cases {
        let f = dir.path().join("sweep.csv");
        std::fs::write(&f, &text).unwrap();
        let mut args = vec!["--slip-sweep", f.to_str().unwrap()];
        args.extend(WHEEL);
        let o = calibrate(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(
            err.contains("sweep.csv") && !err.contains("panicked"),
            "{err}"
        );
        for w in words {
            assert!(err.contains(w), "{w:?} not in {err}");
        }
    }
    // A medium file whose coefficient left its range: every reader refuses it by name.
    let kept = std::fs::read_to_string(repo().join(SWEEP)).unwrap();
    for (key, bad) in [("interface_tan", "-0.2"), ("exponent", "40.5")] {
        let start = kept.find(&format!("  {key}: ")).unwrap();
        let end = start + kept[start..].find('\n').unwrap();
        let text = format!("{}  {key}: {bad}{}", &kept[..start], &kept[end..]);
        let f = dir.path().join("bad.yaml");
        std::fs::write(&f, text).unwrap();
        let runs = repo().join("tests/data/real-wheel/slip_sweep_runs.csv");
        for args in [
            vec!["media".to_string(), f.display().to_string()],
            [
                vec!["steady".to_string(), runs.display().to_string()],
                WHEEL.map(String::from).to_vec(),
                vec!["--medium-file".into(), f.display().to_string()],
            ]
            .concat(),
        ] {
            let o = run(&args.iter().map(String::as_str).collect::<Vec<_>>());
            let err = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(2), "{err}");
            assert!(
                err.contains(key) && err.contains(bad) && err.contains("bad.yaml"),
                "{err}"
            );
        }
    }
}

/// What the sheared bearing does not reach is said, never passed over: a planar leg takes it
/// only when asked (`predict` notes it otherwise; with `--planar-sheared-bearing` its lift falls
/// where its resultant leans, its drag stays), a file of another law cannot carry it, and a
/// runs file with a column `steady` writes is refused by name.
#[test]
fn where_the_sheared_bearing_does_not_act_it_says_so() {
    let predict = |medium: &str, extra: &[&str]| {
        let mut args = vec![
            "predict",
            "--model",
            "rft",
            "--medium-file",
            medium,
            "--length-m",
            "0.1",
            "--width-m",
            "0.02",
            "--hip-height-m",
            "0.05",
            "--beta-deg",
            "40:120:20",
            "--format",
            "json",
        ];
        args.extend(extra);
        let o = run(&args);
        let rows: Vec<serde_json::Value> = serde_json::from_str(&ok(&o)).unwrap();
        (rows, String::from_utf8_lossy(&o.stderr).into_owned())
    };
    let (at_rest, _) = predict(PLATES, &[]);
    let (off, err) = predict(SWEEP, &[]);
    assert!(err.contains("unless --planar-sheared-bearing"), "{err}");
    assert_eq!(off, at_rest);
    let (on, err) = predict(SWEEP, &["--planar-sheared-bearing"]);
    assert!(!err.contains("note:"), "{err}");
    let lift = |r: &serde_json::Value| r["lift_n"].as_f64().unwrap();
    let mut less = 0;
    for (a, b) in at_rest.iter().zip(&on) {
        assert_eq!(a["drag_n"], b["drag_n"]);
        assert!(lift(b) <= lift(a) + 1e-12, "{a} against {b}");
        less += usize::from(lift(b) < lift(a));
    }
    assert!(less > 0, "{on:?}");
    let o = calibrate(&["--law", "bekker", "--sheared-from-repose"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--sheared-from-repose") && err.contains("bekker"),
        "{err}"
    );
    let dir = tempfile::tempdir().unwrap();
    let runs = dir.path().join("runs.csv");
    std::fs::write(
        &runs,
        "load_n,hub_vx_m_s,omega_rad_s,slip_angle_deg,borne\n20,0.01,0,0,yes\n",
    )
    .unwrap();
    let mut args = vec!["steady", runs.to_str().unwrap()];
    args.extend(WHEEL);
    args.extend(["--medium-file", SWEEP]);
    let o = run(&args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("runs.csv") && err.contains("\"borne\""),
        "{err}"
    );
}

/// A CSV file's rows, each its columns by name.
fn rows(path: &Path) -> Vec<std::collections::BTreeMap<String, String>> {
    let mut rdr = csv::Reader::from_path(path).unwrap();
    let head: Vec<String> = rdr.headers().unwrap().iter().map(str::to_string).collect();
    rdr.records()
        .map(|r| {
            let r = r.unwrap();
            head.iter()
                .cloned()
                .zip(r.iter().map(str::to_string))
                .collect()
        })
        .collect()
}

/// Column `c` of a row of [`rows`] as a number.
fn num(row: &std::collections::BTreeMap<String, String>, c: &str) -> f64 {
    row[c]
        .parse()
        .unwrap_or_else(|_| panic!("{c}: {:?}", row[c]))
}

/// The plate runs alone (`calibrate --law rft_depth_power`): nothing from a wheel.
const PLATES: &str = "tests/data/medium_plate_runs_rft.yaml";

/// `terzaghi diagnose RUNS --shape wheel ... --medium-file M --json`: its report.
fn diagnose(runs: &str, medium: &str, out: &Path) -> serde_json::Value {
    let mut args = vec!["diagnose", runs];
    args.extend(WHEEL);
    args.extend(["--medium-file", medium, "--json", "--out"]);
    args.push(out.to_str().unwrap());
    serde_json::from_str(&ok(&run(&args))).expect("the report's JSON")
}

/// The diagnosis of the shared sweep against the plates alone names the sheared sand's bearing,
/// on the locked and skidding runs, with the coefficients a medium file takes (held out run by
/// run, the gap closes); the medium it writes is read by steady and bears the sweep as
/// calibrate's does; on a sweep the model itself settled (steady's own output), nothing to
/// explain.
#[test]
fn diagnose_names_the_sheared_bearing_of_the_shared_sweep_and_nothing_on_the_models_own() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = "tests/data/real-wheel/slip_sweep_runs.csv";
    let r = diagnose(sweep, PLATES, &dir.path().join("real"));
    assert_eq!(
        r["verdict"]["effect"], "sheared_bearing",
        "{}",
        r["verdict"]
    );
    let claim = r["verdict"]["claim"].as_str().unwrap();
    assert!(
        claim.contains("3 of 3 locked") && claim.contains("skidding"),
        "{claim}"
    );
    let groups = r["groups"].as_array().unwrap();
    let group = |class: &str| groups.iter().find(|g| g["slip_class"] == class).unwrap();
    // The bearing acts where the rim skids, not where it drives.
    assert!(group("skidding")["sheared"].as_u64().unwrap() > 0);
    assert_eq!(group("driving")["sheared"], 0);
    // The load borne at the measured sinkage: a quarter of what the sand at rest bears there
    // for the locked wheel; it follows the rim's lean more than the slip's sign.
    assert!(group("locked")["median_load_share"].as_f64().unwrap() < 0.4);
    let e = &r["evidence"];
    assert!(
        e["r_with_lean"].as_f64().unwrap() < -0.5
            && e["r_with_slip"].as_f64().unwrap().abs() < e["r_with_lean"].as_f64().unwrap().abs(),
        "{e}"
    );
    let best = &r["candidates"][0];
    let held = &best["held_out"];
    assert!(
        held["r2_sinkage"].as_f64().unwrap() >= 0.85 && held["r2_drawbar"].as_f64().unwrap() >= 0.9,
        "{best}"
    );
    // The other candidates were weighed, and close less.
    let others: Vec<&str> = r["candidates"].as_array().unwrap()[1..]
        .iter()
        .map(|c| c["effect"].as_str().unwrap())
        .collect();
    assert_eq!(others.len(), 3, "{others:?}");
    // Its coefficients as the medium file takes them: calibrate --slip-sweep's own.
    let kept: serde_yaml_ng::Value =
        serde_yaml_ng::from_str(&std::fs::read_to_string(repo().join(SWEEP)).unwrap()).unwrap();
    let corrected = dir.path().join("real/corrected_medium.yaml");
    let made: serde_yaml_ng::Value =
        serde_yaml_ng::from_str(&std::fs::read_to_string(&corrected).unwrap()).unwrap();
    for k in ["interface_tan", "exponent"] {
        let (x, y) = (
            made["sheared_bearing"][k].as_f64().unwrap(),
            kept["sheared_bearing"][k].as_f64().unwrap(),
        );
        assert!((x - y).abs() <= 1e-6 * y, "{k}: {x} against {y}");
    }
    let (_, summary) = steady(
        sweep,
        corrected.to_str().unwrap(),
        &dir.path().join("s.csv"),
    );
    assert!(r2_of(&summary, "sinkage_m") >= 0.85, "{summary}");

    // docs/bodies.md shows the text of the same diagnosis, line for line.
    let text_out = dir.path().join("text");
    let mut args = vec!["diagnose", sweep];
    args.extend(WHEEL);
    args.extend(["--medium-file", PLATES, "--out", text_out.to_str().unwrap()]);
    let printed = ok(&run(&args)).replace(text_out.to_str().unwrap(), "DIR");
    let docs = std::fs::read_to_string(repo().join("docs/bodies.md")).unwrap();
    for line in printed.lines() {
        assert!(
            docs.contains(line),
            "docs/bodies.md lacks this line of the diagnosis:\n{line}"
        );
    }

    // The model's own sweep: steady's output, its sinkage_m and drawbar_n the model's.
    let own = dir.path().join("own.csv");
    steady(sweep, PLATES, &own);
    let r = diagnose(own.to_str().unwrap(), PLATES, &dir.path().join("own"));
    assert_eq!(r["verdict"]["effect"], "none", "{}", r["verdict"]);
    assert!(
        r["verdict"]["claim"]
            .as_str()
            .unwrap()
            .starts_with("nothing to explain")
    );
    assert!(!dir.path().join("own/corrected_medium.yaml").exists());
}

/// The plate-only medium is what calibrate writes from the plate runs today.
#[test]
fn calibrate_remakes_the_plates_only_medium() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.yaml");
    ok(&calibrate(&[
        "--name",
        "plate_runs",
        "-o",
        out.to_str().unwrap(),
    ]));
    let read = |p: &Path| -> serde_yaml_ng::Value {
        serde_yaml_ng::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    let (made, kept) = (read(&out), read(&repo().join(PLATES)));
    assert_eq!(made["params"], kept["params"]);
    assert!(kept.get("sheared_bearing").is_none());
}

/// A wheel's runs that cannot be diagnosed are refused by name.
#[test]
fn diagnose_refuses_what_is_no_wheel_test() {
    let dir = tempfile::tempdir().unwrap();
    let text =
        std::fs::read_to_string(repo().join("tests/data/real-wheel/slip_sweep_runs.csv")).unwrap();
    let few: String = text.lines().take(4).map(|l| format!("{l}\n")).collect();
    let f = dir.path().join("few.csv");
    std::fs::write(&f, few).unwrap();
    let mut args = vec!["diagnose", f.to_str().unwrap()];
    args.extend(WHEEL);
    args.extend([
        "--medium-file",
        PLATES,
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    let o = run(&args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("few.csv") && err.contains("5 runs or more"),
        "{err}"
    );
    // No body, no medium: what is missing is named.
    let x = dir.path().join("x");
    let x = x.to_str().unwrap();
    let o = run(&[
        "diagnose",
        "tests/data/real-wheel/slip_sweep_runs.csv",
        "--out",
        x,
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("--shape wheel"), "{err}");
    let mut args = vec!["diagnose", "tests/data/real-wheel/slip_sweep_runs.csv"];
    args.extend(WHEEL);
    args.extend(["--out", x]);
    let err = String::from_utf8_lossy(&run(&args).stderr).into_owned();
    assert!(err.contains("--medium-file"), "{err}");
    // A bad value names its file and line.
    let bad = text.replacen("22.9927", "heavy", 1);
    let f = dir.path().join("bad.csv");
    std::fs::write(&f, bad).unwrap();
    let mut args = vec!["diagnose", f.to_str().unwrap()];
    args.extend(WHEEL);
    args.extend([
        "--medium-file",
        PLATES,
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&run(&args).stderr).into_owned();
    assert!(
        err.contains("bad.csv line 2") && err.contains("heavy"),
        "{err}"
    );
}
