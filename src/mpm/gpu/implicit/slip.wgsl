// Friction and drag of a node sliding on a surface (cpu `implicit::slip`).

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
