//! Modified Denavit–Hartenberg forward kinematics of the classic PSM and ECM, straight from the tables in
//! dVRK's configuration (shared/reference/dvrk.md).
//!
//! The simulation itself uses the URDF ([`crate::robot::Chain`]); this module is the independent
//! reference the tests hold the URDF to, so it is deliberately written from the table with
//! matrices of elementary transforms and shares no code with the URDF path.

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

use crate::robot::chain::JointKind;

/// One row of a modified-DH (Craig) table: the transform from frame i−1 to frame i is
/// `RotX(alpha) · TransX(a) · RotZ(theta) · TransZ(d)`, where the joint value plus `offset`
/// replaces `theta` for a revolute joint and `d` for a prismatic one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DhRow {
    /// Revolute (the joint value adds to `theta`) or prismatic (adds to `d`).
    pub kind: JointKind,
    /// Twist about x_{i−1}, rad.
    pub alpha: f64,
    /// Length along x_{i−1}, m.
    pub a: f64,
    /// Rotation about z_i, rad (a revolute joint's value + `offset` replaces it).
    pub theta: f64,
    /// Offset along z_i, m (a prismatic joint's value + `offset` replaces it).
    pub d: f64,
    /// Added to the joint value, rad or m.
    pub offset: f64,
}

impl DhRow {
    /// The transform from frame i−1 to frame i at joint value `q`.
    pub fn transform(&self, q: f64) -> Isometry3<f64> {
        let (theta, d) = match self.kind {
            JointKind::Revolute => (q + self.offset, self.d),
            JointKind::Prismatic => (self.theta, q + self.offset),
        };
        let rot_x = Isometry3::from_parts(
            Translation3::identity(),
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), self.alpha),
        );
        let rot_z = Isometry3::from_parts(
            Translation3::identity(),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), theta),
        );
        rot_x
            * Isometry3::translation(self.a, 0.0, 0.0)
            * rot_z
            * Isometry3::translation(0.0, 0.0, d)
    }
}

const FRAC_PI_2: f64 = std::f64::consts::FRAC_PI_2;

const fn revolute(alpha: f64, a: f64, d: f64, offset: f64) -> DhRow {
    DhRow {
        kind: JointKind::Revolute,
        alpha,
        a,
        theta: 0.0,
        d,
        offset,
    }
}

/// Classic PSM with the Large Needle Driver 400006: yaw, pitch, insertion, roll, wrist_pitch,
/// wrist_yaw (dvrk.md, "PSM kinematics").
pub const PSM_LARGE_NEEDLE_DRIVER: [DhRow; 6] = [
    revolute(FRAC_PI_2, 0.0, 0.0, FRAC_PI_2),
    revolute(-FRAC_PI_2, 0.0, 0.0, -FRAC_PI_2),
    DhRow {
        kind: JointKind::Prismatic,
        alpha: FRAC_PI_2,
        a: 0.0,
        theta: 0.0,
        d: 0.0,
        offset: -0.4318,
    },
    revolute(0.0, 0.0, 0.4162, 0.0),
    revolute(-FRAC_PI_2, 0.0, 0.0, -FRAC_PI_2),
    revolute(-FRAC_PI_2, 0.0091, 0.0, -FRAC_PI_2),
];

/// Si PSM (sawIntuitiveResearchKit `share/kinematic/PSM_Si.json`) with the Si Large Needle
/// Driver 420006 (`share/tool/LARGE_NEEDLE_DRIVER_420006.json`): the classic rows but for the
/// insertion offset (−0.4826 m) and the longer shaft (roll d = 0.4670 m).
pub const PSM_SI_LARGE_NEEDLE_DRIVER_420006: [DhRow; 6] = [
    revolute(FRAC_PI_2, 0.0, 0.0, FRAC_PI_2),
    revolute(-FRAC_PI_2, 0.0, 0.0, -FRAC_PI_2),
    DhRow {
        kind: JointKind::Prismatic,
        alpha: FRAC_PI_2,
        a: 0.0,
        theta: 0.0,
        d: 0.0,
        offset: -0.4826,
    },
    revolute(0.0, 0.0, 0.4670, 0.0),
    revolute(-FRAC_PI_2, 0.0, 0.0, -FRAC_PI_2),
    revolute(-FRAC_PI_2, 0.0091, 0.0, -FRAC_PI_2),
];

/// Classic ECM with a straight scope: outer_yaw, outer_pitch, insertion, outer_roll (dVRK's
/// ECM table: the PSM's first three rows with a −0.3822 m insertion offset, the scope's
/// d = 0.3829 m). Its tool frame, the scope's tip, is DH frame 4.
pub const ECM_CLASSIC: [DhRow; 4] = [
    revolute(FRAC_PI_2, 0.0, 0.0, FRAC_PI_2),
    revolute(-FRAC_PI_2, 0.0, 0.0, -FRAC_PI_2),
    DhRow {
        kind: JointKind::Prismatic,
        alpha: FRAC_PI_2,
        a: 0.0,
        theta: 0.0,
        d: 0.0,
        offset: -0.3822,
    },
    revolute(0.0, 0.0, 0.3829, 0.0),
];

/// The ECM's tool frame (the scope's tip, what `measured_cp` reports) in its RCM frame.
pub fn ecm_tool_pose(q: &[f64; 4]) -> Isometry3<f64> {
    forward(&ECM_CLASSIC, q)[3]
}

/// dVRK's tool offset: the pure rotation from DH frame 6 to the reported tool frame.
pub fn psm_tool_offset() -> Isometry3<f64> {
    let rotation = Rotation3::from_matrix_unchecked(Matrix3::new(
        0.0, -1.0, 0.0, //
        0.0, 0.0, 1.0, //
        -1.0, 0.0, 0.0,
    ));
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_rotation_matrix(&rotation),
    )
}

/// Frames 1..N in frame 0, for joint values `q`.
pub fn forward<const N: usize>(rows: &[DhRow; N], q: &[f64; N]) -> [Isometry3<f64>; N] {
    let mut pose = Isometry3::identity();
    std::array::from_fn(|i| {
        pose *= rows[i].transform(q[i]);
        pose
    })
}

/// The PSM tool frame (what `measured_cp` reports) in the RCM frame.
pub fn psm_tool_pose(q: &[f64; 6]) -> Isometry3<f64> {
    tool_pose(&PSM_LARGE_NEEDLE_DRIVER, q)
}

/// The tool frame of the PSM that `rows` describe, in its RCM frame (the same tool offset for
/// the Classic and the Si instruments).
pub fn tool_pose(rows: &[DhRow; 6], q: &[f64; 6]) -> Isometry3<f64> {
    forward(rows, q)[5] * psm_tool_offset()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn home_pose_points_the_shaft_down_from_the_rcm() {
        // At q = 0 except insertion, the jaw pivot sits on the shaft axis, insertion − 0.4318 +
        // 0.4162 + 0.0091 m beyond the RCM, with the tool z axis along the shaft.
        let insertion = 0.1;
        let tool = psm_tool_pose(&[0.0, 0.0, insertion, 0.0, 0.0, 0.0]);
        let depth = insertion - 0.4318 + 0.4162 + 0.0091;
        assert!((tool.translation.vector - Vector3::new(0.0, 0.0, -depth)).norm() < 1e-12);
        let z = tool.rotation * Vector3::z();
        assert!((z - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-12);
    }

    #[test]
    fn yaw_and_pitch_keep_the_shaft_through_the_rcm() {
        let frames = forward(&PSM_LARGE_NEEDLE_DRIVER, &[0.7, -0.4, 0.15, 1.0, 0.3, -0.2]);
        // Frame 3 (instrument back end) and frame 4 (wrist) are both on the line through the RCM.
        let back = frames[2].translation.vector;
        let wrist = frames[3].translation.vector;
        assert!(back.cross(&wrist).norm() < 1e-12);
        assert!((wrist.norm() - (0.15 - 0.4318 + 0.4162)).abs() < 1e-12);
    }
}
