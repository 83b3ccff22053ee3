//! Scene assembly: a validated scene becomes what the frame loop steps — the world, each
//! arm at home with the scene tool it drives, teleoperation, and the tissue outputs' options.
//! Everything here can fail on user input (a URDF, home joints, a tool name), so it fails
//! with a [`SetupError`] before any thread or network participant exists.

use std::collections::VecDeque;
use std::path::Path;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use crate::config::{Outputs, Scene};
use crate::output::mesh::MeshError;
use crate::output::snapshot::SnapshotSchedule;
use crate::output::{CloudOptions, SurfaceKind, TissueSurface};
use crate::robot::ecm::ECM_SPEEDS;
use crate::robot::psm::{UrdfRoles, DVRK_JAW_SPEED, DVRK_PSM_SPEEDS};
use crate::robot::urdf::{self, CLASSIC_ECM_URDF, CLASSIC_PSM_URDF};
use crate::robot::ArmKind;
use crate::robot::{Psm, PsmError, Teleop, TeleopConfig, TeleopError};
use crate::sim::arm::{ArmError, ArmSim};
use crate::sim::input::ReplayInput;
use crate::sim::sink::FrameSink;
use crate::world::{World, WorldError};

/// Why a scene's simulation side could not be built.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    #[error(transparent)]
    /// The world could not be built from the scene.
    World(#[from] WorldError),
    #[error(transparent)]
    /// An arm's URDF cannot be used.
    Psm(#[from] Box<ArmUrdfProblem>),
    #[error("arm {arm}: {source}")]
    /// An arm could not be set up at its home joints.
    Arm {
        /// The arm's name.
        arm: String,
        /// Why.
        source: ArmError,
    },
    #[error("arm {arm}: no tool {tool}")]
    /// An arm names a tool the scene does not have.
    NoTool {
        /// The arm's name.
        arm: String,
        /// The tool name it gives.
        tool: String,
    },
    #[error(
        "arm {arm} holds the needle of thread {thread:?}, whose {value}; it must be in {allowed}"
    )]
    /// An arm's needle starts away from the thread swaged to it.
    SwageOffNeedle {
        /// The arm's name.
        arm: String,
        /// The thread's name.
        thread: String,
        /// The thread's first point.
        value: String,
        /// Where the swage end is.
        allowed: String,
    },
    #[error("teleop.arm {0} is not an arm")]
    /// `teleop.arm` names no arm of the scene (holds the name).
    TeleopArm(String),
    #[error("teleop: {0}")]
    /// The teleoperation settings are invalid.
    Teleop(#[from] TeleopError),
    #[error("tissue surface: {0}")]
    /// The tissue surface could not be built.
    Surface(#[from] MeshError),
}

/// Teleoperation of one arm by one MTM.
pub struct TeleopBinding {
    /// Index of the scene arm the MTM drives.
    pub arm: usize,
    /// The MTM's namespace (for log lines).
    pub mtm: String,
    /// The MTM-to-PSM mapping.
    pub teleop: Teleop,
    /// The MTM's latest pose, and its gripper.
    pub mtm_pose: Option<Isometry3<f64>>,
    /// The MTM gripper's latest angle (rad).
    pub mtm_gripper: f64,
    /// A pose or gripper arrived since the mapping last read them.
    pub mtm_fresh: bool,
}

/// The simulation's side of the exchange, handed to the frame loop.
pub struct SimSetup {
    /// The simulated world.
    pub world: World,
    /// The scene's arms, scene order.
    pub arms: Vec<ArmSim>,
    /// Scene tool index each arm drives (`None` for the ECM).
    pub arm_tools: Vec<Option<usize>>,
    /// Teleoperation, one binding per `[[teleop]]` pair (none without).
    pub teleop: Vec<TeleopBinding>,
    /// What the point cloud output carries.
    pub cloud: CloudOptions,
    /// `None` in a scripted run, which builds no surface.
    pub surface: Option<TissueSurface>,
    /// When to write snapshot pictures (`None`: none).
    pub snapshots: Option<SnapshotSchedule>,
    /// Records inputs, events and outputs.
    pub recorder: Option<Box<dyn FrameSink>>,
    /// Recorded inputs to apply, in order, each at the frame start at its time.
    pub replay: Option<VecDeque<ReplayInput>>,
    /// Frames at the scene's rate in real time (false: as fast as they compute).
    pub paced: bool,
    /// The thread ends by itself once simulated time reaches this (s).
    pub stop_at: Option<f64>,
    /// The scene's camera, when it has one and it can run.
    pub camera: Option<crate::render::CameraRig>,
}

impl SimSetup {
    /// A scripted run of `world`: no arms, no teleop, no outputs; its tools follow their
    /// keyframes.
    pub fn scripted(world: World) -> SimSetup {
        let cloud = cloud_options(&world.scene().outputs);
        SimSetup {
            world,
            arms: Vec::new(),
            arm_tools: Vec::new(),
            teleop: Vec::new(),
            cloud,
            surface: None,
            snapshots: None,
            recorder: None,
            replay: None,
            paced: false,
            stop_at: None,
            camera: None,
        }
    }
}

/// The scene's camera for a run without arms (a scripted run that records): fixed where
/// the scene places it, or where the scene's ECM holds it at its home joints, since nothing
/// moves the ECM there. `None` where the scene has no camera or it cannot run (logged).
pub fn scripted_camera(world: &World) -> Option<crate::render::CameraRig> {
    let mut rig = crate::render::CameraRig::for_world(world)?;
    let scene = world.scene();
    if let Some((index, ecm)) = scene
        .arms
        .iter()
        .enumerate()
        .find(|(_, a)| a.kind == ArmKind::Ecm)
    {
        let at_home = load_psm(index, ecm)
            .map_err(|e| e.to_string())
            .and_then(|psm| {
                ArmSim::new(psm, ecm.mode, arm_base(ecm), &ecm.home_joints, 0.0)
                    .map_err(|e| e.to_string())
            });
        match at_home {
            Ok(arm) => rig.set_pose(arm.world_cp().cast::<f32>()),
            Err(e) => {
                tracing::warn!("camera off: {}: {e}", ecm.name);
                return None;
            }
        }
    }
    Some(rig)
}

/// The world-from-base pose of a scene arm.
pub fn arm_base(arm: &crate::config::Arm) -> Isometry3<f64> {
    let [r, p, y] = arm.base_rpy_deg.map(f64::to_radians);
    Isometry3::from_parts(
        Translation3::from(Vector3::from(arm.base_xyz)),
        UnitQuaternion::from_euler_angles(r, p, y),
    )
}

/// Why an arm's URDF cannot be used: the scene key to look at, the URDF file and the reason.
#[derive(Debug, thiserror::Error)]
#[error("arm[{index}] ({arm}).{key} = \"{file}\": {source}")]
pub struct ArmUrdfProblem {
    /// Position of the `[[arm]]` table in the scene.
    pub index: usize,
    /// The arm's name.
    pub arm: String,
    /// `urdf`, `base_link`, `tool_link`, `joint_speeds`, or `home_joints` / `home_jaw_deg`
    /// outside the URDF's limits.
    pub key: &'static str,
    /// The `urdf` value.
    pub file: String,
    /// Why the URDF cannot be used.
    pub source: PsmError,
}

/// Loads an arm's model: its URDF file, or the built-in classic PSM / ECM when the default
/// path of its kind (`urdf/psm.urdf`, `urdf/ecm.urdf`) is not found from the working
/// directory; base and tool links as the scene names them or by the default rule; speed
/// limits the scene's, else dVRK's.
pub fn load_psm(index: usize, arm: &crate::config::Arm) -> Result<Psm, Box<ArmUrdfProblem>> {
    load_arm_psm(arm).map_err(|source| {
        let key = match &source {
            PsmError::NoSuchRoleLink { key, .. } => key,
            PsmError::NoBaseLink { .. } | PsmError::AmbiguousBase { .. } => "base_link",
            PsmError::NoToolLink { .. } => "tool_link",
            PsmError::InvalidSpeed { .. } | PsmError::SpeedCount { .. } => "joint_speeds",
            _ => "urdf",
        };
        Box::new(ArmUrdfProblem {
            index,
            arm: arm.name.clone(),
            key,
            file: arm.urdf_path().to_owned(),
            source,
        })
    })
}

fn load_arm_psm(arm: &crate::config::Arm) -> Result<Psm, PsmError> {
    let path = Path::new(arm.urdf_path());
    let roles = UrdfRoles {
        base_link: arm.base_link.clone(),
        tool_link: arm.tool_link.clone(),
    };
    let built_in = match arm.kind {
        ArmKind::Psm => CLASSIC_PSM_URDF,
        ArmKind::Ecm => CLASSIC_ECM_URDF,
    };
    let robot = if !path.exists() && arm.urdf.is_none() {
        urdf::parse_urdf(built_in)?
    } else {
        urdf::load_urdf(path, arm.dvrk_model.as_deref().map(Path::new))?
    };
    let mut psm = match arm.kind {
        ArmKind::Psm => Psm::from_urdf_with_roles(robot, &arm.name, &roles)?,
        ArmKind::Ecm => Psm::ecm_from_urdf_with_roles(robot, &arm.name, &roles)?,
    };
    let defaults: &[f64] = match arm.kind {
        ArmKind::Psm => &DVRK_PSM_SPEEDS,
        ArmKind::Ecm => &ECM_SPEEDS,
    };
    let jaw_default = (arm.kind == ArmKind::Psm).then_some(DVRK_JAW_SPEED);
    if arm.joint_speeds.is_some() || arm.jaw_speed.is_some() {
        let joints = arm.joint_speeds.as_deref().unwrap_or(defaults);
        let jaw = arm.jaw_speed.or(jaw_default);
        psm.set_speed_limits(joints, jaw)?;
        tracing::info!(
            "arm {}: move_jp speed limits from the scene: {joints:?}{}",
            arm.name,
            jaw.map(|j| format!(", jaw {j} rad/s")).unwrap_or_default()
        );
    } else {
        tracing::info!(
            "arm {}: move_jp speed limits dVRK's (not the URDF's velocity)",
            arm.name
        );
    }
    Ok(psm)
}

/// Loads every arm's URDF as a run would (for `check`): one problem per arm that fails.
pub fn check_arm_urdfs(scene: &Scene) -> Vec<ArmUrdfProblem> {
    scene
        .arms
        .iter()
        .enumerate()
        .filter_map(|(index, arm)| match load_psm(index, arm) {
            Err(problem) => Some(*problem),
            Ok(psm) => home_outside_limits(index, arm, &psm),
        })
        .collect()
}

/// The arm's home joints (and a PSM's home jaw) checked against its URDF's limits, as
/// building the arm checks them, so that `check` refuses what the node would.
fn home_outside_limits(
    index: usize,
    arm: &crate::config::Arm,
    psm: &Psm,
) -> Option<ArmUrdfProblem> {
    let joints = psm.joints().validate::<&str>(&[], &arm.home_joints, None);
    let jaw = if psm.jaw().is_empty() {
        Ok(Vec::new())
    } else {
        psm.jaw()
            .validate::<&str>(&[], &[arm.home_jaw_deg.to_radians()], None)
    };
    let (key, error) = match (joints, jaw) {
        (Err(e), _) => ("home_joints", e),
        (Ok(_), Err(e)) => ("home_jaw_deg", e),
        (Ok(_), Ok(_)) => return None,
    };
    Some(ArmUrdfProblem {
        index,
        arm: arm.name.clone(),
        key,
        file: arm.urdf_path().to_owned(),
        source: PsmError::Joint(error),
    })
}

/// The surface a scene's outputs get: the constant-topology mesh cannot follow a cut, so a
/// scene with a slicer that asks for it gets the isosurface instead, with the reason logged.
pub fn surface_kind(scene: &Scene) -> SurfaceKind {
    let (kind, instead) = surface_choice(scene);
    if let Some(reason) = instead {
        tracing::info!("outputs.surface: isosurface instead of mesh: {reason}");
    }
    kind
}

/// [`surface_kind`] without the log line: the kind, and why the isosurface replaced the
/// mesh the scene asked for (`None`: it did not).
pub fn surface_choice(scene: &Scene) -> (SurfaceKind, Option<String>) {
    if scene.outputs.surface != SurfaceKind::Mesh {
        return (scene.outputs.surface, None);
    }
    let fixed = "and the mesh's topology is fixed at rest";
    if let Some(tissue) = scene
        .tissues
        .iter()
        .find(|t| t.material.toughness.is_some())
    {
        let reason = format!(
            "tissue {} can tear (material.toughness), {fixed}",
            tissue.name
        );
        return (SurfaceKind::Isosurface, Some(reason));
    }
    match scene.tools.iter().find(|t| t.shape.cuts()) {
        Some(tool) => {
            let reason = format!("tool {} cuts the tissue, {fixed}", tool.name);
            (SurfaceKind::Isosurface, Some(reason))
        }
        None => (SurfaceKind::Mesh, None),
    }
}

fn cloud_options(outputs: &Outputs) -> CloudOptions {
    CloudOptions {
        measure: outputs.points_scalar,
        stride: outputs.points_downsample.max(1) as usize,
        voxel: outputs.points_voxel as f32,
    }
}

/// Arm `index` of `scene` at home, holding its tool (the tool's scene index; `None` for the
/// ECM). A thread swaged to the arm's needle must start in the needle's swage end where the
/// arm's home puts it, or the first frame would jerk it there: refused otherwise.
fn arm_at_home(
    scene: &Scene,
    index: usize,
    arm: &crate::config::Arm,
) -> Result<(ArmSim, Option<usize>), SetupError> {
    let mut sim = ArmSim::new(
        load_psm(index, arm)?,
        arm.mode,
        arm_base(arm),
        &arm.home_joints,
        arm.home_jaw_deg.to_radians(),
    )
    .map_err(|source| SetupError::Arm {
        arm: arm.name.clone(),
        source,
    })?;
    if arm.kind == ArmKind::Ecm {
        return Ok((sim, None));
    }
    let name = arm.tool.as_deref().unwrap_or_default();
    let tool = scene
        .tools
        .iter()
        .position(|t| t.name == name)
        .ok_or_else(|| SetupError::NoTool {
            arm: arm.name.clone(),
            tool: name.to_owned(),
        })?;
    sim.set_jaw_effort_limit(scene.tools[tool].jaw.effort_max);
    let [r, p, y] = arm.tool_rpy_deg.map(f64::to_radians);
    sim.set_tool_mount(Isometry3::from_parts(
        Vector3::from(arm.tool_xyz).into(),
        UnitQuaternion::from_euler_angles(r, p, y),
    ));
    let needle = &scene.tools[tool];
    let placed_by = format!("arm {}'s home_joints", arm.name);
    for thread in &scene.threads {
        if thread.swaged_to.as_deref() != Some(needle.name.as_str()) {
            continue;
        }
        let miss = crate::config::thread::swage_miss(thread, needle, &sim.tool_pose(), &placed_by);
        if let Some((value, allowed)) = miss {
            return Err(SetupError::SwageOffNeedle {
                arm: arm.name.clone(),
                thread: thread.name.clone(),
                value,
                allowed,
            });
        }
    }
    Ok((sim, Some(tool)))
}

/// What `check` reports beyond the URDFs ([`check_arm_urdfs`]): an arm whose home puts its
/// needle away from the thread swaged to it. Arms whose URDF cannot be used are skipped
/// (their problem is the URDF's). Only an arm holding a tool that a thread is swaged to is
/// built: the others' URDFs were loaded once already.
pub fn check_arm_swages(scene: &Scene) -> Vec<SetupError> {
    let holds_a_swage = |arm: &crate::config::Arm| {
        arm.kind != ArmKind::Ecm
            && scene
                .threads
                .iter()
                .any(|t| t.swaged_to.is_some() && t.swaged_to == arm.tool)
    };
    scene
        .arms
        .iter()
        .enumerate()
        .filter(|(_, arm)| holds_a_swage(arm))
        .filter_map(|(index, arm)| match arm_at_home(scene, index, arm) {
            Err(e @ SetupError::SwageOffNeedle { .. }) => Some(e),
            _ => None,
        })
        .collect()
}

/// The simulation side of a scene: world, arms at home, teleop.
pub fn build_setup(scene: &Scene) -> Result<SimSetup, SetupError> {
    let world = World::try_new(scene)?;
    let mut arms = Vec::new();
    let mut arm_tools = Vec::new();
    for (index, arm) in scene.arms.iter().enumerate() {
        let (sim, tool) = arm_at_home(scene, index, arm)?;
        arms.push(sim);
        arm_tools.push(tool);
    }
    let mut teleop = Vec::new();
    for t in &scene.teleop {
        let arm = scene
            .arms
            .iter()
            .position(|a| a.name == t.arm)
            .ok_or_else(|| SetupError::TeleopArm(t.arm.clone()))?;
        let mut config = TeleopConfig::for_psm(arms[arm].psm());
        config.scale = t.scale;
        let mut mapping = Teleop::new(config)?;
        mapping.set_operator_present(t.operator_present);
        teleop.push(TeleopBinding {
            arm,
            mtm: t.mtm.clone(),
            teleop: mapping,
            mtm_pose: None,
            mtm_gripper: 0.0,
            mtm_fresh: false,
        });
    }
    let outputs = &scene.outputs;
    let surface = TissueSurface::new(
        surface_kind(scene),
        world.particles(),
        scene.domain.dx as f32,
        outputs.points_scalar,
    )?;
    let camera = crate::render::CameraRig::for_world(&world);
    Ok(SimSetup {
        world,
        arms,
        arm_tools,
        teleop,
        cloud: cloud_options(outputs),
        surface: Some(surface),
        snapshots: None,
        recorder: None,
        replay: None,
        paced: true,
        stop_at: None,
        camera,
    })
}
