//! Host side of `g2p.wgsl`: the integrating G2P with the guard, and the end-of-frame
//! stages (the guard event's details, the extract the readback copies).

use super::pass::CountingPass;
use super::prelude::StageBuilder;
use super::Groups;

/// The stage's WGSL (after the prelude, `common.wgsl` and the P2G variant).
pub const SOURCE: &str = include_str!("g2p.wgsl");

pub struct G2pStage {
    g2p: wgpu::ComputePipeline,
    finalize: wgpu::ComputePipeline,
    extract: wgpu::ComputePipeline,
    /// Total Lagrangian MPM's G2P, built only for it.
    g2p_tl: Option<wgpu::ComputePipeline>,
}

impl G2pStage {
    pub fn new(b: &StageBuilder) -> Self {
        let module = b.module("g2p", SOURCE);
        G2pStage {
            g2p: b.pipeline(&module, "g2p", false),
            finalize: b.pipeline(&module, "finalize_guard", false),
            extract: b.pipeline(&module, "extract_positions", false),
            g2p_tl: b
                .total_lagrangian
                .then(|| b.pipeline(&module, "g2p_tl", false)),
        }
    }

    pub fn record(&self, pass: &mut CountingPass, groups: &Groups) {
        pass.set_pipeline(&self.g2p);
        pass.dispatch_workgroups(groups.particles, 1, 1);
    }

    /// Records total Lagrangian MPM's G2P (a solver built for it).
    pub fn record_tl(&self, pass: &mut CountingPass, groups: &Groups) {
        pass.set_pipeline(self.g2p_tl.as_ref().expect("a total Lagrangian solver"));
        pass.dispatch_workgroups(groups.particles, 1, 1);
    }

    /// Records the end of a frame: the guard event's details, then the extract.
    pub fn record_frame_end(&self, pass: &mut CountingPass, groups: &Groups) {
        pass.set_pipeline(&self.finalize);
        pass.dispatch_workgroups(1, 1, 1);
        pass.set_pipeline(&self.extract);
        pass.dispatch_workgroups(groups.particles, 1, 1);
    }
}
