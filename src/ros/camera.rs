//! The endoscope's topics, as dVRK's ROS 2 simulators name them, and their messages built
//! from a camera frame. Each is encoded only while someone subscribes to it (a bag's
//! pictures are encoded on the recorder's thread, [`crate::ros::recorder`]).
//!
//! | topic | type | content |
//! |---|---|---|
//! | `ECM/image_raw` | sensor_msgs/Image | both eyes side by side (left on the left), `rgb8` |
//! | `ECM/image_raw/compressed` | sensor_msgs/CompressedImage | the same as JPEG (quality 90) |
//! | `ECM/left/camera_info`, `ECM/right/camera_info` | sensor_msgs/CameraInfo | K, P (right: Tx = −f·b), `plumb_bob` with D zero |
//! | `ECM/left/depth`, `ECM/right/depth` | sensor_msgs/Image | `32FC1`, camera-frame z in m, NaN where nothing was drawn |
//! | `ECM/left/labels`, `ECM/right/labels` | sensor_msgs/Image | `mono8`: 0 nothing, 1 table, 10 + i tissue i, 50 + i thread i, 100 + i tool i |
//!
//! Frames: `ECM_left_optical_frame` and `ECM_right_optical_frame` (REP 103 optical
//! frames), on `/tf_static` under the ECM's tool frame `ECM` where an ECM holds the camera
//! (the camera is fixed at its tip) or under `world` for a camera the scene places; the
//! side-by-side images are in the left eye's. Stamps are the simulated time of the picture.

use nalgebra::Isometry3;

use crate::render::camera::stereo_eyes;
use crate::render::{CameraImages, Frame, Pinhole};
use crate::ros::msgs::{
    CameraInfo, CompressedImage, Header, Image, RegionOfInterest, Time, TransformStamped,
};

/// The side-by-side RGB image.
pub const IMAGE_TOPIC: &str = "ECM/image_raw";
/// The side-by-side image as JPEG.
pub const COMPRESSED_TOPIC: &str = "ECM/image_raw/compressed";
/// JPEG quality of [`COMPRESSED_TOPIC`] (1…100).
pub const JPEG_QUALITY: u8 = 90;
/// The eyes' names, left first, as they appear in topics and frames.
pub const EYES: [&str; 2] = ["left", "right"];

/// `ECM/<eye>/camera_info`.
pub fn info_topic(eye: &str) -> String {
    format!("ECM/{eye}/camera_info")
}

/// `ECM/<eye>/depth`.
pub fn depth_topic(eye: &str) -> String {
    format!("ECM/{eye}/depth")
}

/// `ECM/<eye>/labels`.
pub fn labels_topic(eye: &str) -> String {
    format!("ECM/{eye}/labels")
}

/// The optical frame of `eye`.
pub fn optical_frame(eye: &str) -> String {
    format!("ECM_{eye}_optical_frame")
}

/// The eyes' optical frames under `parent`, for `/tf_static`: `rig` is the rig's centre in
/// `parent` (identity under the ECM's tool frame, the scene's pose under `world`), and the
/// eyes sit where [`stereo_eyes`] puts them for the renderer, so a pixel's ray and tf agree.
pub fn optical_frame_transforms(
    parent: &str,
    rig: &Isometry3<f32>,
    pinhole: Pinhole,
    baseline: f32,
) -> Vec<TransformStamped> {
    stereo_eyes(rig, pinhole, baseline)
        .iter()
        .zip(EYES)
        .map(|(eye, name)| TransformStamped {
            header: Header::new(Time::default(), parent),
            child_frame_id: optical_frame(name),
            transform: (&eye.pose.cast::<f64>()).into(),
        })
        .collect()
}

fn stamp(images: &CameraImages) -> Time {
    Time::from_secs(images.time)
}

/// The eyes side by side, `rgb8`.
pub fn image_message(images: &CameraImages) -> Image {
    let f = &images.frame;
    Image {
        header: Header::new(stamp(images), &optical_frame(EYES[0])),
        height: f.height,
        width: f.width,
        encoding: "rgb8".into(),
        is_bigendian: 0,
        step: 3 * f.width,
        data: f.rgb.clone(),
    }
}

/// The eyes side by side as JPEG; `None` (logged by the caller) if encoding fails.
pub fn compressed_message(images: &CameraImages) -> Result<CompressedImage, String> {
    let f = &images.frame;
    let mut data = Vec::new();
    let (w, h) = (
        u16::try_from(f.width).map_err(|e| e.to_string())?,
        u16::try_from(f.height).map_err(|e| e.to_string())?,
    );
    jpeg_encoder::Encoder::new(&mut data, JPEG_QUALITY)
        .encode(&f.rgb, w, h, jpeg_encoder::ColorType::Rgb)
        .map_err(|e| e.to_string())?;
    Ok(CompressedImage {
        header: Header::new(stamp(images), &optical_frame(EYES[0])),
        format: "jpeg".into(),
        data,
    })
}

/// CameraInfo of eye `index` (0 left, 1 right).
pub fn info_message(images: &CameraImages, index: usize) -> CameraInfo {
    let eye = images.eyes[index.min(images.eyes.len() - 1)].pinhole;
    let offset = if index == 0 { 0.0 } else { images.baseline };
    CameraInfo {
        header: Header::new(stamp(images), &optical_frame(EYES[index])),
        height: eye.height,
        width: eye.width,
        distortion_model: "plumb_bob".into(),
        d: vec![0.0; 5],
        k: eye.k(),
        r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        p: eye.p(offset),
        binning_x: 0,
        binning_y: 0,
        roi: RegionOfInterest::default(),
    }
}

fn eye_index(frame: &Frame, index: usize) -> usize {
    index.min((frame.width / frame.eye_width) as usize - 1)
}

/// Eye `index`'s depth, `32FC1` (little-endian), m.
pub fn depth_message(images: &CameraImages, index: usize) -> Image {
    let f = &images.frame;
    let depth = f.eye(&f.depth, eye_index(f, index), 1);
    Image {
        header: Header::new(stamp(images), &optical_frame(EYES[index])),
        height: f.height,
        width: f.eye_width,
        encoding: "32FC1".into(),
        is_bigendian: 0,
        step: 4 * f.eye_width,
        data: depth.iter().flat_map(|d| d.to_le_bytes()).collect(),
    }
}

/// Eye `index`'s labels, `mono8`.
pub fn labels_message(images: &CameraImages, index: usize) -> Image {
    let f = &images.frame;
    Image {
        header: Header::new(stamp(images), &optical_frame(EYES[index])),
        height: f.height,
        width: f.eye_width,
        encoding: "mono8".into(),
        is_bigendian: 0,
        step: f.eye_width,
        data: f.eye(&f.labels, eye_index(f, index), 1),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::camera::look_at;
    use crate::ros::msgs::Transform;
    use nalgebra::{Quaternion, Translation3, UnitQuaternion, Vector3};

    /// The pose a tf listener reads from a transform.
    fn pose_of(t: &Transform) -> Isometry3<f32> {
        let (p, q) = (t.translation, t.rotation);
        Isometry3::from_parts(
            Translation3::new(p.x, p.y, p.z),
            UnitQuaternion::from_quaternion(Quaternion::new(q.w, q.x, q.y, q.z)),
        )
        .cast::<f32>()
    }

    #[test]
    fn optical_frames_under_the_ecm_compose_to_the_rendered_eyes() {
        let pinhole = Pinhole::from_hfov(64, 48, 1.0, 0.005, 10.0);
        let frames = optical_frame_transforms("ECM", &Isometry3::identity(), pinhole, 0.006);
        let names: Vec<(&str, &str)> = frames
            .iter()
            .map(|t| (t.header.frame_id.as_str(), t.child_frame_id.as_str()))
            .collect();
        assert_eq!(
            names,
            [
                ("ECM", "ECM_left_optical_frame"),
                ("ECM", "ECM_right_optical_frame")
            ]
        );
        // World → ECM (the scope's tip, wherever the arm holds it) → eye must be the eye the
        // renderer draws from at that tip.
        let tip = look_at(
            Vector3::new(0.02, -0.05, 0.09),
            Vector3::new(0.0, 0.0, 0.01),
        );
        for (frame, eye) in frames.iter().zip(stereo_eyes(&tip, pinhole, 0.006)) {
            let composed = tip * pose_of(&frame.transform);
            assert!(
                (composed.translation.vector - eye.pose.translation.vector).norm() < 1e-6,
                "{}: {composed} against {}",
                frame.child_frame_id,
                eye.pose
            );
            assert!(composed.rotation.angle_to(&eye.pose.rotation) < 1e-5);
        }
        // The left eye 3 mm to the rig's −x, the right 3 mm to its +x.
        let x: Vec<f64> = frames.iter().map(|t| t.transform.translation.x).collect();
        assert!(
            (x[0] + 0.003).abs() < 1e-9 && (x[1] - 0.003).abs() < 1e-9,
            "{x:?}"
        );
    }

    #[test]
    fn a_fixed_mono_camera_has_one_optical_frame_under_world() {
        let pinhole = Pinhole::from_hfov(64, 48, 1.0, 0.005, 10.0);
        let pose = look_at(Vector3::new(0.0, -0.1, 0.1), Vector3::zeros());
        let frames = optical_frame_transforms("world", &pose, pinhole, 0.0);
        assert_eq!(frames.len(), 1);
        assert_eq!(frames[0].header.frame_id, "world");
        assert_eq!(frames[0].child_frame_id, "ECM_left_optical_frame");
        let p = pose_of(&frames[0].transform);
        assert!((p.translation.vector - pose.translation.vector).norm() < 1e-6);
    }
}
