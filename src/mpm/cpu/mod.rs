//! Reference MLS-MPM solver on the CPU (rayon), f32 state.
//!
//! One substep (seed 002 Algorithm 1, seed 000 eqs. 1–10):
//! 1. bin particles into grid blocks (see `binning`), clear the blocks they touch;
//! 2. P2G: fused APIC momentum + MLS force transfer, block colours in turn;
//! 3. grid update: velocity, gravity, tool contact with momentum exchange, table, walls;
//! 4. G2P: velocity and affine velocity back to particles, advect, update F, guard; in
//!    groups of 4, 8 or 16 particles in SIMD lanes, the width the CPU offers chosen at run
//!    time (see [`lanes`]), equal to the one-particle reference to the bit.
//!
//! Work is proportional to the occupied blocks, not to the domain volume, and a substep
//! allocates nothing. PB-MPM (`pbmpm`) reuses these stages with its constraint iterations.
//!
//! **Parallel P2G without atomics or locks**: particles are binned each substep into 4³-node
//! grid blocks; blocks are coloured by coordinate parity, and a colour's blocks scatter
//! concurrently because their stencils never overlap. Only blocks particles touch are
//! cleared and updated: work follows the tissue, not the domain. The stencil loops are
//! functions of the crack side test (`scatter`, `gather`), so a particle no cut reaches takes
//! the loop without a test in it. The implicit solver ([`implicit`]) reuses the binning and
//! the block colours for its Hessian products.
//!
//! `cargo run --release -- bench throughput --frames 20` (this 2-core machine, AMD EPYC with
//! AVX-512, 24,000 particles on a 68³ grid, 2,100 substeps), the binary before the lane G2P
//! and the four-lane node arithmetic beside the one after, three runs each in turn: 9.77,
//! 10.22, 10.31 against 12.12, 12.62, 12.30 M particle-substeps/s (1.21×).
//! `bench throughput --transfer scalar,lanes4,lanes8,lanes16` times each G2P path.
//!
//! Scaling with cores: `bench throughput --frames 10 --threads 1,2` runs the same scene in a
//! pool of each size. On this 2-core machine, with a load of about 1.2 from other work:
//! 4.10 M particle-substeps/s on one thread, 6.78 M on two (1.65×, an efficiency of 0.83 a
//! thread; 1.44× in a 5-frame run just before). `--threads 1,2,4,8,16` gives the sweep on a
//! machine with the cores.

mod binning;
pub mod captured;
pub mod implicit;
pub mod lanes;
mod node_contact;
pub mod pbmpm;
pub mod thread_contact;
pub mod tl_node_sums;
pub mod tlmpm;

use super::grid::{Boundary, GridLayout, Node, NODES_PER_BLOCK};
use super::guard::GuardEvent;
use super::kernel::Stencil;
use super::material::kirchhoff_stress;
use super::{crack, damage};
use super::{
    ImplicitParams, Mat3, MaterialParams, Method, Particles, PbMpmParams, SolveCounts, SolverSetup,
    SubstepStats, ToolImpulse, Vec3, MAX_TOOLS,
};
use crate::tools::ToolKinematics;
use binning::Binning;
pub use lanes::TransferPath;
use node_contact::{apply_boundary, apply_tools, hold_node, record_contact, SolvedContact};
use rayon::prelude::*;

/// Inputs of one substep that change from substep to substep.
#[derive(Clone, Copy, Debug)]
pub struct SubstepInput<'a> {
    /// Substep length, s.
    pub dt: f32,
    /// Gravity, world frame, m/s².
    pub gravity: Vec3,
    /// The tools at this substep.
    pub tools: &'a [ToolKinematics],
}

/// The CPU MPM solver: particles, a sparse block grid, and the substep of the scene's method.
pub struct CpuSolver {
    /// The grid's placement and size.
    pub layout: GridLayout,
    /// The tissue's particles.
    pub particles: Particles,
    /// The material table `Particles::material` indexes.
    pub materials: Vec<MaterialParams>,
    /// The table and the domain walls.
    pub boundary: Boundary,
    /// Speed above which the guard reports a runaway (m/s).
    pub max_speed: f32,
    /// MLS-MPM, PB-MPM or the PIC reference.
    pub method: Method,
    /// PB-MPM's iteration settings.
    pub pb_mpm: PbMpmParams,
    /// The implicit solver's Newton and CG settings.
    pub implicit: ImplicitParams,
    /// When stretched particles split (see [`super::split`]), after each frame.
    pub split: super::split::SplitParams,
    /// Damage onset energy of each material (see [`damage::onsets`]); empty when nothing
    /// tears, and then the particles keep no damage either.
    damage_onset: Vec<f32>,
    grid: Vec<Node>,
    bins: Binning,
    /// The implicit solver's buffers, sized on its first substep.
    implicit_work: implicit::Workspace,
    /// The particles grippers hold, for total Lagrangian MPM's grip (see [`captured`]).
    captured: captured::Captured,
    /// Total Lagrangian MPM's rest configuration, built on its first substep.
    total_lagrangian: tlmpm::TotalLagrangian,
    /// Suture threads in the tissue (see [`thread_contact`]); the world loads them each
    /// frame and reads their impulses back.
    pub thread_contact: thread_contact::ThreadContact,
    /// How G2P (and total Lagrangian P2G's node sums) run: the widest SIMD lanes this CPU
    /// offers unless set otherwise (see [`lanes`], [`tl_node_sums`]); every path gives the
    /// same particles to the bit.
    pub transfer_path: TransferPath,
}

/// A raw pointer shared across rayon tasks that write provably disjoint elements.
#[derive(Clone, Copy)]
struct SharedMut<T>(*mut T);
// SAFETY: only used where the caller guarantees that concurrent tasks touch disjoint indices
// (block colouring in P2G, distinct blocks in clearing and the grid update).
unsafe impl<T: Send> Send for SharedMut<T> {}
unsafe impl<T: Send> Sync for SharedMut<T> {}

impl<T> SharedMut<T> {
    /// The pointer; a method, so that a closure using it captures the whole (Sync) wrapper.
    #[inline(always)]
    fn ptr(self) -> *mut T {
        self.0
    }
}

/// Storage offsets of the three stencil nodes along each axis; a node's index is
/// `ox[a] + oy[b] + oz[c]` because the blocked layout is separable.
#[inline(always)]
fn axis_offsets(layout: &GridLayout, base: super::IVec3) -> [[usize; 3]; 3] {
    let bs = super::grid::BLOCK;
    let stride = [
        layout.blocks[1] * layout.blocks[2] * NODES_PER_BLOCK,
        layout.blocks[2] * NODES_PER_BLOCK,
        NODES_PER_BLOCK,
    ];
    let local = [bs * bs, bs, 1];
    let mut out = [[0usize; 3]; 3];
    for axis in 0..3 {
        for (a, slot) in out[axis].iter_mut().enumerate() {
            let n = (base[axis] + a as i32) as usize;
            *slot = (n / bs) * stride[axis] + (n % bs) * local[axis];
        }
    }
    out
}

/// Four lanes added element-wise: a node's (momentum or velocity, mass) as one vector.
#[inline(always)]
fn add4(a: [f32; 4], b: [f32; 4]) -> [f32; 4] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3]]
}

/// Four lanes scaled by one weight.
#[inline(always)]
fn scale4(a: [f32; 4], w: f32) -> [f32; 4] {
    [a[0] * w, a[1] * w, a[2] * w, a[3] * w]
}

/// Spreads one particle's momentum over its stencil (P2G's inner loop): node i gets
/// w·(`momentum` + Q·i) and w·`m`, with Q·i = a·q₀ + b·q₁ + c·q₂ built up axis by axis so
/// that the inner loop only adds; nodes for which `across` holds (the far side of the
/// particle's crack) get nothing. Momentum and mass travel as one four-lane vector
/// (the mass lane's increments are zero), so a node costs one multiply and one add of a
/// vector register rather than three-component arithmetic the compiler must shuffle.
///
/// # Safety
/// Every node `offs` addresses must lie in `grid`, and no other thread may write them
/// meanwhile.
#[inline(always)]
unsafe fn scatter(
    grid: *mut [f32; 4],
    offs: &[[usize; 3]; 3],
    s: &Stencil,
    m: f32,
    momentum: Vec3,
    q: [Vec3; 3],
    across: impl Fn(usize, usize, usize) -> bool,
) {
    let [q0, q1, q2] = q.map(|q| [q.x, q.y, q.z, 0.0]);
    let mut qa = [momentum.x, momentum.y, momentum.z, m];
    for a in 0..3 {
        let mut qab = qa;
        for b in 0..3 {
            let wab = s.w[a].x * s.w[b].y;
            let mut qabc = qab;
            for c in 0..3 {
                if !across(a, b, c) {
                    let node = &mut *grid.add(offs[0][a] + offs[1][b] + offs[2][c]);
                    *node = add4(*node, scale4(qabc, wab * s.w[c].z));
                }
                qabc = add4(qabc, q2);
            }
            qab = add4(qab, q1);
        }
        qa = add4(qa, q0);
    }
}

/// Gathers one particle's stencil (G2P's inner loop): Σ w·v, and B's columns
/// [Σ a·wv, Σ b·wv, Σ c·wv]; at nodes for which `across` holds (the far side of the
/// particle's crack) the particle's own velocity `own` stands for the node's. Nodes are
/// read as four-lane vectors (the mass lane rides along unused), and the index factors
/// 0, 1, 2 are a skip, an add and a doubling, which are exact.
#[inline(always)]
fn gather(
    grid: &[[f32; 4]],
    offs: &[[usize; 3]; 3],
    s: &Stencil,
    own: Vec3,
    across: impl Fn(usize, usize, usize) -> bool,
) -> (Vec3, [Vec3; 3]) {
    let own = [own.x, own.y, own.z, 0.0];
    let (mut v, mut b0, mut b1, mut b2) = ([0.0f32; 4], [0.0f32; 4], [0.0f32; 4], [0.0f32; 4]);
    for a in 0..3 {
        let mut sum_a = [0.0f32; 4];
        for bb in 0..3 {
            let wab = s.w[a].x * s.w[bb].y;
            let mut sum_b = [0.0f32; 4];
            let mut wv = [[0.0f32; 4]; 3];
            for (c, wv) in wv.iter_mut().enumerate() {
                let node = if across(a, bb, c) {
                    own
                } else {
                    grid[offs[0][a] + offs[1][bb] + offs[2][c]]
                };
                *wv = scale4(node, wab * s.w[c].z);
                sum_b = add4(sum_b, *wv);
            }
            b2 = add4(add4(b2, wv[1]), add4(wv[2], wv[2]));
            sum_a = add4(sum_a, sum_b);
            if bb == 1 {
                b1 = add4(b1, sum_b);
            } else if bb == 2 {
                b1 = add4(b1, add4(sum_b, sum_b));
            }
        }
        v = add4(v, sum_a);
        if a == 1 {
            b0 = add4(b0, sum_a);
        } else if a == 2 {
            b0 = add4(b0, add4(sum_a, sum_a));
        }
    }
    let xyz = |l: [f32; 4]| Vec3::new(l[0], l[1], l[2]);
    (xyz(v), [xyz(b0), xyz(b1), xyz(b2)])
}

impl CpuSolver {
    /// A solver for `setup` (the method, materials and particles it names).
    pub fn new(setup: SolverSetup) -> Self {
        let layout = setup.layout;
        let bins = Binning::new(&layout, setup.particles.len());
        let damage_onset = damage::onsets(&setup).unwrap_or_default();
        let mut particles = setup.particles;
        if !damage_onset.is_empty() {
            particles.damage = vec![0.0; particles.len()];
        }
        CpuSolver {
            damage_onset,
            grid: vec![[0.0; 4]; layout.node_count()],
            layout,
            particles,
            materials: setup.materials,
            boundary: setup.boundary,
            max_speed: setup.max_speed,
            method: setup.method,
            pb_mpm: setup.pb_mpm,
            implicit: setup.implicit,
            split: setup.split,
            bins,
            implicit_work: implicit::Workspace::default(),
            captured: captured::Captured::default(),
            total_lagrangian: tlmpm::TotalLagrangian::default(),
            thread_contact: thread_contact::ThreadContact::default(),
            transfer_path: TransferPath::best(),
        }
    }

    /// Grid velocity and mass of node (i, j, k) after the last grid update.
    pub fn node(&self, i: usize, j: usize, k: usize) -> Node {
        self.grid[self.layout.node_index(i, j, k)]
    }

    /// Number of grid blocks the last substep worked on.
    pub fn active_blocks(&self) -> usize {
        self.bins.touched.len()
    }

    /// Total Lagrangian MPM's stiffening bounds of the particles now (see
    /// [`super::stiffening`]); only meaningful with `method = "tl_mpm"`.
    pub fn stiffening_bounds(&self) -> super::stiffening::StiffeningBounds {
        tlmpm::TotalLagrangian::stiffening_bounds(&self.particles, &self.captured)
    }

    /// Advances the particles by one substep of `input.dt` and reports impulses, speed and guard
    /// events.
    pub fn substep(&mut self, input: &SubstepInput) -> SubstepStats {
        self.substep_with_threads(input, None)
    }

    /// [`CpuSolver::substep`] with the threads loaded into `thread_contact` in the tissue,
    /// their rods stepped by `threads` inside the substep (see [`thread_contact`]); without
    /// a stepper the grid does not meet them.
    pub fn substep_with_threads(
        &mut self,
        input: &SubstepInput,
        threads: Option<&mut (dyn thread_contact::ThreadStepper + '_)>,
    ) -> SubstepStats {
        assert!(input.tools.len() <= MAX_TOOLS, "at most {MAX_TOOLS} tools");
        if self.method == Method::Implicit {
            // The implicit substep bins the particles itself: its marking tests them all.
            self.mark_cuts(input.tools, false);
            return self.implicit_substep(input);
        }
        if self.method == Method::TlMpm {
            let (tool_impulses, max_speed, clamped_particles, guard) =
                self.total_lagrangian.substep(
                    &self.layout,
                    &self.boundary,
                    &self.materials,
                    &self.damage_onset,
                    &mut self.particles,
                    &mut self.captured,
                    input.tools,
                    input.dt,
                    input.gravity,
                    self.max_speed,
                    self.transfer_path,
                );
            return SubstepStats {
                tool_impulses,
                max_speed,
                clamped_particles,
                guard,
                solve: SolveCounts::default(),
            };
        }
        self.bin_particles();
        self.mark_cuts(input.tools, true);
        if self.method == Method::PbMpm {
            return self.pb_substep(input, self.pb_mpm);
        }
        self.clear_touched_blocks();
        let stress_scale = -input.dt * 4.0 * self.layout.inv_dx * self.layout.inv_dx;
        self.particle_to_grid(Some(stress_scale), self.method.affine_transfer());
        let tool_impulses = self.update_grid(input);
        if let (false, Some(stepper)) = (self.thread_contact.is_empty(), threads) {
            let bins = &self.bins;
            self.thread_contact.apply(
                &self.layout,
                &self.boundary,
                &mut self.grid,
                &|b| bins.is_touched(b),
                input.dt,
                thread_contact::TissueLimits::new(&self.materials, self.layout.dx),
                stepper,
            );
        }
        let (max_speed, clamped_particles, guard) = self.grid_to_particle(input.dt, true);
        SubstepStats {
            tool_impulses,
            max_speed,
            clamped_particles,
            guard,
            solve: SolveCounts::default(),
        }
    }

    /// Cracks where a slicer's edge passes (see [`crack`]). The crack state is allocated
    /// when the edge first reaches a particle; without a slicer this costs one scan of the
    /// tools. With `binned` (the bins hold this substep's positions) only the particles of
    /// blocks a slicer's reach meets are tested, so a slicer far from the tissue costs a
    /// test per occupied block, and one cutting it the particles near its edge.
    fn mark_cuts(&mut self, tools: &[ToolKinematics], binned: bool) {
        if !crack::any_slicer(tools) {
            return;
        }
        let layout = self.layout;
        let reaches = crack::Reaches::new(tools, layout.dx);
        let bins = &self.bins;
        let near: Vec<&[u32]> = if binned {
            // A particle of block b has its stencil base in nodes 4b..4b+3 along each axis,
            // so it lies within cells 4b + [0.5, 4.5) of the origin; half a cell more
            // either side covers the base's truncation at the domain's low edge.
            let bs = super::grid::BLOCK as f32;
            bins.by_color
                .iter()
                .flatten()
                .map(|r| &bins.order[r.start as usize..r.end as usize])
                .filter(|ps| {
                    let key = bins.key[ps[0] as usize] as usize;
                    let b = Vec3::from(layout.block_coords(key).map(|c| c as f32));
                    let lo = layout.origin + b * (bs * layout.dx);
                    reaches.meet_box(lo, lo + Vec3::repeat((bs + 1.0) * layout.dx))
                })
                .collect()
        } else {
            Vec::new()
        };
        let parts = &mut self.particles;
        let x = &parts.x[..];
        if parts.crack.len() != parts.len() {
            let any = if binned {
                near.par_iter()
                    .any(|ps| ps.iter().any(|&p| reaches.passing(x[p as usize]).is_some()))
            } else {
                x.par_iter()
                    .with_min_len(1024)
                    .any(|&x| reaches.passing(x).is_some())
            };
            if !any {
                return;
            }
            parts.crack = vec![Vec3::zeros(); parts.len()];
        }
        if !binned {
            crack::mark(tools, x, &mut parts.crack, layout.dx);
            return;
        }
        let cracks = SharedMut(parts.crack.as_mut_ptr());
        near.par_iter().for_each(|ps| {
            for &p in ps.iter() {
                // SAFETY: each particle index appears once in the bins' order.
                let crack = unsafe { &mut *cracks.ptr().add(p as usize) };
                if *crack == Vec3::zeros() {
                    if let Some(new) = reaches.passing(x[p as usize]) {
                        *crack = new;
                    }
                }
            }
        });
    }

    /// Whether particles carry cracks: P2G and G2P then test each node against them; a
    /// scene that never cut takes the plain transfers.
    fn cutting(&self) -> bool {
        !self.particles.crack.is_empty()
    }

    fn bin_particles(&mut self) {
        let layout = self.layout;
        if self.bins.key.len() != self.particles.len() {
            // Splitting added particles (or a restore removed them) since the last substep.
            self.bins.resize(self.particles.len());
        }
        self.bins
            .key
            .par_iter_mut()
            .zip(self.particles.x.par_iter())
            .with_min_len(1024)
            .for_each(|(key, x)| {
                let base = Stencil::new((x - layout.origin) * layout.inv_dx).base;
                let bs = super::grid::BLOCK as i32;
                *key = layout.block_index(
                    (base.x / bs) as usize,
                    (base.y / bs) as usize,
                    (base.z / bs) as usize,
                ) as u32;
            });
        self.bins.rebuild(&layout);
    }

    fn clear_touched_blocks(&mut self) {
        let grid = SharedMut(self.grid.as_mut_ptr());
        self.bins
            .touched
            .par_iter()
            .with_min_len(16)
            .for_each(move |&b| {
                let grid = grid;
                // SAFETY: `touched` lists each block once, so tasks clear disjoint slices.
                let nodes = unsafe {
                    std::slice::from_raw_parts_mut(
                        grid.0.add(b as usize * NODES_PER_BLOCK),
                        NODES_PER_BLOCK,
                    )
                };
                nodes.fill([0.0; 4]);
            });
    }

    /// Scatters mass and momentum: with `stress_scale` (−dt·4/dx², MLS-MPM and PIC) the
    /// Kirchhoff stress's force is fused in, without it (PB-MPM) only momentum moves; with
    /// `affine` the momentum carries APIC's affine part m·C·(xᵢ − xₚ) (PIC without).
    fn particle_to_grid(&mut self, stress_scale: Option<f32>, affine: bool) {
        let tearing = !self.damage_onset.is_empty();
        match (self.cutting(), tearing) {
            (false, false) => self.transfer_to_grid::<false, false>(stress_scale, affine),
            (true, false) => self.transfer_to_grid::<true, false>(stress_scale, affine),
            (false, true) => self.transfer_to_grid::<false, true>(stress_scale, affine),
            (true, true) => self.transfer_to_grid::<true, true>(stress_scale, affine),
        }
    }

    /// P2G; with `CUT` a particle skips the nodes across its crack (the per-node test only
    /// where the crack passes through its stencil, see [`crack::StencilCut`]), with `TEAR`
    /// its damage follows its deformation and degrades its tension (see [`damage`]).
    fn transfer_to_grid<const CUT: bool, const TEAR: bool>(
        &mut self,
        stress_scale: Option<f32>,
        affine: bool,
    ) {
        let layout = self.layout;
        let onsets = &self.damage_onset[..];
        let damage = SharedMut(self.particles.damage.as_mut_ptr());
        let deformation = SharedMut(self.particles.f.as_mut_ptr());
        let parts = &self.particles;
        let materials = &self.materials[..];
        let order = &self.bins.order[..];
        let grid = SharedMut(self.grid.as_mut_ptr());
        // PB-MPM's cut particles take their affine momentum about their kept nodes (below).
        let about_kept = CUT && self.method == Method::PbMpm;
        for color in &self.bins.by_color {
            color.par_iter().for_each(move |range| {
                let grid = grid;
                for &p in &order[range.start as usize..range.end as usize] {
                    let p = p as usize;
                    let s = Stencil::new((parts.x[p] - layout.origin) * layout.inv_dx);
                    let mat = materials[parts.material[p] as usize];
                    let m = parts.mass[p];
                    // MLS-MPM: force and APIC affine momentum fused in one matrix (seed 002
                    // eq. 10), scaled by dx because stencil offsets are in grid units.
                    let mut q: Mat3 = if affine {
                        parts.c[p] * m
                    } else {
                        Mat3::zeros()
                    };
                    if let Some(scale) = stress_scale {
                        let tau = if TEAR {
                            let onset = onsets[parts.material[p] as usize];
                            // SAFETY: with TEAR there is one damage per particle, and P2G
                            // visits each particle once (and reads its F nowhere else).
                            let (d, f) = unsafe {
                                (&mut *damage.ptr().add(p), &mut *deformation.ptr().add(p))
                            };
                            damage::degraded_stress(&mat, onset, f, d)
                        } else {
                            kirchhoff_stress(mat.model, mat.lame, &parts.f[p])
                        };
                        q += tau * (scale * parts.volume0[p]);
                    }
                    let q = q * layout.dx;
                    let cut = if CUT {
                        crack::StencilCut::new(parts.crack[p], s.fx, layout.dx)
                    } else {
                        None
                    };
                    // Node momentum is w·(m v + Q (i − centre)); Q·i = a·Q₀ + b·Q₁ + c·Q₂ is
                    // built up axis by axis so that the inner loop only adds. The centre is
                    // the particle (fx), except for PB-MPM's cut particles: APIC's affine
                    // momentum m·C·(xᵢ − xₚ) sums to zero only over the whole stencil
                    // (Σ wᵢ(xᵢ − xₚ) = 0), so a P2G that skips the nodes across the crack
                    // writes a net m·C·Σ_kept wᵢ(xᵢ − xₚ) (kg·m/s), a push along the crack
                    // normal. PB-MPM's C is the constraint's (R·F⁻¹ − I)/dt, large at a
                    // substep of milliseconds, and that push slides the cut's faces through
                    // each other: the block stays one piece. About the kept nodes' weighted
                    // centre x̄ = Σ_kept wᵢxᵢ / Σ_kept wᵢ the affine part sums to zero over
                    // the nodes written, and the particle moves only m·v·Σ_kept wᵢ. MLS-MPM's
                    // Q also carries the stress force, whose moment about the particle is the
                    // force itself, and its C (the grid's velocity gradient) is small: it
                    // keeps the particle as centre.
                    let centre = match cut {
                        Some(cut) if about_kept => cut.kept_centre(&s),
                        _ => s.fx,
                    };
                    let momentum = parts.v[p] * m - q * centre;
                    let (q0, q1, q2) = (
                        q.column(0).into_owned(),
                        q.column(1).into_owned(),
                        q.column(2).into_owned(),
                    );
                    let offs = axis_offsets(&layout, s.base);
                    let grid = grid.0;
                    // SAFETY: blocks of one colour write disjoint node sets (see `binning`),
                    // and every node is inside the grid because particles are kept within
                    // `particle_bounds`. A particle whose stencil the crack does not cross
                    // takes the loop without the side test (monomorphised apart).
                    unsafe {
                        match cut {
                            Some(cut) => {
                                scatter(grid, &offs, &s, m, momentum, [q0, q1, q2], |a, b, c| {
                                    cut.across(a, b, c)
                                })
                            }
                            None => {
                                scatter(grid, &offs, &s, m, momentum, [q0, q1, q2], |_, _, _| false)
                            }
                        }
                    }
                }
            });
        }
    }

    fn update_grid(&mut self, input: &SubstepInput) -> [ToolImpulse; MAX_TOOLS] {
        self.update_grid_with(input, |_| None)
    }

    /// The grid update, where `solved` gives the velocity an implicit solve already settled
    /// a node in contact at (`SolvedContact`): such a node takes it, and the momentum it
    /// loses on the way is recorded as its tool's impulse.
    fn update_grid_with(
        &mut self,
        input: &SubstepInput,
        solved: impl Fn(usize) -> Option<SolvedContact> + Sync + Send,
    ) -> [ToolImpulse; MAX_TOOLS] {
        let layout = self.layout;
        let boundary = self.boundary;
        let grid = SharedMut(self.grid.as_mut_ptr());
        let dt = input.dt;
        let gravity = input.gravity;
        let tools = input.tools;
        self.bins
            .touched
            .par_iter()
            .with_min_len(4)
            .fold(
                || [ToolImpulse::default(); MAX_TOOLS],
                move |mut impulses, &b| {
                    let grid = grid;
                    // SAFETY: each block appears once in `touched`.
                    let nodes = unsafe {
                        std::slice::from_raw_parts_mut(
                            grid.0.add(b as usize * NODES_PER_BLOCK),
                            NODES_PER_BLOCK,
                        )
                    };
                    for (local, node) in nodes.iter_mut().enumerate() {
                        let m = node[3];
                        if m <= 0.0 {
                            continue;
                        }
                        let ijk = layout.node_coords(b as usize, local);
                        let x = layout.node_position(ijk);
                        let mut v = Vec3::new(node[0], node[1], node[2]) / m + gravity * dt;
                        v = if let Some(settled) = solved(b as usize * NODES_PER_BLOCK + local) {
                            if let Some(tool) = tools.get(settled.tool as usize) {
                                let dp = ((v - settled.velocity) * m).cast::<f64>();
                                let t = settled.tool as usize;
                                record_contact(tool, t, x, settled.part, m, dp, &mut impulses);
                            }
                            settled.velocity
                        } else {
                            match hold_node(tools, x, v, m, &mut impulses) {
                                Some(held) => held,
                                None => apply_tools(tools, x, v, m, &mut impulses),
                            }
                        };
                        v = apply_boundary(&layout, &boundary, ijk, x, v);
                        *node = [v.x, v.y, v.z, m];
                    }
                    impulses
                },
            )
            .reduce(
                || [ToolImpulse::default(); MAX_TOOLS],
                |mut a, b| {
                    for (a, b) in a.iter_mut().zip(&b) {
                        a.add(b);
                    }
                    a
                },
            )
    }

    /// Gathers velocity and affine velocity. With `integrate` the particles also move, F
    /// is updated and damping applies (the end of a substep); without it (PB-MPM's inner
    /// iterations) only v and C are stored.
    fn grid_to_particle(&mut self, dt: f32, integrate: bool) -> (f32, u32, Option<GuardEvent>) {
        if self.cutting() {
            self.transfer_to_particles::<true>(dt, integrate)
        } else {
            self.transfer_to_particles::<false>(dt, integrate)
        }
    }

    /// G2P; with `CUT` a particle reads its own velocity at the nodes across its crack (and
    /// its crack turns with it). Particles no crack can reach go through the lane path
    /// (`self.transfer_path`, see [`lanes`]) in whole groups; the rest of a chunk, and any
    /// particle the guard stops, through [`g2p_particle`], the reference.
    fn transfer_to_particles<const CUT: bool>(
        &mut self,
        dt: f32,
        integrate: bool,
    ) -> (f32, u32, Option<GuardEvent>) {
        let (lo, hi) = self.layout.particle_bounds();
        let step = G2pStep {
            grid: &self.grid,
            layout: self.layout,
            materials: &self.materials,
            dt,
            integrate,
            lo,
            hi,
            max_speed: self.max_speed,
        };
        let path = if CUT {
            TransferPath::Scalar
        } else {
            self.transfer_path
        };
        let cracks = SharedMut(self.particles.crack.as_mut_ptr());
        let tally = lanes::in_chunks(
            &mut self.particles,
            |_, chunk, tally, redo| lanes::gather_groups(path, &step, chunk, tally, redo),
            |p, particle, material, tally| {
                // SAFETY: with CUT the crack vector has one entry per particle, and G2P
                // visits each particle once.
                let crack = CUT.then(|| unsafe { &mut *cracks.ptr().add(p) });
                g2p_particle(&step, p, particle, material, crack, tally);
            },
        );
        (tally.max_speed, tally.clamped, tally.guard)
    }
}

/// What G2P reads that is the same for every particle of a substep.
pub(super) struct G2pStep<'a> {
    pub grid: &'a [[f32; 4]],
    pub layout: GridLayout,
    pub materials: &'a [MaterialParams],
    pub dt: f32,
    /// Move the particles and update F (the end of a substep), not only v and C.
    pub integrate: bool,
    /// `GridLayout::particle_bounds`, grid units.
    pub lo: Vec3,
    pub hi: Vec3,
    /// Speed above which the guard stops a particle, m/s.
    pub max_speed: f32,
}

/// G2P's running totals: the fastest particle stored, particles held at the domain's edge,
/// and the guard's first event.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct G2pTally {
    pub max_speed: f32,
    pub clamped: u32,
    pub guard: Option<GuardEvent>,
}

impl G2pTally {
    fn merge(a: Self, b: Self) -> Self {
        G2pTally {
            max_speed: a.max_speed.max(b.max_speed),
            clamped: a.clamped + b.clamped,
            guard: GuardEvent::first(a.guard, b.guard),
        }
    }
}

/// G2P of one particle, the reference path: gathers its stencil (reading its own velocity
/// across its crack, when it has one), and with `step.integrate` moves it, updates F and
/// damps. A particle whose result would be non-finite or faster than the guard allows is
/// left as it was and reported.
fn g2p_particle(
    step: &G2pStep,
    index: usize,
    (x, v_stored, c, f): lanes::ParticleMut,
    material: u16,
    crack: Option<&mut Vec3>,
    tally: &mut G2pTally,
) {
    let layout = &step.layout;
    let (dt, lo, hi) = (step.dt, step.lo, step.hi);
    let cracked = crack.as_ref().is_some_and(|c| **c != Vec3::zeros());
    let x0 = *x;
    let g = (x0 - layout.origin) * layout.inv_dx;
    let s = Stencil::new(g);
    let cut = match &crack {
        Some(crack) if cracked => crack::StencilCut::new(**crack, s.fx, layout.dx),
        _ => None,
    };
    let offs = axis_offsets(layout, s.base);
    // B = Σ w v (i − fx)ᵀ = [Σ a·wv, Σ b·wv, Σ c·wv] − v fxᵀ: the per-node work is a few
    // adds instead of an outer product. A particle whose stencil the crack does not cross
    // takes the loop without the side test (monomorphised apart).
    let (mut v, [b0, b1, b2]) = match cut {
        Some(cut) => gather(step.grid, &offs, &s, *v_stored, |a, b, c| {
            cut.across(a, b, c)
        }),
        None => gather(step.grid, &offs, &s, *v_stored, |_, _, _| false),
    };
    let b = Mat3::from_columns(&[b0, b1, b2]) - v * s.fx.transpose();
    // APIC: C = B·D⁻¹ with D = dx²/4·I; offsets are in grid units.
    let c_new = b * (4.0 * layout.inv_dx);
    let (mut g_new, mut f_new) = (g, *f);
    if step.integrate {
        g_new += v * (dt * layout.inv_dx);
        let inside = g_new.sup(&lo).inf(&hi);
        if inside != g_new {
            tally.clamped += 1;
            g_new = inside;
        }
        f_new = (Mat3::identity() + c_new * dt) * *f;
        let damping = step.materials[material as usize].damping;
        if damping > 0.0 {
            v /= 1.0 + damping * dt;
        }
    }
    let speed = v.norm();
    let finite = speed.is_finite()
        && c_new.iter().all(|e| e.is_finite())
        && f_new.iter().all(|e| e.is_finite())
        && g_new.iter().all(|e| e.is_finite());
    if !finite || speed > step.max_speed {
        let event = GuardEvent::stopped(finite, index, x0, speed);
        tally.guard = GuardEvent::first(tally.guard, Some(event));
        // Leave this particle as it was: nothing non-finite is stored.
        return;
    }
    tally.max_speed = tally.max_speed.max(speed);
    *v_stored = v;
    *c = c_new;
    if step.integrate {
        *x = layout.origin + g_new * layout.dx;
        *f = f_new;
        if let Some(crack) = crack.filter(|_| cracked) {
            *crack = crack::advect(*crack, &c_new, dt);
        }
    }
}
