//! The ROS 2 side, transport only: message types ([`msgs`], [`schema`]), topic names
//! ([`names`]), messages to simulation inputs ([`inputs`]) and finished frames to messages
//! ([`outputs`]), the endoscope's images ([`camera`]), the node's topic wiring ([`node`]), the bag recorder and replay
//! ([`recorder`], [`replay`], [`recover`] for a bag a killed run left), `/rosout` ([`rosout`]) and a run's setup
//! shared by the node and a headless replay ([`session`]), `/clock` ([`sim_clock`]) and the
//! node's status ([`status`]), and its DDS participant ([`participant`]: limits, discovery
//! range, one node per name). The simulation itself is [`crate::sim`].
//!
//! # The node
//!
//! `run` without `--headless` is a ROS 2 node on ros2-client + RustDDS: no ROS installation
//! needed (it speaks kilted; with `ROS_DISTRO` unset it sets it for itself before any thread
//! starts). The simulation steps on its own thread at the scene's `frame_rate_hz` (never faster
//! than real time; slower when a frame costs more than its period) and exchanges latest values
//! with the ROS side: commands go in through a bounded queue and are applied at the next frame
//! boundary, finished frames come out as a latest value (a slow reader skips frames). Every
//! stamp is simulated time. Relative names live under `--namespace`; `/tf` is global. The
//! standard ROS arguments work as for any ROS 2 node (`--ros-args -r __ns:=/sim -r
//! __node:=sim -r FROM:=TO -p NAME:=VALUE`, [`ros_args`]); the declared parameters (scene,
//! rates, `use_sim_time`) are served read-only to `ros2 param` ([`parameters`]).
//!
//! | topic | type | notes |
//! |---|---|---|
//! | `PSM1/measured_js`, `setpoint_js` | sensor_msgs/JointState | `yaw, pitch, insertion, roll, wrist_pitch, wrist_yaw` |
//! | `PSM1/jaw/measured_js`, `jaw/setpoint_js` | sensor_msgs/JointState | `jaw`: measured = the opening reached, with the controller's `effort` (N·m); setpoint = the command |
//! | `PSM1/measured_cp`, `setpoint_cp` | geometry_msgs/PoseStamped | frame `PSM1_base` |
//! | `PSM1/measured_cv` | geometry_msgs/TwistStamped | from the Jacobian |
//! | `PSM1/local/measured_cp`, `local/setpoint_cp` | geometry_msgs/PoseStamped | as `measured_cp` (the base frame is the arm's own) |
//! | `PSM1/body/measured_cf`, `spatial/measured_cf` | geometry_msgs/WrenchStamped | the held tool's contact wrench in the tool frame `PSM1`; the same about the tool in `PSM1_base`'s orientation |
//! | `PSM1/body/jacobian`, `spatial/jacobian` | std_msgs/Float64MultiArray | 6 × 6 row-major (linear rows first): tool twist in the tool frame / in `PSM1_base` |
//! | `PSM1/tool_type`, `trajectory_j/ratio` | std_msgs/String, Float64 | latched: dVRK's instrument (`LARGE_NEEDLE_DRIVER:400006` for a gripper, the arm's `tool_type` where set, else the tool's scene name); the share of dVRK's `move_jp` speeds in use |
//! | `PSM1/operating_state` | crtk_msgs/OperatingState | latched; a new stamp on every change; busy around each `move_*` |
//! | `PSM1/error`, `warning`, `status` | std_msgs/String | latched; every rejected command is reported on `error` |
//! | `PSM1/servo_jp`, `move_jp`, `jaw/servo_jp`, `jaw/move_jp` | sensor_msgs/JointState (sub) | names optional (then canonical order) |
//! | `PSM1/jaw/servo_jf` | sensor_msgs/JointState (sub) | jaw effort in `effort[0]` (N·m, negative closes), clamped to the limit; a jaw position command ends it |
//! | `PSM1/servo_cp`, `move_cp` | geometry_msgs/PoseStamped (sub) | in `PSM1_base` |
//! | `PSM1/hold`, `free` | std_msgs/Empty (sub) | `free` holds (a kinematic arm) |
//! | `PSM1/state_command` | crtk_msgs/StringStamped (sub) | `enable, disable, home, unhome, pause, resume` |
//! | `PSM1/body/servo_cf`, `use_gravity_compensation` | (sub) | accepted, no effect on a kinematic arm |
//! | `PSM1/servo_jr`, `move_jr` | sensor_msgs/JointState (sub) | relative joint commands: a step from the joints now (jump bound as `servo_jp`), a move to the sum (as `move_jp`) |
//! | `PSM1/servo_jf`, `spatial/servo_cf` | JointState, WrenchStamped (sub) | refused on `error`: a kinematic arm cannot apply efforts or forces |
//! | `PSM1/trajectory_j/set_ratio` | std_msgs/Float64 (sub) | (0, 1]: moves at that share of dVRK's speeds |
//! | `PSM1/body/set_cf_orientation_absolute`, `emulate_tool_present` | std_msgs/Bool (sub) | accepted, no effect (no force control; the tool is always present) |
//!
//! These are the topics dVRK's Python client (`dvrk_python`'s `psm` on `crtk_python_client`)
//! opens, and its `forward_kinematics` (also under `local/`) / `inverse_kinematics` services (crtk_msgs'
//! `QueryForwardKinematics` / `QueryInverseKinematics`, [`kinematics`]) on every simulated
//! arm. `tests/ros/test_dvrk_client.py` opens exactly the client's publishers and
//! subscribers with crtk_msgs' own Python bindings (built from its definitions by
//! `.ci/crtk_msgs.sh`; crtk_msgs has no wheel), finds every one matched within 5 s, and runs
//! a user's first script on `config/default.toml`: enable, home, `move_jp` and wait,
//! `servo_cp`, the jaw open and closed, `forward_kinematics` and `local/forward_kinematics`.
//!
//! An ECM (`kind = "ecm"`, e.g. `ECM`) has the same topics without the jaw and the tool
//! (no `jaw/...`, no `tool_type`; `body/measured_cf` and
//! `spatial/measured_cf` are zero, the scope touching nothing; its force commands are
//! answered as a PSM's), as dVRK's `ecm` client opens them: `ECM/measured_js`, `setpoint_js`
//! (`outer_yaw, outer_pitch, insertion, outer_roll`), `measured_cp`, `setpoint_cp` (frame
//! `ECM_base`, the tool frame `ECM` at the scope's tip, where the camera is),
//! `operating_state`, `move_jp`, `servo_jp`, `state_command`, ...; `/tf_static` carries
//! `world` → `ECM_base`, `/tf` its links.
//! | `tissue/points` | sensor_msgs/PointCloud2 | x, y, z and the scalar `points_scalar` names (`volumetric_strain`, `equivalent_strain` or `damage`), frame `world` |
//! | `tissue/surface` | visualization_msgs/Marker | TRIANGLE_LIST in `world`: the mesh (fixed corner order, a strain colour and a UV per corner) or the isosurface |
//! | `tissue/pieces` | std_msgs/UInt32 | separate tissue pieces, counted at `pieces_rate_hz` in simulated time while subscribed (and when recording); under total Lagrangian MPM, the rest configuration's pieces ([`crate::mpm::pieces`]) |
//! | `tissue/wound_gap` | std_msgs/Float64 | in a scene with a `wound`: the gap between its two blocks (m, [`crate::world::wound`]), measured with the piece count |
//! | `tools/<tool>/wrench` | geometry_msgs/WrenchStamped | contact wrench on the tool, in its frame (`PSM1` for an arm's tool, the mount undone: the torque about the arm's tool frame origin) |
//! | `threads/<name>/centreline`, `threads/<name>/tension` | Marker, PointCloud2 | a suture thread's LINE_STRIP and its axial force per point |
//! | `/tf_static` | tf2_msgs/TFMessage | once, transient local: `world` → `PSM1_base`; with a camera, `ECM` → `ECM_left_optical_frame` and `ECM_right_optical_frame` (`world` → them for a camera without an arm) |
//! | `/tf` | tf2_msgs/TFMessage | `PSM1_base` → every arm link (with `[outputs] tf_arm_links = false` only `PSM1` and `PSM1_tool_tip`, leaving the links to dVRK's robot_state_publisher); each held tool under its arm's tool frame through the mount (`PSM1` → `needle`); scripted tools under `world` |
//! | `<mtm>/measured_cp`, `<mtm>/gripper/measured_js` for each `[[teleop]]` pair (`MTMR`, `MTML`), `console/clutch`, `console/operator_present` | (sub, with `[[teleop]]`) | Joy `buttons[0] = 1` pressed; the one console's pedals engage every pair |
//! | `<mtm>/body/servo_cf` | geometry_msgs/WrenchStamped | with a pair's `force_feedback`: its tool's contact wrench × scale |
//! | `/clock` | rosgraph_msgs/Clock | simulated time, once per frame |
//! | `/rosout` | rcl_interfaces/Log | WARN and ERROR log lines, the arms' `error` (ERROR), `warning` (WARN) and `status` (INFO) events, logger `<namespace>.<name>` ([`rosout`]) |
//! | `/diagnostics` | diagnostic_msgs/DiagnosticArray | latched, once a second: real-time factor, substeps and frames per second, backend, adapter |
//! | `ECM/image_raw`, `ECM/image_raw/compressed`, `ECM/{left,right}/camera_info`, `ECM/{left,right}/depth`, `ECM/{left,right}/labels` | Image, CompressedImage, CameraInfo | with `[camera]`: the stereo endoscope ([`camera`]) at the ECM's tip (or fixed where the scene has no ECM), rendered at `camera.rate_hz` in simulated time while subscribed (and when a bag keeps pictures, `camera.record`) |
//!
//! - **Simulated arms** satisfy dVRK's `dvrk_arm_from_ros` contract: a dVRK console can
//!   teleoperate them with a real MTM. They start ENABLED and homed at `home_joints`;
//!   measured = setpoint (as dVRK's `KIN_SIMULATED`). Joint limits, the 45 mm RCM safety
//!   distance (Cartesian commands) and dVRK's `move_jp` speeds (90°/s, 0.2 m/s, 1080°/s; jaw
//!   720°/s) are enforced; a servo command may move a joint at most 0.1 s × its speed limit.
//! - **The jaw is dVRK's jaw** ([`crate::tools::jaw`]): a position servo whose effort is
//!   limited, acting against the tissue, d_gain·θ̇ = clamp(p_gain·(θ_sp − θ), ±effort_max) +
//!   τ_tissue, with dVRK's gains and the Large Needle Driver's effort limit; closing onto
//!   tissue it stops where the tissue's torque meets what the controller can apply, and
//!   pressed shut it grips ([`crate::tools::grip`]).
//! - **Mirror arms** follow a real arm's `measured_js` and `jaw/measured_js` and publish
//!   nothing on the arm's topics.
//! - **Teleoperation** maps MTM motion to the PSM as dVRK does ([`crate::robot::teleop`]:
//!   position relative × scale, orientation absolute with the offset captured at engage, jaw
//!   from the gripper, clutch re-anchors). An MTM that stops publishing for 0.5 s simulated
//!   makes the PSM hold where it is (one WARN) until it publishes again.
//! - **Bad input never stops the node**: NaN / inf, wrong length, unknown or duplicate joint
//!   names, out-of-limit values, jumps, non-unit quaternions, targets inside the RCM safety
//!   distance, unknown state commands and pedal messages without buttons are rejected with a
//!   log line naming the topic and the reason (one per topic and second, with a count of the
//!   ones held back), also published on `PSM1/error`; the last valid command holds.
//! - **Outputs nobody subscribes to are not computed**; each is published at its rate from the
//!   newest frame.
//! - **Large clouds**: RustDDS sends a sample in one UDP burst; rclpy / rclcpp subscribers with
//!   Fast DDS need bigger socket buffers for clouds over ~17k points: `RMW_IMPLEMENTATION=rmw_fastrtps_cpp`,
//!   `FASTDDS_DEFAULT_PROFILES_FILE=config/fastdds_large_data.xml` and
//!   `sysctl -w net.core.rmem_max=4194304 net.core.wmem_max=4194304`, or thin the cloud with
//!   `[outputs] points_downsample`.
//!
//! `launch-scripts/`: `run_node.sh [SCENE] [flags]` starts the node; `dvrk_tissue_sim.launch.py`
//! is a ROS 2 launch file; `dvrk_tissue_sim.rviz` an RViz 2 view (arm frames, tissue cloud and
//! mesh, thread, wrench); `teleop_demo.py` plays a scripted MTM on `config/teleop.toml`;
//! `suture_demo.py` throws a stitch with PSM1 on `config/suture.toml` (the roll with
//! `move_jp`), hands the needle to PSM2 (`move_cp` onto it, `jaw/move_jp` on both arms) and
//! has PSM2 pull the stitch closed (`move_cp`), reading the wound gap before and after;
//! `record_tissue_bag.sh` records with `ros2 bag`; `soak.py` drives the node for a long run.
//!
//! # /clock and status
//!
//! `/clock` carries the simulated time once per frame, so a node started with
//! `use_sim_time:=true` follows the simulation, also when it runs slower than real time.
//! The node never runs ros2-client's spinner, whose own `/clock` subscription (type
//! `builtin_interfaces/msg/Time`) would give `/clock` a second type in the graph
//! ([`sim_clock`]); `tests/ros_contract.rs` fails on any topic with two types.
//!
//! `/diagnostics` (where diagnostic_aggregator and rqt_robot_monitor look; status
//! `<node name>: simulation`) says how the simulation keeps up, measured over the last 5 s of
//! wall time: `real_time_factor`, `substeps_per_frame`, `frames_per_second`, `simulated_time`,
//! `backend` (`cpu`, `gpu-fixed-point`, `gpu-f32-atomics`) and `adapter`. Level OK at real
//! time, WARN below 0.9× with a message that says by how much; the log says the same every
//! 10 s while frames are late. `tests/clock_status.rs` checks that an rclpy node with `use_sim_time` finds its clock
//! equal to the last `/clock`, and the status's factor within 25 % of the one it measures.
//!
//! **No ERROR in normal use.** A subscriber of rclpy's default QoS (reliable, keep last 10) on
//! `tissue/points` that falls behind on a large, fragmented cloud asks for fragments the
//! writer's keep-last history has already replaced; RustDDS logs that as an ERROR although it
//! is keep-last history working as specified. The node drops exactly that line (its target and
//! text, `src/cli/dds_log.rs`); every other RustDDS error still reaches the log.
//!
//! # Measured
//!
//! `ip netns exec NS cargo test --release --test ros_node -- --nocapture --test-threads=1` (NS a
//! loopback-only namespace as `.ci/run` makes it; rclpy 9.1.2 and Fast DDS 3.2.3 wheels, this
//! 2-core machine):
//!
//! | what | result |
//! |---|---|
//! | discovery: rclpy sees the node and all 28 expected topics with exact types | 0.28 s after `rclpy.init()` |
//! | `tissue/points`, 30,000 points (480 kB) published at 30 Hz, the Fast DDS profile above | 138 of 138 clouds whole in 5 s: 27.6 Hz |
//! | `servo_jp` → `measured_cp` against dVRK's DH forward kinematics | position error 8e-17 m, rotation 7e-16 |
//! | teleop: MTM +50 mm / clutched +40 mm / released −30 mm | PSM +10.0 mm / 0.0 mm / −6.0 mm |
//! | bad input (12 kinds on the arm topics, plus MTM and pedals) | all rejected with topic and reason on `PSM1/error`; publishing never stopped |
//!
//! Faults tried on purpose (`tests/bag_faults.rs`, `tests/recording.rs`, `tests/flood.rs`,
//! `tests/fuzz_inputs.rs`, `tests/urdf_layouts.rs`, `tests/clock_status.rs`, run in a loopback
//! namespace): a node killed with SIGKILL while recording loses nothing the log reported on
//! disk once `bag recover` has rebuilt the bag; a full disk stops the recording and leaves a
//! readable bag while the node runs on and exits 0; a record path in a missing folder or on a
//! read-only file system is refused before the node starts; a `servo_jp` flood at 6,271
//! commands/s keeps the frame rate within 85 % and the memory flat; a cloud subscriber that
//! stops reading costs the frame rate nothing; 20,000 fuzzed CDR payloads, 2,057 mutated scene
//! files and 1,600 fuzzed URDFs are refused with a message each, never a panic; a 30-minute
//! soak (`launch-scripts/soak.py --minutes 30`) ran at 0.98× real time with 0 ERROR lines.
//!
//! # Reliability under hostile input
//!
//! What a process on the same network, or a crafted file, can do to the node, each row with
//! its regression test (the DDS ones in a loopback namespace):
//!
//! | attack | what happens | test |
//! |---|---|---|
//! | RTPS DATA_FRAG claiming a 4 GiB sample, from made-up writers, to the discovery and user ports | dropped before anything is allocated ([`participant`]: 64 KiB per sample, 8 MiB in all, through a patched RustDDS); memory flat, /clock at its rate | `tests/hostile_network.rs` |
//! | arrays longer than the arm's joints, names longer than a name can be, control characters | dropped on receipt with one short, rate-limited line stating the size; log lines escape control characters | `tests/ros_node.rs` (`tests/ros/test_bad_input.py`) |
//! | SIGTERM, SIGHUP | finish the bag as SIGINT does, exit 0 ([`shutdown`]) | `tests/bag_faults.rs` |
//! | a bag with a huge record length to `bag recover` or `--replay` | refused with a limit from the file's size; no partial output | `tests/bag_faults.rs` |
//! | `--record` / `bag recover` onto an existing file or a symlink | refused unless `--force`; never written through a symlink | `tests/bag_faults.rs` |
//! | a URDF with 10⁵ links | checked in linear time (about a second), bounded memory | `tests/urdf_limits.rs` |
//! | 2·10⁵ nested XML elements in a URDF | refused: nesting deeper than 32 levels, with the line | `tests/urdf_limits.rs` |
//! | a second node with the same name and namespace in the domain | refused at start, naming the first; the first runs on | `tests/hostile_network.rs` |
//! | `ROS_AUTOMATIC_DISCOVERY_RANGE`, `ROS_LOCALHOST_ONLY` | honoured as ROS 2 defines them (LOCALHOST: rclpy on this host finds the node, and every socket of the node is bound to 127.0.0.1 or the multicast group, none to every interface; OFF: nobody does); an unknown range refused | `tests/hostile_network.rs`, unit test in [`participant`] |
//! | a participant without a permitted identity (unsecured, or with its own CA's identity and permissions) sending `move_jp` to a node under SROS2 | not matched: the arm does not move and the participant reads nothing; a permitted reader is refused a writer its permissions do not grant ([`security`]: `ROS_SECURITY_ENABLE=true`, a keystore, the `sros2` feature) | `tests/sros2.rs`, unit test in [`security`] |
//!
//! Without SROS2 (the default, as in ROS 2), any participant that can reach the node's
//! ports may command the arms: `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` keeps other hosts
//! out, SROS2 keeps out every participant without a permitted identity.

pub mod camera;
pub mod inputs;
pub mod kinematics;
pub mod msgs;
pub mod names;
pub mod node;
pub mod outputs;
pub mod parameters;
pub mod participant;
pub mod recorder;
pub mod recover;
pub mod replay;
pub mod ros_args;
pub mod rosout;
pub mod schema;
pub mod security;
pub mod session;
pub mod shutdown;
pub mod sim_clock;
pub mod status;

pub use node::{run_node, NodeError};
pub use session::{NodeSettings, SessionError};
