// Grid update (cpu `update_grid`): velocity from momentum, gravity, contact with the
// nearest tool the node is inside of (only tools whose bounding box holds the node are
// evaluated), momentum exchange into per-tool impulses, table and walls. One workgroup per
// active block; each block with contact leaves its per-tool sums in `partials`. Total
// Lagrangian MPM's (cpu tlmpm.rs) works on the rest configuration's nodes at their current
// places, with its force and the material grip (`grid_update_tl`).

var<workgroup> wg_guard: u32;
var<workgroup> wg_contacts: atomic<u32>;
var<workgroup> wg_any: u32;
var<workgroup> wg_slot: u32;
var<workgroup> wg_tool: array<u32, NODES_PER_BLOCK>;
var<workgroup> wg_val: array<f32, NODES_PER_BLOCK * IMPULSE_WORDS>;

@compute @workgroup_size(NODES_PER_BLOCK)
fn grid_update(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    update_block(wid, lid, false, false);
}

@compute @workgroup_size(NODES_PER_BLOCK)
fn grid_update_tl(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    update_block(wid, lid, false, true);
}

// After an implicit solve: a node the solve settled in contact (`im_finish` left its
// velocity in `grid_v`, w ≠ 0) takes that velocity, friction included, and the momentum it
// loses on the way is its tool's impulse (cpu `update_grid_with`).
@compute @workgroup_size(NODES_PER_BLOCK)
fn grid_update_implicit(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    update_block(wid, lid, true, false);
}

fn update_block(wid: vec3<u32>, lid: u32, settled_by_solve: bool, total_lagrangian: bool) {
    if (lid == 0u) {
        wg_guard = select(0u, 1u, guard_tripped());
        atomicStore(&wg_contacts, 0u);
    }
    if (workgroupUniformLoad(&wg_guard) != 0u) {
        return;
    }
    let b = active_blocks[wid.x];
    let node = b * NODES_PER_BLOCK + lid;
    let at_node = NODE_WORDS * node;
    let m = acc_load_m(at_node + 3u);
    var out = vec4<f32>(0.0);
    var hit_tool = NO_TOOL;
    var dp = vec3<f32>(0.0);
    var dl = vec3<f32>(0.0);
    var jaw_opening = 0.0;
    var grip = vec3<f32>(0.0);
    var grip_mass = 0.0;
    var grip_lever = 0.0;
    var contact_inertia = 0.0;
    if (m > 0.0) {
        let ijk = node_coords(b, lid);
        let x_grid = sim.origin_dx.xyz + vec3<f32>(ijk) * sim.origin_dx.w;
        var x = x_grid;
        let p = vec3<f32>(acc_load_p(at_node), acc_load_p(at_node + 1u), acc_load_p(at_node + 2u));
        var v = p / m + st.gravity.xyz * st.dt;
        let tl = tl_words(node);
        if (total_lagrangian) {
            // The node's current place, and its force (tlmpm.rs `step`).
            x += vec3<f32>(acc_load_m(tl + 3u), acc_load_m(tl + 4u), acc_load_m(tl + 5u))
                * (sim.origin_dx.w / (PLACE_SCALE * m));
            v += vec3<f32>(acc_load_p(tl), acc_load_p(tl + 1u), acc_load_p(tl + 2u)) / m;
        }
        var settled = vec4<f32>(0.0);
        if (settled_by_solve) {
            settled = grid_v[node];
        }
        var handled = settled.w != 0.0;
        if (settled.w > 0.0) {
            let code = u32(settled.w) - 1u;
            hit_tool = code / 8u;
            let tool = tools[st.substep * sim.n_tools + hit_tool];
            dp = (v - settled.xyz) * m;
            dl = cross(x - tool.trans.xyz, dp);
            if (code % 8u != 0u) {
                jaw_opening = jaw_angle(code % 8u, 1.0) * dot(dl, tool.rot[0]);
            }
            atomicAdd(&wg_contacts, 1u);
        }
        if (handled) {
            v = settled.xyz;
        }
        // The gripper that holds the node, with the node's lever and jaw: in total Lagrangian
        // MPM the gripper whose captured particles carry at least half the node's mass, wherever
        // the node is (captured.rs `holder`); otherwise the first gripper whose grip region holds
        // the node (cpu `hold_node`).
        var grip_tool = NO_TOOL;
        var lever = 0.0;
        var jaw = 0u;
        if (total_lagrangian) {
            let holder = atomicLoad(&tl_nodes[node]);
            if (holder != 0u && acc_load_m(tl + 6u) >= HELD_SHARE * m) {
                grip_tool = holder - 1u;
                let tool = tools[st.substep * sim.n_tools + grip_tool];
                let local = transpose(tool.rot) * (x - tool.trans.xyz);
                lever = sqrt(local.y * local.y + local.z * local.z);
                jaw = select(2u, 1u, local.y >= 0.0);
            }
        } else if (!handled) {
            for (var t = 0u; t < sim.n_tools && grip_tool == NO_TOOL; t++) {
                let tool = tools[st.substep * sim.n_tools + t];
                if (tool.shape.w < 0.0) {
                    continue;
                }
                let region = grip_region(tool, x);
                if (region.x >= 0.0) {
                    grip_tool = t;
                    lever = region.x;
                    jaw = u32(region.y);
                }
            }
        }
        if (grip_tool != NO_TOOL) {
            let held = hold_at(tools[st.substep * sim.n_tools + grip_tool], x, v, m, lever, jaw);
            v = held.v;
            dp = held.dp;
            dl = held.dl;
            jaw_opening = held.jaw_opening;
            grip = held.required;
            grip_mass = m;
            grip_lever = held.mass_lever;
            hit_tool = grip_tool;
            handled = true;
            atomicAdd(&wg_contacts, 1u);
        }
        // Nearest tool the node is inside of.
        var best_depth = 0.0;
        var best_hit: Hit;
        for (var t = 0u; t < sim.n_tools; t++) {
            if (handled) {
                break;
            }
            let tool = tools[st.substep * sim.n_tools + t];
            if (!in_aabb(tool, x)) {
                continue;
            }
            let hit = tool_probe(tool, x);
            if (hit.distance < 0.0 && (hit_tool == NO_TOOL || hit.distance < best_depth)) {
                hit_tool = t;
                best_depth = hit.distance;
                best_hit = hit;
            }
        }
        if (hit_tool != NO_TOOL && !handled) {
            let tool = tools[st.substep * sim.n_tools + hit_tool];
            let v_tool = surface_velocity(tool, x, best_hit.part);
            let v_new = resolve(tool.kind.y == STICKY, tool.aabb_min.w, tool.aabb_max.w, v, v_tool,
                                best_hit.normal, best_hit.tangent);
            dp = (v - v_new) * m;
            dl = cross(x - tool.trans.xyz, dp);
            if (best_hit.part != 0u) {
                // Jaw k turns by jaw_angle(k, θ) about the hinge (the tool's x axis): the
                // opening θ takes that share of the torque about it.
                jaw_opening = jaw_angle(best_hit.part, 1.0) * dot(dl, tool.rot[0]);
            }
            v = v_new;
            atomicAdd(&wg_contacts, 1u);
        }
        if (hit_tool != NO_TOOL) {
            let arm = x - tools[st.substep * sim.n_tools + hit_tool].trans.xyz;
            contact_inertia = m * dot(arm, arm);
        }
        if (total_lagrangian) {
            v = boundary_at(grid_pos(x), x_grid.z, x, v);
        } else {
            v = apply_boundary(ijk, x, v);
        }
        out = vec4<f32>(v, m);
    }
    grid_v[node] = out;
    wg_tool[lid] = hit_tool;
    let at = lid * IMPULSE_WORDS;
    wg_val[at] = dp.x;
    wg_val[at + 1u] = dp.y;
    wg_val[at + 2u] = dp.z;
    wg_val[at + 3u] = dl.x;
    wg_val[at + 4u] = dl.y;
    wg_val[at + 5u] = dl.z;
    wg_val[at + 6u] = select(0.0, 1.0, hit_tool != NO_TOOL);
    wg_val[at + 7u] = jaw_opening;
    wg_val[at + 8u] = grip.x;
    wg_val[at + 9u] = grip.y;
    wg_val[at + 10u] = grip.z;
    wg_val[at + 11u] = grip_mass;
    wg_val[at + 12u] = grip_lever;
    wg_val[at + 13u] = select(0.0, m, hit_tool != NO_TOOL);
    wg_val[at + 14u] = contact_inertia;
    wg_val[at + 15u] = 0.0;
    workgroupBarrier();
    if (lid == 0u) {
        wg_any = atomicLoad(&wg_contacts);
        if (wg_any > 0u) {
            wg_slot = atomicAdd(&stats[S_CONTACT_BLOCKS], 1u);
        }
    }
    if (workgroupUniformLoad(&wg_any) == 0u) {
        return;
    }
    // Invocation lid sums (tool t, word k) over the block's nodes, for every
    // (t, k) = lid + j·NODES_PER_BLOCK.
    for (var tk = lid; tk < MAX_TOOLS * IMPULSE_WORDS; tk += NODES_PER_BLOCK) {
        let t = tk / IMPULSE_WORDS;
        let k = tk % IMPULSE_WORDS;
        var sum = 0.0;
        for (var n = 0u; n < NODES_PER_BLOCK; n++) {
            if (wg_tool[n] == t) {
                sum += wg_val[n * IMPULSE_WORDS + k];
            }
        }
        partials[wg_slot * MAX_TOOLS * IMPULSE_WORDS + tk] = sum;
    }
}

// One workgroup: adds this substep's per-block contact sums to the frame's tool impulses.
// Runs after G2P so that a substep the guard rejects contributes nothing, as on the CPU.
@compute @workgroup_size(MAX_TOOLS * IMPULSE_WORDS)
fn reduce_impulses(@builtin(local_invocation_index) lid: u32) {
    reduce_impulse_word(lid);
}
