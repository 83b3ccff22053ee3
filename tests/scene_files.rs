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
    let bad = config::from_str(&scene("method = \"implicit\""), Path::new("m.toml"));
    let message = bad.unwrap_err().to_string();
    assert!(
        ["mls_mpm", "pb_mpm", "pic_mpm"]
            .iter()
            .all(|m| message.contains(m)),
        "{message}"
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
    assert_eq!(scene.arms[0].urdf, "urdf/psm.urdf");
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
    let mirror = arm.replace("tool = \"probe\"", "tool = \"probe\"\nmirror_of = \"PSM1\"");
    let problems = problems_of(&format!("{GOOD}{mirror}"));
    assert!(problems
        .iter()
        .any(|p| p.key.ends_with("mirror_of") && p.allowed.contains("mode = \"mirror\"")));
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
