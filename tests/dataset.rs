//! `dataset` as a user runs it: two shards of a dataset give exactly the episodes of one
//! unsharded run (manifest lines, bags to the bit on the CPU backend); a worker killed
//! mid-episode and run again completes the dataset with no duplicate and no truncated bag;
//! variation files with an unknown key, an empty range or a distribution leaving the valid
//! range are refused, naming the key, the value and the reason. Small scene, short episodes.

mod support;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use support::{binary, output_of_success};

const SCENE: &str = "tests/scenes/small_scripted.toml";

/// Varies the material, the block's place and the probe's path of the small scene.
const VARY: &str = r#"
[[vary]]
key = "tissue.0.material.youngs_modulus"
dist = "log_uniform"
min = 600.0
max = 2000.0

[[vary]]
key = "tissue.0.material.poisson_ratio"
dist = "uniform"
min = 0.25
max = 0.4

[[vary]]
key = "tissue.0.center.0"
dist = "normal"
add = true
mean = 0.0
std = 0.002
min = -0.004
max = 0.004

[[vary]]
key = "tool.0.keyframe.*.position.1"
dist = "uniform"
add = true
shared = true
min = -0.004
max = 0.004

[[vary]]
key = "tool.0.contact.friction"
dist = "choice"
values = [0.2, 0.5]
"#;

fn write_vary(dir: &Path, text: &str) -> PathBuf {
    let path = dir.join("vary.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// `dataset` on `scene` (CPU, seed 11) with the variations in `vary`, as a user runs it.
fn dataset(scene: &str, vary: &Path, out: &Path, episodes: u32, seconds: f64) -> Command {
    let mut command = binary();
    command
        .args(["dataset", "--scene", scene, "--backend", "cpu", "--vary"])
        .arg(vary)
        .args(["--episodes", &episodes.to_string(), "--seed", "11"])
        .args(["--seconds", &seconds.to_string(), "--out"])
        .arg(out)
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX");
    command
}

/// Every manifest line of a dataset folder, sorted.
fn manifest_lines(dir: &Path) -> Vec<String> {
    let mut lines = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let name = entry.unwrap().file_name().into_string().unwrap();
        if name.starts_with("manifest-") && name.ends_with(".jsonl") {
            let text = std::fs::read_to_string(dir.join(&name)).unwrap();
            lines.extend(text.lines().map(str::to_owned));
        }
    }
    lines.sort();
    lines
}

/// The folder's finished files (no temporary ones), name to contents.
fn finished_files(dir: &Path, ext: &str) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.starts_with("episode-") && n.ends_with(ext))
        .map(|n| (n.clone(), std::fs::read(dir.join(&n)).unwrap()))
        .collect()
}

/// Messages in a complete MCAP file: its summary section is read (a file cut short has
/// none) and every message is read back.
fn messages_in_complete_bag(bytes: &[u8]) -> u64 {
    let summary = mcap::Summary::read(bytes)
        .expect("a readable bag")
        .expect("a complete bag has a summary");
    let stats = summary.stats.expect("statistics in the summary");
    let mut read = 0;
    for message in mcap::MessageStream::new(bytes).unwrap() {
        message.expect("every message readable");
        read += 1;
    }
    assert_eq!(read, stats.message_count);
    read
}

#[test]
fn two_shards_give_the_episodes_of_the_unsharded_run() {
    let tmp = tempfile::tempdir().unwrap();
    let vary = write_vary(tmp.path(), VARY);
    let whole = tmp.path().join("whole");
    let sharded = tmp.path().join("sharded");
    output_of_success(&mut dataset(SCENE, &vary, &whole, 6, 0.25));
    // Shard 0 from --shard with two episodes at once; shard 1 from Slurm's environment.
    output_of_success(
        dataset(SCENE, &vary, &sharded, 6, 0.25).args(["--shard", "0/2", "--jobs", "2"]),
    );
    output_of_success(
        dataset(SCENE, &vary, &sharded, 6, 0.25)
            .env("SLURM_ARRAY_TASK_ID", "1")
            .env("SLURM_ARRAY_TASK_COUNT", "2"),
    );
    let lines = manifest_lines(&whole);
    assert_eq!(lines.len(), 6);
    assert_eq!(lines, manifest_lines(&sharded));
    let bags = finished_files(&whole, ".mcap");
    assert_eq!(bags.len(), 6);
    for (name, bytes) in &bags {
        assert!(messages_in_complete_bag(bytes) > 0, "{name}");
    }
    assert!(
        bags == finished_files(&sharded, ".mcap"),
        "the shards' bags differ from the unsharded run's"
    );
    // The draws differ between episodes: a dataset, not six copies.
    let params: std::collections::BTreeSet<String> = lines
        .iter()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap()["params"].to_string())
        .collect();
    assert_eq!(params.len(), 6);
    // A rerun finds every episode finished.
    let (stdout, _) = output_of_success(&mut dataset(SCENE, &vary, &whole, 6, 0.25));
    assert!(stdout.contains("0 episode(s) run, 6 skipped"), "{stdout}");
    let (table, _) = output_of_success(binary().args(["dataset", "summary"]).arg(&sharded));
    assert!(table.contains("6 of 6 episode(s) finished"), "{table}");
    // Another definition in the same folder is refused.
    let refused = dataset(SCENE, &vary, &whole, 7, 0.25).output().unwrap();
    assert!(!refused.status.success());
    assert!(String::from_utf8_lossy(&refused.stderr).contains("another dataset"));
}

#[test]
fn a_killed_worker_rerun_completes_without_duplicates_or_truncated_bags() {
    let tmp = tempfile::tempdir().unwrap();
    let vary = write_vary(tmp.path(), VARY);
    let out = tmp.path().join("out");
    let mut child = dataset(SCENE, &vary, &out, 3, 1.0)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Killed while episode 1 is being written: episode 0 finished, 1's bag partial.
    let start = Instant::now();
    let mid_episode_1 = loop {
        let names: Vec<String> = std::fs::read_dir(&out)
            .map(|d| {
                d.map(|e| e.unwrap().file_name().into_string().unwrap())
                    .collect()
            })
            .unwrap_or_default();
        let partial_1 = names
            .iter()
            .any(|n| n.starts_with(".episode-000001.mcap") && n.ends_with(".partial"));
        if partial_1 && names.iter().any(|n| n == "episode-000000.json") {
            break true;
        }
        if start.elapsed() > Duration::from_secs(120) || child.try_wait().unwrap().is_some() {
            break false;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    std::thread::sleep(Duration::from_millis(100));
    Command::new("kill")
        .args(["-KILL", &child.id().to_string()])
        .status()
        .unwrap();
    child.wait().unwrap();
    assert!(
        mid_episode_1,
        "episode 1 never started before the worker ended"
    );
    assert!(!out.join("episode-000001.json").exists());
    assert!(!out.join("episode-000001.mcap").exists());
    let (table, _) = output_of_success(binary().args(["dataset", "summary"]).arg(&out));
    assert!(table.contains("1 of 3 episode(s) finished"), "{table}");
    assert!(table.contains("temporary .partial file(s)"), "{table}");

    let (stdout, _) = output_of_success(&mut dataset(SCENE, &vary, &out, 3, 1.0));
    assert!(stdout.contains("2 episode(s) run, 1 skipped"), "{stdout}");
    let lines = manifest_lines(&out);
    let indices: Vec<u64> = lines
        .iter()
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).unwrap();
            v["index"].as_u64().unwrap()
        })
        .collect();
    assert_eq!(indices, vec![0, 1, 2], "one line per episode");
    for (name, bytes) in finished_files(&out, ".mcap") {
        let record: serde_json::Value = serde_json::from_slice(
            &std::fs::read(out.join(name.replace(".mcap", ".json"))).unwrap(),
        )
        .unwrap();
        assert_eq!(
            messages_in_complete_bag(&bytes),
            record["bag_messages"].as_u64().unwrap(),
            "{name}"
        );
    }
}

/// Episodes of a scene with a camera keep its pictures in their bags, as a node's bag does
/// (tests/scenes/camera.toml: the ECM's 2 × 160 × 120 stereo camera at 30 Hz, JPEG by
/// default), drawn from where each episode's drawn ECM joints put the scope: two episodes
/// with different yaws see different pictures from their first frame on.
#[test]
fn episodes_of_a_scene_with_a_camera_keep_the_pictures_of_their_drawn_view() {
    const CAMERA: &str = "tests/scenes/camera.toml";
    let dir = std::env::temp_dir().join(format!("dts-dataset-camera-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dvrk_tissue_sim::config::load(&support::root().join(CAMERA)).unwrap();
    let ecm = scene.arms.iter().position(|a| a.name == "ECM").unwrap();
    let vary = write_vary(
        &dir,
        &format!(
            "[[vary]]\nkey = \"arm.{ecm}.home_joints.0\"\ndist = \"uniform\"\nadd = true\n\
             min = -0.2\nmax = 0.2\n"
        ),
    );
    let out = dir.join("out");
    let mut command = binary();
    command
        .args(["dataset", "--scene", CAMERA, "--backend", "cpu", "--vary"])
        .arg(&vary)
        .args([
            "--episodes",
            "2",
            "--seed",
            "5",
            "--seconds",
            "0.2",
            "--out",
        ])
        .arg(&out)
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX");
    output_of_success(&mut command);
    let bags = finished_files(&out, ".mcap");
    assert_eq!(bags.len(), 2, "{:?}", bags.keys());
    let mut first_pictures = Vec::new();
    for (name, bytes) in &bags {
        messages_in_complete_bag(bytes);
        let mut pictures = Vec::new();
        let mut infos = 0;
        for message in mcap::MessageStream::new(bytes).unwrap() {
            let message = message.unwrap();
            match message.channel.topic.as_str() {
                "/ECM/image_raw/compressed" => pictures.push(message.data.into_owned()),
                "/ECM/left/camera_info" | "/ECM/right/camera_info" => infos += 1,
                _ => {}
            }
        }
        // 12 frames of 1/60 s, a picture every other one from the first.
        assert_eq!((pictures.len(), infos), (6, 12), "{name}");
        first_pictures.push(pictures[0].clone());
    }
    assert_ne!(
        first_pictures[0], first_pictures[1],
        "two drawn views gave the same picture"
    );
    std::fs::remove_dir_all(&dir).ok();
}

fn refusal(vary_text: &str) -> String {
    let tmp = tempfile::tempdir().unwrap();
    let vary = write_vary(tmp.path(), vary_text);
    let out = tmp.path().join("out");
    let run = dataset(SCENE, &vary, &out, 2, 0.1).output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr).into_owned();
    assert!(!run.status.success(), "accepted:\n{vary_text}\n{stderr}");
    assert!(!out.exists(), "a refused dataset wrote {}", out.display());
    stderr
}

#[test]
fn bad_variation_files_are_refused_with_key_value_and_reason() {
    let unknown = refusal(
        "[[vary]]\nkey = \"tissue.0.material.youngs\"\ndist = \"uniform\"\nmin = 1.0\nmax = 2.0\n",
    );
    assert!(
        unknown.contains("tissue.0.material.youngs") && unknown.contains("unknown field"),
        "{unknown}"
    );
    let missing =
        refusal("[[vary]]\nkey = \"tissue.3.center\"\ndist = \"uniform\"\nmin = 1.0\nmax = 2.0\n");
    assert!(missing.contains("no `3` in `tissue`"), "{missing}");
    let empty = refusal(
        "[[vary]]\nkey = \"tissue.0.material.damping\"\ndist = \"uniform\"\nmin = 3.0\nmax = 3.0\n",
    );
    assert!(
        empty.contains("tissue.0.material.damping") && empty.contains("empty range"),
        "{empty}"
    );
    let leaves = refusal(
        "[[vary]]\nkey = \"tissue.0.material.poisson_ratio\"\ndist = \"uniform\"\nmin = 0.3\nmax = 0.6\n",
    );
    assert!(
        leaves.contains("max 0.6 leaves the valid range")
            && leaves.contains("tissue[0].material.poisson_ratio = 0.6")
            && leaves.contains("ν < 0.5"),
        "{leaves}"
    );
    let normal = refusal(
        "[[vary]]\nkey = \"tissue.0.material.density\"\ndist = \"normal\"\nmean = 1000.0\nstd = 50.0\nmin = -10.0\nmax = 1100.0\n",
    );
    assert!(
        normal.contains("min -10.0 leaves the valid range"),
        "{normal}"
    );
    let typo = refusal(
        "[[vary]]\nkey = \"tissue.0.material.damping\"\ndist = \"gaussian\"\nmin = 1.0\nmax = 2.0\n",
    );
    assert!(typo.contains("unknown distribution `gaussian`"), "{typo}");
}

/// A scene with a `wound` labels its episodes with the wound gap at the end, and
/// `dataset summary` shows it: `config/suture.toml` with its right block moved away from
/// the wound by a drawn 0–1 mm, cut to 3 frames.
#[test]
fn a_wound_scene_labels_its_episodes_with_the_wound_gap() {
    let tmp = tempfile::tempdir().unwrap();
    let vary = write_vary(
        tmp.path(),
        "[[vary]]\nkey = \"tissue.1.center.0\"\ndist = \"uniform\"\nadd = true\nmin = 0.0\nmax = 0.001\n",
    );
    let out = tmp.path().join("out");
    let (stdout, _) = output_of_success(&mut dataset("config/suture.toml", &vary, &out, 2, 0.05));
    assert!(stdout.contains("wound gap"), "{stdout}");
    let lines = manifest_lines(&out);
    assert_eq!(lines.len(), 2);
    for line in &lines {
        let v: serde_json::Value = serde_json::from_str(line).unwrap();
        let gap = v["outcomes"]["wound_gap_m"].as_f64().expect("a wound gap");
        let moved = v["params"]["tissue.1.center.0"].as_f64().unwrap() - 0.011;
        // The blocks are laid 4 mm apart; the particles nearest the wound sit on the grid's
        // lattice, 3.9 mm apart at rest (the summary of `run --headless`).
        assert!(
            (gap - (0.0039 + moved)).abs() < 0.0007,
            "gap {gap} m with the right block moved {moved} m: {line}"
        );
    }
    let (table, _) = output_of_success(binary().args(["dataset", "summary"]).arg(&out));
    assert!(table.contains("wound gap mm"), "{table}");
}
