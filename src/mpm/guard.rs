//! Detection of non-finite values and runaway speeds, inside the substep that produces them.

use super::Vec3;
use serde::{Deserialize, Serialize};
use std::fmt;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
/// What the guard found wrong with a particle.
pub enum GuardKind {
    /// Position, velocity, affine velocity or deformation gradient is NaN or infinite.
    NonFinite,
    /// Speed above the scene's `solver.max_speed`.
    Runaway,
}

/// The first offending particle of a substep (lowest index, so CPU reports are reproducible).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GuardEvent {
    /// What was wrong.
    pub kind: GuardKind,
    /// The particle's index.
    pub particle: u32,
    /// Position before the substep that went wrong.
    pub position: Vec3,
    /// Speed that tripped the guard (NaN for non-finite events).
    pub speed: f32,
}

impl GuardEvent {
    /// Keeps the event with the lowest particle index.
    pub fn first(a: Option<GuardEvent>, b: Option<GuardEvent>) -> Option<GuardEvent> {
        match (a, b) {
            (Some(a), Some(b)) => Some(if a.particle <= b.particle { a } else { b }),
            (a, None) => a,
            (None, b) => b,
        }
    }
}

impl fmt::Display for GuardEvent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let p = self.position;
        match self.kind {
            GuardKind::NonFinite => write!(
                f,
                "non-finite state at particle {} near ({:.4}, {:.4}, {:.4}) m",
                self.particle, p.x, p.y, p.z
            ),
            GuardKind::Runaway => write!(
                f,
                "runaway speed {:.3} m/s at particle {} near ({:.4}, {:.4}, {:.4}) m",
                self.speed, self.particle, p.x, p.y, p.z
            ),
        }
    }
}

/// What the world does when the guard trips.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum GuardPolicy {
    /// Restore the last good frame and stop with an error.
    #[default]
    Stop,
    /// Put the tissue back to its rest configuration and carry on.
    ResetTissue,
}
