//! The narrow view of one finished frame that everything downstream of the loop consumes
//! (publishers, the recorder, a headless run): arm states, tool poses and wrenches, and the
//! tissue outputs that were asked for. Consumers depend on this, never on the loop itself.

use std::sync::Arc;

use crate::output::{SurfaceTriangles, ThreadState, TissueCloud};
use crate::robot::TeleopState;
use crate::sim::arm::ArmStatus;
use crate::tools::ToolPose;
use crate::world::Wrench;

/// A tool at the end of a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct ToolState {
    /// The scene tool's name.
    pub name: String,
    /// Frame of the wrench: the arm's tool frame (`PSM1`) or the tool's name.
    pub frame_id: String,
    /// The tool's world pose and jaw opening.
    pub pose: ToolPose,
    /// Contact wrench in `frame_id`'s axes, the torque about its origin (an arm's tool
    /// frame, behind the held tool's mount; otherwise the tool's own).
    pub wrench: Wrench,
}

/// Everything the outputs need from one frame.
#[derive(Clone, Debug, Default)]
pub struct Frame {
    /// 0 before the first frame.
    pub index: u64,
    /// Simulated time at the end of the frame (s).
    pub time: f64,
    /// The scene's arms, scene order.
    pub arms: Vec<ArmStatus>,
    /// The scene's tools, scene order.
    pub tools: Vec<ToolState>,
    /// Present while the ROS side asks for the point cloud.
    pub cloud: Option<Arc<TissueCloud>>,
    /// Present while the ROS side asks for the surface.
    pub surface: Option<Arc<SurfaceTriangles>>,
    /// Every suture thread, scene order (a few dozen points each: always carried).
    pub threads: Vec<Arc<ThreadState>>,
    /// The teleoperation state of each `[[teleop]]` pair, scene order.
    pub teleop: Vec<TeleopState>,
    /// Separate tissue pieces, in the frames where they were counted (`tissue/pieces`).
    pub pieces: Option<u32>,
    /// The wound gap (m), counted with the pieces in a scene with a `wound`
    /// (`tissue/wound_gap`).
    pub wound_gap: Option<f64>,
    /// The camera's images, in the frames where a subscriber wanted one and it was due.
    pub camera: Option<Arc<crate::render::CameraImages>>,
}

/// Which outputs a frame carries.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Due {
    /// Arm state topics.
    pub arm: bool,
    /// Tissue point cloud.
    pub points: bool,
    /// Tissue surface marker.
    pub surface: bool,
    /// Tool contact wrenches.
    pub wrench: bool,
    /// `/tf`.
    pub tf: bool,
    /// Suture thread markers.
    pub thread: bool,
    /// Cut-piece count.
    pub pieces: bool,
    /// The camera's pictures, at the camera's own rate (`camera.rate_hz`).
    pub camera: bool,
}

impl Due {
    /// Whether the frame carries any output.
    pub fn any(&self) -> bool {
        self.arm
            || self.points
            || self.surface
            || self.wrench
            || self.tf
            || self.thread
            || self.pieces
            || self.camera
    }
}
