//! Host side of `g2p.wgsl`: the integrating G2P with the guard, and the end-of-frame
//! stages (the guard event's details, the extract the readback copies).

use super::prelude::StageBuilder;
use super::Groups;

/// The stage's WGSL (after the prelude, `common.wgsl` and the P2G variant).
pub const SOURCE: &str = include_str!("g2p.wgsl");

pub struct G2pStage {
    g2p: wgpu::ComputePipeline,
    finalize: wgpu::ComputePipeline,
    extract: wgpu::ComputePipeline,
}

impl G2pStage {
    pub fn new(b: &StageBuilder) -> Self {
        let module = b.module("g2p", SOURCE);
        G2pStage {
            g2p: b.pipeline(&module, "g2p", false),
            finalize: b.pipeline(&module, "finalize_guard", false),
            extract: b.pipeline(&module, "extract_positions", false),
        }
    }

    pub fn record(&self, pass: &mut wgpu::ComputePass, groups: &Groups) {
        pass.set_pipeline(&self.g2p);
        pass.dispatch_workgroups(groups.particles, 1, 1);
    }

    /// Records the end of a frame: the guard event's details, then the extract.
    pub fn record_frame_end(&self, pass: &mut wgpu::ComputePass, groups: &Groups) {
        pass.set_pipeline(&self.finalize);
        pass.dispatch_workgroups(1, 1, 1);
        pass.set_pipeline(&self.extract);
        pass.dispatch_workgroups(groups.particles, 1, 1);
    }
}
