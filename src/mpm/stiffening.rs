//! Total Lagrangian MPM's substep cut: how many pieces each substep of a frame is cut into,
//! decided once per frame from the tissue's state at the frame's start, the same way on
//! the CPU and the GPU.
//!
//! The substep the world chooses is sized for tissue at rest. A Neo-Hookean particle
//! squeezed to a smallest principal stretch σ_min stiffens by about 1/σ_min² along that axis
//! (the F⁻ᵀ terms of its stress), so elastic waves cross a rest cell up to 1/σ_min times
//! sooner than that substep allows. Tissue a lift stretches narrows across the pull, and
//! tissue between closed jaws is squeezed; without the cut the liver `config/default.toml`
//! lifts 25 mm ran away at 10 m/s when the jaws let it go.
//!
//! Each substep is therefore cut into ⌈b⌉ pieces (at most [`MAX_PIECES`]), b the largest
//! bound on 1/σ_min(F) over the particles no gripper holds. A held particle moves with the
//! jaws and does not count, except in a frame in which its gripper lets go at some substep:
//! it counts for the whole of that frame. The bound is taken at the frame's start (the GPU
//! computes it at the end of the frame before, on the device, and reads it back with the
//! frame's statistics), so the frame is recorded on the GPU as one submission of
//! substeps × pieces equal steps.

use super::frame_plan::FramePlan;
use super::{Mat3, MAX_TOOLS};
use crate::tools::ToolKinematics;

/// The most pieces a substep is cut into (tissue squeezed to a sixteenth of its rest
/// length across; beyond that the guard is the answer).
pub const MAX_PIECES: u32 = 16;

/// A bound on 1/σ_min(F) = ‖F⁻¹‖₂: √(‖F⁻¹‖₁‖F⁻¹‖∞), exact for a diagonal F and never below
/// the true value. A singular F counts as undeformed (the guard deals with it).
#[inline]
pub fn inverse_stretch_bound(f: &Mat3) -> f32 {
    let f_inv = f.try_inverse().unwrap_or_else(Mat3::identity);
    let abs = f_inv.abs();
    (abs.row_sum().max() * abs.column_sum().max()).sqrt()
}

/// The bounds of [`inverse_stretch_bound`] over the particles at a frame's start: the free
/// ones, and those each gripper holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StiffeningBounds {
    /// Over the particles no gripper holds (at least 1).
    pub free: f32,
    /// Over the particles gripper `t` holds (0 when it holds none).
    pub held: [f32; MAX_TOOLS],
}

impl Default for StiffeningBounds {
    fn default() -> Self {
        StiffeningBounds {
            free: 1.0,
            held: [0.0; MAX_TOOLS],
        }
    }
}

impl StiffeningBounds {
    /// Every particle counted as free (when which ones a gripper holds is not known).
    pub fn all_free(f: &[Mat3]) -> Self {
        StiffeningBounds {
            free: f.iter().map(inverse_stretch_bound).fold(1.0, f32::max),
            held: [0.0; MAX_TOOLS],
        }
    }

    /// Pieces each substep of `plan` is cut into: the free particles' bound, and a
    /// gripper's held particles' where the gripper lets go at some substep of the frame.
    pub fn pieces(&self, plan: &FramePlan) -> u32 {
        let mut bound = self.free;
        for t in 0..plan.tool_count.min(MAX_TOOLS) {
            let lets_go = (0..plan.substeps as usize).any(|s| plan.substep_tools(s)[t].grip < 0.0);
            if lets_go {
                bound = bound.max(self.held[t]);
            }
        }
        // Within a whisker of a whole number the substep stays whole.
        (bound - 1e-3).ceil().clamp(1.0, MAX_PIECES as f32) as u32
    }
}

/// `plan` with each substep cut into `pieces` equal steps, the tools of each piece those of
/// its substep; `plan` itself when one piece is enough. The pieces' tools are written into
/// `buffer`, which a caller keeps from frame to frame so that cutting allocates only when a
/// frame needs more pieces than any before it.
pub fn cut<'a>(
    plan: &FramePlan<'a>,
    pieces: u32,
    buffer: &'a mut Vec<ToolKinematics>,
) -> FramePlan<'a> {
    if pieces <= 1 {
        return *plan;
    }
    buffer.clear();
    buffer.extend(
        (0..plan.substeps as usize)
            .flat_map(|s| std::iter::repeat_n(plan.substep_tools(s), pieces as usize).flatten())
            .cloned(),
    );
    FramePlan {
        dt: plan.dt / pieces as f32,
        substeps: plan.substeps * pieces,
        gravity: plan.gravity,
        tool_count: plan.tool_count,
        tools: buffer,
        part: plan.part,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mpm::Vec3;

    /// A sphere whose `grip` stands for a gripper's.
    fn tool(grip: f32) -> ToolKinematics {
        let shape = crate::tools::Shape::Sphere { radius: 0.002 };
        let contact = crate::tools::ContactModel::default();
        let mut k = ToolKinematics::new(
            shape,
            contact,
            &Default::default(),
            &Default::default(),
            1e-3,
        );
        k.grip = grip;
        k
    }

    fn plan(tools: &[ToolKinematics], substeps: u32) -> FramePlan<'_> {
        FramePlan {
            dt: 1e-4,
            substeps,
            gravity: Vec3::zeros(),
            tool_count: tools.len() / substeps as usize,
            tools,
            part: crate::mpm::frame_plan::FramePart::WHOLE,
        }
    }

    #[test]
    fn the_bound_is_one_over_the_least_stretch_for_a_diagonal_f() {
        let f = Mat3::from_diagonal(&Vec3::new(1.5, 0.4, 1.0));
        assert!((inverse_stretch_bound(&f) - 2.5).abs() < 1e-6);
        // For a rotation 1/σ_min is 1: the bound is never below it, and at most √3 above.
        let r = nalgebra::Rotation3::from_euler_angles(0.3f32, -0.2, 1.1).into_inner();
        let bound = inverse_stretch_bound(&r);
        assert!((1.0 - 1e-6..=3f32.sqrt()).contains(&bound), "{bound}");
    }

    #[test]
    fn held_particles_count_only_in_a_frame_whose_gripper_lets_go() {
        let mut bounds = StiffeningBounds {
            free: 2.4,
            ..Default::default()
        };
        bounds.held[0] = 5.5;
        let (holding, open) = (tool(1.0), tool(-1.0));
        // Gripper 0 holds the whole frame: the free particles decide, ⌈2.4⌉.
        assert_eq!(bounds.pieces(&plan(&[holding, holding], 2)), 3);
        // It lets go at the second substep: its squeezed particles count, ⌈5.5⌉.
        assert_eq!(bounds.pieces(&plan(&[holding, open], 2)), 6);
        // Whole numbers stay whole, and the cut is capped.
        bounds.held[0] = 0.0;
        bounds.free = 2.0005;
        assert_eq!(bounds.pieces(&plan(&[open], 1)), 2);
        bounds.free = 1e3;
        assert_eq!(bounds.pieces(&plan(&[open], 1)), MAX_PIECES);
    }

    #[test]
    fn a_cut_plan_repeats_each_substeps_tools_at_a_fraction_of_its_step() {
        let tools = [tool(0.25), tool(0.75)];
        let frame = plan(&tools, 2);
        let mut buffer = Vec::new();
        assert_eq!(cut(&frame, 1, &mut buffer).substeps, 2);
        assert!(buffer.is_empty(), "one piece needs no tools of its own");
        let cut = cut(&frame, 3, &mut buffer);
        assert_eq!(cut.substeps, 6);
        assert!((cut.dt * 3.0 - frame.dt).abs() < 1e-6 * frame.dt);
        let grips: Vec<f32> = (0..6).map(|s| cut.substep_tools(s)[0].grip).collect();
        assert_eq!(grips, [0.25, 0.25, 0.25, 0.75, 0.75, 0.75]);
    }
}
