//! Grid-node contact between tissue and a rigid tool (seed 000 eqs. 15–19, seed 002 eqs.
//! 17–19).
//!
//! Velocities are taken relative to the tool's surface velocity at the node. A node moving
//! away from the tool is left alone; an approaching node loses its normal component and its
//! tangential component is reduced by Coulomb friction, then scaled by `1 − drag`. Curve
//! tools (the arc needle) keep only the component along their own tangent. Sticky contact
//! (grips, bonded fixtures) matches the tool velocity exactly.

use crate::math::Vec3;
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case", deny_unknown_fields)]
pub enum ContactModel {
    /// Coulomb friction `friction` (μ) and drag in [0, 1]: seed 002's c_d is `1 − drag`.
    Coulomb {
        #[serde(default = "default_friction")]
        friction: f32,
        #[serde(default)]
        drag: f32,
    },
    /// Nodes in contact move with the tool, approaching or not (clamps, grips).
    Sticky,
}

fn default_friction() -> f32 {
    0.3
}

impl Default for ContactModel {
    fn default() -> Self {
        ContactModel::Coulomb {
            friction: default_friction(),
            drag: 0.0,
        }
    }
}

/// New world velocity of a node in contact.
///
/// `normal` points out of the tool. `tangent` is the unit tangent of a curve tool, zero for
/// solid tools.
#[inline(always)]
pub fn resolve(
    model: ContactModel,
    v_node: Vec3,
    v_tool: Vec3,
    normal: Vec3,
    tangent: Vec3,
) -> Vec3 {
    let (friction, drag) = match model {
        ContactModel::Sticky => return v_tool,
        ContactModel::Coulomb { friction, drag } => (friction, drag),
    };
    let v_rel = v_node - v_tool;
    let v_n = v_rel.dot(&normal);
    if v_n >= 0.0 {
        return v_node;
    }
    let is_curve = tangent.norm_squared() > 0.0;
    // The part of the relative velocity the tool lets through: everything tangential for a
    // solid, only the component along the curve for a needle (eq. 19).
    let v_t = if is_curve {
        tangent * v_rel.dot(&tangent)
    } else {
        v_rel - v_n * normal
    };
    let v_t_norm = v_t.norm();
    if v_t_norm <= 1e-12 {
        return v_tool;
    }
    // Coulomb: the tangential speed drops by μ·|v_n| (v_n ≤ 0 when approaching), never past
    // zero (eq. 18 with the sign of an approaching node).
    let approach = v_n.min(0.0);
    let scale = (1.0 + friction * approach / v_t_norm).max(0.0) * (1.0 - drag);
    v_tool + v_t * scale
}

#[cfg(test)]
mod tests {
    use super::*;

    const N: Vec3 = Vec3::new(0.0, 0.0, 1.0);

    fn coulomb(mu: f32) -> ContactModel {
        ContactModel::Coulomb {
            friction: mu,
            drag: 0.0,
        }
    }

    #[test]
    fn separating_nodes_are_untouched() {
        let v = Vec3::new(0.3, -0.2, 0.5);
        assert_eq!(resolve(coulomb(0.5), v, Vec3::zeros(), N, Vec3::zeros()), v);
        // Relative to a tool moving down faster than the node, the node separates too.
        let v = Vec3::new(0.1, 0.0, -0.1);
        assert_eq!(
            resolve(coulomb(0.5), v, Vec3::new(0.0, 0.0, -0.4), N, Vec3::zeros()),
            v
        );
    }

    #[test]
    fn approaching_node_loses_normal_velocity_and_slides_inside_friction_cone() {
        // Tangential 1.0, normal −0.5, μ 0.4: tangential speed reduced by 0.2.
        let out = resolve(
            coulomb(0.4),
            Vec3::new(1.0, 0.0, -0.5),
            Vec3::zeros(),
            N,
            Vec3::zeros(),
        );
        assert!((out - Vec3::new(0.8, 0.0, 0.0)).norm() < 1e-6, "{out}");
        // Inside the cone (μ|v_n| ≥ |v_t|): the node sticks to the tool.
        let v_tool = Vec3::new(0.0, 0.2, 0.1);
        let out = resolve(
            coulomb(0.4),
            v_tool + Vec3::new(0.1, 0.0, -0.5),
            v_tool,
            N,
            Vec3::zeros(),
        );
        assert!((out - v_tool).norm() < 1e-6, "{out}");
        // Frictionless: tangential velocity kept exactly.
        let out = resolve(
            coulomb(0.0),
            Vec3::new(0.7, -0.3, -2.0),
            Vec3::zeros(),
            N,
            Vec3::zeros(),
        );
        assert!((out - Vec3::new(0.7, -0.3, 0.0)).norm() < 1e-6);
    }

    #[test]
    fn drag_scales_the_tangential_part() {
        let model = ContactModel::Coulomb {
            friction: 0.0,
            drag: 0.25,
        };
        let out = resolve(
            model,
            Vec3::new(1.0, 0.0, -0.5),
            Vec3::zeros(),
            N,
            Vec3::zeros(),
        );
        assert!((out - Vec3::new(0.75, 0.0, 0.0)).norm() < 1e-6);
    }

    #[test]
    fn needle_keeps_only_the_tangent_component() {
        let tangent = Vec3::x();
        let normal = Vec3::z();
        // Relative velocity with parts along the tangent, the normal and the binormal (y).
        let v_tool = Vec3::new(0.0, 0.0, 0.0);
        let out = resolve(
            coulomb(0.0),
            Vec3::new(0.4, 0.3, -0.2),
            v_tool,
            normal,
            tangent,
        );
        assert!((out - Vec3::new(0.4, 0.0, 0.0)).norm() < 1e-6, "{out}");
        // Pushed sideways (binormal and normal), an approaching node is dragged along.
        let v_needle = Vec3::new(0.0, 0.3, 0.2);
        let out = resolve(coulomb(0.0), Vec3::zeros(), v_needle, normal, tangent);
        assert!((out - v_needle).norm() < 1e-6, "{out}");
        // Moving the needle along itself leaves still tissue still.
        let v_needle = Vec3::new(0.05, 0.0, 0.0);
        let out = resolve(coulomb(0.0), Vec3::zeros(), v_needle, normal, tangent);
        assert!(out.norm() < 1e-6, "{out}");
    }

    #[test]
    fn sticky_matches_the_tool() {
        let v_tool = Vec3::new(0.01, 0.02, 0.03);
        let out = resolve(
            ContactModel::Sticky,
            Vec3::new(1.0, 1.0, 1.0),
            v_tool,
            N,
            Vec3::zeros(),
        );
        assert_eq!(out, v_tool);
    }
}
