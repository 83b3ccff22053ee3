//! `bench`: the runtime-against-error sweep over the analytic scenes (the default), and
//! throughput, scaling, frame, skip, surface, dataset, camera and accuracy tables. Each is a command that
//! prints a table and writes it as Markdown and CSV under `--out` ([`report`]); none is
//! library API.

pub mod accuracy;
pub mod camera;
pub mod dataset;
pub mod frame;
pub mod plot;
pub mod report;
pub mod scaling;
pub mod skip;
pub mod stress;
pub mod surface;
pub mod sweep;
pub mod thread;
pub mod thread_stress;
pub mod throughput;

use crate::scene_args::{scene_value, SolverOverrides};
use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand};
use dvrk_tissue_sim::mpm::backend::BackendChoice;
use dvrk_tissue_sim::mpm::cpu::TransferPath;
use dvrk_tissue_sim::mpm::gpu::adapter;
use dvrk_tissue_sim::mpm::Method;
use std::path::{Path, PathBuf};
use sweep::SweepPlan;

#[derive(Args)]
pub struct BenchArgs {
    #[command(subcommand)]
    which: Option<BenchCommand>,
    /// Coarse resolutions only, without the stiff group (`bench stiff`).
    #[arg(long)]
    quick: bool,
    /// Folder for the tables as Markdown and CSV, each headed by the command line, commit,
    /// date and machine: bench.md, bench.csv and bench.png for the sweep, NAME.md and
    /// NAME.csv for `bench NAME`.
    #[arg(long, default_value = "target/bench", global = true)]
    out: PathBuf,
    /// Backends to sweep (default: cpu, plus gpu when a hardware GPU adapter exists).
    #[arg(long, value_delimiter = ',', value_parser = scene_value::<BackendChoice>)]
    backends: Option<Vec<BackendChoice>>,
}

#[derive(Subcommand)]
pub enum BenchCommand {
    /// Particle-substeps per second on the seed-000 retraction scene (≈24,000 particles,
    /// 64³ grid, dt from CFL), CPU backend.
    Throughput {
        /// Frames to time (after one warm-up frame).
        #[arg(long, default_value_t = 20)]
        frames: u32,
        /// MPM formulation to time (`mls_mpm`, `tl_mpm`, `pic_mpm`, `pb_mpm` or `implicit`).
        #[arg(long, default_value = "mls_mpm", value_parser = scene_value::<Method>)]
        method: Method,
        /// Thread counts to sweep, comma-separated (e.g. `1,2,4,8,16`): the run in a pool of
        /// each size, with speed-up and efficiency per thread. Without it, one run on all
        /// cores.
        #[arg(long, value_delimiter = ',', value_parser = clap::value_parser!(u16).range(1..))]
        threads: Option<Vec<u16>>,
        /// Transfer paths to compare (G2P, and total Lagrangian P2G's node sums),
        /// comma-separated: `scalar` (one particle at a time, the reference), `lanes4`
        /// (SSE2), `lanes8` (AVX2), `lanes16` (AVX-512); a row each, with the speed-up over
        /// the first. Without it, the widest this CPU runs.
        #[arg(long, value_delimiter = ',', value_parser = scene_value::<TransferPath>, conflicts_with = "threads")]
        transfer: Option<Vec<TransferPath>>,
    },
    /// Error of the scenes with analytic answers at a few resolutions.
    Accuracy,
    /// The stiff-tissue group alone: Hertz and stretch at E 60 kPa and 1 MPa, ν 0.49,
    /// explicit MLS-MPM (CFL 0.5) against implicit, with the implicit speed-up.
    Stiff,
    /// The suture thread swinging from one fixed end: ms/frame and elongation at 40–1000
    /// segments, one core; and a scene of threads in contact (`config/knot.toml`) stepped
    /// headless: its real-time factor on one core.
    Thread {
        /// Frames to run each thread (60 Hz).
        #[arg(long, default_value_t = 60)]
        frames: u32,
        /// Scene of threads alone for the contact row (two grippers tying a knot).
        #[arg(long, default_value = "config/knot.toml")]
        knot_scene: PathBuf,
        /// Simulated seconds of that scene (default: its script to the end).
        #[arg(long)]
        knot_seconds: Option<f64>,
    },
    /// What a scene does not need costs nothing: resting tissue asleep against stepped, the
    /// same tissue in a 4× larger domain, tools parked out of reach against none; and what
    /// the grip, cutting, the damage model and a suture thread through the tissue cost.
    Skip {
        /// Timed frames per case (at most 15 for the grip cases: the hold lasts 0.3 s).
        #[arg(long, default_value_t = 10)]
        frames: u32,
        /// Solver backend (`cpu`, `gpu` or `auto`).
        #[arg(long, default_value = "cpu", value_parser = scene_value::<BackendChoice>)]
        backend: BackendChoice,
        /// Only the cases whose name contains this (and the cases they are compared with),
        /// e.g. `toughness` or `cutting`.
        #[arg(long)]
        only: Option<String>,
    },
    /// `dataset`'s cost: episodes per hour at each --jobs, and the overhead of its machinery
    /// against plain `run --headless --record` runs of the same sampled scenes (target ≤ 5 %).
    Dataset {
        #[arg(long, default_value = "config/default.toml")]
        scene: PathBuf,
        #[arg(long, default_value = "config/vary/grasp.toml")]
        vary: PathBuf,
        /// Episodes per timed run.
        #[arg(long, default_value_t = 4)]
        episodes: u64,
        /// Simulated seconds per episode.
        #[arg(long, default_value_t = 2.0)]
        seconds: f64,
        /// The --jobs settings to time besides 1.
        #[arg(long, value_delimiter = ',', default_value = "2")]
        jobs: Vec<usize>,
        #[command(flatten)]
        solver: SolverOverrides,
    },
    /// Particle-substeps per second against particle count (10k–1M) and on the seed-000
    /// scene, for the CPU backend and each GPU P2G variant the adapter can run.
    Scaling {
        /// Particle counts to time (default 10000,30000,100000,300000,1000000).
        #[arg(long, value_delimiter = ',')]
        counts: Option<Vec<usize>>,
        /// Least wall time per measurement (s).
        #[arg(long, default_value_t = 2.0)]
        min_seconds: f64,
    },
    /// A seed-000 output frame as the node runs it (substeps, readback, point cloud), per
    /// backend: serially, and pipelined (the previous frame's cloud built while the next
    /// frame computes).
    Frame {
        /// Frames to time each way (after one warm-up frame).
        #[arg(long, default_value_t = 30)]
        frames: u32,
    },
    /// The tissue surface on a scene: the constant-topology mesh's deviation from the
    /// particles as the tissue deforms, and the per-frame cost of the mesh and isosurface.
    Surface {
        #[arg(long, default_value = "config/retraction.toml")]
        scene: PathBuf,
        /// Simulated seconds to run.
        #[arg(long, default_value_t = 1.6)]
        seconds: f64,
        /// Simulated seconds between deviation samples.
        #[arg(long, default_value_t = 0.2)]
        every: f64,
        #[command(flatten)]
        solver: SolverOverrides,
    },
    /// The stereo camera on a scene with a `[camera]`: render time per stereo frame (RGB,
    /// depth, labels, readback; JPEG) at 320×240, 640×360 and 1280×720 per eye, and the
    /// simulation's frame rate with the camera subscribed against unsubscribed, and recorded
    /// with the pictures against without.
    Camera {
        #[arg(long, default_value = "config/default.toml")]
        scene: PathBuf,
        /// Frames to time each way (after one warm-up frame).
        #[arg(long, default_value_t = 20)]
        frames: u32,
    },
}

/// The first GPU adapter, as the benchmark tables name it.
pub fn adapter_name() -> String {
    adapter::adapters()
        .first()
        .map(|a| {
            let i = a.get_info();
            format!("{} ({:?}, {:?})", i.name, i.backend, i.device_type)
        })
        .unwrap_or_else(|| "none".into())
}

pub fn run(args: BenchArgs) -> Result<()> {
    let Some(which) = args.which else {
        return run_sweep(args.quick, &args.out, args.backends);
    };
    let out = args.out;
    // Each table is printed, then written under `out` as `<stem>.md` and `<stem>.csv`.
    let print_and_write = |stem: &str, table: &str, gpu: Option<&str>| -> Result<()> {
        print!("{table}");
        let [md, csv] = report::write(&out, stem, &report::Provenance::here(gpu), table, None)?;
        println!("wrote {} and {}", md.display(), csv.display());
        Ok(())
    };
    match which {
        BenchCommand::Skip {
            frames,
            backend,
            only,
        } => {
            let rows = skip::run(backend, frames.max(1), only.as_deref())?;
            let gpu = (backend != BackendChoice::Cpu).then(adapter_name);
            print_and_write("skip", &skip::table(&rows), gpu.as_deref())?;
            let over = skip::over_target(&rows);
            if !over.is_empty() {
                bail!("over target: {}", over.join("; "));
            }
            Ok(())
        }
        BenchCommand::Throughput {
            frames,
            method,
            transfer: Some(paths),
            ..
        } => {
            let table = throughput::sweep_transfer(frames, method, &paths)?;
            print_and_write("throughput-transfer", &table, None)
        }
        BenchCommand::Throughput {
            frames,
            method,
            threads: Some(threads),
            ..
        } => {
            let threads: Vec<usize> = threads.into_iter().map(usize::from).collect();
            let table = throughput::sweep_threads(frames, method, &threads)?;
            print_and_write("throughput-threads", &table, None)
        }
        BenchCommand::Throughput {
            frames,
            method,
            threads: None,
            transfer: None,
        } => {
            let result = throughput::run_seed000(frames, method, TransferPath::best())?;
            print_and_write("throughput", &result.table(), None)
        }
        BenchCommand::Scaling {
            counts,
            min_seconds,
        } => {
            let counts = counts.unwrap_or_else(|| scaling::COUNTS.to_vec());
            let rows = scaling::run(&counts, min_seconds);
            let adapter = adapter_name();
            let gpu = rows.iter().any(|r| r.backend.starts_with("gpu"));
            print_and_write(
                "scaling",
                &scaling::table(&rows, &adapter),
                gpu.then_some(adapter.as_str()),
            )
        }
        BenchCommand::Frame { frames } => {
            let rows = frame::run(frames);
            let adapter = adapter_name();
            let gpu = rows.iter().any(|r| r.backend.starts_with("gpu"));
            print_and_write(
                "frame",
                &frame::table(&rows, &adapter),
                gpu.then_some(adapter.as_str()),
            )
        }
        BenchCommand::Surface {
            scene,
            seconds,
            every,
            solver,
        } => {
            if !(every > 0.0 && seconds > 0.0) {
                bail!("--seconds ({seconds}) and --every ({every}) must be > 0");
            }
            let loaded = solver.load(&scene)?;
            let result = surface::run(&loaded, seconds, every)
                .with_context(|| format!("surface bench on {}", scene.display()))?;
            let gpu = (loaded.solver.backend != BackendChoice::Cpu).then(adapter_name);
            print_and_write("surface", &result.table(), gpu.as_deref())
        }
        BenchCommand::Thread {
            frames,
            knot_scene,
            knot_seconds,
        } => {
            let frames = frames.max(1);
            let table = format!(
                "{}{}{}{}",
                thread::table(&thread::run(&thread::SEGMENTS, frames), frames),
                thread::substep_table(frames),
                thread::analytic_table(),
                thread::knot_table(&thread::knot_run(&knot_scene, knot_seconds)?)
            );
            print_and_write("thread", &table, None)
        }
        BenchCommand::Stiff => {
            let plan = SweepPlan::stiff(vec![BackendChoice::Cpu]);
            let rows = sweep::run(&plan, |row| {
                eprintln!(
                    "{} {}: {:+.2}% in {:.1} s",
                    row.case.scene_name(),
                    row.setting.solver_name(),
                    100.0 * row.error,
                    row.wall_s
                )
            });
            let table = format!(
                "{}\n{}",
                sweep::markdown(&rows),
                sweep::stiff_summary(&rows)
            );
            print_and_write("stiff", &table, None)
        }
        BenchCommand::Dataset {
            scene,
            vary,
            episodes,
            seconds,
            jobs,
            solver,
        } => {
            let gpu = solver
                .backend
                .is_some_and(|b| b != BackendChoice::Cpu)
                .then(adapter_name);
            let spec = crate::dataset::DatasetSpec {
                scene: Some(scene),
                vary: Some(vary),
                episodes: Some(episodes),
                out: None,
                seed: 0,
                seconds: Some(seconds),
                shard: None,
                jobs: 1,
                solver,
            };
            print_and_write("dataset", &dataset::run(&spec, &jobs)?, gpu.as_deref())
        }
        BenchCommand::Accuracy => print_and_write("accuracy", &accuracy::table(), None),
        BenchCommand::Camera { scene, frames } => {
            let loaded = dvrk_tissue_sim::config::load(&scene)?;
            let result = camera::run(&loaded, frames.max(1))
                .with_context(|| format!("camera bench on {}", scene.display()))?;
            let adapter = adapter_name();
            print_and_write("camera", &result.table(), Some(adapter.as_str()))
        }
    }
}

fn run_sweep(quick: bool, out: &Path, backends: Option<Vec<BackendChoice>>) -> Result<()> {
    let backends = backends.unwrap_or_else(|| {
        let hardware = adapter::adapters()
            .iter()
            .any(|a| a.get_info().device_type != wgpu::DeviceType::Cpu);
        let mut b = vec![BackendChoice::Cpu];
        if hardware {
            b.push(BackendChoice::Gpu);
        }
        b
    });
    // The analytic runs build their worlds from code; a missing adapter is caught here,
    // with a message, rather than in the middle of the sweep.
    if backends.contains(&BackendChoice::Gpu) && adapter::adapters().is_empty() {
        bail!("--backends gpu: no GPU adapter (hardware or software) is available here");
    }
    let gpu = backends.contains(&BackendChoice::Gpu).then(adapter_name);
    let plan = if quick {
        SweepPlan::quick(backends)
    } else {
        SweepPlan::full(backends)
    };
    let progress = indicatif::ProgressBar::new(plan.len() as u64).with_style(
        indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} [{elapsed}] {msg}")
            .expect("valid progress template"),
    );
    let rows = sweep::run(&plan, |row| {
        progress.set_message(format!(
            "{} {} {} {} {}: {:+.2}%",
            row.case.scene_name(),
            row.case.resolution(),
            row.setting.solver_name(),
            row.setting.step_label(),
            row.backend,
            100.0 * row.error
        ));
        progress.inc(1);
    });
    progress.finish_and_clear();
    let mut table = sweep::markdown(&rows);
    if rows.iter().any(|r| r.case.is_stiff()) {
        table += &format!(
            "\nStiff tissue, explicit MLS-MPM (CFL 0.5) against implicit:\n\n{}",
            sweep::stiff_summary(&rows)
        );
    }
    print!("{table}");
    let provenance = report::Provenance::here(gpu.as_deref());
    let [md, csv] = report::write(out, "bench", &provenance, &table, Some(&sweep::csv(&rows)))?;
    let png = out.join("bench.png");
    plot::render(&sweep::panels(&rows), "wall time (s)", "|error| (%)")?
        .write_png(&png)
        .with_context(|| format!("cannot write {}", png.display()))?;
    println!(
        "wrote {}, {} and {}",
        md.display(),
        csv.display(),
        png.display()
    );
    fail_out_of_bounds(&rows)
}

/// Fails when a run is outside its error bound, naming each.
fn fail_out_of_bounds(rows: &[sweep::Row]) -> Result<()> {
    let failures = sweep::failures(rows);
    if !failures.is_empty() {
        for f in &failures {
            eprintln!("out of bounds: {f}");
        }
        bail!(
            "{} of {} runs outside their error bound",
            failures.len(),
            rows.len()
        );
    }
    Ok(())
}
