//! Command-line entry point: one module per subcommand (`run`, `snapshot`, `stress`,
//! `check`, `bench`, `dataset`, `bag`); the benchmarks and the stress matrix live here, beside the commands
//! that print them, not in the library.

mod bag;
mod bench;
mod check;
mod dataset;
mod dds_log;
mod run;
mod scene_args;
mod snapshot;
mod stress;

use anyhow::Result;
use clap::{Parser, Subcommand};

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
    Run(run::RunArgs),
    /// Simulate a scene headless to a time and write a PNG picture of it, drawn by the
    /// camera's renderer (a GPU, or Mesa's llvmpipe; no display needed): tissue coloured
    /// by strain, tools and threads drawn.
    Snapshot(snapshot::SnapshotArgs),
    /// Stability matrix: stiffness, Poisson ratio, time step, tool speed, jaws closing,
    /// pulling apart, dropping, and a long soak; a table of stability, energy drift,
    /// penetration, escaped particles and guard events. Exits non-zero if a case inside the
    /// safe envelope fails.
    Stress(stress::StressArgs),
    /// Validate scene files and report every problem.
    Check(check::CheckArgs),
    /// Benchmarks. Without a subcommand: the runtime-against-error sweep over the analytic
    /// scenes × solver settings × backends × resolutions, printed as a table and written as
    /// CSV, Markdown and a PNG plot; exits non-zero if an error exceeds its bound.
    Bench(bench::BenchArgs),
    /// Randomised headless episodes of a scene, each recorded to its own bag and labelled
    /// with its outcomes; resumable, sharded across a cluster (`dataset summary DIR`: the
    /// outcomes as a table).
    Dataset(dataset::DatasetArgs),
    /// Bag tools: `bag recover IN OUT` rebuilds a readable bag from one a killed run left.
    Bag(bag::BagArgs),
}

fn main() {
    // Before any thread exists: the environment is not thread-safe to change.
    dvrk_tissue_sim::ros::node::adopt_wire_distribution();
    use tracing_subscriber::layer::SubscriberExt;
    use tracing_subscriber::util::SubscriberInitExt;
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
                "info,rustdds=error,ros2_client=warn,ros2_client::distributions=error".into()
            }),
        )
        .with_writer(std::io::stderr)
        .finish()
        .with(dds_log::KeepLastRepairNoise)
        .with(dvrk_tissue_sim::ros::rosout::RosoutLayer)
        .init();
    // ROS 2's own arguments (`--ros-args ... [--]`) are not the program's: parsed apart.
    let (own, ros_args) = dvrk_tissue_sim::ros::ros_args::split(std::env::args_os());
    let mut cli = Cli::parse_from(own);
    if !ros_args.is_empty() {
        match &mut cli.command {
            Command::Run(args) => args.ros_args = ros_args,
            _ => {
                eprintln!("error: --ros-args: only `run` starts a ROS node");
                std::process::exit(2);
            }
        }
    }
    if let Err(e) = dispatch(cli) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn dispatch(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Run(args) => run::run(args),
        Command::Snapshot(args) => snapshot::run(args),
        Command::Stress(args) => stress::run(args),
        Command::Check(args) => check::run(args),
        Command::Bench(args) => bench::run(args),
        Command::Dataset(args) => dataset::run(args),
        Command::Bag(args) => bag::run(args),
    }
}
