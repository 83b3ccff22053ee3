//! Position-based MPM (Lewin 2024; seed 002 §III-C, eqs. 13–16) on the CPU.
//!
//! One substep of length dt, `iterations` times: the elastic constraint corrects each
//! particle's affine velocity C (below) → clear grid → P2G of APIC momentum
//! m(v + C(xᵢ − xₚ)) and mass → grid update (gravity in the first iteration only; tools
//! with momentum exchange, table, walls) → G2P of v and C; the last G2P also integrates,
//! once per substep: x ← x + v·dt, F ← (I + C·dt)F, damping, guard.
//!
//! The grid carries velocity rather than the reference's mass-weighted displacement: the
//! two differ by the factor dt, and velocity lets the tool contact and the boundaries of
//! MLS-MPM run unchanged.
//!
//! Elastic constraint (eqs. 13–16 with the reference code's relaxation): with F the
//! deformation gradient at the substep start and F* = (I + C·dt)F, the target is the
//! rotation R of F* (polar decomposition) and C ← C + relaxation·s·((R·F⁻¹ − I)/dt − C).
//! Eq. 15 blends R with the unit-volume F*/∛J* by a weight β; we keep β = 1 (the reference
//! code's elastic default): β < 1 weakens the shape correction against the volume one, and
//! since a constraint's stiffness is capped by the iterations, no iteration count recovers
//! it. Mapping β from ν (β = 1 − 2ν = 0.1 at ν = 0.45) let a 6 mm block on a table sag
//! 1.9 mm under gravity, about 90× the linear-elastic sag.
//!
//! How E and ν enter. PB-MPM's stiffness is set by its iterations, not by moduli. They
//! enter through the constraint softness s = (c·dt)² / ((c·dt)² + dx²/4), c the P-wave
//! speed √((λ+2μ)/ρ): the XPBD weight of a constraint of stiffness λ+2μ against the
//! particle's APIC inertia ρ·dx²/4. A soft material or a short step corrects less per
//! iteration; once an elastic wave crosses a cell per step (the steps PB-MPM is for),
//! s → 1 and the constraint is the reference's hard one, whose stiffness then depends on
//! the iteration count and step alone, not on E.
//!
//! `bench` measures what this gives against the analytic answers.
//!
//! Tool wrenches: linear and angular momentum only change through gravity and the grid
//! update (APIC P2G, G2P and the constraint on C conserve both), so the impulse a tool
//! takes in each iteration's grid update, summed over the iterations, is the momentum it
//! exchanged with the tissue during the substep.

use super::{CpuSolver, SubstepInput};
use crate::mpm::material::rotation_of;
use crate::mpm::{Mat3, MaterialParams, PbMpmParams, SubstepStats, ToolImpulse, Vec3, MAX_TOOLS};
use rayon::prelude::*;

/// Step of one constraint projection for a material: relaxation times the softness s
/// (module docs).
pub fn constraint_step(mat: &MaterialParams, relaxation: f32, dt: f32, dx: f32) -> f32 {
    let lame = mat.lame;
    let c2dt2 = (lame.lambda + 2.0 * lame.mu) / mat.density * dt * dt;
    relaxation * c2dt2 / (c2dt2 + 0.25 * dx * dx)
}

/// New affine velocity C of a particle after one elastic constraint projection with
/// `step` from [`constraint_step`].
#[inline(always)]
pub fn project_elastic(c: &Mat3, f: &Mat3, dt: f32, step: f32) -> Mat3 {
    let Some(f_inv) = f.try_inverse() else {
        return *c;
    };
    let f_star = (Mat3::identity() + c * dt) * f;
    let goal = (rotation_of(&f_star) * f_inv - Mat3::identity()) / dt;
    c + (goal - c) * step
}

impl CpuSolver {
    /// One PB-MPM substep (module docs), on particles the caller has binned.
    pub(super) fn pb_substep(&mut self, input: &SubstepInput, params: PbMpmParams) -> SubstepStats {
        let later = SubstepInput {
            gravity: Vec3::zeros(),
            ..*input
        };
        let mut tool_impulses = [ToolImpulse::default(); MAX_TOOLS];
        let iterations = params.iterations.max(1);
        let mut end = (0.0, 0, None);
        for k in 0..iterations {
            self.constrain(input.dt, params.relaxation);
            self.clear_touched_blocks();
            self.particle_to_grid(None, true);
            let impulses = self.update_grid(if k == 0 { input } else { &later });
            for (acc, imp) in tool_impulses.iter_mut().zip(&impulses) {
                acc.add(imp);
            }
            end = self.grid_to_particle(input.dt, k + 1 == iterations);
            if end.2.is_some() {
                break;
            }
        }
        let (max_speed, clamped_particles, guard) = end;
        SubstepStats {
            tool_impulses,
            max_speed,
            clamped_particles,
            guard,
            solve: Default::default(),
        }
    }

    /// Elastic constraint on every particle's C.
    fn constrain(&mut self, dt: f32, relaxation: f32) {
        let dx = self.layout.dx;
        let materials = &self.materials[..];
        let parts = &mut self.particles;
        parts
            .c
            .par_iter_mut()
            .zip(parts.f.par_iter())
            .zip(parts.material.par_iter())
            .with_min_len(256)
            .for_each(|((c, f), &m)| {
                let step = constraint_step(&materials[m as usize], relaxation, dt, dx);
                *c = project_elastic(c, f, dt, step);
            });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mpm::{Lame, MaterialModel};

    fn material(nu: f64) -> MaterialParams {
        MaterialParams {
            model: MaterialModel::NeoHookean,
            lame: Lame::from_young_poisson(10_000.0, nu),
            density: 1000.0,
            damping: 0.0,
            toughness: 0.0,
        }
    }

    #[test]
    fn long_steps_give_the_hard_constraint_short_ones_a_soft_one() {
        for nu in [0.0, 0.25, 0.45, 0.49] {
            let step = constraint_step(&material(nu), 1.0, 1.0 / 240.0, 1e-3);
            assert!(step > 0.99 && step <= 1.0, "ν {nu}: {step}");
        }
        let short = constraint_step(&material(0.3), 1.0, 1e-5, 1e-3);
        assert!(short < 0.01, "short step: soft constraint, {short}");
    }

    #[test]
    fn rigid_motion_satisfies_the_constraint() {
        // A spin is a rotation rate: F* stays a rotation of unit volume, so C is unchanged.
        let spin = Mat3::new(0.0, -2.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        let step = constraint_step(&material(0.3), 1.5, 1e-3, 1e-3);
        let c = project_elastic(&spin, &Mat3::identity(), 1e-3, step);
        assert!((c - spin).norm() < 2e-3 * spin.norm(), "{c:?}");
    }

    #[test]
    fn a_squeeze_is_pushed_back_towards_rest() {
        // Compression rate along x on an undeformed particle: the constraint asks for the
        // opposite rate, so C·dt moves towards zero strain.
        let squeeze = Mat3::from_diagonal(&Vec3::new(-20.0, 0.0, 0.0));
        let dt = 1.0 / 240.0;
        let step = constraint_step(&material(0.3), 1.0, dt, 1e-3);
        let c = project_elastic(&squeeze, &Mat3::identity(), dt, step);
        let f_star = (Mat3::identity() + c * dt).determinant();
        assert!(
            (f_star - 1.0).abs() < 0.05 * (1.0 + squeeze[(0, 0)] * dt - 1.0).abs(),
            "J* {f_star}"
        );
    }
}
