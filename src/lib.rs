//! dvrk-tissue-sim: MPM soft-tissue simulation for da Vinci Research Kit arms.
//!
//! Module map (see DESIGN.md): `config` (scene files and scene builders), `tools` (rigid
//! tool SDFs and contact), `mpm` (particles, grid, materials, solvers), `world` (one
//! scene's simulation), `robot` (PSM URDF, kinematics, teleoperation mapping), `output`
//! (point cloud, surface, pictures), `sim` (frame loop, arm state machines, scene assembly;
//! transport-agnostic), `ros` (the ROS 2 node: transport only), `sleep` (resting tissue
//! skips frames), `thread_body` (suture threads in the world: grasps, table), `validation` (scenes with analytic answers). The command line,
//! benchmarks and stress sweeps are the binary's (`src/cli/`).

pub mod config;
pub mod math;
pub mod mpm;
pub mod output;
pub mod robot;
pub mod rod;
pub mod ros;
pub mod sim;
pub mod sleep;
pub mod tools;
pub mod validation;
pub mod world;
