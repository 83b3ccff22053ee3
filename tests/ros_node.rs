//! The node against real ROS 2 clients: the rclpy scripts in `tests/ros/` (Fast DDS, from the
//! PyPI wheels in `.venv/`) and, for the crtk_msgs topics that have no Python wheel, a
//! ros2-client peer in this process.
//!
//! DDS traffic must never leave the machine: these tests only run inside a network namespace
//! whose only interface is loopback (`.ci/run` creates one). Elsewhere, or without the venv,
//! they print why and pass — unless `CI` is set, where a missing prerequisite fails them.

use std::sync::Mutex;
use std::time::{Duration, Instant};

use dvrk_tissue_sim::ros::msgs::{
    Header, JointState, OperatingState, StringMsg, StringStamped, TFMessage,
};
use ros2_client::{
    qos::{Durability, History},
    Context, ContextOptions, NodeName, NodeOptions, QosProfile, Subscription,
};

mod support;
use support::dds::{network_prerequisites as prerequisites, topic};
use support::node::{run_rclpy_against, NodeProcess};

/// One node at a time: two cores, and every test's timing matters.
static SERIAL: Mutex<()> = Mutex::new(());

/// Runs `tests/ros/<script>` against a node on `scene`; returns its stdout.
fn rclpy_test(script: &str, scene: &str, domain: u16) -> Option<String> {
    rclpy_test_with_log(script, scene, domain).map(|(stdout, _)| stdout)
}

/// As [`rclpy_test`], also returning the node's log.
fn rclpy_test_with_log(script: &str, scene: &str, domain: u16) -> Option<(String, String)> {
    if !prerequisites(true) {
        return None;
    }
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let node = NodeProcess::start(scene, domain);
    let stdout = run_rclpy_against(&node, script, domain);
    Some((stdout, node.log()))
}

const SMALL: &str = "tests/scenes/small.toml";

#[test]
fn rclpy_sees_node_topics_and_exact_types() {
    rclpy_test("test_graph.py", SMALL, 11);
}

#[test]
fn rclpy_servo_jp_moves_measured_js_and_measured_cp_matches_fk() {
    rclpy_test("test_servo.py", SMALL, 12);
}

#[test]
fn rclpy_measured_cp_matches_fk_with_a_dvrk_model_layout_urdf() {
    rclpy_test("test_servo.py", "tests/scenes/official_layout.toml", 18);
}

#[test]
fn rclpy_reads_the_stereo_camera_images_and_camera_info() {
    rclpy_test("test_camera.py", "tests/scenes/camera.toml", 37);
}

#[test]
fn rclpy_push_displaces_tissue_and_wrench_opposes_motion() {
    rclpy_test("test_push.py", SMALL, 13);
}

#[test]
fn rclpy_teleop_follows_at_scale_and_holds_while_clutched() {
    rclpy_test("test_teleop.py", SMALL, 14);
}

#[test]
fn rclpy_bimanual_teleop_drives_each_psm_from_its_mtm_and_one_clutch_holds_both() {
    rclpy_test("test_bimanual.py", "tests/scenes/bimanual.toml", 90);
}

#[test]
fn rclpy_jaw_servo_and_effort_commands_follow_dvrk() {
    rclpy_test("test_jaw.py", "tests/scenes/gripper.toml", 20);
}

#[test]
fn rclpy_grasp_lifts_the_default_liver_and_opening_releases_it() {
    rclpy_test("test_grasp.py", "config/default.toml", 61);
}

#[test]
fn rclpy_psm1_picks_up_the_thread_and_opening_drops_it() {
    rclpy_test("test_thread_pickup.py", "config/thread.toml", 63);
}

#[test]
fn rclpy_psm1_holding_a_scalpel_cuts_the_block_into_two_pieces() {
    rclpy_test("test_scalpel_cut.py", "config/cutting_psm.toml", 71);
}

#[test]
fn teleop_demo_grasps_lifts_and_releases_the_liver() {
    // The demo exits non-zero when nothing was lifted; it prints what it lifted.
    if let Some(out) = rclpy_test(
        "../../launch-scripts/teleop_demo.py",
        "config/teleop.toml",
        62,
    ) {
        assert!(out.contains("lifted: the grasped tissue rose"), "{out}");
    }
}

#[test]
fn rclpy_bad_input_is_rejected_and_node_keeps_publishing() {
    let Some((_, log)) = rclpy_test_with_log("test_bad_input.py", SMALL, 15) else {
        return;
    };
    // Oversized input is named by its size, in one short line, and never quoted.
    for dropped in [
        "/PSM1/servo_jp: dropped on receipt: position has 5000 values",
        "/PSM1/servo_jp: dropped on receipt: a joint name is 20000 bytes long",
    ] {
        assert!(log.contains(dropped), "no '{dropped}' in\n{log}");
    }
    assert!(
        !log.contains(&"y".repeat(1000)),
        "an oversized name was quoted"
    );
    assert!(
        log.contains("yaw\\nWARN forged") && !log.lines().any(|l| l.starts_with("WARN forged")),
        "a joint name's newline forged a log line"
    );
}

#[test]
fn rclpy_receives_30k_point_clouds_whole_at_30_hz() {
    rclpy_test("test_cloud_throughput.py", "tests/scenes/cloud30k.toml", 16);
}

// ---- crtk_msgs topics (no Python wheel): a ros2-client peer ----

/// What the peer has received so far.
struct Probe {
    states: Subscription<OperatingState>,
    errors: Subscription<StringMsg>,
    tf: Subscription<TFMessage>,
    measured: Subscription<JointState>,
    seen_states: Vec<OperatingState>,
    seen_errors: Vec<String>,
    frames: Vec<String>,
    js: Option<JointState>,
}

impl Probe {
    fn poll(&mut self) {
        while let Ok(Some((s, _))) = self.states.take() {
            self.seen_states.push(s);
        }
        while let Ok(Some((e, _))) = self.errors.take() {
            self.seen_errors.push(e.data);
        }
        while let Ok(Some((m, _))) = self.tf.take() {
            self.frames = m
                .transforms
                .iter()
                .map(|t| t.child_frame_id.clone())
                .collect();
        }
        while let Ok(Some((m, _))) = self.measured.take() {
            self.js = Some(m);
        }
    }

    fn wait(&mut self, what: &str, node: &NodeProcess, done: impl Fn(&Probe) -> bool) {
        let deadline = Instant::now() + Duration::from_secs(15);
        while Instant::now() < deadline {
            self.poll();
            if done(self) {
                return;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        panic!(
            "timed out waiting for {what}; states {:?}, errors {:?}\n--- node log ---\n{}",
            self.seen_states,
            self.seen_errors,
            node.log()
        );
    }
}

#[test]
fn crtk_operating_state_state_commands_and_tf() {
    if !prerequisites(false) {
        return;
    }
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let domain = 17;
    let node_process = NodeProcess::start(SMALL, domain);
    let context = Context::with_options(ContextOptions::new().domain_id(domain)).unwrap();
    let mut node = context
        .new_node(
            NodeName::new("/", "crtk_probe").unwrap(),
            NodeOptions::new(),
        )
        .unwrap();
    let latched = QosProfile::publisher_default()
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 100 });
    let reliable = QosProfile::publisher_default().history(History::KeepLast { depth: 10 });
    let t = topic::<OperatingState>(&mut node, "/PSM1/operating_state", &latched);
    let states = node.create_subscription(&t, Some(latched.clone())).unwrap();
    let t = topic::<StringMsg>(&mut node, "/PSM1/error", &latched);
    let errors = node.create_subscription(&t, Some(latched.clone())).unwrap();
    let t = topic::<TFMessage>(&mut node, "/tf", &reliable);
    let tf = node
        .create_subscription(&t, Some(reliable.clone()))
        .unwrap();
    let t = topic::<JointState>(&mut node, "/PSM1/measured_js", &reliable);
    let measured = node
        .create_subscription(&t, Some(reliable.clone()))
        .unwrap();
    let t = topic::<StringStamped>(&mut node, "/PSM1/state_command", &reliable);
    let state_command = node.create_publisher::<StringStamped>(&t, None).unwrap();
    let t = topic::<JointState>(&mut node, "/PSM1/move_jp", &reliable);
    let move_jp = node.create_publisher::<JointState>(&t, None).unwrap();
    let t = topic::<JointState>(&mut node, "/PSM1/servo_jp", &reliable);
    let servo_jp = node.create_publisher::<JointState>(&t, None).unwrap();
    let mut probe = Probe {
        states,
        errors,
        tf,
        measured,
        seen_states: Vec::new(),
        seen_errors: Vec::new(),
        frames: Vec::new(),
        js: None,
    };
    let n = &node_process;

    probe.wait("the initial operating state, /tf and measured_js", n, |p| {
        !p.seen_states.is_empty() && !p.frames.is_empty() && p.js.is_some()
    });
    let first = &probe.seen_states[0];
    assert_eq!(
        (first.state.as_str(), first.is_homed, first.is_busy),
        ("ENABLED", true, false)
    );
    // world → PSM1_base is fixed: it goes on /tf_static (tests/ros_contract.rs).
    for frame in ["PSM1", "PSM1_tool_tip", "PSM1_jaw_1", "PSM1_jaw_2"] {
        assert!(
            probe.frames.iter().any(|f| f == frame),
            "{frame} not in /tf: {:?}",
            probe.frames
        );
    }
    // Subscriptions must be matched before commands go out.
    std::thread::sleep(Duration::from_millis(500));

    // move_jp: busy true, then busy false at the goal, with increasing stamps.
    let goal = vec![0.2, 0.1, 0.12, 0.0, 0.0, 0.0];
    move_jp
        .publish(JointState {
            position: goal.clone(),
            ..Default::default()
        })
        .unwrap();
    probe.wait("busy true then false", n, |p| {
        let s = &p.seen_states;
        s.len() >= 3 && s[s.len() - 2].is_busy && !s[s.len() - 1].is_busy
    });
    probe.wait("measured_js at the move_jp goal", n, |p| {
        p.js.as_ref().is_some_and(|js| {
            js.position
                .iter()
                .zip(&goal)
                .all(|(a, b)| (a - b).abs() < 1e-9)
        })
    });
    for w in probe.seen_states.windows(2) {
        assert!(
            w[1].header.stamp > w[0].header.stamp,
            "stamps must increase: {:?}",
            probe.seen_states
        );
    }

    // disable: DISABLED, and servo commands are refused with a reason on `error`.
    let command = |s: &str| StringStamped {
        header: Header::default(),
        string: s.into(),
    };
    state_command.publish(command("disable")).unwrap();
    probe.wait("DISABLED", n, |p| {
        p.seen_states.last().is_some_and(|s| s.state == "DISABLED")
    });
    servo_jp
        .publish(JointState {
            position: vec![0.21, 0.1, 0.12, 0.0, 0.0, 0.0],
            ..Default::default()
        })
        .unwrap();
    probe.wait("an error for servo_jp while disabled", n, |p| {
        p.seen_errors
            .iter()
            .any(|e| e.contains("servo_jp: rejected: arm is DISABLED"))
    });
    state_command.publish(command("fly")).unwrap();
    probe.wait("an error for an unknown state command", n, |p| {
        p.seen_errors
            .iter()
            .any(|e| e.contains("unknown state command `fly`"))
    });
    state_command.publish(command("enable")).unwrap();
    probe.wait("ENABLED again", n, |p| {
        p.seen_states.last().is_some_and(|s| s.state == "ENABLED")
    });
    probe.poll();
    let js = probe.js.clone().unwrap();
    assert!(
        (js.position[0] - 0.2).abs() < 1e-9,
        "the disabled arm moved: {js:?}"
    );
}
