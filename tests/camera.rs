//! The camera's pictures against geometry (small images: on llvmpipe a frame is CPU work):
//! a plane's depth against the analytic depth, a point's pixel against CameraInfo's K, stereo
//! disparity against f·b/z, and labels against the shapes drawn.

use dvrk_tissue_sim::config::builders::grasp_scene;
use dvrk_tissue_sim::math::Vec3;
use dvrk_tissue_sim::mpm::Method;
use dvrk_tissue_sim::render::camera::{look_at, stereo_eyes};
use dvrk_tissue_sim::render::geometry::{LABEL_TABLE, LABEL_TISSUE, LABEL_TOOL};
use dvrk_tissue_sim::render::{Frame, Pinhole, Renderer, SceneGeometry, Triangles};
use dvrk_tissue_sim::tools::Shape;
use dvrk_tissue_sim::world::World;
use nalgebra::{Isometry3, Point3, Translation3};

fn renderer() -> Renderer {
    Renderer::new().expect("the camera tests need a GPU adapter (llvmpipe will do)")
}

fn pinhole(width: u32, height: u32) -> Pinhole {
    Pinhole::from_hfov(width, height, 60f64.to_radians(), 0.005, 10.0)
}

/// Mean pixel (OpenCV coordinates) of the pixels of one eye labelled `label`, and their count.
fn centroid(frame: &Frame, eye: usize, label: u8) -> ([f64; 2], usize) {
    let labels = frame.eye(&frame.labels, eye, 1);
    let w = frame.eye_width as usize;
    let (mut sx, mut sy, mut n) = (0.0, 0.0, 0usize);
    for (i, &l) in labels.iter().enumerate() {
        if l == label {
            sx += (i % w) as f64;
            sy += (i / w) as f64;
            n += 1;
        }
    }
    ([sx / n.max(1) as f64, sy / n.max(1) as f64], n)
}

#[test]
fn a_plane_seen_obliquely_has_the_analytic_depth_within_half_a_percent() {
    let mut r = renderer();
    let mut tris = Triangles::default();
    tris.table(0.0, [-1.0, -1.0], [1.0, 1.0]);
    let eye_at = Vec3::new(0.03, -0.04, 0.08);
    let pose = look_at(eye_at, Vec3::new(0.0, 0.01, 0.0));
    let p = pinhole(64, 48);
    let eyes = stereo_eyes(&pose, p, 0.0);
    let frame = r.render(&tris.vertices, &eyes).unwrap();
    assert_eq!((frame.width, frame.height), (64, 48));
    let mut checked = 0;
    let mut worst = 0f64;
    for v in 0..48 {
        for u in 0..64 {
            let i = v * 64 + u;
            assert_eq!(frame.labels[i], LABEL_TABLE, "pixel ({u}, {v})");
            // The pixel's ray in the camera frame (z = 1), into the world, onto z = 0.
            let ray = Vec3::new(
                (u as f32 - p.cx) / p.focal,
                (v as f32 - p.cy) / p.focal,
                1.0,
            );
            let world_ray = pose.rotation * ray;
            let analytic = (-eye_at.z / world_ray.z) as f64;
            let rel = (frame.depth[i] as f64 - analytic).abs() / analytic;
            worst = worst.max(rel);
            checked += 1;
        }
    }
    println!(
        "plane: {checked} pixels, largest depth error {:.4} %",
        100.0 * worst
    );
    assert!(worst < 0.005, "largest relative depth error {worst}");
}

#[test]
fn a_point_lands_where_k_projects_it_and_stereo_disparity_is_f_b_over_z() {
    let mut r = renderer();
    let p = pinhole(160, 120);
    let rig = look_at(Vec3::new(0.0, 0.0, 0.1), Vec3::zeros());
    let baseline = 0.006;
    let eyes = stereo_eyes(&rig, p, baseline);
    // Small spheres at several depths and off-axis positions.
    for (k, centre) in [
        Vec3::new(0.0, 0.0, 0.04),
        Vec3::new(0.012, -0.008, 0.0),
        Vec3::new(-0.02, 0.01, 0.03),
    ]
    .into_iter()
    .enumerate()
    {
        let mut tris = Triangles::default();
        tris.tool(
            &Shape::Sphere { radius: 0.002 },
            &Isometry3::from_parts(Translation3::from(centre), Default::default()),
            0.0,
            LABEL_TOOL,
        );
        let frame = r.render(&tris.vertices, &eyes).unwrap();
        assert_eq!(
            (frame.width, frame.eye_width, frame.height),
            (320, 160, 120)
        );
        let mut seen = [[0.0; 2]; 2];
        for (e, eye) in eyes.iter().enumerate() {
            let in_eye = eye.pose.inverse_transform_point(&Point3::from(centre));
            let expected = p.project(in_eye.coords).unwrap();
            let (drawn, n) = centroid(&frame, e, LABEL_TOOL);
            assert!(n > 3, "sphere {k} eye {e}: {n} pixels");
            let err = ((drawn[0] - expected[0] as f64).powi(2)
                + (drawn[1] - expected[1] as f64).powi(2))
            .sqrt();
            println!("sphere {k} eye {e}: drawn {drawn:.2?}, K gives {expected:.2?}, {err:.3} px");
            assert!(
                err < 1.0,
                "sphere {k} eye {e}: {err} px from K's projection"
            );
            seen[e] = drawn;
        }
        let z = rig.inverse_transform_point(&Point3::from(centre)).z as f64;
        let disparity = seen[0][0] - seen[1][0];
        let expected = p.focal as f64 * baseline as f64 / z;
        println!("sphere {k}: disparity {disparity:.3} px, f·b/z = {expected:.3} px");
        assert!((disparity - expected).abs() < 1.0);
        assert!(
            (seen[0][1] - seen[1][1]).abs() < 0.5,
            "rectified: same rows"
        );
    }
}

#[test]
fn labels_match_the_shapes_drawn_in_a_shipped_scene() {
    // The grasp scene: a tissue block on the table, a gripper above it with its jaws open.
    let scene = grasp_scene(0.5, 0.8, 1.2, 0.01);
    let world = World::new(&scene);
    let mut geometry = SceneGeometry::new(&world, None).unwrap();
    let tris = geometry.triangles(&world);
    let mut r = renderer();
    let p = pinhole(96, 72);
    let pose = look_at(Vec3::new(0.03, -0.035, 0.045), Vec3::new(0.0, 0.0, 0.008));
    let eyes = stereo_eyes(&pose, p, 0.0);
    let frame = r.render(&tris.vertices, &eyes).unwrap();
    let table_z = scene.table.as_ref().unwrap().height as f32;
    let tool = &world.tools()[0];
    let tool_pose = tool.pose_at(0.0);
    let (rot, at): (nalgebra::Matrix3<f32>, Vec3) = (
        tool_pose.rotation.to_rotation_matrix().into_inner().cast(),
        tool_pose.position.cast(),
    );
    let particles = &world.particles().x;
    let spacing = world.particles().volume0[0].cbrt();
    let mut counts = [0usize; 3];
    for v in 0..72 {
        for u in 0..96 {
            let i = v * 96 + u;
            let label = frame.labels[i];
            let z = frame.depth[i];
            assert_eq!(
                label == 0,
                z.is_nan(),
                "pixel ({u}, {v}): depth {z}, label {label}"
            );
            if label == 0 {
                continue;
            }
            let ray = Vec3::new(
                (u as f32 - p.cx) / p.focal,
                (v as f32 - p.cy) / p.focal,
                1.0,
            );
            let x = pose * Point3::from(ray * z);
            if label == LABEL_TABLE {
                assert!(
                    (x.z - table_z).abs() < 1e-4,
                    "table pixel ({u}, {v}) at {x}"
                );
                counts[0] += 1;
            } else if label == LABEL_TISSUE {
                // On the block's surface: within a spacing of its particles' hull.
                let nearest = particles
                    .iter()
                    .map(|q| (q - x.coords).norm())
                    .fold(f32::INFINITY, f32::min);
                assert!(
                    nearest < 1.2 * spacing,
                    "tissue pixel ({u}, {v}) {nearest} m from particles"
                );
                counts[1] += 1;
            } else if label == LABEL_TOOL {
                let local = rot.tr_mul(&(x.coords - at));
                let d = tool.shape.query(local, tool_pose.jaw as f32).distance;
                assert!(
                    d.abs() < 2e-4,
                    "tool pixel ({u}, {v}) {d} m off the gripper's surface"
                );
                counts[2] += 1;
            } else {
                panic!("pixel ({u}, {v}) labelled {label}: nothing of that label is in the scene");
            }
        }
    }
    println!(
        "labelled pixels: table {}, tissue {}, gripper {}",
        counts[0], counts[1], counts[2]
    );
    assert!(counts.iter().all(|&c| c > 30), "{counts:?}");
}

#[test]
fn the_shipped_default_scene_puts_its_optical_frames_on_tf_static_under_the_ecm() {
    use dvrk_tissue_sim::ros::camera::{optical_frame, EYES};
    use dvrk_tissue_sim::ros::outputs::{tf_static_message, OutputLayout};
    use dvrk_tissue_sim::sim::{build_setup, frame_loop::endoscope_pose};
    let path = format!("{}/config/default.toml", env!("CARGO_MANIFEST_DIR"));
    let scene = dvrk_tissue_sim::config::load(std::path::Path::new(&path)).unwrap();
    let mut setup = build_setup(&scene).unwrap();
    let layout = OutputLayout::new(&scene, &setup, "/");
    let fixed = tf_static_message(&layout).transforms;
    let edges: Vec<(&str, &str)> = fixed
        .iter()
        .map(|t| (t.header.frame_id.as_str(), t.child_frame_id.as_str()))
        .collect();
    for edge in [
        ("world", "PSM1_base"),
        ("world", "ECM_base"),
        ("ECM", "ECM_left_optical_frame"),
        ("ECM", "ECM_right_optical_frame"),
    ] {
        assert!(edges.contains(&edge), "{edge:?} missing from {edges:?}");
    }
    // Through the ECM's tool frame, where the frame loop puts the camera, to the eyes the
    // renderer draws from.
    let tip = endoscope_pose(&setup).unwrap();
    let rig = setup
        .camera
        .as_mut()
        .expect("the camera (llvmpipe will do)");
    rig.set_pose(tip);
    for (eye, side) in rig.eyes().iter().zip(EYES) {
        let name = optical_frame(side);
        let t = &fixed
            .iter()
            .find(|t| t.child_frame_id == name)
            .unwrap()
            .transform;
        let offset = Vec3::new(
            t.translation.x as f32,
            t.translation.y as f32,
            t.translation.z as f32,
        );
        let at = tip * Point3::from(offset);
        assert!(
            (at.coords - eye.pose.translation.vector).norm() < 1e-6,
            "{name}: tf puts it at {at}, the renderer at {}",
            eye.pose.translation.vector
        );
    }
}

/// Tissue labelled pixels whose surface point lies in the gap between the two halves of a
/// block pulled 4 mm apart (world x from 1 to 3 mm, above the table), and all tissue pixels,
/// as the camera draws the scene with `toughness` set (tissue that can tear) or not.
fn tissue_pixels_in_the_gap(toughness: Option<f64>) -> (usize, usize) {
    let mut scene = grasp_scene(0.5, 0.8, 1.2, 0.01);
    scene.tools.clear();
    scene.tissues[0].center = [0.0, 0.0, 0.004];
    scene.tissues[0].size = [0.012, 0.006, 0.004];
    scene.tissues[0].material.toughness = toughness;
    let mut world = World::new(&scene);
    let mut geometry = SceneGeometry::new(&world, None).unwrap();
    // The block in two: the half at x > 0 moved 4 mm (four cells) along x.
    for x in world.particles_mut().x.iter_mut().filter(|x| x.x > 0.0) {
        x.x += 0.004;
    }
    let tris = geometry.triangles(&world);
    let mut r = renderer();
    let p = pinhole(128, 96);
    let pose = look_at(
        Vec3::new(0.002, -0.025, 0.035),
        Vec3::new(0.002, 0.0, 0.004),
    );
    let frame = r
        .render(&tris.vertices, &stereo_eyes(&pose, p, 0.0))
        .unwrap();
    let (mut in_gap, mut tissue) = (0, 0);
    for v in 0..96 {
        for u in 0..128 {
            let i = v * 128 + u;
            if frame.labels[i] != LABEL_TISSUE {
                continue;
            }
            tissue += 1;
            let ray = Vec3::new(
                (u as f32 - p.cx) / p.focal,
                (v as f32 - p.cy) / p.focal,
                1.0,
            );
            let x = pose * Point3::from(ray * frame.depth[i]);
            if x.x > 0.001 && x.x < 0.003 && x.z > 0.0025 {
                in_gap += 1;
            }
        }
    }
    (in_gap, tissue)
}

#[test]
fn tissue_that_can_tear_is_drawn_as_its_isosurface_so_a_gap_shows() {
    // The rest surface's mesh stretches over the gap: what the camera drew before.
    let (bridged, mesh_tissue) = tissue_pixels_in_the_gap(None);
    // With toughness the scene's surface is the isosurface, rebuilt from the particles.
    let (in_gap, iso_tissue) = tissue_pixels_in_the_gap(Some(1.0));
    println!(
        "tissue pixels over the 4 mm gap: mesh {bridged} of {mesh_tissue}, isosurface \
         {in_gap} of {iso_tissue}"
    );
    assert!(
        bridged > 50,
        "the mesh should bridge the gap: {bridged} pixels"
    );
    assert_eq!(in_gap, 0, "the isosurface drew tissue in the gap");
    assert!(iso_tissue > mesh_tissue / 2, "{iso_tissue} tissue pixels");
}

/// A grasp lifted on the GPU backend (llvmpipe here), drawn with the tissue from the
/// solver's buffers and from the host at the same state, with the next frame in flight as
/// the node draws: asserts the device drew it and the two pictures agree; returns how many
/// tissue pixels both drew.
fn drawn_in_place_as_on_the_host(method: Method, toughness: Option<f64>) -> usize {
    use dvrk_tissue_sim::mpm::backend::BackendChoice;
    use dvrk_tissue_sim::render::{CameraRig, CameraSettings};
    // The jaws close on the block and lift it 20 mm.
    let mut scene = grasp_scene(0.05, 0.15, 0.35, 0.02);
    scene.solver.backend = BackendChoice::Gpu;
    scene.tissues[0].material.toughness = toughness;
    scene.solver.method = method;
    scene.camera = Some(CameraSettings {
        resolution: [160, 120],
        position: Some([0.015, -0.025, 0.028]),
        look_at: Some([0.0, 0.0, 0.008]),
        ..CameraSettings::default()
    });
    let mut world = World::try_new(&scene).expect("the GPU backend (llvmpipe will do)");
    let mut in_place = CameraRig::for_world(&world).expect("a camera");
    let mut host = CameraRig::for_world(&world).expect("a camera");
    host.set_in_place(false);
    // The camera's first frame was submitted before the surface was built on the device.
    let rest = in_place.render(&mut world).unwrap().frame;
    assert!(!in_place.drew_in_place());
    while world.time() < 0.3 {
        world.step_frame().expect("frame");
    }
    // As the node draws: the next frame is in flight while the last one's outputs are
    // built, so the device's particles are a frame ahead of the picture.
    world.begin_frame();
    let drawn = in_place.render(&mut world).unwrap().frame;
    assert!(in_place.drew_in_place(), "the tissue drawn from the device");
    let reference = host.render(&mut world).unwrap().frame;
    assert!(!host.drew_in_place());
    world.finish_frame().expect("frame");
    let is_tissue = |l: u8| l == LABEL_TISSUE;
    let (mut tissue, mut label_differs, mut brightest) = (0, 0, 0u8);
    let (mut depths, mut moved) = (Vec::new(), 0);
    for i in 0..drawn.labels.len() {
        let (a, b) = (drawn.labels[i], reference.labels[i]);
        if a != b {
            label_differs += 1;
            continue;
        }
        if !is_tissue(a) {
            continue;
        }
        tissue += 1;
        depths.push((drawn.depth[i] - reference.depth[i]).abs());
        for c in 0..3 {
            brightest = brightest.max(drawn.rgb[3 * i + c].abs_diff(reference.rgb[3 * i + c]));
        }
        if !is_tissue(rest.labels[i]) || (drawn.depth[i] - rest.depth[i]).abs() > 5e-4 {
            moved += 1;
        }
    }
    depths.sort_by(f32::total_cmp);
    let deepest = depths.last().copied().unwrap_or(0.0);
    println!(
        "{method:?}, toughness {toughness:?}: tissue pixels {tissue}, labels differing {label_differs} of \
         {}, largest depth difference {deepest:.2e} m, largest colour difference \
         {brightest}/255, tissue pixels moved since rest {moved}",
        drawn.labels.len()
    );
    assert!(tissue > 1000, "{tissue} tissue pixels");
    assert!(
        moved > tissue / 10,
        "the lift moved the drawn tissue: {moved} of {tissue} pixels"
    );
    // The same sums in another order (f32), so edges may flip a pixel's label.
    assert!(label_differs * 200 < drawn.labels.len(), "{label_differs}");
    assert!(deepest < 1e-6, "depth {deepest} m apart");
    assert!(brightest <= 3, "colour {brightest}/255 apart");
    tissue
}

/// The rest mesh moved with the particles on the device draws as the host's, under the
/// default scene's total Lagrangian MPM (a mesh a frame stale measured 6.7e-6 m under
/// MLS-MPM and fails).
#[test]
fn the_gpu_backend_draws_the_tissue_mesh_from_its_own_buffers_as_the_host_would() {
    drawn_in_place_as_on_the_host(Method::TlMpm, None);
}

/// Tissue that can tear is the level set, extracted on the device as the host does.
#[test]
fn the_gpu_backend_extracts_the_level_set_it_draws_as_the_host_would() {
    drawn_in_place_as_on_the_host(Method::MlsMpm, Some(1e4));
}
