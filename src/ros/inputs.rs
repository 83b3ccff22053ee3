//! The node's input topics: their names and types for a scene, and how a message on each
//! becomes a [`SimInput`]. The node's subscriptions and the replay of a recorded bag go
//! through the same conversion, so a replayed command does exactly what the live one did.

use crate::config::{ArmMode, Scene};
use crate::ros::msgs::*;
use crate::ros::names::resolve;
use crate::sim::arm::{ArmCommand, ArmInput};
use crate::sim::SimInput;

/// What an input topic is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputKind {
    /// `<arm>/servo_jp` (`sensor_msgs/JointState`).
    ServoJp,
    /// `<arm>/move_jp` (`sensor_msgs/JointState`).
    MoveJp,
    /// `<arm>/jaw/servo_jp` (`sensor_msgs/JointState`).
    JawServoJp,
    /// `<arm>/jaw/move_jp` (`sensor_msgs/JointState`).
    JawMoveJp,
    /// `<arm>/jaw/servo_jf` (`sensor_msgs/JointState`, effort in N·m).
    JawServoJf,
    /// `<arm>/servo_cp` (`geometry_msgs/PoseStamped`).
    ServoCp,
    /// `<arm>/move_cp` (`geometry_msgs/PoseStamped`).
    MoveCp,
    /// `<arm>/hold` (`std_msgs/Empty`).
    Hold,
    /// `<arm>/free` (`std_msgs/Empty`).
    Free,
    /// `<arm>/state_command` (`crtk_msgs/StringStamped`).
    StateCommand,
    /// `<arm>/body/servo_cf` (`geometry_msgs/WrenchStamped`).
    ServoCf,
    /// `<arm>/use_gravity_compensation` (`std_msgs/Bool`).
    GravityCompensation,
    /// `<arm>/servo_jr` (`sensor_msgs/JointState`): a joint step from the setpoint.
    ServoJr,
    /// `<arm>/move_jr` (`sensor_msgs/JointState`): a joint move relative to the setpoint.
    MoveJr,
    /// `<arm>/servo_jf` (`sensor_msgs/JointState`, joint efforts).
    ServoJf,
    /// `<arm>/spatial/servo_cf` (`geometry_msgs/WrenchStamped`).
    SpatialServoCf,
    /// `<arm>/trajectory_j/set_ratio` (`std_msgs/Float64`): the share of dVRK's `move_jp`
    /// speeds moves use.
    TrajectoryRatio,
    /// `<arm>/body/set_cf_orientation_absolute` (`std_msgs/Bool`).
    CfOrientationAbsolute,
    /// `<arm>/emulate_tool_present` (`std_msgs/Bool`).
    EmulateToolPresent,
    /// A mirrored real arm's `measured_js` (`sensor_msgs/JointState`).
    MirrorJs,
    /// A mirrored real arm's `jaw/measured_js` (`sensor_msgs/JointState`).
    MirrorJaw,
    /// Teleoperation: the MTM's `measured_cp` (`geometry_msgs/PoseStamped`).
    MtmCp,
    /// Teleoperation: the MTM's `gripper/measured_js` (`sensor_msgs/JointState`).
    MtmGripper,
    /// Teleoperation: the console's `clutch` pedal (`sensor_msgs/Joy`).
    Clutch,
    /// Teleoperation: the console's `operator_present` pedal (`sensor_msgs/Joy`).
    OperatorPresent,
}

/// A message on one of the input topics.
#[derive(Clone, Debug, PartialEq)]
pub enum InputMessage {
    /// `sensor_msgs/JointState`.
    Joints(JointState),
    /// `geometry_msgs/PoseStamped`.
    Pose(PoseStamped),
    /// `std_msgs/Empty`.
    Empty(Empty),
    /// `crtk_msgs/StringStamped`.
    Command(StringStamped),
    /// `geometry_msgs/WrenchStamped`.
    Wrench(WrenchStamped),
    /// `std_msgs/Bool`.
    Flag(Bool),
    /// `std_msgs/Float64`.
    Number(Float64),
    /// `sensor_msgs/Joy`.
    Joy(Joy),
}

impl InputKind {
    /// The ROS 2 type of the topic, `pkg/msg/Type`.
    pub fn type_name(&self) -> String {
        use InputKind::*;
        match self {
            ServoJp | MoveJp | JawServoJp | JawMoveJp | JawServoJf | MirrorJs | MirrorJaw
            | MtmGripper | ServoJr | MoveJr | ServoJf => JointState::type_name(),
            ServoCp | MoveCp | MtmCp => PoseStamped::type_name(),
            Hold | Free => Empty::type_name(),
            StateCommand => StringStamped::type_name(),
            ServoCf | SpatialServoCf => WrenchStamped::type_name(),
            GravityCompensation | CfOrientationAbsolute | EmulateToolPresent => Bool::type_name(),
            TrajectoryRatio => Float64::type_name(),
            Clutch | OperatorPresent => Joy::type_name(),
        }
    }

    /// Decodes a CDR payload (with its encapsulation header) of this topic's type.
    pub fn decode(&self, cdr: &[u8]) -> Result<InputMessage, CdrError> {
        use InputKind::*;
        Ok(match self {
            ServoJp | MoveJp | JawServoJp | JawMoveJp | JawServoJf | MirrorJs | MirrorJaw
            | MtmGripper | ServoJr | MoveJr | ServoJf => InputMessage::Joints(from_cdr(cdr)?),
            ServoCp | MoveCp | MtmCp => InputMessage::Pose(from_cdr(cdr)?),
            Hold | Free => InputMessage::Empty(Empty {}),
            StateCommand => InputMessage::Command(from_cdr(cdr)?),
            ServoCf | SpatialServoCf => InputMessage::Wrench(from_cdr(cdr)?),
            GravityCompensation | CfOrientationAbsolute | EmulateToolPresent => {
                InputMessage::Flag(from_cdr(cdr)?)
            }
            TrajectoryRatio => InputMessage::Number(from_cdr(cdr)?),
            Clutch | OperatorPresent => InputMessage::Joy(from_cdr(cdr)?),
        })
    }
}

/// Most values an input array may hold: a PSM has six joints and its jaw one, an MTM seven
/// and its gripper one, a Joy a few buttons. Anything longer cannot be a command the arms
/// take, and is dropped on receipt.
pub const MAX_INPUT_VALUES: usize = 16;

/// Most bytes of a name (a joint name, a frame id) or a state command in an input message:
/// ROS names are short; a megabyte name is an attack or a bug.
pub const MAX_INPUT_NAME_BYTES: usize = 256;

impl InputMessage {
    /// Why the message is too large to be a command (an array longer than
    /// [`MAX_INPUT_VALUES`], a string longer than [`MAX_INPUT_NAME_BYTES`]), stating the size
    /// and nothing of the content; `None` when it is within bounds. Checked on receipt, before
    /// the message is recorded, converted or quoted in a log line.
    pub fn oversize(&self) -> Option<String> {
        let arrays: Vec<(&str, usize)>;
        let mut strings: Vec<(&str, usize)> = Vec::new();
        match self {
            InputMessage::Joints(m) => {
                arrays = vec![
                    ("name", m.name.len()),
                    ("position", m.position.len()),
                    ("velocity", m.velocity.len()),
                    ("effort", m.effort.len()),
                ];
                strings.push(("frame_id", m.header.frame_id.len()));
                let longest = m.name.iter().map(String::len).max().unwrap_or(0);
                strings.push(("a joint name", longest));
            }
            InputMessage::Pose(m) => {
                arrays = vec![];
                strings.push(("frame_id", m.header.frame_id.len()));
            }
            InputMessage::Command(m) => {
                arrays = vec![];
                strings.push(("frame_id", m.header.frame_id.len()));
                strings.push(("the command", m.string.len()));
            }
            InputMessage::Wrench(m) => {
                arrays = vec![];
                strings.push(("frame_id", m.header.frame_id.len()));
            }
            InputMessage::Joy(m) => {
                arrays = vec![("axes", m.axes.len()), ("buttons", m.buttons.len())];
                strings.push(("frame_id", m.header.frame_id.len()));
            }
            InputMessage::Empty(_) | InputMessage::Flag(_) | InputMessage::Number(_) => {
                return None
            }
        }
        if let Some((field, n)) = arrays.iter().find(|(_, n)| *n > MAX_INPUT_VALUES) {
            return Some(format!(
                "{field} has {n} values, at most {MAX_INPUT_VALUES} are taken"
            ));
        }
        strings
            .iter()
            .find(|(_, n)| *n > MAX_INPUT_NAME_BYTES)
            .map(|(field, n)| {
                format!("{field} is {n} bytes long, at most {MAX_INPUT_NAME_BYTES} are taken")
            })
    }

    /// The message as ROS 2 serializes it.
    pub fn to_cdr(&self) -> Result<Vec<u8>, CdrError> {
        match self {
            InputMessage::Joints(m) => to_cdr(m),
            InputMessage::Pose(m) => to_cdr(m),
            InputMessage::Empty(m) => to_cdr(m),
            InputMessage::Command(m) => to_cdr(m),
            InputMessage::Wrench(m) => to_cdr(m),
            InputMessage::Flag(m) => to_cdr(m),
            InputMessage::Number(m) => to_cdr(m),
            InputMessage::Joy(m) => to_cdr(m),
        }
    }
}

/// Why a message was rejected before it reached the simulation.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    #[error("Joy without buttons")]
    /// A pedal `Joy` message with no button value.
    JoyWithoutButtons,
    #[error("{kind:?} cannot take {message:?}")]
    /// A message of a type the topic does not carry.
    WrongMessage {
        /// The topic's kind.
        kind: InputKind,
        /// The message received.
        message: Box<InputMessage>,
    },
}

/// One input topic of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct InputTopic {
    /// Absolute topic name.
    pub topic: String,
    /// What the topic is for (and so its message type).
    pub kind: InputKind,
    /// The scene arm it drives (an MTM's topics: the PSM it teleoperates; `None`: the
    /// console's pedals).
    pub arm: Option<usize>,
}

/// Every input topic of `scene` under `namespace`, in a fixed order.
pub fn input_topics(scene: &Scene, namespace: &str) -> Vec<InputTopic> {
    use InputKind::*;
    let name = |relative: &str| {
        if relative.starts_with('/') {
            relative.to_owned()
        } else {
            resolve(namespace, relative)
        }
    };
    let mut out = Vec::new();
    for (index, arm) in scene.arms.iter().enumerate() {
        let n = &arm.name;
        let mut push = |topic: String, kind| {
            out.push(InputTopic {
                topic,
                kind,
                arm: Some(index),
            })
        };
        match arm.mode {
            ArmMode::Simulated => {
                let ecm = arm.kind == crate::robot::ArmKind::Ecm;
                for (suffix, kind) in [
                    ("servo_jp", ServoJp),
                    ("move_jp", MoveJp),
                    ("jaw/servo_jp", JawServoJp),
                    ("jaw/move_jp", JawMoveJp),
                    ("jaw/servo_jf", JawServoJf),
                    ("servo_cp", ServoCp),
                    ("move_cp", MoveCp),
                    ("hold", Hold),
                    ("free", Free),
                    ("state_command", StateCommand),
                    ("body/servo_cf", ServoCf),
                    ("use_gravity_compensation", GravityCompensation),
                    ("servo_jr", ServoJr),
                    ("move_jr", MoveJr),
                    ("servo_jf", ServoJf),
                    ("spatial/servo_cf", SpatialServoCf),
                    ("trajectory_j/set_ratio", TrajectoryRatio),
                    ("body/set_cf_orientation_absolute", CfOrientationAbsolute),
                    ("emulate_tool_present", EmulateToolPresent),
                ] {
                    // The ECM has no jaw; its force commands are answered as a PSM's are
                    // (dVRK's ECM client opens them too).
                    if !(ecm && suffix.starts_with("jaw/")) {
                        push(name(&format!("{n}/{suffix}")), kind);
                    }
                }
            }
            ArmMode::Mirror => {
                let of = arm.mirror_of.clone().unwrap_or_else(|| format!("/{n}"));
                push(name(&format!("{of}/measured_js")), MirrorJs);
                push(name(&format!("{of}/jaw/measured_js")), MirrorJaw);
            }
        }
    }
    // Each MTM drives its PSM; the pedals of the one console (validation makes every pair
    // name the same) engage them all.
    for t in &scene.teleop {
        let arm = scene.arms.iter().position(|a| a.name == t.arm);
        for (relative, kind) in [
            (format!("{}/measured_cp", t.mtm), MtmCp),
            (format!("{}/gripper/measured_js", t.mtm), MtmGripper),
        ] {
            out.push(InputTopic {
                topic: name(&relative),
                kind,
                arm,
            });
        }
    }
    if let Some(t) = scene.teleop.first() {
        for (relative, kind) in [
            (format!("{}/clutch", t.console), Clutch),
            (format!("{}/operator_present", t.console), OperatorPresent),
        ] {
            out.push(InputTopic {
                topic: name(&relative),
                kind,
                arm: None,
            });
        }
    }
    out
}

fn pose_parts(m: &PoseStamped) -> ([f64; 3], [f64; 4]) {
    let p = &m.pose.position;
    let o = &m.pose.orientation;
    ([p.x, p.y, p.z], [o.x, o.y, o.z, o.w])
}

impl InputTopic {
    /// What the message asks of the simulation: `Ok(None)` for a message accepted without
    /// effect (gravity compensation of a kinematic arm), `Err` for one rejected here.
    pub fn to_sim_input(&self, message: InputMessage) -> Result<Option<SimInput>, InputError> {
        use InputKind::*;
        let arm = |topic: &'static str, input: ArmInput| {
            Ok(Some(SimInput::Arm {
                arm: self.arm.unwrap_or(0),
                command: ArmCommand { topic, input },
            }))
        };
        match (self.kind, message) {
            (ServoJp, InputMessage::Joints(m)) => arm(
                "servo_jp",
                ArmInput::ServoJp {
                    names: m.name,
                    positions: m.position,
                },
            ),
            (MoveJp, InputMessage::Joints(m)) => arm(
                "move_jp",
                ArmInput::MoveJp {
                    names: m.name,
                    positions: m.position,
                },
            ),
            (JawServoJp, InputMessage::Joints(m)) => arm(
                "jaw/servo_jp",
                ArmInput::JawServoJp {
                    names: m.name,
                    positions: m.position,
                },
            ),
            (JawMoveJp, InputMessage::Joints(m)) => arm(
                "jaw/move_jp",
                ArmInput::JawMoveJp {
                    names: m.name,
                    positions: m.position,
                },
            ),
            (JawServoJf, InputMessage::Joints(m)) => arm(
                "jaw/servo_jf",
                ArmInput::JawServoJf {
                    names: m.name,
                    efforts: m.effort,
                },
            ),
            (ServoCp, InputMessage::Pose(m)) => {
                let (position, quaternion) = pose_parts(&m);
                arm(
                    "servo_cp",
                    ArmInput::ServoCp {
                        position,
                        quaternion,
                    },
                )
            }
            (MoveCp, InputMessage::Pose(m)) => {
                let (position, quaternion) = pose_parts(&m);
                arm(
                    "move_cp",
                    ArmInput::MoveCp {
                        position,
                        quaternion,
                    },
                )
            }
            (Hold, InputMessage::Empty(_)) => arm("hold", ArmInput::Hold),
            (Free, InputMessage::Empty(_)) => arm("free", ArmInput::Free),
            (StateCommand, InputMessage::Command(m)) => {
                arm("state_command", ArmInput::StateCommand(m.string))
            }
            (ServoCf, InputMessage::Wrench(m)) => {
                let w = m.wrench;
                arm(
                    "body/servo_cf",
                    ArmInput::ServoCf([
                        w.force.x, w.force.y, w.force.z, w.torque.x, w.torque.y, w.torque.z,
                    ]),
                )
            }
            // A kinematic arm has no force control to orient, and its tool is always there.
            (
                GravityCompensation | CfOrientationAbsolute | EmulateToolPresent,
                InputMessage::Flag(_),
            ) => Ok(None),
            (ServoJr, InputMessage::Joints(m)) => arm(
                "servo_jr",
                ArmInput::ServoJr {
                    names: m.name,
                    steps: m.position,
                },
            ),
            (MoveJr, InputMessage::Joints(m)) => arm(
                "move_jr",
                ArmInput::MoveJr {
                    names: m.name,
                    steps: m.position,
                },
            ),
            (ServoJf, InputMessage::Joints(_)) => arm("servo_jf", ArmInput::ForceCommand),
            (SpatialServoCf, InputMessage::Wrench(_)) => {
                arm("spatial/servo_cf", ArmInput::ForceCommand)
            }
            (TrajectoryRatio, InputMessage::Number(m)) => {
                arm("trajectory_j/set_ratio", ArmInput::TrajectoryRatio(m.data))
            }
            (MirrorJs, InputMessage::Joints(m)) => arm(
                "measured_js (mirrored)",
                ArmInput::MirrorJs {
                    names: m.name,
                    positions: m.position,
                },
            ),
            (MirrorJaw, InputMessage::Joints(m)) => arm(
                "jaw/measured_js (mirrored)",
                ArmInput::MirrorJaw {
                    names: m.name,
                    positions: m.position,
                },
            ),
            (MtmCp, InputMessage::Pose(m)) => {
                let (position, quaternion) = pose_parts(&m);
                Ok(Some(SimInput::MtmPose {
                    arm: self.arm.unwrap_or(0),
                    position,
                    quaternion,
                }))
            }
            (MtmGripper, InputMessage::Joints(m)) => Ok(Some(SimInput::MtmGripper {
                arm: self.arm.unwrap_or(0),
                positions: m.position,
            })),
            (Clutch, InputMessage::Joy(m)) => match m.buttons.first() {
                Some(b) => Ok(Some(SimInput::Clutch(*b == 1))),
                None => Err(InputError::JoyWithoutButtons),
            },
            (OperatorPresent, InputMessage::Joy(m)) => match m.buttons.first() {
                Some(b) => Ok(Some(SimInput::OperatorPresent(*b == 1))),
                None => Err(InputError::JoyWithoutButtons),
            },
            (kind, message) => Err(InputError::WrongMessage {
                kind,
                message: Box::new(message),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn oversized_inputs_are_named_by_size_not_content() {
        let huge = InputMessage::Joints(JointState {
            position: vec![0.0; 1_000_000],
            ..Default::default()
        });
        let why = huge.oversize().expect("a million positions is too many");
        assert!(why.contains("position has 1000000 values"), "{why}");
        let long_name = InputMessage::Joints(JointState {
            name: vec!["x".repeat(1 << 20)],
            position: vec![0.0],
            ..Default::default()
        });
        let why = long_name.oversize().expect("a 1 MB joint name is too long");
        assert!(
            why.contains("1048576 bytes") && !why.contains("xxx"),
            "{why}"
        );
        let command = InputMessage::Command(StringStamped {
            string: "enable".repeat(100),
            ..Default::default()
        });
        assert!(command.oversize().is_some());
        let psm = InputMessage::Joints(JointState {
            name: crate::robot::psm::PSM_JOINT_NAMES
                .map(String::from)
                .to_vec(),
            position: vec![0.0; 6],
            ..Default::default()
        });
        assert_eq!(psm.oversize(), None);
        let pedals = InputMessage::Joy(Joy {
            buttons: vec![1],
            ..Default::default()
        });
        assert_eq!(pedals.oversize(), None);
    }

    use super::*;

    #[test]
    fn messages_round_trip_through_cdr() {
        let js = InputMessage::Joints(JointState {
            header: Header::new(Time::from_secs(1.5), "x"),
            name: vec!["a".into()],
            position: vec![0.25],
            velocity: vec![],
            effort: vec![],
        });
        let bytes = js.to_cdr().unwrap();
        assert_eq!(&bytes[..4], &CDR_LE_HEADER);
        assert_eq!(InputKind::ServoJp.decode(&bytes).unwrap(), js);
        // std_msgs/Empty carries one padding byte, as other ROS 2 implementations send it.
        assert_eq!(InputMessage::Empty(Empty {}).to_cdr().unwrap().len(), 5);
    }
}
