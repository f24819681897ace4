//! Helpers for tests that open DDS participants or use the Python peers.
//!
//! Network rule: a DDS participant must never send discovery traffic off the machine, so every
//! DDS test runs inside a private network namespace with only loopback (`netns-run`). A test
//! that finds itself outside one runs its commands (or itself) through `netns-run`.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

/// The repository's root (the workspace), from any of its packages' tests.
pub fn repo() -> PathBuf {
    let here = Path::new(env!("CARGO_MANIFEST_DIR"));
    here.ancestors()
        .find(|d| d.join("Cargo.lock").exists() && d.join("msgs").is_dir())
        .unwrap_or(here)
        .to_path_buf()
}

/// `terzaghi`, the product's binary: cargo's own path in the product's tests; beside the test's
/// package binary in the other packages' tests, where `cargo test --workspace` (the README's
/// command) builds it in the same run.
pub fn terzaghi() -> PathBuf {
    match option_env!("CARGO_BIN_EXE_terzaghi") {
        Some(p) => PathBuf::from(p),
        None => workspace_exe("terzaghi"),
    }
}

/// The benchmarks' binary, for the tests of the `terzaghi-bench` package (cargo builds it for
/// them).
pub fn bench_exe() -> PathBuf {
    match option_env!("CARGO_BIN_EXE_terzaghi-bench") {
        Some(p) => PathBuf::from(p),
        None => panic!("a test that runs terzaghi-bench belongs to benches/terzaghi-bench/tests"),
    }
}

/// The evaluation's binary (`diagnose-eval`, `dem-report`), for the tests of the
/// `terzaghi-eval` package (cargo builds it for them).
pub fn eval_exe() -> PathBuf {
    match option_env!("CARGO_BIN_EXE_terzaghi-eval") {
        Some(p) => PathBuf::from(p),
        None => panic!("a test that runs terzaghi-eval belongs to crates/terzaghi-eval/tests"),
    }
}

/// The binary `name` of another package of the workspace, in the target directory of this
/// test's own executable (`target/<profile>/deps/<test>` -> `target/<profile>/<name>`).
fn workspace_exe(name: &str) -> PathBuf {
    let me = std::env::current_exe().expect("the test's executable");
    let dir = me
        .parent()
        .and_then(Path::parent)
        .expect("target/<profile>");
    let exe = dir.join(format!("{name}{}", std::env::consts::EXE_SUFFIX));
    assert!(
        exe.exists(),
        "{} is missing: run the tests of the whole workspace (cargo test --release --workspace), which builds it, or cargo build --release --bin {name}",
        exe.display()
    );
    exe
}

/// The project's `netns-run` (`tests/netns-run`), or `$NETNS_RUN` where it is set.
pub fn netns_run() -> PathBuf {
    std::env::var_os("NETNS_RUN")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo().join("tests/netns-run"))
}

/// True inside a namespace where only loopback exists.
pub fn isolated() -> bool {
    if std::env::var("NETNS_RUN_INSIDE").as_deref() == Ok("1") {
        return true;
    }
    match std::fs::read_dir("/sys/class/net") {
        Ok(entries) => entries.flatten().all(|e| e.file_name() == "lo"),
        Err(_) => false,
    }
}

/// `cmd` as is when isolated, else wrapped in `netns-run`. Panics (a test failure with a clear
/// message) when isolation is not available, rather than touching the network.
pub fn isolated_command(program: &Path) -> Command {
    if isolated() {
        return Command::new(program);
    }
    let wrapper = netns_run();
    assert!(
        wrapper.exists(),
        "DDS tests must run in a private network namespace: {} not found",
        wrapper.display()
    );
    isolation_works(&wrapper);
    let mut c = Command::new(wrapper);
    c.arg(program);
    c
}

/// Panics with the wrapper's own reason where no private network namespace can be made here
/// (neither root nor unprivileged user namespaces): a DDS test then fails, never touching the
/// network. Asked once per test binary.
fn isolation_works(wrapper: &Path) {
    static VERDICT: std::sync::OnceLock<Result<(), String>> = std::sync::OnceLock::new();
    let verdict = VERDICT.get_or_init(|| {
        let out = Command::new(wrapper)
            .arg("true")
            .output()
            .map_err(|e| format!("cannot run {}: {e}", wrapper.display()))?;
        if out.status.success() {
            Ok(())
        } else {
            Err(String::from_utf8_lossy(&out.stderr).trim().to_string())
        }
    });
    if let Err(why) = verdict {
        panic!("DDS tests must run in a private network namespace, and none can be made: {why}");
    }
}

/// The Python interpreter with the independent peers installed (`$TERZAGHI_PYTHON`, else the
/// venv `target/venv`, made here on first use from `tests/python/requirements.txt`, which needs
/// PyPI).
pub fn python() -> PathBuf {
    if let Some(p) = std::env::var_os("TERZAGHI_PYTHON") {
        return PathBuf::from(p);
    }
    venv_python(
        "target/venv",
        "tests/python/requirements.txt",
        "cyclonedds, mcap_ros2, rosbags, websockets",
    )
}

/// The Python of the venv `venv` (a path under the repository), made on first use with
/// `requirements` installed (which needs PyPI), until it imports `imports`; one install at a
/// time among the processes that ask (a lock on `<venv>.lock`).
#[allow(dead_code)]
pub fn venv_python(venv: &str, requirements: &str, imports: &str) -> PathBuf {
    let venv = repo().join(venv);
    let py = venv.join("bin/python");
    let ready = || {
        Command::new(&py)
            .args(["-c", &format!("import {imports}")])
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if ready() {
        return py;
    }
    std::fs::create_dir_all(venv.parent().unwrap()).unwrap();
    let lock_path = venv.with_extension("lock");
    let lock = std::fs::File::create(&lock_path)
        .unwrap_or_else(|e| panic!("cannot open {}: {e}", lock_path.display()));
    lock.lock()
        .unwrap_or_else(|e| panic!("cannot lock {}: {e}", lock_path.display()));
    if !ready() {
        let ok = Command::new("python3")
            .args(["-m", "venv"])
            .arg(&venv)
            .status()
            .is_ok_and(|s| s.success())
            && Command::new(venv.join("bin/pip"))
                .args(["install", "-q", "-r"])
                .arg(repo().join(requirements))
                .status()
                .is_ok_and(|s| s.success());
        assert!(
            ok && ready(),
            "cannot set up the venv {} (pip install -r {requirements} needs PyPI)",
            venv.display()
        );
    }
    py
}

/// `node` and the JavaScript MCAP reader `tests/js/decode_all.mjs` with its packages installed
/// (`$TERZAGHI_JS_READER`, else this checkout's, whose packages are installed here on first use
/// with `npm ci --prefix tests/js`, which needs the npm registry).
/// Returns the script's path.
pub fn js_reader() -> PathBuf {
    if let Some(p) = std::env::var_os("TERZAGHI_JS_READER") {
        return PathBuf::from(p);
    }
    let dir = repo().join("tests/js");
    let ready = || dir.join("node_modules/@mcap/core/package.json").exists();
    if !ready() {
        static INSTALL: std::sync::Mutex<()> = std::sync::Mutex::new(());
        let _one = INSTALL.lock().unwrap_or_else(|p| p.into_inner());
        if !ready() {
            let ok = Command::new("npm")
                .args(["ci", "--no-audit", "--no-fund", "--prefix"])
                .arg(&dir)
                .status()
                .is_ok_and(|s| s.success());
            assert!(
                ok && ready(),
                "cannot install the JavaScript reader's packages in {} (run `npm ci --prefix tests/js` once, with network)",
                dir.display()
            );
        }
    }
    dir.join("decode_all.mjs")
}

/// What a command printed on stdout, once it succeeded; else a failure that shows its exit code,
/// stdout and stderr.
pub fn ok(out: &std::process::Output) -> String {
    assert!(
        out.status.success(),
        "exit {:?}\nstdout: {}\nstderr: {}",
        out.status.code(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The paper's testbed plate (0.25 x 0.06 m, hip 0.15 m) in its sand, as CLI flags.
pub const SAND_GEOM: [&str; 12] = [
    "--length-m",
    "0.25",
    "--width-m",
    "0.06",
    "--hip-height-m",
    "0.15",
    "--unit-weight-n-m3",
    "16170",
    "--phi-deg",
    "32",
    "--delta-deg",
    "19",
];

/// Node parameters for one leg on that plate, `b_k = 2, a = 1.5`, F/T on `leg/ft`.
pub const LEG_PARAMS: &str = "/**:\n  ros__parameters:\n    legs: [leg]\n    leg:\n      joint: hip\n      length_m: 0.25\n      width_m: 0.06\n      hip_height_m: 0.15\n      unit_weight_n_m3: 16170\n      phi_deg: 32.0\n      delta_deg: 19.0\n      b_k: 2.0\n      a: 1.5\n      ft_topic: leg/ft\n";

/// An MCAP session of `n` samples `spacing_ns` apart: JointState on /joint_states (joint `hip`)
/// and WrenchStamped on /leg/ft, chunks closed every `flush_period_ns` of log time.
pub fn leg_session(n: u64, spacing_ns: u64, flush_period_ns: u64) -> Vec<u8> {
    leg_session_with(n, spacing_ns, flush_period_ns, false)
}

/// [`leg_session`], and with `outputs` the F/T sample again on `/leg/predicted_wrench`, written
/// as the node's output (in chunks apart from the inputs).
pub fn leg_session_with(n: u64, spacing_ns: u64, flush_period_ns: u64, outputs: bool) -> Vec<u8> {
    use terzaghi::msgs::*;
    use terzaghi::record::{OfferedQos, RecordOptions, SessionWriter};
    let opts = RecordOptions {
        flush_period_ns,
        ..Default::default()
    };
    let mut w = SessionWriter::new(std::io::Cursor::new(Vec::new()), opts).unwrap();
    for i in 0..n {
        let t = 1_000_000_000 + i * spacing_ns;
        let header = Header {
            stamp: Time::from_nanos(t as i64).unwrap(),
            frame_id: String::new(),
        };
        let js = JointState {
            header: header.clone(),
            name: vec!["hip".into()],
            position: vec![i as f64 * 0.01],
            ..Default::default()
        };
        w.write("/joint_states", OfferedQos::BEST_EFFORT, &js, t, t)
            .unwrap();
        let force = Vector3 {
            x: -(i as f64),
            y: 0.0,
            z: 2.0,
        };
        let ft = WrenchStamped {
            header,
            wrench: Wrench {
                force,
                ..Default::default()
            },
        };
        w.write("/leg/ft", OfferedQos::BEST_EFFORT, &ft, t, t)
            .unwrap();
        if outputs {
            w.write_output(
                "/leg/predicted_wrench",
                OfferedQos::RELIABLE,
                &ft,
                t + 1000,
                t,
            )
            .unwrap();
        }
    }
    w.finish().unwrap().into_inner()
}

/// The environment script that makes [`python`] a ROS 2 peer: rclpy over Fast DDS, the
/// `terzaghi_msgs` classes built by colcon from `msgs/` and `tf2_msgs`'s TFMessage from
/// `tests/python/tf2_msgs` (`$TERZAGHI_ROS_MSGS/env.sh`, else
/// `target/ros_msgs/env.sh`, made here on first use with `tests/python/build_msgs.sh`, which
/// needs PyPI).
pub fn ros_env() -> PathBuf {
    let dir = std::env::var_os("TERZAGHI_ROS_MSGS")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo().join("target/ros_msgs"));
    let env = dir.join("env.sh");
    // A build from before tf2_msgs joined it lacks its install.
    let built = || env.exists() && dir.join("install/tf2_msgs").exists();
    if !built() {
        let py = python();
        let venv = py.parent().and_then(Path::parent).unwrap().to_path_buf();
        // One build at a time among this binary's tests.
        static BUILD: std::sync::Mutex<()> = std::sync::Mutex::new(());
        let _one = BUILD.lock().unwrap_or_else(|p| p.into_inner());
        if !built() {
            let ok = Command::new(venv.join("bin/pip"))
                .args(["install", "-q", "--prefer-binary", "-r"])
                .arg(repo().join("tests/python/requirements-ros.txt"))
                .status()
                .is_ok_and(|s| s.success())
                && Command::new(repo().join("tests/python/build_msgs.sh"))
                    .arg(&venv)
                    .arg(&dir)
                    .status()
                    .is_ok_and(|s| s.success());
            assert!(
                ok && built(),
                "cannot build terzaghi_msgs and tf2_msgs for the rclpy peer into {} (the ROS 2 wheels come from PyPI)",
                dir.display()
            );
        }
    }
    env
}

/// `python SCRIPT ARGS...` in the ROS 2 peer's environment ([`ros_env`]), inside the private
/// network namespace, from `tests/python`.
pub fn ros_python_command(script: &str, args: &[&str]) -> Command {
    let env = ros_env();
    let mut c = isolated_command(Path::new("bash"));
    c.arg("-c")
        .arg("source \"$0\" && exec \"$@\"")
        .arg(&env)
        .arg(python())
        .arg(repo().join("tests/python").join(script))
        .args(args)
        .current_dir(repo().join("tests/python"));
    c
}

/// The README and every page of `docs/`, one after the other: where the figures that tests keep
/// in step with their commands are written.
pub fn docs_text() -> String {
    let mut pages = vec![repo().join("README.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(repo().join("docs"))
        .expect("docs/")
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    docs.sort();
    pages.extend(docs);
    pages
        .iter()
        .map(|p| std::fs::read_to_string(p).unwrap())
        .collect::<Vec<_>>()
        .join("\n")
}

/// Runs `terzaghi` with `args` and asserts that it refused them as a user error (exit code 2),
/// its message holding each of `words`, without a panic.
pub fn refused(args: &[&std::ffi::OsStr], words: &[&str]) {
    let out = Command::new(terzaghi()).args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    for w in words {
        assert!(err.contains(w), "{w:?} not in: {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
}

/// The Python of the venv `venv` (under the repository, made on first use: needs PyPI) with
/// `requirements` installed and the package built from this checkout (reinstalled on every
/// call: the crate may have changed since). The venv is made and its requirements installed
/// under a lock on the file `<venv>.lock` (flock): tests that share a venv take turns, two
/// venvs install side by side, and another process may make the venv ahead of the tests while
/// it holds the lock (CI does, for the peers' 6 GB, while the tests build). The package is
/// built for one venv at a time.
#[allow(dead_code)]
pub fn python_venv(venv: &str, requirements: &str) -> std::path::PathBuf {
    use std::sync::Mutex;
    let venv = repo().join(venv);
    let py = venv.join("bin/python");
    let pip = venv.join("bin/pip");
    let lock_path = venv.with_extension("lock");
    std::fs::create_dir_all(venv.parent().unwrap()).unwrap();
    let lock = std::fs::File::create(&lock_path)
        .unwrap_or_else(|e| panic!("cannot open {}: {e}", lock_path.display()));
    lock.lock()
        .unwrap_or_else(|e| panic!("cannot lock {}: {e}", lock_path.display()));
    if !py.exists() {
        let ok = Command::new("python3")
            .args(["-m", "venv"])
            .arg(&venv)
            .status()
            .is_ok_and(|s| s.success());
        assert!(ok, "cannot make the venv {}", venv.display());
    }
    let ok = Command::new(&pip)
        .args(["install", "-q", "-r"])
        .arg(repo().join(requirements))
        .status()
        .is_ok_and(|s| s.success());
    assert!(ok, "pip install -r {requirements} failed (it needs PyPI)");
    drop(lock);
    static BUILD: Mutex<()> = Mutex::new(());
    let _build = BUILD.lock().unwrap_or_else(|p| p.into_inner());
    let out = Command::new(&pip)
        .args(["install", "-q", "--force-reinstall", "--no-deps"])
        .arg(repo().join("python"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "pip install ./python failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    py
}
