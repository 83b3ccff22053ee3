//! The camera's cost on a scene with a `[camera]`: the time of one stereo frame (the
//! scene's triangles, the render with RGB, depth and labels and its readback, the JPEG) at
//! a few resolutions, and the simulation's frame rate with the camera subscribed against
//! unsubscribed, and recorded to a bag with the pictures against without. On the GPU
//! backend: a camera frame with the tissue drawn from the solver's buffers against one
//! drawn from the positions read back to the host.

use anyhow::{bail, Result};
use dvrk_tissue_sim::config::Scene;
use dvrk_tissue_sim::mpm::backend::BackendChoice;
use dvrk_tissue_sim::render::camera::stereo_eyes;
use dvrk_tissue_sim::render::CameraRecord;
use dvrk_tissue_sim::render::{CameraImages, CameraRig, Renderer, SceneGeometry};
use dvrk_tissue_sim::ros::camera::{compressed_message, COMPRESSED_TOPIC};
use dvrk_tissue_sim::ros::outputs::OutputLayout;
use dvrk_tissue_sim::ros::recorder::Recorder;
use dvrk_tissue_sim::sim::frame_loop::{endoscope_pose, FrameLoop, Wanted};
use dvrk_tissue_sim::sim::setup::build_setup;
use dvrk_tissue_sim::world::World;
use std::fmt::Write;
use std::time::Instant;

/// Per-eye resolutions timed.
pub const RESOLUTIONS: [[u32; 2]; 3] = [[320, 240], [640, 360], [1280, 720]];

pub struct Row {
    resolution: [u32; 2],
    triangles: usize,
    geometry_ms: f64,
    render_ms: f64,
    jpeg_ms: f64,
}

pub struct CameraBench {
    scene: String,
    adapter: String,
    rows: Vec<Row>,
    /// Frames per second of the simulation (paced off) unsubscribed, subscribed, recorded
    /// without pictures (`camera.record = "off"`) and recorded with JPEG pictures.
    fps: [f64; 4],
    /// The camera frames the subscribed run rendered, and the pictures the second recorded
    /// run's bag holds.
    rendered: usize,
    recorded: u64,
    frames: u32,
    /// On the GPU backend at the scene's camera settings: ms per picture and per
    /// simulation frame with the tissue drawn from the host and in place, or why not
    /// measured.
    in_place: Result<[[f64; 2]; 2], String>,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

pub fn run(scene: &Scene, frames: u32) -> Result<CameraBench> {
    let Some(camera) = scene.camera.clone() else {
        bail!("the scene has no [camera]");
    };
    // A fixed camera, else where the scene's ECM holds it at home.
    let pose = match camera.fixed_pose() {
        Some(pose) => pose,
        None => match endoscope_pose(&build_setup(scene)?) {
            Some(pose) => pose,
            None => bail!("the scene's camera has no position and no ECM carries it"),
        },
    };
    let world = World::try_new(scene)?;
    let mut renderer = Renderer::new()?;
    let mut geometry = SceneGeometry::new(&world, None)?;
    let mut rows = Vec::new();
    for resolution in RESOLUTIONS {
        let mut settings = camera.clone();
        settings.resolution = resolution;
        let eyes = stereo_eyes(&pose, settings.pinhole(), settings.baseline as f32);
        let (mut g, mut r, mut j) = (Vec::new(), Vec::new(), Vec::new());
        let mut triangles = 0;
        // One warm-up frame (pipeline and target creation) before the timed ones.
        for k in 0..=frames {
            let t0 = Instant::now();
            let tris = geometry.triangles(&world);
            let t1 = Instant::now();
            let frame = renderer.render(&tris.vertices, &eyes)?;
            let t2 = Instant::now();
            let images = CameraImages {
                time: 0.0,
                frame,
                eyes: eyes.clone(),
                baseline: settings.baseline,
            };
            compressed_message(&images).map_err(anyhow::Error::msg)?;
            let t3 = Instant::now();
            if k > 0 {
                g.push((t1 - t0).as_secs_f64() * 1e3);
                r.push((t2 - t1).as_secs_f64() * 1e3);
                j.push((t3 - t2).as_secs_f64() * 1e3);
            }
            triangles = tris.vertices.len() / 3;
        }
        rows.push(Row {
            resolution,
            triangles,
            geometry_ms: median(g),
            render_ms: median(r),
            jpeg_ms: median(j),
        });
    }
    let mut fps = [0.0; 4];
    let mut rendered = 0;
    let mut recorded = 0;
    let runs = [
        (false, None),
        (true, None),
        (false, Some(CameraRecord::Off)),
        (false, Some(CameraRecord::Compressed)),
    ];
    let bag = std::env::temp_dir().join(format!("dts-bench-camera-{}.mcap", std::process::id()));
    for (k, (subscribed, record)) in runs.into_iter().enumerate() {
        let mut scene = scene.clone();
        if let (Some(camera), Some(record)) = (&mut scene.camera, record) {
            camera.record = record;
        }
        let mut setup = build_setup(&scene)?;
        setup.paced = false;
        // Recorded as `run --record` does, every frame kept (the writer's JPEG work counts).
        let recorder = match record {
            Some(_) => {
                let layout = OutputLayout::new(&scene, &setup, "/");
                let (recorder, mut tap) = Recorder::create(&bag, layout, 1.0, true)?;
                tap.wait_when_behind();
                setup.recorder = Some(Box::new(tap));
                Some(recorder)
            }
            None => None,
        };
        let mut frame_loop = FrameLoop::new(setup, None);
        let wanted = Wanted {
            camera: subscribed,
            ..Default::default()
        };
        let start = Instant::now();
        for _ in 0..frames {
            let (finished, _) = frame_loop.step([], wanted, None, |_| {});
            let frame = frame_loop.finish(finished);
            rendered += (subscribed && frame.camera.is_some()) as usize;
        }
        drop(frame_loop);
        if let Some(recorder) = recorder {
            recorder.finish()?;
            if record == Some(CameraRecord::Compressed) {
                recorded = count_pictures(&bag)?;
            }
        }
        fps[k] = frames as f64 / start.elapsed().as_secs_f64();
    }
    std::fs::remove_file(&bag).ok();
    let in_place = in_place_against_host(scene, pose, frames).map_err(|e| format!("{e:#}"));
    Ok(CameraBench {
        scene: scene.name.clone(),
        adapter: renderer.adapter.clone(),
        rows,
        fps,
        rendered,
        recorded,
        frames,
        in_place,
    })
}

/// On the GPU backend: median ms of a camera picture (the scene's triangles, the render
/// and its readback) and of a simulation frame, with the tissue drawn from the host (first,
/// before the solver builds a surface for the camera) and from the solver's buffers.
fn in_place_against_host(
    scene: &Scene,
    pose: nalgebra::Isometry3<f32>,
    frames: u32,
) -> Result<[[f64; 2]; 2]> {
    let mut scene = scene.clone();
    scene.solver.backend = BackendChoice::Gpu;
    let mut world = World::try_new(&scene)?;
    let mut out = [[0.0; 2]; 2];
    for (k, in_place) in [false, true].into_iter().enumerate() {
        let Some(mut rig) = CameraRig::for_world(&world) else {
            bail!("the camera cannot run on this scene");
        };
        rig.set_pose(pose);
        rig.set_in_place(in_place);
        // The first picture opens the device; in place, the solver builds the surface from
        // the next frame on.
        rig.render(&mut world)?;
        let (mut pictures, mut steps) = (Vec::new(), Vec::new());
        for _ in 0..frames.max(1) {
            let start = Instant::now();
            world.step_frame()?;
            steps.push(start.elapsed().as_secs_f64() * 1e3);
            let start = Instant::now();
            rig.render(&mut world)?;
            pictures.push(start.elapsed().as_secs_f64() * 1e3);
        }
        if rig.drew_in_place() != in_place {
            bail!("the tissue cannot be drawn in place here (coloured by strain)");
        }
        out[k] = [median(pictures), median(steps)];
    }
    Ok(out)
}

/// The JPEG pictures in `bag`.
fn count_pictures(bag: &std::path::Path) -> Result<u64> {
    let bytes = std::fs::read(bag)?;
    let mut pictures = 0;
    for message in mcap::MessageStream::new(&bytes)? {
        pictures += (message?.channel.topic == format!("/{COMPRESSED_TOPIC}")) as u64;
    }
    Ok(pictures)
}

impl CameraBench {
    pub fn table(&self) -> String {
        let mut s = format!(
            "Stereo camera on `{}`, {}: median of {} frames (RGB, depth and labels, both eyes \
             side by side)\n\n",
            self.scene, self.adapter, self.frames
        );
        s +=
            "| per eye | triangles | scene triangles (ms) | render + readback (ms) | JPEG (ms) |\n";
        s += "|---|---|---|---|---|\n";
        for r in &self.rows {
            let _ = writeln!(
                s,
                "| {} × {} | {} | {:.2} | {:.1} | {:.1} |",
                r.resolution[0],
                r.resolution[1],
                r.triangles,
                r.geometry_ms,
                r.render_ms,
                r.jpeg_ms
            );
        }
        let _ = write!(
            s,
            "\nSimulation, {} frames as fast as they compute, at the scene's camera settings:\n\n\
             | run | frames/s | pictures |\n|---|---|---|\n\
             | unsubscribed | {:.1} | 0 |\n\
             | subscribed | {:.1} | {} rendered |\n\
             | recorded, `camera.record = \"off\"` | {:.1} | 0 |\n\
             | recorded, `camera.record = \"compressed\"` | {:.1} | {} in the bag |\n",
            self.frames,
            self.fps[0],
            self.fps[1],
            self.rendered,
            self.fps[2],
            self.fps[3],
            self.recorded
        );
        let _ = match &self.in_place {
            Ok([host, in_place]) => write!(
                s,
                "\nGPU backend at the scene's camera settings, median of {} frames each \
                 followed by a picture (its triangles, render and readback; in place the \
                 solver builds the tissue's surface at the end of each frame):\n\n\
                 | tissue drawn from | ms per picture | ms per simulation frame |\n\
                 |---|---|---|\n\
                 | positions read back to the host | {:.2} | {:.2} |\n\
                 | the solver's buffers (in place) | {:.2} | {:.2} |\n",
                self.frames, host[0], host[1], in_place[0], in_place[1]
            ),
            Err(why) => write!(
                s,
                "\nGPU backend in place against host: not measured ({why})\n"
            ),
        };
        s
    }
}
