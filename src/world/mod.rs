//! One scene's simulation: tissue, tools, time. `World::step_frame` advances one output
//! frame in as many CFL-bounded substeps as stability requires: MLS-MPM's bound is the
//! elastic wave and the material speed, PB-MPM's the material speed alone, under a substep
//! of `solver.dt` (default 1/240 s).

pub mod needle_body;
mod report;
mod step_params;
pub mod thread_body;
mod tool;
pub mod wound;

use crate::config::{Hold, Scene};
use crate::math::Vec3;
use crate::mpm::backend::{Backend, BackendChoice, CpuBackend};
use crate::mpm::cpu::thread_contact::{ThreadProxy, ThreadStepper};
use crate::mpm::cpu::CpuSolver;
use crate::mpm::frame_plan::{FramePart, FramePlan, FrameStats};
use crate::mpm::gpu::{self, GpuError, GpuSolver};
use crate::mpm::grid::{Boundary, GridLayout, TableHold};
use crate::mpm::guard::GuardPolicy;
use crate::mpm::Method;
use crate::mpm::SolveCounts;
use crate::mpm::{timestep, Lame, MaterialParams, Particles, PbMpmParams, SolverSetup};
use crate::sleep::SleepState;
use crate::tools::{JawCommand, Shape, ToolKinematics, ToolPose, ToolVelocity, Trajectory};
use crate::world::thread_body::grasp::GripperView;
use crate::world::thread_body::{ThreadBody, ToolsOverStep};
use nalgebra::Vector3;
use needle_body::{NeedleBody, Surroundings, TissueExchange};
pub use report::{CommandError, FrameReport, StepError, Wrench};
pub use step_params::StepParams;
use tool::Jaws;
pub use tool::{ToolDriver, WorldTool};

/// One scene's simulation: tissue on its backend, tools, threads and simulated time.
pub struct World {
    /// The scene this world was built from, for describing it (never read while stepping).
    scene: Scene,
    params: StepParams,
    backend: Backend,
    tools: Vec<WorldTool>,
    /// Simulated time (s).
    time: f64,
    last_max_speed: f32,
    /// Particles the scene's tissue starts with (splitting adds to them).
    scene_particles: usize,
    /// Under total Lagrangian MPM, the rest positions, on which [`World::pieces`] links the
    /// particles; `None` for the other methods, whose pieces are linked where they are now.
    rest_positions: Option<Vec<Vec3>>,
    warned_fixed_dt: bool,
    /// This frame's tool kinematics, substep-major (capacity reused across frames).
    kinematics: Vec<ToolKinematics>,
    sleep: SleepState,
    /// The frame begun and not finished yet.
    in_flight: Option<InFlight>,
    /// Suture threads, scene order; stepped with every frame, the tissue asleep or not.
    threads: Vec<ThreadBody>,
    /// Whether the frame being finished stepped the threads inside the tissue's substeps.
    threads_stepped_in_tissue: bool,
    /// The tools as the threads see them over their latest step (reused).
    thread_tools: ToolsOverStep,
    /// Seconds of the current frame each thread has stepped inside tissue (reused).
    thread_elapsed: Vec<f64>,
    /// Start time of the frame in flight (a skipped frame advances `time` when it begins).
    frame_start: f64,
}

/// A frame between `begin_frame` and `finish_frame`.
enum InFlight {
    /// The tissue sleeps: the frame's report is ready.
    Skipped(FrameReport),
    Stepped(PlannedFrame),
}

/// The schedule of a stepped frame.
struct PlannedFrame {
    t_start: f64,
    t_end: f64,
    dt: f64,
    substeps: u32,
    truncated: bool,
    /// A needle is free: the backend steps the frame one substep at a time, the needle
    /// moving between them (see [`needle_body`]).
    by_substep: bool,
}

impl PlannedFrame {
    /// What the backend runs; `kinematics` holds every substep's tool kinematics.
    fn plan<'a>(
        &self,
        gravity: Vec3,
        tool_count: usize,
        kinematics: &'a [ToolKinematics],
    ) -> FramePlan<'a> {
        FramePlan {
            dt: self.dt as f32,
            substeps: self.substeps,
            gravity,
            tool_count,
            tools: kinematics,
            part: FramePart::WHOLE,
        }
    }
}

/// Why a world could not be built.
#[derive(Debug, thiserror::Error)]
pub enum WorldError {
    #[error(transparent)]
    /// The GPU backend could not be set up.
    Gpu(#[from] GpuError),
}

/// The particles of `scene`'s tissue blocks at rest, block by block.
fn rest_particles(scene: &Scene) -> Particles {
    let dx = scene.domain.dx as f32;
    let mut particles = Particles::default();
    for (i, t) in scene.tissues.iter().enumerate() {
        let c = Vector3::from(t.center);
        let h = Vector3::from(t.size) * 0.5;
        particles.add_box(
            (c - h).cast(),
            (c + h).cast(),
            dx,
            t.particles_per_axis,
            t.material.density as f32,
            i as u16,
        );
    }
    particles
}

impl World {
    /// Builds the world of a validated scene on the backend its `solver.backend` asks for.
    ///
    /// # Panics
    /// When the scene asks for `backend = "gpu"` and no GPU adapter can be used; for scenes
    /// from user input use [`World::try_new`].
    pub fn new(scene: &Scene) -> Self {
        match Self::try_new(scene) {
            Ok(w) => w,
            Err(e) => panic!("{e}"),
        }
    }

    /// Builds the world of a validated scene on the backend its `solver.backend` asks for:
    /// `auto` never fails (it falls back to the CPU), `gpu` fails when no adapter works.
    pub fn try_new(scene: &Scene) -> Result<Self, WorldError> {
        let d = &scene.domain;
        let dx = d.dx as f32;
        let layout = GridLayout::new(
            Vector3::from(d.origin).cast(),
            Vector3::from(d.size).cast(),
            dx,
        );
        let particles = rest_particles(scene);
        let rest_positions = (scene.solver.method == Method::TlMpm).then(|| particles.x.clone());
        let mut materials = Vec::new();
        let mut wave_speed: f64 = 0.0;
        for t in &scene.tissues {
            let m = &t.material;
            let lame = Lame::from_young_poisson(m.youngs_modulus, m.poisson_ratio);
            wave_speed = wave_speed.max(lame.p_wave_speed(m.density));
            materials.push(MaterialParams {
                model: m.model,
                lame,
                density: m.density as f32,
                damping: m.damping as f32,
                toughness: m.toughness.unwrap_or(0.0) as f32,
            });
        }
        let boundary = Boundary {
            table: scene.table.as_ref().map(|t| {
                let hold = match t.hold {
                    Hold::Bonded => TableHold::Bonded,
                    Hold::Resting => TableHold::Resting {
                        friction: t.friction as f32,
                    },
                };
                (t.height as f32, hold)
            }),
        };
        let tools: Vec<WorldTool> = scene
            .tools
            .iter()
            .map(|t| WorldTool {
                name: t.name.clone(),
                shape: t.shape,
                contact: t.contact,
                jaws: matches!(t.shape, Shape::Gripper { .. }).then(|| {
                    let first = t.keyframes.first().map_or(0.0, |k| k.jaw_deg.to_radians());
                    Jaws::new(t.jaw, first)
                }),
                driver: ToolDriver::Scripted(Trajectory::new(
                    t.keyframes.iter().map(|k| (k.t, k.pose())).collect(),
                )),
                body: NeedleBody::new(
                    t.shape,
                    t.contact,
                    t.keyframes.first().map(|k| k.pose()).unwrap_or_default(),
                ),
            })
            .collect();
        let split = scene.solver.split_params(particles.len());
        let scene_particles = particles.len();
        let setup = SolverSetup {
            layout,
            particles,
            materials,
            boundary,
            max_speed: scene.solver.max_speed as f32,
            max_substeps: scene.solver.max_substeps_per_frame,
            tool_count: tools.len(),
            cutting: tools.iter().any(|t| t.shape.cuts()),
            p2g: scene.solver.p2g_atomics,
            method: scene.solver.method,
            pb_mpm: PbMpmParams {
                iterations: scene.solver.iterations,
                relaxation: scene.solver.relaxation as f32,
            },
            implicit: scene.solver.implicit_params(),
            split,
        };
        // A scene of threads alone has no tissue to step: its (empty) grid stays on the CPU.
        // Threads in tissue take `auto` to the CPU: the GPU backend couples them on the host,
        // reading its grid back every substep (`mpm::gpu::thread_grid`).
        let gpu_context = if setup.particles.is_empty() {
            None
        } else if !scene.threads.is_empty() && scene.solver.backend == BackendChoice::Auto {
            tracing::info!(
                "backend: cpu (auto: the GPU backend reads its grid back every substep for a \
                 thread in tissue; `backend = \"gpu\"` asks for it)"
            );
            None
        } else {
            match gpu::adapter::select(scene.solver.backend)? {
                Some(ctx) if scene.solver.backend == BackendChoice::Auto => {
                    match gpu::unsupported(&ctx, &setup) {
                        Some(feature) => {
                            tracing::info!("backend: cpu (auto: the GPU backend has no {feature})");
                            None
                        }
                        None => Some(ctx),
                    }
                }
                other => other,
            }
        };
        let backend = match gpu_context {
            Some(ctx) => {
                if setup.split.max_edge_cells > 0.0 {
                    tracing::warn!(
                        "the GPU backend does not split stretched particles \
                         (solver.split_max_edge_cells): tissue pulled past a cell per \
                         particle may part by numerics; `backend = \"cpu\"` splits them"
                    );
                }
                let shapes: Vec<_> = tools.iter().map(|t| t.shape).collect();
                Backend::Gpu(Box::new(GpuSolver::new(ctx, setup, &shapes)?))
            }
            None => Backend::Cpu(Box::new(CpuBackend::new(CpuSolver::new(setup)))),
        };
        Ok(World {
            rest_positions,
            scene: scene.clone(),
            params: StepParams::new(scene, wave_speed),
            last_max_speed: 0.0,
            scene_particles,
            backend,
            tools,
            time: 0.0,
            warned_fixed_dt: false,
            kinematics: Vec::new(),
            sleep: SleepState::default(),
            in_flight: None,
            frame_start: 0.0,
            threads: scene
                .threads
                .iter()
                .map(|t| ThreadBody::new(scene, t))
                .collect(),
            threads_stepped_in_tissue: false,
            thread_tools: ToolsOverStep::default(),
            thread_elapsed: Vec::new(),
        })
    }

    /// The scene's tissue at rest, as the world started: what a surface mesh binds to.
    pub fn rest_particles(&self) -> Particles {
        rest_particles(&self.scene)
    }

    /// Particles the scene's tissue started with; [`World::particles`] holds more once
    /// stretched particles split (see [`crate::mpm::split`]).
    pub fn scene_particles(&self) -> usize {
        self.scene_particles
    }

    /// The scene this world was built from.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// How this world steps.
    pub fn params(&self) -> &StepParams {
        &self.params
    }

    /// Simulated time (s).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The tools, scene order.
    pub fn tools(&self) -> &[WorldTool] {
        &self.tools
    }

    /// The suture threads, scene order.
    pub fn threads(&self) -> &[ThreadBody] {
        &self.threads
    }

    /// The suture threads, mutably (to move their held ends, see
    /// [`ThreadBody::move_anchor`]).
    pub fn threads_mut(&mut self) -> &mut [ThreadBody] {
        &mut self.threads
    }

    /// The solver backend stepping the tissue.
    pub fn backend(&self) -> &Backend {
        &self.backend
    }

    /// The backend, mutably (for tests and benchmarks that reach into its buffers).
    pub fn backend_mut(&mut self) -> &mut Backend {
        &mut self.backend
    }

    /// Particle state on the host (see [`Backend::particles`] for what is current on the
    /// GPU; call [`World::sync_particles`] for every field).
    pub fn particles(&self) -> &Particles {
        self.backend.particles()
    }

    /// Particle state for editing before the next frame (wakes the tissue).
    pub fn particles_mut(&mut self) -> &mut Particles {
        self.sleep.wake();
        self.backend.particles_mut()
    }

    /// Downloads every particle field from the GPU (nothing to do on the CPU).
    pub fn sync_particles(&mut self) {
        self.backend.sync_particles();
    }

    /// Whether each frame brings the deformation gradients to the host (see
    /// [`Backend::set_deformation_readback`]); outputs that colour by strain turn it on.
    pub fn set_deformation_readback(&mut self, on: bool) {
        self.backend.set_deformation_readback(on);
    }

    /// Separate tissue pieces: particles linked through neighbours within a cell, not
    /// across a cut and not through torn particles (see [`crate::mpm::pieces`]). Under
    /// total Lagrangian MPM, the pieces of the rest configuration: two particles that share
    /// grid nodes at rest interact however far they are pulled apart, so tissue stretched
    /// past a cell per particle is still one piece; only a tear, which takes the tension out
    /// of the particles between them, parts two neighbours at rest.
    pub fn pieces(&self) -> usize {
        let p = self.particles();
        // Total Lagrangian MPM does not cut: its particles carry no crack.
        let (x, crack) = match &self.rest_positions {
            Some(rest) => (&rest[..], &[][..]),
            None => (&p.x[..], &p.crack[..]),
        };
        crate::mpm::pieces::count_torn(x, crack, &p.damage, self.layout().dx)
    }

    /// The wound gap, m (see [`wound`]): the closest distance between a particle of the
    /// scene's first `wound` block and one of its second, less the first block's particle
    /// spacing; `None` in a scene without a `wound` or once either block has no particles.
    pub fn wound_gap(&self) -> Option<f32> {
        let sides = self.scene.wound.as_ref()?;
        let index = |name: &str| self.scene.tissues.iter().position(|t| t.name == name);
        let (first, second) = (index(&sides[0])?, index(&sides[1])?);
        let p = self.particles();
        let block = |index: usize| -> Vec<Vec3> {
            p.x.iter()
                .zip(&p.material)
                .filter(|(_, &m)| usize::from(m) == index)
                .map(|(x, _)| *x)
                .collect()
        };
        let gap = wound::closest_distance(&block(first), &block(second));
        let spacing =
            self.scene.domain.dx as f32 / self.scene.tissues[first].particles_per_axis as f32;
        gap.is_finite().then_some(gap - spacing)
    }

    /// The grid's origin, spacing and size.
    pub fn layout(&self) -> &GridLayout {
        self.backend.layout()
    }

    /// Length of one frame (s).
    pub fn frame_dt(&self) -> f64 {
        self.params.frame_dt
    }

    /// Largest stable substep given current particle and tool speeds: the elastic wave
    /// bounds MLS-MPM too, PB-MPM only the advection.
    pub fn stable_dt(&self, tool_speed: f64) -> f64 {
        let speed = (self.last_max_speed as f64).max(tool_speed);
        let p = &self.params;
        if p.implicit {
            return timestep::advection_dt(p.cfl, p.dx, speed, p.gravity.norm() as f64);
        }
        timestep::stable_dt(p.cfl, p.dx, p.bounding_wave_speed, speed)
    }

    /// Holds tool `index` still at `pose` until it is commanded again (an arm's tool starts
    /// where the arm is, not where the scene's keyframes are).
    pub fn hold_tool(&mut self, index: usize, pose: ToolPose) -> Result<(), CommandError> {
        self.drive_tool(index, Some(pose), pose, 0.0)
    }

    /// Makes tool `index` follow commanded poses: it reaches `pose` at the end of the next
    /// frame, moving smoothly from where it is now. Non-finite poses are refused.
    pub fn command_tool_pose(&mut self, index: usize, pose: ToolPose) -> Result<(), CommandError> {
        let frame_dt = self.frame_dt();
        self.drive_tool(index, None, pose, frame_dt)
    }

    /// Moves tool `index` linearly from `from` (where it is now when `None`) to `to` over
    /// `duration` seconds from now, so contact sees a smooth velocity.
    fn drive_tool(
        &mut self,
        index: usize,
        from: Option<ToolPose>,
        to: ToolPose,
        duration: f64,
    ) -> Result<(), CommandError> {
        let time = self.time;
        let tool = self
            .tools
            .get_mut(index)
            .ok_or(CommandError::NoSuchTool(index))?;
        if !to.is_finite() {
            return Err(CommandError::NonFinitePose(tool.name.clone()));
        }
        if let Some(jaws) = &mut tool.jaws {
            match from {
                // Held: the jaws are where the pose says.
                Some(held) => *jaws = Jaws::new(jaws.servo.gains, held.jaw),
                None => jaws.effort = None,
            }
        }
        let from = from.unwrap_or_else(|| tool.setpoint_at(time));
        tool.driver = ToolDriver::Commanded {
            from,
            to,
            t0: time,
            t1: time + duration,
        };
        Ok(())
    }

    /// Drives gripper `index`'s jaws with an effort (N·m, positive opens; dVRK's
    /// `jaw/servo_jf`) until the next pose command, or back to its position setpoint with
    /// `None`. The effort is clamped to the jaw's limit.
    pub fn command_jaw_effort(
        &mut self,
        index: usize,
        effort: Option<f64>,
    ) -> Result<(), CommandError> {
        let tool = self
            .tools
            .get_mut(index)
            .ok_or(CommandError::NoSuchTool(index))?;
        let name = tool.name.clone();
        let jaws = tool
            .jaws
            .as_mut()
            .ok_or(CommandError::NoJaws(name.clone()))?;
        if let Some(e) = effort {
            if !e.is_finite() {
                return Err(CommandError::NonFiniteEffort(name, e));
            }
        }
        let limit = jaws.servo.gains.effort_max;
        jaws.effort = effort.map(|e| e.clamp(-limit, limit));
        Ok(())
    }

    /// Moves every gripper's jaws over the frame [t_start, t_end] against the tissue's
    /// torque of the last frame, and sets the grip ratio the frame steps with.
    fn advance_jaws(&mut self, t_start: f64, t_end: f64) {
        let dx = self.params.dx;
        for tool in &mut self.tools {
            let setpoint = tool.setpoint_at(t_end).jaw;
            let (shape, contact) = (tool.shape, tool.contact);
            let Some(jaws) = &mut tool.jaws else {
                continue;
            };
            let command = match jaws.effort {
                Some(e) => JawCommand::Effort(e),
                None => JawCommand::Position(setpoint),
            };
            let start = jaws.servo.angle;
            jaws.servo
                .update(command, jaws.tissue_torque, t_end - t_start);
            jaws.span = (t_start, start, t_end, jaws.servo.angle);
            jaws.grip = jaws.grip_ratio(shape, contact, dx);
        }
    }

    /// Plans every needle's motion over the frame [t_start, t_end]: who carries it (its
    /// driver, a gripper closed on it, or nothing) and, free, where gravity, the table and
    /// its thread would take it without tissue: the frame's plan and the tissue's sleep
    /// see that; where the tissue steps, [`World::step_by_substep`] moves it with the
    /// tissue instead (see [`needle_body`]).
    fn advance_needles(&mut self, t_start: f64, t_end: f64) {
        if self.tools.iter().all(|t| t.body.is_none()) {
            return;
        }
        let grippers: Vec<GripperView> = self
            .tools
            .iter()
            .enumerate()
            .filter_map(|(i, t)| GripperView::of(i, t, t_start, t_end))
            .collect();
        let floor = self.floor();
        let gravity = self.params.gravity.cast::<f64>();
        for (i, tool) in self.tools.iter_mut().enumerate() {
            let (from, to) = (tool.setpoint_at(t_start), tool.setpoint_at(t_end));
            let Some(body) = &mut tool.body else {
                continue;
            };
            let around = Surroundings {
                gravity,
                floor,
                thread_pull: swage_pull(&self.threads, i),
            };
            body.advance(&from, &to, &grippers, &around, (t_start, t_end));
        }
    }

    /// Advances one frame: [`World::begin_frame`] then [`World::finish_frame`].
    pub fn step_frame(&mut self) -> Result<FrameReport, StepError> {
        self.begin_frame();
        self.finish_frame()
    }

    /// Plans the next frame and starts it. The frame's schedule is planned up front: dt from
    /// CFL with the previous frame's largest particle speed and the tools' speeds over the
    /// frame, equal substeps, and every substep's tool kinematics. On the GPU the frame is
    /// submitted and runs while this returns; until [`World::finish_frame`],
    /// [`World::particles`] still holds the previous frame, so its outputs can be built in
    /// the meantime. Give tool commands before this call, not between the two.
    ///
    /// # Panics
    /// When a frame is already in flight.
    pub fn begin_frame(&mut self) {
        assert!(
            self.in_flight.is_none(),
            "begin_frame called while a frame is in flight"
        );
        let frame_dt = self.frame_dt();
        let t_start = self.time;
        let t_end = t_start + frame_dt;
        self.frame_start = t_start;
        self.advance_jaws(t_start, t_end);
        self.advance_needles(t_start, t_end);
        if self.backend.particles().is_empty() {
            // No tissue: nothing for the grid to do; the threads step in `finish_frame`.
            self.time = t_end;
            self.in_flight = Some(InFlight::Skipped(self.report_without_tissue(t_end, false)));
            return;
        }
        if let Some(report) = self.skip_sleeping_frame(t_start, t_end) {
            self.in_flight = Some(InFlight::Skipped(report));
            return;
        }
        let planned = self.plan_frame(t_start, frame_dt);
        self.load_thread_proxies();
        if !planned.by_substep {
            let plan = planned.plan(self.params.gravity, self.tools.len(), &self.kinematics);
            self.backend.begin_frame(&plan);
        }
        self.in_flight = Some(InFlight::Stepped(planned));
    }

    /// Completes the frame [`World::begin_frame`] started (the CPU backend does its work
    /// here). With guard policy `stop`, a guard event restores the state at the start of the
    /// frame and returns the error; with `reset_tissue` the tissue goes back to rest and the
    /// frame ends early.
    ///
    /// # Panics
    /// When no frame is in flight.
    pub fn finish_frame(&mut self) -> Result<FrameReport, StepError> {
        let report = match self
            .in_flight
            .take()
            .expect("finish_frame called with no frame in flight")
        {
            InFlight::Skipped(report) => Ok(report),
            // Run the frame on a pool thread: parallel loops started there queue their tasks
            // on the worker's own deque instead of the pool's global injector, whose queue
            // grows in heap blocks (an allocation every few dozen calls from outside the pool).
            InFlight::Stepped(planned) => rayon::scope(|_| self.finish_stepped(planned)),
        };
        if report.is_ok() && !std::mem::take(&mut self.threads_stepped_in_tissue) {
            self.step_threads(self.frame_start, self.time);
        }
        report
    }

    /// Loads the threads into the grid's contact (see [`crate::mpm::cpu::thread_contact`])
    /// as they start the frame.
    fn load_thread_proxies(&mut self) {
        if self.threads.is_empty() {
            return;
        }
        let Some(proxies) = self.backend.load_threads(self.threads.len()) else {
            return;
        };
        for (thread, proxy) in self.threads.iter_mut().zip(proxies) {
            thread.load_proxy(proxy);
        }
    }

    /// Advances every thread over [t_start, t_end] with the grippers as they move then, in a
    /// frame the tissue did not step them.
    fn step_threads(&mut self, t_start: f64, t_end: f64) {
        if self.threads.is_empty() || t_end <= t_start {
            return;
        }
        self.thread_tools.fill(&self.tools, t_start, t_end);
        for thread in &mut self.threads {
            thread.step_frame(
                t_end - t_start,
                &self.thread_tools.colliders,
                &self.thread_tools.grippers,
            );
        }
    }

    /// Whether the tissue is asleep (frames are skipped until a tool comes near).
    pub fn is_asleep(&self) -> bool {
        self.sleep.is_asleep()
    }

    /// The report of a frame skipped because the tissue sleeps and no tool can reach it,
    /// or `None` (waking the tissue) when one can.
    fn skip_sleeping_frame(&mut self, t_start: f64, t_end: f64) -> Option<FrameReport> {
        let tissue = self.sleep.tissue_box()?;
        let dx = self.params.dx as f32;
        let frame_dt = (t_end - t_start) as f32;
        let gravity = self.params.gravity.norm();
        // A thread reaches the grid within its contact capsule (`thread_contact`): one
        // cell beyond its radius.
        let thread_margin = crate::mpm::cpu::thread_contact::REACH_CELLS * dx;
        if self
            .tools
            .iter()
            .any(|t| t.reach_between(t_start, t_end, dx).intersects(&tissue))
            || self.threads.iter().any(|thread| {
                let held_travel = self
                    .tools
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| thread.held_by(*i))
                    .map(|(_, t)| t.travel_between(t_start, t_end) as f32)
                    .fold(0.0, f32::max);
                thread
                    .reach_over(frame_dt, gravity, thread_margin, held_travel)
                    .intersects(&tissue)
            })
        {
            self.sleep.wake();
            return None;
        }
        self.time = t_end;
        Some(self.report_without_tissue(t_end, true))
    }

    /// The report of a frame ending at `t_end` in which the tissue did not step.
    fn report_without_tissue(&self, t_end: f64, asleep: bool) -> FrameReport {
        FrameReport {
            time: t_end,
            substeps: 0,
            dt_min: 0.0,
            dt_max: 0.0,
            wrenches: vec![Wrench::default(); self.tools.len()],
            contact_nodes: vec![0; self.tools.len()],
            max_speed: 0.0,
            clamped_particles: 0,
            truncated: false,
            tissue_reset: None,
            asleep,
            solve: SolveCounts::default(),
            split: Default::default(),
            max_stretch: 0.0,
            max_stretch_at: Vec3::zeros(),
        }
    }

    /// Chooses the frame's substep length and count and fills `kinematics` with every
    /// substep's tool kinematics.
    fn plan_frame(&mut self, t_start: f64, frame_dt: f64) -> PlannedFrame {
        let t_end = t_start + frame_dt;
        // Tool speed over the frame bounds dt like particle speed does.
        let tool_speed = self
            .tools
            .iter()
            .map(|t| {
                let v = ToolVelocity::between(&t.pose_at(t_start), &t.pose_at(t_end), frame_dt);
                v.linear.norm() + v.angular.norm() * t.shape.bounding_radius() as f64
            })
            .fold(0.0, f64::max);
        let mut dt_limit = self.stable_dt(tool_speed);
        if let Some(fixed) = self.params.requested_dt {
            if fixed > dt_limit {
                if self.params.dt_from_scene && !self.warned_fixed_dt {
                    tracing::warn!(
                        "solver.dt = {fixed:.3e} s exceeds the stable bound {dt_limit:.3e} s; subdividing"
                    );
                    self.warned_fixed_dt = true;
                }
            } else {
                dt_limit = fixed;
            }
        }
        let dt = timestep::even_substep(frame_dt, dt_limit);
        let needed = (frame_dt / dt).round().max(1.0) as u32;
        let max_substeps = self.params.max_substeps;
        let substeps = needed.min(max_substeps);
        let dx = self.params.dx as f32;
        self.kinematics.clear();
        for s in 0..substeps {
            let t0 = t_start + s as f64 * dt;
            for tool in &self.tools {
                let from = tool.pose_at(t0);
                let to = tool.pose_at(t0 + dt);
                let velocity = ToolVelocity::between(&from, &to, dt);
                let mut k = ToolKinematics::new(tool.shape, tool.contact, &from, &velocity, dx);
                k.grip = tool.jaws.as_ref().map_or(-1.0, |j| j.grip);
                self.kinematics.push(k);
            }
        }
        PlannedFrame {
            t_start,
            t_end,
            dt,
            substeps,
            truncated: needed > max_substeps,
            by_substep: self
                .tools
                .iter()
                .any(|t| t.body.as_ref().is_some_and(|b| b.is_free())),
        }
    }

    fn finish_stepped(&mut self, planned: PlannedFrame) -> Result<FrameReport, StepError> {
        let plan = planned.plan(self.params.gravity, self.tools.len(), &self.kinematics);
        // Threads the grid meets step inside its substeps; a guard event puts them back.
        let in_tissue = !self.threads.is_empty() && self.backend.thread_proxy(0).is_some();
        let threads_at_start = in_tissue.then(|| self.threads.clone());
        self.thread_elapsed.clear();
        self.thread_elapsed.resize(self.threads.len(), 0.0);
        let stats = if planned.by_substep {
            self.step_by_substep(&planned, in_tissue)
        } else {
            let mut stepper = ThreadsInTissue::over(
                &planned,
                &mut self.threads,
                &self.tools,
                &mut self.thread_tools,
                &mut self.thread_elapsed,
            );
            let threads = in_tissue.then_some(&mut stepper as &mut dyn ThreadStepper);
            self.backend.finish_frame(&plan, threads)
        };
        self.threads_stepped_in_tissue =
            in_tissue && stats.guard.is_none() && stats.substeps_done > 0;
        if let (Some(threads), Some(_)) = (threads_at_start, &stats.guard) {
            self.threads = threads;
        }
        let PlannedFrame {
            t_start,
            t_end,
            dt,
            substeps,
            truncated,
            ..
        } = planned;
        let dx = self.params.dx as f32;
        let mut report = FrameReport {
            time: t_start,
            substeps: stats.substeps_done,
            dt_min: dt,
            dt_max: dt,
            wrenches: Vec::new(),
            contact_nodes: Vec::new(),
            max_speed: stats.max_speed,
            clamped_particles: stats.clamped_particles,
            truncated,
            tissue_reset: None,
            asleep: false,
            solve: stats.solve,
            split: stats.split,
            max_stretch: stats.max_stretch,
            max_stretch_at: stats.max_stretch_at,
        };
        if let Some(event) = stats.guard {
            self.sleep.wake();
            self.backend.restore_frame_start();
            self.last_max_speed = 0.0;
            match self.params.guard_policy {
                GuardPolicy::Stop => {
                    self.time = t_start;
                    return Err(StepError::Guard {
                        time: self.time,
                        event,
                    });
                }
                GuardPolicy::ResetTissue => {
                    tracing::error!(
                        "t = {:.4} s: {event}; resetting the tissue to rest",
                        t_start + stats.substeps_done as f64 * dt
                    );
                    self.backend.reset_to_rest();
                    report.tissue_reset = Some(event);
                    self.time = t_end;
                }
            }
        } else {
            self.last_max_speed = stats.max_speed;
            let any_contact = stats.tool_impulses[..self.tools.len()]
                .iter()
                .any(|i| i.contact_nodes > 0);
            self.sleep.observe(
                &self.params.sleep,
                stats.max_speed,
                any_contact,
                &self.backend.particles().x,
                dx,
            );
            self.time = if truncated {
                t_start + substeps as f64 * dt
            } else {
                t_end
            };
        }
        let elapsed = (self.time - t_start).max(1e-12);
        report.time = self.time;
        let impulses = &stats.tool_impulses[..self.tools.len()];
        report.wrenches = impulses
            .iter()
            .map(|imp| Wrench {
                force: imp.linear / elapsed,
                torque: imp.angular / elapsed,
            })
            .collect();
        report.contact_nodes = impulses.iter().map(|i| i.contact_nodes).collect();
        if self.threads_stepped_in_tissue {
            for thread in &mut self.threads {
                thread.end_frame(elapsed);
            }
        }
        for (tool, imp) in self.tools.iter_mut().zip(impulses) {
            if let Some(jaws) = &mut tool.jaws {
                jaws.tissue_torque = imp.jaw_opening / elapsed;
                jaws.sums = imp.grip;
                jaws.sums_elapsed = elapsed;
            }
        }
        Ok(report)
    }
}

impl World {
    /// Steps the planned frame as one backend frame per substep, each free needle moving
    /// between them with the tissue's exchange of the substep before (see [`needle_body`]):
    /// a needle far lighter than the tissue it touches must meet it substep by substep, or
    /// the frame's lag makes it ring. Costs a backend frame's overhead per substep (on the
    /// GPU, a submission and a readback of the frame's statistics; the particles are read
    /// back after the last), only while a needle is free. A guard event puts the tissue
    /// back to the start of the frame, as in any other frame.
    fn step_by_substep(&mut self, planned: &PlannedFrame, in_tissue: bool) -> FrameStats {
        let tool_count = self.tools.len();
        let dx = self.params.dx as f32;
        let floor = self.floor();
        let gravity = self.params.gravity.cast::<f64>();
        let mut total = FrameStats::default();
        for s in 0..planned.substeps as usize {
            let t0 = planned.t_start + s as f64 * planned.dt;
            let span = (t0, t0 + planned.dt);
            for (i, tool) in self.tools.iter_mut().enumerate() {
                let Some(body) = tool.body.as_mut().filter(|b| b.is_free()) else {
                    continue;
                };
                let around = Surroundings {
                    gravity,
                    floor,
                    thread_pull: swage_pull(&self.threads, i),
                };
                let (from, to) = body.step_substep(&around, span, s == 0);
                let velocity = ToolVelocity::between(&from, &to, planned.dt);
                self.kinematics[s * tool_count + i] =
                    ToolKinematics::new(tool.shape, tool.contact, &from, &velocity, dx);
            }
            let plan = FramePlan {
                dt: planned.dt as f32,
                substeps: 1,
                gravity: self.params.gravity,
                tool_count,
                tools: &self.kinematics[s * tool_count..(s + 1) * tool_count],
                part: FramePart {
                    first: s == 0,
                    last: s + 1 == planned.substeps as usize,
                },
            };
            self.backend.begin_frame(&plan);
            let mut stepper = ThreadsInTissue::over(
                planned,
                &mut self.threads,
                &self.tools,
                &mut self.thread_tools,
                &mut self.thread_elapsed,
            );
            let threads = in_tissue.then_some(&mut stepper as &mut dyn ThreadStepper);
            let stats = self.backend.finish_frame(&plan, threads);
            for (tool, imp) in self.tools.iter_mut().zip(&stats.tool_impulses) {
                if let Some(body) = tool.body.as_mut().filter(|b| b.is_free()) {
                    body.record_tissue(TissueExchange {
                        linear: imp.linear,
                        angular: imp.angular,
                        contact_mass: imp.contact_mass,
                        contact_inertia: imp.contact_inertia,
                    });
                }
            }
            total.continue_with(&stats);
            if stats.guard.is_some() {
                break;
            }
        }
        total
    }

    /// Height a free needle rests on: the table's, or the domain's floor inside its walls.
    fn floor(&self) -> f64 {
        let layout = self.backend.layout();
        match &self.scene.table {
            Some(table) => table.height,
            None => (layout.origin.z + crate::mpm::grid::WALL_NODES as f32 * layout.dx) as f64,
        }
    }
}

/// The pull on needle `tool`'s swage end of the threads swaged to it, N.
fn swage_pull(threads: &[ThreadBody], tool: usize) -> nalgebra::Vector3<f64> {
    threads
        .iter()
        .filter(|thread| thread.swaged_to() == Some(tool))
        .map(ThreadBody::swage_pull)
        .sum()
}

/// The world's threads as the CPU's tissue substeps step them (see
/// [`crate::mpm::cpu::thread_contact`]), with the tools moving over each substep.
struct ThreadsInTissue<'a> {
    threads: &'a mut [ThreadBody],
    tools: &'a [WorldTool],
    /// The tools over the substep being stepped (reused).
    view: &'a mut ToolsOverStep,
    /// The frame's start and length, s.
    t_start: f64,
    frame_dt: f64,
    /// Seconds of the frame each thread has stepped.
    elapsed: &'a mut [f64],
}

impl<'a> ThreadsInTissue<'a> {
    /// The stepper for `planned`'s frame; the fields are the world's, borrowed apart from
    /// its backend, which calls the stepper.
    fn over(
        planned: &PlannedFrame,
        threads: &'a mut [ThreadBody],
        tools: &'a [WorldTool],
        view: &'a mut ToolsOverStep,
        elapsed: &'a mut [f64],
    ) -> Self {
        ThreadsInTissue {
            threads,
            tools,
            view,
            t_start: planned.t_start,
            frame_dt: planned.t_end - planned.t_start,
            elapsed,
        }
    }
}

impl ThreadStepper for ThreadsInTissue<'_> {
    fn step(&mut self, thread: usize, proxy: &mut ThreadProxy, dt: f32) {
        let t0 = self.t_start + self.elapsed[thread];
        let t1 = t0 + dt as f64;
        self.elapsed[thread] += dt as f64;
        let fraction = |t: f64| ((t - self.t_start) / self.frame_dt).clamp(0.0, 1.0) as f32;
        self.view.fill(self.tools, t0, t1);
        self.threads[thread].step_in_tissue(
            proxy,
            dt,
            (fraction(t0), fraction(t1)),
            &self.view.colliders,
            &self.view.grippers,
        );
    }
}
