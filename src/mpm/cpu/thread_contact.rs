//! A suture thread in the tissue, two-way, on the MPM grid (seed 002 §IV-C, its eq. 19 for
//! the needle generalised to a chain of segments), on the explicit update-Lagrangian path
//! (MLS-MPM and PIC share it; the other methods refuse a thread in tissue, see
//! `config/README.md`). The GPU backend runs this same code on its grid, read back and
//! written again each substep ([`crate::mpm::gpu`]'s `thread_grid`).
//!
//! # Coupling scheme
//!
//! The rod steps inside every tissue substep, between the grid update and G2P: the nodes
//! near the thread are coupled to it (below), the world's [`ThreadStepper`] steps each rod
//! by one substep of the tissue's `dt` with what the grid gave it, and the grid takes back
//! what the rod's step gave the tissue. Tension, grasps and pinned ends thus act on the
//! tissue within the substep they arise in, and the tissue's inertia and elasticity act on
//! the rod's solve. (Exchanging momentum once a frame cannot drag tissue: the rod's frame
//! solve saw the tissue only as a constant force, and a thread pulled 10 mm sideways
//! through a 3 kPa block slid through it, moving its centre 0.001 mm.)
//!
//! # Binding: the thread inside the tissue
//!
//! A free point whose segments' capsules (radius r + dx, below) are full of tissue carries
//! the tissue across the thread: the point gathers the tissue's mass M and velocity from
//! the nodes of its quadratic B-spline stencil as an MPM particle would, each node's share
//! being the point's weight over the sum of the weights all bound points give that node (so
//! the shares of a node add to one and no tissue is bound twice). For the rod's step the
//! point's inverse mass becomes 1/m along the thread and 1/(m + M) across it
//! ([`crate::rod::Binding`]): point and tissue meet at their common velocity across the
//! thread and move as one body, while the thread slides along its channel. Along it the
//! point carries the fraction `tissue_drag` of M (the drag, implicit: 0 slides freely, 1
//! holds the tissue along as well), and Coulomb friction (`tissue_friction` times the normal
//! impulse, the last substep's push across) acts between the point and its tissue as two
//! bodies, as on the surface below. After the step the momentum the tissue gained, M·Δv
//! across and `tissue_drag`·M·Δv along, and the friction's reaction go back to the same
//! nodes in the same shares (each gains the same velocity), then the table and walls act on
//! them.
//!
//! How full a capsule is decides how much: its nodes' mass over that of as many nodes
//! inside tissue at rest; a point carries none of its stencil's tissue below a fill of 0.6
//! (a thread lying on a surface fills its capsule about half), all of it above 0.85, and a
//! linear share between. Each bound point keeps a material anchor, where the tissue it is
//! bound to carried it (moved with the grid's velocity like a particle), and the bound
//! velocity takes a tenth of the point's slip from it each substep: without it a soft block
//! held sideways crept off the thread (the tissue near it fell back from 9.3 mm to 4.7 mm in
//! 0.5 s). The anchor slides along the thread with its point by the share of the slip along
//! it that the tissue does not hold (1 − `tissue_drag`), so that only the slip across the
//! thread, and the drag's share along it, is taken back: a thread drawn along a curved
//! channel (a needle's arc) follows the channel instead of being pulled onto its chord.
//!
//! Measured (`tests/thread_tissue.rs`): a 7 cm thread through a 4 × 3 × 2 cm, 3 kPa block
//! bonded to the table, both ends pulled 10 mm sideways over 0.5 s: the thread's middle
//! moves 6.8 mm and the tissue around it 6.9 mm at dx 4 mm, 5.3 mm and 4.8 mm at dx 2 mm;
//! pulled 10 mm along itself it slides through and the tissue moves 0.02 mm along it, or
//! with `tissue_drag = 1` 9.7 mm of the thread's 10.0 mm.
//!
//! # Contact law: the thread on the tissue
//!
//! Every segment of every thread is a capsule of radius r + dx (the thread's radius plus one
//! cell): a grid node with mass within it, and in no bound point's stencil, is in contact
//! with the segment, the nearest segment winning where two reach a node. One cell because
//! the nearest node of any cell the thread crosses is at most √3/2·dx ≈ 0.87·dx from it, so
//! no cell lets tissue slip past the thread unseen, while the tissue a stencil away (1.5
//! cells) still moves freely. Bound nodes are left out because the binding moves them with
//! the thread already: acting on them twice fed energy into the free points by the block's
//! face (at dx 2 mm their contact force doubled every two frames until a particle ran away).
//! Relative to the segment's velocity s = (1 − θ)·u_a + θ·u_b at the node's closest-point
//! parameter θ (u_a, u_b the velocities of the segment's two points), a node keeps only its
//! velocity along the segment's tangent t:
//!
//! - the node and the segment at θ (inverse mass w_s = (1 − θ)²·w_a + θ²·w_b; 0 for a held,
//!   grasped or pinned, point) meet at one velocity across the segment: with
//!   P = I − t·tᵀ and k = 1/(1/m + w_s) the node gives the segment the impulse k·P(v − s),
//!   which leaves no relative velocity across it (an inelastic two-body collision, so a rod
//!   point hundreds of times lighter than a node cannot overshoot);
//! - along it, the impulse that would stop the slip, k·t·(v − s), is capped at μ times the
//!   impulse across it (Coulomb, μ the thread's `tissue_friction`), and the fraction
//!   `tissue_drag` of the rest is taken too (seed 002's drag).
//!
//! Nodes are visited segment by segment and each node's impulse changes its segment's points
//! at once (u_a += (1 − θ)·w_a·Δp, u_b += θ·w_b·Δp; Gauss–Seidel), so the next node sees them.
//! The momentum each node loses, mₖ·(vₖ − vₖ'), goes to the segment's points, (1 − θ) of it to
//! a and θ to b, and the rod's step takes it as a force over the substep; the table and the
//! walls then act on the node as in the grid update. The grid and the rod exchange the same
//! momentum, contact and binding alike (`tests/thread_tissue.rs`: to a relative 2e-8).
//!
//! **Limit**: Coulomb friction along the thread is explicit, between a point and the tissue
//! as two bodies, so it is bounded by what stops the light point's own slip: a thread whose
//! ends are pulled along slides through the tissue with the default `tissue_friction` alone
//! (measured: the tissue near its middle moved 0.009 mm). Static friction that holds a
//! taut thread in the tissue would need the friction inside the rod's solve;
//! `tissue_drag` is that, without Coulomb's load dependence.
//!
//! # Cutting: a thread through tough tissue
//!
//! Where every tissue has a `toughness` G_c (the least tough one's is taken), the tissue
//! holds a bound point across the thread with at most G_c per unit length of thread, as a
//! wire cuts a soft solid (the work of advancing it by d over a length L opens a crack of
//! area L·d). A bound point whose tissue took more push across in a substep's step than
//! G_c · l · dt (l: the thread's length at the point, half of each segment beside it) cuts
//! from the next substep on: it is not bound, so the rod moves it with its own mass, and it
//! and its tissue exchange G_c · s · l · dt against their relative velocity across (s: the
//! binding share), given to the rod and the stencil's nodes as the friction along is. While
//! it slips across the same way it keeps cutting; once it stops, the tissue binds it again
//! where it is, with a fresh anchor. Without a toughness nothing changes.
//!
//! The force is the toughness's and not the grid's (`tests/thread_tissue.rs`: the 7 cm
//! thread through the 4 cm block pulled 10 mm sideways cuts through it, its middle moving
//! 8.3 mm and the tissue near it 0.3 mm, pulling with 32.1 mN at dx 4 mm and 27.3 mN at
//! dx 2 mm for G_c 1 J/m², 10.2 and 8.4 mN for 0.3 J/m², against G_c · 40 mm = 40 and
//! 12 mN; with 30 J/m², more than the pull asks, it drags the tissue as without one). On
//! `config/suture.toml` with 0.3 J/m² the throw's pull cuts through the tissue and the
//! wound stays open, 3.88 mm -> 3.74 mm (`tests/suture.rs`). The
//! lag of one substep lets a point carry its tissue once past G_c before it cuts. The cut
//! makes no crack plane: the tissue the thread has passed is not parted by it (the
//! tissue's own damage, which the toughness also switches on, tears where its strain
//! energy says so).
//!
//! # Cost
//!
//! Only nodes near segments are visited: each segment tests the nodes of its capsule's
//! bounding box (about (2(r + dx)/dx + 1)³ ≈ 27–64 nodes), skipping blocks the substep did not
//! touch, and each bound point its 27-node stencil; the claims are sorted by node (nearest
//! segment wins) and by segment. The rod steps once per tissue substep, one direct solve
//! per iteration: its iterations follow the stretch residual, up to 16 while tissue is bound
//! (see [`crate::rod::solver`]). `bench skip --only thread` measures a 100-segment thread
//! through the resting seed-000 block against none.

use super::node_contact::apply_boundary;
use crate::mpm::grid::{Boundary, GridLayout, Node, NODES_PER_BLOCK};
use crate::mpm::kernel::Stencil;
use crate::mpm::MaterialParams;
use crate::mpm::{Mat3, Vec3};
use nalgebra::Vector3;
use std::collections::HashMap;

/// How far beyond the thread's radius a node is in contact, in cells (see the module doc).
pub const REACH_CELLS: f32 = 1.0;

/// How full of tissue a segment's capsule is (its nodes' mass over that of as many nodes
/// inside tissue at rest) where a point starts to carry tissue across the thread, and where
/// it carries all its stencil's share. A thread lying on a surface fills its capsule about
/// half (the nodes below are full, those above hold the kernel's tail of the top particles:
/// 0.50 measured on a block of 8 particles a cell); one a cell inside fills it whole.
const FILL_UNBOUND: f32 = 0.6;
const FILL_BOUND: f32 = 0.85;

/// The fraction of a bound point's slip from its material anchor taken back per substep
/// (module doc, binding). Without it a thread held sideways in a soft block crept through
/// it: the tissue near the thread fell back from 9.3 mm to 4.7 mm in 0.5 s while the
/// thread stayed put.
const ANCHOR_PULL: f32 = 0.1;

/// The share of its stencil's tissue a point carries across the thread at capsule fill
/// `fill`: none on a surface, all inside, linear between.
fn binding_share(fill: f32) -> f32 {
    ((fill - FILL_UNBOUND) / (FILL_BOUND - FILL_UNBOUND)).clamp(0.0, 1.0)
}

/// What steps the threads' rods inside a tissue substep (the world, which holds them).
pub trait ThreadStepper {
    /// Steps thread `thread`'s rod over the substep of `dt` seconds: the rod takes the
    /// proxy's `impulse` (what the contact gave each point this substep) as a force and its
    /// bound tissue (`bound_mass`, `bound_velocity`), steps, and leaves in the proxy its
    /// points, velocities and inverse masses (0 where held) after the step and in `push` the
    /// momentum each bound tissue gained.
    fn step(&mut self, thread: usize, proxy: &mut ThreadProxy, dt: f32);
}

/// One thread as the grid sees it within a frame: the rod's state after its latest step.
#[derive(Clone, Debug, Default)]
pub struct ThreadProxy {
    /// The points, m.
    pub points: Vec<Vec3>,
    /// The points' velocities, m/s.
    pub velocities: Vec<Vec3>,
    /// Inverse masses, 1/kg; 0 for a point held kinematically.
    pub inv_mass: Vec<f32>,
    /// The thread's radius, m.
    pub radius: f32,
    /// Coulomb coefficient of tissue sliding along the thread.
    pub friction: f32,
    /// Fraction of the slip along the thread removed per substep.
    pub drag: f32,
    /// Momentum each point received from the contact in the current substep, N·s; the
    /// stepper takes it.
    pub impulse: Vec<Vector3<f64>>,
    /// Momentum each point received from the contact since the frame began, N·s.
    pub frame_impulse: Vec<Vector3<f64>>,
    /// The tissue's mass bound to each point across the thread this substep, kg (0: the
    /// point is not inside the tissue).
    pub bound_mass: Vec<f32>,
    /// The bound tissue's velocity at each point, anchor pull included, m/s.
    pub bound_velocity: Vec<Vec3>,
    /// Momentum each point's bound tissue gained in the rod's step (across the thread, and
    /// along it with `tissue_drag`), N·s; set by the stepper, pushed into the grid.
    pub push: Vec<Vec3>,
    /// Momentum the bound tissue took since the frame began, N·s, summed per point.
    pub frame_push: Vec<Vector3<f64>>,
    /// The friction each point's bound tissue gives it along the thread this substep, N·s
    /// (the tissue takes the opposite).
    along_friction: Vec<Vec3>,
    /// The friction along bound points since the frame began, N·s, summed per point.
    pub frame_friction: Vec<Vector3<f64>>,
    /// Each bound point's material anchor: where the tissue it is bound to carried it.
    anchor: Vec<Option<Vec3>>,
    /// Each point cutting through its tissue (module doc, cutting): the direction it slips
    /// across the thread relative to the tissue.
    cutting: Vec<Option<Vec3>>,
    /// Each bound point's stencil share of the grid's mass, kg (the push divides by it).
    stencil_mass: Vec<f32>,
    /// Where each point was when its stencil was gathered (the push returns there).
    stencil_at: Vec<Vec3>,
    /// Per segment: the mass of every node within reach and how many there are, with mass
    /// or not (how full of tissue its capsule is); reused each substep.
    reach_fill: Vec<(f32, u32)>,
}

impl ThreadProxy {
    /// Empties the frame's sums and this substep's state for a frame starting from the
    /// points, velocities and inverse masses just loaded (anchors are kept: the tissue still
    /// holds the thread where it held it).
    pub fn start_frame(&mut self) {
        let n = self.points.len();
        for v in [
            &mut self.impulse,
            &mut self.frame_impulse,
            &mut self.frame_push,
            &mut self.frame_friction,
        ] {
            v.clear();
            v.resize(n, Vector3::zeros());
        }
        for v in [&mut self.push, &mut self.along_friction] {
            v.clear();
            v.resize(n, Vec3::zeros());
        }
        self.bound_mass.clear();
        self.bound_mass.resize(n, 0.0);
        self.bound_velocity.clear();
        self.bound_velocity.resize(n, Vec3::zeros());
        self.stencil_mass.clear();
        self.stencil_mass.resize(n, 0.0);
        self.stencil_at.clear();
        self.stencil_at.resize(n, Vec3::zeros());
        self.anchor.resize(n, None);
        self.cutting.resize(n, None);
    }

    /// The length of thread point `i` stands for: half of each segment beside it.
    fn length_at(&self, i: usize) -> f32 {
        let n = self.points.len();
        let half = |a: usize, b: usize| 0.5 * (self.points[b] - self.points[a]).norm();
        (if i > 0 { half(i - 1, i) } else { 0.0 }) + (if i + 1 < n { half(i, i + 1) } else { 0.0 })
    }

    /// `v` without its part along the thread at point `i`.
    fn across(&self, i: usize, v: Vec3) -> Vec3 {
        match self.axis(i) {
            Some(t) => v - t * t.dot(&v),
            None => v,
        }
    }

    /// Marks the bound points whose tissue took more push across the thread in this
    /// substep's step than toughness `g` (J/m²) allows over the thread's length there: from
    /// the next substep they cut through it, in the direction of that push.
    fn start_cutting(&mut self, g: f32, dt: f32) {
        for i in 0..self.points.len() {
            if self.bound_mass[i] <= 0.0 {
                continue;
            }
            let across = self.across(i, self.push[i]);
            if across.norm() > g * self.length_at(i) * dt {
                self.cutting[i] = across.try_normalize(f32::EPSILON);
            }
        }
    }

    /// The share of its stencil's tissue point `i` carries: the mean binding share of its
    /// segments' fill; none for a held point. `full_node_mass`: a node inside tissue at rest.
    fn binding_share(&self, i: usize, full_node_mass: f32) -> f32 {
        if self.inv_mass[i] <= 0.0 || full_node_mass <= 0.0 {
            return 0.0;
        }
        let fill = |j: usize| {
            let (mass, count) = self.reach_fill[j];
            if count == 0 {
                0.0
            } else {
                mass / (count as f32 * full_node_mass)
            }
        };
        let last = self.reach_fill.len() - 1;
        binding_share(0.5 * (fill(i.saturating_sub(1)) + fill(i.min(last))))
    }

    /// The thread's direction at point `i` (from its previous point to its next), or `None`
    /// where those coincide.
    fn axis(&self, i: usize) -> Option<Vec3> {
        let n = self.points.len();
        let (lo, hi) = (i.saturating_sub(1), (i + 1).min(n - 1));
        (self.points[hi] - self.points[lo]).try_normalize(f32::EPSILON)
    }

    /// Moves point `i`'s material anchor along the thread with the point, by the fraction
    /// of their offset along it that the tissue does not hold (1 − `drag`), and returns it:
    /// the thread slides along its channel, so only the slip the tissue holds is taken back.
    /// (An anchor left where a point entered pulled a point sliding round a curved channel
    /// across, onto the chord: a thread drawn through tissue on a needle's arc cut the
    /// chord of the arc.)
    fn slide_anchor(&mut self, i: usize) -> Vec3 {
        let point = self.points[i];
        let axis = self.axis(i);
        let free = 1.0 - self.drag;
        let anchor = self.anchor[i].get_or_insert(point);
        if let Some(t) = axis {
            *anchor += t * (free * t.dot(&(point - *anchor)));
        }
        *anchor
    }

    /// The friction bound point `i`'s tissue, moving at `tissue_velocity`, gives it along
    /// the thread this substep, N·s: the impulse that would stop their slip along it
    /// (point and bound tissue as two bodies), capped at `friction` times the normal impulse
    /// between them (the across push of the last substep), and the fraction `drag` of the
    /// rest, as the contact law does on the surface.
    fn friction_along(&self, i: usize, tissue_velocity: Vec3) -> Vec3 {
        let Some(t) = self.axis(i) else {
            return Vec3::zeros();
        };
        let slip = t.dot(&(tissue_velocity - self.velocities[i]));
        let k = 1.0 / (self.inv_mass[i] + 1.0 / self.bound_mass[i]);
        let stick = k * slip.abs();
        // The push's part across the thread (with `tissue_drag` it has one along it too).
        let normal = self.across(i, self.push[i]).norm();
        let mut along = stick.min(self.friction * normal);
        along += self.drag * (stick - along);
        t * along.copysign(slip)
    }
}

/// A node within reach of a segment.
#[derive(Clone, Copy, Debug)]
struct Claim {
    node: u32,
    thread: u32,
    segment: u32,
    theta: f32,
    distance2: f32,
}

/// What of the tissue's materials the thread's coupling reads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TissueLimits {
    /// The mass of a node inside tissue at rest, kg: density · dx³, the least dense
    /// material's.
    pub full_node_mass: f32,
    /// The tissue's G_c, J/m² (the least tough material's); `None` where some tissue has
    /// none and so never tears.
    pub toughness: Option<f32>,
}

impl TissueLimits {
    /// The limits of tissue made of `materials` on a grid of spacing `dx`.
    pub fn new(materials: &[MaterialParams], dx: f32) -> Self {
        let least = |value: fn(&MaterialParams) -> f32| {
            materials.iter().map(value).fold(f32::MAX, f32::min)
        };
        TissueLimits {
            full_node_mass: least(|m| m.density) * dx * dx * dx,
            toughness: materials
                .iter()
                .all(|m| m.toughness > 0.0)
                .then(|| least(|m| m.toughness)),
        }
    }
}

/// What the grid and the threads exchanged since the frame began, summed node by node
/// (momenta in N·s, the counts over substeps).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GridExchange {
    /// Momentum the nodes lost to the contact law (what the threads' `frame_impulse`s add
    /// up to).
    pub contact: Vector3<f64>,
    /// Node contacts of the contact law.
    pub contacts: u64,
    /// Momentum the bound tissue's push gave the nodes (what the `frame_push`es add up to).
    pub push: Vector3<f64>,
    /// Points with tissue bound across them.
    pub bound_points: u64,
    /// Points cutting through their tissue (module doc, cutting), counted with
    /// `bound_points`.
    pub cutting_points: u64,
    /// Momentum the nodes lost to the friction along bound points (what the
    /// `frame_friction`s add up to).
    pub friction: Vector3<f64>,
}

/// The threads in the tissue and the buffers of their contact pass.
#[derive(Debug, Default)]
pub struct ThreadContact {
    /// The threads, scene order; empty when the scene has none.
    threads: Vec<ThreadProxy>,
    exchange: GridExchange,
    claims: Vec<Claim>,
    /// Per node in a bound point's stencil: the sum of the weights the bound points give it.
    stencil_sums: HashMap<u32, f32>,
}

impl ThreadContact {
    /// Whether there is a thread to touch.
    pub fn is_empty(&self) -> bool {
        self.threads.is_empty()
    }

    /// Keeps `count` proxies for the caller to load for the coming frame (then
    /// [`ThreadProxy::start_frame`]) and forgets the last frame's sums.
    pub fn load(&mut self, count: usize) -> &mut [ThreadProxy] {
        self.threads.resize_with(count, Default::default);
        self.exchange = GridExchange::default();
        &mut self.threads
    }

    /// Thread `thread` as the grid left it; `None` for a thread not loaded.
    pub fn proxy(&self, thread: usize) -> Option<&ThreadProxy> {
        self.threads.get(thread)
    }

    /// What the grid and the threads exchanged since the frame began.
    pub fn exchange(&self) -> GridExchange {
        self.exchange
    }

    /// A box holding every node the next `ThreadContact::apply` can read or write, or
    /// `None` without a thread: the points' segments' capsules (radius plus
    /// [`REACH_CELLS`]) and the stencils of the points and their anchors, with a cell more
    /// for the points' motion within the substep.
    pub fn reach_box(&self, dx: f32) -> Option<(Vec3, Vec3)> {
        let mut reach: Option<(Vec3, Vec3)> = None;
        for thread in &self.threads {
            let margin = Vec3::repeat(thread.radius + (REACH_CELLS.max(2.0) + 1.0) * dx);
            for p in thread.points.iter().chain(thread.anchor.iter().flatten()) {
                let (lo, hi) = (p - margin, p + margin);
                reach = Some(match reach {
                    Some((a, b)) => (a.inf(&lo), b.sup(&hi)),
                    None => (lo, hi),
                });
            }
        }
        reach
    }

    /// One substep of `dt` after the grid update (module doc): the tissue across each point
    /// inside it is bound, the other nodes near segments take the contact, `stepper` steps
    /// the rods, the bound tissue takes its push and the anchors move with the grid.
    /// `touched` says whether the substep's particles wrote to a block (the others hold
    /// stale nodes).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn apply(
        &mut self,
        layout: &GridLayout,
        boundary: &Boundary,
        grid: &mut [Node],
        touched: &dyn Fn(usize) -> bool,
        dt: f32,
        tissue: TissueLimits,
        stepper: &mut dyn ThreadStepper,
    ) {
        let TissueLimits {
            full_node_mass,
            toughness,
        } = tissue;
        self.claim_nodes(layout, grid, touched);
        self.bind_tissue(layout, grid, dt, full_node_mass, toughness);
        // Bound tissue moves with its point across the thread: the contact law would act on
        // those nodes a second time (measured at dx 2 mm: the contact's force on the free
        // points by the block's face doubled every two frames until a particle ran away).
        let sums = &self.stencil_sums;
        self.claims.retain(|c| !sums.contains_key(&c.node));
        let mut start = 0;
        while start < self.claims.len() {
            let (t, j) = (self.claims[start].thread, self.claims[start].segment);
            let end = start
                + self.claims[start..]
                    .iter()
                    .take_while(|c| c.thread == t && c.segment == j)
                    .count();
            let loss = resolve_segment(
                &mut self.threads[t as usize],
                j as usize,
                &self.claims[start..end],
                layout,
                boundary,
                grid,
            );
            self.exchange.contact += loss;
            start = end;
        }
        self.exchange.contacts += self.claims.len() as u64;
        for (i, thread) in self.threads.iter_mut().enumerate() {
            for (sum, j) in thread.frame_impulse.iter_mut().zip(&thread.impulse) {
                *sum += j;
            }
            // The friction along bound points reaches the rod with the contact's impulse.
            for ((j, sum), f) in (thread.impulse.iter_mut())
                .zip(&mut thread.frame_friction)
                .zip(&thread.along_friction)
            {
                let f = f.cast::<f64>();
                *j += f;
                *sum += f;
            }
            thread.push.fill(Vec3::zeros());
            stepper.step(i, thread, dt);
            thread.impulse.fill(Vector3::zeros());
            if let Some(g) = toughness {
                thread.start_cutting(g, dt);
            }
        }
        self.push_bound_tissue(layout, boundary, grid, dt);
    }

    /// Binds the tissue across every free point inside it, as an MPM particle gathers it:
    /// each node of the point's quadratic B-spline stencil gives its mass and momentum in
    /// proportion to the point's weight over the weights all bound points give that node
    /// (so that a node's shares add up to one), times the point's binding share. The bound
    /// velocity takes `ANCHOR_PULL` of the point's slip from its material anchor.
    fn bind_tissue(
        &mut self,
        layout: &GridLayout,
        grid: &[Node],
        dt: f32,
        full_node_mass: f32,
        toughness: Option<f32>,
    ) {
        self.stencil_sums.clear();
        for thread in &mut self.threads {
            for i in 0..thread.points.len() {
                let share = thread.binding_share(i, full_node_mass);
                thread.bound_mass[i] = share;
                if share <= 0.0 {
                    thread.cutting[i] = None;
                    continue;
                }
                let sums = &mut self.stencil_sums;
                stencil_nodes(layout, thread.points[i], |n, w| {
                    *sums.entry(n).or_insert(0.0) += w
                });
            }
        }
        for thread in &mut self.threads {
            for i in 0..thread.points.len() {
                let share = thread.bound_mass[i];
                if share <= 0.0 {
                    thread.bound_mass[i] = 0.0;
                    thread.stencil_mass[i] = 0.0;
                    thread.along_friction[i] = Vec3::zeros();
                    thread.anchor[i] = None;
                    continue;
                }
                let point = thread.points[i];
                let (mut mass, mut momentum) = (0.0f32, Vec3::zeros());
                stencil_nodes(layout, point, |n, w| {
                    let node = grid[n as usize];
                    let m = w / self.stencil_sums[&n] * node[3];
                    mass += m;
                    momentum += Vec3::new(node[0], node[1], node[2]) * m;
                });
                self.exchange.bound_points += 1;
                thread.stencil_mass[i] = mass;
                thread.stencil_at[i] = point;
                thread.bound_mass[i] = share * mass;
                thread.along_friction[i] = Vec3::zeros();
                if let (Some(g), Some(direction), true) = (toughness, thread.cutting[i], mass > 0.0)
                {
                    // Still slipping across the same way: the tissue resists with G_c per
                    // unit length of thread (as friction does, between two bodies) and binds
                    // nothing. Stopped, it holds the thread again where it is now.
                    let slip = thread.across(i, thread.velocities[i] - momentum / mass);
                    if slip.dot(&direction) > 0.0 {
                        let direction = slip.normalize();
                        thread.cutting[i] = Some(direction);
                        thread.anchor[i] = None;
                        thread.bound_mass[i] = 0.0;
                        thread.along_friction[i] =
                            -direction * (g * share * thread.length_at(i) * dt);
                        self.exchange.cutting_points += 1;
                        continue;
                    }
                    thread.cutting[i] = None;
                }
                let anchor = thread.slide_anchor(i);
                if mass <= 0.0 {
                    thread.bound_velocity[i] = Vec3::zeros();
                    continue;
                }
                let tissue_velocity = momentum / mass;
                thread.bound_velocity[i] = tissue_velocity + (anchor - point) * (ANCHOR_PULL / dt);
                thread.along_friction[i] = thread.friction_along(i, tissue_velocity);
            }
        }
    }

    /// Gives each bound point's push to the nodes it gathered its tissue from, in the same
    /// shares (each node gains the same velocity, and the momenta add up to the push), then
    /// moves every anchor with the grid's velocity there, as a particle moves.
    fn push_bound_tissue(
        &mut self,
        layout: &GridLayout,
        boundary: &Boundary,
        grid: &mut [Node],
        dt: f32,
    ) {
        for thread in &mut self.threads {
            for i in 0..thread.points.len() {
                let mass = thread.stencil_mass[i];
                let cutting = thread.cutting[i].is_some();
                if (thread.bound_mass[i] <= 0.0 && !cutting) || mass <= 0.0 {
                    continue;
                }
                let push = thread.push[i] / mass;
                let friction = thread.along_friction[i] / mass;
                thread.frame_push[i] += thread.push[i].cast::<f64>();
                let exchange = &mut self.exchange;
                stencil_nodes(layout, thread.stencil_at[i], |n, w| {
                    let index = n as usize;
                    let [vx, vy, vz, m] = grid[index];
                    let share = w / self.stencil_sums[&n];
                    let (push, friction) = (push * share, friction * share);
                    exchange.push += (push * m).cast::<f64>();
                    exchange.friction += (friction * m).cast::<f64>();
                    // The table and the walls act on the node after the push as after the
                    // grid update.
                    let block = index / NODES_PER_BLOCK;
                    let ijk = layout.node_coords(block, index % NODES_PER_BLOCK);
                    let x = layout.node_position(ijk);
                    let v = Vec3::new(vx, vy, vz) + push - friction;
                    let v = apply_boundary(layout, boundary, ijk, x, v);
                    grid[index] = [v.x, v.y, v.z, m];
                });
            }
        }
        for thread in &mut self.threads {
            for anchor in thread.anchor.iter_mut().flatten() {
                let mut v = Vec3::zeros();
                stencil_nodes(layout, *anchor, |n, w| {
                    let node = grid[n as usize];
                    v += Vec3::new(node[0], node[1], node[2]) * w;
                });
                *anchor += v * dt;
            }
        }
    }

    /// Lists the nodes with mass within reach of a segment, each once (its nearest segment),
    /// grouped by segment.
    fn claim_nodes(&mut self, layout: &GridLayout, grid: &[Node], touched: &dyn Fn(usize) -> bool) {
        self.claims.clear();
        let last = layout.nodes.map(|n| n as i64 - 1);
        for (t, thread) in self.threads.iter_mut().enumerate() {
            let reach = thread.radius + REACH_CELLS * layout.dx;
            thread.reach_fill.clear();
            thread.reach_fill.resize(thread.points.len() - 1, (0.0, 0));
            for (j, pair) in thread.points.windows(2).enumerate() {
                let (a, b) = (pair[0], pair[1]);
                let ab = b - a;
                let length2 = ab.norm_squared();
                if length2 <= f32::EPSILON * f32::EPSILON {
                    continue;
                }
                let lo = (a.inf(&b) - Vector3::repeat(reach) - layout.origin) * layout.inv_dx;
                let hi = (a.sup(&b) + Vector3::repeat(reach) - layout.origin) * layout.inv_dx;
                let range = |axis: usize| {
                    let from = (lo[axis].ceil() as i64).max(0);
                    let to = (hi[axis].floor() as i64).min(last[axis]);
                    from..=to
                };
                for i in range(0) {
                    for jj in range(1) {
                        for k in range(2) {
                            let ijk = [i as usize, jj as usize, k as usize];
                            let node = layout.node_index(ijk[0], ijk[1], ijk[2]);
                            let x = layout.node_position(ijk);
                            let theta = ((x - a).dot(&ab) / length2).clamp(0.0, 1.0);
                            let distance2 = (x - (a + ab * theta)).norm_squared();
                            if distance2 > reach * reach {
                                continue;
                            }
                            let mass = if touched(node / NODES_PER_BLOCK) {
                                grid[node][3]
                            } else {
                                0.0
                            };
                            let fill = &mut thread.reach_fill[j];
                            fill.1 += 1;
                            if mass > 0.0 {
                                fill.0 += mass;
                                self.claims.push(Claim {
                                    node: node as u32,
                                    thread: t as u32,
                                    segment: j as u32,
                                    theta,
                                    distance2,
                                });
                            }
                        }
                    }
                }
            }
        }
        // Nearest segment wins (ties to the lower thread and segment, for reproducibility).
        self.claims.sort_unstable_by(|p, q| {
            (p.node.cmp(&q.node))
                .then(p.distance2.total_cmp(&q.distance2))
                .then((p.thread, p.segment).cmp(&(q.thread, q.segment)))
        });
        self.claims.dedup_by_key(|c| c.node);
        self.claims
            .sort_unstable_by_key(|c| (c.thread, c.segment, c.node));
    }
}

/// The contact of segment `j` of `thread` with the nodes `claims` (module doc), node after
/// node; returns the momentum the nodes lost, which the segment's points received.
fn resolve_segment(
    thread: &mut ThreadProxy,
    j: usize,
    claims: &[Claim],
    layout: &GridLayout,
    boundary: &Boundary,
    grid: &mut [Node],
) -> Vector3<f64> {
    let (pa, pb) = (thread.points[j], thread.points[j + 1]);
    let Some(t) = (pb - pa).try_normalize(f32::EPSILON) else {
        return Vector3::zeros();
    };
    let across = Mat3::identity() - t * t.transpose();
    let (wa, wb) = (thread.inv_mass[j], thread.inv_mass[j + 1]);
    let mut loss = Vector3::<f64>::zeros();
    for c in claims {
        let index = c.node as usize;
        let node = grid[index];
        let (v, m) = (Vec3::new(node[0], node[1], node[2]), node[3]);
        let theta = c.theta;
        let s = thread.velocities[j].lerp(&thread.velocities[j + 1], theta);
        let relative = v - s;
        // Node and segment (inverse mass (1 − θ)²·w_a + θ²·w_b at θ) meet at one velocity.
        let segment_w = (1.0 - theta).powi(2) * wa + theta.powi(2) * wb;
        let k = 1.0 / (1.0 / m + segment_w);
        let normal = across * relative * k;
        let slip = t.dot(&relative);
        let stick = k * slip.abs();
        let mut along = stick.min(thread.friction * normal.norm());
        along += thread.drag * (stick - along);
        let dp = normal + t * along.copysign(slip);
        let v_new = v - dp / m;
        thread.velocities[j] += dp * ((1.0 - theta) * wa);
        thread.velocities[j + 1] += dp * (theta * wb);
        // Split in f64 so that the two shares add up to what the node lost.
        let dp = dp.cast::<f64>();
        let share_a = dp * (1.0 - theta as f64);
        loss += dp;
        thread.impulse[j] += share_a;
        thread.impulse[j + 1] += dp - share_a;
        let block = index / NODES_PER_BLOCK;
        let ijk = layout.node_coords(block, index % NODES_PER_BLOCK);
        let x = layout.node_position(ijk);
        let v_final = apply_boundary(layout, boundary, ijk, x, v_new);
        grid[index] = [v_final.x, v_final.y, v_final.z, m];
    }
    loss
}

/// Calls `f` with each node of the quadratic B-spline stencil of position `p` (the MPM
/// particle's) inside the grid and its weight, skipping zero weights (a point on a node
/// plane has some; dividing by their sum gave NaN).
fn stencil_nodes(layout: &GridLayout, p: Vec3, mut f: impl FnMut(u32, f32)) {
    let stencil = Stencil::new((p - layout.origin) * layout.inv_dx);
    for a in 0..3 {
        for b in 0..3 {
            for c in 0..3 {
                let w = stencil.weight(a, b, c);
                let ijk = stencil.base + nalgebra::Vector3::new(a as i32, b as i32, c as i32);
                let inside = (0..3).all(|k| ijk[k] >= 0 && (ijk[k] as usize) < layout.nodes[k]);
                if w > 0.0 && inside {
                    let node = layout.node_index(ijk[0] as usize, ijk[1] as usize, ijk[2] as usize);
                    f(node as u32, w);
                }
            }
        }
    }
}
