//! The tissue as points: position and one deformation scalar per point (volume change
//! J − 1, equivalent strain or tearing damage; see [`StrainMeasure`]), thinned by a particle stride and
//! optionally by a voxel filter.

use super::strain::StrainMeasure;
use crate::mpm::Particles;
use std::collections::HashMap;

/// Bytes per point in [`TissueCloud::cloud_bytes`]: x, y, z, scalar as little-endian f32.
pub const CLOUD_POINT_STEP: usize = 16;

/// How the cloud is built from the particles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CloudOptions {
    /// Which strain each point carries.
    pub measure: StrainMeasure,
    /// Every `stride`-th particle (1: all).
    pub stride: usize,
    /// Edge of the voxel filter's cubes (m); 0 turns it off.
    pub voxel: f32,
}

impl Default for CloudOptions {
    fn default() -> Self {
        CloudOptions {
            measure: StrainMeasure::Volumetric,
            stride: 1,
            voxel: 0.0,
        }
    }
}

/// A copy of what the point cloud needs from the particles at one frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TissueCloud {
    /// Which strain `scalar` holds.
    pub measure: StrainMeasure,
    /// Point positions, world frame, m.
    pub positions: Vec<[f32; 3]>,
    /// `measure` per point.
    pub scalar: Vec<f32>,
}

impl TissueCloud {
    /// Every `stride`-th particle, then one point per occupied voxel when the filter is on.
    /// Particles with non-finite positions or scalars are left out (NaN is never published).
    pub fn from_particles(particles: &Particles, options: &CloudOptions) -> TissueCloud {
        let stride = options.stride.max(1);
        let values = options.measure.values(particles);
        let (positions, scalar) = particles
            .x
            .iter()
            .zip(values)
            .step_by(stride)
            .map(|(x, s)| ([x.x, x.y, x.z], s))
            .filter(|(p, s)| s.is_finite() && p.iter().all(|v| v.is_finite()))
            .unzip();
        let cloud = TissueCloud {
            measure: options.measure,
            positions,
            scalar,
        };
        if options.voxel > 0.0 {
            cloud.voxel_filtered(options.voxel)
        } else {
            cloud
        }
    }

    /// One point per occupied cube of edge `voxel` (m): the mean position and mean scalar of
    /// the points in it, in the order of the cubes' integer coordinates.
    pub fn voxel_filtered(&self, voxel: f32) -> TissueCloud {
        let mut sums: HashMap<[i32; 3], ([f64; 3], f64, u32)> = HashMap::new();
        for (p, s) in self.positions.iter().zip(&self.scalar) {
            let key = p.map(|v| (v / voxel).floor() as i32);
            let e = sums.entry(key).or_insert(([0.0; 3], 0.0, 0));
            for (sum, v) in e.0.iter_mut().zip(p) {
                *sum += *v as f64;
            }
            e.1 += *s as f64;
            e.2 += 1;
        }
        let mut voxels: Vec<_> = sums.into_iter().collect();
        voxels.sort_unstable_by_key(|(k, _)| *k);
        let (positions, scalar) = voxels
            .into_iter()
            .map(|(_, (p, s, n))| {
                let n = n as f64;
                (p.map(|v| (v / n) as f32), (s / n) as f32)
            })
            .unzip();
        TissueCloud {
            measure: self.measure,
            positions,
            scalar,
        }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether the cloud has no points.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Name of the scalar field in the published cloud.
    pub fn scalar_name(&self) -> &'static str {
        self.measure.field_name()
    }

    /// Packed x, y, z, scalar (f32 little-endian), [`CLOUD_POINT_STEP`] bytes a point.
    pub fn cloud_bytes(&self) -> Vec<u8> {
        let mut data = Vec::with_capacity(self.len() * CLOUD_POINT_STEP);
        for (p, s) in self.positions.iter().zip(&self.scalar) {
            for v in [p[0], p[1], p[2], *s] {
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

    fn cube() -> Particles {
        let mut particles = Particles::default();
        particles.add_box(
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(0.004, 0.004, 0.004),
            0.002,
            2,
            1000.0,
            0,
        );
        particles
    }

    #[test]
    fn cloud_packs_position_and_the_chosen_scalar() {
        let mut particles = cube();
        particles.f[0] *= 1.1;
        let cloud = TissueCloud::from_particles(&particles, &CloudOptions::default());
        assert_eq!(cloud.len(), particles.len());
        assert_eq!(cloud.scalar_name(), "volumetric_strain");
        let bytes = cloud.cloud_bytes();
        assert_eq!(bytes.len(), cloud.len() * CLOUD_POINT_STEP);
        let read = |i: usize| f32::from_le_bytes(bytes[4 * i..4 * i + 4].try_into().unwrap());
        assert_eq!(read(0), particles.x[0].x);
        assert_eq!(read(2), particles.x[0].z);
        assert!((read(3) - (1.1f32.powi(3) - 1.0)).abs() < 1e-5);
        assert_eq!(read(7), 0.0);
        let options = CloudOptions {
            stride: 2,
            ..CloudOptions::default()
        };
        let half = TissueCloud::from_particles(&particles, &options);
        assert_eq!(half.len(), particles.len().div_ceil(2));

        // Uniform expansion: volume change, no shape change.
        let options = CloudOptions {
            measure: StrainMeasure::Equivalent,
            ..CloudOptions::default()
        };
        let cloud = TissueCloud::from_particles(&particles, &options);
        assert_eq!(cloud.scalar_name(), "equivalent_strain");
        assert!(cloud.scalar[0].abs() < 1e-6);
    }

    #[test]
    fn the_cloud_carries_damage_when_asked() {
        let mut particles = cube();
        let options = CloudOptions {
            measure: StrainMeasure::Damage,
            ..CloudOptions::default()
        };
        // A tissue that cannot tear has no damage state: zero everywhere.
        let cloud = TissueCloud::from_particles(&particles, &options);
        assert_eq!(cloud.scalar_name(), "damage");
        assert!(cloud.scalar.iter().all(|&s| s == 0.0));
        particles.damage = (0..particles.len()).map(|i| i as f32 * 0.01).collect();
        let cloud = TissueCloud::from_particles(&particles, &options);
        assert_eq!(cloud.scalar, particles.damage);
        let bytes = cloud.cloud_bytes();
        let at = 5 * CLOUD_POINT_STEP + 12;
        assert_eq!(
            f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()),
            particles.damage[5]
        );
    }

    #[test]
    fn voxel_filter_keeps_one_mean_point_per_occupied_voxel() {
        // 64 particles on a 1 mm lattice filling a 4 mm cube; 2 mm voxels hold 8 each.
        let mut particles = cube();
        for (i, f) in particles.f.iter_mut().enumerate() {
            *f *= 1.0 + 0.001 * i as f32;
        }
        let all = TissueCloud::from_particles(&particles, &CloudOptions::default());
        let filtered = all.voxel_filtered(0.002);
        assert_eq!(filtered.len(), 8);
        let mut keys: Vec<[i32; 3]> = filtered
            .positions
            .iter()
            .map(|p| p.map(|v| (v / 0.002).floor() as i32))
            .collect();
        keys.dedup();
        assert_eq!(keys.len(), 8, "one point per voxel, each inside its voxel");
        for (p, s) in filtered.positions.iter().zip(&filtered.scalar) {
            let members: Vec<usize> = (0..all.len())
                .filter(|&i| {
                    (0..3).all(|k| (all.positions[i][k] / 0.002).floor() == (p[k] / 0.002).floor())
                })
                .collect();
            assert_eq!(members.len(), 8);
            let mean = members.iter().map(|&i| all.scalar[i]).sum::<f32>() / 8.0;
            assert!((s - mean).abs() < 1e-5);
            for (k, v) in p.iter().enumerate() {
                let c = members.iter().map(|&i| all.positions[i][k]).sum::<f32>() / 8.0;
                assert!((v - c).abs() < 1e-7);
            }
        }
        let options = CloudOptions {
            voxel: 0.002,
            ..CloudOptions::default()
        };
        assert_eq!(TissueCloud::from_particles(&particles, &options), filtered);
    }

    #[test]
    fn non_finite_particles_are_left_out() {
        let mut particles = cube();
        particles.x[3].y = f32::NAN;
        particles.f[5] *= f32::INFINITY;
        let cloud = TissueCloud::from_particles(&particles, &CloudOptions::default());
        assert_eq!(cloud.len(), particles.len() - 2);
        assert!(cloud.scalar.iter().all(|s| s.is_finite()));
    }
}
