//! The node on a real DDS network, against an independent DDS implementation (Python
//! cyclonedds), inside a private network namespace. Each test uses its own DDS domain, so that
//! tests running at once in one namespace do not hear each other.

mod common;

use common::*;
use std::sync::{RwLock, RwLockReadGuard, RwLockWriteGuard};

/// The discovery benchmark measures start-up times against a threshold: it runs alone, the
/// other tests of this file side by side. (Run beside one, it also starved a node's parameter
/// service of a first answer for 10 s once in six runs.)
static ALONE: RwLock<()> = RwLock::new(());

fn shared() -> RwLockReadGuard<'static, ()> {
    ALONE.read().unwrap_or_else(|p| p.into_inner())
}

fn alone() -> RwLockWriteGuard<'static, ()> {
    ALONE.write().unwrap_or_else(|p| p.into_inner())
}

fn run_peer(node_args: &[&str], predict_flags: &[&str], extra: &[&str]) -> serde_json::Value {
    let out = isolated_command(&python())
        .arg(repo().join("tests/python/interop_peer.py"))
        .arg("--terzaghi")
        .arg(terzaghi())
        .arg("--node-args")
        .arg(serde_json::to_string(node_args).unwrap())
        .arg("--predict-flags")
        .arg(serde_json::to_string(predict_flags).unwrap())
        .args(extra)
        .current_dir(repo().join("tests/python"))
        .output()
        .expect("run the Python peer");
    let stdout = String::from_utf8_lossy(&out.stdout);
    eprintln!("{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "peer failed: {stdout}");
    serde_json::from_str(&stdout).expect("peer summary")
}

/// Cyclone DDS publishes JointState and F/T; the node's wrenches match `terzaghi predict` and
/// its model_params converge within 3 % to the b_k, a the F/T was generated with.
#[test]
fn cyclonedds_peer_gets_predictions_and_sees_identification_converge() {
    let _guard = shared();
    let dir = tempfile::tempdir().unwrap();
    let params = dir.path().join("leg.yaml");
    std::fs::write(&params, LEG_PARAMS).unwrap();
    let mut flags = SAND_GEOM.to_vec();
    flags.extend(["--bk", "2.0", "--a", "1.5"]);
    // Pinned to one CPU, as a control node on a core of its own runs (its DDS threads too).
    let v = run_peer(
        &[
            "--cpu",
            "0",
            "--ros-args",
            "--params-file",
            params.to_str().unwrap(),
        ],
        &flags,
        &[
            "--identify",
            "--truth-bk",
            "3.0",
            "--truth-a",
            "1.8",
            "--domain",
            "11",
        ],
    );
    assert_eq!(v["checks"]["predictions"]["received"], 21);
    let id = &v["checks"]["identification"];
    assert!(id["rel_error_b_k"].as_f64().unwrap().abs() < 0.03, "{id}");
    assert!(id["rel_error_a"].as_f64().unwrap().abs() < 0.03, "{id}");
    assert_eq!(id["converged"], true);
    assert_eq!(v["node_exit_code"], 0);
}

/// rclpy, ROS 2's own client library over Fast DDS, as a ROS 2 user's code: predicted wrenches
/// (best-effort and reliable JointState publishers) and `leg_force` through the colcon-built
/// terzaghi_msgs, checked against `terzaghi predict`; `model_params` converging from F/T and
/// reaching a late transient-local subscriber; the parameter services from rclpy's client
/// (list, get, describe, a refused and an accepted set); the node's log on `/rosout`; and
/// `/diagnostics` stamped by `/clock` under `use_sim_time`, a jump back followed and counted.
#[test]
fn rclpy_peer_over_fast_dds_sees_what_a_ros_user_relies_on() {
    let _guard = shared();
    let out = ros_python_command(
        "rclpy_peer.py",
        &["--terzaghi", terzaghi().to_str().unwrap(), "--domain", "21"],
    )
    .output()
    .expect("run the rclpy peer");
    let stdout = String::from_utf8_lossy(&out.stdout);
    eprintln!("{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).expect("peer summary");
    let checks = v["checks"].as_object().expect("checks");
    for name in [
        "predicted_wrench_best_effort",
        "predicted_wrench_reliable",
        "leg_force_best_effort",
        "leg_force_reliable",
        "param_list",
        "param_get",
        "param_describe",
        "param_set_refused",
        "param_set",
        "param_set_takes_effect",
        "model_params_converge",
        "model_params_transient_local",
        "diagnostics_follow_clock",
        "clock_jump_back_followed",
        "rosout_startup",
        "rosout_refused_param",
        "rosout_param_set",
        "rosout_clock_back",
        "rosout_source",
    ] {
        assert_eq!(checks[name]["ok"], true, "{name}: {}", checks[name]);
    }
    assert_eq!(v["node_exit_code"], 0);
    assert!(out.status.success());
}

/// Time from the node's start to the first prediction a peer receives, for a Cyclone DDS and an
/// rclpy (Fast DDS) peer, each started before and after the node, 20 starts each: the median
/// within 0.5 s and no start over 2.5 s. Most starts take 0.13-0.22 s; now and then one takes a
/// second more (1.2 s: its first match waits for a one-second retry), up to 3 of 20 in one CI
/// run, so the p90 is reported, not asserted (docs/node.md). Before the RustDDS patch
/// (patches/README.md) a Cyclone peer that was up first waited 7.9 s every time.
#[test]
fn discovery_with_cyclone_and_rclpy_peers_is_under_a_second() {
    let _guard = alone();
    let mut report = Vec::new();
    for (k, (peer, order)) in [
        ("cyclone", "before"),
        ("cyclone", "after"),
        ("rclpy", "before"),
        ("rclpy", "after"),
    ]
    .into_iter()
    .enumerate()
    {
        // Domains 20-99: a DDS domain above 101 puts its ports in Linux's ephemeral range
        // (32768-60999), where another socket of the namespace may hold one (a Cyclone peer in
        // domain 147 once failed to bind 44150: address in use).
        let domain = (20 + 20 * k).to_string();
        let out = ros_python_command(
            "discovery.py",
            &[
                "--terzaghi",
                terzaghi().to_str().unwrap(),
                "--peer",
                peer,
                "--order",
                order,
                "--starts",
                "20",
                "--domain",
                &domain,
            ],
        )
        .output()
        .expect("run the discovery peer");
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{peer} {order}: {stdout}\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let v: serde_json::Value = serde_json::from_str(stdout.trim()).expect("discovery summary");
        report.push(v.to_string());
        assert_eq!(v["failures"], 0, "{v}");
        assert!(v["p50_s"].as_f64().unwrap() <= 0.5, "{peer} {order}: {v}");
        let slowest = v["times_s"]
            .as_array()
            .unwrap()
            .iter()
            .map(|t| t.as_f64().unwrap())
            .fold(0.0, f64::max);
        assert!(slowest <= 2.5, "{peer} {order}: {v}");
    }
    eprintln!("{}", report.join("\n"));
}

/// The shipped testbed parameter file, with --ros-args overrides: another plate width (whose
/// Table 1 fit the hit_sand preset supplies), a namespace and a joint name, on ROS_DOMAIN_ID 7
/// with discovery on localhost only; then `leg.b_k` set
/// through the parameter services takes effect at once, and an invalid width is refused.
#[test]
fn node_runs_from_the_launch_config_with_ros_args_overrides() {
    let _guard = shared();
    let params = repo().join("launch_configs/testbed.yaml");
    let v = run_peer(
        &[
            "--ros-args",
            "--params-file",
            params.to_str().unwrap(),
            "-p",
            "leg.width_m:=0.04",
            "-p",
            "leg.joint:=knee",
            "-r",
            "__ns:=/bench",
        ],
        &[
            "--length-m",
            "0.25",
            "--width-m",
            "0.04",
            "--hip-height-m",
            "0.15",
            "--medium",
            "hit_sand",
        ],
        &[
            "--ns",
            "/bench",
            "--joint",
            "knee",
            "--set-param",
            "leg.b_k=7.5",
            "--domain",
            "7",
            "--after-set-flags",
            r#"["--length-m", "0.25", "--width-m", "0.04", "--hip-height-m", "0.15", "--medium", "hit_sand", "--bk", "7.5", "--a", "1.61"]"#,
        ],
    );
    assert_eq!(v["checks"]["predictions"]["received"], 21);
    assert_eq!(v["checks"]["predictions"]["worst_rel_error"], 0.0);
    // Changed at run time, without a restart; an invalid value is refused with its reason.
    assert_eq!(v["checks"]["predictions_after_set"]["received"], 21);
    assert_eq!(v["checks"]["predictions_after_set"]["worst_rel_error"], 0.0);
    assert_eq!(v["checks"]["refused_set"]["exit_code"], 2);
}

/// A CPU that does not exist is refused at start-up, naming it, before any DDS traffic.
#[test]
fn a_cpu_that_does_not_exist_is_refused() {
    let _guard = shared();
    let out = isolated_command(&terzaghi())
        .args(["node", "--cpu", "4096", "--ros-args", "--params-file"])
        .arg(repo().join("launch_configs/rhex.yaml"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("CPU 4096 does not exist"), "{err}");
}

/// `terzaghi demo --dds`: the same walk over real DDS (the node and the simulated robot as two
/// participants), recorded by the node and diagnosed.
#[test]
fn the_demo_runs_over_dds() {
    let _guard = shared();
    let tmp = tempfile::tempdir().unwrap();
    let out = isolated_command(&terzaghi())
        .args(["demo", "--dds", "--seconds", "15", "--speed", "5", "--out"])
        .arg(tmp.path())
        .env("ROS_DOMAIN_ID", "31")
        .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        .output()
        .expect("run the demo");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(tmp.path().join("summary.json")).unwrap())
            .unwrap();
    // Over DDS a few best-effort samples may be lost while discovery settles; most arrive.
    assert!(summary["recorded_messages"].as_u64().unwrap() > 15 * 500 * 10);
    let hidden = summary["truth"]["effects"].as_array().unwrap().clone();
    for leg in summary["legs"].as_array().unwrap() {
        assert!(hidden.contains(&leg["verdict"]), "{leg}");
        assert!(leg["online"]["b_k"].as_f64().unwrap() > 0.0, "{leg}");
    }
}

/// `node --foxglove`: an independent Foxglove WebSocket client (Python `websockets`, protocol
/// foxglove.sdk.v1, formerly foxglove.websocket.v1) sees every topic advertised with its ROS 2
/// schema, subscribes, and
/// decodes what it receives with the advertised schema alone (mcap-ros2-support's decoder):
/// the predicted wrenches are the ones the node records, value for value, and the measured F/T
/// the ones replayed into it.
#[test]
fn a_foxglove_client_receives_predicted_and_measured_forces_live() {
    let _guard = shared();
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src.mcap");
    // 400 joint states and F/T samples 5 ms apart.
    std::fs::write(&src, leg_session_with(400, 5_000_000, 1_000_000_000, false)).unwrap();
    let params = dir.path().join("leg.yaml");
    std::fs::write(&params, LEG_PARAMS).unwrap();
    let rec = dir.path().join("node.mcap");
    let live = dir.path().join("live.json");
    let t = terzaghi();
    let script = format!(
        "ROS_DOMAIN_ID=33 '{t}' node --record '{rec}' --foxglove 127.0.0.1:18765 --ros-args --params-file '{params}' & N=$!; \
         '{py}' '{client}' live --url ws://127.0.0.1:18765 --seconds 8 --keep 100000 --out '{live}' \
           --topics /joint_states /leg/ft /leg/predicted_wrench /leg/leg_force /leg/model_params /diagnostics /rosout & C=$!; \
         sleep 1; ROS_DOMAIN_ID=33 '{t}' replay '{src}' --rate 1; wait $C; kill -INT $N; wait $N",
        t = t.display(),
        rec = rec.display(),
        params = params.display(),
        py = python().display(),
        client = repo().join("tests/python/foxglove_client.py").display(),
        live = live.display(),
        src = src.display(),
    );
    let out = isolated_command(std::path::Path::new("/bin/sh"))
        .arg("-c")
        .arg(&script)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let v: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(&live)
            .unwrap_or_else(|e| panic!("the client's output: {e}; stderr:\n{stderr}")),
    )
    .unwrap();
    assert_eq!(v["subprotocol"], "foxglove.sdk.v1");
    let topic = |t: &str| &v["topics"][t];
    for (t, schema) in [
        ("/joint_states", "sensor_msgs/msg/JointState"),
        ("/leg/ft", "geometry_msgs/msg/WrenchStamped"),
        ("/leg/predicted_wrench", "geometry_msgs/msg/WrenchStamped"),
        ("/leg/leg_force", "terzaghi_msgs/msg/LegForce"),
        ("/leg/model_params", "terzaghi_msgs/msg/ModelParams"),
        ("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray"),
        ("/rosout", "rcl_interfaces/msg/Log"),
    ] {
        assert_eq!(topic(t)["schemaName"], schema, "{t}: {}", topic(t));
        assert_eq!(topic(t)["encoding"], "cdr", "{t}");
        assert_eq!(topic(t)["schemaEncoding"], "ros2msg", "{t}");
    }
    // What the node recorded, by stamp.
    let bytes = std::fs::read(&rec).unwrap();
    let session = terzaghi::record::read::read_session(&bytes).unwrap();
    let by_stamp = |name: &str| -> std::collections::HashMap<(i64, i64), [f64; 3]> {
        let i = session.topics.iter().position(|t| t.topic == name).unwrap();
        session
            .messages
            .iter()
            .filter(|m| m.topic == i)
            .map(|m| {
                let w: terzaghi::msgs::WrenchStamped = session.decode(m).unwrap();
                let s = &w.header.stamp;
                (
                    (s.sec as i64, s.nanosec as i64),
                    [w.wrench.force.x, w.wrench.force.z, w.wrench.torque.y],
                )
            })
            .collect()
    };
    for (t, min) in [("/leg/predicted_wrench", 390), ("/leg/ft", 390)] {
        let recorded = by_stamp(t);
        let live = topic(t)["messages"].as_array().unwrap();
        assert!(live.len() >= min, "{t}: {} received live", live.len());
        for m in live {
            let s = &m["header"]["stamp"];
            let key = (s["sec"].as_i64().unwrap(), s["nanosec"].as_i64().unwrap());
            let w = &m["wrench"];
            let got = [
                w["force"]["x"].as_f64().unwrap(),
                w["force"]["z"].as_f64().unwrap(),
                w["torque"]["y"].as_f64().unwrap(),
            ];
            // Equal to the bit, up to serde_json's float parsing (not exact in its last bit).
            let want = recorded
                .get(&key)
                .unwrap_or_else(|| panic!("{t}: {key:?} not recorded"));
            for (w, g) in want.iter().zip(got) {
                assert!(
                    (w - g).abs() <= 1e-12 * w.abs().max(1.0),
                    "{t} at {key:?}: {want:?} {got:?}"
                );
            }
        }
    }
    assert!(topic("/leg/leg_force")["received"].as_u64().unwrap() >= 390);
    assert!(topic("/joint_states")["received"].as_u64().unwrap() >= 390);
    assert!(topic("/diagnostics")["received"].as_u64().unwrap() >= 3);
}

/// `--ros-args --log-level warn` leaves out the node's info lines (its start-up, its summary),
/// as a ROS user expects; by default they are there.
#[test]
fn the_log_level_flag_is_honoured() {
    let _guard = shared();
    let dir = tempfile::tempdir().unwrap();
    let params = dir.path().join("leg.yaml");
    std::fs::write(&params, LEG_PARAMS).unwrap();
    let run = |extra: &str| {
        let script = format!(
            "'{t}' node --ros-args --params-file '{p}' {extra} & N=$!; sleep 1.5; kill -INT $N; wait $N",
            t = terzaghi().display(),
            p = params.display()
        );
        let out = isolated_command(std::path::Path::new("/bin/sh"))
            .arg("-c")
            .arg(&script)
            .env("ROS_DOMAIN_ID", "39")
            .output()
            .unwrap();
        assert!(out.status.success());
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    let default = run("");
    assert!(
        default.contains("[INFO]") && default.contains("[terzaghi]: terzaghi node stopped"),
        "{default}"
    );
    let warn = run("--log-level warn");
    assert!(!warn.contains("[INFO]"), "{warn}");
    // An unknown level is a usage error that names it.
    let bad = isolated_command(&terzaghi())
        .args(["node", "--ros-args", "--params-file"])
        .arg(&params)
        .args(["--log-level", "loud"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert_eq!(bad.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("loud") && stderr.contains("debug"),
        "{stderr}"
    );
}

/// The loop closed over DDS: a node started from the corrected.yaml `terzaghi diagnose` wrote
/// for a log publishes, to a Cyclone DDS peer, the same corrected forces (and the bare force,
/// each correction's part and the expected F/T reading) as `replay --reevaluate` of the node's
/// own recording with the same file.
#[test]
fn a_node_started_from_corrected_yaml_publishes_what_replay_reevaluates() {
    let _guard = shared();
    let dir = tempfile::tempdir().unwrap();
    let case = dir.path().join("case");
    // Case 3 of the generated rotation (diagnose-eval's run 1) hides surcharge.
    terzaghi_eval::withheld::export_case(3, 1, &case).expect("export a generated case");
    let info: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(case.join("case.json")).unwrap()).unwrap();
    let flags: Vec<String> = info["flags"]
        .as_array()
        .expect("case.json has the geometry flags")
        .iter()
        .map(|f| f.as_str().unwrap().to_string())
        .collect();
    let log = case.join("session.csv");
    let out = dir.path().join("diagnosis");
    let o = std::process::Command::new(terzaghi())
        .arg("diagnose")
        .arg(&log)
        .arg("--out")
        .arg(&out)
        .args(&flags)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let params = out.join("corrected.yaml");
    let yaml = std::fs::read_to_string(&params).unwrap();
    assert!(yaml.contains("surcharge"), "{yaml}");
    let record = dir.path().join("node.mcap");
    let peer = isolated_command(&python())
        .arg(repo().join("tests/python/corrected_peer.py"))
        .arg("--terzaghi")
        .arg(terzaghi())
        .arg("--params")
        .arg(&params)
        .arg("--log")
        .arg(&log)
        .args(["--leg", "session", "--samples", "2000", "--domain", "31"])
        .arg("--record")
        .arg(&record)
        .current_dir(repo().join("tests/python"))
        .output()
        .expect("run the Python peer");
    let stdout = String::from_utf8_lossy(&peer.stdout);
    assert!(
        peer.status.success(),
        "peer failed: {stdout}\n{}",
        String::from_utf8_lossy(&peer.stderr)
    );
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).expect("peer summary");
    assert_eq!(v["node_exit_code"], 0, "{}", v["node_stderr_tail"]);
    let got = v["leg_force"].as_object().unwrap();
    // The node subscribes best effort, as ROS nodes do to match any publisher: a sample can be
    // lost on the way; what arrives is compared.
    assert!(
        got.len() >= 1960,
        "{} of 2000 joint states answered",
        got.len()
    );
    // The node's own recording, re-evaluated with the same file.
    let rows = dir.path().join("rows.csv");
    let o = std::process::Command::new(terzaghi())
        .arg("replay")
        .arg(&record)
        .args(["--reevaluate", "--params-file"])
        .arg(&params)
        .arg("-o")
        .arg(&rows)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut rdr = csv::Reader::from_path(&rows).unwrap();
    let h = rdr.headers().unwrap().clone();
    let col = |name: &str| h.iter().position(|c| c == name).unwrap();
    let mut offline = std::collections::HashMap::new();
    for rec in rdr.records() {
        let rec = rec.unwrap();
        let f = |name: &str| rec[col(name)].parse::<f64>().unwrap();
        offline.insert(
            (f("t_s") * 1e9).round() as i64,
            [
                f("predicted_drag_n"),
                f("predicted_lift_n"),
                f("bare_drag_n"),
                f("bare_lift_n"),
                f("expected_reading_drag_n"),
                f("expected_reading_lift_n"),
            ],
        );
    }
    let mut compared = 0;
    let mut corrected_differs = false;
    for (stamp, m) in got {
        let t: i64 = stamp.parse().unwrap();
        let want = offline
            .get(&t)
            .unwrap_or_else(|| panic!("no re-evaluated row at {t} ns"));
        let have = [
            "drag_n",
            "lift_n",
            "bare_drag_n",
            "bare_lift_n",
            "sensor_drag_n",
            "sensor_lift_n",
        ]
        .map(|k| m[k].as_f64().unwrap());
        for (w, h) in want.iter().zip(have) {
            assert!(
                (w - h).abs() <= 1e-9 * w.abs().max(1.0),
                "at {t}: {want:?} against {have:?}"
            );
        }
        let wrench = &v["predicted_wrench"][stamp.as_str()];
        assert_eq!(wrench[0].as_f64(), Some(-have[0]), "at {t}");
        assert_eq!(wrench[1].as_f64(), Some(have[1]), "at {t}");
        if m["correction_names"].to_string().contains("surcharge")
            && (have[0] - have[2]).abs() > 1e-6
        {
            corrected_differs = true;
        }
        compared += 1;
    }
    assert_eq!(compared, got.len());
    assert!(corrected_differs, "the corrections change some predictions");
}

/// The robot's state from rclpy (Fast DDS), as a ROS 2 robot publishes it: `/tf_static` before
/// the node starts and `/tf` with every joint angle, under tf2_ros's QoS (plain publishers of
/// tf2_msgs/TFMessage: the PyPI wheels carry no tf2_ros). The node's `leg_force` reports the hip
/// height and pitch the peer placed, and with a level body its forces equal `terzaghi predict
/// --hip-height-m` at that height (three heights, 21 angles each).
#[test]
fn rclpy_tf_drives_the_hip_height_as_terzaghi_predict_at_that_height() {
    let _guard = shared();
    let out = ros_python_command(
        "rclpy_tf_peer.py",
        &["--terzaghi", terzaghi().to_str().unwrap(), "--domain", "23"],
    )
    .output()
    .expect("run the rclpy tf peer");
    let stdout = String::from_utf8_lossy(&out.stdout);
    eprintln!("{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).expect("peer summary");
    for name in ["tf_hip_height", "tf_matches_predict", "tf_pitch"] {
        assert_eq!(
            v["checks"][name]["ok"], true,
            "{name}: {}",
            v["checks"][name]
        );
    }
    assert_eq!(v["node_exit_code"], 0);
    assert!(out.status.success());
}

/// The robot's state over DDS: a Cyclone DDS peer publishes the hip's place in the body on
/// `/tf_static` (transient local, before the node starts) and the body's heaving, pitching pose
/// on `/tf` with every joint angle; the node's `leg_force` reports the hip the peer placed
/// (height and pitch), and `replay --reevaluate` of the node's own recording (which holds both
/// transform topics) predicts the same forces.
#[test]
fn the_node_places_a_hip_from_tf_and_tf_static_of_a_cyclone_peer() {
    let _guard = shared();
    let dir = tempfile::tempdir().unwrap();
    let params = dir.path().join("params.yaml");
    std::fs::write(
        &params,
        "/**:\n  ros__parameters:\n    legs: [fl]\n    use_identified: false\n    fl:\n      joint: fl\n      length_m: 0.25\n      width_m: 0.06\n      hip_height_m: 0.15\n      medium: hit_sand\n      hip_frame: fl_hip\n",
    )
    .unwrap();
    let record = dir.path().join("node.mcap");
    let peer = isolated_command(&python())
        .arg(repo().join("tests/python/tf_peer.py"))
        .arg("--terzaghi")
        .arg(terzaghi())
        .arg("--params")
        .arg(&params)
        .args(["--leg", "fl", "--samples", "1000", "--domain", "32"])
        .arg("--record")
        .arg(&record)
        .current_dir(repo().join("tests/python"))
        .output()
        .expect("run the Python peer");
    let stdout = String::from_utf8_lossy(&peer.stdout);
    assert!(
        peer.status.success(),
        "peer failed: {stdout}\n{}",
        String::from_utf8_lossy(&peer.stderr)
    );
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).expect("peer summary");
    assert_eq!(v["node_exit_code"], 0, "{}", v["node_stderr_tail"]);
    let got = v["leg_force"].as_object().unwrap();
    let sent = v["sent"].as_array().unwrap();
    assert!(
        got.len() >= 980,
        "{} of 1000 joint states answered",
        got.len()
    );
    // Each answer places the hip where the peer put it: at its own stamp when its /tf came
    // first (the peer sends it half a millisecond before the angle); else, the /tf of its stamp
    // not yet there, its height goes on from the last two poses the peer sent (within
    // robot_state.max_age_s, 50 ms) and its pitch is held from the last.
    let poses: Vec<(i64, f64, f64)> = sent
        .iter()
        .map(|s| {
            (
                s["stamp"].as_str().unwrap().parse().unwrap(),
                s["hip_height_m"].as_f64().unwrap(),
                s["pitch_rad"].as_f64().unwrap(),
            )
        })
        .collect();
    let (mut exact, mut compared) = (0, 0);
    for &(t, h, p) in &poses {
        let Some(f) = got.get(&t.to_string()) else {
            continue;
        };
        compared += 1;
        assert_eq!(f["robot_state"], true, "{f}");
        let (fh, fp) = (
            f["hip_height_m"].as_f64().unwrap(),
            f["body_pitch_rad"].as_f64().unwrap(),
        );
        let pitch_held = poses
            .iter()
            .any(|&(ts, _, ps)| ts <= t && t - ts <= 50_000_000 && (fp - ps).abs() < 1e-9);
        assert!(
            pitch_held && (fh - h).abs() < 1e-3,
            "{f}: not the peer's hip at {t} ({h}, {p}), nor carried on from a pose it sent within 50 ms"
        );
        if (fh - h).abs() < 1e-9 && (fp - p).abs() < 1e-9 {
            exact += 1;
        }
    }
    assert!(
        exact * 2 >= compared,
        "{exact} of {compared} at their own stamp"
    );
    // The node's own recording, re-evaluated as it ran.
    let rows = dir.path().join("rows.csv");
    let o = std::process::Command::new(terzaghi())
        .arg("replay")
        .arg(&record)
        .args(["--reevaluate", "-o"])
        .arg(&rows)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut rdr = csv::Reader::from_path(&rows).unwrap();
    let h = rdr.headers().unwrap().clone();
    let col = |name: &str| h.iter().position(|c| c == name).unwrap();
    let mut same = 0;
    let mut rows_n = 0;
    for rec in rdr.records() {
        let rec = rec.unwrap();
        let t_ns = (rec[col("t_s")].parse::<f64>().unwrap() * 1e9).round() as i64;
        let Some(f) = got.get(&t_ns.to_string()) else {
            continue;
        };
        rows_n += 1;
        let d: f64 = rec[col("predicted_drag_n")].parse().unwrap();
        if (d - f["drag_n"].as_f64().unwrap()).abs() < 1e-6 {
            same += 1;
        }
    }
    assert!(rows_n >= 900, "{rows_n} rows matched the node's answers");
    assert!(same * 100 >= rows_n * 95, "{same} of {rows_n} the same");
}

/// A hostile peer on every topic the node reads (Python cyclonedds writing raw bytes under each
/// topic's type name: garbage, truncated samples, JointStates of a million names), as fast as
/// it writes, while well-formed JointStates go in: the node skips and counts what does not
/// decode, its peak memory stays bounded, and every well-formed message is predicted exactly as
/// `terzaghi predict` predicts it.
#[test]
fn a_hostile_peer_is_counted_and_skipped_and_changes_no_prediction() {
    let _guard = shared();
    let dir = tempfile::tempdir().unwrap();
    let params = dir.path().join("leg.yaml");
    // The leg reads its hip from /tf (none valid ever comes: it stays at its configured height),
    // so that the node subscribes to /tf and /tf_static too.
    std::fs::write(&params, format!("{LEG_PARAMS}      hip_frame: leg_hip\n")).unwrap();
    let mut flags = SAND_GEOM.to_vec();
    flags.extend(["--bk", "2.0", "--a", "1.5"]);
    let out = isolated_command(&python())
        .arg(repo().join("tests/python/hostile_peer.py"))
        .arg("--terzaghi")
        .arg(terzaghi())
        .arg("--params-file")
        .arg(&params)
        .arg("--predict-flags")
        .arg(serde_json::to_string(&flags).unwrap())
        .args(["--domain", "23"])
        .current_dir(repo().join("tests/python"))
        .output()
        .expect("run the hostile peer");
    let stdout = String::from_utf8_lossy(&out.stdout);
    eprintln!("{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "peer failed: {stdout}");
    let v: serde_json::Value = serde_json::from_str(&stdout).expect("peer summary");
    println!(
        "hostile peer: sent {}; node: {}; peak memory {} kB before, {} kB after",
        v["sent"], v["node_stopped_line"], v["vm_hwm_kb"]["before"], v["vm_hwm_kb"]["after"]
    );
    // Every prediction that came back is exactly `terzaghi predict`'s (the peer checks to 1e-9).
    assert!(v["predictions"]["worst_rel_error"].as_f64().unwrap() <= 1e-9);
    let line = v["node_stopped_line"].as_str().unwrap();
    let count = |what: &str| -> u64 {
        line.split(what)
            .next()
            .and_then(|s| s.rsplit(' ').next())
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("no count of {what:?} in {line:?}"))
    };
    let (skipped, dropped) = (
        count(" samples that did not decode skipped"),
        count(" inputs dropped"),
    );
    // Every row was answered (the peer sends a row again until it is); each attempt that got
    // no answer is an input the node counted as dropped.
    assert_eq!(
        v["predictions"]["answered"], v["predictions"]["rows"],
        "{}",
        v["predictions"]
    );
    let lost = v["predictions"]["unanswered_attempts"].as_u64().unwrap();
    assert!(
        lost <= dropped,
        "{lost} attempts lost, {dropped} counted as dropped"
    );
    let sent: u64 = v["sent"]
        .as_object()
        .unwrap()
        .iter()
        .filter(|(k, _)| !k.starts_with("oversized"))
        .map(|(_, n)| n.as_u64().unwrap())
        .sum();
    assert!(
        skipped >= sent / 2,
        "{skipped} counted of {sent} sent (best effort may lose some, not most)"
    );
    let (before, after) = (
        v["vm_hwm_kb"]["before"].as_u64().unwrap(),
        v["vm_hwm_kb"]["after"].as_u64().unwrap(),
    );
    assert!(
        after < 512_000,
        "peak memory {after} kB (before the traffic: {before} kB)"
    );
}
