//! Per-particle deformation scalars for colouring point clouds and pictures.

use crate::math::{Mat3, Vec3};

pub use crate::config::outputs::StrainMeasure;
use crate::mpm::Particles;

impl StrainMeasure {
    /// The measure at deformation gradient `f` (0 for [`StrainMeasure::Damage`], which
    /// [`StrainMeasure::values`] reads from the particles).
    pub fn of(self, f: &Mat3) -> f32 {
        match self {
            StrainMeasure::Damage => 0.0,
            StrainMeasure::Volumetric => f.determinant() - 1.0,
            StrainMeasure::Equivalent => {
                let e = 0.5 * (f.transpose() * f - Mat3::identity());
                let dev = e - Mat3::identity() * (e.trace() / 3.0);
                (2.0 / 3.0 * dev.norm_squared()).sqrt()
            }
        }
    }

    /// The measure of every particle.
    pub fn values(self, particles: &Particles) -> Vec<f32> {
        match self {
            StrainMeasure::Damage if particles.damage.len() == particles.len() => {
                particles.damage.clone()
            }
            _ => particles.f.iter().map(|f| self.of(f)).collect(),
        }
    }

    /// Whether the measure is signed (drawn with a diverging colour map).
    pub fn is_signed(self) -> bool {
        matches!(self, StrainMeasure::Volumetric)
    }

    /// Name of the measure as a point-cloud field.
    pub fn field_name(self) -> &'static str {
        match self {
            StrainMeasure::Volumetric => "volumetric_strain",
            StrainMeasure::Equivalent => "equivalent_strain",
            StrainMeasure::Damage => "damage",
        }
    }

    /// Colour (linear RGB, 0..1) of `value` on a scale whose ends are ±`range` (signed
    /// measures: blue compressed, grey none, red expanded) or 0…`range` (viridis-like).
    pub fn colour(self, value: f32, range: f32) -> Vec3 {
        let s = value / range.max(f32::MIN_POSITIVE);
        if self.is_signed() {
            let t = s.clamp(-1.0, 1.0);
            let mid = Vec3::new(0.86, 0.86, 0.86);
            if t < 0.0 {
                mid.lerp(&Vec3::new(0.15, 0.3, 0.85), -t)
            } else {
                mid.lerp(&Vec3::new(0.85, 0.15, 0.12), t)
            }
        } else {
            let stops = [
                Vec3::new(0.27, 0.00, 0.33),
                Vec3::new(0.23, 0.32, 0.55),
                Vec3::new(0.13, 0.57, 0.55),
                Vec3::new(0.37, 0.79, 0.38),
                Vec3::new(0.99, 0.91, 0.14),
            ];
            let t = s.clamp(0.0, 1.0) * (stops.len() - 1) as f32;
            let i = (t as usize).min(stops.len() - 2);
            stops[i].lerp(&stops[i + 1], t - i as f32)
        }
    }
}

/// The top of a colour scale for `values`: the 98th percentile of |value|, at least 0.01 so
/// that an undeformed tissue is not coloured by noise.
pub fn colour_range(values: &[f32]) -> f32 {
    let mut mags: Vec<f32> = values
        .iter()
        .map(|s| s.abs())
        .filter(|s| s.is_finite())
        .collect();
    mags.sort_by(f32::total_cmp);
    mags.get(mags.len() * 98 / 100)
        .copied()
        .unwrap_or(0.0)
        .max(0.01)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn measures_of_simple_deformations() {
        let id = Mat3::identity();
        assert_eq!(StrainMeasure::Volumetric.of(&id), 0.0);
        assert!(StrainMeasure::Equivalent.of(&id).abs() < 1e-7);
        // Uniform expansion changes volume but not shape.
        let grow = id * 1.1;
        assert!((StrainMeasure::Volumetric.of(&grow) - 0.331).abs() < 1e-5);
        assert!(StrainMeasure::Equivalent.of(&grow) < 1e-6);
        // Isochoric stretch: shape change, no volume change.
        let s = 1.2f32;
        let stretch =
            Mat3::from_diagonal(&crate::math::Vec3::new(s, 1.0 / s.sqrt(), 1.0 / s.sqrt()));
        assert!(StrainMeasure::Volumetric.of(&stretch).abs() < 1e-6);
        assert!(StrainMeasure::Equivalent.of(&stretch) > 0.1);
    }

    #[test]
    fn equivalent_strain_of_known_homogeneous_deformations() {
        // Isochoric stretch λ: E = ½ diag(λ² − 1, 1/λ − 1, 1/λ − 1), equivalent strain
        // (2/3)|E₁₁ − E₂₂|.
        let l = 1.2f32;
        let stretch = Mat3::from_diagonal(&Vec3::new(l, 1.0 / l.sqrt(), 1.0 / l.sqrt()));
        let expected = 2.0 / 3.0 * (0.5 * (l * l - 1.0) - 0.5 * (1.0 / l - 1.0));
        assert!((StrainMeasure::Equivalent.of(&stretch) - expected).abs() < 1e-5);
        // Simple shear γ: √(γ⁴/9 + γ²/3), with no volume change.
        let g = 0.3f32;
        let mut shear = Mat3::identity();
        shear[(0, 1)] = g;
        let expected = (g.powi(4) / 9.0 + g * g / 3.0).sqrt();
        assert!((StrainMeasure::Equivalent.of(&shear) - expected).abs() < 1e-5);
        assert!(StrainMeasure::Volumetric.of(&shear).abs() < 1e-6);
        // A rigid rotation on top changes neither.
        let r = nalgebra::Rotation3::from_euler_angles(0.4f32, -0.7, 1.1).into_inner();
        assert!((StrainMeasure::Equivalent.of(&(r * shear)) - expected).abs() < 1e-5);
    }

    #[test]
    fn colour_scale_ends_and_range() {
        let v = StrainMeasure::Volumetric;
        assert!(v.colour(-1.0, 0.5).z > 0.8 && v.colour(1.0, 0.5).x > 0.8);
        assert_eq!(v.colour(0.0, 0.5), Vec3::new(0.86, 0.86, 0.86));
        let values: Vec<f32> = (0..100).map(|i| i as f32 * 0.01).collect();
        assert!((colour_range(&values) - 0.98).abs() < 1e-6);
        assert_eq!(colour_range(&[]), 0.01);
    }
}
