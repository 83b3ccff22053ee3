//! All of a rod's constraints solved together, directly, once per iteration (Deul, Kugelstadt,
//! Weiler & Bender 2018; seed 001's direct distance constraint is the stretch-only special case).
//!
//! One Newton step of XPBD: (J·W·Jᵀ + α̃)·Δλ = −C − α̃·λ over every constraint at once. Grouping
//! segment j's stretch-shear with joint j's bend-twist (6 rows), group j shares unknowns only
//! with groups j ± 1 (points pⱼ₊₁ and frame qⱼ₊₁), so the system is block tridiagonal with 6×6
//! blocks and block elimination along the chain solves it in O(n) without fill-in.
//! Gauss–Seidel cannot do this job: a cantilever's weight must reach the clamp through every
//! joint, and with EI eight orders below EA a few sweeps leave the rod as limp as a chain.
//!
//! The assembly and elimination run in f64: the diagonal mixes inverse inertias of ~1e14–1e17
//! with bending compliances over h² of ~1e6–1e8, and the chain's lowest (bending) modes sit
//! another n² below the diagonal, beyond f32's 7 digits.

use super::constraints::{bend_twist, stretch_shear, Compliance, M3, V3};
use super::state::{add_rotation, Rod};
use crate::mpm::Vec3;
use nalgebra::{Matrix6, Vector6};

type M6 = Matrix6<f64>;
type V6 = Vector6<f64>;

/// Reused per-solve buffers (no allocation in the step).
#[derive(Clone, Debug, Default)]
pub struct DirectScratch {
    /// Per group: Aₖ,ₖ₊₁, the coupling to the next group.
    coupling: Vec<M6>,
    /// Per group: D̃ₖ⁻¹·Aₖ,ₖ₊₁ after elimination.
    upper: Vec<M6>,
    /// Per group: the right-hand side, then D̃ₖ⁻¹·b̃ₖ, then Δλ.
    rhs: Vec<V6>,
    diag: Vec<M6>,
    d3: Vec<V3>,
    bend_jacobian: Vec<M3>,
    inv_length: Vec<f64>,
    rotation: Vec<V3>,
}

/// One direct solve; `lambda` (stretch-shear in rows 0..3, bend-twist in 3..6 of each group)
/// accumulates over the substep. Returns false, leaving the rod unchanged, if the system
/// could not be factorised. It is J·W·Jᵀ + α̃, positive definite while every compliance is
/// positive, however many points have inverse mass 0 (pinned, grasped): the diagonal blocks
/// are assembled as products J·W·Jᵀ so that rounding keeps them positive semi-definite.
pub fn solve(
    rod: &mut Rod,
    compliance: &Compliance,
    lambda: &mut [V6],
    inv_h2: f64,
    s: &mut DirectScratch,
) -> bool {
    let n = rod.segments();
    s.coupling.resize(n, M6::zeros());
    s.upper.resize(n, M6::zeros());
    s.rhs.resize(n, V6::zeros());
    s.diag.resize(n, M6::zeros());
    s.d3.resize(n, V3::zeros());
    s.bend_jacobian.resize(n, M3::zeros());
    s.inv_length.resize(n, 0.0);
    s.rotation.resize(n, V3::zeros());
    // Linearise every constraint at the current state.
    for (j, &lam) in lambda.iter().enumerate().take(n) {
        let ss = stretch_shear(rod, j, compliance.stretch_shear[j]);
        s.d3[j] = ss.d3;
        s.inv_length[j] = ss.inv_length;
        let alpha = ss.compliance * inv_h2;
        let mut rhs = V6::zeros();
        rhs.fixed_rows_mut::<3>(0)
            .copy_from(&(-ss.value - alpha * lam.fixed_rows::<3>(0)));
        let mut diag = M6::zeros();
        diag.fixed_view_mut::<3, 3>(0, 0).copy_from(&alpha);
        if j + 1 < n {
            let bt = bend_twist(rod, j);
            s.bend_jacobian[j] = bt.jacobian;
            let alpha = compliance.bend_twist[j] * inv_h2;
            let c = -bt.value - alpha.component_mul(&lam.fixed_rows::<3>(3).into_owned());
            rhs.fixed_rows_mut::<3>(3).copy_from(&c);
            diag.fixed_view_mut::<3, 3>(3, 3)
                .copy_from(&M3::from_diagonal(&alpha));
        } else {
            // No joint after the last segment: an identity row with a zero right-hand side.
            s.bend_jacobian[j] = M3::zeros();
            diag.fixed_view_mut::<3, 3>(3, 3).copy_from(&M3::identity());
        }
        s.rhs[j] = rhs;
        s.diag[j] = diag;
    }
    // J·W·Jᵀ blocks.
    for j in 0..n {
        let (w0, w1) = (rod.inv_mass[j] as f64, rod.inv_mass[j + 1] as f64);
        let wq = rod.inv_inertia[j] as f64;
        let il = s.inv_length[j];
        let d3x = s.d3[j].cross_matrix();
        let e = s.bend_jacobian[j];
        let mut block = s.diag[j];
        // S·S: points (w0 + w1)/l², frame [d3]×[d3]×ᵀ. Formed as that product, not as
        // I − d3·d3ᵀ: the two differ by (|d3|² − 1)·I, and an error of 1e-16 in |d3| times an
        // inverse inertia of ~1e13 is a negative axial term beside axial compliances of
        // ~1e5. A piece of chain held at both ends has no point mass to give along its axis,
        // so its axial pivot is that compliance alone, and the factorisation failed there.
        let ss = M3::identity() * ((w0 + w1) * il * il) + d3x * d3x.transpose() * wq;
        let sb = -(d3x * e.transpose()) * wq;
        let wq_next = if j + 1 < n {
            rod.inv_inertia[j + 1] as f64
        } else {
            0.0
        };
        let bb = e * e.transpose() * (wq + wq_next);
        add3(&mut block, 0, 0, &ss);
        add3(&mut block, 0, 3, &sb);
        add3(&mut block, 3, 0, &sb.transpose());
        add3(&mut block, 3, 3, &bb);
        s.diag[j] = block;
        let mut upper = M6::zeros();
        if j + 1 < n {
            let il_next = s.inv_length[j + 1];
            // Sⱼ·Sⱼ₊₁ share pⱼ₊₁; Bⱼ shares qⱼ₊₁ with Sⱼ₊₁ and Bⱼ₊₁.
            add3(&mut upper, 0, 0, &(M3::identity() * (-w1 * il * il_next)));
            add3(
                &mut upper,
                3,
                0,
                &(-(e * s.d3[j + 1].cross_matrix()) * wq_next),
            );
            add3(
                &mut upper,
                3,
                3,
                &(-(e * s.bend_jacobian[j + 1].transpose()) * wq_next),
            );
        }
        s.coupling[j] = upper;
    }
    // Block elimination down the chain, then back substitution.
    for k in 0..n {
        if k > 0 {
            let lower = s.coupling[k - 1].transpose();
            let (above_y, above_z) = (s.upper[k - 1], s.rhs[k - 1]);
            s.diag[k] -= lower * above_y;
            s.rhs[k] -= lower * above_z;
        }
        let Some(chol) = s.diag[k].cholesky() else {
            return false;
        };
        s.rhs[k] = chol.solve(&s.rhs[k]);
        s.upper[k] = chol.solve(&s.coupling[k]);
    }
    for k in (0..n.saturating_sub(1)).rev() {
        let next = s.rhs[k + 1];
        s.rhs[k] -= s.upper[k] * next;
    }
    if s.rhs.iter().any(|v| !v.iter().all(|c| c.is_finite())) {
        return false;
    }
    // Δx = W·Jᵀ·Δλ, from all Δλ at once.
    s.rotation.fill(V3::zeros());
    for (j, lam) in lambda.iter_mut().enumerate().take(n) {
        let dl = s.rhs[j];
        *lam += dl;
        let (dls, dlb) = (dl.fixed_rows::<3>(0).into_owned(), dl.fixed_rows::<3>(3));
        let dp = dls * s.inv_length[j];
        let dp = Vec3::new(dp.x as f32, dp.y as f32, dp.z as f32);
        let (w0, w1) = (rod.inv_mass[j], rod.inv_mass[j + 1]);
        rod.points[j] -= dp * w0;
        rod.points[j + 1] += dp * w1;
        let torque = s.bend_jacobian[j].transpose() * dlb;
        s.rotation[j] += dls.cross(&s.d3[j]) - torque;
        if j + 1 < n {
            s.rotation[j + 1] += torque;
        }
    }
    for (j, r) in s.rotation.iter().enumerate() {
        let wq = rod.inv_inertia[j];
        if wq > 0.0 {
            let r = r * wq as f64;
            add_rotation(
                &mut rod.frames[j],
                Vec3::new(r.x as f32, r.y as f32, r.z as f32),
            );
        }
    }
    true
}

fn add3(m: &mut M6, row: usize, col: usize, block: &M3) {
    let mut view = m.fixed_view_mut::<3, 3>(row, col);
    view += block;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rod::constraints::stretch_shear;
    use crate::rod::ThreadMaterial;

    /// Points moved along a straight rod's axis change only the (linear) stretch: one solve
    /// must leave every constraint satisfied, C + α̃·λ = 0.
    #[test]
    fn one_solve_satisfies_axial_constraints_exactly() {
        let mut rod = Rod::straight(
            ThreadMaterial::nylon_3_0(),
            Vec3::zeros(),
            Vec3::x(),
            0.15,
            8,
        );
        rod.pin_point(0);
        rod.points[8].x += 0.01;
        rod.points[5].x -= 0.002;
        let c = Compliance::of(&rod);
        let mut lambda = vec![V6::zeros(); 8];
        let inv_h2 = 240.0f64 * 240.0;
        assert!(solve(
            &mut rod,
            &c,
            &mut lambda,
            inv_h2,
            &mut DirectScratch::default()
        ));
        for (j, lambda) in lambda.iter().enumerate() {
            let ss = stretch_shear(&rod, j, c.stretch_shear[j]);
            let residual = ss.value + ss.compliance * inv_h2 * lambda.fixed_rows::<3>(0);
            // The displacement was a strain of ~0.5; what remains is f32 rounding of points.
            assert!(residual.norm() < 2e-6, "segment {j}: residual {residual}");
        }
    }
}
