//! `terzaghi simulate`: a synthetic session of one leg in continuous rotation, as CSV.

use super::{MediumArgs, PlateArgs, WidthArgs, print_out, terzaghi_model};
use anyhow::{Result, bail};
use clap::Args;
use rand::SeedableRng;
use rand::rngs::StdRng;
use std::io::Write;
use std::path::PathBuf;
use terzaghi::session::files::write_atomically;
use terzaghi::sim;

#[derive(Debug, Args)]
pub struct SimulateArgs {
    #[command(flatten)]
    pub plate: PlateArgs,
    #[command(flatten)]
    pub medium: MediumArgs,
    #[command(flatten)]
    pub width: WidthArgs,
    /// Number of full turns of the leg.
    #[arg(long, default_value_t = 10)]
    pub strokes: usize,
    /// Sample rate (Hz).
    #[arg(long, default_value_t = 250.0)]
    pub rate_hz: f64,
    /// Angular speed range MIN:MAX (rad/s); each stroke draws its speed from it.
    #[arg(long, default_value = "0.5:4")]
    pub speed_rad_s: String,
    /// Gaussian sensor noise, as a fraction of the session's peak force.
    #[arg(long, default_value_t = 0.02)]
    pub noise_frac: f64,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output CSV (t_s,beta_rad,drag_n,lift_n); default: standard output.
    #[arg(short, long, value_name = "OUT.csv")]
    pub output: Option<PathBuf>,
}

/// Most samples one call writes.
const MAX_SAMPLES: f64 = 50_000_000.0;

pub fn run(a: SimulateArgs) -> Result<()> {
    let (lo, hi) = match a.speed_rad_s.split_once(':') {
        Some((l, h)) => (l.trim().parse::<f64>().ok(), h.trim().parse::<f64>().ok()),
        None => {
            let v = a.speed_rad_s.trim().parse::<f64>().ok();
            (v, v)
        }
    };
    let (Some(lo), Some(hi)) = (lo, hi) else {
        bail!(
            "--speed-rad-s {:?}: expected MIN:MAX or one speed, in rad/s",
            a.speed_rad_s
        );
    };
    if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && hi >= lo) {
        bail!("--speed-rad-s {:?}: need 0 < MIN <= MAX", a.speed_rad_s);
    }
    if !(a.rate_hz.is_finite() && a.rate_hz > 0.0) {
        bail!("--rate-hz must be a positive number, got {}", a.rate_hz);
    }
    if a.strokes == 0 {
        bail!("--strokes must be at least 1, got 0");
    }
    if !(a.noise_frac.is_finite() && a.noise_frac >= 0.0) {
        bail!("--noise-frac must be >= 0, got {}", a.noise_frac);
    }
    let expected = a.strokes as f64 * std::f64::consts::TAU / lo * a.rate_hz;
    if expected > MAX_SAMPLES {
        bail!("that session would have about {expected:.0} samples; at most {MAX_SAMPLES:.0}");
    }
    let plate = a.plate.plate()?;
    let chosen = a.medium.medium()?;
    let model = terzaghi_model(
        plate,
        &chosen,
        Some(a.width.fitting_width(&chosen, &plate)?),
    );
    let rot = sim::Rotation {
        sample_rate_hz: a.rate_hz,
        speed_min_rad_s: lo,
        speed_max_rad_s: hi,
        start_beta_rad: 0.0,
    };
    let mut rng = StdRng::seed_from_u64(a.seed);
    let angles = sim::rotate(&rot, a.strokes, &mut rng);
    let samples = sim::measure(&angles, a.noise_frac, &mut rng, |_, b| {
        model
            .evaluate(b)
            .map(|f| (f.drag_n, f.lift_n))
            .unwrap_or((0.0, 0.0))
    });
    let text = sim::to_csv(&samples);
    match &a.output {
        Some(path) => write_atomically(path, |w| Ok(w.write_all(text.as_bytes())?)),
        None => print_out(&text),
    }
}
