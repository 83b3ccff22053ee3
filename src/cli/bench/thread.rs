//! `bench thread`: a 15 cm 3-0 nylon thread released from horizontal, swinging from one fixed
//! end under gravity (seed 001's length test), at 40, 100, 400 and 1000 segments on one core:
//! ms per 60 Hz frame with the solver's default settings, and the largest elongation of the
//! centreline over the run (the material's own strain here is ≈ 1e-6, tension of a few
//! thread weights over EA, so the figure is the solver's error). The rod solver runs on the
//! calling thread alone (no rayon), so the rows are one core's; besides wall time the table
//! gives the thread's own CPU time, which other processes on a loaded machine do not inflate.
//! A second table: the analytic beam cases of `validation::thread` against segment count.
//! A third: `config/knot.toml` stepped headless (two grippers tie an overhand knot on the
//! table and pull it tight: contact with the table, the tools and itself every substep), its
//! thread CPU time against the simulated time, so the real-time factor of a thread in
//! contact is measured where it is hardest, and the factorisations of the rod's system per
//! substep (counted as they are done), which set most of that cost.

use dvrk_tissue_sim::math::Vec3;
use dvrk_tissue_sim::rod::solver::RodSolverSettings;
use dvrk_tissue_sim::rod::{Rod, RodSolver, ThreadMaterial};
use dvrk_tissue_sim::validation::thread as analytic;
use std::path::Path;
use std::time::Instant;

pub const SEGMENTS: [usize; 4] = [40, 100, 400, 1000];
const FRAME_DT: f32 = 1.0 / 60.0;

pub struct ThreadRow {
    pub segments: usize,
    pub ms_per_frame: f64,
    /// This thread's CPU time per frame (ms), where the system reports it.
    pub cpu_ms_per_frame: Option<f64>,
    pub elongation: f32,
}

pub fn run(segments: &[usize], frames: u32) -> Vec<ThreadRow> {
    run_with(segments, frames, RodSolverSettings::default())
}

fn run_with(segments: &[usize], frames: u32, settings: RodSolverSettings) -> Vec<ThreadRow> {
    segments
        .iter()
        .map(|&n| {
            let mut rod = Rod::straight(
                ThreadMaterial::nylon_3_0(),
                Vec3::new(0.0, 0.0, 0.3),
                Vec3::x(),
                0.15,
                n,
            );
            rod.pin_point(0);
            let rest = rod.rest_length();
            let mut solver = RodSolver::new(&rod, settings, Vec3::new(0.0, 0.0, -9.81));
            let mut elongation = 0.0f32;
            let mut wall = 0.0;
            let cpu_start = thread_cpu_seconds();
            for _ in 0..frames {
                let start = Instant::now();
                solver.step_frame(&mut rod, FRAME_DT);
                wall += start.elapsed().as_secs_f64();
                elongation = elongation.max((rod.length() / rest - 1.0).abs());
            }
            let cpu = thread_cpu_seconds()
                .zip(cpu_start)
                .map(|(end, start)| end - start);
            ThreadRow {
                segments: n,
                ms_per_frame: 1e3 * wall / frames as f64,
                // The elongation measure between frames is a small part of it.
                cpu_ms_per_frame: cpu.map(|c| 1e3 * c / frames as f64),
                elongation,
            }
        })
        .collect()
}

pub fn table(rows: &[ThreadRow], frames: u32) -> String {
    let s = RodSolverSettings::default();
    let mut out = format!(
        "thread swinging from one fixed end, 15 cm 3-0 nylon, {frames} frames at 60 Hz, \
         {} substeps x {} iterations, one core\n\
         | segments | ms/frame | cpu ms/frame | elongation |\n|---|---|---|---|\n",
        s.substeps, s.iterations
    );
    for r in rows {
        let cpu = r
            .cpu_ms_per_frame
            .map_or_else(|| "n/a".to_string(), |c| format!("{c:.3}"));
        out += &format!(
            "| {} | {:.3} | {cpu} | {:.2e} |\n",
            r.segments, r.ms_per_frame, r.elongation
        );
    }
    out
}

/// Substeps per frame against cost and elongation (2 iterations each), at the smallest and
/// largest thread: what fewer substeps would save and lose.
pub fn substep_table(frames: u32) -> String {
    let mut out = format!(
        "\nsubsteps per frame, same swing, 2 iterations, {frames} frames\n\
         | substeps | segments | ms/frame | cpu ms/frame | elongation |\n|---|---|---|---|---|\n"
    );
    for substeps in [1, 2, 4] {
        let settings = RodSolverSettings {
            substeps,
            iterations: 2,
        };
        for r in run_with(&[SEGMENTS[0], SEGMENTS[3]], frames, settings) {
            let cpu = r.cpu_ms_per_frame.unwrap_or(f64::NAN);
            out += &format!(
                "| {substeps} | {} | {:.3} | {cpu:.3} | {:.2e} |\n",
                r.segments, r.ms_per_frame, r.elongation
            );
        }
    }
    out
}

/// Segment counts of the analytic table: each case's error must shrink as they double.
pub const ANALYTIC_SEGMENTS: [usize; 3] = [10, 20, 40];

/// The analytic beam cases (validation::thread) at 10, 20 and 40 segments, default solver.
pub fn analytic_table() -> String {
    let mut out = String::from(
        "\nthread against beam theory (2 cm cantilevers of 3-0 nylon; catenary: 15 cm between \
         pins 12 cm apart), default solver\n\
         | case | segments | rod (m) | analytic (m) | error |\n|---|---|---|---|---|\n",
    );
    for (name, case) in analytic::CASES {
        for segments in ANALYTIC_SEGMENTS {
            let c = case(segments);
            out += &format!(
                "| {name} | {segments} | {:.4e} | {:.4e} | {:.2e} |\n",
                c.measured, c.expected, c.error
            );
        }
    }
    out
}

/// What stepping a scene of threads alone headless cost, one core.
pub struct KnotRow {
    pub scene: String,
    pub simulated_s: f64,
    pub wall_s: f64,
    pub cpu_s: Option<f64>,
    /// Knot determinant of the first thread at the end (1: unknotted, 3: trefoil).
    pub determinant: u128,
    /// Largest |strain| of any segment at the end of any frame.
    pub max_strain: f32,
    /// Frames in which a move was scaled back because it would have passed a strand
    /// through another (the crossing guard acted).
    pub frames_held_back: u32,
    /// Factorisations of the rod's system per rod substep, counted as they were done.
    pub factorisations_per_substep: f64,
}

/// Steps `scene` (threads alone: the world steps them on this thread) for `seconds`, or its
/// script to the end.
pub fn knot_run(scene: &Path, seconds: Option<f64>) -> anyhow::Result<KnotRow> {
    use anyhow::{bail, Context};
    use dvrk_tissue_sim::{config, world::World};
    let loaded =
        config::load(scene).with_context(|| format!("thread bench scene {}", scene.display()))?;
    if loaded.threads.is_empty() || !loaded.tissues.is_empty() {
        bail!(
            "{}: the knot row steps a scene of threads alone",
            scene.display()
        );
    }
    let seconds = seconds.or(loaded.script_end_s()).unwrap_or(2.0);
    let mut world = World::try_new(&loaded)?;
    let frames = (seconds * loaded.frame_rate_hz).round().max(1.0) as u64;
    let (mut max_strain, mut frames_held_back) = (0.0f32, 0u32);
    let (mut substeps, mut factorisations) = (0u64, 0u64);
    let cpu_start = thread_cpu_seconds();
    let start = Instant::now();
    for _ in 0..frames {
        world.step_frame().context("knot row: a frame failed")?;
        for thread in world.threads() {
            let report = thread.last_report();
            max_strain = max_strain.max(report.max_strain);
            frames_held_back += u32::from(report.substeps_held_back > 0);
            substeps += u64::from(report.substeps);
            factorisations += u64::from(report.factorisations);
        }
    }
    let wall_s = start.elapsed().as_secs_f64();
    let cpu_s = thread_cpu_seconds()
        .zip(cpu_start)
        .map(|(end, start)| end - start);
    Ok(KnotRow {
        scene: scene.display().to_string(),
        simulated_s: frames as f64 / loaded.frame_rate_hz,
        wall_s,
        cpu_s,
        determinant: world.threads()[0].knot_determinant(),
        max_strain,
        frames_held_back,
        factorisations_per_substep: factorisations as f64 / substeps.max(1) as f64,
    })
}

pub fn knot_table(row: &KnotRow) -> String {
    let cpu = row
        .cpu_s
        .map_or_else(|| "n/a".to_string(), |c| format!("{c:.1}"));
    let factor = row.cpu_s.map_or_else(
        || "n/a".to_string(),
        |c| format!("{:.2}", row.simulated_s / c),
    );
    format!(
        "\na scene of threads in contact, stepped headless on one core (real-time factor: \
         simulated s per CPU s)\n\
         | scene | simulated s | wall s | cpu s | real-time factor | knot determinant | largest strain | frames held back | factorisations a substep |\n\
         |---|---|---|---|---|---|---|---|---|\n\
         | {} | {:.2} | {:.1} | {cpu} | {factor} | {} | {:.2e} | {} | {:.2} |\n",
        row.scene,
        row.simulated_s,
        row.wall_s,
        row.determinant,
        row.max_strain,
        row.frames_held_back,
        row.factorisations_per_substep
    )
}

/// CPU time this thread has run (s), from CLOCK_THREAD_CPUTIME_ID (brought up to date when
/// read, unlike /proc's per-tick accounting). None where the clock is not available.
fn thread_cpu_seconds() -> Option<f64> {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one timespec through a valid pointer.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) };
    (rc == 0).then_some(t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9)
}
