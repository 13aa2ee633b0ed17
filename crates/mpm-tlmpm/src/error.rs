//! Errors of the TLMPM solvers.

use mpm_core::Real;
use thiserror::Error;

/// Why Newton's method failed on one step.
#[derive(Clone, Debug, PartialEq, Error)]
pub enum NewtonError {
    /// The iteration cap was reached before the residual met the tolerance.
    #[error(
        "Newton did not converge in {iterations} iterations: residual {residual:.3e} N \
         (initial {initial:.3e} N, tolerance {tolerance:.3e} N)"
    )]
    NotConverged {
        /// Iterations performed.
        iterations: u32,
        /// Final residual norm `‖∇E‖₂` (N).
        residual: Real,
        /// Initial residual norm (N).
        initial: Real,
        /// Tolerance that was not met (N).
        tolerance: Real,
    },
    /// The capped backtracking line search found no acceptable step.
    #[error(
        "line search found no decrease at Newton iteration {iteration} after {halvings} \
         halvings (residual {residual:.3e} N)"
    )]
    LineSearchFailed {
        /// Newton iteration (0-based).
        iteration: u32,
        /// Step halvings tried.
        halvings: u32,
        /// Residual norm at the iterate (N).
        residual: Real,
    },
    /// The tangent was not positive definite and SPD projection is disabled (or did not help).
    #[error("tangent is not positive definite at Newton iteration {iteration}")]
    IndefiniteTangent {
        /// Newton iteration (0-based).
        iteration: u32,
    },
    /// The potential is not finite at the initial guess.
    #[error("the incremental potential is not finite at the initial guess")]
    NonFiniteStart,
    /// The linear solver failed for a reason other than definiteness.
    #[error("linear solver failed at Newton iteration {iteration}: {message}")]
    LinearSolver {
        /// Newton iteration (0-based).
        iteration: u32,
        /// What the solver reported.
        message: String,
    },
}

/// Why a step failed: a guard check, or Newton's method after the retries the policy allowed
/// (`StepError::Solve` with stage `solve`).
pub type StepError = mpm_core::StepError<NewtonError>;
