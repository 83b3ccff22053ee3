//! The ROS 2 node: topics, QoS and wiring between DDS (ros2-client + RustDDS, no ROS
//! installation) and the simulation thread.
//!
//! One tokio task polls every subscription, turns messages into [`SimInput`]s (latest values;
//! the simulation validates them), and publishes from the newest [`Frame`] at each output's
//! rate. Stamps are simulated time throughout. With `--record` a recorder writes the inputs
//! and outputs to an MCAP bag; with `--replay` a bag's inputs drive the arms instead of the
//! input topics.

use std::collections::VecDeque;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::{Duration, Instant};

use ros2_client::log::Log;
use ros2_client::{
    qos::{Durability, History, Reliability, WhenFull},
    MessageTypeName, Name, Node, NodeName, NodeOptions, Publisher, QosProfile, ReadError,
    Subscription,
};

use crate::config::Scene;
use crate::render::CameraImages;
use crate::ros::inputs::{input_topics, InputKind, InputMessage, InputTopic};
use crate::ros::kinematics::KinematicsServices;
use crate::ros::msgs::*;
use crate::ros::names::remap;
use crate::ros::outputs::{self, ArmOutput, EventMessage, EventStamps, OutputLayout};
use crate::ros::parameters::ParameterServices;
use crate::ros::participant::{self, DiscoveryRange};
use crate::ros::rosout::Rosout;
use crate::ros::security;
use crate::ros::session::{finish_recording, prepare, NodeSettings, SessionError};
use crate::ros::sim_clock::SimClock;
use crate::ros::status::{backend_and_adapter, Progress, StatusReport};
use crate::sim::arm::ArmEvent;
use crate::sim::log::RateLimitedLog;
use crate::sim::realtime::{self, SimHandle};
use crate::sim::{Frame, RecordedInput, SimInput};

/// Why the node could not start or ended with an error.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    #[error(transparent)]
    /// The run could not be set up or recorded.
    Session(#[from] SessionError),
    #[error("ROS_DOMAIN_ID = {0:?}: expected an integer from 0 to 232")]
    /// `ROS_DOMAIN_ID` is not an integer from 0 to 232 (holds its value).
    DomainId(String),
    #[error(
        "a node named {node} already runs in this ROS domain (DDS participant {participant}): \
         two nodes with one name would interleave their topics; stop it, or start this one \
         with another --name or --namespace"
    )]
    /// Another participant in the domain already runs a node with this name and namespace.
    NameTaken {
        /// The node's fully qualified name.
        node: String,
        /// The other participant's GID.
        participant: String,
    },
    /// A ROS 2 / DDS call failed; `detail` is the library's own description.
    #[error("{what}: {detail}")]
    Ros {
        /// What the node was doing, e.g. creating a publisher.
        what: String,
        /// The library's error text.
        detail: String,
    },
}

fn err(what: &str, e: impl std::fmt::Debug) -> NodeError {
    NodeError::Ros {
        what: what.to_owned(),
        detail: format!("{e:?}"),
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

/// The status: latched (a late subscriber gets the latest), only the latest kept.
fn status_qos() -> QosProfile {
    QosProfile::publisher_default()
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
}

/// `/tf_static` as tf2's static broadcaster offers it: reliable, transient local, keep last 1.
fn tf_static_qos() -> QosProfile {
    QosProfile::publisher_default()
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
}

fn command_qos() -> QosProfile {
    QosProfile::publisher_default()
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
}

struct Topics<'a> {
    node: &'a mut Node,
    namespace: String,
    remaps: &'a [(String, String)],
}

impl Topics<'_> {
    fn name(&self, topic: &str) -> Result<Name, NodeError> {
        let full = remap(&self.namespace, self.remaps, topic);
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

    fn subscribe<M: RosMessage>(&mut self, topic: &str) -> Result<Subscription<M>, NodeError> {
        let qos = command_qos();
        let name = self.name(topic)?;
        let t = self
            .node
            .create_topic(&name, MessageTypeName::new(M::PACKAGE, M::NAME), &qos)
            .map_err(|e| err(topic, e))?;
        self.node
            .create_subscription(&t, Some(qos))
            .map_err(|e| err(topic, e))
    }

    fn input(&mut self, topic: InputTopic) -> Result<InputSubscription, NodeError> {
        use InputKind::*;
        let name = topic.topic.clone();
        let subscription = match topic.kind {
            ServoJp | MoveJp | JawServoJp | JawMoveJp | JawServoJf | MirrorJs | MirrorJaw
            | MtmGripper | ServoJr | MoveJr | ServoJf => {
                AnySubscription::Joints(self.subscribe(&name)?)
            }
            ServoCp | MoveCp | MtmCp => AnySubscription::Pose(self.subscribe(&name)?),
            Hold | Free => AnySubscription::Empty(self.subscribe(&name)?),
            StateCommand => AnySubscription::Command(self.subscribe(&name)?),
            ServoCf | SpatialServoCf => AnySubscription::Wrench(self.subscribe(&name)?),
            GravityCompensation | CfOrientationAbsolute | EmulateToolPresent => {
                AnySubscription::Flag(self.subscribe(&name)?)
            }
            TrajectoryRatio => AnySubscription::Number(self.subscribe(&name)?),
            Clutch | OperatorPresent => AnySubscription::Joy(self.subscribe(&name)?),
        };
        Ok(InputSubscription {
            topic,
            subscription,
        })
    }
}

/// A subscription of one of the input types.
enum AnySubscription {
    Joints(Subscription<JointState>),
    Pose(Subscription<PoseStamped>),
    Empty(Subscription<Empty>),
    Command(Subscription<StringStamped>),
    Wrench(Subscription<WrenchStamped>),
    Flag(Subscription<Bool>),
    Number(Subscription<Float64>),
    Joy(Subscription<Joy>),
}

impl AnySubscription {
    fn take(&self) -> Result<Option<InputMessage>, ReadError> {
        fn one<M: RosMessage>(
            s: &Subscription<M>,
            wrap: impl FnOnce(M) -> InputMessage,
        ) -> Result<Option<InputMessage>, ReadError> {
            Ok(s.take()?.map(|(m, _info)| wrap(m)))
        }
        match self {
            AnySubscription::Joints(s) => one(s, InputMessage::Joints),
            AnySubscription::Pose(s) => one(s, InputMessage::Pose),
            AnySubscription::Empty(s) => one(s, InputMessage::Empty),
            AnySubscription::Command(s) => one(s, InputMessage::Command),
            AnySubscription::Wrench(s) => one(s, InputMessage::Wrench),
            AnySubscription::Flag(s) => one(s, InputMessage::Flag),
            AnySubscription::Number(s) => one(s, InputMessage::Number),
            AnySubscription::Joy(s) => one(s, InputMessage::Joy),
        }
    }
}

struct InputSubscription {
    topic: InputTopic,
    subscription: AnySubscription,
}

/// Publishers of a simulated arm.
struct ArmPublishers {
    measured_js: Publisher<JointState>,
    setpoint_js: Publisher<JointState>,
    measured_cp: Publisher<PoseStamped>,
    setpoint_cp: Publisher<PoseStamped>,
    measured_cv: Publisher<TwistStamped>,
    /// A PSM's `jaw/measured_js`, `jaw/setpoint_js` (the ECM has no jaw).
    jaw: Option<[Publisher<JointState>; 2]>,
    operating_state: Publisher<OperatingState>,
    error: Publisher<StringMsg>,
    warning: Publisher<StringMsg>,
    status: Publisher<StringMsg>,
    local_measured_cp: Publisher<PoseStamped>,
    local_setpoint_cp: Publisher<PoseStamped>,
    /// `body/measured_cf`, `spatial/measured_cf`: a PSM's tool's contact wrench; zero on the
    /// ECM, whose scope touches nothing in the simulation.
    measured_cf: [Publisher<WrenchStamped>; 2],
    body_jacobian: Publisher<Float64MultiArray>,
    spatial_jacobian: Publisher<Float64MultiArray>,
    /// Latched, sent once: kept alive for late subscribers (a PSM's).
    _tool_type: Option<Publisher<StringMsg>>,
    trajectory_ratio: Publisher<Float64>,
}

struct ArmIo {
    publishers: Option<ArmPublishers>,
    /// The last `trajectory_j/ratio` published.
    ratio: Option<f64>,
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

/// The DDS domain from `ROS_DOMAIN_ID` (0 when unset), as every ROS 2 node reads it.
pub fn domain_id_from_env() -> Result<u16, NodeError> {
    match std::env::var("ROS_DOMAIN_ID") {
        Err(_) => Ok(0),
        Ok(v) if v.trim().is_empty() => Ok(0),
        Ok(v) => match v.trim().parse::<u16>() {
            Ok(id) if id <= 232 => Ok(id),
            _ => Err(NodeError::DomainId(v)),
        },
    }
}

/// Runs the node on `scene` until SIGINT, SIGTERM or SIGHUP (see [`crate::ros::shutdown`]),
/// or `settings.seconds` of simulated time.
pub fn run_node(scene: &Scene, settings: &NodeSettings) -> Result<(), NodeError> {
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| err("tokio runtime", e))?;
    runtime.block_on(run_async(scene, settings))
}

/// Whether [`adopt_wire_distribution`] set `ROS_DISTRO` for this process.
static DISTRO_ADOPTED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// The node needs no ROS installation, so an unset `ROS_DISTRO` is the normal case; ros2-client
/// warns about it whatever the log filter a user sets. Setting the variable to the distribution
/// whose wire format the crate was built for silences that warning and changes nothing else
/// (ros2-client only compares it). Call it at program start, before any thread exists
/// (changing the environment is not thread-safe); a user's own `ROS_DISTRO` is left alone.
pub fn adopt_wire_distribution() {
    if std::env::var_os("ROS_DISTRO").is_none() {
        std::env::set_var("ROS_DISTRO", ros2_client::COMPILED_ROS_DISTRO.as_str());
        DISTRO_ADOPTED.store(true, std::sync::atomic::Ordering::Relaxed);
    }
}

/// Says at info which ROS 2 distribution's wire format the node speaks.
fn log_wire_distribution() {
    let built = ros2_client::COMPILED_ROS_DISTRO;
    if DISTRO_ADOPTED.load(std::sync::atomic::Ordering::Relaxed) {
        tracing::info!(
            "speaking ROS 2 {built} over DDS (no ROS installation needed; ROS_DISTRO was not \
             set and is taken as {built})"
        );
    } else {
        let distro = std::env::var("ROS_DISTRO").unwrap_or_default();
        tracing::info!("speaking ROS 2 {built} over DDS (ROS_DISTRO = {distro})");
    }
}

async fn run_async(scene: &Scene, settings: &NodeSettings) -> Result<(), NodeError> {
    // Everything that can fail on user input fails before a DDS participant exists.
    let node_name = NodeName::new(&settings.namespace, &settings.name)
        .map_err(|e| err("node name / namespace", e))?;
    let domain_id = domain_id_from_env()?;
    let discovery_range = DiscoveryRange::from_env()?;
    let enclave = security::enclave_from_env(&node_name.fully_qualified_name())?;
    let (setup, recorder) = prepare(scene, settings)?;
    let layout = OutputLayout::new(scene, &setup, &settings.namespace);
    log_wire_distribution();
    if let Some(dir) = &enclave {
        tracing::info!("DDS Security on: SROS2 enclave {}", dir.display());
    }
    let context = participant::open(domain_id, discovery_range, enclave.as_deref())?;
    participant::ensure_name_is_free(&context, &node_name)?;
    let mut node = context
        .new_node(node_name, NodeOptions::new().enable_rosout(true))
        .map_err(|e| err("node", e))?;
    let mut clock = SimClock::start(&mut node)?;
    let rosout = Rosout::start(&node);

    let parameters = ParameterServices::start(&mut node, settings.parameters.clone())?;
    let mut kinematics = Vec::new();
    for arm in layout.arms.iter().filter(|a| a.simulated) {
        kinematics.push(KinematicsServices::start(
            &mut node,
            &settings.namespace,
            &arm.name,
            arm.psm.clone(),
        )?);
    }
    let mut topics = Topics {
        node: &mut node,
        namespace: settings.namespace.clone(),
        remaps: &settings.remaps,
    };
    // Where each output lives on the graph, for its subscriber count.
    let graph_name = |topic: &str| remap(&settings.namespace, &settings.remaps, topic);
    let mut arms = Vec::new();
    for output in &layout.arms {
        let n = &output.name;
        let publishers = if output.simulated {
            Some(ArmPublishers {
                measured_js: topics.publisher(&format!("{n}/measured_js"), periodic_qos())?,
                setpoint_js: topics.publisher(&format!("{n}/setpoint_js"), periodic_qos())?,
                measured_cp: topics.publisher(&format!("{n}/measured_cp"), periodic_qos())?,
                setpoint_cp: topics.publisher(&format!("{n}/setpoint_cp"), periodic_qos())?,
                measured_cv: topics.publisher(&format!("{n}/measured_cv"), periodic_qos())?,
                jaw: match output.psm.jaw().is_empty() {
                    true => None,
                    false => Some([
                        topics.publisher(&format!("{n}/jaw/measured_js"), periodic_qos())?,
                        topics.publisher(&format!("{n}/jaw/setpoint_js"), periodic_qos())?,
                    ]),
                },
                operating_state: topics.publisher(&format!("{n}/operating_state"), event_qos())?,
                error: topics.publisher(&format!("{n}/error"), event_qos())?,
                warning: topics.publisher(&format!("{n}/warning"), event_qos())?,
                status: topics.publisher(&format!("{n}/status"), event_qos())?,
                local_measured_cp: topics
                    .publisher(&format!("{n}/local/measured_cp"), periodic_qos())?,
                local_setpoint_cp: topics
                    .publisher(&format!("{n}/local/setpoint_cp"), periodic_qos())?,
                measured_cf: [
                    topics.publisher(&format!("{n}/body/measured_cf"), periodic_qos())?,
                    topics.publisher(&format!("{n}/spatial/measured_cf"), periodic_qos())?,
                ],
                body_jacobian: topics.publisher(&format!("{n}/body/jacobian"), periodic_qos())?,
                spatial_jacobian: topics
                    .publisher(&format!("{n}/spatial/jacobian"), periodic_qos())?,
                _tool_type: match &output.tool_type {
                    None => None,
                    Some(tool_type) => {
                        let p = topics.publisher(&format!("{n}/tool_type"), event_qos())?;
                        let _ = p.publish(StringMsg {
                            data: tool_type.clone(),
                        });
                        Some(p)
                    }
                },
                trajectory_ratio: topics
                    .publisher(&format!("{n}/trajectory_j/ratio"), event_qos())?,
            })
        } else {
            None
        };
        arms.push(ArmIo {
            publishers,
            ratio: None,
        });
    }
    // A replay drives the arms from the bag: the input topics are not subscribed.
    let mut inputs = Vec::new();
    if settings.replay.is_none() {
        for topic in input_topics(scene, &settings.namespace) {
            inputs.push(topics.input(topic)?);
        }
    }
    let mut force = Vec::new();
    for f in &layout.force_feedback {
        force.push((topics.publisher(&f.topic, periodic_qos())?, f.scale, f.tool));
    }
    let points: Publisher<PointCloud2> = topics.publisher("tissue/points", periodic_qos())?;
    let surface: Publisher<Marker> = topics.publisher("tissue/surface", periodic_qos())?;
    let pieces: Publisher<UInt32> = topics.publisher(outputs::PIECES_TOPIC, periodic_qos())?;
    let wound_gap: Option<Publisher<Float64>> = match scene.wound {
        Some(_) => Some(topics.publisher(outputs::WOUND_GAP_TOPIC, periodic_qos())?),
        None => None,
    };
    let mut wrenches: Vec<Publisher<WrenchStamped>> = Vec::new();
    for tool in &scene.tools {
        wrenches.push(topics.publisher(&format!("tools/{}/wrench", tool.name), periodic_qos())?);
    }
    let mut threads = Vec::new();
    for thread in &scene.threads {
        let centreline = outputs::thread_centreline_topic(&thread.name);
        let tension = outputs::thread_tension_topic(&thread.name);
        threads.push(ThreadIo {
            centreline: topics.publisher(&centreline, periodic_qos())?,
            tension: topics.publisher(&tension, periodic_qos())?,
            topics: [graph_name(&centreline), graph_name(&tension)],
            wanted: [false; 2],
        });
    }
    let tf: Publisher<TFMessage> = topics.publisher("/tf", periodic_qos())?;
    // The fixed frames, once: latched for every later subscriber.
    let tf_static: Publisher<TFMessage> = topics.publisher("/tf_static", tf_static_qos())?;
    if let Err(e) = tf_static.publish(outputs::tf_static_message(&layout)) {
        tracing::warn!("/tf_static: {e:?}");
    }
    let status: Publisher<DiagnosticArray> = topics.publisher("/diagnostics", status_qos())?;
    let camera = match setup.camera.is_some() {
        true => Some(CameraIo::new(&mut topics)?),
        false => None,
    };
    drop(topics);
    let (backend, adapter) = backend_and_adapter(&setup.world);
    let mut status_report = StatusReport::new(&settings.name, &backend, &adapter);
    status_report.start(Progress {
        wall: Instant::now(),
        time: 0.0,
        frames: 0,
        substeps: 0,
    });

    let mut sim = realtime::spawn(setup);
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
        points_topic: graph_name("tissue/points"),
        surface_topic: graph_name("tissue/surface"),
        pieces_topic: graph_name(outputs::PIECES_TOPIC),
        wound_gap_topic: graph_name(outputs::WOUND_GAP_TOPIC),
        tf_topic: graph_name("/tf"),
        pieces_published: 0,
        wrench_topics: scene
            .tools
            .iter()
            .map(|t| graph_name(&format!("tools/{}/wrench", t.name)))
            .collect(),
        demand: Demand::default(),
        arm_outputs: layout.arms.clone(),
        inputs,
        recording: recorder.is_some(),
        stamps: EventStamps::default(),
        held_events: VecDeque::new(),
        arms_published: f64::NEG_INFINITY,
        force,
        points,
        surface,
        pieces,
        wound_gap,
        wrenches,
        threads,
        tf,
        _tf_static: tf_static,
        tf_arm_links: layout.tf_arm_links,
        camera,
        log: RateLimitedLog::default(),
        rates: Rates {
            arm: Rate::new(outputs.arm_rate_hz),
            points: Rate::new(outputs.points_rate_hz),
            surface: Rate::new(outputs.surface_rate_hz),
            wrench: Rate::new(outputs.wrench_rate_hz),
            tf: Rate::new(outputs.tf_rate_hz),
            thread: Rate::new(outputs.thread_rate_hz),
            demand: Rate::new(10.0),
        },
    };
    let main = async {
        let mut tick = tokio::time::interval(Duration::from_millis(2));
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        let stop = crate::ros::shutdown::polite_stop();
        tokio::pin!(stop);
        loop {
            tokio::select! {
                signal = &mut stop => {
                    tracing::info!("{signal}: shutting down");
                    break;
                }
                _ = tick.tick() => {}
            }
            io.poll_inputs(&sim);
            parameters.serve();
            for services in &kinematics {
                services.serve();
            }
            let frame = sim.frames.borrow().clone();
            io.publish_frame(&node, &sim, &frame);
            io.publish_events(&sim, &rosout, Time::from_secs(frame.time));
            rosout.publish_logged(Time::from_secs(frame.time));
            clock.publish(&frame);
            let progress = Progress {
                wall: Instant::now(),
                time: frame.time,
                frames: frame.index,
                substeps: sim.substeps.load(Ordering::Relaxed),
            };
            if let Some(m) = status_report.due(progress) {
                if let Err(e) = status.publish(m) {
                    tracing::debug!("/diagnostics: {e:?}");
                }
            }
            if sim.is_finished() {
                break;
            }
        }
    };
    main.await;
    drop(node);
    sim.shutdown();
    if let Some(summary) = finish_recording(recorder)? {
        if summary.stopped.is_some() {
            tracing::warn!("bag finished early: {summary}");
        } else {
            tracing::info!("bag finished: {summary}");
        }
    }
    Ok(())
}

struct Rates {
    arm: Rate,
    points: Rate,
    surface: Rate,
    wrench: Rate,
    tf: Rate,
    thread: Rate,
    demand: Rate,
}

/// One thread's publishers: its centreline marker and tension cloud, their absolute topic
/// names and whether each has a subscriber.
struct ThreadIo {
    centreline: Publisher<Marker>,
    tension: Publisher<PointCloud2>,
    topics: [String; 2],
    wanted: [bool; 2],
}

/// Which outputs have subscribers (refreshed a few times a second).
#[derive(Default)]
struct Demand {
    points: bool,
    surface: bool,
    pieces: bool,
    wound_gap: bool,
    tf: bool,
    wrenches: Vec<bool>,
}

struct Io {
    arms: Vec<ArmIo>,
    /// Absolute names of the output topics, for subscriber counts.
    points_topic: String,
    surface_topic: String,
    pieces_topic: String,
    wound_gap_topic: String,
    tf_topic: String,
    /// Index of the last frame whose piece count was published.
    pieces_published: u64,
    wrench_topics: Vec<String>,
    demand: Demand,
    arm_outputs: Vec<ArmOutput>,
    inputs: Vec<InputSubscription>,
    /// Inputs go to the simulation with their messages, to be recorded.
    recording: bool,
    stamps: EventStamps,
    /// Arm events received from the simulation and not published yet: a state change waits
    /// until the arm states of its frame are out (see [`Io::publish_events`]).
    held_events: VecDeque<(usize, ArmEvent)>,
    /// Simulated time of the last frame whose arm states were published (s).
    arms_published: f64,
    /// MTM force feedback, per teleoperation pair that asks for it: publisher, scale,
    /// scene tool.
    force: Vec<(Publisher<WrenchStamped>, f64, usize)>,
    points: Publisher<PointCloud2>,
    surface: Publisher<Marker>,
    pieces: Publisher<UInt32>,
    /// `tissue/wound_gap`, in a scene with a `wound`.
    wound_gap: Option<Publisher<Float64>>,
    wrenches: Vec<Publisher<WrenchStamped>>,
    threads: Vec<ThreadIo>,
    tf: Publisher<TFMessage>,
    /// Kept alive: its one message stays available to late subscribers.
    _tf_static: Publisher<TFMessage>,
    tf_arm_links: bool,
    camera: Option<CameraIo>,
    log: RateLimitedLog,
    rates: Rates,
}

/// The camera's publishers (see [`crate::ros::camera`]), their absolute topic names, which
/// have subscribers, and the time of the last picture published.
struct CameraIo {
    image: Publisher<Image>,
    compressed: Publisher<CompressedImage>,
    info: [Publisher<CameraInfo>; 2],
    depth: [Publisher<Image>; 2],
    labels: [Publisher<Image>; 2],
    /// Image, compressed, info ×2, depth ×2, labels ×2.
    topics: [String; 8],
    wanted: [bool; 8],
    published: f64,
}

impl CameraIo {
    fn new(topics: &mut Topics) -> Result<CameraIo, NodeError> {
        use crate::ros::camera::{self as cam, EYES};
        let names = [
            cam::IMAGE_TOPIC.to_string(),
            cam::COMPRESSED_TOPIC.to_string(),
            cam::info_topic(EYES[0]),
            cam::info_topic(EYES[1]),
            cam::depth_topic(EYES[0]),
            cam::depth_topic(EYES[1]),
            cam::labels_topic(EYES[0]),
            cam::labels_topic(EYES[1]),
        ];
        Ok(CameraIo {
            image: topics.publisher(&names[0], periodic_qos())?,
            compressed: topics.publisher(&names[1], periodic_qos())?,
            info: [
                topics.publisher(&names[2], periodic_qos())?,
                topics.publisher(&names[3], periodic_qos())?,
            ],
            depth: [
                topics.publisher(&names[4], periodic_qos())?,
                topics.publisher(&names[5], periodic_qos())?,
            ],
            labels: [
                topics.publisher(&names[6], periodic_qos())?,
                topics.publisher(&names[7], periodic_qos())?,
            ],
            topics: names.map(|n| remap(&topics.namespace, topics.remaps, &n)),
            wanted: [false; 8],
            published: f64::NEG_INFINITY,
        })
    }

    /// Publishes a picture not published yet, each topic only while subscribed.
    fn publish(&mut self, images: &CameraImages, log: &mut RateLimitedLog) {
        use crate::ros::camera as cam;
        if images.time <= self.published {
            return;
        }
        self.published = images.time;
        let w = self.wanted;
        if w[0] {
            let _ = self.image.publish(cam::image_message(images));
        }
        if w[1] {
            match cam::compressed_message(images) {
                Ok(m) => {
                    let _ = self.compressed.publish(m);
                }
                Err(e) => {
                    let line = format!("{}: not encoded: {e}", self.topics[1]);
                    if let Some(line) = log.admit(&self.topics[1], &line) {
                        tracing::warn!("{line}");
                    }
                }
            }
        }
        for eye in 0..images.eyes.len().min(2) {
            if w[2 + eye] {
                let _ = self.info[eye].publish(cam::info_message(images, eye));
            }
            if w[4 + eye] {
                let _ = self.depth[eye].publish(cam::depth_message(images, eye));
            }
            if w[6 + eye] {
                let _ = self.labels[eye].publish(cam::labels_message(images, eye));
            }
        }
    }
}

impl Io {
    fn send(&mut self, sim: &SimHandle, input: Option<SimInput>, record: Option<RecordedInput>) {
        if !sim.send(input, record) {
            if let Some(line) = self
                .log
                .admit("inputs", "input queue full: dropping commands")
            {
                tracing::warn!("{line}");
            }
        }
    }

    fn poll_inputs(&mut self, sim: &SimHandle) {
        let mut received = Vec::new();
        for input in &self.inputs {
            loop {
                let message = match input.subscription.take() {
                    Ok(Some(m)) => m,
                    Ok(None) => break,
                    Err(e) => {
                        let topic = &input.topic.topic;
                        let line = format!("{topic}: rejected: unreadable message: {e:?}");
                        if let Some(line) = self.log.admit(topic, &line) {
                            tracing::warn!("{line}");
                        }
                        break;
                    }
                };
                if let Some(why) = message.oversize() {
                    let topic = &input.topic.topic;
                    let line = format!("{topic}: dropped on receipt: {why}");
                    if let Some(line) = self.log.admit(topic, &line) {
                        tracing::warn!("{line}");
                    }
                    continue;
                }
                let record = if self.recording {
                    match message.to_cdr() {
                        Ok(cdr) => Some(RecordedInput {
                            topic: input.topic.topic.clone(),
                            type_name: input.topic.kind.type_name(),
                            cdr,
                        }),
                        Err(e) => {
                            tracing::warn!("{}: not recorded: {e}", input.topic.topic);
                            None
                        }
                    }
                } else {
                    None
                };
                match input.topic.to_sim_input(message) {
                    Ok(sim_input) => received.push((sim_input, record)),
                    Err(reason) => {
                        let topic = &input.topic.topic;
                        if let Some(line) = self
                            .log
                            .admit(topic, &format!("{topic}: rejected: {reason}"))
                        {
                            tracing::warn!("{line}");
                        }
                        received.push((None, record));
                    }
                }
            }
        }
        for (input, record) in received {
            if input.is_some() || record.is_some() {
                self.send(sim, input, record);
            }
        }
    }

    /// The arms' events on their topics, and their texts on `/rosout` at dVRK's levels.
    ///
    /// A state change (a move's end, say) goes out only once the arm states of the frame it
    /// happened in have: a client that waits for the idle state and then reads
    /// `measured_js` reads where the move ended. Events keep their order.
    fn publish_events(&mut self, sim: &SimHandle, rosout: &Rosout, stamp: Time) {
        self.held_events.extend(sim.events.try_iter());
        while let Some((_, event)) = self.held_events.front() {
            // Without arm states (`arm_rate_hz = 0`) nothing is waited for.
            let arm_states = self.rates.arm.period.is_some();
            if let ArmEvent::State { time, .. } = event {
                if arm_states && *time > self.arms_published + 1e-9 {
                    break;
                }
            }
            let Some((index, event)) = self.held_events.pop_front() else {
                break;
            };
            let Some(p) = self.arms.get(index).and_then(|a| a.publishers.as_ref()) else {
                continue;
            };
            let _ = match self.stamps.message(index, event) {
                EventMessage::State(m) => p.operating_state.publish(m).map_err(|_| ()),
                EventMessage::Text { suffix, message } => {
                    let (publisher, level) = match suffix {
                        "error" => (&p.error, Log::ERROR),
                        "warning" => (&p.warning, Log::WARN),
                        _ => (&p.status, Log::INFO),
                    };
                    rosout.publish(stamp, level, &message.data);
                    publisher.publish(message).map_err(|_| ())
                }
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
                pieces: node.subscription_count(&self.pieces_topic) > 0,
                wound_gap: self.wound_gap.is_some()
                    && node.subscription_count(&self.wound_gap_topic) > 0,
                tf: node.subscription_count(&self.tf_topic) > 0,
                wrenches: self
                    .wrench_topics
                    .iter()
                    .map(|t| node.subscription_count(t) > 0)
                    .collect(),
            };
            for t in &mut self.threads {
                t.wanted = t
                    .topics
                    .clone()
                    .map(|topic| node.subscription_count(&topic) > 0);
            }
            sim.points_wanted
                .store(self.demand.points, Ordering::Relaxed);
            sim.surface_wanted
                .store(self.demand.surface, Ordering::Relaxed);
            // The wound gap is measured with the piece count.
            sim.pieces_wanted.store(
                self.demand.pieces || self.demand.wound_gap,
                Ordering::Relaxed,
            );
            if let Some(camera) = &mut self.camera {
                camera.wanted = camera
                    .topics
                    .clone()
                    .map(|topic| node.subscription_count(&topic) > 0);
                sim.camera_wanted
                    .store(camera.wanted.iter().any(|&w| w), Ordering::Relaxed);
            }
        }
        if let (Some(camera), Some(images)) = (&mut self.camera, &frame.camera) {
            camera.publish(images, &mut self.log);
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
                let _ = publisher.publish(outputs::wrench_message(tool, 1.0, stamp));
            }
        }
        if self.rates.tf.due(now) && self.demand.tf {
            self.publish_tf(frame, stamp);
        }
        if self.rates.points.due(now) && self.demand.points {
            if let Some(t) = &frame.cloud {
                let _ = self.points.publish(outputs::cloud_message(t, stamp));
            }
        }
        if self.rates.surface.due(now) && self.demand.surface {
            if let Some(t) = &frame.surface {
                let _ = self.surface.publish(outputs::surface_message(t, stamp));
            }
        }
        // Counted by the simulation at the scene's rate (simulated time) while subscribed:
        // each count is published once.
        if let Some(pieces) = frame.pieces.filter(|_| frame.index > self.pieces_published) {
            self.pieces_published = frame.index;
            if self.demand.pieces {
                let _ = self.pieces.publish(outputs::pieces_message(pieces));
            }
            if let (Some(publisher), Some(gap), true) =
                (&self.wound_gap, frame.wound_gap, self.demand.wound_gap)
            {
                let _ = publisher.publish(outputs::wound_gap_message(gap));
            }
        }
        if self.rates.thread.due(now) {
            for (io, thread) in self.threads.iter().zip(&frame.threads) {
                if io.wanted[0] {
                    let m = outputs::thread_centreline_message(thread, stamp);
                    let _ = io.centreline.publish(m);
                }
                if io.wanted[1] {
                    let _ = io
                        .tension
                        .publish(outputs::thread_tension_message(thread, stamp));
                }
            }
        }
    }

    fn publish_arms(&mut self, frame: &Frame, stamp: Time) {
        self.arms_published = frame.time;
        for (index, (io, status)) in self.arms.iter_mut().zip(&frame.arms).enumerate() {
            let Some(p) = &io.publishers else {
                continue;
            };
            let arm = &self.arm_outputs[index];
            if io.ratio != Some(status.trajectory_ratio) {
                io.ratio = Some(status.trajectory_ratio);
                let _ = p.trajectory_ratio.publish(Float64 {
                    data: status.trajectory_ratio,
                });
            }
            let tool = arm.tool.and_then(|t| frame.tools.get(t));
            let (body, spatial) = outputs::measured_cf_messages(arm, status, tool, stamp);
            let _ = p.measured_cf[0].publish(body);
            let _ = p.measured_cf[1].publish(spatial);
            if let Some((body, spatial)) = outputs::jacobian_messages(arm, status) {
                let _ = p.body_jacobian.publish(body);
                let _ = p.spatial_jacobian.publish(spatial);
            }
            let m = outputs::arm_messages(arm, status, stamp);
            let _ = p.local_measured_cp.publish(m.cp.clone());
            let _ = p.local_setpoint_cp.publish(m.cp.clone());
            let _ = p.measured_js.publish(m.js.clone());
            let _ = p.setpoint_js.publish(m.js);
            if let (Some([measured, setpoint]), Some(jaw), Some(jaw_setpoint)) =
                (&p.jaw, m.jaw, m.jaw_setpoint)
            {
                let _ = measured.publish(jaw);
                let _ = setpoint.publish(jaw_setpoint);
            }
            let _ = p.measured_cp.publish(m.cp.clone());
            let _ = p.setpoint_cp.publish(m.cp);
            let _ = p.measured_cv.publish(m.cv);
        }
        for (publisher, scale, tool) in &self.force {
            if let Some(tool) = frame.tools.get(*tool) {
                let _ = publisher.publish(outputs::wrench_message(tool, *scale, stamp));
            }
        }
    }

    fn publish_tf(&mut self, frame: &Frame, stamp: Time) {
        let m = outputs::tf_message(&self.arm_outputs, frame, stamp, self.tf_arm_links);
        let _ = self.tf.publish(m);
    }
}
