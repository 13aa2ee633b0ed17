//! Symmetric sparsity patterns built once, and matrices refilled into them by slot.
//!
//! A [`SymmetricPattern`] stores the lower triangle of a symmetric `n × n` matrix in compressed
//! columns (equivalently the upper triangle in compressed rows), which is what faer's sparse
//! Cholesky factorisation reads. The unknowns come in blocks of `block_size` scalars (1 for a
//! scalar system, `D` for a node displacement), numbered block by block: scalar `I·B + a` is
//! component `a` of block `I`. The pattern couples whole blocks. Column `I·B + b` holds, rows
//! ascending, the rows `I·B + a` (`a ≥ b`) of the diagonal block followed by all `B` rows of each
//! coupled block `J > I`, blocks ascending. The diagonal is always present.
//!
//! Every stored entry has a fixed *slot* (its index in the value array), so a
//! [`SymmetricMatrix`] is refilled step after step into the same storage: by slot
//! ([`SymmetricPattern::slot`], [`SymmetricMatrix::add`]) or column block by column block in
//! parallel ([`SymmetricMatrix::refill_block_columns`]).

use crate::cg::LinearOperator;
use crate::par::for_each_segment;
use crate::unknown::{scalar, scalar_mut, Unknown};
use faer::sparse::{SymbolicSparseColMat, SymbolicSparseColMatRef};
use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};
use thiserror::Error;

/// Errors of pattern construction and of writes into a pattern.
#[derive(Clone, Debug, PartialEq, Eq, Error)]
pub enum PatternError {
    /// A block size of zero.
    #[error("the block size must be at least 1")]
    ZeroBlockSize,
    /// A block or scalar index beyond the matrix.
    #[error("{what} index {index} out of range (size {len})")]
    OutOfRange {
        /// Which kind of index.
        what: &'static str,
        /// The index.
        index: usize,
        /// The number of blocks or scalars.
        len: usize,
    },
    /// The matrix has more entries than `usize` can count.
    #[error("the pattern is too large to index")]
    TooLarge,
    /// Compressed-column arrays that do not describe a lower triangle with sorted rows and the
    /// diagonal present.
    #[error("invalid compressed-column arrays: {0}")]
    InvalidCsc(&'static str),
    /// A write to an entry the pattern does not hold.
    #[error("entry ({row}, {col}) is not in the pattern")]
    NotInPattern {
        /// Row.
        row: usize,
        /// Column.
        col: usize,
    },
}

/// Source of the identities that tie a factorisation to the pattern it was analysed for.
static NEXT_ID: AtomicU64 = AtomicU64::new(0);

/// The lower-triangular pattern of a symmetric matrix with block structure (see the module
/// docs). It cannot change after construction; clones share its identity.
#[derive(Clone, Debug)]
pub struct SymmetricPattern {
    id: u64,
    block_size: usize,
    /// Offset of each block column's `B` columns in the value array (`num_blocks + 1`).
    block_ptr: Vec<usize>,
    csc: SymbolicSparseColMat<usize>,
}

impl SymmetricPattern {
    /// Builds the pattern of `num_blocks` blocks of `block_size` scalars from each block's
    /// couplings: `neighbours(I, out)` pushes onto the (empty) `out` the blocks `J` that block
    /// `I` couples with, in any order and with repeats. Only `J > I` are kept (the diagonal is
    /// always there), so every coupling must be listed by its lower block at least; a symmetric
    /// adjacency listed from both sides is fine. Fails on a `J ≥ num_blocks`.
    pub fn from_block_rows(
        num_blocks: usize,
        block_size: usize,
        mut neighbours: impl FnMut(usize, &mut Vec<usize>),
    ) -> Result<Self, PatternError> {
        if block_size == 0 {
            return Err(PatternError::ZeroBlockSize);
        }
        let bs = block_size;
        let n = num_blocks.checked_mul(bs).ok_or(PatternError::TooLarge)?;
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        let mut block_ptr = Vec::with_capacity(num_blocks + 1);
        let mut nbrs = Vec::new();
        col_ptr.push(0);
        for i in 0..num_blocks {
            nbrs.clear();
            neighbours(i, &mut nbrs);
            if let Some(&j) = nbrs.iter().find(|&&j| j >= num_blocks) {
                return Err(PatternError::OutOfRange {
                    what: "block",
                    index: j,
                    len: num_blocks,
                });
            }
            nbrs.retain(|&j| j > i);
            nbrs.sort_unstable();
            nbrs.dedup();
            block_ptr.push(row_idx.len());
            for b in 0..bs {
                row_idx.extend((b..bs).map(|a| i * bs + a));
                for &j in &nbrs {
                    row_idx.extend((0..bs).map(|a| j * bs + a));
                }
                col_ptr.push(row_idx.len());
            }
        }
        block_ptr.push(row_idx.len());
        Ok(Self::from_valid_parts(bs, block_ptr, n, col_ptr, row_idx))
    }

    /// Builds the pattern of `num_blocks` blocks of `block_size` scalars coupled by the block
    /// pairs `(I, J)` (either order; repeats and diagonal pairs are allowed). Fails on an index
    /// `≥ num_blocks`.
    pub fn from_block_couplings(
        num_blocks: usize,
        block_size: usize,
        couplings: impl IntoIterator<Item = (usize, usize)>,
    ) -> Result<Self, PatternError> {
        // Bucket each pair by its lower block (counting sort).
        let pairs: Vec<(usize, usize)> = couplings
            .into_iter()
            .map(|(i, j)| (i.min(j), i.max(j)))
            .collect();
        if let Some(&(_, j)) = pairs.iter().find(|&&(_, j)| j >= num_blocks) {
            return Err(PatternError::OutOfRange {
                what: "block",
                index: j,
                len: num_blocks,
            });
        }
        let mut ptr = vec![0usize; num_blocks + 1];
        for &(i, _) in &pairs {
            ptr[i + 1] += 1;
        }
        for i in 0..num_blocks {
            ptr[i + 1] += ptr[i];
        }
        let mut fill = ptr.clone();
        let mut upper = vec![0usize; pairs.len()];
        for &(i, j) in &pairs {
            upper[fill[i]] = j;
            fill[i] += 1;
        }
        Self::from_block_rows(num_blocks, block_size, |i, out| {
            out.extend_from_slice(&upper[ptr[i]..ptr[i + 1]]);
        })
    }

    /// Builds the pattern of an `n × n` scalar matrix (block size 1) coupled by the pairs
    /// `(i, j)` (either order; repeats allowed). Fails on an index `≥ n`.
    pub fn from_couplings(
        n: usize,
        couplings: impl IntoIterator<Item = (usize, usize)>,
    ) -> Result<Self, PatternError> {
        Self::from_block_couplings(n, 1, couplings)
    }

    /// Takes the lower triangle of an `n × n` symmetric matrix in compressed columns (block size
    /// 1): column `c` holds rows `row_idx[col_ptr[c]..col_ptr[c + 1]]`, strictly ascending,
    /// starting with the diagonal `c` and below `n`.
    pub fn from_lower_csc(
        n: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
    ) -> Result<Self, PatternError> {
        if col_ptr.len() != n + 1 || col_ptr[0] != 0 || col_ptr[n] != row_idx.len() {
            return Err(PatternError::InvalidCsc(
                "col_ptr must have n + 1 entries from 0 to nnz",
            ));
        }
        for c in 0..n {
            if col_ptr[c] > col_ptr[c + 1] {
                return Err(PatternError::InvalidCsc("col_ptr must not decrease"));
            }
            let rows = &row_idx[col_ptr[c]..col_ptr[c + 1]];
            if rows.first() != Some(&c) {
                return Err(PatternError::InvalidCsc(
                    "each column must start with its diagonal entry (lower triangle)",
                ));
            }
            if rows.last().is_some_and(|&r| r >= n) {
                return Err(PatternError::InvalidCsc("row index out of range"));
            }
            if rows.windows(2).any(|w| w[0] >= w[1]) {
                return Err(PatternError::InvalidCsc("rows must be strictly ascending"));
            }
        }
        let block_ptr = col_ptr.clone();
        Ok(Self::from_valid_parts(1, block_ptr, n, col_ptr, row_idx))
    }

    fn from_valid_parts(
        block_size: usize,
        block_ptr: Vec<usize>,
        n: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
    ) -> Self {
        Self {
            id: NEXT_ID.fetch_add(1, Ordering::Relaxed),
            block_size,
            block_ptr,
            csc: SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx),
        }
    }

    /// The matrix dimension `n` (scalars).
    pub fn dim(&self) -> usize {
        self.csc.ncols()
    }

    /// Scalars per block.
    pub fn block_size(&self) -> usize {
        self.block_size
    }

    /// Number of blocks, `n / block_size`.
    pub fn num_blocks(&self) -> usize {
        self.block_ptr.len() - 1
    }

    /// Number of stored entries (lower triangle with the diagonal).
    pub fn nnz(&self) -> usize {
        self.csc.row_idx().len()
    }

    /// Column pointers of the lower triangle (`n + 1` entries).
    pub fn col_ptr(&self) -> &[usize] {
        self.csc.col_ptr()
    }

    /// Row indices of the lower triangle, ascending within each column.
    pub fn row_idx(&self) -> &[usize] {
        self.csc.row_idx()
    }

    /// The slot of entry `(row, col)` or, by symmetry, `(col, row)`: its index in the value
    /// array. `None` when the pattern does not hold it. A binary search in one column.
    pub fn slot(&self, row: usize, col: usize) -> Option<usize> {
        let (r, c) = (row.max(col), row.min(col));
        if r >= self.dim() {
            return None;
        }
        let range = self.col_ptr()[c]..self.col_ptr()[c + 1];
        let pos = self.row_idx()[range.clone()].binary_search(&r).ok()?;
        Some(range.start + pos)
    }

    /// The slots of block column `I` (its `B` scalar columns), a contiguous range of the value
    /// array. Panics if `I ≥ num_blocks`.
    pub fn block_column_range(&self, block: usize) -> Range<usize> {
        self.block_ptr[block]..self.block_ptr[block + 1]
    }

    /// The blocks `J ≥ I` coupled to block `I` (the diagonal block first), ascending. Panics if
    /// `I ≥ num_blocks`.
    pub fn block_column_blocks(&self, block: usize) -> impl Iterator<Item = usize> + '_ {
        let rows = self.first_column_rows(block);
        let bs = self.block_size;
        (0..Self::blocks_in_column(rows.len(), bs)).map(move |k| block_row(block, rows, bs, k))
    }

    /// Rows of the first scalar column of block column `I`.
    fn first_column_rows(&self, block: usize) -> &[usize] {
        let c = block * self.block_size;
        &self.row_idx()[self.col_ptr()[c]..self.col_ptr()[c + 1]]
    }

    /// Number of blocks (diagonal included) in a block column whose first column holds `rows`.
    fn blocks_in_column(rows: usize, bs: usize) -> usize {
        (rows - bs) / bs + 1
    }

    /// The faer view of the pattern.
    pub(crate) fn symbolic(&self) -> SymbolicSparseColMatRef<'_, usize> {
        self.csc.as_ref()
    }

    /// Identity shared by clones, distinct between separately built patterns.
    pub(crate) fn id(&self) -> u64 {
        self.id
    }
}

/// Block row of the `k`-th block of a block column whose first scalar column holds `rows`.
#[inline]
fn block_row(block: usize, rows: &[usize], bs: usize, k: usize) -> usize {
    if k == 0 {
        block
    } else {
        rows[bs + (k - 1) * bs] / bs
    }
}

/// Mutable view of one block column's values during [`SymmetricMatrix::refill_block_columns`]:
/// the entries `(J·B + a, I·B + b)` of the blocks `J ≥ I` coupled to block `I`, where `J` is
/// given by its position `k` in the column (0 for the diagonal block, see [`Self::position`]).
#[derive(Debug)]
pub struct BlockColumn<'a> {
    block: usize,
    block_size: usize,
    num_blocks: usize,
    rows: &'a [usize],
    values: &'a mut [f64],
}

impl BlockColumn<'_> {
    /// The block `I` of this column.
    pub fn block(&self) -> usize {
        self.block
    }

    /// Number of blocks in the column, the diagonal block included.
    pub fn num_blocks(&self) -> usize {
        self.num_blocks
    }

    /// The block row `J` at position `k` (panics if `k ≥ num_blocks`).
    pub fn block_row(&self, k: usize) -> usize {
        assert!(k < self.num_blocks, "block position out of range");
        block_row(self.block, self.rows, self.block_size, k)
    }

    /// The position `k` of block row `J` in the column: 0 for `J = I`, `None` when `J < I` or
    /// `J` is not coupled to `I`. A binary search.
    pub fn position(&self, j: usize) -> Option<usize> {
        if j == self.block {
            return Some(0);
        }
        let (mut lo, mut hi) = (1, self.num_blocks);
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            let r = block_row(self.block, self.rows, self.block_size, mid);
            match r.cmp(&j) {
                std::cmp::Ordering::Less => lo = mid + 1,
                std::cmp::Ordering::Greater => hi = mid,
                std::cmp::Ordering::Equal => return Some(mid),
            }
        }
        None
    }

    /// Index in [`Self::values_mut`] of entry `(J·B + a, I·B + b)` with `J` at position `k`.
    /// Panics if `k = 0` and `a < b` (the upper triangle of the diagonal block is not stored)
    /// or if an index is out of range.
    #[inline]
    pub fn slot(&self, k: usize, a: usize, b: usize) -> usize {
        let bs = self.block_size;
        assert!(
            k < self.num_blocks && a < bs && b < bs,
            "entry out of range"
        );
        assert!(k > 0 || a >= b, "upper triangle of the diagonal block");
        let col_off = b * self.num_blocks * bs - b * b.saturating_sub(1) / 2;
        let row = if k == 0 {
            a - b
        } else {
            (bs - b) + (k - 1) * bs + a
        };
        col_off + row
    }

    /// Adds `v` to entry `(J·B + a, I·B + b)`, `J` at position `k` (see [`Self::slot`]).
    #[inline]
    pub fn add(&mut self, k: usize, a: usize, b: usize, v: f64) {
        let s = self.slot(k, a, b);
        self.values[s] += v;
    }

    /// Sets entry `(J·B + a, I·B + b)`, `J` at position `k`, to `v` (see [`Self::slot`]).
    #[inline]
    pub fn set(&mut self, k: usize, a: usize, b: usize, v: f64) {
        let s = self.slot(k, a, b);
        self.values[s] = v;
    }

    /// The column's values in slot order (its `B` scalar columns one after the other).
    pub fn values_mut(&mut self) -> &mut [f64] {
        self.values
    }
}

/// A symmetric matrix: a [`SymmetricPattern`] and one value per stored entry (lower triangle),
/// refilled in place. As a [`LinearOperator`] it computes `y = A x` on scalar or block unknowns.
#[derive(Clone, Debug)]
pub struct SymmetricMatrix {
    pattern: SymmetricPattern,
    values: Vec<f64>,
}

impl SymmetricMatrix {
    /// The zero matrix on `pattern`.
    pub fn new(pattern: SymmetricPattern) -> Self {
        let values = vec![0.0; pattern.nnz()];
        Self { pattern, values }
    }

    /// The pattern.
    pub fn pattern(&self) -> &SymmetricPattern {
        &self.pattern
    }

    /// The values of the lower triangle, in slot order.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// The values of the lower triangle, in slot order, for writing by slot.
    pub fn values_mut(&mut self) -> &mut [f64] {
        &mut self.values
    }

    /// Sets every value to zero (no allocation).
    pub fn set_zero(&mut self) {
        self.values.fill(0.0);
    }

    /// Adds `v` to entry `(row, col)`, and so by symmetry to `(col, row)`: an off-diagonal
    /// coupling is added once, not once per triangle.
    pub fn add(&mut self, row: usize, col: usize, v: f64) -> Result<(), PatternError> {
        let s = self
            .pattern
            .slot(row, col)
            .ok_or(PatternError::NotInPattern { row, col })?;
        self.values[s] += v;
        Ok(())
    }

    /// Entry `(row, col)`; zero when the pattern does not hold it.
    pub fn get(&self, row: usize, col: usize) -> f64 {
        self.pattern.slot(row, col).map_or(0.0, |s| self.values[s])
    }

    /// Diagonal entry `(i, i)` (panics if `i ≥ n`).
    pub fn diagonal(&self, i: usize) -> f64 {
        self.values[self.pattern.col_ptr()[i]]
    }

    /// Refills every block column: each is zeroed and then handed to `fill`, block columns in
    /// parallel over rayon, each by exactly one task. Each value therefore receives the writes
    /// `fill` makes for its column in the order `fill` makes them, whatever the thread count.
    pub fn refill_block_columns<F>(&mut self, fill: F)
    where
        F: Fn(&mut BlockColumn<'_>) + Sync,
    {
        let pattern = &self.pattern;
        let bs = pattern.block_size;
        for_each_segment(&mut self.values, &pattern.block_ptr, &|block, values| {
            values.fill(0.0);
            let rows = pattern.first_column_rows(block);
            let mut column = BlockColumn {
                block,
                block_size: bs,
                num_blocks: SymmetricPattern::blocks_in_column(rows.len(), bs),
                rows,
                values,
            };
            fill(&mut column);
        });
    }

    /// `y = A x` for scalar or block unknowns (`x.len() · T::LEN = n`), summed serially column
    /// by column, so the result does not depend on the thread count. Panics on a size mismatch.
    pub fn mul_vec<T: Unknown>(&self, x: &[T], y: &mut [T]) {
        let n = self.pattern.dim();
        assert!(
            x.len() * T::LEN == n && y.len() == x.len(),
            "matrix–vector product of mismatched sizes"
        );
        y.iter_mut().for_each(|v| *v = T::zero());
        let (col_ptr, row_idx) = (self.pattern.col_ptr(), self.pattern.row_idx());
        for c in 0..n {
            let xc = scalar(x, c);
            let mut yc = 0.0;
            for k in col_ptr[c]..col_ptr[c + 1] {
                let r = row_idx[k];
                let v = self.values[k];
                *scalar_mut(y, r) += v * xc;
                if r != c {
                    yc += v * scalar(x, r);
                }
            }
            *scalar_mut(y, c) += yc;
        }
    }

    /// The dense `n × n` matrix (both triangles), for checks on small systems.
    pub fn to_dense(&self) -> nalgebra::DMatrix<f64> {
        let n = self.pattern.dim();
        let mut m = nalgebra::DMatrix::zeros(n, n);
        let (col_ptr, row_idx) = (self.pattern.col_ptr(), self.pattern.row_idx());
        for c in 0..n {
            for k in col_ptr[c]..col_ptr[c + 1] {
                let r = row_idx[k];
                m[(r, c)] = self.values[k];
                m[(c, r)] = self.values[k];
            }
        }
        m
    }
}

impl<T: Unknown> LinearOperator<T> for SymmetricMatrix {
    fn apply(&mut self, x: &[T], y: &mut [T]) {
        self.mul_vec(x, y);
    }

    fn scalar_dim(&self) -> Option<usize> {
        Some(self.pattern.dim())
    }
}
