//! ROS 2 message types the project speaks, as serde structs whose field order equals the `.msg`
//! order (CDR is positional), and their definitions with dependencies, as `ros2msg` schemas
//! (MCAP) carry them. Standard types are written out here because no maintained crate provides
//! them for ros2-client 0.12; the project's own types mirror `msgs/msg/*.msg`.

use serde::{Deserialize, Serialize};

/// `builtin_interfaces/Time`
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Time {
    pub sec: i32,
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
    pub fn to_nanos(self) -> i64 {
        self.sec as i64 * 1_000_000_000 + self.nanosec as i64
    }
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
    pub stamp: Time,
    pub frame_id: String,
}

/// `sensor_msgs/JointState`: parallel arrays; velocity and effort may be empty.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct JointState {
    pub header: Header,
    pub name: Vec<String>,
    pub position: Vec<f64>,
    pub velocity: Vec<f64>,
    pub effort: Vec<f64>,
}

/// `geometry_msgs/Vector3`
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Vector3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// `geometry_msgs/Wrench`
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Wrench {
    pub force: Vector3,
    pub torque: Vector3,
}

/// `geometry_msgs/WrenchStamped`
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct WrenchStamped {
    pub header: Header,
    pub wrench: Wrench,
}

/// `diagnostic_msgs/KeyValue`
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct KeyValue {
    pub key: String,
    pub value: String,
}

/// `diagnostic_msgs/DiagnosticStatus`
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct DiagnosticStatus {
    pub level: u8,
    pub name: String,
    pub message: String,
    pub hardware_id: String,
    pub values: Vec<KeyValue>,
}

impl DiagnosticStatus {
    pub const OK: u8 = 0;
    pub const WARN: u8 = 1;
    pub const ERROR: u8 = 2;
    pub const STALE: u8 = 3;
}

/// `diagnostic_msgs/DiagnosticArray`
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct DiagnosticArray {
    pub header: Header,
    pub status: Vec<DiagnosticStatus>,
}

/// `terzaghi_msgs/LegForce` (msgs/msg/LegForce.msg)
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct LegForce {
    pub header: Header,
    pub attack_angle_rad: f64,
    pub submerged_length_m: f64,
    pub depth_m: f64,
    pub drag_n: f64,
    pub lift_n: f64,
    pub hip_torque_nm: f64,
    pub regime: u8,
    pub model: String,
    pub b_k: f64,
    pub a: f64,
    pub delta_deg: f64,
    pub identified: bool,
}

/// `terzaghi_msgs/ModelParams` (msgs/msg/ModelParams.msg)
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ModelParams {
    pub header: Header,
    pub b_k: f64,
    pub a: f64,
    pub delta_deg: f64,
    pub std_b_k: f64,
    pub std_a: f64,
    pub std_delta_deg: f64,
    pub samples_used: u64,
    pub samples_rejected: u64,
    pub innovation_rms_n: f64,
    pub converged: bool,
    pub changes_detected: u32,
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
const KEY_VALUE: (&str, &str) = ("diagnostic_msgs", "KeyValue");
const DIAG_STATUS: (&str, &str) = ("diagnostic_msgs", "DiagnosticStatus");

/// The definition text of a type this project knows.
pub fn definition(t: (&str, &str)) -> Option<&'static str> {
    Some(match t {
        ("builtin_interfaces", "Time") => "int32 sec\nuint32 nanosec\n",
        ("std_msgs", "Header") => "builtin_interfaces/Time stamp\nstring frame_id\n",
        ("sensor_msgs", "JointState") => {
            "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n"
        }
        ("geometry_msgs", "Vector3") => "float64 x\nfloat64 y\nfloat64 z\n",
        ("geometry_msgs", "Wrench") => "Vector3 force\nVector3 torque\n",
        ("geometry_msgs", "WrenchStamped") => "std_msgs/Header header\nWrench wrench\n",
        ("diagnostic_msgs", "KeyValue") => "string key\nstring value\n",
        ("diagnostic_msgs", "DiagnosticStatus") => {
            "byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\nbyte level\nstring name\nstring message\nstring hardware_id\nKeyValue[] values\n"
        }
        ("diagnostic_msgs", "DiagnosticArray") => {
            "std_msgs/Header header\nDiagnosticStatus[] status\n"
        }
        ("terzaghi_msgs", "LegForce") => include_str!("../msgs/msg/LegForce.msg"),
        ("terzaghi_msgs", "ModelParams") => include_str!("../msgs/msg/ModelParams.msg"),
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
    TooShort(usize),
    #[error("unsupported CDR encapsulation {0:#06x} (plain CDR, big or little endian, only)")]
    Encapsulation(u16),
    #[error("CDR payload does not decode: {0}")]
    Decode(#[from] cdr_encoding::Error),
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

    #[test]
    fn time_conversions() {
        let t = Time::from_nanos(-1).unwrap();
        assert_eq!((t.sec, t.nanosec), (-1, 999_999_999));
        assert_eq!(t.to_nanos(), -1);
        assert!(Time::from_nanos(i64::MAX).is_none());
    }
}
