//! The implicit (backward-Euler Newton–CG) method: accuracy on the analytic scenes against
//! explicit MLS-MPM at the same resolution, frame-long steps, tools as constraints.

use dvrk_tissue_sim::config::Scene;
use dvrk_tissue_sim::mpm::backend::BackendChoice;
use dvrk_tissue_sim::mpm::Method;
use dvrk_tissue_sim::validation::analytic::{
    bar_run, bar_scene, hertz_run, hertz_scene, stretch_run, stretch_scene,
};
use dvrk_tissue_sim::validation::meter::Meter;

fn with(mut scene: Scene, method: Method) -> Scene {
    scene.solver.method = method;
    scene.solver.backend = BackendChoice::Cpu;
    scene
}

/// Implicit error within 1.5× of explicit MLS-MPM's (plus half a percent for errors that
/// are both near zero).
fn assert_within(name: &str, explicit: f64, implicit: f64) {
    println!("{name}: explicit {explicit:+.4}, implicit {implicit:+.4}");
    assert!(implicit.is_finite(), "{name}: no measurement");
    assert!(
        implicit.abs() <= 1.5 * explicit.abs() + 0.005,
        "{name}: implicit {implicit:+.4} against explicit {explicit:+.4}"
    );
}

#[test]
fn bar_period_within_explicit_error() {
    let (scene, _, _) = bar_scene(4);
    let mut m_exp = Meter::default();
    let mut m_imp = Meter::default();
    let exp = bar_run(4, &with(scene.clone(), Method::MlsMpm), &mut m_exp);
    let imp = bar_run(4, &with(scene, Method::Implicit), &mut m_imp);
    println!(
        "implicit: {} substeps, {} Newton, {} CG; explicit {} substeps",
        m_imp.substeps, m_imp.newton, m_imp.cg, m_exp.substeps
    );
    println!(
        "amplitude kept per period: explicit {:.4}, implicit {:.4}",
        exp.amplitude_per_period, imp.amplitude_per_period
    );
    assert!(m_imp.newton > 0, "the implicit solver ran");
    assert_within("bar period", exp.relative_error(), imp.relative_error());
    // Backward Euler damps: at a step of a hundredth of the period (ωdt = 0.063) each step
    // keeps 1/√(1 + (ωdt)²) of the amplitude, 82 % a period; APIC alone loses little.
    assert!(
        imp.amplitude_per_period < exp.amplitude_per_period,
        "implicit Euler must damp more than explicit"
    );
    assert!(
        imp.amplitude_per_period > 0.6 && imp.amplitude_per_period < 0.95,
        "implicit damping {:.4} far from backward Euler's 0.82",
        imp.amplitude_per_period
    );
}

#[test]
fn stretch_force_within_explicit_error() {
    let (scene, _, _) = stretch_scene(4, 1.3);
    let exp = stretch_run(
        4,
        1.3,
        &with(scene.clone(), Method::MlsMpm),
        &mut Meter::default(),
    );
    let mut meter = Meter::default();
    let imp = stretch_run(4, 1.3, &with(scene, Method::Implicit), &mut meter);
    println!(
        "implicit: {} substeps, {} Newton, {} CG",
        meter.substeps, meter.newton, meter.cg
    );
    assert_within("stretch force", exp.relative_error(), imp.relative_error());
}

#[test]
fn hertz_force_within_explicit_error() {
    let (scene, _, _) = hertz_scene(3.0);
    let exp = hertz_run(
        3.0,
        &with(scene.clone(), Method::MlsMpm),
        &mut Meter::default(),
    );
    let mut meter = Meter::default();
    let imp = hertz_run(3.0, &with(scene, Method::Implicit), &mut meter);
    println!(
        "implicit: {} substeps, {} Newton, {} CG",
        meter.substeps, meter.newton, meter.cg
    );
    assert!(imp.samples.len() > 20);
    assert_within(
        "Hertz RMS force",
        exp.rms_relative_error(),
        imp.rms_relative_error(),
    );
}

/// A 6 × 6 × 4 mm block of 50 kPa (dx 1 mm) resting on a table of friction `mu`, under
/// gravity tilted by `degrees` about y: the table is an incline.
fn block_on_an_incline(mu: f64, degrees: f64) -> Scene {
    use dvrk_tissue_sim::config::builders::*;
    use dvrk_tissue_sim::config::{Hold, Table};
    let (s, c) = degrees.to_radians().sin_cos();
    let mut scene = scene(
        "incline",
        60.0,
        domain(
            [-0.012, -0.008, 0.0],
            [0.080, 0.016, 0.014],
            0.001,
            [9.81 * s, 0.0, -9.81 * c],
        ),
        Some(Table {
            height: 0.002,
            hold: Hold::Resting,
            friction: mu,
        }),
        vec![tissue(
            [0.0, 0.0, 0.004],
            [0.006, 0.006, 0.004],
            material(5.0e4, 0.45, 1000.0, 0.0),
        )],
        vec![],
    );
    scene.solver.method = Method::Implicit;
    scene.solver.backend = BackendChoice::Cpu;
    scene
}

/// The block's mean acceleration along x over the second half of `frames` frames (after
/// the first steps, in which the contact's normal force builds up and the block settles),
/// from its mean velocity, and its mean displacement at the end (m).
fn slide(scene: &Scene, frames: usize) -> (f64, f64) {
    let mut world = dvrk_tissue_sim::world::World::new(scene);
    let mean = |w: &dvrk_tissue_sim::world::World| {
        let p = w.particles();
        let n = p.x.len() as f64;
        let x = p.x.iter().map(|q| q.x as f64).sum::<f64>() / n;
        let v = p.v.iter().map(|q| q.x as f64).sum::<f64>() / n;
        (x, v)
    };
    let (start, _) = mean(&world);
    let mut velocity = Vec::new();
    for _ in 0..frames {
        let report = world.step_frame().unwrap();
        assert!(report.tissue_reset.is_none());
        velocity.push(mean(&world).1);
    }
    let half = frames / 2;
    let acceleration = (velocity[frames - 1] - velocity[half - 1]) * 60.0 / (frames - half) as f64;
    (acceleration, mean(&world).0 - start)
}

#[test]
fn friction_in_the_solve_holds_a_block_on_a_gentle_incline_and_lets_it_slide_on_a_steep_one() {
    // Coulomb: on an incline of angle θ a block sticks while tan θ ≤ μ and otherwise slides
    // with a = g(sin θ − μ cos θ); backward Euler's velocities under a constant
    // acceleration are exact.
    let g = 9.81;
    let mut slid = 0.0;
    // The frictionless block slides 14 mm in four frames, the other 35 mm in ten, short of
    // the domain's wall.
    for (mu, degrees, frames) in [(0.0, 40.0f64, 4), (0.5, 40.0, 10)] {
        let (s, c) = degrees.to_radians().sin_cos();
        let expected = g * (s - mu * c);
        let (a, x) = slide(&block_on_an_incline(mu, degrees), frames);
        println!(
            "μ {mu}, {degrees}°: acceleration {a:.3} m/s² against {expected:.3} m/s² \
             ({:+.1} %), slid {x:.3e} m in {frames} frames",
            100.0 * (a / expected - 1.0)
        );
        assert!(
            (a / expected - 1.0).abs() < 0.05,
            "μ {mu}, {degrees}°: acceleration {a} m/s², expected {expected} m/s²"
        );
        slid = x;
    }
    // tan 20° = 0.36 < μ = 0.5: static friction holds the block. It slips a little in the
    // first steps, while its normal force builds from the first contact's estimate
    // (measured 0.41 mm in ten frames, 1.1 % of the slide at 40°), then stops.
    let (a, x) = slide(&block_on_an_incline(0.5, 20.0), 10);
    println!("μ 0.5, 20°: acceleration {a:.3e} m/s², moved {x:.3e} m");
    assert!(
        a.abs() < 0.01 * g,
        "the block held by friction accelerates at {a} m/s²"
    );
    assert!(
        x.abs() < 0.02 * slid,
        "the block held by friction moved {x} m (sliding at 40°: {slid} m)"
    );
}
