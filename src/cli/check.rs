//! `check`: validate scene files and report every problem.

use anyhow::{bail, Result};
use clap::Args;
use dvrk_tissue_sim::config;
use std::path::PathBuf;

#[derive(Args)]
pub struct CheckArgs {
    #[arg(required = true)]
    scenes: Vec<PathBuf>,
}

pub fn run(args: CheckArgs) -> Result<()> {
    let mut failed = 0;
    for path in &args.scenes {
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
        bail!("{failed} of {} scene file(s) invalid", args.scenes.len());
    }
    Ok(())
}
