// The constraints of the solve (cpu `implicit::constraints`): which velocity components
// tools, the table and the walls prescribe at a node, and the active set's growth after
// Newton converged.

struct Constraint {
    free: mat3x3<f32>,
    prescribed: vec3<f32>,
    normal: vec3<f32>,
    // The surface a node with one prescribed direction slides on: its velocity, and μ,
    // drag, tool index (bits) and tool part (bits) as in `ImNode.slip`.
    surface: vec3<f32>,
    slip: vec4<f32>,
}

// A fixed, frictionless surface (a wall).
fn still_surface() -> vec4<f32> {
    return vec4<f32>(0.0, 0.0, bitcast<f32>(NO_TOOL), 0.0);
}

fn fixed_at(v: vec3<f32>) -> Constraint {
    return Constraint(mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0)), v, vec3<f32>(0.0),
                      vec3<f32>(0.0), still_surface());
}

// Which components tools, the table and the walls prescribe (constraints.rs).
fn node_constraint(ijk: vec3<u32>, x: vec3<f32>, v_star: vec3<f32>) -> Constraint {
    for (var t = 0u; t < sim.n_tools; t++) {
        let tool = tools[st.substep * sim.n_tools + t];
        if (tool.shape.w < 0.0) {
            continue;
        }
        if (grip_region(tool, x).x < 0.0) {
            continue;
        }
        let dv = tool.lin.xyz + cross(tool.ang.xyz, x - tool.trans.xyz) - v_star;
        let normal = tool.rot[1];
        let along_normal = normal * dot(normal, dv);
        return fixed_at(v_star + along_normal + (dv - along_normal) * tool.shape.w);
    }
    var normals: array<vec3<f32>, 4>;
    var count = 0u;
    var v = v_star;
    var surface = vec3<f32>(0.0);
    var slip = still_surface();
    var hit_tool = NO_TOOL;
    var best: Hit;
    for (var t = 0u; t < sim.n_tools; t++) {
        let tool = tools[st.substep * sim.n_tools + t];
        if (!in_aabb(tool, x)) {
            continue;
        }
        let hit = tool_probe(tool, x);
        if (hit.distance < 0.0 && (hit_tool == NO_TOOL || hit.distance < best.distance)) {
            hit_tool = t;
            best = hit;
        }
    }
    if (hit_tool != NO_TOOL) {
        let tool = tools[st.substep * sim.n_tools + hit_tool];
        let v_tool = surface_velocity(tool, x, best.part);
        if (tool.kind.y == STICKY) {
            return fixed_at(v_tool);
        }
        if (dot(v - v_tool, best.normal) < 0.0) {
            v = resolve(false, tool.aabb_min.w, tool.aabb_max.w, v, v_tool, best.normal, best.tangent);
            if (dot(best.tangent, best.tangent) > 0.0 || tool.aabb_max.w >= 1.0) {
                return fixed_at(v);
            }
            normals[count] = best.normal;
            surface = v_tool;
            slip = vec4<f32>(tool.aabb_min.w, tool.aabb_max.w, bitcast<f32>(hit_tool),
                             bitcast<f32>(best.part));
            count += 1u;
        }
    }
    let table = sim.blocks.w;
    if (table != TABLE_NONE && x.z <= sim.table.x + 1e-3 * sim.origin_dx.w) {
        if (table == TABLE_BONDED) {
            return fixed_at(vec3<f32>(0.0));
        }
        if (v.z < 0.0) {
            v.z = 0.0;
            normals[count] = vec3<f32>(0.0, 0.0, 1.0);
            if (count == 0u) {
                slip.x = sim.table.y;
            }
            count += 1u;
        }
    }
    let walls = i32(WALL_NODES);
    for (var a = 0u; a < 3u; a++) {
        let i = i32(ijk[a]);
        let low = i < walls && v[a] < 0.0;
        let high = i >= i32(sim.nodes[a]) - walls && v[a] > 0.0;
        if (low || high) {
            v[a] = 0.0;
            var n = vec3<f32>(0.0);
            n[a] = select(-1.0, 1.0, low);
            normals[count] = n;
            count += 1u;
        }
    }
    if (count == 0u) {
        return Constraint(ID3, vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), still_surface());
    }
    if (count == 1u) {
        let n = normals[0];
        let nn = mat3x3<f32>(n * n.x, n * n.y, n * n.z);
        return Constraint(ID3 - nn, n * dot(n, v), n, surface, slip);
    }
    return fixed_at(v);
}

// Node `n` of mass `m` under constraint `c` chosen at velocity `v` (cpu `NodeWriter::constrain`),
// `v` projected onto it as the iterate; its friction weight is μ times the normal impulse
// `carried` over from the last substep where that was one, else the impulse that stops `v`
// at the surface.
fn constrain(n: ptr<function, ImNode>, m: f32, c: Constraint, v: vec3<f32>, carried: f32) {
    let arrival = m * max(dot(c.surface - v, c.normal), 0.0);
    let impulse = select(arrival, carried, carried > 0.0);
    (*n).free = c.free;
    (*n).prescribed = vec4<f32>(c.prescribed, 0.0);
    (*n).normal = vec4<f32>(c.normal, 0.0);
    (*n).surface = vec4<f32>(c.surface, c.slip.x * impulse);
    (*n).slip = c.slip;
    (*n).v = vec4<f32>(c.free * v + c.prescribed, 0.0);
}

// Grows the active set (cpu `activate_constraints`): a node with a free component that the
// iterate v moves into a tool, the table or a wall gets that constraint, as the grid update
// would set it, and v is projected onto it; only more prescribed components than now, so
// the set only grows and the host's rounds end. Counts the grown nodes in I_ACTIVATED.
@compute @workgroup_size(NODES_PER_BLOCK)
fn im_activate(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let b = active_blocks[wid.x];
    let i = b * NODES_PER_BLOCK + lid;
    var n = im_nodes[i];
    let free_now = n.free[0][0] + n.free[1][1] + n.free[2][2];
    // Fully prescribed nodes have nothing left to constrain.
    if (n.v_star.w <= 0.0 || free_now < 0.5) {
        return;
    }
    let ijk = node_coords(b, lid);
    let x = sim.origin_dx.xyz + vec3<f32>(ijk) * sim.origin_dx.w;
    let c = node_constraint(ijk, x, n.v.xyz);
    if (c.free[0][0] + c.free[1][1] + c.free[2][2] > free_now - 0.5) {
        return;
    }
    constrain(&n, n.v_star.w, c, n.v.xyz, 0.0);
    im_nodes[i] = n;
    atomicAdd(&im_scal[I_ACTIVATED], 1u);
}
