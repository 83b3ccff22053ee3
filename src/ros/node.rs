//! The ROS 2 node: topics, QoS and wiring between DDS (ros2-client + RustDDS, no ROS
//! installation) and the simulation thread.
//!
//! One tokio task polls every subscription, turns messages into [`SimInput`]s (latest values;
//! the simulation validates them), and publishes from the newest [`Frame`] at each output's
//! rate. Stamps are simulated time throughout.

use std::path::Path;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::{Duration, Instant};

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use ros2_client::{
    qos::{Durability, History, Reliability, WhenFull},
    Context, ContextOptions, MessageTypeName, Name, Node, NodeName, NodeOptions, Publisher,
    QosProfile, Subscription,
};

use crate::config::{ArmMode, Scene};
use crate::output::snapshot::SnapshotSchedule;
use crate::output::{CloudOptions, TissueSurface, CLOUD_POINT_STEP};
use crate::robot::{Psm, Teleop, TeleopConfig};
use crate::ros::arm::{ArmCommand, ArmEvent, ArmInput, ArmSim};
use crate::ros::msgs::*;
use crate::ros::sim_thread::{
    self, Frame, RateLimitedLog, SimHandle, SimInput, SimSetup, TeleopBinding,
};
use crate::world::World;

#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct NodeError(pub String);

fn err(what: &str, e: impl std::fmt::Debug) -> NodeError {
    NodeError(format!("{what}: {e:?}"))
}

/// Node identity on the ROS graph.
#[derive(Clone, Debug)]
pub struct NodeSettings {
    pub name: String,
    /// Absolute namespace (`/` for none); every topic but `/tf` lives under it.
    pub namespace: String,
    /// Stop after this much simulated time (s); `None` runs until Ctrl-C.
    pub seconds: Option<f64>,
    /// Pictures during the run (taken on the simulation thread, which pauses for each).
    pub snapshots: Option<SnapshotSchedule>,
}

/// The world-from-base pose of a scene arm.
pub fn arm_base(arm: &crate::config::Arm) -> Isometry3<f64> {
    let [r, p, y] = arm.base_rpy_deg.map(f64::to_radians);
    Isometry3::from_parts(
        Translation3::from(Vector3::from(arm.base_xyz)),
        UnitQuaternion::from_euler_angles(r, p, y),
    )
}

/// Loads an arm's PSM: its URDF file, or the built-in classic PSM when the default path
/// `urdf/psm.urdf` is not found from the working directory.
pub fn load_psm(arm: &crate::config::Arm) -> Result<Psm, NodeError> {
    let path = Path::new(&arm.urdf);
    let psm = if !path.exists() && arm.urdf == "urdf/psm.urdf" {
        Psm::classic(&arm.name)
    } else {
        Psm::from_urdf_file(path, &arm.name)
    };
    psm.map_err(|e| NodeError(format!("arm {}: {e}", arm.name)))
}

/// The simulation side of a scene: world, arms at home, teleop.
pub fn build_setup(scene: &Scene) -> Result<SimSetup, NodeError> {
    let world = World::new(scene);
    let mut arms = Vec::new();
    let mut arm_tools = Vec::new();
    for arm in &scene.arms {
        let psm = load_psm(arm)?;
        let sim = ArmSim::new(
            psm,
            arm.mode,
            arm_base(arm),
            &arm.home_joints,
            arm.home_jaw_deg.to_radians(),
        )
        .map_err(|e| NodeError(format!("arm {}: {e}", arm.name)))?;
        arms.push(sim);
        let tool = scene
            .tools
            .iter()
            .position(|t| t.name == arm.tool)
            .ok_or_else(|| NodeError(format!("arm {}: no tool {}", arm.name, arm.tool)))?;
        arm_tools.push(tool);
    }
    let teleop = match &scene.teleop {
        None => None,
        Some(t) => {
            let arm = scene
                .arms
                .iter()
                .position(|a| a.name == t.arm)
                .ok_or_else(|| NodeError(format!("teleop.arm {} is not an arm", t.arm)))?;
            let mut config = TeleopConfig::for_psm(arms[arm].psm());
            config.scale = t.scale;
            let mut teleop = Teleop::new(config).map_err(|e| err("teleop", e))?;
            teleop.set_operator_present(t.operator_present);
            Some(TeleopBinding { arm, teleop })
        }
    };
    let outputs = &scene.outputs;
    let surface = TissueSurface::new(
        outputs.surface,
        world.particles(),
        scene.domain.dx as f32,
        outputs.points_scalar,
    )
    .map_err(|e| err("tissue surface", e))?;
    Ok(SimSetup {
        world,
        arms,
        arm_tools,
        teleop,
        cloud: CloudOptions {
            measure: outputs.points_scalar,
            stride: outputs.points_downsample.max(1) as usize,
            voxel: outputs.points_voxel as f32,
        },
        surface,
        snapshots: None,
    })
}

/// Absolute topic name of `relative` under `namespace`.
pub fn resolve(namespace: &str, relative: &str) -> String {
    let relative = relative.trim_start_matches('/');
    if namespace == "/" || namespace.is_empty() {
        format!("/{relative}")
    } else {
        format!("{}/{relative}", namespace.trim_end_matches('/'))
    }
}

fn periodic_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability(Reliability::Reliable {
            when_full: WhenFull::Wait(Duration::from_millis(5)),
        })
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 5 })
}

fn event_qos() -> QosProfile {
    QosProfile::publisher_default()
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 100 })
}

fn command_qos() -> QosProfile {
    QosProfile::publisher_default()
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
}

struct Topics<'a> {
    node: &'a mut Node,
    namespace: String,
}

impl Topics<'_> {
    fn name(&self, topic: &str) -> Result<Name, NodeError> {
        let full = if topic.starts_with('/') {
            topic.to_owned()
        } else {
            resolve(&self.namespace, topic)
        };
        Name::parse(&full).map_err(|e| err(&format!("topic name {full}"), e))
    }

    fn publisher<M: RosMessage>(
        &mut self,
        topic: &str,
        qos: QosProfile,
    ) -> Result<Publisher<M>, NodeError> {
        let name = self.name(topic)?;
        let t = self
            .node
            .create_topic(&name, MessageTypeName::new(M::PACKAGE, M::NAME), &qos)
            .map_err(|e| err(topic, e))?;
        self.node
            .create_publisher(&t, Some(qos))
            .map_err(|e| err(topic, e))
    }

    fn subscription<M: RosMessage>(
        &mut self,
        topic: &str,
    ) -> Result<(String, Subscription<M>), NodeError> {
        let qos = command_qos();
        let name = self.name(topic)?;
        let t = self
            .node
            .create_topic(&name, MessageTypeName::new(M::PACKAGE, M::NAME), &qos)
            .map_err(|e| err(topic, e))?;
        let s = self
            .node
            .create_subscription(&t, Some(qos))
            .map_err(|e| err(topic, e))?;
        Ok((topic.to_owned(), s))
    }
}

/// Publishers of a simulated arm.
struct ArmPublishers {
    measured_js: Publisher<JointState>,
    setpoint_js: Publisher<JointState>,
    measured_cp: Publisher<PoseStamped>,
    setpoint_cp: Publisher<PoseStamped>,
    measured_cv: Publisher<TwistStamped>,
    jaw_measured_js: Publisher<JointState>,
    jaw_setpoint_js: Publisher<JointState>,
    operating_state: Publisher<OperatingState>,
    error: Publisher<StringMsg>,
    warning: Publisher<StringMsg>,
    status: Publisher<StringMsg>,
    last_state_stamp: Time,
}

/// Subscriptions of a simulated arm.
struct ArmSubscriptions {
    servo_jp: (String, Subscription<JointState>),
    move_jp: (String, Subscription<JointState>),
    jaw_servo_jp: (String, Subscription<JointState>),
    jaw_move_jp: (String, Subscription<JointState>),
    servo_cp: (String, Subscription<PoseStamped>),
    move_cp: (String, Subscription<PoseStamped>),
    hold: (String, Subscription<Empty>),
    free: (String, Subscription<Empty>),
    state_command: (String, Subscription<StringStamped>),
    servo_cf: (String, Subscription<WrenchStamped>),
    gravity: (String, Subscription<Bool>),
}

struct MirrorSubscriptions {
    measured_js: (String, Subscription<JointState>),
    jaw_measured_js: (String, Subscription<JointState>),
}

struct ArmIo {
    name: String,
    base_frame: String,
    psm: Psm,
    base: Isometry3<f64>,
    publishers: Option<ArmPublishers>,
    subscriptions: Option<ArmSubscriptions>,
    mirror: Option<MirrorSubscriptions>,
}

struct TeleopIo {
    mtm_cp: (String, Subscription<PoseStamped>),
    gripper: (String, Subscription<JointState>),
    clutch: (String, Subscription<Joy>),
    operator_present: (String, Subscription<Joy>),
    force: Option<(Publisher<WrenchStamped>, f64, usize)>,
}

/// Sends the next output of one kind when its period (wall clock) has passed.
struct Rate {
    period: Option<Duration>,
    next: Instant,
}

impl Rate {
    fn new(hz: f64) -> Rate {
        Rate {
            period: (hz > 0.0).then(|| Duration::from_secs_f64(1.0 / hz)),
            next: Instant::now(),
        }
    }

    fn due(&mut self, now: Instant) -> bool {
        let Some(period) = self.period else {
            return false;
        };
        if now < self.next {
            return false;
        }
        self.next += period;
        if self.next < now {
            self.next = now + period;
        }
        true
    }
}

/// Drains a subscription, handing each message to `f`; malformed samples are logged.
fn drain<M: RosMessage>(
    sub: &(String, Subscription<M>),
    log: &mut RateLimitedLog,
    mut f: impl FnMut(M),
) {
    loop {
        match sub.1.take() {
            Ok(Some((msg, _info))) => f(msg),
            Ok(None) => break,
            Err(e) => {
                if let Some(line) = log.admit(
                    &sub.0,
                    &format!("{}: rejected: unreadable message: {e:?}", sub.0),
                ) {
                    tracing::warn!("{line}");
                }
                break;
            }
        }
    }
}

fn joint_state(stamp: Time, names: &[&str], position: &[f64], velocity: &[f64]) -> JointState {
    JointState {
        header: Header::new(stamp, ""),
        name: names.iter().map(|s| s.to_string()).collect(),
        position: position.to_vec(),
        velocity: velocity.to_vec(),
        effort: Vec::new(),
    }
}

fn pose_input(msg: &PoseStamped) -> ([f64; 3], [f64; 4]) {
    let p = &msg.pose.position;
    let o = &msg.pose.orientation;
    ([p.x, p.y, p.z], [o.x, o.y, o.z, o.w])
}

fn pressed(joy: &Joy) -> Option<bool> {
    joy.buttons.first().map(|b| *b == 1)
}

/// The DDS domain from `ROS_DOMAIN_ID` (0 when unset), as every ROS 2 node reads it.
pub fn domain_id_from_env() -> Result<u16, NodeError> {
    match std::env::var("ROS_DOMAIN_ID") {
        Err(_) => Ok(0),
        Ok(v) if v.trim().is_empty() => Ok(0),
        Ok(v) => match v.trim().parse::<u16>() {
            Ok(id) if id <= 232 => Ok(id),
            _ => Err(NodeError(format!(
                "ROS_DOMAIN_ID = {v:?}: expected an integer from 0 to 232"
            ))),
        },
    }
}

/// Runs the node on `scene` until Ctrl-C (or `settings.seconds` of simulated time).
pub fn run_node(scene: &Scene, settings: &NodeSettings) -> Result<(), NodeError> {
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| err("tokio runtime", e))?;
    runtime.block_on(run_async(scene, settings))
}

async fn run_async(scene: &Scene, settings: &NodeSettings) -> Result<(), NodeError> {
    // Everything that can fail on user input fails before a DDS participant exists.
    let node_name = NodeName::new(&settings.namespace, &settings.name)
        .map_err(|e| err("node name / namespace", e))?;
    let domain_id = domain_id_from_env()?;
    let mut setup = build_setup(scene)?;
    setup.snapshots = settings.snapshots.clone();
    let context = Context::with_options(ContextOptions::new().domain_id(domain_id))
        .map_err(|e| err("DDS participant", e))?;
    let mut node = context
        .new_node(node_name, NodeOptions::new().enable_rosout(true))
        .map_err(|e| err("node", e))?;
    let spinner = node.spinner().map_err(|e| err("spinner", e))?;

    let mut topics = Topics {
        node: &mut node,
        namespace: settings.namespace.clone(),
    };
    let mut arms = Vec::new();
    for (arm, sim) in scene.arms.iter().zip(&setup.arms) {
        let n = &arm.name;
        let (publishers, subscriptions, mirror) = match arm.mode {
            ArmMode::Simulated => {
                let p = ArmPublishers {
                    measured_js: topics.publisher(&format!("{n}/measured_js"), periodic_qos())?,
                    setpoint_js: topics.publisher(&format!("{n}/setpoint_js"), periodic_qos())?,
                    measured_cp: topics.publisher(&format!("{n}/measured_cp"), periodic_qos())?,
                    setpoint_cp: topics.publisher(&format!("{n}/setpoint_cp"), periodic_qos())?,
                    measured_cv: topics.publisher(&format!("{n}/measured_cv"), periodic_qos())?,
                    jaw_measured_js: topics
                        .publisher(&format!("{n}/jaw/measured_js"), periodic_qos())?,
                    jaw_setpoint_js: topics
                        .publisher(&format!("{n}/jaw/setpoint_js"), periodic_qos())?,
                    operating_state: topics
                        .publisher(&format!("{n}/operating_state"), event_qos())?,
                    error: topics.publisher(&format!("{n}/error"), event_qos())?,
                    warning: topics.publisher(&format!("{n}/warning"), event_qos())?,
                    status: topics.publisher(&format!("{n}/status"), event_qos())?,
                    last_state_stamp: Time::default(),
                };
                let s = ArmSubscriptions {
                    servo_jp: topics.subscription(&format!("{n}/servo_jp"))?,
                    move_jp: topics.subscription(&format!("{n}/move_jp"))?,
                    jaw_servo_jp: topics.subscription(&format!("{n}/jaw/servo_jp"))?,
                    jaw_move_jp: topics.subscription(&format!("{n}/jaw/move_jp"))?,
                    servo_cp: topics.subscription(&format!("{n}/servo_cp"))?,
                    move_cp: topics.subscription(&format!("{n}/move_cp"))?,
                    hold: topics.subscription(&format!("{n}/hold"))?,
                    free: topics.subscription(&format!("{n}/free"))?,
                    state_command: topics.subscription(&format!("{n}/state_command"))?,
                    servo_cf: topics.subscription(&format!("{n}/body/servo_cf"))?,
                    gravity: topics.subscription(&format!("{n}/use_gravity_compensation"))?,
                };
                (Some(p), Some(s), None)
            }
            ArmMode::Mirror => {
                let of = arm.mirror_of.clone().unwrap_or_else(|| format!("/{n}"));
                let m = MirrorSubscriptions {
                    measured_js: topics.subscription(&format!("{of}/measured_js"))?,
                    jaw_measured_js: topics.subscription(&format!("{of}/jaw/measured_js"))?,
                };
                (None, None, Some(m))
            }
        };
        arms.push(ArmIo {
            name: n.clone(),
            base_frame: sim.psm().base_frame().to_owned(),
            psm: sim.psm().clone(),
            base: *sim.base(),
            publishers,
            subscriptions,
            mirror,
        });
    }
    let teleop = match &scene.teleop {
        None => None,
        Some(t) => {
            let arm = scene.arms.iter().position(|a| a.name == t.arm).unwrap_or(0);
            let tool = setup.arm_tools.get(arm).copied().unwrap_or(0);
            Some(TeleopIo {
                mtm_cp: topics.subscription(&format!("{}/measured_cp", t.mtm))?,
                gripper: topics.subscription(&format!("{}/gripper/measured_js", t.mtm))?,
                clutch: topics.subscription(&format!("{}/clutch", t.console))?,
                operator_present: topics
                    .subscription(&format!("{}/operator_present", t.console))?,
                force: if t.force_feedback {
                    Some((
                        topics.publisher(&format!("{}/body/servo_cf", t.mtm), periodic_qos())?,
                        t.force_feedback_scale,
                        tool,
                    ))
                } else {
                    None
                },
            })
        }
    };
    let points: Publisher<PointCloud2> = topics.publisher("tissue/points", periodic_qos())?;
    let surface: Publisher<Marker> = topics.publisher("tissue/surface", periodic_qos())?;
    let mut wrenches: Vec<Publisher<WrenchStamped>> = Vec::new();
    for tool in &scene.tools {
        wrenches.push(topics.publisher(&format!("tools/{}/wrench", tool.name), periodic_qos())?);
    }
    let tf: Publisher<TFMessage> = topics.publisher("/tf", periodic_qos())?;
    drop(topics);

    let mut sim = sim_thread::spawn(setup);
    tracing::info!(
        "node {} in namespace {} up: {} arm(s), {} tool(s), frames at {} Hz",
        settings.name,
        settings.namespace,
        arms.len(),
        scene.tools.len(),
        scene.frame_rate_hz
    );

    let outputs = &scene.outputs;
    let mut io = Io {
        arms,
        points_topic: resolve(&settings.namespace, "tissue/points"),
        surface_topic: resolve(&settings.namespace, "tissue/surface"),
        wrench_topics: scene
            .tools
            .iter()
            .map(|t| resolve(&settings.namespace, &format!("tools/{}/wrench", t.name)))
            .collect(),
        demand: Demand::default(),
        teleop,
        points,
        surface,
        wrenches,
        tf,
        log: RateLimitedLog::default(),
        rates: Rates {
            arm: Rate::new(outputs.arm_rate_hz),
            points: Rate::new(outputs.points_rate_hz),
            surface: Rate::new(outputs.surface_rate_hz),
            wrench: Rate::new(outputs.wrench_rate_hz),
            tf: Rate::new(outputs.tf_rate_hz),
            demand: Rate::new(10.0),
        },
    };
    let main = async {
        let mut tick = tokio::time::interval(Duration::from_millis(2));
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        let ctrl_c = tokio::signal::ctrl_c();
        tokio::pin!(ctrl_c);
        loop {
            tokio::select! {
                _ = &mut ctrl_c => {
                    tracing::info!("Ctrl-C: shutting down");
                    break;
                }
                _ = tick.tick() => {}
            }
            io.poll_inputs(&sim);
            io.publish_events(&sim);
            let frame = sim.frames.borrow().clone();
            io.publish_frame(&node, &sim, &frame);
            if let Some(limit) = settings.seconds {
                if frame.time >= limit {
                    break;
                }
            }
        }
    };
    tokio::select! {
        r = spinner.spin() => {
            if let Err(e) = r {
                tracing::error!("ROS spinner stopped: {e:?}");
            }
        }
        _ = main => {}
    }
    sim.shutdown();
    Ok(())
}

struct Rates {
    arm: Rate,
    points: Rate,
    surface: Rate,
    wrench: Rate,
    tf: Rate,
    demand: Rate,
}

/// Which outputs have subscribers (refreshed a few times a second).
#[derive(Default)]
struct Demand {
    points: bool,
    surface: bool,
    tf: bool,
    wrenches: Vec<bool>,
}

struct Io {
    arms: Vec<ArmIo>,
    /// Absolute names of the output topics, for subscriber counts.
    points_topic: String,
    surface_topic: String,
    wrench_topics: Vec<String>,
    demand: Demand,
    teleop: Option<TeleopIo>,
    points: Publisher<PointCloud2>,
    surface: Publisher<Marker>,
    wrenches: Vec<Publisher<WrenchStamped>>,
    tf: Publisher<TFMessage>,
    log: RateLimitedLog,
    rates: Rates,
}

impl Io {
    fn send(&mut self, sim: &SimHandle, input: SimInput) {
        if !sim.send(input) {
            if let Some(line) = self
                .log
                .admit("inputs", "input queue full: dropping commands")
            {
                tracing::warn!("{line}");
            }
        }
    }

    fn poll_inputs(&mut self, sim: &SimHandle) {
        let mut inputs = Vec::new();
        for (index, arm) in self.arms.iter().enumerate() {
            let mut push = |topic: &'static str, input: ArmInput| {
                inputs.push(SimInput::Arm {
                    arm: index,
                    command: ArmCommand { topic, input },
                })
            };
            if let Some(s) = &arm.subscriptions {
                let log = &mut self.log;
                drain(&s.servo_jp, log, |m| {
                    push(
                        "servo_jp",
                        ArmInput::ServoJp {
                            names: m.name,
                            positions: m.position,
                        },
                    )
                });
                drain(&s.move_jp, log, |m| {
                    push(
                        "move_jp",
                        ArmInput::MoveJp {
                            names: m.name,
                            positions: m.position,
                        },
                    )
                });
                drain(&s.jaw_servo_jp, log, |m| {
                    push(
                        "jaw/servo_jp",
                        ArmInput::JawServoJp {
                            names: m.name,
                            positions: m.position,
                        },
                    )
                });
                drain(&s.jaw_move_jp, log, |m| {
                    push(
                        "jaw/move_jp",
                        ArmInput::JawMoveJp {
                            names: m.name,
                            positions: m.position,
                        },
                    )
                });
                drain(&s.servo_cp, log, |m| {
                    let (position, quaternion) = pose_input(&m);
                    push(
                        "servo_cp",
                        ArmInput::ServoCp {
                            position,
                            quaternion,
                        },
                    )
                });
                drain(&s.move_cp, log, |m| {
                    let (position, quaternion) = pose_input(&m);
                    push(
                        "move_cp",
                        ArmInput::MoveCp {
                            position,
                            quaternion,
                        },
                    )
                });
                drain(&s.hold, log, |_| push("hold", ArmInput::Hold));
                drain(&s.free, log, |_| push("free", ArmInput::Free));
                drain(&s.state_command, log, |m| {
                    push("state_command", ArmInput::StateCommand(m.string))
                });
                drain(&s.servo_cf, log, |m| {
                    let w = m.wrench;
                    push(
                        "body/servo_cf",
                        ArmInput::ServoCf([
                            w.force.x, w.force.y, w.force.z, w.torque.x, w.torque.y, w.torque.z,
                        ]),
                    )
                });
                drain(&s.gravity, log, |_| {});
            }
            if let Some(m) = &arm.mirror {
                let log = &mut self.log;
                drain(&m.measured_js, log, |m| {
                    push(
                        "measured_js (mirrored)",
                        ArmInput::MirrorJs {
                            names: m.name,
                            positions: m.position,
                        },
                    )
                });
                drain(&m.jaw_measured_js, log, |m| {
                    push(
                        "jaw/measured_js (mirrored)",
                        ArmInput::MirrorJaw {
                            names: m.name,
                            positions: m.position,
                        },
                    )
                });
            }
        }
        if let Some(t) = &self.teleop {
            let log = &mut self.log;
            drain(&t.mtm_cp, log, |m| {
                let (position, quaternion) = pose_input(&m);
                inputs.push(SimInput::MtmPose {
                    position,
                    quaternion,
                })
            });
            drain(&t.gripper, log, |m| {
                inputs.push(SimInput::MtmGripper(m.position))
            });
            let mut bad_joy = Vec::new();
            drain(&t.clutch, log, |m| match pressed(&m) {
                Some(p) => inputs.push(SimInput::Clutch(p)),
                None => bad_joy.push(t.clutch.0.clone()),
            });
            drain(&t.operator_present, log, |m| match pressed(&m) {
                Some(p) => inputs.push(SimInput::OperatorPresent(p)),
                None => bad_joy.push(t.operator_present.0.clone()),
            });
            for topic in bad_joy {
                if let Some(line) =
                    log.admit(&topic, &format!("{topic}: rejected: Joy without buttons"))
                {
                    tracing::warn!("{line}");
                }
            }
        }
        for input in inputs {
            self.send(sim, input);
        }
    }

    fn publish_events(&mut self, sim: &SimHandle) {
        while let Ok((index, event)) = sim.events.try_recv() {
            let Some(p) = self.arms.get_mut(index).and_then(|a| a.publishers.as_mut()) else {
                continue;
            };
            let text = |s: String| StringMsg { data: s };
            let _ = match event {
                ArmEvent::State {
                    time,
                    state,
                    homed,
                    busy,
                } => {
                    // Strictly increasing stamps: clients drop states not newer than the last.
                    let mut stamp = Time::from_secs(time);
                    if stamp <= p.last_state_stamp {
                        stamp = Time::from_secs(p.last_state_stamp.as_secs() + 1e-6);
                    }
                    p.last_state_stamp = stamp;
                    p.operating_state
                        .publish(OperatingState {
                            header: Header::new(stamp, ""),
                            state: state.as_str().to_owned(),
                            is_homed: homed,
                            is_busy: busy,
                        })
                        .map_err(|_| ())
                }
                ArmEvent::Error(s) => p.error.publish(text(s)).map_err(|_| ()),
                ArmEvent::Warning(s) => p.warning.publish(text(s)).map_err(|_| ()),
                ArmEvent::Status(s) => p.status.publish(text(s)).map_err(|_| ()),
            };
        }
    }

    fn publish_frame(&mut self, node: &Node, sim: &SimHandle, frame: &Arc<Frame>) {
        let now = Instant::now();
        let stamp = Time::from_secs(frame.time);
        if self.rates.demand.due(now) {
            self.demand = Demand {
                points: node.subscription_count(&self.points_topic) > 0,
                surface: node.subscription_count(&self.surface_topic) > 0,
                tf: node.subscription_count("/tf") > 0,
                wrenches: self
                    .wrench_topics
                    .iter()
                    .map(|t| node.subscription_count(t) > 0)
                    .collect(),
            };
            sim.points_wanted
                .store(self.demand.points, Ordering::Relaxed);
            sim.surface_wanted
                .store(self.demand.surface, Ordering::Relaxed);
        }
        if self.rates.arm.due(now) {
            self.publish_arms(frame, stamp);
        }
        if self.rates.wrench.due(now) {
            for ((publisher, tool), wanted) in self
                .wrenches
                .iter()
                .zip(&frame.tools)
                .zip(&self.demand.wrenches)
            {
                if !wanted {
                    continue;
                }
                let _ = publisher.publish(WrenchStamped {
                    header: Header::new(stamp, &tool.frame_id),
                    wrench: Wrench {
                        force: tool.wrench.force.into(),
                        torque: tool.wrench.torque.into(),
                    },
                });
            }
        }
        if self.rates.tf.due(now) && self.demand.tf {
            self.publish_tf(frame, stamp);
        }
        if self.rates.points.due(now) && self.demand.points {
            if let Some(t) = &frame.cloud {
                let field = |name: &str, offset: u32| PointField {
                    name: name.into(),
                    offset,
                    datatype: PointField::FLOAT32,
                    count: 1,
                };
                let _ = self.points.publish(PointCloud2 {
                    header: Header::new(stamp, "world"),
                    height: 1,
                    width: t.len() as u32,
                    fields: vec![
                        field("x", 0),
                        field("y", 4),
                        field("z", 8),
                        field(t.scalar_name(), 12),
                    ],
                    is_bigendian: false,
                    point_step: CLOUD_POINT_STEP as u32,
                    row_step: (CLOUD_POINT_STEP * t.len()) as u32,
                    data: t.cloud_bytes(),
                    is_dense: true,
                });
            }
        }
        if self.rates.surface.due(now) && self.demand.surface {
            if let Some(t) = &frame.surface {
                let point = |p: &[f32; 3]| Point {
                    x: p[0] as f64,
                    y: p[1] as f64,
                    z: p[2] as f64,
                };
                let _ = self.surface.publish(Marker {
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
                });
            }
        }
    }

    fn publish_arms(&mut self, frame: &Frame, stamp: Time) {
        for (io, status) in self.arms.iter_mut().zip(&frame.arms) {
            let Some(p) = &io.publishers else {
                continue;
            };
            let names = io.psm.joints().names();
            let js = joint_state(stamp, &names, &status.q, &status.qdot);
            let _ = p.measured_js.publish(js.clone());
            let _ = p.setpoint_js.publish(js);
            let jaw = joint_state(stamp, &["jaw"], &[status.jaw], &[status.jaw_rate]);
            let _ = p.jaw_measured_js.publish(jaw.clone());
            let _ = p.jaw_setpoint_js.publish(jaw);
            let pose = Pose::from_isometry(&status.cp);
            let _ = p.measured_cp.publish(PoseStamped {
                header: Header::new(stamp, &io.base_frame),
                pose,
            });
            let _ = p.setpoint_cp.publish(PoseStamped {
                header: Header::new(stamp, &io.base_frame),
                pose,
            });
            let _ = p.measured_cv.publish(TwistStamped {
                header: Header::new(stamp, &io.base_frame),
                twist: Twist {
                    linear: status.linear_velocity.into(),
                    angular: status.angular_velocity.into(),
                },
            });
        }
        if let Some(t) = &self.teleop {
            if let Some((publisher, scale, tool)) = &t.force {
                if let Some(tool) = frame.tools.get(*tool) {
                    let _ = publisher.publish(WrenchStamped {
                        header: Header::new(stamp, &tool.frame_id),
                        wrench: Wrench {
                            force: (tool.wrench.force * *scale).into(),
                            torque: (tool.wrench.torque * *scale).into(),
                        },
                    });
                }
            }
        }
    }

    fn publish_tf(&mut self, frame: &Frame, stamp: Time) {
        let mut transforms = Vec::new();
        let arm_frames: Vec<&str> = self.arms.iter().map(|a| a.name.as_str()).collect();
        for (io, status) in self.arms.iter().zip(&frame.arms) {
            transforms.push(TransformStamped {
                header: Header::new(stamp, "world"),
                child_frame_id: io.base_frame.clone(),
                transform: (&io.base).into(),
            });
            if let Ok(links) = io.psm.link_frames(&status.q, status.jaw) {
                for link in links {
                    if link.link == io.base_frame {
                        continue;
                    }
                    transforms.push(TransformStamped {
                        header: Header::new(stamp, &io.base_frame),
                        child_frame_id: link.link,
                        transform: (&link.pose).into(),
                    });
                }
            }
        }
        for tool in &frame.tools {
            if arm_frames.contains(&tool.frame_id.as_str()) {
                continue;
            }
            let iso =
                Isometry3::from_parts(Translation3::from(tool.pose.position), tool.pose.rotation);
            transforms.push(TransformStamped {
                header: Header::new(stamp, "world"),
                child_frame_id: tool.frame_id.clone(),
                transform: (&iso).into(),
            });
        }
        let _ = self.tf.publish(TFMessage { transforms });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn topics_resolve_under_the_namespace() {
        assert_eq!(resolve("/", "PSM1/measured_js"), "/PSM1/measured_js");
        assert_eq!(resolve("/sim", "tissue/points"), "/sim/tissue/points");
        assert_eq!(resolve("/a/b", "/x"), "/a/b/x");
    }
}
