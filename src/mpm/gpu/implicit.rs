//! Host side of `implicit.wgsl`: backward-Euler MLS-MPM on the device, the CPU solver's
//! math (`mpm::cpu::implicit`: Gast et al. 2015, Newton on the grid velocities, projected
//! PCG with block Jacobi, backtracking line search, Eisenstat–Walker forcing, warm start)
//! with the node and particle work in WGSL.
//!
//! Split of the work. Every array the solve touches lives on the device: per node (of the
//! active blocks) v*, the iterate, the trial, ∇Φ, the Newton step, the CG vectors, the
//! constraint projection, the preconditioner and the warm-start correction; per particle
//! the 9×9 velocity-gradient stiffness and the 3×3 matrix its scatter multiplies (360 B).
//! Sums (energies, norms, dot products) are two-level reductions: each workgroup leaves its
//! sum in a partials buffer, one workgroup adds them up (compensated f32) into a scalar.
//! The conjugate gradients keep their scalars (rz, α, β, the iteration count, a done flag)
//! on the device: one CG iteration is ten dispatches (product clear, particle product,
//! particle scatter, node finish, sum, α, update, sum, β, direction) and reads nothing back; the host records `CG_CHUNK` iterations, then reads
//! the 128-byte scalar block to see whether CG has stopped (iterations past the stop are
//! recorded but return at once). Newton and the line search stay on the host, as in the
//! CPU solver, because each decision (forcing term, Armijo test, stopping) needs Φ or ‖∇Φ‖:
//! each evaluation is one submission and one 128-byte readback.
//!
//! Active-set rounds (cpu `activate_constraints`). After Newton converges, `im_activate`
//! re-evaluates each node's constraint at the iterate v (the `node_constraint` that chose
//! them from v*); a node the solution moves into a tool, the table or a wall gets the
//! constraint (only more prescribed components: the set grows), its iterate is projected
//! and an atomic counter in the scalar block counts it. The host reads the count back (one
//! readback per round) and, where nodes grew, re-evaluates and resumes Newton, at most
//! `CONTACT_ROUNDS` rounds.
//!
//! Cost per substep, with Newton iterations k = 1..N, Cₖ CG iterations and Lₖ line-search
//! trials in iteration k (counted from the code below):
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
//! 2,300 dispatches. On a
//! discrete GPU a submit-and-wait round trip costs some 20–50 µs and a dispatch a few µs,
//! so such a substep is latency bound at a few milliseconds before any arithmetic; the
//! arithmetic per CG iteration is one pass over the particles' stiffness (324 B each) and a
//! few over the active nodes, memory bound like an explicit substep. The frame's readback
//! of positions and statistics is the explicit solver's (see `super`). Fewer round trips
//! (the slope and the line search's first trial folded into the last CG chunk, Newton's
//! stopping test on the device) are the next step where latency dominates.
//!
//! Order-independent sums: the result is the same from run to run. The particle scatters
//! (P2G's momentum and mass, ∇Φ, the diagonal blocks, the Hessian product) add 64-bit
//! fixed-point integers (two u32 atomics each), in a unit set from a bound on the
//! contributions that a first pass over the particles raises, so that each scatter is two
//! particle passes (`implicit.wgsl` `fixed_add` has the range and resolution); the
//! reductions add per-workgroup partials in a fixed tree, the node workgroups in the active
//! blocks' increasing index (`sparse.wgsl` `compact`). With f32 atomics the sums changed
//! with the order the invocations ran in: on llvmpipe the sphere-press agreement scene took
//! 121–142 Newton iterations from run to run, where the fixed-point solve takes the same
//! count every run.
//!
//! Requires f32 atomics (`SHADER_FLOAT32_ATOMIC`) for group 0's accumulators, which the
//! solve stores the grid update's mass and momentum into, and at most [`MAX_PARTICLES`]
//! particles. Without them, and in scenes that cut, the solver refuses implicit (`auto`
//! then takes the CPU).

use super::resources::Resources;
use super::{GpuSolver, Groups};
use crate::mpm::cpu::implicit::{forcing_term, CONTACT_ROUNDS};
use crate::mpm::frame_plan::FramePlan;
use crate::mpm::{ImplicitParams, Preconditioner, SolveCounts};
use std::sync::mpsc;

/// The stage's WGSL (after the prelude, `common.wgsl` and the P2G variant).
pub const SOURCE: &str = include_str!("implicit.wgsl");

/// CG iterations recorded between two looks at whether CG has stopped.
pub const CG_CHUNK: u32 = 8;

/// Bytes per node of `ImNode` (13 vec4 and two mat3x3) and of the accumulators (16
/// two-word fixed-point sums, then the finished product's 3 f32 and a word of padding).
const NODE_BYTES: u64 = 13 * 16 + 2 * 48;
const ACC_BYTES: u64 = 36 * 4;
/// Words per particle of the stiffness buffer: the 9×9 stiffness, then the scatter's 3×3.
const STIFF_WORDS: u64 = 90;

/// The most particles the implicit solve takes: a node's fixed-point sum takes one
/// contribution of at most 2^40 units per particle, so 2^22 particles keep it below 2^62
/// (`implicit.wgsl` `fixed_add`).
pub const MAX_PARTICLES: usize = 1 << 22;
const SCALAR_WORDS: usize = 32;

// Words of the scalar block (implicit.wgsl `I_*` and the sum slots).
const I_CRUSH: usize = 3;
const I_ALPHA: usize = 4;
const I_TARGET: usize = 5;
const I_EPOCH: usize = 6;
const I_CAP: usize = 7;
const I_ITER: usize = 2;
const I_DONE: usize = 1;
const I_ACTIVATED: usize = 11;
const SLOT_ELASTIC: u32 = 12;
const SLOT_KINETIC: u32 = 14;
const SLOT_RZ0: u32 = 16;
const SLOT_PAP: u32 = 18;
const SLOT_RR: u32 = 20;
const SLOT_SLOPE: u32 = 22;
const SLOT_MASS: u32 = 24;
// Which sums `im_clear` zeroes (implicit.wgsl `CLEAR_*`).
const CLEAR_P2G: f64 = 0.0;
const CLEAR_EVAL: f64 = 1.0;
const CLEAR_PRODUCT: f64 = 2.0;

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

/// Newton's absolute residual scales (N·s): the floor (a velocity error of 1e-5·dx/dt per
/// node) and the momentum gravity gives the nodes in one step.
struct Scales {
    floor: f64,
    gravity: f64,
}

/// The scalar block read back.
struct Scalars([u32; SCALAR_WORDS]);

impl Scalars {
    fn f(&self, i: u32) -> f64 {
        f32::from_bits(self.0[i as usize]) as f64
    }
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
            particles as u64 * STIFF_WORDS * 4,
        );
        let groups = particles.div_ceil(super::WG as usize).max(blocks).max(1);
        let partials = storage(device, "implicit partials", 2 * groups as u64 * 4);
        let scalars = storage(device, "implicit scalars", (SCALAR_WORDS * 4) as u64);
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("implicit scalars readback"),
            size: (SCALAR_WORDS * 4) as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let entries: Vec<_> = (0..5)
            .map(|binding| wgpu::BindGroupLayoutEntry {
                binding,
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
        let buffers = [&node_buffer, &acc, &stiffness, &partials, &scalars];
        let bind_entries: Vec<_> = buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("implicit"),
            layout: &layout,
            entries: &bind_entries,
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("mpm + implicit"),
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
            p2g_clear: make("im_clear", &[("CLEAR", CLEAR_P2G)]),
            p2g_bound: make("im_p2g", &[("BOUND_PASS", 1.0)]),
            p2g: make("im_p2g", &[("BOUND_PASS", 0.0)]),
            prepare: make("im_prepare", &[]),
            trial_correction: make("im_trial_correction", &[]),
            energy: [select("im_energy", false), select("im_energy", true)],
            kinetic: [select("im_kinetic", false), select("im_kinetic", true)],
            eval_clear: make("im_clear", &[("CLEAR", CLEAR_EVAL)]),
            eval: [eval("im_eval", false), eval("im_eval", true)],
            eval_scatter: [
                eval("im_eval_scatter", false),
                eval("im_eval_scatter", true),
            ],
            eval_nodes: [eval("im_eval_nodes", false), eval("im_eval_nodes", true)],
            cg_init: make("im_cg_init", &[]),
            cg_start: make("im_cg_start", &[("SLOT", SLOT_RZ0 as f64)]),
            product_clear: make("im_clear", &[("CLEAR", CLEAR_PRODUCT)]),
            product: make("im_product", &[]),
            product_scatter: make("im_product_scatter", &[]),
            product_finish: make("im_product_finish", &[]),
            cg_alpha: make("im_cg_alpha", &[("SLOT", SLOT_PAP as f64)]),
            cg_update: make("im_cg_update", &[]),
            cg_beta: make("im_cg_beta", &[("SLOT", SLOT_RR as f64)]),
            cg_direction: make("im_cg_direction", &[]),
            slope: make("im_slope", &[]),
            trial_step: make("im_trial_step", &[]),
            accept: make("im_accept", &[]),
            finish: make("im_finish", &[]),
            activate: make("im_activate", &[]),
            sum_elastic: sum(SLOT_ELASTIC, false),
            sum_kinetic: sum(SLOT_KINETIC, true),
            sum_rz0: sum(SLOT_RZ0, true),
            sum_pap: sum(SLOT_PAP, true),
            sum_rr: sum(SLOT_RR, true),
            sum_slope: sum(SLOT_SLOPE, true),
            sum_mass: sum(SLOT_MASS, true),
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
fn single(pass: &mut wgpu::ComputePass, p: &wgpu::ComputePipeline) {
    pass.set_pipeline(p);
    pass.dispatch_workgroups(1, 1, 1);
}

fn nodes(pass: &mut wgpu::ComputePass, p: &wgpu::ComputePipeline, g: &Groups) {
    pass.set_pipeline(p);
    pass.dispatch_workgroups_indirect(g.active_blocks, 0);
}

fn particles(pass: &mut wgpu::ComputePass, p: &wgpu::ComputePipeline, g: &Groups) {
    pass.set_pipeline(p);
    pass.dispatch_workgroups(g.particles, 1, 1);
}

impl ImplicitStages {
    /// Φ (elastic + kinetic) at v (`trial` false) or the trial velocities.
    fn record_energy(&self, pass: &mut wgpu::ComputePass, trial: bool, g: &Groups) {
        let p = &self.pipelines;
        particles(pass, &p.energy[trial as usize], g);
        single(pass, &p.sum_elastic);
        nodes(pass, &p.kinetic[trial as usize], g);
        single(pass, &p.sum_kinetic);
    }

    /// Φ, ∇Φ and, with `hessian`, the stiffness and preconditioner at v.
    fn record_evaluate(&self, pass: &mut wgpu::ComputePass, hessian: bool, g: &Groups) {
        let p = &self.pipelines;
        nodes(pass, &p.eval_clear, g);
        particles(pass, &p.eval[hessian as usize], g);
        particles(pass, &p.eval_scatter[hessian as usize], g);
        single(pass, &p.sum_elastic);
        nodes(pass, &p.eval_nodes[hessian as usize], g);
        single(pass, &p.sum_kinetic);
    }

    fn record_cg_iteration(&self, pass: &mut wgpu::ComputePass, g: &Groups) {
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

impl GpuSolver {
    /// Records `f` into a compute pass bound to substep `s` and the implicit group, submits
    /// it and, with `read`, returns the scalar block after it.
    fn implicit_pass(
        &self,
        s: u32,
        read: bool,
        f: impl FnOnce(&mut wgpu::ComputePass, &ImplicitStages, &Groups),
    ) -> Option<Scalars> {
        let im = self.implicit.as_ref().expect("implicit stages");
        let device = &self.ctx.device;
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("implicit"),
        });
        {
            let groups = self.groups();
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("implicit"),
                timestamp_writes: None,
            });
            self.res.bind_step(&mut pass, s);
            pass.set_bind_group(1, &im.bind_group, &[]);
            f(&mut pass, im, &groups);
        }
        if read {
            encoder.copy_buffer_to_buffer(&im.scalars, 0, &im.staging, 0, None);
        }
        self.ctx.queue.submit([encoder.finish()]);
        if !read {
            return None;
        }
        let (tx, rx) = mpsc::channel();
        im.staging
            .slice(..)
            .map_async(wgpu::MapMode::Read, move |r| {
                let _ = tx.send(r);
            });
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .expect("GPU device lost during the implicit solve");
        rx.recv()
            .expect("map callback ran")
            .expect("implicit scalar readback failed");
        let mut words = [0u32; SCALAR_WORDS];
        words.copy_from_slice(bytemuck::cast_slice(
            &im.staging.slice(..).get_mapped_range(),
        ));
        im.staging.unmap();
        Some(Scalars(words))
    }

    /// Writes scalar word `i` (host-set: α, the CG target, the epoch, the cap).
    fn write_scalar(&self, i: usize, bits: u32) {
        let im = self.implicit.as_ref().expect("implicit stages");
        self.ctx
            .queue
            .write_buffer(&im.scalars, (i * 4) as u64, bytemuck::bytes_of(&bits));
    }

    /// Φ at v or the trial; infinite where a particle would be crushed.
    fn implicit_energy(&self, s: u32, trial: bool) -> f64 {
        self.write_scalar(I_CRUSH, 0);
        let sc = self
            .implicit_pass(s, true, |pass, im, g| im.record_energy(pass, trial, g))
            .expect("read back");
        if sc.0[I_CRUSH] != 0 {
            return f64::INFINITY;
        }
        sc.f(SLOT_ELASTIC) + sc.f(SLOT_KINETIC)
    }

    /// Φ and ‖∇Φ‖ at v (with `hessian` the stiffness and preconditioner too).
    fn implicit_evaluate(&self, s: u32, hessian: bool) -> (f64, f64) {
        let sc = self
            .implicit_pass(s, true, |pass, im, g| im.record_evaluate(pass, hessian, g))
            .expect("read back");
        (
            sc.f(SLOT_ELASTIC) + sc.f(SLOT_KINETIC),
            sc.f(SLOT_KINETIC + 1).max(0.0).sqrt(),
        )
    }

    /// One implicit substep of `dt` under `gravity`, recorded and submitted in pieces
    /// (module docs); scenes that cut are refused at construction, so P2G is momentum and
    /// mass alone.
    pub(super) fn implicit_substep(&mut self, s: u32, dt: f32, gravity: f32) -> SolveCounts {
        let params = self.implicit.as_ref().expect("implicit stages").params;
        let epoch = self.implicit.as_ref().map_or(0, |im| im.epoch);
        self.write_scalar(I_EPOCH, epoch);
        self.write_scalar(I_CAP, params.cg_iterations);
        self.write_scalar(I_CRUSH, 0);
        // Block list, clear, P2G, the nodes' start (and Σm²); Φ of the carried velocities.
        let sc = self
            .implicit_pass(s, true, |pass, im, g| {
                pass.set_bind_group(1, &self.res.args_group, &[]);
                self.sparse.record(pass, g);
                pass.set_bind_group(1, &im.bind_group, &[]);
                let p = &im.pipelines;
                nodes(pass, &p.p2g_clear, g);
                particles(pass, &p.p2g_bound, g);
                particles(pass, &p.p2g, g);
                nodes(pass, &p.prepare, g);
                single(pass, &p.sum_mass);
                im.record_energy(pass, false, g);
            })
            .expect("read back");
        let mass_norm = sc.f(SLOT_MASS).max(0.0).sqrt();
        let carried = if sc.0[I_CRUSH] != 0 {
            f64::INFINITY
        } else {
            sc.f(SLOT_ELASTIC) + sc.f(SLOT_KINETIC)
        };
        // Warm start: the lowest Φ of v*, rest and v* plus the last elastic change.
        let rest = self.implicit_energy(s, true);
        let mut best = carried;
        if rest < carried {
            self.implicit_pass(s, false, |pass, im, g| nodes(pass, &im.pipelines.accept, g));
            best = rest;
        }
        if epoch > 0 {
            self.implicit_pass(s, false, |pass, im, g| {
                nodes(pass, &im.pipelines.trial_correction, g)
            });
            if self.implicit_energy(s, true) < best {
                self.implicit_pass(s, false, |pass, im, g| nodes(pass, &im.pipelines.accept, g));
            }
        }
        let scales = Scales {
            floor: 1e-5 * mass_norm * (self.layout.dx / dt) as f64,
            gravity: (gravity * dt) as f64 * mass_norm,
        };
        let counts = self.implicit_newton(s, &params, scales);
        self.implicit_pass(s, false, |pass, im, g| {
            nodes(pass, &im.pipelines.finish, g);
            self.grid_update.record_implicit(pass, g);
            self.g2p.record(pass, g);
            self.grid_update.record_reduce(pass);
        });
        if let Some(im) = self.implicit.as_mut() {
            im.epoch += 1;
        }
        counts
    }

    /// Newton's method on the grid velocities (cpu `solve_velocities`): Newton on the
    /// active set, then the nodes the solution moves into a tool, the table or a wall join
    /// it and Newton resumes, at most `CONTACT_ROUNDS` times.
    fn implicit_newton(&mut self, s: u32, params: &ImplicitParams, scales: Scales) -> SolveCounts {
        let mut counts = SolveCounts::default();
        let mut first_norm = None;
        let mut residuals = Vec::new();
        let (mut energy, mut norm) = self.implicit_evaluate(s, true);
        for round in 0..=CONTACT_ROUNDS {
            let mut newton = 0;
            let mut previous: Option<(f64, f64)> = None;
            loop {
                residuals.push(norm);
                let reference = first_norm.get_or_insert(norm).max(scales.gravity);
                let goal = (params.newton_tolerance as f64 * reference).max(scales.floor);
                if norm <= goal || newton >= params.newton_iterations {
                    break;
                }
                let eta = forcing_term(norm, previous, goal, params.cg_tolerance as f64);
                previous = Some((norm, eta));
                counts.cg += self.implicit_cg(s, eta * norm);
                newton += 1;
                let at_rounding = match self.implicit_line_search(s, energy) {
                    Some((e, at_rounding)) if e.is_finite() => at_rounding,
                    _ => break,
                };
                let more = !at_rounding && newton < params.newton_iterations;
                (energy, norm) = self.implicit_evaluate(s, more);
                if at_rounding {
                    residuals.push(norm);
                    break;
                }
            }
            counts.newton += newton;
            if round == CONTACT_ROUNDS {
                break;
            }
            let activated = self.implicit_activate(s);
            counts.activated += activated;
            if activated == 0 {
                break;
            }
            (energy, norm) = self.implicit_evaluate(s, true);
        }
        if let Some(im) = self.implicit.as_mut() {
            im.residuals = residuals;
        }
        counts
    }

    /// Grows the active set at the iterate (cpu `activate_constraints`); returns how many
    /// nodes gained a constraint.
    fn implicit_activate(&self, s: u32) -> u32 {
        self.write_scalar(I_ACTIVATED, 0);
        self.implicit_pass(s, true, |pass, im, g| {
            nodes(pass, &im.pipelines.activate, g)
        })
        .expect("read back")
        .0[I_ACTIVATED]
    }

    /// Preconditioned CG until ‖r‖ ≤ `target` or the cap; returns its iterations.
    fn implicit_cg(&self, s: u32, target: f64) -> u32 {
        self.write_scalar(I_TARGET, (target as f32).to_bits());
        self.implicit_pass(s, false, |pass, im, g| {
            let p = &im.pipelines;
            nodes(pass, &p.cg_init, g);
            single(pass, &p.sum_rz0);
            single(pass, &p.cg_start);
        });
        loop {
            let sc = self
                .implicit_pass(s, true, |pass, im, g| {
                    for _ in 0..CG_CHUNK {
                        im.record_cg_iteration(pass, g);
                    }
                })
                .expect("read back");
            if sc.0[I_DONE] != 0 {
                return sc.0[I_ITER];
            }
        }
    }

    /// Backtracking along the Newton step (cpu `line_search`).
    fn implicit_line_search(&self, s: u32, energy: f64) -> Option<(f64, bool)> {
        let slope = self
            .implicit_pass(s, true, |pass, im, g| {
                nodes(pass, &im.pipelines.slope, g);
                single(pass, &im.pipelines.sum_slope);
            })
            .expect("read back")
            .f(SLOT_SLOPE);
        let noise = 1e-6 * energy.abs();
        let trial_at = |alpha: f32| {
            self.write_scalar(I_ALPHA, alpha.to_bits());
            self.implicit_pass(s, false, |pass, im, g| {
                nodes(pass, &im.pipelines.trial_step, g)
            });
            self.implicit_energy(s, true)
        };
        let accept = || {
            self.implicit_pass(s, false, |pass, im, g| nodes(pass, &im.pipelines.accept, g));
        };
        if -0.5 * slope <= noise {
            let trial_energy = trial_at(1.0);
            if !trial_energy.is_finite() {
                return None;
            }
            accept();
            return Some((trial_energy, true));
        }
        let mut alpha = 1.0f32;
        let mut trial_energy = f64::NAN;
        for _ in 0..8 {
            trial_energy = trial_at(alpha);
            if trial_energy <= energy + 1e-4 * alpha as f64 * slope + noise {
                break;
            }
            alpha *= 0.5;
        }
        accept();
        Some((trial_energy, false))
    }
}

impl GpuSolver {
    /// A frame of implicit substeps: the frame-start copy, each substep in its submissions,
    /// then the frame's end and readback as the explicit solver's.
    pub(super) fn submit_implicit_frame(&mut self, plan: &FramePlan) {
        let device = &self.ctx.device;
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("frame start"),
        });
        encoder.copy_buffer_to_buffer(&self.res.particles, 0, &self.res.snapshot, 0, None);
        self.ctx.queue.submit([encoder.finish()]);
        let mut solve = SolveCounts::default();
        for s in 0..plan.substeps {
            solve.add(self.implicit_substep(s, plan.dt, plan.gravity.norm()));
        }
        self.frame_solve = solve;
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame end"),
            });
        {
            let groups = self.groups();
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("frame end"),
                timestamp_writes: None,
            });
            self.res.bind_step(&mut pass, 0);
            self.g2p.record_frame_end(&mut pass, &groups);
        }
        let copies = self.readback.record(
            &mut encoder,
            &self.res.stats,
            &self.res.extract,
            self.n as usize,
            self.read_deformation,
        );
        self.ctx.queue.submit([encoder.finish()]);
        self.readback.request(copies);
    }

    /// ‖∇Φ‖ over the free components at each Newton iterate of the last implicit substep
    /// (N·s), the first the warm start's; empty for the explicit methods.
    pub fn implicit_residuals(&self) -> &[f64] {
        self.implicit.as_ref().map_or(&[], |im| &im.residuals)
    }
}
