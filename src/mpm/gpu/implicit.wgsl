// Backward-Euler MLS-MPM (cpu `implicit`): the node and particle kernels of the Newton–CG
// solve on the grid velocities. Group 1 holds the solve's own buffers (implicit.rs); the
// host drives Newton and the line search, the conjugate gradients run on the device with
// their scalars in `im_scal`. Every sum is order-independent, so the solve gives the same
// result from run to run: the particles scatter in 64-bit fixed point (`fixed_add`), the
// node and particle reductions add per-workgroup partials in a fixed tree over the active
// blocks in increasing index (sparse.wgsl `compact`). Built on the f32-atomics variant of
// group 0 (`im_prepare` and `im_finish` store the grid update's mass and momentum as f32).

struct ImNode {
    // xyz: v* = p/m + g dt; w: the node mass.
    v_star: vec4<f32>,
    v: vec4<f32>,
    trial: vec4<f32>,
    grad: vec4<f32>,
    step: vec4<f32>,
    r: vec4<f32>,
    z: vec4<f32>,
    d: vec4<f32>,
    prescribed: vec4<f32>,
    normal: vec4<f32>,
    // xyz: v − v* along the free components at the end of a substep; w: that substep's
    // epoch (bits), so that only the last substep's correction is read.
    correction: vec4<f32>,
    // With one prescribed direction, the surface the node slides on (cpu `Surface`): xyz
    // its velocity, w the friction weight λ = μ·N (N·s); and x μ, y drag, z the tool index
    // (bits; NO_TOOL for the table or a wall), w the tool part (bits). `normal.w` holds the
    // normal impulse the surface gave the node at the end of the substep, for the next
    // substep's friction weight.
    surface: vec4<f32>,
    slip: vec4<f32>,
    free: mat3x3<f32>,
    // The diagonal Hessian block while evaluating, then the preconditioner.
    block: mat3x3<f32>,
}

@group(1) @binding(0) var<storage, read_write> im_nodes: array<ImNode>;
// Per node ACC_WORDS words: sums scattered from the particles in 64-bit fixed point, value k
// in words 2k (low) and 2k + 1 (high) (`fixed_add`): the P2G momentum (0..3) and mass (3)
// until `im_prepare`, then ∂E/∂v (0..3), the diagonal Hessian block (3..12) and the Hessian
// product (12..15); words PRODUCT_WORD.. hold the finished product (f32 bits).
@group(1) @binding(1) var<storage, read_write> im_acc: array<atomic<u32>>;
// Per particle STIFF_STRIDE words: the 9×9 velocity-gradient stiffness (hessian.rs),
// column-major, then at SCATTER_Q the 3×3 matrix q (column-major) whose products q·∇wᵢ the
// particle's second pass scatters.
@group(1) @binding(2) var<storage, read_write> im_stiff: array<f32>;
// Per workgroup reduction partials: two regions of arrayLength/2 entries.
@group(1) @binding(3) var<storage, read_write> im_partials: array<f32>;
// Scalars (f32 as bits, or u32): the I_* words below.
@group(1) @binding(4) var<storage, read_write> im_scal: array<atomic<u32>>;

const ACC_WORDS: u32 = 36u;
const PRODUCT_WORD: u32 = 32u;
const STIFF_STRIDE: u32 = 90u;
const SCATTER_Q: u32 = 81u;
const I_COUNT: u32 = 0u;
const I_DONE: u32 = 1u;
const I_ITER: u32 = 2u;
const I_CRUSH: u32 = 3u;
const I_ALPHA: u32 = 4u;
const I_TARGET: u32 = 5u;
const I_EPOCH: u32 = 6u;
const I_CAP: u32 = 7u;
const I_RZ: u32 = 8u;
const I_CG_ALPHA: u32 = 9u;
const I_BETA: u32 = 10u;
const I_ACTIVATED: u32 = 11u;
// Bounds on the scattered contributions' magnitude (f32 bits, raised by atomicMax), one per
// fixed-point sum: P2G momentum and mass, ∂E/∂v, the diagonal blocks, the Hessian product.
const B_MOMENTUM: u32 = 26u;
const B_MASS: u32 = 27u;
const B_GRAD: u32 = 28u;
const B_BLOCK: u32 = 29u;
const B_PRODUCT: u32 = 30u;

// Which sum `im_sum` writes (its two regions to SLOT and SLOT + 1), over node or particle
// workgroups; which velocity the energy kernels read; whether `im_eval*` build the Hessian
// and the block-Jacobi preconditioner.
override SLOT: u32 = 12u;
override OVER_NODES: bool = true;
override SELECT_TRIAL: bool = false;
override HESSIAN: bool = false;
override BLOCK_JACOBI: bool = true;
// `im_p2g`: the pass that raises the bounds (true) or the one that scatters.
override BOUND_PASS: bool = false;

const ID3 = mat3x3<f32>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));

fn scal_f(i: u32) -> f32 {
    return bitcast<f32>(atomicLoad(&im_scal[i]));
}

fn set_scal_f(i: u32, v: f32) {
    atomicStore(&im_scal[i], bitcast<u32>(v));
}

fn cg_done() -> bool {
    return atomicLoad(&im_scal[I_DONE]) != 0u;
}

// ---- reductions: a workgroup's two sums into the partials, then `im_sum` ----

var<workgroup> wg_a: array<f32, WG>;
var<workgroup> wg_b: array<f32, WG>;

// Every invocation of the workgroup calls this (it has barriers).
fn reduce_to_partials(lid: u32, wid: u32, a: f32, b: f32) {
    wg_a[lid] = a;
    wg_b[lid] = b;
    workgroupBarrier();
    for (var s = WG / 2u; s > 0u; s = s / 2u) {
        if (lid < s) {
            wg_a[lid] += wg_a[lid + s];
            wg_b[lid] += wg_b[lid + s];
        }
        workgroupBarrier();
    }
    if (lid == 0u) {
        let stride = arrayLength(&im_partials) / 2u;
        im_partials[wid] = wg_a[0];
        im_partials[stride + wid] = wg_b[0];
    }
}

// One workgroup: the partials of the last reducing kernel summed (compensated) into
// im_scal[SLOT] and im_scal[SLOT + 1].
@compute @workgroup_size(WG)
fn im_sum(@builtin(local_invocation_index) lid: u32) {
    var count = (sim.n_particles + WG - 1u) / WG;
    if (OVER_NODES) {
        count = atomicLoad(&im_scal[I_COUNT]);
    }
    let stride = arrayLength(&im_partials) / 2u;
    var sa = 0.0;
    var ca = 0.0;
    var sb = 0.0;
    var cb = 0.0;
    for (var i = lid; i < count; i += WG) {
        let ya = im_partials[i] - ca;
        let ta = sa + ya;
        ca = (ta - sa) - ya;
        sa = ta;
        let yb = im_partials[stride + i] - cb;
        let tb = sb + yb;
        cb = (tb - sb) - yb;
        sb = tb;
    }
    wg_a[lid] = sa;
    wg_b[lid] = sb;
    workgroupBarrier();
    for (var s = WG / 2u; s > 0u; s = s / 2u) {
        if (lid < s) {
            wg_a[lid] += wg_a[lid + s];
            wg_b[lid] += wg_b[lid + s];
        }
        workgroupBarrier();
    }
    if (lid == 0u) {
        set_scal_f(SLOT, wg_a[0]);
        set_scal_f(SLOT + 1u, wg_b[0]);
    }
}

// ---- stencil with MLS kernel gradients ----

struct Grads {
    idx: array<u32, 27>,
    grad: array<vec3<f32>, 27>,
}

// The 27 stencil nodes of a particle and ∇wᵢₚ = wᵢₚ·4/dx²·(xᵢ − xₚ) (1/m).
fn stencil_gradients(x: vec3<f32>) -> Grads {
    let s = make_stencil(grid_pos(x));
    let offs = node_offsets(s.base);
    let scale = 4.0 * sim.inv_dx;
    var out: Grads;
    for (var a = 0u; a < 3u; a++) {
        for (var b = 0u; b < 3u; b++) {
            for (var c = 0u; c < 3u; c++) {
                let k = 9u * a + 3u * b + c;
                out.idx[k] = offs[a].x + offs[b].y + offs[c].z;
                let w = s.w[a].x * s.w[b].y * s.w[c].z;
                out.grad[k] = (vec3<f32>(f32(a), f32(b), f32(c)) - s.fx) * (w * scale);
            }
        }
    }
    return out;
}

fn node_velocity(i: u32) -> vec3<f32> {
    if (SELECT_TRIAL) {
        return im_nodes[i].trial.xyz;
    }
    return im_nodes[i].v.xyz;
}

// Σᵢ vᵢ ∇wᵢₚᵀ over the stencil, of the iterate (or the trial).
fn velocity_gradient(g: Grads) -> mat3x3<f32> {
    var m = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    for (var k = 0u; k < 27u; k++) {
        let v = node_velocity(g.idx[k]);
        m += mat3x3<f32>(v * g.grad[k].x, v * g.grad[k].y, v * g.grad[k].z);
    }
    return m;
}

// ---- strain energy in terms of H = F − I (no cancellation of the O(1) parts) ----

// u − ln(1 + u).
fn u_minus_log1p(u: f32) -> f32 {
    if (abs(u) < 0.05) {
        var term = u * u;
        var sum = 0.0;
        var sign = 1.0;
        for (var k = 2; k < 9; k++) {
            sum += sign * term / f32(k);
            term *= u;
            sign = -sign;
        }
        return sum;
    }
    return u - log(1.0 + u);
}

// J − 1 from H: tr H + the principal 2×2 minors + det H.
fn j_minus_one(h: mat3x3<f32>) -> f32 {
    let minors = h[0][0] * h[1][1] - h[1][0] * h[0][1] + h[0][0] * h[2][2] - h[2][0] * h[0][2]
        + h[1][1] * h[2][2] - h[2][1] * h[1][2];
    return h[0][0] + h[1][1] + h[2][2] + minors + determinant(h);
}

fn frob2(m: mat3x3<f32>) -> f32 {
    return dot(m[0], m[0]) + dot(m[1], m[1]) + dot(m[2], m[2]);
}

// I − R(q), entry by entry without subtracting from one.
fn identity_minus_rotation(q: vec4<f32>) -> mat3x3<f32> {
    let x = q.x;
    let y = q.y;
    let z = q.z;
    let w = q.w;
    return mat3x3<f32>(
        vec3<f32>(2.0 * (y * y + z * z), -2.0 * (x * y + w * z), -2.0 * (x * z - w * y)),
        vec3<f32>(-2.0 * (x * y - w * z), 2.0 * (x * x + z * z), -2.0 * (y * z + w * x)),
        vec3<f32>(-2.0 * (x * z + w * y), -2.0 * (y * z - w * x), 2.0 * (x * x + y * y)),
    );
}

// Ψ (J/m³) at F = I + H (material.rs `energy_density`, the J clamp included).
fn energy_density(mat: Material, h: mat3x3<f32>) -> f32 {
    let u = j_minus_one(h);
    if (mat.model == 0u) {
        let tr = h[0][0] + h[1][1] + h[2][2];
        if (1.0 + u <= J_MIN) {
            let ln_j = log(J_MIN);
            return 0.5 * mat.mu * (2.0 * tr + frob2(h)) - mat.mu * ln_j + 0.5 * mat.lambda * ln_j * ln_j;
        }
        // ½μ(2 tr H + |H|²) − μ ln J with ln J = u − g(u), u = tr H + m₂ + det H:
        // μ(½|H|² − m₂ − det H + g(u)).
        let minors_det = u - tr;
        let ln_j = u - u_minus_log1p(u);
        return mat.mu * (0.5 * frob2(h) - minors_det + u_minus_log1p(u)) + 0.5 * mat.lambda * ln_j * ln_j;
    }
    let q = rotation_quat(ID3 + h);
    let f_minus_r = h + identity_minus_rotation(q);
    return mat.mu * frob2(f_minus_r) + 0.5 * mat.lambda * u * u;
}

// First Piola–Kirchhoff stress (material.rs `first_piola`: τ F⁻ᵀ, zero where F is singular).
fn first_piola(mat: Material, f: mat3x3<f32>) -> mat3x3<f32> {
    let j = determinant(f);
    if (j == 0.0) {
        return mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    }
    let cof = mat3x3<f32>(cross(f[1], f[2]), cross(f[2], f[0]), cross(f[0], f[1]));
    return kirchhoff_stress(mat, f) * (cof * (1.0 / j));
}

// ---- ∂P/∂F (hessian.rs) ----

fn cofactor(f: mat3x3<f32>) -> mat3x3<f32> {
    return mat3x3<f32>(cross(f[1], f[2]), cross(f[2], f[0]), cross(f[0], f[1]));
}

fn cofactor_derivative(f: mat3x3<f32>, d: mat3x3<f32>) -> mat3x3<f32> {
    return mat3x3<f32>(
        cross(d[1], f[2]) + cross(f[1], d[2]),
        cross(d[2], f[0]) + cross(f[2], d[0]),
        cross(d[0], f[1]) + cross(f[0], d[1]),
    );
}

fn ddot(a: mat3x3<f32>, b: mat3x3<f32>) -> f32 {
    return dot(a[0], b[0]) + dot(a[1], b[1]) + dot(a[2], b[2]);
}

fn inverse3(m: mat3x3<f32>) -> mat3x3<f32> {
    let det = determinant(m);
    if (det == 0.0) {
        return mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    }
    return transpose(cofactor(m)) * (1.0 / det);
}

fn cross_matrix(w: vec3<f32>) -> mat3x3<f32> {
    return mat3x3<f32>(vec3<f32>(0.0, w.z, -w.y), vec3<f32>(-w.z, 0.0, w.x), vec3<f32>(w.y, -w.x, 0.0));
}

struct Lin {
    kind: u32,
    mu: f32,
    lambda: f32,
    a: mat3x3<f32>,
    b: mat3x3<f32>,
    f: mat3x3<f32>,
    cof: mat3x3<f32>,
    s: f32,
}

// What every direction δF shares (hessian.rs `Linearization::new`); kind 0 Neo-Hookean
// (a = F⁻ᵀ, s = μ − λ ln J, lambda = λ above the clamp), 1 fixed-corotated (a = R,
// b = ((tr S)I − S)⁻¹, s = J), 2 the shear term alone (singular F).
fn linearize(mat: Material, f: mat3x3<f32>) -> Lin {
    var l: Lin;
    l.mu = mat.mu;
    l.f = f;
    let j = determinant(f);
    if (mat.model == 0u) {
        if (j == 0.0) {
            l.kind = 2u;
            return l;
        }
        l.kind = 0u;
        l.a = transpose(inverse3(f));
        l.s = mat.mu - mat.lambda * log(max(j, J_MIN));
        l.lambda = select(0.0, mat.lambda, j > J_MIN);
        return l;
    }
    l.kind = 1u;
    l.lambda = mat.lambda;
    let r = rotation_of(f);
    let s0 = transpose(r) * f;
    let s = (s0 + transpose(s0)) * 0.5;
    l.a = r;
    l.b = inverse3(ID3 * (s[0][0] + s[1][1] + s[2][2]) - s);
    l.cof = cofactor(f);
    l.s = j;
    return l;
}

fn apply_lin(l: Lin, df: mat3x3<f32>) -> mat3x3<f32> {
    if (l.kind == 2u) {
        return df * l.mu;
    }
    if (l.kind == 0u) {
        let fit = l.a;
        return df * l.mu + fit * transpose(df) * fit * l.s + fit * (l.lambda * ddot(fit, df));
    }
    let a = transpose(l.a) * df;
    let skew = a - transpose(a);
    let axial = vec3<f32>(skew[1][2], skew[2][0], skew[0][1]);
    let dr = l.a * cross_matrix(l.b * axial);
    return (df - dr) * (2.0 * l.mu) + l.cof * (l.lambda * ddot(l.cof, df))
        + cofactor_derivative(l.f, df) * (l.lambda * (l.s - 1.0));
}

// Column-major flattening: k = row + 3·column; WGSL's m[column][row].
fn unit_matrix(k: u32) -> mat3x3<f32> {
    var m = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    m[k / 3u][k % 3u] = 1.0;
    return m;
}

// Cholesky test of a + shift·I (hessian.rs `project_psd`'s fast path).
fn is_positive_definite(a: ptr<function, array<f32, 81>>, shift: f32) -> bool {
    var l: array<f32, 81>;
    for (var j = 0u; j < 9u; j++) {
        var d = (*a)[j * 9u + j] + shift;
        for (var k = 0u; k < j; k++) {
            d -= l[j * 9u + k] * l[j * 9u + k];
        }
        if (!(d > 0.0)) {
            return false;
        }
        let ljj = sqrt(d);
        l[j * 9u + j] = ljj;
        for (var i = j + 1u; i < 9u; i++) {
            var s = (*a)[i * 9u + j];
            for (var k = 0u; k < j; k++) {
                s -= l[i * 9u + k] * l[j * 9u + k];
            }
            l[i * 9u + j] = s / ljj;
        }
    }
    return true;
}

// The closest PSD matrix (negative eigenvalues set to zero) by cyclic Jacobi rotations.
fn clamp_negative_eigenvalues(a: ptr<function, array<f32, 81>>) {
    var v: array<f32, 81>;
    for (var i = 0u; i < 81u; i++) {
        v[i] = select(0.0, 1.0, i % 10u == 0u);
    }
    for (var sweep = 0; sweep < 16; sweep++) {
        var off = 0.0;
        var total = 0.0;
        for (var i = 0u; i < 81u; i++) {
            total += (*a)[i] * (*a)[i];
            if (i % 10u != 0u) {
                off += (*a)[i] * (*a)[i];
            }
        }
        if (off <= 1e-14 * total) {
            break;
        }
        for (var p = 0u; p < 8u; p++) {
            for (var q = p + 1u; q < 9u; q++) {
                let apq = (*a)[p * 9u + q];
                if (apq == 0.0) {
                    continue;
                }
                let theta = ((*a)[q * 9u + q] - (*a)[p * 9u + p]) / (2.0 * apq);
                let t = sign(theta + select(0.0, 1.0, theta == 0.0)) / (abs(theta) + sqrt(theta * theta + 1.0));
                let c = 1.0 / sqrt(t * t + 1.0);
                let s = t * c;
                for (var k = 0u; k < 9u; k++) {
                    let akp = (*a)[k * 9u + p];
                    let akq = (*a)[k * 9u + q];
                    (*a)[k * 9u + p] = c * akp - s * akq;
                    (*a)[k * 9u + q] = s * akp + c * akq;
                }
                for (var k = 0u; k < 9u; k++) {
                    let apk = (*a)[p * 9u + k];
                    let aqk = (*a)[q * 9u + k];
                    (*a)[p * 9u + k] = c * apk - s * aqk;
                    (*a)[q * 9u + k] = s * apk + c * aqk;
                }
                for (var k = 0u; k < 9u; k++) {
                    let vkp = v[k * 9u + p];
                    let vkq = v[k * 9u + q];
                    v[k * 9u + p] = c * vkp - s * vkq;
                    v[k * 9u + q] = s * vkp + c * vkq;
                }
            }
        }
    }
    var lambda: array<f32, 9>;
    for (var k = 0u; k < 9u; k++) {
        lambda[k] = max((*a)[k * 9u + k], 0.0);
    }
    for (var i = 0u; i < 9u; i++) {
        for (var j = 0u; j < 9u; j++) {
            var s = 0.0;
            for (var k = 0u; k < 9u; k++) {
                s += v[i * 9u + k] * lambda[k] * v[j * 9u + k];
            }
            (*a)[i * 9u + j] = s;
        }
    }
}

// The particle's velocity-gradient stiffness V₀dt²·Lᵀ A L into im_stiff (row-major 9×9,
// symmetric), A the projected ∂P/∂F at F and L: vec(δG) ↦ vec(δG Fₙ) (hessian.rs
// `velocity_gradient_stiffness`).
fn store_stiffness(p: u32, mat: Material, f: mat3x3<f32>, f_n: mat3x3<f32>, volume_dt2: f32) {
    let lin = linearize(mat, f);
    var a: array<f32, 81>;
    for (var j = 0u; j < 9u; j++) {
        let dp = apply_lin(lin, unit_matrix(j));
        for (var k = 0u; k < 9u; k++) {
            a[k * 9u + j] = dp[k / 3u][k % 3u];
        }
    }
    for (var i = 0u; i < 9u; i++) {
        for (var j = i + 1u; j < 9u; j++) {
            let m = 0.5 * (a[i * 9u + j] + a[j * 9u + i]);
            a[i * 9u + j] = m;
            a[j * 9u + i] = m;
        }
    }
    if (!is_positive_definite(&a, 1e-5 * (mat.lambda + 2.0 * mat.mu))) {
        clamp_negative_eigenvalues(&a);
    }
    // (A L)[k][r + 3s] = Σ_c A[k][r + 3c] Fₙ(s, c); K[r + 3s][j] = Σ_c Fₙ(s, c) (A L)[r + 3c][j].
    var al: array<f32, 81>;
    for (var k = 0u; k < 9u; k++) {
        for (var r = 0u; r < 3u; r++) {
            for (var s = 0u; s < 3u; s++) {
                var sum = 0.0;
                for (var c = 0u; c < 3u; c++) {
                    sum += a[k * 9u + r + 3u * c] * f_n[c][s];
                }
                al[k * 9u + r + 3u * s] = sum;
            }
        }
    }
    let base = p * STIFF_STRIDE;
    for (var r = 0u; r < 3u; r++) {
        for (var s = 0u; s < 3u; s++) {
            for (var j = 0u; j < 9u; j++) {
                var sum = 0.0;
                for (var c = 0u; c < 3u; c++) {
                    sum += f_n[c][s] * al[(r + 3u * c) * 9u + j];
                }
                im_stiff[base + (r + 3u * s) * 9u + j] = sum * volume_dt2;
            }
        }
    }
}

// K·vec(g) unflattened.
fn stiffness_times(p: u32, g: mat3x3<f32>) -> mat3x3<f32> {
    let base = p * STIFF_STRIDE;
    var out = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    for (var i = 0u; i < 9u; i++) {
        var s = 0.0;
        for (var j = 0u; j < 9u; j++) {
            s += im_stiff[base + i * 9u + j] * g[j / 3u][j % 3u];
        }
        out[i / 3u][i % 3u] = s;
    }
    return out;
}

// ---- order-independent scatters: 64-bit fixed point ----
//
// f32 atomics add in the order the invocations happen to run, so their sums, and the Newton
// and CG counts that follow, would change from run to run. The particle scatters add
// integers instead, which associate. Each sum's unit is 2^(e − FIXED_BITS), 2^e the power of
// two above a bound on its contributions' magnitude that a first pass over the same
// particles raised (atomicMax of f32 bits: order-independent too), so a contribution is at
// most 2^FIXED_BITS units and is resolved to 2^−FIXED_BITS of the bound (f32 atomics resolve
// 2^−24 of each partial sum). A node takes one contribution per particle and the solver
// takes at most 2^22 particles (implicit.rs `MAX_PARTICLES`), so a sum stays below 2^62
// units: it cannot overflow. The 64 bits are two u32 atomics: atomicAdd on the low word
// returns the old value, so the carry into the high word is exact.

const FIXED_BITS: i32 = 40;
const TWO_32: f32 = 4294967296.0;
// 2^(FIXED_BITS + 1): a recomputed contribution a rounding above its bound still fits.
const FIXED_CLAMP: f32 = 2199023255552.0;

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

fn active_node(wid: u32, lid: u32) -> u32 {
    return active_blocks[wid] * NODES_PER_BLOCK + lid;
}

// ---- P2G without stress, and the nodes' start ----

// Which sums `im_clear` zeroes (the Rust side's `CLEAR_*`): the P2G momentum and mass,
// Φ's gradient and diagonal blocks, or the Hessian product.
override CLEAR: u32 = 0u;
const CLEAR_P2G: u32 = 0u;
const CLEAR_EVAL: u32 = 1u;
const CLEAR_PRODUCT: u32 = 2u;

// One workgroup per active block: zeroes the node values of the sums CLEAR names and
// resets their bounds, before a pass accumulates them again.
@compute @workgroup_size(NODES_PER_BLOCK)
fn im_clear(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    // (first value, value count, first bound slot, bound count)
    var span = vec4<u32>(0u, 4u, B_MOMENTUM, 2u);
    if (CLEAR == CLEAR_EVAL) {
        span = vec4<u32>(0u, 12u, B_GRAD, 2u);
    } else if (CLEAR == CLEAR_PRODUCT) {
        span = vec4<u32>(12u, 3u, B_PRODUCT, 1u);
    }
    if (wid.x == 0u && lid == 0u) {
        for (var b = span.z; b < span.z + span.w; b++) {
            atomicStore(&im_scal[b], 0u);
        }
    }
    acc_clear(active_node(wid.x, lid), span.x, span.y);
}

// APIC momentum and mass only (cpu `particle_to_grid(None, …)`; common.wgsl
// `scatter_apic` without a crack), in two passes: BOUND_PASS raises the bounds of the
// momentum and mass contributions, the other pass scatters them.
@compute @workgroup_size(WG)
fn im_p2g(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (!particle_live(p)) {
        return;
    }
    let part = particles[p];
    let m = pconst[p].x;
    let s = make_stencil(grid_pos(part.x.xyz));
    let q = part.c * (m * sim.origin_dx.w);
    let momentum = part.v.xyz * m - q * s.fx;
    let offs = node_offsets(s.base);
    let scale_p = fixed_scale(B_MOMENTUM);
    let scale_m = fixed_scale(B_MASS);
    var bound_p: Bound;
    var bound_m: Bound;
    for (var a = 0u; a < 3u; a++) {
        for (var b = 0u; b < 3u; b++) {
            for (var c = 0u; c < 3u; c++) {
                let w = s.w[a].x * s.w[b].y * s.w[c].z;
                let contrib = (momentum + q * vec3<f32>(f32(a), f32(b), f32(c))) * w;
                if (BOUND_PASS) {
                    bound3(&bound_p, contrib);
                    bound1(&bound_m, w * m);
                } else {
                    let i = offs[a].x + offs[b].y + offs[c].z;
                    fixed_add3(i, 0u, contrib, scale_p);
                    fixed_add(i, 3u, w * m, scale_m);
                }
            }
        }
    }
    if (BOUND_PASS) {
        raise_bound(B_MOMENTUM, bound_p);
        raise_bound(B_MASS, bound_m);
    }
}

struct Constraint {
    free: mat3x3<f32>,
    prescribed: vec3<f32>,
    normal: vec3<f32>,
    // The surface a node with one prescribed direction slides on: its velocity, and μ,
    // drag, tool index (bits) and tool part (bits) as in `ImNode.slip`.
    surface: vec3<f32>,
    slip: vec4<f32>,
}

// A fixed, frictionless surface (a wall).
fn still_surface() -> vec4<f32> {
    return vec4<f32>(0.0, 0.0, bitcast<f32>(NO_TOOL), 0.0);
}

fn fixed_at(v: vec3<f32>) -> Constraint {
    return Constraint(mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0)), v, vec3<f32>(0.0),
                      vec3<f32>(0.0), still_surface());
}

// Which components tools, the table and the walls prescribe (constraints.rs).
fn node_constraint(ijk: vec3<u32>, x: vec3<f32>, v_star: vec3<f32>) -> Constraint {
    for (var t = 0u; t < sim.n_tools; t++) {
        let tool = tools[st.substep * sim.n_tools + t];
        if (tool.shape.w < 0.0) {
            continue;
        }
        if (grip_region(tool, x).x < 0.0) {
            continue;
        }
        let dv = tool.lin.xyz + cross(tool.ang.xyz, x - tool.trans.xyz) - v_star;
        let normal = tool.rot[1];
        let along_normal = normal * dot(normal, dv);
        return fixed_at(v_star + along_normal + (dv - along_normal) * tool.shape.w);
    }
    var normals: array<vec3<f32>, 4>;
    var count = 0u;
    var v = v_star;
    var surface = vec3<f32>(0.0);
    var slip = still_surface();
    var hit_tool = NO_TOOL;
    var best: Hit;
    for (var t = 0u; t < sim.n_tools; t++) {
        let tool = tools[st.substep * sim.n_tools + t];
        if (!in_aabb(tool, x)) {
            continue;
        }
        let hit = tool_probe(tool, x);
        if (hit.distance < 0.0 && (hit_tool == NO_TOOL || hit.distance < best.distance)) {
            hit_tool = t;
            best = hit;
        }
    }
    if (hit_tool != NO_TOOL) {
        let tool = tools[st.substep * sim.n_tools + hit_tool];
        let v_tool = surface_velocity(tool, x, best.part);
        if (tool.kind.y == 1u) {
            return fixed_at(v_tool);
        }
        if (dot(v - v_tool, best.normal) < 0.0) {
            v = resolve(false, tool.aabb_min.w, tool.aabb_max.w, v, v_tool, best.normal, best.tangent);
            if (dot(best.tangent, best.tangent) > 0.0 || tool.aabb_max.w >= 1.0) {
                return fixed_at(v);
            }
            normals[count] = best.normal;
            surface = v_tool;
            slip = vec4<f32>(tool.aabb_min.w, tool.aabb_max.w, bitcast<f32>(hit_tool),
                             bitcast<f32>(best.part));
            count += 1u;
        }
    }
    let table = sim.blocks.w;
    if (table != 0u && x.z <= sim.table.x + 1e-3 * sim.origin_dx.w) {
        if (table == 1u) {
            return fixed_at(vec3<f32>(0.0));
        }
        if (v.z < 0.0) {
            v.z = 0.0;
            normals[count] = vec3<f32>(0.0, 0.0, 1.0);
            if (count == 0u) {
                slip.x = sim.table.y;
            }
            count += 1u;
        }
    }
    let walls = i32(WALL_NODES);
    for (var a = 0u; a < 3u; a++) {
        let i = i32(ijk[a]);
        let low = i < walls && v[a] < 0.0;
        let high = i >= i32(sim.nodes[a]) - walls && v[a] > 0.0;
        if (low || high) {
            v[a] = 0.0;
            var n = vec3<f32>(0.0);
            n[a] = select(-1.0, 1.0, low);
            normals[count] = n;
            count += 1u;
        }
    }
    if (count == 0u) {
        return Constraint(ID3, vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), still_surface());
    }
    if (count == 1u) {
        let n = normals[0];
        let nn = mat3x3<f32>(n * n.x, n * n.y, n * n.z);
        return Constraint(ID3 - nn, n * dot(n, v), n, surface, slip);
    }
    return fixed_at(v);
}

// Node `n` of mass `m` under constraint `c` chosen at velocity `v` (cpu `NodeWriter::constrain`),
// `v` projected onto it as the iterate; its friction weight is μ times the normal impulse
// `carried` over from the last substep where that was one, else the impulse that stops `v`
// at the surface.
fn constrain(n: ptr<function, ImNode>, m: f32, c: Constraint, v: vec3<f32>, carried: f32) {
    let arrival = m * max(dot(c.surface - v, c.normal), 0.0);
    let impulse = select(arrival, carried, carried > 0.0);
    (*n).free = c.free;
    (*n).prescribed = vec4<f32>(c.prescribed, 0.0);
    (*n).normal = vec4<f32>(c.normal, 0.0);
    (*n).surface = vec4<f32>(c.surface, c.slip.x * impulse);
    (*n).slip = c.slip;
    (*n).v = vec4<f32>(c.free * v + c.prescribed, 0.0);
}

// One workgroup per active block: mass and v*, the constraints, v = S v* + prescribed and
// the rest candidate trial = prescribed; counts the active blocks for `im_sum`; sums m².
@compute @workgroup_size(NODES_PER_BLOCK)
fn im_prepare(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32,
              @builtin(num_workgroups) groups: vec3<u32>) {
    if (wid.x == 0u && lid == 0u) {
        atomicStore(&im_scal[I_COUNT], groups.x);
    }
    let b = active_blocks[wid.x];
    let i = b * NODES_PER_BLOCK + lid;
    let at = NODE_WORDS * i;
    let m = fixed_load(i, 3u, fixed_unit(B_MASS));
    // The mass for the grid update (`grid_update_implicit`).
    atomicStore(&grid_acc[at + 3u], m);
    var node: ImNode;
    let zero = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    node.free = zero;
    node.slip = still_surface();
    node.block = zero;
    node.correction = im_nodes[i].correction;
    node.v_star = vec4<f32>(0.0, 0.0, 0.0, m);
    if (m > 0.0) {
        let ijk = node_coords(b, lid);
        let x = sim.origin_dx.xyz + vec3<f32>(ijk) * sim.origin_dx.w;
        let p = fixed_load3(i, 0u, fixed_unit(B_MOMENTUM));
        let v_star = p / m + st.gravity.xyz * st.dt;
        node.v_star = vec4<f32>(v_star, m);
        // The last substep's normal impulse (`im_finish`), where it touched the node.
        let last = im_nodes[i];
        let carried = select(0.0, last.normal.w,
                             bitcast<u32>(last.correction.w) + 1u == atomicLoad(&im_scal[I_EPOCH]));
        constrain(&node, m, node_constraint(ijk, x, v_star), v_star, carried);
        node.trial = node.prescribed;
    }
    im_nodes[i] = node;
    reduce_to_partials(lid, wid.x, m * m, 0.0);
}

// Grows the active set (cpu `activate_constraints`): a node with a free component that the
// iterate v moves into a tool, the table or a wall gets that constraint, as the grid update
// would set it, and v is projected onto it; only more prescribed components than now, so
// the set only grows and the host's rounds end. Counts the grown nodes in I_ACTIVATED.
@compute @workgroup_size(NODES_PER_BLOCK)
fn im_activate(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let b = active_blocks[wid.x];
    let i = b * NODES_PER_BLOCK + lid;
    var n = im_nodes[i];
    let free_now = n.free[0][0] + n.free[1][1] + n.free[2][2];
    // Fully prescribed nodes have nothing left to constrain.
    if (n.v_star.w <= 0.0 || free_now < 0.5) {
        return;
    }
    let ijk = node_coords(b, lid);
    let x = sim.origin_dx.xyz + vec3<f32>(ijk) * sim.origin_dx.w;
    let c = node_constraint(ijk, x, n.v.xyz);
    if (c.free[0][0] + c.free[1][1] + c.free[2][2] > free_now - 0.5) {
        return;
    }
    constrain(&n, n.v_star.w, c, n.v.xyz, 0.0);
    im_nodes[i] = n;
    atomicAdd(&im_scal[I_ACTIVATED], 1u);
}

// The warm-start candidate v* plus the last substep's elastic velocity change (zero where
// the last substep did not touch the node).
@compute @workgroup_size(NODES_PER_BLOCK)
fn im_trial_correction(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = active_node(wid.x, lid);
    let n = im_nodes[i];
    var corr = vec3<f32>(0.0);
    if (bitcast<u32>(n.correction.w) + 1u == atomicLoad(&im_scal[I_EPOCH])) {
        corr = n.correction.xyz;
    }
    im_nodes[i].trial = vec4<f32>(n.free * (n.v_star.xyz + corr) + n.prescribed.xyz, 0.0);
}

// ---- friction and drag of a node sliding on a surface (cpu `implicit::slip`) ----

struct SlipTerms {
    energy: f32,
    gradient: vec3<f32>,
    hessian: mat3x3<f32>,
}

fn outer(a: vec3<f32>, b: vec3<f32>) -> mat3x3<f32> {
    return mat3x3<f32>(a * b.x, a * b.y, a * b.z);
}

// D, ∇D and ∇²D of node `n` at velocity `v`: λf₀(|u|) + ½κ|u|² of the tangential velocity u
// relative to its surface; zero for a node without one prescribed direction.
fn slip_terms(n: ImNode, v: vec3<f32>) -> SlipTerms {
    var out: SlipTerms;
    let normal = n.normal.xyz;
    if (dot(normal, normal) == 0.0) {
        return out;
    }
    let lambda = n.surface.w;
    let kappa = n.v_star.w * n.slip.y / (1.0 - n.slip.y);
    if (lambda <= 0.0 && kappa <= 0.0) {
        return out;
    }
    let eps = SLIP_THRESHOLD * sim.origin_dx.w / st.dt;
    let rel = v - n.surface.xyz;
    let u = rel - normal * dot(normal, rel);
    let s = length(u);
    // f₀(s), f₁(s)/s and the coefficient of ûûᵀ, f₁′(s) − f₁(s)/s.
    var f0 = s;
    var f1_over_s = 1.0 / s;
    var along = -1.0 / s;
    if (s < eps) {
        f0 = s * s / eps - s * s * s / (3.0 * eps * eps) + eps / 3.0;
        f1_over_s = (2.0 - s / eps) / eps;
        along = -s / (eps * eps);
    }
    var unit = vec3<f32>(0.0);
    if (s > 0.0) {
        unit = u / s;
    }
    out.energy = lambda * f0 + 0.5 * kappa * s * s;
    out.gradient = u * (lambda * f1_over_s + kappa);
    out.hessian = (ID3 - outer(normal, normal)) * (lambda * f1_over_s + kappa)
        + outer(unit, unit) * (lambda * along);
    return out;
}

// ---- energy at the iterate or the trial (line search, warm start) ----

// Elastic energy Σ V₀Ψ; a particle crushed to J_MIN or inverted raises I_CRUSH (Φ = ∞).
@compute @workgroup_size(WG)
fn im_energy(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(workgroup_id) wid: vec3<u32>,
             @builtin(local_invocation_index) lid: u32) {
    let p = gid.x;
    var e = 0.0;
    if (p < sim.n_particles) {
        let part = particles[p];
        let g = stencil_gradients(part.x.xyz);
        let dg = velocity_gradient(g) * st.dt;
        let h = (part.f - ID3) + dg * part.f;
        if (1.0 + j_minus_one(h) <= J_MIN) {
            atomicStore(&im_scal[I_CRUSH], 1u);
        } else {
            let pc = pconst[p];
            e = pc.y * energy_density(materials[bitcast<u32>(pc.z)], h);
        }
    }
    reduce_to_partials(lid, wid.x, e, 0.0);
}

// Kinetic energy Σ ½m|v − v*|² of the iterate or the trial.
@compute @workgroup_size(NODES_PER_BLOCK)
fn im_kinetic(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = active_node(wid.x, lid);
    let n = im_nodes[i];
    var k = 0.0;
    if (n.v_star.w > 0.0) {
        let v = node_velocity(i);
        let dv = v - n.v_star.xyz;
        k = 0.5 * n.v_star.w * dot(dv, dv) + slip_terms(n, v).energy;
    }
    reduce_to_partials(lid, wid.x, k, 0.0);
}

// ---- Φ, its gradient and the Hessian at the iterate ----

// Per particle, the first pass: V₀Ψ, q = V₀dt·P Fₙᵀ (whose products q·∇wᵢ are the elastic
// gradient) kept for `im_eval_scatter`, and with HESSIAN the stiffness; raises the bounds of
// the gradient's and the diagonal blocks' contributions.
@compute @workgroup_size(WG)
fn im_eval(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(workgroup_id) wid: vec3<u32>,
           @builtin(local_invocation_index) lid: u32) {
    let p = gid.x;
    var e = 0.0;
    if (p < sim.n_particles) {
        let part = particles[p];
        let pc = pconst[p];
        let mat = materials[bitcast<u32>(pc.z)];
        let g = stencil_gradients(part.x.xyz);
        let dt = st.dt;
        let f_n = part.f;
        let dg = velocity_gradient(g) * dt;
        let h = (f_n - ID3) + dg * f_n;
        let f = ID3 + h;
        e = pc.y * energy_density(mat, h);
        let q = first_piola(mat, f) * transpose(f_n) * (pc.y * dt);
        store_q(p, q);
        raise_bound_q(B_GRAD, g, q);
        if (HESSIAN) {
            store_stiffness(p, mat, f, f_n, pc.y * dt * dt);
            if (BLOCK_JACOBI) {
                // |block entry| ≤ max |K| (Σ_c |∂wᵢ/∂x_c|)².
                var b: Bound;
                for (var k = 0u; k < 81u; k++) {
                    bound1(&b, im_stiff[p * STIFF_STRIDE + k]);
                }
                var reach = 0.0;
                for (var k = 0u; k < 27u; k++) {
                    let d = abs(g.grad[k]);
                    reach = max(reach, d.x + d.y + d.z);
                }
                b.largest *= reach * reach;
                b.total *= reach * reach;
                raise_bound(B_BLOCK, b);
            }
        }
    }
    reduce_to_partials(lid, wid.x, e, 0.0);
}

// Per particle, the second pass: the elastic gradient q·∇wᵢ scattered, and with HESSIAN
// the preconditioner's diagonal blocks.
@compute @workgroup_size(WG)
fn im_eval_scatter(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p >= sim.n_particles) {
        return;
    }
    let g = stencil_gradients(particles[p].x.xyz);
    let q = load_q(p);
    let scale = fixed_scale(B_GRAD);
    for (var k = 0u; k < 27u; k++) {
        fixed_add3(g.idx[k], 0u, q * g.grad[k], scale);
    }
    if (HESSIAN && BLOCK_JACOBI) {
        let scale_block = fixed_scale(B_BLOCK);
        let base = p * STIFF_STRIDE;
        for (var k = 0u; k < 27u; k++) {
            let d = g.grad[k];
            // Block (a, b) = Σ_c Σ_c' K[a + 3c][b + 3c'] d_c d_c'.
            var blk = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
            for (var a = 0u; a < 3u; a++) {
                for (var bb = 0u; bb < 3u; bb++) {
                    var s = 0.0;
                    for (var c = 0u; c < 3u; c++) {
                        for (var cc = 0u; cc < 3u; cc++) {
                            s += im_stiff[base + (a + 3u * c) * 9u + bb + 3u * cc] * d[c] * d[cc];
                        }
                    }
                    blk[bb][a] = s;
                }
            }
            fixed_add3(g.idx[k], 3u, blk[0], scale_block);
            fixed_add3(g.idx[k], 6u, blk[1], scale_block);
            fixed_add3(g.idx[k], 9u, blk[2], scale_block);
        }
    }
}

// Per node: the projected ∇Φ, with HESSIAN the preconditioner; sums ½m|v − v*|² and |∇Φ|².
@compute @workgroup_size(NODES_PER_BLOCK)
fn im_eval_nodes(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = active_node(wid.x, lid);
    let n = im_nodes[i];
    let m = n.v_star.w;
    var kinetic = 0.0;
    var norm2 = 0.0;
    if (m > 0.0) {
        let dv = n.v.xyz - n.v_star.xyz;
        let slip = slip_terms(n, n.v.xyz);
        let grad = n.free * (dv * m + fixed_load3(i, 0u, fixed_unit(B_GRAD)) + slip.gradient);
        im_nodes[i].grad = vec4<f32>(grad, 0.0);
        norm2 = dot(grad, grad);
        kinetic = 0.5 * m * dot(dv, dv) + slip.energy;
        if (HESSIAN) {
            var d = ID3 * m + slip.hessian;
            if (BLOCK_JACOBI) {
                let unit = fixed_unit(B_BLOCK);
                d += mat3x3<f32>(fixed_load3(i, 3u, unit), fixed_load3(i, 6u, unit), fixed_load3(i, 9u, unit));
            }
            // Inverse on the free subspace: (S D S + I − S)⁻¹ restricted by S.
            let restricted = n.free * d * n.free + (ID3 - n.free);
            var inv = ID3 * (1.0 / m);
            if (determinant(restricted) != 0.0) {
                inv = inverse3(restricted);
            }
            im_nodes[i].block = n.free * inv * n.free;
        }
    } else {
        im_nodes[i].grad = vec4<f32>(0.0);
    }
    reduce_to_partials(lid, wid.x, kinetic, norm2);
}

// ---- conjugate gradients on H·step = −∇Φ, scalars on the device ----

@compute @workgroup_size(NODES_PER_BLOCK)
fn im_cg_init(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = active_node(wid.x, lid);
    let n = im_nodes[i];
    let r = -n.grad.xyz;
    let z = n.block * r;
    im_nodes[i].step = vec4<f32>(0.0);
    im_nodes[i].r = vec4<f32>(r, 0.0);
    im_nodes[i].z = vec4<f32>(z, 0.0);
    im_nodes[i].d = vec4<f32>(z, 0.0);
    reduce_to_partials(lid, wid.x, dot(r, z), 0.0);
}

// One invocation: rz from the sum at SLOT (the host's SLOT_RZ0), the loop's state reset.
@compute @workgroup_size(1)
fn im_cg_start() {
    atomicStore(&im_scal[I_RZ], atomicLoad(&im_scal[SLOT]));
    atomicStore(&im_scal[I_DONE], 0u);
    atomicStore(&im_scal[I_ITER], 0u);
}

// Per particle, the first pass of the stiffness part of H·d: gather, 9×9, q kept for
// `im_product_scatter`; raises the bound of its contributions.
@compute @workgroup_size(WG)
fn im_product(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p >= sim.n_particles || cg_done()) {
        return;
    }
    let g = stencil_gradients(particles[p].x.xyz);
    var dg = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    for (var k = 0u; k < 27u; k++) {
        let d = im_nodes[g.idx[k]].d.xyz;
        dg += mat3x3<f32>(d * g.grad[k].x, d * g.grad[k].y, d * g.grad[k].z);
    }
    let q = stiffness_times(p, dg);
    store_q(p, q);
    raise_bound_q(B_PRODUCT, g, q);
}

// Per particle, the second pass: q·∇wᵢ scattered.
@compute @workgroup_size(WG)
fn im_product_scatter(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p >= sim.n_particles || cg_done()) {
        return;
    }
    let g = stencil_gradients(particles[p].x.xyz);
    let q = load_q(p);
    let scale = fixed_scale(B_PRODUCT);
    for (var k = 0u; k < 27u; k++) {
        fixed_add3(g.idx[k], 12u, q * g.grad[k], scale);
    }
}

// Per node: product = S(K d + m d + ∇²D d); sums d·product.
@compute @workgroup_size(NODES_PER_BLOCK)
fn im_product_finish(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = active_node(wid.x, lid);
    let n = im_nodes[i];
    let q = n.free * (fixed_load3(i, 12u, fixed_unit(B_PRODUCT)) + n.d.xyz * n.v_star.w
        + slip_terms(n, n.v.xyz).hessian * n.d.xyz);
    let at = i * ACC_WORDS + PRODUCT_WORD;
    atomicStore(&im_acc[at], bitcast<u32>(q.x));
    atomicStore(&im_acc[at + 1u], bitcast<u32>(q.y));
    atomicStore(&im_acc[at + 2u], bitcast<u32>(q.z));
    reduce_to_partials(lid, wid.x, dot(n.d.xyz, q), 0.0);
}

// One invocation: α = rz/(d·Hd) from the sum at SLOT, or done (cap reached, or a
// direction of no positive curvature).
@compute @workgroup_size(1)
fn im_cg_alpha() {
    if (cg_done()) {
        return;
    }
    let pap = scal_f(SLOT);
    let iterations = atomicLoad(&im_scal[I_ITER]);
    if (iterations >= atomicLoad(&im_scal[I_CAP]) || !(pap > 0.0) || !is_finite(pap)) {
        atomicStore(&im_scal[I_DONE], 1u);
        return;
    }
    set_scal_f(I_CG_ALPHA, scal_f(I_RZ) / pap);
    atomicStore(&im_scal[I_ITER], iterations + 1u);
}

// Per node: step += αd, r −= αHd, z = P r; sums |r|² and r·z.
@compute @workgroup_size(NODES_PER_BLOCK)
fn im_cg_update(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = active_node(wid.x, lid);
    var rr = 0.0;
    var rz = 0.0;
    if (!cg_done()) {
        let n = im_nodes[i];
        let alpha = scal_f(I_CG_ALPHA);
        let r = n.r.xyz - product_load(i) * alpha;
        let z = n.block * r;
        im_nodes[i].step = vec4<f32>(n.step.xyz + n.d.xyz * alpha, 0.0);
        im_nodes[i].r = vec4<f32>(r, 0.0);
        im_nodes[i].z = vec4<f32>(z, 0.0);
        rr = dot(r, r);
        rz = dot(r, z);
    }
    reduce_to_partials(lid, wid.x, rr, rz);
}

// One invocation: done when ‖r‖ reaches the target, else β = rz_new/rz.
@compute @workgroup_size(1)
fn im_cg_beta() {
    if (cg_done()) {
        return;
    }
    if (sqrt(scal_f(SLOT)) <= scal_f(I_TARGET)) {
        atomicStore(&im_scal[I_DONE], 1u);
        return;
    }
    let rz_new = scal_f(SLOT + 1u);
    set_scal_f(I_BETA, rz_new / scal_f(I_RZ));
    set_scal_f(I_RZ, rz_new);
}

@compute @workgroup_size(NODES_PER_BLOCK)
fn im_cg_direction(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    if (cg_done()) {
        return;
    }
    let i = active_node(wid.x, lid);
    let n = im_nodes[i];
    im_nodes[i].d = vec4<f32>(n.z.xyz + n.d.xyz * scal_f(I_BETA), 0.0);
}

// ---- line search ----

// Sums ∇Φ·step (the slope along the Newton step).
@compute @workgroup_size(NODES_PER_BLOCK)
fn im_slope(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = active_node(wid.x, lid);
    let n = im_nodes[i];
    reduce_to_partials(lid, wid.x, dot(n.grad.xyz, n.step.xyz), 0.0);
}

// trial = v + α·step, α from the host.
@compute @workgroup_size(NODES_PER_BLOCK)
fn im_trial_step(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = active_node(wid.x, lid);
    let n = im_nodes[i];
    im_nodes[i].trial = vec4<f32>(n.v.xyz + n.step.xyz * scal_f(I_ALPHA), 0.0);
}

// v = trial.
@compute @workgroup_size(NODES_PER_BLOCK)
fn im_accept(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = active_node(wid.x, lid);
    im_nodes[i].v = im_nodes[i].trial;
}

// ---- the end of the solve ----

// Per node: momentum (v − g dt)m and mass into the P2G accumulators for the grid update
// (cpu `solve_velocities`: the solution for a free node, v* − (∂E/∂v)/m for a constrained
// one), and v − v* along the free components kept for the next substep's warm start. A
// node with one prescribed direction leaves the solution in `grid_v` for the grid update
// (`grid_update_implicit`) with w: 1 + 8·tool + part, or −1 for the table or a wall; 0 for
// every other node.
@compute @workgroup_size(NODES_PER_BLOCK)
fn im_finish(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = active_node(wid.x, lid);
    let n = im_nodes[i];
    let m = n.v_star.w;
    let epoch = bitcast<f32>(atomicLoad(&im_scal[I_EPOCH]));
    var settled = vec4<f32>(0.0);
    if (m > 0.0) {
        let elastic = fixed_load3(i, 0u, fixed_unit(B_GRAD));
        var v = n.v_star.xyz - elastic / m;
        if (n.free[0][0] + n.free[1][1] + n.free[2][2] > 2.5) {
            v = n.v.xyz;
        }
        if (dot(n.normal.xyz, n.normal.xyz) > 0.0) {
            let tool = bitcast<u32>(n.slip.z);
            let code = select(f32(1u + 8u * tool + bitcast<u32>(n.slip.w)), -1.0, tool == NO_TOOL);
            settled = vec4<f32>(n.v.xyz, code);
        }
        let reaction = (n.v.xyz - n.v_star.xyz) * m + elastic;
        im_nodes[i].normal.w = max(dot(n.normal.xyz, reaction), 0.0);
        let p = (v - st.gravity.xyz * st.dt) * m;
        let at = NODE_WORDS * i;
        atomicStore(&grid_acc[at], p.x);
        atomicStore(&grid_acc[at + 1u], p.y);
        atomicStore(&grid_acc[at + 2u], p.z);
        im_nodes[i].correction = vec4<f32>(n.free * (n.v.xyz - n.v_star.xyz), epoch);
    } else {
        im_nodes[i].correction = vec4<f32>(vec3<f32>(0.0), epoch);
    }
    grid_v[i] = settled;
}
