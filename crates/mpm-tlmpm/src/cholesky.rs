//! Sparse Cholesky factorisation with the symbolic analysis done once (faer 0.24).
//!
//! The symbolic analysis (AMD fill-reducing ordering, elimination tree, supernode structure)
//! depends only on the sparsity pattern. TLMPM's pattern comes from the fixed reference
//! connectivity, so [`SparseCholesky::new`] analyses it once and [`SparseCholesky::factorize`]
//! only recomputes the numeric factor, into storage and scratch memory allocated up front. faer
//! runs sequentially here ([`faer::Par::Seq`]) so that the factor, like the rest of the solver,
//! is bitwise identical for any rayon thread count.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltError;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, LltRef, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par, Side};
use mpm_core::Real;
use std::fmt;
use thiserror::Error;

/// Errors of [`SparseCholesky`].
#[derive(Clone, Debug, PartialEq, Error)]
pub enum CholeskyError {
    /// The compressed-column arrays do not describe a lower triangle with sorted rows.
    #[error("invalid sparsity pattern: {0}")]
    InvalidPattern(&'static str),
    /// A value or right-hand-side array has the wrong length.
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

/// A symmetric positive definite sparse matrix's `L Lᵀ` factorisation whose symbolic part is
/// computed once for a fixed pattern and reused for every numeric factorisation.
pub struct SparseCholesky {
    pattern: SymbolicSparseColMat<usize>,
    symbolic: SymbolicCholesky<usize>,
    factor: Vec<Real>,
    factor_stack: MemBuffer,
    solve_stack: MemBuffer,
    factored: bool,
}

impl fmt::Debug for SparseCholesky {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SparseCholesky")
            .field("n", &self.dim())
            .field("nnz", &self.nnz())
            .field("factor_nnz", &self.factor.len())
            .field("factored", &self.factored)
            .finish()
    }
}

impl SparseCholesky {
    /// Analyses the pattern of an `n × n` symmetric matrix given by its lower triangle in
    /// compressed columns: column `c` holds rows `row_idx[col_ptr[c]..col_ptr[c + 1]]`, strictly
    /// ascending and `≥ c`.
    pub fn new(n: usize, col_ptr: Vec<usize>, row_idx: Vec<usize>) -> Result<Self, CholeskyError> {
        validate(n, &col_ptr, &row_idx)?;
        let pattern = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        let symbolic = factorize_symbolic_cholesky(
            pattern.as_ref(),
            Side::Lower,
            SymmetricOrdering::Amd,
            Default::default(),
        )
        .map_err(|e| CholeskyError::Backend(format!("{e:?}")))?;
        let factor_stack = MemBuffer::try_new(
            symbolic.factorize_numeric_llt_scratch::<Real>(Par::Seq, Default::default()),
        )
        .map_err(|e| CholeskyError::Backend(format!("{e:?}")))?;
        let solve_stack = MemBuffer::try_new(symbolic.solve_in_place_scratch::<Real>(1, Par::Seq))
            .map_err(|e| CholeskyError::Backend(format!("{e:?}")))?;
        let factor = vec![0.0; symbolic.len_val()];
        Ok(Self {
            pattern,
            symbolic,
            factor,
            factor_stack,
            solve_stack,
            factored: false,
        })
    }

    /// Matrix dimension.
    pub fn dim(&self) -> usize {
        self.pattern.nrows()
    }

    /// Number of stored entries of the lower triangle.
    pub fn nnz(&self) -> usize {
        self.pattern.row_idx().len()
    }

    /// Number of stored entries of the factor `L`.
    pub fn factor_nnz(&self) -> usize {
        self.factor.len()
    }

    /// Column pointers of the analysed pattern.
    pub fn col_ptr(&self) -> &[usize] {
        self.pattern.col_ptr()
    }

    /// Row indices of the analysed pattern.
    pub fn row_idx(&self) -> &[usize] {
        self.pattern.row_idx()
    }

    /// Numeric factorisation of the matrix with the analysed pattern and the given values
    /// (ordered like `row_idx`), reusing the symbolic analysis and all storage.
    pub fn factorize(&mut self, values: &[Real]) -> Result<(), CholeskyError> {
        self.factored = false;
        if values.len() != self.nnz() {
            return Err(CholeskyError::WrongLength {
                expected: self.nnz(),
                got: values.len(),
            });
        }
        let matrix = SparseColMatRef::new(self.pattern.as_ref(), values);
        self.symbolic
            .factorize_numeric_llt::<Real>(
                &mut self.factor,
                matrix,
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
    pub fn solve_in_place(&mut self, rhs: &mut [Real]) -> Result<(), CholeskyError> {
        if !self.factored {
            return Err(CholeskyError::NotFactorized);
        }
        let n = self.dim();
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

fn validate(n: usize, col_ptr: &[usize], row_idx: &[usize]) -> Result<(), CholeskyError> {
    if col_ptr.len() != n + 1 || col_ptr[0] != 0 || col_ptr[n] != row_idx.len() {
        return Err(CholeskyError::InvalidPattern(
            "col_ptr must have n + 1 entries from 0 to nnz",
        ));
    }
    for c in 0..n {
        if col_ptr[c] > col_ptr[c + 1] {
            return Err(CholeskyError::InvalidPattern("col_ptr must not decrease"));
        }
        let rows = &row_idx[col_ptr[c]..col_ptr[c + 1]];
        if rows.first().is_some_and(|&r| r < c) || rows.last().is_some_and(|&r| r >= n) {
            return Err(CholeskyError::InvalidPattern(
                "rows must lie in the lower triangle",
            ));
        }
        if rows.windows(2).any(|w| w[0] >= w[1]) {
            return Err(CholeskyError::InvalidPattern(
                "rows must be strictly ascending",
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 1D Laplacian plus `shift · I`, lower triangle.
    fn laplacian(n: usize, shift: Real) -> (Vec<usize>, Vec<usize>, Vec<Real>) {
        let (mut cp, mut ri, mut v) = (vec![0], Vec::new(), Vec::new());
        for c in 0..n {
            ri.push(c);
            v.push(2.0 + shift);
            if c + 1 < n {
                ri.push(c + 1);
                v.push(-1.0);
            }
            cp.push(ri.len());
        }
        (cp, ri, v)
    }

    #[test]
    fn refactorisation_reuses_the_analysis() {
        let n = 50;
        let (cp, ri, v) = laplacian(n, 0.1);
        let mut chol = SparseCholesky::new(n, cp.clone(), ri.clone()).unwrap();
        for shift in [0.1, 3.0] {
            let v: Vec<Real> = v
                .iter()
                .map(|&x| if x > 0.0 { 2.0 + shift } else { x })
                .collect();
            chol.factorize(&v).unwrap();
            let b: Vec<Real> = (0..n).map(|i| (i as Real).sin()).collect();
            let mut x = b.clone();
            chol.solve_in_place(&mut x).unwrap();
            let ax = crate::assembly::symmetric_product(&cp, &ri, &v, &x);
            let err = ax
                .iter()
                .zip(&b)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, Real::max);
            assert!(err < 1e-12, "residual {err}");
        }
        // Indefinite values are reported, not panicked on.
        let bad: Vec<Real> = v.iter().map(|&x| if x > 0.0 { -1.0 } else { x }).collect();
        assert!(matches!(
            chol.factorize(&bad),
            Err(CholeskyError::NotPositiveDefinite { .. })
        ));
        assert_eq!(
            chol.solve_in_place(&mut vec![0.0; n]),
            Err(CholeskyError::NotFactorized)
        );
        assert!(matches!(
            SparseCholesky::new(2, vec![0, 1, 2], vec![1, 0]),
            Err(CholeskyError::InvalidPattern(_))
        ));
    }
}
