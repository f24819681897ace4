//! The native module of the `terzaghi` Python package (`terzaghi._terzaghi`): thin wrappers of
//! the library's model, identification and diagnosis over numpy arrays. The Python side
//! (`python/terzaghi/__init__.py`) gives them their documented signatures; everything here
//! calls the same functions as the `terzaghi` command line.

mod free_base;

use numpy::ndarray::{ArrayD, Zip};
use numpy::{
    AllowTypeChange, IntoPyArray, PyArray1, PyArrayDyn, PyArrayLikeDyn, PyUntypedArrayMethods,
};
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
    shape: &str,
    c_leg_radius_m: Option<f64>,
    c_leg_span_deg: Option<f64>,
    profile: Option<Vec<(f64, f64)>>,
    medium_file: Option<std::path::PathBuf>,
) -> PyResult<ModelSpec> {
    let shape = match (shape, profile) {
        ("plate", None) => terzaghi::model_spec::LegShape::Plate,
        ("c_leg", None) => terzaghi::model_spec::LegShape::CLeg {
            radius_m: c_leg_radius_m,
            span_deg: c_leg_span_deg,
        },
        ("polyline", Some(line)) => terzaghi::model_spec::LegShape::Polyline { line },
        ("polyline", None) => {
            return Err(TerzaghiError::new_err(
                "shape polyline needs profile: the leg's mid-line as [(s, q), ...] in metres (s from the hip along the chord, q toward the travel)",
            ));
        }
        (_, Some(_)) => {
            return Err(TerzaghiError::new_err("profile is for shape polyline"));
        }
        (other, None) => {
            return Err(TerzaghiError::new_err(format!(
                "shape {other:?}: expected plate, c_leg or polyline"
            )));
        }
    };
    if matches!(shape, terzaghi::model_spec::LegShape::Plate)
        && (c_leg_radius_m.is_some() || c_leg_span_deg.is_some())
    {
        return Err(TerzaghiError::new_err(
            "c_leg_radius_m and c_leg_span_deg are for shape c_leg",
        ));
    }
    Ok(ModelSpec {
        kind: ModelKind::by_name(model).map_err(err)?,
        length_m,
        width_m,
        hip_height_m,
        medium: MediumSpec {
            file: medium_file,
            ..medium_spec(medium, unit_weight_n_m3, phi_deg, delta_deg)
        },
        b_k,
        a,
        rft_coeffs,
        rft_zeta,
        rft_elements,
        shape,
        planar_sheared_bearing: false,
    })
}

/// The medium the Python arguments name: a preset, or the three soil values.
fn medium_spec(
    preset: Option<String>,
    unit_weight_n_m3: Option<f64>,
    phi_deg: Option<f64>,
    delta_deg: Option<f64>,
) -> MediumSpec {
    MediumSpec {
        preset,
        unit_weight_n_m3,
        phi_deg,
        delta_deg,
        file: None,
    }
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

/// The band of a medium file's trial-to-trial scatter: its low and high scale on the law's
/// force and the share of further trials between them; a file without one is refused, saying
/// why.
#[pyfunction]
fn medium_band(medium_file: std::path::PathBuf) -> PyResult<(f64, f64, f64)> {
    let medium = terzaghi::medium_file::MediumFile::read(&medium_file).map_err(err)?;
    let (low, high) = medium.band(&medium_file).map_err(err)?;
    Ok((low, high, medium.scatter.map_or(f64::NAN, |s| s.level)))
}

/// A wheel's or a foot's steady state for each run of flat arrays of one length (`load_n`, `hub_vx_m_s`,
/// `omega_rad_s`, `slip_angle_deg`; or, with `sinkage_m`, held there): sinkage, drawbar, side
/// force, drive torque, the load borne and whether the sand bears the run (1) or not (0: the
/// body buried to its top, the most the sand bears as its load), as `terzaghi steady` gives
/// them.
#[pyfunction]
#[pyo3(signature = (load_n, hub_vx_m_s, omega_rad_s, slip_angle_deg, sinkage_m, body, medium_file, scale = 1.0))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn steady(
    py: Python<'_>,
    load_n: Vec<f64>,
    hub_vx_m_s: Vec<f64>,
    omega_rad_s: Vec<f64>,
    slip_angle_deg: Vec<f64>,
    sinkage_m: Option<Vec<f64>>,
    body: BodyArgs,
    medium_file: std::path::PathBuf,
    scale: f64,
) -> PyResult<[Vec<f64>; 6]> {
    use terzaghi::model::{Drive, Stress, state_at_sinkage, steady_sinkage};
    use terzaghi::session::steady::borne_or_deepest;
    let medium = terzaghi::medium_file::MediumFile::read(&medium_file).map_err(err)?;
    if !(scale.is_finite() && scale > 0.0) {
        return Err(TerzaghiError::new_err(format!(
            "the medium's scale must be a number > 0, got {scale}"
        )));
    }
    let law = medium.rft_law(None).map_err(err)?.scaled(scale);
    let body = body_of(body)?;
    let n = hub_vx_m_s.len();
    if [load_n.len(), omega_rad_s.len(), slip_angle_deg.len()]
        .iter()
        .chain(sinkage_m.as_ref().map(Vec::len).as_ref())
        .any(|&l| l != n)
    {
        return Err(TerzaghiError::new_err(
            "load_n, hub_vx_m_s, omega_rad_s, slip_angle_deg (and sinkage_m) must be of one length",
        ));
    }
    py.detach(move || {
        let stress = Stress {
            coefficients: &law.coefficients,
            depth_law: Some(&law.depth_law),
            speed_law: law.speed_law.as_ref(),
            sheared: law.sheared.as_ref(),
        };
        let mut out: [Vec<f64>; 6] = std::array::from_fn(|_| Vec::with_capacity(n));
        for i in 0..n {
            let drive = Drive {
                speed_m_s: hub_vx_m_s[i],
                omega_rad_s: omega_rad_s[i],
                slip_angle_rad: slip_angle_deg[i].to_radians(),
            };
            let solved = match &sinkage_m {
                None => steady_sinkage(&body, &stress, load_n[i], &drive),
                Some(z) => state_at_sinkage(&body, &stress, z[i], &drive),
            };
            let (s, borne) = borne_or_deepest(&body, &stress, &drive, solved)
                .map_err(|e| TerzaghiError::new_err(format!("run {i} (flat index): {e}")))?;
            for (c, v) in out.iter_mut().zip([
                s.sinkage_m,
                s.drawbar_n,
                s.side_n,
                s.torque_nm,
                s.load_n,
                f64::from(u8::from(borne)),
            ]) {
                c.push(v);
            }
        }
        Ok(out)
    })
}

/// The model's forces at every angle of `beta_rad` (any shape): drag, lift, hip torque,
/// submerged length, depth (each the shape of `beta_rad`) and the regime's code.
#[pyfunction]
#[pyo3(signature = (beta_rad, model, length_m, width_m, hip_height_m, medium, unit_weight_n_m3, phi_deg, delta_deg, b_k, a, rft_coeffs, rft_zeta, rft_elements, shape, c_leg_radius_m, c_leg_span_deg, profile, medium_file, planar_sheared_bearing=false))]
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
    shape: &str,
    c_leg_radius_m: Option<f64>,
    c_leg_span_deg: Option<f64>,
    profile: Option<Vec<(f64, f64)>>,
    medium_file: Option<std::path::PathBuf>,
    planar_sheared_bearing: bool,
) -> PyResult<(
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<u8>>,
)> {
    let m: ForceModel = ModelSpec {
        planar_sheared_bearing,
        ..spec(
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
            shape,
            c_leg_radius_m,
            c_leg_span_deg,
            profile,
            medium_file,
        )?
    }
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

/// A body as Python's `predict` gives it: shape, radius, width, thickness, sizes, mesh file,
/// mesh scale, element size, grousers (count, height, thickness), rim elements.
type BodyArgs = (
    String,
    Option<f64>,
    Option<f64>,
    Option<f64>,
    Option<Vec<f64>>,
    Option<std::path::PathBuf>,
    Option<f64>,
    Option<f64>,
    Option<(usize, f64, f64)>,
    Option<usize>,
);

/// The body `b` describes, or an error naming the value Python's argument gave wrong.
fn body_of(b: BodyArgs) -> PyResult<terzaghi::model::Body> {
    let (shape, radius_m, width_m, thickness_m, size_m, mesh_file, mesh_scale, element_m) =
        (b.0, b.1, b.2, b.3, b.4, b.5, b.6, b.7);
    let spec = terzaghi::session::steady::BodySpec {
        shape,
        radius_m,
        width_m,
        thickness_m,
        size_m,
        mesh_file,
        mesh_scale,
        element_m,
        grousers: b
            .8
            .map(|(count, height_m, thickness_m)| terzaghi::model::Grousers {
                count,
                height_m,
                thickness_m,
            }),
        rim_elements: b.9,
    };
    terzaghi::session::steady::build_body(&spec, str::to_string).map_err(err)
}

/// `spec` with its leg the body `b` (by RFT, the body's reach and width its length and width).
fn with_body(
    mut spec: terzaghi::model_spec::ModelSpec,
    b: BodyArgs,
) -> PyResult<terzaghi::model_spec::ModelSpec> {
    let body = body_of(b)?;
    (spec.length_m, spec.width_m) = (body.reach_m(), body.width_m());
    spec.shape = terzaghi::model_spec::LegShape::Body(Box::new(body));
    Ok(spec)
}

/// [`predict`] with each sample's own hip: heights (m above the surface, negative below it),
/// velocities (forward, to the left and up, m/s) and the leg's rotation rate (rad/s) beside the
/// angles, flat arrays of one length. The sinkage model's path (its depth is the hip's height
/// below the surface) and a body's (`body`: then the leg is that body, by RFT, its reach and
/// width its own); the model is built with its hip at the surface. Columns: drag, lift, hip
/// torque, submerged length, depth, side force, roll and yaw moments; and the regimes.
#[pyfunction]
#[pyo3(signature = (beta_rad, hip_height_m, up_m_s, forward_m_s, lateral_m_s, omega_rad_s, model, length_m, width_m, medium, unit_weight_n_m3, phi_deg, delta_deg, b_k, a, rft_coeffs, rft_zeta, rft_elements, shape, c_leg_radius_m, c_leg_span_deg, profile, medium_file, body, planar_sheared_bearing=false))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn predict_moving<'py>(
    py: Python<'py>,
    beta_rad: Vec<f64>,
    hip_height_m: Vec<f64>,
    up_m_s: Vec<f64>,
    forward_m_s: Vec<f64>,
    lateral_m_s: Vec<f64>,
    omega_rad_s: Vec<f64>,
    model: &str,
    length_m: f64,
    width_m: f64,
    medium: Option<String>,
    unit_weight_n_m3: Option<f64>,
    phi_deg: Option<f64>,
    delta_deg: Option<f64>,
    b_k: Option<f64>,
    a: Option<f64>,
    rft_coeffs: Option<String>,
    rft_zeta: Option<f64>,
    rft_elements: usize,
    shape: &str,
    c_leg_radius_m: Option<f64>,
    c_leg_span_deg: Option<f64>,
    profile: Option<Vec<(f64, f64)>>,
    medium_file: Option<std::path::PathBuf>,
    body: Option<BodyArgs>,
    planar_sheared_bearing: bool,
) -> PyResult<(Vec<Vec<f64>>, Vec<u8>)> {
    let n = beta_rad.len();
    let motion = [
        ("hip_height_m", &hip_height_m),
        ("up_m_s", &up_m_s),
        ("forward_m_s", &forward_m_s),
        ("lateral_m_s", &lateral_m_s),
        ("omega_rad_s", &omega_rad_s),
    ];
    if let Some((name, v)) = motion.iter().find(|(_, v)| v.len() != n) {
        return Err(TerzaghiError::new_err(format!(
            "{n} angles and {} of {name}: give one of each per sample",
            v.len()
        )));
    }
    let mut spec = spec(
        model,
        length_m,
        width_m,
        0.0,
        medium,
        unit_weight_n_m3,
        phi_deg,
        delta_deg,
        b_k,
        a,
        rft_coeffs,
        rft_zeta,
        rft_elements,
        shape,
        c_leg_radius_m,
        c_leg_span_deg,
        profile,
        medium_file,
    )?;
    spec.planar_sheared_bearing = planar_sheared_bearing;
    if let Some(b) = body {
        spec = with_body(spec, b)?;
    }
    let m: ForceModel = spec.build().map_err(err)?;
    py.detach(move || {
        let mut cols: Vec<Vec<f64>> = (0..8).map(|_| Vec::with_capacity(n)).collect();
        let mut regime = Vec::with_capacity(n);
        for (k, &b) in beta_rad.iter().enumerate() {
            let [h, u, f, l, w] = motion.map(|(_, v)| v[k]);
            let hip = terzaghi::model::HipMotion {
                up_m_s: u,
                forward_m_s: f,
                lateral_m_s: l,
                omega_rad_s: w,
                ..terzaghi::model::HipMotion::still(h)
            };
            let p = m.predict_moving(b, &hip).map_err(|e| {
                TerzaghiError::new_err(format!(
                    "sample {k} (flat index): beta_rad {b}, hip_height_m {h}, up_m_s {u}, forward_m_s {f}, lateral_m_s {l}, omega_rad_s {w}: {e}"
                ))
            })?;
            for (c, v) in cols.iter_mut().zip([
                p.drag_n,
                p.lift_n,
                p.hip_torque_nm,
                p.submerged_m,
                p.depth_m,
                p.side_n,
                p.roll_moment_nm,
                p.yaw_moment_nm,
            ]) {
                c.push(v);
            }
            regime.push(p.regime.code());
        }
        Ok((cols, regime))
    })
}

/// A recording's topics as tables ([`terzaghi::session::topics::read_topics`]): per topic its
/// name, type, whether its type is read, its messages, those that did not decode, and its
/// columns as arrays.
#[pyfunction]
#[pyo3(signature = (path, topics))]
#[allow(clippy::type_complexity)]
fn read_topics<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    topics: Option<Vec<String>>,
) -> PyResult<
    Vec<(
        String,
        String,
        bool,
        u64,
        u64,
        Vec<(String, Bound<'py, PyArray1<f64>>)>,
    )>,
> {
    let tables = py
        .detach(|| terzaghi::session::topics::read_topics(&path, topics.as_deref()))
        .map_err(err)?;
    Ok(tables
        .into_iter()
        .map(|t| {
            let cols = t
                .columns
                .into_iter()
                .map(|(n, v)| (n, v.into_pyarray(py)))
                .collect();
            (
                t.topic,
                t.type_name,
                t.read,
                t.messages,
                t.undecodable,
                cols,
            )
        })
        .collect())
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
        medium_spec(medium, unit_weight_n_m3, phi_deg, delta_deg),
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
            medium_spec(medium, unit_weight_n_m3, phi_deg, delta_deg),
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
#[pyo3(signature = (path, out, medium_file, body))]
fn diagnose_json(
    py: Python<'_>,
    path: std::path::PathBuf,
    out: std::path::PathBuf,
    medium_file: Option<std::path::PathBuf>,
    body: Option<BodyArgs>,
) -> PyResult<String> {
    let body = body.map(|b| {
        let text = format!(
            "{}{}{}",
            b.0,
            b.1.map_or(String::new(), |r| format!(" radius {r} m")),
            b.2.map_or(String::new(), |w| format!(" width {w} m"))
        );
        body_of(b).map(|body| (body, text))
    });
    let body = body.transpose()?;
    py.detach(|| -> anyhow::Result<String> {
        use terzaghi::session::diagnose::{DiagnoseFileOptions, diagnose_file, write_reports};
        use terzaghi::session::wheel_test::{diagnose_runs, is_wheel_test, write_wheel_report};
        if body.is_some() || is_wheel_test(&path) {
            let (Some((body, text)), Some(medium_file)) = (&body, &medium_file) else {
                anyhow::bail!(
                    "{} is a body's runs: give its body (shape, radius_m, width_m, ...) and the medium to judge it against (medium_file, written by terzaghi calibrate)",
                    path.display()
                );
            };
            let d = diagnose_runs(&path, medium_file, body, text, &Default::default())?;
            let json = write_wheel_report(&d, &out)?;
            return Ok(format!("[{json}]"));
        }
        if terzaghi::session::plate_test::is_plate_test(&path) {
            let Some(medium_file) = medium_file else {
                anyhow::bail!(
                    "{} is a plate-sinkage test: give the medium to judge it against (medium_file, written by terzaghi calibrate)",
                    path.display()
                );
            };
            let (_, json) = terzaghi::session::plate_test::diagnose_test_to_dir(
                &path,
                &medium_file,
                None,
                &out,
            )?;
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

/// A recording (MCAP session or CSV force log) re-evaluated through the node's code, as
/// `terzaghi replay --reevaluate` does: the leg names, then every row's columns in
/// [`COLUMNS`]'s order (a missing measurement is NaN; `leg` indexes the names).
#[pyfunction]
#[pyo3(signature = (path, params_file, params))]
#[allow(clippy::type_complexity)]
fn reevaluate<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    params_file: Option<std::path::PathBuf>,
    params: Vec<(String, String)>,
) -> PyResult<(Vec<String>, Vec<Bound<'py, PyArray1<f64>>>)> {
    let (names, cols) = py
        .detach(|| -> anyhow::Result<_> {
            use terzaghi::session::reevaluate::{ReevaluateOptions, reevaluate_file};
            let opts = ReevaluateOptions {
                params_file,
                params: params
                    .into_iter()
                    .map(|(k, v)| (k, terzaghi::config::parse_value(&v)))
                    .collect(),
                progress: None,
            };
            let mut cols: Vec<Vec<f64>> = vec![Vec::new(); COLUMNS.len()];
            let done = reevaluate_file(&path, opts, |r| {
                let v = [
                    r.t_s,
                    r.leg as f64,
                    r.beta_rad,
                    f64::from(r.regime.code()),
                    r.measured_drag_n.unwrap_or(f64::NAN),
                    r.measured_lift_n.unwrap_or(f64::NAN),
                    r.predicted_drag_n,
                    r.predicted_lift_n,
                    r.predicted_hip_torque_nm,
                    r.b_k,
                    r.a,
                    f64::from(u8::from(r.identified)),
                    r.bare_drag_n,
                    r.bare_lift_n,
                    r.expected_reading_drag_n,
                    r.expected_reading_lift_n,
                    r.predicted_side_n,
                    r.predicted_roll_moment_nm,
                    r.predicted_yaw_moment_nm,
                ];
                for (c, x) in cols.iter_mut().zip(v) {
                    c.push(x);
                }
            })?;
            done.check_inputs_found(&path)?;
            let names = done.config.legs.iter().map(|l| l.name.clone()).collect();
            Ok((names, cols))
        })
        .map_err(err)?;
    Ok((
        names,
        cols.into_iter()
            .map(|c| PyArray1::from_vec(py, c))
            .collect(),
    ))
}

/// The columns [`reevaluate`] returns, in order.
const COLUMNS: [&str; 19] = [
    "t_s",
    "leg",
    "beta_rad",
    "regime",
    "measured_drag_n",
    "measured_lift_n",
    "predicted_drag_n",
    "predicted_lift_n",
    "predicted_hip_torque_nm",
    "b_k",
    "a",
    "identified",
    "bare_drag_n",
    "bare_lift_n",
    "expected_reading_drag_n",
    "expected_reading_lift_n",
    "predicted_side_n",
    "predicted_roll_moment_nm",
    "predicted_yaw_moment_nm",
];

/// One model evaluated for many legs at once (a simulator's environments times legs), from
/// arrays of float64 or float32, on every core without the interpreter's lock, into arrays the
/// caller owns: nothing is allocated per call.
#[pyclass(module = "terzaghi._terzaghi", name = "Batch")]
struct Batch {
    kernel: terzaghi::model::batch::LegKernel,
}

/// Legs per task of [`Batch::forces_into`].
const CHUNK: usize = 1024;

/// The names of [`Batch::forces_into`]'s inputs, in its order.
const BATCH_INPUTS: [&str; 9] = [
    "beta_rad",
    "hip_height_m",
    "pitch_rad",
    "omega_rad_s",
    "forward_m_s",
    "up_m_s",
    "b_k",
    "a",
    "lateral_m_s",
];

/// The names of its outputs: the forces, then the rest of the wrench.
const BATCH_OUTPUTS: [&str; 6] = [
    "drag_n",
    "lift_n",
    "hip_torque_nm",
    "side_n",
    "roll_moment_nm",
    "yaw_moment_nm",
];

/// `a` as a C-contiguous array of `T` of `shape`, or an error naming it, its shape and dtype,
/// and the batch's.
fn batch_array<'py, T: numpy::Element>(
    name: &str,
    a: &Bound<'py, PyAny>,
    shape: &[usize],
) -> PyResult<Bound<'py, PyArrayDyn<T>>> {
    let want = || {
        format!(
            "{} {shape:?}",
            std::any::type_name::<T>().replace("f", "float")
        )
    };
    let arr = a.cast::<PyArrayDyn<T>>().map_err(|_| {
        let got = a
            .cast::<numpy::PyUntypedArray>()
            .map(|u| format!("{} {:?}", u.dtype(), u.shape()))
            .unwrap_or_else(|_| a.get_type().to_string());
        TerzaghiError::new_err(format!(
            "{name} is {got}, the batch {}: give every array the batch's dtype and shape",
            want()
        ))
    })?;
    if arr.shape() != shape {
        return Err(TerzaghiError::new_err(format!(
            "{name} has shape {:?}, the batch {}",
            arr.shape(),
            want()
        )));
    }
    if !arr.is_c_contiguous() {
        return Err(TerzaghiError::new_err(format!(
            "{name} must be C-contiguous (np.ascontiguousarray)"
        )));
    }
    Ok(arr.clone())
}

/// `run(c, outputs)` over each chunk `c` of [`CHUNK`] legs of the outputs (each the same
/// length), the calling thread taking chunks beside rayon's threads (each takes the next chunk
/// not yet taken): the caller neither sleeps while the pool works nor waits for a thread to
/// wake before starting, and a robot's few legs or a pool of one thread run on the caller
/// alone. The error of the first chunk that failed (by its place), if any.
fn shared_chunks<T: Send, E: Send>(
    outputs: Vec<&mut [T]>,
    run: impl Fn(usize, &mut [&mut [T]]) -> Option<E> + Sync,
) -> Option<E> {
    use std::sync::Mutex;
    use std::sync::atomic::{AtomicUsize, Ordering};
    let mut parts: Vec<_> = outputs.into_iter().map(|o| o.chunks_mut(CHUNK)).collect();
    let mut chunks = Vec::new();
    loop {
        let chunk: Vec<&mut [T]> = parts.iter_mut().filter_map(Iterator::next).collect();
        if chunk.is_empty() {
            break;
        }
        chunks.push(Mutex::new(chunk));
    }
    let helpers = rayon::current_num_threads()
        .min(chunks.len())
        .saturating_sub(1);
    let next = AtomicUsize::new(0);
    let failed: Mutex<Option<(usize, E)>> = Mutex::new(None);
    let work = || {
        loop {
            let c = next.fetch_add(1, Ordering::Relaxed);
            let Some(chunk) = chunks.get(c) else { break };
            // Each chunk is taken once: its lock is never contended.
            let mut guard = chunk.lock().unwrap_or_else(|e| e.into_inner());
            if let Some(e) = run(c, &mut guard) {
                let mut f = failed.lock().unwrap_or_else(|e| e.into_inner());
                if f.as_ref().is_none_or(|(first, _)| c < *first) {
                    *f = Some((c, e));
                }
            }
        }
    };
    if helpers == 0 {
        work();
    } else {
        rayon::in_place_scope(|s| {
            for _ in 0..helpers {
                s.spawn(|_| work());
            }
            work();
        });
    }
    failed
        .into_inner()
        .unwrap_or_else(|e| e.into_inner())
        .map(|(_, e)| e)
}

impl Batch {
    /// [`Batch::forces_into`] in `T`: three outputs (the forces) or six (the whole wrench).
    fn forces_as<T: numpy::Element + terzaghi::model::batch::Real>(
        &self,
        py: Python<'_>,
        inputs: [Option<&Bound<'_, PyAny>>; 9],
        outputs: &[&Bound<'_, PyAny>],
    ) -> PyResult<()> {
        use numpy::PyArrayMethods;
        use terzaghi::model::batch::{LegForcesOut, LegSideOut, Legs};
        let beta = inputs[0].expect("beta_rad is required");
        let shape = beta
            .cast::<numpy::PyUntypedArray>()
            .map(|u| u.shape().to_vec())
            .map_err(|_| TerzaghiError::new_err("beta_rad must be a numpy array"))?;
        if !self.kernel.takes_fitting_width() {
            for (name, a) in [("b_k", inputs[6]), ("a", inputs[7])] {
                if a.is_some() {
                    return Err(TerzaghiError::new_err(format!(
                        "{name}: a fitting width per leg is the improved model's, and this batch's model is not it"
                    )));
                }
            }
        }
        let wrench = outputs.len() == 6;
        if !wrench && inputs[8].is_some() {
            return Err(TerzaghiError::new_err(
                "lateral_m_s: a sideways motion gives a side force and moments; ask for the whole wrench (wrenches) to have them",
            ));
        }
        let mut ins = Vec::with_capacity(9);
        for (name, a) in BATCH_INPUTS.iter().zip(inputs) {
            ins.push(
                a.map(|a| batch_array::<T>(name, a, &shape).map(|a| a.readonly()))
                    .transpose()?,
            );
        }
        let mut outs = Vec::with_capacity(outputs.len());
        for (name, a) in BATCH_OUTPUTS.iter().zip(outputs) {
            let a = batch_array::<T>(name, a, &shape)?;
            outs.push(a.try_readwrite().map_err(|_| {
                TerzaghiError::new_err(format!(
                    "{name} is an input too, or not writeable: give each output its own writeable array"
                ))
            })?);
        }
        let slice = |i: usize| -> Option<&[T]> {
            ins[i]
                .as_ref()
                .map(|a| a.as_slice().expect("checked C-contiguous"))
        };
        let legs = Legs {
            beta_rad: slice(0).expect("given"),
            hip_height_m: slice(1)
                .ok_or_else(|| TerzaghiError::new_err("hip_height_m is required"))?,
            pitch_rad: slice(2),
            omega_rad_s: slice(3),
            forward_m_s: slice(4),
            up_m_s: slice(5),
            b_k: slice(6),
            a: slice(7),
        };
        let lateral = slice(8);
        let slices: Vec<&mut [T]> = outs
            .iter_mut()
            .map(|o| o.as_slice_mut().expect("checked C-contiguous"))
            .collect();
        let kernel = &self.kernel;
        let failed = py.detach(|| {
            let run = |c: usize, o: &mut [&mut [T]]| {
                let (forces, more) = o.split_at_mut(3);
                let [d, l, t] = forces else {
                    unreachable!("three forces")
                };
                let out = LegForcesOut {
                    drag_n: d,
                    lift_n: l,
                    hip_torque_nm: t,
                };
                match more {
                    [s, r, y] => kernel.wrenches(
                        &legs,
                        lateral,
                        c * CHUNK,
                        out,
                        LegSideOut {
                            side_n: s,
                            roll_moment_nm: r,
                            yaw_moment_nm: y,
                        },
                    ),
                    _ => kernel.forces(&legs, c * CHUNK, out),
                }
                .err()
            };
            shared_chunks(slices, run)
        });
        match failed {
            Some(e) => Err(TerzaghiError::new_err(e.to_string())),
            None => Ok(()),
        }
    }
}

#[pymethods]
impl Batch {
    #[new]
    #[pyo3(signature = (model, length_m, width_m, medium, unit_weight_n_m3, phi_deg, delta_deg, b_k, a, rft_coeffs, rft_zeta, rft_elements, shape, c_leg_radius_m, c_leg_span_deg, profile, medium_file, body=None, planar_sheared_bearing=false))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        model: &str,
        length_m: f64,
        width_m: f64,
        medium: Option<String>,
        unit_weight_n_m3: Option<f64>,
        phi_deg: Option<f64>,
        delta_deg: Option<f64>,
        b_k: Option<f64>,
        a: Option<f64>,
        rft_coeffs: Option<String>,
        rft_zeta: Option<f64>,
        rft_elements: usize,
        shape: &str,
        c_leg_radius_m: Option<f64>,
        c_leg_span_deg: Option<f64>,
        profile: Option<Vec<(f64, f64)>>,
        medium_file: Option<std::path::PathBuf>,
        body: Option<BodyArgs>,
        planar_sheared_bearing: bool,
    ) -> PyResult<Self> {
        // The hip height is given per leg and step; 0 to build.
        let mut model = spec(
            model,
            length_m,
            width_m,
            0.0,
            medium,
            unit_weight_n_m3,
            phi_deg,
            delta_deg,
            b_k,
            a,
            rft_coeffs,
            rft_zeta,
            rft_elements,
            shape,
            c_leg_radius_m,
            c_leg_span_deg,
            profile,
            medium_file,
        )?;
        model.planar_sheared_bearing = planar_sheared_bearing;
        if let Some(b) = body {
            model = with_body(model, b)?;
        }
        let model = model.build().map_err(err)?;
        Ok(Batch {
            kernel: terzaghi::model::batch::LegKernel::new(model),
        })
    }

    /// Whether the model's legs go through the vector loop (RFT with fitted coefficients).
    #[getter]
    fn vectorised(&self) -> bool {
        self.kernel.is_vectorised()
    }

    /// Whether the model takes `b_k` and `a` per leg (the improved model).
    #[getter]
    fn takes_fitting_width(&self) -> bool {
        self.kernel.takes_fitting_width()
    }

    /// Writes the forces at every element of the inputs (one shape and dtype, float64 or
    /// float32, C-contiguous: `beta_rad`'s) into `drag_n`, `lift_n` and `hip_torque_nm` (the
    /// same), and with `side_n`, `roll_moment_nm` and `yaw_moment_nm` (all three or none) the
    /// rest of the wrench, the hips moving to their left at `lateral_m_s` (only with them).
    /// Inputs left out are zero (`b_k`, `a`: the model's). A non-finite input is an error
    /// naming its flat index (the outputs are then partly written).
    #[pyo3(signature = (beta_rad, hip_height_m, pitch_rad, omega_rad_s, forward_m_s, up_m_s, b_k, a, drag_n, lift_n, hip_torque_nm, lateral_m_s=None, side_n=None, roll_moment_nm=None, yaw_moment_nm=None))]
    #[allow(clippy::too_many_arguments)]
    fn forces_into(
        &self,
        py: Python<'_>,
        beta_rad: &Bound<'_, PyAny>,
        hip_height_m: &Bound<'_, PyAny>,
        pitch_rad: Option<&Bound<'_, PyAny>>,
        omega_rad_s: Option<&Bound<'_, PyAny>>,
        forward_m_s: Option<&Bound<'_, PyAny>>,
        up_m_s: Option<&Bound<'_, PyAny>>,
        b_k: Option<&Bound<'_, PyAny>>,
        a: Option<&Bound<'_, PyAny>>,
        drag_n: &Bound<'_, PyAny>,
        lift_n: &Bound<'_, PyAny>,
        hip_torque_nm: &Bound<'_, PyAny>,
        lateral_m_s: Option<&Bound<'_, PyAny>>,
        side_n: Option<&Bound<'_, PyAny>>,
        roll_moment_nm: Option<&Bound<'_, PyAny>>,
        yaw_moment_nm: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let inputs = [
            Some(beta_rad),
            Some(hip_height_m),
            pitch_rad,
            omega_rad_s,
            forward_m_s,
            up_m_s,
            b_k,
            a,
            lateral_m_s,
        ];
        let mut outputs = vec![drag_n, lift_n, hip_torque_nm];
        match (side_n, roll_moment_nm, yaw_moment_nm) {
            (Some(s), Some(r), Some(y)) => outputs.extend([s, r, y]),
            (None, None, None) => {}
            _ => {
                return Err(TerzaghiError::new_err(
                    "side_n, roll_moment_nm, yaw_moment_nm: give all three or none",
                ));
            }
        }
        if beta_rad.cast::<PyArrayDyn<f32>>().is_ok() {
            self.forces_as::<f32>(py, inputs, &outputs)
        } else {
            self.forces_as::<f64>(py, inputs, &outputs)
        }
    }
}

/// A session written to MCAP in the node's topics and types, with the node's parameters as
/// its metadata: what `terzaghi diagnose` and `replay --reevaluate` read.
#[pyclass(module = "terzaghi._terzaghi", name = "Recorder", unsendable)]
struct Recorder {
    w: Option<terzaghi::record::SessionWriter<std::io::BufWriter<std::fs::File>>>,
    path: std::path::PathBuf,
    messages: u64,
}

fn header(t_ns: i64, frame_id: &str) -> PyResult<terzaghi::msgs::Header> {
    Ok(terzaghi::msgs::Header {
        stamp: terzaghi::msgs::Time::from_nanos(t_ns).ok_or_else(|| {
            TerzaghiError::new_err(format!("t_ns = {t_ns}: not a time a ROS stamp can hold"))
        })?,
        frame_id: frame_id.to_string(),
    })
}

impl Recorder {
    fn writer(
        &mut self,
    ) -> PyResult<&mut terzaghi::record::SessionWriter<std::io::BufWriter<std::fs::File>>> {
        self.w
            .as_mut()
            .ok_or_else(|| TerzaghiError::new_err(format!("{} is closed", self.path.display())))
    }

    fn put<M: terzaghi::msgs::RosMessage>(
        &mut self,
        topic: &str,
        msg: &M,
        t_ns: i64,
    ) -> PyResult<()> {
        let t = u64::try_from(t_ns)
            .map_err(|_| TerzaghiError::new_err(format!("t_ns = {t_ns}: before 1970")))?;
        self.writer()?
            .write(topic, terzaghi::record::OfferedQos::BEST_EFFORT, msg, t, t)
            .map_err(err)?;
        self.messages += 1;
        Ok(())
    }
}

#[pymethods]
impl Recorder {
    #[new]
    #[pyo3(signature = (path, params, overwrite))]
    fn new(
        path: std::path::PathBuf,
        params: Vec<(String, String)>,
        overwrite: bool,
    ) -> PyResult<Self> {
        terzaghi::session::files::refuse_existing_recording(&path, overwrite).map_err(err)?;
        let file = std::fs::File::create(&path)
            .map_err(|e| TerzaghiError::new_err(format!("cannot write {}: {e}", path.display())))?;
        let w = terzaghi::record::SessionWriter::new(
            std::io::BufWriter::new(file),
            terzaghi::record::RecordOptions {
                params: params.into_iter().collect(),
                ..Default::default()
            },
        )
        .map_err(err)?;
        Ok(Recorder {
            w: Some(w),
            path,
            messages: 0,
        })
    }

    /// A sensor_msgs/JointState on `topic`.
    #[pyo3(signature = (topic, t_ns, names, position, velocity))]
    fn joint_state(
        &mut self,
        topic: &str,
        t_ns: i64,
        names: Vec<String>,
        position: Vec<f64>,
        velocity: Vec<f64>,
    ) -> PyResult<()> {
        if position.len() != names.len() || !(velocity.is_empty() || velocity.len() == names.len())
        {
            return Err(TerzaghiError::new_err(format!(
                "{} names, {} positions, {} velocities: give one position (and velocity) per name",
                names.len(),
                position.len(),
                velocity.len()
            )));
        }
        let msg = terzaghi::msgs::JointState {
            header: header(t_ns, "")?,
            name: names,
            position,
            velocity,
            effort: Vec::new(),
        };
        self.put(topic, &msg, t_ns)
    }

    /// A geometry_msgs/WrenchStamped on `topic`.
    #[pyo3(signature = (topic, t_ns, frame_id, force, torque))]
    fn wrench(
        &mut self,
        topic: &str,
        t_ns: i64,
        frame_id: &str,
        force: [f64; 3],
        torque: [f64; 3],
    ) -> PyResult<()> {
        let v = |a: [f64; 3]| terzaghi::msgs::Vector3 {
            x: a[0],
            y: a[1],
            z: a[2],
        };
        let msg = terzaghi::msgs::WrenchStamped {
            header: header(t_ns, frame_id)?,
            wrench: terzaghi::msgs::Wrench {
                force: v(force),
                torque: v(torque),
            },
        };
        self.put(topic, &msg, t_ns)
    }

    /// A geometry_msgs/PoseStamped on `topic` (orientation as x, y, z, w).
    #[pyo3(signature = (topic, t_ns, frame_id, position, orientation))]
    fn pose(
        &mut self,
        topic: &str,
        t_ns: i64,
        frame_id: &str,
        position: [f64; 3],
        orientation: [f64; 4],
    ) -> PyResult<()> {
        let msg = terzaghi::msgs::PoseStamped {
            header: header(t_ns, frame_id)?,
            pose: terzaghi::msgs::Pose {
                position: terzaghi::msgs::Point {
                    x: position[0],
                    y: position[1],
                    z: position[2],
                },
                orientation: terzaghi::msgs::Quaternion {
                    x: orientation[0],
                    y: orientation[1],
                    z: orientation[2],
                    w: orientation[3],
                },
            },
        };
        self.put(topic, &msg, t_ns)
    }

    /// Finishes the file (its summary and index); returns the messages written.
    fn close(&mut self) -> PyResult<u64> {
        if let Some(w) = self.w.take() {
            use std::io::Write;
            let mut f = w.finish().map_err(err)?;
            f.flush().map_err(|e| {
                TerzaghiError::new_err(format!("cannot write {}: {e}", self.path.display()))
            })?;
        }
        Ok(self.messages)
    }
}

/// The node's core (no DDS, no clock): its parameters (a `corrected.yaml` of the diagnosis,
/// a robot's parameter file, overrides), fed the messages a robot would send it, predicting
/// each leg's force as the node publishes it.
#[pyclass(module = "terzaghi._terzaghi", name = "Node", unsendable)]
struct Node {
    core: terzaghi::node::core::NodeCore,
    out: terzaghi::node::core::Outputs,
    params: Vec<(String, String)>,
    joints: terzaghi::msgs::JointState,
}

/// The fields of each leg's prediction that [`Node::joint_state`] returns, in order.
const NODE_FIELDS: [&str; 10] = [
    "drag_n",
    "lift_n",
    "hip_torque_nm",
    "sensor_drag_n",
    "sensor_lift_n",
    "bare_drag_n",
    "bare_lift_n",
    "hip_height_m",
    "attack_angle_rad",
    "regime",
];

#[pymethods]
impl Node {
    #[new]
    #[pyo3(signature = (params_file, params))]
    fn new(
        params_file: Option<std::path::PathBuf>,
        params: Vec<(String, String)>,
    ) -> PyResult<Self> {
        let ros = terzaghi::config::RosArgs {
            params: params
                .into_iter()
                .map(|(k, v)| {
                    let v = terzaghi::config::parse_value(&v);
                    (k, v)
                })
                .collect(),
            params_files: params_file.into_iter().collect(),
            ..Default::default()
        };
        let map = terzaghi::config::load_params(&ros, "terzaghi", "/").map_err(err)?;
        let cfg =
            terzaghi::config::NodeConfig::from_params(&map, "terzaghi", "/", &[]).map_err(err)?;
        Ok(Node {
            core: terzaghi::node::core::NodeCore::new(cfg),
            out: Default::default(),
            params: map
                .iter()
                .map(|(k, v)| (k.clone(), v.to_string()))
                .collect(),
            joints: Default::default(),
        })
    }

    /// The legs' names, in the order of the `legs` parameter.
    fn legs(&self) -> Vec<String> {
        self.core
            .config()
            .legs
            .iter()
            .map(|l| l.name.clone())
            .collect()
    }

    /// The parameters the node runs with (defaults, the file, the overrides), as text.
    fn params(&self) -> Vec<(String, String)> {
        self.params.clone()
    }

    /// The body's pose (`robot_state.pose_topic`), position (m) and orientation `(x, y, z,
    /// w)`, in `frame_id` ("" for the world frame).
    #[pyo3(signature = (t_ns, position, orientation_xyzw, frame_id))]
    fn pose(
        &mut self,
        t_ns: i64,
        position: [f64; 3],
        orientation_xyzw: [f64; 4],
        frame_id: &str,
    ) -> PyResult<()> {
        let [x, y, z, w] = orientation_xyzw;
        let msg = terzaghi::msgs::PoseStamped {
            header: header(t_ns, frame_id)?,
            pose: terzaghi::msgs::Pose {
                position: terzaghi::msgs::Point {
                    x: position[0],
                    y: position[1],
                    z: position[2],
                },
                orientation: terzaghi::msgs::Quaternion { x, y, z, w },
            },
        };
        self.out.clear();
        self.core
            .handle(terzaghi::node::core::Input::Pose(&msg), &mut self.out);
        Ok(())
    }

    /// A measured wrench of leg `leg` (by index), in its sensor's frame: what the node learns
    /// from.
    #[pyo3(signature = (leg, t_ns, force, torque, frame_id))]
    fn wrench(
        &mut self,
        leg: usize,
        t_ns: i64,
        force: [f64; 3],
        torque: [f64; 3],
        frame_id: &str,
    ) -> PyResult<()> {
        let n = self.core.legs();
        if leg >= n {
            return Err(TerzaghiError::new_err(format!(
                "leg {leg}: the node has {n} legs"
            )));
        }
        let v = |a: [f64; 3]| terzaghi::msgs::Vector3 {
            x: a[0],
            y: a[1],
            z: a[2],
        };
        let msg = terzaghi::msgs::WrenchStamped {
            header: header(t_ns, frame_id)?,
            wrench: terzaghi::msgs::Wrench {
                force: v(force),
                torque: v(torque),
            },
        };
        self.out.clear();
        self.core.handle(
            terzaghi::node::core::Input::Wrench(leg, &msg),
            &mut self.out,
        );
        Ok(())
    }

    /// A JointState: each configured leg whose joint it names is predicted. Returns, per field
    /// of [`NODE_FIELDS`], one value per leg (in the order of [`Node::legs`]; NaN for a leg
    /// the message does not predict).
    #[pyo3(signature = (t_ns, names, position, velocity))]
    fn joint_state(
        &mut self,
        t_ns: i64,
        names: Vec<String>,
        position: Vec<f64>,
        velocity: Vec<f64>,
    ) -> PyResult<Vec<Vec<f64>>> {
        if position.len() != names.len() || !(velocity.is_empty() || velocity.len() == names.len())
        {
            return Err(TerzaghiError::new_err(format!(
                "{} names, {} positions, {} velocities: give one position (and velocity, or none) per name",
                names.len(),
                position.len(),
                velocity.len()
            )));
        }
        self.joints.header = header(t_ns, "")?;
        self.joints.name = names;
        self.joints.position = position;
        self.joints.velocity = velocity;
        self.out.clear();
        self.core.handle(
            terzaghi::node::core::Input::Joints(&self.joints),
            &mut self.out,
        );
        let mut cols = vec![vec![f64::NAN; self.core.legs()]; NODE_FIELDS.len()];
        for o in &self.out.legs {
            let f = &o.force;
            let v = [
                f.drag_n,
                f.lift_n,
                f.hip_torque_nm,
                f.sensor_drag_n,
                f.sensor_lift_n,
                f.bare_drag_n,
                f.bare_lift_n,
                f.hip_height_m,
                f.attack_angle_rad,
                f64::from(f.regime),
            ];
            for (c, x) in cols.iter_mut().zip(v) {
                c[o.leg] = x;
            }
        }
        Ok(cols)
    }
}

/// The shipped six-legged robot's node parameters (`launch_configs/rhex.yaml` over the
/// defaults), as `name`, value text pairs.
#[pyfunction]
fn rhex_params() -> PyResult<Vec<(String, String)>> {
    let (params, _) = terzaghi::sim::robot::rhex().map_err(err)?;
    Ok(params
        .iter()
        .map(|(k, v)| (k.clone(), v.to_string()))
        .collect())
}

/// The native module.
#[pymodule]
fn _terzaghi(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("TerzaghiError", m.py().get_type::<TerzaghiError>())?;
    m.add_function(wrap_pyfunction!(predict, m)?)?;
    m.add_function(wrap_pyfunction!(steady, m)?)?;
    m.add_function(wrap_pyfunction!(medium_band, m)?)?;
    m.add_function(wrap_pyfunction!(predict_moving, m)?)?;
    m.add_function(wrap_pyfunction!(read_topics, m)?)?;
    m.add_function(wrap_pyfunction!(fit_json, m)?)?;
    m.add_function(wrap_pyfunction!(diagnose_json, m)?)?;
    m.add_function(wrap_pyfunction!(recording_info, m)?)?;
    m.add_function(wrap_pyfunction!(reevaluate, m)?)?;
    m.add("REEVALUATE_COLUMNS", COLUMNS.to_vec())?;
    m.add_class::<Online>()?;
    m.add_class::<Batch>()?;
    m.add_class::<free_base::FreeBase>()?;
    m.add_class::<Recorder>()?;
    m.add_class::<Node>()?;
    m.add("NODE_FIELDS", NODE_FIELDS.to_vec())?;
    m.add_function(wrap_pyfunction!(rhex_params, m)?)?;
    m.add(
        "REGIMES",
        terzaghi::model::Regime::ALL
            .iter()
            .map(|r| r.as_str())
            .collect::<Vec<_>>(),
    )?;
    Ok(())
}
