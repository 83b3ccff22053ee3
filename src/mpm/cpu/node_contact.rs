//! The grid update's contact at one node, on the CPU: a gripper's grip, the nearest tool's
//! contact (seed 000's collision-objects table), the table plane and the domain's slip walls,
//! each recording the momentum a tool takes from the node as its impulse. The GPU's
//! `grid_update.wgsl` and `common.wgsl` do the same per node.

use super::super::grid::{Boundary, GridLayout, TableHold, WALL_NODES};
use super::super::{ToolImpulse, Vec3, MAX_TOOLS};
use crate::tools::{contact, ToolKinematics};

/// The grip of the first gripper that holds the node (see [`crate::tools::grip`]),
/// recording the impulse the tool receives, the share along the jaw normal that pushes the
/// jaws apart, and the grip's sums. Grid contact does not apply to a held node.
#[inline(always)]
pub(super) fn hold_node(
    tools: &[ToolKinematics],
    x: Vec3,
    v: Vec3,
    m: f32,
    impulses: &mut [ToolImpulse; MAX_TOOLS],
) -> Option<Vec3> {
    let (t, tool, held) = tools
        .iter()
        .enumerate()
        .find_map(|(t, tool)| tool.hold(x, v).map(|held| (t, tool, held)))?;
    Some(record_hold(tool, t, x, v, m, &held, impulses))
}

/// Records what holding the node at `x` (velocity `v`, mass `m`) as `held` costs gripper `t`:
/// the impulse, the share along the jaw normal that pushes the jaws apart, and the grip's
/// sums; returns the held velocity.
#[inline(always)]
pub(super) fn record_hold(
    tool: &ToolKinematics,
    t: usize,
    x: Vec3,
    v: Vec3,
    m: f32,
    held: &crate::tools::grip::Held,
    impulses: &mut [ToolImpulse; MAX_TOOLS],
) -> Vec3 {
    let dp = ((v - held.v) * m).cast::<f64>();
    let arm = (x - tool.translation).cast::<f64>();
    let normal = tool.jaw_normal().cast::<f64>();
    let hinge = tool.rotation.column(0).into_owned().cast::<f64>();
    let share = crate::tools::sdf::jaw_angle(held.jaw, 1.0) as f64;
    let imp = &mut impulses[t];
    imp.linear += dp;
    imp.angular += arm.cross(&dp);
    imp.contact_nodes += 1;
    imp.contact_mass += m as f64;
    imp.contact_inertia += m as f64 * arm.norm_squared();
    imp.jaw_opening += share * arm.cross(&(normal * normal.dot(&dp))).dot(&hinge);
    imp.grip.required += (held.required * m).cast::<f64>();
    imp.grip.mass += m as f64;
    imp.grip.mass_lever += (m * held.lever) as f64;
    held.v
}

/// Contact with the nearest tool the node is inside of (seed 000's collision-objects table:
/// one tool per node), recording the impulse the tool receives.
#[inline(always)]
pub(super) fn apply_tools(
    tools: &[ToolKinematics],
    x: Vec3,
    v: Vec3,
    m: f32,
    impulses: &mut [ToolImpulse; MAX_TOOLS],
) -> Vec3 {
    let mut nearest: Option<(usize, crate::tools::NodeContact)> = None;
    for (t, tool) in tools.iter().enumerate() {
        if let Some(hit) = tool.probe(x) {
            if hit.depth < 0.0 && nearest.is_none_or(|(_, best)| hit.depth < best.depth) {
                nearest = Some((t, hit));
            }
        }
    }
    let Some((t, hit)) = nearest else {
        return v;
    };
    let tool = &tools[t];
    let v_tool = tool.surface_velocity(x, hit.part);
    let v_new = contact::resolve(tool.contact, v, v_tool, hit.normal, hit.tangent);
    // Momentum the tool takes from the tissue: the opposite of what it gives the node.
    let dp = ((v - v_new) * m).cast::<f64>();
    record_contact(tool, t, x, hit.part, m, dp, impulses);
    v_new
}

/// Adds the momentum `dp` that tool `t` takes from the node at `x` (mass `m`, touching
/// tool part `part`) to the tool's impulse.
#[inline(always)]
pub(super) fn record_contact(
    tool: &ToolKinematics,
    t: usize,
    x: Vec3,
    part: u8,
    m: f32,
    dp: nalgebra::Vector3<f64>,
    impulses: &mut [ToolImpulse; MAX_TOOLS],
) {
    let arm = (x - tool.translation).cast::<f64>();
    let imp = &mut impulses[t];
    let torque = arm.cross(&dp);
    imp.linear += dp;
    imp.angular += torque;
    imp.contact_nodes += 1;
    imp.contact_mass += m as f64;
    imp.contact_inertia += m as f64 * arm.norm_squared();
    if part != 0 {
        // Jaw k turns by jaw_angle(k, θ) about the hinge (the tool's x axis): the opening θ
        // takes that share of the torque about it.
        let hinge = tool.rotation.column(0).into_owned().cast::<f64>();
        let share = crate::tools::sdf::jaw_angle(part, 1.0) as f64;
        imp.jaw_opening += share * torque.dot(&hinge);
    }
}

/// A node the implicit solve settled in contact with a surface: its velocity at the end of
/// the step, and the tool it touches (index `tool`, part `part`), or an index past the
/// tools for the table or a wall.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SolvedContact {
    pub velocity: Vec3,
    pub tool: u8,
    pub part: u8,
}

/// Table plane and slip walls at the domain faces.
#[inline(always)]
pub(super) fn apply_boundary(
    layout: &GridLayout,
    boundary: &Boundary,
    ijk: [usize; 3],
    x: Vec3,
    mut v: Vec3,
) -> Vec3 {
    if let Some((height, hold)) = boundary.table {
        if x.z <= height + 1e-3 * layout.dx {
            v = match hold {
                TableHold::Bonded => Vec3::zeros(),
                TableHold::Resting { friction } => contact::resolve(
                    contact::ContactModel::Coulomb {
                        friction,
                        drag: 0.0,
                    },
                    v,
                    Vec3::zeros(),
                    Vec3::z(),
                    Vec3::zeros(),
                ),
            };
        }
    }
    for axis in 0..3 {
        let i = ijk[axis] as i32;
        if i < WALL_NODES && v[axis] < 0.0 {
            v[axis] = 0.0;
        }
        if i >= layout.nodes[axis] as i32 - WALL_NODES && v[axis] > 0.0 {
            v[axis] = 0.0;
        }
    }
    v
}
