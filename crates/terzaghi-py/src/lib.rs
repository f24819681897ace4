//! The native module of the `terzaghi` Python package (`terzaghi._terzaghi`): thin wrappers of
//! the library's model, identification and diagnosis over numpy arrays. The Python side
//! (`python/terzaghi/__init__.py`) gives them their documented signatures; everything here
//! calls the same functions as the `terzaghi` command line.

use numpy::ndarray::{ArrayD, Zip};
use numpy::{AllowTypeChange, IntoPyArray, PyArrayDyn, PyArrayLikeDyn};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use terzaghi::ident::online::{OnlineEstimator as CoreOnline, OnlineOptions};
use terzaghi::ident::{BatchOptions, Sample, fit_batch};
use terzaghi::model::{ForceModel, TerzaghiModel};
use terzaghi::model_spec::{MediumSpec, ModelKind, ModelSpec};

pyo3::create_exception!(
    _terzaghi,
    TerzaghiError,
    PyValueError,
    "A value terzaghi refuses, with the words of its reason (a ValueError)."
);

/// The error's whole chain in one line, as the command line words it.
fn err(e: impl Into<anyhow::Error>) -> PyErr {
    let e: anyhow::Error = e.into();
    TerzaghiError::new_err(format!("{e:#}"))
}

type F64Array<'py> = PyArrayLikeDyn<'py, f64, AllowTypeChange>;

#[allow(clippy::too_many_arguments)]
fn spec(
    model: &str,
    length_m: f64,
    width_m: f64,
    hip_height_m: f64,
    medium: Option<String>,
    unit_weight_n_m3: Option<f64>,
    phi_deg: Option<f64>,
    delta_deg: Option<f64>,
    b_k: Option<f64>,
    a: Option<f64>,
    rft_coeffs: Option<String>,
    rft_zeta: Option<f64>,
    rft_elements: usize,
) -> PyResult<ModelSpec> {
    Ok(ModelSpec {
        kind: ModelKind::by_name(model).map_err(err)?,
        length_m,
        width_m,
        hip_height_m,
        medium: MediumSpec {
            preset: medium,
            unit_weight_n_m3,
            phi_deg,
            delta_deg,
        },
        b_k,
        a,
        rft_coeffs,
        rft_zeta,
        rft_elements,
    })
}

/// The conventional model of a plate and medium: the base the fits scale.
fn base_model(
    length_m: f64,
    width_m: f64,
    hip_height_m: f64,
    medium: MediumSpec,
) -> PyResult<TerzaghiModel> {
    let plate = terzaghi::model_spec::plate(length_m, width_m, hip_height_m).map_err(err)?;
    let chosen = medium.medium().map_err(err)?;
    Ok(terzaghi::model_spec::terzaghi_model(plate, &chosen, None))
}

/// The model's forces at every angle of `beta_rad` (any shape): drag, lift, hip torque,
/// submerged length, depth (each the shape of `beta_rad`) and the regime's code.
#[pyfunction]
#[pyo3(signature = (beta_rad, model, length_m, width_m, hip_height_m, medium, unit_weight_n_m3, phi_deg, delta_deg, b_k, a, rft_coeffs, rft_zeta, rft_elements))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn predict<'py>(
    py: Python<'py>,
    beta_rad: F64Array<'py>,
    model: &str,
    length_m: f64,
    width_m: f64,
    hip_height_m: f64,
    medium: Option<String>,
    unit_weight_n_m3: Option<f64>,
    phi_deg: Option<f64>,
    delta_deg: Option<f64>,
    b_k: Option<f64>,
    a: Option<f64>,
    rft_coeffs: Option<String>,
    rft_zeta: Option<f64>,
    rft_elements: usize,
) -> PyResult<(
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<u8>>,
)> {
    let m: ForceModel = spec(
        model,
        length_m,
        width_m,
        hip_height_m,
        medium,
        unit_weight_n_m3,
        phi_deg,
        delta_deg,
        b_k,
        a,
        rft_coeffs,
        rft_zeta,
        rft_elements,
    )?
    .build()
    .map_err(err)?;
    let beta = beta_rad.as_array().to_owned();
    // Without the interpreter's lock: numpy's buffer is copied, the model is pure.
    let out = py.detach(move || -> Result<_, String> {
        let shape = beta.raw_dim();
        let mut cols: [ArrayD<f64>; 5] = std::array::from_fn(|_| ArrayD::zeros(shape.clone()));
        let mut regime = ArrayD::<u8>::zeros(shape.clone());
        for (k, (idx, b)) in beta.indexed_iter().enumerate() {
            let p = m
                .predict(*b)
                .map_err(|e| format!("beta_rad[{k}] (flat index) = {b}: {e}"))?;
            for (c, v) in cols.iter_mut().zip([
                p.drag_n,
                p.lift_n,
                p.hip_torque_nm,
                p.submerged_m,
                p.depth_m,
            ]) {
                c[&idx] = v;
            }
            regime[&idx] = p.regime.code();
        }
        Ok((cols, regime))
    });
    let (cols, regime) = out.map_err(TerzaghiError::new_err)?;
    let [d, l, t, s, z] = cols;
    Ok((
        d.into_pyarray(py),
        l.into_pyarray(py),
        t.into_pyarray(py),
        s.into_pyarray(py),
        z.into_pyarray(py),
        regime.into_pyarray(py),
    ))
}

/// Samples from equal-shaped arrays of angle, drag and lift (and time).
fn samples(
    beta_rad: &F64Array<'_>,
    drag_n: &F64Array<'_>,
    lift_n: &F64Array<'_>,
    t_s: Option<&F64Array<'_>>,
) -> PyResult<Vec<Sample>> {
    let (b, d, l) = (beta_rad.as_array(), drag_n.as_array(), lift_n.as_array());
    if b.shape() != d.shape() || b.shape() != l.shape() {
        return Err(TerzaghiError::new_err(format!(
            "beta_rad, drag_n and lift_n must have one shape: got {:?}, {:?}, {:?}",
            b.shape(),
            d.shape(),
            l.shape()
        )));
    }
    let mut out = Vec::with_capacity(b.len());
    Zip::from(&b)
        .and(&d)
        .and(&l)
        .for_each(|&beta_rad, &drag_n, &lift_n| {
            out.push(Sample {
                t_s: None,
                beta_rad,
                drag_n,
                lift_n,
            })
        });
    if let Some(t) = t_s {
        let t = t.as_array();
        if t.shape() != b.shape() {
            return Err(TerzaghiError::new_err(format!(
                "t_s must have the shape of beta_rad: got {:?} against {:?}",
                t.shape(),
                b.shape()
            )));
        }
        for (s, t) in out.iter_mut().zip(t.iter()) {
            s.t_s = Some(*t);
        }
    }
    Ok(out)
}

/// The batch fit of `b_k, a` (and `delta`), as `terzaghi fit --json` prints it (JSON text).
#[pyfunction]
#[pyo3(signature = (beta_rad, drag_n, lift_n, length_m, width_m, hip_height_m, medium, unit_weight_n_m3, phi_deg, delta_deg, fit_delta, all_regimes))]
#[allow(clippy::too_many_arguments)]
fn fit_json(
    py: Python<'_>,
    beta_rad: F64Array<'_>,
    drag_n: F64Array<'_>,
    lift_n: F64Array<'_>,
    length_m: f64,
    width_m: f64,
    hip_height_m: f64,
    medium: Option<String>,
    unit_weight_n_m3: Option<f64>,
    phi_deg: Option<f64>,
    delta_deg: Option<f64>,
    fit_delta: bool,
    all_regimes: bool,
) -> PyResult<String> {
    let base = base_model(
        length_m,
        width_m,
        hip_height_m,
        MediumSpec {
            preset: medium,
            unit_weight_n_m3,
            phi_deg,
            delta_deg,
        },
    )?;
    let samples = samples(&beta_rad, &drag_n, &lift_n, None)?;
    let opts = BatchOptions {
        fit_delta,
        all_regimes,
        ..Default::default()
    };
    let fit = py
        .detach(|| fit_batch(&base, &samples, &opts))
        .map_err(err)?;
    serde_json::to_string(&fit).map_err(err)
}

/// The online estimator of `b_k, a` (and `delta`) over a plate and medium.
#[pyclass(module = "terzaghi._terzaghi", name = "OnlineEstimator")]
struct Online {
    inner: CoreOnline,
}

#[pymethods]
impl Online {
    #[new]
    #[pyo3(signature = (length_m, width_m, hip_height_m, medium, unit_weight_n_m3, phi_deg, delta_deg, fit_delta, forgetting, min_unit_force_n))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        length_m: f64,
        width_m: f64,
        hip_height_m: f64,
        medium: Option<String>,
        unit_weight_n_m3: Option<f64>,
        phi_deg: Option<f64>,
        delta_deg: Option<f64>,
        fit_delta: bool,
        forgetting: Option<f64>,
        min_unit_force_n: Option<f64>,
    ) -> PyResult<Self> {
        let base = base_model(
            length_m,
            width_m,
            hip_height_m,
            MediumSpec {
                preset: medium,
                unit_weight_n_m3,
                phi_deg,
                delta_deg,
            },
        )?;
        let mut opts = OnlineOptions {
            fit_delta,
            ..Default::default()
        };
        if let Some(f) = forgetting {
            opts.forgetting = terzaghi::ident::online::Forgetting::PerSample(f);
        }
        if let Some(n) = min_unit_force_n {
            opts.min_unit_force_n = n;
        }
        Ok(Online {
            inner: CoreOnline::new(&base, opts).map_err(err)?,
        })
    }

    /// Feeds samples in order; returns how many updated the estimate (the others were skipped
    /// and counted in the estimate: non-finite, outside the gate, a stuck sensor).
    #[pyo3(signature = (beta_rad, drag_n, lift_n, t_s=None))]
    fn update(
        &mut self,
        py: Python<'_>,
        beta_rad: F64Array<'_>,
        drag_n: F64Array<'_>,
        lift_n: F64Array<'_>,
        t_s: Option<F64Array<'_>>,
    ) -> PyResult<u64> {
        let samples = samples(&beta_rad, &drag_n, &lift_n, t_s.as_ref())?;
        let inner = &mut self.inner;
        Ok(py.detach(|| {
            samples
                .iter()
                .map(|s| u64::from(inner.update(s).is_ok()))
                .sum()
        }))
    }

    /// The estimate as JSON text (the fields of `terzaghi identify --online --json`).
    fn estimate_json(&self) -> PyResult<String> {
        serde_json::to_string(self.inner.estimate()).map_err(err)
    }
}

/// Diagnoses a recording (MCAP session, or a plate-sinkage test with `medium_file`) into
/// `out`: the reports' JSON text, as `terzaghi diagnose --json` prints them (a list).
#[pyfunction]
#[pyo3(signature = (path, out, medium_file))]
fn diagnose_json(
    py: Python<'_>,
    path: std::path::PathBuf,
    out: std::path::PathBuf,
    medium_file: Option<std::path::PathBuf>,
) -> PyResult<String> {
    py.detach(|| -> anyhow::Result<String> {
        use terzaghi::session::diagnose::{DiagnoseFileOptions, diagnose_file, write_reports};
        if terzaghi::session::plate_test::is_plate_test(&path) {
            use terzaghi::model::sinkage::RegimeOptions;
            use terzaghi::session::plate_test::{
                DepthColumn, MediumFile, diagnose_test, read_test,
            };
            let Some(medium_file) = medium_file else {
                anyhow::bail!(
                    "{} is a plate-sinkage test: give the medium to judge it against (medium_file, written by terzaghi calibrate)",
                    path.display()
                );
            };
            let medium = MediumFile::read(&medium_file)?;
            let test = read_test(&path, None, DepthColumn::AsLogged, &RegimeOptions::default())?;
            let d = diagnose_test(&test, &medium)?;
            let json = serde_json::to_string_pretty(&d)? + "\n";
            std::fs::create_dir_all(&out)?;
            terzaghi::session::files::write_text(&out.join("report.json"), &json)?;
            return Ok(format!("[{json}]"));
        }
        let d = diagnose_file(&path, &DiagnoseFileOptions::default())?;
        let written = write_reports(&d, &out)?;
        if !written.failed.is_empty() {
            anyhow::bail!("cannot diagnose {}", written.failed.join("; "));
        }
        let reports: Vec<&serde_json::Value> = written.reports.iter().map(|(_, r)| r).collect();
        Ok(serde_json::to_string(&reports)?)
    })
    .map_err(err)
}

/// An MCAP recording's first and last message time (ns since the Unix epoch, `None` when it
/// has no message) and its message count, from its summary (or a scan of a cut-off file).
#[pyfunction]
fn recording_info(path: std::path::PathBuf) -> PyResult<(Option<u64>, Option<u64>, u64)> {
    let opened = terzaghi::session::Opened::mcap(&path)
        .map_err(err)?
        .ok_or_else(|| {
            TerzaghiError::new_err(format!("{} is not an MCAP recording", path.display()))
        })?;
    let head = opened.head();
    Ok((head.start_ns, head.end_ns, head.messages))
}

/// The native module.
#[pymodule]
fn _terzaghi(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("TerzaghiError", m.py().get_type::<TerzaghiError>())?;
    m.add_function(wrap_pyfunction!(predict, m)?)?;
    m.add_function(wrap_pyfunction!(fit_json, m)?)?;
    m.add_function(wrap_pyfunction!(diagnose_json, m)?)?;
    m.add_function(wrap_pyfunction!(recording_info, m)?)?;
    m.add_class::<Online>()?;
    m.add(
        "REGIMES",
        terzaghi::model::Regime::ALL
            .iter()
            .map(|r| r.as_str())
            .collect::<Vec<_>>(),
    )?;
    Ok(())
}
