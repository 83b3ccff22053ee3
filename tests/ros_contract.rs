//! The node as ROS 2 tools and dVRK's Python client see it, on one node process: rclpy
//! (tests/ros/test_contract.py) reads the graph (one type per topic) and `/rosout` (the
//! arms' events with the node's logger name and dVRK's levels); a ros2-client peer in this
//! process reads the crtk_msgs topics, which have no Python wheel (a refused move's busy pair).
//!
//! Starts DDS participants: runs only inside a loopback-only network namespace (as
//! tests/ros_node.rs; `.ci/run` makes one); elsewhere prints `SKIPPED: <reason>` and passes,
//! unless `CI` is set.

use std::time::{Duration, Instant};

use dvrk_tissue_sim::ros::msgs::{JointState, OperatingState, RosMessage};
use ros2_client::{
    qos::{Durability, History},
    Context, ContextOptions, MessageTypeName, Name, NodeName, NodeOptions, QosProfile,
};

mod support;
use support::dds::network_prerequisites;
use support::node::{run_rclpy, NodeProcess};

const SMALL: &str = "tests/scenes/small.toml";
const DOMAIN: u16 = 61;

fn topic<M: RosMessage>(
    node: &mut ros2_client::Node,
    name: &str,
    qos: &QosProfile,
) -> ros2_client::dds::rustdds::Topic {
    node.create_topic(
        &Name::parse(name).unwrap(),
        MessageTypeName::new(M::PACKAGE, M::NAME),
        qos,
    )
    .unwrap()
}

/// Polls `take` until `done` holds for what it gathered, at most 10 s.
fn gather<T>(
    what: &str,
    log: impl Fn() -> String,
    mut take: impl FnMut() -> Option<T>,
    done: impl Fn(&[T]) -> bool,
) -> Vec<T>
where
    T: std::fmt::Debug,
{
    let mut seen = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(10);
    while Instant::now() < deadline {
        while let Some(m) = take() {
            seen.push(m);
        }
        if done(&seen) {
            return seen;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    panic!(
        "timed out waiting for {what}; got {seen:?}\n--- node log ---\n{}",
        log()
    );
}

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

    let context = Context::with_options(ContextOptions::new().domain_id(DOMAIN)).unwrap();
    let mut peer = context
        .new_node(
            NodeName::new("/", "contract_peer").unwrap(),
            NodeOptions::new(),
        )
        .unwrap();
    let latched = QosProfile::publisher_default()
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 100 });
    let reliable = QosProfile::publisher_default().history(History::KeepLast { depth: 10 });
    let t = topic::<OperatingState>(&mut peer, "/PSM1/operating_state", &latched);
    let states = peer
        .create_subscription::<OperatingState>(&t, Some(latched.clone()))
        .unwrap();
    let t = topic::<JointState>(&mut peer, "/PSM1/move_jp", &reliable);
    let move_jp = peer.create_publisher::<JointState>(&t, None).unwrap();
    let log = || node.log();

    // A refused move (beyond the yaw limit) still sends busy true then false, newer than
    // every state before it, so a client's wait() returns at once.
    let history = gather(
        "the latched operating states",
        log,
        || states.take().ok().flatten().map(|(m, _)| m),
        |s| !s.is_empty(),
    );
    // The rest of the history, and the end of the probe's own move, before the command.
    std::thread::sleep(Duration::from_millis(500));
    let rest = std::iter::from_fn(|| states.take().ok().flatten().map(|(m, _)| m));
    let last_stamp = rest
        .last()
        .unwrap_or_else(|| history[history.len() - 1].clone());
    let last_stamp = last_stamp.header.stamp;
    let sent = Instant::now();
    move_jp
        .publish(JointState {
            position: vec![2.5, 0.0, 0.12, 0.0, 0.0, 0.0],
            ..Default::default()
        })
        .unwrap();
    let pair = gather(
        "a busy pair for the refused move",
        log,
        || states.take().ok().flatten().map(|(m, _)| m),
        |s| s.len() >= 2,
    );
    let busy: Vec<bool> = pair.iter().map(|s| s.is_busy).collect();
    assert_eq!(busy, [true, false], "{pair:?}");
    assert!(pair[0].header.stamp > last_stamp && pair[1].header.stamp > pair[0].header.stamp);
    println!(
        "ok: a refused move_jp sent busy true, then false, {:.3} s after the command",
        sent.elapsed().as_secs_f64()
    );

    drop(move_jp);
    drop(states);
    drop(peer);
    let (status, log) = node.stop();
    assert!(
        status.is_some_and(|s| s.success()),
        "node exit {status:?}\n{log}"
    );
}
