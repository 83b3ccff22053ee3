//! Solver backends behind one frame-level interface.
//!
//! `World` plans a whole frame up front (equal substeps, every substep's tool kinematics)
//! and hands the plan to a backend, which runs all substeps and reports frame-level
//! statistics. The CPU backend loops its `substep`; the GPU backend records every substep
//! into one submission and reads back only what the frame's outputs need.

use super::cpu::thread_contact::{GridExchange, ThreadProxy, ThreadStepper};
use super::cpu::{CpuSolver, SubstepInput};
use super::frame_plan::{FramePlan, FrameStats};
use super::gpu::GpuSolver;
use super::stiffening;
use super::{GridLayout, Particles};
use serde::{Deserialize, Serialize};

/// Which backend a scene asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum BackendChoice {
    /// A hardware GPU adapter when one exists, the CPU backend otherwise.
    #[default]
    Auto,
    /// A GPU adapter, a software one (llvmpipe) if no hardware adapter exists.
    Gpu,
    /// The CPU reference solver.
    Cpu,
}

/// How the GPU's P2G scatter accumulates into the grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum P2gAtomics {
    /// f32 atomics where the adapter has `SHADER_FLOAT32_ATOMIC`, fixed point otherwise.
    #[default]
    Auto,
    /// f32 atomic add (Vulkan with VK_EXT_shader_atomic_float, Metal Apple7+).
    Float,
    /// i32 fixed-point atomic add (core WGSL: WebGPU, DX12, everywhere).
    Fixed,
}

/// A solver backend.
pub enum Backend {
    /// The CPU solver.
    Cpu(Box<CpuBackend>),
    /// The wgpu compute solver.
    Gpu(Box<GpuSolver>),
}

/// The CPU solver plus the copies the guard policy restores from.
pub struct CpuBackend {
    /// The solver.
    pub solver: CpuSolver,
    frame_start: Particles,
    rest: Particles,
}

impl CpuBackend {
    /// A backend around `solver`, its particles kept as the frame-start and rest copies.
    pub fn new(solver: CpuSolver) -> Self {
        CpuBackend {
            frame_start: solver.particles.clone(),
            rest: solver.particles.clone(),
            solver,
        }
    }
}

impl Backend {
    /// `cpu` or `gpu`.
    pub fn name(&self) -> &'static str {
        match self {
            Backend::Cpu(_) => "cpu",
            Backend::Gpu(g) => g.variant_name(),
        }
    }

    /// The grid's placement and size.
    pub fn layout(&self) -> &GridLayout {
        match self {
            Backend::Cpu(c) => &c.solver.layout,
            Backend::Gpu(g) => g.layout(),
        }
    }

    /// Runs a planned frame. The state at the frame start is kept for `restore_frame_start`.
    pub fn step_frame(&mut self, plan: &FramePlan) -> FrameStats {
        self.begin_frame(plan);
        self.finish_frame(plan, None)
    }

    /// Starts a planned frame: the GPU backend submits it and returns at once; the CPU
    /// backend does its work in `finish_frame`. Until `finish_frame`, `particles()` holds
    /// the previous frame's state on both, so its outputs can be built meanwhile.
    pub fn begin_frame(&mut self, plan: &FramePlan) {
        if let Backend::Gpu(g) = self {
            // A frame with threads in the tissue waits for the device every substep: it
            // runs in `finish_frame`, which has the threads' stepper.
            if !g.has_threads() {
                g.submit_frame(plan);
            }
        }
    }

    /// The proxies of `count` threads for the grid to touch over the coming frame (see
    /// [`super::cpu::thread_contact`]), for the caller to load, with no impulse yet; `None`
    /// with a method whose grid does not meet threads.
    pub fn load_threads(&mut self, count: usize) -> Option<&mut [ThreadProxy]> {
        match self {
            Backend::Cpu(c) => Some(c.solver.thread_contact.load(count)),
            Backend::Gpu(g) => g.load_threads(count),
        }
    }

    /// Thread `thread` as the grid left it (its frame's sums of contact impulse and bound
    /// tissue's push among them); `None` for a thread not loaded.
    pub fn thread_proxy(&self, thread: usize) -> Option<&ThreadProxy> {
        match self {
            Backend::Cpu(c) => c.solver.thread_contact.proxy(thread),
            Backend::Gpu(g) => g.thread_contact()?.proxy(thread),
        }
    }

    /// What the grid and the threads exchanged since the frame began (see
    /// [`super::cpu::thread_contact`]); `None` on the GPU before a frame loaded threads.
    pub fn thread_exchange(&self) -> Option<GridExchange> {
        match self {
            Backend::Cpu(c) => Some(c.solver.thread_contact.exchange()),
            Backend::Gpu(g) => g.thread_contact().map(|t| t.exchange()),
        }
    }

    /// Completes the frame `begin_frame` started (the same plan is passed to both); the CPU
    /// steps the threads loaded by [`Backend::load_threads`] through `threads` inside its
    /// substeps.
    pub fn finish_frame(
        &mut self,
        plan: &FramePlan,
        mut threads: Option<&mut (dyn ThreadStepper + '_)>,
    ) -> FrameStats {
        match self {
            Backend::Cpu(c) => {
                if plan.part.first {
                    c.frame_start.copy_state_from(&c.solver.particles);
                }
                // Total Lagrangian MPM cuts each substep into pieces (see `stiffening`).
                let pieces = if c.solver.method == super::Method::TlMpm {
                    c.solver.stiffening_bounds().pieces(plan)
                } else {
                    1
                };
                let mut cut_tools = Vec::new();
                let steps = stiffening::cut(plan, pieces, &mut cut_tools);
                let mut out = FrameStats::default();
                for s in 0..steps.substeps as usize {
                    let input = SubstepInput {
                        dt: steps.dt,
                        gravity: steps.gravity,
                        tools: steps.substep_tools(s),
                    };
                    let stats = c
                        .solver
                        .substep_with_threads(&input, threads.as_deref_mut());
                    if stats.guard.is_some() {
                        out.guard = stats.guard;
                        break;
                    }
                    for (acc, imp) in out.tool_impulses.iter_mut().zip(&stats.tool_impulses) {
                        acc.add(imp);
                    }
                    out.max_speed = out.max_speed.max(stats.max_speed);
                    out.clamped_particles += stats.clamped_particles;
                    out.solve.add(stats.solve);
                    out.substeps_done += 1;
                }
                out.substeps_done /= pieces;
                if out.guard.is_none() && plan.part.last && c.solver.split.max_edge_cells > 0.0 {
                    let dx = c.solver.layout.dx;
                    let params = c.solver.split;
                    out.split = super::split::split_stretched(&mut c.solver.particles, dx, &params);
                    let (stretch, p) = super::split::max_stretch(&c.solver.particles);
                    out.max_stretch = stretch;
                    out.max_stretch_at = c.solver.particles.x.get(p).copied().unwrap_or_default();
                }
                out
            }
            Backend::Gpu(g) => match threads {
                Some(threads) if g.has_threads() => g.step_frame_with_threads(plan, threads),
                // `begin_frame` left a frame with threads loaded to this call.
                None if g.has_threads() => g.step_frame(plan),
                _ => g.collect_frame(),
            },
        }
    }

    /// Puts the particles back to where they were when the last frame started.
    pub fn restore_frame_start(&mut self) {
        match self {
            Backend::Cpu(c) => c.solver.particles.copy_state_from(&c.frame_start),
            Backend::Gpu(g) => g.restore_frame_start(),
        }
    }

    /// Puts the particles back to the scene's rest configuration.
    pub fn reset_to_rest(&mut self) {
        match self {
            Backend::Cpu(c) => c.solver.particles.copy_state_from(&c.rest),
            Backend::Gpu(g) => g.reset_to_rest(),
        }
    }

    /// Whether frames bring the deformation gradients to the host as well as the positions
    /// (a per-frame download on the GPU while on; the CPU always has them).
    pub fn set_deformation_readback(&mut self, on: bool) {
        if let Backend::Gpu(g) = self {
            g.set_deformation_readback(on);
        }
    }

    /// Particle state on the host. On the GPU: positions as of the last frame, deformation
    /// gradients too while `set_deformation_readback` is on; everything else as of the
    /// last `sync_particles`.
    pub fn particles(&self) -> &Particles {
        match self {
            Backend::Cpu(c) => &c.solver.particles,
            Backend::Gpu(g) => g.host_particles(),
        }
    }

    /// Full particle state for editing; on the GPU it is downloaded first and uploaded
    /// again before the next frame.
    pub fn particles_mut(&mut self) -> &mut Particles {
        match self {
            Backend::Cpu(c) => &mut c.solver.particles,
            Backend::Gpu(g) => g.host_particles_mut(),
        }
    }

    /// Brings the host copy of every particle field up to date (a blocking download on the
    /// GPU; nothing on the CPU).
    pub fn sync_particles(&mut self) {
        if let Backend::Gpu(g) = self {
            g.download_all();
        }
    }
}
