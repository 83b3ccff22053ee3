//! A simulated or mirrored PSM on top of [`crate::robot::Psm`]: the CRTK operating state,
//! servo / move commands with validation, and the joint state the ROS side publishes.
//!
//! No ROS types here: the node turns messages into [`ArmInput`]s, the frame loop feeds
//! them in at frame boundaries ([`ArmSim::apply`]) and advances the arm in simulated time
//! ([`ArmSim::advance`]). Kinematic simulation, as dVRK's `KIN_SIMULATED`: measured = setpoint.

use nalgebra::{Isometry3, Vector3};

use crate::config::ArmMode;
use crate::robot::{JointCommandError, Psm, PsmError, RcmPolicy, Trajectory};
use crate::sim::input::{isometry, PoseError};
use crate::tools::ToolPose;

/// What a topic asked for, before validation.
#[derive(Clone, Debug, PartialEq)]
pub enum ArmInput {
    /// `servo_jp`: go to these joint positions now (each joint within its jump bound).
    ServoJp {
        /// Joint names, or empty for the canonical order.
        names: Vec<String>,
        /// Joint positions, rad or m, in `names` order.
        positions: Vec<f64>,
    },
    /// `move_jp`: interpolate to these joint positions (no jump bound).
    MoveJp {
        /// Joint names, or empty for the canonical order.
        names: Vec<String>,
        /// Joint positions, rad or m, in `names` order.
        positions: Vec<f64>,
    },
    /// `jaw/servo_jp`: set the jaw opening now.
    JawServoJp {
        /// The jaw's joint name, or empty.
        names: Vec<String>,
        /// The jaw opening, rad (one value).
        positions: Vec<f64>,
    },
    /// `jaw/move_jp`: interpolate the jaw to this opening.
    JawMoveJp {
        /// The jaw's joint name, or empty.
        names: Vec<String>,
        /// The jaw opening, rad (one value).
        positions: Vec<f64>,
    },
    /// Jaw effort (N·m, positive opens), as dVRK's `jaw/servo_jf`.
    JawServoJf {
        /// The jaw's joint name, or empty.
        names: Vec<String>,
        /// The jaw effort, N·m (one value).
        efforts: Vec<f64>,
    },
    /// Position (m) and quaternion x, y, z, w, in the arm's base frame.
    ServoCp {
        /// Tool origin in the base frame, m.
        position: [f64; 3],
        /// Tool orientation in the base frame, quaternion x, y, z, w.
        quaternion: [f64; 4],
    },
    /// `move_cp`: interpolate to this tool pose (position in m, quaternion x, y, z, w, base frame).
    MoveCp {
        /// Tool origin in the base frame, m.
        position: [f64; 3],
        /// Tool orientation in the base frame, quaternion x, y, z, w.
        quaternion: [f64; 4],
    },
    /// `servo_jr`: step the joints by these amounts from where they are now (each joint
    /// within its jump bound).
    ServoJr {
        /// Joint names, or empty for the canonical order.
        names: Vec<String>,
        /// Joint steps, rad or m, in `names` order.
        steps: Vec<f64>,
    },
    /// `move_jr`: move the joints by these amounts, as `move_jp` would to the sum.
    MoveJr {
        /// Joint names, or empty for the canonical order.
        names: Vec<String>,
        /// Joint steps, rad or m, in `names` order.
        steps: Vec<f64>,
    },
    /// `servo_jf` or `spatial/servo_cf`: an effort or force command, which a kinematic arm
    /// cannot apply (refused, as dVRK refuses one in a state that cannot).
    ForceCommand,
    /// `trajectory_j/set_ratio`: moves use this share (0, 1] of dVRK's `move_jp` speeds.
    TrajectoryRatio(f64),
    /// `hold`: stop any motion where the arm is.
    Hold,
    /// `free`: not simulated on a kinematic arm; holds instead.
    Free,
    /// `state_command`: `enable`, `disable`, `home`, `unhome`, `pause` or `resume`.
    StateCommand(String),
    /// Force command (N, N·m): accepted when finite; a kinematic arm cannot apply it.
    ServoCf([f64; 6]),
    /// A real arm's `measured_js` (mirror mode).
    MirrorJs {
        /// Joint names, or empty for the canonical order.
        names: Vec<String>,
        /// Measured joint positions, rad or m, in `names` order.
        positions: Vec<f64>,
    },
    /// A real arm's `jaw/measured_js` (mirror mode).
    MirrorJaw {
        /// The jaw's joint name, or empty.
        names: Vec<String>,
        /// The measured jaw opening, rad (one value).
        positions: Vec<f64>,
    },
}

impl ArmInput {
    /// Whether the command starts a move (`move_jp`, `move_cp`, `jaw/move_jp`): a client waits
    /// for its busy edges.
    pub fn is_move(&self) -> bool {
        matches!(
            self,
            ArmInput::MoveJp { .. }
                | ArmInput::MoveJr { .. }
                | ArmInput::MoveCp { .. }
                | ArmInput::JawMoveJp { .. }
        )
    }
}

/// A command from a topic.
#[derive(Clone, Debug, PartialEq)]
pub struct ArmCommand {
    /// Topic relative to the arm (`servo_jp`, `jaw/servo_jp`, ...), for messages.
    pub topic: &'static str,
    /// The command, before validation.
    pub input: ArmInput,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
/// The CRTK operating state of an arm.
pub enum OperatingState {
    /// Not accepting motion commands.
    Disabled,
    /// Accepting motion commands (once homed).
    Enabled,
    /// Paused: motion commands rejected until `resume`.
    Paused,
    /// Faulted.
    Fault,
}

impl OperatingState {
    /// The CRTK name, as `crtk_msgs/OperatingState.state` carries it.
    pub fn as_str(&self) -> &'static str {
        match self {
            OperatingState::Disabled => "DISABLED",
            OperatingState::Enabled => "ENABLED",
            OperatingState::Paused => "PAUSED",
            OperatingState::Fault => "FAULT",
        }
    }
}

/// Something the ROS side publishes once (latched event topics), at simulated `time`.
#[derive(Clone, Debug, PartialEq)]
pub enum ArmEvent {
    /// The operating state changed, or a move started or ended.
    State {
        /// Simulated time of the change, s.
        time: f64,
        /// The operating state now.
        state: OperatingState,
        /// Whether the arm is homed.
        homed: bool,
        /// Whether a move (arm or jaw) is in progress.
        busy: bool,
    },
    /// A message for the arm's `error` topic.
    Error(String),
    /// A message for the arm's `warning` topic.
    Warning(String),
    /// A message for the arm's `status` topic.
    Status(String),
}

/// Why an arm refused a command (or could not be built).
#[derive(Debug, thiserror::Error)]
pub enum ArmError {
    #[error("home_joints: {0}")]
    /// The configured home joints are invalid.
    HomeJoints(JointCommandError),
    #[error("home_jaw_deg: {0}")]
    /// The configured home jaw opening is invalid.
    HomeJaw(JointCommandError),
    #[error("arm is {}, not ENABLED", .0.as_str())]
    /// A motion command arrived while the arm is not ENABLED (holds the state it is in).
    NotEnabled(OperatingState),
    #[error("arm is not homed")]
    /// A motion command arrived before the arm was homed.
    NotHomed,
    #[error("the arm mirrors a real arm")]
    /// A motion command to an arm that mirrors a real arm.
    Mirrors,
    #[error("the arm is simulated, not mirrored")]
    /// A mirror message to an arm that is simulated.
    NotMirrored,
    #[error("wrench has NaN or infinite values")]
    /// A `servo_cf` wrench with NaN or infinite values.
    Wrench,
    #[error("expected one finite jaw effort, got {0:?}")]
    /// A `jaw/servo_jf` that is not one finite effort (holds the values received).
    JawEffort(Vec<f64>),
    #[error("a kinematic arm cannot apply efforts or forces")]
    /// `servo_jf` or `spatial/servo_cf` on a kinematic arm.
    NoForceControl,
    #[error("trajectory ratio {0}: expected a number in (0, 1]")]
    /// A `trajectory_j/set_ratio` outside (0, 1] or not finite.
    TrajectoryRatio(f64),
    #[error("arm is PAUSED: send resume")]
    /// A motion command while PAUSED.
    Paused,
    #[error("cannot {action} from {}", .state.as_str())]
    /// A state command not allowed from the current state.
    Transition {
        /// The command, e.g. `home`.
        action: &'static str,
        /// The state the arm was in.
        state: OperatingState,
    },
    #[error("unknown state command `{0}` (enable, disable, home, unhome, pause, resume)")]
    /// A state command other than enable, disable, home, unhome, pause, resume.
    UnknownStateCommand(String),
    #[error(transparent)]
    /// A joint command failed validation (names, length, limits, jump).
    Joints(#[from] JointCommandError),
    #[error(transparent)]
    /// A Cartesian pose command was not finite or not a unit quaternion.
    Pose(#[from] PoseError),
    #[error(transparent)]
    /// The kinematics failed (e.g. no inverse kinematics solution).
    Psm(#[from] PsmError),
}

/// A rejected command: the topic and why.
#[derive(Debug)]
pub struct Rejection {
    /// The topic relative to the arm (`servo_jp`, ...).
    pub topic: &'static str,
    /// Why the command was rejected.
    pub reason: ArmError,
}

impl std::fmt::Display for Rejection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.topic, self.reason)
    }
}

/// The arm's state at the end of a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct ArmStatus {
    /// Joint positions, rad or m, in canonical order.
    pub q: Vec<f64>,
    /// Joint velocities, rad/s or m/s, in canonical order.
    pub qdot: Vec<f64>,
    /// The jaw opening reached (rad), its rate and the controller's effort (N·m).
    pub jaw: f64,
    /// Jaw opening rate, rad/s.
    pub jaw_rate: f64,
    /// Jaw controller effort, N·m.
    pub jaw_effort: f64,
    /// The commanded opening (`jaw/setpoint_js`).
    pub jaw_setpoint: f64,
    /// Tool frame in the base frame (`measured_cp`; equals `setpoint_cp`).
    pub cp: Isometry3<f64>,
    /// Tool twist in the base frame: linear (m/s), angular (rad/s).
    pub linear_velocity: Vector3<f64>,
    /// Angular velocity of the tool in the base frame, rad/s.
    pub angular_velocity: Vector3<f64>,
    /// The share of dVRK's `move_jp` speeds moves use (`trajectory_j/ratio`).
    pub trajectory_ratio: f64,
}

enum Motion {
    Hold,
    Move { trajectory: Trajectory, start: f64 },
}

/// One PSM in the scene: simulated kinematically (measured = setpoint) or mirroring a real arm's
/// joint states.
pub struct ArmSim {
    psm: Psm,
    mode: ArmMode,
    /// World from `<name>_base`.
    base: Isometry3<f64>,
    /// The held tool's pose in the arm's tool frame (`[[arm]] tool_xyz`, `tool_rpy_deg`): a
    /// slicer's blade hangs along its own −z, the instrument's axis is the tool frame's +z.
    mount: Isometry3<f64>,
    home: Vec<f64>,
    state: OperatingState,
    homed: bool,
    q: Vec<f64>,
    qdot: Vec<f64>,
    jaw: f64,
    jaw_rate: f64,
    motion: Motion,
    jaw_motion: Option<(Trajectory, f64)>,
    /// An effort command replacing the jaw's position servo (`jaw/servo_jf`).
    jaw_effort: Option<f64>,
    /// The jaw controller's effort limit (N·m).
    jaw_effort_max: f64,
    warned_jaw_effort: bool,
    /// The jaw as the tool reached it: opening, rate, effort.
    jaw_measured: Option<(f64, f64, f64)>,
    /// Time of the last `advance`.
    time: f64,
    events: Vec<ArmEvent>,
    warned_cf: bool,
    /// The share of dVRK's `move_jp` speeds moves use.
    trajectory_ratio: f64,
}

impl ArmSim {
    /// An arm at `home` (validated against the joint limits), ENABLED and homed.
    pub fn new(
        psm: Psm,
        mode: ArmMode,
        base: Isometry3<f64>,
        home: &[f64],
        home_jaw: f64,
    ) -> Result<ArmSim, ArmError> {
        let q = psm
            .joints()
            .validate::<&str>(&[], home, None)
            .map_err(ArmError::HomeJoints)?;
        let jaw = match psm.jaw().is_empty() {
            true => 0.0,
            false => psm
                .jaw()
                .validate::<&str>(&[], &[home_jaw], None)
                .map_err(ArmError::HomeJaw)?[0],
        };
        let n = q.len();
        let mut arm = ArmSim {
            psm,
            mode,
            base,
            mount: Isometry3::identity(),
            home: q.clone(),
            state: OperatingState::Enabled,
            homed: true,
            qdot: vec![0.0; n],
            q,
            jaw,
            jaw_rate: 0.0,
            motion: Motion::Hold,
            jaw_motion: None,
            jaw_effort: None,
            jaw_effort_max: crate::tools::JawGains::default().effort_max,
            warned_jaw_effort: false,
            jaw_measured: None,
            time: 0.0,
            events: Vec::new(),
            warned_cf: false,
            trajectory_ratio: 1.0,
        };
        if mode == ArmMode::Simulated {
            arm.push_state();
        }
        Ok(arm)
    }

    /// The arm's kinematics (joints, jaw, chain).
    pub fn psm(&self) -> &Psm {
        &self.psm
    }

    /// The arm's name, e.g. `PSM1` (the prefix of its topics and frames).
    pub fn name(&self) -> &str {
        self.psm.name()
    }

    /// Simulated, or mirroring a real arm.
    pub fn mode(&self) -> ArmMode {
        self.mode
    }

    /// The world pose of the arm's `<name>_base` frame (m).
    pub fn base(&self) -> &Isometry3<f64> {
        &self.base
    }

    /// Holds the tool at `mount` in the arm's tool frame (`[[arm]] tool_xyz`,
    /// `tool_rpy_deg`).
    pub fn set_tool_mount(&mut self, mount: Isometry3<f64>) {
        self.mount = mount;
    }

    /// The held tool's pose in the arm's tool frame.
    pub fn tool_mount(&self) -> &Isometry3<f64> {
        &self.mount
    }

    /// The CRTK operating state.
    pub fn operating_state(&self) -> OperatingState {
        self.state
    }

    /// Whether the arm has been homed.
    pub fn is_homed(&self) -> bool {
        self.homed
    }

    /// Whether an arm or jaw move is in progress.
    pub fn is_busy(&self) -> bool {
        matches!(self.motion, Motion::Move { .. }) || self.jaw_motion.is_some()
    }

    /// The joint positions, rad or m, in canonical order.
    pub fn q(&self) -> &[f64] {
        &self.q
    }

    /// The jaw setpoint (rad).
    pub fn jaw(&self) -> f64 {
        self.jaw
    }

    /// The jaw effort command in force, if any (N·m, within the limit).
    pub fn jaw_effort(&self) -> Option<f64> {
        self.jaw_effort
    }

    /// The effort limit of the jaw controller driving this arm's tool (N·m).
    pub fn set_jaw_effort_limit(&mut self, limit: f64) {
        self.jaw_effort_max = limit;
    }

    /// What the tool's jaws reached this frame: opening (rad), rate (rad/s), effort (N·m).
    pub fn set_jaw_measured(&mut self, angle: f64, rate: f64, effort: f64) {
        self.jaw_measured = Some((angle, rate, effort));
    }

    /// Events since the last call (operating state changes, error / warning / status text).
    pub fn take_events(&mut self) -> Vec<ArmEvent> {
        std::mem::take(&mut self.events)
    }

    /// The tool frame in the base frame.
    pub fn cp(&self) -> Isometry3<f64> {
        self.psm
            .forward(&self.q)
            .expect("arm joint vector has the chain's length")
    }

    /// The tool frame in the world: the base's pose times `cp`.
    pub fn world_cp(&self) -> Isometry3<f64> {
        self.base * self.cp()
    }

    /// The tool pose in the world, jaw included: what drives the scene's tool.
    pub fn tool_pose(&self) -> ToolPose {
        let world = self.world_cp() * self.mount;
        ToolPose {
            position: world.translation.vector,
            rotation: world.rotation,
            jaw: self.jaw,
        }
    }

    /// The arm's state now: joints, jaw, tool frame and twist in the base frame.
    pub fn status(&self) -> ArmStatus {
        let cp = self.cp();
        let j = self
            .psm
            .jacobian(&self.q)
            .expect("arm joint vector has the chain's length");
        let twist = j * nalgebra::DVector::from_column_slice(&self.qdot);
        let (jaw, jaw_rate, jaw_effort) =
            self.jaw_measured.unwrap_or((self.jaw, self.jaw_rate, 0.0));
        ArmStatus {
            q: self.q.clone(),
            qdot: self.qdot.clone(),
            jaw,
            jaw_rate,
            jaw_effort,
            jaw_setpoint: self.jaw,
            cp,
            linear_velocity: Vector3::new(twist[0], twist[1], twist[2]),
            angular_velocity: Vector3::new(twist[3], twist[4], twist[5]),
            trajectory_ratio: self.trajectory_ratio,
        }
    }

    /// Where a relative joint command (`servo_jr`, `move_jr`) leads from the joints now.
    fn relative_goal(&self, names: &[String], steps: &[f64]) -> Result<Vec<f64>, ArmError> {
        let steps = self.psm.joints().validate_shape(names, steps)?;
        Ok(self.q.iter().zip(&steps).map(|(q, d)| q + d).collect())
    }

    fn push_busy(&mut self, busy: bool) {
        self.events.push(ArmEvent::State {
            time: self.time,
            state: self.state,
            homed: self.homed,
            busy,
        });
    }

    fn push_state(&mut self) {
        self.push_busy(self.is_busy());
    }

    fn set_state(&mut self, state: OperatingState) {
        if self.state != state {
            self.state = state;
            self.push_state();
        }
    }

    fn stop_motion(&mut self) {
        let was_busy = self.is_busy();
        self.motion = Motion::Hold;
        self.jaw_motion = None;
        if was_busy {
            self.push_state();
        }
    }

    /// Ok when the arm accepts motion commands (ENABLED and homed).
    pub fn ready(&self) -> Result<(), ArmError> {
        if self.state != OperatingState::Enabled {
            return Err(ArmError::NotEnabled(self.state));
        }
        if !self.homed {
            return Err(ArmError::NotHomed);
        }
        Ok(())
    }

    /// Applies one command at simulated time `now`. A rejected command changes nothing: the
    /// last valid command holds.
    pub fn apply(&mut self, command: &ArmCommand, now: f64) -> Result<(), Rejection> {
        self.time = now;
        let reject = |reason: ArmError| Rejection {
            topic: command.topic,
            reason,
        };
        match (&command.input, self.mode) {
            (ArmInput::MirrorJs { names, positions }, ArmMode::Mirror) => {
                let mut q = self
                    .psm
                    .joints()
                    .validate_shape(names, positions)
                    .map_err(|e| reject(e.into()))?;
                self.psm.joints().clamp(&mut q);
                self.q = q;
                Ok(())
            }
            (ArmInput::MirrorJaw { names, positions }, ArmMode::Mirror) => {
                let mut q = self
                    .psm
                    .jaw()
                    .validate_shape(names, positions)
                    .map_err(|e| reject(e.into()))?;
                self.psm.jaw().clamp(&mut q);
                self.jaw = q[0];
                Ok(())
            }
            (_, ArmMode::Mirror) => Err(reject(ArmError::Mirrors)),
            (ArmInput::MirrorJs { .. } | ArmInput::MirrorJaw { .. }, _) => {
                Err(reject(ArmError::NotMirrored))
            }
            (input, ArmMode::Simulated) => {
                let result = self.apply_simulated(input, now);
                if result.is_err() && input.is_move() && !self.is_busy() {
                    // As dVRK's simulators: a refused move still starts and ends, so a
                    // client waiting for the move's busy edges returns at once.
                    self.push_busy(true);
                    self.push_busy(false);
                }
                result.map_err(reject)
            }
        }
    }

    fn apply_simulated(&mut self, input: &ArmInput, now: f64) -> Result<(), ArmError> {
        match input {
            ArmInput::StateCommand(command) => self.state_command(command),
            ArmInput::Hold => {
                self.stop_motion();
                Ok(())
            }
            ArmInput::ForceCommand => Err(ArmError::NoForceControl),
            ArmInput::TrajectoryRatio(ratio) => {
                if !(ratio.is_finite() && *ratio > 0.0 && *ratio <= 1.0) {
                    return Err(ArmError::TrajectoryRatio(*ratio));
                }
                self.trajectory_ratio = *ratio;
                Ok(())
            }
            ArmInput::ServoJr { names, steps } => {
                self.ready()?;
                let goal = self.relative_goal(names, steps)?;
                let q = self
                    .psm
                    .joints()
                    .validate::<&str>(&[], &goal, Some(&self.q))?;
                if let Motion::Move { .. } = self.motion {
                    self.motion = Motion::Hold;
                    self.push_state();
                }
                self.set_q(q);
                Ok(())
            }
            ArmInput::MoveJr { names, steps } => {
                self.ready()?;
                let goal = self.relative_goal(names, steps)?;
                let goal = self.psm.joints().validate::<&str>(&[], &goal, None)?;
                self.start_move(goal, now)
            }
            ArmInput::Free => {
                self.stop_motion();
                self.events.push(ArmEvent::Status(format!(
                    "{}: free is not simulated (kinematic arm); holding",
                    self.name()
                )));
                Ok(())
            }
            ArmInput::ServoCf(w) => {
                if !w.iter().all(|v| v.is_finite()) {
                    return Err(ArmError::Wrench);
                }
                if !self.warned_cf {
                    self.warned_cf = true;
                    self.events.push(ArmEvent::Warning(format!(
                        "{}: body/servo_cf is accepted but has no effect on a kinematic arm",
                        self.name()
                    )));
                }
                Ok(())
            }
            ArmInput::ServoJp { names, positions } => {
                self.ready()?;
                let q = self
                    .psm
                    .joints()
                    .validate(names, positions, Some(&self.q))?;
                if let Motion::Move { .. } = self.motion {
                    self.motion = Motion::Hold;
                    self.push_state();
                }
                self.set_q(q);
                Ok(())
            }
            ArmInput::JawServoJp { names, positions } => {
                self.ready()?;
                let jaw = self
                    .psm
                    .jaw()
                    .validate(names, positions, Some(&[self.jaw]))?;
                if self.jaw_motion.take().is_some() {
                    self.push_state();
                }
                self.jaw = jaw[0];
                self.jaw_effort = None;
                Ok(())
            }
            ArmInput::JawServoJf { names, efforts } => {
                self.ready()?;
                let effort = match (names.as_slice(), efforts.as_slice()) {
                    ([] | [_], [e]) if e.is_finite() && names.iter().all(|n| n == "jaw") => *e,
                    _ => return Err(ArmError::JawEffort(efforts.clone())),
                };
                let limit = self.jaw_effort_max;
                if effort.abs() > limit && !self.warned_jaw_effort {
                    self.warned_jaw_effort = true;
                    self.events.push(ArmEvent::Warning(format!(
                        "{}: jaw/servo_jf {effort} N·m is beyond the jaw's limit; clamped to ±{limit} N·m",
                        self.name()
                    )));
                }
                if self.jaw_motion.take().is_some() {
                    self.push_state();
                }
                self.jaw_effort = Some(effort.clamp(-limit, limit));
                Ok(())
            }
            ArmInput::MoveJp { names, positions } => {
                self.ready()?;
                let goal = self.psm.joints().validate(names, positions, None)?;
                self.start_move(goal, now)
            }
            ArmInput::JawMoveJp { names, positions } => {
                self.ready()?;
                let goal = self.psm.jaw().validate(names, positions, None)?;
                let trajectory = self.psm.plan_move_jaw(self.jaw, goal[0])?;
                self.jaw_effort = None;
                let was_busy = self.is_busy();
                self.jaw_motion = Some((trajectory, now));
                if !was_busy {
                    self.push_state();
                }
                Ok(())
            }
            ArmInput::ServoCp {
                position,
                quaternion,
            } => {
                self.ready()?;
                let target = isometry(position, quaternion)?;
                self.servo_cp(&target, RcmPolicy::Reject)
            }
            ArmInput::MoveCp {
                position,
                quaternion,
            } => {
                self.ready()?;
                let target = isometry(position, quaternion)?;
                let solution = self
                    .psm
                    .solve_cartesian(&target, &self.q, RcmPolicy::Reject)?;
                self.start_move(solution.ik.q, now)
            }
            ArmInput::MirrorJs { .. } | ArmInput::MirrorJaw { .. } => unreachable!(),
        }
    }

    /// A Cartesian servo target in the base frame (also teleop's): IK from the current joints,
    /// then the servo jump check, so a far target is refused rather than teleported to.
    pub fn servo_cp(&mut self, target: &Isometry3<f64>, policy: RcmPolicy) -> Result<(), ArmError> {
        let solution = self.psm.solve_cartesian(target, &self.q, policy)?;
        let q = self
            .psm
            .joints()
            .validate::<&str>(&[], &solution.ik.q, Some(&self.q))?;
        if let Motion::Move { .. } = self.motion {
            self.motion = Motion::Hold;
            self.push_state();
        }
        self.set_q(q);
        Ok(())
    }

    /// Teleop's jaw target (already rate-limited and clamped by the mapping).
    pub fn servo_jaw_clamped(&mut self, jaw: f64) {
        if jaw.is_finite() && self.jaw_motion.is_none() {
            let mut v = [jaw];
            self.psm.jaw().clamp(&mut v);
            self.jaw = v[0];
            self.jaw_effort = None;
        }
    }

    fn set_q(&mut self, q: Vec<f64>) {
        self.q = q;
    }

    fn start_move(&mut self, goal: Vec<f64>, now: f64) -> Result<(), ArmError> {
        let trajectory = self
            .psm
            .plan_move_jp(&self.q, &goal, self.trajectory_ratio)?;
        let was_busy = self.is_busy();
        self.motion = Motion::Move {
            trajectory,
            start: now,
        };
        if !was_busy {
            self.push_state();
        }
        self.events.push(ArmEvent::Status(format!(
            "{}: moving to {:?}",
            self.name(),
            goal.iter()
                .map(|v| (v * 1e4).round() / 1e4)
                .collect::<Vec<_>>()
        )));
        Ok(())
    }

    fn state_command(&mut self, command: &str) -> Result<(), ArmError> {
        match command {
            "enable" => match self.state {
                OperatingState::Fault | OperatingState::Disabled | OperatingState::Enabled => {
                    self.set_state(OperatingState::Enabled);
                    Ok(())
                }
                OperatingState::Paused => Err(ArmError::Paused),
            },
            "disable" => {
                self.stop_motion();
                self.set_state(OperatingState::Disabled);
                Ok(())
            }
            "pause" => {
                if self.state != OperatingState::Enabled {
                    return Err(ArmError::Transition {
                        action: "pause",
                        state: self.state,
                    });
                }
                self.stop_motion();
                self.set_state(OperatingState::Paused);
                Ok(())
            }
            "resume" => {
                if self.state != OperatingState::Paused {
                    return Err(ArmError::Transition {
                        action: "resume",
                        state: self.state,
                    });
                }
                self.set_state(OperatingState::Enabled);
                Ok(())
            }
            "home" => {
                if self.state != OperatingState::Enabled {
                    return Err(ArmError::Transition {
                        action: "home",
                        state: self.state,
                    });
                }
                if !self.homed {
                    self.homed = true;
                    self.push_state();
                }
                let home = self.home.clone();
                self.start_move(home, self.time)
            }
            "unhome" => {
                self.stop_motion();
                if self.homed {
                    self.homed = false;
                    self.push_state();
                }
                Ok(())
            }
            other => Err(ArmError::UnknownStateCommand(other.to_owned())),
        }
    }

    /// Moves the setpoint to simulated time `t` (the end of the coming frame).
    pub fn advance(&mut self, t: f64) {
        let dt = t - self.time;
        self.time = t;
        let previous = self.q.clone();
        let previous_jaw = self.jaw;
        let mut finished = false;
        if let Motion::Move { trajectory, start } = &self.motion {
            self.q = trajectory.setpoint(t - start);
            if trajectory.is_done(t - start) {
                self.q = trajectory.goal().to_vec();
                finished = true;
            }
        }
        if finished {
            self.motion = Motion::Hold;
        }
        let mut jaw_finished = false;
        if let Some((trajectory, start)) = &self.jaw_motion {
            self.jaw = trajectory.setpoint(t - start)[0];
            if trajectory.is_done(t - start) {
                self.jaw = trajectory.goal()[0];
                jaw_finished = true;
            }
        }
        if jaw_finished {
            self.jaw_motion = None;
        }
        if (finished || jaw_finished) && !self.is_busy() {
            self.push_state();
        }
        if dt > 0.0 {
            for ((v, a), b) in self.qdot.iter_mut().zip(&self.q).zip(&previous) {
                *v = (a - b) / dt;
            }
            self.jaw_rate = (self.jaw - previous_jaw) / dt;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HOME: [f64; 6] = [0.0, 0.0, 0.12, 0.0, 0.0, 0.0];

    fn arm(mode: ArmMode) -> ArmSim {
        ArmSim::new(
            Psm::classic("PSM1").unwrap(),
            mode,
            Isometry3::identity(),
            &HOME,
            0.0,
        )
        .unwrap()
    }

    fn command(topic: &'static str, input: ArmInput) -> ArmCommand {
        ArmCommand { topic, input }
    }

    fn servo(q: &[f64]) -> ArmCommand {
        command(
            "servo_jp",
            ArmInput::ServoJp {
                names: vec![],
                positions: q.to_vec(),
            },
        )
    }

    #[test]
    fn starts_enabled_and_homed_and_reports_it() {
        let mut a = arm(ArmMode::Simulated);
        let events = a.take_events();
        assert_eq!(
            events,
            [ArmEvent::State {
                time: 0.0,
                state: OperatingState::Enabled,
                homed: true,
                busy: false
            }]
        );
        assert_eq!(a.q(), HOME);
    }

    #[test]
    fn rejected_commands_keep_the_last_valid_one() {
        let mut a = arm(ArmMode::Simulated);
        let good = [0.05, 0.0, 0.125, 0.0, 0.0, 0.0];
        a.apply(&servo(&good), 0.0).unwrap();
        for bad in [
            vec![f64::NAN, 0.0, 0.12, 0.0, 0.0, 0.0],
            vec![0.0, 0.0, 0.12],
            vec![0.0, 0.0, 0.5, 0.0, 0.0, 0.0],
            vec![1.0, 0.0, 0.125, 0.0, 0.0, 0.0],
        ] {
            let r = a.apply(&servo(&bad), 0.0).unwrap_err();
            assert_eq!(r.topic, "servo_jp");
            assert_eq!(a.q(), good);
        }
        let cp = command(
            "servo_cp",
            ArmInput::ServoCp {
                position: [0.0, 0.0, -0.01],
                quaternion: [0.0, 0.0, 0.0, 1.0],
            },
        );
        assert!(a
            .apply(&cp, 0.0)
            .unwrap_err()
            .reason
            .to_string()
            .contains("RCM"));
        assert_eq!(a.q(), good);
    }

    #[test]
    fn move_jp_is_busy_until_the_goal_at_dvrk_speed() {
        let mut a = arm(ArmMode::Simulated);
        a.take_events();
        let goal = [0.3, 0.0, 0.12, 0.0, 0.0, 0.0];
        a.apply(
            &command(
                "move_jp",
                ArmInput::MoveJp {
                    names: vec![],
                    positions: goal.to_vec(),
                },
            ),
            0.0,
        )
        .unwrap();
        assert!(a.is_busy());
        // 0.3 rad at 90°/s with the quintic profile: 15/8 · 0.3 / (π/2) s.
        let duration = 15.0 / 8.0 * 0.3 / std::f64::consts::FRAC_PI_2;
        let mut t = 0.0;
        while t < duration - 0.02 {
            t += 0.01;
            a.advance(t);
            assert!(a.is_busy());
        }
        a.advance(duration + 0.01);
        assert!(!a.is_busy());
        assert_eq!(a.q(), goal);
        let busy: Vec<bool> = a
            .take_events()
            .iter()
            .filter_map(|e| match e {
                ArmEvent::State { busy, .. } => Some(*busy),
                _ => None,
            })
            .collect();
        assert_eq!(busy, [true, false]);
    }

    #[test]
    fn disabled_arms_refuse_motion_and_mirrors_follow_the_real_arm() {
        let mut a = arm(ArmMode::Simulated);
        a.apply(
            &command("state_command", ArmInput::StateCommand("disable".into())),
            0.0,
        )
        .unwrap();
        assert_eq!(a.operating_state(), OperatingState::Disabled);
        assert!(a
            .apply(&servo(&HOME), 0.0)
            .unwrap_err()
            .reason
            .to_string()
            .contains("DISABLED"));
        assert!(a
            .apply(
                &command("state_command", ArmInput::StateCommand("fly".into())),
                0.0
            )
            .is_err());

        let mut m = arm(ArmMode::Mirror);
        assert!(m.take_events().is_empty());
        let real = [0.1, 0.2, 0.15, 0.3, 0.0, 0.0];
        m.apply(
            &command(
                "measured_js",
                ArmInput::MirrorJs {
                    names: vec![],
                    positions: real.to_vec(),
                },
            ),
            0.0,
        )
        .unwrap();
        assert_eq!(m.q(), real);
        assert!(m.apply(&servo(&HOME), 0.0).is_err());
    }

    #[test]
    fn a_refused_move_sends_a_busy_pair_and_a_refused_servo_none() {
        let mut a = arm(ArmMode::Simulated);
        let busy_edges = |a: &mut ArmSim| -> Vec<bool> {
            a.take_events()
                .iter()
                .filter_map(|e| match e {
                    ArmEvent::State { busy, .. } => Some(*busy),
                    _ => None,
                })
                .collect()
        };
        busy_edges(&mut a);
        let beyond = vec![2.5, 0.0, 0.12, 0.0, 0.0, 0.0];
        let refused = ArmInput::MoveJp {
            names: vec![],
            positions: beyond.clone(),
        };
        assert!(a.apply(&command("move_jp", refused), 0.5).is_err());
        assert_eq!(busy_edges(&mut a), [true, false]);
        assert!(!a.is_busy());
        assert_eq!(a.q(), HOME);
        assert!(a.apply(&servo(&beyond), 0.6).is_err());
        assert!(busy_edges(&mut a).is_empty());
    }

    #[test]
    fn relative_moves_step_from_the_joints_and_the_ratio_slows_moves() {
        let mut a = arm(ArmMode::Simulated);
        let step = |a: &mut ArmSim, topic, input, t| a.apply(&command(topic, input), t);
        step(
            &mut a,
            "servo_jr",
            ArmInput::ServoJr {
                names: vec![],
                steps: vec![0.0, 0.0, 0.002, 0.0, 0.0, 0.0],
            },
            0.0,
        )
        .unwrap();
        assert!((a.q()[2] - 0.122).abs() < 1e-12);
        // move_jr of 0.3 rad on yaw at half of dVRK's speed: twice the full-speed duration.
        step(&mut a, "set_ratio", ArmInput::TrajectoryRatio(0.5), 0.0).unwrap();
        assert_eq!(a.status().trajectory_ratio, 0.5);
        step(
            &mut a,
            "move_jr",
            ArmInput::MoveJr {
                names: vec![],
                steps: vec![0.3, 0.0, 0.0, 0.0, 0.0, 0.0],
            },
            0.0,
        )
        .unwrap();
        let full_speed = 15.0 / 8.0 * 0.3 / std::f64::consts::FRAC_PI_2;
        a.advance(2.0 * full_speed - 0.02);
        assert!(a.is_busy());
        a.advance(2.0 * full_speed + 0.01);
        assert!(!a.is_busy());
        assert!((a.q()[0] - 0.3).abs() < 1e-9 && (a.q()[2] - 0.122).abs() < 1e-12);
        for bad in [0.0, 1.5, f64::NAN] {
            assert!(step(&mut a, "set_ratio", ArmInput::TrajectoryRatio(bad), 1.0).is_err());
        }
        for force in ["servo_jf", "spatial/servo_cf"] {
            let e = step(&mut a, force, ArmInput::ForceCommand, 1.0).unwrap_err();
            assert!(
                e.to_string().contains("cannot apply efforts or forces"),
                "{e}"
            );
        }
    }
}
