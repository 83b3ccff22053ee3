//! Particle state, structure of arrays, f32 (the GPU's type, so that backends compare).

use super::{material::MaterialModel, Lame, Mat3, Vec3};

/// Per-material constants the solver reads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaterialParams {
    /// The constitutive model.
    pub model: MaterialModel,
    /// Lamé parameters, Pa.
    pub lame: Lame,
    /// Density, kg/m³.
    pub density: f32,
    /// Mass-proportional (Rayleigh α) velocity damping, 1/s, integrated implicitly:
    /// v ← v / (1 + α·dt), stable for any α·dt.
    pub damping: f32,
    /// Toughness G_c (J/m²) of the damage model (see [`super::damage`]); 0: never tears.
    pub toughness: f32,
}

#[derive(Clone, Debug, Default)]
/// The tissue's particles, one entry per particle in each array.
pub struct Particles {
    /// Positions, world frame, m.
    pub x: Vec<Vec3>,
    /// Velocities, world frame, m/s.
    pub v: Vec<Vec3>,
    /// APIC affine velocity (velocity gradient estimate), 1/s.
    pub c: Vec<Mat3>,
    /// Elastic deformation gradient.
    pub f: Vec<Mat3>,
    /// Mass, kg.
    pub mass: Vec<f32>,
    /// Volume in the rest state, m³.
    pub volume0: Vec<f32>,
    /// Index into the solver's material table.
    pub material: Vec<u16>,
    /// Per-particle crack plane (see [`super::crack`]); empty until a slicer first cuts.
    pub crack: Vec<Vec3>,
    /// Per-particle damage in [0, 1] (see [`super::damage`]); empty when no material tears.
    pub damage: Vec<f32>,
    /// Rest edges of each particle's parallelepiped (columns, m; see [`super::split`]);
    /// empty until a particle first splits, the cube of the rest volume until then.
    pub domain: Vec<Mat3>,
}

impl Particles {
    /// Number of particles.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Fills an axis-aligned box `[min, max]` with particles on a regular lattice of
    /// `per_axis` particles per grid cell along each axis, at rest and undeformed.
    pub fn add_box(
        &mut self,
        min: Vec3,
        max: Vec3,
        dx: f32,
        per_axis: u32,
        density: f32,
        material: u16,
    ) {
        let spacing = dx / per_axis as f32;
        let counts = ((max - min) / spacing).map(|n| (n.round() as i64).max(1) as usize);
        let volume = spacing * spacing * spacing;
        for i in 0..counts.x {
            for j in 0..counts.y {
                for k in 0..counts.z {
                    let p =
                        min + Vec3::new(i as f32 + 0.5, j as f32 + 0.5, k as f32 + 0.5) * spacing;
                    self.x.push(p);
                    self.v.push(Vec3::zeros());
                    self.c.push(Mat3::zeros());
                    self.f.push(Mat3::identity());
                    self.mass.push(density * volume);
                    self.volume0.push(volume);
                    self.material.push(material);
                }
            }
        }
    }

    /// Copies the state of `other` (x, v, C, F, cracks, damage, and the particles splitting
    /// made or undid: mass, rest volume, material, rest edges), reusing this one's buffers.
    pub fn copy_state_from(&mut self, other: &Particles) {
        self.x.clone_from(&other.x);
        self.v.clone_from(&other.v);
        self.c.clone_from(&other.c);
        self.f.clone_from(&other.f);
        self.crack.clone_from(&other.crack);
        self.damage.clone_from(&other.damage);
        self.mass.clone_from(&other.mass);
        self.volume0.clone_from(&other.volume0);
        self.material.clone_from(&other.material);
        self.domain.clone_from(&other.domain);
    }

    /// Total linear momentum (kg·m/s), f64.
    pub fn momentum(&self) -> nalgebra::Vector3<f64> {
        self.v
            .iter()
            .zip(&self.mass)
            .map(|(v, &m)| v.cast::<f64>() * m as f64)
            .sum()
    }

    /// Kinetic energy (J), f64.
    pub fn kinetic_energy(&self) -> f64 {
        self.v
            .iter()
            .zip(&self.mass)
            .map(|(v, &m)| 0.5 * m as f64 * v.cast::<f64>().norm_squared())
            .sum()
    }

    /// Total mass (kg), f64.
    pub fn total_mass(&self) -> f64 {
        self.mass.iter().map(|&m| m as f64).sum()
    }

    /// Centre of mass (m), f64.
    pub fn centre_of_mass(&self) -> nalgebra::Vector3<f64> {
        let total = self.total_mass();
        let weighted: nalgebra::Vector3<f64> = self
            .x
            .iter()
            .zip(&self.mass)
            .map(|(x, &m)| x.cast::<f64>() * m as f64)
            .sum();
        weighted / total.max(f64::MIN_POSITIVE)
    }
}
