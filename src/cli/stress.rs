//! `stress`: the stability matrix (stiffness, Poisson ratio, time step, tool speed, jaws
//! closing, pulling apart, dropping, a long soak) as a table, and the suture thread's cases.

use crate::bench::stress::{self, Matrix};
use crate::bench::{report, thread_stress};
use crate::scene_args::scene_value;
use anyhow::{bail, Result};
use clap::Args;
use dvrk_tissue_sim::mpm::backend::BackendChoice;
use std::path::PathBuf;

#[derive(Args)]
pub struct StressArgs {
    /// The CI matrix: a corner of each group and a 10-second soak.
    #[arg(long)]
    reduced: bool,
    /// Solver backend for every case (`cpu`, `gpu` or `auto`).
    #[arg(long, default_value = "cpu", value_parser = scene_value::<BackendChoice>)]
    backend: BackendChoice,
    /// Only the cases whose group or name contains this text.
    #[arg(long)]
    only: Option<String>,
    /// Folder to write the table to as stress.md and stress.csv, each headed by the command
    /// line, commit, date and machine (without it the table is only printed).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

pub fn run(args: StressArgs) -> Result<()> {
    let StressArgs {
        reduced,
        backend,
        only,
        out,
    } = args;
    let only = only.as_deref();
    let matrix = if reduced {
        Matrix::Reduced
    } else {
        Matrix::Full
    };
    let cases: Vec<_> = stress::with_backend(stress::cases(matrix), backend)
        .into_iter()
        .filter(|c| only.is_none_or(|o| c.group.contains(o) || c.name.contains(o)))
        .collect();
    // The thread's cases (a rod alone, not a scene): all or none, a second table; in the
    // full matrix or when asked for by name (`--only thread`), not in the reduced one.
    let threads = match only {
        Some(o) => "thread".contains(o) || o.contains("thread"),
        None => !reduced,
    };
    if cases.is_empty() && !threads {
        bail!("no stress case matches {:?}", only.unwrap_or_default());
    }
    let mut table = String::new();
    let mut failures = Vec::new();
    if threads {
        let results = thread_stress::run();
        table += &thread_stress::markdown(&results);
        table += "\n";
        failures.extend(
            results
                .iter()
                .filter(|r| !r.stable())
                .map(|r| format!("thread / {}", r.name)),
        );
        if cases.is_empty() {
            print!("{table}");
            return finish(&table, out.as_deref(), backend, &failures, results.len());
        }
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
    table += &stress::markdown(&results);
    print!("{table}");
    let checked = results.iter().filter(|r| r.in_envelope).count()
        + if threads { thread_stress::CASES } else { 0 };
    failures.extend(stress::envelope_failures(&results));
    finish(&table, out.as_deref(), backend, &failures, checked)
}

/// Writes the table under `out` and fails when any case inside the safe envelope did.
fn finish(
    table: &str,
    out: Option<&std::path::Path>,
    backend: BackendChoice,
    failures: &[String],
    checked: usize,
) -> Result<()> {
    if let Some(dir) = out {
        let gpu = (backend != BackendChoice::Cpu).then(crate::bench::adapter_name);
        let provenance = report::Provenance::here(gpu.as_deref());
        let [md, csv] = report::write(dir, "stress", &provenance, table, None)?;
        println!("wrote {} and {}", md.display(), csv.display());
    }
    if !failures.is_empty() {
        for f in failures {
            eprintln!("unstable inside the safe envelope: {f}");
        }
        bail!(
            "{} of {} cases inside the safe envelope failed",
            failures.len(),
            checked
        );
    }
    Ok(())
}
