//! The node as ROS 2 tools and dVRK's Python client see it (tests/ros/test_contract.py, one
//! node process for every check): one type per topic.
//!
//! Starts DDS participants: runs only inside a loopback-only network namespace (as
//! tests/ros_node.rs; `.ci/run` makes one); elsewhere prints `SKIPPED: <reason>` and passes,
//! unless `CI` is set.

mod support;
use support::dds::network_prerequisites;
use support::node::{run_rclpy, NodeProcess};

const SMALL: &str = "tests/scenes/small.toml";

#[test]
fn ros_tools_see_one_type_per_topic() {
    if !network_prerequisites(true) {
        return;
    }
    let node = NodeProcess::start_with(&["--scene", SMALL, "--backend", "cpu"], 61);
    let out = run_rclpy("test_contract.py", 61);
    let (status, log) = node.stop();
    println!("{}", String::from_utf8_lossy(&out.stdout));
    assert!(
        out.status.success(),
        "test_contract.py failed:\n{}\n{}\n--- node ---\n{log}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        status.is_some_and(|s| s.success()),
        "node exit {status:?}\n{log}"
    );
}
