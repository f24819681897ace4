//! `terzaghi info` and `terzaghi recover`: looking into and mending MCAP sessions.

use super::print_out;
use anyhow::{Context, Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;
use terzaghi::record::{read::scan, recover};
use terzaghi::session::files::read_file;
use terzaghi::session::refuse_cut_off;

#[derive(Debug, Args)]
pub struct InfoArgs {
    /// An MCAP file.
    pub file: PathBuf,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Args)]
pub struct RecoverArgs {
    /// A (possibly cut-off) MCAP file.
    pub input: PathBuf,
    /// Where to write the mended file (an existing file is refused).
    #[arg(short, long, value_name = "FIXED.mcap")]
    pub output: PathBuf,
    /// Replace the output file if it exists.
    #[arg(long)]
    pub overwrite: bool,
}

/// A progress bar on stderr when it is a terminal, hidden otherwise.
pub fn progress(len: u64, what: &str) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(len);
    pb.set_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} ({per_sec}, {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_message(what.to_string());
    pb
}

#[derive(serde::Serialize)]
struct TopicJson<'a> {
    topic: &'a str,
    r#type: &'a str,
    encoding: &'a str,
    messages: u64,
}

pub fn info(a: InfoArgs) -> Result<()> {
    let bytes = read_file(&a.file)?;
    let s = scan(&bytes, |_, _| {}).with_context(|| a.file.display().to_string())?;
    if a.json {
        let topics: Vec<TopicJson> = s
            .topics
            .iter()
            .map(|t| TopicJson {
                topic: &t.topic,
                r#type: &t.type_name,
                encoding: &t.encoding,
                messages: t.count,
            })
            .collect();
        let v = serde_json::json!({
            "file": a.file.display().to_string(),
            "messages": s.messages,
            "duration_s": s.duration_s(),
            "start_ns": s.start_ns,
            "end_ns": s.end_ns,
            "complete": s.complete,
            "stopped": s.stopped,
            "topics": topics,
            "metadata": s.metadata.keys().collect::<Vec<_>>(),
        });
        print_out(&(serde_json::to_string_pretty(&v)? + "\n"))?;
        // After its summary, a cut-off file is an error, so that a script sees it.
        return refuse_cut_off(&a.file, &s);
    }
    let mut out = format!(
        "file:      {}\nmessages:  {}\nduration:  {:.3} s\ncomplete:  {}\n",
        a.file.display(),
        s.messages,
        s.duration_s(),
        if s.complete {
            "yes".to_string()
        } else {
            format!(
                "no ({}): `terzaghi recover` writes a valid copy",
                s.stopped
                    .as_deref()
                    .unwrap_or("no summary or end magic: cut off")
            )
        }
    );
    if !s.metadata.is_empty() {
        out += &format!(
            "metadata:  {}\n",
            s.metadata.keys().cloned().collect::<Vec<_>>().join(", ")
        );
    }
    out += &format!("\n{:<40} {:<36} {:>10}\n", "topic", "type", "messages");
    for t in &s.topics {
        out += &format!("{:<40} {:<36} {:>10}\n", t.topic, t.type_name, t.count);
    }
    print_out(&out)?;
    refuse_cut_off(&a.file, &s)
}

pub fn recover_cmd(a: RecoverArgs) -> Result<()> {
    terzaghi::session::files::refuse_output_over_input(&a.output, &[&a.input])?;
    terzaghi::session::files::refuse_existing_recording(&a.output, a.overwrite)?;
    let bytes = read_file(&a.input)?;
    let pb = progress(0, "recovering");
    let mut result = None;
    terzaghi::session::files::write_atomically(&a.output, |w| {
        let (_, r) = recover(&bytes, w, |n| {
            pb.set_position(n);
        })
        .with_context(|| a.input.display().to_string())?;
        result = Some(r);
        Ok(())
    })?;
    pb.finish_and_clear();
    let Some(r) = result else {
        bail!("nothing recovered")
    };
    print_out(&format!(
        "kept {} messages on {} topics from {} ({}); wrote {}\n",
        r.messages,
        r.topics,
        a.input.display(),
        if r.input_complete {
            "it was complete".to_string()
        } else {
            format!(
                "cut off: {}",
                r.stopped.unwrap_or_else(|| "no summary".into())
            )
        },
        a.output.display()
    ))
}
