//! The tissue surface on a scene: how far the constant-topology mesh drifts from the
//! particles as the tissue deforms, and what each surface kind costs per frame.

use dvrk_tissue_sim::config::Scene;
use dvrk_tissue_sim::output::mesh::{MeshDeviation, TissueMesh};
use dvrk_tissue_sim::output::{SurfaceKind, TissueSurface};
use dvrk_tissue_sim::world::{StepError, World, WorldError};
use std::fmt::Write;
use std::time::Instant;

/// Nearest-particle search radius of the deviation, in particle spacings: wider than any
/// rest gap (a box corner's is 0.87), so a vertex lifting off shows as such up to 4.
const GAP_RADIUS_SPACINGS: f32 = 4.0;

#[derive(Debug, thiserror::Error)]
pub enum SurfaceBenchError {
    #[error(transparent)]
    World(#[from] WorldError),
    #[error(transparent)]
    Step(#[from] StepError),
    #[error("{0}")]
    Mesh(#[from] dvrk_tissue_sim::output::mesh::MeshError),
}

/// The mesh's deviation at one time.
#[derive(Clone, Debug)]
pub struct DeviationSample {
    pub time: f64,
    pub deviation: MeshDeviation,
    /// Largest particle displacement from rest (m): how much the tissue has deformed.
    pub max_displacement: f32,
}

#[derive(Clone, Debug)]
pub struct SurfaceBench {
    pub scene: String,
    pub backend: &'static str,
    pub particles: usize,
    pub spacing: f32,
    pub vertices: usize,
    pub triangles: usize,
    /// Particle references of the mesh binding.
    pub binding: usize,
    pub samples: Vec<DeviationSample>,
    pub frames: u32,
    /// Mean wall time per frame (ms) of the mesh (update, normals, colours, triangle list)
    /// and of the isosurface (field, extraction, triangle list).
    pub mesh_ms: f64,
    pub isosurface_ms: f64,
    pub isosurface_triangles: usize,
}

/// Runs `scene` for `seconds`, building both surfaces every frame, and samples the mesh's
/// deviation every `every` seconds (and at the end).
pub fn run(scene: &Scene, seconds: f64, every: f64) -> Result<SurfaceBench, SurfaceBenchError> {
    let mut world = World::try_new(scene)?;
    world.set_deformation_readback(true);
    let rest = world.particles().clone();
    let cell = scene.domain.dx as f32;
    let measure = scene.outputs.points_scalar;
    let mut mesh = TissueSurface::new(SurfaceKind::Mesh, &rest, cell, measure)?;
    let mut iso = TissueSurface::new(SurfaceKind::Isosurface, &rest, cell, measure)?;
    // The same mesh again, updated only where the deviation is sampled.
    let mut probe = TissueMesh::build(&rest, cell)?;
    let spacing = rest.volume0.first().map_or(cell, |v| v.cbrt());
    let radius = GAP_RADIUS_SPACINGS * spacing;
    let rest_gaps = probe.particle_gaps(&probe.rest, &rest.x, radius);

    let frames = (seconds * scene.frame_rate_hz).round().max(1.0) as u32;
    let (mut mesh_s, mut iso_s, mut iso_triangles) = (0.0, 0.0, 0);
    let mut samples = Vec::new();
    let mut next_sample = every;
    for frame in 0..frames {
        world.step_frame()?;
        let particles = world.particles();
        let t0 = Instant::now();
        let m = mesh.triangles(particles);
        mesh_s += t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let s = iso.triangles(particles);
        iso_s += t1.elapsed().as_secs_f64();
        iso_triangles = s.corners.len() / 3;
        std::hint::black_box(m);
        if world.time() >= next_sample - 1e-9 || frame + 1 == frames {
            next_sample += every;
            let max_displacement = particles
                .x
                .iter()
                .zip(&rest.x)
                .map(|(x, x0)| (x - x0).norm())
                .fold(0.0, f32::max);
            samples.push(DeviationSample {
                time: world.time(),
                deviation: {
                    probe.update(&particles.x);
                    probe.deviation(&particles.x, &rest_gaps, radius)
                },
                max_displacement,
            });
        }
    }
    Ok(SurfaceBench {
        scene: scene.name.clone(),
        backend: world.backend().name(),
        particles: rest.len(),
        spacing,
        vertices: probe.rest.len(),
        triangles: probe.triangles.len(),
        binding: probe.binding_len(),
        samples,
        frames,
        mesh_ms: 1e3 * mesh_s / frames as f64,
        isosurface_ms: 1e3 * iso_s / frames as f64,
        isosurface_triangles: iso_triangles,
    })
}

impl SurfaceBench {
    pub fn table(&self) -> String {
        let mut out = String::new();
        let um = |m: f32| m * 1e6;
        let _ = writeln!(
            out,
            "scene \"{}\" on {}: {} particles (spacing {:.0} µm); mesh {} vertices, {} \
             triangles, {} particle references",
            self.scene,
            self.backend,
            self.particles,
            um(self.spacing),
            self.vertices,
            self.triangles,
            self.binding
        );
        let _ = writeln!(
            out,
            "\nMesh deviation: change of each vertex's distance to the nearest particle since rest\n"
        );
        let _ = writeln!(
            out,
            "| t (s) | max particle displacement (mm) | mean (µm) | p95 (µm) | max (µm) | max / spacing |"
        );
        let _ = writeln!(out, "|---|---|---|---|---|---|");
        for s in &self.samples {
            let d = &s.deviation;
            let _ = writeln!(
                out,
                "| {:.3} | {:.2} | {:.1} | {:.1} | {:.1} | {:.2} |",
                s.time,
                s.max_displacement * 1e3,
                um(d.mean),
                um(d.p95),
                um(d.max),
                d.max / self.spacing
            );
        }
        let _ = writeln!(
            out,
            "\nPer frame over {} frames (one thread): mesh {:.3} ms (update, normals, colours, \
             triangle list); isosurface {:.3} ms ({} triangles at the end)",
            self.frames, self.mesh_ms, self.isosurface_ms, self.isosurface_triangles
        );
        out
    }
}
