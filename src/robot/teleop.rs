//! MTM → PSM teleoperation mapping, as dVRK's `mtsTeleOperationPSM` does it, as a plain state
//! machine: the caller feeds MTM poses, the PSM's setpoint and the pedals, and sends
//! [`Teleop::target`] to the PSM (`servo_cp`, `jaw/servo_jp`) while it is `Some`.
//!
//! - Position is relative: `PSM = scale · (MTM − MTM at engage) + PSM at engage`.
//! - Orientation is absolute: `PSM = MTM · offset`, the offset captured at engage, so engaging
//!   never makes the PSM jump (dVRK first aligns the MTM so the offset is small; the offset makes
//!   the mapping continuous whatever the alignment).
//! - Clutch pressed or operator absent: no target (the PSM holds); on release / return the
//!   mapping re-anchors on the current MTM pose and PSM setpoint.
//! - Jaw = gripper · jaw_max / 60°, clamped to the jaw limits, at most `jaw_max_speed` fast.
//! - An MTM silent for [`MTM_SILENCE_S`] counts as gone: no target (the PSM holds where it
//!   was); when it publishes again the mapping re-anchors, so the PSM resumes without a jump
//!   however far the MTM moved meanwhile.
//!
//! Bimanual teleoperation (MTMR → PSM1, MTML → PSM2, `[[teleop]]` once per pair) runs one
//! mapping per pair; the console's clutch and operator pedals go to every mapping at once.
//!
//! MTM and PSM poses must be given in one common frame (dVRK: the camera frame); converting
//! from each arm's base is the caller's job. dVRK's engage checks (orientation error ≤ 5°, a
//! gripper wiggle) belong to the operator console and are not modelled here.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use crate::robot::psm::Psm;

/// dVRK's default motion scale.
pub const DEFAULT_SCALE: f64 = 0.2;

/// The MTM gripper's span (rad): fully open maps to the jaw's upper limit.
pub const MTM_GRIPPER_SPAN: f64 = 60.0 * std::f64::consts::PI / 180.0;

/// dVRK's teleop jaw speed limit (rad/s).
pub const DEFAULT_JAW_MAX_SPEED: f64 = 720.0 * std::f64::consts::PI / 180.0;

/// How long (s of simulated time) the MTM may be silent before it counts as gone. dVRK's MTM
/// publishes at 100 Hz or more, so this is dozens of lost messages, not jitter.
pub const MTM_SILENCE_S: f64 = 0.5;

#[derive(Debug, Clone, Copy, PartialEq)]
/// The settings of the MTM-to-PSM mapping.
pub struct TeleopConfig {
    /// PSM displacement per MTM displacement.
    pub scale: f64,
    /// Jaw limits (rad); `jaw_upper` is also the jaw at a fully open gripper.
    pub jaw_lower: f64,
    /// Upper jaw limit, rad.
    pub jaw_upper: f64,
    /// Fastest jaw motion (rad/s).
    pub jaw_max_speed: f64,
}

impl TeleopConfig {
    /// dVRK defaults with the jaw limits of `psm`.
    pub fn for_psm(psm: &Psm) -> TeleopConfig {
        let jaw = &psm.jaw().joints()[0];
        TeleopConfig {
            scale: DEFAULT_SCALE,
            jaw_lower: jaw.lower,
            jaw_upper: jaw.upper,
            jaw_max_speed: DEFAULT_JAW_MAX_SPEED,
        }
    }
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
/// Why a teleoperation setting or input was rejected.
pub enum TeleopError {
    #[error("teleop scale must be a positive finite number, got {0}")]
    /// A scale that is not a positive finite number (holds it).
    InvalidScale(f64),
    #[error("teleop jaw limits [{lower}, {upper}] and speed {speed} rad/s are not usable")]
    /// Jaw limits not ordered, or a speed not positive and finite.
    InvalidJawConfig {
        /// Lower jaw limit, rad.
        lower: f64,
        /// Upper jaw limit, rad.
        upper: f64,
        /// Jaw speed limit, rad/s.
        speed: f64,
    },
    #[error("{0} is not finite")]
    /// An input with NaN or infinite values (holds which input).
    NonFinite(&'static str),
    #[error("time step must be finite and not negative, got {0} s")]
    /// A negative or non-finite time step, s (holds it).
    InvalidTimeStep(f64),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
/// Where the mapping stands.
pub enum TeleopState {
    /// Operator present, not clutched, but no MTM pose or PSM setpoint received yet.
    WaitingForArms,
    /// The operator is not at the console: no target.
    OperatorAbsent,
    /// Clutch pedal pressed: the PSM holds while the MTM moves freely.
    Clutched,
    /// The MTM stopped publishing: the PSM holds until it is back.
    MtmSilent,
    /// Engaged: the PSM follows the MTM.
    Following,
}

/// What to send the PSM.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TeleopTarget {
    /// Tool pose for the PSM's `servo_cp`, in the common (camera) frame, m.
    pub pose: Isometry3<f64>,
    /// Jaw opening for the PSM's `jaw/servo_jp`, rad.
    pub jaw: f64,
}

/// Where the mapping was engaged.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Anchor {
    mtm_position: Vector3<f64>,
    psm_position: Vector3<f64>,
    orientation_offset: UnitQuaternion<f64>,
}

#[derive(Debug, Clone)]
/// The teleoperation state machine of one MTM-PSM pair.
pub struct Teleop {
    config: TeleopConfig,
    operator_present: bool,
    clutched: bool,
    /// Latest MTM pose and gripper angle.
    mtm: Option<(Isometry3<f64>, f64)>,
    /// Latest PSM setpoint pose and jaw.
    psm: Option<(Isometry3<f64>, f64)>,
    anchor: Option<Anchor>,
    target: Option<TeleopTarget>,
    /// Time since the last MTM message (s), once there was one.
    mtm_silent_for: f64,
    mtm_gone: bool,
}

impl Teleop {
    /// Starts with the operator absent and the clutch released.
    pub fn new(config: TeleopConfig) -> Result<Teleop, TeleopError> {
        check_scale(config.scale)?;
        let jaw_ok = config.jaw_lower.is_finite()
            && config.jaw_upper.is_finite()
            && config.jaw_lower <= config.jaw_upper
            && config.jaw_max_speed > 0.0;
        if !jaw_ok {
            return Err(TeleopError::InvalidJawConfig {
                lower: config.jaw_lower,
                upper: config.jaw_upper,
                speed: config.jaw_max_speed,
            });
        }
        Ok(Teleop {
            config,
            operator_present: false,
            clutched: false,
            mtm: None,
            psm: None,
            anchor: None,
            target: None,
            mtm_silent_for: 0.0,
            mtm_gone: false,
        })
    }

    /// Where the mapping stands now.
    pub fn state(&self) -> TeleopState {
        if self.anchor.is_some() {
            TeleopState::Following
        } else if !self.operator_present {
            TeleopState::OperatorAbsent
        } else if self.clutched {
            TeleopState::Clutched
        } else if self.mtm_gone {
            TeleopState::MtmSilent
        } else {
            TeleopState::WaitingForArms
        }
    }

    /// The PSM setpoint to send, while following; `None` means the PSM should hold.
    pub fn target(&self) -> Option<TeleopTarget> {
        self.anchor.and(self.target)
    }

    /// PSM displacement per MTM displacement.
    pub fn scale(&self) -> f64 {
        self.config.scale
    }

    /// Changes the scale; while following the mapping re-anchors so the PSM does not jump.
    pub fn set_scale(&mut self, scale: f64) -> Result<(), TeleopError> {
        check_scale(scale)?;
        self.config.scale = scale;
        if let (Some(anchor), Some((mtm, _)), Some(target)) =
            (&mut self.anchor, self.mtm, self.target)
        {
            anchor.mtm_position = mtm.translation.vector;
            anchor.psm_position = target.pose.translation.vector;
        }
        Ok(())
    }

    /// The operator-presence pedal / head sensor.
    pub fn set_operator_present(&mut self, present: bool) {
        self.operator_present = present;
        self.refresh_engagement();
    }

    /// The clutch pedal.
    pub fn set_clutch(&mut self, pressed: bool) {
        self.clutched = pressed;
        self.refresh_engagement();
    }

    /// The PSM's current setpoint (`setpoint_cp`, `jaw/setpoint_js`), which the mapping anchors
    /// on when it engages. Feed it every cycle, as dVRK's teleop reads it.
    pub fn update_psm_setpoint(
        &mut self,
        pose: Isometry3<f64>,
        jaw: f64,
    ) -> Result<(), TeleopError> {
        check_pose(&pose, "PSM setpoint pose")?;
        check_value(jaw, "PSM jaw setpoint")?;
        self.psm = Some((pose, jaw));
        self.refresh_engagement();
        Ok(())
    }

    /// `dt` seconds passed without an MTM message. True exactly when this makes the MTM count
    /// as gone (silent for [`MTM_SILENCE_S`] after having published): the mapping disengages
    /// and the PSM holds.
    pub fn mtm_silent(&mut self, dt: f64) -> bool {
        if self.mtm.is_none() || self.mtm_gone {
            return false;
        }
        self.mtm_silent_for += dt.max(0.0);
        if self.mtm_silent_for < MTM_SILENCE_S {
            return false;
        }
        self.mtm_gone = true;
        self.refresh_engagement();
        true
    }

    /// Whether the MTM counts as gone (see [`Teleop::mtm_silent`]).
    pub fn mtm_gone(&self) -> bool {
        self.mtm_gone
    }

    /// A new MTM pose and gripper angle (rad), `dt` seconds after the previous one; updates the
    /// target while following. An MTM that was gone is back: the mapping re-anchors.
    pub fn update_mtm(
        &mut self,
        pose: Isometry3<f64>,
        gripper: f64,
        dt: f64,
    ) -> Result<(), TeleopError> {
        check_pose(&pose, "MTM pose")?;
        check_value(gripper, "MTM gripper angle")?;
        if !(dt.is_finite() && dt >= 0.0) {
            return Err(TeleopError::InvalidTimeStep(dt));
        }
        self.mtm = Some((pose, gripper));
        self.mtm_silent_for = 0.0;
        self.mtm_gone = false;
        self.refresh_engagement();
        let (Some(anchor), Some(held)) = (self.anchor, self.target) else {
            return Ok(());
        };
        let position = self.config.scale * (pose.translation.vector - anchor.mtm_position)
            + anchor.psm_position;
        let orientation = pose.rotation * anchor.orientation_offset;
        let wanted_jaw = (gripper * self.config.jaw_upper / MTM_GRIPPER_SPAN)
            .clamp(self.config.jaw_lower, self.config.jaw_upper);
        let max_step = self.config.jaw_max_speed * dt;
        let jaw = held.jaw + (wanted_jaw - held.jaw).clamp(-max_step, max_step);
        self.target = Some(TeleopTarget {
            pose: Isometry3::from_parts(Translation3::from(position), orientation),
            jaw,
        });
        Ok(())
    }

    /// Engages when everything allows it, disengages when something forbids it.
    fn refresh_engagement(&mut self) {
        if !self.operator_present || self.clutched || self.mtm_gone {
            self.anchor = None;
            self.target = None;
            return;
        }
        if self.anchor.is_some() {
            return;
        }
        if let (Some((mtm, _)), Some((psm, psm_jaw))) = (self.mtm, self.psm) {
            self.anchor = Some(Anchor {
                mtm_position: mtm.translation.vector,
                psm_position: psm.translation.vector,
                orientation_offset: mtm.rotation.inverse() * psm.rotation,
            });
            self.target = Some(TeleopTarget {
                pose: psm,
                jaw: psm_jaw,
            });
        }
    }
}

fn check_scale(scale: f64) -> Result<(), TeleopError> {
    if scale.is_finite() && scale > 0.0 {
        Ok(())
    } else {
        Err(TeleopError::InvalidScale(scale))
    }
}

fn check_pose(pose: &Isometry3<f64>, what: &'static str) -> Result<(), TeleopError> {
    let finite = pose.translation.vector.iter().all(|v| v.is_finite())
        && pose.rotation.coords.iter().all(|v| v.is_finite());
    if finite {
        Ok(())
    } else {
        Err(TeleopError::NonFinite(what))
    }
}

fn check_value(value: f64, what: &'static str) -> Result<(), TeleopError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(TeleopError::NonFinite(what))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    const DT: f64 = 1e-3;

    fn config() -> TeleopConfig {
        TeleopConfig::for_psm(&Psm::classic("PSM1").unwrap())
    }

    fn pose(x: f64, y: f64, z: f64, roll: f64, pitch: f64, yaw: f64) -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::new(x, y, z),
            UnitQuaternion::from_euler_angles(roll, pitch, yaw),
        )
    }

    /// A PSM that reaches every target at once, as the simulation's does.
    struct Rig {
        teleop: Teleop,
        psm: Isometry3<f64>,
        jaw: f64,
    }

    impl Rig {
        fn new() -> Rig {
            let psm = pose(0.01, -0.02, -0.1, PI, 0.1, 0.2);
            let mut teleop = Teleop::new(config()).unwrap();
            teleop.update_psm_setpoint(psm, 0.2).unwrap();
            Rig {
                teleop,
                psm,
                jaw: 0.2,
            }
        }

        fn mtm(&mut self, mtm: Isometry3<f64>, gripper: f64) {
            self.teleop.update_mtm(mtm, gripper, DT).unwrap();
            if let Some(target) = self.teleop.target() {
                self.psm = target.pose;
                self.jaw = target.jaw;
            }
            self.teleop.update_psm_setpoint(self.psm, self.jaw).unwrap();
        }
    }

    #[test]
    fn follows_at_a_fifth_of_the_mtm_displacement() {
        let mut rig = Rig::new();
        let start = rig.psm;
        rig.teleop.set_operator_present(true);
        let mtm0 = pose(0.1, 0.2, 0.3, 0.3, -0.2, 1.0);
        rig.mtm(mtm0, 0.0);
        assert_eq!(rig.teleop.state(), TeleopState::Following);
        // Engaging does not move the PSM.
        assert!((rig.psm.translation.vector - start.translation.vector).norm() < 1e-15);
        assert!(rig.psm.rotation.angle_to(&start.rotation) < 1e-12);

        let step = Vector3::new(0.05, -0.03, 0.02);
        let turn = UnitQuaternion::from_euler_angles(0.1, 0.2, -0.3);
        let mtm1 = Isometry3::from_parts(
            Translation3::from(mtm0.translation.vector + step),
            mtm0.rotation * turn,
        );
        rig.mtm(mtm1, 0.0);
        let moved = rig.psm.translation.vector - start.translation.vector;
        assert!((moved - DEFAULT_SCALE * step).norm() < 1e-15);
        // Absolute orientation: PSM = MTM · offset, offset = MTM₀⁻¹ · PSM₀.
        let expected = mtm1.rotation * mtm0.rotation.inverse() * start.rotation;
        assert!(rig.psm.rotation.angle_to(&expected) < 1e-12);
    }

    #[test]
    fn clutch_holds_then_reanchors() {
        let mut rig = Rig::new();
        rig.teleop.set_operator_present(true);
        rig.mtm(pose(0.0, 0.0, 0.0, 0.0, 0.0, 0.0), 0.0);
        rig.mtm(pose(0.02, 0.0, 0.0, 0.0, 0.0, 0.0), 0.0);
        let before_clutch = rig.psm;

        rig.teleop.set_clutch(true);
        assert_eq!(rig.teleop.state(), TeleopState::Clutched);
        assert_eq!(rig.teleop.target(), None);
        for k in 1..=50 {
            rig.mtm(
                pose(0.02 + k as f64 * 0.002, 0.05, -0.01, 0.0, 0.0, 0.0),
                0.0,
            );
        }
        assert_eq!(rig.psm, before_clutch);

        // Release: no jump, then relative motion from the new MTM position.
        rig.teleop.set_clutch(false);
        assert_eq!(rig.teleop.state(), TeleopState::Following);
        assert_eq!(rig.teleop.target().unwrap().pose, before_clutch);
        rig.mtm(pose(0.12, 0.05, -0.01, 0.0, 0.0, 0.0), 0.0);
        assert!((rig.psm.translation.vector - before_clutch.translation.vector).norm() < 1e-15);
        rig.mtm(pose(0.12, 0.10, -0.01, 0.0, 0.0, 0.0), 0.0);
        let moved = rig.psm.translation.vector - before_clutch.translation.vector;
        assert!((moved - Vector3::new(0.0, 0.05 * DEFAULT_SCALE, 0.0)).norm() < 1e-15);
    }

    #[test]
    fn operator_presence_gates_following() {
        let mut rig = Rig::new();
        let start = rig.psm;
        rig.mtm(pose(0.0, 0.0, 0.0, 0.0, 0.0, 0.0), 0.0);
        assert_eq!(rig.teleop.state(), TeleopState::OperatorAbsent);
        rig.mtm(pose(0.1, 0.0, 0.0, 0.0, 0.0, 0.0), 0.0);
        assert_eq!(rig.teleop.target(), None);
        assert_eq!(rig.psm, start);

        rig.teleop.set_operator_present(true);
        assert_eq!(rig.teleop.state(), TeleopState::Following);
        rig.mtm(pose(0.15, 0.0, 0.0, 0.0, 0.0, 0.0), 0.0);
        assert!((rig.psm.translation.x - (start.translation.x + 0.01)).abs() < 1e-15);

        rig.teleop.set_operator_present(false);
        assert_eq!(rig.teleop.target(), None);
        let left_at = rig.psm;
        rig.mtm(pose(0.3, 0.0, 0.0, 0.0, 0.0, 0.0), 0.0);
        assert_eq!(rig.psm, left_at);
    }

    #[test]
    fn waits_for_both_arms_before_engaging() {
        let mut teleop = Teleop::new(config()).unwrap();
        teleop.set_operator_present(true);
        assert_eq!(teleop.state(), TeleopState::WaitingForArms);
        teleop.update_mtm(Isometry3::identity(), 0.0, DT).unwrap();
        assert_eq!(teleop.state(), TeleopState::WaitingForArms);
        assert_eq!(teleop.target(), None);
        teleop
            .update_psm_setpoint(Isometry3::translation(0.0, 0.0, -0.1), 0.0)
            .unwrap();
        assert_eq!(teleop.state(), TeleopState::Following);
    }

    #[test]
    fn gripper_maps_to_jaw_with_clamp_and_speed_limit() {
        let jaw_max = config().jaw_upper;
        let mut rig = Rig::new();
        rig.teleop.set_operator_present(true);
        let mtm = pose(0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        rig.mtm(mtm, 0.0);
        // Half-open gripper: half the jaw range, reached at ≤ 720°/s.
        let mut previous = rig.jaw;
        for _ in 0..200 {
            rig.mtm(mtm, 30f64.to_radians());
            assert!((rig.jaw - previous).abs() <= DEFAULT_JAW_MAX_SPEED * DT * (1.0 + 1e-12));
            previous = rig.jaw;
        }
        assert!((rig.jaw - 0.5 * jaw_max).abs() < 1e-12);
        // Beyond the gripper span: the jaw limit.
        for _ in 0..200 {
            rig.mtm(mtm, 90f64.to_radians());
        }
        assert!((rig.jaw - jaw_max).abs() < 1e-12);
        // Squeezing hard: the lower limit.
        for _ in 0..400 {
            rig.mtm(mtm, -60f64.to_radians());
        }
        assert!((rig.jaw - config().jaw_lower).abs() < 1e-12);
    }

    #[test]
    fn scale_change_reanchors_without_a_jump() {
        let mut rig = Rig::new();
        rig.teleop.set_operator_present(true);
        rig.mtm(pose(0.0, 0.0, 0.0, 0.0, 0.0, 0.0), 0.0);
        rig.mtm(pose(0.05, 0.0, 0.0, 0.0, 0.0, 0.0), 0.0);
        let before = rig.psm;
        rig.teleop.set_scale(0.5).unwrap();
        assert_eq!(rig.teleop.scale(), 0.5);
        rig.mtm(pose(0.05, 0.0, 0.0, 0.0, 0.0, 0.0), 0.0);
        assert!((rig.psm.translation.vector - before.translation.vector).norm() < 1e-15);
        rig.mtm(pose(0.07, 0.0, 0.0, 0.0, 0.0, 0.0), 0.0);
        assert!((rig.psm.translation.x - (before.translation.x + 0.01)).abs() < 1e-15);
        assert!(matches!(
            rig.teleop.set_scale(0.0),
            Err(TeleopError::InvalidScale(_))
        ));
        assert!(matches!(
            rig.teleop.set_scale(f64::NAN),
            Err(TeleopError::InvalidScale(_))
        ));
    }

    #[test]
    fn a_silent_mtm_holds_the_psm_and_its_return_reanchors() {
        let mut rig = Rig::new();
        rig.teleop.set_operator_present(true);
        rig.mtm(pose(0.0, 0.0, 0.0, 0.0, 0.0, 0.0), 0.3);
        rig.mtm(pose(0.05, 0.0, 0.0, 0.0, 0.0, 0.0), 0.3);
        let held = rig.teleop.target().unwrap().pose;
        // Silent just short of the limit: still following, nothing said.
        let frames = (MTM_SILENCE_S / 0.01).round() as usize;
        for _ in 0..frames - 1 {
            assert!(!rig.teleop.mtm_silent(0.01));
        }
        assert_eq!(rig.teleop.state(), TeleopState::Following);
        // Then gone, said once; the PSM has no target (holds).
        assert!(rig.teleop.mtm_silent(0.01));
        assert!(!rig.teleop.mtm_silent(0.01));
        assert_eq!(rig.teleop.state(), TeleopState::MtmSilent);
        assert!(rig.teleop.target().is_none());
        // Back 80 mm further on: re-anchored where the PSM held, no jump; then following.
        rig.mtm(pose(0.13, 0.0, 0.0, 0.0, 0.0, 0.0), 0.3);
        assert_eq!(rig.teleop.state(), TeleopState::Following);
        let back = rig.teleop.target().unwrap().pose;
        assert!((back.translation.vector - held.translation.vector).norm() < 1e-12);
        rig.mtm(pose(0.18, 0.0, 0.0, 0.0, 0.0, 0.0), 0.3);
        let moved = rig.teleop.target().unwrap().pose.translation.vector - held.translation.vector;
        assert!((moved - Vector3::new(0.2 * 0.05, 0.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn bad_inputs_are_refused_and_change_nothing() {
        let mut rig = Rig::new();
        rig.teleop.set_operator_present(true);
        rig.mtm(pose(0.0, 0.0, 0.0, 0.0, 0.0, 0.0), 0.0);
        let target = rig.teleop.target();
        let t = &mut rig.teleop;
        assert!(matches!(
            t.update_mtm(pose(f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0), 0.0, DT),
            Err(TeleopError::NonFinite(_))
        ));
        assert!(matches!(
            t.update_mtm(Isometry3::identity(), f64::INFINITY, DT),
            Err(TeleopError::NonFinite(_))
        ));
        assert!(matches!(
            t.update_mtm(Isometry3::identity(), 0.0, -DT),
            Err(TeleopError::InvalidTimeStep(_))
        ));
        assert!(matches!(
            t.update_psm_setpoint(Isometry3::identity(), f64::NAN),
            Err(TeleopError::NonFinite(_))
        ));
        assert_eq!(t.target(), target);
        let bad = TeleopConfig {
            jaw_lower: 1.0,
            jaw_upper: 0.0,
            ..config()
        };
        assert!(matches!(
            Teleop::new(bad),
            Err(TeleopError::InvalidJawConfig { .. })
        ));
    }
}
