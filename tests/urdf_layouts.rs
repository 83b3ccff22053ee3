//! PSM URDFs in dvrk_model's layouts through the `check` command, as a user runs it.

use std::path::Path;
use std::process::Command;

fn check(scene: &str) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_dvrk-tissue-sim"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["check", scene])
        .output()
        .expect("the binary runs");
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    (out.status.success(), text)
}

/// `check` on a scene whose arm PSM2 is the Si fixture (written for PSM1) opens the URDF and
/// says ok; the same scene with the fixture's jaw renamed is refused with the file and reason.
#[test]
fn check_opens_the_si_layout_urdf() {
    let (ok, text) = check("tests/scenes/si_layout.toml");
    assert!(ok, "{text}");
    assert!(
        text.contains("si_layout.toml: ok (scene \"ros-test-si-layout\"")
            && text.contains("1 arm(s)"),
        "{text}"
    );

    let dir = std::env::temp_dir().join(format!("dvrk-si-check-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let urdf = std::fs::read_to_string(root.join("tests/urdf/PSM1_si_layout.urdf")).unwrap();
    let broken = dir.join("PSM1_si_no_jaw.urdf");
    std::fs::write(&broken, urdf.replace("joint=\"jaw\"", "joint=\"grip\"")).unwrap();
    let scene = std::fs::read_to_string(root.join("tests/scenes/si_layout.toml")).unwrap();
    let broken_scene = dir.join("si_no_jaw.toml");
    std::fs::write(
        &broken_scene,
        scene.replace(
            "\"tests/urdf/PSM1_si_layout.urdf\"",
            &format!("{:?}", broken.display().to_string()),
        ),
    )
    .unwrap();
    let (ok, text) = check(broken_scene.to_str().unwrap());
    assert!(!ok, "{text}");
    for fragment in [
        "arm[0] (PSM2).urdf",
        broken.to_str().unwrap(),
        "`jaw_1` mimics `grip`, which is not in the URDF",
    ] {
        assert!(text.contains(fragment), "lacks {fragment}: {text}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// SplitMix64: a fixed seed, so a failure reproduces.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

/// One mutation of a URDF text: a cut, a numeric attribute made NaN / infinite / huge / text /
/// empty, a name changed, a tag or attribute dropped, bytes flipped or removed.
fn mutate(text: &str, rng: &mut Rng) -> (String, String) {
    let quotes: Vec<usize> = text.match_indices('"').map(|(i, _)| i).collect();
    let attribute = |rng: &mut Rng| {
        let k = rng.below(quotes.len() / 2) * 2;
        (quotes[k] + 1, quotes[k + 1])
    };
    match rng.below(7) {
        0 => {
            let mut cut = rng.below(text.len());
            while !text.is_char_boundary(cut) {
                cut -= 1;
            }
            (text[..cut].to_owned(), format!("cut at byte {cut}"))
        }
        1 | 2 => {
            let (a, b) = attribute(rng);
            let value = [
                "nan",
                "NaN",
                "inf",
                "-inf",
                "1e308",
                "-1e308",
                "1e400",
                "x",
                "",
                "0 0",
                "1 2 3 4",
                "nan nan nan",
            ][rng.below(12)];
            let old = &text[a..b];
            // A vector attribute (xyz, rpy, axis) gets the value in one of its places.
            let new = if old.split(' ').count() == 3 && rng.below(2) == 0 {
                let mut parts: Vec<&str> = old.split(' ').collect();
                parts[rng.below(3)] = value;
                parts.join(" ")
            } else {
                value.to_owned()
            };
            (
                format!("{}{new}{}", &text[..a], &text[b..]),
                format!("\"{old}\" -> \"{new}\" at byte {a}"),
            )
        }
        3 => {
            // A name changed: a link, joint, parent, child or mimic no longer matches.
            let (a, b) = attribute(rng);
            (
                format!("{}{}_x{}", &text[..a], &text[a..b], &text[b..]),
                format!("\"{}\" renamed at byte {a}", &text[a..b]),
            )
        }
        4 => {
            // An element dropped (from one `<` to the next `>`).
            let starts: Vec<usize> = text.match_indices('<').map(|(i, _)| i).collect();
            let a = starts[rng.below(starts.len())];
            let b = a + text[a..].find('>').unwrap() + 1;
            (
                format!("{}{}", &text[..a], &text[b..]),
                format!("`{}` dropped", &text[a..b]),
            )
        }
        5 => {
            // An attribute dropped with its value.
            let (a, b) = attribute(rng);
            let start = text[..a].rfind(' ').unwrap();
            (
                format!("{}{}", &text[..start], &text[b + 1..]),
                format!("attribute `{}` dropped", &text[start..=b]),
            )
        }
        _ => {
            let mut bytes = text.as_bytes().to_vec();
            let at = rng.below(bytes.len());
            bytes[at] = (rng.next() & 0x7f) as u8;
            (
                String::from_utf8_lossy(&bytes).into_owned(),
                format!("byte {at} replaced"),
            )
        }
    }
}

/// Mutated and truncated PSM URDFs (the built-in one and the dvrk_model-layout test files),
/// loaded as `check` and a run load them: never a panic; a refused file gets a message with
/// the scene key, the file and a reason; an accepted one gives a finite tool pose everywhere
/// in its joint limits (no NaN can reach `measured_cp`).
#[test]
fn fuzzed_urdfs_never_panic_and_are_refused_with_file_and_reason() {
    use dvrk_tissue_sim::config;
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene_text = std::fs::read_to_string(root.join("tests/scenes/si_layout.toml")).unwrap();
    let dir = std::env::temp_dir().join(format!("dvrk-urdf-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut rng = Rng(0x0dd_b1a5_f00d);
    let (mut refused, mut accepted) = (0u32, 0u32);
    for file in [
        "urdf/psm.urdf",
        "tests/urdf/PSM1_si_layout.urdf",
        "tests/urdf/PSM1_current_layout.urdf",
        "tests/urdf/PSM1_older_layout.urdf",
    ] {
        let text = std::fs::read_to_string(root.join(file)).unwrap();
        for case in 0..400 {
            let (mutated, what) = mutate(&text, &mut rng);
            let path = dir.join(format!("case{case}.urdf"));
            std::fs::write(&path, &mutated).unwrap();
            let scene = config::from_str(
                &scene_text.replace(
                    "\"tests/urdf/PSM1_si_layout.urdf\"",
                    &format!("{:?}", path.display().to_string()),
                ),
                Path::new("fuzz.toml"),
            )
            .unwrap();
            let outcome = std::panic::catch_unwind(|| {
                let problems = dvrk_tissue_sim::sim::check_arm_urdfs(&scene);
                let built = problems
                    .is_empty()
                    .then(|| dvrk_tissue_sim::robot::Psm::from_urdf_file(&path, "PSM2").unwrap());
                (problems, built)
            });
            let (problems, built) =
                outcome.unwrap_or_else(|_| panic!("{file} case {case} ({what}) panicked"));
            match built {
                Some(psm) => {
                    accepted += 1;
                    let joints = psm.joints().joints().to_vec();
                    for corner in 0..64 {
                        let q: [f64; 6] = std::array::from_fn(|i| {
                            if corner >> i & 1 == 0 {
                                joints[i].lower
                            } else {
                                joints[i].upper
                            }
                        });
                        let pose = psm.forward(&q).unwrap();
                        assert!(
                            pose.translation.vector.iter().all(|v| v.is_finite())
                                && pose.rotation.coords.iter().all(|v| v.is_finite()),
                            "{file} case {case} ({what}): accepted, but the tool pose at {q:?} is \
                             {pose:?}"
                        );
                    }
                }
                None => {
                    refused += 1;
                    assert_eq!(problems.len(), 1, "{problems:?}");
                    let message = problems[0].to_string();
                    assert!(
                        message.starts_with("arm[0] (PSM2).")
                            && message.contains(&path.display().to_string())
                            && message.len() > path.display().to_string().len() + 40,
                        "{file} case {case} ({what}): {message}"
                    );
                }
            }
        }
    }
    println!("1600 fuzzed URDFs: {refused} refused with file and reason, {accepted} accepted");
    assert!(refused > 0 && accepted > 0);
    std::fs::remove_dir_all(&dir).ok();
}
