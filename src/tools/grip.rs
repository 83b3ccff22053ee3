//! The grip: tissue pinched between a gripper's closed jaws is held by the jaws as a whole,
//! with Coulomb friction at the squeeze the jaw's controller applies.
//!
//! Why a particle-level grasp constraint and not grid contact alone: a jaw gap is a
//! fraction of a grid cell once closed, so grid nodes cannot hold tissue between two jaw
//! faces (at dx = 2 mm the jaws close through the tissue and squeeze it out). The pinch is
//! decided per particle, from the jaws' own geometry, so it does not depend on the grid
//! resolving the gap:
//!
//! - a particle is *pinched* when it lies within the jaws' footprint between their outer
//!   faces (the gap and the jaws themselves, where tissue caught by closing jaws ends up);
//! - while the jaw's controller pushes them closed, a pinched particle's velocity after G2P
//!   is the jaws' rigid velocity at its position along the jaw normal (closing jaws catch
//!   the tissue between them instead of squeezing it out of a gap the grid cannot resolve)
//!   and, across the faces, that velocity scaled by the grip ratio;
//! - the grip ratio is Coulomb's law on the grip as a whole: the tangential force needed to
//!   hold every pinched particle, measured over the last frame, against μ × the jaws' total
//!   normal force 2·squeeze/lever (two faces; the lever is the pinched mass's mean distance
//!   from the hinge). Held in full below that, it slips with exactly the friction force
//!   above it. Opening the jaws ends the squeeze and releases the tissue.
//!
//! The impulses the grip gives the particles go to the tool's wrench like contact's.

use super::sdf::{jaw_angle, rotate_x};
use super::{Shape, ToolKinematics};
use crate::mpm::Vec3;

/// What the grip did to one particle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Held {
    /// The particle's velocity after the grip.
    pub v: Vec3,
    /// Velocity change across the jaw faces that holding it in full takes.
    pub required: Vec3,
    /// Distance from the hinge (m).
    pub lever: f32,
}

impl ToolKinematics {
    /// Distance from the hinge when `x` is pinched between this gripper's jaws; `None` for
    /// other shapes and points outside the jaws.
    #[inline(always)]
    pub fn pinch(&self, x: Vec3) -> Option<f32> {
        let Shape::Gripper {
            jaw_length,
            jaw_width,
            jaw_thickness,
        } = self.shape
        else {
            return None;
        };
        if (0..3).any(|a| x[a] < self.aabb_min[a] || x[a] > self.aabb_max[a]) {
            return None;
        }
        let p = self.rotation.tr_mul(&(x - self.translation));
        if p.x.abs() > 0.5 * jaw_width {
            return None;
        }
        // Each jaw's own frame: jaw 1 occupies 0 ≤ y ≤ thickness, jaw 2 −thickness ≤ y ≤ 0.
        let in1 = rotate_x(p, -jaw_angle(1, self.jaw));
        let in2 = rotate_x(p, -jaw_angle(2, self.jaw));
        let along = |q: Vec3| (0.0..=jaw_length).contains(&q.z);
        (in1.y <= jaw_thickness && in2.y >= -jaw_thickness && along(in1) && along(in2))
            .then(|| (p.y * p.y + p.z * p.z).sqrt())
    }

    /// The grip on a particle at `x` moving at `v` after G2P, when it is pinched.
    #[inline(always)]
    pub fn hold(&self, x: Vec3, v: Vec3) -> Option<Held> {
        let lever = self.pinch(x)?;
        let v_jaws = self.linear_velocity + self.angular_velocity.cross(&(x - self.translation));
        let dv = v_jaws - v;
        let normal = self.rotation.column(1).into_owned();
        let along_normal = normal * normal.dot(&dv);
        let required = dv - along_normal;
        let v = if self.grip >= 0.0 {
            v + along_normal + required * self.grip
        } else {
            v
        };
        Some(Held { v, required, lever })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tools::{ContactModel, ToolPose, ToolVelocity};
    use nalgebra::{UnitQuaternion, Vector3};

    fn gripper(opening: f64, grip: f32, velocity: ToolVelocity) -> ToolKinematics {
        let pose = ToolPose {
            position: Vector3::zeros(),
            rotation: UnitQuaternion::identity(),
            jaw: opening,
        };
        let shape = Shape::Gripper {
            jaw_length: 0.01,
            jaw_width: 0.006,
            jaw_thickness: 0.002,
        };
        let mut k = ToolKinematics::new(shape, ContactModel::default(), &pose, &velocity, 0.002);
        k.grip = grip;
        k
    }

    #[test]
    fn the_gap_and_the_jaws_are_pinched_the_outside_is_not() {
        let k = gripper(0.4, 1.0, ToolVelocity::default());
        // On the midplane between the jaws, half way along.
        assert!((k.pinch(Vec3::new(0.0, 0.0, 0.005)).unwrap() - 0.005).abs() < 1e-6);
        // Inside jaw 1 (its inner face at angle 0.2 rad towards +y).
        let in_jaw = rotate_x(Vec3::new(0.0, 0.001, 0.008), jaw_angle(1, 0.4));
        assert!(k.pinch(in_jaw).is_some());
        // Beyond jaw 1's outer face, beside the jaws, past the tips: not pinched.
        let outside = rotate_x(Vec3::new(0.0, 0.003, 0.008), jaw_angle(1, 0.4));
        assert!(k.pinch(outside).is_none());
        assert!(k.pinch(Vec3::new(0.004, 0.0, 0.005)).is_none());
        assert!(k.pinch(Vec3::new(0.0, 0.0, 0.0115)).is_none());
        // Not a gripper: nothing is pinched.
        let mut sphere = k;
        sphere.shape = Shape::Sphere { radius: 0.01 };
        assert!(sphere.pinch(Vec3::zeros()).is_none());
    }

    #[test]
    fn a_full_grip_moves_the_particle_with_the_jaws() {
        let lift = ToolVelocity {
            linear: Vector3::new(0.0, 0.0, 0.02),
            ..Default::default()
        };
        let x = Vec3::new(0.0, 0.0005, 0.005);
        let v = Vec3::new(0.001, -0.003, 0.0);
        let held = gripper(0.0, 1.0, lift).hold(x, v).unwrap();
        assert!(
            (held.v - Vec3::new(0.0, 0.0, 0.02)).norm() < 1e-7,
            "{:?}",
            held.v
        );
        // What holding takes across the faces (x and z; y is the jaw normal).
        assert!((held.required - Vec3::new(-0.001, 0.0, 0.02)).norm() < 1e-7);
    }

    #[test]
    fn a_partial_grip_holds_along_the_normal_and_slips_across() {
        let x = Vec3::new(0.0, 0.0, 0.005);
        let v = Vec3::new(0.0, 0.004, 0.01);
        let held = gripper(0.0, 0.25, ToolVelocity::default())
            .hold(x, v)
            .unwrap();
        assert!(
            (held.v - Vec3::new(0.0, 0.0, 0.0075)).norm() < 1e-7,
            "{:?}",
            held.v
        );
        // No squeeze: measured, not moved.
        let free = gripper(0.0, 0.0, ToolVelocity::default())
            .hold(x, v)
            .unwrap();
        assert_eq!(free.v, v);
        assert!((free.required - Vec3::new(0.0, 0.0, -0.01)).norm() < 1e-7);
    }
}
