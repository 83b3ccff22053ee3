//! Scene files: the serde model, loading, and validation with clear errors.

pub mod builders;
pub mod outputs;
mod scene;
pub mod thread;
mod validate;

pub use scene::{
    Arm, ArmMode, Domain, Hold, Keyframe, Material, Outputs, Scene, Solver, Table, TeleopSettings,
    Tissue, Tool, PB_MPM_DEFAULT_DT,
};
pub use thread::{PinnedEnds, Thread};
pub use validate::{validate, Problem};

use crate::tools::Shape;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{path}: cannot read scene file: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: not a valid scene file: {message}")]
    Parse { path: PathBuf, message: String },
    #[error("{path}: {} problem(s):\n{}", problems.len(), problems.iter().map(|p| format!("  {p}")).collect::<Vec<_>>().join("\n"))]
    Invalid {
        path: PathBuf,
        problems: Vec<Problem>,
    },
}

/// Parses scene text without semantic checks, and reads the files it names relative to
/// `path`'s folder (blade meshes; their problems are reported by [`validate`]).
pub fn parse(text: &str, path: &Path) -> Result<Scene, SceneError> {
    let scene: Scene = toml::from_str(text).map_err(|e| SceneError::Parse {
        path: path.to_owned(),
        message: e.to_string(),
    })?;
    let folder = path.parent().unwrap_or(Path::new(""));
    for tool in &scene.tools {
        if let Shape::MeshSlicer { file, .. } = tool.shape {
            file.load(folder);
        }
    }
    Ok(scene)
}

/// Parses and validates scene text.
pub fn from_str(text: &str, path: &Path) -> Result<Scene, SceneError> {
    let scene = parse(text, path)?;
    let problems = validate(&scene);
    if problems.is_empty() {
        Ok(scene)
    } else {
        Err(SceneError::Invalid {
            path: path.to_owned(),
            problems,
        })
    }
}

/// Reads, parses and validates a scene file.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
        path: path.to_owned(),
        source,
    })?;
    from_str(&text, path)
}
