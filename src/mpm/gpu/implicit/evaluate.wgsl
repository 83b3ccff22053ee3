// Φ at the iterate or the trial (line search, warm start), and Φ, its gradient and the
// Hessian's stiffness and preconditioner at the iterate.

// Whether `im_eval*` build the Hessian and the block-Jacobi preconditioner.
override HESSIAN: bool = false;
override BLOCK_JACOBI: bool = true;

// ---- energy at the iterate or the trial ----

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
        fixed_add3(g.idx[k], V_GRAD, q * g.grad[k], scale);
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
            fixed_add3(g.idx[k], V_BLOCK, blk[0], scale_block);
            fixed_add3(g.idx[k], V_BLOCK + 3u, blk[1], scale_block);
            fixed_add3(g.idx[k], V_BLOCK + 6u, blk[2], scale_block);
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
        let grad = n.free * (dv * m + fixed_load3(i, V_GRAD, fixed_unit(B_GRAD)) + slip.gradient);
        im_nodes[i].grad = vec4<f32>(grad, 0.0);
        norm2 = dot(grad, grad);
        kinetic = 0.5 * m * dot(dv, dv) + slip.energy;
        if (HESSIAN) {
            var d = ID3 * m + slip.hessian;
            if (BLOCK_JACOBI) {
                let unit = fixed_unit(B_BLOCK);
                d += mat3x3<f32>(fixed_load3(i, V_BLOCK, unit), fixed_load3(i, V_BLOCK + 3u, unit),
                                fixed_load3(i, V_BLOCK + 6u, unit));
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
