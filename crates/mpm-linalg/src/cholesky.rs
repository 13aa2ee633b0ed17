//! Sparse Cholesky factorisation with the symbolic analysis done once (faer 0.24).
//!
//! The symbolic analysis (AMD fill-reducing ordering, elimination tree, supernode structure)
//! depends only on the sparsity pattern. When the pattern is fixed, as TLMPM's reference
//! connectivity is, [`SparseCholesky::new`] analyses it once and [`SparseCholesky::factorize`]
//! only recomputes the numeric factor, into storage and scratch memory allocated up front. faer
//! runs sequentially here ([`faer::Par::Seq`]) so that the factor is bitwise identical for any
//! rayon thread count (with `Par::rayon` the 2D Newton benchmark's factorisation also took
//! twice as long on this 2-core machine: its supernodes are too small to share).
//!
//! [`SparseCholesky::factorize_single`] factorises in single precision (f32): the flops of a
//! supernodal factorisation run twice as wide per SIMD instruction and the factor takes half the
//! memory. Its solves return an approximate `A⁻¹ b` (relative error about `κ(A) · 6e-8`), for
//! iterations that correct it (Newton's chord iterations, iterative refinement).

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

/// Precision of the numeric factor held by a [`SparseCholesky`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precision {
    /// f64 factor: solves are accurate to `κ(A)` times the f64 rounding.
    Double,
    /// f32 factor: solves are accurate to about `κ(A) · 6e-8`.
    Single,
}

/// Numeric factor, its scratch memory and (single precision) the converted matrix values and
/// right-hand side.
struct Numeric<T> {
    factor: Vec<T>,
    values: Vec<T>,
    rhs: Vec<T>,
    factor_stack: MemBuffer,
    solve_stack: MemBuffer,
}

impl<T: faer::traits::ComplexField + Copy + Default> Numeric<T> {
    fn new(symbolic: &SymbolicCholesky<usize>) -> Result<Self, CholeskyError> {
        let backend = |e: &dyn fmt::Debug| CholeskyError::Backend(format!("{e:?}"));
        let factor_stack = MemBuffer::try_new(
            symbolic.factorize_numeric_llt_scratch::<T>(Par::Seq, Default::default()),
        )
        .map_err(|e| backend(&e))?;
        let solve_stack = MemBuffer::try_new(symbolic.solve_in_place_scratch::<T>(1, Par::Seq))
            .map_err(|e| backend(&e))?;
        Ok(Self {
            factor: vec![T::default(); symbolic.len_val()],
            values: Vec::new(),
            rhs: Vec::new(),
            factor_stack,
            solve_stack,
        })
    }

    fn solve(&mut self, symbolic: &SymbolicCholesky<usize>, rhs: MatMut<'_, T>) {
        LltRef::new(symbolic, &self.factor).solve_in_place_with_conj(
            Conj::No,
            rhs,
            Par::Seq,
            MemStack::new(&mut self.solve_stack),
        );
    }
}

/// Numeric `L Lᵀ` of `a` into `factor` with the scratch `stack`.
fn llt<T: faer::traits::ComplexField>(
    symbolic: &SymbolicCholesky<usize>,
    factor: &mut [T],
    stack: &mut MemBuffer,
    a: SparseColMatRef<'_, usize, T>,
) -> Result<(), CholeskyError> {
    symbolic
        .factorize_numeric_llt::<T>(
            factor,
            a,
            Side::Lower,
            Default::default(),
            Par::Seq,
            MemStack::new(stack),
            Default::default(),
        )
        .map_err(|e| match e {
            LltError::NonPositivePivot { index } => CholeskyError::NotPositiveDefinite { index },
        })?;
    Ok(())
}

/// The `L Lᵀ` factorisation of a symmetric positive definite sparse matrix whose symbolic part
/// is computed once for a fixed [`SymmetricPattern`] and reused for every numeric factorisation
/// of a [`SymmetricMatrix`] on that pattern (the pattern itself or a clone of it).
pub struct SparseCholesky {
    pattern_id: u64,
    dim: usize,
    nnz: usize,
    symbolic: SymbolicCholesky<usize>,
    double: Numeric<f64>,
    /// Allocated at the first [`Self::factorize_single`].
    single: Option<Numeric<f32>>,
    factored: Option<Precision>,
}

impl fmt::Debug for SparseCholesky {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SparseCholesky")
            .field("n", &self.dim)
            .field("nnz", &self.nnz)
            .field("factor_nnz", &self.double.factor.len())
            .field("factored", &self.factored)
            .finish()
    }
}

impl SparseCholesky {
    /// Analyses `pattern` (fill-reducing ordering and symbolic factorisation) and allocates the
    /// f64 factor and its scratch memory.
    pub fn new(pattern: &SymmetricPattern) -> Result<Self, CholeskyError> {
        let symbolic = factorize_symbolic_cholesky(
            pattern.symbolic(),
            Side::Lower,
            SymmetricOrdering::Amd,
            Default::default(),
        )
        .map_err(|e| CholeskyError::Backend(format!("{e:?}")))?;
        Ok(Self {
            pattern_id: pattern.id(),
            dim: pattern.dim(),
            nnz: pattern.nnz(),
            double: Numeric::new(&symbolic)?,
            single: None,
            symbolic,
            factored: None,
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
        self.double.factor.len()
    }

    /// The precision of the current factorisation, `None` when there is none.
    pub fn factored(&self) -> Option<Precision> {
        self.factored
    }

    /// Numeric factorisation of `matrix` in f64, whose pattern must be the analysed one, reusing
    /// the symbolic analysis and all storage. A failure leaves no factorisation.
    pub fn factorize(&mut self, matrix: &SymmetricMatrix) -> Result<(), CholeskyError> {
        self.factored = None;
        if matrix.pattern().id() != self.pattern_id {
            return Err(CholeskyError::PatternMismatch);
        }
        let a = SparseColMatRef::new(matrix.pattern().symbolic(), matrix.values());
        let d = &mut self.double;
        llt(&self.symbolic, &mut d.factor, &mut d.factor_stack, a)?;
        self.factored = Some(Precision::Double);
        Ok(())
    }

    /// As [`Self::factorize`], in single precision: the values are rounded to f32 and the
    /// factor is f32 (see the module docs). A matrix that is positive definite in f64 can fail
    /// here when it is ill conditioned (`κ ≳ 1e7`).
    pub fn factorize_single(&mut self, matrix: &SymmetricMatrix) -> Result<(), CholeskyError> {
        self.factored = None;
        if matrix.pattern().id() != self.pattern_id {
            return Err(CholeskyError::PatternMismatch);
        }
        let single = match &mut self.single {
            Some(s) => s,
            None => self.single.insert(Numeric::new(&self.symbolic)?),
        };
        let Numeric {
            factor,
            values,
            factor_stack,
            ..
        } = single;
        values.clear();
        values.extend(matrix.values().iter().map(|&v| v as f32));
        let a = SparseColMatRef::new(matrix.pattern().symbolic(), &values[..]);
        llt(&self.symbolic, factor, factor_stack, a)?;
        self.factored = Some(Precision::Single);
        Ok(())
    }

    /// Overwrites `rhs` with the solution `x` of `A x = rhs` using the last factorisation (in
    /// its precision; the right-hand side and solution stay f64).
    pub fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), CholeskyError> {
        let n = self.dim;
        if rhs.len() != n {
            return Err(CholeskyError::WrongLength {
                expected: n,
                got: rhs.len(),
            });
        }
        match (self.factored, &mut self.single) {
            (None, _) | (Some(Precision::Single), None) => {
                return Err(CholeskyError::NotFactorized)
            }
            (Some(Precision::Double), _) => self.double.solve(
                &self.symbolic,
                MatMut::from_column_major_slice_mut(rhs, n, 1),
            ),
            (Some(Precision::Single), Some(single)) => {
                let mut x = std::mem::take(&mut single.rhs);
                x.clear();
                x.extend(rhs.iter().map(|&v| v as f32));
                single.solve(
                    &self.symbolic,
                    MatMut::from_column_major_slice_mut(&mut x, n, 1),
                );
                for (r, v) in rhs.iter_mut().zip(&x) {
                    *r = f64::from(*v);
                }
                single.rhs = x;
            }
        }
        Ok(())
    }
}
