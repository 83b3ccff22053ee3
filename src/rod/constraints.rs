//! The two Cosserat constraints as XPBD projections (compliance α = 1/stiffness scaled to the
//! constraint, α̃ = α/h²; multipliers λ accumulated over a substep so that the response does
//! not depend on the iteration count).
//!
//! Stretch-shear (seed 001 eq. 8) is written here with the segment's current unit tangent,
//! C = t − d3, so it carries shear only: the stretch is the distance constraint's (solved
//! directly, `distance`), and counting it twice would add κGA to EA.
//! Bend-twist (eq. 11): C = Im(q̄ⱼqⱼ₊₁ ∓ Ω⁰), the sign of the rest Darboux quaternion chosen to
//! give the smaller 4-vector difference (q and −q are the same frame).

use super::state::{add_rotation, rotate_z, Quat, Rod};
use crate::mpm::Vec3;

/// Compliances per segment and per joint (stiffness inverted once, not per iteration).
#[derive(Clone, Debug, Default)]
pub struct Compliance {
    /// 1/(κGA·l) per segment (C is a dimensionless shear strain).
    pub shear: Vec<f32>,
    /// l̄/(4·(EI, EI, GJ)) per joint: Im(q̄q′) ≈ ½·κ·l̄, energy ½·K·l̄·κ² = ½·(4K/l̄)·C².
    pub bend_twist: Vec<Vec3>,
    /// l/(EA) per segment (C is a length).
    pub stretch: Vec<f32>,
}

impl Compliance {
    pub fn of(rod: &Rod) -> Compliance {
        let m = rod.material;
        let (ea, gak) = (m.axial_stiffness(), m.shear_stiffness());
        let (ei, gj) = (m.bending_stiffness(), m.torsional_stiffness());
        let l = &rod.rest_lengths;
        Compliance {
            shear: l.iter().map(|&l| 1.0 / (gak * l)).collect(),
            bend_twist: l
                .windows(2)
                .map(|w| {
                    let mean = 0.5 * (w[0] + w[1]);
                    Vec3::new(mean / (4.0 * ei), mean / (4.0 * ei), mean / (4.0 * gj))
                })
                .collect(),
            stretch: l.iter().map(|&l| l / ea).collect(),
        }
    }
}

/// Shear of every segment: rotate the frame's d3 and move the two points (normal to the
/// segment) towards agreement.
pub fn project_stretch_shear(rod: &mut Rod, compliance: &[f32], lambda: &mut [Vec3], inv_h2: f32) {
    for j in 0..rod.segments() {
        let (w0, w1, wq) = (rod.inv_mass[j], rod.inv_mass[j + 1], rod.inv_inertia[j]);
        let d = rod.points[j + 1] - rod.points[j];
        let len = d.norm();
        if len <= f32::EPSILON {
            continue;
        }
        let t = d / len;
        let d3 = rotate_z(&rod.frames[j]);
        let c = t - d3;
        // |∂C/∂p|² = 1/L² normal to t; |∂C/∂θ|² = 1 normal to d3 (isotropic approximation).
        let alpha = compliance[j] * inv_h2;
        let denom = (w0 + w1) / (len * len) + wq + alpha;
        if denom <= 0.0 {
            continue;
        }
        let dl = (-c - alpha * lambda[j]) / denom;
        lambda[j] += dl;
        let dp = (dl - t * t.dot(&dl)) / len;
        rod.points[j] -= dp * w0;
        rod.points[j + 1] += dp * w1;
        if wq > 0.0 {
            add_rotation(&mut rod.frames[j], dl.cross(&d3) * wq);
        }
    }
}

/// Bend and twist of every interior joint.
pub fn project_bend_twist(rod: &mut Rod, compliance: &[Vec3], lambda: &mut [Vec3], inv_h2: f32) {
    for j in 0..rod.segments().saturating_sub(1) {
        let (wa, wb) = (rod.inv_inertia[j], rod.inv_inertia[j + 1]);
        let w = 0.25 * (wa + wb);
        if w <= 0.0 {
            continue;
        }
        let (qa, qb) = (rod.frames[j], rod.frames[j + 1]);
        let darboux = qa.conjugate() * qb;
        let rest = rod.rest_darboux[j];
        let diff = if (darboux - rest).norm_squared() <= (darboux + rest).norm_squared() {
            darboux - rest
        } else {
            darboux + rest
        };
        let c = diff.imag();
        let alpha = compliance[j].component_mul(&Vec3::repeat(inv_h2));
        let dl = (-c - alpha.component_mul(&lambda[j])).component_div(&(alpha.add_scalar(w)));
        lambda[j] += dl;
        // For world rotation vectors θ: ∂C/∂θ_b = ½·(D.w·I − [d]×)·R(qa)ᵀ and ∂C/∂θ_a its
        // negative, D = q̄a·qb = (D.w, d). D.w is ≈ −1 when one frame's sign is flipped, so the
        // gradient flips with it.
        let torque = rotate(&qa, dl * darboux.w + darboux.imag().cross(&dl)) * 0.5;
        if wa > 0.0 {
            add_rotation(&mut rod.frames[j], -torque * wa);
        }
        if wb > 0.0 {
            add_rotation(&mut rod.frames[j + 1], torque * wb);
        }
    }
}

/// q·v·q̄ for a unit quaternion.
#[inline]
fn rotate(q: &Quat, v: Vec3) -> Vec3 {
    let u = q.imag();
    let t = u.cross(&v) * 2.0;
    v + t * q.w + u.cross(&t)
}
