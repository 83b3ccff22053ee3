//! Scripted tool motion for headless runs: keyframes interpolated in time.

use super::pose::ToolPose;

/// Keyframes sorted by time; before the first and after the last the pose holds.
#[derive(Clone, Debug, PartialEq)]
pub struct Trajectory {
    keys: Vec<(f64, ToolPose)>,
}

impl Trajectory {
    /// `keys` must be non-empty with strictly increasing times (the scene check ensures it).
    pub fn new(keys: Vec<(f64, ToolPose)>) -> Self {
        assert!(!keys.is_empty(), "a trajectory needs at least one keyframe");
        Trajectory { keys }
    }

    /// The pose at time `t` (s): linear in position and jaw, spherical-linear in rotation between
    /// keyframes; the first or last keyframe's pose outside them.
    pub fn sample(&self, t: f64) -> ToolPose {
        let keys = &self.keys;
        if t <= keys[0].0 {
            return keys[0].1;
        }
        let last = keys.len() - 1;
        if t >= keys[last].0 {
            return keys[last].1;
        }
        let i = keys.partition_point(|(kt, _)| *kt <= t) - 1;
        let (t0, p0) = keys[i];
        let (t1, p1) = keys[i + 1];
        p0.lerp(&p1, (t - t0) / (t1 - t0))
    }

    /// Keyframe times strictly between `t0` and `t1`: between them the pose is linear.
    pub fn key_times_between(&self, t0: f64, t1: f64) -> impl Iterator<Item = f64> + '_ {
        self.keys
            .iter()
            .map(|(t, _)| *t)
            .filter(move |&t| t > t0 && t < t1)
    }

    /// Time of the last keyframe.
    pub fn end_time(&self) -> f64 {
        self.keys[self.keys.len() - 1].0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn samples_hold_at_ends_and_interpolate_between() {
        let at = |z: f64| ToolPose {
            position: Vector3::new(0.0, 0.0, z),
            ..Default::default()
        };
        let tr = Trajectory::new(vec![(0.5, at(1.0)), (1.5, at(3.0)), (2.0, at(3.0))]);
        assert_eq!(tr.sample(0.0).position.z, 1.0);
        assert!((tr.sample(1.0).position.z - 2.0).abs() < 1e-12);
        assert_eq!(tr.sample(9.0).position.z, 3.0);
        assert_eq!(tr.end_time(), 2.0);
    }
}
