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
