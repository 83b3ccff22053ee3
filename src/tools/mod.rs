//! Rigid tools: shapes as signed distance functions, scripted motion, and the per-node
//! contact model.

pub mod contact;
pub mod grip;
pub mod jaw;
pub mod mesh_slicer;
pub mod obj;
pub mod pose;
pub mod sdf;
pub mod slicer;
pub mod trajectory;

pub use contact::ContactModel;
pub use jaw::{JawCommand, JawGains, JawServo};
pub use pose::{ToolPose, ToolVelocity};
pub use sdf::{SdfHit, Shape};
pub use trajectory::Trajectory;

use crate::math::{Mat3, Vec3};

/// Everything the grid update needs to know about one tool during one substep, in f32 and
/// world frame: pose at the start of the substep, its velocity over the substep, and a
/// bounding box outside which the SDF is never evaluated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToolKinematics {
    pub shape: Shape,
    pub contact: ContactModel,
    /// World-from-tool rotation.
    pub rotation: Mat3,
    /// Tool frame origin in the world (also the gripper's jaw pivot).
    pub translation: Vec3,
    pub linear_velocity: Vec3,
    pub angular_velocity: Vec3,
    /// Jaw opening (rad) and its rate (rad/s).
    pub jaw: f32,
    pub jaw_rate: f32,
    /// A node is in contact when its signed distance is below this (m). Zero for solids;
    /// curve tools are fattened to a radius of 1.5 grid cells so that a wire thinner than a
    /// cell still constrains a full stencil of nodes around it (seed 002 §IV-B); with less,
    /// tissue flows through the wire when it moves sideways.
    pub contact_threshold: f32,
    /// A gripper's grip ratio this substep (see [`grip`]): negative while its controller
    /// does not press the jaws closed (nothing is held); otherwise the grip region is held
    /// along the jaw normal, and across the faces at this ratio: 1 while friction holds it,
    /// less when it slips.
    pub grip: f32,
    /// How far a gripper's grip region reaches beyond its jaws (one grid cell; see [`grip`]).
    pub grip_reach: f32,
    pub aabb_min: Vec3,
    pub aabb_max: Vec3,
}

/// A node's contact with a tool, world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeContact {
    /// Signed distance minus the contact threshold (negative: in contact).
    pub depth: f32,
    pub normal: Vec3,
    pub tangent: Vec3,
    pub part: u8,
}

impl ToolKinematics {
    pub fn new(
        shape: Shape,
        contact: ContactModel,
        pose: &ToolPose,
        velocity: &ToolVelocity,
        dx: f32,
    ) -> Self {
        let contact_threshold = match shape {
            Shape::Needle { wire_radius, .. } => (1.5 * dx - wire_radius).max(0.0),
            // The spine is a cylinder of the blade's thickness, fattened as a wire is.
            Shape::Slicer { thickness, .. } | Shape::MeshSlicer { thickness, .. } => {
                (1.5 * dx - 0.5 * thickness).max(0.0)
            }
            _ => 0.0,
        };
        let translation: Vec3 = pose.position.cast();
        let reach = Vec3::repeat(shape.bounding_radius() + contact_threshold + dx);
        ToolKinematics {
            shape,
            contact,
            rotation: pose.rotation.to_rotation_matrix().into_inner().cast(),
            translation,
            linear_velocity: velocity.linear.cast(),
            angular_velocity: velocity.angular.cast(),
            jaw: pose.jaw as f32,
            jaw_rate: velocity.jaw_rate as f32,
            contact_threshold,
            grip: -1.0,
            grip_reach: match shape {
                Shape::Gripper { .. } => dx,
                _ => 0.0,
            },
            aabb_min: translation - reach,
            aabb_max: translation + reach,
        }
    }

    /// Contact query at world point `x`; `None` when outside the bounding box.
    #[inline(always)]
    pub fn probe(&self, x: Vec3) -> Option<NodeContact> {
        if (0..3).any(|a| x[a] < self.aabb_min[a] || x[a] > self.aabb_max[a]) {
            return None;
        }
        let local = self.rotation.tr_mul(&(x - self.translation));
        let hit = self.shape.query(local, self.jaw);
        Some(NodeContact {
            depth: hit.distance - self.contact_threshold,
            normal: self.rotation * hit.normal,
            tangent: self.rotation * hit.tangent,
            part: hit.part,
        })
    }

    /// Velocity of the tool's material point at `x` (rigid motion, plus the jaw's own
    /// rotation about the hinge for gripper parts).
    #[inline(always)]
    pub fn surface_velocity(&self, x: Vec3, part: u8) -> Vec3 {
        let mut omega = self.angular_velocity;
        if part != 0 {
            let hinge = self.rotation.column(0).into_owned();
            omega += hinge * sdf::jaw_angle(part, self.jaw_rate);
        }
        self.linear_velocity + omega.cross(&(x - self.translation))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{UnitQuaternion, Vector3};

    #[test]
    fn probe_uses_tool_frame_and_bounding_box() {
        let pose = ToolPose {
            position: Vector3::new(0.1, 0.0, 0.05),
            rotation: UnitQuaternion::from_euler_angles(std::f64::consts::FRAC_PI_2, 0.0, 0.0),
            jaw: 0.0,
        };
        let shape = Shape::Capsule {
            radius: 0.002,
            half_length: 0.01,
        };
        let k = ToolKinematics::new(
            shape,
            ContactModel::default(),
            &pose,
            &ToolVelocity::default(),
            0.001,
        );
        // Rolled 90° about x: the capsule axis (local z) lies along world −y.
        let hit = k.probe(Vector3::new(0.1, -0.008, 0.05).cast()).unwrap();
        assert!((hit.depth + 0.002).abs() < 1e-6, "{hit:?}");
        let hit = k.probe(Vector3::new(0.1, 0.0, 0.055).cast()).unwrap();
        assert!((hit.depth - 0.003).abs() < 1e-6);
        assert!((hit.normal - Vec3::z()).norm() < 1e-5);
        assert!(k.probe(Vec3::new(0.5, 0.0, 0.0)).is_none());
    }

    #[test]
    fn closing_jaws_move_towards_each_other() {
        let pose = ToolPose::default();
        let vel = ToolVelocity {
            jaw_rate: -1.0,
            ..Default::default()
        };
        let shape = Shape::Gripper {
            jaw_length: 0.01,
            jaw_width: 0.004,
            jaw_thickness: 0.002,
        };
        let k = ToolKinematics::new(shape, ContactModel::default(), &pose, &vel, 0.001);
        let tip = Vec3::new(0.0, 0.0, 0.01);
        // Jaw 1 lies on +y when open: closing moves its tip towards −y, jaw 2's towards +y.
        assert!(k.surface_velocity(tip, 1).y < 0.0);
        assert!(k.surface_velocity(tip, 2).y > 0.0);
        assert!((k.surface_velocity(tip, 1).y + 0.005).abs() < 1e-6);
    }
}
