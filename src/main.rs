//! Command-line entry point: `run`, `check`, `bench`.

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use dvrk_tissue_sim::mpm::backend::{BackendChoice, P2gAtomics};
use dvrk_tissue_sim::output::snapshot::{self, SnapshotOptions, SnapshotSchedule};
use dvrk_tissue_sim::output::strain::StrainMeasure;
use dvrk_tissue_sim::{bench, config, ros, world::World};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Parser)]
#[command(
    name = "dvrk-tissue-sim",
    version,
    about = "MPM soft-tissue simulation for dVRK PSM arms"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Start the ROS 2 node on a scene; `--headless` instead runs its scripted tools with no
    /// network at all.
    Run {
        /// Scene file (TOML).
        #[arg(long, default_value = "config/default.toml")]
        scene: PathBuf,
        /// Scripted run: no ROS, no network socket; prints a line per frame and a summary.
        #[arg(long)]
        headless: bool,
        /// Simulated seconds to run (headless default 2; the node runs until Ctrl-C).
        #[arg(long)]
        seconds: Option<f64>,
        /// ROS node name.
        #[arg(long, default_value = "dvrk_tissue_sim")]
        node_name: String,
        /// ROS namespace of the node and all its topics except /tf.
        #[arg(long, default_value = "/")]
        namespace: String,
        /// Print every n-th frame line (the summary is always printed).
        #[arg(long, default_value_t = 1)]
        print_every: u32,
        /// Solver backend: `auto` (a hardware GPU if there is one, else the CPU), `gpu`
        /// (software adapters too) or `cpu`. Overrides the scene's `solver.backend`.
        #[arg(long, value_enum)]
        backend: Option<BackendChoice>,
        /// GPU P2G accumulation: `auto`, `float` (f32 atomics) or `fixed` (i32 fixed point).
        /// Overrides the scene's `solver.p2g_atomics`.
        #[arg(long, value_enum)]
        p2g: Option<P2gAtomics>,
        /// Write a PNG of the scene (tissue coloured by equivalent strain, tools drawn)
        /// every S simulated seconds, headless or as a node.
        #[arg(long, value_name = "S")]
        snapshot_every: Option<f64>,
        /// Folder for those pictures (created if missing).
        #[arg(long, default_value = "snapshots")]
        snapshot_dir: PathBuf,
        /// Record the node's outputs and the inputs it applied to this rosbag2-compatible
        /// MCAP file (finished on Ctrl-C and at the end of --seconds).
        #[arg(long, value_name = "OUT.mcap")]
        record: Option<PathBuf>,
        /// Drive the arms from the inputs of a bag written by --record, each at the frame it
        /// was applied originally (the input topics are not subscribed); runs until the bag's
        /// end unless --seconds is given. With --headless: no network, as fast as it computes.
        #[arg(long, value_name = "IN.mcap")]
        replay: Option<PathBuf>,
    },
    /// Simulate a scene headless to a time and write a PNG picture of it: tissue coloured
    /// by strain, tools drawn, no display or GPU needed.
    Snapshot {
        #[arg(long, default_value = "config/default.toml")]
        scene: PathBuf,
        /// Simulated time of the picture (s).
        #[arg(long, default_value_t = 1.0)]
        time: f64,
        #[arg(long, default_value = "snapshot.png")]
        out: PathBuf,
        #[arg(long, default_value_t = 960)]
        width: u32,
        #[arg(long, default_value_t = 640)]
        height: u32,
        /// Camera azimuth about the scene, degrees from +x towards +y.
        #[arg(long, default_value_t = -60.0, allow_negative_numbers = true)]
        azimuth: f32,
        /// Camera elevation above the table plane, degrees.
        #[arg(long, default_value_t = 35.0)]
        elevation: f32,
        /// Colour by shape change (equivalent strain) or volume change (J − 1).
        #[arg(long, value_enum, default_value_t = StrainMeasure::Equivalent)]
        measure: StrainMeasure,
    },
    /// Stability matrix: stiffness, Poisson ratio, time step, tool speed, jaws closing,
    /// pulling apart, dropping, and a long soak; a table of stability, energy drift,
    /// penetration, escaped particles and guard events. Exits non-zero if a case inside the
    /// safe envelope fails.
    Stress {
        /// The CI matrix: a corner of each group and a 10-second soak.
        #[arg(long)]
        reduced: bool,
        /// Solver backend for every case.
        #[arg(long, value_enum, default_value_t = BackendChoice::Cpu)]
        backend: BackendChoice,
        /// Only the cases whose group or name contains this text.
        #[arg(long)]
        only: Option<String>,
        /// Markdown table written here too.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Validate scene files and report every problem.
    Check {
        #[arg(required = true)]
        scenes: Vec<PathBuf>,
    },
    /// Benchmarks. Without a subcommand: the runtime-against-error sweep over the analytic
    /// scenes × solver settings × backends × resolutions, printed as a table and written as
    /// CSV, Markdown and a PNG plot; exits non-zero if an error exceeds its bound.
    Bench {
        #[command(subcommand)]
        which: Option<BenchCommand>,
        /// Coarse resolutions only (under two minutes on two CPU cores).
        #[arg(long)]
        quick: bool,
        /// Folder for bench.csv, bench.md and bench.png.
        #[arg(long, default_value = "target/bench")]
        out: PathBuf,
        /// Backends to sweep (default: cpu, plus gpu when a hardware GPU adapter exists).
        #[arg(long, value_enum, value_delimiter = ',')]
        backends: Option<Vec<BackendChoice>>,
    },
}

#[derive(Subcommand)]
enum BenchCommand {
    /// Particle-substeps per second on the seed-000 retraction scene (≈24,000 particles,
    /// 64³ grid, dt from CFL), CPU backend.
    Throughput {
        /// Frames to time (after one warm-up frame).
        #[arg(long, default_value_t = 20)]
        frames: u32,
    },
    /// Error of the scenes with analytic answers at a few resolutions.
    Accuracy,
    /// What a scene does not need costs nothing: resting tissue asleep against stepped, the
    /// same tissue in a 4× larger domain, tools parked out of reach against none.
    Skip {
        /// Timed frames per case.
        #[arg(long, default_value_t = 10)]
        frames: u32,
        #[arg(long, value_enum, default_value_t = BackendChoice::Cpu)]
        backend: BackendChoice,
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
        /// Overrides the scene's `solver.backend`.
        #[arg(long, value_enum)]
        backend: Option<BackendChoice>,
    },
}

/// The first GPU adapter, as the benchmark tables name it.
fn adapter_name() -> String {
    dvrk_tissue_sim::mpm::gpu::adapter::adapters()
        .first()
        .map(|a| {
            let i = a.get_info();
            format!("{} ({:?}, {:?})", i.name, i.backend, i.device_type)
        })
        .unwrap_or_else(|| "none".into())
}

fn main() {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| "info,rustdds=error,ros2_client=warn".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    if let Err(e) = run(Cli::parse()) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Run {
            scene,
            headless,
            seconds,
            print_every,
            backend,
            p2g,
            node_name,
            namespace,
            snapshot_every,
            snapshot_dir,
            record,
            replay,
        } => {
            let snapshots = snapshot_schedule(snapshot_every, snapshot_dir)?;
            if headless && replay.is_none() && record.is_some() {
                bail!(
                    "--record in a headless run needs --replay: the scripted headless run \
                     has no ROS inputs or outputs to record (run as a node, or replay a bag)"
                );
            }
            if headless && replay.is_none() {
                return run_headless(
                    &scene,
                    seconds.unwrap_or(2.0),
                    print_every.max(1),
                    backend,
                    p2g,
                    snapshots,
                );
            }
            let path = scene;
            let mut scene = config::load(&path)?;
            if let Some(backend) = backend {
                scene.solver.backend = backend;
            }
            if let Some(p2g) = p2g {
                scene.solver.p2g_atomics = p2g;
            }
            let settings = ros::NodeSettings {
                name: node_name,
                namespace,
                seconds,
                snapshots,
                record,
                replay,
            };
            if headless {
                let run = ros::replay::run_headless(&scene, &settings)
                    .with_context(|| format!("replay on scene {}", path.display()))?;
                println!(
                    "replay: {} frames, {:.3} s simulated in {:.2} s wall",
                    run.frames,
                    run.time,
                    run.wall.as_secs_f64()
                );
                if let Some(summary) = run.record {
                    println!(
                        "recorded {summary}; {:.1} frames/s written",
                        run.frames as f64 / run.wall.as_secs_f64()
                    );
                }
                return Ok(());
            }
            ros::run_node(&scene, &settings)
                .with_context(|| format!("node on scene {}", path.display()))
        }
        Command::Snapshot {
            scene,
            time,
            out,
            width,
            height,
            azimuth,
            elevation,
            measure,
        } => {
            let loaded = config::load(&scene)?;
            let mut world = World::try_new(&loaded)?;
            while world.time() < time - 1e-9 {
                world
                    .step_frame()
                    .context("simulating up to the snapshot time")?;
            }
            world.sync_particles();
            let options = SnapshotOptions {
                width,
                height,
                azimuth_deg: azimuth,
                elevation_deg: elevation,
                measure,
                strain_range: None,
            };
            let picture = snapshot::render(&world, &options);
            picture
                .write_png(&out)
                .with_context(|| format!("writing {}", out.display()))?;
            println!(
                "{}: scene \"{}\" at t = {:.3} s, colour scale 0 … {:.3} ({measure:?} strain)",
                out.display(),
                loaded.name,
                world.time(),
                picture.strain_range
            );
            Ok(())
        }
        Command::Stress {
            reduced,
            backend,
            only,
            out,
        } => run_stress(reduced, backend, only.as_deref(), out.as_deref()),
        Command::Check { scenes } => {
            let mut failed = 0;
            for path in &scenes {
                match config::load(path) {
                    Ok(s) => println!(
                        "{}: ok (scene \"{}\", {} tissue block(s), {} tool(s))",
                        path.display(),
                        s.name,
                        s.tissues.len(),
                        s.tools.len()
                    ),
                    Err(e) => {
                        failed += 1;
                        println!("{e}");
                    }
                }
            }
            if failed > 0 {
                bail!("{failed} of {} scene file(s) invalid", scenes.len());
            }
            Ok(())
        }
        Command::Bench {
            which: None,
            quick,
            out,
            backends,
        } => run_sweep(quick, &out, backends),
        Command::Bench {
            which: Some(which), ..
        } => match which {
            BenchCommand::Skip { frames, backend } => {
                let rows = bench::skip::run(backend, frames.max(1))?;
                print!("{}", bench::skip::table(&rows));
                let over = bench::skip::over_target(&rows);
                if !over.is_empty() {
                    bail!("over target: {}", over.join("; "));
                }
                Ok(())
            }
            BenchCommand::Throughput { frames } => {
                let result = bench::throughput::run_seed000(frames);
                print!("{}", result.table());
                Ok(())
            }
            BenchCommand::Scaling {
                counts,
                min_seconds,
            } => {
                let counts = counts.unwrap_or_else(|| bench::scaling::COUNTS.to_vec());
                let rows = bench::scaling::run(&counts, min_seconds);
                print!("{}", bench::scaling::table(&rows, &adapter_name()));
                Ok(())
            }
            BenchCommand::Frame { frames } => {
                let rows = bench::frame::run(frames);
                print!("{}", bench::frame::table(&rows, &adapter_name()));
                Ok(())
            }
            BenchCommand::Surface {
                scene,
                seconds,
                every,
                backend,
            } => {
                if !(every > 0.0 && seconds > 0.0) {
                    bail!("--seconds ({seconds}) and --every ({every}) must be > 0");
                }
                let mut loaded = config::load(&scene)?;
                if let Some(b) = backend {
                    loaded.solver.backend = b;
                }
                let result = bench::surface::run(&loaded, seconds, every)
                    .with_context(|| format!("surface bench on {}", scene.display()))?;
                print!("{}", result.table());
                Ok(())
            }
            BenchCommand::Accuracy => {
                print!("{}", bench::analytic::accuracy_table());
                Ok(())
            }
        },
    }
}

fn run_sweep(quick: bool, out: &Path, backends: Option<Vec<BackendChoice>>) -> Result<()> {
    use bench::sweep::{self, SweepPlan};
    let backends = backends.unwrap_or_else(|| {
        let hardware = dvrk_tissue_sim::mpm::gpu::adapter::adapters()
            .iter()
            .any(|a| a.get_info().device_type != wgpu::DeviceType::Cpu);
        let mut b = vec![BackendChoice::Cpu];
        if hardware {
            b.push(BackendChoice::Gpu);
        }
        b
    });
    let plan = if quick {
        SweepPlan::quick(backends)
    } else {
        SweepPlan::full(backends)
    };
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
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
    let table = sweep::markdown(&rows);
    print!("{table}");
    let write = |name: &str, text: &str| {
        let path = out.join(name);
        std::fs::write(&path, text).with_context(|| format!("cannot write {}", path.display()))
    };
    write("bench.csv", &sweep::csv(&rows))?;
    write("bench.md", &table)?;
    let png = out.join("bench.png");
    bench::plot::render(&sweep::panels(&rows), "wall time (s)", "|error| (%)")
        .write_png(&png)
        .with_context(|| format!("cannot write {}", png.display()))?;
    println!(
        "wrote {}, bench.md and bench.png",
        out.join("bench.csv").display()
    );
    let failures = sweep::failures(&rows);
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

fn run_stress(
    reduced: bool,
    backend: BackendChoice,
    only: Option<&str>,
    out: Option<&Path>,
) -> Result<()> {
    use bench::stress::{self, Matrix};
    let matrix = if reduced {
        Matrix::Reduced
    } else {
        Matrix::Full
    };
    let cases: Vec<_> = stress::with_backend(stress::cases(matrix), backend)
        .into_iter()
        .filter(|c| only.is_none_or(|o| c.group.contains(o) || c.name.contains(o)))
        .collect();
    if cases.is_empty() {
        bail!("no stress case matches {:?}", only.unwrap_or_default());
    }
    let progress = indicatif::ProgressBar::new(cases.len() as u64).with_style(
        indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} [{elapsed}] {msg}")
            .expect("valid progress template"),
    );
    progress.set_message(cases[0].name.clone());
    let results = stress::run(&cases, |r| {
        // Printed through the bar so it also shows when stderr is not a terminal.
        progress.suspend(|| {
            eprintln!(
                "{} / {}: {} ({:.1} s)",
                r.group,
                r.name,
                if r.stable() { "stable" } else { "UNSTABLE" },
                r.wall_s
            )
        });
        progress.inc(1);
    });
    progress.finish_and_clear();
    let table = stress::markdown(&results);
    print!("{table}");
    if let Some(path) = out {
        std::fs::write(path, &table).with_context(|| format!("cannot write {}", path.display()))?;
    }
    let failures = stress::envelope_failures(&results);
    if !failures.is_empty() {
        for f in &failures {
            eprintln!("unstable inside the safe envelope: {f}");
        }
        bail!(
            "{} of {} cases inside the safe envelope failed",
            failures.len(),
            results.iter().filter(|r| r.in_envelope).count()
        );
    }
    Ok(())
}

/// The `--snapshot-every` pictures, with their folder created.
fn snapshot_schedule(every: Option<f64>, dir: PathBuf) -> Result<Option<SnapshotSchedule>> {
    let Some(every) = every else {
        return Ok(None);
    };
    if !(every.is_finite() && every > 0.0) {
        bail!("--snapshot-every {every}: must be a positive number of simulated seconds");
    }
    std::fs::create_dir_all(&dir)
        .with_context(|| format!("--snapshot-dir: cannot create {}", dir.display()))?;
    Ok(Some(SnapshotSchedule::new(
        every,
        dir,
        SnapshotOptions::default(),
    )))
}

fn run_headless(
    path: &Path,
    seconds: f64,
    print_every: u32,
    backend: Option<BackendChoice>,
    p2g: Option<P2gAtomics>,
    mut snapshots: Option<SnapshotSchedule>,
) -> Result<()> {
    let mut scene = config::load(path)?;
    if let Some(b) = backend {
        scene.solver.backend = b;
    }
    if let Some(p) = p2g {
        scene.solver.p2g_atomics = p;
    }
    let mut world = World::try_new(&scene).context("choosing the solver backend")?;
    let frames = (seconds * scene.frame_rate_hz).round().max(1.0) as u32;
    println!(
        "scene \"{}\": {} particles, grid {}×{}×{} nodes (dx {} m), {} tool(s), {} frames of {:.4} s, backend {}",
        scene.name,
        world.particles().len(),
        world.layout().nodes[0],
        world.layout().nodes[1],
        world.layout().nodes[2],
        scene.domain.dx,
        world.tools().len(),
        frames,
        world.frame_dt(),
        world.backend().name()
    );
    let start = Instant::now();
    let mut total_substeps: u64 = 0;
    let mut peak_force = vec![0.0f64; world.tools().len()];
    let mut peak_speed = 0.0f32;
    for frame in 0..frames {
        let t0 = Instant::now();
        let report = world.step_frame().context("headless run")?;
        let wall = t0.elapsed().as_secs_f64();
        if let Some(schedule) = &mut snapshots {
            if let Some(path) = schedule
                .take_if_due(&mut world)
                .with_context(|| format!("snapshot in {}", schedule.dir.display()))?
            {
                println!("snapshot {}", path.display());
            }
        }
        total_substeps += report.substeps as u64;
        peak_speed = peak_speed.max(report.max_speed);
        for (p, w) in peak_force.iter_mut().zip(&report.wrenches) {
            *p = p.max(w.force.norm());
        }
        if report.truncated {
            tracing::warn!(
                "frame {frame}: hit max_substeps_per_frame; simulated time lags the frame clock"
            );
        }
        if frame % print_every == 0 || frame + 1 == frames {
            let forces: Vec<String> = world
                .tools()
                .iter()
                .zip(&report.wrenches)
                .map(|(t, w)| {
                    format!(
                        "{} F=({:+.4},{:+.4},{:+.4}) N",
                        t.name, w.force.x, w.force.y, w.force.z
                    )
                })
                .collect();
            let step = if report.asleep {
                "asleep (no tool within reach)".to_owned()
            } else {
                format!("substeps={} dt={:.2e}s", report.substeps, report.dt_max)
            };
            println!(
                "t={:.4}s {step} {} vmax={:.4}m/s rtf={:.3}",
                report.time,
                forces.join(" "),
                report.max_speed,
                world.frame_dt() / wall
            );
        }
    }
    let wall = start.elapsed().as_secs_f64();
    let n = world.particles().len() as f64;
    println!(
        "summary: {frames} frames, {:.3} s simulated in {wall:.2} s wall (real-time factor {:.3})",
        world.time(),
        world.time() / wall
    );
    println!(
        "summary: {total_substeps} substeps ({:.1} per frame), {:.2} M particle-substeps/s",
        total_substeps as f64 / frames as f64,
        n * total_substeps as f64 / wall / 1e6
    );
    for (t, f) in world.tools().iter().zip(&peak_force) {
        println!("summary: tool {} peak contact force {f:.4} N", t.name);
    }
    println!("summary: peak particle speed {peak_speed:.4} m/s");
    let com = world.particles().centre_of_mass();
    let top = world
        .particles()
        .x
        .iter()
        .map(|x| x.z)
        .fold(f32::MIN, f32::max);
    println!(
        "summary: tissue centre of mass ({:.4}, {:.4}, {:.4}) m, highest particle z {top:.4} m",
        com.x, com.y, com.z
    );
    Ok(())
}
