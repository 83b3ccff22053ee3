//! Total Lagrangian MPM's grip: the tissue a gripper's jaws close on is captured as a set
//! of particles, and the rest-configuration nodes that carry at least half their mass in
//! captured particles are held (see [`crate::tools::grip`] for what holding a node means).
//!
//! The updated-Lagrangian solvers hold every node inside a box fixed to the jaws. On the
//! rest configuration's grid such a box means nothing (its nodes do not move with the
//! jaws), so total Lagrangian MPM holds material instead: the particles in the grip region
//! when the press starts. A node is held or not, never in part: a partial hold applied
//! every substep would hold harder the more substeps a frame takes.

use super::super::grid::GridLayout;
use super::super::kernel::Stencil;
use super::super::particles::Particles;
use super::super::{ToolImpulse, Vec3, MAX_TOOLS};
use crate::tools::ToolKinematics;

/// The share of a node's mass its captured particles must carry for the node to be held:
/// half, less a thousandth. A node on the grip region's edge of a regular lattice of
/// particles often has exactly half its mass inside, and the rounding of its two sums
/// (f32 here, fixed point or f32 atomics on the GPU) would decide such a tie differently
/// on each backend; seen as 2 % of the held mass differing between the CPU and the GPU's
/// fixed point. The GPU's grid update uses the same share.
pub const HELD_SHARE: f32 = 0.499;

/// Which particles each gripper holds, and the held mass they put on the grid this substep.
#[derive(Default)]
pub(super) struct Captured {
    /// Per particle: 0 when free, `t + 1` when gripper `t` holds it.
    tool: Vec<u8>,
    /// The held particles.
    held: Vec<u32>,
    /// Which grippers held during the last substep.
    holding: [bool; MAX_TOOLS],
    /// Per node: the held mass this substep (kg), and the gripper holding it (`t + 1`).
    node_mass: Vec<f32>,
    node_tool: Vec<u8>,
    /// Nodes written this substep, cleared before the next scatter.
    touched: Vec<usize>,
}

impl Captured {
    /// Captures the particles in a gripper's grip region when it starts to hold, and lets
    /// them go when it stops.
    pub(super) fn update(&mut self, particles: &Particles, tools: &[ToolKinematics]) {
        if self.tool.len() != particles.len() {
            // Split halves start free; removed particles take their marks with them.
            self.tool.resize(particles.len(), 0);
            self.held.retain(|&p| (p as usize) < particles.len());
        }
        for (t, tool) in tools.iter().enumerate() {
            let holds = tool.grip >= 0.0;
            if holds == self.holding[t] {
                continue;
            }
            self.holding[t] = holds;
            let mark = t as u8 + 1;
            if holds {
                for (p, x) in particles.x.iter().enumerate() {
                    if self.tool[p] == 0 && tool.grip_region(*x).is_some() {
                        self.tool[p] = mark;
                        self.held.push(p as u32);
                    }
                }
            } else {
                for &p in &self.held {
                    if self.tool[p as usize] == mark {
                        self.tool[p as usize] = 0;
                    }
                }
                let marks = &self.tool;
                self.held.retain(|&p| marks[p as usize] != 0);
            }
        }
        for t in tools.len()..MAX_TOOLS {
            self.holding[t] = false;
        }
    }

    /// Spreads the held particles' mass over the stencils at `positions` (the current
    /// ones, or the rest configuration's for total Lagrangian MPM).
    pub(super) fn scatter_at(&mut self, layout: &GridLayout, positions: &[Vec3], mass: &[f32]) {
        for &n in &self.touched {
            self.node_mass[n] = 0.0;
            self.node_tool[n] = 0;
        }
        self.touched.clear();
        if self.held.is_empty() {
            return;
        }
        if self.node_mass.len() != layout.node_count() {
            self.node_mass = vec![0.0; layout.node_count()];
            self.node_tool = vec![0; layout.node_count()];
        }
        for &p in &self.held {
            let p = p as usize;
            let s = Stencil::new((positions[p] - layout.origin) * layout.inv_dx);
            for a in 0..3 {
                for b in 0..3 {
                    for c in 0..3 {
                        let ijk = [
                            (s.base.x + a as i32) as usize,
                            (s.base.y + b as i32) as usize,
                            (s.base.z + c as i32) as usize,
                        ];
                        let n = layout.node_index(ijk[0], ijk[1], ijk[2]);
                        if self.node_tool[n] == 0 {
                            self.touched.push(n);
                        }
                        self.node_mass[n] += s.weight(a, b, c) * mass[p];
                        self.node_tool[n] = self.tool[p];
                    }
                }
            }
        }
    }

    /// The gripper holding node `n` of mass `m`: the one whose captured particles carry at
    /// least half of it ([`HELD_SHARE`]). All or nothing, so that how firmly a node is held
    /// does not depend on how many substeps hold it.
    #[inline(always)]
    pub(super) fn holder(&self, n: usize, m: f32) -> Option<usize> {
        let t = *self.node_tool.get(n)?;
        (t != 0 && self.node_mass[n] >= HELD_SHARE * m).then(|| t as usize - 1)
    }

    /// The gripper holding particle `p`, if one does.
    #[inline(always)]
    pub(super) fn tool_of(&self, p: usize) -> Option<usize> {
        self.tool
            .get(p)
            .and_then(|&t| t.checked_sub(1))
            .map(usize::from)
    }
}

/// The grip on a node of mass `m` that gripper `t` holds (see [`Captured::holder`]),
/// recording the impulse and the grip's sums as the region grip records them.
#[inline(always)]
pub(super) fn hold(
    tools: &[ToolKinematics],
    t: usize,
    x: Vec3,
    v: Vec3,
    m: f32,
    impulses: &mut [ToolImpulse; MAX_TOOLS],
) -> Vec3 {
    let tool = &tools[t];
    let held = tool.hold_anywhere(x, v);
    super::node_contact::record_hold(tool, t, x, v, m, &held, impulses)
}
