// P2G accumulation in i32 fixed point (core WGSL atomics). Momentum is counted in units of
// `sim.fixed.z` (a cell's mass of the densest material times an eighth of the guard speed
// `solver.max_speed`) and mass in units of `sim.fixed.w` (that cell mass), both times
// `sim.fixed.x` = 2^26: a node holds ±32 units, i.e. up to 32 cells' worth of mass and a
// momentum of 4 cell masses at the guard speed. Resolution: 2^-26 of a unit per particle
// contribution (rounded to nearest). Past the range the f32→i32 conversion saturates and
// the atomic sum wraps: the node's velocity is then wrong by a large amount, which trips
// the runaway guard.

fn acc_zero(i: u32) {
    atomicStore(&grid_acc[i], 0);
}

fn acc_add_p(i: u32, v: f32) {
    atomicAdd(&grid_acc[i], i32(round(v / sim.fixed.z * sim.fixed.x)));
}

fn acc_add_m(i: u32, v: f32) {
    atomicAdd(&grid_acc[i], i32(round(v / sim.fixed.w * sim.fixed.x)));
}

fn acc_load_p(i: u32) -> f32 {
    return f32(atomicLoad(&grid_acc[i])) * sim.fixed.y * sim.fixed.z;
}

fn acc_load_m(i: u32) -> f32 {
    return f32(atomicLoad(&grid_acc[i])) * sim.fixed.y * sim.fixed.w;
}
