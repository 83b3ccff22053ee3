//! Particle splitting: tissue stays connected under large stretch unless a crack or damage
//! separates it.
//!
//! # Why
//!
//! In an updated-Lagrangian MPM two particles interact only through grid nodes they share,
//! and a quadratic B-spline reaches 1.5 cells either way. Where tissue is pulled, its
//! particles drift apart with the material; once neighbours are more than about a cell apart
//! a cell of the stretched region holds no particle, the grid there carries no stress, and
//! the tissue parts by numerics (numerical fracture): the default liver, lifted 11 mm by the
//! gripper, left a two-layer chunk in the jaws at 0.9 N although its material has no
//! toughness.
//!
//! # What
//!
//! Each particle stands for a parallelepiped of material: at rest the cube of its lattice
//! spacing, its edges the columns of `R₀ = h·I`; deformed, the edges `F·R₀`. After every
//! frame, a particle whose longest deformed edge exceeds `max_edge_cells` cells is split in
//! two across that edge (the CPDI domain split of Sadeghirad et al. 2011, Homel et al.'s
//! split of stretched particles): the two halves sit at ±¼ of the edge from the old centre,
//! each with half the mass and rest volume, the same velocity, affine velocity C,
//! deformation gradient and damage, and with that edge of R₀ halved. Mass, momentum and
//! the centre of mass are unchanged, and so is the stress each half carries, so the split
//! is invisible to the material and keeps the sampling of stretched tissue at least one
//! particle per cell along the stretch. The first half keeps the particle's index, so
//! outputs bound to particle indices (the constant-topology surface mesh, strain weights)
//! keep following the same material.
//!
//! # What it leaves alone
//!
//! - A particle with a crack (see [`super::crack`]) is not split: a cut must stay open.
//! - A particle damaged to `d ≥ 0.5` (see [`super::damage`]) is not split: a tear the
//!   material's toughness asks for must open, and splitting would bridge it.
//! - At most `max_particles` particles exist: past it no particle splits, and the frame
//!   report counts the refused splits so the user sees why a stretched region may part.
//!
//! # Cost
//!
//! One pass over the particles per frame (three column norms each, and the largest
//! principal stretch for the frame line), and the new particles' substeps. `R₀` is stored
//! only once a particle has split (36 B a particle, allocated for all at the first split).
//! Off by default (`solver.split_max_edge_cells = 0`); the GPU backend does not split (it
//! says so once when a scene asks for it).
//!
//! # Measured
//!
//! The default liver grasped as `config/default.toml` does and lifted on at 25 mm/s to 25 mm
//! above the grasp (`run --headless --backend cpu`, the scene's lift keyframe moved to
//! z = 0.054 at t = 2 s):
//!
//! | splitting | cfl | what happens | wrench |
//! |---|---|---|---|
//! | off | 0.5 | a two-layer chunk comes away in the jaws between 10.4 and 12.9 mm of lift | 0.91 N, then 0.014 N |
//! | on (1 cell) | 0.5 | one piece until the guard stops a runaway at the jaws' corner at 14.2 mm | 1.09 N at 10.4 mm |
//! | on (1 cell) | 0.1 | one piece at 22.5 mm (`pieces 1`), 1.9 s simulated in 854 s | 1.15 N |
//!
//! The frame line's `stretch=` names the most stretched particle: at the corner of the
//! jaws' hold (5 mm beside their midplane, at the level of their tips) its largest principal
//! stretch went from 3.4 to 21 within 0.15 s of the lift, and an explicit step sized for the
//! tissue at rest no longer resolves it: splitting keeps such tissue sampled, the step has
//! to shrink with it.

use super::{Mat3, Particles};
use rayon::prelude::*;

/// Splitting settings (`[solver]` keys `split_max_edge_cells` and `split_max_particles`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitParams {
    /// Longest deformed particle edge, in cells, beyond which a particle splits; 0: never.
    pub max_edge_cells: f32,
    /// Most particles the tissue may reach by splitting.
    pub max_particles: usize,
}

impl SplitParams {
    /// No splitting.
    pub const OFF: SplitParams = SplitParams {
        max_edge_cells: 0.0,
        max_particles: 0,
    };
}

/// Damage from which a particle no longer splits (the tear is the material's).
pub const DAMAGED: f32 = 0.5;

/// What one splitting pass did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SplitCount {
    /// Particles split in two.
    pub split: usize,
    /// Particles that asked to split but the `max_particles` cap refused.
    pub refused: usize,
}

/// The rest edges of particle `p`: its stored `R₀`, or the cube of its rest volume.
fn rest_edges(particles: &Particles, p: usize) -> Mat3 {
    match particles.domain.get(p) {
        Some(r0) => *r0,
        None => Mat3::identity() * particles.volume0[p].cbrt(),
    }
}

/// Splits every particle whose longest deformed edge exceeds the limit (see the module
/// docs), appending the second halves. Returns how many split and how many the cap refused.
pub fn split_stretched(particles: &mut Particles, dx: f32, params: &SplitParams) -> SplitCount {
    let mut count = SplitCount::default();
    if params.max_edge_cells <= 0.0 {
        return count;
    }
    let limit = params.max_edge_cells * dx;
    let n = particles.len();
    for p in 0..n {
        if particles
            .crack
            .get(p)
            .is_some_and(|c| *c != super::Vec3::zeros())
            || particles.damage.get(p).is_some_and(|&d| d >= DAMAGED)
        {
            continue;
        }
        let r0 = rest_edges(particles, p);
        let edges = particles.f[p] * r0;
        let (k, len) = (0..3)
            .map(|k| (k, edges.column(k).norm()))
            .fold((0, 0.0f32), |a, b| if b.1 > a.1 { b } else { a });
        if len <= limit {
            continue;
        }
        if particles.len() >= params.max_particles {
            count.refused += 1;
            continue;
        }
        if particles.domain.len() != particles.len() {
            let all: Vec<Mat3> = (0..particles.len())
                .map(|q| rest_edges(particles, q))
                .collect();
            particles.domain = all;
        }
        let offset = edges.column(k) * 0.25;
        let mut halved = r0;
        halved.set_column(k, &(r0.column(k) * 0.5));
        let centre = particles.x[p];
        particles.x[p] = centre - offset;
        particles.mass[p] *= 0.5;
        particles.volume0[p] *= 0.5;
        particles.domain[p] = halved;
        particles.x.push(centre + offset);
        particles.v.push(particles.v[p]);
        particles.c.push(particles.c[p]);
        particles.f.push(particles.f[p]);
        particles.mass.push(particles.mass[p]);
        particles.volume0.push(particles.volume0[p]);
        particles.material.push(particles.material[p]);
        particles.domain.push(halved);
        if !particles.crack.is_empty() {
            particles.crack.push(super::Vec3::zeros());
        }
        if !particles.damage.is_empty() {
            particles.damage.push(particles.damage[p]);
        }
        count.split += 1;
    }
    count
}

/// Largest principal stretch of `f`: the square root of the largest eigenvalue of FᵀF
/// (closed form for a symmetric 3×3 matrix, in f64).
pub fn largest_stretch(f: &Mat3) -> f32 {
    let a = (f.transpose() * f).cast::<f64>();
    let off = a[(0, 1)].powi(2) + a[(0, 2)].powi(2) + a[(1, 2)].powi(2);
    let q = a.trace() / 3.0;
    let largest = if off <= 1e-30 {
        a[(0, 0)].max(a[(1, 1)]).max(a[(2, 2)])
    } else {
        let spread = (a[(0, 0)] - q).powi(2) + (a[(1, 1)] - q).powi(2) + (a[(2, 2)] - q).powi(2);
        let p = ((spread + 2.0 * off) / 6.0).sqrt();
        let b = (a - nalgebra::Matrix3::identity() * q) / p;
        let phi = (0.5 * b.determinant()).clamp(-1.0, 1.0).acos() / 3.0;
        q + 2.0 * p * phi.cos()
    };
    largest.max(0.0).sqrt() as f32
}

/// The largest principal stretch of any particle (1 at rest) and that particle's index: where
/// tissue is pulled hardest, reported per frame by the CPU backend.
pub fn max_stretch(particles: &Particles) -> (f32, usize) {
    particles
        .f
        .par_iter()
        .enumerate()
        .with_min_len(4096)
        .map(|(p, f)| (largest_stretch(f), p))
        .reduce(|| (0.0, 0), |a, b| if b.0 > a.0 { b } else { a })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

    fn block(stretch: f32) -> Particles {
        let mut p = Particles::default();
        p.add_box(Vec3::zeros(), Vec3::repeat(0.004), 0.002, 2, 1000.0, 0);
        for f in &mut p.f {
            *f = Mat3::from_diagonal(&Vec3::new(stretch, 1.0, 1.0));
        }
        for v in &mut p.v {
            *v = Vec3::new(0.1, 0.0, 0.0);
        }
        p
    }

    const PARAMS: SplitParams = SplitParams {
        max_edge_cells: 1.0,
        max_particles: 1_000,
    };

    #[test]
    fn a_particle_stretched_past_a_cell_splits_across_the_stretch_keeping_mass_and_momentum() {
        // Spacing 1 mm, stretched 2.5×: edges of 2.5 mm along x exceed the 2 mm cell.
        let mut p = block(2.5);
        let (mass, momentum, centre) = (p.total_mass(), p.momentum(), p.centre_of_mass());
        let n = p.len();
        let count = split_stretched(&mut p, 0.002, &PARAMS);
        assert_eq!(
            count,
            SplitCount {
                split: n,
                refused: 0
            }
        );
        assert_eq!(p.len(), 2 * n);
        assert!((p.total_mass() - mass).abs() < 1e-12 * mass.max(1.0));
        assert!((p.momentum() - momentum).norm() < 1e-9);
        assert!((p.centre_of_mass() - centre).norm() < 1e-9);
        // The halves sit a quarter of the 2.5 mm edge either side, along x.
        let d = p.x[n] - p.x[0];
        assert!((d - Vec3::new(0.00125, 0.0, 0.0)).norm() < 1e-7, "{d:?}");
        // Each half's edge along x is now 1.25 mm: no second split.
        assert_eq!(split_stretched(&mut p, 0.002, &PARAMS).split, 0);
    }

    #[test]
    fn the_largest_stretch_is_the_largest_singular_value() {
        let rotation = nalgebra::Rotation3::from_euler_angles(0.3, -0.7, 1.1).into_inner();
        let f = rotation * Mat3::from_diagonal(&Vec3::new(0.5, 2.5, 1.2)) * rotation.transpose();
        assert!((largest_stretch(&f) - 2.5).abs() < 1e-5);
        assert!((largest_stretch(&Mat3::identity()) - 1.0).abs() < 1e-7);
        let shear = Mat3::new(1.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
        let golden = (1.0 + 5f32.sqrt()) / 2.0;
        assert!((largest_stretch(&shear) - golden).abs() < 1e-5);
        let mut p = block(1.0);
        p.f[7] = f;
        assert_eq!(max_stretch(&p).1, 7);
    }

    #[test]
    fn unstretched_cracked_and_torn_particles_and_the_cap_keep_the_count() {
        let mut p = block(1.9);
        assert_eq!(split_stretched(&mut p, 0.002, &PARAMS).split, 0);
        let mut cut = block(2.5);
        cut.crack = vec![Vec3::new(0.0, 0.0, 1e-4); cut.len()];
        assert_eq!(split_stretched(&mut cut, 0.002, &PARAMS).split, 0);
        let mut torn = block(2.5);
        torn.damage = vec![DAMAGED; torn.len()];
        assert_eq!(split_stretched(&mut torn, 0.002, &PARAMS).split, 0);
        let mut capped = block(2.5);
        let n = capped.len();
        let cap = SplitParams {
            max_particles: n + 3,
            ..PARAMS
        };
        let count = split_stretched(&mut capped, 0.002, &cap);
        assert_eq!(
            count,
            SplitCount {
                split: 3,
                refused: n - 3
            }
        );
        let off = SplitParams {
            max_edge_cells: 0.0,
            ..PARAMS
        };
        assert_eq!(split_stretched(&mut block(3.0), 0.002, &off).split, 0);
    }
}
