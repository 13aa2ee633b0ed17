//! Cell-centred pressure Poisson problems on a labelled grid, their matrix-free operator and a
//! geometric multigrid V-cycle preconditioner for conjugate gradients.
//!
//! The approach follows McAdams, Sifakis and Teran (2010): the unknowns are the fluid cells of a
//! regular grid, air cells fix the pressure to zero (Dirichlet), solid cells close the faces they
//! share with fluid (homogeneous Neumann), and one multigrid V-cycle on the labelled grid is the
//! preconditioner of CG. Coarse labels come from the children (air wins over fluid, fluid over
//! solid), the coarse operators are the same stencil re-discretised at twice the spacing,
//! prolongation is multilinear between cell centres and restriction is its transpose divided by
//! `2^D`. The smoother is damped Jacobi, the same number of sweeps before and after the coarse
//! correction, and the coarsest level gets a fixed number of sweeps; every piece is symmetric,
//! so the V-cycle is a symmetric positive definite preconditioner and CG stays valid.
//!
//! **Determinism.** Every parallel loop (rayon, over slabs of the outermost axis or over
//! unknowns) writes disjoint values, each computed by one task in a fixed order: results are
//! bitwise identical for any thread count.

mod transfer;

use crate::cg::LinearOperator;
use crate::dof::DofMap;
use crate::pattern::{PatternError, SymmetricMatrix, SymmetricPattern};
use crate::precond::Preconditioner;
use rayon::prelude::*;
use thiserror::Error;
use transfer::{prolong_add, prolongation_table, restrict};

/// What a cell of a [`PoissonGrid`] holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CellLabel {
    /// A fluid cell: one pressure unknown.
    Fluid,
    /// An air (empty) cell: pressure fixed to zero (Dirichlet).
    Air,
    /// A solid or wall cell: no flow through the faces it shares with fluid (Neumann).
    Solid,
}

/// Why a [`PoissonGrid`] could not be built.
#[derive(Clone, Debug, PartialEq, Error)]
pub enum PoissonGridError {
    /// The number of labels is not the product of the dimensions.
    #[error("{got} cell labels for a grid of {expected} cells")]
    LabelCount {
        /// Number of cells.
        expected: usize,
        /// Number of labels given.
        got: usize,
    },
    /// A dimension is zero.
    #[error("every grid dimension must be at least 1")]
    EmptyDimension,
    /// The exterior was labelled [`CellLabel::Fluid`]; it must be air or solid.
    #[error("the exterior of the grid must be air or solid, not fluid")]
    FluidExterior,
    /// The coefficient is not finite and positive.
    #[error("invalid coefficient {0}: must be finite and positive")]
    InvalidCoefficient(f64),
}

/// A regular grid of `dims[0] × … × dims[D−1]` cells with a [`CellLabel`] each, the label of
/// everything outside it, and a uniform coefficient `c`: the problem `A p = b` on the fluid
/// cells with
///
/// `(A p)_i = c · Σ_{j face neighbour of i, j not solid} (p_i − p_j)`, `p_j = 0` on air,
///
/// the 5-point (2D) or 7-point (3D) Laplacian. With `c = Δt / (ρ Δx²)` (s m³ kg⁻¹ m⁻²) and `p`
/// in Pa, `A p` is a velocity divergence in s⁻¹; any consistent choice of units works. Cells are
/// numbered with axis 0 fastest, `i = x₀ + dims₀ (x₁ + dims₁ x₂)`; the unknowns are the fluid
/// cells in cell order ([`Self::unknowns`]).
///
/// `A` is symmetric positive semi-definite; it is definite when every connected fluid region
/// touches air (or the exterior is air where it touches the grid boundary).
#[derive(Clone, Debug, PartialEq)]
pub struct PoissonGrid<const D: usize> {
    dims: [usize; D],
    labels: Vec<CellLabel>,
    exterior: CellLabel,
    coefficient: f64,
    unknowns: DofMap,
}

impl<const D: usize> PoissonGrid<D> {
    /// The grid with the given cell labels (cell order as in the type's documentation), the
    /// label `exterior` (air or solid) for everything outside it, and coefficient 1.
    pub fn new(
        dims: [usize; D],
        labels: Vec<CellLabel>,
        exterior: CellLabel,
    ) -> Result<Self, PoissonGridError> {
        if dims.contains(&0) {
            return Err(PoissonGridError::EmptyDimension);
        }
        let expected = dims.iter().product();
        if labels.len() != expected {
            return Err(PoissonGridError::LabelCount {
                expected,
                got: labels.len(),
            });
        }
        if exterior == CellLabel::Fluid {
            return Err(PoissonGridError::FluidExterior);
        }
        let unknowns = DofMap::from_predicate(expected, |c| labels[c] == CellLabel::Fluid);
        Ok(Self {
            dims,
            labels,
            exterior,
            coefficient: 1.0,
            unknowns,
        })
    }

    /// All cells fluid, air outside, coefficient 1: the Dirichlet Poisson problem with
    /// diagonal `2D` and off-diagonal −1.
    pub fn dirichlet_box(dims: [usize; D]) -> Result<Self, PoissonGridError> {
        let n = dims.iter().product();
        Self::new(dims, vec![CellLabel::Fluid; n], CellLabel::Air)
    }

    /// The same grid with coefficient `c` (finite, positive; units as in the type's
    /// documentation).
    pub fn with_coefficient(mut self, c: f64) -> Result<Self, PoissonGridError> {
        if !(c.is_finite() && c > 0.0) {
            return Err(PoissonGridError::InvalidCoefficient(c));
        }
        self.coefficient = c;
        Ok(self)
    }

    /// Cells per axis.
    pub fn dims(&self) -> [usize; D] {
        self.dims
    }

    /// The label of every cell, in cell order.
    pub fn labels(&self) -> &[CellLabel] {
        &self.labels
    }

    /// The label of everything outside the grid (air or solid).
    pub fn exterior(&self) -> CellLabel {
        self.exterior
    }

    /// The coefficient `c` (units as in the type's documentation).
    pub fn coefficient(&self) -> f64 {
        self.coefficient
    }

    /// The linear index of the cell with coordinates `x` (each below its dimension).
    pub fn cell_index(&self, x: [usize; D]) -> usize {
        (0..D).rev().fold(0, |acc, a| acc * self.dims[a] + x[a])
    }

    /// Fluid cells ↔ unknowns, in cell order.
    pub fn unknowns(&self) -> &DofMap {
        &self.unknowns
    }

    /// The number of unknowns (fluid cells).
    pub fn num_unknowns(&self) -> usize {
        self.unknowns.len()
    }

    /// Assembles `A` as a [`SymmetricMatrix`] over the unknowns (for direct solves of small
    /// systems and for checks of the matrix-free operator).
    pub fn assemble(&self) -> Result<SymmetricMatrix, PatternError> {
        let n = self.num_unknowns();
        let mut couplings = Vec::with_capacity(n * D);
        let mut diagonal = vec![0.0; n];
        for (k, &cell) in self.unknowns.nodes().iter().enumerate() {
            let x = coords(cell, &self.dims);
            let mut stride = 1;
            for a in 0..D {
                for up in [false, true] {
                    let label = match neighbour(&x, a, up, &self.dims) {
                        Some(_) => {
                            let j = if up { cell + stride } else { cell - stride };
                            if let (true, Some(m)) = (up, self.unknowns.unknown(j)) {
                                couplings.push((k, m));
                            }
                            self.labels[j]
                        }
                        None => self.exterior,
                    };
                    if label != CellLabel::Solid {
                        diagonal[k] += self.coefficient;
                    }
                }
                stride *= self.dims[a];
            }
        }
        let pattern = SymmetricPattern::from_couplings(
            n,
            couplings.iter().copied().chain((0..n).map(|k| (k, k))),
        )?;
        let mut matrix = SymmetricMatrix::new(pattern);
        for (k, &d) in diagonal.iter().enumerate() {
            matrix.add(k, k, d)?;
        }
        for &(k, m) in &couplings {
            matrix.add(k, m, -self.coefficient)?;
        }
        Ok(matrix)
    }
}

/// Coordinates of cell `c` (axis 0 fastest).
fn coords<const D: usize>(mut c: usize, dims: &[usize; D]) -> [usize; D] {
    std::array::from_fn(|a| {
        let x = c % dims[a];
        c /= dims[a];
        x
    })
}

/// The coordinate along axis `a` of the neighbour of `x` (up or down), if inside the grid.
fn neighbour<const D: usize>(
    x: &[usize; D],
    a: usize,
    up: bool,
    dims: &[usize; D],
) -> Option<isize> {
    let y = x[a] as isize + if up { 1 } else { -1 };
    (y >= 0 && (y as usize) < dims[a]).then_some(y)
}

/// A grid stored with a layer of ghost cells (zero) around it, one more above on odd axes so
/// that the children of every coarse cell exist: the layout the stencil loops work on.
#[derive(Clone, Debug)]
struct Padded<const D: usize> {
    /// Interior cells per axis.
    dims: [usize; D],
    /// Stored cells per axis.
    pdims: [usize; D],
    /// Strides of the stored layout (axis 0 fastest).
    strides: [usize; D],
    /// Stored cells in all.
    len: usize,
}

impl<const D: usize> Padded<D> {
    fn new(dims: [usize; D]) -> Self {
        let pdims: [usize; D] = std::array::from_fn(|a| dims[a] + 2 + (dims[a] & 1));
        let mut strides = [1; D];
        for a in 1..D {
            strides[a] = strides[a - 1] * pdims[a - 1];
        }
        Self {
            dims,
            pdims,
            strides,
            len: strides[D - 1] * pdims[D - 1],
        }
    }

    /// Stored index of interior cell `x`.
    fn index(&self, x: &[usize; D]) -> usize {
        (0..D).map(|a| (x[a] + 1) * self.strides[a]).sum()
    }

    /// Length of one slab (stored cells with one outermost coordinate).
    fn slab(&self) -> usize {
        self.strides[D - 1]
    }

    /// Calls `f(offset)` with the slab-relative stored index of the first interior cell of each
    /// interior line (axis 0) of a slab, in order.
    fn for_each_line(&self, mut f: impl FnMut(usize)) {
        let lines: usize = self.dims[1..D - 1].iter().product();
        for l in 0..lines {
            let mut rest = l;
            let mut offset = 1;
            for a in 1..D - 1 {
                offset += (rest % self.dims[a] + 1) * self.strides[a];
                rest /= self.dims[a];
            }
            f(offset);
        }
    }

    /// Calls `f(c0, line)` for every interior line (axis 0) of the stored grid `out`, in
    /// parallel over slabs: `c0` is the stored index of the line's first interior cell and
    /// `line` its `dims[0]` interior values. Ghost cells of `out` are not touched.
    fn par_for_each_line(&self, out: &mut [f64], f: impl Fn(usize, &mut [f64]) + Sync) {
        let slab = self.slab();
        let last = self.dims[D - 1];
        let n = self.dims[0];
        out.par_chunks_mut(slab).enumerate().for_each(|(s, out)| {
            if s == 0 || s > last {
                return;
            }
            let base = s * slab;
            self.for_each_line(|off| f(base + off, &mut out[off..off + n]));
        });
    }
}

/// The fluid cells' stored indices and, per slab, the range of unknowns in it.
#[derive(Clone, Debug)]
struct CellMap {
    cells: Vec<usize>,
    slab_start: Vec<usize>,
}

impl CellMap {
    fn new<const D: usize>(grid: &PoissonGrid<D>, padded: &Padded<D>) -> Self {
        let cells: Vec<usize> = grid
            .unknowns
            .nodes()
            .iter()
            .map(|&c| padded.index(&coords(c, &grid.dims)))
            .collect();
        let slab = padded.slab();
        let slabs = padded.pdims[D - 1];
        let slab_start = (0..=slabs)
            .map(|s| cells.partition_point(|&p| p < s * slab))
            .collect();
        Self { cells, slab_start }
    }

    /// Writes the unknowns `x` into their cells of the stored grid `out` (other cells are left).
    fn scatter(&self, x: &[f64], out: &mut [f64], slab: usize) {
        out.par_chunks_mut(slab).enumerate().for_each(|(s, chunk)| {
            let base = s * slab;
            for k in self.slab_start[s]..self.slab_start[s + 1] {
                chunk[self.cells[k] - base] = x[k];
            }
        });
    }

    /// Reads the unknowns `z` from their cells of the stored grid `from`.
    fn gather(&self, from: &[f64], z: &mut [f64]) {
        z.par_iter_mut()
            .zip(self.cells.par_iter())
            .with_min_len(4096)
            .for_each(|(z, &p)| *z = from[p]);
    }
}

/// Per stored cell: `diag = c · (non-solid neighbours)` on fluid cells, and `1 / diag` where
/// that is positive (zero elsewhere, which also marks the cells the smoother leaves at zero).
fn diagonals<const D: usize>(grid: &PoissonGrid<D>, padded: &Padded<D>) -> (Vec<f64>, Vec<f64>) {
    let mut diag = vec![0.0; padded.len];
    let mut inv = vec![0.0; padded.len];
    for &cell in grid.unknowns.nodes() {
        let x = coords(cell, &grid.dims);
        let mut count = 0usize;
        let mut stride = 1;
        for a in 0..D {
            for up in [false, true] {
                let label = match neighbour(&x, a, up, &grid.dims) {
                    Some(_) => grid.labels[if up { cell + stride } else { cell - stride }],
                    None => grid.exterior,
                };
                count += usize::from(label != CellLabel::Solid);
            }
            stride *= grid.dims[a];
        }
        let p = padded.index(&x);
        diag[p] = grid.coefficient * count as f64;
        if count > 0 {
            inv[p] = 1.0 / diag[p];
        }
    }
    (diag, inv)
}

/// Writes into `out` (one line of `n` cells) the sum of the `2D` face neighbours of the cells
/// starting at stored index `c0` of `x`, in a fixed order.
#[inline]
fn neighbour_sum<const D: usize>(
    x: &[f64],
    c0: usize,
    n: usize,
    strides: &[usize; D],
    out: &mut [f64],
) {
    out.copy_from_slice(&x[c0 - 1..c0 - 1 + n]);
    for (o, v) in out.iter_mut().zip(&x[c0 + 1..c0 + 1 + n]) {
        *o += v;
    }
    for &s in &strides[1..] {
        for (o, (p, m)) in out
            .iter_mut()
            .zip(x[c0 + s..c0 + s + n].iter().zip(&x[c0 - s..c0 - s + n]))
        {
            *o += p + m;
        }
    }
}

/// The matrix-free operator `A` of a [`PoissonGrid`] on its unknowns (see the grid's
/// documentation), `y = A x` with `x`, `y` one value per fluid cell in cell order.
#[derive(Clone, Debug)]
pub struct PoissonOperator<const D: usize> {
    padded: Padded<D>,
    map: CellMap,
    diag: Vec<f64>,
    coefficient: f64,
    x: Vec<f64>,
}

impl<const D: usize> PoissonOperator<D> {
    /// The operator of `grid`.
    pub fn new(grid: &PoissonGrid<D>) -> Self {
        let padded = Padded::new(grid.dims);
        let map = CellMap::new(grid, &padded);
        let (diag, _) = diagonals(grid, &padded);
        let x = vec![0.0; padded.len];
        Self {
            padded,
            map,
            diag,
            coefficient: grid.coefficient,
            x,
        }
    }

    /// The number of unknowns.
    pub fn dim(&self) -> usize {
        self.map.cells.len()
    }
}

impl<const D: usize> LinearOperator<f64> for PoissonOperator<D> {
    fn apply(&mut self, x: &[f64], y: &mut [f64]) {
        self.map.scatter(x, &mut self.x, self.padded.slab());
        let (xp, diag, cells) = (&self.x, &self.diag, &self.map.cells);
        let (strides, c) = (&self.padded.strides, self.coefficient);
        y.par_iter_mut()
            .zip(cells.par_iter())
            .with_min_len(4096)
            .for_each(|(y, &p)| {
                let mut sum = xp[p - 1] + xp[p + 1];
                for &s in &strides[1..] {
                    sum += xp[p + s] + xp[p - s];
                }
                *y = diag[p] * xp[p] - c * sum;
            });
    }

    fn scalar_dim(&self) -> Option<usize> {
        Some(self.dim())
    }
}

/// Parameters of [`MultigridPreconditioner`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MultigridParams {
    /// Damped-Jacobi sweeps before and (as many) after the coarse correction, per level (≥ 1).
    pub smoothing_sweeps: u32,
    /// Damped-Jacobi sweeps on the coarsest level (≥ 1).
    pub coarsest_sweeps: u32,
    /// Coarsening stops once every axis has at most this many cells (≥ 2).
    pub coarsest_cells_per_axis: usize,
    /// Jacobi damping ω (dimensionless, in (0, 1)); `None` picks `2D / (2D + 1)`, the best
    /// smoothing factor for the Laplacian.
    pub damping: Option<f64>,
}

impl Default for MultigridParams {
    /// 2 sweeps before and after, 30 on the coarsest level, coarsening down to 4 cells per
    /// axis, ω = `2D / (2D + 1)`.
    fn default() -> Self {
        Self {
            smoothing_sweeps: 2,
            coarsest_sweeps: 30,
            coarsest_cells_per_axis: 4,
            damping: None,
        }
    }
}

/// One level of the hierarchy.
#[derive(Clone, Debug)]
struct Level<const D: usize> {
    padded: Padded<D>,
    coefficient: f64,
    diag: Vec<f64>,
    inv: Vec<f64>,
    /// Right-hand side, iterate, residual / scratch (stored layout).
    b: Vec<f64>,
    x: Vec<f64>,
    t: Vec<f64>,
}

impl<const D: usize> Level<D> {
    fn new(grid: &PoissonGrid<D>) -> Self {
        let padded = Padded::new(grid.dims);
        let (diag, inv) = diagonals(grid, &padded);
        let len = padded.len;
        Self {
            padded,
            coefficient: grid.coefficient,
            diag,
            inv,
            b: vec![0.0; len],
            x: vec![0.0; len],
            t: vec![0.0; len],
        }
    }

    /// `x = ω D⁻¹ b` (one sweep from zero).
    fn first_sweep(&mut self, omega: f64) {
        let (b, inv) = (&self.b, &self.inv);
        self.x
            .par_iter_mut()
            .zip(b.par_iter().zip(inv.par_iter()))
            .with_min_len(4096)
            .for_each(|(x, (b, d))| *x = omega * d * b);
    }

    /// Writes `out[i] = f(i, Σ_{face neighbours j} x_j)` on every interior cell `i` (stored
    /// indices), slab by slab in parallel; ghost cells of `out` are left as they are.
    fn stencil_pass(
        padded: &Padded<D>,
        x: &[f64],
        out: &mut [f64],
        f: impl Fn(usize, f64) -> f64 + Sync,
    ) {
        padded.par_for_each_line(out, |c0, line| {
            neighbour_sum(x, c0, line.len(), &padded.strides, line);
            for (k, o) in line.iter_mut().enumerate() {
                *o = f(c0 + k, *o);
            }
        });
    }

    /// One damped-Jacobi sweep, `x ← x + ω D⁻¹ (b − A x)`.
    fn sweep(&mut self, omega: f64) {
        let (x, b, diag, inv, c) = (&self.x, &self.b, &self.diag, &self.inv, self.coefficient);
        Self::stencil_pass(&self.padded, x, &mut self.t, |i, sum| {
            x[i] + omega * inv[i] * (b[i] - diag[i] * x[i] + c * sum)
        });
        std::mem::swap(&mut self.x, &mut self.t);
    }

    /// `t = b − A x` on active cells (`inv > 0`), zero elsewhere.
    fn residual(&mut self) {
        let (x, b, diag, inv, c) = (&self.x, &self.b, &self.diag, &self.inv, self.coefficient);
        Self::stencil_pass(&self.padded, x, &mut self.t, |i, sum| {
            if inv[i] > 0.0 {
                b[i] - diag[i] * x[i] + c * sum
            } else {
                0.0
            }
        });
    }
}

/// Geometric multigrid V-cycle on the labelled grid of a [`PoissonGrid`], as a
/// [`Preconditioner<f64>`] of its operator (one value per fluid cell in cell order): one cycle
/// from a zero guess per application. Coarse labels: air over fluid over solid; coarse operators:
/// the stencil re-discretised at twice the spacing (coefficient / 4); prolongation multilinear
/// between cell centres, restriction its transpose over `2^D`; damped-Jacobi smoothing, the same
/// sweeps before and after; a fixed number of sweeps on the coarsest level.
/// Symmetric positive definite on the unknowns with at least one non-solid neighbour, so it
/// keeps CG valid. The hierarchy and every level vector are built once; applying it allocates
/// nothing.
#[derive(Clone, Debug)]
pub struct MultigridPreconditioner<const D: usize> {
    levels: Vec<Level<D>>,
    tables: Vec<[Vec<(usize, usize)>; D]>,
    map: CellMap,
    params: MultigridParams,
    omega: f64,
}

impl<const D: usize> MultigridPreconditioner<D> {
    /// The preconditioner of `grid` with the default [`MultigridParams`].
    pub fn new(grid: &PoissonGrid<D>) -> Self {
        Self::with_params(grid, MultigridParams::default())
    }

    /// The preconditioner of `grid` with `params` (out-of-range sweep and size values are
    /// clamped into their documented ranges; a damping outside (0, 1) falls back to the
    /// default).
    pub fn with_params(grid: &PoissonGrid<D>, params: MultigridParams) -> Self {
        let params = MultigridParams {
            smoothing_sweeps: params.smoothing_sweeps.max(1),
            coarsest_sweeps: params.coarsest_sweeps.max(1),
            coarsest_cells_per_axis: params.coarsest_cells_per_axis.max(2),
            damping: params.damping,
        };
        let default_omega = (2 * D) as f64 / (2 * D + 1) as f64;
        let omega = params
            .damping
            .filter(|w| *w > 0.0 && *w < 1.0)
            .unwrap_or(default_omega);
        let mut levels = vec![Level::new(grid)];
        let mut tables = Vec::new();
        let map = CellMap::new(grid, &levels[0].padded);
        let mut current = grid.clone();
        while current
            .dims
            .iter()
            .any(|&d| d > params.coarsest_cells_per_axis)
        {
            tables.push(std::array::from_fn(|a| prolongation_table(current.dims[a])));
            current = current.coarsened();
            levels.push(Level::new(&current));
        }
        Self {
            levels,
            tables,
            map,
            params,
            omega,
        }
    }

    /// The number of levels, the fine one included.
    pub fn num_levels(&self) -> usize {
        self.levels.len()
    }

    /// The number of unknowns.
    pub fn dim(&self) -> usize {
        self.map.cells.len()
    }

    /// One V-cycle for the right-hand side in `levels[0].b`, result in `levels[0].x`.
    fn v_cycle(&mut self) {
        let omega = self.omega;
        let nu = self.params.smoothing_sweeps;
        let last = self.levels.len() - 1;
        for l in 0..last {
            let level = &mut self.levels[l];
            level.first_sweep(omega);
            for _ in 1..nu {
                level.sweep(omega);
            }
            level.residual();
            let (fine, coarse) = self.levels.split_at_mut(l + 1);
            restrict(&fine[l], &mut coarse[0]);
        }
        let coarsest = &mut self.levels[last];
        coarsest.first_sweep(omega);
        for _ in 1..self.params.coarsest_sweeps {
            coarsest.sweep(omega);
        }
        for l in (0..last).rev() {
            let (fine, coarse) = self.levels.split_at_mut(l + 1);
            prolong_add(&coarse[0], &mut fine[l], &self.tables[l]);
            for _ in 0..nu {
                fine[l].sweep(omega);
            }
        }
    }
}

impl<const D: usize> Preconditioner<f64> for MultigridPreconditioner<D> {
    fn apply(&mut self, r: &[f64], z: &mut [f64]) {
        let slab = self.levels[0].padded.slab();
        self.map.scatter(r, &mut self.levels[0].b, slab);
        self.v_cycle();
        self.map.gather(&self.levels[0].x, z);
    }

    fn scalar_dim(&self) -> Option<usize> {
        Some(self.dim())
    }
}

#[cfg(test)]
mod tests;
