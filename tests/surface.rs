//! The tissue surface through a large deformation: the grasp scene's jaws squeeze a 6 mm
//! block to about half its width and lift it (CPU backend).

use dvrk_tissue_sim::config::builders::grasp_scene;
use dvrk_tissue_sim::mpm::backend::BackendChoice;
use dvrk_tissue_sim::output::isosurface::{self, is_closed};
use dvrk_tissue_sim::output::mesh::TissueMesh;
use dvrk_tissue_sim::output::strain::StrainMeasure;
use dvrk_tissue_sim::world::World;

#[test]
fn mesh_keeps_its_topology_and_stays_on_the_particles_through_a_squeeze_and_lift() {
    let mut scene = grasp_scene(0.1, 0.3, 0.6, 0.005);
    scene.solver.backend = BackendChoice::Cpu;
    // A jaw ten times quicker than dVRK's (its effort-limited closing speed is 1.8 rad/s), so
    // that the jaws reach the keyframes' squeeze within the scene's 0.2 s of closing.
    scene.tools[0].jaw.d_gain *= 0.1;
    let mut world = World::new(&scene);
    let rest = world.particles().clone();
    let spacing = rest.volume0[0].cbrt();
    let mut mesh = TissueMesh::build(&rest, scene.domain.dx as f32).unwrap();
    let (vertices, triangles, uvs) = (mesh.rest.len(), mesh.triangles.clone(), mesh.uvs.clone());
    let radius = 4.0 * spacing;
    let rest_gaps = mesh.particle_gaps(&mesh.rest, &rest.x, radius);
    let mut worst = 0.0f32;
    while world.time() < 0.6 {
        world.step_frame().unwrap();
        mesh.update(&world.particles().x);
        assert_eq!(mesh.vertices.len(), vertices);
        assert_eq!(mesh.triangles, triangles);
        assert_eq!(mesh.uvs, uvs);
        assert!(mesh.vertices.iter().flatten().all(|v| v.is_finite()));
        let d = mesh.deviation(&world.particles().x, &rest_gaps, radius);
        worst = worst.max(d.max);
    }
    let particles = world.particles();
    let strain = particles
        .f
        .iter()
        .map(|f| StrainMeasure::Equivalent.of(f))
        .fold(0.0, f32::max);
    let lifted = particles.centre_of_mass().z - rest.centre_of_mass().z;
    let d = mesh.deviation(&particles.x, &rest_gaps, radius);
    println!(
        "largest equivalent strain {strain:.3}, lift {:.2} mm; deviation at the end: mean {:.1} \
         µm, p95 {:.1} µm, max {:.1} µm; largest over the run {:.1} µm (spacing {:.0} µm)",
        lifted * 1e3,
        d.mean * 1e6,
        d.p95 * 1e6,
        d.max * 1e6,
        worst * 1e6,
        spacing * 1e6
    );
    assert!(strain > 0.3, "a large deformation ({strain})");
    assert!(lifted > 0.002, "the block was lifted ({lifted} m)");
    // Measured: mean 18 µm, p95 58 µm, largest 95 µm over the run (spacing 500 µm).
    assert!(d.mean < 0.1 * spacing, "mean deviation {} m", d.mean);
    assert!(d.p95 < 0.25 * spacing, "95th percentile {} m", d.p95);
    assert!(worst < 0.4 * spacing, "largest deviation {worst} m");

    // The isosurface of the squeezed block is still one closed surface.
    let s = isosurface::extract(particles, scene.domain.dx as f32);
    assert!(!s.triangles.is_empty() && is_closed(&s.triangles));
}
