//! The MLS-MPM and PB-MPM solvers on wgpu: the CPU solvers' math in WGSL compute shaders.
//!
//! Stages, one `.wgsl` each, all sharing `common.wgsl` (bindings, stencil, materials, tool
//! SDFs, contact, boundary):
//! - `sparse.wgsl`: flag the 4³-node blocks the particles' stencils touch, compact them into
//!   an active-block list (its length is the indirect dispatch size), clear those blocks;
//! - `p2g.wgsl`: fused APIC + MLS force scatter with f32 atomics, or i32 fixed-point
//!   atomics where the adapter has no f32 atomics (`acc_float.wgsl` / `acc_fixed.wgsl`);
//! - `grid_update.wgsl`: gravity, tools (SDF only inside each tool's bounding box),
//!   friction, momentum exchange reduced per block into per-tool impulses, table, walls;
//! - `g2p.wgsl`: interpolation back, advection, F update, damping and the guard;
//! - `pbmpm.wgsl`: PB-MPM's elastic constraint on C, momentum-only P2G and the inner
//!   iterations' G2P; a PB-MPM substep records the stages above once per iteration, each
//!   iteration with its own parameter entry (gravity in the first only), integrating in
//!   the last (`record_pb_substep`).
//!
//! Particle and grid buffers live on the device for the solver's lifetime. A frame is one
//! submission: the frame-start state is copied on the device (for the guard's restore),
//! every substep is recorded into one compute pass with its parameters selected by a
//! dynamic uniform offset (all substeps' parameters and tool kinematics are written once
//! per frame), and at the end the frame statistics (tool impulses, max speed, clamped
//! count, guard) and the positions are copied into one of two staging buffers used in turn,
//! with the deformation gradients too while an output asks for them
//! ([`GpuSolver::set_deformation_readback`]). Nothing is read back per substep.
//!
//! Submitting a frame and collecting it are separate calls ([`GpuSolver::submit_frame`],
//! [`GpuSolver::collect_frame`]): between them the host copy still holds the previous
//! frame, so its outputs (point cloud, mesh) are built on the CPU while the device computes.

pub mod adapter;
mod pack;

use super::backend::{FramePlan, FrameStats, P2gAtomics};
use super::grid::NODES_PER_BLOCK;
use super::guard::{GuardEvent, GuardKind};
use super::{GridLayout, Method, Particles, PbMpmParams, SolverSetup, TableHold, Vec3, MAX_TOOLS};
use adapter::GpuContext;
use pack::{GpuParticle, GpuTool, SimUniform, StepUniform};
use std::sync::mpsc;

/// Why the GPU backend could not be used.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "backend \"gpu\" asked for, but no GPU adapter exists (no Vulkan, Metal or DX12 \
         driver found; on Debian/Ubuntu `apt-get install mesa-vulkan-drivers` provides the \
         llvmpipe software adapter)"
    )]
    NoAdapter,
    #[error("could not open the GPU device: {0}")]
    Device(String),
    #[error("scene too large for the GPU backend: {0}")]
    TooLarge(String),
}

const WG: u32 = 64;
const STATS_WORDS: usize = 80;
const STATS_BYTES: u64 = 512;
const S_GUARD: usize = 0;
const S_GUARD_PARTICLE: usize = 1;
const S_MAX_SPEED: usize = 2;
const S_CLAMPED: usize = 3;
const S_SUBSTEPS: usize = 4;
const S_GUARD_KIND: usize = 6;
const S_GUARD_SPEED: usize = 7;
const S_GUARD_POS: usize = 8;
const S_IMPULSE: usize = 16;
/// Bytes per particle of the end-of-frame extract: a position and three F columns, vec4 each.
const EXTRACT_BYTES: usize = 64;
/// Fixed-point scale of the integer P2G: 2^26 per unit, so a node holds ±32 units (see
/// `acc_fixed.wgsl`). Measured on the free-block agreement scene: 2^23 leaves 29 µm of
/// position difference to the f32 solver after 0.1 s, 2^26 leaves 1.7 µm.
pub const FIXED_SCALE: f32 = (1u32 << 26) as f32;

struct Pipelines {
    begin: wgpu::ComputePipeline,
    mark: wgpu::ComputePipeline,
    compact: wgpu::ComputePipeline,
    clear: wgpu::ComputePipeline,
    p2g: wgpu::ComputePipeline,
    grid_update: wgpu::ComputePipeline,
    g2p: wgpu::ComputePipeline,
    reduce: wgpu::ComputePipeline,
    finalize: wgpu::ComputePipeline,
    extract: wgpu::ComputePipeline,
    pb_constrain: wgpu::ComputePipeline,
    pb_p2g: wgpu::ComputePipeline,
    pb_g2p: wgpu::ComputePipeline,
    pb_next_iteration: wgpu::ComputePipeline,
}

pub struct GpuSolver {
    ctx: GpuContext,
    layout: GridLayout,
    float_p2g: bool,
    method: Method,
    pb_mpm: PbMpmParams,
    n: u32,
    tool_count: usize,
    max_substeps: u32,
    step_stride: u64,
    pipelines: Pipelines,
    bind_group: wgpu::BindGroup,
    args_group: wgpu::BindGroup,
    particles: wgpu::Buffer,
    snapshot: wgpu::Buffer,
    rest: wgpu::Buffer,
    tools: wgpu::Buffer,
    steps: wgpu::Buffer,
    stats: wgpu::Buffer,
    args: wgpu::Buffer,
    /// End-of-frame extract: positions (n × vec4), then deformation gradient columns
    /// (n × 3 × vec4).
    out_pos: wgpu::Buffer,
    /// Whether frames read back the deformation gradients as well as the positions.
    read_deformation: bool,
    /// Readback ring: frame k reads back through `staging[k % 2]`.
    staging: [wgpu::Buffer; 2],
    frame: u64,
    /// The frame submitted and not collected yet.
    pending: Option<PendingFrame>,
    host: Particles,
    /// The host copy has edits the device does not have yet.
    host_dirty: bool,
    tool_scratch: Vec<GpuTool>,
    step_scratch: Vec<u8>,
}

/// A submitted frame whose readback is under way.
struct PendingFrame {
    /// Staging buffer its statistics and extract are copied into.
    slot: usize,
    /// Bytes of the extract after the statistics.
    extract_bytes: usize,
    /// Answered once the staging buffer is mapped.
    mapped: mpsc::Receiver<Result<(), wgpu::BufferAsyncError>>,
}

fn storage(
    device: &wgpu::Device,
    label: &str,
    size: u64,
    extra: wgpu::BufferUsages,
) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size.max(16),
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | extra,
        mapped_at_creation: false,
    })
}

fn layout_entry(binding: u32, ty: wgpu::BindingType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty,
        count: None,
    }
}

fn storage_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    layout_entry(
        binding,
        wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: false },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
    )
}

/// Shader source of one stage: the shared declarations, the P2G accumulation variant, and
/// the stage itself.
fn shader_source(stage: &str, float_p2g: bool) -> String {
    let common = include_str!("common.wgsl").replace(
        "ACC_ATOMIC",
        if float_p2g {
            "atomic<f32>"
        } else {
            "atomic<i32>"
        },
    );
    let acc = if float_p2g {
        include_str!("acc_float.wgsl")
    } else {
        include_str!("acc_fixed.wgsl")
    };
    format!("{common}\n{acc}\n{stage}")
}

impl GpuSolver {
    pub fn new(ctx: GpuContext, setup: SolverSetup) -> Result<Self, GpuError> {
        let float_p2g = match setup.p2g {
            P2gAtomics::Auto => ctx.float_atomics,
            P2gAtomics::Float if !ctx.float_atomics => {
                return Err(GpuError::Device(format!(
                    "p2g_atomics = \"float\" but adapter \"{}\" has no f32 atomics \
                     (SHADER_FLOAT32_ATOMIC); use \"fixed\" or \"auto\"",
                    ctx.info.name
                )))
            }
            P2gAtomics::Float => true,
            P2gAtomics::Fixed => false,
        };
        tracing::info!(
            "gpu P2G: {}",
            if float_p2g {
                "f32 atomics"
            } else {
                "i32 fixed-point atomics"
            }
        );
        let device = &ctx.device;
        let limits = device.limits();
        let layout = setup.layout;
        let n = setup.particles.len();
        let blocks = layout.block_count();
        let nodes = layout.node_count();
        let particle_bytes = (n * std::mem::size_of::<GpuParticle>()) as u64;
        let grid_bytes = (nodes * 16) as u64;
        let max_binding = limits.max_storage_buffer_binding_size as u64;
        if particle_bytes > max_binding || grid_bytes > max_binding {
            return Err(GpuError::TooLarge(format!(
                "{n} particles ({particle_bytes} B) and {nodes} nodes ({grid_bytes} B) against \
                 a storage binding limit of {max_binding} B"
            )));
        }
        let max_groups = limits.max_compute_workgroups_per_dimension as usize;
        if n.div_ceil(WG as usize) > max_groups || blocks > max_groups {
            return Err(GpuError::TooLarge(format!(
                "{n} particles / {blocks} blocks exceed {max_groups} workgroups per dispatch"
            )));
        }
        if setup.tool_count > MAX_TOOLS {
            return Err(GpuError::TooLarge(format!("at most {MAX_TOOLS} tools")));
        }
        let step_stride = (limits.min_uniform_buffer_offset_alignment as u64).max(256);
        let max_substeps = setup.max_substeps.max(1);
        // One Step entry per substep, per constraint iteration with PB-MPM.
        let steps_per_substep = match setup.method {
            Method::MlsMpm | Method::PicMpm => 1,
            Method::PbMpm => setup.pb_mpm.iterations.max(1) as u64,
        };

        let copy = wgpu::BufferUsages::COPY_SRC;
        let particles = storage(device, "particles", particle_bytes, copy);
        let snapshot = storage(device, "frame-start particles", particle_bytes, copy);
        let rest = storage(device, "rest particles", particle_bytes, copy);
        let pconst = storage(device, "particle constants", (n * 16) as u64, copy);
        let materials = storage(
            device,
            "materials",
            (setup.materials.len() * 32) as u64,
            copy,
        );
        let tools = storage(
            device,
            "tools per substep",
            (max_substeps as usize * setup.tool_count.max(1) * std::mem::size_of::<GpuTool>())
                as u64,
            copy,
        );
        let grid_acc = storage(device, "grid accumulators", grid_bytes, copy);
        let grid_v = storage(device, "grid velocity", grid_bytes, copy);
        let block_flags = storage(device, "block flags", (blocks * 4) as u64, copy);
        let active = storage(device, "active blocks", (blocks * 4) as u64, copy);
        let stats = storage(device, "frame stats", STATS_BYTES, copy);
        let partials = storage(device, "contact partials", (blocks * 64 * 4) as u64, copy);
        let out_pos = storage(device, "frame extract", (n * EXTRACT_BYTES) as u64, copy);
        let args = storage(device, "indirect args", 16, wgpu::BufferUsages::INDIRECT);
        let sim = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("sim"),
            size: std::mem::size_of::<SimUniform>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let steps = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("substep parameters"),
            size: step_stride * max_substeps as u64 * steps_per_substep,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let staging = [0, 1].map(|i| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(if i == 0 { "readback 0" } else { "readback 1" }),
                size: STATS_BYTES + (n * EXTRACT_BYTES).max(16) as u64,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        });

        // Fixed-point units: a cell's worth of the densest material, and an eighth of the
        // guard speed (see acc_fixed.wgsl).
        let density = setup
            .materials
            .iter()
            .map(|m| m.density)
            .fold(1e-6f32, f32::max);
        let mass_unit = density * layout.dx.powi(3);
        let momentum_unit = mass_unit * (setup.max_speed / 8.0).max(1e-6);
        let (table_kind, table_height, table_friction) = match setup.boundary.table {
            None => (0, 0.0, 0.0),
            Some((h, TableHold::Bonded)) => (1, h, 0.0),
            Some((h, TableHold::Resting { friction })) => (2, h, friction),
        };
        let sim_uniform = SimUniform {
            origin_dx: [layout.origin.x, layout.origin.y, layout.origin.z, layout.dx],
            inv_dx: layout.inv_dx,
            n_particles: n as u32,
            max_speed: setup.max_speed,
            n_tools: setup.tool_count as u32,
            nodes: [
                layout.nodes[0] as u32,
                layout.nodes[1] as u32,
                layout.nodes[2] as u32,
                blocks as u32,
            ],
            blocks: [
                layout.blocks[0] as u32,
                layout.blocks[1] as u32,
                layout.blocks[2] as u32,
                table_kind,
            ],
            table: [table_height, table_friction, 0.0, 0.0],
            fixed: [FIXED_SCALE, 1.0 / FIXED_SCALE, momentum_unit, mass_unit],
            transfer: [
                if setup.method.affine_transfer() {
                    1.0
                } else {
                    0.0
                },
                0.0,
                0.0,
                0.0,
            ],
        };
        let queue = &ctx.queue;
        queue.write_buffer(&sim, 0, bytemuck::bytes_of(&sim_uniform));
        queue.write_buffer(
            &pconst,
            0,
            bytemuck::cast_slice(&pack::constants(&setup.particles)),
        );
        queue.write_buffer(
            &materials,
            0,
            bytemuck::cast_slice(&pack::materials(&setup.materials)),
        );
        let packed = pack::particles(&setup.particles);
        queue.write_buffer(&particles, 0, bytemuck::cast_slice(&packed));
        queue.write_buffer(&rest, 0, bytemuck::cast_slice(&packed));

        let mut entries = vec![
            layout_entry(
                0,
                wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
            ),
            layout_entry(
                1,
                wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: true,
                    min_binding_size: wgpu::BufferSize::new(
                        std::mem::size_of::<StepUniform>() as u64
                    ),
                },
            ),
        ];
        entries.extend((2..=12).map(storage_entry));
        let group0 = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("mpm"),
            entries: &entries,
        });
        let group1 = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("indirect args"),
            entries: &[storage_entry(0)],
        });
        let buffers: [&wgpu::Buffer; 11] = [
            &particles,
            &pconst,
            &materials,
            &tools,
            &grid_acc,
            &grid_v,
            &block_flags,
            &active,
            &stats,
            &partials,
            &out_pos,
        ];
        let mut bind_entries = vec![
            wgpu::BindGroupEntry {
                binding: 0,
                resource: sim.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &steps,
                    offset: 0,
                    size: wgpu::BufferSize::new(std::mem::size_of::<StepUniform>() as u64),
                }),
            },
        ];
        for (i, b) in buffers.iter().enumerate() {
            bind_entries.push(wgpu::BindGroupEntry {
                binding: 2 + i as u32,
                resource: b.as_entire_binding(),
            });
        }
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("mpm"),
            layout: &group0,
            entries: &bind_entries,
        });
        let args_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("indirect args"),
            layout: &group1,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: args.as_entire_binding(),
            }],
        });
        // Stages that write the indirect arguments see group 1; the indirect dispatches do
        // not, so the buffer is never storage and indirect in one dispatch.
        let plain = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("mpm"),
            bind_group_layouts: &[&group0],
            push_constant_ranges: &[],
        });
        let with_args = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("mpm + args"),
            bind_group_layouts: &[&group0, &group1],
            push_constant_ranges: &[],
        });
        let module = |label: &str, src: &str| {
            device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(shader_source(src, float_p2g).into()),
            })
        };
        let sparse = module("sparse", include_str!("sparse.wgsl"));
        let p2g = module("p2g", include_str!("p2g.wgsl"));
        let grid_update = module("grid_update", include_str!("grid_update.wgsl"));
        let g2p = module("g2p", include_str!("g2p.wgsl"));
        let pbmpm = module("pbmpm", include_str!("pbmpm.wgsl"));
        let pipeline = |m: &wgpu::ShaderModule, entry: &str, l: &wgpu::PipelineLayout| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(l),
                module: m,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let pipelines = Pipelines {
            begin: pipeline(&sparse, "begin", &with_args),
            mark: pipeline(&sparse, "mark", &with_args),
            compact: pipeline(&sparse, "compact", &with_args),
            clear: pipeline(&sparse, "clear", &plain),
            p2g: pipeline(&p2g, "p2g", &plain),
            grid_update: pipeline(&grid_update, "grid_update", &plain),
            reduce: pipeline(&grid_update, "reduce_impulses", &plain),
            g2p: pipeline(&g2p, "g2p", &plain),
            finalize: pipeline(&g2p, "finalize_guard", &plain),
            extract: pipeline(&g2p, "extract_positions", &plain),
            pb_constrain: pipeline(&pbmpm, "pb_constrain", &plain),
            pb_p2g: pipeline(&pbmpm, "pb_p2g", &plain),
            pb_g2p: pipeline(&pbmpm, "pb_g2p", &plain),
            pb_next_iteration: pipeline(&pbmpm, "pb_next_iteration", &plain),
        };
        Ok(GpuSolver {
            layout,
            float_p2g,
            method: setup.method,
            pb_mpm: setup.pb_mpm,
            n: n as u32,
            tool_count: setup.tool_count,
            max_substeps,
            step_stride,
            pipelines,
            bind_group,
            args_group,
            particles,
            snapshot,
            rest,
            tools,
            steps,
            stats,
            args,
            out_pos,
            read_deformation: false,
            staging,
            frame: 0,
            pending: None,
            host: setup.particles,
            host_dirty: false,
            tool_scratch: Vec::new(),
            step_scratch: Vec::new(),
            ctx,
        })
    }

    pub fn layout(&self) -> &GridLayout {
        &self.layout
    }

    /// "gpu-f32-atomics" or "gpu-fixed-point".
    pub fn variant_name(&self) -> &'static str {
        if self.float_p2g {
            "gpu-f32-atomics"
        } else {
            "gpu-fixed-point"
        }
    }

    pub fn adapter_name(&self) -> &str {
        &self.ctx.info.name
    }

    /// Whether each frame also reads back the deformation gradients (48 bytes a particle
    /// on top of the positions' 16), so that `host_particles().f` is current.
    pub fn set_deformation_readback(&mut self, on: bool) {
        self.read_deformation = on;
    }

    pub fn host_particles(&self) -> &Particles {
        &self.host
    }

    pub fn host_particles_mut(&mut self) -> &mut Particles {
        self.download_all();
        self.host_dirty = true;
        &mut self.host
    }

    fn upload_if_dirty(&mut self) {
        if self.host_dirty {
            let packed = pack::particles(&self.host);
            self.ctx
                .queue
                .write_buffer(&self.particles, 0, bytemuck::cast_slice(&packed));
            self.host_dirty = false;
        }
    }

    /// Runs a frame's substeps in one submission and reads back its statistics and the
    /// particle positions: [`GpuSolver::submit_frame`] then [`GpuSolver::collect_frame`].
    pub fn step_frame(&mut self, plan: &FramePlan) -> FrameStats {
        self.submit_frame(plan);
        self.collect_frame()
    }

    /// Records a frame's substeps into one submission, submits it and asks for its readback,
    /// without waiting: the host copy keeps the previous frame's state until
    /// [`GpuSolver::collect_frame`], so the caller can build that frame's outputs while the
    /// device computes this one.
    pub fn submit_frame(&mut self, plan: &FramePlan) {
        assert!(
            self.pending.is_none(),
            "submit_frame called while a frame is in flight"
        );
        assert!(
            plan.substeps <= self.max_substeps && plan.tool_count == self.tool_count,
            "frame plan does not fit the solver ({} substeps of at most {}, {} tools of {})",
            plan.substeps,
            self.max_substeps,
            plan.tool_count,
            self.tool_count
        );
        self.upload_if_dirty();
        let queue = &self.ctx.queue;
        // Every substep's parameters and tool kinematics, written once for the frame.
        self.step_scratch.clear();
        let (entries, relaxation) = match self.method {
            Method::MlsMpm | Method::PicMpm => (1, 0.0),
            Method::PbMpm => (self.pb_mpm.iterations.max(1), self.pb_mpm.relaxation),
        };
        self.step_scratch.resize(
            self.step_stride as usize * (plan.substeps * entries) as usize,
            0,
        );
        for s in 0..plan.substeps {
            for k in 0..entries {
                // Gravity enters once per substep: in PB-MPM's first iteration.
                let g = if k == 0 { plan.gravity } else { Vec3::zeros() };
                let u = StepUniform {
                    dt: plan.dt,
                    substep: s,
                    pad: 0,
                    relaxation,
                    gravity: [g.x, g.y, g.z, 0.0],
                };
                let at = (s * entries + k) as usize * self.step_stride as usize;
                self.step_scratch[at..at + std::mem::size_of::<StepUniform>()]
                    .copy_from_slice(bytemuck::bytes_of(&u));
            }
        }
        if !self.step_scratch.is_empty() {
            queue.write_buffer(&self.steps, 0, &self.step_scratch);
        }
        self.tool_scratch.clear();
        self.tool_scratch
            .extend(plan.tools.iter().map(GpuTool::from));
        if !self.tool_scratch.is_empty() {
            queue.write_buffer(&self.tools, 0, bytemuck::cast_slice(&self.tool_scratch));
        }
        let mut init = [0u32; STATS_WORDS];
        init[S_GUARD_PARTICLE] = u32::MAX;
        queue.write_buffer(&self.stats, 0, bytemuck::cast_slice(&init));

        let device = &self.ctx.device;
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("frame"),
        });
        encoder.copy_buffer_to_buffer(&self.particles, 0, &self.snapshot, 0, None);
        {
            let p = &self.pipelines;
            let particle_groups = self.n.div_ceil(WG).max(1);
            let block_groups = (self.layout.block_count() as u32).div_ceil(WG);
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("substeps"),
                timestamp_writes: None,
            });
            pass.set_bind_group(1, &self.args_group, &[]);
            for s in 0..plan.substeps {
                match self.method {
                    Method::MlsMpm | Method::PicMpm => {
                        let offset = (s as u64 * self.step_stride) as u32;
                        pass.set_bind_group(0, &self.bind_group, &[offset]);
                        self.record_sparse(&mut pass, particle_groups, block_groups);
                        pass.set_pipeline(&p.p2g);
                        pass.dispatch_workgroups(particle_groups, 1, 1);
                        pass.set_pipeline(&p.grid_update);
                        pass.dispatch_workgroups_indirect(&self.args, 0);
                        pass.set_pipeline(&p.g2p);
                        pass.dispatch_workgroups(particle_groups, 1, 1);
                        pass.set_pipeline(&p.reduce);
                        pass.dispatch_workgroups(1, 1, 1);
                    }
                    Method::PbMpm => self.record_pb_substep(
                        &mut pass,
                        s,
                        self.pb_mpm.iterations.max(1),
                        particle_groups,
                        block_groups,
                    ),
                }
            }
            pass.set_bind_group(0, &self.bind_group, &[0]);
            pass.set_pipeline(&p.finalize);
            pass.dispatch_workgroups(1, 1, 1);
            pass.set_pipeline(&p.extract);
            pass.dispatch_workgroups(particle_groups, 1, 1);
        }
        let slot = (self.frame % 2) as usize;
        self.frame += 1;
        let staging = &self.staging[slot];
        encoder.copy_buffer_to_buffer(&self.stats, 0, staging, 0, STATS_BYTES);
        let n = self.n as usize;
        let extract_bytes = if self.read_deformation {
            n * EXTRACT_BYTES
        } else {
            n * 16
        };
        if n > 0 {
            encoder.copy_buffer_to_buffer(
                &self.out_pos,
                0,
                staging,
                STATS_BYTES,
                extract_bytes as u64,
            );
        }
        queue.submit([encoder.finish()]);
        let (tx, mapped) = mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        self.pending = Some(PendingFrame {
            slot,
            extract_bytes,
            mapped,
        });
    }

    /// Waits for the frame in flight, copies its positions (and deformation gradients while
    /// asked for) into the host copy and returns its statistics.
    ///
    /// # Panics
    /// When no frame was submitted, or the device is lost.
    pub fn collect_frame(&mut self) -> FrameStats {
        let pending = self
            .pending
            .take()
            .expect("collect_frame called with no frame in flight");
        self.ctx
            .device
            .poll(wgpu::PollType::wait_indefinitely())
            .expect("GPU device lost while waiting for a frame");
        pending
            .mapped
            .recv()
            .expect("map callback ran")
            .expect("GPU readback mapping failed");
        let staging = &self.staging[pending.slot];
        let bytes = staging.get_mapped_range(..);
        let n = self.n as usize;
        let extract_bytes = pending.extract_bytes;
        let words: &[u32] = bytemuck::cast_slice(&bytes[..STATS_BYTES as usize]);
        let extract: &[[f32; 4]] = bytemuck::cast_slice(
            &bytes[STATS_BYTES as usize..STATS_BYTES as usize + extract_bytes],
        );
        let (positions, gradients) = extract.split_at(n.min(extract.len()));
        for (x, p) in self.host.x.iter_mut().zip(positions) {
            *x = Vec3::new(p[0], p[1], p[2]);
        }
        for (f, cols) in self.host.f.iter_mut().zip(gradients.chunks_exact(3)) {
            *f = pack::unpack_mat3(cols);
        }
        let stats = parse_stats(words);
        drop(bytes);
        staging.unmap();
        stats
    }

    /// Records the sparse-grid bookkeeping of a substep: the active block list, and the
    /// clear of those blocks.
    fn record_sparse(&self, pass: &mut wgpu::ComputePass, particle_groups: u32, block_groups: u32) {
        let p = &self.pipelines;
        pass.set_pipeline(&p.begin);
        pass.dispatch_workgroups(1, 1, 1);
        pass.set_pipeline(&p.mark);
        pass.dispatch_workgroups(particle_groups, 1, 1);
        pass.set_pipeline(&p.compact);
        pass.dispatch_workgroups(block_groups, 1, 1);
        pass.set_pipeline(&p.clear);
        pass.dispatch_workgroups_indirect(&self.args, 0);
    }

    /// Records one PB-MPM substep (cpu `pb_substep`): the block list once, then per
    /// iteration constraint → clear → P2G → grid update → G2P (integrating in the last) →
    /// impulse reduction, each iteration with its own Step entry.
    fn record_pb_substep(
        &self,
        pass: &mut wgpu::ComputePass,
        s: u32,
        iterations: u32,
        particle_groups: u32,
        block_groups: u32,
    ) {
        let p = &self.pipelines;
        for k in 0..iterations {
            let offset = ((s * iterations + k) as u64 * self.step_stride) as u32;
            pass.set_bind_group(0, &self.bind_group, &[offset]);
            if k == 0 {
                self.record_sparse(pass, particle_groups, block_groups);
            } else {
                pass.set_pipeline(&p.clear);
                pass.dispatch_workgroups_indirect(&self.args, 0);
            }
            pass.set_pipeline(&p.pb_constrain);
            pass.dispatch_workgroups(particle_groups, 1, 1);
            pass.set_pipeline(&p.pb_p2g);
            pass.dispatch_workgroups(particle_groups, 1, 1);
            pass.set_pipeline(&p.grid_update);
            pass.dispatch_workgroups_indirect(&self.args, 0);
            pass.set_pipeline(if k + 1 == iterations {
                &p.g2p
            } else {
                &p.pb_g2p
            });
            pass.dispatch_workgroups(particle_groups, 1, 1);
            pass.set_pipeline(&p.reduce);
            pass.dispatch_workgroups(1, 1, 1);
            pass.set_pipeline(&p.pb_next_iteration);
            pass.dispatch_workgroups(1, 1, 1);
        }
    }

    fn submit_copy(&self, from: &wgpu::Buffer, to: &wgpu::Buffer) {
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("copy"),
            });
        encoder.copy_buffer_to_buffer(from, 0, to, 0, None);
        self.ctx.queue.submit([encoder.finish()]);
    }

    /// Device-side copy of the frame-start state back into the particles.
    pub fn restore_frame_start(&mut self) {
        self.submit_copy(&self.snapshot, &self.particles);
        self.host_dirty = false;
        self.download_all();
    }

    /// Device-side copy of the rest state into the particles.
    pub fn reset_to_rest(&mut self) {
        self.submit_copy(&self.rest, &self.particles);
        self.host_dirty = false;
        self.download_all();
    }

    /// Blocking download of every particle field into the host copy (unless the host copy
    /// holds edits not uploaded yet).
    pub fn download_all(&mut self) {
        debug_assert!(
            self.pending.is_none(),
            "download while a frame is in flight"
        );
        if self.host_dirty || self.n == 0 {
            return;
        }
        let device = &self.ctx.device;
        let size = self.n as u64 * std::mem::size_of::<GpuParticle>() as u64;
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("particle download"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder =
            device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        encoder.copy_buffer_to_buffer(&self.particles, 0, &staging, 0, size);
        self.ctx.queue.submit([encoder.finish()]);
        let bytes = map_read(device, &staging);
        pack::unpack_particles(bytemuck::cast_slice(&bytes), &mut self.host);
        drop(bytes);
        staging.unmap();
    }
}

/// Maps `buffer` for reading once the queue's work is done.
fn map_read(device: &wgpu::Device, buffer: &wgpu::Buffer) -> wgpu::BufferView {
    let (tx, rx) = mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .expect("GPU device lost while waiting for a frame");
    rx.recv()
        .expect("map callback ran")
        .expect("GPU readback mapping failed");
    buffer.get_mapped_range(..)
}

fn parse_stats(w: &[u32]) -> FrameStats {
    let mut out = FrameStats {
        max_speed: f32::from_bits(w[S_MAX_SPEED]),
        clamped_particles: w[S_CLAMPED],
        substeps_done: w[S_SUBSTEPS],
        ..Default::default()
    };
    for (t, imp) in out.tool_impulses.iter_mut().enumerate() {
        let f = |k: usize| f32::from_bits(w[S_IMPULSE + t * 8 + k]) as f64;
        imp.linear = nalgebra::Vector3::new(f(0), f(1), f(2));
        imp.angular = nalgebra::Vector3::new(f(3), f(4), f(5));
        imp.contact_nodes = f(6).round() as u32;
    }
    if w[S_GUARD] != 0 {
        out.substeps_done = w[S_GUARD] - 1;
        let non_finite = w[S_GUARD_KIND] == 0;
        out.guard = Some(GuardEvent {
            kind: if non_finite {
                GuardKind::NonFinite
            } else {
                GuardKind::Runaway
            },
            particle: w[S_GUARD_PARTICLE],
            position: Vec3::new(
                f32::from_bits(w[S_GUARD_POS]),
                f32::from_bits(w[S_GUARD_POS + 1]),
                f32::from_bits(w[S_GUARD_POS + 2]),
            ),
            speed: if non_finite {
                f32::NAN
            } else {
                f32::from_bits(w[S_GUARD_SPEED])
            },
        });
    }
    out
}

const _: () = assert!(NODES_PER_BLOCK == 64);
