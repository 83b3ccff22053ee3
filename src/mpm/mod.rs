//! Material Point Method: particle and grid state, materials, time step, guard, solvers.
//!
//! `cpu` is the reference solver (rayon); every other backend implements the same math.

pub mod backend;
pub mod cpu;
pub mod gpu;
pub mod grid;
pub mod guard;
pub mod kernel;
pub mod material;
pub mod particles;
pub mod timestep;

pub type Vec3 = nalgebra::Vector3<f32>;
pub type IVec3 = nalgebra::Vector3<i32>;
pub type Mat3 = nalgebra::Matrix3<f32>;

pub use grid::{Boundary, GridLayout, TableHold};
pub use guard::{GuardEvent, GuardKind};
pub use material::{Lame, MaterialModel};
pub use particles::{MaterialParams, Particles};

/// Most tools one scene may hold: per-tool impulses are reduced in fixed-size arrays so
/// that a substep never allocates.
pub const MAX_TOOLS: usize = 8;

/// Linear and angular impulse (N·s, N·m·s) a tool received during one substep, world frame,
/// angular part about the tool frame origin.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ToolImpulse {
    pub linear: nalgebra::Vector3<f64>,
    pub angular: nalgebra::Vector3<f64>,
    /// Grid nodes this tool touched.
    pub contact_nodes: u32,
}

impl ToolImpulse {
    pub fn add(&mut self, other: &ToolImpulse) {
        self.linear += other.linear;
        self.angular += other.angular;
        self.contact_nodes += other.contact_nodes;
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
}
