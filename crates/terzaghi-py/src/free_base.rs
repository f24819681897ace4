//! The kinematics of `terzaghi.mujoco.BatchCoupling`: many environments' MuJoCo states (rows of
//! `mjSTATE_FULLPHYSICS`) in, each leg's model inputs out; each leg's drag, lift and hip torque
//! in, the wrench at its body's centre of mass out, into the rows of a rollout's control
//! (`xfrc_applied`). The robot is a torso on a free joint with legs hinged to it about its +y
//! axis, each leg's hinge at its body's origin (the hip); Python checks the model is so.

use numpy::{PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use rayon::prelude::*;

use crate::TerzaghiError;
use terzaghi::model::batch::{LANES, atan2_lanes, sin_cos_lanes};

/// Environments per task.
const ENVS_PER_TASK: usize = 256;

/// The torso's frame and motion in one environment.
struct Torso {
    /// Position of its origin in the world (m).
    p: [f64; 3],
    /// Rotation to the world: columns are its axes.
    r: [[f64; 3]; 3],
    /// Linear velocity of its origin (world, m/s).
    v: [f64; 3],
    /// Angular velocity (world, rad/s).
    w: [f64; 3],
    /// Its heading: its +x axis in the horizontal plane, of unit length.
    fwd: [f64; 2],
    /// Its pitch, nose down positive (rad).
    pitch_rad: f64,
}

#[inline(always)]
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[inline(always)]
fn rotate(r: &[[f64; 3]; 3], x: [f64; 3]) -> [f64; 3] {
    [
        r[0][0] * x[0] + r[0][1] * x[1] + r[0][2] * x[2],
        r[1][0] * x[0] + r[1][1] * x[1] + r[1][2] * x[2],
        r[2][0] * x[0] + r[2][1] * x[1] + r[2][2] * x[2],
    ]
}

impl Torso {
    /// From a state row: the free joint's position and quaternion (w, x, y, z) at `qpos0`, its
    /// world linear and local angular velocity at `qvel0`. `None` for a quaternion of no length.
    #[inline(always)]
    fn from_state(row: &[f64], qpos0: usize, qvel0: usize) -> Option<Torso> {
        let p = [row[qpos0], row[qpos0 + 1], row[qpos0 + 2]];
        let q = &row[qpos0 + 3..qpos0 + 7];
        let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
        if !(n > 0.0 && n.is_finite()) {
            return None;
        }
        let (w, x, y, z) = (q[0] / n, q[1] / n, q[2] / n, q[3] / n);
        let r = [
            [
                1.0 - 2.0 * (y * y + z * z),
                2.0 * (x * y - w * z),
                2.0 * (x * z + w * y),
            ],
            [
                2.0 * (x * y + w * z),
                1.0 - 2.0 * (x * x + z * z),
                2.0 * (y * z - w * x),
            ],
            [
                2.0 * (x * z - w * y),
                2.0 * (y * z + w * x),
                1.0 - 2.0 * (x * x + y * y),
            ],
        ];
        let v = [row[qvel0], row[qvel0 + 1], row[qvel0 + 2]];
        let w = rotate(&r, [row[qvel0 + 3], row[qvel0 + 4], row[qvel0 + 5]]);
        // The columns are of unit length: no overflow to guard against.
        let norm = (r[0][0] * r[0][0] + r[1][0] * r[1][0]).sqrt();
        let fwd = if norm > 0.0 {
            [r[0][0] / norm, r[1][0] / norm]
        } else {
            [1.0, 0.0]
        };
        Some(Torso {
            p,
            r,
            v,
            w,
            fwd,
            // Set by `Torso::pitch_all`, sixteen at a time.
            pitch_rad: f64::NAN,
        })
    }

    /// Each torso's pitch, `atan2(-r20, |r00, r10|)`, sixteen at a time.
    #[inline(always)]
    fn pitch_all(torsos: &mut [Option<Torso>]) {
        for block in torsos.chunks_mut(LANES) {
            let (mut y, mut x) = ([0.0; LANES], [1.0; LANES]);
            for (k, t) in block.iter().enumerate() {
                if let Some(t) = t {
                    y[k] = -t.r[2][0];
                    x[k] = (t.r[0][0] * t.r[0][0] + t.r[1][0] * t.r[1][0]).sqrt();
                }
            }
            let pitch = atan2_lanes(&y, &x);
            for (t, p) in block.iter_mut().zip(pitch) {
                if let Some(t) = t {
                    t.pitch_rad = p;
                }
            }
        }
    }
}

/// The layout of one model's environments: where the torso and legs are in a state row, and
/// where each leg's `xfrc_applied` is in a control row.
#[pyclass(module = "terzaghi._terzaghi", name = "FreeBase")]
pub(crate) struct FreeBase {
    qpos0: usize,
    qvel0: usize,
    nstate: usize,
    joint_qpos: Vec<usize>,
    joint_dof: Vec<usize>,
    /// Each hip in the torso's frame (m).
    hip_m: Vec<[f64; 3]>,
    /// Each leg's centre of mass from its hip, in the torso's frame at joint angle 0 (m).
    com_m: Vec<[f64; 3]>,
    /// Each leg's `xfrc_applied` in a control row.
    xfrc: Vec<usize>,
    ncontrol: usize,
    surface_z_m: f64,
}

/// `a` as a C-contiguous (rows, cols) float64 array, or an error naming it and both shapes.
fn rows<'py>(name: &str, a: &Bound<'py, PyArray2<f64>>, rows: usize, cols: usize) -> PyResult<()> {
    if a.shape() != [rows, cols] || !a.is_c_contiguous() {
        return Err(TerzaghiError::new_err(format!(
            "{name} has shape {:?}{}, expected ({rows}, {cols}) C-contiguous float64",
            a.shape(),
            if a.is_c_contiguous() {
                ""
            } else {
                " (not C-contiguous)"
            }
        )));
    }
    Ok(())
}

#[pymethods]
impl FreeBase {
    #[new]
    #[pyo3(signature = (qpos0, qvel0, nstate, joint_qpos, joint_dof, hip_m, com_m, xfrc, ncontrol, surface_z_m))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        qpos0: usize,
        qvel0: usize,
        nstate: usize,
        joint_qpos: Vec<usize>,
        joint_dof: Vec<usize>,
        hip_m: Vec<[f64; 3]>,
        com_m: Vec<[f64; 3]>,
        xfrc: Vec<usize>,
        ncontrol: usize,
        surface_z_m: f64,
    ) -> PyResult<Self> {
        let n = joint_qpos.len();
        if [joint_dof.len(), hip_m.len(), com_m.len(), xfrc.len()] != [n; 4] {
            return Err(TerzaghiError::new_err(
                "FreeBase: one entry per leg in each list",
            ));
        }
        let in_row = |i: usize| i < nstate;
        if qpos0 + 7 > nstate
            || qvel0 + 6 > nstate
            || !joint_qpos.iter().chain(&joint_dof).all(|&i| in_row(i))
            || xfrc.iter().any(|&i| i + 6 > ncontrol)
        {
            return Err(TerzaghiError::new_err(
                "FreeBase: an address beyond the state or control row",
            ));
        }
        if !surface_z_m.is_finite() {
            return Err(TerzaghiError::new_err(format!(
                "surface_z_m = {surface_z_m}: not a finite height"
            )));
        }
        Ok(FreeBase {
            qpos0,
            qvel0,
            nstate,
            joint_qpos,
            joint_dof,
            hip_m,
            com_m,
            xfrc,
            ncontrol,
            surface_z_m,
        })
    }

    /// One step's coupling in one call: each environment's legs read from `state` into the
    /// six input arrays, evaluated by `batch` (with `b_k` and `a` per leg where given) into
    /// `drag_n`, `lift_n` and `hip_torque_nm`, and their wrenches written into `control`, a
    /// chunk of environments at a time on every core. With `lateral_m_s`, `side_n`,
    /// `roll_moment_nm` and `yaw_moment_nm` (all four or none: a body's legs) each hip's
    /// velocity across the torso's heading is read too and the whole wrench applied. A leg the
    /// model refuses is an error naming its environment and leg.
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (state, batch, b_k, a, beta_rad, hip_height_m, pitch_rad, omega_rad_s, forward_m_s, up_m_s, drag_n, lift_n, hip_torque_nm, control, lateral_m_s=None, side_n=None, roll_moment_nm=None, yaw_moment_nm=None))]
    fn apply(
        &self,
        py: Python<'_>,
        state: &Bound<'_, PyArray2<f64>>,
        batch: PyRef<'_, crate::Batch>,
        b_k: Option<&Bound<'_, PyArray2<f64>>>,
        a: Option<&Bound<'_, PyArray2<f64>>>,
        beta_rad: &Bound<'_, PyArray2<f64>>,
        hip_height_m: &Bound<'_, PyArray2<f64>>,
        pitch_rad: &Bound<'_, PyArray2<f64>>,
        omega_rad_s: &Bound<'_, PyArray2<f64>>,
        forward_m_s: &Bound<'_, PyArray2<f64>>,
        up_m_s: &Bound<'_, PyArray2<f64>>,
        drag_n: &Bound<'_, PyArray2<f64>>,
        lift_n: &Bound<'_, PyArray2<f64>>,
        hip_torque_nm: &Bound<'_, PyArray2<f64>>,
        control: &Bound<'_, PyArray2<f64>>,
        lateral_m_s: Option<&Bound<'_, PyArray2<f64>>>,
        side_n: Option<&Bound<'_, PyArray2<f64>>>,
        roll_moment_nm: Option<&Bound<'_, PyArray2<f64>>>,
        yaw_moment_nm: Option<&Bound<'_, PyArray2<f64>>>,
    ) -> PyResult<()> {
        let n_env = state.shape()[0];
        let n_leg = self.joint_qpos.len();
        rows("state", state, n_env, self.nstate)?;
        rows("control", control, n_env, self.ncontrol)?;
        let media = [("b_k", b_k), ("a", a)];
        for (name, m) in media {
            if let Some(m) = m {
                rows(name, m, n_env, n_leg)?;
            }
        }
        let mut arrays = vec![
            ("beta_rad", beta_rad),
            ("hip_height_m", hip_height_m),
            ("pitch_rad", pitch_rad),
            ("omega_rad_s", omega_rad_s),
            ("forward_m_s", forward_m_s),
            ("up_m_s", up_m_s),
            ("drag_n", drag_n),
            ("lift_n", lift_n),
            ("hip_torque_nm", hip_torque_nm),
        ];
        let wrench = match (lateral_m_s, side_n, roll_moment_nm, yaw_moment_nm) {
            (Some(l), Some(s), Some(r), Some(y)) => {
                arrays.extend([
                    ("lateral_m_s", l),
                    ("side_n", s),
                    ("roll_moment_nm", r),
                    ("yaw_moment_nm", y),
                ]);
                true
            }
            (None, None, None, None) => false,
            _ => {
                return Err(TerzaghiError::new_err(
                    "lateral_m_s, side_n, roll_moment_nm, yaw_moment_nm: give all four or none",
                ));
            }
        };
        for (name, x) in &arrays {
            rows(name, x, n_env, n_leg)?;
        }
        let state = state.readonly();
        let (b_k, a) = (b_k.map(|x| x.readonly()), a.map(|x| x.readonly()));
        let mut w: Vec<_> = arrays
            .iter()
            .map(|(name, x)| {
                x.try_readwrite().map_err(|_| {
                    TerzaghiError::new_err(format!("{name}: not writeable, or given twice"))
                })
            })
            .collect::<PyResult<_>>()?;
        let mut c = control
            .try_readwrite()
            .map_err(|_| TerzaghiError::new_err("control: not writeable"))?;
        let state = state.as_slice().expect("checked C-contiguous");
        let b_k = b_k
            .as_ref()
            .map(|x| x.as_slice().expect("checked C-contiguous"));
        let a = a
            .as_ref()
            .map(|x| x.as_slice().expect("checked C-contiguous"));
        let c = c.as_slice_mut().expect("checked C-contiguous");
        let kernel = &batch.kernel;
        let chunk = ENVS_PER_TASK * n_leg.max(1);
        // Each task's environments: their rows, and their legs' part of every array.
        let mut parts: Vec<_> = w
            .iter_mut()
            .map(|x| {
                x.as_slice_mut()
                    .expect("checked C-contiguous")
                    .chunks_mut(chunk)
            })
            .collect();
        let mut tasks = Vec::new();
        let rows = state
            .chunks(ENVS_PER_TASK * self.nstate)
            .zip(c.chunks_mut(ENVS_PER_TASK * self.ncontrol));
        for (k, (s, c)) in rows.enumerate() {
            // No legs: every leg array is empty, and each task's part of it too.
            let mut next = parts.iter_mut().map(|p| p.next().unwrap_or_default());
            let mut take = || next.next().expect("an array per part");
            let ins: [&mut [f64]; 6] = std::array::from_fn(|_| take());
            let outs: [&mut [f64]; 3] = std::array::from_fn(|_| take());
            let more = wrench.then(|| {
                let lateral = take();
                (lateral, std::array::from_fn(|_| take()))
            });
            let first = k * chunk;
            let span = first..first + ins[0].len();
            let media = (b_k.map(|m| &m[span.clone()]), a.map(|m| &m[span]));
            tasks.push((
                first,
                Chunk {
                    state: s,
                    control: c,
                    ins,
                    outs,
                    more,
                    media,
                },
            ));
        }
        let failed = py.detach(|| {
            tasks
                .into_par_iter()
                .map(|(first, task)| {
                    self.chunk(kernel, task).map(|(leg, why)| {
                        let leg = first + leg;
                        let n = n_leg.max(1);
                        format!("environment {}, leg {}: {why}", leg / n, leg % n)
                    })
                })
                .find_first(Option::is_some)
                .flatten()
        });
        match failed {
            Some(e) => Err(TerzaghiError::new_err(e)),
            None => Ok(()),
        }
    }
}

/// One task's environments: their state and control rows (whole rows), their legs' slices of
/// the model's inputs (`[beta, h, pitch, omega, fwd, up]`) and outputs (`[drag, lift, hip
/// torque]`), for a body's legs their sideways velocity and the rest of the wrench (`[side,
/// roll, yaw]`), and their media (`b_k`, `a`) if given.
struct Chunk<'a> {
    state: &'a [f64],
    control: &'a mut [f64],
    ins: [&'a mut [f64]; 6],
    outs: [&'a mut [f64]; 3],
    more: Option<(&'a mut [f64], [&'a mut [f64]; 3])>,
    media: (Option<&'a [f64]>, Option<&'a [f64]>),
}

impl FreeBase {
    /// [`FreeBase::chunk_any`], compiled for AVX2 and FMA where the processor has them.
    fn chunk(
        &self,
        kernel: &terzaghi::model::batch::LegKernel,
        task: Chunk<'_>,
    ) -> Option<(usize, String)> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the processor has the instructions it is compiled for.
            return unsafe { self.chunk_avx2(kernel, task) };
        }
        self.chunk_any(kernel, task)
    }

    /// [`FreeBase::chunk_any`] compiled for AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn chunk_avx2(
        &self,
        kernel: &terzaghi::model::batch::LegKernel,
        task: Chunk<'_>,
    ) -> Option<(usize, String)> {
        self.chunk_any(kernel, task)
    }

    /// [`FreeBase::apply`] for one task's environments: `None`, or the failing leg (its index
    /// among these legs) and why.
    #[inline(always)]
    fn chunk_any(
        &self,
        kernel: &terzaghi::model::batch::LegKernel,
        task: Chunk<'_>,
    ) -> Option<(usize, String)> {
        let Chunk {
            state,
            control,
            ins,
            outs,
            mut more,
            media,
        } = task;
        use terzaghi::model::batch::{LegForcesOut, LegSideOut, Legs};
        let n_leg = self.joint_qpos.len();
        let [beta, h, pitch, omega, fwd, up] = ins;
        let mut torsos: Vec<Option<Torso>> = state
            .chunks(self.nstate)
            .map(|row| Torso::from_state(row, self.qpos0, self.qvel0))
            .collect();
        Torso::pitch_all(&mut torsos);
        for (e, (row, torso)) in state.chunks(self.nstate).zip(&torsos).enumerate() {
            let legs = e * n_leg..(e + 1) * n_leg;
            self.env_in(
                torso.as_ref(),
                row,
                &mut beta[legs.clone()],
                &mut h[legs.clone()],
                &mut pitch[legs.clone()],
                &mut omega[legs.clone()],
                &mut fwd[legs.clone()],
                &mut up[legs.clone()],
                more.as_mut().map(|(lateral, _)| &mut lateral[legs]),
            );
        }
        // The legs' joint angles' sines and cosines, sixteen at a time, to turn their centres
        // of mass.
        let mut sin_cos = vec![(0.0, 0.0); beta.len()];
        for (b, sc) in beta.chunks(LANES).zip(sin_cos.chunks_mut(LANES)) {
            // A whole block by a load of known size (a copy of unknown size is a call).
            let x = <[f64; LANES]>::try_from(b).unwrap_or_else(|_| {
                let mut x = [0.0; LANES];
                x[..b.len()].copy_from_slice(b);
                x
            });
            let (s, c) = sin_cos_lanes(&x);
            for (k, sc) in sc.iter_mut().enumerate() {
                *sc = (s[k], c[k]);
            }
        }
        let [d, l, t] = outs;
        let input = Legs {
            b_k: media.0,
            a: media.1,
            ..Legs::moving([beta, h, pitch, omega, fwd, up])
        };
        let out = LegForcesOut {
            drag_n: d,
            lift_n: l,
            hip_torque_nm: t,
        };
        let done = match more.as_mut() {
            Some((lateral, [s, r, y])) => kernel.wrenches(
                &input,
                Some(lateral),
                0,
                out,
                LegSideOut {
                    side_n: s,
                    roll_moment_nm: r,
                    yaw_moment_nm: y,
                },
            ),
            None => kernel.forces(&input, 0, out),
        };
        if let Err(e) = done {
            return Some((e.index, e.problem.to_string()));
        }
        let rows = control.chunks_mut(self.ncontrol).zip(&torsos);
        for (e, (c, torso)) in rows.enumerate() {
            let legs = e * n_leg..(e + 1) * n_leg;
            let forces = [&d[legs.clone()], &l[legs.clone()], &t[legs.clone()]];
            let rest = more
                .as_ref()
                .map(|(_, [s, r, y])| [&s[legs.clone()], &r[legs.clone()], &y[legs.clone()]]);
            self.env_out(torso.as_ref(), &sin_cos[legs], forces, rest, c);
        }
        None
    }

    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn env_in(
        &self,
        torso: Option<&Torso>,
        row: &[f64],
        beta: &mut [f64],
        h: &mut [f64],
        pitch: &mut [f64],
        omega: &mut [f64],
        fwd: &mut [f64],
        up: &mut [f64],
        mut lateral: Option<&mut [f64]>,
    ) {
        let Some(torso) = torso else {
            for x in [beta, h, pitch, omega, fwd, up] {
                x.fill(f64::NAN);
            }
            if let Some(x) = lateral {
                x.fill(f64::NAN);
            }
            return;
        };
        for (i, hip) in self.hip_m.iter().enumerate() {
            let arm = rotate(&torso.r, *hip);
            let wxr = cross(torso.w, arm);
            let v = [
                torso.v[0] + wxr[0],
                torso.v[1] + wxr[1],
                torso.v[2] + wxr[2],
            ];
            beta[i] = row[self.joint_qpos[i]];
            h[i] = torso.p[2] + arm[2] - self.surface_z_m;
            pitch[i] = torso.pitch_rad;
            omega[i] = row[self.joint_dof[i]];
            fwd[i] = v[0] * torso.fwd[0] + v[1] * torso.fwd[1];
            up[i] = v[2];
            if let Some(x) = lateral.as_mut() {
                // Toward the torso's left, z x its heading.
                x[i] = -v[0] * torso.fwd[1] + v[1] * torso.fwd[0];
            }
        }
    }

    #[inline(always)]
    fn env_out(
        &self,
        torso: Option<&Torso>,
        sin_cos: &[(f64, f64)],
        [d, l, t]: [&[f64]; 3],
        rest: Option<[&[f64]; 3]>,
        control: &mut [f64],
    ) {
        let Some(torso) = torso else {
            for &x in &self.xfrc {
                control[x..x + 6].fill(0.0);
            }
            return;
        };
        let axis = [torso.r[0][1], torso.r[1][1], torso.r[2][1]];
        for (i, com) in self.com_m.iter().enumerate() {
            let mut f = [d[i] * torso.fwd[0], d[i] * torso.fwd[1], l[i]];
            // A body's side force (toward the torso's right) and moments about the heading's
            // backward and the vertical, at the hip.
            let mut hip_moment = [0.0; 3];
            if let Some([s, r, y]) = rest {
                f[0] += s[i] * torso.fwd[1];
                f[1] -= s[i] * torso.fwd[0];
                hip_moment = [-r[i] * torso.fwd[0], -r[i] * torso.fwd[1], y[i]];
            }
            // The leg's centre of mass turned about the hip's +y by the joint angle.
            let (s, c) = sin_cos[i];
            let local = [c * com[0] + s * com[2], com[1], c * com[2] - s * com[0]];
            let hip_from_com = rotate(&torso.r, local).map(|x| -x);
            // xfrc_applied acts at the centre of mass: M_com = M_hip + (r_hip - r_com) x F.
            let m = cross(hip_from_com, f);
            let x = self.xfrc[i];
            control[x..x + 3].copy_from_slice(&f);
            control[x + 3] = m[0] - t[i] * axis[0] + hip_moment[0];
            control[x + 4] = m[1] - t[i] * axis[1] + hip_moment[1];
            control[x + 5] = m[2] - t[i] * axis[2] + hip_moment[2];
        }
    }
}
