//! Total Lagrangian MPM (de Vaucorbeil, Nguyen & Hutchinson 2020) on the CPU: the shape
//! functions are evaluated at the particles' rest positions on the grid of the rest
//! configuration, once, so two particles that share nodes at rest share them forever, and
//! the tissue cannot come apart by numerics however far it is pulled.
//!
//! The substep, with Xₚ the rest position, Pₚ the first Piola–Kirchhoff stress and V⁰ₚ the
//! rest volume:
//!
//! - P2G: mᵢ = Σ wᵢₚ mₚ (fixed), momentum Σ wᵢₚ mₚ vₚ, force fᵢ = −Σ V⁰ₚ Pₚ ∇Nᵢ(Xₚ) plus
//!   gravity, and the node's current place x̄ᵢ = Σ wᵢₚ mₚ xₚ / mᵢ;
//! - the grid update at x̄ᵢ: the grip, the tools' contact and the domain walls as the
//!   updated-Lagrangian solver applies them at a node's grid position (a reference node
//!   moves with the material it carries, so contact asks where it is now); the bonded
//!   table holds the nodes whose rest position is on it;
//! - G2P: vₚ by FLIP (0.99) blended with PIC, xₚ += dt Σ wᵢₚ vᵢ, and
//!   Fₚ += dt Σ vᵢ ⊗ ∇Nᵢ(Xₚ): F comes from the rest configuration's gradients, never from
//!   a stencil that has moved.
//!
//! - Stability: each substep is cut into as many pieces as the tissue's stiffening asks
//!   (see [`crate::mpm::stiffening`]); the backend cuts the frame's plan, so a call here
//!   is one step.
//!
//! Measured on `config/default.toml` (the default liver, lifted 25 mm above the grasp,
//! `tests/deep_lift.rs`): one piece to the top and after the release, |F_z| rising every
//! 0.1 s of the lift from 0.39 to 2.78 N, the top of the liver at 23.5 mm at rest, 48.6 mm
//! lifted and back at 23.7 mm 0.8 s after the jaws open. MLS-MPM on the same lift tears a
//! chunk away between 10.4 and 12.9 mm (0.91 N falling to 0.014 N; `run --headless
//! --backend cpu --print-every 6` on the scene with `method = "mls_mpm"`).
//!
//! Speed on the CPU: P2G computes each particle's share once (one 64-byte
//! `Source`), then each node sums its rest stencil's particles in vector
//! registers (see [`tl_node_sums`]); the nodes are stored compactly in the order of
//! `active` (the default scene's few thousand stay in cache), G2P runs in SIMD lanes
//! through the cached `stencil_nodes` (108 bytes a particle; see [`super::lanes`]), and
//! the grid update runs in parallel over chunks of nodes. Every width gives the same
//! particles to the bit. Measured on a 2-core Intel Xeon with AVX-512, the build before
//! the vector node sums beside the one after, in turn: `bench throughput --method tl_mpm
//! --frames 10` 6.31 and 6.35 against 8.37 and 8.24 M particle-substeps/s (1.31×);
//! `run --headless --scene config/default.toml --seconds 0.5` 10.78 and 11.06 s against
//! 8.19 and 8.58 s wall (real-time factor 0.046 → 0.060), and 13.66 s for the build
//! before G2P's lanes.
//!
//! Tearing: a material with a `toughness` tears as under the updated-Lagrangian methods
//! (see [`damage`]): the particle's damage follows its deformation and degrades the
//! tension in its `Source`, and a torn particle's F keeps only its compression. Torn
//! particles carry no tension, so once a band of them has torn through (see below) the
//! material on either side moves apart however far the pull goes, and `World::pieces`
//! links only the particles that are not torn, on the rest configuration. Measured on
//! `config/default.toml` with a toughness (`tests/deep_lift.rs`): the same 25 mm lift
//! pulls a chunk out around the jaws, two pieces at the top, the force at its peak
//! 0.612 N with G_c = 7.5 J/m² and 1.201 N with 30 J/m² (1.96×, where the crack band's
//! energy-density onset Y₀ = G_c/(2h) predicts √4 = 2); `config/tearing.toml` run
//! headless with `method = "tl_mpm"` ends in two pieces as under MLS-MPM, its highest
//! particle 21.3 mm up against MLS-MPM's 22.1 mm. The GPU tears the same particles
//! (`tests/tearing.rs`).
//!
//! Two particles that share a node at rest stay coupled through it, torn or not: the
//! material on either side of a tear parts only where the torn band is as wide as the
//! stencil (3 cells) less one particle spacing, 2.5 cells at two particles a cell. That is
//! this method's crack band ([`damage::crack_band`]): the damage onset Y₀ = G_c/(2h) takes
//! h = 2.5·dx, so that a unit area of tear dissipates G_c. The trouser specimen of
//! `tests/tearing.rs` (dx 1 mm, the slit pre-torn, the toughness on a line 3 cells wide):
//! each leg pulls 2.74 / 2.86 × G_c·t/2 and the damage law takes 0.87 G_c per unit area of
//! tear (MLS-MPM, whose crack needs no band: 4.1 ×); with a one-cell band, as MLS-MPM's,
//! it took 5.2 × and 2.28 G_c. As the legs soften (E from 250 to 62.5 kPa) the force tends
//! linearly to 1.67 × G_c·t/2 (MLS-MPM: 0.86 ×), the damage law taking 0.87–1.10 G_c per
//! unit area throughout: the rest is strain energy the band's neighbours hold through
//! the nodes they share with it until it has torn through. A line 1 cell wide cannot
//! part the legs: 30.7 × G_c·t/2.
//! Nodes split across a tear by the damage field's gradient (Homel & Herbold 2017) would
//! let a one-cell band part too; that is not built.
//!
//! What it does not do: cut (a crack would have to be carried back to the rest
//! configuration); contact between separate pieces of tissue is not seen (their nodes
//! never meet). The GPU runs the same math (`mpm::gpu`'s `tlmpm`).
//!
//! Resolution-independent under the jaws: the default liver's half-size copy (20 × 20 ×
//! 10 mm, the same grasp 5 mm deep, the jaws closing from 50°, a 25 mm lift over 1 s)
//! pulls 1.68 N halfway up and 3.00 N at the top at dx 2 mm (4,000 particles), 1.96 N and
//! 3.26 N at dx 1 mm (32,000 particles): 14 % and 8 % apart (`tests/deep_lift.rs`). That
//! takes the grip holding from the moment the tips come within a cell, before the jaws
//! stop (see [`crate::tools::grip`]): jaws that must first stop crush the tissue between
//! them at dx 1 mm, and it ran away at 11.8 m/s.

use super::super::damage;
use super::super::grid::{Boundary, GridLayout, TableHold, WALL_NODES};
use super::super::guard::GuardEvent;
use super::super::kernel::Stencil;
use super::super::material::kirchhoff_stress;
use super::super::particles::Particles;
use super::super::MaterialParams;
use super::super::{Mat3, ToolImpulse, Vec3, MAX_TOOLS};
use super::captured::{self, Captured};
use super::node_contact::apply_tools;
use super::tl_node_sums::{self, Entry, NodeSums, Source, Sum};
use super::{lanes, G2pTally, TransferPath};
use crate::mpm::stiffening::{inverse_stretch_bound, StiffeningBounds};
use crate::tools::{contact, ToolKinematics};
use rayon::prelude::*;

/// FLIP's share of the particle velocity update (the rest is PIC), as the paper uses.
pub(super) const FLIP: f32 = 0.99;

/// The rest configuration and the grid on it.
#[derive(Default)]
pub(super) struct TotalLagrangian {
    /// Rest positions.
    rest: Vec<Vec3>,
    /// The nodes with mass at rest (storage indices); the node arrays below are indexed by
    /// the place `k` of a node in this list, so they are compact and stay in cache.
    active: Vec<u32>,
    /// Node mass (kg), fixed.
    mass: Vec<f32>,
    /// For each node, its particles and their weight times mass and weight gradient (grid
    /// units) at rest: `entries[starts[k]..starts[k + 1]]` for `active[k]`. P2G gathers
    /// along it, in parallel over nodes and in a fixed order (the result does not depend on
    /// the thread count).
    starts: Vec<u32>,
    entries: Vec<Entry>,
    /// For each particle, the place in `active` of each node of its rest stencil, in
    /// [`for_stencil`]'s order (108 bytes a particle): G2P reads the compact node arrays
    /// through it instead of locating the nodes again every substep.
    stencil_nodes: Vec<[u32; 27]>,
    /// Per particle this substep, what the nodes gather from it, in one cache line.
    sources: Vec<Source>,
    /// Per node this substep: the velocity after the grid update, and its change there;
    /// one more, always zero, for the stencil nodes without mass, and another that the lane
    /// loader's reads past the last node land in.
    velocity: Vec<NodeVelocity>,
    /// Per chunk of [`CHUNK`] nodes, the tools' impulses of its grid update; summed in
    /// chunk order, so the sum does not depend on the thread count.
    chunk_impulses: Vec<[ToolImpulse; MAX_TOOLS]>,
}

/// Nodes per parallel task of the grid update.
const CHUNK: usize = 256;

/// A node's velocity after the grid update and its change in the grid update and P2G's
/// forces (what FLIP adds to a particle).
#[derive(Clone, Copy, Default)]
#[repr(C)]
pub(super) struct NodeVelocity {
    pub after: Vec3,
    pub change: Vec3,
}

/// Quadratic B-spline weight derivatives along one axis (grid units), matching
/// [`Stencil`]'s weights.
#[inline(always)]
fn weight_derivatives(fx: Vec3) -> [Vec3; 3] {
    [
        (fx - Vec3::repeat(1.5)),
        (fx - Vec3::repeat(1.0)) * -2.0,
        (fx - Vec3::repeat(0.5)),
    ]
}

impl TotalLagrangian {
    /// Takes the particles' current state as the rest configuration (on the first substep,
    /// and again when particles are added).
    fn ensure_rest(&mut self, layout: &GridLayout, particles: &Particles) {
        if self.rest.len() == particles.len() {
            return;
        }
        self.rest = particles.x.clone();
        let n = layout.node_count();
        let mut mass = vec![0.0f32; n];
        let mut by_node: Vec<Vec<Entry>> = vec![Vec::new(); n];
        for (p, x) in self.rest.iter().enumerate() {
            let s = Stencil::new((x - layout.origin) * layout.inv_dx);
            for_stencil(layout, &s, |node, w, grad| {
                mass[node] += w * particles.mass[p];
                by_node[node].push(Entry {
                    particle: p as u32,
                    weighted_mass: w * particles.mass[p],
                    grad: grad.into(),
                });
            });
        }
        self.active = (0..n as u32).filter(|&i| mass[i as usize] > 0.0).collect();
        self.mass = self.active.iter().map(|&i| mass[i as usize]).collect();
        let mut place = vec![u32::MAX; n];
        self.starts = Vec::with_capacity(self.active.len() + 1);
        self.entries.clear();
        for (k, &i) in self.active.iter().enumerate() {
            place[i as usize] = k as u32;
            self.starts.push(self.entries.len() as u32);
            self.entries.extend_from_slice(&by_node[i as usize]);
        }
        self.starts.push(self.entries.len() as u32);
        // A stencil node where the particle's weight is zero may carry no mass at all: it
        // points at the zero velocity kept after the active nodes.
        let still = self.active.len() as u32;
        self.stencil_nodes = self
            .rest
            .iter()
            .map(|x| {
                let s = Stencil::new((x - layout.origin) * layout.inv_dx);
                let mut nodes = [0u32; 27];
                let mut j = 0;
                for_stencil(layout, &s, |node, _, _| {
                    nodes[j] = place[node].min(still);
                    j += 1;
                });
                nodes
            })
            .collect();
        self.sources = vec![Source::default(); particles.len()];
        // One more after that: the lane loader reads eight floats from a node's start, two
        // past the last node's six.
        self.velocity = vec![NodeVelocity::default(); self.active.len() + 2];
        self.chunk_impulses =
            vec![[ToolImpulse::default(); MAX_TOOLS]; self.active.len().div_ceil(CHUNK)];
    }

    /// The stiffening bounds of the particles now (see [`crate::mpm::stiffening`]): over
    /// the free particles, and over each gripper's captured ones.
    pub(super) fn stiffening_bounds(
        particles: &Particles,
        captured: &Captured,
    ) -> StiffeningBounds {
        particles
            .f
            .par_iter()
            .enumerate()
            .fold(StiffeningBounds::default, |mut b, (p, f)| {
                let bound = inverse_stretch_bound(f);
                match captured.tool_of(p) {
                    Some(t) => b.held[t] = b.held[t].max(bound),
                    None => b.free = b.free.max(bound),
                }
                b
            })
            .reduce(StiffeningBounds::default, |mut a, b| {
                a.free = a.free.max(b.free);
                for (x, y) in a.held.iter_mut().zip(b.held) {
                    *x = x.max(y);
                }
                a
            })
    }

    /// One explicit step of `dt`, G2P on `transfer`, with `onsets` each material's damage
    /// onset energy (empty when nothing tears, see [`damage`]): returns the tools'
    /// impulses, the largest speed, the particles clamped at the domain's edge and the
    /// guard's first event.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn substep(
        &mut self,
        layout: &GridLayout,
        boundary: &Boundary,
        materials: &[MaterialParams],
        onsets: &[f32],
        particles: &mut Particles,
        captured: &mut Captured,
        tools: &[ToolKinematics],
        dt: f32,
        gravity: Vec3,
        max_speed_limit: f32,
        transfer: TransferPath,
    ) -> ([ToolImpulse; MAX_TOOLS], f32, u32, Option<GuardEvent>) {
        self.ensure_rest(layout, particles);
        captured.update(particles, tools);
        captured.scatter_at(layout, &self.rest, &particles.mass);
        // P2G on the rest configuration: each particle's stress, then each node gathers.
        let inv_dx = layout.inv_dx;
        let sources = self
            .sources
            .par_iter_mut()
            .zip(particles.f.par_iter_mut())
            .zip(particles.material.par_iter())
            .zip(particles.volume0.par_iter())
            .zip(particles.v.par_iter())
            .zip(particles.x.par_iter());
        let source = |tau: Mat3, f: &Mat3, volume0: f32, v: Vec3, x: Vec3| {
            let f_inv_t = f.try_inverse().unwrap_or_else(Mat3::identity).transpose();
            Source::new(v, x, &(tau * f_inv_t * (-volume0 * inv_dx)))
        };
        if onsets.is_empty() {
            sources.for_each(|(((((out, f), mat), volume0), v), x)| {
                let mat = materials[*mat as usize];
                let tau = kirchhoff_stress(mat.model, mat.lame, f);
                *out = source(tau, f, *volume0, *v, *x);
            });
        } else {
            // Tearing: the damage follows the deformation and degrades the tension, as in
            // the updated Lagrangian P2G; a torn particle's F keeps only its compression.
            sources.zip(particles.damage.par_iter_mut()).for_each(
                |((((((out, f), mat), volume0), v), x), d)| {
                    let onset = onsets[*mat as usize];
                    let mat = materials[*mat as usize];
                    let tau = damage::degraded_stress(&mat, onset, f, d);
                    *out = source(tau, f, *volume0, *v, *x);
                },
            );
        }
        // Each node gathers, then the grid update at the node's current place, in parallel
        // over chunks of nodes.
        let (starts, entries, sources) = (&self.starts, &self.entries, &self.sources);
        let (active, mass, captured) = (&self.active, &self.mass, &*captured);
        let nodes = self.active.len();
        self.velocity[..nodes]
            .par_chunks_mut(CHUNK)
            .zip(self.chunk_impulses.par_iter_mut())
            .enumerate()
            .for_each(|(chunk, (velocity, impulses))| {
                *impulses = [ToolImpulse::default(); MAX_TOOLS];
                let first = chunk * CHUNK;
                let mut sums = [Sum::default(); CHUNK];
                let sums = &mut sums[..velocity.len()];
                tl_node_sums::node_sums(
                    transfer,
                    &starts[first..=first + velocity.len()],
                    entries,
                    sources,
                    sums,
                );
                for (j, (node, sum)) in velocity.iter_mut().zip(sums.iter()).enumerate() {
                    let k = first + j;
                    let m = mass[k];
                    let NodeSums {
                        momentum,
                        place,
                        force,
                    } = NodeSums::of(sum);
                    let (x, v_before) = (place / m, momentum / m);
                    let i = active[k] as usize;
                    let mut v = v_before + (force / m + gravity) * dt;
                    v = match captured.holder(i, m) {
                        Some(t) => captured::hold(tools, t, x, v, m, impulses),
                        None => apply_tools(tools, x, v, m, impulses),
                    };
                    v = Self::apply_boundary(layout, boundary, i, x, v);
                    *node = NodeVelocity {
                        after: v,
                        change: v - v_before,
                    };
                }
            });
        let mut impulses = [ToolImpulse::default(); MAX_TOOLS];
        for chunk in &self.chunk_impulses {
            for (sum, impulse) in impulses.iter_mut().zip(chunk) {
                sum.add(impulse);
            }
        }
        // G2P, in parallel over chunks of particles: whole groups in SIMD lanes (see
        // `lanes`), the rest and any particle the guard stops one at a time.
        let (lo, hi) = layout.particle_bounds();
        let step = TlG2pStep {
            layout: *layout,
            materials,
            rest: &self.rest,
            stencil_nodes: &self.stencil_nodes,
            velocity: &self.velocity,
            dt,
            lo,
            hi,
            max_speed: max_speed_limit,
        };
        let tally = lanes::in_chunks(
            particles,
            |first, chunk, tally, redo| {
                lanes::tl_gather_groups(transfer, &step, first, chunk, tally, redo)
            },
            |p, particle, material, tally| tl_g2p_particle(&step, p, particle, material, tally),
        );
        let (max_speed, clamped, guard) = (tally.max_speed, tally.clamped, tally.guard);
        (impulses, max_speed, clamped, guard)
    }

    /// The table and the domain's slip walls: a bonded table holds the nodes whose rest
    /// place is on it (bonded tissue never leaves it); a resting table and the walls act at
    /// the node's current place.
    fn apply_boundary(
        layout: &GridLayout,
        boundary: &Boundary,
        node: usize,
        x: Vec3,
        mut v: Vec3,
    ) -> Vec3 {
        let (b, local) = (node / super::NODES_PER_BLOCK, node % super::NODES_PER_BLOCK);
        let rest = layout.node_position(layout.node_coords(b, local));
        if let Some((height, hold)) = boundary.table {
            match hold {
                TableHold::Bonded if rest.z <= height + 1e-3 * layout.dx => v = Vec3::zeros(),
                TableHold::Resting { friction } if x.z <= height + 1e-3 * layout.dx => {
                    v = contact::resolve(
                        contact::ContactModel::Coulomb {
                            friction,
                            drag: 0.0,
                        },
                        v,
                        Vec3::zeros(),
                        Vec3::z(),
                        Vec3::zeros(),
                    )
                }
                _ => {}
            }
        }
        let g = (x - layout.origin) * layout.inv_dx;
        for axis in 0..3 {
            if g[axis] < WALL_NODES as f32 && v[axis] < 0.0 {
                v[axis] = 0.0;
            }
            if g[axis] > (layout.nodes[axis] as i32 - 1 - WALL_NODES) as f32 && v[axis] > 0.0 {
                v[axis] = 0.0;
            }
        }
        v
    }
}

/// What total Lagrangian G2P reads that is the same for every particle of a substep.
pub(super) struct TlG2pStep<'a> {
    pub layout: GridLayout,
    pub materials: &'a [MaterialParams],
    /// Rest positions.
    pub rest: &'a [Vec3],
    /// Each particle's 27 stencil nodes' places in `velocity`.
    pub stencil_nodes: &'a [[u32; 27]],
    pub velocity: &'a [NodeVelocity],
    pub dt: f32,
    /// `GridLayout::particle_bounds`, grid units.
    pub lo: Vec3,
    pub hi: Vec3,
    /// Speed above which the guard stops a particle, m/s.
    pub max_speed: f32,
}

/// G2P of particle `p`, the reference path: PIC and FLIP velocities and the velocity
/// gradient from the rest stencil's nodes, then the move and F. A particle whose result
/// would be non-finite or faster than the guard allows is left as it was and reported.
pub(super) fn tl_g2p_particle(
    step: &TlG2pStep,
    p: usize,
    (x, v, c, f): lanes::ParticleMut,
    material: u16,
    tally: &mut G2pTally,
) {
    let layout = &step.layout;
    let dt = step.dt;
    let s = Stencil::new((step.rest[p] - layout.origin) * layout.inv_dx);
    let (mut v_pic, mut dv, mut grad_v) = (Vec3::zeros(), Vec3::zeros(), Mat3::zeros());
    let nodes = &step.stencil_nodes[p];
    for_stencil_weights(&s, |j, w, grad| {
        let node = step.velocity[nodes[j] as usize];
        v_pic += node.after * w;
        dv += node.change * w;
        grad_v += node.after * (grad * layout.inv_dx).transpose();
    });
    let mut v_new = (*v + dv) * FLIP + v_pic * (1.0 - FLIP);
    let damping = step.materials[material as usize].damping;
    if damping > 0.0 {
        v_new /= 1.0 + damping * dt;
    }
    let mut g = (*x + v_pic * dt - layout.origin) * layout.inv_dx;
    let inside = g.sup(&step.lo).inf(&step.hi);
    if inside != g {
        tally.clamped += 1;
        g = inside;
    }
    let f_new = *f + grad_v * dt;
    let speed = v_new.norm();
    let finite =
        speed.is_finite() && f_new.iter().all(|e| e.is_finite()) && g.iter().all(|e| e.is_finite());
    if !finite || speed > step.max_speed {
        let event = GuardEvent::stopped(finite, p, *x, speed);
        // Leave this particle as it was: nothing non-finite is stored.
        tally.guard = GuardEvent::first(tally.guard, Some(event));
        return;
    }
    tally.max_speed = tally.max_speed.max(speed);
    *v = v_new;
    *c = grad_v;
    *x = layout.origin + g * layout.dx;
    *f = f_new;
}

/// Calls `visit(node, weight, weight gradient in grid units)` for each node of a stencil.
#[inline(always)]
fn for_stencil(layout: &GridLayout, s: &Stencil, mut visit: impl FnMut(usize, f32, Vec3)) {
    for_stencil_weights(s, |j, w, grad| {
        let (a, b, c) = (j / 9, (j / 3) % 3, j % 3);
        let node = layout.node_index(
            (s.base.x + a as i32) as usize,
            (s.base.y + b as i32) as usize,
            (s.base.z + c as i32) as usize,
        );
        visit(node, w, grad);
    });
}

/// Calls `visit(j, weight, weight gradient in grid units)` for the stencil's nodes
/// j = 9a + 3b + c, node (a, b, c) from its base.
#[inline(always)]
fn for_stencil_weights(s: &Stencil, mut visit: impl FnMut(usize, f32, Vec3)) {
    let dw = weight_derivatives(s.fx);
    for a in 0..3 {
        for b in 0..3 {
            for c in 0..3 {
                let grad = Vec3::new(
                    dw[a].x * s.w[b].y * s.w[c].z,
                    s.w[a].x * dw[b].y * s.w[c].z,
                    s.w[a].x * s.w[b].y * dw[c].z,
                );
                visit(9 * a + 3 * b + c, s.weight(a, b, c), grad);
            }
        }
    }
}
