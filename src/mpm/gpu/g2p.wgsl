// G2P (cpu `grid_to_particle`): velocity and affine velocity from the grid, advection with
// clamping to the domain, deformation-gradient update, damping, the guard, a cut
// particle's crack carried with the material, and the blocks its next stencil covers.

var<workgroup> wg_max: atomic<u32>;
var<workgroup> wg_clamped: atomic<u32>;

@compute @workgroup_size(WG)
fn g2p(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    g2p_entry(gid.x, lid, false);
}

@compute @workgroup_size(WG)
fn g2p_tl(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    g2p_entry(gid.x, lid, true);
}

// G2P of particle p, total Lagrangian MPM's or the others', then the workgroup's statistics.
fn g2p_entry(p: u32, lid: u32, total_lagrangian: bool) {
    if (lid == 0u) {
        atomicStore(&wg_max, 0u);
        atomicStore(&wg_clamped, 0u);
    }
    workgroupBarrier();
    if (p < sim.n_particles && !guard_before()) {
        if (total_lagrangian) {
            tl_g2p_particle(p);
        } else {
            g2p_particle(p);
        }
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
    if (guard_trips(p, speed, finite)) {
        return;
    }
    store_particle(p, g_new, v, c_new, f_new, speed);
    // The next substep's block list (sparse.wgsl's `end_substep`) starts from these flags.
    mark_stencil_blocks(g_new);
    if (is_cracked(crack)) {
        cracks[p] = vec4<f32>(advect_crack(crack, c_new, dt), 0.0);
    }
}

// Whether the guard trips on a particle's new state; if so, notes what tripped in v.w for
// the frame's report (the particle is left as it was).
fn guard_trips(p: u32, speed: f32, finite: bool) -> bool {
    if (!finite || speed > sim.max_speed) {
        particles[p].v.w = select(-1.0, speed, finite);
        atomicMax(&stats[S_GUARD], st.substep + 1u);
        atomicMin(&stats[S_GUARD_PARTICLE], p);
        return true;
    }
    return false;
}

// Stores a particle's new state (grid position g) and counts its speed.
fn store_particle(p: u32, g: vec3<f32>, v: vec3<f32>, c: mat3x3<f32>, f: mat3x3<f32>, speed: f32) {
    atomicMax(&wg_max, bitcast<u32>(speed));
    // w: the damage (damage.wgsl), which P2G advances.
    particles[p].x = vec4<f32>(sim.origin_dx.xyz + g * sim.origin_dx.w, particles[p].x.w);
    particles[p].v = vec4<f32>(v, 0.0);
    particles[p].c = c;
    particles[p].f = f;
}

// FLIP's share of total Lagrangian MPM's particle velocity update (tlmpm.rs `FLIP`).
const FLIP: f32 = 0.99;

// Total Lagrangian G2P (cpu tlmpm.rs `step`): on the rest configuration's stencil, the
// velocity by FLIP blended with PIC (the velocity before the grid update is the
// accumulators' momentum over mass), the position by the PIC velocity, and
// F += dt·Σ vᵢ ⊗ ∇Nᵢ(X), which C keeps.
fn tl_g2p_particle(p: u32) {
    let part = particles[p];
    let dt = st.dt;
    let s = make_stencil(grid_pos(tl_rest[p].xyz));
    let dw = weight_derivatives(s.fx);
    let offs = node_offsets(s.base);
    var v_pic = vec3<f32>(0.0);
    var dv = vec3<f32>(0.0);
    var grad_v = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    for (var a = 0u; a < 3u; a++) {
        for (var b = 0u; b < 3u; b++) {
            for (var c = 0u; c < 3u; c++) {
                let node = offs[a].x + offs[b].y + offs[c].z;
                let w = s.w[a].x * s.w[b].y * s.w[c].z;
                let vi = grid_v[node].xyz;
                let i = NODE_WORDS * node;
                let m = acc_load_m(i + 3u);
                var v_before = vi;
                if (m > 0.0) {
                    v_before = vec3<f32>(acc_load_p(i), acc_load_p(i + 1u), acc_load_p(i + 2u)) / m;
                }
                let grad = weight_gradient(s, dw, a, b, c) * sim.inv_dx;
                v_pic += vi * w;
                dv += (vi - v_before) * w;
                grad_v += mat3x3<f32>(vi * grad.x, vi * grad.y, vi * grad.z);
            }
        }
    }
    var v = (part.v.xyz + dv) * FLIP + v_pic * (1.0 - FLIP);
    let damping = materials[bitcast<u32>(pconst[p].z)].damping;
    if (damping > 0.0) {
        v /= 1.0 + damping * dt;
    }
    var g_new = grid_pos(part.x.xyz) + v_pic * (dt * sim.inv_dx);
    let inside = min(max(g_new, vec3<f32>(1.0)), vec3<f32>(sim.nodes.xyz) - vec3<f32>(2.0));
    if (any(inside != g_new)) {
        atomicAdd(&wg_clamped, 1u);
        g_new = inside;
    }
    let f_new = part.f + grad_v * dt;
    let speed = length(v);
    let finite = is_finite(speed) && is_finite_m(f_new) && is_finite3(g_new);
    if (guard_trips(p, speed, finite)) {
        return;
    }
    store_particle(p, g_new, v, grad_v, f_new, speed);
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
