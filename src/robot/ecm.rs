//! The dVRK Endoscope Camera Manipulator: four joints (`outer_yaw`, `outer_pitch`,
//! `insertion`, `outer_roll`) about the same kind of remote centre of motion as a PSM, no
//! jaw, and the camera at the scope's tip.
//!
//! The arm is a [`Psm`] of kind [`ArmKind::Ecm`]: the same joint commands, `move_jp`
//! planning and Cartesian frames, without the jaw and the instrument's wrist. The built-in
//! model is `urdf/ecm.urdf` (dVRK's classic ECM DH table, dvrk_model's joint limits); a
//! dvrk_model ECM URDF loads by role as the PSM's does:
//! - **Base** (the RCM, frame of `measured_cp`, published as `<name>_base`): as for the
//!   PSM (`base_link`, else `P_base`, `P_base_link`, ...; `P_RCM_link` where the tool hangs
//!   below it), and dvrk_model's classic `P_remote_center_link`, which hangs beside the arm
//!   off `P_base_link`: the chain then starts at `P_base_link` and is re-expressed in the
//!   RCM frame.
//! - **Tool frame** (the scope's tip, the camera): `tool_link`, else the link `<name>`, else
//!   dvrk_model's `<name>_end_link` (older layouts) or `<name>_tip_link` (the current one,
//!   the straight scope's tip).
//!
//! dvrk_model's current classic ECM (`tests/urdf/ECM_current_layout.urdf`, its kinematic
//! structure: the RCM link as the root, the parallelogram as mimic joints, roll about −z)
//! loads by these rules and is a remote-centre arm to its file's rounding (the tip within
//! 0.12 mm of the RCM's view line over 500 random poses, `tests/robot_kinematics.rs`). Its
//! frames are its own, not dVRK's DH table's, which `urdf/ecm.urdf` follows: its tip is 10.1 mm
//! further back along the view, and its RCM frame is turned (yaw moves the tip along its y,
//! the DH table's along x). A scene that loads it reports `measured_cp` in its frames.
//! - **Joints**: the four on the path, named `outer_yaw, outer_pitch, insertion, outer_roll`
//!   (dvrk_model's `yaw, pitch, insertion, roll` are taken for them, and published under
//!   dVRK's ECM names); insertion prismatic; finite limits from the file.

use nalgebra::Isometry3;

use crate::robot::chain::{Chain, JointKind};
use crate::robot::joints::JointGroup;
use crate::robot::psm::{locate_roles, ArmKind, Psm, PsmError, UrdfRoles};
use crate::robot::urdf::{self, CLASSIC_ECM_URDF};

/// The ECM joints, in dVRK's `JointState` order.
pub const ECM_JOINT_NAMES: [&str; 4] = ["outer_yaw", "outer_pitch", "insertion", "outer_roll"];

/// dvrk_model's names for the same joints, in the same order.
const DVRK_MODEL_ECM_JOINT_NAMES: [&str; 4] = ["yaw", "pitch", "insertion", "roll"];

/// `move_jp` speed limits of the ECM (rad/s; insertion m/s): the PSM's for yaw, pitch and
/// insertion (the same mechanism), 90°/s on the scope's roll. A scene can set others
/// (`joint_speeds`).
pub const ECM_SPEEDS: [f64; 4] = [
    std::f64::consts::FRAC_PI_2,
    std::f64::consts::FRAC_PI_2,
    0.2,
    std::f64::consts::FRAC_PI_2,
];

impl Psm {
    /// The classic ECM with a straight scope (`urdf/ecm.urdf`, built in), as arm `name`.
    pub fn classic_ecm(name: &str) -> Result<Psm, PsmError> {
        Psm::ecm_from_urdf_with_roles(
            urdf::parse_urdf(CLASSIC_ECM_URDF)?,
            name,
            &UrdfRoles::default(),
        )
    }

    /// Builds ECM `name` from a parsed ECM URDF, its base and tool found by the rule of the
    /// module documentation.
    pub fn ecm_from_urdf_with_roles(
        mut robot: urdf_rs::Robot,
        name: &str,
        roles: &UrdfRoles,
    ) -> Result<Psm, PsmError> {
        let tool_frames = [
            (name.to_owned(), None),
            (format!("{name}_end_link"), None),
            (format!("{name}_tip_link"), None),
        ];
        let (base_link, tool_link, _) = locate_roles(&mut robot, name, roles, &tool_frames)?;
        // dvrk_model's classic ECM hangs its RCM link off the mounting, beside the arm.
        let beside = format!("{name}_remote_center_link");
        let root = match Chain::from_urdf(&robot, &base_link, &beside) {
            Ok(rcm) if roles.base_link.is_none() && rcm.dof() == 0 => rcm.tip_pose(&[])?.inverse(),
            _ => Isometry3::identity(),
        };
        let arm = Chain::from_urdf(&robot, &base_link, &tool_link)?;
        let found: Vec<&str> = arm.joints().iter().map(|j| j.name.as_str()).collect();
        if found != ECM_JOINT_NAMES && found != DVRK_MODEL_ECM_JOINT_NAMES {
            return Err(PsmError::NotAPsm(format!(
                "the joints from {base_link} to {tool_link} are {found:?}, expected the ECM's \
                 {ECM_JOINT_NAMES:?}"
            )));
        }
        if arm.joints()[2].kind != JointKind::Prismatic {
            return Err(PsmError::NotAPsm("`insertion` must be prismatic".into()));
        }
        let mut joints = arm.joints().to_vec();
        for ((joint, canonical), speed) in joints.iter_mut().zip(ECM_JOINT_NAMES).zip(ECM_SPEEDS) {
            if !(joint.lower.is_finite() && joint.upper.is_finite()) {
                return Err(PsmError::NotAPsm(format!(
                    "joint `{}` needs finite position limits, got [{}, {}]",
                    joint.name, joint.lower, joint.upper
                )));
            }
            joint.name = canonical.to_owned();
            joint.max_velocity = speed;
        }
        let meshes = urdf::mesh_count(&robot);
        if meshes > 0 {
            tracing::info!(
                "arm {name}: {meshes} mesh(es) in the URDF are not read (kinematics only)"
            );
        }
        tracing::info!(
            "arm {name} (ECM): base link {base_link}{}, tool frame {name}{}; joint limits from \
             the URDF",
            if root == Isometry3::identity() {
                String::new()
            } else {
                format!(" (RCM {beside})")
            },
            if tool_link != name {
                format!(" = {tool_link}")
            } else {
                String::new()
            }
        );
        Ok(Psm::without_jaw(
            name,
            ArmKind::Ecm,
            root,
            arm,
            JointGroup::new(joints),
        ))
    }
}
