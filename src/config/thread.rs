//! `[[thread]]`: a suture thread (a Cosserat rod, see [`crate::rod`]) laid out straight in
//! the scene, its material, which ends are held, and how its solver steps; and the checks
//! that refuse threads the rod cannot simulate.
//!
//! Every key but `start` has a default: a 15 cm USP 3-0 nylon thread along +x of 60
//! segments (2.5 mm each), both ends free, colliding with itself, the rod solver's default
//! substeps and iterations.

use super::validate::Problem;
use super::{Scene, Tool};
use crate::mpm::Method;
use crate::rod::solver::RodSolverSettings;
use crate::rod::ThreadMaterial;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
/// `[[thread]]` in a scene file: a suture thread, simulated as a Cosserat rod.
pub struct Thread {
    #[serde(default = "default_name")]
    /// The thread's name, for its topics and reports (default `thread`).
    pub name: String,
    /// World position of the first point (m): the thread lies straight from it along
    /// `direction`. Give either `start` or `points`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start: Option<[f64; 3]>,
    /// A polyline (m) the thread is laid along instead, from its first point: `segments`
    /// points each a segment's length (`length / segments`) from the last, so that the
    /// thread covers `length` of chord along the polyline.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub points: Option<Vec<[f64; 3]>>,
    /// The shape the thread has at rest: `straight` (a thread laid along `points` springs
    /// back as far as the table's friction lets it) or `as_laid` (its starting shape, a
    /// thread with the memory of a coil).
    #[serde(default)]
    pub rest_shape: RestShape,
    /// Direction from the first point to the last (any length but zero).
    #[serde(default = "default_direction")]
    pub direction: [f64; 3],
    /// Rest length (m).
    #[serde(default = "default_length")]
    pub length: f64,
    /// Number of segments (points = segments + 1).
    #[serde(default = "default_segments")]
    pub segments: u32,
    /// Cross-section radius (m).
    #[serde(default = "default_radius")]
    pub radius: f64,
    /// Young's modulus E (Pa).
    #[serde(default = "default_youngs_modulus")]
    pub youngs_modulus: f64,
    /// Shear modulus G (Pa).
    #[serde(default = "default_shear_modulus")]
    pub shear_modulus: f64,
    /// kg/m³.
    #[serde(default = "default_density")]
    pub density: f64,
    /// Which ends are held where they start: `none`, `start`, `end` or `both`.
    #[serde(default)]
    pub pinned: PinnedEnds,
    /// Coulomb friction coefficient against the table.
    #[serde(default = "default_friction")]
    pub friction: f64,
    /// Whether the thread collides with itself (continuous segment–segment contact: it
    /// cannot pass through itself, so knots hold).
    #[serde(default = "default_self_contact")]
    pub self_contact: bool,
    /// Coulomb friction coefficient of the thread on itself.
    #[serde(default = "default_self_friction")]
    pub self_friction: f64,
    /// Coulomb friction coefficient of tissue sliding along the thread (see
    /// [`crate::mpm::cpu::thread_contact`]).
    #[serde(default = "default_tissue_friction")]
    pub tissue_friction: f64,
    /// Fraction of the tissue's slip along the thread removed per substep (seed 002's drag).
    #[serde(default)]
    pub tissue_drag: f64,
    /// The needle tool (`shape.type = "needle"`) the thread is swaged to: the thread's first
    /// point sits in the needle's swage end (the arc's end at `arc_angle`, the tip being at
    /// angle 0) and moves rigidly with the needle, through whatever the needle passes. The
    /// first point must start there (`check` prints where that is).
    #[serde(default)]
    pub swaged_to: Option<String>,
    /// Solver substeps per frame.
    #[serde(default = "default_substeps")]
    pub substeps: u32,
    /// Direct-solve iterations per substep.
    #[serde(default = "default_iterations")]
    pub iterations: u32,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
/// The shape a thread returns to at rest.
pub enum RestShape {
    #[default]
    /// Straight, whatever shape it was laid in.
    Straight,
    /// The shape it was laid in.
    AsLaid,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
/// Which ends of a thread are held where they start.
pub enum PinnedEnds {
    #[default]
    /// Neither end.
    None,
    /// The first point.
    Start,
    /// The last point.
    End,
    /// Both ends.
    Both,
}

impl PinnedEnds {
    /// Whether the first point is held.
    pub fn start(self) -> bool {
        matches!(self, PinnedEnds::Start | PinnedEnds::Both)
    }
    /// Whether the last point is held.
    pub fn end(self) -> bool {
        matches!(self, PinnedEnds::End | PinnedEnds::Both)
    }
}

fn default_name() -> String {
    "thread".into()
}
fn default_direction() -> [f64; 3] {
    [1.0, 0.0, 0.0]
}
fn default_length() -> f64 {
    0.15
}
fn default_segments() -> u32 {
    60
}
fn default_radius() -> f64 {
    ThreadMaterial::nylon_3_0().radius as f64
}
fn default_youngs_modulus() -> f64 {
    ThreadMaterial::nylon_3_0().young_modulus as f64
}
fn default_shear_modulus() -> f64 {
    ThreadMaterial::nylon_3_0().shear_modulus as f64
}
fn default_density() -> f64 {
    ThreadMaterial::nylon_3_0().density as f64
}
fn default_friction() -> f64 {
    0.3
}
fn default_self_contact() -> bool {
    true
}
fn default_self_friction() -> f64 {
    0.2
}
fn default_tissue_friction() -> f64 {
    0.2
}
fn default_substeps() -> u32 {
    RodSolverSettings::default().substeps
}
fn default_iterations() -> u32 {
    RodSolverSettings::default().iterations
}

impl Thread {
    /// A default (3-0 nylon) thread starting at `start`.
    pub fn nylon_3_0(start: [f64; 3]) -> Thread {
        Thread {
            name: default_name(),
            start: Some(start),
            points: None,
            rest_shape: RestShape::Straight,
            direction: default_direction(),
            length: default_length(),
            segments: default_segments(),
            radius: default_radius(),
            youngs_modulus: default_youngs_modulus(),
            shear_modulus: default_shear_modulus(),
            density: default_density(),
            pinned: PinnedEnds::None,
            friction: default_friction(),
            self_contact: default_self_contact(),
            self_friction: default_self_friction(),
            tissue_friction: default_tissue_friction(),
            tissue_drag: 0.0,
            swaged_to: None,
            substeps: default_substeps(),
            iterations: default_iterations(),
        }
    }

    /// The thread's material (radius, moduli, density).
    pub fn material(&self) -> ThreadMaterial {
        ThreadMaterial {
            radius: self.radius as f32,
            young_modulus: self.youngs_modulus as f32,
            shear_modulus: self.shear_modulus as f32,
            density: self.density as f32,
        }
    }

    /// The solver's substeps and iterations.
    pub fn solver_settings(&self) -> RodSolverSettings {
        RodSolverSettings {
            substeps: self.substeps,
            iterations: self.iterations,
        }
    }

    /// World position of the last point of a straight thread (`start`, `direction`), or
    /// `None` when it has no start or the direction has no length.
    pub fn end(&self) -> Option<[f64; 3]> {
        let start = self.start?;
        let [x, y, z] = self.direction;
        let n = (x * x + y * y + z * z).sqrt();
        (n.is_finite() && n > 0.0)
            .then(|| [0, 1, 2].map(|a| start[a] + self.direction[a] / n * self.length))
    }

    /// The thread's starting centreline, `segments + 1` points: straight from `start`, or
    /// laid along `points`. `None` when neither fits (see [`lay_along`]).
    pub fn centreline(&self) -> Option<Vec<[f64; 3]>> {
        let n = self.segments as usize;
        match (&self.points, self.start) {
            (Some(polyline), _) => lay_along(polyline, self.length / n as f64, n),
            (None, Some(start)) => {
                let end = self.end()?;
                Some(
                    (0..=n)
                        .map(|i| {
                            let s = i as f64 / n as f64;
                            [0, 1, 2].map(|a| start[a] + (end[a] - start[a]) * s)
                        })
                        .collect(),
                )
            }
            (None, None) => None,
        }
    }
}

/// `segments + 1` points along `polyline`, from its first point, each `step` (m, straight
/// line) from the one before and further along: a thread of `segments` pieces of rest
/// length `step` laid along it. `None` when the polyline ends before the thread does.
pub fn lay_along(polyline: &[[f64; 3]], step: f64, segments: usize) -> Option<Vec<[f64; 3]>> {
    use nalgebra::Vector3;
    let corners: Vec<Vector3<f64>> = polyline.iter().map(|&p| Vector3::from(p)).collect();
    let mut laid = vec![*corners.first()?];
    // The walk: on piece `k` (corners k, k+1) at parameter `t`.
    let (mut k, mut t) = (0, 0.0);
    while laid.len() <= segments {
        let p = *laid.last()?;
        let (a, b) = (*corners.get(k)?, *corners.get(k + 1)?);
        // |a + u (b − a) − p| = step for the largest u, if it lies in [t, 1]: the sphere of
        // radius `step` about p leaves the piece there.
        let (d, f) = (b - a, a - p);
        let (qa, qb, qc) = (
            d.norm_squared(),
            2.0 * d.dot(&f),
            f.norm_squared() - step * step,
        );
        let disc = qb * qb - 4.0 * qa * qc;
        let u = (disc >= 0.0 && qa > 0.0).then(|| (-qb + disc.sqrt()) / (2.0 * qa));
        match u.filter(|&u| u >= t && u <= 1.0) {
            Some(u) => {
                laid.push(a + d * u);
                t = u;
            }
            None => {
                k += 1;
                t = 0.0;
            }
        }
    }
    Some(laid.iter().map(|p| [p.x, p.y, p.z]).collect())
}

/// Thinnest and thickest thread: USP 11-0 (10 µm diameter) to a 1 cm cord.
const RADIUS_RANGE: (f64, f64) = (5e-6, 5e-3);
/// Moduli from a soft elastomer (1 MPa) to steel wire and beyond (1 TPa).
const MODULUS_RANGE: (f64, f64) = (1e6, 1e12);
/// Densities from a foam to tungsten.
const DENSITY_RANGE: (f64, f64) = (10.0, 20_000.0);
/// Most segments per thread: the direct solve is linear in segments, 10 000 a few ms.
const MAX_SEGMENTS: u32 = 10_000;
/// Shortest piece of a `points` polyline (m): shorter ones are repeated points.
const MIN_PIECE: f64 = 1e-9;
/// The longest thread (m).
const MAX_THREAD_LENGTH: f64 = 10.0;

/// The deepest point of thread `t` inside the first solid tool it starts in (sphere,
/// capsule, box, open gripper jaw, needle, each where the scene's script starts it: its
/// first keyframe), as a problem under `key`. The rod's contact keeps the thread outside a
/// tool's surface; one starting inside would be pushed through the tool or held crossed in
/// it. A gripper closed at the start holds what lies between its jaws. A tool an arm drives
/// starts where the arm's home joints put it, not at a keyframe, and is not checked.
fn start_inside_tool(scene: &Scene, t: &Thread, key: &dyn Fn(&str) -> String) -> Option<Problem> {
    use crate::tools::Shape;
    use nalgebra::Vector3;
    let points = t.centreline()?;
    let driven = |name: &str| scene.arms.iter().any(|a| a.tool.as_deref() == Some(name));
    for tool in scene.tools.iter().filter(|tool| !driven(&tool.name)) {
        if matches!(tool.shape, Shape::Slicer { .. } | Shape::MeshSlicer { .. }) {
            continue;
        }
        let Some(first) = tool.keyframes.first() else {
            continue;
        };
        if matches!(tool.shape, Shape::Gripper { .. }) && first.jaw_deg <= 0.0 {
            // Jaws closed at the start hold the thread between them: a grasp (the closed
            // jaws' volume is the grasp's, `world::thread_body::grasp`).
            continue;
        }
        let pose = first.pose();
        // The points a swaged needle's wire covers are held in it.
        let swaged = match tool.shape {
            Shape::Needle { wire_radius, .. } if t.swaged_to.as_ref() == Some(&tool.name) => {
                swage_covered(t, wire_radius) + 1
            }
            _ => 0,
        };
        let deepest = points
            .iter()
            .enumerate()
            .skip(swaged)
            .map(|(k, point)| {
                let local = pose.rotation.inverse() * (Vector3::from(*point) - pose.position);
                let hit = tool.shape.query(local.cast::<f32>(), pose.jaw as f32);
                (k, -hit.distance)
            })
            .max_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((k, depth)) = deepest.filter(|&(_, depth)| depth > 0.0) {
            let point = points[k];
            let field = if t.points.is_some() {
                "points"
            } else {
                "start"
            };
            return Some(Problem {
                key: key(field),
                value: format!(
                    "point {k} of the thread at ({:.4}, {:.4}, {:.4}) m",
                    point[0], point[1], point[2]
                ),
                allowed: format!(
                    "outside every solid tool at the script's start: it lies {:.2} mm inside \
                     tool {:?}",
                    depth * 1e3,
                    tool.name
                ),
            });
        }
    }
    None
}

/// The problems of `scene`'s threads; `inside` tells whether a point lies in the domain less
/// its wall cells, described by `region`.
pub(super) fn validate(
    scene: &Scene,
    inside: &dyn Fn([f64; 3]) -> bool,
    region: &str,
) -> Vec<Problem> {
    let mut problems = Vec::new();
    let mut require = |ok: bool, key: String, value: String, allowed: String| {
        if !ok {
            problems.push(Problem {
                key,
                value,
                allowed,
            });
        }
    };
    let within = |v: f64, (lo, hi): (f64, f64)| v.is_finite() && v >= lo && v <= hi;
    if !scene.threads.is_empty() && !scene.tissues.is_empty() {
        // Threads in tissue are contact geometry of the explicit grid update
        // (crate::mpm::cpu::thread_contact), on either backend.
        let method = scene.solver.method;
        require(
            matches!(method, Method::MlsMpm | Method::PicMpm),
            "solver.method".into(),
            format!("{method:?}"),
            "mls_mpm or pic_mpm: a thread in tissue is contact geometry of the explicit \
             update-Lagrangian grid update only"
                .into(),
        );
    }
    for (i, t) in scene.threads.iter().enumerate() {
        let key = |k: &str| format!("thread[{i}] ({}).{k}", t.name);
        if let Some(p) = start_inside_tool(scene, t, &key) {
            require(false, p.key, p.value, p.allowed);
        }
        if scene.threads[..i].iter().any(|o| o.name == t.name) {
            require(
                false,
                key("name"),
                format!("{:?}", t.name),
                "unique among threads".into(),
            );
        }
        for (k, v, range, what) in [
            ("radius", t.radius, RADIUS_RANGE, "m"),
            ("youngs_modulus", t.youngs_modulus, MODULUS_RANGE, "Pa"),
            ("shear_modulus", t.shear_modulus, MODULUS_RANGE, "Pa"),
            ("density", t.density, DENSITY_RANGE, "kg/m³"),
        ] {
            require(
                within(v, range),
                key(k),
                format!("{v:?}"),
                format!("{} ≤ value ≤ {} {what}", range.0, range.1),
            );
        }
        require(
            (1..=MAX_SEGMENTS).contains(&t.segments),
            key("segments"),
            t.segments.to_string(),
            format!("1 ≤ segments ≤ {MAX_SEGMENTS}"),
        );
        require(
            t.length.is_finite() && t.length > 0.0 && t.length <= MAX_THREAD_LENGTH,
            key("length"),
            format!("{:?}", t.length),
            format!("0 < length ≤ {MAX_THREAD_LENGTH} m"),
        );
        // A segment shorter than the thread is thick is no rod: its bending and shear
        // stiffnesses (EI/l, κGA·l) meet and the discrete frames stop following the line.
        if t.length > 0.0
            && (1..=MAX_SEGMENTS).contains(&t.segments)
            && within(t.radius, RADIUS_RANGE)
        {
            let segment = t.length / t.segments as f64;
            require(
                segment >= 2.0 * t.radius,
                key("length"),
                format!("{:?}", t.length),
                format!(
                    "at least segments × diameter = {} × {:.3e} = {:.3e} m (each segment at least as long as the thread is thick)",
                    t.segments,
                    2.0 * t.radius,
                    t.segments as f64 * 2.0 * t.radius
                ),
            );
        }
        match (&t.points, t.start) {
            (Some(_), Some(start)) => require(
                false,
                key("start"),
                format!("{start:?}"),
                "absent when `points` lays the thread out (give one of `start`, `points`)".into(),
            ),
            (None, None) => require(
                false,
                key("start"),
                "missing".into(),
                "a point in the domain, or `points` (give one of `start`, `points`)".into(),
            ),
            (None, Some(start)) => validate_straight(t, start, inside, region, &key, &mut require),
            (Some(polyline), None) => {
                validate_polyline(t, polyline, inside, region, &key, &mut require)
            }
        }
        require(
            within(t.tissue_drag, (0.0, 1.0)),
            key("tissue_drag"),
            format!("{:?}", t.tissue_drag),
            "0 ≤ value ≤ 1 (fraction of the slip removed per substep)".into(),
        );
        for (k, v) in [
            ("friction", t.friction),
            ("self_friction", t.self_friction),
            ("tissue_friction", t.tissue_friction),
        ] {
            require(
                within(v, (0.0, 10.0)),
                key(k),
                format!("{v:?}"),
                "0 ≤ value ≤ 10 (Coulomb coefficient)".into(),
            );
        }
        if let Some(p) = swage_problem(scene, t, &key) {
            require(false, p.key, p.value, p.allowed);
        }
        require(
            (1..=100).contains(&t.substeps),
            key("substeps"),
            t.substeps.to_string(),
            "1 ≤ substeps ≤ 100 (per frame)".into(),
        );
        require(
            (1..=20).contains(&t.iterations),
            key("iterations"),
            t.iterations.to_string(),
            "1 ≤ iterations ≤ 20 (direct solves per substep)".into(),
        );
    }
    problems
}

/// How many points after the first the wire of a needle of `wire_radius` covers at the
/// swage of thread `t` (laid out of the needle along its arc): the points whose distance
/// from the swage end is less than the wire's radius plus the thread's.
pub fn swage_covered(t: &Thread, wire_radius: f32) -> usize {
    let segment = t.length / t.segments.max(1) as f64;
    ((wire_radius as f64 + t.radius) / segment).ceil() as usize
}

/// What is wrong with thread `t`'s `swaged_to`, if anything: it must name a needle tool,
/// the thread's first point must not also be pinned, and where the needle's script starts
/// it (its first keyframe; an arm's needle starts at the arm's home, checked when the arm
/// is built: [`swage_miss`]) the first point must lie in the needle's swage end, within the
/// wire's radius.
fn swage_problem(scene: &Scene, t: &Thread, key: &dyn Fn(&str) -> String) -> Option<Problem> {
    let needle = t.swaged_to.as_ref()?;
    let problem = |field: &str, value: String, allowed: String| {
        Some(Problem {
            key: key(field),
            value,
            allowed,
        })
    };
    let Some(tool) = scene.tools.iter().find(|tool| &tool.name == needle) else {
        let names: Vec<_> = scene.tools.iter().map(|tool| tool.name.as_str()).collect();
        return problem(
            "swaged_to",
            format!("{needle:?}"),
            format!("the name of a needle tool of the scene (tools: {names:?})"),
        );
    };
    let crate::tools::Shape::Needle { .. } = tool.shape else {
        return problem(
            "swaged_to",
            format!("{needle:?}"),
            "a tool of shape type \"needle\" (a thread is swaged to a needle's end)".into(),
        );
    };
    if t.pinned.start() {
        return problem(
            "pinned",
            format!("{:?}", t.pinned),
            "\"none\" or \"end\": the first point is held by the needle it is swaged to".into(),
        );
    }
    let driven = scene.arms.iter().any(|a| a.tool.as_deref() == Some(needle));
    let (Some(first), false) = (tool.keyframes.first(), driven) else {
        return None;
    };
    let (value, allowed) = swage_miss(t, tool, &first.pose(), "its first keyframe")?;
    problem(
        if t.points.is_some() {
            "points"
        } else {
            "start"
        },
        value,
        allowed,
    )
}

type Require<'a> = dyn FnMut(bool, String, String, String) + 'a;

/// A straight thread: from `start` along `direction`, both ends in the domain.
fn validate_straight(
    t: &Thread,
    start: [f64; 3],
    inside: &dyn Fn([f64; 3]) -> bool,
    region: &str,
    key: &dyn Fn(&str) -> String,
    require: &mut Require,
) {
    require(
        start.iter().all(|v| v.is_finite()) && inside(start),
        key("start"),
        format!("{start:?}"),
        format!("thread outside the domain: must be {region}"),
    );
    match t.end() {
        None => require(
            false,
            key("direction"),
            format!("{:?}", t.direction),
            "a finite, non-zero vector".into(),
        ),
        Some(end) => require(
            !t.length.is_finite() || inside(end),
            key("length"),
            format!("{:?}", t.length),
            format!(
                "thread outside the domain: its end ({:.4}, {:.4}, {:.4}) m must be {region}",
                end[0], end[1], end[2]
            ),
        ),
    }
}

/// A thread laid along `polyline`: at least two corners, all in the domain (the domain is
/// a box, so the pieces between them are too), no piece of zero length, and long enough to
/// lay the whole thread along.
fn validate_polyline(
    t: &Thread,
    polyline: &[[f64; 3]],
    inside: &dyn Fn([f64; 3]) -> bool,
    region: &str,
    key: &dyn Fn(&str) -> String,
    require: &mut Require,
) {
    if polyline.len() < 2 {
        require(
            false,
            key("points"),
            format!("{} point(s)", polyline.len()),
            "at least 2 points (a polyline the thread is laid along)".into(),
        );
        return;
    }
    for (i, p) in polyline.iter().enumerate() {
        require(
            p.iter().all(|v| v.is_finite()) && inside(*p),
            key(&format!("points[{i}]")),
            format!("{p:?}"),
            format!("thread outside the domain: must be {region}"),
        );
    }
    for (i, w) in polyline.windows(2).enumerate() {
        let piece = (0..3)
            .map(|a| (w[1][a] - w[0][a]).powi(2))
            .sum::<f64>()
            .sqrt();
        require(
            piece > MIN_PIECE,
            key(&format!("points[{}]", i + 1)),
            format!("{:?}", w[1]),
            format!("more than {MIN_PIECE} m from points[{i}] (no piece of zero length)"),
        );
    }
    let arc: f64 = polyline
        .windows(2)
        .map(|w| {
            (0..3)
                .map(|a| (w[1][a] - w[0][a]).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .sum();
    if t.length.is_finite() && t.length > 0.0 && (1..=MAX_SEGMENTS).contains(&t.segments) {
        require(
            t.centreline().is_some(),
            key("length"),
            format!("{:?}", t.length),
            format!(
                "a thread the polyline `points` can hold: it is {arc:.4} m long, and {} segments of {:.3e} m must fit along it one after another",
                t.segments,
                t.length / t.segments as f64
            ),
        );
    }
}

/// Where thread `t`'s first point misses the swage end of `needle` at `pose` (placed there
/// by `placed_by`, for the message) by more than the wire's radius: the point as a value and
/// what is allowed, with where the swage end is and how far off the point lies. `None` when
/// it is in the swage end, or `needle` is no needle, or the thread has no centreline.
pub fn swage_miss(
    t: &Thread,
    needle: &Tool,
    pose: &crate::tools::ToolPose,
    placed_by: &str,
) -> Option<(String, String)> {
    let (Some((end, _)), crate::tools::Shape::Needle { wire_radius, .. }) =
        (needle.shape.swage_end(), needle.shape)
    else {
        return None;
    };
    let at = pose.position + pose.rotation * end.cast::<f64>();
    let start = t.centreline()?[0];
    let off = (nalgebra::Vector3::from(start) - at).norm();
    (off > wire_radius as f64).then(|| {
        (
            format!(
                "first point ({:.5}, {:.5}, {:.5}) m",
                start[0], start[1], start[2]
            ),
            format!(
                "the swage end of needle {:?} where {placed_by} puts it, ({:.5}, {:.5}, \
                 {:.5}) m, within the wire's radius {:.2} mm: the first point lies {:.2} mm \
                 from it",
                needle.name,
                at.x,
                at.y,
                at.z,
                wire_radius * 1e3,
                off * 1e3
            ),
        )
    })
}
