//! `dataset`: randomised headless episodes of a scene, each recorded to its own bag and
//! labelled, resumable and sharded ([`dvrk_tissue_sim::dataset`] has the format); `dataset
//! summary DIR` prints the outcomes.

use crate::run::{headless_episode, BagOptions, HeadlessOptions};
use crate::scene_args::SolverOverrides;
use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand};
use dvrk_tissue_sim::dataset::store::{self, Definition, Episode, Outcomes, Record};
use dvrk_tissue_sim::dataset::vary::Variation;
use dvrk_tissue_sim::dataset::{episode_rng, Shard};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

#[derive(Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct DatasetArgs {
    #[command(subcommand)]
    command: Option<DatasetCommand>,
    #[command(flatten)]
    spec: DatasetSpec,
}

#[derive(Subcommand)]
enum DatasetCommand {
    /// A table of a dataset's episodes and outcomes, from its manifests and records.
    Summary {
        /// The dataset's folder.
        dir: PathBuf,
    },
}

/// What `dataset` runs.
#[derive(Args, Clone)]
pub struct DatasetSpec {
    /// Scene file (TOML) the episodes vary.
    #[arg(long, required = true)]
    pub scene: Option<PathBuf>,
    /// Variation file (TOML): the scene keys varied and their distributions.
    #[arg(long, required = true)]
    pub vary: Option<PathBuf>,
    /// Episodes in the dataset (all shards together).
    #[arg(long, required = true)]
    pub episodes: Option<u64>,
    /// Folder for the episodes and manifests (created if missing; shared by all shards).
    #[arg(long, required = true)]
    pub out: Option<PathBuf>,
    /// The dataset's seed: episode i draws from (seed, i) alone.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Simulated seconds per episode (default: each sampled scene's script to its end).
    #[arg(long)]
    pub seconds: Option<f64>,
    /// Run shard i of N (the episodes whose index is i modulo N); default: from
    /// SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT or JOB_COMPLETION_INDEX/JOB_COMPLETIONS,
    /// else all.
    #[arg(long, value_name = "i/N")]
    pub shard: Option<String>,
    /// Episodes run at once, each on ⌊cores / J⌋ solver threads.
    #[arg(long, default_value_t = 1)]
    pub jobs: usize,
    #[command(flatten)]
    pub solver: SolverOverrides,
}

pub fn run(args: DatasetArgs) -> Result<()> {
    match args.command {
        Some(DatasetCommand::Summary { dir }) => summary(&dir),
        None => {
            let report = generate(&args.spec, true)?;
            if report.failed > 0 {
                bail!("{} episode(s) failed (see above)", report.failed);
            }
            Ok(())
        }
    }
}

/// What one worker did.
pub struct WorkerReport {
    /// Episodes run now.
    pub ran: usize,
    /// Episodes that failed.
    pub failed: usize,
    /// The shard's records, in index order.
    pub records: Vec<Record>,
}

/// A loaded dataset: its scene, variation and definition.
pub struct Prepared {
    pub variation: Variation,
    pub definition: Definition,
    pub out: PathBuf,
    pub shard: Shard,
}

/// Loads and checks everything before any episode runs.
pub fn prepare(spec: &DatasetSpec, verbose: bool) -> Result<Prepared> {
    let (Some(scene_path), Some(vary_path), Some(episodes), Some(out)) =
        (&spec.scene, &spec.vary, spec.episodes, &spec.out)
    else {
        bail!("dataset needs --scene, --vary, --episodes and --out");
    };
    if let Some(s) = spec.seconds {
        if !(s.is_finite() && s > 0.0) {
            bail!("--seconds {s}: must be a positive number of simulated seconds");
        }
    }
    if spec.jobs == 0 {
        bail!("--jobs 0: at least one episode must run at a time");
    }
    let shard = match &spec.shard {
        Some(text) => Shard::parse(text).map_err(anyhow::Error::msg)?,
        None => {
            match Shard::from_env(|name| std::env::var(name).ok()).map_err(anyhow::Error::msg)? {
                Some((shard, from)) => {
                    if verbose {
                        println!("shard {}/{} from {from}", shard.index, shard.count);
                    }
                    shard
                }
                None => Shard::ALL,
            }
        }
    };
    let scene = spec.solver.load(scene_path)?;
    let variation = Variation::load(vary_path, &scene, scene_path).map_err(anyhow::Error::msg)?;
    let read = |p: &Path| {
        dvrk_tissue_sim::files::read_regular(p).with_context(|| format!("reading {}", p.display()))
    };
    let definition = Definition {
        seed: spec.seed,
        episodes,
        seconds: spec.seconds,
        scene: read(scene_path)?,
        vary: read(vary_path)?,
    };
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let defined = out.join("dataset.json");
    match std::fs::read_to_string(&defined) {
        Ok(text) => {
            let existing: Definition = serde_json::from_str(&text)
                .with_context(|| format!("{}: not a dataset definition", defined.display()))?;
            if existing != definition {
                bail!(
                    "{} holds another dataset (seed, episode count, --seconds, scene or \
                     variation differ): use a new --out folder",
                    out.display()
                );
            }
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            let text = serde_json::to_string_pretty(&definition)?;
            store::write_atomic(out, "dataset.json", text.as_bytes())
                .with_context(|| format!("writing {}", defined.display()))?;
        }
        Err(e) => return Err(e).with_context(|| format!("reading {}", defined.display())),
    }
    Ok(Prepared {
        variation,
        definition,
        out: out.clone(),
        shard,
    })
}

/// Runs this worker's unfinished episodes; `verbose` prints a line per episode.
pub fn generate(spec: &DatasetSpec, verbose: bool) -> Result<WorkerReport> {
    let start = Instant::now();
    let prepared = prepare(spec, verbose)?;
    let (out, shard) = (&prepared.out, prepared.shard);
    let indices: Vec<u64> = shard.indices(prepared.definition.episodes).collect();
    let mut done: Vec<Record> = Vec::new();
    let mut pending = Vec::new();
    for &i in &indices {
        match store::finished(out, i) {
            Some(record) => done.push(record),
            None => pending.push(i),
        }
    }
    let skipped = done.len();
    // A manifest line lost to a kill between an episode's record and its line comes back.
    let episodes: Vec<Episode> = done.iter().map(|r| r.episode.clone()).collect();
    store::rewrite_manifest(out, shard, &episodes)
        .with_context(|| format!("writing the manifest in {}", out.display()))?;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let jobs = spec.jobs.min(pending.len()).max(1);
    let threads = (cores / jobs).max(1);
    if verbose {
        println!(
            "dataset {}: shard {}/{}, {} episode(s) of {}: {} finished before, {} to run, {jobs} \
             at a time on {threads} thread(s) each",
            out.display(),
            shard.index,
            shard.count,
            indices.len(),
            prepared.definition.episodes,
            skipped,
            pending.len()
        );
    }
    let next = AtomicUsize::new(0);
    let results = Mutex::new((done, 0usize));
    std::thread::scope(|scope| -> Result<()> {
        let mut workers = Vec::new();
        for _ in 0..jobs {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .context("a thread pool for an episode")?;
            let (next, results, pending, prepared) = (&next, &results, &pending, &prepared);
            workers.push(scope.spawn(move || {
                while let Some(&index) = pending.get(next.fetch_add(1, Ordering::Relaxed)) {
                    let result = pool.install(|| run_episode(prepared, index, threads));
                    let mut results = results.lock().unwrap_or_else(|e| e.into_inner());
                    match result {
                        Ok(record) => {
                            if verbose {
                                print_episode(&record);
                            }
                            if let Err(e) =
                                store::append_manifest(&prepared.out, shard, &record.episode)
                            {
                                eprintln!("episode {index}: manifest: {e}");
                                results.1 += 1;
                            }
                            results.0.push(record);
                        }
                        Err(e) => {
                            eprintln!("episode {index}: failed: {e:#}");
                            results.1 += 1;
                        }
                    }
                }
            }));
        }
        for w in workers {
            w.join()
                .map_err(|_| anyhow::anyhow!("an episode worker panicked"))?;
        }
        Ok(())
    })?;
    let (mut records, failed) = results.into_inner().unwrap_or_else(|e| e.into_inner());
    records.sort_by_key(|r| r.episode.index);
    let episodes: Vec<Episode> = records.iter().map(|r| r.episode.clone()).collect();
    store::rewrite_manifest(out, shard, &episodes)
        .with_context(|| format!("writing the manifest in {}", out.display()))?;
    let wall_s = start.elapsed().as_secs_f64();
    let ran = records.len() - skipped;
    if verbose {
        println!(
            "dataset: {ran} episode(s) run, {skipped} skipped (finished before), {failed} \
             failed, in {wall_s:.1} s wall ({:.0} episodes/hour); manifest {}",
            ran as f64 / wall_s * 3600.0,
            out.join(store::manifest_file(shard)).display()
        );
    }
    Ok(WorkerReport {
        ran,
        failed,
        records,
    })
}

/// Samples, runs and records one episode; its files appear complete or not at all.
fn run_episode(prepared: &Prepared, index: u64, threads: usize) -> Result<Record> {
    let start = Instant::now();
    let seed = prepared.definition.seed;
    let sample = prepared
        .variation
        .sample(&mut episode_rng(seed, index))
        .map_err(anyhow::Error::msg)
        .with_context(|| format!("episode {index}: sampling the scene"))?;
    let out = &prepared.out;
    let seconds = prepared
        .definition
        .seconds
        .or(sample.scene.script_end_s())
        .unwrap_or(crate::run::UNSCRIPTED_SECONDS);
    let bag = store::episode_file(index, "mcap");
    let partial = out.join(store::partial_name(&bag));
    let simulate = Instant::now();
    let outcome = headless_episode(
        &sample.scene,
        seconds,
        HeadlessOptions {
            print_every: None,
            snapshots: None,
            record: Some(BagOptions {
                bag: &partial,
                chunk_every: dvrk_tissue_sim::ros::recorder::DEFAULT_CHUNK_SECONDS,
                replace: true,
                lossless: true,
            }),
            guard_is_outcome: true,
        },
    )
    .inspect_err(|_| {
        let _ = std::fs::remove_file(&partial);
    })?;
    let simulate_s = simulate.elapsed().as_secs_f64();
    let recorded = outcome.record.expect("recording was asked for");
    if let Some(why) = recorded.stopped {
        let _ = std::fs::remove_file(&partial);
        bail!("episode {index}: recording stopped: {why}");
    }
    store::commit(&partial, &out.join(&bag))
        .with_context(|| format!("episode {index}: renaming its bag"))?;
    let scene_file = store::episode_file(index, "toml");
    store::write_atomic(out, &scene_file, sample.toml.as_bytes())
        .with_context(|| format!("episode {index}: writing its scene"))?;
    let episode = Episode {
        index,
        seed,
        draws: sample.draws,
        params: sample.params.into_iter().collect(),
        outcomes: Outcomes {
            lift_m: outcome.lift_m,
            com_rise_m: outcome.com_rise_m,
            pieces: outcome.pieces,
            wound_gap_m: outcome.wound_gap_m.map(|(_, end)| end),
            peak_force_n: outcome.peak_force_n.into_iter().collect(),
            guard_stop: outcome.guard_stop,
        },
        frames: outcome.frames,
        simulated_s: outcome.simulated_s,
        substeps: outcome.substeps,
        bag,
        bag_messages: recorded.messages,
        scene: scene_file,
    };
    let record = Record {
        episode,
        wall_s: start.elapsed().as_secs_f64(),
        simulate_s,
        threads,
    };
    // The record last: its presence marks the episode finished.
    let text = serde_json::to_string_pretty(&record)?;
    store::write_atomic(out, &store::episode_file(index, "json"), text.as_bytes())
        .with_context(|| format!("episode {index}: writing its record"))?;
    Ok(record)
}

fn forces(o: &Outcomes) -> String {
    o.peak_force_n
        .values()
        .map(|f| format!("{f:.3}"))
        .collect::<Vec<_>>()
        .join("/")
}

fn print_episode(r: &Record) {
    let (e, o) = (&r.episode, &r.episode.outcomes);
    println!(
        "episode {}: lift {:.2} mm, pieces {}, {}peak force {} N{}, {} frames, {:.1} s wall",
        e.index,
        o.lift_m * 1e3,
        o.pieces,
        o.wound_gap_m
            .map(|g| format!("wound gap {:.2} mm, ", g * 1e3))
            .unwrap_or_default(),
        forces(o),
        o.guard_stop
            .as_ref()
            .map(|g| format!(", guard stop: {g}"))
            .unwrap_or_default(),
        e.frames,
        r.wall_s
    );
}

/// `dataset summary DIR`.
fn summary(dir: &Path) -> Result<()> {
    let text = std::fs::read_to_string(dir.join("dataset.json"))
        .with_context(|| format!("{}: no dataset.json (not a dataset folder?)", dir.display()))?;
    let definition: Definition = serde_json::from_str(&text)
        .with_context(|| format!("{}/dataset.json: not a dataset definition", dir.display()))?;
    let (episodes, problems) = store::read_manifests(dir)
        .with_context(|| format!("reading the manifests in {}", dir.display()))?;
    let mut rows = Vec::new();
    let mut wall = 0.0;
    for e in &episodes {
        let record = store::finished(dir, e.index);
        let w = record.as_ref().map(|r| r.wall_s);
        wall += w.unwrap_or(0.0);
        let o = &e.outcomes;
        rows.push(vec![
            e.index.to_string(),
            format!("{:.2}", o.lift_m * 1e3),
            format!("{:.2}", o.com_rise_m * 1e3),
            o.pieces.to_string(),
            o.wound_gap_m
                .map_or("-".into(), |g| format!("{:.2}", g * 1e3)),
            forces(o),
            if o.guard_stop.is_some() { "yes" } else { "no" }.into(),
            e.frames.to_string(),
            w.map_or("?".into(), |w| format!("{w:.1}")),
            e.bag.clone(),
        ]);
    }
    let head = [
        "episode",
        "lift mm",
        "com rise mm",
        "pieces",
        "wound gap mm",
        "peak force N",
        "guard stop",
        "frames",
        "wall s",
        "bag",
    ];
    let mut widths: Vec<usize> = head.iter().map(|h| h.chars().count()).collect();
    for row in &rows {
        for (w, cell) in widths.iter_mut().zip(row) {
            *w = (*w).max(cell.chars().count());
        }
    }
    let line = |cells: Vec<String>| {
        let padded: Vec<String> = cells
            .iter()
            .zip(&widths)
            .map(|(c, w)| format!("{c:>w$}"))
            .collect();
        println!("{}", padded.join("  "));
    };
    line(head.iter().map(|h| h.to_string()).collect());
    for row in rows {
        line(row);
    }
    let partials = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_str().is_some_and(store::is_partial))
        .count();
    let guard = episodes
        .iter()
        .filter(|e| e.outcomes.guard_stop.is_some())
        .count();
    println!(
        "{} of {} episode(s) finished (seed {}), {guard} stopped by the guard, {:.1} s wall in \
         all",
        episodes.len(),
        definition.episodes,
        definition.seed,
        wall
    );
    if partials > 0 {
        println!(
            "{partials} temporary .partial file(s) left by killed workers (never read; safe to \
             delete when no worker runs)"
        );
    }
    for p in &problems {
        println!("warning: {p}");
    }
    Ok(())
}
