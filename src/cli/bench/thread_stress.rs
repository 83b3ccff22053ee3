//! The thread's cases of `stress` (group `thread`): a 3-0 nylon thread pulled at 1 m/s
//! across the table, a loop whose ends are pulled apart until it closes on its crossing
//! (knot-like tightening of crossing segments), and a thread dropped in coils onto itself.
//! Each case must stay finite, never bring two segments closer than 90 % of a diameter
//! (no pass-through) and keep every segment's strain below 1 %.

use dvrk_tissue_sim::math::Vec3;
use dvrk_tissue_sim::rod::self_contact::min_self_distance;
use dvrk_tissue_sim::rod::solver::RodSolverSettings;
use dvrk_tissue_sim::rod::{Rod, RodAttachment, RodEnvironment, RodSolver, ThreadMaterial};
use std::f32::consts::TAU;
use std::time::Instant;

const FRAME_DT: f32 = 1.0 / 60.0;
const GRAVITY: Vec3 = Vec3::new(0.0, 0.0, -9.81);
/// Closest approach of two segments, in diameters, below which a case failed.
pub const MIN_SEPARATION: f32 = 0.9;
/// Largest strain of any segment above which a case failed.
pub const MAX_STRAIN: f32 = 1e-2;

pub struct ThreadStressResult {
    pub name: &'static str,
    pub frames: usize,
    pub finite: bool,
    /// Closest approach of non-neighbouring segments over the run, in thread diameters.
    pub min_separation: f32,
    pub max_strain: f32,
    pub self_contacts: u64,
    pub wall_s: f64,
}

impl ThreadStressResult {
    pub fn stable(&self) -> bool {
        self.finite && self.min_separation >= MIN_SEPARATION && self.max_strain <= MAX_STRAIN
    }
}

/// A case: the rod, then per frame the attachments (frame index, rod) → targets.
struct Case {
    name: &'static str,
    rod: Rod,
    frames: usize,
    attachments: fn(usize, &Rod) -> Vec<RodAttachment>,
}

fn environment() -> RodEnvironment<'static> {
    RodEnvironment {
        table_friction: 0.3,
        table_height: Some(0.0),
        self_collision: true,
        self_friction: 0.2,
        ..Default::default()
    }
}

fn nylon(points: Vec<Vec3>) -> Rod {
    Rod::from_polyline(ThreadMaterial::nylon_3_0(), points)
}

/// A 15 cm thread in an S on the table, one end pulled along x at 1 m/s for 0.25 s.
fn pull_case() -> Case {
    let r = ThreadMaterial::nylon_3_0().radius;
    let points = (0..=60)
        .map(|i| {
            let s = i as f32 / 60.0;
            Vec3::new(0.1 * s, 0.01 * (TAU * s).sin(), r)
        })
        .collect();
    Case {
        name: "pull 1 m/s",
        rod: nylon(points),
        frames: 30,
        attachments: |frame, rod| {
            if frame >= 15 {
                return Vec::new();
            }
            let from = rod.points[60];
            vec![RodAttachment {
                point: 60,
                from,
                to: from + Vec3::new(FRAME_DT, 0.0, 0.0),
            }]
        },
    }
}

/// A loop of 8 mm radius (50 mm of slack) on the table whose end passes 2 mm beside and 2.5
/// radii above its start; the tails are pulled apart at 0.5 m/s each (1 m/s relative) for
/// two frames (33 mm in all), closing the loop to about 2.7 mm radius, then held.
fn tightening_case() -> Case {
    let r = ThreadMaterial::nylon_3_0().radius;
    let radius = 0.008;
    let tail = 0.04;
    let mut points = Vec::new();
    // Left tail along +x towards the crossing at the origin, rising over it.
    for i in 0..20 {
        let s = i as f32 / 20.0;
        points.push(Vec3::new(-tail + tail * s, -0.002 * (1.0 - s), r));
    }
    // The loop: a circle above the crossing, from the origin round and back.
    for i in 0..=60 {
        let a = TAU * i as f32 / 60.0;
        points.push(Vec3::new(
            radius * a.sin(),
            radius * (1.0 - a.cos()) - 0.002 * a / TAU,
            r + (2.5 * r) * (a / TAU),
        ));
    }
    // Right tail from just past the crossing, along +x.
    for i in 1..=20 {
        let s = i as f32 / 20.0;
        points.push(Vec3::new(tail * s, -0.002 - 0.002 * s, 3.5 * r));
    }
    Case {
        name: "loop tightened 1 m/s",
        rod: nylon(points),
        frames: 60,
        attachments: |frame, rod| {
            let last = rod.points.len() - 1;
            let speed = if frame < 2 { 0.5 * FRAME_DT } else { 0.0 };
            [(0, -speed), (last, speed)]
                .map(|(p, dx)| RodAttachment {
                    point: p,
                    from: rod.points[p],
                    to: rod.points[p] + Vec3::new(dx, 0.0, 0.0),
                })
                .to_vec()
        },
    }
}

/// 40 cm of thread in five stacked 8 mm coils, 1 mm apart, dropped from 1 cm.
fn coils_case() -> Case {
    let turns = 5.0;
    let segments = 200;
    let points = (0..=segments)
        .map(|i| {
            let a = TAU * turns * i as f32 / segments as f32;
            Vec3::new(0.008 * a.cos(), 0.008 * a.sin(), 0.01 + 0.001 * a / TAU)
        })
        .collect();
    Case {
        name: "coils dropped",
        rod: nylon(points),
        frames: 90,
        attachments: |_, _| Vec::new(),
    }
}

fn run_case(mut case: Case) -> ThreadStressResult {
    let mut solver = RodSolver::new(&case.rod, RodSolverSettings::default(), GRAVITY);
    let diameter = 2.0 * case.rod.material.radius;
    let mut result = ThreadStressResult {
        name: case.name,
        frames: 0,
        finite: true,
        min_separation: min_self_distance(&case.rod) / diameter,
        max_strain: 0.0,
        self_contacts: 0,
        wall_s: 0.0,
    };
    for frame in 0..case.frames {
        let attachments = (case.attachments)(frame, &case.rod);
        let env = RodEnvironment {
            attachments: &attachments,
            ..environment()
        };
        let start = Instant::now();
        let report = solver.step_frame_in(&mut case.rod, FRAME_DT, &env);
        result.wall_s += start.elapsed().as_secs_f64();
        result.frames += 1;
        if !case.rod.is_finite() {
            result.finite = false;
            break;
        }
        result.self_contacts += report.self_contacts as u64;
        result.max_strain = result.max_strain.max(report.max_strain);
        result.min_separation = result
            .min_separation
            .min(min_self_distance(&case.rod) / diameter);
    }
    result
}

/// Number of cases `run` runs.
pub const CASES: usize = 3;

pub fn run() -> Vec<ThreadStressResult> {
    [pull_case(), tightening_case(), coils_case()]
        .into_iter()
        .map(run_case)
        .collect()
}

pub fn markdown(results: &[ThreadStressResult]) -> String {
    let mut out = String::from(
        "| group | case | stable | frames | min separation (diameters) | max strain | self contacts | wall (s) |\n|---|---|---|---|---|---|---|---|\n",
    );
    for r in results {
        out += &format!(
            "| thread | {} | {} | {} | {:.3} | {:.2e} | {} | {:.2} |\n",
            r.name,
            if r.stable() { "yes" } else { "NO" },
            r.frames,
            r.min_separation,
            r.max_strain,
            r.self_contacts,
            r.wall_s
        );
    }
    out
}
