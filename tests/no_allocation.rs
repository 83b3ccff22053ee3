//! A substep allocates nothing: buffers are sized when the solver is built.

use dvrk_tissue_sim::config::builders::seed000_scene;
use dvrk_tissue_sim::mpm::backend::{Backend, BackendChoice};
use dvrk_tissue_sim::mpm::cpu::SubstepInput;
use dvrk_tissue_sim::mpm::{Method, PbMpmParams, SolverKind};
use dvrk_tissue_sim::tools::{ToolKinematics, ToolVelocity};
use dvrk_tissue_sim::world::World;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

struct CountingAllocator;
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

/// Steps the seed-000 scene (with `method`) until the gripper touches the tissue, then runs
/// `substeps` substeps of `dt` by hand on a pool thread, as `World::step_frame` does; returns
/// the solver kind, the contact nodes summed over them and the allocations they made.
fn allocations_in_contact(method: Method, dt: f32, substeps: u32) -> (SolverKind, u32, usize) {
    // The count is process-wide: one measurement at a time, none beside another test's setup.
    let _alone = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let mut scene = seed000_scene();
    scene.solver.backend = BackendChoice::Cpu;
    scene.solver.method = method;
    let mut world = World::new(&scene);
    while world.time() < 0.15 {
        world.step_frame().unwrap();
    }
    let tool = &world.tools()[0];
    let pose = tool.pose_at(world.time());
    let kinematics = [ToolKinematics::new(
        tool.shape,
        tool.contact,
        &pose,
        &ToolVelocity::default(),
        scene.domain.dx as f32,
    )];
    let input = SubstepInput {
        dt,
        gravity: nalgebra::Vector3::new(0.0, 0.0, -9.81),
        tools: &kinematics,
    };
    let Backend::Cpu(cpu) = world.backend_mut() else {
        unreachable!("the scene asks for the CPU backend")
    };
    let solver = &mut cpu.solver;
    let kind = solver.kind;
    let (contacts, allocations) = rayon::scope(|_| {
        solver.substep(&input);
        let before = ALLOCATIONS.load(Ordering::SeqCst);
        let mut contacts = 0;
        for _ in 0..substeps {
            contacts += solver.substep(&input).tool_impulses[0].contact_nodes;
        }
        (contacts, ALLOCATIONS.load(Ordering::SeqCst) - before)
    });
    (kind, contacts, allocations)
}

#[test]
fn substeps_do_not_allocate() {
    let (kind, contacts, allocations) = allocations_in_contact(Method::MlsMpm, 1e-4, 50);
    assert_eq!(kind, SolverKind::MlsMpm);
    assert!(contacts > 0, "the gripper should be in contact");
    assert_eq!(allocations, 0, "50 substeps allocated {allocations} times");
}

#[test]
fn pb_mpm_substeps_do_not_allocate() {
    let (kind, contacts, allocations) = allocations_in_contact(Method::PbMpm, 1.0 / 240.0, 10);
    assert_eq!(
        kind,
        SolverKind::PbMpm(PbMpmParams {
            iterations: 5,
            relaxation: 1.5
        })
    );
    assert!(contacts > 0, "the gripper should be in contact");
    assert_eq!(allocations, 0, "10 substeps allocated {allocations} times");
}
