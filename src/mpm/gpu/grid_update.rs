//! Host side of `grid_update.wgsl`: the grid update over the active blocks (one workgroup
//! a block) and the reduction of the blocks' contact sums into per-tool impulses.

use super::pass::CountingPass;
use super::prelude::StageBuilder;
use super::{Groups, WG};
use crate::mpm::grid::NODES_PER_BLOCK;
use crate::mpm::MAX_TOOLS;

// One workgroup a block, one invocation a node.
const _: () = assert!(WG as usize == NODES_PER_BLOCK);
// `reduce_impulses` is one workgroup of one invocation per (tool, word): within the
// 256 invocations a workgroup may have on every adapter.
const _: () = assert!(MAX_TOOLS * IMPULSE_WORDS <= 256);

/// The stage's WGSL (after the prelude, `common.wgsl` and the P2G variant).
pub const SOURCE: &str = include_str!("grid_update.wgsl");

/// Words of one tool's impulse sums (linear xyz, angular xyz, contact nodes, angular impulse
/// on a gripper's jaw opening, the grip's sums: required momentum xyz, held mass, its first
/// moment about the hinge; the mass of the nodes touched and their moment of inertia about
/// the tool origin; one unused), in the grid update's per-block partials and in
/// the frame statistics.
pub const IMPULSE_WORDS: usize = 16;

pub struct GridUpdateStage {
    grid_update: wgpu::ComputePipeline,
    /// The grid update after an implicit solve, which settles the nodes in contact itself.
    grid_update_implicit: wgpu::ComputePipeline,
    reduce: wgpu::ComputePipeline,
    /// Total Lagrangian MPM's grid update, built only for it.
    grid_update_tl: Option<wgpu::ComputePipeline>,
}

impl GridUpdateStage {
    pub fn new(b: &StageBuilder) -> Self {
        let module = b.module("grid_update", SOURCE);
        GridUpdateStage {
            grid_update: b.pipeline(&module, "grid_update", false),
            grid_update_implicit: b.pipeline(&module, "grid_update_implicit", false),
            reduce: b.pipeline(&module, "reduce_impulses", false),
            grid_update_tl: b
                .total_lagrangian
                .then(|| b.pipeline(&module, "grid_update_tl", false)),
        }
    }

    pub fn record(&self, pass: &mut CountingPass, groups: &Groups) {
        pass.set_pipeline(&self.grid_update);
        pass.dispatch_workgroups_indirect(groups.active_blocks, 0);
    }

    /// Records total Lagrangian MPM's grid update (a solver built for it).
    pub fn record_tl(&self, pass: &mut CountingPass, groups: &Groups) {
        pass.set_pipeline(
            self.grid_update_tl
                .as_ref()
                .expect("a total Lagrangian solver"),
        );
        pass.dispatch_workgroups_indirect(groups.active_blocks, 0);
    }

    /// Records the grid update that follows `implicit.wgsl`'s `im_finish`.
    pub fn record_implicit(&self, pass: &mut CountingPass, groups: &Groups) {
        pass.set_pipeline(&self.grid_update_implicit);
        pass.dispatch_workgroups_indirect(groups.active_blocks, 0);
    }

    /// Records the impulse reduction; after G2P, so that a substep the guard rejects
    /// contributes nothing.
    pub fn record_reduce(&self, pass: &mut CountingPass) {
        pass.set_pipeline(&self.reduce);
        pass.dispatch_workgroups(1, 1, 1);
    }
}
