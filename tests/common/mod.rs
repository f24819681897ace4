//! Helpers for tests that open DDS participants or use the Python peers.
//!
//! Network rule: a DDS participant must never send discovery traffic off the machine, so every
//! DDS test runs inside a private network namespace with only loopback (`netns-run`). A test
//! that finds itself outside one runs its commands (or itself) through `netns-run`.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

pub fn terzaghi() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_terzaghi"))
}

/// `netns-run`: `$NETNS_RUN`, else `../shared/tools/netns-run` beside the repository.
pub fn netns_run() -> PathBuf {
    std::env::var_os("NETNS_RUN")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo().join("../shared/tools/netns-run"))
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
        "DDS tests must run in a private network namespace: {} not found (set NETNS_RUN, or run the tests inside one)",
        wrapper.display()
    );
    let mut c = Command::new(wrapper);
    c.arg(program);
    c
}

/// The Python interpreter with the independent peers installed (`$TERZAGHI_PYTHON`, else the
/// venv `.ci/run` makes in `target/venv`, made here if it is missing).
pub fn python() -> PathBuf {
    if let Some(p) = std::env::var_os("TERZAGHI_PYTHON") {
        return PathBuf::from(p);
    }
    let venv = repo().join("target/venv");
    let py = venv.join("bin/python");
    let ready = || {
        Command::new(&py)
            .args(["-c", "import cyclonedds, mcap_ros2, rosbags"])
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if !ready() {
        let _lock = std::fs::File::create(repo().join("target/venv.lock"));
        if !ready() {
            let ok = Command::new("python3")
                .args(["-m", "venv"])
                .arg(&venv)
                .status()
                .is_ok_and(|s| s.success())
                && Command::new(venv.join("bin/pip"))
                    .args(["install", "-q", "-r"])
                    .arg(repo().join("tests/python/requirements.txt"))
                    .status()
                    .is_ok_and(|s| s.success());
            assert!(
                ok && ready(),
                "cannot set up the Python peers in {} (run .ci/run once, with network)",
                venv.display()
            );
        }
    }
    py
}
