//! A suture thread in the world: the rod (see [`crate::rod`]) with its solver, the ends the
//! scene holds, the table, domain walls and tools it meets, and the grippers holding it
//! ([`grasp`]). The world steps each thread once per frame alongside the tissue, through
//! [`RodSolver::step_frame_in`] with one [`RodEnvironment`] per frame.
//!
//! [`crate::rod::knot`] tells whether its centreline is knotted.

pub mod grasp;

use crate::config::thread::RestShape;
use crate::config::{Scene, Thread};
use crate::math::Vec3;
use crate::mpm::grid::WALL_NODES;
use crate::rod::{Rod, RodAttachment, RodCollider, RodEnvironment, RodSolver};
use crate::tools::ContactModel;
use crate::world::WorldTool;
use grasp::{Grasps, GripperView};
use nalgebra::Quaternion;

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

/// One thread and how it steps.
pub struct ThreadBody {
    pub name: String,
    pub rod: Rod,
    solver: RodSolver,
    /// Points the scene holds where they start.
    pinned: Vec<bool>,
    /// The scene's held points and where they are held.
    anchors: Vec<(usize, Vec3)>,
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
                anchors.push((i, rod.points[i]));
            }
        }
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
            pinned,
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
        }
    }

    /// Advances one frame of `dt` seconds while the tools `colliders` (every tool of the
    /// scene, in scene order) and among them the grippers `grippers` move over it: first grasps begin or end
    /// (jaws closed on the thread catch the points between their faces; opening lets them
    /// go), then the rod steps among the table, walls and tools, the grasped points moving
    /// with their jaws and the pinned ones staying put.
    pub fn step_frame(&mut self, dt: f64, colliders: &[RodCollider], grippers: &[GripperView]) {
        let radius = self.rod.material.radius;
        self.grasps
            .update(&self.rod, grippers, radius, &self.pinned);
        self.attachments.clear();
        self.grasps.attachments(grippers, &mut self.attachments);
        self.attachments
            .extend(self.anchors.iter().map(|&(point, at)| RodAttachment {
                point,
                from: at,
                to: at,
            }));
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
                RodCollider {
                    spared: self
                        .grasps
                        .held_range(tool)
                        .map(|(lo, hi)| (lo.saturating_sub(reach), (hi + reach).min(last))),
                    ..*c
                }
            }));
        let env = RodEnvironment {
            table_height: self.table.map(|(z, _)| z),
            table_friction: self.table.map_or(0.0, |(_, mu)| mu),
            colliders: &self.colliders,
            attachments: &self.attachments,
            walls: Some(self.walls),
            self_collision: self.self_contact,
            self_friction: self.self_friction,
        };
        self.solver.step_frame_in(&mut self.rod, dt as f32, &env);
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

    /// Points held by grippers now.
    pub fn grasped_points(&self) -> usize {
        self.grasps.held_points()
    }

    /// Whether tool `tool` holds any of this thread.
    pub fn held_by(&self, tool: usize) -> bool {
        self.grasps.holds_with(tool)
    }
}
