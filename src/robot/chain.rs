//! A serial kinematic chain read from a URDF: the joints on the path from a base link to a tip
//! link, with forward kinematics for every link on the path and the tip's geometric Jacobian.
//!
//! Mimic joints are supported because dVRK's tools draw their two jaws as mimics of one `jaw`
//! joint: a mimic on the path moves with `multiplier · q[master] + offset`, and the master becomes
//! one of the chain's variables even when it is not on the path itself.

use std::collections::{HashMap, HashSet};

use nalgebra::{Isometry3, Matrix6xX, Translation3, Unit, UnitQuaternion, Vector3};

/// How a joint moves its child.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointKind {
    /// Rotation about the axis (URDF `revolute` or `continuous`), in rad.
    Revolute,
    /// Translation along the axis (URDF `prismatic`), in m.
    Prismatic,
}

/// One variable of a chain (one entry of `q`), with its URDF limits.
#[derive(Debug, Clone, PartialEq)]
pub struct ActuatedJoint {
    /// The URDF joint name.
    pub name: String,
    /// Revolute (rad) or prismatic (m).
    pub kind: JointKind,
    /// Lower position limit (rad or m); −∞ for a continuous joint.
    pub lower: f64,
    /// Upper position limit (rad or m); +∞ for a continuous joint.
    pub upper: f64,
    /// The URDF `velocity` limit (rad/s or m/s), as written (0 when the file gives none).
    pub max_velocity: f64,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
/// Why a URDF does not give a serial chain, or joint values do not fit it.
pub enum ChainError {
    #[error("link `{0}` is not in the URDF")]
    /// A named base or tip link that the URDF does not have.
    MissingLink(String),
    #[error("joint `{joint}` refers to link `{link}`, which is not in the URDF")]
    /// A joint whose parent or child link the URDF does not have.
    DanglingJoint {
        /// The joint's name.
        joint: String,
        /// The missing link's name.
        link: String,
    },
    #[error(
        "link `{link}` is the child of two joints (`{first}` and `{second}`): a URDF must be a tree"
    )]
    /// A link that is the child of two joints.
    MultipleParents {
        /// The link's name.
        link: String,
        /// The first joint naming it as child.
        first: String,
        /// The second joint naming it as child.
        second: String,
    },
    #[error("the joints above link `{link}` form a loop: a URDF must be a tree")]
    /// Joints whose parent links loop back.
    Cycle {
        /// A link on the loop.
        link: String,
    },
    #[error(
        "no serial path from `{base}` to `{tip}`: `{tip}` is not below `{base}` in the URDF tree \
         (they are on different branches, or in the wrong order)"
    )]
    /// The tip is not below the base in the tree.
    NoPath {
        /// The requested base link.
        base: String,
        /// The requested tip link.
        tip: String,
    },
    #[error(
        "joint `{joint}` is {kind}; a serial chain supports revolute, continuous, prismatic and \
         fixed joints"
    )]
    /// A joint type other than revolute, continuous, prismatic or fixed (e.g. floating, planar).
    UnsupportedJoint {
        /// The joint's name.
        joint: String,
        /// The URDF joint type.
        kind: String,
    },
    #[error("joint `{joint}` has a zero-length axis")]
    /// A movable joint with a zero axis.
    ZeroAxis {
        /// The joint's name.
        joint: String,
    },
    #[error("joint `{joint}` has a non-finite origin or axis")]
    /// A joint with NaN or infinite origin or axis values.
    NonFinite {
        /// The joint's name.
        joint: String,
    },
    #[error("joint `{joint}` has lower limit {lower} above upper limit {upper}")]
    /// A joint whose lower limit exceeds its upper limit.
    InvalidLimits {
        /// The joint's name.
        joint: String,
        /// Lower limit, rad or m.
        lower: f64,
        /// Upper limit, rad or m.
        upper: f64,
    },
    #[error("joint `{joint}` mimics `{master}`, which {reason}")]
    /// A mimic joint whose master cannot be followed.
    BadMimic {
        /// The mimicking joint.
        joint: String,
        /// The joint it mimics.
        master: String,
        /// Why the master cannot be followed (e.g. is not in the chain).
        reason: &'static str,
    },
    #[error("expected {expected} joint values ({names}), got {got}")]
    /// A joint vector of the wrong length.
    JointCount {
        /// The chain's number of actuated joints.
        expected: usize,
        /// The length given.
        got: usize,
        /// The actuated joints' names, comma separated.
        names: String,
    },
}

#[derive(Debug, Clone)]
enum Motion {
    Fixed,
    Moving {
        kind: JointKind,
        axis: Unit<Vector3<f64>>,
        /// Which entry of `q` drives this joint.
        index: usize,
        multiplier: f64,
        offset: f64,
    },
}

#[derive(Debug, Clone)]
struct Segment {
    child: String,
    /// The joint frame in the parent link's frame (URDF `<origin>`).
    origin: Isometry3<f64>,
    motion: Motion,
}

/// The joints on the URDF path from a base link to a tip link.
#[derive(Debug, Clone)]
pub struct Chain {
    base: String,
    segments: Vec<Segment>,
    joints: Vec<ActuatedJoint>,
}

/// A URDF's links and joints indexed once, so that any number of chains can be taken from
/// it in time proportional to their length (a model with many links is read in linear time).
pub struct UrdfTree<'a> {
    robot: &'a urdf_rs::Robot,
    links: HashSet<&'a str>,
    parent_joint: HashMap<&'a str, &'a urdf_rs::Joint>,
    child_joints: HashMap<&'a str, Vec<&'a urdf_rs::Joint>>,
    by_name: HashMap<&'a str, &'a urdf_rs::Joint>,
    /// The first joint that does not fit a tree (dangling or a second parent).
    fault: Option<ChainError>,
}

impl<'a> UrdfTree<'a> {
    /// Indexes `robot`'s links and joints.
    pub fn new(robot: &'a urdf_rs::Robot) -> UrdfTree<'a> {
        let links: HashSet<&str> = robot.links.iter().map(|l| l.name.as_str()).collect();
        let mut parent_joint: HashMap<&str, &urdf_rs::Joint> = HashMap::new();
        let mut child_joints: HashMap<&str, Vec<&urdf_rs::Joint>> = HashMap::new();
        let mut fault = None;
        for joint in &robot.joints {
            for link in [&joint.parent.link, &joint.child.link] {
                if fault.is_none() && !links.contains(link.as_str()) {
                    fault = Some(ChainError::DanglingJoint {
                        joint: joint.name.clone(),
                        link: link.clone(),
                    });
                }
            }
            if let Some(first) = parent_joint.insert(&joint.child.link, joint) {
                if fault.is_none() {
                    fault = Some(ChainError::MultipleParents {
                        link: joint.child.link.clone(),
                        first: first.name.clone(),
                        second: joint.name.clone(),
                    });
                }
            }
            child_joints
                .entry(joint.parent.link.as_str())
                .or_default()
                .push(joint);
        }
        let by_name = robot.joints.iter().map(|j| (j.name.as_str(), j)).collect();
        UrdfTree {
            robot,
            links,
            parent_joint,
            child_joints,
            by_name,
            fault,
        }
    }

    /// The joints whose parent is `link`, in the file's order.
    pub fn child_joints(&self, link: &str) -> &[&'a urdf_rs::Joint] {
        self.child_joints.get(link).map_or(&[], Vec::as_slice)
    }
}

impl Chain {
    /// Extracts the path from `base` down to `tip` (`tip` must be a descendant of `base`).
    pub fn from_urdf(robot: &urdf_rs::Robot, base: &str, tip: &str) -> Result<Chain, ChainError> {
        Chain::from_tree(&UrdfTree::new(robot), base, tip)
    }

    /// [`Chain::from_urdf`] on an indexed URDF.
    pub fn from_tree(tree: &UrdfTree<'_>, base: &str, tip: &str) -> Result<Chain, ChainError> {
        let robot = tree.robot;
        for link in [base, tip] {
            if !tree.links.contains(link) {
                return Err(ChainError::MissingLink(link.to_owned()));
            }
        }
        if let Some(fault) = &tree.fault {
            return Err(fault.clone());
        }
        let parent_joint = &tree.parent_joint;

        // Walk up from the tip: in a tree the path to any ancestor is unique.
        let mut path = Vec::new();
        let mut link = tip;
        while link != base {
            let Some(joint) = parent_joint.get(link) else {
                return Err(ChainError::NoPath {
                    base: base.to_owned(),
                    tip: tip.to_owned(),
                });
            };
            if path.len() == robot.joints.len() {
                return Err(ChainError::Cycle {
                    link: tip.to_owned(),
                });
            }
            path.push(*joint);
            link = &joint.parent.link;
        }
        path.reverse();

        let by_name = &tree.by_name;
        let mut joints: Vec<ActuatedJoint> = Vec::new();
        let mut segments = Vec::with_capacity(path.len());
        for joint in path {
            let origin = origin_of(joint)?;
            let motion = match movable_kind(joint)? {
                None => Motion::Fixed,
                Some(kind) => {
                    let (variable, multiplier, offset) = match &joint.mimic {
                        None => (joint, 1.0, 0.0),
                        Some(mimic) => {
                            let bad = |reason| ChainError::BadMimic {
                                joint: joint.name.clone(),
                                master: mimic.joint.clone(),
                                reason,
                            };
                            let master = by_name
                                .get(mimic.joint.as_str())
                                .ok_or_else(|| bad("is not in the URDF"))?;
                            if master.mimic.is_some()
                                || movable_kind(master).ok().flatten().is_none()
                            {
                                return Err(bad(
                                    "is not a revolute, continuous or prismatic joint without a \
                                     mimic of its own",
                                ));
                            }
                            (
                                *master,
                                mimic.multiplier.unwrap_or(1.0),
                                mimic.offset.unwrap_or(0.0),
                            )
                        }
                    };
                    let index = match joints.iter().position(|j| j.name == variable.name) {
                        Some(index) => index,
                        None => {
                            joints.push(actuated_joint(variable)?);
                            joints.len() - 1
                        }
                    };
                    Motion::Moving {
                        kind,
                        axis: axis_of(joint)?,
                        index,
                        multiplier,
                        offset,
                    }
                }
            };
            segments.push(Segment {
                child: joint.child.link.clone(),
                origin,
                motion,
            });
        }
        Ok(Chain {
            base: base.to_owned(),
            segments,
            joints,
        })
    }

    /// The chain extended by a fixed frame `link` at `offset` from its tip (a frame the URDF
    /// does not name, such as dVRK's tool frame behind dvrk_model's `tool_tip_link`).
    pub fn with_fixed_tip(mut self, link: &str, offset: Isometry3<f64>) -> Chain {
        self.segments.push(Segment {
            child: link.to_owned(),
            origin: offset,
            motion: Motion::Fixed,
        });
        self
    }

    /// The link the chain starts at (its poses are in this link's frame).
    pub fn base_link(&self) -> &str {
        &self.base
    }

    /// The link the chain ends at (the base link for an empty chain).
    pub fn tip_link(&self) -> &str {
        self.segments.last().map_or(&self.base, |s| &s.child)
    }

    /// The chain's variables, in the order of `q`: path order, with a mimicked master placed
    /// where its first mimic appears.
    pub fn joints(&self) -> &[ActuatedJoint] {
        &self.joints
    }

    /// Number of variables in `q`.
    pub fn dof(&self) -> usize {
        self.joints.len()
    }

    /// The links on the path, base first, tip last (the order of [`Chain::link_poses`]).
    pub fn link_names(&self) -> Vec<&str> {
        std::iter::once(self.base.as_str())
            .chain(self.segments.iter().map(|s| s.child.as_str()))
            .collect()
    }

    /// The pose of every link on the path in the base frame, base (identity) first.
    pub fn link_poses(&self, q: &[f64]) -> Result<Vec<Isometry3<f64>>, ChainError> {
        self.check_len(q)?;
        let mut pose = Isometry3::identity();
        let mut poses = Vec::with_capacity(self.segments.len() + 1);
        poses.push(pose);
        for segment in &self.segments {
            pose = pose * segment.origin * motion_transform(&segment.motion, q);
            poses.push(pose);
        }
        Ok(poses)
    }

    /// The tip link's pose in the base frame.
    pub fn tip_pose(&self, q: &[f64]) -> Result<Isometry3<f64>, ChainError> {
        self.check_len(q)?;
        Ok(self.segments.iter().fold(Isometry3::identity(), |pose, s| {
            pose * s.origin * motion_transform(&s.motion, q)
        }))
    }

    /// Geometric Jacobian of the tip in the base frame: rows 0–2 map `q̇` to the linear velocity of
    /// the tip origin, rows 3–5 to the angular velocity; one column per variable.
    pub fn jacobian(&self, q: &[f64]) -> Result<Matrix6xX<f64>, ChainError> {
        self.check_len(q)?;
        let mut pose = Isometry3::identity();
        let mut columns = Vec::new();
        for segment in &self.segments {
            let joint_frame = pose * segment.origin;
            if let Motion::Moving {
                kind,
                axis,
                index,
                multiplier,
                ..
            } = segment.motion
            {
                let axis = joint_frame.rotation * axis.into_inner();
                columns.push((
                    kind,
                    axis,
                    joint_frame.translation.vector,
                    index,
                    multiplier,
                ));
            }
            pose = joint_frame * motion_transform(&segment.motion, q);
        }
        let tip = pose.translation.vector;
        let mut jacobian = Matrix6xX::zeros(self.dof());
        for (kind, axis, origin, index, multiplier) in columns {
            let (linear, angular) = match kind {
                JointKind::Revolute => (axis.cross(&(tip - origin)), axis),
                JointKind::Prismatic => (axis, Vector3::zeros()),
            };
            let mut column = jacobian.column_mut(index);
            column.fixed_rows_mut::<3>(0).axpy(multiplier, &linear, 1.0);
            column
                .fixed_rows_mut::<3>(3)
                .axpy(multiplier, &angular, 1.0);
        }
        Ok(jacobian)
    }

    fn check_len(&self, q: &[f64]) -> Result<(), ChainError> {
        if q.len() == self.dof() {
            Ok(())
        } else {
            Err(ChainError::JointCount {
                expected: self.dof(),
                got: q.len(),
                names: self
                    .joints
                    .iter()
                    .map(|j| j.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            })
        }
    }
}

fn motion_transform(motion: &Motion, q: &[f64]) -> Isometry3<f64> {
    match *motion {
        Motion::Fixed => Isometry3::identity(),
        Motion::Moving {
            kind,
            axis,
            index,
            multiplier,
            offset,
        } => {
            let value = multiplier * q[index] + offset;
            match kind {
                JointKind::Revolute => Isometry3::from_parts(
                    Translation3::identity(),
                    UnitQuaternion::from_axis_angle(&axis, value),
                ),
                JointKind::Prismatic => {
                    Isometry3::translation(axis.x * value, axis.y * value, axis.z * value)
                }
            }
        }
    }
}

/// `None` for a fixed joint, the motion kind for a movable one, an error for the rest.
fn movable_kind(joint: &urdf_rs::Joint) -> Result<Option<JointKind>, ChainError> {
    use urdf_rs::JointType;
    match joint.joint_type {
        JointType::Fixed => Ok(None),
        JointType::Revolute | JointType::Continuous => Ok(Some(JointKind::Revolute)),
        JointType::Prismatic => Ok(Some(JointKind::Prismatic)),
        ref other => Err(ChainError::UnsupportedJoint {
            joint: joint.name.clone(),
            kind: format!("{other:?}").to_lowercase(),
        }),
    }
}

fn actuated_joint(joint: &urdf_rs::Joint) -> Result<ActuatedJoint, ChainError> {
    let kind = movable_kind(joint)?.ok_or_else(|| ChainError::BadMimic {
        joint: joint.name.clone(),
        master: joint.name.clone(),
        reason: "is fixed",
    })?;
    let (lower, upper) = if joint.joint_type == urdf_rs::JointType::Continuous {
        (f64::NEG_INFINITY, f64::INFINITY)
    } else {
        (joint.limit.lower, joint.limit.upper)
    };
    if lower > upper {
        return Err(ChainError::InvalidLimits {
            joint: joint.name.clone(),
            lower,
            upper,
        });
    }
    Ok(ActuatedJoint {
        name: joint.name.clone(),
        kind,
        lower,
        upper,
        max_velocity: joint.limit.velocity,
    })
}

fn origin_of(joint: &urdf_rs::Joint) -> Result<Isometry3<f64>, ChainError> {
    let [x, y, z] = joint.origin.xyz.0;
    let [roll, pitch, yaw] = joint.origin.rpy.0;
    if ![x, y, z, roll, pitch, yaw].iter().all(|v| v.is_finite()) {
        return Err(ChainError::NonFinite {
            joint: joint.name.clone(),
        });
    }
    // URDF rpy is fixed-axis X, then Y, then Z: R = Rz(yaw)·Ry(pitch)·Rx(roll), which is exactly
    // nalgebra's `from_euler_angles(roll, pitch, yaw)`.
    Ok(Isometry3::from_parts(
        Translation3::new(x, y, z),
        UnitQuaternion::from_euler_angles(roll, pitch, yaw),
    ))
}

fn axis_of(joint: &urdf_rs::Joint) -> Result<Unit<Vector3<f64>>, ChainError> {
    let axis = Vector3::from(joint.axis.xyz.0);
    if !axis.iter().all(|v| v.is_finite()) {
        return Err(ChainError::NonFinite {
            joint: joint.name.clone(),
        });
    }
    Unit::try_new(axis, 1e-12).ok_or_else(|| ChainError::ZeroAxis {
        joint: joint.name.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::urdf::parse_urdf;

    /// Two revolute joints about z, 1 m apart, and a fixed tip 0.5 m further.
    const PLANAR_ARM: &str = r#"
        <robot name="planar">
          <link name="base"/><link name="l1"/><link name="l2"/><link name="tip"/>
          <joint name="j1" type="revolute">
            <parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
            <limit lower="-3" upper="3" velocity="1" effort="1"/>
          </joint>
          <joint name="j2" type="continuous">
            <parent link="l1"/><child link="l2"/><origin xyz="1 0 0"/><axis xyz="0 0 1"/>
          </joint>
          <joint name="fixed_tip" type="fixed">
            <parent link="l2"/><child link="tip"/><origin xyz="0.5 0 0"/>
          </joint>
        </robot>"#;

    fn chain_of(urdf: &str, base: &str, tip: &str) -> Result<Chain, ChainError> {
        Chain::from_urdf(&parse_urdf(urdf).unwrap(), base, tip)
    }

    #[test]
    fn planar_arm_forward_kinematics_and_jacobian() {
        let chain = chain_of(PLANAR_ARM, "base", "tip").unwrap();
        assert_eq!(chain.dof(), 2);
        assert_eq!(chain.link_names(), ["base", "l1", "l2", "tip"]);
        assert_eq!(chain.joints()[1].upper, f64::INFINITY);
        let q = [std::f64::consts::FRAC_PI_2, -std::f64::consts::FRAC_PI_2];
        let tip = chain.tip_pose(&q).unwrap();
        // First link points along +y, second turns back to +x.
        assert!((tip.translation.vector - Vector3::new(0.5, 1.0, 0.0)).norm() < 1e-12);
        let j = chain.jacobian(&q).unwrap();
        // ∂tip/∂q1 = z × (tip − 0), ∂tip/∂q2 = z × (tip − (0, 1, 0)).
        assert!((j.fixed_view::<3, 1>(0, 0) - Vector3::new(-1.0, 0.5, 0.0)).norm() < 1e-12);
        assert!((j.fixed_view::<3, 1>(0, 1) - Vector3::new(0.0, 0.5, 0.0)).norm() < 1e-12);
        assert_eq!(j.fixed_view::<3, 1>(3, 0), Vector3::z());
    }

    #[test]
    fn wrong_joint_count_is_an_error() {
        let chain = chain_of(PLANAR_ARM, "base", "tip").unwrap();
        assert!(matches!(
            chain.tip_pose(&[0.0]),
            Err(ChainError::JointCount {
                expected: 2,
                got: 1,
                ..
            })
        ));
        assert!(chain.jacobian(&[0.0; 3]).is_err());
        assert!(chain.link_poses(&[]).is_err());
    }

    #[test]
    fn missing_links_are_named() {
        assert_eq!(
            chain_of(PLANAR_ARM, "base", "hand").unwrap_err(),
            ChainError::MissingLink("hand".into())
        );
        assert_eq!(
            chain_of(PLANAR_ARM, "world", "tip").unwrap_err(),
            ChainError::MissingLink("world".into())
        );
    }

    #[test]
    fn tip_above_base_has_no_path() {
        assert!(matches!(
            chain_of(PLANAR_ARM, "tip", "base"),
            Err(ChainError::NoPath { .. })
        ));
    }

    #[test]
    fn sibling_branches_have_no_path() {
        let urdf = r#"<robot name="y">
            <link name="root"/><link name="a"/><link name="b"/>
            <joint name="ja" type="fixed"><parent link="root"/><child link="a"/></joint>
            <joint name="jb" type="fixed"><parent link="root"/><child link="b"/></joint>
          </robot>"#;
        assert!(matches!(
            chain_of(urdf, "a", "b"),
            Err(ChainError::NoPath { .. })
        ));
        assert_eq!(
            chain_of(urdf, "root", "b").unwrap().link_names(),
            ["root", "b"]
        );
    }

    #[test]
    fn unsupported_joint_type_is_named() {
        let urdf = r#"<robot name="f">
            <link name="a"/><link name="b"/>
            <joint name="free" type="floating"><parent link="a"/><child link="b"/></joint>
          </robot>"#;
        assert_eq!(
            chain_of(urdf, "a", "b").unwrap_err(),
            ChainError::UnsupportedJoint {
                joint: "free".into(),
                kind: "floating".into()
            }
        );
    }

    #[test]
    fn malformed_trees_are_rejected() {
        let two_parents = r#"<robot name="t">
            <link name="a"/><link name="b"/><link name="c"/>
            <joint name="j1" type="fixed"><parent link="a"/><child link="c"/></joint>
            <joint name="j2" type="fixed"><parent link="b"/><child link="c"/></joint>
          </robot>"#;
        assert!(matches!(
            chain_of(two_parents, "a", "c"),
            Err(ChainError::MultipleParents { .. })
        ));
        let dangling = r#"<robot name="t">
            <link name="a"/><link name="b"/>
            <joint name="j1" type="fixed"><parent link="a"/><child link="ghost"/></joint>
          </robot>"#;
        assert!(matches!(
            chain_of(dangling, "a", "b"),
            Err(ChainError::DanglingJoint { .. })
        ));
        let cycle = r#"<robot name="t">
            <link name="root"/><link name="a"/><link name="b"/>
            <joint name="j1" type="fixed"><parent link="a"/><child link="b"/></joint>
            <joint name="j2" type="fixed"><parent link="b"/><child link="a"/></joint>
          </robot>"#;
        assert!(matches!(
            chain_of(cycle, "root", "a"),
            Err(ChainError::Cycle { .. })
        ));
    }

    #[test]
    fn bad_axes_and_limits_are_rejected() {
        let zero_axis = r#"<robot name="t"><link name="a"/><link name="b"/>
            <joint name="j" type="revolute"><parent link="a"/><child link="b"/>
              <axis xyz="0 0 0"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
          </robot>"#;
        assert!(matches!(
            chain_of(zero_axis, "a", "b"),
            Err(ChainError::ZeroAxis { .. })
        ));
        let inverted = r#"<robot name="t"><link name="a"/><link name="b"/>
            <joint name="j" type="prismatic"><parent link="a"/><child link="b"/>
              <axis xyz="1 0 0"/><limit lower="1" upper="-1" velocity="1" effort="1"/></joint>
          </robot>"#;
        assert!(matches!(
            chain_of(inverted, "a", "b"),
            Err(ChainError::InvalidLimits { .. })
        ));
        let infinite_origin = r#"<robot name="t"><link name="a"/><link name="b"/>
            <joint name="j" type="fixed"><parent link="a"/><child link="b"/>
              <origin xyz="inf 0 0"/></joint>
          </robot>"#;
        assert!(matches!(
            chain_of(infinite_origin, "a", "b"),
            Err(ChainError::NonFinite { .. })
        ));
    }

    #[test]
    fn mimic_joint_follows_its_master() {
        let urdf = r#"<robot name="m">
            <link name="a"/><link name="hidden"/><link name="b"/>
            <joint name="master" type="revolute"><parent link="a"/><child link="hidden"/>
              <axis xyz="0 0 1"/><limit lower="-1" upper="2" velocity="3" effort="1"/></joint>
            <joint name="follower" type="prismatic"><parent link="a"/><child link="b"/>
              <axis xyz="1 0 0"/><limit lower="-1" upper="1" velocity="1" effort="1"/>
              <mimic joint="master" multiplier="0.5" offset="0.1"/></joint>
          </robot>"#;
        let chain = chain_of(urdf, "a", "b").unwrap();
        assert_eq!(chain.joints().len(), 1);
        assert_eq!(chain.joints()[0].name, "master");
        assert_eq!(
            (chain.joints()[0].lower, chain.joints()[0].upper),
            (-1.0, 2.0)
        );
        let tip = chain.tip_pose(&[0.8]).unwrap();
        assert!((tip.translation.x - 0.5).abs() < 1e-15);
        let j = chain.jacobian(&[0.8]).unwrap();
        assert!((j[(0, 0)] - 0.5).abs() < 1e-15);

        let bad = urdf.replace(r#"mimic joint="master""#, r#"mimic joint="nobody""#);
        assert!(matches!(
            chain_of(&bad, "a", "b"),
            Err(ChainError::BadMimic { .. })
        ));
    }
}
