//! Hyperelastic constitutive models, written as the Kirchhoff stress τ = P·Fᵀ
//! that MLS-MPM's fused P2G needs.
//!
//! Degenerate and inverted deformation gradients: Neo-Hookean's `log J` is undefined for
//! `J ≤ 0`, so the volumetric term uses `J_eff = max(J, J_MIN)`. An inverted or crushed
//! particle therefore feels the (large, finite) pressure of a particle compressed to
//! `J_MIN`, which pushes it back towards positive volume instead of producing NaN. The
//! deviatoric term `μ(FFᵀ − I)` is polynomial and always finite. Fixed-corotated stays
//! defined for inverted F by construction (its rotation comes from an iteration that
//! never divides by a singular value).

use super::{Mat3, Vec3};
use serde::{Deserialize, Serialize};

/// Smallest volume ratio the Neo-Hookean volumetric term sees (see module docs).
pub const J_MIN: f32 = 1e-4;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
/// The elastic energy density of a material.
pub enum MaterialModel {
    /// Ψ = μ/2 (tr FᵀF − 3) − μ ln J + λ/2 (ln J)²  (seed 000 eq. 5).
    #[default]
    NeoHookean,
    /// Ψ = μ ‖F − R‖² + λ/2 (J − 1)².
    FixedCorotated,
}

/// Lamé parameters of an isotropic material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lame {
    /// Shear modulus μ, Pa.
    pub mu: f32,
    /// Lamé's first parameter λ, Pa.
    pub lambda: f32,
}

impl Lame {
    /// From Young's modulus `e` (Pa) and Poisson ratio `nu` (seed 000 eq. 6).
    pub fn from_young_poisson(e: f64, nu: f64) -> Self {
        let mu = e / (2.0 * (1.0 + nu));
        let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        Lame {
            mu: mu as f32,
            lambda: lambda as f32,
        }
    }

    /// P-wave speed √((λ+2μ)/ρ): the fastest signal in the material, which bounds dt.
    pub fn p_wave_speed(&self, density: f64) -> f64 {
        ((self.lambda as f64 + 2.0 * self.mu as f64) / density).sqrt()
    }
}

/// Kirchhoff stress τ = P Fᵀ of `model` at deformation gradient `f`.
#[inline(always)]
pub fn kirchhoff_stress(model: MaterialModel, lame: Lame, f: &Mat3) -> Mat3 {
    match model {
        MaterialModel::NeoHookean => {
            let j = f.determinant().max(J_MIN);
            // τ = μ(FFᵀ − I) + λ ln(J) I: needs no inverse, so it is cheap and finite.
            let mut tau = lame.mu * (f * f.transpose());
            let diag = lame.lambda * j.ln() - lame.mu;
            tau[(0, 0)] += diag;
            tau[(1, 1)] += diag;
            tau[(2, 2)] += diag;
            tau
        }
        MaterialModel::FixedCorotated => {
            let j = f.determinant();
            let r = rotation_of(f);
            let mut tau = 2.0 * lame.mu * (f - r) * f.transpose();
            let diag = lame.lambda * (j - 1.0) * j;
            tau[(0, 0)] += diag;
            tau[(1, 1)] += diag;
            tau[(2, 2)] += diag;
            tau
        }
    }
}

/// First Piola–Kirchhoff stress P = τ F⁻ᵀ (diagnostics and tests; the solver uses τ).
pub fn first_piola(model: MaterialModel, lame: Lame, f: &Mat3) -> Option<Mat3> {
    let f_inv_t = f.try_inverse()?.transpose();
    Some(kirchhoff_stress(model, lame, f) * f_inv_t)
}

/// Strain energy density Ψ(F) per unit reference volume (J/m³), in f64 for tests and energy
/// diagnostics.
pub fn energy_density(model: MaterialModel, lame: Lame, f: &Mat3) -> f64 {
    let mu = lame.mu as f64;
    let lambda = lame.lambda as f64;
    let f64m = f.cast::<f64>();
    let j = f64m.determinant();
    match model {
        MaterialModel::NeoHookean => {
            let ln_j = j.max(J_MIN as f64).ln();
            0.5 * mu * ((f64m.transpose() * f64m).trace() - 3.0) - mu * ln_j
                + 0.5 * lambda * ln_j * ln_j
        }
        MaterialModel::FixedCorotated => {
            let r = rotation_of(f).cast::<f64>();
            mu * (f64m - r).norm_squared() + 0.5 * lambda * (j - 1.0) * (j - 1.0)
        }
    }
}

/// Rotation closest to `a`, by the iterative rotation extraction of Müller et al. (2016).
/// It uses only cross and dot products (no SVD, no division by singular values), so it is
/// defined for inverted and singular matrices and ports line for line to WGSL.
pub fn rotation_of(a: &Mat3) -> Mat3 {
    let mut q = nalgebra::UnitQuaternion::<f32>::identity();
    for _ in 0..ROTATION_ITERATIONS {
        let r = q.to_rotation_matrix().into_inner();
        let omega_num: Vec3 = r.column(0).cross(&a.column(0))
            + r.column(1).cross(&a.column(1))
            + r.column(2).cross(&a.column(2));
        let omega_den = (r.column(0).dot(&a.column(0))
            + r.column(1).dot(&a.column(1))
            + r.column(2).dot(&a.column(2)))
        .abs()
            + 1e-9;
        let omega = omega_num / omega_den;
        let angle = omega.norm();
        if angle < 1e-9 {
            break;
        }
        let axis = nalgebra::Unit::new_unchecked(omega / angle);
        q = nalgebra::UnitQuaternion::from_axis_angle(&axis, angle) * q;
        q.renormalize();
    }
    q.to_rotation_matrix().into_inner()
}

/// Iterations of `rotation_of` (the GPU runs as many).
pub const ROTATION_ITERATIONS: usize = 20;

#[cfg(test)]
mod tests {
    use super::*;

    fn sample_f() -> Vec<Mat3> {
        vec![
            Mat3::new(1.1, 0.05, -0.02, 0.03, 0.92, 0.04, -0.01, 0.06, 1.05),
            Mat3::new(1.3, 0.0, 0.0, 0.0, 0.87, 0.0, 0.0, 0.0, 0.87),
            Mat3::new(0.8, 0.2, 0.1, -0.15, 1.2, 0.0, 0.05, -0.1, 0.95),
        ]
    }

    #[test]
    fn identity_is_stress_free() {
        let lame = Lame::from_young_poisson(5400.0, 0.45);
        for model in [MaterialModel::NeoHookean, MaterialModel::FixedCorotated] {
            let tau = kirchhoff_stress(model, lame, &Mat3::identity());
            assert!(tau.norm() < 1e-3, "{model:?}: {tau}");
            // A pure rotation is stress free too.
            let r = nalgebra::Rotation3::from_euler_angles(0.3, -0.7, 1.1).into_inner();
            let tau = kirchhoff_stress(model, lame, &r);
            assert!(tau.norm() < 2e-2 * lame.mu, "{model:?} rotated: {tau}");
        }
    }

    #[test]
    fn stress_is_the_energy_derivative() {
        let lame = Lame::from_young_poisson(1.0e4, 0.4);
        for model in [MaterialModel::NeoHookean, MaterialModel::FixedCorotated] {
            for f in sample_f() {
                let p = first_piola(model, lame, &f).unwrap();
                let h = 1e-3f32;
                for r in 0..3 {
                    for c in 0..3 {
                        let mut fp = f;
                        fp[(r, c)] += h;
                        let mut fm = f;
                        fm[(r, c)] -= h;
                        let fd = (energy_density(model, lame, &fp)
                            - energy_density(model, lame, &fm))
                            / (2.0 * h as f64);
                        let err = (fd - p[(r, c)] as f64).abs();
                        assert!(
                            err < 2e-3 * lame.mu as f64 + 1e-3 * fd.abs(),
                            "{model:?} dΨ/dF[{r}{c}]: fd {fd}, P {}",
                            p[(r, c)]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn inverted_and_singular_f_stay_finite_and_push_back() {
        let lame = Lame::from_young_poisson(5400.0, 0.49);
        let inverted = Mat3::new(-0.5, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
        let singular = Mat3::new(0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
        for model in [MaterialModel::NeoHookean, MaterialModel::FixedCorotated] {
            for f in [inverted, singular, Mat3::zeros()] {
                let tau = kirchhoff_stress(model, lame, &f);
                assert!(tau.iter().all(|x| x.is_finite()), "{model:?} {f}: {tau}");
            }
        }
        // Crushed to zero volume, Neo-Hookean pressure is compressive (pushes material apart).
        let tau = kirchhoff_stress(MaterialModel::NeoHookean, lame, &(Mat3::identity() * 1e-3));
        assert!(tau.trace() < 0.0);
    }

    #[test]
    fn rotation_extraction_matches_polar_decomposition() {
        let r_true = nalgebra::Rotation3::from_euler_angles(0.4, 0.2, -0.9).into_inner();
        let s = Mat3::new(1.2, 0.1, 0.0, 0.1, 0.9, 0.05, 0.0, 0.05, 1.1);
        let r = rotation_of(&(r_true * s));
        assert!((r - r_true).norm() < 1e-4, "{r} vs {r_true}");
    }
}
