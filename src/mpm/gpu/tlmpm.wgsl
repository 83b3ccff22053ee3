// Total Lagrangian MPM's own passes (cpu tlmpm.rs, captured.rs; its P2G, grid update and
// G2P are entries of those stages): the material grip's capture, and the stiffening bounds
// at a frame's end (stiffening.rs). tl_rest[p].w is the gripper that holds particle p
// (t + 1, 0 while free); tl_nodes holds each node's gripper, then each gripper's holding
// flag as of the last substep.

fn holding_flag(t: u32) -> u32 {
    return sim.nodes.w * NODES_PER_BLOCK + t;
}

fn grips(tool: Tool) -> bool {
    return tool.kind.x == GRIPPER_KIND && tool.shape.w >= 0.0;
}

// One invocation per particle (captured.rs `update`): a gripper that starts to hold
// captures the free particles in its grip region; one that stops lets its particles go.
@compute @workgroup_size(WG)
fn tl_capture(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (!particle_live(p)) {
        return;
    }
    var mark = u32(tl_rest[p].w);
    let x = particles[p].x.xyz;
    for (var t = 0u; t < sim.n_tools; t++) {
        let tool = tools[st.substep * sim.n_tools + t];
        let holds = grips(tool);
        if (holds == (atomicLoad(&tl_nodes[holding_flag(t)]) != 0u)) {
            continue;
        }
        if (holds && mark == 0u && grip_region(tool, x).x >= 0.0) {
            mark = t + 1u;
        }
        if (!holds && mark == t + 1u) {
            mark = 0u;
        }
    }
    tl_rest[p].w = f32(mark);
}

// One invocation, after `tl_capture`: each gripper's holding flag for the next substep.
@compute @workgroup_size(1)
fn tl_commit() {
    if (guard_tripped()) {
        return;
    }
    for (var t = 0u; t < sim.n_tools; t++) {
        let tool = tools[st.substep * sim.n_tools + t];
        atomicStore(&tl_nodes[holding_flag(t)], select(0u, 1u, grips(tool)));
    }
}

// One invocation per particle at a frame's end: the largest bound on 1/σ_min(F) over the
// free particles (word S_TL_BOUND) and over each gripper's (the words after it).
@compute @workgroup_size(WG)
fn tl_bound(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p >= sim.n_particles) {
        return;
    }
    let bound = inverse_stretch_bound(particles[p].f);
    atomicMax(&stats[S_TL_BOUND + u32(tl_rest[p].w)], bitcast<u32>(bound));
}
