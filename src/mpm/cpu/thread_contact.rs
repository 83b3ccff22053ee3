//! A suture thread as contact geometry on the MPM grid (seed 002 §IV-C, its eq. 19 for the
//! needle generalised to a chain of segments), on the CPU's explicit update-Lagrangian path
//! (MLS-MPM and PIC share it; the other methods and the GPU backend refuse a thread in
//! tissue, see `config/README.md`).
//!
//! # Contact law
//!
//! Every segment of every thread is a capsule of radius r + dx (the thread's radius plus one
//! cell): a grid node with mass within it is in contact with the segment, the nearest segment
//! winning where two reach a node. One cell because the nearest node of any cell the thread
//! crosses is at most √3/2·dx ≈ 0.87·dx from it, so no cell lets tissue slip past the thread
//! unseen, while the tissue a stencil away (1.5 cells) still moves freely. Relative to the
//! segment's velocity s = (1 − θ)·u_a + θ·u_b at the node's closest-point parameter θ
//! (u_a, u_b the velocities of the segment's two points), a node keeps only its velocity
//! along the segment's tangent t (bilateral: the tissue the thread passes through can
//! neither cross it nor leave it sideways):
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
//! a and θ to b; the table and the walls then act on the node as in the grid update.
//!
//! # Coupling scheme
//!
//! The grid and the rod step one after the other in a frame: the tissue's substeps first,
//! then the rod's frame solve. Over the tissue's substeps each thread is a light body of its
//! own (a *proxy*): it starts from the rod's points and velocities at the frame's start; in
//! each substep its free points accelerate by their *drive* (the rod's acceleration over its
//! last frame less the tissue's share of it: gravity, tension, table, grasps), take the
//! momentum the contact gives them, and move by their velocity. The momentum the grid lost over the frame, summed per point,
//! is applied to the rod in its frame solve as a constant force J/T
//! ([`crate::rod::RodEnvironment::point_forces`]); the momentum the grid loses equals what
//! the rod receives, in f64 sums (`tests/thread_tissue.rs`: to a relative 7e-9). Explicit
//! exchange of a stiff tissue's momentum with a rod point hundreds of times lighter than a
//! node rings (a node simply taking the segment's velocity, its momentum given to the rod,
//! ran away in the first frame): the two-body impulse bounds what a point receives to what
//! brings it to the tissue's velocity.
//!
//! **Limit**: within the tissue's frame only the drive carries the rod's tension, so a
//! thread whose held ends are pulled sideways slides through the tissue instead of dragging
//! it (measured: 10 mm sideways through a 3 kPa block moved its centre 0.001 mm, the tissue's
//! force on the thread peaked at 0.09 mN). Holding the proxy's segments to their rest
//! lengths within the frame does not change that (measured: the same 0.001 mm): the proxy
//! restarts from the rod every frame, so it lags the held ends by at most one frame's pull
//! (0.33 mm there), whose stretch is second order in the lag, and the rod's frame solve,
//! which sees the tissue only as the constant force J/T, then carries the thread through.
//! Dragging needs the tissue inside the rod's solve (the rod's constraint solve stepped
//! within the tissue's substeps, or an implicit coupling).
//!
//! # Cost
//!
//! Only nodes near segments are visited: each segment tests the nodes of its capsule's
//! bounding box (about (2(r + dx)/dx + 1)³ ≈ 27–64 nodes), skipping blocks the substep did not
//! touch; the claims are sorted by node (nearest segment wins) and by segment. Serial, a few
//! microseconds per segment and substep, and nothing is allocated once the buffers grew.

use super::binning::Binning;
use super::node_contact::apply_boundary;
use crate::mpm::grid::{Boundary, GridLayout, Node, NODES_PER_BLOCK};
use crate::mpm::{Mat3, Vec3};
use nalgebra::Vector3;

/// How far beyond the thread's radius a node is in contact, in cells (see the module doc).
pub const REACH_CELLS: f32 = 1.0;

/// One thread as the grid sees it over a frame (the proxy of the module doc).
#[derive(Clone, Debug, Default)]
pub struct ThreadProxy {
    /// The points, m; moved by their velocities after every substep.
    pub points: Vec<Vec3>,
    /// The points' velocities, m/s.
    pub velocities: Vec<Vec3>,
    /// Each point's acceleration without the tissue, m/s² (gravity on a rod at rest).
    pub drive: Vec<Vec3>,
    /// Inverse masses, 1/kg; 0 for a point held kinematically.
    pub inv_mass: Vec<f32>,
    /// The thread's radius, m.
    pub radius: f32,
    /// Coulomb coefficient of tissue sliding along the thread.
    pub friction: f32,
    /// Fraction of the slip along the thread removed per substep.
    pub drag: f32,
    /// Momentum each point received from the grid since the frame began, N·s.
    pub impulse: Vec<Vector3<f64>>,
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

/// The threads in the tissue and the buffers of their contact pass.
#[derive(Debug, Default)]
pub struct ThreadContact {
    /// The threads, scene order; empty when the scene has none.
    threads: Vec<ThreadProxy>,
    /// Momentum the grid's nodes lost to the threads since the frame began, N·s, summed node
    /// by node (what the threads' `impulse`s add up to).
    grid_loss: Vector3<f64>,
    /// Node contacts since the frame began, summed over substeps.
    contacts: u64,
    claims: Vec<Claim>,
}

impl ThreadContact {
    /// Whether there is a thread to touch.
    pub fn is_empty(&self) -> bool {
        self.threads.is_empty()
    }

    /// Keeps `count` proxies for the caller to load for the coming frame and forgets the
    /// last frame's momentum and contacts.
    pub fn load(&mut self, count: usize) -> &mut [ThreadProxy] {
        self.threads.resize_with(count, Default::default);
        self.grid_loss = Vector3::zeros();
        self.contacts = 0;
        &mut self.threads
    }

    /// The momentum each point of thread `thread` received from the grid since the frame
    /// began, N·s; `None` for a thread not loaded.
    pub fn impulses(&self, thread: usize) -> Option<&[Vector3<f64>]> {
        self.threads.get(thread).map(|p| &p.impulse[..])
    }

    /// The momentum the grid's nodes lost to the threads since the frame began, N·s, summed
    /// node by node, and how many node contacts gave it.
    pub fn grid_loss(&self) -> (Vector3<f64>, u64) {
        (self.grid_loss, self.contacts)
    }

    /// One substep of `dt` after the grid update: the proxies accelerate by their drive, the
    /// nodes near their segments take the contact (module doc), the proxies take the
    /// momentum and move.
    pub(super) fn apply(
        &mut self,
        layout: &GridLayout,
        boundary: &Boundary,
        grid: &mut [Node],
        bins: &Binning,
        dt: f32,
    ) {
        for thread in &mut self.threads {
            for ((v, a), &w) in thread
                .velocities
                .iter_mut()
                .zip(&thread.drive)
                .zip(&thread.inv_mass)
            {
                if w > 0.0 {
                    *v += a * dt;
                }
            }
        }
        self.claim_nodes(layout, grid, bins);
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
            self.grid_loss += loss;
            start = end;
        }
        self.contacts += self.claims.len() as u64;
        for thread in &mut self.threads {
            for (x, v) in thread.points.iter_mut().zip(&thread.velocities) {
                *x += v * dt;
            }
        }
    }

    /// Lists the nodes with mass within reach of a segment, each once (its nearest segment),
    /// grouped by segment.
    fn claim_nodes(&mut self, layout: &GridLayout, grid: &[Node], bins: &Binning) {
        self.claims.clear();
        let last = layout.nodes.map(|n| n as i64 - 1);
        for (t, thread) in self.threads.iter().enumerate() {
            let reach = thread.radius + REACH_CELLS * layout.dx;
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
                            if !bins.is_touched(node / NODES_PER_BLOCK) || grid[node][3] <= 0.0 {
                                continue;
                            }
                            let x = layout.node_position(ijk);
                            let theta = ((x - a).dot(&ab) / length2).clamp(0.0, 1.0);
                            let distance2 = (x - (a + ab * theta)).norm_squared();
                            if distance2 <= reach * reach {
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
