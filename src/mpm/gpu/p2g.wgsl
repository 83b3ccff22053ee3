// P2G: fused APIC momentum + MLS force transfer (cpu `particle_to_grid`; the affine part
// weighted by sim.transfer.x, 0 for PIC), scattered with atomics into the 27 stencil nodes.
// A material with toughness advances the particle's damage and scatters the degraded
// stress (damage.wgsl).

@compute @workgroup_size(WG)
fn p2g(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (!particle_live(p)) {
        return;
    }
    let part = particles[p];
    let pc = pconst[p];
    let m = pc.x;
    let mat = materials[bitcast<u32>(pc.z)];
    let dx = sim.origin_dx.w;
    let s = make_stencil(grid_pos(part.x.xyz));
    var tau: mat3x3<f32>;
    if (mat.onset > 0.0) {
        let degraded = degraded_stress(mat, part.f, part.x.w);
        tau = degraded.tau;
        particles[p].x.w = degraded.d;
        particles[p].f = degraded.f;
    } else {
        tau = kirchhoff_stress(mat, part.f);
    }
    let stress_scale = -st.dt * 4.0 * sim.inv_dx * sim.inv_dx;
    let q = (tau * (stress_scale * pc.y) + part.c * (m * sim.transfer.x)) * dx;
    scatter_apic(s, m, part.v.xyz, q, particle_crack(p));
}

// Total Lagrangian P2G (cpu tlmpm.rs `substep`): on the rest configuration's stencil, each
// particle scatters its mass and momentum into the node's accumulators and, into its total
// Lagrangian words (`tl_words`), dt times its force −V⁰·P·∇N, its mass-weighted offset from
// the node (the node's current place is its grid position plus their sum over its mass),
// and, for a captured particle, its mass and its gripper (captured.rs `scatter_at`). A
// material with toughness tears as in MLS-MPM's P2G.
@compute @workgroup_size(WG)
fn p2g_tl(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (!particle_live(p)) {
        return;
    }
    let part = particles[p];
    let pc = pconst[p];
    let m = pc.x;
    let mat = materials[bitcast<u32>(pc.z)];
    let rest = tl_rest[p];
    let s = make_stencil(grid_pos(rest.xyz));
    let dw = weight_derivatives(s.fx);
    let offs = node_offsets(s.base);
    // A material with toughness advances the damage and degrades the tension, as above.
    var tau: mat3x3<f32>;
    var f = part.f;
    if (mat.onset > 0.0) {
        let degraded = degraded_stress(mat, part.f, part.x.w);
        tau = degraded.tau;
        f = degraded.f;
        particles[p].x.w = degraded.d;
        particles[p].f = f;
    } else {
        tau = kirchhoff_stress(mat, part.f);
    }
    // dt·(−V⁰·P)/dx with P = τ·F⁻ᵀ: the node's dt·force is this times ∇N in grid units.
    let stress = tau * inverse_transpose(f) * (-pc.y * sim.inv_dx * st.dt);
    let momentum = part.v.xyz * m;
    let g = grid_pos(part.x.xyz);
    let holder = u32(rest.w);
    for (var a = 0u; a < 3u; a++) {
        for (var b = 0u; b < 3u; b++) {
            for (var c = 0u; c < 3u; c++) {
                let node = offs[a].x + offs[b].y + offs[c].z;
                let w = s.w[a].x * s.w[b].y * s.w[c].z;
                let i = NODE_WORDS * node;
                acc_add_p(i, momentum.x * w);
                acc_add_p(i + 1u, momentum.y * w);
                acc_add_p(i + 2u, momentum.z * w);
                acc_add_m(i + 3u, m * w);
                let t = tl_words(node);
                let force = stress * weight_gradient(s, dw, a, b, c);
                acc_add_p(t, force.x);
                acc_add_p(t + 1u, force.y);
                acc_add_p(t + 2u, force.z);
                let offset = (g - vec3<f32>(s.base + vec3<i32>(vec3<u32>(a, b, c)))) * (m * w * PLACE_SCALE);
                acc_add_m(t + 3u, offset.x);
                acc_add_m(t + 4u, offset.y);
                acc_add_m(t + 5u, offset.z);
                if (holder != 0u) {
                    acc_add_m(t + 6u, m * w);
                    atomicMax(&tl_nodes[node], holder);
                }
            }
        }
    }
}
