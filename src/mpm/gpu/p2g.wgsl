// P2G: fused APIC momentum + MLS force transfer (cpu `particle_to_grid`), scattered with
// atomics into the 27 stencil nodes.

@compute @workgroup_size(64)
fn p2g(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p >= sim.n_particles || atomicLoad(&stats[S_GUARD]) != 0u) {
        return;
    }
    let part = particles[p];
    let pc = pconst[p];
    let m = pc.x;
    let mat = materials[bitcast<u32>(pc.z)];
    let dx = sim.origin_dx.w;
    let s = make_stencil(grid_pos(part.x.xyz));
    let tau = kirchhoff_stress(mat, part.f);
    let stress_scale = -st.dt * 4.0 * sim.inv_dx * sim.inv_dx;
    let q = (tau * (stress_scale * pc.y) + part.c * m) * dx;
    let momentum = part.v.xyz * m - q * s.fx;
    let offs = node_offsets(s.base);
    for (var a = 0u; a < 3u; a++) {
        for (var b = 0u; b < 3u; b++) {
            for (var c = 0u; c < 3u; c++) {
                let w = s.w[a].x * s.w[b].y * s.w[c].z;
                let contrib = (momentum + q * vec3<f32>(f32(a), f32(b), f32(c))) * w;
                let i = 4u * (offs[a].x + offs[b].y + offs[c].z);
                acc_add_p(i, contrib.x);
                acc_add_p(i + 1u, contrib.y);
                acc_add_p(i + 2u, contrib.z);
                acc_add_m(i + 3u, w * m);
            }
        }
    }
}
