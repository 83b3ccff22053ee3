//! The slicer from a triangle mesh file (seed 002 §IV-B, its `TriangleMeshSlicer`): the quad
//! blade of [`super::slicer`] generalised to any open surface, such as a scalpel's curved
//! belly.
//!
//! The file is a Wavefront OBJ in the tool frame (m, see [`super::obj`]): its faces are the
//! blade's mid-surface, one or more `l` polylines its spine (the blunt side, where the
//! handle holds the blade). The cutting edge is every boundary edge of the surface (an edge
//! of one face only) that is not a spine segment. The spine has grid contact, a chain of
//! capsules of the blade's thickness fattened like the quad's spine; the surface and edge
//! have none: where the edge passes, particles take the local tangent plane of the blade as
//! their crack (see [`crate::mpm::crack`]).

use super::obj::{self, Obj};
use super::SdfHit;
use crate::math::Vec3;
use parry3d::math::Point;
use parry3d::query::{PointQuery, PointQueryWithLocation};
use parry3d::shape::{TriMesh, TrianglePointLocation};
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::collections::HashMap;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Why a blade mesh file cannot be used: the file, the line where one applies, and what is
/// wrong.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{}{}: {message}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
pub struct BladeError {
    pub path: PathBuf,
    pub line: Option<usize>,
    pub message: String,
}

/// Triangles with less area than this fraction of the blade's squared bounding-box diagonal
/// are degenerate: their normal is noise.
const DEGENERATE_AREA: f32 = 1e-8;

/// The edges of a triangle `[a, b, c]` in parry's numbering of
/// [`TrianglePointLocation::OnEdge`]: 0 is AB, 1 is BC, 2 is AC.
const TRIANGLE_EDGES: [[usize; 2]; 3] = [[0, 1], [1, 2], [0, 2]];

/// One triangle of a blade with what the cut rule needs to classify a closest point on it
/// (see [`BladeMesh::edge_passing`]): the GPU backend uploads these.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BladeTriangle {
    /// Corners a, b, c in the file's order (tool frame, m).
    pub corners: [Vec3; 3],
    /// Unit normal, as `edge_passing` takes it on a face.
    pub normal: Vec3,
    /// Whether each edge is on the surface's boundary, in parry's numbering of
    /// `TrianglePointLocation::OnEdge`: 0 is AB, 1 is BC, 2 is AC.
    pub boundary_edges: [bool; 3],
    /// Whether each corner is a boundary vertex of the surface.
    pub boundary_corners: [bool; 3],
}

/// A loaded blade: its surface (for closest points), which of its features are on the
/// outline, its cutting edge and its spine, all in the tool frame.
pub struct BladeMesh {
    surface: TriMesh,
    triangles: Vec<[u32; 3]>,
    vertices: Vec<Vec3>,
    /// Unit normal of each triangle (its orientation is irrelevant: cracks take the side of
    /// the particle).
    normals: Vec<Vec3>,
    /// Per triangle, whether each edge (parry's numbering) is on the surface's boundary.
    boundary_edge: Vec<[bool; 3]>,
    /// Per vertex, whether it is on the surface's boundary.
    boundary_vertex: Vec<bool>,
    cutting_edges: Vec<[Vec3; 2]>,
    spine: Vec<[Vec3; 2]>,
    aabb_min: Vec3,
    aabb_max: Vec3,
    /// Farthest a surface vertex lies from the spine (m): the quad's height.
    height: f32,
}

impl fmt::Debug for BladeMesh {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "BladeMesh {{ {} triangles, {} cutting-edge segments, {} spine segments }}",
            self.triangles.len(),
            self.cutting_edges.len(),
            self.spine.len()
        )
    }
}

fn point(p: Vec3) -> Point<f32> {
    Point::new(p.x, p.y, p.z)
}

/// Closest point to `p` on the segment `[a, b]`.
#[inline(always)]
fn closest_on_segment(p: Vec3, [a, b]: [Vec3; 2]) -> Vec3 {
    let ab = b - a;
    let t = ((p - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
    a + ab * t
}

impl BladeMesh {
    /// Reads and checks a blade OBJ file.
    pub fn load(path: &Path) -> Result<Self, BladeError> {
        let text = std::fs::read_to_string(path).map_err(|e| BladeError {
            path: path.to_owned(),
            line: None,
            message: format!("cannot read the blade mesh: {e}"),
        })?;
        let obj = obj::parse(&text).map_err(|e| BladeError {
            path: path.to_owned(),
            line: Some(e.line),
            message: e.message,
        })?;
        Self::from_obj(obj, path)
    }

    /// Builds the blade from parsed OBJ (`path` only names it in errors): refuses a file
    /// without faces, degenerate or non-manifold triangles, no spine, a spine segment that
    /// is not a boundary edge, and a surface whose whole boundary is spine.
    pub fn from_obj(obj: Obj, path: &Path) -> Result<Self, BladeError> {
        let error = |line: Option<usize>, message: String| BladeError {
            path: path.to_owned(),
            line,
            message,
        };
        if obj.triangles.is_empty() {
            return Err(error(
                None,
                "no faces (`f`): a blade needs a surface".into(),
            ));
        }
        let (aabb_min, aabb_max) = obj.vertices.iter().fold(
            (Vec3::repeat(f32::MAX), Vec3::repeat(f32::MIN)),
            |(lo, hi), v| (lo.inf(v), hi.sup(v)),
        );
        let least_area = DEGENERATE_AREA * (aabb_max - aabb_min).norm_squared();
        let vertices = obj.vertices;
        let mut normals = Vec::with_capacity(obj.triangles.len());
        let mut edge_faces: HashMap<[u32; 2], Vec<(usize, usize)>> = HashMap::new();
        for (t, (tri, line)) in obj.triangles.iter().enumerate() {
            let [a, b, c] = tri.map(|i| vertices[i as usize]);
            let scaled = (b - a).cross(&(c - a));
            if 0.5 * scaled.norm() <= least_area {
                return Err(error(
                    Some(*line),
                    format!("degenerate face (area {:.3e} m²)", 0.5 * scaled.norm()),
                ));
            }
            normals.push(scaled.normalize());
            for (e, [i, j]) in TRIANGLE_EDGES.iter().enumerate() {
                let (vi, vj) = (tri[*i], tri[*j]);
                let users = edge_faces.entry([vi.min(vj), vi.max(vj)]).or_default();
                users.push((t, e));
                if users.len() > 2 {
                    return Err(error(
                        Some(*line),
                        format!(
                            "the edge between vertices {} and {} belongs to more than two faces \
                             (the blade must be a manifold surface)",
                            vi + 1,
                            vj + 1
                        ),
                    ));
                }
            }
        }
        let mut boundary_edge = vec![[false; 3]; obj.triangles.len()];
        let mut boundary_vertex = vec![false; vertices.len()];
        for (key, users) in &edge_faces {
            if let [(t, e)] = users[..] {
                boundary_edge[t][e] = true;
                boundary_vertex[key[0] as usize] = true;
                boundary_vertex[key[1] as usize] = true;
            }
        }
        if obj.polylines.is_empty() {
            return Err(error(
                None,
                "no spine: one `l` polyline along the blade's blunt side is needed".into(),
            ));
        }
        let mut spine_keys = Vec::new();
        for (points, line) in &obj.polylines {
            for pair in points.windows(2) {
                let key = [pair[0].min(pair[1]), pair[0].max(pair[1])];
                if edge_faces.get(&key).is_none_or(|users| users.len() != 1) {
                    return Err(error(
                        Some(*line),
                        format!(
                            "spine segment {}–{} is not a boundary edge of the surface",
                            pair[0] + 1,
                            pair[1] + 1
                        ),
                    ));
                }
                spine_keys.push(key);
            }
        }
        let segment = |[i, j]: [u32; 2]| [vertices[i as usize], vertices[j as usize]];
        let mut cutting_keys: Vec<[u32; 2]> = edge_faces
            .iter()
            .filter(|(key, users)| users.len() == 1 && !spine_keys.contains(key))
            .map(|(key, _)| *key)
            .collect();
        // A fixed order, so that runs and the GPU upload do not depend on hashing.
        cutting_keys.sort_unstable();
        if cutting_keys.is_empty() {
            return Err(error(
                None,
                "no cutting edge: every boundary edge of the surface is on the spine".into(),
            ));
        }
        let cutting_edges: Vec<[Vec3; 2]> = cutting_keys.into_iter().map(segment).collect();
        let spine: Vec<[Vec3; 2]> = spine_keys.into_iter().map(segment).collect();
        let from_spine = |v: &Vec3| {
            spine
                .iter()
                .map(|s| (v - closest_on_segment(*v, *s)).norm())
                .fold(f32::INFINITY, f32::min)
        };
        let height = vertices.iter().map(from_spine).fold(0.0, f32::max);
        let triangles: Vec<[u32; 3]> = obj.triangles.iter().map(|(t, _)| *t).collect();
        let surface = TriMesh::new(
            vertices.iter().copied().map(point).collect(),
            triangles.clone(),
        )
        .map_err(|e| error(None, format!("not a triangle mesh: {e}")))?;
        Ok(BladeMesh {
            surface,
            triangles,
            vertices,
            normals,
            boundary_edge,
            boundary_vertex,
            cutting_edges,
            spine,
            aabb_min,
            aabb_max,
            height,
        })
    }

    /// Number of triangles of the surface.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// The triangles with their normals and boundary features, in the file's order.
    pub fn triangles(&self) -> impl ExactSizeIterator<Item = BladeTriangle> + '_ {
        self.triangles
            .iter()
            .enumerate()
            .map(|(t, tri)| BladeTriangle {
                corners: tri.map(|i| self.vertices[i as usize]),
                normal: self.normals[t],
                boundary_edges: self.boundary_edge[t],
                boundary_corners: tri.map(|i| self.boundary_vertex[i as usize]),
            })
    }

    /// Least and greatest corner of the surface's bounding box in the tool frame (m).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        (self.aabb_min, self.aabb_max)
    }

    /// The tool-frame box outside which [`Self::edge_passing`] answers `None` for this
    /// `band`: the surface's bounding box grown by it, least and greatest corner (m).
    pub fn cutting_box(&self, band: f32) -> (Vec3, Vec3) {
        (
            self.aabb_min.add_scalar(-band),
            self.aabb_max.add_scalar(band),
        )
    }

    /// The cutting edge's segments (tool frame, m).
    pub fn cutting_edges(&self) -> &[[Vec3; 2]] {
        &self.cutting_edges
    }

    /// The spine's segments (tool frame, m).
    pub fn spine_segments(&self) -> &[[Vec3; 2]] {
        &self.spine
    }

    /// Side lengths of the surface's bounding box in the tool frame (m).
    pub fn extents(&self) -> Vec3 {
        self.aabb_max - self.aabb_min
    }

    /// Farthest a point of the surface lies from the spine (m): the quad's `height`.
    pub fn height(&self) -> f32 {
        self.height
    }

    /// Radius of a sphere about the tool origin holding the whole surface.
    pub fn bounding_radius(&self) -> f32 {
        self.vertices.iter().map(|v| v.norm()).fold(0.0, f32::max)
    }

    /// Distance to the spine: a capsule of radius `thickness`/2 along each spine segment.
    pub fn spine_distance(&self, p: Vec3, thickness: f32) -> SdfHit {
        let nearest = self
            .spine
            .iter()
            .map(|s| closest_on_segment(p, *s))
            .min_by(|a, b| (p - a).norm_squared().total_cmp(&(p - b).norm_squared()))
            .unwrap_or(p);
        let d = p - nearest;
        let n = d.norm();
        SdfHit {
            distance: n - 0.5 * thickness,
            normal: if n > 1e-12 { d / n } else { Vec3::z() },
            part: 0,
            tangent: Vec3::zeros(),
        }
    }

    /// Unsigned distance to the surface (m), for drawing.
    pub fn surface_distance(&self, p: Vec3) -> f32 {
        self.surface.distance_to_local_point(&point(p), false)
    }

    /// The crack plane the edge gives a tool-frame point `p` when it is passing it: the
    /// unit normal (from the blade towards `p`) and `p`'s distance from the blade. The quad's
    /// [`super::slicer::edge_passing`] generalised: `p`'s closest point `q` on the surface
    /// lies on a face or an interior edge or vertex (on the outline, `p` is beyond the blade
    /// and not reached yet), `p` is nearer the surface than `band`, and `q` within `band`
    /// of the cutting edge (the surface far from the edge does not cut). On a face, the
    /// plane is the face's; on an interior edge or vertex (a bend), the plane through `q`
    /// normal to `p − q`.
    pub fn edge_passing(&self, p: Vec3, band: f32) -> Option<(Vec3, f32)> {
        if (0..3).any(|a| p[a] < self.aabb_min[a] - band || p[a] > self.aabb_max[a] + band) {
            return None;
        }
        // Bounded by the band: the tree skips every triangle farther than that.
        let (projection, (triangle, location)) = self
            .surface
            .project_local_point_and_get_location_with_max_dist(&point(p), false, band)?;
        let t = triangle as usize;
        let (normal, distance, q) = match location {
            TrianglePointLocation::OnVertex(i)
                if self.boundary_vertex[self.triangles[t][i as usize] as usize] =>
            {
                return None
            }
            TrianglePointLocation::OnEdge(e, _) if self.boundary_edge[t][e as usize] => {
                return None
            }
            TrianglePointLocation::OnFace(..) | TrianglePointLocation::OnSolid => {
                // The face's own plane: computed here rather than from the projection, so
                // that a flat blade gives the quad's crack to the last bit.
                let n = self.normals[t];
                let side = n.dot(&(p - self.vertices[self.triangles[t][0] as usize]));
                let normal = if side < 0.0 { -n } else { n };
                (normal, side.abs(), p - n * side)
            }
            _ => {
                let q = Vec3::new(projection.point.x, projection.point.y, projection.point.z);
                let d = (p - q).norm();
                let normal = if d > 1e-12 {
                    (p - q) / d
                } else {
                    self.normals[t]
                };
                (normal, d, q)
            }
        };
        if distance >= band {
            return None;
        }
        let near_edge = self
            .cutting_edges
            .iter()
            .any(|s| (q - closest_on_segment(q, *s)).norm() <= band);
        near_edge.then_some((normal, distance))
    }
}

/// A scene's blade mesh file: the path as the scene writes it (relative to the scene
/// file), and the mesh once [`BladeFile::load`] has read it.
///
/// [`super::Shape`] is `Copy` and every substep's tool kinematics carry it, so this is a
/// shared reference to a source that lives as long as the program: a program reads a scene
/// file a few times at most, and a blade is a few kilobytes.
#[derive(Clone, Copy)]
pub struct BladeFile(&'static BladeSource);

struct BladeSource {
    path: String,
    mesh: OnceLock<Result<BladeMesh, BladeError>>,
}

impl BladeFile {
    /// A reference to `path`, not read yet.
    pub fn new(path: impl Into<String>) -> Self {
        BladeFile(Box::leak(Box::new(BladeSource {
            path: path.into(),
            mesh: OnceLock::new(),
        })))
    }

    /// A file already read (for scenes built in code).
    pub fn loaded(path: impl Into<String>, mesh: Result<BladeMesh, BladeError>) -> Self {
        let file = Self::new(path);
        let _ = file.0.mesh.set(mesh);
        file
    }

    /// The path as the scene writes it.
    pub fn path(&self) -> &'static str {
        &self.0.path
    }

    /// Reads the file relative to `scene_dir` (once: later calls keep the first result).
    pub fn load(&self, scene_dir: &Path) {
        self.0
            .mesh
            .get_or_init(|| BladeMesh::load(&scene_dir.join(&self.0.path)));
    }

    /// The mesh, or why it could not be read; `None` before [`BladeFile::load`].
    pub fn state(&self) -> Option<&'static Result<BladeMesh, BladeError>> {
        self.0.mesh.get()
    }

    /// The mesh of a validated scene (validation refuses a scene whose blade did not load).
    pub fn mesh(&self) -> &'static BladeMesh {
        match self.state() {
            Some(Ok(mesh)) => mesh,
            _ => panic!(
                "blade mesh {} used before a successful load (the scene was not validated)",
                self.path()
            ),
        }
    }
}

impl PartialEq for BladeFile {
    fn eq(&self, other: &Self) -> bool {
        std::ptr::eq(self.0, other.0)
    }
}

impl fmt::Debug for BladeFile {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}", self.path())
    }
}

impl Serialize for BladeFile {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.path())
    }
}

impl<'de> Deserialize<'de> for BladeFile {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        String::deserialize(d).map(BladeFile::new)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat rectangle in the xz plane, `length` along x centred on 0, from z = 0 (the
    /// spine, written as an `l` line) down to z = −`height`, as `columns` quads.
    pub fn flat_blade(length: f32, height: f32, columns: usize) -> String {
        let mut text = String::new();
        for i in 0..=columns {
            let x = -0.5 * length + length * i as f32 / columns as f32;
            text += &format!("v {x} 0 0\nv {x} 0 {}\n", -height);
        }
        for i in 0..columns {
            let (a, b) = (2 * i + 1, 2 * i + 3);
            text += &format!("f {a} {} {} {b}\n", a + 1, b + 1);
        }
        let spine: Vec<String> = (0..=columns).map(|i| (2 * i + 1).to_string()).collect();
        text + &format!("l {}\n", spine.join(" "))
    }

    fn blade(text: &str) -> Result<BladeMesh, BladeError> {
        BladeMesh::from_obj(obj::parse(text).unwrap(), Path::new("blade.obj"))
    }

    #[test]
    fn a_flat_blade_cuts_as_the_quad_does() {
        let (l, h, band) = (0.03, 0.02, 0.003);
        let mesh = blade(&flat_blade(l, h, 3)).unwrap();
        assert_eq!(mesh.cutting_edges().len(), 5, "3 bottom + 2 side segments");
        assert!((mesh.height() - h).abs() < 1e-7);
        for p in [
            Vec3::new(0.0, -0.001, -0.019),
            Vec3::new(0.0, 0.001, -0.021),
            Vec3::new(0.0, 0.001, -0.01),
            Vec3::new(0.0, 0.004, -0.019),
            Vec3::new(0.005, 0.0007, -0.0185),
            Vec3::new(0.01, -0.0002, -0.0199),
            Vec3::new(0.0, 0.001, 0.001),
        ] {
            let quad = super::super::slicer::edge_passing(p, l, h, band);
            let from_mesh = mesh.edge_passing(p, band).map(|(n, d)| n.y.signum() * d);
            assert_eq!(quad, from_mesh, "{p:?}");
        }
    }

    #[test]
    fn only_points_the_surface_covers_are_cut_and_the_spine_pushes() {
        let mesh = blade(&flat_blade(0.03, 0.02, 2)).unwrap();
        // Beyond the outline near the edge (below it, or past the side): not reached.
        assert!(mesh
            .edge_passing(Vec3::new(0.0, 0.0, -0.0201), 0.003)
            .is_none());
        // A side is a cutting edge too: a point just inside it is cut.
        assert!(mesh
            .edge_passing(Vec3::new(0.0145, 0.0005, -0.01), 0.003)
            .is_some());
        let hit = mesh.spine_distance(Vec3::new(0.002, 0.0, 0.003), 0.0004);
        assert!((hit.distance - (0.003 - 0.0002)).abs() < 1e-6, "{hit:?}");
        assert!((hit.normal - Vec3::z()).norm() < 1e-6);
    }

    #[test]
    fn at_a_bend_the_crack_is_normal_to_the_offset() {
        // Two faces folded along the interior edge x = 0 (a roof ridge along z, y up).
        let text = "v -0.01 -0.002 0\nv 0 0 0\nv 0.01 -0.002 0\n\
                    v -0.01 -0.002 -0.02\nv 0 0 -0.02\nv 0.01 -0.002 -0.02\n\
                    f 1 2 5 4\nf 2 3 6 5\nl 1 2 3\n";
        let mesh = blade(text).unwrap();
        let (normal, distance) = mesh
            .edge_passing(Vec3::new(0.0, 0.001, -0.019), 0.003)
            .unwrap();
        assert!((normal - Vec3::y()).norm() < 1e-5, "{normal:?}");
        assert!((distance - 0.001).abs() < 1e-6);
    }

    #[test]
    fn bad_blades_are_refused_with_their_line() {
        let flat = flat_blade(0.03, 0.02, 1);
        let cases: [(String, Option<usize>, &str); 5] = [
            ("v 0 0 0\nl 1 1\n".into(), None, "no faces"),
            (
                "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\nl 1 2\n".into(),
                Some(4),
                "degenerate",
            ),
            (
                flat.lines()
                    .filter(|l| !l.starts_with('l'))
                    .collect::<Vec<_>>()
                    .join("\n"),
                None,
                "no spine",
            ),
            (
                flat.replace("l 1 3", "l 1 4"),
                Some(6),
                "not a boundary edge",
            ),
            (
                flat.replace("l 1 3", "l 1 3 4 2 1"),
                None,
                "no cutting edge",
            ),
        ];
        for (text, line, what) in cases {
            let err = blade(&text).unwrap_err();
            assert_eq!(err.line, line, "{text}: {err}");
            assert!(err.to_string().contains(what), "{err}");
            assert!(err.to_string().starts_with("blade.obj"), "{err}");
        }
    }
}
