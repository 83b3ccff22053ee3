//! A suture thread in the world: the rod (see [`crate::rod`]) with its solver, the ends the
//! scene holds, the table, domain walls and tools it meets, and the grippers holding it
//! ([`grasp`]). The world steps each thread once per frame through
//! [`RodSolver::step_frame_in`] with one [`RodEnvironment`] per frame, or, where the CPU's
//! tissue steps, once per tissue substep inside it ([`ThreadBody::step_in_tissue`]).
//!
//! [`crate::rod::knot`] tells whether its centreline is knotted.
//!
//! # A thread in a scene
//!
//! A `[[thread]]` table (keys in `config/README.md`) puts a rod in the world; every key but
//! `start` (or `points`) has a default, a 15 cm USP 3-0 nylon thread.
//! - **World**: each frame the thread's environment holds the table (its height, the thread's
//!   `friction`), the domain walls, every tool of the scene as a collider (its SDF at its poses
//!   at the frame's start and end; friction from its `contact`, 1.0 for `sticky`), the grasped
//!   and pinned points as attachments, and self-contact. The thread is stepped also while the
//!   tissue sleeps, and a scene without tissue skips the grid and runs on the CPU.
//! - **Tissue** ([`crate::mpm::cpu::thread_contact`]): in a scene with tissue the thread is
//!   two-way coupled to the MPM grid and steps inside the tissue's substeps. Inside the
//!   tissue each point carries the tissue around it across the thread (the thread slides
//!   along its channel, and a sideways pull drags the tissue); on the surface the nodes near
//!   a segment keep, relative to it, only their velocity along it (Coulomb
//!   `tissue_friction`, `tissue_drag`), and the momentum they lose comes to the rod's points
//!   as a force. The tissue does not sleep while a scene has threads. Explicit MLS-MPM or
//!   PIC on the CPU only (`check` refuses the others).
//! - **Grasping** ([`grasp`]): a gripper whose jaw servo presses the jaws shut (as for the
//!   tissue grip) with the tips no further apart than the thread's diameter catches every
//!   thread point inside the closed jaws' volume; each frame those points are attachments
//!   moving with the jaws from the frame's start to its end, let go with the jaws' velocity
//!   when the jaws stop pressing. `pinned` ends are attachments that stay put.
//! - **Swage**: a thread `swaged_to` a needle tool has its first point fixed in the needle's
//!   swage end ([`crate::tools::Shape::swage_end`]): each step that point is an attachment
//!   moving rigidly with the needle from its pose at the step's start to its pose at the
//!   end, so that the thread follows the needle's path through the tissue. The needle
//!   spares the points its wire covers at the swage (and one more), as a holding gripper
//!   spares the points between its jaws.
//! - **A gripper holding the thread** spares only the points it holds and their neighbours
//!   within a jaw thickness (one run along the thread, from the lowest held index to the
//!   highest): its jaws are pressed shut past the thread and would push those out again, but
//!   the rest of the thread still collides with it and cannot slide through the holding jaws.
//!   After it lets go the same points stay spared until its tips are further apart than a jaw
//!   is thick plus the thread's diameter.
//! - **Outputs**: `threads/<name>/centreline` (Marker LINE_STRIP in `world`) and
//!   `threads/<name>/tension` (PointCloud2 with the mean axial force at each point) at
//!   `[outputs] thread_rate_hz`, only while subscribed, and in bags; `snapshot` draws threads as
//!   tubes. The headless summary prints each thread's elongation, ends and grasped points, and
//!   its knot: `summary: knot thread <name>: det <d> (<the simplest knot with it>)`.
//! - **Knots** ([`crate::rod::knot`]): `knot_determinant(points)` is |Δ(−1)| (the Alexander polynomial at
//!   −1, from the Fox colouring matrix of a projection, an exact integer Bareiss determinant)
//!   of the centreline closed up on a sphere ten times its extent: 1 unknotted, 3 overhand
//!   (trefoil), 5 figure-eight, 9 square or granny.
//!
//! `config/thread.toml` (`cargo test --release --test thread_scene -- --nocapture`): the thread
//! lies on the table by 0.45 s, the jaws meet on it and catch 3 points, lifted 40 mm each half
//! droops within 0.5–1.5 × the cantilever answer qL⁴/(8EI) with the elongation below 0.1 %, and
//! opened it falls back. Through ROS (`rclpy_psm1_picks_up_the_thread_and_opening_drops_it`,
//! `tests/ros_node.rs`) PSM1 rolls a quarter turn (at home the jaws close along the thread),
//! inserts, closes, lifts 40 mm and opens, as a dVRK user would.
//!
//! # The tied knot
//!
//! `config/knot.toml`: two scripted grippers tie an overhand knot in a straight soft thread
//! (E = 0.1 GPa, 45 cm, 225 segments of 2 mm, 100 substeps of 3 direct solves a frame) lying on
//! the table, pull it tight, pull on both ends once more and hold. Gripper a lifts an arch;
//! b carries the tail over the arch's right leg and back under the left, through the loop,
//! while a lowers the arch so that the loop goes slack; a takes the standing part 140 mm
//! beyond the knot and both pull. `knot_toml_ties_an_overhand_knot_and_pulls_it_tight`
//! (`cargo test --release --test thread_scene knot_toml -- --nocapture`) asserts det 1 before
//! the tuck and det 3 from the tuck to the end, that no pair of segments within four diameters
//! passes through another in any frame (a knot made by a pass-through would not be tied), and
//! that the tightening pulls the loop's thread out of the knot (190 mm before the pull, 42 mm
//! tightened, 36 mm at the end) and closes it.
//!
//! What the tightening needs:
//! - **A short step.** At 32 substeps a frame the strands squeezed in the knot's core run
//!   nearly parallel 0.9 diameters apart and the knot comes undone; at 100 substeps (1/6000 s)
//!   it tightens with no pair flagged.
//! - **A long enough standing part.** With 78 mm of standing part the tightening drew it into
//!   the knot, which travelled into a's jaws; with 140 mm the loop's thread leaves the knot on
//!   both sides and it closes where it lies.
//! - **Length restoration that keeps the bend-twist multipliers**, and **contact passes that
//!   alternate their sweep order** (see [`crate::rod::self_contact`]): otherwise the bending
//!   impulse is applied twice in contact, and a hard pull slides the knot along the thread in
//!   the direction of its numbering.
//! - **Limits**: pulled to 85 mm a side the knot closes to about 13 mm of thread, as small as
//!   2 mm segments can draw; the ideal tight trefoil takes about 16.4 diameters of rope
//!   (Pieranski's tight knots), 3.3 mm of this thread. The same choreography does not tie 3-0
//!   nylon: its stiff standing part stands out sideways instead of arching.
//!
//! `tests/scenes/knot_laid.toml` starts from an open overhand knot laid on the table (det 3
//! from the first frame) and pulls its tails apart: it keeps self-contact's regression cases
//! on a knot whose start does not depend on a tying motion, in the soft thread, in 3-0 nylon
//! and pulled 70 mm a side (`cargo test --release --test thread_scene knot -- --nocapture`).

pub mod grasp;

use crate::config::thread::{swage_covered, RestShape};
use crate::config::{Scene, Thread};
use crate::math::Vec3;
use crate::mpm::cpu::thread_contact::ThreadProxy;
use crate::mpm::grid::WALL_NODES;
use crate::rod::{
    Binding, Rod, RodAttachment, RodCollider, RodEnvironment, RodFrameReport, RodSolver,
};
use crate::tools::{ContactModel, ToolPose};
use crate::world::WorldTool;
use grasp::{Grasps, GripperView};
use nalgebra::{Quaternion, Vector3};

/// Coulomb coefficient of a `sticky` tool against the thread: sticky contact holds the
/// tissue's nodes to the tool; for the thread it becomes a grip this strong, the rod's
/// friction being position based (static while the slip is below μ times the penetration).
const STICKY_TOOL_FRICTION: f32 = 1.0;

/// Tool `tool` as the thread sees it over [t0, t1]: its shape moving (jaws included) from
/// its pose at `t0` to its pose at `t1`.
pub fn tool_collider(tool: &WorldTool, t0: f64, t1: f64) -> RodCollider {
    RodCollider {
        shape: tool.shape,
        pose_start: tool.pose_at(t0),
        pose_end: tool.pose_at(t1),
        friction: match tool.contact {
            ContactModel::Coulomb { friction, .. } => friction,
            ContactModel::Sticky => STICKY_TOOL_FRICTION,
        },
        spared: None,
    }
}

/// A thread's first point fixed in a needle's swage end.
#[derive(Clone, Debug)]
struct Swage {
    /// Scene index of the needle tool.
    tool: usize,
    /// The swage end in the needle's frame, m.
    local: Vector3<f64>,
    /// The last point the needle's collision spares (those its wire covers, and one more).
    spared_to: usize,
}

/// The tools as the threads see them over one step [t0, t1]: the grippers that can hold a
/// thread and every tool as a collider. The world keeps one and refills it each step, so
/// stepping threads inside the tissue's substeps allocates nothing once warm.
#[derive(Default)]
pub struct ToolsOverStep {
    /// The tools with jaws, as a thread's grasps see them.
    pub grippers: Vec<GripperView>,
    /// Every tool, scene order, as the rod's contact sees it.
    pub colliders: Vec<RodCollider>,
}

impl ToolsOverStep {
    /// Refills the views with `tools` moving over [t0, t1].
    pub fn fill(&mut self, tools: &[WorldTool], t0: f64, t1: f64) {
        self.grippers.clear();
        self.grippers.extend(
            tools
                .iter()
                .enumerate()
                .filter_map(|(i, t)| GripperView::of(i, t, t0, t1)),
        );
        self.colliders.clear();
        self.colliders
            .extend(tools.iter().map(|t| tool_collider(t, t0, t1)));
    }
}

/// One thread and how it steps.
#[derive(Clone)]
pub struct ThreadBody {
    /// The thread's name in the scene.
    pub name: String,
    /// The thread's state.
    pub rod: Rod,
    solver: RodSolver,
    /// Points the scene holds: pinned where they start, or swaged to a needle.
    pinned: Vec<bool>,
    /// The needle the first point is swaged to, if any.
    swage: Option<Swage>,
    /// The scene's held points, where they are held, and where they are held next.
    anchors: Vec<(usize, Vec3, Vec3)>,
    /// Height of the table (m) and the Coulomb coefficient against it.
    table: Option<(f32, f32)>,
    /// The box the centreline stays inside: the domain less its wall cells and the radius.
    walls: (Vec3, Vec3),
    self_contact: bool,
    self_friction: f32,
    grasps: Grasps,
    /// This frame's attachments (grasped and pinned points); reused.
    attachments: Vec<RodAttachment>,
    /// This frame's colliders: every tool, a holding gripper sparing the points it holds;
    /// reused.
    colliders: Vec<RodCollider>,
    /// Coulomb coefficient and drag of tissue sliding along the thread.
    tissue_friction: f32,
    tissue_drag: f32,
    /// The tissue's force on each point, N: the contact's over the coming step while the
    /// tissue steps the rod, averaged over the frame after [`ThreadBody::end_frame`].
    tissue_force: Vec<Vec3>,
    /// The momentum the tissue gave each point since the frame began, N·s.
    frame_tissue_momentum: Vec<Vector3<f64>>,
    /// Points held (grasped or pinned) in the latest step.
    held: Vec<bool>,
    /// What the last frame's solve met (contacts, strain, crossings held back).
    last_report: RodFrameReport,
}

impl ThreadBody {
    /// The thread `config` of a validated `scene`.
    pub fn new(scene: &Scene, config: &Thread) -> ThreadBody {
        let laid = config
            .centreline()
            .expect("a validated thread has a centreline")
            .into_iter()
            .map(|p| nalgebra::Vector3::from(p).cast::<f32>())
            .collect();
        let mut rod = Rod::from_polyline(config.material(), laid);
        if config.rest_shape == RestShape::Straight {
            // Straight and untwisted at rest: the frames along a straight rod are all one.
            rod.rest_darboux.fill(Quaternion::identity());
        }
        let gravity = nalgebra::Vector3::from(scene.domain.gravity).cast::<f32>();
        let mut pinned = vec![false; rod.points.len()];
        let mut anchors = Vec::new();
        let last = rod.points.len() - 1;
        for (i, held) in [(0, config.pinned.start()), (last, config.pinned.end())] {
            if held {
                pinned[i] = true;
                anchors.push((i, rod.points[i], rod.points[i]));
            }
        }
        let swage = config.swaged_to.as_ref().map(|needle| {
            let (tool, shape) = scene
                .tools
                .iter()
                .enumerate()
                .find_map(|(i, t)| (&t.name == needle).then_some((i, t.shape)))
                .expect("a validated swage names a tool");
            let (local, _) = shape.swage_end().expect("a validated swage names a needle");
            let wire = match shape {
                crate::tools::Shape::Needle { wire_radius, .. } => wire_radius,
                _ => 0.0,
            };
            pinned[0] = true;
            Swage {
                tool,
                local: local.cast(),
                spared_to: (swage_covered(config, wire) + 1).min(last),
            }
        });
        let d = &scene.domain;
        let r = config.radius as f32;
        // Walls as the tissue sees them: the domain less its wall cells.
        let margin = WALL_NODES as f64 * d.dx;
        let lo = Vec3::from_fn(|a, _| (d.origin[a] + margin) as f32 + r);
        let hi = Vec3::from_fn(|a, _| (d.origin[a] + d.size[a] - margin) as f32 - r);
        let solver = RodSolver::new(&rod, config.solver_settings(), gravity);
        ThreadBody {
            name: config.name.clone(),
            rod,
            solver,
            anchors,
            table: scene
                .table
                .as_ref()
                .map(|t| (t.height as f32, config.friction as f32)),
            walls: (lo, hi),
            self_contact: config.self_contact,
            self_friction: config.self_friction as f32,
            grasps: Grasps::default(),
            attachments: Vec::new(),
            colliders: Vec::new(),
            tissue_friction: config.tissue_friction as f32,
            tissue_drag: config.tissue_drag as f32,
            tissue_force: vec![Vec3::zeros(); pinned.len()],
            frame_tissue_momentum: vec![Vector3::zeros(); pinned.len()],
            held: pinned.clone(),
            last_report: RodFrameReport::default(),
            pinned,
            swage,
        }
    }

    /// Advances one frame of `dt` seconds while the tools `colliders` (every tool of the
    /// scene, in scene order) and among them the grippers `grippers` move over it: first
    /// grasps begin or end (jaws closed on the thread catch the points between their faces;
    /// opening lets them go), then the rod steps among the table, walls and tools, the
    /// grasped points moving with their jaws and the pinned ones staying put. For a frame
    /// the tissue did not step (none in the scene, asleep, or reset).
    pub fn step_frame(&mut self, dt: f64, colliders: &[RodCollider], grippers: &[GripperView]) {
        self.tissue_force.fill(Vec3::zeros());
        self.frame_tissue_momentum.fill(Vector3::zeros());
        self.last_report = self.step(dt, (0.0, 1.0), colliders, grippers, false);
        self.end_frame(dt);
    }

    /// Loads `proxy` with the thread as the grid sees it at the start of a frame the tissue
    /// steps (see [`crate::mpm::cpu::thread_contact`]); the rod then steps inside the
    /// tissue's substeps ([`ThreadBody::step_in_tissue`]) until [`ThreadBody::end_frame`].
    pub fn load_proxy(&mut self, proxy: &mut ThreadProxy) {
        proxy.radius = self.rod.material.radius;
        proxy.friction = self.tissue_friction;
        proxy.drag = self.tissue_drag;
        self.show_to(proxy);
        proxy.start_frame();
        self.frame_tissue_momentum.fill(Vector3::zeros());
        self.last_report = RodFrameReport::default();
    }

    /// One tissue substep of `dt` seconds, the part `span` of the frame (start and end as
    /// fractions of it), with the tools `colliders` and `grippers` moving over the substep:
    /// the rod takes the contact's impulse in `proxy` as a force, steps with the tissue bound
    /// across its points (see [`crate::mpm::cpu::thread_contact`]), and leaves its state in
    /// `proxy` and the momentum each bound tissue gained in `proxy.push`.
    pub fn step_in_tissue(
        &mut self,
        proxy: &mut ThreadProxy,
        dt: f32,
        span: (f32, f32),
        colliders: &[RodCollider],
        grippers: &[GripperView],
    ) {
        for ((force, sum), j) in self
            .tissue_force
            .iter_mut()
            .zip(&mut self.frame_tissue_momentum)
            .zip(&proxy.impulse)
        {
            *force = (j / dt as f64).cast::<f32>();
            *sum += j;
        }
        self.bind_tissue(&proxy.bound_mass, &proxy.bound_velocity);
        let report = self.step(dt as f64, span, colliders, grippers, true);
        self.release_tissue(&proxy.bound_velocity, &mut proxy.push);
        for (sum, push) in self.frame_tissue_momentum.iter_mut().zip(&proxy.push) {
            *sum -= push.cast::<f64>();
        }
        let last = &mut self.last_report;
        last.table_contacts += report.table_contacts;
        last.tool_contacts += report.tool_contacts;
        last.self_contacts += report.self_contacts;
        last.substeps_held_back += report.substeps_held_back;
        last.substeps += report.substeps;
        last.factorisations += report.factorisations;
        last.max_strain = report.max_strain;
        self.show_to(proxy);
    }

    /// Ends a frame of `elapsed` seconds: the pinned points reach where they are held next,
    /// and the tissue's force over the frame is its momentum over `elapsed`.
    pub fn end_frame(&mut self, elapsed: f64) {
        for (_, at, next) in &mut self.anchors {
            *at = *next;
        }
        for (force, j) in self
            .tissue_force
            .iter_mut()
            .zip(&self.frame_tissue_momentum)
        {
            *force = (j / elapsed.max(1e-12)).cast::<f32>();
        }
    }

    /// The rod's points, velocities and inverse masses (0 where held: pinned, or grasped in
    /// its latest step) as the grid sees them.
    fn show_to(&self, proxy: &mut ThreadProxy) {
        let rod = &self.rod;
        proxy.points.clone_from(&rod.points);
        proxy.velocities.clone_from(&rod.velocities);
        proxy.inv_mass.clear();
        proxy.inv_mass.extend(
            rod.inv_mass
                .iter()
                .zip(&self.held)
                .map(|(&w, &held)| if held { 0.0 } else { w }),
        );
    }

    /// One step of `dt` seconds over the part `span` of the frame (the pinned points move
    /// that part of the way to where they are held next): grasps, attachments, colliders and
    /// the rod's solve, a frame's substeps (`in_tissue` false) or a tissue substep's one.
    fn step(
        &mut self,
        dt: f64,
        span: (f32, f32),
        colliders: &[RodCollider],
        grippers: &[GripperView],
        in_tissue: bool,
    ) -> RodFrameReport {
        let radius = self.rod.material.radius;
        self.grasps
            .update(&self.rod, grippers, radius, &self.pinned);
        self.attachments.clear();
        self.grasps.attachments(grippers, &mut self.attachments);
        self.attachments
            .extend(self.anchors.iter().map(|&(point, at, next)| RodAttachment {
                point,
                from: at.lerp(&next, span.0),
                to: at.lerp(&next, span.1),
            }));
        if let Some(swage) = &self.swage {
            let needle = &colliders[swage.tool];
            let at = |pose: &ToolPose| (pose.position + pose.rotation * swage.local).cast();
            self.attachments.push(RodAttachment {
                point: 0,
                from: at(&needle.pose_start),
                to: at(&needle.pose_end),
            });
        }
        // A gripper holding the thread holds the points between its jaws: those and their
        // neighbours (pressed against the jaws' sides and faces, within a jaw thickness along
        // the thread) move with it and are spared its collision, which would push them out
        // of the jaws shut past them. The rest of the thread still collides with it, so that
        // the thread cannot slide through the holding gripper.
        let reach = self.spared_neighbours(grippers);
        let last = self.rod.points.len() - 1;
        self.colliders.clear();
        self.colliders
            .extend(colliders.iter().enumerate().map(|(tool, c)| {
                let held = self
                    .grasps
                    .held_range(tool)
                    .map(|(lo, hi)| (lo.saturating_sub(reach), (hi + reach).min(last)));
                let swaged = self
                    .swage
                    .as_ref()
                    .filter(|s| s.tool == tool)
                    .map(|s| (0, s.spared_to));
                // A needle has no jaws and a gripper no swage: at most one applies.
                RodCollider {
                    spared: held.or(swaged),
                    ..*c
                }
            }));
        let env = RodEnvironment {
            table_height: self.table.map(|(z, _)| z),
            table_friction: self.table.map_or(0.0, |(_, mu)| mu),
            colliders: &self.colliders,
            attachments: &self.attachments,
            walls: Some(self.walls),
            point_forces: &self.tissue_force,
            self_collision: self.self_contact,
            self_friction: self.self_friction,
        };
        let report = if in_tissue {
            self.solver.step_substep_in(&mut self.rod, dt as f32, &env)
        } else {
            self.solver.step_frame_in(&mut self.rod, dt as f32, &env)
        };
        self.held.copy_from_slice(&self.pinned);
        for a in &self.attachments {
            if let Some(h) = self.held.get_mut(a.point) {
                *h = true;
            }
        }
        report
    }

    /// Binds the tissue across each free point (`mass`, kg, and `velocity`, m/s, per point;
    /// see [`crate::mpm::cpu::thread_contact`]) for the coming step, and the fraction
    /// `tissue_drag` of it along the thread: the point and its tissue meet at their common
    /// velocity (momentum kept) and move as one body ([`Rod::bindings`]).
    fn bind_tissue(&mut self, mass: &[f32], velocity: &[Vec3]) {
        let rod = &mut self.rod;
        rod.bindings.clear();
        if mass.iter().all(|&m| m <= 0.0) {
            return;
        }
        let n = rod.points.len();
        rod.bindings.resize(n, Binding::default());
        for i in 0..n {
            if mass[i] <= 0.0 || rod.inv_mass[i] <= 0.0 || self.held[i] {
                continue;
            }
            let (lo, hi) = (i.saturating_sub(1), (i + 1).min(n - 1));
            let Some(axis) = (rod.points[hi] - rod.points[lo]).try_normalize(f32::EPSILON) else {
                continue;
            };
            let binding = Binding {
                axis,
                mass: mass[i],
                along_mass: self.tissue_drag * mass[i],
            };
            let own = 1.0 / rod.inv_mass[i];
            let (v, tissue) = (rod.velocities[i], velocity[i]);
            let (along, across) = (binding.along(v), v - binding.along(v));
            let tissue_along = binding.along(tissue);
            let tissue_across = tissue - tissue_along;
            rod.velocities[i] = (across * own + tissue_across * binding.mass)
                / (own + binding.mass)
                + (along * own + tissue_along * binding.along_mass) / (own + binding.along_mass);
            rod.bindings[i] = binding;
        }
    }

    /// After a step with tissue bound: the momentum each bound tissue (bound with
    /// `velocity`) gained, its mass times the change of its velocity across the thread and
    /// its mass along it times the change along, into `push`; the bindings end.
    fn release_tissue(&mut self, velocity: &[Vec3], push: &mut [Vec3]) {
        push.fill(Vec3::zeros());
        for (i, b) in self.rod.bindings.iter().enumerate() {
            if !self.rod.is_bound(i) {
                continue;
            }
            let dv = self.rod.velocities[i] - velocity[i];
            let along = b.along(dv);
            push[i] = (dv - along) * b.mass + along * b.along_mass;
        }
        self.rod.bindings.clear();
    }

    /// What the last frame's solve met: contacts found, the largest strain, substeps whose
    /// moves were scaled back so that no strand passed through another.
    pub fn last_report(&self) -> RodFrameReport {
        self.last_report
    }

    /// The tissue's force on each point averaged over the last frame, N: the contact's and,
    /// where tissue was bound across the point, the bound tissue's reaction.
    pub fn tissue_force(&self) -> &[Vec3] {
        &self.tissue_force
    }

    /// Moves pinned point `point` linearly to `to` over the next frame (it stays there
    /// afterwards); false when the point is not pinned.
    pub fn move_anchor(&mut self, point: usize, to: Vec3) -> bool {
        match self.anchors.iter_mut().find(|a| a.0 == point) {
            Some(anchor) => {
                anchor.2 = to;
                true
            }
            None => false,
        }
    }

    /// How many neighbours on each side of a grasp are spared its gripper's collision: the
    /// points within the thickest jaw's thickness along the thread (at least one, the
    /// neighbour whose segment leaves the jaws).
    fn spared_neighbours(&self, grippers: &[GripperView]) -> usize {
        let thickness = grippers.iter().map(|g| g.jaw_thickness).fold(0.0, f32::max);
        let segment = self
            .rod
            .rest_lengths
            .iter()
            .copied()
            .fold(f32::MAX, f32::min);
        ((thickness / segment).ceil() as usize).max(1)
    }

    /// Current length over rest length, minus one.
    pub fn elongation(&self) -> f64 {
        self.rod.length() as f64 / self.rod.rest_length() as f64 - 1.0
    }

    /// The knot determinant of the centreline (see [`crate::rod::knot`]): 1 unknotted, 3 an overhand
    /// knot (trefoil).
    pub fn knot_determinant(&self) -> u128 {
        let points: Vec<_> = self.rod.points.iter().map(|p| p.cast::<f64>()).collect();
        crate::rod::knot::knot_determinant(&points)
    }

    /// Box that every point of the thread's surface can reach over a frame of `dt` seconds
    /// under `gravity`, when the grippers holding it travel at most `held_travel` in the
    /// frame: its points and its scene anchors' targets, grown by the radius, `margin`, the
    /// farthest any holder (gripper or anchor) travels, and twice the distance its fastest
    /// point would cover on its own. A thread cannot stretch, so a pull drags its points no
    /// farther than the holder moves (they trail behind it); what they move beyond that
    /// comes from their own speed and gravity, where the factor 2 covers the constraint
    /// solve speeding a slack stretch up within the frame.
    pub fn reach_over(
        &self,
        dt: f32,
        gravity: f32,
        margin: f32,
        held_travel: f32,
    ) -> crate::sleep::Aabb {
        let points = crate::sleep::Aabb::of_points(&self.rod.points);
        let reach = self
            .anchors
            .iter()
            .fold(points, |b, (_, _, next)| b.including(next));
        let pull = self
            .anchors
            .iter()
            .map(|(_, at, next)| (next - at).norm())
            .fold(held_travel, f32::max);
        let speed = self
            .rod
            .velocities
            .iter()
            .map(|v| v.norm())
            .fold(0.0, f32::max);
        let travel = pull + 2.0 * (speed + gravity * dt) * dt;
        reach.grown(self.rod.material.radius + margin + travel)
    }

    /// Points held by grippers now.
    pub fn grasped_points(&self) -> usize {
        self.grasps.held_points()
    }

    /// The scene index of the needle this thread is swaged to, if any.
    pub fn swaged_to(&self) -> Option<usize> {
        self.swage.as_ref().map(|s| s.tool)
    }

    /// The thread's pull on its swage end (N, world frame): its first segment's tension
    /// along that segment, away from the swage; zero when the segment is slack.
    pub fn swage_pull(&self) -> Vector3<f64> {
        let (Some(&tension), [first, second, ..]) =
            (self.rod.tension.first(), &self.rod.points[..])
        else {
            return Vector3::zeros();
        };
        let along = (second - first).cast::<f64>();
        along.try_normalize(1e-12).unwrap_or_default() * tension.max(0.0) as f64
    }

    /// Whether tool `tool` holds any of this thread.
    pub fn held_by(&self, tool: usize) -> bool {
        self.grasps.holds_with(tool) || self.swage.as_ref().is_some_and(|s| s.tool == tool)
    }
}
