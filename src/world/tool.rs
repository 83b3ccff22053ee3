//! A tool in the world: what drives it (the scene's keyframes or commanded poses) and a
//! gripper's jaws between frames.

use super::needle_body::NeedleBody;
use crate::mpm::GripSums;
use crate::sleep::Aabb;
use crate::tools::{
    ContactModel, JawGains, JawServo, Shape, ToolKinematics, ToolPose, ToolVelocity, Trajectory,
};

/// What moves a tool.
#[derive(Clone, Debug, PartialEq)]
pub enum ToolDriver {
    /// The scene's keyframes (headless runs).
    Scripted(Trajectory),
    /// Poses commanded from outside (an arm's kinematics): the tool moves from `from` at
    /// `t0` to `to` at `t1` (one frame), linearly, so contact sees a smooth velocity.
    Commanded {
        /// The pose at the frame's start.
        from: ToolPose,
        /// The pose at the frame's end.
        to: ToolPose,
        /// Simulated time of the frame's start, s.
        t0: f64,
        /// Simulated time of the frame's end, s.
        t1: f64,
    },
}

/// A tool in the world and what drives it.
pub struct WorldTool {
    /// The tool's name in the scene.
    pub name: String,
    /// The tool's shape (tool frame).
    pub shape: Shape,
    /// How grid nodes in contact move with the tool.
    pub contact: ContactModel,
    /// Set through [`World::command_tool_pose`] and [`World::hold_tool`].
    pub(super) driver: ToolDriver,
    /// A gripper's jaws: the driver's jaw angle is their setpoint.
    pub(super) jaws: Option<Jaws>,
    /// A needle's rigid body: what carries it, and its motion when nothing does.
    pub(super) body: Option<NeedleBody>,
}

/// A gripper's jaws between frames (see [`crate::tools::jaw`] and [`crate::tools::grip`]).
#[derive(Clone, Debug)]
pub(super) struct Jaws {
    pub(super) servo: JawServo,
    /// An effort command (N·m) that replaces the position servo until a pose command.
    pub(super) effort: Option<f64>,
    /// The opening at the start and end of the frame being stepped: (t0, θ0, t1, θ1).
    pub(super) span: (f64, f64, f64, f64),
    /// Generalised force of the tissue on the opening over the last frame (N·m).
    pub(super) tissue_torque: f64,
    /// What the grip measured over the last frame, and that frame's length.
    pub(super) sums: GripSums,
    pub(super) sums_elapsed: f64,
    /// Grip ratio for the frame being stepped.
    pub(super) grip: f32,
}

impl Jaws {
    pub(super) fn new(gains: JawGains, angle: f64) -> Self {
        Jaws {
            servo: JawServo::new(gains, angle),
            effort: None,
            span: (0.0, angle, 0.0, angle),
            tissue_torque: 0.0,
            sums: GripSums::default(),
            sums_elapsed: 0.0,
            grip: -1.0,
        }
    }

    /// Opening at time `t` of the frame being stepped.
    pub(super) fn angle_at(&self, t: f64) -> f64 {
        let (t0, a0, t1, a1) = self.span;
        if t1 > t0 {
            a0 + (a1 - a0) * ((t - t0) / (t1 - t0)).clamp(0.0, 1.0)
        } else {
            a1
        }
    }

    /// Coulomb on the grip as a whole: the share of the tangential hold the squeeze can
    /// pay for, from the force holding took over the last frame; negative (no hold) while
    /// the controller does not drive the jaws closed, or while their tips are more than a
    /// cell apart.
    pub(super) fn grip_ratio(&self, shape: Shape, contact: ContactModel, dx: f64) -> f32 {
        let Shape::Gripper { jaw_length, .. } = shape else {
            return -1.0;
        };
        // Only a gap the grid cannot resolve needs the grip: with the tips more than a cell
        // apart, contact and its friction act on the tissue between the faces (and stop
        // the jaws on it).
        let tip_gap = 2.0 * jaw_length as f64 * (0.5 * self.servo.angle).sin();
        if !self.servo.driving_closed() || tip_gap > dx {
            return -1.0;
        }
        let squeeze = self.servo.squeeze();
        let friction = match contact {
            ContactModel::Sticky => return 1.0,
            ContactModel::Coulomb { friction, .. } => friction as f64,
        };
        let lever = if self.sums.mass > 0.0 {
            self.sums.mass_lever / self.sums.mass
        } else {
            0.5 * jaw_length as f64
        }
        .max(1e-4);
        let capacity = friction * 2.0 * squeeze / lever;
        let needed = if self.sums_elapsed > 0.0 {
            self.sums.required.norm() / self.sums_elapsed
        } else {
            0.0
        };
        if needed <= capacity {
            1.0
        } else {
            (capacity / needed) as f32
        }
    }
}

impl WorldTool {
    /// What moves the tool now.
    pub fn driver(&self) -> &ToolDriver {
        &self.driver
    }

    /// A gripper's jaw state: the opening reached, the controller's effort, the squeeze.
    pub fn jaw(&self) -> Option<&JawServo> {
        self.jaws.as_ref().map(|j| &j.servo)
    }

    /// What a gripper's grip held over the last frame (zero when it held nothing; see
    /// [`crate::tools::grip`]).
    pub fn grip_sums(&self) -> GripSums {
        self.jaws
            .as_ref()
            .map_or_else(GripSums::default, |j| j.sums)
    }

    /// A gripper's grip ratio for the frame being stepped: negative when it holds nothing,
    /// 1 when friction holds what it grips, less while that slips.
    pub fn grip_ratio(&self) -> Option<f32> {
        self.jaws.as_ref().map(|j| j.grip)
    }

    /// Box that every grid node this tool can touch between `t0` and `t1` lies in: its
    /// contact bounding box at both ends and at every keyframe between them, since it moves
    /// linearly from one to the next.
    pub fn reach_between(&self, t0: f64, t1: f64, dx: f32) -> Aabb {
        let reach_at = |t: f64| {
            let k = ToolKinematics::new(
                self.shape,
                self.contact,
                &self.pose_at(t),
                &ToolVelocity::default(),
                dx,
            );
            Aabb {
                min: k.aabb_min,
                max: k.aabb_max,
            }
        };
        let mut reach = reach_at(t0).union(&reach_at(t1));
        if let ToolDriver::Scripted(trajectory) = &self.driver {
            for t in trajectory.key_times_between(t0, t1) {
                reach = reach.union(&reach_at(t));
            }
        }
        reach
    }

    /// How far the tool frame's origin travels between `t0` and `t1`: the length of its
    /// path through the keyframes between them, along which it moves linearly.
    pub fn travel_between(&self, t0: f64, t1: f64) -> f64 {
        let mut times = vec![t0];
        if let ToolDriver::Scripted(trajectory) = &self.driver {
            times.extend(trajectory.key_times_between(t0, t1));
        }
        times.push(t1);
        times
            .windows(2)
            .map(|w| (self.pose_at(w[1]).position - self.pose_at(w[0]).position).norm())
            .sum()
    }

    /// A needle's rigid body (see [`super::needle_body`]); `None` for other shapes.
    pub fn needle(&self) -> Option<&NeedleBody> {
        self.body.as_ref()
    }

    /// Whether the tool's driver (its keyframes or the arm holding it) moves it: always,
    /// except for a needle its driver has let go of.
    pub fn carried_by_driver(&self) -> bool {
        self.body
            .as_ref()
            .is_none_or(|b| *b.carrier() == super::needle_body::Carrier::Driver)
    }

    /// The tool's pose at `t`: a needle's carrier's; a gripper's jaw is the opening its
    /// jaws reach, not their setpoint.
    pub fn pose_at(&self, t: f64) -> ToolPose {
        if let Some(pose) = self.body.as_ref().and_then(|b| b.pose_at(t)) {
            return pose;
        }
        let mut pose = self.setpoint_at(t);
        if let Some(jaws) = &self.jaws {
            pose.jaw = jaws.angle_at(t);
        }
        pose
    }

    /// The pose the driver asks for at `t`, jaw setpoint included.
    pub fn setpoint_at(&self, t: f64) -> ToolPose {
        match &self.driver {
            ToolDriver::Scripted(trajectory) => trajectory.sample(t),
            ToolDriver::Commanded { from, to, t0, t1 } => {
                let s = if t1 > t0 {
                    ((t - t0) / (t1 - t0)).clamp(0.0, 1.0)
                } else {
                    1.0
                };
                from.lerp(to, s)
            }
        }
    }
}
