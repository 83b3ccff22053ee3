//! What the tests that run the binary or the GPU backend share.
// Each test crate that includes this module uses part of it.
#![allow(dead_code)]

use dvrk_tissue_sim::config::builders::{domain, material, scene, tissue};
use dvrk_tissue_sim::config::{Scene, Table, Tool};
use dvrk_tissue_sim::mpm::gpu::adapter;
use dvrk_tissue_sim::mpm::P2gAtomics;
use std::process::Command;

/// The project's binary, run from the project root as a user runs it.
pub fn binary() -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_dvrk-tissue-sim"));
    command.current_dir(env!("CARGO_MANIFEST_DIR"));
    command
}

/// Runs `command` and returns its standard output; fails the test, showing both of its
/// outputs, unless it exits with success.
pub fn stdout_of_success(command: &mut Command) -> String {
    let out = command.output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// Whether the GPU P2G variant `p2g` can run here; panics under CI when there is no adapter
/// at all (CI installs llvmpipe, so the GPU paths are always tested there).
pub fn gpu_ready(p2g: P2gAtomics) -> bool {
    let adapters = adapter::adapters();
    let Some(first) = adapters.first() else {
        let reason = "no GPU adapter (Vulkan/Metal/DX12) found; on Debian/Ubuntu install \
                      mesa-vulkan-drivers for the llvmpipe software adapter";
        if std::env::var_os("CI").is_some() {
            panic!("CI is set and the GPU backend cannot be tested: {reason}");
        }
        println!("skipped: {reason}");
        return false;
    };
    if p2g == P2gAtomics::Float
        && !first
            .features()
            .contains(wgpu::Features::SHADER_FLOAT32_ATOMIC)
    {
        println!(
            "skipped: adapter \"{}\" has no f32 atomics (the fixed-point test covers it)",
            first.get_info().name
        );
        return false;
    }
    true
}

/// A 6 × 6 × 4 mm block of `e` Pa, ν 0.45 (1152 particles at dx = 1 mm) on `table` at z = 2 mm
/// under gravity, in a 16 × 16 × 14 mm domain at 60 Hz; the caller picks method and backend.
pub fn small_block_scene(name: &str, e: f64, table: Table, tools: Vec<Tool>) -> Scene {
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
