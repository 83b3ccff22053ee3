//! What the camera sees, as one labelled triangle list in the world frame: the tissue's
//! surface, each tool tessellated from its shape, each thread as a tube, and the table.

use crate::math::Vec3;
use crate::output::isosurface;
use crate::output::mesh::{SpatialHash, TissueMesh};
use crate::output::snapshot::on_cut_face;
use crate::output::strain::{colour_range, StrainMeasure};
use crate::output::SurfaceKind;
use crate::sim::setup::surface_choice;
use crate::tools::sdf::jaw_angle;
use crate::tools::Shape;
use crate::world::World;
use bytemuck::{Pod, Zeroable};
use nalgebra::{Isometry3, Rotation3, Translation3, UnitQuaternion};

/// Label of pixels where nothing was drawn.
pub const LABEL_NONE: u8 = 0;
/// Label of the table.
pub const LABEL_TABLE: u8 = 1;
/// Label of tissue block 0; block i is `LABEL_TISSUE + i` (at most 40 blocks).
pub const LABEL_TISSUE: u8 = 10;
/// Label of thread 0; thread i is `LABEL_THREAD + i` (at most 50 threads).
pub const LABEL_THREAD: u8 = 50;
/// Label of tool 0 in scene order (needles and blades included); tool i is
/// `LABEL_TOOL + i` (at most 155 tools).
pub const LABEL_TOOL: u8 = 100;

/// Tissue's colour (linear RGB): a pale pink.
pub const TISSUE_COLOUR: [f32; 3] = [0.80, 0.42, 0.40];
const TOOL_COLOUR: [f32; 3] = [0.62, 0.64, 0.68];
const THREAD_COLOUR: [f32; 3] = [0.35, 0.2, 0.75];
const TABLE_COLOURS: [[f32; 3]; 2] = [[0.30, 0.42, 0.36], [0.26, 0.37, 0.32]];

/// A triangle corner as the renderer takes it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Vertex {
    /// World position, m.
    pub position: [f32; 3],
    /// Unit normal, world frame (lighting is two-sided).
    pub normal: [f32; 3],
    /// Linear RGB.
    pub colour: [f32; 3],
    /// Label (see the `LABEL_` constants), as u32 for the vertex format.
    pub label: u32,
}

/// A triangle list under construction.
#[derive(Clone, Debug, Default)]
pub struct Triangles {
    /// Three vertices a triangle.
    pub vertices: Vec<Vertex>,
}

impl Triangles {
    fn push(&mut self, corners: [Vec3; 3], normals: [Vec3; 3], colour: [f32; 3], label: u8) {
        if !corners.iter().all(|c| c.iter().all(|v| v.is_finite())) {
            return;
        }
        for (p, n) in corners.into_iter().zip(normals) {
            self.vertices.push(Vertex {
                position: p.into(),
                normal: n.into(),
                colour,
                label: label as u32,
            });
        }
    }

    /// A tissue surface: `triangles` over `vertices` with their `normals` and `colours`,
    /// each triangle labelled by its first corner's tissue block (`blocks`); triangles with
    /// a non-finite corner are left out.
    fn tissue(
        &mut self,
        vertices: &[Vec3],
        normals: &[Vec3],
        triangles: &[[u32; 3]],
        colours: &[[f32; 3]],
        blocks: &[u16],
    ) {
        for t in triangles {
            let [a, b, c] = t.map(|i| i as usize);
            if ![a, b, c]
                .iter()
                .all(|&v| vertices[v].iter().all(|x| x.is_finite()))
            {
                continue;
            }
            let label = LABEL_TISSUE.saturating_add(blocks[a].min(39) as u8);
            for v in [a, b, c] {
                self.vertices.push(Vertex {
                    position: vertices[v].into(),
                    normal: normals[v].into(),
                    colour: colours[v],
                    label: label as u32,
                });
            }
        }
    }

    /// A box of half extents `half` centred at `pose`.
    pub fn cuboid(&mut self, pose: &Isometry3<f32>, half: Vec3, colour: [f32; 3], label: u8) {
        for axis in 0..3 {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            for sign in [-1.0f32, 1.0] {
                let corner = |a: f32, b: f32| {
                    let mut p = Vec3::zeros();
                    p[axis] = sign * half[axis];
                    p[u] = a * half[u];
                    p[v] = b * half[v];
                    pose * nalgebra::Point3::from(p)
                };
                let q = [
                    corner(-1.0, -1.0),
                    corner(1.0, -1.0),
                    corner(1.0, 1.0),
                    corner(-1.0, 1.0),
                ]
                .map(|p| p.coords);
                let mut n = Vec3::zeros();
                n[axis] = sign;
                let n = pose.rotation * n;
                self.push([q[0], q[1], q[2]], [n; 3], colour, label);
                self.push([q[0], q[2], q[3]], [n; 3], colour, label);
            }
        }
    }

    /// A tube of radius `radius` along `points` (open ends), `sides` faces round.
    pub fn tube(
        &mut self,
        points: &[Vec3],
        radius: f32,
        sides: usize,
        colour: [f32; 3],
        label: u8,
    ) {
        if points.len() < 2 {
            return;
        }
        // A frame carried along the curve by parallel transport, so the tube does not twist.
        let first = (points[1] - points[0])
            .try_normalize(1e-12)
            .unwrap_or(Vec3::z());
        let mut normal = first.cross(&Vec3::x());
        if normal.norm() < 1e-3 {
            normal = first.cross(&Vec3::y());
        }
        let mut normal = normal.normalize();
        let mut rings: Vec<Vec<(Vec3, Vec3)>> = Vec::with_capacity(points.len());
        for (i, p) in points.iter().enumerate() {
            let ahead = points[(i + 1).min(points.len() - 1)] - points[i.saturating_sub(1)];
            let tangent = ahead.try_normalize(1e-12).unwrap_or(first);
            normal = (normal - tangent * normal.dot(&tangent))
                .try_normalize(1e-12)
                .unwrap_or(normal);
            let binormal = tangent.cross(&normal);
            rings.push(
                (0..sides)
                    .map(|k| {
                        let a = std::f32::consts::TAU * k as f32 / sides as f32;
                        let n = normal * a.cos() + binormal * a.sin();
                        (p + n * radius, n)
                    })
                    .collect(),
            );
        }
        for pair in rings.windows(2) {
            for k in 0..sides {
                let k1 = (k + 1) % sides;
                let (a, b, c, d) = (pair[0][k], pair[0][k1], pair[1][k1], pair[1][k]);
                self.push([a.0, b.0, c.0], [a.1, b.1, c.1], colour, label);
                self.push([a.0, c.0, d.0], [a.1, c.1, d.1], colour, label);
            }
        }
    }

    /// A sphere-swept segment from `a` to `b` (a sphere when they coincide): a tube with
    /// hemispherical caps.
    fn capsule(&mut self, a: Vec3, b: Vec3, radius: f32, colour: [f32; 3], label: u8) {
        let axis = (b - a).try_normalize(1e-12).unwrap_or(Vec3::z());
        let mut u = axis.cross(&Vec3::x());
        if u.norm() < 1e-3 {
            u = axis.cross(&Vec3::y());
        }
        let u = u.normalize();
        let w = axis.cross(&u);
        const RINGS: usize = 8;
        const SIDES: usize = 16;
        // Latitudes from the −axis pole to the +axis pole; the lower half about a, the upper
        // about b.
        let mut rings: Vec<Vec<(Vec3, Vec3)>> = Vec::new();
        for j in 0..=2 * RINGS {
            let lat =
                -std::f32::consts::FRAC_PI_2 + std::f32::consts::PI * j as f32 / (2 * RINGS) as f32;
            let centre = if j <= RINGS { a } else { b };
            let mut ring = Vec::with_capacity(SIDES);
            for k in 0..SIDES {
                let lon = std::f32::consts::TAU * k as f32 / SIDES as f32;
                let n = axis * lat.sin() + (u * lon.cos() + w * lon.sin()) * lat.cos();
                ring.push((centre + n * radius, n));
            }
            rings.push(ring);
            if j == RINGS {
                // The equator again about b: the cylinder between the caps.
                rings.push(
                    (0..SIDES)
                        .map(|k| {
                            let lon = std::f32::consts::TAU * k as f32 / SIDES as f32;
                            let n = u * lon.cos() + w * lon.sin();
                            (b + n * radius, n)
                        })
                        .collect(),
                );
            }
        }
        for pair in rings.windows(2) {
            for k in 0..SIDES {
                let k1 = (k + 1) % SIDES;
                let (p, q, r, s) = (pair[0][k], pair[0][k1], pair[1][k1], pair[1][k]);
                self.push([p.0, q.0, r.0], [p.1, q.1, r.1], colour, label);
                self.push([p.0, r.0, s.0], [p.1, r.1, s.1], colour, label);
            }
        }
    }

    /// A tool of `shape` at `pose` (world from tool) with its jaws `opening` rad apart.
    pub fn tool(&mut self, shape: &Shape, pose: &Isometry3<f32>, opening: f32, label: u8) {
        let c = TOOL_COLOUR;
        let at = |p: Vec3| (pose * nalgebra::Point3::from(p)).coords;
        match *shape {
            Shape::Sphere { radius } => {
                let o = at(Vec3::zeros());
                self.capsule(o, o, radius, c, label)
            }
            Shape::Capsule {
                radius,
                half_length,
            } => self.capsule(
                at(Vec3::new(0.0, 0.0, -half_length)),
                at(Vec3::new(0.0, 0.0, half_length)),
                radius,
                c,
                label,
            ),
            Shape::Box { half_extents } => self.cuboid(pose, half_extents.into(), c, label),
            Shape::Gripper {
                jaw_length,
                jaw_width,
                jaw_thickness,
            } => {
                // As the SDF: each jaw a box from the hinge along +z, turned about x.
                let half = Vec3::new(0.5 * jaw_width, 0.5 * jaw_thickness, 0.5 * jaw_length);
                for part in [1u8, 2] {
                    let side = if part == 1 { 1.0 } else { -1.0 };
                    let turn =
                        UnitQuaternion::from_axis_angle(&Vec3::x_axis(), jaw_angle(part, opening));
                    let jaw = pose
                        * Isometry3::from_parts(Translation3::identity(), turn)
                        * Translation3::new(0.0, side * 0.5 * jaw_thickness, 0.5 * jaw_length);
                    self.cuboid(&jaw, half, c, label);
                }
            }
            Shape::Needle {
                radius,
                arc_angle,
                wire_radius,
            } => {
                let n = ((arc_angle / 0.1).ceil() as usize).max(4);
                let points: Vec<Vec3> = (0..=n)
                    .map(|k| {
                        let a = arc_angle * k as f32 / n as f32;
                        at(Vec3::new(radius * a.cos(), radius * a.sin(), 0.0))
                    })
                    .collect();
                self.tube(&points, wire_radius, 10, c, label);
            }
            Shape::Slicer {
                length,
                height,
                thickness,
            } => {
                let centre = pose * Translation3::new(0.0, 0.0, -0.5 * height);
                let half = Vec3::new(0.5 * length, 0.5 * thickness, 0.5 * height);
                self.cuboid(&centre, half, c, label);
            }
            Shape::MeshSlicer { file, .. } => {
                let r = pose.rotation;
                for t in file.mesh().triangles() {
                    let n = r * t.normal;
                    self.push(t.corners.map(at), [n; 3], c, label);
                }
            }
        }
    }

    /// The table at height `z` over the square `lo`–`hi` (x, y), in 5 mm tiles of two shades.
    pub fn table(&mut self, z: f32, lo: [f32; 2], hi: [f32; 2]) {
        const TILE: f32 = 0.005;
        let nx = (((hi[0] - lo[0]) / TILE).ceil() as usize).clamp(1, 400);
        let ny = (((hi[1] - lo[1]) / TILE).ceil() as usize).clamp(1, 400);
        let (sx, sy) = ((hi[0] - lo[0]) / nx as f32, (hi[1] - lo[1]) / ny as f32);
        for j in 0..ny {
            for i in 0..nx {
                let x0 = lo[0] + sx * i as f32;
                let y0 = lo[1] + sy * j as f32;
                let p = |a: f32, b: f32| Vec3::new(x0 + a * sx, y0 + b * sy, z);
                let colour = TABLE_COLOURS[(i + j) % 2];
                let n = [Vec3::z(); 3];
                self.push(
                    [p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0)],
                    n,
                    colour,
                    LABEL_TABLE,
                );
                self.push(
                    [p(0.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)],
                    n,
                    colour,
                    LABEL_TABLE,
                );
            }
        }
    }
}

/// How the tissue's surface is drawn: as the scene's outputs publish it.
enum TissueDrawing {
    /// The rest surface's mesh carried by the particles, with each vertex's tissue block.
    Mesh {
        mesh: Box<TissueMesh>,
        vertex_block: Vec<u16>,
    },
    /// The level set extracted afresh each frame (tissue that is cut or tears, whose
    /// topology the mesh cannot follow), on a lattice of spacing `cell` (m).
    Isosurface { cell: f32 },
}

/// The tissue surface as the GPU solver can build it (see
/// [`SceneGeometry::device_drawable`]).
pub enum DeviceDrawable<'a> {
    /// The rest mesh with each vertex's tissue block.
    Mesh(&'a TissueMesh, &'a [u16]),
    /// The level set on a lattice of spacing `cell` (m).
    LevelSet {
        /// Lattice spacing, m.
        cell: f32,
    },
}

/// Builds a world's triangles each frame; holds the tissue mesh bound to the particles.
pub struct SceneGeometry {
    /// The tissue surface (None: no tissue).
    tissue: Option<TissueDrawing>,
    /// Strain measure the tissue is coloured by; `None`: the tissue colour.
    strain: Option<StrainMeasure>,
    /// Strain at the top of the colour scale; `None`: the 98th percentile over the surface.
    strain_range: Option<f32>,
    /// The strain range of the last frame coloured by strain.
    last_strain_range: Option<f32>,
    /// Colour of the surface over a cut's faces (`None`: not marked).
    cut_faces: Option<[f32; 3]>,
    /// Threads are drawn at least this thick (m): a picture framing a whole scene would
    /// lose a 0.1 mm thread between its pixels.
    min_thread_radius: f32,
}

impl SceneGeometry {
    /// The geometry of `world` (the tissue mesh bound to the scene's particles at rest);
    /// `strain`: colour the tissue by that measure instead of its
    /// colour. The tissue is drawn as the scene's surface output is (see
    /// [`crate::sim::setup::surface_kind`]): the isosurface where it is cut or tears.
    pub fn new(
        world: &World,
        strain: Option<StrainMeasure>,
    ) -> Result<SceneGeometry, crate::output::mesh::MeshError> {
        let particles = &world.rest_particles();
        let cell = world.scene().domain.dx as f32;
        let tissue = if particles.is_empty() {
            None
        } else if surface_choice(world.scene()).0 == SurfaceKind::Isosurface {
            Some(TissueDrawing::Isosurface { cell })
        } else {
            let mesh = TissueMesh::build(particles, cell)?;
            let vertex_block = (0..mesh.vertices.len())
                .map(|v| particles.material[mesh.first_particle(v) as usize])
                .collect();
            Some(TissueDrawing::Mesh {
                mesh: Box::new(mesh),
                vertex_block,
            })
        };
        Ok(SceneGeometry {
            tissue,
            strain,
            strain_range: None,
            last_strain_range: None,
            cut_faces: None,
            min_thread_radius: 0.0,
        })
    }

    /// Colours strain up to `range` at the top of the scale (`None`: the 98th percentile
    /// over the surface, frame by frame).
    pub fn with_strain_range(mut self, range: Option<f32>) -> Self {
        self.strain_range = range;
        self
    }

    /// Colours the isosurface `colour` where its nearest particle lies on a cut's face (the
    /// particle layer next to the blade's plane), so a picture shows where the blade cut.
    pub fn with_cut_faces(mut self, colour: [f32; 3]) -> Self {
        self.cut_faces = Some(colour);
        self
    }

    /// Draws threads at least `radius` (m) thick, so that they show in a picture whose
    /// pixels are wider than a thread.
    pub fn set_min_thread_radius(&mut self, radius: f32) {
        self.min_thread_radius = radius;
    }

    /// The strain at the top of the colour scale in the last frame coloured by strain.
    pub fn last_strain_range(&self) -> Option<f32> {
        self.last_strain_range
    }

    /// The tissue's surface where the camera may draw it from the GPU solver's buffers:
    /// in the tissue colour (strain colours need the deformation gradients on the host)
    /// and not marking cut faces.
    pub fn device_drawable(&self) -> Option<DeviceDrawable<'_>> {
        match (&self.tissue, self.strain, self.cut_faces) {
            (Some(TissueDrawing::Mesh { mesh, vertex_block }), None, None) => {
                Some(DeviceDrawable::Mesh(mesh, vertex_block))
            }
            (Some(TissueDrawing::Isosurface { cell }), None, None) => {
                Some(DeviceDrawable::LevelSet { cell: *cell })
            }
            _ => None,
        }
    }

    /// The world's triangles now (particles as the backend last read them back).
    pub fn triangles(&mut self, world: &World) -> Triangles {
        self.scene_triangles(world, true)
    }

    /// The world's triangles now but the tissue's, which the renderer draws from the
    /// device (see [`SceneGeometry::device_drawable`]).
    pub fn triangles_around_tissue(&mut self, world: &World) -> Triangles {
        self.scene_triangles(world, false)
    }

    fn scene_triangles(&mut self, world: &World, with_tissue: bool) -> Triangles {
        let mut out = Triangles::default();
        let scene = world.scene();
        if let Some(table) = &scene.table {
            let o = scene.domain.origin;
            let s = scene.domain.size;
            // Beyond the domain, so the table fills the view's lower edge.
            out.table(
                table.height as f32,
                [(o[0] - 0.5 * s[0]) as f32, (o[1] - 0.5 * s[1]) as f32],
                [(o[0] + 1.5 * s[0]) as f32, (o[1] + 1.5 * s[1]) as f32],
            );
        }
        let particles = world.particles();
        let (strain, range) = (self.strain, self.strain_range);
        let mut used_range = None;
        let tissue = if with_tissue {
            &mut self.tissue
        } else {
            &mut None
        };
        match tissue {
            Some(TissueDrawing::Mesh { mesh, vertex_block }) => {
                mesh.update(&particles.x);
                let colours = strain_colours(strain, range, particles, |values| {
                    mesh.vertex_values(values)
                });
                used_range = colours.as_ref().map(|c| c.1);
                let colours =
                    colours.map_or_else(|| vec![TISSUE_COLOUR; mesh.vertices.len()], |c| c.0);
                let blocks = vertex_block.as_slice();
                out.tissue(
                    &mesh.vertices,
                    &mesh.normals,
                    &mesh.triangles,
                    &colours,
                    blocks,
                );
            }
            Some(TissueDrawing::Isosurface { cell }) => {
                let surface = isosurface::extract(particles, *cell);
                // Each vertex takes its block and strain from the particle nearest it
                // (a vertex of the ½ level set lies within a lattice cell of one).
                let near = SpatialHash::new(
                    particles.x.iter().enumerate().map(|(i, &x)| (i as u32, x)),
                    *cell,
                );
                let nearest: Vec<Option<u32>> = surface
                    .vertices
                    .iter()
                    .map(|&v| near.nearest(v, *cell))
                    .collect();
                let blocks: Vec<u16> = nearest
                    .iter()
                    .map(|p| p.map_or(0, |p| particles.material[p as usize]))
                    .collect();
                let colours = strain_colours(strain, range, particles, |values| {
                    let of = |p: &Option<u32>| p.map_or(0.0, |p| values[p as usize]);
                    nearest.iter().map(of).collect()
                });
                used_range = colours.as_ref().map(|c| c.1);
                let mut colours =
                    colours.map_or_else(|| vec![TISSUE_COLOUR; surface.vertices.len()], |c| c.0);
                if let Some(face) = self.cut_faces {
                    let spacing = particles.volume0.first().map_or(*cell, |v| v.cbrt());
                    for (colour, p) in colours.iter_mut().zip(&nearest) {
                        let crack = p.and_then(|p| particles.crack.get(p as usize));
                        if crack.is_some_and(|&c| on_cut_face(c, spacing)) {
                            *colour = face;
                        }
                    }
                }
                out.tissue(
                    &surface.vertices,
                    &surface.normals,
                    &surface.triangles,
                    &colours,
                    &blocks,
                );
            }
            None => {}
        }
        if used_range.is_some() {
            self.last_strain_range = used_range;
        }
        for (i, thread) in world.threads().iter().enumerate() {
            let label = LABEL_THREAD.saturating_add(i.min(49) as u8);
            out.tube(
                &thread.rod.points,
                thread.rod.material.radius.max(self.min_thread_radius),
                6,
                THREAD_COLOUR,
                label,
            );
        }
        for (i, tool) in world.tools().iter().enumerate() {
            let pose = tool.pose_at(world.time());
            let iso = Isometry3::from_parts(
                Translation3::from(pose.position.cast::<f32>()),
                UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(
                    pose.rotation
                        .to_rotation_matrix()
                        .into_inner()
                        .cast::<f32>(),
                )),
            );
            let label = LABEL_TOOL.saturating_add(i.min(155) as u8);
            out.tool(&tool.shape, &iso, pose.jaw as f32, label);
        }
        out
    }
}

/// The tissue's vertex colours by `strain` (`None`: coloured as tissue) with the strain at
/// the top of the scale (`range`, or the 98th percentile of the vertices' values), the
/// particles' values carried to the vertices by `at_vertices`.
fn strain_colours(
    strain: Option<StrainMeasure>,
    range: Option<f32>,
    particles: &crate::mpm::Particles,
    at_vertices: impl FnOnce(&[f32]) -> Vec<f32>,
) -> Option<(Vec<[f32; 3]>, f32)> {
    let measure = strain?;
    let values = at_vertices(&measure.values(particles));
    let range = range.unwrap_or_else(|| colour_range(&values));
    let colours = values
        .iter()
        .map(|&v| measure.colour(v, range).into())
        .collect();
    Some((colours, range))
}
