//! Detection of non-finite values and runaway speeds, inside the substep that produces them,
//! and the stability matrix that says where the solvers stay stable.
//!
//! # The guard
//!
//! Non-finite state or a particle speed above `solver.max_speed` is caught in the substep it
//! appears (the lowest particle index is reported, with its position, so CPU reports are
//! reproducible). `guard_policy = "stop"` restores the last good frame and ends the run with
//! the error; `"reset_tissue"` puts the tissue back to rest and carries on. On the GPU the
//! same checks run in G2P and the frame-start state is copied on the device, so `stop`
//! restores it bit for bit.
//!
//! # Stability: `stress`
//!
//! `cargo run --release -- stress` runs the stability matrix (`stress --reduced`, which CI
//! runs through `tests/stress_reduced.rs`, a corner of each group and a 10-second soak).
//! Per case: stable (every check below passed), energy drift (E_end − E_start − tool work)
//! over an energy scale (tissue weight × its height + |tool work|; negative is dissipation),
//! the largest energy gain seen at any frame (checked ≤ 0.1, except where jaws close: the tool
//! work counts the tool's rigid motion, not the jaws rotating about their hinge), the deepest
//! particle inside a solid tool in grid cells (≤ 2: beyond that tissue flows through the
//! tool), particles escaped, non-finite particles, guard events, and frames whose fixed `dt`
//! was subdivided to respect the CFL bound.
//!
//! **Safe envelope** (every case inside it must pass; `stress` exits non-zero otherwise):
//! E 1 kPa–1 MPa, ν 0.3–0.49, any fixed `dt` (subdivided down to the CFL bound), tool speeds up
//! to 1 m/s, jaws closing fully, tissue pulled to 1.5×, dropped from 30 mm, ten minutes of
//! periodic grasping; with `method = "implicit"` the sphere indentation at E 1 kPa–1 MPa and
//! ν 0.3–0.499 and capsule drags up to 1 m/s (backward Euler dissipates: no implicit case
//! gains energy). Cases outside it (ν 0.499, 3 m/s) show where it ends. The `pb-mpm` group
//! runs the sphere indentation with PB-MPM at 1/240 s; its energy balance is shown, not
//! checked, because PB-MPM's elastic response is not derived from the Neo-Hookean energy the
//! check evaluates. The `thread` group is described in [`crate::rod`].
//!
//! Selected rows of `cargo run --release -- stress` (CPU backend, this 2-core machine):
//!
//! | group | case | envelope | stable | substeps | energy drift | max energy gain | max penetration (cells) |
//! |---|---|---|---|---|---|---|---|
//! | material | E 1 kPa ν 0.3 | inside | yes | 171 | -0.013 | +0.000 | 0.29 |
//! | material | E 1 MPa ν 0.49 | inside | yes | 19062 | -0.059 | +0.000 | 0.31 |
//! | material | E 1 MPa ν 0.499 | outside | yes | 59562 | -0.101 | +0.000 | 0.26 |
//! | time step | dt 4× CFL | inside | yes | 666 | -0.021 | +0.000 | 0.33 |
//! | tool speed | 1 m/s sideways | inside | yes | 370 | -0.568 | +0.000 | 0.73 |
//! | tool speed | 3 m/s sideways | outside | yes | 370 | -0.595 | +0.000 | 0.69 |
//! | scenario | jaws close fully on tissue | inside | yes | 2970 | +0.965 | (+9.914) | 1.00 |
//! | scenario | two tools pull apart 1.5× | inside | yes | 2220 | -0.144 | +0.000 | 0.75 |
//! | scenario | dropped from 30 mm | inside | yes | 1332 | -3.072 | +0.000 | 0.00 |
//! | soak | periodic grasp, 10 min simulated | inside | yes | 3960000 | -0.032 | (+1.516) | 1.00 |
//! | pb-mpm | E 1 MPa ν 0.49, dt 1/240 s | inside | yes | 36 | +864.625 | (+1343.312) | 0.23 |
//!
//! The substep counts are the CFL cost of stiffness and near-incompressibility for MLS-MPM
//! (19,062 substeps for 0.15 s at 1 MPa, ν 0.49, where PB-MPM takes 36 and the implicit
//! method 18).

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
    /// The event of a particle G2P stopped: non-finite unless `finite` (its speed then NaN),
    /// a runaway at `speed` otherwise; `position` is where it was before the substep.
    pub fn stopped(finite: bool, particle: usize, position: Vec3, speed: f32) -> Self {
        GuardEvent {
            kind: if finite {
                GuardKind::Runaway
            } else {
                GuardKind::NonFinite
            },
            particle: particle as u32,
            position,
            speed: if finite { speed } else { f32::NAN },
        }
    }

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
