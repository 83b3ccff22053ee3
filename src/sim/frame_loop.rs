//! The frame loop, one frame at a time: applies the frame's commands at its start (replayed
//! ones first, at the frame they were applied originally), runs teleoperation, advances the
//! arms to the frame's end and drives their tools, steps the world, takes a snapshot when one
//! is due, and builds the finished [`Frame`]. Who calls it decides the pacing: the simulation
//! thread ([`crate::sim::realtime`]) at the scene's rate in real time, a headless run
//! ([`crate::sim::headless`]) as fast as frames compute.
//!
//! With a recorder attached, each frame's applied inputs, arm events and (when an output is
//! due) the finished frame go to it; with a replay attached, the recorded inputs are applied
//! at the frames they were applied originally.

use std::fmt::Display;
use std::path::PathBuf;
use std::sync::mpsc::SyncSender;
use std::sync::Arc;
use std::time::{Duration, Instant};

use nalgebra::Isometry3;

use crate::output::{ThreadState, TissueCloud};
use crate::robot::teleop::MTM_SILENCE_S;
use crate::robot::RcmPolicy;
use crate::sim::arm::ArmEvent;
use crate::sim::frame::{Due, Frame, ToolState};
use crate::sim::input::{isometry, nanos, Received, RecordedInput, SimInput};
use crate::sim::log::{RateLimitedLog, ARM_EVENT_TARGET};
use crate::sim::setup::SimSetup;
use crate::sim::sink::FrameRecord;
use crate::world::{FrameReport, StepError, World};

/// Which tissue outputs the consumers of frames ask for.
#[derive(Clone, Copy, Debug, Default)]
pub struct Wanted {
    /// The tissue point cloud.
    pub points: bool,
    /// The tissue surface.
    pub surface: bool,
    /// The piece count, at `outputs.pieces_rate_hz` in simulated time.
    pub pieces: bool,
    /// The camera's images, at `camera.rate_hz` in simulated time.
    pub camera: bool,
}

/// What one frame did.
pub struct Stepped {
    /// The world's report, or the guard event that ended the frame (already logged and sent
    /// to the arms as an error).
    pub report: Result<FrameReport, StepError>,
    /// The picture taken at the frame's end, when one was due.
    pub snapshot: Option<std::io::Result<PathBuf>>,
    /// Wall time of the world's step.
    pub wall: Duration,
}

/// A frame's applied inputs and arm events, for the recorder.
type FrameShare = (Vec<RecordedInput>, Vec<(usize, ArmEvent)>);

/// A finished frame, the tissue outputs it is to carry and, when recording, its share of the
/// bag: its start time, applied inputs, arm events and the outputs due.
pub struct Finished {
    frame: Frame,
    points: bool,
    surface: bool,
    pieces: bool,
    camera: bool,
    /// The camera's pose for this frame's picture where the ECM carries it.
    camera_pose: Option<Isometry3<f32>>,
    record: Option<(f64, FrameShare, Due)>,
}

/// The simulation between frames: the scene's setup and the commands' state.
pub struct FrameLoop {
    setup: SimSetup,
    log: RateLimitedLog,
    /// Arm events for the network side; `None` where nobody publishes them.
    events: Option<SyncSender<(usize, ArmEvent)>>,
    /// This frame's applied inputs and events, while recording.
    recording: Option<FrameShare>,
    index: u64,
    /// Simulated time from which the piece count is next due for [`Wanted::pieces`].
    pieces_next: f64,
}

impl FrameLoop {
    /// The loop of `setup`, its arm-driven tools where the arms are; arm events go to
    /// `events` when given.
    pub fn new(mut setup: SimSetup, events: Option<SyncSender<(usize, ArmEvent)>>) -> FrameLoop {
        // Tools driven by arms start where the arm is, not where their keyframes are.
        for (arm, &tool) in setup.arms.iter().zip(&setup.arm_tools) {
            let Some(tool) = tool else { continue };
            let pose = arm.tool_pose();
            setup
                .world
                .hold_tool(tool, pose)
                .expect("arm tools are scene tools with finite poses");
        }
        FrameLoop {
            setup,
            log: RateLimitedLog::default(),
            events,
            recording: None,
            index: 0,
            pieces_next: 0.0,
        }
    }

    /// The simulated world.
    pub fn world(&self) -> &World {
        &self.setup.world
    }

    /// Whether frames are to run at the scene's rate in real time.
    pub fn paced(&self) -> bool {
        self.setup.paced
    }

    /// True once simulated time has reached the setup's stop time.
    pub fn done(&self) -> bool {
        self.setup
            .stop_at
            .is_some_and(|t| self.setup.world.time() >= t - 1e-9)
    }

    /// The frame as it stands now, without tissue outputs or wrenches (before the first step).
    pub fn current(&self) -> Frame {
        frame_of(&self.setup, None)
    }

    /// Runs one frame with `received` applied at its start. `previous`, a finished frame
    /// whose tissue outputs are still to be built, is built while this frame's GPU work runs
    /// (the world's particles hold it until the step ends) and handed to `publish` at once.
    /// This frame comes back as [`Finished`]: build it with [`FrameLoop::finish`], now or
    /// during the next step.
    pub fn step(
        &mut self,
        received: impl IntoIterator<Item = Received>,
        wanted: Wanted,
        previous: Option<Finished>,
        publish: impl FnOnce(Arc<Frame>),
    ) -> (Finished, Stepped) {
        let frame_dt = self.setup.world.frame_dt();
        let start = self.setup.world.time();
        if self.setup.recorder.is_some() {
            self.recording = Some(Default::default());
        }
        if let Some(mut replay) = self.setup.replay.take() {
            let now = nanos(start);
            while replay.front().is_some_and(|r| r.time <= now) {
                let r = replay.pop_front().expect("front exists");
                self.receive(Received {
                    input: r.input,
                    record: Some(r.record),
                });
            }
            self.setup.replay = Some(replay);
        }
        for r in received {
            self.receive(r);
        }
        self.teleoperate(frame_dt);
        let t_next = self.setup.world.time() + frame_dt;
        for a in 0..self.setup.arms.len() {
            let arm = &mut self.setup.arms[a];
            arm.advance(t_next);
            if let Some(tool) = self.setup.arm_tools[a] {
                if let Err(e) = self.setup.world.command_tool_pose(tool, arm.tool_pose()) {
                    tracing::error!("{}: {e}", arm.name());
                }
                if self.setup.world.tools()[tool].jaw().is_some() {
                    if let Err(e) = self.setup.world.command_jaw_effort(tool, arm.jaw_effort()) {
                        tracing::error!("{}: {e}", arm.name());
                    }
                }
            }
            for event in arm.take_events() {
                self.event(a, event);
            }
        }
        let mut due = match &mut self.setup.recorder {
            Some(sink) => sink.due(t_next),
            None => Due::default(),
        };
        let points = wanted.points || due.points;
        let surface = wanted.surface || due.surface;
        let pieces = due.pieces || (wanted.pieces && self.pieces_due(t_next));
        // A bag that keeps pictures asks for them every frame; the camera's own rate decides
        // which frames take one, for the bag and the subscribers alike.
        let camera = (wanted.camera || due.camera)
            && self.setup.camera.as_mut().is_some_and(|c| c.due(t_next));
        due.camera &= camera;
        // Where the ECM holds the camera at the frame's end, for the picture taken then.
        let camera_pose = camera.then(|| endoscope_pose(&self.setup)).flatten();
        let needs_deformation = self
            .setup
            .surface
            .as_ref()
            .is_some_and(|s| s.needs_deformation());
        let began = Instant::now();
        self.setup
            .world
            .set_deformation_readback(points || (surface && needs_deformation));
        self.setup.world.begin_frame();
        // The world's particles hold the previous frame until `finish_frame`.
        if let Some(p) = previous {
            publish(self.finish(p));
        }
        let report = self.setup.world.finish_frame();
        let wall = began.elapsed();
        for (arm, &tool) in self.setup.arms.iter_mut().zip(&self.setup.arm_tools) {
            let Some(tool) = tool else { continue };
            if let Some(jaw) = self.setup.world.tools()[tool].jaw() {
                arm.set_jaw_measured(jaw.angle, jaw.rate, jaw.effort);
            }
        }
        if let Err(e) = &report {
            if let Some(line) = self.log.admit("guard", &e.to_string()) {
                if self.setup.arms.is_empty() {
                    tracing::error!("{line}");
                } else {
                    tracing::error!(target: ARM_EVENT_TARGET, "{line}");
                }
                for a in 0..self.setup.arms.len() {
                    self.event(a, ArmEvent::Error(line.clone()));
                }
            }
        }
        self.index += 1;
        let snapshot = match &mut self.setup.snapshots {
            Some(schedule) => schedule.take_if_due(&mut self.setup.world).transpose(),
            None => None,
        };
        let mut frame = frame_of(&self.setup, report.as_ref().ok());
        frame.index = self.index;
        let record = self.recording.take().and_then(|(inputs, events)| {
            (due.any() || !inputs.is_empty() || !events.is_empty()).then_some((
                start,
                (inputs, events),
                due,
            ))
        });
        let finished = Finished {
            frame,
            points,
            surface,
            pieces,
            camera,
            camera_pose,
            record,
        };
        let stepped = Stepped {
            report,
            snapshot,
            wall,
        };
        (finished, stepped)
    }

    /// Whether the frame ending at `t` counts the pieces for a subscriber: once per period
    /// of `outputs.pieces_rate_hz` in simulated time (a count walks every particle's
    /// neighbours, too much for every frame of a large scene).
    fn pieces_due(&mut self, t: f64) -> bool {
        let rate = self.setup.world.scene().outputs.pieces_rate_hz;
        if rate <= 0.0 || t + 1e-9 < self.pieces_next {
            return false;
        }
        self.pieces_next = t + 1.0 / rate;
        true
    }

    /// Logs a snapshot taken by [`FrameLoop::step`]; after a failure, takes no more.
    pub fn log_snapshot(&mut self, snapshot: std::io::Result<PathBuf>) {
        match snapshot {
            Ok(path) => tracing::info!("snapshot {}", path.display()),
            Err(e) => {
                if let Some(schedule) = self.setup.snapshots.take() {
                    tracing::error!(
                        "snapshot in {}: {e}; no more pictures",
                        schedule.dir.display()
                    );
                }
            }
        }
    }

    /// Builds the frame's tissue outputs from the world's particles and hands its share to
    /// the recorder.
    pub fn finish(&mut self, finished: Finished) -> Arc<Frame> {
        let setup = &mut self.setup;
        let Finished {
            mut frame,
            points,
            surface,
            pieces,
            camera,
            camera_pose,
            record,
        } = finished;
        if pieces {
            frame.pieces = Some(setup.world.pieces() as u32);
            frame.wound_gap = setup.world.wound_gap().map(f64::from);
        }
        if points {
            frame.cloud = Some(Arc::new(TissueCloud::from_particles(
                setup.world.particles(),
                &setup.cloud,
            )));
        }
        if let (true, Some(s)) = (surface, &mut setup.surface) {
            frame.surface = Some(Arc::new(s.triangles(setup.world.particles())));
        }
        if let (true, Some(rig)) = (camera, &mut setup.camera) {
            if let Some(pose) = camera_pose {
                rig.set_pose(pose);
            }
            match rig.render(&mut setup.world) {
                Ok(images) => frame.camera = Some(Arc::new(images)),
                Err(e) => {
                    tracing::error!("camera off: {e}");
                    setup.camera = None;
                }
            }
        }
        let frame = Arc::new(frame);
        if let (Some(sink), Some((start, (inputs, events), due))) = (&mut setup.recorder, record) {
            sink.send(FrameRecord {
                start,
                inputs,
                events,
                frame: frame.clone(),
                due,
            });
        }
        frame
    }

    fn event(&mut self, arm: usize, event: ArmEvent) {
        if let Some((_, events)) = &mut self.recording {
            events.push((arm, event.clone()));
        }
        if let Some(tx) = &self.events {
            if tx.try_send((arm, event)).is_err() {
                tracing::warn!("arm event queue full; dropping an event");
            }
        }
    }

    fn receive(&mut self, received: Received) {
        if let (Some((inputs, _)), Some(record)) = (&mut self.recording, received.record) {
            inputs.push(record);
        }
        if let Some(input) = received.input {
            self.apply(input);
        }
    }

    fn reject(&mut self, arm: Option<(usize, &str)>, topic: &str, reason: impl Display) {
        let who = arm.map(|(_, n)| n).unwrap_or("teleop");
        let key = format!("{who}/{topic}");
        let message = format!("{who}/{topic}: rejected: {reason}");
        if let Some(line) = self.log.admit(&key, &message) {
            if let Some((index, _)) = arm {
                tracing::warn!(target: ARM_EVENT_TARGET, "{line}");
                self.event(index, ArmEvent::Error(line));
            } else {
                tracing::warn!("{line}");
            }
        }
    }

    fn apply(&mut self, input: SimInput) {
        let now = self.setup.world.time();
        match input {
            SimInput::Arm { arm, command } => {
                let Some(a) = self.setup.arms.get_mut(arm) else {
                    return;
                };
                if let Err(rejection) = a.apply(&command, now) {
                    let name = a.name().to_owned();
                    self.reject(Some((arm, &name)), rejection.topic, &rejection.reason);
                }
            }
            SimInput::MtmPose {
                arm,
                position,
                quaternion,
            } => {
                let Some(binding) = self.setup.teleop.iter_mut().find(|b| b.arm == arm) else {
                    return;
                };
                match isometry(&position, &quaternion) {
                    Ok(pose) => {
                        binding.mtm_pose = Some(pose);
                        binding.mtm_fresh = true;
                    }
                    Err(reason) => {
                        let topic = format!("{}/measured_cp", binding.mtm);
                        self.reject(None, &topic, reason)
                    }
                }
            }
            SimInput::MtmGripper { arm, positions } => {
                let Some(binding) = self.setup.teleop.iter_mut().find(|b| b.arm == arm) else {
                    return;
                };
                match positions.first() {
                    Some(g) if g.is_finite() && positions.len() == 1 => {
                        binding.mtm_gripper = *g;
                        binding.mtm_fresh = true;
                    }
                    _ => {
                        let topic = format!("{}/gripper/measured_js", binding.mtm);
                        self.reject(
                            None,
                            &topic,
                            format!("expected one finite position, got {positions:?}"),
                        )
                    }
                }
            }
            SimInput::Clutch(pressed) => {
                for t in &mut self.setup.teleop {
                    t.teleop.set_clutch(pressed);
                }
            }
            SimInput::OperatorPresent(present) => {
                for t in &mut self.setup.teleop {
                    t.teleop.set_operator_present(present);
                }
            }
        }
    }

    /// Each MTM's pose and gripper mapped onto its PSM (see [`crate::robot::teleop`]).
    fn teleoperate(&mut self, dt: f64) {
        let mut rejected = Vec::new();
        for binding in &mut self.setup.teleop {
            let arm = &mut self.setup.arms[binding.arm];
            if arm.ready().is_err() {
                continue;
            }
            let _ = binding.teleop.update_psm_setpoint(arm.cp(), arm.jaw());
            if let (Some(pose), true) = (binding.mtm_pose, binding.mtm_fresh) {
                let was_gone = binding.teleop.mtm_gone();
                let _ = binding.teleop.update_mtm(pose, binding.mtm_gripper, dt);
                binding.mtm_fresh = false;
                if was_gone {
                    tracing::info!(
                        "teleop: the MTM {} publishes again; {} follows it from where it held",
                        binding.mtm,
                        arm.name()
                    );
                }
            } else if binding.teleop.mtm_silent(dt) {
                tracing::warn!(
                    "teleop: no message from the MTM {} for {MTM_SILENCE_S} s; {} holds where \
                     it is until the MTM publishes again",
                    binding.mtm,
                    arm.name()
                );
            }
            let Some(target) = binding.teleop.target() else {
                continue;
            };
            match arm.servo_cp(&target.pose, RcmPolicy::Clamp) {
                Ok(()) => arm.servo_jaw_clamped(target.jaw),
                Err(reason) => rejected.push((binding.arm, arm.name().to_owned(), reason)),
            }
        }
        for (index, name, reason) in rejected {
            self.reject(Some((index, &name)), "teleop servo_cp", reason);
        }
    }
}

/// The camera's pose in the world where the scene has an ECM: its tool frame, the scope's
/// tip (z along the scope, the optical axis).
pub fn endoscope_pose(setup: &SimSetup) -> Option<Isometry3<f32>> {
    let ecm = setup
        .arms
        .iter()
        .find(|a| a.psm().kind() == crate::robot::ArmKind::Ecm)?;
    Some(ecm.world_cp().cast::<f32>())
}

fn frame_of(setup: &SimSetup, report: Option<&FrameReport>) -> Frame {
    let world = &setup.world;
    let tools = world
        .tools()
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let pose = t.pose_at(world.time());
            // A needle its arm has let go of is no longer under the arm's tool frame.
            let arm = setup
                .arm_tools
                .iter()
                .position(|&k| k == Some(i))
                .filter(|_| t.carried_by_driver());
            let frame_id = arm
                .map(|a| setup.arms[a].name().to_owned())
                .unwrap_or_else(|| t.name.clone());
            // An arm's tool reports in the arm's tool frame, the held tool's mount undone.
            let wrench = report
                .and_then(|r| r.wrenches.get(i))
                .map(|w| match arm {
                    Some(a) => w.in_holder_frame(&pose.rotation, setup.arms[a].tool_mount()),
                    None => w.in_tool_frame(&pose.rotation),
                })
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
        threads: world
            .threads()
            .iter()
            .map(|t| Arc::new(ThreadState::of(t)))
            .collect(),
        teleop: setup.teleop.iter().map(|t| t.teleop.state()).collect(),
        pieces: None,
        wound_gap: None,
        camera: None,
    }
}
