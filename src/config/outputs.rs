//! What a scene asks its outputs to show: the choices a scene file names, defined here so
//! that the scene model does not depend on the code that computes the outputs
//! ([`crate::output`]).

use serde::{Deserialize, Serialize};

/// Which per-particle scalar the cloud carries and the pictures colour by (computed in
/// [`crate::output::strain`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum StrainMeasure {
    /// Volume change J − 1 (negative: compressed, positive: expanded).
    Volumetric,
    /// Equivalent (von Mises) Green strain √(2/3 · dev E : dev E), E = ½(FᵀF − I): shape change.
    #[default]
    Equivalent,
    /// Tearing damage d ∈ [0, 1] (see [`crate::mpm::damage`]; 1: torn through). Particle
    /// state, not a function of F: 0 where the tissue cannot tear.
    Damage,
}

/// Which surface a scene publishes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum SurfaceKind {
    /// Triangulated once at rest and carried by the particles: vertex count, triangles and
    /// UVs never change, so the tissue cannot be cut.
    #[default]
    Mesh,
    /// The ½ volume-fraction level set by marching cubes (split into tetrahedra), rebuilt
    /// every frame: follows any change of topology, no UVs, one colour.
    Isosurface,
}
