//! A whole output frame on the seed-000 scene, the way the node runs it: the frame's
//! substeps, the readback, and the point cloud built from what came back. Timed two ways
//! per backend: serially (step the frame, then build its cloud) and pipelined (submit the
//! frame, build the previous frame's cloud while it computes, collect it), which is what
//! the node's simulation thread does when it runs behind real time.

use super::scaling::variants;
use dvrk_tissue_sim::config::builders::seed000_scene;
use dvrk_tissue_sim::mpm::backend::{Backend, BackendChoice, P2gAtomics};
use dvrk_tissue_sim::mpm::gpu::DispatchCount;
use dvrk_tissue_sim::output::{CloudOptions, TissueCloud};
use dvrk_tissue_sim::world::World;
use std::time::Instant;

pub struct Row {
    pub backend: String,
    pub particles: usize,
    pub frames: u32,
    /// Mean substeps per frame.
    pub substeps: f64,
    /// Serial: mean wall time of a frame plus its cloud (ms).
    pub serial_ms: f64,
    /// Of which building the cloud (ms).
    pub cloud_ms: f64,
    /// Pipelined: mean wall time of a frame plus the previous frame's cloud (ms).
    pub pipelined_ms: f64,
    /// The GPU's compute dispatches of the last frame, as recorded (none on the CPU).
    pub dispatches: Option<DispatchCount>,
}

fn world_on(variant: (BackendChoice, P2gAtomics)) -> Option<World> {
    let mut scene = seed000_scene();
    scene.solver.backend = variant.0;
    scene.solver.p2g_atomics = variant.1;
    match World::try_new(&scene) {
        Ok(mut world) => {
            // The cloud's strain scalar needs F, as in the node.
            world.set_deformation_readback(true);
            world.step_frame().expect("benchmark scene is stable");
            Some(world)
        }
        Err(e) => {
            eprintln!("frame bench: {variant:?} skipped: {e}");
            None
        }
    }
}

/// Times `frames` frames each way on every backend variant the machine has.
pub fn run(frames: u32) -> Vec<Row> {
    let options = CloudOptions::default();
    let frames = frames.max(2);
    let mut rows = Vec::new();
    for variant in variants() {
        let (Some(mut serial), Some(mut pipelined)) = (world_on(variant), world_on(variant)) else {
            continue;
        };
        // The two ways alternate frame by frame, so drift in the machine's speed (other
        // load, clocks) falls on both alike.
        let (mut serial_s, mut cloud_s, mut pipelined_s, mut substeps) = (0.0, 0.0, 0.0, 0u64);
        for _ in 0..frames {
            let start = Instant::now();
            substeps += serial
                .step_frame()
                .expect("benchmark scene is stable")
                .substeps as u64;
            let t = Instant::now();
            std::hint::black_box(TissueCloud::from_particles(serial.particles(), &options));
            cloud_s += t.elapsed().as_secs_f64();
            serial_s += start.elapsed().as_secs_f64();

            let start = Instant::now();
            pipelined.begin_frame();
            std::hint::black_box(TissueCloud::from_particles(pipelined.particles(), &options));
            pipelined.finish_frame().expect("benchmark scene is stable");
            pipelined_s += start.elapsed().as_secs_f64();
        }

        let per_frame = |s: f64| 1e3 * s / frames as f64;
        let row = Row {
            backend: serial.backend().name().to_string(),
            particles: serial.particles().len(),
            frames,
            substeps: substeps as f64 / frames as f64,
            serial_ms: per_frame(serial_s),
            cloud_ms: per_frame(cloud_s),
            pipelined_ms: per_frame(pipelined_s),
            dispatches: match serial.backend() {
                Backend::Gpu(gpu) => Some(gpu.dispatch_count()),
                Backend::Cpu(_) => None,
            },
        };
        eprintln!(
            "{}: serial {:.2} ms/frame, pipelined {:.2} ms/frame",
            row.backend, row.serial_ms, row.pipelined_ms
        );
        rows.push(row);
    }
    rows
}

pub fn table(rows: &[Row], adapter: &str) -> String {
    let mut out = format!(
        "GPU adapter: {adapter}\n\n| backend | particles | frames | substeps/frame | serial ms/frame | of which cloud | pipelined ms/frame | saved | dispatches/substep | dispatches/frame |\n|---|---|---|---|---|---|---|---|---|---|\n"
    );
    for r in rows {
        out += &format!(
            "| {} | {} | {} | {:.1} | {:.2} | {:.2} | {:.2} | {:+.1}% | {} | {} |\n",
            r.backend,
            r.particles,
            r.frames,
            r.substeps,
            r.serial_ms,
            r.cloud_ms,
            r.pipelined_ms,
            100.0 * (r.serial_ms - r.pipelined_ms) / r.serial_ms,
            r.dispatches
                .map_or("—".to_string(), |d| format!("{:.1}", d.per_substep())),
            r.dispatches
                .map_or("—".to_string(), |d| d.frame.to_string()),
        );
    }
    out
}
