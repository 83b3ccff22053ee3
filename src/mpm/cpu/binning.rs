//! Per-substep binning of particles into grid blocks, so that P2G can scatter in parallel
//! without atomics or locks.
//!
//! A particle whose stencil base node lies in block `b` writes only to blocks `b + {0,1}³`.
//! Blocks are coloured by the parity of their coordinates (8 colours); two blocks of one
//! colour are at least two blocks apart, so their particles' writes never overlap and a
//! colour's blocks can be processed concurrently. All buffers are sized at construction:
//! binning never allocates.

use crate::mpm::grid::GridLayout;

/// Particles of one occupied block: `order[start..end]`.
#[derive(Clone, Copy, Debug)]
pub struct BlockRange {
    pub start: u32,
    pub end: u32,
}

pub struct Binning {
    /// Block of each particle's stencil base.
    pub key: Vec<u32>,
    /// Particle indices grouped by block.
    pub order: Vec<u32>,
    /// Occupied blocks of each colour with their particle ranges.
    pub by_color: [Vec<BlockRange>; 8],
    /// Blocks any particle writes to this substep (occupied blocks and their +1 neighbours).
    pub touched: Vec<u32>,
    count: Vec<u32>,
    cursor: Vec<u32>,
    occupied: Vec<u32>,
    touched_stamp: Vec<u32>,
    generation: u32,
}

impl Binning {
    pub fn new(layout: &GridLayout, particles: usize) -> Self {
        let blocks = layout.block_count();
        Binning {
            key: vec![0; particles],
            order: vec![0; particles],
            // The largest colour holds ⌈bx/2⌉·⌈by/2⌉·⌈bz/2⌉ blocks.
            by_color: std::array::from_fn(|_| {
                Vec::with_capacity(layout.blocks.iter().map(|b| b.div_ceil(2)).product())
            }),
            touched: Vec::with_capacity(blocks),
            count: vec![0; blocks],
            cursor: vec![0; blocks],
            occupied: Vec::with_capacity(blocks),
            touched_stamp: vec![0; blocks],
            generation: 0,
        }
    }

    /// Holds `particles` particles from now on (allocates: only when splitting changed the
    /// count).
    pub fn resize(&mut self, particles: usize) {
        self.key.resize(particles, 0);
        self.order.resize(particles, 0);
    }

    /// Whether block `b` is among this substep's `touched` blocks (its nodes hold this
    /// substep's P2G; other blocks hold stale values).
    pub fn is_touched(&self, b: usize) -> bool {
        self.touched_stamp[b] == self.generation
    }

    /// Groups particles by `key` (already filled by the caller) and lists touched blocks.
    pub fn rebuild(&mut self, layout: &GridLayout) {
        self.generation = self.generation.wrapping_add(1);
        if self.generation == 0 {
            self.touched_stamp.fill(0);
            self.generation = 1;
        }
        self.occupied.clear();
        for &b in &self.key {
            let c = &mut self.count[b as usize];
            if *c == 0 {
                self.occupied.push(b);
            }
            *c += 1;
        }
        // Sorted blocks give a reproducible particle order, hence reproducible sums.
        self.occupied.sort_unstable();
        let mut running = 0u32;
        for &b in &self.occupied {
            self.cursor[b as usize] = running;
            running += self.count[b as usize];
        }
        for (p, &b) in self.key.iter().enumerate() {
            let c = &mut self.cursor[b as usize];
            self.order[*c as usize] = p as u32;
            *c += 1;
        }
        for list in &mut self.by_color {
            list.clear();
        }
        self.touched.clear();
        for &b in &self.occupied {
            let bu = b as usize;
            let end = self.cursor[bu];
            let start = end - self.count[bu];
            self.count[bu] = 0;
            let [bx, by, bz] = layout.block_coords(bu);
            let color = (bx & 1) << 2 | (by & 1) << 1 | (bz & 1);
            self.by_color[color].push(BlockRange { start, end });
            for nx in bx..(bx + 2).min(layout.blocks[0]) {
                for ny in by..(by + 2).min(layout.blocks[1]) {
                    for nz in bz..(bz + 2).min(layout.blocks[2]) {
                        let n = layout.block_index(nx, ny, nz);
                        if self.touched_stamp[n] != self.generation {
                            self.touched_stamp[n] = self.generation;
                            self.touched.push(n as u32);
                        }
                    }
                }
            }
        }
    }
}
