//! Tool pose (f64, kinematics precision) and its interpolation.

use nalgebra::{UnitQuaternion, Vector3};

/// Pose of a tool frame in the world, plus the jaw opening of a gripper (rad).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToolPose {
    /// Tool frame origin in the world, m.
    pub position: Vector3<f64>,
    /// World-from-tool rotation.
    pub rotation: UnitQuaternion<f64>,
    /// Jaw opening, rad (0 for tools without jaws).
    pub jaw: f64,
}

impl Default for ToolPose {
    fn default() -> Self {
        ToolPose {
            position: Vector3::zeros(),
            rotation: UnitQuaternion::identity(),
            jaw: 0.0,
        }
    }
}

impl ToolPose {
    /// Linear interpolation of position and jaw, spherical of rotation; `s` in [0, 1].
    pub fn lerp(&self, other: &ToolPose, s: f64) -> ToolPose {
        ToolPose {
            position: self.position.lerp(&other.position, s),
            rotation: self
                .rotation
                .try_slerp(&other.rotation, s, 1e-12)
                .unwrap_or(other.rotation),
            jaw: self.jaw + (other.jaw - self.jaw) * s,
        }
    }

    /// Whether every value is finite.
    pub fn is_finite(&self) -> bool {
        self.position.iter().all(|v| v.is_finite())
            && self.rotation.coords.iter().all(|v| v.is_finite())
            && self.jaw.is_finite()
    }
}

/// Rigid-body velocity that carries `from` to `to` in `dt` seconds: linear (m/s), angular
/// (rad/s, world frame) and jaw opening rate (rad/s).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ToolVelocity {
    /// Velocity of the tool frame origin, world frame, m/s.
    pub linear: Vector3<f64>,
    /// Angular velocity, world frame, rad/s.
    pub angular: Vector3<f64>,
    /// Jaw opening rate, rad/s.
    pub jaw_rate: f64,
}

impl ToolVelocity {
    /// The constant velocity that carries `from` to `to` in `dt` s (zero for `dt` ≤ 0).
    pub fn between(from: &ToolPose, to: &ToolPose, dt: f64) -> ToolVelocity {
        if dt <= 0.0 {
            return ToolVelocity::default();
        }
        let delta = to.rotation * from.rotation.inverse();
        ToolVelocity {
            linear: (to.position - from.position) / dt,
            angular: delta.scaled_axis() / dt,
            jaw_rate: (to.jaw - from.jaw) / dt,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn velocity_recovers_a_constant_twist() {
        let a = ToolPose {
            position: Vector3::new(0.1, 0.0, 0.0),
            rotation: UnitQuaternion::from_euler_angles(0.1, 0.0, 0.0),
            jaw: 0.5,
        };
        let b = ToolPose {
            position: Vector3::new(0.1, 0.002, 0.0),
            rotation: UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.0, 0.01)) * a.rotation,
            jaw: 0.4,
        };
        let v = ToolVelocity::between(&a, &b, 0.01);
        assert!((v.linear - Vector3::new(0.0, 0.2, 0.0)).norm() < 1e-12);
        assert!((v.angular - Vector3::new(0.0, 0.0, 1.0)).norm() < 1e-9);
        assert!((v.jaw_rate + 10.0).abs() < 1e-9);
        let mid = a.lerp(&b, 0.5);
        assert!((mid.position.y - 0.001).abs() < 1e-12);
    }
}
