//! One frame as a backend runs it: the plan decided before the first substep (equal
//! substeps, every substep's tool kinematics) and the statistics reported back.

use super::guard::GuardEvent;
use super::{SolveCounts, ToolImpulse, Vec3, MAX_TOOLS};
use crate::tools::ToolKinematics;

/// Everything one frame's substeps need, decided before the first of them runs.
#[derive(Clone, Copy, Debug)]
pub struct FramePlan<'a> {
    /// Substep length, s (the same for every substep of the frame).
    pub dt: f32,
    /// Substeps planned.
    pub substeps: u32,
    /// Gravity, world frame, m/s².
    pub gravity: Vec3,
    /// Tools per substep.
    pub tool_count: usize,
    /// `substeps × tool_count` entries, substep-major.
    pub tools: &'a [ToolKinematics],
    /// Where this frame sits in the world's frame.
    pub part: FramePart,
}

/// Where a backend frame sits in the world's frame: all of it, or one of the substeps the
/// world steps as a backend frame each while a needle is free (see
/// [`crate::world::needle_body`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FramePart {
    /// The world's frame starts here: the backend keeps this state for a guard event's
    /// restore.
    pub first: bool,
    /// The world's frame ends here: the backend reads the particles back (the GPU) and
    /// splits the stretched ones (the CPU).
    pub last: bool,
}

impl FramePart {
    /// A backend frame that is the world's frame.
    pub const WHOLE: FramePart = FramePart {
        first: true,
        last: true,
    };
}

impl FramePlan<'_> {
    /// The tools of substep `s`.
    pub fn substep_tools(&self, s: usize) -> &[ToolKinematics] {
        &self.tools[s * self.tool_count..(s + 1) * self.tool_count]
    }
}

/// What a frame reports back.
#[derive(Clone, Debug, Default)]
pub struct FrameStats {
    /// Impulse on each tool summed over the completed substeps.
    pub tool_impulses: [ToolImpulse; MAX_TOOLS],
    /// Largest particle speed over the frame (m/s).
    pub max_speed: f32,
    /// Particles that reached the domain edge and were clamped back inside, summed over substeps.
    pub clamped_particles: u32,
    /// Substeps completed before the guard tripped (all of them when it did not).
    pub substeps_done: u32,
    /// The guard event of the first substep that tripped; the state is unusable then and
    /// must be restored (`restore_frame_start` or `reset_to_rest`).
    pub guard: Option<GuardEvent>,
    /// Newton and CG iterations of the implicit solver over the frame.
    pub solve: SolveCounts,
    /// Particles split at the frame's end, and splits the particle cap refused (see
    /// [`super::split`]).
    pub split: super::split::SplitCount,
    /// Largest principal stretch of any particle at the frame's end (see
    /// [`super::split::max_stretch`]), measured where particles split (CPU); 0 elsewhere.
    pub max_stretch: f32,
    /// Where that particle is (m).
    pub max_stretch_at: Vec3,
}

impl FrameStats {
    /// Adds the statistics of a frame that continued this one (a frame stepped as several
    /// backend frames): sums and counts add, extremes take the larger, the first guard
    /// event stays, the end-of-frame measures are the later frame's.
    pub fn continue_with(&mut self, later: &FrameStats) {
        for (acc, imp) in self.tool_impulses.iter_mut().zip(&later.tool_impulses) {
            acc.add(imp);
        }
        self.max_speed = self.max_speed.max(later.max_speed);
        self.clamped_particles += later.clamped_particles;
        self.substeps_done += later.substeps_done;
        self.guard = self.guard.or(later.guard);
        self.solve.add(later.solve);
        self.split.split += later.split.split;
        self.split.refused += later.split.refused;
        self.max_stretch = later.max_stretch;
        self.max_stretch_at = later.max_stretch_at;
    }
}
