//! The dVRK Patient Side Manipulator: its kinematic chain from the URDF, joint and jaw limits,
//! the RCM safety distance for Cartesian commands, IK, and `move_jp` planning.

use std::collections::{HashMap, HashSet};
use std::path::Path;

use nalgebra::{Isometry3, Matrix6xX, Translation3, Vector3};

use crate::robot::chain::{Chain, ChainError, JointKind, UrdfTree};
use crate::robot::ik::{self, IkError, IkOptions, IkSolution};
use crate::robot::joints::{JointCommandError, JointGroup};
use crate::robot::trajectory::{Trajectory, TrajectoryError};
use crate::robot::urdf::{self, UrdfError, CLASSIC_PSM_URDF, URDF_ARM_PREFIX};

/// dVRK's `move_jp` speed limits for the PSM arm joints (rad/s; insertion m/s), from its arm
/// configuration: 90°/s on yaw and pitch, 0.2 m/s on insertion, 1080°/s on roll and the wrist.
/// A URDF's `velocity` attributes are not these (dvrk_model writes 0.4 everywhere), so they are
/// not read; a scene can set others (`joint_speeds`).
pub const DVRK_PSM_SPEEDS: [f64; 6] = [
    std::f64::consts::FRAC_PI_2,
    std::f64::consts::FRAC_PI_2,
    0.2,
    6.0 * std::f64::consts::PI,
    6.0 * std::f64::consts::PI,
    6.0 * std::f64::consts::PI,
];

/// dVRK's jaw speed limit (rad/s): 720°/s.
pub const DVRK_JAW_SPEED: f64 = 4.0 * std::f64::consts::PI;

/// dvrk_model's `tool_tip_link` lies this far (m) along the tool z axis beyond dVRK's tool frame
/// (the jaw pivot, where `measured_cp` is): the loader moves back by it when that link is the
/// tool frame it finds.
pub const DVRK_MODEL_TOOL_TIP_SETBACK: f64 = 0.0102;

/// Base link names tried, in order, for an arm prefix `P`: the project's, dvrk_model 2.x's, and
/// the older dvrk_model's.
const BASE_SUFFIXES: [&str; 3] = ["_base", "_base_link", "_psm_base_link"];

/// The arm joints, in dVRK's `JointState` order.
pub const PSM_JOINT_NAMES: [&str; 6] = [
    "yaw",
    "pitch",
    "insertion",
    "roll",
    "wrist_pitch",
    "wrist_yaw",
];

/// The instrument's jaw opening joint.
pub const JAW_JOINT_NAME: &str = "jaw";

/// dVRK's Cartesian IK keeps the tool at least this far from the remote centre of motion (m):
/// closer in, yaw and pitch barely move the tool and the instrument would leave the cannula.
pub const RCM_MIN_DISTANCE: f64 = 0.045;

#[derive(Debug, thiserror::Error)]
/// Why a PSM could not be built from its URDF, or a command could not be carried out.
pub enum PsmError {
    #[error(transparent)]
    /// The URDF could not be read or parsed.
    Urdf(#[from] UrdfError),
    #[error(transparent)]
    /// The URDF does not give the serial chain the PSM needs.
    Chain(#[from] ChainError),
    #[error("the URDF does not describe a PSM: {0}")]
    /// The URDF lacks what a PSM has (holds what is missing).
    NotAPsm(String),
    #[error(
        "no arm base link found: looked for {tried} (the remote centre of motion, frame of \
         measured_cp); name it with `base_link` on the [[arm]]"
    )]
    /// No base (RCM) link found by the usual names.
    NoBaseLink {
        /// The link names looked for, comma separated.
        tried: String,
    },
    #[error(
        "several links could be the arm base ({found}); name the one at the remote centre of \
         motion with `base_link` on the [[arm]]"
    )]
    /// More than one candidate base link.
    AmbiguousBase {
        /// The candidates found, comma separated.
        found: String,
    },
    #[error(
        "no tool link found: looked for {tried}; name the link whose frame measured_cp reports \
         with `tool_link` on the [[arm]]"
    )]
    /// No tool link found by the usual names.
    NoToolLink {
        /// The link names looked for, comma separated.
        tried: String,
    },
    #[error("`{key}` = \"{link}\" is not a link of the URDF")]
    /// A link named in the scene's `[[arm]]` that the URDF does not have.
    NoSuchRoleLink {
        /// The scene key, e.g. `base_link`.
        key: &'static str,
        /// The link name given.
        link: String,
    },
    #[error("{got} joint speed limits given, the arm has {expected} joints")]
    /// A list of speed limits whose length is not the arm's joint count.
    SpeedCount {
        /// The arm's joint count.
        expected: usize,
        /// The number of speeds given.
        got: usize,
    },
    #[error("speed limit of joint `{joint}` must be a finite number > 0, got {value}")]
    /// A joint speed limit that is not a finite number > 0.
    InvalidSpeed {
        /// The joint's name.
        joint: String,
        /// The value given, rad/s or m/s.
        value: f64,
    },
    #[error(
        "Cartesian target is {distance:.4} m from the RCM, closer than the {min:.3} m safety \
         distance"
    )]
    /// A Cartesian target closer to the RCM than the safety distance (under [`RcmPolicy::Reject`]).
    TooCloseToRcm {
        /// The target's distance from the RCM, m.
        distance: f64,
        /// The safety distance, m.
        min: f64,
    },
    #[error("Cartesian target pose is not finite")]
    /// A Cartesian target pose with NaN or infinite values.
    NonFinitePose,
    #[error(transparent)]
    /// A joint command failed validation.
    Joint(#[from] JointCommandError),
    #[error(transparent)]
    /// Inverse kinematics found no solution.
    Ik(#[from] IkError),
    #[error(transparent)]
    /// A move could not be planned.
    Trajectory(#[from] TrajectoryError),
}

/// What to do with a Cartesian target closer to the RCM than [`RCM_MIN_DISTANCE`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RcmPolicy {
    /// Refuse it with [`PsmError::TooCloseToRcm`].
    Reject,
    /// Move its position radially out to the safety distance (orientation unchanged).
    Clamp,
}

/// A Cartesian target that respects the RCM safety distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SafeTarget {
    /// The target pose in the base (RCM) frame, m.
    pub pose: Isometry3<f64>,
    /// The requested distance from the RCM (m), when the position had to be moved out.
    pub clamped_from: Option<f64>,
}

/// Joint values for a Cartesian command, with the target actually used.
#[derive(Debug, Clone, PartialEq)]
pub struct CartesianSolution {
    /// The target actually used (clamped out of the RCM safety distance, or as asked).
    pub target: SafeTarget,
    /// The joint values reaching it and the residual error.
    pub ik: IkSolution,
}

/// A link's pose in the arm's base (RCM) frame, for /tf.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkFrame {
    /// The URDF link name.
    pub link: String,
    /// The link's pose in the base (RCM) frame, m.
    pub pose: Isometry3<f64>,
}

/// Which URDF links play the arm's roles, as named in the file; `None` finds them by the default
/// rule of [`Psm::from_urdf_with_roles`].
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct UrdfRoles {
    /// The remote centre of motion, the frame of `measured_cp`.
    pub base_link: Option<String>,
    /// The link whose frame `measured_cp` reports, taken as it is.
    pub tool_link: Option<String>,
}

/// A link below the wrist: the joint from its parent.
#[derive(Debug, Clone)]
struct Attachment {
    parent: Parent,
    joint: Chain,
}

/// Where an [`Attachment`]'s parent link is.
#[derive(Debug, Clone, Copy)]
enum Parent {
    /// On the arm's path (index in its links).
    Path(usize),
    /// Another attachment (index in the attachments, always earlier).
    Attachment(usize),
}

/// Which dVRK arm a URDF describes (`[[arm]] kind`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ArmKind {
    /// A Patient Side Manipulator: six joints and a jaw, holding a scene tool.
    #[default]
    Psm,
    /// The Endoscope Camera Manipulator: four joints, the camera at its tip
    /// (see [`crate::robot::ecm`]).
    Ecm,
}

/// One dVRK arm, a PSM or the ECM: frames are named after the arm (`PSM1_base`, `PSM1`,
/// `PSM1_tool_tip`, ...).
#[derive(Debug, Clone)]
pub struct Psm {
    name: String,
    kind: ArmKind,
    base_frame: String,
    /// The chain's base link in the RCM frame (identity unless the URDF's RCM link hangs
    /// beside the chain rather than above it, as in dvrk_model's classic ECM).
    root: Isometry3<f64>,
    /// From the base (the RCM) to dVRK's tool frame (what `measured_cp` reports).
    arm: Chain,
    /// Every link below the wrist off the arm's path (tool tip, jaws), parents before
    /// children: one joint from its parent each; their only variable is `jaw`.
    attachments: Vec<Attachment>,
    /// The order [`Psm::link_frames`] lists `attachments` in: the file's order of links.
    attachment_order: Vec<usize>,
    joints: JointGroup,
    jaw: JointGroup,
    ik_options: IkOptions,
}

impl Psm {
    /// The classic PSM with the Large Needle Driver (`urdf/psm.urdf`, built in).
    pub fn classic(name: &str) -> Result<Psm, PsmError> {
        Psm::from_urdf(urdf::parse_urdf(CLASSIC_PSM_URDF)?, name)
    }

    /// Loads a PSM URDF file (see [`Psm::from_urdf_with_roles`]) as arm `name`.
    pub fn from_urdf_file(path: &Path, name: &str) -> Result<Psm, PsmError> {
        Psm::from_urdf(urdf::load_urdf_file(path)?, name)
    }

    /// [`Psm::from_urdf_with_roles`] with every role found by the default rule.
    pub fn from_urdf(robot: urdf_rs::Robot, name: &str) -> Result<Psm, PsmError> {
        Psm::from_urdf_with_roles(robot, name, &UrdfRoles::default())
    }

    /// Builds arm `name` from a parsed PSM URDF: the project's `urdf/psm.urdf`, or dvrk_model's
    /// (Classic or Si, current or older layout) expanded from its xacro.
    ///
    /// The rule, by role rather than by one name:
    /// - **Base** (the RCM, frame of `measured_cp`): `roles.base_link` (whose prefix `P` is what
    ///   precedes `_base`, `_base_link` or `_psm_base_link`, else its first `_`), else the link
    ///   `P_base`,
    ///   `P_base_link` or `P_psm_base_link` (tried in that order), where the prefix `P` is the
    ///   arm's name, else `PSM1`, else the only prefix such a link has; but `P_RCM_link`
    ///   (dvrk_model's current layout, where the Si's `P_base_link` is the arm's mounting
    ///   away from the RCM) wherever the tool hangs below it. Links above the base
    ///   (`world`) are ignored: the scene places the base.
    /// - The base is published as dVRK's frame `name_base` (`measured_cp`'s frame id).
    /// - **Names**: every link `P` / `P_*` is renamed `name` / `name_*`, so a file written for
    ///   PSM1 serves PSM2; joints keep dVRK's unprefixed names.
    /// - **Tool frame** (what `measured_cp` reports, dVRK's tool frame on the jaw pivot):
    ///   `roles.tool_link` as it is, else the project's link `name`, else dvrk_model's
    ///   `name_tool_tip_link` moved back [`DVRK_MODEL_TOOL_TIP_SETBACK`] along its z (same
    ///   rotation), published as frame `name`.
    /// - The path from base to tool must pass exactly the six PSM joints (mimics of them, such
    ///   as the parallelogram's `pitch_2`..., count as their master); side branches are not
    ///   part of the chain.
    /// - **Jaws**: every link below the wrist (the child of `wrist_yaw`) off that path may move
    ///   only with `jaw` (`jaw` itself, or `jaw_1` / `jaw_2` mimicking it), and one must.
    /// - **Limits** are the file's; speed limits are dVRK's ([`DVRK_PSM_SPEEDS`],
    ///   [`DVRK_JAW_SPEED`]), not the file's `velocity`. Meshes are not read.
    pub fn from_urdf_with_roles(
        mut robot: urdf_rs::Robot,
        name: &str,
        roles: &UrdfRoles,
    ) -> Result<Psm, PsmError> {
        let tool_frames = [
            (name.to_owned(), None),
            (
                format!("{name}_tool_tip_link"),
                Some(DVRK_MODEL_TOOL_TIP_SETBACK),
            ),
        ];
        let (base_link, tool_link, setback) = locate_roles(&mut robot, name, roles, &tool_frames)?;
        let tree = UrdfTree::new(&robot);
        let mut arm = Chain::from_tree(&tree, &base_link, &tool_link)?;
        if let Some(setback) = setback {
            arm = arm.with_fixed_tip(name, Isometry3::translation(0.0, 0.0, -setback));
        }
        let arm_names: Vec<&str> = arm.joints().iter().map(|j| j.name.as_str()).collect();
        if arm_names != PSM_JOINT_NAMES {
            return Err(PsmError::NotAPsm(format!(
                "the joints from {base_link} to {tool_link} are {arm_names:?}, expected {PSM_JOINT_NAMES:?}"
            )));
        }
        if arm.joints()[2].kind != JointKind::Prismatic {
            return Err(PsmError::NotAPsm("`insertion` must be prismatic".into()));
        }

        // The wrist: the child of `wrist_yaw` (on the path, since wrist_yaw is a chain variable
        // and mimics of it are not allowed below).
        let path = arm.link_names();
        let wrist = robot
            .joints
            .iter()
            .find(|j| j.name == PSM_JOINT_NAMES[5])
            .and_then(|j| path.iter().position(|l| *l == j.child.link))
            .ok_or_else(|| {
                PsmError::NotAPsm(format!(
                    "`{}` is not on the path from {base_link} to {tool_link} itself (only \
                     through a mimic)",
                    PSM_JOINT_NAMES[5]
                ))
            })?;
        // Breadth first from the wrist, one joint at a time: linear in the links below it.
        let on_path: HashMap<&str, usize> = path.iter().enumerate().map(|(i, l)| (*l, i)).collect();
        let mut attachments: Vec<Attachment> = Vec::new();
        let mut queue = std::collections::VecDeque::from([(path[wrist], Parent::Path(wrist))]);
        let mut seen = HashSet::from([path[wrist]]);
        while let Some((link, parent)) = queue.pop_front() {
            for joint in tree.child_joints(link) {
                let child = joint.child.link.as_str();
                if !seen.insert(child) {
                    continue;
                }
                let place = match on_path.get(child) {
                    Some(&i) => Parent::Path(i),
                    None => {
                        attachments.push(Attachment {
                            parent,
                            joint: Chain::from_tree(&tree, link, child)?,
                        });
                        Parent::Attachment(attachments.len() - 1)
                    }
                };
                queue.push_back((child, place));
            }
        }
        let link_index: HashMap<&str, usize> = robot
            .links
            .iter()
            .enumerate()
            .map(|(i, l)| (l.name.as_str(), i))
            .collect();
        let mut attachment_order: Vec<usize> = (0..attachments.len()).collect();
        attachment_order.sort_by_key(|&a| link_index.get(attachments[a].joint.tip_link()));
        let mut jaw = None;
        for chain in attachments.iter().map(|a| &a.joint) {
            for joint in chain.joints() {
                if joint.name != JAW_JOINT_NAME {
                    return Err(PsmError::NotAPsm(format!(
                        "joint `{}` moves link `{}` below the wrist; only `{JAW_JOINT_NAME}` \
                         (and its mimics) may",
                        joint.name,
                        chain.tip_link()
                    )));
                }
                jaw = Some(joint.clone());
            }
        }
        let mut jaw = jaw.ok_or_else(|| {
            PsmError::NotAPsm(format!(
                "no `{JAW_JOINT_NAME}` joint below the wrist {}",
                path[wrist]
            ))
        })?;

        let mut arm_joints = arm.joints().to_vec();
        for joint in arm_joints.iter().chain([&jaw]) {
            if !(joint.lower.is_finite() && joint.upper.is_finite()) {
                return Err(PsmError::NotAPsm(format!(
                    "joint `{}` needs finite position limits, got [{}, {}]",
                    joint.name, joint.lower, joint.upper
                )));
            }
        }
        for (joint, speed) in arm_joints.iter_mut().zip(DVRK_PSM_SPEEDS) {
            joint.max_velocity = speed;
        }
        jaw.max_velocity = DVRK_JAW_SPEED;
        let meshes = urdf::mesh_count(&robot);
        if meshes > 0 {
            tracing::info!(
                "arm {name}: {meshes} mesh(es) in the URDF are not read (kinematics only)"
            );
        }
        tracing::info!(
            "arm {name}: base link {base_link}, tool frame {name}{}; joint limits from the URDF, \
             speed limits dVRK's",
            if setback.is_some() {
                format!(" ({tool_link} moved back {DVRK_MODEL_TOOL_TIP_SETBACK} m)")
            } else if tool_link != name {
                format!(" = {tool_link}")
            } else {
                String::new()
            }
        );
        Ok(Psm {
            name: name.to_owned(),
            kind: ArmKind::Psm,
            base_frame: format!("{name}_base"),
            root: Isometry3::identity(),
            arm,
            attachments,
            attachment_order,
            joints: JointGroup::new(arm_joints),
            jaw: JointGroup::new(vec![jaw]),
            ik_options: IkOptions::default(),
        })
    }

    /// Replaces the `move_jp` speed limits (arm joints in canonical order, then the jaw where
    /// the arm has one), e.g. from a scene; resets the servo jump bounds that derive from them.
    pub fn set_speed_limits(&mut self, arm: &[f64], jaw: Option<f64>) -> Result<(), PsmError> {
        if arm.len() != self.joints.len() {
            return Err(PsmError::SpeedCount {
                expected: self.joints.len(),
                got: arm.len(),
            });
        }
        let mut joints = self.joints.joints().to_vec();
        let mut jaw_joint = self.jaw.joints().to_vec();
        let jaw = jaw.into_iter().take(jaw_joint.len());
        for (joint, value) in joints
            .iter_mut()
            .chain(jaw_joint.iter_mut())
            .zip(arm.iter().copied().chain(jaw))
        {
            if !(value.is_finite() && value > 0.0) {
                return Err(PsmError::InvalidSpeed {
                    joint: joint.name.clone(),
                    value,
                });
            }
            joint.max_velocity = value;
        }
        self.joints = JointGroup::new(joints);
        self.jaw = JointGroup::new(jaw_joint);
        Ok(())
    }

    /// An arm built by the ECM's loader ([`crate::robot::ecm`]): no jaw, no attachments.
    pub(crate) fn without_jaw(
        name: &str,
        kind: ArmKind,
        root: Isometry3<f64>,
        arm: Chain,
        joints: JointGroup,
    ) -> Psm {
        Psm {
            name: name.to_owned(),
            kind,
            base_frame: format!("{name}_base"),
            root,
            arm,
            attachments: Vec::new(),
            attachment_order: Vec::new(),
            joints,
            jaw: JointGroup::new(Vec::new()),
            ik_options: IkOptions::default(),
        }
    }

    /// A PSM or the ECM.
    pub fn kind(&self) -> ArmKind {
        self.kind
    }

    /// The arm name (`PSM1`), which is also the tool frame's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The RCM frame's name, `<name>_base` (dVRK's), whatever the URDF calls the base link: the
    /// frame of `measured_cp`.
    pub fn base_frame(&self) -> &str {
        &self.base_frame
    }

    /// The six arm joints: names, limits, `move_jp` speed limits, servo jump bounds.
    pub fn joints(&self) -> &JointGroup {
        &self.joints
    }

    /// The arm joints, to change their jump bounds ([`JointGroup::set_max_jump`]).
    pub fn joints_mut(&mut self) -> &mut JointGroup {
        &mut self.joints
    }

    /// The jaw joint.
    pub fn jaw(&self) -> &JointGroup {
        &self.jaw
    }

    /// The jaw joint, to change its jump bound ([`JointGroup::set_max_jump`]).
    pub fn jaw_mut(&mut self) -> &mut JointGroup {
        &mut self.jaw
    }

    /// The chain from the RCM to the tool frame.
    pub fn chain(&self) -> &Chain {
        &self.arm
    }

    /// The inverse kinematics solver's settings.
    pub fn ik_options(&self) -> &IkOptions {
        &self.ik_options
    }

    /// Replaces the inverse kinematics solver's settings.
    pub fn set_ik_options(&mut self, options: IkOptions) {
        self.ik_options = options;
    }

    /// The tool frame (`measured_cp`) in the RCM frame.
    pub fn forward(&self, q: &[f64]) -> Result<Isometry3<f64>, PsmError> {
        Ok(self.root * self.arm.tip_pose(q)?)
    }

    /// The tool frame's geometric Jacobian in the RCM frame (see [`Chain::jacobian`]).
    pub fn jacobian(&self, q: &[f64]) -> Result<Matrix6xX<f64>, PsmError> {
        let mut j = self.arm.jacobian(q)?;
        if self.root != Isometry3::identity() {
            let r = self.root.rotation.to_rotation_matrix();
            for mut column in j.column_iter_mut() {
                let linear = r * column.fixed_rows::<3>(0).into_owned();
                let angular = r * column.fixed_rows::<3>(3).into_owned();
                column.fixed_rows_mut::<3>(0).copy_from(&linear);
                column.fixed_rows_mut::<3>(3).copy_from(&angular);
            }
        }
        Ok(j)
    }

    /// The pose of every link on the arm's path and below the wrist in the RCM frame (base
    /// first, then the arm, the tool frame, the tool tip and the jaws), for /tf.
    pub fn link_frames(&self, q: &[f64], jaw: f64) -> Result<Vec<LinkFrame>, PsmError> {
        let poses = self.arm.link_poses(q)?;
        let jaw_q = [jaw];
        let mut below: Vec<Isometry3<f64>> = Vec::with_capacity(self.attachments.len());
        for attachment in &self.attachments {
            let parent = match attachment.parent {
                Parent::Path(i) => poses[i],
                Parent::Attachment(i) => below[i],
            };
            let q = &jaw_q[..attachment.joint.dof()];
            below.push(parent * attachment.joint.tip_pose(q)?);
        }
        let mut frames: Vec<LinkFrame> = self
            .arm
            .link_names()
            .into_iter()
            .zip(poses)
            .map(|(link, pose)| LinkFrame {
                link: link.to_owned(),
                pose: self.root * pose,
            })
            .collect();
        for &i in &self.attachment_order {
            frames.push(LinkFrame {
                link: self.attachments[i].joint.tip_link().to_owned(),
                pose: self.root * below[i],
            });
        }
        Ok(frames)
    }

    /// Applies the RCM safety distance to a Cartesian target (in the RCM frame).
    pub fn enforce_rcm_distance(
        &self,
        target: &Isometry3<f64>,
        policy: RcmPolicy,
    ) -> Result<SafeTarget, PsmError> {
        let finite = target.translation.vector.iter().all(|v| v.is_finite())
            && target.rotation.coords.iter().all(|v| v.is_finite());
        if !finite {
            return Err(PsmError::NonFinitePose);
        }
        let position = target.translation.vector;
        let distance = position.norm();
        if distance >= RCM_MIN_DISTANCE {
            return Ok(SafeTarget {
                pose: *target,
                clamped_from: None,
            });
        }
        match policy {
            RcmPolicy::Reject => Err(PsmError::TooCloseToRcm {
                distance,
                min: RCM_MIN_DISTANCE,
            }),
            RcmPolicy::Clamp => {
                // At the RCM itself there is no radial direction: go out along the tool's own
                // axis, which points away from the RCM for any pose the arm can take.
                let direction = if distance > 1e-9 {
                    position / distance
                } else {
                    target.rotation * Vector3::z()
                };
                Ok(SafeTarget {
                    pose: Isometry3::from_parts(
                        Translation3::from(direction * RCM_MIN_DISTANCE),
                        target.rotation,
                    ),
                    clamped_from: Some(distance),
                })
            }
        }
    }

    /// Joint values for a Cartesian target of the tool frame (servo_cp / move_cp): RCM safety
    /// first, then IK warm-started from `current`.
    pub fn solve_cartesian(
        &self,
        target: &Isometry3<f64>,
        current: &[f64],
        policy: RcmPolicy,
    ) -> Result<CartesianSolution, PsmError> {
        let target = self.enforce_rcm_distance(target, policy)?;
        let ik = ik::solve(&self.arm, &target.pose, current, &self.ik_options)?;
        Ok(CartesianSolution { target, ik })
    }

    /// A `move_jp` from `start` to `goal` (canonical order) at `ratio` (0, 1] of the arm's speed
    /// limits (`trajectory_j/set_ratio`); `goal` must be inside the joint limits.
    pub fn plan_move_jp(
        &self,
        start: &[f64],
        goal: &[f64],
        ratio: f64,
    ) -> Result<Trajectory, PsmError> {
        let goal = self.joints.validate::<&str>(&[], goal, None)?;
        let speeds: Vec<f64> = self
            .joints
            .max_velocities()
            .iter()
            .map(|v| v * ratio)
            .collect();
        Ok(Trajectory::new(start, &goal, &speeds)?)
    }

    /// A `jaw/move_jp` from `start` to `goal` under the jaw's speed limit.
    pub fn plan_move_jaw(&self, start: f64, goal: f64) -> Result<Trajectory, PsmError> {
        let goal = self.jaw.validate::<&str>(&[], &[goal], None)?;
        Ok(Trajectory::new(
            &[start],
            &goal,
            &self.jaw.max_velocities(),
        )?)
    }
}

/// Finds the arm's base and tool links by the rule of [`Psm::from_urdf_with_roles`] and
/// renames the file's links for arm `name`: returns the base link, the tool link and how far
/// the tool frame lies behind it along its z (m), where the tool link is one of
/// `tool_frames` (link, setback) found by default.
pub(crate) fn locate_roles(
    robot: &mut urdf_rs::Robot,
    name: &str,
    roles: &UrdfRoles,
    tool_frames: &[(String, Option<f64>)],
) -> Result<(String, String, Option<f64>), PsmError> {
    urdf::check_arm_name(name)?;
    let has_link = |robot: &urdf_rs::Robot, link: &str| robot.links.iter().any(|l| l.name == link);

    let (prefix, file_base) = match &roles.base_link {
        Some(base) => {
            if !has_link(robot, base) {
                return Err(PsmError::NoSuchRoleLink {
                    key: "base_link",
                    link: base.clone(),
                });
            }
            let prefix = base_prefix(base).map(|(p, _)| p).or_else(|| {
                base.split_once('_')
                    .map(|(p, _)| p)
                    .filter(|p| urdf::check_arm_name(p).is_ok())
            });
            (prefix.map(str::to_owned), base.clone())
        }
        None => {
            let (prefix, base) = find_base(robot, name)?;
            (Some(prefix), base)
        }
    };
    let (base_link, tool_link) = match &prefix {
        Some(prefix) => {
            urdf::rename_arm_prefix(robot, prefix, name)?;
            (
                urdf::rename_link(&file_base, prefix, name),
                roles
                    .tool_link
                    .as_ref()
                    .map(|t| urdf::rename_link(t, prefix, name)),
            )
        }
        None => (file_base, roles.tool_link.clone()),
    };
    let (tool_link, setback) = match tool_link {
        Some(tool) if has_link(robot, &tool) => (tool, None),
        Some(_) => {
            return Err(PsmError::NoSuchRoleLink {
                key: "tool_link",
                link: roles.tool_link.clone().unwrap_or_default(),
            })
        }
        None => match tool_frames.iter().find(|(link, _)| has_link(robot, link)) {
            Some((link, setback)) => (link.clone(), *setback),
            None => {
                return Err(PsmError::NoToolLink {
                    tried: tool_frames
                        .iter()
                        .map(|(link, _)| format!("`{link}`"))
                        .collect::<Vec<_>>()
                        .join(", "),
                })
            }
        },
    };
    // dvrk_model's current layout names the remote centre of motion `P_RCM_link`; in its Si
    // layout `P_base_link` is the arm's mounting, on the yaw axis 0.8 m from the RCM, so
    // the RCM link is the base wherever the tool hangs below it.
    let rcm_link = format!("{name}_RCM_link");
    let base_link = if roles.base_link.is_none()
        && has_link(robot, &rcm_link)
        && Chain::from_urdf(robot, &rcm_link, &tool_link).is_ok()
    {
        rcm_link
    } else {
        base_link
    };
    Ok((base_link, tool_link, setback))
}

/// The arm prefix of a base link name and the rank of its suffix in [`BASE_SUFFIXES`]
/// (`PSM1_psm_base_link` → `PSM1`, not `PSM1_psm`).
fn base_prefix(link: &str) -> Option<(&str, usize)> {
    BASE_SUFFIXES
        .iter()
        .enumerate()
        .rev()
        .find_map(|(rank, suffix)| {
            link.strip_suffix(suffix)
                .filter(|p| urdf::check_arm_name(p).is_ok())
                .map(|p| (p, rank))
        })
}

/// The default base rule of [`Psm::from_urdf_with_roles`]: the file's arm prefix and base link.
fn find_base(robot: &urdf_rs::Robot, name: &str) -> Result<(String, String), PsmError> {
    let candidates: Vec<(&str, usize, &str)> = robot
        .links
        .iter()
        .filter_map(|l| base_prefix(&l.name).map(|(p, rank)| (p, rank, l.name.as_str())))
        .collect();
    let mut prefixes: Vec<&str> = candidates.iter().map(|c| c.0).collect();
    prefixes.sort_unstable();
    prefixes.dedup();
    let prefix = if prefixes.contains(&name) {
        name
    } else if prefixes.contains(&URDF_ARM_PREFIX) {
        URDF_ARM_PREFIX
    } else {
        match prefixes[..] {
            [] => {
                return Err(PsmError::NoBaseLink {
                    tried: BASE_SUFFIXES
                        .iter()
                        .map(|s| format!("`{name}{s}`"))
                        .collect::<Vec<_>>()
                        .join(", "),
                })
            }
            [only] => only,
            _ => {
                return Err(PsmError::AmbiguousBase {
                    found: candidates
                        .iter()
                        .map(|c| format!("`{}`", c.2))
                        .collect::<Vec<_>>()
                        .join(", "),
                })
            }
        }
    };
    let (_, _, base) = candidates
        .iter()
        .filter(|c| c.0 == prefix)
        .min_by_key(|c| c.1)
        .copied()
        .unwrap_or((prefix, 0, prefix));
    Ok((prefix.to_owned(), base.to_owned()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn psm() -> Psm {
        Psm::classic("PSM2").unwrap()
    }

    #[test]
    fn classic_psm_has_dvrk_names_and_limits() {
        let psm = psm();
        assert_eq!(psm.joints().names(), PSM_JOINT_NAMES);
        assert_eq!(psm.jaw().names(), [JAW_JOINT_NAME]);
        assert_eq!(psm.base_frame(), "PSM2_base");
        assert_eq!(psm.chain().tip_link(), "PSM2");
        assert_eq!(
            psm.joints().limits(),
            [
                (-1.588, 1.588),
                (-0.925, 0.925),
                (0.0, 0.24),
                (-4.538, 4.538),
                (-1.396, 1.396),
                (-1.396, 1.396)
            ]
        );
        let jaw = &psm.jaw().joints()[0];
        assert_eq!((jaw.lower, jaw.upper), (-0.698, 1.396));
        // dVRK's move_jp speeds: 90°/s, 0.2 m/s, 1080°/s; jaw 720°/s.
        let deg = PI / 180.0;
        let expected = [
            90.0 * deg,
            90.0 * deg,
            0.2,
            1080.0 * deg,
            1080.0 * deg,
            1080.0 * deg,
        ];
        for (got, want) in psm.joints().max_velocities().iter().zip(expected) {
            assert!((got - want).abs() < 1e-12, "{got} vs {want}");
        }
        assert!((psm.jaw().max_velocities()[0] - 720.0 * deg).abs() < 1e-12);
    }

    #[test]
    fn link_frames_cover_every_link_with_the_arm_prefix() {
        let psm = psm();
        let q = [0.2, -0.3, 0.12, 0.5, 0.1, -0.2];
        let frames = psm.link_frames(&q, 0.6).unwrap();
        let names: Vec<&str> = frames.iter().map(|f| f.link.as_str()).collect();
        let robot = urdf::parse_urdf(CLASSIC_PSM_URDF).unwrap();
        assert_eq!(names.len(), robot.links.len());
        for link in &robot.links {
            let renamed = link.name.replacen("PSM1", "PSM2", 1);
            assert!(names.contains(&renamed.as_str()), "{renamed} missing");
        }
        let find = |name: &str| frames.iter().find(|f| f.link == name).unwrap().pose;
        let tool = psm.forward(&q).unwrap();
        assert_eq!(find("PSM2"), tool);
        // The tool tip is 10.2 mm along the tool z axis.
        let tip = find("PSM2_tool_tip").translation.vector;
        let expected = tool * nalgebra::Point3::new(0.0, 0.0, 0.0102);
        assert!((tip - expected.coords).norm() < 1e-12);
        // The jaws open symmetrically by half the jaw angle each.
        let jaw_1 = find("PSM2_jaw_1").rotation;
        let jaw_2 = find("PSM2_jaw_2").rotation;
        assert!((jaw_1.angle_to(&tool.rotation) - 0.3).abs() < 1e-12);
        assert!((jaw_2.angle_to(&tool.rotation) - 0.3).abs() < 1e-12);
        assert!((jaw_1.angle_to(&jaw_2) - 0.6).abs() < 1e-12);
        assert!(psm.link_frames(&q[..5], 0.0).is_err());
    }

    #[test]
    fn rcm_distance_rejects_close_targets() {
        let psm = psm();
        for distance in [0.0, 0.01, 0.03, 0.0449] {
            let pose = Isometry3::translation(0.0, 0.0, -distance);
            match psm.enforce_rcm_distance(&pose, RcmPolicy::Reject) {
                Err(PsmError::TooCloseToRcm { distance: d, min }) => {
                    assert!((d - distance).abs() < 1e-15);
                    assert_eq!(min, RCM_MIN_DISTANCE);
                }
                other => panic!("{distance}: {other:?}"),
            }
        }
        let far = Isometry3::translation(0.03, 0.0, -0.04);
        let safe = psm.enforce_rcm_distance(&far, RcmPolicy::Reject).unwrap();
        assert_eq!((safe.pose, safe.clamped_from), (far, None));
    }

    #[test]
    fn rcm_distance_clamps_radially() {
        let psm = psm();
        let pose = Isometry3::translation(0.0, 0.01, -0.02);
        let safe = psm.enforce_rcm_distance(&pose, RcmPolicy::Clamp).unwrap();
        let p = safe.pose.translation.vector;
        assert!((p.norm() - RCM_MIN_DISTANCE).abs() < 1e-15);
        assert!(
            p.normalize()
                .cross(&pose.translation.vector.normalize())
                .norm()
                < 1e-12
        );
        assert!((safe.clamped_from.unwrap() - 0.0005f64.sqrt()).abs() < 1e-15);
        // At the RCM itself: out along the tool axis.
        let at_rcm = psm
            .enforce_rcm_distance(&Isometry3::identity(), RcmPolicy::Clamp)
            .unwrap();
        assert_eq!(
            at_rcm.pose.translation.vector,
            Vector3::new(0.0, 0.0, RCM_MIN_DISTANCE)
        );
    }

    #[test]
    fn cartesian_commands_too_close_to_the_rcm_are_refused_before_ik() {
        let psm = psm();
        let current = [0.0, 0.0, 0.12, 0.0, 0.0, 0.0];
        let mut target = psm.forward(&[0.0, 0.0, 0.04, 0.0, 0.0, 0.0]).unwrap();
        assert!(target.translation.vector.norm() < RCM_MIN_DISTANCE);
        assert!(matches!(
            psm.solve_cartesian(&target, &current, RcmPolicy::Reject),
            Err(PsmError::TooCloseToRcm { .. })
        ));
        let clamped = psm
            .solve_cartesian(&target, &current, RcmPolicy::Clamp)
            .unwrap();
        let reached = psm.forward(&clamped.ik.q).unwrap();
        assert!((reached.translation.vector.norm() - RCM_MIN_DISTANCE).abs() < 1e-6);
        target.translation.vector.x = f64::NAN;
        assert!(matches!(
            psm.solve_cartesian(&target, &current, RcmPolicy::Clamp),
            Err(PsmError::NonFinitePose)
        ));
    }

    #[test]
    fn move_jp_goal_outside_limits_is_refused() {
        let psm = psm();
        let start = [0.0, 0.0, 0.1, 0.0, 0.0, 0.0];
        assert!(matches!(
            psm.plan_move_jp(&start, &[0.0, 0.0, 0.3, 0.0, 0.0, 0.0], 1.0),
            Err(PsmError::Joint(JointCommandError::OutOfLimits { .. }))
        ));
        assert!(matches!(
            psm.plan_move_jaw(0.0, 2.0),
            Err(PsmError::Joint(JointCommandError::OutOfLimits { .. }))
        ));
    }

    #[test]
    fn move_jp_respects_each_joint_speed_limit() {
        let psm = psm();
        let start = [-1.0, 0.5, 0.02, -3.0, 1.0, -1.0];
        let goal = [1.0, -0.5, 0.22, 3.0, -1.0, 1.0];
        let traj = psm.plan_move_jp(&start, &goal, 1.0).unwrap();
        let limits = psm.joints().max_velocities();
        // Yaw (2 rad at 90°/s) is the slowest: T = 15/8 · 2 / (π/2).
        assert!((traj.duration() - 15.0 / 8.0 * 2.0 / (PI / 2.0)).abs() < 1e-12);
        let dt = 1e-3;
        let mut previous = traj.setpoint(0.0);
        let mut t = 0.0;
        while !traj.is_done(t) {
            t += dt;
            let q = traj.setpoint(t);
            for i in 0..6 {
                assert!((q[i] - previous[i]).abs() / dt <= limits[i] * (1.0 + 1e-9));
            }
            previous = q;
        }
        assert_eq!(previous, goal);
        let jaw = psm.plan_move_jaw(0.0, 1.2).unwrap();
        assert!((jaw.duration() - 15.0 / 8.0 * 1.2 / (4.0 * PI)).abs() < 1e-12);
    }

    fn fixture(file: &str) -> urdf_rs::Robot {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/urdf")
            .join(file);
        urdf::load_urdf_file(&path).unwrap()
    }

    #[test]
    fn roles_can_be_named_and_bad_names_are_explained() {
        let roles = UrdfRoles {
            base_link: Some("PSM1_base_link".into()),
            tool_link: Some("PSM1_wrist_yaw_link".into()),
        };
        let psm =
            Psm::from_urdf_with_roles(fixture("PSM1_current_layout.urdf"), "PSM2", &roles).unwrap();
        assert_eq!(psm.chain().link_names()[0], "PSM2_base_link");
        assert_eq!(psm.chain().tip_link(), "PSM2_wrist_yaw_link");
        let missing = UrdfRoles {
            tool_link: Some("PSM1_tip".into()),
            ..UrdfRoles::default()
        };
        let err = Psm::from_urdf_with_roles(fixture("PSM1_current_layout.urdf"), "PSM1", &missing)
            .unwrap_err();
        assert!(
            matches!(&err, PsmError::NoSuchRoleLink { key: "tool_link", link } if link == "PSM1_tip"),
            "{err}"
        );
        let no_base = CLASSIC_PSM_URDF.replace("PSM1_base", "PSM1_root");
        let err = Psm::from_urdf(urdf::parse_urdf(&no_base).unwrap(), "PSM1").unwrap_err();
        assert!(err.to_string().contains("`PSM1_base_link`"), "{err}");
        let two_bases = CLASSIC_PSM_URDF
            .replace("PSM1", "ECM")
            .replace("</robot>", r#"<link name="SUJ_base"/></robot>"#);
        assert!(matches!(
            Psm::from_urdf(urdf::parse_urdf(&two_bases).unwrap(), "PSM1"),
            Err(PsmError::AmbiguousBase { .. })
        ));
    }

    #[test]
    fn speeds_are_dvrks_unless_set() {
        let mut psm = Psm::from_urdf(fixture("PSM1_current_layout.urdf"), "PSM1").unwrap();
        assert_eq!(psm.joints().max_velocities(), DVRK_PSM_SPEEDS);
        assert_eq!(psm.jaw().max_velocities(), [DVRK_JAW_SPEED]);
        // Limits are the file's.
        // The fixture's pitch range is ±π/4 to four digits, narrower than the built-in ±0.925.
        let pitch = &psm.joints().joints()[1];
        assert!((pitch.upper - std::f64::consts::FRAC_PI_4).abs() < 1e-4);
        assert_eq!(psm.jaw().joints()[0].lower, -0.349);
        psm.set_speed_limits(&[1.0, 1.0, 0.1, 2.0, 2.0, 2.0], Some(3.0))
            .unwrap();
        assert_eq!(
            psm.joints().max_velocities(),
            [1.0, 1.0, 0.1, 2.0, 2.0, 2.0]
        );
        assert_eq!(
            psm.joints().max_jump()[2],
            0.1 * crate::robot::joints::DEFAULT_JUMP_WINDOW_S
        );
        assert!(matches!(
            psm.set_speed_limits(&[1.0, 0.0, 0.1, 2.0, 2.0, 2.0], Some(3.0)),
            Err(PsmError::InvalidSpeed { joint, .. }) if joint == "pitch"
        ));
    }

    #[test]
    fn urdf_without_the_psm_joints_is_not_a_psm() {
        let renamed = CLASSIC_PSM_URDF.replace("name=\"roll\"", "name=\"spin\"");
        assert!(matches!(
            Psm::from_urdf(urdf::parse_urdf(&renamed).unwrap(), "PSM1"),
            Err(PsmError::NotAPsm(_))
        ));
        let jaws_mimic_wrist = CLASSIC_PSM_URDF.replace("joint=\"jaw\"", "joint=\"wrist_yaw\"");
        assert!(matches!(
            Psm::from_urdf(urdf::parse_urdf(&jaws_mimic_wrist).unwrap(), "PSM1"),
            Err(PsmError::NotAPsm(_))
        ));
        assert!(matches!(
            Psm::classic("PSM 1"),
            Err(PsmError::Urdf(UrdfError::InvalidArmName(_)))
        ));
        assert!(matches!(
            Psm::from_urdf_file(Path::new("/nonexistent.urdf"), "PSM1"),
            Err(PsmError::Urdf(UrdfError::Read { .. }))
        ));
    }
}
