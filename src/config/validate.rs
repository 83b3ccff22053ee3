//! Semantic checks of a parsed scene: every problem is reported (not just the first), each
//! naming the key, the value and what is allowed.

use super::scene::{ArmMode, Hold, Scene};
use crate::mpm::grid::WALL_NODES;
use crate::mpm::{Method, MAX_TOOLS};
use crate::robot::ArmKind;
use crate::tools::{ContactModel, Shape};
use std::fmt;

/// One invalid value.
#[derive(Clone, Debug, PartialEq)]
pub struct Problem {
    /// Dotted path of the key, e.g. `tissue[0].material.poisson_ratio`.
    pub key: String,
    /// The value found, as written.
    pub value: String,
    /// What would be accepted.
    pub allowed: String,
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} = {}: {}", self.key, self.value, self.allowed)
    }
}

struct Checker {
    problems: Vec<Problem>,
}

impl Checker {
    fn require(
        &mut self,
        ok: bool,
        key: impl Into<String>,
        value: impl fmt::Debug,
        allowed: impl Into<String>,
    ) {
        if !ok {
            self.problems.push(Problem {
                key: key.into(),
                value: format!("{value:?}"),
                allowed: allowed.into(),
            });
        }
    }

    fn positive(&mut self, key: impl Into<String>, value: f64) {
        self.require(
            value.is_finite() && value > 0.0,
            key,
            value,
            "must be a finite number > 0",
        );
    }

    /// `lower ≤ value ≤ upper` (finite), `what` saying the unit and why the bound.
    fn within(&mut self, key: impl Into<String>, value: f64, lower: f64, upper: f64, what: &str) {
        self.require(
            value.is_finite() && (lower..=upper).contains(&value),
            key,
            value,
            format!("{lower} ≤ value ≤ {upper} {what}"),
        );
    }

    /// `0 < value ≤ upper` (finite).
    fn positive_up_to(&mut self, key: impl Into<String>, value: f64, upper: f64, what: &str) {
        self.require(
            value.is_finite() && value > 0.0 && value <= upper,
            key,
            value,
            format!("0 < value ≤ {upper} {what}"),
        );
    }
}

/// Largest length anywhere in a scene (m): positions, sizes and offsets beyond it are typing
/// errors, not an operating table.
const MAX_LENGTH: f64 = 100.0;
/// Largest angle written in degrees: a turn and a half either way covers every orientation.
const MAX_DEGREES: f64 = 540.0;
/// Largest speed limit (rad/s or m/s): far beyond any surgical robot joint.
const MAX_JOINT_SPEED: f64 = 100.0;
/// Farthest a held tool's origin may sit from the arm's tool frame (m): a jaw is about a
/// centimetre long, a needle a few centimetres across.
const MAX_TOOL_OFFSET: f64 = 0.05;
/// Largest friction coefficient: real contacts stay below a few.
const MAX_FRICTION: f64 = 10.0;
/// Largest toughness (J/m²): tough skin is of the order of 1e4 J/m², soft tissue 1e1–1e3.
const MAX_TOUGHNESS: f64 = 1e6;
/// Longest scripted time (s): a day of simulated time.
const MAX_TIME: f64 = 86_400.0;

/// All problems of `scene`; empty when it can be simulated.
pub fn validate(scene: &Scene) -> Vec<Problem> {
    let mut c = Checker {
        problems: Vec::new(),
    };
    c.require(
        scene.frame_rate_hz.is_finite()
            && scene.frame_rate_hz > 0.0
            && scene.frame_rate_hz <= 10_000.0,
        "frame_rate_hz",
        scene.frame_rate_hz,
        "0 < frame_rate_hz ≤ 10000",
    );
    c.require(
        scene.settle_s.is_finite() && scene.settle_s >= 0.0,
        "settle_s",
        scene.settle_s,
        "simulated seconds after the last keyframe: a finite number ≥ 0",
    );

    let d = &scene.domain;
    c.positive("domain.dx", d.dx);
    for (a, axis) in ["x", "y", "z"].iter().enumerate() {
        c.positive(format!("domain.size[{a}] ({axis})"), d.size[a]);
        c.within(
            format!("domain.origin[{a}]"),
            d.origin[a],
            -MAX_LENGTH,
            MAX_LENGTH,
            "m",
        );
        c.within(
            format!("domain.gravity[{a}]"),
            d.gravity[a],
            -1000.0,
            1000.0,
            "m/s² (100 g)",
        );
    }
    let domain_ok = d.dx > 0.0 && d.size.iter().all(|s| *s > 0.0);
    if domain_ok {
        for (a, size) in d.size.iter().enumerate() {
            let cells = size / d.dx;
            c.require(
                (8.0..=1024.0).contains(&cells),
                format!("domain.size[{a}]"),
                *size,
                format!(
                    "between 8 and 1024 cells of dx = {} m (is {cells:.0})",
                    d.dx
                ),
            );
        }
    }
    // Usable region: particles and tools must stay clear of the slip walls.
    let margin = WALL_NODES as f64 * d.dx;
    let lo: Vec<f64> = (0..3).map(|a| d.origin[a] + margin).collect();
    let hi: Vec<f64> = (0..3).map(|a| d.origin[a] + d.size[a] - margin).collect();
    let inside = |p: [f64; 3]| (0..3).all(|a| p[a] >= lo[a] && p[a] <= hi[a]);
    let region = format!(
        "inside the domain less {WALL_NODES} wall cells: [{:.4}, {:.4}] × [{:.4}, {:.4}] × [{:.4}, {:.4}] m",
        lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]
    );

    let s = &scene.solver;
    c.require(
        s.cfl > 0.0 && s.cfl <= 1.0,
        "solver.cfl",
        s.cfl,
        "0 < cfl ≤ 1",
    );
    if let Some(dt) = s.dt {
        c.positive_up_to("solver.dt", dt, 0.1, "s (a substep, shorter than a frame)");
    }
    c.require(
        (1..=1_000_000).contains(&s.max_substeps_per_frame),
        "solver.max_substeps_per_frame",
        s.max_substeps_per_frame,
        "1 ≤ value ≤ 1000000",
    );
    c.positive_up_to(
        "solver.max_speed",
        s.max_speed,
        1000.0,
        "m/s (a guard on particle speed: faster is no guard)",
    );
    c.require(
        (1..=100).contains(&s.iterations),
        "solver.iterations",
        s.iterations,
        "1 ≤ iterations ≤ 100 (PB-MPM constraint iterations per substep)",
    );
    c.require(
        s.relaxation > 0.0 && s.relaxation < 2.0,
        "solver.relaxation",
        s.relaxation,
        "0 < relaxation < 2 (PB-MPM over-relaxation; 2 and above overshoots without converging)",
    );
    c.require(
        (1..=100).contains(&s.newton_iterations),
        "solver.newton_iterations",
        s.newton_iterations,
        "1 ≤ newton_iterations ≤ 100 (implicit: Newton iterations per substep)",
    );
    c.require(
        s.newton_tolerance > 0.0 && s.newton_tolerance < 1.0,
        "solver.newton_tolerance",
        s.newton_tolerance,
        "0 < newton_tolerance < 1 (implicit: residual relative to its first value)",
    );
    c.require(
        (1..=10_000).contains(&s.cg_iterations),
        "solver.cg_iterations",
        s.cg_iterations,
        "1 ≤ cg_iterations ≤ 10000 (implicit: CG iterations per Newton iteration)",
    );
    c.require(
        s.cg_tolerance > 0.0 && s.cg_tolerance < 1.0,
        "solver.cg_tolerance",
        s.cg_tolerance,
        "0 < cg_tolerance < 1 (implicit: CG residual relative to the Newton residual)",
    );
    if s.method == Method::TlMpm {
        // Total Lagrangian MPM keeps every particle's rest neighbours: there is nothing to
        // split, and a crack would have to be carried back to the rest configuration.
        c.require(
            s.split_max_edge_cells == 0.0,
            "solver.split_max_edge_cells",
            s.split_max_edge_cells,
            "0 with solver.method = \"tl_mpm\" (its tissue never parts by numerics)",
        );
        let slicer = scene
            .tools
            .iter()
            .position(|t| matches!(t.shape, Shape::Slicer { .. } | Shape::MeshSlicer { .. }));
        c.require(
            slicer.is_none(),
            "solver.method",
            s.method,
            format!(
                "mls_mpm, pic_mpm, pb_mpm or implicit: tool[{}] cuts, and tl_mpm does not cut",
                slicer.unwrap_or_default()
            ),
        );
    }
    c.require(
        s.split_max_edge_cells == 0.0 || (0.5..=8.0).contains(&s.split_max_edge_cells),
        "solver.split_max_edge_cells",
        s.split_max_edge_cells,
        "0 (never split) or 0.5 ≤ value ≤ 8 cells (the longest deformed particle edge)",
    );
    c.within(
        "solver.split_max_growth",
        s.split_max_growth,
        1.0,
        64.0,
        "× the starting particle count (the most splitting may reach)",
    );
    c.within(
        "sleep.speed",
        scene.sleep.speed,
        0.0,
        10.0,
        "m/s (the speed below which tissue may sleep)",
    );

    if let Some(t) = &scene.table {
        c.require(
            t.height.is_finite() && t.height >= lo[2] && t.height <= hi[2],
            "table.height",
            t.height,
            format!(
                "between {:.4} and {:.4} m (inside the domain's z range less wall cells)",
                lo[2], hi[2]
            ),
        );
        if t.hold == Hold::Resting {
            c.within(
                "table.friction",
                t.friction,
                0.0,
                MAX_FRICTION,
                "(Coulomb coefficient)",
            );
        }
    }

    c.require(
        !scene.tissues.is_empty() || !scene.threads.is_empty(),
        "tissue",
        "none",
        "at least one [[tissue]] or [[thread]] block",
    );
    for (i, t) in scene.tissues.iter().enumerate() {
        let key = |k: &str| format!("tissue[{i}].{k}");
        let m = &t.material;
        c.require(
            m.youngs_modulus.is_finite() && m.youngs_modulus > 0.0 && m.youngs_modulus <= 1e9,
            key("material.youngs_modulus"),
            m.youngs_modulus,
            "0 < E ≤ 1e9 Pa",
        );
        c.require(
            m.poisson_ratio.is_finite() && (0.0..0.5).contains(&m.poisson_ratio),
            key("material.poisson_ratio"),
            m.poisson_ratio,
            "0 ≤ ν < 0.5",
        );
        c.require(
            m.density.is_finite() && m.density > 0.0 && m.density <= 1e5,
            key("material.density"),
            m.density,
            "0 < ρ ≤ 1e5 kg/m³",
        );
        c.within(
            key("material.damping"),
            m.damping,
            0.0,
            // Stiff analytic blocks (1 MPa, ν 0.49, a few mm deep) are damped near their
            // lowest mode, above 1e4 1/s.
            1e6,
            "1/s (a decay time of 1 µs and more)",
        );
        if let Some(toughness) = m.toughness {
            c.positive_up_to(
                key("material.toughness"),
                toughness,
                MAX_TOUGHNESS,
                "J/m² (G_c: energy per unit area of tear)",
            );
            c.require(
                matches!(
                    scene.solver.method,
                    Method::MlsMpm | Method::PicMpm | Method::TlMpm
                ),
                "solver.method",
                scene.solver.method,
                format!(
                    "mls_mpm, pic_mpm or tl_mpm: tissue[{i}].material.toughness (tearing) is \
                     stepped by the explicit methods only"
                ),
            );
        }
        c.require(
            (1..=4).contains(&t.particles_per_axis),
            key("particles_per_axis"),
            t.particles_per_axis,
            "1 to 4",
        );
        for a in 0..3 {
            c.positive_up_to(key(&format!("size[{a}]")), t.size[a], MAX_LENGTH, "m");
            if d.dx > 0.0 && t.size[a] > 0.0 {
                c.require(
                    t.size[a] >= 2.0 * d.dx,
                    key(&format!("size[{a}]")),
                    t.size[a],
                    format!("at least 2 grid cells (2·dx = {} m): the grid is too coarse for this tissue", 2.0 * d.dx),
                );
            }
        }
        let lo_corner = [0, 1, 2].map(|a| t.center[a] - 0.5 * t.size[a]);
        let hi_corner = [0, 1, 2].map(|a| t.center[a] + 0.5 * t.size[a]);
        c.require(
            inside(lo_corner) && inside(hi_corner),
            key("center"),
            t.center,
            format!("the whole block {region}"),
        );
        if let Some(table) = &scene.table {
            c.require(
                lo_corner[2] >= table.height - 1e-9,
                key("center"),
                t.center,
                format!(
                    "block bottom z = {:.4} m must not be below table.height = {} m",
                    lo_corner[2], table.height
                ),
            );
        }
    }

    if let Some(wound) = &scene.wound {
        let names: Vec<_> = scene.tissues.iter().map(|t| t.name.as_str()).collect();
        for side in wound {
            c.require(
                names.contains(&side.as_str()),
                "wound",
                side,
                format!("the name of a [[tissue]] block: one of {names:?}"),
            );
        }
        c.require(
            wound[0] != wound[1],
            "wound",
            format!("{wound:?}"),
            "two different [[tissue]] blocks, one either side of the wound",
        );
    }

    c.require(
        scene.tools.len() <= MAX_TOOLS,
        "tool",
        scene.tools.len(),
        format!("at most {MAX_TOOLS} tools"),
    );
    for (i, tool) in scene.tools.iter().enumerate() {
        let key = |k: &str| format!("tool[{i}] ({}).{k}", tool.name);
        if scene.tools[..i].iter().any(|o| o.name == tool.name) {
            c.require(false, key("name"), &tool.name, "unique among tools");
        }
        match tool.shape {
            Shape::Sphere { radius } => length(&mut c, key("shape.radius"), radius),
            Shape::Capsule {
                radius,
                half_length,
            } => {
                length(&mut c, key("shape.radius"), radius);
                length(&mut c, key("shape.half_length"), half_length);
            }
            Shape::Box { half_extents } => {
                for (a, h) in half_extents.iter().enumerate() {
                    length(&mut c, key(&format!("shape.half_extents[{a}]")), *h);
                }
            }
            Shape::Gripper {
                jaw_length,
                jaw_width,
                jaw_thickness,
            } => {
                length(&mut c, key("shape.jaw_length"), jaw_length);
                length(&mut c, key("shape.jaw_width"), jaw_width);
                length(&mut c, key("shape.jaw_thickness"), jaw_thickness);
            }
            Shape::Needle {
                radius,
                arc_angle,
                wire_radius,
            } => {
                length(&mut c, key("shape.radius"), radius);
                length(&mut c, key("shape.wire_radius"), wire_radius);
                c.require(
                    arc_angle > 0.0 && arc_angle < std::f32::consts::TAU,
                    key("shape.arc_angle"),
                    arc_angle,
                    "0 < arc_angle < 2π rad",
                );
            }
            Shape::Slicer {
                length: l,
                height,
                thickness,
            } => {
                // The blade separates a particle from the nodes across it only where it
                // covers a stencil: at least two cells long and high. Its thickness is the
                // spine's (the edge side has no thickness to resolve), finite and > 0.
                for (k, v) in [("shape.length", l), ("shape.height", height)] {
                    c.within(
                        key(k),
                        v as f64,
                        2.0 * d.dx,
                        MAX_LENGTH,
                        "m (at least 2·dx: the blade must cover a particle's stencil)",
                    );
                }
                c.require(
                    thickness.is_finite() && thickness > 0.0 && thickness <= 0.5 * height,
                    key("shape.thickness"),
                    thickness,
                    format!(
                        "0 < thickness ≤ height/2 = {} m (the spine's)",
                        0.5 * height
                    ),
                );
            }
            Shape::MeshSlicer { file, thickness } => match file.state() {
                None => c.require(
                    false,
                    key("shape.file"),
                    file.path(),
                    "a blade mesh read relative to the scene file (this scene was not read \
                     from a file)",
                ),
                Some(Err(e)) => c.require(false, key("shape.file"), file.path(), e.to_string()),
                Some(Ok(blade)) => {
                    // As for the quad: the blade must span a particle's stencil in both
                    // directions of its surface, and the spine fit on it.
                    let mut sides = [0, 1, 2].map(|a| blade.extents()[a] as f64);
                    sides.sort_by(f64::total_cmp);
                    c.require(
                        sides[1] >= 2.0 * d.dx,
                        key("shape.file"),
                        file.path(),
                        format!(
                            "a blade at least 2·dx = {} m across in both directions of its \
                             surface (this one's bounding box is {:.5} × {:.5} m): it must \
                             cover a particle's stencil",
                            2.0 * d.dx,
                            sides[2],
                            sides[1]
                        ),
                    );
                    let height = blade.height();
                    c.require(
                        thickness.is_finite() && thickness > 0.0 && thickness <= 0.5 * height,
                        key("shape.thickness"),
                        thickness,
                        format!(
                            "0 < thickness ≤ height/2 = {} m (the spine's; the blade's height \
                             is the farthest its surface lies from the spine)",
                            0.5 * height
                        ),
                    );
                }
            },
        }
        // Grid contact acts on nodes inside a solid; one thinner than two cells leaves too
        // few of a particle's 27 stencil nodes constrained, and tissue flows through it.
        if let (Some(thickness), true) = (tool.shape.solid_thickness(), d.dx > 0.0) {
            c.require(
                thickness as f64 >= 2.0 * d.dx * (1.0 - 1e-6),
                key("shape"),
                tool.shape,
                format!(
                    "solid parts at least 2 grid cells thick (2·dx = {} m, thinnest here {thickness} m): \
                     the grid is too coarse for this tool and tissue would flow through it",
                    2.0 * d.dx
                ),
            );
        }
        if let ContactModel::Coulomb { friction, drag } = tool.contact {
            c.within(
                key("contact.friction"),
                friction as f64,
                0.0,
                MAX_FRICTION,
                "(Coulomb coefficient)",
            );
            c.require(
                (0.0..=1.0).contains(&drag),
                key("contact.drag"),
                drag,
                "0 ≤ drag ≤ 1",
            );
        }
        if let Some((k, v)) = tool.jaw.invalid() {
            c.require(false, key(&format!("jaw.{k}")), v, "finite and > 0");
        }
        // dVRK's jaw: p 6 N·m/rad, d 0.09 N·m·s/rad, effort 0.16 N·m; a thousand times more
        // is no instrument.
        for (k, v, upper, unit) in [
            ("p_gain", tool.jaw.p_gain, 6000.0, "N·m/rad"),
            ("d_gain", tool.jaw.d_gain, 90.0, "N·m·s/rad"),
            ("effort_max", tool.jaw.effort_max, 160.0, "N·m"),
        ] {
            if v.is_finite() && v > 0.0 {
                c.positive_up_to(key(&format!("jaw.{k}")), v, upper, unit);
            }
        }
        c.require(
            !tool.keyframes.is_empty(),
            key("keyframe"),
            "none",
            "at least one [[tool.keyframe]]",
        );
        for (k, kf) in tool.keyframes.iter().enumerate() {
            let kkey = |f: &str| key(&format!("keyframe[{k}].{f}"));
            c.within(kkey("t"), kf.t, 0.0, MAX_TIME, "s (a day)");
            if k > 0 {
                let prev = tool.keyframes[k - 1].t;
                c.require(
                    kf.t > prev,
                    kkey("t"),
                    kf.t,
                    format!("greater than the previous keyframe's t = {prev}"),
                );
            }
            c.require(
                kf.position.iter().all(|v| v.is_finite()) && inside(kf.position),
                kkey("position"),
                kf.position,
                format!("tool outside the domain: must be {region}"),
            );
            c.require(
                kf.rpy_deg.iter().all(|v| v.abs() <= MAX_DEGREES),
                kkey("rpy_deg"),
                kf.rpy_deg,
                format!("angles of at most ±{MAX_DEGREES}°"),
            );
            c.require(
                kf.jaw_deg.is_finite() && (-40.0..=80.0).contains(&kf.jaw_deg),
                kkey("jaw_deg"),
                kf.jaw_deg,
                "−40° ≤ jaw ≤ 80° (the PSM jaw range)",
            );
        }
    }

    c.problems
        .extend(super::thread::validate(scene, &inside, &region));
    validate_arms(&mut c, scene);
    validate_outputs(&mut c, scene);
    if let Some(camera) = &scene.camera {
        c.problems.extend(
            camera
                .problems(scene.frame_rate_hz)
                .into_iter()
                .map(|e| Problem {
                    key: format!("camera.{}", e.key),
                    value: e.value,
                    allowed: e.reason,
                }),
        );
        let ecm = scene.arms.iter().any(|a| a.kind == ArmKind::Ecm);
        c.require(
            ecm || camera.position.is_some(),
            "camera.position",
            camera.position,
            "a camera without an ECM [[arm]] needs `position` and `look_at`",
        );
        if ecm {
            c.require(
                camera.position.is_none() && camera.look_at.is_none(),
                "camera.position",
                camera.position,
                "nothing: the camera rides at the ECM's tip",
            );
        }
    }
    c.problems
}

/// A tool dimension: a positive length up to [`MAX_LENGTH`].
fn length(c: &mut Checker, key: String, value: f32) {
    c.positive_up_to(key, value as f64, MAX_LENGTH, "m");
}

fn kind_name(kind: ArmKind) -> &'static str {
    match kind {
        ArmKind::Psm => "PSM",
        ArmKind::Ecm => "ECM",
    }
}

/// Arm names are used as topic namespaces and frame prefixes.
fn is_ros_name(name: &str) -> bool {
    let mut chars = name.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic())
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

fn validate_arms(c: &mut Checker, scene: &Scene) {
    let psms = scene.arms.iter().filter(|a| a.kind == ArmKind::Psm).count();
    c.require(
        psms <= 2,
        "arm",
        psms,
        "one or two [[arm]] tables of kind \"psm\"",
    );
    for (i, arm) in scene.arms.iter().enumerate() {
        let key = |k: &str| format!("arm[{i}] ({}).{k}", arm.name);
        c.require(
            is_ros_name(&arm.name),
            key("name"),
            &arm.name,
            "a ROS name: a letter, then letters, digits or _ (e.g. PSM1)",
        );
        if scene.arms[..i].iter().any(|o| o.name == arm.name) {
            c.require(false, key("name"), &arm.name, "unique among arms");
        }
        if let Some(urdf) = &arm.urdf {
            c.require(!urdf.is_empty(), key("urdf"), urdf, "a URDF file path");
        }
        let ecm = arm.kind == ArmKind::Ecm;
        let joints = if ecm { 4 } else { 6 };
        for (k, link) in [("base_link", &arm.base_link), ("tool_link", &arm.tool_link)] {
            if let Some(link) = link {
                c.require(!link.is_empty(), key(k), link, "a link name of the URDF");
            }
        }
        if let Some(speeds) = &arm.joint_speeds {
            c.require(
                speeds.len() == joints && speeds.iter().all(|v| *v > 0.0 && *v <= MAX_JOINT_SPEED),
                key("joint_speeds"),
                speeds,
                format!(
                    "{joints} speeds (one per joint of the {}), 0 < speed ≤ {MAX_JOINT_SPEED} \
                     (rad/s; insertion m/s)",
                    kind_name(arm.kind)
                ),
            );
        }
        if let Some(speed) = arm.jaw_speed {
            c.require(
                !ecm,
                key("jaw_speed"),
                speed,
                "only on a PSM (the ECM has no jaw)",
            );
            c.positive_up_to(key("jaw_speed"), speed, MAX_JOINT_SPEED, "rad/s");
        }
        c.require(
            arm.base_xyz.iter().all(|v| v.abs() <= MAX_LENGTH),
            key("base_xyz"),
            arm.base_xyz,
            format!("coordinates of at most ±{MAX_LENGTH} m"),
        );
        c.require(
            arm.base_rpy_deg.iter().all(|v| v.abs() <= MAX_DEGREES),
            key("base_rpy_deg"),
            arm.base_rpy_deg,
            format!("angles of at most ±{MAX_DEGREES}°"),
        );
        if let Some(tool_type) = &arm.tool_type {
            c.require(
                is_dvrk_tool_type(tool_type),
                key("tool_type"),
                tool_type,
                "dVRK's NAME:model, e.g. LARGE_NEEDLE_DRIVER:400006 (capitals, digits and _, \
                 then : and digits; at most 64 characters)",
            );
        }
        c.require(
            arm.tool_rpy_deg.iter().all(|v| v.abs() <= MAX_DEGREES),
            key("tool_rpy_deg"),
            arm.tool_rpy_deg,
            format!("angles of at most ±{MAX_DEGREES}°"),
        );
        c.require(
            arm.tool_xyz.iter().all(|v| v.abs() <= MAX_TOOL_OFFSET),
            key("tool_xyz"),
            arm.tool_xyz,
            format!(
                "coordinates of at most ±{MAX_TOOL_OFFSET} m: the tool is held at the \
                 instrument's tip"
            ),
        );
        // The URDF's limits are checked when the arm is built; no PSM joint turns more than a
        // turn either way, nor inserts more than a metre.
        c.require(
            arm.home_joints.len() == joints
                && arm
                    .home_joints
                    .iter()
                    .all(|v| v.abs() <= std::f64::consts::TAU),
            key("home_joints"),
            &arm.home_joints,
            format!(
                "{joints} joint values (one per joint of the {}) of at most ±2π rad (insertion \
                 ±2π m), inside the URDF's limits",
                kind_name(arm.kind)
            ),
        );
        c.within(
            key("home_jaw_deg"),
            arm.home_jaw_deg,
            -40.0,
            80.0,
            "° (the PSM jaw range; the URDF's limits are checked when the arm is built)",
        );
        if ecm {
            c.require(
                arm.home_jaw_deg == 0.0,
                key("home_jaw_deg"),
                arm.home_jaw_deg,
                "only on a PSM (the ECM has no jaw)",
            );
            if let Some(tool) = &arm.tool {
                c.require(false, key("tool"), tool, "nothing: the ECM holds no tool");
            }
            if let Some(tool_type) = &arm.tool_type {
                c.require(
                    false,
                    key("tool_type"),
                    tool_type,
                    "nothing: the ECM holds no tool",
                );
            }
            c.require(
                arm.tool_rpy_deg == [0.0; 3],
                key("tool_rpy_deg"),
                arm.tool_rpy_deg,
                "only on a PSM (the ECM holds no tool)",
            );
            c.require(
                arm.tool_xyz == [0.0; 3],
                key("tool_xyz"),
                arm.tool_xyz,
                "only on a PSM (the ECM holds no tool)",
            );
            c.require(
                arm.mode == ArmMode::Simulated,
                key("mode"),
                "mirror",
                "\"simulated\" for the ECM",
            );
            if scene.arms[..i].iter().any(|o| o.kind == ArmKind::Ecm) {
                c.require(false, key("kind"), "ecm", "at most one ECM");
            }
        } else {
            let tool = arm.tool.as_deref().unwrap_or_default();
            c.require(
                scene.tools.iter().any(|t| t.name == tool),
                key("tool"),
                tool,
                format!(
                    "the name of a [[tool]] ({})",
                    scene
                        .tools
                        .iter()
                        .map(|t| t.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            );
            if scene.arms[..i]
                .iter()
                .any(|o| o.kind == ArmKind::Psm && o.tool.as_deref() == Some(tool))
            {
                c.require(false, key("tool"), tool, "a tool no other arm drives");
            }
        }
        if let Some(ns) = &arm.mirror_of {
            c.require(
                arm.mode == ArmMode::Mirror,
                key("mirror_of"),
                ns,
                "only with mode = \"mirror\"",
            );
            c.require(
                ns.starts_with('/') && ns[1..].split('/').all(is_ros_name),
                key("mirror_of"),
                ns,
                "an absolute ROS namespace such as /PSM1",
            );
        }
    }
    let one = scene.teleop.len() == 1;
    for (i, t) in scene.teleop.iter().enumerate() {
        let key = |k: &str| match one {
            true => format!("teleop.{k}"),
            false => format!("teleop[{i}].{k}"),
        };
        let arm = scene.arms.iter().find(|a| a.name == t.arm);
        c.require(
            arm.is_some_and(|a| a.mode == ArmMode::Simulated && a.kind == ArmKind::Psm),
            key("arm"),
            &t.arm,
            "the name of a PSM [[arm]] with mode = \"simulated\"",
        );
        for (k, v) in [("mtm", &t.mtm), ("console", &t.console)] {
            c.require(
                v.split('/').filter(|s| !s.is_empty()).all(is_ros_name) && !v.is_empty(),
                key(k),
                v,
                "a ROS namespace (letters, digits, _ and /)",
            );
        }
        c.positive_up_to(
            key("scale"),
            t.scale,
            10.0,
            "(PSM motion per MTM motion; dVRK's default is 0.2)",
        );
        c.within(
            key("force_feedback_scale"),
            t.force_feedback_scale,
            0.0,
            10.0,
            "(MTM force per PSM force)",
        );
        // Each pair is one MTM driving one PSM, and one console's pedals engage them all.
        let earlier = &scene.teleop[..i];
        c.require(
            earlier.iter().all(|e| e.arm != t.arm),
            key("arm"),
            &t.arm,
            "an arm no other [[teleop]] pair drives",
        );
        c.require(
            earlier.iter().all(|e| e.mtm != t.mtm),
            key("mtm"),
            &t.mtm,
            "an MTM no other [[teleop]] pair reads",
        );
        c.require(
            earlier.iter().all(|e| e.console == t.console),
            key("console"),
            &t.console,
            "the console of the other [[teleop]] pairs (one console's clutch and operator \
             pedals engage every pair)",
        );
    }
}

fn validate_outputs(c: &mut Checker, scene: &Scene) {
    let o = &scene.outputs;
    for (k, v) in [
        ("outputs.points_rate_hz", o.points_rate_hz),
        ("outputs.surface_rate_hz", o.surface_rate_hz),
        ("outputs.wrench_rate_hz", o.wrench_rate_hz),
        ("outputs.tf_rate_hz", o.tf_rate_hz),
        ("outputs.arm_rate_hz", o.arm_rate_hz),
        ("outputs.thread_rate_hz", o.thread_rate_hz),
        ("outputs.pieces_rate_hz", o.pieces_rate_hz),
    ] {
        c.require(
            v.is_finite() && (0.0..=1000.0).contains(&v),
            k,
            v,
            "0 (off) to 1000 Hz",
        );
    }
    c.require(
        (1..=1_000_000).contains(&o.points_downsample),
        "outputs.points_downsample",
        o.points_downsample,
        "1 ≤ value ≤ 1000000 (1 publishes every particle)",
    );
    c.within(
        "outputs.points_voxel",
        o.points_voxel,
        0.0,
        1.0,
        "m (0: off, else a cube edge)",
    );
}

/// dVRK's instrument naming, `NAME:model` (`LARGE_NEEDLE_DRIVER:400006`).
fn is_dvrk_tool_type(value: &str) -> bool {
    let Some((name, model)) = value.split_once(':') else {
        return false;
    };
    value.len() <= 64
        && !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_')
        && !model.is_empty()
        && model.chars().all(|c| c.is_ascii_digit())
}
