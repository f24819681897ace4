//! The sand's scatter from trial to trial: plate tests of one sand, prepared again for each
//! trial, differ by a scale (the force at a depth 2-6 times from one trial to the next on a
//! hand-prepared bed) far more than by the law's shape. A law fitted to them gets its values'
//! standard deviations over the trials (a jackknife leaving one test out, beside the rows' own),
//! and the trials' own scales against it give the band a further trial of the same preparation
//! lies in ([`TrialScatter`]).
//!
//! The band is a prediction interval of the logarithm of a trial's scale: normal, its centre
//! and spread from the trials, Student's t at their degrees of freedom.

use super::sinkage::{LoadedTest, SinkageFit, SinkageFitError, fit_sinkage, trial_scale};
use crate::model::sinkage::{SinkageLaw, SinkageModel};
use serde::Serialize;

/// The share of further trials the band is to hold.
pub const BAND_LEVEL: f64 = 0.9;

/// The normal distribution's quantile at `(1 + BAND_LEVEL) / 2`.
const Z_BAND: f64 = 1.644_853_626_951_472_2;

/// Fewest degrees of freedom a band is told with.
pub const MIN_BAND_DEGREES_OF_FREEDOM: usize = 2;

/// The trials' scatter about a fitted law.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrialScatter {
    /// Trials whose own scale is known.
    pub trials: usize,
    /// The degrees of freedom the spread is told with: the trials less one, less one more where
    /// the law's width term was fitted (it takes up part of the trials' differences).
    pub degrees_of_freedom: usize,
    /// The standard deviation of the logarithm of the trials' scales.
    pub sd_ln_scale: f64,
    /// The softest trial's scale.
    pub lowest_scale: f64,
    /// The stiffest trial's scale.
    pub highest_scale: f64,
    /// The share of further trials the band holds ([`BAND_LEVEL`]).
    pub level: f64,
    /// The band's low scale: a further trial's force at a depth, over the law's.
    pub low: f64,
    /// Its high scale.
    pub high: f64,
}

impl TrialScatter {
    /// The scatter of `tests` about `model` in sample (`width_fitted`: the law's width term
    /// was fitted, and took up part of the trials' differences), or `None` where fewer than
    /// [`MIN_BAND_DEGREES_OF_FREEDOM`] degrees of freedom remain. The band widens by
    /// `sqrt(1 + 1/n)` for the law's own uncertainty in scale.
    pub fn of(model: &SinkageModel, tests: &[LoadedTest], width_fitted: bool) -> Option<Self> {
        let logs: Vec<f64> = tests
            .iter()
            .filter_map(|t| trial_scale(model, t))
            .map(f64::ln)
            .collect();
        let df = logs.len().checked_sub(1 + usize::from(width_fitted))?;
        let widen = (1.0 + 1.0 / logs.len() as f64).sqrt();
        Self::of_logs(&logs, &logs, df, widen)
    }

    /// The scatter of trials whose scales were each taken against the law fitted without them
    /// (`left_out`, logarithms): their spread is a further trial's, the law's own uncertainty
    /// in it. `in_sample`: the logarithms of the same trials' scales against the whole fit.
    pub fn of_left_out(left_out: &[f64], in_sample: &[f64]) -> Option<Self> {
        Self::of_logs(left_out, in_sample, left_out.len().checked_sub(1)?, 1.0)
    }

    fn of_logs(spread: &[f64], in_sample: &[f64], df: usize, widen: f64) -> Option<Self> {
        if df < MIN_BAND_DEGREES_OF_FREEDOM || in_sample.is_empty() {
            return None;
        }
        let n = spread.len() as f64;
        let mean = spread.iter().sum::<f64>() / n;
        let sd = (spread.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / df as f64).sqrt();
        let half = t_quantile(df) * sd * widen;
        let lowest = in_sample.iter().cloned().fold(f64::INFINITY, f64::min);
        let highest = in_sample.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        [mean, sd, half, lowest, highest]
            .iter()
            .all(|v| v.is_finite())
            .then(|| Self {
                trials: in_sample.len(),
                degrees_of_freedom: df,
                sd_ln_scale: sd,
                lowest_scale: lowest.exp(),
                highest_scale: highest.exp(),
                level: BAND_LEVEL,
                low: (mean - half).exp(),
                high: (mean + half).exp(),
            })
    }
}

/// Student's t quantile at `(1 + BAND_LEVEL) / 2` for `df` degrees of freedom, by the
/// Cornish-Fisher expansion about the normal's (Abramowitz & Stegun 26.7.5): within 0.3 % of the
/// tables from 2 degrees of freedom up.
pub fn t_quantile(df: usize) -> f64 {
    let (z, v) = (Z_BAND, df as f64);
    let g1 = (z.powi(3) + z) / 4.0;
    let g2 = (5.0 * z.powi(5) + 16.0 * z.powi(3) + 3.0 * z) / 96.0;
    let g3 = (3.0 * z.powi(7) + 19.0 * z.powi(5) + 17.0 * z.powi(3) - 15.0 * z) / 384.0;
    let g4 = (79.0 * z.powi(9) + 776.0 * z.powi(7) + 1482.0 * z.powi(5)
        - 1920.0 * z.powi(3)
        - 945.0 * z)
        / 92160.0;
    z + g1 / v + g2 / v.powi(2) + g3 / v.powi(3) + g4 / v.powi(4)
}

/// [`fit_sinkage`] with the trials taken as what they are, samples of the sand's preparation:
/// with three tests or more each free value's standard deviation is the larger of the rows' and
/// a jackknife's over the tests (each left out once, the law fitted to the others), and the
/// fit carries the trials' scatter ([`TrialScatter`]).
pub fn fit_over_trials(
    law: SinkageLaw,
    tests: &[LoadedTest],
    unit_weight_n_m3: f64,
    rft_alpha_z_n_cm3: f64,
) -> Result<SinkageFit, SinkageFitError> {
    let mut fit = fit_sinkage(law, tests, unit_weight_n_m3, rft_alpha_z_n_cm3)?;
    let n = tests.len();
    if n >= 3 {
        // Each fit leaving one test out, where every one holds what the whole fit holds.
        let left_out: Option<Vec<SinkageModel>> = (0..n)
            .map(|i| {
                let rest: Vec<LoadedTest> = tests
                    .iter()
                    .enumerate()
                    .filter(|&(k, _)| k != i)
                    .map(|(_, t)| t.clone())
                    .collect();
                fit_sinkage(law, &rest, unit_weight_n_m3, rft_alpha_z_n_cm3)
                    .ok()
                    .filter(|f| f.width_held == fit.width_held)
                    .map(|f| f.model)
            })
            .collect();
        // Each test's scale against the law fitted without it: a further trial's.
        if let Some(models) = &left_out {
            let logs: Option<Vec<f64>> = models
                .iter()
                .zip(tests)
                .map(|(m, t)| trial_scale(m, t).map(f64::ln))
                .collect();
            let in_sample: Vec<f64> = tests
                .iter()
                .filter_map(|t| trial_scale(&fit.model, t).map(f64::ln))
                .collect();
            fit.scatter = logs.and_then(|l| TrialScatter::of_left_out(&l, &in_sample));
        }
        let left_out: Option<Vec<Vec<f64>>> =
            left_out.map(|ms| ms.into_iter().map(|m| m.params).collect());
        let names = law.param_names();
        let held_width = law.width_param().map(|w| w.0).filter(|_| fit.width_held);
        for (k, name) in names.iter().enumerate() {
            let Some(values) = &left_out else { break };
            if Some(k) == held_width || fit.on_bound.iter().any(|(b, _)| b == name) {
                continue;
            }
            let mean = values.iter().map(|v| v[k]).sum::<f64>() / n as f64;
            let ss: f64 = values.iter().map(|v| (v[k] - mean).powi(2)).sum();
            let jackknife = ((n as f64 - 1.0) / n as f64 * ss).sqrt();
            let rows = fit.std_dev[k];
            if jackknife.is_finite() && (rows.is_nan() || rows < jackknife) {
                fit.std_dev[k] = jackknife;
                fit.std_dev_over_trials = true;
            }
        }
    }
    if fit.scatter.is_none() {
        let width_fitted = law.width_param().is_some() && !fit.width_held;
        fit.scatter = TrialScatter::of(&fit.model, tests, width_fitted);
    }
    Ok(fit)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::sinkage::PlateShape;
    use rand::{Rng, SeedableRng, rngs::StdRng};
    use rand_distr::{Distribution, Normal};

    /// Student's t at 0.95 from the tables.
    #[test]
    fn the_t_quantile_is_the_tables() {
        for (df, table) in [(2, 2.920), (3, 2.353), (5, 2.015), (9, 1.833), (14, 1.761)] {
            let t = t_quantile(df);
            assert!(
                (t - table).abs() < 3e-3 * table,
                "df {df}: {t} against {table}"
            );
        }
    }

    /// Trials of one depth-width law, each at its own scale (log-normal, sd `sd_ln`), on
    /// three disc sizes, `per_size` of each.
    fn trials(
        rng: &mut StdRng,
        truth: &SinkageModel,
        per_size: usize,
        sd_ln: f64,
    ) -> Vec<LoadedTest> {
        let spread = Normal::new(0.0, sd_ln).unwrap();
        let mut out = Vec::new();
        for d in [0.04, 0.06, 0.08] {
            for k in 0..per_size {
                let plate = PlateShape::disc(d).unwrap();
                let s = spread.sample(rng).exp();
                let rows = (1..=40)
                    .map(|i| {
                        let z = i as f64 * 0.5e-3;
                        let wiggle = 1.0 + 0.03 * (rng.random::<f64>() - 0.5);
                        (z, s * truth.force_n(&plate, z) * wiggle)
                    })
                    .collect();
                out.push(LoadedTest {
                    name: format!("d{d} trial {k}"),
                    plate,
                    rows,
                });
            }
        }
        out
    }

    /// Thirty sands of known scatter (sd of ln scale 0.35: the strongest trial about 3 times the
    /// softest in fifteen), each calibrated on fifteen trials: a hundred further trials of each
    /// lie in its band as often as the band says (90 %, counted over 3000), and the values'
    /// standard deviations over the trials cover the truth as a standard deviation does.
    #[test]
    fn the_band_holds_further_trials_at_its_level() {
        let truth = SinkageModel::new(
            SinkageLaw::DepthWidthPower,
            vec![2800.0, 1.3, 1.0],
            13e3,
            0.254,
        )
        .unwrap();
        let mut rng = StdRng::seed_from_u64(75);
        let (mut inside, mut further, mut k_within) = (0, 0, 0);
        for _ in 0..30 {
            let calibration = trials(&mut rng, &truth, 5, 0.35);
            let fit =
                fit_over_trials(SinkageLaw::DepthWidthPower, &calibration, 13e3, 0.254).unwrap();
            assert!(fit.std_dev_over_trials);
            let band = fit.scatter.clone().expect("fifteen trials tell a band");
            assert_eq!((band.trials, band.degrees_of_freedom), (15, 14));
            assert!(band.low < 1.0 && band.high > 1.0, "{band:?}");
            if (fit.model.params[0] - 2800.0).abs() <= fit.std_dev[0] {
                k_within += 1;
            }
            for t in trials(&mut rng, &truth, 34, 0.35).iter().take(100) {
                let s = trial_scale(&fit.model, t).unwrap();
                further += 1;
                inside += usize::from(band.low <= s && s <= band.high);
            }
        }
        let share = inside as f64 / further as f64;
        eprintln!("{inside} of {further} further trials in their sand's 90 % band");
        assert!(
            (0.86..=0.94).contains(&share),
            "{inside} of {further} in the band"
        );
        // One standard deviation holds about 68 % of the fits (30: 14 to 27 of them).
        assert!(
            (14..=27).contains(&k_within),
            "k within one sd in {k_within} of 30"
        );
    }

    /// Trials that differ by their scale alone: the rows' own standard deviation of the scale
    /// is far too small (the rows of a trial scatter little about it), the jackknife's is not.
    #[test]
    fn the_standard_deviations_see_the_trials_scatter() {
        let truth =
            SinkageModel::new(SinkageLaw::RftDepthPower, vec![4.5, 1.2], 13e3, 0.254).unwrap();
        let mut rng = StdRng::seed_from_u64(7);
        let tests = trials(&mut rng, &truth, 3, 0.3);
        let rows_only = fit_sinkage(SinkageLaw::RftDepthPower, &tests, 13e3, 0.254).unwrap();
        let over = fit_over_trials(SinkageLaw::RftDepthPower, &tests, 13e3, 0.254).unwrap();
        assert_eq!(rows_only.model, over.model);
        assert!(
            over.std_dev[0] > 5.0 * rows_only.std_dev[0],
            "{:?} against {:?}",
            over.std_dev,
            rows_only.std_dev
        );
        // Nine trials of sd 0.3: the scale's own sd about 4.5 x 0.3 / 3.
        assert!((0.2..=0.9).contains(&over.std_dev[0]), "{:?}", over.std_dev);
        let band = over.scatter.unwrap();
        assert!(band.high / band.low > 2.0, "{band:?}");
        // Two trials tell no band.
        assert!(TrialScatter::of(&over.model, &tests[..2], false).is_none());
    }
}
