//! The grip: tissue pinched between a gripper's closed jaws moves with them, with Coulomb
//! friction on the grip as a whole at the squeeze the jaw's controller applies.
//!
//! The model is sticky jaw contact on grid nodes, switched on by the jaw's controller:
//!
//! - while the controller drives the jaws closed
//!   ([`crate::tools::jaw::JawServo::driving_closed`]) with their tips at most a grid cell
//!   apart, every grid node in the *grip region* moves with the jaws: along the jaw normal
//!   always, across the faces at the grip ratio (jaws that stop wider apart, on stiff
//!   tissue, hold it by contact and its friction, which resolves such a gap);
//! - the grip region is the jaws' footprint from one outer face to the other (the gap and the
//!   jaws themselves, where closing jaws leave the tissue they caught), widened on every
//!   side by [`grip_reach`]: half the jaw thickness, at least a grid cell;
//! - the grip ratio is Coulomb's law on the grip as a whole: the tangential force holding
//!   every node in full took over the last frame, against μ × the jaws' total normal force,
//!   2·squeeze/lever (two faces; the lever is the held mass's mean distance from the
//!   hinge). Held in full below that; above it the grip slips with the friction force;
//! - opening the jaws (or any command that stops the press) ends the grip, and the jaws are
//!   ordinary contact again.
//!
//! Why from the moment the tips come within a cell, not once the jaws have stopped: the
//! jaw's effort limit (0.16 N·m) is far above what soft tissue resists, so the jaws close
//! through it at their free speed, and tissue caught between faces less than a cell apart
//! is crushed, not squeezed out. At dx 1 mm the default liver's bite reached a least
//! stretch of 1/20 and ran away at 11.8 m/s just before the jaws met; held from the moment
//! the grid can no longer resolve the tips' gap, it is lifted as at dx 2 mm
//! (`tests/deep_lift.rs`). While they still close, the squeeze that pays for friction is
//! the effort left over from the closing motion (see [`crate::tools::jaw::JawServo::squeeze`]).
//!
//! Why nodes and why the extra cell: a closed jaw gap is a fraction of a cell, so contact
//! alone cannot hold tissue between the faces at dx = 2 mm (the jaws close through it and
//! squeeze it out). Holding only the nodes inside the jaws' own footprint, or the particles
//! there, is not enough either: all the pull then passes through one layer of particles at
//! the footprint's edge, whose spacing stretches several-fold within a frame or two until
//! the particles no longer share grid nodes and the held piece tears off the tissue (seen
//! at 0.3 N on the default liver, far below what lifting it takes). One more cell of held
//! nodes, the same reach as the jaws' contact, spreads the pull over a stencil, and the
//! tissue around follows as a tent. Particles are not touched: they take the held nodes'
//! motion through G2P, so their deformation gradient stays consistent with the grid.
//!
//! Why half the jaw thickness and not one cell: the held tissue, and with it what a lift
//! pulls, must not shrink with the cell. The region reaches as far beyond the faces at
//! dx 1 mm as at dx 2 mm on the default 4 mm jaws (`tests/deep_lift.rs` lifts the same
//! liver at both). A scene's jaws are at least two cells thick (`check`), so the reach is
//! never less than a cell, and every shipped gripper scene's jaws are exactly two cells
//! thick: one cell there, as before.
//!
//! The momentum the held nodes receive goes to the tool's wrench like contact's; its part
//! along the jaw normal pushes the jaws apart (the tissue's torque on the opening).

use super::sdf::{jaw_angle, rotate_x};
use super::{Shape, ToolKinematics};
use crate::math::Vec3;

/// What the grip does to one grid node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Held {
    /// The node's velocity after the grip.
    pub v: Vec3,
    /// Velocity change across the jaw faces that holding it in full takes.
    pub required: Vec3,
    /// Distance from the hinge (m).
    pub lever: f32,
    /// Which jaw's side of the midplane the node is on (1 or 2, as the SDF's parts).
    pub jaw: u8,
}

/// How far a gripper of `jaw_thickness` holds beyond its jaws on a grid of spacing `dx`:
/// half the jaw thickness (a physical reach, the same on every grid), at least a cell (the
/// stencil the pull spreads over; see the module doc).
pub fn grip_reach(jaw_thickness: f32, dx: f32) -> f32 {
    dx.max(0.5 * jaw_thickness)
}

impl ToolKinematics {
    /// Distance from the hinge when `x` is in this gripper's grip region, with the jaw on
    /// whose side it is; `None` for other shapes and points outside it.
    #[inline(always)]
    pub fn grip_region(&self, x: Vec3) -> Option<(f32, u8)> {
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
        let reach = self.grip_reach;
        let p = self.rotation.tr_mul(&(x - self.translation));
        if p.x.abs() > 0.5 * jaw_width + reach {
            return None;
        }
        // Each jaw's own frame: jaw 1 occupies 0 ≤ y ≤ thickness, jaw 2 −thickness ≤ y ≤ 0.
        let in1 = rotate_x(p, -jaw_angle(1, self.jaw));
        let in2 = rotate_x(p, -jaw_angle(2, self.jaw));
        let along = |q: Vec3| (0.0..=jaw_length + reach).contains(&q.z);
        let between = in1.y <= jaw_thickness + reach && in2.y >= -(jaw_thickness + reach);
        (between && along(in1) && along(in2)).then(|| {
            (
                (p.y * p.y + p.z * p.z).sqrt(),
                if p.y >= 0.0 { 1 } else { 2 },
            )
        })
    }

    /// The grip on a grid node at `x` moving at `v`, when this gripper holds and the node is
    /// in its grip region.
    #[inline(always)]
    pub fn hold(&self, x: Vec3, v: Vec3) -> Option<Held> {
        if self.grip < 0.0 {
            return None;
        }
        let (lever, jaw) = self.grip_region(x)?;
        Some(self.held(x, v, lever, jaw))
    }

    /// The grip on a grid node at `x` moving at `v` wherever it is: the material grip holds
    /// the nodes its captured particles touch, in or out of the region.
    #[inline(always)]
    pub fn hold_anywhere(&self, x: Vec3, v: Vec3) -> Held {
        let p = self.rotation.tr_mul(&(x - self.translation));
        let lever = (p.y * p.y + p.z * p.z).sqrt();
        self.held(x, v, lever, if p.y >= 0.0 { 1 } else { 2 })
    }

    #[inline(always)]
    fn held(&self, x: Vec3, v: Vec3, lever: f32, jaw: u8) -> Held {
        let v_jaws = self.linear_velocity + self.angular_velocity.cross(&(x - self.translation));
        let dv = v_jaws - v;
        let along_normal = self.jaw_normal() * self.jaw_normal().dot(&dv);
        let required = dv - along_normal;
        Held {
            v: v + along_normal + required * self.grip.max(0.0),
            required,
            lever,
            jaw,
        }
    }

    /// The jaws' closing direction (the tool's y axis, world frame).
    #[inline(always)]
    pub fn jaw_normal(&self) -> Vec3 {
        self.rotation.column(1).into_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tools::{ContactModel, ToolPose, ToolVelocity};
    use nalgebra::{UnitQuaternion, Vector3};

    const DX: f32 = 0.002;

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
        let mut k = ToolKinematics::new(shape, ContactModel::default(), &pose, &velocity, DX);
        k.grip = grip;
        k
    }

    #[test]
    fn the_region_is_the_jaws_and_their_gap_widened_by_a_cell() {
        let k = gripper(0.4, 1.0, ToolVelocity::default());
        // On the midplane between the jaws, half way along.
        let (lever, _) = k.grip_region(Vec3::new(0.0, 0.0, 0.005)).unwrap();
        assert!((lever - 0.005).abs() < 1e-6);
        // Inside jaw 1 (its inner face at angle 0.2 rad towards +y), and within a cell
        // beyond its outer face.
        let in_jaw = rotate_x(Vec3::new(0.0, 0.001, 0.008), jaw_angle(1, 0.4));
        assert_eq!(k.grip_region(in_jaw).unwrap().1, 1);
        let beside = rotate_x(Vec3::new(0.0, 0.0035, 0.008), jaw_angle(1, 0.4));
        assert!(k.grip_region(beside).is_some());
        let in_jaw_2 = rotate_x(Vec3::new(0.0, -0.001, 0.008), jaw_angle(2, 0.4));
        assert_eq!(k.grip_region(in_jaw_2).unwrap().1, 2);
        // More than a cell beyond an outer face, beside the jaws, past the tips: outside.
        let outside = rotate_x(Vec3::new(0.0, 0.0045, 0.008), jaw_angle(1, 0.4));
        assert!(k.grip_region(outside).is_none());
        assert!(k.grip_region(Vec3::new(0.0055, 0.0, 0.005)).is_none());
        assert!(k.grip_region(Vec3::new(0.0, 0.0, 0.0125)).is_none());
        // Not a gripper: no region.
        let mut sphere = k;
        sphere.shape = Shape::Sphere { radius: 0.01 };
        assert!(sphere.grip_region(Vec3::zeros()).is_none());
    }

    #[test]
    fn thick_jaws_hold_half_their_thickness_beyond_their_faces_on_a_fine_grid() {
        assert_eq!(grip_reach(0.002, DX), DX);
        assert_eq!(grip_reach(0.004, DX), DX);
        assert_eq!(grip_reach(0.004, 0.5 * DX), 0.002);
        let shape = Shape::Gripper {
            jaw_length: 0.01,
            jaw_width: 0.006,
            jaw_thickness: 0.004,
        };
        let at = |dx: f32, pose: &ToolPose| {
            ToolKinematics::new(
                shape,
                ContactModel::default(),
                pose,
                &ToolVelocity::default(),
                dx,
            )
        };
        let fine = |dx: f32| at(dx, &ToolPose::default());
        // 1.5 mm beyond the side of the closed jaws: held at dx 2 mm and at dx 1 mm alike.
        let beside = Vec3::new(0.0045, 0.0, 0.005);
        assert!(fine(DX).grip_region(beside).is_some());
        assert!(fine(0.5 * DX).grip_region(beside).is_some());
        assert!(fine(0.5 * DX)
            .grip_region(Vec3::new(0.0055, 0.0, 0.005))
            .is_none());
        // The region's far corner, 2 mm beyond a face and the tips, is in the tool's
        // bounding box however the tool is turned (here 45° about its hinge).
        let turned = ToolPose {
            rotation: UnitQuaternion::from_euler_angles(std::f64::consts::FRAC_PI_4, 0.0, 0.0),
            ..ToolPose::default()
        };
        let k = at(0.5 * DX, &turned);
        let corner = k.rotation * Vec3::new(0.0, 0.0059, 0.0119);
        assert!(k.grip_region(corner).is_some());
    }

    #[test]
    fn a_full_grip_moves_the_node_with_the_jaws() {
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
        // Without squeeze nothing slows it across the faces.
        let free = gripper(0.0, 0.0, ToolVelocity::default())
            .hold(x, v)
            .unwrap();
        assert_eq!(free.v, Vec3::new(0.0, 0.0, 0.01));
        // A gripper that does not press holds nothing.
        assert!(gripper(0.0, -1.0, ToolVelocity::default())
            .hold(x, v)
            .is_none());
    }
}
