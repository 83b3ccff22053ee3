//! Still pictures through the camera's renderer: what `snapshot` and `run --snapshot-every`
//! draw, so a picture of a scene is what the endoscope would see of it. The tissue, tools
//! and threads are framed from an azimuth and an elevation about them, seen by one eye; the
//! tissue is coloured by strain and, where a blade cut it, the surface over the cut's faces
//! is marked (see [`crate::output::snapshot`] for the options and the fallback).

use super::camera::{look_at, stereo_eyes, Pinhole};
use super::geometry::SceneGeometry;
use super::gpu::{RenderError, Renderer};
use crate::math::Vec3;
use crate::output::snapshot::{cut_face_colour, on_cut_face, Snapshot, SnapshotOptions};
use crate::world::World;
use nalgebra::Isometry3;

/// Vertical field of view of a picture.
const VERTICAL_FOV_DEG: f32 = 30.0;

/// The renderer and the scene's geometry, kept from picture to picture.
pub struct Picture {
    renderer: Renderer,
    geometry: SceneGeometry,
}

impl Picture {
    /// Opens the renderer's device and binds the tissue's surface to the scene at rest.
    pub fn new(world: &World, opts: &SnapshotOptions) -> Result<Picture, RenderError> {
        let renderer = Renderer::new()?;
        let geometry = SceneGeometry::new(world, Some(opts.measure))
            .map_err(|e| RenderError::Device(format!("the tissue surface: {e}")))?
            .with_strain_range(opts.strain_range)
            .with_cut_faces(cut_face_colour(opts.measure).into());
        Ok(Picture { renderer, geometry })
    }

    /// The world as it is now.
    pub fn draw(&mut self, world: &World, opts: &SnapshotOptions) -> Result<Snapshot, RenderError> {
        let (pose, pinhole, distance) = framing(world, opts);
        // A thread at least a pixel and a half wide at the scene's centre.
        self.geometry
            .set_min_thread_radius(0.75 * distance / pinhole.focal);
        let triangles = self.geometry.triangles(world);
        let frame = self
            .renderer
            .render(&triangles.vertices, &stereo_eyes(&pose, pinhole, 0.0))?;
        let particles = world.particles();
        let spacing = particles
            .volume0
            .first()
            .map_or(world.scene().domain.dx as f32, |v| v.cbrt());
        Ok(Snapshot {
            width: frame.width,
            height: frame.height,
            rgb: frame.rgb,
            strain_range: self.geometry.last_strain_range().unwrap_or(0.0),
            cut_face_particles: particles
                .crack
                .iter()
                .filter(|&&c| on_cut_face(c, spacing))
                .count(),
        })
    }
}

/// Where the picture is taken from: the bounding sphere of the tissue, the tools and the
/// threads seen from `opts`' azimuth and elevation, filling the picture's height; with the
/// distance from the eye to the sphere's centre (m).
pub fn framing(world: &World, opts: &SnapshotOptions) -> (Isometry3<f32>, Pinhole, f32) {
    let mut lo = Vec3::repeat(f32::INFINITY);
    let mut hi = Vec3::repeat(f32::NEG_INFINITY);
    let mut include = |a: Vec3, b: Vec3| {
        if a.iter().chain(b.iter()).all(|v| v.is_finite()) {
            lo = lo.inf(&a);
            hi = hi.sup(&b);
        }
    };
    for x in &world.particles().x {
        include(*x, *x);
    }
    for tool in world.tools() {
        let at: Vec3 = tool.pose_at(world.time()).position.cast();
        let reach = Vec3::repeat(tool.shape.bounding_radius());
        include(at - reach, at + reach);
    }
    for x in world.threads().iter().flat_map(|t| &t.rod.points) {
        include(*x, *x);
    }
    if lo.x > hi.x {
        let d = &world.scene().domain;
        (lo, hi) = (
            Vec3::from(d.origin.map(|v| v as f32)),
            Vec3::from(std::array::from_fn(|i| (d.origin[i] + d.size[i]) as f32)),
        );
    }
    let centre = (lo + hi) * 0.5;
    let radius = ((hi - lo) * 0.5).norm().max(1e-3);
    let half_fov = 0.5 * VERTICAL_FOV_DEG.to_radians();
    let (az, el) = (
        opts.azimuth_deg.to_radians(),
        opts.elevation_deg.to_radians(),
    );
    let direction = Vec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
    let distance = radius / half_fov.sin() * 1.05;
    let pose = look_at(centre + direction * distance, centre);
    let aspect = opts.width as f32 / opts.height.max(1) as f32;
    let hfov = 2.0 * (half_fov.tan() * aspect).atan();
    let near = (distance - 2.0 * radius).max(1e-3);
    let far = distance + 50.0 * radius;
    let pinhole = Pinhole::from_hfov(opts.width, opts.height, hfov as f64, near, far);
    (pose, pinhole, distance)
}
