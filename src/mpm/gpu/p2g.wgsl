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
