// Conjugate gradients on H·step = −∇Φ with their scalars on the device: one iteration is
// the product's clear, two particle passes and the nodes' finish, then α, the update, β and
// the direction; once done (the cap, the target or no positive curvature) every kernel
// returns at once, so the host may record iterations past the stop.

fn cg_done() -> bool {
    return atomicLoad(&im_scal[I_DONE]) != 0u;
}


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

// One invocation: rz from the sum at SLOT (SLOT_RZ0), the loop's state reset.
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
        fixed_add3(g.idx[k], V_PRODUCT, q * g.grad[k], scale);
    }
}

// Per node: product = S(K d + m d + ∇²D d); sums d·product.
@compute @workgroup_size(NODES_PER_BLOCK)
fn im_product_finish(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = active_node(wid.x, lid);
    let n = im_nodes[i];
    let q = n.free * (fixed_load3(i, V_PRODUCT, fixed_unit(B_PRODUCT)) + n.d.xyz * n.v_star.w
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
