//! Stepping a rod: substeps of predict → iterations of (stretch-shear, bend-twist, direct
//! distance solve) → velocities from the corrections (XPBD, Macklin 2016/2019).

use super::constraints::{project_bend_twist, project_stretch_shear, Compliance};
use super::distance::{solve_distances, DistanceScratch};
use super::state::{Quat, Rod};
use crate::mpm::Vec3;
use serde::{Deserialize, Serialize};

/// Direct distance solves per iteration. One solve is exact for the linearised chain, but
/// it holds the segment directions fixed: under tension that treats the transverse
/// (geometric) stiffness explicitly, which is unstable once a transverse wave crosses a
/// segment within a substep (a hanging 40-segment thread at 240 Hz). A second Newton step
/// with the updated directions makes the projection implicit in them and stable.
const DISTANCE_NEWTON_STEPS: usize = 2;

/// Largest travel of a point per substep, in shortest segment lengths.
const MAX_TRAVEL_PER_SUBSTEP: f32 = 0.5;

/// Bound on the substeps of one frame (a thread thrown at tens of m/s still ends the frame).
pub const MAX_SUBSTEPS: u32 = 2048;

/// Least substeps per frame and iterations per substep.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RodSolverSettings {
    pub substeps: u32,
    pub iterations: u32,
}

impl Default for RodSolverSettings {
    /// Small steps beat many iterations (Macklin 2019); the direct distance solve makes
    /// the length exact in one iteration.
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
    lambda_stretch: Vec<f32>,
    lambda_shear: Vec<Vec3>,
    lambda_bend: Vec<Vec3>,
    prev_points: Vec<Vec3>,
    prev_frames: Vec<Quat>,
    distance: DistanceScratch,
}

impl RodSolver {
    pub fn new(rod: &Rod, settings: RodSolverSettings, gravity: Vec3) -> RodSolver {
        let n = rod.segments();
        RodSolver {
            settings,
            gravity,
            compliance: Compliance::of(rod),
            lambda_stretch: vec![0.0; n],
            lambda_shear: vec![Vec3::zeros(); n],
            lambda_bend: vec![Vec3::zeros(); n.saturating_sub(1)],
            prev_points: rod.points.clone(),
            prev_frames: rod.frames.clone(),
            distance: DistanceScratch::default(),
        }
    }

    /// Advance `rod` by one frame of `dt` seconds.
    pub fn step_frame(&mut self, rod: &mut Rod, dt: f32) {
        let substeps = self.substeps_for(rod, dt);
        let h = dt / substeps as f32;
        for _ in 0..substeps {
            self.substep(rod, h, |_, _| {});
        }
    }

    /// At least `settings.substeps`, and enough that no point moves more than half its
    /// shortest segment in one substep: the direct distance solve linearises about the
    /// segment directions, and a fine thread moving further than a segment per substep makes
    /// the Newton step overshoot sideways and diverge (a 100-segment thread swinging at
    /// 4 substeps per 60 Hz frame does). The cost is therefore linear in segments times speed.
    pub fn substeps_for(&self, rod: &Rod, dt: f32) -> u32 {
        let fastest =
            rod.velocities.iter().map(|v| v.norm()).fold(0.0, f32::max) + self.gravity.norm() * dt;
        let shortest = rod.rest_lengths.iter().copied().fold(f32::MAX, f32::min);
        let needed = (fastest * dt / (MAX_TRAVEL_PER_SUBSTEP * shortest)).ceil();
        let needed = if needed.is_finite() {
            needed.min(MAX_SUBSTEPS as f32) as u32
        } else {
            MAX_SUBSTEPS
        };
        needed.max(self.settings.substeps.max(1))
    }

    /// One substep of `h` seconds; `contacts(rod, iteration_h)` projects whatever keeps the
    /// rod out of other bodies, once per iteration after the elastic constraints.
    pub fn substep(&mut self, rod: &mut Rod, h: f32, mut contacts: impl FnMut(&mut Rod, f32)) {
        self.predict(rod, h);
        self.lambda_stretch.fill(0.0);
        self.lambda_shear.fill(Vec3::zeros());
        self.lambda_bend.fill(Vec3::zeros());
        let inv_h2 = 1.0 / (h * h);
        for _ in 0..self.settings.iterations.max(1) {
            project_stretch_shear(rod, &self.compliance.shear, &mut self.lambda_shear, inv_h2);
            project_bend_twist(
                rod,
                &self.compliance.bend_twist,
                &mut self.lambda_bend,
                inv_h2,
            );
            contacts(rod, h);
            // Last, so that each iteration ends with the length the material allows.
            for _ in 0..DISTANCE_NEWTON_STEPS {
                solve_distances(
                    rod,
                    &self.compliance.stretch,
                    &mut self.lambda_stretch,
                    inv_h2,
                    &mut self.distance,
                );
            }
        }
        self.update_velocities(rod, h);
        for (t, l) in rod.tension.iter_mut().zip(&self.lambda_stretch) {
            // λ·∇C is an impulse·h; C > 0 (stretched) gives λ < 0.
            *t = -l * inv_h2;
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
