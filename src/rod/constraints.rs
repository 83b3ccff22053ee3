//! The two Cosserat constraints of a segment, their compliances and their linearisation (the
//! values and Jacobians the direct solve assembles).
//!
//! Stretch-shear (seed 001 eq. 8): C = (pⱼ₊₁ − pⱼ)/lⱼ − d3ⱼ, a strain vector; its stiffness is
//! anisotropic, EA along the frame's d3 and κGA across it, so one constraint carries both the
//! thread's length (F/EA) and its shear.
//! Bend-twist (eq. 11): C = Im(q̄ⱼqⱼ₊₁ ∓ Ω⁰) in segment j's material frame, the sign of the rest
//! Darboux quaternion chosen to give the smaller 4-vector difference (q and −q are the same
//! frame).
//!
//! Rotations are world-frame rotation vectors θ applied as q ← q + ½·(0, θ)·q.
//! Linearisations are in f64: see `direct` for why.

use super::state::{Quat, Rod};
use crate::math::{Mat3d, Vec3d};
use nalgebra::UnitQuaternion;

/// Compliances per segment and per joint (stiffness inverted once, not per iteration).
#[derive(Clone, Debug, Default)]
pub struct Compliance {
    /// (1/(κGA·l), 1/(EA·l)) per segment: across and along d3 (C is a dimensionless strain,
    /// energy ½·l·(κGA·|γ⊥|² + EA·γ₃²)).
    pub stretch_shear: Vec<(f64, f64)>,
    /// l̄/(4·(EI, EI, GJ)) per joint: Im(q̄q′) ≈ ½·κ·l̄, energy ½·K·l̄·κ² = ½·(4K/l̄)·C².
    pub bend_twist: Vec<Vec3d>,
}

impl Compliance {
    pub fn of(rod: &Rod) -> Compliance {
        let m = rod.material;
        let (ea, gak) = (m.axial_stiffness() as f64, m.shear_stiffness() as f64);
        let (ei, gj) = (m.bending_stiffness() as f64, m.torsional_stiffness() as f64);
        let l = &rod.rest_lengths;
        Compliance {
            stretch_shear: l
                .iter()
                .map(|&l| (1.0 / (gak * l as f64), 1.0 / (ea * l as f64)))
                .collect(),
            bend_twist: l
                .windows(2)
                .map(|w| {
                    let mean = 0.5 * (w[0] + w[1]) as f64;
                    Vec3d::new(mean / (4.0 * ei), mean / (4.0 * ei), mean / (4.0 * gj))
                })
                .collect(),
        }
    }
}

/// Stretch-shear of one segment linearised at the current state.
#[derive(Clone, Copy, Debug)]
pub struct StretchShear {
    pub value: Vec3d,
    /// ∂C/∂pⱼ₊₁ = I/l (and ∂C/∂pⱼ = −I/l).
    pub inv_length: f64,
    /// d3 of the frame: ∂C/∂θⱼ = [d3]×.
    pub d3: Vec3d,
    /// World-frame compliance matrix (before the 1/h² of XPBD).
    pub compliance: Mat3d,
}

pub fn stretch_shear(rod: &Rod, j: usize, compliance: (f64, f64)) -> StretchShear {
    let inv_length = 1.0 / rod.rest_lengths[j] as f64;
    let d = (rod.points[j + 1] - rod.points[j]).cast::<f64>();
    let d3 = rotate_z(&rod.frames[j]);
    let (across, along) = compliance;
    StretchShear {
        value: d * inv_length - d3,
        inv_length,
        d3,
        compliance: Mat3d::identity() * across + d3 * d3.transpose() * (along - across),
    }
}

/// Bend-twist of one joint linearised at the current state.
#[derive(Clone, Copy, Debug)]
pub struct BendTwist {
    pub value: Vec3d,
    /// ∂C/∂θⱼ₊₁ = E and ∂C/∂θⱼ = −E, E = ½·(D.w·I − [d]×)·R(qⱼ)ᵀ with D = q̄ⱼqⱼ₊₁ = (D.w, d):
    /// D.w is ≈ −1 when one frame's sign is flipped, and the gradient flips with it.
    pub jacobian: Mat3d,
}

pub fn bend_twist(rod: &Rod, j: usize) -> BendTwist {
    let (qa, qb) = (quat64(&rod.frames[j]), quat64(&rod.frames[j + 1]));
    let darboux = qa.conjugate() * qb;
    let rest = quat64(&rod.rest_darboux[j]);
    let diff = if (darboux - rest).norm_squared() <= (darboux + rest).norm_squared() {
        darboux - rest
    } else {
        darboux + rest
    };
    let ra = UnitQuaternion::new_unchecked(qa).to_rotation_matrix();
    let d = darboux.imag();
    let jacobian =
        (Mat3d::identity() * darboux.w - d.cross_matrix()) * ra.matrix().transpose() * 0.5;
    BendTwist {
        value: diff.imag(),
        jacobian,
    }
}

fn quat64(q: &Quat) -> nalgebra::Quaternion<f64> {
    nalgebra::Quaternion::new(q.w as f64, q.i as f64, q.j as f64, q.k as f64)
}

/// q·e3·q̄ in f64, of unit length: the f32 quaternion is unit only to f32 rounding (the
/// constraint would target a length off by that much, and [d3]× would not be the
/// Jacobian's exact cross matrix of a unit vector).
fn rotate_z(q: &Quat) -> Vec3d {
    super::state::rotate_z(q).cast::<f64>().normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::rod::state::add_rotation;
    use crate::rod::ThreadMaterial;

    /// A bent, twisted rod whose rest shape differs from its current one, with one frame's
    /// sign flipped (so that D.w < 0 at one joint).
    fn bent_rod() -> Rod {
        let points = (0..=4)
            .map(|i| {
                let a = 0.4 * i as f32;
                Vec3::new(0.01 * a.sin(), 0.002 * a, 0.01 * (1.0 - a.cos()))
            })
            .collect();
        let mut rod = Rod::from_polyline(ThreadMaterial::nylon_3_0(), points);
        for (j, q) in rod.frames.iter_mut().enumerate() {
            add_rotation(q, Vec3::new(0.1, -0.05, 0.2) * j as f32);
        }
        rod.frames[2] = -rod.frames[2];
        rod.points[3] += Vec3::new(1e-4, -2e-4, 5e-5);
        rod
    }

    fn rotated(rod: &Rod, j: usize, dtheta: Vec3) -> Rod {
        let mut r = rod.clone();
        add_rotation(&mut r.frames[j], dtheta);
        r
    }

    /// The analytic Jacobians against central differences of C under small world-frame
    /// rotations (the update the solver applies) and point moves.
    #[test]
    fn jacobians_match_finite_differences() {
        let rod = bent_rod();
        let eps = 1e-3f32;
        for j in 0..rod.segments() - 1 {
            let lin = bend_twist(&rod, j);
            for (k, sign) in [(j, -1.0), (j + 1, 1.0)] {
                for axis in 0..3 {
                    let mut e = Vec3::zeros();
                    e[axis] = eps;
                    let plus = bend_twist(&rotated(&rod, k, e), j).value;
                    let minus = bend_twist(&rotated(&rod, k, -e), j).value;
                    let numeric = (plus - minus) / (2.0 * eps as f64);
                    let analytic = lin.jacobian.column(axis) * sign;
                    assert!(
                        (numeric - analytic).norm() < 2e-3,
                        "bend-twist {j}, frame {k}, axis {axis}: {numeric} vs {analytic}"
                    );
                }
            }
        }
        let c = Compliance::of(&rod);
        for j in 0..rod.segments() {
            let lin = stretch_shear(&rod, j, c.stretch_shear[j]);
            for axis in 0..3 {
                let mut e = Vec3::zeros();
                e[axis] = eps;
                let plus = stretch_shear(&rotated(&rod, j, e), j, c.stretch_shear[j]).value;
                let minus = stretch_shear(&rotated(&rod, j, -e), j, c.stretch_shear[j]).value;
                let numeric = (plus - minus) / (2.0 * eps as f64);
                let analytic = lin.d3.cross_matrix().column(axis).into_owned();
                assert!(
                    (numeric - analytic).norm() < 2e-3,
                    "stretch-shear {j}, axis {axis}: {numeric} vs {analytic}"
                );
                let step = 1e-6f32;
                let mut moved = rod.clone();
                moved.points[j + 1][axis] += step;
                let numeric =
                    (stretch_shear(&moved, j, c.stretch_shear[j]).value - lin.value) / step as f64;
                let mut analytic = Vec3d::zeros();
                analytic[axis] = lin.inv_length;
                assert!(
                    (numeric - analytic).norm() < 1e-2 * lin.inv_length,
                    "stretch-shear {j}, point axis {axis}: {numeric} vs {analytic}"
                );
            }
        }
    }
}
