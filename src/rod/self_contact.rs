//! The thread against itself: segment–segment contact, continuous, with friction.
//!
//! Two segments collide when the distance between their centrelines falls below 2r (the
//! thread's diameter). At 1 m/s a point moves 4 mm in a 4.2 ms substep, twenty radii of a
//! 3-0 thread, so a check of the end positions alone would let segments pass through each
//! other. Detection is therefore continuous in the way of Bridson et al. (2002) for cloth:
//!
//! 1. Broad phase, each iteration after the elastic solve: each segment's box swept from its
//!    substep-start to its current position (grown by 2r and half its own motion, for what
//!    the contact passes add), hashed into a uniform grid (Teschner et al. 2003, sorted
//!    keys instead of a hash table: no allocation once warm); pairs sharing a cell whose
//!    boxes overlap are candidates.
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
//!
//! Segments fewer than `1 + ⌈4r/l⌉` apart along the chain never collide: the chain between
//! them is shorter than two diameters, so that bent gently they touch. Segments two apart
//! do collide where segments are two diameters long or longer: a knot pulled hard folds the
//! thread tighter than a segment (config/knot.toml pulled to 85 mm a side closes its knot
//! to six segments of 2 mm), and with them left out its strands passed through each other
//! there (the knot came undone at 16.5 s; tests/thread_scene.rs).

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
    /// (cell key, segment), sorted by key.
    cells: Vec<(u64, u32)>,
    /// Segments whose swept box covers too many cells to hash; tested against all.
    large: Vec<u32>,
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

/// Above this many cells a segment's box goes to the brute-force list.
const MAX_CELLS_PER_SEGMENT: i64 = 64;

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
        let mut widest = 0.0f32;
        for j in 0..n {
            let (a0, a1, b0, b1) = (start[j], start[j + 1], rod.points[j], rod.points[j + 1]);
            let motion = (b0 - a0).norm().max((b1 - a1).norm());
            let grow = Vec3::repeat(2.0 * r + 0.5 * motion);
            let lo = a0.inf(&a1).inf(&b0).inf(&b1) - grow;
            let hi = a0.sup(&a1).sup(&b0).sup(&b1) + grow;
            widest = widest.max(rod.rest_lengths[j]);
            self.lo.push(lo);
            self.hi.push(hi);
        }
        // Cells about a segment plus its margin: a resting segment spans a few.
        let cell = widest + 4.0 * r;
        let index = |x: f32| (x / cell).floor() as i64;
        self.cells.clear();
        self.large.clear();
        for j in 0..n {
            let (lo, hi) = (self.lo[j], self.hi[j]);
            let (i0, i1) = (
                [index(lo.x), index(lo.y), index(lo.z)],
                [index(hi.x), index(hi.y), index(hi.z)],
            );
            let count = (0..3).map(|a| i1[a] - i0[a] + 1).product::<i64>();
            if count > MAX_CELLS_PER_SEGMENT {
                self.large.push(j as u32);
                continue;
            }
            for x in i0[0]..=i1[0] {
                for y in i0[1]..=i1[1] {
                    for z in i0[2]..=i1[2] {
                        self.cells.push((cell_key(x, y, z), j as u32));
                    }
                }
            }
        }
        self.cells.sort_unstable();
        self.pairs.clear();
        let overlaps = |lo: &[Vec3], hi: &[Vec3], a: usize, b: usize| {
            (0..3).all(|k| lo[a][k] <= hi[b][k] && lo[b][k] <= hi[a][k])
        };
        let mut run = 0;
        while run < self.cells.len() {
            let key = self.cells[run].0;
            let end = run
                + self.cells[run..]
                    .iter()
                    .take_while(|(k, _)| *k == key)
                    .count();
            for p in run..end {
                for q in p + 1..end {
                    let (a, b) = (self.cells[p].1 as usize, self.cells[q].1 as usize);
                    let (a, b) = (a.min(b), a.max(b));
                    if b - a >= gap && overlaps(&self.lo, &self.hi, a, b) {
                        self.pairs.push((a as u32, b as u32));
                    }
                }
            }
            run = end;
        }
        for &l in &self.large {
            let l = l as usize;
            for j in 0..n {
                if l.abs_diff(j) >= gap && overlaps(&self.lo, &self.hi, l, j) {
                    self.pairs.push((l.min(j) as u32, l.max(j) as u32));
                }
            }
        }
        self.pairs.sort_unstable();
        self.pairs.dedup();
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

fn cell_key(x: i64, y: i64, z: i64) -> u64 {
    (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
        ^ (z as u64).wrapping_mul(0x1656_67B1_9E37_79F9)
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
