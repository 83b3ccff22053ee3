//! The tissue surface published each frame, in the form a scene asks for: the mesh of
//! constant topology carried by the particles ([`TissueMesh`], coloured by strain, with
//! UVs), or the level set extracted afresh ([`isosurface`], for tissue whose topology
//! changes). Either way the result is a triangle list in a fixed vertex order.

use super::isosurface;
use super::mesh::{MeshError, TissueMesh};
use super::strain::{colour_range, StrainMeasure};
pub use crate::config::outputs::SurfaceKind;
use crate::mpm::Particles;

/// One frame's surface as a triangle list: three corners a triangle, in a fixed order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SurfaceTriangles {
    pub corners: Vec<[f32; 3]>,
    /// Linear RGB per corner (empty: one colour for the whole surface).
    pub colours: Vec<[f32; 3]>,
    /// Texture coordinates per corner (empty for the isosurface).
    pub uvs: Vec<[f32; 2]>,
}

/// Builds a scene's surface each frame.
pub enum TissueSurface {
    Mesh {
        mesh: Box<TissueMesh>,
        /// Strain the vertices are coloured by.
        measure: StrainMeasure,
    },
    Isosurface {
        /// Lattice spacing (m).
        cell: f32,
    },
}

impl TissueSurface {
    /// `rest`: the particles at rest; `cell` (m): triangle size of the mesh and lattice
    /// spacing of the isosurface.
    pub fn new(
        kind: SurfaceKind,
        rest: &Particles,
        cell: f32,
        measure: StrainMeasure,
    ) -> Result<TissueSurface, MeshError> {
        Ok(match kind {
            SurfaceKind::Mesh => TissueSurface::Mesh {
                mesh: Box::new(TissueMesh::build(rest, cell)?),
                measure,
            },
            SurfaceKind::Isosurface => TissueSurface::Isosurface { cell },
        })
    }

    /// Whether a frame needs the particles' deformation gradients (the mesh's colours).
    pub fn needs_deformation(&self) -> bool {
        matches!(self, TissueSurface::Mesh { .. })
    }

    /// The surface of `particles` now. Non-finite corners (a diverged particle bound to a
    /// vertex) drop their triangle, so NaN is never published.
    pub fn triangles(&mut self, particles: &Particles) -> SurfaceTriangles {
        let mut out = SurfaceTriangles::default();
        match self {
            TissueSurface::Mesh { mesh, measure } => {
                mesh.update(&particles.x);
                let strain = measure.values(particles);
                let values = mesh.vertex_values(&strain);
                let range = colour_range(&values);
                for t in &mesh.triangles {
                    let corners = t.map(|i| mesh.vertices[i as usize]);
                    if !corners.iter().flatten().all(|v| v.is_finite()) {
                        continue;
                    }
                    for &i in t {
                        let i = i as usize;
                        let x = mesh.vertices[i];
                        let value = if values[i].is_finite() {
                            values[i]
                        } else {
                            0.0
                        };
                        let c = measure.colour(value, range);
                        out.corners.push([x.x, x.y, x.z]);
                        out.colours.push([c.x, c.y, c.z]);
                        out.uvs.push(mesh.uvs[i]);
                    }
                }
            }
            TissueSurface::Isosurface { cell } => {
                let s = isosurface::extract(particles, *cell);
                out.corners = s
                    .triangles
                    .iter()
                    .flatten()
                    .map(|&i| {
                        let x = s.vertices[i as usize];
                        [x.x, x.y, x.z]
                    })
                    .collect();
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    fn block() -> Particles {
        let mut p = Particles::default();
        p.add_box(
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(0.004, 0.003, 0.002),
            0.001,
            2,
            1000.0,
            0,
        );
        p
    }

    #[test]
    fn both_kinds_give_triangle_lists_and_the_mesh_keeps_its_order() {
        let mut particles = block();
        let mut mesh = TissueSurface::new(
            SurfaceKind::Mesh,
            &particles,
            0.001,
            StrainMeasure::Volumetric,
        )
        .unwrap();
        assert!(mesh.needs_deformation());
        let before = mesh.triangles(&particles);
        assert!(before.corners.len().is_multiple_of(3));
        assert_eq!(before.colours.len(), before.corners.len());
        assert_eq!(before.uvs.len(), before.corners.len());
        // Squash the top: same count, same UVs, the top corners lower, colours by J − 1.
        for (x, f) in particles.x.iter_mut().zip(particles.f.iter_mut()) {
            x.z *= 0.5;
            f[(2, 2)] = 0.5;
        }
        let after = mesh.triangles(&particles);
        assert_eq!(after.corners.len(), before.corners.len());
        assert_eq!(after.uvs, before.uvs);
        let top = |s: &SurfaceTriangles| s.corners.iter().map(|c| c[2]).fold(0.0, f32::max);
        assert!((top(&before) - 0.002).abs() < 1e-6);
        assert!((top(&after) - 0.001).abs() < 1e-6);
        assert!(
            after.colours.iter().all(|c| c[2] > c[0]),
            "compression is blue"
        );

        let mut iso = TissueSurface::new(
            SurfaceKind::Isosurface,
            &particles,
            0.001,
            StrainMeasure::Volumetric,
        )
        .unwrap();
        assert!(!iso.needs_deformation());
        let s = iso.triangles(&block());
        assert!(!s.corners.is_empty() && s.corners.len().is_multiple_of(3));
        assert!(s.colours.is_empty() && s.uvs.is_empty());
    }

    #[test]
    fn diverged_particles_drop_their_triangles() {
        let mut particles = block();
        let mut mesh = TissueSurface::new(
            SurfaceKind::Mesh,
            &particles,
            0.001,
            StrainMeasure::Volumetric,
        )
        .unwrap();
        let all = mesh.triangles(&particles).corners.len();
        particles.x[0].x = f32::NAN;
        let some = mesh.triangles(&particles);
        assert!(some.corners.len() < all);
        assert!(some.corners.iter().flatten().all(|v| v.is_finite()));
    }
}
