//! What a frame reports: the wrench each tool receives, the substeps taken, and why a
//! command or a step was refused.

use crate::mpm::guard::GuardEvent;
use crate::mpm::SolveCounts;
use nalgebra::{Isometry3, UnitQuaternion, Vector3};

/// Force (N) and torque (N·m) a tool receives from the tissue: world frame, torque about
/// the tool frame origin, averaged over a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Wrench {
    /// Force on the tool, world frame, N.
    pub force: Vector3<f64>,
    /// Torque on the tool about its frame origin, world frame, N·m.
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

    /// The same wrench as the holder of a mounted tool feels it, in the holder's frame: the
    /// torque about the holder's origin, behind which `mount` (holder-from-tool) puts the
    /// tool's, and the axes the mount's rotation turns away from the tool's.
    /// `tool_rotation` is world-from-tool.
    pub fn in_holder_frame(
        &self,
        tool_rotation: &UnitQuaternion<f64>,
        mount: &Isometry3<f64>,
    ) -> Wrench {
        let holder_rotation = tool_rotation * mount.rotation.inverse();
        let tool_origin_from_holder = holder_rotation * mount.translation.vector;
        Wrench {
            force: self.force,
            torque: self.torque + tool_origin_from_holder.cross(&self.force),
        }
        .in_tool_frame(&holder_rotation)
    }
}

/// What one frame did.
#[derive(Clone, Debug)]
pub struct FrameReport {
    /// Simulated time at the end of the frame (s).
    pub time: f64,
    /// Substeps taken.
    pub substeps: u32,
    /// Smallest substep of the frame, s.
    pub dt_min: f64,
    /// Largest substep of the frame, s.
    pub dt_max: f64,
    /// Per tool, scene order.
    pub wrenches: Vec<Wrench>,
    /// Contact nodes per tool, summed over the frame's substeps.
    pub contact_nodes: Vec<u32>,
    /// Largest particle speed over the frame, m/s.
    pub max_speed: f32,
    /// Particles that reached the domain edge and were clamped back inside, summed over substeps.
    pub clamped_particles: u32,
    /// The frame hit `max_substeps_per_frame` and advanced less than a frame of time.
    pub truncated: bool,
    /// Guard event that reset the tissue during this frame (policy `reset_tissue`).
    pub tissue_reset: Option<GuardEvent>,
    /// The tissue was asleep and the frame was skipped (see [`crate::sleep`]).
    pub asleep: bool,
    /// Newton and CG iterations of the implicit solver over the frame.
    pub solve: SolveCounts,
    /// Particles split at the frame's end and splits refused by the cap (see
    /// [`crate::mpm::split`]).
    pub split: crate::mpm::split::SplitCount,
    /// Largest principal stretch of any particle at the frame's end; 0 where unmeasured.
    pub max_stretch: f32,
    /// Where the most stretched particle is (m).
    pub max_stretch_at: crate::math::Vec3,
}

#[derive(Debug, thiserror::Error, PartialEq)]
/// Why a tool command was refused.
pub enum CommandError {
    #[error("no tool with index {0}")]
    /// No tool at this index (holds it).
    NoSuchTool(usize),
    #[error("tool {0}: commanded pose is not finite; keeping the last valid one")]
    /// A pose with NaN or infinite values; the tool keeps its last valid pose (holds the tool's
    /// name).
    NonFinitePose(String),
    #[error("tool {0} has no jaws")]
    /// A jaw command to a tool without jaws (holds the tool's name).
    NoJaws(String),
    #[error("tool {0}: jaw effort {1} N·m is not finite")]
    /// A NaN or infinite jaw effort: the tool's name and the effort, N·m.
    NonFiniteEffort(String, f64),
}

#[derive(Debug, thiserror::Error)]
/// Why a frame could not be stepped.
pub enum StepError {
    #[error(
        "simulation stopped at t = {time:.4} s: {event}; tissue restored to the last good frame"
    )]
    /// The guard stopped the simulation; the tissue is restored to the last good frame.
    Guard {
        /// Simulated time of the event, s.
        time: f64,
        /// What the guard saw.
        event: GuardEvent,
    },
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Translation3;

    #[test]
    fn a_mounted_tool_s_wrench_is_taken_about_the_holder_s_origin_in_its_axes() {
        // The tool sits 9 mm along the holder's z, turned 90° about it; the holder's axes are
        // the world's. A push along world x on the tool's origin, 9 mm ahead of the holder,
        // turns the holder about its y: τ = (0, 0, 0.009) × (2, 0, 0) = (0, 0.018, 0).
        let quarter =
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2);
        let mount = Isometry3::from_parts(Translation3::new(0.0, 0.0, 0.009), quarter);
        let pushed = Wrench {
            force: Vector3::new(2.0, 0.0, 0.0),
            torque: Vector3::new(0.0, 0.0, 0.001),
        };
        let held = pushed.in_holder_frame(&quarter, &mount);
        assert!(
            (held.force - Vector3::new(2.0, 0.0, 0.0)).norm() < 1e-12,
            "{held:?}"
        );
        assert!(
            (held.torque - Vector3::new(0.0, 0.018, 0.001)).norm() < 1e-12,
            "{held:?}"
        );
        // A tool with no mount feels it as itself.
        let own = pushed.in_holder_frame(&quarter, &Isometry3::identity());
        assert_eq!(own, pushed.in_tool_frame(&quarter));
    }
}
