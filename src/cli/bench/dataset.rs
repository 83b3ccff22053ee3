//! What a dataset costs: episodes per hour of `dataset` at each `--jobs`, and the dataset
//! machinery's overhead against plain headless runs of the same episodes.
//!
//! The overhead compares one worker (`--jobs 1`) running N episodes (sampling, validation,
//! the bag under a temporary name, the sampled scene, the record and the manifest, each
//! synced and renamed) with `run --headless --record` of the N sampled scene files it wrote,
//! one after the other in this process: the same simulation, so the difference is the
//! machinery. The two are timed twice, in the orders dataset–plain and plain–dataset, so a
//! drift of the machine's load counts against neither.

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
}

impl Row {
    fn per_hour(&self) -> f64 {
        self.episodes as f64 / self.wall_s * 3600.0
    }
}

/// Plain `run --headless --record` of the scene files a dataset wrote, one after the other.
fn plain_runs(dataset: &Path, records: &[store::Record], seconds: f64) -> Result<f64> {
    let bags = tempfile::tempdir().context("a folder for the plain runs' bags")?;
    let start = Instant::now();
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
    Ok(start.elapsed().as_secs_f64())
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
    let report = generate(&spec, false)?;
    if report.failed > 0 {
        anyhow::bail!("{} episode(s) failed", report.failed);
    }
    let row = Row {
        what: format!("dataset --jobs {jobs}"),
        episodes: report.ran,
        seconds: spec.seconds.unwrap_or(f64::NAN),
        wall_s: report.wall_s,
    };
    Ok((row, out, report.records))
}

/// Times `spec` at each of `jobs`, and the overhead at `--jobs 1`; returns the table.
pub fn run(spec: &DatasetSpec, jobs: &[usize]) -> Result<String> {
    let seconds = spec.seconds.context("bench dataset needs --seconds")?;
    let mut rows = Vec::new();
    let mut overhead = Vec::new();
    for round in 0..2 {
        let plain_first = round == 1;
        let (mut row, dir, records) = dataset_run(spec, 1)?;
        let plain_start = Instant::now();
        let plain = plain_runs(dir.path(), &records, seconds)?;
        let plain_row = Row {
            what: "run --headless --record".into(),
            episodes: records.len(),
            seconds,
            wall_s: plain,
        };
        if plain_first {
            // The same order reversed: the plain runs first, then a fresh dataset.
            let (again, _dir, _) = dataset_run(spec, 1)?;
            row = again;
        }
        eprintln!(
            "round {}: dataset {:.1} s, plain {:.1} s ({:.1} s)",
            round + 1,
            row.wall_s,
            plain_row.wall_s,
            plain_start.elapsed().as_secs_f64()
        );
        overhead.push((row.wall_s - plain_row.wall_s) / plain_row.wall_s);
        let label = if plain_first {
            "plain first"
        } else {
            "dataset first"
        };
        row.what = format!("{} ({label})", row.what);
        let mut plain_row = plain_row;
        plain_row.what = format!("{} ({label})", plain_row.what);
        rows.push(row);
        rows.push(plain_row);
    }
    for &j in jobs.iter().filter(|&&j| j != 1) {
        rows.push(dataset_run(spec, j)?.0);
    }
    let mut table = String::from(
        "| run | episodes | simulated s each | wall s | episodes/hour |\n|---|---|---|---|---|\n",
    );
    for r in &rows {
        table += &format!(
            "| {} | {} | {} | {:.1} | {:.0} |\n",
            r.what,
            r.episodes,
            r.seconds,
            r.wall_s,
            r.per_hour()
        );
    }
    let mean = overhead.iter().sum::<f64>() / overhead.len() as f64;
    table += &format!(
        "\nDataset machinery against plain headless runs of the same episodes (--jobs 1): \
         {:+.2} % (dataset first), {:+.2} % (plain first), mean {mean:+.2} % (target ≤ 5 %).\n",
        100.0 * overhead[0],
        100.0 * overhead[1]
    );
    Ok(table)
}
