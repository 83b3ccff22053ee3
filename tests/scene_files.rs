//! Scene files: shipped scenes are valid; each kind of bad input gives its own clear error.

use dvrk_tissue_sim::config::{self, SceneError};
use std::path::Path;

const GOOD: &str = r#"
name = "ok"
[domain]
origin = [-0.048, -0.048, 0.0]
size = [0.096, 0.096, 0.048]
dx = 0.002
[table]
height = 0.004
[[tissue]]
center = [0.0, 0.0, 0.014]
size = [0.04, 0.04, 0.02]
[tissue.material]
youngs_modulus = 5400.0
poisson_ratio = 0.45
density = 1060.0
[[tool]]
name = "probe"
shape = { type = "sphere", radius = 0.005 }
[[tool.keyframe]]
t = 0.0
position = [0.0, 0.0, 0.031]
"#;

fn problems_of(text: &str) -> Vec<config::Problem> {
    match config::from_str(text, Path::new("test.toml")) {
        Err(SceneError::Invalid { problems, .. }) => problems,
        other => panic!("expected validation problems, got {other:?}"),
    }
}

/// Replaces the first occurrence of `from` in the good scene and returns the problems.
fn problems_with(from: &str, to: &str) -> Vec<config::Problem> {
    assert!(GOOD.contains(from), "fixture lacks {from}");
    problems_of(&GOOD.replacen(from, to, 1))
}

fn assert_single(problems: &[config::Problem], key: &str, allowed_fragment: &str) {
    assert_eq!(problems.len(), 1, "{problems:#?}");
    assert_eq!(problems[0].key, key, "{problems:#?}");
    assert!(
        problems[0].allowed.contains(allowed_fragment),
        "'{}' should mention '{allowed_fragment}'",
        problems[0].allowed
    );
}

#[test]
fn shipped_scenes_are_valid() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("config");
    let mut count = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            config::load(&path).unwrap_or_else(|e| panic!("{e}"));
            count += 1;
        }
    }
    assert!(count >= 4, "default, retraction, push, needle at least");
    assert!(config::from_str(GOOD, Path::new("good.toml")).is_ok());
}

#[test]
fn poisson_ratio_of_one_half_or_more_is_rejected() {
    let p = problems_with("poisson_ratio = 0.45", "poisson_ratio = 0.5");
    assert_single(&p, "tissue[0].material.poisson_ratio", "ν < 0.5");
    assert_eq!(p[0].value, "0.5");
}

#[test]
fn pb_mpm_settings_are_parsed_and_bad_ones_explained() {
    let pb = "[table]\nheight = 0.004\n";
    let scene = |solver: &str| GOOD.replacen(pb, &format!("[solver]\n{solver}\n{pb}"), 1);
    let ok = config::from_str(
        &scene("method = \"pb_mpm\"\niterations = 10\nrelaxation = 1.2\ndt = 0.004"),
        Path::new("pb.toml"),
    )
    .unwrap();
    assert_eq!(ok.solver.method, dvrk_tissue_sim::mpm::Method::PbMpm);
    assert_eq!((ok.solver.iterations, ok.solver.relaxation), (10, 1.2));
    let defaults = config::from_str(GOOD, Path::new("good.toml")).unwrap();
    assert_eq!(defaults.solver.method, dvrk_tissue_sim::mpm::Method::MlsMpm);
    assert_eq!(
        (defaults.solver.iterations, defaults.solver.relaxation),
        (5, 1.5)
    );
    assert_single(
        &problems_of(&scene("method = \"pb_mpm\"\niterations = 0")),
        "solver.iterations",
        "1 ≤ iterations ≤ 100",
    );
    assert_single(
        &problems_of(&scene("relaxation = 2.0")),
        "solver.relaxation",
        "0 < relaxation < 2",
    );
    let pic = config::from_str(&scene("method = \"pic_mpm\""), Path::new("pic.toml")).unwrap();
    assert_eq!(pic.solver.method, dvrk_tissue_sim::mpm::Method::PicMpm);
    let bad = config::from_str(&scene("method = \"semi_implicit\""), Path::new("m.toml"));
    let message = bad.unwrap_err().to_string();
    assert!(
        ["mls_mpm", "pb_mpm", "pic_mpm", "implicit"]
            .iter()
            .all(|m| message.contains(m)),
        "{message}"
    );
}

#[test]
fn implicit_settings_are_parsed_and_bad_ones_explained() {
    let pb = "[table]\nheight = 0.004\n";
    let scene = |solver: &str| GOOD.replacen(pb, &format!("[solver]\n{solver}\n{pb}"), 1);
    let ok = config::from_str(
        &scene(
            "method = \"implicit\"\nnewton_iterations = 4\ncg_tolerance = 0.05\npreconditioner = \"mass\"",
        ),
        Path::new("implicit.toml"),
    )
    .unwrap();
    assert_eq!(ok.solver.method, dvrk_tissue_sim::mpm::Method::Implicit);
    let params = ok.solver.implicit_params();
    assert_eq!(params.newton_iterations, 4);
    assert_eq!(params.cg_tolerance, 0.05);
    assert_eq!(
        params.preconditioner,
        dvrk_tissue_sim::mpm::Preconditioner::Mass
    );
    assert_single(
        &problems_of(&scene("method = \"implicit\"\nnewton_iterations = 0")),
        "solver.newton_iterations",
        "1 ≤ newton_iterations ≤ 100",
    );
    assert_single(
        &problems_of(&scene("newton_tolerance = 1.0")),
        "solver.newton_tolerance",
        "0 < newton_tolerance < 1",
    );
    assert_single(
        &problems_of(&scene("cg_iterations = 20000")),
        "solver.cg_iterations",
        "1 ≤ cg_iterations ≤ 10000",
    );
    assert_single(
        &problems_of(&scene("cg_tolerance = 0.0")),
        "solver.cg_tolerance",
        "0 < cg_tolerance < 1",
    );
}

#[test]
fn non_positive_youngs_modulus_is_rejected() {
    let p = problems_with("youngs_modulus = 5400.0", "youngs_modulus = -1.0");
    assert_single(&p, "tissue[0].material.youngs_modulus", "0 < E");
}

#[test]
fn tool_outside_the_domain_is_rejected() {
    let p = problems_with(
        "position = [0.0, 0.0, 0.031]",
        "position = [0.5, 0.0, 0.031]",
    );
    assert_single(
        &p,
        "tool[0] (probe).keyframe[0].position",
        "tool outside the domain",
    );
}

#[test]
fn grid_too_coarse_for_the_tissue_is_rejected() {
    let p = problems_with("size = [0.04, 0.04, 0.02]", "size = [0.04, 0.04, 0.003]");
    assert_single(&p, "tissue[0].size[2]", "too coarse");
}

#[test]
fn tissue_below_the_table_is_rejected() {
    let p = problems_with("height = 0.004", "height = 0.006");
    assert_single(&p, "tissue[0].center", "below table.height");
}

#[test]
fn keyframes_out_of_order_are_rejected() {
    let text = format!("{GOOD}[[tool.keyframe]]\nt = 0.0\nposition = [0.0, 0.0, 0.03]\n");
    let p = problems_of(&text);
    assert_single(
        &p,
        "tool[0] (probe).keyframe[1].t",
        "greater than the previous",
    );
}

#[test]
fn every_problem_is_reported_at_once() {
    let text = GOOD
        .replacen("poisson_ratio = 0.45", "poisson_ratio = 0.7", 1)
        .replacen("dx = 0.002", "dx = 0.002\n", 1)
        .replacen("density = 1060.0", "density = 0.0", 1)
        .replacen("radius = 0.005", "radius = -0.005", 1);
    let keys: Vec<String> = problems_of(&text).into_iter().map(|p| p.key).collect();
    for key in [
        "tissue[0].material.poisson_ratio",
        "tissue[0].material.density",
        "tool[0] (probe).shape.radius",
    ] {
        assert!(keys.iter().any(|k| k == key), "{key} missing from {keys:?}");
    }
}

#[test]
fn syntax_errors_and_unknown_keys_name_the_place() {
    let err = config::from_str(
        &GOOD.replacen("dx = 0.002", "dx = ", 1),
        Path::new("broken.toml"),
    )
    .unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.starts_with("broken.toml: not a valid scene file"),
        "{msg}"
    );
    assert!(msg.contains("line"), "{msg}");

    let err = config::from_str(
        &GOOD.replacen("dx = 0.002", "dx = 0.002\ndxx = 1", 1),
        Path::new("typo.toml"),
    )
    .unwrap_err();
    assert!(err.to_string().contains("dxx"), "{err}");

    let err = config::from_str(
        &GOOD.replacen("\"sphere\"", "\"cube\"", 1),
        Path::new("shape.toml"),
    )
    .unwrap_err();
    assert!(err.to_string().contains("cube"), "{err}");
}

#[test]
fn missing_file_is_an_io_error_naming_the_path() {
    let err = config::load(Path::new("/nonexistent/scene.toml")).unwrap_err();
    assert!(matches!(err, SceneError::Io { .. }));
    assert!(err.to_string().contains("/nonexistent/scene.toml"));
}

#[test]
fn tool_thinner_than_two_cells_is_rejected() {
    let p = problems_with("radius = 0.005", "radius = 0.0015");
    assert_single(&p, "tool[0] (probe).shape", "at least 2 grid cells thick");
}

#[test]
fn arms_teleop_and_outputs_are_validated() {
    let arm = r#"
[[arm]]
name = "PSM1"
base_xyz = [0.0, 0.0, 0.14]
home_joints = [0.0, 0.0, 0.12, 0.0, 0.0, 0.0]
tool = "probe"
"#;
    let good = format!("{GOOD}{arm}");
    let scene = config::from_str(&good, Path::new("arm.toml")).unwrap();
    assert_eq!(scene.arms[0].urdf_path(), "urdf/psm.urdf");
    assert_eq!(scene.arms[0].mode, config::ArmMode::Simulated);
    assert_eq!(scene.outputs.points_rate_hz, 30.0);

    let bad = format!(
        "{GOOD}{}\n[teleop]\narm = \"PSM9\"\nscale = -1.0\n[outputs]\npoints_rate_hz = -3.0\npoints_downsample = 0\npoints_voxel = -0.001\n",
        arm.replace("\"probe\"", "\"scalpel\"")
            .replace("name = \"PSM1\"", "name = \"PSM 1\"")
            .replace("0.12, 0.0", "nan, 0.0")
    );
    let problems = problems_of(&bad);
    let keys: Vec<&str> = problems.iter().map(|p| p.key.as_str()).collect();
    for key in [
        "arm[0] (PSM 1).name",
        "arm[0] (PSM 1).tool",
        "arm[0] (PSM 1).home_joints",
        "teleop.arm",
        "teleop.scale",
        "outputs.points_rate_hz",
        "outputs.points_downsample",
        "outputs.points_voxel",
    ] {
        assert!(keys.contains(&key), "{key} not reported: {keys:?}");
    }
    let typed = arm.replace(
        "tool = \"probe\"",
        "tool = \"probe\"\ntool_type = \"MONOPOLAR_CURVED_SCISSORS:400179\"",
    );
    let scene = config::from_str(&format!("{GOOD}{typed}"), Path::new("typed.toml")).unwrap();
    assert_eq!(
        scene.arms[0].tool_type.as_deref(),
        Some("MONOPOLAR_CURVED_SCISSORS:400179")
    );
    for bad in ["large needle driver", "LARGE_NEEDLE_DRIVER", "LND:40x"] {
        let problems = problems_of(&format!(
            "{GOOD}{}",
            arm.replace(
                "tool = \"probe\"",
                &format!("tool = \"probe\"\ntool_type = \"{bad}\"")
            )
        ));
        assert_single(&problems, "arm[0] (PSM1).tool_type", "NAME:model");
    }
    let mirror = arm.replace("tool = \"probe\"", "tool = \"probe\"\nmirror_of = \"PSM1\"");
    let problems = problems_of(&format!("{GOOD}{mirror}"));
    assert!(problems
        .iter()
        .any(|p| p.key.ends_with("mirror_of") && p.allowed.contains("mode = \"mirror\"")));
}

/// Bimanual teleoperation: `[[teleop]]` once per MTM–PSM pair (a single `[teleop]` table
/// still reads as one pair); two pairs driving one arm, reading one MTM, on two consoles, or
/// naming a missing arm are refused with the pair's key.
#[test]
fn teleop_pairs_read_as_a_table_or_an_array_and_clashes_are_refused() {
    let pairs = config::load(Path::new("tests/scenes/bimanual.toml")).unwrap();
    let read: Vec<(&str, &str)> = pairs
        .teleop
        .iter()
        .map(|t| (t.arm.as_str(), t.mtm.as_str()))
        .collect();
    assert_eq!(read, [("PSM1", "MTMR"), ("PSM2", "MTML")]);
    let single = config::load(Path::new("tests/scenes/small.toml")).unwrap();
    assert_eq!(single.teleop.len(), 1);
    assert_eq!(single.teleop[0].mtm, "MTMR");

    let text = std::fs::read_to_string("tests/scenes/bimanual.toml").unwrap();
    let clash = text.replace(
        "arm = \"PSM2\"\nmtm = \"MTML\"",
        "arm = \"PSM1\"\nmtm = \"MTMR\"\nconsole = \"pedals\"",
    );
    let problems = problems_of(&clash);
    let found: Vec<(&str, &str)> = problems
        .iter()
        .map(|p| (p.key.as_str(), p.allowed.as_str()))
        .collect();
    for (key, allowed) in [
        ("teleop[1].arm", "an arm no other [[teleop]] pair drives"),
        ("teleop[1].mtm", "an MTM no other [[teleop]] pair reads"),
        (
            "teleop[1].console",
            "the console of the other [[teleop]] pairs",
        ),
    ] {
        assert!(
            found
                .iter()
                .any(|(k, a)| *k == key && a.starts_with(allowed)),
            "{key}: {allowed} not reported: {found:?}"
        );
    }
    let missing = problems_of(&text.replace("arm = \"PSM2\"\nmtm", "arm = \"PSM3\"\nmtm"));
    assert_single(&missing, "teleop[1].arm", "the name of a PSM [[arm]]");
}

#[test]
fn surface_and_cloud_scalar_options_parse_and_bad_names_are_explained() {
    let scene = config::from_str(GOOD, Path::new("ok.toml")).unwrap();
    assert_eq!(
        scene.outputs.surface,
        dvrk_tissue_sim::output::SurfaceKind::Mesh
    );
    let chosen = format!(
        "{GOOD}[outputs]\nsurface = \"isosurface\"\npoints_scalar = \"equivalent\"\npoints_voxel = 0.002\n"
    );
    let scene = config::from_str(&chosen, Path::new("iso.toml")).unwrap();
    assert_eq!(
        scene.outputs.surface,
        dvrk_tissue_sim::output::SurfaceKind::Isosurface
    );
    assert_eq!(
        scene.outputs.points_scalar,
        dvrk_tissue_sim::output::strain::StrainMeasure::Equivalent
    );
    assert_eq!(scene.outputs.points_voxel, 0.002);
    let err = config::from_str(
        &format!("{GOOD}[outputs]\nsurface = \"marching\"\n"),
        Path::new("bad.toml"),
    )
    .unwrap_err()
    .to_string();
    for fragment in ["bad.toml", "surface", "marching", "mesh", "isosurface"] {
        assert!(err.contains(fragment), "'{fragment}' missing from: {err}");
    }
}

/// `check`'s URDF pass over the good scene with one arm whose `urdf` is `urdf` (plus `extra`
/// keys), as one message per failing arm.
fn urdf_messages(urdf: &str, extra: &str) -> Vec<String> {
    let text = format!(
        "{GOOD}\n[[arm]]\nname = \"PSM2\"\nurdf = {urdf:?}\nbase_xyz = [0.0, 0.0, 0.14]\n\
         home_joints = [0.0, 0.0, 0.12, 0.0, 0.0, 0.0]\ntool = \"probe\"\n{extra}"
    );
    let scene = config::from_str(&text, Path::new("arm.toml")).unwrap();
    dvrk_tissue_sim::sim::check_arm_urdfs(&scene)
        .iter()
        .map(|p| p.to_string())
        .collect()
}

/// A copy of a tests/urdf fixture with `from` replaced by `to`, in a fresh temporary file.
fn edited_fixture(file: &str, from: &str, to: &str) -> String {
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/urdf");
    let text = std::fs::read_to_string(fixtures.join(file)).unwrap();
    assert!(text.contains(from), "{file} lacks {from}");
    let dir = std::env::temp_dir().join(format!("dvrk-urdf-check-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{}-{file}", from.len() * 31 + to.len()));
    std::fs::write(&path, text.replace(from, to)).unwrap();
    path.display().to_string()
}

fn assert_one_message(messages: &[String], fragments: &[&str]) {
    assert_eq!(messages.len(), 1, "{messages:#?}");
    for fragment in fragments {
        assert!(
            messages[0].contains(fragment),
            "{} lacks {fragment}",
            messages[0]
        );
    }
}

#[test]
fn check_loads_the_dvrk_model_layout_and_the_built_in_urdf() {
    for file in [
        "PSM1_current_layout.urdf",
        "PSM2_current_layout.urdf",
        "PSM1_older_layout.urdf",
    ] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/urdf")
            .join(file);
        assert_eq!(
            urdf_messages(&path.display().to_string(), ""),
            Vec::<String>::new()
        );
    }
    assert_eq!(urdf_messages("urdf/psm.urdf", ""), Vec::<String>::new());
}

#[test]
fn check_reports_a_missing_urdf_file() {
    assert_one_message(
        &urdf_messages("/nonexistent/PSM2.urdf", ""),
        &[
            "arm[0] (PSM2).urdf = \"/nonexistent/PSM2.urdf\"",
            "cannot read URDF file",
        ],
    );
}

#[test]
fn check_reports_malformed_urdf_xml() {
    let path = edited_fixture("PSM1_current_layout.urdf", "</robot>", "</robo");
    assert_one_message(
        &urdf_messages(&path, ""),
        &[
            &format!("arm[0] (PSM2).urdf = \"{path}\""),
            "malformed URDF",
        ],
    );
}

#[test]
fn check_reports_a_missing_psm_joint() {
    let path = edited_fixture("PSM1_current_layout.urdf", "name=\"roll\"", "name=\"spin\"");
    assert_one_message(
        &urdf_messages(&path, ""),
        &[
            "arm[0] (PSM2).urdf",
            "does not describe a PSM",
            "\"spin\"",
            "\"roll\"",
        ],
    );
}

#[test]
fn check_reports_a_missing_jaw() {
    let path = edited_fixture(
        "PSM1_current_layout.urdf",
        "joint name=\"jaw\"",
        "joint name=\"grip\"",
    );
    let messages = urdf_messages(&path, "");
    assert_one_message(
        &messages,
        &[
            "arm[0] (PSM2).urdf",
            "`jaw_1` mimics `jaw`, which is not in the URDF",
        ],
    );
}

#[test]
fn check_reports_a_base_link_it_cannot_find() {
    let path = edited_fixture("PSM1_current_layout.urdf", "PSM1_base_link", "PSM1_mount");
    assert_one_message(
        &urdf_messages(&path, ""),
        &[
            "arm[0] (PSM2).base_link",
            "`PSM2_base_link`",
            "name it with `base_link`",
        ],
    );
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/urdf/PSM1_current_layout.urdf");
    assert_one_message(
        &urdf_messages(&path.display().to_string(), "base_link = \"PSM1_mount\"\n"),
        &[
            "arm[0] (PSM2).base_link",
            "`base_link` = \"PSM1_mount\" is not a link",
        ],
    );
}

#[test]
fn check_reports_a_chain_it_cannot_find() {
    // The tool link on a side branch (the parallelogram), not below the base's path to it.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/urdf/PSM1_current_layout.urdf");
    assert_one_message(
        &urdf_messages(
            &path.display().to_string(),
            "base_link = \"PSM1_pitch_5_link\"\ntool_link = \"PSM1_tool_tip_link\"\n",
        ),
        &[
            "arm[0] (PSM2).urdf",
            "no serial path from `PSM2_pitch_5_link` to `PSM2_tool_tip_link`",
        ],
    );
    let path = edited_fixture("PSM1_current_layout.urdf", "PSM1_tool_tip_link", "PSM1_tip");
    assert_one_message(
        &urdf_messages(&path, ""),
        &["arm[0] (PSM2).tool_link", "`PSM2`, `PSM2_tool_tip_link`"],
    );
}

#[test]
fn a_scene_with_the_dvrk_model_layout_builds_and_reports_the_dh_tool_frame() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/urdf/PSM2_current_layout.urdf");
    let text = format!(
        "{GOOD}\n[[arm]]\nname = \"PSM2\"\nurdf = {:?}\nbase_xyz = [0.0, 0.0, 0.14]\n\
         home_joints = [0.1, -0.2, 0.12, 0.3, 0.2, -0.1]\ntool = \"probe\"\n",
        path.display().to_string()
    );
    let scene = config::from_str(&text, Path::new("official.toml")).unwrap();
    let setup = dvrk_tissue_sim::sim::build_setup(&scene).unwrap_or_else(|e| panic!("{e}"));
    let psm = setup.arms[0].psm();
    assert_eq!(psm.base_frame(), "PSM2_base");
    let q = [0.1, -0.2, 0.12, 0.3, 0.2, -0.1];
    let tool = psm.forward(&q).unwrap();
    let dh = dvrk_tissue_sim::robot::dh::psm_tool_pose(&q);
    assert!((tool.translation.vector - dh.translation.vector).norm() < 1e-9);
    assert!(tool.rotation.angle_to(&dh.rotation) < 1e-9);
}

#[test]
fn slicer_blades_the_grid_cannot_resolve_are_rejected() {
    let blade = |l: &str, h: &str, t: &str| {
        problems_with(
            r#"shape = { type = "sphere", radius = 0.005 }"#,
            &format!(
                r#"shape = {{ type = "slicer", length = {l}, height = {h}, thickness = {t} }}"#
            ),
        )
    };
    let good = GOOD.replacen(
        r#"shape = { type = "sphere", radius = 0.005 }"#,
        r#"shape = { type = "slicer", length = 0.03, height = 0.02, thickness = 0.0004 }"#,
        1,
    );
    config::from_str(&good, Path::new("slicer.toml")).unwrap();
    // Shorter or lower than two cells (dx = 2 mm): the blade covers no stencil.
    let p = blade("0.003", "0.02", "0.0004");
    assert_single(&p, "tool[0] (probe).shape.length", "at least 2·dx");
    assert!(p[0].value.contains("0.003"), "{p:?}");
    let p = blade("0.03", "0.0", "0.0");
    assert_eq!(p.len(), 2, "{p:#?}");
    assert_eq!(p[0].key, "tool[0] (probe).shape.height");
    // A thickness ≤ 0 or wider than half the blade.
    let p = blade("0.03", "0.02", "-0.0001");
    assert_single(&p, "tool[0] (probe).shape.thickness", "0 < thickness");
    let p = blade("0.03", "0.02", "0.015");
    assert_single(&p, "tool[0] (probe).shape.thickness", "height/2 = 0.01 m");
}

/// The good scene with a default (3-0 nylon) thread on the table.
fn with_thread(keys: &str) -> String {
    format!(
        "{GOOD}\n[[thread]]\nname = \"suture\"\nstart = [-0.03, 0.0, 0.006]\nlength = 0.06\n{keys}"
    )
}

fn thread_problems(keys: &str) -> Vec<config::Problem> {
    problems_of(&with_thread(keys))
}

#[test]
fn a_thread_with_defaults_is_valid_and_a_scene_may_have_threads_alone() {
    let scene = config::from_str(&with_thread(""), Path::new("t.toml")).unwrap();
    let t = &scene.threads[0];
    assert_eq!((t.segments, t.youngs_modulus), (60, 3.0e9));
    assert!((t.radius - 1.125e-4).abs() < 1e-10, "radius {}", t.radius);
    let alone = GOOD.replace(
        "[[tissue]]\ncenter = [0.0, 0.0, 0.014]\nsize = [0.04, 0.04, 0.02]\n[tissue.material]\nyoungs_modulus = 5400.0\npoisson_ratio = 0.45\ndensity = 1060.0\n",
        "[[thread]]\nstart = [-0.03, 0.0, 0.006]\nlength = 0.06\n",
    );
    assert!(!alone.contains("[[tissue]]"));
    config::from_str(&alone, Path::new("alone.toml")).unwrap_or_else(|e| panic!("{e}"));
    // Neither tissue nor thread: nothing to simulate.
    let empty = alone.replace(
        "[[thread]]\nstart = [-0.03, 0.0, 0.006]\nlength = 0.06\n",
        "",
    );
    assert_single(&problems_of(&empty), "tissue", "[[thread]]");
}

#[test]
fn non_physical_threads_are_refused_with_key_value_and_range() {
    let key = |k: &str| format!("thread[0] (suture).{k}");
    for (keys, k, fragment) in [
        ("radius = 0.0", "radius", "≤ value ≤"),
        ("radius = -1e-4", "radius", "≤ value ≤"),
        ("youngs_modulus = 0.0", "youngs_modulus", "Pa"),
        ("youngs_modulus = -3e9", "youngs_modulus", "Pa"),
        ("shear_modulus = 0.0", "shear_modulus", "Pa"),
        ("density = 0.0", "density", "kg/m³"),
        ("segments = 0", "segments", "1 ≤ segments"),
        ("segments = 100000", "segments", "≤ 10000"),
        // 1000 segments of 60 µm: shorter than the 0.225 mm thread is thick.
        ("segments = 1000", "length", "segments × diameter"),
        ("length = 0.0", "length", "0 < length"),
        ("direction = [0.0, 0.0, 0.0]", "direction", "non-zero"),
        ("substeps = 0", "substeps", "1 ≤ substeps"),
        ("iterations = 50", "iterations", "≤ 20"),
        ("friction = -0.1", "friction", "Coulomb"),
    ] {
        let p = if keys.starts_with("length") {
            problems_of(&with_thread("").replace("length = 0.06", keys))
        } else {
            thread_problems(keys)
        };
        assert_single(&p, &key(k), fragment);
        assert!(!p[0].value.is_empty(), "{keys}: no value in {p:?}");
    }
}

#[test]
fn a_thread_outside_the_domain_is_refused() {
    // Starts outside.
    let p = problems_of(&with_thread("").replace("[-0.03, 0.0, 0.006]", "[-0.3, 0.0, 0.006]"));
    assert_eq!(p[0].key, "thread[0] (suture).start", "{p:#?}");
    assert!(p[0].allowed.contains("outside the domain"), "{p:#?}");
    // Starts inside, runs out of it: the end is named with its position.
    let p = thread_problems("direction = [0.0, 0.0, 1.0]");
    assert_single(
        &p,
        "thread[0] (suture).length",
        "its end (-0.0300, 0.0000, 0.0660)",
    );
    // Shown to the user with the file name by `check`.
    let e = config::from_str(&with_thread("radius = 0.0"), Path::new("bad_thread.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("bad_thread.toml") && e.contains("thread[0] (suture).radius = 0.0"),
        "{e}"
    );
}

/// A thread starting inside a solid tool would be pushed through it or held crossed in it:
/// refused with the point, where it lies and how deep in which tool. Jaws closed on it at
/// the start are a grasp; a tool an arm drives starts at the arm's pose and is not checked.
#[test]
fn a_thread_starting_inside_a_tool_is_refused() {
    // The probe (a 5 mm sphere) moved onto the thread's middle, 1 mm above its axis.
    let inside = with_thread("").replace("[0.0, 0.0, 0.031]", "[0.0, 0.0, 0.007]");
    let p = problems_of(&inside);
    assert_single(&p, "thread[0] (suture).start", "inside tool \"probe\"");
    assert!(
        p[0].value.contains("point 30 of the thread at (0.0000"),
        "{p:?}"
    );
    assert!(p[0].allowed.contains("4.00 mm inside"), "{p:?}");
    // Laid along points: the key is `points`.
    let laid = inside.replace(
        "start = [-0.03, 0.0, 0.006]\nlength = 0.06\n",
        "points = [[-0.03, 0.0, 0.006], [0.03, 0.0, 0.006]]\nlength = 0.06\n",
    );
    assert_single(&problems_of(&laid), "thread[0] (suture).points", "probe");
    // Touching from above (the thread 0.1 mm below the sphere's surface line): valid.
    let above = with_thread("").replace("[0.0, 0.0, 0.031]", "[0.0, 0.0, 0.0111]");
    config::from_str(&above, Path::new("above.toml")).unwrap_or_else(|e| panic!("{e}"));
    // A gripper closed on the thread at the start holds it.
    let grasp = with_thread("").replace(
        "shape = { type = \"sphere\", radius = 0.005 }\n[[tool.keyframe]]\nt = 0.0\nposition = [0.0, 0.0, 0.031]",
        "shape = { type = \"gripper\", jaw_length = 0.01, jaw_width = 0.006, jaw_thickness = 0.004 }\n\
         [[tool.keyframe]]\nt = 0.0\nposition = [0.0, 0.0017, 0.0155]\nrpy_deg = [180.0, 0.0, 0.0]\njaw_deg = 0.0",
    );
    assert_ne!(grasp, with_thread(""), "the gripper replaced the probe");
    config::from_str(&grasp, Path::new("grasp.toml")).unwrap_or_else(|e| panic!("{e}"));
    // Driven by an arm, the probe starts where the arm's home joints put it: not checked.
    let driven = format!(
        "{inside}\n[[arm]]\nname = \"PSM1\"\nbase_xyz = [0.0, 0.0, 0.14]\n\
         home_joints = [0.0, 0.0, 0.12, 0.0, 0.0, 0.0]\ntool = \"probe\"\n"
    );
    config::from_str(&driven, Path::new("driven.toml")).unwrap_or_else(|e| panic!("{e}"));
}

/// The good scene with a half-circle needle (radius 10 mm, its arc in the xy plane at
/// z = 35 mm, swage end at (−10, 0, 35) mm) and a 3 cm thread swaged to `swaged_to` that
/// leaves the swage end along the arc's tangent there (−y), with `keys` added.
fn swaged(swaged_to: &str, start: &str, keys: &str) -> String {
    format!(
        "{GOOD}\n[[tool]]\nname = \"needle\"\nshape = {{ type = \"needle\", radius = 0.01, arc_angle = 3.14159, wire_radius = 0.0005 }}\n[[tool.keyframe]]\nt = 0.0\nposition = [0.0, 0.0, 0.035]\n\
         [[thread]]\nname = \"suture\"\nstart = {start}\ndirection = [0.0, -1.0, 0.0]\nlength = 0.03\nswaged_to = \"{swaged_to}\"\n{keys}"
    )
}

/// A thread swaged to a needle: the needle must be a needle tool of the scene, the first
/// point must start in its swage end (the message says where that is) and not be pinned.
#[test]
fn a_swage_to_a_missing_or_wrong_tool_or_off_the_needle_is_refused() {
    let at_swage = "[-0.01, 0.0, 0.035]";
    let good = swaged("needle", at_swage, "");
    let scene = config::from_str(&good, Path::new("swaged.toml")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.threads[0].swaged_to.as_deref(), Some("needle"));
    let key = |k: &str| format!("thread[0] (suture).{k}");

    // Not swaged after all, the thread's first point lies in the needle's wire: that is
    // refused too.
    let named = |p: &[config::Problem], k: &str, fragment: &str| {
        assert!(
            p.iter()
                .any(|q| q.key == key(k) && q.allowed.contains(fragment)),
            "no {k} problem mentioning {fragment:?}: {p:#?}"
        )
    };
    let p = problems_of(&swaged("nedle", at_swage, ""));
    named(
        &p,
        "swaged_to",
        "needle tool of the scene (tools: [\"probe\", \"needle\"])",
    );
    named(&p, "start", "inside tool \"needle\"");
    let p = problems_of(&swaged("probe", at_swage, ""));
    named(&p, "swaged_to", "shape type \"needle\"");
    let p = problems_of(&swaged("needle", at_swage, "pinned = \"start\""));
    assert_single(&p, &key("pinned"), "held by the needle");
    // 2 mm off the swage end: refused, with where the swage end is and how far off.
    let p = problems_of(&swaged("needle", "[-0.012, 0.0, 0.035]", ""));
    assert_single(&p, &key("start"), "(-0.01000, 0.00000, 0.03500) m");
    assert!(p[0].allowed.contains("lies 2.00 mm from it"), "{p:?}");
}

/// A `wound` names two different blocks of the scene: a misspelt block is refused with the
/// scene's block names, one block named twice is refused.
#[test]
fn a_wound_between_missing_or_identical_blocks_is_refused() {
    let text = std::fs::read_to_string("config/suture.toml").unwrap();
    let shipped = "wound = [\"left\", \"right\"]";
    assert!(text.contains(shipped));
    let scene = config::from_str(&text, Path::new("suture.toml")).unwrap();
    assert_eq!(scene.wound, Some(["left".into(), "right".into()]));

    let p = problems_of(&text.replace(shipped, "wound = [\"left\", \"rigth\"]"));
    assert_single(&p, "wound", "one of [\"left\", \"right\"]");
    assert!(p[0].value.contains("rigth"), "{p:?}");
    let p = problems_of(&text.replace(shipped, "wound = [\"left\", \"left\"]"));
    assert_single(&p, "wound", "two different [[tissue]] blocks");
}

#[test]
fn an_arm_held_tools_mount_and_the_pieces_rate_are_validated() {
    let arm = "\n[[arm]]\nname = \"PSM1\"\nbase_xyz = [0.0, 0.0, 0.14]\n\
               home_joints = [0.0, 0.0, 0.12, 0.0, 0.0, 0.0]\ntool = \"probe\"\n";
    let scene = config::from_str(&format!("{GOOD}{arm}"), Path::new("arm.toml")).unwrap();
    assert_eq!(scene.arms[0].tool_rpy_deg, [0.0; 3]);
    assert_eq!(scene.outputs.pieces_rate_hz, 5.0);
    let turned = format!("{GOOD}{arm}tool_rpy_deg = [180.0, 0.0, 0.0]\n");
    let scene = config::from_str(&turned, Path::new("arm.toml")).unwrap();
    assert_eq!(scene.arms[0].tool_rpy_deg, [180.0, 0.0, 0.0]);

    let bad =
        format!("{GOOD}{arm}tool_rpy_deg = [0.0, 1.0e9, 0.0]\n[outputs]\npieces_rate_hz = -1.0\n");
    let problems = problems_of(&bad);
    assert_eq!(problems.len(), 2, "{problems:#?}");
    let mount = problems
        .iter()
        .find(|p| p.key == "arm[0] (PSM1).tool_rpy_deg")
        .unwrap_or_else(|| panic!("{problems:#?}"));
    assert!(mount.allowed.contains("angles of at most"), "{mount:?}");
    assert!(mount.value.contains("1000000000"), "{mount:?}");
    let rate = problems
        .iter()
        .find(|p| p.key == "outputs.pieces_rate_hz")
        .unwrap_or_else(|| panic!("{problems:#?}"));
    assert!(rate.allowed.contains("0 (off) to 1000 Hz"), "{rate:?}");

    // A tool held 9 mm ahead of the jaw pivot is fine; 20 cm away is not a held tool.
    let ahead = format!("{GOOD}{arm}tool_xyz = [0.0, 0.0, 0.009]\n");
    let scene = config::from_str(&ahead, Path::new("arm.toml")).unwrap();
    assert_eq!(scene.arms[0].tool_xyz, [0.0, 0.0, 0.009]);
    let far = problems_of(&format!("{GOOD}{arm}tool_xyz = [0.0, 0.2, 0.0]\n"));
    assert_single(&far, "arm[0] (PSM1).tool_xyz", "at most ±0.05 m");
}

#[test]
fn a_thread_laid_along_points_is_valid_and_bad_polylines_are_refused() {
    let laid = |points: &str| {
        format!(
            "{GOOD}\n[[thread]]\nname = \"suture\"\npoints = {points}\nlength = 0.06\nsegments = 24\n"
        )
    };
    // An L on the table, 8 cm of polyline for 6 cm of thread: laid out, one segment apart.
    let good =
        laid("[[-0.03, 0.0, 0.006], [0.01, 0.0, 0.006], [0.01, 0.02, 0.006], [0.01, 0.04, 0.006]]");
    let scene = config::from_str(&good, Path::new("laid.toml")).unwrap_or_else(|e| panic!("{e}"));
    let line = scene.threads[0].centreline().unwrap();
    assert_eq!(line.len(), scene.threads[0].segments as usize + 1);
    assert_eq!(line[0], [-0.03, 0.0, 0.006]);
    for w in line.windows(2) {
        let d = (0..3)
            .map(|a| (w[1][a] - w[0][a]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!((d - 0.0025).abs() < 1e-12, "segment {d}");
    }
    // Past the corner it runs along +y.
    assert!(
        (line[24][0] - 0.01).abs() < 1e-12 && line[24][1] > 0.015,
        "{:?}",
        line[24]
    );
    let key = |k: &str| format!("thread[0] (suture).{k}");
    for (points, k, fragment) in [
        ("[[0.0, 0.0, 0.006]]", "points", "at least 2 points"),
        (
            "[[0.0, 0.0, 0.006], [0.5, 0.0, 0.006]]",
            "points[1]",
            "outside the domain",
        ),
        (
            "[[-0.03, 0.0, 0.006], [-0.03, 0.0, 0.006], [0.04, 0.0, 0.006]]",
            "points[1]",
            "zero length",
        ),
        // 4 cm of polyline cannot hold 6 cm of thread.
        (
            "[[-0.02, 0.0, 0.006], [0.02, 0.0, 0.006]]",
            "length",
            "0.0400 m long",
        ),
    ] {
        assert_single(&problems_of(&laid(points)), &key(k), fragment);
    }
    // `start` and `points` together, or neither.
    let both = laid("[[-0.03, 0.0, 0.006], [0.04, 0.0, 0.006]]")
        .replace("points =", "start = [-0.03, 0.0, 0.006]\npoints =");
    assert_single(
        &problems_of(&both),
        &key("start"),
        "one of `start`, `points`",
    );
    let neither = with_thread("").replace("start = [-0.03, 0.0, 0.006]\n", "");
    assert_single(
        &problems_of(&neither),
        &key("start"),
        "one of `start`, `points`",
    );
}

/// A flat 30 × 20 mm blade: spine (`l`) along the top, edge 20 mm below it.
const FLAT_BLADE: &str = "v -0.015 0 0\nv -0.015 0 -0.02\nv 0.015 0 0\nv 0.015 0 -0.02\n\
                          f 1 2 4 3\nl 1 3\n";

/// The good scene with a mesh slicer of `thickness` reading `blade.obj` beside the scene
/// file, in a fresh folder holding `obj` as that file (none when `None`); its problems.
fn mesh_slicer_problems(obj: Option<&str>, thickness: &str) -> Vec<config::Problem> {
    static FOLDERS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let n = FOLDERS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("mesh_slicer_check_{}_{n}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    if let Some(obj) = obj {
        std::fs::write(dir.join("blade.obj"), obj).unwrap();
    }
    let text = GOOD.replacen(
        r#"shape = { type = "sphere", radius = 0.005 }"#,
        &format!(
            r#"shape = {{ type = "mesh_slicer", file = "blade.obj", thickness = {thickness} }}"#
        ),
        1,
    );
    let result = config::from_str(&text, &dir.join("scene.toml"));
    std::fs::remove_dir_all(&dir).unwrap();
    match result {
        Ok(_) => Vec::new(),
        Err(SceneError::Invalid { problems, .. }) => problems,
        Err(other) => panic!("expected validation problems, got {other}"),
    }
}

#[test]
fn mesh_slicer_files_are_read_beside_the_scene_and_bad_ones_refused() {
    assert_eq!(mesh_slicer_problems(Some(FLAT_BLADE), "0.0004"), vec![]);
    let file_key = "tool[0] (probe).shape.file";
    let file_problem = |obj: Option<&str>, fragment: &str| {
        let p = mesh_slicer_problems(obj, "0.0004");
        assert_single(&p, file_key, fragment);
        assert_eq!(p[0].value, "\"blade.obj\"");
    };
    file_problem(None, "cannot read the blade mesh");
    // Malformed OBJ: the file and line.
    file_problem(Some("v 0 0\n"), "blade.obj:1: a vertex needs three");
    file_problem(Some("v 0 0 0\nl 1 1\n"), "no faces");
    file_problem(
        Some("v 0 0 0\nv 0.01 0 0\nv 0.02 0 0\nf 1 2 3\nl 1 2\n"),
        "blade.obj:4: degenerate face",
    );
    file_problem(Some(&FLAT_BLADE.replace("l 1 3\n", "")), "no spine");
    file_problem(
        Some(&FLAT_BLADE.replace("l 1 3", "l 1 4")),
        "blade.obj:6: spine segment 1–4 is not a boundary edge",
    );
    file_problem(
        Some(&FLAT_BLADE.replace("l 1 3", "l 1 3 4 2 1")),
        "no cutting edge",
    );
    // 3 mm long: less than 2·dx = 4 mm across.
    file_problem(
        Some(&FLAT_BLADE.replace("0.015", "0.0015")),
        "at least 2·dx = 0.004 m across",
    );
    // The spine's thickness: > 0, and at most half the blade's height (20 mm).
    let thickness_key = "tool[0] (probe).shape.thickness";
    let p = mesh_slicer_problems(Some(FLAT_BLADE), "-0.0001");
    assert_single(&p, thickness_key, "0 < thickness");
    let p = mesh_slicer_problems(Some(FLAT_BLADE), "0.015");
    assert_single(&p, thickness_key, "height/2 = 0.01 m");
}

#[test]
fn an_ecm_arm_is_validated_and_carries_the_camera() {
    let ecm = r#"
[[arm]]
name = "ECM"
kind = "ecm"
base_xyz = [0.0, -0.1, 0.12]
home_joints = [0.0, 0.0, 0.05, 0.0]
[camera]
resolution = [160, 120]
"#;
    let scene = config::from_str(&format!("{GOOD}{ecm}"), Path::new("ecm.toml")).unwrap();
    assert_eq!(scene.arms[0].kind, dvrk_tissue_sim::robot::ArmKind::Ecm);
    assert_eq!(scene.arms[0].urdf_path(), "urdf/ecm.urdf");
    assert_eq!(scene.arms[0].tool, None);

    // Six joints (a PSM's), a tool, a jaw, a mirror, a fixed camera position, two ECMs.
    let bad = ecm
        .replace(
            "[0.0, 0.0, 0.05, 0.0]",
            "[0.0, 0.0, 0.05, 0.0, 0.0, 0.0]\ntool = \"probe\"\nhome_jaw_deg = 30.0\njoint_speeds = [1.0, 1.0, 0.1, 1.0, 1.0, 1.0]\nmode = \"mirror\"",
        )
        .replace("[camera]", "[[arm]]\nname = \"ECM2\"\nkind = \"ecm\"\nbase_xyz = [0.0, 0.1, 0.12]\nhome_joints = [0.0, 0.0, 0.05, 0.0]\n[camera]\nposition = [0.0, 0.0, 0.1]\nlook_at = [0.0, 0.0, 0.0]");
    let problems = problems_of(&format!("{GOOD}{bad}"));
    let keys: Vec<&str> = problems.iter().map(|p| p.key.as_str()).collect();
    for key in [
        "arm[0] (ECM).home_joints",
        "arm[0] (ECM).tool",
        "arm[0] (ECM).home_jaw_deg",
        "arm[0] (ECM).joint_speeds",
        "arm[0] (ECM).mode",
        "arm[1] (ECM2).kind",
        "camera.position",
    ] {
        assert!(keys.contains(&key), "{key} not reported: {keys:?}");
    }
    let home = problems
        .iter()
        .find(|p| p.key.ends_with("home_joints"))
        .unwrap();
    assert!(home.allowed.contains("4 joint values"), "{}", home.allowed);

    // A PSM still needs its tool; a camera without an ECM still needs a position.
    let problems = problems_of(&format!(
        "{GOOD}\n[[arm]]\nname = \"PSM1\"\nbase_xyz = [0.0, 0.0, 0.14]\nhome_joints = [0.0, 0.0, 0.12, 0.0, 0.0, 0.0]\n[camera]\n"
    ));
    let keys: Vec<&str> = problems.iter().map(|p| p.key.as_str()).collect();
    assert!(keys.contains(&"arm[0] (PSM1).tool"), "{keys:?}");
    assert!(keys.contains(&"camera.position"), "{keys:?}");
}

/// The shipped scenes with tissue put the ECM where the surgeon's view shows the liver: the
/// scope's optical axis passes through the liver's top, from in front and above, with world
/// up at the top of the picture.
#[test]
fn shipped_scenes_point_the_ecm_at_the_liver() {
    use nalgebra::Vector3;
    for file in ["config/default.toml", "config/teleop.toml"] {
        let scene = config::load(Path::new(file)).unwrap();
        let index = scene
            .arms
            .iter()
            .position(|a| a.kind == dvrk_tissue_sim::robot::ArmKind::Ecm)
            .unwrap_or_else(|| panic!("{file}: no ECM"));
        let arm = &scene.arms[index];
        let ecm = dvrk_tissue_sim::sim::setup::load_psm(index, arm).unwrap();
        let view =
            dvrk_tissue_sim::sim::setup::arm_base(arm) * ecm.forward(&arm.home_joints).unwrap();
        let eye = view.translation.vector;
        let forward = view.rotation * Vector3::z();
        let down = view.rotation * Vector3::y();
        let tissue = &scene.tissues[0];
        let top = Vector3::new(
            tissue.center[0],
            tissue.center[1],
            tissue.center[2] + 0.5 * tissue.size[2],
        );
        let to_top = top - eye;
        let miss = (to_top - forward * to_top.dot(&forward)).norm();
        assert!(
            miss < 0.005,
            "{file}: optical axis {miss} m from the liver's top"
        );
        assert!(
            to_top.dot(&forward) > 0.05,
            "{file}: liver not in front of the scope"
        );
        assert!(
            forward.z < -0.5 && forward.y > 0.5,
            "{file}: looking {forward}"
        );
        assert!(
            down.z < -0.5 && down.x.abs() < 1e-3,
            "{file}: picture's down is {down}"
        );
    }
}
