//! Total Lagrangian P2G's node sums in vector registers, with the width chosen at run time.
//!
//! Each node gathers from the particles of its rest stencil: momentum Σ wm·v, place
//! Σ wm·x and force Σ S·∇N, where S = −V⁰P/dx (see [`super::tlmpm`]). A particle's share
//! is laid out as sixteen floats (one 64-byte `Source`: v, x, an empty lane, then S's
//! three columns), and an entry of the node's list as its multipliers (wm for v and x,
//! the gradient's components for S's columns). One entry is then one element-wise
//! multiply over sixteen lanes (one instruction on AVX-512, two on AVX2, four on SSE2),
//! the entry's force S·∇N = (S₀g₀ + S₁g₁) + S₂g₂ from the product's three column lanes,
//! and one add. The force is formed per entry before it is summed, as the GPU's scatter
//! forms it: summing the three column products apart over the whole list and adding them
//! at the end measured 20× further from the GPU (`tests/gpu_agreement.rs`'s total
//! Lagrangian grip, 8.2e-5 N against 3.9e-6 N of a 0.021 N peak). Entries go round four
//! partial sums, so consecutive adds do not wait on each other.
//!
//! The arithmetic is element-wise in a fixed order with no fused multiply-add, so every
//! width gives the same sums to the bit; one source is compiled per width under
//! `#[target_feature]` and [`TransferPath`] picks it, as G2P's lanes do.

use super::TransferPath;
use crate::mpm::{Mat3, Vec3};

/// Floats per source and per sum.
const WIDTH: usize = 16;

/// One node's sums, lane for lane as a [`Source`]'s (read by [`NodeSums::of`]).
pub(super) type Sum = [f32; WIDTH];

/// What a particle gives its nodes in P2G, as sixteen floats: velocity (0..3), place
/// (3..6), an unused lane (6), and the columns of S = −V⁰P/dx (7..16), so that the force is
/// `S · ∇N`.
#[derive(Clone, Copy, Default)]
#[repr(C, align(64))]
pub(super) struct Source([f32; WIDTH]);

impl Source {
    pub fn new(v: Vec3, x: Vec3, stress: &Mat3) -> Self {
        let mut s = [0.0; WIDTH];
        s[0..3].copy_from_slice(v.as_slice());
        s[3..6].copy_from_slice(x.as_slice());
        s[7..16].copy_from_slice(stress.as_slice());
        Source(s)
    }
}

/// One particle of a node's rest stencil: the particle, its weight times its mass, and the
/// weight's gradient in grid units (all fixed at rest).
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub(super) struct Entry {
    pub particle: u32,
    pub weighted_mass: f32,
    pub grad: [f32; 3],
}

/// A node's sums: momentum Σ wm·v, place Σ wm·x and force Σ S·∇N, from lanes 0..3, 3..6
/// and 7..10 of its sixteen (the rest are scratch).
pub(super) struct NodeSums {
    pub momentum: Vec3,
    pub place: Vec3,
    pub force: Vec3,
}

/// The sums of every node of a chunk: node `j`'s entries are
/// `entries[starts[j]..starts[j + 1]]`, written to `out[j]`.
pub(super) fn node_sums(
    path: TransferPath,
    starts: &[u32],
    entries: &[Entry],
    sources: &[Source],
    out: &mut [Sum],
) {
    match path {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `available` lists this path only where the CPU has AVX2.
        TransferPath::Lanes8 => unsafe { sums_avx2(starts, entries, sources, out) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `available` lists this path only where the CPU has AVX-512F.
        TransferPath::Lanes16 => unsafe { sums_avx512(starts, entries, sources, out) },
        _ => sums(starts, entries, sources, out),
    }
}

/// Partial sums per node: entry `e` of a node's list goes to partial `e % PARTIALS`, so
/// that consecutive adds do not wait on each other (an add's latency is four cycles).
const PARTIALS: usize = 4;

/// The loop every width shares: per node, entries go round the partial sums (`add` folds
/// one entry into one), which are then added lane by lane, ((0 + 1) + (2 + 3)), by
/// `finish`.
#[inline(always)]
fn sums_with<A: Copy>(
    starts: &[u32],
    entries: &[Entry],
    out: &mut [Sum],
    zero: impl Fn() -> A,
    add: impl Fn(A, &Entry) -> A,
    finish: impl Fn([A; PARTIALS], &mut Sum),
) {
    for (j, sum) in out.iter_mut().enumerate() {
        let list = &entries[starts[j] as usize..starts[j + 1] as usize];
        let mut partial = [zero(); PARTIALS];
        let mut rounds = list.chunks_exact(PARTIALS);
        for round in &mut rounds {
            for (acc, entry) in partial.iter_mut().zip(round) {
                *acc = add(*acc, entry);
            }
        }
        for (acc, entry) in partial.iter_mut().zip(rounds.remainder()) {
            *acc = add(*acc, entry);
        }
        finish(partial, sum);
    }
}

/// The reference: sixteen floats in an array (the baseline build's vectors: four lanes on
/// x86-64).
fn sums(starts: &[u32], entries: &[Entry], sources: &[Source], out: &mut [Sum]) {
    sums_with(
        starts,
        entries,
        out,
        || [0.0f32; WIDTH],
        |mut acc, entry| {
            let source = &sources[entry.particle as usize].0;
            let (wm, [g0, g1, g2]) = (entry.weighted_mass, entry.grad);
            // Lane 6 of a source is zero, so its multiplier does not matter; wm is what the
            // wide paths' permutation puts there.
            let multipliers = [
                wm, wm, wm, wm, wm, wm, wm, g0, g0, g0, g1, g1, g1, g2, g2, g2,
            ];
            let product: [f32; WIDTH] = std::array::from_fn(|l| source[l] * multipliers[l]);
            for l in 0..7 {
                acc[l] += product[l];
            }
            for l in 7..10 {
                acc[l] += (product[l] + product[l + 3]) + product[l + 6];
            }
            acc
        },
        |[p0, p1, p2, p3], sum| {
            for l in 0..10 {
                sum[l] = (p0[l] + p1[l]) + (p2[l] + p3[l]);
            }
        },
    )
}

/// An entry's (wm, g₀, g₁, g₂): the four floats after its particle index, in one load.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn entry_factors(entry: &Entry) -> std::arch::x86_64::__m128 {
    // SAFETY: the four floats lie within the entry (repr(C): u32, f32, [f32; 3]); SSE is
    // part of x86-64.
    unsafe { std::arch::x86_64::_mm_loadu_ps(&entry.weighted_mass) }
}

/// Sixteen lanes as two 256-bit halves; momentum and place sum in the low half's lanes
/// 0..6, the force in a third register's lanes 0..3.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn sums_avx2(starts: &[u32], entries: &[Entry], sources: &[Source], out: &mut [Sum]) {
    use std::arch::x86_64::*;
    let low = _mm256_setr_epi32(0, 0, 0, 0, 0, 0, 0, 1);
    let high = _mm256_setr_epi32(1, 1, 2, 2, 2, 3, 3, 3);
    // S's columns: column 0 is lane 7 of the low product and lanes 0, 1 of the high one
    // (brought together by a blend), columns 1 and 2 are the high one's lanes 2..5, 5..8.
    let (column0, column1, column2) = (
        _mm256_setr_epi32(7, 0, 1, 7, 7, 7, 7, 7),
        _mm256_setr_epi32(2, 3, 4, 7, 7, 7, 7, 7),
        _mm256_setr_epi32(5, 6, 7, 7, 7, 7, 7, 7),
    );
    sums_with(
        starts,
        entries,
        out,
        || [_mm256_setzero_ps(); 2],
        |[moving, force], entry| {
            let source = sources[entry.particle as usize].0.as_ptr();
            let factors = _mm256_castps128_ps256(entry_factors(entry));
            let (m_lo, m_hi) = (
                _mm256_permutevar8x32_ps(factors, low),
                _mm256_permutevar8x32_ps(factors, high),
            );
            // SAFETY: a source is 64 aligned bytes.
            let (lo, hi) = (
                _mm256_mul_ps(_mm256_load_ps(source), m_lo),
                _mm256_mul_ps(_mm256_load_ps(source.add(8)), m_hi),
            );
            let joined = _mm256_blend_ps::<0x80>(hi, lo);
            let s0g0 = _mm256_permutevar8x32_ps(joined, column0);
            let s1g1 = _mm256_permutevar8x32_ps(hi, column1);
            let s2g2 = _mm256_permutevar8x32_ps(hi, column2);
            let entry_force = _mm256_add_ps(_mm256_add_ps(s0g0, s1g1), s2g2);
            [_mm256_add_ps(moving, lo), _mm256_add_ps(force, entry_force)]
        },
        |[p0, p1, p2, p3], sum| {
            let sum = sum.as_mut_ptr();
            for (half, at) in [(0, 0), (1, 7)] {
                let (a, b) = (
                    _mm256_add_ps(p0[half], p1[half]),
                    _mm256_add_ps(p2[half], p3[half]),
                );
                // The force's lanes land on 7..10, after the low half's eight.
                _mm256_storeu_ps(sum.add(at), _mm256_add_ps(a, b));
            }
        },
    )
}

/// Sixteen lanes in one 512-bit register.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn sums_avx512(starts: &[u32], entries: &[Entry], sources: &[Source], out: &mut [Sum]) {
    use std::arch::x86_64::*;
    let spread = _mm512_setr_epi32(0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3);
    // Columns 1 and 2 of S brought onto column 0's lanes 7..10 (lanes 0..7 masked to zero,
    // so momentum and place pass through; the lanes after 10 are scratch).
    let (column1, column2) = (
        _mm512_setr_epi32(0, 0, 0, 0, 0, 0, 0, 10, 11, 12, 6, 6, 6, 6, 6, 6),
        _mm512_setr_epi32(0, 0, 0, 0, 0, 0, 0, 13, 14, 15, 6, 6, 6, 6, 6, 6),
    );
    const FORCE_LANES: u16 = 0xFF80;
    sums_with(
        starts,
        entries,
        out,
        || _mm512_setzero_ps(),
        |acc, entry| {
            // SAFETY: a source is 64 aligned bytes.
            let source = _mm512_load_ps(sources[entry.particle as usize].0.as_ptr());
            let factors = _mm512_castps128_ps512(entry_factors(entry));
            let product = _mm512_mul_ps(source, _mm512_permutexvar_ps(spread, factors));
            let s1g1 = _mm512_maskz_permutexvar_ps(FORCE_LANES, column1, product);
            let s2g2 = _mm512_maskz_permutexvar_ps(FORCE_LANES, column2, product);
            // Lanes 0..7: the product plus zeros, which adds to the sum what the product
            // alone would (the sums start at +0 and so never hold −0).
            let share = _mm512_add_ps(_mm512_add_ps(product, s1g1), s2g2);
            _mm512_add_ps(acc, share)
        },
        |[p0, p1, p2, p3], sum| {
            let (a, b) = (_mm512_add_ps(p0, p1), _mm512_add_ps(p2, p3));
            _mm512_storeu_ps(sum.as_mut_ptr(), _mm512_add_ps(a, b))
        },
    )
}

impl NodeSums {
    /// The momentum, place and force a node's sixteen lane sums hold.
    pub fn of(sum: &Sum) -> Self {
        let v = |i: usize| Vec3::new(sum[i], sum[i + 1], sum[i + 2]);
        NodeSums {
            momentum: v(0),
            place: v(3),
            force: v(7),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every width gives the sums the baseline build gives, to the bit, on lists of odd and
    /// even lengths with values of mixed magnitude; and the sums are the momentum, place
    /// and force they stand for.
    #[test]
    fn every_width_gives_the_same_sums() {
        let mut seed = 12345u32;
        let mut rand = move || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        let n_particles = 40;
        let particles: Vec<(Vec3, Vec3, Mat3)> = (0..n_particles)
            .map(|_| {
                let v = Vec3::new(rand(), rand(), rand());
                let x = Vec3::new(rand(), rand(), rand()) * 0.1;
                let s = Mat3::from_fn(|_, _| rand() * 1e3);
                (v, x, s)
            })
            .collect();
        let sources: Vec<Source> = particles
            .iter()
            .map(|(v, x, s)| Source::new(*v, *x, s))
            .collect();
        let lengths = [0usize, 1, 2, 7, 27, 64];
        let mut starts = vec![0u32];
        let mut entries = Vec::new();
        for len in lengths {
            for _ in 0..len {
                entries.push(Entry {
                    particle: ((rand() + 0.5) * n_particles as f32) as u32 % n_particles,
                    weighted_mass: rand() + 0.5,
                    grad: [rand(), rand(), rand()],
                });
            }
            starts.push(entries.len() as u32);
        }
        let mut want = vec![[0.0f32; WIDTH]; lengths.len()];
        sums(&starts, &entries, &sources, &mut want);
        for path in TransferPath::available() {
            let mut got = vec![[1.0f32; WIDTH]; lengths.len()];
            node_sums(path, &starts, &entries, &sources, &mut got);
            for (j, sum) in got.iter().enumerate() {
                let force = NodeSums::of(sum).force;
                let from_want = NodeSums::of(&want[j]).force;
                assert_eq!(force, from_want, "{path:?}: the force as NodeSums reads it");
            }
            for (g, w) in got.iter().zip(&want) {
                let bits =
                    |s: &[f32; WIDTH]| s[..10].iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(g), bits(w), "{path:?}");
            }
        }
        for (j, sum) in want.iter().enumerate() {
            let got = NodeSums::of(sum);
            let (mut momentum, mut place, mut force) =
                (Vec3::zeros(), Vec3::zeros(), Vec3::zeros());
            for e in &entries[starts[j] as usize..starts[j + 1] as usize] {
                let (v, x, s) = &particles[e.particle as usize];
                momentum += v * e.weighted_mass;
                place += x * e.weighted_mass;
                force += s * Vec3::from(e.grad);
            }
            assert!((got.momentum - momentum).norm() <= 1e-5 * (1.0 + momentum.norm()));
            assert!((got.place - place).norm() <= 1e-5 * (1.0 + place.norm()));
            assert!((got.force - force).norm() <= 1e-5 * (1.0 + force.norm()));
        }
    }
}
