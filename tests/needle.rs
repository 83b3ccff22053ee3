//! The needle as a rigid body (`world::needle_body`), driven through headless keyframes as a
//! user scripts it: let go above tissue it falls onto it and comes to rest on its surface,
//! on the CPU and on the GPU with both P2G variants (agreeing); a gripper closing on it
//! carries it, a second gripper closing on it takes it over, and opened it drops it onto
//! the tissue; resting, the tissue's force on it is its weight. `cargo test --release --test needle -- --nocapture` prints the figures.

use dvrk_tissue_sim::config::{self, Scene};
use dvrk_tissue_sim::mpm::backend::{BackendChoice, P2gAtomics};
use dvrk_tissue_sim::world::needle_body::Carrier;
use dvrk_tissue_sim::world::World;
use std::path::Path;

mod support;

const DX: f64 = 0.002;
/// Top of the tissue block (its particles' upper face), m.
const TISSUE_TOP: f64 = 0.014;
/// Where the needle's centre is held before it is let go, m.
const HELD_Z: f64 = 0.03;

/// A 3 × 3 × 1 cm block bonded to the table, a half-circle needle (radius 10 mm) lying flat
/// 16 mm above it, held by its keyframes; `tools` adds more `[[tool]]` tables, `release`
/// the time its keyframes open the needle driver's jaw (none: held throughout).
fn scene(release: Option<f64>, tools: &str) -> Scene {
    let release = match release {
        Some(t) => format!(
            "[[tool.keyframe]]\nt = {t}\nposition = [0.0, -0.005, {HELD_Z}]\njaw_deg = 30.0\n"
        ),
        None => String::new(),
    };
    let text = format!(
        r#"
name = "needle"
frame_rate_hz = 60
[domain]
origin = [-0.03, -0.03, -0.002]
size = [0.06, 0.06, 0.05]
dx = {DX}
[solver]
backend = "cpu"
[table]
height = 0.004
hold = "bonded"
[[tissue]]
center = [0.0, 0.0, 0.009]
size = [0.03, 0.03, 0.01]
[tissue.material]
youngs_modulus = 5000.0
poisson_ratio = 0.45
density = 1100.0
damping = 2.0
[[tool]]
name = "needle"
shape = {{ type = "needle", radius = 0.01, arc_angle = 3.14159, wire_radius = 0.0005 }}
[[tool.keyframe]]
t = 0.0
position = [0.0, -0.005, {HELD_Z}]
{release}
{tools}
"#
    );
    config::from_str(&text, Path::new("needle.toml")).expect("valid scene")
}

fn needle_z(world: &World) -> f64 {
    world.tools()[0].pose_at(world.time()).position.z
}

/// Lets the needle go at 0.1 s and steps `seconds`; returns the needle's height each frame
/// and the tissue's force on it over the last frame, N.
fn drop_onto_tissue(
    backend: BackendChoice,
    p2g: P2gAtomics,
    seconds: f64,
) -> (World, Vec<f64>, f64) {
    let mut scene = scene(Some(0.1), "");
    scene.solver.backend = backend;
    scene.solver.p2g_atomics = p2g;
    let mut world = World::new(&scene);
    let frames = (seconds * 60.0).round() as usize;
    let mut heights = Vec::with_capacity(frames);
    let mut force = 0.0;
    for _ in 0..frames {
        let report = world.step_frame().expect("frame");
        force = report.wrenches[0].force.z;
        heights.push(needle_z(&world));
    }
    (world, heights, force)
}

/// The needle's rest height on the tissue, checked: it fell, never sank through the tissue,
/// lies still on its surface, and the tissue carries its weight (`force`, N).
fn check_rest(label: &str, world: &World, heights: &[f64], force: f64) -> f64 {
    let needle = world.tools()[0].needle().expect("a needle has a body");
    assert_eq!(*needle.carrier(), Carrier::Free, "{label}: let go");
    let rest = *heights.last().unwrap();
    let lowest = heights.iter().copied().fold(f64::INFINITY, f64::min);
    let speed = needle.velocity().norm();
    let particles = &world.particles().x;
    assert!(
        particles.iter().all(|x| x.iter().all(|c| c.is_finite())),
        "{label}: tissue finite"
    );
    println!(
        "{label}: held at {:.2} mm, lowest {:.2} mm, rests at {:.2} mm ({:.2} mm above the \
         tissue's top), speed {:.2} mm/s",
        HELD_Z * 1e3,
        lowest * 1e3,
        rest * 1e3,
        (rest - TISSUE_TOP) * 1e3,
        speed * 1e3
    );
    // The wire is fattened to 1.5 cells for the grid, so it rests on the nodes its tissue
    // reaches: within that of the particles' top face, and not below it by a cell.
    assert!(
        rest > TISSUE_TOP && rest < TISSUE_TOP + 2.0 * DX,
        "{label}: rests on the tissue, not in it or above it: {rest}"
    );
    assert!(
        lowest > TISSUE_TOP - DX,
        "{label}: never sank through: {lowest}"
    );
    assert!(speed < 0.005, "{label}: still: {speed} m/s");
    let weight = needle.mass() * 9.81;
    println!(
        "{label}: the tissue pushes the needle up with {:.3} mN; its weight is {:.3} mN",
        force * 1e3,
        weight * 1e3
    );
    assert!(
        (force / weight - 1.0).abs() < 0.05,
        "{label}: the tissue carries the needle's weight: {force} N against {weight} N"
    );
    rest
}

#[test]
fn let_go_above_tissue_the_needle_falls_onto_it_and_rests_there_on_cpu_and_gpu() {
    let (world, heights, force) = drop_onto_tissue(BackendChoice::Cpu, P2gAtomics::Auto, 1.0);
    // Still held after the first frame (the keyframes open the jaw past 10° at a third of
    // 0.1 s).
    assert!((heights[0] - HELD_Z).abs() < 1e-12, "held: {}", heights[0]);
    let cpu = check_rest("cpu", &world, &heights, force);
    for p2g in [P2gAtomics::Fixed, P2gAtomics::Float] {
        if !support::gpu::ready(p2g) {
            continue;
        }
        let (world, heights, force) = drop_onto_tissue(BackendChoice::Gpu, p2g, 1.0);
        let gpu = check_rest(&format!("gpu {p2g:?}"), &world, &heights, force);
        // The same law on both backends: they differ only in the order atomics sum the
        // contact's momentum.
        assert!(
            (gpu - cpu).abs() < 0.1 * DX,
            "gpu {p2g:?} rests at {gpu}, cpu at {cpu}"
        );
    }
}

/// Two grippers pointing down over the needle, their jaws 20° open: [`FIRST`], then `second`
/// closes on it at the arc's start (0°) from 0.75 s, `first` opens at 1.05 s, `second`
/// carries it 4 mm along −x over 1.15–1.35 s and opens at 1.4 s. Jaws close at the
/// controller's effort limit, about 0.2 s from 20°.
fn handover() -> String {
    format!("{FIRST}{SECOND}")
}

/// A gripper pointing down over the needle, its jaws 20° open, that closes on the wire at
/// the arc's top (90°) from 0.05 s, lifts it 10 mm over 0.4–0.7 s and opens at 1.05 s.
const FIRST: &str = r#"
[[tool]]
name = "first"
shape = { type = "gripper", jaw_length = 0.008, jaw_width = 0.006, jaw_thickness = 0.004 }
[[tool.keyframe]]
t = 0.0
position = [0.0, 0.005, 0.034]
rpy_deg = [180.0, 0.0, 0.0]
jaw_deg = 20.0
[[tool.keyframe]]
t = 0.05
position = [0.0, 0.005, 0.034]
rpy_deg = [180.0, 0.0, 0.0]
jaw_deg = 20.0
[[tool.keyframe]]
t = 0.1
position = [0.0, 0.005, 0.034]
rpy_deg = [180.0, 0.0, 0.0]
jaw_deg = -20.0
[[tool.keyframe]]
t = 0.4
position = [0.0, 0.005, 0.034]
rpy_deg = [180.0, 0.0, 0.0]
jaw_deg = -20.0
[[tool.keyframe]]
t = 0.7
position = [0.0, 0.005, 0.044]
rpy_deg = [180.0, 0.0, 0.0]
jaw_deg = -20.0
[[tool.keyframe]]
t = 1.05
position = [0.0, 0.005, 0.044]
rpy_deg = [180.0, 0.0, 0.0]
jaw_deg = -20.0
[[tool.keyframe]]
t = 1.1
position = [0.0, 0.005, 0.044]
rpy_deg = [180.0, 0.0, 0.0]
jaw_deg = 40.0
"#;

const SECOND: &str = r#"
[[tool]]
name = "second"
shape = { type = "gripper", jaw_length = 0.008, jaw_width = 0.006, jaw_thickness = 0.004 }
[[tool.keyframe]]
t = 0.0
position = [0.01, -0.005, 0.044]
rpy_deg = [180.0, 0.0, 90.0]
jaw_deg = 20.0
[[tool.keyframe]]
t = 0.75
position = [0.01, -0.005, 0.044]
rpy_deg = [180.0, 0.0, 90.0]
jaw_deg = 20.0
[[tool.keyframe]]
t = 0.8
position = [0.01, -0.005, 0.044]
rpy_deg = [180.0, 0.0, 90.0]
jaw_deg = -20.0
[[tool.keyframe]]
t = 1.15
position = [0.01, -0.005, 0.044]
rpy_deg = [180.0, 0.0, 90.0]
jaw_deg = -20.0
[[tool.keyframe]]
t = 1.35
position = [0.006, -0.005, 0.044]
rpy_deg = [180.0, 0.0, 90.0]
jaw_deg = -20.0
[[tool.keyframe]]
t = 1.4
position = [0.006, -0.005, 0.044]
rpy_deg = [180.0, 0.0, 90.0]
jaw_deg = -20.0
[[tool.keyframe]]
t = 1.45
position = [0.006, -0.005, 0.044]
rpy_deg = [180.0, 0.0, 90.0]
jaw_deg = 40.0
"#;

#[test]
fn a_gripper_closing_on_the_needle_carries_it_a_second_takes_it_over_and_opening_drops_it() {
    let mut world = World::new(&scene(None, &handover()));
    let held_by = |world: &World| world.tools()[0].needle().unwrap().carrier().clone();
    let step_to = |world: &mut World, t: f64| {
        while world.time() < t - 1e-9 {
            world.step_frame().expect("frame");
        }
    };
    let needle = |world: &World| world.tools()[0].pose_at(world.time()).position;
    step_to(&mut world, 0.05);
    assert_eq!(held_by(&world), Carrier::Driver);
    // The first gripper closes and lifts 10 mm: the needle rises with it.
    step_to(&mut world, 0.75);
    assert!(matches!(held_by(&world), Carrier::Gripper { tool: 1, .. }));
    let lifted = needle(&world);
    println!("lifted by the first gripper to {:.2} mm", lifted.z * 1e3);
    assert!((lifted.z - (HELD_Z + 0.01)).abs() < 1e-9, "{lifted}");
    // The second closes on it and takes it; the first opening then drops nothing.
    step_to(&mut world, 1.25);
    assert!(matches!(held_by(&world), Carrier::Gripper { tool: 2, .. }));
    let halfway = needle(&world);
    assert!((halfway.x - (lifted.x - 0.002)).abs() < 1e-9, "{halfway}");
    step_to(&mut world, 1.4);
    let carried = needle(&world);
    println!(
        "carried by the second gripper to x {:.2} mm",
        carried.x * 1e3
    );
    assert!((carried.x - (lifted.x - 0.004)).abs() < 1e-9, "{carried}");
    assert!((carried.z - lifted.z).abs() < 1e-9, "{carried}");
    // Opened: it falls onto the tissue and rests there.
    step_to(&mut world, 2.4);
    assert_eq!(held_by(&world), Carrier::Free);
    let rest = needle(&world);
    println!("dropped: rests at {:.2} mm", rest.z * 1e3);
    assert!(
        rest.z > TISSUE_TOP && rest.z < TISSUE_TOP + 2.0 * DX,
        "{rest}"
    );
    assert!(world.tools()[0].needle().unwrap().velocity().norm() < 0.005);
}

/// The needle driver's keyframes after its first (holding the needle at rest): it opens
/// at 0.3–0.35 s, once [`FIRST`] holds the needle, follows it up 10 mm over 0.4–0.7 s, closes
/// on it at 0.8–0.85 s, carries it 4 mm along +x over 1.1–1.3 s and opens at 1.4–1.45 s.
const DRIVER_TAKES_IT_BACK: &str = r#"
[[tool.keyframe]]
t = 0.3
position = [0.0, -0.005, 0.03]
[[tool.keyframe]]
t = 0.35
position = [0.0, -0.005, 0.03]
jaw_deg = 30.0
[[tool.keyframe]]
t = 0.4
position = [0.0, -0.005, 0.03]
jaw_deg = 30.0
[[tool.keyframe]]
t = 0.7
position = [0.0, -0.005, 0.04]
jaw_deg = 30.0
[[tool.keyframe]]
t = 0.8
position = [0.0, -0.005, 0.04]
jaw_deg = 30.0
[[tool.keyframe]]
t = 0.85
position = [0.0, -0.005, 0.04]
[[tool.keyframe]]
t = 1.1
position = [0.0, -0.005, 0.04]
[[tool.keyframe]]
t = 1.3
position = [0.004, -0.005, 0.04]
[[tool.keyframe]]
t = 1.4
position = [0.004, -0.005, 0.04]
[[tool.keyframe]]
t = 1.45
position = [0.004, -0.005, 0.04]
jaw_deg = 30.0
"#;

/// The needle driver hands the needle to a gripper, opens, follows it, closes on it and
/// takes it back: the gripper opening then drops nothing, the driver carries it, and opened
/// again it lets it fall onto the tissue.
#[test]
fn the_driver_closing_on_the_needle_a_gripper_holds_takes_it_back() {
    let mut world = World::new(&scene(None, &format!("{DRIVER_TAKES_IT_BACK}{FIRST}")));
    let held_by = |world: &World| world.tools()[0].needle().unwrap().carrier().clone();
    let step_to = |world: &mut World, t: f64| {
        while world.time() < t - 1e-9 {
            world.step_frame().expect("frame");
        }
    };
    let needle = |world: &World| world.tools()[0].pose_at(world.time()).position;
    step_to(&mut world, 0.75);
    assert!(matches!(held_by(&world), Carrier::Gripper { tool: 1, .. }));
    assert!((needle(&world).z - (HELD_Z + 0.01)).abs() < 1e-9);
    // Closed on the needle where the gripper holds it: the driver has it again.
    step_to(&mut world, 0.9);
    assert_eq!(held_by(&world), Carrier::Driver);
    // The gripper opens; the driver carries it 4 mm along +x.
    step_to(&mut world, 1.35);
    assert_eq!(held_by(&world), Carrier::Driver);
    let carried = needle(&world);
    println!(
        "taken back by the driver and carried to x {:.2} mm",
        carried.x * 1e3
    );
    assert!((carried.x - 0.004).abs() < 1e-9, "{carried}");
    assert!((carried.z - (HELD_Z + 0.01)).abs() < 1e-9, "{carried}");
    // Opened: it falls onto the tissue.
    step_to(&mut world, 2.3);
    assert_eq!(held_by(&world), Carrier::Free);
    let rest = needle(&world);
    println!("let go again: rests at {:.2} mm", rest.z * 1e3);
    assert!(
        rest.z > TISSUE_TOP && rest.z < TISSUE_TOP + 2.0 * DX,
        "{rest}"
    );
}

/// While the needle is free the tissue steps one backend frame per substep; a guard event's
/// restore still puts the tissue back to where the world's frame started (not to the start
/// of its last substep), on the CPU and the GPU.
#[test]
fn a_frame_stepped_by_substep_restores_to_its_start() {
    for backend in [BackendChoice::Cpu, BackendChoice::Gpu] {
        let mut scene = scene(Some(0.1), "");
        scene.solver.backend = backend;
        scene.solver.p2g_atomics = P2gAtomics::Fixed;
        let mut world = World::new(&scene);
        while world.time() < 0.15 {
            world.step_frame().expect("frame");
        }
        let needle = world.tools()[0].needle().expect("a needle");
        assert_eq!(*needle.carrier(), Carrier::Free, "{backend:?}: let go");
        let start = world.particles().x.clone();
        world.step_frame().expect("frame");
        let moved = (world.particles().x.iter().zip(&start))
            .map(|(a, b)| (a - b).norm())
            .fold(0.0f32, f32::max);
        world.backend_mut().restore_frame_start();
        let restored = (world.particles().x.iter().zip(&start))
            .map(|(a, b)| (a - b).norm())
            .fold(0.0f32, f32::max);
        println!("{backend:?}: the frame moved particles up to {moved:.2e} m, restored to {restored:.1e} m");
        assert!(moved > 0.0, "{backend:?}: the tissue moved over the frame");
        assert_eq!(restored, 0.0, "{backend:?}: restored to the frame's start");
    }
}
