//! The endoscope's optics: an ideal pinhole per eye, a rectified stereo pair a baseline
//! apart, and the ROS `CameraInfo` matrices (K, P) that describe them.
//!
//! Frames follow REP 103's optical convention: z forward, x right, y down. A pixel's
//! coordinates are OpenCV's (the centre of pixel (i, j) is at (i, j)), so a camera-frame
//! point (x, y, z) is drawn on pixel (round(fx·x/z + cx), round(fy·y/z + cy)).

use crate::math::Vec3;
use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion};
use serde::{Deserialize, Serialize};

/// `[camera]` in a scene file: the stereo endoscope camera.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSettings {
    /// Whether the node renders and publishes the camera (default true; it is off anyway on
    /// a machine without a GPU adapter).
    #[serde(default = "default_enabled")]
    pub enabled: bool,
    /// Width and height of one eye's image, pixels (16…4096 each).
    #[serde(default = "default_resolution")]
    pub resolution: [u32; 2],
    /// Horizontal field of view, degrees (10…150).
    #[serde(default = "default_hfov_deg")]
    pub hfov_deg: f64,
    /// Distance between the two eyes, m (0…0.1; 0 draws one eye only).
    #[serde(default = "default_baseline")]
    pub baseline: f64,
    /// Images per second of simulated time (0 < rate ≤ 240, and at most the scene's frame
    /// rate).
    #[serde(default = "default_rate_hz")]
    pub rate_hz: f64,
    /// Near and far clipping distances, m (0 < near < far ≤ 1000).
    #[serde(default = "default_clip")]
    pub clip: [f64; 2],
    /// The camera's position, world frame, m (required by `check`: no ECM arm carries one yet).
    #[serde(default)]
    pub position: Option<[f64; 3]>,
    /// The point a fixed camera looks at, world frame, m (needed with `position`).
    #[serde(default)]
    pub look_at: Option<[f64; 3]>,
    /// What the tissue is coloured by: `tissue` (one tissue colour) or `strain` (the measure
    /// of the scene's `outputs.points_scalar`).
    #[serde(default)]
    pub colour: TissueColour,
    /// What a bag (`run --record`) keeps of the camera: `compressed` (the JPEG stereo image
    /// and both CameraInfos), `raw` (the rgb8 image, each eye's depth and labels, and both
    /// CameraInfos) or `off`.
    #[serde(default)]
    pub record: CameraRecord,
}

/// What a bag keeps of the camera's pictures.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CameraRecord {
    /// No picture: the bag holds the state the pictures are drawn from, and `--replay`
    /// draws them again.
    Off,
    /// `ECM/image_raw/compressed` (JPEG) and both eyes' `camera_info`.
    #[default]
    Compressed,
    /// `ECM/image_raw` (rgb8), each eye's `depth` and `labels`, and both `camera_info`s.
    Raw,
}

/// How the renderer colours the tissue.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TissueColour {
    /// One tissue colour, shaded.
    #[default]
    Tissue,
    /// The strain colour map of `outputs.points_scalar`'s measure.
    Strain,
}

fn default_enabled() -> bool {
    true
}
fn default_resolution() -> [u32; 2] {
    [1280, 720]
}
fn default_hfov_deg() -> f64 {
    60.0
}
fn default_baseline() -> f64 {
    0.006
}
fn default_rate_hz() -> f64 {
    30.0
}
fn default_clip() -> [f64; 2] {
    [0.005, 10.0]
}

impl Default for CameraSettings {
    fn default() -> Self {
        CameraSettings {
            enabled: default_enabled(),
            resolution: default_resolution(),
            hfov_deg: default_hfov_deg(),
            baseline: default_baseline(),
            rate_hz: default_rate_hz(),
            clip: default_clip(),
            position: None,
            look_at: None,
            colour: TissueColour::default(),
            record: CameraRecord::default(),
        }
    }
}

/// A camera setting out of range: the key, its value and why.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("camera.{key} = {value}: {reason}")]
pub struct CameraError {
    /// The key under `[camera]`.
    pub key: &'static str,
    /// The value as written.
    pub value: String,
    /// What is wrong with it.
    pub reason: String,
}

impl CameraSettings {
    /// Every problem with these settings for a scene stepped at `frame_rate_hz`.
    pub fn problems(&self, frame_rate_hz: f64) -> Vec<CameraError> {
        let mut out = Vec::new();
        let mut check = |ok: bool, key: &'static str, value: String, reason: &str| {
            if !ok {
                out.push(CameraError {
                    key,
                    value,
                    reason: reason.into(),
                });
            }
        };
        let [w, h] = self.resolution;
        check(
            (16..=4096).contains(&w) && (16..=4096).contains(&h),
            "resolution",
            format!("[{w}, {h}]"),
            "width and height must each be 16 to 4096 pixels",
        );
        check(
            (10.0..=150.0).contains(&self.hfov_deg),
            "hfov_deg",
            self.hfov_deg.to_string(),
            "the horizontal field of view must be 10 to 150 degrees",
        );
        check(
            (0.0..=0.1).contains(&self.baseline),
            "baseline",
            self.baseline.to_string(),
            "the baseline must be 0 to 0.1 m",
        );
        check(
            self.rate_hz > 0.0 && self.rate_hz <= 240.0 && self.rate_hz <= frame_rate_hz + 1e-9,
            "rate_hz",
            self.rate_hz.to_string(),
            &format!(
                "the rate must be above 0 and at most 240 Hz and the scene's frame rate \
                 ({frame_rate_hz} Hz)"
            ),
        );
        let [near, far] = self.clip;
        check(
            near > 0.0 && near < far && far <= 1000.0,
            "clip",
            format!("[{near}, {far}]"),
            "near and far must satisfy 0 < near < far <= 1000 m",
        );
        let finite = |p: &Option<[f64; 3]>| p.is_none_or(|p| p.iter().all(|c| c.is_finite()));
        check(
            finite(&self.position) && finite(&self.look_at),
            "position",
            format!("{:?} looking at {:?}", self.position, self.look_at),
            "coordinates must be finite",
        );
        check(
            self.position.is_some() == self.look_at.is_some(),
            "look_at",
            format!("{:?}", self.look_at),
            "a fixed camera needs both position and look_at",
        );
        if let (Some(p), Some(q)) = (self.position, self.look_at) {
            let d = (Vec3::from(q.map(|c| c as f32)) - Vec3::from(p.map(|c| c as f32))).norm();
            check(
                d > 1e-6,
                "look_at",
                format!("{q:?}"),
                "must differ from position",
            );
        }
        out
    }

    /// The pinhole of one eye.
    pub fn pinhole(&self) -> Pinhole {
        Pinhole::from_hfov(
            self.resolution[0],
            self.resolution[1],
            self.hfov_deg.to_radians(),
            self.clip[0] as f32,
            self.clip[1] as f32,
        )
    }

    /// The fixed camera's pose (world from the rig's optical frame), when the scene places one.
    pub fn fixed_pose(&self) -> Option<Isometry3<f32>> {
        let (p, q) = (self.position?, self.look_at?);
        Some(look_at(
            Vec3::from(p.map(|c| c as f32)),
            Vec3::from(q.map(|c| c as f32)),
        ))
    }
}

/// The optical frame at `eye` looking at `target` with the world's +z up in the picture
/// (world from optical: z forward, x right, y down).
pub fn look_at(eye: Vec3, target: Vec3) -> Isometry3<f32> {
    let forward = (target - eye).normalize();
    let up = if forward.cross(&Vec3::z()).norm() > 1e-3 {
        Vec3::z()
    } else {
        Vec3::y()
    };
    let right = forward.cross(&up).normalize();
    let down = forward.cross(&right);
    let r = Matrix3::from_columns(&[right, down, forward]);
    Isometry3::from_parts(
        Translation3::from(eye),
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r)),
    )
}

/// An ideal pinhole camera with square pixels and no distortion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pinhole {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Focal length, pixels (the same along x and y).
    pub focal: f32,
    /// Principal point x, pixels.
    pub cx: f32,
    /// Principal point y, pixels.
    pub cy: f32,
    /// Near clipping distance, m.
    pub near: f32,
    /// Far clipping distance, m.
    pub far: f32,
}

impl Pinhole {
    /// A pinhole of `width` × `height` pixels whose image spans `hfov` (rad) horizontally:
    /// f = (width/2)/tan(hfov/2), principal point at the image centre.
    pub fn from_hfov(width: u32, height: u32, hfov: f64, near: f32, far: f32) -> Pinhole {
        Pinhole {
            width,
            height,
            focal: (0.5 * width as f64 / (0.5 * hfov).tan()) as f32,
            cx: 0.5 * width as f32,
            cy: 0.5 * height as f32,
            near,
            far,
        }
    }

    /// Pixel coordinates (OpenCV's) of a camera-frame point; `None` behind the camera.
    pub fn project(&self, p: Vec3) -> Option<[f32; 2]> {
        (p.z > 0.0).then(|| {
            [
                self.focal * p.x / p.z + self.cx,
                self.focal * p.y / p.z + self.cy,
            ]
        })
    }

    /// CameraInfo's K, row-major.
    pub fn k(&self) -> [f64; 9] {
        let (f, cx, cy) = (self.focal as f64, self.cx as f64, self.cy as f64);
        [f, 0.0, cx, 0.0, f, cy, 0.0, 0.0, 1.0]
    }

    /// CameraInfo's P, row-major, for an eye `offset` m to the right of the left eye of a
    /// rectified pair: Tx = −f·offset (0 for the left eye).
    pub fn p(&self, offset: f64) -> [f64; 12] {
        let (f, cx, cy) = (self.focal as f64, self.cx as f64, self.cy as f64);
        [f, 0.0, cx, -f * offset, 0.0, f, cy, 0.0, 0.0, 0.0, 1.0, 0.0]
    }
}

/// One eye of the rig: its optical frame and pinhole.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Eye {
    /// World from this eye's optical frame.
    pub pose: Isometry3<f32>,
    /// Its optics.
    pub pinhole: Pinhole,
}

/// The eyes of a rig whose optical frame (its centre, between the eyes) is `rig` in the
/// world: the left eye `baseline`/2 to the rig's −x, the right eye `baseline`/2 to its +x;
/// one eye at the rig's centre when the baseline is 0.
pub fn stereo_eyes(rig: &Isometry3<f32>, pinhole: Pinhole, baseline: f32) -> Vec<Eye> {
    if baseline <= 0.0 {
        return vec![Eye {
            pose: *rig,
            pinhole,
        }];
    }
    [-0.5 * baseline, 0.5 * baseline]
        .into_iter()
        .map(|dx| Eye {
            pose: rig * Translation3::new(dx, 0.0, 0.0),
            pinhole,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_dvrk_simulators_and_k_has_the_reference_focal_length() {
        let s = CameraSettings::default();
        assert!(s.problems(60.0).is_empty());
        let p = s.pinhole();
        // (1280/2)/tan(30°) = 1108.51 px.
        assert!((p.focal - 1108.51).abs() < 0.01, "{}", p.focal);
        assert_eq!(p.k()[2], 640.0);
        assert!((p.p(0.006)[3] + 1108.51 * 0.006).abs() < 1e-3);
        assert_eq!(p.p(0.0)[3], 0.0);
    }

    #[test]
    fn out_of_range_settings_name_their_key() {
        let bad = CameraSettings {
            resolution: [8, 720],
            hfov_deg: 170.0,
            baseline: -0.001,
            rate_hz: 100.0,
            clip: [0.0, 1.0],
            position: Some([0.0, 0.0, 0.1]),
            ..Default::default()
        };
        let keys: Vec<&str> = bad.problems(60.0).iter().map(|e| e.key).collect();
        assert_eq!(
            keys,
            [
                "resolution",
                "hfov_deg",
                "baseline",
                "rate_hz",
                "clip",
                "look_at"
            ]
        );
        let msg = bad.problems(60.0)[3].to_string();
        assert!(
            msg.contains("camera.rate_hz = 100") && msg.contains("60 Hz"),
            "{msg}"
        );
    }

    #[test]
    fn look_at_puts_the_target_on_the_optical_axis_with_world_up_up() {
        let pose = look_at(Vec3::new(0.1, 0.0, 0.1), Vec3::zeros());
        let target = pose.inverse_transform_point(&Vec3::zeros().into());
        assert!(target.x.abs() < 1e-6 && target.y.abs() < 1e-6 && target.z > 0.0);
        // A point above the target is drawn higher up the picture (smaller y).
        let above = pose.inverse_transform_point(&Vec3::new(0.0, 0.0, 0.01).into());
        assert!(above.y < 0.0);
    }
}
