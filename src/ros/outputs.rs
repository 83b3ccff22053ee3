//! The node's output messages, built from a finished [`Frame`]: what the publishers send and
//! what the recorder writes are the same messages on the same topics. Also the output rates
//! counted in simulated time, which the recorder follows (publishers follow the wall clock).

use nalgebra::{Isometry3, Translation3};

use crate::config::{ArmMode, Scene};
use crate::output::{
    SurfaceTriangles, ThreadState, TissueCloud, CLOUD_POINT_STEP, THREAD_POINT_STEP,
};
use crate::render::CameraRecord;
use crate::robot::{ArmKind, Psm};
use crate::ros::camera;
use crate::ros::msgs::*;
use crate::ros::names::resolve;
use crate::sim::arm::{ArmEvent, ArmStatus};
use crate::sim::{Due, Frame, SimSetup, ToolState};

/// What the outputs need to know about an arm.
#[derive(Clone)]
pub struct ArmOutput {
    /// The arm's name, e.g. `PSM1`: its topics are `<namespace>/<name>/...`.
    pub name: String,
    /// The TF frame of `measured_cp` (the arm's base, RCM, link).
    pub base_frame: String,
    /// The arm's kinematics, for its joint names and link frames.
    pub psm: Psm,
    /// World from `<name>_base`.
    pub base: Isometry3<f64>,
    /// Simulated arms publish their state; mirrored ones publish nothing on the arm's topics.
    pub simulated: bool,
    /// Index of the scene tool a PSM holds (its contact wrench is `measured_cf`); `None`
    /// for the ECM.
    pub tool: Option<usize>,
    /// What `tool_type` reports (see [`crate::config::Arm::tool_type`]); `None` for the
    /// ECM.
    pub tool_type: Option<String>,
    /// The held tool's pose in the arm's tool frame (`[[arm]] tool_xyz`, `tool_rpy_deg`):
    /// its transform on `/tf`.
    pub tool_mount: Isometry3<f64>,
}

/// MTM force feedback: the tool's contact wrench × scale on `<mtm>/body/servo_cf`.
#[derive(Clone, Debug)]
pub struct ForceFeedback {
    /// Absolute topic of the MTM's `body/servo_cf`.
    pub topic: String,
    /// Factor from the tool's contact wrench to the wrench sent (dimensionless).
    pub scale: f64,
    /// Index of the scene tool whose contact wrench is fed back.
    pub tool: usize,
}

/// Output rates (Hz; 0 turns an output off).
#[derive(Clone, Copy, Debug)]
pub struct OutputRates {
    /// Arm state topics (`measured_js`, `measured_cp`, ...), Hz.
    pub arm: f64,
    /// Tissue point cloud, Hz.
    pub points: f64,
    /// Tissue surface marker, Hz.
    pub surface: f64,
    /// Tool contact wrenches, Hz.
    pub wrench: f64,
    /// `/tf` (arm links, tools), Hz.
    pub tf: f64,
    /// Suture thread markers, Hz.
    pub thread: f64,
    /// Cut-piece count, Hz.
    pub pieces: f64,
}

/// Every output topic of a scene (absolute names) and what builds its messages.
#[derive(Clone)]
pub struct OutputLayout {
    /// The node's namespace, e.g. `/`; relative topics resolve under it.
    pub namespace: String,
    /// The scene's arms, scene order.
    pub arms: Vec<ArmOutput>,
    /// The scene's tool names, scene order.
    pub tools: Vec<String>,
    /// Suture thread names, scene order.
    pub threads: Vec<String>,
    /// Whether the scene has a `wound`, whose gap `tissue/wound_gap` carries.
    pub wound: bool,
    /// MTM force feedback, for each teleoperation pair that asks for it.
    pub force_feedback: Vec<ForceFeedback>,
    /// How often each output is published.
    pub rates: OutputRates,
    /// Whether `/tf` carries every arm link ([`tf_message`]).
    pub tf_arm_links: bool,
    /// The camera's optical frames, for `/tf_static` (none without a camera).
    pub camera_frames: Vec<TransformStamped>,
    /// What a bag keeps of the camera's pictures (`Off` without a camera).
    pub camera_record: CameraRecord,
}

impl OutputLayout {
    /// The outputs of `scene` as set up in `setup`, with topics under `namespace`.
    pub fn new(scene: &Scene, setup: &SimSetup, namespace: &str) -> OutputLayout {
        let arms = scene
            .arms
            .iter()
            .zip(&setup.arms)
            .enumerate()
            .map(|(index, (arm, sim))| ArmOutput {
                name: arm.name.clone(),
                base_frame: sim.psm().base_frame().to_owned(),
                psm: sim.psm().clone(),
                base: *sim.base(),
                simulated: arm.mode == ArmMode::Simulated,
                tool: setup.arm_tools.get(index).copied().flatten(),
                tool_type: tool_type(scene, arm),
                tool_mount: *sim.tool_mount(),
            })
            .collect();
        let force_feedback = scene
            .teleop
            .iter()
            .filter(|t| t.force_feedback)
            .map(|t| {
                let arm = scene.arms.iter().position(|a| a.name == t.arm).unwrap_or(0);
                ForceFeedback {
                    topic: resolve(namespace, &format!("{}/body/servo_cf", t.mtm)),
                    scale: t.force_feedback_scale,
                    tool: setup.arm_tools.get(arm).copied().flatten().unwrap_or(0),
                }
            })
            .collect();
        // The camera's optical frames: fixed under the ECM's tool frame where a simulated ECM
        // holds it, else under `world` where the camera is (a run without arms holds it
        // where the ECM's home puts it).
        let ecm = scene
            .arms
            .iter()
            .take(setup.arms.len())
            .find(|a| a.kind == ArmKind::Ecm);
        let camera_frames = setup
            .camera
            .as_ref()
            .map(|rig| {
                let settings = rig.settings();
                let (parent, pose) = match ecm {
                    Some(ecm) => (ecm.name.as_str(), Isometry3::identity()),
                    None => ("world", *rig.pose()),
                };
                camera::optical_frame_transforms(
                    parent,
                    &pose,
                    settings.pinhole(),
                    settings.baseline as f32,
                )
            })
            .unwrap_or_default();
        let o = &scene.outputs;
        OutputLayout {
            namespace: namespace.to_owned(),
            arms,
            tools: scene.tools.iter().map(|t| t.name.clone()).collect(),
            threads: scene.threads.iter().map(|t| t.name.clone()).collect(),
            wound: scene.wound.is_some(),
            force_feedback,
            rates: OutputRates {
                arm: o.arm_rate_hz,
                points: o.points_rate_hz,
                surface: o.surface_rate_hz,
                wrench: o.wrench_rate_hz,
                tf: o.tf_rate_hz,
                thread: o.thread_rate_hz,
                pieces: o.pieces_rate_hz,
            },
            tf_arm_links: o.tf_arm_links,
            camera_frames,
            camera_record: setup
                .camera
                .as_ref()
                .map_or(CameraRecord::Off, |rig| rig.settings().record),
        }
    }

    /// Absolute name of a topic relative to the namespace (`/tf` stays global).
    pub fn topic(&self, relative: &str) -> String {
        if relative.starts_with('/') {
            relative.to_owned()
        } else {
            resolve(&self.namespace, relative)
        }
    }

    /// Every output topic with its type.
    pub fn topics(&self) -> Vec<(String, String)> {
        let mut out = Vec::new();
        for arm in self.arms.iter().filter(|a| a.simulated) {
            let n = &arm.name;
            let jaw: &[&str] = match arm.psm.jaw().is_empty() {
                true => &[],
                false => &["jaw/measured_js", "jaw/setpoint_js"],
            };
            for t in ["measured_js", "setpoint_js"].iter().chain(jaw) {
                out.push((self.topic(&format!("{n}/{t}")), JointState::type_name()));
            }
            for t in ["measured_cp", "setpoint_cp"] {
                out.push((self.topic(&format!("{n}/{t}")), PoseStamped::type_name()));
            }
            out.push((
                self.topic(&format!("{n}/measured_cv")),
                TwistStamped::type_name(),
            ));
            out.push((
                self.topic(&format!("{n}/operating_state")),
                OperatingState::type_name(),
            ));
            for t in ["error", "warning", "status"] {
                out.push((self.topic(&format!("{n}/{t}")), StringMsg::type_name()));
            }
        }
        out.push((self.topic("tissue/points"), PointCloud2::type_name()));
        out.push((self.topic("tissue/surface"), Marker::type_name()));
        for tool in &self.tools {
            out.push((
                self.topic(&format!("tools/{tool}/wrench")),
                WrenchStamped::type_name(),
            ));
        }
        for thread in &self.threads {
            out.push((
                self.topic(&thread_centreline_topic(thread)),
                Marker::type_name(),
            ));
            out.push((
                self.topic(&thread_tension_topic(thread)),
                PointCloud2::type_name(),
            ));
        }
        out.push((self.topic(PIECES_TOPIC), UInt32::type_name()));
        if self.wound {
            out.push((self.topic(WOUND_GAP_TOPIC), Float64::type_name()));
        }
        out.push(("/tf".to_owned(), TFMessage::type_name()));
        out.push(("/tf_static".to_owned(), TFMessage::type_name()));
        for f in &self.force_feedback {
            out.push((f.topic.clone(), WrenchStamped::type_name()));
        }
        out
    }
}

/// `<arm>/tool_type`: the arm's `tool_type`, else dVRK's Large Needle Driver for a gripper,
/// else the held tool's scene name.
fn tool_type(scene: &Scene, arm: &crate::config::Arm) -> Option<String> {
    let held = scene
        .tools
        .iter()
        .find(|t| Some(&t.name) == arm.tool.as_ref())?;
    Some(match (&arm.tool_type, held.shape) {
        (Some(chosen), _) => chosen.clone(),
        (None, crate::tools::Shape::Gripper { .. }) => LARGE_NEEDLE_DRIVER.to_owned(),
        (None, _) => held.name.clone(),
    })
}

/// dVRK's name for the Large Needle Driver, the gripper's default instrument.
pub const LARGE_NEEDLE_DRIVER: &str = "LARGE_NEEDLE_DRIVER:400006";

pub(crate) fn joint_state(
    stamp: Time,
    names: &[&str],
    position: &[f64],
    velocity: &[f64],
) -> JointState {
    JointState {
        header: Header::new(stamp, ""),
        name: names.iter().map(|s| s.to_string()).collect(),
        position: position.to_vec(),
        velocity: velocity.to_vec(),
        effort: Vec::new(),
    }
}

/// A simulated arm's periodic state messages (joints: measured = setpoint; a PSM's jaw: what
/// the tool's jaws reached, with the controller's effort, and the setpoint apart).
pub(crate) struct ArmMessages {
    pub js: JointState,
    pub jaw: Option<JointState>,
    pub jaw_setpoint: Option<JointState>,
    pub cp: PoseStamped,
    pub cv: TwistStamped,
}

pub(crate) fn arm_messages(arm: &ArmOutput, status: &ArmStatus, stamp: Time) -> ArmMessages {
    let names = arm.psm.joints().names();
    let has_jaw = !arm.psm.jaw().is_empty();
    ArmMessages {
        js: joint_state(stamp, &names, &status.q, &status.qdot),
        jaw: has_jaw.then(|| JointState {
            effort: vec![status.jaw_effort],
            ..joint_state(stamp, &["jaw"], &[status.jaw], &[status.jaw_rate])
        }),
        jaw_setpoint: has_jaw.then(|| joint_state(stamp, &["jaw"], &[status.jaw_setpoint], &[])),
        cp: PoseStamped {
            header: Header::new(stamp, &arm.base_frame),
            pose: Pose::from_isometry(&status.cp),
        },
        cv: TwistStamped {
            header: Header::new(stamp, &arm.base_frame),
            twist: Twist {
                linear: status.linear_velocity.into(),
                angular: status.angular_velocity.into(),
            },
        },
    }
}

/// The contact wrench on an arm's tool as dVRK's `body/measured_cf` (in the arm's tool
/// frame) and `spatial/measured_cf` (the same wrench, about the tool, in the base frame's
/// orientation); zero for an arm without a tool (the ECM).
pub fn measured_cf_messages(
    arm: &ArmOutput,
    status: &ArmStatus,
    tool: Option<&ToolState>,
    stamp: Time,
) -> (WrenchStamped, WrenchStamped) {
    let wrench = tool.map(|t| t.wrench).unwrap_or_default();
    let body_frame = tool.map_or(arm.name.as_str(), |t| &t.frame_id);
    let body = wrench_stamped(wrench.force, wrench.torque, body_frame, stamp);
    let r = status.cp.rotation;
    let spatial = wrench_stamped(r * wrench.force, r * wrench.torque, &arm.base_frame, stamp);
    (body, spatial)
}

/// The tool frame's Jacobians as dVRK's `body/jacobian` (twist in the tool frame) and
/// `spatial/jacobian` (twist in the base frame), 6 rows × one column per joint, row-major.
pub fn jacobian_messages(
    arm: &ArmOutput,
    status: &ArmStatus,
) -> Option<(Float64MultiArray, Float64MultiArray)> {
    let spatial = arm.psm.jacobian(&status.q).ok()?;
    let rt = status.cp.rotation.inverse().to_rotation_matrix();
    let mut body = spatial.clone();
    for c in 0..spatial.ncols() {
        let v = rt * spatial.fixed_view::<3, 1>(0, c);
        let w = rt * spatial.fixed_view::<3, 1>(3, c);
        body.fixed_view_mut::<3, 1>(0, c).copy_from(&v);
        body.fixed_view_mut::<3, 1>(3, c).copy_from(&w);
    }
    let array = |m: &nalgebra::Matrix6xX<f64>| {
        let cols = m.ncols() as u32;
        Float64MultiArray {
            layout: MultiArrayLayout {
                dim: vec![
                    MultiArrayDimension {
                        label: "rows".into(),
                        size: 6,
                        stride: 6 * cols,
                    },
                    MultiArrayDimension {
                        label: "columns".into(),
                        size: cols,
                        stride: cols,
                    },
                ],
                data_offset: 0,
            },
            data: (0..6)
                .flat_map(|r| (0..m.ncols()).map(move |c| m[(r, c)]))
                .collect(),
        }
    };
    Some((array(&body), array(&spatial)))
}

/// A tool's contact wrench, in its frame, times `scale`.
pub fn wrench_message(tool: &ToolState, scale: f64, stamp: Time) -> WrenchStamped {
    let w = &tool.wrench;
    wrench_stamped(w.force * scale, w.torque * scale, &tool.frame_id, stamp)
}

/// A force and torque, expressed in `frame`, as a stamped wrench message.
fn wrench_stamped(
    force: nalgebra::Vector3<f64>,
    torque: nalgebra::Vector3<f64>,
    frame: &str,
    stamp: Time,
) -> WrenchStamped {
    WrenchStamped {
        header: Header::new(stamp, frame),
        wrench: Wrench {
            force: force.into(),
            torque: torque.into(),
        },
    }
}

pub(crate) fn cloud_message(cloud: &TissueCloud, stamp: Time) -> PointCloud2 {
    let field = |name: &str, offset: u32| PointField {
        name: name.into(),
        offset,
        datatype: PointField::FLOAT32,
        count: 1,
    };
    PointCloud2 {
        header: Header::new(stamp, "world"),
        height: 1,
        width: cloud.len() as u32,
        fields: vec![
            field("x", 0),
            field("y", 4),
            field("z", 8),
            field(cloud.scalar_name(), 12),
        ],
        is_bigendian: false,
        point_step: CLOUD_POINT_STEP as u32,
        row_step: (CLOUD_POINT_STEP * cloud.len()) as u32,
        data: cloud.cloud_bytes(),
        is_dense: true,
    }
}

pub(crate) fn surface_message(t: &SurfaceTriangles, stamp: Time) -> Marker {
    let point = |p: &[f32; 3]| Point {
        x: p[0] as f64,
        y: p[1] as f64,
        z: p[2] as f64,
    };
    Marker {
        header: Header::new(stamp, "world"),
        ns: "tissue".into(),
        id: 0,
        kind: Marker::TRIANGLE_LIST,
        action: Marker::ADD,
        pose: Pose::default(),
        scale: Vector3Msg {
            x: 1.0,
            y: 1.0,
            z: 1.0,
        },
        color: ColorRGBA {
            r: 0.85,
            g: 0.45,
            b: 0.45,
            a: 1.0,
        },
        points: t.corners.iter().map(point).collect(),
        colors: t
            .colours
            .iter()
            .map(|c| ColorRGBA {
                r: c[0],
                g: c[1],
                b: c[2],
                a: 1.0,
            })
            .collect(),
        uv_coordinates: t
            .uvs
            .iter()
            .map(|uv| UVCoordinate { u: uv[0], v: uv[1] })
            .collect(),
        ..Default::default()
    }
}

/// Topic of the tissue's piece count, relative to the namespace.
pub const PIECES_TOPIC: &str = "tissue/pieces";

/// How many separate pieces the tissue is in.
pub fn pieces_message(pieces: u32) -> UInt32 {
    UInt32 { data: pieces }
}

/// Topic of the wound gap (scenes with a `wound`), relative to the namespace.
pub const WOUND_GAP_TOPIC: &str = "tissue/wound_gap";

/// The wound gap, m.
pub fn wound_gap_message(gap: f64) -> Float64 {
    Float64 { data: gap }
}

/// Topic of a thread's centreline marker, relative to the namespace.
pub fn thread_centreline_topic(thread: &str) -> String {
    format!("threads/{thread}/centreline")
}

/// Topic of a thread's tension cloud, relative to the namespace.
pub fn thread_tension_topic(thread: &str) -> String {
    format!("threads/{thread}/tension")
}

/// A thread's centreline as a LINE_STRIP in `world`, as wide as the thread (drawn at least
/// 0.5 mm wide so that a viewer shows it).
pub fn thread_centreline_message(thread: &ThreadState, stamp: Time) -> Marker {
    Marker {
        header: Header::new(stamp, "world"),
        ns: format!("threads/{}", thread.name),
        id: 0,
        kind: Marker::LINE_STRIP,
        action: Marker::ADD,
        pose: Pose::default(),
        scale: Vector3Msg {
            x: (2.0 * thread.radius as f64).max(5e-4),
            y: 0.0,
            z: 0.0,
        },
        color: ColorRGBA {
            r: 0.35,
            g: 0.2,
            b: 0.75,
            a: 1.0,
        },
        points: thread
            .points
            .iter()
            .map(|p| Point {
                x: p[0] as f64,
                y: p[1] as f64,
                z: p[2] as f64,
            })
            .collect(),
        ..Default::default()
    }
}

/// A thread's points with the axial force there (N), fields x, y, z, tension, in `world`.
pub fn thread_tension_message(thread: &ThreadState, stamp: Time) -> PointCloud2 {
    let field = |name: &str, offset: u32| PointField {
        name: name.into(),
        offset,
        datatype: PointField::FLOAT32,
        count: 1,
    };
    let n = thread.points.len();
    PointCloud2 {
        header: Header::new(stamp, "world"),
        height: 1,
        width: n as u32,
        fields: vec![
            field("x", 0),
            field("y", 4),
            field("z", 8),
            field("tension", 12),
        ],
        is_bigendian: false,
        point_step: THREAD_POINT_STEP as u32,
        row_step: (THREAD_POINT_STEP * n) as u32,
        data: thread.cloud_bytes(),
        is_dense: true,
    }
}

/// `world` → each arm's base, and the camera's optical frames: fixed, sent once on
/// `/tf_static`.
pub fn tf_static_message(layout: &OutputLayout) -> TFMessage {
    TFMessage {
        transforms: layout
            .arms
            .iter()
            .map(|arm| TransformStamped {
                header: Header::new(Time::default(), "world"),
                child_frame_id: arm.base_frame.clone(),
                transform: (&arm.base).into(),
            })
            .chain(layout.camera_frames.iter().cloned())
            .collect(),
    }
}

/// Each arm's base → its links (with `all_links` false only the tool frame and the tool
/// tip, which dVRK's robot_state_publisher does not publish); each held tool under its arm's
/// tool frame, through the mount (`PSM1` → `needle`: where the needle is, not the jaws);
/// scripted tools in `world`.
pub fn tf_message(arms: &[ArmOutput], frame: &Frame, stamp: Time, all_links: bool) -> TFMessage {
    let mut transforms = Vec::new();
    for (arm, status) in arms.iter().zip(&frame.arms) {
        // dvrk_model's own tip link (`<arm>_tool_tip_link`) is robot_state_publisher's.
        let tool_tip = format!("{}_tool_tip", arm.name);
        if let Ok(links) = arm.psm.link_frames(&status.q, status.jaw) {
            for link in links {
                let ours = link.link == arm.name || link.link == tool_tip;
                if link.link == arm.base_frame || !(all_links || ours) {
                    continue;
                }
                transforms.push(TransformStamped {
                    header: Header::new(stamp, &arm.base_frame),
                    child_frame_id: link.link,
                    transform: (&link.pose).into(),
                });
            }
        }
    }
    for tool in &frame.tools {
        let holder = arms.iter().find(|a| a.name == tool.frame_id);
        let (parent, transform) = match holder {
            // The tool frame's name is the arm's; the tool's own frame hangs under it.
            Some(_) if tool.name == tool.frame_id => continue,
            Some(arm) => (arm.name.as_str(), arm.tool_mount),
            None => (
                "world",
                Isometry3::from_parts(Translation3::from(tool.pose.position), tool.pose.rotation),
            ),
        };
        transforms.push(TransformStamped {
            header: Header::new(stamp, parent),
            child_frame_id: tool.name.clone(),
            transform: (&transform).into(),
        });
    }
    TFMessage { transforms }
}

/// A latched arm event as a message on the arm's topic `suffix`.
pub(crate) enum EventMessage {
    State(OperatingState),
    Text {
        suffix: &'static str,
        message: StringMsg,
    },
}

/// Turns arm events into messages; operating states get strictly increasing stamps per arm
/// (clients drop a state not newer than the last).
#[derive(Default)]
pub(crate) struct EventStamps {
    last: Vec<Time>,
}

impl EventStamps {
    pub fn message(&mut self, arm: usize, event: ArmEvent) -> EventMessage {
        let text = |suffix, s: String| EventMessage::Text {
            suffix,
            message: StringMsg { data: s },
        };
        match event {
            ArmEvent::State {
                time,
                state,
                homed,
                busy,
            } => {
                if self.last.len() <= arm {
                    self.last.resize(arm + 1, Time::default());
                }
                let last = &mut self.last[arm];
                let mut stamp = Time::from_secs(time);
                if stamp <= *last {
                    stamp = Time::from_secs(last.as_secs() + 1e-6);
                }
                *last = stamp;
                EventMessage::State(OperatingState {
                    header: Header::new(stamp, ""),
                    state: state.as_str().to_owned(),
                    is_homed: homed,
                    is_busy: busy,
                })
            }
            ArmEvent::Error(s) => text("error", s),
            ArmEvent::Warning(s) => text("warning", s),
            ArmEvent::Status(s) => text("status", s),
        }
    }
}

/// An output rate counted in simulated time: due at the first frame ending at or after each
/// multiple of the period (from one period on), so a recording and its replay sample the same frames.
#[derive(Clone, Debug)]
struct SimRate {
    period: Option<f64>,
    next: f64,
}

impl SimRate {
    fn new(hz: f64) -> SimRate {
        let period = (hz > 0.0).then(|| 1.0 / hz);
        SimRate {
            period,
            next: period.unwrap_or(0.0),
        }
    }

    fn due(&mut self, t: f64) -> bool {
        let Some(period) = self.period else {
            return false;
        };
        if t + 1e-9 < self.next {
            return false;
        }
        self.next += period;
        if self.next <= t + 1e-9 {
            self.next = t + period;
        }
        true
    }
}

/// The output rates in simulated time.
#[derive(Clone, Debug)]
pub(crate) struct SimSchedule {
    arm: SimRate,
    points: SimRate,
    surface: SimRate,
    wrench: SimRate,
    tf: SimRate,
    thread: SimRate,
    pieces: SimRate,
}

impl SimSchedule {
    pub fn new(rates: &OutputRates) -> SimSchedule {
        SimSchedule {
            arm: SimRate::new(rates.arm),
            points: SimRate::new(rates.points),
            surface: SimRate::new(rates.surface),
            wrench: SimRate::new(rates.wrench),
            tf: SimRate::new(rates.tf),
            thread: SimRate::new(rates.thread),
            pieces: SimRate::new(rates.pieces),
        }
    }

    /// The outputs due for the frame ending at `t`; call once per frame, in order.
    pub fn due(&mut self, t: f64) -> Due {
        Due {
            arm: self.arm.due(t),
            points: self.points.due(t),
            surface: self.surface.due(t),
            wrench: self.wrench.due(t),
            tf: self.tf.due(t),
            thread: self.thread.due(t),
            pieces: self.pieces.due(t),
            // Pictures follow the camera's own rate; whoever records asks for them.
            camera: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_in_simulated_time_pick_every_nth_frame() {
        let mut s = SimSchedule::new(&OutputRates {
            arm: 100.0,
            points: 30.0,
            surface: 10.0,
            wrench: 0.0,
            tf: 60.0,
            thread: 30.0,
            pieces: 5.0,
        });
        let (mut arm, mut points, mut surface, mut wrench, mut tf) = (0, 0, 0, 0, 0);
        for k in 1..=60 {
            let d = s.due(k as f64 / 60.0);
            arm += d.arm as u32;
            points += d.points as u32;
            surface += d.surface as u32;
            wrench += d.wrench as u32;
            tf += d.tf as u32;
        }
        assert_eq!((arm, points, surface, wrench, tf), (60, 30, 10, 0, 60));
    }
}
