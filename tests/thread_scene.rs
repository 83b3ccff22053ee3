//! The suture thread in scenes: `config/thread.toml` headless (a gripper picks the thread up
//! off the table, lifts it by the grasped point while the rest hangs, opens and it falls
//! back), a thread-only scene with a pinned end, a capsule pushing a lying thread, the
//! thread's topics in a recorded bag, `config/knot.toml` (two grippers tie an overhand knot
//! in a straight thread and pull it) and `tests/scenes/knot_laid.toml` (a laid overhand knot
//! pulled tight, with its 3-0 nylon and 70 mm variants).

use dvrk_tissue_sim::config;
use dvrk_tissue_sim::world::World;
use nalgebra::Vector3;
use std::path::Path;

mod support;

use support::scenes::shipped;

/// A thread-only domain (30 × 20 × 30 cm, 1 cm cells) around the origin, for scenes of one
/// `[[thread]]` table given after it.
const HANG_DOMAIN: &str = r#"
[domain]
origin = [-0.15, -0.1, -0.2]
size = [0.3, 0.2, 0.3]
dx = 0.01
"#;

/// The scene of `text` (TOML), named `name` in messages.
fn scene(text: &str, name: &str) -> config::Scene {
    config::from_str(text, Path::new(name)).unwrap_or_else(|e| panic!("{e}"))
}

fn elongation_within(world: &World, bound: f64) {
    let elongation = world.threads()[0].elongation();
    assert!(elongation.abs() < bound, "elongation {elongation}");
}

/// Steps `world` until simulated time reaches `t`.
fn run_until(world: &mut World, t: f64) {
    while world.time() < t - 1e-9 {
        world.step_frame().expect("frame");
        assert!(world.threads().iter().all(|th| th.rod.is_finite()));
    }
}

fn highest(world: &World) -> f32 {
    world.threads()[0]
        .rod
        .points
        .iter()
        .map(|p| p.z)
        .fold(f32::MIN, f32::max)
}

#[test]
fn gripper_picks_the_thread_up_lifts_it_and_lets_it_fall() {
    let scene = shipped("thread.toml");
    let table = scene.table.as_ref().unwrap().height as f32;
    let mut world = World::new(&scene);
    assert_eq!(world.threads().len(), 1);
    let r = world.threads()[0].rod.material.radius;

    // Dropped from 6 mm, it lies on the table before the gripper arrives.
    run_until(&mut world, 0.45);
    let lying = highest(&world);
    assert!(
        lying < table + 4.0 * r,
        "thread not on the table: highest point {lying} m"
    );
    assert_eq!(world.threads()[0].grasped_points(), 0);

    // Closed on it and lifted 40 mm: the grasped points ride with the jaws.
    run_until(&mut world, 1.95);
    let thread = &world.threads()[0];
    assert!(
        thread.grasped_points() >= 2,
        "grasped {} points",
        thread.grasped_points()
    );
    assert!(thread.held_by(0));
    let tool = world.tools()[0].pose_at(world.time());
    // The jaw tips were 9.4 mm below the pivot on the thread when they closed.
    let expected_z = (tool.position.z - 0.0094) as f32;
    let middle = thread.rod.points[thread.rod.points.len() / 2];
    assert!(
        (middle.z - expected_z).abs() < 1e-3,
        "grasped point at z {} m, jaws hold it at {expected_z} m",
        middle.z
    );
    assert!(middle.z > table + 0.035, "lifted only to {} m", middle.z);
    // The rest hangs from the grasp. Held in the jaws, each 75 mm half is a cantilever under
    // its own weight: 3-0 nylon (EI ≈ 3.8e-7 N·m²) droops by about qL⁴/(8EI) ≈ 4.6 mm at its
    // end (the jaws clamp 2.5 mm of it, so the free length is a little shorter).
    let points = &thread.rod.points;
    let m = thread.rod.material;
    let q = m.linear_density() * 9.81;
    let droop = q * 0.075f32.powi(4) / (8.0 * m.bending_stiffness());
    for (end, quarter) in [
        (points[0], points[points.len() / 4]),
        (points[points.len() - 1], points[3 * points.len() / 4]),
    ] {
        let end_droop = middle.z - end.z;
        assert!(
            end_droop > 0.5 * droop && end_droop < 1.5 * droop,
            "end droops {end_droop} m, cantilever {droop} m"
        );
        assert!(
            end.z < quarter.z && quarter.z < middle.z,
            "not hanging: end {end}, quarter {quarter}"
        );
    }
    // Hanging by its middle, its length holds to well within 0.1 %.
    assert!(
        thread.elongation().abs() < 1e-3,
        "elongation {}",
        thread.elongation()
    );

    // Opened at 2.0–2.1 s: let go, it falls back onto the table.
    run_until(&mut world, 2.7);
    let thread = &world.threads()[0];
    assert_eq!(thread.grasped_points(), 0);
    assert!(!thread.held_by(0));
    let fallen = highest(&world);
    assert!(
        fallen < table + 0.003,
        "thread did not fall back: highest point {fallen} m"
    );
}

#[test]
fn a_thread_only_scene_with_a_pinned_end_hangs_from_it() {
    let text = format!(
        r#"{HANG_DOMAIN}
[[thread]]
start = [-0.05, 0.0, 0.05]
pinned = "start"
"#
    );
    let scene = scene(&text, "hang.toml");
    assert!(scene.tissues.is_empty());
    let mut world = World::new(&scene);
    run_until(&mut world, 1.5);
    let rod = &world.threads()[0].rod;
    // The pinned start stays; the free end swung down below it.
    assert_eq!(rod.points[0], nalgebra::Vector3::new(-0.05, 0.0, 0.05));
    let end = rod.points[rod.points.len() - 1];
    assert!(end.z < 0.05 - 0.08, "free end at z {} m", end.z);
    elongation_within(&world, 1e-3);
}

#[test]
fn headless_record_of_thread_toml_holds_the_thread_topics_and_the_summary_reports_it() {
    use dvrk_tissue_sim::ros::msgs::{from_cdr, Marker, PointCloud2};
    let dir = std::env::temp_dir().join(format!("dvrk-thread-scene-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bag = dir.join("thread.mcap");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_dvrk-tissue-sim"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["run", "--scene", "config/thread.toml", "--headless"])
        .args(["--seconds", "1.5", "--print-every", "60", "--record"])
        .arg(&bag)
        .output()
        .expect("cannot run the binary");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let summary = stdout
        .lines()
        .find(|l| l.starts_with("summary: thread suture elongation"))
        .unwrap_or_else(|| panic!("no thread summary in:\n{stdout}"));
    // Held by the jaws at the end of the run.
    assert!(
        summary.contains("ends (") && !summary.contains(" 0 point(s) grasped"),
        "{summary}"
    );

    let bytes = std::fs::read(&bag).unwrap();
    let mut markers = Vec::new();
    let mut clouds = Vec::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        match m.channel.topic.as_str() {
            "/threads/suture/centreline" => markers.push(from_cdr::<Marker>(&m.data).unwrap()),
            "/threads/suture/tension" => clouds.push(from_cdr::<PointCloud2>(&m.data).unwrap()),
            _ => {}
        }
    }
    // A message of each per period of the scene's thread rate through the 1.5 s run, and a
    // centreline point per joint of the thread's segments.
    let shipped =
        config::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("config/thread.toml")).unwrap();
    let per_topic = (1.5 * shipped.outputs.thread_rate_hz).round() as usize;
    assert_eq!((markers.len(), clouds.len()), (per_topic, per_topic));
    let last = markers.last().unwrap();
    assert_eq!(
        (last.kind, last.header.frame_id.as_str()),
        (Marker::LINE_STRIP, "world")
    );
    assert_eq!(last.points.len(), shipped.threads[0].segments as usize + 1);
    let cloud = clouds.last().unwrap();
    let names: Vec<&str> = cloud.fields.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, ["x", "y", "z", "tension"]);
    assert_eq!(cloud.width, 61);
    // The cloud's points are the marker's.
    let x0 = f32::from_le_bytes(cloud.data[0..4].try_into().unwrap());
    assert!((x0 as f64 - last.points[0].x).abs() < 1e-6);
    // At 1.5 s the thread hangs from the jaws, 32 mm up: its tension is positive near the
    // grasp, and of the order of the weight hanging there (the whole thread weighs
    // 6.7e-5 N), far below a newton.
    let tension: Vec<f32> = cloud
        .data
        .chunks(16)
        .map(|p| f32::from_le_bytes(p[12..16].try_into().unwrap()))
        .collect();
    let peak = tension.iter().cloned().fold(f32::MIN, f32::max);
    assert!(peak > 0.0 && peak < 1e-2, "peak tension {peak} N");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_thread_pinned_at_both_ends_sags_between_them_and_keeps_its_ends() {
    let text = format!(
        r#"{HANG_DOMAIN}
[[thread]]
start = [-0.05, 0.0, 0.05]
direction = [1.0, 0.0, -0.2]
length = 0.1
segments = 40
pinned = "both"
"#
    );
    let scene = scene(&text, "both.toml");
    let mut world = World::new(&scene);
    let rod0 = world.threads()[0].rod.clone();
    run_until(&mut world, 1.0);
    let rod = &world.threads()[0].rod;
    assert_eq!(rod.points[0], rod0.points[0]);
    assert_eq!(rod.points[40], rod0.points[40]);
    // A straight thread between fixed ends can only sag by stretching: it stays nearly
    // straight, within F/(EA) of its length, its middle a little below the chord.
    let chord_mid = (rod0.points[0] + rod0.points[40]) * 0.5;
    let sag = chord_mid.z - rod.points[20].z;
    assert!(sag > 0.0 && sag < 0.005, "sag {sag} m");
    elongation_within(&world, 1e-3);
}

/// Distance from `p` to the segment from `a` to `b`.
fn to_segment(p: Vector3<f32>, a: Vector3<f32>, b: Vector3<f32>) -> f32 {
    let ab = b - a;
    let t = ((p - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
    (p - (a + ab * t)).norm()
}

#[test]
fn a_capsule_pushed_across_a_lying_thread_moves_it_and_never_passes_through_it() {
    // A 15 cm thread on the table along x; an upright capsule (3 mm radius, reaching 1 mm
    // below the table top) sweeps along y through its middle at 0.1 m/s, from y = −20 mm
    // to +20 mm.
    let text = r#"
[domain]
origin = [-0.1, -0.05, -0.01]
size = [0.2, 0.1, 0.06]
dx = 0.002
[table]
height = 0.0
[[thread]]
start = [-0.075, 0.0, 0.0002]
[[tool]]
name = "probe"
shape = { type = "capsule", radius = 0.003, half_length = 0.01 }
contact = { model = "coulomb", friction = 0.3 }
[[tool.keyframe]]
t = 0.0
position = [0.0, -0.02, 0.012]
[[tool.keyframe]]
t = 0.1
position = [0.0, -0.02, 0.012]
[[tool.keyframe]]
t = 0.5
position = [0.0, 0.02, 0.012]
"#;
    let scene = scene(text, "push.toml");
    let mut world = World::new(&scene);
    let (capsule_radius, half_length) = (0.003f32, 0.01f32);
    let r = world.threads()[0].rod.material.radius;
    let mut deepest = f32::MAX;
    while world.time() < 0.7 - 1e-9 {
        world.step_frame().expect("frame");
        let rod = &world.threads()[0].rod;
        assert!(rod.is_finite());
        let centre: Vector3<f32> = world.tools()[0].pose_at(world.time()).position.cast();
        let axis = Vector3::new(0.0, 0.0, half_length);
        // Clearance of the centreline (points and segment interiors) from the capsule.
        for w in rod.points.windows(2) {
            for k in 0..8 {
                let p = w[0] + (w[1] - w[0]) * (k as f32 / 8.0);
                deepest = deepest.min(to_segment(p, centre - axis, centre + axis));
            }
        }
    }
    // Never inside the capsule by more than 10 % of the thread's radius.
    assert!(
        deepest > capsule_radius + 0.9 * r,
        "centreline came {deepest} m from the capsule's axis (radius {capsule_radius} m)"
    );
    // Carried along: the thread is on the far side of the capsule, ahead of it. (The point
    // in front of the capsule's axis, not a fixed index: wrapped round the capsule the
    // thread slides along it by a fraction of a segment.)
    let rod = &world.threads()[0].rod;
    let ahead = rod.points.iter().map(|p| p.y).fold(f32::MIN, f32::max);
    assert!(
        ahead > 0.02 + capsule_radius,
        "thread's furthest point at y {ahead} m, capsule at 0.02 m"
    );
    // Pushed, not lifted: it stays on the table, and keeps its length.
    assert!(
        rod.points.iter().all(|p| p.z < 4.0 * r),
        "thread left the table"
    );
    elongation_within(&world, 1e-3);
}

/// A thread laid in a U on the table (`points`): arms along x at y = 0 and y = 15 mm.
/// A gripper closes on the first arm and drags it 30 mm along +y across the table, through
/// where the second arm lies. The gripper holds only the points between its jaws: the
/// rest of the thread still collides with it, so the second arm is pushed ahead of the
/// jaws rather than passing through them.
#[test]
fn a_gripper_holding_the_thread_still_pushes_the_rest_of_it() {
    let r: f32 = 1.125e-4;
    let z = r;
    let text = format!(
        r#"
[domain]
origin = [-0.08, -0.04, -0.008]
size = [0.16, 0.12, 0.06]
dx = 0.002
[table]
height = 0.0
[[thread]]
points = [[-0.06, 0.0, {z}], [0.03, 0.0, {z}], [0.03, 0.015, {z}], [-0.06, 0.015, {z}]]
length = 0.19
segments = 76
rest_shape = "as_laid"
[[tool]]
name = "gripper"
shape = {{ type = "gripper", jaw_length = 0.01, jaw_width = 0.006, jaw_thickness = 0.004 }}
contact = {{ model = "coulomb", friction = 1.0 }}
[[tool.keyframe]]
t = 0.0
position = [0.0, 0.0, 0.0095]
rpy_deg = [180.0, 0.0, 0.0]
jaw_deg = 0.0
[[tool.keyframe]]
t = 0.05
position = [0.0, 0.0, 0.0095]
rpy_deg = [180.0, 0.0, 0.0]
jaw_deg = -20.0
[[tool.keyframe]]
t = 0.3
position = [0.0, 0.0, 0.0095]
rpy_deg = [180.0, 0.0, 0.0]
jaw_deg = -20.0
[[tool.keyframe]]
t = 1.3
position = [0.0, 0.03, 0.0095]
rpy_deg = [180.0, 0.0, 0.0]
jaw_deg = -20.0
"#
    );
    let scene = scene(&text, "u.toml");
    let mut world = World::new(&scene);
    run_until(&mut world, 0.3);
    let held = world.threads()[0].grasped_points();
    assert!(held >= 2, "grasped {held} points");
    run_until(&mut world, 1.4);
    let thread = &world.threads()[0];
    assert_eq!(thread.grasped_points(), held, "the grasp slipped");
    let points = &thread.rod.points;
    // The held arm went with the jaws to y = 30 mm.
    let first_arm = points[24];
    assert!(
        (first_arm.y - 0.03).abs() < 1e-3,
        "first arm at {first_arm:?}"
    );
    // The second arm's points within the jaws' width (|x| ≤ 3 mm + r) lie ahead of the
    // jaws (4 mm thick), not between or behind them.
    let second_arm: Vec<_> = points[50..]
        .iter()
        .filter(|p| p.x.abs() <= 0.003 + r)
        .collect();
    assert!(!second_arm.is_empty());
    for p in &second_arm {
        assert!(
            p.y >= 0.03 + 0.004 - r,
            "second-arm point {p:?} inside or behind the jaws at y = 0.03 m"
        );
    }
    elongation_within(&world, 2e-3);
}

/// Pairs of segments (at least `chain_gap` apart along the chain) whose centrelines were
/// within `near` of each other in `before` and are on opposite sides of each other in
/// `after`: the vector between their closest points reversed, with those points inside
/// both segments in both states (a pair whose closest point ran off a segment's end slid
/// past it, not through it). A strand pulled through a joint has its closest points at the
/// joint, the end of both segments there: near pairs whose closest points lie at an end
/// before or after are tested by their centrelines' meetings (reported as (a, b + 1000)).
fn crossings(
    before: &[Vector3<f32>],
    after: &[Vector3<f32>],
    gap: usize,
    near: f32,
) -> Vec<(usize, usize, f32)> {
    use dvrk_tissue_sim::rod::crossing::pair_crossed;
    use dvrk_tissue_sim::rod::self_contact::closest_parameters;
    let inside = |(s, t): (f32, f32)| s > 0.0 && s < 1.0 && t > 0.0 && t < 1.0;
    let between = |p: &[Vector3<f32>], a: usize, b: usize, (s, t): (f32, f32)| {
        (p[b] + (p[b + 1] - p[b]) * t) - (p[a] + (p[a + 1] - p[a]) * s)
    };
    let n = before.len() - 1;
    let mut found = Vec::new();
    for a in 0..n {
        for b in a + gap..n {
            let st0 = closest_parameters(before[a], before[a + 1], before[b], before[b + 1]);
            let d0 = between(before, a, b, st0);
            if d0.norm() > near || !inside(st0) {
                continue;
            }
            let st1 = closest_parameters(after[a], after[a + 1], after[b], after[b + 1]);
            let d1 = between(after, a, b, st1);
            if inside(st1) && d0.dot(&d1) < 0.0 {
                found.push((a, b, d0.norm()));
            }
        }
    }
    // Through a joint, or while turned nearly parallel, the closest points sit at a
    // segment's end and the test above cannot tell through from round: there the solver's
    // own exact test decides (the centrelines met an odd number of times on the straight
    // way from `before` to `after`).
    for a in 0..n {
        for b in a + gap..n {
            let st0 = closest_parameters(before[a], before[a + 1], before[b], before[b + 1]);
            let d0 = between(before, a, b, st0);
            if d0.norm() > near
                || inside(st0) && {
                    let st1 = closest_parameters(after[a], after[a + 1], after[b], after[b + 1]);
                    inside(st1)
                }
            {
                continue;
            }
            if pair_crossed(before, after, a, b, near / 4.0) {
                found.push((a, b + 1000, d0.norm()));
            }
        }
    }
    found
}

/// The reproduction of a pass-through (tests/scenes/coil_drag.toml): a tail dragged along
/// its length across the side of an upright coil. Frame by frame, no pair of segments that
/// were close changes sides, and the tail does not end up inside the coil.
#[test]
fn a_tail_dragged_across_a_coil_does_not_pass_through_it() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/scenes/coil_drag.toml");
    let scene = config::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let mut world = World::new(&scene);
    let rod = &world.threads()[0].rod;
    let gap = dvrk_tissue_sim::rod::self_contact::SelfContacts::chain_gap(rod);
    let diameter = 2.0 * rod.material.radius;
    let mut closest = f32::MAX;
    while world.time() < 2.7 - 1e-9 {
        let before = world.threads()[0].rod.points.clone();
        world.step_frame().expect("frame");
        let rod = &world.threads()[0].rod;
        assert!(rod.is_finite());
        let crossed = crossings(&before, &rod.points, gap, 4.0 * diameter);
        assert!(
            crossed.is_empty(),
            "at {:.3} s segments (a, b, distance before in m) crossed: {crossed:?}",
            world.time()
        );
        closest = closest.min(dvrk_tissue_sim::rod::self_contact::min_self_distance(rod));
    }
    // Never closer than 80 % of a diameter (the contact's own tolerance).
    assert!(
        closest > 0.8 * diameter,
        "closest approach {} diameters",
        closest / diameter
    );
}

/// A knot scene's thread at one moment.
#[derive(Debug)]
struct KnotState {
    /// Knot determinant of the centreline (1 unknotted, 3 overhand).
    det: u128,
    /// How far (m) the knot reaches across the line of pull of the laid knot: from the
    /// ends' mean y down to its lowest y (its lobes lie at −y).
    depth: f32,
    /// The knotted part's extent in the top view (m, `knot_span`).
    extent: f32,
    /// The length of thread in the knotted part (m, `knot_span`): what a tightening pulls
    /// out of the loop.
    length: f32,
    /// Where along the thread the knotted part lies: its middle point's index, counted from
    /// the thread's start (`knot_span`).
    middle: f32,
    /// The median tension along the thread (N).
    median_tension: f32,
}

fn knot_state(world: &World) -> KnotState {
    let thread = &world.threads()[0];
    let points = &thread.rod.points;
    let ends = 0.5 * (points[0].y + points[points.len() - 1].y);
    let lowest = points.iter().map(|p| p.y).fold(f32::MAX, f32::min);
    let (extent, length, middle) = knot_span(points);
    let mut tension = thread.rod.tension.clone();
    tension.sort_by(f32::total_cmp);
    KnotState {
        det: thread.knot_determinant(),
        depth: ends - lowest,
        extent,
        length,
        middle,
        median_tension: tension[tension.len() / 2],
    }
}

/// The knotted part of `points`, from the first to the last segment that crosses another in
/// the top view: the larger side of its x–y bounding box and its length along the thread
/// (m; both zero where none crosses), and the index of its middle point.
fn knot_span(points: &[Vector3<f32>]) -> (f32, f32, f32) {
    let cross = |a: Vector3<f32>, b: Vector3<f32>, c: Vector3<f32>| {
        (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x)
    };
    let n = points.len() - 1;
    let (mut first, mut last) = (usize::MAX, 0);
    for i in 0..n {
        for j in i + 2..n {
            let (p, q, r, s) = (points[i], points[i + 1], points[j], points[j + 1]);
            if cross(p, q, r) * cross(p, q, s) < 0.0 && cross(r, s, p) * cross(r, s, q) < 0.0 {
                first = first.min(i);
                last = last.max(j + 1);
            }
        }
    }
    if first > last {
        return (0.0, 0.0, 0.0);
    }
    let knot = &points[first..=last];
    let length = knot.windows(2).map(|w| (w[1] - w[0]).norm()).sum();
    let side = |f: fn(&Vector3<f32>) -> f32| {
        let (lo, hi) = knot
            .iter()
            .map(f)
            .fold((f32::MAX, f32::MIN), |(lo, hi), v| (lo.min(v), hi.max(v)));
        hi - lo
    };
    (
        side(|p| p.x).max(side(|p| p.y)),
        length,
        0.5 * (first + last) as f32,
    )
}

/// config/knot.toml with its pull on both ends carried on past the tightening (15.05 s) at
/// 10 mm/s to `side` a side in all (the shipped file stops 72 mm a side), then held for half
/// a second; with `reversed` the thread is numbered from its standing end. Returns the scene
/// and the checkpoints: the tightening's end, the pull's end and the hold's end.
fn knot_pulled_hard(side: f64, reversed: bool) -> (config::Scene, [f64; 3]) {
    let mut scene = shipped("knot.toml");
    if reversed {
        let thread = &mut scene.threads[0];
        let (start, d) = (
            thread.start.expect("knot.toml sets start"),
            thread.direction,
        );
        thread.start = Some(std::array::from_fn(|k| start[k] + d[k] * thread.length));
        thread.direction = d.map(|x| -x);
    }
    let tightened = 15.05;
    let pulled = tightened + (side - 0.07) / 0.01;
    // a pulls along +15°, b along -x (knot.toml).
    for (tool, along) in scene
        .tools
        .iter_mut()
        .zip([15f64.to_radians(), std::f64::consts::PI])
    {
        tool.keyframes.retain(|f| f.t <= tightened + 1e-9);
        let mut frame = tool.keyframes.last().expect("keyframes").clone();
        frame.t = pulled;
        frame.position[0] += (side - 0.07) * along.cos();
        frame.position[1] += (side - 0.07) * along.sin();
        tool.keyframes.push(frame.clone());
        frame.t = pulled + 0.5;
        tool.keyframes.push(frame);
    }
    (scene, [tightened, pulled, pulled + 0.5])
}

/// The knot of config/knot.toml pulled on after the tightening to 85 mm a side: it closes to
/// a third of its thread, jams (the tension rises 40-fold) and stays where it was tied,
/// whichever end the thread is numbered from. Two defects failed this pull:
/// - With the contact pairs swept always in chain order the knot ran along the standing part
///   towards the higher numbers: its middle from point 68 at 15.0 s to 140 at 15.9 s (144
///   mm); numbered from the other end it ran the other way, 110 mm towards the tail by 15.8
///   s, and came undone (`SelfContacts::project`).
/// - With segments two apart left out of the self-contact, the knot numbered from the
///   standing end closed to six segments and came undone at 16.5 s
///   (`SelfContacts::chain_gap`).
///
/// Checked by the determinant at the checkpoints, not frame by frame: in the knot's core,
/// closed to 10 segments a turn, strands in contact slide about a diameter past each other
/// between two 60 Hz frames, and the straight way from one frame to the next (the proxy of
/// `crossings` and `meetings` for the 100 substeps between them, each of which the solver
/// tests exactly) has pairs 10 and 12 segments apart meet (segments 75 and 86 at 15.600 s,
/// numbered from the tail).
fn knot_pulled_hard_stays(reversed: bool) {
    let (scene, times) = knot_pulled_hard(0.085, reversed);
    let KnotPull {
        checks,
        largest_elongation,
        world,
        ..
    } = pull_knot(&scene, 1, &times, Check::Determinant);
    let rod = &world.threads()[0].rod;
    let last = (rod.points.len() - 1) as f32;
    // The knot's place along the thread in the shipped numbering (points from the tail).
    let place = |k: &KnotState| if reversed { last - k.middle } else { k.middle };
    let summary: Vec<_> = checks
        .iter()
        .map(|(t, k)| (*t, k.det, k.length, place(k), k.median_tension))
        .collect();
    println!(
        "reversed {reversed}: (time s, det, thread in the knot m, its middle point, median \
         tension N): {summary:?}; largest |elongation| {largest_elongation:.2e}"
    );
    for (t, knot) in &checks {
        assert_eq!(knot.det, 3, "knot determinant at {t} s");
    }
    let [tightened, pulled, held] = [&checks[0].1, &checks[1].1, &checks[2].1];
    // Measured: 53 mm numbered from the tail, 21 mm from the standing end, both towards a.
    // Half of what the pump ran.
    let travel = (place(held) - place(tightened)).abs() * rod.rest_lengths[0];
    assert!(
        travel < 0.07,
        "the knot ran {travel} m along the thread: {tightened:?}, then {held:?}"
    );
    // Measured: 42 -> 13.5 mm of thread numbered from the tail, 40 -> 10.8 mm from the
    // standing end. The length counts whole segments from the first crossing to the last:
    // held, it may gain part of one.
    assert!(
        pulled.length < 0.5 * tightened.length && held.length < 0.5 * tightened.length,
        "the pull closes the knot and the hold keeps it: {tightened:?}, {pulled:?}, {held:?}"
    );
    // Measured: 0.30 -> 13.5 mN and 0.33 -> 13.6 mN. A knot that slides or comes undone
    // leaves the thread slack (0.05 mN after it came undone).
    assert!(
        held.median_tension > 10.0 * tightened.median_tension,
        "the jammed knot takes the pull: {tightened:?}, then {held:?}"
    );
    // No runaway stretch: the thread's own strain at the jam's median tension is T/(EA) =
    // 4.3e-3. Measured 5.2e-3 and 5.6e-3 (the taut part carries more than the median).
    assert!(
        largest_elongation < 1e-2,
        "largest elongation {largest_elongation}"
    );
}

#[test]
fn knot_toml_pulled_hard_stays_where_it_was_tied() {
    knot_pulled_hard_stays(false);
}

#[test]
fn knot_toml_pulled_hard_stays_with_the_thread_numbered_from_its_other_end() {
    knot_pulled_hard_stays(true);
}

/// What a knot scene showed: its thread at the start and at each of `until`, the largest
/// |elongation| of any frame, and the world at the end. Frame by frame it asserts that no
/// pair of segments within four diameters passes through another (by `check`).
struct KnotPull {
    start: KnotState,
    checks: Vec<(f64, KnotState)>,
    largest_elongation: f64,
    world: World,
}

fn pull_knot(scene: &config::Scene, start: u128, until: &[f64], check: Check) -> KnotPull {
    let mut world = World::new(scene);
    let rod = &world.threads()[0].rod;
    let gap = dvrk_tissue_sim::rod::self_contact::SelfContacts::chain_gap(rod);
    let diameter = 2.0 * rod.material.radius;
    let at_start = knot_state(&world);
    assert_eq!(at_start.det, start, "knot determinant at the start");
    let mut largest_elongation = 0.0_f64;
    let mut checks = Vec::new();
    for &until in until {
        while world.time() < until - 1e-9 {
            let before = world.threads()[0].rod.points.clone();
            world.step_frame().expect("frame");
            let thread = &world.threads()[0];
            assert!(thread.rod.is_finite());
            let crossed = match check {
                Check::Sides => crossings(&before, &thread.rod.points, gap, 4.0 * diameter),
                Check::Meetings => meetings(&before, &thread.rod.points, gap, 4.0 * diameter),
                Check::Determinant => Vec::new(),
            };
            assert!(
                crossed.is_empty(),
                "at {:.3} s segments (a, b, distance before in m) crossed: {crossed:?}",
                world.time()
            );
            largest_elongation = largest_elongation.max(thread.elongation().abs());
        }
        checks.push((until, knot_state(&world)));
    }
    KnotPull {
        start: at_start,
        checks,
        largest_elongation,
        world,
    }
}

/// How `pull_knot` checks each frame for pairs passed through each other.
#[derive(Clone, Copy)]
enum Check {
    /// `crossings`: the closest points' vector reversed, or the centrelines met an odd
    /// number of times where the closest points lie at an end.
    Sides,
    /// `meetings`: the centrelines met an odd number of times, for every near pair.
    Meetings,
    /// None frame by frame: only the knot determinant at the checkpoints.
    Determinant,
}

/// Pairs of segments within `near` in `before` whose centrelines met an odd number of times
/// on the straight way from `before` to `after` (the solver's exact test, frame to frame).
fn meetings(
    before: &[Vector3<f32>],
    after: &[Vector3<f32>],
    gap: usize,
    near: f32,
) -> Vec<(usize, usize, f32)> {
    use dvrk_tissue_sim::rod::crossing::pair_crossed;
    use dvrk_tissue_sim::rod::self_contact::segment_distance;
    let n = before.len() - 1;
    let mut found = Vec::new();
    for a in 0..n {
        for b in a + gap..n {
            let d = segment_distance(before[a], before[a + 1], before[b], before[b + 1]);
            if d <= near && pair_crossed(before, after, a, b, near / 4.0) {
                found.push((a, b, d));
            }
        }
    }
    found
}

/// The keyframe times of tests/scenes/knot_laid.toml: the tightening pull ends, the last
/// pull ends, the hold ends.
const KNOT_TIMES: [f64; 3] = [2.6, 3.5, 4.5];

/// The laid knot (tests/scenes/knot_laid.toml).
fn laid_knot_path() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/scenes/knot_laid.toml")
}

/// tests/scenes/knot_laid.toml with `replacements` (text, new text) made, each of which
/// must occur.
fn knot_variant(replacements: &[(&str, &str)], name: &str) -> config::Scene {
    let mut text = std::fs::read_to_string(laid_knot_path()).expect("knot_laid.toml");
    for (from, to) in replacements {
        assert!(text.contains(from), "{from} not in knot_laid.toml");
        text = text.replace(from, to);
    }
    scene(&text, name)
}

/// Pulls the variant of the laid knot made by `replacements` (named `name` in messages),
/// each frame checked by `check`, and prints its figures under `label`: the knot
/// determinant must read 3 at each of `KNOT_TIMES` and the largest |elongation| of any frame
/// stay below 1 %.
fn knot_variant_stays_an_overhand_knot(
    replacements: &[(&str, &str)],
    name: &str,
    check: Check,
    label: &str,
) {
    let pull = pull_knot(&knot_variant(replacements, name), 3, &KNOT_TIMES, check);
    println!(
        "{label}: laid {:?}; (time s, knot): {:?}; largest |elongation| {:.2e}",
        pull.start, pull.checks, pull.largest_elongation
    );
    for (t, knot) in &pull.checks {
        assert_eq!(knot.det, 3, "knot determinant at {t} s");
    }
    assert!(
        pull.largest_elongation < 1e-2,
        "largest elongation {}",
        pull.largest_elongation
    );
}

/// Issue 18: the laid knot in 3-0 nylon (E = 3 GPa, G = 1.07 GPa) came
/// undone while tightening (det 1 at 2.6 s): the length restoration after the contact
/// rounds pulled the taut strand through a bent joint of the other, deeper than the side
/// test recognised. It must hold through the tightening, the last pull and the hold.
/// Largest |elongation| measured 2.3e-3 (a tension EA·ε ≈ 0.28 N in the tightened nylon
/// knot; whether its bending or the contacts hold it is not traced).
#[test]
fn laid_knot_in_3_0_nylon_stays_an_overhand_knot() {
    knot_variant_stays_an_overhand_knot(
        &[
            ("youngs_modulus = 1.0e8", "youngs_modulus = 3.0e9"),
            ("shear_modulus = 3.57e7", "shear_modulus = 1.07e9"),
        ],
        "knot_nylon.toml",
        Check::Meetings,
        "3-0 nylon",
    );
}

/// Issue 18: the soft laid knot pulled 70 mm a side instead of 55 (and 5 mm
/// more each at 3.0–3.5 s) came undone (det 1 at 2.6 s) through a pair that turned nearly
/// parallel within a substep. It must hold. Checked by the determinant only: frame to
/// frame, the straight way from one frame's points to the next (a proxy for the 32 substeps
/// between them, each of which the solver checks) has segments 65 and 66 meet 97 at 3.050 s
/// while the knot stays one (not traced further). Largest |elongation| measured 1.15e-3 (see
/// the README: the fail-safe that keeps the strands apart here also holds part of the knot
/// back).
#[test]
fn laid_knot_pulled_70_mm_a_side_stays_an_overhand_knot() {
    knot_variant_stays_an_overhand_knot(
        &[
            ("[0.1047,", "[0.1197,"),
            ("[0.1097,", "[0.1247,"),
            ("[-0.1027,", "[-0.1177,"),
            ("[-0.1077,", "[-0.1227,"),
        ],
        "knot_70mm.toml",
        Check::Determinant,
        "pulled 70 mm",
    );
}

/// tests/scenes/knot_laid.toml: an overhand knot laid loosely on the table (det 3), its
/// tails grasped and pulled apart along x until the knot reaches less than 60 % as far
/// across the line of pull as laid, then pulled once more (closing it further) and held.
/// Frame by frame no pair of segments passes through another;
/// the knot determinant reads 3 after the tightening, after the last pull and at the end of
/// the hold, and the thread stays within 0.1 % of its length.
#[test]
fn laid_knot_pulled_tight_and_pulled_again_stays_an_overhand_knot() {
    let KnotPull {
        start,
        checks,
        largest_elongation,
        ..
    } = pull_knot(
        &config::load(&laid_knot_path()).unwrap_or_else(|e| panic!("{e}")),
        3,
        &KNOT_TIMES,
        Check::Sides,
    );
    println!(
        "laid: {start:?}; (time s, knot): {checks:?}; \
         largest |elongation| {largest_elongation:.2e}"
    );
    for (t, knot) in &checks {
        assert_eq!(knot.det, 3, "knot determinant at {t} s");
    }
    // Measured: 40.2 mm laid, 23.4 mm tightened, 18.6 mm after the last pull, 17.6 mm at
    // the end of the hold.
    let laid_depth = start.depth;
    let tightened_depth = checks[0].1.depth;
    assert!(
        tightened_depth < 0.6 * laid_depth,
        "the pull closes the lobes: depth {tightened_depth} m of {laid_depth} m laid"
    );
    let final_depth = checks[2].1.depth;
    assert!(
        final_depth < tightened_depth,
        "the last pull closes them further: depth {final_depth} m, {tightened_depth} m before"
    );
    assert!(
        largest_elongation < 1e-3,
        "largest elongation {largest_elongation}"
    );
}

/// `config/knot.toml`, the headline of issue 18's knot: two keyframed grippers tie an
/// overhand knot in a straight thread lying on the table (det 1), pull it tight, pull both
/// ends once more and hold. Frame by frame no pair of segments passes through another (a
/// knot made that way would not be tied); the determinant reads 1 until the tail is carried
/// through the loop, 3 from then on, after the pulls and at the end of the hold, with both
/// grippers holding the thread; the tightening pulls most of the loop's thread out of the
/// knot and the knot stays that tight; the thread stays within 0.1 % of its length.
#[test]
fn knot_toml_ties_an_overhand_knot_and_pulls_it_tight() {
    // Before the tuck, the tail through the loop, A on the standing part, the tightening's
    // end, the last pull's end, the hold's end.
    const TIMES: [f64; 6] = [6.5, 8.65, 12.2, 15.05, 15.95, 16.65];
    let KnotPull {
        checks,
        largest_elongation,
        world,
        ..
    } = pull_knot(&shipped("knot.toml"), 1, &TIMES, Check::Sides);
    let spans: Vec<(f64, u128, f32, f32)> = checks
        .iter()
        .map(|(t, k)| (*t, k.det, k.extent, k.length))
        .collect();
    println!(
        "(time s, det, knot extent m, thread in the knot m): {spans:?}; \
         largest |elongation| {largest_elongation:.2e}"
    );
    assert_eq!(
        checks[0].1.det, 1,
        "not knotted before the tail goes through the loop"
    );
    for (t, knot) in &checks[1..] {
        assert_eq!(knot.det, 3, "knot determinant at {t} s");
    }
    let thread = &world.threads()[0];
    assert!(
        thread.held_by(0) && thread.held_by(1),
        "both grippers hold the thread at the end"
    );
    let [before, tightened, pulled_again, held] =
        [&checks[2].1, &checks[3].1, &checks[4].1, &checks[5].1];
    // Measured: 190 mm of thread in the knot before the pull, 42 mm tightened, 36 mm after
    // the last pull and at the end of the hold; 54.0, 11.0, 9.6 and 9.5 mm across the top
    // view.
    assert!(
        tightened.length < 0.4 * before.length && tightened.extent < 0.5 * before.extent,
        "the tightening pulls the loop's thread out: {before:?}, then {tightened:?}"
    );
    assert!(
        pulled_again.length <= tightened.length && held.length <= 1.05 * pulled_again.length,
        "the last pull closes it further and the hold keeps it: {tightened:?}, \
         {pulled_again:?}, {held:?}"
    );
    assert!(
        largest_elongation < 1e-3,
        "largest elongation {largest_elongation}"
    );
}
