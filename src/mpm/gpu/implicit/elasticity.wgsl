// The particles' side of Φ: each particle's stencil of MLS kernel gradients, its
// velocity gradient at the iterate or the trial, the strain energy Ψ and stress P at
// F = (I + dt Σᵢ vᵢ∇wᵢₚᵀ)Fₙ, and the velocity-gradient stiffness (cpu `implicit::energy`
// and `hessian.rs`).

// Which velocity the energy kernels read: the iterate (false) or the trial.
override SELECT_TRIAL: bool = false;

const ID3 = mat3x3<f32>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));

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
    if (mat.model == NEO_HOOKEAN) {
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
    if (mat.model == NEO_HOOKEAN) {
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
