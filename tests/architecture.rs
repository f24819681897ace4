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

#[test]
fn every_module_is_on_the_map_and_uses_only_those_above_it() {
    let src = repo().join("src");
    let lib = std::fs::read_to_string(src.join("lib.rs")).unwrap();
    // The map: "//! - [`name`]: ..." lines, in order.
    let map: Vec<String> = lib
        .lines()
        .filter_map(|l| l.strip_prefix("//! - [`"))
        .filter_map(|l| l.split('`').next())
        .map(String::from)
        .collect();
    let declared: Vec<String> = lib
        .lines()
        .filter_map(|l| l.strip_prefix("pub mod "))
        .map(|l| l.trim_end_matches(';').to_string())
        .collect();
    let on_map: BTreeSet<&String> = map.iter().collect();
    let all: BTreeSet<&String> = declared.iter().collect();
    assert_eq!(on_map, all, "src/lib.rs's map and its modules differ");
    for (i, module) in map.iter().enumerate() {
        let above = &map[..i];
        for file in files_of(&src, module) {
            let text = std::fs::read_to_string(&file).unwrap();
            for used in uses(&text, &declared) {
                if &used == module {
                    continue;
                }
                assert!(
                    above.contains(&used),
                    "{} ({module}) uses crate::{used}, which is not above {module} on the map of src/lib.rs",
                    file.display()
                );
            }
        }
    }
    assert_eq!(map.last().map(String::as_str), Some("cli"), "cli is on top");
}
