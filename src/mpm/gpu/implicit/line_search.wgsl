// The line search along the Newton step; the host picks α and judges Φ.

// Sums ∇Φ·step (the slope along the Newton step).
@compute @workgroup_size(NODES_PER_BLOCK)
fn im_slope(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = active_node(wid.x, lid);
    let n = im_nodes[i];
    reduce_to_partials(lid, wid.x, dot(n.grad.xyz, n.step.xyz), 0.0);
}

// trial = v + α·step, α from the host.
@compute @workgroup_size(NODES_PER_BLOCK)
fn im_trial_step(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = active_node(wid.x, lid);
    let n = im_nodes[i];
    im_nodes[i].trial = vec4<f32>(n.v.xyz + n.step.xyz * scal_f(I_ALPHA), 0.0);
}

// v = trial.
@compute @workgroup_size(NODES_PER_BLOCK)
fn im_accept(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = active_node(wid.x, lid);
    im_nodes[i].v = im_nodes[i].trial;
}
