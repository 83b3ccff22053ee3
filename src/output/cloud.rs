//! The tissue as points: position and volume change J − 1 (J = det F; negative where the
//! tissue is compressed, positive where stretched).

use crate::mpm::Particles;

/// Bytes per point in [`TissueSample::cloud_bytes`]: x, y, z, deformation as little-endian f32.
pub const CLOUD_POINT_STEP: usize = 16;

/// A copy of what the outputs need from the particles at one frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TissueSample {
    pub positions: Vec<[f32; 3]>,
    /// J − 1 per particle.
    pub deformation: Vec<f32>,
}

impl TissueSample {
    /// Every `stride`-th particle (1: all).
    pub fn from_particles(particles: &Particles, stride: usize) -> TissueSample {
        let stride = stride.max(1);
        let positions = particles
            .x
            .iter()
            .step_by(stride)
            .map(|x| [x.x, x.y, x.z])
            .collect();
        let deformation = particles
            .f
            .iter()
            .step_by(stride)
            .map(|f| f.determinant() - 1.0)
            .collect();
        TissueSample {
            positions,
            deformation,
        }
    }

    pub fn len(&self) -> usize {
        self.positions.len()
    }

    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Packed x, y, z, deformation (f32 little-endian), [`CLOUD_POINT_STEP`] bytes a point.
    pub fn cloud_bytes(&self) -> Vec<u8> {
        let mut data = Vec::with_capacity(self.len() * CLOUD_POINT_STEP);
        for (p, d) in self.positions.iter().zip(&self.deformation) {
            for v in [p[0], p[1], p[2], *d] {
                data.extend_from_slice(&v.to_le_bytes());
            }
        }
        data
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn cloud_packs_position_and_volume_change() {
        let mut particles = Particles::default();
        particles.add_box(
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(0.004, 0.004, 0.004),
            0.002,
            2,
            1000.0,
            0,
        );
        particles.f[0] *= 1.1;
        let sample = TissueSample::from_particles(&particles, 1);
        assert_eq!(sample.len(), particles.len());
        let bytes = sample.cloud_bytes();
        assert_eq!(bytes.len(), sample.len() * CLOUD_POINT_STEP);
        let read = |i: usize| f32::from_le_bytes(bytes[4 * i..4 * i + 4].try_into().unwrap());
        assert_eq!(read(0), particles.x[0].x);
        assert_eq!(read(2), particles.x[0].z);
        assert!((read(3) - (1.1f32.powi(3) - 1.0)).abs() < 1e-5);
        assert_eq!(read(7), 0.0);
        let half = TissueSample::from_particles(&particles, 2);
        assert_eq!(half.len(), particles.len().div_ceil(2));
    }
}
