//! Particle-substeps per second against particle count, per backend: a block of tissue
//! (8 particles per cell) settling on a bonded table under gravity, a sphere resting in it,
//! dx = 1 mm, dt from CFL, 10 substeps per frame (positions read back every frame), plus
//! the seed-000 scene (≈24,000 particles, 64³ grid).

use dvrk_tissue_sim::config::builders::seed000_scene;
use dvrk_tissue_sim::config::builders::*;
use dvrk_tissue_sim::config::Scene;
use dvrk_tissue_sim::mpm::backend::{BackendChoice, P2gAtomics};
use dvrk_tissue_sim::mpm::timestep;
use dvrk_tissue_sim::mpm::Lame;
use dvrk_tissue_sim::tools::{ContactModel, Shape};
use dvrk_tissue_sim::world::World;
use std::time::Instant;

pub const COUNTS: [usize; 5] = [10_000, 30_000, 100_000, 300_000, 1_000_000];

/// A cube of about `n` particles (2 per cell per axis) in a domain 8 cells wider.
pub fn block_scene(n: usize) -> Scene {
    let dx = 0.001;
    let cells = ((n as f64 / 8.0).cbrt()).round().max(2.0);
    let side = cells * dx;
    let size = side + 8.0 * dx;
    let table = 3.0 * dx;
    let mat = material(5000.0, 0.4, 1000.0, 2.0);
    let lame = Lame::from_young_poisson(mat.youngs_modulus, mat.poisson_ratio);
    let dt = timestep::stable_dt(0.5, dx, lame.p_wave_speed(mat.density), 0.0);
    let top = table + side;
    let mut s = scene(
        "scaling-block",
        (1.0 / (10.0 * dt)).min(10_000.0),
        domain(
            [-0.5 * size, -0.5 * size, 0.0],
            [size, size, top + 5.0 * dx],
            dx,
            [0.0, 0.0, -9.81],
        ),
        Some(bonded_table(table)),
        vec![tissue(
            [0.0, 0.0, table + 0.5 * side],
            [side, side, side],
            mat,
        )],
        vec![tool(
            "sphere",
            Shape::Sphere {
                radius: 3.0 * dx as f32,
            },
            ContactModel::default(),
            vec![key(0.0, [0.0, 0.0, top + 2.5 * dx], [0.0; 3], 0.0)],
        )],
    );
    s.solver.max_substeps_per_frame = 100;
    s
}

pub struct Row {
    pub scene: String,
    pub backend: String,
    pub particles: usize,
    pub grid: [usize; 3],
    pub substeps: u64,
    pub wall_s: f64,
}

impl Row {
    pub fn rate(&self) -> f64 {
        self.particles as f64 * self.substeps as f64 / self.wall_s
    }
}

/// Times `world` for at least `min_wall_s` and at least 2 frames, after one warm-up frame.
fn time_world(label: &str, mut world: World, min_wall_s: f64) -> Row {
    world.step_frame().expect("benchmark scene is stable");
    let start = Instant::now();
    let (mut substeps, mut frames) = (0u64, 0u32);
    while frames < 2 || start.elapsed().as_secs_f64() < min_wall_s {
        substeps += world
            .step_frame()
            .expect("benchmark scene is stable")
            .substeps as u64;
        frames += 1;
    }
    Row {
        scene: label.to_string(),
        backend: world.backend().name().to_string(),
        particles: world.particles().len(),
        grid: world.layout().nodes,
        substeps,
        wall_s: start.elapsed().as_secs_f64(),
    }
}

/// The backends to compare: the CPU, and the GPU with each P2G variant it can run.
pub fn variants() -> Vec<(BackendChoice, P2gAtomics)> {
    let mut v = vec![(BackendChoice::Cpu, P2gAtomics::Auto)];
    if let Some(a) = dvrk_tissue_sim::mpm::gpu::adapter::adapters().first() {
        if a.features().contains(wgpu::Features::SHADER_FLOAT32_ATOMIC) {
            v.push((BackendChoice::Gpu, P2gAtomics::Float));
        }
        v.push((BackendChoice::Gpu, P2gAtomics::Fixed));
    }
    v
}

pub fn run(counts: &[usize], min_wall_s: f64) -> Vec<Row> {
    let mut rows = Vec::new();
    let mut scenes: Vec<(String, Scene)> = counts
        .iter()
        .map(|&n| (format!("block {n}"), block_scene(n)))
        .collect();
    scenes.push(("seed-000".into(), seed000_scene()));
    for (label, scene) in &scenes {
        for &(backend, p2g) in &variants() {
            let mut s = scene.clone();
            s.solver.backend = backend;
            s.solver.p2g_atomics = p2g;
            match World::try_new(&s) {
                Ok(world) => {
                    let row = time_world(label, world, min_wall_s);
                    eprintln!(
                        "{label}: {} {:.2} M particle-substeps/s",
                        row.backend,
                        row.rate() / 1e6
                    );
                    rows.push(row);
                }
                Err(e) => eprintln!("{label}: {backend:?}/{p2g:?} skipped: {e}"),
            }
        }
    }
    rows
}

pub fn table(rows: &[Row], adapter: &str) -> String {
    let mut out = format!(
        "GPU adapter: {adapter}\n\n| scene | backend | particles | grid | substeps | wall (s) | ms/substep | M particle-substeps/s |\n|---|---|---|---|---|---|---|---|\n"
    );
    for r in rows {
        out += &format!(
            "| {} | {} | {} | {}×{}×{} | {} | {:.2} | {:.2} | {:.2} |\n",
            r.scene,
            r.backend,
            r.particles,
            r.grid[0],
            r.grid[1],
            r.grid[2],
            r.substeps,
            r.wall_s,
            1e3 * r.wall_s / r.substeps as f64,
            r.rate() / 1e6
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn block_scenes_have_about_the_asked_particle_count() {
        for n in [10_000, 100_000] {
            let s = block_scene(n);
            assert!(
                dvrk_tissue_sim::config::validate(&s).is_empty(),
                "{:?}",
                dvrk_tissue_sim::config::validate(&s)
            );
            let mut cpu = s.clone();
            cpu.solver.backend = BackendChoice::Cpu;
            let got = World::new(&cpu).particles().len();
            assert!((got as f64 / n as f64 - 1.0).abs() < 0.1, "{n}: {got}");
        }
    }
}
