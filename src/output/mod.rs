//! Tissue outputs independent of any transport: per-particle deformation measures, a point
//! cloud with a deformation scalar per point, the tissue surface (a mesh of constant
//! topology, or an isosurface), suture threads' centrelines and tension, and pictures. The ROS node wraps them in messages.

pub mod cloud;
pub mod isosurface;
pub mod mesh;
pub mod snapshot;
pub mod strain;
pub mod surface;
pub mod thread;

pub use cloud::{CloudOptions, TissueCloud, CLOUD_POINT_STEP};
pub use surface::{SurfaceKind, SurfaceTriangles, TissueSurface};
pub use thread::{ThreadState, THREAD_POINT_STEP};
