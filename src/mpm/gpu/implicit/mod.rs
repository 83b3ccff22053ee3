//! Backward-Euler MLS-MPM on the device: the CPU solver's math (`mpm::cpu::implicit`:
//! Gast et al. 2015, Newton on the grid velocities, projected PCG with block Jacobi,
//! backtracking line search, Eisenstat–Walker forcing, warm start) with the node and
//! particle work in WGSL, and the settings and rules both backends share from
//! [`crate::mpm::implicit_params`].
//!
//! Files. `layout.rs` declares the solve's device layouts once (the node record, the
//! fixed-point sums, the stiffness record, the scalar block, its bind group) and generates
//! their WGSL; the shader is that, then one file per part of the solve: `reduce.wgsl`
//! (scalar block, reductions), `elasticity.wgsl` (stencil gradients, Ψ, P, the stiffness),
//! `fixed_point.wgsl` (order-independent scatters), `start.wgsl` (P2G without stress, the
//! nodes' start), `constraints.wgsl`, `slip.wgsl`, `evaluate.wgsl` (Φ, ∇Φ, the
//! preconditioner), `cg.wgsl`, `line_search.wgsl` and `finish.wgsl`. This file builds the
//! buffers and pipelines and records the dispatches; `solve.rs` drives a substep from the
//! host.
//!
//! Split of the work. Every array the solve touches lives on the device: per node (of the
//! active blocks) v*, the iterate, the trial, ∇Φ, the Newton step, the CG vectors, the
//! constraint projection, the preconditioner and the warm-start correction; per particle
//! the 9×9 velocity-gradient stiffness and the 3×3 matrix its scatter multiplies (360 B).
//! Sums (energies, norms, dot products) are two-level reductions: each workgroup leaves its
//! sum in a partials buffer, one workgroup adds them up (compensated f32) into a scalar.
//! The conjugate gradients keep their scalars (rz, α, β, the iteration count, a done flag)
//! on the device: one CG iteration is ten dispatches (product clear, particle product,
//! particle scatter, node finish, sum, α, update, sum, β, direction) and reads nothing
//! back; the host records [`CG_CHUNK`] iterations, then reads the 128-byte scalar block to
//! see whether CG has stopped (iterations past the stop are recorded but return at once).
//! Newton and the line search stay on the host, as in the CPU solver, because each
//! decision (forcing term, Armijo test, stopping) needs Φ or ‖∇Φ‖: each evaluation is one
//! submission and one 128-byte readback.
//!
//! Active-set rounds (cpu `activate_constraints`). After Newton converges, `im_activate`
//! re-evaluates each node's constraint at the iterate v (the `node_constraint` that chose
//! them from v*); a node the solution moves into a tool, the table or a wall gets the
//! constraint (only more prescribed components: the set grows), its iterate is projected
//! and an atomic counter in the scalar block counts it. The host reads the count back (one
//! readback per round) and, where nodes grew, re-evaluates and resumes Newton, at most
//! [`CONTACT_ROUNDS`](crate::mpm::implicit_params::CONTACT_ROUNDS) rounds.
//!
//! Cost per substep, with Newton iterations k = 1..N, Cₖ CG iterations and Lₖ line-search
//! trials in iteration k (counted from `solve.rs`):
//! - readbacks (128 bytes each, one submission and one wait each): 4 (P2G with the
//!   carried Φ, the rest Φ, the corrected Φ, the first evaluation) + Σₖ (⌈Cₖ/CG_CHUNK⌉ +
//!   Lₖ + 2) (CG chunks, trials, the slope, the evaluation) + 2 per active-set round
//!   that grew (the count, the evaluation) + 1 for the round that grew none;
//! - submissions without a readback: about 4 + 3N (warm-start choices, CG start, trial
//!   steps, acceptance, the end);
//! - dispatches: about 33 + Σₖ (80·⌈Cₖ/CG_CHUNK⌉ + 5Lₖ + 12); a chunk always records its 8
//!   iterations, those past CG's stop return at once.
//!
//! For a substep of 9 Newton iterations with ~19 CG iterations and ~1 trial each (the
//! sphere-press agreement scene's) that is about 58 readbacks, 30 other submissions and
//! 2,300 dispatches. On a discrete GPU a submit-and-wait round trip costs some 20–50 µs and
//! a dispatch a few µs, so such a substep is latency bound at a few milliseconds before any
//! arithmetic; the arithmetic per CG iteration is one pass over the particles' stiffness
//! (324 B each) and a few over the active nodes, memory bound like an explicit substep. The
//! frame's readback of positions and statistics is the explicit solver's (see `super`).
//! Where latency dominates, fewer round trips would come from folding the slope and the
//! line search's first trial into the last CG chunk and testing Newton's stop on the
//! device.
//!
//! Order-independent sums: the result is the same from run to run. f32 atomics add in the
//! order the invocations happen to run, so sums scattered with them, and the Newton and CG
//! counts that follow, would change from run to run. The particle scatters (P2G's momentum
//! and mass, ∇Φ, the diagonal blocks, the Hessian product) therefore add 64-bit fixed-point
//! integers (two u32 atomics each), in a unit set from a bound on the contributions that a
//! first pass over the particles raises, so that each scatter is two particle passes
//! (`fixed_point.wgsl` has the range and resolution); the reductions add per-workgroup
//! partials in a fixed tree, the node workgroups in the active blocks' increasing index
//! (`sparse.wgsl` `compact`).
//!
//! Requires f32 atomics (`SHADER_FLOAT32_ATOMIC`) for group 0's accumulators, which the
//! solve stores the grid update's mass and momentum into (`im_prepare`, `im_finish`), and
//! at most [`MAX_PARTICLES`] particles. Without them, and in scenes that cut, the solver
//! refuses implicit (`auto` then takes the CPU).

mod layout;
mod solve;

use super::pass::CountingPass;
use super::resources::Resources;
use super::Groups;
use crate::mpm::{ImplicitParams, Preconditioner};
pub use layout::MAX_PARTICLES;
use layout::{scalar, Clear, ImBinding, ACC_BYTES, NODE_BYTES, STIFFNESS_BYTES};

/// The stage's WGSL (after the prelude, `common.wgsl` and the P2G variant): the layouts
/// generated from `layout.rs`, then the solve's shader files.
pub fn source() -> String {
    let files = [
        include_str!("reduce.wgsl"),
        include_str!("elasticity.wgsl"),
        include_str!("fixed_point.wgsl"),
        include_str!("start.wgsl"),
        include_str!("constraints.wgsl"),
        include_str!("slip.wgsl"),
        include_str!("evaluate.wgsl"),
        include_str!("cg.wgsl"),
        include_str!("line_search.wgsl"),
        include_str!("finish.wgsl"),
    ];
    let mut out = layout::declarations();
    for file in files {
        out.push('\n');
        out.push_str(file);
    }
    out
}

/// CG iterations recorded between two looks at whether CG has stopped.
pub const CG_CHUNK: u32 = 8;

struct Pipelines {
    p2g_clear: wgpu::ComputePipeline,
    /// The P2G pass that raises the bounds, then the one that scatters.
    p2g_bound: wgpu::ComputePipeline,
    p2g: wgpu::ComputePipeline,
    prepare: wgpu::ComputePipeline,
    trial_correction: wgpu::ComputePipeline,
    /// Elastic energy at [v, trial].
    energy: [wgpu::ComputePipeline; 2],
    kinetic: [wgpu::ComputePipeline; 2],
    eval_clear: wgpu::ComputePipeline,
    /// [without, with] the Hessian.
    eval: [wgpu::ComputePipeline; 2],
    eval_scatter: [wgpu::ComputePipeline; 2],
    eval_nodes: [wgpu::ComputePipeline; 2],
    cg_init: wgpu::ComputePipeline,
    cg_start: wgpu::ComputePipeline,
    product_clear: wgpu::ComputePipeline,
    product: wgpu::ComputePipeline,
    product_scatter: wgpu::ComputePipeline,
    product_finish: wgpu::ComputePipeline,
    cg_alpha: wgpu::ComputePipeline,
    cg_update: wgpu::ComputePipeline,
    cg_beta: wgpu::ComputePipeline,
    cg_direction: wgpu::ComputePipeline,
    slope: wgpu::ComputePipeline,
    trial_step: wgpu::ComputePipeline,
    accept: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    activate: wgpu::ComputePipeline,
    sum_elastic: wgpu::ComputePipeline,
    sum_kinetic: wgpu::ComputePipeline,
    sum_rz0: wgpu::ComputePipeline,
    sum_pap: wgpu::ComputePipeline,
    sum_rr: wgpu::ComputePipeline,
    sum_slope: wgpu::ComputePipeline,
    sum_mass: wgpu::ComputePipeline,
}

/// The implicit solve's device buffers, bind group, pipelines and host state.
pub struct ImplicitStages {
    pipelines: Pipelines,
    bind_group: wgpu::BindGroup,
    scalars: wgpu::Buffer,
    staging: wgpu::Buffer,
    params: ImplicitParams,
    /// Implicit substeps run so far: the warm start reads the correction of the last one.
    epoch: u32,
    /// ‖∇Φ‖ at each Newton iterate of the last substep (N·s).
    residuals: Vec<f64>,
}

fn storage(device: &wgpu::Device, label: &str, size: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size.max(16),
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_DST
            | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    })
}

impl ImplicitStages {
    /// Buffers for `nodes` grid nodes, `particles` particles and `blocks` blocks; pipelines
    /// on group 0 of `res` and the solve's own group 1.
    pub fn new(
        device: &wgpu::Device,
        res: &Resources,
        module: &wgpu::ShaderModule,
        sizes: (usize, usize, usize),
        params: ImplicitParams,
    ) -> Self {
        let (nodes, particles, blocks) = sizes;
        let node_buffer = storage(device, "implicit nodes", nodes as u64 * NODE_BYTES);
        let acc = storage(device, "implicit accumulators", nodes as u64 * ACC_BYTES);
        let stiffness = storage(
            device,
            "implicit stiffness",
            particles as u64 * STIFFNESS_BYTES,
        );
        let groups = particles.div_ceil(super::WG as usize).max(blocks).max(1);
        let partials = storage(device, "implicit partials", 2 * groups as u64 * 4);
        let scalars = storage(device, "implicit scalars", (scalar::WORDS * 4) as u64);
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("implicit scalars readback"),
            size: (scalar::WORDS * 4) as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let entries: Vec<_> = ImBinding::ALL
            .iter()
            .map(|&b| wgpu::BindGroupLayoutEntry {
                binding: b as u32,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only: false },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            })
            .collect();
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("implicit"),
            entries: &entries,
        });
        let bind_entries: Vec<_> = ImBinding::ALL
            .iter()
            .map(|&b| wgpu::BindGroupEntry {
                binding: b as u32,
                resource: match b {
                    ImBinding::Nodes => &node_buffer,
                    ImBinding::Acc => &acc,
                    ImBinding::Stiffness => &stiffness,
                    ImBinding::Partials => &partials,
                    ImBinding::Scalars => &scalars,
                }
                .as_entire_binding(),
            })
            .collect();
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("implicit"),
            layout: &layout,
            entries: &bind_entries,
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("mpm + implicit"),
            // Group 0, then the solve's own group (`layout::GROUP`).
            bind_group_layouts: &[&res.group0, &layout],
            push_constant_ranges: &[],
        });
        let block_jacobi = if params.preconditioner == Preconditioner::BlockJacobi {
            1.0
        } else {
            0.0
        };
        let make = |entry: &str, constants: &[(&str, f64)]| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&pipeline_layout),
                module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants,
                    ..Default::default()
                },
                cache: None,
            })
        };
        let sum = |slot: u32, over_nodes: bool| {
            make(
                "im_sum",
                &[
                    ("SLOT", slot as f64),
                    ("OVER_NODES", if over_nodes { 1.0 } else { 0.0 }),
                ],
            )
        };
        let select =
            |entry: &str, trial: bool| make(entry, &[("SELECT_TRIAL", trial as u8 as f64)]);
        let eval = |entry: &str, hessian: bool| {
            make(
                entry,
                &[
                    ("HESSIAN", hessian as u8 as f64),
                    ("BLOCK_JACOBI", block_jacobi),
                ],
            )
        };
        let pipelines = Pipelines {
            p2g_clear: make("im_clear", &[("CLEAR", Clear::P2g as u32 as f64)]),
            p2g_bound: make("im_p2g", &[("BOUND_PASS", 1.0)]),
            p2g: make("im_p2g", &[("BOUND_PASS", 0.0)]),
            prepare: make("im_prepare", &[]),
            trial_correction: make("im_trial_correction", &[]),
            energy: [select("im_energy", false), select("im_energy", true)],
            kinetic: [select("im_kinetic", false), select("im_kinetic", true)],
            eval_clear: make("im_clear", &[("CLEAR", Clear::Eval as u32 as f64)]),
            eval: [eval("im_eval", false), eval("im_eval", true)],
            eval_scatter: [
                eval("im_eval_scatter", false),
                eval("im_eval_scatter", true),
            ],
            eval_nodes: [eval("im_eval_nodes", false), eval("im_eval_nodes", true)],
            cg_init: make("im_cg_init", &[]),
            cg_start: make("im_cg_start", &[("SLOT", scalar::SLOT_RZ0 as f64)]),
            product_clear: make("im_clear", &[("CLEAR", Clear::Product as u32 as f64)]),
            product: make("im_product", &[]),
            product_scatter: make("im_product_scatter", &[]),
            product_finish: make("im_product_finish", &[]),
            cg_alpha: make("im_cg_alpha", &[("SLOT", scalar::SLOT_PAP as f64)]),
            cg_update: make("im_cg_update", &[]),
            cg_beta: make("im_cg_beta", &[("SLOT", scalar::SLOT_RR as f64)]),
            cg_direction: make("im_cg_direction", &[]),
            slope: make("im_slope", &[]),
            trial_step: make("im_trial_step", &[]),
            accept: make("im_accept", &[]),
            finish: make("im_finish", &[]),
            activate: make("im_activate", &[]),
            sum_elastic: sum(scalar::SLOT_ELASTIC, false),
            sum_kinetic: sum(scalar::SLOT_KINETIC, true),
            sum_rz0: sum(scalar::SLOT_RZ0, true),
            sum_pap: sum(scalar::SLOT_PAP, true),
            sum_rr: sum(scalar::SLOT_RR, true),
            sum_slope: sum(scalar::SLOT_SLOPE, true),
            sum_mass: sum(scalar::SLOT_MASS, true),
        };
        ImplicitStages {
            pipelines,
            bind_group,
            scalars,
            staging,
            params,
            epoch: 0,
            residuals: Vec::new(),
        }
    }
}

/// One-invocation dispatch, node dispatch (one workgroup per active block), particle
/// dispatch.
fn single(pass: &mut CountingPass, p: &wgpu::ComputePipeline) {
    pass.set_pipeline(p);
    pass.dispatch_workgroups(1, 1, 1);
}

fn nodes(pass: &mut CountingPass, p: &wgpu::ComputePipeline, g: &Groups) {
    pass.set_pipeline(p);
    pass.dispatch_workgroups_indirect(g.active_blocks, 0);
}

fn particles(pass: &mut CountingPass, p: &wgpu::ComputePipeline, g: &Groups) {
    pass.set_pipeline(p);
    pass.dispatch_workgroups(g.particles, 1, 1);
}

impl ImplicitStages {
    /// Φ (elastic + kinetic) at v (`trial` false) or the trial velocities.
    fn record_energy(&self, pass: &mut CountingPass, trial: bool, g: &Groups) {
        let p = &self.pipelines;
        particles(pass, &p.energy[trial as usize], g);
        single(pass, &p.sum_elastic);
        nodes(pass, &p.kinetic[trial as usize], g);
        single(pass, &p.sum_kinetic);
    }

    /// Φ, ∇Φ and, with `hessian`, the stiffness and preconditioner at v.
    fn record_evaluate(&self, pass: &mut CountingPass, hessian: bool, g: &Groups) {
        let p = &self.pipelines;
        nodes(pass, &p.eval_clear, g);
        particles(pass, &p.eval[hessian as usize], g);
        particles(pass, &p.eval_scatter[hessian as usize], g);
        single(pass, &p.sum_elastic);
        nodes(pass, &p.eval_nodes[hessian as usize], g);
        single(pass, &p.sum_kinetic);
    }

    fn record_cg_iteration(&self, pass: &mut CountingPass, g: &Groups) {
        let p = &self.pipelines;
        nodes(pass, &p.product_clear, g);
        particles(pass, &p.product, g);
        particles(pass, &p.product_scatter, g);
        nodes(pass, &p.product_finish, g);
        single(pass, &p.sum_pap);
        single(pass, &p.cg_alpha);
        nodes(pass, &p.cg_update, g);
        single(pass, &p.sum_rr);
        single(pass, &p.cg_beta);
        nodes(pass, &p.cg_direction, g);
    }
}
