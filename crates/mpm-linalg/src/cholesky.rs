//! Sparse Cholesky factorisation with the symbolic analysis done once (faer 0.24).
//!
//! The symbolic analysis (AMD fill-reducing ordering, elimination tree, supernode structure)
//! depends only on the sparsity pattern. When the pattern is fixed, as TLMPM's reference
//! connectivity is, [`SparseCholesky::new`] analyses it once and [`SparseCholesky::factorize`]
//! only recomputes the numeric factor, into storage and scratch memory allocated up front. faer
//! runs sequentially here ([`faer::Par::Seq`]) so that the factor is bitwise identical for any
//! rayon thread count.

use crate::pattern::{PatternError, SymmetricMatrix, SymmetricPattern};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltError;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, LltRef, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::SparseColMatRef;
use faer::{Conj, MatMut, Par, Side};
use std::fmt;
use thiserror::Error;

/// Errors of [`SparseCholesky`].
#[derive(Clone, Debug, PartialEq, Error)]
pub enum CholeskyError {
    /// The sparsity pattern could not be built.
    #[error("invalid sparsity pattern: {0}")]
    Pattern(#[from] PatternError),
    /// The matrix's pattern is not the one that was analysed.
    #[error("the matrix's sparsity pattern is not the one the factorisation was analysed for")]
    PatternMismatch,
    /// A right-hand side has the wrong length.
    #[error("expected {expected} entries, got {got}")]
    WrongLength {
        /// Required length.
        expected: usize,
        /// Given length.
        got: usize,
    },
    /// The matrix is not numerically positive definite.
    #[error("matrix is not positive definite (non-positive pivot at index {index})")]
    NotPositiveDefinite {
        /// Pivot index in the permuted ordering.
        index: usize,
    },
    /// `solve_in_place` was called before a successful `factorize`.
    #[error("no numeric factorisation available")]
    NotFactorized,
    /// faer reported another failure (e.g. out of memory).
    #[error("sparse Cholesky failed: {0}")]
    Backend(String),
}

/// The `L Lᵀ` factorisation of a symmetric positive definite sparse matrix whose symbolic part
/// is computed once for a fixed [`SymmetricPattern`] and reused for every numeric factorisation
/// of a [`SymmetricMatrix`] on that pattern (the pattern itself or a clone of it).
pub struct SparseCholesky {
    pattern_id: u64,
    dim: usize,
    nnz: usize,
    symbolic: SymbolicCholesky<usize>,
    factor: Vec<f64>,
    factor_stack: MemBuffer,
    solve_stack: MemBuffer,
    factored: bool,
}

impl fmt::Debug for SparseCholesky {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SparseCholesky")
            .field("n", &self.dim)
            .field("nnz", &self.nnz)
            .field("factor_nnz", &self.factor.len())
            .field("factored", &self.factored)
            .finish()
    }
}

impl SparseCholesky {
    /// Analyses `pattern` (fill-reducing ordering and symbolic factorisation) and allocates the
    /// factor and all scratch memory.
    pub fn new(pattern: &SymmetricPattern) -> Result<Self, CholeskyError> {
        let backend = |e: &dyn fmt::Debug| CholeskyError::Backend(format!("{e:?}"));
        let symbolic = factorize_symbolic_cholesky(
            pattern.symbolic(),
            Side::Lower,
            SymmetricOrdering::Amd,
            Default::default(),
        )
        .map_err(|e| backend(&e))?;
        let factor_stack = MemBuffer::try_new(
            symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
        )
        .map_err(|e| backend(&e))?;
        let solve_stack = MemBuffer::try_new(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq))
            .map_err(|e| backend(&e))?;
        let factor = vec![0.0; symbolic.len_val()];
        Ok(Self {
            pattern_id: pattern.id(),
            dim: pattern.dim(),
            nnz: pattern.nnz(),
            symbolic,
            factor,
            factor_stack,
            solve_stack,
            factored: false,
        })
    }

    /// Matrix dimension.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Number of stored entries of the analysed lower triangle.
    pub fn nnz(&self) -> usize {
        self.nnz
    }

    /// Number of stored entries of the factor `L`.
    pub fn factor_nnz(&self) -> usize {
        self.factor.len()
    }

    /// Numeric factorisation of `matrix`, whose pattern must be the analysed one, reusing the
    /// symbolic analysis and all storage. A failure leaves no factorisation.
    pub fn factorize(&mut self, matrix: &SymmetricMatrix) -> Result<(), CholeskyError> {
        self.factored = false;
        if matrix.pattern().id() != self.pattern_id {
            return Err(CholeskyError::PatternMismatch);
        }
        let a = SparseColMatRef::new(matrix.pattern().symbolic(), matrix.values());
        self.symbolic
            .factorize_numeric_llt::<f64>(
                &mut self.factor,
                a,
                Side::Lower,
                Default::default(),
                Par::Seq,
                MemStack::new(&mut self.factor_stack),
                Default::default(),
            )
            .map_err(|e| match e {
                LltError::NonPositivePivot { index } => {
                    CholeskyError::NotPositiveDefinite { index }
                }
            })?;
        self.factored = true;
        Ok(())
    }

    /// Overwrites `rhs` with the solution `x` of `A x = rhs` using the last factorisation.
    pub fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), CholeskyError> {
        if !self.factored {
            return Err(CholeskyError::NotFactorized);
        }
        let n = self.dim;
        if rhs.len() != n {
            return Err(CholeskyError::WrongLength {
                expected: n,
                got: rhs.len(),
            });
        }
        LltRef::new(&self.symbolic, &self.factor).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(rhs, n, 1),
            Par::Seq,
            MemStack::new(&mut self.solve_stack),
        );
        Ok(())
    }
}
