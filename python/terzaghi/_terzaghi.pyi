"""Type stubs of the native module; the documented API is in ``terzaghi/__init__.py``."""

from typing import List, Optional, Tuple

import numpy as np
import numpy.typing as npt

REGIMES: List[str]

class TerzaghiError(ValueError):
    """A value terzaghi refuses, with the words of its reason."""

# A body: shape, radius, width, thickness, sizes, mesh file, mesh scale, element size,
# grousers (count, height, thickness), rim elements.
BodyArgs = Tuple[
    str,
    Optional[float],
    Optional[float],
    Optional[float],
    Optional[List[float]],
    Optional[str],
    Optional[float],
    Optional[float],
    Optional[Tuple[int, float, float]],
    Optional[int],
]

def steady(
    load_n: List[float],
    hub_vx_m_s: List[float],
    omega_rad_s: List[float],
    slip_angle_deg: List[float],
    sinkage_m: Optional[List[float]],
    body: BodyArgs,
    medium_file: str,
    scale: float = 1.0,
) -> List[List[float]]: ...

def medium_band(medium_file: str) -> Tuple[float, float, float]: ...

def predict(
    beta_rad: npt.ArrayLike,
    model: str,
    length_m: float,
    width_m: float,
    hip_height_m: float,
    medium: Optional[str],
    unit_weight_n_m3: Optional[float],
    phi_deg: Optional[float],
    delta_deg: Optional[float],
    b_k: Optional[float],
    a: Optional[float],
    rft_coeffs: Optional[str],
    rft_zeta: Optional[float],
    rft_elements: int,
    shape: str,
    c_leg_radius_m: Optional[float],
    c_leg_span_deg: Optional[float],
    profile: Optional[List[Tuple[float, float]]],
    medium_file: Optional[str],
    planar_sheared_bearing: bool = ...,
) -> Tuple[
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.uint8],
]: ...

def predict_moving(
    beta_rad: List[float],
    hip_height_m: List[float],
    up_m_s: List[float],
    forward_m_s: List[float],
    lateral_m_s: List[float],
    omega_rad_s: List[float],
    model: str,
    length_m: float,
    width_m: float,
    medium: Optional[str],
    unit_weight_n_m3: Optional[float],
    phi_deg: Optional[float],
    delta_deg: Optional[float],
    b_k: Optional[float],
    a: Optional[float],
    rft_coeffs: Optional[str],
    rft_zeta: Optional[float],
    rft_elements: int,
    shape: str,
    c_leg_radius_m: Optional[float],
    c_leg_span_deg: Optional[float],
    profile: Optional[List[Tuple[float, float]]],
    medium_file: Optional[str],
    body: Optional[BodyArgs],
    planar_sheared_bearing: bool = ...,
) -> Tuple[List[List[float]], List[int]]: ...
def fit_json(
    beta_rad: npt.ArrayLike,
    drag_n: npt.ArrayLike,
    lift_n: npt.ArrayLike,
    length_m: float,
    width_m: float,
    hip_height_m: float,
    medium: Optional[str],
    unit_weight_n_m3: Optional[float],
    phi_deg: Optional[float],
    delta_deg: Optional[float],
    fit_delta: bool,
    all_regimes: bool,
) -> str: ...
def diagnose_json(
    path: str, out: str, medium_file: Optional[str], body: Optional[BodyArgs]
) -> str: ...
def recording_info(path: str) -> Tuple[Optional[int], Optional[int], int]: ...

REEVALUATE_COLUMNS: List[str]

def reevaluate(
    path: str, params_file: Optional[str], params: List[Tuple[str, str]]
) -> Tuple[List[str], List[npt.NDArray[np.float64]]]: ...

class OnlineEstimator:
    def __init__(
        self,
        length_m: float,
        width_m: float,
        hip_height_m: float,
        medium: Optional[str],
        unit_weight_n_m3: Optional[float],
        phi_deg: Optional[float],
        delta_deg: Optional[float],
        fit_delta: bool,
        forgetting: Optional[float],
        min_unit_force_n: Optional[float],
    ) -> None: ...
    def update(
        self,
        beta_rad: npt.ArrayLike,
        drag_n: npt.ArrayLike,
        lift_n: npt.ArrayLike,
        t_s: Optional[npt.ArrayLike] = None,
    ) -> int: ...
    def estimate_json(self) -> str: ...

class Batch:
    def __init__(
        self,
        model: str,
        length_m: float,
        width_m: float,
        medium: Optional[str],
        unit_weight_n_m3: Optional[float],
        phi_deg: Optional[float],
        delta_deg: Optional[float],
        b_k: Optional[float],
        a: Optional[float],
        rft_coeffs: Optional[str],
        rft_zeta: Optional[float],
        rft_elements: int,
        shape: str,
        c_leg_radius_m: Optional[float],
        c_leg_span_deg: Optional[float],
        profile: Optional[List[Tuple[float, float]]],
        medium_file: Optional[str],
        body: Optional[BodyArgs] = None,
            planar_sheared_bearing: bool = ...,
) -> None: ...
    @property
    def vectorised(self) -> bool: ...
    @property
    def takes_fitting_width(self) -> bool: ...
    def forces_into(
        self,
        beta_rad: npt.NDArray[np.floating],
        hip_height_m: npt.NDArray[np.floating],
        pitch_rad: Optional[npt.NDArray[np.floating]],
        omega_rad_s: Optional[npt.NDArray[np.floating]],
        forward_m_s: Optional[npt.NDArray[np.floating]],
        up_m_s: Optional[npt.NDArray[np.floating]],
        b_k: Optional[npt.NDArray[np.floating]],
        a: Optional[npt.NDArray[np.floating]],
        drag_n: npt.NDArray[np.floating],
        lift_n: npt.NDArray[np.floating],
        hip_torque_nm: npt.NDArray[np.floating],
        lateral_m_s: Optional[npt.NDArray[np.floating]] = None,
        side_n: Optional[npt.NDArray[np.floating]] = None,
        roll_moment_nm: Optional[npt.NDArray[np.floating]] = None,
        yaw_moment_nm: Optional[npt.NDArray[np.floating]] = None,
    ) -> None: ...

class FreeBase:
    def __init__(
        self,
        qpos0: int,
        qvel0: int,
        nstate: int,
        joint_qpos: List[int],
        joint_dof: List[int],
        hip_m: List[Tuple[float, float, float]],
        com_m: List[Tuple[float, float, float]],
        xfrc: List[int],
        ncontrol: int,
        surface_z_m: float,
    ) -> None: ...
    def apply(
        self,
        state: npt.NDArray[np.float64],
        batch: Batch,
        b_k: Optional[npt.NDArray[np.float64]],
        a: Optional[npt.NDArray[np.float64]],
        beta_rad: npt.NDArray[np.float64],
        hip_height_m: npt.NDArray[np.float64],
        pitch_rad: npt.NDArray[np.float64],
        omega_rad_s: npt.NDArray[np.float64],
        forward_m_s: npt.NDArray[np.float64],
        up_m_s: npt.NDArray[np.float64],
        drag_n: npt.NDArray[np.float64],
        lift_n: npt.NDArray[np.float64],
        hip_torque_nm: npt.NDArray[np.float64],
        control: npt.NDArray[np.float64],
    ) -> None: ...

class Recorder:
    def __init__(self, path: str, params: List[Tuple[str, str]], overwrite: bool) -> None: ...
    def joint_state(
        self, topic: str, t_ns: int, names: List[str], position: List[float], velocity: List[float]
    ) -> None: ...
    def wrench(
        self, topic: str, t_ns: int, frame_id: str, force: List[float], torque: List[float]
    ) -> None: ...
    def pose(
        self, topic: str, t_ns: int, frame_id: str, position: List[float], orientation: List[float]
    ) -> None: ...
    def close(self) -> int: ...

def read_topics(
    path: str, topics: Optional[List[str]]
) -> List[Tuple[str, str, bool, int, int, List[Tuple[str, npt.NDArray[np.float64]]]]]: ...

NODE_FIELDS: List[str]

class Node:
    def __init__(self, params_file: Optional[str], params: List[Tuple[str, str]]) -> None: ...
    def legs(self) -> List[str]: ...
    def params(self) -> List[Tuple[str, str]]: ...
    def pose(
        self, t_ns: int, position: List[float], orientation_xyzw: List[float], frame_id: str
    ) -> None: ...
    def wrench(
        self, leg: int, t_ns: int, force: List[float], torque: List[float], frame_id: str
    ) -> None: ...
    def joint_state(
        self, t_ns: int, names: List[str], position: List[float], velocity: List[float]
    ) -> List[List[float]]: ...

def rhex_params() -> List[Tuple[str, str]]: ...
