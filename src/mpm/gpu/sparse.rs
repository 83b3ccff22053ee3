//! Host side of `sparse.wgsl`: the active-block list of a substep (its length is the
//! indirect dispatch size of the clear and grid-update stages; its order, increasing block
//! index, the same from run to run) and the clear of those blocks. MLS-MPM and PIC make the
//! list once per frame here and then at the end of each substep, from the blocks G2P
//! flagged, fused with the impulse reduction: five dispatches a substep (clear, P2G, grid
//! update, G2P, end) instead of eight.

use super::pass::CountingPass;
use super::prelude::StageBuilder;
use super::Groups;

/// The stage's WGSL (after the prelude, `common.wgsl` and the P2G variant).
pub const SOURCE: &str = include_str!("sparse.wgsl");

pub struct SparseStage {
    begin: wgpu::ComputePipeline,
    mark: wgpu::ComputePipeline,
    compact: wgpu::ComputePipeline,
    clear: wgpu::ComputePipeline,
    first_blocks: wgpu::ComputePipeline,
    end_substep: wgpu::ComputePipeline,
}

impl SparseStage {
    pub fn new(b: &StageBuilder) -> Self {
        let module = b.module("sparse", SOURCE);
        SparseStage {
            begin: b.pipeline(&module, "begin", true),
            mark: b.pipeline(&module, "mark", true),
            compact: b.pipeline(&module, "compact", true),
            clear: b.pipeline(&module, "clear", false),
            first_blocks: b.pipeline(&module, "first_blocks", true),
            end_substep: b.pipeline(&module, "end_substep", true),
        }
    }

    /// Records the sparse-grid bookkeeping of a substep: the active block list, and the
    /// clear of those blocks.
    pub fn record(&self, pass: &mut CountingPass, groups: &Groups) {
        pass.set_pipeline(&self.begin);
        pass.dispatch_workgroups(1, 1, 1);
        pass.set_pipeline(&self.mark);
        pass.dispatch_workgroups(groups.particles, 1, 1);
        pass.set_pipeline(&self.compact);
        pass.dispatch_workgroups(1, 1, 1);
        self.record_clear(pass, groups);
    }

    /// Records the block list of an MLS-MPM or PIC frame's first substep; the substeps
    /// then make the next one in [`SparseStage::record_end_substep`].
    pub fn record_first_blocks(&self, pass: &mut CountingPass, groups: &Groups) {
        pass.set_pipeline(&self.mark);
        pass.dispatch_workgroups(groups.particles, 1, 1);
        pass.set_pipeline(&self.first_blocks);
        pass.dispatch_workgroups(1, 1, 1);
    }

    /// Records the end of an MLS-MPM or PIC substep: its impulse reduction and the next
    /// substep's block list from the blocks its G2P flagged, in one dispatch.
    pub fn record_end_substep(&self, pass: &mut CountingPass) {
        pass.set_pipeline(&self.end_substep);
        pass.dispatch_workgroups(1, 1, 1);
    }

    /// Records the clear of the active blocks alone (PB-MPM's later iterations, and every
    /// MLS-MPM or PIC substep).
    pub fn record_clear(&self, pass: &mut CountingPass, groups: &Groups) {
        pass.set_pipeline(&self.clear);
        pass.dispatch_workgroups_indirect(groups.active_blocks, 0);
    }
}
