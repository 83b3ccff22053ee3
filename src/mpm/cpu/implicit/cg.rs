//! Newton's linear solve: preconditioned conjugate gradients on H·step = −∇Φ over the free
//! components, matrix-free (a Hessian product gathers each particle's velocity gradient,
//! multiplies its 9×9 stiffness and scatters back, block colours in turn).

use super::energy::{stencil_gradients, velocity_gradient};
use super::workspace::{NodeWriter, Workspace};
use crate::mpm::cpu::{CpuSolver, SharedMut};
use crate::mpm::{ImplicitParams, Mat3, Vec3};

/// Flattened column-major, as the 9×9 stiffness expects.
#[inline(always)]
fn flatten(m: &Mat3) -> nalgebra::SVector<f32, 9> {
    nalgebra::SVector::<f32, 9>::from_column_slice(m.as_slice())
}

#[inline(always)]
fn unflatten(v: &nalgebra::SVector<f32, 9>) -> Mat3 {
    Mat3::from_column_slice(v.as_slice())
}

impl CpuSolver {
    /// Preconditioned CG on H·step = −∇Φ over the free components until its residual is
    /// below `target` (N·s); returns its iterations.
    pub(super) fn conjugate_gradients(
        &self,
        ws: &mut Workspace,
        params: &ImplicitParams,
        target: f64,
    ) -> u32 {
        {
            let out = NodeWriter::new(ws);
            self.for_each_node(|i| unsafe {
                let r = -*out.grad.at(i);
                let z = *out.block.at(i) * r;
                *out.step.at(i) = Vec3::zeros();
                *out.residual.at(i) = r;
                *out.precond_residual.at(i) = z;
                *out.direction.at(i) = z;
            });
        }
        let mut rz = self.sum_nodes(|i| ws.residual[i].dot(&ws.precond_residual[i]) as f64);
        let mut iterations = 0;
        while iterations < params.cg_iterations {
            self.hessian_product(ws);
            let pap = self.sum_nodes(|i| ws.direction[i].dot(&ws.product[i]) as f64);
            if pap.is_nan() || pap <= 0.0 {
                break;
            }
            let alpha = (rz / pap) as f32;
            iterations += 1;
            let r_norm = {
                let out = NodeWriter::new(ws);
                self.sum_nodes(|i| unsafe {
                    *out.step.at(i) += *out.direction.at(i) * alpha;
                    let r = *out.residual.at(i) - *out.product.at(i) * alpha;
                    *out.residual.at(i) = r;
                    *out.precond_residual.at(i) = *out.block.at(i) * r;
                    r.norm_squared() as f64
                })
                .sqrt()
            };
            if r_norm <= target {
                break;
            }
            let rz_new = self.sum_nodes(|i| ws.residual[i].dot(&ws.precond_residual[i]) as f64);
            let beta = (rz_new / rz) as f32;
            rz = rz_new;
            let out = NodeWriter::new(ws);
            self.for_each_node(|i| unsafe {
                *out.direction.at(i) = *out.precond_residual.at(i) + *out.direction.at(i) * beta;
            });
        }
        iterations
    }

    /// `product` = S·H·S `direction`: inertia plus the particles' stiffness, matrix-free
    /// (gather of the velocity gradient, 9×9 product, scatter).
    fn hessian_product(&self, ws: &mut Workspace) {
        let layout = self.layout;
        let parts = &self.particles;
        {
            let out = NodeWriter::new(ws);
            self.for_each_node(|i| unsafe { *out.product.at(i) = Vec3::zeros() });
        }
        let x = &ws.direction[..];
        let stiffness = &ws.stiffness[..];
        let product = SharedMut(ws.product.as_mut_ptr());
        self.for_each_particle_coloured(|p| {
            let (idx, grad) = stencil_gradients(&layout, parts.x[p]);
            let dg = velocity_gradient(x, &idx, &grad);
            let q = unflatten(&(stiffness[p] * flatten(&dg)));
            for (&i, d) in idx.iter().zip(&grad) {
                // SAFETY: particles of one colour scatter to disjoint nodes.
                unsafe { *product.at(i) += q * d };
            }
        });
        let threshold = ws.slip_threshold;
        let out = NodeWriter::new(ws);
        self.for_each_node(|i| unsafe {
            let m = *out.mass.at(i);
            let free = *out.free.at(i);
            let d = *out.direction.at(i);
            let mut q = *out.product.at(i) + d * m;
            if let Some(slip) = out.slip(i, threshold) {
                q += slip.terms(&*out.v.at(i)).hessian * d;
            }
            *out.product.at(i) = free * q;
        });
    }
}
