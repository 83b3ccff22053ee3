//! The stability matrix behind `stress`: stiff and soft, compressible and nearly
//! incompressible tissue, time steps past the CFL bound, slow and fast tools, jaws closing
//! fully, two tools pulling tissue apart, tissue dropped from height, and a long soak of
//! periodic grasping, and PB-MPM at its default step on liver and on the stiffest, most
//! nearly incompressible material. Each case runs through the same `World` as a scene file and reports
//! whether it stayed stable, its energy drift, how deep particles got inside solid tools,
//! escaped or non-finite particles, guard events and frames whose step was subdivided.
//!
//! A case inside the documented safe envelope (see README, "Stability") must pass every
//! check; cases outside it are there to show where the envelope ends.

use dvrk_tissue_sim::config::builders::*;
use dvrk_tissue_sim::config::{Hold, Scene, Table};
use dvrk_tissue_sim::mpm::backend::BackendChoice;
use dvrk_tissue_sim::mpm::material::energy_density;
use dvrk_tissue_sim::mpm::{timestep, Lame, Method};
use dvrk_tissue_sim::tools::{ContactModel, Shape, ToolKinematics, ToolVelocity};
use dvrk_tissue_sim::world::{StepError, World};
use std::fmt::Write as _;
use std::time::Instant;

/// Particles deeper than this inside a solid tool (in grid cells) mean tissue is flowing
/// through it: grid contact stops nodes, so particles may sit up to about a cell inside.
pub const MAX_PENETRATION_CELLS: f64 = 2.0;
/// Energy gained beyond the work tools did, as a fraction of the case's energy scale,
/// above which a run counts as unstable (a blow-up gains orders of magnitude more).
pub const MAX_ENERGY_GAIN: f64 = 0.10;

/// How much of the matrix to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Matrix {
    /// Every case, the soak 10 simulated minutes long.
    Full,
    /// A corner of each group and a 10-second soak (CI).
    Reduced,
}

/// One scene of the matrix.
#[derive(Clone, Debug)]
pub struct StressCase {
    pub group: &'static str,
    pub name: String,
    pub scene: Scene,
    /// Simulated seconds to run.
    pub duration: f64,
    /// Inside the documented safe envelope: a failure makes `stress` exit non-zero.
    pub in_envelope: bool,
    /// Whether the energy balance is checked: tool work is the wrench times the tool's rigid
    /// velocity, which misses the work of jaws rotating about their hinge.
    pub energy_checked: bool,
}

/// What one case did.
#[derive(Clone, Debug)]
pub struct StressResult {
    pub group: &'static str,
    pub name: String,
    pub in_envelope: bool,
    pub particles: usize,
    pub simulated: f64,
    pub substeps: u64,
    pub wall_s: f64,
    /// (E_end − E_start − tool work) / energy scale; negative is dissipation.
    pub energy_drift: f64,
    /// Largest energy gain beyond tool work seen at any frame, same scale.
    pub max_energy_gain: f64,
    pub energy_checked: bool,
    /// Deepest particle inside a solid tool, in grid cells.
    pub max_penetration_cells: f64,
    /// Particles clamped at the domain edge (summed over frames) or found below the table.
    pub escaped: u64,
    pub non_finite: usize,
    pub guard_events: u32,
    /// Frames whose substep was cut below the scene's fixed `dt` to respect the CFL bound.
    pub subdivided_frames: u32,
    /// The guard's message when it stopped the run.
    pub failure: Option<String>,
}

impl StressResult {
    /// Every check passed.
    pub fn stable(&self) -> bool {
        self.failure.is_none()
            && self.non_finite == 0
            && self.escaped == 0
            && self.guard_events == 0
            && self.max_penetration_cells <= MAX_PENETRATION_CELLS
            && (!self.energy_checked || self.max_energy_gain <= MAX_ENERGY_GAIN)
    }
}

const LIVER_E: f64 = 5400.0;
const LIVER_NU: f64 = 0.45;
const DENSITY: f64 = 1060.0;

/// The cases of `matrix`.
pub fn cases(matrix: Matrix) -> Vec<StressCase> {
    let full = matrix == Matrix::Full;
    let mut out = Vec::new();
    let (moduli, ratios): (&[f64], &[f64]) = if full {
        (&[1e3, 1e4, 1e5, 1e6], &[0.3, 0.4, 0.45, 0.49])
    } else {
        (&[1e3, 1e6], &[0.3, 0.49])
    };
    for &e in moduli {
        for &nu in ratios {
            out.push(indentation_case(e, nu, true));
        }
    }
    if full {
        out.push(indentation_case(1e6, 0.499, false));
    }
    let factors: &[f64] = if full {
        &[0.5, 1.0, 2.0, 4.0]
    } else {
        &[0.5, 4.0]
    };
    for &k in factors {
        out.push(fixed_dt_case(k));
    }
    let speeds: &[f64] = if full {
        &[1e-3, 1e-2, 1e-1, 1.0]
    } else {
        &[1e-2, 1.0]
    };
    for &v in speeds {
        out.push(tool_speed_case(v, true));
    }
    if full {
        out.push(tool_speed_case(3.0, false));
    }
    out.push(pb_mpm_case(LIVER_E, LIVER_NU));
    out.push(pb_mpm_case(1e6, 0.49));
    out.extend(implicit_cases(full));
    out.push(jaws_closing_case());
    out.push(pull_apart_case());
    out.push(drop_case());
    out.push(soak_case(if full { 600.0 } else { 10.0 }));
    out
}

/// Stress cases run on `backend` (the solver settings of every case are otherwise its own).
pub fn with_backend(mut cases: Vec<StressCase>, backend: BackendChoice) -> Vec<StressCase> {
    for c in &mut cases {
        c.scene.solver.backend = backend;
    }
    cases
}

/// Block 16 × 16 × 8 mm bonded to the table at dx = 2 mm.
fn block_scene(name: &str, e: f64, nu: f64, tools: Vec<dvrk_tissue_sim::config::Tool>) -> Scene {
    let mut s = scene(
        name,
        60.0,
        domain(
            [-0.016, -0.016, 0.0],
            [0.032, 0.032, 0.032],
            0.002,
            [0.0, 0.0, -9.81],
        ),
        Some(bonded_table(0.004)),
        vec![tissue(
            [0.0, 0.0, 0.008],
            [0.016, 0.016, 0.008],
            material(e, nu, DENSITY, 0.0),
        )],
        tools,
    );
    s.solver.max_substeps_per_frame = 20_000;
    s
}

const SPHERE: Shape = Shape::Sphere { radius: 0.004 };
const FRICTIONLESS: ContactModel = ContactModel::Coulomb {
    friction: 0.0,
    drag: 0.0,
};

/// Top face of [`block_scene`]'s tissue (m).
const BLOCK_TOP: f64 = 0.012;

/// A sphere pressed 2 mm into the block over 0.1 s and held for 0.05 s.
fn indentation_case(e: f64, nu: f64, in_envelope: bool) -> StressCase {
    let touching = BLOCK_TOP + 0.004;
    let probe = tool(
        "sphere",
        SPHERE,
        FRICTIONLESS,
        vec![
            key(0.0, [0.0, 0.0, touching + 0.001], [0.0; 3], 0.0),
            key(0.1, [0.0, 0.0, touching - 0.002], [0.0; 3], 0.0),
        ],
    );
    StressCase {
        group: "material",
        name: format!("E {} ν {nu}", si(e, "Pa")),
        scene: block_scene("stress material", e, nu, vec![probe]),
        duration: 0.15,
        in_envelope,
        energy_checked: true,
    }
}

/// Liver pressed by a sphere with a fixed `dt` of `factor` × the CFL bound.
fn fixed_dt_case(factor: f64) -> StressCase {
    let mut case = indentation_case(LIVER_E, LIVER_NU, true);
    let lame = Lame::from_young_poisson(LIVER_E, LIVER_NU);
    let bound = timestep::stable_dt(
        case.scene.solver.cfl,
        case.scene.domain.dx,
        lame.p_wave_speed(DENSITY),
        0.0,
    );
    case.scene.solver.dt = Some(factor * bound);
    case.group = "time step";
    case.name = format!("dt {factor}× CFL");
    case
}

/// The sphere indentation with PB-MPM at its default 1/240 s substep (1 MPa, ν 0.49 needs
/// about 2100 MLS-MPM substeps a frame). The energy balance is not checked: PB-MPM's
/// elastic response is not derived from the Neo-Hookean energy the check evaluates.
fn pb_mpm_case(e: f64, nu: f64) -> StressCase {
    let mut case = indentation_case(e, nu, true);
    case.scene.solver.method = Method::PbMpm;
    case.group = "pb-mpm";
    case.name = format!("E {} ν {nu}, dt 1/240 s", si(e, "Pa"));
    case.energy_checked = false;
    case
}

/// The implicit method at one substep per 60 Hz frame where advection allows: the sphere
/// indentation across E 1 kPa–1 MPa and ν 0.3–0.499, and the capsule dragged through liver
/// and through 1 MPa tissue at up to 1 m/s. The energy balance is checked: backward Euler
/// only ever dissipates.
fn implicit_cases(full: bool) -> Vec<StressCase> {
    let mut materials = Vec::new();
    let mut drags = Vec::new();
    if full {
        for e in [1e3, 1e4, 1e5, 1e6] {
            for nu in [0.3, 0.45, 0.49, 0.499] {
                materials.push((e, nu));
            }
        }
        for v in [1e-2, 1e-1, 1.0] {
            drags.push((v, LIVER_E));
            drags.push((v, 1e6));
        }
    } else {
        // The soft corner and the stiff one (the 1 MPa, ν 0.499 indentation, which gained
        // energy until the solve's active set took in the nodes it moves into a tool, takes
        // 38 s here: full matrix only; `a_tool_slower_than_gravity_pays_for_the_energy_it_stores`
        // in `mpm::cpu::implicit` guards the same mechanism in a few seconds).
        materials = vec![(1e3, 0.3), (1e6, 0.49)];
        // The fastest drag through the stiffest tissue, with friction (5 s here).
        drags = vec![(1.0, 1e6)];
    }
    // Every case is measured stable with no energy gained (README, "Implicit method"):
    // the capsule's friction acts inside the solve (`mpm::cpu::implicit::slip`).
    let implicit = |mut case: StressCase, name: String| {
        case.scene.solver.method = Method::Implicit;
        case.group = "implicit";
        case.name = name;
        case.in_envelope = true;
        case.energy_checked = true;
        case
    };
    let mut out = Vec::new();
    for (e, nu) in materials {
        let name = format!("sphere, E {} ν {nu}", si(e, "Pa"));
        out.push(implicit(indentation_case(e, nu, true), name));
    }
    for (v, e) in drags {
        let mut case = tool_speed_case(v, true);
        case.scene.tissues[0].material.youngs_modulus = e;
        let name = format!("capsule {} in E {}", si(v, "m/s"), si(e, "Pa"));
        out.push(implicit(case, name));
    }
    out
}

/// A capsule pressed 2 mm into liver, then dragged 6 mm sideways at `speed` (m/s).
fn tool_speed_case(speed: f64, in_envelope: bool) -> StressCase {
    let radius = 0.002;
    let z = BLOCK_TOP + radius - 0.002;
    let press = 0.05;
    let travel = 0.006;
    let slide = travel / speed;
    let capsule = tool(
        "capsule",
        Shape::Capsule {
            radius: radius as f32,
            half_length: 0.006,
        },
        ContactModel::Coulomb {
            friction: 0.3,
            drag: 0.0,
        },
        vec![
            key(0.0, [-0.003, 0.0, z + 0.003], [90.0, 0.0, 0.0], 0.0),
            key(press, [-0.003, 0.0, z], [90.0, 0.0, 0.0], 0.0),
            key(press + slide, [0.003, 0.0, z], [90.0, 0.0, 0.0], 0.0),
        ],
    );
    StressCase {
        group: "tool speed",
        name: format!("{} sideways", si(speed, "m/s")),
        scene: block_scene("stress tool speed", LIVER_E, LIVER_NU, vec![capsule]),
        duration: press + slide + 0.02,
        in_envelope,
        energy_checked: true,
    }
}

/// The grasp scene's gripper closing fully (jaw 0°) on the 6 mm block and lifting it.
fn jaws_closing_case() -> StressCase {
    let mut scene = grasp_scene(0.05, 0.2, 0.35, 0.006);
    for k in &mut scene.tools[0].keyframes[2..] {
        k.jaw_deg = 0.0;
    }
    scene.solver.max_substeps_per_frame = 20_000;
    StressCase {
        group: "scenario",
        name: "jaws close fully on tissue".into(),
        scene,
        duration: 0.45,
        in_envelope: true,
        energy_checked: false,
    }
}

/// Two sticky boxes grip the ends of a free 16 mm strip and pull it to 1.5× its length.
fn pull_apart_case() -> StressCase {
    let grip = Shape::Box {
        half_extents: [0.002, 0.005, 0.003],
    };
    let z = 0.008;
    let ends = |x: f64, dir: f64| {
        vec![
            key(0.0, [x, 0.0, z], [0.0; 3], 0.0),
            key(0.05, [x, 0.0, z], [0.0; 3], 0.0),
            key(0.45, [x + dir * 0.004, 0.0, z], [0.0; 3], 0.0),
        ]
    };
    let mut s = scene(
        "stress pull apart",
        60.0,
        domain(
            [-0.02, -0.012, 0.0],
            [0.04, 0.024, 0.02],
            0.002,
            [0.0, 0.0, -9.81],
        ),
        Some(Table {
            height: 0.004,
            hold: Hold::Resting,
            friction: 0.2,
        }),
        vec![tissue(
            [0.0, 0.0, 0.008],
            [0.016, 0.008, 0.004],
            material(LIVER_E, LIVER_NU, DENSITY, 0.0),
        )],
        vec![
            tool("left", grip, ContactModel::Sticky, ends(-0.008, -1.0)),
            tool("right", grip, ContactModel::Sticky, ends(0.008, 1.0)),
        ],
    );
    s.solver.max_substeps_per_frame = 20_000;
    StressCase {
        group: "scenario",
        name: "two tools pull apart 1.5×".into(),
        scene: s,
        duration: 0.5,
        in_envelope: true,
        energy_checked: true,
    }
}

/// A liver block dropped from 30 mm onto a table with friction.
fn drop_case() -> StressCase {
    let mut s = scene(
        "stress drop",
        60.0,
        domain(
            [-0.016, -0.016, 0.0],
            [0.032, 0.032, 0.048],
            0.002,
            [0.0, 0.0, -9.81],
        ),
        Some(Table {
            height: 0.004,
            hold: Hold::Resting,
            friction: 0.3,
        }),
        vec![tissue(
            [0.0, 0.0, 0.004 + 0.030 + 0.004],
            [0.012, 0.012, 0.008],
            material(LIVER_E, LIVER_NU, DENSITY, 0.0),
        )],
        Vec::new(),
    );
    s.solver.max_substeps_per_frame = 20_000;
    StressCase {
        group: "scenario",
        name: "dropped from 30 mm".into(),
        scene: s,
        duration: 0.3,
        in_envelope: true,
        energy_checked: true,
    }
}

/// The grasp scene's gripper grasping, lifting 4 mm, lowering and releasing, every 2 s.
fn soak_case(seconds: f64) -> StressCase {
    let mut scene = grasp_scene(0.1, 0.4, 0.8, 0.004);
    let gripper = &mut scene.tools[0];
    let cycle = gripper.keyframes.clone();
    let mut keys = Vec::new();
    let period = 2.0;
    let cycles = (seconds / period).ceil() as usize;
    for n in 0..cycles {
        let t0 = n as f64 * period;
        for k in &cycle {
            keys.push(key(t0 + k.t, k.position, k.rpy_deg, k.jaw_deg));
        }
        // Back down, then open.
        let down = cycle[2].position;
        keys.push(key(t0 + 1.2, down, cycle[2].rpy_deg, cycle[2].jaw_deg));
        keys.push(key(t0 + 1.6, down, cycle[0].rpy_deg, cycle[0].jaw_deg));
    }
    keys.dedup_by(|b, a| (a.t - b.t).abs() < 1e-9);
    gripper.keyframes = keys;
    scene.solver.max_substeps_per_frame = 20_000;
    StressCase {
        group: "soak",
        name: format!("periodic grasp, {} simulated", duration_label(seconds)),
        scene,
        duration: seconds,
        in_envelope: true,
        energy_checked: false,
    }
}

/// Total mechanical energy: kinetic + gravitational (relative to the origin) + elastic (J).
fn mechanical_energy(
    world: &World,
    materials: &[(dvrk_tissue_sim::mpm::MaterialModel, Lame)],
) -> f64 {
    let p = world.particles();
    let g: nalgebra::Vector3<f64> = nalgebra::Vector3::from(world.scene().domain.gravity);
    let mut e = p.kinetic_energy();
    for i in 0..p.len() {
        let (model, lame) = materials[p.material[i] as usize];
        e -= p.mass[i] as f64 * g.dot(&p.x[i].cast::<f64>());
        e += p.volume0[i] as f64 * energy_density(model, lame, &p.f[i]);
    }
    e
}

/// Runs one case; a guard stop ends the run and is reported, never propagated.
pub fn run_case(case: &StressCase) -> StressResult {
    let mut result = StressResult {
        group: case.group,
        name: case.name.clone(),
        in_envelope: case.in_envelope,
        particles: 0,
        simulated: 0.0,
        substeps: 0,
        wall_s: 0.0,
        energy_drift: 0.0,
        max_energy_gain: 0.0,
        energy_checked: case.energy_checked,
        max_penetration_cells: 0.0,
        escaped: 0,
        non_finite: 0,
        guard_events: 0,
        subdivided_frames: 0,
        failure: None,
    };
    let mut world = match World::try_new(&case.scene) {
        Ok(w) => w,
        Err(e) => {
            result.failure = Some(e.to_string());
            return result;
        }
    };
    let materials: Vec<_> = case
        .scene
        .tissues
        .iter()
        .map(|t| {
            (
                t.material.model,
                Lame::from_young_poisson(t.material.youngs_modulus, t.material.poisson_ratio),
            )
        })
        .collect();
    result.particles = world.particles().len();
    let dx = case.scene.domain.dx;
    let table = case.scene.table.as_ref().map(|t| t.height);
    let e_start = mechanical_energy(&world, &materials);
    // Energy scale: the tissue's weight times its own height, plus all tool work done.
    let mass = world.particles().total_mass();
    let height = case
        .scene
        .tissues
        .iter()
        .map(|t| t.size[2])
        .fold(0.0, f64::max);
    let weight_scale = mass * nalgebra::Vector3::from(case.scene.domain.gravity).norm() * height;
    let mut tool_work = 0.0;
    let mut tool_work_abs = 0.0;
    let start = Instant::now();
    let mut e_now = e_start;
    while world.time() < case.duration - 1e-9 {
        let t0 = world.time();
        let poses: Vec<_> = world.tools().iter().map(|t| t.pose_at(t0)).collect();
        match world.step_frame() {
            Ok(report) => {
                result.substeps += report.substeps as u64;
                result.escaped += report.clamped_particles as u64;
                if let Some(fixed) = case.scene.solver.dt {
                    // Without the CFL bound the frame would take equal substeps of at most
                    // `fixed`; anything shorter was cut to stay stable.
                    let planned = timestep::even_substep(world.frame_dt(), fixed);
                    if report.dt_max < planned * (1.0 - 1e-6) {
                        result.subdivided_frames += 1;
                    }
                }
                let elapsed = world.time() - t0;
                for ((tool, pose), wrench) in world.tools().iter().zip(&poses).zip(&report.wrenches)
                {
                    let v = ToolVelocity::between(pose, &tool.pose_at(world.time()), elapsed);
                    // The tissue feels the opposite of the tool's contact wrench.
                    let power = -(wrench.force.dot(&v.linear) + wrench.torque.dot(&v.angular));
                    tool_work += power * elapsed;
                    tool_work_abs += power.abs() * elapsed;
                }
            }
            Err(StepError::Guard { event, .. }) => {
                result.guard_events += 1;
                result.failure = Some(event.to_string());
                break;
            }
        }
        world.sync_particles();
        result.max_penetration_cells = result
            .max_penetration_cells
            .max(max_penetration(&world) / dx);
        let p = world.particles();
        result.non_finite = p
            .x
            .iter()
            .zip(&p.v)
            .filter(|(x, v)| !(x.iter().all(|c| c.is_finite()) && v.iter().all(|c| c.is_finite())))
            .count();
        if result.non_finite > 0 {
            break;
        }
        e_now = mechanical_energy(&world, &materials);
        let scale = (weight_scale + tool_work_abs).max(f64::MIN_POSITIVE);
        result.max_energy_gain = result
            .max_energy_gain
            .max((e_now - e_start - tool_work) / scale);
    }
    result.wall_s = start.elapsed().as_secs_f64();
    result.simulated = world.time();
    let scale = (weight_scale + tool_work_abs).max(f64::MIN_POSITIVE);
    result.energy_drift = (e_now - e_start - tool_work) / scale;
    if let Some(h) = table {
        let below = world
            .particles()
            .x
            .iter()
            .filter(|x| (x.z as f64) < h - dx)
            .count();
        result.escaped += below as u64;
    }
    result
}

/// Deepest particle inside any solid tool at the world's current time (m); curve tools
/// (the needle) act through a fattened contact band and are left out.
fn max_penetration(world: &World) -> f64 {
    let dx = world.scene().domain.dx as f32;
    let mut deepest = 0.0f32;
    for tool in world.tools() {
        if tool.shape.solid_thickness().is_none() {
            continue;
        }
        let pose = tool.pose_at(world.time());
        let k = ToolKinematics::new(
            tool.shape,
            tool.contact,
            &pose,
            &ToolVelocity::default(),
            dx,
        );
        for x in &world.particles().x {
            if let Some(hit) = k.probe(*x) {
                deepest = deepest.max(-hit.depth);
            }
        }
    }
    deepest as f64
}

/// Runs every case, calling `on_result` after each (for progress).
pub fn run(cases: &[StressCase], mut on_result: impl FnMut(&StressResult)) -> Vec<StressResult> {
    cases
        .iter()
        .map(|c| {
            let r = run_case(c);
            on_result(&r);
            r
        })
        .collect()
}

pub fn markdown(results: &[StressResult]) -> String {
    let mut out = String::from(
        "| group | case | envelope | stable | particles | simulated (s) | substeps | subdivided frames | energy drift | max energy gain | max penetration (cells) | escaped | non-finite | guard | wall (s) |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in results {
        let stable = match (&r.failure, r.stable()) {
            (Some(f), _) => format!("no: {f}"),
            (None, true) => "yes".to_owned(),
            (None, false) => "no".to_owned(),
        };
        let gain = if r.energy_checked {
            format!("{:+.3}", r.max_energy_gain)
        } else {
            format!("({:+.3})", r.max_energy_gain)
        };
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {:.2} | {} | {} | {:+.3} | {} | {:.2} | {} | {} | {} | {:.1} |",
            r.group,
            r.name,
            if r.in_envelope { "inside" } else { "outside" },
            stable,
            r.particles,
            r.simulated,
            r.substeps,
            r.subdivided_frames,
            r.energy_drift,
            gain,
            r.max_penetration_cells,
            r.escaped,
            r.non_finite,
            r.guard_events,
            r.wall_s,
        );
    }
    out
}

/// Cases inside the envelope that failed a check, one line each.
pub fn envelope_failures(results: &[StressResult]) -> Vec<String> {
    results
        .iter()
        .filter(|r| r.in_envelope && !r.stable())
        .map(|r| {
            let mut why = Vec::new();
            if let Some(f) = &r.failure {
                why.push(f.clone());
            }
            if r.non_finite > 0 {
                why.push(format!("{} non-finite particles", r.non_finite));
            }
            if r.escaped > 0 {
                why.push(format!("{} escaped particles", r.escaped));
            }
            if r.max_penetration_cells > MAX_PENETRATION_CELLS {
                why.push(format!(
                    "penetration {:.2} cells > {MAX_PENETRATION_CELLS}",
                    r.max_penetration_cells
                ));
            }
            if r.energy_checked && r.max_energy_gain > MAX_ENERGY_GAIN {
                why.push(format!(
                    "energy gain {:.3} > {MAX_ENERGY_GAIN}",
                    r.max_energy_gain
                ));
            }
            format!("{} / {}: {}", r.group, r.name, why.join(", "))
        })
        .collect()
}

/// `1000` → "1 kPa", `0.001` → "1 mm/s".
fn si(value: f64, unit: &str) -> String {
    let (scaled, prefix) = if value >= 1e6 {
        (value / 1e6, "M")
    } else if value >= 1e3 {
        (value / 1e3, "k")
    } else if value < 1e-2 {
        (value * 1e3, "m")
    } else {
        (value, "")
    };
    if unit == "m/s" && prefix.is_empty() && value < 1.0 {
        return format!("{} mm/s", value * 1e3);
    }
    format!("{scaled} {prefix}{unit}")
}

fn duration_label(seconds: f64) -> String {
    if seconds >= 60.0 {
        format!("{} min", seconds / 60.0)
    } else {
        format!("{seconds} s")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_case_scene_is_valid() {
        for case in cases(Matrix::Full) {
            let problems = dvrk_tissue_sim::config::validate(&case.scene);
            assert!(problems.is_empty(), "{}: {problems:?}", case.name);
        }
    }

    #[test]
    fn reduced_matrix_covers_every_group() {
        let reduced = cases(Matrix::Reduced);
        for group in [
            "material",
            "time step",
            "tool speed",
            "scenario",
            "soak",
            "implicit",
        ] {
            assert!(reduced.iter().any(|c| c.group == group), "{group}");
        }
        assert!(reduced.iter().all(|c| c.in_envelope));
        assert!(cases(Matrix::Full).len() > reduced.len());
    }

    #[test]
    fn labels_read_as_units() {
        assert_eq!(si(1e3, "Pa"), "1 kPa");
        assert_eq!(si(1e6, "Pa"), "1 MPa");
        assert_eq!(si(1e-3, "m/s"), "1 mm/s");
        assert_eq!(si(0.1, "m/s"), "100 mm/s");
        assert_eq!(si(1.0, "m/s"), "1 m/s");
        assert_eq!(duration_label(600.0), "10 min");
    }

    #[test]
    fn soak_repeats_its_grasp_cycle() {
        let case = soak_case(6.0);
        let keys = &case.scene.tools[0].keyframes;
        assert!(keys.windows(2).all(|w| w[1].t > w[0].t));
        let closed = keys.iter().filter(|k| k.jaw_deg < 30.0).count();
        assert!(closed >= 3 * 3, "{closed} closed keyframes");
        assert!(keys.last().unwrap().t <= 6.0);
    }

    #[test]
    fn a_failing_check_marks_the_case_unstable() {
        let mut r = run_case(&drop_case_short());
        assert!(r.stable(), "{r:?}");
        r.max_penetration_cells = MAX_PENETRATION_CELLS + 0.1;
        assert!(!r.stable());
        assert_eq!(envelope_failures(&[r]).len(), 1);
    }

    fn drop_case_short() -> StressCase {
        let mut c = drop_case();
        c.duration = 0.05;
        c
    }
}
