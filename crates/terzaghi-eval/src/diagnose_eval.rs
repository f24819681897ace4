//! `terzaghi diagnose-eval`: the diagnosis checked on sessions whose hidden effect it is not told.

use crate::dem_cases::{CaseError, DemOutcome};
use crate::withheld::{Outcome, Summary, run, summarize};
use anyhow::{Context, Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use terzaghi::diagnose::DiagnoseOptions;
use terzaghi::session::files::print_out;

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
    /// Also check the diagnosis on the DEM campaign in DIR (tests/dem/campaign): every
    /// controlled variation with the effect it must name, and the base case. With --cases 0,
    /// only these.
    #[arg(long, value_name = "DIR")]
    pub dem: Option<std::path::PathBuf>,
    /// Instead of scoring the verdicts, close the loop: diagnose the first two thirds of each
    /// session's strokes and predict the rest through the node, with the bare model and with
    /// the corrected model the diagnosis wrote (the demo's six legs, --cases generated
    /// sessions, and with --dem the DEM cases).
    #[arg(long)]
    pub closed_loop: bool,
    /// Instead of evaluating, learn the corrected model online: the generated sessions with one
    /// hidden effect each (cases 1-9 of the run), diagnosed whole, then learnt by the node's
    /// online identification from the conventional start over the same session; and four of
    /// them followed by a medium 1.4 times as strong. Prints each value against the batch one.
    #[arg(long, conflicts_with = "closed_loop")]
    pub online: bool,
    /// With --online: for each session that does not hold (where all hold, the one whose value
    /// comes nearest the 10 % bound), how precisely its strokes determine the value that misses
    /// most: the diagnosis run again with each stroke left out in turn (a stroke jackknife;
    /// some ten seconds per session).
    #[arg(long, requires = "online")]
    pub jackknife: bool,
}

pub fn run_cmd(a: DiagnoseEvalArgs) -> Result<()> {
    if let (Some(i), Some(dir)) = (a.export_case, &a.export_dir) {
        crate::withheld::export_case(i, a.seed, dir)?;
        return print_out(&format!(
            "wrote {} and case.json\n",
            dir.join("session.csv").display()
        ));
    }
    if a.cases == 0 && a.dem.is_none() {
        bail!("--cases must be at least 1 (or give --dem DIR to check only the DEM cases)");
    }
    let campaign = match &a.dem {
        Some(dir) => Some(
            terzaghi::dem::read_campaign(dir)
                .with_context(|| format!("cannot read the DEM campaign {}", dir.display()))?,
        ),
        None => None,
    };
    let threads = a
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(2, |n| n.get()));
    if threads == 0 {
        bail!("--threads must be at least 1");
    }
    if a.closed_loop {
        return closed_loop(&a, campaign.as_ref(), threads);
    }
    if a.online {
        return online(a.seed, threads, a.json, a.jackknife);
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
    let generated_s = start.elapsed().as_secs_f64();
    let dem_start = std::time::Instant::now();
    let dem: Vec<Result<DemOutcome, CaseError>> = campaign
        .as_ref()
        .map(|c| crate::dem_cases::run_all(c, a.seed, &DiagnoseOptions::default()))
        .unwrap_or_default();
    let dem_s = dem_start.elapsed().as_secs_f64();
    if let Some(e) = dem.iter().find_map(|r| r.as_ref().err()) {
        bail!("{e}");
    }
    let dem: Vec<DemOutcome> = dem.into_iter().filter_map(Result::ok).collect();
    let summary = summarize(&outcomes);
    if a.json {
        #[derive(serde::Serialize)]
        struct All<'a> {
            summary: &'a Summary,
            cases: &'a [Outcome],
            dem: &'a [DemOutcome],
        }
        let all = All {
            summary: &summary,
            cases: &outcomes,
            dem: &dem,
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
                o.steps
                    .iter()
                    .map(|e| e.name())
                    .collect::<Vec<_>>()
                    .join(", "),
                o.reported_gap_closed_pct,
                o.true_gap_closed_pct
                    .map_or("-".to_string(), |t| format!("{t:.0} %"))
            );
        }
        s += "\n";
    }
    if a.cases > 0 {
        s += &render(&summary, generated_s);
    }
    if let Some(dir) = &a.dem {
        if a.cases > 0 {
            s += "\n";
        }
        s += &render_dem(&dem, dir, dem_s);
    }
    print_out(&s)
}

/// `--online`: the corrected model learnt online against the batch diagnosis (as JSON, with
/// every value, its batch value and its online standard deviation, with `json`).
fn online(seed: u64, threads: usize, json: bool, with_jackknife: bool) -> Result<()> {
    use crate::closed_loop::{
        ONLINE_CASES, STEP_CASES, STEP_FACTOR, jackknife, learnt_online, learnt_step,
    };
    use rayon::prelude::*;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("cannot start the worker threads")?;
    let (cases, steps) = pool.install(|| {
        let cases: Vec<_> = ONLINE_CASES
            .into_par_iter()
            .map(|i| learnt_online(i, seed))
            .collect();
        let steps: Vec<_> = STEP_CASES
            .into_par_iter()
            .map(|i| learnt_step(i, seed, STEP_FACTOR))
            .collect();
        (cases, steps)
    });
    let cases: Vec<_> = cases.into_iter().collect::<Result<_, _>>()?;
    let steps: Vec<_> = steps.into_iter().collect::<Result<_, _>>()?;
    // The value that misses most in each session that does not hold; where every session
    // holds, in the session whose value comes nearest the 10 % bound.
    let misses: Vec<(usize, String)> = if with_jackknife {
        let (failing, holding): (Vec<_>, Vec<_>) = ONLINE_CASES
            .zip(&cases)
            .filter_map(|(i, c)| worst_value(c).map(|v| (i, c.holds(), v)))
            .partition(|(_, holds, _)| !holds);
        let picked: Vec<_> = if failing.is_empty() {
            holding
                .into_iter()
                .max_by(|a, b| a.2.diff_pct().abs().total_cmp(&b.2.diff_pct().abs()))
                .into_iter()
                .collect()
        } else {
            failing
        };
        picked
            .into_iter()
            .map(|(i, _, v)| (i, v.name.clone()))
            .collect()
    } else {
        Vec::new()
    };
    let jack: Vec<_> = pool.install(|| {
        misses
            .into_par_iter()
            .map(|(i, name)| jackknife(i, seed, &name))
            .collect()
    });
    let jack: Vec<_> = jack.into_iter().collect::<Result<_, _>>()?;
    if json {
        #[derive(serde::Serialize)]
        struct Online<'a> {
            cases: &'a [crate::closed_loop::LearntOnline],
            steps: &'a [crate::closed_loop::LearntStep],
            #[serde(skip_serializing_if = "<[_]>::is_empty")]
            jackknife: &'a [crate::closed_loop::Jackknife],
        }
        let all = Online {
            cases: &cases,
            steps: &steps,
            jackknife: &jack,
        };
        return print_out(&(serde_json::to_string_pretty(&all)? + "\n"));
    }
    let mut out = render_online(&cases, &steps);
    if with_jackknife {
        out += &render_jackknife(&cases, &jack);
    }
    print_out(&out)
}

/// A session's determined value farthest from its batch value.
fn worst_value(c: &crate::closed_loop::LearntOnline) -> Option<&crate::closed_loop::LearntValue> {
    c.values
        .iter()
        .filter(|v| v.determined())
        .max_by(|a, b| a.diff_pct().abs().total_cmp(&b.diff_pct().abs()))
}

/// The table of `--online --jackknife`.
pub fn render_jackknife(
    cases: &[crate::closed_loop::LearntOnline],
    jack: &[crate::closed_loop::Jackknife],
) -> String {
    let mut s = String::from(
        "\nStroke jackknife of the value that misses most (the batch diagnosis run again with each stroke left out)\n\n| case | hidden effect | value | batch | online +- online std | jackknife standard error (runs) | online - batch, in jackknife errors |\n|---|---|---|---|---|---|---|\n",
    );
    for j in jack {
        let Some(v) = cases
            .iter()
            .find(|c| c.case == j.case)
            .and_then(|c| c.values.iter().find(|v| v.name == j.name))
        else {
            continue;
        };
        // Fewer than two runs that kept the session's terms give no spread to report.
        let (error, in_errors) = match j.std_error.filter(|e| *e > 0.0) {
            Some(e) => (
                format!(
                    "{e:.2e} ({} of {}, {:.0} % of the value)",
                    j.runs,
                    j.strokes,
                    100.0 * e / j.batch.abs()
                ),
                format!("{:+.2}", (v.online - j.batch) / e),
            ),
            None => (
                format!("- ({} of {} runs kept the terms)", j.runs, j.strokes),
                "-".to_string(),
            ),
        };
        s += &format!(
            "| {} | {} | {} | {:.4e} | {:.4e} +- {:.2e} | {error} | {in_errors} |\n",
            j.case, j.truth, j.name, j.batch, v.online, v.std,
        );
    }
    s
}

/// The tables of `--online`.
pub fn render_online(
    cases: &[crate::closed_loop::LearntOnline],
    steps: &[crate::closed_loop::LearntStep],
) -> String {
    use crate::closed_loop::{LearntOnline, STEP_FACTOR};
    let mut s = String::from(
        "Corrected model learnt online from b_k = a = 1 and zero coefficients, against the batch diagnosis of the same session\n(a value counts as determined when its batch value is over three online standard deviations from zero; b_k and a always)\n\n| case | hidden effect | strokes | determined values within 10 % | largest difference of a determined value | converged | changes detected (the bare estimator's) | change alarms dismissed | holds |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    let worst = |c: &LearntOnline| {
        worst_value(c).map_or("-".to_string(), |v| {
            format!("{} {:+.1} %", v.name, v.diff_pct())
        })
    };
    let count = |c: &LearntOnline| {
        let d: Vec<_> = c.values.iter().filter(|v| v.determined()).collect();
        format!(
            "{} of {}",
            d.iter().filter(|v| v.within_10_pct()).count(),
            d.len()
        )
    };
    for c in cases {
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {} ({}) | {} | {} |\n",
            c.case,
            c.truth,
            c.strokes,
            count(c),
            worst(c),
            if c.converged { "yes" } else { "no" },
            c.changes_detected,
            c.bare_changes_detected,
            if c.alarm_under_test {
                format!("{}, 1 under test at the end", c.alarms_dismissed)
            } else {
                c.alarms_dismissed.to_string()
            },
            if c.holds() { "yes" } else { "no" }
        );
    }
    s += &format!(
        "\nholds: {} of {}\n\nA step of the medium (b_k x {STEP_FACTOR}) after the session: the same motion again\n\n| case | hidden effect | detected after (strokes) | before the step | after: b_k batch / online | after: largest difference | after: holds |\n|---|---|---|---|---|---|---|\n",
        cases.iter().filter(|c| c.holds()).count(),
        cases.len()
    );
    for st in steps {
        let b_k = st.after.values.first();
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {} |\n",
            st.before.case.split(',').next().unwrap_or_default(),
            st.before.truth,
            st.detected_after_strokes
                .map_or("not detected".to_string(), |x| format!("{x:.1}")),
            if st.before.holds() {
                "holds"
            } else {
                "does not hold"
            },
            b_k.map_or("-".to_string(), |v| format!(
                "{:.3} / {:.3}",
                v.batch, v.online
            )),
            worst(&st.after),
            if st.after.holds() { "yes" } else { "no" }
        );
    }
    s
}

/// `--closed-loop`: every session's held-out strokes, bare against corrected.
fn closed_loop(
    a: &DiagnoseEvalArgs,
    campaign: Option<&terzaghi::dem::Campaign>,
    threads: usize,
) -> Result<()> {
    use crate::closed_loop::{dem_sessions, demo_sessions, generated_sessions};
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("cannot start the worker threads")?;
    let start = std::time::Instant::now();
    let (all, seconds) = pool.install(|| {
        let mut all = demo_sessions(60.0, a.seed);
        all.extend(generated_sessions(a.cases, a.seed));
        if let Some(c) = campaign {
            all.extend(dem_sessions(c, a.seed));
        }
        (all, start.elapsed().as_secs_f64())
    });
    let (done, failed): (Vec<_>, Vec<_>) = all.into_iter().partition(|r| r.is_ok());
    let done: Vec<crate::closed_loop::HeldOut> = done.into_iter().filter_map(Result::ok).collect();
    let failed: Vec<String> = failed
        .into_iter()
        .filter_map(|r| r.err().map(|e| e.to_string()))
        .collect();
    if a.json {
        return print_out(
            &(serde_json::to_string_pretty(&serde_json::json!({
                "sessions": done,
                "not_checked": failed,
            }))? + "\n"),
        );
    }
    print_out(&render_closed_loop(&done, &failed, seconds))
}

/// The held-out table: per session, what the diagnosis kept and reported, and the node's error
/// on the strokes it did not see with the bare and the corrected model.
pub fn render_closed_loop(
    done: &[crate::closed_loop::HeldOut],
    failed: &[String],
    seconds: f64,
) -> String {
    let whole = |v: f64| format!("{:.0} %", v.round() + 0.0);
    let kept = |h: &crate::closed_loop::HeldOut| {
        if h.kept.is_empty() {
            "-".to_string()
        } else {
            h.kept
                .iter()
                .map(|e| e.name())
                .collect::<Vec<_>>()
                .join(", ")
        }
    };
    let (wc, wt, wk) = done.iter().fold((4, 5, 4), |(c, t, k), h| {
        (
            c.max(h.case.len()),
            t.max(h.truth.len()),
            k.max(kept(h).len()),
        )
    });
    let mut out = format!(
        "Held-out strokes: each session's first {:.0} % of strokes diagnosed, the rest predicted through the node\n\
         with the bare model (the diagnosis's b_k, a) and the corrected model it wrote; {} sessions in {seconds:.1} s\n\n",
        100.0 * crate::closed_loop::TRAIN_FRAC,
        done.len()
    );
    out += &format!(
        "{:<9} {:<wc$} {:<wt$} {:<wk$} {:>8} {:>7} {:>8} {:>21} {:>21} {:>5}\n",
        "source",
        "case",
        "truth",
        "kept",
        "reported",
        "forward",
        "measured",
        "bare RMSE (R^2 d/l)",
        "corrected (R^2 d/l)",
        "holds"
    );
    for h in done {
        let fit = |f: &crate::closed_loop::HeldOutFit| {
            format!("{:.3} N ({:.2}/{:.2})", f.rmse_n, f.r2_drag, f.r2_lift)
        };
        out += &format!(
            "{:<9} {:<wc$} {:<wt$} {:<wk$} {:>8} {:>7} {:>8} {:>21} {:>21} {:>5}\n",
            h.source,
            h.case,
            h.truth,
            kept(h),
            if h.kept.is_empty() {
                "-".to_string()
            } else {
                whole(h.reported_pct)
            },
            h.reported_forward_pct.map_or("-".to_string(), whole),
            h.measured_pct.map_or("-".to_string(), whole),
            fit(&h.bare),
            fit(&h.corrected),
            if h.holds { "yes" } else { "NO" }
        );
    }
    out += "\n";
    for source in ["demo", "generated", "dem"] {
        let of: Vec<&crate::closed_loop::HeldOut> =
            done.iter().filter(|h| h.source == source).collect();
        if of.is_empty() {
            continue;
        }
        let corrected: Vec<&&crate::closed_loop::HeldOut> =
            of.iter().filter(|h| !h.kept.is_empty()).collect();
        let holds = corrected.iter().filter(|h| h.holds).count();
        let better = corrected
            .iter()
            .filter(|h| h.corrected.rmse_n < h.bare.rmse_n)
            .count();
        let forward_holds = corrected
            .iter()
            .filter(|h| match (h.reported_forward_pct, h.measured_pct) {
                (Some(f), Some(m)) => crate::closed_loop::closes_share(m, f),
                _ => h.holds,
            })
            .count();
        out += &format!(
            "{source}: {} sessions, {} with corrections; the corrected model closes at least the reported share less 10 points in {holds} of them (the forward share less 10 points in {forward_holds}), and predicts the held-out strokes better than the bare model in {better}\n",
            of.len(),
            corrected.len()
        );
    }
    for f in failed {
        out += &format!("not checked: {f}\n");
    }
    out
}

/// The DEM cases as a table, and how many variations had their effect found.
pub fn render_dem(d: &[DemOutcome], dir: &std::path::Path, seconds: f64) -> String {
    let mut out = format!(
        "DEM cases from {} ({} cases in {seconds:.1} s; F/T noise {:.0} % of the peak force)\n",
        dir.display(),
        d.len(),
        100.0 * crate::dem_cases::NOISE_FRAC
    );
    // Rounded to whole percent, a share just below zero reads 0 %, not -0 %.
    let whole = |v: f64| format!("{:.0} %", v.round() + 0.0);
    let pct = |v: Option<f64>| v.map_or("-".to_string(), whole);
    let effects_of = |o: &DemOutcome| {
        if o.effects.is_empty() {
            "-".to_string()
        } else {
            o.effects
                .iter()
                .map(|(e, p)| format!("{e} {}", whole(*p)))
                .collect::<Vec<_>>()
                .join(", ")
        }
    };
    let first = "significant effects (share of the gap)";
    let (wc, we) = d.iter().fold((4, first.len()), |(wc, we), o| {
        (wc.max(o.case.len()), we.max(effects_of(o).len()))
    });
    out += &format!(
        "{:<wc$} {:<12} {:<12} {:<we$} {:>5} {:>9} {:>9} {:>11}\n",
        "case", "expected", "verdict", first, "found", "reported", "measured", "unexplained"
    );
    for o in d {
        let effects = effects_of(o);
        out += &format!(
            "{:<wc$} {:<12} {:<12} {:<we$} {:>5} {:>9} {:>9} {:>11}\n",
            o.case,
            o.expected.map_or("(free)".to_string(), |e| e.to_string()),
            o.verdict,
            effects,
            if o.expected.is_none() {
                "-"
            } else if o.found {
                "yes"
            } else {
                "NO"
            },
            pct(o.reported_pct),
            pct(o.measured_pct),
            format!("{:.0} %", o.unexplained_pct),
        );
    }
    let varied: Vec<&DemOutcome> = d.iter().filter(|o| o.expected.is_some()).collect();
    let found = varied.iter().filter(|o| o.found).count();
    let compared: Vec<f64> = varied
        .iter()
        .filter_map(|o| Some((o.reported_pct? - o.measured_pct?).abs()))
        .collect();
    let within = compared.iter().filter(|e| **e <= 10.0).count();
    out += &format!(
        "\nDEM: the varied effect found in {found} of {} variations; its reported share of the gap within 10 points of the measured in {within} of {}\n",
        varied.len(),
        compared.len()
    );
    let split: Vec<(&DemOutcome, &terzaghi::diagnose::signatures::TimingSplit)> = d
        .iter()
        .filter_map(|o| Some((o, o.report.signatures.delay.timing_split.as_ref()?)))
        .collect();
    if !split.is_empty() {
        out += "\nwhere the speeds vary, each stroke's best-aligning shift split as time + angle / omega (reported, not used to decide):\n";
        out += &format!(
            "{:<wc$} {:>10} {:>7} {:>11}  strokes (rad/s: ms)\n",
            "case", "time (ms)", "t", "angle (deg)"
        );
        for (o, t) in split {
            let strokes: Vec<String> = t
                .strokes
                .iter()
                .map(|(w, l)| format!("{w:.1}: {:+.0}", 1e3 * l))
                .collect();
            out += &format!(
                "{:<wc$} {:>+10.1} {:>+7.1} {:>+11.2}  {}\n",
                o.case,
                1e3 * t.time_shift_s,
                t.time_shift_t,
                t.angle_shift_deg,
                strokes.join(", ")
            );
        }
    }
    if let Some(base) = d.iter().find(|o| o.case == "base") {
        out += &format!(
            "DEM base case: held-out Psi drag {:.3}, lift {:.3}; {:.0} % of the gap unexplained (the model's own misfit)\n",
            base.baseline_psi[0], base.baseline_psi[1], base.unexplained_pct
        );
    }
    out
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
