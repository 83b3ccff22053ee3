//! The scene a subcommand runs, and the command-line settings that override its file: one
//! place that loads a scene file and applies `--backend` / `--p2g`.

use anyhow::Result;
use clap::Args;
use dvrk_tissue_sim::config::{self, Scene};
use dvrk_tissue_sim::mpm::backend::{BackendChoice, P2gAtomics};
use serde::de::{value::StrDeserializer, DeserializeOwned, IntoDeserializer};
use std::path::Path;

/// Parses a command-line value by the name the scene file uses for it (`cpu`, `fixed`,
/// `volumetric`, ...), so that the two spell every choice alike.
pub fn scene_value<T: DeserializeOwned>(text: &str) -> Result<T, String> {
    let de: StrDeserializer<'_, serde::de::value::Error> = text.into_deserializer();
    T::deserialize(de).map_err(|e| e.to_string())
}

/// Solver settings that override the scene file's.
#[derive(Args, Clone, Debug, Default)]
pub struct SolverOverrides {
    /// Solver backend: `auto` (a hardware GPU if there is one, else the CPU), `gpu`
    /// (software adapters too) or `cpu`. Overrides the scene's `solver.backend`.
    #[arg(long, value_parser = scene_value::<BackendChoice>)]
    pub backend: Option<BackendChoice>,
    /// GPU P2G accumulation: `auto`, `float` (f32 atomics) or `fixed` (i32 fixed point).
    /// Overrides the scene's `solver.p2g_atomics`.
    #[arg(long, value_parser = scene_value::<P2gAtomics>)]
    pub p2g: Option<P2gAtomics>,
}

impl SolverOverrides {
    /// Loads and validates the scene at `path`, then applies these overrides.
    pub fn load(&self, path: &Path) -> Result<Scene> {
        let mut scene = config::load(path)?;
        self.apply(&mut scene);
        Ok(scene)
    }

    pub fn apply(&self, scene: &mut Scene) {
        if let Some(backend) = self.backend {
            scene.solver.backend = backend;
        }
        if let Some(p2g) = self.p2g {
            scene.solver.p2g_atomics = p2g;
        }
    }
}
