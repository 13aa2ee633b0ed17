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
//! - [`Anderson`]: Anderson acceleration of fixed-point iterations on the same unknowns.
//! - [`SparseCholesky`]: sparse `L Lᵀ` with the symbolic factorisation computed once per pattern
//!   and the numeric one per matrix; [`IncompleteCholesky`], the IC(0) preconditioner.
//! - [`DofMap`]: grid nodes or cells ↔ compact unknown indices, rebuilt in place.
//! - [`PoissonGrid`]: a cell-centred pressure Poisson problem on a grid of labelled cells
//!   ([`CellLabel`]: fluid unknowns, air with `p = 0`, solid walls closing faces), with its
//!   matrix-free [`PoissonOperator`], [`PoissonGrid::assemble`] into a [`SymmetricMatrix`], and
//!   the geometric multigrid V-cycle [`MultigridPreconditioner`] (McAdams, Sifakis and Teran
//!   2010), 2D and 3D.
//!
//! **Pressure preconditioner: multigrid is the default.** CG with each preconditioner on the 3D
//! 7-point Dirichlet Poisson problem of `n³` unknowns (diagonal 6, off-diagonal −1, standard
//! normal right-hand side, `x₀ = 0`) to `‖b − A x‖ ≤ 10⁻⁶ ‖b‖`, matrix-free operator, set-up +
//! solve wall time, 2 rayon threads on a shared 2-core machine (load average ≈ 4), one run each
//! (`cargo bench -p mpm-benches --bench pressure`, which prints this table first):
//!
//! | n | identity: s (iterations) | Jacobi: s (iterations) | IC(0): s (iterations) | multigrid: s (iterations) |
//! |---|---|---|---|---|
//! | 32 | 0.024 (97) | 0.037 (97) | 0.038 (32) | 0.023 (8) |
//! | 64 | 0.561 (185) | 0.562 (185) | 0.795 (59) | 0.212 (8) |
//! | 128 | 19.2 (349) | 18.0 (349) | 15.9 (111) | 2.09 (9) |
//!
//! Jacobi equals identity in iterations here because the diagonal is constant; it differs on
//! labelled grids (solid faces lower the diagonal). The multigrid iteration count stays flat with
//! `n`, so its advantage grows with the grid: use [`MultigridPreconditioner`] for cell-centred
//! pressure systems. [`IncompleteCholesky`] (IC(0), serial triangular solves) cuts the iterations
//! by about 3× but not the time.
//!
//! **Determinism.** Inner products are summed serially in index order, vector updates are
//! element-wise, matrix–vector products are serial, parallel refills give each value to one
//! task, and faer runs sequentially: results are bitwise identical for any rayon thread count.
//!
//! Numbers are `f64`. The matrices carry whatever units their caller's equations have; where a
//! quantity's unit follows from others (a residual is in the units of the right-hand side), the
//! documentation says so.

mod anderson;
mod cg;
mod cholesky;
mod dof;
mod multigrid;
mod par;
mod pattern;
mod precond;
mod unknown;

pub use anderson::Anderson;
pub use cg::{
    conjugate_gradient, CgError, CgInfo, CgParams, CgStop, CgWorkspace, InitialGuess,
    LinearOperator, OnIterationCap,
};
pub use cholesky::{CholeskyError, Precision, SparseCholesky};
pub use dof::DofMap;
pub use multigrid::{
    CellLabel, MultigridParams, MultigridPreconditioner, PoissonGrid, PoissonGridError,
    PoissonOperator,
};
pub use pattern::{BlockColumn, PatternError, SymmetricMatrix, SymmetricPattern};
pub use precond::{Identity, IncompleteCholesky, Jacobi, Preconditioner};
pub use unknown::{dot, norm, Unknown};

#[cfg(test)]
mod tests;
