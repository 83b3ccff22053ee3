//! The tissue's ½ volume-fraction isosurface extracted on the device, for the camera to draw
//! tissue that can be cut or tear from the solver's own buffers: the host's
//! [`crate::output::isosurface`] on a dense lattice over the domain.
//!
//! Four passes end a frame's submission once a camera asks for them
//! ([`GpuSolver::extract_level_set`](super::GpuSolver::extract_level_set)):
//! 1. clear the lattice and the triangle count;
//! 2. each particle spreads its rest volume over its cell's eight nodes with trilinear
//!    weights (fixed point, so the field is the same whatever the order), and marks each
//!    node with the material of the particle that weighs most there (the label);
//! 3. each lattice cube with nodes on both sides of ½ is split into the host's six
//!    tetrahedra, whose crossings become triangles with normals down the field's
//!    central-difference gradient, appended to a vertex list;
//! 4. one invocation writes the draw's indirect arguments (3 × the triangles kept).
//!
//! A triangle list has no shared vertices here (the host's has): the picture is the same.
//! The list holds at most `capacity` triangles, four times the rest surface's or 65,536
//! (within the device's largest buffer); beyond that triangles are dropped (a torn tissue's
//! surface grows by its crack faces, far less than fourfold). A lattice too large for one
//! buffer leaves the isosurface to the host (the camera logs it). As with the skinned mesh
//! ([`super::skin`]) the outputs go into two sets in turn.

use super::skin::{bind_buffers, compute_pipeline, particle_reader};

const SHADER: &str = r#"
struct Lattice {
    lo: vec4<i32>,
    dims: vec4<u32>,
    // x: cell (m), y: 1 / cell³, z: the tissue colour's red, w: green
    cell: vec4<f32>,
    // x: blue, y: label of material 0 (bits), z: capacity in triangles (bits)
    more: vec4<f32>,
};
@group(0) @binding(0) var<uniform> lattice: Lattice;
@group(0) @binding(1) var<storage, read> particles: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> constants: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> field: array<atomic<i32>>;
@group(0) @binding(4) var<storage, read_write> owner: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> count: array<atomic<u32>>;
@group(0) @binding(6) var<storage, read_write> positions: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> normals: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> attributes: array<vec4<u32>>;
@group(0) @binding(9) var<storage, read_write> args: array<u32>;

const PARTICLE_VEC4S: u32 = {PARTICLE_VEC4S}u;
const FIXED: f32 = 1048576.0;
const ISO: f32 = 0.5;

fn node_index(n: vec3<i32>) -> i32 {
    let l = n - lattice.lo.xyz;
    let d = vec3<i32>(lattice.dims.xyz);
    if any(l < vec3<i32>(0)) || any(l >= d) {
        return -1;
    }
    return l.x + d.x * (l.y + d.y * l.z);
}

fn value(n: vec3<i32>) -> f32 {
    let i = node_index(n);
    if i < 0 {
        return 0.0;
    }
    return f32(atomicLoad(&field[i])) / FIXED;
}

@compute @workgroup_size(4, 4, 4)
fn clear(@builtin(global_invocation_id) id: vec3<u32>) {
    if all(id == vec3<u32>(0u)) {
        atomicStore(&count[0], 0u);
    }
    if any(id >= lattice.dims.xyz) {
        return;
    }
    let i = id.x + lattice.dims.x * (id.y + lattice.dims.y * id.z);
    atomicStore(&field[i], 0);
    atomicStore(&owner[i], 0u);
}

@compute @workgroup_size(64)
fn splat(@builtin(global_invocation_id) id: vec3<u32>) {
    let p = id.x;
    if p >= arrayLength(&constants) {
        return;
    }
    let x = particles[p * PARTICLE_VEC4S].xyz;
    if any(x != x) || any(abs(x) > vec3<f32>(1e30)) {
        return;
    }
    let c = constants[p];
    let g = x / lattice.cell.x;
    let base = floor(g);
    let frac = g - base;
    let b = vec3<i32>(base);
    for (var o = 0u; o < 8u; o++) {
        let bits = vec3<u32>(o & 1u, (o >> 1u) & 1u, (o >> 2u) & 1u);
        let f = select(1.0 - frac, frac, bits == vec3<u32>(1u));
        let w = c.y * lattice.cell.y * f.x * f.y * f.z;
        let i = node_index(b + vec3<i32>(bits));
        if i < 0 {
            continue;
        }
        atomicAdd(&field[i], i32(round(w * FIXED)));
        let material = bitcast<u32>(c.z) & 255u;
        atomicMax(&owner[i], (u32(clamp(w, 0.0, 1.0) * FIXED) << 8u) | material);
    }
}

fn corner(c: vec3<i32>, o: u32) -> vec3<i32> {
    return c + vec3<i32>(vec3<u32>(o & 1u, (o >> 1u) & 1u, (o >> 2u) & 1u));
}

fn gradient(n: vec3<i32>) -> vec3<f32> {
    let h = 2.0 * lattice.cell.x;
    return vec3<f32>(
        value(n + vec3<i32>(1, 0, 0)) - value(n - vec3<i32>(1, 0, 0)),
        value(n + vec3<i32>(0, 1, 0)) - value(n - vec3<i32>(0, 1, 0)),
        value(n + vec3<i32>(0, 0, 1)) - value(n - vec3<i32>(0, 0, 1)),
    ) / h;
}

struct Crossing {
    position: vec3<f32>,
    normal: vec3<f32>,
    label: u32,
};

// The vertex where the level set crosses the edge from a (inside) to b (outside), as the
// host's `crossing`.
fn crossing(a: vec3<i32>, va: f32, b: vec3<i32>, vb: f32) -> Crossing {
    let t = clamp((ISO - va) / (vb - va), 0.0, 1.0);
    let pa = vec3<f32>(a) * lattice.cell.x;
    let pb = vec3<f32>(b) * lattice.cell.x;
    let n = -mix(gradient(a), gradient(b), t);
    let length = sqrt(dot(n, n));
    var out: Crossing;
    out.position = mix(pa, pb, t);
    out.normal = select((pb - pa) / lattice.cell.x, n / length, length > 0.0);
    out.label = bitcast<u32>(lattice.more.y) + (atomicLoad(&owner[node_index(a)]) & 255u);
    return out;
}

fn emit(a: Crossing, b: Crossing, c: Crossing) {
    let t = atomicAdd(&count[0], 1u);
    if t >= bitcast<u32>(lattice.more.z) {
        return;
    }
    let colour = vec3<u32>(
        bitcast<u32>(lattice.cell.z),
        bitcast<u32>(lattice.cell.w),
        bitcast<u32>(lattice.more.x),
    );
    // A triangle takes its first corner's label, as the host's tissue triangles do.
    let corners = array<Crossing, 3>(a, b, c);
    for (var k = 0u; k < 3u; k++) {
        let v = 3u * t + k;
        positions[v] = vec4<f32>(corners[k].position, 1.0);
        normals[v] = vec4<f32>(corners[k].normal, 0.0);
        attributes[v] = vec4<u32>(colour, corners[0].label);
    }
}

fn orientation(p: array<vec3<f32>, 4>) -> f32 {
    return dot(cross(p[1] - p[0], p[2] - p[0]), p[3] - p[0]);
}

@compute @workgroup_size(4, 4, 4)
fn march(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id + vec3<u32>(1u) >= lattice.dims.xyz) {
        return;
    }
    let c = lattice.lo.xyz + vec3<i32>(id);
    var v: array<f32, 8>;
    var inside_count = 0u;
    for (var o = 0u; o < 8u; o++) {
        v[o] = value(corner(c, o));
        inside_count += select(0u, 1u, v[o] >= ISO);
    }
    if inside_count == 0u || inside_count == 8u {
        return;
    }
    let tets = array<vec4<u32>, 6>(
        vec4<u32>(0u, 1u, 3u, 7u),
        vec4<u32>(0u, 1u, 5u, 7u),
        vec4<u32>(0u, 2u, 3u, 7u),
        vec4<u32>(0u, 2u, 6u, 7u),
        vec4<u32>(0u, 4u, 5u, 7u),
        vec4<u32>(0u, 4u, 6u, 7u),
    );
    for (var k = 0u; k < 6u; k++) {
        // The corners inside first, then those outside, each in the tetrahedron's order
        // (the host's `side` filters).
        var ins: array<u32, 4>;
        var outs: array<u32, 4>;
        var ni = 0u;
        var no = 0u;
        for (var j = 0u; j < 4u; j++) {
            let o = tets[k][j];
            if v[o] >= ISO {
                ins[ni] = o;
                ni++;
            } else {
                outs[no] = o;
                no++;
            }
        }
        if ni == 1u {
            let i = ins[0];
            let s = orientation(array<vec3<f32>, 4>(
                vec3<f32>(corner(c, i)), vec3<f32>(corner(c, outs[0])),
                vec3<f32>(corner(c, outs[1])), vec3<f32>(corner(c, outs[2]))));
            let a = crossing(corner(c, i), v[i], corner(c, outs[0]), v[outs[0]]);
            let b = crossing(corner(c, i), v[i], corner(c, outs[1]), v[outs[1]]);
            let d = crossing(corner(c, i), v[i], corner(c, outs[2]), v[outs[2]]);
            if s > 0.0 { emit(a, b, d); } else { emit(a, d, b); }
        } else if ni == 3u {
            let o = outs[0];
            let s = orientation(array<vec3<f32>, 4>(
                vec3<f32>(corner(c, o)), vec3<f32>(corner(c, ins[0])),
                vec3<f32>(corner(c, ins[1])), vec3<f32>(corner(c, ins[2]))));
            let a = crossing(corner(c, ins[0]), v[ins[0]], corner(c, o), v[o]);
            let b = crossing(corner(c, ins[1]), v[ins[1]], corner(c, o), v[o]);
            let d = crossing(corner(c, ins[2]), v[ins[2]], corner(c, o), v[o]);
            if s > 0.0 { emit(a, d, b); } else { emit(a, b, d); }
        } else if ni == 2u {
            let i = ins[0];
            let j = ins[1];
            let kk = outs[0];
            let l = outs[1];
            let s = orientation(array<vec3<f32>, 4>(
                vec3<f32>(corner(c, i)), vec3<f32>(corner(c, j)),
                vec3<f32>(corner(c, kk)), vec3<f32>(corner(c, l))));
            let a = crossing(corner(c, i), v[i], corner(c, kk), v[kk]);
            let b = crossing(corner(c, j), v[j], corner(c, kk), v[kk]);
            let d = crossing(corner(c, j), v[j], corner(c, l), v[l]);
            let e = crossing(corner(c, i), v[i], corner(c, l), v[l]);
            if s > 0.0 {
                emit(a, d, b);
                emit(a, e, d);
            } else {
                emit(a, b, d);
                emit(a, d, e);
            }
        }
    }
}

@compute @workgroup_size(1)
fn draw_args() {
    let kept = min(atomicLoad(&count[0]), bitcast<u32>(lattice.more.z));
    args[0] = 3u * kept;
    args[1] = 1u;
    args[2] = 0u;
    args[3] = 0u;
}
"#;

/// The lattice the level set is extracted on: nodes `lo ..= hi` (multiples of `cell`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lattice {
    /// Spacing, m.
    pub cell: f32,
    /// Lowest node, in cells.
    pub lo: [i32; 3],
    /// Highest node, in cells.
    pub hi: [i32; 3],
}

impl Lattice {
    /// The nodes around a domain from `origin` of `size` (m), with a node to spare on
    /// each side (a particle on the domain's face spreads into the node beyond).
    pub fn around(origin: [f64; 3], size: [f64; 3], cell: f32) -> Lattice {
        let c = cell as f64;
        Lattice {
            cell,
            lo: std::array::from_fn(|k| (origin[k] / c).floor() as i32 - 1),
            hi: std::array::from_fn(|k| ((origin[k] + size[k]) / c).ceil() as i32 + 1),
        }
    }

    fn dims(&self) -> [u32; 3] {
        std::array::from_fn(|k| (self.hi[k] - self.lo[k] + 1).max(1) as u32)
    }

    /// Nodes in the lattice.
    pub fn nodes(&self) -> u64 {
        self.dims().iter().map(|&d| d as u64).product()
    }
}

/// One frame's isosurface on the device: a triangle list and its draw arguments.
pub struct LevelSetVertices {
    /// Positions (m), one `vec4` a vertex.
    pub positions: wgpu::Buffer,
    /// Unit normals, one `vec4` a vertex.
    pub normals: wgpu::Buffer,
    /// Colour (linear RGB) and label, 16 bytes a vertex (the renderer's `MeshAttributes`).
    pub attributes: wgpu::Buffer,
    /// `draw_indirect`'s arguments: vertices, 1, 0, 0.
    pub args: wgpu::Buffer,
}

/// The extraction's passes and buffers.
pub struct LevelSetStage {
    pipelines: [wgpu::ComputePipeline; 4],
    groups: [wgpu::BindGroup; 2],
    outputs: [LevelSetVertices; 2],
    dims: [u32; 3],
    particles: u32,
}

/// What the level set is drawn with: the tissue colour and the label of material 0
/// (material i is labelled `label + i`).
#[derive(Clone, Copy, Debug)]
pub struct LevelSetLook {
    /// Linear RGB.
    pub colour: [f32; 3],
    /// Label of material 0.
    pub label: u32,
    /// Most triangles kept.
    pub capacity: u32,
}

impl LevelSetStage {
    /// The passes over the solver's `count` particles (its particle buffer and its
    /// per-particle constants: mass, rest volume, material) on `lattice`.
    pub fn new(
        device: &wgpu::Device,
        [particles_buffer, constants]: [&wgpu::Buffer; 2],
        count: u32,
        lattice: Lattice,
        look: LevelSetLook,
    ) -> LevelSetStage {
        use wgpu::util::DeviceExt;
        let dims = lattice.dims();
        let nodes = lattice.nodes();
        let module = particle_reader(device, "level set", SHADER);
        let mut uniform = [0u32; 16];
        uniform[..3].copy_from_slice(&lattice.lo.map(|v| v as u32));
        uniform[4..7].copy_from_slice(&dims);
        let cell = lattice.cell;
        uniform[8] = cell.to_bits();
        uniform[9] = (1.0 / (cell * cell * cell)).to_bits();
        uniform[10] = look.colour[0].to_bits();
        uniform[11] = look.colour[1].to_bits();
        uniform[12] = look.colour[2].to_bits();
        uniform[13] = look.label;
        uniform[14] = look.capacity;
        let init = |label, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
        };
        let uniform = init(
            "level set lattice",
            bytemuck::cast_slice(&uniform),
            wgpu::BufferUsages::UNIFORM,
        );
        let buffer = |label, size: u64, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size.max(16),
                usage,
                mapped_at_creation: false,
            })
        };
        let storage = wgpu::BufferUsages::STORAGE;
        let field = buffer("level set field", 4 * nodes, storage);
        let owner = buffer("level set owner", 4 * nodes, storage);
        let vertices = 3 * look.capacity as u64;
        let outputs = [0, 1].map(|_| LevelSetVertices {
            positions: buffer(
                "level set positions",
                16 * vertices,
                storage | wgpu::BufferUsages::VERTEX,
            ),
            normals: buffer(
                "level set normals",
                16 * vertices,
                storage | wgpu::BufferUsages::VERTEX,
            ),
            attributes: buffer(
                "level set attributes",
                16 * vertices,
                storage | wgpu::BufferUsages::VERTEX,
            ),
            args: buffer("level set draw", 16, storage | wgpu::BufferUsages::INDIRECT),
        });
        let counts = [0, 1].map(|_| buffer("level set count", 16, storage));
        let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let mut entries = vec![entry(0, wgpu::BufferBindingType::Uniform)];
        entries.extend(
            (1..10).map(|b| entry(b, wgpu::BufferBindingType::Storage { read_only: b <= 2 })),
        );
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("level set"),
            entries: &entries,
        });
        let pipelines = ["clear", "splat", "march", "draw_args"]
            .map(|entry| compute_pipeline(device, &module, entry, &layout));
        let groups = [0, 1].map(|slot| {
            let out = &outputs[slot];
            let buffers = [
                &uniform,
                particles_buffer,
                constants,
                &field,
                &owner,
                &counts[slot],
                &out.positions,
                &out.normals,
                &out.attributes,
                &out.args,
            ];
            bind_buffers(device, "level set", &layout, 0, &buffers)
        });
        LevelSetStage {
            pipelines,
            groups,
            outputs,
            dims,
            particles: count,
        }
    }

    /// Records the four passes at the end of a frame that ends the world's frame, into
    /// output set `slot`.
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, slot: usize) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("level set"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &self.groups[slot], &[]);
        let [nx, ny, nz] = self.dims.map(|d| d.div_ceil(4).max(1));
        let [clear, splat, march, args] = &self.pipelines;
        pass.set_pipeline(clear);
        pass.dispatch_workgroups(nx, ny, nz);
        pass.set_pipeline(splat);
        pass.dispatch_workgroups(self.particles.div_ceil(64).max(1), 1, 1);
        pass.set_pipeline(march);
        pass.dispatch_workgroups(nx, ny, nz);
        pass.set_pipeline(args);
        pass.dispatch_workgroups(1, 1, 1);
    }

    /// The triangles a frame wrote into `slot`.
    pub fn vertices(&self, slot: usize) -> &LevelSetVertices {
        &self.outputs[slot]
    }
}
