//! What a rod touches during one frame: the table, rigid tools and grasps.
//!
//! A caller (the world) describes one frame's surroundings in a [`RodEnvironment`] and calls
//! [`RodSolver::step_frame_in`](super::RodSolver::step_frame_in):
//!
//! - `table_height`: a plane z = height the thread rests on (its centreline stays a radius
//!   above it), with Coulomb friction `table_friction`.
//! - `colliders`: tools as the SDFs of [`crate::tools::Shape`] (sphere, capsule, box, gripper
//!   jaws, needle), each with its pose (and jaw opening, in [`ToolPose::jaw`]) at the start
//!   and end of the frame, interpolated per substep, and a friction coefficient. The thread's
//!   segments are kept a thread radius outside the shape.
//! - `attachments`: points held kinematically (a grasp): each moves linearly from `from` to
//!   `to` over the frame with inverse mass 0, and is free again in the next frame unless
//!   attached again.
//! - `walls`: an axis-aligned box (lower and upper corner) the centreline points stay
//!   inside, such as a scene's domain less its wall cells and the thread radius.
//! - `point_forces`: a force on each point (N, one per point; empty for none) held constant
//!   over the frame and added to the rod's own `external_forces` in every substep's
//!   prediction: the tissue's reaction to the thread (see
//!   [`crate::mpm::cpu::thread_contact`]), the momentum the grid gave the thread over the
//!   frame divided by the frame's length.
//! - `self_collision`: segment–segment contact of the thread with itself (see
//!   [`super::self_contact`]), with friction `self_friction`.
//!
//! Contacts are position constraints projected after each direct solve (one per iteration).
//! Friction is position based (Macklin et al. 2014, "Unified particle physics", §6.1; seed 001's
//! appendix): the contact point's displacement over the substep relative to the surface is
//! split into normal and tangential parts; the tangential part is removed entirely while it is
//! below μ·d (d the penetration the normal projection just removed: static friction, the
//! Coulomb cone in displacement form, since d/h² is the normal force per mass and Δx_t/h²
//! the tangential one) and shortened by μ·d otherwise (kinetic).

use super::state::Rod;
use crate::math::{Mat3, Vec3};
use crate::tools::sdf::{jaw_angle, rotate_x};
use crate::tools::{Shape, ToolPose};

/// A rigid tool the thread collides with, moving over the frame from `pose_start` to
/// `pose_end` (jaw opening included, for grippers).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RodCollider {
    /// The tool's shape (tool frame).
    pub shape: Shape,
    /// The tool's pose (and jaw opening) at the start of the frame.
    pub pose_start: ToolPose,
    /// The tool's pose (and jaw opening) at the end of the frame.
    pub pose_end: ToolPose,
    /// Coulomb coefficient between thread and tool.
    pub friction: f32,
    /// Points `lo..=hi` the tool leaves alone (the points a gripper holds and their
    /// neighbours, which sit between or against its closed jaws), and the segments between
    /// them; every other point and segment collides with it.
    pub spared: Option<(usize, usize)>,
}

impl RodCollider {
    fn spares_point(spared: Option<(usize, usize)>, i: usize) -> bool {
        spared.is_some_and(|(lo, hi)| (lo..=hi).contains(&i))
    }
}

/// Point `point` of the rod held and moved linearly from `from` to `to` over the frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RodAttachment {
    /// Index of the held point along the rod.
    pub point: usize,
    /// Its position at the start of the frame, world frame, m.
    pub from: Vec3,
    /// Its position at the end of the frame, world frame, m.
    pub to: Vec3,
}

/// One frame's surroundings of a rod.
#[derive(Clone, Copy, Debug, Default)]
pub struct RodEnvironment<'a> {
    /// Height z of the table plane, m (`None`: no table).
    pub table_height: Option<f32>,
    /// Coulomb coefficient between thread and table.
    pub table_friction: f32,
    /// The tools the thread collides with.
    pub colliders: &'a [RodCollider],
    /// The points held this frame.
    pub attachments: &'a [RodAttachment],
    /// Lower and upper corner of the box the centreline stays inside, m (`None`: unbounded).
    pub walls: Option<(Vec3, Vec3)>,
    /// A force on each point over the whole frame, N (empty: none; else one per point).
    pub point_forces: &'a [Vec3],
    /// Whether the thread collides with itself.
    pub self_collision: bool,
    /// Coulomb coefficient of thread on thread.
    pub self_friction: f32,
}

/// What happened during one frame (contacts found by the first contact pass of each
/// substep's first iteration, summed over substeps).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RodFrameReport {
    /// Points found touching the table, summed over substeps.
    pub table_contacts: u32,
    /// Point or segment contacts with tools, summed over substeps.
    pub tool_contacts: u32,
    /// Segment pairs in self-contact, summed over substeps.
    pub self_contacts: u32,
    /// Substeps in which the move of some points was scaled back because it would have
    /// passed a strand through another (`crossing`).
    pub substeps_held_back: u32,
    /// Largest |strain| of any segment at the end of the frame.
    pub max_strain: f32,
    /// Substeps taken.
    pub substeps: u32,
    /// Direct solves that factorised the system, summed over substeps: a substep's cost
    /// (a chord step reuses the last factorisation at about a fifth of the price).
    pub factorisations: u32,
}

/// A collider placed for one substep: its pose at the substep's start and end in f32.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PlacedCollider {
    shape: Shape,
    friction: f32,
    spared: Option<(usize, usize)>,
    rotation: Mat3,
    translation: Vec3,
    jaw: f32,
    start_rotation: Mat3,
    start_translation: Vec3,
    start_jaw: f32,
    /// Bounding box of the shape over the substep, grown by the thread radius.
    aabb_min: Vec3,
    aabb_max: Vec3,
}

fn pose_f32(p: &ToolPose) -> (Mat3, Vec3, f32) {
    (
        p.rotation.to_rotation_matrix().into_inner().cast(),
        p.position.cast(),
        p.jaw as f32,
    )
}

impl PlacedCollider {
    /// `c` between fractions `s0` and `s1` of the frame.
    pub(crate) fn new(c: &RodCollider, s0: f64, s1: f64, thread_radius: f32) -> PlacedCollider {
        let (start_rotation, start_translation, start_jaw) =
            pose_f32(&c.pose_start.lerp(&c.pose_end, s0));
        let (rotation, translation, jaw) = pose_f32(&c.pose_start.lerp(&c.pose_end, s1));
        let reach = Vec3::repeat(c.shape.bounding_radius() + thread_radius);
        PlacedCollider {
            shape: c.shape,
            friction: c.friction,
            spared: c.spared,
            rotation,
            translation,
            jaw,
            start_rotation,
            start_translation,
            start_jaw,
            aabb_min: translation.inf(&start_translation) - reach,
            aabb_max: translation.sup(&start_translation) + reach,
        }
    }

    /// How far the tool's material point now at `x` moved over the substep (rigid motion,
    /// plus the jaw's rotation about its hinge for gripper parts).
    fn surface_displacement(&self, x: Vec3, part: u8) -> Vec3 {
        let mut local = self.rotation.tr_mul(&(x - self.translation));
        if part != 0 {
            let in_jaw = rotate_x(local, -jaw_angle(part, self.jaw));
            local = rotate_x(in_jaw, jaw_angle(part, self.start_jaw));
        }
        x - (self.start_rotation * local + self.start_translation)
    }

    fn overlaps(&self, lo: Vec3, hi: Vec3) -> bool {
        (0..3).all(|a| lo[a] <= self.aabb_max[a] && hi[a] >= self.aabb_min[a])
    }
}

/// Coulomb friction in displacement form: the correction to a tangential relative
/// displacement `slip` given the normal correction `depth` (both m) and coefficient `mu`.
pub(crate) fn friction_correction(slip: Vec3, depth: f32, mu: f32) -> Vec3 {
    let norm = slip.norm();
    let limit = mu * depth;
    if norm <= limit {
        -slip
    } else if norm > 0.0 {
        -slip * (limit / norm)
    } else {
        Vec3::zeros()
    }
}

/// Moves the point at parameter `t` of segment (`a`, `b`) by `delta`, distributing it over
/// the two end points by their inverse masses and barycentric weights (the least-norm
/// mass-weighted correction). Returns false when both ends are held.
fn move_segment_point(rod: &mut Rod, a: usize, b: usize, t: f32, delta: Vec3) -> bool {
    let (wa, wb) = (rod.inv_mass[a] * (1.0 - t), rod.inv_mass[b] * t);
    let denom = wa * (1.0 - t) + wb * t;
    if denom <= 0.0 {
        return false;
    }
    rod.points[a] += delta * (wa / denom);
    rod.points[b] += delta * (wb / denom);
    true
}

/// Most samples along one segment's interior (a segment is sampled every thread diameter).
const MAX_SEGMENT_SAMPLES: usize = 16;
/// Most sphere-tracing steps along one point's path.
const TRACE_STEPS: usize = 32;

/// Projects the rod out of the table and the colliders, with friction; `start` holds the
/// points at the start of the substep. Returns (table, tool) contact counts.
pub(crate) fn project_contacts(
    rod: &mut Rod,
    start: &[Vec3],
    table: Option<(f32, f32)>,
    colliders: &[PlacedCollider],
) -> (u32, u32) {
    let r = rod.material.radius;
    let mut table_contacts = 0;
    if let Some((height, mu)) = table {
        let floor = height + r;
        for (i, &x0) in start.iter().enumerate().take(rod.points.len()) {
            let depth = floor - rod.points[i].z;
            if depth > 0.0 && rod.inv_mass[i] > 0.0 {
                rod.points[i].z = floor;
                let moved = rod.points[i] - x0;
                let slip = Vec3::new(moved.x, moved.y, 0.0);
                rod.points[i] += friction_correction(slip, depth, mu);
                table_contacts += 1;
            }
        }
    }
    let mut tool_contacts = 0;
    for c in colliders {
        // Points first (a flat face touches a segment at its ends), then each segment's
        // interior where it dips deeper than both its ends (an edge, a wire, a jaw's corner).
        for (i, &x0) in start.iter().enumerate().take(rod.points.len()) {
            let x = rod.points[i];
            if rod.inv_mass[i] <= 0.0
                || RodCollider::spares_point(c.spared, i)
                || !c.overlaps(x0.inf(&x), x0.sup(&x))
            {
                continue;
            }
            if let Some(hit) = c.swept_contact(x0, x, r) {
                rod.points[i] += hit.normal * hit.depth;
                let moved = rod.points[i] - x0 - c.surface_displacement(rod.points[i], hit.part);
                let slip = moved - hit.normal * moved.dot(&hit.normal);
                rod.points[i] += friction_correction(slip, hit.depth, c.friction);
                tool_contacts += 1;
            }
        }
        for j in 0..rod.segments() {
            let (a0, b0, a, b) = (start[j], start[j + 1], rod.points[j], rod.points[j + 1]);
            let spared = RodCollider::spares_point(c.spared, j)
                && RodCollider::spares_point(c.spared, j + 1);
            if spared || !c.overlaps(a0.inf(&b0).inf(&a).inf(&b), a0.sup(&b0).sup(&a).sup(&b)) {
                continue;
            }
            let samples =
                ((rod.rest_lengths[j] / (2.0 * r)).ceil() as usize).clamp(2, MAX_SEGMENT_SAMPLES);
            let ends = [(a0, a), (b0, b)]
                .iter()
                .filter_map(|&(x0, x)| c.swept_contact(x0, x, r))
                .fold(0.0f32, |m, h| m.max(h.depth));
            let mut deepest: Option<(f32, ToolHit)> = None;
            for k in 1..samples {
                let t = k as f32 / samples as f32;
                let hit = c.swept_contact(a0 + (b0 - a0) * t, a + (b - a) * t, r);
                if let Some(hit) = hit.filter(|h| h.depth > ends) {
                    if deepest.is_none_or(|(_, d)| hit.depth > d.depth) {
                        deepest = Some((t, hit));
                    }
                }
            }
            let Some((t, hit)) = deepest else {
                continue;
            };
            if !move_segment_point(rod, j, j + 1, t, hit.normal * hit.depth) {
                continue;
            }
            let x = rod.points[j] + (rod.points[j + 1] - rod.points[j]) * t;
            let x_start = start[j] + (start[j + 1] - start[j]) * t;
            let moved = x - x_start - c.surface_displacement(x, hit.part);
            let slip = moved - hit.normal * moved.dot(&hit.normal);
            move_segment_point(
                rod,
                j,
                j + 1,
                t,
                friction_correction(slip, hit.depth, c.friction),
            );
            tool_contacts += 1;
        }
    }
    (table_contacts, tool_contacts)
}

/// Puts the free points of `rod` back inside the box from `lo` to `hi` (frictionless
/// walls). Returns how many it moved.
pub(crate) fn project_walls(rod: &mut Rod, lo: Vec3, hi: Vec3) -> u32 {
    let mut moved = 0;
    for (p, &w) in rod.points.iter_mut().zip(&rod.inv_mass) {
        let inside = p.sup(&lo).inf(&hi);
        if w > 0.0 && inside != *p {
            *p = inside;
            moved += 1;
        }
    }
    moved
}

/// A point's contact with a tool: how far to move it along the world normal.
#[derive(Clone, Copy, Debug)]
struct ToolHit {
    depth: f32,
    normal: Vec3,
    part: u8,
}

impl PlacedCollider {
    /// Contact of a thread point of radius `r` that moved from `x0` (substep start) to `x`
    /// while the tool moved from its start to its end pose: continuous, so that a thin tool
    /// (a 0.3 mm needle wire moves 4 mm per substep at 1 m/s) cannot pass through the thread.
    ///
    /// The point's path is taken in the tool's frame, from its start-pose coordinates to its
    /// end-pose ones, and sphere-traced against the shape grown by r. Where the path enters
    /// the shape, the point must end on the outer side of the tangent plane there (a point
    /// that went through is pushed back to the side it came from). A point that started in
    /// contact is resolved by the distance at its end, or by the start's tangent plane if
    /// it was pulled through to the far side.
    fn swept_contact(&self, x0: Vec3, x: Vec3, r: f32) -> Option<ToolHit> {
        let end = self.rotation.tr_mul(&(x - self.translation));
        let begin = self.start_rotation.tr_mul(&(x0 - self.start_translation));
        let at_end = self.shape.query(end, self.jaw);
        let discrete = |hit: crate::tools::SdfHit| {
            (hit.distance < r).then(|| ToolHit {
                depth: r - hit.distance,
                normal: self.rotation * hit.normal,
                part: hit.part,
            })
        };
        let at_begin = self.shape.query(begin, self.start_jaw);
        if at_begin.distance < r {
            // Started in contact (resting, sliding): the end's own distance, unless the end
            // lies on the other side of the tool (its normal turned away), then the start's
            // tangent plane.
            if at_end.normal.dot(&at_begin.normal) > 0.0 {
                return discrete(at_end);
            }
            let depth = r - at_begin.distance - at_begin.normal.dot(&(end - begin));
            return (depth > 0.0).then(|| ToolHit {
                depth,
                normal: self.rotation * at_begin.normal,
                part: at_begin.part,
            });
        }
        let path = end - begin;
        let length = path.norm();
        if length <= f32::EPSILON {
            return discrete(at_end);
        }
        // March until within 1 % of r of the grown surface (the tracing never overshoots:
        // the SDF bounds the distance to the surface).
        let mut travelled = 0.0;
        for _ in 0..TRACE_STEPS {
            let p = begin + path * (travelled / length);
            let hit = self.shape.query(p, self.jaw);
            let gap = hit.distance - r;
            if gap < 0.01 * r {
                let depth = -hit.normal.dot(&(end - p)) - gap;
                return (depth > 0.0).then(|| ToolHit {
                    depth,
                    normal: self.rotation * hit.normal,
                    part: hit.part,
                });
            }
            travelled += gap;
            if travelled >= length {
                return None;
            }
        }
        // A grazing path: fall back on the end position.
        discrete(at_end)
    }
}
