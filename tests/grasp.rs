//! Grasping as users do it, headless: each shipped scene's own keyframes open the jaws,
//! insert, close, lift, hold and open again. The grasped tissue must rise with the jaws,
//! the gripper must feel the pull while it holds, and opening must let the tissue go.
//! Also: slip at μ × the squeeze, and jaws closing on air hold nothing. The default scene's
//! 25 mm lift is `tests/deep_lift.rs`'s.

use dvrk_tissue_sim::config::Scene;
use dvrk_tissue_sim::math::Vec3;
use dvrk_tissue_sim::world::World;

mod support;

use support::scenes::shipped;

/// The keyframe times of a scene's grasp: jaws closing, lift done, jaws opening.
struct GraspTimes {
    close: f64,
    lifted: f64,
    open: f64,
}

fn grasp_times(scene: &Scene, tool: usize) -> GraspTimes {
    let keys = &scene.tools[tool].keyframes;
    let close = keys
        .iter()
        .position(|k| k.jaw_deg <= 0.0)
        .expect("a closing keyframe");
    let open = close
        + keys[close..]
            .iter()
            .position(|k| k.jaw_deg > 0.0)
            .expect("an opening keyframe");
    let top = keys[close..open]
        .iter()
        .map(|k| k.position[2])
        .fold(f64::MIN, f64::max);
    let lifted = (close..open).find(|&k| keys[k].position[2] == top).unwrap();
    // The hold lasts from the highest keyframe to the one before the jaws open.
    GraspTimes {
        close: keys[close].t,
        lifted: keys[lifted].t,
        open: keys[open - 1].t,
    }
}

/// The particles the jaws close on: within the jaws' reach of the tool axis at the closing
/// keyframe, in the top 5 mm of the tissue there.
fn grasped_region(world: &World, scene: &Scene, tool: usize, times: &GraspTimes) -> Vec<usize> {
    let key = scene.tools[tool]
        .keyframes
        .iter()
        .find(|k| k.t == times.close)
        .unwrap();
    let axis = Vec3::new(key.position[0] as f32, key.position[1] as f32, 0.0);
    let near: Vec<usize> = world
        .particles()
        .x
        .iter()
        .enumerate()
        .filter(|(_, x)| (Vec3::new(x.x, x.y, 0.0) - axis).norm() <= 0.004)
        .map(|(i, _)| i)
        .collect();
    let top = near
        .iter()
        .map(|&i| world.particles().x[i].z)
        .fold(f32::MIN, f32::max);
    near.into_iter()
        .filter(|&i| world.particles().x[i].z >= top - 0.005)
        .collect()
}

fn mean_z(world: &World, region: &[usize]) -> f64 {
    region
        .iter()
        .map(|&i| world.particles().x[i].z as f64)
        .sum::<f64>()
        / region.len() as f64
}

struct Grasp {
    /// Rise of the grasped region while held, and after opening (m).
    held_rise: f64,
    released_rise: f64,
    /// Tool's own rise from closing to the hold (m).
    tool_rise: f64,
    /// Mean force on the gripper while held (N, world z; negative: pulled down).
    held_force_z: f64,
    /// Jaw opening and squeeze effort while held.
    jaw_angle: f64,
    squeeze: f64,
}

fn grasp(scene: &Scene, tool: usize) -> Grasp {
    let times = grasp_times(scene, tool);
    let mut world = World::new(scene);
    let region = grasped_region(&world, scene, tool, &times);
    assert!(
        region.len() > 10,
        "{} particles under the jaws",
        region.len()
    );
    let z0 = mean_z(&world, &region);
    let hold_from = times.lifted + 0.5 * (times.open - times.lifted);
    let mut forces = Vec::new();
    let (mut held_rise, mut jaw_angle, mut squeeze) = (0.0, 0.0, 0.0);
    while world.time() < times.open - 1e-9 {
        let report = world.step_frame().unwrap();
        if world.time() >= hold_from {
            forces.push(report.wrenches[tool].force.z);
            held_rise = mean_z(&world, &region) - z0;
            let jaw = world.tools()[tool].jaw().unwrap();
            (jaw_angle, squeeze) = (jaw.angle, jaw.squeeze());
        }
    }
    // dVRK's jaw takes about 0.7 s to open 70°.
    while world.time() < times.open + 1.0 {
        world.step_frame().unwrap();
    }
    let keys = &scene.tools[tool].keyframes;
    let z_of = |t: f64| keys.iter().find(|k| k.t == t).unwrap().position[2];
    Grasp {
        held_rise,
        released_rise: mean_z(&world, &region) - z0,
        tool_rise: z_of(times.lifted) - z_of(times.close),
        held_force_z: forces.iter().sum::<f64>() / forces.len() as f64,
        jaw_angle,
        squeeze,
    }
}

fn assert_lifts(name: &str, tool: usize) {
    let scene = shipped(name);
    let g = grasp(&scene, tool);
    let report = format!(
        "{name}: held rise {:.2} mm of the tool's {:.2} mm, released {:.2} mm, force z {:.3} N, \
         jaw {:.3} rad, squeeze {:.3} N·m",
        g.held_rise * 1e3,
        g.tool_rise * 1e3,
        g.released_rise * 1e3,
        g.held_force_z,
        g.jaw_angle,
        g.squeeze
    );
    println!("{report}");
    assert!(
        g.held_rise >= 0.005,
        "the grasped region rose < 5 mm: {report}"
    );
    assert!(
        g.held_force_z < -0.02,
        "the gripper does not feel the pull: {report}"
    );
    assert!(
        g.jaw_angle < 0.05 && g.squeeze > 0.1,
        "the jaws do not squeeze: {report}"
    );
    assert!(
        g.released_rise < 0.3 * g.held_rise,
        "opening the jaws did not let the tissue go: {report}"
    );
}

#[test]
fn teleop_scene_grasp_lifts_and_releases_the_liver() {
    assert_lifts("teleop.toml", 0);
}

#[test]
fn retraction_scene_grasp_lifts_and_releases_the_flap() {
    assert_lifts("retraction.toml", 1);
}

/// A 12 mm × 12 mm × 6 mm block bonded to the table, its top pinched with a weak squeeze
/// and pulled up along the jaw faces at 4 mm/s: the elastic pull grows until the grip
/// slips, and the tissue slides out between the jaws. Coulomb on the grip as a whole:
/// pull-out force = μ × total normal force, each face's normal force being the squeeze
/// over its lever about the hinge.
#[test]
fn a_pulled_grip_slips_at_friction_times_the_squeeze() {
    use dvrk_tissue_sim::config::{builders, Hold};
    use dvrk_tissue_sim::tools::ContactModel;
    let friction = 0.2;
    let mut scene = builders::grasp_scene(0.1, 0.8, 1.0, 0.0);
    scene.table.as_mut().unwrap().hold = Hold::Bonded;
    scene.tissues[0].size = [0.012, 0.012, 0.006];
    let tool = &mut scene.tools[0];
    tool.contact = ContactModel::Coulomb {
        friction,
        drag: 0.0,
    };
    // A squeeze of 0.002 N·m, closing as fast as dVRK's jaw (speed = effort / d_gain).
    tool.jaw.effort_max = 0.002;
    tool.jaw.d_gain = 0.09 * 0.002 / 0.16;
    for key in &mut tool.keyframes[2..] {
        key.jaw_deg = -20.0;
    }
    let mut pull_up = tool.keyframes[3].clone();
    pull_up.t = 2.5;
    pull_up.position[2] += 0.006;
    tool.keyframes.push(pull_up);
    let mut world = World::new(&scene);
    let (mut peak_pull, mut normal_at_peak, mut slipped_at) = (0.0f64, 0.0f64, None);
    let mut history = Vec::new();
    while world.time() < 2.5 {
        let report = world.step_frame().unwrap();
        if world.time() < 1.0 {
            continue;
        }
        // The tissue pulls the lifted gripper down.
        let pull = -report.wrenches[0].force.z;
        let tool = &world.tools()[0];
        let sums = tool.grip_sums();
        let squeeze = tool.jaw().unwrap().squeeze();
        if sums.mass == 0.0 {
            break;
        }
        let normal = 2.0 * squeeze / (sums.mass_lever / sums.mass);
        if tool.grip_ratio().unwrap() < 1.0 && slipped_at.is_none() {
            slipped_at = Some(world.time());
        }
        if pull > peak_pull {
            (peak_pull, normal_at_peak) = (pull, normal);
        }
        history.push((world.time(), pull, normal));
    }
    let expected = friction as f64 * normal_at_peak;
    let report = format!(
        "pull-out {peak_pull:.4} N, μ × normal force {expected:.4} N (normal {normal_at_peak:.3} N), \
         slipping from t = {slipped_at:?} s; (t, pull, normal): {:?}",
        history.iter().step_by(10).collect::<Vec<_>>()
    );
    println!("{report}");
    assert!(slipped_at.is_some(), "the grip never slipped: {report}");
    assert!(
        (peak_pull - expected).abs() <= 0.3 * expected,
        "pull-out force off μ × squeeze by more than 30 %: {report}"
    );
}

/// Jaws pressed shut above the tissue hold nothing and feel nothing.
#[test]
fn jaws_closed_on_air_hold_nothing() {
    let mut scene = dvrk_tissue_sim::config::builders::grasp_scene(0.1, 0.8, 1.0, 0.0);
    for key in &mut scene.tools[0].keyframes {
        key.position[2] += 0.012;
    }
    for key in &mut scene.tools[0].keyframes[2..] {
        key.jaw_deg = -20.0;
    }
    let mut world = World::new(&scene);
    while world.time() < 1.0 {
        let report = world.step_frame().unwrap();
        let tool = &world.tools()[0];
        assert_eq!(tool.grip_sums().mass, 0.0);
        assert_eq!(report.wrenches[0].force.norm(), 0.0);
    }
    let jaw = world.tools()[0].jaw().unwrap();
    assert!(jaw.angle == 0.0 && world.tools()[0].grip_ratio().unwrap() >= 0.0);
}
