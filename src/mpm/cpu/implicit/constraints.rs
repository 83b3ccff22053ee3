//! Which velocity components of a grid node tools, the table and the walls prescribe
//! during the implicit solve.
//!
//! A node is classified from v*, its velocity without elasticity, with the explicit grid
//! update's rules (`super::super::update_grid`): a node a gripper holds, a node inside a
//! sticky tool and a node on a bonded table move as prescribed (all three components); an
//! approaching node in Coulomb contact with a solid tool, on a resting table or at a wall
//! has its normal component prescribed (the tool's, zero for table and wall) and slides
//! along the surface, resisted by the surface's friction and drag inside the solve (`slip`).
//! A node that two surfaces act on, a curve tool (which lets through only its tangent) or
//! a drag of 1 prescribes it in full at what the explicit rules give.

use crate::mpm::grid::{Boundary, GridLayout, TableHold, WALL_NODES};
use crate::mpm::{Mat3, Vec3};
use crate::tools::{contact, ContactModel, ToolKinematics};

/// v = free·u + prescribed for the free velocity u: `free` projects onto the components
/// the solve may change, `prescribed` lies in the others.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeConstraint {
    pub free: Mat3,
    pub prescribed: Vec3,
    /// With one prescribed direction: the surface normal, pointing from the tool, table
    /// or wall into the tissue; zero otherwise.
    pub normal: Vec3,
    /// With one prescribed direction: the surface the node slides on.
    pub surface: Surface,
}

/// The surface a node with one prescribed direction slides on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    /// The surface's velocity at the node (m/s).
    pub velocity: Vec3,
    /// Coulomb friction μ and drag (the share of the tangential velocity the explicit
    /// contact takes away, below 1).
    pub friction: f32,
    pub drag: f32,
    /// The tool (index) and tool part the surface belongs to; `NO_TOOL` for the table and
    /// the walls.
    pub tool: u8,
    pub part: u8,
}

/// `Surface::tool` of the table and the walls.
pub const NO_TOOL: u8 = u8::MAX;

impl Surface {
    /// A fixed, frictionless surface (a wall).
    pub fn still() -> Self {
        Surface {
            velocity: Vec3::zeros(),
            friction: 0.0,
            drag: 0.0,
            tool: NO_TOOL,
            part: 0,
        }
    }
}

impl NodeConstraint {
    fn unconstrained() -> Self {
        NodeConstraint {
            free: Mat3::identity(),
            prescribed: Vec3::zeros(),
            normal: Vec3::zeros(),
            surface: Surface::still(),
        }
    }

    fn fixed(v: Vec3) -> Self {
        NodeConstraint {
            free: Mat3::zeros(),
            prescribed: v,
            normal: Vec3::zeros(),
            surface: Surface::still(),
        }
    }

    fn normal(n: Vec3, v: Vec3, surface: Surface) -> Self {
        NodeConstraint {
            free: Mat3::identity() - n * n.transpose(),
            prescribed: n * n.dot(&v),
            normal: n,
            surface,
        }
    }
}

/// The constraint on the node at grid coordinates `ijk` (position `x`) moving at `v_star`.
pub fn node_constraint(
    tools: &[ToolKinematics],
    layout: &GridLayout,
    boundary: &Boundary,
    ijk: [usize; 3],
    x: Vec3,
    v_star: Vec3,
) -> NodeConstraint {
    if let Some(held) = tools.iter().find_map(|t| t.hold(x, v_star)) {
        return NodeConstraint::fixed(held.v);
    }
    // Normals of the surfaces the node pushes against, and the velocity the explicit rules
    // leave it with.
    let mut normals: [Vec3; 4] = [Vec3::zeros(); 4];
    let mut surface = Surface::still();
    let mut count = 0;
    let mut v = v_star;
    let mut nearest: Option<(usize, crate::tools::NodeContact)> = None;
    for (t, tool) in tools.iter().enumerate() {
        if let Some(hit) = tool.probe(x) {
            if hit.depth < 0.0 && nearest.is_none_or(|(_, best)| hit.depth < best.depth) {
                nearest = Some((t, hit));
            }
        }
    }
    if let Some((t, hit)) = nearest {
        let tool = &tools[t];
        let v_tool = tool.surface_velocity(x, hit.part);
        match tool.contact {
            ContactModel::Sticky => return NodeConstraint::fixed(v_tool),
            ContactModel::Coulomb { friction, drag } => {
                if (v - v_tool).dot(&hit.normal) < 0.0 {
                    v = contact::resolve(tool.contact, v, v_tool, hit.normal, hit.tangent);
                    if hit.tangent.norm_squared() > 0.0 || drag >= 1.0 {
                        return NodeConstraint::fixed(v);
                    }
                    normals[count] = hit.normal;
                    surface = Surface {
                        velocity: v_tool,
                        friction,
                        drag,
                        tool: t as u8,
                        part: hit.part,
                    };
                    count += 1;
                }
            }
        }
    }
    if let Some((height, hold)) = boundary.table {
        if x.z <= height + 1e-3 * layout.dx {
            match hold {
                TableHold::Bonded => return NodeConstraint::fixed(Vec3::zeros()),
                TableHold::Resting { friction } => {
                    if v.z < 0.0 {
                        v.z = 0.0;
                        normals[count] = Vec3::z();
                        if count == 0 {
                            surface = Surface {
                                friction,
                                ..Surface::still()
                            };
                        }
                        count += 1;
                    }
                }
            }
        }
    }
    for axis in 0..3 {
        let i = ijk[axis] as i32;
        let low = i < WALL_NODES && v[axis] < 0.0;
        let high = i >= layout.nodes[axis] as i32 - WALL_NODES && v[axis] > 0.0;
        if low || high {
            v[axis] = 0.0;
            normals[count] = Vec3::ith(axis, if low { 1.0 } else { -1.0 });
            count += 1;
        }
    }
    match count {
        0 => NodeConstraint::unconstrained(),
        1 => NodeConstraint::normal(normals[0], v, surface),
        _ => NodeConstraint::fixed(v),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn walls_prescribe_the_outward_component_only() {
        let layout = GridLayout::new(Vec3::zeros(), Vec3::new(0.02, 0.02, 0.02), 0.001);
        let boundary = Boundary { table: None };
        let x = layout.node_position([0, 10, 10]);
        let c = node_constraint(
            &[],
            &layout,
            &boundary,
            [0, 10, 10],
            x,
            Vec3::new(-1.0, 2.0, 3.0),
        );
        assert_eq!(c.free * Vec3::new(5.0, 2.0, 3.0), Vec3::new(0.0, 2.0, 3.0));
        assert_eq!(c.prescribed, Vec3::zeros());
        // Moving away from the wall: free.
        let c = node_constraint(
            &[],
            &layout,
            &boundary,
            [0, 10, 10],
            x,
            Vec3::new(1.0, 0.0, 0.0),
        );
        assert_eq!(c, NodeConstraint::unconstrained());
        // A corner against two walls: prescribed in full.
        let c = node_constraint(
            &[],
            &layout,
            &boundary,
            [0, 0, 10],
            x,
            Vec3::new(-1.0, -1.0, 1.0),
        );
        assert_eq!(c.free, Mat3::zeros());
        assert_eq!(c.prescribed, Vec3::new(0.0, 0.0, 1.0));
    }

    #[test]
    fn a_bonded_table_holds_the_node() {
        let layout = GridLayout::new(Vec3::zeros(), Vec3::new(0.02, 0.02, 0.02), 0.001);
        let boundary = Boundary {
            table: Some((0.005, TableHold::Bonded)),
        };
        let x = layout.node_position([10, 10, 5]);
        let c = node_constraint(
            &[],
            &layout,
            &boundary,
            [10, 10, 5],
            x,
            Vec3::new(1.0, 1.0, 1.0),
        );
        assert_eq!(c, NodeConstraint::fixed(Vec3::zeros()));
    }
}
