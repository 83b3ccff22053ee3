//! Stepping a rod: substeps of predict → iterations of (direct solve of every constraint,
//! contacts) → velocities from the corrections (XPBD, Macklin 2016/2019).

use super::constraints::Compliance;
use super::crossing::CrossingGuard;
use super::direct::{self, DirectScratch};
use super::environment::{
    project_contacts, project_walls, PlacedCollider, RodEnvironment, RodFrameReport,
};
use super::self_contact::SelfContacts;
use super::state::{Quat, Rod};
use crate::math::Vec3;
use nalgebra::Vector6;
use serde::{Deserialize, Serialize};

/// Least substeps per frame and iterations per substep.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RodSolverSettings {
    /// Substeps per frame (at least).
    pub substeps: u32,
    /// Direct-solve iterations per substep.
    pub iterations: u32,
}

impl Default for RodSolverSettings {
    /// One substep of two direct solves. The direct solve holds the length whatever the
    /// step (Macklin 2019's case for small steps is Gauss–Seidel's slow convergence, which
    /// the direct solve does not have): measured with `bench thread`, a swinging
    /// 1000-segment thread stretches 1.3e-5 at one substep, 6.3e-6 at two and 6.1e-6 at
    /// four (120 frames), against a 0.1 % budget, for a quarter of the cost of four.
    /// Scenes with fast tools or piles of thread may ask for more (`substeps` in a scene's
    /// `[[thread]]`). The second iteration corrects the f32 rounding of the first (see
    /// tests/thread.rs).
    fn default() -> Self {
        RodSolverSettings {
            substeps: 1,
            iterations: 2,
        }
    }
}

/// Most contact projection passes per iteration.
const CONTACT_PASSES: usize = 8;

/// Least substeps per frame while the thread can touch something (a table, a tool, itself).
/// The elastic solve is direct and needs no small steps, but contacts are projected one after
/// another, with friction measured from the substep's start and self-contact normals taken
/// there: at one substep a strand dragged at 1 m/s moves 17 mm (75 diameters of 3-0) between
/// those normals and was measured to pass through another (tests/thread.rs); four substeps
/// hold it.
pub const CONTACT_SUBSTEPS: u32 = 4;

/// Largest |C + α̃·λ| of any stretch-shear constraint (a strain) that ends a substep's
/// iterations out of contact once the set number is done; above it, more full solves follow (Newton), up to
/// `MAX_ITERATIONS`. A thread held at both ends and swinging through its sag was measured
/// to stretch 1.4 % after two iterations of one substep (the linearisation of a nearly taut
/// chord is poor far from the solution); a free thread stays far below the bound and pays
/// one residual evaluation. Half the 0.1 % length budget, and above the f32 rounding of a
/// segment's length (a 0.15 mm segment at 0.3 m from the origin: ~2e-4).
const RESIDUAL_TOLERANCE: f64 = 5e-4;

/// Most iterations per substep in contact, the extra ones included.
const CONTACT_ITERATIONS: u32 = 4;

/// Most iterations per substep, the extra ones included.
const MAX_ITERATIONS: u32 = 8;

/// Most iterations per substep with tissue bound to points ([`Rod::bindings`]), the extra
/// ones included. A bound point is about 10⁴–10⁶ times heavier across the thread than its
/// free neighbour where the thread leaves the tissue, and the linearised solve converges
/// slowly there. A thread through a 2 mm grid, its ends pulled 10 mm sideways
/// (`tests/thread_tissue.rs`), ended with its middle 4.31 mm across at most eight
/// iterations, 5.24 mm at sixteen and 5.26 mm at thirty-two.
const BOUND_ITERATIONS: u32 = 16;

/// Most direct solves that restore the length after a substep's contacts. One is not enough
/// where segments turned far in the substep (the frames enter the stretch-shear constraint
/// nonlinearly): measured on `stress`'s loop pulled shut, strain 8.0e-2 after one, 3.1e-5
/// after three or four.
const LENGTH_SOLVES: u32 = 4;

/// Closest approach, in diameters, that self-contact restores after the length solves
/// (during the rounds it keeps a full diameter). The band between it and a diameter is left
/// to the next substep's rounds, so that the last contact pass stretches the thread little.
/// Above `stress`'s bound of 0.9 diameters by a margin: a pile pressed down to this
/// separation ends some pairs an f32 rounding below it (`stress`'s coils, restored to 0.9,
/// measured 0.89999).
const RESTORED_SEPARATION: f32 = 0.95;

/// The solver for one rod: its compliances, multipliers and the previous substep's state.
#[derive(Clone, Debug)]
pub struct RodSolver {
    /// Substeps and iterations.
    pub settings: RodSolverSettings,
    /// Gravity, world frame, m/s².
    pub gravity: Vec3,
    compliance: Compliance,
    /// Per segment: stretch-shear multipliers, then the bend-twist ones of the joint after it.
    lambda: Vec<Vector6<f64>>,
    prev_points: Vec<Vec3>,
    prev_frames: Vec<Quat>,
    scratch: DirectScratch,
    /// Attached points' own inverse masses, restored after the frame.
    held: Vec<(usize, f32)>,
    /// This substep's colliders.
    placed: Vec<PlacedCollider>,
    self_contacts: SelfContacts,
    /// The multipliers of the solve → contact rounds, while the length is restored.
    round_lambda: Vec<Vector6<f64>>,
    /// The points as the contact rounds left them, before the length is restored.
    rounds_points: Vec<Vec3>,
    crossing_guard: CrossingGuard,
}

/// Whether the thread can touch anything in `env` (a table, a tool, itself).
fn touches(env: &RodEnvironment) -> bool {
    env.table_height.is_some() || !env.colliders.is_empty() || env.self_collision
}

impl RodSolver {
    /// A solver for `rod` at rest (zero multipliers), with `gravity` in m/s².
    pub fn new(rod: &Rod, settings: RodSolverSettings, gravity: Vec3) -> RodSolver {
        let n = rod.segments();
        RodSolver {
            settings,
            gravity,
            compliance: Compliance::of(rod),
            lambda: vec![Vector6::zeros(); n],
            prev_points: rod.points.clone(),
            prev_frames: rod.frames.clone(),
            scratch: DirectScratch::default(),
            held: Vec::new(),
            placed: Vec::new(),
            self_contacts: SelfContacts::default(),
            round_lambda: Vec::new(),
            rounds_points: Vec::new(),
            crossing_guard: CrossingGuard::default(),
        }
    }

    /// Advance `rod` by one frame of `dt` seconds in free space. The stretch-shear
    /// constraint is linear in the points, so the direct solve needs no limit on how far a
    /// point moves per substep (the distance constraint's linearisation did: it made cost
    /// grow with segments × speed).
    pub fn step_frame(&mut self, rod: &mut Rod, dt: f32) -> RodFrameReport {
        self.step_frame_in(rod, dt, &RodEnvironment::default())
    }

    /// Advance `rod` by one frame of `dt` seconds among the table, tools and grasps of `env`
    /// (see [`super::environment`]): substeps of predict → attachments to their targets →
    /// iterations of (direct solve of every elastic constraint, contacts) → velocities.
    pub fn step_frame_in(
        &mut self,
        rod: &mut Rod,
        dt: f32,
        env: &RodEnvironment,
    ) -> RodFrameReport {
        let substeps = if touches(env) {
            self.settings.substeps.max(CONTACT_SUBSTEPS)
        } else {
            self.settings.substeps.max(1)
        };
        self.step_in(rod, dt, env, substeps)
    }

    /// Advance `rod` by one substep of `dt` seconds in `env`: a tissue substep, inside which
    /// the thread and the tissue bound to it ([`Rod::bindings`]) step together (see
    /// [`crate::mpm::cpu::thread_contact`]). The tissue's substeps are short enough for
    /// contact's normals (a fraction of a millisecond).
    pub fn step_substep_in(
        &mut self,
        rod: &mut Rod,
        dt: f32,
        env: &RodEnvironment,
    ) -> RodFrameReport {
        self.step_in(rod, dt, env, 1)
    }

    fn step_in(
        &mut self,
        rod: &mut Rod,
        dt: f32,
        env: &RodEnvironment,
        substeps: u32,
    ) -> RodFrameReport {
        let touches = touches(env);
        let iterations = self.settings.iterations.max(1);
        let h = dt / substeps as f32;
        let inv_h2 = 1.0 / (h as f64 * h as f64);
        let mut report = RodFrameReport::default();
        // Attached points are held (inverse mass 0) for this frame only, moving at the
        // attachment's velocity, which they keep when released.
        self.held.clear();
        let count = rod.points.len();
        for a in env.attachments.iter().filter(|a| a.point < count) {
            self.held.push((a.point, rod.inv_mass[a.point]));
            rod.inv_mass[a.point] = 0.0;
            rod.points[a.point] = a.from;
            rod.velocities[a.point] = (a.to - a.from) / dt;
        }
        let table = env.table_height.map(|z| (z, env.table_friction));
        for k in 0..substeps {
            let (s0, s1) = (k as f64 / substeps as f64, (k + 1) as f64 / substeps as f64);
            self.placed.clear();
            self.placed.extend(
                env.colliders
                    .iter()
                    .map(|c| PlacedCollider::new(c, s0, s1, rod.material.radius)),
            );
            self.predict(rod, h, env.point_forces);
            for a in env.attachments.iter().filter(|a| a.point < count) {
                rod.points[a.point] = a.from.lerp(&a.to, s1 as f32);
            }
            self.lambda.fill(Vector6::zeros());
            let mut touched = false;
            // In contact, every iteration factorises afresh (the contacts projected after
            // each solve move points far from the last linearisation), and extra solve →
            // contact rounds follow while the length is off: contacts projected last
            // stretch the segments they push. A pair the solve pulls back through another is
            // caught by its start side, however far it went (`self_contact`).
            let most = if !rod.bindings.is_empty() {
                iterations.max(BOUND_ITERATIONS)
            } else if touches {
                iterations.max(CONTACT_ITERATIONS)
            } else {
                iterations.max(MAX_ITERATIONS)
            };
            for iteration in 0..most {
                let (compliance, lambda, scratch) =
                    (&self.compliance, &mut self.lambda, &mut self.scratch);
                if iteration >= iterations
                    && direct::stretch_residual(rod, compliance, lambda, inv_h2)
                        <= RESIDUAL_TOLERANCE
                {
                    break;
                }
                // Out of contact the first iteration factorises and the set ones after it
                // reuse that (a chord step, see `direct`); extra ones, for a residual still
                // too large, factorise afresh (Newton).
                let chord = !touches && iteration > 0 && iteration < iterations;
                if !(chord && direct::resolve(rod, compliance, lambda, inv_h2, scratch)) {
                    direct::solve(rod, compliance, lambda, inv_h2, scratch);
                    report.factorisations += 1;
                }
                let (found, any) = self.project_contacts(rod, env, table);
                touched |= any;
                if iteration == 0 {
                    report.table_contacts += found.0;
                    report.tool_contacts += found.1;
                    report.self_contacts += found.2;
                }
            }
            let mut held_back = 0;
            // The projection now sees a pair pulled through (`crossing`), but its
            // Gauss–Seidel passes push pairs one after another, and a pair pushed back may
            // push a neighbour through a third. The substep's start has no pair crossed:
            // where the move from there passes one through, it is scaled back (a fail-safe;
            // without it the soft laid knot of tests/scenes/knot_laid.toml pulled 70 mm a
            // side came undone).
            if env.self_collision {
                held_back +=
                    self.crossing_guard
                        .keep_sides(rod, &self.prev_points, &mut self.self_contacts);
            }
            if touched {
                self.rounds_points.clone_from(&rod.points);
                report.factorisations += self.restore_length(rod, inv_h2);
                // The restoring solves move the touching points too. Tools get the last word
                // (without it the solves pulled a thread back through a 0.3 mm wire pushing a
                // segment's middle, tests/thread.rs), and so do pairs of segments the solves
                // pulled through each other or closer than `RESTORED_SEPARATION` (without it
                // the tail of tests/scenes/coil_drag.toml crossed the coil; with crossed pairs
                // alone it came within 0.14 diameters). The table and pairs merely closer
                // than a diameter do not: all contacts projected again after the solves
                // stretched `stress`'s coil pile by 4.1e-2 and let the strand dragged in
                // tests/thread.rs end within a diameter of the one it pushed.
                if env.self_collision {
                    self.self_contacts.detect(rod, &self.prev_points);
                }
                for _ in 0..CONTACT_PASSES {
                    let (_, on_tools) =
                        project_contacts(rod, &self.prev_points, None, &self.placed);
                    let on_self = if env.self_collision {
                        self.self_contacts.project(
                            rod,
                            &self.prev_points,
                            env.self_friction,
                            RESTORED_SEPARATION,
                        )
                    } else {
                        0
                    };
                    if on_tools + on_self == 0 {
                        break;
                    }
                }
                // The restoring solves are free of contacts: they pulled 3-0 nylon in the
                // laid knot (tests/scenes/knot_laid.toml) through a bent joint in 639
                // substeps to 2.6 s. The pass above pushes such pairs back, one after
                // another; where the move from the rounds' end still passes a pair through,
                // it is scaled back too.
                if env.self_collision {
                    held_back += self.crossing_guard.keep_sides(
                        rod,
                        &self.rounds_points,
                        &mut self.self_contacts,
                    );
                }
            }
            if held_back > 0 {
                report.substeps_held_back += 1;
            }
            self.update_velocities(rod, h);
            self.update_tension(rod, inv_h2);
        }
        report.substeps = substeps;
        for &(point, inv_mass) in self.held.iter().rev() {
            rod.inv_mass[point] = inv_mass;
        }
        report.max_strain = (0..rod.segments())
            .map(|j| rod.strain(j).abs())
            .fold(0.0, f32::max);
        report
    }

    /// Every contact projected, in Gauss–Seidel passes until one finds nothing to correct
    /// (contacts in a pile, thread on thread on table, push each other back in). Returns
    /// the table, tool and self contacts the first pass found, and whether any pass moved a
    /// point.
    fn project_contacts(
        &mut self,
        rod: &mut Rod,
        env: &RodEnvironment,
        table: Option<(f32, f32)>,
    ) -> ((u32, u32, u32), bool) {
        // Self-contact candidates from the substep's start to where the solve put the
        // points: a strand pulled taut round another moves far beyond its prediction
        // (measured: 1.2 mm, five diameters, in one 4 ms substep of
        // tests/scenes/coil_drag.toml).
        if env.self_collision {
            self.self_contacts.detect(rod, &self.prev_points);
        }
        let mut found = (0, 0, 0);
        let mut any = false;
        for pass in 0..CONTACT_PASSES {
            let (on_table, on_tools) =
                project_contacts(rod, &self.prev_points, table, &self.placed);
            let on_walls = env.walls.map_or(0, |(lo, hi)| project_walls(rod, lo, hi));
            let on_self = if env.self_collision {
                self.self_contacts
                    .project(rod, &self.prev_points, env.self_friction, 1.0)
            } else {
                0
            };
            if pass == 0 {
                found = (on_table, on_tools, on_self);
            }
            if on_table + on_tools + on_self + on_walls == 0 {
                break;
            }
            any = true;
        }
        (found, any)
    }

    /// Direct solves after the substep's last contact projection, from zero multipliers,
    /// until the stretch residual is within `RESIDUAL_TOLERANCE` (at most `LENGTH_SOLVES`);
    /// returns how many.
    ///
    /// Contacts projected after the solve lengthen the segments they push, and the rounds'
    /// multipliers cannot take that back: table friction returns each point to where the
    /// solve moved it from (its slip is far below μ·d), so every round adds the same Δλ and
    /// the solve ends believing in a tension that the strain C = −α̃·λ then keeps (a final
    /// solve that kept them left `stress`'s loop 1.4 % long, frame after frame). Solved from
    /// λ = 0 the segments come back to their length.
    /// The points are free in these solves: holding the points that touch something along
    /// their contact normals (inverse mass w·(I − n·nᵀ)) stiffens a pile of coils against
    /// its own contacts until it blows up (`stress`'s coil drop). The tension reported is the
    /// sum of both sets of multipliers.
    ///
    /// Only the stretch-shear multipliers start from zero: the bend-twist ones keep the
    /// rounds' values. Solved from zero, a compliant bend-twist constraint finds its whole
    /// multiplier again and applies the bending impulse a second time in the substep, which
    /// stretches a hard-pulled knot (tests/scenes/knot_laid.toml) by orders of magnitude
    /// more than the length budget.
    fn restore_length(&mut self, rod: &mut Rod, inv_h2: f64) -> u32 {
        self.round_lambda.clone_from(&self.lambda);
        for lambda in &mut self.lambda {
            lambda.fixed_rows_mut::<3>(0).fill(0.0);
        }
        let mut solves = 0;
        for solve in 0..LENGTH_SOLVES {
            if solve > 0
                && direct::stretch_residual(rod, &self.compliance, &self.lambda, inv_h2)
                    <= RESIDUAL_TOLERANCE
            {
                break;
            }
            solves += 1;
            direct::solve(
                rod,
                &self.compliance,
                &mut self.lambda,
                inv_h2,
                &mut self.scratch,
            );
        }
        for (lambda, round) in self.lambda.iter_mut().zip(&self.round_lambda) {
            let mut stretch = lambda.fixed_rows_mut::<3>(0);
            stretch += round.fixed_rows::<3>(0);
        }
        solves
    }

    fn update_tension(&self, rod: &mut Rod, inv_h2: f64) {
        for j in 0..rod.segments() {
            // Jᵀ·λ/h² is the force: λ/(l·h²) on pⱼ₊₁, pulling it back along the segment
            // when stretched.
            let t = (rod.points[j + 1] - rod.points[j])
                .try_normalize(f32::EPSILON)
                .unwrap_or_else(|| rod.director(j))
                .cast::<f64>();
            let lambda = self.lambda[j].fixed_rows::<3>(0).into_owned();
            rod.tension[j] = (-lambda.dot(&t) * inv_h2 / rod.rest_lengths[j] as f64) as f32;
        }
    }

    /// Moves the points by their velocities after gravity, the rod's `external_forces` and
    /// the frame's `point_forces` (empty: none) act over `h`.
    fn predict(&mut self, rod: &mut Rod, h: f32, point_forces: &[Vec3]) {
        self.prev_points.clone_from(&rod.points);
        self.prev_frames.clone_from(&rod.frames);
        for i in 0..rod.points.len() {
            let w = rod.inv_mass[i];
            if w > 0.0 {
                let force =
                    rod.external_forces[i] + point_forces.get(i).copied().unwrap_or_default();
                if rod.is_bound(i) {
                    // The point and the tissue bound to it move as one across the thread;
                    // gravity acts on the point's own mass only (the tissue's weight is the
                    // tissue's to carry).
                    let a = rod.inverse_mass_matrix(i) * (self.gravity / w + force).cast::<f64>();
                    rod.velocities[i] += a.cast::<f32>() * h;
                } else {
                    rod.velocities[i] += (self.gravity + force * w) * h;
                }
                rod.points[i] += rod.velocities[i] * h;
            }
        }
        for j in 0..rod.segments() {
            if rod.inv_inertia[j] > 0.0 {
                // Isotropic inertia: no gyroscopic term, no external torque.
                super::state::add_rotation(&mut rod.frames[j], rod.angular_velocities[j] * h);
            }
        }
    }

    fn update_velocities(&mut self, rod: &mut Rod, h: f32) {
        let inv_h = 1.0 / h;
        for i in 0..rod.points.len() {
            if rod.inv_mass[i] > 0.0 {
                rod.velocities[i] = (rod.points[i] - self.prev_points[i]) * inv_h;
            }
        }
        for j in 0..rod.segments() {
            if rod.inv_inertia[j] > 0.0 {
                let mut dq = rod.frames[j] * self.prev_frames[j].conjugate();
                if dq.w < 0.0 {
                    dq = -dq;
                }
                rod.angular_velocities[j] = dq.imag() * (2.0 * inv_h);
            }
        }
    }
}
