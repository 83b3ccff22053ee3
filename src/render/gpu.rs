//! The offscreen rasteriser on wgpu: a triangle list drawn once per eye into one image
//! (the eyes side by side, left on the left), with three colour targets (RGB, camera-frame
//! depth in metres, label) and a depth buffer, read back to the CPU.

use super::camera::Eye;
use super::geometry::{Vertex, LABEL_NONE};
use crate::mpm::gpu::adapter;

/// Why the renderer cannot run.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The machine has no Vulkan, Metal or DX12 adapter at all.
    #[error("no GPU adapter (not even a software one such as Mesa's llvmpipe)")]
    NoAdapter,
    /// The adapter would not open a device.
    #[error("GPU device for the camera: {0}")]
    Device(String),
    /// A frame's size the device cannot hold.
    #[error("camera image of {0} × {1} pixels exceeds the adapter's largest texture ({2})")]
    TooLarge(u32, u32, u32),
}

/// One rendered frame of every eye, side by side (left eye first).
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Width of the whole image (eyes × one eye's width), pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// One eye's width, pixels.
    pub eye_width: u32,
    /// RGB, 3 bytes a pixel, rows from the top.
    pub rgb: Vec<u8>,
    /// Camera-frame depth (z along the optical axis), m; NaN where nothing was drawn.
    pub depth: Vec<f32>,
    /// Label per pixel (see [`super::geometry`]'s `LABEL_` constants).
    pub labels: Vec<u8>,
}

impl Frame {
    /// One eye's columns of a row-major image of `channels` values a pixel.
    pub fn eye<T: Copy>(&self, data: &[T], eye: usize, channels: usize) -> Vec<T> {
        let (w, ew) = (self.width as usize, self.eye_width as usize);
        (0..self.height as usize)
            .flat_map(|y| {
                let row = (y * w + eye * ew) * channels;
                data[row..row + ew * channels].iter().copied()
            })
            .collect()
    }
}

const SHADER: &str = r#"
struct EyeUniform {
    view: mat4x4<f32>,
    intrinsics: vec4<f32>,
    size: vec4<f32>,
    eye: vec4<f32>,
};
@group(0) @binding(0) var<uniform> cam: EyeUniform;

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) colour: vec3<f32>,
    @location(3) label: u32,
};
struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) colour: vec3<f32>,
    @location(3) @interpolate(flat) label: u32,
    @location(4) depth: f32,
};

@vertex
fn vs(v: VertexIn) -> VertexOut {
    let p = cam.view * vec4<f32>(v.position, 1.0);
    let z = p.z;
    let w = cam.size.x;
    let h = cam.size.y;
    let near = cam.size.z;
    let far = cam.size.w;
    // OpenCV pixel coordinates u = f x / z + cx have pixel centres on integers; the
    // framebuffer's are at half-integers.
    let u = cam.intrinsics.x * p.x + (cam.intrinsics.z + 0.5) * z;
    let r = cam.intrinsics.y * p.y + (cam.intrinsics.w + 0.5) * z;
    var out: VertexOut;
    out.clip = vec4<f32>(2.0 * u / w - z, z - 2.0 * r / h, far * (z - near) / (far - near), z);
    out.world = v.position;
    out.normal = v.normal;
    out.colour = v.colour;
    out.label = v.label;
    out.depth = z;
    return out;
}

struct FragmentOut {
    @location(0) colour: vec4<f32>,
    @location(1) depth: f32,
    @location(2) label: u32,
};

@fragment
fn fs(i: VertexOut) -> FragmentOut {
    // Lit from the eye, as an endoscope's light leaves beside its lens: Lambert and a
    // Blinn highlight (the light and view directions coincide), both two-sided.
    let to_eye = normalize(cam.eye.xyz - i.world);
    let n = normalize(i.normal);
    let c = abs(dot(n, to_eye));
    let lit = i.colour * (0.15 + 0.85 * c) + vec3<f32>(0.35) * pow(c, 48.0);
    var out: FragmentOut;
    out.colour = vec4<f32>(lit, 1.0);
    out.depth = i.depth;
    out.label = i.label;
    return out;
}
"#;

const COLOUR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
const LABEL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;
const Z_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Bytes a texel of each read-back target (colour, depth, label).
const TEXEL_BYTES: u32 = 4;
/// Uniform slot size: the eye's 112 bytes padded to the dynamic-offset alignment.
const EYE_SLOT: u64 = 256;

struct Targets {
    width: u32,
    height: u32,
    colour: wgpu::Texture,
    depth: wgpu::Texture,
    label: wgpu::Texture,
    z: wgpu::TextureView,
    readback: wgpu::Buffer,
    padded_row: u32,
}

/// A tissue surface already on the renderer's device (the GPU solver's skinned mesh or
/// level set, see [`crate::mpm::gpu::skin`] and [`crate::mpm::gpu::level_set`]), drawn with
/// the triangle list from its own buffers.
pub struct DeviceMesh<'a> {
    /// Positions, one `vec4` a vertex (xyz in m).
    pub positions: &'a wgpu::Buffer,
    /// Unit normals, one `vec4` a vertex.
    pub normals: &'a wgpu::Buffer,
    /// Colour and label, one [`MeshAttributes`] a vertex; a triangle takes its first
    /// corner's label.
    pub attributes: &'a wgpu::Buffer,
    /// Which vertices make the triangles.
    pub draw: MeshDraw<'a>,
}

/// How a [`DeviceMesh`]'s vertices make triangles.
pub enum MeshDraw<'a> {
    /// `count` `u32` vertex indices, three a triangle.
    Indexed {
        /// The index buffer.
        indices: &'a wgpu::Buffer,
        /// Indices to draw.
        count: u32,
    },
    /// Three vertices a triangle, as many as the device wrote into `args` (the arguments of
    /// `draw_indirect`).
    Indirect {
        /// Vertex count, instance count (1), first vertex, first instance.
        args: &'a wgpu::Buffer,
    },
}

/// A device mesh vertex's colour (linear RGB) and label.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MeshAttributes {
    /// Linear RGB.
    pub colour: [f32; 3],
    /// Label (see [`super::geometry`]'s `LABEL_` constants).
    pub label: u32,
}

/// The camera's renderer: its own device on the best adapter there is, or the GPU solver's
/// (to draw its buffers in place).
pub struct Renderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    pipeline: wgpu::RenderPipeline,
    /// The same shading, fed by a [`DeviceMesh`]'s three vertex buffers and its indices.
    mesh_pipeline: wgpu::RenderPipeline,
    eyes: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    vertices: Option<wgpu::Buffer>,
    targets: Option<Targets>,
    max_texture: u32,
    /// The adapter's name, for the log.
    pub adapter: String,
}

impl Renderer {
    /// Opens a device on the best adapter (hardware first, a software rasteriser otherwise).
    pub fn new() -> Result<Renderer, RenderError> {
        let adapter = adapter::adapters()
            .into_iter()
            .next()
            .ok_or(RenderError::NoAdapter)?;
        let info = adapter.get_info();
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("camera"),
            required_limits: wgpu::Limits {
                max_texture_dimension_2d: limits.max_texture_dimension_2d,
                ..wgpu::Limits::default()
            },
            ..Default::default()
        }))
        .map_err(|e| RenderError::Device(format!("on adapter \"{}\": {e}", info.name)))?;
        let adapter = format!("{} ({:?}, {:?})", info.name, info.backend, info.device_type);
        Ok(Renderer::on_device(
            device,
            queue,
            limits.max_texture_dimension_2d,
            adapter,
        ))
    }

    /// A renderer on the GPU solver's device, which draws that solver's buffers in place.
    pub fn on_solver_device(ctx: &crate::mpm::gpu::adapter::GpuContext) -> Renderer {
        let info = &ctx.info;
        Renderer::on_device(
            ctx.device.clone(),
            ctx.queue.clone(),
            ctx.device.limits().max_texture_dimension_2d,
            format!("{} ({:?}, {:?})", info.name, info.backend, info.device_type),
        )
    }

    fn on_device(
        device: wgpu::Device,
        queue: wgpu::Queue,
        max_texture: u32,
        adapter: String,
    ) -> Renderer {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("camera"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("camera eye"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: true,
                    min_binding_size: wgpu::BufferSize::new(112),
                },
                count: None,
            }],
        });
        let eyes = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("camera eyes"),
            size: 2 * EYE_SLOT,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("camera eye"),
            layout: &layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &eyes,
                    offset: 0,
                    size: wgpu::BufferSize::new(112),
                }),
            }],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("camera"),
            bind_group_layouts: &[&layout],
            push_constant_ranges: &[],
        });
        let attributes =
            wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x3, 3 => Uint32];
        let target = |format| {
            Some(wgpu::ColorTargetState {
                format,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })
        };
        let triangle_list = [wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<Vertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &attributes,
        }];
        let position = wgpu::vertex_attr_array![0 => Float32x3];
        let normal = wgpu::vertex_attr_array![1 => Float32x3];
        let colour_label = wgpu::vertex_attr_array![2 => Float32x3, 3 => Uint32];
        let vec4 = |attributes| wgpu::VertexBufferLayout {
            array_stride: 16,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes,
        };
        let device_mesh = [vec4(&position), vec4(&normal), vec4(&colour_label)];
        let pipeline = |buffers| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("camera"),
                layout: Some(&pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs"),
                    compilation_options: Default::default(),
                    buffers,
                },
                primitive: wgpu::PrimitiveState {
                    topology: wgpu::PrimitiveTopology::TriangleList,
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: Z_FORMAT,
                    depth_write_enabled: true,
                    depth_compare: wgpu::CompareFunction::Less,
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs"),
                    compilation_options: Default::default(),
                    targets: &[
                        target(COLOUR_FORMAT),
                        target(DEPTH_FORMAT),
                        target(LABEL_FORMAT),
                    ],
                }),
                multiview: None,
                cache: None,
            })
        };
        Renderer {
            pipeline: pipeline(&triangle_list),
            mesh_pipeline: pipeline(&device_mesh),
            device,
            queue,
            eyes,
            bind_group,
            vertices: None,
            targets: None,
            max_texture,
            adapter,
        }
    }

    /// The device the renderer draws on (a [`DeviceMesh`]'s buffers must live there).
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    fn targets(&mut self, width: u32, height: u32) -> &Targets {
        if self
            .targets
            .as_ref()
            .is_none_or(|t| t.width != width || t.height != height)
        {
            let texture = |label, format, usage| {
                self.device.create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size: wgpu::Extent3d {
                        width,
                        height,
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage,
                    view_formats: &[],
                })
            };
            let read = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
            let padded_row = (width * TEXEL_BYTES).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
                * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
            self.targets = Some(Targets {
                width,
                height,
                colour: texture("camera colour", COLOUR_FORMAT, read),
                depth: texture("camera depth", DEPTH_FORMAT, read),
                label: texture("camera label", LABEL_FORMAT, read),
                z: texture(
                    "camera z buffer",
                    Z_FORMAT,
                    wgpu::TextureUsages::RENDER_ATTACHMENT,
                )
                .create_view(&Default::default()),
                readback: self.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("camera readback"),
                    size: 3 * padded_row as u64 * height as u64,
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
                padded_row,
            });
        }
        self.targets.as_ref().expect("made above")
    }

    /// Draws `vertices` (a triangle list) from each of `eyes` (one or two, all of one image
    /// size), side by side, and reads the images back.
    pub fn render(&mut self, vertices: &[Vertex], eyes: &[Eye]) -> Result<Frame, RenderError> {
        self.render_with(vertices, None, eyes)
    }

    /// As [`Renderer::render`], with `mesh` (on this renderer's device) drawn too.
    pub fn render_with(
        &mut self,
        vertices: &[Vertex],
        mesh: Option<&DeviceMesh>,
        eyes: &[Eye],
    ) -> Result<Frame, RenderError> {
        let pinhole = eyes[0].pinhole;
        let (eye_w, h) = (pinhole.width, pinhole.height);
        let w = eye_w * eyes.len() as u32;
        if w > self.max_texture || h > self.max_texture {
            return Err(RenderError::TooLarge(w, h, self.max_texture));
        }
        for (k, eye) in eyes.iter().enumerate() {
            let view = eye.pose.inverse().to_homogeneous();
            let p = eye.pinhole;
            let mut slot = [0f32; 28];
            slot[..16].copy_from_slice(view.as_slice());
            slot[16..20].copy_from_slice(&[p.focal, p.focal, p.cx, p.cy]);
            slot[20..24].copy_from_slice(&[p.width as f32, p.height as f32, p.near, p.far]);
            let e = eye.pose.translation.vector;
            slot[24..28].copy_from_slice(&[e.x, e.y, e.z, 1.0]);
            self.queue
                .write_buffer(&self.eyes, k as u64 * EYE_SLOT, bytemuck::cast_slice(&slot));
        }
        let bytes = std::mem::size_of_val(vertices) as u64;
        if bytes > 0 && self.vertices.as_ref().is_none_or(|b| b.size() < bytes) {
            self.vertices = Some(self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("camera vertices"),
                size: bytes.next_power_of_two(),
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        if bytes > 0 {
            let buffer = self.vertices.as_ref().expect("made above");
            self.queue
                .write_buffer(buffer, 0, bytemuck::cast_slice(vertices));
        }
        self.targets(w, h);
        let t = self.targets.as_ref().expect("made above");
        let views = [&t.colour, &t.depth, &t.label].map(|x| x.create_view(&Default::default()));
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("camera"),
            });
        {
            let attachment = |view, clear| {
                Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(clear),
                        store: wgpu::StoreOp::Store,
                    },
                })
            };
            // A grey-brown background: the inside of a body cavity beyond the lit scene.
            let background = wgpu::Color {
                r: 0.05,
                g: 0.035,
                b: 0.03,
                a: 1.0,
            };
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("camera"),
                color_attachments: &[
                    attachment(&views[0], background),
                    attachment(&views[1], wgpu::Color::TRANSPARENT),
                    attachment(&views[2], wgpu::Color::TRANSPARENT),
                ],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &t.z,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
            });
            for k in 0..eyes.len() {
                pass.set_bind_group(0, &self.bind_group, &[(k as u64 * EYE_SLOT) as u32]);
                pass.set_viewport(
                    (k as u32 * eye_w) as f32,
                    0.0,
                    eye_w as f32,
                    h as f32,
                    0.0,
                    1.0,
                );
                if let (Some(buffer), true) = (&self.vertices, bytes > 0) {
                    pass.set_pipeline(&self.pipeline);
                    pass.set_vertex_buffer(0, buffer.slice(..bytes));
                    pass.draw(0..vertices.len() as u32, 0..1);
                }
                if let Some(mesh) = mesh {
                    pass.set_pipeline(&self.mesh_pipeline);
                    pass.set_vertex_buffer(0, mesh.positions.slice(..));
                    pass.set_vertex_buffer(1, mesh.normals.slice(..));
                    pass.set_vertex_buffer(2, mesh.attributes.slice(..));
                    match mesh.draw {
                        MeshDraw::Indexed { indices, count } => {
                            pass.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint32);
                            pass.draw_indexed(0..count, 0, 0..1);
                        }
                        MeshDraw::Indirect { args } => pass.draw_indirect(args, 0),
                    }
                }
            }
        }
        let plane = t.padded_row as u64 * h as u64;
        for (k, texture) in [&t.colour, &t.depth, &t.label].into_iter().enumerate() {
            encoder.copy_texture_to_buffer(
                texture.as_image_copy(),
                wgpu::TexelCopyBufferInfo {
                    buffer: &t.readback,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: k as u64 * plane,
                        bytes_per_row: Some(t.padded_row),
                        rows_per_image: Some(h),
                    },
                },
                wgpu::Extent3d {
                    width: w,
                    height: h,
                    depth_or_array_layers: 1,
                },
            );
        }
        self.queue.submit([encoder.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        t.readback.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| RenderError::Device(e.to_string()))?;
        rx.recv()
            .map_err(|e| RenderError::Device(e.to_string()))?
            .map_err(|e| RenderError::Device(e.to_string()))?;
        let n = (w * h) as usize;
        let mut frame = Frame {
            width: w,
            height: h,
            eye_width: eye_w,
            rgb: Vec::with_capacity(3 * n),
            depth: Vec::with_capacity(n),
            labels: Vec::with_capacity(n),
        };
        {
            let data = t.readback.get_mapped_range(..);
            let row = |k: usize, y: usize| {
                let start = k * plane as usize + y * t.padded_row as usize;
                &data[start..start + (w * TEXEL_BYTES) as usize]
            };
            for y in 0..h as usize {
                for px in row(0, y).chunks_exact(4) {
                    frame.rgb.extend_from_slice(&px[..3]);
                }
                let labels = row(2, y);
                for (d, l) in row(1, y).chunks_exact(4).zip(labels.chunks_exact(4)) {
                    let label = u32::from_le_bytes([l[0], l[1], l[2], l[3]]).min(255) as u8;
                    frame.labels.push(label);
                    frame.depth.push(if label == LABEL_NONE {
                        f32::NAN
                    } else {
                        f32::from_le_bytes([d[0], d[1], d[2], d[3]])
                    });
                }
            }
        }
        t.readback.unmap();
        Ok(frame)
    }
}
