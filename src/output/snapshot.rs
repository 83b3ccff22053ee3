//! Headless pictures of a scene, drawn by the endoscope camera's renderer
//! ([`crate::render::picture`]: wgpu on a hardware GPU, or Mesa's llvmpipe on the CPU), so a
//! picture is what the camera would see: the tissue's surface coloured by strain, the
//! surface over the faces of a cut marked (red, or green against the volume-change map),
//! tools from their shapes, threads as tubes, the table in 5 mm tiles.
//!
//! On a machine with no GPU adapter at all (not even a software one) the pictures fall back
//! to a CPU splat renderer ([`render_splats`], said once in the log): each particle a
//! shaded sphere, tools ray-marched from their signed distance functions, the table as a
//! checkerboard. It stays for that case only, so `snapshot` works on every machine.

use super::strain::{self, StrainMeasure};
use crate::math::Vec3;
use crate::render::picture::Picture;
use crate::tools::Shape;
use crate::world::World;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

#[derive(Clone, Debug)]
/// How a snapshot is drawn.
pub struct SnapshotOptions {
    /// Picture width, pixels.
    pub width: u32,
    /// Picture height, pixels.
    pub height: u32,
    /// Camera direction about the scene centre: azimuth from +x towards +y, elevation
    /// above the xy plane (degrees).
    pub azimuth_deg: f32,
    /// Camera elevation above the xy plane, degrees (see `azimuth_deg`).
    pub elevation_deg: f32,
    /// Which strain the tissue is coloured by.
    pub measure: StrainMeasure,
    /// Strain at the top of the colour scale; by default the 98th percentile of |strain|.
    pub strain_range: Option<f32>,
}

impl Default for SnapshotOptions {
    fn default() -> Self {
        SnapshotOptions {
            width: 960,
            height: 640,
            azimuth_deg: -60.0,
            elevation_deg: 35.0,
            measure: StrainMeasure::Equivalent,
            strain_range: None,
        }
    }
}

/// An RGB picture, the strain range its colours span, and how many particles it draws on
/// the faces of a cut.
pub struct Snapshot {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Pixels row by row from the top, 3 bytes (R, G, B) each.
    pub rgb: Vec<u8>,
    /// Strain at the top of the colour scale.
    pub strain_range: f32,
    /// Particles drawn on the faces of a cut (in red).
    pub cut_face_particles: usize,
}

/// Colour of the particles on a cut's faces, outside the strain colour map so that a picture
/// shows where the blade has cut: red against the shape-change map (dark purple to
/// yellow), green against the signed volume-change map (blue, grey, red).
pub fn cut_face_colour(measure: StrainMeasure) -> Vec3 {
    if measure.is_signed() {
        Vec3::new(0.1, 0.75, 0.2)
    } else {
        Vec3::new(0.9, 0.12, 0.1)
    }
}

/// Whether a particle with crack `crack` (see [`crate::mpm::crack`]) lies on a face of the
/// cut: its crack plane is nearer than one particle spacing, i.e. it is in the particle
/// layer next to the cut (particles further from the plane carry a crack too, up to a
/// stencil's reach, but lie inside their piece).
pub(crate) fn on_cut_face(crack: Vec3, spacing: f32) -> bool {
    crack != Vec3::zeros() && crack.norm() < spacing
}

impl Snapshot {
    /// Writes the picture as an 8-bit RGB PNG.
    pub fn write_png(&self, path: &Path) -> std::io::Result<()> {
        let file = std::fs::File::create(path)?;
        let mut encoder = png::Encoder::new(BufWriter::new(file), self.width, self.height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(std::io::Error::other)?;
        writer
            .write_image_data(&self.rgb)
            .map_err(std::io::Error::other)
    }
}

/// Pictures at regular simulated times during a run, written as `DIR/t<seconds>.png`.
pub struct SnapshotSchedule {
    /// Simulated seconds between pictures (> 0).
    pub every: f64,
    /// Directory the pictures are written to.
    pub dir: PathBuf,
    /// How each picture is drawn.
    pub options: SnapshotOptions,
    next: f64,
    /// The renderer, opened at the first picture.
    picture: Option<Picture>,
    /// No renderer can run: pictures are splats.
    splats: bool,
}

/// A copy opens its own renderer at its first picture.
impl Clone for SnapshotSchedule {
    fn clone(&self) -> Self {
        SnapshotSchedule {
            every: self.every,
            dir: self.dir.clone(),
            options: self.options.clone(),
            next: self.next,
            picture: None,
            splats: false,
        }
    }
}

impl std::fmt::Debug for SnapshotSchedule {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SnapshotSchedule")
            .field("every", &self.every)
            .field("dir", &self.dir)
            .field("options", &self.options)
            .field("next", &self.next)
            .finish_non_exhaustive()
    }
}

impl SnapshotSchedule {
    /// The first picture is of the first frame at or after `every`.
    pub fn new(every: f64, dir: PathBuf, options: SnapshotOptions) -> SnapshotSchedule {
        SnapshotSchedule {
            every,
            dir,
            options,
            next: every,
            picture: None,
            splats: false,
        }
    }

    /// Writes a picture if the world's time has reached the next one, and returns its path.
    /// On the GPU the particle state is downloaded first (the picture's strain needs F).
    pub fn take_if_due(&mut self, world: &mut World) -> std::io::Result<Option<PathBuf>> {
        if world.time() + 1e-9 < self.next {
            return Ok(None);
        }
        while self.next <= world.time() + 1e-9 {
            self.next += self.every;
        }
        world.sync_particles();
        let path = self.dir.join(format!("t{:08.3}.png", world.time()));
        if self.picture.is_none() && !self.splats {
            match Picture::new(world, &self.options) {
                Ok(p) => self.picture = Some(p),
                Err(e) => {
                    warn_fallback(&e);
                    self.splats = true;
                }
            }
        }
        let picture = match &mut self.picture {
            Some(p) => p
                .draw(world, &self.options)
                .map_err(std::io::Error::other)?,
            None => render_splats(world, &self.options),
        };
        picture.write_png(&path)?;
        Ok(Some(path))
    }
}

struct Camera {
    eye: Vec3,
    right: Vec3,
    up: Vec3,
    forward: Vec3,
    focal: f32,
    cx: f32,
    cy: f32,
}

impl Camera {
    /// Screen position and depth of a world point; `None` behind the camera.
    fn project(&self, p: Vec3) -> Option<(f32, f32, f32)> {
        let d = p - self.eye;
        let z = d.dot(&self.forward);
        (z > 1e-6).then(|| {
            (
                self.cx + d.dot(&self.right) / z * self.focal,
                self.cy - d.dot(&self.up) / z * self.focal,
                z,
            )
        })
    }

    fn ray(&self, px: f32, py: f32) -> Vec3 {
        (self.forward * self.focal + self.right * (px - self.cx) - self.up * (py - self.cy))
            .normalize()
    }
}

/// Tool geometry in world space for ray marching.
struct DrawnTool {
    shape: Shape,
    rotation: nalgebra::Matrix3<f32>,
    translation: Vec3,
    jaw: f32,
    bound: f32,
}

impl DrawnTool {
    fn distance(&self, p: Vec3) -> f32 {
        let local = self.rotation.tr_mul(&(p - self.translation));
        match self.shape {
            // A wire thinner than a pixel would vanish: draw it at least 0.6 mm thick.
            Shape::Needle {
                radius,
                arc_angle,
                wire_radius,
            } => {
                crate::tools::sdf::needle(local, radius, arc_angle, wire_radius.max(6e-4)).distance
            }
            // The slicer's whole blade (contact is its spine's alone), at least 0.6 mm thick.
            Shape::Slicer {
                length,
                height,
                thickness,
            } => {
                let half = Vec3::new(0.5 * length, 0.5 * thickness.max(6e-4), 0.5 * height);
                crate::tools::sdf::cuboid(local + Vec3::new(0.0, 0.0, 0.5 * height), half).distance
            }
            // A mesh blade as a sheet at least 0.6 mm thick.
            Shape::MeshSlicer { file, thickness } => {
                file.mesh().surface_distance(local) - 0.5 * thickness.max(6e-4)
            }
            shape => shape.query(local, self.jaw).distance,
        }
    }
}

fn scene_distance(tools: &[DrawnTool], p: Vec3) -> f32 {
    tools
        .iter()
        .map(|t| t.distance(p))
        .fold(f32::INFINITY, f32::min)
}

/// Renders the world's current state through the camera's renderer, or by
/// [`render_splats`] where there is no GPU adapter at all (said once in the log).
pub fn render(world: &World, opts: &SnapshotOptions) -> Snapshot {
    match Picture::new(world, opts).and_then(|mut p| p.draw(world, opts)) {
        Ok(picture) => picture,
        Err(e) => {
            warn_fallback(&e);
            render_splats(world, opts)
        }
    }
}

/// Says once per process why pictures are splats.
fn warn_fallback(e: &crate::render::RenderError) {
    static SAID: std::sync::Once = std::sync::Once::new();
    SAID.call_once(|| {
        tracing::warn!("snapshot: the camera's renderer cannot run ({e}); drawing particles as splats on the CPU");
    });
}

/// Renders the world's current state on the CPU: particles as shaded spheres (the fallback
/// where no GPU adapter exists).
pub fn render_splats(world: &World, opts: &SnapshotOptions) -> Snapshot {
    let (w, h) = (opts.width as usize, opts.height as usize);
    let particles = world.particles();
    let tools: Vec<DrawnTool> = world
        .tools()
        .iter()
        .map(|t| {
            let pose = t.pose_at(world.time());
            DrawnTool {
                shape: t.shape,
                rotation: pose.rotation.to_rotation_matrix().into_inner().cast(),
                translation: pose.position.cast(),
                jaw: pose.jaw as f32,
                bound: t.shape.bounding_radius(),
            }
        })
        .collect();

    // Frame the tissue (and the tools near it).
    let mut lo = Vec3::repeat(f32::INFINITY);
    let mut hi = Vec3::repeat(f32::NEG_INFINITY);
    for x in &particles.x {
        lo = lo.inf(x);
        hi = hi.sup(x);
    }
    for t in &tools {
        lo = lo.inf(&(t.translation - Vec3::repeat(t.bound)));
        hi = hi.sup(&(t.translation + Vec3::repeat(t.bound)));
    }
    for x in world.threads().iter().flat_map(|t| &t.rod.points) {
        lo = lo.inf(x);
        hi = hi.sup(x);
    }
    let centre = (lo + hi) * 0.5;
    let radius = ((hi - lo) * 0.5).norm().max(1e-3);
    let fov = 30f32.to_radians();
    let (az, el) = (
        opts.azimuth_deg.to_radians(),
        opts.elevation_deg.to_radians(),
    );
    let dir = Vec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
    let eye = centre + dir * (radius / (0.5 * fov).sin() * 1.05);
    let forward = (centre - eye).normalize();
    let right = forward.cross(&Vec3::z()).normalize();
    let up = right.cross(&forward);
    let cam = Camera {
        eye,
        right,
        up,
        forward,
        focal: 0.5 * h as f32 / (0.5 * fov).tan(),
        cx: 0.5 * w as f32,
        cy: 0.5 * h as f32,
    };
    let light = (Vec3::new(0.3, -0.5, 1.0) - forward * 0.5).normalize();

    let mut depth = vec![f32::INFINITY; w * h];
    let mut rgb = vec![Vec3::zeros(); w * h];
    for y in 0..h {
        let shade = 0.97 - 0.25 * y as f32 / h as f32;
        for x in 0..w {
            rgb[y * w + x] = Vec3::new(shade, shade, shade + 0.02);
        }
    }

    // Table: checkerboard of 5 mm squares at the table height.
    if let Some(table) = &world.scene().table {
        let z0 = table.height as f32;
        for y in 0..h {
            for x in 0..w {
                let ray = cam.ray(x as f32 + 0.5, y as f32 + 0.5);
                if ray.z.abs() < 1e-6 {
                    continue;
                }
                let t = (z0 - eye.z) / ray.z;
                if t <= 0.0 {
                    continue;
                }
                let p = eye + ray * t;
                let extent = 3.0 * radius;
                if (p.x - centre.x).abs() > extent || (p.y - centre.y).abs() > extent {
                    continue;
                }
                let checker =
                    ((p.x / 0.005).floor() as i64 + (p.y / 0.005).floor() as i64).rem_euclid(2);
                let c = if checker == 0 { 0.80 } else { 0.70 };
                depth[y * w + x] = t * ray.dot(&forward);
                rgb[y * w + x] = Vec3::new(c, c * 0.98, c * 0.94);
            }
        }
    }

    // Tissue: one shaded sphere per particle, coloured by strain.
    let strains = opts.measure.values(particles);
    let strain_range = opts
        .strain_range
        .unwrap_or_else(|| strain::colour_range(&strains));
    let spacing = particles
        .volume0
        .first()
        .map_or(world.scene().domain.dx as f32, |v| v.cbrt());
    let r_world = 0.65 * spacing;
    let cut_face = cut_face_colour(opts.measure);
    let mut cut_face_particles = 0;
    for (i, (x, strain)) in particles.x.iter().zip(&strains).enumerate() {
        let on_face = particles
            .crack
            .get(i)
            .is_some_and(|c| on_cut_face(*c, spacing));
        cut_face_particles += on_face as usize;
        let Some((sx, sy, z)) = cam.project(*x) else {
            continue;
        };
        let r_px = (r_world * cam.focal / z).max(0.7);
        let base = if on_face {
            cut_face
        } else {
            opts.measure.colour(*strain, strain_range)
        };
        let (x0, x1) = (
            (sx - r_px).floor().max(0.0) as usize,
            (sx + r_px).ceil().min(w as f32 - 1.0) as usize,
        );
        let (y0, y1) = (
            (sy - r_px).floor().max(0.0) as usize,
            (sy + r_px).ceil().min(h as f32 - 1.0) as usize,
        );
        for py in y0..=y1.min(h - 1) {
            for px in x0..=x1.min(w - 1) {
                let (dx, dy) = ((px as f32 + 0.5 - sx) / r_px, (py as f32 + 0.5 - sy) / r_px);
                let q = dx * dx + dy * dy;
                if q > 1.0 {
                    continue;
                }
                let nz = (1.0 - q).sqrt();
                let d = z - nz * r_world;
                let i = py * w + px;
                if d < depth[i] {
                    depth[i] = d;
                    let normal = right * dx - up * dy - forward * nz;
                    rgb[i] = base * (0.45 + 0.55 * normal.dot(&light).max(0.0));
                }
            }
        }
    }

    // Threads: shaded discs along the centreline, a pixel or more wide (a 3-0 thread is
    // far thinner than a pixel at this framing).
    for thread in world.threads() {
        let r_world = thread.rod.material.radius;
        let colour = Vec3::new(0.35, 0.2, 0.75);
        for seg in thread.rod.points.windows(2) {
            let (Some(a), Some(b)) = (cam.project(seg[0]), cam.project(seg[1])) else {
                continue;
            };
            let steps = ((a.0 - b.0).hypot(a.1 - b.1).ceil() as usize).max(1);
            for k in 0..=steps {
                let s = k as f32 / steps as f32;
                let (sx, sy, z) = (
                    a.0 + (b.0 - a.0) * s,
                    a.1 + (b.1 - a.1) * s,
                    a.2 + (b.2 - a.2) * s,
                );
                let r_px = (r_world * cam.focal / z).max(1.2);
                let (x0, x1) = ((sx - r_px).floor(), (sx + r_px).ceil());
                let (y0, y1) = ((sy - r_px).floor(), (sy + r_px).ceil());
                if x1 < 0.0 || y1 < 0.0 || x0 >= w as f32 || y0 >= h as f32 {
                    continue;
                }
                for py in y0.max(0.0) as usize..=(y1 as usize).min(h - 1) {
                    for px in x0.max(0.0) as usize..=(x1 as usize).min(w - 1) {
                        let (dx, dy) =
                            ((px as f32 + 0.5 - sx) / r_px, (py as f32 + 0.5 - sy) / r_px);
                        let q = dx * dx + dy * dy;
                        if q > 1.0 {
                            continue;
                        }
                        let nz = (1.0 - q).sqrt();
                        let i = py * w + px;
                        // Drawn in front of the table it lies on.
                        let d = z - nz * r_world - 1e-4;
                        if d < depth[i] {
                            depth[i] = d;
                            let normal = right * dx - up * dy - forward * nz;
                            rgb[i] = colour * (0.5 + 0.5 * normal.dot(&light).max(0.0));
                        }
                    }
                }
            }
        }
    }

    // Tools: sphere tracing of the union of their SDFs, only where their bounds project.
    for tool in &tools {
        let Some((sx, sy, z)) = cam.project(tool.translation) else {
            continue;
        };
        let r_px = tool.bound * cam.focal / (z - tool.bound).max(1e-4) + 2.0;
        let (x0, x1) = (
            (sx - r_px).max(0.0) as usize,
            ((sx + r_px).max(0.0) as usize).min(w - 1),
        );
        let (y0, y1) = (
            (sy - r_px).max(0.0) as usize,
            ((sy + r_px).max(0.0) as usize).min(h - 1),
        );
        for py in y0..=y1 {
            for px in x0..=x1 {
                let ray = cam.ray(px as f32 + 0.5, py as f32 + 0.5);
                let mut t = (z - tool.bound).max(0.0) / ray.dot(&forward).max(1e-3);
                let t_max = (z + tool.bound) / ray.dot(&forward).max(1e-3);
                let eps = 2e-5 * radius.max(0.01) / 0.01;
                for _ in 0..96 {
                    let p = eye + ray * t;
                    let d = scene_distance(&tools, p);
                    if d < eps {
                        let i = py * w + px;
                        let depth_here = t * ray.dot(&forward);
                        if depth_here < depth[i] {
                            depth[i] = depth_here;
                            let e = 1e-4;
                            let n = Vec3::new(
                                scene_distance(&tools, p + Vec3::x() * e)
                                    - scene_distance(&tools, p - Vec3::x() * e),
                                scene_distance(&tools, p + Vec3::y() * e)
                                    - scene_distance(&tools, p - Vec3::y() * e),
                                scene_distance(&tools, p + Vec3::z() * e)
                                    - scene_distance(&tools, p - Vec3::z() * e),
                            )
                            .normalize();
                            let diffuse = n.dot(&light).max(0.0);
                            let spec = (ray - n * 2.0 * ray.dot(&n)).dot(&light).max(0.0).powi(24);
                            let metal = 0.30 + 0.45 * diffuse + 0.5 * spec;
                            rgb[i] = Vec3::new(metal, metal * 1.02, metal * 1.06);
                        }
                        break;
                    }
                    t += d;
                    if t > t_max {
                        break;
                    }
                }
            }
        }
    }

    Snapshot {
        width: opts.width,
        height: opts.height,
        rgb: rgb
            .iter()
            .flat_map(|c| [c.x, c.y, c.z].map(|v| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8))
            .collect(),
        strain_range,
        cut_face_particles,
    }
}
