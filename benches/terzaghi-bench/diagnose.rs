//! `terzaghi-bench diagnose`: how long the diagnosis of a long session takes on this machine.
//!
//! It simulates the shipped six-legged robot (launch_configs/rhex.yaml) walking with a hidden
//! surcharge effect, writes the session as the robot's recording would hold it (JointState and
//! every leg's F/T, with the node parameters as metadata), then times `terzaghi diagnose` (the
//! `terzaghi` binary beside this one) on the file, every leg.

use crate::print_out;
use anyhow::{Context, Result, bail};
use clap::Args;
use std::io::BufWriter;
use std::time::Instant;
use terzaghi::sim::robot::{simulate, surcharge_walk, write_recording};

#[derive(Debug, Args)]
pub struct BenchDiagnoseArgs {
    /// Length of the session (minutes).
    #[arg(long, default_value_t = 10.0)]
    pub minutes: f64,
    /// JointState and F/T rate (Hz).
    #[arg(long, default_value_t = 1000.0)]
    pub rate_hz: f64,
    /// Keep the session file here instead of a temporary one.
    #[arg(long, value_name = "FILE.mcap")]
    pub keep: Option<std::path::PathBuf>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn run(a: BenchDiagnoseArgs) -> Result<()> {
    if !(a.minutes.is_finite() && a.minutes > 0.0 && a.minutes <= 120.0) {
        bail!("--minutes must be in (0, 120], got {}", a.minutes);
    }
    if !(a.rate_hz.is_finite() && (10.0..=10_000.0).contains(&a.rate_hz)) {
        bail!("--rate-hz must be in [10, 10000], got {}", a.rate_hz);
    }
    let (params, cfg) = terzaghi::sim::robot::rhex()?;
    let dir = std::env::temp_dir().join(format!("terzaghi-bench-diagnose-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let path = a.keep.clone().unwrap_or_else(|| dir.join("session.mcap"));
    let (truth, gait) = surcharge_walk(a.minutes * 60.0, a.rate_hz);
    let start = Instant::now();
    let session = simulate(&cfg, &truth, &gait);
    let simulate_s = start.elapsed().as_secs_f64();
    let file = std::fs::File::create(&path)
        .with_context(|| format!("cannot create {}", path.display()))?;
    let t0: i64 = 1_700_000_000_000_000_000;
    let start = Instant::now();
    let messages = write_recording(
        BufWriter::with_capacity(1 << 20, file),
        &params,
        &cfg,
        &session,
        t0,
    )?;
    let write_s = start.elapsed().as_secs_f64();
    let out = dir.join("report");
    let start = Instant::now();
    let result = std::process::Command::new(crate::terzaghi_exe()?)
        .arg("diagnose")
        .arg(&path)
        .arg("--out")
        .arg(&out)
        .arg("--json")
        .stderr(std::process::Stdio::inherit())
        .output()?;
    let diagnose_s = start.elapsed().as_secs_f64();
    if !result.status.success() {
        bail!("terzaghi diagnose failed on the benchmark session");
    }
    let reports: serde_json::Value = serde_json::from_slice(&result.stdout)?;
    let verdicts: Vec<String> = reports
        .as_array()
        .map(|legs| {
            legs.iter()
                .map(|r| {
                    format!(
                        "{} {} ({:.0} %)",
                        r["leg"].as_str().unwrap_or("?"),
                        r["verdict"]["effect"].as_str().unwrap_or("?"),
                        r["verdict"]["gap_closed_pct"].as_f64().unwrap_or(0.0)
                    )
                })
                .collect()
        })
        .unwrap_or_default();
    if a.keep.is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
    if a.json {
        let doc = serde_json::json!({
            "minutes": a.minutes,
            "legs": cfg.legs.len(),
            "rate_hz": a.rate_hz,
            "messages": messages,
            "simulate_s": simulate_s,
            "write_s": write_s,
            "diagnose_s": diagnose_s,
            "hidden": "surcharge",
            "verdicts": reports.as_array().map(|l| l.iter().map(|r| r["verdict"]["effect"].clone()).collect::<Vec<_>>()),
        });
        return print_out(&(serde_json::to_string_pretty(&doc)? + "\n"));
    }
    print_out(&format!(
        "session: {} min, {} legs, JointState and F/T at {} Hz: {} messages, hidden effect surcharge\n\
         simulated in {:.1} s, written in {:.1} s\n\
         terzaghi diagnose (every leg): {:.1} s\n\
         verdicts: {}\n",
        a.minutes,
        cfg.legs.len(),
        a.rate_hz,
        messages,
        simulate_s,
        write_s,
        diagnose_s,
        verdicts.join(", ")
    ))
}
