//! The `terzaghi` binary as users call it: outputs, --help, and every kind of bad input
//! (exit code 2, one clear line on stderr, no panic, nothing on stdout).

mod common;

use common::SAND_GEOM;
use std::path::Path;
use std::process::{Command, Output};

fn terzaghi(args: &[&str]) -> Output {
    Command::new(common::terzaghi())
        .args(args)
        .output()
        .expect("run terzaghi")
}

const GEOM: [&str; 6] = [
    "--length-m",
    "0.25",
    "--width-m",
    "0.06",
    "--hip-height-m",
    "0.15",
];
const SAND: [&str; 6] = [
    "--unit-weight-n-m3",
    "16170",
    "--phi-deg",
    "32",
    "--delta-deg",
    "19",
];

fn with(base: &[&str], extra: &[&str]) -> Vec<String> {
    base.iter().chain(extra).map(|s| s.to_string()).collect()
}

fn run(args: &[String]) -> Output {
    terzaghi(&args.iter().map(String::as_str).collect::<Vec<_>>())
}

/// Exit 2, a single stderr line that contains every `needle`, no panic, no stdout.
fn assert_clean_error(out: &Output, needles: &[&str]) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "stderr: {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(
        err.trim_end().lines().count(),
        1,
        "one line expected: {err}"
    );
    for n in needles {
        assert!(err.contains(n), "{n:?} missing from: {err}");
    }
    assert!(
        out.stdout.is_empty(),
        "partial output: {}",
        String::from_utf8_lossy(&out.stdout)
    );
}

fn predict(extra: &[&str]) -> Output {
    let mut a = with(&["predict"], &GEOM);
    a.extend(extra.iter().map(|s| s.to_string()));
    run(&a)
}

#[test]
fn predict_prints_the_check_values_as_csv() {
    let mut extra = vec!["--model", "conventional", "--beta-deg", "45:135:15"];
    extra.extend(SAND);
    let out = predict(&extra);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        lines[0],
        "beta_deg,submerged_m,depth_m,drag_n,lift_n,hip_torque_nm,regime"
    );
    assert_eq!(lines.len(), 8);
    assert_eq!(
        lines[2],
        "60,0.076795,0.066506,39.674130,45.639865,12.831005,penetration"
    );
    assert!(lines[5].ends_with("extraction_spiral"));
}

#[test]
fn predict_json_and_presets_and_rft() {
    let out = predict(&[
        "--medium",
        "poppy_lp",
        "--model",
        "rft",
        "--beta-deg",
        "60",
        "--format",
        "json",
    ]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let drag = v[0]["drag_n"].as_f64().unwrap();
    assert!((drag - 14.3).abs() < 0.05, "{drag}");
    // Improved with a preset's Table 3 fit, and with explicit --bk --a (Case B).
    let out = predict(&["--medium", "poppy_cp", "--beta-deg", "60"]);
    assert!(out.status.success());
    let mut extra = vec![
        "--bk",
        "2.5",
        "--a",
        "1.6",
        "--beta-deg",
        "60",
        "--format",
        "json",
    ];
    extra.extend(SAND);
    let v: serde_json::Value = serde_json::from_slice(&predict(&extra).stdout).unwrap();
    assert!((v[0]["drag_n"].as_f64().unwrap() - 60.630824).abs() < 1e-5);
}

/// A plate that can never reach the medium is impossible geometry for a fixed hip: exit 2.
#[test]
fn never_submerged_is_refused() {
    let out = terzaghi(&[
        "predict",
        "--length-m",
        "0.1",
        "--width-m",
        "0.05",
        "--hip-height-m",
        "0.2",
        "--medium",
        "poppy_lp",
        "--beta-deg",
        "90",
    ]);
    assert_clean_error(
        &out,
        &[
            "hip height 0.2 m",
            "--hip-height-m",
            "never enters the medium",
        ],
    );
}

#[test]
fn help_for_every_command() {
    for cmd in [
        vec!["--help"],
        vec!["predict", "--help"],
        vec!["fit", "--help"],
        vec!["media", "--help"],
    ] {
        let out = terzaghi(&cmd);
        assert!(out.status.success(), "{cmd:?}");
        assert!(
            String::from_utf8_lossy(&out.stdout).contains("Usage"),
            "{cmd:?}"
        );
    }
    let out = terzaghi(&["media"]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("glass_spheres_cp"));
}

#[test]
fn impossible_geometry_and_media_are_clean_errors() {
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            vec![
                "--length-m",
                "0",
                "--width-m",
                "0.06",
                "--hip-height-m",
                "0.1",
            ],
            vec!["length", "0"],
        ),
        (
            vec![
                "--length-m",
                "0.25",
                "--width-m",
                "-0.06",
                "--hip-height-m",
                "0.1",
            ],
            vec!["width", "-0.06"],
        ),
        (
            vec![
                "--length-m",
                "0.25",
                "--width-m",
                "0.06",
                "--hip-height-m",
                "-0.1",
            ],
            vec!["hip height", "-0.1"],
        ),
        (
            vec![
                "--length-m",
                "nan",
                "--width-m",
                "0.06",
                "--hip-height-m",
                "0.1",
            ],
            vec!["length", "NaN"],
        ),
    ];
    for (geom, needles) in cases {
        let mut a = vec!["predict"];
        a.extend(geom);
        a.extend(["--medium", "poppy_lp", "--beta-deg", "60"]);
        assert_clean_error(&terzaghi(&a), &needles);
    }
    let bad_media: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            vec![
                "--unit-weight-n-m3",
                "16170",
                "--phi-deg",
                "95",
                "--delta-deg",
                "19",
            ],
            vec!["phi", "95"],
        ),
        (
            vec![
                "--unit-weight-n-m3",
                "16170",
                "--phi-deg",
                "32",
                "--delta-deg",
                "90",
            ],
            vec!["delta", "90"],
        ),
        (
            vec![
                "--unit-weight-n-m3",
                "-1",
                "--phi-deg",
                "32",
                "--delta-deg",
                "19",
            ],
            vec!["unit weight", "-1"],
        ),
        (
            vec![
                "--unit-weight-n-m3",
                "16170",
                "--phi-deg",
                "32",
                "--delta-deg",
                "19",
                "--bk",
                "0",
                "--a",
                "1",
            ],
            vec!["b_k", "0"],
        ),
        (
            vec![
                "--unit-weight-n-m3",
                "16170",
                "--phi-deg",
                "32",
                "--delta-deg",
                "19",
                "--bk",
                "1",
                "--a",
                "-2",
            ],
            vec!["a ", "-2"],
        ),
        (
            vec![
                "--unit-weight-n-m3",
                "16170",
                "--phi-deg",
                "32",
                "--delta-deg",
                "19",
            ],
            vec!["--bk"],
        ),
        (vec!["--medium", "mud"], vec!["mud", "poppy_lp"]),
        (vec![], vec!["no medium"]),
        (
            vec!["--medium", "poppy_lp", "--beta-deg", "0:10:0"],
            vec!["STEP"],
        ),
        (
            vec![
                "--medium",
                "poppy_lp",
                "--model",
                "rft",
                "--rft-elements",
                "0",
            ],
            vec!["element"],
        ),
        (
            vec!["--medium", "glass_beads_lp", "--model", "rft"],
            vec!["--rft-coeffs"],
        ),
    ];
    for (extra, needles) in bad_media {
        let mut a = extra.clone();
        if !a.contains(&"--beta-deg") {
            a.extend(["--beta-deg", "60"]);
        }
        assert_clean_error(&predict(&a), &needles);
    }
}

fn fit(path: &Path, extra: &[&str]) -> Output {
    let mut a = with(&["fit", path.to_str().unwrap()], &GEOM);
    a.extend(SAND.iter().chain(extra).map(|s| s.to_string()));
    run(&a)
}

#[test]
fn fit_rejects_bad_files_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.csv");
    assert_clean_error(&fit(&missing, &[]), &["nope.csv"]);

    let header = dir.path().join("header.csv");
    std::fs::write(&header, "beta,drag,lift\n1,2,3\n").unwrap();
    assert_clean_error(&fit(&header, &[]), &["beta_rad", "beta,drag,lift"]);

    let cell = dir.path().join("cell.csv");
    std::fs::write(&cell, "beta_rad,drag_n,lift_n\n1.0,2,3\n1.1,2x,3\n").unwrap();
    assert_clean_error(&fit(&cell, &[]), &["line 3", "drag_n", "2x"]);

    let empty = dir.path().join("empty.csv");
    std::fs::write(&empty, "").unwrap();
    assert_clean_error(&fit(&empty, &[]), &["empty"]);

    let ragged = dir.path().join("ragged.csv");
    std::fs::write(&ragged, "beta_rad,drag_n,lift_n\n1.0,2,3\n1.1,2\n").unwrap();
    assert_clean_error(&fit(&ragged, &[]), &["line 3"]);

    let few = dir.path().join("few.csv");
    std::fs::write(&few, "beta_rad,drag_n,lift_n\n1.0,2,3\n0.1,0,0\n").unwrap();
    assert_clean_error(&fit(&few, &[]), &["too few usable samples"]);

    let binary = dir.path().join("binary.csv");
    std::fs::write(&binary, [0xff, 0xfe, 0x00, 0x41, 0x0a, 0x80]).unwrap();
    let out = fit(&binary, &[]);
    assert_eq!(out.status.code(), Some(2));
    assert!(!String::from_utf8_lossy(&out.stderr).contains("panicked"));
}

#[test]
fn usage_errors_exit_2() {
    let out = terzaghi(&["predict", "--frobnicate"]);
    assert_eq!(out.status.code(), Some(2));
    let out = terzaghi(&["nonsense"]);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn simulate_then_identify_online_with_trace_and_plot() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("session.csv");
    let mut a = vec![
        "simulate",
        "--bk",
        "2",
        "--a",
        "1.5",
        "--strokes",
        "12",
        "--seed",
        "4",
        "-o",
        data.to_str().unwrap(),
    ];
    a.extend(SAND_GEOM);
    let out = terzaghi(&a);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // A NaN row in the middle is counted, not fatal.
    let mut text = std::fs::read_to_string(&data).unwrap();
    text.push_str("999,1.0,nan,nan\n");
    std::fs::write(&data, text).unwrap();

    let trace = dir.path().join("trace.csv");
    let plot = dir.path().join("trace.svg");
    let mut a = vec![
        "identify",
        data.to_str().unwrap(),
        "--online",
        "--json",
        "--trace",
        trace.to_str().unwrap(),
        "--trace-plot",
        plot.to_str().unwrap(),
    ];
    a.extend(SAND_GEOM);
    let out = terzaghi(&a);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for key in [
        "b_k",
        "a",
        "delta_deg",
        "std_b_k",
        "std_a",
        "converged_at_s",
        "samples",
    ] {
        assert!(v[key].is_number(), "{key}: {v}");
    }
    for key in [
        "psi_drag",
        "psi_lift",
        "r2_drag",
        "r2_lift",
        "rmse_drag_n",
        "rmse_lift_n",
    ] {
        assert!(
            v["improved"][key].is_number() && v["conventional"][key].is_number(),
            "{key}"
        );
    }
    assert_eq!(v["converged"], true);
    assert_eq!(v["changes_detected"], 0);
    assert_eq!(v["samples_non_finite"], 1);
    assert!((v["b_k"].as_f64().unwrap() / 2.0 - 1.0).abs() < 0.03, "{v}");
    assert!((v["a"].as_f64().unwrap() / 1.5 - 1.0).abs() < 0.03, "{v}");

    let trace_text = std::fs::read_to_string(&trace).unwrap();
    assert!(
        trace_text.starts_with("t_s,b_k,a,delta_deg,std_b_k,std_a,innovation_rms_n,converged\n")
    );
    assert_eq!(
        trace_text.lines().count() as u64 - 1,
        v["samples_used"].as_u64().unwrap()
    );
    let svg = std::fs::read_to_string(&plot).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    assert!(
        svg.contains("b_k (online estimate") && svg.contains("<polygon"),
        "band missing"
    );

    // Batch mode of the same command is `fit`.
    let mut a = vec!["identify", data.to_str().unwrap(), "--json"];
    a.extend(SAND_GEOM);
    let v: serde_json::Value = serde_json::from_slice(&terzaghi(&a).stdout).unwrap();
    assert!((v["b_k"].as_f64().unwrap() / 2.0 - 1.0).abs() < 0.03);
}

#[test]
fn identify_errors_are_clean_and_leave_no_partial_file() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("s.csv");
    let mut a = vec![
        "simulate",
        "--strokes",
        "2",
        "--bk",
        "2",
        "--a",
        "1.5",
        "-o",
        data.to_str().unwrap(),
    ];
    a.extend(SAND_GEOM);
    assert!(terzaghi(&a).status.success());
    let d = data.to_str().unwrap();

    let mut a = vec!["identify", d, "--trace", "x.csv"];
    a.extend(SAND_GEOM);
    assert_clean_error(&terzaghi(&a), &["--online"]);

    let mut a = vec!["identify", d, "--online", "--forgetting", "1.5"];
    a.extend(SAND_GEOM);
    assert_clean_error(&terzaghi(&a), &["forgetting factor", "1.5"]);

    let bad_dir = dir.path().join("no/such/dir/trace.csv");
    let mut a = vec![
        "identify",
        d,
        "--online",
        "--trace",
        bad_dir.to_str().unwrap(),
    ];
    a.extend(SAND_GEOM);
    // An output that cannot be written: the run failed (exit 1), its input was fine.
    let out = terzaghi(&a);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(
        err.contains("cannot write") && err.contains("trace.csv"),
        "{err}"
    );

    // Nothing learnable: every sample out of the medium.
    let flat = dir.path().join("flat.csv");
    std::fs::write(&flat, "t_s,beta_rad,drag_n,lift_n\n0,4.0,0,0\n1,4.1,0,0\n").unwrap();
    let mut a = vec!["identify", flat.to_str().unwrap(), "--online"];
    a.extend(SAND_GEOM);
    assert_clean_error(&terzaghi(&a), &["excitation gate"]);

    let mut a = vec!["simulate", "--speed-rad-s", "0:1"];
    a.extend(SAND_GEOM);
    assert_clean_error(&terzaghi(&a), &["speed"]);
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        2,
        "no stray files"
    );
}

/// The shipped Foxglove layout plots what the node serves with the testbed's parameters: every
/// plotted path names a topic the node reads or writes with `launch_configs/testbed.yaml`, and
/// a field of that topic's message type.
#[test]
fn the_foxglove_layout_plots_topics_and_fields_the_node_serves() {
    use terzaghi::config::*;
    use terzaghi::msgs::definition;
    let repo = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let ros = RosArgs {
        params_files: vec![repo.join("launch_configs/testbed.yaml")],
        ..Default::default()
    };
    let params = load_params(&ros, "terzaghi", "/").unwrap();
    let cfg = NodeConfig::from_params(&params, "terzaghi", "/", &[]).unwrap();
    let out = OutputTopics::of(&cfg, &[]);
    // Topic -> (package, type) of what the node serves.
    let mut served = std::collections::HashMap::new();
    for (leg, t) in cfg.legs.iter().zip(&out.legs) {
        served.insert(t.wrench.clone(), ("geometry_msgs", "WrenchStamped"));
        served.insert(t.force.clone(), ("terzaghi_msgs", "LegForce"));
        served.insert(t.params.clone(), ("terzaghi_msgs", "ModelParams"));
        if let Some(ft) = &leg.ft_topic {
            served.insert(ft.clone(), ("geometry_msgs", "WrenchStamped"));
        }
    }
    let layout: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(repo.join("launch_configs/testbed.foxglove.json")).unwrap(),
    )
    .unwrap();
    let mut plotted = 0;
    for (id, panel) in layout["configById"].as_object().unwrap() {
        for path in panel["paths"].as_array().into_iter().flatten() {
            let value = path["value"].as_str().unwrap();
            let (topic, fields) = value.split_once('.').unwrap();
            let (mut pkg, mut ty) = *served
                .get(topic)
                .unwrap_or_else(|| panic!("{id}: {topic} is not a topic the node serves"));
            let fields: Vec<&str> = fields.split('.').collect();
            for (i, field) in fields.iter().enumerate() {
                let def = definition((pkg, ty)).unwrap();
                let line = def
                    .lines()
                    .map(|l| l.split('#').next().unwrap().trim())
                    .find(|l| l.split_whitespace().nth(1) == Some(*field))
                    .unwrap_or_else(|| panic!("{id}: {value}: {pkg}/{ty} has no field {field}"));
                let field_type = line.split_whitespace().next().unwrap();
                if i + 1 < fields.len() {
                    // A nested message: `pkg/Type`, or `Type` of the same package.
                    let (p, t) = field_type.split_once('/').unwrap_or((pkg, field_type));
                    (pkg, ty) = (if p == pkg { pkg } else { leak(p) }, leak(t));
                } else {
                    assert!(
                        ["float64", "uint64", "uint32", "bool"].contains(&field_type),
                        "{id}: {value} is a {field_type}, not a number"
                    );
                }
            }
            plotted += 1;
        }
    }
    assert!(plotted >= 6, "{plotted} paths plotted");
}

fn leak(s: &str) -> &'static str {
    Box::leak(s.to_string().into_boxed_str())
}
