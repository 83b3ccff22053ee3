//! G2P across particles in SIMD lanes, with the lane width chosen at run time.
//!
//! The reference G2P (`g2p_particle` in the parent module) works one particle at a time on
//! three-component vectors, which leaves most of a vector register idle and spends its
//! time shuffling. Here a group of 4, 8 or 16 particles is one step: every quantity is an
//! array with one lane per particle (structure of arrays), so each line of the arithmetic
//! is one vector instruction over the group. The stencil's node velocities are gathered per
//! lane; the rest (weights, the 27-node sums, B, C, the F update, damping, the guard's
//! tests) runs lane-parallel.
//!
//! **Same particles to the bit**: each lane performs exactly the reference's operations in
//! the reference's order (no fused multiply-add, which would round differently), so every
//! path agrees with the reference exactly; the test below holds them to that on a deformed,
//! moving block. A lane whose result the guard would stop (non-finite, or faster than the
//! limit) is left untouched and redone by the reference, which reports it as before.
//!
//! **Runtime dispatch**: one source, compiled three times. [`TransferPath::best`] asks the
//! CPU once (`is_x86_feature_detected!`): AVX-512 gets 16 lanes in zmm registers, AVX2 8
//! in ymm, and every x86-64 (SSE2) or other target 4; the kernel is `#[inline(always)]`
//! into a `#[target_feature]` function per width, so a plain `cargo build --release` binary
//! runs the widest path the machine has. Once a slicer has cut (the particles carry
//! cracks, and a stencil a crack crosses skips nodes), G2P runs the reference throughout;
//! so do a chunk's last particles short of a whole group.
//!
//! Total Lagrangian MPM's G2P (`tl_gather_groups`) runs the same way: its rest stencil's
//! weights and gradients, and the velocities and FLIP changes of the nodes its cached
//! stencil names, lane-parallel.

use super::tlmpm::{TlG2pStep, FLIP};
use super::{G2pStep, G2pTally};
use crate::mpm::grid::BLOCK;
use crate::mpm::Particles;
use crate::mpm::{Mat3, Vec3};
use rayon::prelude::*;

/// How G2P, and total Lagrangian P2G's node sums (see [`super::tl_node_sums`]), run on
/// the CPU (`bench throughput --transfer` names them).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TransferPath {
    /// One particle at a time: the reference every lane path equals.
    Scalar,
    /// Groups of 4 particles (SSE2: every x86-64; other targets' baseline vectors).
    Lanes4,
    /// Groups of 8 (AVX2).
    Lanes8,
    /// Groups of 16 (AVX-512).
    Lanes16,
}

impl TransferPath {
    /// The widest path this CPU runs.
    pub fn best() -> Self {
        *Self::available()
            .last()
            .expect("the scalar path always runs")
    }

    /// Every path this CPU runs, narrowest first.
    pub fn available() -> Vec<Self> {
        let mut paths = vec![TransferPath::Scalar, TransferPath::Lanes4];
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                paths.push(TransferPath::Lanes8);
            }
            if std::arch::is_x86_feature_detected!("avx512f") {
                paths.push(TransferPath::Lanes16);
            }
        }
        paths
    }

    /// The name `bench throughput --transfer` takes.
    pub fn key(self) -> &'static str {
        match self {
            TransferPath::Scalar => "scalar",
            TransferPath::Lanes4 => "lanes4",
            TransferPath::Lanes8 => "lanes8",
            TransferPath::Lanes16 => "lanes16",
        }
    }

    /// Particles per group.
    pub fn lanes(self) -> usize {
        match self {
            TransferPath::Scalar => 1,
            TransferPath::Lanes4 => 4,
            TransferPath::Lanes8 => 8,
            TransferPath::Lanes16 => 16,
        }
    }
}

/// One chunk of the particle arrays, as G2P writes it.
pub(super) struct Chunk<'a> {
    pub xs: &'a mut [Vec3],
    pub vs: &'a mut [Vec3],
    pub cs: &'a mut [Mat3],
    pub fs: &'a mut [Mat3],
    pub mats: &'a [u16],
}

/// G2P of the chunk's whole groups on `path`; returns how many particles from the chunk's
/// start it covered. Particles among them that the reference must redo (the guard would
/// stop them) are pushed to `redo` as chunk indices, untouched.
pub(super) fn gather_groups(
    path: TransferPath,
    step: &G2pStep,
    chunk: Chunk,
    tally: &mut G2pTally,
    redo: &mut Vec<u32>,
) -> usize {
    // Float indices into the grid are kept below 2³¹: the gather instructions take signed
    // 32-bit indices (so a vector holds as many as it holds floats).
    if step.grid.len() > (i32::MAX / 4) as usize {
        return 0;
    }
    match path {
        TransferPath::Scalar => 0,
        TransferPath::Lanes4 => groups::<4>(load_lanes, step, chunk, tally, redo),
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `available` lists this path only where the CPU has AVX2.
        TransferPath::Lanes8 => unsafe { groups_avx2(step, chunk, tally, redo) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `available` lists this path only where the CPU has AVX-512F.
        TransferPath::Lanes16 => unsafe { groups_avx512(step, chunk, tally, redo) },
        #[cfg(not(target_arch = "x86_64"))]
        _ => groups::<4>(load_lanes, step, chunk, tally, redo),
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn groups_avx2(
    step: &G2pStep,
    chunk: Chunk,
    tally: &mut G2pTally,
    redo: &mut Vec<u32>,
) -> usize {
    groups::<8>(load_avx2, step, chunk, tally, redo)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn groups_avx512(
    step: &G2pStep,
    chunk: Chunk,
    tally: &mut G2pTally,
    redo: &mut Vec<u32>,
) -> usize {
    groups::<16>(load_avx512, step, chunk, tally, redo)
}

/// Loads `grid[node[l] + k]` into lane l: the stencil's node velocities, one component at a
/// time. The portable loader reads lane by lane; AVX2 and AVX-512 have gather instructions
/// (one instruction for the group, where the compiler otherwise inserts lane by lane). A
/// 128-bit load a lane and 4×4 transposes instead measured slower here (10.8–10.9 against
/// 11.7–11.9 M particle-substeps/s in `bench throughput`), unlike total Lagrangian MPM's
/// six-float nodes (`NodeLoad`).
///
/// # Safety
/// Every `node[l] + k` must index a float of the grid `grid` points to.
type LaneLoad<const L: usize> = unsafe fn(*const f32, &[u32; L], usize) -> [f32; L];

unsafe fn load_lanes<const L: usize>(grid: *const f32, node: &[u32; L], k: usize) -> [f32; L] {
    // SAFETY: the caller's contract (LaneLoad).
    std::array::from_fn(|l| unsafe { *grid.add(node[l] as usize + k) })
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn load_avx2(grid: *const f32, node: &[u32; 8], k: usize) -> [f32; 8] {
    use std::arch::x86_64::*;
    // SAFETY: the caller's contract (LaneLoad); indices below 2³¹ (`gather_groups`).
    unsafe {
        let idx = _mm256_loadu_si256(node.as_ptr() as *const __m256i);
        std::mem::transmute::<__m256, [f32; 8]>(_mm256_i32gather_ps::<4>(grid.add(k), idx))
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn load_avx512(grid: *const f32, node: &[u32; 16], k: usize) -> [f32; 16] {
    use std::arch::x86_64::*;
    // SAFETY: the caller's contract (LaneLoad); indices below 2³¹ (`gather_groups`).
    unsafe {
        let idx = _mm512_loadu_si512(node.as_ptr() as *const __m512i);
        std::mem::transmute::<__m512, [f32; 16]>(_mm512_i32gather_ps::<4>(idx, grid.add(k)))
    }
}

/// Loads the six floats of total Lagrangian MPM's node `node[l]` (a float index) into lane
/// l of six arrays: velocity after the grid update, then its change.
///
/// # Safety
/// Eight floats from every `node[l]` must lie in the array `velocity` points to (the
/// AVX2 loader reads a whole 256-bit row per lane and transposes).
type NodeLoad<const L: usize> = unsafe fn(*const f32, &[u32; L]) -> [[f32; L]; 6];

unsafe fn load_nodes<const L: usize>(velocity: *const f32, node: &[u32; L]) -> [[f32; L]; 6] {
    // SAFETY: the caller's contract (NodeLoad).
    std::array::from_fn(|k| std::array::from_fn(|l| unsafe { *velocity.add(node[l] as usize + k) }))
}

/// Eight rows of eight floats, transposed: row l's float k goes to lane l of column k.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn transpose8(r: [std::arch::x86_64::__m256; 8]) -> [std::arch::x86_64::__m256; 8] {
    use std::arch::x86_64::*;
    let t0 = _mm256_unpacklo_ps(r[0], r[1]);
    let t1 = _mm256_unpackhi_ps(r[0], r[1]);
    let t2 = _mm256_unpacklo_ps(r[2], r[3]);
    let t3 = _mm256_unpackhi_ps(r[2], r[3]);
    let t4 = _mm256_unpacklo_ps(r[4], r[5]);
    let t5 = _mm256_unpackhi_ps(r[4], r[5]);
    let t6 = _mm256_unpacklo_ps(r[6], r[7]);
    let t7 = _mm256_unpackhi_ps(r[6], r[7]);
    let u0 = _mm256_shuffle_ps::<0x44>(t0, t2);
    let u1 = _mm256_shuffle_ps::<0xEE>(t0, t2);
    let u2 = _mm256_shuffle_ps::<0x44>(t1, t3);
    let u3 = _mm256_shuffle_ps::<0xEE>(t1, t3);
    let u4 = _mm256_shuffle_ps::<0x44>(t4, t6);
    let u5 = _mm256_shuffle_ps::<0xEE>(t4, t6);
    let u6 = _mm256_shuffle_ps::<0x44>(t5, t7);
    let u7 = _mm256_shuffle_ps::<0xEE>(t5, t7);
    [
        _mm256_permute2f128_ps::<0x20>(u0, u4),
        _mm256_permute2f128_ps::<0x20>(u1, u5),
        _mm256_permute2f128_ps::<0x20>(u2, u6),
        _mm256_permute2f128_ps::<0x20>(u3, u7),
        _mm256_permute2f128_ps::<0x31>(u0, u4),
        _mm256_permute2f128_ps::<0x31>(u1, u5),
        _mm256_permute2f128_ps::<0x31>(u2, u6),
        _mm256_permute2f128_ps::<0x31>(u3, u7),
    ]
}

/// Eight lanes' nodes: one 256-bit load a lane and a transpose, in place of six gathers
/// (`bench throughput --method tl_mpm --frames 10`, this AVX-512 machine, against the build
/// before the lanes: 4.79–4.82 → 5.61–5.65 M particle-substeps/s; with gathers, 4.69–4.78
/// → 4.99–5.06).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn load_nodes_avx2(velocity: *const f32, node: &[u32; 8]) -> [[f32; 8]; 6] {
    use std::arch::x86_64::*;
    // SAFETY: the caller's contract (NodeLoad).
    let rows = std::array::from_fn(|l| unsafe { _mm256_loadu_ps(velocity.add(node[l] as usize)) });
    let columns = transpose8(rows);
    // SAFETY: __m256 and [f32; 8] have the same size, and every bit pattern is a float.
    std::array::from_fn(|k| unsafe { std::mem::transmute::<__m256, [f32; 8]>(columns[k]) })
}

/// Sixteen lanes' nodes: the eight-lane loader on each half.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn load_nodes_avx512(velocity: *const f32, node: &[u32; 16]) -> [[f32; 16]; 6] {
    let (low, high) = node.split_at(8);
    // SAFETY: the caller's contract (NodeLoad), half by half.
    let (low, high) = unsafe {
        (
            load_nodes_avx2(velocity, low.try_into().unwrap()),
            load_nodes_avx2(velocity, high.try_into().unwrap()),
        )
    };
    // Copied half by half: a per-lane choice here was left as a call per element.
    let mut out = [[0.0f32; 16]; 6];
    for (column, (low, high)) in out.iter_mut().zip(low.iter().zip(&high)) {
        column[..8].copy_from_slice(low);
        column[8..].copy_from_slice(high);
    }
    out
}

/// One value per lane.
type Lanes<const L: usize> = [f32; L];

/// `moved` held within [lo, hi] the way the reference's nalgebra `sup` then `inf` do it,
/// comparison for comparison.
#[inline(always)]
fn keep_inside(moved: f32, lo: f32, hi: f32) -> f32 {
    let above = if moved >= lo { moved } else { lo };
    if above <= hi {
        above
    } else {
        hi
    }
}

/// Particles per parallel task of G2P.
const CHUNK: usize = 256;

/// One particle as G2P writes it: position, velocity, affine velocity, F.
pub(super) type ParticleMut<'a> = (&'a mut Vec3, &'a mut Vec3, &'a mut Mat3, &'a mut Mat3);

/// G2P over all particles in parallel chunks: `groups(first, chunk, tally, redo)` takes the
/// whole lane groups of the chunk whose first particle is `first` and returns how many
/// particles from its start it covered, pushing those it leaves to the reference into
/// `redo`; `one(index, particle, material, tally)` is the reference for one particle, run
/// for those and for the chunk's tail.
pub(super) fn in_chunks(
    particles: &mut Particles,
    groups: impl Fn(usize, Chunk, &mut G2pTally, &mut Vec<u32>) -> usize + Sync + Send,
    one: impl Fn(usize, ParticleMut, u16, &mut G2pTally) + Sync + Send,
) -> G2pTally {
    particles
        .x
        .par_chunks_mut(CHUNK)
        .zip(particles.v.par_chunks_mut(CHUNK))
        .zip(particles.c.par_chunks_mut(CHUNK))
        .zip(particles.f.par_chunks_mut(CHUNK))
        .zip(particles.material.par_chunks(CHUNK))
        .enumerate()
        .fold(
            G2pTally::default,
            |mut tally, (chunk, ((((xs, vs), cs), fs), mats))| {
                let first = chunk * CHUNK;
                // Empty unless the guard stops a particle: nothing is allocated otherwise.
                let mut redo = Vec::new();
                let arrays = Chunk {
                    xs,
                    vs,
                    cs,
                    fs,
                    mats,
                };
                let grouped = groups(first, arrays, &mut tally, &mut redo);
                for i in redo
                    .into_iter()
                    .map(|i| i as usize)
                    .chain(grouped..xs.len())
                {
                    let particle = (&mut xs[i], &mut vs[i], &mut cs[i], &mut fs[i]);
                    one(first + i, particle, mats[i], &mut tally);
                }
                tally
            },
        )
        .reduce(G2pTally::default, G2pTally::merge)
}

/// The kernel: every whole group of `L` particles of the chunk.
#[inline(always)]
fn groups<const L: usize>(
    load: LaneLoad<L>,
    step: &G2pStep,
    chunk: Chunk,
    tally: &mut G2pTally,
    redo: &mut Vec<u32>,
) -> usize {
    let layout = &step.layout;
    let whole = chunk.xs.len() / L * L;
    let stride = [
        (layout.blocks[1] * layout.blocks[2] * BLOCK * BLOCK * BLOCK) as u32,
        (layout.blocks[2] * BLOCK * BLOCK * BLOCK) as u32,
        (BLOCK * BLOCK * BLOCK) as u32,
    ];
    let local = [(BLOCK * BLOCK) as u32, BLOCK as u32, 1];
    let bs = BLOCK as u32;
    let grid = step.grid.as_ptr() as *const f32;
    let (origin, inv_dx, dx, dt) = (layout.origin, layout.inv_dx, layout.dx, step.dt);
    for start in (0..whole).step_by(L) {
        let xs: &mut [Vec3; L] = (&mut chunk.xs[start..start + L]).try_into().unwrap();
        let vs: &mut [Vec3; L] = (&mut chunk.vs[start..start + L]).try_into().unwrap();
        let cs: &mut [Mat3; L] = (&mut chunk.cs[start..start + L]).try_into().unwrap();
        let fs: &mut [Mat3; L] = (&mut chunk.fs[start..start + L]).try_into().unwrap();
        let mats: &[u16; L] = (&chunk.mats[start..start + L]).try_into().unwrap();

        // Stencil (kernel::Stencil::new per lane): grid position, fx, weights, and each
        // axis's three storage offsets (super::axis_offsets).
        let mut g = [[0.0f32; L]; 3];
        let mut fx = [[0.0f32; L]; 3];
        let mut w = [[[0.0f32; L]; 3]; 3]; // w[node a][axis][lane]
        let mut off = [[[0u32; L]; 3]; 3]; // off[axis][node a][lane]
        for k in 0..3 {
            for l in 0..L {
                let gk = (xs[l][k] - origin[k]) * inv_dx;
                let base_f = (gk - 0.5) as i32 as f32;
                let f = gk - base_f;
                let t0 = 1.5 - f;
                let t1 = f - 1.0;
                let t2 = f - 0.5;
                g[k][l] = gk;
                fx[k][l] = f;
                w[0][k][l] = 0.5 * t0 * t0;
                w[1][k][l] = 0.75 - t1 * t1;
                w[2][k][l] = 0.5 * t2 * t2;
                let base = base_f as i32 as u32;
                for (a, off) in off[k].iter_mut().enumerate() {
                    let n = base.wrapping_add(a as u32);
                    off[l] = (n / bs) * stride[k] + (n % bs) * local[k];
                }
            }
        }
        // The stencil's last node has each group's largest index: all inside, or the
        // reference takes the group (and its bounds checks).
        let [x_last, y_last, z_last] = [off[0][2], off[1][2], off[2][2]];
        let inside = (0..L).all(|l| {
            (x_last[l] as usize + y_last[l] as usize + z_last[l] as usize) < step.grid.len()
        });
        if !inside {
            redo.extend((start..start + L).map(|i| i as u32));
            continue;
        }

        // The gather (super::gather): Σ w·v and B's columns [Σ a·wv, Σ b·wv, Σ c·wv].
        let mut v = [[0.0f32; L]; 3];
        let mut b = [[[0.0f32; L]; 3]; 3]; // b[column][component][lane]
        for a in 0..3 {
            let mut sum_a = [[0.0f32; L]; 3];
            for bb in 0..3 {
                let mut wab: Lanes<L> = [0.0; L];
                for l in 0..L {
                    wab[l] = w[a][0][l] * w[bb][1][l];
                }
                let mut sum_b = [[0.0f32; L]; 3];
                let mut wv = [[[0.0f32; L]; 3]; 3]; // wv[node c][component][lane]
                for (c, wv) in wv.iter_mut().enumerate() {
                    let mut node: [u32; L] = [0; L];
                    for l in 0..L {
                        node[l] = (off[0][a][l] + off[1][bb][l] + off[2][c][l]) * 4;
                    }
                    // SAFETY: node + 2 < 4·grid.len(): checked above for the stencil's last
                    // node, and offsets grow with a, b and c.
                    let node_v: [Lanes<L>; 3] =
                        std::array::from_fn(|k| unsafe { load(grid, &node, k) });
                    let mut wc: Lanes<L> = [0.0; L];
                    for l in 0..L {
                        wc[l] = wab[l] * w[c][2][l];
                    }
                    for k in 0..3 {
                        for l in 0..L {
                            wv[k][l] = node_v[k][l] * wc[l];
                            sum_b[k][l] += wv[k][l];
                        }
                    }
                }
                for k in 0..3 {
                    for l in 0..L {
                        b[2][k][l] = (b[2][k][l] + wv[1][k][l]) + (wv[2][k][l] + wv[2][k][l]);
                        sum_a[k][l] += sum_b[k][l];
                        if bb == 1 {
                            b[1][k][l] += sum_b[k][l];
                        } else if bb == 2 {
                            b[1][k][l] += sum_b[k][l] + sum_b[k][l];
                        }
                    }
                }
            }
            for k in 0..3 {
                for l in 0..L {
                    v[k][l] += sum_a[k][l];
                    if a == 1 {
                        b[0][k][l] += sum_a[k][l];
                    } else if a == 2 {
                        b[0][k][l] += sum_a[k][l] + sum_a[k][l];
                    }
                }
            }
        }

        // C = (B − v fxᵀ)·4/dx (APIC), then the move, F and damping (super::g2p_particle).
        let apic = 4.0 * inv_dx;
        let mut c_new = [[[0.0f32; L]; 3]; 3]; // c_new[column][row][lane]
        for (col, c_col) in c_new.iter_mut().enumerate() {
            for (r, c_rc) in c_col.iter_mut().enumerate() {
                for l in 0..L {
                    c_rc[l] = (b[col][r][l] - v[r][l] * fx[col][l]) * apic;
                }
            }
        }
        let mut f_new = [[[0.0f32; L]; 3]; 3]; // f_new[column][row][lane]
        let mut clamped = [false; L];
        if step.integrate {
            let move_scale = dt * inv_dx;
            for k in 0..3 {
                for l in 0..L {
                    let moved = g[k][l] + v[k][l] * move_scale;
                    let inside = keep_inside(moved, step.lo[k], step.hi[k]);
                    clamped[l] |= inside != moved;
                    g[k][l] = inside;
                }
            }
            // F ← (I + C·dt)·F, summed over the inner index in nalgebra's order.
            let mut step_m = [[[0.0f32; L]; 3]; 3];
            for col in 0..3 {
                for r in 0..3 {
                    let identity = if r == col { 1.0 } else { 0.0 };
                    for l in 0..L {
                        step_m[col][r][l] = identity + c_new[col][r][l] * dt;
                    }
                }
            }
            for (col, f_col) in f_new.iter_mut().enumerate() {
                for (r, f_rc) in f_col.iter_mut().enumerate() {
                    for l in 0..L {
                        let f = &fs[l];
                        f_rc[l] = step_m[0][r][l] * f[(0, col)]
                            + step_m[1][r][l] * f[(1, col)]
                            + step_m[2][r][l] * f[(2, col)];
                    }
                }
            }
            for l in 0..L {
                let damping = step.materials[mats[l] as usize].damping;
                if damping > 0.0 {
                    let divisor = 1.0 + damping * dt;
                    for v in &mut v {
                        v[l] /= divisor;
                    }
                }
            }
        }

        // The guard's tests, then the stores of every lane that passes them.
        for l in 0..L {
            let speed = (v[0][l] * v[0][l] + v[1][l] * v[1][l] + v[2][l] * v[2][l]).sqrt();
            let mut finite = speed.is_finite();
            for col in 0..3 {
                for r in 0..3 {
                    finite &= c_new[col][r][l].is_finite();
                    finite &= if step.integrate {
                        f_new[col][r][l].is_finite()
                    } else {
                        fs[l][(r, col)].is_finite()
                    };
                }
                finite &= g[col][l].is_finite();
            }
            if !finite || speed > step.max_speed {
                redo.push((start + l) as u32);
                continue;
            }
            tally.max_speed = tally.max_speed.max(speed);
            tally.clamped += clamped[l] as u32;
            vs[l] = Vec3::new(v[0][l], v[1][l], v[2][l]);
            cs[l] = Mat3::from_fn(|r, col| c_new[col][r][l]);
            if step.integrate {
                xs[l] = origin + Vec3::new(g[0][l], g[1][l], g[2][l]) * dx;
                fs[l] = Mat3::from_fn(|r, col| f_new[col][r][l]);
            }
        }
    }
    whole
}

/// Total Lagrangian MPM's G2P (`tlmpm::tl_g2p_particle`) on the chunk's whole groups on
/// `path` (particle `first` is the chunk's first): the rest stencil's weights and gradients,
/// the node velocities and their changes gathered through the cached stencil nodes, then
/// FLIP/PIC, the move and F. Returns how many particles from the chunk's start it covered;
/// particles among them the reference must redo are pushed to `redo`, untouched.
pub(super) fn tl_gather_groups(
    path: TransferPath,
    step: &TlG2pStep,
    first: usize,
    chunk: Chunk,
    tally: &mut G2pTally,
    redo: &mut Vec<u32>,
) -> usize {
    // Six floats a node, indexed in 32 bits.
    if step.velocity.len() > (u32::MAX / 6) as usize {
        return 0;
    }
    match path {
        TransferPath::Scalar => 0,
        TransferPath::Lanes4 => tl_groups::<4>(load_nodes, step, first, chunk, tally, redo),
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `available` lists this path only where the CPU has AVX2.
        TransferPath::Lanes8 => unsafe { tl_groups_avx2(step, first, chunk, tally, redo) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `available` lists this path only where the CPU has AVX-512F.
        TransferPath::Lanes16 => unsafe { tl_groups_avx512(step, first, chunk, tally, redo) },
        #[cfg(not(target_arch = "x86_64"))]
        _ => tl_groups::<4>(load_nodes, step, first, chunk, tally, redo),
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn tl_groups_avx2(
    step: &TlG2pStep,
    first: usize,
    chunk: Chunk,
    tally: &mut G2pTally,
    redo: &mut Vec<u32>,
) -> usize {
    tl_groups::<8>(load_nodes_avx2, step, first, chunk, tally, redo)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn tl_groups_avx512(
    step: &TlG2pStep,
    first: usize,
    chunk: Chunk,
    tally: &mut G2pTally,
    redo: &mut Vec<u32>,
) -> usize {
    tl_groups::<16>(load_nodes_avx512, step, first, chunk, tally, redo)
}

/// The total Lagrangian kernel: every whole group of `L` particles of the chunk.
#[inline(always)]
fn tl_groups<const L: usize>(
    load: NodeLoad<L>,
    step: &TlG2pStep,
    first: usize,
    chunk: Chunk,
    tally: &mut G2pTally,
    redo: &mut Vec<u32>,
) -> usize {
    let layout = &step.layout;
    let whole = chunk.xs.len() / L * L;
    let velocity = step.velocity.as_ptr() as *const f32;
    let (origin, inv_dx, dx, dt) = (layout.origin, layout.inv_dx, layout.dx, step.dt);
    for start in (0..whole).step_by(L) {
        let xs: &mut [Vec3; L] = (&mut chunk.xs[start..start + L]).try_into().unwrap();
        let vs: &mut [Vec3; L] = (&mut chunk.vs[start..start + L]).try_into().unwrap();
        let cs: &mut [Mat3; L] = (&mut chunk.cs[start..start + L]).try_into().unwrap();
        let fs: &mut [Mat3; L] = (&mut chunk.fs[start..start + L]).try_into().unwrap();
        let mats: &[u16; L] = (&chunk.mats[start..start + L]).try_into().unwrap();
        let at = first + start;
        let rest: &[Vec3; L] = (&step.rest[at..at + L]).try_into().unwrap();
        let nodes: &[[u32; 27]; L] = (&step.stencil_nodes[at..at + L]).try_into().unwrap();

        // The rest stencil (kernel::Stencil::new and tlmpm::weight_derivatives per lane).
        let mut w = [[[0.0f32; L]; 3]; 3]; // w[node a][axis][lane]
        let mut dw = [[[0.0f32; L]; 3]; 3];
        for k in 0..3 {
            for l in 0..L {
                let gk = (rest[l][k] - origin[k]) * inv_dx;
                let f = gk - (gk - 0.5) as i32 as f32;
                let (t0, t1, t2) = (1.5 - f, f - 1.0, f - 0.5);
                w[0][k][l] = 0.5 * t0 * t0;
                w[1][k][l] = 0.75 - t1 * t1;
                w[2][k][l] = 0.5 * t2 * t2;
                dw[0][k][l] = f - 1.5;
                dw[1][k][l] = (f - 1.0) * -2.0;
                dw[2][k][l] = f - 0.5;
            }
        }

        // PIC velocity, FLIP's change and the velocity gradient (tlmpm::for_stencil_weights
        // order: node j = 9a + 3b + c).
        let mut v_pic = [[0.0f32; L]; 3];
        let mut dv = [[0.0f32; L]; 3];
        let mut grad_v = [[[0.0f32; L]; 3]; 3]; // grad_v[column][row][lane]
        for a in 0..3 {
            for b in 0..3 {
                for c in 0..3 {
                    let j = 9 * a + 3 * b + c;
                    let mut node: [u32; L] = [0; L];
                    for l in 0..L {
                        node[l] = nodes[l][j] * 6;
                    }
                    // SAFETY: the stencil nodes index `velocity` (built with it, see
                    // `tlmpm::ensure_rest`), six floats each and one node more at the end.
                    let nv: [Lanes<L>; 6] = unsafe { load(velocity, &node) };
                    let mut weight: Lanes<L> = [0.0; L];
                    let mut grad = [[0.0f32; L]; 3];
                    for l in 0..L {
                        weight[l] = w[a][0][l] * w[b][1][l] * w[c][2][l];
                        grad[0][l] = dw[a][0][l] * w[b][1][l] * w[c][2][l] * inv_dx;
                        grad[1][l] = w[a][0][l] * dw[b][1][l] * w[c][2][l] * inv_dx;
                        grad[2][l] = w[a][0][l] * w[b][1][l] * dw[c][2][l] * inv_dx;
                    }
                    for k in 0..3 {
                        for l in 0..L {
                            v_pic[k][l] += nv[k][l] * weight[l];
                            dv[k][l] += nv[3 + k][l] * weight[l];
                        }
                    }
                    for (col, grad_col) in grad.iter().enumerate() {
                        for r in 0..3 {
                            for l in 0..L {
                                grad_v[col][r][l] += nv[r][l] * grad_col[l];
                            }
                        }
                    }
                }
            }
        }

        // FLIP/PIC blend, damping, the move and F.
        let mut v_new = [[0.0f32; L]; 3];
        let mut g = [[0.0f32; L]; 3];
        let mut clamped = [false; L];
        for l in 0..L {
            let damping = step.materials[mats[l] as usize].damping;
            // Dividing by 1 is exact: a material without damping keeps its velocity.
            let divisor = if damping > 0.0 {
                1.0 + damping * dt
            } else {
                1.0
            };
            for k in 0..3 {
                let blended = (vs[l][k] + dv[k][l]) * FLIP + v_pic[k][l] * (1.0 - FLIP);
                v_new[k][l] = blended / divisor;
                let moved = (xs[l][k] + v_pic[k][l] * dt - origin[k]) * inv_dx;
                let inside = keep_inside(moved, step.lo[k], step.hi[k]);
                clamped[l] |= inside != moved;
                g[k][l] = inside;
            }
        }
        for l in 0..L {
            let f_new = Mat3::from_fn(|r, col| fs[l][(r, col)] + grad_v[col][r][l] * dt);
            let (vx, vy, vz) = (v_new[0][l], v_new[1][l], v_new[2][l]);
            let speed = (vx * vx + vy * vy + vz * vz).sqrt();
            let finite = speed.is_finite()
                && f_new.iter().all(|e| e.is_finite())
                && (0..3).all(|k| g[k][l].is_finite());
            if !finite || speed > step.max_speed {
                redo.push((start + l) as u32);
                continue;
            }
            tally.max_speed = tally.max_speed.max(speed);
            tally.clamped += clamped[l] as u32;
            vs[l] = Vec3::new(vx, vy, vz);
            cs[l] = Mat3::from_fn(|r, col| grad_v[col][r][l]);
            xs[l] = origin + Vec3::new(g[0][l], g[1][l], g[2][l]) * dx;
            fs[l] = f_new;
        }
    }
    whole
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mpm::cpu::{CpuSolver, SubstepInput};
    use crate::mpm::grid::{Boundary, GridLayout};
    use crate::mpm::material::{Lame, MaterialModel};
    use crate::mpm::{MaterialParams, Method, Particles, PbMpmParams, SolverSetup};

    /// A block squeezed and spun, so that F, C and the velocities are all far from trivial.
    fn deformed_block(path: TransferPath, method: Method) -> CpuSolver {
        let dx = 0.002;
        let layout = GridLayout::new(Vec3::new(-0.02, -0.02, 0.0), Vec3::repeat(0.04), dx);
        let mut particles = Particles::default();
        // 2 per cell over 7 × 6 × 5 cells, 3,360 particles: groups end short of the
        // 256-particle chunks, so the reference's tail runs too.
        particles.add_box(
            Vec3::new(-0.007, -0.006, 0.004),
            Vec3::new(0.007, 0.006, 0.014),
            dx,
            2,
            1000.0,
            0,
        );
        for (i, (x, v)) in particles.x.iter().zip(&mut particles.v).enumerate() {
            *v = Vec3::new(-x.y, x.x, 0.1 * x.z) * 20.0 + Vec3::repeat((i % 7) as f32 * 0.01);
        }
        for (i, f) in particles.f.iter_mut().enumerate() {
            let t = (i % 11) as f32 * 0.01;
            *f = Mat3::new(1.05, t, 0.0, -t, 0.97, 0.02, 0.01, 0.0, 1.02);
        }
        let mut solver = CpuSolver::new(SolverSetup {
            layout,
            particles,
            materials: vec![MaterialParams {
                model: MaterialModel::NeoHookean,
                lame: Lame::from_young_poisson(5000.0, 0.4),
                density: 1000.0,
                damping: 2.0,
                toughness: 0.0,
            }],
            boundary: Boundary { table: None },
            max_speed: 20.0,
            max_substeps: 1,
            tool_count: 0,
            cutting: false,
            p2g: Default::default(),
            method,
            pb_mpm: PbMpmParams {
                iterations: 3,
                relaxation: 1.0,
            },
            implicit: Default::default(),
            split: crate::mpm::split::SplitParams::OFF,
        });
        solver.transfer_path = path;
        solver
    }

    /// Equal element for element, or a panic naming the first particle that differs.
    fn same<T: PartialEq + std::fmt::Debug>(got: &[T], want: &[T], at: &str, what: &str) {
        assert_eq!(got.len(), want.len(), "{at}: {what}");
        if let Some(i) = (0..got.len()).find(|&i| got[i] != want[i]) {
            panic!(
                "{at}: {what} of particle {i}: {:?} against {:?}",
                got[i], want[i]
            );
        }
    }

    /// MLS-MPM's G2P moves the particles; PB-MPM's iterations also gather without moving
    /// them (`integrate` false) before the last one does; total Lagrangian MPM has its own
    /// G2P on the rest configuration.
    #[test]
    fn every_lane_path_equals_the_reference_to_the_bit() {
        let paths = TransferPath::available();
        assert!(paths.contains(&TransferPath::Lanes4), "{paths:?}");
        let input = SubstepInput {
            dt: 1e-4,
            gravity: Vec3::new(0.0, 0.0, -9.81),
            tools: &[],
        };
        for method in [Method::MlsMpm, Method::PbMpm, Method::TlMpm] {
            let run = |path| {
                let mut solver = deformed_block(path, method);
                let stats: Vec<_> = (0..20).map(|_| solver.substep(&input)).collect();
                (solver.particles, stats)
            };
            let (reference, reference_stats) = run(TransferPath::Scalar);
            let start = deformed_block(TransferPath::Scalar, method).particles;
            // The reference moved the particles and changed F: the comparison is not of
            // untouched state.
            let moved =
                |a: &[Vec3], b: &[Vec3]| a.iter().zip(b).any(|(a, b)| (a - b).norm() > 1e-5);
            assert!(moved(&reference.x, &start.x), "{method:?}");
            assert!(reference
                .f
                .iter()
                .zip(&start.f)
                .any(|(a, b)| (a - b).norm() > 1e-5));
            for path in &paths {
                let (parts, stats) = run(*path);
                let at = format!("{method:?} on {path:?}");
                same(&parts.x, &reference.x, &at, "positions");
                same(&parts.v, &reference.v, &at, "velocities");
                same(&parts.c, &reference.c, &at, "affine velocities");
                same(&parts.f, &reference.f, &at, "deformation gradients");
                for (s, r) in stats.iter().zip(&reference_stats) {
                    assert_eq!(s.max_speed, r.max_speed, "{at}: fastest particle");
                    assert_eq!(s.clamped_particles, r.clamped_particles, "{at}");
                }
            }
        }
    }
}
