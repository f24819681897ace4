//! `terzaghi-eval diagnose-eval` as the docs quote it: the diagnosis on sessions whose hidden
//! effect it is not told, on the DEM campaign, and its corrections on held-out strokes. These
//! tests live in the evaluation's package, where cargo builds `terzaghi-eval` for them.

#[path = "../../../tests/common/mod.rs"]
mod common;

use common::ok;

use serde_json::Value;
use std::process::{Command, Output};

/// `terzaghi-eval diagnose-eval ARGS`: the diagnosis's own checks.
fn diagnose_eval(args: &[&str]) -> Output {
    Command::new(common::eval_exe())
        .arg("diagnose-eval")
        .args(args)
        .output()
        .expect("run terzaghi-eval")
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
    let campaign = common::repo().join("tests/dem/campaign");
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
    let campaign = common::repo().join("tests/dem/campaign");
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
