// Order-independent scatters: 64-bit fixed point (FIXED_BITS and FIXED_CLAMP: layout.rs).
//
// f32 atomics add in the order the invocations happen to run, so their sums, and the Newton
// and CG counts that follow, would change from run to run. The particle scatters add
// integers instead, which associate. Each sum's unit is 2^(e − FIXED_BITS), 2^e the power of
// two above a bound on its contributions' magnitude that a first pass over the same
// particles raised (atomicMax of f32 bits: order-independent too), so a contribution is at
// most 2^FIXED_BITS units and is resolved to 2^−FIXED_BITS of the bound (f32 atomics resolve
// 2^−24 of each partial sum). A node takes one contribution per particle and the solver
// takes at most 2^(62 − FIXED_BITS) particles (layout.rs `MAX_PARTICLES`), so a sum stays below 2^62
// units: it cannot overflow. The 64 bits are two u32 atomics: atomicAdd on the low word
// returns the old value, so the carry into the high word is exact.

const TWO_32: f32 = 4294967296.0;

fn pow2(k: i32) -> f32 {
    return bitcast<f32>(u32(k + 127) << 23u);
}

// A pass's running bound: the largest |component| and, to catch a non-finite one, their sum.
struct Bound {
    largest: f32,
    total: f32,
}

fn bound1(b: ptr<function, Bound>, x: f32) {
    (*b).largest = max((*b).largest, abs(x));
    (*b).total += abs(x);
}

fn bound3(b: ptr<function, Bound>, v: vec3<f32>) {
    let a = abs(v);
    (*b).largest = max((*b).largest, max(a.x, max(a.y, a.z)));
    (*b).total += a.x + a.y + a.z;
}

// Raises bound `slot` to `b`; to NaN's bits (above every finite bound) where a contribution
// was not finite, which makes the sum read NaN as an f32 atomic sum would.
fn raise_bound(slot: u32, b: Bound) {
    var bits = bitcast<u32>(b.largest);
    if (!is_finite(b.total)) {
        bits = 0x7fc00000u;
    }
    if (bits > atomicLoad(&im_scal[slot])) {
        atomicMax(&im_scal[slot], bits);
    }
}

// e with bound < 2^e (from the f32 exponent), kept where 2^(e ± FIXED_BITS) is a normal f32.
fn bound_exponent(slot: u32) -> i32 {
    let bits = atomicLoad(&im_scal[slot]);
    return clamp(i32((bits >> 23u) & 0xffu) - 126, -80, 128);
}

// Units per unit of the quantity of the sum with bound `slot`.
fn fixed_scale(slot: u32) -> f32 {
    return pow2(FIXED_BITS - bound_exponent(slot));
}

// The quantity per unit of that sum; NaN where a contribution was not finite.
fn fixed_unit(slot: u32) -> f32 {
    if (atomicLoad(&im_scal[slot]) >= 0x7f800000u) {
        return bitcast<f32>(0x7fc00000u);
    }
    return pow2(bound_exponent(slot) - FIXED_BITS);
}

// Adds x (times `scale`, rounded to a whole unit) to value v of node i.
fn fixed_add(i: u32, v: u32, x: f32, scale: f32) {
    let y = clamp(round(x * scale), -FIXED_CLAMP, FIXED_CLAMP);
    if (y == 0.0) {
        return;
    }
    // |y| = hi·2^32 + lo exactly (|y| is a whole number below 2^42 with at most 24
    // significant bits), then the two's complement of y.
    let a = abs(y);
    let a_hi = floor(a / TWO_32);
    var lo = u32(a - a_hi * TWO_32);
    var hi = u32(a_hi);
    if (y < 0.0) {
        lo = ~lo + 1u;
        hi = ~hi + select(0u, 1u, lo == 0u);
    }
    let at = i * ACC_WORDS + 2u * v;
    let old = atomicAdd(&im_acc[at], lo);
    hi += select(0u, 1u, old + lo < old);
    if (hi != 0u) {
        atomicAdd(&im_acc[at + 1u], hi);
    }
}

fn fixed_add3(i: u32, v: u32, x: vec3<f32>, scale: f32) {
    fixed_add(i, v, x.x, scale);
    fixed_add(i, v + 1u, x.y, scale);
    fixed_add(i, v + 2u, x.z, scale);
}

// Value v of node i in the quantity's units (`fixed_unit`).
fn fixed_load(i: u32, v: u32, unit: f32) -> f32 {
    let at = i * ACC_WORDS + 2u * v;
    var lo = atomicLoad(&im_acc[at]);
    var hi = atomicLoad(&im_acc[at + 1u]);
    let negative = (hi & 0x80000000u) != 0u;
    if (negative) {
        lo = ~lo + 1u;
        hi = ~hi + select(0u, 1u, lo == 0u);
    }
    let magnitude = (f32(hi) * TWO_32 + f32(lo)) * unit;
    return select(magnitude, -magnitude, negative);
}

fn fixed_load3(i: u32, v: u32, unit: f32) -> vec3<f32> {
    return vec3<f32>(fixed_load(i, v, unit), fixed_load(i, v + 1u, unit), fixed_load(i, v + 2u, unit));
}

// Zeroes values first..first + count of node i.
fn acc_clear(i: u32, first: u32, count: u32) {
    for (var k = 2u * first; k < 2u * (first + count); k++) {
        atomicStore(&im_acc[i * ACC_WORDS + k], 0u);
    }
}

// The finished Hessian product of node i (`im_product_finish`).
fn product_load(i: u32) -> vec3<f32> {
    let at = i * ACC_WORDS + PRODUCT_WORD;
    return vec3<f32>(bitcast<f32>(atomicLoad(&im_acc[at])), bitcast<f32>(atomicLoad(&im_acc[at + 1u])),
                     bitcast<f32>(atomicLoad(&im_acc[at + 2u])));
}

fn store_q(p: u32, q: mat3x3<f32>) {
    let at = p * STIFF_STRIDE + SCATTER_Q;
    for (var c = 0u; c < 3u; c++) {
        for (var r = 0u; r < 3u; r++) {
            im_stiff[at + 3u * c + r] = q[c][r];
        }
    }
}

fn load_q(p: u32) -> mat3x3<f32> {
    let at = p * STIFF_STRIDE + SCATTER_Q;
    var q: mat3x3<f32>;
    for (var c = 0u; c < 3u; c++) {
        q[c] = vec3<f32>(im_stiff[at + 3u * c], im_stiff[at + 3u * c + 1u], im_stiff[at + 3u * c + 2u]);
    }
    return q;
}

// Raises bound `slot` over the contributions q·∇wₖ of the stencil `g`.
fn raise_bound_q(slot: u32, g: Grads, q: mat3x3<f32>) {
    var b: Bound;
    for (var k = 0u; k < 27u; k++) {
        bound3(&b, q * g.grad[k]);
    }
    raise_bound(slot, b);
}
