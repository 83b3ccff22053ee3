//! A scene's camera while the simulation runs: where it is, when a frame is due (its rate in
//! simulated time) and the renderer that draws it.

use super::camera::{stereo_eyes, CameraSettings, Eye, TissueColour};
use super::geometry::SceneGeometry;
use super::geometry::{DeviceDrawable, LABEL_TISSUE, TISSUE_COLOUR};
use super::gpu::{DeviceMesh, Frame, MeshAttributes, MeshDraw, RenderError, Renderer};
use crate::mpm::backend::Backend;
use crate::mpm::gpu::level_set::{Lattice, LevelSetLook};
use crate::mpm::gpu::skin::MeshBinding;
use crate::mpm::gpu::{GpuSolver, SurfaceOnDevice};
use crate::output::isosurface;
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
    /// Whether the tissue may be drawn from the GPU solver's buffers (see
    /// [`CameraRig::set_in_place`]).
    in_place: bool,
    /// The renderer is on the GPU solver's device, which builds the tissue's surface.
    on_device: bool,
    /// The tissue mesh's colours and labels on the solver's device, once it is skinned
    /// there (a level set writes its own).
    mesh_attributes: Option<wgpu::Buffer>,
    /// Whether the last picture drew the tissue from the solver's buffers.
    drew_in_place: bool,
}

/// The GPU solver of `world`, if it runs on one.
fn gpu_solver(world: &World) -> Option<&GpuSolver> {
    match world.backend() {
        Backend::Gpu(g) => Some(g),
        Backend::Cpu(_) => None,
    }
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
            in_place: true,
            on_device: false,
            mesh_attributes: None,
            drew_in_place: false,
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

    /// Whether the tissue may be drawn where the GPU solver's buffers already are (on by
    /// default): the solver then builds the tissue's surface at the end of each frame (the
    /// mesh moved with the particles, [`crate::mpm::gpu::skin`], or the isosurface,
    /// [`crate::mpm::gpu::level_set`]) and it is drawn from there; only the tools, threads
    /// and table go from the host to the renderer. Off, or on the CPU backend, or where the
    /// tissue is coloured by strain, the surface is built from the particles read back to
    /// the host. Takes effect before the first picture.
    pub fn set_in_place(&mut self, on: bool) {
        self.in_place = on;
    }

    /// Whether the last picture drew the tissue from the GPU solver's buffers (the first
    /// frame after the camera opens still draws from the host: its frame was submitted
    /// before the solver built the surface).
    pub fn drew_in_place(&self) -> bool {
        self.drew_in_place
    }

    /// Draws `world` as it is now (opening the device the first time: the GPU solver's own
    /// when the tissue is drawn in place, see [`CameraRig::set_in_place`]).
    pub fn render(&mut self, world: &mut World) -> Result<CameraImages, RenderError> {
        if self.renderer.is_none() {
            let in_place = self.in_place && self.geometry.device_drawable().is_some();
            self.renderer = Some(match gpu_solver(world).filter(|_| in_place) {
                Some(gpu) => {
                    let renderer = Renderer::on_solver_device(gpu.context());
                    self.mesh_attributes = self.surface_on_device(world, &renderer);
                    self.on_device = true;
                    renderer
                }
                None => Renderer::new()?,
            });
        }
        let eyes = self.eyes();
        let on_device = gpu_solver(world)
            .filter(|_| self.on_device)
            .and_then(GpuSolver::surface_on_device);
        let renderer = self.renderer.as_mut().expect("opened above");
        let mesh = match &on_device {
            Some(SurfaceOnDevice::Mesh(stage, vertices)) => {
                self.mesh_attributes.as_ref().map(|attributes| DeviceMesh {
                    positions: &vertices.positions,
                    normals: &vertices.normals,
                    attributes,
                    draw: MeshDraw::Indexed {
                        indices: &stage.indices,
                        count: stage.index_count,
                    },
                })
            }
            Some(SurfaceOnDevice::LevelSet(vertices)) => Some(DeviceMesh {
                positions: &vertices.positions,
                normals: &vertices.normals,
                attributes: &vertices.attributes,
                draw: MeshDraw::Indirect {
                    args: &vertices.args,
                },
            }),
            None => None,
        };
        self.drew_in_place = mesh.is_some();
        let frame = match mesh {
            Some(mesh) => {
                let triangles = self.geometry.triangles_around_tissue(world);
                renderer.render_with(&triangles.vertices, Some(&mesh), &eyes)?
            }
            None => {
                let triangles = self.geometry.triangles(world);
                renderer.render(&triangles.vertices, &eyes)?
            }
        };
        Ok(CameraImages {
            time: world.time(),
            frame,
            eyes,
            baseline: self.settings.baseline,
        })
    }

    /// Has the GPU solver build the tissue's surface from the next frame on (the mesh
    /// moved with the particles, or the level set), and returns the mesh's colours and
    /// labels on `renderer`'s device (the solver's); the level set writes its own.
    fn surface_on_device(&self, world: &mut World, renderer: &Renderer) -> Option<wgpu::Buffer> {
        use wgpu::util::DeviceExt;
        let drawable = self.geometry.device_drawable()?;
        let attributes = match drawable {
            DeviceDrawable::Mesh(mesh, blocks) => {
                let (offsets, particles, coefficients) = mesh.binding();
                let binding = MeshBinding {
                    offsets,
                    particles,
                    coefficients,
                    triangles: &mesh.triangles,
                };
                if let Backend::Gpu(gpu) = world.backend_mut() {
                    gpu.skin_mesh(&binding);
                }
                let attributes: Vec<MeshAttributes> = blocks
                    .iter()
                    .map(|&b| MeshAttributes {
                        colour: TISSUE_COLOUR,
                        label: LABEL_TISSUE.saturating_add(b.min(39) as u8) as u32,
                    })
                    .collect();
                Some(
                    renderer
                        .device()
                        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                            label: Some("tissue mesh attributes"),
                            contents: bytemuck::cast_slice(&attributes),
                            usage: wgpu::BufferUsages::VERTEX,
                        }),
                )
            }
            DeviceDrawable::LevelSet { cell } => {
                let domain = &world.scene().domain;
                let lattice = Lattice::around(domain.origin, domain.size, cell);
                let limits = renderer.device().limits();
                let largest = limits
                    .max_storage_buffer_binding_size
                    .min(limits.max_buffer_size.min(u32::MAX as u64) as u32)
                    as u64;
                // Room for four times the rest surface's triangles (a tear adds its faces),
                // 48 bytes a triangle in each of its three buffers.
                let rest = isosurface::extract(&world.rest_particles(), cell);
                let capacity = ((4 * rest.triangles.len()).max(65_536) as u64).min(largest / 48);
                if 4 * lattice.nodes() > largest {
                    tracing::warn!(
                        "camera: the tissue's isosurface is drawn from the host: a lattice of \
                         {} nodes over the domain exceeds the device's largest buffer",
                        lattice.nodes()
                    );
                    return None;
                }
                let look = LevelSetLook {
                    colour: TISSUE_COLOUR,
                    label: LABEL_TISSUE as u32,
                    capacity: capacity as u32,
                };
                if let Backend::Gpu(gpu) = world.backend_mut() {
                    gpu.extract_level_set(lattice, look);
                }
                None
            }
        };
        attributes
    }
}
