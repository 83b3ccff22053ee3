//! A suture thread in the world: the rod (see [`crate::rod`]) with its solver, the ends the
//! scene holds, the table and domain it lies in, and the grippers holding it
//! ([`grasp`]). The world steps each thread once per frame alongside the tissue.
//!
//! `contact` keeps the thread above the table and inside the domain; `knot` tells whether
//! its centreline is knotted.

pub mod contact;
pub mod grasp;
pub mod knot;

use crate::config::{Scene, Thread};
use crate::mpm::Vec3;
use crate::rod::{Rod, RodSolver};
use contact::ThreadBounds;
use grasp::{Grasps, GripperView};

/// One thread and how it steps.
pub struct ThreadBody {
    pub name: String,
    pub rod: Rod,
    solver: RodSolver,
    /// Points the scene holds where they start.
    pinned: Vec<bool>,
    /// The scene's held points and where they are held.
    anchors: Vec<(usize, Vec3)>,
    /// Each point's inverse mass when free (restored when a grasp lets go).
    free_inv_mass: Vec<f32>,
    bounds: ThreadBounds,
    grasps: Grasps,
    /// Velocities at the start of the substep being solved (friction's reference).
    velocities_before: Vec<Vec3>,
}

impl ThreadBody {
    /// The thread `config` of a validated `scene`.
    pub fn new(scene: &Scene, config: &Thread) -> ThreadBody {
        let start = nalgebra::Vector3::from(config.start).cast::<f32>();
        let direction = nalgebra::Vector3::from(config.direction).cast::<f32>();
        let mut rod = Rod::straight(
            config.material(),
            start,
            direction,
            config.length as f32,
            config.segments as usize,
        );
        let free_inv_mass = rod.inv_mass.clone();
        let gravity = nalgebra::Vector3::from(scene.domain.gravity).cast::<f32>();
        let mut pinned = vec![false; rod.points.len()];
        let mut anchors = Vec::new();
        let last = rod.points.len() - 1;
        for (i, held) in [(0, config.pinned.start()), (last, config.pinned.end())] {
            if held {
                grasp::hold(&mut rod, i, free_inv_mass[i], gravity);
                pinned[i] = true;
                anchors.push((i, rod.points[i]));
            }
        }
        let solver = RodSolver::new(&rod, config.solver_settings(), gravity);
        ThreadBody {
            name: config.name.clone(),
            velocities_before: rod.velocities.clone(),
            bounds: ThreadBounds::new(scene, config),
            rod,
            solver,
            pinned,
            anchors,
            free_inv_mass,
            grasps: Grasps::default(),
        }
    }

    /// Advances one frame of `dt` seconds while the grippers `grippers` move over it:
    /// first grasps begin or end (jaws closed on the thread catch the points between their
    /// faces; opening lets them go), then each substep moves the grasped points with their
    /// jaws and solves the rod against the table.
    pub fn step_frame(&mut self, dt: f64, grippers: &[GripperView]) {
        let radius = self.rod.material.radius;
        let gravity = self.solver.gravity;
        self.grasps.update(
            &mut self.rod,
            grippers,
            radius,
            &self.pinned,
            &self.free_inv_mass,
            gravity,
        );
        let substeps = self.solver.settings.substeps.max(1);
        let h = (dt / substeps as f64) as f32;
        for s in 0..substeps {
            let (s0, s1) = (s as f64 / substeps as f64, (s + 1) as f64 / substeps as f64);
            self.grasps
                .start_substep(&mut self.rod, grippers, s0, s1, h);
            self.hold_anchors();
            self.velocities_before.clone_from(&self.rod.velocities);
            let bounds = &self.bounds;
            self.solver
                .substep(&mut self.rod, h, |rod, _| bounds.project(rod));
            let gravity_z = self.solver.gravity.z;
            self.bounds
                .friction(&mut self.rod, &self.velocities_before, gravity_z, h);
            self.grasps.end_substep(&mut self.rod, grippers, s1);
            self.hold_anchors();
        }
    }

    /// The scene's held points where they are held, at rest.
    fn hold_anchors(&mut self) {
        for &(i, at) in &self.anchors {
            self.rod.points[i] = at;
            self.rod.velocities[i] = Vec3::zeros();
        }
    }

    /// Current length over rest length, minus one.
    pub fn elongation(&self) -> f64 {
        self.rod.length() as f64 / self.rod.rest_length() as f64 - 1.0
    }

    /// Points held by grippers now.
    pub fn grasped_points(&self) -> usize {
        self.grasps.held_points()
    }

    /// Whether tool `tool` holds any of this thread.
    pub fn held_by(&self, tool: usize) -> bool {
        self.grasps.holds_with(tool)
    }
}
