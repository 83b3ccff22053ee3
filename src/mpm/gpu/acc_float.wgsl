// P2G accumulation with f32 atomics (SHADER_FLOAT32_ATOMIC).

fn acc_zero(i: u32) {
    atomicStore(&grid_acc[i], 0.0);
}

fn acc_add_p(i: u32, v: f32) {
    atomicAdd(&grid_acc[i], v);
}

fn acc_add_m(i: u32, v: f32) {
    atomicAdd(&grid_acc[i], v);
}

fn acc_load_p(i: u32) -> f32 {
    return atomicLoad(&grid_acc[i]);
}

fn acc_load_m(i: u32) -> f32 {
    return atomicLoad(&grid_acc[i]);
}
