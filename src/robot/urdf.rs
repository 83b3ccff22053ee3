//! Reading URDF files and giving a model's links the arm's name.
//!
//! Our URDFs are plain files for one arm (`PSM1`): links are prefixed (`PSM1_base`, `PSM1`,
//! `PSM1_tool_tip`), joints are not (`yaw`, `jaw`), as in dVRK. Rather than a placeholder that
//! would make the file unusable as-is in RViz or `check_urdf`, the loader renames the prefix for
//! another arm ([`rename_arm_prefix`]).
//!
//! # dVRK's own PSM URDFs
//!
//! The built-in `urdf/psm.urdf` (the classic PSM with the Large Needle Driver, written from
//! dVRK's modified-DH table) is the default. To use dVRK's own model (jhu-dvrk `dvrk_model`,
//! Classic or Si, current or older layout), point the scene's `[[arm]] urdf` at its
//! `.urdf.xacro` (or an expanded `.urdf`) and `dvrk_model` at the package folder. A
//! `.urdf.xacro` is expanded by the `xacro` command (`pip install xacro` works without ROS).
//! ROS 2's xacro resolves `$(find dvrk_model)` only through the ament index of a sourced
//! workspace; with `dvrk_model` set, the package's `.xacro` and `.urdf` files are copied to a
//! temporary folder with `$(find dvrk_model)` replaced by the copy's path and xacro runs on the
//! copy. Without `xacro` installed a `.urdf.xacro` path fails with a message saying how to
//! expand it. `check` loads the file as a run would and names the key, file and reason of a
//! problem.
//!
//! What is read from the file (`robot::Psm::from_urdf_with_roles`):
//! - **Base** (the remote centre of motion, `measured_cp`'s frame, published as `<arm>_base`
//!   whatever the file calls it): `base_link` if set, else `P_base` (ours), `P_base_link`
//!   (dvrk_model 2.x) or `P_psm_base_link` (older), with `P` the arm's name, else `PSM1`, else
//!   the file's only such prefix; but `P_RCM_link` wherever the tool hangs below it (in the Si
//!   files `P_base_link` is the arm's mounting, 0.8 m from the remote centre of motion). Links
//!   `P` / `P_*` are renamed for the arm, so a PSM1 file serves PSM2. Anything above the base is
//!   ignored: `base_xyz` places the base.
//! - **Tool frame** (`measured_cp`, dVRK's tool frame on the jaw pivot): `tool_link` if set;
//!   else our link `<arm>`; else dvrk_model's `<arm>_tool_tip_link` moved back 10.2 mm along
//!   its z with the same rotation.
//! - **Chain**: the path from base to tool through `yaw, pitch, insertion, roll, wrist_pitch,
//!   wrist_yaw`; the parallelogram's `pitch_2`… mimics count as `pitch` where the path runs
//!   through them, and side branches are not part of the chain.
//! - **Jaws**: anything below the wrist moved by `jaw` or its mimics (`jaw_1`, `jaw_2`).
//! - **Limits**: position limits are the file's. Speed limits are dVRK's arm configuration's
//!   (90°/s, 0.2 m/s, 1080°/s, jaw 720°/s), never the file's `velocity` (dvrk_model writes 0.4
//!   everywhere), unless the scene sets `joint_speeds` / `jaw_speed`; the log says which.
//! - **Meshes** are not read (kinematics only); the MTM and ECM URDFs are not loaded.
//!
//! Tested (`cargo test --release --test robot_kinematics -- --nocapture`): test URDFs in
//! dvrk_model's Classic layouts (`tests/urdf/`) give the tool frame of the built-in URDF and the
//! DH table within 1e-15 m over 2,000 random joint vectors; the Si layout, loaded as PSM1, PSM2
//! and PSM3, gives dVRK's Si DH table within 1.2e-15 m; a package in dvrk_model's layout
//! expanded with PyPI xacro 2.1 (nested `$(find)` includes) within 1e-6 m. The current
//! dvrk_model Si PSM2 loads and `check`s, but its pitch zero is not the Si DH table's (its tool
//! frame is up to 50.8 mm from the table's; comparing the file at pitch q with the table at
//! q + 0.1629 rad, the sum of its parallelogram origin pitches negated, leaves 4.4 mm): the
//! loader takes the file as it is.

use std::path::{Path, PathBuf};

/// The classic PSM with the Large Needle Driver, as shipped in `urdf/psm.urdf`.
pub const CLASSIC_PSM_URDF: &str = include_str!("../../urdf/psm.urdf");

/// The classic ECM with a straight scope, as shipped in `urdf/ecm.urdf`.
pub const CLASSIC_ECM_URDF: &str = include_str!("../../urdf/ecm.urdf");

/// The arm name our URDF files are written for; [`rename_arm_prefix`] replaces it.
pub const URDF_ARM_PREFIX: &str = "PSM1";

#[derive(Debug, thiserror::Error)]
/// Why a URDF could not be loaded.
pub enum UrdfError {
    #[error("cannot read URDF file {path}: {source}")]
    /// The file cannot be read.
    Read {
        /// The file's path.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    #[error("malformed URDF{}: {source}", .path.as_ref().map(|p| format!(" {}", p.display())).unwrap_or_default())]
    /// The URDF does not parse.
    Parse {
        /// The file's path (`None` for URDF text given directly).
        path: Option<PathBuf>,
        /// The parser's error.
        source: urdf_rs::UrdfError,
    },
    #[error(
        "malformed URDF{}: elements nest deeper than {MAX_XML_DEPTH} levels at line {line} (a \
         URDF needs five)",
        .path.as_ref().map(|p| format!(" {}", p.display())).unwrap_or_default()
    )]
    /// Elements nested deeper than [`MAX_XML_DEPTH`].
    TooDeep {
        /// The file's path (`None` for URDF text given directly).
        path: Option<PathBuf>,
        /// The line where the nesting passes the limit.
        line: usize,
    },
    #[error(
        "cannot expand {path}: the `{program}` command is not installed ({source}). Expand it \
         yourself, e.g. `xacro {path} > PSM1.urdf` (xacro from PyPI or ROS, with dvrk_model in a \
         sourced ROS workspace, or the scene's `dvrk_model` key set), and point `urdf =` at \
         the .urdf"
    )]
    /// A `.xacro` file, and the `xacro` command is not installed.
    XacroMissing {
        /// The `.xacro` file's path.
        path: PathBuf,
        /// The command tried.
        program: String,
        /// Why it could not be run.
        source: std::io::Error,
    },
    #[error("`xacro {path}` failed ({status}): {stderr}")]
    /// `xacro` ran and failed.
    XacroFailed {
        /// The `.xacro` file's path.
        path: PathBuf,
        /// Its exit status.
        status: std::process::ExitStatus,
        /// What it wrote to stderr.
        stderr: String,
    },
    #[error(
        "arm name `{0}` is not usable as a frame prefix: use letters, digits and `_`, \
         starting with a letter (e.g. `PSM2`)"
    )]
    /// An arm name unusable as a URDF prefix and topic name (holds it).
    InvalidArmName(String),
}

/// The deepest element nesting a URDF may have: a URDF nests five levels (`robot`, `link`,
/// `visual`, `geometry`, `mesh`); the XML parser recurses per level, so without a limit a
/// file of nested elements overflows the stack.
pub const MAX_XML_DEPTH: usize = 32;

/// The deepest element nesting in XML `text` and the line where it passes `limit`, if it
/// does (comments, processing instructions, declarations and CDATA are skipped; a scan of
/// the text, before any parser recursion).
fn nesting_over(text: &str, limit: usize) -> Option<usize> {
    let bytes = text.as_bytes();
    let mut depth = 0usize;
    let mut i = 0;
    while let Some(offset) = bytes[i..].iter().position(|&b| b == b'<') {
        let start = i + offset;
        let rest = &text[start..];
        let (end_marker, kind) = if rest.starts_with("<!--") {
            ("-->", 0)
        } else if rest.starts_with("<![CDATA[") {
            ("]]>", 0)
        } else if rest.starts_with("<?") || rest.starts_with("<!") {
            (">", 0)
        } else if rest.starts_with("</") {
            (">", -1)
        } else {
            (">", 1)
        };
        let Some(end) = rest.find(end_marker) else {
            return None; // unterminated: the parser names the fault
        };
        let tag = &rest[..end];
        match kind {
            1 if !tag.ends_with('/') => {
                depth += 1;
                if depth > limit {
                    return Some(text[..start].matches('\n').count() + 1);
                }
            }
            -1 => depth = depth.saturating_sub(1),
            _ => {}
        }
        i = start + end + end_marker.len();
    }
    None
}

fn parse(text: &str, path: Option<&Path>) -> Result<urdf_rs::Robot, UrdfError> {
    if let Some(line) = nesting_over(text, MAX_XML_DEPTH) {
        return Err(UrdfError::TooDeep {
            path: path.map(Path::to_owned),
            line,
        });
    }
    urdf_rs::read_from_string(text).map_err(|source| UrdfError::Parse {
        path: path.map(Path::to_owned),
        source,
    })
}

/// Parses URDF text.
pub fn parse_urdf(text: &str) -> Result<urdf_rs::Robot, UrdfError> {
    parse(text, None)
}

/// Reads and parses a URDF file (read and parse failures are told apart, with the path).
pub fn load_urdf_file(path: &Path) -> Result<urdf_rs::Robot, UrdfError> {
    load_urdf(path, None)
}

/// Reads and parses a URDF file, or a `.xacro` file expanded by the `xacro` command first
/// (see [`expand_xacro`]).
pub fn load_urdf(path: &Path, dvrk_model: Option<&Path>) -> Result<urdf_rs::Robot, UrdfError> {
    let text = if path.extension().is_some_and(|e| e == "xacro") {
        expand_xacro("xacro", path, dvrk_model)?
    } else {
        crate::files::read_regular(path).map_err(|source| UrdfError::Read {
            path: path.to_owned(),
            source,
        })?
    };
    parse(&text, Some(path))
}

/// Runs `program` (the `xacro` command) on `path` and returns the URDF it prints.
///
/// `$(find dvrk_model)`: with `dvrk_model` (the package's folder) given, the package's `.xacro`
/// and `.urdf` files (and `path`, when it lies outside the package) are copied to a
/// temporary folder with every `$(find dvrk_model)` replaced by that copy's path, and xacro
/// runs on the copy. ROS 1's xacro would find the package on ROS_PACKAGE_PATH, but ROS 2's
/// (the PyPI one among them) resolves `$(find)` through the ament index only, which a plain
/// folder is not in. Without `dvrk_model`, xacro resolves it itself (a sourced workspace).
pub fn expand_xacro(
    program: &str,
    path: &Path,
    dvrk_model: Option<&Path>,
) -> Result<String, UrdfError> {
    if !path.exists() {
        return Err(UrdfError::Read {
            path: path.to_owned(),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
        });
    }
    let copy = match dvrk_model {
        Some(package) => {
            Some(
                PackageCopy::new(package, path).map_err(|source| UrdfError::Read {
                    path: package.to_owned(),
                    source,
                })?,
            )
        }
        None => None,
    };
    let input = copy.as_ref().map_or(path, |c| c.input.as_path());
    let output = std::process::Command::new(program)
        .arg(input)
        .output()
        .map_err(|source| UrdfError::XacroMissing {
            path: path.to_owned(),
            program: program.to_owned(),
            source,
        })?;
    if !output.status.success() {
        return Err(UrdfError::XacroFailed {
            path: path.to_owned(),
            status: output.status,
            stderr: String::from_utf8_lossy(&output.stderr).trim().to_owned(),
        });
    }
    tracing::info!("expanded {} with {program}", path.display());
    Ok(String::from_utf8_lossy(&output.stdout).into_owned())
}

/// A temporary copy of a dvrk_model package's description files with `$(find dvrk_model)`
/// resolved to the copy, removed when dropped. The folder has an unpredictable name and is
/// created new (`tempfile`), so nothing planted in the temporary folder is written through.
struct PackageCopy {
    /// The copy's folder, held for its removal on drop.
    _folder: tempfile::TempDir,
    /// The file to expand, inside the copy.
    input: PathBuf,
}

const FIND_DVRK_MODEL: &str = "$(find dvrk_model)";

impl PackageCopy {
    fn new(package: &Path, input: &Path) -> std::io::Result<PackageCopy> {
        if !package.is_dir() {
            return Err(std::io::Error::new(
                std::io::ErrorKind::NotFound,
                "dvrk_model: not a folder",
            ));
        }
        let root = tempfile::Builder::new()
            .prefix("dvrk-tissue-sim-xacro-")
            .tempdir()?;
        let package_copy = root.path().join("dvrk_model");
        let mut copy = PackageCopy {
            input: root.path().join("input.urdf.xacro"),
            _folder: root,
        };
        copy_resolved(package, &package_copy, &package_copy)?;
        let package = package.canonicalize()?;
        let input = input.canonicalize()?;
        match input.strip_prefix(&package) {
            Ok(inside) => copy.input = package_copy.join(inside),
            Err(_) => {
                let text = std::fs::read_to_string(&input)?;
                std::fs::write(&copy.input, resolve_find(&text, &package_copy))?;
            }
        }
        Ok(copy)
    }
}

fn resolve_find(text: &str, package: &Path) -> String {
    text.replace(FIND_DVRK_MODEL, &package.to_string_lossy())
}

/// Copies the `.xacro` and `.urdf` files under `from` to `to` (meshes are not needed for
/// kinematics), resolving `$(find dvrk_model)` to `package`.
fn copy_resolved(from: &Path, to: &Path, package: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(to)?;
    for entry in std::fs::read_dir(from)? {
        let entry = entry?;
        let source = entry.path();
        let target = to.join(entry.file_name());
        if entry.file_type()?.is_dir() {
            copy_resolved(&source, &target, package)?;
        } else if source
            .extension()
            .is_some_and(|e| e == "xacro" || e == "urdf")
        {
            let text = std::fs::read_to_string(&source)?;
            std::fs::write(&target, resolve_find(&text, package))?;
        }
    }
    Ok(())
}

/// Checks that `name` can prefix ROS frame names.
pub fn check_arm_name(name: &str) -> Result<(), UrdfError> {
    let mut chars = name.chars();
    let starts_with_letter = chars.next().is_some_and(|c| c.is_ascii_alphabetic());
    if starts_with_letter && chars.all(|c| c.is_ascii_alphanumeric() || c == '_') {
        Ok(())
    } else {
        Err(UrdfError::InvalidArmName(name.to_owned()))
    }
}

/// `name` with the arm prefix `from` replaced by `to` when it is `from` or starts `from_`;
/// otherwise unchanged.
pub fn rename_link(name: &str, from: &str, to: &str) -> String {
    if name == from {
        return to.to_owned();
    }
    name.strip_prefix(from)
        .and_then(|rest| rest.strip_prefix('_'))
        .map_or_else(|| name.to_owned(), |rest| format!("{to}_{rest}"))
}

/// Renames every link `from` or `from_*` to `to` / `to_*`, in links and in the joints that name
/// them. Links without the prefix and joint names are left alone.
pub fn rename_arm_prefix(
    robot: &mut urdf_rs::Robot,
    from: &str,
    to: &str,
) -> Result<(), UrdfError> {
    check_arm_name(to)?;
    let rename = |name: &mut String| *name = rename_link(name, from, to);
    for link in &mut robot.links {
        rename(&mut link.name);
    }
    for joint in &mut robot.joints {
        rename(&mut joint.parent.link);
        rename(&mut joint.child.link);
    }
    Ok(())
}

/// How many visual and collision meshes the URDF names. Kinematics never reads them (they are
/// usually `package://` paths into a ROS package); the loader only says they were skipped.
pub fn mesh_count(robot: &urdf_rs::Robot) -> usize {
    let is_mesh = |g: &urdf_rs::Geometry| matches!(g, urdf_rs::Geometry::Mesh { .. });
    robot
        .links
        .iter()
        .map(|l| {
            l.visual.iter().filter(|v| is_mesh(&v.geometry)).count()
                + l.collision.iter().filter(|c| is_mesh(&c.geometry)).count()
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classic_psm_parses_with_expected_links() {
        let robot = parse_urdf(CLASSIC_PSM_URDF).unwrap();
        let links: Vec<&str> = robot.links.iter().map(|l| l.name.as_str()).collect();
        for expected in [
            "PSM1_base",
            "PSM1",
            "PSM1_tool_tip",
            "PSM1_jaw_1",
            "PSM1_jaw_2",
        ] {
            assert!(
                links.contains(&expected),
                "{expected} missing from {links:?}"
            );
        }
    }

    #[test]
    fn rename_changes_prefixed_links_only() {
        let mut robot = parse_urdf(CLASSIC_PSM_URDF).unwrap();
        rename_arm_prefix(&mut robot, URDF_ARM_PREFIX, "PSM2").unwrap();
        assert!(robot.links.iter().all(|l| l.name.starts_with("PSM2")));
        assert!(robot.links.iter().any(|l| l.name == "PSM2"));
        assert!(robot.links.iter().any(|l| l.name == "PSM2_base"));
        let yaw = robot.joints.iter().find(|j| j.name == "yaw").unwrap();
        assert_eq!(yaw.parent.link, "PSM2_base");
        assert_eq!(yaw.child.link, "PSM2_yaw_link");
    }

    #[test]
    fn rename_leaves_lookalike_names() {
        let mut robot = parse_urdf(
            r#"<robot name="r"><link name="PSM1"/><link name="PSM10_x"/><link name="PSM1_y"/></robot>"#,
        )
        .unwrap();
        rename_arm_prefix(&mut robot, "PSM1", "PSM3").unwrap();
        let names: Vec<&str> = robot.links.iter().map(|l| l.name.as_str()).collect();
        assert_eq!(names, ["PSM3", "PSM10_x", "PSM3_y"]);
    }

    #[test]
    fn bad_arm_names_are_rejected() {
        for bad in ["", "2PSM", "PSM 1", "PSM/1"] {
            assert!(
                matches!(check_arm_name(bad), Err(UrdfError::InvalidArmName(_))),
                "{bad:?}"
            );
        }
        check_arm_name("PSM2").unwrap();
    }

    #[test]
    fn xacro_without_the_command_says_how_to_expand_it() {
        let xacro = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/urdf/PSM1.urdf.xacro");
        let err = expand_xacro("dvrk-no-such-xacro", &xacro, None).unwrap_err();
        let message = err.to_string();
        assert!(matches!(err, UrdfError::XacroMissing { .. }), "{message}");
        for fragment in [
            "PSM1.urdf.xacro",
            "not installed",
            "xacro ",
            "point `urdf =`",
        ] {
            assert!(message.contains(fragment), "{message} lacks {fragment}");
        }
        let missing = expand_xacro("xacro", Path::new("/nonexistent/PSM1.urdf.xacro"), None);
        assert!(matches!(missing, Err(UrdfError::Read { .. })));
        // `false` stands for a xacro that fails.
        let package = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/urdf/dvrk_model");
        let failed = expand_xacro("false", &xacro, Some(&package));
        assert!(matches!(failed, Err(UrdfError::XacroFailed { .. })));
        // A dvrk_model folder that does not exist is named.
        let no_package = expand_xacro("false", &xacro, Some(Path::new("/nonexistent/dvrk_model")));
        assert!(
            matches!(&no_package, Err(UrdfError::Read { path, .. }) if path.ends_with("dvrk_model")),
            "{no_package:?}"
        );
    }

    #[test]
    fn malformed_and_missing_files_are_told_apart() {
        assert!(matches!(
            parse_urdf("<robot><link"),
            Err(UrdfError::Parse { .. })
        ));
        let missing = Path::new("/nonexistent/psm.urdf");
        assert!(matches!(
            load_urdf_file(missing),
            Err(UrdfError::Read { .. })
        ));
    }
}
