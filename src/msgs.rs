//! ROS 2 message types the project speaks, as serde structs whose field order equals the `.msg`
//! order (CDR is positional), and their definitions with dependencies, as `ros2msg` schemas
//! (MCAP) carry them. Standard types are written out here because no maintained crate provides
//! them for ros2-client 0.12; the project's own types mirror `msgs/msg/*.msg`.

use serde::{Deserialize, Serialize};

/// `rosgraph_msgs/Clock`: the time of a simulation or of a log played back, on `/clock`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Clock {
    /// The time it carries.
    pub clock: Time,
}

/// `rcl_interfaces/Log`: a node's log line, on `/rosout`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct RosLog {
    /// When the line was logged.
    pub stamp: Time,
    /// Severity: 10 debug, 20 info, 30 warn, 40 error, 50 fatal.
    pub level: u8,
    /// The logging node's name.
    pub name: String,
    /// The line.
    pub msg: String,
    /// Source file that logged it.
    pub file: String,
    /// Function that logged it.
    pub function: String,
    /// Line in that file.
    pub line: u32,
}

/// `builtin_interfaces/Time`
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Time {
    /// Seconds since the epoch.
    pub sec: i32,
    /// Nanoseconds within the second, below 1e9.
    pub nanosec: u32,
}

impl Time {
    /// From nanoseconds since the epoch; `None` outside what `Time` can hold.
    pub fn from_nanos(ns: i64) -> Option<Time> {
        let sec = ns.div_euclid(1_000_000_000);
        Some(Time {
            sec: i32::try_from(sec).ok()?,
            nanosec: ns.rem_euclid(1_000_000_000) as u32,
        })
    }
    /// Nanoseconds since the epoch.
    pub fn to_nanos(self) -> i64 {
        self.sec as i64 * 1_000_000_000 + self.nanosec as i64
    }
    /// Seconds since the epoch.
    pub fn to_secs(self) -> f64 {
        self.sec as f64 + self.nanosec as f64 * 1e-9
    }
    /// A valid stamp has `nanosec < 1e9`.
    pub fn is_valid(self) -> bool {
        self.nanosec < 1_000_000_000
    }
}

/// `std_msgs/Header`
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Header {
    /// Time of the data.
    pub stamp: Time,
    /// The frame the data is in.
    pub frame_id: String,
}

/// `sensor_msgs/JointState`: parallel arrays; velocity and effort may be empty.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct JointState {
    /// Stamp of the joint states.
    pub header: Header,
    /// Joint names.
    pub name: Vec<String>,
    /// Joint positions (rad for a revolute joint), by name's index.
    pub position: Vec<f64>,
    /// Joint velocities (rad/s); empty where not measured.
    pub velocity: Vec<f64>,
    /// Joint efforts (N m); empty where not measured.
    pub effort: Vec<f64>,
}

/// `geometry_msgs/Vector3`
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Vector3 {
    /// x component.
    pub x: f64,
    /// y component.
    pub y: f64,
    /// z component.
    pub z: f64,
}

/// `geometry_msgs/Wrench`
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Wrench {
    /// Force (N).
    pub force: Vector3,
    /// Torque (N m).
    pub torque: Vector3,
}

/// `geometry_msgs/WrenchStamped`
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct WrenchStamped {
    /// Stamp and sensor frame.
    pub header: Header,
    /// The force and torque.
    pub wrench: Wrench,
}

/// `geometry_msgs/Quaternion` (ROS's default is the identity, `w = 1`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x component.
    pub x: f64,
    /// y component.
    pub y: f64,
    /// z component.
    pub z: f64,
    /// Scalar part.
    pub w: f64,
}

impl Default for Quaternion {
    fn default() -> Self {
        Quaternion {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        }
    }
}

/// `geometry_msgs/Transform`
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Transform {
    /// Position of the child frame's origin in the parent frame (m).
    pub translation: Vector3,
    /// Orientation of the child frame in the parent frame.
    pub rotation: Quaternion,
}

/// `geometry_msgs/TransformStamped`: the pose of `child_frame_id` in `header.frame_id`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Stamp and parent frame.
    pub header: Header,
    /// The frame whose pose this is.
    pub child_frame_id: String,
    /// The child frame's pose in the parent.
    pub transform: Transform,
}

/// `geometry_msgs/Point`
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Point {
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// z (m).
    pub z: f64,
}

/// `geometry_msgs/Pose`
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose {
    /// Position (m).
    pub position: Point,
    /// Orientation.
    pub orientation: Quaternion,
}

/// `geometry_msgs/PoseStamped`: a body's pose in `header.frame_id`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseStamped {
    /// Stamp and the frame the pose is in.
    pub header: Header,
    /// The pose.
    pub pose: Pose,
}

/// `tf2_msgs/TFMessage`, as `/tf` and `/tf_static` carry it.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TfMessage {
    /// The transforms, each stamped.
    pub transforms: Vec<TransformStamped>,
}

/// `diagnostic_msgs/KeyValue`
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct KeyValue {
    /// Name of the value.
    pub key: String,
    /// The value, as text.
    pub value: String,
}

/// `diagnostic_msgs/DiagnosticStatus`
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct DiagnosticStatus {
    /// OK, WARN, ERROR or STALE (the constants below).
    pub level: u8,
    /// What is reported on, as `node: part`.
    pub name: String,
    /// A short summary for people.
    pub message: String,
    /// The hardware this is about.
    pub hardware_id: String,
    /// Each reported value.
    pub values: Vec<KeyValue>,
}

impl DiagnosticStatus {
    /// Level: all is well.
    pub const OK: u8 = 0;
    /// Level: something needs attention.
    pub const WARN: u8 = 1;
    /// Level: something is wrong.
    pub const ERROR: u8 = 2;
    /// Level: no recent report.
    pub const STALE: u8 = 3;
}

/// `diagnostic_msgs/DiagnosticArray`
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct DiagnosticArray {
    /// Stamp of the report.
    pub header: Header,
    /// One status per part reported on.
    pub status: Vec<DiagnosticStatus>,
}

/// `terzaghi_msgs/LegForce` (msgs/msg/LegForce.msg)
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct LegForce {
    /// Stamp of the JointState the prediction was made from; frame `<leg>_hip`.
    pub header: Header,
    /// Attack angle beta (rad) in [0, 2 pi): 0 horizontal, pi/2 vertical.
    pub attack_angle_rad: f64,
    /// Length of the leg below the surface (m).
    pub submerged_length_m: f64,
    /// Depth of the tip below the free surface (m).
    pub depth_m: f64,
    /// Horizontal force resisting the travel (N); the force on the leg is -drag along x.
    pub drag_n: f64,
    /// Vertical force, positive up (N).
    pub lift_n: f64,
    /// Moment about the hip axis, positive when it resists the rotation (N m).
    pub hip_torque_nm: f64,
    /// Regime of the prediction: one of the `REGIME_*` codes of `LegForce.msg`.
    pub regime: u8,
    /// `improved`, `conventional`, `rft` or `sinkage`.
    pub model: String,
    /// Fitting width's `b_k` used (`b_e = b_k b a^(-beta)`).
    pub b_k: f64,
    /// Fitting width's `a` used.
    pub a: f64,
    /// Plate-medium friction angle used (deg).
    pub delta_deg: f64,
    /// Whether `b_k`, `a` (and delta) come from online identification.
    pub identified: bool,
    /// The bare improved model's drag (N), what the corrections are added to.
    pub bare_drag_n: f64,
    /// The bare improved model's lift (N).
    pub bare_lift_n: f64,
    /// Each correction's name, in the order of its parts below.
    pub correction_names: Vec<String>,
    /// Each correction's part of the drag (N).
    pub correction_drag_n: Vec<f64>,
    /// Each correction's part of the lift (N).
    pub correction_lift_n: Vec<f64>,
    /// What the leg's F/T sensor is expected to read, drag (N): the medium's force through the
    /// sensor's own corrections; equal to `drag_n` without them.
    pub sensor_drag_n: f64,
    /// What the F/T sensor is expected to read, lift (N).
    pub sensor_lift_n: f64,
    /// The hip's height above the surface for this prediction (m).
    pub hip_height_m: f64,
    /// The body's pitch added to the attack angle (rad; ROS's pitch, positive nose down).
    pub body_pitch_rad: f64,
    /// The hip's horizontal velocity, forward (m/s).
    pub hip_forward_m_s: f64,
    /// The hip's vertical velocity, up (m/s).
    pub hip_up_m_s: f64,
    /// Whether the hip came from the robot's state (`/tf`); else the configured height, level and still.
    pub robot_state: bool,
    /// The scale RFT's stresses were multiplied by; 1 for the improved or conventional model.
    pub rft_scale: f64,
    /// Horizontal force across the travel, along the hip frame's `y` (N; the frame is
    /// right-handed, `x` along the tip's travel and `z` up, so `y` is the robot's right).
    pub side_n: f64,
    /// The medium's moment about the hip frame's `x` (N m).
    pub roll_moment_nm: f64,
    /// The medium's moment about the hip frame's `z`, up (N m).
    pub yaw_moment_nm: f64,
    /// The hip's horizontal velocity across the robot's forward, toward its left (m/s).
    pub hip_lateral_m_s: f64,
}

/// `terzaghi_msgs/Gap` (msgs/msg/Gap.msg)
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Gap {
    /// Stamp of the newest F/T sample diagnosed; frame `<leg>_hip`.
    pub header: Header,
    /// Strokes diagnosed.
    pub strokes: u32,
    /// F/T samples diagnosed.
    pub samples: u64,
    /// The bare model's held-out RMS residual over drag and lift (N).
    pub heldout_rmse_n: f64,
    /// The sensor noise over drag and lift (N).
    pub noise_n: f64,
    /// Whether the residual exceeds the noise beyond chance.
    pub gap_real: bool,
    /// `none`, `unexplained`, or the effect with the largest share of the gap.
    pub verdict: String,
    /// The significant effects, in the order found.
    pub effects: Vec<String>,
    /// The share of the gap each effect adds (%).
    pub share_of_gap_pct: Vec<f64>,
    /// What shows each effect (`force_out_of_medium`, `alignment`, `onset_angle`, `contrast`, `form_only`).
    pub basis: Vec<String>,
    /// What the diagnosis says of each effect.
    pub claim: Vec<String>,
    /// Significant effects the leg's model does not correct: what the node warns of.
    pub new_effects: Vec<String>,
    /// Why the strokes could not be diagnosed (empty when they were).
    pub error: String,
}

/// `terzaghi_msgs/ModelParams` (msgs/msg/ModelParams.msg)
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ModelParams {
    /// Stamp of the last F/T sample used.
    pub header: Header,
    /// Estimated `b_k` of the fitting width.
    pub b_k: f64,
    /// Estimated `a` of the fitting width.
    pub a: f64,
    /// Estimated plate-medium friction angle (deg).
    pub delta_deg: f64,
    /// Standard deviation of `b_k`, from the estimator's covariance.
    pub std_b_k: f64,
    /// Standard deviation of `a`.
    pub std_a: f64,
    /// Standard deviation of `delta_deg` (deg).
    pub std_delta_deg: f64,
    /// Samples that updated the estimate.
    pub samples_used: u64,
    /// Samples skipped: non-finite, outside the excitation gate, stuck sensor, or without a joint
    /// angle close enough in time.
    pub samples_rejected: u64,
    /// RMS of recent innovations, measured minus predicted force (N).
    pub innovation_rms_n: f64,
    /// Whether the relative standard deviations of `b_k` and `a` are below the configured bound.
    pub converged: bool,
    /// Changes of the medium detected so far.
    pub changes_detected: u32,
    /// For a leg with corrections, each learnt coefficient as `<effect>.<param>`, its value and
    /// standard deviation (empty otherwise).
    pub correction_params: Vec<String>,
    /// Each learnt coefficient's value, by `correction_params`' index.
    pub correction_values: Vec<f64>,
    /// Each learnt coefficient's standard deviation.
    pub correction_stds: Vec<f64>,
    /// An RFT leg's learnt scale of its stresses; 1 for the improved or conventional model.
    pub rft_scale: f64,
    /// The RFT scale's standard deviation; 0 for the improved or conventional model.
    pub std_rft_scale: f64,
    /// With `estimator.fit_surface`: how far the surface is above where the hip's height puts it (m).
    pub surface_offset_m: f64,
    /// The surface offset's standard deviation (m).
    pub std_surface_offset_m: f64,
    /// Whether the surface offset has converged (the leg then predicts at the corrected height).
    pub surface_converged: bool,
}

/// A message type: its ROS name and its definition.
pub trait RosMessage: Serialize + for<'de> Deserialize<'de> + Send + 'static {
    /// `(package, type)`, e.g. `("sensor_msgs", "JointState")`.
    const TYPE: (&'static str, &'static str);
    /// The types this one's definition refers to, directly or not, each once.
    const DEPENDENCIES: &'static [(&'static str, &'static str)];

    /// `pkg/msg/Type`, as MCAP schema names and `ros2 topic info` show it.
    fn type_name() -> String {
        format!("{}/msg/{}", Self::TYPE.0, Self::TYPE.1)
    }

    /// The `ros2msg` schema text: this type's definition, then for each dependency a line of 80
    /// `=`, `MSG: pkg/Type` and its definition (as rosbag2 writes it).
    fn schema_text() -> String {
        let mut s = definition(Self::TYPE).unwrap_or_default().to_string();
        for dep in Self::DEPENDENCIES {
            s.push_str(&"=".repeat(80));
            s.push_str(&format!("\nMSG: {}/{}\n", dep.0, dep.1));
            s.push_str(definition(*dep).unwrap_or_default());
        }
        s
    }
}

const TIME: (&str, &str) = ("builtin_interfaces", "Time");
const HEADER: (&str, &str) = ("std_msgs", "Header");
const VECTOR3: (&str, &str) = ("geometry_msgs", "Vector3");
const WRENCH: (&str, &str) = ("geometry_msgs", "Wrench");
const QUATERNION: (&str, &str) = ("geometry_msgs", "Quaternion");
const TRANSFORM: (&str, &str) = ("geometry_msgs", "Transform");
const POINT: (&str, &str) = ("geometry_msgs", "Point");
const POSE: (&str, &str) = ("geometry_msgs", "Pose");
const TRANSFORM_STAMPED: (&str, &str) = ("geometry_msgs", "TransformStamped");
const KEY_VALUE: (&str, &str) = ("diagnostic_msgs", "KeyValue");
const DIAG_STATUS: (&str, &str) = ("diagnostic_msgs", "DiagnosticStatus");

/// The definition text of a type this project knows.
pub fn definition(t: (&str, &str)) -> Option<&'static str> {
    Some(match t {
        ("builtin_interfaces", "Time") => "int32 sec\nuint32 nanosec\n",
        ("std_msgs", "Header") => "builtin_interfaces/Time stamp\nstring frame_id\n",
        ("rosgraph_msgs", "Clock") => "builtin_interfaces/Time clock\n",
        ("rcl_interfaces", "Log") => {
            "byte DEBUG=10\nbyte INFO=20\nbyte WARN=30\nbyte ERROR=40\nbyte FATAL=50\nbuiltin_interfaces/Time stamp\nuint8 level\nstring name\nstring msg\nstring file\nstring function\nuint32 line\n"
        }
        ("sensor_msgs", "JointState") => {
            "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n"
        }
        ("geometry_msgs", "Vector3") => "float64 x\nfloat64 y\nfloat64 z\n",
        ("geometry_msgs", "Wrench") => "Vector3 force\nVector3 torque\n",
        ("geometry_msgs", "WrenchStamped") => "std_msgs/Header header\nWrench wrench\n",
        ("geometry_msgs", "Quaternion") => "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
        ("geometry_msgs", "Transform") => "Vector3 translation\nQuaternion rotation\n",
        ("geometry_msgs", "TransformStamped") => {
            "std_msgs/Header header\nstring child_frame_id\nTransform transform\n"
        }
        ("tf2_msgs", "TFMessage") => "geometry_msgs/TransformStamped[] transforms\n",
        ("geometry_msgs", "Point") => "float64 x\nfloat64 y\nfloat64 z\n",
        ("geometry_msgs", "Pose") => "Point position\nQuaternion orientation\n",
        ("geometry_msgs", "PoseStamped") => "std_msgs/Header header\nPose pose\n",
        ("diagnostic_msgs", "KeyValue") => "string key\nstring value\n",
        ("diagnostic_msgs", "DiagnosticStatus") => {
            "byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\nbyte level\nstring name\nstring message\nstring hardware_id\nKeyValue[] values\n"
        }
        ("diagnostic_msgs", "DiagnosticArray") => {
            "std_msgs/Header header\nDiagnosticStatus[] status\n"
        }
        ("terzaghi_msgs", "LegForce") => include_str!("../msgs/msg/LegForce.msg"),
        ("terzaghi_msgs", "ModelParams") => include_str!("../msgs/msg/ModelParams.msg"),
        ("terzaghi_msgs", "Gap") => include_str!("../msgs/msg/Gap.msg"),
        _ => return None,
    })
}

macro_rules! ros_message {
    ($t:ty, $pkg:literal, $name:literal, [$($dep:expr),*]) => {
        impl RosMessage for $t {
            const TYPE: (&'static str, &'static str) = ($pkg, $name);
            const DEPENDENCIES: &'static [(&'static str, &'static str)] = &[$($dep),*];
        }
    };
}

ros_message!(Time, "builtin_interfaces", "Time", []);
ros_message!(Clock, "rosgraph_msgs", "Clock", [TIME]);
ros_message!(RosLog, "rcl_interfaces", "Log", [TIME]);
ros_message!(Header, "std_msgs", "Header", [TIME]);
ros_message!(JointState, "sensor_msgs", "JointState", [HEADER, TIME]);
ros_message!(Vector3, "geometry_msgs", "Vector3", []);
ros_message!(Wrench, "geometry_msgs", "Wrench", [VECTOR3]);
ros_message!(
    WrenchStamped,
    "geometry_msgs",
    "WrenchStamped",
    [HEADER, TIME, WRENCH, VECTOR3]
);
ros_message!(
    TfMessage,
    "tf2_msgs",
    "TFMessage",
    [
        TRANSFORM_STAMPED,
        HEADER,
        TIME,
        TRANSFORM,
        VECTOR3,
        QUATERNION
    ]
);
ros_message!(
    PoseStamped,
    "geometry_msgs",
    "PoseStamped",
    [HEADER, TIME, POSE, POINT, QUATERNION]
);
ros_message!(KeyValue, "diagnostic_msgs", "KeyValue", []);
ros_message!(
    DiagnosticStatus,
    "diagnostic_msgs",
    "DiagnosticStatus",
    [KEY_VALUE]
);
ros_message!(
    DiagnosticArray,
    "diagnostic_msgs",
    "DiagnosticArray",
    [HEADER, TIME, DIAG_STATUS, KEY_VALUE]
);
ros_message!(LegForce, "terzaghi_msgs", "LegForce", [HEADER, TIME]);
ros_message!(ModelParams, "terzaghi_msgs", "ModelParams", [HEADER, TIME]);
ros_message!(Gap, "terzaghi_msgs", "Gap", [HEADER, TIME]);

/// CDR bytes of a message as they travel and as MCAP stores them: the 4-byte encapsulation
/// header (CDR, little endian) then the payload.
pub fn to_cdr<M: Serialize>(msg: &M) -> Result<Vec<u8>, cdr_encoding::Error> {
    let mut out = vec![0x00, 0x01, 0x00, 0x00];
    cdr_encoding::to_writer::<_, byteorder::LittleEndian, _>(&mut out, msg)?;
    Ok(out)
}

/// What is wrong with CDR bytes.
#[derive(Debug, thiserror::Error)]
pub enum CdrError {
    #[error("CDR message shorter than its 4-byte header ({0} bytes)")]
    /// Fewer bytes than the header (the count).
    TooShort(usize),
    #[error("unsupported CDR encapsulation {0:#06x} (plain CDR, big or little endian, only)")]
    /// An encapsulation other than plain CDR (its code).
    Encapsulation(u16),
    // Not `#[from]`, which would make the inner error the source too, printed twice by `{e:#}`.
    #[error("CDR payload does not decode: {0}")]
    /// The payload does not decode as the message.
    Decode(cdr_encoding::Error),
    #[error("CDR payload ends at byte {at} inside a field")]
    /// The payload ends inside a field (at this byte).
    Truncated {
        /// The byte.
        at: usize,
    },
    #[error("CDR string at byte {at} is not UTF-8")]
    /// A string that is not UTF-8 (at this byte).
    NotUtf8 {
        /// The byte where the string starts.
        at: usize,
    },
}

impl From<cdr_encoding::Error> for CdrError {
    fn from(e: cdr_encoding::Error) -> Self {
        CdrError::Decode(e)
    }
}

/// Decodes CDR bytes with their encapsulation header (big- or little-endian plain CDR).
pub fn from_cdr<M: for<'de> Deserialize<'de>>(bytes: &[u8]) -> Result<M, CdrError> {
    if bytes.len() < 4 {
        return Err(CdrError::TooShort(bytes.len()));
    }
    let kind = u16::from_be_bytes([bytes[0], bytes[1]]);
    let body = &bytes[4..];
    Ok(match kind {
        0x0001 => cdr_encoding::from_bytes::<M, byteorder::LittleEndian>(body)?.0,
        0x0000 => cdr_encoding::from_bytes::<M, byteorder::BigEndian>(body)?.0,
        other => return Err(CdrError::Encapsulation(other)),
    })
}

/// Decoding into a message that is kept and reused, for the two input types that a
/// re-evaluation decodes millions of times. Hand-written beside serde's decoding
/// (`cdr_encoding`, as [`from_cdr`] does), which makes every string and array anew: here the
/// names and arrays keep their allocations, and a name that equals the one already held is not
/// copied or checked again. `cargo bench --bench session` measures the two (`docs/benchmarks.md`);
/// the result is the same as [`from_cdr`]'s, which a unit test checks on good and
/// damaged bytes and a property test (`tests/properties.rs`) on arbitrary messages.
pub trait DecodeInto {
    /// Decodes `bytes` (with their encapsulation header) into `self`, as [`from_cdr`] would make it.
    fn decode_into(&mut self, bytes: &[u8]) -> Result<(), CdrError>;
}

/// Plain CDR after the encapsulation header: alignment counts from the start of the body.
struct CdrReader<'a> {
    body: &'a [u8],
    at: usize,
    little_endian: bool,
}

impl<'a> CdrReader<'a> {
    fn new(bytes: &'a [u8]) -> Result<Self, CdrError> {
        if bytes.len() < 4 {
            return Err(CdrError::TooShort(bytes.len()));
        }
        let little_endian = match u16::from_be_bytes([bytes[0], bytes[1]]) {
            0x0001 => true,
            0x0000 => false,
            other => return Err(CdrError::Encapsulation(other)),
        };
        Ok(CdrReader {
            body: &bytes[4..],
            at: 0,
            little_endian,
        })
    }

    fn take<const N: usize>(&mut self) -> Result<[u8; N], CdrError> {
        let start = self.at.next_multiple_of(N);
        let b = self
            .body
            .get(start..start + N)
            .ok_or(CdrError::Truncated { at: start + 4 })?;
        self.at = start + N;
        Ok(b.try_into().unwrap_or([0; N]))
    }

    fn u32(&mut self) -> Result<u32, CdrError> {
        let b = self.take::<4>()?;
        Ok(if self.little_endian {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    fn f64(&mut self) -> Result<f64, CdrError> {
        let b = self.take::<8>()?;
        Ok(if self.little_endian {
            f64::from_le_bytes(b)
        } else {
            f64::from_be_bytes(b)
        })
    }

    fn time(&mut self) -> Result<Time, CdrError> {
        Ok(Time {
            sec: self.u32()? as i32,
            nanosec: self.u32()?,
        })
    }

    /// A string: its length counts the terminating NUL, which is dropped.
    fn string_into(&mut self, s: &mut String) -> Result<(), CdrError> {
        let len = self.u32()? as usize;
        let bytes = self
            .body
            .get(self.at..)
            .and_then(|rest| rest.get(..len))
            .ok_or(CdrError::Truncated { at: self.at + 4 })?;
        let text = bytes.split_last().map_or(bytes, |(_, text)| text);
        if text != s.as_bytes() {
            s.clear();
            s.push_str(
                std::str::from_utf8(text).map_err(|_| CdrError::NotUtf8 { at: self.at + 4 })?,
            );
        }
        self.at += len;
        Ok(())
    }

    /// A sequence's length, checked against what is left (each element takes at least
    /// `min_bytes`), so that a damaged length does not reserve memory for nothing.
    fn count(&mut self, min_bytes: usize) -> Result<usize, CdrError> {
        let n = self.u32()? as usize;
        if n.saturating_mul(min_bytes) > self.body.len().saturating_sub(self.at) {
            return Err(CdrError::Truncated {
                at: self.body.len() + 4,
            });
        }
        Ok(n)
    }

    fn f64s_into(&mut self, v: &mut Vec<f64>) -> Result<(), CdrError> {
        let n = self.count(8)?;
        v.clear();
        for _ in 0..n {
            v.push(self.f64()?);
        }
        Ok(())
    }

    fn header_into(&mut self, h: &mut Header) -> Result<(), CdrError> {
        h.stamp = self.time()?;
        self.string_into(&mut h.frame_id)
    }

    fn vector3(&mut self) -> Result<Vector3, CdrError> {
        Ok(Vector3 {
            x: self.f64()?,
            y: self.f64()?,
            z: self.f64()?,
        })
    }
}

impl DecodeInto for JointState {
    fn decode_into(&mut self, bytes: &[u8]) -> Result<(), CdrError> {
        let mut r = CdrReader::new(bytes)?;
        r.header_into(&mut self.header)?;
        let n = r.count(4)?;
        self.name.truncate(n);
        for i in 0..n {
            if i == self.name.len() {
                self.name.push(String::new());
            }
            r.string_into(&mut self.name[i])?;
        }
        r.f64s_into(&mut self.position)?;
        r.f64s_into(&mut self.velocity)?;
        r.f64s_into(&mut self.effort)
    }
}

impl DecodeInto for WrenchStamped {
    fn decode_into(&mut self, bytes: &[u8]) -> Result<(), CdrError> {
        let mut r = CdrReader::new(bytes)?;
        r.header_into(&mut self.header)?;
        self.wrench.force = r.vector3()?;
        self.wrench.torque = r.vector3()?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schema_text_carries_dependencies_once() {
        let s = WrenchStamped::schema_text();
        assert!(s.starts_with("std_msgs/Header header\nWrench wrench\n"));
        for dep in [
            "MSG: std_msgs/Header",
            "MSG: builtin_interfaces/Time",
            "MSG: geometry_msgs/Wrench",
            "MSG: geometry_msgs/Vector3",
        ] {
            assert_eq!(s.matches(dep).count(), 1, "{dep}");
        }
        assert_eq!(
            WrenchStamped::type_name(),
            "geometry_msgs/msg/WrenchStamped"
        );
        assert!(LegForce::schema_text().contains("float64 hip_torque_nm"));
    }

    #[test]
    fn cdr_round_trip_and_bad_bytes() {
        let m = JointState {
            header: Header {
                stamp: Time { sec: 3, nanosec: 5 },
                frame_id: "base".into(),
            },
            name: vec!["hip".into()],
            position: vec![1.5],
            velocity: vec![],
            effort: vec![],
        };
        let b = to_cdr(&m).unwrap();
        assert_eq!(&b[..4], &[0, 1, 0, 0]);
        assert_eq!(from_cdr::<JointState>(&b).unwrap(), m);
        assert!(from_cdr::<JointState>(&b[..2]).is_err());
        assert!(from_cdr::<JointState>(&b[..b.len() - 3]).is_err());
        assert!(from_cdr::<JointState>(&[0, 9, 0, 0, 1]).is_err());
    }

    /// The hand-written decoder agrees with serde's on good bytes, in both byte orders, and
    /// fails where it fails on cut and damaged ones; a reused message is fully overwritten.
    #[test]
    fn decode_into_agrees_with_from_cdr() {
        let m = JointState {
            header: Header {
                stamp: Time {
                    sec: -3,
                    nanosec: 5,
                },
                frame_id: "base".into(),
            },
            name: vec!["hip_a".into(), "".into(), "hip_ccc".into()],
            position: vec![1.5, -2.0, f64::NAN],
            velocity: vec![0.25],
            effort: vec![],
        };
        let w = WrenchStamped {
            header: Header {
                stamp: Time { sec: 7, nanosec: 9 },
                frame_id: "leg_ft".into(),
            },
            wrench: Wrench {
                force: Vector3 {
                    x: 1.0,
                    y: 2.0,
                    z: 3.0,
                },
                torque: Vector3 {
                    x: 4.0,
                    y: 5.0,
                    z: 6.0,
                },
            },
        };
        let mut big_endian = vec![0x00, 0x00, 0x00, 0x00];
        cdr_encoding::to_writer::<_, byteorder::BigEndian, _>(&mut big_endian, &m).unwrap();
        // A message held from before, with more names and longer arrays.
        let mut js = JointState {
            name: vec!["x".into(); 5],
            position: vec![9.0; 7],
            effort: vec![1.0],
            ..Default::default()
        };
        for b in [to_cdr(&m).unwrap(), big_endian] {
            js.decode_into(&b).unwrap();
            assert_eq!(format!("{js:?}"), format!("{m:?}"));
            for cut in 0..b.len() {
                let ours = JointState::default().decode_into(&b[..cut]).is_ok();
                assert_eq!(
                    ours,
                    from_cdr::<JointState>(&b[..cut]).is_ok(),
                    "cut at {cut}"
                );
            }
        }
        let b = to_cdr(&w).unwrap();
        let mut ws = WrenchStamped::default();
        ws.decode_into(&b).unwrap();
        assert_eq!(ws, w);
        for cut in 0..b.len() {
            let ours = WrenchStamped::default().decode_into(&b[..cut]).is_ok();
            assert_eq!(
                ours,
                from_cdr::<WrenchStamped>(&b[..cut]).is_ok(),
                "cut at {cut}"
            );
        }
        // A name that is not UTF-8, and a sequence longer than the bytes left.
        let mut bad = to_cdr(&m).unwrap();
        let at = bad.windows(5).position(|x| x == b"hip_a").unwrap();
        bad[at] = 0xff;
        assert!(from_cdr::<JointState>(&bad).is_err());
        assert!(matches!(
            JointState::default().decode_into(&bad),
            Err(CdrError::NotUtf8 { .. })
        ));
        let mut long = to_cdr(&m).unwrap();
        let count_at = 4usize + 8 + 4 + 5;
        let count_at = count_at.next_multiple_of(4);
        long[count_at..count_at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(JointState::default().decode_into(&long).is_err());
        assert!(from_cdr::<JointState>(&long).is_err());
    }

    #[test]
    fn time_conversions() {
        let t = Time::from_nanos(-1).unwrap();
        assert_eq!((t.sec, t.nanosec), (-1, 999_999_999));
        assert_eq!(t.to_nanos(), -1);
        assert!(Time::from_nanos(i64::MAX).is_none());
    }
}
