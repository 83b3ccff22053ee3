//! The device state every stage shares: particle, grid, tool and statistics buffers, the
//! per-solver and per-substep uniforms, the bind groups and the two pipeline layouts.
//!
//! Group 0's bindings are listed once, by [`Binding`]: its order is the binding numbers, and
//! both the bind group layout here and the WGSL declarations of the prelude come from it.

use super::blade;
use super::grid_update::IMPULSE_WORDS;
use super::p2g::FIXED_SCALE;
use super::pack::{self, GpuMaterial, GpuParticle, GpuTool, SimUniform, StepUniform};
use super::pass::CountingPass;
use super::readback::{self, extract_bytes_per_particle, CRACK_BYTES, STATS_BYTES};
use super::tlmpm::TL_WORDS;
use crate::mpm::frame_plan::FramePlan;
use crate::mpm::grid::Node;
use crate::mpm::{damage, SolverSetup, TableHold, Vec3, MAX_TOOLS};
use crate::tools::Shape;

/// The bind group of the indirect dispatch arguments (binding 0 in it).
pub const ARGS_GROUP: u32 = 1;

/// Group 0's bindings, in binding order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Binding {
    /// Per-solver constants.
    Sim,
    /// The current substep's parameters (dynamic offset).
    Step,
    Particles,
    /// Per particle: mass, initial volume, material index (as f32 bits), 0.
    ParticleConstants,
    Materials,
    /// Every substep's tool kinematics, substep-major.
    Tools,
    /// P2G accumulators: momentum xyz and mass per node (f32 or i32 fixed point).
    GridAcc,
    /// Grid velocity and mass after the grid update.
    GridV,
    BlockFlags,
    ActiveBlocks,
    Stats,
    /// Per contact block, per tool: the block's impulse sums.
    Partials,
    /// The end-of-frame extract read back.
    Extract,
    /// Per particle: its crack n·d (see `crack.wgsl`); a placeholder without a slicer.
    Cracks,
    /// The mesh slicers' blades (see `blade.rs`); a placeholder without one.
    Blades,
    /// Total Lagrangian MPM: per particle, its rest position and the gripper holding it
    /// (see `tlmpm.wgsl`); a placeholder with the other methods.
    TlRest,
    /// Total Lagrangian MPM: per node the gripper holding it, then per gripper whether it
    /// held in the last substep; a placeholder with the other methods.
    TlNodes,
}

impl Binding {
    pub const ALL: [Binding; 17] = [
        Binding::Sim,
        Binding::Step,
        Binding::Particles,
        Binding::ParticleConstants,
        Binding::Materials,
        Binding::Tools,
        Binding::GridAcc,
        Binding::GridV,
        Binding::BlockFlags,
        Binding::ActiveBlocks,
        Binding::Stats,
        Binding::Partials,
        Binding::Extract,
        Binding::Cracks,
        Binding::Blades,
        Binding::TlRest,
        Binding::TlNodes,
    ];

    /// The variable's name in WGSL.
    pub fn name(self) -> &'static str {
        match self {
            Binding::Sim => "sim",
            Binding::Step => "st",
            Binding::Particles => "particles",
            Binding::ParticleConstants => "pconst",
            Binding::Materials => "materials",
            Binding::Tools => "tools",
            Binding::GridAcc => "grid_acc",
            Binding::GridV => "grid_v",
            Binding::BlockFlags => "block_flags",
            Binding::ActiveBlocks => "active_blocks",
            Binding::Stats => "stats",
            Binding::Partials => "partials",
            Binding::Extract => "out_pos",
            Binding::Cracks => "cracks",
            Binding::Blades => "blades",
            Binding::TlRest => "tl_rest",
            Binding::TlNodes => "tl_nodes",
        }
    }

    pub fn address_space(self) -> &'static str {
        match self {
            Binding::Sim | Binding::Step => "uniform",
            _ => "storage, read_write",
        }
    }

    /// The variable's WGSL type; the accumulators' depends on the P2G variant.
    pub fn wgsl_type(self, float_p2g: bool) -> &'static str {
        match self {
            Binding::Sim => "Sim",
            Binding::Step => "Step",
            Binding::Particles => "array<Particle>",
            Binding::ParticleConstants => "array<vec4<f32>>",
            Binding::Materials => "array<Material>",
            Binding::Tools => "array<Tool>",
            Binding::GridAcc if float_p2g => "array<atomic<f32>>",
            Binding::GridAcc => "array<atomic<i32>>",
            Binding::GridV => "array<vec4<f32>>",
            Binding::BlockFlags => "array<atomic<u32>>",
            Binding::ActiveBlocks => "array<u32>",
            Binding::Stats => "array<atomic<u32>>",
            Binding::Partials => "array<f32>",
            Binding::Extract => "array<vec4<f32>>",
            Binding::Cracks => "array<vec4<f32>>",
            Binding::Blades => "array<vec4<f32>>",
            Binding::TlRest => "array<vec4<f32>>",
            Binding::TlNodes => "array<atomic<u32>>",
        }
    }

    fn layout_entry(self) -> wgpu::BindGroupLayoutEntry {
        let ty = match self {
            Binding::Sim => wgpu::BufferBindingType::Uniform,
            Binding::Step => wgpu::BufferBindingType::Uniform,
            _ => wgpu::BufferBindingType::Storage { read_only: false },
        };
        let dynamic = self == Binding::Step;
        layout_entry(
            self as u32,
            wgpu::BindingType::Buffer {
                ty,
                has_dynamic_offset: dynamic,
                min_binding_size: if dynamic {
                    wgpu::BufferSize::new(std::mem::size_of::<StepUniform>() as u64)
                } else {
                    None
                },
            },
        )
    }
}

const _: () = assert!(Binding::ALL.len() == Binding::TlNodes as usize + 1);

/// Buffers, bind groups and pipeline layouts of one solver.
pub struct Resources {
    pub particles: wgpu::Buffer,
    /// Per particle: mass, rest volume, material (bits), 0 ([`pack::constants`]).
    pub constants: wgpu::Buffer,
    /// Frame-start particles, for the guard's restore.
    pub snapshot: wgpu::Buffer,
    /// Rest particles, for the reset.
    pub rest: wgpu::Buffer,
    /// Per-particle cracks (vec4) in a scene with a slicer, 16 unused bytes otherwise.
    pub cracks: wgpu::Buffer,
    /// Frame-start cracks, for the guard's restore (16 unused bytes without a slicer).
    pub crack_snapshot: wgpu::Buffer,
    /// Total Lagrangian MPM's rest positions and captures (16 unused bytes otherwise).
    pub tl_rest: wgpu::Buffer,
    tools: wgpu::Buffer,
    steps: wgpu::Buffer,
    pub stats: wgpu::Buffer,
    /// Indirect dispatch arguments: the active block count, 1, 1.
    pub args: wgpu::Buffer,
    /// Grid velocity and mass (one vec4 a node) after the grid update.
    pub grid_v: wgpu::Buffer,
    /// The substep's active blocks, in increasing index (`args`' first word counts them).
    pub active_blocks: wgpu::Buffer,
    /// End-of-frame extract: positions (n × vec4), then deformation gradient columns
    /// (n × 3 × vec4).
    pub extract: wgpu::Buffer,
    pub bind_group: wgpu::BindGroup,
    pub args_group: wgpu::BindGroup,
    /// Group 0's layout (the implicit solve adds a group of its own after it).
    pub group0: wgpu::BindGroupLayout,
    /// Group 0 only.
    pub plain: wgpu::PipelineLayout,
    /// Group 0 and the indirect arguments: for the stages that write them, so that the
    /// indirect dispatches never see the buffer as storage.
    pub with_args: wgpu::PipelineLayout,
    /// Bytes between two Step entries (the uniform offset alignment).
    pub step_stride: u64,
    /// Per tool of the scene, its blade's record in the blades buffer (0 for a tool that
    /// is not a mesh slicer).
    blade_at: Vec<u32>,
    tool_scratch: Vec<GpuTool>,
    step_scratch: Vec<u8>,
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

fn uniform(device: &wgpu::Device, label: &str, size: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
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

/// The per-solver constants.
fn sim_uniform(setup: &SolverSetup) -> SimUniform {
    let layout = &setup.layout;
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
        None => (pack::TABLE_NONE, 0.0, 0.0),
        Some((h, TableHold::Bonded)) => (pack::TABLE_BONDED, h, 0.0),
        Some((h, TableHold::Resting { friction })) => (pack::TABLE_RESTING, h, friction),
    };
    SimUniform {
        origin_dx: [layout.origin.x, layout.origin.y, layout.origin.z, layout.dx],
        inv_dx: layout.inv_dx,
        n_particles: setup.particles.len() as u32,
        max_speed: setup.max_speed,
        n_tools: setup.tool_count as u32,
        nodes: [
            layout.nodes[0] as u32,
            layout.nodes[1] as u32,
            layout.nodes[2] as u32,
            layout.block_count() as u32,
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
    }
}

impl Resources {
    /// Allocates the buffers for `setup` with `steps_per_substep` Step entries a substep,
    /// uploads the particles, materials, constants and the blades of the mesh slicers
    /// among `shapes` (the scene's tools in order), and builds the bind groups.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        setup: &SolverSetup,
        shapes: &[Shape],
        max_substeps: u32,
        steps_per_substep: u64,
    ) -> Self {
        let layout = &setup.layout;
        let n = setup.particles.len();
        let blocks = layout.block_count();
        let particle_bytes = (n * std::mem::size_of::<GpuParticle>()) as u64;
        let grid_bytes = (layout.node_count() * std::mem::size_of::<Node>()) as u64;
        let step_stride = (device.limits().min_uniform_buffer_offset_alignment as u64).max(256);

        let copy = wgpu::BufferUsages::COPY_SRC;
        let particles = storage(device, "particles", particle_bytes, copy);
        let snapshot = storage(device, "frame-start particles", particle_bytes, copy);
        let rest = storage(device, "rest particles", particle_bytes, copy);
        let pconst = storage(device, "particle constants", (n * 16) as u64, copy);
        let materials = storage(
            device,
            "materials",
            (setup.materials.len() * std::mem::size_of::<GpuMaterial>()) as u64,
            copy,
        );
        let tools = storage(
            device,
            "tools per substep",
            (max_substeps as usize * setup.tool_count.max(1) * std::mem::size_of::<GpuTool>())
                as u64,
            copy,
        );
        // Total Lagrangian MPM's nodes carry words of their own after everyone's
        // NODE_WORDS, its particles their rest positions, its nodes their grippers.
        let total_lagrangian = setup.method == crate::mpm::Method::TlMpm;
        let (tl_node_bytes, tl_rest_bytes, tl_nodes_bytes) = if total_lagrangian {
            let nodes = layout.node_count();
            (
                (nodes * TL_WORDS * 4) as u64,
                (n * 16) as u64,
                ((nodes + MAX_TOOLS) * 4) as u64,
            )
        } else {
            (0, 0, 0)
        };
        let grid_acc = storage(
            device,
            "grid accumulators",
            grid_bytes + tl_node_bytes,
            copy,
        );
        let tl_rest = storage(device, "rest positions", tl_rest_bytes, copy);
        let tl_nodes = storage(device, "node grippers", tl_nodes_bytes, copy);
        let grid_v = storage(device, "grid velocity", grid_bytes, copy);
        let block_flags = storage(device, "block flags", (blocks * 4) as u64, copy);
        let active = storage(device, "active blocks", (blocks * 4) as u64, copy);
        let stats = storage(device, "frame stats", STATS_BYTES, copy);
        let partials = storage(
            device,
            "contact partials",
            (blocks * MAX_TOOLS * IMPULSE_WORDS * 4) as u64,
            copy,
        );
        let extract = storage(
            device,
            "frame extract",
            (n * extract_bytes_per_particle(setup.cutting)) as u64,
            copy,
        );
        // The crack state exists only in a scene that can cut.
        let crack_bytes = if setup.cutting { n * CRACK_BYTES } else { 0 } as u64;
        let cracks = storage(device, "cracks", crack_bytes, copy);
        let crack_snapshot = storage(device, "frame-start cracks", crack_bytes, copy);
        // Only a scene with a mesh slicer has blades; the others bind 16 unused bytes.
        let (blade_data, blade_at) = blade::pack(shapes);
        let blades = storage(
            device,
            "blades",
            std::mem::size_of_val(blade_data.as_slice()) as u64,
            copy,
        );
        if !blade_data.is_empty() {
            queue.write_buffer(&blades, 0, bytemuck::cast_slice(&blade_data));
        }
        let args = storage(
            device,
            "indirect args",
            16,
            wgpu::BufferUsages::INDIRECT | copy,
        );
        let sim = uniform(device, "sim", std::mem::size_of::<SimUniform>() as u64);
        let steps = uniform(
            device,
            "substep parameters",
            step_stride * max_substeps as u64 * steps_per_substep,
        );

        queue.write_buffer(&sim, 0, bytemuck::bytes_of(&sim_uniform(setup)));
        queue.write_buffer(
            &pconst,
            0,
            bytemuck::cast_slice(&pack::constants(&setup.particles)),
        );
        queue.write_buffer(
            &materials,
            0,
            bytemuck::cast_slice(&pack::materials(
                &setup.materials,
                &damage::onsets(setup).unwrap_or_default(),
            )),
        );
        let packed = pack::particles(&setup.particles);
        queue.write_buffer(&particles, 0, bytemuck::cast_slice(&packed));
        queue.write_buffer(&rest, 0, bytemuck::cast_slice(&packed));

        let entries: Vec<_> = Binding::ALL.iter().map(|b| b.layout_entry()).collect();
        let group0 = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("mpm"),
            entries: &entries,
        });
        let group1 = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("indirect args"),
            entries: &[layout_entry(
                0,
                wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only: false },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
            )],
        });
        let resource = |b: Binding| match b {
            Binding::Sim => sim.as_entire_binding(),
            Binding::Step => wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer: &steps,
                offset: 0,
                size: wgpu::BufferSize::new(std::mem::size_of::<StepUniform>() as u64),
            }),
            Binding::Particles => particles.as_entire_binding(),
            Binding::ParticleConstants => pconst.as_entire_binding(),
            Binding::Materials => materials.as_entire_binding(),
            Binding::Tools => tools.as_entire_binding(),
            Binding::GridAcc => grid_acc.as_entire_binding(),
            Binding::GridV => grid_v.as_entire_binding(),
            Binding::BlockFlags => block_flags.as_entire_binding(),
            Binding::ActiveBlocks => active.as_entire_binding(),
            Binding::Stats => stats.as_entire_binding(),
            Binding::Partials => partials.as_entire_binding(),
            Binding::Extract => extract.as_entire_binding(),
            Binding::Cracks => cracks.as_entire_binding(),
            Binding::Blades => blades.as_entire_binding(),
            Binding::TlRest => tl_rest.as_entire_binding(),
            Binding::TlNodes => tl_nodes.as_entire_binding(),
        };
        let bind_entries: Vec<_> = Binding::ALL
            .iter()
            .map(|&b| wgpu::BindGroupEntry {
                binding: b as u32,
                resource: resource(b),
            })
            .collect();
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
        Resources {
            particles,
            constants: pconst,
            snapshot,
            rest,
            cracks,
            crack_snapshot,
            tl_rest,
            tools,
            steps,
            stats,
            args,
            grid_v,
            active_blocks: active,
            extract,
            bind_group,
            args_group,
            group0,
            plain,
            with_args,
            step_stride,
            blade_at,
            tool_scratch: Vec::new(),
            step_scratch: Vec::new(),
        }
    }

    /// Writes every substep's parameters and tool kinematics once for the frame, and the
    /// statistics it starts from. With PB-MPM a substep has `entries` Step entries, one per
    /// iteration.
    pub fn write_frame_inputs(
        &mut self,
        queue: &wgpu::Queue,
        plan: &FramePlan,
        entries: u32,
        relaxation: f32,
    ) {
        self.step_scratch.clear();
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
        let blade_at = &self.blade_at;
        self.tool_scratch
            .extend(plan.tools.iter().enumerate().map(|(i, t)| {
                let mut tool = GpuTool::from(t);
                // Substep-major: entry i is tool i mod the tool count.
                tool.kind[2] = blade_at
                    .get(i % blade_at.len().max(1))
                    .copied()
                    .unwrap_or(0);
                tool
            }));
        if !self.tool_scratch.is_empty() {
            queue.write_buffer(&self.tools, 0, bytemuck::cast_slice(&self.tool_scratch));
        }
        queue.write_buffer(
            &self.stats,
            0,
            bytemuck::cast_slice(&readback::stats_at_frame_start()),
        );
    }

    /// Binds group 0 with Step entry `entry` (a substep, or a PB-MPM iteration).
    pub fn bind_step(&self, pass: &mut CountingPass, entry: u32) {
        let offset = (entry as u64 * self.step_stride) as u32;
        pass.set_bind_group(0, &self.bind_group, &[offset]);
    }
}
