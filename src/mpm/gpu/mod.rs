//! The MLS-MPM, PIC, PB-MPM, total Lagrangian and implicit solvers on wgpu: the CPU
//! solvers' math in WGSL compute shaders. The CPU solver ([`crate::mpm::cpu`]) stays the
//! reference and the fallback.
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
//!   and total Lagrangian MPM's P2G advance each particle's damage (kept in its position's
//!   w) and take the degraded stress (see [`crate::mpm::damage`]); PB-MPM has no stress to
//!   degrade and `check` refuses toughness with it;
//! - `pbmpm`: PB-MPM's elastic constraint on C, momentum-only P2G and the inner
//!   iterations' G2P; a PB-MPM substep records the stages above once per iteration, each
//!   iteration with its own parameter entry (gravity in the first only), integrating in
//!   the last (`record_pb_substep`);
//! - `tlmpm`: total Lagrangian MPM's capture of the grip and its stiffening bounds; its
//!   P2G, grid update and G2P are entries (`p2g_tl`, `grid_update_tl`, `g2p_tl`) of the
//!   stages above, on the rest configuration's stencils (see that module);
//! - `implicit`: backward-Euler MLS-MPM, Newton–CG on the grid velocities (its own
//!   buffers in bind group 1; a frame is several submissions, see that module).
//!
//! `resources.rs` holds the buffers and bind groups the stages share, `readback.rs` what
//! comes back to the host, `pack.rs` the structs shared with WGSL.
//!
//! # Choosing it
//!
//! `run --backend auto|gpu|cpu`, or `backend` in the scene's `[solver]` (the flag wins).
//! `auto` (the default) uses a hardware adapter (discrete, integrated or virtual) when one
//! exists and the CPU otherwise; `gpu` uses a hardware adapter when there is one and a software
//! one (Mesa's llvmpipe) otherwise, and fails with a message naming `mesa-vulkan-drivers` when
//! there is none. The chosen adapter (name, API, device type, f32 atomics) and the reason are
//! logged at `info`. One wgpu instance serves the whole process ([`adapter`]); each world opens
//! and, dropped, frees only its own device on it: NVIDIA's Vulkan driver takes static TLS on
//! every load that its unload does not give back, so an instance per world runs out after
//! about 30 worlds (`tests/gpu_lifetime.rs` builds and drops 30 and checks that wgpu's live
//! objects, threads and file descriptors return to their warm-up counts).
//!
//! Debian 12's own Mesa (22.3) lavapipe keeps about 100 MB of heap per submitted frame until
//! its device is dropped, on its own queue thread, so no drop order on our side helps; Mesa 25
//! keeps none. `.ci/run` installs Mesa from bookworm-backports there, and `gpu` on a software
//! adapter from Mesa 22 or older logs a warning.
//!
//! # P2G variants
//!
//! `--p2g auto|float|fixed` (scene: `p2g_atomics`). `float` scatters with f32 `atomicAdd`
//! (wgpu's `SHADER_FLOAT32_ATOMIC`: Vulkan with VK_EXT_shader_atomic_float, and Metal on
//! Apple7+). `fixed` uses core-WGSL i32 atomics (WebGPU, DX12, anything): momentum in units of
//! a cell's mass × max_speed/8 and mass in units of a cell's mass, × 2^26, so a node holds ±32
//! units (4 cell masses at the guard speed); past that the sum wraps and the runaway guard
//! trips. `auto` takes `float` where the adapter has it. Fixed point sums in any order to the
//! same bits, so a replay on it repeats the clouds bit for bit; f32 atomics sum in the order
//! the invocations run.
//!
//! # On the device
//!
//! Particle and grid buffers live on the device for the solver's lifetime. A frame is one
//! submission: a device-side copy of the frame-start state (what the guard's `stop` restores;
//! `reset_tissue` copies a device-side rest state), then every substep recorded into one
//! compute pass with each substep's dt and gravity picked by a dynamic uniform offset and every
//! substep's tool kinematics written once per frame. An MLS-MPM or PIC substep is five
//! dispatches, counted as they are recorded ([`DispatchCount`], printed by `bench frame`):
//! clear the active blocks, P2G, grid update, G2P (which flags the blocks the particle's next
//! stencil covers), and one workgroup that reduces the substep's contact impulses and
//! compacts the flags into the next substep's block list (a list whose count is also the x
//! of the indirect dispatches); the frame adds a mark and a compaction before its first
//! substep and the guard's report and the readback's extraction after its last. Eight
//! dispatches a substep before the fusion (`bench frame --frames 2`, seed 000's 105-substep
//! frame: 842 dispatches a frame, 529 after; on llvmpipe 2.48–3.54 s a frame before and
//! 2.57–2.81 s after, within that adapter's noise). Clearing and the grid update run only on
//! touched blocks; tool SDFs only on nodes inside each tool's bounding box. Contact impulses
//! are summed per block in workgroup memory, then per substep by one workgroup: no float
//! atomics, deterministic. The only readback is per frame: the frame statistics (per-tool
//! impulse and contact-node count, max speed, clamped count, guard event) and the positions,
//! through two staging buffers used in turn, with the deformation gradients too while an
//! output asks for them ([`GpuSolver::set_deformation_readback`]). Nothing is read back per
//! substep.
//!
//! Submitting a frame and collecting it are separate calls ([`GpuSolver::submit_frame`],
//! [`GpuSolver::collect_frame`]): between them the host copy still holds the previous
//! frame, so its outputs (point cloud, mesh, bag record) are built on the CPU while the device
//! computes the next; the node does so whenever it runs behind real time.
//!
//! # The implicit solve on the device
//!
//! The CPU solver's math (see [`crate::mpm`], "The implicit solver") with the node and
//! particle work in WGSL: momentum-only P2G, the constraints per node, Φ and ∇Φ per particle
//! (the energy written in H = F − I so that f32 keeps small strains), the 9×9 stiffness with
//! the same PSD projection (a Cholesky test, else cyclic Jacobi eigen-rotations with negative
//! eigenvalues set to zero), the Hessian product as gather → 9×9 → scatter, block Jacobi, and
//! the end velocities written back into the P2G accumulators for the explicit grid update and
//! G2P. Every sum is order-independent, so the solve gives the same result on every run: the
//! particle scatters add 64-bit fixed-point integers (two u32 atomics, the carry taken from
//! the low word's old value) in a unit set by a bound a first pass over the particles raises,
//! and the reductions over nodes take the active blocks in increasing index (the block list is
//! compacted by a scan, not an atomic append). CG keeps its scalars on the device and is read
//! back every 8 iterations; Newton and the line search stay on the host, each evaluation one
//! submission and a small readback. A substep of k Newton iterations with Cₖ CG iterations
//! and Lₖ line-search trials costs 4 + Σₖ (⌈Cₖ/8⌉ + Lₖ + 2) readbacks and about
//! 33 + Σₖ (80⌈Cₖ/8⌉ + 5Lₖ + 12) dispatches: on a discrete GPU it is latency bound at a few ms
//! a substep before any arithmetic. It needs f32 atomics (it stores the grid update's mass and
//! momentum into the f32 accumulators) and a scene that does not cut.
//!
//! # Agreement with the CPU
//!
//! `tests/gpu_agreement.rs` (total Lagrangian MPM included), `tests/implicit_gpu.rs`,
//! `tests/cutting_gpu.rs` and `tests/tearing.rs` compare both P2G variants with the CPU on
//! llvmpipe in CI (without any adapter they fail when `CI` is set and are skipped with the
//! reason otherwise): a free block spinning, squeezed and falling within 1 µm (f32) and
//! 5 µm (fixed point) of the CPU's positions, a grasp's forces within 2 % of the peak every
//! frame, Hertz's RMS error to the same 0.1540, the guard's restore bit for bit, PB-MPM and
//! PIC alike, the implicit solve within 5 % of the displacement with Newton totals within
//! 10 %, and total Lagrangian MPM's free block within 1 µm and 2 µm and its grip, lift and
//! release within 10 µm and 0.5 % of the peak force every frame.
//!
//! # On an NVIDIA H100
//!
//! `cargo run --release -- bench scaling` (block: a tissue cube at 8 particles per cell on a
//! bonded table with a sphere resting in it, dx 1 mm, 10 substeps per frame with positions read
//! back every frame; the machine's 16 CPU cores for the `cpu` rows):
//!
//! | scene | backend | particles | ms/substep | M particle-substeps/s |
//! |---|---|---|---|---|
//! | block 10000 | cpu (16 cores) | 10648 | 0.96 | 11.12 |
//! | block 10000 | gpu-f32-atomics | 10648 | 0.13 | 83.13 |
//! | block 100000 | cpu (16 cores) | 97336 | 3.28 | 29.65 |
//! | block 100000 | gpu-f32-atomics | 97336 | 0.27 | 356.98 |
//! | block 1000000 | cpu (16 cores) | 1000000 | 26.68 | 37.48 |
//! | block 1000000 | gpu-f32-atomics | 1000000 | 1.85 | 541.11 |
//! | block 1000000 | gpu-fixed-point | 1000000 | 1.77 | 563.79 |
//! | seed-000 | gpu-f32-atomics | 24000 | 0.22 | 110.88 |
//!
//! - **1 M particles** take 10 substeps a 60 Hz frame: 17.7–18.5 ms of GPU time for 16.7 ms
//!   simulated (0.90–0.94× real time), 15× the 16-core CPU. The rate still grows with the
//!   count, so the device is not saturated at 1 M.
//! - **Small scenes are fixed cost.** The seed-000 frame (`bench frame --frames 30`: 105
//!   substeps, readback and the 24,000-point cloud) takes 14.6 ms: at 24,000 particles a
//!   substep is about ten dispatches each waiting for the last, whatever the particle count.
//!   A 2 ms frame needs fewer, fused dispatches per substep (marking, compaction and clearing
//!   in one pass; G2P fused with the next substep's P2G as in wgsparkl), not more arithmetic.
//!   Pipelining the cloud saves 0.7 % there: the cloud costs 0.3 ms of the frame.
//! - **The implicit method on the GPU** (`bench --quick --backends gpu`) runs the stiff
//!   stretch at 60 kPa and 1 MPa 1.1× and 4.0× faster than explicit MLS-MPM at equal or better
//!   error, at about 50 ms a substep of readbacks and dispatches; on Hertz R = 6 dx (186,624
//!   particles, soft) it took 204.7 s for 100 substeps against 0.31 s explicit: on a GPU the
//!   implicit method is for stiff tissue only.
//!
//! On llvmpipe the GPU path runs at roughly a quarter of the CPU solver's rate on the same
//! cores (a software rasteriser pays for 108 atomics per particle in P2G and for every
//! dispatch), so `auto` keeps such machines on the CPU; its work still grows with particles
//! and touched blocks, not with the domain.

pub mod adapter;
mod blade;
mod crack;
mod g2p;
mod grid_update;
mod implicit;
pub mod level_set;
mod p2g;
mod pack;
mod pass;
mod pbmpm;
mod prelude;
mod readback;
mod resources;
pub mod skin;
mod sparse;
mod thread_grid;
mod tlmpm;

use super::backend::P2gAtomics;
use super::cpu::thread_contact::{ThreadContact, ThreadProxy, ThreadStepper, TissueLimits};
use super::frame_plan::{FramePart, FramePlan, FrameStats};
use super::grid::{Boundary, Node};
use super::stiffening::{self, StiffeningBounds, MAX_PIECES};
use super::{GridLayout, Method, Particles, PbMpmParams, SolveCounts, SolverSetup, MAX_TOOLS};
use crate::tools::{Shape, ToolKinematics};
use adapter::GpuContext;
use crack::CrackStage;
use g2p::G2pStage;
use grid_update::GridUpdateStage;
use implicit::ImplicitStages;
use level_set::{Lattice, LevelSetLook, LevelSetStage, LevelSetVertices};
use p2g::P2gStage;
pub use p2g::FIXED_SCALE;
use pack::GpuParticle;
use pass::CountingPass;
use pbmpm::PbMpmStages;
use prelude::StageBuilder;
use readback::Readback;
use resources::{Resources, ARGS_GROUP};
use skin::{FrameSlots, MeshBinding, SkinStage, SkinnedVertices};
use sparse::SparseStage;
use thread_grid::ThreadGrid;
use tlmpm::TlStages;

/// How [`GpuError::Unsupported`] names the implicit method on an adapter without f32
/// atomics (see `implicit`).
pub const IMPLICIT_WITHOUT_FLOAT_ATOMICS: &str =
    "solver.method = \"implicit\" on an adapter without f32 atomics (SHADER_FLOAT32_ATOMIC)";
/// What the GPU backend lacks for the implicit method in a scene with a slicer.
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
    /// No GPU adapter exists (no Vulkan, Metal or DX12 driver).
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
    /// The scene exceeds the device's buffer or dispatch limits, or the implicit solve's particle
    /// bound (holds which).
    TooLarge(String),
    #[error("the GPU backend does not support {0} yet; use backend = \"cpu\" or \"auto\"")]
    /// A scene feature the GPU backend does not implement yet (holds which).
    Unsupported(&'static str),
}

/// Total Lagrangian MPM's passes and what the host keeps of it (see [`tlmpm`]).
struct TotalLagrangian {
    stages: TlStages,
    /// The rest positions are on the device (written before the first frame).
    rest_written: bool,
    /// The stiffening bounds the next frame's pieces come from.
    bounds: StiffeningBounds,
    /// The bounds are not those of the device's state (a restore or a host edit since).
    bounds_stale: bool,
    /// Pieces each substep of the frame in flight is cut into.
    pieces: u32,
    /// The tools of a frame cut into pieces, kept from frame to frame.
    cut_tools: Vec<ToolKinematics>,
}

/// Workgroup size of the per-particle and per-block stages.
const WG: u32 = 64;

/// The sizes of a frame's dispatches: workgroups over the particles, and the indirect
/// arguments (one workgroup per active block).
struct Groups<'a> {
    particles: u32,
    active_blocks: &'a wgpu::Buffer,
}

/// The compute dispatches of one frame, counted as they were recorded.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DispatchCount {
    /// Every dispatch of the frame's pass.
    pub frame: u32,
    /// The frame's substeps (total Lagrangian MPM: its pieces).
    pub substeps: u32,
    /// The dispatches recorded by the substeps themselves (the rest open or close the frame).
    pub in_substeps: u32,
}

impl DispatchCount {
    /// Dispatches per substep.
    pub fn per_substep(&self) -> f64 {
        self.in_substeps as f64 / self.substeps.max(1) as f64
    }
}
/// The wgpu compute solver: particles and the sparse block grid on the GPU, with a host copy of the
/// particles read back each frame.
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
    /// With `method = "tl_mpm"`: its own passes and host state.
    total_lagrangian: Option<TotalLagrangian>,
    /// Newton and CG iterations of the frame in flight.
    frame_solve: SolveCounts,
    /// Dispatches the last explicit frame recorded (see [`DispatchCount`]).
    dispatches: DispatchCount,
    readback: Readback,
    /// Whether frames read back the deformation gradients as well as the positions.
    read_deformation: bool,
    host: Particles,
    /// The host copy has edits the device does not have yet.
    host_dirty: bool,
    /// The walls and table, for the threads' coupling on the host.
    boundary: Boundary,
    tissue: TissueLimits,
    /// Threads in the tissue, once a frame loaded them (see [`thread_grid`]).
    threads: Option<Box<ThreadGrid>>,
    /// The tissue surface a camera draws from the device, once one asked.
    surface: Option<DeviceSurface>,
}

/// The tissue surface built on the device at the end of each frame, for the camera, into
/// two output sets in turn.
struct DeviceSurface {
    stage: SurfaceStage,
    slots: FrameSlots,
}

enum SurfaceStage {
    /// The rest mesh moved with the particles ([`skin`]).
    Mesh(SkinStage),
    /// The level set extracted afresh ([`level_set`]).
    LevelSet(LevelSetStage),
}

/// The device surface of the frame last collected, as the camera draws it.
pub enum SurfaceOnDevice<'a> {
    /// The skinned mesh: its stage (for the triangles) and its vertices.
    Mesh(&'a SkinStage, &'a SkinnedVertices),
    /// The level set's triangle list.
    LevelSet(&'a LevelSetVertices),
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
        if crate::mpm::damage::onsets(&setup).is_some() {
            setup.particles.damage = vec![0.0; setup.particles.len()];
        }
        let max_substeps = setup.max_substeps.max(1);
        // One Step entry per substep, per constraint iteration with PB-MPM; total
        // Lagrangian MPM's substeps are cut into as many as MAX_PIECES steps, each with its
        // own entry and tools.
        let (steps_per_substep, _) = step_entries(setup.method, setup.pb_mpm);
        let total_lagrangian = setup.method == Method::TlMpm;
        let step_capacity = max_substeps * if total_lagrangian { MAX_PIECES } else { 1 };
        let res = Resources::new(
            device,
            &ctx.queue,
            &setup,
            shapes,
            step_capacity,
            steps_per_substep as u64,
        );
        let builder = StageBuilder {
            device,
            float_p2g,
            total_lagrangian,
            cutting: setup.cutting,
            plain: &res.plain,
            with_args: &res.with_args,
        };
        let implicit = (setup.method == Method::Implicit).then(|| {
            let module = builder.module("implicit", &implicit::source());
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
        let tissue = TissueLimits::new(&setup.materials, setup.layout.dx);
        let boundary = setup.boundary;
        let total_lagrangian = total_lagrangian.then(|| TotalLagrangian {
            stages: TlStages::new(&builder),
            rest_written: false,
            bounds: StiffeningBounds::default(),
            bounds_stale: true,
            pieces: 1,
            cut_tools: Vec::new(),
        });
        Ok(GpuSolver {
            implicit,
            total_lagrangian,
            frame_solve: SolveCounts::default(),
            dispatches: DispatchCount::default(),
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
            boundary,
            tissue,
            threads: None,
            surface: None,
            ctx,
        })
    }

    /// The grid's placement and size.
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

    /// The GPU adapter's name, as the driver reports it.
    pub fn adapter_name(&self) -> &str {
        &self.ctx.info.name
    }

    /// Whether each frame also reads back the deformation gradients (48 bytes a particle
    /// on top of the positions' 16), so that `host_particles().f` is current.
    pub fn set_deformation_readback(&mut self, on: bool) {
        self.read_deformation = on;
    }

    /// The host copy of the particles: positions as of the last frame read back (deformation
    /// gradients only with [`GpuSolver::set_deformation_readback`]).
    pub fn host_particles(&self) -> &Particles {
        &self.host
    }

    /// The host copy of the particles, brought fully up to date from the GPU, to edit: the edits
    /// are uploaded before the next substep.
    pub fn host_particles_mut(&mut self) -> &mut Particles {
        self.download_all();
        self.host_dirty = true;
        self.invalidate_surface();
        &mut self.host
    }

    fn upload_if_dirty(&mut self) {
        if self.host_dirty {
            if let Some(tl) = &mut self.total_lagrangian {
                tl.bounds_stale = true;
            }
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
        if self.method == Method::TlMpm {
            self.submit_tl_frame(plan);
            return;
        }
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
        self.record_frame_start(&mut encoder, plan.part);
        let dispatches;
        {
            let groups = self.groups();
            let mut pass =
                CountingPass::new(encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("substeps"),
                    timestamp_writes: None,
                }));
            pass.set_bind_group(ARGS_GROUP, &self.res.args_group, &[]);
            if matches!(self.method, Method::MlsMpm | Method::PicMpm) {
                self.res.bind_step(&mut pass, 0);
                self.sparse.record_first_blocks(&mut pass, &groups);
            }
            let before = pass.dispatches();
            for s in 0..plan.substeps {
                match self.method {
                    Method::MlsMpm | Method::PicMpm => self.record_substep(&mut pass, s, &groups),
                    Method::PbMpm => self.record_pb_substep(&mut pass, s, entries, &groups),
                    Method::Implicit => unreachable!("implicit frames: submit_implicit_frame"),
                    Method::TlMpm => unreachable!("total Lagrangian frames: submit_tl_frame"),
                }
            }
            let in_substeps = pass.dispatches() - before;
            if plan.part.last {
                self.res.bind_step(&mut pass, 0);
                self.g2p.record_frame_end(&mut pass, &groups);
            }
            dispatches = DispatchCount {
                frame: pass.dispatches(),
                substeps: plan.substeps,
                in_substeps,
            };
        }
        self.dispatches = dispatches;
        self.submit_with_readback(encoder, plan.part.last);
    }

    /// The dispatches the last explicit frame recorded, counted as they were recorded.
    pub fn dispatch_count(&self) -> DispatchCount {
        self.dispatches
    }

    /// Waits for the frame in flight, copies its positions (and deformation gradients while
    /// asked for) into the host copy and returns its statistics.
    ///
    /// # Panics
    /// When no frame was submitted, or the device is lost.
    pub fn collect_frame(&mut self) -> FrameStats {
        let mut stats = self.readback.collect(&self.ctx.device, &mut self.host);
        if let Some(surface) = &mut self.surface {
            surface.slots.collected();
        }
        stats.solve = std::mem::take(&mut self.frame_solve);
        if let Some(tl) = &mut self.total_lagrangian {
            // Steps done, in whole substeps; the bounds decide the next frame's pieces.
            stats.substeps_done /= tl.pieces;
            tl.bounds = self.readback.stiffening;
            tl.bounds_stale = stats.guard.is_some();
        }
        stats
    }

    /// The proxies of `count` threads in the tissue for the caller to load for the coming
    /// frame (see `thread_grid`); `None` for a method other than MLS-MPM and PIC, whose
    /// grid update the coupling follows.
    pub fn load_threads(&mut self, count: usize) -> Option<&mut [ThreadProxy]> {
        if !matches!(self.method, Method::MlsMpm | Method::PicMpm) {
            return None;
        }
        let threads = self.threads.get_or_insert_with(|| {
            Box::new(ThreadGrid::new(
                &self.ctx.device,
                &self.layout,
                self.boundary,
                self.tissue,
            ))
        });
        Some(threads.contact.load(count))
    }

    /// The threads' coupling with the grid, once loaded.
    pub fn thread_contact(&self) -> Option<&ThreadContact> {
        self.threads.as_ref().map(|t| &t.contact)
    }

    /// Whether frames step threads in the tissue (and so wait for the device each
    /// substep: [`GpuSolver::step_frame_with_threads`]).
    pub fn has_threads(&self) -> bool {
        self.threads.as_ref().is_some_and(|t| !t.contact.is_empty())
    }

    /// Steps an MLS-MPM or PIC frame with the loaded threads coupled to the grid in every
    /// substep, `stepper` stepping their rods (see `thread_grid`), and returns its
    /// statistics: the frame is done when this returns.
    ///
    /// # Panics
    /// When a frame is in flight, no thread was loaded, or the device is lost.
    pub fn step_frame_with_threads(
        &mut self,
        plan: &FramePlan,
        stepper: &mut dyn ThreadStepper,
    ) -> FrameStats {
        assert!(
            !self.readback.in_flight(),
            "step_frame_with_threads called while a frame is in flight"
        );
        assert!(plan.substeps <= self.max_substeps && plan.tool_count == self.tool_count);
        let mut threads = self
            .threads
            .take()
            .expect("step_frame_with_threads called with no thread loaded");
        self.upload_if_dirty();
        let (entries, relaxation) = step_entries(self.method, self.pb_mpm);
        self.res
            .write_frame_inputs(&self.ctx.queue, plan, entries, relaxation);
        let device = &self.ctx.device;
        let new_encoder = || {
            device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame with threads"),
            })
        };
        let mut encoder = new_encoder();
        self.record_frame_start(&mut encoder, plan.part);
        let groups = self.groups();
        for s in 0..plan.substeps {
            {
                let mut pass = self.begin_thread_pass(&mut encoder);
                if s == 0 {
                    self.res.bind_step(&mut pass, 0);
                    self.sparse.record_first_blocks(&mut pass, &groups);
                }
                self.record_to_grid(&mut pass, s, &groups);
            }
            threads.plan_reach(&self.layout);
            threads.record_copy(&mut encoder, &self.res);
            self.ctx.queue.submit([encoder.finish()]);
            threads.couple(
                device,
                &self.ctx.queue,
                &self.res,
                &self.layout,
                plan.dt,
                stepper,
            );
            encoder = new_encoder();
            let mut pass = self.begin_thread_pass(&mut encoder);
            self.res.bind_step(&mut pass, s);
            self.record_from_grid(&mut pass, &groups);
            if s + 1 == plan.substeps && plan.part.last {
                self.res.bind_step(&mut pass, 0);
                self.g2p.record_frame_end(&mut pass, &groups);
            }
        }
        self.threads = Some(threads);
        self.submit_with_readback(encoder, plan.part.last);
        self.collect_frame()
    }

    /// Records the copy of the particles (and cracks) kept for a guard event's restore, at
    /// the start of the world's frame only.
    pub(in crate::mpm::gpu) fn record_frame_start(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        part: FramePart,
    ) {
        if !part.first {
            return;
        }
        encoder.copy_buffer_to_buffer(&self.res.particles, 0, &self.res.snapshot, 0, None);
        if self.cutting {
            encoder.copy_buffer_to_buffer(&self.res.cracks, 0, &self.res.crack_snapshot, 0, None);
        }
    }

    /// A pass of a frame with threads, the indirect arguments bound.
    fn begin_thread_pass<'e>(&self, encoder: &'e mut wgpu::CommandEncoder) -> CountingPass<'e> {
        let mut pass =
            CountingPass::new(encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("substep with threads"),
                timestamp_writes: None,
            }));
        pass.set_bind_group(ARGS_GROUP, &self.res.args_group, &[]);
        pass
    }

    /// Records and submits a total Lagrangian frame (see [`tlmpm`]): the plan cut into the
    /// pieces its stiffening bounds ask for, each piece a step of its own.
    fn submit_tl_frame(&mut self, plan: &FramePlan) {
        let tl = self
            .total_lagrangian
            .as_mut()
            .expect("a total Lagrangian solver");
        if !tl.rest_written {
            let rest: Vec<[f32; 4]> = self.host.x.iter().map(|x| [x.x, x.y, x.z, 0.0]).collect();
            self.ctx
                .queue
                .write_buffer(&self.res.tl_rest, 0, bytemuck::cast_slice(&rest));
            tl.rest_written = true;
        }
        if tl.bounds_stale {
            tl.bounds = StiffeningBounds::all_free(&self.host.f);
            tl.bounds_stale = false;
        }
        tl.pieces = tl.bounds.pieces(plan);
        let mut cut_tools = std::mem::take(&mut tl.cut_tools);
        let steps = stiffening::cut(plan, tl.pieces, &mut cut_tools);
        let substeps = steps.substeps;
        self.res.write_frame_inputs(&self.ctx.queue, &steps, 1, 0.0);
        tl.cut_tools = cut_tools;
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("total Lagrangian frame"),
            });
        self.record_frame_start(&mut encoder, plan.part);
        let dispatches;
        {
            let groups = self.groups();
            let tl = self.total_lagrangian.as_ref().expect("checked above");
            let mut pass =
                CountingPass::new(encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("steps"),
                    timestamp_writes: None,
                }));
            pass.set_bind_group(ARGS_GROUP, &self.res.args_group, &[]);
            let before = pass.dispatches();
            for step in 0..substeps {
                self.res.bind_step(&mut pass, step);
                self.sparse.record(&mut pass, &groups);
                tl.stages.record_capture(&mut pass, &groups);
                self.p2g.record_tl(&mut pass, &groups);
                self.grid_update.record_tl(&mut pass, &groups);
                self.g2p.record_tl(&mut pass, &groups);
                self.grid_update.record_reduce(&mut pass);
            }
            let in_substeps = pass.dispatches() - before;
            self.res.bind_step(&mut pass, 0);
            tl.stages.record_bound(&mut pass, &groups);
            if plan.part.last {
                self.g2p.record_frame_end(&mut pass, &groups);
            }
            dispatches = DispatchCount {
                frame: pass.dispatches(),
                substeps,
                in_substeps,
            };
        }
        self.dispatches = dispatches;
        self.submit_with_readback(encoder, plan.part.last);
    }

    /// The dispatch sizes of a frame.
    fn groups(&self) -> Groups<'_> {
        Groups {
            particles: self.n.div_ceil(WG).max(1),
            active_blocks: &self.res.args,
        }
    }

    /// Records one MLS-MPM (or PIC) substep: cracks (with a slicer) → clear of the block
    /// list → P2G → grid update → G2P (flagging the next substep's blocks) → impulse
    /// reduction fused with the next block list. The frame's first list comes from
    /// [`SparseStage::record_first_blocks`].
    fn record_substep(&self, pass: &mut CountingPass, s: u32, groups: &Groups) {
        self.record_to_grid(pass, s, groups);
        self.record_from_grid(pass, groups);
    }

    /// The first half of an MLS-MPM (or PIC) substep: up to the grid update.
    fn record_to_grid(&self, pass: &mut CountingPass, s: u32, groups: &Groups) {
        self.res.bind_step(pass, s);
        self.crack.record(pass, groups);
        self.sparse.record_clear(pass, groups);
        self.p2g.record(pass, groups);
        self.grid_update.record(pass, groups);
    }

    /// The second half of an MLS-MPM (or PIC) substep, its step bound: G2P on.
    fn record_from_grid(&self, pass: &mut CountingPass, groups: &Groups) {
        self.g2p.record(pass, groups);
        self.sparse.record_end_substep(pass);
    }

    /// Records one PB-MPM substep (cpu `pb_substep`): cracks (with a slicer) and the block
    /// list once, then per
    /// iteration constraint → clear → P2G → grid update → G2P (integrating in the last) →
    /// impulse reduction, each iteration with its own Step entry.
    fn record_pb_substep(&self, pass: &mut CountingPass, s: u32, iterations: u32, groups: &Groups) {
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
    /// Records the copies the frame's outputs need after a frame's passes, submits the frame
    /// and asks for the readback (shared by the explicit and the implicit frames).
    /// Without `particles` (a frame that does not end the world's frame, see
    /// [`FramePart`]) only the statistics come back, and the host copy stays as it was.
    fn submit_with_readback(&mut self, mut encoder: wgpu::CommandEncoder, particles: bool) {
        if let (true, Some(surface)) = (particles, &mut self.surface) {
            let slot = surface.slots.begin();
            match &surface.stage {
                SurfaceStage::Mesh(s) => s.record(&mut encoder, slot),
                SurfaceStage::LevelSet(s) => s.record(&mut encoder, slot),
            }
        }
        let copies = self.readback.record(
            &mut encoder,
            &self.res.stats,
            &self.res.extract,
            if particles { self.n as usize } else { 0 },
            self.read_deformation,
        );
        self.ctx.queue.submit([encoder.finish()]);
        self.readback.request(copies);
    }

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
        self.mark_bounds_stale();
        self.invalidate_surface();
        self.submit_copy(&self.res.snapshot, Some(&self.res.crack_snapshot));
        self.host_dirty = false;
        self.download_all();
    }

    /// Device-side copy of the rest state into the particles.
    pub fn reset_to_rest(&mut self) {
        self.mark_bounds_stale();
        self.invalidate_surface();
        self.submit_copy(&self.res.rest, None);
        self.host_dirty = false;
        self.download_all();
    }

    /// The device's particles moved outside a frame: the device surface is stale until the
    /// next frame.
    fn invalidate_surface(&mut self) {
        if let Some(surface) = &mut self.surface {
            surface.slots.invalidate();
        }
    }

    /// Moves `binding`'s mesh (the tissue surface bound to these particles) with the
    /// particles at the end of every frame from the next one submitted, for a camera to draw
    /// on this device (see [`skin`]).
    pub fn skin_mesh(&mut self, binding: &MeshBinding) {
        self.surface = Some(DeviceSurface {
            stage: SurfaceStage::Mesh(SkinStage::new(
                &self.ctx.device,
                &self.res.particles,
                binding,
            )),
            slots: FrameSlots::default(),
        });
    }

    /// Extracts the particles' ½ volume-fraction level set on `lattice` at the end of every
    /// frame from the next one submitted, for a camera to draw on this device (see
    /// [`level_set`]).
    pub fn extract_level_set(&mut self, lattice: Lattice, look: LevelSetLook) {
        self.surface = Some(DeviceSurface {
            stage: SurfaceStage::LevelSet(LevelSetStage::new(
                &self.ctx.device,
                [&self.res.particles, &self.res.constants],
                self.n,
                lattice,
                look,
            )),
            slots: FrameSlots::default(),
        });
    }

    /// The device surface of the frame last collected, while it matches the particles;
    /// `None` before [`GpuSolver::skin_mesh`] or [`GpuSolver::extract_level_set`], before
    /// the first frame after it, and after the particles moved outside a frame.
    pub fn surface_on_device(&self) -> Option<SurfaceOnDevice<'_>> {
        let surface = self.surface.as_ref()?;
        let slot = surface.slots.current()?;
        Some(match &surface.stage {
            SurfaceStage::Mesh(s) => SurfaceOnDevice::Mesh(s, s.vertices(slot)),
            SurfaceStage::LevelSet(s) => SurfaceOnDevice::LevelSet(s.vertices(slot)),
        })
    }

    /// The device and queue the solver runs on.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// The device's state changed behind total Lagrangian MPM's stiffening bounds.
    fn mark_bounds_stale(&mut self) {
        if let Some(tl) = &mut self.total_lagrangian {
            tl.bounds_stale = true;
        }
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
        Method::MlsMpm | Method::PicMpm | Method::Implicit | Method::TlMpm => (1, 0.0),
        Method::PbMpm => (pb_mpm.iterations.max(1), pb_mpm.relaxation),
    }
}
