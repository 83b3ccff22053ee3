//! A thread's material and cross-section, and the stiffnesses the constraints need.

use serde::{Deserialize, Serialize};

/// Solid circular thread. SI units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThreadMaterial {
    /// Radius of the cross-section (m).
    pub radius: f32,
    /// Young's modulus (Pa).
    pub young_modulus: f32,
    /// Shear modulus (Pa).
    pub shear_modulus: f32,
    /// Density (kg/m³).
    pub density: f32,
}

/// Timoshenko's shear coefficient of a solid circular section.
const CIRCLE_SHEAR_COEFFICIENT: f32 = 0.9;

impl ThreadMaterial {
    /// USP 3-0 nylon (0.225 mm diameter, E = 3 GPa, ν ≈ 0.4, 1140 kg/m³): EA ≈ 119 N,
    /// EI ≈ 3.8e-7 N·m² (reference/thread.md).
    pub fn nylon_3_0() -> Self {
        ThreadMaterial {
            radius: 0.1125e-3,
            young_modulus: 3.0e9,
            shear_modulus: 1.07e9,
            density: 1140.0,
        }
    }

    /// Cross-section area, m².
    pub fn area(&self) -> f32 {
        std::f32::consts::PI * self.radius * self.radius
    }

    /// Axial stiffness EA (N).
    pub fn axial_stiffness(&self) -> f32 {
        self.young_modulus * self.area()
    }

    /// Shear stiffness κGA (N).
    pub fn shear_stiffness(&self) -> f32 {
        CIRCLE_SHEAR_COEFFICIENT * self.shear_modulus * self.area()
    }

    /// Bending stiffness EI (N·m²), I = πr⁴/4.
    pub fn bending_stiffness(&self) -> f32 {
        self.young_modulus * std::f32::consts::PI * self.radius.powi(4) / 4.0
    }

    /// Torsional stiffness GJ (N·m²), J = πr⁴/2.
    pub fn torsional_stiffness(&self) -> f32 {
        self.shear_modulus * std::f32::consts::PI * self.radius.powi(4) / 2.0
    }

    /// Mass per unit length (kg/m).
    pub fn linear_density(&self) -> f32 {
        self.density * self.area()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nylon_3_0_matches_the_reference_stiffnesses() {
        let m = ThreadMaterial::nylon_3_0();
        assert!(
            (m.axial_stiffness() - 119.0).abs() < 1.0,
            "EA {}",
            m.axial_stiffness()
        );
        let ei = m.bending_stiffness();
        assert!((ei - 3.8e-7).abs() < 0.1e-7, "EI {ei}");
    }
}
