//! PSM URDFs in dvrk_model's layouts through the `check` command, as a user runs it.

use std::path::Path;
use std::process::Command;

fn check(scene: &str) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_dvrk-tissue-sim"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["check", scene])
        .output()
        .expect("the binary runs");
    let text = String::from_utf8_lossy(&out.stdout).into_owned()
        + &String::from_utf8_lossy(&out.stderr);
    (out.status.success(), text)
}

/// `check` on a scene whose arm PSM2 is the Si fixture (written for PSM1) opens the URDF and
/// says ok; the same scene with the fixture's jaw renamed is refused with the file and reason.
#[test]
fn check_opens_the_si_layout_urdf() {
    let (ok, text) = check("tests/ros/scenes/si_layout.toml");
    assert!(ok, "{text}");
    assert!(
        text.contains("si_layout.toml: ok (scene \"ros-test-si-layout\"") && text.contains("1 arm(s)"),
        "{text}"
    );

    let dir = std::env::temp_dir().join(format!("dvrk-si-check-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let urdf = std::fs::read_to_string(root.join("tests/urdf/PSM1_si_layout.urdf")).unwrap();
    let broken = dir.join("PSM1_si_no_jaw.urdf");
    std::fs::write(&broken, urdf.replace("joint=\"jaw\"", "joint=\"grip\"")).unwrap();
    let scene = std::fs::read_to_string(root.join("tests/ros/scenes/si_layout.toml")).unwrap();
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
