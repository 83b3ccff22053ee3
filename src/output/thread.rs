//! A suture thread's outputs at the end of a frame: its centreline and the axial force along
//! it, independent of any transport (the node wraps them in a LINE_STRIP marker and a
//! PointCloud2 with fields x, y, z, tension).

use crate::world::thread_body::ThreadBody;

/// Bytes per point of the tension cloud: x, y, z, tension as little-endian f32.
pub const THREAD_POINT_STEP: usize = 16;

/// One thread at the end of a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct ThreadState {
    pub name: String,
    /// Centreline points, first to last (m, world).
    pub points: Vec<[f32; 3]>,
    /// Axial force at each point (N, + = tension): the mean of the segments meeting there.
    pub tension: Vec<f32>,
    /// Length over rest length, minus one.
    pub elongation: f64,
    /// Points held by grippers.
    pub grasped: usize,
    /// Cross-section radius (m), for drawing.
    pub radius: f32,
}

impl ThreadState {
    pub fn of(body: &ThreadBody) -> ThreadState {
        let rod = &body.rod;
        let segment = &rod.tension;
        let n = rod.points.len();
        let tension = (0..n)
            .map(|i| match (i.checked_sub(1), segment.get(i)) {
                (Some(before), Some(after)) => 0.5 * (segment[before] + after),
                (Some(before), None) => segment[before],
                (None, Some(after)) => *after,
                (None, None) => 0.0,
            })
            .collect();
        ThreadState {
            name: body.name.clone(),
            points: rod.points.iter().map(|p| [p.x, p.y, p.z]).collect(),
            tension,
            elongation: body.elongation(),
            grasped: body.grasped_points(),
            radius: rod.material.radius,
        }
    }

    /// The tension cloud's data: x, y, z, tension per point.
    pub fn cloud_bytes(&self) -> Vec<u8> {
        let mut data = Vec::with_capacity(self.points.len() * THREAD_POINT_STEP);
        for (p, t) in self.points.iter().zip(&self.tension) {
            for v in [p[0], p[1], p[2], *t] {
                data.extend_from_slice(&v.to_le_bytes());
            }
        }
        data
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::builders;
    use crate::config::Thread;

    #[test]
    fn a_stretched_thread_reports_its_tension_at_every_point() {
        let mut scene = builders::scene(
            "t",
            60.0,
            builders::domain([-0.1, -0.1, 0.0], [0.2, 0.2, 0.2], 0.01, [0.0; 3]),
            None,
            Vec::new(),
            Vec::new(),
        );
        let mut thread = Thread::nylon_3_0([-0.05, 0.0, 0.1]);
        thread.length = 0.1;
        thread.segments = 4;
        scene.threads.push(thread.clone());
        let mut body = ThreadBody::new(&scene, &thread);
        body.rod.tension = vec![1.0, 2.0, 3.0, 4.0];
        let state = ThreadState::of(&body);
        assert_eq!(state.points.len(), 5);
        assert_eq!(state.tension, vec![1.0, 1.5, 2.5, 3.5, 4.0]);
        let bytes = state.cloud_bytes();
        assert_eq!(bytes.len(), 5 * THREAD_POINT_STEP);
        assert_eq!(f32::from_le_bytes(bytes[12..16].try_into().unwrap()), 1.0);
        let x1 = f32::from_le_bytes(bytes[16..20].try_into().unwrap());
        assert!((x1 + 0.025).abs() < 1e-6, "{x1}");
    }
}
