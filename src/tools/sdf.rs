//! Signed distance functions of rigid tool shapes, in the tool's own frame.
//!
//! Each returns the distance to the surface (negative inside), the outward unit normal, and
//! which part of the tool is nearest (a gripper has two jaws that move differently). 1D
//! shapes (the arc needle) also return the unit tangent of the curve at the nearest point.

use super::mesh_slicer::BladeFile;
use crate::math::Vec3;
use serde::{Deserialize, Serialize};

/// Tool geometry. Lengths in metres, angles in radians unless the name says otherwise.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Shape {
    /// A sphere centred on the tool origin.
    Sphere {
        /// Radius, m.
        radius: f32,
    },
    /// Segment along local z from −half_length to +half_length, swept by a sphere.
    Capsule {
        /// Radius of the swept sphere, m.
        radius: f32,
        /// Half the axis segment's length, m.
        half_length: f32,
    },
    /// A box centred on the tool origin, axis-aligned in the tool frame.
    Box {
        /// Half the box's size along local x, y, z, m.
        half_extents: [f32; 3],
    },
    /// Two jaws hinged on the local x axis at the origin, pointing along +z; the opening angle
    /// (the arm's jaw joint) rotates jaw 1 towards +y and jaw 2 towards −y by half of it each.
    Gripper {
        /// Jaw length from the hinge along +z, m.
        jaw_length: f32,
        /// Jaw width along local x, m.
        jaw_width: f32,
        /// Jaw thickness along local y, m.
        jaw_thickness: f32,
    },
    /// Circular arc in the local xy plane centred on the origin, from angle 0 to `arc_angle`
    /// (counter-clockwise about +z), swept by a wire of `wire_radius`.
    Needle {
        /// Arc radius (origin to the wire's centre line), m.
        radius: f32,
        /// Angle the arc spans, rad.
        arc_angle: f32,
        /// Radius of the wire, m.
        wire_radius: f32,
    },
    /// A blade (seed 002's quad slicer) in the local xz plane: `length` along x centred on
    /// the origin, `height` down along −z, `thickness` along y; the blunt spine is the local
    /// x axis, the cutting edge the line z = −height. Only the spine has contact (see
    /// [`crate::tools::slicer`]).
    Slicer {
        /// Blade length along local x, m.
        length: f32,
        /// Blade height from the spine down to the cutting edge, m.
        height: f32,
        /// Blade thickness along local y, m.
        thickness: f32,
    },
    /// A blade from a triangle mesh file (seed 002's triangle-mesh slicer): its surface,
    /// spine and cutting edge come from the OBJ `file` (tool frame, see
    /// [`crate::tools::mesh_slicer`]); `thickness` is the spine's, as for the quad.
    MeshSlicer {
        /// The blade's mesh file (path as written in the scene).
        file: BladeFile,
        /// Thickness of the blunt spine, m.
        thickness: f32,
    },
}

/// Result of one SDF query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SdfHit {
    /// Signed distance from the surface, m (negative inside the tool).
    pub distance: f32,
    /// Outward unit normal (tool frame).
    pub normal: Vec3,
    /// Part of the tool: 0 for one-piece shapes, 1 and 2 for gripper jaws.
    pub part: u8,
    /// Unit tangent of a 1D shape at the nearest point (tool frame); zero otherwise.
    pub tangent: Vec3,
}

impl SdfHit {
    fn solid(distance: f32, normal: Vec3, part: u8) -> Self {
        SdfHit {
            distance,
            normal,
            part,
            tangent: Vec3::zeros(),
        }
    }
}

/// Rotation of each gripper jaw about the hinge (local x), relative to the tool frame, for a
/// total opening `opening`: jaw 1 at −opening/2 (its tip goes to +y), jaw 2 at +opening/2.
#[inline(always)]
pub fn jaw_angle(part: u8, opening: f32) -> f32 {
    if part == 1 {
        -0.5 * opening
    } else {
        0.5 * opening
    }
}

#[inline(always)]
pub(crate) fn rotate_x(p: Vec3, angle: f32) -> Vec3 {
    let (s, c) = angle.sin_cos();
    Vec3::new(p.x, c * p.y - s * p.z, s * p.y + c * p.z)
}

/// Unit vector along `v`, or `fallback` when `v` is (nearly) zero.
#[inline(always)]
fn unit_or(v: Vec3, fallback: Vec3) -> Vec3 {
    let n = v.norm();
    if n > 1e-12 {
        v / n
    } else {
        fallback
    }
}

pub(crate) fn sphere(p: Vec3, radius: f32) -> SdfHit {
    SdfHit::solid(p.norm() - radius, unit_or(p, Vec3::z()), 0)
}

pub(crate) fn capsule(p: Vec3, radius: f32, half_length: f32) -> SdfHit {
    let axis_point = Vec3::new(0.0, 0.0, p.z.clamp(-half_length, half_length));
    let d = p - axis_point;
    let fallback = if p.z >= 0.0 { Vec3::z() } else { -Vec3::z() };
    SdfHit::solid(d.norm() - radius, unit_or(d, fallback), 0)
}

pub(crate) fn cuboid(p: Vec3, half: Vec3) -> SdfHit {
    let q = p.abs() - half;
    let sign = p.map(|c| if c < 0.0 { -1.0 } else { 1.0 });
    let outside = q.map(|c| c.max(0.0));
    if outside.norm_squared() > 0.0 {
        let n = outside.component_mul(&sign);
        SdfHit::solid(outside.norm(), n / n.norm(), 0)
    } else {
        // Inside: the nearest face is the one with the largest (least negative) q.
        let axis = q.imax();
        let mut n = Vec3::zeros();
        n[axis] = sign[axis];
        SdfHit::solid(q[axis], n, 0)
    }
}

pub(crate) fn gripper(p: Vec3, opening: f32, length: f32, width: f32, thickness: f32) -> SdfHit {
    let half = Vec3::new(0.5 * width, 0.5 * thickness, 0.5 * length);
    let mut best = SdfHit::solid(f32::INFINITY, Vec3::z(), 1);
    for part in [1u8, 2u8] {
        let angle = jaw_angle(part, opening);
        // Into the jaw frame (inverse rotation), then relative to the jaw box centre; closed
        // jaws meet on the y = 0 plane.
        let in_jaw = rotate_x(p, -angle);
        let side = if part == 1 { 1.0 } else { -1.0 };
        let centre = Vec3::new(0.0, side * 0.5 * thickness, 0.5 * length);
        let hit = cuboid(in_jaw - centre, half);
        if hit.distance < best.distance {
            best = SdfHit::solid(hit.distance, rotate_x(hit.normal, angle), part);
        }
    }
    best
}

pub(crate) fn needle(p: Vec3, radius: f32, arc_angle: f32, wire_radius: f32) -> SdfHit {
    let phi = p.y.atan2(p.x);
    let phi = if phi < 0.0 {
        phi + std::f32::consts::TAU
    } else {
        phi
    };
    // Nearest point on the arc: the radial projection when inside the arc's angular span,
    // otherwise whichever end is closer.
    let on_arc = |a: f32| Vec3::new(radius * a.cos(), radius * a.sin(), 0.0);
    let angle = if phi <= arc_angle {
        phi
    } else {
        let end = on_arc(arc_angle);
        let start = on_arc(0.0);
        if (p - end).norm_squared() < (p - start).norm_squared() {
            arc_angle
        } else {
            0.0
        }
    };
    let nearest = on_arc(angle);
    let tangent = Vec3::new(-angle.sin(), angle.cos(), 0.0);
    let d = p - nearest;
    // On the centre line itself any direction normal to the tangent will do.
    let normal = unit_or(d, Vec3::new(angle.cos(), angle.sin(), 0.0));
    SdfHit {
        distance: d.norm() - wire_radius,
        normal,
        part: 0,
        tangent,
    }
}

impl Shape {
    /// Distance query in the tool frame; `opening` is the gripper's jaw angle (rad).
    pub fn query(&self, p: Vec3, opening: f32) -> SdfHit {
        match *self {
            Shape::Sphere { radius } => sphere(p, radius),
            Shape::Capsule {
                radius,
                half_length,
            } => capsule(p, radius, half_length),
            Shape::Box { half_extents } => cuboid(p, Vec3::from(half_extents)),
            Shape::Gripper {
                jaw_length,
                jaw_width,
                jaw_thickness,
            } => gripper(p, opening, jaw_length, jaw_width, jaw_thickness),
            Shape::Needle {
                radius,
                arc_angle,
                wire_radius,
            } => needle(p, radius, arc_angle, wire_radius),
            Shape::Slicer {
                length, thickness, ..
            } => super::slicer::spine(p, length, thickness),
            Shape::MeshSlicer { file, thickness } => file.mesh().spine_distance(p, thickness),
        }
    }

    /// Radius of a sphere about the tool origin that contains the whole shape at any jaw
    /// opening (for bounding boxes).
    pub fn bounding_radius(&self) -> f32 {
        match *self {
            Shape::Sphere { radius } => radius,
            Shape::Capsule {
                radius,
                half_length,
            } => radius + half_length,
            Shape::Box { half_extents } => Vec3::from(half_extents).norm(),
            Shape::Gripper {
                jaw_length,
                jaw_width,
                jaw_thickness,
            } => Vec3::new(0.5 * jaw_width, jaw_thickness, jaw_length).norm(),
            Shape::Needle {
                radius,
                wire_radius,
                ..
            } => radius + wire_radius,
            Shape::Slicer {
                length,
                height,
                thickness,
            } => Vec3::new(0.5 * length, 0.5 * thickness, height).norm() + thickness,
            Shape::MeshSlicer { file, thickness } => file.mesh().bounding_radius() + thickness,
        }
    }

    /// Thinnest dimension of a solid shape (m); `None` for curve shapes and the slicer's
    /// spine, which contact fattens instead.
    pub fn solid_thickness(&self) -> Option<f32> {
        match *self {
            Shape::Sphere { radius } | Shape::Capsule { radius, .. } => Some(2.0 * radius),
            Shape::Box { half_extents } => {
                Some(2.0 * half_extents.iter().fold(f32::INFINITY, |a, &b| a.min(b)))
            }
            Shape::Gripper {
                jaw_thickness,
                jaw_width,
                ..
            } => Some(jaw_thickness.min(jaw_width)),
            Shape::Needle { .. } | Shape::Slicer { .. } | Shape::MeshSlicer { .. } => None,
        }
    }

    /// A needle's swage end, where a thread is fixed to it, and the direction a thread leaves
    /// it in (continuing the arc past its end), both in the tool frame; `None` for the other
    /// shapes. The tip is the arc's other end, at angle 0.
    pub fn swage_end(&self) -> Option<(Vec3, Vec3)> {
        let Shape::Needle {
            radius, arc_angle, ..
        } = *self
        else {
            return None;
        };
        let (sin, cos) = arc_angle.sin_cos();
        Some((
            Vec3::new(radius * cos, radius * sin, 0.0),
            Vec3::new(-sin, cos, 0.0),
        ))
    }

    /// Whether the shape cuts tissue (a slicer of either kind).
    pub fn cuts(&self) -> bool {
        matches!(self, Shape::Slicer { .. } | Shape::MeshSlicer { .. })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f32, b: f32) -> bool {
        (a - b).abs() < 1e-5
    }

    fn close_v(a: Vec3, b: Vec3) -> bool {
        (a - b).norm() < 1e-5
    }

    #[test]
    fn sphere_distance_and_normal() {
        let h = sphere(Vec3::new(0.0, 3.0, 4.0), 2.0);
        assert!(close(h.distance, 3.0));
        assert!(close_v(h.normal, Vec3::new(0.0, 0.6, 0.8)));
        let h = sphere(Vec3::new(0.5, 0.0, 0.0), 2.0);
        assert!(close(h.distance, -1.5));
        assert!(close_v(h.normal, Vec3::x()));
    }

    #[test]
    fn capsule_distance_and_normal() {
        // Beside the segment: radial distance.
        let h = capsule(Vec3::new(3.0, 0.0, 0.5), 1.0, 2.0);
        assert!(close(h.distance, 2.0) && close_v(h.normal, Vec3::x()));
        // Beyond the end cap: distance to the end point.
        let h = capsule(Vec3::new(0.0, 3.0, 6.0), 1.0, 2.0);
        assert!(close(h.distance, 4.0));
        assert!(close_v(h.normal, Vec3::new(0.0, 0.6, 0.8)));
    }

    #[test]
    fn box_distance_and_normal() {
        let half = Vec3::new(1.0, 2.0, 3.0);
        // Face region.
        let h = cuboid(Vec3::new(0.2, 4.0, 0.0), half);
        assert!(close(h.distance, 2.0) && close_v(h.normal, Vec3::y()));
        // Edge region: distance to the edge.
        let h = cuboid(Vec3::new(4.0, -6.0, 0.0), half);
        assert!(close(h.distance, 5.0));
        assert!(close_v(h.normal, Vec3::new(0.6, -0.8, 0.0)));
        // Inside: distance to the nearest face, normal through it.
        let h = cuboid(Vec3::new(0.0, 0.0, -2.5), half);
        assert!(close(h.distance, -0.5) && close_v(h.normal, -Vec3::z()));
    }

    #[test]
    fn gripper_jaws_open_symmetrically() {
        let (len, w, t) = (0.01, 0.004, 0.002);
        let opening = std::f32::consts::FRAC_PI_2;
        // Tip of jaw 1's inner face: rotated from (0, 0, len) by −opening/2 about x.
        let tip1 = rotate_x(Vec3::new(0.0, 0.0, len), jaw_angle(1, opening));
        assert!(tip1.y > 0.0);
        let h = gripper(tip1 * 0.5, opening, len, w, t);
        assert_eq!(h.part, 1);
        assert!(
            h.distance.abs() < 1e-6,
            "on jaw 1's inner face: {}",
            h.distance
        );
        // Its normal points away from jaw 1, towards the gap between the jaws.
        let expected_n = rotate_x(-Vec3::y(), jaw_angle(1, opening));
        assert!(close_v(h.normal, expected_n));
        // Mirror point belongs to jaw 2.
        let h2 = gripper(Vec3::new(0.0, -tip1.y, tip1.z) * 0.5, opening, len, w, t);
        assert_eq!(h2.part, 2);
        assert!(h2.distance.abs() < 1e-6);
        // On the axis between open jaws: outside both.
        assert!(gripper(Vec3::new(0.0, 0.0, 0.008), opening, len, w, t).distance > 0.0);
        // Closed jaws: a point between them along the midplane is inside.
        assert!(gripper(Vec3::new(0.0, 0.0005, 0.005), 0.0, len, w, t).distance < 0.0);
    }

    #[test]
    fn the_swage_end_is_the_arc_end_opposite_the_tip_and_the_thread_leaves_along_the_arc() {
        let (r, arc, wire) = (0.01, 0.75 * std::f32::consts::PI, 0.0005);
        let needle = Shape::Needle {
            radius: r,
            arc_angle: arc,
            wire_radius: wire,
        };
        let (end, leaving) = needle.swage_end().unwrap();
        assert!(close_v(end, Vec3::new(r * arc.cos(), r * arc.sin(), 0.0)));
        // On the wire's centre line, and the tip (angle 0) is the other end.
        assert!(close(needle.query(end, 0.0).distance, -wire));
        assert!((end - Vec3::new(r, 0.0, 0.0)).norm() > r);
        // Leaving along the arc's tangent, away from the needle: a step out is off the wire.
        assert!(close(leaving.dot(&end), 0.0) && close(leaving.norm(), 1.0));
        assert!(needle.query(end + leaving * 2.0 * wire, 0.0).distance > 0.0);
        assert!(needle.query(end - leaving * 2.0 * wire, 0.0).distance < 0.0);
        assert!(Shape::Sphere { radius: r }.swage_end().is_none());
    }

    #[test]
    fn needle_distance_normal_and_tangent() {
        let (r, arc, wire) = (0.01, std::f32::consts::PI, 0.0005);
        // Outside the ring at 90°: radial distance, tangent along −x.
        let h = needle(Vec3::new(0.0, 0.012, 0.0), r, arc, wire);
        assert!(close(h.distance, 0.002 - wire));
        assert!(close_v(h.normal, Vec3::y()));
        assert!(close_v(h.tangent, -Vec3::x()));
        // Above the plane at 0°: distance straight up.
        let h = needle(Vec3::new(0.01, 0.0, 0.003), r, arc, wire);
        assert!(close(h.distance, 0.003 - wire) && close_v(h.normal, Vec3::z()));
        // Beyond the arc's end (angle 270°): nearest is an end point.
        let h = needle(Vec3::new(0.0, -0.01, 0.0), r, arc, wire);
        let to_start = (Vec3::new(0.0, -0.01, 0.0) - Vec3::new(0.01, 0.0, 0.0)).norm();
        assert!(close(h.distance, to_start - wire));
    }
}
