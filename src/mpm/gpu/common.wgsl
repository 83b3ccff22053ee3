// Shared functions of every MPM stage: the guard, the B-spline stencil, the constitutive
// models, tool SDFs and contact, and the grid boundary. Line for line the math of the CPU
// solver (src/mpm/{kernel,material,grid}.rs, src/tools/{sdf,contact}.rs). The constants,
// structs and bindings they use come before them, in the prelude generated from Rust
// (prelude.rs).

const NO_TOOL: u32 = 0xffffffffu;
const TAU: f32 = 6.28318530717958647692;

// True once the guard has tripped in this frame: the rest of the frame does nothing, and
// the host restores the state.
fn guard_tripped() -> bool {
    return atomicLoad(&stats[S_GUARD]) != 0u;
}

// True when the guard tripped in an earlier substep of this frame. The G2P of the substep
// that trips it runs to the end, so that the lowest offending particle is the one reported.
fn guard_before() -> bool {
    let g = atomicLoad(&stats[S_GUARD]);
    return g != 0u && g != st.substep + 1u;
}

// The prologue of the per-particle stages: whether invocation `p` has a particle to work
// on (it is one of them and the guard has not tripped).
fn particle_live(p: u32) -> bool {
    return p < sim.n_particles && !guard_tripped();
}

fn is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn is_finite3(v: vec3<f32>) -> bool {
    return is_finite(v.x) && is_finite(v.y) && is_finite(v.z);
}

fn is_finite_m(m: mat3x3<f32>) -> bool {
    return is_finite3(m[0]) && is_finite3(m[1]) && is_finite3(m[2]);
}

// ---- grid layout (BLOCK³-node blocks, as GridLayout) ----

fn block_index(b: vec3<u32>) -> u32 {
    return (b.x * sim.blocks.y + b.y) * sim.blocks.z + b.z;
}

fn node_coords(b: u32, local: u32) -> vec3<u32> {
    let bz = b % sim.blocks.z;
    let rest = b / sim.blocks.z;
    let bb = vec3<u32>(rest / sim.blocks.y, rest % sim.blocks.y, bz);
    return bb * BLOCK + vec3<u32>(local / (BLOCK * BLOCK), (local / BLOCK) % BLOCK, local % BLOCK);
}

// Storage offsets of the three stencil nodes along each axis: node (a, b, c) is at
// offs[a].x + offs[b].y + offs[c].z.
fn node_offsets(base: vec3<i32>) -> array<vec3<u32>, 3> {
    let stride = vec3<u32>(sim.blocks.y * sim.blocks.z * NODES_PER_BLOCK, sim.blocks.z * NODES_PER_BLOCK,
                           NODES_PER_BLOCK);
    let local = vec3<u32>(BLOCK * BLOCK, BLOCK, 1u);
    var out: array<vec3<u32>, 3>;
    for (var a = 0u; a < 3u; a++) {
        let n = vec3<u32>(base) + vec3<u32>(a);
        out[a] = (n / BLOCK) * stride + (n % BLOCK) * local;
    }
    return out;
}

// ---- quadratic B-spline stencil (kernel.rs) ----

struct Stencil {
    base: vec3<i32>,
    fx: vec3<f32>,
    w: array<vec3<f32>, 3>,
}

fn make_stencil(g: vec3<f32>) -> Stencil {
    let base_f = floor(g - vec3<f32>(0.5));
    let fx = g - base_f;
    let t0 = vec3<f32>(1.5) - fx;
    let t1 = fx - vec3<f32>(1.0);
    let t2 = fx - vec3<f32>(0.5);
    var s: Stencil;
    s.base = vec3<i32>(base_f);
    s.fx = fx;
    s.w[0] = 0.5 * t0 * t0;
    s.w[1] = vec3<f32>(0.75) - t1 * t1;
    s.w[2] = 0.5 * t2 * t2;
    return s;
}

// ---- cuts (crack.rs) ----

// Particle p's crack n·d (see crack.wgsl): zero when it is not cut, and always zero in a
// scene without a slicer (CUTTING false: the side tests below fold away).
fn particle_crack(p: u32) -> vec3<f32> {
    if (CUTTING) {
        return cracks[p].xyz;
    }
    return vec3<f32>(0.0);
}

fn is_cracked(crack: vec3<f32>) -> bool {
    return CUTTING && any(crack != vec3<f32>(0.0));
}

// The side test of one cut particle against its stencil (crack.rs `StencilCut`): n·r for
// node (a, b, c) is along[a].x + along[b].y + along[c].z, across when below limit = −|n·d|².
// `crossed` is false when no node is across (the least sum is at a stencil corner): the
// particle then takes the plain transfer.
struct StencilCut {
    along: array<vec3<f32>, 3>,
    limit: f32,
    crossed: bool,
}

fn stencil_cut(crack: vec3<f32>, s: Stencil) -> StencilCut {
    var cut: StencilCut;
    cut.crossed = false;
    if (!is_cracked(crack)) {
        return cut;
    }
    for (var i = 0u; i < 3u; i++) {
        cut.along[i] = crack * ((vec3<f32>(f32(i)) - s.fx) * sim.origin_dx.w);
    }
    let least = min(cut.along[0], cut.along[2]);
    cut.limit = -dot(crack, crack);
    cut.crossed = least.x + least.y + least.z < cut.limit;
    return cut;
}

fn cut_across(cut: StencilCut, a: u32, b: u32, c: u32) -> bool {
    return cut.crossed && cut.along[a].x + cut.along[b].y + cut.along[c].z < cut.limit;
}

// APIC scatter of one particle (the second half of cpu `particle_to_grid`): node i of the
// stencil receives w_i · (momentum + q·(i − base)) and w_i · m, with momentum = m·v − q·fx
// so that q·(i − base − fx) = q·(x_i − x_p)/dx. MLS-MPM's q carries the stress term,
// PB-MPM's only m·C·dx. A cut particle writes nothing to the nodes across its crack.
// acc_add_* come from the P2G accumulation variant.
fn scatter_apic(s: Stencil, m: f32, v: vec3<f32>, q: mat3x3<f32>, crack: vec3<f32>) {
    scatter_apic_about(s, m, v, q, stencil_cut(crack, s), s.fx);
}

// The weighted centre Σ_kept w_i·(a, b, c) / Σ_kept w_i of the stencil nodes on a cut
// particle's side, in stencil units (crack.rs `StencilCut::kept_centre`).
fn kept_centre(cut: StencilCut, s: Stencil) -> vec3<f32> {
    var weight = 0.0;
    var moment = vec3<f32>(0.0);
    for (var a = 0u; a < 3u; a++) {
        for (var b = 0u; b < 3u; b++) {
            let wab = s.w[a].x * s.w[b].y;
            for (var c = 0u; c < 3u; c++) {
                if (cut_across(cut, a, b, c)) {
                    continue;
                }
                let w = wab * s.w[c].z;
                weight += w;
                moment += vec3<f32>(f32(a), f32(b), f32(c)) * w;
            }
        }
    }
    if (weight > 0.0) {
        return moment / weight;
    }
    return s.fx;
}

// PB-MPM's scatter (q = m·C·dx, no stress): a cut particle takes its affine momentum about
// its kept nodes' weighted centre x̄ instead of x_p. APIC's m·C·(x_i − x_p) sums to zero
// only over the whole stencil, so skipping the nodes across the crack would write a net
// m·C·Σ_kept w_i(x_i − x_p), a push along the crack normal; PB-MPM's C ((R·F⁻¹ − I)/dt) is
// large enough for it to slide the cut's faces through each other (cpu
// `transfer_to_grid` has the derivation).
fn scatter_apic_about_kept(s: Stencil, m: f32, v: vec3<f32>, q: mat3x3<f32>, crack: vec3<f32>) {
    let cut = stencil_cut(crack, s);
    var centre = s.fx;
    if (cut.crossed) {
        centre = kept_centre(cut, s);
    }
    scatter_apic_about(s, m, v, q, cut, centre);
}

// The scatter with the affine momentum about `centre` (stencil units): node i receives
// w_i · (m·v + q·(i − centre)) and w_i · m, except the nodes across `cut`.
fn scatter_apic_about(s: Stencil, m: f32, v: vec3<f32>, q: mat3x3<f32>, cut: StencilCut, centre: vec3<f32>) {
    let momentum = v * m - q * centre;
    let offs = node_offsets(s.base);
    for (var a = 0u; a < 3u; a++) {
        for (var b = 0u; b < 3u; b++) {
            for (var c = 0u; c < 3u; c++) {
                if (cut_across(cut, a, b, c)) {
                    continue;
                }
                let abc = vec3<f32>(f32(a), f32(b), f32(c));
                let w = s.w[a].x * s.w[b].y * s.w[c].z;
                let contrib = (momentum + q * abc) * w;
                let i = NODE_WORDS * (offs[a].x + offs[b].y + offs[c].z);
                acc_add_p(i, contrib.x);
                acc_add_p(i + 1u, contrib.y);
                acc_add_p(i + 2u, contrib.z);
                acc_add_m(i + 3u, w * m);
            }
        }
    }
}

// Quadratic B-spline weight derivatives along each axis, in grid units (tlmpm.rs
// `weight_derivatives`).
fn weight_derivatives(fx: vec3<f32>) -> array<vec3<f32>, 3> {
    return array<vec3<f32>, 3>(fx - vec3<f32>(1.5), (fx - vec3<f32>(1.0)) * -2.0, fx - vec3<f32>(0.5));
}

// The gradient (grid units) of stencil node (a, b, c)'s weight.
fn weight_gradient(s: Stencil, dw: array<vec3<f32>, 3>, a: u32, b: u32, c: u32) -> vec3<f32> {
    return vec3<f32>(dw[a].x * s.w[b].y * s.w[c].z, s.w[a].x * dw[b].y * s.w[c].z,
                     s.w[a].x * s.w[b].y * dw[c].z);
}

// Node `node`'s words in the accumulators after every node's NODE_WORDS: total Lagrangian
// MPM's dt·force xyz (momentum), the mass-weighted offset of its particles from it xyz (in
// cells times PLACE_SCALE, added as mass) and the captured mass (tlmpm.wgsl).
fn tl_words(node: u32) -> u32 {
    return sim.nodes.w * NODES_PER_BLOCK * NODE_WORDS + TL_WORDS * node;
}

// The offsets' scale: in fixed point a node then resolves its place to 2^-26·4 of a cell's
// mass·dx (a node of 1/1000 of a cell's mass to 0.06 µm at dx = 1 mm; the momentum unit
// left the free block's bottom nodes 20 µm off and the walls caught them differently from
// the CPU), and holds particles up to 128 cells from it at a cell's mass.
const PLACE_SCALE: f32 = 0.25;

fn grid_pos(x: vec3<f32>) -> vec3<f32> {
    return (x - sim.origin_dx.xyz) * sim.inv_dx;
}

// Flags the (up to 8) blocks the 3×3×3 stencil of a particle at grid position g covers,
// for the next block list (sparse.wgsl's `compact`).
fn mark_stencil_blocks(g: vec3<f32>) {
    let s = make_stencil(g);
    let hi_node = vec3<i32>(sim.nodes.xyz) - vec3<i32>(3);
    let base = vec3<u32>(clamp(s.base, vec3<i32>(0), hi_node));
    let lo = base / BLOCK;
    let hi = (base + vec3<u32>(2u)) / BLOCK;
    for (var bx = lo.x; bx <= hi.x; bx++) {
        for (var by = lo.y; by <= hi.y; by++) {
            for (var bz = lo.z; bz <= hi.z; bz++) {
                atomicStore(&block_flags[block_index(vec3<u32>(bx, by, bz))], 1u);
            }
        }
    }
}

// Velocity and affine velocity C gathered from the grid at grid position g (the first half
// of cpu `grid_to_particle`); a cut particle reads its own velocity `own_v` at the nodes
// across its crack (CPIC's ghost velocity).
struct Gather {
    v: vec3<f32>,
    c: mat3x3<f32>,
}

fn gather(g: vec3<f32>, crack: vec3<f32>, own_v: vec3<f32>) -> Gather {
    let s = make_stencil(g);
    let offs = node_offsets(s.base);
    let cut = stencil_cut(crack, s);
    var v = vec3<f32>(0.0);
    var bm = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    for (var a = 0u; a < 3u; a++) {
        for (var b = 0u; b < 3u; b++) {
            for (var c = 0u; c < 3u; c++) {
                let w = s.w[a].x * s.w[b].y * s.w[c].z;
                let abc = vec3<f32>(f32(a), f32(b), f32(c));
                var node_v = grid_v[offs[a].x + offs[b].y + offs[c].z].xyz;
                if (cut_across(cut, a, b, c)) {
                    node_v = own_v;
                }
                let vi = node_v * w;
                let o = abc - s.fx;
                v += vi;
                bm += mat3x3<f32>(vi * o.x, vi * o.y, vi * o.z);
            }
        }
    }
    return Gather(v, bm * (4.0 * sim.inv_dx));
}

// ---- constitutive models (material.rs) ----

fn quat_mul(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    return vec4<f32>(a.w * b.xyz + b.w * a.xyz + cross(a.xyz, b.xyz), a.w * b.w - dot(a.xyz, b.xyz));
}

fn quat_to_mat(q: vec4<f32>) -> mat3x3<f32> {
    let x = q.x;
    let y = q.y;
    let z = q.z;
    let w = q.w;
    return mat3x3<f32>(
        vec3<f32>(1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + w * z), 2.0 * (x * z - w * y)),
        vec3<f32>(2.0 * (x * y - w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z + w * x)),
        vec3<f32>(2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y)),
    );
}

// Rotation closest to `a` (Müller et al. 2016) as a quaternion, as `rotation_of` in
// material.rs.
fn rotation_quat(a: mat3x3<f32>) -> vec4<f32> {
    var q = vec4<f32>(0.0, 0.0, 0.0, 1.0);
    for (var i = 0; i < ROTATION_ITERATIONS; i++) {
        let r = quat_to_mat(q);
        let num = cross(r[0], a[0]) + cross(r[1], a[1]) + cross(r[2], a[2]);
        let den = abs(dot(r[0], a[0]) + dot(r[1], a[1]) + dot(r[2], a[2])) + 1e-9;
        let omega = num / den;
        let angle = length(omega);
        if (angle < 1e-9) {
            break;
        }
        let axis = omega / angle;
        let h = 0.5 * angle;
        q = quat_mul(vec4<f32>(axis * sin(h), cos(h)), q);
        q = q / length(q);
    }
    return q;
}

// The same rotation as a matrix.
fn rotation_of(a: mat3x3<f32>) -> mat3x3<f32> {
    return quat_to_mat(rotation_quat(a));
}

fn kirchhoff_stress(mat: Material, f: mat3x3<f32>) -> mat3x3<f32> {
    let id = mat3x3<f32>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));
    if (mat.model == NEO_HOOKEAN) {
        let j = max(determinant(f), J_MIN);
        let tau = (f * transpose(f)) * mat.mu;
        return tau + id * (mat.lambda * log(j) - mat.mu);
    }
    let j = determinant(f);
    let r = rotation_of(f);
    let tau = ((f - r) * transpose(f)) * (2.0 * mat.mu);
    return tau + id * (mat.lambda * (j - 1.0) * j);
}

// F⁻ᵀ, from the cofactors (columns b×c, c×a, a×b of F = [a b c], over det F); the identity
// for a singular F, as nalgebra's `try_inverse` fallback in the CPU solver.
fn inverse_transpose(f: mat3x3<f32>) -> mat3x3<f32> {
    let det = determinant(f);
    if (det == 0.0) {
        return mat3x3<f32>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));
    }
    return mat3x3<f32>(cross(f[1], f[2]), cross(f[2], f[0]), cross(f[0], f[1])) * (1.0 / det);
}

// √(‖F⁻¹‖₁‖F⁻¹‖∞), a bound on 1/σ_min(F) (stiffening.rs `inverse_stretch_bound`).
fn inverse_stretch_bound(f: mat3x3<f32>) -> f32 {
    let inv = transpose(inverse_transpose(f));
    let a = abs(inv[0]);
    let b = abs(inv[1]);
    let c = abs(inv[2]);
    let columns = vec3<f32>(a.x + a.y + a.z, b.x + b.y + b.z, c.x + c.y + c.z);
    let rows = a + b + c;
    return sqrt(max(max(columns.x, columns.y), columns.z) * max(max(rows.x, rows.y), rows.z));
}

// ---- tool SDFs (sdf.rs), tool frame ----

struct Hit {
    distance: f32,
    normal: vec3<f32>,
    tangent: vec3<f32>,
    part: u32,
}

fn solid(distance: f32, normal: vec3<f32>, part: u32) -> Hit {
    return Hit(distance, normal, vec3<f32>(0.0), part);
}

fn unit_or(v: vec3<f32>, fallback: vec3<f32>) -> vec3<f32> {
    let n = length(v);
    if (n > 1e-12) {
        return v / n;
    }
    return fallback;
}

fn jaw_angle(part: u32, opening: f32) -> f32 {
    if (part == 1u) {
        return -0.5 * opening;
    }
    return 0.5 * opening;
}

fn rotate_x(p: vec3<f32>, angle: f32) -> vec3<f32> {
    let s = sin(angle);
    let c = cos(angle);
    return vec3<f32>(p.x, c * p.y - s * p.z, s * p.y + c * p.z);
}

fn sdf_sphere(p: vec3<f32>, radius: f32) -> Hit {
    return solid(length(p) - radius, unit_or(p, vec3<f32>(0.0, 0.0, 1.0)), 0u);
}

fn sdf_capsule(p: vec3<f32>, radius: f32, half_length: f32) -> Hit {
    let d = p - vec3<f32>(0.0, 0.0, clamp(p.z, -half_length, half_length));
    var fallback = vec3<f32>(0.0, 0.0, -1.0);
    if (p.z >= 0.0) {
        fallback = vec3<f32>(0.0, 0.0, 1.0);
    }
    return solid(length(d) - radius, unit_or(d, fallback), 0u);
}

fn sdf_box(p: vec3<f32>, half: vec3<f32>) -> Hit {
    let q = abs(p) - half;
    let sign = select(vec3<f32>(1.0), vec3<f32>(-1.0), p < vec3<f32>(0.0));
    let outside = max(q, vec3<f32>(0.0));
    if (dot(outside, outside) > 0.0) {
        let n = outside * sign;
        return solid(length(outside), n / length(n), 0u);
    }
    // Inside: the face with the largest q (the first one on ties, as nalgebra's imax).
    var axis = 0u;
    var best = q.x;
    if (q.y > best) {
        axis = 1u;
        best = q.y;
    }
    if (q.z > best) {
        axis = 2u;
        best = q.z;
    }
    var n = vec3<f32>(0.0);
    n[axis] = sign[axis];
    return solid(best, n, 0u);
}

fn sdf_gripper(p: vec3<f32>, opening: f32, len: f32, width: f32, thickness: f32) -> Hit {
    let half = vec3<f32>(0.5 * width, 0.5 * thickness, 0.5 * len);
    var best = solid(3.0e38, vec3<f32>(0.0, 0.0, 1.0), 1u);
    for (var part = 1u; part <= 2u; part++) {
        let angle = jaw_angle(part, opening);
        let in_jaw = rotate_x(p, -angle);
        var side = -1.0;
        if (part == 1u) {
            side = 1.0;
        }
        let centre = vec3<f32>(0.0, side * 0.5 * thickness, 0.5 * len);
        let hit = sdf_box(in_jaw - centre, half);
        if (hit.distance < best.distance) {
            best = solid(hit.distance, rotate_x(hit.normal, angle), part);
        }
    }
    return best;
}

fn on_arc(radius: f32, a: f32) -> vec3<f32> {
    return vec3<f32>(radius * cos(a), radius * sin(a), 0.0);
}

fn sdf_needle(p: vec3<f32>, radius: f32, arc_angle: f32, wire_radius: f32) -> Hit {
    var phi = atan2(p.y, p.x);
    if (phi < 0.0) {
        phi = phi + TAU;
    }
    var angle = phi;
    if (phi > arc_angle) {
        let end = on_arc(radius, arc_angle);
        let start = on_arc(radius, 0.0);
        let de = p - end;
        let ds = p - start;
        if (dot(de, de) < dot(ds, ds)) {
            angle = arc_angle;
        } else {
            angle = 0.0;
        }
    }
    let nearest = on_arc(radius, angle);
    let tangent = vec3<f32>(-sin(angle), cos(angle), 0.0);
    let d = p - nearest;
    let normal = unit_or(d, vec3<f32>(cos(angle), sin(angle), 0.0));
    return Hit(length(d) - wire_radius, normal, tangent, 0u);
}

// The slicer's blunt spine (slicer.rs `spine`): a cylinder of radius thickness/2 along the
// local x axis, capped by half spheres at x = ±length/2. Its blade has no contact.
fn sdf_slicer_spine(p: vec3<f32>, len: f32, thickness: f32) -> Hit {
    let d = p - vec3<f32>(clamp(p.x, -0.5 * len, 0.5 * len), 0.0, 0.0);
    return solid(length(d) - 0.5 * thickness, unit_or(d, vec3<f32>(0.0, 0.0, 1.0)), 0u);
}

// ---- a mesh slicer's blade (blade.rs: its record in `blades`; mesh_slicer.rs) ----

// The counts of the blade record at `blade`: triangles, cutting-edge segments, spine
// segments.
fn blade_counts(blade: u32) -> vec4<u32> {
    return bitcast<vec4<u32>>(blades[blade]);
}

// Index of the blade's first segment record: its cutting edge's, the spine's after them.
fn blade_segments(blade: u32) -> u32 {
    return blade + BLADE_HEADER + 4u * blade_counts(blade).x;
}

// Closest point to p on the segment [a, b] (mesh_slicer.rs `closest_on_segment`).
fn closest_on_segment(p: vec3<f32>, a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    let ab = b - a;
    let t = clamp(dot(p - a, ab) / dot(ab, ab), 0.0, 1.0);
    return a + ab * t;
}

// The mesh slicer's blunt spine (mesh_slicer.rs `spine_distance`): a capsule of radius
// thickness/2 along each spine segment; the nearest segment's point, the first on ties.
// Its surface and edge have no contact.
fn sdf_mesh_spine(p: vec3<f32>, blade: u32, thickness: f32) -> Hit {
    let counts = blade_counts(blade);
    let first = blade_segments(blade) + 2u * counts.y;
    var nearest = p;
    var least = 3.0e38;
    for (var s = 0u; s < counts.z; s++) {
        let q = closest_on_segment(p, blades[first + 2u * s].xyz, blades[first + 2u * s + 1u].xyz);
        let r = p - q;
        if (dot(r, r) < least) {
            least = dot(r, r);
            nearest = q;
        }
    }
    let d = p - nearest;
    return solid(length(d) - 0.5 * thickness, unit_or(d, vec3<f32>(0.0, 0.0, 1.0)), 0u);
}

fn tool_query(t: Tool, p: vec3<f32>) -> Hit {
    let s = t.shape;
    switch t.kind.x {
        case SPHERE_KIND: { return sdf_sphere(p, s.x); }
        case CAPSULE_KIND: { return sdf_capsule(p, s.x, s.y); }
        case BOX_KIND: { return sdf_box(p, s.xyz); }
        case GRIPPER_KIND: { return sdf_gripper(p, t.lin.w, s.x, s.y, s.z); }
        case NEEDLE_KIND: { return sdf_needle(p, s.x, s.y, s.z); }
        case SLICER_KIND: { return sdf_slicer_spine(p, s.x, s.z); }
        default: { return sdf_mesh_spine(p, t.kind.z, s.x); }
    }
}

fn in_aabb(t: Tool, x: vec3<f32>) -> bool {
    return all(x >= t.aabb_min.xyz) && all(x <= t.aabb_max.xyz);
}

// Contact query in world frame (ToolKinematics::probe, after the bounding-box test).
fn tool_probe(t: Tool, x: vec3<f32>) -> Hit {
    let local = transpose(t.rot) * (x - t.trans.xyz);
    let h = tool_query(t, local);
    return Hit(h.distance - t.trans.w, t.rot * h.normal, t.rot * h.tangent, h.part);
}

fn surface_velocity(t: Tool, x: vec3<f32>, part: u32) -> vec3<f32> {
    var omega = t.ang.xyz;
    if (part != 0u) {
        omega = omega + t.rot[0] * jaw_angle(part, t.ang.w);
    }
    return t.lin.xyz + cross(omega, x - t.trans.xyz);
}

// Coulomb contact (contact.rs `resolve`): `sticky` moves with the tool.
fn resolve(sticky: bool, friction: f32, drag: f32, v_node: vec3<f32>, v_tool: vec3<f32>,
           normal: vec3<f32>, tangent: vec3<f32>) -> vec3<f32> {
    if (sticky) {
        return v_tool;
    }
    let v_rel = v_node - v_tool;
    let v_n = dot(v_rel, normal);
    if (v_n >= 0.0) {
        return v_node;
    }
    let is_curve = dot(tangent, tangent) > 0.0;
    var v_t = v_rel - v_n * normal;
    if (is_curve) {
        v_t = tangent * dot(v_rel, tangent);
    }
    let v_t_norm = length(v_t);
    if (v_t_norm <= 1e-12) {
        return v_tool;
    }
    let approach = min(v_n, 0.0);
    let scale = max(1.0 + friction * approach / v_t_norm, 0.0) * (1.0 - drag);
    return v_tool + v_t * scale;
}

// Table plane and slip walls (cpu `apply_boundary`) at grid node ijk.
fn apply_boundary(ijk: vec3<u32>, x: vec3<f32>, v: vec3<f32>) -> vec3<f32> {
    return boundary_at(vec3<f32>(ijk), x.z, x, v);
}

// The table and the walls for a node at grid position g and place x whose bonding to a
// bonded table is decided at height bonded_z: its own place for the updated-Lagrangian
// solvers, its rest place for total Lagrangian MPM (tlmpm.rs `apply_boundary`).
fn boundary_at(g: vec3<f32>, bonded_z: f32, x: vec3<f32>, v_in: vec3<f32>) -> vec3<f32> {
    var v = v_in;
    let table = sim.blocks.w;
    let eps = 1e-3 * sim.origin_dx.w;
    if (table == TABLE_BONDED && bonded_z <= sim.table.x + eps) {
        v = vec3<f32>(0.0);
    }
    if (table == TABLE_RESTING && x.z <= sim.table.x + eps) {
        v = resolve(false, sim.table.y, 0.0, v, vec3<f32>(0.0), vec3<f32>(0.0, 0.0, 1.0), vec3<f32>(0.0));
    }
    let walls = f32(WALL_NODES);
    for (var a = 0u; a < 3u; a++) {
        if (g[a] < walls && v[a] < 0.0) {
            v[a] = 0.0;
        }
        if (g[a] > f32(sim.nodes[a] - 1u - WALL_NODES) && v[a] > 0.0) {
            v[a] = 0.0;
        }
    }
    return v;
}

// A node at x (velocity v, mass m) held by gripper `tool`, `lever` from its hinge on jaw
// `jaw`'s side (tools/grip.rs `held`, node_contact.rs `record_hold`): the held velocity,
// the momentum the tool takes and its moment, the share that turns the jaws, and the grip's
// sums.
struct Held {
    v: vec3<f32>,
    dp: vec3<f32>,
    dl: vec3<f32>,
    jaw_opening: f32,
    required: vec3<f32>,
    mass_lever: f32,
}

fn hold_at(tool: Tool, x: vec3<f32>, v: vec3<f32>, m: f32, lever: f32, jaw: u32) -> Held {
    let arm = x - tool.trans.xyz;
    let dv = tool.lin.xyz + cross(tool.ang.xyz, arm) - v;
    let normal = tool.rot[1];
    let along_normal = normal * dot(normal, dv);
    let required = dv - along_normal;
    let v_held = v + along_normal + required * max(tool.shape.w, 0.0);
    let dp = (v - v_held) * m;
    let opening = jaw_angle(jaw, 1.0) * dot(cross(arm, normal * dot(normal, dp)), tool.rot[0]);
    return Held(v_held, dp, cross(arm, dp), opening, required * m, m * lever);
}

// Gripper `t`'s grip region at `x` (ToolKinematics::grip_region in tools/grip.rs): x the
// distance from the hinge and y the jaw on whose side it is (1 or 2); x < 0 outside it.
// The region reaches `grip_reach` (tools/grip.rs) beyond the jaws, in the tool's kind.w.
fn grip_region(t: Tool, x: vec3<f32>) -> vec2<f32> {
    let outside = vec2<f32>(-1.0, 0.0);
    if (t.kind.x != GRIPPER_KIND || !in_aabb(t, x)) {
        return outside;
    }
    let reach = bitcast<f32>(t.kind.w);
    let p = transpose(t.rot) * (x - t.trans.xyz);
    let len = t.shape.x + reach;
    let thickness = t.shape.z + reach;
    if (abs(p.x) > 0.5 * t.shape.y + reach) {
        return outside;
    }
    let in1 = rotate_x(p, -jaw_angle(1u, t.lin.w));
    let in2 = rotate_x(p, -jaw_angle(2u, t.lin.w));
    let along = in1.z >= 0.0 && in1.z <= len && in2.z >= 0.0 && in2.z <= len;
    if (in1.y <= thickness && in2.y >= -thickness && along) {
        return vec2<f32>(sqrt(p.y * p.y + p.z * p.z), select(2.0, 1.0, p.y >= 0.0));
    }
    return outside;
}

// Word `word` of every tool's impulse: this substep's per-block contact sums (grid_update.wgsl)
// added to the frame's; nothing once the guard tripped.
fn reduce_impulse_word(word: u32) {
    if (guard_tripped()) {
        return;
    }
    let n = atomicLoad(&stats[S_CONTACT_BLOCKS]);
    var sum = 0.0;
    for (var i = 0u; i < n; i++) {
        sum += partials[i * MAX_TOOLS * IMPULSE_WORDS + word];
    }
    let w = S_IMPULSE + word;
    atomicStore(&stats[w], bitcast<u32>(bitcast<f32>(atomicLoad(&stats[w])) + sum));
}
