//! The tissue surface as a mesh of constant topology: each tissue block's rest surface (a
//! box) is triangulated once, with UVs, and every vertex is bound at rest to the particles
//! near it. A vertex then follows those particles by the affine map that best fits their
//! motion (weighted least squares, weights fixed at rest), which reduces to a fixed linear
//! combination of particle positions: `x_v = Σ c_vi x_i` with `Σ c_vi = 1`, exact for any
//! affine motion of the neighbourhood (so for rigid motion too). Vertex count, triangles
//! and UVs never change; positions and normals are updated per frame from positions alone,
//! which every backend reads back every frame.

use crate::math::Vec3;

use crate::mpm::Particles;
use nalgebra::{Matrix3, Vector3};
use std::collections::HashMap;

/// Radius of a vertex's neighbourhood in particle spacings: deep enough below the surface
/// (the outermost particles lie half a spacing inside it) for a three-dimensional fit.
const BIND_RADIUS_SPACINGS: f32 = 2.0;

/// Directions in which a neighbourhood's second moment is below this fraction of its
/// largest are left out of the fit (a pseudo-inverse), so a one-particle-thin block still
/// has a fit, flat in its thin direction.
const MOMENT_CUTOFF: f64 = 1e-3;

/// A tissue surface triangulated once and carried by the particles.
#[derive(Clone, Debug)]
pub struct TissueMesh {
    /// Current vertex positions (m).
    pub vertices: Vec<Vec3>,
    /// Current unit vertex normals (area-weighted over the vertex's triangles), outwards.
    pub normals: Vec<Vec3>,
    /// Texture coordinates: each block's six faces in a 3 × 2 atlas.
    pub uvs: Vec<[f32; 2]>,
    /// Counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
    /// Vertex positions at rest.
    pub rest: Vec<Vec3>,
    /// Binding, compressed rows: vertex v uses entries `offsets[v]..offsets[v + 1]`.
    offsets: Vec<u32>,
    particle: Vec<u32>,
    /// Affine-fit coefficients (sum to 1 per vertex; may be negative).
    coefficient: Vec<f32>,
    /// Normalised kernel weights (non-negative), for per-particle scalars.
    weight: Vec<f32>,
}

/// Why a mesh cannot be built.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MeshError {
    #[error(
        "mesh vertex at ({0:.4}, {1:.4}, {2:.4}) m has no particle of its block within {3:.4} m"
    )]
    /// A mesh vertex with no particle of its block nearby: its position (m) and the search radius
    /// (m).
    Unbound(f32, f32, f32, f32),
    #[error("mesh cell size {0} m must be positive and finite")]
    /// A cell size that is not positive and finite, m (holds it).
    Cell(f32),
}

impl TissueMesh {
    /// Triangulates the rest surface of each tissue block (particles of one material form
    /// one box block, as scenes define them) with triangles of about `cell` (m) on a side,
    /// and binds every vertex to the particles of its block.
    pub fn build(rest: &Particles, cell: f32) -> Result<TissueMesh, MeshError> {
        if !(cell.is_finite() && cell > 0.0) {
            return Err(MeshError::Cell(cell));
        }
        let mut mesh = TissueMesh {
            vertices: Vec::new(),
            normals: Vec::new(),
            uvs: Vec::new(),
            triangles: Vec::new(),
            rest: Vec::new(),
            offsets: vec![0],
            particle: Vec::new(),
            coefficient: Vec::new(),
            weight: Vec::new(),
        };
        let mut blocks: Vec<u16> = rest.material.clone();
        blocks.sort_unstable();
        blocks.dedup();
        for block in blocks {
            let members: Vec<u32> = (0..rest.len() as u32)
                .filter(|&i| rest.material[i as usize] == block)
                .collect();
            let spacing = rest.volume0[members[0] as usize].cbrt();
            let mut lo = Vec3::repeat(f32::INFINITY);
            let mut hi = Vec3::repeat(f32::NEG_INFINITY);
            for &i in &members {
                lo = lo.inf(&rest.x[i as usize]);
                hi = hi.sup(&rest.x[i as usize]);
            }
            let half = Vec3::repeat(0.5 * spacing);
            let first = mesh.rest.len();
            mesh.add_box(lo - half, hi + half, cell);
            mesh.bind(first, rest, &members, BIND_RADIUS_SPACINGS * spacing)?;
        }
        mesh.vertices = mesh.rest.clone();
        mesh.update_normals();
        Ok(mesh)
    }

    /// Appends the six faces of the box `lo`–`hi`, each a grid of about `cell`-sized quads.
    /// Faces do not share vertices, so each keeps its own UVs and its edges stay sharp;
    /// coincident vertices of two faces are bound identically and stay together.
    fn add_box(&mut self, lo: Vec3, hi: Vec3, cell: f32) {
        let size = hi - lo;
        for axis in 0..3 {
            for (side, positive) in [(0, false), (1, true)] {
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                let nu = ((size[u] / cell).round() as usize).max(1);
                let nv = ((size[v] / cell).round() as usize).max(1);
                let face = 2 * axis + side;
                let (col, row) = ((face % 3) as f32, (face / 3) as f32);
                let base = self.rest.len() as u32;
                for j in 0..=nv {
                    for i in 0..=nu {
                        let (s, t) = (i as f32 / nu as f32, j as f32 / nv as f32);
                        let mut p = lo;
                        p[axis] = if positive { hi[axis] } else { lo[axis] };
                        p[u] += s * size[u];
                        p[v] += t * size[v];
                        self.rest.push(p);
                        self.uvs.push([(col + s) / 3.0, (row + t) / 2.0]);
                    }
                }
                let at = |i: usize, j: usize| base + (j * (nu + 1) + i) as u32;
                for j in 0..nv {
                    for i in 0..nu {
                        let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                        // (u, v, axis) is right-handed: a→b→c is counter-clockwise from +axis.
                        if positive {
                            self.triangles.extend([[a, b, c], [a, c, d]]);
                        } else {
                            self.triangles.extend([[a, c, b], [a, d, c]]);
                        }
                    }
                }
            }
        }
    }

    /// Binds vertices `first..` to the particles `members` within `radius` of them.
    fn bind(
        &mut self,
        first: usize,
        rest: &Particles,
        members: &[u32],
        radius: f32,
    ) -> Result<(), MeshError> {
        let grid = SpatialHash::new(members.iter().map(|&i| (i, rest.x[i as usize])), radius);
        for v in first..self.rest.len() {
            let xv = self.rest[v];
            let near: Vec<(u32, f32)> = grid
                .within(xv, radius)
                .map(|(i, d2)| (i, (1.0 - d2 / (radius * radius)).powi(3)))
                .collect();
            // The fit in f64: its coefficients must sum to 1 and reproduce the vertex from
            // its neighbours to well below f32 position resolution.
            let total: f64 = near.iter().map(|(_, w)| *w as f64).sum();
            if near.is_empty() || total <= 0.0 {
                return Err(MeshError::Unbound(xv.x, xv.y, xv.z, radius));
            }
            let at = |i: u32| rest.x[i as usize].cast::<f64>();
            let centre: Vector3<f64> = near.iter().map(|&(i, w)| at(i) * (w as f64 / total)).sum();
            let mut moment = Matrix3::<f64>::zeros();
            for &(i, w) in &near {
                let d = at(i) - centre;
                moment += d * d.transpose() * (w as f64 / total);
            }
            let g = pseudo_inverse(&moment) * (xv.cast::<f64>() - centre);
            for &(i, w) in &near {
                let w = w as f64 / total;
                self.particle.push(i);
                self.weight.push(w as f32);
                self.coefficient
                    .push((w * (1.0 + (at(i) - centre).dot(&g))) as f32);
            }
            self.offsets.push(self.particle.len() as u32);
        }
        Ok(())
    }

    fn row(&self, v: usize) -> std::ops::Range<usize> {
        self.offsets[v] as usize..self.offsets[v + 1] as usize
    }

    /// Moves the vertices with the particles (`positions` of the particles the mesh was
    /// built from) and recomputes the normals.
    pub fn update(&mut self, positions: &[Vec3]) {
        for v in 0..self.vertices.len() {
            let mut x = Vec3::zeros();
            for k in self.row(v) {
                x += positions[self.particle[k] as usize] * self.coefficient[k];
            }
            self.vertices[v] = x;
        }
        self.update_normals();
    }

    fn update_normals(&mut self) {
        self.normals = vertex_normals(&self.vertices, &self.triangles);
    }

    /// The binding: vertex v is the sum over entries `offsets[v]..offsets[v + 1]` of
    /// `particles`' positions times `coefficients` (returned in that order).
    pub fn binding(&self) -> (&[u32], &[u32], &[f32]) {
        (&self.offsets, &self.particle, &self.coefficient)
    }

    /// A per-particle scalar averaged onto the vertices with the binding's kernel weights.
    pub fn vertex_values(&self, per_particle: &[f32]) -> Vec<f32> {
        (0..self.vertices.len())
            .map(|v| {
                self.row(v)
                    .map(|k| per_particle[self.particle[k] as usize] * self.weight[k])
                    .sum()
            })
            .collect()
    }

    /// The first particle vertex `v` is bound to (all of a vertex's particles are of its
    /// block, so this names the block).
    pub fn first_particle(&self, v: usize) -> u32 {
        self.particle[self.offsets[v] as usize]
    }

    /// Total number of particle references of the binding (the per-frame work).
    pub fn binding_len(&self) -> usize {
        self.particle.len()
    }
}

/// Unit normal per vertex: the area-weighted mean of its triangles' normals (+z for a vertex
/// of no triangle or of triangles of no area).
pub fn vertex_normals(vertices: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let mut normals = vec![Vec3::zeros(); vertices.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| vertices[i as usize]);
        // Twice the area times the unit normal: larger triangles weigh more.
        let n = (b - a).cross(&(c - a));
        for i in t {
            normals[*i as usize] += n;
        }
    }
    for n in &mut normals {
        *n = n.try_normalize(0.0).unwrap_or(Vec3::z());
    }
    normals
}

/// Points bucketed by cubes of edge `cell`, for fixed-radius neighbour queries.
pub(crate) struct SpatialHash {
    cell: f32,
    buckets: HashMap<[i32; 3], Vec<(u32, Vec3)>>,
}

impl SpatialHash {
    pub fn new(points: impl Iterator<Item = (u32, Vec3)>, cell: f32) -> SpatialHash {
        let mut buckets: HashMap<[i32; 3], Vec<(u32, Vec3)>> = HashMap::new();
        for (i, p) in points {
            if p.iter().all(|v| v.is_finite()) {
                buckets.entry(key(p, cell)).or_default().push((i, p));
            }
        }
        SpatialHash { cell, buckets }
    }

    /// Points within `radius` (at most the cell edge) of `p`, with their squared distance.
    pub fn within(&self, p: Vec3, radius: f32) -> impl Iterator<Item = (u32, f32)> + '_ {
        let c = key(p, self.cell);
        let r2 = radius * radius;
        (-1..=1)
            .flat_map(move |dx| (-1..=1).flat_map(move |dy| (-1..=1).map(move |dz| (dx, dy, dz))))
            .filter_map(move |(dx, dy, dz)| self.buckets.get(&[c[0] + dx, c[1] + dy, c[2] + dz]))
            .flatten()
            .filter_map(move |&(i, q)| {
                let d2 = (q - p).norm_squared();
                (d2 < r2).then_some((i, d2))
            })
    }

    /// The point nearest `p` within `radius` (at most the cell edge), if any.
    pub fn nearest(&self, p: Vec3, radius: f32) -> Option<u32> {
        self.within(p, radius)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _)| i)
    }

    /// Distance from `p` to the nearest point within `radius`; `radius` when there is none.
    pub fn nearest_distance(&self, p: Vec3, radius: f32) -> f32 {
        self.within(p, radius)
            .map(|(_, d2)| d2.sqrt())
            .fold(radius, f32::min)
    }
}

/// Inverse of a symmetric positive semi-definite matrix on the span of its eigenvectors
/// whose eigenvalues exceed [`MOMENT_CUTOFF`] times the largest.
fn pseudo_inverse(m: &Matrix3<f64>) -> Matrix3<f64> {
    let eig = m.symmetric_eigen();
    let largest = eig.eigenvalues.max();
    let mut inv = Matrix3::zeros();
    for k in 0..3 {
        let l = eig.eigenvalues[k];
        if l > MOMENT_CUTOFF * largest && l > 0.0 {
            let q = eig.eigenvectors.column(k);
            inv += q * q.transpose() / l;
        }
    }
    inv
}

fn key(p: Vec3, cell: f32) -> [i32; 3] {
    [
        (p.x / cell).floor() as i32,
        (p.y / cell).floor() as i32,
        (p.z / cell).floor() as i32,
    ]
}

/// How far a mesh has drifted from the particle surface: for each vertex, the change of its
/// distance to the nearest particle since rest (at rest a face vertex lies half a particle
/// spacing outside the outermost particles, an edge or corner vertex a little more). Zero
/// for any rigid motion; grows where the mesh sinks into or lifts off the particles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshDeviation {
    /// Mean and largest |change| over the vertices (m).
    pub mean: f32,
    /// Largest |change| over the vertices, m.
    pub max: f32,
    /// 95th percentile of |change| (m).
    pub p95: f32,
}

impl TissueMesh {
    /// Nearest-particle distance of every vertex (searched up to `radius`, m).
    pub fn particle_gaps(&self, vertices: &[Vec3], positions: &[Vec3], radius: f32) -> Vec<f32> {
        let grid = SpatialHash::new(
            positions.iter().enumerate().map(|(i, x)| (i as u32, *x)),
            radius,
        );
        vertices
            .iter()
            .map(|v| grid.nearest_distance(*v, radius))
            .collect()
    }

    /// The deviation of the current vertices from the particle surface at `positions`,
    /// against the gaps at rest (`rest_gaps` from [`TissueMesh::particle_gaps`] of the rest
    /// vertices and rest particles, same `radius`).
    pub fn deviation(&self, positions: &[Vec3], rest_gaps: &[f32], radius: f32) -> MeshDeviation {
        let now = self.particle_gaps(&self.vertices, positions, radius);
        let mut changes: Vec<f32> = now
            .iter()
            .zip(rest_gaps)
            .map(|(a, b)| (a - b).abs())
            .collect();
        changes.sort_by(f32::total_cmp);
        let n = changes.len().max(1);
        MeshDeviation {
            mean: changes.iter().sum::<f32>() / n as f32,
            max: changes.last().copied().unwrap_or(0.0),
            p95: changes
                .get(changes.len() * 95 / 100)
                .copied()
                .unwrap_or(0.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Vector3};

    fn block() -> Particles {
        let mut p = Particles::default();
        p.add_box(
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(0.006, 0.004, 0.002),
            0.001,
            2,
            1000.0,
            0,
        );
        p
    }

    fn enclosed_volume(mesh: &TissueMesh) -> f32 {
        mesh.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
                a.dot(&b.cross(&c)) / 6.0
            })
            .sum()
    }

    #[test]
    fn box_mesh_covers_the_block_with_outward_normals() {
        let particles = block();
        let mesh = TissueMesh::build(&particles, 0.001).unwrap();
        // Faces 6×4, 6×2 and 4×2 cells, both sides, (nu + 1)(nv + 1) vertices each.
        assert_eq!(mesh.triangles.len(), 2 * 2 * (24 + 12 + 8));
        assert_eq!(mesh.vertices.len(), 2 * (35 + 21 + 15));
        assert_eq!(mesh.uvs.len(), mesh.vertices.len());
        assert!((enclosed_volume(&mesh) - 0.006 * 0.004 * 0.002).abs() < 1e-12);
        let centre = Vec3::new(0.003, 0.002, 0.001);
        for (x, n) in mesh.vertices.iter().zip(&mesh.normals) {
            assert!((n.norm() - 1.0).abs() < 1e-5);
            assert!(n.dot(&(x - centre)) > 0.0, "inward normal at {x:?}");
        }
        assert!(mesh.uvs.iter().flatten().all(|u| (0.0..=1.0).contains(u)));
    }

    #[test]
    fn vertices_follow_affine_motion_exactly() {
        let particles = block();
        let mut mesh = TissueMesh::build(&particles, 0.001).unwrap();
        let rotation = Rotation3::from_euler_angles(0.3f32, -0.5, 1.2).into_inner();
        let stretch = crate::math::Mat3::new(1.3, 0.2, 0.0, 0.0, 0.9, 0.1, 0.05, 0.0, 0.8);
        let map = |x: &Vec3| rotation * stretch * x + Vec3::new(0.01, -0.02, 0.005);
        let moved: Vec<Vec3> = particles.x.iter().map(map).collect();
        let triangles = mesh.triangles.clone();
        let uvs = mesh.uvs.clone();
        mesh.update(&moved);
        for (x, x0) in mesh.vertices.iter().zip(&mesh.rest) {
            assert!((x - map(x0)).norm() < 2e-7, "{x:?} vs {:?}", map(x0));
        }
        assert_eq!(mesh.triangles, triangles);
        assert_eq!(mesh.uvs, uvs);
        let det = (rotation * stretch).determinant();
        assert!((enclosed_volume(&mesh) - det * 0.006 * 0.004 * 0.002).abs() < 1e-11);
    }

    #[test]
    fn vertex_values_average_particle_scalars() {
        let particles = block();
        let mesh = TissueMesh::build(&particles, 0.001).unwrap();
        let ones = vec![1.0; particles.len()];
        assert!(mesh
            .vertex_values(&ones)
            .iter()
            .all(|v| (v - 1.0).abs() < 1e-5));
        let z: Vec<f32> = particles.x.iter().map(|x| x.z).collect();
        let top = mesh.vertex_values(&z);
        for (x, v) in mesh.rest.iter().zip(&top) {
            assert!((v - x.z).abs() < 0.001, "vertex z {} smoothed to {v}", x.z);
        }
    }

    #[test]
    fn rigid_motion_has_no_deviation() {
        let particles = block();
        let mut mesh = TissueMesh::build(&particles, 0.001).unwrap();
        let radius = 0.002;
        let rest_gaps = mesh.particle_gaps(&mesh.rest, &particles.x, radius);
        // A face vertex lies half a spacing (0.25 mm) outside the outermost particles.
        assert!(rest_gaps
            .iter()
            .all(|g| *g >= 0.25e-3 - 1e-7 && *g < 0.45e-3));
        let rotation = Rotation3::from_euler_angles(0.2f32, 0.1, -0.4).into_inner();
        let moved: Vec<Vec3> = particles.x.iter().map(|x| rotation * x).collect();
        mesh.update(&moved);
        let d = mesh.deviation(&moved, &rest_gaps, radius);
        assert!(d.max < 1e-6, "{d:?}");
    }

    #[test]
    fn bad_cell_is_an_error() {
        assert_eq!(
            TissueMesh::build(&block(), 0.0).unwrap_err(),
            MeshError::Cell(0.0)
        );
    }
}
