//! Stepping a rod: substeps of predict → iterations of (direct solve of every constraint,
//! contacts) → velocities from the corrections (XPBD, Macklin 2016/2019).

use super::constraints::Compliance;
use super::direct::{self, DirectScratch};
use super::state::{Quat, Rod};
use crate::mpm::Vec3;
use nalgebra::Vector6;
use serde::{Deserialize, Serialize};

/// Least substeps per frame and iterations per substep.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RodSolverSettings {
    pub substeps: u32,
    pub iterations: u32,
}

impl Default for RodSolverSettings {
    /// Small steps beat many iterations (Macklin 2019). Measured with `bench thread`: a
    /// swinging 1000-segment thread stretches 0.15 % at one substep, 0.11 % at two (120
    /// frames), 0.02 % at four;
    /// the second iteration corrects the f32 rounding of the first (see tests/thread.rs).
    fn default() -> Self {
        RodSolverSettings {
            substeps: 4,
            iterations: 2,
        }
    }
}

/// The solver for one rod: its compliances, multipliers and the previous substep's state.
#[derive(Clone, Debug)]
pub struct RodSolver {
    pub settings: RodSolverSettings,
    pub gravity: Vec3,
    compliance: Compliance,
    /// Per segment: stretch-shear multipliers, then the bend-twist ones of the joint after it.
    lambda: Vec<Vector6<f64>>,
    prev_points: Vec<Vec3>,
    prev_frames: Vec<Quat>,
    scratch: DirectScratch,
}

impl RodSolver {
    pub fn new(rod: &Rod, settings: RodSolverSettings, gravity: Vec3) -> RodSolver {
        let n = rod.segments();
        RodSolver {
            settings,
            gravity,
            compliance: Compliance::of(rod),
            lambda: vec![Vector6::zeros(); n],
            prev_points: rod.points.clone(),
            prev_frames: rod.frames.clone(),
            scratch: DirectScratch::default(),
        }
    }

    /// Advance `rod` by one frame of `dt` seconds. The stretch-shear constraint is linear in
    /// the points, so the direct solve needs no limit on how far a point moves per substep
    /// (the distance constraint's linearisation did: it made cost grow with segments × speed).
    pub fn step_frame(&mut self, rod: &mut Rod, dt: f32) {
        let substeps = self.settings.substeps.max(1);
        let h = dt / substeps as f32;
        for _ in 0..substeps {
            self.substep(rod, h, |_, _| {});
        }
    }

    /// One substep of `h` seconds; `contacts(rod, iteration_h)` projects whatever keeps the
    /// rod out of other bodies, once per iteration after the elastic constraints.
    pub fn substep(&mut self, rod: &mut Rod, h: f32, mut contacts: impl FnMut(&mut Rod, f32)) {
        self.predict(rod, h);
        self.lambda.fill(Vector6::zeros());
        let inv_h2 = 1.0 / (h as f64 * h as f64);
        for _ in 0..self.settings.iterations.max(1) {
            direct::solve(
                rod,
                &self.compliance,
                &mut self.lambda,
                inv_h2,
                &mut self.scratch,
            );
            contacts(rod, h);
        }
        self.update_velocities(rod, h);
        for j in 0..rod.segments() {
            // Jᵀ·λ/h² is the force: λ/(l·h²) on pⱼ₊₁, pulling it back along the segment
            // when stretched.
            let t = (rod.points[j + 1] - rod.points[j])
                .try_normalize(f32::EPSILON)
                .unwrap_or_else(|| rod.director(j))
                .cast::<f64>();
            let lambda = self.lambda[j].fixed_rows::<3>(0).into_owned();
            rod.tension[j] = (-lambda.dot(&t) * inv_h2 / rod.rest_lengths[j] as f64) as f32;
        }
    }

    fn predict(&mut self, rod: &mut Rod, h: f32) {
        self.prev_points.clone_from(&rod.points);
        self.prev_frames.clone_from(&rod.frames);
        for i in 0..rod.points.len() {
            let w = rod.inv_mass[i];
            if w > 0.0 {
                rod.velocities[i] += (self.gravity + rod.external_forces[i] * w) * h;
                rod.points[i] += rod.velocities[i] * h;
            }
        }
        for j in 0..rod.segments() {
            if rod.inv_inertia[j] > 0.0 {
                // Isotropic inertia: no gyroscopic term, no external torque.
                super::state::add_rotation(&mut rod.frames[j], rod.angular_velocities[j] * h);
            }
        }
    }

    fn update_velocities(&mut self, rod: &mut Rod, h: f32) {
        let inv_h = 1.0 / h;
        for i in 0..rod.points.len() {
            if rod.inv_mass[i] > 0.0 {
                rod.velocities[i] = (rod.points[i] - self.prev_points[i]) * inv_h;
            }
        }
        for j in 0..rod.segments() {
            if rod.inv_inertia[j] > 0.0 {
                let mut dq = rod.frames[j] * self.prev_frames[j].conjugate();
                if dq.w < 0.0 {
                    dq = -dq;
                }
                rod.angular_velocities[j] = dq.imag() * (2.0 * inv_h);
            }
        }
    }
}
