//! Grippers holding a thread. A thread is far too thin for the tissue's grid grip (its
//! diameter is a tenth of a cell), so a gripper holds it kinematically: when its jaws are
//! closed on the thread — the jaw controller presses them shut (see
//! [`crate::tools::JawServo::pressing`]) with the tips no further apart than the thread is
//! thick — every thread point inside the closed jaws' volume is caught between the faces
//! and from then on moves rigidly with the tool frame: each frame it is a
//! [`RodAttachment`] (inverse mass 0) from where the jaws hold it at the frame's start to
//! where they hold it at its end, so that it turns with the tool as well as moving with it.
//! When the jaws stop pressing or open wider than the thread, the points are let go with
//! the velocity the jaws gave them.
//!
//! The closed jaws' volume, in the tool frame (x across the jaw width, y across the faces,
//! z from the hinge to the tips): |x| ≤ width/2 + r, −r ≤ z ≤ length + r, |y| ≤ thickness + r.
//! A point that far from the faces' plane was swept between them as they closed.

use crate::math::Vec3;
use crate::rod::{Rod, RodAttachment};
use crate::tools::{Shape, ToolPose};
use crate::world::WorldTool;
use nalgebra::Vector3;

/// What a thread needs of one gripper over the frame being stepped.
#[derive(Clone, Debug)]
pub struct GripperView {
    /// Scene index of the tool.
    pub tool: usize,
    /// Jaw length from the hinge, m.
    pub jaw_length: f32,
    /// Jaw width, m.
    pub jaw_width: f32,
    /// Jaw thickness, m.
    pub jaw_thickness: f32,
    /// Tool pose at the frame's start and end (it moves linearly between them).
    pub from: ToolPose,
    /// Tool pose at the frame's end.
    pub to: ToolPose,
    /// Jaw opening reached at the frame's end (rad).
    pub opening: f64,
    /// The jaw controller presses the jaws shut on whatever stopped them.
    pub pressing: bool,
}

impl GripperView {
    /// The view of `tool` (scene index `index`) over [t0, t1], or `None` when it has no jaws.
    pub fn of(index: usize, tool: &WorldTool, t0: f64, t1: f64) -> Option<GripperView> {
        let Shape::Gripper {
            jaw_length,
            jaw_width,
            jaw_thickness,
        } = tool.shape
        else {
            return None;
        };
        let jaw = tool.jaw()?;
        Some(GripperView {
            tool: index,
            jaw_length,
            jaw_width,
            jaw_thickness,
            from: tool.pose_at(t0),
            to: tool.pose_at(t1),
            opening: jaw.angle,
            pressing: jaw.pressing(),
        })
    }

    /// Whether the jaws are closed on a thread of `radius`: pressed shut, tips no further
    /// apart than its diameter.
    pub fn closed_on(&self, radius: f32) -> bool {
        let tip_gap = 2.0 * self.jaw_length as f64 * (0.5 * self.opening).sin();
        self.pressing && tip_gap <= 2.0 * radius as f64
    }

    /// Whether the jaws are open past a thread of `radius`: their tips further apart than
    /// the jaws are thick, so that the points they held lie in the gap between the faces.
    fn open_past(&self, radius: f32) -> bool {
        let tip_gap = 2.0 * self.jaw_length as f64 * (0.5 * self.opening).sin();
        tip_gap > (self.jaw_thickness + 2.0 * radius) as f64
    }

    /// Whether `local` (tool frame) lies inside the closed jaws, for a thread of `radius`.
    pub fn between_jaws(&self, local: &Vector3<f64>, radius: f32) -> bool {
        let r = radius as f64;
        local.x.abs() <= 0.5 * self.jaw_width as f64 + r
            && local.z >= -r
            && local.z <= self.jaw_length as f64 + r
            && local.y.abs() <= self.jaw_thickness as f64 + r
    }

    fn pose_at(&self, s: f64) -> ToolPose {
        self.from.lerp(&self.to, s)
    }
}

/// The lowest and highest of `indices`, or `None` when there are none.
fn span(indices: impl Iterator<Item = usize>) -> Option<(usize, usize)> {
    indices.fold(None, |range, i| match range {
        None => Some((i, i)),
        Some((lo, hi)) => Some((lo.min(i), hi.max(i))),
    })
}

/// One gripper's hold on a thread: the points caught and where they sit in the tool frame.
#[derive(Clone, Debug)]
struct Grasp {
    tool: usize,
    points: Vec<(usize, Vector3<f64>)>,
}

/// The grasps on one thread.
#[derive(Clone, Debug, Default)]
pub struct Grasps {
    held: Vec<Grasp>,
    /// Points just let go, by tool: the lowest and highest. Jaws pressed shut past the
    /// thread overlap it when they start to open; until they are open wider than the
    /// thread (see [`GripperView::open_past`]) they leave those points alone, which would
    /// otherwise be pushed out of the jaws' solid in one step.
    released: Vec<(usize, (usize, usize))>,
}

impl Grasps {
    /// Ends the grasps whose jaws no longer hold and begins one for each gripper newly
    /// closed on the thread (an empty one when nothing lay between its jaws, so that closed
    /// jaws brushing the thread later do not pick it up). `pinned` points stay the scene's.
    pub fn update(&mut self, rod: &Rod, grippers: &[GripperView], radius: f32, pinned: &[bool]) {
        let still_closed = |g: &Grasp| {
            grippers
                .iter()
                .any(|v| v.tool == g.tool && v.closed_on(radius))
        };
        self.released.retain(|(tool, _)| {
            grippers
                .iter()
                .any(|v| v.tool == *tool && !v.open_past(radius))
        });
        for grasp in self.held.iter().filter(|g| !still_closed(g)) {
            if let Some(range) = span(grasp.points.iter().map(|(i, _)| *i)) {
                self.released.push((grasp.tool, range));
            }
        }
        self.held.retain(still_closed);
        for view in grippers {
            if !view.closed_on(radius) || self.held.iter().any(|g| g.tool == view.tool) {
                continue;
            }
            let pose = &view.from;
            let mut points = Vec::new();
            for (i, (point, &is_pinned)) in rod.points.iter().zip(pinned).enumerate() {
                if is_pinned || self.holds_point(i) {
                    continue;
                }
                let local = pose
                    .rotation
                    .inverse_transform_vector(&(point.cast::<f64>() - pose.position));
                if view.between_jaws(&local, radius) {
                    points.push((i, local));
                }
            }
            self.held.push(Grasp {
                tool: view.tool,
                points,
            });
        }
    }

    /// Appends one attachment per grasped point: from where its jaws hold it at the frame's
    /// start to where they hold it at its end.
    pub fn attachments(&self, grippers: &[GripperView], out: &mut Vec<RodAttachment>) {
        let first = out.len();
        self.each_target(grippers, 0.0, |point, from| {
            out.push(RodAttachment {
                point,
                from,
                to: from,
            })
        });
        let mut k = first;
        self.each_target(grippers, 1.0, |_, to| {
            out[k].to = to;
            k += 1;
        });
    }

    fn each_target(&self, grippers: &[GripperView], s: f64, mut f: impl FnMut(usize, Vec3)) {
        for grasp in &self.held {
            let Some(view) = grippers.iter().find(|v| v.tool == grasp.tool) else {
                continue;
            };
            let pose = view.pose_at(s);
            for (i, local) in &grasp.points {
                f(*i, (pose.position + pose.rotation * local).cast());
            }
        }
    }

    /// Thread points held by grippers now.
    pub fn held_points(&self) -> usize {
        self.held.iter().map(|g| g.points.len()).sum()
    }

    /// The lowest and highest point tool `tool` holds or has just let go of (its jaws not
    /// yet open past the thread), or `None` when there are none.
    pub fn held_range(&self, tool: usize) -> Option<(usize, usize)> {
        let held = self.held.iter().filter(|g| g.tool == tool);
        let released = self.released.iter().filter(|(t, _)| *t == tool);
        span(
            held.flat_map(|g| g.points.iter().map(|(i, _)| *i))
                .chain(released.flat_map(|(_, (lo, hi))| [*lo, *hi])),
        )
    }

    /// Whether tool `tool` holds any point.
    pub fn holds_with(&self, tool: usize) -> bool {
        self.held
            .iter()
            .any(|g| g.tool == tool && !g.points.is_empty())
    }

    fn holds_point(&self, i: usize) -> bool {
        self.held
            .iter()
            .any(|g| g.points.iter().any(|(k, _)| *k == i))
    }
}
