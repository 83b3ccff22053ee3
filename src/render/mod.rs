//! The endoscope camera: what it sees, drawn on the GPU.
//!
//! - **Optics** ([`camera`]): an ideal pinhole per eye, f = (width/2)/tan(hfov/2), the
//!   principal point at the image centre; a rectified stereo pair `baseline` apart (by
//!   default dVRK's simulators': 1280 × 720 per eye, 60°, 6 mm, 30 Hz), with CameraInfo's
//!   K and P (the right eye's Tx = −f·baseline). Frames are REP 103's optical frames.
//! - **Geometry** ([`geometry`]): one triangle list a frame, each corner labelled: the
//!   tissue's surface as the scene's outputs publish it (the fixed-topology mesh bound to
//!   the particles, or, where the tissue is cut or can tear, the isosurface extracted afresh
//!   each frame, so a cut or a tear shows as the gap it is; in a tissue colour or coloured by
//!   strain), each tool tessellated from its shape (the
//!   gripper's two jaws at their opening, the needle's arc as a tube, a slicer's blade,
//!   a mesh slicer's triangles), each thread as a tube of its radius, the table in 5 mm
//!   tiles. Labels: 0 nothing, 1 the table, 10 + i tissue block i, 50 + i thread i,
//!   100 + i tool i in scene order (a needle or a blade is a tool).
//! - **Rasteriser** ([`gpu`]): wgpu on the best adapter (a hardware GPU, otherwise Mesa's
//!   llvmpipe), or on the GPU solver's own device (below); both eyes drawn into one side-by-side image (left eye on the left) with
//!   three targets: RGB lit from the eye (an endoscope's light sits beside its lens),
//!   depth as the camera-frame z in metres (32-bit float, NaN where nothing was drawn, as
//!   REP 118 asks) and the label. Without any adapter [`gpu::Renderer::new`] says so and the
//!   camera stays off.
//!
//! **Pictures** ([`picture`]): `snapshot` and `run --snapshot-every` draw through the same
//! geometry and rasteriser, one eye framing the scene from an azimuth and an elevation,
//! threads drawn at least a pixel and a half thick; where no adapter exists at all they fall
//! back to the CPU splat renderer (`output::snapshot::render_splats`).
//!
//! **Where** ([`rig`]): with an ECM `[[arm]]` the camera sits at the ECM's tool frame (the
//! scope's tip, z along the scope), moved to the ECM's pose at the end of each frame that
//! takes a picture, so `move_jp` on the ECM moves the view; without one it stays where
//! `[camera] position` and `look_at` put it.
//!
//! **In place on the GPU backend** ([`CameraRig::set_in_place`], on by default): the
//! renderer opens on the solver's own device, the solver builds the tissue's surface from
//! its particles at the end of each frame, and the tissue is drawn from those buffers; only
//! the tools, threads and table go from the host. The surface is the rest mesh moved with
//! the particles (two dispatches a frame, [`crate::mpm::gpu::skin`]) or, for tissue that can
//! be cut or tear, the level set extracted on a lattice over the domain (four,
//! [`crate::mpm::gpu::level_set`]), each the host's construction. The positions still come
//! back each frame (the point cloud, the pieces, the wound gap are built from them); what a
//! picture no longer costs is the host moving the mesh or extracting the level set,
//! computing normals and uploading the triangles (6,266 triangles, 0.75 MB a picture on
//! `config/default.toml`). Strain colours and the cut faces a `snapshot` marks need the
//! host. `tests/camera.rs` draws a grasp lifted on the GPU backend both ways, the next
//! frame in flight as the node runs it, and finds the same picture: the mesh (under total
//! Lagrangian MPM) 0 m apart in depth, the level set (MLS-MPM) 4.5e-8 to 1.2e-7 m, against
//! a bound of 1 µm; a surface a frame stale measured 6.7e-6 and 5.8e-5 m and fails.
//! `bench camera` times a picture and a frame both ways (llvmpipe, 2 × 1280 × 720:
//! `config/tearing.toml` with a camera 38.9–40.9 ms a picture from the host, 26.2–29.8 ms
//! in place; `config/default.toml` 33.3 and 30.8 ms).
//!
//! `tests/camera.rs` checks the picture against geometry: a plane's depth against the
//! analytic one, a point's pixel against K, stereo disparity against f·b/z, labels against
//! the shapes, and tissue in two pieces 4 mm apart drawn with the gap between them
//! (nothing labelled tissue over it, where the rest surface's mesh drew 101 pixels).

pub mod camera;
pub mod geometry;
pub mod gpu;
pub mod picture;
pub mod rig;

pub use camera::{CameraRecord, CameraSettings, Eye, Pinhole, TissueColour};
pub use geometry::{SceneGeometry, Triangles, Vertex};
pub use gpu::{Frame, RenderError, Renderer};
pub use rig::{CameraImages, CameraRig};
