//! `/clock` and `sim/status` through rclpy (tests/ros/test_clock_status.py) on the default
//! scene on the CPU backend, which runs slower than real time on a small machine: rclpy with
//! `use_sim_time` follows the simulated clock, and the status's real-time factor agrees with
//! the one measured from /clock. A cloud subscriber of depth 10 reads tissue/points meanwhile,
//! and the node's log has no ERROR line.
//!
//! Starts DDS participants: runs only inside a loopback-only network namespace (as
//! tests/ros_node.rs; `.ci/run` makes one); elsewhere prints `SKIPPED: <reason>` and passes,
//! unless `CI` is set.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod common;
use common::{network_prerequisites, python, root};

#[test]
fn clock_follows_the_simulation_and_the_status_reports_its_real_time_factor() {
    if !network_prerequisites(true) {
        return;
    }
    let log = std::env::temp_dir().join(format!("dvrk-clock-{}.log", std::process::id()));
    let mut node = Command::new(env!("CARGO_BIN_EXE_dvrk-tissue-sim"))
        .current_dir(root())
        .args(["run", "--scene", "config/default.toml", "--backend", "cpu"])
        .env("ROS_DOMAIN_ID", "47")
        .env("NO_COLOR", "1")
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&log).unwrap())
        .spawn()
        .expect("cannot start the node");
    let out = Command::new(python())
        .arg(root().join("tests/ros/test_clock_status.py"))
        .current_dir(root().join("tests/ros"))
        .env("ROS_DOMAIN_ID", "47")
        .env("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
        .env("PYTHONUNBUFFERED", "1")
        .output()
        .expect("cannot run python");
    let _ = Command::new("kill")
        .args(["-INT", &node.id().to_string()])
        .status();
    let deadline = Instant::now() + Duration::from_secs(15);
    let status = loop {
        if let Ok(Some(s)) = node.try_wait() {
            break Some(s);
        }
        if Instant::now() > deadline {
            let _ = node.kill();
            break None;
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let text = std::fs::read_to_string(&log).unwrap_or_default();
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
