"""Forces on legs moving through sand, from Python.

The models, the identification of a medium and the diagnosis of a recording are the
``terzaghi`` library's own (Rust, through a native module): the answers equal those of the
``terzaghi`` command line on the same inputs.

>>> import numpy as np, terzaghi
>>> f = terzaghi.predict(np.radians([30.0, 60.0]), length_m=0.1, width_m=0.025,
...                      hip_height_m=0.0, medium="poppy_lp")
>>> f["lift_n"].shape
(2,)

Every refused value raises :class:`TerzaghiError` (a ``ValueError``) with the words of its reason.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Union

import numpy as np

from . import _terzaghi
from ._terzaghi import TerzaghiError

__all__ = [
    "TerzaghiError",
    "REGIMES",
    "predict",
    "steady",
    "fit",
    "OnlineEstimator",
    "diagnose",
    "session_rows",
    "read_topics",
    "topic_counts",
    "Recorder",
    "Node",
]

#: The regimes' names, indexed by the codes :func:`predict` returns (``LegForce.msg``'s order).
REGIMES: List[str] = list(_terzaghi.REGIMES)

ArrayLike = Union[float, "np.typing.ArrayLike"]
PathLike = Union[str, "os.PathLike[str]"]


def _finite(name: str, value: Optional[float]) -> Optional[float]:
    if value is None:
        return None
    v = float(value)
    if not np.isfinite(v):
        raise TerzaghiError(f"{name} = {value!r}: must be a finite number")
    return v


def _vector(name: str, x, n: int, what: str) -> List[float]:
    """``x`` as ``n`` floats, from an array of shape ``(n,)`` only: a ``(1, n)`` or an ``(n + 1,)``
    is refused naming both shapes, as numpy refuses shapes that do not fit."""
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise TerzaghiError(f"{name}: not an array of numbers ({e})") from None
    if a.shape != (n,):
        raise TerzaghiError(f"{name} has shape {a.shape}, expected ({n},): {what}")
    return a.tolist()


def _broadcast(given: Dict[str, Any]) -> List[np.ndarray]:
    """The named inputs as float64 arrays broadcast together, as numpy broadcasts; inputs that
    are not numbers, or shapes that do not broadcast, are refused naming every input's shape."""
    try:
        arrays = [np.asarray(v, dtype=np.float64) for v in given.values()]
    except (TypeError, ValueError) as e:
        names = ", ".join(given)
        raise TerzaghiError(f"{names} must be numbers ({e})") from None
    try:
        return np.broadcast_arrays(*arrays)
    except ValueError:
        shapes = ", ".join(f"{k} {a.shape}" for k, a in zip(given, arrays))
        raise TerzaghiError(f"the inputs' shapes do not broadcast: {shapes}") from None


def _joints(names, position, velocity) -> tuple:
    """A JointState's names, positions and velocities: one position (and velocity, if given)
    per name, as arrays of shape ``(len(names),)``."""
    if isinstance(names, str):
        raise TerzaghiError(f"names must be a list of joint names, got the string {names!r}")
    names = [str(n) for n in names]
    what = f"one per name ({len(names)} names)"
    pos = _vector("position", position, len(names), what)
    vel = [] if velocity is None else _vector("velocity", velocity, len(names), what)
    return names, pos, vel


def _medium(medium, unit_weight_n_m3, phi_deg, delta_deg) -> tuple:
    """The medium as the native calls take it: a preset's name, or the three soil values."""
    return (medium, _finite("unit_weight_n_m3", unit_weight_n_m3), _finite("phi_deg", phi_deg),
            _finite("delta_deg", delta_deg))


def _profile(profile) -> Optional[List[tuple]]:
    """A polyline's points as ``[(s, q), ...]`` floats, or an error naming what is wrong."""
    if profile is None:
        return None
    p = np.asarray(profile, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2:
        raise TerzaghiError(f"profile has shape {p.shape}: give the mid-line as [(s, q), ...] in metres")
    return [(float(s), float(q)) for s, q in p]


def _model_tail(b_k, a, rft_coeffs, rft_zeta, rft_elements, shape, c_leg_radius_m,
                c_leg_span_deg, profile=None, medium_file=None) -> tuple:
    """The fitting width, RFT's values, the leg's shape and a medium file as the native calls
    take them."""
    if isinstance(rft_elements, bool) or int(rft_elements) != rft_elements or rft_elements < 1:
        raise TerzaghiError(f"rft_elements = {rft_elements!r}: must be a positive whole number")
    return (_finite("b_k", b_k), _finite("a", a), rft_coeffs, _finite("rft_zeta", rft_zeta),
            int(rft_elements), shape, _finite("c_leg_radius_m", c_leg_radius_m),
            _finite("c_leg_span_deg", c_leg_span_deg), _profile(profile),
            None if medium_file is None else os.fspath(medium_file))


#: The shapes that are bodies (by 3D RFT, with a medium file): ``predict`` and ``steady`` take
#: them with the values each needs, as ``terzaghi predict --shape`` and ``terzaghi steady``.
BODY_SHAPES = ("wheel", "disc", "sphere", "box", "mesh")


def _number(name: str, v, optional: bool = True) -> Optional[float]:
    """``v`` as a float, or a TerzaghiError naming ``name`` (``None`` passes if optional)."""
    if v is None and optional:
        return None
    try:
        return float(v)
    except (TypeError, ValueError):
        raise TerzaghiError(f"{name} {v!r} is not a number") from None


def _body(shape, radius_m, width_m, thickness_m, size_m, mesh_file, mesh_scale, element_m,
          grouser_count, grouser_height_m, grouser_thickness_m, rim_elements) -> tuple:
    """A body's values as the native calls take them, each checked and named."""
    grousers = (grouser_count, grouser_height_m, grouser_thickness_m)
    if any(g is not None for g in grousers) and not all(g is not None for g in grousers):
        raise TerzaghiError("grousers need grouser_count, grouser_height_m and grouser_thickness_m")
    if grouser_count is not None and (
            isinstance(grouser_count, bool) or not isinstance(grouser_count, (int, float, np.number))
            or not float(grouser_count).is_integer() or grouser_count < 1):
        raise TerzaghiError(f"grouser_count {grouser_count!r} is not a whole number of grousers >= 1")
    sizes = None
    if size_m is not None:
        try:
            sizes = [_number("size_m", v) for v in size_m]
        except TypeError:
            raise TerzaghiError(f"size_m {size_m!r} is not three sizes (m)") from None
    return (str(shape), _number("radius_m", radius_m), _number("width_m", width_m),
            _number("thickness_m", thickness_m), sizes,
            None if mesh_file is None else os.fspath(mesh_file),
            _number("mesh_scale", mesh_scale), _number("element_m", element_m),
            None if grouser_count is None else (int(grouser_count),
                                                _number("grouser_height_m", grouser_height_m),
                                                _number("grouser_thickness_m", grouser_thickness_m)),
            None if rim_elements is None else _whole("rim_elements", rim_elements))


def _body_or_leg(shape, length_m, width_m, body_values: Dict[str, Any]) -> tuple:
    """A body's values for the native calls and the leg's stand-ins there (``(body, 1.0, 1.0,
    "plate")``: its reach and width are its own), or ``(None, length_m, width_m, shape)`` for a
    leg; a ``length_m`` given a body, or a body's value given a leg, refused by name."""
    if shape in BODY_SHAPES:
        if length_m is not None:
            raise TerzaghiError(f"length_m is not given for a body ({shape}): its reach is its own")
        return _body(shape, width_m=width_m, **body_values), 1.0, 1.0, "plate"
    given = [k for k, v in body_values.items() if v is not None]
    if given:
        raise TerzaghiError(f"{given[0]} is for a body (shape one of {', '.join(BODY_SHAPES)})")
    return None, length_m, width_m, shape


def _whole(name: str, v) -> int:
    """``v`` as a whole number, or a TerzaghiError naming ``name``."""
    f = _number(name, v, False)
    if not f.is_integer() or f < 0:
        raise TerzaghiError(f"{name} {v!r} is not a whole number")
    return int(f)


def predict(
    beta_rad: ArrayLike,
    *,
    length_m: Optional[float] = None,
    width_m: Optional[float] = None,
    hip_height_m: ArrayLike,
    medium: Optional[str] = None,
    unit_weight_n_m3: Optional[float] = None,
    phi_deg: Optional[float] = None,
    delta_deg: Optional[float] = None,
    model: str = "improved",
    b_k: Optional[float] = None,
    a: Optional[float] = None,
    rft_coeffs: Optional[str] = None,
    rft_zeta: Optional[float] = None,
    rft_elements: Optional[int] = None,
    shape: str = "plate",
    c_leg_radius_m: Optional[float] = None,
    c_leg_span_deg: Optional[float] = None,
    profile=None,
    medium_file: Optional[PathLike] = None,
    up_m_s: Optional[ArrayLike] = None,
    forward_m_s: Optional[ArrayLike] = None,
    lateral_m_s: Optional[ArrayLike] = None,
    omega_rad_s: Optional[ArrayLike] = None,
    radius_m: Optional[float] = None,
    thickness_m: Optional[float] = None,
    size_m: Optional[Sequence[float]] = None,
    mesh_file: Optional[PathLike] = None,
    mesh_scale: Optional[float] = None,
    element_m: Optional[float] = None,
    grouser_count: Optional[int] = None,
    grouser_height_m: Optional[float] = None,
    grouser_thickness_m: Optional[float] = None,
    rim_elements: Optional[int] = None,
    planar_sheared_bearing: bool = False,
    band: bool = False,
) -> Dict[str, np.ndarray]:
    """The forces on a leg or a body at each attack angle, as ``terzaghi predict`` gives them.

    Args:
        beta_rad: attack angles (rad), an array of any shape (or a number).
        length_m, width_m: the plate, from the hip axis to the tip (m).
        hip_height_m: height of the hip axis above the free surface (m). An array (broadcast
            with ``beta_rad``) gives each sample its own hip, as the node's robot state does;
            for ``model="sinkage"`` it is minus the plate's depth.
        medium: a preset's name (see ``terzaghi media``), or else give
            ``unit_weight_n_m3``, ``phi_deg`` and ``delta_deg``.
        model: ``"improved"`` (default), ``"conventional"``, ``"rft"`` or ``"sinkage"`` (a
            horizontal plate pushed straight down, by the law of ``medium_file``, written by
            ``terzaghi calibrate``: a disc of diameter ``width_m``, or a rectangle with
            ``length_m``; ``up_m_s``, the plate's vertical velocity, tells loading, down at
            0.5 mm/s or faster, from unloading). With ``model="rft"``, ``medium_file`` (of
            the ``rft_depth_power`` law) gives RFT's stresses its scale and depth exponent.
        b_k, a: the improved model's fitting width (default: the preset's for this width).
        rft_coeffs, rft_zeta, rft_elements: RFT's coefficient set, its generic scale
            (N/cm^3) and its elements over the submerged length.
        shape: ``"plate"`` or ``"c_leg"`` (RHex's C-leg, an arc whose chord is ``length_m``,
            of ``c_leg_radius_m`` (default half the length) over ``c_leg_span_deg`` (default
            180); RFT only, as the node's ``<leg>.shape: c_leg``), or ``"polyline"`` (any
            mid-line: ``profile``, ``[(s, q), ...]`` in metres from the hip, ``s`` along the
            chord, ``q`` toward the travel; RFT only, as ``<leg>.shape: polyline``); or a body
            (:data:`BODY_SHAPES`: ``"wheel"``, ``"disc"``, ``"sphere"``, ``"box"``, ``"mesh"``,
            about the hip, its hub) with the values :func:`steady` takes (``radius_m``,
            ``width_m``, ``thickness_m``, ``size_m``, ``mesh_file``, ``mesh_scale``,
            ``element_m``, the grousers, ``rim_elements``): RFT with ``medium_file``; its reach
            and width are its own (``length_m`` is not given); its hub may be below the surface.
        up_m_s, forward_m_s, lateral_m_s, omega_rad_s: the hip's velocity (up, forward, to the
            robot's left; m/s) and the leg's rotation rate (rad/s, + as the attack angle grows),
            arrays broadcast with ``beta_rad``. Without them a leg turns quasi-statically and a
            body is held (the sand's reaction to it, no drag), as ``terzaghi predict``.
        planar_sheared_bearing: a planar leg (plate, C-leg, polyline) takes ``medium_file``'s
            bearing of sheared sand, as ``terzaghi predict --planar-sheared-bearing`` (a body
            always does; off by default, as a leg turning through fresh sand loses lift it
            keeps: ``docs/bodies.md``).
        band: add the band of ``medium_file``'s trial-to-trial scatter, as ``terzaghi predict
            --band``: ``drag_low_n``, ``drag_high_n``, ``lift_low_n``, ``lift_high_n``,
            ``hip_torque_low_nm``, ``hip_torque_high_nm``, the forces at the band's low and
            high scale (90 % of further trials of the sand so prepared between them; at a given
            depth every stress scales with the sand's scale). A file without a band is refused.

    Returns:
        A dict of arrays shaped like ``beta_rad``: ``drag_n``, ``lift_n``,
        ``hip_torque_nm``, ``submerged_m``, ``depth_m`` (float64) and ``regime``
        (uint8 codes; their names are :data:`REGIMES`); for a body, or a leg moving sideways,
        also ``side_n``, ``roll_moment_nm`` and ``yaw_moment_nm``.

    Raises:
        TerzaghiError: a value the model refuses (a NaN angle, a plate that never enters the
            medium, an unknown preset, ...), named.
    """
    body_values = dict(radius_m=radius_m, thickness_m=thickness_m, size_m=size_m,
                       mesh_file=mesh_file, mesh_scale=mesh_scale, element_m=element_m,
                       grouser_count=grouser_count, grouser_height_m=grouser_height_m,
                       grouser_thickness_m=grouser_thickness_m, rim_elements=rim_elements)
    if shape in BODY_SHAPES and rft_elements is not None:
        raise TerzaghiError(f"rft_elements is for a leg's mid-line: a body ({shape}) is cut "
                            "by element_m or rim_elements")
    body, length_m, width_m, shape = _body_or_leg(shape, length_m, width_m, body_values)
    if body is None:
        if width_m is None:
            raise TerzaghiError("width_m is needed (the leg's width, m)")
        if length_m is None:
            if model != "sinkage":
                raise TerzaghiError("length_m is needed (the leg from the hip axis to the tip)")
            length_m = width_m  # a disc
    tail = (*_medium(medium, unit_weight_n_m3, phi_deg, delta_deg),
            *_model_tail(b_k, a, rft_coeffs, rft_zeta,
                         100 if rft_elements is None else rft_elements, shape, c_leg_radius_m,
                         c_leg_span_deg, profile, medium_file))
    motion = {"up_m_s": up_m_s, "forward_m_s": forward_m_s, "lateral_m_s": lateral_m_s,
              "omega_rad_s": omega_rad_s}
    moving = any(v is not None for v in motion.values())
    # The side force and the moments about the heading and the vertical: a body's, or a leg's
    # moving sideways (as terzaghi predict's columns).
    full = body is not None or (lateral_m_s is not None and np.any(np.asarray(lateral_m_s) != 0))
    if model == "sinkage" or body is not None or np.ndim(hip_height_m) > 0 or moving:
        given = {"beta_rad": beta_rad, "hip_height_m": hip_height_m,
                 **{k: 0.0 if v is None else v for k, v in motion.items()}}
        b, h, u, f, l, w = _broadcast(given)
        cols, regime = _terzaghi.predict_moving(
            b.ravel().tolist(), h.ravel().tolist(), u.ravel().tolist(), f.ravel().tolist(),
            l.ravel().tolist(), w.ravel().tolist(), model, float(length_m), float(width_m),
            *tail, body, bool(planar_sheared_bearing))
        drag, lift, torque, submerged, depth, side, roll, yaw = (
            np.asarray(c).reshape(b.shape) for c in cols)
        regime = np.frombuffer(bytes(regime), dtype=np.uint8).reshape(b.shape).copy()
    else:
        drag, lift, torque, submerged, depth, regime = _terzaghi.predict(
            beta_rad, model, float(length_m), float(width_m), float(hip_height_m), *tail,
            bool(planar_sheared_bearing))
    out = {
        "drag_n": drag,
        "lift_n": lift,
        "hip_torque_nm": torque,
        "submerged_m": submerged,
        "depth_m": depth,
        "regime": regime,
    }
    if full:
        out.update(side_n=side, roll_moment_nm=roll, yaw_moment_nm=yaw)
    if band:
        out.update(_band_columns(out, model, medium_file))
    return out


def _band_columns(out: Dict[str, np.ndarray], model: str, medium_file) -> Dict[str, np.ndarray]:
    """The forces of ``out`` at the band's low and high scale of ``medium_file``."""
    if medium_file is None or model not in ("sinkage", "rft"):
        raise TerzaghiError("band is the medium file's scatter: it goes with medium_file and "
                            f"model 'sinkage' or 'rft' (model {model!r}, medium_file {medium_file!r})")
    low, high, _ = _terzaghi.medium_band(os.fspath(medium_file))
    columns = (("drag_n", "drag", "n"), ("lift_n", "lift", "n"), ("hip_torque_nm", "hip_torque", "nm"))
    return {f"{name}_{end}_{unit}": out[k] * scale
            for k, name, unit in columns for end, scale in (("low", low), ("high", high))}


def steady(
    load_n: ArrayLike = None,
    hub_vx_m_s: ArrayLike = 0.01,
    omega_rad_s: ArrayLike = 0.0,
    slip_angle_deg: ArrayLike = 0.0,
    *,
    medium_file: PathLike,
    shape: str = "wheel",
    radius_m: Optional[float] = None,
    width_m: Optional[float] = None,
    thickness_m: Optional[float] = None,
    size_m: Optional[Sequence[float]] = None,
    mesh_file: Optional[PathLike] = None,
    mesh_scale: Optional[float] = None,
    element_m: Optional[float] = None,
    grouser_count: Optional[int] = None,
    grouser_height_m: Optional[float] = None,
    grouser_thickness_m: Optional[float] = None,
    rim_elements: Optional[int] = None,
    sinkage_m: Optional[ArrayLike] = None,
    band: bool = False,
) -> Dict[str, np.ndarray]:
    """A wheel's or a foot's steady state under each run's load, as ``terzaghi steady`` gives it.

    Args:
        load_n: the load the sand must bear (N), an array of any shape (or a number); leave it
            out with ``sinkage_m``.
        hub_vx_m_s: the hub's speed over the ground along its travel (m/s).
        omega_rad_s: the rotation rate (rad/s, + rolling forward).
        slip_angle_deg: the heading's angle from the travel (deg, + the travel toward the
            wheel's left).
        medium_file: a medium file (``terzaghi calibrate``).
        shape: ``"wheel"`` (``radius_m``, ``width_m``, grousers), ``"disc"`` (``radius_m``,
            ``thickness_m``: a flat pad, its axis vertical), ``"sphere"`` (``radius_m``),
            ``"box"`` (``size_m``: along the heading, across it, up) or ``"mesh"``
            (``mesh_file``: a closed STL, ``mesh_scale`` metres per unit), as ``terzaghi
            steady --shape`` takes them; a value another shape takes is refused by name.
        radius_m, width_m: the wheel's rim radius and width (m); radius_m a disc's or sphere's.
        thickness_m: a disc's thickness (m).
        size_m: a box's three sizes (m).
        mesh_file, mesh_scale: a mesh's STL file, its hub at the file's origin, and the metres
            one of its units is (default 1; 0.001 for millimetres).
        element_m: a foot's or a mesh's elements, their longest edge (m; default 0.002).
        grouser_count, grouser_height_m, grouser_thickness_m: grousers, all three or none.
        rim_elements: elements of a wheel's rim (at least 360; default 720). A value the shape
            does not take is refused, as a default or not.
        sinkage_m: hold each run at this sinkage (m) instead of solving for it; the load the
            sand bears there is then ``load_borne_n``.
        band: add the band of ``medium_file``'s trial-to-trial scatter, as ``terzaghi steady
            --band``: each run solved again in sand at the band's low and high scale (90 % of
            further trials of the sand so prepared between them): ``sinkage_low_m``,
            ``sinkage_high_m``, ``drawbar_low_n``, ``drawbar_high_n`` (low: the softer sand,
            the deeper sinkage), or with ``sinkage_m`` ``load_borne_low_n`` and
            ``load_borne_high_n``. A file without a band is refused.

    The arrays broadcast together (as numpy broadcasts); a shape that does not is refused
    naming every shape.

    Returns:
        A dict of float64 arrays of the broadcast shape: ``sinkage_m``, ``drawbar_n`` (+
        forward), ``side_n`` (+ opposing the sideways motion), ``torque_nm`` (the drive torque,
        + along a forward roll), ``load_borne_n``; and ``borne``, a bool array: False where the
        sand does not bear the run's load within the body's height (that run's row is the body
        buried to its top, ``load_borne_n`` the most the sand bears there), as ``terzaghi
        steady`` writes such a run.

    Raises:
        TerzaghiError: a value the model refuses (a NaN, a bad wheel or medium file), named
            with the run's flat index.
    """
    given = {"hub_vx_m_s": hub_vx_m_s, "omega_rad_s": omega_rad_s,
             "slip_angle_deg": slip_angle_deg}
    if sinkage_m is None:
        if load_n is None:
            raise TerzaghiError("load_n is needed (or sinkage_m, to hold each run at a depth)")
        given["load_n"] = load_n
    else:
        if load_n is not None:
            raise TerzaghiError("give load_n (the sinkage is solved for) or sinkage_m, not both")
        given["sinkage_m"] = sinkage_m
    b = _broadcast(given)
    flat = {k: a.ravel().tolist() for k, a in zip(given, b)}
    body = _body(shape, radius_m, width_m, thickness_m, size_m, mesh_file, mesh_scale, element_m,
                 grouser_count, grouser_height_m, grouser_thickness_m, rim_elements)
    n = len(flat["hub_vx_m_s"])

    def solve(scale: float) -> List[List[float]]:
        return _terzaghi.steady(
            flat.get("load_n", [0.0] * n), flat["hub_vx_m_s"], flat["omega_rad_s"],
            flat["slip_angle_deg"], flat.get("sinkage_m"), body, os.fspath(medium_file), scale)

    cols = solve(1.0)
    shape = b[0].shape
    names = ("sinkage_m", "drawbar_n", "side_n", "torque_nm", "load_borne_n")
    out = {k: np.asarray(c, dtype=np.float64).reshape(shape) for k, c in zip(names, cols)}
    out["borne"] = np.asarray(cols[5], dtype=np.float64).reshape(shape) > 0.5
    if band:
        low, high, _ = _terzaghi.medium_band(os.fspath(medium_file))
        banded = (("load_borne", "n", 4),) if sinkage_m is not None else (
            ("sinkage", "m", 0), ("drawbar", "n", 1))
        for end, scale in (("low", low), ("high", high)):
            c = solve(scale)
            for name, unit, k in banded:
                out[f"{name}_{end}_{unit}"] = np.asarray(c[k], dtype=np.float64).reshape(shape)
    return out


def fit(
    beta_rad: ArrayLike,
    drag_n: ArrayLike,
    lift_n: ArrayLike,
    *,
    length_m: float,
    width_m: float,
    hip_height_m: float,
    medium: Optional[str] = None,
    unit_weight_n_m3: Optional[float] = None,
    phi_deg: Optional[float] = None,
    delta_deg: Optional[float] = None,
    fit_delta: bool = False,
    all_regimes: bool = False,
) -> Dict[str, Any]:
    """The batch fit of ``b_k`` and ``a`` (and ``delta``) to measured forces.

    The same fit as ``terzaghi fit --json``, and the same fields: ``b_k``, ``a``,
    ``delta_deg``, the samples used and skipped, and the goodness of fit of the
    conventional and improved models.

    Args:
        beta_rad, drag_n, lift_n: arrays of one shape: attack angle (rad) and the measured
            drag and lift in the hip frame (N). Non-finite samples are skipped and counted.
        length_m, width_m, hip_height_m, medium, unit_weight_n_m3, phi_deg, delta_deg: the
            plate and medium, as for :func:`predict`.
        fit_delta: fit the plate-medium friction angle as well.
        all_regimes: use every submerged sample, not only penetration.
    """
    text = _terzaghi.fit_json(
        beta_rad,
        drag_n,
        lift_n,
        float(length_m),
        float(width_m),
        float(hip_height_m),
        *_medium(medium, unit_weight_n_m3, phi_deg, delta_deg),
        bool(fit_delta),
        bool(all_regimes),
    )
    return json.loads(text)


class OnlineEstimator:
    """The node's online estimator of ``b_k`` and ``a`` (recursive least squares).

    Feed it samples in time order with :meth:`update`; :attr:`estimate` is then what
    ``terzaghi identify --online --json`` reports after the same samples: ``b_k``, ``a``,
    ``delta_deg`` with their standard deviations (``std_b_k``, ``std_a``), the samples used
    and skipped, and whether it has ``converged``.

    Args:
        length_m, width_m, hip_height_m, medium, unit_weight_n_m3, phi_deg, delta_deg: the
            plate and medium, as for :func:`predict`.
        fit_delta: estimate the plate-medium friction angle as well.
        forgetting: a forgetting factor per sample (0 < f <= 1) instead of the default
            memory of strokes.
        min_unit_force_n: the excitation gate (least unit-width model force, N).
    """

    def __init__(
        self,
        *,
        length_m: float,
        width_m: float,
        hip_height_m: float,
        medium: Optional[str] = None,
        unit_weight_n_m3: Optional[float] = None,
        phi_deg: Optional[float] = None,
        delta_deg: Optional[float] = None,
        fit_delta: bool = False,
        forgetting: Optional[float] = None,
        min_unit_force_n: Optional[float] = None,
    ) -> None:
        self._inner = _terzaghi.OnlineEstimator(
            float(length_m),
            float(width_m),
            float(hip_height_m),
            *_medium(medium, unit_weight_n_m3, phi_deg, delta_deg),
            bool(fit_delta),
            _finite("forgetting", forgetting),
            _finite("min_unit_force_n", min_unit_force_n),
        )

    def update(
        self,
        beta_rad: ArrayLike,
        drag_n: ArrayLike,
        lift_n: ArrayLike,
        t_s: Optional[ArrayLike] = None,
    ) -> int:
        """Feeds one sample, or arrays of one shape in order; returns how many updated the
        estimate (the rest are counted in :attr:`estimate` as skipped)."""
        return self._inner.update(beta_rad, drag_n, lift_n, t_s)

    @property
    def estimate(self) -> Dict[str, Any]:
        """The current estimate (a dict; see the class's description)."""
        return json.loads(self._inner.estimate_json())


def diagnose(
    path: PathLike,
    out: PathLike,
    *,
    medium_file: Optional[PathLike] = None,
    shape: Optional[str] = None,
    radius_m: Optional[float] = None,
    width_m: Optional[float] = None,
    thickness_m: Optional[float] = None,
    size_m: Optional[Sequence[float]] = None,
    mesh_file: Optional[PathLike] = None,
    mesh_scale: Optional[float] = None,
    element_m: Optional[float] = None,
    grouser_count: Optional[int] = None,
    grouser_height_m: Optional[float] = None,
    grouser_thickness_m: Optional[float] = None,
    rim_elements: Optional[int] = None,
) -> List[Dict[str, Any]]:
    """Diagnoses a recording as ``terzaghi diagnose --out OUT --json`` does.

    Args:
        path: an MCAP session (each leg with an F/T topic); a plate-sinkage test (then
            ``medium_file`` names the medium, written by ``terzaghi calibrate``); or a wheel's
            or a foot's runs (a CSV in ``terzaghi steady``'s format with the measured
            ``sinkage_m`` and ``drawbar_n``: then ``medium_file`` and the body, ``shape`` with
            the values ``steady`` takes).
        out: the directory the reports go to (``report.json``, ``report.html``,
            ``corrected.yaml``; one directory per leg when there are several; for a body's
            runs ``report.json`` and, where the effect found is the sheared sand's bearing,
            ``corrected_medium.yaml``).

    Returns:
        One report per leg (or the body's), as ``report.json`` holds it.
    """
    body = None
    if shape is not None:
        body = _body(shape, radius_m, width_m, thickness_m, size_m, mesh_file, mesh_scale,
                     element_m, grouser_count, grouser_height_m, grouser_thickness_m, rim_elements)
    elif any(v is not None for v in (radius_m, width_m, thickness_m, size_m, mesh_file, mesh_scale,
                                     element_m, grouser_count, rim_elements)):
        raise TerzaghiError("a body's values describe a wheel's or a foot's runs: give its shape too")
    text = _terzaghi.diagnose_json(
        os.fspath(path),
        os.fspath(out),
        None if medium_file is None else os.fspath(medium_file),
        body,
    )
    return json.loads(text)


def _param_text(name: str, value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float, str)):
        return str(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_param_text(name, v) for v in value) + "]"
    raise TerzaghiError(f"parameter {name} = {value!r}: expected a bool, number, string or list of them")


def session_rows(
    path: PathLike,
    *,
    params_file: Optional[PathLike] = None,
    params: Optional[Dict[str, Any]] = None,
    pandas: bool = False,
) -> Dict[str, Any]:
    """A recording's rows per leg, re-evaluated through the node's own code.

    The rows of ``terzaghi replay --reevaluate PATH -o rows.csv``: each prediction next to the
    measurement it was matched with. ``path`` is an MCAP session (its recorded parameters) or a
    CSV force log; ``params_file`` and ``params`` (``{"use_identified": False}``) set the
    node's parameters as ``--params-file`` and ``-p`` do.

    Returns:
        ``{leg: {column: array}}`` (columns ``t_s``, ``beta_rad``, ``regime`` codes,
        ``measured_drag_n`` and ``measured_lift_n`` (NaN where the row has none),
        ``predicted_drag_n``, ``predicted_lift_n``, ``predicted_hip_torque_nm``, ``b_k``, ``a``,
        ``identified``, ``bare_*``, ``expected_reading_*``, and a body's ``predicted_side_n``,
        ``predicted_roll_moment_nm``, ``predicted_yaw_moment_nm``), or ``{leg: DataFrame}`` with
        ``pandas=True`` (its ``regime`` column by name).
    """
    pairs = [(str(k), _param_text(str(k), v)) for k, v in (params or {}).items()]
    names, cols = _terzaghi.reevaluate(
        os.fspath(path), None if params_file is None else os.fspath(params_file), pairs
    )
    columns = dict(zip(_terzaghi.REEVALUATE_COLUMNS, cols))
    leg = columns.pop("leg").astype(np.int64)
    columns["regime"] = columns["regime"].astype(np.uint8)
    columns["identified"] = columns["identified"].astype(bool)
    out: Dict[str, Any] = {}
    for i, name in enumerate(names):
        mine = leg == i
        legs = {k: v[mine] for k, v in columns.items()}
        if pandas:
            import pandas as pd

            df = pd.DataFrame(legs)
            df["regime"] = [REGIMES[c] for c in df["regime"]]
            out[name] = df
        else:
            out[name] = legs
    return out


def read_topics(path: PathLike, topics: Optional[List[str]] = None, *,
                pandas: bool = False) -> Dict[str, Any]:
    """A recording's topics as tables: one row per message, in the recording's order.

    The types read are the node's and its inputs': ``sensor_msgs/JointState`` (a column per
    joint and field: ``position.<joint>``, ``velocity.<joint>``, ``effort.<joint>``, NaN where
    a message does not name the joint), ``geometry_msgs/WrenchStamped`` (``force_x_n``, ...,
    ``torque_z_nm``), ``geometry_msgs/PoseStamped`` (``x_m``, ``y_m``, ``z_m``, ``qx``, ...,
    ``qw``), ``terzaghi_msgs/LegForce`` and ``terzaghi_msgs/ModelParams`` (their numeric fields;
    booleans as 0 or 1). Every table has ``log_time_s`` and ``stamp_s`` (the header's stamp),
    seconds since the Unix epoch. Topics of other types are left out; a message that does not
    decode is skipped, and counted by :func:`topic_counts`.

    Args:
        path: the ``.mcap`` recording.
        topics: the topics to read (default: every topic of a type read); naming a topic the
            recording lacks, or one of a type not read, is an error.
        pandas: a ``pandas.DataFrame`` per topic instead of a dict of arrays.

    Returns:
        ``{topic: {column: array}}`` (or ``{topic: DataFrame}``).
    """
    tables = _terzaghi.read_topics(os.fspath(path), None if topics is None else list(topics))
    out: Dict[str, Any] = {}
    for topic, type_name, read, _messages, _bad, cols in tables:
        if not read:
            if topics is not None:
                raise TerzaghiError(f"{topic} carries {type_name}, which read_topics does not read")
            continue
        d = dict(cols)
        if pandas:
            import pandas as pd

            d = pd.DataFrame(d)
        out[topic] = d
    return out


def topic_counts(path: PathLike) -> Dict[str, Dict[str, Any]]:
    """Each topic of a recording: its type, its messages, whether :func:`read_topics` reads its
    type, and how many of its messages did not decode."""
    return {topic: {"type": type_name, "messages": messages, "read": read, "undecodable": bad}
            for topic, type_name, read, messages, bad, _ in
            _terzaghi.read_topics(os.fspath(path), None)}


class Recorder:
    """A session written to MCAP in the node's topics and message types, with node parameters
    as its metadata, so that ``terzaghi diagnose`` and ``replay --reevaluate`` read it as they
    read a robot's recording. Use as a context manager (the file is finished on exit); an
    existing file is refused unless ``overwrite``.

    Args:
        path: the ``.mcap`` file to write.
        params: the node's parameters, ``{name: value}`` (``legs``, each leg's ``joint``,
            geometry, ``medium`` and ``ft_topic``, ...), as a parameter file would give them.
    """

    def __init__(self, path: PathLike, params: Dict[str, Any], *, overwrite: bool = False) -> None:
        pairs = [(str(k), _param_text(str(k), v)) for k, v in params.items()]
        self._inner = _terzaghi.Recorder(os.fspath(path), pairs, bool(overwrite))

    def joint_state(self, t_ns: int, names: List[str], position, velocity=None,
                    topic: str = "/joint_states") -> None:
        """A ``sensor_msgs/JointState`` stamped ``t_ns`` (ns since the Unix epoch)."""
        names, pos, vel = _joints(names, position, velocity)
        self._inner.joint_state(topic, int(t_ns), names, pos, vel)

    def wrench(self, topic: str, t_ns: int, force, torque=(0.0, 0.0, 0.0), frame_id: str = "") -> None:
        """A ``geometry_msgs/WrenchStamped`` (N, N m)."""
        self._inner.wrench(topic, int(t_ns), frame_id, _vector("force", force, 3, "(x, y, z) in N"),
                           _vector("torque", torque, 3, "(x, y, z) in N m"))

    def pose(self, topic: str, t_ns: int, position, orientation_xyzw, frame_id: str = "") -> None:
        """A ``geometry_msgs/PoseStamped`` (m; a unit quaternion x, y, z, w)."""
        self._inner.pose(topic, int(t_ns), frame_id, _vector("position", position, 3, "(x, y, z) in m"),
                         _vector("orientation_xyzw", orientation_xyzw, 4, "a quaternion (x, y, z, w)"))

    def close(self) -> int:
        """Finishes the file; returns the messages written."""
        return self._inner.close()

    def __enter__(self) -> "Recorder":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class Node:
    """The node's core, without DDS or a clock: it predicts each leg's force from the messages a
    robot would send it, exactly as ``terzaghi node`` publishes them. With a ``corrected.yaml``
    of :func:`diagnose` as its parameters, it predicts with the corrections the diagnosis found.

    Args:
        params_file: a node parameter file (``corrected.yaml``, a robot's parameters); optional.
        params: parameters over the file's, ``{name: value}`` (as ``-p name:=value``).

    Feed it in stamp order: :meth:`pose` (the body's pose, for a robot whose hips
    ``<leg>.hip_offset_m`` places in the body), :meth:`wrench` (a leg's measured F/T, which the
    node learns from) and :meth:`joint_state`, which returns the legs' predictions.
    """

    def __init__(self, params_file: Optional[PathLike] = None,
                 params: Optional[Dict[str, Any]] = None) -> None:
        pairs = [(str(k), _param_text(str(k), v)) for k, v in (params or {}).items()]
        self._inner = _terzaghi.Node(None if params_file is None else os.fspath(params_file), pairs)
        #: The legs' names, in the order of the ``legs`` parameter and of the returned arrays.
        self.legs: List[str] = list(self._inner.legs())
        self._fields = list(_terzaghi.NODE_FIELDS)

    @property
    def params(self) -> Dict[str, str]:
        """The parameters the node runs with (defaults, the file, the overrides), as text: what
        a :class:`Recorder` stores so that a recording replays with them."""
        return dict(self._inner.params())

    def pose(self, t_ns: int, position, orientation_xyzw, frame_id: str = "") -> None:
        """The body's pose at ``t_ns`` (ns): position (m) and unit quaternion ``(x, y, z, w)``
        in ``frame_id`` (the world frame when empty)."""
        self._inner.pose(int(t_ns), _vector("position", position, 3, "(x, y, z) in m"),
                         _vector("orientation_xyzw", orientation_xyzw, 4, "a quaternion (x, y, z, w)"),
                         frame_id)

    def wrench(self, leg: Union[int, str], t_ns: int, force, torque=(0.0, 0.0, 0.0),
               frame_id: str = "") -> None:
        """Leg ``leg``'s (index or name) measured F/T at ``t_ns`` (N, N m, in its sensor's
        frame)."""
        if isinstance(leg, str):
            if leg not in self.legs:
                raise TerzaghiError(f"leg {leg!r}: the node's legs are {self.legs}")
            i = self.legs.index(leg)
        else:
            i = int(leg)
            if not 0 <= i < len(self.legs):
                raise TerzaghiError(f"leg {leg!r}: the node has {len(self.legs)} legs (0 to {len(self.legs) - 1})")
        self._inner.wrench(i, int(t_ns), _vector("force", force, 3, "(x, y, z) in N"),
                           _vector("torque", torque, 3, "(x, y, z) in N m"), frame_id)

    def joint_state(self, t_ns: int, names: List[str], position, velocity=None) -> Dict[str, np.ndarray]:
        """A JointState at ``t_ns``: returns each leg's prediction as arrays over
        :attr:`legs` (NaN for a leg whose joint the message does not name): ``drag_n``,
        ``lift_n``, ``hip_torque_nm`` (the medium's force with every correction),
        ``sensor_drag_n``, ``sensor_lift_n`` (what its F/T sensor is expected to read),
        ``bare_drag_n``, ``bare_lift_n`` (the bare model's), ``hip_height_m``,
        ``attack_angle_rad`` and ``regime`` (codes, :data:`REGIMES`)."""
        names, pos, vel = _joints(names, position, velocity)
        cols = self._inner.joint_state(int(t_ns), names, pos, vel)
        return {k: np.asarray(v) for k, v in zip(self._fields, cols)}


def rhex_params() -> Dict[str, str]:
    """The shipped six-legged robot's node parameters (``launch_configs/rhex.yaml``), each value
    as the text a parameter file holds (a string quoted)."""
    return dict(_terzaghi.rhex_params())
