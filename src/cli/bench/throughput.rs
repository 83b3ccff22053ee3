//! Throughput on the seed-000 scene size: ≈24,000 particles, a 64³ grid over the domain,
//! dt from CFL, a gripper retracting the tissue (SurRoL's benchmark setting); with
//! `--threads 1,2,4,...` the same run in a pool of each size, with the speed-up over the
//! first and the efficiency per thread; with `--transfer scalar,lanes16,...` the same run
//! on each G2P path (see `mpm::cpu::lanes`), with the speed-up over the first.

use anyhow::{bail, Result};
use dvrk_tissue_sim::config::builders::*;
use dvrk_tissue_sim::mpm::backend::Backend;
use dvrk_tissue_sim::mpm::cpu::TransferPath;
use dvrk_tissue_sim::mpm::Method;
use dvrk_tissue_sim::world::World;
use std::time::Instant;

pub struct ThroughputResult {
    pub backend: &'static str,
    pub method: Method,
    pub particles: usize,
    pub grid: [usize; 3],
    pub frames: u32,
    pub substeps: u64,
    pub wall_s: f64,
    pub threads: usize,
    /// The G2P path the CPU ran.
    pub transfer: TransferPath,
}

impl ThroughputResult {
    pub fn particle_substeps_per_s(&self) -> f64 {
        self.particles as f64 * self.substeps as f64 / self.wall_s
    }

    pub fn table(&self) -> String {
        let ms_per_substep = 1e3 * self.wall_s / self.substeps as f64;
        format!(
            "| backend | method | G2P | threads | particles | grid | frames | substeps | wall (s) | ms/substep | ms per 25-substep frame | M particle-substeps/s |\n\
             |---|---|---|---|---|---|---|---|---|---|---|---|\n\
             | {} | {} | {} | {} | {} | {}×{}×{} | {} | {} | {:.3} | {:.3} | {:.2} | {:.2} |\n",
            self.backend,
            self.method.key(),
            self.transfer.key(),
            self.threads,
            self.particles,
            self.grid[0],
            self.grid[1],
            self.grid[2],
            self.frames,
            self.substeps,
            self.wall_s,
            ms_per_substep,
            25.0 * ms_per_substep,
            self.particle_substeps_per_s() / 1e6
        )
    }
}

/// [`run_seed000`] in a pool of each of `threads` sizes, in that order, and the table of
/// them: M particle-substeps/s, the speed-up over the first size, and that speed-up per
/// thread added over the first size's count (1.0: perfect scaling).
pub fn sweep_threads(frames: u32, method: Method, threads: &[usize]) -> Result<String> {
    let mut results = Vec::new();
    for &n in threads {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(n).build()?;
        let result = pool.install(|| run_seed000(frames, method, TransferPath::best()))?;
        eprintln!(
            "{n} threads: {:.2} M particle-substeps/s",
            result.particle_substeps_per_s() / 1e6
        );
        results.push(result);
    }
    let Some(first) = results.first() else {
        bail!("--threads lists no pool size");
    };
    let base = first.particle_substeps_per_s();
    let mut out = format!(
        "{} cores available; the seed-000 scene, method {}, {} frames a size\n\n\
         | threads | particles | substeps | wall (s) | M particle-substeps/s | speed-up | efficiency |\n\
         |---|---|---|---|---|---|---|\n",
        std::thread::available_parallelism().map_or(0, |n| n.get()),
        method.key(),
        frames
    );
    for r in &results {
        let speed_up = r.particle_substeps_per_s() / base;
        out += &format!(
            "| {} | {} | {} | {:.3} | {:.2} | {:.2} | {:.2} |\n",
            r.threads,
            r.particles,
            r.substeps,
            r.wall_s,
            r.particle_substeps_per_s() / 1e6,
            speed_up,
            speed_up * first.threads as f64 / r.threads as f64
        );
    }
    Ok(out)
}

/// [`run_seed000`] on each of the G2P `paths`, in that order, and the table of them: M
/// particle-substeps/s and the speed-up over the first path. Every path gives the same
/// particles to the bit (`mpm::cpu::lanes`'s test), so the rows time the same work.
pub fn sweep_transfer(frames: u32, method: Method, paths: &[TransferPath]) -> Result<String> {
    let available = TransferPath::available();
    if let Some(missing) = paths.iter().find(|p| !available.contains(p)) {
        let names: Vec<_> = available.iter().map(|p| p.key()).collect();
        bail!(
            "this CPU cannot run G2P path `{}`; it runs {}",
            missing.key(),
            names.join(", ")
        );
    }
    let mut results = Vec::new();
    for &path in paths {
        let result = run_seed000(frames, method, path)?;
        eprintln!(
            "{}: {:.2} M particle-substeps/s",
            path.key(),
            result.particle_substeps_per_s() / 1e6
        );
        results.push(result);
    }
    let Some(first) = results.first() else {
        bail!("--transfer lists no path");
    };
    let base = first.particle_substeps_per_s();
    let mut out = format!(
        "the seed-000 scene, method {}, {} threads, {} frames a path\n\n\
         | G2P | lanes | particles | substeps | wall (s) | M particle-substeps/s | speed-up |\n\
         |---|---|---|---|---|---|---|\n",
        method.key(),
        rayon::current_num_threads(),
        frames
    );
    for r in &results {
        out += &format!(
            "| {} | {} | {} | {} | {:.3} | {:.2} | {:.2} |\n",
            r.transfer.key(),
            r.transfer.lanes(),
            r.particles,
            r.substeps,
            r.wall_s,
            r.particle_substeps_per_s() / 1e6,
            r.particle_substeps_per_s() / base
        );
    }
    Ok(out)
}

/// Times `frames` frames of the seed-000 scene stepped by `method` on the CPU backend, G2P
/// on `transfer`, after one warm-up frame, in the current rayon pool.
pub fn run_seed000(
    frames: u32,
    method: Method,
    transfer: TransferPath,
) -> Result<ThroughputResult> {
    let mut scene = seed000_scene();
    scene.solver.method = method;
    let errors = dvrk_tissue_sim::config::validate(&scene);
    if !errors.is_empty() {
        bail!("the seed-000 scene with solver.method = {method:?}: {errors:?}");
    }
    let mut world = World::new(&scene);
    if let Backend::Cpu(cpu) = world.backend_mut() {
        cpu.solver.transfer_path = transfer;
    }
    world.step_frame().expect("seed-000 scene is stable");
    let start = Instant::now();
    let mut substeps = 0u64;
    for _ in 0..frames {
        substeps += world
            .step_frame()
            .expect("seed-000 scene is stable")
            .substeps as u64;
    }
    Ok(ThroughputResult {
        backend: "cpu",
        method,
        particles: world.particles().len(),
        grid: world.layout().nodes,
        frames,
        substeps,
        wall_s: start.elapsed().as_secs_f64(),
        threads: rayon::current_num_threads(),
        transfer,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed000_scene_matches_the_paper_setting() {
        let scene = seed000_scene();
        assert!(
            dvrk_tissue_sim::config::validate(&scene).is_empty(),
            "{:?}",
            dvrk_tissue_sim::config::validate(&scene)
        );
        let world = World::new(&scene);
        assert_eq!(world.particles().len(), 24_000);
        assert_eq!(
            world.layout().nodes,
            [68, 68, 68],
            "64 cells (+1 node, rounded to blocks)"
        );
    }
}
