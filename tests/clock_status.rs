//! `/clock` and `/diagnostics` through rclpy (tests/ros/test_clock_status.py) on the default
//! scene on the CPU backend, which runs slower than real time on a small machine: rclpy with
//! `use_sim_time` follows the simulated clock, and the status's real-time factor agrees with
//! the one measured from /clock. A cloud subscriber of depth 10 reads tissue/points meanwhile,
//! and the node's log has no ERROR line.
//!
//! Starts DDS participants: runs only inside a loopback-only network namespace (as
//! tests/ros_node.rs; `.ci/run` makes one); elsewhere prints `SKIPPED: <reason>` and passes,
//! unless `CI` is set.

use std::process::Command;

mod support;
use support::dds::network_prerequisites;
use support::node::{run_rclpy, NodeProcess};
use support::root;

#[test]
fn clock_follows_the_simulation_and_the_status_reports_its_real_time_factor() {
    if !network_prerequisites(true) {
        return;
    }
    let node = NodeProcess::start_with(&["--scene", "config/default.toml", "--backend", "cpu"], 47);
    let out = run_rclpy("test_clock_status.py", 47);
    let (status, text) = node.stop();
    println!("{}", String::from_utf8_lossy(&out.stdout));
    assert!(
        out.status.success(),
        "test_clock_status.py failed:\n{}\n{}\n--- node ---\n{text}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        status.is_some_and(|s| s.success()),
        "node exit {status:?}\n{text}"
    );
    assert!(
        !text.lines().any(|l| l.contains("ERROR")),
        "ERROR in the node's log:\n{text}"
    );
}

/// No ROS installation, and a user's own `RUST_LOG` that shows every warning: the node says at
/// info which distribution's messages it speaks and logs no `ROS_DISTRO` warning.
#[test]
fn no_ros_distro_warning_without_a_ros_installation() {
    if !network_prerequisites(false) {
        return;
    }
    for (user_distro, expected) in [
        (None, "ROS_DISTRO was not set and is taken as"),
        (Some("kilted"), "(ROS_DISTRO = kilted)"),
    ] {
        let mut command = Command::new(env!("CARGO_BIN_EXE_dvrk-tissue-sim"));
        command
            .current_dir(root())
            .args([
                "run",
                "--scene",
                "tests/scenes/small.toml",
                "--backend",
                "cpu",
                "--seconds",
                "0.5",
            ])
            .env("ROS_DOMAIN_ID", "52")
            .env("RUST_LOG", "info")
            .env("NO_COLOR", "1")
            .env_remove("ROS_DISTRO");
        if let Some(distro) = user_distro {
            command.env("ROS_DISTRO", distro);
        }
        let out = command.output().expect("cannot run the node");
        let log = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{log}");
        assert!(log.contains("speaking ROS 2"), "{log}");
        assert!(log.contains(expected), "lacks {expected}: {log}");
        assert!(
            !log.lines()
                .any(|l| l.contains("ROS_DISTRO") && (l.contains("WARN") || l.contains("ERROR"))),
            "{log}"
        );
    }
}
