//! Recording sessions to MCAP: read back by independent readers (Python mcap-ros2-support and
//! rosbags), crash safety, and robustness against damaged files.

mod common;

use common::*;
use std::path::Path;
use std::process::Command;

const FLAGS: &str = r#"["--length-m","0.25","--width-m","0.06","--hip-height-m","0.15","--unit-weight-n-m3","16170","--phi-deg","32","--delta-deg","19","--bk","2","--a","1.5"]"#;

/// Runs the Cyclone DDS peer against `terzaghi node --record`, with `extra` peer options.
fn recorded_session(dir: &Path, domain: &str, extra: &[&str]) -> serde_json::Value {
    let params = dir.join("leg.yaml");
    std::fs::write(&params, LEG_PARAMS).unwrap();
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

/// A bag written by rosbags (rosbag2 MCAP storage, an independent writer) is read by
/// `replay --reevaluate`: every F/T sample comes out next to its prediction, the values are the
/// ones written, and a topic of an unknown type is skipped with a note.
#[test]
fn a_rosbags_bag_is_reevaluated() {
    let dir = tempfile::tempdir().unwrap();
    let bag = dir.path().join("bag");
    let out = Command::new(python())
        .arg(repo().join("tests/python/write_rosbag.py"))
        .arg(terzaghi())
        .arg(&bag)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let mcap = v["mcap"].as_str().unwrap();
    let params = dir.path().join("leg.yaml");
    std::fs::write(&params, LEG_PARAMS).unwrap();
    let csv = dir.path().join("out.csv");
    let o = Command::new(terzaghi())
        .args(["replay", mcap, "--reevaluate", "--params-file"])
        .arg(&params)
        .arg("-o")
        .arg(&csv)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(stderr.contains("skipped: /chatter"), "{stderr}");
    let written = v["written"]["ft"].as_object().unwrap();
    let mut rdr = csv::Reader::from_path(&csv).unwrap();
    let rows: Vec<csv::StringRecord> = rdr.records().map(|r| r.unwrap()).collect();
    assert_eq!(rows.len(), written.len());
    let h = rdr.headers().unwrap().clone();
    let col = |name: &str| h.iter().position(|c| c == name).unwrap();
    let (md, ml, pd, pl) = (
        col("measured_drag_n"),
        col("measured_lift_n"),
        col("predicted_drag_n"),
        col("predicted_lift_n"),
    );
    for (row, (_, w)) in rows.iter().zip(written.iter()) {
        let f = |i: usize| row[i].parse::<f64>().unwrap();
        assert!(
            (f(md) - w[0].as_f64().unwrap()).abs() < 1e-5,
            "{row:?} vs {w}"
        );
        assert!((f(ml) - w[1].as_f64().unwrap()).abs() < 1e-5);
        // The forces were generated with the parameters the bag is re-evaluated with.
        assert!(
            (f(pd) - f(md)).abs() < 1e-5 && (f(pl) - f(ml)).abs() < 1e-5,
            "{row:?}"
        );
    }

    // To MCAP: the inputs with the new outputs, every message decoded by mcap-ros2-support, and
    // the parameters stored, so that the result re-evaluates without --params-file to the same
    // rows.
    let again = dir.path().join("again.mcap");
    let o = Command::new(terzaghi())
        .args(["replay", mcap, "--reevaluate", "--params-file"])
        .arg(&params)
        .arg("-o")
        .arg(&again)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = Command::new(python())
        .arg(repo().join("tests/python/decode_all.py"))
        .arg(&again)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let counts: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let counts = counts["counts"].as_object().unwrap();
    assert_eq!(
        counts["/leg/ft"].as_u64(),
        Some(written.len() as u64),
        "{counts:?}"
    );
    assert!(
        counts["/leg/predicted_wrench"].as_u64() > Some(0),
        "{counts:?}"
    );
    let csv_again = dir.path().join("again.csv");
    let o = Command::new(terzaghi())
        .arg("replay")
        .arg(&again)
        .args(["--reevaluate", "-o"])
        .arg(&csv_again)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        std::fs::read_to_string(&csv_again).unwrap(),
        std::fs::read_to_string(&csv).unwrap()
    );
}

/// Cut a valid session at many offsets and flip random bytes: `info`, `recover` and
/// `replay --reevaluate` answer with a result or a clear error (exit 2), never a panic.
#[test]
fn damaged_files_never_panic() {
    use rand::{Rng, SeedableRng};
    let dir = tempfile::tempdir().unwrap();
    let good = leg_session(600, 4_000_000, 50_000_000);
    let params = dir.path().join("leg.yaml");
    std::fs::write(&params, LEG_PARAMS).unwrap();
    let file = dir.path().join("damaged.mcap");
    let fixed = dir.path().join("fixed.mcap");
    let mut rng = rand::rngs::StdRng::seed_from_u64(5);
    let mut cases: Vec<Vec<u8>> = (0..30)
        .map(|i| good[..good.len() * i / 30].to_vec())
        .collect();
    for _ in 0..30 {
        let mut b = good.clone();
        for _ in 0..rng.random_range(1..20) {
            let at = rng.random_range(0..b.len());
            b[at] = rng.random();
        }
        cases.push(b);
    }
    for (i, bytes) in cases.iter().enumerate() {
        std::fs::write(&file, bytes).unwrap();
        let runs: [Vec<&std::ffi::OsStr>; 3] = [
            vec!["info".as_ref(), file.as_os_str()],
            vec![
                "recover".as_ref(),
                file.as_os_str(),
                "-o".as_ref(),
                fixed.as_os_str(),
                "--overwrite".as_ref(),
            ],
            vec![
                "replay".as_ref(),
                file.as_os_str(),
                "--reevaluate".as_ref(),
                "--params-file".as_ref(),
                params.as_os_str(),
                "-o".as_ref(),
                dir.path().join("o.csv").into_os_string().leak(),
            ],
        ];
        for args in runs {
            let o = Command::new(terzaghi()).args(&args).output().unwrap();
            let stderr = String::from_utf8_lossy(&o.stderr);
            assert!(!stderr.contains("panicked"), "case {i} {args:?}: {stderr}");
            assert!(
                matches!(o.status.code(), Some(0) | Some(2)),
                "case {i} {args:?}: {:?} {stderr}",
                o.status
            );
        }
    }
    // In process: every 7th cut, and 3000 random damages, through the library's reader and
    // recovery.
    for cut in (0..good.len()).step_by(7) {
        let _ = terzaghi::record::read::scan(&good[..cut], |_, _| {});
    }
    for _ in 0..3000 {
        let mut b = good.clone();
        for _ in 0..rng.random_range(1..8) {
            let at = rng.random_range(0..b.len());
            b[at] = rng.random();
        }
        let _ = terzaghi::record::read::scan(&b, |_, _| {});
        let _ = terzaghi::record::recover(&b, std::io::Cursor::new(Vec::new()), |_| {});
    }
}

/// `replay` republishes a session over DDS with its timing, and `terzaghi record` (the
/// standalone recorder) records it again: every message arrives, topics and types kept.
#[test]
fn replay_over_dds_is_recorded_again_by_the_standalone_recorder() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src.mcap");
    std::fs::write(&src, leg_session_with(400, 5_000_000, 1_000_000_000, true)).unwrap();
    let again = dir.path().join("again.mcap");
    let t = terzaghi();
    let script = format!(
        "ROS_DOMAIN_ID=23 '{t}' record --topics /joint_states /leg/ft /leg/predicted_wrench --duration-s 8 -o '{again}' & R=$!; sleep 1; \
         ROS_DOMAIN_ID=23 '{t}' replay '{src}' --rate 1; wait $R",
        t = t.display(),
        again = again.display(),
        src = src.display()
    );
    let out = isolated_command(Path::new("/bin/sh"))
        .arg("-c")
        .arg(&script)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("replayed 1200 messages"), "{stderr}");
    let o = Command::new(terzaghi())
        .arg("info")
        .arg(&again)
        .arg("--json")
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["complete"], true);
    let counts: std::collections::BTreeMap<String, u64> = v["topics"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| {
            (
                t["topic"].as_str().unwrap().to_string(),
                t["messages"].as_u64().unwrap(),
            )
        })
        .collect();
    assert_eq!(counts.get("/joint_states"), Some(&400), "{v}");
    assert_eq!(counts.get("/leg/ft"), Some(&400), "{v}");
    assert_eq!(counts.get("/leg/predicted_wrench"), Some(&400), "{v}");
    // The replay kept the recorded timing: 2 s of messages take about 2 s, and every message,
    // the outputs (in chunks of their own) too, arrives when its stamp says.
    let dur = v["duration_s"].as_f64().unwrap();
    assert!((1.8..2.6).contains(&dur), "{dur}");
    let bytes = std::fs::read(&again).unwrap();
    let session = terzaghi::record::read_session(&bytes).unwrap();
    let first = session
        .messages
        .iter()
        .min_by_key(|m| m.log_time_ns)
        .unwrap();
    let worst_lag_s = session
        .messages
        .iter()
        .map(|m| {
            let received = m.log_time_ns as f64 - first.log_time_ns as f64;
            let stamped = m.publish_time_ns as f64 - first.publish_time_ns as f64;
            (received - stamped).abs() * 1e-9
        })
        .fold(0.0, f64::max);
    assert!(
        worst_lag_s < 0.3,
        "a message arrived {worst_lag_s} s off its stamp"
    );
}

/// Every command that writes a recording refuses a file that exists (exit 2, naming it) and
/// leaves it byte for byte as it was, unless --overwrite is given; a CSV output is replaced.
#[test]
fn an_existing_recording_is_never_overwritten() {
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("session.mcap");
    std::fs::write(&session, leg_session(600, 4_000_000, 50_000_000)).unwrap();
    let params = dir.path().join("leg.yaml");
    std::fs::write(&params, LEG_PARAMS).unwrap();
    let existing = dir.path().join("existing.mcap");
    let keep = b"an earlier recording, 18 MB in real life".to_vec();
    let p = |x: &Path| x.to_str().unwrap().to_string();
    let (s, e, prm) = (p(&session), p(&existing), p(&params));
    let cases: Vec<(bool, Vec<String>)> = vec![
        (
            false,
            vec!["recover".into(), s.clone(), "-o".into(), e.clone()],
        ),
        (
            false,
            vec![
                "replay".into(),
                s.clone(),
                "--reevaluate".into(),
                "--params-file".into(),
                prm.clone(),
                "-o".into(),
                e.clone(),
            ],
        ),
        // These two would open a DDS participant if they did not refuse first.
        (
            true,
            vec![
                "record".into(),
                "--topics".into(),
                "/joint_states".into(),
                "-o".into(),
                e.clone(),
            ],
        ),
        (
            true,
            vec![
                "node".into(),
                "--record".into(),
                e.clone(),
                "--ros-args".into(),
                "--params-file".into(),
                prm.clone(),
            ],
        ),
        (
            true,
            vec![
                "node".into(),
                "--ros-args".into(),
                "--params-file".into(),
                prm.clone(),
                "-p".into(),
                format!("record:={e}"),
            ],
        ),
    ];
    for (dds, args) in &cases {
        std::fs::write(&existing, &keep).unwrap();
        let mut c = if *dds {
            isolated_command(&terzaghi())
        } else {
            Command::new(terzaghi())
        };
        let o = c.args(args).output().unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(
            stderr.contains("existing.mcap exists") && stderr.contains("--overwrite"),
            "{args:?}: {stderr}"
        );
        assert_eq!(std::fs::read(&existing).unwrap(), keep, "{args:?}");
    }
    // With --overwrite, the offline commands replace it with a valid session.
    for (_, args) in &cases[..2] {
        std::fs::write(&existing, &keep).unwrap();
        let o = Command::new(terzaghi())
            .args(args)
            .arg("--overwrite")
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(std::fs::read(&existing).unwrap().starts_with(b"\x89MCAP"));
    }
    // A CSV output is replaced, as --help says.
    let csv = dir.path().join("out.csv");
    std::fs::write(&csv, "old").unwrap();
    let o = Command::new(terzaghi())
        .args([
            "replay",
            s.as_str(),
            "--reevaluate",
            "--params-file",
            prm.as_str(),
            "-o",
        ])
        .arg(&csv)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        std::fs::read_to_string(&csv)
            .unwrap()
            .starts_with("t_s,leg")
    );
}

#[test]
fn a_recording_without_a_name_is_named_from_its_start_time() {
    assert_eq!(
        terzaghi::session::files::recording_name(1_795_395_599).to_str(),
        Some("terzaghi_2026_11_23-00_59_59.mcap")
    );
    assert_eq!(
        terzaghi::session::files::recording_name(0).to_str(),
        Some("terzaghi_1970_01_01-00_00_00.mcap")
    );
    assert_eq!(
        terzaghi::session::files::recording_name(951_782_400).to_str(),
        Some("terzaghi_2000_02_29-00_00_00.mcap")
    );
}

/// A third, independent reader: Foxglove's TypeScript MCAP library and ROS 2 deserializer
/// (`tests/js/decode_all.mjs`, run by Node.js) decode every message of a recording and of
/// `replay --reevaluate -o OUT.mcap`, from the schemas in the files, and count the same
/// messages per topic as the Python reader.
#[test]
fn the_javascript_mcap_reader_decodes_every_message() {
    let js = common::js_reader();
    let dir = tempfile::tempdir().unwrap();
    let demo = dir.path().join("demo");
    let o = Command::new(terzaghi())
        .args(["demo", "--seconds", "10", "--speed", "20", "--out"])
        .arg(&demo)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let session = demo.join("session.mcap");
    let again = dir.path().join("again.mcap");
    let o = Command::new(terzaghi())
        .arg("replay")
        .arg(&session)
        .args(["--reevaluate", "-o"])
        .arg(&again)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for file in [&session, &again] {
        let o = Command::new("node").arg(&js).arg(file).output().unwrap();
        assert!(
            o.status.success(),
            "{}: {}",
            file.display(),
            String::from_utf8_lossy(&o.stderr)
        );
        let js_out: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let o = Command::new(python())
            .arg(repo().join("tests/python/decode_all.py"))
            .arg(file)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let py_out: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(js_out["counts"], py_out["counts"], "{}", file.display());
        let counts = js_out["counts"].as_object().unwrap();
        for topic in [
            "/joint_states",
            "/front_left/ft/wrench",
            "/front_left/predicted_wrench",
        ] {
            assert!(counts[topic].as_u64() > Some(10), "{topic}: {counts:?}");
        }
        // Values, not only counts: the first JointState names six hips with six finite angles.
        let js0 = &js_out["first"]["/joint_states"];
        assert_eq!(js0["name"].as_array().unwrap().len(), 6, "{js0}");
        assert!(
            js0["position"]
                .as_array()
                .unwrap()
                .iter()
                .all(|p| p.as_f64().is_some_and(f64::is_finite)),
            "{js0}"
        );
    }
}

/// `replay --clock` publishes the recording's time on `/clock`, as `ros2 bag play --clock`
/// does; a node run with `use_sim_time` follows it: its `/diagnostics`, as it records them,
/// are stamped within the recording's time (1 s to 3 s), not with the wall clock, and so are
/// the receive times of what it records.
#[test]
fn replay_clock_drives_a_node_on_simulated_time() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src.mcap");
    // 400 samples 5 ms apart from t = 1 s.
    std::fs::write(&src, leg_session_with(400, 5_000_000, 1_000_000_000, false)).unwrap();
    let params = dir.path().join("leg.yaml");
    std::fs::write(&params, LEG_PARAMS).unwrap();
    let out_mcap = dir.path().join("node.mcap");
    let t = terzaghi();
    let script = format!(
        "ROS_DOMAIN_ID=27 '{t}' node --record '{out}' --ros-args --params-file '{params}' -p use_sim_time:=true -p diagnostics_period_s:=0.1 & N=$!; sleep 1; \
         ROS_DOMAIN_ID=27 '{t}' replay '{src}' --rate 1 --clock 100; kill -INT $N; wait $N",
        t = t.display(),
        out = out_mcap.display(),
        params = params.display(),
        src = src.display()
    );
    let out = isolated_command(Path::new("/bin/sh"))
        .arg("-c")
        .arg(&script)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let bytes = std::fs::read(&out_mcap).unwrap();
    let session = terzaghi::record::read::read_session(&bytes).unwrap();
    let diag_topic = session
        .topics
        .iter()
        .position(|t| t.topic == "/diagnostics")
        .expect("/diagnostics recorded");
    let js_topic = session
        .topics
        .iter()
        .position(|t| t.topic == "/joint_states")
        .expect("/joint_states recorded");
    let (mut in_recording, mut wall) = (0, 0);
    for m in session.messages.iter().filter(|m| m.topic == diag_topic) {
        let d: terzaghi::msgs::DiagnosticArray = session.decode(m).unwrap();
        let s = d.header.stamp.sec as f64 + d.header.stamp.nanosec as f64 * 1e-9;
        if (1.0..=3.5).contains(&s) {
            in_recording += 1;
        }
        if s > 1e9 {
            wall += 1;
        }
    }
    // 2 s of recording at 10 Hz diagnostics; before the first /clock the time is 0.
    assert!(
        in_recording >= 10,
        "{in_recording} stamped in the recording's time"
    );
    assert_eq!(wall, 0, "diagnostics stamped with the wall clock");
    let js: Vec<u64> = session
        .messages
        .iter()
        .filter(|m| m.topic == js_topic)
        .map(|m| m.log_time_ns)
        .collect();
    assert!(js.len() >= 390, "{} joint states recorded", js.len());
    // A joint state taken before the first /clock arrived is stamped 0, as in any ROS node.
    let in_time = js
        .iter()
        .filter(|&&t| (900_000_000..3_600_000_000).contains(&t))
        .count();
    assert!(
        in_time >= js.len() - 5,
        "{in_time} of {} receive times within the recording's time: {:?}",
        js.len(),
        (js.iter().min(), js.iter().max())
    );
}
