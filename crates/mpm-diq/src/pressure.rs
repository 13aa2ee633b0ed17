//! The pressure-only system (diq-mpm Eq. 35, fluid blocks `A22, A23, A33`), reusable by the
//! coupled solver.
//!
//! **The constraint operator.** Every unknown `k` of the system is a piecewise-constant (B0)
//! pressure: a fluid pressure `p` on a cell (a row of `G^fᵀ`, touching the `2^D` corners of
//! the cell) or a boundary pressure `y` on the boundary around a node (a row of the wall
//! operator `B`, touching the nodes whose support meets that piece of boundary). A row is stored
//! sparsely as vectors `R_k[n]` per node ([`Constraints`]). Stacked, the rows form
//! `J = [G^fᵀ; B]`, and
//!
//! - the momentum equation (Eq. 22 with Eq. 26's third row) is `v = v* − Δt M⁻¹ Jᵀ λ`,
//! - the constraints (Eqs. 23 and 25) are `J v = b` (`b = 0` on fluid rows, `∫ v_b t ds` on
//!   wall rows),
//!
//! so the Schur complement is `A λ = J v* − b` with `A = Δt J M⁻¹ Jᵀ`: exactly Eq. 35's
//! `A22 = Δt G^fᵀ M⁻¹ G^f`, `A23 = Δt G^fᵀ M⁻¹ Bᵀ`, `A33 = Δt B M⁻¹ Bᵀ` and right-hand sides
//! `G^fᵀ v*`, `B v* − b`. `A` is symmetric positive semi-definite by construction and definite
//! when `Jᵀ` has full column rank, which holds when the fluid touches a free surface (see the
//! crate docs); [`Constraints::pin_gauge`] handles fluid enclosed on every side.
//!
//! Units (3D; in 2D replace m³ by m²): rows of `J` in m² (a volume times a gradient, or an
//! area), `M` in kg, `λ` in Pa, `A` in m⁴ s kg⁻¹ and the right-hand side in m³/s.
//!
//! **Pattern reuse.** Two unknowns couple when their rows share a node, so the sparsity pattern
//! depends only on which nodes each row touches. [`PressureSystem`] keeps the pattern
//! (and the symbolic Cholesky factorisation) while that list does not change, and refills the
//! values in place.
//!
//! **Determinism.** Rows are built per unknown, matrix columns are refilled each by one task in
//! a fixed order, scatters back to nodes are serial, and CG sums in index order: results are
//! bitwise identical for any thread count.

use mpm_core::{on_pool, Real, Vector};
use mpm_linalg::{
    conjugate_gradient, CellLabel, CgError, CgParams, CgWorkspace, CholeskyError,
    IncompleteCholesky, InitialGuess, Jacobi, MultigridPreconditioner, OnIterationCap,
    PatternError, PoissonGrid, PoissonGridError, Preconditioner, SparseCholesky, SymmetricMatrix,
    SymmetricPattern,
};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// What one unknown of the pressure system is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum UnknownKind {
    /// A fluid pressure `p` (Pa) on a cell that holds fluid particles: a row of `G^fᵀ`.
    Fluid,
    /// A boundary pressure `y` (Pa) on a cell that holds wall or collider quadrature points: a
    /// row of `B`.
    Wall,
    /// A solid pressure `P^s` (Pa) on a reference-grid cell that holds solid particles: a row
    /// of `G^{sT}` with the compliance `S^s/Δt` on the diagonal (Eq. 35's `A11`).
    SolidPressure,
    /// An interface pressure `h` (Pa) on a current-grid cell that holds interface quadrature
    /// points: a row of `[−H^s, H^f]` (Eq. 35's fourth row).
    Interface,
}

/// How the pressure system is solved.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PressureMethod {
    /// CG with Jacobi (diagonal) preconditioning.
    Jacobi,
    /// CG preconditioned by IC(0) of the assembled matrix (serial triangular solves; Jacobi
    /// for a step whose IC(0) factorisation breaks down). The default: on the fluid systems it needs the fewest iterations (a 2D column of 32² cells:
    /// 34 against 78 for Jacobi and 135 for multigrid) and the least time (see
    /// `benches/README.md`).
    #[default]
    IncompleteCholesky,
    /// CG preconditioned by one geometric multigrid V-cycle (McAdams et al. 2010) of the
    /// 5/7-point Laplacian on the labelled cell grid for the fluid pressures, and Jacobi for the
    /// boundary pressures. It is a poor match for the B1B0 operator, whose stencil couples all
    /// `3^D` cells sharing a node and whose boundary pressures it ignores.
    Multigrid,
    /// faer's sparse Cholesky factorisation (symbolic part reused with the pattern): a direct
    /// solve, for small systems.
    Cholesky,
}

impl PressureMethod {
    /// The method in words, for stage plans.
    pub fn describe(self) -> &'static str {
        match self {
            PressureMethod::Jacobi => "Jacobi-preconditioned CG",
            PressureMethod::IncompleteCholesky => "IC(0)-preconditioned CG",
            PressureMethod::Multigrid => "multigrid-preconditioned CG (V-cycle on fluid cells)",
            PressureMethod::Cholesky => "sparse Cholesky (direct)",
        }
    }
}

/// Parameters of the pressure solve.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PressureParams {
    /// Solver and preconditioner.
    #[serde(default)]
    pub method: PressureMethod,
    /// CG stops at `‖A λ − r‖₂ ≤ rel_tol ‖r‖₂` (dimensionless, in (0, 1)).
    #[serde(default = "PressureParams::default_rel_tol")]
    pub rel_tol: Real,
    /// CG iteration cap; reaching it is an error, never a silently wrong pressure.
    #[serde(default = "PressureParams::default_max_iterations")]
    pub max_iterations: u32,
    /// Keep the residual norm of every CG iteration in [`PressureInfo::history`].
    #[serde(default)]
    pub keep_history: bool,
}

impl PressureParams {
    fn default_rel_tol() -> Real {
        1e-8
    }
    fn default_max_iterations() -> u32 {
        2000
    }
}

impl Default for PressureParams {
    /// IC(0)-preconditioned CG to a relative residual of 1e-8, at most 2000 iterations.
    fn default() -> Self {
        Self {
            method: PressureMethod::default(),
            rel_tol: Self::default_rel_tol(),
            max_iterations: Self::default_max_iterations(),
            keep_history: false,
        }
    }
}

/// Why a pressure solve failed.
#[derive(Clone, Debug, PartialEq, Error)]
pub enum PressureError {
    /// CG failed: not converged within the cap, negative curvature or a non-finite value.
    #[error("pressure CG ({method}): {source}")]
    Cg {
        /// The method in words.
        method: &'static str,
        /// What CG reported.
        #[source]
        source: CgError,
    },
    /// The direct factorisation failed.
    #[error("pressure Cholesky: {0}")]
    Cholesky(#[from] CholeskyError),
    /// The pattern could not be built.
    #[error("pressure pattern: {0}")]
    Pattern(#[from] PatternError),
    /// The multigrid cell grid could not be built.
    #[error("pressure multigrid grid: {0}")]
    Grid(#[from] PoissonGridError),
    /// The preconditioner could not be built from the matrix.
    #[error("pressure preconditioner: {0}")]
    Preconditioner(CgError),
    /// The implicit viscosity's CG failed (see [`crate::viscosity`]).
    #[error("viscosity CG (Jacobi): {0}")]
    Viscosity(CgError),
}

/// What one pressure solve did.
#[derive(Clone, Debug, PartialEq)]
pub struct PressureInfo {
    /// Number of unknowns (fluid plus boundary pressures).
    pub unknowns: usize,
    /// CG iterations (0 for the direct solve).
    pub iterations: u32,
    /// Final residual norm relative to the right-hand side's (dimensionless; 0 when the
    /// right-hand side is 0).
    pub relative_residual: Real,
    /// Whether the sparsity pattern of the previous solve was reused.
    pub pattern_reused: bool,
    /// Residual norms per iteration (m³/s in 3D), when asked for.
    pub history: Vec<Real>,
}

/// The rows of `J` for one solve, as sparse rows over node velocities: per unknown its kind,
/// its anchor (the cell of a fluid row, the node of a boundary row), its nonzero entries
/// `R_k[n]` (one vector per node `n`, sorted by node) and its right-hand-side offset. Fluid rows
/// come first, in cell order.
#[derive(Clone, Debug, PartialEq)]
pub struct Constraints<const D: usize> {
    /// Cells per axis of the fluid grid (nodes per axis minus one).
    cell_dims: [usize; D],
    /// Velocity slots the rows index: the fluid grid's nodes, then any appended with
    /// [`Self::append_nodes`] (the solid's reference nodes in the coupled system).
    num_nodes: usize,
    /// Kind of each unknown.
    kinds: Vec<UnknownKind>,
    /// Cell (linear index, axis 0 fastest) of a fluid row; node (linear index) of a boundary
    /// row.
    anchors: Vec<usize>,
    row_ptr: Vec<usize>,
    nodes: Vec<usize>,
    coeffs: Vec<Vector<D>>,
    /// `b_k` (m³/s in 3D): the prescribed flux of a boundary row, 0 on fluid rows,
    /// `−S^s_k P^{s,n}_k/Δt` on solid-pressure rows.
    offsets: Vec<Real>,
    /// `D_k` (m⁴ s/kg in 3D): added to the diagonal of the assembled `A` after scaling; the
    /// solid compliance `S^s_k/Δt` on solid-pressure rows, 0 elsewhere.
    diagonal: Vec<Real>,
    /// Whether the fluid is enclosed (no free surface), so that `A` has the constant pressure
    /// as a (near) null vector: the first unknown is then pinned (see [`PressureSystem`]).
    pin_gauge: bool,
}

impl<const D: usize> Constraints<D> {
    /// No rows yet, on a grid of `cell_dims` cells.
    pub fn new(cell_dims: [usize; D]) -> Self {
        Self {
            cell_dims,
            num_nodes: cell_dims.iter().map(|c| c + 1).product(),
            kinds: Vec::new(),
            anchors: Vec::new(),
            row_ptr: vec![0],
            nodes: Vec::new(),
            coeffs: Vec::new(),
            offsets: Vec::new(),
            diagonal: Vec::new(),
            pin_gauge: false,
        }
    }

    /// Appends `count` velocity slots after the current ones and returns the index of the
    /// first (the offset of the appended block).
    pub fn append_nodes(&mut self, count: usize) -> usize {
        let first = self.num_nodes;
        self.num_nodes += count;
        first
    }

    /// Appends a row: entries `(node, R_k[node])` in any order (repeated nodes are summed,
    /// zero vectors dropped), with offset `b_k`.
    pub fn push_row(
        &mut self,
        kind: UnknownKind,
        anchor: usize,
        entries: impl IntoIterator<Item = (usize, Vector<D>)>,
        offset: Real,
    ) {
        let mut e: Vec<(usize, Vector<D>)> = entries.into_iter().collect();
        e.sort_by_key(|&(n, _)| n);
        let first = self.nodes.len();
        for (n, r) in e {
            if self.nodes.len() > first && *self.nodes.last().expect("non-empty") == n {
                *self.coeffs.last_mut().expect("non-empty") += r;
            } else {
                self.nodes.push(n);
                self.coeffs.push(r);
            }
        }
        // Drop exact zeros (points on a face touch the far corners with weight 0).
        let mut keep = first;
        for i in first..self.nodes.len() {
            if self.coeffs[i] != Vector::<D>::zeros() {
                self.nodes[keep] = self.nodes[i];
                self.coeffs[keep] = self.coeffs[i];
                keep += 1;
            }
        }
        self.nodes.truncate(keep);
        self.coeffs.truncate(keep);
        self.row_ptr.push(keep);
        self.kinds.push(kind);
        self.anchors.push(anchor);
        self.offsets.push(offset);
        self.diagonal.push(0.0);
    }

    /// Cells per axis of the fluid grid (nodes per axis minus one).
    pub fn cell_dims(&self) -> [usize; D] {
        self.cell_dims
    }

    /// Velocity slots the rows index: the fluid grid's nodes, then any appended with
    /// [`Self::append_nodes`].
    pub fn num_nodes(&self) -> usize {
        self.num_nodes
    }

    /// Kind of each unknown.
    pub fn kinds(&self) -> &[UnknownKind] {
        &self.kinds
    }

    /// Cell (linear index) of each fluid row, node (linear index) of each boundary row.
    pub fn anchors(&self) -> &[usize] {
        &self.anchors
    }

    /// `b_k` of each row (m³/s in 3D).
    pub fn offsets(&self) -> &[Real] {
        &self.offsets
    }

    /// `b_k` of each row, to change in place (one per row: rows are added with
    /// [`Self::push_row`] only).
    pub fn offsets_mut(&mut self) -> &mut [Real] {
        &mut self.offsets
    }

    /// `D_k` of each row (m⁴ s/kg in 3D).
    pub fn diagonal(&self) -> &[Real] {
        &self.diagonal
    }

    /// `D_k` of each row, to change in place.
    pub fn diagonal_mut(&mut self) -> &mut [Real] {
        &mut self.diagonal
    }

    /// Whether the first unknown is pinned (an enclosed fluid, see [`PressureSystem`]).
    pub fn pin_gauge(&self) -> bool {
        self.pin_gauge
    }

    /// Pins the first unknown (`true`) or not.
    pub fn set_pin_gauge(&mut self, pin: bool) {
        self.pin_gauge = pin;
    }

    /// Number of unknowns.
    pub fn len(&self) -> usize {
        self.kinds.len()
    }

    /// Whether there are no unknowns.
    pub fn is_empty(&self) -> bool {
        self.kinds.is_empty()
    }

    /// Number of fluid-pressure unknowns (they come first).
    pub fn num_fluid(&self) -> usize {
        self.kinds
            .iter()
            .take_while(|&&k| k == UnknownKind::Fluid)
            .count()
    }

    /// The nodes and entries `R_k[n]` of row `k` (m² in 3D, m in 2D), sorted by node.
    pub fn row(&self, k: usize) -> (&[usize], &[Vector<D>]) {
        let r = self.row_ptr[k]..self.row_ptr[k + 1];
        (&self.nodes[r.clone()], &self.coeffs[r])
    }

    /// `J v − b`: the right-hand side of the system for the predicted node velocities `v`
    /// (m/s), one value per unknown (m³/s in 3D). In parallel over unknowns.
    pub fn residual(&self, v: &[Vector<D>]) -> Vec<Real> {
        (0..self.len())
            .into_par_iter()
            .map(|k| {
                let (nodes, coeffs) = self.row(k);
                let mut s = 0.0;
                for (n, r) in nodes.iter().zip(coeffs) {
                    s += r.dot(&v[*n]);
                }
                s - self.offsets[k]
            })
            .collect()
    }

    /// `v ← v − scale · M⁻¹ Jᵀ λ` with `inv_mass` the inverse lumped node masses (1/kg, 0 on
    /// nodes without mass) and `scale` (s for velocities). Serial, in unknown order.
    pub fn apply_transpose(
        &self,
        lambda: &[Real],
        inv_mass: &[Real],
        scale: Real,
        v: &mut [Vector<D>],
    ) {
        for k in 0..self.len() {
            let (nodes, coeffs) = self.row(k);
            for (n, r) in nodes.iter().zip(coeffs) {
                v[*n] -= r * (scale * inv_mass[*n] * lambda[k]);
            }
        }
    }

    /// `A_kl = scale Σ_n inv_mass_n R_k[n]·R_l[n]` over the nodes both rows touch.
    fn entry(&self, k: usize, l: usize, inv_mass: &[Real], scale: Real) -> Real {
        let ((nk, rk), (nl, rl)) = (self.row(k), self.row(l));
        let (mut i, mut j, mut s) = (0, 0, 0.0);
        while i < nk.len() && j < nl.len() {
            match nk[i].cmp(&nl[j]) {
                std::cmp::Ordering::Less => i += 1,
                std::cmp::Ordering::Greater => j += 1,
                std::cmp::Ordering::Equal => {
                    s += inv_mass[nk[i]] * rk[i].dot(&rl[j]);
                    i += 1;
                    j += 1;
                }
            }
        }
        scale * s
    }

    /// The sparsity pattern: unknowns couple when their rows share a node.
    fn pattern(&self) -> Result<SymmetricPattern, PatternError> {
        let num_nodes = self.num_nodes;
        let mut ptr = vec![0usize; num_nodes + 1];
        for &n in &self.nodes {
            ptr[n + 1] += 1;
        }
        for n in 0..num_nodes {
            ptr[n + 1] += ptr[n];
        }
        let mut fill = ptr.clone();
        let mut rows_of = vec![0usize; self.nodes.len()];
        for k in 0..self.len() {
            for &n in self.row(k).0 {
                rows_of[fill[n]] = k;
                fill[n] += 1;
            }
        }
        SymmetricPattern::from_block_rows(self.len(), 1, |k, out| {
            for &n in self.row(k).0 {
                out.extend_from_slice(&rows_of[ptr[n]..ptr[n + 1]]);
            }
        })
    }

    /// Whether `other` has the same unknowns touching the same nodes (same pattern).
    fn same_structure(&self, other: &Self) -> bool {
        self.cell_dims == other.cell_dims
            && self.num_nodes == other.num_nodes
            && self.kinds == other.kinds
            && self.row_ptr == other.row_ptr
            && self.nodes == other.nodes
    }

    /// The cell labels of the multigrid preconditioner: fluid cells (those with a fluid
    /// unknown), solid where `solid(cell)`, air elsewhere.
    fn labels(&self, solid: &dyn Fn(usize) -> bool) -> Vec<CellLabel> {
        let num_cells: usize = self.cell_dims.iter().product();
        let mut labels: Vec<CellLabel> = (0..num_cells)
            .map(|c| {
                if solid(c) {
                    CellLabel::Solid
                } else {
                    CellLabel::Air
                }
            })
            .collect();
        for k in 0..self.num_fluid() {
            labels[self.anchors[k]] = CellLabel::Fluid;
        }
        labels
    }
}

/// The preconditioner in use.
#[derive(Debug)]
enum Precond<const D: usize> {
    None,
    Jacobi(Jacobi<f64>),
    Ic(IncompleteCholesky),
    /// Multigrid on the first `fluid` unknowns, Jacobi on the rest.
    Multigrid {
        mg: Box<MultigridPreconditioner<D>>,
        fluid: usize,
        rest: Jacobi<f64>,
    },
}

impl<const D: usize> Preconditioner<f64> for Precond<D> {
    fn apply(&mut self, r: &[f64], z: &mut [f64]) {
        match self {
            Precond::None => z.copy_from_slice(r),
            Precond::Jacobi(j) => j.apply(r, z),
            Precond::Ic(ic) => ic.apply(r, z),
            Precond::Multigrid { mg, fluid, rest } => {
                let f = *fluid;
                mg.apply(&r[..f], &mut z[..f]);
                for (i, (zi, ri)) in z[f..].iter_mut().zip(&r[f..]).enumerate() {
                    *zi = rest.inverse_diagonal()[i] * ri;
                }
            }
        }
    }
}

/// The assembled pressure system with its cached pattern, preconditioner and CG workspace.
#[derive(Debug, Default)]
pub struct PressureSystem<const D: usize> {
    key: Option<Constraints<D>>,
    matrix: Option<SymmetricMatrix>,
    cholesky: Option<SparseCholesky>,
    precond: Option<Precond<D>>,
    work: CgWorkspace<f64>,
    reused: bool,
}

impl<const D: usize> PressureSystem<D> {
    /// An empty system; the first [`Self::assemble`] builds the pattern.
    pub fn new() -> Self {
        Self::default()
    }

    /// The assembled matrix, after [`Self::assemble`].
    pub fn matrix(&self) -> Option<&SymmetricMatrix> {
        self.matrix.as_ref()
    }

    /// Assembles `A = scale · J M⁻¹ Jᵀ` (`inv_mass` in 1/kg per node, `scale` in s) and sets up
    /// the preconditioner of `params.method`; `solid(cell)` tells the multigrid preconditioner
    /// which cells are walls. The pattern is rebuilt only when the unknowns changed.
    pub fn assemble(
        &mut self,
        rows: &Constraints<D>,
        inv_mass: &[Real],
        scale: Real,
        params: &PressureParams,
        solid: &dyn Fn(usize) -> bool,
    ) -> Result<(), PressureError> {
        let same =
            self.matrix.is_some() && self.key.as_ref().is_some_and(|k| k.same_structure(rows));
        if !same {
            self.key = Some(rows.clone());
            self.matrix = Some(SymmetricMatrix::new(rows.pattern()?));
            self.cholesky = None;
        }
        self.reused = same;
        let matrix = self.matrix.as_mut().expect("built above");
        matrix.refill_block_columns(|col| {
            let k = col.block();
            for pos in 0..col.num_blocks() {
                let l = col.block_row(pos);
                let d = if k == l { rows.diagonal[k] } else { 0.0 };
                col.add(pos, 0, 0, rows.entry(k, l, inv_mass, scale) + d);
            }
        });
        if rows.pin_gauge && !rows.is_empty() {
            // Doubling A₀₀ adds a rank-one term that fixes λ₀ = 0 for a consistent singular
            // system without changing its solution otherwise.
            matrix.add(0, 0, matrix.diagonal(0))?;
        }
        self.precond = Some(match params.method {
            PressureMethod::Cholesky => Precond::None,
            PressureMethod::Jacobi => {
                let mut j = Jacobi::new();
                j.set_from_matrix(matrix)
                    .map_err(PressureError::Preconditioner)?;
                Precond::Jacobi(j)
            }
            PressureMethod::IncompleteCholesky => match IncompleteCholesky::new(matrix) {
                Ok(ic) => Precond::Ic(ic),
                // IC(0) can break down on an SPD matrix that is not an M-matrix (a pivot
                // vanishes to round-off); Jacobi always exists for a positive diagonal.
                Err(_) => {
                    let mut j = Jacobi::new();
                    j.set_from_matrix(matrix)
                        .map_err(PressureError::Preconditioner)?;
                    Precond::Jacobi(j)
                }
            },
            PressureMethod::Multigrid => {
                let fluid = rows.num_fluid();
                let mut all = Jacobi::new();
                all.set_from_matrix(matrix)
                    .map_err(PressureError::Preconditioner)?;
                if rows.pin_gauge || fluid == 0 {
                    // All-Neumann multigrid is singular: fall back to Jacobi.
                    Precond::Jacobi(all)
                } else {
                    let mean_diag =
                        (0..fluid).map(|i| matrix.diagonal(i)).sum::<Real>() / fluid as Real;
                    let grid =
                        PoissonGrid::new(rows.cell_dims, rows.labels(solid), CellLabel::Solid)
                            .and_then(|g| g.with_coefficient(mean_diag / (2 * D) as Real))
                            .map_err(PressureError::Grid)?;
                    let rest =
                        Jacobi::from_inverse_diagonal(all.inverse_diagonal()[fluid..].to_vec());
                    Precond::Multigrid {
                        mg: Box::new(MultigridPreconditioner::new(&grid)),
                        fluid,
                        rest,
                    }
                }
            }
        });
        Ok(())
    }

    /// Solves `A λ = rhs` (λ in Pa) with the method the system was assembled for, on a thread
    /// of the rayon pool ([`on_pool`]: each conjugate gradient iteration runs several short
    /// parallel vector operations, which would otherwise each be handed over from a caller
    /// outside the pool; inside a solver's step it already runs on the pool).
    pub fn solve(
        &mut self,
        rhs: &[Real],
        lambda: &mut Vec<Real>,
        params: &PressureParams,
    ) -> Result<PressureInfo, PressureError> {
        on_pool(|| self.solve_here(rhs, lambda, params))
    }

    /// [`Self::solve`] on the calling thread.
    fn solve_here(
        &mut self,
        rhs: &[Real],
        lambda: &mut Vec<Real>,
        params: &PressureParams,
    ) -> Result<PressureInfo, PressureError> {
        let Self {
            matrix,
            cholesky,
            precond,
            work,
            reused,
            ..
        } = self;
        let matrix = matrix.as_mut().expect("assemble before solve");
        lambda.clear();
        lambda.resize(rhs.len(), 0.0);
        let rhs_norm = rhs.iter().map(|r| r * r).sum::<Real>().sqrt();
        let mut info = PressureInfo {
            unknowns: rhs.len(),
            iterations: 0,
            relative_residual: 0.0,
            pattern_reused: *reused,
            history: Vec::new(),
        };
        if rhs.is_empty() || rhs_norm == 0.0 {
            return Ok(info);
        }
        if params.method == PressureMethod::Cholesky {
            if cholesky.is_none() {
                *cholesky = Some(SparseCholesky::new(matrix.pattern())?);
            }
            let chol = cholesky.as_mut().expect("set above");
            chol.factorize(matrix)?;
            lambda.copy_from_slice(rhs);
            chol.solve_in_place(lambda)?;
            let mut ax = vec![0.0; rhs.len()];
            matrix.mul_vec(lambda, &mut ax);
            let res = ax
                .iter()
                .zip(rhs)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<Real>()
                .sqrt();
            info.relative_residual = res / rhs_norm;
            return Ok(info);
        }
        let cg = CgParams {
            max_iterations: params.max_iterations,
            rel_tol: params.rel_tol,
            abs_tol: 0.0,
            keep_history: params.keep_history,
            initial_guess: InitialGuess::Zero,
            on_cap: OnIterationCap::Error,
        };
        let precond = precond.as_mut().expect("assembled");
        let out =
            conjugate_gradient(matrix, precond, rhs, lambda, &cg, work).map_err(|source| {
                PressureError::Cg {
                    method: params.method.describe(),
                    source,
                }
            })?;
        info.iterations = out.iterations;
        info.relative_residual = out.residual / rhs_norm;
        info.history = out.history;
        Ok(info)
    }
}
