//! The shape of the library, as `src/lib.rs` maps it: every top-level module is on the map, and
//! each uses only modules above it there (so the arrows point one way and there is no cycle);
//! nothing outside the command line uses the command line.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The `.rs` files of a top-level module (a file `src/x.rs` or a directory `src/x/`).
fn files_of(src: &Path, module: &str) -> Vec<PathBuf> {
    let file = src.join(format!("{module}.rs"));
    if file.exists() {
        return vec![file];
    }
    let mut out = Vec::new();
    let mut dirs = vec![src.join(module)];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }
    out
}

/// The top-level modules a module's code names as `crate::<module>`, also inside
/// `crate::{a, b::c}` groups.
fn uses(text: &str, modules: &[String]) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for (i, _) in text.match_indices("crate::") {
        let rest = &text[i + 7..];
        let names: Vec<&str> = if let Some(group) = rest.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            group[..end]
                .split(',')
                .map(|s| s.trim().split("::").next().unwrap_or("").trim())
                .collect()
        } else {
            vec![
                rest.split(|c: char| !(c.is_alphanumeric() || c == '_'))
                    .next()
                    .unwrap_or(""),
            ]
        };
        out.extend(
            names
                .into_iter()
                .filter(|n| modules.iter().any(|m| m == n))
                .map(String::from),
        );
    }
    out
}

/// One crate's `src/lib.rs` map against its modules: every module is on the map, and each
/// uses only modules above it there (the crates below it are not on the map: any may be used).
fn check_map(src: &Path) -> Vec<String> {
    let lib = std::fs::read_to_string(src.join("lib.rs")).unwrap();
    // The map: "//! - [`name`]: ..." lines (a private module: "//! - `name`: ..."), in order.
    let map: Vec<String> = lib
        .lines()
        .filter_map(|l| {
            l.strip_prefix("//! - [`")
                .or_else(|| l.strip_prefix("//! - `"))
        })
        .filter_map(|l| l.split('`').next())
        .map(String::from)
        .collect();
    // Modules in files of their own (`pub mod name;`), not an inline facade of re-exports.
    let declared: Vec<String> = lib
        .lines()
        .filter_map(|l| {
            l.strip_prefix("pub mod ")
                .or_else(|| l.strip_prefix("mod "))
        })
        .filter_map(|l| l.strip_suffix(';'))
        .map(String::from)
        .collect();
    assert!(declared.len() >= 4, "{}: no modules found", src.display());
    let on_map: BTreeSet<&String> = map.iter().collect();
    let all: BTreeSet<&String> = declared.iter().collect();
    assert_eq!(
        on_map,
        all,
        "{}/lib.rs's map and its modules differ",
        src.display()
    );
    for (i, module) in map.iter().enumerate() {
        let above = &map[..i];
        for file in files_of(src, module) {
            let text = std::fs::read_to_string(&file).unwrap();
            for used in uses(&text, &declared) {
                if &used == module {
                    continue;
                }
                assert!(
                    above.contains(&used),
                    "{} ({module}) uses crate::{used}, which is not above {module} on the map of {}/lib.rs",
                    file.display(),
                    src.display()
                );
            }
        }
    }
    map
}

#[test]
fn every_module_is_on_the_map_and_uses_only_those_above_it() {
    let map = check_map(&repo().join("src"));
    assert_eq!(map.last().map(String::as_str), Some("fuzzing"), "{map:?}");
    let core = check_map(&repo().join("crates/terzaghi-core/src"));
    assert_eq!(core, ["model", "ident", "sim", "diagnose"]);
    let eval = check_map(&repo().join("crates/terzaghi-eval/src"));
    assert_eq!(eval.last().map(String::as_str), Some("dem_report"));
}

/// The core crate needs no I/O, DDS, runtime or command line: its dependencies are the
/// numerical ones it declares, and nothing of the node's.
#[test]
fn the_core_crate_depends_on_no_dds_runtime_or_command_line() {
    let manifest = std::fs::read_to_string(repo().join("crates/terzaghi-core/Cargo.toml")).unwrap();
    let deps: Vec<&str> = manifest
        .split("[dependencies]")
        .nth(1)
        .unwrap()
        .lines()
        .take_while(|l| !l.starts_with('['))
        .filter_map(|l| l.split('=').next())
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect();
    assert_eq!(
        deps,
        ["nalgebra", "rand", "rand_distr", "serde", "thiserror"]
    );
    let out = std::process::Command::new(env!("CARGO"))
        .args([
            "tree",
            "--offline",
            "-p",
            "terzaghi-core",
            "-e",
            "normal",
            "--prefix",
            "none",
        ])
        .current_dir(repo())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let tree = String::from_utf8(out.stdout).unwrap();
    assert!(tree.contains("nalgebra"), "{tree}");
    for forbidden in [
        "rustdds",
        "ros2-client",
        "foxglove",
        "tokio",
        "clap",
        "mcap",
    ] {
        assert!(
            !tree
                .lines()
                .any(|l| l.starts_with(&format!("{forbidden} "))),
            "terzaghi-core depends on {forbidden}:\n{tree}"
        );
    }
}

/// The library does not reach up to its own face: the command line is the binary's (`src/main.rs`
/// declares `cli` and `demo`), and no library module names it.
#[test]
fn the_library_does_not_reach_up_to_the_command_line() {
    let lib = std::fs::read_to_string(repo().join("src/lib.rs")).unwrap();
    for word in ["command_line", "mod cli", "mod demo"] {
        assert!(!lib.contains(word), "src/lib.rs names {word}");
    }
    let main = std::fs::read_to_string(repo().join("src/main.rs")).unwrap();
    assert!(main.contains("mod cli;") && main.contains("mod demo;"));
    for dir in ["src", "crates/terzaghi-eval/src", "benches/terzaghi-bench"] {
        for file in rust_files(&repo().join(dir)) {
            let path = file.to_string_lossy();
            if path.contains("/src/cli/")
                || path.ends_with("src/main.rs")
                || path.ends_with("src/demo.rs")
            {
                continue;
            }
            let text = std::fs::read_to_string(&file).unwrap();
            assert!(
                !text.contains("crate::cli") && !text.contains("terzaghi::cli"),
                "{path} uses the command line"
            );
        }
    }
}

/// Every `.rs` file under `dir`, recursively.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            out.extend(rust_files(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
    out
}

/// A reader finds each step of the work in a function that fits on a screen or two: no function
/// of the product's code (`src/`, `crates/*/src/`) is longer than 200 lines, from its `fn` line
/// to the brace that closes it at the same indentation (rustfmt's layout).
#[test]
fn no_function_of_the_product_is_over_200_lines() {
    let mut dirs = vec![repo().join("src")];
    for e in std::fs::read_dir(repo().join("crates")).unwrap() {
        dirs.push(e.unwrap().path().join("src"));
    }
    let mut long = Vec::new();
    for dir in dirs {
        for file in rust_files(&dir) {
            let text = std::fs::read_to_string(&file).unwrap();
            let lines: Vec<&str> = text.lines().collect();
            for (i, line) in lines.iter().enumerate() {
                let body = line.trim_start();
                let indent = &line[..line.len() - body.len()];
                let is_fn = [
                    "fn ",
                    "pub fn ",
                    "pub(crate) fn ",
                    "pub(super) fn ",
                    "async fn ",
                ]
                .iter()
                .chain(&["pub async fn ", "const fn ", "pub const fn "])
                .any(|p| body.starts_with(p));
                if !is_fn || line.ends_with('}') || line.ends_with(';') {
                    continue;
                }
                let close = format!("{indent}}}");
                if let Some(end) = lines[i + 1..].iter().position(|l| *l == close) {
                    let n = end + 2;
                    if n > 200 {
                        long.push(format!("{}:{} ({n} lines): {body}", file.display(), i + 1));
                    }
                }
            }
        }
    }
    assert!(
        long.is_empty(),
        "functions over 200 lines:\n{}",
        long.join("\n")
    );
}
