//! The implicit solver's settings, and the constants and rules both backends' Newton
//! solves share (the method is described in [`crate::mpm::cpu::implicit`]; the GPU runs the
//! same Newton iteration with its node and particle work on the device).

use serde::{Deserialize, Serialize};

/// Implicit solver settings (scene keys `solver.newton_*`, `solver.cg_*`,
/// `solver.preconditioner`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImplicitParams {
    /// Most Newton iterations per substep.
    pub newton_iterations: u32,
    /// Newton stops when the free-node residual falls below this fraction of its first value
    /// or of the momentum gravity gives the nodes in one step, whichever is larger.
    pub newton_tolerance: f32,
    /// Most conjugate-gradient iterations per Newton iteration.
    pub cg_iterations: u32,
    /// The loosest Eisenstat–Walker forcing term: CG stops when its residual falls below
    /// η times the Newton residual, η at most this (the first Newton iteration's), then
    /// shrinking as Newton converges ([`forcing_term`]).
    pub cg_tolerance: f32,
    /// The CG preconditioner.
    pub preconditioner: Preconditioner,
}

impl Default for ImplicitParams {
    fn default() -> Self {
        ImplicitParams {
            newton_iterations: 8,
            newton_tolerance: 1e-3,
            cg_iterations: 200,
            cg_tolerance: 1e-1,
            preconditioner: Preconditioner::BlockJacobi,
        }
    }
}

/// Preconditioner of the implicit solver's conjugate gradients (scene key
/// `solver.preconditioner`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Preconditioner {
    /// The node mass: the Hessian's inertia term alone.
    Mass,
    /// Each node's 3×3 diagonal block of the Hessian, inertia and elasticity.
    #[default]
    BlockJacobi,
}

/// Iterations an implicit solve took (zero for the explicit methods).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SolveCounts {
    /// Newton iterations.
    pub newton: u32,
    /// Conjugate-gradient iterations, summed over the Newton iterations.
    pub cg: u32,
    /// Nodes that joined the active set of constraints after a Newton solve (the solution
    /// moved them into a tool, the table or a wall).
    pub activated: u32,
}

impl SolveCounts {
    /// Adds another solve's counts to these.
    pub fn add(&mut self, other: SolveCounts) {
        self.newton += other.newton;
        self.cg += other.cg;
        self.activated += other.activated;
    }
}

/// Times the active set of constraints may grow after Newton converged (the CPU's
/// `activate_constraints`); each round reruns Newton from the projected solution.
pub const CONTACT_ROUNDS: usize = 3;

/// Newton's absolute residual floor, as a velocity error per node in units of dx/dt: far
/// below what moves a particle. The floor in N·s is this times ‖m‖ (the nodes' masses as a
/// vector) times dx/dt.
pub const RESIDUAL_FLOOR: f64 = 1e-5;

/// Φ is summed from f32 deformation gradients: a change of Φ below this share of |Φ| is
/// rounding, which the line search neither asks for nor trusts.
pub const ENERGY_ROUNDING: f64 = 1e-6;

/// The line search's sufficient decrease (Armijo): a trial of step length α is taken when
/// Φ fell by at least this share of the decrease the slope predicts, α·slope.
pub const ARMIJO: f64 = 1e-4;

/// Trials of the backtracking line search (α = 1, ½, ¼, ...), the last taken whatever Φ.
pub const LINE_SEARCH_TRIALS: u32 = 8;

/// The slip threshold ε as a share of dx/dt: a node held by static friction creeps by at
/// most this share of a cell per step (see [`crate::mpm::cpu::implicit::slip`]). A tenth
/// of this (1e-3) took up to 1.5 times the Newton iterations on the sphere press of the
/// implicit GPU agreement test.
pub const SLIP_THRESHOLD: f32 = 1e-2;

/// The Eisenstat–Walker forcing term η of a Newton iteration at residual `norm` (CG stops at
/// η·norm): their choice 2, η = γ(‖gₖ‖/‖gₖ₋₁‖)² with γ = 0.9, safeguarded by γηₖ₋₁² while
/// that exceeds 0.1 (`previous` holds the last residual and η), starting at and never
/// looser than `loosest`. A linear solve far more exact than the Newton iterate it
/// corrects is wasted work; as Newton converges the ratio falls and η with it. Never
/// tighter than needed to bring the residual to half the Newton `goal`: the last step
/// solves only as far as stopping needs.
pub fn forcing_term(norm: f64, previous: Option<(f64, f64)>, goal: f64, loosest: f64) -> f64 {
    const GAMMA: f64 = 0.9;
    let eta = match previous {
        None => loosest,
        Some((previous_norm, previous_eta)) => {
            let eta = GAMMA * (norm / previous_norm).powi(2);
            let safeguard = GAMMA * previous_eta * previous_eta;
            if safeguard > 0.1 {
                eta.max(safeguard)
            } else {
                eta
            }
        }
    };
    eta.max(0.5 * goal / norm).min(loosest)
}

#[cfg(test)]
mod tests {
    use super::forcing_term;

    #[test]
    fn forcing_terms_loosen_far_from_the_solution_and_never_oversolve() {
        let goal = 1e-3;
        // The first Newton iteration takes the loosest term.
        assert_eq!(forcing_term(1.0, None, goal, 0.1), 0.1);
        // Fast convergence (residual down 10×) tightens it to γ·0.01.
        let eta = forcing_term(0.1, Some((1.0, 0.1)), goal, 0.1);
        assert!((eta - 0.009).abs() < 1e-9, "{eta}");
        // Slow convergence keeps it loose.
        assert_eq!(forcing_term(0.9, Some((1.0, 0.1)), goal, 0.1), 0.1);
        // Near the goal CG only needs to reach half of it: at 10× the goal, η = 0.05
        // instead of γ(0.01)² = 9e-5.
        let eta = forcing_term(0.01, Some((1.0, 0.1)), goal, 0.1);
        assert!((eta - 0.05).abs() < 1e-12, "{eta}");
    }
}
