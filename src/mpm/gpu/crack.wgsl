// Crack marking (cpu `crack::mark`): each uncut particle that a slicer's edge passes this
// substep takes the blade's plane as its crack, n·d: n the plane's unit normal pointing
// towards the particle, d its distance from the plane (at least MIN_OFFSET_CELLS cells, so
// that a particle on the plane still tells its sides apart). Dispatched only in a scene
// with a slicer.

@compute @workgroup_size(WG)
fn mark_cracks(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (!particle_live(p) || any(cracks[p].xyz != vec3<f32>(0.0))) {
        return;
    }
    let x = particles[p].x.xyz;
    let dx = sim.origin_dx.w;
    let band = STENCIL_REACH_CELLS * dx;
    for (var t = 0u; t < sim.n_tools; t++) {
        let tool = tools[st.substep * sim.n_tools + t];
        if (tool.kind.x != SLICER_KIND) {
            continue;
        }
        // slicer.rs `edge_passing`: within the blade's length (shape.x), nearer its plane
        // (local y = 0) than a stencil's reach, and at most that far above its edge
        // (local z = −height, shape.y).
        let local = transpose(tool.rot) * (x - tool.trans.xyz);
        let above_edge = local.z + tool.shape.y;
        let covered = abs(local.x) <= 0.5 * tool.shape.x && abs(local.y) < band
            && above_edge >= 0.0 && above_edge <= band;
        if (covered) {
            let sign = select(1.0, -1.0, local.y < 0.0);
            let d = max(abs(local.y), MIN_OFFSET_CELLS * dx);
            cracks[p] = vec4<f32>(tool.rot[1] * (sign * d), 0.0);
            return;
        }
    }
}
