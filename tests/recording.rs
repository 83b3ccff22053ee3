//! `run --record` and `run --replay`: the bag's topics, types, counts, stamps and contents;
//! a replay reproducing the tissue clouds bit for bit on the CPU backend; clear errors for bad
//! bags; the bag read by the PyPI `rosbags` package (tests/ros/read_bag.py).
//!
//! The headless tests need no network. The node tests start DDS participants and run only
//! inside a loopback-only network namespace (as tests/ros_node.rs; `.ci/run` makes one);
//! elsewhere they print `SKIPPED: <reason>` and pass, unless `CI` is set.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::Arc;
use std::time::{Duration, Instant};

use dvrk_tissue_sim::ros::msgs::*;
use dvrk_tissue_sim::ros::outputs::OutputLayout;
use dvrk_tissue_sim::ros::recorder::Recorder;
use dvrk_tissue_sim::sim::{Due, Frame, FrameRecord, FrameSink, RecordedInput};

mod support;
use support::dds::{network_prerequisites, python, skip_or_fail};
use support::root;

const SMALL: &str = "tests/scenes/small.toml";

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("dvrk-recording-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn sim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dvrk-tissue-sim"))
        .current_dir(root())
        .args(args)
        .output()
        .expect("cannot run the binary")
}

fn servo_jp(q: &[f64]) -> RecordedInput {
    RecordedInput {
        topic: "/PSM1/servo_jp".into(),
        type_name: JointState::type_name(),
        cdr: to_cdr(&JointState {
            position: q.to_vec(),
            ..Default::default()
        })
        .unwrap(),
    }
}

/// A bag of inputs only, as `--record` writes them: servo_jp pushing the probe 16 mm down
/// into the tissue from frame 5 on (one command a frame at 60 Hz), then holding.
fn write_input_bag(path: &Path, topic_arm: &str) {
    write_input_bag_for(SMALL, path, topic_arm);
}

/// [`write_input_bag`] for the scene file `scene`.
fn write_input_bag_for(scene: &str, path: &Path, topic_arm: &str) {
    let scene = dvrk_tissue_sim::config::load(&root().join(scene)).unwrap();
    let setup = dvrk_tissue_sim::sim::build_setup(&scene).unwrap();
    let layout = OutputLayout::new(&scene, &setup, "/");
    let (recorder, mut tap) = Recorder::create(path, layout, 1.0, false).unwrap();
    for k in 5..=37u32 {
        let mut q = [0.0, 0.0, 0.12, 0.0, 0.0, 0.0];
        q[2] += 0.0005 * (k - 4) as f64;
        let mut input = servo_jp(&q);
        input.topic = format!("/{topic_arm}/servo_jp");
        tap.send(FrameRecord {
            start: k as f64 / 60.0,
            inputs: vec![input],
            events: vec![],
            frame: Arc::new(Frame {
                time: (k + 1) as f64 / 60.0,
                ..Default::default()
            }),
            due: Due::default(),
        });
    }
    drop(tap);
    recorder.finish().unwrap();
}

/// Messages of a bag: (topic, schema name, log time, payload), in file order.
fn read_bag(path: &Path) -> Vec<(String, String, u64, Vec<u8>)> {
    let bytes = std::fs::read(path).unwrap();
    let summary = mcap::Summary::read(&bytes)
        .expect("summary readable")
        .expect("the bag has a summary (it was finished)");
    assert!(summary.stats.is_some());
    mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(|m| {
            let m = m.expect("message readable");
            let schema = m.channel.schema.as_ref().unwrap();
            assert_eq!(schema.encoding, "ros2msg");
            assert_eq!(m.channel.message_encoding, "cdr");
            assert!(m.channel.metadata.contains_key("offered_qos_profiles"));
            (
                m.channel.topic.clone(),
                schema.name.clone(),
                m.log_time,
                m.data.into_owned(),
            )
        })
        .collect()
}

fn clouds(messages: &[(String, String, u64, Vec<u8>)]) -> BTreeMap<u64, Vec<u8>> {
    messages
        .iter()
        .filter(|m| m.0 == "/tissue/points")
        .map(|m| (m.2, m.3.clone()))
        .collect()
}

fn replay(input: &Path, out: &Path) {
    replay_on(input, out, &["--backend", "cpu"]);
}

/// Headless replay of `input` into `out` with `backend` arguments (`--backend ...`, `--p2g`).
fn replay_on(input: &Path, out: &Path, backend: &[&str]) {
    replay_scene(SMALL, input, out, backend);
}

/// [`replay_on`] for the scene file `scene`.
fn replay_scene(scene: &str, input: &Path, out: &Path, backend: &[&str]) {
    let mut args = vec!["run", "--scene", scene, "--headless"];
    args.extend_from_slice(backend);
    args.extend_from_slice(&[
        "--replay",
        input.to_str().unwrap(),
        "--record",
        out.to_str().unwrap(),
    ]);
    let o = sim(&args);
    assert!(
        o.status.success(),
        "replay failed:\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    println!("{stdout}");
    assert!(stdout.contains("0 frame(s) dropped"), "{stdout}");
}

#[test]
fn replay_records_every_output_and_repeats_tissue_clouds_bit_for_bit() {
    let input = scratch("inputs.mcap");
    write_input_bag(&input, "PSM1");
    let (a, b) = (scratch("replay_a.mcap"), scratch("replay_b.mcap"));
    replay(&input, &a);
    replay(&input, &b);
    let messages = read_bag(&a);

    // Topics and types as the node publishes them.
    let mut types = BTreeMap::new();
    let mut counts: BTreeMap<String, usize> = BTreeMap::new();
    for (topic, ty, _, _) in &messages {
        types.insert(topic.clone(), ty.clone());
        *counts.entry(topic.clone()).or_default() += 1;
    }
    for (topic, ty) in [
        ("/PSM1/servo_jp", "sensor_msgs/msg/JointState"),
        ("/PSM1/measured_js", "sensor_msgs/msg/JointState"),
        ("/PSM1/jaw/measured_js", "sensor_msgs/msg/JointState"),
        ("/PSM1/measured_cp", "geometry_msgs/msg/PoseStamped"),
        ("/PSM1/measured_cv", "geometry_msgs/msg/TwistStamped"),
        ("/tissue/points", "sensor_msgs/msg/PointCloud2"),
        ("/tissue/surface", "visualization_msgs/msg/Marker"),
        ("/tools/probe/wrench", "geometry_msgs/msg/WrenchStamped"),
        ("/tf", "tf2_msgs/msg/TFMessage"),
    ] {
        assert_eq!(types.get(topic).map(String::as_str), Some(ty), "{topic}");
    }
    // The bag's inputs, all applied; 38 frames (through the last input's frame) at the
    // scene's rates in simulated time.
    assert_eq!(counts["/PSM1/servo_jp"], 33);
    assert_eq!(counts["/PSM1/measured_js"], 38);
    assert_eq!(counts["/tools/probe/wrench"], 38);
    assert_eq!(counts["/tissue/points"], 19);
    assert_eq!(counts["/tissue/surface"], 6);

    // Log times never go back; header stamps equal them on outputs.
    for w in messages.windows(2) {
        assert!(
            w[1].2 >= w[0].2,
            "log time goes back: {:?} then {:?}",
            w[0].0,
            w[1].0
        );
    }
    let (_, _, t, bytes) = messages
        .iter()
        .rev()
        .find(|m| m.0 == "/tissue/points")
        .unwrap();
    let cloud: PointCloud2 = from_cdr(bytes).unwrap();
    assert_eq!(Time::from_secs(*t as f64 * 1e-9), cloud.header.stamp);
    let names: Vec<&str> = cloud.fields.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, ["x", "y", "z", "volumetric_strain"]);
    assert_eq!(cloud.data.len(), (cloud.width * cloud.point_step) as usize);
    assert!(cloud.width > 1000);
    let js: JointState = from_cdr(
        &messages
            .iter()
            .rev()
            .find(|m| m.0 == "/PSM1/measured_js")
            .unwrap()
            .3,
    )
    .unwrap();
    assert_eq!(js.name[2], "insertion");
    assert!((js.position[2] - 0.1365).abs() < 1e-9, "{:?}", js.position);
    let wrench: WrenchStamped = from_cdr(
        &messages
            .iter()
            .rev()
            .find(|m| m.0 == "/tools/probe/wrench")
            .unwrap()
            .3,
    )
    .unwrap();
    assert_eq!(wrench.header.frame_id, "PSM1");
    assert!(wrench.wrench.force.z < -0.005, "{:?}", wrench.wrench);

    // The push moved the tissue, and both replays agree on every cloud bit for bit.
    let (ca, cb) = (clouds(&messages), clouds(&read_bag(&b)));
    assert_eq!(ca.len(), cb.len());
    assert!(ca == cb, "replayed clouds differ");
    assert_ne!(
        ca.values().next(),
        ca.values().last(),
        "the tissue never moved"
    );

    // The replayed bag's inputs are the originals.
    let original: Vec<_> = read_bag(&input)
        .into_iter()
        .map(|m| (m.0, m.2, m.3))
        .collect();
    let replayed: Vec<_> = messages
        .iter()
        .filter(|m| m.0 == "/PSM1/servo_jp")
        .map(|m| (m.0.clone(), m.2, m.3.clone()))
        .collect();
    assert_eq!(original, replayed);

    // The PyPI rosbags package reads it (types, counts, stamps, decoded contents).
    rosbags_check(&a, "replay");
}

/// The width and height a baseline JPEG's SOF0 segment declares.
fn jpeg_size(jpeg: &[u8]) -> (u16, u16) {
    assert_eq!(&jpeg[..2], [0xff, 0xd8], "no JPEG start-of-image marker");
    let mut at = 2;
    while at + 9 <= jpeg.len() {
        let length = u16::from_be_bytes([jpeg[at + 2], jpeg[at + 3]]) as usize;
        if jpeg[at + 1] == 0xc0 {
            let height = u16::from_be_bytes([jpeg[at + 5], jpeg[at + 6]]);
            let width = u16::from_be_bytes([jpeg[at + 7], jpeg[at + 8]]);
            return (width, height);
        }
        at += 2 + length;
    }
    panic!("no SOF0 segment in the JPEG");
}

/// A headless replay that records keeps the endoscope's pictures (tests/scenes/camera.toml:
/// an ECM's 2 × 160 × 120 stereo camera at 30 Hz), drawn again from the replayed state: as
/// JPEG with both CameraInfos by default, as rgb8 with each eye's depth and labels with
/// `camera.record = "raw"`, none with `"off"`; the same bag replayed twice gives the same
/// pictures, and the PyPI `rosbags` package reads them (tests/ros/read_camera_bag.py).
#[test]
fn a_recorded_replay_draws_the_camera_again_and_keeps_its_pictures() {
    const CAMERA: &str = "tests/scenes/camera.toml";
    let input = scratch("camera_inputs.mcap");
    write_input_bag_for(CAMERA, &input, "PSM1");
    let (a, b) = (scratch("camera_a.mcap"), scratch("camera_b.mcap"));
    replay_scene(CAMERA, &input, &a, &["--backend", "cpu"]);
    replay_scene(CAMERA, &input, &b, &["--backend", "cpu"]);
    let pictures = |bag: &Path| -> BTreeMap<u64, Vec<u8>> {
        read_bag(bag)
            .into_iter()
            .filter(|m| m.0 == "/ECM/image_raw/compressed")
            .map(|m| (m.2, m.3))
            .collect()
    };
    let messages = read_bag(&a);
    let count = |topic: &str| messages.iter().filter(|m| m.0 == topic).count();
    // 38 frames at 60 Hz, a picture every other one (30 Hz), from the first frame on.
    assert_eq!(count("/ECM/image_raw/compressed"), 19);
    assert_eq!(count("/ECM/left/camera_info"), 19);
    assert_eq!(count("/ECM/right/camera_info"), 19);
    assert_eq!(
        count("/ECM/image_raw"),
        0,
        "raw pictures in a compressed bag"
    );
    let (in_a, in_b) = (pictures(&a), pictures(&b));
    for (t, jpeg) in &in_a {
        let m: CompressedImage = from_cdr(jpeg).unwrap();
        assert_eq!(Time::from_secs(*t as f64 * 1e-9), m.header.stamp);
        assert_eq!(m.header.frame_id, "ECM_left_optical_frame");
        assert_eq!(
            (m.format.as_str(), jpeg_size(&m.data)),
            ("jpeg", (320, 120))
        );
    }
    assert!(in_a == in_b, "the same replay drew different pictures");
    assert_ne!(
        in_a.values().next(),
        in_a.values().last(),
        "the probe pushed the tissue, yet the picture never changed"
    );
    rosbags_camera_check(&a, "compressed");

    // `record = "raw"`: the rgb8 pair, and each eye's depth and labels.
    // The camera scene with `camera.record = mode`, replayed into a bag of that name.
    let replay_recording = |mode: &str| {
        let text = std::fs::read_to_string(root().join(CAMERA)).unwrap();
        let scene = scratch(&format!("camera_{mode}.toml"));
        let record = format!("[camera]\nrecord = \"{mode}\"\n");
        std::fs::write(&scene, text.replace("[camera]\n", &record)).unwrap();
        let bag = scratch(&format!("camera_{mode}.mcap"));
        replay_scene(scene.to_str().unwrap(), &input, &bag, &["--backend", "cpu"]);
        bag
    };
    let raw = replay_recording("raw");
    let messages = read_bag(&raw);
    let count = |topic: &str| messages.iter().filter(|m| m.0 == topic).count();
    for topic in [
        "/ECM/image_raw",
        "/ECM/left/depth",
        "/ECM/right/depth",
        "/ECM/left/labels",
        "/ECM/right/labels",
        "/ECM/left/camera_info",
    ] {
        assert_eq!(count(topic), 19, "{topic}");
    }
    assert_eq!(count("/ECM/image_raw/compressed"), 0);
    rosbags_camera_check(&raw, "raw");

    // `record = "off"`: no picture at all.
    let messages = read_bag(&replay_recording("off"));
    assert!(messages
        .iter()
        .all(|m| !m.0.starts_with("/ECM/image") && !m.0.ends_with("camera_info")));
    assert!(messages.iter().any(|m| m.0 == "/tissue/points"));
}

/// tests/ros/read_camera_bag.py on `bag` (`kind`: compressed or raw).
fn rosbags_camera_check(bag: &Path, kind: &str) {
    run_bag_script("read_camera_bag.py", bag, kind);
}

/// tests/ros/read_bag.py on `bag` (`kind`: replay, node or interrupted).
fn rosbags_check(bag: &Path, kind: &str) {
    run_bag_script("read_bag.py", bag, kind);
}

fn has_rosbags() -> bool {
    support::dds::python_imports("rosbags")
}

/// `tests/ros/<script> BAG KIND`, which reads the bag with the PyPI rosbags package and
/// fails on what it finds wrong.
fn run_bag_script(script: &str, bag: &Path, kind: &str) {
    if !has_rosbags() {
        skip_or_fail("no .venv with the PyPI rosbags package (see .ci/run)");
        return;
    }
    let o = Command::new(python())
        .arg(root().join("tests/ros").join(script))
        .args([bag.to_str().unwrap(), kind])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    println!("{stdout}");
    assert!(
        o.status.success(),
        "{script} failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Point positions of every cloud of a bag, by stamp.
fn cloud_points(messages: &[(String, String, u64, Vec<u8>)]) -> BTreeMap<u64, Vec<[f32; 3]>> {
    clouds(messages)
        .into_iter()
        .map(|(t, cdr)| {
            let cloud: PointCloud2 = from_cdr(&cdr).unwrap();
            let points = cloud
                .data
                .chunks(cloud.point_step as usize)
                .map(|p| {
                    let f = |k: usize| f32::from_le_bytes(p[4 * k..4 * k + 4].try_into().unwrap());
                    [f(0), f(1), f(2)]
                })
                .collect();
            (t, points)
        })
        .collect()
}

/// Largest point distance between two bags' clouds at equal stamps (m), and how many
/// clouds were compared.
fn largest_cloud_difference(a: &Path, b: &Path) -> (f32, usize) {
    let (ca, cb) = (cloud_points(&read_bag(a)), cloud_points(&read_bag(b)));
    assert_eq!(ca.keys().collect::<Vec<_>>(), cb.keys().collect::<Vec<_>>());
    let mut largest = 0.0f32;
    for (t, pa) in &ca {
        let pb = &cb[t];
        assert_eq!(pa.len(), pb.len());
        for (p, q) in pa.iter().zip(pb) {
            let d = (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f32>().sqrt();
            largest = largest.max(d);
        }
    }
    (largest, ca.len())
}

/// What a replay repeats on the GPU backend: with fixed-point P2G (integer atomics) the
/// clouds bit for bit; with f32 atomics (sums in a varying order) the same clouds to within
/// a few micrometres of the CPU's (measured on llvmpipe: 0.53 µm fixed point, 0.54 µm f32).
#[test]
fn gpu_replays_repeat_bit_for_bit_with_fixed_point_and_closely_with_f32_atomics() {
    let adapters = dvrk_tissue_sim::mpm::gpu::adapter::adapters();
    let Some(first) = adapters.first() else {
        skip_or_fail("no GPU adapter (install mesa-vulkan-drivers for llvmpipe)");
        return;
    };
    let input = scratch("gpu_inputs.mcap");
    write_input_bag(&input, "PSM1");
    let fixed = ["--backend", "gpu", "--p2g", "fixed"];
    let (a, b) = (scratch("gpu_fixed_a.mcap"), scratch("gpu_fixed_b.mcap"));
    replay_on(&input, &a, &fixed);
    replay_on(&input, &b, &fixed);
    let (ca, cb) = (clouds(&read_bag(&a)), clouds(&read_bag(&b)));
    assert!(ca.len() >= 19, "{} clouds", ca.len());
    assert_eq!(ca, cb, "fixed-point GPU replays differ");
    assert_ne!(
        ca.values().next(),
        ca.values().last(),
        "the tissue never moved"
    );

    let cpu = scratch("gpu_vs_cpu.mcap");
    replay(&input, &cpu);
    let (d, n) = largest_cloud_difference(&a, &cpu);
    println!("fixed-point GPU against CPU: {n} clouds, largest point difference {d:e} m");
    assert!(d < 5e-6, "fixed-point GPU and CPU clouds differ by {d} m");
    if first
        .features()
        .contains(wgpu::Features::SHADER_FLOAT32_ATOMIC)
    {
        let float = scratch("gpu_float.mcap");
        replay_on(&input, &float, &["--backend", "gpu", "--p2g", "float"]);
        let (d, n) = largest_cloud_difference(&float, &cpu);
        println!("f32-atomic GPU against CPU: {n} clouds, largest point difference {d:e} m");
        assert!(d < 2e-6, "f32-atomic GPU and CPU clouds differ by {d} m");
    }
}

#[test]
fn bad_bags_are_refused_with_clear_errors() {
    let replay_err = |bag: &Path| {
        let o = sim(&[
            "run",
            "--scene",
            SMALL,
            "--headless",
            "--backend",
            "cpu",
            "--replay",
            bag.to_str().unwrap(),
        ]);
        assert!(!o.status.success());
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let missing = scratch("missing.mcap");
    assert!(replay_err(&missing).contains("cannot open"));

    let corrupt = scratch("corrupt.mcap");
    std::fs::write(&corrupt, b"not an mcap file at all").unwrap();
    assert!(replay_err(&corrupt).contains("is not a readable MCAP file"));

    let other = scratch("other_scene.mcap");
    write_input_bag(&other, "PSM2");
    let e = replay_err(&other);
    assert!(
        e.contains("was not recorded on this scene") && e.contains("/PSM2/servo_jp"),
        "{e}"
    );

    // Outputs only: a bag written with nothing driving the arms.
    let outputs_only = scratch("outputs_only.mcap");
    {
        let scene = dvrk_tissue_sim::config::load(&root().join(SMALL)).unwrap();
        let setup = dvrk_tissue_sim::sim::build_setup(&scene).unwrap();
        let layout = OutputLayout::new(&scene, &setup, "/");
        let (recorder, mut tap) = Recorder::create(&outputs_only, layout, 1.0, false).unwrap();
        tap.send(FrameRecord {
            start: 0.0,
            inputs: vec![],
            events: vec![],
            frame: Arc::new(Frame {
                time: 1.0 / 60.0,
                tools: vec![],
                ..Default::default()
            }),
            due: Due {
                tf: true,
                ..Default::default()
            },
        });
        drop(tap);
        recorder.finish().unwrap();
    }
    assert!(replay_err(&outputs_only).contains("has no input messages"));
}

// ---- the node (DDS: loopback-only network namespace) ----

fn start_node(domain: u16, bag: &Path) -> std::process::Child {
    Command::new(env!("CARGO_BIN_EXE_dvrk-tissue-sim"))
        .current_dir(root())
        .args(["run", "--scene", SMALL, "--backend", "cpu", "--record"])
        .arg(bag)
        .env("ROS_DOMAIN_ID", domain.to_string())
        .env("ROS_DISTRO", "kilted")
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(bag.with_extension("log")).unwrap())
        .spawn()
        .expect("cannot start the node")
}

/// SIGINT, then wait (at most 10 s) for a clean exit.
fn interrupt(mut child: std::process::Child) -> std::process::ExitStatus {
    let _ = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status();
    let deadline = Instant::now() + Duration::from_secs(10);
    while Instant::now() < deadline {
        if let Ok(Some(status)) = child.try_wait() {
            return status;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let _ = child.kill();
    panic!("the node did not stop within 10 s of SIGINT");
}

/// rclpy pushes the probe with servo_jp while the node records; SIGINT ends the node with
/// the bag finished (rosbags reads it); a headless replay of that bag on the CPU backend
/// gives the same tissue clouds, bit for bit, at every recorded stamp.
#[test]
fn node_recording_survives_sigint_and_replays_bit_for_bit() {
    if !network_prerequisites(true) {
        return;
    }
    let bag = scratch("node.mcap");
    let node = start_node(31, &bag);
    let out = Command::new(python())
        .arg(root().join("tests/ros/drive_servo.py"))
        .env("ROS_DOMAIN_ID", "31")
        .env("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
        .env("PYTHONUNBUFFERED", "1")
        .output()
        .expect("cannot run python");
    let status = interrupt(node);
    let log = std::fs::read_to_string(bag.with_extension("log")).unwrap_or_default();
    println!("{}", String::from_utf8_lossy(&out.stdout));
    assert!(
        out.status.success(),
        "drive_servo.py failed:\n{}\n{}\n--- node ---\n{log}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(status.success(), "node exit {status:?}\n{log}");
    assert!(log.contains("bag finished"), "{log}");
    assert!(
        !log.contains("Cannot notify spin task"),
        "a normal Ctrl-C logged an error:\n{log}"
    );
    rosbags_check(&bag, "node");

    let recorded = read_bag(&bag);
    let inputs = recorded.iter().filter(|m| m.0 == "/PSM1/servo_jp").count();
    assert!(inputs >= 20, "{inputs} servo_jp inputs recorded");
    let replayed = scratch("node_replayed.mcap");
    replay(&bag, &replayed);
    let (ca, cb) = (clouds(&recorded), clouds(&read_bag(&replayed)));
    let mut compared = 0;
    for (t, cloud) in &ca {
        if let Some(other) = cb.get(t) {
            assert!(cloud == other, "clouds differ at t = {} ns", t);
            compared += 1;
        }
    }
    println!("{compared} clouds identical after replay");
    assert!(
        compared + 2 >= ca.len() && compared > 20,
        "{compared} of {}",
        ca.len()
    );
    assert_ne!(
        ca.values().next(),
        ca.values().last(),
        "the tissue never moved"
    );
}

/// `run --headless --record`: a scripted run (no ROS, no network) records its outputs at the
/// scene's rates in simulated time; the last wrench in the bag is the force the run printed
/// for its last frame, and the standard readers (rosbags, mcap) decode every message.
#[test]
fn a_scripted_headless_run_records_its_outputs() {
    let bag = scratch("scripted.mcap");
    let o = sim(&[
        "run",
        "--scene",
        "tests/scenes/small_scripted.toml",
        "--headless",
        "--backend",
        "cpu",
        "--seconds",
        "1",
        "--record",
        bag.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(stdout.contains("0 frame(s) dropped"), "{stdout}");
    let messages = read_bag(&bag);
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    for m in &messages {
        *counts.entry(m.0.as_str()).or_default() += 1;
    }
    // 60 frames of 1/60 s; points and tf at 30 Hz, wrench at 60 Hz, surface at 10 Hz, the
    // piece count at 5 Hz.
    let expected = [
        ("/tf", 30),
        ("/tf_static", 1),
        ("/tissue/pieces", 5),
        ("/tissue/points", 30),
        ("/tissue/surface", 10),
        ("/tools/probe/wrench", 60),
    ];
    for (topic, n) in expected {
        let got = counts.get(topic).copied().unwrap_or(0);
        assert!(
            got.abs_diff(n) <= 1,
            "{topic}: {got} messages, expected {n}"
        );
    }
    assert_eq!(counts.len(), expected.len(), "{counts:?}");
    for m in &messages {
        let stamp = match m.0.as_str() {
            "/tools/probe/wrench" => from_cdr::<WrenchStamped>(&m.3).unwrap().header.stamp,
            "/tissue/points" => from_cdr::<PointCloud2>(&m.3).unwrap().header.stamp,
            _ => continue,
        };
        assert_eq!(
            stamp.sec as u64 * 1_000_000_000 + stamp.nanosec as u64,
            m.2,
            "{}: stamp is the log time",
            m.0
        );
    }
    let last_wrench = messages
        .iter()
        .rfind(|m| m.0 == "/tools/probe/wrench")
        .map(|m| from_cdr::<WrenchStamped>(&m.3).unwrap())
        .unwrap();
    let printed = stdout
        .lines()
        .rfind(|l| l.starts_with("t="))
        .and_then(|l| l.split("F=(").nth(1))
        .and_then(|f| f.split(')').next())
        .unwrap_or_else(|| panic!("no force line in {stdout}"));
    let f: Vec<f64> = printed.split(',').map(|v| v.parse().unwrap()).collect();
    let w = &last_wrench.wrench.force;
    assert!(
        (w.x - f[0]).abs() <= 1e-4 && (w.y - f[1]).abs() <= 1e-4 && (w.z - f[2]).abs() <= 1e-4,
        "bag {w:?} against printed {f:?}"
    );
    assert!(f[2].abs() > 1e-3, "the probe pressed the tissue: {f:?}");
    let cl = clouds(&messages);
    assert_ne!(
        cl.values().next(),
        cl.values().last(),
        "the tissue never moved"
    );
    rosbags_check_counts(&bag);
}

/// Every message of `bag` decoded by rosbags and read by the `mcap` package, both counting
/// what the Rust reader counts (tests/ros/count_bag.py).
fn rosbags_check_counts(bag: &Path) {
    if !has_rosbags() {
        skip_or_fail("no .venv with the PyPI rosbags package (see .ci/run)");
        return;
    }
    let n = read_bag(bag).len();
    let o = Command::new(python())
        .arg(root().join("tests/ros/count_bag.py"))
        .arg(bag)
        .arg(u64::MAX.to_string())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    for reader in ["rosbags", "mcap"] {
        assert!(
            stdout.contains(&format!("{reader} total={n} ")),
            "{reader} does not count {n}:\n{stdout}"
        );
    }
}
