//! The WGSL every stage starts with, generated from Rust: the constants, struct layouts and
//! resource bindings that host and shaders share are defined once, on the Rust side, and
//! reach the shaders only through this prelude.
//!
//! - Constants (`MAX_TOOLS`, `J_MIN`, block size, workgroup size, the statistics buffer's
//!   word indices, ...) are written as `const NAME: type = value;` from the Rust constants.
//! - Structs are declared by `shared_struct!` (`pack.rs`), which makes the Rust struct and
//!   its WGSL text from one field list.
//! - Bindings: WGSL needs a literal number in `@binding(N)` (neither a `const` nor an
//!   `override` may stand there), so the declarations themselves are generated. [`Binding`]
//!   (`resources.rs`) lists group 0's resources in binding order; the bind group layout,
//!   the bind group and the `@group(0) @binding(N) var<…> name: type;` lines here are all
//!   made from it. Shaders name a resource, never its number.
//!
//! A stage's source is then the prelude, `common.wgsl` (stencil, materials, tool SDFs,
//! contact, boundary, the guard), the P2G accumulation variant, and the stage's own file.

use super::blade;
use super::grid_update::IMPULSE_WORDS;
use super::pack::{WGSL_CODES, WGSL_STRUCTS};
use super::readback::word;
use super::resources::{Binding, ARGS_GROUP};
use super::tlmpm::TL_WORDS;
use super::WG;
use crate::mpm::cpu::captured::HELD_SHARE;
use crate::mpm::crack::MIN_OFFSET_CELLS;
use crate::mpm::damage::TORN;
use crate::mpm::grid::{Node, BLOCK, NODES_PER_BLOCK, WALL_NODES};
use crate::mpm::implicit_params::SLIP_THRESHOLD;
use crate::mpm::material::{J_MIN, ROTATION_ITERATIONS};
use crate::mpm::MAX_TOOLS;
use crate::tools::slicer::STENCIL_REACH_CELLS;
use std::fmt::Write;

/// The shared declarations for a P2G variant (f32 or i32 fixed-point accumulators), in a
/// solver that cuts (a scene with a slicer) or does not.
fn prelude(float_p2g: bool, cutting: bool, total_lagrangian: bool) -> String {
    let mut out = String::from("// Generated from Rust (src/mpm/gpu/prelude.rs).\n\n");
    let u32s: [(&str, usize); 8] = [
        ("WG", WG as usize),
        ("BLOCK", BLOCK),
        ("NODES_PER_BLOCK", NODES_PER_BLOCK),
        ("NODE_WORDS", std::mem::size_of::<Node>() / 4),
        ("MAX_TOOLS", MAX_TOOLS),
        ("IMPULSE_WORDS", IMPULSE_WORDS),
        ("WALL_NODES", WALL_NODES as usize),
        ("TL_WORDS", TL_WORDS),
    ];
    for (name, value) in u32s {
        writeln!(out, "const {name}: u32 = {value}u;").unwrap();
    }
    writeln!(out, "const J_MIN: f32 = {J_MIN:?};").unwrap();
    writeln!(out, "const TORN: f32 = {TORN:?};").unwrap();
    writeln!(out, "const SLIP_THRESHOLD: f32 = {SLIP_THRESHOLD:?};").unwrap();
    writeln!(out, "const HELD_SHARE: f32 = {HELD_SHARE:?};").unwrap();
    // Cutting: whether particles carry cracks, and the constants of crack.rs / slicer.rs.
    writeln!(out, "const CUTTING: bool = {cutting};").unwrap();
    // Total Lagrangian MPM: the blocks come from the rest configuration, and the nodes
    // carry its words (see `tlmpm.rs`).
    writeln!(out, "const TOTAL_LAGRANGIAN: bool = {total_lagrangian};").unwrap();
    // The codes the shared structs' fields take (pack.rs).
    for (name, value) in WGSL_CODES {
        writeln!(out, "const {name}: u32 = {value}u;").unwrap();
    }
    out.push_str(&blade::wgsl_constants());
    writeln!(
        out,
        "const STENCIL_REACH_CELLS: f32 = {STENCIL_REACH_CELLS:?};"
    )
    .unwrap();
    writeln!(out, "const MIN_OFFSET_CELLS: f32 = {MIN_OFFSET_CELLS:?};").unwrap();
    writeln!(
        out,
        "const ROTATION_ITERATIONS: i32 = {ROTATION_ITERATIONS};"
    )
    .unwrap();
    out.push_str("\n// Word indices of the per-frame statistics buffer (readback.rs).\n");
    for (name, value) in word::ALL {
        writeln!(out, "const S_{name}: u32 = {value}u;").unwrap();
    }
    writeln!(
        out,
        "const GUARD_NON_FINITE: u32 = {}u;",
        word::GUARD_NON_FINITE
    )
    .unwrap();
    writeln!(out, "const GUARD_RUNAWAY: u32 = {}u;", word::GUARD_RUNAWAY).unwrap();
    out.push('\n');
    for s in WGSL_STRUCTS {
        out.push_str(s);
        out.push('\n');
    }
    for b in Binding::ALL {
        writeln!(
            out,
            "@group(0) @binding({}) var<{}> {}: {};",
            b as u32,
            b.address_space(),
            b.name(),
            b.wgsl_type(float_p2g)
        )
        .unwrap();
    }
    // Indirect dispatch arguments: a group of their own, bound only by the stages that
    // write them, so that the indirect dispatches never see them as storage.
    writeln!(
        out,
        "@group({ARGS_GROUP}) @binding(0) var<storage, read_write> args: array<atomic<u32>>;"
    )
    .unwrap();
    out
}

/// Full source of one stage: the prelude, the shared functions, the damage model, the P2G
/// accumulation variant, and the stage itself.
fn shader_source(stage: &str, float_p2g: bool, cutting: bool, total_lagrangian: bool) -> String {
    let acc = if float_p2g {
        include_str!("acc_float.wgsl")
    } else {
        include_str!("acc_fixed.wgsl")
    };
    format!(
        "{}\n{}\n{}\n{acc}\n{stage}",
        prelude(float_p2g, cutting, total_lagrangian),
        include_str!("common.wgsl"),
        include_str!("damage.wgsl")
    )
}

/// Builds the stages' shader modules and compute pipelines on the solver's two pipeline
/// layouts (`resources.rs`).
pub struct StageBuilder<'a> {
    pub device: &'a wgpu::Device,
    pub float_p2g: bool,
    /// Whether the scene cuts (see [`super::crack`]).
    pub cutting: bool,
    /// Whether the solver is total Lagrangian MPM (see [`super::tlmpm`]).
    pub total_lagrangian: bool,
    /// Group 0 only.
    pub plain: &'a wgpu::PipelineLayout,
    /// Group 0 and the indirect arguments.
    pub with_args: &'a wgpu::PipelineLayout,
}

impl StageBuilder<'_> {
    pub fn module(&self, label: &str, stage: &str) -> wgpu::ShaderModule {
        self.device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(
                    shader_source(stage, self.float_p2g, self.cutting, self.total_lagrangian)
                        .into(),
                ),
            })
    }

    /// The pipeline of `entry`; `writes_args` for the stages that fill the indirect
    /// arguments (they see group 1).
    pub fn pipeline(
        &self,
        module: &wgpu::ShaderModule,
        entry: &str,
        writes_args: bool,
    ) -> wgpu::ComputePipeline {
        self.device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(if writes_args {
                    self.with_args
                } else {
                    self.plain
                }),
                module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
    }
}

#[cfg(test)]
mod tests {
    use super::shader_source;
    use wgpu::naga;

    /// Every stage's full source parses and validates, with either P2G variant, cutting or
    /// not, and the implicit solve's with f32 atomics (no device needed: a mismatch between
    /// the prelude and a stage shows here first).
    #[test]
    fn every_stage_source_validates() {
        let stages = [
            ("sparse", super::super::sparse::SOURCE),
            ("p2g", super::super::p2g::SOURCE),
            ("grid_update", super::super::grid_update::SOURCE),
            ("g2p", super::super::g2p::SOURCE),
            ("pbmpm", super::super::pbmpm::SOURCE),
            ("crack", super::super::crack::SOURCE),
            ("tlmpm", super::super::tlmpm::SOURCE),
        ];
        let variants = [
            (false, false, false),
            (true, false, false),
            (false, true, false),
            (true, true, false),
            (false, false, true),
            (true, false, true),
        ];
        for (float_p2g, cutting, total_lagrangian) in variants {
            for (name, stage) in stages {
                let source = shader_source(stage, float_p2g, cutting, total_lagrangian);
                let module = naga::front::wgsl::parse_str(&source)
                    .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&source)));
                naga::valid::Validator::new(
                    naga::valid::ValidationFlags::all(),
                    naga::valid::Capabilities::all(),
                )
                .validate(&module)
                .unwrap_or_else(|e| {
                    panic!(
                        "{name} (float P2G {float_p2g}, cutting {cutting}, total Lagrangian \
                         {total_lagrangian}): {e:?}"
                    )
                });
            }
        }
        // The implicit solve runs only with f32 atomics and without cuts.
        let source = shader_source(&super::super::implicit::source(), true, false, false);
        let module = naga::front::wgsl::parse_str(&source)
            .unwrap_or_else(|e| panic!("implicit: {}", e.emit_to_string(&source)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("implicit: {e:?}"));
    }
}
