//! Whether a move of the thread's points passes its centreline through itself, and the move
//! scaled back point by point until it does not.
//!
//! Self-contact (`self_contact`) keeps each pair of segments on its side through the solve →
//! contact rounds of a substep, but it judges a pair from where it ends: the side normal and
//! whether the lines meet within (a margin of) both segments. The length restoration that
//! follows the rounds (`RodSolver::restore_length`) moves the points again, and a taut strand
//! pulled through another there is not always seen: through a *bent* joint the lines'
//! closest points land beyond both segments' ends, and pairs turned nearly parallel have no
//! line parameters at all (README, "Suture thread in scenes", the 3-0 nylon knot).
//!
//! Here the move from a state without crossings (`safe`) to the moved points is taken as
//! linear per point, and every pair of segments whose swept boxes overlap is tested
//! continuously, as in the edge–edge test of Provot (1997) and Bridson et al. (2002): the
//! centrelines meet at a fraction τ of the move only where the four points are coplanar, a
//! cubic in τ, and there the segments' own closest points coincide. Joints need no margin:
//! a chain's segments cover it, ends included, so a strand passing through a joint meets
//! one of its two segments at an end (parameter 0 or 1, distance zero); parallel pairs need
//! no line parameters, since the closest points of two segments are defined for any pair.
//! Centrelines that stay exactly coplanar for the whole move (a thread flat on the table
//! sliding in its plane) have no coplanarity instant to find; there self-contact's distance
//! keeps them apart.

use super::self_contact::{segment_distance, SelfContacts};
use super::state::Rod;
use crate::math::Vec3;

/// Distance, in diameters, between the centrelines at a coplanar instant below which a pair
/// counts as meeting: far above the f64 rounding at the root (~1e-15 m), and small, since
/// crossings are counted by parity: a near miss counted as a meeting would cancel a crossing.
const MEETING: f64 = 1e-4;

/// Rounds of halving the move of the points of crossing pairs; a point whose share of its
/// move is already below `LEAST_SHARE` gives up the rest of it. After the last round every
/// free point still moving is returned to `safe`, which has no crossing.
const ROUNDS: usize = 8;
const LEAST_SHARE: f32 = 1.0 / 8.0;

/// Reused buffers of [`CrossingGuard::keep_sides`].
#[derive(Clone, Debug, Default)]
pub struct CrossingGuard {
    moved: Vec<Vec3>,
    share: Vec<f32>,
    crossed: Vec<(u32, u32)>,
}

impl CrossingGuard {
    /// Scales back the move of the rod's points from `safe` (the same points in a state
    /// where no pair of segments crosses) until no pair's centrelines meet along it: the
    /// points of every pair that meets keep half their move, round after round, and give it
    /// up entirely below an eighth. Held points (inverse mass 0) keep theirs. `broad` lends
    /// its broad phase. Returns the number of points whose move was scaled back.
    pub fn keep_sides(&mut self, rod: &mut Rod, safe: &[Vec3], broad: &mut SelfContacts) -> usize {
        let meeting = MEETING * 2.0 * rod.material.radius as f64;
        self.moved.clone_from(&rod.points);
        self.share.clear();
        self.share.resize(rod.points.len(), 1.0);
        for round in 0..=ROUNDS {
            self.crossed.clear();
            for &(a, b) in broad.swept_pairs(rod, safe) {
                let (a, b) = (a as usize, b as usize);
                let from = [safe[a], safe[a + 1], safe[b], safe[b + 1]];
                let p = &rod.points;
                // Any meeting, not an odd count: a fail-safe, and a near miss within
                // `MEETING` of a real crossing must not cancel it.
                if centrelines_meet(from, [p[a], p[a + 1], p[b], p[b + 1]], meeting) {
                    self.crossed.push((a as u32, b as u32));
                }
            }
            if self.crossed.is_empty() {
                break;
            }
            for &(a, b) in &self.crossed {
                for i in [a as usize, a as usize + 1, b as usize, b as usize + 1] {
                    if rod.inv_mass[i] > 0.0 {
                        let share = &mut self.share[i];
                        *share = if round == ROUNDS || *share <= LEAST_SHARE {
                            0.0
                        } else {
                            0.5 * *share
                        };
                    }
                }
            }
            if round == ROUNDS {
                // Pairs still meeting after every halving: no free point of the rod moves
                // (`safe` has no crossing; held points follow their attachments).
                for (share, &w) in self.share.iter_mut().zip(&rod.inv_mass) {
                    if w > 0.0 {
                        *share = 0.0;
                    }
                }
            }
            for (i, point) in rod.points.iter_mut().enumerate() {
                *point = safe[i] + (self.moved[i] - safe[i]) * self.share[i];
            }
        }
        self.share.iter().filter(|&&s| s < 1.0).count()
    }
}

/// Whether segments a and b of the rod crossed in the move from `from` to `to`: their
/// centrelines met an odd number of times (through and back again is no crossing).
pub fn pair_crossed(from: &[Vec3], to: &[Vec3], a: usize, b: usize, diameter: f32) -> bool {
    let meeting = MEETING * diameter as f64;
    meetings(
        [from[a], from[a + 1], from[b], from[b + 1]],
        [to[a], to[a + 1], to[b], to[b + 1]],
        meeting,
    ) % 2
        == 1
}

/// Whether segments a = p0–p1 and b = p2–p3, each point moving linearly from `from` to `to`,
/// have centrelines meeting (within `meeting` metres) at some instant of the move.
pub fn centrelines_meet(from: [Vec3; 4], to: [Vec3; 4], meeting: f64) -> bool {
    meetings(from, to, meeting) > 0
}

/// The number of instants of the move at which the centrelines meet.
fn meetings(from: [Vec3; 4], to: [Vec3; 4], meeting: f64) -> usize {
    let x0 = from.map(|p| p.cast::<f64>());
    let v = [0, 1, 2, 3].map(|i| to[i].cast::<f64>() - x0[i]);
    // The four points are coplanar where det[p1 − p0, p2 − p0, p3 − p0] = 0; each edge is
    // linear in τ, so the determinant is a cubic.
    let edge = |i: usize| (x0[i] - x0[0], v[i] - v[0]);
    let (e1, e2, e3) = (edge(1), edge(2), edge(3));
    let cross = [
        e2.0.cross(&e3.0),
        e2.0.cross(&e3.1) + e2.1.cross(&e3.0),
        e2.1.cross(&e3.1),
    ];
    let cubic = [
        e1.0.dot(&cross[0]),
        e1.0.dot(&cross[1]) + e1.1.dot(&cross[0]),
        e1.0.dot(&cross[2]) + e1.1.dot(&cross[1]),
        e1.1.dot(&cross[2]),
    ];
    let at = |tau: f64| [0, 1, 2, 3].map(|i| x0[i] + v[i] * tau);
    unit_roots(cubic)
        .into_iter()
        .flatten()
        .filter(|&tau| {
            // In f64: a crossing's distance at its root is ~1e-15 m.
            let p = at(tau);
            segment_distance(p[0], p[1], p[2], p[3]) <= meeting
        })
        .count()
}

/// The roots in [0, 1] of c₀ + c₁τ + c₂τ² + c₃τ³: each interval between the roots of the
/// derivative is monotone, and a sign change in one is bisected to f64 precision.
fn unit_roots(c: [f64; 4]) -> [Option<f64>; 3] {
    let f = |x: f64| ((c[3] * x + c[2]) * x + c[1]) * x + c[0];
    // Stationary points: 3c₃τ² + 2c₂τ + c₁ = 0.
    let mut splits = [0.0, 1.0, 1.0, 1.0];
    let mut count = 1;
    let (qa, qb, qc) = (3.0 * c[3], 2.0 * c[2], c[1]);
    let mut stationary = |x: f64| {
        if x > 0.0 && x < 1.0 {
            splits[count] = x;
            count += 1;
        }
    };
    if qa != 0.0 {
        let disc = qb * qb - 4.0 * qa * qc;
        if disc >= 0.0 {
            let sq = disc.sqrt();
            stationary((-qb - sq) / (2.0 * qa));
            stationary((-qb + sq) / (2.0 * qa));
        }
    } else if qb != 0.0 {
        stationary(-qc / qb);
    }
    splits[1..count].sort_by(f64::total_cmp);
    splits[count] = 1.0;
    let mut roots = [None; 3];
    let mut found = 0;
    for k in 0..count {
        let (mut lo, mut hi) = (splits[k], splits[k + 1]);
        let (flo, fhi) = (f(lo), f(hi));
        let root = if flo == 0.0 {
            Some(lo)
        } else if fhi == 0.0 && k + 1 == count {
            Some(hi)
        } else if (flo < 0.0) != (fhi < 0.0) {
            let rising = flo < 0.0;
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if (f(mid) < 0.0) == rising {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            Some(0.5 * (lo + hi))
        } else {
            None
        };
        if root.is_some() && found < 3 {
            roots[found] = root;
            found += 1;
        }
    }
    roots
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f32, y: f32, z: f32) -> Vec3 {
        Vec3::new(x, y, z)
    }

    #[test]
    fn cubic_roots_in_the_unit_interval() {
        // (τ − 0.2)(τ − 0.5)(τ − 0.9) = τ³ − 1.6τ² + 0.73τ − 0.09.
        let roots = unit_roots([-0.09, 0.73, -1.6, 1.0]);
        let got: Vec<f64> = roots.into_iter().flatten().collect();
        assert_eq!(got.len(), 3, "{got:?}");
        for (r, want) in got.iter().zip([0.2, 0.5, 0.9]) {
            assert!((r - want).abs() < 1e-12, "{got:?}");
        }
        // (τ − 2)(τ − 3): roots outside [0, 1] only.
        assert!(unit_roots([6.0, -5.0, 1.0, 0.0])
            .iter()
            .all(|r| r.is_none()));
        // (τ − 1)(τ − 2): the root at the move's end counts.
        let end: Vec<f64> = unit_roots([2.0, -3.0, 1.0, 0.0])
            .into_iter()
            .flatten()
            .collect();
        assert_eq!(end, vec![1.0]);
    }

    #[test]
    fn a_segment_moved_through_another_meets_it_and_one_moved_past_its_end_does_not() {
        let b = [v(-1.0, 0.0, 0.0), v(1.0, 0.0, 0.0)];
        let a = [v(0.3, -1.0, 1.0), v(0.3, 1.0, 1.0)];
        let down = |p: [Vec3; 2], dz: f32, dx: f32| p.map(|q| q + v(dx, 0.0, dz));
        let from = [a[0], a[1], b[0], b[1]];
        let through = down(a, -2.0, 0.0);
        assert!(centrelines_meet(
            from,
            [through[0], through[1], b[0], b[1]],
            1e-6
        ));
        // Passing beyond b's end (x > 1) is round it, not through.
        let beyond = [a[0], a[1]].map(|q| q + v(1.5, 0.0, 0.0));
        let below = down(beyond, -2.0, 0.0);
        assert!(!centrelines_meet(
            [beyond[0], beyond[1], b[0], b[1]],
            [below[0], below[1], b[0], b[1]],
            1e-6
        ));
        // Nearly parallel (sine 0.08, as the pairs a tightened knot wraps at shallow
        // angles), one moved through the other: they have no useful line parameters, but
        // they meet.
        let c = [v(-0.5, -0.04, 1.0), v(0.5, 0.04, 1.0)];
        let c_down = down(c, -2.0, 0.0);
        assert!(centrelines_meet(
            [c[0], c[1], b[0], b[1]],
            [c_down[0], c_down[1], b[0], b[1]],
            1e-6
        ));
    }

    #[test]
    fn a_strand_pulled_through_a_bent_joint_meets_one_of_its_segments() {
        // Segments 0–1 and 1–2 bent at the joint p1 = origin, 60° between them; a strand
        // across the joint's bisector plane moves down through the joint.
        let (p0, p1, p2) = (v(-1.0, 0.5, 0.0), v(0.0, 0.0, 0.0), v(1.0, 0.5, 0.0));
        let strand = [v(0.0, -1.0, 0.3), v(0.0, 1.0, 0.3)];
        let moved = strand.map(|q| q + v(0.0, 0.0, -0.6));
        let meets = |s0: Vec3, s1: Vec3| {
            centrelines_meet(
                [strand[0], strand[1], s0, s1],
                [moved[0], moved[1], s0, s1],
                1e-6,
            )
        };
        assert!(meets(p0, p1) || meets(p1, p2));
        // Just inside the bend, it meets the second segment near its end.
        let strand = strand.map(|q| q + v(0.05, 0.0, 0.0));
        let moved = strand.map(|q| q + v(0.0, 0.0, -0.6));
        let (s0, s1) = (p1, p2);
        assert!(centrelines_meet(
            [strand[0], strand[1], s0, s1],
            [moved[0], moved[1], s0, s1],
            1e-6
        ));
    }
}
