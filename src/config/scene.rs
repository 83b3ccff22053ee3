//! Scene file model (TOML). Every field is documented here; `config/*.toml` are examples.
//!
//! Units are SI (m, kg, s, Pa) unless a name says otherwise (`rpy_deg`, `jaw_deg`).

use super::outputs::{StrainMeasure, SurfaceKind};
use crate::mpm::backend::{BackendChoice, P2gAtomics};
use crate::mpm::guard::GuardPolicy;
use crate::mpm::material::MaterialModel;
use crate::mpm::{ImplicitParams, Method, Preconditioner};
use crate::tools::{ContactModel, Shape};
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
/// A scene file: the domain, solver, table, tissue blocks, threads, tools, arms, teleoperation and
/// outputs.
pub struct Scene {
    #[serde(default = "default_name")]
    /// The scene's name, for messages and reports (default `unnamed`).
    pub name: String,
    /// Simulation frames per second (output and command exchange rate).
    #[serde(default = "default_frame_rate")]
    pub frame_rate_hz: f64,
    /// Simulated seconds a headless run without `--seconds` goes on after the tools' last
    /// keyframe, for the scene to come to rest (s, finite, ≥ 0).
    #[serde(default = "default_settle_s")]
    pub settle_s: f64,
    /// `[domain]`: the simulated box and its grid.
    pub domain: Domain,
    #[serde(default)]
    /// `[solver]`: method, backend and substep settings.
    pub solver: Solver,
    #[serde(default)]
    /// `[table]`: the table plane (`None`: no table).
    pub table: Option<Table>,
    #[serde(default, rename = "tissue")]
    /// `[[tissue]]`: the tissue blocks.
    pub tissues: Vec<Tissue>,
    /// The wound a suture closes: the names of the two `[[tissue]]` blocks either side of it
    /// (`wound = ["left", "right"]`). Headless summaries and dataset outcomes then report the
    /// gap between them (see `world::wound`); without it no gap is measured.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wound: Option<[String; 2]>,
    /// Suture threads (see [`super::thread`]).
    #[serde(default, rename = "thread")]
    pub threads: Vec<super::thread::Thread>,
    #[serde(default, rename = "tool")]
    /// `[[tool]]`: the rigid tools.
    pub tools: Vec<Tool>,
    /// PSM arms driving tools (ROS node runs; headless runs ignore them).
    #[serde(default, rename = "arm")]
    pub arms: Vec<Arm>,
    /// MTM → PSM teleoperation: `[teleop]` for one pair, or `[[teleop]]` once per pair for
    /// bimanual teleoperation (MTMR → PSM1 and MTML → PSM2 on one console).
    #[serde(
        default,
        deserialize_with = "one_or_many",
        skip_serializing_if = "Vec::is_empty"
    )]
    pub teleop: Vec<TeleopSettings>,
    /// What the ROS node publishes and how often.
    #[serde(default)]
    pub outputs: Outputs,
    /// When resting tissue may skip frames.
    #[serde(default)]
    pub sleep: crate::sleep::SleepSettings,
    /// `[camera]`: the stereo endoscope camera (`None`: no camera).
    #[serde(default)]
    pub camera: Option<crate::render::CameraSettings>,
}

fn default_name() -> String {
    "unnamed".into()
}
fn default_frame_rate() -> f64 {
    60.0
}
pub(crate) fn default_settle_s() -> f64 {
    0.5
}

impl Scene {
    /// Where the tools' script ends: the last keyframe's time plus [`Scene::settle_s`], or
    /// `None` when no tool has a keyframe.
    pub fn script_end_s(&self) -> Option<f64> {
        self.tools
            .iter()
            .flat_map(|t| &t.keyframes)
            .map(|k| k.t)
            .reduce(f64::max)
            .map(|last| last + self.settle_s)
    }
}

/// The simulated box of space and its background grid.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Domain {
    /// Lowest corner (m).
    pub origin: [f64; 3],
    /// Extent along x, y, z (m).
    pub size: [f64; 3],
    /// Grid spacing (m).
    pub dx: f64,
    #[serde(default = "default_gravity")]
    /// Gravity, world frame, m/s² (default [0, 0, −9.81]).
    pub gravity: [f64; 3],
}

fn default_gravity() -> [f64; 3] {
    [0.0, 0.0, -9.81]
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
/// `[solver]` in a scene file: how the tissue is stepped.
pub struct Solver {
    /// Fraction of a cell a wave or particle may cross per substep (0 < cfl ≤ 1).
    #[serde(default = "default_cfl")]
    pub cfl: f64,
    /// Fixed substep (s), rounded down so that whole substeps fill a frame. Subdivided (with
    /// a warning) where larger than the CFL bound.
    #[serde(default)]
    pub dt: Option<f64>,
    /// Most substeps one frame may take; past it the frame advances less simulated time.
    #[serde(default = "default_max_substeps")]
    pub max_substeps_per_frame: u32,
    /// Particle speed the guard treats as a runaway (m/s).
    #[serde(default = "default_max_speed")]
    pub max_speed: f64,
    #[serde(default)]
    /// What the world does when the guard trips (default: stop).
    pub guard_policy: GuardPolicy,
    /// Which solver backend runs the scene: `auto` (a hardware GPU when there is one, the
    /// CPU otherwise), `gpu` (any GPU adapter, software rasterisers included) or `cpu`.
    #[serde(default)]
    pub backend: BackendChoice,
    /// How the GPU backend accumulates P2G: `auto` (f32 atomics where the adapter has them),
    /// `float` or `fixed` (i32 fixed-point atomics, as WebGPU and DX12 need).
    #[serde(default)]
    pub p2g_atomics: P2gAtomics,
    /// `mls_mpm` (explicit, substeps bound by the elastic wave CFL), `pb_mpm`
    /// (position-based: substeps of `dt`, default 1/240 s, bound only by advection, each
    /// solved by `iterations` constraint iterations) or `pic_mpm` (the standard-MPM
    /// reference: MLS-MPM with PIC velocity transfer) or `implicit` (backward Euler by
    /// Newton–CG: one substep per frame where advection allows, `cfl` bounding only the
    /// material speed; CPU backend only).
    #[serde(default)]
    pub method: Method,
    /// PB-MPM constraint iterations per substep (1–100). More iterations: stiffer (the
    /// stiffness follows iterations and step, not E), at proportional cost.
    #[serde(default = "default_iterations")]
    pub iterations: u32,
    /// PB-MPM over-relaxation of the elastic constraint (0 < relaxation < 2).
    #[serde(default = "default_relaxation")]
    pub relaxation: f64,
    /// Implicit: most Newton iterations per substep (1–100).
    #[serde(default = "default_newton_iterations")]
    pub newton_iterations: u32,
    /// Implicit: Newton stops when the residual falls below this fraction of its first
    /// value or of the momentum gravity gives the body in one step, whichever is larger
    /// (0 < value < 1).
    #[serde(default = "default_newton_tolerance")]
    pub newton_tolerance: f64,
    /// Implicit: most conjugate-gradient iterations per Newton iteration (1–10000).
    #[serde(default = "default_cg_iterations")]
    pub cg_iterations: u32,
    /// Implicit: the loosest forcing term of the inexact Newton solve: CG stops when its
    /// residual falls below η times the Newton residual, η at most this value and
    /// shrinking as Newton converges (Eisenstat–Walker; 0 < value < 1).
    #[serde(default = "default_cg_tolerance")]
    pub cg_tolerance: f64,
    /// Implicit: CG preconditioner, `block_jacobi` (each node's 3×3 Hessian block) or
    /// `mass` (the node mass).
    #[serde(default)]
    pub preconditioner: Preconditioner,
    /// A particle whose longest deformed edge exceeds this many cells splits in two at the
    /// frame's end, so stretched tissue stays sampled (0, the default: never; see
    /// [`crate::mpm::split`]). CPU backend.
    #[serde(default = "default_split_max_edge_cells")]
    pub split_max_edge_cells: f64,
    /// Splitting stops when the tissue holds this many times its starting particles.
    #[serde(default = "default_split_max_growth")]
    pub split_max_growth: f64,
}

impl Solver {
    /// The splitting settings for tissue that starts with `particles` particles.
    pub fn split_params(&self, particles: usize) -> crate::mpm::split::SplitParams {
        crate::mpm::split::SplitParams {
            max_edge_cells: self.split_max_edge_cells as f32,
            max_particles: (particles as f64 * self.split_max_growth) as usize,
        }
    }

    /// The implicit solver's settings from the scene keys.
    pub fn implicit_params(&self) -> ImplicitParams {
        ImplicitParams {
            newton_iterations: self.newton_iterations,
            newton_tolerance: self.newton_tolerance as f32,
            cg_iterations: self.cg_iterations,
            cg_tolerance: self.cg_tolerance as f32,
            preconditioner: self.preconditioner,
        }
    }
}

fn default_newton_iterations() -> u32 {
    ImplicitParams::default().newton_iterations
}
fn default_newton_tolerance() -> f64 {
    ImplicitParams::default().newton_tolerance as f64
}
fn default_cg_iterations() -> u32 {
    ImplicitParams::default().cg_iterations
}
fn default_cg_tolerance() -> f64 {
    ImplicitParams::default().cg_tolerance as f64
}

fn default_split_max_edge_cells() -> f64 {
    0.0
}
fn default_split_max_growth() -> f64 {
    4.0
}

fn default_cfl() -> f64 {
    0.5
}
fn default_max_substeps() -> u32 {
    2000
}
fn default_max_speed() -> f64 {
    20.0
}
fn default_iterations() -> u32 {
    5
}
fn default_relaxation() -> f64 {
    1.5
}

/// PB-MPM substep where the scene sets no `solver.dt`: the reference code's 1/240 s, four
/// substeps per 60 Hz frame.
pub const PB_MPM_DEFAULT_DT: f64 = 1.0 / 240.0;

impl Default for Solver {
    fn default() -> Self {
        Solver {
            cfl: default_cfl(),
            dt: None,
            max_substeps_per_frame: default_max_substeps(),
            max_speed: default_max_speed(),
            guard_policy: GuardPolicy::default(),
            backend: BackendChoice::default(),
            p2g_atomics: P2gAtomics::default(),
            method: Method::default(),
            iterations: default_iterations(),
            relaxation: default_relaxation(),
            newton_iterations: default_newton_iterations(),
            newton_tolerance: default_newton_tolerance(),
            cg_iterations: default_cg_iterations(),
            cg_tolerance: default_cg_tolerance(),
            preconditioner: Preconditioner::default(),
            split_max_edge_cells: default_split_max_edge_cells(),
            split_max_growth: default_split_max_growth(),
        }
    }
}

/// The table plane the tissue lies on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Table {
    /// World z of the table surface (m).
    pub height: f64,
    /// `bonded`: the bottom face sticks; `resting`: contact with Coulomb `friction`.
    #[serde(default = "default_hold")]
    pub hold: Hold,
    #[serde(default = "default_table_friction")]
    /// Coulomb friction coefficient of a `resting` table (default 0.5).
    pub friction: f64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
/// How the tissue is held on the table.
pub enum Hold {
    /// The bottom face sticks to the table.
    Bonded,
    /// The tissue rests on the table with Coulomb friction and can lift off.
    Resting,
}

fn default_hold() -> Hold {
    Hold::Bonded
}
fn default_table_friction() -> f64 {
    0.5
}

/// An axis-aligned block of tissue.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tissue {
    #[serde(default = "default_tissue_name")]
    /// The block's name (default `tissue`).
    pub name: String,
    /// Centre of the block (m).
    pub center: [f64; 3],
    /// Edge lengths (m).
    pub size: [f64; 3],
    /// Particles per grid cell along each axis (2 gives 8 particles per cell).
    #[serde(default = "default_per_axis")]
    pub particles_per_axis: u32,
    /// The block's material.
    pub material: Material,
}

fn default_tissue_name() -> String {
    "tissue".into()
}
fn default_per_axis() -> u32 {
    2
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
/// `material` of a `[[tissue]]` block.
pub struct Material {
    #[serde(default)]
    /// The elastic energy model (default `neo_hookean`).
    pub model: MaterialModel,
    /// Young's modulus E (Pa).
    pub youngs_modulus: f64,
    /// Poisson ratio ν, 0 ≤ ν < 0.5.
    pub poisson_ratio: f64,
    /// kg/m³.
    pub density: f64,
    /// Mass-proportional velocity damping (1/s), 0 for none.
    #[serde(default)]
    pub damping: f64,
    /// Toughness G_c (J/m²): the energy a unit area of tear takes (see
    /// [`crate::mpm::damage`]); absent: the tissue never tears.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub toughness: Option<f64>,
}

/// A rigid tool with a scripted trajectory (headless runs) or, later, an arm driving it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tool {
    /// The tool's name, for its topics, frame and reports.
    pub name: String,
    /// The tool's geometry.
    pub shape: Shape,
    #[serde(default)]
    /// How grid nodes in contact move with the tool (default Coulomb friction).
    pub contact: ContactModel,
    /// A gripper's jaw controller (dVRK's gains and effort limit unless given).
    #[serde(default)]
    pub jaw: crate::tools::JawGains,
    #[serde(default, rename = "keyframe")]
    /// `[[tool.keyframe]]`: the scripted motion of headless runs, in time order.
    pub keyframes: Vec<Keyframe>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
/// A scripted tool pose at one time (`[[tool.keyframe]]`).
pub struct Keyframe {
    /// Simulated time (s).
    pub t: f64,
    /// Tool frame origin in the world (m).
    pub position: [f64; 3],
    /// Orientation as roll, pitch, yaw about fixed x, y, z (degrees).
    #[serde(default)]
    pub rpy_deg: [f64; 3],
    /// Gripper opening (degrees).
    #[serde(default)]
    pub jaw_deg: f64,
}

impl Keyframe {
    /// The tool pose this keyframe names (angles in radians).
    pub fn pose(&self) -> crate::tools::ToolPose {
        let [r, p, y] = self.rpy_deg.map(f64::to_radians);
        crate::tools::ToolPose {
            position: nalgebra::Vector3::from(self.position),
            rotation: nalgebra::UnitQuaternion::from_euler_angles(r, p, y),
            jaw: self.jaw_deg.to_radians(),
        }
    }
}

/// A dVRK arm: a PSM whose tool frame (FK ∘ base) drives one of the scene's tools in node
/// runs, or the ECM that carries the camera.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Arm {
    /// dVRK arm name, also its topic namespace and frame prefix (`PSM1`).
    #[serde(default = "default_arm_name")]
    pub name: String,
    /// `psm` (the default) or `ecm` (the endoscope: four joints, no jaw, no tool; the
    /// scene's `[camera]` rides at its tip).
    #[serde(default)]
    pub kind: crate::robot::ArmKind,
    /// The arm's URDF: the project's `urdf/psm.urdf` / `urdf/ecm.urdf` (built in, the
    /// default for the kind) or dvrk_model's expanded URDF; links are renamed for `name`.
    /// Relative paths are relative to the working directory.
    #[serde(default)]
    pub urdf: Option<String>,
    /// The dvrk_model package folder, for `$(find dvrk_model)` when `urdf` is a `.urdf.xacro`
    /// (expanded by the `xacro` command on a copy with it resolved; without it, xacro resolves
    /// it from a sourced ROS workspace).
    #[serde(default)]
    pub dvrk_model: Option<String>,
    /// The URDF link at the remote centre of motion (default: `<arm>_base`, `<arm>_base_link`
    /// or `<arm>_psm_base_link`, see `robot::Psm::from_urdf_with_roles`).
    #[serde(default)]
    pub base_link: Option<String>,
    /// The URDF link whose frame `measured_cp` reports, as it is (default: the link `<arm>`,
    /// else dvrk_model's `<arm>_tool_tip_link` moved back 10.2 mm to the jaw pivot).
    #[serde(default)]
    pub tool_link: Option<String>,
    /// `move_jp` speed limits, one per joint (rad/s; insertion m/s). PSM: yaw, pitch,
    /// insertion, roll, wrist_pitch, wrist_yaw, default dVRK's (90°/s, 90°/s, 0.2 m/s,
    /// 1080°/s ×3); ECM: outer_yaw, outer_pitch, insertion, outer_roll, default 90°/s,
    /// 90°/s, 0.2 m/s, 90°/s; never the URDF's.
    #[serde(default)]
    pub joint_speeds: Option<Vec<f64>>,
    /// Jaw speed limit (rad/s); default dVRK's 720°/s.
    #[serde(default)]
    pub jaw_speed: Option<f64>,
    /// World position of the arm base `<name>_base`, the remote centre of motion (m).
    pub base_xyz: [f64; 3],
    /// World orientation of the base as roll, pitch, yaw about fixed x, y, z (degrees).
    #[serde(default)]
    pub base_rpy_deg: [f64; 3],
    /// Joint values at start, one per joint: PSM yaw, pitch (rad), insertion (m), roll,
    /// wrist_pitch, wrist_yaw (rad); ECM outer_yaw, outer_pitch (rad), insertion (m),
    /// outer_roll (rad).
    pub home_joints: Vec<f64>,
    /// Jaw opening at start (degrees).
    #[serde(default)]
    pub home_jaw_deg: f64,
    /// Name of the `[[tool]]` a PSM holds (required for a PSM; an ECM holds none).
    #[serde(default)]
    pub tool: Option<String>,
    /// The held tool's orientation in the arm's tool frame, as roll, pitch, yaw about fixed
    /// x, y, z (degrees). The tool frame's +z is the instrument's axis, out of its tip; a
    /// slicer's blade hangs along its own −z, so a PSM holding a scalpel uses [180, 0, 0].
    #[serde(default)]
    pub tool_rpy_deg: [f64; 3],
    /// The held tool's origin in the arm's tool frame (m): a needle held with its arc's
    /// centre on the instrument's axis, ahead of the jaw pivot, is mounted at `[0, 0, d]`, so
    /// that rolling the instrument turns the needle about its own centre.
    #[serde(default)]
    pub tool_xyz: [f64; 3],
    /// What `<arm>/tool_type` reports, as dVRK names its instruments (`NAME:model`, e.g.
    /// `"LARGE_NEEDLE_DRIVER:400006"`); absent: dVRK's Large Needle Driver for a gripper
    /// (whose default jaw gains and effort limit are that tool's), the tool's scene name
    /// otherwise.
    #[serde(default)]
    pub tool_type: Option<String>,
    #[serde(default)]
    /// `simulated` (the node is the arm, the default) or `mirror` (follows a real arm).
    pub mode: ArmMode,
    /// Mirror mode: namespace of the real arm whose `measured_js` and `jaw/measured_js` are
    /// followed (default `/<name>`).
    #[serde(default)]
    pub mirror_of: Option<String>,
}

fn default_arm_name() -> String {
    "PSM1".into()
}

impl Arm {
    /// The URDF path the arm loads: the scene's, else the built-in one of its kind.
    pub fn urdf_path(&self) -> &str {
        match (&self.urdf, self.kind) {
            (Some(path), _) => path,
            (None, crate::robot::ArmKind::Psm) => DEFAULT_PSM_URDF,
            (None, crate::robot::ArmKind::Ecm) => DEFAULT_ECM_URDF,
        }
    }
}

/// The PSM's built-in URDF path (used from the source tree, else compiled in).
pub const DEFAULT_PSM_URDF: &str = "urdf/psm.urdf";
/// The ECM's built-in URDF path (used from the source tree, else compiled in).
pub const DEFAULT_ECM_URDF: &str = "urdf/ecm.urdf";

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
/// Whether the node simulates an arm or follows a real one.
pub enum ArmMode {
    /// The node is the arm (dVRK's `dvrk_arm_from_ros` contract).
    #[default]
    Simulated,
    /// The tool follows a real arm's `measured_js`; nothing is published for the arm.
    Mirror,
}

/// MTM → PSM teleoperation without a dVRK console.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TeleopSettings {
    /// The simulated PSM that follows.
    #[serde(default = "default_arm_name")]
    pub arm: String,
    /// Namespace of the MTM's `measured_cp` and `gripper/measured_js`.
    #[serde(default = "default_mtm")]
    pub mtm: String,
    /// Namespace of the `clutch` and `operator_present` pedals (sensor_msgs/Joy).
    #[serde(default = "default_console")]
    pub console: String,
    /// PSM displacement per MTM displacement.
    #[serde(default = "default_teleop_scale")]
    pub scale: f64,
    /// Start with the operator present (no `operator_present` pedal needed).
    #[serde(default)]
    pub operator_present: bool,
    /// Publish the tool's contact wrench, scaled, on `<mtm>/body/servo_cf`.
    #[serde(default)]
    pub force_feedback: bool,
    /// MTM force per tool contact force.
    #[serde(default = "default_force_scale")]
    pub force_feedback_scale: f64,
}

/// A table, or an array of tables, as a list: `[teleop]` and `[[teleop]]` both read, with
/// the field-by-field errors of the table itself (an untagged enum would hide them).
fn one_or_many<'de, D, T>(deserializer: D) -> Result<Vec<T>, D::Error>
where
    D: serde::Deserializer<'de>,
    T: Deserialize<'de>,
{
    use serde::de::value::{MapAccessDeserializer, SeqAccessDeserializer};
    struct OneOrMany<T>(std::marker::PhantomData<T>);
    impl<'de, T: Deserialize<'de>> serde::de::Visitor<'de> for OneOrMany<T> {
        type Value = Vec<T>;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a table or an array of tables")
        }
        fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<Vec<T>, A::Error> {
            T::deserialize(MapAccessDeserializer::new(map)).map(|one| vec![one])
        }
        fn visit_seq<A: serde::de::SeqAccess<'de>>(self, seq: A) -> Result<Vec<T>, A::Error> {
            Vec::deserialize(SeqAccessDeserializer::new(seq))
        }
    }
    deserializer.deserialize_any(OneOrMany(std::marker::PhantomData))
}

fn default_mtm() -> String {
    "MTMR".into()
}
fn default_console() -> String {
    "console".into()
}
fn default_teleop_scale() -> f64 {
    0.2
}
fn default_force_scale() -> f64 {
    0.2
}

/// Rates (Hz) of the node's outputs; 0 turns one off. Outputs are only computed while
/// someone subscribes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Outputs {
    /// `tissue/points` (sensor_msgs/PointCloud2).
    #[serde(default = "default_points_rate")]
    pub points_rate_hz: f64,
    /// Publish every n-th particle only (1: all).
    #[serde(default = "default_downsample")]
    pub points_downsample: u32,
    /// Then one point (the mean) per occupied cube of this edge (m); 0: off.
    #[serde(default)]
    pub points_voxel: f64,
    /// The cloud's scalar: `volumetric` (J − 1) or `equivalent` (equivalent Green strain);
    /// also what the surface mesh is coloured by.
    #[serde(default = "default_points_scalar")]
    pub points_scalar: StrainMeasure,
    /// `tissue/surface` (visualization_msgs/Marker).
    #[serde(default = "default_surface_rate")]
    pub surface_rate_hz: f64,
    /// `mesh` (constant topology, carried by the particles) or `isosurface` (rebuilt each
    /// frame, for tissue whose topology changes).
    #[serde(default)]
    pub surface: SurfaceKind,
    /// `tools/<tool>/wrench` (geometry_msgs/WrenchStamped).
    #[serde(default = "default_wrench_rate")]
    pub wrench_rate_hz: f64,
    /// `/tf` for arm links.
    #[serde(default = "default_tf_rate")]
    pub tf_rate_hz: f64,
    /// Whether `/tf` carries every arm link (`true`) or only what dVRK's own
    /// robot_state_publisher launch cannot (each arm's tool frame and tool tip, and the
    /// scripted tools), leaving the links to it (`false`).
    #[serde(default = "default_true")]
    pub tf_arm_links: bool,
    /// Arm state topics (`measured_js`, ...): every frame up to this rate.
    #[serde(default = "default_arm_rate")]
    pub arm_rate_hz: f64,
    /// `threads/<thread>/centreline` (visualization_msgs/Marker) and
    /// `threads/<thread>/tension` (sensor_msgs/PointCloud2).
    #[serde(default = "default_thread_rate")]
    pub thread_rate_hz: f64,
    /// `tissue/pieces` (std_msgs/UInt32): how many separate pieces the tissue is in, counted
    /// at this rate in simulated time while someone subscribes (and when recording).
    #[serde(default = "default_pieces_rate")]
    pub pieces_rate_hz: f64,
}

fn default_pieces_rate() -> f64 {
    5.0
}

fn default_points_rate() -> f64 {
    30.0
}
fn default_downsample() -> u32 {
    1
}
fn default_points_scalar() -> StrainMeasure {
    StrainMeasure::Volumetric
}
fn default_surface_rate() -> f64 {
    10.0
}
fn default_wrench_rate() -> f64 {
    60.0
}
fn default_true() -> bool {
    true
}
fn default_tf_rate() -> f64 {
    50.0
}
fn default_arm_rate() -> f64 {
    100.0
}
fn default_thread_rate() -> f64 {
    30.0
}

impl Default for Outputs {
    fn default() -> Self {
        Outputs {
            points_rate_hz: default_points_rate(),
            points_downsample: default_downsample(),
            points_voxel: 0.0,
            points_scalar: default_points_scalar(),
            surface_rate_hz: default_surface_rate(),
            surface: SurfaceKind::default(),
            wrench_rate_hz: default_wrench_rate(),
            tf_rate_hz: default_tf_rate(),
            tf_arm_links: true,
            arm_rate_hz: default_arm_rate(),
            thread_rate_hz: default_thread_rate(),
            pieces_rate_hz: default_pieces_rate(),
        }
    }
}
