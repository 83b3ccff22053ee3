//! Material Point Method: particle and grid state, materials, time step, guard, solvers.
//!
//! `cpu` is the reference solver (rayon); every other backend implements the same math.

pub mod backend;
pub mod cpu;
pub mod crack;
pub mod damage;
pub mod frame_plan;
pub mod gpu;
pub mod grid;
pub mod guard;
pub mod kernel;
pub mod material;
pub mod particles;
pub mod pieces;
pub mod timestep;

pub use crate::math::{IVec3, Mat3, Vec3};

use serde::{Deserialize, Serialize};

pub use backend::P2gAtomics;
pub use grid::{Boundary, GridLayout, TableHold};
pub use guard::{GuardEvent, GuardKind};
pub use material::{Lame, MaterialModel};
pub use particles::{MaterialParams, Particles};

/// Which MPM formulation steps the tissue (scene key `solver.method`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Explicit MLS-MPM: substeps bound by the elastic wave CFL, stiffness from E and ν.
    #[default]
    MlsMpm,
    /// Position-based MPM (Lewin 2024; seed 002 eqs. 13–16): larger substeps solved by
    /// constraint iterations; see [`cpu::pbmpm`] for how E and ν enter.
    PbMpm,
    /// The standard-MPM reference: MLS-MPM's forces and step with PIC velocity transfer
    /// (P2G carries m·v without APIC's affine momentum m·C·(xᵢ − xₚ)), so it dissipates
    /// rotation and shear motion that APIC keeps.
    PicMpm,
    /// Backward-Euler MLS-MPM solved as an energy minimisation (Gast et al. 2015): substeps
    /// bound by advection only, stiffness from E and ν; see [`cpu::implicit`].
    Implicit,
}

impl Method {
    /// Whether P2G carries APIC's affine momentum (all but the PIC reference).
    pub fn affine_transfer(&self) -> bool {
        !matches!(self, Method::PicMpm)
    }
}

/// PB-MPM settings (scene keys `solver.iterations`, `solver.relaxation`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PbMpmParams {
    /// Constraint iterations (P2G–grid–G2P cycles) per substep.
    pub iterations: u32,
    /// Over-relaxation of the elastic constraint, 0 < relaxation < 2.
    pub relaxation: f32,
}

/// Implicit solver settings (scene keys `solver.newton_*`, `solver.cg_*`,
/// `solver.preconditioner`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImplicitParams {
    /// Most Newton iterations per substep.
    pub newton_iterations: u32,
    /// Newton stops when the free-node residual falls below this fraction of its first value
    /// or of the momentum gravity gives the nodes in one step, whichever is larger.
    pub newton_tolerance: f32,
    /// Most conjugate-gradient iterations per Newton iteration.
    pub cg_iterations: u32,
    /// The loosest Eisenstat–Walker forcing term: CG stops when its residual falls below
    /// η times the Newton residual, η at most this (the first Newton iteration's), then
    /// shrinking as Newton converges (`mpm::cpu::implicit`).
    pub cg_tolerance: f32,
    pub preconditioner: Preconditioner,
}

impl Default for ImplicitParams {
    fn default() -> Self {
        ImplicitParams {
            newton_iterations: 8,
            newton_tolerance: 1e-3,
            cg_iterations: 200,
            cg_tolerance: 1e-1,
            preconditioner: Preconditioner::BlockJacobi,
        }
    }
}

/// Preconditioner of the implicit solver's conjugate gradients (scene key
/// `solver.preconditioner`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Preconditioner {
    /// The node mass: the Hessian's inertia term alone.
    Mass,
    /// Each node's 3×3 diagonal block of the Hessian, inertia and elasticity.
    #[default]
    BlockJacobi,
}

/// Iterations an implicit solve took (zero for the explicit methods).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SolveCounts {
    pub newton: u32,
    pub cg: u32,
    /// Nodes that joined the active set of constraints after a Newton solve (the solution
    /// moved them into a tool, the table or a wall).
    pub activated: u32,
}

impl SolveCounts {
    pub fn add(&mut self, other: SolveCounts) {
        self.newton += other.newton;
        self.cg += other.cg;
        self.activated += other.activated;
    }
}

/// What a solver is built from: the same for the CPU and the GPU backend.
pub struct SolverSetup {
    pub layout: GridLayout,
    pub particles: Particles,
    pub materials: Vec<MaterialParams>,
    pub boundary: Boundary,
    /// Speed above which the guard reports a runaway (m/s).
    pub max_speed: f32,
    /// Most substeps one frame may hold (the GPU sizes its per-substep buffers by it).
    pub max_substeps: u32,
    /// Tools of the scene (the GPU sizes its per-substep tool buffer by it).
    pub tool_count: usize,
    /// Whether a tool of the scene cuts (a slicer): the GPU then allocates, binds and steps
    /// the per-particle crack state (the CPU allocates it when the first cut happens).
    pub cutting: bool,
    /// How the GPU's P2G accumulates (the CPU ignores it).
    pub p2g: P2gAtomics,
    pub method: Method,
    /// Iteration settings, read when `method` is PB-MPM.
    pub pb_mpm: PbMpmParams,
    /// Newton and CG settings, read when `method` is implicit.
    pub implicit: ImplicitParams,
}

/// Most tools one scene may hold: per-tool impulses are reduced in fixed-size arrays so
/// that a substep never allocates.
pub const MAX_TOOLS: usize = 8;

/// Linear and angular impulse (N·s, N·m·s) a tool received during one substep, world frame,
/// angular part about the tool frame origin; for a gripper also the jaws' share and what
/// its grip measured (see [`crate::tools::grip`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ToolImpulse {
    pub linear: nalgebra::Vector3<f64>,
    pub angular: nalgebra::Vector3<f64>,
    /// Grid nodes this tool touched.
    pub contact_nodes: u32,
    /// Angular impulse on the jaw opening from contact with the jaws (N·m·s; positive
    /// pushes them apart).
    pub jaw_opening: f64,
    pub grip: GripSums,
}

/// Sums over the grid nodes a gripper's grip held (see [`crate::tools::grip`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GripSums {
    /// Momentum change across the jaw faces that holding them in full takes (N·s).
    pub required: nalgebra::Vector3<f64>,
    /// Pinched mass (kg) and its first moment about the hinge (kg·m).
    pub mass: f64,
    pub mass_lever: f64,
}

impl ToolImpulse {
    pub fn add(&mut self, other: &ToolImpulse) {
        self.linear += other.linear;
        self.angular += other.angular;
        self.contact_nodes += other.contact_nodes;
        self.jaw_opening += other.jaw_opening;
        self.grip.required += other.grip.required;
        self.grip.mass += other.grip.mass;
        self.grip.mass_lever += other.grip.mass_lever;
    }
}

/// What one substep reports back.
#[derive(Clone, Debug)]
pub struct SubstepStats {
    /// Impulse on each tool (index = tool index); entries past the scene's tool count are zero.
    pub tool_impulses: [ToolImpulse; MAX_TOOLS],
    /// Largest particle speed after the substep (m/s).
    pub max_speed: f32,
    /// Particles that reached the domain edge and were clamped back inside.
    pub clamped_particles: u32,
    /// First problem the guard found, if any. When set, the particle state is unusable.
    pub guard: Option<GuardEvent>,
    /// Newton and CG iterations of an implicit substep.
    pub solve: SolveCounts,
}
