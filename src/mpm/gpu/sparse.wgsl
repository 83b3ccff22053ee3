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

// One invocation per particle: flags the (up to 8) blocks its 3×3×3 stencil covers (on the
// rest configuration with total Lagrangian MPM).
@compute @workgroup_size(WG)
fn mark(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (!particle_live(p)) {
        return;
    }
    var x = particles[p].x.xyz;
    if (TOTAL_LAGRANGIAN) {
        x = tl_rest[p].xyz;
    }
    let s = make_stencil(grid_pos(x));
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

// Invocations of `compact`'s single workgroup.
const COMPACT_WG: u32 = 256u;
var<workgroup> wg_scan: array<u32, COMPACT_WG>;

// One workgroup: the flagged blocks listed in increasing block index (an exclusive scan of
// the flags; invocation t takes the t-th contiguous run of blocks), the count in the
// indirect arguments' x, the flags cleared for the next substep. The list is the same from
// run to run, and with it the order of every per-block partial sum (implicit.wgsl); an
// atomic append would order the blocks as the workgroups happened to run.
@compute @workgroup_size(COMPACT_WG)
fn compact(@builtin(local_invocation_index) lid: u32) {
    let n = sim.nodes.w;
    let run = (n + COMPACT_WG - 1u) / COMPACT_WG;
    let start = min(lid * run, n);
    let end = min(start + run, n);
    var count = 0u;
    for (var b = start; b < end; b++) {
        count += select(0u, 1u, atomicLoad(&block_flags[b]) != 0u);
    }
    wg_scan[lid] = count;
    workgroupBarrier();
    for (var s = 1u; s < COMPACT_WG; s *= 2u) {
        var sum = wg_scan[lid];
        if (lid >= s) {
            sum += wg_scan[lid - s];
        }
        workgroupBarrier();
        wg_scan[lid] = sum;
        workgroupBarrier();
    }
    var at = wg_scan[lid] - count;
    for (var b = start; b < end; b++) {
        if (atomicLoad(&block_flags[b]) != 0u) {
            atomicStore(&block_flags[b], 0u);
            active_blocks[at] = b;
            at += 1u;
        }
    }
    if (lid == COMPACT_WG - 1u) {
        atomicStore(&args[0], wg_scan[lid]);
    }
}

// One workgroup per active block: zeroes its nodes before P2G (with total Lagrangian MPM,
// their own words and gripper too).
@compute @workgroup_size(NODES_PER_BLOCK)
fn clear(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let node = active_blocks[wid.x] * NODES_PER_BLOCK + lid;
    for (var k = 0u; k < NODE_WORDS; k++) {
        acc_zero(NODE_WORDS * node + k);
    }
    if (TOTAL_LAGRANGIAN) {
        for (var k = 0u; k < TL_WORDS; k++) {
            acc_zero(tl_words(node) + k);
        }
        atomicStore(&tl_nodes[node], 0u);
    }
}
