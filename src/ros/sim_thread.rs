//! The simulation on its own thread: steps the world at the scene's frame rate (never faster
//! than real time), applies the latest commands at frame boundaries, and hands each finished
//! frame to the ROS side as a latest value (a `watch` channel: a slow reader skips frames, it
//! never queues them). Commands come in through a bounded channel; when it is full a command
//! is dropped with a log line rather than blocking the network side.
//!
//! With a recorder attached, each frame's applied inputs, arm events and (when an output is
//! due) the finished frame go to it; with a replay attached, the recorded inputs are applied
//! at the frames they were applied originally.

use std::collections::{HashMap, VecDeque};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender, TryRecvError, TrySendError};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};
use tokio::sync::watch;

use crate::output::snapshot::SnapshotSchedule;
use crate::output::{CloudOptions, SurfaceTriangles, TissueCloud, TissueSurface};
use crate::robot::{RcmPolicy, Teleop, TeleopState};
use crate::ros::arm::{ArmCommand, ArmEvent, ArmSim, ArmStatus};
use crate::ros::outputs::Due;
use crate::ros::recorder::{nanos, FrameRecord, RecordTap, RecordedInput};
use crate::ros::replay::ReplayInput;
use crate::tools::ToolPose;
use crate::world::{World, Wrench};

/// Commands waiting for the next frame; beyond this, new ones are dropped (and logged).
pub const INPUT_CAPACITY: usize = 1024;
/// Arm events waiting for the ROS side.
pub const EVENT_CAPACITY: usize = 1024;

/// Input from the network side.
#[derive(Clone, Debug, PartialEq)]
pub enum SimInput {
    Arm {
        arm: usize,
        command: ArmCommand,
    },
    /// MTM `measured_cp`: position (m), quaternion x, y, z, w.
    MtmPose {
        position: [f64; 3],
        quaternion: [f64; 4],
    },
    /// MTM `gripper/measured_js` positions (rad).
    MtmGripper(Vec<f64>),
    Clutch(bool),
    OperatorPresent(bool),
}

/// An input with, when recording, the message it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct Received {
    /// `None` for a message with no effect on the simulation (recorded all the same).
    pub input: Option<SimInput>,
    pub record: Option<RecordedInput>,
}

/// A tool at the end of a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct ToolState {
    pub name: String,
    /// Frame of the wrench: the arm's tool frame (`PSM1`) or the tool's name.
    pub frame_id: String,
    pub pose: ToolPose,
    /// Contact wrench in the tool frame (torque about the tool origin).
    pub wrench: Wrench,
}

/// Everything the outputs need from one frame.
#[derive(Clone, Debug, Default)]
pub struct Frame {
    /// 0 before the first frame.
    pub index: u64,
    /// Simulated time at the end of the frame (s).
    pub time: f64,
    pub arms: Vec<ArmStatus>,
    pub tools: Vec<ToolState>,
    /// Present while the ROS side asks for the point cloud.
    pub cloud: Option<Arc<TissueCloud>>,
    /// Present while the ROS side asks for the surface.
    pub surface: Option<Arc<SurfaceTriangles>>,
    pub teleop: Option<TeleopState>,
}

/// Teleoperation of one arm.
pub struct TeleopBinding {
    pub arm: usize,
    pub teleop: Teleop,
}

/// The simulation's side of the exchange, handed to [`spawn`].
pub struct SimSetup {
    pub world: World,
    pub arms: Vec<ArmSim>,
    /// Scene tool index each arm drives.
    pub arm_tools: Vec<usize>,
    pub teleop: Option<TeleopBinding>,
    pub cloud: CloudOptions,
    pub surface: TissueSurface,
    pub snapshots: Option<SnapshotSchedule>,
    /// Records inputs, events and outputs.
    pub recorder: Option<RecordTap>,
    /// Recorded inputs to apply, in order, each at the frame start at its time.
    pub replay: Option<VecDeque<ReplayInput>>,
    /// Frames at the scene's rate in real time (false: as fast as they compute).
    pub paced: bool,
    /// The thread ends by itself once simulated time reaches this (s).
    pub stop_at: Option<f64>,
}

/// The network side's handles.
pub struct SimHandle {
    pub inputs: SyncSender<Received>,
    pub frames: watch::Receiver<Arc<Frame>>,
    pub events: Receiver<(usize, ArmEvent)>,
    /// Set while someone subscribes to the point cloud.
    pub points_wanted: Arc<AtomicBool>,
    /// Set while someone subscribes to the surface.
    pub surface_wanted: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl SimHandle {
    /// Queues an input for the next frame (with its message when recording); drops it
    /// (false) when the queue is full.
    pub fn send(&self, input: Option<SimInput>, record: Option<RecordedInput>) -> bool {
        match self.inputs.try_send(Received { input, record }) {
            Ok(()) => true,
            Err(TrySendError::Full(_)) | Err(TrySendError::Disconnected(_)) => false,
        }
    }

    /// True once the thread has ended (at `stop_at`, or after [`SimHandle::shutdown`]).
    pub fn is_finished(&self) -> bool {
        self.thread.as_ref().is_none_or(|t| t.is_finished())
    }

    /// Stops the thread after its current frame and waits for it.
    pub fn shutdown(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for SimHandle {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// One log line per key and second at most, with a count of the ones held back.
#[derive(Default)]
pub struct RateLimitedLog {
    last: HashMap<String, (Instant, u32)>,
}

impl RateLimitedLog {
    /// Returns the line to log (and publish) now, or `None` when it is held back.
    pub fn admit(&mut self, key: &str, message: &str) -> Option<String> {
        let now = Instant::now();
        match self.last.get_mut(key) {
            Some((at, held)) if now.duration_since(*at) < Duration::from_secs(1) => {
                *held += 1;
                None
            }
            Some((at, held)) => {
                let line = if *held > 0 {
                    format!("{message} ({held} similar held back)")
                } else {
                    message.to_owned()
                };
                *at = now;
                *held = 0;
                Some(line)
            }
            None => {
                self.last.insert(key.to_owned(), (now, 0));
                Some(message.to_owned())
            }
        }
    }
}

/// Starts the simulation thread.
pub fn spawn(mut setup: SimSetup) -> SimHandle {
    let (input_tx, input_rx) = sync_channel(INPUT_CAPACITY);
    let (event_tx, event_rx) = sync_channel(EVENT_CAPACITY);
    let wanted = Wanted {
        points: Arc::new(AtomicBool::new(false)),
        surface: Arc::new(AtomicBool::new(false)),
    };
    let stop = Arc::new(AtomicBool::new(false));
    // Tools driven by arms start where the arm is, not where their keyframes are.
    for (arm, &tool) in setup.arms.iter().zip(&setup.arm_tools) {
        let pose = arm.tool_pose();
        setup
            .world
            .hold_tool(tool, pose)
            .expect("arm tools are scene tools with finite poses");
    }
    let first = Arc::new(frame_of(&setup, None));
    let (frame_tx, frame_rx) = watch::channel(first);
    let thread = {
        let wanted = wanted.clone();
        let stop = stop.clone();
        std::thread::Builder::new()
            .name("simulation".into())
            .spawn(move || run(setup, input_rx, event_tx, frame_tx, &wanted, &stop))
            .expect("cannot start the simulation thread")
    };
    SimHandle {
        inputs: input_tx,
        frames: frame_rx,
        events: event_rx,
        points_wanted: wanted.points,
        surface_wanted: wanted.surface,
        stop,
        thread: Some(thread),
    }
}

fn frame_of(setup: &SimSetup, report: Option<&crate::world::FrameReport>) -> Frame {
    let world = &setup.world;
    let tools = world
        .tools()
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let pose = t.pose_at(world.time());
            let frame_id = setup
                .arm_tools
                .iter()
                .position(|&k| k == i)
                .map(|a| setup.arms[a].name().to_owned())
                .unwrap_or_else(|| t.name.clone());
            let wrench = report
                .and_then(|r| r.wrenches.get(i))
                .map(|w| w.in_tool_frame(&pose.rotation))
                .unwrap_or_default();
            ToolState {
                name: t.name.clone(),
                frame_id,
                pose,
                wrench,
            }
        })
        .collect();
    Frame {
        index: 0,
        time: world.time(),
        arms: setup.arms.iter().map(|a| a.status()).collect(),
        tools,
        cloud: None,
        surface: None,
        teleop: setup.teleop.as_ref().map(|t| t.teleop.state()),
    }
}

fn isometry(position: &[f64; 3], quaternion: &[f64; 4]) -> Result<Isometry3<f64>, String> {
    if !position.iter().chain(quaternion).all(|v| v.is_finite()) {
        return Err("pose has NaN or infinite values".into());
    }
    let [x, y, z, w] = *quaternion;
    let q = Quaternion::new(w, x, y, z);
    if (q.norm() - 1.0).abs() > 0.01 {
        return Err(format!("orientation quaternion has length {:.4}", q.norm()));
    }
    Ok(Isometry3::from_parts(
        Translation3::new(position[0], position[1], position[2]),
        UnitQuaternion::from_quaternion(q),
    ))
}

/// Which tissue outputs the ROS side asks for.
#[derive(Clone)]
struct Wanted {
    points: Arc<AtomicBool>,
    surface: Arc<AtomicBool>,
}

/// A frame's applied inputs and arm events, for the recorder.
type FrameShare = (Vec<RecordedInput>, Vec<(usize, ArmEvent)>);

struct Loop {
    log: RateLimitedLog,
    events: SyncSender<(usize, ArmEvent)>,
    mtm_pose: Option<Isometry3<f64>>,
    mtm_gripper: f64,
    mtm_fresh: bool,
    /// This frame's applied inputs and events, while recording.
    recording: Option<FrameShare>,
}

impl Loop {
    fn event(&mut self, arm: usize, event: ArmEvent) {
        if let Some((_, events)) = &mut self.recording {
            events.push((arm, event.clone()));
        }
        if self.events.try_send((arm, event)).is_err() {
            tracing::warn!("arm event queue full; dropping an event");
        }
    }

    fn receive(&mut self, setup: &mut SimSetup, received: Received) {
        if let (Some((inputs, _)), Some(record)) = (&mut self.recording, received.record) {
            inputs.push(record);
        }
        if let Some(input) = received.input {
            self.apply(setup, input);
        }
    }

    fn reject(&mut self, arm: Option<(usize, &str)>, topic: &str, reason: &str) {
        let who = arm.map(|(_, n)| n).unwrap_or("teleop");
        let key = format!("{who}/{topic}");
        let message = format!("{who}/{topic}: rejected: {reason}");
        if let Some(line) = self.log.admit(&key, &message) {
            tracing::warn!("{line}");
            if let Some((index, _)) = arm {
                self.event(index, ArmEvent::Error(line));
            }
        }
    }

    fn apply(&mut self, setup: &mut SimSetup, input: SimInput) {
        let now = setup.world.time();
        match input {
            SimInput::Arm { arm, command } => {
                let Some(a) = setup.arms.get_mut(arm) else {
                    return;
                };
                if let Err(rejection) = a.apply(&command, now) {
                    let name = a.name().to_owned();
                    self.reject(Some((arm, &name)), rejection.topic, &rejection.reason);
                }
            }
            SimInput::MtmPose {
                position,
                quaternion,
            } => match isometry(&position, &quaternion) {
                Ok(pose) => {
                    self.mtm_pose = Some(pose);
                    self.mtm_fresh = true;
                }
                Err(reason) => self.reject(None, "MTM measured_cp", &reason),
            },
            SimInput::MtmGripper(positions) => match positions.first() {
                Some(g) if g.is_finite() && positions.len() == 1 => {
                    self.mtm_gripper = *g;
                    self.mtm_fresh = true;
                }
                _ => self.reject(
                    None,
                    "MTM gripper/measured_js",
                    &format!("expected one finite position, got {positions:?}"),
                ),
            },
            SimInput::Clutch(pressed) => {
                if let Some(t) = &mut setup.teleop {
                    t.teleop.set_clutch(pressed);
                }
            }
            SimInput::OperatorPresent(present) => {
                if let Some(t) = &mut setup.teleop {
                    t.teleop.set_operator_present(present);
                }
            }
        }
    }

    fn teleoperate(&mut self, setup: &mut SimSetup, dt: f64) {
        let Some(binding) = &mut setup.teleop else {
            return;
        };
        let arm = &mut setup.arms[binding.arm];
        if arm.ready().is_err() {
            return;
        }
        let _ = binding.teleop.update_psm_setpoint(arm.cp(), arm.jaw());
        if let (Some(pose), true) = (self.mtm_pose, self.mtm_fresh) {
            let _ = binding.teleop.update_mtm(pose, self.mtm_gripper, dt);
            self.mtm_fresh = false;
        }
        if let Some(target) = binding.teleop.target() {
            if let Err(reason) = arm.servo_cp(&target.pose, RcmPolicy::Clamp) {
                let name = arm.name().to_owned();
                self.reject(Some((binding.arm, &name)), "teleop servo_cp", &reason);
            } else {
                arm.servo_jaw_clamped(target.jaw);
            }
        }
    }
}

fn run(
    mut setup: SimSetup,
    inputs: Receiver<Received>,
    events: SyncSender<(usize, ArmEvent)>,
    frames: watch::Sender<Arc<Frame>>,
    wanted: &Wanted,
    stop: &AtomicBool,
) {
    let frame_dt = setup.world.frame_dt();
    let period = Duration::from_secs_f64(frame_dt);
    let mut state = Loop {
        log: RateLimitedLog::default(),
        events,
        mtm_pose: None,
        mtm_gripper: 0.0,
        mtm_fresh: false,
        recording: None,
    };
    let mut deadline = Instant::now();
    let mut index = 0u64;
    let mut lagging_since: Option<Instant> = None;
    // A finished frame whose tissue outputs are still to be built: while the simulation runs
    // behind real time, they are built during the next frame's GPU work instead of before it.
    let mut held: Option<HeldFrame> = None;
    'frames: while !stop.load(Ordering::Relaxed) {
        if setup
            .stop_at
            .is_some_and(|t| setup.world.time() >= t - 1e-9)
        {
            break;
        }
        let start = setup.world.time();
        if setup.recorder.is_some() {
            state.recording = Some(Default::default());
        }
        if let Some(mut replay) = setup.replay.take() {
            let now = nanos(start);
            while replay.front().is_some_and(|r| r.time <= now) {
                let r = replay.pop_front().expect("front exists");
                state.receive(
                    &mut setup,
                    Received {
                        input: r.input,
                        record: Some(r.record),
                    },
                );
            }
            setup.replay = Some(replay);
        }
        loop {
            match inputs.try_recv() {
                Ok(received) => state.receive(&mut setup, received),
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => break 'frames,
            }
        }
        state.teleoperate(&mut setup, frame_dt);
        let t_next = setup.world.time() + frame_dt;
        for (a, arm) in setup.arms.iter_mut().enumerate() {
            arm.advance(t_next);
            let tool = setup.arm_tools[a];
            if let Err(e) = setup.world.command_tool_pose(tool, arm.tool_pose()) {
                tracing::error!("{}: {e}", arm.name());
            }
            for event in arm.take_events() {
                state.event(a, event);
            }
        }
        let due = match &mut setup.recorder {
            Some(tap) => tap.due(t_next),
            None => Default::default(),
        };
        let points = wanted.points.load(Ordering::Relaxed) || due.points;
        let surface = wanted.surface.load(Ordering::Relaxed) || due.surface;
        setup
            .world
            .set_deformation_readback(points || (surface && setup.surface.needs_deformation()));
        setup.world.begin_frame();
        // The world's particles hold the previous frame until `finish_frame`.
        if let Some(h) = held.take() {
            publish(&mut setup, &frames, h);
        }
        let report = match setup.world.finish_frame() {
            Ok(report) => Some(report),
            Err(e) => {
                if let Some(line) = state.log.admit("guard", &e.to_string()) {
                    tracing::error!("{line}");
                    for a in 0..setup.arms.len() {
                        state.event(a, ArmEvent::Error(line.clone()));
                    }
                }
                None
            }
        };
        index += 1;
        if let Some(schedule) = &mut setup.snapshots {
            match schedule.take_if_due(&mut setup.world) {
                Ok(Some(path)) => tracing::info!("snapshot {}", path.display()),
                Ok(None) => {}
                Err(e) => {
                    tracing::error!(
                        "snapshot in {}: {e}; no more pictures",
                        schedule.dir.display()
                    );
                    setup.snapshots = None;
                }
            }
        }
        let mut frame = frame_of(&setup, report.as_ref());
        frame.index = index;
        let record = state.recording.take().and_then(|(inputs, events)| {
            (due.any() || !inputs.is_empty() || !events.is_empty()).then_some((
                start,
                (inputs, events),
                due,
            ))
        });
        let finished = HeldFrame {
            frame,
            points,
            surface,
            record,
        };

        if !setup.paced {
            // As fast as frames compute: always build outputs during the next frame.
            held = Some(finished);
            continue;
        }
        deadline += period;
        let now = Instant::now();
        if deadline > now {
            // Ahead of real time: publish at once, the lowest latency.
            publish(&mut setup, &frames, finished);
            std::thread::sleep(deadline - now);
            lagging_since = None;
        } else {
            held = Some(finished);
            // Slower than real time: carry on at full speed, without trying to catch up.
            deadline = now;
            let since = *lagging_since.get_or_insert(now);
            if now.duration_since(since) > Duration::from_secs(10) {
                tracing::info!(
                    "simulation runs slower than real time (t = {:.3} s simulated)",
                    setup.world.time()
                );
                lagging_since = Some(now);
            }
        }
    }
    if let Some(h) = held {
        publish(&mut setup, &frames, h);
    }
}

/// A finished frame, the tissue outputs it is to carry and, when recording, its share of the
/// bag: its start time, applied inputs, arm events and the outputs due.
struct HeldFrame {
    frame: Frame,
    points: bool,
    surface: bool,
    record: Option<(f64, FrameShare, Due)>,
}

/// Builds the frame's tissue outputs from the world's particles and hands it to the ROS side
/// and the recorder.
fn publish(setup: &mut SimSetup, frames: &watch::Sender<Arc<Frame>>, held: HeldFrame) {
    let HeldFrame {
        mut frame,
        points,
        surface,
        record,
    } = held;
    if points {
        frame.cloud = Some(Arc::new(TissueCloud::from_particles(
            setup.world.particles(),
            &setup.cloud,
        )));
    }
    if surface {
        frame.surface = Some(Arc::new(setup.surface.triangles(setup.world.particles())));
    }
    let frame = Arc::new(frame);
    if let (Some(tap), Some((start, (inputs, events), due))) = (&mut setup.recorder, record) {
        tap.send(FrameRecord {
            start,
            inputs,
            events,
            frame: frame.clone(),
            due,
        });
    }
    frames.send_replace(frame);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_lines_are_rate_limited_per_key() {
        let mut log = RateLimitedLog::default();
        assert!(log.admit("a", "first").is_some());
        assert!(log.admit("a", "again").is_none());
        assert!(log.admit("b", "other key").is_some());
    }
}
