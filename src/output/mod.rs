//! Tissue outputs independent of any transport: per-particle deformation measures, a point
//! cloud with a deformation scalar per point, the tissue surface (a mesh of constant
//! topology, or an isosurface), suture threads' centrelines and tension, and pictures. The
//! ROS node wraps them in messages.
//!
//! Outputs are computed only while someone subscribes (or a recording runs), from what the
//! backend reads back each frame: positions always, and, while the cloud or the mesh's
//! colours need them, the deformation gradients (48 more bytes a particle on the GPU;
//! `tests/gpu_agreement.rs` checks the GPU cloud's scalars against the CPU's).
//!
//! - **Cloud** ([`cloud`]): every particle, every n-th (`points_downsample`) or one mean point
//!   per occupied cube (`points_voxel`), with the scalar `points_scalar` names: `volumetric`
//!   (J − 1), `equivalent` (equivalent Green strain, [`strain`]) or `damage` (tearing, 0…1).
//! - **Mesh** (`surface = "mesh"`, [`mesh`]): each tissue block's rest surface is triangulated
//!   once at the grid spacing, with UVs (a block's six faces in a 3 × 2 atlas). Every vertex
//!   is bound at rest to the particles within two particle spacings; its position is the
//!   weighted least-squares affine fit of their motion, which reduces to a fixed linear
//!   combination x_v = Σ c_i x_i (Σ c_i = 1, exact for any affine motion). Vertex count,
//!   triangles and UVs never change; positions, normals and strain colours are updated per
//!   frame. Faces do not share vertices, so box edges stay sharp.
//! - **Isosurface** (`surface = "isosurface"`, [`isosurface`]): the particles' volume fraction
//!   on a lattice of the grid spacing, its ½ level by marching cubes split into six tetrahedra
//!   each (closed wherever the field is; a box's volume is kept within 6 %, the loss being its
//!   rounded edges). Rebuilt every frame, so it follows cuts and tears; scenes that cut or tear
//!   get it instead of the mesh.
//! - **Pictures** ([`snapshot`]): a CPU renderer (no display, no GPU) drawing particles by
//!   strain, tools from their SDFs, blades and the faces of cuts, and threads as tubes.
//!
//! `cargo run --release -- bench surface` on the retraction scene (CPU, 60,480 particles,
//! spacing 0.5 mm; a mesh of 3,702 vertices; deviation = change of each vertex's distance to
//! the nearest particle since rest):
//!
//! | t (s) | largest particle displacement (mm) | mean (µm) | p95 (µm) | max (µm) |
//! |---|---|---|---|---|
//! | 0.4 | 1.6 | 3.5 | 14 | 105 |
//! | 0.8 | 5.2 | 5.2 | 15 | 72 |
//! | 1.2 | 14.3 | 6.0 | 20 | 110 |
//! | 1.6 | 23.2 | 7.3 | 24 | 557 |
//!
//! The mesh stays on the particles to a few per cent of a spacing except at the pinched edge
//! late in the lift, where the jaws pull particles apart. Per frame on one thread: the mesh
//! 1.1 ms (update, normals, colours, triangle list), the isosurface 81 ms.

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
