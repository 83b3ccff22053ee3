//! One scene's simulation: tissue, tools, time. `World::step_frame` advances one output
//! frame in as many CFL-bounded substeps as stability requires.

use crate::config::{Hold, Scene};
use crate::mpm::cpu::{CpuSolver, SubstepInput};
use crate::mpm::grid::{Boundary, GridLayout, TableHold};
use crate::mpm::guard::{GuardEvent, GuardPolicy};
use crate::mpm::{timestep, Lame, MaterialParams, Particles, ToolImpulse, Vec3};
use crate::tools::{ContactModel, Shape, ToolKinematics, ToolPose, ToolVelocity, Trajectory};
use nalgebra::{UnitQuaternion, Vector3};

/// Force (N) and torque (N·m) a tool receives from the tissue: world frame, torque about
/// the tool frame origin, averaged over a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Wrench {
    pub force: Vector3<f64>,
    pub torque: Vector3<f64>,
}

impl Wrench {
    /// The same wrench expressed in the tool frame (rotation = world-from-tool).
    pub fn in_tool_frame(&self, rotation: &UnitQuaternion<f64>) -> Wrench {
        Wrench {
            force: rotation.inverse_transform_vector(&self.force),
            torque: rotation.inverse_transform_vector(&self.torque),
        }
    }
}

/// What one frame did.
#[derive(Clone, Debug)]
pub struct FrameReport {
    /// Simulated time at the end of the frame (s).
    pub time: f64,
    pub substeps: u32,
    pub dt_min: f64,
    pub dt_max: f64,
    /// Per tool, scene order.
    pub wrenches: Vec<Wrench>,
    /// Contact nodes per tool, summed over the frame's substeps.
    pub contact_nodes: Vec<u32>,
    pub max_speed: f32,
    pub clamped_particles: u32,
    /// The frame hit `max_substeps_per_frame` and advanced less than a frame of time.
    pub truncated: bool,
    /// Guard event that reset the tissue during this frame (policy `reset_tissue`).
    pub tissue_reset: Option<GuardEvent>,
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum CommandError {
    #[error("no tool with index {0}")]
    NoSuchTool(usize),
    #[error("tool {0}: commanded pose is not finite; keeping the last valid one")]
    NonFinitePose(String),
}

#[derive(Debug, thiserror::Error)]
pub enum StepError {
    #[error(
        "simulation stopped at t = {time:.4} s: {event}; tissue restored to the last good frame"
    )]
    Guard { time: f64, event: GuardEvent },
}

/// What moves a tool.
#[derive(Clone, Debug, PartialEq)]
pub enum ToolDriver {
    /// The scene's keyframes (headless runs).
    Scripted(Trajectory),
    /// Poses commanded from outside (an arm's kinematics): the tool moves from `from` at
    /// `t0` to `to` at `t1` (one frame), linearly, so contact sees a smooth velocity.
    Commanded {
        from: ToolPose,
        to: ToolPose,
        t0: f64,
        t1: f64,
    },
}

/// A tool in the world and what drives it.
pub struct WorldTool {
    pub name: String,
    pub shape: Shape,
    pub contact: ContactModel,
    pub driver: ToolDriver,
}

impl WorldTool {
    pub fn pose_at(&self, t: f64) -> ToolPose {
        match &self.driver {
            ToolDriver::Scripted(trajectory) => trajectory.sample(t),
            ToolDriver::Commanded { from, to, t0, t1 } => {
                let s = if t1 > t0 {
                    ((t - t0) / (t1 - t0)).clamp(0.0, 1.0)
                } else {
                    1.0
                };
                from.lerp(to, s)
            }
        }
    }
}

pub struct World {
    pub scene: Scene,
    pub solver: CpuSolver,
    pub tools: Vec<WorldTool>,
    /// Simulated time (s).
    pub time: f64,
    gravity: Vec3,
    /// Fastest elastic wave of any material (m/s), for the CFL bound.
    wave_speed: f64,
    last_max_speed: f32,
    rest: Particles,
    last_good: Particles,
    warned_fixed_dt: bool,
    kinematics: Vec<ToolKinematics>,
}

impl World {
    /// Builds the world of a validated scene.
    pub fn new(scene: &Scene) -> Self {
        let d = &scene.domain;
        let dx = d.dx as f32;
        let layout = GridLayout::new(
            Vector3::from(d.origin).cast(),
            Vector3::from(d.size).cast(),
            dx,
        );
        let mut particles = Particles::default();
        let mut materials = Vec::new();
        let mut wave_speed: f64 = 0.0;
        for (i, t) in scene.tissues.iter().enumerate() {
            let m = &t.material;
            let lame = Lame::from_young_poisson(m.youngs_modulus, m.poisson_ratio);
            wave_speed = wave_speed.max(lame.p_wave_speed(m.density));
            materials.push(MaterialParams {
                model: m.model,
                lame,
                density: m.density as f32,
                damping: m.damping as f32,
            });
            let c = Vector3::from(t.center);
            let h = Vector3::from(t.size) * 0.5;
            particles.add_box(
                (c - h).cast(),
                (c + h).cast(),
                dx,
                t.particles_per_axis,
                m.density as f32,
                i as u16,
            );
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
        let tools = scene
            .tools
            .iter()
            .map(|t| WorldTool {
                name: t.name.clone(),
                shape: t.shape,
                contact: t.contact,
                driver: ToolDriver::Scripted(Trajectory::new(
                    t.keyframes
                        .iter()
                        .map(|k| {
                            let [r, p, y] = k.rpy_deg.map(f64::to_radians);
                            let pose = ToolPose {
                                position: Vector3::from(k.position),
                                rotation: UnitQuaternion::from_euler_angles(r, p, y),
                                jaw: k.jaw_deg.to_radians(),
                            };
                            (k.t, pose)
                        })
                        .collect(),
                )),
            })
            .collect();
        let solver = CpuSolver::new(
            layout,
            particles.clone(),
            materials,
            boundary,
            scene.solver.max_speed as f32,
        );
        World {
            scene: scene.clone(),
            gravity: Vector3::from(d.gravity).cast(),
            wave_speed,
            last_max_speed: 0.0,
            last_good: particles.clone(),
            rest: particles,
            solver,
            tools,
            time: 0.0,
            warned_fixed_dt: false,
            kinematics: Vec::with_capacity(crate::mpm::MAX_TOOLS),
        }
    }

    pub fn particles(&self) -> &Particles {
        &self.solver.particles
    }

    /// Length of one frame (s).
    pub fn frame_dt(&self) -> f64 {
        1.0 / self.scene.frame_rate_hz
    }

    /// Largest stable substep given current particle and tool speeds.
    pub fn stable_dt(&self, tool_speed: f64) -> f64 {
        let speed = (self.last_max_speed as f64).max(tool_speed);
        timestep::stable_dt(
            self.scene.solver.cfl,
            self.scene.domain.dx,
            self.wave_speed,
            speed,
        )
    }

    /// Makes tool `index` follow commanded poses: it reaches `pose` at the end of the next
    /// frame, moving smoothly from where it is now. Non-finite poses are refused.
    pub fn command_tool_pose(&mut self, index: usize, pose: ToolPose) -> Result<(), CommandError> {
        let frame_dt = self.frame_dt();
        let tool = self
            .tools
            .get_mut(index)
            .ok_or(CommandError::NoSuchTool(index))?;
        if !pose.is_finite() {
            return Err(CommandError::NonFinitePose(tool.name.clone()));
        }
        let now = tool.pose_at(self.time);
        tool.driver = ToolDriver::Commanded {
            from: now,
            to: pose,
            t0: self.time,
            t1: self.time + frame_dt,
        };
        Ok(())
    }

    /// Advances one frame. With guard policy `stop`, a guard event restores the state at the
    /// start of the frame and returns the error; with `reset_tissue` the tissue goes back to
    /// rest and the frame ends early.
    pub fn step_frame(&mut self) -> Result<FrameReport, StepError> {
        // Run the frame on a pool thread: parallel loops started there queue their tasks on
        // the worker's own deque instead of the pool's global injector, whose queue grows
        // in heap blocks (an allocation every few dozen calls from outside the pool).
        rayon::scope(|_| self.step_frame_on_pool())
    }

    fn step_frame_on_pool(&mut self) -> Result<FrameReport, StepError> {
        let frame_dt = self.frame_dt();
        let t_end = self.time + frame_dt;
        let t_start = self.time;
        self.last_good.copy_state_from(&self.solver.particles);
        let mut impulses = [ToolImpulse::default(); crate::mpm::MAX_TOOLS];
        let mut report = FrameReport {
            time: self.time,
            substeps: 0,
            dt_min: f64::INFINITY,
            dt_max: 0.0,
            wrenches: Vec::new(),
            contact_nodes: Vec::new(),
            max_speed: 0.0,
            clamped_particles: 0,
            truncated: false,
            tissue_reset: None,
        };
        let dx = self.scene.domain.dx as f32;
        while t_end - self.time > 1e-9 * frame_dt {
            if report.substeps >= self.scene.solver.max_substeps_per_frame {
                report.truncated = true;
                break;
            }
            let remaining = t_end - self.time;
            // Tool speed over the rest of the frame bounds dt like particle speed does.
            let tool_speed = self
                .tools
                .iter()
                .map(|t| {
                    let v =
                        ToolVelocity::between(&t.pose_at(self.time), &t.pose_at(t_end), remaining);
                    v.linear.norm() + v.angular.norm() * t.shape.bounding_radius() as f64
                })
                .fold(0.0, f64::max);
            let mut dt_limit = self.stable_dt(tool_speed);
            if let Some(fixed) = self.scene.solver.dt {
                if fixed > dt_limit {
                    if !self.warned_fixed_dt {
                        tracing::warn!(
                            "solver.dt = {fixed:.3e} s exceeds the stable bound {dt_limit:.3e} s; subdividing"
                        );
                        self.warned_fixed_dt = true;
                    }
                } else {
                    dt_limit = fixed;
                }
            }
            let dt = timestep::even_substep(remaining, dt_limit);
            // Reuses the buffer's capacity: no allocation per substep.
            self.kinematics.clear();
            for tool in &self.tools {
                let from = tool.pose_at(self.time);
                let to = tool.pose_at(self.time + dt);
                let velocity = ToolVelocity::between(&from, &to, dt);
                self.kinematics.push(ToolKinematics::new(
                    tool.shape,
                    tool.contact,
                    &from,
                    &velocity,
                    dx,
                ));
            }
            let stats = self.solver.substep(&SubstepInput {
                dt: dt as f32,
                gravity: self.gravity,
                tools: &self.kinematics,
            });
            if let Some(event) = stats.guard {
                self.solver.particles.copy_state_from(&self.last_good);
                self.last_max_speed = 0.0;
                match self.scene.solver.guard_policy {
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
                            self.time
                        );
                        self.solver.particles.copy_state_from(&self.rest);
                        report.tissue_reset = Some(event);
                        self.time = t_end;
                        break;
                    }
                }
            }
            for (acc, imp) in impulses.iter_mut().zip(&stats.tool_impulses) {
                acc.add(imp);
            }
            self.last_max_speed = stats.max_speed;
            report.max_speed = report.max_speed.max(stats.max_speed);
            report.clamped_particles += stats.clamped_particles;
            report.substeps += 1;
            report.dt_min = report.dt_min.min(dt);
            report.dt_max = report.dt_max.max(dt);
            self.time += dt;
        }
        let elapsed = (self.time - t_start).max(1e-12);
        report.time = self.time;
        report.wrenches = impulses[..self.tools.len()]
            .iter()
            .map(|imp| Wrench {
                force: imp.linear / elapsed,
                torque: imp.angular / elapsed,
            })
            .collect();
        report.contact_nodes = impulses[..self.tools.len()]
            .iter()
            .map(|i| i.contact_nodes)
            .collect();
        Ok(report)
    }
}
