//! What a frame reports: the wrench each tool receives, the substeps taken, and why a
//! command or a step was refused.

use crate::mpm::guard::GuardEvent;
use crate::mpm::SolveCounts;
use nalgebra::{UnitQuaternion, Vector3};

/// Force (N) and torque (N·m) a tool receives from the tissue: world frame, torque about
/// the tool frame origin, averaged over a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Wrench {
    pub force: Vector3<f64>,
    pub torque: Vector3<f64>,
}

impl Wrench {
    /// The same wrench expressed in the tool frame (rotation = world-from-tool).
    pub fn in_tool_frame(&self, rotation: &UnitQuaternion<f64>) -> Wrench {
        Wrench {
            force: rotation.inverse_transform_vector(&self.force),
            torque: rotation.inverse_transform_vector(&self.torque),
        }
    }
}

/// What one frame did.
#[derive(Clone, Debug)]
pub struct FrameReport {
    /// Simulated time at the end of the frame (s).
    pub time: f64,
    pub substeps: u32,
    pub dt_min: f64,
    pub dt_max: f64,
    /// Per tool, scene order.
    pub wrenches: Vec<Wrench>,
    /// Contact nodes per tool, summed over the frame's substeps.
    pub contact_nodes: Vec<u32>,
    pub max_speed: f32,
    pub clamped_particles: u32,
    /// The frame hit `max_substeps_per_frame` and advanced less than a frame of time.
    pub truncated: bool,
    /// Guard event that reset the tissue during this frame (policy `reset_tissue`).
    pub tissue_reset: Option<GuardEvent>,
    /// The tissue was asleep and the frame was skipped (see [`crate::sleep`]).
    pub asleep: bool,
    /// Newton and CG iterations of the implicit solver over the frame.
    pub solve: SolveCounts,
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum CommandError {
    #[error("no tool with index {0}")]
    NoSuchTool(usize),
    #[error("tool {0}: commanded pose is not finite; keeping the last valid one")]
    NonFinitePose(String),
    #[error("tool {0} has no jaws")]
    NoJaws(String),
    #[error("tool {0}: jaw effort {1} N·m is not finite")]
    NonFiniteEffort(String, f64),
}

#[derive(Debug, thiserror::Error)]
pub enum StepError {
    #[error(
        "simulation stopped at t = {time:.4} s: {event}; tissue restored to the last good frame"
    )]
    Guard { time: f64, event: GuardEvent },
}
