//! PB-MPM behaviour on the CPU: large steps stay stable, tools feel physical forces,
//! momentum is conserved.

use dvrk_tissue_sim::config::builders::*;
use dvrk_tissue_sim::config::{Hold, Scene, Table};
use dvrk_tissue_sim::math::Vec3;
use dvrk_tissue_sim::mpm::backend::BackendChoice;
use dvrk_tissue_sim::mpm::{timestep, Lame, Method};
use dvrk_tissue_sim::tools::{ContactModel, Shape};
use dvrk_tissue_sim::world::World;

fn pb(mut scene: Scene) -> Scene {
    scene.solver.method = Method::PbMpm;
    scene.solver.backend = BackendChoice::Cpu;
    scene
}

const TABLE: f64 = 0.002;
const NU: f64 = 0.45;

/// A 10 × 8 × 6 mm block of soft tissue resting on a table, optionally pressed by a flat
/// box that descends `press` metres between 0.1 s and 0.4 s and then holds.
fn block_scene(press: f64) -> Scene {
    let top = TABLE + 0.006;
    let half = [0.008f32, 0.008, 0.002];
    let start = top + half[2] as f64 + 0.0005;
    let tools = if press > 0.0 {
        vec![tool(
            "press",
            Shape::Box { half_extents: half },
            ContactModel::Sticky,
            vec![
                key(0.0, [0.0, 0.0, start], [0.0; 3], 0.0),
                key(0.1, [0.0, 0.0, start], [0.0; 3], 0.0),
                key(0.4, [0.0, 0.0, start - press], [0.0; 3], 0.0),
            ],
        )]
    } else {
        vec![]
    };
    pb(scene(
        "pb-block",
        60.0,
        domain(
            [-0.016, -0.016, 0.0],
            [0.032, 0.032, 0.024],
            0.001,
            [0.0, 0.0, -9.81],
        ),
        Some(Table {
            height: TABLE,
            hold: Hold::Resting,
            friction: 0.5,
        }),
        vec![tissue(
            [0.0, 0.0, TABLE + 0.003],
            [0.010, 0.008, 0.006],
            material(5000.0, NU, 1000.0, 2.0),
        )],
        tools,
    ))
}

#[test]
fn block_settles_on_the_table_at_steps_far_above_the_mls_bound() {
    let scene = block_scene(0.0);
    let mls_bound = timestep::stable_dt(
        scene.solver.cfl,
        scene.domain.dx,
        Lame::from_young_poisson(5000.0, NU).p_wave_speed(1000.0),
        0.0,
    );
    let mut world = World::new(&scene);
    let z0 = world.particles().centre_of_mass().z;
    let mut dt_max: f64 = 0.0;
    while world.time() < 1.0 {
        let r = world.step_frame().unwrap();
        dt_max = dt_max.max(r.dt_max);
    }
    println!(
        "PB-MPM dt {dt_max:e} s, MLS-MPM bound {mls_bound:e} s ({:.0}×)",
        dt_max / mls_bound
    );
    assert!(dt_max > 30.0 * mls_bound, "dt {dt_max} vs {mls_bound}");
    let p = world.particles();
    assert!(p.x.iter().all(|x| x.iter().all(|c| c.is_finite())));
    let sag = z0 - p.centre_of_mass().z;
    let lowest = p.x.iter().map(|x| x.z).fold(f32::INFINITY, f32::min) as f64;
    let ke = p.kinetic_energy();
    println!("sag {sag:e} m, lowest particle {lowest} m, kinetic energy {ke:e} J");
    // Measured 0.64 mm (linear elasticity: 0.02 mm): at this step PB-MPM is far softer
    // than E says (see `mpm::cpu::pbmpm`), but it settles and holds.
    assert!(sag > 0.0 && sag < 0.001, "centre of mass sank {sag} m");
    assert!(
        lowest > TABLE - 0.0005,
        "particle below the table: {lowest}"
    );
    // At rest: kinetic energy far below what a fall of 0.1 mm would give.
    let mass = p.total_mass();
    assert!(ke < 0.01 * mass * 9.81 * 1e-4, "kinetic energy {ke} J");
}

#[test]
fn pressing_tool_feels_a_force_opposing_the_press() {
    let mut world = World::new(&block_scene(0.0015));
    let mut held = Vec::new();
    while world.time() < 0.8 {
        let r = world.step_frame().unwrap();
        assert!(r.wrenches[0].force.iter().all(|f| f.is_finite()));
        if world.time() > 0.6 {
            held.push(r.wrenches[0].force);
        }
    }
    let f = held.iter().sum::<nalgebra::Vector3<f64>>() / held.len() as f64;
    println!("force on the pressing tool while held: {f:?} N");
    // Pressed down, the tool is pushed up; the press is symmetric, so no side force.
    assert!(f.z > 0.0, "{f:?}");
    assert!(f.x.abs() + f.y.abs() < 0.1 * f.z, "{f:?}");
    let p = world.particles();
    assert!(p.x.iter().all(|x| x.iter().all(|c| c.is_finite())));
}

#[test]
fn block_resting_on_a_tool_loads_it_with_its_weight() {
    // The table replaced by a fixed slab tool: the impulses the tool takes, summed over the
    // constraint iterations, must add up to the weight it carries.
    let mut scene = block_scene(0.0);
    scene.table = None;
    scene.tools = vec![tool(
        "slab",
        Shape::Box {
            half_extents: [0.012, 0.012, 0.002],
        },
        ContactModel::Coulomb {
            friction: 0.5,
            drag: 0.0,
        },
        vec![key(0.0, [0.0, 0.0, TABLE - 0.002], [0.0; 3], 0.0)],
    )];
    let mut world = World::new(&scene);
    let weight = world.particles().total_mass() * 9.81;
    let mut forces = Vec::new();
    while world.time() < 1.0 {
        let r = world.step_frame().unwrap();
        if world.time() > 0.7 {
            forces.push(r.wrenches[0].force);
        }
    }
    let f = forces.iter().sum::<nalgebra::Vector3<f64>>() / forces.len() as f64;
    println!("force on the slab {f:?} N, tissue weight {weight} N");
    assert!((f.z + weight).abs() < 0.02 * weight, "{f:?} vs {weight}");
    assert!(f.x.abs() + f.y.abs() < 0.02 * weight, "{f:?}");
}

#[test]
fn free_flying_block_conserves_momentum() {
    let mut scene = block_scene(0.0);
    scene.table = None;
    scene.domain.gravity = [0.0; 3];
    scene.tissues[0].center = [0.0, 0.0, 0.012];
    let mut world = World::new(&scene);
    let p = world.particles_mut();
    for (x, v) in p.x.iter().zip(p.v.iter_mut()) {
        let r = x - Vec3::new(0.0, 0.0, 0.012);
        *v = Vec3::new(0.02, -0.01, 0.005)
            + Vec3::new(0.0, 0.0, 3.0).cross(&r)
            + Vec3::new(-2.0 * r.x, 0.0, 0.0);
    }
    let p0 = world.particles().momentum();
    for _ in 0..6 {
        world.step_frame().unwrap();
    }
    let p1 = world.particles().momentum();
    // Damping (2 /s) takes its share: v /(1 + α dt) per substep.
    let steps = (world.time() / dvrk_tissue_sim::config::PB_MPM_DEFAULT_DT).round() as i32;
    let damped = p0 / (1.0 + 2.0 * dvrk_tissue_sim::config::PB_MPM_DEFAULT_DT).powi(steps);
    let drift = (p1 - damped).norm() / p0.norm();
    assert!(
        drift < 1e-4,
        "momentum drift {drift:e}: {damped:?} → {p1:?}"
    );
}
