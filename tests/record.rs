//! Recording sessions to MCAP: read back by independent readers (Python mcap-ros2-support and
//! rosbags), crash safety, and robustness against damaged files.

mod common;

use common::*;
use std::path::Path;
use std::process::Command;

const PARAMS: &str = "/**:\n  ros__parameters:\n    legs: [leg]\n    leg:\n      joint: hip\n      length_m: 0.25\n      width_m: 0.06\n      hip_height_m: 0.15\n      unit_weight_n_m3: 16170\n      phi_deg: 32.0\n      delta_deg: 19.0\n      b_k: 2.0\n      a: 1.5\n      ft_topic: leg/ft\n";
const FLAGS: &str = r#"["--length-m","0.25","--width-m","0.06","--hip-height-m","0.15","--unit-weight-n-m3","16170","--phi-deg","32","--delta-deg","19","--bk","2","--a","1.5"]"#;

/// Runs the Cyclone DDS peer against `terzaghi node --record`, with `extra` peer options.
fn recorded_session(dir: &Path, domain: &str, extra: &[&str]) -> serde_json::Value {
    let params = dir.join("leg.yaml");
    std::fs::write(&params, PARAMS).unwrap();
    let mcap = dir.join("session.mcap");
    let node_args = serde_json::json!(["--record", mcap, "--ros-args", "--params-file", params]);
    let out = isolated_command(&python())
        .arg(repo().join("tests/python/interop_peer.py"))
        .arg("--terzaghi")
        .arg(terzaghi())
        .args([
            "--node-args",
            &node_args.to_string(),
            "--predict-flags",
            FLAGS,
            "--identify",
            "--domain",
            domain,
        ])
        .arg("--dump")
        .arg(dir.join("dump.json"))
        .args(extra)
        .current_dir(repo().join("tests/python"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    eprintln!("{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "peer failed");
    serde_json::from_str(&stdout).unwrap()
}

fn info_json(file: &Path, out: &Path) {
    let o = Command::new(terzaghi())
        .arg("info")
        .arg(file)
        .arg("--json")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::write(out, &o.stdout).unwrap();
}

fn check_with_python_readers(file: &Path, dir: &Path, extra: &[&str]) -> serde_json::Value {
    info_json(file, &dir.join("info.json"));
    let out = Command::new(python())
        .arg(repo().join("tests/python/check_recording.py"))
        .arg(file)
        .arg(dir.join("dump.json"))
        .arg(dir.join("info.json"))
        .args(extra)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    eprintln!("{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "independent readers disagree");
    serde_json::from_str(&stdout).unwrap()
}

/// A node session recorded inside the namespace opens with mcap-ros2-support and rosbags; every
/// message the peer published or received decodes to the same values, and the counts per topic
/// agree with `terzaghi info` in both readers.
#[test]
fn recorded_session_reads_back_in_mcap_ros2_and_rosbags() {
    let dir = tempfile::tempdir().unwrap();
    recorded_session(dir.path(), "21", &["--strokes", "6"]);
    let file = dir.path().join("session.mcap");
    let v = check_with_python_readers(&file, dir.path(), &[]);
    for reader in ["mcap_ros2", "rosbags"] {
        for kind in ["joint_states", "ft", "predicted_wrench"] {
            let k = &v[format!("{reader}:{kind}")];
            assert!(k["published"].as_u64().unwrap() > 100, "{k}");
            assert_eq!(k["missing"], 0);
            assert_eq!(k["wrong"], 0);
        }
        assert!(v[reader]["/diagnostics"].as_u64().unwrap() >= 3);
        assert!(v[reader]["/leg/leg_force"].as_u64().unwrap() > 100);
    }
    let o = Command::new(terzaghi())
        .arg("info")
        .arg(&file)
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&o.stdout).contains("complete:  yes"));
}

/// SIGKILL mid-session: `recover` keeps every message received more than a second before the
/// kill, and the recovered file opens in both readers.
#[test]
fn a_killed_recording_is_recovered_but_for_the_last_second() {
    let dir = tempfile::tempdir().unwrap();
    let v = recorded_session(dir.path(), "22", &["--strokes", "6", "--kill-after", "4"]);
    assert_eq!(v["node_exit_code"], -9);
    let cut = dir.path().join("session.mcap");
    let o = Command::new(terzaghi())
        .arg("info")
        .arg(&cut)
        .output()
        .unwrap();
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("complete:  no"),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    let fixed = dir.path().join("fixed.mcap");
    let o = Command::new(terzaghi())
        .arg("recover")
        .arg(&cut)
        .arg("-o")
        .arg(&fixed)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).starts_with("kept "));
    let v = check_with_python_readers(&fixed, dir.path(), &["--crash"]);
    for reader in ["mcap_ros2", "rosbags"] {
        for kind in ["joint_states", "ft"] {
            let k = &v[format!("{reader}:{kind}")];
            assert!(k["published"].as_u64().unwrap() > 200, "{k}");
            assert_eq!(k["missing"], 0, "{reader} {kind}");
        }
    }
}
