//! Second derivative of the strain energy, ∂P/∂F as a 9×9 matrix, made positive
//! semi-definite for Newton's method.
//!
//! Matrices are flattened column-major, k = row + 3·column (nalgebra's storage order).
//!
//! Neo-Hookean, P = μF + (λ ln J − μ)F⁻ᵀ (with d F⁻ᵀ = −F⁻ᵀ δFᵀ F⁻ᵀ, d ln J = F⁻ᵀ : δF):
//!   δP = μ δF + (μ − λ ln J) F⁻ᵀ δFᵀ F⁻ᵀ + λ (F⁻ᵀ : δF) F⁻ᵀ.
//! Below `J_MIN` the stress sees J clamped (see [`crate::mpm::material`]), so the λ ln J
//! term has no derivative there.
//!
//! Fixed-corotated, P = 2μ(F − R) + λ(J − 1) cof F with cof F = J F⁻ᵀ, whose columns are
//! f₁×f₂, f₂×f₀, f₀×f₁ (no inverse needed):
//!   δP = 2μ(δF − δR) + λ (cof F : δF) cof F + λ(J − 1) δcof F.
//! δR from the polar decomposition F = RS: Rᵀ δF − δFᵀ R = ω̂S + Sω̂ = ((tr S)I − S)ω as a
//! skew matrix, so ω = ((tr S)I − S)⁻¹ axial(Rᵀ δF − δFᵀ R) and δR = R ω̂.
//!
//! Both Hessians are indefinite away from rest (Neo-Hookean's F⁻ᵀ δFᵀ F⁻ᵀ term has
//! eigenvalues of both signs; fixed-corotated's rotational term turns negative under
//! compression), and Newton's conjugate gradients need a positive semi-definite matrix. The
//! definiteness fix: a Cholesky test first (the common case near rest passes and costs a
//! factorisation), otherwise the symmetric eigen-decomposition with negative eigenvalues
//! set to zero, the closest PSD matrix in the Frobenius norm (Teran et al. 2005 project in
//! the same way, per singular-value block).

use crate::mpm::material::{rotation_of, J_MIN};
use crate::mpm::{Lame, Mat3, MaterialModel, Vec3};
use nalgebra::SMatrix;

/// A 9×9 matrix, such as ∂P/∂F with F and P flattened column-major to 9-vectors.
pub type Mat9 = SMatrix<f32, 9, 9>;

/// ∂P/∂F at one F, with what every direction δF shares computed once.
enum Linearization {
    NeoHookean {
        mu: f32,
        f_inv_t: Mat3,
        /// μ − λ ln J.
        flip: f32,
        /// λ where J is above the clamp, zero below.
        volume: f32,
    },
    FixedCorotated {
        mu: f32,
        lambda: f32,
        r: Mat3,
        /// ((tr S)I − S)⁻¹, zero where singular.
        spin: Mat3,
        f: Mat3,
        cof: Mat3,
        j: f32,
    },
    /// A singular F under Neo-Hookean: only the μ δF term is defined.
    Shear { mu: f32 },
}

impl Linearization {
    fn new(model: MaterialModel, lame: Lame, f: &Mat3) -> Self {
        match model {
            MaterialModel::NeoHookean => {
                let j = f.determinant();
                let Some(f_inv) = f.try_inverse() else {
                    return Linearization::Shear { mu: lame.mu };
                };
                Linearization::NeoHookean {
                    mu: lame.mu,
                    f_inv_t: f_inv.transpose(),
                    flip: lame.mu - lame.lambda * j.max(J_MIN).ln(),
                    volume: if j > J_MIN { lame.lambda } else { 0.0 },
                }
            }
            MaterialModel::FixedCorotated => {
                let r = rotation_of(f);
                let s = r.transpose() * f;
                let s = (s + s.transpose()) * 0.5;
                // (tr S)I − S is singular only when two singular values cancel (an inverted
                // element at the flip); its derivative there is unbounded and left out.
                let spin = (Mat3::identity() * s.trace() - s)
                    .try_inverse()
                    .unwrap_or_else(Mat3::zeros);
                Linearization::FixedCorotated {
                    mu: lame.mu,
                    lambda: lame.lambda,
                    r,
                    spin,
                    f: *f,
                    cof: cofactor(f),
                    j: f.determinant(),
                }
            }
        }
    }

    fn apply(&self, df: &Mat3) -> Mat3 {
        match *self {
            Linearization::Shear { mu } => df * mu,
            Linearization::NeoHookean {
                mu,
                f_inv_t,
                flip,
                volume,
            } => {
                df * mu
                    + f_inv_t * df.transpose() * f_inv_t * flip
                    + f_inv_t * (volume * f_inv_t.component_mul(df).sum())
            }
            Linearization::FixedCorotated {
                mu,
                lambda,
                r,
                spin,
                f,
                cof,
                j,
            } => {
                let a = r.transpose() * df;
                let skew = a - a.transpose();
                let axial = Vec3::new(skew[(2, 1)], skew[(0, 2)], skew[(1, 0)]);
                let dr = r * (spin * axial).cross_matrix();
                (df - dr) * (2.0 * mu)
                    + cof * (lambda * cof.component_mul(df).sum())
                    + cofactor_derivative(&f, df) * (lambda * (j - 1.0))
            }
        }
    }
}

/// Directional derivative of the first Piola–Kirchhoff stress: δP = ∂P/∂F : δF.
pub fn stress_derivative(model: MaterialModel, lame: Lame, f: &Mat3, df: &Mat3) -> Mat3 {
    Linearization::new(model, lame, f).apply(df)
}

/// cof F = J F⁻ᵀ: columns f₁×f₂, f₂×f₀, f₀×f₁.
fn cofactor(f: &Mat3) -> Mat3 {
    let (f0, f1, f2) = (f.column(0), f.column(1), f.column(2));
    Mat3::from_columns(&[f1.cross(&f2), f2.cross(&f0), f0.cross(&f1)])
}

fn cofactor_derivative(f: &Mat3, df: &Mat3) -> Mat3 {
    let (f0, f1, f2) = (f.column(0), f.column(1), f.column(2));
    let (d0, d1, d2) = (df.column(0), df.column(1), df.column(2));
    Mat3::from_columns(&[
        d1.cross(&f2) + f1.cross(&d2),
        d2.cross(&f0) + f2.cross(&d0),
        d0.cross(&f1) + f0.cross(&d1),
    ])
}

/// The 9×9 matrix of ∂P/∂F at `f` (column-major flattening), symmetrised.
pub fn stress_hessian(model: MaterialModel, lame: Lame, f: &Mat3) -> Mat9 {
    let lin = Linearization::new(model, lame, f);
    let mut a = Mat9::zeros();
    for j in 0..9 {
        let mut e = Mat3::zeros();
        e[(j % 3, j / 3)] = 1.0;
        let dp = lin.apply(&e);
        for (k, v) in dp.as_slice().iter().enumerate() {
            a[(k, j)] = *v;
        }
    }
    (a + a.transpose()) * 0.5
}

/// The closest positive semi-definite matrix to the symmetric `a` (module docs); `scale`
/// (Pa, e.g. λ + 2μ) sets how small an eigenvalue the Cholesky test lets pass as zero.
pub fn project_psd(a: &Mat9, scale: f32) -> Mat9 {
    let shifted = a + Mat9::identity() * (1e-5 * scale);
    if shifted.cholesky().is_some() {
        return *a;
    }
    let eig = a.symmetric_eigen();
    let clamped = eig.eigenvalues.map(|l| l.max(0.0));
    eig.eigenvectors * Mat9::from_diagonal(&clamped) * eig.eigenvectors.transpose()
}

/// The velocity-gradient stiffness of one particle: the 9×9 map from a grid velocity
/// gradient δG to V₀dt²·(∂P/∂F : δG Fₙ)Fₙᵀ, whose products with the kernel gradients are
/// the particle's share of the Hessian of the backward-Euler energy (see `super`).
/// Positive semi-definite: a congruence of the projected ∂P/∂F.
pub fn velocity_gradient_stiffness(
    model: MaterialModel,
    lame: Lame,
    f: &Mat3,
    f_n: &Mat3,
    volume_dt2: f32,
) -> Mat9 {
    let a = project_psd(&stress_hessian(model, lame, f), lame.lambda + 2.0 * lame.mu);
    // L maps vec(δG) to vec(δG Fₙ); Lᵀ maps vec(Y) to vec(Y Fₙᵀ).
    let mut l = Mat9::zeros();
    for j in 0..9 {
        let mut e = Mat3::zeros();
        e[(j % 3, j / 3)] = 1.0;
        let col = e * f_n;
        for (k, v) in col.as_slice().iter().enumerate() {
            l[(k, j)] = *v;
        }
    }
    l.transpose() * a * l * volume_dt2
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mpm::material::first_piola;

    fn samples() -> Vec<Mat3> {
        vec![
            Mat3::identity(),
            Mat3::new(1.1, 0.05, -0.02, 0.03, 0.92, 0.04, -0.01, 0.06, 1.05),
            Mat3::new(1.3, 0.0, 0.0, 0.0, 0.8, 0.0, 0.0, 0.0, 0.87),
            Mat3::new(0.8, 0.2, 0.1, -0.15, 1.2, 0.0, 0.05, -0.1, 0.95),
        ]
    }

    #[test]
    fn stress_derivative_matches_finite_differences() {
        let lame = Lame::from_young_poisson(1.0e4, 0.4);
        let scale = lame.lambda + 2.0 * lame.mu;
        let df = Mat3::new(0.3, -0.2, 0.1, 0.05, 0.4, -0.3, 0.2, 0.1, -0.25);
        for model in [MaterialModel::NeoHookean, MaterialModel::FixedCorotated] {
            for f in samples() {
                let h = 1e-3;
                let fd = (first_piola(model, lame, &(f + df * h)).unwrap()
                    - first_piola(model, lame, &(f - df * h)).unwrap())
                    / (2.0 * h);
                let dp = stress_derivative(model, lame, &f, &df);
                assert!(
                    (fd - dp).norm() < 2e-3 * scale,
                    "{model:?} at {f}: finite difference {fd}, analytic {dp}"
                );
            }
        }
    }

    #[test]
    fn projection_leaves_no_negative_curvature_and_keeps_psd_matrices() {
        let lame = Lame::from_young_poisson(1.0e4, 0.45);
        let scale = lame.lambda + 2.0 * lame.mu;
        // Strong compression makes both models' ∂P/∂F indefinite.
        let crushed = Mat3::new(0.5, 0.1, 0.0, 0.0, 0.6, 0.05, 0.0, 0.0, 1.4);
        for model in [MaterialModel::NeoHookean, MaterialModel::FixedCorotated] {
            let a = stress_hessian(model, lame, &crushed);
            let before = a.symmetric_eigen().eigenvalues.min();
            let p = project_psd(&a, scale);
            let after = p.symmetric_eigen().eigenvalues.min();
            assert!(after > -1e-4 * scale, "{model:?}: {before} → {after}");
            // A matrix already PSD (rest state) is returned unchanged.
            let rest = stress_hessian(model, lame, &Mat3::identity());
            assert_eq!(project_psd(&rest, scale), rest);
        }
        let nh = stress_hessian(MaterialModel::NeoHookean, lame, &crushed);
        assert!(nh.symmetric_eigen().eigenvalues.min() < -1e-3 * scale);
    }
}
