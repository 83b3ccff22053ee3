//! The implicit solve's buffers, the raw node writers its parallel node loops use, and
//! the loops themselves: over the nodes of the touched blocks (each index once) and over
//! the particles in block colours (particles running at the same time scatter to disjoint
//! nodes).

use super::constraints::{self, Surface};
use super::hessian::Mat9;
use super::slip::Slip;
use crate::mpm::cpu::{CpuSolver, SharedMut};
use crate::mpm::grid::NODES_PER_BLOCK;
use crate::mpm::{Mat3, Vec3};
use rayon::prelude::*;

/// Buffers of the implicit solve: node arrays indexed like the grid (only the nodes of the
/// touched blocks are read or written), particle arrays indexed like the particles.
#[derive(Default)]
pub struct Workspace {
    pub(super) mass: Vec<f32>,
    /// Velocity without elasticity, pⁿ/m + g dt.
    pub(super) v_star: Vec<Vec3>,
    /// The Newton iterate.
    pub(super) v: Vec<Vec3>,
    /// Line-search trial velocities.
    pub(super) trial: Vec<Vec3>,
    /// ∂(Σ V₀Ψ)/∂v: the elastic part of ∇Φ (−dt × the elastic force).
    pub(super) elastic_grad: Vec<Vec3>,
    /// Projected ∇Φ.
    pub(super) grad: Vec<Vec3>,
    /// Newton step and the CG vectors.
    pub(super) step: Vec<Vec3>,
    pub(super) residual: Vec<Vec3>,
    pub(super) precond_residual: Vec<Vec3>,
    pub(super) direction: Vec<Vec3>,
    pub(super) product: Vec<Vec3>,
    /// Projection onto each node's free velocity components, and the prescribed part.
    pub(super) free: Vec<Mat3>,
    pub(super) prescribed: Vec<Vec3>,
    /// Surface normal of a node with one prescribed direction (see `constraints`).
    pub(super) normal: Vec<Vec3>,
    /// The surface such a node slides on, and its friction weight λ = μ·N (N·s; `slip`).
    pub(super) surface: Vec<Surface>,
    pub(super) slip_weight: Vec<f32>,
    /// The slip threshold ε of this substep (m/s).
    pub(super) slip_threshold: f32,
    /// Diagonal Hessian block, then the preconditioner (its projected inverse).
    pub(super) block: Vec<Mat3>,
    /// Per particle: velocity-gradient stiffness (see `hessian`).
    pub(super) stiffness: Vec<Mat9>,
    /// ‖∇Φ‖ over the free components at each Newton iterate of the last substep.
    pub(super) residuals: Vec<f64>,
    /// v − v* along the free components at the end of the last substep (the velocity the
    /// elastic forces added, dt·f/m), kept for the next substep's warm start; zero outside
    /// `correction_blocks`.
    pub(super) correction: Vec<Vec3>,
    /// The normal impulse N (N·s) a surface gave each node with one prescribed direction at
    /// the end of the last substep, zero elsewhere: the next substep's first friction
    /// weights (`slip`); zero outside `correction_blocks`.
    pub(super) carried_impulse: Vec<f32>,
    /// The blocks the last substep touched: where `correction` may be non-zero.
    pub(super) correction_blocks: Vec<u32>,
}

impl Workspace {
    pub(super) fn fit(&mut self, nodes: usize, particles: usize) {
        if self.mass.len() != nodes {
            for v in [
                &mut self.v_star,
                &mut self.v,
                &mut self.trial,
                &mut self.elastic_grad,
                &mut self.grad,
                &mut self.step,
                &mut self.residual,
                &mut self.precond_residual,
                &mut self.direction,
                &mut self.product,
                &mut self.prescribed,
                &mut self.normal,
            ] {
                *v = vec![Vec3::zeros(); nodes];
            }
            self.mass = vec![0.0; nodes];
            self.slip_weight = vec![0.0; nodes];
            self.surface = vec![Surface::still(); nodes];
            self.correction = vec![Vec3::zeros(); nodes];
            self.carried_impulse = vec![0.0; nodes];
            self.correction_blocks.clear();
            self.free = vec![Mat3::zeros(); nodes];
            self.block = vec![Mat3::zeros(); nodes];
        }
        if self.stiffness.len() != particles {
            self.stiffness = vec![Mat9::zeros(); particles];
        }
    }
}

impl<T> SharedMut<T> {
    /// Element `i`.
    ///
    /// # Safety
    /// `i` is in bounds and no other thread touches element `i` meanwhile.
    #[allow(clippy::mut_from_ref)]
    #[inline(always)]
    pub(super) unsafe fn at(&self, i: usize) -> &mut T {
        &mut *self.0.add(i)
    }
}

impl CpuSolver {
    /// Runs every node of the touched blocks through `f` (each index once, in parallel).
    pub(super) fn for_each_node(&self, f: impl Fn(usize) + Sync + Send) {
        self.bins.touched.par_iter().with_min_len(4).for_each(|&b| {
            let start = b as usize * NODES_PER_BLOCK;
            (start..start + NODES_PER_BLOCK).for_each(&f);
        });
    }

    /// Σ over the nodes of the touched blocks, in f64.
    pub(super) fn sum_nodes(&self, f: impl Fn(usize) -> f64 + Sync + Send) -> f64 {
        self.bins
            .touched
            .par_iter()
            .with_min_len(4)
            .map(|&b| {
                let start = b as usize * NODES_PER_BLOCK;
                (start..start + NODES_PER_BLOCK).map(&f).sum::<f64>()
            })
            .sum()
    }

    /// Runs every particle through `f`, block colours in turn, so that particles running
    /// at the same time scatter to disjoint nodes (see `binning`).
    pub(super) fn for_each_particle_coloured(&self, f: impl Fn(usize) + Sync + Send) {
        let order = &self.bins.order[..];
        for color in &self.bins.by_color {
            color.par_iter().for_each(|range| {
                for &p in &order[range.start as usize..range.end as usize] {
                    f(p as usize);
                }
            });
        }
    }
}

/// The slip term of a node of mass `m` with surface normal `normal` (zero: none), sliding
/// on `surface` with friction weight `weight`.
#[inline(always)]
pub(super) fn slip_of(
    m: f32,
    normal: Vec3,
    surface: &Surface,
    weight: f32,
    threshold: f32,
) -> Option<Slip> {
    if normal.norm_squared() == 0.0 {
        return None;
    }
    let slip = Slip {
        normal,
        surface: surface.velocity,
        friction: weight,
        drag: m * surface.drag / (1.0 - surface.drag),
        threshold,
    };
    (!slip.is_none()).then_some(slip)
}

/// Raw pointers to the workspace's node arrays for the node loops, each of which writes
/// every node index once.
pub(super) struct NodeWriter {
    pub(super) mass: SharedMut<f32>,
    pub(super) v_star: SharedMut<Vec3>,
    pub(super) v: SharedMut<Vec3>,
    pub(super) trial: SharedMut<Vec3>,
    pub(super) elastic_grad: SharedMut<Vec3>,
    pub(super) grad: SharedMut<Vec3>,
    pub(super) step: SharedMut<Vec3>,
    pub(super) residual: SharedMut<Vec3>,
    pub(super) precond_residual: SharedMut<Vec3>,
    pub(super) direction: SharedMut<Vec3>,
    pub(super) product: SharedMut<Vec3>,
    pub(super) free: SharedMut<Mat3>,
    pub(super) prescribed: SharedMut<Vec3>,
    pub(super) normal: SharedMut<Vec3>,
    pub(super) surface: SharedMut<Surface>,
    pub(super) slip_weight: SharedMut<f32>,
    pub(super) block: SharedMut<Mat3>,
}

impl NodeWriter {
    pub(super) fn new(ws: &mut Workspace) -> Self {
        NodeWriter {
            mass: SharedMut(ws.mass.as_mut_ptr()),
            v_star: SharedMut(ws.v_star.as_mut_ptr()),
            v: SharedMut(ws.v.as_mut_ptr()),
            trial: SharedMut(ws.trial.as_mut_ptr()),
            elastic_grad: SharedMut(ws.elastic_grad.as_mut_ptr()),
            grad: SharedMut(ws.grad.as_mut_ptr()),
            step: SharedMut(ws.step.as_mut_ptr()),
            residual: SharedMut(ws.residual.as_mut_ptr()),
            precond_residual: SharedMut(ws.precond_residual.as_mut_ptr()),
            direction: SharedMut(ws.direction.as_mut_ptr()),
            product: SharedMut(ws.product.as_mut_ptr()),
            free: SharedMut(ws.free.as_mut_ptr()),
            prescribed: SharedMut(ws.prescribed.as_mut_ptr()),
            normal: SharedMut(ws.normal.as_mut_ptr()),
            surface: SharedMut(ws.surface.as_mut_ptr()),
            slip_weight: SharedMut(ws.slip_weight.as_mut_ptr()),
            block: SharedMut(ws.block.as_mut_ptr()),
        }
    }

    /// Clears node `i` of every array.
    ///
    /// # Safety
    /// No other thread may touch node `i` meanwhile.
    pub(super) unsafe fn zero(&self, i: usize) {
        for p in [
            &self.v_star,
            &self.v,
            &self.trial,
            &self.elastic_grad,
            &self.grad,
            &self.step,
            &self.residual,
            &self.precond_residual,
            &self.direction,
            &self.product,
            &self.prescribed,
            &self.normal,
        ] {
            *p.at(i) = Vec3::zeros();
        }
        *self.free.at(i) = Mat3::zeros();
        *self.block.at(i) = Mat3::zeros();
        *self.surface.at(i) = Surface::still();
        *self.slip_weight.at(i) = 0.0;
    }

    /// Sets node `i`'s constraint `c`, chosen at velocity `v`, and projects `v` onto it
    /// into the iterate. Its friction weight is μ times the normal impulse `carried` over
    /// from the last substep where that was one, else the impulse that stops `v` at the
    /// surface (a node arriving), until the solve gives a better one.
    ///
    /// # Safety
    /// No other thread may touch node `i` meanwhile.
    pub(super) unsafe fn constrain(
        &self,
        i: usize,
        c: &constraints::NodeConstraint,
        v: Vec3,
        carried: f32,
    ) {
        let m = *self.mass.at(i);
        let arrival = m * (c.surface.velocity - v).dot(&c.normal).max(0.0);
        let impulse = if carried > 0.0 { carried } else { arrival };
        *self.free.at(i) = c.free;
        *self.prescribed.at(i) = c.prescribed;
        *self.normal.at(i) = c.normal;
        *self.surface.at(i) = c.surface;
        *self.slip_weight.at(i) = c.surface.friction * impulse;
        *self.v.at(i) = c.free * v + c.prescribed;
    }

    /// The slip term of node `i` (see `slip`), if it has one.
    ///
    /// # Safety
    /// No other thread may write node `i` meanwhile.
    pub(super) unsafe fn slip(&self, i: usize, threshold: f32) -> Option<Slip> {
        slip_of(
            *self.mass.at(i),
            *self.normal.at(i),
            &*self.surface.at(i),
            *self.slip_weight.at(i),
            threshold,
        )
    }
}
