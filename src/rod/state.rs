//! The rod's state: centreline points (positions, velocities, inverse masses) and one frame
//! quaternion per segment (orientation, angular velocity, inverse rotational inertia), with
//! the rest shape the elastic constraints return to.

use super::material::ThreadMaterial;
use crate::math::{Mat3d, Vec3};
use nalgebra::{Quaternion, UnitQuaternion};

/// Frame quaternions are kept unit length by the solver; stored raw so that the constraint
/// projections can add to them before renormalising.
pub type Quat = Quaternion<f32>;

/// A discrete Cosserat rod of `segments()` segments and `segments() + 1` points. Segment `j`
/// joins points `j` and `j + 1`; its frame's third director d3 = q·e3·q̄ follows the segment.
#[derive(Clone, Debug)]
pub struct Rod {
    /// Radius, stiffness and density of the thread.
    pub material: ThreadMaterial,
    /// Centreline points, world frame, m.
    pub points: Vec<Vec3>,
    /// Point velocities, world frame, m/s.
    pub velocities: Vec<Vec3>,
    /// 1/m per point; 0 pins the point (held by the world or a grasp).
    pub inv_mass: Vec<f32>,
    /// Orientation of each segment's material frame (world from segment), unit quaternion.
    pub frames: Vec<Quat>,
    /// World-frame angular velocity per segment (rad/s).
    pub angular_velocities: Vec<Vec3>,
    /// 1/I per segment (isotropic); 0 clamps the frame.
    pub inv_inertia: Vec<f32>,
    /// Rest length of each segment, m.
    pub rest_lengths: Vec<f32>,
    /// Rest Darboux quaternion q̄ⱼ·qⱼ₊₁ of the rest shape, one per interior joint.
    pub rest_darboux: Vec<Quat>,
    /// External force per point (N), applied each substep (a pull, a drag); gravity is the
    /// solver's.
    pub external_forces: Vec<Vec3>,
    /// Axial force per segment from the last substep's distance multipliers (N, + = tension).
    pub tension: Vec<f32>,
    /// Tissue bound to each point across the thread (one per point, or empty for none): the
    /// world sets it for a tissue substep where the thread runs through tissue (see
    /// [`crate::mpm::cpu::thread_contact`]).
    pub bindings: Vec<Binding>,
}

/// Tissue a point carries: across `axis` the point moves with `mass` added to its own,
/// along it with `along_mass` (the thread slides along its channel through the tissue, freely
/// with none, but cannot leave it sideways without taking the tissue along).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Binding {
    /// The thread's direction at the point, unit.
    pub axis: Vec3,
    /// The tissue's mass bound to the point across the thread, kg; 0 for none.
    pub mass: f32,
    /// The tissue's mass bound to the point along the thread, kg (at most `mass`).
    pub along_mass: f32,
}

impl Binding {
    /// The part of `v` along the axis.
    pub fn along(&self, v: Vec3) -> Vec3 {
        self.axis * self.axis.dot(&v)
    }
}

impl Rod {
    /// Point `i`'s inverse mass as a matrix: 1/(m + M_along) along its binding's axis and
    /// 1/(m + M) across it where tissue is bound to it (see [`Binding`]), 1/m·I otherwise; 0
    /// for a held point.
    pub fn inverse_mass_matrix(&self, i: usize) -> Mat3d {
        let w = self.inv_mass[i] as f64;
        match self.bindings.get(i) {
            Some(b) if b.mass > 0.0 && w > 0.0 => {
                let t = b.axis.cast::<f64>();
                let along = t * t.transpose();
                let w_across = 1.0 / (1.0 / w + b.mass as f64);
                let w_along = 1.0 / (1.0 / w + b.along_mass as f64);
                along * w_along + (Mat3d::identity() - along) * w_across
            }
            _ => Mat3d::identity() * w,
        }
    }

    /// Whether point `i` carries tissue across the thread (see [`Binding`]).
    pub fn is_bound(&self, i: usize) -> bool {
        self.inv_mass[i] > 0.0 && self.bindings.get(i).is_some_and(|b| b.mass > 0.0)
    }

    /// A straight rod from `start` along `direction` of `length`, split into `segments` equal
    /// segments, at rest in that shape.
    pub fn straight(
        material: ThreadMaterial,
        start: Vec3,
        direction: Vec3,
        length: f32,
        segments: usize,
    ) -> Rod {
        let axis = direction.normalize();
        let points = (0..=segments)
            .map(|i| start + axis * (length * i as f32 / segments as f32))
            .collect::<Vec<_>>();
        Rod::from_polyline(material, points)
    }

    /// A rod through `points`, at rest in that shape (its bends and lengths are the rest
    /// state). Frames have d3 along each segment, carried from one segment to the next by
    /// the smallest rotation so that the rod starts untwisted.
    pub fn from_polyline(material: ThreadMaterial, points: Vec<Vec3>) -> Rod {
        assert!(points.len() >= 2, "a rod needs at least one segment");
        let segments = points.len() - 1;
        let rest_lengths: Vec<f32> = points.windows(2).map(|w| (w[1] - w[0]).norm()).collect();
        let mut frames = Vec::with_capacity(segments);
        let mut frame = UnitQuaternion::identity();
        for w in points.windows(2) {
            let tangent = (w[1] - w[0]).normalize();
            let d3 = frame * Vec3::z();
            let turn = UnitQuaternion::rotation_between(&d3, &tangent).unwrap_or_else(|| {
                // Antiparallel: half a turn about any axis normal to d3.
                let normal = d3
                    .cross(&Vec3::x())
                    .try_normalize(1e-6)
                    .unwrap_or(Vec3::y());
                UnitQuaternion::from_axis_angle(
                    &nalgebra::Unit::new_normalize(normal),
                    std::f32::consts::PI,
                )
            });
            frame = turn * frame;
            frames.push(*frame.quaternion());
        }
        let rest_darboux = frames.windows(2).map(|w| w[0].conjugate() * w[1]).collect();
        let linear_density = material.linear_density();
        let mut inv_mass = vec![0.0; segments + 1];
        let mut inv_inertia = Vec::with_capacity(segments);
        for (j, &l) in rest_lengths.iter().enumerate() {
            let m = linear_density * l;
            inv_mass[j] += 0.5 * m;
            inv_mass[j + 1] += 0.5 * m;
            // Isotropic inertia of the segment about its centre (the bending axes' value):
            // twist inertia is πr⁴ smaller, a rate no 60 Hz frame resolves, so the statics are
            // unchanged and the solver stays well conditioned.
            let r = material.radius;
            inv_inertia.push(1.0 / (m * (r * r / 4.0 + l * l / 12.0)));
        }
        for w in &mut inv_mass {
            *w = 1.0 / *w;
        }
        Rod {
            material,
            velocities: vec![Vec3::zeros(); points.len()],
            external_forces: vec![Vec3::zeros(); points.len()],
            points,
            inv_mass,
            angular_velocities: vec![Vec3::zeros(); segments],
            frames,
            inv_inertia,
            tension: vec![0.0; segments],
            bindings: Vec::new(),
            rest_lengths,
            rest_darboux,
        }
    }

    /// Number of segments (one less than the points).
    pub fn segments(&self) -> usize {
        self.rest_lengths.len()
    }

    /// Total rest length, m.
    pub fn rest_length(&self) -> f32 {
        self.rest_lengths.iter().sum()
    }

    /// Current centreline length.
    pub fn length(&self) -> f32 {
        self.points.windows(2).map(|w| (w[1] - w[0]).norm()).sum()
    }

    /// Strain of segment `j` (current over rest length, minus one).
    pub fn strain(&self, j: usize) -> f32 {
        (self.points[j + 1] - self.points[j]).norm() / self.rest_lengths[j] - 1.0
    }

    /// Third director (the frame's tangent) of segment `j`.
    pub fn director(&self, j: usize) -> Vec3 {
        rotate_z(&self.frames[j])
    }

    /// Hold point `i` where it is (a fixed end, a grasp): it no longer moves by itself.
    pub fn pin_point(&mut self, i: usize) {
        self.inv_mass[i] = 0.0;
        self.velocities[i] = Vec3::zeros();
    }

    /// Clamp segment `j`'s frame (a built-in end).
    pub fn clamp_frame(&mut self, j: usize) {
        self.inv_inertia[j] = 0.0;
        self.angular_velocities[j] = Vec3::zeros();
    }

    /// Every point, velocity and frame finite.
    pub fn is_finite(&self) -> bool {
        self.points
            .iter()
            .chain(&self.velocities)
            .all(|v| v.iter().all(|c| c.is_finite()))
            && self
                .frames
                .iter()
                .all(|q| q.coords.iter().all(|c| c.is_finite()))
    }
}

/// q·e3·q̄ without forming the rotation matrix.
#[inline]
pub fn rotate_z(q: &Quat) -> Vec3 {
    let (w, x, y, z) = (q.w, q.i, q.j, q.k);
    Vec3::new(
        2.0 * (x * z + w * y),
        2.0 * (y * z - w * x),
        w * w - x * x - y * y + z * z,
    )
}

/// Rotate `q` by the small world-frame rotation vector `dtheta` (q ← q + ½·dθ·q) and
/// renormalise.
#[inline]
pub fn add_rotation(q: &mut Quat, dtheta: Vec3) {
    let dq = Quaternion::new(0.0, dtheta.x, dtheta.y, dtheta.z) * *q;
    *q += dq * 0.5;
    let n = q.norm();
    *q /= n;
}
