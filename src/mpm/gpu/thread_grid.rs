//! Suture threads in the tissue on the GPU backend: the device's grid meets the threads
//! through the CPU's coupling ([`crate::mpm::cpu::thread_contact`]), the same code on both
//! backends, so the same binding, contact law, cutting and rod step.
//!
//! A frame with threads in the tissue is stepped substep by substep, each in two
//! submissions: P2G and the grid update on the device; the substep's list of active blocks
//! and the blocks within the threads' reach ([`ThreadContact::reach_box`]) read back; the
//! threads coupled to those nodes and their rods stepped on the host, as the CPU backend
//! does between its grid update and G2P; those blocks written back; then G2P and the
//! impulse reduction on the device. Blocks the substep's particles did not touch are zeroed
//! in the host copy, as they hold the nodes of an earlier substep, and so is every block
//! out of reach, which the coupling never reads.
//!
//! Cost: a round trip of the blocks in reach per substep (1 KiB a block each way) and a
//! wait for the device, only while a thread lies in the tissue; every other frame is one
//! submission as before. `auto` keeps such a scene on the CPU for that reason (see
//! `World::new`); `backend = "gpu"` asks for this path. On llvmpipe, `bench skip --only
//! thread --backend gpu` (a 100-segment thread through the resting 24,000-particle block)
//! steps at 0.92–0.95 of the time of the block alone (the CPU: 0.95), and
//! `run --headless --scene config/suture.toml --seconds 1` takes 80 s on the GPU backend
//! against 30 s on the CPU, with the same summary.
//!
//! Agreement (`cargo test --release --test thread_tissue the_gpu -- --nocapture`): a 7 cm
//! thread pulled 10 mm sideways through a 4 × 3 × 2 cm block drags it to within 2.6e-5 m of
//! the CPU's particles with fixed-point P2G (the same every run) and 1.5e-5 to 4.8e-5 m with
//! f32 atomics, the peak force within 0.1 % and 0.5 %; with a toughness of 1 J/m² it cuts
//! through on both, the particles within 4.4e-4 m, pulling under G_c times the block's
//! length. `tests/suture.rs` runs the shipped throw's first 2.5 s on both: the thread within
//! 0.25 mm, the particles within 0.08 mm, the wound gap within 0.011 mm.

use super::readback::map_read;
use super::resources::Resources;
use crate::mpm::cpu::thread_contact::{ThreadContact, TissueLimits};
use crate::mpm::grid::{Boundary, GridLayout, Node, BLOCK, NODES_PER_BLOCK};
use std::ops::Range;

/// The host's side of the GPU grid for the threads in the tissue.
pub struct ThreadGrid {
    /// The threads' coupling state (proxies, bindings, anchors), as on the CPU.
    pub contact: ThreadContact,
    boundary: Boundary,
    tissue: TissueLimits,
    /// The grid as the last substep's update left it, untouched blocks zeroed.
    nodes: Vec<Node>,
    /// Per block: whether the substep's particles wrote to it.
    touched: Vec<bool>,
    /// The blocks in the threads' reach this substep, as runs of consecutive indices.
    runs: Vec<Range<usize>>,
    /// Map-readable copy of: the indirect arguments (16 bytes, the first word the active
    /// block count), the active block list, the grid's nodes.
    staging: wgpu::Buffer,
}

/// Bytes before the active block list in the staging buffer.
const ARGS_BYTES: u64 = 16;

impl ThreadGrid {
    pub fn new(
        device: &wgpu::Device,
        layout: &GridLayout,
        boundary: Boundary,
        tissue: TissueLimits,
    ) -> Self {
        let blocks = layout.block_count();
        let nodes = layout.node_count();
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("thread grid readback"),
            size: ARGS_BYTES + Self::list_bytes(blocks) + Self::node_bytes(nodes),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        ThreadGrid {
            contact: ThreadContact::default(),
            boundary,
            tissue,
            nodes: vec![[0.0; 4]; nodes],
            touched: vec![false; blocks],
            runs: Vec::new(),
            staging,
        }
    }

    fn list_bytes(blocks: usize) -> u64 {
        (blocks * 4) as u64
    }

    fn node_bytes(nodes: usize) -> u64 {
        (nodes * std::mem::size_of::<Node>()) as u64
    }

    /// Lists the blocks within the threads' reach for the coming substep (the host copy
    /// of the last substep's zeroed).
    pub fn plan_reach(&mut self, layout: &GridLayout) {
        for run in self.runs.drain(..) {
            self.nodes[run.start * NODES_PER_BLOCK..run.end * NODES_PER_BLOCK].fill([0.0; 4]);
        }
        let Some((lo, hi)) = self.contact.reach_box(layout.dx) else {
            return;
        };
        let block = |x: f32, axis: usize| {
            let node = ((x - layout.origin[axis]) * layout.inv_dx).floor() as i64;
            node.clamp(0, layout.nodes[axis] as i64 - 1) as usize / BLOCK
        };
        let [from, to] = [lo, hi].map(|x| [0, 1, 2].map(|a| block(x[a], a)));
        for bx in from[0]..=to[0] {
            for by in from[1]..=to[1] {
                let first = layout.block_index(bx, by, from[2]);
                self.runs.push(first..first + to[2] - from[2] + 1);
            }
        }
    }

    /// Records the copies of the grid update's results into the staging buffer, each
    /// block at its own offset after the active block list.
    pub fn record_copy(&self, encoder: &mut wgpu::CommandEncoder, res: &Resources) {
        let list = Self::list_bytes(self.touched.len());
        encoder.copy_buffer_to_buffer(&res.args, 0, &self.staging, 0, ARGS_BYTES);
        encoder.copy_buffer_to_buffer(&res.active_blocks, 0, &self.staging, ARGS_BYTES, list);
        for run in &self.runs {
            let at = Self::node_bytes(run.start * NODES_PER_BLOCK);
            let bytes = Self::node_bytes(run.len() * NODES_PER_BLOCK);
            encoder.copy_buffer_to_buffer(
                &res.grid_v,
                at,
                &self.staging,
                ARGS_BYTES + list + at,
                bytes,
            );
        }
    }

    /// Waits for the copies [`ThreadGrid::record_copy`] recorded (submitted since), couples
    /// the threads to the grid over a substep of `dt` with `stepper` stepping their rods,
    /// and writes the blocks in reach back for G2P.
    pub fn couple(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        res: &Resources,
        layout: &GridLayout,
        dt: f32,
        stepper: &mut dyn crate::mpm::cpu::thread_contact::ThreadStepper,
    ) {
        let list = Self::list_bytes(self.touched.len()) as usize;
        {
            let bytes = map_read(device, &self.staging);
            let args: &[u32] = bytemuck::cast_slice(&bytes[..ARGS_BYTES as usize]);
            let count = (args[0] as usize).min(self.touched.len());
            let at = ARGS_BYTES as usize;
            let list: &[u32] = bytemuck::cast_slice(&bytes[at..at + list]);
            let nodes: &[Node] = bytemuck::cast_slice(&bytes[at + list.len() * 4..]);
            self.touched.fill(false);
            for &b in &list[..count] {
                self.touched[b as usize] = true;
            }
            for run in &self.runs {
                for b in run.clone() {
                    let slots = b * NODES_PER_BLOCK..(b + 1) * NODES_PER_BLOCK;
                    if self.touched[b] {
                        self.nodes[slots.clone()].copy_from_slice(&nodes[slots]);
                    } else {
                        self.nodes[slots].fill([0.0; 4]);
                    }
                }
            }
        }
        self.staging.unmap();
        let touched = &self.touched;
        self.contact.apply(
            layout,
            &self.boundary,
            &mut self.nodes,
            &|b| touched[b],
            dt,
            self.tissue,
            stepper,
        );
        for run in &self.runs {
            let slots = run.start * NODES_PER_BLOCK..run.end * NODES_PER_BLOCK;
            let at = Self::node_bytes(slots.start);
            queue.write_buffer(&res.grid_v, at, bytemuck::cast_slice(&self.nodes[slots]));
        }
    }
}
