"""ROS 2 message types as Cyclone DDS IDL structs (the wire names ROS uses), and a wait for peers to match, for test peers."""
from dataclasses import dataclass, field

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import float64, int32, sequence, uint8, uint32, uint64


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32 = 0
    nanosec: uint32 = 0


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header = field(default_factory=Header)
    name: sequence[str] = field(default_factory=list)
    position: sequence[float64] = field(default_factory=list)
    velocity: sequence[float64] = field(default_factory=list)
    effort: sequence[float64] = field(default_factory=list)


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
class Wrench(IdlStruct, typename="geometry_msgs::msg::dds_::Wrench_"):
    force: Vector3 = field(default_factory=Vector3)
    torque: Vector3 = field(default_factory=Vector3)


@dataclass
class WrenchStamped(IdlStruct, typename="geometry_msgs::msg::dds_::WrenchStamped_"):
    header: Header = field(default_factory=Header)
    wrench: Wrench = field(default_factory=Wrench)


@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0
    w: float64 = 1.0


@dataclass
class Transform(IdlStruct, typename="geometry_msgs::msg::dds_::Transform_"):
    translation: Vector3 = field(default_factory=Vector3)
    rotation: Quaternion = field(default_factory=Quaternion)


@dataclass
class TransformStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    transform: Transform = field(default_factory=Transform)


@dataclass
class TFMessage(IdlStruct, typename="tf2_msgs::msg::dds_::TFMessage_"):
    transforms: sequence[TransformStamped] = field(default_factory=list)


@dataclass
class ModelParams(IdlStruct, typename="terzaghi_msgs::msg::dds_::ModelParams_"):
    header: Header = field(default_factory=Header)
    b_k: float64 = 0.0
    a: float64 = 0.0
    delta_deg: float64 = 0.0
    std_b_k: float64 = 0.0
    std_a: float64 = 0.0
    std_delta_deg: float64 = 0.0
    samples_used: uint64 = 0
    samples_rejected: uint64 = 0
    innovation_rms_n: float64 = 0.0
    converged: bool = False
    changes_detected: uint32 = 0
    correction_params: sequence[str] = field(default_factory=list)
    correction_values: sequence[float64] = field(default_factory=list)
    correction_stds: sequence[float64] = field(default_factory=list)
    rft_scale: float64 = 0.0
    std_rft_scale: float64 = 0.0
    surface_offset_m: float64 = 0.0
    std_surface_offset_m: float64 = 0.0
    surface_converged: bool = False


@dataclass
class LegForce(IdlStruct, typename="terzaghi_msgs::msg::dds_::LegForce_"):
    header: Header = field(default_factory=Header)
    attack_angle_rad: float64 = 0.0
    submerged_length_m: float64 = 0.0
    depth_m: float64 = 0.0
    drag_n: float64 = 0.0
    lift_n: float64 = 0.0
    hip_torque_nm: float64 = 0.0
    regime: uint8 = 0
    model: str = ""
    b_k: float64 = 0.0
    a: float64 = 0.0
    delta_deg: float64 = 0.0
    identified: bool = False
    bare_drag_n: float64 = 0.0
    bare_lift_n: float64 = 0.0
    correction_names: sequence[str] = field(default_factory=list)
    correction_drag_n: sequence[float64] = field(default_factory=list)
    correction_lift_n: sequence[float64] = field(default_factory=list)
    sensor_drag_n: float64 = 0.0
    sensor_lift_n: float64 = 0.0
    hip_height_m: float64 = 0.0
    body_pitch_rad: float64 = 0.0
    hip_forward_m_s: float64 = 0.0
    hip_up_m_s: float64 = 0.0
    robot_state: bool = False
    rft_scale: float64 = 0.0
    side_n: float64 = 0.0
    roll_moment_nm: float64 = 0.0
    yaw_moment_nm: float64 = 0.0
    hip_lateral_m_s: float64 = 0.0


def stamp(t_s):
    sec = int(t_s // 1)
    return Time(sec=sec, nanosec=int(round((t_s - sec) * 1e9)) % 1_000_000_000)


def wait_matched(entities, timeout_s=30.0):
    """Waits until every writer and reader of `entities` has matched a peer; False on time-out."""
    import time
    from cyclonedds.pub import DataWriter
    end = time.time() + timeout_s
    while time.time() < end:
        if all((e.get_publication_matched_status().current_count if isinstance(e, DataWriter)
                else e.get_subscription_matched_status().current_count) > 0 for e in entities):
            return True
        time.sleep(0.05)
    return False
