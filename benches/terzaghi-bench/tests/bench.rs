//! `terzaghi-bench` as the docs run it: its help, and the diagnosis benchmark's session
//! diagnosed by `terzaghi diagnose` (the binary beside it) on every leg.

#[path = "../../../tests/common/mod.rs"]
mod common;

use std::process::Command;

#[test]
fn the_benchmarks_explain_themselves() {
    for cmd in [
        vec!["--help"],
        vec!["model", "--help"],
        vec!["node", "--help"],
        vec!["diagnose", "--help"],
    ] {
        let out = Command::new(common::bench_exe())
            .args(&cmd)
            .output()
            .unwrap();
        assert!(out.status.success(), "terzaghi-bench {cmd:?}");
        assert!(
            String::from_utf8_lossy(&out.stdout).contains("Usage"),
            "{cmd:?}"
        );
    }
}

/// `terzaghi-bench diagnose` times `terzaghi diagnose` on a walk whose hidden effect is
/// surcharge: every leg's verdict comes back, and names it.
#[test]
fn the_diagnosis_benchmark_diagnoses_every_leg() {
    let dir = tempfile::tempdir().unwrap();
    let keep = dir.path().join("walk.mcap");
    let out = Command::new(common::bench_exe())
        .args([
            "diagnose",
            "--minutes",
            "1.5",
            "--rate-hz",
            "250",
            "--json",
            "--keep",
        ])
        .arg(&keep)
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_str(&common::ok(&out)).expect("JSON on stdout");
    let verdicts = v["verdicts"].as_array().expect("verdicts");
    assert_eq!(verdicts.len(), 6, "{v}");
    assert!(verdicts.iter().all(|e| e == "surcharge"), "{v}");
    assert!(keep.exists());
}

#[test]
fn a_bad_duration_is_a_usage_error() {
    let out = Command::new(common::bench_exe())
        .args(["model", "--seconds", "-1"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}

/// RFT integrated over 100 elements costs at least 5x one improved-model evaluation, measured in
/// the same run (a ratio, so that the machine's load cancels out): the improved model stays the
/// cheap one (about 15x on a quiet machine; under a loaded machine the short evaluation's time
/// swells more than the long one's).
#[test]
fn rft_costs_at_least_5x_the_improved_model() {
    let out = Command::new(common::bench_exe())
        .args(["model", "--seconds", "0.3", "--json"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    eprintln!("{v}");
    assert!(v["ratio_rft_to_improved"].as_f64().unwrap() >= 5.0, "{v}");
    assert!(v["improved_median_ns"].as_f64().unwrap() > 0.0, "{v}");
    assert!(v["online_update_median_ns"].as_f64().unwrap() > 0.0, "{v}");
}
