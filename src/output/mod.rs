//! Tissue outputs independent of any transport: a point cloud with a deformation scalar per
//! point, and a triangle surface. The ROS node wraps them in messages.

pub mod cloud;
pub mod surface;

pub use cloud::{TissueSample, CLOUD_POINT_STEP};
pub use surface::boundary_faces;
