//! A newcomer's first minutes: clone the repository, run the two commands at the top of the
//! README exactly as written there, and check what the demo left behind.
//!
//! The commands are read from the README's first `sh` block, not copied here. The clone builds
//! in its own target directory, seeded with a copy of this build's so that only this crate is
//! compiled again. The clone's own run of the tests skips this test (it would clone again,
//! forever): that is what `TERZAGHI_IN_CLONE_TEST` says.

mod common;

use serde_json::Value;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

/// The command lines of the README's first ```sh block.
fn readme_commands(readme: &str) -> Vec<String> {
    let start = readme.find("```sh\n").expect("the README has an sh block") + 6;
    let block = &readme[start..];
    let end = block.find("```").expect("the sh block ends");
    block[..end]
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(String::from)
        .collect()
}

#[test]
fn the_readme_commands_work_in_a_fresh_clone() {
    if std::env::var_os("TERZAGHI_IN_CLONE_TEST").is_some() {
        eprintln!("inside the clone's own test run: not cloning again");
        return;
    }
    let repo = common::repo();
    let readme = std::fs::read_to_string(repo.join("README.md")).unwrap();
    let commands = readme_commands(&readme);
    assert_eq!(commands.len(), 2, "two commands at the top: {commands:?}");
    assert!(commands[0].contains(" demo"), "{commands:?}");
    assert!(commands[1].starts_with("cargo test"), "{commands:?}");

    let tmp = tempfile::tempdir().unwrap();
    let clone = tmp.path().join("terzaghi");
    let status = Command::new("git")
        .args(["clone", "--quiet"])
        .arg(&repo)
        .arg(&clone)
        .status()
        .expect("git clone");
    assert!(status.success());
    // Seed the clone's target directory with this build's release artifacts.
    let target = tmp.path().join("target");
    std::fs::create_dir_all(&target).unwrap();
    let status = Command::new("cp")
        .args(["-a"])
        .arg(repo.join("target/release"))
        .arg(target.join("release"))
        .status()
        .expect("cp");
    assert!(status.success());
    let python = common::python();
    // The clone has no network for npm (its tests run inside netns-run): it reads with this
    // checkout's JavaScript reader, as with its Python.
    let js_reader = common::js_reader();
    // Nor for PyPI: the clone's rclpy peer uses this checkout's colcon-built terzaghi_msgs.
    let ros_msgs = common::ros_env().parent().unwrap().to_path_buf();
    // The clone's DDS tests find the namespace tool where this checkout finds it.
    let netns_run = common::netns_run()
        .canonicalize()
        .unwrap_or_else(|_| common::netns_run());
    let run = |line: &str| {
        let started = Instant::now();
        let out = Command::new("sh")
            .arg("-c")
            .arg(line)
            .current_dir(&clone)
            .env("CARGO_TARGET_DIR", &target)
            .env("TERZAGHI_IN_CLONE_TEST", "1")
            .env("TERZAGHI_PYTHON", &python)
            .env("TERZAGHI_JS_READER", &js_reader)
            .env("TERZAGHI_ROS_MSGS", &ros_msgs)
            .env("NETNS_RUN", &netns_run)
            .output()
            .expect("run a README command");
        let secs = started.elapsed().as_secs_f64();
        assert!(
            out.status.success(),
            "{line} failed:\n{}\n{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        (String::from_utf8_lossy(&out.stdout).into_owned(), secs)
    };
    let (demo_out, _) = run(&commands[0]);
    check_demo(&clone.join("terzaghi-demo"), &python);
    assert!(demo_out.contains("hidden by the simulation"), "{demo_out}");
    let (tests_out, _) = run(&commands[1]);
    assert!(tests_out.contains("test result: ok"), "{tests_out}");

    // After the build, the demo's default run takes under a minute.
    let bin = target.join("release/terzaghi");
    let started = Instant::now();
    let out = Command::new(&bin)
        .args(["demo", "--out"])
        .arg(tmp.path().join("timed"))
        .output()
        .unwrap();
    let secs = started.elapsed().as_secs_f64();
    assert!(out.status.success());
    eprintln!("demo, default run after the build: {secs:.1} s");
    assert!(secs < 60.0, "the demo took {secs:.1} s");
}

/// What the demo leaves: an MCAP that an independent reader decodes, a diagnosis that names a
/// hidden effect, and identified parameters within 5 % of the truth.
fn check_demo(dir: &Path, python: &Path) {
    let mcap = dir.join("session.mcap");
    let out = Command::new(python)
        .arg(common::repo().join("tests/python/decode_all.py"))
        .arg(&mcap)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let counts: Value = serde_json::from_slice(&out.stdout).expect("the reader prints counts");
    let topics = counts["counts"].as_object().expect("counts per topic");
    assert!(topics["/joint_states"].as_u64().unwrap() > 1000);
    assert!(topics.keys().any(|t| t.ends_with("/leg_force")));
    assert!(topics.keys().any(|t| t.ends_with("/ft/wrench")));

    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    let hidden: Vec<&str> = summary["truth"]["effects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e.as_str().unwrap())
        .collect();
    let (b_k, a) = (
        summary["truth"]["b_k"].as_f64().unwrap(),
        summary["truth"]["a"].as_f64().unwrap(),
    );
    for leg in summary["legs"].as_array().unwrap() {
        let name = leg["leg"].as_str().unwrap();
        let report: Value = serde_json::from_str(
            &std::fs::read_to_string(dir.join("diagnosis").join(name).join("report.json")).unwrap(),
        )
        .unwrap();
        let verdict = report["verdict"]["effect"].as_str().unwrap();
        assert!(
            hidden.contains(&verdict),
            "leg {name}: verdict {verdict}, hidden {hidden:?}"
        );
        let c = &leg["corrected"];
        let (cb, ca) = (c["b_k"].as_f64().unwrap(), c["a"].as_f64().unwrap());
        assert!(
            (cb / b_k - 1.0).abs() < 0.05,
            "leg {name}: b_k {cb} vs {b_k}"
        );
        assert!((ca / a - 1.0).abs() < 0.05, "leg {name}: a {ca} vs {a}");
        assert!(
            leg["online"]["converged"].as_bool().unwrap(),
            "leg {name}: the node's estimate converged"
        );
    }
    assert!(dir.join("diagnosis/report.html").exists());
}

/// The library's Rust example (`docs/command-line.md`) is the doctest of `terzaghi::session`
/// (which `cargo test` runs on a recording of the simulated robot): the two say the same, line
/// for line.
#[test]
fn the_readme_rust_example_is_the_tested_one() {
    let repo = common::repo();
    let readme = std::fs::read_to_string(repo.join("docs/command-line.md")).unwrap();
    let start = readme
        .find("```rust\n")
        .expect("docs/command-line.md has a rust block")
        + 8;
    let example = &readme[start..start + readme[start..].find("```").unwrap()];
    let module = std::fs::read_to_string(repo.join("src/session/mod.rs")).unwrap();
    let doc: String = module
        .lines()
        .filter_map(|l| l.strip_prefix("//!"))
        .map(|l| l.strip_prefix(' ').unwrap_or(l))
        .filter(|l| !l.starts_with("# ") && *l != "#")
        .map(|l| format!("{l}\n"))
        .collect();
    assert!(
        doc.contains(example),
        "docs/command-line.md's rust block is not the doctest of src/session/mod.rs:\n{example}"
    );
}

/// Every relative link of the README and of `docs/` reaches a file of the repository, and every
/// `#anchor` a heading of the page it names: a newcomer following them never lands nowhere.
#[test]
fn the_documentation_links_resolve() {
    let repo = common::repo();
    let mut pages = vec![repo.join("README.md")];
    for e in std::fs::read_dir(repo.join("docs")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "md") {
            pages.push(p);
        }
    }
    assert!(pages.len() >= 8, "{pages:?}");
    // GitHub's anchor of a heading: lower case, punctuation but '-' and '_' dropped, spaces '-'.
    let anchors = |text: &str| -> Vec<String> {
        text.lines()
            .filter(|l| l.starts_with('#'))
            .map(|l| {
                l.trim_start_matches('#')
                    .trim()
                    .to_lowercase()
                    .chars()
                    .filter(|c| c.is_alphanumeric() || *c == ' ' || *c == '-' || *c == '_')
                    .map(|c| if c == ' ' { '-' } else { c })
                    .collect()
            })
            .collect()
    };
    let mut checked = 0;
    for page in &pages {
        let text = std::fs::read_to_string(page).unwrap();
        // Links outside code blocks: `](target)`.
        let mut in_code = false;
        for line in text.lines() {
            if line.starts_with("```") {
                in_code = !in_code;
                continue;
            }
            if in_code {
                continue;
            }
            for (i, _) in line.match_indices("](") {
                let rest = &line[i + 2..];
                let Some(end) = rest.find(')') else { continue };
                let target = &rest[..end];
                if target.contains("://") || target.contains(' ') {
                    continue;
                }
                let (file, anchor) = target.split_once('#').unwrap_or((target, ""));
                let path = if file.is_empty() {
                    page.clone()
                } else {
                    page.parent().unwrap().join(file)
                };
                assert!(
                    path.exists(),
                    "{}: the link {target} leads nowhere",
                    page.display()
                );
                if !anchor.is_empty() {
                    let there = std::fs::read_to_string(&path).unwrap();
                    assert!(
                        anchors(&there).iter().any(|a| a == anchor),
                        "{}: {target}: no such heading in {}",
                        page.display(),
                        path.display()
                    );
                }
                checked += 1;
            }
        }
    }
    assert!(checked >= 30, "only {checked} links");
}
