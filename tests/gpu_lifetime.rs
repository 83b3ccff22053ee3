//! GPU worlds built and dropped one after another in one process, as `bench` builds one per
//! row: each world must open its device on the process's one wgpu instance and free the
//! device, its buffers and everything made from it when dropped, leaving the process's
//! threads and file descriptors as they were. An instance per world once made the 31st world
//! of a `bench --backends gpu` process on an H100 find no adapter at all.
//!
//! Without any GPU adapter the test fails when `CI` is set and is skipped (with the reason
//! printed) otherwise; on a plain CI machine Mesa's llvmpipe (software Vulkan) is the adapter.

use dvrk_tissue_sim::config::{Hold, Scene, Table};
use dvrk_tissue_sim::mpm::backend::{BackendChoice, P2gAtomics};
use dvrk_tissue_sim::mpm::gpu::adapter;
use dvrk_tissue_sim::mpm::Method;
use dvrk_tissue_sim::world::World;
use std::time::Instant;

mod support;

/// Worlds built, stepped and dropped after the warm-up.
const CYCLES: usize = 30;
/// Every `IMPLICIT_EVERY`th of them solves implicitly (where the adapter has f32 atomics).
const IMPLICIT_EVERY: usize = 5;

/// `support::scenes::small_block` of 5 kPa on a bonded table, on the GPU.
fn block(method: Method) -> Scene {
    let table = Table {
        height: 0.002,
        hold: Hold::Bonded,
        friction: 0.5,
    };
    let mut s = support::scenes::small_block("lifetime-block", 5000.0, table, vec![]);
    s.solver.method = method;
    s.solver.backend = BackendChoice::Gpu;
    s
}

/// What the process holds: wgpu objects alive on the process's instance, threads, open file
/// descriptors, and (printed only) resident memory.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Held {
    adapters: usize,
    devices: usize,
    queues: usize,
    buffers: usize,
    bind_groups: usize,
    pipelines: usize,
    threads: u64,
    fds: usize,
}

/// A field of /proc/self/status (the number before any unit).
fn proc_status(key: &str) -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    status
        .lines()
        .find_map(|l| l.strip_prefix(key))
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no {key} in /proc/self/status"))
}

fn held() -> Held {
    let report = adapter::instance()
        .generate_report()
        .expect("the native wgpu instance reports its objects");
    let hub = &report.hub;
    Held {
        adapters: hub.adapters.num_kept_from_user,
        devices: hub.devices.num_kept_from_user,
        queues: hub.queues.num_kept_from_user,
        buffers: hub.buffers.num_kept_from_user,
        bind_groups: hub.bind_groups.num_kept_from_user,
        pipelines: hub.compute_pipelines.num_kept_from_user,
        threads: proc_status("Threads:"),
        fds: std::fs::read_dir("/proc/self/fd").unwrap().count(),
    }
}

/// Builds a world of `scene`, checks that it holds one device more than `before`, steps it
/// two frames and drops it.
fn cycle(scene: &Scene, before: &Held) {
    let mut world = World::new(scene);
    assert_ne!(world.backend().name(), "cpu");
    let alive = held();
    assert_eq!(
        (alive.devices, alive.queues),
        (before.devices + 1, before.queues + 1),
        "a live GPU world holds one device and queue on the process's wgpu instance"
    );
    assert!(alive.buffers > before.buffers);
    world.step_frame().unwrap();
    world.step_frame().unwrap();
}

#[test]
fn gpu_worlds_built_and_dropped_free_their_device_buffers_and_threads() {
    if !support::gpu::ready(P2gAtomics::Fixed) {
        return;
    }
    // The GPU refuses implicit worlds without f32 atomics.
    let implicit = support::gpu::ready(P2gAtomics::Float);
    if !implicit {
        println!("adapter without f32 atomics: implicit worlds left out (the GPU refuses them)");
    }
    let explicit_scene = block(Method::MlsMpm);
    let implicit_scene = block(Method::Implicit);
    let scene_of = |i: usize| {
        if implicit && i.is_multiple_of(IMPLICIT_EVERY) {
            &implicit_scene
        } else {
            &explicit_scene
        }
    };

    // A warm-up world of each kind: the driver starts its threads and the allocator its
    // arenas once, and those stay.
    let start = held();
    cycle(scene_of(0), &start);
    cycle(scene_of(1), &start);
    let base = held();
    println!(
        "before: {start:?}\nafter the warm-up: {base:?}, RSS {} kB",
        proc_status("VmRSS:")
    );

    let t = Instant::now();
    for i in 0..CYCLES {
        cycle(scene_of(i), &base);
        let now = held();
        if i % 10 == 9 {
            println!(
                "after {} worlds: {now:?}, RSS {} kB",
                i + 1,
                proc_status("VmRSS:")
            );
        }
        // The wgpu objects must all be gone again (adapters included: each world's
        // enumeration makes them afresh), and nothing of the driver's may pile up.
        assert_eq!(
            Held {
                threads: base.threads,
                fds: base.fds,
                ..now
            },
            base,
            "world {i} left wgpu objects behind"
        );
        assert!(
            now.threads <= base.threads && now.fds <= base.fds,
            "world {i} left threads or file descriptors behind: {now:?} against {base:?}"
        );
    }
    println!("{CYCLES} worlds in {:.1} s", t.elapsed().as_secs_f64());
}
