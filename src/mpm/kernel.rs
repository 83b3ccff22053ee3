//! Quadratic B-spline interpolation weights (the MLS-MPM kernel).
//!
//! A particle at grid coordinate `x / dx` touches the 3×3×3 nodes starting at
//! `base = floor(x / dx - 0.5)`. Quadratic splines are C¹, which avoids the
//! cell-crossing noise of linear kernels, and make the APIC inertia tensor
//! `D = dx²/4 · I` constant.

use super::{IVec3, Vec3};

/// Stencil of one particle: its base node and the per-axis weights of the three nodes.
#[derive(Clone, Copy, Debug)]
pub struct Stencil {
    /// Lowest node index of the 3×3×3 stencil.
    pub base: IVec3,
    /// `fx = x/dx - base`, in [0.5, 1.5) per axis.
    pub fx: Vec3,
    /// `w[a][axis]`: weight of node `base + a` along `axis`.
    pub w: [Vec3; 3],
}

impl Stencil {
    /// `grid_pos` is the particle position in grid units (`(x - origin) / dx`), at least
    /// 0.5 on every axis (solvers keep particles inside `GridLayout::particle_bounds`).
    #[inline(always)]
    pub fn new(grid_pos: Vec3) -> Self {
        // Truncation equals floor for the non-negative values the solver passes, and avoids
        // a libm call on CPUs without SSE4.1 rounding.
        let base_f = (grid_pos - Vec3::repeat(0.5)).map(|g| g as i32 as f32);
        let fx = grid_pos - base_f;
        let w0 = (Vec3::repeat(1.5) - fx).map(|t| 0.5 * t * t);
        let w1 = (fx - Vec3::repeat(1.0)).map(|t| 0.75 - t * t);
        let w2 = (fx - Vec3::repeat(0.5)).map(|t| 0.5 * t * t);
        Stencil {
            base: IVec3::new(base_f.x as i32, base_f.y as i32, base_f.z as i32),
            fx,
            w: [w0, w1, w2],
        }
    }

    /// Weight of stencil node (a, b, c), each in 0..3.
    #[inline(always)]
    pub fn weight(&self, a: usize, b: usize, c: usize) -> f32 {
        self.w[a].x * self.w[b].y * self.w[c].z
    }

    /// Offset from the particle to stencil node (a, b, c), in grid units.
    #[inline(always)]
    pub fn offset(&self, a: usize, b: usize, c: usize) -> Vec3 {
        Vec3::new(a as f32, b as f32, c as f32) - self.fx
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_partition_unity_and_reproduce_position() {
        for &p in &[
            Vec3::new(3.5, 4.2, 7.9),
            Vec3::new(10.0, 10.49, 10.51),
            Vec3::new(2.0001, 5.75, 6.25),
        ] {
            let s = Stencil::new(p);
            let mut sum = 0.0;
            let mut first_moment = Vec3::zeros();
            for a in 0..3 {
                for b in 0..3 {
                    for c in 0..3 {
                        let w = s.weight(a, b, c);
                        sum += w;
                        first_moment += w * s.offset(a, b, c);
                    }
                }
            }
            assert!((sum - 1.0).abs() < 1e-6, "weights sum to {sum}");
            // Quadratic B-splines reproduce linear functions: sum w (x_i - x_p) = 0.
            assert!(first_moment.norm() < 1e-5, "first moment {first_moment:?}");
        }
    }
}
