//! `terzaghi` as a ROS 2 package in a colcon workspace, the way a ROS 2 user builds it: colcon
//! from PyPI (`tests/python/requirements-colcon.txt`: colcon-ros-cargo and its
//! cargo-ament-build), a workspace holding this repository under `src/`, `colcon build`; then
//! the package resolved with `ament_index_python` as `ros2 run` and `ros2 launch` resolve it (the
//! executable in `lib/terzaghi/`, every launch file and the parameter files they name in
//! `share/terzaghi/`, the ament index entry), and the installed node started from there, in a
//! private network namespace, against a Cyclone DDS peer that checks its predictions.
//!
//! The workspace's build directory for `terzaghi` is this test's own target directory (a link),
//! so that cargo, called by colcon, finds what `cargo test` already built instead of building
//! it a second time; everything else is colcon's.

#[path = "common/mod.rs"]
mod common;

use common::{isolated_command, ok, python, repo, terzaghi};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The venv `target/colconvenv` with colcon and ament_index_python (made on first use: needs
/// PyPI); its `bin/`.
fn colcon_bin() -> PathBuf {
    let py = common::venv_python(
        "target/colconvenv",
        "tests/python/requirements-colcon.txt",
        "ament_index_python, colcon_ros_cargo",
    );
    py.parent().unwrap().to_path_buf()
}

/// `colcon` with `args` in the workspace `ws`, the venv's tools first on PATH.
fn colcon(bin: &Path, ws: &Path, args: &[&str]) -> String {
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let out = Command::new(bin.join("colcon"))
        .args(args)
        .current_dir(ws)
        .env("PATH", path)
        .env_remove("AMENT_PREFIX_PATH")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "colcon {args:?} failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The package names `colcon list` prints.
fn names(listed: &str) -> Vec<String> {
    listed
        .lines()
        .filter_map(|l| l.split('\t').next())
        .filter(|n| !n.is_empty())
        .map(String::from)
        .collect()
}

/// What `ament_index_python` says of the package, as `ros2 run` and `ros2 launch` ask it.
const RESOLVE: &str = r#"
import json, os, sys
from ament_index_python.packages import get_package_prefix, get_package_share_directory
from ament_index_python.resources import get_resources
prefix = get_package_prefix("terzaghi")
share = get_package_share_directory("terzaghi")
files = sorted(os.path.relpath(os.path.join(d, f), share)
               for d, _, fs in os.walk(share) for f in fs)
print(json.dumps({"prefix": prefix, "share": share, "files": files,
                  "packages": sorted(get_resources("packages"))}))
"#;

#[test]
fn colcon_builds_the_package_that_ros2_run_and_ros2_launch_find_and_its_node_answers() {
    let bin = colcon_bin();
    let ws = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(ws.path().join("src")).unwrap();
    std::os::unix::fs::symlink(repo(), ws.path().join("src/terzaghi")).unwrap();
    // cargo's target directory: where this test's terzaghi was built (target/<profile>/..).
    let target = terzaghi()
        .parent()
        .and_then(Path::parent)
        .unwrap()
        .to_path_buf();
    std::fs::create_dir_all(ws.path().join("build")).unwrap();
    // As colcon marks its own build directory, not to be crawled for packages.
    std::fs::write(ws.path().join("build/COLCON_IGNORE"), "").unwrap();
    std::os::unix::fs::symlink(&target, ws.path().join("build/terzaghi")).unwrap();

    // colcon does not look inside a package for more: a plain crawl finds terzaghi alone, and
    // the README's one extra argument finds its messages too.
    assert_eq!(names(&colcon(&bin, ws.path(), &["list"])), ["terzaghi"]);
    let both = colcon(
        &bin,
        ws.path(),
        &["list", "--base-paths", "src", "src/terzaghi/msgs"],
    );
    assert_eq!(names(&both), ["terzaghi", "terzaghi_msgs"], "{both}");
    assert!(both.contains("(ament_cargo)"), "{both}");

    colcon(
        &bin,
        ws.path(),
        &[
            "build",
            "--packages-select",
            "terzaghi",
            "--cargo-args",
            "--release",
        ],
    );
    let install = ws.path().join("install/terzaghi");
    let out = Command::new(bin.join("python"))
        .args(["-c", RESOLVE])
        .env("AMENT_PREFIX_PATH", &install)
        .output()
        .unwrap();
    let found: serde_json::Value = serde_json::from_str(&ok(&out)).unwrap();
    assert!(
        found["packages"]
            .as_array()
            .unwrap()
            .contains(&"terzaghi".into()),
        "{found}"
    );
    let (prefix, share) = (
        PathBuf::from(found["prefix"].as_str().unwrap()),
        PathBuf::from(found["share"].as_str().unwrap()),
    );
    // ros2 run terzaghi terzaghi: <prefix>/lib/terzaghi/terzaghi, executable.
    let exe = prefix.join("lib/terzaghi/terzaghi");
    let mode =
        std::os::unix::fs::PermissionsExt::mode(&std::fs::metadata(&exe).unwrap().permissions());
    assert!(mode & 0o111 != 0, "{} is not executable", exe.display());
    let files: Vec<&str> = found["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f.as_str().unwrap())
        .collect();
    assert!(files.contains(&"package.xml"), "{files:?}");
    // Every launch file, and every file one names by $(find-pkg-share terzaghi), is in share.
    let mut launch_files = 0;
    for entry in std::fs::read_dir(repo().join("launch_configs")).unwrap() {
        let name = entry.unwrap().file_name().into_string().unwrap();
        let shared = format!("launch_configs/{name}");
        assert!(
            files.contains(&shared.as_str()),
            "{shared} not installed: {files:?}"
        );
        if !name.contains(".launch.") {
            continue;
        }
        launch_files += 1;
        let text = std::fs::read_to_string(share.join(&shared)).unwrap();
        assert!(
            text.contains("terzaghi") && text.contains("exec") && !text.contains("cargo install"),
            "{shared} does not start the package's executable:\n{text}"
        );
        for named in text.split("$(find-pkg-share terzaghi)/").skip(1) {
            let file = named.split(['"', '\'', ' ']).next().unwrap();
            assert!(
                share.join(file).is_file(),
                "{shared} names {file}, not in share"
            );
        }
    }
    assert!(launch_files >= 4, "{launch_files} launch files");

    // The installed node, started as ros2 run starts it, with the installed parameter file,
    // answers a Cyclone DDS peer as `terzaghi predict` does.
    let params = share.join("launch_configs/testbed.yaml");
    let node_args = ["--ros-args", "--params-file", params.to_str().unwrap()];
    let out = isolated_command(&python())
        .arg(repo().join("tests/python/interop_peer.py"))
        .arg("--terzaghi")
        .arg(&exe)
        .arg("--node-args")
        .arg(serde_json::to_string(&node_args).unwrap())
        .arg("--predict-flags")
        .arg(
            serde_json::to_string(&[
                "--length-m",
                "0.25",
                "--width-m",
                "0.06",
                "--hip-height-m",
                "0.15",
                "--medium",
                "hit_sand",
            ])
            .unwrap(),
        )
        .args(["--domain", "23"])
        .current_dir(repo().join("tests/python"))
        .output()
        .unwrap();
    let summary = ok(&out);
    let v: serde_json::Value = serde_json::from_str(&summary).expect("the peer's summary");
    assert_eq!(v["checks"]["predictions"]["received"], 21, "{v}");
    assert_eq!(v["checks"]["predictions"]["worst_rel_error"], 0.0, "{v}");
    assert_eq!(v["node_exit_code"], 0, "{v}");
}
