//! The docs a reader relies on: `docs/command-line.md` lists every command and every flag that
//! `--help` prints (its reference is what `terzaghi help-markdown` prints), and a performance
//! figure is stated on one page, `docs/benchmarks.md`, which the other pages quote exactly.

mod common;

use std::collections::BTreeSet;
use std::process::Command;

fn terzaghi(args: &[&str]) -> String {
    let out = Command::new(common::terzaghi())
        .args(args)
        .output()
        .expect("run terzaghi");
    assert!(out.status.success(), "terzaghi {args:?}");
    String::from_utf8(out.stdout).unwrap()
}

fn page(name: &str) -> String {
    std::fs::read_to_string(common::repo().join(name)).unwrap()
}

/// The commands `terzaghi --help` lists (and `param`'s own), as argument lists.
fn commands() -> Vec<Vec<String>> {
    let names = |help: &str| -> Vec<String> {
        help.split("Commands:")
            .nth(1)
            .expect("a list of commands")
            .lines()
            .skip(1)
            .take_while(|l| l.starts_with("  "))
            .filter_map(|l| l.split_whitespace().next())
            .filter(|c| *c != "help")
            .map(String::from)
            .collect()
    };
    let mut all = Vec::new();
    for c in names(&terzaghi(&["--help"])) {
        let help = terzaghi(&[&c, "--help"]);
        if help.contains("Commands:") {
            for sub in names(&help) {
                all.push(vec![c.clone(), sub]);
            }
        } else {
            all.push(vec![c]);
        }
    }
    assert!(all.len() >= 15, "{all:?}");
    all
}

#[test]
fn the_command_line_page_lists_every_command_and_flag_that_help_prints() {
    let doc = page("docs/command-line.md");
    let mut missing = BTreeSet::new();
    for cmd in commands() {
        let title = format!("### `terzaghi {}`", cmd.join(" "));
        let Some(start) = doc.find(&title) else {
            missing.insert(title);
            continue;
        };
        let section = &doc[start + title.len()..];
        let section = &section[..section.find("\n### ").unwrap_or(section.len())];
        let args: Vec<&str> = cmd.iter().map(String::as_str).chain(["--help"]).collect();
        for line in terzaghi(&args).lines() {
            let line = line.trim_start();
            if !line.starts_with('-') {
                continue;
            }
            // "-o, --output <OUT>" or "--seconds <SECONDS>": the long name.
            let Some(flag) = line
                .split(|c: char| c == ',' || c.is_whitespace())
                .find(|w| w.starts_with("--"))
            else {
                continue;
            };
            if flag == "--help" || flag == "--version" {
                continue;
            }
            if !section.contains(&format!("{flag} ")) && !section.contains(&format!("{flag}`")) {
                missing.insert(format!("terzaghi {} {flag}", cmd.join(" ")));
            }
        }
    }
    assert!(
        missing.is_empty(),
        "docs/command-line.md lacks: {missing:?}"
    );
}

#[test]
fn the_flag_reference_is_what_help_markdown_prints() {
    let doc = page("docs/command-line.md");
    let start = "<!-- generated: terzaghi help-markdown -->\n";
    let from = doc.find(start).expect("the generated section's start") + start.len();
    let to = doc.find("<!-- end generated -->").expect("its end");
    assert_eq!(
        &doc[from..to],
        terzaghi(&["help-markdown"]),
        "docs/command-line.md's reference is stale: regenerate it with terzaghi help-markdown"
    );
}

/// Every time figure of the code's speed (a number of ns or us) that a page other than `docs/benchmarks.md`
/// states is one `docs/benchmarks.md` states too, in the same words: the pages cannot give one
/// measurement two values.
#[test]
fn performance_figures_are_the_benchmarks_pages() {
    let bench = page("docs/benchmarks.md");
    let figure = |text: &str| -> Vec<String> {
        let words: Vec<&str> = text.split_whitespace().collect();
        words
            .windows(2)
            .filter(|w| {
                matches!(
                    w[1].trim_end_matches(|c: char| ",.;:)".contains(c)),
                    "ns" | "us"
                ) && w[0]
                    .trim_start_matches('(')
                    .replace(',', "")
                    .parse::<f64>()
                    .is_ok()
            })
            .map(|w| {
                format!(
                    "{} {}",
                    w[0].trim_start_matches('('),
                    w[1].trim_end_matches(|c: char| ",.;:)".contains(c))
                )
            })
            .collect()
    };
    let stated: BTreeSet<String> = figure(&bench).into_iter().collect();
    let mut pages = vec!["README.md".to_string(), "patches/README.md".to_string()];
    for e in std::fs::read_dir(common::repo().join("docs")).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if name.ends_with(".md") && name != "benchmarks.md" {
            pages.push(format!("docs/{name}"));
        }
    }
    let mut elsewhere = Vec::new();
    for p in &pages {
        for f in figure(&page(p)) {
            if !stated.contains(&f) {
                elsewhere.push(format!("{p}: {f}"));
            }
        }
    }
    assert!(
        elsewhere.is_empty(),
        "figures not stated by docs/benchmarks.md: {elsewhere:?}"
    );
}
