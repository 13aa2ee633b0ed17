//! Preconditioners for the conjugate-gradient solver.

use crate::cg::CgError;
use crate::pattern::SymmetricMatrix;
use crate::unknown::{par_mul_elementwise, scalar_mut, Unknown};

/// A symmetric positive definite approximation `M` of the operator, applied as `z = M⁻¹ r`.
///
/// It takes `&mut self` so that an implementation may keep scratch memory (an incomplete
/// factorisation's triangular solves, a multigrid hierarchy's level vectors) and reuse it from
/// one application to the next.
pub trait Preconditioner<T: Unknown> {
    /// Writes `z = M⁻¹ r`; `r` and `z` have the system's number of unknowns.
    fn apply(&mut self, r: &[T], z: &mut [T]);

    /// The number of scalar components it acts on, when it knows it; the solvers compare it
    /// with the right-hand side's. `None` (the default) skips the check.
    fn scalar_dim(&self) -> Option<usize> {
        None
    }
}

/// No preconditioning, `M = I`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Identity;

impl<T: Unknown> Preconditioner<T> for Identity {
    fn apply(&mut self, r: &[T], z: &mut [T]) {
        z.copy_from_slice(r);
    }
}

/// Jacobi (diagonal) preconditioning, `M = diag(A)`: `z = d ⊙ r` with the stored inverse
/// diagonal `d`, one entry per unknown (a block unknown holds the inverse diagonal of each of its
/// components, so this is point Jacobi, not block Jacobi). The vector is kept between solves, so
/// refilling it does not allocate.
#[derive(Clone, Debug, PartialEq)]
pub struct Jacobi<T> {
    inv_diag: Vec<T>,
}

impl<T> Default for Jacobi<T> {
    /// An empty preconditioner (see [`Jacobi::new`]).
    fn default() -> Self {
        Self {
            inv_diag: Vec::new(),
        }
    }
}

impl<T: Unknown> Jacobi<T> {
    /// An empty preconditioner: fill it with [`Self::inverse_diagonal_mut`] or
    /// [`Self::set_from_matrix`] before use.
    pub fn new() -> Self {
        Self::default()
    }

    /// The preconditioner with inverse diagonal `inv_diag` (in the inverse units of `A`'s
    /// diagonal). A zero entry excludes that component from the preconditioned residual, which
    /// suits components fixed to zero.
    pub fn from_inverse_diagonal(inv_diag: Vec<T>) -> Self {
        Self { inv_diag }
    }

    /// The inverse diagonal.
    pub fn inverse_diagonal(&self) -> &[T] {
        &self.inv_diag
    }

    /// The inverse diagonal, to be resized and refilled by the caller.
    pub fn inverse_diagonal_mut(&mut self) -> &mut Vec<T> {
        &mut self.inv_diag
    }

    /// Sets the inverse diagonal from an assembled matrix, `d_s = 1 / A_ss`, reusing the
    /// storage. Fails with [`CgError::NonPositiveDiagonal`] when a diagonal entry is not
    /// positive (the matrix is then not SPD) and with [`CgError::DimensionMismatch`] when the
    /// matrix's dimension is not a whole number of unknowns.
    pub fn set_from_matrix(&mut self, matrix: &SymmetricMatrix) -> Result<(), CgError> {
        let n = matrix.pattern().dim();
        if n % T::LEN != 0 {
            return Err(CgError::DimensionMismatch {
                what: "matrix dimension (not a multiple of the block size)",
                expected: n.div_ceil(T::LEN) * T::LEN,
                got: n,
            });
        }
        self.inv_diag.clear();
        self.inv_diag.resize(n / T::LEN, T::zero());
        for s in 0..n {
            let a = matrix.diagonal(s);
            if a <= 0.0 || !a.is_finite() {
                return Err(CgError::NonPositiveDiagonal { index: s, value: a });
            }
            *scalar_mut(&mut self.inv_diag, s) = 1.0 / a;
        }
        Ok(())
    }
}

impl<T: Unknown> Preconditioner<T> for Jacobi<T> {
    fn apply(&mut self, r: &[T], z: &mut [T]) {
        par_mul_elementwise(z, r, &self.inv_diag);
    }

    fn scalar_dim(&self) -> Option<usize> {
        Some(self.inv_diag.len() * T::LEN)
    }
}

/// Incomplete Cholesky with no fill, IC(0): `M = L Lᵀ` with `L` restricted to the lower
/// pattern of the matrix. Built from a [`SymmetricMatrix`] (scalar entries, whatever the block
/// size); applied by a forward and a backward triangular solve, serially, so it is
/// deterministic but does not use more than one thread.
#[derive(Clone, Debug)]
pub struct IncompleteCholesky {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// `L` in the matrix's lower CSC layout (diagonal first in each column).
    values: Vec<f64>,
}

impl IncompleteCholesky {
    /// Factorises `matrix`. Fails with [`CgError::NonPositiveDiagonal`] when a pivot is not
    /// positive (IC(0) exists for M-matrices such as the Poisson ones, not for every SPD
    /// matrix).
    pub fn new(matrix: &SymmetricMatrix) -> Result<Self, CgError> {
        let pattern = matrix.pattern();
        let col_ptr = pattern.col_ptr().to_vec();
        let row_idx = pattern.row_idx().to_vec();
        let mut values = matrix.values().to_vec();
        for j in 0..pattern.dim() {
            let (start, end) = (col_ptr[j], col_ptr[j + 1]);
            let d = values[start];
            if d <= 0.0 || !d.is_finite() {
                return Err(CgError::NonPositiveDiagonal { index: j, value: d });
            }
            let ljj = d.sqrt();
            values[start] = ljj;
            for p in start + 1..end {
                values[p] /= ljj;
            }
            // Right-looking update of the later columns, kept inside the pattern.
            for q in start + 1..end {
                let (k, lkj) = (row_idx[q], values[q]);
                for p in q..end {
                    if let Some(s) = pattern.slot(row_idx[p], k) {
                        values[s] -= values[p] * lkj;
                    }
                }
            }
        }
        Ok(Self {
            col_ptr,
            row_idx,
            values,
        })
    }

    /// The number of unknowns.
    pub fn dim(&self) -> usize {
        self.col_ptr.len() - 1
    }
}

impl Preconditioner<f64> for IncompleteCholesky {
    fn apply(&mut self, r: &[f64], z: &mut [f64]) {
        z.copy_from_slice(r);
        let (cp, ri, v) = (&self.col_ptr, &self.row_idx, &self.values);
        for j in 0..self.dim() {
            z[j] /= v[cp[j]];
            let zj = z[j];
            for p in cp[j] + 1..cp[j + 1] {
                z[ri[p]] -= v[p] * zj;
            }
        }
        for j in (0..self.dim()).rev() {
            let mut s = z[j];
            for p in cp[j] + 1..cp[j + 1] {
                s -= v[p] * z[ri[p]];
            }
            z[j] = s / v[cp[j]];
        }
    }

    fn scalar_dim(&self) -> Option<usize> {
        Some(self.dim())
    }
}
