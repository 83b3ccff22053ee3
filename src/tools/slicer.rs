//! The slicer (seed 002 §IV-B, its `QuadSlicer`): a blade that separates tissue with its
//! edge side and pushes it with its blunt spine.
//!
//! The blade lies in the tool's local xz plane: `length` along x centred on the origin,
//! `height` down from the origin along −z, `thickness` along y. Its spine is the local x
//! axis (where a handle holds it), its cutting edge the line z = −`height`. The spine has grid contact: a cylinder along the spine line (seed 002
//! Fig. 6a–7: a circular distance field on the spine side), fattened like a curve tool so
//! that a spine thinner than a cell still holds a stencil of nodes. The blade's faces and
//! edge have no contact: where the edge passes, particles remember the blade's plane as their
//! crack (see [`crate::mpm::crack`]) and exchange nothing with nodes across it (CPIC, Hu et
//! al. 2018; seed 002 Fig. 6b).

use super::SdfHit;
use crate::math::Vec3;

/// How far (in cells) from the blade plane a particle's stencil reaches: quadratic B-spline
/// nodes lie up to 1.5 cells from the particle along each axis, so up to 1.5·√3 cells along
/// a blade normal that is not aligned with the grid. Particles nearer the plane than this
/// take the blade's plane as their crack when the blade passes them.
pub const STENCIL_REACH_CELLS: f32 = 1.5 * 1.732_050_8;

/// Distance to the spine: a cylinder of radius `thickness`/2 along the local x axis,
/// capped by half spheres at x = ±`length`/2.
pub fn spine(p: Vec3, length: f32, thickness: f32) -> SdfHit {
    let axis_point = Vec3::new(p.x.clamp(-0.5 * length, 0.5 * length), 0.0, 0.0);
    let d = p - axis_point;
    let n = d.norm();
    let normal = if n > 1e-12 { d / n } else { Vec3::z() };
    SdfHit {
        distance: n - 0.5 * thickness,
        normal,
        part: 0,
        tangent: Vec3::zeros(),
    }
}

/// Signed distance (m, along local +y) of a tool-frame point from the blade plane, when the
/// blade's edge is passing it: within the blade's length, nearer the plane than `band`, and
/// at most `band` above the edge. Only the edge cuts: the blade moved sideways or along its
/// plane through tissue it has already cut makes no new crack, and the edge moves less than
/// a cell per substep (CFL), so every particle it passes lies in this strip for a substep.
/// `None` elsewhere.
#[inline(always)]
pub fn edge_passing(p: Vec3, length: f32, height: f32, band: f32) -> Option<f32> {
    let above_edge = p.z + height;
    let covered =
        p.x.abs() <= 0.5 * length && p.y.abs() < band && (0.0..=band).contains(&above_edge);
    covered.then_some(p.y)
}

/// The tool-frame box outside which [`edge_passing`] answers `None` for this `band`: the
/// strip along the edge, least and greatest corner (m).
pub fn cutting_box(length: f32, height: f32, band: f32) -> (Vec3, Vec3) {
    (
        Vec3::new(-0.5 * length, -band, -height),
        Vec3::new(0.5 * length, band, band - height),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spine_is_a_capped_cylinder_on_the_blunt_side() {
        let (l, t) = (0.03, 0.0004);
        // Straight above the spine line.
        let hit = spine(Vec3::new(0.005, 0.0, 0.002), l, t);
        assert!((hit.distance - (0.002 - 0.0002)).abs() < 1e-6, "{hit:?}");
        assert!((hit.normal - Vec3::z()).norm() < 1e-5);
        // Beside the blade near its edge: far from the spine, the edge side has no contact.
        let hit = spine(Vec3::new(0.0, 0.001, -0.019), l, t);
        assert!(hit.distance > 0.018);
        // Beyond the end of the spine: distance to its end point.
        let hit = spine(Vec3::new(0.018, 0.0, 0.0), l, t);
        assert!((hit.distance - (0.003 - 0.0002)).abs() < 1e-6);
    }

    #[test]
    fn only_the_edge_cuts() {
        let (l, h, band) = (0.03, 0.02, 0.003);
        // Just above the edge (z = −0.02), beside the plane.
        assert_eq!(
            edge_passing(Vec3::new(0.0, -0.001, -0.019), l, h, band),
            Some(-0.001)
        );
        // Below the edge: not yet cut; beside the blade's face far above the edge: the
        // face does not cut.
        assert_eq!(
            edge_passing(Vec3::new(0.0, 0.001, -0.021), l, h, band),
            None
        );
        assert_eq!(edge_passing(Vec3::new(0.0, 0.001, -0.01), l, h, band), None);
        // Beyond the blade's length or too far from its plane.
        assert_eq!(
            edge_passing(Vec3::new(0.016, 0.0, -0.019), l, h, band),
            None
        );
        assert_eq!(
            edge_passing(Vec3::new(0.0, 0.004, -0.019), l, h, band),
            None
        );
    }
}
