//! The gap of a plate-sinkage test (or a leg pushed straight down) against a calibrated
//! medium: the sensor's own habits (its update rate and hold, from repeated values and the
//! spacing of changes), a bias on the force, the surface's level, and the medium's scale,
//! fitted together over the rows where the law holds (the plate loading, and above the surface
//! before it); and where the gap lies in the terms of the motion: depth and speed.

use super::context::median;
use super::signatures::median_step;
use crate::ident::metrics::component_fit;
use crate::ident::sinkage::least_squares;
use crate::model::sinkage::{PlateShape, SinkageModel, SinkageRegime};
use nalgebra::DVector;
use serde::Serialize;

/// A row of a test, with its regime (from the rig's motion).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TestSample {
    /// Time (s).
    pub t_s: f64,
    /// Sinkage (m; negative above the surface).
    pub depth_m: f64,
    /// Measured upward force (N).
    pub force_n: f64,
    /// Its regime.
    pub regime: SinkageRegime,
}

/// How the sensor delivers its values.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SensorHabits {
    /// Rows of the log.
    pub rows: usize,
    /// Rows whose value differs from the row before.
    pub changes: usize,
    /// The rate of the log's rows (Hz; median spacing).
    pub stream_rate_hz: f64,
    /// The rate at which the value changes (Hz; the mean spacing of changes, gaps of three
    /// times the median left out): the sensor's effective sample rate.
    pub update_rate_hz: f64,
    /// How long a value is held (s): the mean spacing of changes.
    pub hold_s: f64,
    /// Rows per held value (1: no hold).
    pub rows_per_value: f64,
}

/// The sensor's habits from a log's times and values; `None` with fewer than three changes.
pub fn sensor_habits(t_s: &[f64], value: &[f64]) -> Option<SensorHabits> {
    let n = t_s.len().min(value.len());
    let mut change_t = Vec::new();
    for i in 1..n {
        if value[i] != value[i - 1] && value[i].is_finite() && t_s[i].is_finite() {
            change_t.push(t_s[i]);
        }
    }
    if change_t.len() < 3 {
        return None;
    }
    let stream = median_step(&t_s[..n]);
    // The mean spacing of changes, leaving out gaps (three times the median or more, where the
    // value truly stood still): a stream's rows quantise each spacing, their mean does not.
    let spacings: Vec<f64> = change_t.windows(2).map(|w| w[1] - w[0]).collect();
    let typical = median(&spacings);
    let kept: Vec<f64> = spacings
        .into_iter()
        .filter(|d| *d < 3.0 * typical)
        .collect();
    let hold = kept.iter().sum::<f64>() / kept.len().max(1) as f64;
    Some(SensorHabits {
        rows: n,
        changes: change_t.len(),
        stream_rate_hz: 1.0 / stream,
        update_rate_hz: 1.0 / hold,
        hold_s: hold,
        rows_per_value: hold / stream,
    })
}

/// A value fitted with its standard deviation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Fitted {
    /// The value.
    pub value: f64,
    /// One standard deviation.
    pub std_dev: f64,
}

/// The mean gap of the force over a band of depth or speed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GapBand {
    /// From (mm, or mm/s).
    pub from: f64,
    /// To (mm, or mm/s).
    pub to: f64,
    /// Rows in the band.
    pub rows: usize,
    /// Mean of measured minus predicted (N), with the medium as calibrated.
    pub mean_gap_n: f64,
}

/// What the test's gap comes from.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SinkageDiagnosis {
    /// Rows of the test, and rows the fit used (loading, and above the surface).
    pub rows: usize,
    /// Rows the fit used.
    pub rows_used: usize,
    /// The sensor's habits, if the force changes often enough to tell.
    pub sensor: Option<SensorHabits>,
    /// A constant added to the force (N): the sensor's offset against the tare the log used.
    pub bias_n: Fitted,
    /// How far the surface lies above the depth's zero (m): a depth told `d` too deep reads
    /// `-d`, the depth to add to the log's.
    pub depth_shift_m: Fitted,
    /// The medium's scale against the calibrated law (1: as calibrated).
    pub scale: Fitted,
    /// R^2 and RMSE (N) of the loaded rows with the medium as calibrated.
    pub r2_as_calibrated: f64,
    /// RMSE as calibrated (N).
    pub rmse_as_calibrated_n: f64,
    /// R^2 with the bias, surface and scale fitted.
    pub r2_corrected: f64,
    /// RMSE with them (N).
    pub rmse_corrected_n: f64,
    /// The gap as calibrated, by depth (mm).
    pub gap_by_depth: Vec<GapBand>,
    /// The gap as calibrated, by downward speed (mm/s).
    pub gap_by_speed: Vec<GapBand>,
}

/// Why a test could not be diagnosed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SinkageDiagnosisError {
    /// Too little to judge.
    #[error(
        "too little to judge: {loaded} loaded rows and {above} above the surface (need at least {needed} loaded and 3 above)"
    )]
    TooLittle {
        /// Loaded rows.
        loaded: usize,
        /// Rows above the surface before loading.
        above: usize,
        /// Loaded rows needed.
        needed: usize,
    },
}

/// Loaded rows a diagnosis needs.
pub const MIN_LOADED_ROWS: usize = 12;

fn bands(values: &[(f64, f64)], count: usize) -> Vec<GapBand> {
    if values.is_empty() {
        return Vec::new();
    }
    let mut keys: Vec<f64> = values.iter().map(|v| v.0).collect();
    keys.sort_by(f64::total_cmp);
    let edges: Vec<f64> = (0..=count)
        .map(|k| keys[((keys.len() - 1) * k) / count])
        .collect();
    (0..count)
        .filter_map(|k| {
            let (lo, hi) = (edges[k], edges[k + 1]);
            let inside: Vec<f64> = values
                .iter()
                .filter(|v| v.0 >= lo && (v.0 < hi || (k == count - 1 && v.0 <= hi)))
                .map(|v| v.1)
                .collect();
            (!inside.is_empty()).then(|| GapBand {
                from: lo,
                to: hi,
                rows: inside.len(),
                mean_gap_n: inside.iter().sum::<f64>() / inside.len() as f64,
            })
        })
        .collect()
}

/// Diagnoses a test of `plate` against `model`: fits `F = scale law(z + shift) + bias` over
/// the loading rows and the rows above the surface before an intrusion's loading (a log may
/// hold any number of intrusions), and bands the
/// calibrated model's gap by depth and speed.
pub fn diagnose_sinkage(
    model: &SinkageModel,
    plate: &PlateShape,
    samples: &[TestSample],
) -> Result<SinkageDiagnosis, SinkageDiagnosisError> {
    // Above the surface before an intrusion's loading (not on the way out of the last, where
    // sand the plate lifts may weigh on it).
    let last_loading = samples
        .iter()
        .rposition(|s| s.regime == SinkageRegime::Loading)
        .unwrap_or(0);
    let used: Vec<TestSample> = samples
        .iter()
        .enumerate()
        .filter(|(i, s)| {
            s.depth_m.is_finite()
                && s.force_n.is_finite()
                && (s.regime == SinkageRegime::Loading
                    || (s.regime == SinkageRegime::Above && *i < last_loading))
        })
        .map(|(_, s)| *s)
        .collect();
    let loaded = used
        .iter()
        .filter(|s| s.regime == SinkageRegime::Loading)
        .count();
    let above = used.len() - loaded;
    if loaded < MIN_LOADED_ROWS || above < 3 {
        return Err(SinkageDiagnosisError::TooLittle {
            loaded,
            above,
            needed: MIN_LOADED_ROWS,
        });
    }
    // params: scale, shift (mm, for conditioning), bias (N).
    let predict = |p: &[f64], z: f64| p[0] * model.force_n(plate, z + p[1] * 1e-3) + p[2];
    let residuals = |p: &[f64]| {
        DVector::from_iterator(
            used.len(),
            used.iter().map(|s| s.force_n - predict(p, s.depth_m)),
        )
    };
    // Start from the calibrated medium, the bias from the rows above.
    let bias0 = used
        .iter()
        .filter(|s| s.regime == SinkageRegime::Above)
        .map(|s| s.force_n)
        .sum::<f64>()
        / above as f64;
    // The surface's level is not convex in the residuals: start from a few shifts.
    let best = [-10.0, -5.0, 0.0, 5.0, 10.0]
        .map(|shift_mm| least_squares(vec![1.0, shift_mm, bias0], &[0, 1, 2], 1e-3, &residuals))
        .into_iter()
        .filter(|f| f.cost.is_finite())
        .min_by(|a, b| a.cost.total_cmp(&b.cost));
    let (p, sd) = match best {
        Some(f) => (f.params, f.std_dev),
        None => (vec![1.0, 0.0, bias0], vec![f64::NAN; 3]),
    };
    let sd = |k: usize| sd[k];
    let loaded_rows: Vec<&TestSample> = samples
        .iter()
        .filter(|s| s.regime == SinkageRegime::Loading && s.force_n.is_finite())
        .collect();
    let measured: Vec<f64> = loaded_rows.iter().map(|s| s.force_n).collect();
    let as_calibrated: Vec<f64> = loaded_rows
        .iter()
        .map(|s| model.force_n(plate, s.depth_m))
        .collect();
    let corrected: Vec<f64> = loaded_rows.iter().map(|s| predict(&p, s.depth_m)).collect();
    let (before, after) = (
        component_fit(&as_calibrated, &measured),
        component_fit(&corrected, &measured),
    );
    // Speeds on the rows' own timeline.
    let mut by_depth = Vec::new();
    let mut by_speed = Vec::new();
    for (i, s) in samples.iter().enumerate() {
        if s.regime != SinkageRegime::Loading {
            continue;
        }
        let gap = s.force_n - model.force_n(plate, s.depth_m);
        by_depth.push((s.depth_m * 1e3, gap));
        let (a, b) = (i.saturating_sub(1), (i + 1).min(samples.len() - 1));
        let dt = samples[b].t_s - samples[a].t_s;
        if dt > 0.0 {
            by_speed.push(((samples[b].depth_m - samples[a].depth_m) / dt * 1e3, gap));
        }
    }
    Ok(SinkageDiagnosis {
        rows: samples.len(),
        rows_used: used.len(),
        sensor: sensor_habits(
            &samples.iter().map(|s| s.t_s).collect::<Vec<_>>(),
            &samples.iter().map(|s| s.force_n).collect::<Vec<_>>(),
        ),
        bias_n: Fitted {
            value: p[2],
            std_dev: sd(2),
        },
        depth_shift_m: Fitted {
            value: p[1] * 1e-3,
            std_dev: sd(1) * 1e-3,
        },
        scale: Fitted {
            value: p[0],
            std_dev: sd(0),
        },
        r2_as_calibrated: before.r2,
        rmse_as_calibrated_n: before.rmse,
        r2_corrected: after.r2,
        rmse_corrected_n: after.rmse,
        gap_by_depth: bands(&by_depth, 4),
        gap_by_speed: bands(&by_speed, 3),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::sinkage::{RegimeOptions, SinkageLaw, sinkage_regimes};

    /// A test at 12 Hz with a hold: 0.5 s above, down at 5 mm/s to 30 mm, with `bias_n` on the
    /// force and the depth logged `told_m` too deep.
    fn test(model: &SinkageModel, plate: &PlateShape, bias_n: f64, told_m: f64) -> Vec<TestSample> {
        let mut rows = Vec::new();
        let mut t: f64 = 0.0;
        while t < 9.0 {
            let z = -0.01 + 0.005 * t;
            // The sensor updates every 85 ms and holds its value between.
            let t_held = (t / 0.085).floor() * 0.085;
            let z_held = -0.01 + 0.005 * t_held;
            rows.push((t, z + told_m, model.force_n(plate, z_held) + bias_n));
            t += 0.01;
        }
        let pairs: Vec<(f64, f64)> = rows.iter().map(|r| (r.0, r.1)).collect();
        let regimes = sinkage_regimes(&pairs, &RegimeOptions::default());
        rows.iter()
            .zip(regimes)
            .map(|(r, regime)| TestSample {
                t_s: r.0,
                depth_m: r.1,
                force_n: r.2,
                regime,
            })
            .collect()
    }

    /// The power law of the shared runs' sand, about.
    fn medium() -> SinkageModel {
        SinkageModel::new(
            SinkageLaw::DepthWidthPower,
            vec![2800.0, 1.29, 1.0],
            13e3,
            0.25,
        )
        .unwrap()
    }

    #[test]
    fn a_bias_a_wrong_surface_and_the_hold_are_found() {
        let model = medium();
        let plate = PlateShape::disc(0.08).unwrap();
        let d = diagnose_sinkage(&model, &plate, &test(&model, &plate, 1.5, 0.008)).unwrap();
        assert!((d.bias_n.value - 1.5).abs() < 0.15, "{:?}", d.bias_n);
        assert!(
            (d.depth_shift_m.value + 0.008).abs() < 0.002,
            "{:?}",
            d.depth_shift_m
        );
        assert!((d.scale.value - 1.0).abs() < 0.1, "{:?}", d.scale);
        let s = d.sensor.unwrap();
        assert!((s.update_rate_hz - 1.0 / 0.085).abs() < 0.5, "{s:?}");
        assert!((s.stream_rate_hz - 100.0).abs() < 1.0, "{s:?}");
        assert!(d.r2_corrected > 0.99 && d.r2_as_calibrated < d.r2_corrected);
        // Nothing wrong: nothing found.
        let d = diagnose_sinkage(&model, &plate, &test(&model, &plate, 0.0, 0.0)).unwrap();
        assert!(
            d.bias_n.value.abs() < 0.15 && d.depth_shift_m.value.abs() < 0.001,
            "{d:?}"
        );
    }

    #[test]
    fn too_little_is_said() {
        let model = medium();
        let plate = PlateShape::disc(0.08).unwrap();
        let rows = test(&model, &plate, 0.0, 0.0);
        let e = diagnose_sinkage(&model, &plate, &rows[..205]).unwrap_err();
        assert!(e.to_string().starts_with("too little to judge"), "{e}");
    }
}
