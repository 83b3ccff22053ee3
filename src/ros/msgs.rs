//! ROS 2 message types as serde structs, fields in exactly their `.msg` order (CDR encodes
//! fields in declaration order, nothing else). Only the messages the node uses.

use nalgebra::{Isometry3, Quaternion as NaQuaternion, Translation3, UnitQuaternion, Vector3};
use ros2_client::dds::rustdds::cdr_encoding;
use serde::{Deserialize, Serialize};

/// A ROS type name and the Rust struct that carries it.
pub trait RosMessage: Serialize + for<'de> Deserialize<'de> + 'static {
    /// The ROS package that defines the message, e.g. `sensor_msgs`.
    const PACKAGE: &'static str;
    /// The message's type name within its package, e.g. `JointState`.
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
    /// The encoder failed (a type the CDR encoder cannot write).
    Encode(cdr_encoding::Error),
    #[error("{0} bytes: no CDR header")]
    /// Fewer than the 4 bytes of the encapsulation header; holds the length received.
    NoHeader(usize),
    #[error("unsupported CDR representation {0:#04x}")]
    /// An encapsulation other than plain CDR (byte 1 neither 0x00 nor 0x01); holds that byte.
    Representation(u8),
    #[error("CDR decoding: {0}")]
    /// The body does not decode as the expected message.
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

/// `builtin_interfaces/Time`: a time stamp, seconds and nanoseconds since the clock's epoch (here
/// the simulated time since start).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Time {
    /// `Time.sec`: whole seconds.
    pub sec: i32,
    /// `Time.nanosec`: nanoseconds within the second, 0..1e9.
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

    /// The time in seconds.
    pub fn as_secs(&self) -> f64 {
        self.sec as f64 + self.nanosec as f64 * 1e-9
    }

    /// Whether this is the zero time, which ROS reads as "no stamp".
    pub fn is_zero(&self) -> bool {
        self.sec == 0 && self.nanosec == 0
    }
}

/// `builtin_interfaces/Duration`: a time span, seconds plus nanoseconds (0 means forever where ROS
/// uses it as a lifetime).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Duration {
    /// `Duration.sec`: whole seconds.
    pub sec: i32,
    /// `Duration.nanosec`: nanoseconds within the second, 0..1e9.
    pub nanosec: u32,
}

/// `std_msgs/Header`: when and in which frame a stamped message's data hold.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// `Header.stamp`: the simulated time the data belong to.
    pub stamp: Time,
    /// `Header.frame_id`: the TF frame the data are expressed in (empty: no frame).
    pub frame_id: String,
}

impl Header {
    /// A header at `stamp` in the frame `frame_id`.
    pub fn new(stamp: Time, frame_id: &str) -> Header {
        Header {
            stamp,
            frame_id: frame_id.to_owned(),
        }
    }
}

/// `std_msgs/String`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StringMsg {
    /// `String.data`: the text.
    pub data: String,
}
ros_message!(StringMsg, "std_msgs", "String");

/// `std_msgs/Bool`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Bool {
    /// `Bool.data`: the value.
    pub data: bool,
}
ros_message!(Bool, "std_msgs", "Bool");

/// `std_msgs/UInt32`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct UInt32 {
    /// `UInt32.data`: the value.
    pub data: u32,
}
ros_message!(UInt32, "std_msgs", "UInt32");

/// `std_msgs/Float64`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Float64 {
    /// `Float64.data`: the value.
    pub data: f64,
}
ros_message!(Float64, "std_msgs", "Float64");

/// `std_msgs/MultiArrayDimension`: one dimension of a multi-array.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MultiArrayDimension {
    /// `label`: what the dimension indexes.
    pub label: String,
    /// `size`: its length.
    pub size: u32,
    /// `stride`: elements spanned by one step of the enclosing dimension.
    pub stride: u32,
}

/// `std_msgs/MultiArrayLayout`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MultiArrayLayout {
    /// `dim`: outermost first.
    pub dim: Vec<MultiArrayDimension>,
    /// `data_offset`: padding elements at the front of `data`.
    pub data_offset: u32,
}

/// `std_msgs/Float64MultiArray` (the arms' Jacobians, row-major).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Float64MultiArray {
    /// `layout`.
    pub layout: MultiArrayLayout,
    /// `data`.
    pub data: Vec<f64>,
}
ros_message!(Float64MultiArray, "std_msgs", "Float64MultiArray");

/// std_msgs/Empty. Other ROS 2 implementations put one padding byte on the wire; reading none
/// accepts both.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Empty {}
ros_message!(Empty, "std_msgs", "Empty");

/// `std_msgs/ColorRGBA`: a colour, each channel 0..1.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ColorRGBA {
    /// `ColorRGBA.r`: red, 0..1.
    pub r: f32,
    /// `ColorRGBA.g`: green, 0..1.
    pub g: f32,
    /// `ColorRGBA.b`: blue, 0..1.
    pub b: f32,
    /// `ColorRGBA.a`: opacity, 0 (transparent) ..1 (opaque).
    pub a: f32,
}

// ---- geometry_msgs ----

/// `geometry_msgs/Vector3` (also `Point`, same layout): a 3-vector in the frame of the enclosing
/// message.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3Msg {
    /// `Vector3.x`: in the unit of the enclosing field (m, m/s, rad/s, N or N m).
    pub x: f64,
    /// `Vector3.y`: in the unit of the enclosing field.
    pub y: f64,
    /// `Vector3.z`: in the unit of the enclosing field.
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

/// `geometry_msgs/Quaternion`: a rotation as a unit quaternion (default: identity).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct QuaternionMsg {
    /// `Quaternion.x`: vector part, i component.
    pub x: f64,
    /// `Quaternion.y`: vector part, j component.
    pub y: f64,
    /// `Quaternion.z`: vector part, k component.
    pub z: f64,
    /// `Quaternion.w`: scalar part.
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

/// `geometry_msgs/Pose`: a position and orientation in the frame of the enclosing message.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// `Pose.position`: m.
    pub position: Point,
    /// `Pose.orientation`: unit quaternion.
    pub orientation: QuaternionMsg,
}

/// Why a pose from the wire cannot be used.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PoseError {
    #[error("pose has NaN or infinite values")]
    /// A coordinate is NaN or infinite.
    NotFinite,
    #[error("orientation quaternion is not of unit length")]
    /// The quaternion's norm differs from 1 by more than 1 %.
    NotUnit,
}

impl Pose {
    /// The pose of an isometry (translation in m).
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

/// `geometry_msgs/PoseStamped`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseStamped {
    /// `PoseStamped.header`: stamp and frame the pose is given in.
    pub header: Header,
    /// `PoseStamped.pose`: the pose, m.
    pub pose: Pose,
}
ros_message!(PoseStamped, "geometry_msgs", "PoseStamped");

/// `geometry_msgs/Twist`: a velocity in the frame of the enclosing message.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Twist {
    /// `Twist.linear`: m/s.
    pub linear: Vector3Msg,
    /// `Twist.angular`: rad/s.
    pub angular: Vector3Msg,
}

/// `geometry_msgs/TwistStamped`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TwistStamped {
    /// `TwistStamped.header`: stamp and frame the twist is given in.
    pub header: Header,
    /// `TwistStamped.twist`: m/s and rad/s.
    pub twist: Twist,
}
ros_message!(TwistStamped, "geometry_msgs", "TwistStamped");

/// `geometry_msgs/Wrench`: a force and torque in the frame of the enclosing message.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Wrench {
    /// `Wrench.force`: N.
    pub force: Vector3Msg,
    /// `Wrench.torque`: N m.
    pub torque: Vector3Msg,
}

/// `geometry_msgs/WrenchStamped`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct WrenchStamped {
    /// `WrenchStamped.header`: stamp and frame the wrench is given in.
    pub header: Header,
    /// `WrenchStamped.wrench`: N and N m.
    pub wrench: Wrench,
}
ros_message!(WrenchStamped, "geometry_msgs", "WrenchStamped");

/// `geometry_msgs/Transform`: the pose of a child frame in its parent frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    /// `Transform.translation`: the child origin in the parent frame, m.
    pub translation: Vector3Msg,
    /// `Transform.rotation`: the child orientation in the parent frame.
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

/// `geometry_msgs/TransformStamped`: one TF edge.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    /// `TransformStamped.header`: stamp, and the parent frame in `frame_id`.
    pub header: Header,
    /// `TransformStamped.child_frame_id`: the frame whose pose this is.
    pub child_frame_id: String,
    /// `TransformStamped.transform`: the child frame in the parent frame, m.
    pub transform: Transform,
}

/// `tf2_msgs/TFMessage`: what `/tf` and `/tf_static` carry.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TFMessage {
    /// `TFMessage.transforms`: the transforms, one per parent-child edge.
    pub transforms: Vec<TransformStamped>,
}
ros_message!(TFMessage, "tf2_msgs", "TFMessage");

// ---- sensor_msgs ----

/// `sensor_msgs/JointState`: the arrays are in `name` order; an empty array means not reported.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JointState {
    /// `JointState.header`: stamp of the joint values (frame unused).
    pub header: Header,
    /// `JointState.name`: the joint names.
    pub name: Vec<String>,
    /// `JointState.position`: rad (revolute) or m (prismatic) per joint, in `name` order.
    pub position: Vec<f64>,
    /// `JointState.velocity`: rad/s or m/s per joint, in `name` order.
    pub velocity: Vec<f64>,
    /// `JointState.effort`: N m (revolute) or N (prismatic) per joint, in `name` order.
    pub effort: Vec<f64>,
}
ros_message!(JointState, "sensor_msgs", "JointState");

/// `sensor_msgs/Joy`: a joystick or foot pedal state.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Joy {
    /// `Joy.header`: stamp of the reading.
    pub header: Header,
    /// `Joy.axes`: axis positions, -1..1 each.
    pub axes: Vec<f32>,
    /// `Joy.buttons`: button states, 1 pressed, 0 released.
    pub buttons: Vec<i32>,
}
ros_message!(Joy, "sensor_msgs", "Joy");

/// `sensor_msgs/PointField`: one field of a point cloud's point record.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PointField {
    /// `PointField.name`: the field's name, e.g. `x`.
    pub name: String,
    /// `PointField.offset`: byte offset of the field within the point record.
    pub offset: u32,
    /// `PointField.datatype`: element type code, e.g. [`PointField::FLOAT32`].
    pub datatype: u8,
    /// `PointField.count`: number of elements in the field.
    pub count: u32,
}

impl PointField {
    /// The `datatype` code of a 32-bit float.
    pub const FLOAT32: u8 = 7;
}

/// `sensor_msgs/PointCloud2`: points as packed records of `fields`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PointCloud2 {
    /// `PointCloud2.header`: stamp and the frame the points are expressed in.
    pub header: Header,
    /// `PointCloud2.height`: rows; 1 for an unordered cloud.
    pub height: u32,
    /// `PointCloud2.width`: points per row (all points for an unordered cloud).
    pub width: u32,
    /// `PointCloud2.fields`: the layout of one point record.
    pub fields: Vec<PointField>,
    /// `PointCloud2.is_bigendian`: byte order of `data`.
    pub is_bigendian: bool,
    /// `PointCloud2.point_step`: bytes per point.
    pub point_step: u32,
    /// `PointCloud2.row_step`: bytes per row.
    pub row_step: u32,
    #[serde(with = "serde_bytes")]
    /// `PointCloud2.data`: the point records, `row_step * height` bytes.
    pub data: Vec<u8>,
    /// `PointCloud2.is_dense`: true when no point is invalid (NaN).
    pub is_dense: bool,
}
ros_message!(PointCloud2, "sensor_msgs", "PointCloud2");

/// `sensor_msgs/CompressedImage`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CompressedImage {
    /// `CompressedImage.header`: stamp and camera frame.
    pub header: Header,
    /// `CompressedImage.format`: the encoding, e.g. `png` (empty with no image).
    pub format: String,
    #[serde(with = "serde_bytes")]
    /// `CompressedImage.data`: the encoded image bytes.
    pub data: Vec<u8>,
}

ros_message!(CompressedImage, "sensor_msgs", "CompressedImage");

/// `sensor_msgs/Image`: an uncompressed image, rows from the top.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Image {
    /// `Image.header`: stamp and the camera's optical frame.
    pub header: Header,
    /// `Image.height`: rows.
    pub height: u32,
    /// `Image.width`: columns.
    pub width: u32,
    /// `Image.encoding`: the pixel format (`rgb8`, `32FC1`, `mono8`, ...).
    pub encoding: String,
    /// `Image.is_bigendian`: byte order of multi-byte pixels (0: little-endian).
    pub is_bigendian: u8,
    /// `Image.step`: bytes per row.
    pub step: u32,
    #[serde(with = "serde_bytes")]
    /// `Image.data`: `step * height` bytes.
    pub data: Vec<u8>,
}
ros_message!(Image, "sensor_msgs", "Image");

/// `sensor_msgs/RegionOfInterest` (CameraInfo's; all zero: the full image).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RegionOfInterest {
    /// `RegionOfInterest.x_offset`: leftmost column.
    pub x_offset: u32,
    /// `RegionOfInterest.y_offset`: topmost row.
    pub y_offset: u32,
    /// `RegionOfInterest.height`: rows.
    pub height: u32,
    /// `RegionOfInterest.width`: columns.
    pub width: u32,
    /// `RegionOfInterest.do_rectify`: whether to rectify the region.
    pub do_rectify: bool,
}

/// `sensor_msgs/CameraInfo`: a camera's calibration.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CameraInfo {
    /// `CameraInfo.header`: stamp and the camera's optical frame.
    pub header: Header,
    /// `CameraInfo.height`: image rows.
    pub height: u32,
    /// `CameraInfo.width`: image columns.
    pub width: u32,
    /// `CameraInfo.distortion_model`: `plumb_bob`.
    pub distortion_model: String,
    /// `CameraInfo.d`: distortion coefficients (all zero: an ideal pinhole).
    pub d: Vec<f64>,
    /// `CameraInfo.k`: intrinsic matrix, row-major.
    pub k: [f64; 9],
    /// `CameraInfo.r`: rectification rotation, row-major (identity).
    pub r: [f64; 9],
    /// `CameraInfo.p`: projection matrix, row-major (Tx = −f·baseline for the right eye).
    pub p: [f64; 12],
    /// `CameraInfo.binning_x`: 0 (no binning).
    pub binning_x: u32,
    /// `CameraInfo.binning_y`: 0 (no binning).
    pub binning_y: u32,
    /// `CameraInfo.roi`: the full image.
    pub roi: RegionOfInterest,
}
ros_message!(CameraInfo, "sensor_msgs", "CameraInfo");

// ---- visualization_msgs ----

/// `visualization_msgs/UVCoordinate`: a texture coordinate.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct UVCoordinate {
    /// `UVCoordinate.u`: horizontal texture coordinate, 0..1.
    pub u: f32,
    /// `UVCoordinate.v`: vertical texture coordinate, 0..1.
    pub v: f32,
}

/// `visualization_msgs/MeshFile`: a mesh sent inline.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MeshFile {
    /// `MeshFile.filename`: the name, whose extension tells the format.
    pub filename: String,
    /// `MeshFile.data`: the file's bytes (empty: none).
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}

/// `visualization_msgs/Marker`: a shape for RViz.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Marker {
    /// `Marker.header`: stamp and the frame `pose` and `points` are given in.
    pub header: Header,
    /// `Marker.ns`: namespace; with `id` names the marker.
    pub ns: String,
    /// `Marker.id`: identifier within `ns`; a marker with the same pair replaces this one.
    pub id: i32,
    #[serde(rename = "type")]
    /// `Marker.type`: the shape, e.g. [`Marker::LINE_STRIP`], [`Marker::TRIANGLE_LIST`].
    pub kind: i32,
    /// `Marker.action`: what to do with the marker, e.g. [`Marker::ADD`].
    pub action: i32,
    /// `Marker.pose`: the marker frame in the header frame, m.
    pub pose: Pose,
    /// `Marker.scale`: size per axis, m (for a line strip, `x` is the line width).
    pub scale: Vector3Msg,
    /// `Marker.color`: the colour used where `colors` is empty.
    pub color: ColorRGBA,
    /// `Marker.lifetime`: how long the marker stays (zero: until replaced).
    pub lifetime: Duration,
    /// `Marker.frame_locked`: whether the marker follows its frame as TF changes.
    pub frame_locked: bool,
    /// `Marker.points`: vertices in the marker frame, m (lines and triangle lists).
    pub points: Vec<Point>,
    /// `Marker.colors`: per-vertex colours, one per point (empty: `color` for all).
    pub colors: Vec<ColorRGBA>,
    /// `Marker.texture_resource`: texture URI (empty: none).
    pub texture_resource: String,
    /// `Marker.texture`: inline texture image (used with `texture_resource` `embedded://`).
    pub texture: CompressedImage,
    /// `Marker.uv_coordinates`: texture coordinates, one per point.
    pub uv_coordinates: Vec<UVCoordinate>,
    /// `Marker.text`: text shown by text markers.
    pub text: String,
    /// `Marker.mesh_resource`: mesh URI for mesh markers (empty: none).
    pub mesh_resource: String,
    /// `Marker.mesh_file`: inline mesh (used with `mesh_resource` `embedded://`).
    pub mesh_file: MeshFile,
    /// `Marker.mesh_use_embedded_materials`: use the mesh's own materials instead of `color`.
    pub mesh_use_embedded_materials: bool,
}
ros_message!(Marker, "visualization_msgs", "Marker");

impl Marker {
    /// `type`: a connected polyline through `points`.
    pub const LINE_STRIP: i32 = 4;
    /// `type`: triangles, each three consecutive `points`.
    pub const TRIANGLE_LIST: i32 = 11;
    /// `action`: add or replace the marker.
    pub const ADD: i32 = 0;
}

// ---- crtk_msgs ----

/// `crtk_msgs/OperatingState`: the CRTK state of an arm.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct OperatingState {
    /// `OperatingState.header`: stamp of the state.
    pub header: Header,
    /// `OperatingState.state`: the CRTK state name: `DISABLED`, `ENABLED`, `PAUSED` or `FAULT`.
    pub state: String,
    /// `OperatingState.is_homed`: whether the arm has been homed.
    pub is_homed: bool,
    /// `OperatingState.is_busy`: whether a move is in progress.
    pub is_busy: bool,
}
ros_message!(OperatingState, "crtk_msgs", "OperatingState");

/// `crtk_msgs/StringStamped`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StringStamped {
    /// `StringStamped.header`: stamp of the message.
    pub header: Header,
    /// `StringStamped.string`: the text.
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
    /// `Clock.clock`: the simulated time, s since start.
    pub clock: Time,
}
ros_message!(Clock, "rosgraph_msgs", "Clock");

/// diagnostic_msgs/KeyValue.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct KeyValue {
    /// `KeyValue.key`: the value's name.
    pub key: String,
    /// `KeyValue.value`: the value, as text.
    pub value: String,
}

/// diagnostic_msgs/DiagnosticStatus (`level`: 0 OK, 1 WARN, 2 ERROR, 3 STALE).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticStatus {
    /// `DiagnosticStatus.level`: 0 OK, 1 WARN, 2 ERROR, 3 STALE.
    pub level: u8,
    /// `DiagnosticStatus.name`: what the status is of.
    pub name: String,
    /// `DiagnosticStatus.message`: a one-line summary.
    pub message: String,
    /// `DiagnosticStatus.hardware_id`: the device the status is of (may be empty).
    pub hardware_id: String,
    /// `DiagnosticStatus.values`: further named values.
    pub values: Vec<KeyValue>,
}

/// diagnostic_msgs/DiagnosticArray.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticArray {
    /// `DiagnosticArray.header`: stamp of the report.
    pub header: Header,
    /// `DiagnosticArray.status`: one entry per reported component.
    pub status: Vec<DiagnosticStatus>,
}
ros_message!(DiagnosticArray, "diagnostic_msgs", "DiagnosticArray");
