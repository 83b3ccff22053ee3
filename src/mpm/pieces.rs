//! How many separate pieces the tissue is in: connected components of particles, two
//! particles linked when they are nearer than one grid cell and no crack lies between them
//! (a crack face touching the face across it is still two pieces; see [`super::crack`]).
//!
//! Torn-through material (damage ≥ [`TORN`]) links nothing: it is the tear. Each torn
//! particle belongs to the piece of its nearest intact neighbour within a cell (the tear's
//! faces), so that the band of torn particles neither bridges the pieces on either side nor
//! counts as pieces of its own; a torn particle with no intact neighbour is in no piece
//! ([`NO_PIECE`]).
//!
//! Under total Lagrangian MPM the count is taken once, on the rest configuration
//! ([`crate::world::World::pieces`]): its particles interact through the nodes they share
//! at rest however far apart they are pulled, so distances now say nothing of its
//! connectivity (a 10 mm-thick liver lifted 25 mm spaces particles past a cell while it still
//! pulls as one piece).

use super::crack::separates;
use super::damage::TORN;
use super::Vec3;
use std::collections::HashMap;

/// The label of a torn particle with no intact neighbour within a cell.
pub const NO_PIECE: u32 = u32::MAX;

/// Number of connected pieces of the particles at `x` with cracks `crack` (empty: none cut),
/// linking neighbours nearer than `dx` (m).
pub fn count(x: &[Vec3], crack: &[Vec3], dx: f32) -> usize {
    count_torn(x, crack, &[], dx)
}

/// [`count`] with damage `damage` (empty: none): torn-through particles link nothing.
pub fn count_torn(x: &[Vec3], crack: &[Vec3], damage: &[f32], dx: f32) -> usize {
    label_torn(x, crack, damage, dx)
        .iter()
        .filter(|&&l| l != NO_PIECE)
        .max()
        .map_or(0, |&m| m as usize + 1)
}

/// The piece of each particle, numbered 0, 1, ... in order of each piece's first particle.
pub fn label(x: &[Vec3], crack: &[Vec3], dx: f32) -> Vec<u32> {
    label_torn(x, crack, &[], dx)
}

/// [`label`] with damage `damage` (empty: none; see the module docs): torn particles with
/// no intact neighbour are [`NO_PIECE`].
pub fn label_torn(x: &[Vec3], crack: &[Vec3], damage: &[f32], dx: f32) -> Vec<u32> {
    let torn = |i: usize| damage.get(i).is_some_and(|&d| d >= TORN);
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
    // The nearest intact neighbour of each torn particle: (distance², index).
    let mut face: Vec<Option<(f32, u32)>> = vec![None; if damage.is_empty() { 0 } else { x.len() }];
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
                let r2 = r.norm_squared();
                if r2 >= dx2 || separates(cut(i), r) || separates(cut(j), -r) {
                    continue;
                }
                match (torn(i), torn(j)) {
                    (false, false) => {}
                    (true, true) => continue,
                    (torn_i, _) => {
                        let (t, intact) = if torn_i { (i, j) } else { (j, i) };
                        if face[t].is_none_or(|(best, _)| r2 < best) {
                            face[t] = Some((r2, intact as u32));
                        }
                        continue;
                    }
                }
                let (ri, rj) = (root(&mut parent, i as u32), root(&mut parent, j as u32));
                if ri != rj {
                    parent[ri as usize] = rj;
                }
            }
        }
    }
    for (t, f) in face.iter().enumerate() {
        if let Some((_, intact)) = *f {
            let (rt, ri) = (root(&mut parent, t as u32), root(&mut parent, intact));
            if rt != ri {
                parent[rt as usize] = ri;
            }
        }
    }
    let mut number = HashMap::new();
    (0..x.len() as u32)
        .map(|i| {
            if torn(i as usize) && face[i as usize].is_none() {
                return NO_PIECE;
            }
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

    #[test]
    fn torn_particles_split_pieces_and_join_a_face() {
        let dx = 0.002;
        // A row 0.6 cells apart; particles 2 and 3 torn through: a band two particles wide.
        let x = row(7, 0.0, 0.0012);
        let mut damage = vec![0.0; 7];
        assert_eq!(count_torn(&x, &[], &damage, dx), 1);
        damage[2] = 1.0;
        damage[3] = TORN;
        let labels = label_torn(&x, &[], &damage, dx);
        assert_eq!(labels, vec![0, 0, 0, 1, 1, 1, 1]);
        // One torn particle splits the row too: the intact particles either side of it are
        // 1.2 cells apart, not neighbours.
        damage[3] = 0.5;
        assert_eq!(count_torn(&x, &[], &damage, dx), 2);
        // Torn particles with no intact neighbour are in no piece.
        damage[4] = 1.0;
        damage[5] = 1.0;
        damage[6] = 1.0;
        let labels = label_torn(&x, &[], &damage, dx);
        assert_eq!(labels[6], NO_PIECE);
        assert_eq!(count_torn(&x, &[], &damage, dx), 2);
        damage[4] = 0.0;
        damage[5] = 0.0;
        damage[6] = 0.0;
        // Partly damaged material still links.
        damage[2] = 0.9;
        assert_eq!(count_torn(&x, &[], &damage, dx), 1);
    }
}
