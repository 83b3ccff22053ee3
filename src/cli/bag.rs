//! `bag`: tools for bags written by `run --record`.

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use dvrk_tissue_sim::ros::recover;
use std::path::PathBuf;

#[derive(Args)]
pub struct BagArgs {
    #[command(subcommand)]
    command: BagCommand,
}

#[derive(Subcommand)]
enum BagCommand {
    /// Rebuild a finished, indexed bag from one whose run was killed (or lost power) before
    /// it finished the file: every message of its completed chunks is kept.
    Recover {
        /// The unfinished bag.
        input: PathBuf,
        /// The rebuilt bag (must not exist yet, unless --force).
        output: PathBuf,
        /// Replace OUTPUT if it exists (a symlink there is replaced, never followed).
        #[arg(long)]
        force: bool,
    },
}

pub fn run(args: BagArgs) -> Result<()> {
    match args.command {
        BagCommand::Recover {
            input,
            output,
            force,
        } => {
            let unfinished = recover::is_unfinished(&input)
                .with_context(|| format!("cannot read {}", input.display()))?;
            let r = recover::recover(&input, &output, force)?;
            println!(
                "recovered {} messages on {} topics through t = {:.3} s into {}",
                r.messages,
                r.topics,
                r.end,
                output.display()
            );
            match (&r.stopped, unfinished) {
                (Some(why), _) => println!(
                    "{} was cut off; the part after the last completed chunk is lost ({why})",
                    input.display()
                ),
                (None, true) => println!("{} ended after a completed chunk", input.display()),
                (None, false) => println!("{} was already a finished bag", input.display()),
            }
            Ok(())
        }
    }
}
