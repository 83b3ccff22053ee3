//! Host side of `pbmpm.wgsl`: PB-MPM's elastic constraint on C, its momentum-only P2G, the
//! inner iterations' G2P and the reset between iterations. The rest of a PB-MPM substep is
//! MLS-MPM's stages (see `GpuSolver::record_pb_substep`).

use super::pass::CountingPass;
use super::prelude::StageBuilder;
use super::Groups;

/// The stage's WGSL (after the prelude, `common.wgsl` and the P2G variant).
pub const SOURCE: &str = include_str!("pbmpm.wgsl");

pub struct PbMpmStages {
    constrain: wgpu::ComputePipeline,
    p2g: wgpu::ComputePipeline,
    g2p: wgpu::ComputePipeline,
    next_iteration: wgpu::ComputePipeline,
}

impl PbMpmStages {
    pub fn new(b: &StageBuilder) -> Self {
        let module = b.module("pbmpm", SOURCE);
        PbMpmStages {
            constrain: b.pipeline(&module, "pb_constrain", false),
            p2g: b.pipeline(&module, "pb_p2g", false),
            g2p: b.pipeline(&module, "pb_g2p", false),
            next_iteration: b.pipeline(&module, "pb_next_iteration", false),
        }
    }

    /// Records the constraint on C and the momentum-only P2G of an iteration.
    pub fn record_p2g(&self, pass: &mut CountingPass, groups: &Groups) {
        pass.set_pipeline(&self.constrain);
        pass.dispatch_workgroups(groups.particles, 1, 1);
        pass.set_pipeline(&self.p2g);
        pass.dispatch_workgroups(groups.particles, 1, 1);
    }

    /// Records the G2P of an inner (not the last) iteration: v and C only.
    pub fn record_g2p(&self, pass: &mut CountingPass, groups: &Groups) {
        pass.set_pipeline(&self.g2p);
        pass.dispatch_workgroups(groups.particles, 1, 1);
    }

    /// Records the reset between iterations.
    pub fn record_next_iteration(&self, pass: &mut CountingPass) {
        pass.set_pipeline(&self.next_iteration);
        pass.dispatch_workgroups(1, 1, 1);
    }
}
