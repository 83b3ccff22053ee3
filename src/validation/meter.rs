//! Wall time and work of the frames a benchmark runs, measured around `World::step_frame`
//! only (probes that read the state between frames are not solver cost).

use crate::world::{FrameReport, StepError, World};
use std::time::{Duration, Instant};

#[derive(Clone, Debug, Default)]
/// Work and wall time of the frames stepped through it, summed.
pub struct Meter {
    /// Frames stepped (failed ones included).
    pub frames: u64,
    /// Substeps of the frames that succeeded.
    pub substeps: u64,
    /// Particles and backend of the last world stepped.
    pub particles: usize,
    /// Backend name of the last world stepped (`cpu` or `gpu`).
    pub backend: &'static str,
    /// Simulated time advanced (s).
    pub simulated: f64,
    /// Wall time inside `World::step_frame`, failed frames included.
    pub wall: Duration,
    /// Newton and CG iterations of the implicit solver, summed over the frames.
    pub newton: u64,
    /// CG iterations of the implicit solver, summed over the frames.
    pub cg: u64,
}

impl Meter {
    /// Steps `world` one frame and counts it.
    pub fn step(&mut self, world: &mut World) -> Result<FrameReport, StepError> {
        let t0 = world.time();
        let start = Instant::now();
        let result = world.step_frame();
        self.wall += start.elapsed();
        self.frames += 1;
        self.particles = world.particles().len();
        self.backend = world.backend().name();
        if let Ok(report) = &result {
            self.substeps += report.substeps as u64;
            self.newton += report.solve.newton as u64;
            self.cg += report.solve.cg as u64;
            self.simulated += world.time() - t0;
        }
        result
    }

    /// Particles × substeps: the work measure benchmarks divide the wall time by.
    pub fn particle_substeps(&self) -> f64 {
        self.particles as f64 * self.substeps as f64
    }

    /// Particle-substeps per wall-clock second.
    pub fn rate(&self) -> f64 {
        self.particle_substeps() / self.wall.as_secs_f64().max(1e-12)
    }

    /// Simulated seconds per wall-clock second (1: real time).
    pub fn realtime_factor(&self) -> f64 {
        self.simulated / self.wall.as_secs_f64().max(1e-12)
    }
}
