//! The thread against itself: segment–segment contact, continuous, with friction.
//!
//! Two segments collide when the distance between their centrelines falls below 2r (the
//! thread's diameter). At 1 m/s a point moves 4 mm in a 4.2 ms substep, twenty radii of a
//! 3-0 thread, so a check of the end positions alone would let segments pass through each
//! other. Detection is therefore continuous in the way of Bridson et al. (2002) for cloth:
//!
//! 1. Broad phase, each iteration after the elastic solve: each segment's box swept from its
//!    substep-start to its current position (grown by 2r and half its own motion, for what
//!    the contact passes add), sorted along the axis where they spread most and swept
//!    (sweep and prune, Baraff 1992: no allocation once warm); pairs whose boxes overlap
//!    are candidates. A thread's boxes are a few segments long, so the sweep meets each
//!    box's chain neighbours and the strands that cross it; sorting one key per segment
//!    costs far less than hashing each box into every cell it covers and sorting those
//!    (measured: `bench thread`'s knot row, see `rod`'s module doc).
//! 2. For each candidate the side each segment must keep is taken at the substep's start,
//!    where the thread is known not to intersect itself. For segments crossing at an angle
//!    it is the sign of the distance of the two segments' lines along their common normal
//!    c = e_a × e_b: that sign changes only when one segment passes through the other (or
//!    round its end), and it is defined even while the closest points sit at a segment's end,
//!    as they do when a strand slides along its length onto another. For nearly parallel
//!    segments (lines within `PARALLEL_SINE` of each other, no common normal) it is the unit
//!    vector between the closest points of the start segments.
//! 3. Each iteration, after the elastic solve has moved the points, the broad phase is run
//!    again from the substep's start to the current points (the solve may move a point far
//!    beyond its prediction: a strand pulled taut round another), and each candidate pair is
//!    projected: if it is on its start side it must keep its closest points 2r apart
//!    (|x_b − x_a| ≥ 2r, pushed along x_b − x_a); if it crossed to the other side with its
//!    closest points inside both segments it passed through, and is pushed back along the
//!    side normal to 2r on its start side, however far it went. A plain distance constraint
//!    alone would push a crossed pair on through. No candidate is ever skipped: the pair
//!    that passed through furthest is the one that most needs its correction.
//! 4. Whether a pair passed through is also known exactly (`crossing`): its centrelines met
//!    an odd number of times on the straight way from the substep's start. This catches
//!    what the end test of step 3 cannot: a taut strand pulled through a *bent* joint
//!    (the lines' closest points land beyond both segments' ends) and pairs turned nearly
//!    parallel (no line parameters). It is tested once per broad phase, and again in the
//!    passes for pairs within two diameters, which a neighbour's push may have moved through.
//! 5. The contact passes (up to 8 Gauss–Seidel passes after each direct solve) sweep the pairs
//!    in opposite orders on successive passes (symmetric Gauss–Seidel). Swept always in chain
//!    order, the pairs further along have every pass's last word, and that bias pumps thread
//!    through a tight knot in the direction of the numbering: `config/knot.toml` pulled on
//!    slid its knot along the standing part, the other way with the thread numbered from its
//!    other end, until it came undone. With alternating sweeps the knot stays where it was
//!    tied in both numberings (`knot_toml_pulled_hard_stays_where_it_was_tied` and its
//!    renumbered twin in tests/thread_scene.rs).
//! 6. As a fail-safe on the points' moves, `CrossingGuard::keep_sides` (called by the solver
//!    after the rounds, against the substep's start, and after the length restoration, against
//!    the rounds' end) tests every pair whose swept boxes overlap (any meeting counts): the
//!    points of a pair that met keep half their move, round after round, give it up below an
//!    eighth, and after 8 rounds every free point returns to the safe state.
//!    `RodFrameReport::substeps_held_back` counts the substeps where it acted.
//!
//! Segments fewer than `1 + ⌈4r/l⌉` apart along the chain never collide: the chain between
//! them is shorter than two diameters, so that bent gently they touch. Segments two apart
//! do collide where segments are two diameters long or longer: a knot pulled hard folds the
//! thread tighter than a segment (config/knot.toml pulled to 85 mm a side closes its knot
//! to six segments of 2 mm), and its strands then lie two segments apart along the chain.

use super::crossing::pair_crossed;
use super::environment::friction_correction;
use super::state::Rod;
use crate::math::Vec3;
use nalgebra::{RealField, Vector3};

/// Reused buffers of the broad and narrow phase.
#[derive(Clone, Debug, Default)]
pub struct SelfContacts {
    lo: Vec<Vec3>,
    hi: Vec<Vec3>,
    /// Segments sorted by their box's lower corner along the sweep axis.
    order: Vec<u32>,
    pairs: Vec<(u32, u32)>,
    candidates: Vec<Candidate>,
    /// Whether the last `project` swept the candidates from the chain's far end.
    backward: bool,
}

#[derive(Clone, Copy, Debug)]
struct Candidate {
    a: u32,
    b: u32,
    /// The side to keep, from a towards b, taken at the substep's start.
    side: Side,
    /// Whether the centrelines crossed on the way from the substep's start to where the
    /// solve put them (`crossing`): true where the side test below cannot tell, through a
    /// bent joint or a pair turned nearly parallel.
    crossed: bool,
}

#[derive(Clone, Copy, Debug)]
enum Side {
    /// Segments at an angle: their unit common normal, oriented from a's line to b's.
    Crossing(Vec3),
    /// Nearly parallel segments: the unit vector between their closest points.
    Parallel(Vec3),
}

/// Sine of the angle between two segments below which they count as parallel: their common
/// normal c = e_a × e_b is then too short to give a direction (|c| = |e_a||e_b| sin θ).
const PARALLEL_SINE: f32 = 0.1;

impl SelfContacts {
    /// Least chain distance (in segments) between two segments that may collide.
    pub fn chain_gap(rod: &Rod) -> usize {
        let shortest = rod
            .rest_lengths
            .iter()
            .fold(f32::INFINITY, |a, &b| a.min(b));
        1 + (4.0 * rod.material.radius / shortest).ceil() as usize
    }

    /// Candidate pairs for the substep from `start` to the rod's current points.
    pub fn detect(&mut self, rod: &Rod, start: &[Vec3]) {
        let r = rod.material.radius;
        self.swept_pairs(rod, start);
        self.candidates.clear();
        for &(a, b) in &self.pairs {
            let (ai, bi) = (a as usize, b as usize);
            let (s, t) = closest_parameters(start[ai], start[ai + 1], start[bi], start[bi + 1]);
            let xa = start[ai] + (start[ai + 1] - start[ai]) * s;
            let xb = start[bi] + (start[bi + 1] - start[bi]) * t;
            let d = xb - xa;
            let (ea, eb) = (start[ai + 1] - start[ai], start[bi + 1] - start[bi]);
            let c = ea.cross(&eb);
            let side = if c.norm() > PARALLEL_SINE * ea.norm() * eb.norm() {
                // (x_b − x_a)·c is the same for any two points of the lines: the signed
                // distance of b's line from a's. Exactly 0 (lines meeting: segments flat
                // on a table, end to side) leaves either side free; pick one.
                let c = c.normalize();
                Side::Crossing(if d.dot(&c) < 0.0 { -c } else { c })
            } else {
                match d.try_normalize(1e-3 * r) {
                    Some(n) => Side::Parallel(n),
                    // Parallel and touching along their length: no side to keep.
                    None => continue,
                }
            };
            let crossed = pair_crossed(start, &rod.points, ai, bi, 2.0 * r);
            self.candidates.push(Candidate {
                a,
                b,
                side,
                crossed,
            });
        }
    }

    /// Broad phase: the pairs of segments, at least `chain_gap` apart along the chain, whose
    /// boxes swept from `start` to the rod's current points (grown by a diameter and half
    /// their motion) overlap, sorted and without repeats.
    pub(crate) fn swept_pairs(&mut self, rod: &Rod, start: &[Vec3]) -> &[(u32, u32)] {
        let n = rod.segments();
        let r = rod.material.radius;
        let gap = Self::chain_gap(rod);
        self.lo.clear();
        self.hi.clear();
        for j in 0..n {
            let (a0, a1, b0, b1) = (start[j], start[j + 1], rod.points[j], rod.points[j + 1]);
            let motion = (b0 - a0).norm().max((b1 - a1).norm());
            let grow = Vec3::repeat(2.0 * r + 0.5 * motion);
            let lo = a0.inf(&a1).inf(&b0).inf(&b1) - grow;
            let hi = a0.sup(&a1).sup(&b0).sup(&b1) + grow;
            self.lo.push(lo);
            self.hi.push(hi);
        }
        // Sweep along the axis where the boxes spread most: along it a box overlaps the
        // fewest others.
        let spread = |axis: usize| {
            let (lo, hi) = self.lo.iter().fold((f32::MAX, f32::MIN), |(a, b), p| {
                (a.min(p[axis]), b.max(p[axis]))
            });
            hi - lo
        };
        let axis = (0..3)
            .max_by(|&a, &b| spread(a).total_cmp(&spread(b)))
            .unwrap_or(0);
        self.order.clear();
        self.order.extend(0..n as u32);
        let lo = &self.lo;
        self.order
            .sort_unstable_by(|&a, &b| lo[a as usize][axis].total_cmp(&lo[b as usize][axis]));
        self.pairs.clear();
        let overlaps = |lo: &[Vec3], hi: &[Vec3], a: usize, b: usize| {
            (0..3).all(|k| lo[a][k] <= hi[b][k] && lo[b][k] <= hi[a][k])
        };
        for (k, &a) in self.order.iter().enumerate() {
            let a = a as usize;
            let reach = self.hi[a][axis];
            for &b in &self.order[k + 1..] {
                let b = b as usize;
                if self.lo[b][axis] > reach {
                    break;
                }
                let (a, b) = (a.min(b), a.max(b));
                if b - a >= gap && overlaps(&self.lo, &self.hi, a, b) {
                    self.pairs.push((a as u32, b as u32));
                }
            }
        }
        self.pairs.sort_unstable();
        &self.pairs
    }

    /// Candidate pairs found by the last `detect`.
    pub fn candidate_count(&self) -> usize {
        self.candidates.len()
    }

    /// Projects every candidate pair apart, back to its start side if it crossed, with
    /// friction `mu` relative to the substep-start points `start`. Pairs on their side are
    /// pushed apart only when closer than `least` diameters, and then to that distance;
    /// pairs that crossed always go back to a diameter. Returns the number of active
    /// contacts.
    ///
    /// Successive calls sweep the pairs in opposite orders (symmetric Gauss–Seidel). A
    /// sweep always in chain order leaves every pass's last word to the pairs further
    /// along, a bias that pumps thread through a tight knot in the direction of the
    /// numbering; alternating sweeps have none, and a pulled knot jams where it was tied
    /// (tests/thread_scene.rs, `knot_toml_pulled_hard_stays_where_it_was_tied`).
    pub fn project(&mut self, rod: &mut Rod, start: &[Vec3], mu: f32, least: f32) -> u32 {
        let diameter = 2.0 * rod.material.radius;
        let mut active = 0;
        self.backward = !self.backward;
        let count = self.candidates.len();
        for k in 0..count {
            let c = &self.candidates[if self.backward { count - 1 - k } else { k }];
            let (a, b) = (c.a as usize, c.b as usize);
            let p = &rod.points;
            let (s, t) = closest_parameters(p[a], p[a + 1], p[b], p[b + 1]);
            let d = (p[b] + (p[b + 1] - p[b]) * t) - (p[a] + (p[a + 1] - p[a]) * s);
            // Passes move points by less than a diameter, but pushing one pair apart can push
            // a neighbouring pair through: near pairs are tested afresh.
            let crossed =
                c.crossed || (d.norm() < 2.0 * diameter && pair_crossed(start, p, a, b, diameter));
            // The side normal now: for crossing segments their current common normal,
            // oriented as at the start (a substep turns a segment by far less than 90°).
            let (side_normal, passed) = match c.side {
                Side::Crossing(c0) => {
                    let (ea, eb) = (p[a + 1] - p[a], p[b + 1] - p[b]);
                    let c = ea.cross(&eb);
                    let normal = if c.norm() > PARALLEL_SINE * ea.norm() * eb.norm() {
                        let n = c.normalize();
                        if n.dot(&c0) < 0.0 {
                            -n
                        } else {
                            n
                        }
                    } else {
                        c0
                    };
                    // On the other side where the lines meet within both segments:
                    // through. On the other side by an end: round it, which is allowed.
                    // The lines' own closest points, not the segments' (clamped to the ends),
                    // and a diameter's margin past each end: a strand pushed through the
                    // joint of two segments has its closest points at the joint, an end of
                    // both pairs it crossed.
                    let margin = |e: Vec3| diameter / e.norm().max(f32::EPSILON);
                    let through = line_parameters(p[a], ea, p[b], eb).is_some_and(|(ls, lt)| {
                        let (ma, mb) = (margin(ea), margin(eb));
                        ls > -ma && ls < 1.0 + ma && lt > -mb && lt < 1.0 + mb
                    });
                    (normal, (through || crossed) && d.dot(&normal) < 0.0)
                }
                Side::Parallel(n0) => {
                    // Parallel segments that slid past each other's ends are beside each
                    // other, not through: their closest points are offset along the chain.
                    let along = d.dot(&n0);
                    let sideways = (d - n0 * along).norm();
                    (
                        n0,
                        along < 0.0 && (crossed || sideways <= diameter + 0.5 * d.norm()),
                    )
                }
            };
            let (n, depth) = if passed {
                (side_normal, diameter - d.dot(&side_normal))
            } else {
                let distance = d.norm();
                if distance >= least * diameter {
                    continue;
                }
                let n = if distance > 1e-3 * diameter {
                    d / distance
                } else {
                    side_normal
                };
                (n, least * diameter - distance)
            };
            // Barycentric inverse-mass weights of the four points.
            let w = [
                rod.inv_mass[a] * (1.0 - s),
                rod.inv_mass[a + 1] * s,
                rod.inv_mass[b] * (1.0 - t),
                rod.inv_mass[b + 1] * t,
            ];
            let denom = w[0] * (1.0 - s) + w[1] * s + w[2] * (1.0 - t) + w[3] * t;
            if denom <= 0.0 {
                continue;
            }
            apply(rod, a, b, w, n * (depth / denom));
            // Friction on the relative displacement of the two contact points.
            let p = &rod.points;
            let xa = p[a] + (p[a + 1] - p[a]) * s;
            let xb = p[b] + (p[b + 1] - p[b]) * t;
            let xa0 = start[a] + (start[a + 1] - start[a]) * s;
            let xb0 = start[b] + (start[b + 1] - start[b]) * t;
            let rel = (xb - xb0) - (xa - xa0);
            let slip = rel - n * rel.dot(&n);
            apply(
                rod,
                a,
                b,
                w,
                friction_correction(slip, depth, mu) * (1.0 / denom),
            );
            active += 1;
        }
        active
    }
}

/// Moves segment b's points along `impulse` and segment a's against it, each by its weight.
fn apply(rod: &mut Rod, a: usize, b: usize, w: [f32; 4], impulse: Vec3) {
    rod.points[a] -= impulse * w[0];
    rod.points[a + 1] -= impulse * w[1];
    rod.points[b] += impulse * w[2];
    rod.points[b + 1] += impulse * w[3];
}

/// Parameters (s, t) ∈ [0, 1]² of the closest points of segments p0–p1 and q0–q1
/// (Ericson, "Real-Time Collision Detection", §5.1.9), in the precision of the points: f32
/// for the contact passes, f64 for `crossing` (a crossing's distance at its root is
/// ~1e-15 m, far below f32's resolution of the thread's coordinates).
pub fn closest_parameters<T: RealField + Copy>(
    p0: Vector3<T>,
    p1: Vector3<T>,
    q0: Vector3<T>,
    q1: Vector3<T>,
) -> (T, T) {
    let (zero, one) = (T::zero(), T::one());
    // Squared lengths up to `eps` are points. Lines count as parallel where a·e − b² is at
    // most `eps`·a·e; a nonzero a·e − b² is at least about a rounding step of a·e (~1e-7·a·e in
    // f32, ~1e-16·a·e in f64), so in either precision this turns away only a vanishing or
    // negative denominator.
    let eps: T = nalgebra::convert(1e-20);
    let (d1, d2, r) = (p1 - p0, q1 - q0, p0 - q0);
    let (a, e, f) = (d1.norm_squared(), d2.norm_squared(), d2.dot(&r));
    if a <= eps && e <= eps {
        return (zero, zero);
    }
    if a <= eps {
        return (zero, (f / e).clamp(zero, one));
    }
    let c = d1.dot(&r);
    if e <= eps {
        return ((-c / a).clamp(zero, one), zero);
    }
    let b = d1.dot(&d2);
    let denom = a * e - b * b;
    let mut s = if denom > eps * a * e {
        ((b * f - c * e) / denom).clamp(zero, one)
    } else {
        zero
    };
    let mut t = (b * s + f) / e;
    if t < zero {
        t = zero;
        s = (-c / a).clamp(zero, one);
    } else if t > one {
        t = one;
        s = ((b - c) / a).clamp(zero, one);
    }
    (s, t)
}

/// Distance between the centrelines of segments p0–p1 and q0–q1: between their closest
/// points (`closest_parameters`).
pub fn segment_distance<T: RealField + Copy>(
    p0: Vector3<T>,
    p1: Vector3<T>,
    q0: Vector3<T>,
    q1: Vector3<T>,
) -> T {
    let (s, t) = closest_parameters(p0, p1, q0, q1);
    ((q0 + (q1 - q0) * t) - (p0 + (p1 - p0) * s)).norm()
}

/// Parameters (s, t) of the closest points of the lines p0 + s·d1 and q0 + t·d2, unclamped;
/// None for parallel lines.
fn line_parameters(p0: Vec3, d1: Vec3, q0: Vec3, d2: Vec3) -> Option<(f32, f32)> {
    let r = p0 - q0;
    let (a, b, e) = (d1.norm_squared(), d1.dot(&d2), d2.norm_squared());
    let (c, f) = (d1.dot(&r), d2.dot(&r));
    let denom = a * e - b * b;
    if denom <= PARALLEL_SINE * PARALLEL_SINE * a * e {
        return None;
    }
    let s = (b * f - c * e) / denom;
    Some((s, (b * s + f) / e))
}

/// Smallest centreline distance between two segments at least `chain_gap` apart along the
/// chain (brute force, for tests and diagnostics).
pub fn min_self_distance(rod: &Rod) -> f32 {
    let gap = SelfContacts::chain_gap(rod);
    let p = &rod.points;
    let mut best = f32::INFINITY;
    for a in 0..rod.segments() {
        for b in a + gap..rod.segments() {
            best = best.min(segment_distance(p[a], p[a + 1], p[b], p[b + 1]));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rod::ThreadMaterial;

    /// Every pair of segments at least `chain_gap` apart whose swept boxes overlap, by
    /// testing all pairs.
    fn brute_force_pairs(rod: &Rod, start: &[Vec3], contacts: &SelfContacts) -> Vec<(u32, u32)> {
        let gap = SelfContacts::chain_gap(rod);
        let n = rod.segments();
        let (lo, hi) = (&contacts.lo, &contacts.hi);
        let mut pairs = Vec::new();
        for a in 0..n {
            for b in a + gap..n {
                if (0..3).all(|k| lo[a][k] <= hi[b][k] && lo[b][k] <= hi[a][k]) {
                    pairs.push((a as u32, b as u32));
                }
            }
        }
        assert_eq!(lo.len(), n, "boxes of the rod from {} points", start.len());
        pairs
    }

    #[test]
    fn sweep_and_prune_finds_every_overlapping_pair() {
        // A helix of 3-0 thread wound tighter than its pitch in places, moved by a random
        // step per point: strands lie beside, across and on top of each other.
        use rand::{rngs::ChaCha8Rng, Rng, SeedableRng};
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut jitter = || ((rng.next_u64() >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 1e-3;
        let points: Vec<Vec3> = (0..300)
            .map(|i| {
                let t = i as f32 * 0.25;
                Vec3::new(0.004 * t.cos(), 0.004 * t.sin(), 0.0003 * t)
            })
            .collect();
        let rod = {
            let mut rod = Rod::from_polyline(ThreadMaterial::nylon_3_0(), points.clone());
            for p in &mut rod.points {
                *p += Vec3::new(jitter(), jitter(), jitter());
            }
            rod
        };
        let mut contacts = SelfContacts::default();
        let swept = contacts.swept_pairs(&rod, &points).to_vec();
        let expected = brute_force_pairs(&rod, &points, &contacts);
        assert!(swept.len() > 300, "a tangle: {} pairs", swept.len());
        assert_eq!(swept, expected);
    }
}
