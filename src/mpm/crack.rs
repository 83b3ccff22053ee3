//! Cuts that stay cut: each particle the blade has passed keeps the blade's plane as its
//! crack, and from then on exchanges nothing with grid nodes on the far side of it.
//!
//! This is CPIC's compatibility test (Hu et al. 2018; seed 002 §IV-B) with the side bits
//! held by the particle instead of a coloured distance field on the grid: a particle and a
//! node are incompatible when the crack plane lies between them. In P2G the particle does
//! not write an incompatible node (the crack face is traction free and carries no
//! momentum), in G2P it reads its own velocity there (CPIC's ghost velocity), so momentum
//! never crosses the cut, during the cut or after the blade has left.
//!
//! The crack is one vector per particle, `n·d`: `n` the unit normal of the plane pointing
//! from the plane towards the particle, `d` > 0 the particle's distance from it (m). A node
//! at offset `r = xᵢ − xₚ` is across the plane when `n·r < −d`, i.e. `crack·r < −|crack|²`;
//! the zero vector is "not cut". The plane turns and stretches with the material (its normal
//! is a covector: ṅ = −Cᵀn), so that a cut spread open or carried away stays a cut.
//!
//! # The blade
//!
//! A slicer ([`crate::tools::slicer`], seed 002's quad slicer; or a blade from a mesh file,
//! [`crate::tools::mesh_slicer`]) has two sides:
//! - **The edge separates and has no contact.** Each substep, every particle within a
//!   stencil's reach (1.5·√3 cells) of the blade plane and in the strip just above the edge
//!   takes the blade plane as its crack. Only the edge cuts: moving the blade sideways through
//!   tissue it has already cut makes no new crack.
//! - **The spine is a blunt tool**: a cylinder of the blade's thickness, fattened to 1.5 cells
//!   as a wire is (seed 002 Fig. 6–7), with the tool's `contact` model (the shipped scene's is
//!   frictionless Coulomb, so that the spine lets go when it lifts out).
//!
//! # What it costs
//!
//! - **Nothing when off.** The crack state is allocated when an edge first reaches a particle;
//!   until then, and in every scene without a slicer, P2G and G2P take the plain code path (a
//!   const-generic switch), and the only cost is one scan of the tool list per substep.
//! - **Only where an edge can reach.** After binning, each slicer's cutting box (the tool-frame
//!   box outside which its edge test answers nothing: the strip along the edge grown by the
//!   band, or a mesh blade's bounding box grown by it) is tested against every occupied 4³-node
//!   block's box of particles, along the world's and the tool's axes ([`Reaches::meet_box`]);
//!   only the particles of blocks it meets take the edge test. The box is padded by 1e-2 cells
//!   against rounding; a unit test checks on 200 random blade poses and 40,000 blocks that no
//!   block holding a particle the edge passes is skipped. The GPU's marking pass is one
//!   invocation per particle, where such a test would cost what it spares.
//! - **Only where the plane crosses the stencil.** A cut particle's side test is set up once
//!   per transfer ([`StencilCut`]): n·r splits into one term per axis, and the least sum over
//!   the 27 nodes is at a stencil corner, so when even that corner is on the particle's side
//!   the particle takes the plain transfer; only particles whose stencil the plane crosses test
//!   their nodes, three adds each.
//!
//! Measured with `dvrk-tissue-sim bench skip --only cutting --frames 10` and `--only parked
//! --frames 10` on a quiet 2-core machine (CPU; the shipped scene at dx = 1 mm, 38,400
//! particles, mid-cut, against a blunt capsule on the same path): the blade cutting costs
//! 1.036–1.051× the blunt tool (target ≤ 1.1), a slicer parked out of reach 1.036–1.083× no
//! tools, about what a parked gripper costs (1.019–1.039×).
//!
//! # Pieces, outputs, checks
//!
//! - **Pieces**: the headless summary prints `summary: pieces N`, the connected components of
//!   particles linked to neighbours nearer than one cell and not across a crack
//!   ([`crate::mpm::pieces`]); the node publishes it on `tissue/pieces`.
//! - **Outputs**: a scene with a slicer gets the isosurface instead of the constant-topology
//!   mesh (logged); `snapshot` draws the blade and the particles on the cut's faces in red.
//! - **Checks**: `check` refuses a blade shorter or lower than 2·dx (it would cover no
//!   particle's stencil) and a thickness outside 0 < thickness ≤ height/2.
//! - **GPU**: the same math in WGSL (`gpu/crack.wgsl`, `common.wgsl`): a per-particle marking
//!   pass before each substep's P2G, the side test in both P2G variants, in G2P and in
//!   PB-MPM's inner transfers, the crack advected in G2P. Only a scene with a slicer allocates
//!   the crack buffers (16 B a particle, and their frame-start copy) and reads them back.
//!
//! # PB-MPM's cut
//!
//! PB-MPM's affine velocity C is large (the constraint's (R·F⁻¹ − I)/dt at a substep of
//! 1/240 s), and APIC's affine momentum m·C·(xᵢ − xₚ) sums to zero only over the whole
//! stencil: a P2G that skips the nodes across the crack would write a net
//! m·C·Σ_kept wᵢ(xᵢ − xₚ), a push along the crack normal that slides the faces through each
//! other. PB-MPM's momentum-only P2G therefore takes a cut particle's affine part about its
//! kept nodes' weighted centre, m·v + m·C·(xᵢ − x̄) with x̄ = Σ_kept wᵢxᵢ / Σ_kept wᵢ, which
//! sums to zero over the nodes written ([`StencilCut::kept_centre`]; on the GPU
//! `scatter_apic_about_kept`). MLS-MPM keeps xₚ as the centre: its matrix also carries the
//! stress force, and its C is small. Still open: with PB-MPM the shipped block is two pieces
//! at the cut-through but joins again while the spine spreads the cut (top-face particles
//! dragged down turn their cracks with the material; the ignored test
//! `a_pb_mpm_cut_block_stays_two_through_the_spread` names the link).
//!
//! A node exactly on a crack plane takes its full share when `n·r ≥ −d`; on a blade that
//! runs along a node plane the sign of a particle's drift since the cut decides whether such
//! nodes couple the faces, so CPU and GPU may differ there by rounding.
//! `tests/cutting_gpu.rs` holds the MLS-MPM variants 0.25 mm off the node plane
//! (`BLADE_OFF_NODE_PLANE`), where the backends agree within 1.1–6.8e-6 rad for 99 % of the
//! normals; a tie rule that serves both cutting and the trouser tear's slit is open.
//!
//! # Verification
//!
//! `cargo test --release --test cutting -- --nocapture` (the shipped scene's keyframes,
//! dx = 2 mm): after the cut exactly two pieces, each exactly the particles that started on
//! one side of the blade plane, faces one particle spacing apart; after the spread the top
//! faces 2.9 mm apart; two pieces every 0.1 s for the second after the blade left; a blunt
//! capsule on the same path leaves one piece; a flat mesh blade marks exactly the particles
//! the quad marks (22,200 cracks equal to the last bit). `cargo test --release --test
//! cutting_gpu -- --nocapture` (llvmpipe, the block shrunk to 1,152 particles): the same 960
//! particles cut on both backends, the same two pieces, positions within 1e-5 m.

use super::kernel::Stencil;
use super::{Mat3, Vec3};
use crate::tools::{slicer, Shape, ToolKinematics};
use rayon::prelude::*;

/// Least particle–plane distance kept, in cells: a particle exactly on the blade plane still
/// gets a crack that tells its sides apart.
pub const MIN_OFFSET_CELLS: f32 = 1e-3;

/// Whether a node at offset `r` (m) from a particle lies across the particle's crack.
#[inline(always)]
pub fn separates(crack: Vec3, r: Vec3) -> bool {
    crack.dot(&r) < -crack.norm_squared()
}

/// The side test of one cut particle against its 3×3×3 stencil, set up once per particle
/// and transfer. `n·r` for node (a, b, c) at `r = (abc − fx)·dx` is a sum of one term per
/// axis, so the terms are computed once per axis and node, and the node is across when
/// their sum is below `−|crack|²` (exactly [`separates`]). The sum is least at a corner of
/// the stencil, so when even the least one is not across, no node is: most particles near
/// the blade have the plane only beyond their stencil, and take the plain transfer.
#[derive(Clone, Copy, Debug)]
pub struct StencilCut {
    /// `crack[axis]·(i − fx[axis])·dx` for stencil index i along each axis (m²).
    along: [[f32; 3]; 3],
    /// `−|crack|²` (m²).
    limit: f32,
}

impl StencilCut {
    /// The test for a particle with crack `crack` whose stencil base is `fx` cells behind
    /// it; `None` when it is not cut or its crack lies beyond every node of its stencil.
    #[inline(always)]
    pub fn new(crack: Vec3, fx: Vec3, dx: f32) -> Option<Self> {
        if crack == Vec3::zeros() {
            return None;
        }
        let mut along = [[0.0f32; 3]; 3];
        let mut least = 0.0f32;
        for (axis, row) in along.iter_mut().enumerate() {
            for (i, term) in row.iter_mut().enumerate() {
                *term = crack[axis] * ((i as f32 - fx[axis]) * dx);
            }
            least += row[0].min(row[2]);
        }
        let limit = -crack.norm_squared();
        (least < limit).then_some(StencilCut { along, limit })
    }

    /// Whether stencil node (a, b, c) lies across the crack.
    #[inline(always)]
    pub fn across(&self, a: usize, b: usize, c: usize) -> bool {
        self.along[0][a] + self.along[1][b] + self.along[2][c] < self.limit
    }

    /// The weighted centre of the stencil nodes on the particle's side, in stencil units:
    /// Σ_kept wᵢ·(a, b, c) / Σ_kept wᵢ (for the whole stencil it would be `s.fx`). PB-MPM's
    /// P2G takes a cut particle's affine momentum about it (`CpuSolver::transfer_to_grid`).
    /// Some node on the particle's side always has weight (the stencil spans the particle
    /// on every axis); `s.fx` is returned were none to.
    #[inline(always)]
    pub fn kept_centre(&self, s: &Stencil) -> Vec3 {
        let mut weight = 0.0f32;
        let mut moment = Vec3::zeros();
        for a in 0..3 {
            for b in 0..3 {
                let wab = s.w[a].x * s.w[b].y;
                for c in 0..3 {
                    if self.across(a, b, c) {
                        continue;
                    }
                    let w = wab * s.w[c].z;
                    weight += w;
                    moment += Vec3::new(a as f32, b as f32, c as f32) * w;
                }
            }
        }
        if weight > 0.0 {
            moment / weight
        } else {
            s.fx
        }
    }
}

/// Whether any of the tools cuts (needs the per-particle crack state).
pub fn any_slicer(tools: &[ToolKinematics]) -> bool {
    tools.iter().any(|t| t.shape.cuts())
}

/// Padding (cells) of a slicer's cutting box in [`Reaches::meet_box`]: the box is tested in
/// the world frame there and in the tool's frame by the edge test, and the two frames'
/// rounding differ by far less than this.
pub const REACH_PAD_CELLS: f32 = 1e-2;

/// Where one slicer's edge can give a crack this substep: the tool-frame box outside which
/// its edge test answers nothing (the blade's cutting strip, or a mesh blade's bounding box,
/// grown by the band), padded by [`REACH_PAD_CELLS`].
struct Reach<'a> {
    tool: &'a ToolKinematics,
    /// The box's half extents in the tool frame (m).
    half: Vec3,
    /// Its centre in the world, and the half extents of its world-axis bounding box (m).
    world_centre: Vec3,
    world_half: Vec3,
}

impl Reach<'_> {
    /// Whether the world box with centre `c` and half extents `e` may meet this reach: it
    /// does not when the two boxes are apart along a world axis or along one of the tool's
    /// axes (separating axes; the edge–edge axes are left out, so a few boxes that miss
    /// are kept, never one that meets).
    fn meets(&self, c: Vec3, e: Vec3) -> bool {
        let apart_world = ((c - self.world_centre).abs() - e - self.world_half).max() > 0.0;
        if apart_world {
            return false;
        }
        let r = &self.tool.rotation;
        let along = r.tr_mul(&(c - self.world_centre));
        let reach = r.abs().tr_mul(&e);
        (along.abs() - reach - self.half).max() <= 0.0
    }
}

/// The cutting tools' reaches this substep, in the order of `tools` (the first whose edge
/// passes a particle gives its crack). Tested against the box of a block of particles,
/// they spare the block's particles the edge test when no slicer's edge can reach it.
pub struct Reaches<'a> {
    reaches: Vec<Reach<'a>>,
    band: f32,
    floor: f32,
}

impl<'a> Reaches<'a> {
    /// The reaches of the slicers among `tools` on a grid of spacing `dx` (m).
    pub fn new(tools: &'a [ToolKinematics], dx: f32) -> Self {
        let band = slicer::STENCIL_REACH_CELLS * dx;
        let pad = REACH_PAD_CELLS * dx;
        let reaches = tools
            .iter()
            .filter_map(|tool| {
                let (lo, hi) = match tool.shape {
                    Shape::Slicer { length, height, .. } => {
                        slicer::cutting_box(length, height, band)
                    }
                    Shape::MeshSlicer { file, .. } => file.mesh().cutting_box(band),
                    _ => return None,
                };
                let centre = 0.5 * (lo + hi);
                let half = (0.5 * (hi - lo)).add_scalar(pad);
                Some(Reach {
                    tool,
                    half,
                    world_centre: tool.translation + tool.rotation * centre,
                    world_half: tool.rotation.abs() * half,
                })
            })
            .collect();
        Reaches {
            reaches,
            band,
            floor: MIN_OFFSET_CELLS * dx,
        }
    }

    /// Whether some slicer's edge may give a crack to a particle in the world box
    /// `lo`–`hi` (m) this substep.
    pub fn meet_box(&self, lo: Vec3, hi: Vec3) -> bool {
        let (c, e) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        self.reaches.iter().any(|r| r.meets(c, e))
    }

    /// The crack a slicer's edge gives the particle at `x` this substep (see
    /// [`slicer::edge_passing`] and [`crate::tools::mesh_slicer::BladeMesh::edge_passing`]):
    /// the blade's local plane, for a particle nearer it than a stencil's reach, in a strip
    /// along the edge.
    #[inline(always)]
    pub fn passing(&self, x: Vec3) -> Option<Vec3> {
        let (band, floor) = (self.band, self.floor);
        self.reaches.iter().find_map(|&Reach { tool, .. }| {
            let local = tool.rotation.tr_mul(&(x - tool.translation));
            match tool.shape {
                Shape::Slicer { length, height, .. } => {
                    slicer::edge_passing(local, length, height, band).map(|side| {
                        let sign = if side < 0.0 { -1.0 } else { 1.0 };
                        let normal = tool.rotation.column(1).into_owned() * sign;
                        normal * side.abs().max(floor)
                    })
                }
                Shape::MeshSlicer { file, .. } => file
                    .mesh()
                    .edge_passing(local, band)
                    .map(|(normal, distance)| tool.rotation * normal * distance.max(floor)),
                _ => None,
            }
        })
    }
}

/// Gives each uncut particle that a slicer's edge passes this substep the blade's plane as
/// its crack (see [`Reaches::passing`]), testing every particle. The solver tests only the
/// particles of grid blocks a reach meets (`CpuSolver::mark_cuts`).
pub fn mark(tools: &[ToolKinematics], x: &[Vec3], crack: &mut [Vec3], dx: f32) {
    let reaches = Reaches::new(tools, dx);
    crack
        .par_iter_mut()
        .zip(x.par_iter())
        .with_min_len(1024)
        .for_each(|(crack, x)| {
            if *crack == Vec3::zeros() {
                if let Some(new) = reaches.passing(*x) {
                    *crack = new;
                }
            }
        });
}

/// The crack carried through one substep of the velocity gradient `c` (1/s): the normal
/// turns as a covector, n ← (I − dt·Cᵀ)·n, renormalised; the distance to the plane is kept.
#[inline(always)]
pub fn advect(crack: Vec3, c: &Mat3, dt: f32) -> Vec3 {
    let d = crack.norm();
    if d == 0.0 {
        return crack;
    }
    let turned = crack - c.tr_mul(&crack) * dt;
    let len = turned.norm();
    if len > 0.0 && len.is_finite() {
        turned * (d / len)
    } else {
        crack
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tools::{ContactModel, ToolPose, ToolVelocity};
    use nalgebra::{UnitQuaternion, Vector3};

    fn blade(yaw_deg: f64) -> ToolKinematics {
        let pose = ToolPose {
            position: Vector3::new(0.0, 0.0, 0.02),
            rotation: UnitQuaternion::from_euler_angles(0.0, 0.0, yaw_deg.to_radians()),
            jaw: 0.0,
        };
        let shape = Shape::Slicer {
            length: 0.03,
            height: 0.02,
            thickness: 0.0004,
        };
        ToolKinematics::new(
            shape,
            ContactModel::Sticky,
            &pose,
            &ToolVelocity::default(),
            0.002,
        )
    }

    #[test]
    fn the_blade_plane_separates_nodes_on_its_far_side() {
        let tools = [blade(90.0)];
        // Yawed 90°: the blade's plane is world x = 0, its normal world ∓x.
        let x = [
            Vec3::new(-0.001, 0.0, 0.002),
            Vec3::new(0.0025, 0.0, 0.002),
            Vec3::new(0.01, 0.0, 0.002),
            Vec3::new(0.0, 0.0, -0.002),
        ];
        let mut crack = [Vec3::zeros(); 4];
        mark(&tools, &x, &mut crack, 0.002);
        assert!(
            (crack[0] - Vec3::new(-0.001, 0.0, 0.0)).norm() < 1e-6,
            "{crack:?}"
        );
        assert!((crack[1] - Vec3::new(0.0025, 0.0, 0.0)).norm() < 1e-6);
        // Beyond a stencil's reach of the plane, and below the edge: uncut.
        assert_eq!(crack[2], Vec3::zeros());
        assert_eq!(crack[3], Vec3::zeros());
        // A node just across the plane is cut off, one on the particle's side is not.
        assert!(separates(crack[0], Vec3::new(0.0015, 0.0, 0.0)));
        assert!(!separates(crack[0], Vec3::new(0.0005, 0.002, 0.0)));
        assert!(!separates(crack[0], Vec3::new(-0.002, 0.0, 0.0)));
        assert!(!separates(Vec3::zeros(), Vec3::new(1.0, 0.0, 0.0)));
    }

    #[test]
    fn the_stencil_test_agrees_with_the_node_test_and_skips_uncrossed_stencils() {
        let dx = 0.002;
        // A fixed pseudo-random sweep of crack planes and particle positions in the cell.
        let mut state = 12345u32;
        let mut uniform = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32
        };
        let (mut fast, mut slow) = (0, 0);
        for _ in 0..2000 {
            let normal = Vec3::new(uniform() - 0.5, uniform() - 0.5, uniform() - 0.5).normalize();
            let crack = normal * (uniform() * slicer::STENCIL_REACH_CELLS * dx);
            let fx = Vec3::new(uniform(), uniform(), uniform()).add_scalar(0.5);
            let mut any = false;
            let cut = StencilCut::new(crack, fx, dx);
            for (a, b, c) in (0..27).map(|k| (k / 9, (k / 3) % 3, k % 3)) {
                let r = (Vec3::new(a as f32, b as f32, c as f32) - fx) * dx;
                let node = separates(crack, r);
                any |= node;
                if let Some(cut) = cut {
                    assert_eq!(cut.across(a, b, c), node, "{crack:?} {fx:?} {a}{b}{c}");
                }
            }
            assert_eq!(cut.is_some(), any, "{crack:?} {fx:?}");
            if any {
                slow += 1;
            } else {
                fast += 1;
            }
        }
        // Both paths are exercised: within the marking band, many planes miss the stencil.
        assert!(fast > 200 && slow > 200, "fast {fast}, slow {slow}");
        assert!(StencilCut::new(Vec3::zeros(), Vec3::repeat(1.0), dx).is_none());
    }

    #[test]
    fn the_affine_momentum_about_the_kept_centre_sums_to_zero_over_the_kept_nodes() {
        let dx = 0.002;
        let mut state = 777u32;
        let mut uniform = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32
        };
        let mut cut_stencils = 0;
        for _ in 0..2000 {
            let normal = Vec3::new(uniform() - 0.5, uniform() - 0.5, uniform() - 0.5).normalize();
            let crack = normal * (uniform() * slicer::STENCIL_REACH_CELLS * dx);
            let s = Stencil::new(Vec3::new(uniform(), uniform(), uniform()).add_scalar(3.0));
            let Some(cut) = StencilCut::new(crack, s.fx, dx) else {
                continue;
            };
            cut_stencils += 1;
            let centre = cut.kept_centre(&s);
            // Σ_kept wᵢ(i − centre) = 0 (that is what the centre is for), while about the
            // particle the kept nodes' moment points along the normal, away from the cut.
            let (mut about_centre, mut about_particle, mut kept) =
                (Vec3::zeros(), Vec3::zeros(), 0.0);
            for (a, b, c) in (0..27).map(|k| (k / 9, (k / 3) % 3, k % 3)) {
                let i = Vec3::new(a as f32, b as f32, c as f32);
                if separates(crack, (i - s.fx) * dx) {
                    continue;
                }
                let w = s.w[a].x * s.w[b].y * s.w[c].z;
                kept += w;
                about_centre += (i - centre) * w;
                about_particle += (i - s.fx) * w;
            }
            assert!(kept > 0.0);
            assert!(
                about_centre.norm() < 1e-5,
                "{about_centre:?} {crack:?} {:?}",
                s.fx
            );
            assert!(
                about_particle.dot(&normal) > 0.0,
                "{about_particle:?} {crack:?}"
            );
        }
        assert!(cut_stencils > 200, "{cut_stencils} cut stencils");
    }

    #[test]
    fn a_block_no_edge_reaches_is_skipped_and_none_an_edge_reaches_is() {
        let dx = 0.002;
        let mut state = 4242u32;
        let mut uniform = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32
        };
        let (mut passed, mut skipped) = (0, 0);
        for _ in 0..200 {
            let mut tool = blade(360.0 * uniform() as f64);
            let axis = Vec3::new(uniform() - 0.5, uniform() - 0.5, uniform() - 0.5).normalize();
            tool.rotation = nalgebra::Rotation3::from_axis_angle(
                &nalgebra::Unit::new_normalize(axis),
                6.0 * uniform(),
            )
            .into_inner();
            let tools = [tool];
            let reaches = Reaches::new(&tools, dx);
            for _ in 0..200 {
                // A block of the grid's size (five cells with its margin) somewhere within
                // 30 mm of the blade, and a particle in it.
                let lo = tools[0].translation
                    + Vec3::new(uniform() - 0.5, uniform() - 0.5, uniform() - 0.5) * 0.06;
                let hi = lo + Vec3::repeat(5.0 * dx);
                let x = lo + Vec3::new(uniform(), uniform(), uniform()) * 5.0 * dx;
                let met = reaches.meet_box(lo, hi);
                if reaches.passing(x).is_some() {
                    passed += 1;
                    assert!(met, "{lo:?} {x:?}");
                }
                skipped += usize::from(!met);
            }
        }
        // Both answers are exercised, and most blocks this far out are skipped.
        assert!(
            passed > 50 && skipped > 20_000,
            "{passed} passed, {skipped} skipped"
        );
    }

    #[test]
    fn a_crack_turns_with_the_material() {
        // Rigid rotation about z at ω = 1 rad/s: C = [[0, −1, 0], [1, 0, 0], [0, 0, 0]].
        let c = Mat3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        let mut crack = Vec3::new(0.001, 0.0, 0.0);
        for _ in 0..1000 {
            crack = advect(crack, &c, 1e-3);
        }
        // After 1 rad the normal points at (cos 1, sin 1, 0), the distance unchanged.
        let expected = Vec3::new(1f32.cos(), 1f32.sin(), 0.0) * 0.001;
        assert!((crack - expected).norm() < 2e-6, "{crack:?}");
    }
}
