//! `terzaghi diagnose-eval`: the diagnosis checked on sessions whose hidden effect it is not told.

use super::print_out;
use crate::diagnose::DiagnoseOptions;
use crate::withheld::{Outcome, Summary, run, summarize};
use anyhow::{Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;

#[derive(Debug, Args)]
pub struct DiagnoseEvalArgs {
    /// Number of generated sessions (kinds rotate: clean, each of the nine effects, two effects
    /// outside the library, pairs).
    #[arg(long, default_value_t = 260)]
    pub cases: usize,
    /// Seed of the run (same seed, same sessions).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Worker threads (default: the machine's cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print the summary and every case as JSON.
    #[arg(long)]
    pub json: bool,
    /// Print every case's truth and verdict.
    #[arg(long)]
    pub verbose: bool,
    /// Instead of evaluating, write case number I of the run as DIR/session.csv with its truth
    /// and the geometry flags in DIR/case.json (to try `terzaghi diagnose` on it).
    #[arg(long, value_name = "I", requires = "export_dir")]
    pub export_case: Option<usize>,
    #[arg(long, value_name = "DIR", requires = "export_case")]
    pub export_dir: Option<std::path::PathBuf>,
}

pub fn run_cmd(a: DiagnoseEvalArgs) -> Result<()> {
    if let (Some(i), Some(dir)) = (a.export_case, &a.export_dir) {
        crate::withheld::export_case(i, a.seed, dir)?;
        return print_out(&format!(
            "wrote {} and case.json\n",
            dir.join("session.csv").display()
        ));
    }
    if a.cases == 0 {
        bail!("--cases must be at least 1");
    }
    let threads = a
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(2, |n| n.get()));
    if threads == 0 {
        bail!("--threads must be at least 1");
    }
    let bar = if std::io::stderr().is_terminal() && !a.json {
        ProgressBar::new(a.cases as u64)
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} cases {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let start = std::time::Instant::now();
    let outcomes = run(a.cases, a.seed, threads, &DiagnoseOptions::default(), |d| {
        bar.set_position(d as u64)
    });
    bar.finish_and_clear();
    let summary = summarize(&outcomes);
    if a.json {
        #[derive(serde::Serialize)]
        struct All<'a> {
            summary: &'a Summary,
            cases: &'a [Outcome],
        }
        let all = All {
            summary: &summary,
            cases: &outcomes,
        };
        return print_out(&(serde_json::to_string_pretty(&all)? + "\n"));
    }
    let mut s = String::new();
    if a.verbose {
        for o in &outcomes {
            s += &format!(
                "{:>6} {:<26} -> {:<14} steps [{}] gap closed {:.0} % (truth {})\n",
                o.seed,
                o.truth,
                o.verdict,
                o.steps.join(", "),
                o.reported_gap_closed_pct,
                o.true_gap_closed_pct
                    .map_or("-".to_string(), |t| format!("{t:.0} %"))
            );
        }
        s += "\n";
    }
    s += &render(&summary, start.elapsed().as_secs_f64());
    print_out(&s)
}

pub fn render(s: &Summary, seconds: f64) -> String {
    let mut cols: Vec<String> = s
        .confusion
        .values()
        .flat_map(|r| r.keys().cloned())
        .collect();
    cols.sort();
    cols.dedup();
    let mut out = format!(
        "confusion (rows: hidden effect, columns: verdict), {} cases in {seconds:.1} s\n",
        s.cases
    );
    out += &format!("{:<12}", "");
    for c in &cols {
        out += &format!(" {:>11}", abbreviate(c));
    }
    out += "\n";
    for (row, counts) in &s.confusion {
        out += &format!("{:<12}", abbreviate(row));
        for c in &cols {
            out += &format!(
                " {:>11}",
                counts.get(c).map_or(".".to_string(), |n| n.to_string())
            );
        }
        out += "\n";
    }
    out += &format!(
        "\nsingle effects named correctly: {:.1} % of {} (target >= 90 %)\n",
        s.single_accuracy_pct, s.single_cases
    );
    out += &format!(
        "false alarms on clean sessions: {:.1} % of {} (target <= 5 %)\n",
        s.false_alarm_pct, s.clean_cases
    );
    out += &format!(
        "outside the library, unexplained or gain < 30 %: {:.1} % of {}\n",
        s.outside_ok_pct, s.outside_cases
    );
    out += &format!(
        "pairs: verdict one of the two {:.1} %, both in the steps {:.1} % of {}\n",
        s.pair_first_ok_pct, s.pair_both_ok_pct, s.pair_cases
    );
    out += &format!(
        "gap closed vs truth ({} cases): mean error {:.1} pts, median {:.1} pts, within 10 pts {:.1} %\n",
        s.gap_cases, s.gap_error_mean_pts, s.gap_error_median_pts, s.gap_within_10_pts_pct
    );
    out
}

fn abbreviate(name: &str) -> String {
    name.chars().take(11).collect()
}
