//! `check`: validate scene files, every arm's URDF and where its home puts a needle a thread
//! is swaged to, and report every problem.

use anyhow::{bail, Result};
use clap::Args;
use dvrk_tissue_sim::{config, sim};
use std::path::PathBuf;

#[derive(Args)]
pub struct CheckArgs {
    #[arg(required = true)]
    scenes: Vec<PathBuf>,
}

pub fn run(args: CheckArgs) -> Result<()> {
    let mut failed = 0;
    for path in &args.scenes {
        let scene = match config::load(path) {
            Ok(scene) => scene,
            Err(e) => {
                failed += 1;
                println!("{e}");
                continue;
            }
        };
        let mut arm_problems: Vec<String> = sim::check_arm_urdfs(&scene)
            .iter()
            .map(ToString::to_string)
            .collect();
        arm_problems.extend(
            sim::check_arm_swages(&scene)
                .iter()
                .map(ToString::to_string),
        );
        if arm_problems.is_empty() {
            println!(
                "{}: ok (scene \"{}\", {} tissue block(s), {} tool(s), {} arm(s))",
                path.display(),
                scene.name,
                scene.tissues.len(),
                scene.tools.len(),
                scene.arms.len()
            );
        } else {
            failed += 1;
            println!("{}: {} problem(s):", path.display(), arm_problems.len());
            for problem in arm_problems {
                println!("  {problem}");
            }
        }
    }
    if failed > 0 {
        bail!("{failed} of {} scene file(s) invalid", args.scenes.len());
    }
    Ok(())
}
