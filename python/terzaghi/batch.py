"""The model for many legs at once: a simulator's environments times legs, one call per step.

>>> import numpy as np
>>> from terzaghi.batch import LegBatch
>>> legs = LegBatch(length_m=0.1, width_m=0.025, medium="poppy_lp")
>>> beta = np.full((4096, 6), 0.6); hip = np.full((4096, 6), 0.02)
>>> drag, lift, torque = legs.forces(beta, hip)
>>> drag.shape
(4096, 6)

The arrays are read and written in place, without a copy when they are C-contiguous float64:
pass ``out=(drag, lift, torque)`` to reuse arrays from step to step, and nothing is allocated
per call. The work is shared over every core, without the interpreter's lock.
"""

from __future__ import annotations

from typing import Optional, Tuple

import numpy as np

from . import TerzaghiError, _medium, _model_tail, _terzaghi

__all__ = ["LegBatch"]

Arrays = Tuple[np.ndarray, np.ndarray, np.ndarray]


def _f64(name: str, x) -> np.ndarray:
    try:
        return np.ascontiguousarray(x, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise TerzaghiError(f"{name}: not an array of numbers ({e})") from None


def _like(name: str, x, beta: np.ndarray) -> np.ndarray:
    """``x`` as a C-contiguous float64 array of ``beta``'s shape: a scalar is broadcast (as
    :func:`terzaghi.predict` does), any other shape is refused by name, even with as many
    values (a transposed ``(6, 4096)`` against ``(4096, 6)`` would read the legs out of order)."""
    if np.ndim(x) == 0:
        try:
            return np.full(beta.shape, float(x))
        except (TypeError, ValueError) as e:
            raise TerzaghiError(f"{name}: not a number ({e})") from None
    a = _f64(name, x)
    if a.shape != beta.shape:
        hint = " (transposed?)" if a.shape == beta.shape[::-1] and a.ndim > 1 else ""
        raise TerzaghiError(
            f"{name} has shape {a.shape}, beta_rad {beta.shape}{hint}: give each input the "
            "shape of beta_rad, or a scalar")
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
        b_k, a, rft_coeffs, rft_zeta, rft_elements: as for :func:`terzaghi.predict`.
    """

    def __init__(
        self,
        *,
        length_m: float,
        width_m: float,
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
        rft_elements: int = 100,
        c_leg_radius_m: Optional[float] = None,
        c_leg_span_deg: Optional[float] = None,
        profile=None,
        medium_file=None,
    ) -> None:
        self._inner = _terzaghi.Batch(
            model,
            float(length_m),
            float(width_m),
            *_medium(medium, unit_weight_n_m3, phi_deg, delta_deg),
            *_model_tail(b_k, a, rft_coeffs, rft_zeta, rft_elements, shape, c_leg_radius_m,
                         c_leg_span_deg, profile, medium_file),
        )

    def forces(
        self,
        beta_rad,
        hip_height_m,
        *,
        pitch_rad=None,
        omega_rad_s=None,
        forward_m_s=None,
        up_m_s=None,
        out: Optional[Arrays] = None,
    ) -> Arrays:
        """Drag, lift (N) and hip torque (N m) of every leg.

        Args:
            beta_rad: each leg's joint angle (rad), any shape.
            hip_height_m: each hip's height above the surface (m), the same shape (a scalar is
                broadcast).
            pitch_rad, omega_rad_s, forward_m_s, up_m_s: the body's pitch, the leg's rate and
                the hip's horizontal (forward) and vertical (up) velocity; zero if left out.
                RFT uses the velocities; the improved model uses the pitch and height.
            out: three C-contiguous float64 arrays of that shape to write into.

        Raises:
            TerzaghiError: a non-finite input (its flat index named), or an input or output
                array whose shape differs from ``beta_rad``'s (its name and both shapes).
        """
        beta = _f64("beta_rad", beta_rad)
        arrays = [_like("hip_height_m", hip_height_m, beta)] + [
            None if v is None else _like(n, v, beta)
            for n, v in [("pitch_rad", pitch_rad), ("omega_rad_s", omega_rad_s),
                         ("forward_m_s", forward_m_s), ("up_m_s", up_m_s)]
        ]
        if out is None:
            out = (np.empty_like(beta), np.empty_like(beta), np.empty_like(beta))
        self._inner.forces_into(beta, *arrays, *out)
        return out
