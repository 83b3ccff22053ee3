//! Host side of `sparse.wgsl`: the active-block list of a substep (its length is the
//! indirect dispatch size of the clear and grid-update stages; its order, increasing block
//! index, the same from run to run) and the clear of those blocks.

use super::prelude::StageBuilder;
use super::Groups;

/// The stage's WGSL (after the prelude, `common.wgsl` and the P2G variant).
pub const SOURCE: &str = include_str!("sparse.wgsl");

pub struct SparseStage {
    begin: wgpu::ComputePipeline,
    mark: wgpu::ComputePipeline,
    compact: wgpu::ComputePipeline,
    clear: wgpu::ComputePipeline,
}

impl SparseStage {
    pub fn new(b: &StageBuilder) -> Self {
        let module = b.module("sparse", SOURCE);
        SparseStage {
            begin: b.pipeline(&module, "begin", true),
            mark: b.pipeline(&module, "mark", true),
            compact: b.pipeline(&module, "compact", true),
            clear: b.pipeline(&module, "clear", false),
        }
    }

    /// Records the sparse-grid bookkeeping of a substep: the active block list, and the
    /// clear of those blocks.
    pub fn record(&self, pass: &mut wgpu::ComputePass, groups: &Groups) {
        pass.set_pipeline(&self.begin);
        pass.dispatch_workgroups(1, 1, 1);
        pass.set_pipeline(&self.mark);
        pass.dispatch_workgroups(groups.particles, 1, 1);
        pass.set_pipeline(&self.compact);
        pass.dispatch_workgroups(1, 1, 1);
        self.record_clear(pass, groups);
    }

    /// Records the clear of the active blocks alone (PB-MPM's later iterations).
    pub fn record_clear(&self, pass: &mut wgpu::ComputePass, groups: &Groups) {
        pass.set_pipeline(&self.clear);
        pass.dispatch_workgroups_indirect(groups.active_blocks, 0);
    }
}
