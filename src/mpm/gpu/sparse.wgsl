// Sparse grid bookkeeping: which BLOCK³-node blocks the particles' stencils touch, compacted
// into a list that sizes the indirect dispatches of the clear and grid-update stages.

// One invocation: resets the substep's counters.
@compute @workgroup_size(1)
fn begin() {
    atomicStore(&args[0], 0u);
    atomicStore(&args[1], 1u);
    atomicStore(&args[2], 1u);
    if (guard_tripped()) {
        return;
    }
    atomicStore(&stats[S_CONTACT_BLOCKS], 0u);
    atomicAdd(&stats[S_SUBSTEPS], 1u);
}

// One invocation per particle: flags the (up to 8) blocks its 3×3×3 stencil covers.
@compute @workgroup_size(WG)
fn mark(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (!particle_live(p)) {
        return;
    }
    let s = make_stencil(grid_pos(particles[p].x.xyz));
    let hi_node = vec3<i32>(sim.nodes.xyz) - vec3<i32>(3);
    let base = vec3<u32>(clamp(s.base, vec3<i32>(0), hi_node));
    let lo = base / BLOCK;
    let hi = (base + vec3<u32>(2u)) / BLOCK;
    for (var bx = lo.x; bx <= hi.x; bx++) {
        for (var by = lo.y; by <= hi.y; by++) {
            for (var bz = lo.z; bz <= hi.z; bz++) {
                atomicStore(&block_flags[block_index(vec3<u32>(bx, by, bz))], 1u);
            }
        }
    }
}

// One invocation per block of the domain: appends flagged blocks to the active list (the
// count is the x of the indirect arguments) and clears the flag for the next substep.
@compute @workgroup_size(WG)
fn compact(@builtin(global_invocation_id) gid: vec3<u32>) {
    let b = gid.x;
    if (b >= sim.nodes.w) {
        return;
    }
    if (atomicLoad(&block_flags[b]) != 0u) {
        atomicStore(&block_flags[b], 0u);
        let i = atomicAdd(&args[0], 1u);
        active_blocks[i] = b;
    }
}

// One workgroup per active block: zeroes its nodes before P2G.
@compute @workgroup_size(NODES_PER_BLOCK)
fn clear(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let node = active_blocks[wid.x] * NODES_PER_BLOCK + lid;
    for (var k = 0u; k < NODE_WORDS; k++) {
        acc_zero(NODE_WORDS * node + k);
    }
}
