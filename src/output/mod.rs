//! Tissue outputs independent of any transport: per-particle deformation measures, a point
//! cloud with a deformation scalar per point, a triangle surface, and pictures. The ROS
//! node wraps them in messages.

pub mod cloud;
pub mod snapshot;
pub mod strain;
pub mod surface;

pub use cloud::{TissueSample, CLOUD_POINT_STEP};
pub use surface::boundary_faces;
