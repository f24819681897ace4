//! `terzaghi replay`: republish a session over DDS with its recorded timing (like `ros2 bag
//! play`), or re-evaluate it offline through the model and the estimator (`--reevaluate`).

use super::mcap_tools::progress;
use anyhow::{Result, anyhow, bail};
use clap::Args;
use std::path::PathBuf;
use terzaghi::session::files::write_atomically;
use terzaghi::session::reevaluate::{
    ReevaluateOptions, Reevaluation, reevaluate_to_csv, reevaluate_to_mcap,
};
use terzaghi::session::replay::{ReplayOptions, replay};

#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// The MCAP session (ours, or any ROS 2 MCAP with JointState and WrenchStamped); with
    /// --reevaluate --params-file, also a CSV log of one leg (t_s,beta_rad,drag_n,lift_n, as
    /// diagnose and fit read).
    pub file: PathBuf,
    /// Run the recorded joint states and F/T through the model and estimator offline, as fast as
    /// possible, instead of republishing.
    #[arg(long)]
    pub reevaluate: bool,
    /// --reevaluate: node parameters to use instead of the recorded ones.
    #[arg(long, value_name = "FILE")]
    pub params_file: Option<PathBuf>,
    /// --reevaluate: set a node parameter over the recorded ones (or the file's), as the node's
    /// `-p name:=value` does; repeatable. `-p leg.hip_frame:=` clears one.
    #[arg(short = 'p', long = "param", value_name = "NAME:=VALUE")]
    pub params: Vec<String>,
    /// --reevaluate: write to this file, .mcap (inputs and new outputs) or .csv (predictions next
    /// to measurements); default: CSV on standard output when it is a pipe or a file (a
    /// terminal gets the summary alone).
    #[arg(short, long, value_name = "OUT")]
    pub output: Option<PathBuf>,
    /// --reevaluate -o OUT.mcap: replace OUT.mcap if it exists (an existing recording is
    /// refused; a CSV output is replaced).
    #[arg(long)]
    pub overwrite: bool,
    /// --reevaluate: also print each leg's error stroke by stroke (a stroke: a full turn of the
    /// leg, counted from its first sample, as diagnose counts them).
    #[arg(long, requires = "reevaluate")]
    pub per_stroke: bool,
    /// Replay speed factor.
    #[arg(long, default_value_t = 1.0, conflicts_with = "as_fast_as_possible")]
    pub rate: f64,
    /// Replay without waiting.
    #[arg(long)]
    pub as_fast_as_possible: bool,
    /// Replay only these topics.
    #[arg(long, num_args = 1..)]
    pub topics: Vec<String>,
    /// Start again at the end, until interrupted.
    #[arg(long = "loop")]
    pub repeat: bool,
    /// Publish /clock (rosgraph_msgs/Clock) with the recording's time at HZ (default 40), as
    /// `ros2 bag play --clock` does: nodes with use_sim_time follow it.
    #[arg(long, value_name = "HZ", num_args = 0..=1, default_missing_value = "40")]
    pub clock: Option<f64>,
}

pub fn run(a: ReplayArgs) -> Result<()> {
    if a.reevaluate && a.clock.is_some() {
        bail!("--clock goes with replaying over DDS, not with --reevaluate");
    }
    if a.reevaluate {
        return run_reevaluate(&a);
    }
    if a.params_file.is_some() || a.output.is_some() || !a.params.is_empty() {
        bail!("--params-file, --param and --output go with --reevaluate");
    }
    if !(a.rate.is_finite() && a.rate > 0.0) {
        bail!("--rate must be a positive number, got {}", a.rate);
    }
    run_dds(&a)
}

/// A cut-off recording is refused before anything is replayed or written: `terzaghi recover`
/// mends it first (exit 2, as diagnose).
fn refuse_cut_off(file: &std::path::Path) -> Result<()> {
    if let Some(opened) = terzaghi::session::Opened::mcap(file)? {
        opened.refuse_cut_off(file)?;
    }
    Ok(())
}

fn run_reevaluate(a: &ReplayArgs) -> Result<()> {
    refuse_cut_off(&a.file)?;
    let inputs: Vec<&std::path::Path> = std::iter::once(a.file.as_path())
        .chain(a.params_file.as_deref())
        .collect();
    match &a.output {
        Some(out) => terzaghi::session::files::refuse_output_over_input(out, &inputs)?,
        None => terzaghi::session::files::refuse_stdout_over_input(&inputs)?,
    }
    let params = a
        .params
        .iter()
        .map(|p| match p.split_once(":=") {
            Some((name, value)) if !name.is_empty() => {
                Ok((name.to_string(), terzaghi::config::parse_value(value)))
            }
            _ => Err(anyhow::anyhow!(
                "--param {p:?}: expected NAME:=VALUE, e.g. -p leg.hip_frame:=leg_hip"
            )),
        })
        .collect::<Result<Vec<_>>>()?;
    let pb = progress(0, "re-evaluating");
    let opts = || {
        let pb = pb.clone();
        ReevaluateOptions {
            params_file: a.params_file.clone(),
            params: params.clone(),
            progress: Some(Box::new(move |n, total| {
                pb.set_length(total);
                pb.set_position(n);
            })),
        }
    };
    let out_kind = a
        .output
        .as_ref()
        .and_then(|p| p.extension())
        .and_then(|e| e.to_str())
        .map(str::to_lowercase);
    let mut rows_held = false;
    let done: Reevaluation = match (out_kind.as_deref(), &a.output) {
        (Some("mcap"), Some(path)) => reevaluate_to_mcap(&a.file, path, a.overwrite, opts())?,
        (Some("csv") | None, Some(path)) => {
            let mut result = None;
            write_atomically(path, |w| {
                result = Some(reevaluate_to_csv(&a.file, opts(), w)?);
                Ok(())
            })?;
            result.ok_or_else(|| anyhow!("nothing re-evaluated"))?
        }
        // A terminal gets the summary: a session's rows (hundreds of thousands) are for a file
        // (-o) or a pipe.
        (None, None) if std::io::IsTerminal::is_terminal(&std::io::stdout()) => {
            rows_held = true;
            reevaluate_to_csv(&a.file, opts(), &mut std::io::sink())?
        }
        (None, None) => {
            let mut stdout = std::io::BufWriter::new(std::io::stdout());
            match reevaluate_to_csv(&a.file, opts(), &mut stdout) {
                Ok(s) => s,
                // A reader that stopped early (`| head`) is not an error.
                Err(e)
                    if e.chain().any(|c| {
                        c.downcast_ref::<std::io::Error>()
                            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
                    }) =>
                {
                    return Ok(());
                }
                Err(e) => return Err(e),
            }
        }
        (other, _) => bail!(
            "--output: unknown kind .{}: use .mcap or .csv",
            other.unwrap_or("")
        ),
    };
    pb.finish_and_clear();
    let summary = &done.summary;
    if !summary.skipped_topics.is_empty() {
        eprintln!(
            "note: topics not used by this configuration, skipped: {}",
            summary.skipped_topics.join(", ")
        );
    }
    if summary.undecodable > 0 {
        eprintln!(
            "note: {} messages did not decode and were skipped",
            summary.undecodable
        );
    }
    if !summary.complete {
        eprintln!(
            "note: {} is cut off ({}); re-evaluated what it holds",
            a.file.display(),
            summary.stopped.as_deref().unwrap_or("no summary")
        );
    }
    done.check_inputs_found(&a.file)?;
    if rows_held {
        eprintln!(
            "note: the rows (one per prediction) are not printed to a terminal: -o OUT.csv or -o OUT.mcap writes them, or pipe the output"
        );
    }
    let est: Vec<String> = summary
        .estimates
        .iter()
        .zip(&done.config.legs)
        .enumerate()
        .filter_map(|(i, (e, l))| {
            let learnt_surface = summary.surfaces.get(i).copied().flatten();
            e.map(|e| {
                // An RFT leg learns RFT's scale (its estimate's b_k), a sinkage leg its law's.
                if done.config.model == terzaghi::config::ModelKind::Sinkage {
                    // Its surface, learnt with the scale, in millimetres.
                    let surface = learnt_surface.map_or(String::new(), |s| {
                        format!(
                            ", surface {:+.2} +- {:.2} mm",
                            s.offset_m * 1e3,
                            s.std_offset_m * 1e3
                        )
                    });
                    format!(
                        "{}: scale {:.4} +- {:.4} of the medium file's law{surface} (converged: {}, changes detected: {})",
                        l.name, e.b_k, e.std_b_k, e.converged, e.changes_detected
                    )
                } else if done.config.model == terzaghi::config::ModelKind::Rft && l.rft.is_some() {
                    format!(
                        "{}: rft_scale {:.4} +- {:.4} (converged: {})",
                        l.name, e.b_k, e.std_b_k, e.converged
                    )
                } else {
                    let surface = learnt_surface.map_or(String::new(), |s| {
                        format!(
                            ", surface {:+.4} +- {:.4} m (converged: {})",
                            s.offset_m, s.std_offset_m, s.converged
                        )
                    });
                    format!(
                        "{}: b_k {:.4} a {:.4} (converged: {}){surface}",
                        l.name, e.b_k, e.a, e.converged
                    )
                }
            })
        })
        .collect();
    eprintln!(
        "re-evaluated {} joint states and {} F/T samples into {} rows{}{}",
        summary.joint_states,
        summary.ft_samples,
        summary.rows,
        if est.is_empty() {
            String::new()
        } else {
            "; final estimates: ".to_string()
        },
        est.join("; ")
    );
    if summary.skipped_samples > 0 {
        eprintln!(
            "note: {} samples of the CSV log had no usable time and were skipped",
            summary.skipped_samples
        );
    }
    eprint!("{}", error_table(&done, a.per_stroke));
    Ok(())
}

/// Each leg's prediction error against its measurements: the expected F/T reading (with the
/// leg's corrections, where it has them) and the bare model; with `per_stroke`, the expected
/// reading's stroke by stroke too.
fn error_table(done: &Reevaluation, per_stroke: bool) -> String {
    use terzaghi::session::reevaluate::RowErrors;
    let mut out = String::new();
    for (i, (l, e)) in done
        .config
        .legs
        .iter()
        .zip(&done.summary.errors)
        .enumerate()
    {
        if e.samples() == 0 {
            continue;
        }
        let (d, li) = (e.expected[0].fit(), e.expected[1].fit());
        out += &format!(
            "{}: RMSE {:.3} N (R^2 drag {:.3}, lift {:.3}) over {} samples",
            l.name,
            RowErrors::rmse_n(&e.expected),
            d.r2,
            li.r2,
            e.samples()
        );
        if e.unloading_rows > 0 {
            out += &format!(
                " ({} rows held or unloading left out: the rig sets their force)",
                e.unloading_rows
            );
        }
        if let Some(c) = l.corrections.as_ref().filter(|c| !c.terms.is_empty()) {
            out += &format!(
                " with the corrections {}; bare model {:.3} N (R^2 drag {:.3}, lift {:.3})",
                c.terms
                    .iter()
                    .map(|t| t.effect.name())
                    .collect::<Vec<_>>()
                    .join(", "),
                RowErrors::rmse_n(&e.bare),
                e.bare[0].fit().r2,
                e.bare[1].fit().r2
            );
        }
        out.push('\n');
        if !per_stroke {
            continue;
        }
        let strokes = done.summary.stroke_errors.get(i).map_or(&[][..], |v| v);
        for (k, s) in strokes.iter().enumerate().filter(|(_, s)| s.samples() > 0) {
            out += &format!(
                "{} stroke {}: RMSE {:.3} N (R^2 drag {:.3}, lift {:.3}) over {} samples\n",
                l.name,
                k + 1,
                RowErrors::rmse_n(&s.expected),
                s.expected[0].fit().r2,
                s.expected[1].fit().r2,
                s.samples()
            );
        }
    }
    out
}

fn run_dds(a: &ReplayArgs) -> Result<()> {
    refuse_cut_off(&a.file)?;
    let opts = ReplayOptions {
        rate: a.rate,
        as_fast_as_possible: a.as_fast_as_possible,
        topics: a.topics.clone(),
        repeat: a.repeat,
        clock_hz: a.clock,
    };
    let pb = progress(0, "replaying");
    let rt = terzaghi::node::dds::runtime()?;
    let done = rt.block_on(replay(
        &a.file,
        &opts,
        async {
            let _ = tokio::signal::ctrl_c().await;
        },
        |n, total| {
            pb.set_length(total);
            pb.set_position(n);
        },
    ))?;
    pb.finish_and_clear();
    if !done.skipped.is_empty() {
        eprintln!(
            "note: not replayed (unknown type or encoding): {}",
            done.skipped.join(", ")
        );
    }
    eprintln!(
        "replayed {} messages ({} did not decode and were skipped)",
        done.sent, done.undecodable
    );
    Ok(())
}
