//! The chain's distance constraints Cᵢ = |pᵢ₊₁ − pᵢ| − lᵢ solved together, directly, each
//! iteration (seed 001's direct distance constraint with XPBD compliance lᵢ/EA): the system
//! (J·W·Jᵀ + α̃)·Δλ = −C − α̃·λ is tridiagonal for a chain and the Thomas algorithm solves it in
//! O(n). Gauss–Seidel would need O(n²) sweeps to carry a pull along the thread, because EA is
//! eight orders stiffer than EI.

use super::state::Rod;
use crate::mpm::Vec3;

/// Reused per-solve buffers (no allocation in the step).
#[derive(Clone, Debug, Default)]
pub struct DistanceScratch {
    normals: Vec<Vec3>,
    upper: Vec<f32>,
    rhs: Vec<f32>,
    step_lambda: Vec<f32>,
}

/// One direct solve of all distance constraints; `lambda` accumulates over the substep.
pub fn solve_distances(
    rod: &mut Rod,
    compliance: &[f32],
    lambda: &mut [f32],
    inv_h2: f32,
    scratch: &mut DistanceScratch,
) {
    let n = rod.segments();
    scratch.normals.resize(n, Vec3::zeros());
    scratch.upper.resize(n, 0.0);
    scratch.rhs.resize(n, 0.0);
    let w = &rod.inv_mass;
    for i in 0..n {
        let d = rod.points[i + 1] - rod.points[i];
        let len = d.norm();
        scratch.normals[i] = if len > f32::EPSILON {
            d / len
        } else {
            Vec3::zeros()
        };
        scratch.rhs[i] = -(len - rod.rest_lengths[i]) - compliance[i] * inv_h2 * lambda[i];
    }
    // Forward sweep. Row i: diag wᵢ + wᵢ₊₁ + α̃ᵢ, neighbours −wᵢ·nᵢ₋₁·nᵢ and −wᵢ₊₁·nᵢ·nᵢ₊₁
    // (∂Cᵢ/∂pᵢ₊₁ = nᵢ, ∂Cᵢ/∂pᵢ = −nᵢ).
    let mut prev_upper = 0.0;
    let mut prev_rhs = 0.0;
    for i in 0..n {
        let lower = if i > 0 {
            -w[i] * scratch.normals[i - 1].dot(&scratch.normals[i])
        } else {
            0.0
        };
        let upper = if i + 1 < n {
            -w[i + 1] * scratch.normals[i].dot(&scratch.normals[i + 1])
        } else {
            0.0
        };
        let diag = w[i] + w[i + 1] + compliance[i] * inv_h2 - lower * prev_upper;
        if diag <= f32::MIN_POSITIVE {
            // Both ends held and no compliance: nothing can move; decouple the row.
            scratch.upper[i] = 0.0;
            scratch.rhs[i] = 0.0;
        } else {
            scratch.upper[i] = upper / diag;
            scratch.rhs[i] = (scratch.rhs[i] - lower * prev_rhs) / diag;
        }
        prev_upper = scratch.upper[i];
        prev_rhs = scratch.rhs[i];
    }
    // Back substitution, then the position update from all Δλ at once.
    scratch.step_lambda.resize(n, 0.0);
    let mut next = 0.0;
    for i in (0..n).rev() {
        next = scratch.rhs[i] - scratch.upper[i] * next;
        scratch.step_lambda[i] = next;
    }
    for i in 0..n {
        let ni = scratch.normals[i] * scratch.step_lambda[i];
        lambda[i] += scratch.step_lambda[i];
        rod.points[i] -= ni * w[i];
        rod.points[i + 1] += ni * w[i + 1];
    }
}
