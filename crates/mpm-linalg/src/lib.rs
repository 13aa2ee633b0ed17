//! Sparse linear algebra for the MPM solvers, on faer.
//!
//! - [`SymmetricPattern`]: the lower-triangular sparsity pattern of a symmetric matrix with block
//!   structure (scalar unknowns are blocks of one), built once from couplings;
//!   [`SymmetricMatrix`] holds its values, refilled in place by slot or column block by column
//!   block in parallel ([`SymmetricMatrix::refill_block_columns`]).
//! - [`conjugate_gradient`]: capped preconditioned CG in faer's style (parameters in,
//!   `Result<CgInfo, CgError>` out) on scalar (`f64`) or block (`nalgebra::SVector<f64, B>`)
//!   unknowns through the [`Unknown`] trait, with the operator a closure, a matrix or any
//!   [`LinearOperator`], and the preconditioner a [`Preconditioner`] ([`Identity`], [`Jacobi`]).
//!   Scratch memory lives in a reusable [`CgWorkspace`].
//! - [`SparseCholesky`]: sparse `L Lᵀ` with the symbolic factorisation computed once per pattern
//!   and the numeric one per matrix.
//! - [`DofMap`]: grid nodes or cells ↔ compact unknown indices, rebuilt in place.
//!
//! **Determinism.** Inner products are summed serially in index order, vector updates are
//! element-wise, matrix–vector products are serial, parallel refills give each value to one
//! task, and faer runs sequentially: results are bitwise identical for any rayon thread count.
//!
//! Numbers are `f64`. The matrices carry whatever units their caller's equations have; where a
//! quantity's unit follows from others (a residual is in the units of the right-hand side), the
//! documentation says so.

mod cg;
mod cholesky;
mod dof;
mod multigrid;
mod par;
mod pattern;
mod precond;
mod unknown;

pub use cg::{
    conjugate_gradient, CgError, CgInfo, CgParams, CgStop, CgWorkspace, InitialGuess,
    LinearOperator, OnIterationCap,
};
pub use cholesky::{CholeskyError, SparseCholesky};
pub use dof::DofMap;
pub use multigrid::{
    CellLabel, MultigridParams, MultigridPreconditioner, PoissonGrid, PoissonGridError,
    PoissonOperator,
};
pub use pattern::{BlockColumn, PatternError, SymmetricMatrix, SymmetricPattern};
pub use precond::{Identity, Jacobi, Preconditioner};
pub use unknown::{dot, norm, Unknown};

#[cfg(test)]
mod tests;
