"""The model for many legs at once: a simulator's environments times legs, one call per step.

>>> import numpy as np
>>> from terzaghi.batch import LegBatch
>>> legs = LegBatch(length_m=0.1, width_m=0.025, medium="poppy_lp")
>>> beta = np.full((4096, 6), 0.6); hip = np.full((4096, 6), 0.02)
>>> drag, lift, torque = legs.forces(beta, hip)
>>> drag.shape
(4096, 6)

A batch runs in ``beta_rad``'s dtype, float64 or float32 (float32 in, float32 out). numpy
arrays, CPU torch tensors and JAX arrays (anything with ``__dlpack__`` on the CPU) are read
where they lie, without a copy when they are C-contiguous in the batch's dtype; the outputs
come back as the same kind of array. Pass ``out=(drag, lift, torque)`` to reuse arrays from
step to step, and nothing is allocated per call. The work is shared over every core, without
the interpreter's lock.
"""

from __future__ import annotations

from typing import Any, Optional, Tuple

import numpy as np

from . import BODY_SHAPES, TerzaghiError, _body_or_leg, _medium, _model_tail, _terzaghi

__all__ = ["LegBatch", "WRENCH"]

Arrays = Tuple[Any, Any, Any]
Wrenches = Tuple[Any, Any, Any, Any, Any, Any]

#: The names of :meth:`LegBatch.wrenches`' outputs, in their order.
WRENCH = ("drag_n", "lift_n", "hip_torque_nm", "side_n", "roll_moment_nm", "yaw_moment_nm")


def _kind(x) -> str:
    """``"numpy"``, ``"torch"``, ``"jax"`` or ``"other"``: which stack an array comes from."""
    if isinstance(x, np.ndarray):
        return "numpy"
    module = type(x).__module__.split(".")[0]
    return module if module in ("torch", "jax", "jaxlib") else "other"


def _on_cpu(name: str, x) -> None:
    """Refuses an array that lives on an accelerator, saying what to do."""
    device = getattr(x, "device", None)
    if device is None or isinstance(device, str):
        return
    kind = getattr(device, "type", None) or getattr(device, "platform", None)
    if callable(kind):
        kind = kind()
    if kind is not None and kind != "cpu":
        raise TerzaghiError(
            f"{name} is on {device}: terzaghi computes on the CPU. Move it there once per step "
            "(x.cpu() in torch, jax.device_put(x, jax.devices('cpu')[0]) in JAX); see "
            "docs/python.md, 'GPU users'")


def _view(name: str, x):
    """``x`` as a numpy array over the same memory where it has one (``__dlpack__``)."""
    if isinstance(x, np.ndarray):
        return x
    if hasattr(x, "__dlpack__"):
        _on_cpu(name, x)
        try:
            return np.from_dlpack(x)
        except (TypeError, ValueError, RuntimeError, BufferError) as e:
            raise TerzaghiError(f"{name}: its memory cannot be read in place ({e})") from None
    return x


def _input(name: str, x, dtype, shape) -> np.ndarray:
    """``x`` as a C-contiguous array of ``dtype`` and ``shape``: a scalar is broadcast (as
    :func:`terzaghi.predict` does), any other shape is refused by name, even with as many
    values (a transposed ``(6, 4096)`` against ``(4096, 6)`` would read the legs out of order)."""
    x = _view(name, x)
    if np.ndim(x) == 0:
        try:
            return np.full(shape, float(x), dtype=dtype)
        except (TypeError, ValueError) as e:
            raise TerzaghiError(f"{name}: not a number ({e})") from None
    try:
        a = np.ascontiguousarray(x, dtype=dtype)
    except (TypeError, ValueError) as e:
        raise TerzaghiError(f"{name}: not an array of numbers ({e})") from None
    if a.shape != shape:
        hint = " (transposed?)" if a.shape == shape[::-1] and a.ndim > 1 else ""
        raise TerzaghiError(
            f"{name} has shape {a.shape}, beta_rad {shape}{hint}: give each input the "
            "shape of beta_rad, or a scalar")
    return a


def _output(name: str, x, dtype, shape) -> np.ndarray:
    """An ``out`` array, written in place: it must have the batch's dtype and shape already."""
    a = _view(name, x)
    if not isinstance(a, np.ndarray):
        raise TerzaghiError(f"{name}: not an array ({type(x).__name__})")
    if a.dtype != dtype or a.shape != shape:
        raise TerzaghiError(
            f"{name} is {a.dtype} {a.shape}, the batch {np.dtype(dtype)} {shape} (beta_rad's): "
            "give each output the batch's dtype and shape")
    if not a.flags.c_contiguous:
        raise TerzaghiError(f"{name} must be C-contiguous (np.empty(shape, dtype))")
    if not a.flags.writeable:
        raise TerzaghiError(f"{name} is read-only (a JAX array is): leave out= out for JAX")
    return a


def _aligned_empty(shape, dtype) -> np.ndarray:
    """An empty array whose data starts on a 64-byte boundary (what JAX needs to take it
    without a copy)."""
    n = int(np.prod(shape))
    item = np.dtype(dtype).itemsize
    raw = np.empty(n * item + 64, dtype=np.uint8)
    start = -raw.ctypes.data % 64
    return raw[start:start + n * item].view(dtype).reshape(shape)


def _as_kind(kind: str, a: np.ndarray):
    """``a`` as an array of the stack ``kind``, over the same memory."""
    if kind == "torch":
        import torch

        return torch.from_dlpack(a)
    if kind in ("jax", "jaxlib"):
        import jax.numpy as jnp

        return jnp.from_dlpack(a)
    return a


class LegBatch:
    """One leg model evaluated for arrays of legs.

    Args:
        length_m, width_m: the leg (for a C-leg, ``length_m`` is its hip-to-tip chord).
        medium, unit_weight_n_m3, phi_deg, delta_deg: as for :func:`terzaghi.predict`.
        model: ``"improved"`` (default), ``"conventional"``, ``"rft"`` or ``"sinkage"`` (a
            plate pushed straight down by the law of ``medium_file``; its depth is minus the
            hip's height, ``up_m_s`` tells loading from unloading); with ``"rft"``, a
            ``medium_file`` of the ``rft_depth_power`` law scales RFT's stresses in depth.
        shape: ``"plate"``, ``"c_leg"`` (``c_leg_radius_m``, ``c_leg_span_deg``) or
            ``"polyline"`` (``profile``, ``[(s, q), ...]`` in metres); the curved ones RFT only.
            Or a body about the hip, its hub (``"wheel"``, ``"disc"``, ``"sphere"``, ``"box"``,
            ``"mesh"``) with the values :func:`terzaghi.predict` takes for one (``radius_m``,
            ``width_m``, ``thickness_m``, ``size_m``, ``mesh_file``, ``mesh_scale``,
            ``element_m``, the grousers, ``rim_elements``): RFT in ``medium_file``'s medium,
            without ``length_m`` (its reach is its own), leg by leg (a wheel of 360 rim
            elements takes a few microseconds).
        b_k, a, rft_coeffs, rft_zeta, rft_elements: as for :func:`terzaghi.predict` (RFT's
            elements over a leg's submerged length, 100 by default; not for a body).
        planar_sheared_bearing: as for :func:`terzaghi.predict` (a planar leg with it goes
            leg by leg, not through the vector loop).
    """

    def __init__(
        self,
        *,
        length_m: Optional[float] = None,
        width_m: Optional[float] = None,
        medium: Optional[str] = None,
        unit_weight_n_m3: Optional[float] = None,
        phi_deg: Optional[float] = None,
        delta_deg: Optional[float] = None,
        model: str = "improved",
        shape: str = "plate",
        b_k: Optional[float] = None,
        a: Optional[float] = None,
        rft_coeffs: Optional[str] = None,
        rft_zeta: Optional[float] = None,
        rft_elements: Optional[int] = None,
        c_leg_radius_m: Optional[float] = None,
        c_leg_span_deg: Optional[float] = None,
        profile=None,
        medium_file=None,
        radius_m: Optional[float] = None,
        thickness_m: Optional[float] = None,
        size_m=None,
        mesh_file=None,
        mesh_scale: Optional[float] = None,
        element_m: Optional[float] = None,
        grouser_count: Optional[int] = None,
        grouser_height_m: Optional[float] = None,
        grouser_thickness_m: Optional[float] = None,
        rim_elements: Optional[int] = None,
        planar_sheared_bearing: bool = False,
    ) -> None:
        body_values = dict(radius_m=radius_m, thickness_m=thickness_m, size_m=size_m,
                           mesh_file=mesh_file, mesh_scale=mesh_scale, element_m=element_m,
                           grouser_count=grouser_count, grouser_height_m=grouser_height_m,
                           grouser_thickness_m=grouser_thickness_m, rim_elements=rim_elements)
        if shape in BODY_SHAPES and model != "rft":
            raise TerzaghiError(f"model {model!r}: a body ({shape}) is RFT's (model=\"rft\")")
        if shape in BODY_SHAPES and rft_elements is not None:
            raise TerzaghiError(f"rft_elements is for a leg's mid-line: a body ({shape}) is cut "
                                "by element_m or rim_elements")
        body, length_m, width_m, shape = _body_or_leg(shape, length_m, width_m, body_values)
        if body is None and (length_m is None or width_m is None):
            raise TerzaghiError("length_m and width_m are needed (the leg, m)")
        self.is_body = body is not None
        self._inner = _terzaghi.Batch(
            model,
            float(length_m),
            float(width_m),
            *_medium(medium, unit_weight_n_m3, phi_deg, delta_deg),
            *_model_tail(b_k, a, rft_coeffs, rft_zeta,
                         100 if rft_elements is None else rft_elements, shape, c_leg_radius_m,
                         c_leg_span_deg, profile, medium_file),
            body,
            bool(planar_sheared_bearing),
        )

    @property
    def vectorised(self) -> bool:
        """Whether legs go through the kernel's vector loop (RFT with fitted coefficients);
        other models (and bodies) are evaluated leg by leg, as :func:`terzaghi.predict` does."""
        return self._inner.vectorised

    def forces(
        self,
        beta_rad,
        hip_height_m,
        *,
        pitch_rad=None,
        omega_rad_s=None,
        forward_m_s=None,
        up_m_s=None,
        b_k=None,
        a=None,
        out: Optional[Arrays] = None,
    ) -> Arrays:
        """Drag, lift (N) and hip torque (N m) of every leg.

        Args:
            beta_rad: each leg's joint angle (rad), any shape; float32 makes a float32 batch,
                anything else float64. A numpy array, or a CPU torch tensor or JAX array.
            hip_height_m: each hip's height above the surface (m), the same shape (a scalar is
                broadcast).
            pitch_rad, omega_rad_s, forward_m_s, up_m_s: the body's pitch, the leg's rate and
                the hip's horizontal (forward) and vertical (up) velocity; zero if left out.
                RFT uses the velocities; the improved model uses the pitch and height.
            b_k, a: the improved model's fitting width per leg (a medium per environment),
                the shape of ``beta_rad`` or a scalar; the batch's own if left out.
            out: three C-contiguous arrays of the batch's dtype and shape to write into.

        Returns:
            The three arrays: ``out`` where given, else new arrays of ``beta_rad``'s kind
            (numpy, torch or JAX).

        Raises:
            TerzaghiError: a non-finite input (its flat index named), an input or output array
                whose shape differs from ``beta_rad``'s (its name and both shapes), an output of
                another dtype, or an array on an accelerator.
        """
        return self._run(beta_rad, hip_height_m, pitch_rad, omega_rad_s, forward_m_s, up_m_s,
                         b_k, a, None, WRENCH[:3], out)

    def wrenches(
        self,
        beta_rad,
        hip_height_m,
        *,
        pitch_rad=None,
        omega_rad_s=None,
        forward_m_s=None,
        up_m_s=None,
        lateral_m_s=None,
        b_k=None,
        a=None,
        out: Optional[Wrenches] = None,
    ) -> Wrenches:
        """Every leg's whole wrench at its hip: drag, lift, hip torque, and the side force and
        the moments about the hip frame's ``x`` (the robot's backward) and ``z`` (up), as
        :func:`terzaghi.predict` gives them (``side_n`` + toward the robot's right).

        Args:
            lateral_m_s: each hip's velocity to the robot's left (m/s), the shape of
                ``beta_rad`` or a scalar; zero if left out. A body, or an RFT leg moving
                sideways, feels it (leg by leg); a planar leg moving in its plane has
                :meth:`forces`' values and no side force.
            out: six C-contiguous arrays of the batch's dtype and shape to write into.
            The rest as :meth:`forces`.

        Returns:
            The six arrays (:data:`WRENCH` names them), as :meth:`forces` returns three.
        """
        return self._run(beta_rad, hip_height_m, pitch_rad, omega_rad_s, forward_m_s, up_m_s,
                         b_k, a, lateral_m_s, WRENCH, out)

    def _run(self, beta_rad, hip_height_m, pitch_rad, omega_rad_s, forward_m_s, up_m_s, b_k, a,
             lateral_m_s, names, out):
        kind = _kind(beta_rad)
        beta = _view("beta_rad", beta_rad)
        dtype = np.float32 if getattr(beta, "dtype", None) == np.float32 else np.float64
        try:
            beta = np.ascontiguousarray(beta, dtype=dtype)
        except (TypeError, ValueError) as e:
            raise TerzaghiError(f"beta_rad: not an array of numbers ({e})") from None
        shape = beta.shape
        arrays = [_input("hip_height_m", hip_height_m, dtype, shape)] + [
            None if v is None else _input(n, v, dtype, shape)
            for n, v in [("pitch_rad", pitch_rad), ("omega_rad_s", omega_rad_s),
                         ("forward_m_s", forward_m_s), ("up_m_s", up_m_s), ("b_k", b_k),
                         ("a", a)]
        ]
        lateral = None if lateral_m_s is None else _input("lateral_m_s", lateral_m_s, dtype, shape)
        if out is None:
            arrays_out = tuple(_aligned_empty(shape, dtype) for _ in names)
        else:
            if len(out) != len(names):
                raise TerzaghiError(f"out: {len(names)} arrays ({', '.join(names)}), got {len(out)}")
            arrays_out = tuple(_output(n, o, dtype, shape) for n, o in zip(names, out))
        more = arrays_out[3:] if len(names) == 6 else (None, None, None)
        self._inner.forces_into(beta, *arrays, *arrays_out[:3], lateral, *more)
        if out is None:
            return tuple(_as_kind(kind, o) for o in arrays_out)
        return tuple(out)
