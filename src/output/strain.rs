//! Per-particle deformation scalars for colouring point clouds and pictures.

use crate::mpm::Mat3;
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum StrainMeasure {
    /// Volume change J − 1 (negative: compressed, positive: expanded).
    Volumetric,
    /// Equivalent (von Mises) Green strain √(2/3 · dev E : dev E), E = ½(FᵀF − I): shape change.
    #[default]
    Equivalent,
}

impl StrainMeasure {
    pub fn of(self, f: &Mat3) -> f32 {
        match self {
            StrainMeasure::Volumetric => f.determinant() - 1.0,
            StrainMeasure::Equivalent => {
                let e = 0.5 * (f.transpose() * f - Mat3::identity());
                let dev = e - Mat3::identity() * (e.trace() / 3.0);
                (2.0 / 3.0 * dev.norm_squared()).sqrt()
            }
        }
    }

    /// Whether the measure is signed (drawn with a diverging colour map).
    pub fn is_signed(self) -> bool {
        matches!(self, StrainMeasure::Volumetric)
    }
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
            Mat3::from_diagonal(&crate::mpm::Vec3::new(s, 1.0 / s.sqrt(), 1.0 / s.sqrt()));
        assert!(StrainMeasure::Volumetric.of(&stretch).abs() < 1e-6);
        assert!(StrainMeasure::Equivalent.of(&stretch) > 0.1);
    }
}
