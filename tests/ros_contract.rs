//! The node as ROS 2 tools and dVRK's Python client see it. On one node process: rclpy
//! (tests/ros/test_contract.py) reads the graph (one type per topic), `/rosout` (the arms'
//! events with the node's logger name and dVRK's levels) and `/diagnostics`; a ros2-client
//! peer in this process reads what has no Python wheel: crtk_msgs (a refused move's busy
//! pair, the forward and inverse kinematics services) and tf2_msgs (`world` → `PSM1_base` once on `/tf_static`, the links on `/tf`). On a
//! second, started with `--ros-args` (tests/ros/test_ros_args.py): namespace, node name, a
//! remap and parameters, and `/tf` with the links left to dVRK's robot_state_publisher. On
//! a third, on `config/default.toml`: dVRK's Python PSM client played with crtk_msgs' own
//! Python bindings (built by `.ci/crtk_msgs.sh`), tests/ros/test_dvrk_client.py.
//!
//! Starts DDS participants: runs only inside a loopback-only network namespace (as
//! tests/ros_node.rs; `.ci/run` makes one); elsewhere prints `SKIPPED: <reason>` and passes,
//! unless `CI` is set.

use std::sync::Mutex;
use std::time::{Duration, Instant};

use dvrk_tissue_sim::ros::kinematics::{
    ForwardKinematicsRequest, ForwardKinematicsResponse, InverseKinematicsRequest,
    InverseKinematicsResponse,
};
use dvrk_tissue_sim::ros::msgs::{JointState, OperatingState, PoseStamped, TFMessage};
use ros2_client::{
    qos::{Durability, History},
    Context, ContextOptions, Name, NodeName, NodeOptions, QosProfile, ServiceMapping,
    ServiceTypeName,
};

mod support;
use support::dds::{network_prerequisites, topic};
use support::node::{run_rclpy, NodeProcess};

const SMALL: &str = "tests/scenes/small.toml";
const DOMAIN: u16 = 61;

/// One node at a time: two cores.
static SERIAL: Mutex<()> = Mutex::new(());

fn latched() -> QosProfile {
    QosProfile::publisher_default()
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 100 })
}

fn reliable() -> QosProfile {
    QosProfile::publisher_default().history(History::KeepLast { depth: 10 })
}

/// The child frames of the `/tf` messages received until `done` holds for them.
fn tf_children(
    peer: &mut ros2_client::Node,
    topic_name: &str,
    qos: QosProfile,
    node: &NodeProcess,
) -> Vec<(String, String)> {
    let t = topic::<TFMessage>(peer, topic_name, &qos);
    let tf = peer
        .create_subscription::<TFMessage>(&t, Some(qos))
        .unwrap();
    let messages = gather(
        topic_name,
        || node.log(),
        || tf.take().ok().flatten().map(|(m, _)| m),
        |m| m.len() >= 3,
    );
    messages[messages.len() - 1]
        .transforms
        .iter()
        .map(|t| (t.header.frame_id.clone(), t.child_frame_id.clone()))
        .collect()
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

/// Calls `/PSM1/<service>` (crtk_msgs `type_name`) until it answers, at most 10 s (the
/// first requests may go out before the service is matched).
fn call<Req, Resp>(
    peer: &mut ros2_client::Node,
    service: &str,
    type_name: &str,
    request: Req,
    log: impl Fn() -> String,
) -> Resp
where
    Req: ros2_client::Message + Clone + 'static,
    Resp: ros2_client::Message + 'static,
{
    let qos = reliable();
    let client = peer
        .create_client::<Req, Resp>(
            ServiceMapping::Enhanced,
            &Name::new("/PSM1", service).unwrap(),
            &ServiceTypeName::new("crtk_msgs", type_name),
            qos.clone(),
            qos,
        )
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(10);
    while Instant::now() < deadline {
        let id = client.send_request(request.clone()).unwrap();
        let resend = Instant::now() + Duration::from_millis(500);
        while Instant::now() < resend {
            if let Ok(Some((answered, response))) = client.receive_response() {
                if answered == id {
                    return response;
                }
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }
    panic!(
        "no answer from /PSM1/{service}\n--- node log ---\n{}",
        log()
    );
}

/// Runs `tests/ros/<script>` against `node` on `domain` and fails with both logs if it does.
fn run_script_against(node: &NodeProcess, script: &str, domain: u16) {
    let out = run_rclpy(script, domain);
    println!("{}", String::from_utf8_lossy(&out.stdout));
    assert!(
        out.status.success(),
        "{script} failed:\n{}\n{}\n--- node ---\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
        node.log()
    );
}

#[test]
fn ros_tools_and_dvrk_clients_see_the_node_as_any_node() {
    if !network_prerequisites(true) {
        return;
    }
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let node = NodeProcess::start_with(&["--scene", SMALL, "--backend", "cpu"], DOMAIN);
    run_script_against(&node, "test_contract.py", DOMAIN);

    let context = Context::with_options(ContextOptions::new().domain_id(DOMAIN)).unwrap();
    let mut peer = context
        .new_node(
            NodeName::new("/", "contract_peer").unwrap(),
            NodeOptions::new(),
        )
        .unwrap();
    let t = topic::<OperatingState>(&mut peer, "/PSM1/operating_state", &latched());
    let states = peer
        .create_subscription::<OperatingState>(&t, Some(latched()))
        .unwrap();
    let t = topic::<JointState>(&mut peer, "/PSM1/move_jp", &reliable());
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

    // tf as tf2 expects it: the fixed world → PSM1_base once on /tf_static (transient
    // local: this late subscriber still gets it), the moving links on /tf.
    let tf_static_qos = QosProfile::publisher_default()
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 });
    let t = topic::<TFMessage>(&mut peer, "/tf_static", &tf_static_qos);
    let tf_static = peer
        .create_subscription::<TFMessage>(&t, Some(tf_static_qos))
        .unwrap();
    let fixed = gather(
        "/tf_static",
        log,
        || tf_static.take().ok().flatten().map(|(m, _)| m),
        |m| !m.is_empty(),
    );
    std::thread::sleep(Duration::from_millis(300));
    assert!(
        tf_static.take().ok().flatten().is_none(),
        "/tf_static sent twice"
    );
    let fixed: Vec<(String, String)> = fixed[0]
        .transforms
        .iter()
        .map(|t| (t.header.frame_id.clone(), t.child_frame_id.clone()))
        .collect();
    assert_eq!(fixed, [("world".to_owned(), "PSM1_base".to_owned())]);
    let moving = tf_children(&mut peer, "/tf", reliable(), &node);
    assert!(
        moving.iter().all(|(_, child)| child != "PSM1_base"),
        "{moving:?}"
    );
    for link in ["PSM1", "PSM1_tool_tip", "PSM1_jaw_1"] {
        assert!(
            moving.iter().any(|(_, child)| child == link),
            "{link}: {moving:?}"
        );
    }
    println!(
        "ok: /tf_static world -> PSM1_base once; /tf {} link frames",
        moving.len()
    );

    // dVRK's kinematics services (crtk_msgs, no Python wheel): forward kinematics at the
    // arm's measured joints is its measured_cp (the arm rests after the moves above), and
    // inverse kinematics of that pose from a reference nearby gives those joints back.
    let qos = reliable();
    let t = topic::<PoseStamped>(&mut peer, "/PSM1/measured_cp", &qos);
    let measured_cp = peer
        .create_subscription::<PoseStamped>(&t, Some(qos.clone()))
        .unwrap();
    let t = topic::<JointState>(&mut peer, "/PSM1/measured_js", &qos);
    let measured_js = peer
        .create_subscription::<JointState>(&t, Some(qos))
        .unwrap();
    let latest_of_both = gather(
        "/PSM1/measured_cp and measured_js",
        log,
        || {
            let cp = std::iter::from_fn(|| measured_cp.take().ok().flatten()).last();
            let js = std::iter::from_fn(|| measured_js.take().ok().flatten()).last();
            cp.zip(js).map(|((cp, _), (js, _))| (cp.pose, js.position))
        },
        |m| m.len() >= 2,
    );
    let (measured, joints) = latest_of_both[latest_of_both.len() - 1].clone();
    let fk: ForwardKinematicsResponse = call(
        &mut peer,
        "forward_kinematics",
        "QueryForwardKinematics",
        ForwardKinematicsRequest {
            jp: joints.clone(),
            cp: Default::default(),
        },
        log,
    );
    let (p, q) = (fk.cp.position, measured.position);
    let offset = ((p.x - q.x).powi(2) + (p.y - q.y).powi(2) + (p.z - q.z).powi(2)).sqrt();
    assert!(
        fk.result && offset < 1e-9,
        "{fk:?} against {measured:?} at {joints:?}"
    );
    let ik: InverseKinematicsResponse = call(
        &mut peer,
        "inverse_kinematics",
        "QueryInverseKinematics",
        InverseKinematicsRequest {
            cp: fk.cp,
            jp: joints.iter().map(|q| q + 0.03).collect(),
        },
        log,
    );
    let worst = ik
        .jp
        .iter()
        .zip(&joints)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(ik.result && worst < 1e-5, "{ik:?}");
    println!(
        "ok: forward_kinematics at measured_js is measured_cp ({offset:.1e} m); \
         inverse_kinematics gives the joints back within {worst:.1e}"
    );

    drop((move_jp, states, tf_static, measured_cp, measured_js));
    drop(peer);
    let (status, log) = node.stop();
    assert!(
        status.is_some_and(|s| s.success()),
        "node exit {status:?}\n{log}"
    );
}

#[test]
fn standard_ros_arguments_and_links_left_to_dvrk() {
    if !network_prerequisites(true) {
        return;
    }
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let domain = DOMAIN + 1;
    let node = NodeProcess::start_with(
        &[
            "--backend",
            "cpu",
            "--ros-args",
            "-r",
            "__ns:=/sim",
            "-r",
            "__node:=sim",
            "-r",
            "tissue/points:=cloud",
            "-p",
            "use_sim_time:=true",
            "-p",
            "arm_rate_hz:=50",
            "-p",
            "scene:=tests/scenes/small_dvrk_links.toml",
        ],
        domain,
    );
    run_script_against(&node, "test_ros_args.py", domain);

    // With `tf_arm_links = false` /tf carries only what dVRK's robot_state_publisher (fed
    // by measured_js) does not: the tool frame and our tool tip, under the base, and the
    // held tool's own frame under the tool frame.
    let context = Context::with_options(ContextOptions::new().domain_id(domain)).unwrap();
    let mut peer = context
        .new_node(NodeName::new("/", "tf_peer").unwrap(), NodeOptions::new())
        .unwrap();
    let mut moving = tf_children(&mut peer, "/tf", reliable(), &node);
    moving.sort();
    assert_eq!(
        moving,
        [
            ("PSM1".to_owned(), "probe".to_owned()),
            ("PSM1_base".to_owned(), "PSM1".to_owned()),
            ("PSM1_base".to_owned(), "PSM1_tool_tip".to_owned()),
        ]
    );
    println!("ok: /tf with the links left to robot_state_publisher: {moving:?}");
    drop(peer);
    let (status, log) = node.stop();
    assert!(
        status.is_some_and(|s| s.success()),
        "node exit {status:?}\n{log}"
    );
}

/// dVRK's Python PSM client's connections and first script (tests/ros/test_dvrk_client.py)
/// on the shipped default scene, with crtk_msgs' Python bindings (`.ci/crtk_msgs.sh`).
#[test]
fn dvrk_python_psm_client_connects_and_drives_the_default_scene() {
    if !network_prerequisites(true) {
        return;
    }
    if !support::dds::python_imports("crtk_msgs.srv") {
        support::dds::skip_or_fail("no crtk_msgs Python bindings in .venv (.ci/crtk_msgs.sh)");
        return;
    }
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let domain = DOMAIN + 2;
    let node = NodeProcess::start_with(
        &["--scene", "config/default.toml", "--backend", "cpu"],
        domain,
    );
    run_script_against(&node, "test_dvrk_client.py", domain);
}
