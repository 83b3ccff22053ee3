//! How a world steps, fixed when it is built from its scene.

use crate::config::{Scene, PB_MPM_DEFAULT_DT};
use crate::math::Vec3;
use crate::mpm::guard::GuardPolicy;
use crate::mpm::Method;
use crate::sleep::SleepSettings;
use nalgebra::Vector3;

/// How a world steps, fixed when it is built from its scene (the scene file is not read
/// again while stepping).
#[derive(Clone, Debug)]
pub struct StepParams {
    /// Length of one output frame (s).
    pub frame_dt: f64,
    /// Grid cell size (m).
    pub dx: f64,
    /// Gravity (m/s²).
    pub gravity: Vec3,
    /// Fraction of a cell a wave or particle may cross per substep.
    pub cfl: f64,
    /// Elastic wave speed that bounds the substep (m/s): the fastest P-wave of any material
    /// for MLS-MPM and PIC, zero for PB-MPM, whose constraint solve is bound by advection only.
    pub bounding_wave_speed: f64,
    /// The substep the scene asks for: `solver.dt`, or PB-MPM's default 1/240 s.
    pub requested_dt: Option<f64>,
    /// Whether `requested_dt` was written in the scene (subdividing it is then worth a warning).
    pub dt_from_scene: bool,
    /// Substeps one frame may take at most.
    pub max_substeps: u32,
    /// The implicit method: the substep is bound by advection under gravity only.
    pub implicit: bool,
    /// What the world does when the guard trips.
    pub guard_policy: GuardPolicy,
    /// When resting tissue may skip frames.
    pub sleep: SleepSettings,
}

impl StepParams {
    /// The step parameters of a validated scene; `wave_speed` is the fastest P-wave of its
    /// materials (m/s).
    pub fn new(scene: &Scene, wave_speed: f64) -> Self {
        let s = &scene.solver;
        let (bounding_wave_speed, requested_dt) = match s.method {
            Method::MlsMpm | Method::PicMpm | Method::TlMpm => (wave_speed, s.dt),
            Method::PbMpm => (0.0, Some(s.dt.unwrap_or(PB_MPM_DEFAULT_DT))),
            // Implicit Euler is stable at any step: only advection bounds it.
            Method::Implicit => (0.0, s.dt),
        };
        StepParams {
            frame_dt: 1.0 / scene.frame_rate_hz,
            dx: scene.domain.dx,
            gravity: Vector3::from(scene.domain.gravity).cast(),
            cfl: s.cfl,
            bounding_wave_speed,
            requested_dt,
            dt_from_scene: s.dt.is_some(),
            max_substeps: s.max_substeps_per_frame.max(1),
            implicit: s.method == Method::Implicit,
            guard_policy: s.guard_policy,
            sleep: scene.sleep.clone(),
        }
    }
}
