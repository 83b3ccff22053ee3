//! Host side of `crack.wgsl`: the per-substep crack marking of a scene with a slicer, the
//! quad or one from a mesh file (whose blade `blade.rs` uploads; see
//! [`crate::mpm::crack`]). A scene without one builds no pipeline and records nothing; its
//! P2G and G2P see `CUTTING` false and skip the side tests.

use super::pass::CountingPass;
use super::prelude::StageBuilder;
use super::Groups;

/// The stage's WGSL (after the prelude, `common.wgsl` and the P2G variant).
pub const SOURCE: &str = include_str!("crack.wgsl");

pub struct CrackStage {
    mark: Option<wgpu::ComputePipeline>,
}

impl CrackStage {
    pub fn new(b: &StageBuilder) -> Self {
        let mark = b.cutting.then(|| {
            let module = b.module("crack", SOURCE);
            b.pipeline(&module, "mark_cracks", false)
        });
        CrackStage { mark }
    }

    /// Records the marking of the particles the slicers' edges pass this substep (before
    /// its P2G), when the scene cuts.
    pub fn record(&self, pass: &mut CountingPass, groups: &Groups) {
        if let Some(mark) = &self.mark {
            pass.set_pipeline(mark);
            pass.dispatch_workgroups(groups.particles, 1, 1);
        }
    }
}
