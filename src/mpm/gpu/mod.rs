//! The MLS-MPM and PB-MPM solvers on wgpu: the CPU solvers' math in WGSL compute shaders.
//!
//! Each stage is a unit: its `.wgsl` and, beside it, a host `.rs` owning its pipelines and
//! recording its dispatches (`record`). Every shader starts with the prelude generated
//! from Rust (`prelude.rs`: shared constants, struct layouts, bindings) and `common.wgsl`
//! (stencil, materials, tool SDFs, contact, boundary, the guard):
//! - `sparse`: flag the 4³-node blocks the particles' stencils touch, compact them into
//!   an active-block list (its length is the indirect dispatch size), clear those blocks;
//! - `p2g`: fused APIC + MLS force scatter with f32 atomics, or i32 fixed-point atomics
//!   where the adapter has no f32 atomics (`acc_float.wgsl` / `acc_fixed.wgsl`);
//! - `grid_update`: gravity, tools (SDF only inside each tool's bounding box), friction,
//!   momentum exchange reduced per block into per-tool impulses, table, walls;
//! - `g2p`: interpolation back, advection, F update, damping and the guard;
//! - `crack`: with a slicer, the particles its edge passes take its plane as their crack
//!   (a mesh slicer's local tangent plane: its blade is uploaded once, `blade.rs`);
//!   P2G and G2P then skip (read the particle's own velocity at) the nodes across it, and
//!   G2P turns it with the material (see [`crate::mpm::crack`]). Without a slicer the crack
//!   buffer is a placeholder, nothing is dispatched and the side tests compile away;
//! - `damage.wgsl` (no stage of its own): with a material that has toughness, MLS-MPM's
//!   P2G advances each particle's damage (kept in its position's w) and scatters the
//!   degraded stress (see [`crate::mpm::damage`]); PB-MPM has no stress to degrade and
//!   `check` refuses toughness with it;
//! - `pbmpm`: PB-MPM's elastic constraint on C, momentum-only P2G and the inner
//!   iterations' G2P; a PB-MPM substep records the stages above once per iteration, each
//!   iteration with its own parameter entry (gravity in the first only), integrating in
//!   the last (`record_pb_substep`);
//! - `implicit`: backward-Euler MLS-MPM, Newton–CG on the grid velocities (its own
//!   buffers in bind group 1; a frame is several submissions, see that module).
//!
//! `resources.rs` holds the buffers and bind groups the stages share, `readback.rs` what
//! comes back to the host, `pack.rs` the structs shared with WGSL.
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
mod blade;
mod crack;
mod g2p;
mod grid_update;
mod implicit;
mod p2g;
mod pack;
mod pbmpm;
mod prelude;
mod readback;
mod resources;
mod sparse;

use super::backend::P2gAtomics;
use super::frame_plan::{FramePlan, FrameStats};
use super::grid::Node;
use super::{GridLayout, Method, Particles, PbMpmParams, SolveCounts, SolverSetup, MAX_TOOLS};
use crate::tools::Shape;
use adapter::GpuContext;
use crack::CrackStage;
use g2p::G2pStage;
use grid_update::GridUpdateStage;
use implicit::ImplicitStages;
use p2g::P2gStage;
pub use p2g::FIXED_SCALE;
use pack::GpuParticle;
use pbmpm::PbMpmStages;
use prelude::StageBuilder;
use readback::Readback;
use resources::{Resources, ARGS_GROUP};
use sparse::SparseStage;

/// How [`GpuError::Unsupported`] names the implicit method on an adapter without f32
/// atomics (see `implicit`).
pub const IMPLICIT_WITHOUT_FLOAT_ATOMICS: &str =
    "solver.method = \"implicit\" on an adapter without f32 atomics (SHADER_FLOAT32_ATOMIC)";
/// How [`GpuError::Unsupported`] names the implicit method in a scene with a slicer.
pub const IMPLICIT_WITH_CUTTING: &str = "solver.method = \"implicit\" in a scene that cuts";

/// Why the GPU backend could not be used.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "backend \"gpu\" asked for, but no GPU adapter exists (no Vulkan, Metal or DX12 \
         driver found; VK_LOADER_DEBUG=error shows why the Vulkan loader found none; on \
         Debian/Ubuntu `apt-get install mesa-vulkan-drivers` provides the llvmpipe software \
         adapter)"
    )]
    NoAdapter,
    /// The adapter list came back empty after this process had opened a device on the
    /// adapter named (the driver no longer lists it: the GPU fell off, or the driver ran out
    /// of something), which a missing driver does not explain.
    #[error(
        "backend \"gpu\" asked for, but the GPU adapter this process opened before, {0}, is \
         no longer listed by its driver (lost device or driver failure); restart the process"
    )]
    AdapterGone(String),
    /// An adapter exists but a device could not be opened on it (the adapter and wgpu's
    /// error are in the message), or the device cannot do what the scene asks for.
    #[error("could not open the GPU device: {0}")]
    Device(String),
    #[error("scene too large for the GPU backend: {0}")]
    TooLarge(String),
    #[error("the GPU backend does not support {0} yet; use backend = \"cpu\" or \"auto\"")]
    Unsupported(&'static str),
}

/// Workgroup size of the per-particle and per-block stages.
const WG: u32 = 64;

/// The sizes of a frame's dispatches: workgroups over the particles, and the indirect
/// arguments (one workgroup per active block).
struct Groups<'a> {
    particles: u32,
    active_blocks: &'a wgpu::Buffer,
}

pub struct GpuSolver {
    ctx: GpuContext,
    layout: GridLayout,
    float_p2g: bool,
    /// The scene has a slicer: particles carry cracks on the device.
    cutting: bool,
    method: Method,
    pb_mpm: PbMpmParams,
    n: u32,
    tool_count: usize,
    max_substeps: u32,
    res: Resources,
    sparse: SparseStage,
    crack: CrackStage,
    p2g: P2gStage,
    grid_update: GridUpdateStage,
    g2p: G2pStage,
    pb: PbMpmStages,
    /// With `method = "implicit"`: the Newton–CG solve.
    implicit: Option<ImplicitStages>,
    /// Newton and CG iterations of the frame in flight.
    frame_solve: SolveCounts,
    readback: Readback,
    /// Whether frames read back the deformation gradients as well as the positions.
    read_deformation: bool,
    host: Particles,
    /// The host copy has edits the device does not have yet.
    host_dirty: bool,
}

/// What of `setup` the backend cannot step on this adapter: the implicit method needs f32
/// atomics and a scene that does not cut (see `implicit`).
pub fn unsupported(ctx: &GpuContext, setup: &SolverSetup) -> Option<&'static str> {
    if setup.method != Method::Implicit {
        return None;
    }
    if setup.cutting {
        return Some(IMPLICIT_WITH_CUTTING);
    }
    (!ctx.float_atomics).then_some(IMPLICIT_WITHOUT_FLOAT_ATOMICS)
}

/// Whether the scene fits the device's limits.
fn check_limits(device: &wgpu::Device, setup: &SolverSetup) -> Result<(), GpuError> {
    let limits = device.limits();
    let n = setup.particles.len();
    let blocks = setup.layout.block_count();
    let nodes = setup.layout.node_count();
    let particle_bytes = (n * std::mem::size_of::<GpuParticle>()) as u64;
    let grid_bytes = (nodes * std::mem::size_of::<Node>()) as u64;
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
    if setup.method == Method::Implicit && n > implicit::MAX_PARTICLES {
        return Err(GpuError::TooLarge(format!(
            "{n} particles for the implicit solve, which takes at most {}",
            implicit::MAX_PARTICLES
        )));
    }
    if setup.tool_count > MAX_TOOLS {
        return Err(GpuError::TooLarge(format!("at most {MAX_TOOLS} tools")));
    }
    Ok(())
}

impl GpuSolver {
    /// A solver for `setup` whose tools have the shapes `shapes` (in the scene's order: a
    /// mesh slicer's blade is uploaded once here).
    pub fn new(ctx: GpuContext, setup: SolverSetup, shapes: &[Shape]) -> Result<Self, GpuError> {
        if let Some(feature) = unsupported(&ctx, &setup) {
            return Err(GpuError::Unsupported(feature));
        }
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
        check_limits(device, &setup)?;
        // A scene with toughness keeps one damage per particle (as the CPU solver), which
        // the device holds in each position's w.
        let mut setup = setup;
        if crate::mpm::damage::onsets(&setup.materials, setup.layout.dx).is_some() {
            setup.particles.damage = vec![0.0; setup.particles.len()];
        }
        let max_substeps = setup.max_substeps.max(1);
        // One Step entry per substep, per constraint iteration with PB-MPM.
        let (steps_per_substep, _) = step_entries(setup.method, setup.pb_mpm);
        let res = Resources::new(
            device,
            &ctx.queue,
            &setup,
            shapes,
            max_substeps,
            steps_per_substep as u64,
        );
        let builder = StageBuilder {
            device,
            float_p2g,
            cutting: setup.cutting,
            plain: &res.plain,
            with_args: &res.with_args,
        };
        let implicit = (setup.method == Method::Implicit).then(|| {
            let module = builder.module("implicit", implicit::SOURCE);
            ImplicitStages::new(
                device,
                &res,
                &module,
                (
                    setup.layout.node_count(),
                    setup.particles.len(),
                    setup.layout.block_count(),
                ),
                setup.implicit,
            )
        });
        Ok(GpuSolver {
            implicit,
            frame_solve: SolveCounts::default(),
            sparse: SparseStage::new(&builder),
            crack: CrackStage::new(&builder),
            p2g: P2gStage::new(&builder),
            grid_update: GridUpdateStage::new(&builder),
            g2p: G2pStage::new(&builder),
            pb: PbMpmStages::new(&builder),
            readback: Readback::new(device, setup.particles.len(), setup.cutting),
            layout: setup.layout,
            float_p2g,
            cutting: setup.cutting,
            method: setup.method,
            pb_mpm: setup.pb_mpm,
            n: setup.particles.len() as u32,
            tool_count: setup.tool_count,
            max_substeps,
            res,
            read_deformation: false,
            host: setup.particles,
            host_dirty: false,
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
                .write_buffer(&self.res.particles, 0, bytemuck::cast_slice(&packed));
            if self.cutting {
                let cracks = pack::cracks(&self.host);
                self.ctx
                    .queue
                    .write_buffer(&self.res.cracks, 0, bytemuck::cast_slice(&cracks));
            }
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
            !self.readback.in_flight(),
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
        let (entries, relaxation) = step_entries(self.method, self.pb_mpm);
        self.res
            .write_frame_inputs(&self.ctx.queue, plan, entries, relaxation);
        if self.method == Method::Implicit {
            self.submit_implicit_frame(plan);
            return;
        }

        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame"),
            });
        encoder.copy_buffer_to_buffer(&self.res.particles, 0, &self.res.snapshot, 0, None);
        if self.cutting {
            encoder.copy_buffer_to_buffer(&self.res.cracks, 0, &self.res.crack_snapshot, 0, None);
        }
        {
            let groups = self.groups();
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("substeps"),
                timestamp_writes: None,
            });
            pass.set_bind_group(ARGS_GROUP, &self.res.args_group, &[]);
            for s in 0..plan.substeps {
                match self.method {
                    Method::MlsMpm | Method::PicMpm => self.record_substep(&mut pass, s, &groups),
                    Method::PbMpm => self.record_pb_substep(&mut pass, s, entries, &groups),
                    Method::Implicit => unreachable!("implicit frames: submit_implicit_frame"),
                }
            }
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

    /// Waits for the frame in flight, copies its positions (and deformation gradients while
    /// asked for) into the host copy and returns its statistics.
    ///
    /// # Panics
    /// When no frame was submitted, or the device is lost.
    pub fn collect_frame(&mut self) -> FrameStats {
        let mut stats = self.readback.collect(&self.ctx.device, &mut self.host);
        stats.solve = std::mem::take(&mut self.frame_solve);
        stats
    }

    /// The dispatch sizes of a frame.
    fn groups(&self) -> Groups<'_> {
        Groups {
            particles: self.n.div_ceil(WG).max(1),
            active_blocks: &self.res.args,
        }
    }

    /// Records one MLS-MPM (or PIC) substep: cracks (with a slicer) → block list and clear
    /// → P2G → grid update → G2P → impulse reduction.
    fn record_substep(&self, pass: &mut wgpu::ComputePass, s: u32, groups: &Groups) {
        self.res.bind_step(pass, s);
        self.crack.record(pass, groups);
        self.sparse.record(pass, groups);
        self.p2g.record(pass, groups);
        self.grid_update.record(pass, groups);
        self.g2p.record(pass, groups);
        self.grid_update.record_reduce(pass);
    }

    /// Records one PB-MPM substep (cpu `pb_substep`): cracks (with a slicer) and the block
    /// list once, then per
    /// iteration constraint → clear → P2G → grid update → G2P (integrating in the last) →
    /// impulse reduction, each iteration with its own Step entry.
    fn record_pb_substep(
        &self,
        pass: &mut wgpu::ComputePass,
        s: u32,
        iterations: u32,
        groups: &Groups,
    ) {
        for k in 0..iterations {
            self.res.bind_step(pass, s * iterations + k);
            if k == 0 {
                self.crack.record(pass, groups);
                self.sparse.record(pass, groups);
            } else {
                self.sparse.record_clear(pass, groups);
            }
            self.pb.record_p2g(pass, groups);
            self.grid_update.record(pass, groups);
            if k + 1 == iterations {
                self.g2p.record(pass, groups);
            } else {
                self.pb.record_g2p(pass, groups);
            }
            self.grid_update.record_reduce(pass);
            self.pb.record_next_iteration(pass);
        }
    }

    /// Device-side copy of `from` into the particles; the cracks are copied from
    /// `cracks_from`, or cleared without one (the rest state is uncut).
    fn submit_copy(&self, from: &wgpu::Buffer, cracks_from: Option<&wgpu::Buffer>) {
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("copy"),
            });
        encoder.copy_buffer_to_buffer(from, 0, &self.res.particles, 0, None);
        if self.cutting {
            match cracks_from {
                Some(c) => encoder.copy_buffer_to_buffer(c, 0, &self.res.cracks, 0, None),
                None => encoder.clear_buffer(&self.res.cracks, 0, None),
            }
        }
        self.ctx.queue.submit([encoder.finish()]);
    }

    /// Device-side copy of the frame-start state back into the particles.
    pub fn restore_frame_start(&mut self) {
        self.submit_copy(&self.res.snapshot, Some(&self.res.crack_snapshot));
        self.host_dirty = false;
        self.download_all();
    }

    /// Device-side copy of the rest state into the particles.
    pub fn reset_to_rest(&mut self) {
        self.submit_copy(&self.res.rest, None);
        self.host_dirty = false;
        self.download_all();
    }

    /// Blocking download of every particle field into the host copy (unless the host copy
    /// holds edits not uploaded yet).
    pub fn download_all(&mut self) {
        debug_assert!(
            !self.readback.in_flight(),
            "download while a frame is in flight"
        );
        if self.host_dirty || self.n == 0 {
            return;
        }
        readback::download_particles(
            &self.ctx.device,
            &self.ctx.queue,
            &self.res.particles,
            &mut self.host,
        );
        if self.cutting {
            readback::download_cracks(
                &self.ctx.device,
                &self.ctx.queue,
                &self.res.cracks,
                &mut self.host,
            );
        }
    }
}

/// Step entries per substep (one, or one per PB-MPM iteration) and PB-MPM's relaxation.
fn step_entries(method: Method, pb_mpm: PbMpmParams) -> (u32, f32) {
    match method {
        Method::MlsMpm | Method::PicMpm | Method::Implicit => (1, 0.0),
        Method::PbMpm => (pb_mpm.iterations.max(1), pb_mpm.relaxation),
    }
}
