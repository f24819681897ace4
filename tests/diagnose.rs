//! Gap diagnosis as users run it: `terzaghi diagnose` on CSV logs and MCAP sessions (real files
//! on disk), its reports, its refusals of bad logs, and `diagnose-eval`, the check on sessions
//! whose hidden effect the diagnosis is not told.

mod common;

use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};

fn terzaghi(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_terzaghi"))
        .args(args)
        .output()
        .expect("run terzaghi")
}

/// `terzaghi-eval diagnose-eval ARGS`: the diagnosis's own checks.
fn diagnose_eval(args: &[&str]) -> Output {
    Command::new(common::eval_exe())
        .arg("diagnose-eval")
        .args(args)
        .output()
        .expect("run terzaghi-eval")
}

fn ok(out: &Output) -> String {
    assert!(
        out.status.success(),
        "exit {:?}\nstdout: {}\nstderr: {}",
        out.status.code(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Exit 2 with one clear stderr line holding every needle, and no panic.
fn refused(out: &Output, needles: &[&str]) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "stderr: {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    for n in needles {
        assert!(err.contains(n), "{n:?} missing from: {err}");
    }
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("read json")).expect("parse json")
}

/// Exports case `i` of diagnose-eval's run 1: its session CSV and its truth.
fn exported(i: usize, dir: &Path) -> (Vec<String>, Vec<String>) {
    let d = dir.to_str().unwrap();
    ok(&diagnose_eval(&[
        "--export-case",
        &i.to_string(),
        "--export-dir",
        d,
    ]));
    let case = json(&dir.join("case.json"));
    let flags = case["flags"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap().to_string())
        .collect();
    let truth = case["truth"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap().to_string())
        .collect();
    (flags, truth)
}

#[test]
fn a_csv_log_gives_a_report_that_names_the_hidden_effect() {
    let tmp = tempfile::tempdir().unwrap();
    // Cases 3 and 7 of the rotation hide surcharge and hip_height; case 0 hides nothing.
    for (i, expected) in [(3, "surcharge"), (7, "hip_height"), (0, "none")] {
        let dir = tmp.path().join(format!("case{i}"));
        let (flags, truth) = exported(i, &dir);
        assert_eq!(truth.first().map_or("none", String::as_str), expected);
        let out_dir = dir.join("report");
        let mut args = vec![
            "diagnose".to_string(),
            dir.join("session.csv").display().to_string(),
            "--out".into(),
            out_dir.display().to_string(),
        ];
        args.extend(flags);
        let text = ok(&terzaghi(
            &args.iter().map(String::as_str).collect::<Vec<_>>(),
        ));
        assert!(text.contains(&format!("verdict {expected}")), "{text}");
        let r = json(&out_dir.join("report.json"));
        assert_eq!(r["verdict"]["effect"], expected);
        for key in ["b_k", "a", "psi_drag", "psi_lift", "rmse_n"] {
            assert!(r["baseline"][key].is_f64(), "baseline.{key}");
        }
        let bins = r["where"].as_array().unwrap();
        for dim in [
            "attack_angle_deg",
            "depth_m",
            "speed_rad_s",
            "accel_rad_s2",
            "regime",
            "stroke",
        ] {
            assert!(
                bins.iter().any(|b| b["dimension"] == dim),
                "where has no {dim}"
            );
        }
        assert!(
            bins.iter()
                .all(|b| b["lo"].is_f64() && b["hi"].is_f64() && b["share_of_gap"].is_f64())
        );
        let cands = r["candidates"].as_array().unwrap();
        assert_eq!(cands.len(), 9, "every candidate is scored");
        for c in cands {
            for key in [
                "effect",
                "params",
                "heldout_rmse_before_n",
                "heldout_rmse_after_n",
                "gap_closed_pct",
            ] {
                assert!(c.get(key).is_some(), "candidate without {key}");
            }
        }
        for key in [
            "effect",
            "gap_closed_pct",
            "heldout_psi_before",
            "heldout_psi_after",
        ] {
            assert!(r["verdict"].get(key).is_some(), "verdict without {key}");
        }
        if expected == "none" {
            assert!(!r["gap"]["real"].as_bool().unwrap());
            assert!(r["steps"].as_array().unwrap().is_empty());
        } else {
            // Candidates come best first, the verdict's effect at the top, closing most of the gap.
            assert_eq!(cands[0]["effect"], expected);
            assert!(r["verdict"]["gap_closed_pct"].as_f64().unwrap() > 70.0);
            assert!(
                r["verdict"]["heldout_psi_after"].as_f64()
                    > r["verdict"]["heldout_psi_before"].as_f64()
            );
            assert!(r["steps"][0]["effect"] == expected);
        }
        let html = std::fs::read_to_string(out_dir.join("report.html")).unwrap();
        assert_eq!(html.matches("<svg").count(), 3, "three plots");
        assert!(
            html.contains("</html>") && !html.contains("<script src") && !html.contains("<link")
        );
        assert!(html.contains(&format!("<b>{expected}</b>")));
        // Each step says what shows it, in report.json and in the HTML.
        for st in r["steps"].as_array().unwrap() {
            let claim = st["claim"].as_str().unwrap();
            assert!(html.contains(claim), "{claim}");
        }
        // Beside the report, the corrected model as node parameters; re-running the log with
        // it through the node predicts what the sensor reads better than the bare model does.
        let params = out_dir.join("corrected.yaml");
        let yaml = std::fs::read_to_string(&params).unwrap();
        assert!(yaml.contains("ros__parameters:"), "{yaml}");
        let rows = dir.join("rerun.csv");
        ok(&terzaghi(&[
            "replay",
            dir.join("session.csv").to_str().unwrap(),
            "--reevaluate",
            "--params-file",
            params.to_str().unwrap(),
            "-o",
            rows.to_str().unwrap(),
        ]));
        let mut rdr = csv::Reader::from_path(&rows).unwrap();
        let h = rdr.headers().unwrap().clone();
        let col = |name: &str| h.iter().position(|c| c == name).unwrap();
        let (md, ml, bd, bl, ed, el) = (
            col("measured_drag_n"),
            col("measured_lift_n"),
            col("bare_drag_n"),
            col("bare_lift_n"),
            col("expected_reading_drag_n"),
            col("expected_reading_lift_n"),
        );
        let (mut bare, mut expected_sse, mut n) = (0.0, 0.0, 0);
        for rec in rdr.records() {
            let rec = rec.unwrap();
            let f = |i: usize| rec[i].parse::<f64>().unwrap();
            bare += (f(md) - f(bd)).powi(2) + (f(ml) - f(bl)).powi(2);
            expected_sse += (f(md) - f(ed)).powi(2) + (f(ml) - f(el)).powi(2);
            n += 1;
        }
        assert!(n > 1000, "{n} rows");
        if expected == "none" {
            assert!(!yaml.contains("corrections:"), "{yaml}");
            assert_eq!(bare, expected_sse);
        } else {
            assert!(
                yaml.contains(&format!("effects: [\"{expected}\"")),
                "{yaml}"
            );
            assert!(
                expected_sse < 0.5 * bare,
                "{expected}: {expected_sse} against {bare}"
            );
        }
    }
}

/// Writes a short six-legged session (hidden surcharge) through the diagnosis benchmark's
/// simulation.
fn six_legged_session(path: &Path) -> Value {
    let out = ok(&Command::new(common::bench_exe())
        .args([
            "diagnose",
            "--minutes",
            "1.5",
            "--rate-hz",
            "250",
            "--keep",
            path.to_str().unwrap(),
            "--json",
        ])
        .output()
        .unwrap());
    serde_json::from_str(&out).unwrap()
}

#[test]
fn an_mcap_session_is_diagnosed_per_leg_from_its_recorded_parameters() {
    let tmp = tempfile::tempdir().unwrap();
    let mcap = tmp.path().join("walk.mcap");
    let bench = six_legged_session(&mcap);
    assert_eq!(bench["verdicts"].as_array().unwrap().len(), 6);
    // Every leg, each in its own directory, with an index.
    let out = tmp.path().join("all");
    ok(&terzaghi(&[
        "diagnose",
        mcap.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]));
    let index = json(&out.join("report.json"));
    let legs = index["legs"].as_array().unwrap();
    assert_eq!(legs.len(), 6);
    for l in legs {
        let name = l["leg"].as_str().unwrap();
        let r = json(&out.join(name).join("report.json"));
        assert_eq!(r["verdict"]["effect"], "surcharge", "leg {name}");
        assert!(out.join(name).join("report.html").exists());
    }
    // One leg, and the same leg read as any ROS 2 MCAP (joint, F/T topic and geometry given).
    let one = tmp.path().join("one");
    ok(&terzaghi(&[
        "diagnose",
        mcap.to_str().unwrap(),
        "--leg",
        "middle_left",
        "--out",
        one.to_str().unwrap(),
    ]));
    let r1 = json(&one.join("report.json"));
    assert_eq!(r1["leg"], "middle_left");
    let flags = tmp.path().join("flags");
    ok(&terzaghi(&[
        "diagnose",
        mcap.to_str().unwrap(),
        "--joint",
        "middle_left_hip",
        "--wrench-topic",
        "/middle_left/ft/wrench",
        "--ft-frame",
        "leg",
        "--length-m",
        "0.10",
        "--width-m",
        "0.04",
        "--hip-height-m",
        "0.06",
        "--medium",
        "poppy_lp",
        "--out",
        flags.to_str().unwrap(),
    ]));
    let r2 = json(&flags.join("report.json"));
    assert_eq!(r2["verdict"]["effect"], "surcharge");
    let (b1, b2) = (
        r1["baseline"]["b_k"].as_f64().unwrap(),
        r2["baseline"]["b_k"].as_f64().unwrap(),
    );
    assert!(
        (b1 / b2 - 1.0).abs() < 1e-9,
        "same samples, same fit: {b1} {b2}"
    );
}

#[test]
fn bad_logs_are_refused_with_exit_2() {
    let tmp = tempfile::tempdir().unwrap();
    let p = |name: &str| tmp.path().join(name).display().to_string();
    let out = p("out");
    let geom = [
        "--length-m",
        "0.25",
        "--width-m",
        "0.06",
        "--hip-height-m",
        "0.15",
        "--medium",
        "hit_sand",
    ];
    let csv = |name: &str, rows: &dyn Fn(usize) -> String, n: usize| {
        let mut s = String::from("t_s,beta_rad,drag_n,lift_n\n");
        for i in 0..n {
            s += &rows(i);
        }
        std::fs::write(p(name), s).unwrap();
    };
    let diag = |file: &str, extra: &[&str]| {
        let mut a = vec!["diagnose", file, "--out", &out];
        a.extend_from_slice(extra);
        terzaghi(&a)
    };
    // Two strokes only.
    csv(
        "short.csv",
        &|i| {
            format!(
                "{},{},{},{}\n",
                i as f64 * 0.004,
                (i as f64 * 0.01) % std::f64::consts::TAU,
                5.0,
                3.0
            )
        },
        1200,
    );
    refused(&diag(&p("short.csv"), &geom), &["strokes", "at least 4"]);
    // A real session, but the configured hip is higher than the leg is long: never in the medium.
    ok(&terzaghi(&[
        "simulate",
        "--length-m",
        "0.25",
        "--width-m",
        "0.06",
        "--hip-height-m",
        "0.15",
        "--medium",
        "hit_sand",
        "--strokes",
        "10",
        "-o",
        &p("walk.csv"),
    ]));
    let high = [
        "--length-m",
        "0.25",
        "--width-m",
        "0.06",
        "--hip-height-m",
        "0.3",
        "--medium",
        "hit_sand",
    ];
    refused(&diag(&p("walk.csv"), &high), &["in the medium"]);
    // Not a log at all.
    std::fs::write(p("junk.csv"), "hello\nworld\n").unwrap();
    let r = diag(&p("junk.csv"), &geom);
    assert_eq!(r.status.code(), Some(2));
    assert!(!String::from_utf8_lossy(&r.stderr).contains("panicked"));
    // A CSV without geometry.
    refused(&diag(&p("short.csv"), &[]), &["--length-m"]);

    // MCAP: a session, then the same cut off, and a topic that is not there.
    let mcap = tmp.path().join("walk.mcap");
    six_legged_session(&mcap);
    let bytes = std::fs::read(&mcap).unwrap();
    std::fs::write(p("cut.mcap"), &bytes[..bytes.len() / 2]).unwrap();
    refused(&diag(&p("cut.mcap"), &[]), &["cut off", "terzaghi recover"]);
    refused(
        &diag(
            mcap.to_str().unwrap(),
            &[
                "--joint",
                "front_left_hip",
                "--wrench-topic",
                "/no/such/wrench",
                "--length-m",
                "0.1",
                "--width-m",
                "0.04",
                "--hip-height-m",
                "0.06",
                "--medium",
                "poppy_lp",
            ],
        ),
        &["no F/T sample", "/no/such/wrench"],
    );
    refused(
        &diag(mcap.to_str().unwrap(), &["--leg", "tail"]),
        &["no leg named \"tail\"", "front_left"],
    );
    assert!(
        !Path::new(&out).join("report.json").exists(),
        "no report from a refused log"
    );
}

#[test]
fn diagnose_eval_meets_its_targets_on_withheld_effects() {
    // 208 cases: 16 rounds of clean, the nine effects, two outside the library, and a pair.
    let out = ok(&diagnose_eval(&["--cases", "208", "--seed", "1", "--json"]));
    let v: Value = serde_json::from_str(&out).unwrap();
    let s = &v["summary"];
    eprintln!("{}", serde_json::to_string_pretty(s).unwrap());
    let f = |k: &str| s[k].as_f64().unwrap();
    assert_eq!(s["single_cases"], 144);
    // Every figure below has cases to be of (an empty group's figure is null).
    for n in ["clean_cases", "outside_cases", "pair_cases", "gap_cases"] {
        assert!(s[n].as_u64().unwrap() > 0, "{n}: {s}");
    }
    assert!(
        f("single_accuracy_pct") >= 90.0,
        "accuracy {}",
        f("single_accuracy_pct")
    );
    assert!(
        f("false_alarm_pct") <= 5.0,
        "false alarms {}",
        f("false_alarm_pct")
    );
    assert!(
        f("outside_ok_pct") >= 90.0,
        "outside the library {}",
        f("outside_ok_pct")
    );
    assert!(
        f("gap_error_mean_pts") <= 10.0,
        "gap error {}",
        f("gap_error_mean_pts")
    );
    assert!(f("gap_error_median_pts") <= 10.0);
    // Pairs of effects: both reported as significant effects.
    assert!(
        f("pair_both_ok_pct") >= 80.0,
        "pairs both found {}",
        f("pair_both_ok_pct")
    );
    // The verdicts really come from the sessions: no case is labelled from the truth.
    let cases = v["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 208);
    assert!(cases.iter().any(|c| c["verdict"] == "unexplained"));
    assert!(cases.iter().any(|c| c["verdict"] == "none"));
}

/// The diagnosis on the committed DEM campaign (LIGGGHTS; physics the project did not write):
/// every case is a session built from the campaign's runs with sensor noise, handed to the
/// diagnosis without its label.
#[test]
fn on_the_dem_campaign_the_varied_effect_is_reported() {
    let campaign = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/dem/campaign");
    let out = ok(&diagnose_eval(&[
        "--cases",
        "0",
        "--dem",
        campaign.to_str().unwrap(),
        "--json",
    ]));
    let v: Value = serde_json::from_str(&out).unwrap();
    let dem = v["dem"].as_array().unwrap();
    let case = |name: &str| {
        dem.iter()
            .find(|c| c["case"] == name)
            .unwrap_or_else(|| panic!("no DEM case {name}"))
    };
    for c in dem {
        eprintln!(
            "{:<20} verdict {:<12} effects {} found {} reported {} measured {}",
            c["case"].as_str().unwrap(),
            c["verdict"].as_str().unwrap(),
            c["effects"],
            c["found"],
            c["reported_pct"],
            c["measured_pct"]
        );
    }
    // The varied effect is the verdict or one of the significant effects: speed, cohesion, a
    // bed that gets denser, a surface higher than configured, a trough passed through again,
    // and the sensor's offset (beside the flat-plate model's large misfit on a C-leg too) and
    // delay. The two the README says are missed: a delay on the C-leg, at one speed and at
    // speeds rising to 7.5 rad/s; they are checked as misses, so that a change that finds
    // them (or loses another) says so here.
    let found = [
        "speed",
        "cohesion",
        "density",
        "surface_level",
        "disturbed",
        "sensor_bias",
        "cleg_sensor_bias",
        "sensor_delay_20ms",
        "sensor_delay_30ms",
        "speed_sensor_delay",
    ];
    let expected_misses = ["cleg_sensor_delay", "cleg_speed_sensor_delay"];
    for name in found {
        assert_eq!(
            case(name)["found"],
            true,
            "{name}: {}",
            case(name)["report"]["summary"]
        );
    }
    for name in expected_misses {
        assert_eq!(
            case(name)["found"],
            false,
            "{name}, an expected miss, is found now: move it to the found cases here and in the docs"
        );
    }
    // Every case with a varied effect is one or the other.
    let mut varied: Vec<&str> = dem
        .iter()
        .filter(|c| !c["expected"].is_null())
        .map(|c| c["case"].as_str().unwrap())
        .collect();
    let mut listed: Vec<&str> = found.iter().chain(&expected_misses).copied().collect();
    varied.sort_unstable();
    listed.sort_unstable();
    assert_eq!(varied, listed);
    // Ground passed through again and again changes over the session, and that is the verdict;
    // strokes at speeds rising one after another are not taken for ground changing over the
    // session (the speed's own change of how force grows with the angle is `rate`'s), nor for
    // a late sensor (the DEM's onset comes earlier with speed, a late sensor's later).
    assert_eq!(case("disturbed")["verdict"], "compaction");
    let speed_effects = case("speed")["effects"].to_string();
    assert!(
        !speed_effects.contains("compaction") && !speed_effects.contains("sensor_lag"),
        "speed: {speed_effects}"
    );
    // A sensor offset is measured directly where the leg is far out of the medium: the share of
    // the gap it closes agrees with the share measured against the same strokes without it;
    // so does the share the surface level closes alone.
    // A bed that gets denser, or a trough passed through again, changes the strokes from some
    // stroke on: the strokes before it are the session's own counterpart, and the share of the
    // gap beyond what the model leaves on them agrees with the measured share, where the
    // compaction term alone takes up only part of it. Likewise the strokes at the lowest speed
    // for `rate`: closer to the measured share than its term alone.
    for name in ["density", "disturbed", "speed"] {
        let c = case(name);
        let effect = c["expected"].as_str().unwrap();
        let (r, m) = (
            c["reported_pct"].as_f64().unwrap(),
            c["measured_pct"].as_f64().unwrap(),
        );
        let alone = c["report"]["candidates"]
            .as_array()
            .unwrap()
            .iter()
            .find(|x| x["effect"] == effect)
            .unwrap()["gap_closed_pct"]
            .as_f64()
            .unwrap();
        let step = c["report"]["steps"]
            .as_array()
            .unwrap()
            .iter()
            .find(|x| x["effect"] == effect)
            .unwrap();
        assert_eq!(step["contrast"]["share_of_gap_pct"].as_f64(), Some(r));
        assert!(
            (r - m).abs() < (alone - m).abs(),
            "{name}: contrast {r}, alone {alone}, measured {m}"
        );
        if name != "speed" {
            assert!((r - m).abs() <= 10.0, "{name}: reported {r}, measured {m}");
        }
    }
    // The offset's share, read directly, agrees with the measured one on the flat plate and on
    // the C-leg told as a flat plate (whose early entry a `hip_height` term takes beside it).
    for name in ["sensor_bias", "surface_level", "cleg_sensor_bias"] {
        let c = case(name);
        let (r, m) = (
            c["reported_pct"].as_f64().unwrap(),
            c["measured_pct"].as_f64().unwrap(),
        );
        assert!((r - m).abs() <= 10.0, "{name}: reported {r}, measured {m}");
    }
    // The offset's direct signature is read where the leg is farthest from the medium: there
    // it is the sensor's offset within 2 %, on drag and on lift, also on the C-leg, whose arc
    // puts force on the sensor where the flat plate is out of the medium near the surface
    // (read from there, the C-leg's lift offset was 19 % too high). Where the sensor adds none,
    // none is found, also on the C-leg at rising speeds.
    let offset = |name: &str| case(name)["report"]["signatures"]["sensor_offset"].clone();
    for name in ["sensor_bias", "cleg_sensor_bias"] {
        let truth = case(name)["sensor_offset_n"].as_f64().unwrap();
        assert!(truth > 0.0, "{name}");
        assert_eq!(offset(name)["significant"], true, "{name}");
        for c in ["drag_n", "lift_n"] {
            let read = offset(name)[c].as_f64().unwrap();
            assert!(
                (read - truth).abs() <= 0.02 * truth,
                "{name}: {c} read {read} N, the sensor added {truth} N"
            );
        }
    }
    for c in dem
        .iter()
        .filter(|c| c["sensor_offset_n"].as_f64() == Some(0.0))
    {
        let name = c["case"].as_str().unwrap();
        assert_eq!(
            offset(name)["significant"],
            false,
            "{name}: {}",
            offset(name)
        );
        assert!(
            !c["effects"].to_string().contains("sensor_bias"),
            "{name}: {}",
            c["effects"]
        );
    }
    // Where the speeds vary, the report splits each stroke's best-aligning shift into time and
    // angle. A late sensor moves the time part by its delay, against the same strokes without
    // it; in a session alone the time part is net of the medium's own lead over the
    // quasi-static model, which on the DEM is in time too (its force builds sooner the faster
    // the leg), so that a session alone cannot tell the late sensor: the reason the C-leg's
    // delay at rising speeds is missed.
    let time = |name: &str| {
        case(name)["report"]["signatures"]["delay"]["timing_split"]["time_shift_s"]
            .as_f64()
            .unwrap_or_else(|| panic!("{name}: no timing split"))
    };
    // So on the flat plate's strokes at rising speeds, and on the C-leg's told as a flat plate
    // (whose first stroke, leading the model by more than the shifts searched, is left out).
    for (late, on_time) in [
        ("speed_sensor_delay", "speed"),
        ("cleg_speed_sensor_delay", "cleg_speed"),
    ] {
        let moved = time(late) - time(on_time);
        assert!((moved - 0.020).abs() < 0.005, "{late}: moved {moved} s");
        assert!(time(on_time) < 0.0, "{on_time}: {} s", time(on_time));
    }
    // The base case: the verdict is free, but the model's own misfit is reported as such.
    let base = case("base");
    let u = base["report"]["unexplained"]["share_of_gap_pct"]
        .as_f64()
        .unwrap();
    assert!(
        u > 10.0,
        "the model's misfit on DEM is not all explained away: {u}"
    );
    assert!(
        base["report"]["summary"]
            .as_str()
            .unwrap()
            .contains("unexplained"),
        "{}",
        base["report"]["summary"]
    );
    // The report keeps the shape tools read: verdict, steps, candidates; and every step says
    // what shows it, beyond its term closing part of the gap.
    for c in dem {
        let r = &c["report"];
        assert!(r["verdict"]["effect"].is_string());
        assert!(r["steps"].is_array());
        assert_eq!(r["candidates"].as_array().unwrap().len(), 9);
        for st in r["steps"].as_array().unwrap() {
            assert!(st["basis"].is_string() && !st["claim"].as_str().unwrap().is_empty());
        }
    }
    // The LIGGGHTS beds are not cohesive, and nobody said they were: a cohesion term found by
    // its form alone, on the base case the verdict's, is reported as what it is, and the
    // summary makes no claim of cohesion. The cohesive bed still has it among its effects.
    let verdict = &base["report"]["verdict"];
    assert_eq!(verdict["effect"], "cohesion", "{verdict}");
    assert_eq!(verdict["basis"], "form_only");
    assert!(
        verdict["claim"]
            .as_str()
            .unwrap()
            .contains("cohesion, or the model's own misfit"),
        "{verdict}"
    );
    let summary = base["report"]["summary"].as_str().unwrap();
    assert!(
        summary.contains("The largest is a cohesion-like term")
            && !summary.contains("The largest is cohesion"),
        "{summary}"
    );
    assert_eq!(case("cohesion")["found"], true);
    // Where a signature or a contrast shows the effect, the basis says which.
    let basis = |name: &str, effect: &str| {
        case(name)["report"]["steps"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["effect"] == effect)
            .map(|s| s["basis"].as_str().unwrap().to_string())
            .unwrap_or_default()
    };
    assert_eq!(basis("sensor_bias", "sensor_bias"), "force_out_of_medium");
    assert_eq!(basis("surface_level", "hip_height"), "onset_angle");
    assert_eq!(basis("density", "compaction"), "contrast");
    assert_eq!(basis("speed", "rate"), "contrast");
}

/// The loop closed on strokes the diagnosis did not see: the first two thirds of each session
/// diagnosed, the rest predicted through the node with the bare and the corrected model.
#[test]
fn the_corrected_model_closes_the_reported_share_on_held_out_strokes() {
    let campaign = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/dem/campaign");
    let out = ok(&diagnose_eval(&[
        "--closed-loop",
        "--cases",
        "26",
        "--dem",
        campaign.to_str().unwrap(),
        "--json",
    ]));
    let v: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(
        v["not_checked"],
        serde_json::json!([]),
        "every session is checked"
    );
    let sessions = v["sessions"].as_array().unwrap();
    let of = |source: &str| -> Vec<&Value> {
        sessions.iter().filter(|s| s["source"] == source).collect()
    };
    let (demo, generated, dem) = (of("demo"), of("generated"), of("dem"));
    assert_eq!((demo.len(), generated.len(), dem.len()), (6, 26, 14));
    let rmse = |s: &Value, which: &str| s[which]["rmse_n"].as_f64().unwrap();
    let kept = |s: &Value| !s["kept"].as_array().unwrap().is_empty();
    // The demo's legs: the hidden surcharge is among the corrections, and they close on the
    // held-out strokes what the diagnosis reported.
    for s in &demo {
        assert!(s["kept"].to_string().contains("surcharge"), "{s}");
        assert_eq!(s["holds"], true, "{s}");
        assert!(rmse(s, "corrected") < rmse(s, "bare"), "{s}");
    }
    // Generated sessions: every one with corrections holds and predicts better; one without is
    // predicted alike both ways.
    let corrected: Vec<&&Value> = generated.iter().filter(|s| kept(s)).collect();
    assert!(
        corrected.len() >= 15,
        "{} with corrections",
        corrected.len()
    );
    for s in &generated {
        if kept(s) {
            assert_eq!(s["holds"], true, "{s}");
            assert!(rmse(s, "corrected") < rmse(s, "bare"), "{s}");
        } else {
            let (c, b) = (rmse(s, "corrected"), rmse(s, "bare"));
            assert!((c - b).abs() <= 1e-9 * b, "{s}");
        }
    }
    // DEM: every case gets corrections that predict its held-out strokes better; they close the
    // reported share within 10 points except in one, which the README names: the C-leg told as
    // a flat plate at rising speeds is predicted at speeds the first strokes did not reach. The
    // flat plate's strokes at rising speeds hold, with `rate` in the corrected model.
    let expected_misses = ["cleg_speed"];
    let mut misses: Vec<&str> = Vec::new();
    for s in &dem {
        assert!(kept(s), "{s}");
        assert!(rmse(s, "corrected") < rmse(s, "bare"), "{s}");
        if s["holds"] != true {
            misses.push(s["case"].as_str().unwrap());
        }
    }
    misses.sort();
    assert_eq!(
        misses, expected_misses,
        "the DEM cases whose held-out share falls short"
    );
    let speed = dem.iter().find(|s| s["case"] == "speed").unwrap();
    assert!(speed["kept"].to_string().contains("rate"), "{speed}");
    // The share the report says carries forward (fitted on its earlier strokes, scored on its
    // own last third) is given for every DEM case; on the C-leg at rising speeds it foresees
    // the shortfall: below the folds' share, and within 10 points of what the held-out strokes
    // show.
    for s in &dem {
        assert!(s["reported_forward_pct"].is_number(), "{s}");
    }
    let pct = |s: &Value, k: &str| s[k].as_f64().unwrap();
    // The held-out strokes are whole strokes, in and out of the medium, as the diagnosed ones
    // are: on the base case (four beds alike) the bare model misfits them about as much. A
    // last stroke cut off where the leg leaves the medium is over twice as hard per sample,
    // and an offset, on every sample, a smaller part of its gap.
    let case = |name: &str| dem.iter().find(|s| s["case"] == name).unwrap();
    let base = case("base");
    let ratio = base["bare"]["mse_n2"].as_f64().unwrap() / pct(base, "diagnosed_bare_mse_n2");
    assert!((0.67..1.5).contains(&ratio), "{ratio}: {base}");
    // Each stroke's errors (`strokes`) are those of the whole: the held-out strokes' together
    // are the session's held-out error, for both models.
    for s in sessions {
        let strokes = s["strokes"].as_array().unwrap();
        for which in ["bare", "corrected"] {
            let (mut sum, mut n) = (0.0, 0.0);
            for k in strokes.iter().filter(|k| k["held_out"] == true) {
                let samples = k["samples"].as_f64().unwrap();
                sum += samples * k[format!("{which}_mse_n2")].as_f64().unwrap();
                n += samples;
            }
            let whole = s[which]["mse_n2"].as_f64().unwrap();
            assert!((sum / n - whole).abs() <= 1e-9 * whole, "{which}: {s}");
        }
    }
    let cleg = dem.iter().find(|s| s["case"] == "cleg_speed").unwrap();
    assert!(
        pct(cleg, "reported_forward_pct") < pct(cleg, "reported_pct") - 3.0,
        "{cleg}"
    );
    // Where the C-leg at rising speeds misses: the corrected model's error grows from each
    // stroke to the next faster one, on the diagnosed strokes too, up to the held-out stroke,
    // the fastest (the docs give these errors).
    let errors: Vec<(f64, f64)> = cleg["strokes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|k| {
            (
                k["speed_rad_s"].as_f64().unwrap(),
                k["corrected_mse_n2"].as_f64().unwrap(),
            )
        })
        .collect();
    assert!(
        errors
            .windows(2)
            .all(|w| w[1].0 <= w[0].0 + 0.1 || w[1].1 > w[0].1),
        "{errors:?}"
    );
    assert_eq!(
        cleg["strokes"].as_array().unwrap().last().unwrap()["held_out"],
        true
    );
    assert!(
        pct(cleg, "measured_pct") >= pct(cleg, "reported_forward_pct") - 10.0,
        "{cleg}"
    );
}

/// The node watching its own gap (gap_check): a six-legged session at 1 kHz, run through the
/// node's core as a recording; an F/T offset of 10 % of the peak force that appears half way is
/// reported as a `Gap` naming sensor_bias, which the model does not correct, within 10 strokes;
/// the same session without it gives no such warning.
#[test]
fn the_node_reports_an_offset_that_appears_and_nothing_without_one() {
    use std::f64::consts::TAU;
    use terzaghi::session::reevaluate::{Output, reevaluate};
    use terzaghi::sim::robot::{Gait, Truth, rhex, simulate, write_recording};
    let (params, cfg) = rhex().unwrap();
    assert!(cfg.gap_check.every_strokes > 0, "on by default");
    let truth = Truth {
        b_k: 24.0,
        a: 1.9,
        effects: vec![],
        magnitude: 0.0,
        noise_frac: 0.015,
        rft_scale: 1.0,
    };
    let gait = Gait {
        seconds: 60.0,
        rate_hz: 1000.0,
        mean_speed_rad_s: 4.0,
        seed: 5,
    };
    let clean = simulate(&cfg, &truth, &gait);
    let t_on = 30.0;
    let mut offset = clean.clone();
    for leg in &mut offset.legs {
        let peak = leg
            .iter()
            .map(|s| s.drag_n.abs().max(s.lift_n.abs()))
            .fold(0.0, f64::max);
        for s in leg.iter_mut().filter(|s| s.t_s.unwrap() >= t_on) {
            s.drag_n += 0.1 * peak;
            s.lift_n += 0.1 * peak;
        }
    }
    let t0_ns = 1_700_000_000_000_000_000i64;
    let gaps = |session: &terzaghi::sim::robot::Session| {
        let mut bytes = std::io::Cursor::new(Vec::new());
        write_recording(&mut bytes, &params, &cfg, session, t0_ns).unwrap();
        let bytes = bytes.into_inner();
        let mut out: Vec<(usize, f64, Vec<String>, String)> = Vec::new();
        reevaluate(
            &bytes[..],
            cfg.clone(),
            |_| {},
            |o| {
                if let Output::Gap(_, leg, g) = o {
                    let t = (g.header.stamp.to_nanos() - t0_ns) as f64 * 1e-9;
                    out.push((leg, t, g.new_effects.clone(), g.error.clone()));
                }
            },
        )
        .unwrap();
        out
    };
    let without = gaps(&clean);
    assert!(without.len() >= 30, "{} diagnoses", without.len());
    for (leg, t, new, error) in &without {
        assert!(error.is_empty(), "leg {leg} at {t:.1} s: {error}");
        assert!(
            new.is_empty(),
            "false warning: leg {leg} at {t:.1} s: {new:?}"
        );
    }
    let with = gaps(&offset);
    for leg in 0..cfg.legs.len() {
        let first = with
            .iter()
            .find(|(l, _, new, _)| *l == leg && new.iter().any(|e| e == "sensor_bias"))
            .unwrap_or_else(|| panic!("leg {leg}: the offset is never reported: {with:?}"));
        assert!(
            first.1 >= t_on,
            "leg {leg}: reported before it appears: {first:?}"
        );
        // Strokes from the offset's start to the report, from the leg's own angle.
        let angle_at = |t: f64| {
            let k = offset
                .t_s
                .partition_point(|&x| x < t)
                .min(offset.t_s.len() - 1);
            offset.legs[leg][k].beta_rad
        };
        let mut unwrapped = 0.0;
        let mut prev = angle_at(t_on);
        for k in
            offset.t_s.partition_point(|&x| x < t_on)..offset.t_s.partition_point(|&x| x <= first.1)
        {
            let b = offset.legs[leg][k].beta_rad;
            let d = (b - prev + std::f64::consts::PI).rem_euclid(TAU) - std::f64::consts::PI;
            unwrapped += d;
            prev = b;
        }
        let strokes = unwrapped.abs() / TAU;
        eprintln!(
            "leg {leg}: reported {:.1} s, {strokes:.1} strokes after it appeared",
            first.1 - t_on
        );
        assert!(strokes <= 10.0, "leg {leg}: {strokes:.1} strokes");
    }
}
