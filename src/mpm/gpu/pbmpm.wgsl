// PB-MPM stages (cpu `pbmpm`): the elastic constraint on C, the momentum-only P2G, the G2P
// of the inner iterations (v and C only) and the reset between iterations. Sparse-grid
// bookkeeping, clear, grid update (gravity only in the first iteration's Step), the last
// G2P with integration and the impulse reduction are MLS-MPM's stages.

const IDENTITY = mat3x3<f32>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));

// Relaxation times the softness s = (c·dt)² / ((c·dt)² + dx²/4) (cpu `constraint_step`).
fn constraint_step(mat: Material, dt: f32) -> f32 {
    let dx = sim.origin_dx.w;
    let c2dt2 = (mat.lambda + 2.0 * mat.mu) / mat.density * dt * dt;
    return st.relaxation * c2dt2 / (c2dt2 + 0.25 * dx * dx);
}

// One invocation per particle: C ← C + step·((R(F*)·F⁻¹ − I)/dt − C), F* = (I + C·dt)F.
@compute @workgroup_size(WG)
fn pb_constrain(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (!particle_live(p)) {
        return;
    }
    let part = particles[p];
    let f = part.f;
    let j = determinant(f);
    if (j == 0.0) {
        return;
    }
    // F⁻¹ from the adjugate: its rows are the cross products of F's columns.
    let f_inv = transpose(mat3x3<f32>(cross(f[1], f[2]), cross(f[2], f[0]), cross(f[0], f[1]))) * (1.0 / j);
    let dt = st.dt;
    let f_star = (IDENTITY + part.c * dt) * f;
    let goal = (rotation_of(f_star) * f_inv - IDENTITY) * (1.0 / dt);
    let mat = materials[bitcast<u32>(pconst[p].z)];
    particles[p].c = part.c + (goal - part.c) * constraint_step(mat, dt);
}

// P2G of APIC momentum and mass only (cpu `particle_to_grid(None)`); a cut particle's
// affine momentum about its kept nodes (common.wgsl `scatter_apic_about_kept`).
@compute @workgroup_size(WG)
fn pb_p2g(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (!particle_live(p)) {
        return;
    }
    let part = particles[p];
    let m = pconst[p].x;
    let s = make_stencil(grid_pos(part.x.xyz));
    let q = part.c * (m * sim.origin_dx.w);
    scatter_apic_about_kept(s, m, part.v.xyz, q, particle_crack(p));
}

// G2P of an inner iteration: v and C only; the guard looks at the last, integrating G2P.
@compute @workgroup_size(WG)
fn pb_g2p(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (!particle_live(p)) {
        return;
    }
    let part = particles[p];
    let gathered = gather(grid_pos(part.x.xyz), particle_crack(p), part.v.xyz);
    particles[p].v = vec4<f32>(gathered.v, 0.0);
    particles[p].c = gathered.c;
}

// One invocation between iterations: the next grid update lists its contact blocks afresh
// (`reduce_impulses` has added this iteration's).
@compute @workgroup_size(1)
fn pb_next_iteration() {
    atomicStore(&stats[S_CONTACT_BLOCKS], 0u);
}
