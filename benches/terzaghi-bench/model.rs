//! `terzaghi-bench model`: how long one model evaluation takes on this machine, and the ratio of RFT
//! to the improved model measured in the same run.

use crate::print_out;
use anyhow::Result;
use clap::Args;
use serde::Serialize;
use std::hint::black_box;
use std::time::{Duration, Instant};
use terzaghi::model::{
    FittingWidth, Medium, Plate, RftCoefficients, RftFit, RftModel, TerzaghiModel,
};

#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Measuring time per model (s).
    #[arg(long, default_value_t = 1.0)]
    pub seconds: f64,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Serialize)]
pub struct BenchReport {
    pub improved_median_ns: f64,
    pub improved_p90_ns: f64,
    pub rft_100_median_ns: f64,
    pub rft_100_p90_ns: f64,
    /// RFT median / improved median.
    pub ratio_rft_to_improved: f64,
    /// One online-estimator update with a penetration sample (the Gauss-Newton path).
    pub online_update_median_ns: f64,
    pub online_update_p90_ns: f64,
    pub batches: usize,
}

/// Per-call times (ns) of `f` over the angles, one entry per batch, for about `budget`.
fn time_batches(betas: &[f64], budget: Duration, mut f: impl FnMut(f64) -> f64) -> Vec<f64> {
    let mut per_call = Vec::new();
    let start = Instant::now();
    // Warm-up, then batches until the budget is spent (at least 11).
    for &b in betas {
        black_box(f(black_box(b)));
    }
    while per_call.len() < 11 || start.elapsed() < budget {
        let t = Instant::now();
        let mut acc = 0.0;
        for &b in betas {
            acc += f(black_box(b));
        }
        black_box(acc);
        per_call.push(t.elapsed().as_nanos() as f64 / betas.len() as f64);
        if per_call.len() >= 100_000 {
            break;
        }
    }
    per_call.sort_by(f64::total_cmp);
    per_call
}

fn quantile(sorted: &[f64], q: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

/// The paper's testbed plate in its sand; angles across penetration and extraction.
pub fn measure(seconds: f64) -> Result<BenchReport> {
    let plate = Plate::new(0.25, 0.06, 0.15)?;
    let improved = TerzaghiModel::new(
        plate,
        Medium::new(16170.0, 32.0, 19.0)?,
        FittingWidth::new(2.0, 1.5)?,
    );
    let rft = RftModel::new(plate, RftCoefficients::Fit(RftFit::POPPY_LP), 100)?;
    let betas: Vec<f64> = (0..256).map(|i| 0.7 + 1.7 * i as f64 / 255.0).collect();
    let budget = Duration::from_secs_f64(seconds.clamp(0.05, 60.0));
    let t_imp = time_batches(&betas, budget, |b| {
        improved
            .evaluate(b)
            .map(|f| f.drag_n + f.lift_n)
            .unwrap_or(0.0)
    });
    let t_rft = time_batches(&betas, budget, |b| {
        rft.evaluate(b).map(|f| f.drag_n + f.lift_n).unwrap_or(0.0)
    });
    let (mi, mr) = (quantile(&t_imp, 0.5), quantile(&t_rft, 0.5));
    let t_upd = time_online_updates(&improved, budget)?;
    Ok(BenchReport {
        improved_median_ns: mi,
        improved_p90_ns: quantile(&t_imp, 0.9),
        rft_100_median_ns: mr,
        rft_100_p90_ns: quantile(&t_rft, 0.9),
        ratio_rft_to_improved: mr / mi,
        online_update_median_ns: quantile(&t_upd, 0.5),
        online_update_p90_ns: quantile(&t_upd, 0.9),
        batches: t_imp.len().min(t_rft.len()),
    })
}

/// Per-update times (ns) of the online estimator fed penetration samples of the model, noisy.
fn time_online_updates(model: &TerzaghiModel, budget: Duration) -> Result<Vec<f64>> {
    use terzaghi::ident::{OnlineEstimator, OnlineOptions, Sample};
    let samples: Vec<Sample> = (0..256)
        .map(|i| {
            let beta = 0.7 + 0.85 * i as f64 / 255.0;
            let f = model
                .evaluate(beta)
                .map(|f| (f.drag_n, f.lift_n))
                .unwrap_or((0.0, 0.0));
            let wobble = 0.3 * ((i * 7919) % 13) as f64 / 13.0 - 0.15;
            Sample {
                t_s: Some(i as f64 * 1e-3),
                beta_rad: beta,
                drag_n: f.0 + wobble,
                lift_n: f.1 - wobble,
            }
        })
        .collect();
    let mut est = OnlineEstimator::new(model, OnlineOptions::default())?;
    // Past the start-up, so that every timed update takes the Gauss-Newton path.
    for s in samples.iter().cycle().take(1000) {
        let _ = est.update(s);
    }
    let mut per_call = Vec::new();
    let start = Instant::now();
    while per_call.len() < 11 || start.elapsed() < budget {
        let t = Instant::now();
        for s in &samples {
            black_box(est.update(black_box(s)).is_ok());
        }
        per_call.push(t.elapsed().as_nanos() as f64 / samples.len() as f64);
        if per_call.len() >= 100_000 {
            break;
        }
    }
    per_call.sort_by(f64::total_cmp);
    Ok(per_call)
}

pub fn run(a: BenchArgs) -> Result<()> {
    if !(a.seconds.is_finite() && a.seconds > 0.0) {
        anyhow::bail!("--seconds must be a positive number, got {}", a.seconds);
    }
    let r = measure(a.seconds)?;
    if a.json {
        return print_out(&(serde_json::to_string_pretty(&r)? + "\n"));
    }
    print_out(&format!(
        "one evaluation, plate 0.25 x 0.06 m, h = 0.15 m, 256 angles 40-137 deg, {} batches\n\
         {:<36} {:>10} {:>10}\n\
         {:<36} {:>10.1} {:>10.1}\n\
         {:<36} {:>10.1} {:>10.1}\n\
         {:<36} {:>10.1} {:>10.1}\n\
         RFT / improved (medians, same run): {:.1}x\n",
        r.batches,
        "model",
        "median ns",
        "p90 ns",
        "improved Terzaghi (constants cached)",
        r.improved_median_ns,
        r.improved_p90_ns,
        "RFT, 100 elements (poppy_lp)",
        r.rft_100_median_ns,
        r.rft_100_p90_ns,
        "online update (penetration sample)",
        r.online_update_median_ns,
        r.online_update_p90_ns,
        r.ratio_rft_to_improved
    ))
}
