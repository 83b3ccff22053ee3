//! The wound of a suture scene: the gap between its two tissue blocks, the figure a suture
//! closes. It is the closest distance between a particle of one block and a particle of the
//! other, less one particle spacing, so that two blocks laid with a gap g between their
//! faces start at g (their outer particles sit half a spacing inside each face) and read 0
//! where the edges meet.

use crate::math::Vec3;

/// The closest distance between a point of `a` and a point of `b` (infinite when either is
/// empty). The points of `a` are visited nearest `b`'s bounding box first, and the search
/// stops at the first whose distance to that box exceeds the closest pair found, so only
/// the points along the facing edges are compared with every point of `b`.
pub fn closest_distance(a: &[Vec3], b: &[Vec3]) -> f32 {
    let Some(first) = b.first() else {
        return f32::INFINITY;
    };
    let (lo, hi) = b
        .iter()
        .fold((*first, *first), |(lo, hi), p| (lo.inf(p), hi.sup(p)));
    let to_box = |p: &Vec3| (lo - p).sup(&(p - hi)).sup(&Vec3::zeros()).norm();
    let mut order: Vec<(f32, usize)> = a.iter().map(to_box).zip(0..).collect();
    order.sort_unstable_by(|x, y| x.0.total_cmp(&y.0));
    let mut best = f32::INFINITY;
    for (box_distance, i) in order {
        if box_distance >= best {
            break;
        }
        let p = a[i];
        let nearest = b
            .iter()
            .map(|q| (q - p).norm_squared())
            .fold(f32::INFINITY, f32::min);
        best = best.min(nearest.sqrt());
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The brute-force answer, every pair compared.
    fn brute(a: &[Vec3], b: &[Vec3]) -> f32 {
        a.iter()
            .flat_map(|p| b.iter().map(move |q| (q - p).norm()))
            .fold(f32::INFINITY, f32::min)
    }

    #[test]
    fn closest_distance_matches_every_pair_compared() {
        // Two jittered blocks of points 4 mm apart along x, the right one tilted.
        let mut a = Vec::new();
        let mut b = Vec::new();
        for i in 0..12 {
            for j in 0..9 {
                for k in 0..7 {
                    let jitter = ((i * 7 + j * 13 + k * 29) % 17) as f32 * 1e-5;
                    let (y, z) = (j as f32 * 1e-3, k as f32 * 1e-3);
                    a.push(Vec3::new(-0.002 - i as f32 * 1e-3 + jitter, y, z));
                    b.push(Vec3::new(
                        0.002 + i as f32 * 1e-3 - 0.3 * z + jitter,
                        y + jitter,
                        z,
                    ));
                }
            }
        }
        let fast = closest_distance(&a, &b);
        assert!(
            (fast - brute(&a, &b)).abs() < 1e-7,
            "{fast} vs {}",
            brute(&a, &b)
        );
        assert!(fast < 0.004 && fast > 0.001);
        assert_eq!(closest_distance(&a, &[]), f32::INFINITY);
    }
}
