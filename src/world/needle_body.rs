//! The needle as a rigid body: held by its driver, held by a gripper, or free.
//!
//! A needle tool (`shape.type = "needle"`) is carried by one of three things, and its pose
//! over each frame is its carrier's:
//! - **Its driver** (the scene's keyframes, or the arm that holds it as its tool): the pose
//!   the driver asks for, as for any tool. The driver's jaw is the needle driver's: opened
//!   past [`RELEASE_OPENING_DEG`] (a keyframe's `jaw_deg`, or the arm's `jaw/move_jp`), it
//!   lets the needle go. Closing again (the setpoint crossing back to or below it) it takes
//!   the needle back where the needle lies seated in its jaws: its frame within
//!   [`RETAKE_DISTANCE`] and [`RETAKE_ANGLE_DEG`] of where the driver holds it. The needle
//!   then snaps to the driver's hold (by at most that much), as closing jaws seat a needle
//!   in their grooves. So a driver picks up a needle it let go of, or takes it back from a
//!   gripper (the gripper still closed; it then lets nothing go on opening), once its arm
//!   or keyframes put the hold on the needle's pose (its `/tf` frame).
//! - **A gripper** (a tool with jaws) that closes on the needle's wire: closed as on a
//!   thread (see [`crate::world::thread_body::grasp`]: pressed shut, the tips no further
//!   apart than the wire is thick, a point of the wire inside the closed jaws' volume).
//!   From then on the needle moves rigidly with the gripper's frame, where it was when the
//!   jaws closed: a needle-driver grasp, so it does not turn in the jaws. A gripper closing
//!   on a needle that something else holds takes it over (handover); opening lets it go.
//! - **Nothing** (free): a rigid body of stainless steel ([`NEEDLE_DENSITY`], the wire's
//!   cross-section swept along the arc), stepped once a frame under gravity and:
//!   - **Tissue.** The grid's contact treats the needle as a moving boundary (seed 002
//!     §IV-A's momentum exchange) and sums the momentum the needle takes from the nodes,
//!     the mass of the nodes it touches and their polar moment of inertia about its frame
//!     origin (both backends, [`crate::mpm::ToolImpulse`]). While a needle is free the
//!     world steps the tissue one substep per backend frame and moves the needle between
//!     them: its velocity changes by the last substep's impulse and its weight over its own
//!     mass plus the contact mass, the perfectly inelastic exchange with the nodes pushed
//!     against it, which cannot overshoot. The turn adds the nodes' polar moment on every
//!     axis: more than their inertia about most axes, so a turn is under- rather than
//!     overestimated. Per frame instead, the same law let a 0.2 g needle bounce 27 mm off
//!     a 5 kPa block (the frame's lag integrates the tissue's stiffness explicitly at the
//!     frame's step); per substep it lands and lies still. The cost is a backend frame's
//!     overhead a substep (on the GPU a submission and a readback of the statistics; the
//!     particles are read back once, after the last), only while a needle is free; a guard
//!     event puts the tissue back to the start of the frame, as in any frame.
//!   - **The wire's reach.** As for any wire thinner than a cell, the grid's contact
//!     reaches 1.5 cells from the wire's centre line ([`crate::tools`]): a needle lying on
//!     tissue rests on the nodes that reach touches, 1.9 cells above the particles' top
//!     face (`cargo test --release --test needle -- --nocapture`: 3.84 mm at dx 2 mm, on
//!     the CPU and the GPU's two P2G variants alike, the tissue pushing up with 1.912 mN
//!     against a weight of 1.912 mN). Along its tangent the wire lets
//!     tissue slide (seed 002 eq. 19), so a needle falling point first goes into the
//!     tissue as a sharp point does, without a force threshold to pierce it.
//!   - **The table** (or, without one, the domain's floor): the arc's points closer to it
//!     than the wire's radius are pushed out of it, and their velocity into it is taken
//!     away by impulses at those points (inelastic, with the needle's Coulomb `friction`).
//!   - **The thread** swaged to it: its first segment's tension pulls the swage end along
//!     that segment. The impulse it gives in a frame at most stops the swage end's motion
//!     away from the thread: a taut thread holds the needle, it does not fling it back.
//!
//! Other tools do not push a free needle (only a gripper's grasp moves it).

use crate::tools::{ContactModel, Shape, ToolPose, ToolVelocity};
use crate::world::thread_body::grasp::GripperView;
use nalgebra::{Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};

/// Density of a surgical needle's stainless steel, kg/m³.
pub const NEEDLE_DENSITY: f64 = 7900.0;

/// A needle's driver lets go of it while its jaw setpoint is open wider than this, degrees.
pub const RELEASE_OPENING_DEG: f64 = 10.0;

/// A driver closing its jaw takes the needle back while the needle's frame origin (the
/// arc's centre) lies within this of where the driver holds it, m.
pub const RETAKE_DISTANCE: f64 = 1e-3;

/// ... and its frame is turned from the driver's hold by at most this, degrees.
pub const RETAKE_ANGLE_DEG: f64 = 10.0;

/// Points along the arc at which the table and the grippers' jaws meet the wire.
const ARC_SAMPLES: usize = 33;

/// Rounds of projected Gauss-Seidel over the arc's points against the table.
const TABLE_ROUNDS: usize = 20;

/// What carries a needle.
#[derive(Clone, Debug, PartialEq)]
pub enum Carrier {
    /// Its driver (keyframes or an arm): the tool's pose is the driver's.
    Driver,
    /// Gripper `tool` holds it at `offset`, the needle's pose in the gripper's frame.
    Gripper {
        /// Scene index of the gripper.
        tool: usize,
        /// The needle's pose in the gripper's frame.
        offset: Isometry3<f64>,
    },
    /// Nothing holds it.
    Free,
}

/// The tissue's exchange with a needle over one frame (see [`crate::mpm::ToolImpulse`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TissueExchange {
    /// Momentum the needle took from the grid, world frame, N·s.
    pub linear: Vector3<f64>,
    /// Its moment about the needle's frame origin, N·m·s.
    pub angular: Vector3<f64>,
    /// Mass of the grid nodes the needle touched, summed over the frame's substeps, kg.
    pub contact_mass: f64,
    /// Their polar moment of inertia about the needle's frame origin, summed likewise,
    /// kg·m².
    pub contact_inertia: f64,
}

/// What a free needle moves among in one frame.
#[derive(Clone, Copy, Debug)]
pub struct Surroundings {
    /// Gravity, m/s².
    pub gravity: Vector3<f64>,
    /// Height of the table's surface (or of the domain's floor), m.
    pub floor: f64,
    /// The swaged thread's pull on the swage end: its first segment's tension (N) along that
    /// segment's unit direction, away from the needle. Zero without a thread.
    pub thread_pull: Vector3<f64>,
}

/// One needle as a rigid body.
#[derive(Clone, Debug)]
pub struct NeedleBody {
    /// Mass, kg.
    mass: f64,
    /// Centre of mass in the needle's frame, m.
    com_local: Vector3<f64>,
    /// Inertia about the centre of mass in the needle's frame, kg·m².
    inertia_local: Matrix3<f64>,
    /// Points on the wire's centre line, needle frame.
    arc: Vec<Vector3<f64>>,
    /// The swage end, needle frame.
    swage_local: Vector3<f64>,
    wire_radius: f64,
    /// Coulomb coefficient against the table.
    friction: f64,
    carrier: Carrier,
    /// The pose at the end of the last frame stepped (where the next one starts).
    pose: ToolPose,
    /// Velocity of the centre of mass (m/s) and angular velocity (rad/s), world frame.
    velocity: Vector3<f64>,
    angular_velocity: Vector3<f64>,
    /// The frame being stepped: from which pose to which, over [t0, t1].
    span: Option<(ToolPose, ToolPose, f64, f64)>,
    /// Grippers whose jaws were closed last frame: only a gripper that closes takes the
    /// needle, not one that was closed already.
    closed: Vec<usize>,
    /// The tissue's exchange over the last substep stepped.
    tissue: TissueExchange,
    /// A free needle's pose, velocity and angular velocity at the frame's start, and the
    /// tissue's exchange of the substep before it.
    frame_start: Option<(ToolPose, Vector3<f64>, Vector3<f64>, TissueExchange)>,
}

impl NeedleBody {
    /// The body of a needle `shape` (`None` for other shapes) held by its driver at `pose`.
    pub fn new(shape: Shape, contact: ContactModel, pose: ToolPose) -> Option<NeedleBody> {
        let Shape::Needle {
            radius,
            arc_angle,
            wire_radius,
        } = shape
        else {
            return None;
        };
        let (radius, arc_angle, wire) = (radius as f64, arc_angle as f64, wire_radius as f64);
        let arc: Vec<Vector3<f64>> = (0..ARC_SAMPLES)
            .map(|i| {
                let a = arc_angle * i as f64 / (ARC_SAMPLES - 1) as f64;
                Vector3::new(radius * a.cos(), radius * a.sin(), 0.0)
            })
            .collect();
        let mass = NEEDLE_DENSITY * std::f64::consts::PI * wire * wire * radius * arc_angle;
        let (com_local, inertia_local) = wire_mass_properties(&arc, mass, wire);
        let swage_local = *arc.last().expect("the arc has points");
        Some(NeedleBody {
            mass,
            com_local,
            inertia_local,
            arc,
            swage_local,
            wire_radius: wire,
            friction: match contact {
                ContactModel::Coulomb { friction, .. } => friction as f64,
                ContactModel::Sticky => 1.0,
            },
            carrier: Carrier::Driver,
            pose,
            velocity: Vector3::zeros(),
            angular_velocity: Vector3::zeros(),
            span: None,
            closed: Vec::new(),
            tissue: TissueExchange::default(),
            frame_start: None,
        })
    }

    /// Mass, kg.
    pub fn mass(&self) -> f64 {
        self.mass
    }

    /// Centre of mass in the needle's frame, m.
    pub fn center_of_mass(&self) -> Vector3<f64> {
        self.com_local
    }

    /// What carries the needle now.
    pub fn carrier(&self) -> &Carrier {
        &self.carrier
    }

    /// Velocity of the centre of mass, world frame, m/s.
    pub fn velocity(&self) -> Vector3<f64> {
        self.velocity
    }

    /// The swage end in the needle's frame, m.
    pub fn swage_local(&self) -> Vector3<f64> {
        self.swage_local
    }

    /// The needle's pose at `t`: its carrier's over the frame being stepped, `None` while
    /// its driver carries it (the driver then says).
    pub fn pose_at(&self, t: f64) -> Option<ToolPose> {
        if self.carrier == Carrier::Driver {
            return None;
        }
        let Some((from, to, t0, t1)) = &self.span else {
            return Some(self.pose);
        };
        let s = if t1 > t0 {
            ((t - t0) / (t1 - t0)).clamp(0.0, 1.0)
        } else {
            1.0
        };
        Some(from.lerp(to, s))
    }

    /// Whether nothing holds the needle.
    pub fn is_free(&self) -> bool {
        self.carrier == Carrier::Free
    }

    /// Records what the tissue did to the needle over the substep just stepped.
    pub fn record_tissue(&mut self, exchange: TissueExchange) {
        self.tissue = exchange;
    }

    /// Steps a free needle over one tissue substep [t0, t1] with the tissue's exchange of
    /// the substep before: the `first` from the state the frame started in, the others from
    /// where the one before left it. Returns its pose at t0 and at t1.
    pub fn step_substep(
        &mut self,
        around: &Surroundings,
        (t0, t1): (f64, f64),
        first: bool,
    ) -> (ToolPose, ToolPose) {
        if first {
            if let Some((pose, velocity, angular_velocity, tissue)) = self.frame_start {
                self.pose = pose;
                self.velocity = velocity;
                self.angular_velocity = angular_velocity;
                self.tissue = tissue;
            }
        }
        let start = self.pose;
        let end = self.step_free(&start, around, t1 - t0, start.jaw);
        self.tissue = TissueExchange::default();
        self.span = Some((start, end, t0, t1));
        self.pose = end;
        (start, end)
    }

    /// Plans the frame [t0, t1]: first who carries the needle (its driver, which asks for
    /// `driver_from` at t0 and `driver_to` at t1; the grippers `grippers`), then where it
    /// goes. A free needle is predicted under gravity and `around` without tissue (see
    /// [`NeedleBody::step_substep`] for the frame the tissue steps).
    pub fn advance(
        &mut self,
        driver_from: &ToolPose,
        driver_to: &ToolPose,
        grippers: &[GripperView],
        around: &Surroundings,
        (t0, t1): (f64, f64),
    ) {
        let dt = t1 - t0;
        let start = match self.carrier {
            Carrier::Driver => *driver_from,
            _ => self.pose,
        };
        let wire = self.wire_radius as f32;
        let closed_now: Vec<usize> = grippers
            .iter()
            .filter(|g| g.closed_on(wire))
            .map(|g| g.tool)
            .collect();
        // The holder lets go first, so that a gripper closing as another opens takes it.
        let release = RELEASE_OPENING_DEG.to_radians();
        match self.carrier {
            Carrier::Gripper { tool, .. } if !closed_now.contains(&tool) => {
                self.carrier = Carrier::Free;
            }
            Carrier::Driver if driver_to.jaw > release => {
                self.carrier = Carrier::Free;
            }
            _ => {}
        }
        let driver_closing = driver_from.jaw > release && driver_to.jaw <= release;
        if self.carrier != Carrier::Driver && driver_closing && seated(&start, driver_from) {
            self.carrier = Carrier::Driver;
        }
        for g in grippers {
            let closing = closed_now.contains(&g.tool) && !self.closed.contains(&g.tool);
            if closing && self.between_jaws(&start, g) {
                self.carrier = Carrier::Gripper {
                    tool: g.tool,
                    offset: isometry(&g.from).inverse() * isometry(&start),
                };
            }
        }
        self.closed = closed_now;
        let end = match &self.carrier {
            Carrier::Driver => *driver_to,
            Carrier::Gripper { tool, offset } => {
                let g = grippers
                    .iter()
                    .find(|g| g.tool == *tool)
                    .expect("a holding gripper is among the grippers");
                pose_of(&(isometry(&g.to) * offset), driver_to.jaw)
            }
            Carrier::Free => {
                // Predicted without tissue; where tissue steps, it is stepped again with it
                // from here ([`NeedleBody::step_substep`]).
                // The last substep's exchange carries over to the frame's first substep.
                self.frame_start = Some((start, self.velocity, self.angular_velocity, self.tissue));
                self.tissue = TissueExchange::default();
                self.step_free(&start, around, dt, driver_to.jaw)
            }
        };
        if self.carrier != Carrier::Free && dt > 0.0 {
            // A held needle moves as its holder does; let go, it keeps that motion.
            let v = ToolVelocity::between(&start, &end, dt);
            self.velocity = v.linear + v.angular.cross(&(start.rotation * self.com_local));
            self.angular_velocity = v.angular;
        }
        self.span = Some((start, end, t0, t1));
        self.pose = end;
        self.tissue = TissueExchange::default();
    }

    /// Whether a point of the wire at `pose` lies inside gripper `g`'s closed jaws.
    fn between_jaws(&self, pose: &ToolPose, g: &GripperView) -> bool {
        self.arc.iter().any(|p| {
            let world = pose.rotation * p + pose.position;
            let local = g
                .from
                .rotation
                .inverse_transform_vector(&(world - g.from.position));
            g.between_jaws(&local, self.wire_radius as f32)
        })
    }

    /// One frame of free motion from `start`: velocities from gravity, the tissue's
    /// exchange and the thread, then the pose, then the table.
    fn step_free(
        &mut self,
        start: &ToolPose,
        around: &Surroundings,
        dt: f64,
        jaw: f64,
    ) -> ToolPose {
        let rotation = start.rotation;
        let com = start.position + rotation * self.com_local;
        let inverse_inertia = world_inverse_inertia(&rotation, &self.inertia_local);
        // The tissue, with the mass it put against the needle: one Newton step on the
        // needle's momentum balance, the contact's mass being how fast the tissue's push
        // grows as the needle moves into it.
        let ex = &self.tissue;
        let heavier = self.mass + ex.contact_mass;
        let about_com = ex.angular - (com - start.position).cross(&ex.linear);
        self.velocity += (ex.linear + around.gravity * (self.mass * dt)) / heavier;
        let axes = rotation.to_rotation_matrix().into_inner();
        let inertia = axes * self.inertia_local * axes.transpose();
        let turning = (inertia + Matrix3::identity() * ex.contact_inertia)
            .try_inverse()
            .expect("an inertia is invertible");
        self.angular_velocity += turning * about_com;
        // The thread: at most what stops the swage end moving away from it.
        let pull = around.thread_pull.norm();
        if pull > 0.0 {
            let along = around.thread_pull / pull;
            let arm = rotation * self.swage_local - rotation * self.com_local;
            let k = self.response_along(&inverse_inertia, &arm, &along);
            let away = -(self.velocity + self.angular_velocity.cross(&arm)).dot(&along);
            let impulse = (pull * dt).min(away.max(0.0) / k);
            self.apply_impulse(&inverse_inertia, &arm, &(along * impulse));
        }
        let turned = UnitQuaternion::from_scaled_axis(self.angular_velocity * dt) * rotation;
        let com = com + self.velocity * dt;
        let mut end = ToolPose {
            position: com - turned * self.com_local,
            rotation: turned,
            jaw,
        };
        self.rest_on_floor(&mut end, around.floor);
        end
    }

    /// Pushes the wire at `pose` out of the floor at height `floor` and takes away the
    /// velocity of its points into it, with Coulomb friction.
    fn rest_on_floor(&mut self, pose: &mut ToolPose, floor: f64) {
        let lowest = floor + self.wire_radius;
        let touching: Vec<Vector3<f64>> = self
            .arc
            .iter()
            .map(|p| pose.rotation * p)
            .filter(|r| pose.position.z + r.z < lowest)
            .collect();
        if touching.is_empty() {
            return;
        }
        let depth = touching
            .iter()
            .map(|r| lowest - pose.position.z - r.z)
            .fold(0.0, f64::max);
        pose.position.z += depth;
        let inverse_inertia = world_inverse_inertia(&pose.rotation, &self.inertia_local);
        let com_offset = pose.rotation * self.com_local;
        let up = Vector3::z();
        // Projected Gauss-Seidel on the accumulated impulse at each point: the normal one
        // at least zero, the friction one within μ times it.
        let mut accumulated: Vec<Vector3<f64>> = vec![Vector3::zeros(); touching.len()];
        for _ in 0..TABLE_ROUNDS {
            for (r, total) in touching.iter().zip(&mut accumulated) {
                let arm = r - com_offset;
                let v = self.velocity + self.angular_velocity.cross(&arm);
                let normal =
                    (total.z - v.z / self.response_along(&inverse_inertia, &arm, &up)).max(0.0);
                let mut next = Vector3::new(0.0, 0.0, normal);
                let slip = v - up * v.z;
                let tangential = Vector3::new(total.x, total.y, 0.0);
                let stop = match slip.try_normalize(1e-12) {
                    Some(dir) => {
                        dir * (slip.norm() / self.response_along(&inverse_inertia, &arm, &dir))
                    }
                    None => Vector3::zeros(),
                };
                let wanted = tangential - stop;
                let limit = self.friction * normal;
                next += if wanted.norm() > limit {
                    wanted * (limit / wanted.norm())
                } else {
                    wanted
                };
                self.apply_impulse(&inverse_inertia, &arm, &(next - *total));
                *total = next;
            }
        }
    }

    /// Velocity change along `dir` of the point at `arm` from the centre of mass per unit
    /// impulse along `dir` there.
    fn response_along(
        &self,
        inverse_inertia: &Matrix3<f64>,
        arm: &Vector3<f64>,
        dir: &Vector3<f64>,
    ) -> f64 {
        1.0 / self.mass + (inverse_inertia * arm.cross(dir)).cross(arm).dot(dir)
    }

    fn apply_impulse(
        &mut self,
        inverse_inertia: &Matrix3<f64>,
        arm: &Vector3<f64>,
        impulse: &Vector3<f64>,
    ) {
        self.velocity += impulse / self.mass;
        self.angular_velocity += inverse_inertia * arm.cross(impulse);
    }
}

/// Centre of mass and inertia about it (both in the needle's frame) of a wire of `mass`
/// spread evenly over the points `arc`, each point a disc of the wire's cross-section
/// (radius `wire`) across the arc.
fn wire_mass_properties(
    arc: &[Vector3<f64>],
    mass: f64,
    wire: f64,
) -> (Vector3<f64>, Matrix3<f64>) {
    // Trapezoid weights: the ends carry half a segment each.
    let n = arc.len();
    let weight = |i: usize| if i == 0 || i == n - 1 { 0.5 } else { 1.0 };
    let total: f64 = (0..n).map(weight).sum();
    let com = (0..n).map(|i| arc[i] * weight(i)).sum::<Vector3<f64>>() / total;
    let mut inertia = Matrix3::identity() * (0.5 * mass * wire * wire);
    for (i, p) in arc.iter().enumerate() {
        let r = p - com;
        let m = mass * weight(i) / total;
        inertia += (Matrix3::identity() * r.norm_squared() - r * r.transpose()) * m;
    }
    (com, inertia)
}

fn world_inverse_inertia(
    rotation: &UnitQuaternion<f64>,
    inertia_local: &Matrix3<f64>,
) -> Matrix3<f64> {
    let r = rotation.to_rotation_matrix().into_inner();
    let inverse = inertia_local
        .try_inverse()
        .expect("a wire's inertia has its cross-section's on every axis");
    r * inverse * r.transpose()
}

/// Whether a needle at `needle` lies seated in the jaws of a driver whose hold is at `hold`
/// (see [`RETAKE_DISTANCE`]).
fn seated(needle: &ToolPose, hold: &ToolPose) -> bool {
    (needle.position - hold.position).norm() <= RETAKE_DISTANCE
        && needle.rotation.angle_to(&hold.rotation) <= RETAKE_ANGLE_DEG.to_radians()
}

fn isometry(pose: &ToolPose) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::from(pose.position), pose.rotation)
}

fn pose_of(iso: &Isometry3<f64>, jaw: f64) -> ToolPose {
    ToolPose {
        position: iso.translation.vector,
        rotation: iso.rotation,
        jaw,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    const FRAME: f64 = 1.0 / 60.0;
    const R: f64 = 0.01;
    const WIRE: f64 = 0.0005;

    fn needle_at(position: Vector3<f64>) -> NeedleBody {
        let shape = Shape::Needle {
            radius: R as f32,
            arc_angle: PI as f32,
            wire_radius: WIRE as f32,
        };
        let pose = ToolPose {
            position,
            ..Default::default()
        };
        NeedleBody::new(shape, ContactModel::default(), pose).unwrap()
    }

    fn nothing_around(floor: f64) -> Surroundings {
        Surroundings {
            gravity: Vector3::new(0.0, 0.0, -9.81),
            floor,
            thread_pull: Vector3::zeros(),
        }
    }

    /// The driver's pose at `position`, its jaw opened to `jaw_deg`.
    fn driver(position: Vector3<f64>, jaw_deg: f64) -> ToolPose {
        ToolPose {
            position,
            rotation: UnitQuaternion::identity(),
            jaw: jaw_deg.to_radians(),
        }
    }

    /// A gripper pointing down (its z along world −z) whose jaws close across world y on
    /// the point `at`, between `from` and `to` (offsets of `at`), closed or open.
    fn gripper(tool: usize, at: Vector3<f64>, to: Vector3<f64>, closed: bool) -> GripperView {
        let down = UnitQuaternion::from_euler_angles(PI, 0.0, 0.0);
        // The jaws' middle (4 mm from the hinge) on the point.
        let hinge = at + Vector3::new(0.0, 0.0, 0.004);
        GripperView {
            tool,
            jaw_length: 0.008,
            jaw_width: 0.006,
            jaw_thickness: 0.0025,
            from: ToolPose {
                position: hinge,
                rotation: down,
                jaw: 0.0,
            },
            to: ToolPose {
                position: hinge + to,
                rotation: down,
                jaw: 0.0,
            },
            opening: if closed { -0.3 } else { 0.5 },
            pressing: closed,
        }
    }

    fn step(
        body: &mut NeedleBody,
        held: &ToolPose,
        grippers: &[GripperView],
        around: &Surroundings,
        frame: usize,
    ) {
        let t0 = frame as f64 * FRAME;
        body.advance(held, held, grippers, around, (t0, t0 + FRAME));
    }

    #[test]
    fn its_driver_closing_where_the_needle_lies_takes_it_back_and_nowhere_else() {
        let start = Vector3::new(0.0, 0.0, 0.03);
        let mut body = needle_at(start);
        let around = nothing_around(0.002);
        // Let go, it falls onto the table and lies there; the driver stays open above.
        let open_above = driver(start, 30.0);
        for f in 0..120 {
            step(&mut body, &open_above, &[], &around, f);
        }
        assert_eq!(*body.carrier(), Carrier::Free);
        let t = 120.0 * FRAME;
        let lying = body.pose_at(t).unwrap();
        let closing = |body: &mut NeedleBody, hold: ToolPose, t: f64| {
            let open = ToolPose {
                jaw: 30f64.to_radians(),
                ..hold
            };
            body.advance(&open, &hold, &[], &around, (t, t + FRAME));
        };
        let turned = |deg: f64| {
            lying.rotation * UnitQuaternion::from_euler_angles(0.0, 0.0, deg.to_radians())
        };
        // Closing 3 mm off the needle, or on it but turned 15°, takes nothing.
        for (offset, turn) in [(0.003, 0.0), (0.0, 15.0)] {
            let hold = ToolPose {
                position: lying.position + Vector3::new(offset, 0.0, 0.0),
                rotation: turned(turn),
                jaw: 0.0,
            };
            closing(&mut body, hold, t);
            assert_eq!(*body.carrier(), Carrier::Free, "{offset} m, {turn}°");
        }
        // Closing 0.5 mm off and turned 5° takes it: it is where the driver holds it and
        // moves with the driver.
        let hold = ToolPose {
            position: lying.position + Vector3::new(0.0005, 0.0, 0.0),
            rotation: turned(5.0),
            jaw: 0.0,
        };
        closing(&mut body, hold, t + FRAME);
        assert_eq!(*body.carrier(), Carrier::Driver);
        assert!(
            body.pose_at(t + 2.0 * FRAME).is_none(),
            "its driver says where it is"
        );
        let up = Vector3::new(0.0, 0.0, 0.001);
        let lifted = ToolPose {
            position: hold.position + up,
            ..hold
        };
        body.advance(
            &hold,
            &lifted,
            &[],
            &around,
            (t + 2.0 * FRAME, t + 3.0 * FRAME),
        );
        assert_eq!(*body.carrier(), Carrier::Driver);
        assert!(
            (body.velocity().z - 0.06).abs() < 1e-9,
            "{}",
            body.velocity()
        );
    }

    #[test]
    fn a_half_circle_needle_has_its_centre_of_mass_at_two_radii_over_pi() {
        let body = needle_at(Vector3::zeros());
        let expected = NEEDLE_DENSITY * PI * WIRE * WIRE * R * PI;
        assert!((body.mass() / expected - 1.0).abs() < 1e-6);
        let com = body.center_of_mass();
        assert!(com.x.abs() < 1e-9 && com.z.abs() < 1e-12, "{com}");
        // Sampled with 33 points the arc's centroid is within 0.1 % of 2R/π.
        assert!((com.y / (2.0 * R / PI) - 1.0).abs() < 1e-3, "{com}");
        // About its own axis (z) a ring of radius R has m R², less m |com|² about the centroid.
        let izz = body.inertia_local[(2, 2)];
        let ring = body.mass() * (R * R - com.y * com.y + 0.5 * WIRE * WIRE);
        assert!((izz / ring - 1.0).abs() < 2e-3, "{izz} {ring}");
    }

    #[test]
    fn held_by_its_driver_it_follows_and_opened_it_falls_freely() {
        let start = Vector3::new(0.0, 0.0, 0.1);
        let mut body = needle_at(start);
        let around = nothing_around(-10.0);
        // Held: the needle is where the driver says, moving up at 6 cm/s.
        let up = Vector3::new(0.0, 0.0, 0.001);
        body.advance(
            &driver(start, 0.0),
            &driver(start + up, 0.0),
            &[],
            &around,
            (0.0, FRAME),
        );
        assert_eq!(*body.carrier(), Carrier::Driver);
        assert!(body.pose_at(FRAME).is_none(), "its driver says where it is");
        assert!((body.velocity().z - 0.06).abs() < 1e-9);
        // Opened past 10°: free, with the motion it had.
        let released = start + up;
        let open = driver(released, RELEASE_OPENING_DEG + 5.0);
        let frames = 60;
        for f in 1..=frames {
            step(&mut body, &open, &[], &around, f);
        }
        assert_eq!(*body.carrier(), Carrier::Free);
        // Semi-implicit Euler over 60 frames: z = z0 + v0 t − g dt² n(n+1)/2.
        let t = frames as f64 * FRAME;
        let z = body.pose_at(t + FRAME).unwrap().position.z;
        let expected =
            released.z + 0.06 * t - 9.81 * FRAME * FRAME * (frames * (frames + 1)) as f64 / 2.0;
        assert!((z - expected).abs() < 1e-9, "{z} vs {expected}");
        // Within 2 % of the exact fall g t²/2.
        let fall = released.z + 0.06 * t - z;
        assert!(
            (fall / (0.5 * 9.81 * t * t) - 1.0).abs() < 0.02 + 0.06 * t / fall,
            "{fall}"
        );
    }

    #[test]
    fn let_go_above_the_table_it_comes_to_rest_on_it() {
        let start = Vector3::new(0.0, 0.0, 0.03);
        let mut body = needle_at(start);
        // Tilted and spinning as it drops, so that it lands on one end first.
        body.pose.rotation = UnitQuaternion::from_euler_angles(0.4, 0.3, 0.2);
        body.carrier = Carrier::Free;
        body.angular_velocity = Vector3::new(1.0, -2.0, 0.5);
        let floor = 0.002;
        let around = nothing_around(floor);
        let held = driver(start, 30.0);
        for f in 0..240 {
            step(&mut body, &held, &[], &around, f);
        }
        let pose = body.pose_at(4.0).unwrap();
        let lowest = body
            .arc
            .iter()
            .map(|p| (pose.rotation * p + pose.position).z)
            .fold(f64::INFINITY, f64::min);
        assert!(
            (lowest - (floor + WIRE)).abs() < 1e-4,
            "lowest point {lowest}"
        );
        assert!(body.velocity().norm() < 1e-3, "{}", body.velocity());
        assert!(
            body.angular_velocity.norm() < 0.1,
            "{}",
            body.angular_velocity
        );
    }

    #[test]
    fn a_gripper_closing_on_the_wire_carries_it_and_another_takes_it_over() {
        let start = Vector3::new(0.0, 0.0, 0.05);
        let mut body = needle_at(start);
        let around = nothing_around(-1.0);
        let held = driver(start, 0.0);
        // The wire's point at 90° of the arc, world frame.
        let top = start + Vector3::new(0.0, R, 0.0);
        let lift = Vector3::new(0.0, 0.0, 0.002);
        // Gripper 1 open over it: nothing changes.
        let open = gripper(1, top, lift, false);
        step(&mut body, &held, &[open], &around, 0);
        assert_eq!(*body.carrier(), Carrier::Driver);
        // It closes: it holds the needle, which rises with it 2 mm a frame.
        let closed = gripper(1, top, lift, true);
        step(&mut body, &held, &[closed], &around, 1);
        assert!(matches!(body.carrier(), Carrier::Gripper { tool: 1, .. }));
        let moved = body.pose_at(2.0 * FRAME).unwrap();
        assert!(
            (moved.position - (start + lift)).norm() < 1e-12,
            "{}",
            moved.position
        );
        // Gripper 2, already closed somewhere else, does not take it; closing on it does.
        let elsewhere = gripper(
            2,
            top + Vector3::new(0.05, 0.0, 0.0),
            Vector3::zeros(),
            true,
        );
        let carried = body.pose_at(2.0 * FRAME).unwrap().position;
        let still = gripper(
            1,
            carried + Vector3::new(0.0, R, 0.0),
            Vector3::zeros(),
            true,
        );
        step(&mut body, &held, &[still.clone(), elsewhere], &around, 2);
        assert!(matches!(body.carrier(), Carrier::Gripper { tool: 1, .. }));
        let side = carried + Vector3::new(R, 0.0, 0.0);
        let other_open = gripper(2, side, Vector3::zeros(), false);
        step(&mut body, &held, &[still.clone(), other_open], &around, 3);
        let other = gripper(2, side, Vector3::new(0.001, 0.0, 0.0), true);
        step(
            &mut body,
            &held,
            &[still.clone(), other.clone()],
            &around,
            4,
        );
        assert!(matches!(body.carrier(), Carrier::Gripper { tool: 2, .. }));
        // Gripper 1 opening does not drop what gripper 2 holds.
        let first_opens = gripper(
            1,
            carried + Vector3::new(0.0, R, 0.0),
            Vector3::zeros(),
            false,
        );
        let side = side + Vector3::new(0.001, 0.0, 0.0);
        let other = gripper(2, side, Vector3::new(0.001, 0.0, 0.0), true);
        step(&mut body, &held, &[first_opens, other], &around, 5);
        let side = side + Vector3::new(0.001, 0.0, 0.0);
        assert!(matches!(body.carrier(), Carrier::Gripper { tool: 2, .. }));
        // Gripper 2 opens: it falls from where it was, with the 6 cm/s it was carried at.
        let at = body.pose_at(6.0 * FRAME).unwrap().position;
        let dropped = gripper(2, side, Vector3::zeros(), false);
        step(&mut body, &held, &[dropped], &around, 6);
        assert_eq!(*body.carrier(), Carrier::Free);
        let v = body.velocity();
        assert!(
            (v.x - 0.06).abs() < 1e-9 && (v.z + 9.81 * FRAME).abs() < 1e-9,
            "{v}"
        );
        let fell = body.pose_at(7.0 * FRAME).unwrap().position;
        assert!(fell.z < at.z, "{fell} {at}");
    }

    #[test]
    fn the_tissue_it_pushes_into_stops_it_without_throwing_it_back() {
        let mut body = needle_at(Vector3::zeros());
        body.carrier = Carrier::Free;
        body.velocity = Vector3::new(0.0, 0.0, -0.1);
        let around = Surroundings {
            gravity: Vector3::zeros(),
            floor: -1.0,
            thread_pull: Vector3::zeros(),
        };
        // Nodes ten times its mass, held still by stiff tissue over the substep: the grid
        // took back their momentum at the needle's speed.
        let contact_mass = 10.0 * body.mass();
        body.record_tissue(TissueExchange {
            linear: Vector3::new(0.0, 0.0, 0.1) * contact_mass,
            angular: Vector3::zeros(),
            contact_mass,
            contact_inertia: 0.0,
        });
        body.step_substep(&around, (0.0, 1e-4), false);
        let v = body.velocity().z;
        // The inelastic exchange leaves the needle and the nodes at one velocity.
        assert!((v + 0.1 / 11.0).abs() < 1e-12, "stopped, not bounced: {v}");
    }

    #[test]
    fn a_taut_thread_stops_the_swage_end_leaving_it_and_no_more() {
        let mut body = needle_at(Vector3::zeros());
        body.carrier = Carrier::Free;
        // Moving at 5 cm/s along −x, the thread running off the swage end along +x.
        body.velocity = Vector3::new(-0.05, 0.0, 0.0);
        let around = Surroundings {
            gravity: Vector3::zeros(),
            floor: -1.0,
            thread_pull: Vector3::new(50.0, 0.0, 0.0),
        };
        step(&mut body, &driver(Vector3::zeros(), 30.0), &[], &around, 0);
        let arm = body.swage_local - body.com_local;
        let swage_v = body.velocity + body.angular_velocity.cross(&arm);
        assert!(swage_v.x.abs() < 1e-9, "{swage_v}");
        // A slack thread (no tension) leaves it alone.
        let mut free = needle_at(Vector3::zeros());
        free.carrier = Carrier::Free;
        free.velocity = Vector3::new(-0.05, 0.0, 0.0);
        let slack = Surroundings {
            thread_pull: Vector3::zeros(),
            ..around
        };
        step(&mut free, &driver(Vector3::zeros(), 30.0), &[], &slack, 0);
        assert_eq!(free.velocity, Vector3::new(-0.05, 0.0, 0.0));
    }
}
