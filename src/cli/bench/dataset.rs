//! What a dataset costs: episodes per hour of `dataset` at each `--jobs`, and the dataset
//! machinery's overhead against plain headless runs of the same episodes.
//!
//! The overhead compares one worker (`--jobs 1`) running N episodes (sampling, validation,
//! the bag under a temporary name, the sampled scene, the record and the manifest, each
//! synced and renamed) with `run --headless --record` of the N sampled scene files it wrote,
//! one after the other in this process: the same simulation, so the difference is the
//! machinery. They are timed in the order dataset, plain, plain, dataset, so a drift of the
//! machine's load counts against neither; CPU time (this process's, every thread) is given
//! beside wall time, as it does not count other processes on a shared machine.

use crate::dataset::{generate, DatasetSpec};
use crate::run::{headless_episode, BagOptions, HeadlessOptions};
use anyhow::{Context, Result};
use dvrk_tissue_sim::dataset::store;
use std::path::Path;
use std::time::Instant;

/// One timed run.
pub struct Row {
    /// `dataset --jobs J` or `run --headless --record`.
    pub what: String,
    /// Episodes run.
    pub episodes: usize,
    /// Simulated seconds per episode.
    pub seconds: f64,
    /// Wall time of them all, s.
    pub wall_s: f64,
    /// CPU time of this process (every thread) over them, s.
    pub cpu_s: f64,
}

impl Row {
    fn per_hour(&self) -> f64 {
        self.episodes as f64 / self.wall_s * 3600.0
    }
}

/// This process's CPU time so far (user and system, every thread), s.
fn cpu_seconds() -> f64 {
    // SAFETY: getrusage writes one rusage struct into the zeroed one it is given.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) };
    let secs = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    secs(usage.ru_utime) + secs(usage.ru_stime)
}

/// Times `work`, wall and CPU.
fn timed<T>(work: impl FnOnce() -> Result<T>) -> Result<(T, f64, f64)> {
    let (cpu, start) = (cpu_seconds(), Instant::now());
    let value = work()?;
    Ok((value, start.elapsed().as_secs_f64(), cpu_seconds() - cpu))
}

/// Plain `run --headless --record` of the scene files a dataset wrote, one after the other.
fn plain_runs(dataset: &Path, records: &[store::Record], seconds: f64) -> Result<Row> {
    let bags = tempfile::tempdir().context("a folder for the plain runs' bags")?;
    let ((), wall_s, cpu_s) = timed(|| {
        for r in records {
            let scene = dvrk_tissue_sim::config::load(&dataset.join(&r.episode.scene))?;
            let bag = bags.path().join(&r.episode.bag);
            headless_episode(
                &scene,
                seconds,
                HeadlessOptions {
                    print_every: None,
                    snapshots: None,
                    record: Some(BagOptions {
                        bag: &bag,
                        chunk_every: dvrk_tissue_sim::ros::recorder::DEFAULT_CHUNK_SECONDS,
                        replace: false,
                        lossless: false,
                    }),
                    guard_is_outcome: true,
                },
            )?;
        }
        Ok(())
    })?;
    Ok(Row {
        what: "run --headless --record".into(),
        episodes: records.len(),
        seconds,
        wall_s,
        cpu_s,
    })
}

fn dataset_run(
    spec: &DatasetSpec,
    jobs: usize,
) -> Result<(Row, tempfile::TempDir, Vec<store::Record>)> {
    let out = tempfile::tempdir().context("a folder for the dataset")?;
    let spec = DatasetSpec {
        out: Some(out.path().to_owned()),
        jobs,
        shard: Some("0/1".into()),
        ..spec.clone()
    };
    let (report, wall_s, cpu_s) = timed(|| generate(&spec, false))?;
    if report.failed > 0 {
        anyhow::bail!("{} episode(s) failed", report.failed);
    }
    let row = Row {
        what: format!("dataset --jobs {jobs}"),
        episodes: report.ran,
        seconds: spec.seconds.unwrap_or(f64::NAN),
        wall_s,
        cpu_s,
    };
    Ok((row, out, report.records))
}

/// Times `spec` at each of `jobs`, and the overhead at `--jobs 1`; returns the table.
pub fn run(spec: &DatasetSpec, jobs: &[usize]) -> Result<String> {
    let seconds = spec.seconds.context("bench dataset needs --seconds")?;
    // Dataset, plain, plain, dataset: a drift of the machine's load counts against neither.
    let (mut first, dir, records) = dataset_run(spec, 1)?;
    first.what += " (1st)";
    eprintln!(
        "dataset: {:.1} s wall, {:.1} s CPU",
        first.wall_s, first.cpu_s
    );
    let mut plain = Vec::new();
    for n in ["2nd", "3rd"] {
        let mut row = plain_runs(dir.path(), &records, seconds)?;
        eprintln!("plain: {:.1} s wall, {:.1} s CPU", row.wall_s, row.cpu_s);
        row.what += &format!(" ({n})");
        plain.push(row);
    }
    let (mut last, _dir, last_records) = dataset_run(spec, 1)?;
    last.what += " (4th)";
    eprintln!(
        "dataset: {:.1} s wall, {:.1} s CPU",
        last.wall_s, last.cpu_s
    );
    let overhead = |of: fn(&Row) -> f64| {
        (of(&first) + of(&last) - of(&plain[0]) - of(&plain[1])) / (of(&plain[0]) + of(&plain[1]))
    };
    let (wall_overhead, cpu_overhead) = (overhead(|r| r.wall_s), overhead(|r| r.cpu_s));
    // The machinery inside each episode, timed directly: its wall time less its headless run.
    let (episode_s, simulate_s) = records
        .iter()
        .chain(&last_records)
        .fold((0.0, 0.0), |(w, s), r| (w + r.wall_s, s + r.simulate_s));
    let mut rows = vec![first, plain.remove(0), plain.remove(0), last];
    for &j in jobs.iter().filter(|&&j| j != 1) {
        rows.push(dataset_run(spec, j)?.0);
    }
    let mut table = String::from(
        "| run (in order) | episodes | simulated s each | wall s | CPU s | episodes/hour (wall) |\n\
         |---|---|---|---|---|---|\n",
    );
    for r in &rows {
        table += &format!(
            "| {} | {} | {} | {:.1} | {:.1} | {:.0} |\n",
            r.what,
            r.episodes,
            r.seconds,
            r.wall_s,
            r.cpu_s,
            r.per_hour()
        );
    }
    table += &format!(
        "\nThe machinery inside the dataset's episodes (sampling, validation, syncing and renaming \
         the bag, the scene and the record), timed directly: {:.3} s of {:.1} s ({:.3} %).\n",
        episode_s - simulate_s,
        episode_s,
        100.0 * (episode_s - simulate_s) / episode_s
    );
    table += &format!(
        "\nDataset machinery against plain headless runs of the same sampled scenes (--jobs 1, \
         the two of each summed): {:+.2} % in wall time, {:+.2} % in CPU time (target ≤ 5 %).\n",
        100.0 * wall_overhead,
        100.0 * cpu_overhead
    );
    Ok(table)
}
