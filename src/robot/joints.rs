//! A named group of joints (the PSM arm, or its jaw) with position and speed limits, and the
//! validation every joint command goes through before it reaches the simulation.

use crate::robot::chain::ActuatedJoint;

/// By default a servo command may jump at most as far as `move_jp` would travel in this time at
/// its speed limit: a larger jump is almost always a unit or frame mistake, and `move_jp` is the
/// command for big moves.
pub const DEFAULT_JUMP_WINDOW_S: f64 = 0.1;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
/// Why a joint command was rejected.
pub enum JointCommandError {
    #[error("expected {expected} joint values ({names}), got {got}")]
    /// Fewer or more positions than the group has joints.
    WrongLength {
        /// The group's number of joints.
        expected: usize,
        /// The number of positions given.
        got: usize,
        /// The group's joint names, comma separated.
        names: String,
    },
    #[error("{names} joint names given for {positions} positions")]
    /// The names and positions differ in length.
    NamesMismatch {
        /// Number of names given.
        names: usize,
        /// Number of positions given.
        positions: usize,
    },
    #[error("unknown joint `{name}` (expected some of: {known})")]
    /// A name that is not one of the group's joints.
    UnknownJoint {
        /// The unknown name.
        name: String,
        /// The group's joint names, comma separated.
        known: String,
    },
    #[error("joint `{name}` is given twice")]
    /// A joint named twice.
    DuplicateJoint {
        /// The joint's name.
        name: String,
    },
    #[error("joint `{name}` is missing from the command")]
    /// Names given, but not this joint's.
    MissingJoint {
        /// The joint's name.
        name: String,
    },
    #[error("joint `{name}` value {value} is not a finite number")]
    /// A NaN or infinite position.
    NotFinite {
        /// The joint's name.
        name: String,
        /// The value given.
        value: f64,
    },
    #[error("joint `{name}` value {value} is outside its limits [{lower}, {upper}]")]
    /// A position outside the joint's URDF limits.
    OutOfLimits {
        /// The joint's name.
        name: String,
        /// The value given, rad or m.
        value: f64,
        /// Lower limit, rad or m.
        lower: f64,
        /// Upper limit, rad or m.
        upper: f64,
    },
    #[error(
        "joint `{name}` would jump from {from} to {to} (more than {max} in one command); \
         use move_jp for large moves"
    )]
    /// A servo command that moves a joint further than its jump bound from where it is.
    JumpTooLarge {
        /// The joint's name.
        name: String,
        /// The joint's current position, rad or m.
        from: f64,
        /// The commanded position, rad or m.
        to: f64,
        /// The jump bound, rad or m.
        max: f64,
    },
    #[error("jump bound for joint `{name}` must be positive (NaN is not allowed), got {value}")]
    /// A jump bound that is not positive (or NaN).
    InvalidJumpBound {
        /// The joint's name.
        name: String,
        /// The bound given.
        value: f64,
    },
}

/// Joints with their limits, in a fixed (canonical) order.
#[derive(Debug, Clone, PartialEq)]
pub struct JointGroup {
    joints: Vec<ActuatedJoint>,
    max_jump: Vec<f64>,
}

impl JointGroup {
    /// The jump bound of each joint starts at [`DEFAULT_JUMP_WINDOW_S`] × its speed limit
    /// (unbounded where the speed is not limited).
    pub fn new(joints: Vec<ActuatedJoint>) -> JointGroup {
        let max_jump = joints
            .iter()
            .map(|j| {
                if j.max_velocity > 0.0 {
                    j.max_velocity * DEFAULT_JUMP_WINDOW_S
                } else {
                    f64::INFINITY
                }
            })
            .collect();
        JointGroup { joints, max_jump }
    }

    /// The number of joints.
    pub fn len(&self) -> usize {
        self.joints.len()
    }

    /// Whether the group has no joints.
    pub fn is_empty(&self) -> bool {
        self.joints.is_empty()
    }

    /// The joints with their limits, in canonical order.
    pub fn joints(&self) -> &[ActuatedJoint] {
        &self.joints
    }

    /// The joint names, in canonical order.
    pub fn names(&self) -> Vec<&str> {
        self.joints.iter().map(|j| j.name.as_str()).collect()
    }

    /// The (lower, upper) position limits (rad or m), in canonical order.
    pub fn limits(&self) -> Vec<(f64, f64)> {
        self.joints.iter().map(|j| (j.lower, j.upper)).collect()
    }

    /// Speed limits (rad/s or m/s), in canonical order.
    pub fn max_velocities(&self) -> Vec<f64> {
        self.joints.iter().map(|j| j.max_velocity).collect()
    }

    /// The largest change per servo command, per joint.
    pub fn max_jump(&self) -> &[f64] {
        &self.max_jump
    }

    /// Sets the largest change per servo command (`f64::INFINITY` disables the check).
    pub fn set_max_jump(&mut self, max_jump: &[f64]) -> Result<(), JointCommandError> {
        self.check_len(max_jump.len())?;
        for (joint, &value) in self.joints.iter().zip(max_jump) {
            if value.is_nan() || value <= 0.0 {
                return Err(JointCommandError::InvalidJumpBound {
                    name: joint.name.clone(),
                    value,
                });
            }
        }
        self.max_jump = max_jump.to_vec();
        Ok(())
    }

    /// Clamps `q` into the position limits.
    pub fn clamp(&self, q: &mut [f64]) {
        for (value, joint) in q.iter_mut().zip(&self.joints) {
            *value = value.clamp(joint.lower, joint.upper);
        }
    }

    /// Checks a joint command and returns its positions in canonical order.
    ///
    /// `names` may be empty (positions are then in canonical order, as in a `JointState` without
    /// names) or must name every joint exactly once, in any order. With `current`, each joint may
    /// move at most its jump bound (servo commands); without it there is no jump check (`move_jp`,
    /// which interpolates).
    pub fn validate<S: AsRef<str>>(
        &self,
        names: &[S],
        positions: &[f64],
        current: Option<&[f64]>,
    ) -> Result<Vec<f64>, JointCommandError> {
        let q = if names.is_empty() {
            self.check_len(positions.len())?;
            positions.to_vec()
        } else {
            self.reorder(names, positions)?
        };
        for (joint, &value) in self.joints.iter().zip(&q) {
            if !value.is_finite() {
                return Err(JointCommandError::NotFinite {
                    name: joint.name.clone(),
                    value,
                });
            }
            if value < joint.lower || value > joint.upper {
                return Err(JointCommandError::OutOfLimits {
                    name: joint.name.clone(),
                    value,
                    lower: joint.lower,
                    upper: joint.upper,
                });
            }
        }
        if let Some(current) = current {
            self.check_len(current.len())?;
            for ((joint, (&to, &from)), &max) in self
                .joints
                .iter()
                .zip(q.iter().zip(current))
                .zip(&self.max_jump)
            {
                if (to - from).abs() > max {
                    return Err(JointCommandError::JumpTooLarge {
                        name: joint.name.clone(),
                        from,
                        to,
                        max,
                    });
                }
            }
        }
        Ok(q)
    }

    /// Checks names, length and finiteness only (no limits, no jump): for measured values of a
    /// real arm, which may sit a hair outside the model's limits.
    pub fn validate_shape<S: AsRef<str>>(
        &self,
        names: &[S],
        positions: &[f64],
    ) -> Result<Vec<f64>, JointCommandError> {
        let q = if names.is_empty() {
            self.check_len(positions.len())?;
            positions.to_vec()
        } else {
            self.reorder(names, positions)?
        };
        for (joint, &value) in self.joints.iter().zip(&q) {
            if !value.is_finite() {
                return Err(JointCommandError::NotFinite {
                    name: joint.name.clone(),
                    value,
                });
            }
        }
        Ok(q)
    }

    fn reorder<S: AsRef<str>>(
        &self,
        names: &[S],
        positions: &[f64],
    ) -> Result<Vec<f64>, JointCommandError> {
        if names.len() != positions.len() {
            return Err(JointCommandError::NamesMismatch {
                names: names.len(),
                positions: positions.len(),
            });
        }
        let mut q: Vec<Option<f64>> = vec![None; self.joints.len()];
        for (name, &value) in names.iter().zip(positions) {
            let name = name.as_ref();
            let index = self
                .joints
                .iter()
                .position(|j| j.name == name)
                .ok_or_else(|| JointCommandError::UnknownJoint {
                    name: name.to_owned(),
                    known: self.names().join(", "),
                })?;
            if q[index].replace(value).is_some() {
                return Err(JointCommandError::DuplicateJoint {
                    name: name.to_owned(),
                });
            }
        }
        q.iter()
            .zip(&self.joints)
            .map(|(value, joint)| {
                value.ok_or_else(|| JointCommandError::MissingJoint {
                    name: joint.name.clone(),
                })
            })
            .collect()
    }

    fn check_len(&self, got: usize) -> Result<(), JointCommandError> {
        if got == self.joints.len() {
            Ok(())
        } else {
            Err(JointCommandError::WrongLength {
                expected: self.joints.len(),
                got,
                names: self.names().join(", "),
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::chain::JointKind;

    fn group() -> JointGroup {
        let joint = |name: &str, kind, lower, upper, max_velocity| ActuatedJoint {
            name: name.into(),
            kind,
            lower,
            upper,
            max_velocity,
        };
        JointGroup::new(vec![
            joint("yaw", JointKind::Revolute, -1.5, 1.5, 1.0),
            joint("insertion", JointKind::Prismatic, 0.0, 0.24, 0.2),
        ])
    }

    const NO_NAMES: &[&str] = &[];

    #[test]
    fn good_commands_pass_and_are_reordered() {
        let g = group();
        assert_eq!(g.validate(NO_NAMES, &[0.1, 0.1], None).unwrap(), [0.1, 0.1]);
        assert_eq!(
            g.validate(&["insertion", "yaw"], &[0.2, -0.3], None)
                .unwrap(),
            [-0.3, 0.2]
        );
        assert_eq!(
            g.validate(NO_NAMES, &[0.05, 0.1], Some(&[0.0, 0.1]))
                .unwrap(),
            [0.05, 0.1]
        );
    }

    #[test]
    fn wrong_length_is_rejected() {
        assert!(matches!(
            group().validate(NO_NAMES, &[0.1], None),
            Err(JointCommandError::WrongLength {
                expected: 2,
                got: 1,
                ..
            })
        ));
    }

    #[test]
    fn names_and_positions_must_match() {
        assert!(matches!(
            group().validate(&["yaw"], &[0.1, 0.1], None),
            Err(JointCommandError::NamesMismatch {
                names: 1,
                positions: 2
            })
        ));
    }

    #[test]
    fn unknown_duplicate_and_missing_names_are_rejected() {
        let g = group();
        assert!(matches!(
            g.validate(&["yaw", "elbow"], &[0.0, 0.1], None),
            Err(JointCommandError::UnknownJoint { name, .. }) if name == "elbow"
        ));
        assert!(matches!(
            g.validate(&["yaw", "yaw"], &[0.0, 0.1], None),
            Err(JointCommandError::DuplicateJoint { name }) if name == "yaw"
        ));
        assert!(matches!(
            g.validate(&["yaw"], &[0.0], None),
            Err(JointCommandError::MissingJoint { name }) if name == "insertion"
        ));
    }

    #[test]
    fn non_finite_values_are_rejected() {
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            assert!(matches!(
                group().validate(NO_NAMES, &[0.0, bad], None),
                Err(JointCommandError::NotFinite { name, .. }) if name == "insertion"
            ));
        }
    }

    #[test]
    fn out_of_limits_is_rejected() {
        assert!(matches!(
            group().validate(NO_NAMES, &[1.6, 0.1], None),
            Err(JointCommandError::OutOfLimits { name, value, .. }) if name == "yaw" && value == 1.6
        ));
        assert!(matches!(
            group().validate(NO_NAMES, &[0.0, -0.001], None),
            Err(JointCommandError::OutOfLimits { name, .. }) if name == "insertion"
        ));
    }

    #[test]
    fn jumps_beyond_the_bound_are_rejected() {
        let mut g = group();
        assert_eq!(g.max_jump(), [0.1, 0.2 * DEFAULT_JUMP_WINDOW_S]);
        assert!(matches!(
            g.validate(NO_NAMES, &[0.5, 0.1], Some(&[0.0, 0.1])),
            Err(JointCommandError::JumpTooLarge { name, max, .. }) if name == "yaw" && max == 0.1
        ));
        g.set_max_jump(&[1.0, 1.0]).unwrap();
        g.validate(NO_NAMES, &[0.5, 0.1], Some(&[0.0, 0.1]))
            .unwrap();
        assert!(matches!(
            g.set_max_jump(&[f64::NAN, 1.0]),
            Err(JointCommandError::InvalidJumpBound { .. })
        ));
        assert!(matches!(
            g.set_max_jump(&[1.0]),
            Err(JointCommandError::WrongLength { .. })
        ));
    }

    #[test]
    fn clamp_puts_values_inside_the_limits() {
        let mut q = [-2.0, 0.5];
        group().clamp(&mut q);
        assert_eq!(q, [-1.5, 0.24]);
    }
}
