// Crack marking (cpu `crack::mark`): each uncut particle that a slicer's edge passes this
// substep takes the blade's plane as its crack, n·d: n the plane's unit normal pointing
// towards the particle, d its distance from the plane (at least MIN_OFFSET_CELLS cells, so
// that a particle on the plane still tells its sides apart). Dispatched only in a scene
// with a slicer.

// Where on a triangle a closest point lies (parry's `TrianglePointLocation`): vertex
// a, b, c (0–2), edge AB, BC, AC (3–5, parry's edge numbering plus 3), the face (6).
const ON_EDGE: u32 = 3u;
const ON_FACE: u32 = 6u;

struct TriangleProjection {
    point: vec3<f32>,
    feature: u32,
}

// Closest point to p on triangle abc and its feature: parry's
// `Triangle::project_local_point_and_get_location` (Ericson's Voronoi regions, with parry's
// edge tests), the same operations in the same order, so that both backends classify a
// point alike. Its fallback for a triangle of zero area is left out: `check` refuses
// degenerate faces.
fn project_on_triangle(p: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> TriangleProjection {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let ab_ap = dot(ab, ap);
    let ac_ap = dot(ac, ap);
    if (ab_ap <= 0.0 && ac_ap <= 0.0) {
        return TriangleProjection(a, 0u);
    }
    let bp = p - b;
    let ab_bp = dot(ab, bp);
    let ac_bp = dot(ac, bp);
    if (ab_bp >= 0.0 && ac_bp <= ab_bp) {
        return TriangleProjection(b, 1u);
    }
    let cp = p - c;
    let ab_cp = dot(ab, cp);
    let ac_cp = dot(ac, cp);
    if (ac_cp >= 0.0 && ab_cp <= ac_cp) {
        return TriangleProjection(c, 2u);
    }
    let n = cross(ab, ac);
    let vc = dot(n, cross(ab, ap));
    if (vc < 0.0 && ab_ap >= 0.0 && ab_bp <= 0.0) {
        return TriangleProjection(a + ab * (ab_ap / dot(ab, ab)), ON_EDGE);
    }
    let vb = -dot(n, cross(ac, cp));
    if (vb < 0.0 && ac_ap >= 0.0 && ac_cp <= 0.0) {
        return TriangleProjection(a + ac * (ac_ap / dot(ac, ac)), ON_EDGE + 2u);
    }
    let bc = c - b;
    let va = dot(n, cross(bc, bp));
    if (va < 0.0 && ac_bp - ab_bp >= 0.0 && ab_cp - ac_cp >= 0.0) {
        return TriangleProjection(b + bc * (dot(bc, bp) / dot(bc, bc)), ON_EDGE + 1u);
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    return TriangleProjection(a + ab * v + ac * w, ON_FACE);
}

// The crack plane a mesh slicer's edge gives the tool-frame point p (mesh_slicer.rs
// `BladeMesh::edge_passing`): xyz the unit normal from the blade towards p, w p's distance
// from it; w < 0 when the edge does not pass p. p's closest point q on the surface (over
// every triangle, the first on ties) must lie on a face or an interior edge or vertex, p
// nearer the surface than `band`, and q within `band` of a cutting-edge segment. On a face
// the plane is the face's; on an interior edge or vertex, the plane through q normal to
// p − q (an interior edge's two faces give the same q, so either gives the same plane).
fn mesh_edge_passing(blade: u32, p: vec3<f32>, band: f32) -> vec4<f32> {
    let none = vec4<f32>(0.0, 0.0, 0.0, -1.0);
    if (any(p < blades[blade + 1u].xyz - band) || any(p > blades[blade + 2u].xyz + band)) {
        return none;
    }
    let counts = blade_counts(blade);
    let first = blade + BLADE_HEADER;
    var nearest = TriangleProjection(p, ON_FACE);
    var nearest_triangle = 0u;
    var least = 3.0e38;
    for (var t = 0u; t < counts.x; t++) {
        let at = first + 4u * t;
        let projection = project_on_triangle(p, blades[at].xyz, blades[at + 1u].xyz, blades[at + 2u].xyz);
        let cost = length(projection.point - p);
        if (cost < least) {
            least = cost;
            nearest = projection;
            nearest_triangle = at;
        }
    }
    // The CPU's query is bounded by the band: nothing nearer, no answer.
    if (least > band) {
        return none;
    }
    // On the outline (a boundary vertex or edge): p is beyond the blade, not reached yet.
    let flags = bitcast<u32>(blades[nearest_triangle].w);
    if (nearest.feature < ON_EDGE) {
        if ((flags & (1u << (BLADE_CORNER_FLAG_SHIFT + nearest.feature))) != 0u) {
            return none;
        }
    } else if (nearest.feature < ON_FACE) {
        if ((flags & (1u << (nearest.feature - ON_EDGE))) != 0u) {
            return none;
        }
    }
    let face_normal = blades[nearest_triangle + 3u].xyz;
    var normal: vec3<f32>;
    var distance: f32;
    var q: vec3<f32>;
    if (nearest.feature == ON_FACE) {
        // The face's own plane, as the CPU takes it (a flat blade cuts as the quad does).
        let side = dot(face_normal, p - blades[nearest_triangle].xyz);
        normal = select(face_normal, -face_normal, side < 0.0);
        distance = abs(side);
        q = p - face_normal * side;
    } else {
        q = nearest.point;
        distance = length(p - q);
        normal = select(face_normal, (p - q) / distance, distance > 1e-12);
    }
    if (distance >= band) {
        return none;
    }
    let edges = blade_segments(blade);
    for (var s = 0u; s < counts.y; s++) {
        let on_edge = closest_on_segment(q, blades[edges + 2u * s].xyz, blades[edges + 2u * s + 1u].xyz);
        if (length(q - on_edge) <= band) {
            return vec4<f32>(normal, distance);
        }
    }
    return none;
}

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
        if (tool.kind.x == MESH_SLICER_KIND) {
            let local = transpose(tool.rot) * (x - tool.trans.xyz);
            let plane = mesh_edge_passing(tool.kind.z, local, band);
            if (plane.w >= 0.0) {
                let d = max(plane.w, MIN_OFFSET_CELLS * dx);
                cracks[p] = vec4<f32>(tool.rot * plane.xyz * d, 0.0);
                return;
            }
            continue;
        }
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
