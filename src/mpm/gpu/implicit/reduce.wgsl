// The scalar block's accessors, the node workgroups' indexing, and the two-level
// reductions: each workgroup leaves its two sums in the partials, then one workgroup
// (`im_sum`) adds them up, compensated, into the scalar block. The partials are added in a
// fixed tree over the workgroups, the node workgroups in the active blocks' increasing
// index (sparse.wgsl `compact`), so the sums are the same from run to run.

// Which sum `im_sum` writes (its two regions to SLOT and SLOT + 1), over node or particle
// workgroups.
override SLOT: u32 = SLOT_ELASTIC;
override OVER_NODES: bool = true;

fn scal_f(i: u32) -> f32 {
    return bitcast<f32>(atomicLoad(&im_scal[i]));
}

fn set_scal_f(i: u32, v: f32) {
    atomicStore(&im_scal[i], bitcast<u32>(v));
}

// Node `lid` of node workgroup `wid` (one workgroup per active block).
fn active_node(wid: u32, lid: u32) -> u32 {
    return active_blocks[wid] * NODES_PER_BLOCK + lid;
}

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
