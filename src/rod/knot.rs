//! Whether a thread is knotted, from its centreline alone: the knot determinant |Δ(−1)|, the
//! Alexander polynomial at t = −1, of the centreline closed up far away.
//!
//! The open centreline is closed "at infinity": each end is carried radially away from the
//! centroid to a sphere ten times the thread's extent, and the two points there are joined
//! along that sphere. For a knot whose tails leave its core, that closure adds no crossing
//! in space, so the closed curve's knot type is the thread's. Projected along a generic
//! direction, the curve's crossings give its diagram: arcs run from one under-pass to the
//! next, and each crossing says 2·(over arc) − (arc in) − (arc out) = 0 (Fox colouring, the
//! Alexander relation at t = −1). The determinant of any (n−1)×(n−1) minor of that n×n
//! matrix is, up to sign, the knot determinant: 1 for the unknot (no knot at all), 3 for the
//! trefoil (an overhand knot), 5 for the figure-eight, 9 for square and granny knots. It does
//! not depend on the projection, so it is a knot invariant; a pulled or shaken diagram with
//! more crossings gives the same number while the knot holds.

use nalgebra::Vector3;

type V3 = Vector3<f64>;

/// A projection direction no shipped scene lines up with (axes and diagonals are avoided,
/// so that no two segments project onto each other).
const VIEW: [f64; 3] = [0.2361, 0.4472, 0.8628];

/// The knot determinant of the open polyline `points` closed up far away (1: unknotted).
pub fn knot_determinant(points: &[V3]) -> u128 {
    let closed = close_far_away(points);
    let crossings = crossings(&closed);
    determinant_of(&crossings)
}

/// What a knot determinant tells of the simplest knot that has it.
pub fn knot_name(determinant: u128) -> &'static str {
    match determinant {
        1 => "no knot",
        3 => "trefoil",
        5 => "figure-eight",
        9 => "square or granny",
        _ => "other knot",
    }
}

/// Points of `open` followed by a return path outside its bounding sphere.
fn close_far_away(open: &[V3]) -> Vec<V3> {
    let n = open.len();
    if n < 2 {
        return open.to_vec();
    }
    let centroid = open.iter().sum::<V3>() / n as f64;
    let extent = open
        .iter()
        .map(|p| (p - centroid).norm())
        .fold(0.0, f64::max)
        .max(1e-9);
    let far = 10.0 * extent;
    let outward = |p: &V3| {
        (p - centroid)
            .try_normalize(1e-12)
            .unwrap_or_else(|| V3::new(VIEW[1], -VIEW[0], 0.0).normalize())
    };
    let a = outward(&open[n - 1]);
    let b = outward(&open[0]);
    let mut closed = open.to_vec();
    // Along the sphere from a to b (through a perpendicular when they are opposite).
    let mid = (a + b)
        .try_normalize(1e-6)
        .unwrap_or_else(|| a.cross(&V3::from(VIEW)).normalize());
    for w in [a, (a + mid).normalize(), mid, (mid + b).normalize(), b] {
        closed.push(centroid + w * far);
    }
    closed
}

/// One crossing of the projected closed curve: the under- and over-passing positions as
/// (segment index + fraction along it).
struct Crossing {
    under: f64,
    over: f64,
}

fn crossings(closed: &[V3]) -> Vec<Crossing> {
    let view = V3::from(VIEW).normalize();
    let u = view.cross(&V3::x()).normalize();
    let v = view.cross(&u);
    let flat: Vec<(f64, f64, f64)> = closed
        .iter()
        .map(|p| (p.dot(&u), p.dot(&v), p.dot(&view)))
        .collect();
    let n = flat.len();
    let mut out = Vec::new();
    for i in 0..n {
        let (a0, a1) = (flat[i], flat[(i + 1) % n]);
        for j in i + 2..n {
            if (j + 1) % n == i {
                continue; // neighbours through the closing segment
            }
            let (b0, b1) = (flat[j], flat[(j + 1) % n]);
            let (dax, day) = (a1.0 - a0.0, a1.1 - a0.1);
            let (dbx, dby) = (b1.0 - b0.0, b1.1 - b0.1);
            let denom = dax * dby - day * dbx;
            if denom.abs() < 1e-300 {
                continue;
            }
            let (ex, ey) = (b0.0 - a0.0, b0.1 - a0.1);
            let s = (ex * dby - ey * dbx) / denom;
            let t = (ex * day - ey * dax) / denom;
            if !(0.0..1.0).contains(&s) || !(0.0..1.0).contains(&t) {
                continue;
            }
            let height_a = a0.2 + s * (a1.2 - a0.2);
            let height_b = b0.2 + t * (b1.2 - b0.2);
            let (pa, pb) = (i as f64 + s, j as f64 + t);
            out.push(if height_a > height_b {
                Crossing {
                    under: pb,
                    over: pa,
                }
            } else {
                Crossing {
                    under: pa,
                    over: pb,
                }
            });
        }
    }
    out
}

/// |det| of the colouring matrix's first minor for a diagram with `crossings`.
fn determinant_of(crossings: &[Crossing]) -> u128 {
    let n = crossings.len();
    if n < 3 {
        // A diagram of fewer than three crossings is of the unknot.
        return 1;
    }
    // Arcs start at the under-passes, in order along the curve: arc k runs from the k-th
    // under-pass to the next.
    let mut unders: Vec<f64> = crossings.iter().map(|c| c.under).collect();
    unders.sort_by(f64::total_cmp);
    // The arc holding curve position `x` (not an under-pass itself).
    let arc_of = |x: f64| {
        let k = unders.partition_point(|&u| u <= x);
        if k == 0 {
            n - 1
        } else {
            k - 1
        }
    };
    let mut matrix = vec![vec![0i128; n]; n];
    for (row, c) in crossings.iter().enumerate() {
        let k = unders.partition_point(|&u| u < c.under);
        let arc_out = k % n;
        let arc_in = (k + n - 1) % n;
        let over = arc_of(c.over);
        matrix[row][over] += 2;
        matrix[row][arc_in] -= 1;
        matrix[row][arc_out] -= 1;
    }
    // Any first minor: drop the last row and column.
    let minor: Vec<Vec<i128>> = matrix[..n - 1]
        .iter()
        .map(|r| r[..n - 1].to_vec())
        .collect();
    bareiss_determinant(minor).unsigned_abs()
}

/// Exact determinant of an integer matrix by fraction-free (Bareiss) elimination.
fn bareiss_determinant(mut m: Vec<Vec<i128>>) -> i128 {
    let n = m.len();
    if n == 0 {
        return 1;
    }
    let mut sign = 1;
    let mut previous = 1i128;
    for k in 0..n - 1 {
        if m[k][k] == 0 {
            let Some(swap) = (k + 1..n).find(|&r| m[r][k] != 0) else {
                return 0;
            };
            m.swap(k, swap);
            sign = -sign;
        }
        for i in k + 1..n {
            for j in k + 1..n {
                m[i][j] = (m[i][j] * m[k][k] - m[i][k] * m[k][j]) / previous;
            }
        }
        previous = m[k][k];
    }
    sign * m[n - 1][n - 1]
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    /// An open curve: the closed curve `f` cut open at `t0`, where it is furthest from the
    /// z axis, and its ends drawn out radially as long tails, as a knotted thread's are.
    fn open_curve(f: impl Fn(f64) -> V3, t0: f64, samples: usize) -> Vec<V3> {
        let mut p: Vec<V3> = (0..samples)
            .map(|k| f(t0 + 0.01 + (TAU - 0.02) * k as f64 / (samples - 1) as f64))
            .collect();
        let cut = f(t0);
        let out = V3::new(cut.x, cut.y, 0.0).normalize() * 0.5;
        let (first, last) = (p[0], p[samples - 1]);
        let mut curve: Vec<V3> = (1..=10).rev().map(|k| first + out * k as f64).collect();
        curve.append(&mut p);
        curve.extend((1..=10).map(|k| last + out * k as f64));
        curve
    }

    /// Furthest from the z axis (radius 3) at t = π/3.
    fn trefoil(t: f64) -> V3 {
        V3::new(
            t.sin() + 2.0 * (2.0 * t).sin(),
            t.cos() - 2.0 * (2.0 * t).cos(),
            -(3.0 * t).sin(),
        )
    }

    /// Furthest from the z axis (radius 3) at t = 0.
    fn figure_eight(t: f64) -> V3 {
        V3::new(
            (2.0 + (2.0 * t).cos()) * (3.0 * t).cos(),
            (2.0 + (2.0 * t).cos()) * (3.0 * t).sin(),
            (4.0 * t).sin(),
        )
    }

    #[test]
    fn a_straight_or_looped_thread_is_unknotted() {
        let straight: Vec<V3> = (0..50).map(|k| V3::new(k as f64, 0.0, 0.0)).collect();
        assert_eq!(knot_determinant(&straight), 1);
        // A flat coil of three turns that rises as it goes: many crossings, no knot.
        let coil: Vec<V3> = (0..300)
            .map(|k| {
                let t = 3.0 * TAU * k as f64 / 299.0;
                V3::new(t.cos(), t.sin(), 0.05 * t)
            })
            .collect();
        assert_eq!(knot_determinant(&coil), 1);
    }

    #[test]
    fn a_trefoil_is_three_and_a_figure_eight_five() {
        for samples in [60, 200] {
            assert_eq!(
                knot_determinant(&open_curve(trefoil, TAU / 6.0, samples)),
                3
            );
            assert_eq!(knot_determinant(&open_curve(figure_eight, 0.0, samples)), 5);
        }
        // Its mirror image and a shaken copy are the same knot.
        let mirrored: Vec<V3> = open_curve(trefoil, TAU / 6.0, 120)
            .iter()
            .map(|p| V3::new(p.x, p.y, -p.z))
            .collect();
        assert_eq!(knot_determinant(&mirrored), 3);
        let shaken: Vec<V3> = open_curve(trefoil, TAU / 6.0, 120)
            .iter()
            .enumerate()
            .map(|(k, p)| p + V3::new(0.05, -0.04, 0.03) * ((k * 7919) % 13) as f64 / 13.0)
            .collect();
        assert_eq!(knot_determinant(&shaken), 3);
    }

    #[test]
    fn bareiss_matches_known_determinants() {
        assert_eq!(bareiss_determinant(vec![vec![2, -1], vec![-1, 2]]), 3);
        assert_eq!(
            bareiss_determinant(vec![vec![0, 1, 0], vec![1, 0, 0], vec![0, 0, 5]]),
            -5
        );
        assert_eq!(bareiss_determinant(vec![vec![1, 2], vec![2, 4]]), 0);
    }
}
