//! Message definitions in ROS 2's `.msg` syntax (`ros2msg`), as rosbag2 stores them in an
//! MCAP schema: the type's own text, then every type it uses, each after a line of 80 `=`
//! and `MSG: pkg/msg/Type`. Readers (rosbags, Foxglove, `ros2 bag`) decode the CDR payloads
//! from this text alone, so field names, types and order are exactly those of the `.msg`
//! files (and of the structs in [`super::msgs`]).

/// Own fields and directly used types of one message type.
struct Definition {
    name: &'static str,
    text: &'static str,
    uses: &'static [&'static str],
}

const DEFINITIONS: &[Definition] = &[
    Definition {
        name: "builtin_interfaces/msg/Time",
        text: "int32 sec\nuint32 nanosec\n",
        uses: &[],
    },
    Definition {
        name: "builtin_interfaces/msg/Duration",
        text: "int32 sec\nuint32 nanosec\n",
        uses: &[],
    },
    Definition {
        name: "std_msgs/msg/Header",
        text: "builtin_interfaces/Time stamp\nstring frame_id\n",
        uses: &["builtin_interfaces/msg/Time"],
    },
    Definition {
        name: "std_msgs/msg/String",
        text: "string data\n",
        uses: &[],
    },
    Definition {
        name: "std_msgs/msg/Bool",
        text: "bool data\n",
        uses: &[],
    },
    Definition {
        name: "std_msgs/msg/UInt32",
        text: "uint32 data\n",
        uses: &[],
    },
    Definition {
        name: "std_msgs/msg/Empty",
        text: "",
        uses: &[],
    },
    Definition {
        name: "std_msgs/msg/ColorRGBA",
        text: "float32 r\nfloat32 g\nfloat32 b\nfloat32 a\n",
        uses: &[],
    },
    Definition {
        name: "geometry_msgs/msg/Vector3",
        text: "float64 x\nfloat64 y\nfloat64 z\n",
        uses: &[],
    },
    Definition {
        name: "geometry_msgs/msg/Point",
        text: "float64 x\nfloat64 y\nfloat64 z\n",
        uses: &[],
    },
    Definition {
        name: "geometry_msgs/msg/Quaternion",
        text: "float64 x\nfloat64 y\nfloat64 z\nfloat64 w\n",
        uses: &[],
    },
    Definition {
        name: "geometry_msgs/msg/Pose",
        text: "Point position\nQuaternion orientation\n",
        uses: &["geometry_msgs/msg/Point", "geometry_msgs/msg/Quaternion"],
    },
    Definition {
        name: "geometry_msgs/msg/PoseStamped",
        text: "std_msgs/Header header\nPose pose\n",
        uses: &["std_msgs/msg/Header", "geometry_msgs/msg/Pose"],
    },
    Definition {
        name: "geometry_msgs/msg/Twist",
        text: "Vector3 linear\nVector3 angular\n",
        uses: &["geometry_msgs/msg/Vector3"],
    },
    Definition {
        name: "geometry_msgs/msg/TwistStamped",
        text: "std_msgs/Header header\nTwist twist\n",
        uses: &["std_msgs/msg/Header", "geometry_msgs/msg/Twist"],
    },
    Definition {
        name: "geometry_msgs/msg/Wrench",
        text: "Vector3 force\nVector3 torque\n",
        uses: &["geometry_msgs/msg/Vector3"],
    },
    Definition {
        name: "geometry_msgs/msg/WrenchStamped",
        text: "std_msgs/Header header\nWrench wrench\n",
        uses: &["std_msgs/msg/Header", "geometry_msgs/msg/Wrench"],
    },
    Definition {
        name: "geometry_msgs/msg/Transform",
        text: "Vector3 translation\nQuaternion rotation\n",
        uses: &["geometry_msgs/msg/Vector3", "geometry_msgs/msg/Quaternion"],
    },
    Definition {
        name: "geometry_msgs/msg/TransformStamped",
        text: "std_msgs/Header header\nstring child_frame_id\nTransform transform\n",
        uses: &["std_msgs/msg/Header", "geometry_msgs/msg/Transform"],
    },
    Definition {
        name: "tf2_msgs/msg/TFMessage",
        text: "geometry_msgs/TransformStamped[] transforms\n",
        uses: &["geometry_msgs/msg/TransformStamped"],
    },
    Definition {
        name: "std_msgs/msg/Float64",
        text: "float64 data\n",
        uses: &[],
    },
    Definition {
        name: "sensor_msgs/msg/JointState",
        text: "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\n\
               float64[] effort\n",
        uses: &["std_msgs/msg/Header"],
    },
    Definition {
        name: "sensor_msgs/msg/Joy",
        text: "std_msgs/Header header\nfloat32[] axes\nint32[] buttons\n",
        uses: &["std_msgs/msg/Header"],
    },
    Definition {
        name: "sensor_msgs/msg/PointField",
        text: "uint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\n\
               uint8 INT32=5\nuint8 UINT32=6\nuint8 FLOAT32=7\nuint8 FLOAT64=8\n\
               string name\nuint32 offset\nuint8 datatype\nuint32 count\n",
        uses: &[],
    },
    Definition {
        name: "sensor_msgs/msg/PointCloud2",
        text: "std_msgs/Header header\nuint32 height\nuint32 width\nPointField[] fields\n\
               bool is_bigendian\nuint32 point_step\nuint32 row_step\nuint8[] data\n\
               bool is_dense\n",
        uses: &["std_msgs/msg/Header", "sensor_msgs/msg/PointField"],
    },
    Definition {
        name: "sensor_msgs/msg/CompressedImage",
        text: "std_msgs/Header header\nstring format\nuint8[] data\n",
        uses: &["std_msgs/msg/Header"],
    },
    Definition {
        name: "sensor_msgs/msg/Image",
        text: "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\n\
               uint8 is_bigendian\nuint32 step\nuint8[] data\n",
        uses: &["std_msgs/msg/Header"],
    },
    Definition {
        name: "sensor_msgs/msg/RegionOfInterest",
        text: "uint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify\n",
        uses: &[],
    },
    Definition {
        name: "sensor_msgs/msg/CameraInfo",
        text: "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\n\
               float64[] d\nfloat64[9] k\nfloat64[9] r\nfloat64[12] p\nuint32 binning_x\n\
               uint32 binning_y\nRegionOfInterest roi\n",
        uses: &["std_msgs/msg/Header", "sensor_msgs/msg/RegionOfInterest"],
    },
    Definition {
        name: "visualization_msgs/msg/UVCoordinate",
        text: "float32 u\nfloat32 v\n",
        uses: &[],
    },
    Definition {
        name: "visualization_msgs/msg/MeshFile",
        text: "string filename\nuint8[] data\n",
        uses: &[],
    },
    Definition {
        name: "visualization_msgs/msg/Marker",
        text: "int32 ARROW=0\nint32 CUBE=1\nint32 SPHERE=2\nint32 CYLINDER=3\n\
               int32 LINE_STRIP=4\nint32 LINE_LIST=5\nint32 CUBE_LIST=6\nint32 SPHERE_LIST=7\n\
               int32 POINTS=8\nint32 TEXT_VIEW_FACING=9\nint32 MESH_RESOURCE=10\n\
               int32 TRIANGLE_LIST=11\nint32 ARROW_STRIP=12\n\
               int32 ADD=0\nint32 MODIFY=0\nint32 DELETE=2\nint32 DELETEALL=3\n\
               std_msgs/Header header\nstring ns\nint32 id\nint32 type\nint32 action\n\
               geometry_msgs/Pose pose\ngeometry_msgs/Vector3 scale\nstd_msgs/ColorRGBA color\n\
               builtin_interfaces/Duration lifetime\nbool frame_locked\n\
               geometry_msgs/Point[] points\nstd_msgs/ColorRGBA[] colors\n\
               string texture_resource\nsensor_msgs/CompressedImage texture\n\
               UVCoordinate[] uv_coordinates\nstring text\nstring mesh_resource\n\
               MeshFile mesh_file\nbool mesh_use_embedded_materials\n",
        uses: &[
            "std_msgs/msg/Header",
            "geometry_msgs/msg/Pose",
            "geometry_msgs/msg/Vector3",
            "std_msgs/msg/ColorRGBA",
            "builtin_interfaces/msg/Duration",
            "geometry_msgs/msg/Point",
            "sensor_msgs/msg/CompressedImage",
            "visualization_msgs/msg/UVCoordinate",
            "visualization_msgs/msg/MeshFile",
        ],
    },
    Definition {
        name: "crtk_msgs/msg/OperatingState",
        text: "std_msgs/Header header\nstring state\nbool is_homed\nbool is_busy\n",
        uses: &["std_msgs/msg/Header"],
    },
    Definition {
        name: "crtk_msgs/msg/StringStamped",
        text: "std_msgs/Header header\nstring string\n",
        uses: &["std_msgs/msg/Header"],
    },
];

fn find(name: &str) -> Option<&'static Definition> {
    DEFINITIONS.iter().find(|d| d.name == name)
}

/// The `ros2msg` schema text of `type_name` (`pkg/msg/Type`), or `None` for a type the node
/// does not use.
pub fn ros2msg(type_name: &str) -> Option<String> {
    let root = find(type_name)?;
    // Every type used, directly or not, once, in first-use order.
    let mut order: Vec<&'static str> = Vec::new();
    let mut stack: Vec<&'static str> = root.uses.iter().rev().copied().collect();
    while let Some(name) = stack.pop() {
        if order.contains(&name) {
            continue;
        }
        order.push(name);
        let d = find(name).expect("every used type has a definition");
        stack.extend(d.uses.iter().rev().copied());
    }
    let mut text = root.text.to_owned();
    for name in order {
        text.push_str(&"=".repeat(80));
        text.push_str("\nMSG: ");
        text.push_str(name);
        text.push('\n');
        text.push_str(find(name).map(|d| d.text).unwrap_or_default());
    }
    Some(text)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ros::msgs::*;

    #[test]
    fn every_message_type_has_a_schema_with_its_dependencies() {
        for name in [
            PointCloud2::type_name(),
            Marker::type_name(),
            WrenchStamped::type_name(),
            JointState::type_name(),
            PoseStamped::type_name(),
            TwistStamped::type_name(),
            TFMessage::type_name(),
            OperatingState::type_name(),
            StringMsg::type_name(),
            StringStamped::type_name(),
            Empty::type_name(),
            Bool::type_name(),
            Float64::type_name(),
            UInt32::type_name(),
            Joy::type_name(),
            Image::type_name(),
            CompressedImage::type_name(),
            CameraInfo::type_name(),
        ] {
            assert!(ros2msg(&name).is_some(), "{name}");
        }
        let marker = ros2msg("visualization_msgs/msg/Marker").unwrap();
        for dep in [
            "MSG: builtin_interfaces/msg/Time",
            "MSG: std_msgs/msg/Header",
        ] {
            assert_eq!(marker.matches(dep).count(), 1, "{dep} once in\n{marker}");
        }
        let tf = ros2msg("tf2_msgs/msg/TFMessage").unwrap();
        assert!(tf.contains("MSG: geometry_msgs/msg/Quaternion\nfloat64 x\n"));
    }
}
