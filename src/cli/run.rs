//! `run`: the ROS 2 node on a scene; `--headless` instead runs its scripted tools with no
//! network at all; `--replay` drives the arms from a recorded bag.

use crate::scene_args::SolverOverrides;
use anyhow::{bail, Context, Result};
use clap::Args;
use dvrk_tissue_sim::config::Scene;
use dvrk_tissue_sim::output::snapshot::{SnapshotOptions, SnapshotSchedule};
use dvrk_tissue_sim::output::TissueSurface;
use dvrk_tissue_sim::ros;
use dvrk_tissue_sim::sim::{headless, FrameLoop, SimSetup};
use dvrk_tissue_sim::world::World;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Args)]
pub struct RunArgs {
    /// Scene file (TOML).
    #[arg(long, default_value = "config/default.toml")]
    scene: PathBuf,
    /// Scripted run: no ROS, no network socket; prints a line per frame and a summary.
    #[arg(long)]
    headless: bool,
    /// Simulated seconds to run. Headless default: the tools' script to its end (the last
    /// keyframe plus the scene's `settle_s`), or 2 s for a scene without keyframes; the node
    /// runs until Ctrl-C.
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
    #[command(flatten)]
    solver: SolverOverrides,
    /// Write a PNG of the scene (tissue coloured by equivalent strain, tools drawn)
    /// every S simulated seconds, headless or as a node.
    #[arg(long, value_name = "S")]
    snapshot_every: Option<f64>,
    /// Folder for those pictures (created if missing).
    #[arg(long, default_value = "snapshots")]
    snapshot_dir: PathBuf,
    /// Record the node's outputs and the inputs it applied to this rosbag2-compatible
    /// MCAP file (finished on Ctrl-C and at the end of --seconds); with --headless, the
    /// scripted run's outputs at the scene's rates in simulated time.
    #[arg(long, value_name = "OUT.mcap")]
    record: Option<PathBuf>,
    /// Replace the --record file if it exists (by default an existing file is refused; a
    /// symlink there is replaced, never followed).
    #[arg(long, requires = "record")]
    force: bool,
    /// Close a chunk of the --record bag, synced to disk, at least every S simulated
    /// seconds: a killed run or a power loss loses at most that span (`bag recover` reads
    /// the rest back).
    #[arg(long, value_name = "S", default_value_t = ros::recorder::DEFAULT_CHUNK_SECONDS)]
    record_chunk: f64,
    /// Drive the arms from the inputs of a bag written by --record, each at the frame it
    /// was applied originally (the input topics are not subscribed); runs until the bag's
    /// end unless --seconds is given. With --headless: no network, as fast as it computes.
    #[arg(long, value_name = "IN.mcap")]
    replay: Option<PathBuf>,
    /// The arguments of `--ros-args` blocks (split off before the rest is parsed).
    #[arg(skip)]
    pub ros_args: Vec<String>,
}

pub fn run(args: RunArgs) -> Result<()> {
    let snapshots = snapshot_schedule(args.snapshot_every, args.snapshot_dir)?;
    if args.headless && args.replay.is_none() {
        return run_headless(
            &args.scene,
            args.seconds,
            args.print_every.max(1),
            &args.solver,
            snapshots,
            args.record
                .as_deref()
                .map(|path| (path, args.record_chunk, args.force)),
        );
    }
    if args.headless && !args.ros_args.is_empty() {
        bail!("--ros-args: for the ROS node only, not with --headless");
    }
    let ros_args = ros::ros_args::RosArgs::parse(&args.ros_args)?;
    let path = match ros_args.param("scene") {
        Some(ros::ros_args::ParamValue::Text(scene)) => PathBuf::from(scene),
        _ => args.scene,
    };
    let mut scene = args.solver.load(&path)?;
    ros_args.apply_rates(&mut scene);
    let problems = dvrk_tissue_sim::config::validate(&scene);
    if !problems.is_empty() {
        let problems: Vec<String> = problems.iter().map(|p| format!("  {p}")).collect();
        bail!(
            "--ros-args -p: {} problem(s):\n{}",
            problems.len(),
            problems.join("\n")
        );
    }
    let settings = ros::NodeSettings {
        name: ros_args.node_name.clone().unwrap_or(args.node_name),
        namespace: ros_args.namespace.clone().unwrap_or(args.namespace),
        parameters: ros_args.declared(&path.to_string_lossy(), &scene),
        remaps: ros_args.remaps,
        seconds: args.seconds,
        snapshots,
        record: args.record,
        record_replace: args.force,
        record_chunk: args.record_chunk,
        replay: args.replay,
    };
    if args.headless {
        let run = ros::session::run_headless(&scene, &settings)
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
    ros::run_node(&scene, &settings).with_context(|| format!("node on scene {}", path.display()))
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

/// Simulated seconds a headless run of a scene without keyframes lasts.
pub const UNSCRIPTED_SECONDS: f64 = 2.0;

/// How long a headless run lasts: `--seconds` when given, else the scene's script to its end,
/// else [`UNSCRIPTED_SECONDS`]; with the reason, for the log.
fn headless_seconds(scene: &Scene, asked: Option<f64>) -> (f64, &'static str) {
    match (asked, scene.script_end_s()) {
        (Some(s), _) => (s, "--seconds"),
        (None, Some(end)) => (end, "the last keyframe plus settle_s"),
        (None, None) => (UNSCRIPTED_SECONDS, "no keyframes: the default"),
    }
}

fn run_headless(
    path: &Path,
    seconds: Option<f64>,
    print_every: u32,
    solver: &SolverOverrides,
    snapshots: Option<SnapshotSchedule>,
    record: Option<(&Path, f64, bool)>,
) -> Result<()> {
    let scene = solver.load(path)?;
    let (seconds, why) = headless_seconds(&scene, seconds);
    tracing::info!("running {seconds} s simulated ({why})");
    let outcome = headless_episode(
        &scene,
        seconds,
        HeadlessOptions {
            print_every: Some(print_every),
            snapshots,
            record: record.map(|(bag, chunk_every, replace)| BagOptions {
                bag,
                chunk_every,
                replace,
                lossless: false,
            }),
            guard_is_outcome: false,
        },
    )?;
    if let Some(recorded) = outcome.record {
        println!("summary: recorded {recorded}");
    }
    Ok(())
}

/// How a headless run prints and records.
pub struct HeadlessOptions<'a> {
    /// Print the scene, every n-th frame's line and the summary; `None`: print nothing.
    pub print_every: Option<u32>,
    /// Pictures to take.
    pub snapshots: Option<SnapshotSchedule>,
    /// The bag to record, if any.
    pub record: Option<BagOptions<'a>>,
    /// A guard stop ends the run as an outcome (`HeadlessOutcome::guard_stop`, the bag
    /// finished) instead of failing it.
    pub guard_is_outcome: bool,
}

/// The `--record` bag of a headless run.
pub struct BagOptions<'a> {
    /// The bag's path.
    pub bag: &'a Path,
    /// `--record-chunk`, simulated seconds.
    pub chunk_every: f64,
    /// Replace an existing file there.
    pub replace: bool,
    /// Wait for the writer instead of dropping a frame when it is behind (a headless run has
    /// no clock to keep up with; a dataset's bag must hold every frame to be reproducible).
    pub lossless: bool,
}

/// What a headless run measured: the figures of its summary lines, and a dataset episode's
/// outcomes.
pub struct HeadlessOutcome {
    /// Frames stepped.
    pub frames: u32,
    /// Simulated time at the end, s.
    pub simulated_s: f64,
    /// Wall time of the stepping loop, s.
    pub wall_s: f64,
    /// Substeps in all.
    pub substeps: u64,
    /// Tissue particles.
    pub particles: usize,
    /// Each tool's name and its peak contact force, N.
    pub peak_force_n: Vec<(String, f64)>,
    /// The largest rise of the tissue's highest particle above its start, m (how far a
    /// grasp lifted the tissue).
    pub lift_m: f64,
    /// Rise of the tissue's centre of mass from start to end, m.
    pub com_rise_m: f64,
    /// Tissue pieces at the end (connected components).
    pub pieces: usize,
    /// The wound gap at the start and the end, m, in a scene with a `wound` (see
    /// [`dvrk_tissue_sim::world::wound`]).
    pub wound_gap_m: Option<(f64, f64)>,
    /// Each thread's name and the largest tension any of its segments carried, N.
    pub peak_tension_n: Vec<(String, f64)>,
    /// The guard event that stopped the run, when `guard_is_outcome` let it.
    pub guard_stop: Option<String>,
    /// What the bag holds, when recording.
    pub record: Option<ros::recorder::RecordSummary>,
}

/// Highest particle z, m (`f32::MIN` with no particles).
fn top_z(world: &World) -> f32 {
    world
        .particles()
        .x
        .iter()
        .map(|x| x.z)
        .fold(f32::MIN, f32::max)
}

/// Runs `scene` headless for `seconds` of simulated time (the tools on their keyframes, no
/// network): the loop of `run --headless`, and of every `dataset` episode.
pub fn headless_episode(
    scene: &Scene,
    seconds: f64,
    options: HeadlessOptions<'_>,
) -> Result<HeadlessOutcome> {
    let world = World::try_new(scene).context("choosing the solver backend")?;
    let frames = (seconds * scene.frame_rate_hz).round().max(1.0) as u32;
    let verbose = options.print_every.is_some();
    let print_every = options.print_every.unwrap_or(u32::MAX).max(1);
    if verbose {
        println!(
            "scene \"{}\": {} particles, {} thread(s), grid {}×{}×{} nodes (dx {} m), {} tool(s), {} frames of {:.4} s, backend {}",
            scene.name,
            world.particles().len(),
            world.threads().len(),
            world.layout().nodes[0],
            world.layout().nodes[1],
            world.layout().nodes[2],
            scene.domain.dx,
            world.tools().len(),
            frames,
            world.frame_dt(),
            world.backend().name()
        );
    }
    let snapshot_dir = options
        .snapshots
        .as_ref()
        .map(|s| s.dir.clone())
        .unwrap_or_default();
    let start_top = top_z(&world);
    let start_gap = world.wound_gap();
    let start_com_z = if world.particles().is_empty() {
        0.0
    } else {
        world.particles().centre_of_mass().z
    };
    let mut setup = SimSetup::scripted(world);
    setup.snapshots = options.snapshots;
    let recorder = match options.record {
        None => None,
        Some(bag) => Some(attach_recorder(&mut setup, scene, &bag, verbose)?),
    };
    let mut sim = FrameLoop::new(setup, None);
    let start = Instant::now();
    let mut total_substeps: u64 = 0;
    let mut peak_force = vec![0.0f64; sim.world().tools().len()];
    let mut peak_speed = 0.0f32;
    let mut peak_stretch = 0.0f32;
    let mut split_refused = 0usize;
    let mut peak_top = start_top;
    let mut peak_elongation = vec![0.0f64; sim.world().threads().len()];
    let mut peak_tension = vec![0.0f32; sim.world().threads().len()];
    let mut guard_stop = None;
    let mut frame = 0u32;
    headless::run(&mut sim, |sim, stepped| -> Result<ControlFlow<()>> {
        let report = match stepped.report {
            Err(stop) if options.guard_is_outcome => {
                guard_stop = Some(stop.to_string());
                return Ok(ControlFlow::Break(()));
            }
            report => report.context("headless run")?,
        };
        let wall = stepped.wall.as_secs_f64();
        if let Some(snapshot) = stepped.snapshot {
            let path =
                snapshot.with_context(|| format!("snapshot in {}", snapshot_dir.display()))?;
            println!("snapshot {}", path.display());
        }
        let world = sim.world();
        total_substeps += report.substeps as u64;
        peak_speed = peak_speed.max(report.max_speed);
        peak_stretch = peak_stretch.max(report.max_stretch);
        split_refused += report.split.refused;
        peak_top = peak_top.max(top_z(world));
        for (p, w) in peak_force.iter_mut().zip(&report.wrenches) {
            *p = p.max(w.force.norm());
        }
        for (p, t) in peak_elongation.iter_mut().zip(world.threads()) {
            *p = p.max(t.elongation().abs());
        }
        for (p, t) in peak_tension.iter_mut().zip(world.threads()) {
            *p = t.rod.tension.iter().copied().fold(*p, f32::max);
        }
        if report.truncated {
            tracing::warn!(
                "frame {frame}: hit max_substeps_per_frame; simulated time lags the frame clock"
            );
        }
        if verbose && (frame.is_multiple_of(print_every) || frame + 1 == frames) {
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
            let step = if report.max_stretch > 0.0 {
                let at = report.max_stretch_at * 1e3;
                format!(
                    "{step} stretch={:.2}@({:.1},{:.1},{:.1})mm",
                    report.max_stretch, at.x, at.y, at.z
                )
            } else {
                step
            };
            let step = if report.split.split > 0 {
                format!("{step} split={}", report.split.split)
            } else {
                step
            };
            // The implicit solve's work this frame (load-independent, unlike the wall time).
            let step = if report.solve.newton > 0 {
                format!(
                    "{step} newton={} cg={}",
                    report.solve.newton, report.solve.cg
                )
            } else {
                step
            };
            println!(
                "t={:.4}s {step} {} vmax={:.4}m/s rtf={:.3}",
                report.time,
                forces.join(" "),
                report.max_speed,
                world.frame_dt() / wall
            );
        }
        frame += 1;
        Ok(if frame == frames {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        })
    })?;
    let world = sim.world();
    let wall = start.elapsed().as_secs_f64();
    let (com_z, pieces) = if world.particles().is_empty() {
        (0.0, 0)
    } else {
        (world.particles().centre_of_mass().z, world.pieces())
    };
    let outcome = HeadlessOutcome {
        frames: frame,
        simulated_s: world.time(),
        wall_s: wall,
        substeps: total_substeps,
        particles: world.particles().len(),
        peak_force_n: world
            .tools()
            .iter()
            .zip(&peak_force)
            .map(|(t, f)| (t.name.clone(), *f))
            .collect(),
        lift_m: f64::from(peak_top - start_top),
        com_rise_m: com_z - start_com_z,
        pieces,
        wound_gap_m: start_gap
            .zip(world.wound_gap())
            .map(|(start, end)| (f64::from(start), f64::from(end))),
        peak_tension_n: world
            .threads()
            .iter()
            .zip(&peak_tension)
            .map(|(t, p)| (t.name.clone(), f64::from(*p)))
            .collect(),
        guard_stop,
        record: None,
    };
    if verbose {
        print_summary(
            world,
            &outcome,
            peak_speed,
            (peak_stretch, split_refused),
            &peak_elongation,
        );
    }
    // The recorder's writer ends once the loop, which holds its sending end, is gone.
    drop(sim);
    let record = recorder.map(|r| r.finish()).transpose()?;
    Ok(HeadlessOutcome { record, ..outcome })
}

/// The summary lines of `run --headless`.
fn print_summary(
    world: &World,
    outcome: &HeadlessOutcome,
    peak_speed: f32,
    (peak_stretch, split_refused): (f32, usize),
    peak_elongation: &[f64],
) {
    let (frames, wall, total_substeps) = (outcome.frames, outcome.wall_s, outcome.substeps);
    let n = outcome.particles as f64;
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
    for (name, f) in &outcome.peak_force_n {
        println!("summary: tool {name} peak contact force {f:.4} N");
    }
    if !world.particles().is_empty() {
        println!("summary: peak particle speed {peak_speed:.4} m/s");
        let com = world.particles().centre_of_mass();
        let top = top_z(world);
        println!(
            "summary: tissue centre of mass ({:.4}, {:.4}, {:.4}) m, highest particle z {top:.4} m",
            com.x, com.y, com.z
        );
        println!("summary: pieces {}", world.pieces());
        if let Some((start, end)) = outcome.wound_gap_m {
            let names = world.scene().wound.clone().unwrap_or_default();
            let tensions: Vec<_> = outcome
                .peak_tension_n
                .iter()
                .map(|(name, t)| format!(", thread {name:?} peak tension {t:.3} N"))
                .collect();
            println!(
                "summary: wound gap {:.2} mm -> {:.2} mm (between {:?} and {:?}){}",
                start * 1e3,
                end * 1e3,
                names[0],
                names[1],
                tensions.concat()
            );
        }
        let added = world.particles().len() - world.scene_particles();
        if peak_stretch > 0.0 {
            println!(
                "summary: particles {} ({added} added by splitting, {split_refused} splits refused \
                 at solver.split_max_growth), largest stretch {peak_stretch:.2}",
                world.particles().len()
            );
        }
    }
    for (t, peak) in world.threads().iter().zip(peak_elongation) {
        // The wound's line names the peak tensions where the scene has a wound.
        let peak_tension = outcome.peak_tension_n.iter().find(|(n, _)| *n == t.name);
        if let (Some((_, tension)), None) = (peak_tension, outcome.wound_gap_m) {
            println!("summary: thread {} peak tension {tension:.4} N", t.name);
        }
        let points = &t.rod.points;
        let (first, last) = (points[0], points[points.len() - 1]);
        println!(
            "summary: thread {} elongation {:+.4} % (largest {:.4} % during the run), ends \
             ({:.4}, {:.4}, {:.4}) and ({:.4}, {:.4}, {:.4}) m, {} point(s) grasped",
            t.name,
            100.0 * t.elongation(),
            100.0 * peak,
            first.x,
            first.y,
            first.z,
            last.x,
            last.y,
            last.z,
            t.grasped_points()
        );
        let det = t.knot_determinant();
        println!(
            "summary: knot thread {}: det {det} ({})",
            t.name,
            dvrk_tissue_sim::rod::knot::knot_name(det)
        );
    }
}

/// Records a scripted run's outputs (tools' wrenches, /tf, tissue cloud and surface, the
/// camera's pictures, at the scene's rates in simulated time) to the bag, as the node would
/// publish them.
fn attach_recorder(
    setup: &mut SimSetup,
    scene: &Scene,
    options: &BagOptions<'_>,
    verbose: bool,
) -> Result<ros::recorder::Recorder> {
    let outputs = &scene.outputs;
    setup.surface = Some(
        TissueSurface::new(
            dvrk_tissue_sim::sim::setup::surface_kind(scene),
            setup.world.particles(),
            scene.domain.dx as f32,
            outputs.points_scalar,
        )
        .context("tissue surface for the recording")?,
    );
    // The bag keeps the camera's pictures (`camera.record`) as a node run's does.
    setup.camera = dvrk_tissue_sim::sim::setup::scripted_camera(&setup.world);
    let layout = ros::outputs::OutputLayout::new(scene, setup, "/");
    let (recorder, mut tap) =
        ros::recorder::Recorder::create(options.bag, layout, options.chunk_every, options.replace)?;
    if options.lossless {
        tap.wait_when_behind();
    }
    setup.recorder = Some(Box::new(tap));
    if verbose {
        println!("recording to {}", options.bag.display());
    }
    Ok(recorder)
}
