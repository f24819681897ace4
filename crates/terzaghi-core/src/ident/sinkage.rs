//! Fitting a plate-sinkage law ([`crate::model::sinkage`]) to the loaded rows of one or more
//! plate-sinkage tests, with the parameters' standard deviations and each test's R^2 and RMSE:
//! the calibration of a medium from measurements.
//!
//! The fit is least squares on the logarithm of the vertical force (a relative error: a
//! granular force scatters in proportion to its size, a few newtons at 100 N, tens at 300 N),
//! over the loaded rows deeper than [`FIT_MIN_DEPTH_M`] (the top millimetres carry the
//! surface's roughness and the uncertainty of its level), by Levenberg-Marquardt from a start
//! that a log-linear fit of the pressure gives (`ln p = c + n ln z + m ln b`). R^2 and RMSE are
//! of the force itself, over every loaded row. A law's width
//! term needs at least two plate sizes: with one, it is held at its neutral value and the fit
//! says so ([`SinkageFit::width_held`]).

use super::metrics::component_fit;
use crate::model::sinkage::{PlateShape, REF_LENGTH_M, SinkageLaw, SinkageModel};
use nalgebra::{DMatrix, DVector};

/// The fit uses loaded rows deeper than this (m).
pub const FIT_MIN_DEPTH_M: f64 = 3e-3;
use serde::Serialize;

/// The loaded rows of one plate-sinkage test.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadedTest {
    /// What the test is called in tables (its file's name, say).
    pub name: String,
    /// The plate.
    pub plate: PlateShape,
    /// `(depth_m, force_n)` of each loaded row: sinkage below the surface, upward force.
    pub rows: Vec<(f64, f64)>,
}

/// How one test fits a law.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TestFit {
    /// The test's name.
    pub name: String,
    /// Its plate, in words.
    pub plate: String,
    /// Loaded rows compared.
    pub rows: usize,
    /// R^2 of the vertical force over those rows.
    pub r2: f64,
    /// RMSE of the vertical force (N).
    pub rmse_n: f64,
    /// The largest measured force (N).
    pub peak_force_n: f64,
    /// The test's own scale against the law ([`trial_scale`]): how much stiffer (above 1) or
    /// softer its sand was than the law says; `None` where it has no row deeper than
    /// [`FIT_MIN_DEPTH_M`] with a force.
    pub scale: Option<f64>,
}

/// A law fitted to tests.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SinkageFit {
    /// The law with its fitted values.
    pub model: SinkageModel,
    /// The standard deviation of each parameter, in the order of the law's parameters (0 for
    /// one held fixed).
    pub std_dev: Vec<f64>,
    /// The width term was held at its neutral value: the tests have one plate size.
    pub width_held: bool,
    /// The parameters whose best fit lay outside their physical range
    /// ([`SinkageLaw::param_ranges`]), each held at the bound it is reported with (its
    /// standard deviation 0).
    pub on_bound: Vec<(&'static str, f64)>,
    /// R^2 of the force over every test's loaded rows together.
    pub r2: f64,
    /// RMSE of the force over them (N).
    pub rmse_n: f64,
    /// Each test's own R^2 and RMSE.
    pub tests: Vec<TestFit>,
    /// The standard deviations include the spread of the values fitted leaving one test out
    /// (a jackknife over the trials, [`super::scatter::fit_over_trials`]) where that is larger
    /// than the rows' own.
    pub std_dev_over_trials: bool,
    /// The trials' scatter about the law and the band a further trial lies in, where there
    /// are enough trials to tell it ([`super::scatter::TrialScatter`]).
    pub scatter: Option<super::scatter::TrialScatter>,
}

/// Why a law could not be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SinkageFitError {
    /// Too few loaded rows with a positive depth and force.
    #[error(
        "too few loaded rows to fit {law}: {usable} with a depth > 3 mm and a force > 0 (need at least {needed})"
    )]
    TooFewRows {
        /// The law.
        law: &'static str,
        /// Rows usable.
        usable: usize,
        /// Rows needed.
        needed: usize,
    },
    /// The fit did not reach finite values.
    #[error("{law} did not converge to finite values on these tests")]
    NotConverged {
        /// The law.
        law: &'static str,
    },
}

/// How `model` fits each test, with nothing fitted.
pub fn judge(model: &SinkageModel, tests: &[LoadedTest]) -> Vec<TestFit> {
    tests
        .iter()
        .map(|t| {
            let measured: Vec<f64> = t.rows.iter().map(|r| r.1).collect();
            let predicted: Vec<f64> = t
                .rows
                .iter()
                .map(|r| model.force_n(&t.plate, r.0))
                .collect();
            let fit = component_fit(&predicted, &measured);
            TestFit {
                name: t.name.clone(),
                plate: t.plate.label(),
                rows: t.rows.len(),
                r2: fit.r2,
                rmse_n: fit.rmse,
                peak_force_n: measured.iter().cloned().fold(0.0, f64::max),
                scale: trial_scale(model, t),
            }
        })
        .collect()
}

/// A test's own scale against `model`: the geometric mean of its measured over predicted force
/// over its rows deeper than [`FIT_MIN_DEPTH_M`] with a force (the fit's rows), so that the law
/// times it fits the test best in the fit's own measure; `None` without such a row.
pub fn trial_scale(model: &SinkageModel, test: &LoadedTest) -> Option<f64> {
    let logs: Vec<f64> = test
        .rows
        .iter()
        .filter(|&&(z, f)| z.is_finite() && f.is_finite() && z > FIT_MIN_DEPTH_M && f > 0.0)
        .map(|&(z, f)| (f / model.force_n(&test.plate, z)).ln())
        .collect();
    let mean = logs.iter().sum::<f64>() / logs.len() as f64;
    (!logs.is_empty() && mean.is_finite()).then(|| mean.exp())
}

/// Fits `law` to the loaded rows of `tests` (the medium's unit weight and RFT's `alpha_z` for
/// a plate moving down are given, not fitted).
pub fn fit_sinkage(
    law: SinkageLaw,
    tests: &[LoadedTest],
    unit_weight_n_m3: f64,
    rft_alpha_z_n_cm3: f64,
) -> Result<SinkageFit, SinkageFitError> {
    // Every row with a finite depth below FIT_MIN_DEPTH_M and a force > 0 enters the fit.
    let rows: Vec<(PlateShape, f64, f64)> = tests
        .iter()
        .flat_map(|t| t.rows.iter().map(move |&(z, f)| (t.plate, z, f)))
        .filter(|&(_, z, f)| z.is_finite() && f.is_finite() && z > FIT_MIN_DEPTH_M && f > 0.0)
        .collect();
    let names = law.param_names();
    let needed = names.len() + 3;
    // The start: ln p = c + n ln z (+ m ln b) over rows deep enough to carry a clear force.
    let logs: Vec<(f64, f64, f64)> = rows
        .iter()
        .map(|&(p, z, f)| (f / p.area_m2(), z, p.bekker_b_m()))
        .collect();
    if logs.len() < needed {
        return Err(SinkageFitError::TooFewRows {
            law: law.name(),
            usable: logs.len(),
            needed,
        });
    }
    let b_first = logs[0].2;
    let several_sizes = logs.iter().any(|l| (l.2 - b_first).abs() > 1e-6 * b_first);
    let cols = if several_sizes { 3 } else { 2 };
    let a = DMatrix::from_fn(logs.len(), cols, |i, j| match j {
        0 => 1.0,
        1 => (logs[i].1 / REF_LENGTH_M).ln(),
        _ => (logs[i].2 / REF_LENGTH_M).ln(),
    });
    let y = DVector::from_iterator(logs.len(), logs.iter().map(|l| l.0.ln()));
    // nalgebra's SVD panics on a matrix that is no number: rows of absurd size fit nothing.
    if a.iter().chain(y.iter()).any(|v| !v.is_finite()) {
        return Err(SinkageFitError::NotConverged { law: law.name() });
    }
    let c = a
        .clone()
        .svd(true, true)
        .solve(&y, 1e-12)
        .map_err(|_| SinkageFitError::NotConverged { law: law.name() })?;
    let (k0, n0, m0) = (c[0].exp(), c[1], if several_sizes { c[2] } else { 0.0 });
    let gamma = unit_weight_n_m3;
    // Each law's start from the power law, by least squares where it is linear.
    let linear = |basis: &dyn Fn(&PlateShape, f64) -> Vec<f64>| -> Vec<f64> {
        let k = basis(&rows[0].0, rows[0].1).len();
        let x = DMatrix::from_fn(rows.len(), k, |i, j| {
            basis(&rows[i].0, rows[i].1)[j] * rows[i].0.area_m2()
        });
        let f = DVector::from_iterator(rows.len(), rows.iter().map(|r| r.2));
        if x.iter().chain(f.iter()).any(|v| !v.is_finite()) {
            return vec![1.0; k];
        }
        x.svd(true, true)
            .solve(&f, 1e-12)
            .map(|v| v.iter().cloned().collect())
            .unwrap_or_else(|_| vec![1.0; k])
    };
    let n_start = n0.clamp(0.3, 3.0);
    let mut start: Vec<f64> = match law {
        SinkageLaw::TerzaghiFooting => linear(&|p, z| {
            let (b, s) = p.footing_b_m();
            vec![gamma * z, s * 0.5 * gamma * b]
        }),
        SinkageLaw::Bekker if several_sizes => {
            let mut v = linear(&|p, z| vec![z.powf(n_start) / p.bekker_b_m(), z.powf(n_start)]);
            v.push(n_start);
            v
        }
        SinkageLaw::Bekker => {
            let v = linear(&|_, z| vec![z.powf(n_start)]);
            vec![0.0, v[0], n_start]
        }
        SinkageLaw::Reece => {
            let v = linear(&|p, z| {
                let b = p.bekker_b_m();
                vec![gamma * b * (z / b).powf(n_start)]
            });
            vec![v[0], n_start]
        }
        SinkageLaw::RftDepthPower => {
            let v = linear(&|_, z| {
                vec![rft_alpha_z_n_cm3 * 1e6 * REF_LENGTH_M * (z / REF_LENGTH_M).powf(n_start)]
            });
            vec![v[0], n_start]
        }
        SinkageLaw::DepthWidthPower => vec![k0, n0, m0],
    };
    let held = match law.width_param() {
        Some((i, neutral)) if !several_sizes => {
            start[i] = neutral;
            Some(i)
        }
        _ => None,
    };
    let mut free: Vec<usize> = (0..start.len()).filter(|&i| Some(i) != held).collect();
    let ranges = law.param_ranges();
    let predict = |params: &[f64], p: &PlateShape, z: f64| -> f64 {
        SinkageModel {
            law,
            params: params.to_vec(),
            unit_weight_n_m3,
            rft_alpha_z_n_cm3,
        }
        .force_n(p, z)
    };
    // ln of a force, a prediction of 0 (or less) kept finite and far.
    let ln = |f: f64| f.max(1e-9).ln();
    let residuals = |params: &[f64]| -> DVector<f64> {
        DVector::from_iterator(
            rows.len(),
            rows.iter()
                .map(|&(p, z, f)| ln(f) - ln(predict(params, &p, z))),
        )
    };
    // Bounded: a value the best fit puts outside its range is held at the range's nearest
    // value and the others fitted again, until every value lies in its range (at most once
    // per parameter).
    let mut on_bound = Vec::new();
    let mut fitted = least_squares(start, &free, 1e-6, &residuals);
    loop {
        let out: Vec<usize> = free
            .iter()
            .copied()
            .filter(|&i| fitted.params[i].is_finite() && !ranges[i].contains(fitted.params[i]))
            .collect();
        if out.is_empty() {
            break;
        }
        let mut next = fitted.params.clone();
        for &i in &out {
            next[i] = ranges[i].nearest(next[i]);
            on_bound.push((names[i], next[i]));
        }
        free.retain(|i| !out.contains(i));
        fitted = least_squares(next, &free, 1e-6, &residuals);
    }
    let LeastSquares {
        params,
        cost,
        std_dev,
    } = fitted;
    if !params.iter().all(|v| v.is_finite()) || !cost.is_finite() {
        return Err(SinkageFitError::NotConverged { law: law.name() });
    }
    let model = SinkageModel {
        law,
        params,
        unit_weight_n_m3,
        rft_alpha_z_n_cm3,
    };
    let all: Vec<(PlateShape, f64, f64)> = tests
        .iter()
        .flat_map(|t| t.rows.iter().map(move |&(z, f)| (t.plate, z, f)))
        .filter(|&(_, z, f)| z.is_finite() && f.is_finite())
        .collect();
    let measured: Vec<f64> = all.iter().map(|r| r.2).collect();
    let predicted: Vec<f64> = all.iter().map(|r| model.force_n(&r.0, r.1)).collect();
    let fit = component_fit(&predicted, &measured);
    // Rows of absurd size (forces of 1e300 N) leave a fit whose score is no number.
    let tests_judged = judge(&model, tests);
    let scores = tests_judged
        .iter()
        .flat_map(|t| [t.r2, t.rmse_n])
        .chain([fit.r2, fit.rmse]);
    if scores.into_iter().any(|v| !v.is_finite()) {
        return Err(SinkageFitError::NotConverged { law: law.name() });
    }
    Ok(SinkageFit {
        tests: tests_judged,
        model,
        std_dev,
        width_held: held.is_some(),
        on_bound,
        r2: fit.r2,
        rmse_n: fit.rmse,
        std_dev_over_trials: false,
        scatter: None,
    })
}

/// What [`least_squares`] ends with.
pub(crate) struct LeastSquares {
    /// The parameters.
    pub params: Vec<f64>,
    /// The sum of squared residuals there.
    pub cost: f64,
    /// Each parameter's standard deviation (0 for one held; NaN where the fit does not tell it).
    pub std_dev: Vec<f64>,
}

/// Levenberg-Marquardt on `residuals` over the parameters `free` (the others held), from
/// `start`, with the Jacobian by central differences (steps of 1e-6 of a parameter, at least
/// `1e-6 step_floor`), and the standard deviations from it and the residuals' variance.
pub(crate) fn least_squares(
    start: Vec<f64>,
    free: &[usize],
    step_floor: f64,
    residuals: &dyn Fn(&[f64]) -> DVector<f64>,
) -> LeastSquares {
    // The predictions' Jacobian: the residuals' with the sign turned.
    let jacobian = |params: &[f64], rows: usize| -> DMatrix<f64> {
        let mut j = DMatrix::zeros(rows, free.len());
        for (col, &k) in free.iter().enumerate() {
            let h = 1e-6 * params[k].abs().max(step_floor);
            let (mut up, mut down) = (params.to_vec(), params.to_vec());
            up[k] += h;
            down[k] -= h;
            j.set_column(col, &((residuals(&down) - residuals(&up)) / (2.0 * h)));
        }
        j
    };
    let mut params = start;
    let r0 = residuals(&params);
    let rows = r0.len();
    let mut cost = r0.norm_squared();
    let mut lambda = 1e-3;
    for _ in 0..200 {
        let r = residuals(&params);
        let j = jacobian(&params, rows);
        let jtj = j.transpose() * &j;
        let jtr = j.transpose() * r;
        let mut improved = false;
        for _ in 0..20 {
            let mut m = jtj.clone();
            for d in 0..free.len() {
                m[(d, d)] += lambda * jtj[(d, d)].max(1e-12);
            }
            let Some(step) = m.cholesky().map(|c| c.solve(&jtr)) else {
                lambda *= 10.0;
                continue;
            };
            let mut trial = params.clone();
            for (col, &k) in free.iter().enumerate() {
                trial[k] += step[col];
            }
            let c = residuals(&trial).norm_squared();
            if c.is_finite() && c < cost {
                let done = (cost - c) <= 1e-12 * cost;
                params = trial;
                cost = c;
                lambda = (lambda / 10.0).max(1e-12);
                improved = !done;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    let s2 = cost / (rows as f64 - free.len() as f64).max(1.0);
    let j = jacobian(&params, rows);
    let cov = (j.transpose() * j).try_inverse();
    let mut std_dev = vec![0.0; params.len()];
    for (col, &k) in free.iter().enumerate() {
        std_dev[k] = cov
            .as_ref()
            .map(|c| (c[(col, col)] * s2).max(0.0).sqrt())
            .unwrap_or(f64::NAN);
    }
    LeastSquares {
        params,
        cost,
        std_dev,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn synthetic(truth: &SinkageModel, sizes: &[f64], noise_n: f64) -> Vec<LoadedTest> {
        sizes
            .iter()
            .enumerate()
            .map(|(k, &d)| {
                let plate = PlateShape::disc(d).unwrap();
                let rows = (1..=120)
                    .map(|i| {
                        let z = i as f64 * 0.25e-3;
                        // A deterministic, zero-mean relative wiggle stands in for noise.
                        let wiggle = 1.0 + noise_n * 0.01 * ((i * 7 + k * 3) as f64).sin();
                        (z, truth.force_n(&plate, z) * wiggle)
                    })
                    .collect();
                LoadedTest {
                    name: format!("d{d}"),
                    plate,
                    rows,
                }
            })
            .collect()
    }

    /// Sands whose stress rises with width (a depth-width power with `m` 0.8: Bekker's best
    /// `k_c` lies below 0) and falls with it (`m` -0.8: Terzaghi's best `N_gamma` does): each is
    /// held on its bound, 0, said so, and the model is one the medium file's readers accept;
    /// the law that made the data holds nothing.
    #[test]
    fn a_best_fit_outside_its_range_is_held_on_the_bound_and_said_so() {
        for (m, law, name) in [
            (0.8, SinkageLaw::Bekker, "k_c"),
            (-0.8, SinkageLaw::TerzaghiFooting, "n_gamma"),
        ] {
            let truth = SinkageModel::new(
                SinkageLaw::DepthWidthPower,
                vec![3000.0, 1.2, m],
                13000.0,
                0.254,
            )
            .unwrap();
            let tests = synthetic(&truth, &[0.06, 0.08, 0.1], 1.0);
            let fit = fit_sinkage(law, &tests, 13000.0, 0.254).unwrap();
            assert_eq!(
                fit.on_bound,
                vec![(name, 0.0)],
                "{law:?}: {:?}",
                fit.model.params
            );
            let i = law.param_names().iter().position(|n| *n == name).unwrap();
            assert_eq!((fit.model.params[i], fit.std_dev[i]), (0.0, 0.0));
            SinkageModel::new(law, fit.model.params.clone(), 13000.0, 0.254)
                .unwrap_or_else(|e| panic!("{law:?}: the readers refuse its fit: {e}"));
            let own = fit_sinkage(SinkageLaw::DepthWidthPower, &tests, 13000.0, 0.254).unwrap();
            assert!(own.on_bound.is_empty());
            assert!(
                (own.model.params[2] - m).abs() < 0.02,
                "{:?}",
                own.model.params
            );
        }
    }

    #[test]
    fn every_law_recovers_its_own_values() {
        let truths = [
            (SinkageLaw::TerzaghiFooting, vec![30.0, 15.0]),
            (SinkageLaw::Bekker, vec![2.0e4, 2.0e6, 1.3]),
            (SinkageLaw::Reece, vec![400.0, 1.25]),
            (SinkageLaw::RftDepthPower, vec![3.0, 1.3]),
            (SinkageLaw::DepthWidthPower, vec![3000.0, 1.3, 1.0]),
        ];
        for (law, values) in truths {
            let truth = SinkageModel::new(law, values.clone(), 13_000.0, 0.2).unwrap();
            let tests = synthetic(&truth, &[0.06, 0.08, 0.1], 0.2);
            let fit = fit_sinkage(law, &tests, 13_000.0, 0.2).unwrap();
            for (i, (got, want)) in fit.model.params.iter().zip(&values).enumerate() {
                let tol = 0.02 * want.abs().max(1e-9) + 4.0 * fit.std_dev[i];
                assert!(
                    (got - want).abs() <= tol,
                    "{law:?} param {i}: {got} vs {want}"
                );
            }
            assert!(fit.r2 > 0.99, "{law:?} {}", fit.r2);
            assert!(!fit.width_held);
        }
    }

    #[test]
    fn one_plate_size_holds_the_width_term() {
        let truth = SinkageModel::new(
            SinkageLaw::DepthWidthPower,
            vec![3000.0, 1.3, 1.0],
            13e3,
            0.2,
        )
        .unwrap();
        let tests = synthetic(&truth, &[0.08], 0.1);
        let fit = fit_sinkage(SinkageLaw::DepthWidthPower, &tests, 13e3, 0.2).unwrap();
        assert!(fit.width_held);
        assert_eq!(fit.model.params[2], 0.0);
        assert_eq!(fit.std_dev[2], 0.0);
        assert!((fit.model.params[1] - 1.3).abs() < 0.01);
        assert!(fit.r2 > 0.999);
    }

    #[test]
    fn too_few_rows_is_an_error_naming_the_count() {
        let tests = vec![LoadedTest {
            name: "x".into(),
            plate: PlateShape::disc(0.06).unwrap(),
            rows: vec![(0.001, 1.0), (0.002, 2.0), (-0.001, 0.0)],
        }];
        let e = fit_sinkage(SinkageLaw::Bekker, &tests, 13e3, 0.2).unwrap_err();
        assert!(
            e.to_string().contains("bekker") && e.to_string().contains("0 with"),
            "{e}"
        );
    }
}
