//! The structs Rust and WGSL share, declared once here (std430/uniform layout: vec3 and
//! mat3x3 columns padded to 16 bytes), and the packing of the host state into them.

use crate::mpm::material::MaterialModel;
use crate::mpm::{Mat3, MaterialParams, Particles, Vec3};
use crate::tools::{ContactModel, Shape, ToolKinematics};
use bytemuck::{Pod, Zeroable};

/// Declares a struct shared with WGSL once: the `#[repr(C)]` Rust struct, and its WGSL
/// declaration as `WGSL` (field names and order the same, each Rust type mapped by
/// `wgsl_type!`), which the shader prelude carries.
macro_rules! shared_struct {
    ($(#[$meta:meta])* pub struct $name:ident as $wgsl:literal {
        $($(#[$field_meta:meta])* pub $field:ident: $ty:tt,)*
    }) => {
        $(#[$meta])*
        #[repr(C)]
        #[derive(Clone, Copy, Pod, Zeroable)]
        pub struct $name {
            $($(#[$field_meta])* pub $field: $ty,)*
        }

        impl $name {
            /// The same struct declared in WGSL.
            pub const WGSL: &'static str = concat!(
                "struct ", $wgsl, " {\n",
                $("    ", stringify!($field), ": ", wgsl_type!($ty), ",\n",)*
                "}\n"
            );
        }
    };
}

pub(super) use shared_struct;

/// The WGSL type with the layout of a Rust field type (vec3 and mat3x3 columns padded to
/// 16 bytes, so only 4-wide vectors appear).
macro_rules! wgsl_type {
    (f32) => {
        "f32"
    };
    (u32) => {
        "u32"
    };
    ([f32; 4]) => {
        "vec4<f32>"
    };
    ([u32; 4]) => {
        "vec4<u32>"
    };
    ([[f32; 4]; 3]) => {
        "mat3x3<f32>"
    };
}
pub(super) use wgsl_type;

shared_struct! {
    /// Per-solver constants (uniform `sim`).
    pub struct SimUniform as "Sim" {
        pub origin_dx: [f32; 4],
        pub inv_dx: f32,
        pub n_particles: u32,
        pub max_speed: f32,
        pub n_tools: u32,
        /// Nodes per axis; w: block count.
        pub nodes: [u32; 4],
        /// Blocks per axis; w: the table (`TABLE_*`).
        pub blocks: [u32; 4],
        /// x: table height, y: table friction.
        pub table: [f32; 4],
        /// x: fixed-point scale, y: 1/scale, z: momentum unit, w: mass unit.
        pub fixed: [f32; 4],
        /// x: weight of APIC's affine momentum in P2G (1, or 0 for the PIC reference).
        pub transfer: [f32; 4],
    }
}

shared_struct! {
    /// One substep's (with PB-MPM: one iteration's) parameters (uniform `st`, dynamic offset).
    pub struct StepUniform as "Step" {
        pub dt: f32,
        pub substep: u32,
        pub pad: u32,
        /// PB-MPM over-relaxation.
        pub relaxation: f32,
        pub gravity: [f32; 4],
    }
}

shared_struct! {
    pub struct GpuParticle as "Particle" {
        /// w: damage (see `damage.wgsl`), 0 in a scene without toughness.
        pub x: [f32; 4],
        /// w: 0, or what tripped the guard (speed, −1 for non-finite).
        pub v: [f32; 4],
        pub c: [[f32; 4]; 3],
        pub f: [[f32; 4]; 3],
    }
}

shared_struct! {
    pub struct GpuMaterial as "Material" {
        /// [`NEO_HOOKEAN`] or [`FIXED_COROTATED`].
        pub model: u32,
        pub mu: f32,
        pub lambda: f32,
        pub damping: f32,
        pub density: f32,
        /// Damage onset energy (J/m³, see [`crate::mpm::damage::onset_energy`]); 0: the
        /// material does not tear.
        pub onset: f32,
        pub pad1: f32,
        pub pad2: f32,
    }
}

shared_struct! {
    pub struct GpuTool as "Tool" {
        pub rot: [[f32; 4]; 3],
        /// w: contact threshold.
        pub trans: [f32; 4],
        /// w: jaw opening.
        pub lin: [f32; 4],
        /// w: jaw rate.
        pub ang: [f32; 4],
        /// w: friction.
        pub aabb_min: [f32; 4],
        /// w: drag.
        pub aabb_max: [f32; 4],
        /// The shape's dimensions; a gripper's w: its grip ratio.
        pub shape: [f32; 4],
        /// x: shape (`*_KIND`); y: [`STICKY`] or 0; z: a mesh slicer's blade record in
        /// `blades` (`blade.rs`); w: a gripper's grip reach (f32 bits).
        pub kind: [u32; 4],
    }
}

/// `GpuTool::kind.x`: the tool's shape.
pub const SPHERE_KIND: u32 = 0;
pub const CAPSULE_KIND: u32 = 1;
pub const BOX_KIND: u32 = 2;
pub const GRIPPER_KIND: u32 = 3;
pub const NEEDLE_KIND: u32 = 4;
pub const SLICER_KIND: u32 = 5;
/// A slicer from a mesh file.
pub const MESH_SLICER_KIND: u32 = 6;
/// `GpuTool::kind.y` of a sticky tool (0: Coulomb contact).
pub const STICKY: u32 = 1;
/// `GpuMaterial::model`.
pub const NEO_HOOKEAN: u32 = 0;
pub const FIXED_COROTATED: u32 = 1;
/// `SimUniform::blocks.w`: no table, a bonded one, a resting one.
pub const TABLE_NONE: u32 = 0;
pub const TABLE_BONDED: u32 = 1;
pub const TABLE_RESTING: u32 = 2;

/// The codes above by their WGSL names, for the prelude.
pub const WGSL_CODES: [(&str, u32); 13] = [
    ("SPHERE_KIND", SPHERE_KIND),
    ("CAPSULE_KIND", CAPSULE_KIND),
    ("BOX_KIND", BOX_KIND),
    ("GRIPPER_KIND", GRIPPER_KIND),
    ("NEEDLE_KIND", NEEDLE_KIND),
    ("SLICER_KIND", SLICER_KIND),
    ("MESH_SLICER_KIND", MESH_SLICER_KIND),
    ("STICKY", STICKY),
    ("NEO_HOOKEAN", NEO_HOOKEAN),
    ("FIXED_COROTATED", FIXED_COROTATED),
    ("TABLE_NONE", TABLE_NONE),
    ("TABLE_BONDED", TABLE_BONDED),
    ("TABLE_RESTING", TABLE_RESTING),
];

/// Every shared struct's WGSL declaration, for the prelude.
pub const WGSL_STRUCTS: [&str; 5] = [
    SimUniform::WGSL,
    StepUniform::WGSL,
    GpuParticle::WGSL,
    GpuMaterial::WGSL,
    GpuTool::WGSL,
];

const _: () = assert!(std::mem::size_of::<GpuParticle>() == 128);
const _: () = assert!(std::mem::size_of::<GpuMaterial>() == 32);
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
            Shape::Sphere { radius } => ([radius, 0.0, 0.0, 0.0], SPHERE_KIND),
            Shape::Capsule {
                radius,
                half_length,
            } => ([radius, half_length, 0.0, 0.0], CAPSULE_KIND),
            Shape::Box { half_extents: h } => ([h[0], h[1], h[2], 0.0], BOX_KIND),
            Shape::Gripper {
                jaw_length,
                jaw_width,
                jaw_thickness,
            } => ([jaw_length, jaw_width, jaw_thickness, t.grip], GRIPPER_KIND),
            Shape::Needle {
                radius,
                arc_angle,
                wire_radius,
            } => ([radius, arc_angle, wire_radius, 0.0], NEEDLE_KIND),
            // The spine's contact and the edge's crack marking (crack.wgsl) read these.
            Shape::Slicer {
                length,
                height,
                thickness,
            } => ([length, height, thickness, 0.0], SLICER_KIND),
            // The blade itself is uploaded once (`blade.rs`); `Resources` sets kind.z to
            // its record.
            Shape::MeshSlicer { thickness, .. } => ([thickness, 0.0, 0.0, 0.0], MESH_SLICER_KIND),
        };
        let (friction, drag, sticky) = match t.contact {
            ContactModel::Coulomb { friction, drag } => (friction, drag, 0),
            ContactModel::Sticky => (0.0, 0.0, STICKY),
        };
        GpuTool {
            rot: m3(&t.rotation),
            trans: v4(t.translation, t.contact_threshold),
            lin: v4(t.linear_velocity, t.jaw),
            ang: v4(t.angular_velocity, t.jaw_rate),
            aabb_min: v4(t.aabb_min, friction),
            aabb_max: v4(t.aabb_max, drag),
            shape,
            kind: [kind, sticky, 0, t.grip_reach.to_bits()],
        }
    }
}

pub fn particles(p: &Particles) -> Vec<GpuParticle> {
    (0..p.len())
        .map(|i| GpuParticle {
            x: v4(p.x[i], p.damage.get(i).copied().unwrap_or(0.0)),
            v: v4(p.v[i], 0.0),
            c: m3(&p.c[i]),
            f: m3(&p.f[i]),
        })
        .collect()
}

pub fn unpack_particles(src: &[GpuParticle], p: &mut Particles) {
    for (i, g) in src.iter().enumerate() {
        p.x[i] = Vec3::new(g.x[0], g.x[1], g.x[2]);
        if let Some(d) = p.damage.get_mut(i) {
            *d = g.x[3];
        }
        p.v[i] = Vec3::new(g.v[0], g.v[1], g.v[2]);
        p.c[i] = unm3(&g.c);
        p.f[i] = unm3(&g.f);
    }
}

/// Per particle: its crack as a vec4 (zero for a particle not cut, and for all while the
/// host holds no crack state).
pub fn cracks(p: &Particles) -> Vec<[f32; 4]> {
    (0..p.len())
        .map(|i| v4(p.crack.get(i).copied().unwrap_or_else(Vec3::zeros), 0.0))
        .collect()
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

/// Per material: model, μ, λ, damping, density, and the damage onset `onsets` gives it
/// ([`crate::mpm::damage::onsets`]; none: 0, the material never damages).
pub fn materials(m: &[MaterialParams], onsets: &[f32]) -> Vec<GpuMaterial> {
    m.iter()
        .enumerate()
        .map(|(i, m)| GpuMaterial {
            model: match m.model {
                MaterialModel::NeoHookean => NEO_HOOKEAN,
                MaterialModel::FixedCorotated => FIXED_COROTATED,
            },
            mu: m.lame.mu,
            lambda: m.lame.lambda,
            damping: m.damping,
            density: m.density,
            onset: onsets.get(i).copied().unwrap_or(0.0),
            pad1: 0.0,
            pad2: 0.0,
        })
        .collect()
}
