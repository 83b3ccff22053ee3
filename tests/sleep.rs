//! Resting tissue sleeps while no tool can reach it and never misses a contact: a run with
//! sleep on sees the same contacts at the same frames as a run with sleep off.

use dvrk_tissue_sim::config::builders::*;
use dvrk_tissue_sim::config::Scene;
use dvrk_tissue_sim::mpm::backend::BackendChoice;
use dvrk_tissue_sim::tools::{ContactModel, Shape};
use dvrk_tissue_sim::world::{FrameReport, World};

/// A liver block bonded to the table settles; at 1.0 s a sphere starts down from 14 mm above
/// it and presses 1 mm in by 1.5 s.
fn resting_then_probed(sleep: bool) -> Scene {
    let mut s = scene(
        "rest then probe",
        60.0,
        domain(
            [-0.016, -0.016, 0.0],
            [0.032, 0.032, 0.048],
            0.002,
            [0.0, 0.0, -9.81],
        ),
        Some(bonded_table(0.004)),
        vec![tissue(
            [0.0, 0.0, 0.008],
            [0.016, 0.016, 0.008],
            material(5400.0, 0.45, 1060.0, 2.0),
        )],
        vec![tool(
            "probe",
            Shape::Sphere { radius: 0.004 },
            ContactModel::default(),
            vec![
                key(0.0, [0.0, 0.0, 0.03], [0.0; 3], 0.0),
                key(1.0, [0.0, 0.0, 0.03], [0.0; 3], 0.0),
                key(1.5, [0.0, 0.0, 0.015], [0.0; 3], 0.0),
            ],
        )],
    );
    s.solver.backend = BackendChoice::Cpu;
    s.sleep.enabled = sleep;
    s.sleep.after_frames = 10;
    s
}

fn run(scene: &Scene, seconds: f64) -> (Vec<FrameReport>, World) {
    let mut world = World::new(scene);
    let mut reports = Vec::new();
    while world.time() < seconds - 1e-9 {
        reports.push(world.step_frame().unwrap());
    }
    (reports, world)
}

#[test]
fn sleeping_tissue_wakes_before_every_contact() {
    let (awake, _) = run(&resting_then_probed(false), 1.8);
    let (sleepy, world) = run(&resting_then_probed(true), 1.8);
    assert_eq!(awake.len(), sleepy.len());
    assert!(awake.iter().all(|r| !r.asleep));
    let asleep = sleepy.iter().filter(|r| r.asleep).count();
    assert!(asleep >= 20, "only {asleep} frames asleep");
    let first_contact = awake
        .iter()
        .position(|r| r.contact_nodes[0] > 0)
        .expect("the probe touches the tissue");
    // Every frame with contact in the awake run was stepped, with contact, in the other.
    for (i, (a, s)) in awake.iter().zip(&sleepy).enumerate() {
        if a.contact_nodes[0] > 0 {
            assert!(
                !s.asleep,
                "frame {i} skipped while the probe touched the tissue"
            );
            assert!(s.contact_nodes[0] > 0, "frame {i}: contact missed");
        }
    }
    // The tissue woke before the probe could touch it, not at the contact itself.
    assert!(!sleepy[first_contact - 1].asleep);
    // Force after contact matches the run that never slept (the sleeping tissue was frozen
    // with particle speeds under 0.1 mm/s).
    let peak = awake
        .iter()
        .map(|r| r.wrenches[0].force.norm())
        .fold(0.0, f64::max);
    assert!(peak > 1e-3, "peak force {peak} N");
    let last = awake.len() - 1;
    let diff = (awake[last].wrenches[0].force - sleepy[last].wrenches[0].force).norm();
    assert!(diff < 0.05 * peak, "force differs by {diff} N of {peak} N");
    assert!(!world.is_asleep());
}

#[test]
fn skipped_frames_leave_the_tissue_untouched() {
    let scene = resting_then_probed(true);
    let mut world = World::new(&scene);
    while !world.is_asleep() {
        world.step_frame().unwrap();
        assert!(
            world.time() < 1.0,
            "never fell asleep before the probe moved"
        );
    }
    let before = world.particles().x.clone();
    let report = world.step_frame().unwrap();
    assert!(report.asleep && report.substeps == 0);
    assert_eq!(report.wrenches[0].force.norm(), 0.0);
    assert_eq!(world.particles().x, before);
    // Editing particles wakes the tissue.
    world.particles_mut().v[0].z = 0.01;
    assert!(!world.is_asleep());
    assert!(!world.step_frame().unwrap().asleep);
}

/// Work follows the tissue, not the domain: the same tissue in a domain 4× larger along
/// each axis touches exactly as many grid blocks per substep.
#[test]
fn a_larger_domain_adds_no_grid_work() {
    let active_blocks = |scale: f64| {
        let mut scene = resting_then_probed(false);
        for a in 0..3 {
            scene.domain.origin[a] *= scale;
            scene.domain.size[a] *= scale;
        }
        let mut world = World::new(&scene);
        world.step_frame().unwrap();
        match world.backend() {
            dvrk_tissue_sim::mpm::backend::Backend::Cpu(c) => {
                (c.solver.active_blocks(), world.layout().node_count())
            }
            _ => unreachable!("the scene asks for the CPU backend"),
        }
    };
    let (small_blocks, small_nodes) = active_blocks(1.0);
    let (large_blocks, large_nodes) = active_blocks(4.0);
    assert!(
        large_nodes > 40 * small_nodes,
        "{large_nodes} vs {small_nodes}"
    );
    assert_eq!(small_blocks, large_blocks);
}

/// A thread hanging well above resting tissue lets it sleep; lowered onto it, the thread
/// wakes the tissue before it can touch it, and every frame in which it could touch is
/// stepped.
#[test]
fn a_thread_wakes_sleeping_tissue_before_it_touches() {
    const TISSUE_TOP: f32 = 0.012;
    const HANG: f32 = 0.026;
    let mut scene = resting_then_probed(true);
    scene.tools.clear();
    let mut thread = dvrk_tissue_sim::config::Thread::nylon_3_0([-0.012, 0.0, HANG as f64]);
    thread.length = 0.024;
    thread.segments = 12;
    thread.pinned = dvrk_tissue_sim::config::PinnedEnds::Both;
    scene.threads.push(thread);
    let mut world = World::new(&scene);
    let mut asleep_hanging = 0;
    for _ in 0..90 {
        asleep_hanging += world.step_frame().unwrap().asleep as usize;
    }
    assert!(
        asleep_hanging >= 20,
        "a thread far above the tissue kept it awake: {asleep_hanging} of 90 frames asleep"
    );

    // A gripper pulling the thread drags its points as far as the gripper travels: the
    // thread's reach over the frame grows by that travel on every side.
    let (frame_dt, gravity, reach_cell) = (1.0 / 60.0, 9.81, 0.002);
    let still = world.threads()[0].reach_over(frame_dt, gravity, reach_cell, 0.0);
    let pulled = world.threads()[0].reach_over(frame_dt, gravity, reach_cell, 0.01);
    for axis in 0..3 {
        assert!((still.min[axis] - pulled.min[axis] - 0.01).abs() < 1e-6);
        assert!((pulled.max[axis] - still.max[axis] - 0.01).abs() < 1e-6);
    }

    // Lower both held ends at 30 mm/s until the thread is 2 mm into the tissue.
    let last = world.threads()[0].rod.points.len() - 1;
    let ends = [
        world.threads()[0].rod.points[0],
        world.threads()[0].rod.points[last],
    ];
    let frame_dt = 1.0 / 60.0;
    let step = 0.0005;
    let (dx, radius) = (0.002, world.threads()[0].rod.material.radius);
    let mut stepped_near = 0;
    for frame in 1..=32 {
        let lowest = world.threads()[0]
            .rod
            .points
            .iter()
            .map(|p| p.z)
            .fold(f32::MAX, f32::min);
        let down = nalgebra::Vector3::new(0.0, 0.0, -step * frame as f32);
        let thread = &mut world.threads_mut()[0];
        assert!(thread.move_anchor(0, ends[0] + down));
        assert!(thread.move_anchor(last, ends[1] + down));
        let report = world.step_frame().unwrap();
        // Within reach of the tissue during this frame: its contact capsule (radius + dx)
        // plus what the thread travels in the frame (30 mm/s, and its sag settling).
        if lowest - TISSUE_TOP <= radius + dx + 2.0 * 0.03 * frame_dt {
            assert!(
                !report.asleep,
                "frame {frame} skipped with the thread {:.2} mm above the tissue",
                (lowest - TISSUE_TOP) * 1e3
            );
            stepped_near += 1;
        }
    }
    assert!(stepped_near >= 5, "the thread never neared the tissue");
    assert!(world.threads()[0]
        .rod
        .points
        .iter()
        .all(|p| p.iter().all(|c| c.is_finite())));
}
