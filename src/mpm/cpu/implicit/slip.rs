//! Friction and drag of a node sliding on a tool, the table or a wall, as a dissipation
//! potential in the implicit solve's Φ (lagged friction, Li et al. 2020, IPC §5).
//!
//! A node with one prescribed direction (the surface normal n) slides with the tangential
//! velocity u = T(v − w) relative to the surface (T = I − nnᵀ, w the surface's velocity).
//! Its term of Φ is
//!
//!   D(v) = λ f₀(|u|) + ½ κ |u|²,
//!
//! where λ = μ·N (N·s) is Coulomb's bound from the normal impulse N the surface gave the
//! node at the end of the previous substep, or, for a node arriving, the impulse that stops
//! it at the surface (lagged: λ is constant through the solve, so Φ stays one convex
//! function; the normal force changes little from one step to the next, and re-solving
//! with updated weights measured two to three times the Newton iterations on the
//! implicit GPU agreement test's sphere press), and f₀ is |u| smoothed below the slip
//! threshold ε ([`SLIP_THRESHOLD`](crate::mpm::implicit_params::SLIP_THRESHOLD)·dx/dt):
//! f₀(s) = −s³/(3ε²) + s²/ε + ε/3 under ε, s above it, so that f₀′ = f₁ rises from 0 to 1
//! over [0, ε]. Its gradient, −λ f₁(s) û, is Coulomb friction: of magnitude λ while the node
//! slides, and a stiff viscous hold while it moves slower than ε relative to the surface
//! (static friction, with a slip below ε·dt per step). κ = m·drag/(1 − drag) is the drag
//! that scales the tangential velocity by 1 − drag in the explicit contact (the minimiser of
//! ½m|u − u₀|² + ½κ|u|²).
//!
//! The Hessian, λ[f₁(s)/s T + (f₁′(s) − f₁(s)/s) ûûᵀ] + κT, is positive semi-definite: along
//! û its eigenvalue is λf₁′(s) ≥ 0, across it λf₁(s)/s. Friction inside the minimisation
//! replaces friction applied after it, which the elastic solve never saw and which made
//! the tool's recorded work and the tissue's energy disagree.

use crate::mpm::{Mat3, Vec3};

/// The slip term of one node.
#[derive(Clone, Copy, Debug)]
pub struct Slip {
    /// The surface's unit normal n (the node's prescribed direction).
    pub normal: Vec3,
    /// The surface's velocity.
    pub surface: Vec3,
    /// λ = μ·N (N·s).
    pub friction: f32,
    /// κ (kg).
    pub drag: f32,
    /// ε (m/s).
    pub threshold: f32,
}

/// D, ∇D and ∇²D at velocity `v`.
pub struct SlipTerms {
    /// D(v), J.
    pub energy: f64,
    /// ∇D = ∂D/∂v, N·s.
    pub gradient: Vec3,
    /// ∇²D, kg (positive semi-definite).
    pub hessian: Mat3,
}

impl Slip {
    /// Whether the term is zero everywhere.
    pub fn is_none(&self) -> bool {
        self.friction <= 0.0 && self.drag <= 0.0
    }

    /// The tangential velocity relative to the surface.
    fn tangential(&self, v: &Vec3) -> Vec3 {
        let rel = v - self.surface;
        rel - self.normal * self.normal.dot(&rel)
    }

    /// D at `v` (J).
    pub fn energy(&self, v: &Vec3) -> f64 {
        let u = self.tangential(v);
        let s = u.norm();
        let eps = self.threshold;
        let f0 = if s < eps {
            s * s / eps - s * s * s / (3.0 * eps * eps) + eps / 3.0
        } else {
            s
        };
        self.friction as f64 * f0 as f64 + 0.5 * self.drag as f64 * (s * s) as f64
    }

    /// D, ∇D and ∇²D at `v`.
    pub fn terms(&self, v: &Vec3) -> SlipTerms {
        let u = self.tangential(v);
        let s = u.norm();
        let eps = self.threshold;
        let tangent = Mat3::identity() - self.normal * self.normal.transpose();
        // f₁(s)/s, and the coefficient of ûûᵀ: f₁′(s) − f₁(s)/s.
        let (f1_over_s, along) = if s < eps {
            ((2.0 - s / eps) / eps, -s / (eps * eps))
        } else {
            (1.0 / s, -1.0 / s)
        };
        let unit = if s > 0.0 { u / s } else { Vec3::zeros() };
        let lambda = self.friction;
        let gradient = u * (lambda * f1_over_s + self.drag);
        let hessian =
            tangent * (lambda * f1_over_s + self.drag) + unit * unit.transpose() * (lambda * along);
        SlipTerms {
            energy: self.energy(v),
            gradient,
            hessian,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn slip() -> Slip {
        Slip {
            normal: Vec3::z(),
            surface: Vec3::new(0.0, 0.0, -0.2),
            friction: 2e-3,
            drag: 1e-3,
            threshold: 1e-3,
        }
    }

    #[test]
    fn the_gradient_and_hessian_are_the_derivatives_of_the_energy() {
        let d = slip();
        // Slow (under ε) and fast slides, along several directions; steps of a hundredth
        // of the slide or of ε.
        for v in [
            Vec3::new(0.0003, 0.0002, 0.4),
            Vec3::new(0.0, 0.0004, -0.3),
            Vec3::new(0.03, -0.02, 0.0),
            Vec3::new(-0.05, 0.07, 1.0),
        ] {
            let h = 1e-2 * v.xy().norm().min(d.threshold);
            let t = d.terms(&v);
            for k in 0..3 {
                let e = Vec3::ith(k, h);
                let numeric = (d.energy(&(v + e)) - d.energy(&(v - e))) / (2.0 * h as f64);
                let err = (numeric - t.gradient[k] as f64).abs();
                assert!(
                    err <= 2e-3 * t.gradient.norm() as f64 + 1e-9,
                    "∂D/∂v[{k}] at {v:?}: {numeric} against {}",
                    t.gradient[k]
                );
                let numeric = (d.terms(&(v + e)).gradient - d.terms(&(v - e)).gradient) / (2.0 * h);
                let err = (numeric - t.hessian.column(k)).norm();
                assert!(
                    err <= 2e-2 * t.hessian.norm() + 1e-6,
                    "∂²D/∂v∂v[{k}] at {v:?}: {numeric:?} against {:?}",
                    t.hessian.column(k)
                );
            }
            // Positive semi-definite, and nothing along the normal.
            let eig = t.hessian.symmetric_eigenvalues();
            assert!(eig.min() >= -1e-6 * eig.max(), "{eig:?}");
            assert!((t.hessian * Vec3::z()).norm() < 1e-9);
        }
    }

    #[test]
    fn a_sliding_node_feels_coulomb_friction_and_drag_opposing_its_slide() {
        let d = slip();
        let v = Vec3::new(0.2, 0.0, 5.0);
        let t = d.terms(&v);
        // u = (0.2, 0, 0): friction λ along û plus drag κu.
        let expected = Vec3::new(d.friction + d.drag * 0.2, 0.0, 0.0);
        assert!((t.gradient - expected).norm() < 1e-7, "{:?}", t.gradient);
        // Moving with the surface: no force, and the viscous hold's stiffness 2λ/ε + κ
        // across the normal (finite: a CG on the Hessian needs it).
        let t = d.terms(&Vec3::new(0.0, 0.0, 3.0));
        assert_eq!(t.gradient, Vec3::zeros());
        let hold = 2.0 * d.friction / d.threshold + d.drag;
        let expected = Mat3::from_diagonal(&Vec3::new(hold, hold, 0.0));
        assert!(
            (t.hessian - expected).norm() < 1e-6 * hold,
            "{:?}",
            t.hessian
        );
    }
}
