//! What keeps a thread out of the world's fixed bodies: the table plane (with Coulomb
//! friction) and the domain's walls.
//!
//! The table and walls are projected once per solver iteration after the elastic constraints
//! (the solver's `contacts` hook); friction acts once per substep on the velocities (Macklin
//! et al. 2019's small steps): a point resting on the table received a normal impulse per
//! unit mass Δv_n = v_z(after) − (v_z(before) + g_z·h) from it, and its sliding speed drops by
//! μ·Δv_n, to rest when less. Friction as a position correction inside the iterations would
//! have the last word over the length constraint with two iterations, pinning the thread
//! where it touches the table and stretching the rest when a gripper pulls on it.

use crate::config::{Scene, Thread};
use crate::mpm::grid::WALL_NODES;
use crate::mpm::Vec3;
use crate::rod::Rod;

/// The table and walls a thread's points stay clear of (its centreline a radius away).
#[derive(Clone, Debug)]
pub struct ThreadBounds {
    /// Lowest z of a centreline point on the table (m), and the friction coefficient.
    table: Option<(f32, f32)>,
    lo: Vec3,
    hi: Vec3,
}

impl ThreadBounds {
    pub fn new(scene: &Scene, thread: &Thread) -> ThreadBounds {
        let d = &scene.domain;
        let r = thread.radius as f32;
        // Walls as the tissue sees them: the domain less its wall cells.
        let margin = WALL_NODES as f64 * d.dx;
        let lo = Vec3::from_fn(|a, _| (d.origin[a] + margin) as f32 + r);
        let hi = Vec3::from_fn(|a, _| (d.origin[a] + d.size[a] - margin) as f32 - r);
        ThreadBounds {
            table: scene
                .table
                .as_ref()
                .map(|t| (t.height as f32 + r, thread.friction as f32)),
            lo,
            hi,
        }
    }

    /// Pushes every free point of `rod` out of the table and back inside the walls.
    pub fn project(&self, rod: &mut Rod) {
        for (i, p) in rod.points.iter_mut().enumerate() {
            if rod.inv_mass[i] == 0.0 {
                continue;
            }
            if let Some((floor, _)) = self.table {
                p.z = p.z.max(floor);
            }
            *p = p.sup(&self.lo).inf(&self.hi);
        }
    }

    /// Coulomb friction of the table on the velocities after a substep of `h` seconds under
    /// gravity `gravity_z`, from each point's velocity `before` it.
    pub fn friction(&self, rod: &mut Rod, before: &[Vec3], gravity_z: f32, h: f32) {
        let Some((floor, friction)) = self.table else {
            return;
        };
        for (i, v) in rod.velocities.iter_mut().enumerate() {
            if rod.inv_mass[i] == 0.0 || rod.points[i].z > floor + 1e-7 {
                continue;
            }
            let normal_impulse = (v.z - (before[i].z + gravity_z * h)).max(0.0);
            let slide = Vec3::new(v.x, v.y, 0.0);
            let speed = slide.norm();
            let drop = friction * normal_impulse;
            if speed <= drop {
                v.x = 0.0;
                v.y = 0.0;
            } else {
                *v -= slide * (drop / speed);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rod::ThreadMaterial;

    fn bounds(friction: f32) -> ThreadBounds {
        ThreadBounds {
            table: Some((0.0, friction)),
            lo: Vec3::repeat(-1.0),
            hi: Vec3::repeat(1.0),
        }
    }

    fn one_segment(points: [Vec3; 2]) -> Rod {
        Rod::from_polyline(ThreadMaterial::nylon_3_0(), points.to_vec())
    }

    #[test]
    fn a_point_below_the_table_comes_back_onto_it_and_walls_hold_the_rest() {
        let mut rod = one_segment([Vec3::new(0.0, 0.0, 0.01), Vec3::new(0.01, 0.0, 0.01)]);
        rod.points[0] = Vec3::new(0.0002, 0.0, -0.001);
        rod.points[1] = Vec3::new(2.0, 0.0, 0.5);
        bounds(0.5).project(&mut rod);
        assert_eq!(rod.points[0], Vec3::new(0.0002, 0.0, 0.0));
        assert_eq!(rod.points[1], Vec3::new(1.0, 0.0, 0.5));
    }

    #[test]
    fn friction_stops_a_slow_slide_and_slows_a_fast_one_by_mu_times_the_normal_impulse() {
        let h = 1.0 / 240.0;
        let g = -9.81;
        let mut rod = one_segment([Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.01, 0.0, 0.0)]);
        // Landed at 0.1 m/s: the table took Δv_n = 0.1 + g·h ≈ 0.141 m/s.
        let before = [Vec3::new(0.0, 0.0, -0.1); 2];
        rod.velocities = vec![Vec3::new(0.05, 0.0, 0.0), Vec3::new(0.5, 0.0, 0.0)];
        bounds(0.5).friction(&mut rod, &before, g, h);
        assert_eq!(rod.velocities[0], Vec3::zeros());
        let dvn = 0.1 - g * h;
        assert!(
            (rod.velocities[1].x - (0.5 - 0.5 * dvn)).abs() < 1e-6,
            "{}",
            rod.velocities[1]
        );
    }

    #[test]
    fn held_points_and_points_off_the_table_feel_no_table() {
        let mut rod = one_segment([Vec3::new(0.0, 0.0, -0.5), Vec3::new(0.0, 0.0, 0.01)]);
        rod.pin_point(0);
        bounds(0.5).project(&mut rod);
        assert_eq!(rod.points[0], Vec3::new(0.0, 0.0, -0.5));
        rod.velocities[1] = Vec3::new(0.3, 0.0, -0.2);
        bounds(0.5).friction(&mut rod, &[Vec3::zeros(); 2], -9.81, 0.01);
        assert_eq!(rod.velocities[1], Vec3::new(0.3, 0.0, -0.2));
    }
}
