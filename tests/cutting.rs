//! Cutting, headless, on the shipped scene's own keyframes (`config/cutting.toml`): the
//! scalpel cuts the block through, spreads the cut with its spine and leaves. The block must
//! end in two pieces, the y < 0 and y > 0 halves exactly, and stay two for a second after
//! the blade has gone; the cut must be at most one cell wide. A blunt tool on the same path
//! (a capsule where the blade's spine is) must leave the block one piece.

use dvrk_tissue_sim::config::Scene;
use dvrk_tissue_sim::mpm::backend::BackendChoice;
use dvrk_tissue_sim::mpm::pieces;
use dvrk_tissue_sim::tools::Shape;
use dvrk_tissue_sim::world::World;

mod support;

use support::scenes::shipped_on_cpu as shipped;

/// Keyframe times of the cutting scene: cut through, spread, blade out, end.
struct CutTimes {
    through: f64,
    spread: f64,
    out: f64,
    end: f64,
}

fn cut_times(scene: &Scene) -> CutTimes {
    let k = &scene.tools[0].keyframes;
    assert_eq!(k.len(), 6, "the cutting scene's six keyframes");
    CutTimes {
        through: k[1].t,
        spread: k[3].t,
        out: k[4].t,
        end: k[5].t,
    }
}

fn run_until(world: &mut World, t: f64) {
    while world.time() < t - 1e-9 {
        world.step_frame().unwrap();
    }
}

/// Mean y of the particles that started on each face of the cut plane (half a particle
/// spacing from it), among those in the top `depth` of the block: (−y face, +y face).
fn faces(world: &World, start_y: &[f32], start_z: &[f32], depth: f32) -> (f64, f64) {
    let top = start_z.iter().cloned().fold(f32::MIN, f32::max);
    let mut sums = [(0.0f64, 0usize); 2];
    for (i, x) in world.particles().x.iter().enumerate() {
        if start_y[i].abs() < 0.0006 && start_z[i] > top - depth {
            let side = (start_y[i] > 0.0) as usize;
            sums[side].0 += x.y as f64;
            sums[side].1 += 1;
        }
    }
    (sums[0].0 / sums[0].1 as f64, sums[1].0 / sums[1].1 as f64)
}

/// The block is two pieces, each exactly one side of the blade's plane y = 0 (no particle
/// torn off or left behind in the cut); `start_y` holds each particle's starting y.
fn assert_two_pieces_by_side(world: &World, start_y: &[f32], dx: f32) {
    let p = world.particles();
    let labels = pieces::label(&p.x, &p.crack, dx);
    assert_eq!(labels.iter().max(), Some(&1), "two pieces after the cut");
    for (i, &l) in labels.iter().enumerate() {
        assert_eq!(
            l == labels[0],
            (start_y[i] > 0.0) == (start_y[0] > 0.0),
            "particle {i}"
        );
    }
}

#[test]
fn a_cut_block_ends_in_two_pieces_that_stay_two() {
    let scene = shipped("cutting.toml");
    let times = cut_times(&scene);
    let dx = scene.domain.dx;
    let mut world = World::new(&scene);
    let start_y: Vec<f32> = world.particles().x.iter().map(|x| x.y).collect();
    let start_z: Vec<f32> = world.particles().x.iter().map(|x| x.z).collect();
    assert_eq!(world.pieces(), 1);

    run_until(&mut world, times.through);
    // Cut through: two pieces, each exactly one side of the blade plane (no particle torn
    // off or left behind in the cut).
    assert_two_pieces_by_side(&world, &start_y, dx as f32);
    // The cut is at most a cell wide: the faces stay within a cell of each other (they
    // started one particle spacing, dx/2, apart).
    let (minus, plus) = faces(&world, &start_y, &start_z, 1.0);
    println!("faces after the cut: {minus:.5} / {plus:.5} m");
    assert!(plus - minus <= dx, "cut {:.5} m wide", plus - minus);

    run_until(&mut world, times.spread);
    let (minus, plus) = faces(&world, &start_y, &start_z, 0.004);
    println!("top faces spread: {minus:.5} / {plus:.5} m");
    // The spine wedged the cut open and pushed the +y half's top away: the faces are more
    // than a cell apart (uncut, they stay within one: see the blunt tool below).
    assert!(plus - minus > dx, "spread open by {:.5} m", plus - minus);

    run_until(&mut world, times.out);
    while world.time() < times.end - 1e-9 {
        for _ in 0..6 {
            world.step_frame().unwrap();
        }
        assert_eq!(world.pieces(), 2, "t = {:.3} s", world.time());
    }
    let (minus, plus) = faces(&world, &start_y, &start_z, 0.004);
    println!("top faces a second after the blade left: {minus:.5} / {plus:.5} m");
}

#[test]
fn a_blunt_tool_on_the_same_path_leaves_one_piece() {
    let mut scene = shipped("cutting.toml");
    let times = cut_times(&scene);
    let dx = scene.domain.dx;
    let tool = &mut scene.tools[0];
    let Shape::Slicer { length, .. } = tool.shape else {
        panic!("the cutting scene's tool is a slicer");
    };
    // The capsule the spine's contact region is (1.5 cells round the spine line), along
    // the blade's length (capsule axis z pitched onto x), where the spine is.
    let radius = 1.5 * dx as f32;
    tool.shape = Shape::Capsule {
        radius,
        half_length: 0.5 * length,
    };
    for k in &mut tool.keyframes {
        k.rpy_deg = [0.0, 90.0, 0.0];
    }
    let mut world = World::new(&scene);
    let start_y: Vec<f32> = world.particles().x.iter().map(|x| x.y).collect();
    let start_z: Vec<f32> = world.particles().x.iter().map(|x| x.z).collect();
    run_until(&mut world, times.spread);
    let (minus, plus) = faces(&world, &start_y, &start_z, 0.004);
    println!("blunt, top faces at the end of the push: {minus:.5} / {plus:.5} m");
    assert_eq!(world.pieces(), 1);
    // Uncut, the faces are one material: pushed together, they stay within a cell.
    assert!(plus - minus <= dx, "faces {:.5} m apart", plus - minus);
    while world.time() < times.end - 1e-9 {
        for _ in 0..12 {
            world.step_frame().unwrap();
        }
        assert_eq!(world.pieces(), 1, "t = {:.3} s", world.time());
    }
}

#[test]
fn auto_and_gpu_backends_take_a_slicer_scene() {
    let mut scene = shipped("cutting.toml");
    scene.solver.backend = BackendChoice::Auto;
    let auto = World::try_new(&scene).unwrap();
    let adapters = dvrk_tissue_sim::mpm::gpu::adapter::adapters();
    scene.solver.backend = BackendChoice::Gpu;
    match World::try_new(&scene) {
        // Cutting runs on the GPU (tests/cutting_gpu.rs checks it against the CPU).
        Ok(gpu) => assert_ne!(gpu.backend().name(), "cpu"),
        Err(e) => {
            assert!(adapters.is_empty(), "{e}");
            assert_eq!(auto.backend().name(), "cpu");
        }
    }
}

/// Pixels of a picture within 0.2 (per channel, 0–255 scale) of a shade of `colour`: the
/// colour times a light factor, as particles are shaded.
fn pixels_of_colour(rgb: &[u8], colour: dvrk_tissue_sim::math::Vec3) -> usize {
    rgb.chunks_exact(3)
        .filter(|p| {
            let c = dvrk_tissue_sim::math::Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32) / 255.0;
            let shade = c.dot(&colour) / colour.norm_squared();
            shade > 0.3 && (c - colour * shade).amax() < 0.06
        })
        .count()
}

#[test]
fn a_snapshot_draws_the_faces_of_the_cut() {
    use dvrk_tissue_sim::output::snapshot::{self, SnapshotOptions};
    let scene = shipped("cutting.toml");
    let mut world = World::new(&scene);
    // The camera's renderer marks the surface over the faces, a line along the cut: at
    // 640 × 480 it is a few pixels wide.
    let options = SnapshotOptions {
        width: 640,
        height: 480,
        ..Default::default()
    };
    let face = snapshot::cut_face_colour(options.measure);
    let before = snapshot::render(&world, &options);
    assert_eq!(before.cut_face_particles, 0);
    assert_eq!(
        pixels_of_colour(&before.rgb, face),
        0,
        "uncut: no cut colour"
    );
    // The edge a third of the way down through the block.
    run_until(&mut world, 0.3);
    let picture = snapshot::render(&world, &options);
    let p = world.particles();
    // The faces: the particle layer either side of the blade plane, half a spacing from it.
    let spacing = p.volume0[0].cbrt();
    let expected = p
        .crack
        .iter()
        .filter(|c| c.norm() > 0.0 && c.norm() < spacing)
        .count();
    let red = pixels_of_colour(&picture.rgb, face);
    println!(
        "{} particles on the cut faces, {red} pixels in the cut colour",
        picture.cut_face_particles
    );
    assert!(expected > 0);
    assert_eq!(picture.cut_face_particles, expected);
    assert!(red > 30, "{red} pixels show the cut");
    // The CPU fallback (no GPU adapter at all) draws each face particle as a red disc.
    let splats = snapshot::render_splats(&world, &options);
    let red = pixels_of_colour(&splats.rgb, face);
    println!("the CPU splat fallback: {red} pixels in the cut colour");
    assert!(red > 30, "{red} pixels show the cut");
}

#[test]
fn a_scene_that_cuts_gets_the_isosurface_instead_of_the_fixed_mesh() {
    use dvrk_tissue_sim::output::SurfaceKind;
    use dvrk_tissue_sim::sim::setup::surface_kind;
    let mut scene = shipped("cutting.toml");
    scene.outputs.surface = SurfaceKind::Mesh;
    assert_eq!(surface_kind(&scene), SurfaceKind::Isosurface);
    scene.tools[0].shape = Shape::Sphere { radius: 0.004 };
    assert_eq!(surface_kind(&scene), SurfaceKind::Mesh);
}

/// `config/cutting_psm.toml`: PSM1 at home holds the scalpel (`tool_rpy_deg` turning it half
/// a turn about the instrument's x) exactly where the tool's first keyframe puts it, the
/// blade hanging down with its edge 2 mm above the block; 15 mm more insertion lowers it
/// 15 mm, the edge 1 mm below the table.
#[test]
fn a_psm_holds_the_scalpel_blade_down_along_its_instrument() {
    let scene = shipped("cutting_psm.toml");
    let setup = dvrk_tissue_sim::sim::build_setup(&scene).unwrap();
    let held = setup.arms[0].tool_pose();
    let keyframe =
        setup.world.tools()[setup.arm_tools[0].expect("the PSM holds the scalpel")].pose_at(0.0);
    let dp = (held.position - keyframe.position).norm();
    let angle = held.rotation.angle_to(&keyframe.rotation);
    assert!(dp < 1e-9, "arm {held:?} keyframe {keyframe:?}");
    assert!(angle < 1e-9, "arm {held:?} keyframe {keyframe:?}");
    // The blade's −z (down its height, to the edge) is the world's −z.
    let down = held.rotation * nalgebra::Vector3::new(0.0, 0.0, -1.0);
    assert!((down.z + 1.0).abs() < 1e-12, "blade points {down:?}");
    let Shape::Slicer { height, .. } = scene.tools[0].shape else {
        panic!("the scalpel is a slicer");
    };
    let edge = held.position.z - height as f64;
    let block_top = scene.tissues[0].center[2] + 0.5 * scene.tissues[0].size[2];
    assert!((edge - block_top - 0.002).abs() < 1e-9, "edge at {edge} m");
    let mut q = scene.arms[0].home_joints.clone();
    q[2] += 0.015;
    let lowered = setup.arms[0].psm().forward(&q).unwrap();
    let world = dvrk_tissue_sim::sim::setup::arm_base(&scene.arms[0]) * lowered;
    let edge_down = world.translation.vector.z - height as f64;
    assert!(
        (edge_down - (scene.table.as_ref().unwrap().height - 0.001)).abs() < 1e-6,
        "edge at {edge_down} m after the insertion"
    );
}

/// Messages of an MCAP bag on `topic`: (log time, payload).
fn bag_messages(path: &std::path::Path, topic: &str) -> Vec<(u64, Vec<u8>)> {
    let bytes = std::fs::read(path).unwrap();
    mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(|m| m.unwrap())
        .filter(|m| m.channel.topic == topic)
        .map(|m| (m.log_time, m.data.into_owned()))
        .collect()
}

/// A headless run of `config/cutting_psm.toml` recorded to a bag, the cloud's scalar set to
/// damage (and the block given a toughness so that it has one): the bag's `tissue/pieces`
/// counts one piece before the edge reaches the table and two after, at the scene's
/// `pieces_rate_hz`; its clouds carry the damage field, every value within [0, 1].
#[test]
fn a_recorded_cut_carries_the_piece_count_and_damage() {
    use dvrk_tissue_sim::ros::msgs::{from_cdr, PointCloud2, UInt32};
    let dir = std::env::temp_dir().join(format!("dvrk-cutting-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let text = std::fs::read_to_string(format!(
        "{}/config/cutting_psm.toml",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap()
    .replace("damping = 5.0", "damping = 5.0\ntoughness = 50.0")
    .replace(
        "pieces_rate_hz = 10.0",
        "pieces_rate_hz = 10.0\npoints_scalar = \"damage\"",
    );
    let scene = dir.join("cutting_damage.toml");
    std::fs::write(&scene, text).unwrap();
    let bag = dir.join("cut.mcap");
    let stdout = support::stdout_of_success(
        support::binary()
            .args(["run", "--headless", "--backend", "cpu", "--seconds", "0.6"])
            .arg("--scene")
            .arg(&scene)
            .arg("--record")
            .arg(&bag),
    );
    assert!(stdout.contains("summary: pieces 2"), "{stdout}");
    let counts: Vec<(f64, u32)> = bag_messages(&bag, "/tissue/pieces")
        .iter()
        .map(|(t, m)| (*t as f64 * 1e-9, from_cdr::<UInt32>(m).unwrap().data))
        .collect();
    println!("pieces in the bag: {counts:?}");
    // 10 Hz over 0.6 s.
    assert!((5..=7).contains(&counts.len()), "{counts:?}");
    // The edge reaches the block's top at 0.067 s and the table at 0.467 s (keyframes: 2 mm
    // above the block at t = 0, 1 mm below the table at 0.5 s, 30 mm/s).
    for &(t, n) in &counts {
        if t < 0.42 {
            assert_eq!(n, 1, "{counts:?}");
        } else if t > 0.499 {
            assert_eq!(n, 2, "{counts:?}");
        }
    }
    assert_eq!(counts.last().unwrap().1, 2, "{counts:?}");
    let clouds = bag_messages(&bag, "/tissue/points");
    assert!(!clouds.is_empty());
    let cloud = from_cdr::<PointCloud2>(&clouds.last().unwrap().1).unwrap();
    let names: Vec<&str> = cloud.fields.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, ["x", "y", "z", "damage"]);
    let step = cloud.point_step as usize;
    let damage: Vec<f32> = (0..cloud.width as usize)
        .map(|i| {
            let o = i * step + cloud.fields[3].offset as usize;
            f32::from_le_bytes(cloud.data[o..o + 4].try_into().unwrap())
        })
        .collect();
    assert_eq!(damage.len(), 4800);
    assert!(
        damage.iter().all(|d| (0.0..=1.0).contains(d)),
        "damage outside [0, 1]"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The blade plane's position (m, along world y) as each cut particle remembers it: its y
/// less its crack's y component; `(least, greatest)` for the particles that started at
/// y < 0 and y > 0.
fn remembered_planes(world: &World, start_y: &[f32]) -> [(f32, f32); 2] {
    let p = world.particles();
    let mut planes = [(f32::MAX, f32::MIN); 2];
    for (i, (x, crack)) in p.x.iter().zip(&p.crack).enumerate() {
        if *crack != dvrk_tissue_sim::math::Vec3::zeros() {
            let side = &mut planes[(start_y[i] > 0.0) as usize];
            let plane = x.y - crack.y;
            *side = (side.0.min(plane), side.1.max(plane));
        }
    }
    planes
}

/// The block-cut test with PB-MPM: cut through (0.5 s), the block is two pieces, the y < 0
/// and y > 0 halves exactly, and the cut's faces stay where the blade passed: the blade
/// plane as each half's cut particles remember it (their y less their crack's) spreads over
/// less than a cell (`a_pb_mpm_cut_block_stays_two_through_the_spread` goes on from there).
///
/// Before PB-MPM's P2G took a cut particle's affine momentum about its kept nodes (see
/// `CpuSolver::transfer_to_grid`) the block was one piece at 0.5 s: the −y half's planes
/// spread over [−0.15, +2.62] mm, the faces slid through each other, and particles of one
/// half sat within a cell of the other's, linking them.
#[test]
fn a_pb_mpm_cut_block_ends_in_two_pieces() {
    let mut scene = shipped("cutting.toml");
    scene.solver.method = dvrk_tissue_sim::mpm::Method::PbMpm;
    let times = cut_times(&scene);
    let dx = scene.domain.dx as f32;
    let mut world = World::new(&scene);
    let start_y: Vec<f32> = world.particles().x.iter().map(|x| x.y).collect();
    for k in 1..=5 {
        run_until(&mut world, times.through * k as f64 / 5.0);
        if world.particles().crack.is_empty() {
            continue;
        }
        let [minus, plus] = remembered_planes(&world, &start_y);
        println!(
            "t {:.2} s: {} pieces; remembered blade plane −y half [{:.5}, {:.5}] m, +y half \
             [{:.5}, {:.5}] m",
            world.time(),
            world.pieces(),
            minus.0,
            minus.1,
            plus.0,
            plus.1
        );
    }
    let [minus, plus] = remembered_planes(&world, &start_y);
    // The cut's faces stay where the blade passed, within a cell: no face slides through
    // the other.
    assert!(
        minus.1 - minus.0 < dx && plus.1 - plus.0 < dx,
        "{minus:?} {plus:?}"
    );
    assert_two_pieces_by_side(&world, &start_y, dx);
}

/// PB-MPM on after the cut: the spine spreads the cut (0.7–1.1 s) and leaves (1.3 s), and
/// the block should stay two pieces until the end (2.3 s), as with MLS-MPM. It does not
/// (measured): two pieces at 0.6, 0.8 and 0.9 s (three at 0.7 s), one from 1.0 s on, while
/// the spine pushes the +y half's top away. Ignored until that is understood and fixed; on
/// failure it names a pair of particles, one from each half, that link the halves.
#[test]
#[ignore = "PB-MPM's halves link again while the spine spreads the cut (see the docs)"]
fn a_pb_mpm_cut_block_stays_two_through_the_spread() {
    let mut scene = shipped("cutting.toml");
    scene.solver.method = dvrk_tissue_sim::mpm::Method::PbMpm;
    let times = cut_times(&scene);
    let dx = scene.domain.dx as f32;
    let mut world = World::new(&scene);
    let start: Vec<_> = world.particles().x.clone();
    run_until(&mut world, times.through);
    while world.time() < times.end - 1e-9 {
        for _ in 0..6 {
            world.step_frame().unwrap();
        }
        let pieces = world.pieces();
        println!("t {:.2} s: {pieces} pieces", world.time());
        if pieces >= 2 {
            continue;
        }
        let p = world.particles();
        let separates = dvrk_tissue_sim::mpm::crack::separates;
        let link = (0..p.len())
            .filter(|&i| start[i].y < 0.0)
            .flat_map(|i| (0..p.len()).map(move |j| (i, j)))
            .find(|&(i, j)| {
                let r = p.x[j] - p.x[i];
                start[j].y > 0.0
                    && r.norm() < dx
                    && !separates(p.crack[i], r)
                    && !separates(p.crack[j], -r)
            });
        panic!(
            "one piece at t = {:.2} s; a link across the cut: {}",
            world.time(),
            link.map_or("none found".into(), |(i, j)| format!(
                "particle {i} (started at {:?}, now at {:?}, crack {:?}) and {j} (started at \
                 {:?}, now at {:?}, crack {:?})",
                start[i], p.x[i], p.crack[i], start[j], p.x[j], p.crack[j]
            ))
        );
    }
}

/// A flat mesh blade the shape of the cutting scene's quad: `length` along x centred on 0,
/// from the x axis down to z = −`height`, in `columns` quads (so that its surface has
/// interior edges and vertices too), cutting with its bottom edge only.
fn flat_mesh_blade(length: f32, height: f32, columns: usize) -> Shape {
    use dvrk_tissue_sim::tools::mesh_slicer::{BladeFile, BladeMesh};
    use dvrk_tissue_sim::tools::obj;
    let mut text = String::new();
    for i in 0..=columns {
        let x = -0.5 * length + length * i as f32 / columns as f32;
        text += &format!("v {x} 0 0\nv {x} 0 {}\n", -height);
    }
    for i in 0..columns {
        let (a, b) = (2 * i + 1, 2 * i + 3);
        text += &format!("f {a} {} {} {b}\n", a + 1, b + 1);
    }
    // The spine runs down both sides as well as along the top: the quad's sides do not
    // cut, its edge is the bottom alone.
    let top = (0..=columns).map(|i| (2 * i + 1).to_string());
    let spine: Vec<String> = std::iter::once("2".to_string())
        .chain(top)
        .chain(std::iter::once((2 * columns + 2).to_string()))
        .collect();
    text += &format!("l {}\n", spine.join(" "));
    let path = std::path::Path::new("flat.obj");
    let mesh = BladeMesh::from_obj(obj::parse(&text).unwrap(), path);
    Shape::MeshSlicer {
        file: BladeFile::loaded("flat.obj", mesh),
        thickness: 0.0004,
    }
}

/// The cracks a tool of `shape` at the world's current tool pose gives its particles now.
fn cracks_now(world: &World, shape: Shape) -> Vec<dvrk_tissue_sim::math::Vec3> {
    use dvrk_tissue_sim::tools::{ToolKinematics, ToolVelocity};
    let tool = &world.tools()[0];
    let dx = world.scene().domain.dx as f32;
    let kinematics = ToolKinematics::new(
        shape,
        tool.contact,
        &tool.pose_at(world.time()),
        &ToolVelocity::default(),
        dx,
    );
    let x = &world.particles().x;
    let mut crack = vec![dvrk_tissue_sim::math::Vec3::zeros(); x.len()];
    dvrk_tissue_sim::mpm::crack::mark(&[kinematics], x, &mut crack, dx);
    crack
}

#[test]
fn a_flat_mesh_blade_cuts_what_the_quad_cuts() {
    let scene = shipped("cutting.toml");
    let times = cut_times(&scene);
    let Shape::Slicer { length, height, .. } = scene.tools[0].shape else {
        panic!("the cutting scene's tool is a slicer");
    };
    let mesh = flat_mesh_blade(length, height, 4);
    let mut world = World::new(&scene);
    let (mut frames, mut marked, mut largest_difference) = (0, 0, 0.0f32);
    // Every frame of the cut and the spread, on the particles where the quad left them.
    while world.time() < times.spread - 1e-9 {
        let quad = cracks_now(&world, scene.tools[0].shape);
        let from_mesh = cracks_now(&world, mesh);
        for (i, (q, m)) in quad.iter().zip(&from_mesh).enumerate() {
            assert_eq!(
                q.norm() > 0.0,
                m.norm() > 0.0,
                "particle {i} at {:?}, t = {}",
                world.particles().x[i],
                world.time()
            );
            assert!(
                (q - m).norm() <= 4.0 * f32::EPSILON * q.norm(),
                "particle {i}: quad {q:?}, mesh {m:?}"
            );
            marked += (q.norm() > 0.0) as usize;
            largest_difference = largest_difference.max((q - m).norm());
        }
        frames += 1;
        world.step_frame().unwrap();
    }
    println!(
        "{frames} frames, {marked} particle cracks compared, largest difference \
         {largest_difference:e} m"
    );
    assert!(
        marked > 1000,
        "the comparison covers the cut: {marked} cracks"
    );
}

fn mesh_times(scene: &Scene) -> (f64, f64, f64) {
    let k = &scene.tools[0].keyframes;
    assert_eq!(k.len(), 4, "the mesh cutting scene's four keyframes");
    (k[1].t, k[2].t, k[3].t)
}

#[test]
fn a_mesh_blade_cuts_the_block_into_two_pieces_that_stay_two() {
    let scene = shipped("cutting_mesh.toml");
    assert!(matches!(scene.tools[0].shape, Shape::MeshSlicer { .. }));
    let (through, out, end) = mesh_times(&scene);
    let dx = scene.domain.dx;
    let mut world = World::new(&scene);
    let start_y: Vec<f32> = world.particles().x.iter().map(|x| x.y).collect();
    let start_z: Vec<f32> = world.particles().x.iter().map(|x| x.z).collect();
    assert_eq!(world.pieces(), 1);

    run_until(&mut world, through);
    assert_two_pieces_by_side(&world, &start_y, dx as f32);
    let (minus, plus) = faces(&world, &start_y, &start_z, 1.0);
    println!("faces after the cut: {minus:.5} / {plus:.5} m");
    assert!(plus - minus <= dx, "cut {:.5} m wide", plus - minus);

    run_until(&mut world, out);
    while world.time() < end - 1e-9 {
        for _ in 0..6 {
            world.step_frame().unwrap();
        }
        assert_eq!(world.pieces(), 2, "t = {:.3} s", world.time());
    }
    let (minus, plus) = faces(&world, &start_y, &start_z, 1.0);
    println!("faces a second after the blade left: {minus:.5} / {plus:.5} m");
    assert!(plus - minus <= dx, "cut {:.5} m wide", plus - minus);
}

#[test]
fn auto_and_gpu_backends_take_a_mesh_slicer_scene() {
    let mut scene = shipped("cutting_mesh.toml");
    scene.solver.backend = BackendChoice::Auto;
    let auto = World::try_new(&scene).unwrap();
    use dvrk_tissue_sim::mpm::gpu::adapter;
    let adapters = adapter::adapters();
    // `auto` takes a hardware GPU where there is one, as for any scene the GPU can step.
    let hardware = adapters
        .iter()
        .any(|a| adapter::is_hardware(a.get_info().device_type));
    assert_eq!(auto.backend().name() != "cpu", hardware);
    scene.solver.backend = BackendChoice::Gpu;
    match World::try_new(&scene) {
        // The mesh blade cuts on the GPU (tests/cutting_gpu.rs checks it against the CPU).
        Ok(gpu) => assert_ne!(gpu.backend().name(), "cpu"),
        Err(e) => assert!(adapters.is_empty(), "{e}"),
    }
}

#[test]
fn a_snapshot_draws_the_cut_of_a_mesh_blade() {
    use dvrk_tissue_sim::output::snapshot::{self, SnapshotOptions};
    let scene = shipped("cutting_mesh.toml");
    let mut world = World::new(&scene);
    // The camera's renderer marks the surface over the faces, a line along the cut: at
    // 640 × 480 it is a few pixels wide.
    let options = SnapshotOptions {
        width: 640,
        height: 480,
        ..Default::default()
    };
    run_until(&mut world, 0.3);
    let picture = snapshot::render(&world, &options);
    let red = pixels_of_colour(&picture.rgb, snapshot::cut_face_colour(options.measure));
    println!(
        "{} particles on the cut faces, {red} pixels in the cut colour",
        picture.cut_face_particles
    );
    assert!(picture.cut_face_particles > 0);
    assert!(red > 30, "{red} pixels show the cut");
}
