//! Capped preconditioned conjugate gradients on scalar or block unknowns.
//!
//! One implementation, generic over the [`Unknown`] type, the operator ([`LinearOperator`],
//! e.g. a closure or a [`SymmetricMatrix`](crate::SymmetricMatrix)) and the
//! [`Preconditioner`]. Inner products are summed serially in index order and every vector
//! update is element-wise, so the iterates are bitwise identical for any number of rayon
//! threads, provided the operator and the preconditioner are.

use crate::precond::Preconditioner;
use crate::unknown::{dot, par_axpy, par_xpay, Unknown};
use thiserror::Error;

/// A linear operator `x ↦ A x` on slices of unknowns.
///
/// Closures `FnMut(&[T], &mut [T])` are operators (annotate the argument types so that the
/// closure is generic over their lifetimes).
pub trait LinearOperator<T: Unknown> {
    /// Writes `y = A x`; `x` and `y` have the system's number of unknowns.
    fn apply(&mut self, x: &[T], y: &mut [T]);

    /// The number of scalar components it acts on, when it knows it; the solvers compare it
    /// with the right-hand side's. `None` (the default) skips the check.
    fn scalar_dim(&self) -> Option<usize> {
        None
    }
}

impl<T: Unknown, F: FnMut(&[T], &mut [T])> LinearOperator<T> for F {
    fn apply(&mut self, x: &[T], y: &mut [T]) {
        self(x, y)
    }
}

/// Where the iteration starts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum InitialGuess {
    /// `x₀ = 0` (the solution slice is overwritten; no operator application is needed).
    #[default]
    Zero,
    /// The values in the solution slice (one extra operator application for `b − A x₀`).
    Given,
}

/// What reaching the iteration cap means.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum OnIterationCap {
    /// An error, [`CgError::NotConverged`].
    #[default]
    Error,
    /// A result: the iterate is returned with [`CgStop::IterationCap`]. A truncated CG iterate
    /// from `x₀ = 0` is still a descent direction for the quadratic `½ xᵀAx − bᵀx`, which is what
    /// an inexact Newton method needs.
    Accept,
}

/// Parameters of [`conjugate_gradient`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CgParams {
    /// Iteration cap (each iteration applies the operator and the preconditioner once).
    pub max_iterations: u32,
    /// Relative tolerance on the residual: stop when `‖b − A x‖₂ ≤ rel_tol · ‖b‖₂`
    /// (dimensionless, ≥ 0).
    pub rel_tol: f64,
    /// Absolute tolerance on the residual, in the units of `b` (≥ 0): the target is
    /// `max(abs_tol, rel_tol · ‖b‖₂)`.
    pub abs_tol: f64,
    /// Whether [`CgInfo::history`] records the residual norm of every iteration.
    pub keep_history: bool,
    /// Starting point.
    pub initial_guess: InitialGuess,
    /// Error or result at the iteration cap.
    pub on_cap: OnIterationCap,
}

impl Default for CgParams {
    /// 1000 iterations, `rel_tol = 1e-10`, `abs_tol = 0`, no history, `x₀ = 0`, an error at the
    /// cap.
    fn default() -> Self {
        Self {
            max_iterations: 1000,
            rel_tol: 1e-10,
            abs_tol: 0.0,
            keep_history: false,
            initial_guess: InitialGuess::Zero,
            on_cap: OnIterationCap::Error,
        }
    }
}

/// Why [`conjugate_gradient`] returned a solution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CgStop {
    /// The residual norm reached the target.
    Converged,
    /// The iteration cap was reached ([`OnIterationCap::Accept`]).
    IterationCap,
}

/// What one solve did.
#[derive(Clone, Debug, PartialEq)]
pub struct CgInfo {
    /// Why it stopped.
    pub stop: CgStop,
    /// Iterations done (operator applications, not counting the one for a given `x₀`).
    pub iterations: u32,
    /// Norm of the final residual `‖b − A x‖₂` (units of `b`), from the recurrence
    /// `r ← r − α A p`; it equals the true residual up to round-off.
    pub residual: f64,
    /// Norm of the initial residual `‖b − A x₀‖₂` (units of `b`).
    pub initial_residual: f64,
    /// The target `max(abs_tol, rel_tol · ‖b‖₂)` (units of `b`).
    pub target: f64,
    /// With [`CgParams::keep_history`], the residual norms: the initial one, then one per
    /// iteration (the last equals [`Self::residual`]); empty otherwise.
    pub history: Vec<f64>,
}

/// Why [`conjugate_gradient`] failed.
#[derive(Clone, Debug, PartialEq, Error)]
pub enum CgError {
    /// The iteration cap was reached with [`OnIterationCap::Error`].
    #[error(
        "conjugate gradients did not converge in {iterations} iterations: residual {residual:e} \
         above the target {target:e}"
    )]
    NotConverged {
        /// Iterations done (the cap).
        iterations: u32,
        /// Residual norm at the cap (units of `b`).
        residual: f64,
        /// Target residual norm (units of `b`).
        target: f64,
    },
    /// `pᵀ A p ≤ 0` for a search direction `p`: the operator is not positive definite.
    #[error(
        "negative curvature pᵀAp = {curvature:e} at iteration {iteration}: the operator is not \
         positive definite"
    )]
    NegativeCurvature {
        /// Iteration (from 0) whose direction had non-positive curvature.
        iteration: u32,
        /// The curvature `pᵀ A p` (units of `x` times units of `b`).
        curvature: f64,
    },
    /// A NaN or an infinity appeared.
    #[error("non-finite {quantity} at iteration {iteration}")]
    NonFinite {
        /// Iteration (from 0) at which it appeared.
        iteration: u32,
        /// Which quantity: `"initial residual"`, `"curvature pᵀAp"` or `"residual"`.
        quantity: &'static str,
    },
    /// A vector, operator or preconditioner does not have the right-hand side's size.
    #[error("dimension mismatch: {what} has {got} scalar components, expected {expected}")]
    DimensionMismatch {
        /// Which argument.
        what: &'static str,
        /// Required number of scalar components.
        expected: usize,
        /// Given number.
        got: usize,
    },
    /// A tolerance is negative or not finite.
    #[error("invalid parameter {name} = {value}: must be finite and non-negative")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Given value.
        value: f64,
    },
    /// A diagonal entry is not positive, so no Jacobi preconditioner exists (the matrix is not
    /// SPD).
    #[error("diagonal entry {index} is {value:e}: not positive, the matrix is not SPD")]
    NonPositiveDiagonal {
        /// Scalar index of the entry.
        index: usize,
        /// Its value.
        value: f64,
    },
}

/// Scratch vectors of [`conjugate_gradient`]: residual, preconditioned residual, direction and
/// operator product. Keep one per system size and pass it to every solve; after the first solve
/// of a size, solves do not allocate (apart from the residual history when it is asked for).
#[derive(Clone, Debug)]
pub struct CgWorkspace<T> {
    r: Vec<T>,
    z: Vec<T>,
    p: Vec<T>,
    q: Vec<T>,
}

impl<T> Default for CgWorkspace<T> {
    /// An empty workspace (see [`CgWorkspace::new`]).
    fn default() -> Self {
        Self {
            r: Vec::new(),
            z: Vec::new(),
            p: Vec::new(),
            q: Vec::new(),
        }
    }
}

impl<T: Unknown> CgWorkspace<T> {
    /// An empty workspace (it grows on first use).
    pub fn new() -> Self {
        Self::default()
    }

    fn resize(&mut self, n: usize) {
        for v in [&mut self.r, &mut self.z, &mut self.p, &mut self.q] {
            v.clear();
            v.resize(n, T::zero());
        }
    }
}

/// Solves `A x = b` for a symmetric positive definite operator `A` by preconditioned conjugate
/// gradients, stopping when `‖b − A x‖₂ ≤ max(abs_tol, rel_tol ‖b‖₂)` or at the iteration cap.
///
/// `x` is the initial guess with [`InitialGuess::Given`] and is overwritten with the iterate.
/// The loop is the textbook one: `r = b − A x₀`, `z = M⁻¹ r`, `p = z`; per iteration
/// `q = A p`, `α = rᵀz / pᵀq`, `x ← x + α p`, `r ← r − α q`, then the convergence test,
/// `z = M⁻¹ r`, `β = rᵀz_new / rᵀz_old`, `p ← z + β p`.
pub fn conjugate_gradient<T, A, P>(
    a: &mut A,
    preconditioner: &mut P,
    b: &[T],
    x: &mut [T],
    params: &CgParams,
    work: &mut CgWorkspace<T>,
) -> Result<CgInfo, CgError>
where
    T: Unknown,
    A: LinearOperator<T> + ?Sized,
    P: Preconditioner<T> + ?Sized,
{
    let n = b.len();
    check_dims(
        n,
        x.len(),
        a.scalar_dim(),
        preconditioner.scalar_dim(),
        T::LEN,
    )?;
    for (name, value) in [("rel_tol", params.rel_tol), ("abs_tol", params.abs_tol)] {
        if value < 0.0 || !value.is_finite() {
            return Err(CgError::InvalidParameter { name, value });
        }
    }
    work.resize(n);
    let CgWorkspace { r, z, p, q } = work;
    r.copy_from_slice(b);
    let b_norm = dot(b, b).sqrt();
    let initial = match params.initial_guess {
        InitialGuess::Zero => {
            x.iter_mut().for_each(|v| *v = T::zero());
            b_norm
        }
        InitialGuess::Given => {
            a.apply(x, q);
            par_axpy(r, -1.0, q);
            dot(r, r).sqrt()
        }
    };
    if !initial.is_finite() || !b_norm.is_finite() {
        return Err(CgError::NonFinite {
            iteration: 0,
            quantity: "initial residual",
        });
    }
    let target = params.abs_tol.max(params.rel_tol * b_norm);
    let mut info = CgInfo {
        stop: CgStop::Converged,
        iterations: 0,
        residual: initial,
        initial_residual: initial,
        target,
        history: Vec::new(),
    };
    if params.keep_history {
        info.history
            .reserve(params.max_iterations.min(1024) as usize + 1);
        info.history.push(initial);
    }
    if initial <= target {
        return Ok(info);
    }
    preconditioner.apply(r, z);
    p.copy_from_slice(z);
    let mut rz = dot(r, z);
    for it in 0..params.max_iterations {
        a.apply(p, q);
        let pq = dot(p, q);
        if !pq.is_finite() {
            return Err(CgError::NonFinite {
                iteration: it,
                quantity: "curvature pᵀAp",
            });
        }
        if pq <= 0.0 {
            return Err(CgError::NegativeCurvature {
                iteration: it,
                curvature: pq,
            });
        }
        let alpha = rz / pq;
        par_axpy(x, alpha, p);
        par_axpy(r, -alpha, q);
        let residual = dot(r, r).sqrt();
        info.iterations = it + 1;
        info.residual = residual;
        if params.keep_history {
            info.history.push(residual);
        }
        if !residual.is_finite() {
            return Err(CgError::NonFinite {
                iteration: it,
                quantity: "residual",
            });
        }
        if residual <= target {
            return Ok(info);
        }
        preconditioner.apply(r, z);
        let rz_new = dot(r, z);
        let beta = rz_new / rz;
        rz = rz_new;
        par_xpay(p, z, beta);
    }
    match params.on_cap {
        OnIterationCap::Accept => {
            info.stop = CgStop::IterationCap;
            Ok(info)
        }
        OnIterationCap::Error => Err(CgError::NotConverged {
            iterations: info.iterations,
            residual: info.residual,
            target,
        }),
    }
}

fn check_dims(
    n: usize,
    x: usize,
    operator: Option<usize>,
    preconditioner: Option<usize>,
    len: usize,
) -> Result<(), CgError> {
    let expected = n * len;
    let checks = [
        ("the solution x", Some(x * len)),
        ("the operator", operator),
        ("the preconditioner", preconditioner),
    ];
    for (what, got) in checks {
        if let Some(got) = got.filter(|&g| g != expected) {
            return Err(CgError::DimensionMismatch {
                what,
                expected,
                got,
            });
        }
    }
    Ok(())
}
