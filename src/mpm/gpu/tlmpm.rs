//! Total Lagrangian MPM on the device (the CPU's [`crate::mpm::cpu::tlmpm`] line for line):
//! `tlmpm.wgsl`'s capture and stiffening bounds, and the entries `p2g_tl`,
//! `grid_update_tl` and `g2p_tl` of the P2G, grid-update and G2P stages.
//!
//! A frame is the plan cut into pieces (see [`crate::mpm::stiffening`]) and recorded as
//! one submission of equal steps, each: the block list of the rest configuration's stencils
//! and its clear (`sparse`), the grip's capture and the holding flags, P2G on the rest
//! stencils, the grid update at the nodes' current places, G2P, the impulse reduction. At
//! the frame's end `tl_bound` leaves the stiffening bounds in the statistics words that
//! come back with the frame, and they decide the next frame's pieces; after a restore or
//! an edit of the particles on the host, the host's F decides them (every particle counted
//! free: the captures live on the device).
//!
//! Per node the accumulators carry [`TL_WORDS`] more words than the other methods' (dt·force,
//! the mass-weighted offset from the node, the captured mass), and a gripper index; per
//! particle a rest position whose w is its gripper. What the device gives back each frame
//! is what every method's frame gives back.

use super::pass::CountingPass;
use super::prelude::StageBuilder;
use super::Groups;

/// The stage's WGSL (after the prelude, `common.wgsl` and the P2G variant).
pub const SOURCE: &str = include_str!("tlmpm.wgsl");

/// A node's words after its NODE_WORDS: dt·force xyz, Σ w·m·(xₚ − xᵢ) xyz, captured mass.
pub const TL_WORDS: usize = 7;

pub struct TlStages {
    capture: wgpu::ComputePipeline,
    commit: wgpu::ComputePipeline,
    bound: wgpu::ComputePipeline,
}

impl TlStages {
    pub fn new(b: &StageBuilder) -> Self {
        let module = b.module("tlmpm", SOURCE);
        TlStages {
            capture: b.pipeline(&module, "tl_capture", false),
            commit: b.pipeline(&module, "tl_commit", false),
            bound: b.pipeline(&module, "tl_bound", false),
        }
    }

    /// Records the grip's capture and the holding flags of a step.
    pub fn record_capture(&self, pass: &mut CountingPass, groups: &Groups) {
        pass.set_pipeline(&self.capture);
        pass.dispatch_workgroups(groups.particles, 1, 1);
        pass.set_pipeline(&self.commit);
        pass.dispatch_workgroups(1, 1, 1);
    }

    /// Records the stiffening bounds at a frame's end.
    pub fn record_bound(&self, pass: &mut CountingPass, groups: &Groups) {
        pass.set_pipeline(&self.bound);
        pass.dispatch_workgroups(groups.particles, 1, 1);
    }
}
