//! The node as ROS 2 tools and dVRK's Python client see it, on one node process: rclpy
//! (tests/ros/test_contract.py) reads the graph (one type per topic) and `/rosout` (the
//! arms' events with the node's logger name and dVRK's levels).
//!
//! Starts DDS participants: runs only inside a loopback-only network namespace (as
//! tests/ros_node.rs; `.ci/run` makes one); elsewhere prints `SKIPPED: <reason>` and passes,
//! unless `CI` is set.

mod support;
use support::dds::network_prerequisites;
use support::node::{run_rclpy, NodeProcess};

const SMALL: &str = "tests/scenes/small.toml";
const DOMAIN: u16 = 61;

#[test]
fn ros_tools_and_dvrk_clients_see_the_node_as_any_node() {
    if !network_prerequisites(true) {
        return;
    }
    let node = NodeProcess::start_with(&["--scene", SMALL, "--backend", "cpu"], DOMAIN);
    let out = run_rclpy("test_contract.py", DOMAIN);
    println!("{}", String::from_utf8_lossy(&out.stdout));
    assert!(
        out.status.success(),
        "test_contract.py failed:\n{}\n{}\n--- node ---\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
        node.log()
    );

    let (status, log) = node.stop();
    assert!(
        status.is_some_and(|s| s.success()),
        "node exit {status:?}\n{log}"
    );
}
