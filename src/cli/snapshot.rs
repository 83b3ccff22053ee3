//! `snapshot`: simulate a scene headless to a time and write a PNG picture of it.

use crate::scene_args::scene_value;
use anyhow::{Context, Result};
use clap::Args;
use dvrk_tissue_sim::config;
use dvrk_tissue_sim::output::snapshot::{self, SnapshotOptions};
use dvrk_tissue_sim::output::strain::StrainMeasure;
use dvrk_tissue_sim::world::World;
use std::path::PathBuf;

#[derive(Args)]
pub struct SnapshotArgs {
    #[arg(long, default_value = "config/default.toml")]
    scene: PathBuf,
    /// Simulated time of the picture (s).
    #[arg(long, default_value_t = 1.0)]
    time: f64,
    #[arg(long, default_value = "snapshot.png")]
    out: PathBuf,
    #[arg(long, default_value_t = 960)]
    width: u32,
    #[arg(long, default_value_t = 640)]
    height: u32,
    /// Camera azimuth about the scene, degrees from +x towards +y.
    #[arg(long, default_value_t = -60.0, allow_negative_numbers = true)]
    azimuth: f32,
    /// Camera elevation above the table plane, degrees.
    #[arg(long, default_value_t = 35.0)]
    elevation: f32,
    /// Colour by shape change (`equivalent` strain) or volume change (`volumetric`, J − 1).
    #[arg(long, default_value = "equivalent", value_parser = scene_value::<StrainMeasure>)]
    measure: StrainMeasure,
}

pub fn run(args: SnapshotArgs) -> Result<()> {
    let loaded = config::load(&args.scene)?;
    let mut world = World::try_new(&loaded)?;
    while world.time() < args.time - 1e-9 {
        world
            .step_frame()
            .context("simulating up to the snapshot time")?;
    }
    world.sync_particles();
    let options = SnapshotOptions {
        width: args.width,
        height: args.height,
        azimuth_deg: args.azimuth,
        elevation_deg: args.elevation,
        measure: args.measure,
        strain_range: None,
    };
    let picture = snapshot::render(&world, &options);
    picture
        .write_png(&args.out)
        .with_context(|| format!("writing {}", args.out.display()))?;
    println!(
        "{}: scene \"{}\" at t = {:.3} s, colour scale 0 … {:.3} ({:?} strain)",
        args.out.display(),
        loaded.name,
        world.time(),
        picture.strain_range,
        args.measure
    );
    if picture.cut_face_particles > 0 {
        println!(
            "cut faces: {} particles, the surface over them marked in {}",
            picture.cut_face_particles,
            if args.measure.is_signed() {
                "green"
            } else {
                "red"
            }
        );
    }
    Ok(())
}
