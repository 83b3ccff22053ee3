//! Rigid tools: shapes as signed distance functions, scripted motion, and the per-node
//! contact model.
//!
//! - **Shapes** ([`Shape`], [`sdf`]): sphere, capsule, box, gripper, arc needle, and the
//!   blades ([`slicer`], [`mesh_slicer`]), each a signed distance function in the tool's own
//!   frame, evaluated per grid node only inside each tool's bounding box; the nearest tool
//!   owns a node (seed 000's collision-objects table). The gripper's two jaws rotate about
//!   the hinge with the jaw angle, and the jaw rate enters the node's relative velocity. The
//!   arc needle keeps only the relative velocity along its own tangent (seed 002 eq. 19);
//!   being thinner than a cell, it acts on nodes within 1.5 cells. Solid tools must be at
//!   least two cells thick (`check` refuses thinner ones): a thinner solid constrains too few
//!   of a particle's 27 stencil nodes and tissue flows through it.
//! - **Contact** ([`contact`]): relative velocity; separating nodes untouched; approaching
//!   nodes lose the normal component, Coulomb friction reduces the tangential one, then
//!   `drag` scales it (seed 002's c_d = 1 − drag); `sticky` nodes move with the tool (clamps).
//!   The momentum each tool takes out of the grid per substep, summed to force and torque
//!   about the tool origin and averaged over the frame, is its contact wrench.
//! - **The jaw** ([`jaw`]) is dVRK's: a position servo whose effort is limited, acting against
//!   the tissue's torque on the opening.
//! - **The grip** ([`grip`]): tissue pressed between closed jaws moves with them, with Coulomb
//!   friction on the grip as a whole. Measured (`cargo test --release --test grasp --
//!   --nocapture`): lifting 10 mm, the grasped region of `default.toml` rises 8.90 mm with
//!   0.85 N on the gripper and is back within 0.27 mm 1 s after opening; `retraction.toml`
//!   (dx = 1 mm) 20.78 mm of the tool's 21.5 mm; pulled along the jaw faces with a 0.002 N·m
//!   squeeze and μ 0.2, a bonded block slips at 0.108 N against μ × normal force = 0.098 N.
//! - **Motion**: keyframes ([`trajectory`]) interpolated linearly in time in headless runs;
//!   in node runs a tool an arm holds follows the arm (base ∘ FK(q) ∘ mount, the mount
//!   `tool_xyz`, `tool_rpy_deg`: a slicer, whose blade hangs along its own −z, is held with
//!   [180, 0, 0]; a needle with its centre on the instrument's axis at `[0, 0, d]`). A
//!   needle is a rigid body that its driver can let go of and grippers can take over
//!   ([`crate::world::needle_body`]).

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
    /// The tool's shape (tool frame).
    pub shape: Shape,
    /// How grid nodes in contact move with the tool.
    pub contact: ContactModel,
    /// World-from-tool rotation.
    pub rotation: Mat3,
    /// Tool frame origin in the world (also the gripper's jaw pivot).
    pub translation: Vec3,
    /// Velocity of the tool frame origin over the substep, world frame, m/s.
    pub linear_velocity: Vec3,
    /// Angular velocity over the substep, world frame, rad/s.
    pub angular_velocity: Vec3,
    /// Jaw opening (rad) and its rate (rad/s).
    pub jaw: f32,
    /// Jaw opening rate, rad/s.
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
    /// How far a gripper's grip region reaches beyond its jaws ([`grip::grip_reach`]).
    pub grip_reach: f32,
    /// Lower corner of the world-frame bounding box, m (contact threshold included).
    pub aabb_min: Vec3,
    /// Upper corner of the world-frame bounding box, m (contact threshold included).
    pub aabb_max: Vec3,
}

/// A node's contact with a tool, world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeContact {
    /// Signed distance minus the contact threshold (negative: in contact).
    pub depth: f32,
    /// Outward unit normal of the tool surface, world frame.
    pub normal: Vec3,
    /// Unit tangent of a 1D shape (needle, spine) at the nearest point, world frame; zero
    /// otherwise.
    pub tangent: Vec3,
    /// Part of the tool: 0 for one-piece shapes, 1 and 2 for gripper jaws.
    pub part: u8,
}

impl ToolKinematics {
    /// A tool's kinematics for one substep at `pose`, moving with `velocity`, on a grid of spacing
    /// `dx` (m).
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
        let grip_reach = match shape {
            Shape::Gripper { jaw_thickness, .. } => grip::grip_reach(jaw_thickness, dx),
            _ => 0.0,
        };
        // The box holds the contact's reach (a cell) and the grip region's.
        let reach = Vec3::repeat(shape.bounding_radius() + contact_threshold + dx.max(grip_reach));
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
            grip_reach,
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
