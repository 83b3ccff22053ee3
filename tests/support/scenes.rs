//! Small scenes built in code, shared by several test crates.

use dvrk_tissue_sim::config::builders::{domain, material, scene, tissue};
use dvrk_tissue_sim::config::{Scene, Table, Tool};

/// A 6 × 6 × 4 mm block of `e` Pa, ν 0.45 (1152 particles at dx = 1 mm) on `table` at z = 2 mm
/// under gravity, in a 16 × 16 × 14 mm domain at 60 Hz; the caller picks method and backend.
pub fn small_block(name: &str, e: f64, table: Table, tools: Vec<Tool>) -> Scene {
    scene(
        name,
        60.0,
        domain(
            [-0.008, -0.008, 0.0],
            [0.016, 0.016, 0.014],
            0.001,
            [0.0, 0.0, -9.81],
        ),
        Some(table),
        vec![tissue(
            [0.0, 0.0, 0.004],
            [0.006, 0.006, 0.004],
            material(e, 0.45, 1000.0, 0.0),
        )],
        tools,
    )
}

/// The shipped scene `config/NAME`, as a user's run loads it.
pub fn shipped(name: &str) -> Scene {
    let path = super::root().join("config").join(name);
    dvrk_tissue_sim::config::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// The shipped scene `config/NAME` on the CPU backend, for tests that compare against CPU
/// figures whatever the scene asks for.
pub fn shipped_on_cpu(name: &str) -> Scene {
    let mut scene = shipped(name);
    scene.solver.backend = dvrk_tissue_sim::mpm::backend::BackendChoice::Cpu;
    scene
}
