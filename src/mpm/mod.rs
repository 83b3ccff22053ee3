//! Material Point Method: particle and grid state, materials, time step, guard, solvers.
//!
//! [`cpu`] is the reference solver (rayon); [`gpu`] implements the same math in WGSL and is
//! tested against it. This page is the method and how to choose it; cutting is in [`crack`],
//! tearing in [`damage`], stability in [`guard`], the tools in [`crate::tools`].
//!
//! # The method
//!
//! - **MLS-MPM** (seed 000 eqs. 1–10, seed 002 Algorithm 1): APIC transfers with quadratic
//!   B-splines, force and affine momentum fused in P2G, f32 state. Stress is computed as the
//!   Kirchhoff stress τ = P Fᵀ; for Neo-Hookean τ = μ(FFᵀ − I) + λ ln J · I.
//! - **Inverted or degenerate F**: Neo-Hookean's volumetric term uses max(J, 10⁻⁴), so a
//!   crushed or inverted particle feels a large finite pressure that pushes it back;
//!   fixed-corotated takes its rotation from an iteration that never divides by a singular
//!   value.
//! - **Time step**: dt ≤ cfl · dx / max(c_p, particle speed, tool speed), with the wave speed
//!   c_p = √((λ+2μ)/ρ); a frame is split into equal substeps under that bound.
//! - **PIC reference** (`method = "pic_mpm"`): MLS-MPM's forces and step with PIC velocity
//!   transfer: P2G carries m·v without APIC's affine momentum m·C·(xᵢ − xₚ) (C is still
//!   gathered for the F update). It conserves linear momentum but averages each cell's
//!   velocities, so rotation and shear motion dissipate: a block spun at 3 rad/s keeps 96.5 %
//!   of its angular momentum after 0.5 s with APIC and none with PIC (`tests/solver.rs`). It
//!   is the baseline APIC is measured against.
//! - **PB-MPM** (`method = "pb_mpm"`; Lewin 2024, seed 002 §III-C eqs. 13–16): each substep
//!   runs `iterations` cycles of {elastic constraint on each particle's affine velocity C →
//!   P2G of APIC momentum → grid update (gravity in the first cycle only, tools, table, walls)
//!   → G2P}, then moves particles and updates F once. The constraint pulls F* = (I + C·dt)F
//!   towards its rotation R: C ← C + relaxation·s·((R·F⁻¹ − I)/dt − C), with the XPBD weight
//!   s = (c_p·dt)² / ((c_p·dt)² + dx²/4), so E and ν enter only through c_p. Eq. 15's blend
//!   with the unit-volume F*/∛J is left at weight 0 (the reference code's elastic default;
//!   weighted by 1 − 2ν it let a 6 mm block sag 1.9 mm under gravity). Substeps are bound by
//!   advection only, so `dt` defaults to 1/240 s. Its stiffness comes from the iterations and
//!   the step, not from E: at 1/240 s a 5 kPa, 6 mm block sags 0.64 mm where linear elasticity
//!   says 0.02 mm. The tool impulses of every cycle are summed: APIC transfers and the
//!   constraint conserve momentum, so the sum is the momentum the tool exchanged (a block
//!   resting on a tool carries its weight to within 10⁻⁶, `tests/pbmpm.rs`).
//! - **Implicit** (`method = "implicit"`): backward Euler by Newton–CG, below.
//! - **Total Lagrangian MPM** (`method = "tl_mpm"`, [`cpu::tlmpm`]): the shape functions
//!   live on the rest configuration, so tissue pulled far past a cell per particle stays one
//!   piece, where the updated-Lagrangian methods part it by numerics (the default liver
//!   lifted 25 mm above the grasp: MLS-MPM tears a chunk away at 10–13 mm; `tl_mpm` holds it
//!   to the top with the wrench rising to 2.8 N, `config/default.toml`). Stretched 2× and
//!   3× (`bench accuracy`, a block 4 cells thick), its force stays within 8.1 % of the
//!   Neo-Hookean answer (−7.8 %, −8.1 %; −3.7 %, −4.0 % at 8 cells), where MLS-MPM's block
//!   parts and carries nothing (−100 %). Its cost:
//!   about twice MLS-MPM's time per substep on the CPU, and more substeps where the jaws
//!   squeeze the tissue (each substep is cut into ⌈1/σ_min(F)⌉ pieces, decided per frame,
//!   see [`stiffening`]). It runs on the CPU and the GPU with the same math
//!   (`tests/gpu_agreement.rs`), cuts nothing and does not tear.
//! - **Tools and contact** ([`crate::tools`]): signed distance fields evaluated per grid node
//!   inside each tool's bounding box, the nearest tool owning a node. Approaching nodes lose
//!   the normal component of their velocity relative to the tool, Coulomb friction reduces the
//!   tangential one and `drag` scales it (seed 002's c_d = 1 − drag); separating nodes are
//!   untouched. The momentum each tool takes out of the grid per substep, summed to force and
//!   torque about the tool origin and averaged over the frame, is its contact wrench.
//!
//! # The implicit solver
//!
//! Backward-Euler MLS-MPM as an energy minimisation (Gast et al. 2015). P2G carries momentum
//! and mass only; the end-of-step grid velocities v minimise
//!
//!   Φ(v) = Σᵢ ½ mᵢ |vᵢ − v*ᵢ|² + Σₚ V₀ Ψ(Fₚ(v)),   Fₚ(v) = (I + dt Σᵢ vᵢ ∇wᵢₚᵀ) Fₚ,
//!
//! with MLS-MPM's kernel gradient, so its stationary point is the implicit Euler update with
//! the same forces the explicit P2G fuses.
//!
//! - **Newton on v**, each step solved by preconditioned conjugate gradients, matrix-free: a
//!   Hessian product is a gather of each particle's velocity gradient, its 9×9 stiffness
//!   V₀dt²Fₙᵀ(∂P/∂F)Fₙ, and a scatter (the shapes of G2P and P2G). ∂P/∂F is analytic for both
//!   models and made positive semi-definite per particle (a Cholesky test, then eigenvalues
//!   clamped at zero), so the Hessian is SPD. A backtracking line search on Φ refuses any step
//!   that would crush a particle to J ≤ 10⁻⁴.
//! - **Preconditioner**: each node's 3×3 block of the Hessian (`block_jacobi`, default) or
//!   the node mass (`mass`). On the 1 MPa, ν 0.45 block's first frame-long step block Jacobi
//!   takes 83 CG iterations where the mass takes 119 (`cargo test --release --lib
//!   block_jacobi_needs_fewer_cg_iterations_than_the_mass -- --nocapture`). At ν 0.49 the
//!   volumetric stiffness λ = 49 μ couples nodes, which no block-diagonal preconditioner
//!   sees; a multilevel preconditioner is what stiff tissue needs next.
//! - **Inexact Newton**: CG stops at η·‖∇Φ‖ with Eisenstat–Walker's forcing term (choice 2,
//!   γ = 0.9, α = 2, safeguarded), η at most `solver.cg_tolerance` (default 0.1) and never
//!   tighter than needed to bring the residual to half the Newton goal.
//! - **Warm start**: the lowest Φ of v* (the last step's velocities as the particles carried
//!   them), rest, and v* plus the last step's elastic change v − v*. On a resting body the
//!   elastic forces cancel gravity again, so that start lies within a fraction of a percent of
//!   a gravity impulse from the answer.
//! - **Stopping**: the residual below `newton_tolerance` (1e-3) of the larger of the first
//!   residual and the momentum gravity gives the nodes in one step (a close warm start does
//!   not make the target tighter), at most `newton_iterations` (8). A step whose Newton
//!   decrement is below Φ's f32 rounding, which the line search cannot judge, is taken whole
//!   and ends the solve. CG runs at most `cg_iterations` (200). Newton and CG counts are
//!   reported per frame (`FrameReport::solve`; `bench` columns Newton/frame and CG/frame).
//! - **Constraints inside the solve** (projected CG): grips, sticky tools and a bonded table
//!   prescribe all three velocity components of a node; an approaching node in Coulomb
//!   contact, on a resting table or at a wall its normal component. The constraints are
//!   chosen from v*, and then the active set grows: after Newton converges, every node the
//!   solution moves into a tool, the table or a wall gets that component prescribed, the
//!   iterate is projected and Newton resumes, at most 3 rounds a substep. Without it, a stiff
//!   block that gravity pulls down faster than a tool descends has the nodes under the tool
//!   leaving it in v*, free in the solve, then pushed by contact after it: G2P deforms the
//!   particles by velocities the solve never balanced and the tool's impulse does not pay
//!   for the energy stored (`a_tool_slower_than_gravity_pays_for_the_energy_it_stores`).
//! - **Friction inside the solve**, as IPC's lagged friction (Li et al. 2020): a node with one
//!   prescribed direction n adds to Φ
//!
//!     D(v) = λ f₀(|u|) + ½ κ |u|²,   u = (I − nnᵀ)(v − w),
//!
//!   with w the surface's velocity, λ = μ·N from the normal impulse N the surface gave the
//!   node in the last substep, f₀ the magnitude smoothed below the slip threshold
//!   ε = 10⁻²·dx/dt (a node held by static friction creeps at most a hundredth of a cell a
//!   step) and κ = m·drag/(1 − drag). Its gradient is Coulomb's force −λû while the node
//!   slides and its Hessian is positive semi-definite, so Newton–CG and the preconditioner
//!   take it as they are. Friction applied after the solve instead changes a velocity field
//!   whose elastic response the solve never saw, and the capsule drags of `stress` gained
//!   energy. A node two surfaces act on, a curve tool or a drag of 1 keeps the explicit rules.
//! - **Substep**: bound by advection only, |v|·dt + ½|g|·dt² ≤ cfl·dx (gravity's share keeps
//!   a freely falling first iterate from crushing the cells above a fixed support): one
//!   substep per 60 Hz frame where that allows.
//! - **Damping**: backward Euler keeps 1/√(1 + (ωdt)²) of an oscillation's amplitude per step;
//!   the inexact solve damps less than the exact one (the bar keeps 0.91 of its velocity
//!   amplitude per period where exact backward Euler predicts 0.82).
//! - **Backends**: the same solve runs in WGSL (see [`gpu`]) where the adapter has f32 atomics
//!   and the scene does not cut; elsewhere `backend = "gpu"` is refused with the reason and
//!   `auto` runs it on the CPU with a log line. Tearing is refused with it (`check`).
//!
//! Accuracy against explicit MLS-MPM at the same resolution, one substep per frame
//! (`cargo test --release --test implicit -- --nocapture --test-threads 1`):
//!
//! | scene | explicit MLS-MPM error | implicit error | implicit Newton / CG over the run |
//! |---|---|---|---|
//! | bar period, 4 cells | +2.66 % | +2.78 % | 129 / 496 |
//! | 1.3× stretch force, 4 cells | −7.22 % | −7.24 % | 260 / 2150 |
//! | Hertz RMS force, R = 3 dx | +22.10 % | +28.57 % | 97 / 1337 |
//!
//! Stiff tissue (`cargo run --release -- bench stiff`: ν 0.49, loaded over 0.25 s at 120
//! frames a second, explicit MLS-MPM at CFL 0.5 against implicit on the same scene; this
//! 2-core machine shared with builds, so compare within the table):
//!
//! | stiff scene | explicit wall (s) | explicit error | implicit wall (s) | implicit error | speed-up | Newton / CG per frame |
//! |---|---|---|---|---|---|---|
//! | hertz-stiff-60kPa | 41.96 | +25.13 % | 62.52 | +28.81 % | 0.7× | 3.1 / 209 |
//! | stretch-stiff-60kPa | 23.48 | −3.75 % | 10.63 | −3.41 % | 2.2× | 3.0 / 198 |
//! | hertz-stiff-1MPa | 193.11 | +29.50 % | 63.04 | +28.98 % | 3.1× | 2.9 / 162 |
//! | stretch-stiff-1MPa | 94.67 | −3.84 % | 11.64 | −3.43 % | 8.1× | 3.0 / 220 |
//!
//! The cost is in the conjugate gradients: each CG iteration is one P2G/G2P-shaped pass, about
//! an explicit substep's CPU cost, and a stiff frame takes 160–220 of them. A profile of the
//! 1 MPa, ν 0.49 sphere (`perf record` of `stress --only "sphere, E 1 MPa ν 0.49"`) puts
//! three quarters of the time in the particle loop of the Hessian products and 7 % in the PSD
//! projection: fewer CG iterations, not faster ones, are where the time is.
//!
//! # Choosing a method: accuracy and speed
//!
//! `cargo run --release -- bench --quick --backends cpu` (CI runs it through
//! `tests/bench_quick.rs`) sweeps the analytic scenes of [`crate::validation`] at their
//! coarse resolutions with two MLS-MPM CFL settings, one PB-MPM setting (5 iterations,
//! substeps of 3× MLS-MPM's CFL-0.5 bound) and the PIC reference; `bench` without `--quick`
//! adds finer resolutions, CFL 0.25 and more PB-MPM settings. Every row goes through the same
//! `World` as a scene file, and every row has an error bound the command enforces. On this
//! 2-core machine, CPU backend:
//!
//! | scene | resolution | solver | step | particles | error | wall (s) | particle-substeps/s |
//! |---|---|---|---|---|---|---|---|
//! | hertz | R = 4 dx | MLS-MPM | CFL 0.5 | 55296 | +15.40% | 1.19 | 13.96M |
//! | hertz | R = 4 dx | MLS-MPM | CFL 0.9 | 55296 | +18.01% | 0.81 | 13.72M |
//! | hertz | R = 4 dx | PB-MPM | 5 it; dt 3x MLS | 55296 | +8.22% | 9.26 | 0.60M |
//! | hertz | R = 4 dx | PIC-MPM | CFL 0.5 | 55296 | +12.75% | 1.22 | 13.59M |
//! | bar | h = 4 dx | MLS-MPM | CFL 0.5 | 5632 | +2.66% | 0.44 | 11.89M |
//! | bar | h = 4 dx | MLS-MPM | CFL 0.9 | 5632 | +2.68% | 0.22 | 11.63M |
//! | bar | h = 4 dx | PB-MPM | 5 it; dt 3x MLS | 5632 | -30.79% | 1.51 | 1.16M |
//! | bar | h = 4 dx | PIC-MPM | CFL 0.5 | 5632 | +2.64% | 0.43 | 12.04M |
//! | stretch | h = 4 dx | MLS-MPM | CFL 0.5 | 3328 | -7.22% | 0.49 | 10.90M |
//! | stretch | h = 4 dx | MLS-MPM | CFL 0.9 | 3328 | -7.21% | 0.30 | 10.93M |
//! | stretch | h = 4 dx | PB-MPM | 5 it; dt 3x MLS | 3328 | -16.07% | 2.08 | 0.96M |
//! | stretch | h = 4 dx | PIC-MPM | CFL 0.5 | 3328 | -7.24% | 0.48 | 10.99M |
//!
//! - **MLS-MPM**: at a fixed resolution the CFL number barely changes the error (bar +2.66 %
//!   against +2.68 %) while it sets the cost, so CFL 0.9 is the setting for speed; resolution
//!   buys accuracy (the full sweep: Hertz 15.4 % at R = 4 dx, 7.5 % at 6 dx). Contact with a
//!   moving tool prefers the smaller step (Hertz +18.0 % at CFL 0.9).
//! - **PB-MPM** is on no analytic scene's Pareto front: on these soft materials MLS-MPM's step
//!   is already within 3× of a frame, and a PB-MPM cycle costs about 4.6 MLS-MPM substeps on
//!   the CPU (a polar decomposition of every particle in every cycle). Its stiffness is set by
//!   the iterations and the step, not by E: more cycles or shorter steps make it stiffer
//!   (the full sweep's Hertz at 20 iterations: +324 % to +644 %), longer steps softer, and its
//!   errors do not shrink with resolution.
//! - **Where PB-MPM wins: stiff or nearly incompressible tissue at frame rate.** MLS-MPM's
//!   step shrinks with c_p; PB-MPM's does not. `run --headless --seconds 1 --backend cpu` of
//!   the default scene, and of the same scene with muscle:
//!
//!   | tissue | method | substeps per 60 Hz frame | wall for 1 s simulated | centre of mass z (rest 14.0 mm) |
//!   |---|---|---|---|---|
//!   | liver 5.4 kPa, ν 0.45 | MLS-MPM, CFL 0.5 | 74 | 26.0 s | 13.8 mm |
//!   | liver 5.4 kPa, ν 0.45 | PB-MPM, 1/240 s, 5 cycles | 4 | 16.7 s | 12.1 mm |
//!   | muscle 62 kPa, ν 0.49 | MLS-MPM, CFL 0.5 | 528 | 179.0 s | 13.9 mm |
//!   | muscle 62 kPa, ν 0.49 | PB-MPM, 1/240 s, 5 cycles | 4 | 16.3 s | 12.1 mm |
//!
//!   PB-MPM runs the stiff tissue 11× faster at a cost that does not depend on the material,
//!   but it behaves the same for liver and muscle: at 1/240 s the constraint is at its
//!   iteration-bound stiffness for both.
//! - **PIC** errs no more than MLS-MPM on these quasi-static or smooth scenes, at the same cost,
//!   but loses rotation, which grasping and twisting tissue needs.
//! - **Implicit** gives the material's stiffness at one substep per frame: 2–8× faster than
//!   MLS-MPM on the stiff stretch scenes above, slower on the 60 kPa Hertz scene, and on a GPU
//!   the wrong choice for soft tissue (see [`gpu`]).
//!
//! | use | soft tissue (≲ 10 kPa) | stiff or nearly incompressible tissue (≳ 50 kPa, ν ≥ 0.49) |
//! |---|---|---|
//! | teleoperation | MLS-MPM, `cfl = 0.9`, GPU backend where there is one, `[sleep]` on | PB-MPM with its defaults where a fixed cost per frame matters more than the material's stiffness (tune `iterations` and `dt` by feel, not by E); implicit where a frame's solve fits the frame |
//! | data generation | MLS-MPM, `cfl = 0.9`, `run --headless` at the resolution the labels need | implicit; PB-MPM only where labels do not depend on force or deformation magnitudes |
//! | accuracy studies | MLS-MPM, `cfl = 0.5`, ≥ 6 cells across the contact radius or thickness; check with `bench` at two resolutions that the error shrinks | MLS-MPM or implicit (implicit adds numerical damping to dynamics); not PB-MPM |
//!
//! Interactive sizes: the tissue ~4 cells across its thinnest part and tools at least two
//! cells thick (`check` refuses thinner solids: a thinner solid constrains too few of a
//! particle's 27 stencil nodes and tissue flows through it).

pub mod backend;
pub mod cpu;
pub mod crack;
pub mod damage;
pub mod frame_plan;
pub mod gpu;
pub mod grid;
pub mod guard;
pub mod implicit_params;
pub mod kernel;
pub mod material;
pub mod particles;
pub mod pieces;
pub mod split;
pub mod stiffening;
pub mod timestep;

pub use crate::math::{IVec3, Mat3, Vec3};

use serde::{Deserialize, Serialize};

pub use backend::P2gAtomics;
pub use grid::{Boundary, GridLayout, TableHold};
pub use guard::{GuardEvent, GuardKind};
pub use implicit_params::{ImplicitParams, Preconditioner, SolveCounts};
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
    /// Total Lagrangian MPM (de Vaucorbeil et al. 2020): shape functions on the rest
    /// configuration, so tissue pulled however far stays one piece; explicit, substeps as
    /// MLS-MPM's. CPU and GPU; tears with a toughness, does not cut (see [`cpu::tlmpm`]).
    TlMpm,
}

impl Method {
    /// The method's name as the scene key `solver.method` spells it.
    pub fn key(&self) -> &'static str {
        match self {
            Method::MlsMpm => "mls_mpm",
            Method::PbMpm => "pb_mpm",
            Method::PicMpm => "pic_mpm",
            Method::Implicit => "implicit",
            Method::TlMpm => "tl_mpm",
        }
    }

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

/// What a solver is built from: the same for the CPU and the GPU backend.
pub struct SolverSetup {
    /// The grid's placement and size.
    pub layout: GridLayout,
    /// The tissue's particles at the start.
    pub particles: Particles,
    /// The material table `Particles::material` indexes.
    pub materials: Vec<MaterialParams>,
    /// The table and the domain walls.
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
    /// The MPM formulation.
    pub method: Method,
    /// Iteration settings, read when `method` is PB-MPM.
    pub pb_mpm: PbMpmParams,
    /// Newton and CG settings, read when `method` is implicit.
    pub implicit: ImplicitParams,
    /// When stretched particles split (see [`split`]).
    pub split: split::SplitParams,
}

/// Most tools one scene may hold: per-tool impulses are reduced in fixed-size arrays so
/// that a substep never allocates.
pub const MAX_TOOLS: usize = 8;

/// Linear and angular impulse (N·s, N·m·s) a tool received during one substep, world frame,
/// angular part about the tool frame origin; for a gripper also the jaws' share and what
/// its grip measured (see [`crate::tools::grip`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ToolImpulse {
    /// Linear impulse, world frame, N·s.
    pub linear: nalgebra::Vector3<f64>,
    /// Angular impulse about the tool frame origin, world frame, N·m·s.
    pub angular: nalgebra::Vector3<f64>,
    /// Grid nodes this tool touched.
    pub contact_nodes: u32,
    /// Mass of the grid nodes this tool touched, kg (summed over substeps like the
    /// impulse): the tissue a free needle moves against (see [`crate::world::needle_body`]).
    pub contact_mass: f64,
    /// Their moment of inertia about the tool frame origin, Σ m |x − origin|², kg·m²
    /// (summed over substeps likewise).
    pub contact_inertia: f64,
    /// Angular impulse on the jaw opening from contact with the jaws (N·m·s; positive
    /// pushes them apart).
    pub jaw_opening: f64,
    /// What the grip held (grippers only).
    pub grip: GripSums,
}

/// Sums over the grid nodes a gripper's grip held (see [`crate::tools::grip`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GripSums {
    /// Momentum change across the jaw faces that holding them in full takes (N·s).
    pub required: nalgebra::Vector3<f64>,
    /// Pinched mass (kg) and its first moment about the hinge (kg·m).
    pub mass: f64,
    /// First moment of the pinched mass about the hinge, kg·m.
    pub mass_lever: f64,
}

impl ToolImpulse {
    /// Adds another substep's impulse to this one.
    pub fn add(&mut self, other: &ToolImpulse) {
        self.linear += other.linear;
        self.angular += other.angular;
        self.contact_nodes += other.contact_nodes;
        self.contact_mass += other.contact_mass;
        self.contact_inertia += other.contact_inertia;
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
