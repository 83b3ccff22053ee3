//! What reaches the simulation from outside, transport aside: commands ([`SimInput`]), the
//! message each came from when it is to be recorded ([`RecordedInput`], opaque bytes here),
//! and recorded inputs due again at a frame of a replay ([`ReplayInput`]). The node, a replay
//! and a scripted run all hand the frame loop the same types.

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};

use crate::sim::arm::ArmCommand;

/// Input from the network side.
#[derive(Clone, Debug, PartialEq)]
pub enum SimInput {
    /// A command to one arm.
    Arm {
        /// Index of the scene arm.
        arm: usize,
        /// The command and its topic.
        command: ArmCommand,
    },
    /// MTM `measured_cp`: position (m), quaternion x, y, z, w.
    MtmPose {
        /// Index of the scene arm the MTM drives.
        arm: usize,
        /// MTM position in the common (camera) frame, m.
        position: [f64; 3],
        /// MTM orientation, quaternion x, y, z, w.
        quaternion: [f64; 4],
    },
    /// MTM `gripper/measured_js` positions (rad).
    MtmGripper {
        /// Index of the scene arm the MTM drives.
        arm: usize,
        /// The positions (one expected).
        positions: Vec<f64>,
    },
    /// The console's clutch pedal: true while pressed.
    Clutch(bool),
    /// The console's operator-present pedal: true while the operator is there.
    OperatorPresent(bool),
}

/// An input as it arrived: its topic, type and CDR payload.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordedInput {
    /// The topic's absolute name.
    pub topic: String,
    /// The ROS type, `pkg/msg/Type`.
    pub type_name: String,
    /// The message as received, CDR with its encapsulation header.
    pub cdr: Vec<u8>,
}

/// An input with, when recording, the message it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct Received {
    /// `None` for a message with no effect on the simulation (recorded all the same).
    pub input: Option<SimInput>,
    /// The message as received, when recording (`None` otherwise).
    pub record: Option<RecordedInput>,
}

/// A recorded input, due at the frame starting at `time` (ns of simulated time).
#[derive(Clone, Debug, PartialEq)]
pub struct ReplayInput {
    /// Simulated time of the frame it is due at, ns.
    pub time: u64,
    /// `None` for a message that has no effect on the simulation (recorded all the same).
    pub input: Option<SimInput>,
    /// The message as recorded.
    pub record: RecordedInput,
}

/// Simulated seconds as integer nanoseconds (the MCAP log time).
pub fn nanos(t: f64) -> u64 {
    if t.is_finite() && t > 0.0 {
        (t * 1e9).round() as u64
    } else {
        0
    }
}

/// Why a commanded pose was refused.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PoseError {
    #[error("pose has NaN or infinite values")]
    /// A coordinate is NaN or infinite.
    NotFinite,
    #[error("orientation quaternion has length {0:.4}, not 1")]
    /// The quaternion's length is not 1 within tolerance (holds the length).
    QuaternionLength(f64),
}

/// A commanded pose: position (m) and quaternion x, y, z, w, of length 1 within 1 %.
pub fn isometry(position: &[f64; 3], quaternion: &[f64; 4]) -> Result<Isometry3<f64>, PoseError> {
    if !position.iter().chain(quaternion).all(|v| v.is_finite()) {
        return Err(PoseError::NotFinite);
    }
    let [x, y, z, w] = *quaternion;
    let q = Quaternion::new(w, x, y, z);
    if (q.norm() - 1.0).abs() > 0.01 {
        return Err(PoseError::QuaternionLength(q.norm()));
    }
    Ok(Isometry3::from_parts(
        Translation3::new(position[0], position[1], position[2]),
        UnitQuaternion::from_quaternion(q),
    ))
}
