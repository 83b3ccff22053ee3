//! A scene's camera while the simulation runs: where it is, when a frame is due (its rate in
//! simulated time) and the renderer that draws it.

use super::camera::{stereo_eyes, CameraSettings, Eye, TissueColour};
use super::geometry::SceneGeometry;
use super::gpu::{Frame, RenderError, Renderer};
use crate::world::World;
use nalgebra::Isometry3;

/// One camera frame: both eyes' images, when and from where they were taken.
#[derive(Clone, Debug)]
pub struct CameraImages {
    /// Simulated time of the picture (s).
    pub time: f64,
    /// The images, eyes side by side.
    pub frame: Frame,
    /// The eyes, left first (one when the baseline is 0).
    pub eyes: Vec<Eye>,
    /// Distance between the eyes, m.
    pub baseline: f64,
}

/// The camera of a running scene.
pub struct CameraRig {
    settings: CameraSettings,
    pose: Isometry3<f32>,
    /// Opened at the first picture, so a run nobody watches opens no device.
    renderer: Option<Renderer>,
    geometry: SceneGeometry,
    /// Simulated time from which the next frame is due (s); the first frame asked is.
    next: f64,
}

impl CameraRig {
    /// The camera `world`'s scene asks for, or `None` (with one log line saying why) when it
    /// asks for none, or it cannot run: no GPU adapter at all, no surface mesh. The device is
    /// opened at the first picture (see [`CameraRig::render`]).
    pub fn for_world(world: &World) -> Option<CameraRig> {
        let scene = world.scene();
        let settings = scene.camera.clone().filter(|c| c.enabled)?;
        let on_ecm = scene
            .arms
            .iter()
            .any(|a| a.kind == crate::robot::ArmKind::Ecm);
        // On an ECM the frame loop sets the pose before each picture.
        let pose = match on_ecm {
            true => Isometry3::identity(),
            false => settings.fixed_pose()?,
        };
        let strain =
            (settings.colour == TissueColour::Strain).then_some(scene.outputs.points_scalar);
        let geometry = match SceneGeometry::new(world, strain) {
            Ok(g) => g,
            Err(e) => {
                tracing::warn!("camera off: the tissue surface cannot be built: {e}");
                return None;
            }
        };
        let Some(adapter) = crate::mpm::gpu::adapter::adapters().into_iter().next() else {
            tracing::warn!("camera off: {}", RenderError::NoAdapter);
            return None;
        };
        tracing::info!(
            "camera: {} × {} per eye, {}° wide, baseline {} m, {} Hz, on \"{}\" while subscribed or recorded",
            settings.resolution[0],
            settings.resolution[1],
            settings.hfov_deg,
            settings.baseline,
            settings.rate_hz,
            adapter.get_info().name
        );
        Some(CameraRig {
            settings,
            pose,
            renderer: None,
            geometry,
            next: f64::NEG_INFINITY,
        })
    }

    /// Moves the camera: `pose` is its left-right centre's optical frame in the world (z
    /// forward, x right, y down), e.g. the ECM's tool frame.
    pub fn set_pose(&mut self, pose: Isometry3<f32>) {
        self.pose = pose;
    }

    /// Where the camera is: its left-right centre's optical frame in the world.
    pub fn pose(&self) -> &Isometry3<f32> {
        &self.pose
    }

    /// The camera's settings.
    pub fn settings(&self) -> &CameraSettings {
        &self.settings
    }

    /// The eyes as they are now, left first.
    pub fn eyes(&self) -> Vec<Eye> {
        stereo_eyes(
            &self.pose,
            self.settings.pinhole(),
            self.settings.baseline as f32,
        )
    }

    /// Whether a frame ending at simulated time `t` takes a picture (at most `rate_hz` in
    /// simulated time); claims it when so.
    pub fn due(&mut self, t: f64) -> bool {
        if t + 1e-9 < self.next {
            return false;
        }
        let period = 1.0 / self.settings.rate_hz;
        self.next += period;
        // At the first picture, and after a pause (no subscriber), the schedule starts
        // again from now.
        if self.next <= t {
            self.next = t + period;
        }
        true
    }

    /// Draws `world` as it is now (opening the device the first time).
    pub fn render(&mut self, world: &World) -> Result<CameraImages, RenderError> {
        if self.renderer.is_none() {
            self.renderer = Some(Renderer::new()?);
        }
        let triangles = self.geometry.triangles(world);
        let eyes = self.eyes();
        let renderer = self.renderer.as_mut().expect("opened above");
        let frame = renderer.render(&triangles.vertices, &eyes)?;
        Ok(CameraImages {
            time: world.time(),
            frame,
            eyes,
            baseline: self.settings.baseline,
        })
    }
}
