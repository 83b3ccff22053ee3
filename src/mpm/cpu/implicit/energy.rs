//! Φ and its derivatives at the grid velocities: the elastic energy Σ V₀Ψ(Fₚ(v)) from
//! each particle's stencil of MLS kernel gradients, the inertia and slip terms per node,
//! ∇Φ projected onto the free components, and the per-particle stiffness and block-Jacobi
//! preconditioner Newton's linear solve needs.

use super::hessian::velocity_gradient_stiffness;
use super::workspace::{slip_of, NodeWriter, Workspace};
use crate::mpm::cpu::{axis_offsets, CpuSolver, SharedMut};
use crate::mpm::grid::GridLayout;
use crate::mpm::kernel::Stencil;
use crate::mpm::material::{energy_density, first_piola, J_MIN};
use crate::mpm::{Mat3, Preconditioner, Vec3};
use rayon::prelude::*;

/// The 27 stencil nodes of a particle: storage index and MLS kernel gradient
/// ∇wᵢₚ = wᵢₚ·4/dx²·(xᵢ − xₚ) (1/m).
#[inline(always)]
pub(super) fn stencil_gradients(layout: &GridLayout, x: Vec3) -> ([usize; 27], [Vec3; 27]) {
    let s = Stencil::new((x - layout.origin) * layout.inv_dx);
    let offs = axis_offsets(layout, s.base);
    // Offsets are in grid units: 4/dx² · dx = 4/dx.
    let scale = 4.0 * layout.inv_dx;
    let mut idx = [0usize; 27];
    let mut grad = [Vec3::zeros(); 27];
    for a in 0..3 {
        for b in 0..3 {
            for c in 0..3 {
                let k = 9 * a + 3 * b + c;
                idx[k] = offs[0][a] + offs[1][b] + offs[2][c];
                let w = s.w[a].x * s.w[b].y * s.w[c].z;
                grad[k] = (Vec3::new(a as f32, b as f32, c as f32) - s.fx) * (w * scale);
            }
        }
    }
    (idx, grad)
}

/// Σᵢ vᵢ ∇wᵢₚᵀ over a particle's stencil.
#[inline(always)]
pub(super) fn velocity_gradient(v: &[Vec3], idx: &[usize; 27], grad: &[Vec3; 27]) -> Mat3 {
    let mut g = Mat3::zeros();
    for (&i, d) in idx.iter().zip(grad) {
        g += v[i] * d.transpose();
    }
    g
}

impl CpuSolver {
    /// Φ at `ws.v`; ∂E/∂v into `elastic_grad`, the projected ∇Φ into `grad`, and with
    /// `hessian` the particles' stiffness and the preconditioner.
    pub(super) fn evaluate(&self, ws: &mut Workspace, dt: f32, hessian: bool) -> f64 {
        let layout = self.layout;
        let parts = &self.particles;
        let materials = &self.materials[..];
        let precondition = hessian && self.implicit.preconditioner == Preconditioner::BlockJacobi;
        {
            let out = NodeWriter::new(ws);
            self.for_each_node(|i| unsafe {
                *out.elastic_grad.at(i) = Vec3::zeros();
                *out.block.at(i) = Mat3::zeros();
            });
        }
        let v = &ws.v[..];
        let eg = SharedMut(ws.elastic_grad.as_mut_ptr());
        let block = SharedMut(ws.block.as_mut_ptr());
        let stiffness = SharedMut(ws.stiffness.as_mut_ptr());
        let mut elastic = 0.0f64;
        let order = &self.bins.order[..];
        for color in &self.bins.by_color {
            elastic += color
                .par_iter()
                .map(|range| {
                    let mut e = 0.0f64;
                    for &p in &order[range.start as usize..range.end as usize] {
                        let p = p as usize;
                        let (idx, grad) = stencil_gradients(&layout, parts.x[p]);
                        let f_n = parts.f[p];
                        let f = (Mat3::identity() + velocity_gradient(v, &idx, &grad) * dt) * f_n;
                        let mat = materials[parts.material[p] as usize];
                        let vol = parts.volume0[p];
                        e += vol as f64 * energy_density(mat.model, mat.lame, &f);
                        let piola =
                            first_piola(mat.model, mat.lame, &f).unwrap_or_else(Mat3::zeros);
                        let q = piola * f_n.transpose() * (vol * dt);
                        for (&i, d) in idx.iter().zip(&grad) {
                            // SAFETY: particles of one colour scatter to disjoint nodes.
                            unsafe { *eg.at(i) += q * d };
                        }
                        if hessian {
                            let kp = velocity_gradient_stiffness(
                                mat.model,
                                mat.lame,
                                &f,
                                &f_n,
                                vol * dt * dt,
                            );
                            // SAFETY: each particle writes its own entry.
                            unsafe { *stiffness.at(p) = kp };
                            if precondition {
                                for (&i, d) in idx.iter().zip(&grad) {
                                    // Block (a, b) = Σ_c Σ_c' K[a + 3c, b + 3c'] d_c d_c'.
                                    let blk = Mat3::from_fn(|a, b| {
                                        let mut s = 0.0;
                                        for (c, dc) in d.iter().enumerate() {
                                            for (cc, dcc) in d.iter().enumerate() {
                                                s += kp[(a + 3 * c, b + 3 * cc)] * dc * dcc;
                                            }
                                        }
                                        s
                                    });
                                    // SAFETY: as above.
                                    unsafe { *block.at(i) += blk };
                                }
                            }
                        }
                    }
                    e
                })
                .sum::<f64>();
        }
        let threshold = ws.slip_threshold;
        let out = NodeWriter::new(ws);
        let nodal = self.sum_nodes(|i| unsafe {
            let m = *out.mass.at(i);
            if m <= 0.0 {
                return 0.0;
            }
            let v = *out.v.at(i);
            let dv = v - *out.v_star.at(i);
            let free = *out.free.at(i);
            let mut g = dv * m + *out.elastic_grad.at(i);
            let mut d = Mat3::identity() * m;
            let mut dissipation = 0.0;
            if let Some(slip) = out.slip(i, threshold) {
                let terms = slip.terms(&v);
                g += terms.gradient;
                d += terms.hessian;
                dissipation = terms.energy;
            }
            *out.grad.at(i) = free * g;
            if hessian {
                if precondition {
                    d += *out.block.at(i);
                }
                // Inverse on the free subspace: (S D S + I − S)⁻¹ restricted by S.
                let restricted = free * d * free + (Mat3::identity() - free);
                let inv = restricted
                    .try_inverse()
                    .unwrap_or_else(|| Mat3::identity() / m);
                *out.block.at(i) = free * inv * free;
            }
            0.5 * m as f64 * dv.norm_squared() as f64 + dissipation
        });
        nodal + elastic
    }

    /// Φ at velocities `v` (no derivatives); infinite where a step would crush a particle
    /// to `J_MIN` or invert it, so the line search never steps there (the clamped
    /// Neo-Hookean energy stops being the potential of its stress below it).
    pub(super) fn energy_at(&self, ws: &Workspace, v: &[Vec3], dt: f32) -> f64 {
        let layout = self.layout;
        let parts = &self.particles;
        let materials = &self.materials[..];
        let elastic: f64 = (0..parts.len())
            .into_par_iter()
            .with_min_len(256)
            .map(|p| {
                let (idx, grad) = stencil_gradients(&layout, parts.x[p]);
                let f = (Mat3::identity() + velocity_gradient(v, &idx, &grad) * dt) * parts.f[p];
                if f.determinant() <= J_MIN {
                    return f64::INFINITY;
                }
                let mat = materials[parts.material[p] as usize];
                parts.volume0[p] as f64 * energy_density(mat.model, mat.lame, &f)
            })
            .sum();
        let nodal = self.sum_nodes(|i| {
            let m = ws.mass[i];
            if m <= 0.0 {
                return 0.0;
            }
            let slip = slip_of(
                m,
                ws.normal[i],
                &ws.surface[i],
                ws.slip_weight[i],
                ws.slip_threshold,
            );
            0.5 * m as f64 * (v[i] - ws.v_star[i]).norm_squared() as f64
                + slip.map_or(0.0, |s| s.energy(&v[i]))
        });
        nodal + elastic
    }
}
