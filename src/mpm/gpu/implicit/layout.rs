//! The implicit solve's device layouts, declared once here and generated into the WGSL
//! ([`declarations`]), as the prelude does for the stages' shared state: the per-node
//! record [`ImNode`], the per-node fixed-point sums ([`acc`]), the per-particle stiffness
//! record ([`stiffness`]), the scalar block ([`scalar`]), the fixed-point format and the
//! bindings of the solve's own bind group ([`ImBinding`]).

use super::super::pack::{shared_struct, wgsl_type};
use bytemuck::{Pod, Zeroable};
use std::fmt::Write;

/// The bind group that holds the solve's own buffers (group 0 is the stages' shared one).
pub const GROUP: u32 = 1;

shared_struct! {
    /// One grid node of the solve (`im_nodes`; of the active blocks only).
    #[allow(dead_code)] // Read and written on the device alone: the host sizes it.
    pub struct ImNode as "ImNode" {
        /// xyz: v* = p/m + g dt; w: the node mass.
        pub v_star: [f32; 4],
        /// The Newton iterate.
        pub v: [f32; 4],
        /// The line search's trial velocities (and the warm start's candidates).
        pub trial: [f32; 4],
        /// The projected ∇Φ.
        pub grad: [f32; 4],
        /// The Newton step and the CG vectors.
        pub step: [f32; 4],
        pub r: [f32; 4],
        pub z: [f32; 4],
        pub d: [f32; 4],
        pub prescribed: [f32; 4],
        /// xyz: with one prescribed direction, the surface normal; w: the normal impulse the
        /// surface gave the node at the end of the substep, for the next substep's friction
        /// weight.
        pub normal: [f32; 4],
        /// xyz: v − v* along the free components at the end of a substep; w: that substep's
        /// epoch (bits), so that only the last substep's correction is read.
        pub correction: [f32; 4],
        /// With one prescribed direction, the surface the node slides on (cpu `Surface`):
        /// xyz its velocity, w the friction weight λ = μ·N (N·s).
        pub surface: [f32; 4],
        /// x μ, y drag, z the tool index (bits; NO_TOOL for the table or a wall), w the tool
        /// part (bits).
        pub slip: [f32; 4],
        /// Projection onto the free velocity components.
        pub free: [[f32; 4]; 3],
        /// The diagonal Hessian block while evaluating, then the preconditioner.
        pub block: [[f32; 4]; 3],
    }
}

/// Bytes per node of `im_nodes`.
pub const NODE_BYTES: u64 = std::mem::size_of::<ImNode>() as u64;

/// Per node, sums scattered from the particles in 64-bit fixed point (`fixed_add`): value k
/// in words 2k (low) and 2k + 1 (high). Until `im_prepare` they hold P2G's momentum and
/// mass, then ∂E/∂v, the diagonal Hessian block and the Hessian product; after the values,
/// the finished product (3 f32 bits) and a word of padding.
pub mod acc {
    /// P2G's momentum (3 values) and mass.
    pub const MOMENTUM: u32 = 0;
    pub const MASS: u32 = 3;
    /// ∂E/∂v (3 values), the diagonal block (9, column-major) and the product (3).
    pub const GRAD: u32 = 0;
    pub const BLOCK: u32 = 3;
    pub const PRODUCT: u32 = 12;
    /// Fixed-point values per node.
    pub const VALUES: u32 = 16;
    /// The word of the finished product.
    pub const PRODUCT_WORD: u32 = 2 * VALUES;
    /// Words per node.
    pub const WORDS: u32 = PRODUCT_WORD + 4;
}

/// Per particle: the 9×9 velocity-gradient stiffness (`hessian.rs`), then at `SCATTER_Q`
/// the 3×3 matrix q (column-major) whose products q·∇wᵢ the particle's second pass scatters.
pub mod stiffness {
    pub const SCATTER_Q: u32 = 81;
    /// f32 words per particle.
    pub const WORDS: u32 = SCATTER_Q + 9;
}

/// Bytes per node of the accumulators and per particle of the stiffness buffer.
pub const ACC_BYTES: u64 = acc::WORDS as u64 * 4;
pub const STIFFNESS_BYTES: u64 = stiffness::WORDS as u64 * 4;

/// Each fixed-point sum's unit is 2^(e − FIXED_BITS), 2^e the power of two above a bound on
/// its contributions' magnitude (`fixed_point.wgsl`): a contribution is at most 2^FIXED_BITS
/// units.
pub const FIXED_BITS: i32 = 40;

/// The most particles the implicit solve takes: a node's fixed-point sum takes one
/// contribution of at most 2^FIXED_BITS units per particle, and stays below 2^62.
pub const MAX_PARTICLES: usize = 1 << (62 - FIXED_BITS);

/// Words of the scalar block `im_scal` (f32 as bits, or u32), read back whole by the host.
pub mod scalar {
    /// Active blocks: the node workgroups `im_sum` adds.
    pub const COUNT: u32 = 0;
    /// CG has stopped; its iterations.
    pub const DONE: u32 = 1;
    pub const ITER: u32 = 2;
    /// A particle would be crushed at the velocities the energy kernels read (Φ = ∞).
    pub const CRUSH: u32 = 3;
    /// Host-set: the line search's step length, CG's target residual, the substep's epoch,
    /// CG's iteration cap.
    pub const ALPHA: u32 = 4;
    pub const TARGET: u32 = 5;
    pub const EPOCH: u32 = 6;
    pub const CAP: u32 = 7;
    /// CG's r·z, α and β.
    pub const RZ: u32 = 8;
    pub const CG_ALPHA: u32 = 9;
    pub const BETA: u32 = 10;
    /// Nodes the last `im_activate` constrained.
    pub const ACTIVATED: u32 = 11;
    /// The sums `im_sum` writes, two words each (its two regions): the elastic energy (and
    /// 0), the kinetic and slip energy and |∇Φ|², r·z at CG's start, d·Hd, |r|² and r·z,
    /// ∇Φ·step, Σm².
    pub const SLOT_ELASTIC: u32 = 12;
    pub const SLOT_KINETIC: u32 = 14;
    pub const SLOT_RZ0: u32 = 16;
    pub const SLOT_PAP: u32 = 18;
    pub const SLOT_RR: u32 = 20;
    pub const SLOT_SLOPE: u32 = 22;
    pub const SLOT_MASS: u32 = 24;
    /// Bounds on the scattered contributions' magnitude (f32 bits, raised by atomicMax), one
    /// per fixed-point sum: P2G momentum and mass, ∂E/∂v, the diagonal blocks, the Hessian
    /// product.
    pub const B_MOMENTUM: u32 = 26;
    pub const B_MASS: u32 = 27;
    pub const B_GRAD: u32 = 28;
    pub const B_BLOCK: u32 = 29;
    pub const B_PRODUCT: u32 = 30;
    /// Words of the block.
    pub const WORDS: usize = 32;

    /// WGSL names and words, for [`super::declarations`].
    pub const ALL: [(&str, u32); 24] = [
        ("I_COUNT", COUNT),
        ("I_DONE", DONE),
        ("I_ITER", ITER),
        ("I_CRUSH", CRUSH),
        ("I_ALPHA", ALPHA),
        ("I_TARGET", TARGET),
        ("I_EPOCH", EPOCH),
        ("I_CAP", CAP),
        ("I_RZ", RZ),
        ("I_CG_ALPHA", CG_ALPHA),
        ("I_BETA", BETA),
        ("I_ACTIVATED", ACTIVATED),
        ("SLOT_ELASTIC", SLOT_ELASTIC),
        ("SLOT_KINETIC", SLOT_KINETIC),
        ("SLOT_RZ0", SLOT_RZ0),
        ("SLOT_PAP", SLOT_PAP),
        ("SLOT_RR", SLOT_RR),
        ("SLOT_SLOPE", SLOT_SLOPE),
        ("SLOT_MASS", SLOT_MASS),
        ("B_MOMENTUM", B_MOMENTUM),
        ("B_MASS", B_MASS),
        ("B_GRAD", B_GRAD),
        ("B_BLOCK", B_BLOCK),
        ("B_PRODUCT", B_PRODUCT),
    ];
    const _: () = assert!(B_PRODUCT < WORDS as u32);
}

/// Which sums `im_clear` zeroes (its override `CLEAR`): the P2G momentum and mass, Φ's
/// gradient and diagonal blocks, or the Hessian product.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Clear {
    P2g,
    Eval,
    Product,
}

impl Clear {
    pub const ALL: [Clear; 3] = [Clear::P2g, Clear::Eval, Clear::Product];

    fn wgsl_name(self) -> &'static str {
        match self {
            Clear::P2g => "CLEAR_P2G",
            Clear::Eval => "CLEAR_EVAL",
            Clear::Product => "CLEAR_PRODUCT",
        }
    }
}

/// The solve's own bind group (group [`GROUP`]), in binding order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImBinding {
    /// Per node: [`ImNode`].
    Nodes,
    /// Per node: the fixed-point sums ([`acc`]).
    Acc,
    /// Per particle: the stiffness record ([`stiffness`]).
    Stiffness,
    /// Per workgroup reduction partials: two regions of arrayLength/2 entries.
    Partials,
    /// The scalar block ([`scalar`]).
    Scalars,
}

impl ImBinding {
    pub const ALL: [ImBinding; 5] = [
        ImBinding::Nodes,
        ImBinding::Acc,
        ImBinding::Stiffness,
        ImBinding::Partials,
        ImBinding::Scalars,
    ];

    fn declaration(self) -> (&'static str, &'static str) {
        match self {
            ImBinding::Nodes => ("im_nodes", "array<ImNode>"),
            ImBinding::Acc => ("im_acc", "array<atomic<u32>>"),
            ImBinding::Stiffness => ("im_stiff", "array<f32>"),
            ImBinding::Partials => ("im_partials", "array<f32>"),
            ImBinding::Scalars => ("im_scal", "array<atomic<u32>>"),
        }
    }
}

/// The WGSL declarations of everything above, which the solve's shader files start from.
pub fn declarations() -> String {
    let mut out = String::from("// Generated from Rust (src/mpm/gpu/implicit/layout.rs).\n\n");
    out.push_str(ImNode::WGSL);
    for b in ImBinding::ALL {
        let (name, ty) = b.declaration();
        writeln!(
            out,
            "@group({GROUP}) @binding({}) var<storage, read_write> {name}: {ty};",
            b as u32
        )
        .unwrap();
    }
    let u32s = [
        ("ACC_WORDS", acc::WORDS),
        ("PRODUCT_WORD", acc::PRODUCT_WORD),
        ("V_MOMENTUM", acc::MOMENTUM),
        ("V_MASS", acc::MASS),
        ("V_GRAD", acc::GRAD),
        ("V_BLOCK", acc::BLOCK),
        ("V_PRODUCT", acc::PRODUCT),
        ("STIFF_STRIDE", stiffness::WORDS),
        ("SCATTER_Q", stiffness::SCATTER_Q),
    ];
    for (name, value) in u32s.into_iter().chain(scalar::ALL) {
        writeln!(out, "const {name}: u32 = {value}u;").unwrap();
    }
    for c in Clear::ALL {
        writeln!(out, "const {}: u32 = {}u;", c.wgsl_name(), c as u32).unwrap();
    }
    writeln!(out, "const FIXED_BITS: i32 = {FIXED_BITS};").unwrap();
    // 2^(FIXED_BITS + 1), written out whole: a recomputed contribution a rounding above its
    // bound still fits.
    writeln!(
        out,
        "const FIXED_CLAMP: f32 = {}.0;",
        1u64 << (FIXED_BITS + 1)
    )
    .unwrap();
    out
}
