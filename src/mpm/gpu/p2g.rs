//! Host side of `p2g.wgsl`: the fused APIC + MLS force scatter, with f32 atomics or i32
//! fixed-point atomics (`acc_float.wgsl` / `acc_fixed.wgsl`).

use super::pass::CountingPass;
use super::prelude::StageBuilder;
use super::Groups;

/// The stage's WGSL (after the prelude, `common.wgsl` and the P2G variant).
pub const SOURCE: &str = include_str!("p2g.wgsl");

/// Fixed-point scale of the integer P2G: 2^26 per unit, so a node holds ±32 units (see
/// `acc_fixed.wgsl`). Measured on the free-block agreement scene: 2^23 leaves 29 µm of
/// position difference to the f32 solver after 0.1 s, 2^26 leaves 1.7 µm.
pub const FIXED_SCALE: f32 = (1u32 << 26) as f32;

pub struct P2gStage {
    p2g: wgpu::ComputePipeline,
    /// Total Lagrangian MPM's P2G, built only for it.
    p2g_tl: Option<wgpu::ComputePipeline>,
}

impl P2gStage {
    pub fn new(b: &StageBuilder) -> Self {
        let module = b.module("p2g", SOURCE);
        P2gStage {
            p2g: b.pipeline(&module, "p2g", false),
            p2g_tl: b
                .total_lagrangian
                .then(|| b.pipeline(&module, "p2g_tl", false)),
        }
    }

    pub fn record(&self, pass: &mut CountingPass, groups: &Groups) {
        pass.set_pipeline(&self.p2g);
        pass.dispatch_workgroups(groups.particles, 1, 1);
    }

    /// Records total Lagrangian MPM's P2G (a solver built for it).
    pub fn record_tl(&self, pass: &mut CountingPass, groups: &Groups) {
        pass.set_pipeline(self.p2g_tl.as_ref().expect("a total Lagrangian solver"));
        pass.dispatch_workgroups(groups.particles, 1, 1);
    }
}
