//! Sleep and wake: tissue at rest that no tool can reach skips its frames.
//!
//! Criterion. The tissue falls asleep after `after_frames` consecutive frames in which no
//! particle moved faster than `speed` and no tool touched a grid node. While asleep, a frame
//! is skipped only if no tool can touch the tissue during it: the box swept by each tool's
//! bounding sphere over the frame (at the frame's ends and at every keyframe inside it,
//! between which tools move linearly), grown by its contact reach, must miss the tissue's
//! box grown by the two cells a particle's stencil reaches. Both boxes contain everything
//! that could meet, so a contact is never missed: the first frame in which one could happen
//! is stepped in full. A suture thread is tested the same way: its points and its held
//! ends' targets, grown by its radius, one cell (its contact reach on the grid), the
//! farthest its holders (grippers or scene anchors) travel in the frame and twice the
//! distance its fastest point covers on its own
//! ([`crate::world::thread_body::ThreadBody::reach_over`]). Editing particles or resetting
//! the tissue wakes it too. `tests/sleep.rs` compares a run with sleep on and off frame by
//! frame, and lowers a thread onto sleeping tissue.
//!
//! # Skipping idle work
//!
//! Sleep is one of three ways the simulation spends nothing on what a scene does not need:
//! - **Sleep**, above (`[sleep]` in a scene).
//! - **Work follows occupied blocks**: particles are binned into 4³-node blocks; only touched
//!   blocks are cleared, updated and scattered to, on the CPU and the GPU, so the same tissue
//!   in a domain 4× larger per axis touches exactly as many blocks (`tests/sleep.rs`). On the
//!   GPU the block marking pass still scans one flag per domain block each substep.
//! - **Absent features**: tools are evaluated only on nodes inside their bounding boxes;
//!   outputs nobody subscribes to are not computed; the surface mesh and the deformation
//!   gradient readback run only when wanted; cutting and damage allocate nothing and take the
//!   plain transfers until a scene needs them.
//!
//! `cargo run --release -- bench skip` (seed 000's tissue, 24,000 particles, 64³ grid, CPU, 10
//! frames each, this 2-core machine shared with builds):
//!
//! | case | grid nodes | ms per frame | compared with | ratio | target |
//! |---|---|---|---|---|---|
//! | at rest, stepped (sleep off) | 314432 | 573.235 | — | — | — |
//! | at rest, asleep | 314432 | 0.012 | at rest, stepped | 2.1e-5 | ≤ 0.05 |
//! | domain 4× per axis (64× nodes) | 17576000 | 580.163 | at rest, stepped | 1.012 | ≤ 1.2 |
//! | no tools | 314432 | 567.671 | — | — | — |
//! | gripper, needle, probe parked | 314432 | 578.774 | no tools | 1.020 | ≤ 1.05 |

use crate::math::Vec3;
use serde::{Deserialize, Serialize};

/// `[sleep]` in a scene file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SleepSettings {
    /// Let resting tissue skip frames.
    #[serde(default = "default_enabled")]
    pub enabled: bool,
    /// Particle speed below which the tissue counts as at rest (m/s).
    #[serde(default = "default_speed")]
    pub speed: f64,
    /// Consecutive quiet frames before it falls asleep.
    #[serde(default = "default_after_frames")]
    pub after_frames: u32,
}

fn default_enabled() -> bool {
    true
}
/// 0.1 mm/s: a tissue this slow moves under 2 µm per 60 Hz frame.
fn default_speed() -> f64 {
    1e-4
}
fn default_after_frames() -> u32 {
    30
}

impl Default for SleepSettings {
    fn default() -> Self {
        SleepSettings {
            enabled: default_enabled(),
            speed: default_speed(),
            after_frames: default_after_frames(),
        }
    }
}

/// An axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner, m.
    pub min: Vec3,
    /// Upper corner, m.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box (min +∞, max −∞), which includes nothing.
    pub fn empty() -> Self {
        Aabb {
            min: Vec3::repeat(f32::INFINITY),
            max: Vec3::repeat(f32::NEG_INFINITY),
        }
    }

    /// Box of `points`; empty when there are none.
    pub fn of_points(points: &[Vec3]) -> Self {
        points.iter().fold(Self::empty(), |b, p| b.including(p))
    }

    /// Box of a sphere.
    pub fn of_sphere(centre: Vec3, radius: f32) -> Self {
        Aabb {
            min: centre - Vec3::repeat(radius),
            max: centre + Vec3::repeat(radius),
        }
    }

    /// The box grown to include `p`.
    pub fn including(self, p: &Vec3) -> Self {
        Aabb {
            min: self.min.inf(p),
            max: self.max.sup(p),
        }
    }

    /// The smallest box holding both.
    pub fn union(self, other: &Aabb) -> Self {
        Aabb {
            min: self.min.inf(&other.min),
            max: self.max.sup(&other.max),
        }
    }

    /// The box grown by `margin` (m) on every side.
    pub fn grown(self, margin: f32) -> Self {
        Aabb {
            min: self.min - Vec3::repeat(margin),
            max: self.max + Vec3::repeat(margin),
        }
    }

    /// Whether the boxes overlap (touching counts).
    pub fn intersects(&self, other: &Aabb) -> bool {
        (0..3).all(|a| self.min[a] <= other.max[a] && other.min[a] <= self.max[a])
    }
}

/// Sleep state of one world.
#[derive(Clone, Debug, Default)]
pub struct SleepState {
    quiet_frames: u32,
    /// Grown tissue box while asleep.
    asleep: Option<Aabb>,
}

impl SleepState {
    /// Whether the tissue sleeps (frames may be skipped).
    pub fn is_asleep(&self) -> bool {
        self.asleep.is_some()
    }

    /// The tissue's box grown by its stencil reach, while asleep: a frame may be skipped
    /// when no tool's swept reach meets it.
    pub fn tissue_box(&self) -> Option<Aabb> {
        self.asleep
    }

    /// Records a stepped frame. `positions` is only read when the tissue falls asleep.
    pub fn observe(
        &mut self,
        settings: &SleepSettings,
        max_speed: f32,
        any_contact: bool,
        positions: &[Vec3],
        dx: f32,
    ) {
        if !settings.enabled || any_contact || max_speed as f64 >= settings.speed {
            self.quiet_frames = 0;
            return;
        }
        self.quiet_frames += 1;
        if self.quiet_frames >= settings.after_frames.max(1) {
            // A particle's quadratic stencil reaches nodes up to 1.5 cells away.
            self.asleep = Some(Aabb::of_points(positions).grown(2.0 * dx));
        }
    }

    /// Wakes the tissue: it is stepped again from this frame and must stay quiet to fall asleep
    /// again.
    pub fn wake(&mut self) {
        self.quiet_frames = 0;
        self.asleep = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings() -> SleepSettings {
        SleepSettings {
            enabled: true,
            speed: 1e-4,
            after_frames: 3,
        }
    }

    #[test]
    fn falls_asleep_after_quiet_frames_only() {
        let mut s = SleepState::default();
        let points = [Vec3::zeros(), Vec3::repeat(0.01)];
        for _ in 0..2 {
            s.observe(&settings(), 5e-5, false, &points, 0.001);
        }
        assert!(!s.is_asleep());
        // A fast frame starts the count again.
        s.observe(&settings(), 1e-3, false, &points, 0.001);
        s.observe(&settings(), 5e-5, false, &points, 0.001);
        s.observe(&settings(), 5e-5, false, &points, 0.001);
        assert!(!s.is_asleep());
        s.observe(&settings(), 5e-5, false, &points, 0.001);
        assert!(s.is_asleep());
        // Contact keeps it awake.
        let mut t = SleepState::default();
        for _ in 0..10 {
            t.observe(&settings(), 0.0, true, &points, 0.001);
        }
        assert!(!t.is_asleep());
        // Disabled never sleeps.
        let off = SleepSettings {
            enabled: false,
            ..settings()
        };
        for _ in 0..10 {
            t.observe(&off, 0.0, false, &points, 0.001);
        }
        assert!(!t.is_asleep());
    }

    #[test]
    fn a_tool_within_two_cells_reaches_the_tissue_box() {
        let mut s = SleepState::default();
        let points = [Vec3::zeros(), Vec3::repeat(0.01)];
        for _ in 0..3 {
            s.observe(&settings(), 0.0, false, &points, 0.001);
        }
        let tissue = s.tissue_box().unwrap();
        let far = Aabb::of_sphere(Vec3::new(0.0, 0.0, 0.0125), 0.0004);
        assert!(!far.intersects(&tissue));
        let near = Aabb::of_sphere(Vec3::new(0.0, 0.0, 0.0115), 0.0004);
        assert!(near.intersects(&tissue));
        s.wake();
        assert!(!s.is_asleep());
    }
}
