//! Gap diagnosis as users run it: `terzaghi diagnose` on CSV logs and MCAP sessions (real files
//! on disk), its reports, its refusals of bad logs, and `diagnose-eval`, the check on sessions
//! whose hidden effect the diagnosis is not told.

mod common;

use common::ok;

use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};

fn terzaghi(args: &[&str]) -> Output {
    Command::new(common::terzaghi())
        .args(args)
        .output()
        .expect("run terzaghi")
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

/// Exports case `i` of diagnose-eval's run 1 (seed 1): its session CSV and its truth.
fn exported(i: usize, dir: &Path) -> (Vec<String>, Vec<String>) {
    terzaghi_eval::withheld::export_case(i, 1, dir).expect("export a generated case");
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
            // Its basis in the words of report.json (form_only), not Rust's (FormOnly).
            let basis = st["basis"].as_str().unwrap();
            assert!(html.contains(&format!(": {basis}")), "{basis}");
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

/// Writes a short six-legged session (1.5 min at 250 Hz, hidden surcharge): the walk of the
/// diagnosis benchmark (`terzaghi-bench diagnose`), through the library.
fn six_legged_session(path: &Path) {
    use terzaghi::sim::robot::{rhex, simulate, surcharge_walk, write_recording};
    let (params, cfg) = rhex().unwrap();
    let (truth, gait) = surcharge_walk(90.0, 250.0);
    let session = simulate(&cfg, &truth, &gait);
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    write_recording(file, &params, &cfg, &session, 1_700_000_000_000_000_000).unwrap();
}

#[test]
fn an_mcap_session_is_diagnosed_per_leg_from_its_recorded_parameters() {
    let tmp = tempfile::tempdir().unwrap();
    let mcap = tmp.path().join("walk.mcap");
    six_legged_session(&mcap);
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
    // The model's own forces without noise: thousandths of a newton of misfit, below the
    // watch's floor (gap_check.min_gap_n), are no effect.
    let noiseless = simulate(
        &cfg,
        &Truth {
            noise_frac: 0.0,
            ..truth.clone()
        },
        &Gait {
            seconds: 30.0,
            ..gait
        },
    );
    let quiet = gaps(&noiseless);
    assert!(quiet.len() >= 12, "{} diagnoses", quiet.len());
    for (leg, t, new, error) in &quiet {
        assert!(
            error.is_empty() && new.is_empty(),
            "noise-free leg {leg} at {t:.1} s: {new:?} {error}"
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

/// A session whose legs ran RFT C-legs gets no verdict about the flat plate it did not use,
/// and no `corrected.yaml` that would rewrite its model (exit 2, each leg named).
#[test]
fn a_session_of_rft_c_legs_gets_no_verdict_on_a_flat_plate() {
    use terzaghi::sim::robot::{Gait, Truth, rhex_c_legs, simulate, write_recording};
    let tmp = tempfile::tempdir().unwrap();
    let mcap = tmp.path().join("c_legs.mcap");
    let (params, cfg) = rhex_c_legs().unwrap();
    let truth = Truth {
        b_k: 30.0,
        a: 2.2,
        effects: vec![],
        magnitude: 0.0,
        noise_frac: 0.015,
        rft_scale: 1.0,
    };
    let gait = Gait {
        seconds: 8.0,
        rate_hz: 200.0,
        mean_speed_rad_s: 4.0,
        seed: 3,
    };
    let walk = simulate(&cfg, &truth, &gait);
    let file = std::io::BufWriter::new(std::fs::File::create(&mcap).unwrap());
    write_recording(file, &params, &cfg, &walk, 1_700_000_000_000_000_000).unwrap();
    let out_dir = tmp.path().join("diagnosis");
    let out = terzaghi(&[
        "diagnose",
        mcap.to_str().unwrap(),
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    refused(
        &out,
        &[
            "front_left ran with model rft and shape c_leg",
            "gives no verdict on a model the session did not use",
        ],
    );
    assert!(!out_dir.join("corrected.yaml").exists());
    assert!(!out_dir.join("front_left/report.json").exists());
}

/// The report says how the F/T sensor delivers its values: every row new in a generated log,
/// one value held for 8 rows once the log is made to hold them, as a 12 Hz sensor on a 100 Hz
/// stream does.
#[test]
fn the_report_gives_the_sensors_rate_and_hold() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("case0");
    let (flags, _) = exported(0, &dir);
    let text = std::fs::read_to_string(dir.join("session.csv")).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let cols: Vec<&str> = header.split(',').collect();
    let (id, il) = (
        cols.iter().position(|c| *c == "drag_n").unwrap(),
        cols.iter().position(|c| *c == "lift_n").unwrap(),
    );
    let mut held = format!("{header}\n");
    let mut kept: Vec<String> = Vec::new();
    for (k, line) in lines.enumerate() {
        let mut cells: Vec<String> = line.split(',').map(str::to_string).collect();
        if k % 8 == 0 {
            kept = vec![cells[id].clone(), cells[il].clone()];
        }
        cells[id] = kept[0].clone();
        cells[il] = kept[1].clone();
        held += &(cells.join(",") + "\n");
    }
    std::fs::write(dir.join("held.csv"), held).unwrap();
    for (file, rows_per_value) in [("session.csv", 1.0), ("held.csv", 8.0)] {
        let out_dir = dir.join(format!("report_{file}"));
        let mut args = vec![
            "diagnose".to_string(),
            dir.join(file).display().to_string(),
            "--out".into(),
            out_dir.display().to_string(),
        ];
        args.extend(flags.clone());
        ok(&terzaghi(
            &args.iter().map(String::as_str).collect::<Vec<_>>(),
        ));
        let s = &json(&out_dir.join("report.json"))["sensor"];
        let got = s["rows_per_value"].as_f64().unwrap();
        assert!((got / rows_per_value - 1.0).abs() < 0.05, "{file}: {s}");
        let (stream, update) = (
            s["stream_rate_hz"].as_f64().unwrap(),
            s["update_rate_hz"].as_f64().unwrap(),
        );
        assert!(
            (stream / update / rows_per_value - 1.0).abs() < 0.05,
            "{file}: {s}"
        );
        // The corrected model tells the node the sensor's period where it holds its values.
        let corrected = std::fs::read_to_string(out_dir.join("corrected.yaml")).unwrap();
        let hold_s = corrected
            .lines()
            .find_map(|l| l.trim().strip_prefix("sensor_hold_s:"))
            .map(|v| v.trim().parse::<f64>().unwrap());
        if rows_per_value > 1.0 {
            let hold_s =
                hold_s.unwrap_or_else(|| panic!("{file}: no sensor_hold_s in\n{corrected}"));
            assert!(
                (hold_s * stream / rows_per_value - 1.0).abs() < 0.05,
                "{file}: hold {hold_s} s"
            );
        } else {
            assert_eq!(hold_s, None, "{file}: {corrected}");
        }
    }
    // Replayed with it, the node's expected reading is the force held as the sensor holds it:
    // closer to what the sensor read than the force itself.
    let rows = dir.join("held_rows.csv");
    ok(&terzaghi(&[
        "replay",
        "--reevaluate",
        dir.join("held.csv").to_str().unwrap(),
        "--params-file",
        dir.join("report_held.csv/corrected.yaml").to_str().unwrap(),
        "-o",
        rows.to_str().unwrap(),
    ]));
    let mut rdr = csv::Reader::from_path(&rows).unwrap();
    let h = rdr.headers().unwrap().clone();
    let col = |c: &str| h.iter().position(|x| x == c).unwrap();
    let (im, ip, ie) = (
        col("measured_lift_n"),
        col("predicted_lift_n"),
        col("expected_reading_lift_n"),
    );
    // Over the rows in the medium: the error of each, and whether the expected reading changes
    // at the rows where the sensor's does.
    let (mut n, mut sp, mut se, mut agree) = (0.0, 0.0, 0.0, 0.0);
    let mut last: Option<(f64, f64)> = None;
    for r in rdr.records() {
        let r = r.unwrap();
        if r[im].is_empty() {
            continue;
        }
        let (m, p, e): (f64, f64, f64) = (
            r[im].parse().unwrap(),
            r[ip].parse().unwrap(),
            r[ie].parse().unwrap(),
        );
        if let (Some((lm, le)), true) = (last, p != 0.0) {
            n += 1.0;
            sp += (m - p).powi(2);
            se += (m - e).powi(2);
            agree += f64::from(u8::from((m != lm) == (e != le)));
        }
        last = Some((m, e));
    }
    let (rmse_p, rmse_e) = ((sp / n).sqrt(), (se / n).sqrt());
    let line = format!(
        "held 8 rows, {n} rows in the medium: RMSE of the force {rmse_p:.3} N, of the expected reading {rmse_e:.3} N; the expected reading changes with the sensor's on {:.1} % of rows",
        100.0 * agree / n
    );
    eprintln!("{line}");
    assert!(common::docs_text().contains(&line), "the docs lack\n{line}");
    assert!(agree / n > 0.95, "{agree} of {n}");
    assert!(rmse_e < rmse_p, "{rmse_e} against {rmse_p}");
}

/// A 12 Hz sensor whose readings come three of its samples (250 ms) late: the lag is searched
/// out to four sample periods, and found (it lay beyond the 0.1 s the search stopped at).
#[test]
fn a_slow_sensors_lag_of_a_few_periods_is_found() {
    let tmp = tempfile::tempdir().unwrap();
    let log = tmp.path().join("s12.csv");
    let geometry = [
        "--length-m",
        "0.1",
        "--width-m",
        "0.03",
        "--hip-height-m",
        "0.05",
        "--medium",
        "poppy_lp",
    ];
    let mut args = vec!["simulate"];
    args.extend(geometry);
    args.extend([
        "--rate-hz",
        "12",
        "--strokes",
        "30",
        "--speed-rad-s",
        "0.8:1.2",
        "--noise-frac",
        "0.01",
        "-o",
        log.to_str().unwrap(),
    ]);
    ok(&terzaghi(&args));
    let text = std::fs::read_to_string(&log).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let cols: Vec<&str> = header.split(',').collect();
    let (id, il) = (
        cols.iter().position(|c| *c == "drag_n").unwrap(),
        cols.iter().position(|c| *c == "lift_n").unwrap(),
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let mut late = format!("{header}\n");
    for k in 3..rows.len() {
        let mut r = rows[k].clone();
        r[id] = rows[k - 3][id];
        r[il] = rows[k - 3][il];
        late += &(r.join(",") + "\n");
    }
    let late_log = tmp.path().join("late.csv");
    std::fs::write(&late_log, late).unwrap();
    let out_dir = tmp.path().join("report");
    let mut args = vec![
        "diagnose",
        late_log.to_str().unwrap(),
        "--out",
        out_dir.to_str().unwrap(),
    ];
    args.extend(geometry);
    ok(&terzaghi(&args));
    let r = json(&out_dir.join("report.json"));
    assert_eq!(r["verdict"]["effect"], "sensor_lag", "{}", r["verdict"]);
    let tau = r["corrected_model"]["nonlinear"]["time_constant_s"]
        .as_f64()
        .or_else(|| {
            r["candidates"]
                .as_array()
                .unwrap()
                .iter()
                .find(|c| c["effect"] == "sensor_lag")
                .and_then(|c| c["params"]["time_constant_s"].as_f64())
        })
        .unwrap();
    assert!(tau > 0.1, "time constant {tau} s");
    let s = &r["sensor"];
    assert!(
        (s["update_rate_hz"].as_f64().unwrap() - 12.0).abs() < 0.5,
        "{s}"
    );
}

/// A recording of the model's own forces, without noise (what `hexapod_walk.py --record` or
/// `simulate-robot --noise-frac 0` writes): the held-out gap is thousandths of a newton of
/// numerical misfit, and no effect is named for it. Every leg is `none`, "no gap to explain",
/// with the floor it fell under; the floor is the user's to set, and at 0 the search runs on.
#[test]
fn a_noise_free_walk_has_no_gap_to_explain() {
    let dir = tempfile::tempdir().unwrap();
    let mcap = dir.path().join("walk.mcap");
    ok(&terzaghi(&[
        "simulate-robot",
        "--seconds",
        "20",
        "--noise-frac",
        "0",
        "-o",
        mcap.to_str().unwrap(),
    ]));
    let out = dir.path().join("diag");
    let text = ok(&terzaghi(&[
        "diagnose",
        mcap.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]));
    print!("{text}");
    let verdicts: Vec<&str> = text.lines().filter(|l| l.starts_with("leg ")).collect();
    assert_eq!(verdicts.len(), 6, "{text}");
    for v in &verdicts {
        assert!(
            v.contains("verdict none (no gap to explain:")
                && v.contains("within what the sensor resolves (0.010 N)"),
            "{v}"
        );
    }
    for leg in ["front_left", "rear_right"] {
        let r = json(&out.join(leg).join("report.json"));
        assert_eq!(r["gap"]["below_resolution"], true, "{leg}");
        assert!(r["gap"]["gap_rms_n"].as_f64().unwrap() < 0.01, "{leg}");
        assert!(r["steps"].as_array().unwrap().is_empty(), "{leg}");
        assert!(
            r["summary"].as_str().unwrap().contains("no gap to explain"),
            "{}",
            r["summary"]
        );
    }
    // The floor decides: with none stated, the thousandths are searched for effects.
    let none_floor = ok(&terzaghi(&[
        "diagnose",
        mcap.to_str().unwrap(),
        "--out",
        dir.path().join("diag0").to_str().unwrap(),
        "--min-gap-n",
        "0",
    ]));
    assert!(
        none_floor
            .lines()
            .any(|l| l.starts_with("leg ") && !l.contains("verdict none")),
        "{none_floor}"
    );
    refused(
        &terzaghi(&[
            "diagnose",
            mcap.to_str().unwrap(),
            "--out",
            dir.path().join("d").to_str().unwrap(),
            "--min-gap-n",
            "-1",
        ]),
        &["--min-gap-n", "-1"],
    );
}
