// G2P (cpu `grid_to_particle`): velocity and affine velocity from the grid, advection with
// clamping to the domain, deformation-gradient update, damping, the guard, and a cut
// particle's crack carried with the material.

var<workgroup> wg_max: atomic<u32>;
var<workgroup> wg_clamped: atomic<u32>;

@compute @workgroup_size(WG)
fn g2p(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    if (lid == 0u) {
        atomicStore(&wg_max, 0u);
        atomicStore(&wg_clamped, 0u);
    }
    workgroupBarrier();
    let p = gid.x;
    if (p < sim.n_particles && !guard_before()) {
        g2p_particle(p);
    }
    workgroupBarrier();
    if (lid == 0u) {
        atomicMax(&stats[S_MAX_SPEED], atomicLoad(&wg_max));
        let c = atomicLoad(&wg_clamped);
        if (c > 0u) {
            atomicAdd(&stats[S_CLAMPED], c);
        }
    }
}

fn g2p_particle(p: u32) {
    let part = particles[p];
    let dt = st.dt;
    let g = grid_pos(part.x.xyz);
    let crack = particle_crack(p);
    let gathered = gather(g, crack, part.v.xyz);
    var v = gathered.v;
    let c_new = gathered.c;
    var g_new = g + v * (dt * sim.inv_dx);
    let lo = vec3<f32>(1.0);
    let hi = vec3<f32>(sim.nodes.xyz) - vec3<f32>(2.0);
    let inside = min(max(g_new, lo), hi);
    if (any(inside != g_new)) {
        atomicAdd(&wg_clamped, 1u);
        g_new = inside;
    }
    let id = mat3x3<f32>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));
    let f_new = (id + c_new * dt) * part.f;
    let damping = materials[bitcast<u32>(pconst[p].z)].damping;
    if (damping > 0.0) {
        // Implicit damping, as the CPU: v ← v / (1 + α·dt), stable for any α·dt.
        v /= 1.0 + damping * dt;
    }
    let speed = length(v);
    let finite = is_finite(speed) && is_finite_m(c_new) && is_finite_m(f_new) && is_finite3(g_new);
    if (!finite || speed > sim.max_speed) {
        // Leave the particle as it was; note what tripped in v.w for the frame's report.
        particles[p].v.w = select(-1.0, speed, finite);
        atomicMax(&stats[S_GUARD], st.substep + 1u);
        atomicMin(&stats[S_GUARD_PARTICLE], p);
        return;
    }
    atomicMax(&wg_max, bitcast<u32>(speed));
    // w: the damage (damage.wgsl), which P2G advances.
    particles[p].x = vec4<f32>(sim.origin_dx.xyz + g_new * sim.origin_dx.w, part.x.w);
    particles[p].v = vec4<f32>(v, 0.0);
    particles[p].c = c_new;
    particles[p].f = f_new;
    if (is_cracked(crack)) {
        cracks[p] = vec4<f32>(advect_crack(crack, c_new, dt), 0.0);
    }
}

// The crack carried through a substep of velocity gradient c (crack.rs `advect`): the
// normal turns as a covector, n ← (I − dt·Cᵀ)·n, renormalised; the distance is kept.
fn advect_crack(crack: vec3<f32>, c: mat3x3<f32>, dt: f32) -> vec3<f32> {
    let d = length(crack);
    let turned = crack - (transpose(c) * crack) * dt;
    let len = length(turned);
    if (len > 0.0 && is_finite(len)) {
        return turned * (d / len);
    }
    return crack;
}

// One invocation at the end of a frame: fills in the guard event's details.
@compute @workgroup_size(1)
fn finalize_guard() {
    if (!guard_tripped()) {
        return;
    }
    let part = particles[atomicLoad(&stats[S_GUARD_PARTICLE])];
    atomicStore(&stats[S_GUARD_KIND], select(GUARD_RUNAWAY, GUARD_NON_FINITE, part.v.w < 0.0));
    atomicStore(&stats[S_GUARD_SPEED], bitcast<u32>(part.v.w));
    atomicStore(&stats[S_GUARD_POS], bitcast<u32>(part.x.x));
    atomicStore(&stats[S_GUARD_POS + 1u], bitcast<u32>(part.x.y));
    atomicStore(&stats[S_GUARD_POS + 2u], bitcast<u32>(part.x.z));
}

// One invocation per particle at the end of a frame: what the readback needs, positions
// in the first n entries, with a slicer the cracks in the next n, then the deformation
// gradient's columns (three entries a particle), read back only when an output asks for it.
@compute @workgroup_size(WG)
fn extract_positions(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p < sim.n_particles) {
        let part = particles[p];
        out_pos[p] = part.x;
        var at = sim.n_particles + 3u * p;
        if (CUTTING) {
            out_pos[sim.n_particles + p] = cracks[p];
            at += sim.n_particles;
        }
        out_pos[at] = vec4<f32>(part.f[0], 0.0);
        out_pos[at + 1u] = vec4<f32>(part.f[1], 0.0);
        out_pos[at + 2u] = vec4<f32>(part.f[2], 0.0);
    }
}
