//! Inverse kinematics of a chain's tip by damped least squares (Levenberg–Marquardt), warm-started
//! from the current joints and kept inside the joint limits.
//!
//! Why this and not a closed form: it works on whatever chain the URDF describes (other tools,
//! the Si PSM), and warm-starting from the current joints picks the solution next to the arm's
//! present configuration, which is what a servo loop wants.

use nalgebra::{DMatrix, DVector, Isometry3, Matrix6xX, Vector6};

use crate::robot::chain::{Chain, ChainError};

/// Damping bounds: below the minimum the step is plain Gauss–Newton already; above the maximum
/// steps are too small to matter, so the solver is stuck.
const MIN_DAMPING: f64 = 1e-12;
const MAX_DAMPING: f64 = 1e8;

/// Tuning of the solver. The defaults reach 1 µm / 1 µrad on the PSM in a few iterations from a
/// nearby start.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IkOptions {
    /// Most Levenberg-Marquardt iterations before giving up.
    pub max_iterations: usize,
    /// Largest acceptable distance between the reached and the target tip position (m).
    pub position_tolerance: f64,
    /// Largest acceptable angle between the reached and the target tip orientation (rad).
    pub orientation_tolerance: f64,
    /// Orientation errors are weighed as arc lengths at this radius (m), so that metres and
    /// radians are comparable in the least-squares problem.
    pub orientation_length: f64,
    /// Initial Levenberg–Marquardt damping (relative to the largest diagonal entry of JᵀJ).
    pub initial_damping: f64,
}

impl Default for IkOptions {
    fn default() -> Self {
        IkOptions {
            max_iterations: 100,
            position_tolerance: 1e-6,
            orientation_tolerance: 1e-6,
            orientation_length: 0.05,
            initial_damping: 1e-3,
        }
    }
}

/// A converged solution and what is left of the error.
#[derive(Debug, Clone, PartialEq)]
pub struct IkSolution {
    /// The joint values reaching the target, rad or m, in chain order (inside the limits).
    pub q: Vec<f64>,
    /// Distance between reached and target positions (m).
    pub position_error: f64,
    /// Angle between reached and target orientations (rad).
    pub orientation_error: f64,
    /// Iterations taken.
    pub iterations: usize,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
/// Why inverse kinematics found no solution.
pub enum IkError {
    #[error(transparent)]
    /// The joint vector does not fit the chain.
    Chain(#[from] ChainError),
    #[error("IK target pose is not finite")]
    /// The target pose has NaN or infinite values.
    NonFiniteTarget,
    #[error("IK start joint values are not finite")]
    /// The start joint values have NaN or infinite values.
    NonFiniteStart,
    #[error(
        "IK did not reach the target within tolerance after {iterations} iterations: \
         {position_error:.3e} m and {orientation_error:.3e} rad off (unreachable, or out of \
         joint limits)"
    )]
    /// No joint values within the limits reach the target within tolerance.
    NotConverged {
        /// Distance left between the closest reached and target positions, m.
        position_error: f64,
        /// Angle left between the closest reached and target orientations, rad.
        orientation_error: f64,
        /// Iterations taken.
        iterations: usize,
        /// The closest joint values found (inside the limits).
        best: Vec<f64>,
    },
}

/// Finds joint values (inside the chain's limits) that put the tip at `target`, starting from
/// `start`.
pub fn solve(
    chain: &Chain,
    target: &Isometry3<f64>,
    start: &[f64],
    options: &IkOptions,
) -> Result<IkSolution, IkError> {
    let finite = target.translation.vector.iter().all(|v| v.is_finite())
        && target.rotation.coords.iter().all(|v| v.is_finite());
    if !finite {
        return Err(IkError::NonFiniteTarget);
    }
    if start.iter().any(|v| !v.is_finite()) {
        return Err(IkError::NonFiniteStart);
    }
    let limits: Vec<(f64, f64)> = chain.joints().iter().map(|j| (j.lower, j.upper)).collect();
    let clamp = |q: &mut DVector<f64>| {
        for (value, &(lower, upper)) in q.iter_mut().zip(&limits) {
            *value = value.clamp(lower, upper);
        }
    };

    let mut q = DVector::from_column_slice(start);
    clamp(&mut q);
    let mut error = pose_error(chain, target, q.as_slice(), options)?;
    let mut lambda = options.initial_damping;
    for iteration in 0..options.max_iterations {
        if converged(&error, options) {
            return Ok(solution(q, &error, iteration, options));
        }
        let mut jacobian = chain.jacobian(q.as_slice())?;
        weigh_rows(&mut jacobian, options);
        let jtj = jacobian.transpose() * &jacobian;
        let jte = jacobian.transpose() * error;
        let scale = jtj.diagonal().max().max(f64::MIN_POSITIVE);
        // Raise the damping until a step lowers the error; lower it again after a success.
        loop {
            if lambda > MAX_DAMPING {
                // No step helps: a minimum (inside the limits) that is not the target.
                return Err(not_converged(q, &error, iteration, options));
            }
            let damped = &jtj + DMatrix::identity(q.len(), q.len()) * (lambda * scale);
            let Some(step) = damped.cholesky().map(|c| c.solve(&jte)) else {
                lambda *= 10.0;
                continue;
            };
            let mut candidate = &q + step;
            clamp(&mut candidate);
            let candidate_error = pose_error(chain, target, candidate.as_slice(), options)?;
            if candidate_error.norm_squared() < error.norm_squared() {
                q = candidate;
                error = candidate_error;
                lambda = (lambda / 10.0).max(MIN_DAMPING);
                break;
            }
            lambda *= 10.0;
        }
    }
    if converged(&error, options) {
        Ok(solution(q, &error, options.max_iterations, options))
    } else {
        Err(not_converged(q, &error, options.max_iterations, options))
    }
}

/// Weighted error `[Δp; L·Δθ]` in the base frame, with Δθ the rotation vector taking the reached
/// orientation to the target.
fn pose_error(
    chain: &Chain,
    target: &Isometry3<f64>,
    q: &[f64],
    options: &IkOptions,
) -> Result<Vector6<f64>, ChainError> {
    let reached = chain.tip_pose(q)?;
    let dp = target.translation.vector - reached.translation.vector;
    let dtheta = (target.rotation * reached.rotation.inverse()).scaled_axis();
    let mut error = Vector6::zeros();
    error.fixed_rows_mut::<3>(0).copy_from(&dp);
    error
        .fixed_rows_mut::<3>(3)
        .copy_from(&(dtheta * options.orientation_length));
    Ok(error)
}

fn weigh_rows(jacobian: &mut Matrix6xX<f64>, options: &IkOptions) {
    jacobian
        .fixed_rows_mut::<3>(3)
        .scale_mut(options.orientation_length);
}

fn converged(error: &Vector6<f64>, options: &IkOptions) -> bool {
    let (position, orientation) = split(error, options);
    position <= options.position_tolerance && orientation <= options.orientation_tolerance
}

fn split(error: &Vector6<f64>, options: &IkOptions) -> (f64, f64) {
    (
        error.fixed_rows::<3>(0).norm(),
        error.fixed_rows::<3>(3).norm() / options.orientation_length,
    )
}

fn not_converged(
    q: DVector<f64>,
    error: &Vector6<f64>,
    iterations: usize,
    options: &IkOptions,
) -> IkError {
    let best = solution(q, error, iterations, options);
    IkError::NotConverged {
        position_error: best.position_error,
        orientation_error: best.orientation_error,
        iterations,
        best: best.q,
    }
}

fn solution(
    q: DVector<f64>,
    error: &Vector6<f64>,
    iterations: usize,
    options: &IkOptions,
) -> IkSolution {
    let (position_error, orientation_error) = split(error, options);
    IkSolution {
        q: q.as_slice().to_vec(),
        position_error,
        orientation_error,
        iterations,
    }
}
