//! dvrk-tissue-sim: a simulation node for the da Vinci Research Kit. It stands in for PSM
//! arms and simulates the soft tissue, suture thread and tools they touch: tissue by the
//! Material Point Method (explicit MLS-MPM, position-based PB-MPM, implicit Newton–CG) on the
//! CPU or on a GPU through wgpu, thread as a Cosserat rod, cutting and tearing, contact
//! forces by momentum exchange; a ROS 2 node (CRTK topics as dVRK's) with MCAP recording and
//! replay, and headless scripted runs. The README is the front page; this is the manual, one
//! topic per module, and `config/README.md` documents every scene-file key.
//!
//! # Contents
//!
//! - [`math`]: the vector and matrix aliases every folder shares.
//! - [`files`]: reading the files a scene names: regular files only, short escaped excerpts.
//! - [`config`]: scene files (serde model, validation naming key, value and range) and
//!   scenes built in code.
//! - [`mpm`]: the tissue. The method (MLS-MPM, PIC, PB-MPM, the implicit solver), the time
//!   step, contact and wrenches, and which method to choose, with the measurements behind it.
//!   - [`mpm::cpu`]: the reference solver; block-coloured P2G without atomics.
//!   - [`mpm::cpu::tlmpm`]: total Lagrangian MPM: tissue that never parts by numerics.
//!   - [`mpm::gpu`]: the GPU backend: its design, P2G variants, the implicit solve on the
//!     device, agreement with the CPU and what the H100 measured.
//!   - [`mpm::crack`]: cutting: crack planes, the side test, pieces, PB-MPM's cut, its cost.
//!   - [`mpm::damage`]: tearing: the damage law, the crack band, the trouser and notch tests.
//!   - [`mpm::guard`]: stability: the guard and the `stress` matrix with its safe envelope.
//!   - [`mpm::pieces`]: counting the pieces a cut or a tear leaves.
//! - [`tools`]: rigid tools as signed distance fields, contact, dVRK's jaw and the grip;
//!   [`tools::slicer`] and [`tools::mesh_slicer`] are the blades.
//! - [`rod`]: the suture thread: Cosserat rod, direct solve, contact, length in contact, its
//!   analytic checks and cost; [`rod::self_contact`] and [`rod::crossing`] keep it from
//!   passing through itself; [`rod::knot`] tells a knot from its centreline.
//! - [`world`]: one scene's simulation, stepped a frame at a time;
//!   [`world::thread_body`] is a thread in the world: grasps, outputs, knots and the tied
//!   knot of `config/knot.toml`.
//! - [`sleep`]: skipping idle work: sleep, occupied blocks, absent features.
//! - [`robot`]: PSM kinematics, dVRK's URDFs ([`robot::urdf`]), joints, IK, teleoperation.
//! - [`sim`]: the frame loop, arm state machines and scene assembly, transport-agnostic.
//! - [`output`]: strain measures, the point cloud, the surface mesh and isosurface, pictures.
//! - [`render`]: the endoscope camera: stereo pinhole optics, the scene as labelled
//!   triangles, and the wgpu rasteriser of RGB, depth and label images.
//! - [`validation`]: scenes with analytic answers (Hertz, vibrating bar, stretch, beams) and
//!   the accuracy they measure.
//! - [`ros`]: the ROS 2 node in full: topics, QoS, arms, /clock and status, faults tried;
//!   [`ros::recorder`] records and replays bags.
//! - [`dataset`]: many varied headless episodes, recorded and labelled: variation files
//!   ([`dataset::vary`]), the folder's records and manifests, shards, resuming.
//!
//! The command line, benchmarks and stress sweeps are the binary's (`src/cli/`): `bench`
//! writes `bench.md`, `bench.csv` and `bench.png` where `--out` says, `stress --out` the
//! stability matrix.
#![warn(missing_docs)]

pub mod config;
pub mod dataset;
pub mod files;
pub mod math;
pub mod mpm;
pub mod output;
pub mod render;
pub mod robot;
pub mod rod;
pub mod ros;
pub mod sim;
pub mod sleep;
pub mod tools;
pub mod validation;
pub mod world;
