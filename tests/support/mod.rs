//! What the integration tests share: the project's root and binary here; the DDS
//! prerequisites ([`dds`]), the node as a child process with the rclpy scripts that drive it
//! ([`node`]), the GPU adapter check ([`gpu`]) and small scenes built in code ([`scenes`]).
// Each test crate that includes this module uses part of it.
#![allow(dead_code)]

pub mod dds;
pub mod gpu;
pub mod node;
pub mod scenes;

use std::path::Path;
use std::process::Command;

/// The project's root (where `Cargo.toml`, `config/` and `tests/` are).
pub fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The project's binary, run from the project root as a user runs it.
pub fn binary() -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_dvrk-tissue-sim"));
    command.current_dir(root());
    command
}

/// Runs `command` and returns its standard output; fails the test, showing both of its
/// outputs, unless it exits with success.
pub fn stdout_of_success(command: &mut Command) -> String {
    output_of_success(command).0
}

/// Runs `command` and returns its standard output and standard error; fails the test,
/// showing both, unless it exits with success.
pub fn output_of_success(command: &mut Command) -> (String, String) {
    let out = command.output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{stdout}\n{stderr}");
    (stdout, stderr)
}
