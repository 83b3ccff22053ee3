// The end of the solve: what the grid update and the next substep take from it.

// Per node: momentum (v − g dt)m and mass into the P2G accumulators for the grid update
// (cpu `solve_velocities`: the solution for a free node, v* − (∂E/∂v)/m for a constrained
// one), and v − v* along the free components kept for the next substep's warm start. A
// node with one prescribed direction leaves the solution in `grid_v` for the grid update
// (`grid_update_implicit`) with w: 1 + 8·tool + part, or −1 for the table or a wall; 0 for
// every other node.
@compute @workgroup_size(NODES_PER_BLOCK)
fn im_finish(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = active_node(wid.x, lid);
    let n = im_nodes[i];
    let m = n.v_star.w;
    let epoch = bitcast<f32>(atomicLoad(&im_scal[I_EPOCH]));
    var settled = vec4<f32>(0.0);
    if (m > 0.0) {
        let elastic = fixed_load3(i, V_GRAD, fixed_unit(B_GRAD));
        var v = n.v_star.xyz - elastic / m;
        if (n.free[0][0] + n.free[1][1] + n.free[2][2] > 2.5) {
            v = n.v.xyz;
        }
        if (dot(n.normal.xyz, n.normal.xyz) > 0.0) {
            let tool = bitcast<u32>(n.slip.z);
            let code = select(f32(1u + 8u * tool + bitcast<u32>(n.slip.w)), -1.0, tool == NO_TOOL);
            settled = vec4<f32>(n.v.xyz, code);
        }
        let reaction = (n.v.xyz - n.v_star.xyz) * m + elastic;
        im_nodes[i].normal.w = max(dot(n.normal.xyz, reaction), 0.0);
        let p = (v - st.gravity.xyz * st.dt) * m;
        let at = NODE_WORDS * i;
        atomicStore(&grid_acc[at], p.x);
        atomicStore(&grid_acc[at + 1u], p.y);
        atomicStore(&grid_acc[at + 2u], p.z);
        im_nodes[i].correction = vec4<f32>(n.free * (n.v.xyz - n.v_star.xyz), epoch);
    } else {
        im_nodes[i].correction = vec4<f32>(vec3<f32>(0.0), epoch);
    }
    grid_v[i] = settled;
}
