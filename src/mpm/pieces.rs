//! How many separate pieces the tissue is in: connected components of particles, two
//! particles linked when they are nearer than one grid cell and no crack lies between them
//! (a crack face touching the face across it is still two pieces; see [`super::crack`]).

use super::crack::separates;
use super::Vec3;
use std::collections::HashMap;

/// Number of connected pieces of the particles at `x` with cracks `crack` (empty: none cut),
/// linking neighbours nearer than `dx` (m).
pub fn count(x: &[Vec3], crack: &[Vec3], dx: f32) -> usize {
    label(x, crack, dx)
        .iter()
        .max()
        .map_or(0, |&m| m as usize + 1)
}

/// The piece of each particle, numbered 0, 1, ... in order of each piece's first particle.
pub fn label(x: &[Vec3], crack: &[Vec3], dx: f32) -> Vec<u32> {
    let cell = |p: &Vec3| (p / dx).map(|c| c.floor() as i32);
    let mut cells: HashMap<[i32; 3], Vec<u32>> = HashMap::new();
    for (i, p) in x.iter().enumerate() {
        let c = cell(p);
        cells.entry([c.x, c.y, c.z]).or_default().push(i as u32);
    }
    let mut parent: Vec<u32> = (0..x.len() as u32).collect();
    fn root(parent: &mut [u32], mut i: u32) -> u32 {
        while parent[i as usize] != i {
            let up = parent[parent[i as usize] as usize];
            parent[i as usize] = up;
            i = up;
        }
        i
    }
    let cut = |i: usize| crack.get(i).copied().unwrap_or_else(Vec3::zeros);
    let dx2 = dx * dx;
    for (i, p) in x.iter().enumerate() {
        let c = cell(p);
        for (a, b, d) in
            (-1..=1).flat_map(|a| (-1..=1).flat_map(move |b| (-1..=1).map(move |d| (a, b, d))))
        {
            let Some(near) = cells.get(&[c.x + a, c.y + b, c.z + d]) else {
                continue;
            };
            for &j in near {
                let j = j as usize;
                if j <= i {
                    continue;
                }
                let r = x[j] - p;
                if r.norm_squared() >= dx2 || separates(cut(i), r) || separates(cut(j), -r) {
                    continue;
                }
                let (ri, rj) = (root(&mut parent, i as u32), root(&mut parent, j as u32));
                if ri != rj {
                    parent[ri as usize] = rj;
                }
            }
        }
    }
    let mut number = HashMap::new();
    (0..x.len() as u32)
        .map(|i| {
            let r = root(&mut parent, i);
            let next = number.len() as u32;
            *number.entry(r).or_insert(next)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(n: usize, start: f32, spacing: f32) -> Vec<Vec3> {
        (0..n)
            .map(|i| Vec3::new(start + i as f32 * spacing, 0.0, 0.0))
            .collect()
    }

    #[test]
    fn gaps_and_cracks_split_pieces() {
        let dx = 0.002;
        // Two rows half a cell apart inside, 1.5 cells apart between them.
        let mut x = row(5, 0.0, 0.001);
        x.extend(row(5, 0.007, 0.001));
        assert_eq!(count(&x, &[], dx), 2);
        // One row of six particles 0.6 cells apart (second neighbours beyond a cell).
        let x = row(6, 0.0, 0.0012);
        let mut crack = vec![Vec3::zeros(); 6];
        assert_eq!(count(&x, &crack, dx), 1);
        // Either particle's crack is enough to unlink a pair: particle 2 alone is cut, by
        // a plane halfway to particle 3.
        crack[2] = Vec3::new(-0.0006, 0.0, 0.0);
        assert_eq!(count(&x, &crack, dx), 2);
        assert_eq!(label(&x, &crack, dx), vec![0, 0, 0, 1, 1, 1]);
        // A crack plane beyond the neighbour leaves the pair linked.
        crack[2] = Vec3::new(-0.0018, 0.0, 0.0);
        assert_eq!(count(&x, &crack, dx), 1);
    }
}
