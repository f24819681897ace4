//! Operations on a whole session on disk, as a user runs them: re-evaluate a recording through
//! the model and the estimator ([`reevaluate`]), diagnose the gap of its legs ([`diagnose`]),
//! identify a leg's medium from it ([`identify`]); with the writers of their results beside
//! them (CSV and MCAP in [`reevaluate`], JSON and HTML in [`diagnose`] and `report_html`).
//! Each takes typed options and returns a value; the command line only parses flags and
//! prints.
//!
//! A session is a ROS 2 MCAP file (recorded by `terzaghi node` or any ROS 2 tool) or, for one
//! leg, a CSV log of `t_s,beta_rad,drag_n,lift_n` ([`legs`]).
//!
//! Re-evaluating and diagnosing a recording through the library (the example of
//! `docs/command-line.md`):
//!
//! ```
//! use std::path::Path;
//! use terzaghi::session::diagnose::{DiagnoseFileOptions, diagnose_file, write_reports};
//! use terzaghi::session::reevaluate::{ReevaluateOptions, reevaluate_file};
//!
//! /// Re-evaluates a recording with its recorded parameters, then diagnoses its legs.
//! fn check(log: &Path, out: &Path) -> anyhow::Result<()> {
//!     // Every prediction next to its measurement.
//!     let mut worst_drag_n = 0.0f64;
//!     let done = reevaluate_file(log, ReevaluateOptions::default(), |row| {
//!         if let Some(drag_n) = row.measured_drag_n {
//!             worst_drag_n = worst_drag_n.max((row.predicted_drag_n - drag_n).abs());
//!         }
//!     })?;
//!     println!("{} rows; largest drag error {worst_drag_n:.1} N", done.summary.rows);
//!     // The gap of every leg with F/T; report.json and report.html of each in `out`.
//!     let diagnosed = diagnose_file(log, &DiagnoseFileOptions::default())?;
//!     for leg in &diagnosed.legs {
//!         match &leg.result {
//!             Ok(d) => println!("{}: {}", leg.leg, d.report.verdict.effect),
//!             Err(e) => println!("{}: not diagnosed: {e}", leg.leg),
//!         }
//!     }
//!     write_reports(&diagnosed, out)?;
//!     Ok(())
//! }
//! # fn main() -> anyhow::Result<()> {
//! # use terzaghi::sim::robot::{Gait, Truth, rhex, simulate, write_recording};
//! # let dir = tempfile::tempdir()?;
//! # let log = dir.path().join("walk.mcap");
//! # let (params, cfg) = rhex()?;
//! # let truth = Truth { b_k: 30.0, a: 2.2, effects: vec![], magnitude: 0.0, noise_frac: 0.015, rft_scale: 1.0 };
//! # let gait = Gait { seconds: 20.0, rate_hz: 200.0, mean_speed_rad_s: 4.0, seed: 3 };
//! # let walk = simulate(&cfg, &truth, &gait);
//! # write_recording(std::fs::File::create(&log)?, &params, &cfg, &walk, 1_700_000_000_000_000_000)?;
//! check(&log, &dir.path().join("diagnosis"))?;
//! # assert!(dir.path().join("diagnosis/front_left/report.json").exists());
//! # Ok(())
//! # }
//! ```

pub mod calibration_html;
pub mod csv_rows;
mod refusal;
pub use crate::error::{Failure, NotBorne};
pub use refusal::Refusal;
pub mod diagnose;
pub mod files;
pub mod identify;
pub mod inputs;
pub mod intrusion_test;
pub mod legs;
pub mod plate_export;
pub mod plate_test;
#[cfg(feature = "node")]
pub mod record;
pub mod reevaluate;
#[cfg(feature = "node")]
pub mod replay;
pub(crate) mod report_html;
pub mod slip_sweep;
pub mod steady;
pub mod topics;
pub mod wheel_test;

use crate::record::read::{IndexedFile, Scan, Source, scan};
use anyhow::{Context as _, Result};
use std::path::Path;

/// An MCAP session opened for reading: a finished file by its summary (its chunks are read as
/// they are wanted), a cut-off one whole.
pub struct Opened {
    indexed: Option<IndexedFile>,
    whole: Vec<u8>,
    head: Scan,
}

/// An error, with the command that mends it, when the scanned file is cut off (it has no
/// summary): every command that reads a session whole refuses one (exit 2).
pub fn refuse_cut_off(file: &Path, head: &Scan) -> Result<()> {
    if !head.complete {
        anyhow::bail!(
            "{} is cut off ({}): recover it first with `terzaghi recover {} -o FIXED.mcap`",
            file.display(),
            head.stopped.as_deref().unwrap_or("no footer"),
            file.display()
        );
    }
    Ok(())
}

impl Opened {
    /// Opens `path`; `None` when it is not an MCAP file.
    pub fn mcap(path: &Path) -> Result<Option<Opened>> {
        // Told by its first bytes, so that a CSV log is not read here as well.
        if !files::is_mcap(path)? {
            return Ok(None);
        }
        let indexed =
            IndexedFile::open(path).with_context(|| format!("cannot read {}", path.display()))?;
        if let Some(f) = indexed {
            let head = f.head().clone();
            return Ok(Some(Opened {
                indexed: Some(f),
                whole: Vec::new(),
                head,
            }));
        }
        let whole = files::read_file(path)?;
        // Cut off (no summary): scanned for its topics and parameters.
        let head = scan(&whole, |_, _| {}).with_context(|| path.display().to_string())?;
        Ok(Some(Opened {
            indexed: None,
            whole,
            head,
        }))
    }

    /// An error, with the command that mends it, when the file is cut off (it has no summary);
    /// what is read from a session is read from a complete one.
    pub fn refuse_cut_off(&self, file: &Path) -> Result<()> {
        refuse_cut_off(file, &self.head)
    }

    /// Topics, counts, metadata and whether the file is complete.
    pub fn head(&self) -> &Scan {
        &self.head
    }

    /// The messages, for [`crate::record::read::scan_topics`].
    pub fn source(&self) -> Source<'_> {
        match &self.indexed {
            Some(f) => f.into(),
            None => (&self.whole).into(),
        }
    }
}
