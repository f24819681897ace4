//! The docs' tables of the corrections learnt online are what `terzaghi-eval diagnose-eval
//! --online` prints. In the evaluation's package, where cargo builds `terzaghi-eval`.

#[path = "../../../tests/common/mod.rs"]
mod common;

use terzaghi_eval::closed_loop::STEP_CASES;

/// `diagnose-eval --online --json` gives every value behind the table: each case's batch and
/// online values with the online standard deviation, its largest difference the table's.
#[test]
fn diagnose_eval_online_json_holds_the_values_behind_the_table() {
    let printed = eval_stdout(&["diagnose-eval", "--online", "--json"]);
    let v: serde_json::Value = serde_json::from_str(&printed).expect("JSON on stdout");
    let cases = v["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 9);
    assert_eq!(v["steps"].as_array().unwrap().len(), STEP_CASES.len());
    let readme = common::docs_text();
    for c in cases {
        let values = c["values"].as_array().unwrap();
        assert!(values.len() >= 2, "{c}");
        let num = |x: &serde_json::Value, k: &str| x[k].as_f64().unwrap();
        // The table's rule: b_k and a always, a coefficient when over three deviations from 0.
        let worst = values
            .iter()
            .filter(|x| {
                let name = x["name"].as_str().unwrap();
                name == "b_k" || name == "a" || num(x, "batch").abs() > 3.0 * num(x, "std")
            })
            .map(|x| {
                let pct = 100.0 * (num(x, "online") - num(x, "batch")) / num(x, "batch").abs();
                (x["name"].as_str().unwrap().to_string(), pct)
            })
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
            .unwrap();
        let row = format!(
            "| {} | {} | {} | ",
            c["case"].as_str().unwrap(),
            c["truth"].as_str().unwrap(),
            c["strokes"]
        );
        let line = readme
            .lines()
            .find(|l| l.starts_with(&row))
            .unwrap_or_else(|| panic!("no row {row}"));
        let cell = format!("| {} {:+.1} % |", worst.0, worst.1);
        assert!(line.contains(&cell), "{line} lacks {cell}");
    }
}

/// The README's tables of the corrections learnt online, and the docs' table of the stroke
/// jackknife, are what `diagnose-eval --online --jackknife` prints (one run: the jackknife's
/// output begins with the online tables `--online` alone prints). The jackknife: for each
/// session that does not hold, how far leaving one stroke out moves its batch value.
#[test]
fn the_online_and_jackknife_tables_are_what_diagnose_eval_online_prints() {
    let printed = eval_stdout(&["diagnose-eval", "--online", "--jackknife"]);
    let (online, jackknife) = printed
        .split_once("Stroke jackknife")
        .expect("a jackknife table");
    let is_row = |l: &&str| {
        l.strip_prefix("| case ")
            .is_some_and(|r| r.starts_with(|c: char| c.is_ascii_digit()))
    };
    let docs = common::docs_text();
    let online_rows: Vec<&str> = online.lines().filter(is_row).collect();
    assert_eq!(online_rows.len(), 9 + STEP_CASES.len(), "{printed}");
    for row in online_rows {
        assert!(docs.contains(row), "the README lacks the row\n{row}");
    }
    let rows: Vec<&str> = jackknife.lines().filter(is_row).collect();
    // The sessions that do not hold, in the first table (before its count); where all hold,
    // the one nearest the bound.
    let first_table = printed.split_once("\nholds: ").expect("the count").0;
    let misses = first_table
        .lines()
        .filter(|l| is_row(l) && l.ends_with("| no |"))
        .count();
    assert!(rows.len() == misses.max(1), "{printed}");
    for row in rows {
        assert!(docs.contains(row), "the docs lack the row\n{row}");
    }
}

/// What `terzaghi-eval ARGS` prints, once it succeeded.
fn eval_stdout(args: &[&str]) -> String {
    let out = std::process::Command::new(common::eval_exe())
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "terzaghi-eval {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}
