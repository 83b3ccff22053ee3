// The start of a substep's solve: P2G of momentum and mass without stress, the nodes'
// start (v*, constraints, the warm start's candidates).

// Which sums `im_clear` zeroes (layout.rs `Clear`): the P2G momentum and mass, Φ's
// gradient and diagonal blocks, or the Hessian product.
override CLEAR: u32 = CLEAR_P2G;
// `im_p2g`: the pass that raises the bounds (true) or the one that scatters.
override BOUND_PASS: bool = false;

// One workgroup per active block: zeroes the node values of the sums CLEAR names and
// resets their bounds, before a pass accumulates them again.
@compute @workgroup_size(NODES_PER_BLOCK)
fn im_clear(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    // (first value, value count, first bound slot, bound count)
    var span = vec4<u32>(V_MOMENTUM, 4u, B_MOMENTUM, 2u);
    if (CLEAR == CLEAR_EVAL) {
        span = vec4<u32>(V_GRAD, 12u, B_GRAD, 2u);
    } else if (CLEAR == CLEAR_PRODUCT) {
        span = vec4<u32>(V_PRODUCT, 3u, B_PRODUCT, 1u);
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
                    fixed_add3(i, V_MOMENTUM, contrib, scale_p);
                    fixed_add(i, V_MASS, w * m, scale_m);
                }
            }
        }
    }
    if (BOUND_PASS) {
        raise_bound(B_MOMENTUM, bound_p);
        raise_bound(B_MASS, bound_m);
    }
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
    let m = fixed_load(i, V_MASS, fixed_unit(B_MASS));
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
        let p = fixed_load3(i, V_MOMENTUM, fixed_unit(B_MOMENTUM));
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
