//! URDFs as an attacker could write them, through `check` as a user runs it: many links
//! load in linear time and bounded memory, and deep element nesting is refused with a
//! message instead of overflowing the parser's stack.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A scratch folder with the Si layout scene pointing at `urdf` (the text given).
fn scene_with_urdf(name: &str, urdf: &str) -> (PathBuf, PathBuf) {
    let dir = std::env::temp_dir().join(format!("dvrk-urdf-limits-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("PSM1.urdf");
    std::fs::write(&file, urdf).unwrap();
    let scene = std::fs::read_to_string(root().join("tests/scenes/si_layout.toml")).unwrap();
    let scene_file = dir.join("scene.toml");
    std::fs::write(
        &scene_file,
        scene.replace(
            "\"tests/urdf/PSM1_si_layout.urdf\"",
            &format!("{:?}", file.display().to_string()),
        ),
    )
    .unwrap();
    (dir, scene_file)
}

/// `check SCENE`: success, its output, wall time and the peak resident memory (kB) of the
/// children waited for so far.
fn check(scene: &Path) -> (Option<i32>, String, Duration, i64) {
    let started = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_dvrk-tissue-sim"))
        .current_dir(root())
        .arg("check")
        .arg(scene)
        .output()
        .expect("the binary runs");
    let wall = started.elapsed();
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: getrusage writes the struct it is given.
    unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, &mut usage) };
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    (out.status.code(), text, wall, usage.ru_maxrss)
}

/// The Si layout fixture with `count` extra links below its wrist: half in one long chain
/// of fixed joints, half side by side.
fn with_extra_links(count: usize) -> String {
    let urdf = std::fs::read_to_string(root().join("tests/urdf/PSM1_si_layout.urdf")).unwrap();
    let joint = urdf.find("<joint name=\"wrist_yaw\"").expect("wrist_yaw");
    let child = &urdf[joint..];
    let start = child.find("<child link=\"").unwrap() + "<child link=\"".len();
    let wrist = &child[start..start + child[start..].find('"').unwrap()];
    let mut extra = String::new();
    for i in 0..count {
        let parent = if i % 2 == 0 && i >= 2 {
            format!("extra_{}", i - 2)
        } else {
            wrist.to_owned()
        };
        extra += &format!(
            "<link name=\"extra_{i}\"/><joint name=\"extra_joint_{i}\" type=\"fixed\">\
             <parent link=\"{parent}\"/><child link=\"extra_{i}\"/>\
             <origin xyz=\"0 0 0.001\"/></joint>\n"
        );
    }
    let end = urdf.rfind("</robot>").unwrap();
    format!("{}{extra}{}", &urdf[..end], &urdf[end..])
}

#[test]
fn a_hundred_thousand_links_check_in_seconds_with_bounded_memory() {
    let links = 100_000;
    let (dir, scene) = scene_with_urdf("many", &with_extra_links(links));
    let (code, text, wall, peak_kb) = check(&scene);
    std::fs::remove_dir_all(&dir).ok();
    eprintln!("{links} extra links: check took {wall:.2?}, peak RSS {peak_kb} kB");
    assert_eq!(code, Some(0), "{text}");
    assert!(text.contains(": ok"), "{text}");
    // Quadratic, 10^4 extra links took 54 s and 8.2 GB; linear, 10^5 are far inside these.
    assert!(wall < Duration::from_secs(20), "check took {wall:?}");
    assert!(peak_kb < 1024 * 1024, "peak RSS {peak_kb} kB");
}

#[test]
fn deep_xml_nesting_is_refused_with_the_limit_and_line() {
    let depth = 200_000;
    let urdf = format!(
        "<?xml version=\"1.0\"?>\n<robot name=\"deep\">\n{}{}</robot>\n",
        "<link name=\"a\">".repeat(depth),
        "</link>".repeat(depth)
    );
    let (dir, scene) = scene_with_urdf("deep", &urdf);
    let (code, text, wall, _) = check(&scene);
    std::fs::remove_dir_all(&dir).ok();
    eprintln!("{depth} nested elements: refused in {wall:.2?}");
    assert_eq!(code, Some(1), "not a clean refusal: {text}");
    assert!(
        text.contains("elements nest deeper than 32 levels at line 3"),
        "{text}"
    );
}

/// Home joints outside the URDF's limits are refused by `check` with the arm, the key, the
/// joint and its limits, as building the arm would refuse them; the shipped camera scene's
/// ECM at yaw −3 rad (its limit is −1.595 rad) is the case.
#[test]
fn home_joints_outside_the_urdf_limits_are_refused_by_check() {
    let text = std::fs::read_to_string(root().join("tests/scenes/camera.toml")).unwrap();
    let bad = text.replace(
        "home_joints = [0.0, 0.0, 0.05, 0.0]",
        "home_joints = [-3.0, 0.0, 0.05, 0.0]",
    );
    assert_ne!(bad, text, "the ECM's home_joints line moved");
    let dir = std::env::temp_dir().join(format!("dvrk-home-limits-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, bad).unwrap();
    let (code, out, _, _) = check(&scene);
    std::fs::remove_dir_all(&dir).ok();
    assert_ne!(code, Some(0), "{out}");
    assert!(
        out.contains("(ECM).home_joints") && out.contains("outer_yaw") && out.contains("-1.595183"),
        "{out}"
    );
}
