// Sparse grid bookkeeping: which BLOCK³-node blocks the particles' stencils touch, compacted
// into a list that sizes the indirect dispatches of the clear and grid-update stages.

// One invocation: resets the substep's counters (PB-MPM, total Lagrangian and implicit
// substeps; MLS-MPM and PIC reset them in `first_blocks` and `end_substep`).
@compute @workgroup_size(1)
fn begin() {
    reset_counters();
    if (!guard_tripped()) {
        atomicAdd(&stats[S_SUBSTEPS], 1u);
    }
}

// The indirect dispatch's count and the per-substep contact-block counter.
fn reset_counters() {
    atomicStore(&args[0], 0u);
    atomicStore(&args[1], 1u);
    atomicStore(&args[2], 1u);
    if (!guard_tripped()) {
        atomicStore(&stats[S_CONTACT_BLOCKS], 0u);
    }
}

// One invocation per particle: flags the blocks its stencil covers (on the rest
// configuration with total Lagrangian MPM). MLS-MPM's and PIC's G2P flag them for the next
// substep as they move the particle, so these substeps need no pass of their own for it.
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
    mark_stencil_blocks(grid_pos(x));
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
    compact_blocks(lid);
}

// One workgroup before an MLS-MPM or PIC frame's first substep: the counters reset, then
// the block list of the blocks `mark` flagged.
@compute @workgroup_size(COMPACT_WG)
fn first_blocks(@builtin(local_invocation_index) lid: u32) {
    if (lid == 0u) {
        reset_counters();
    }
    storageBarrier();
    compact_blocks(lid);
}

// One workgroup at the end of an MLS-MPM or PIC substep, two single-workgroup passes in one:
// this substep's contact impulses reduced (grid_update.wgsl's `reduce_impulses`), then the
// counters reset and the next substep's block list made from the blocks G2P flagged.
@compute @workgroup_size(COMPACT_WG)
fn end_substep(@builtin(local_invocation_index) lid: u32) {
    if (lid < MAX_TOOLS * IMPULSE_WORDS) {
        reduce_impulse_word(lid);
    }
    storageBarrier();
    if (lid == 0u) {
        if (!guard_tripped()) {
            atomicAdd(&stats[S_SUBSTEPS], 1u);
        }
        reset_counters();
    }
    storageBarrier();
    compact_blocks(lid);
}

// The exclusive scan of `compact` by the workgroup's invocation `lid`.
fn compact_blocks(lid: u32) {
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
