//! Host-side images of the WGSL structs in `common.wgsl` (std430/uniform layout: vec3 and
//! mat3x3 columns padded to 16 bytes).

use crate::mpm::material::MaterialModel;
use crate::mpm::{Mat3, MaterialParams, Particles, Vec3};
use crate::tools::{ContactModel, Shape, ToolKinematics};
use bytemuck::{Pod, Zeroable};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct SimUniform {
    pub origin_dx: [f32; 4],
    pub inv_dx: f32,
    pub n_particles: u32,
    pub max_speed: f32,
    pub n_tools: u32,
    pub nodes: [u32; 4],
    pub blocks: [u32; 4],
    pub table: [f32; 4],
    pub fixed: [f32; 4],
    /// x: weight of APIC's affine momentum in P2G (1, or 0 for the PIC reference).
    pub transfer: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct StepUniform {
    pub dt: f32,
    pub substep: u32,
    pub pad: u32,
    /// PB-MPM over-relaxation.
    pub relaxation: f32,
    pub gravity: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct GpuParticle {
    pub x: [f32; 4],
    pub v: [f32; 4],
    pub c: [[f32; 4]; 3],
    pub f: [[f32; 4]; 3],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct GpuTool {
    pub rot: [[f32; 4]; 3],
    pub trans: [f32; 4],
    pub lin: [f32; 4],
    pub ang: [f32; 4],
    pub aabb_min: [f32; 4],
    pub aabb_max: [f32; 4],
    pub shape: [f32; 4],
    pub kind: [u32; 4],
}

const _: () = assert!(std::mem::size_of::<GpuParticle>() == 128);
const _: () = assert!(std::mem::size_of::<GpuTool>() == 160);
const _: () = assert!(std::mem::size_of::<SimUniform>() == 112);
const _: () = assert!(std::mem::size_of::<StepUniform>() == 32);

fn v4(v: Vec3, w: f32) -> [f32; 4] {
    [v.x, v.y, v.z, w]
}

fn m3(m: &Mat3) -> [[f32; 4]; 3] {
    [0, 1, 2].map(|c| v4(m.column(c).into_owned(), 0.0))
}

fn unm3(m: &[[f32; 4]; 3]) -> Mat3 {
    Mat3::from_columns(&m.map(|c| Vec3::new(c[0], c[1], c[2])))
}

/// A matrix from its three padded columns (the first three entries of `cols`).
pub fn unpack_mat3(cols: &[[f32; 4]]) -> Mat3 {
    unm3(&[cols[0], cols[1], cols[2]])
}

impl From<&ToolKinematics> for GpuTool {
    fn from(t: &ToolKinematics) -> Self {
        let (shape, kind) = match t.shape {
            Shape::Sphere { radius } => ([radius, 0.0, 0.0, 0.0], 0),
            Shape::Capsule {
                radius,
                half_length,
            } => ([radius, half_length, 0.0, 0.0], 1),
            Shape::Box { half_extents: h } => ([h[0], h[1], h[2], 0.0], 2),
            Shape::Gripper {
                jaw_length,
                jaw_width,
                jaw_thickness,
            } => ([jaw_length, jaw_width, jaw_thickness, 0.0], 3),
            Shape::Needle {
                radius,
                arc_angle,
                wire_radius,
            } => ([radius, arc_angle, wire_radius, 0.0], 4),
        };
        let (friction, drag, sticky) = match t.contact {
            ContactModel::Coulomb { friction, drag } => (friction, drag, 0),
            ContactModel::Sticky => (0.0, 0.0, 1),
        };
        GpuTool {
            rot: m3(&t.rotation),
            trans: v4(t.translation, t.contact_threshold),
            lin: v4(t.linear_velocity, t.jaw),
            ang: v4(t.angular_velocity, t.jaw_rate),
            aabb_min: v4(t.aabb_min, friction),
            aabb_max: v4(t.aabb_max, drag),
            shape,
            kind: [kind, sticky, 0, 0],
        }
    }
}

pub fn particles(p: &Particles) -> Vec<GpuParticle> {
    (0..p.len())
        .map(|i| GpuParticle {
            x: v4(p.x[i], 0.0),
            v: v4(p.v[i], 0.0),
            c: m3(&p.c[i]),
            f: m3(&p.f[i]),
        })
        .collect()
}

pub fn unpack_particles(src: &[GpuParticle], p: &mut Particles) {
    for (i, g) in src.iter().enumerate() {
        p.x[i] = Vec3::new(g.x[0], g.x[1], g.x[2]);
        p.v[i] = Vec3::new(g.v[0], g.v[1], g.v[2]);
        p.c[i] = unm3(&g.c);
        p.f[i] = unm3(&g.f);
    }
}

/// Per particle: mass, initial volume, material index (as f32 bits), 0.
pub fn constants(p: &Particles) -> Vec<[f32; 4]> {
    (0..p.len())
        .map(|i| {
            [
                p.mass[i],
                p.volume0[i],
                f32::from_bits(p.material[i] as u32),
                0.0,
            ]
        })
        .collect()
}

/// Per material: model, μ, λ, damping, density, padding.
pub fn materials(m: &[MaterialParams]) -> Vec<[f32; 8]> {
    m.iter()
        .map(|m| {
            let model = match m.model {
                MaterialModel::NeoHookean => 0u32,
                MaterialModel::FixedCorotated => 1,
            };
            [
                f32::from_bits(model),
                m.lame.mu,
                m.lame.lambda,
                m.damping,
                m.density,
                0.0,
                0.0,
                0.0,
            ]
        })
        .collect()
}
