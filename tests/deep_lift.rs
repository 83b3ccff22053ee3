//! A surgeon's retraction, headless, on the shipped `config/default.toml`: its own keyframes
//! grasp the liver and lift it 25 mm above the grasp, hold, and open the jaws. Total
//! Lagrangian MPM must keep the liver one piece all the way up, the wrench must rise with the
//! lift, and opening must let the liver fall back. With a toughness the same lift tears a
//! chunk out, at a force that follows G_c.

use dvrk_tissue_sim::config;
use dvrk_tissue_sim::mpm::pieces;
use dvrk_tissue_sim::world::World;

#[test]
fn the_liver_lifted_25_mm_stays_one_piece_and_falls_back_when_released() {
    let path = format!("{}/config/default.toml", env!("CARGO_MANIFEST_DIR"));
    let scene = config::load(std::path::Path::new(&path)).unwrap();
    let keys = &scene.tools[0].keyframes;
    let close = keys.iter().find(|k| k.jaw_deg <= 0.0).unwrap();
    let top = keys
        .iter()
        .filter(|k| k.jaw_deg <= 0.0)
        .max_by(|a, b| a.position[2].total_cmp(&b.position[2]))
        .unwrap();
    let lift = top.position[2] - close.position[2];
    assert!(lift >= 0.025 - 1e-9, "the scene lifts {lift} m");
    // Lifting starts at the last keyframe at the closing height; it ends at the top.
    let lift_from = keys
        .iter()
        .filter(|k| k.position[2] == close.position[2])
        .map(|k| k.t)
        .fold(0.0, f64::max);
    let open = keys.iter().rev().find(|k| k.jaw_deg <= 0.0).unwrap().t;

    let mut world = World::new(&scene);
    let top_of = |world: &World| {
        world
            .particles()
            .x
            .iter()
            .map(|x| x.z as f64)
            .fold(f64::MIN, f64::max)
    };
    let rest_top = top_of(&world);
    // |F_z| once a tenth of the way up, then at every frame to the top.
    let mut forces = Vec::new();
    while world.time() < top.t - 1e-9 {
        let report = world.step_frame().unwrap();
        if world.time() >= lift_from + 0.1 * (top.t - lift_from) {
            forces.push((world.time(), -report.wrenches[0].force.z));
        }
    }
    let lifted_top = top_of(&world);
    // Total Lagrangian MPM keeps the rest configuration's connectivity, so `pieces` counts
    // that; that no particle drifted a cell from its neighbours is checked on the positions.
    let dx = world.layout().dx;
    let near_now = |world: &World| pieces::count(&world.particles().x, &[], dx);
    let pieces_at_top = near_now(&world);
    while world.time() < open + 0.8 {
        world.step_frame().unwrap();
    }
    let released_top = top_of(&world);
    let report = format!(
        "top of the liver: {:.1} mm at rest, {:.1} mm lifted, {:.1} mm 0.8 s after opening; \
         pieces at the top {pieces_at_top}, at the end {}; |F_z| from {:.3} N to {:.3} N",
        rest_top * 1e3,
        lifted_top * 1e3,
        released_top * 1e3,
        near_now(&world),
        forces.first().unwrap().1,
        forces.last().unwrap().1,
    );
    println!("{report}");
    assert_eq!(pieces_at_top, 1, "torn by the lift: {report}");
    assert_eq!(near_now(&world), 1, "in pieces after the release: {report}");
    assert!(
        lifted_top - rest_top >= 0.8 * lift,
        "the liver did not follow the jaws up: {report}"
    );
    // The pull grows as the tissue stretches: every frame's force at least the last one's,
    // less 2 % of the final force for the frame-to-frame ripple.
    let last = forces.last().unwrap().1;
    assert!(
        last > 1.0,
        "the gripper feels {last:.3} N at the top: {report}"
    );
    for pair in forces.windows(2) {
        assert!(
            pair[1].1 >= pair[0].1 - 0.02 * last,
            "the force fell from {:.3} N to {:.3} N at t = {:.3} s: {report}",
            pair[0].1,
            pair[1].1,
            pair[1].0
        );
    }
    assert!(
        released_top - rest_top < 0.3 * (lifted_top - rest_top),
        "opening the jaws did not let the liver fall back: {report}"
    );
}

#[test]
fn total_lagrangian_tissue_counts_its_rest_pieces_however_far_it_is_pulled() {
    use dvrk_tissue_sim::config::builders::grasp_scene;
    use dvrk_tissue_sim::mpm::Method;
    // A block whose half at x > 0 is moved three cells away (a stretch past a cell per
    // particle): MLS-MPM's particles there no longer interact, total Lagrangian MPM's still
    // share the nodes they shared at rest.
    let pieces_pulled_apart = |method: Method| {
        let mut scene = grasp_scene(0.5, 0.8, 1.2, 0.01);
        scene.solver.method = method;
        let mut world = World::new(&scene);
        assert_eq!(world.pieces(), 1);
        let dx = world.layout().dx;
        for x in world.particles_mut().x.iter_mut().filter(|x| x.x > 0.0) {
            x.x += 3.0 * dx;
        }
        world.pieces()
    };
    assert_eq!(pieces_pulled_apart(Method::MlsMpm), 2);
    assert_eq!(pieces_pulled_apart(Method::TlMpm), 1);
}

/// The shipped grasp and lift with a toughness G_c, to the top of the lift: the largest
/// |F_z| on the way, |F_z| at the top and the pieces there.
fn lift_with_toughness(toughness: f64) -> (f64, f64, usize) {
    let path = format!("{}/config/default.toml", env!("CARGO_MANIFEST_DIR"));
    let mut scene = config::load(std::path::Path::new(&path)).unwrap();
    scene.tissues[0].material.toughness = Some(toughness);
    let top = scene.tools[0]
        .keyframes
        .iter()
        .filter(|k| k.jaw_deg <= 0.0)
        .max_by(|a, b| a.position[2].total_cmp(&b.position[2]))
        .unwrap()
        .t;
    let mut world = World::new(&scene);
    let (mut peak, mut last) = (0.0f64, 0.0f64);
    while world.time() < top - 1e-9 {
        last = -world.step_frame().unwrap().wrenches[0].force.z;
        peak = peak.max(last);
    }
    (peak, last, world.pieces())
}

/// With a toughness, total Lagrangian MPM tears where the material says so: the same 25 mm
/// lift pulls a chunk out of the liver around the jaws (two pieces at the top, the force
/// fallen to a fraction of its peak), and the force the tear takes follows G_c. The crack
/// band's onset is an energy density, Y₀ = G_c/(2h) (`mpm::damage`), and the tissue's
/// energy density grows as the square of the pull, so four times the toughness takes
/// twice the force: √4.
#[test]
fn with_a_toughness_the_same_lift_tears_the_liver_at_a_force_that_follows_it() {
    let (low, high) = (7.5, 30.0);
    let (peak_low, top_low, pieces_low) = lift_with_toughness(low);
    let (peak_high, top_high, pieces_high) = lift_with_toughness(high);
    let ratio = peak_high / peak_low;
    let report = format!(
        "G_c {low} J/m²: peak |F_z| {peak_low:.3} N, {top_low:.3} N at the top, {pieces_low} \
         pieces; G_c {high} J/m²: peak {peak_high:.3} N, {top_high:.3} N at the top, \
         {pieces_high} pieces; peak ratio {ratio:.3} (√4 = 2)"
    );
    println!("{report}");
    for (pieces, peak, top) in [
        (pieces_low, peak_low, top_low),
        (pieces_high, peak_high, top_high),
    ] {
        assert_eq!(pieces, 2, "not torn by the lift: {report}");
        assert!(top < 0.5 * peak, "the force did not fall: {report}");
    }
    assert!(
        (1.6..2.4).contains(&ratio),
        "the tearing force does not follow √G_c: {report}"
    );
}

/// The pull of the same 25 mm lift at dx 2 mm and 1 mm (8× the particles), halfway up and
/// at the top: total Lagrangian MPM gives a resolution-independent answer where MLS-MPM's
/// is a tear whose height depends on the cell. The default liver at dx 1 mm is 256,000
/// particles, so both runs take its half-size copy (20 × 20 × 10 mm) with the scene's
/// material and gripper, the jaws biting 5 mm: 4,000 and 32,000 particles.
#[test]
fn the_same_lift_at_dx_2_mm_and_1_mm_pulls_within_15_percent() {
    use dvrk_tissue_sim::config::Keyframe;
    const LIFT: f64 = 0.025;
    let (grasp_z, lift_from, lift_to) = (0.019, 0.4, 1.4);
    let pulls = |dx: f64| {
        let path = format!("{}/config/default.toml", env!("CARGO_MANIFEST_DIR"));
        let mut scene = config::load(std::path::Path::new(&path)).unwrap();
        scene.domain.dx = dx;
        let table = scene.table.as_ref().unwrap().height;
        scene.tissues[0].size = [0.02, 0.02, 0.01];
        scene.tissues[0].center = [0.0, 0.0, table + 0.005 + 1e-5];
        // Closing from 50° from the start, lifted 25 mm from 0.4 s to 1.4 s.
        let key = |t: f64, z: f64, jaw_deg: f64| Keyframe {
            t,
            position: [0.0, 0.0, z],
            rpy_deg: [180.0, 0.0, 90.0],
            jaw_deg,
        };
        scene.tools[0].keyframes = vec![
            key(0.0, grasp_z, 50.0),
            key(0.3, grasp_z, -20.0),
            key(lift_from, grasp_z, -20.0),
            key(lift_to, grasp_z + LIFT, -20.0),
        ];
        let mut world = World::new(&scene);
        let mut halfway = None;
        let mut top = 0.0;
        while world.time() < lift_to - 1e-9 {
            top = -world.step_frame().unwrap().wrenches[0].force.z;
            if halfway.is_none() && world.time() >= 0.5 * (lift_from + lift_to) - 1e-9 {
                halfway = Some(top);
            }
        }
        assert_eq!(world.pieces(), 1, "dx {dx}: torn by the lift");
        (halfway.unwrap(), top, world.particles().x.len())
    };
    let coarse = pulls(0.002);
    let fine = pulls(0.001);
    let report = format!(
        "dx 2 mm ({} particles): {:.3} N halfway, {:.3} N at the top; dx 1 mm ({} particles): \
         {:.3} N, {:.3} N",
        coarse.2, coarse.0, coarse.1, fine.2, fine.0, fine.1
    );
    println!("{report}");
    assert_eq!(fine.2, 8 * coarse.2, "{report}");
    for (c, f) in [(coarse.0, fine.0), (coarse.1, fine.1)] {
        assert!(c > 0.5 && f > 0.5, "the lift pulls little: {report}");
        assert!(
            (c - f).abs() <= 0.15 * c.max(f),
            "the pulls differ by more than 15 %: {report}"
        );
    }
}
