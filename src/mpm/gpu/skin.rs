//! The tissue's surface mesh moved with the particles on the device, so that the camera
//! draws the solver's own buffers ([`crate::render`]) instead of positions read back to the
//! host and uploaded again as triangles.
//!
//! Two passes end a frame's submission once a camera asks for them
//! ([`GpuSolver::skin_mesh`](super::GpuSolver::skin_mesh)): each mesh vertex sums its bound
//! particles' positions with the binding's coefficients (the host's
//! [`TissueMesh::update`](crate::output::mesh::TissueMesh::update), the same sums in the
//! same order), then each vertex's normal is the normalised sum of its triangles' area
//! vectors (the host's `vertex_normals`). Both read only the particle buffer and the
//! binding, written once: 2 dispatches a frame, none a substep.
//!
//! The frame whose outputs are being built is not the device's latest when the world runs
//! a frame ahead (the next one is submitted first, see [`crate::sim`]'s frame loop), so the
//! vertices go into two buffers in turn: a frame writes one, and the frame collected before
//! it is drawn from the other.

const SHADER: &str = r#"
// `skin` binds 0–4 and `shade` 4–8: five storage buffers a pass, within every adapter's
// limit of eight.
@group(0) @binding(0) var<storage, read> particles: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> offsets: array<u32>;
@group(0) @binding(2) var<storage, read> bound: array<u32>;
@group(0) @binding(3) var<storage, read> coefficients: array<f32>;
@group(0) @binding(4) var<storage, read_write> positions: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> corner_offsets: array<u32>;
@group(0) @binding(6) var<storage, read> corner_triangles: array<u32>;
@group(0) @binding(7) var<storage, read> triangles: array<u32>;
@group(0) @binding(8) var<storage, read_write> normals: array<vec4<f32>>;

const PARTICLE_VEC4S: u32 = {PARTICLE_VEC4S}u;

@compute @workgroup_size(64)
fn skin(@builtin(global_invocation_id) id: vec3<u32>) {
    let v = id.x;
    if v + 1u >= arrayLength(&offsets) {
        return;
    }
    var x = vec3<f32>(0.0);
    for (var k = offsets[v]; k < offsets[v + 1u]; k++) {
        x += particles[bound[k] * PARTICLE_VEC4S].xyz * coefficients[k];
    }
    positions[v] = vec4<f32>(x, 1.0);
}

@compute @workgroup_size(64)
fn shade(@builtin(global_invocation_id) id: vec3<u32>) {
    let v = id.x;
    if v + 1u >= arrayLength(&corner_offsets) {
        return;
    }
    var n = vec3<f32>(0.0);
    for (var k = corner_offsets[v]; k < corner_offsets[v + 1u]; k++) {
        let t = 3u * corner_triangles[k];
        let a = positions[triangles[t]].xyz;
        let b = positions[triangles[t + 1u]].xyz;
        let c = positions[triangles[t + 2u]].xyz;
        n += cross(b - a, c - a);
    }
    let length = sqrt(dot(n, n));
    normals[v] = select(vec4<f32>(0.0, 0.0, 1.0, 0.0), vec4<f32>(n / length, 0.0), length > 0.0);
}
"#;

/// A shader module from `source`, whose `{PARTICLE_VEC4S}` becomes the particle record's
/// stride in `vec4`s (the stages here read the solver's particles as `array<vec4<f32>>`,
/// the position first).
pub(super) fn particle_reader(
    device: &wgpu::Device,
    label: &str,
    source: &str,
) -> wgpu::ShaderModule {
    let particle_vec4s = std::mem::size_of::<super::pack::GpuParticle>() / 16;
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(
            source
                .replace("{PARTICLE_VEC4S}", &particle_vec4s.to_string())
                .into(),
        ),
    })
}

/// The compute pipeline of `module`'s `entry` over one bind group of `layout`.
pub(super) fn compute_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    entry: &str,
    layout: &wgpu::BindGroupLayout,
) -> wgpu::ComputePipeline {
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(entry),
        bind_group_layouts: &[layout],
        push_constant_ranges: &[],
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: Some(&pipeline_layout),
        module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    })
}

/// A bind group of whole `buffers` at bindings `first`, `first + 1`, ...
pub(super) fn bind_buffers(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    first: u32,
    buffers: &[&wgpu::Buffer],
) -> wgpu::BindGroup {
    let entries: Vec<_> = (first..)
        .zip(buffers)
        .map(|(binding, buffer)| wgpu::BindGroupEntry {
            binding,
            resource: buffer.as_entire_binding(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}

/// How a mesh's vertices follow the particles: the binding rows and the triangles.
pub struct MeshBinding<'a> {
    /// Vertex v uses entries `offsets[v]..offsets[v + 1]` of `particles` and `coefficients`.
    pub offsets: &'a [u32],
    /// The particle of each entry.
    pub particles: &'a [u32],
    /// Each entry's coefficient.
    pub coefficients: &'a [f32],
    /// The triangles, corners as vertex indices.
    pub triangles: &'a [[u32; 3]],
}

/// One frame's skinned vertices on the device.
pub struct SkinnedVertices {
    /// Positions (m), one `vec4` a vertex (w = 1).
    pub positions: wgpu::Buffer,
    /// Unit normals, one `vec4` a vertex (w = 0).
    pub normals: wgpu::Buffer,
}

/// The skinning passes and their buffers.
pub struct SkinStage {
    skin: wgpu::ComputePipeline,
    shade: wgpu::ComputePipeline,
    /// Per slot: the skinning pass's bindings and the shading pass's.
    groups: [[wgpu::BindGroup; 2]; 2],
    outputs: [SkinnedVertices; 2],
    /// The triangles as a `u32` index list (also the draw's index buffer).
    pub indices: wgpu::Buffer,
    /// Indices in `indices`.
    pub index_count: u32,
    vertex_count: u32,
}

/// Which of two output sets a frame writes and which one is drawn: a frame writes the set
/// the frame collected before it does not hold.
#[derive(Clone, Copy, Debug, Default)]
pub struct FrameSlots {
    /// The slot the next frame writes.
    next: usize,
    /// The slot the frame in flight wrote, if it wrote one.
    in_flight: Option<usize>,
    /// The slot holding the frame last collected, if it wrote one and nothing moved the
    /// particles since.
    collected: Option<usize>,
}

impl FrameSlots {
    /// The slot a frame being recorded writes.
    pub fn begin(&mut self) -> usize {
        let slot = self.next;
        self.in_flight = Some(slot);
        self.next = 1 - slot;
        slot
    }

    /// The frame in flight was collected: its slot (if it wrote one) is the drawn one.
    pub fn collected(&mut self) {
        self.collected = self.in_flight.take();
    }

    /// Something moved the particles outside a frame (a restore, an upload): no slot
    /// matches them until the next frame.
    pub fn invalidate(&mut self) {
        self.collected = None;
    }

    /// The slot of the frame last collected, while it matches the particles.
    pub fn current(&self) -> Option<usize> {
        self.collected
    }
}

impl SkinStage {
    /// The passes for `binding`'s mesh over `particles` (the solver's particle buffer).
    pub fn new(
        device: &wgpu::Device,
        particles: &wgpu::Buffer,
        binding: &MeshBinding,
    ) -> SkinStage {
        use wgpu::util::DeviceExt;
        let vertex_count = binding.offsets.len().saturating_sub(1) as u32;
        let module = particle_reader(device, "skin", SHADER);
        let storage = |binding, read_only| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let written = |b| b == 4 || b == 8;
        let layouts = [0..5, 4..9].map(|bindings| {
            let entries: Vec<_> = bindings.map(|b| storage(b, !written(b))).collect();
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("skin"),
                entries: &entries,
            })
        });
        let pipeline = |entry, layout| compute_pipeline(device, &module, entry, layout);
        // Each vertex's triangles, compressed rows like the binding's.
        let mut corner_offsets = vec![0u32; vertex_count as usize + 1];
        for t in binding.triangles {
            for &v in t {
                corner_offsets[v as usize + 1] += 1;
            }
        }
        for v in 0..vertex_count as usize {
            corner_offsets[v + 1] += corner_offsets[v];
        }
        let mut fill = corner_offsets.clone();
        let mut corner_triangles = vec![0u32; *corner_offsets.last().unwrap_or(&0) as usize];
        for (i, t) in binding.triangles.iter().enumerate() {
            for &v in t {
                corner_triangles[fill[v as usize] as usize] = i as u32;
                fill[v as usize] += 1;
            }
        }
        let init = |label, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                // A binding may not be empty.
                contents: if contents.is_empty() {
                    &[0; 4]
                } else {
                    contents
                },
                usage,
            })
        };
        let storage_usage = wgpu::BufferUsages::STORAGE;
        let read = [
            init(
                "skin offsets",
                bytemuck::cast_slice(binding.offsets),
                storage_usage,
            ),
            init(
                "skin particles",
                bytemuck::cast_slice(binding.particles),
                storage_usage,
            ),
            init(
                "skin coefficients",
                bytemuck::cast_slice(binding.coefficients),
                storage_usage,
            ),
            init(
                "skin corner offsets",
                bytemuck::cast_slice(&corner_offsets),
                storage_usage,
            ),
            init(
                "skin corner triangles",
                bytemuck::cast_slice(&corner_triangles),
                storage_usage,
            ),
        ];
        let indices = init(
            "skin triangles",
            bytemuck::cast_slice(binding.triangles),
            storage_usage | wgpu::BufferUsages::INDEX,
        );
        let output = |label| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: 16 * vertex_count.max(1) as u64,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::VERTEX,
                mapped_at_creation: false,
            })
        };
        let outputs = [0, 1].map(|_| SkinnedVertices {
            positions: output("skinned positions"),
            normals: output("skinned normals"),
        });
        let group = |layout, first, buffers: [&wgpu::Buffer; 5]| {
            bind_buffers(device, "skin", layout, first, &buffers)
        };
        let groups = [0, 1].map(|slot| {
            let out = &outputs[slot];
            let [offsets, bound, coefficients, corner_offsets, corner_triangles] = &read;
            [
                group(
                    &layouts[0],
                    0,
                    [particles, offsets, bound, coefficients, &out.positions],
                ),
                group(
                    &layouts[1],
                    4,
                    [
                        &out.positions,
                        corner_offsets,
                        corner_triangles,
                        &indices,
                        &out.normals,
                    ],
                ),
            ]
        });
        SkinStage {
            skin: pipeline("skin", &layouts[0]),
            shade: pipeline("shade", &layouts[1]),
            groups,
            outputs,
            indices,
            index_count: 3 * binding.triangles.len() as u32,
            vertex_count,
        }
    }

    /// Records both passes at the end of a frame that ends the world's frame, into
    /// output set `slot`.
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, slot: usize) {
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("skin"),
                timestamp_writes: None,
            });
            let groups = self.vertex_count.div_ceil(64).max(1);
            pass.set_pipeline(&self.skin);
            pass.set_bind_group(0, &self.groups[slot][0], &[]);
            pass.dispatch_workgroups(groups, 1, 1);
            pass.set_pipeline(&self.shade);
            pass.set_bind_group(0, &self.groups[slot][1], &[]);
            pass.dispatch_workgroups(groups, 1, 1);
        }
    }

    /// The vertices a frame wrote into `slot`.
    pub fn vertices(&self, slot: usize) -> &SkinnedVertices {
        &self.outputs[slot]
    }
}
