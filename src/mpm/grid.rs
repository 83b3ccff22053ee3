//! Background grid: layout in 4³-node blocks, and the boundary conditions applied on it.
//!
//! Nodes are stored block by block (64 nodes, 1 KiB per block) so that a particle's 27-node
//! stencil touches at most 8 blocks, a block can be cleared or updated as a unit, and work
//! follows the blocks particles occupy rather than the domain volume.

use super::Vec3;
use serde::{Deserialize, Serialize};

/// Nodes per block edge.
pub const BLOCK: usize = 4;
/// Nodes per block (64).
pub const NODES_PER_BLOCK: usize = BLOCK * BLOCK * BLOCK;
/// Grid nodes at each domain face that act as a slip wall.
pub const WALL_NODES: i32 = 2;

/// One grid node: momentum (then velocity after the grid update) and mass.
pub type Node = [f32; 4];

#[derive(Clone, Copy, Debug, PartialEq)]
/// The grid's placement and size: nodes stored in blocks of `BLOCK`³.
pub struct GridLayout {
    /// World position of node (0, 0, 0).
    pub origin: Vec3,
    /// Node spacing, m.
    pub dx: f32,
    /// 1 / `dx`, 1/m.
    pub inv_dx: f32,
    /// Nodes per axis (multiples of `BLOCK`).
    pub nodes: [usize; 3],
    /// Blocks per axis.
    pub blocks: [usize; 3],
}

impl GridLayout {
    /// A grid covering `[origin, origin + size]` with spacing `dx`, rounded up to whole blocks.
    pub fn new(origin: Vec3, size: Vec3, dx: f32) -> Self {
        let mut nodes = [0usize; 3];
        let mut blocks = [0usize; 3];
        for a in 0..3 {
            let cells = (size[a] / dx).ceil() as usize + 1;
            blocks[a] = cells.div_ceil(BLOCK).max(1);
            nodes[a] = blocks[a] * BLOCK;
        }
        GridLayout {
            origin,
            dx,
            inv_dx: 1.0 / dx,
            nodes,
            blocks,
        }
    }

    /// Number of blocks.
    pub fn block_count(&self) -> usize {
        self.blocks[0] * self.blocks[1] * self.blocks[2]
    }

    /// Number of nodes stored (whole blocks).
    pub fn node_count(&self) -> usize {
        self.block_count() * NODES_PER_BLOCK
    }

    #[inline(always)]
    /// Storage index of block (bx, by, bz).
    pub fn block_index(&self, bx: usize, by: usize, bz: usize) -> usize {
        (bx * self.blocks[1] + by) * self.blocks[2] + bz
    }

    /// Block coordinates of a block index.
    #[inline(always)]
    pub fn block_coords(&self, b: usize) -> [usize; 3] {
        let bz = b % self.blocks[2];
        let rest = b / self.blocks[2];
        [rest / self.blocks[1], rest % self.blocks[1], bz]
    }

    /// Storage index of node (i, j, k).
    #[inline(always)]
    pub fn node_index(&self, i: usize, j: usize, k: usize) -> usize {
        let block = self.block_index(i / BLOCK, j / BLOCK, k / BLOCK);
        block * NODES_PER_BLOCK + ((i % BLOCK) * BLOCK + (j % BLOCK)) * BLOCK + (k % BLOCK)
    }

    /// Node coordinates of storage slot `local` (0..64) in block `b`.
    #[inline(always)]
    pub fn node_coords(&self, b: usize, local: usize) -> [usize; 3] {
        let [bx, by, bz] = self.block_coords(b);
        [
            bx * BLOCK + local / (BLOCK * BLOCK),
            by * BLOCK + (local / BLOCK) % BLOCK,
            bz * BLOCK + local % BLOCK,
        ]
    }

    /// World position of node (i, j, k), m.
    pub fn node_position(&self, ijk: [usize; 3]) -> Vec3 {
        self.origin + Vec3::new(ijk[0] as f32, ijk[1] as f32, ijk[2] as f32) * self.dx
    }

    /// Range of grid coordinates (`(x - origin)/dx`) where a particle's stencil stays inside
    /// the grid: base = floor(g − 0.5) ≥ 0 and base + 2 ≤ n − 1.
    pub fn particle_bounds(&self) -> (Vec3, Vec3) {
        let lo = Vec3::repeat(1.0);
        let hi = Vec3::new(
            self.nodes[0] as f32 - 2.0,
            self.nodes[1] as f32 - 2.0,
            self.nodes[2] as f32 - 2.0,
        );
        (lo, hi)
    }
}

/// How tissue is held on the table plane.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "hold", rename_all = "snake_case")]
pub enum TableHold {
    /// Nodes on or below the table stick (zero velocity): the bottom face is bonded.
    Bonded,
    /// The table pushes back and resists sliding with Coulomb friction; tissue can lift off.
    Resting {
        /// Coulomb friction coefficient μ between tissue and table.
        friction: f32,
    },
}

/// Boundary conditions of the grid update.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Boundary {
    /// Height of the table plane (world z, m) and how tissue is held on it.
    pub table: Option<(f32, TableHold)>,
}
