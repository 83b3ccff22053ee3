//! `bench skip`: what work a scene does not need costs nothing, measured on the seed-000
//! tissue (24,000 particles, 64³ grid):
//! - tissue at rest with no tool near it, asleep, against the same tissue stepped awake;
//! - the same tissue in a domain 4× larger along each axis (64× the volume and grid nodes);
//! - tools parked out of reach (a gripper, a needle, a second probe) against no tools;
//! - on the default scene, the liver held up 10 mm by the grip against the same jaws closed
//!   on it without pressing (contact only, nothing held);
//! - a scalpel parked out of reach against no tools, and the cutting scene mid-cut against
//!   a blunt tool on the blade's path (the cost of cutting when on);
//! - the resting tissue with a toughness it never reaches against none (the cost of the
//!   damage model when on; off, the CPU compiles it out and the GPU branches past it);
//! - the resting tissue with a 100-segment suture thread through it against none (the
//!   thread's contact on the grid each substep and its rod each frame; on the GPU backend
//!   with the grid's round trip each substep, see `mpm::gpu::thread_grid`).

use dvrk_tissue_sim::config::builders::seed000_scene;
use dvrk_tissue_sim::config::Scene;
use dvrk_tissue_sim::mpm::backend::BackendChoice;
use dvrk_tissue_sim::world::World;
use std::fmt::Write as _;
use std::time::Instant;

/// One measured configuration.
#[derive(Clone, Debug)]
pub struct SkipRow {
    pub case: &'static str,
    pub backend: &'static str,
    pub particles: usize,
    pub grid_nodes: usize,
    pub frames: u32,
    /// Wall time per frame (s).
    pub frame_s: f64,
    /// The case this one is compared with, and the largest ratio allowed.
    pub baseline: Option<(&'static str, f64)>,
    /// `frame_s` / the baseline's.
    pub ratio: Option<f64>,
}

/// The seed-000 tissue with its gripper parked 40 mm above it (out of reach) and sleep off.
fn resting_scene() -> Scene {
    let mut s = seed000_scene();
    for k in &mut s.tools[0].keyframes {
        k.position[2] += 0.04;
    }
    s.sleep.enabled = false;
    s
}

fn parked_tools(mut s: Scene) -> Scene {
    use dvrk_tissue_sim::tools::{ContactModel, Shape};
    let park = |x: f64| {
        vec![dvrk_tissue_sim::config::builders::key(
            0.0,
            [x, 0.03, 0.07],
            [0.0; 3],
            30.0,
        )]
    };
    s.tools.push(dvrk_tissue_sim::config::builders::tool(
        "needle",
        Shape::Needle {
            radius: 0.008,
            arc_angle: std::f32::consts::PI,
            wire_radius: 0.0004,
        },
        ContactModel::default(),
        park(-0.02),
    ));
    s.tools.push(dvrk_tissue_sim::config::builders::tool(
        "second probe",
        Shape::Sphere { radius: 0.004 },
        ContactModel::default(),
        park(0.02),
    ));
    s
}

/// The resting tissue without tools, a 100-segment 3-0 thread through its middle along x,
/// pinned at both ends 10 mm outside the block: every substep the grid's nodes within a
/// cell of each segment take the thread's contact, and every frame the rod steps with the
/// tissue's momentum (see `mpm::cpu::thread_contact`).
fn thread_through(mut s: Scene) -> Scene {
    use dvrk_tissue_sim::config::{PinnedEnds, Thread};
    let block = &s.tissues[0];
    let (centre, half) = (block.center, 0.5 * block.size[0]);
    let mut thread = Thread::nylon_3_0([centre[0] - half - 0.01, centre[1], centre[2]]);
    thread.length = 2.0 * (half + 0.01);
    thread.segments = 100;
    thread.pinned = PinnedEnds::Both;
    s.threads.push(thread);
    s
}

/// A scalpel parked out of reach: the cut's marking scans the particles, nothing is cut.
fn parked_slicer(mut s: Scene) -> Scene {
    use dvrk_tissue_sim::tools::{ContactModel, Shape};
    s.tools.clear();
    s.tools.push(dvrk_tissue_sim::config::builders::tool(
        "scalpel",
        Shape::Slicer {
            length: 0.03,
            height: 0.02,
            thickness: 0.0004,
        },
        ContactModel::default(),
        vec![dvrk_tissue_sim::config::builders::key(
            0.0,
            [0.0, 0.03, 0.07],
            [0.0; 3],
            0.0,
        )],
    ));
    s
}

/// The shipped cutting scene at dx = 1 mm (8× its particles), its scalpel cutting, or on
/// `blunt` a capsule on the same path where the blade's spine is (the same contact, no cut).
fn cutting_scene(blunt: bool) -> Scene {
    use dvrk_tissue_sim::tools::Shape;
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/config/cutting.toml");
    let mut s = dvrk_tissue_sim::config::load(std::path::Path::new(path))
        .expect("the shipped cutting scene loads");
    s.domain.dx = 0.001;
    if blunt {
        let tool = &mut s.tools[0];
        if let Shape::Slicer { length, .. } = tool.shape {
            tool.shape = Shape::Capsule {
                radius: 0.0015,
                half_length: 0.5 * length,
            };
        }
        for k in &mut tool.keyframes {
            k.rpy_deg = [0.0, 90.0, 0.0];
        }
    }
    s
}

/// The default scene with its grasp keyframes; without `grip`, the jaws close to 0° and do
/// not press, so they touch the liver as contact and hold nothing.
fn default_grasp(grip: bool) -> Scene {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/config/default.toml");
    let mut s = dvrk_tissue_sim::config::load(std::path::Path::new(path))
        .expect("the shipped default scene loads");
    if !grip {
        for k in &mut s.tools[0].keyframes {
            k.jaw_deg = k.jaw_deg.max(0.0);
        }
    }
    s
}

/// Times `frames` frames after `warmup` untimed ones.
fn time_frames(world: &mut World, warmup: u32, frames: u32) -> f64 {
    for _ in 0..warmup {
        world.step_frame().expect("bench scene is stable");
    }
    let start = Instant::now();
    for _ in 0..frames {
        world.step_frame().expect("bench scene is stable");
    }
    start.elapsed().as_secs_f64() / frames as f64
}

/// One case to time: its scene, the case it is compared with (and the largest ratio
/// allowed), whether it first steps until the tissue sleeps, and the scene time it is first
/// stepped to (untimed).
struct Case {
    name: &'static str,
    scene: Scene,
    baseline: Option<(&'static str, f64)>,
    settle: bool,
    warm_until: Option<f64>,
}

fn case(
    name: &'static str,
    scene: Scene,
    baseline: Option<(&'static str, f64)>,
    settle: bool,
    warm_until: Option<f64>,
) -> Case {
    Case {
        name,
        scene,
        baseline,
        settle,
        warm_until,
    }
}

/// Every case, each after the case it is compared with.
fn cases() -> Vec<Case> {
    const AWAKE: &str = "at rest, stepped (sleep off)";
    let mut asleep = resting_scene();
    asleep.sleep.enabled = true;
    let mut large = resting_scene();
    for a in 0..3 {
        large.domain.origin[a] *= 4.0;
        large.domain.size[a] *= 4.0;
    }
    let mut bare = resting_scene();
    bare.tools.clear();
    const BARE: &str = "no tools";
    let mut threaded = resting_scene();
    threaded.tools.clear();
    let mut tough = resting_scene();
    // Damage computed every substep, never started: the same motion as the baseline.
    tough.tissues[0].material.toughness = Some(1e5);
    // Mid-cut (the edge halfway down the block at 0.35 s): the blade against a blunt tool
    // on its path; the same substeps, only the cut's marking and tests differ.
    const BLUNT: &str = "cutting scene (dx 1 mm), blunt tool on the blade's path";
    // The default scene's keyframes have lifted the liver 10 mm by 1.5 s and hold it to 1.8 s.
    const CONTACT: &str = "default scene, jaws closed on the liver, contact only";
    vec![
        case(AWAKE, resting_scene(), None, false, None),
        case("at rest, asleep", asleep, Some((AWAKE, 0.05)), true, None),
        case(
            "domain 4× per axis (64× nodes)",
            large,
            Some((AWAKE, 1.2)),
            false,
            None,
        ),
        case(BARE, bare, None, false, None),
        case(
            "at rest, stepped, toughness on (nothing tears)",
            tough,
            Some((AWAKE, 1.1)),
            false,
            None,
        ),
        case(
            "gripper, needle, probe parked",
            parked_tools(resting_scene()),
            Some((BARE, 1.05)),
            false,
            None,
        ),
        case(
            "a 100-segment thread through the tissue",
            thread_through(threaded),
            Some((BARE, 1.15)),
            false,
            None,
        ),
        case(
            "slicer parked",
            parked_slicer(resting_scene()),
            Some((BARE, 1.05)),
            false,
            None,
        ),
        case(BLUNT, cutting_scene(true), None, false, Some(0.35)),
        case(
            "cutting scene (dx 1 mm), blade cutting",
            cutting_scene(false),
            Some((BLUNT, 1.1)),
            false,
            Some(0.35),
        ),
        case(CONTACT, default_grasp(false), None, false, Some(1.5)),
        case(
            "default scene, liver held up by the grip",
            default_grasp(true),
            Some((CONTACT, 1.1)),
            false,
            Some(1.5),
        ),
    ]
}

/// Runs the cases on `backend`, `frames` timed frames each: every case, or with `only` the
/// cases whose name contains it and the cases they are compared with.
pub fn run(
    backend: BackendChoice,
    frames: u32,
    only: Option<&str>,
) -> anyhow::Result<Vec<SkipRow>> {
    let all = cases();
    let chosen: Vec<&'static str> = all
        .iter()
        .filter(|c| only.is_none_or(|o| c.name.contains(o)))
        .flat_map(|c| std::iter::once(c.name).chain(c.baseline.map(|(b, _)| b)))
        .collect();
    anyhow::ensure!(
        !chosen.is_empty(),
        "no bench skip case contains {:?}",
        only.unwrap_or_default()
    );
    let mut rows: Vec<SkipRow> = Vec::new();
    for c in all.into_iter().filter(|c| chosen.contains(&c.name)) {
        let Case {
            name,
            mut scene,
            baseline,
            settle,
            warm_until,
        } = c;
        scene.solver.backend = backend;
        let mut world = World::try_new(&scene)?;
        if settle {
            // Step (untimed) until the tissue has come to rest and fallen asleep.
            while !world.is_asleep() {
                world.step_frame().expect("bench scene is stable");
                anyhow::ensure!(world.time() < 10.0, "{name}: tissue never came to rest");
            }
        }
        if let Some(until) = warm_until {
            while world.time() < until {
                world.step_frame().expect("bench scene is stable");
            }
        }
        // The default scene holds the liver up for 0.3 s (18 frames).
        let frames = if warm_until.is_some() {
            frames.min(15)
        } else {
            frames
        };
        let frame_s = time_frames(&mut world, 1, frames);
        eprintln!("{name}: {:.3} ms per frame", 1e3 * frame_s);
        if !scene.threads.is_empty() {
            // The row measures a thread in the tissue, not one the grid never meets.
            let exchange = world.backend().thread_exchange().unwrap_or_default();
            let (contacts, bound) = (exchange.contacts, exchange.bound_points);
            anyhow::ensure!(contacts + bound > 0, "{name}: the thread met no tissue");
            eprintln!(
                "{name}: in the last frame {contacts} node contacts, {bound} points bound to tissue"
            );
        }
        let ratio = baseline.and_then(|(base, _)| {
            rows.iter()
                .find(|r| r.case == base)
                .map(|r| frame_s / r.frame_s)
        });
        rows.push(SkipRow {
            case: name,
            backend: world.backend().name(),
            particles: world.particles().len(),
            grid_nodes: world.layout().node_count(),
            frames,
            frame_s,
            baseline,
            ratio,
        });
    }
    Ok(rows)
}

/// Rows whose ratio exceeds its allowed bound.
pub fn over_target(rows: &[SkipRow]) -> Vec<String> {
    rows.iter()
        .filter_map(|r| match (r.baseline, r.ratio) {
            (Some((name, bound)), Some(ratio)) if ratio > bound => Some(format!(
                "{} costs {ratio:.3}× \"{name}\" (target ≤ {bound}×)",
                r.case
            )),
            _ => None,
        })
        .collect()
}

pub fn table(rows: &[SkipRow]) -> String {
    let mut out = String::from(
        "| case | backend | particles | grid nodes | frames | ms per frame | compared with | ratio | target |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let (against, ratio, target) = match (r.baseline, r.ratio) {
            (Some((name, bound)), Some(ratio)) => {
                let shown = if ratio < 0.01 {
                    format!("{ratio:.1e}")
                } else {
                    format!("{ratio:.3}")
                };
                (name.to_owned(), shown, format!("≤ {bound}"))
            }
            _ => ("—".into(), "—".into(), "—".into()),
        };
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {:.3} | {} | {} | {} |",
            r.case,
            r.backend,
            r.particles,
            r.grid_nodes,
            r.frames,
            1e3 * r.frame_s,
            against,
            ratio,
            target
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_case_comes_after_its_baseline() {
        let all = cases();
        for (i, c) in all.iter().enumerate() {
            if let Some((base, _)) = c.baseline {
                let at = all.iter().position(|b| b.name == base);
                assert!(at.is_some_and(|at| at < i), "{} before {base}", c.name);
            }
        }
    }

    #[test]
    fn bench_scenes_are_valid_and_keep_tools_out_of_reach() {
        for scene in [
            resting_scene(),
            parked_tools(resting_scene()),
            parked_slicer(resting_scene()),
        ] {
            let problems = dvrk_tissue_sim::config::validate(&scene);
            assert!(problems.is_empty(), "{problems:?}");
            let world = World::new(&scene);
            let dx = scene.domain.dx as f32;
            let tissue =
                dvrk_tissue_sim::sleep::Aabb::of_points(&world.particles().x).grown(2.0 * dx);
            for t in world.tools() {
                assert!(
                    !t.reach_between(0.0, 2.0, dx).intersects(&tissue),
                    "{} within reach",
                    t.name
                );
            }
        }
    }
}
