"""The granular model inside MuJoCo: each leg in the sand feels terzaghi's forces.

A map names, for each leg, its hinge joint and the body the hinge moves (the leg). Every step,
:meth:`Coupling.apply` reads each leg's joint angle and rate and its hip's pose and velocity
from ``MjData``, evaluates the leg model for all legs at once (:class:`terzaghi.batch.LegBatch`),
and writes the force and torque through ``xfrc_applied`` of the leg's body, so that the wrench
about the hip is the model's. The sand's free surface is the plane ``z = surface_z_m``; the
legs' geoms should not collide with it (``contype="0" conaffinity="0"``): the model is their
contact.

The frames are the model's (docs/model.md): a leg is a plate along its body's +x axis from the
hip, turning about the hip body's +y axis (MuJoCo's hinge ``axis="0 1 0"``); at joint angle 0 it
points forward along the torso, at pi/2 straight down. The attack angle is the joint angle plus
the torso's pitch (nose down positive), the hip's height its height above the surface, and the
medium's drag pushes the hip forward, its lift up, its torque resists the leg's rotation.

A leg model that is a body (a wheel, a foot or a mesh: ``LegBatch(shape="wheel", ...)``) is
the body about the hip, its hub, turned by the joint (+ rolling forward); with it
:class:`Coupling` reads each hip's velocity across the torso's heading too, and applies the
whole wrench (:meth:`terzaghi.batch.LegBatch.wrenches`): the side force, and the moments about
the heading and the vertical, beside the drag, lift and torque.

Needs the ``mujoco`` package (``pip install mujoco``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Dict, List, Optional, Sequence, Tuple

import numpy as np

from .batch import LegBatch

if TYPE_CHECKING:
    from . import Node

__all__ = ["LegMap", "Coupling", "BatchCoupling", "HEXAPOD_XML", "hexapod_xml", "hexapod_params", "WalkRecording", "walk"]


@dataclass(frozen=True)
class LegMap:
    """One leg: its name (as the node names legs), the hinge joint that turns it, the body it
    moves (whose origin is on the hinge's axis, the hip) and, where it differs from the
    coupling's, its own leg model (:class:`terzaghi.batch.LegBatch`: its shape and size, a
    C-leg where the others are plates)."""

    name: str
    joint: str
    body: str
    model: Optional[LegBatch] = None


class Coupling:
    """terzaghi's forces on the mapped legs of a MuJoCo model.

    Args:
        model: the ``mujoco.MjModel``.
        legs: the legs (:class:`LegMap`).
        leg_model: the leg model (:class:`terzaghi.batch.LegBatch`) of every leg whose map
            names none, evaluated for those legs at once (legs of one model share a call); or
            ``None`` with ``node``, or where every map names its model.
        torso: the body whose pitch and forward direction the hips share (the robot's trunk).
        surface_z_m: the height of the sand's free surface in the world (m).
        node: instead of ``leg_model``, the node's core (:class:`terzaghi.Node`) with the
            robot's parameters, for instance a ``corrected.yaml``: each step it is sent the
            torso's pose and the joint states, stamped ``t0_ns`` plus the simulated time, and
            the legs feel what it predicts, corrections included. Its legs' names are the map's,
            its joints the map's joints, its hips placed in the torso (``<leg>.hip_offset_m``,
            ``robot_state.pose_topic``), as :func:`hexapod_params` sets them; the surface is
            at ``z = 0``.
    """

    def __init__(self, model, legs: Sequence[LegMap], leg_model: Optional[LegBatch] = None, *,
                 torso: str, surface_z_m: float = 0.0, node: Optional["Node"] = None,
                 t0_ns: int = 1_700_000_000 * 10**9) -> None:
        import mujoco

        legs = list(legs)
        if node is not None and (leg_model is not None or any(leg.model for leg in legs)):
            raise ValueError("give either leg models (leg_model, LegMap.model) or node (a terzaghi.Node)")
        if node is None and leg_model is None and not all(leg.model for leg in legs):
            missing = [leg.name for leg in legs if leg.model is None]
            raise ValueError(f"legs {missing}: no leg model (give leg_model, LegMap.model or node)")
        self.model = model
        self.legs = list(legs)
        self.leg_model = leg_model
        self.node = node
        self.t0_ns = int(t0_ns)
        self.surface_z_m = float(surface_z_m)
        if node is not None:
            missing = [leg.name for leg in self.legs if leg.name not in node.legs]
            if missing:
                raise ValueError(f"legs {missing}: not legs of the node (its legs: {node.legs})")
            if self.surface_z_m != 0.0:
                raise ValueError("with a node the surface is at z = 0 (robot_state.surface_height_m)")
            self._node_index = np.array([node.legs.index(leg.name) for leg in self.legs], dtype=np.intp)
            self._joints = [leg.joint for leg in self.legs]
        name = lambda kind, n: mujoco.mj_name2id(model, kind, n)
        self._torso = name(mujoco.mjtObj.mjOBJ_BODY, torso)
        if self._torso < 0:
            raise ValueError(f"torso {torso!r}: no such body in the model")
        self._body, self._qpos, self._dof = [], [], []
        for leg in self.legs:
            j = name(mujoco.mjtObj.mjOBJ_JOINT, leg.joint)
            b = name(mujoco.mjtObj.mjOBJ_BODY, leg.body)
            if j < 0:
                raise ValueError(f"leg {leg.name}: no joint {leg.joint!r} in the model")
            if b < 0:
                raise ValueError(f"leg {leg.name}: no body {leg.body!r} in the model")
            if model.jnt_type[j] != mujoco.mjtJoint.mjJNT_HINGE:
                raise ValueError(f"leg {leg.name}: joint {leg.joint!r} is not a hinge")
            if model.jnt_bodyid[j] != b:
                raise ValueError(f"leg {leg.name}: joint {leg.joint!r} does not move body {leg.body!r}")
            self._body.append(b)
            self._qpos.append(model.jnt_qposadr[j])
            self._dof.append(model.jnt_dofadr[j])
        n = len(self.legs)
        self._body = np.array(self._body, dtype=np.intp)
        self._qpos = np.array(self._qpos, dtype=np.intp)
        self._dof = np.array(self._dof, dtype=np.intp)
        self._in = {k: np.zeros(n) for k in ["beta", "h", "pitch", "omega", "fwd", "up", "lat"]}
        self.drag_n, self.lift_n, self.hip_torque_nm = (np.zeros(n) for _ in range(3))
        #: The rest of each leg's wrench at its hip (zero for a planar leg): the side force
        #: (+ toward the torso's right) and the moments about the torso's backward and the
        #: vertical (terzaghi.predict's ``side_n``, ``roll_moment_nm``, ``yaw_moment_nm``).
        self.side_n, self.roll_moment_nm, self.yaw_moment_nm = (np.zeros(n) for _ in range(3))
        # The legs of each model, with arrays kept from step to step for their inputs and
        # forces (a body's six, a planar leg's three).
        groups: Dict[int, list] = {}
        for i, leg in enumerate(self.legs):
            m = leg.model or leg_model
            if m is not None:
                groups.setdefault(id(m), [m, []])[1].append(i)
        self._groups = [(m, np.array(idx, dtype=np.intp),
                         {k: np.zeros(len(idx)) for k in self._in},
                         tuple(np.zeros(len(idx)) for _ in range(6 if m.is_body else 3)))
                        for m, idx in groups.values()]
        self._vel = np.zeros((n, 6))
        self._fwd = np.array([1.0, 0.0, 0.0])

    def read(self, data) -> Dict[str, np.ndarray]:
        """Each leg's joint angle, hip height, the torso's pitch, the leg's rate and the hip's
        forward and up velocity, as the model takes them (arrays over the legs)."""
        import mujoco

        # The bodies' poses and velocities of this state: after mj_step, MjData holds those of
        # the state before it (computed before the integration), one step behind qpos and qvel.
        mujoco.mj_kinematics(self.model, data)
        mujoco.mj_comPos(self.model, data)
        mujoco.mj_comVel(self.model, data)
        self._torso_pose = (data.xpos[self._torso].copy(), data.xquat[self._torso].copy())
        R = data.xmat[self._torso].reshape(3, 3)
        fwd = R[:, 0].copy()
        fwd[2] = 0.0
        norm = math.hypot(fwd[0], fwd[1])
        self._fwd = fwd / norm if norm > 0 else np.array([1.0, 0.0, 0.0])
        # Nose down positive: the torso's x axis below the horizontal.
        pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
        for i, b in enumerate(self._body):
            mujoco.mj_objectVelocity(self.model, data, mujoco.mjtObj.mjOBJ_BODY, b, self._vel[i], 0)
        x = self._in
        x["beta"][:] = data.qpos[self._qpos]
        x["h"][:] = data.xpos[self._body, 2] - self.surface_z_m
        x["pitch"][:] = pitch
        x["omega"][:] = data.qvel[self._dof]
        x["fwd"][:] = self._vel[:, 3] * self._fwd[0] + self._vel[:, 4] * self._fwd[1]
        x["up"][:] = self._vel[:, 5]
        # Across the heading, toward the torso's left (z x forward).
        x["lat"][:] = -self._vel[:, 3] * self._fwd[1] + self._vel[:, 4] * self._fwd[0]
        return x

    def apply(self, data) -> None:
        """Reads the legs from ``data``, evaluates the model and writes each leg's wrench into
        ``data.xfrc_applied`` (call before ``mj_step``). The other bodies' entries are kept."""
        x = self.read(data)
        if self.node is not None:
            t = self.t0_ns + int(round(data.time * 1e9))
            p, q = self._torso_pose
            self.node.pose(t, p, (q[1], q[2], q[3], q[0]))
            f = self.node.joint_state(t, self._joints, x["beta"], x["omega"])
            for k, out in (("drag_n", self.drag_n), ("lift_n", self.lift_n),
                           ("hip_torque_nm", self.hip_torque_nm)):
                # A leg the node did not predict (no pose yet) feels nothing.
                out[:] = np.nan_to_num(f[k][self._node_index], nan=0.0)
        elif (len(self._groups) == 1 and len(self._groups[0][1]) == len(self.legs)
              and not self._groups[0][0].is_body):
            # One planar model for every leg: in place, no copies.
            self._groups[0][0].forces(x["beta"], x["h"], pitch_rad=x["pitch"],
                                      omega_rad_s=x["omega"], forward_m_s=x["fwd"], up_m_s=x["up"],
                                      out=(self.drag_n, self.lift_n, self.hip_torque_nm))
        else:
            for m, idx, g, out in self._groups:
                for k, v in g.items():
                    np.take(x[k], idx, out=v)
                motion = dict(pitch_rad=g["pitch"], omega_rad_s=g["omega"], forward_m_s=g["fwd"],
                              up_m_s=g["up"], out=out)
                if m.is_body:
                    m.wrenches(g["beta"], g["h"], lateral_m_s=g["lat"], **motion)
                    self.side_n[idx], self.roll_moment_nm[idx], self.yaw_moment_nm[idx] = out[3:]
                else:
                    m.forces(g["beta"], g["h"], **motion)
                self.drag_n[idx], self.lift_n[idx], self.hip_torque_nm[idx] = out[:3]
        axis = data.xmat[self._torso].reshape(3, 3)[:, 1]  # the hips' +y axis: the legs turn about it
        # The hip frame: x the torso's backward (-forward), y its right, z up.
        right = np.array([self._fwd[1], -self._fwd[0], 0.0])
        f = self.drag_n[:, None] * self._fwd[None, :] + self.side_n[:, None] * right[None, :]
        f[:, 2] += self.lift_n
        # xfrc_applied acts at the body's centre of mass: move the hip's moment there,
        # M_com = M_hip + (r_hip - r_com) x F.
        r = data.xpos[self._body] - data.xipos[self._body]
        m = (-self.hip_torque_nm[:, None] * axis[None, :]
             - self.roll_moment_nm[:, None] * self._fwd[None, :])
        m[:, 2] += self.yaw_moment_nm
        m[:, 0] += r[:, 1] * f[:, 2] - r[:, 2] * f[:, 1]
        m[:, 1] += r[:, 2] * f[:, 0] - r[:, 0] * f[:, 2]
        m[:, 2] += r[:, 0] * f[:, 1] - r[:, 1] * f[:, 0]
        data.xfrc_applied[self._body, :3] = f
        data.xfrc_applied[self._body, 3:] = m


def _state_offset(model, spec: int, part: int) -> int:
    """Where ``part`` (one ``mjtState`` bit) starts in a state vector of ``spec``."""
    import mujoco

    return mujoco.mj_stateSize(model, spec & (part - 1))


class BatchCoupling:
    """terzaghi's forces on the legs of many environments of one MuJoCo model, stepped together
    by MuJoCo's own rollout (``mujoco.rollout``, on ``threads`` threads): one native call per
    step reads every environment's legs, evaluates them with the kernel of ``leg_model`` (a
    :class:`terzaghi.batch.LegBatch`) and writes every leg's wrench, a chunk of environments at
    a time on every core, with no Python loop over environments.

    The robot is a torso on a free joint with legs hinged to it (:class:`LegMap`): each leg's
    body a child of the torso, its hinge at the body's origin (the hip) about the torso's +y
    axis, at angle 0 along the torso's +x (the frames of :class:`Coupling`, whose forces this
    gives to every environment: a test holds them equal).

    Args:
        model: the ``mujoco.MjModel``.
        legs: the legs (:class:`LegMap`); a map that names its own ``model`` other than
            ``leg_model`` is refused (every leg here is ``leg_model``'s: use :class:`Coupling`
            for legs of several models).
        leg_model: the leg model (:class:`terzaghi.batch.LegBatch`) of every leg.
        n_envs: the number of environments.
        torso: the free body the legs hang from.
        surface_z_m: the height of the sand's free surface in the world (m).
        threads: MuJoCo's threads for the step (default: every core).

    Attributes:
        state: ``(n_envs, nstate)``, each environment's ``mjSTATE_FULLPHYSICS`` (all start at
            the model's initial state; write rows to set or reset them).
        ctrl: ``(n_envs, nu)``, each environment's actuator controls for the next step.
        drag_n, lift_n, hip_torque_nm: ``(n_envs, legs)``, the forces of the last step.
        side_n, roll_moment_nm, yaw_moment_nm: ``(n_envs, legs)``, the rest of the wrench of
            the last step, for a leg model that is a body (a wheel, foot or mesh; zero for
            planar legs): applied as :class:`Coupling` applies it.
        b_k, a: ``None``, or ``(n_envs,)`` arrays: the improved model's medium per environment
            (domain randomisation); read-only, set by :meth:`set_media`.
    """

    def __init__(self, model, legs: Sequence[LegMap], leg_model: LegBatch, *, n_envs: int,
                 torso: str, surface_z_m: float = 0.0, threads: Optional[int] = None) -> None:
        import os

        import mujoco
        from mujoco import rollout

        from . import _terzaghi

        if not isinstance(leg_model, LegBatch):
            raise ValueError(f"leg_model: a terzaghi.batch.LegBatch, not {type(leg_model).__name__}")
        if isinstance(n_envs, bool) or not isinstance(n_envs, (int, np.integer)) or n_envs < 1:
            raise ValueError(f"n_envs = {n_envs!r}: a whole number >= 1")
        threads = (os.cpu_count() or 1) if threads is None else int(threads)
        if threads < 1:
            raise ValueError(f"threads = {threads}: at least 1")
        self.model, self.legs, self.leg_model = model, list(legs), leg_model
        for leg in self.legs:
            if leg.model is not None and leg.model is not leg_model:
                raise ValueError(f"leg {leg.name}: names its own leg model, and BatchCoupling "
                                 "evaluates every leg with leg_model; use Coupling for legs of "
                                 "several models")
        self.n_envs = int(n_envs)
        name = lambda kind, n: mujoco.mj_name2id(model, kind, n)
        t = name(mujoco.mjtObj.mjOBJ_BODY, torso)
        if t < 0:
            raise ValueError(f"torso {torso!r}: no such body in the model")
        j = model.body_jntadr[t]
        if model.body_jntnum[t] != 1 or model.jnt_type[j] != mujoco.mjtJoint.mjJNT_FREE:
            raise ValueError(f"torso {torso!r}: needs one joint, a free joint")
        hips, coms, qpos, dofs, xfrc = [], [], [], [], []
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS.value
        control_spec = mujoco.mjtState.mjSTATE_CTRL.value | mujoco.mjtState.mjSTATE_XFRC_APPLIED.value
        xfrc0 = _state_offset(model, control_spec, mujoco.mjtState.mjSTATE_XFRC_APPLIED.value)
        for leg in self.legs:
            jl = name(mujoco.mjtObj.mjOBJ_JOINT, leg.joint)
            b = name(mujoco.mjtObj.mjOBJ_BODY, leg.body)
            if jl < 0 or b < 0:
                raise ValueError(f"leg {leg.name}: no joint {leg.joint!r} or body {leg.body!r} in the model")
            if model.jnt_type[jl] != mujoco.mjtJoint.mjJNT_HINGE or model.jnt_bodyid[jl] != b:
                raise ValueError(f"leg {leg.name}: joint {leg.joint!r} is not a hinge of body {leg.body!r}")
            if model.body_parentid[b] != t or model.body_jntnum[b] != 1:
                raise ValueError(f"leg {leg.name}: body {leg.body!r} must hang from {torso!r} by its hinge alone")
            rot = np.empty(9)
            mujoco.mju_quat2Mat(rot, model.body_quat[b])
            rot = rot.reshape(3, 3)
            axis = rot @ model.jnt_axis[jl]
            if np.abs(axis - [0.0, 1.0, 0.0]).max() > 1e-9 or np.abs(model.jnt_pos[jl]).max() > 0:
                raise ValueError(f"leg {leg.name}: its hinge must turn about the torso's +y axis "
                                 f"at the body's origin (axis {axis.round(6).tolist()}, "
                                 f"pos {model.jnt_pos[jl].tolist()})")
            if model.qpos0[model.jnt_qposadr[jl]] != 0:
                raise ValueError(f"leg {leg.name}: joint {leg.joint!r} has a reference angle; "
                                 "the leg model's angle is its qpos")
            hips.append(model.body_pos[b].tolist())
            coms.append((rot @ model.body_ipos[b]).tolist())
            qpos.append(_state_offset(model, spec, mujoco.mjtState.mjSTATE_QPOS.value) + model.jnt_qposadr[jl])
            dofs.append(_state_offset(model, spec, mujoco.mjtState.mjSTATE_QVEL.value) + model.jnt_dofadr[jl])
            xfrc.append(xfrc0 + 6 * b)
        nstate = mujoco.mj_stateSize(model, spec)
        ncontrol = mujoco.mj_stateSize(model, control_spec)
        self._layout = _terzaghi.FreeBase(
            _state_offset(model, spec, mujoco.mjtState.mjSTATE_QPOS.value) + model.jnt_qposadr[j],
            _state_offset(model, spec, mujoco.mjtState.mjSTATE_QVEL.value) + model.jnt_dofadr[j],
            nstate, qpos, dofs, hips, coms, xfrc, ncontrol, float(surface_z_m))
        self._spec, self._control_spec = spec, control_spec
        # The legs' xfrc_applied columns in a control row.
        self._leg_xfrc = np.array([x + k for x in xfrc for k in range(6)], dtype=np.intp)
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        first = np.empty(nstate)
        mujoco.mj_getState(model, data, first, spec)
        self.initial_state = first
        # Two buffers of states, the step reading one and writing the other.
        self._buf = [np.tile(first, (self.n_envs, 1, 1)), np.empty((self.n_envs, 1, nstate))]
        self.state = self._buf[0][:, 0, :]
        self._sensors = np.empty((self.n_envs, 1, model.nsensordata))
        self._control = np.zeros((self.n_envs, 1, ncontrol))
        self.control = self._control[:, 0, :]
        self.ctrl = self.control[:, :model.nu]
        shape = (self.n_envs, len(self.legs))
        self._in = {k: np.zeros(shape) for k in ["beta", "h", "pitch", "omega", "fwd", "up"]}
        self.drag_n, self.lift_n, self.hip_torque_nm = (np.zeros(shape) for _ in range(3))
        # A body's legs: each hip's velocity across the heading in, the rest of the wrench out
        # (as Coupling's side_n, roll_moment_nm, yaw_moment_nm; zero for planar legs).
        self.side_n, self.roll_moment_nm, self.yaw_moment_nm = (np.zeros(shape) for _ in range(3))
        self._wrench = ((np.zeros(shape), self.side_n, self.roll_moment_nm, self.yaw_moment_nm)
                        if leg_model.is_body else ())
        self._media: Tuple = (None, None)
        self._rollout = rollout.Rollout(nthread=threads if threads > 1 else 0)
        self._datas = [mujoco.MjData(model) for _ in range(threads)]
        # The rollout's call without its checks takes one model per environment.
        self._models = [model] * self.n_envs

    def set_media(self, b_k=None, a=None) -> None:
        """The improved model's ``b_k`` and ``a`` per environment (``(n_envs,)`` arrays, or
        ``None`` for the leg model's own).

        Raises:
            ValueError: another shape, a value that is not a positive number (its environment
                named), or a leg model that is not the improved model; the media are then
                unchanged.
        """
        legs = len(self.legs)
        per_leg = []
        for label, v in (("b_k", b_k), ("a", a)):
            if v is None:
                per_leg.append(None)
                continue
            if not self.leg_model._inner.takes_fitting_width:
                raise ValueError(f"{label}: a fitting width per environment is the improved "
                                 "model's, and leg_model is not it")
            try:
                v = np.asarray(v, dtype=np.float64)
            except (TypeError, ValueError) as e:
                raise ValueError(f"{label}: not an array of numbers ({e})") from None
            if v.shape != (self.n_envs,):
                raise ValueError(f"{label} has shape {v.shape}, the environments ({self.n_envs},)")
            bad = np.flatnonzero(~(np.isfinite(v) & (v > 0)))
            if bad.size:
                raise ValueError(f"{label}[{bad[0]}] = {v[bad[0]]}: a positive number "
                                 f"({bad.size} environment(s) so)")
            per_leg.append(np.ascontiguousarray(np.repeat(v[:, None], legs, axis=1)))
        self._media = tuple(per_leg)

    @property
    def b_k(self) -> Optional[np.ndarray]:
        """Each environment's ``b_k`` (``(n_envs,)``), or ``None`` for the leg model's own
        (read-only: :meth:`set_media` sets it)."""
        return None if self._media[0] is None else self._media[0][:, 0].copy()

    @property
    def a(self) -> Optional[np.ndarray]:
        """Each environment's ``a``, as :attr:`b_k`."""
        return None if self._media[1] is None else self._media[1][:, 0].copy()

    def apply(self) -> None:
        """Evaluates every environment's legs at ``state`` and writes their wrenches into the
        control of the next step (``xfrc_applied``)."""
        x = self._in
        # One native call: a chunk of environments at a time read, evaluated by the leg
        # model's kernel and written, on every core.
        self._layout.apply(self.state, self.leg_model._inner, self._media[0], self._media[1],
                           x["beta"], x["h"], x["pitch"], x["omega"], x["fwd"], x["up"],
                           self.drag_n, self.lift_n, self.hip_torque_nm, self.control,
                           *self._wrench)

    def step(self, coupled: bool = True) -> None:
        """One step of every environment: :meth:`apply` (unless ``coupled`` is false: the legs
        then feel nothing) and MuJoCo's step with ``ctrl``; ``state`` is then the new state."""
        if coupled:
            self.apply()
        else:
            self.control[:, self._leg_xfrc] = 0.0
        self._rollout.rollout(self._models, self._datas, self._buf[0][:, 0, :], self._control,
                              control_spec=self._control_spec, skip_checks=True, nstep=1,
                              state=self._buf[1], sensordata=self._sensors)
        self._buf.reverse()
        self.state = self._buf[0][:, 0, :]

    def close(self) -> None:
        """Stops MuJoCo's threads."""
        self._rollout.close()


#: A RHex-like hexapod: a 0.5 x 0.2 m torso of 7 kg on a free joint, six flat legs 0.1 m long and
#: 0.025 m wide on hinges about the torso's y axis, each turned by a velocity servo. The legs'
#: geoms do not collide (terzaghi is their contact); the torso collides with the floor.
HEXAPOD_XML = """
<mujoco model="terzaghi_hexapod">
  <option timestep="0.002" integrator="implicitfast"/>
  <worldbody>
    <geom name="sand_surface" type="plane" size="20 20 0.1" rgba="0.8 0.7 0.5 1"/>
    <body name="torso" pos="0 0 0.09">
      <freejoint name="root"/>
      <geom type="box" size="0.25 0.1 0.025" mass="7"/>
{legs}
    </body>
  </worldbody>
  <actuator>
{actuators}
  </actuator>
</mujoco>
"""

#: The hexapod's legs: name and hip position in the torso (m).
HEXAPOD_HIPS = {
    "front_left": (0.2, 0.13, 0.0),
    "middle_left": (0.0, 0.13, 0.0),
    "rear_left": (-0.2, 0.13, 0.0),
    "front_right": (0.2, -0.13, 0.0),
    "middle_right": (0.0, -0.13, 0.0),
    "rear_right": (-0.2, -0.13, 0.0),
}


def hexapod_xml(length_m: float = 0.1, width_m: float = 0.025, servo_gain: float = 5.0) -> str:
    """The MJCF of :data:`HEXAPOD_XML` with legs of that size."""
    legs, acts = [], []
    for name, (x, y, z) in HEXAPOD_HIPS.items():
        legs.append(
            f'      <body name="{name}" pos="{x} {y} {z}">\n'
            f'        <joint name="{name}_joint" type="hinge" axis="0 1 0" damping="0.05"/>\n'
            f'        <geom type="box" pos="{length_m / 2} 0 0" size="{length_m / 2} {width_m / 2} 0.004"'
            f' mass="0.1" contype="0" conaffinity="0"/>\n'
            f"      </body>"
        )
        acts.append(f'    <velocity name="{name}_servo" joint="{name}_joint" kv="{servo_gain}"/>')
    return HEXAPOD_XML.format(legs="\n".join(legs), actuators="\n".join(acts))


def hexapod_legs() -> List[LegMap]:
    """The hexapod's legs as the coupling maps them."""
    return [LegMap(name, f"{name}_joint", name) for name in HEXAPOD_HIPS]


TRIPOD_A = ("front_left", "middle_right", "rear_left")


def tripod_speeds(t_s: float, mean_rad_s: float = 4.0) -> Dict[str, float]:
    """An alternating-tripod gait's leg speeds at time ``t_s``: each tripod turns fast through
    its swing and slowly through its stance, half a turn apart."""
    out = {}
    for name in HEXAPOD_HIPS:
        phase = 0.0 if name in TRIPOD_A else math.pi
        out[name] = mean_rad_s * (1.0 + 0.5 * math.sin(mean_rad_s * t_s + phase))
    return out


def hexapod_params(length_m: float = 0.1, width_m: float = 0.025, medium: str = "poppy_lp") -> Dict[str, str]:
    """The node's parameters for the hexapod of :func:`hexapod_xml`: the shipped robot's
    (``launch_configs/rhex.yaml``) with this model's joints, leg size and medium, F/T in the
    hip frame, and each hip placed in the torso whose pose ``/body_pose`` carries."""
    from . import rhex_params

    p = rhex_params()
    p["robot_state.pose_topic"] = "/body_pose"
    for name, (x, y, z) in HEXAPOD_HIPS.items():
        p[f"{name}.joint"] = f"{name}_joint"
        p[f"{name}.direction"] = "1"
        p[f"{name}.angle_offset_rad"] = "0.0"
        p[f"{name}.length_m"] = repr(float(length_m))
        p[f"{name}.width_m"] = repr(float(width_m))
        p[f"{name}.medium"] = medium
        p[f"{name}.ft_frame"] = "hip"
        p[f"{name}.hip_offset_m"] = f"[{x}, {y}, {z}]"
    return p


class WalkRecording:
    """Records a walk as the robot's recording would hold it: ``/joint_states``, each leg's F/T
    (the forces the coupling applied, in the hip frame: ``x`` along the submerged tip's travel,
    so ``-drag``, and ``z`` up, the lift; with Gaussian sensor noise of ``noise_n``) and the
    torso's pose on ``/body_pose``, every ``every`` steps, stamped from ``t0_ns``. Pass its
    :meth:`on_step` to :func:`walk`."""

    def __init__(self, path, params: Dict[str, str], *, t0_ns: int = 1_700_000_000 * 10**9,
                 every: int = 1, noise_n: float = 0.0, seed: int = 1,
                 overwrite: bool = False) -> None:
        from . import Recorder

        if not (math.isfinite(noise_n) and noise_n >= 0):
            raise ValueError(f"noise_n = {noise_n!r}: must be a finite number >= 0")
        self.rec = Recorder(path, params, overwrite=overwrite)
        self.noise_n = float(noise_n)
        self.rng = np.random.default_rng(seed)
        self.t0_ns = int(t0_ns)
        self.every = int(every)
        self.steps = 0
        # A string parameter's text may be quoted, as a parameter file writes it.
        topic = lambda name: str(params[f"{name}.ft_topic"]).strip('"').lstrip("/")
        self.ft_topics = {name: "/" + topic(name) for name in HEXAPOD_HIPS}

    def on_step(self, model, data, c: "Coupling") -> None:
        """Records the step just taken (every ``every``-th): the torso's pose, the joint
        states, and each leg's F/T as ``c`` applied it."""
        self.steps += 1
        if self.steps % self.every:
            return
        # The state the coupling read and the forces it applied for the step just taken.
        t = self.t0_ns + int(round((data.time - model.opt.timestep) * 1e9))
        x = c._in
        # The body's pose first: the node places the hips of a JointState from the poses it
        # has at its stamp (the world frame is the node's default, odom).
        p, q = c._torso_pose
        self.rec.pose("/body_pose", t, p, (q[1], q[2], q[3], q[0]), frame_id="odom")
        self.rec.joint_state(t, [leg.joint for leg in c.legs], x["beta"], x["omega"])
        noise = self.rng.normal(0.0, self.noise_n, (len(c.legs), 2)) if self.noise_n else np.zeros((len(c.legs), 2))
        for i, leg in enumerate(c.legs):
            self.rec.wrench(self.ft_topics[leg.name], t,
                            (-c.drag_n[i] + noise[i, 0], 0.0, c.lift_n[i] + noise[i, 1]),
                            frame_id=f"{leg.name}_ft")

    def close(self) -> int:
        """Finishes the MCAP file; returns the messages written."""
        return self.rec.close()


def walk(seconds: float, *, coupling: bool = True, leg_model: Optional[LegBatch] = None,
         node: Optional["Node"] = None, width_m: float = 0.025, mean_rad_s: float = 4.0,
         legs: Optional[Sequence[LegMap]] = None, on_step=None):
    """The hexapod walking for ``seconds`` of simulated time, with terzaghi's forces on its legs
    (or, ``coupling=False``, with none: the legs turn in the air and the torso lies on the
    floor). The forces come from ``leg_model`` (by default the improved model on poppy seeds),
    or from ``node``, the node's core with the robot's parameters (a ``corrected.yaml`` over
    :func:`hexapod_params`), which predicts with their corrections. Legs 0.1 m long and
    ``width_m`` wide; ``legs`` may give some of them their own leg models (default
    :func:`hexapod_legs`). ``on_step(model, data, coupling)`` is called after each step.
    Returns the model and data at the end."""
    import mujoco

    if leg_model is None and node is None:
        leg_model = LegBatch(length_m=0.1, width_m=width_m, medium="poppy_lp")
    model = mujoco.MjModel.from_xml_string(hexapod_xml(width_m=width_m))
    data = mujoco.MjData(model)
    # Start the tripods half a turn apart.
    for leg in hexapod_legs():
        j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, leg.joint)
        data.qpos[model.jnt_qposadr[j]] = 0.8 if leg.name in TRIPOD_A else 0.8 + math.pi
    legs = hexapod_legs() if legs is None else list(legs)
    if node is not None or all(leg.model for leg in legs):
        leg_model = None
    c = Coupling(model, legs, leg_model, torso="torso", node=node) if coupling else None
    mujoco.mj_forward(model, data)
    steps = int(round(seconds / model.opt.timestep))
    act = {n: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, f"{n}_servo") for n in HEXAPOD_HIPS}
    for _ in range(steps):
        for n, v in tripod_speeds(data.time, mean_rad_s).items():
            data.ctrl[act[n]] = v
        if c is not None:
            c.apply(data)
        mujoco.mj_step(model, data)
        if on_step is not None:
            on_step(model, data, c)
    return model, data
