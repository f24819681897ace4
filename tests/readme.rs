//! A newcomer's first minutes: the two commands at the top of the README, and what the demo
//! leaves behind. That the two commands pass in a fresh clone, with nothing built before them,
//! is what `.ci/run` shows first: it clones the repository and runs the README's test command
//! there (which runs this file too).

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
        // Without the comment that follows a command.
        .map(|l| l.split(" #").next().unwrap_or(l).trim().to_string())
        .collect()
}

/// The README's first command, `cargo run --release -- demo`, is this build's `terzaghi demo`:
/// run from a scratch directory, it prints its tables and leaves what `check_demo` expects. (How
/// long it takes is a benchmark's figure, not this test's.)
#[test]
fn the_readme_demo_leaves_what_it_says() {
    let repo = common::repo();
    let readme = std::fs::read_to_string(repo.join("README.md")).unwrap();
    let commands = readme_commands(&readme);
    assert_eq!(commands.len(), 2, "two commands at the top: {commands:?}");
    assert_eq!(commands[0], "cargo run --release -- demo", "{commands:?}");
    assert_eq!(
        commands[1], "cargo test --release --workspace",
        "{commands:?}"
    );

    let tmp = tempfile::tempdir().unwrap();
    let python = common::python();
    let started = Instant::now();
    let out = Command::new(common::terzaghi())
        .arg("demo")
        .current_dir(tmp.path())
        .output()
        .expect("run terzaghi demo");
    let secs = started.elapsed().as_secs_f64();
    assert!(
        out.status.success(),
        "terzaghi demo failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let demo_out = String::from_utf8_lossy(&out.stdout);
    assert!(demo_out.contains("hidden by the simulation"), "{demo_out}");
    check_demo(&tmp.path().join("terzaghi-demo"), &python);
    eprintln!("demo, default run: {secs:.1} s");
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
