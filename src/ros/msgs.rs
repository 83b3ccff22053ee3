//! ROS 2 message types as serde structs, fields in exactly their `.msg` order (CDR encodes
//! fields in declaration order, nothing else). Only the messages the node uses.

use nalgebra::{Isometry3, Quaternion as NaQuaternion, Translation3, UnitQuaternion, Vector3};
use ros2_client::dds::rustdds::cdr_encoding;
use serde::{Deserialize, Serialize};

/// A ROS type name and the Rust struct that carries it.
pub trait RosMessage: Serialize + for<'de> Deserialize<'de> + 'static {
    const PACKAGE: &'static str;
    const NAME: &'static str;

    /// The ROS 2 type name, `pkg/msg/Type`.
    fn type_name() -> String {
        format!("{}/msg/{}", Self::PACKAGE, Self::NAME)
    }
}

/// The CDR encapsulation header of little-endian plain CDR (what ROS 2 puts on the wire and
/// rosbag2 stores).
pub const CDR_LE_HEADER: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Why a message could not be encoded or decoded.
#[derive(Debug, thiserror::Error)]
pub enum CdrError {
    #[error("CDR encoding: {0}")]
    Encode(cdr_encoding::Error),
    #[error("{0} bytes: no CDR header")]
    NoHeader(usize),
    #[error("unsupported CDR representation {0:#04x}")]
    Representation(u8),
    #[error("CDR decoding: {0}")]
    Decode(cdr_encoding::Error),
}

/// A message as ROS 2 serializes it: encapsulation header, then little-endian CDR (RustDDS's
/// encoder, the one the node publishes with). An empty struct gets the one padding byte
/// other ROS 2 implementations send.
pub fn to_cdr<M: Serialize>(message: &M) -> Result<Vec<u8>, CdrError> {
    let mut out = CDR_LE_HEADER.to_vec();
    cdr_encoding::to_writer::<M, byteorder::LittleEndian, _>(&mut out, message)
        .map_err(CdrError::Encode)?;
    if out.len() == CDR_LE_HEADER.len() {
        out.push(0);
    }
    Ok(out)
}

/// The inverse of [`to_cdr`]; accepts either byte order.
pub fn from_cdr<M: for<'de> Deserialize<'de>>(bytes: &[u8]) -> Result<M, CdrError> {
    if bytes.len() < 4 {
        return Err(CdrError::NoHeader(bytes.len()));
    }
    let body = &bytes[4..];
    let decoded = match bytes[1] {
        0x01 => cdr_encoding::from_bytes::<M, byteorder::LittleEndian>(body),
        0x00 => cdr_encoding::from_bytes::<M, byteorder::BigEndian>(body),
        other => return Err(CdrError::Representation(other)),
    };
    decoded.map(|(m, _)| m).map_err(CdrError::Decode)
}

macro_rules! ros_message {
    ($t:ty, $pkg:literal, $name:literal) => {
        impl RosMessage for $t {
            const PACKAGE: &'static str = $pkg;
            const NAME: &'static str = $name;
        }
    };
}

// ---- builtin_interfaces, std_msgs ----

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Time {
    pub sec: i32,
    pub nanosec: u32,
}

impl Time {
    /// From seconds (negative or non-finite gives zero, ROS's "invalid").
    pub fn from_secs(t: f64) -> Time {
        if !(t.is_finite() && t > 0.0) {
            return Time::default();
        }
        let ns = (t * 1e9).round() as i64;
        Time {
            sec: (ns / 1_000_000_000) as i32,
            nanosec: (ns % 1_000_000_000) as u32,
        }
    }

    pub fn as_secs(&self) -> f64 {
        self.sec as f64 + self.nanosec as f64 * 1e-9
    }

    pub fn is_zero(&self) -> bool {
        self.sec == 0 && self.nanosec == 0
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Duration {
    pub sec: i32,
    pub nanosec: u32,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    pub stamp: Time,
    pub frame_id: String,
}

impl Header {
    pub fn new(stamp: Time, frame_id: &str) -> Header {
        Header {
            stamp,
            frame_id: frame_id.to_owned(),
        }
    }
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StringMsg {
    pub data: String,
}
ros_message!(StringMsg, "std_msgs", "String");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Bool {
    pub data: bool,
}
ros_message!(Bool, "std_msgs", "Bool");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct UInt32 {
    pub data: u32,
}
ros_message!(UInt32, "std_msgs", "UInt32");

/// std_msgs/Empty. Other ROS 2 implementations put one padding byte on the wire; reading none
/// accepts both.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Empty {}
ros_message!(Empty, "std_msgs", "Empty");

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ColorRGBA {
    pub r: f32,
    pub g: f32,
    pub b: f32,
    pub a: f32,
}

// ---- geometry_msgs ----

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3Msg {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

impl From<Vector3<f64>> for Vector3Msg {
    fn from(v: Vector3<f64>) -> Self {
        Vector3Msg {
            x: v.x,
            y: v.y,
            z: v.z,
        }
    }
}

impl From<Vector3Msg> for Vector3<f64> {
    fn from(v: Vector3Msg) -> Self {
        Vector3::new(v.x, v.y, v.z)
    }
}

/// geometry_msgs/Point (same layout as Vector3).
pub type Point = Vector3Msg;

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct QuaternionMsg {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

impl Default for QuaternionMsg {
    fn default() -> Self {
        QuaternionMsg {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        }
    }
}

impl From<UnitQuaternion<f64>> for QuaternionMsg {
    fn from(q: UnitQuaternion<f64>) -> Self {
        QuaternionMsg {
            x: q.i,
            y: q.j,
            z: q.k,
            w: q.w,
        }
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    pub position: Point,
    pub orientation: QuaternionMsg,
}

/// Why a pose from the wire cannot be used.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PoseError {
    #[error("pose has NaN or infinite values")]
    NotFinite,
    #[error("orientation quaternion is not of unit length")]
    NotUnit,
}

impl Pose {
    pub fn from_isometry(iso: &Isometry3<f64>) -> Pose {
        Pose {
            position: iso.translation.vector.into(),
            orientation: iso.rotation.into(),
        }
    }

    /// The pose as an isometry; the quaternion must be of unit length within 1 %.
    pub fn to_isometry(&self) -> Result<Isometry3<f64>, PoseError> {
        let o = &self.orientation;
        let p = &self.position;
        let values = [p.x, p.y, p.z, o.x, o.y, o.z, o.w];
        if !values.iter().all(|v| v.is_finite()) {
            return Err(PoseError::NotFinite);
        }
        let q = NaQuaternion::new(o.w, o.x, o.y, o.z);
        if (q.norm() - 1.0).abs() > 0.01 {
            return Err(PoseError::NotUnit);
        }
        Ok(Isometry3::from_parts(
            Translation3::new(p.x, p.y, p.z),
            UnitQuaternion::from_quaternion(q),
        ))
    }
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseStamped {
    pub header: Header,
    pub pose: Pose,
}
ros_message!(PoseStamped, "geometry_msgs", "PoseStamped");

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Twist {
    pub linear: Vector3Msg,
    pub angular: Vector3Msg,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TwistStamped {
    pub header: Header,
    pub twist: Twist,
}
ros_message!(TwistStamped, "geometry_msgs", "TwistStamped");

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Wrench {
    pub force: Vector3Msg,
    pub torque: Vector3Msg,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct WrenchStamped {
    pub header: Header,
    pub wrench: Wrench,
}
ros_message!(WrenchStamped, "geometry_msgs", "WrenchStamped");

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    pub translation: Vector3Msg,
    pub rotation: QuaternionMsg,
}

impl From<&Isometry3<f64>> for Transform {
    fn from(iso: &Isometry3<f64>) -> Self {
        Transform {
            translation: iso.translation.vector.into(),
            rotation: iso.rotation.into(),
        }
    }
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    pub header: Header,
    pub child_frame_id: String,
    pub transform: Transform,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TFMessage {
    pub transforms: Vec<TransformStamped>,
}
ros_message!(TFMessage, "tf2_msgs", "TFMessage");

// ---- sensor_msgs ----

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JointState {
    pub header: Header,
    pub name: Vec<String>,
    pub position: Vec<f64>,
    pub velocity: Vec<f64>,
    pub effort: Vec<f64>,
}
ros_message!(JointState, "sensor_msgs", "JointState");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Joy {
    pub header: Header,
    pub axes: Vec<f32>,
    pub buttons: Vec<i32>,
}
ros_message!(Joy, "sensor_msgs", "Joy");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PointField {
    pub name: String,
    pub offset: u32,
    pub datatype: u8,
    pub count: u32,
}

impl PointField {
    pub const FLOAT32: u8 = 7;
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PointCloud2 {
    pub header: Header,
    pub height: u32,
    pub width: u32,
    pub fields: Vec<PointField>,
    pub is_bigendian: bool,
    pub point_step: u32,
    pub row_step: u32,
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
    pub is_dense: bool,
}
ros_message!(PointCloud2, "sensor_msgs", "PointCloud2");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CompressedImage {
    pub header: Header,
    pub format: String,
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}

// ---- visualization_msgs ----

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct UVCoordinate {
    pub u: f32,
    pub v: f32,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MeshFile {
    pub filename: String,
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Marker {
    pub header: Header,
    pub ns: String,
    pub id: i32,
    #[serde(rename = "type")]
    pub kind: i32,
    pub action: i32,
    pub pose: Pose,
    pub scale: Vector3Msg,
    pub color: ColorRGBA,
    pub lifetime: Duration,
    pub frame_locked: bool,
    pub points: Vec<Point>,
    pub colors: Vec<ColorRGBA>,
    pub texture_resource: String,
    pub texture: CompressedImage,
    pub uv_coordinates: Vec<UVCoordinate>,
    pub text: String,
    pub mesh_resource: String,
    pub mesh_file: MeshFile,
    pub mesh_use_embedded_materials: bool,
}
ros_message!(Marker, "visualization_msgs", "Marker");

impl Marker {
    pub const LINE_STRIP: i32 = 4;
    pub const TRIANGLE_LIST: i32 = 11;
    pub const ADD: i32 = 0;
}

// ---- crtk_msgs ----

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct OperatingState {
    pub header: Header,
    pub state: String,
    pub is_homed: bool,
    pub is_busy: bool,
}
ros_message!(OperatingState, "crtk_msgs", "OperatingState");

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StringStamped {
    pub header: Header,
    pub string: String,
}
ros_message!(StringStamped, "crtk_msgs", "StringStamped");

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_round_trips_seconds() {
        let t = Time::from_secs(12.345_678_9);
        assert_eq!(t.sec, 12);
        assert_eq!(t.nanosec, 345_678_900);
        assert!((t.as_secs() - 12.345_678_9).abs() < 1e-9);
        assert!(Time::from_secs(f64::NAN).is_zero());
        assert!(Time::from_secs(-1.0).is_zero());
    }

    #[test]
    fn poses_must_be_finite_with_unit_quaternions() {
        let iso = Isometry3::from_parts(
            Translation3::new(0.1, -0.2, 0.3),
            UnitQuaternion::from_euler_angles(0.1, 0.2, 0.3),
        );
        let pose = Pose::from_isometry(&iso);
        let back = pose.to_isometry().unwrap();
        assert!((back.translation.vector - iso.translation.vector).norm() < 1e-12);
        assert!(back.rotation.angle_to(&iso.rotation) < 1e-12);
        let mut bad = pose;
        bad.position.x = f64::NAN;
        assert_eq!(bad.to_isometry(), Err(PoseError::NotFinite));
        let mut zero = pose;
        zero.orientation = QuaternionMsg {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 0.0,
        };
        assert_eq!(zero.to_isometry(), Err(PoseError::NotUnit));
    }
}

/// rosgraph_msgs/Clock: the simulated time, which nodes with `use_sim_time` follow.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Clock {
    pub clock: Time,
}
ros_message!(Clock, "rosgraph_msgs", "Clock");

/// diagnostic_msgs/KeyValue.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct KeyValue {
    pub key: String,
    pub value: String,
}

/// diagnostic_msgs/DiagnosticStatus (`level`: 0 OK, 1 WARN, 2 ERROR, 3 STALE).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticStatus {
    pub level: u8,
    pub name: String,
    pub message: String,
    pub hardware_id: String,
    pub values: Vec<KeyValue>,
}

/// diagnostic_msgs/DiagnosticArray.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticArray {
    pub header: Header,
    pub status: Vec<DiagnosticStatus>,
}
ros_message!(DiagnosticArray, "diagnostic_msgs", "DiagnosticArray");
