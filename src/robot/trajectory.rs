//! Joint-space point-to-point moves (`move_jp`) under per-joint speed limits.
//!
//! All joints follow one quintic time scaling `s(τ) = 10τ³ − 15τ⁴ + 6τ⁵`, so they start and end
//! together with zero velocity and acceleration (dVRK gives speed limits but no acceleration
//! limits, and a jump in acceleration would kick the tissue). The duration is the shortest for
//! which no joint exceeds its limit: the peak of `s'` is 15/8, so `T = 15/8 · max |Δqᵢ| / vᵢ`.

/// Peak of the quintic scaling's derivative, at τ = ½.
const PEAK_SPEED_FACTOR: f64 = 15.0 / 8.0;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
/// Why a move cannot be planned.
pub enum TrajectoryError {
    #[error("start has {start} joint values, goal {goal}, speed limits {limits}")]
    /// Start, goal and speed limits differ in length.
    LengthMismatch {
        /// Number of start values.
        start: usize,
        /// Number of goal values.
        goal: usize,
        /// Number of speed limits.
        limits: usize,
    },
    #[error("joint {index}: start {start} or goal {goal} is not finite")]
    /// A NaN or infinite start or goal value.
    NotFinite {
        /// The joint's index.
        index: usize,
        /// Its start value, rad or m.
        start: f64,
        /// Its goal value, rad or m.
        goal: f64,
    },
    #[error("joint {index}: speed limit {value} must be positive")]
    /// A speed limit that is not positive (or NaN).
    InvalidSpeedLimit {
        /// The joint's index.
        index: usize,
        /// The limit given, rad/s or m/s.
        value: f64,
    },
}

/// A move from `start` to `goal`; sample it with [`Trajectory::setpoint`] at the time since the
/// move began. The caller is busy until [`Trajectory::is_done`].
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    start: Vec<f64>,
    goal: Vec<f64>,
    duration: f64,
}

impl Trajectory {
    /// A move from `start` to `goal` whose slowest joint peaks at its `max_velocity` (rad/s or m/s
    /// per joint); all joints arrive together.
    pub fn new(start: &[f64], goal: &[f64], max_velocity: &[f64]) -> Result<Self, TrajectoryError> {
        if start.len() != goal.len() || start.len() != max_velocity.len() {
            return Err(TrajectoryError::LengthMismatch {
                start: start.len(),
                goal: goal.len(),
                limits: max_velocity.len(),
            });
        }
        let mut slowest: f64 = 0.0;
        for (index, ((&s, &g), &v)) in start.iter().zip(goal).zip(max_velocity).enumerate() {
            if !s.is_finite() || !g.is_finite() {
                return Err(TrajectoryError::NotFinite {
                    index,
                    start: s,
                    goal: g,
                });
            }
            if v.is_nan() || v <= 0.0 {
                return Err(TrajectoryError::InvalidSpeedLimit { index, value: v });
            }
            slowest = slowest.max((g - s).abs() / v);
        }
        Ok(Trajectory {
            start: start.to_vec(),
            goal: goal.to_vec(),
            duration: PEAK_SPEED_FACTOR * slowest,
        })
    }

    /// Time the move takes (s); 0 when start and goal are equal.
    pub fn duration(&self) -> f64 {
        self.duration
    }

    /// The joint values the move starts from, rad or m.
    pub fn start(&self) -> &[f64] {
        &self.start
    }

    /// The joint values the move ends at, rad or m.
    pub fn goal(&self) -> &[f64] {
        &self.goal
    }

    /// True once `t` (s since the move began) reaches the end.
    pub fn is_done(&self, t: f64) -> bool {
        t >= self.duration
    }

    /// Positions at time `t`: `start` before the move (and for a NaN time), exactly `goal` from
    /// the end on.
    pub fn setpoint(&self, t: f64) -> Vec<f64> {
        if self.is_done(t) {
            return self.goal.clone();
        }
        let s = match self.phase(t) {
            Some(tau) => tau * tau * tau * (10.0 + tau * (-15.0 + 6.0 * tau)),
            None => 0.0,
        };
        self.start
            .iter()
            .zip(&self.goal)
            .map(|(a, b)| a + (b - a) * s)
            .collect()
    }

    /// Velocities at time `t` (zero before and after the move).
    pub fn velocity(&self, t: f64) -> Vec<f64> {
        let ds = match self.phase(t) {
            Some(tau) if !self.is_done(t) => {
                30.0 * tau * tau * (1.0 - tau) * (1.0 - tau) / self.duration
            }
            _ => 0.0,
        };
        self.start
            .iter()
            .zip(&self.goal)
            .map(|(a, b)| (b - a) * ds)
            .collect()
    }

    /// Normalised time τ ∈ (0, 1) while the move is under way.
    fn phase(&self, t: f64) -> Option<f64> {
        (t > 0.0 && t < self.duration).then(|| t / self.duration)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slowest_joint_sets_the_duration_and_touches_its_limit() {
        let traj = Trajectory::new(&[0.0, 0.0], &[1.0, -0.1], &[0.5, 0.2]).unwrap();
        assert!((traj.duration() - 15.0 / 8.0 * 2.0).abs() < 1e-12);
        let v = traj.velocity(traj.duration() / 2.0);
        assert!((v[0] - 0.5).abs() < 1e-12);
        assert!(v[1].abs() < 0.2);
    }

    #[test]
    fn samples_never_exceed_the_speed_limits_and_end_on_the_goal() {
        let start = [0.3, -1.0, 0.05];
        let goal = [-1.2, 0.4, 0.2];
        let limits = [1.5, 1.0, 0.2];
        let traj = Trajectory::new(&start, &goal, &limits).unwrap();
        let dt = 1e-3;
        let steps = (traj.duration() / dt).ceil() as usize + 10;
        let mut previous = traj.setpoint(0.0);
        assert_eq!(previous, start);
        let mut peak_ratio: f64 = 0.0;
        for k in 1..=steps {
            let t = k as f64 * dt;
            let q = traj.setpoint(t);
            for i in 0..3 {
                let speed = (q[i] - previous[i]).abs() / dt;
                assert!(
                    speed <= limits[i] * (1.0 + 1e-9),
                    "joint {i} at {t}: {speed}"
                );
                assert!(traj.velocity(t)[i].abs() <= limits[i] * (1.0 + 1e-9));
                peak_ratio = peak_ratio.max(speed / limits[i]);
            }
            previous = q;
        }
        assert_eq!(previous, goal);
        assert!(traj.is_done(steps as f64 * dt));
        assert!(!traj.is_done(traj.duration() * 0.99));
        // Not needlessly slow: the limiting joint gets within 0.1 % of its limit.
        assert!(peak_ratio > 0.999, "{peak_ratio}");
    }

    #[test]
    fn zero_length_move_is_done_at_once() {
        let traj = Trajectory::new(&[0.1], &[0.1], &[1.0]).unwrap();
        assert_eq!(traj.duration(), 0.0);
        assert!(traj.is_done(0.0));
        assert_eq!(traj.setpoint(0.0), [0.1]);
        assert_eq!(traj.velocity(0.0), [0.0]);
    }

    #[test]
    fn bad_inputs_are_rejected() {
        assert!(matches!(
            Trajectory::new(&[0.0], &[1.0, 2.0], &[1.0]),
            Err(TrajectoryError::LengthMismatch { .. })
        ));
        assert!(matches!(
            Trajectory::new(&[0.0], &[f64::NAN], &[1.0]),
            Err(TrajectoryError::NotFinite { index: 0, .. })
        ));
        assert!(matches!(
            Trajectory::new(&[0.0], &[1.0], &[0.0]),
            Err(TrajectoryError::InvalidSpeedLimit { index: 0, .. })
        ));
    }

    #[test]
    fn times_outside_the_move_hold_the_ends() {
        let traj = Trajectory::new(&[0.0], &[1.0], &[1.0]).unwrap();
        assert_eq!(traj.setpoint(-1.0), [0.0]);
        assert_eq!(traj.setpoint(f64::NAN), [0.0]);
        assert_eq!(traj.setpoint(1e9), [1.0]);
    }
}
