//! Sparsity pattern and assembly of the Newton matrix `M/Δt² + K` on the free degrees of freedom.
//!
//! Equations exist for the *equation nodes* (`Constraints::dofs`), active nodes with at least
//! one free component; nodes whose components are all prescribed are eliminated. Equation
//! `e·D + a` is component `a` of equation node `e`. A prescribed component of a partly fixed node
//! keeps its row and column as a unit diagonal with zero coupling and zero right-hand side, which
//! is the same as eliminating it. The matrix is an `mpm_linalg::SymmetricMatrix` with blocks of
//! `D`: equation nodes couple when they share a particle. The pattern depends only on the
//! reference connectivity, so it is built once.

use crate::potential::{tensor_len, Potential};
use crate::reference::{Constraints, ReferenceConfig, NONE};
use mpm_core::{Dim, DimOps, Real};
use mpm_linalg::{PatternError, SymmetricMatrix, SymmetricPattern};

/// The block pattern of the Newton matrix: equation nodes `e` and `e'` couple when some particle
/// has both in its stencil.
pub(crate) fn hessian_pattern<const D: usize>(
    reference: &ReferenceConfig<D>,
    constraints: &Constraints<D>,
) -> Result<SymmetricPattern, PatternError> {
    let dofs = &constraints.dofs;
    SymmetricPattern::from_block_rows(dofs.len(), D, |e, out| {
        for &(p, _) in reference.incidence(dofs.node(e)) {
            for &i in reference.slots(p as usize).0 {
                if i != NONE {
                    out.extend(dofs.unknown(i as usize));
                }
            }
        }
    })
}

/// Entries of the block-position table of [`assemble`]: `(2S − 1)^D` for the widest stencil,
/// the cubic kernel (S = 4) in 3D.
const MAX_TABLE: usize = 343;

/// Refills `matrix` (on [`hessian_pattern`]) with the lower triangle of `M/Δt² + K` from the
/// per-particle tensors. Each equation node's columns are gathered by one task, particles in
/// ascending order, so the values do not depend on the thread count.
pub(crate) fn assemble<const D: usize>(
    pot: &Potential<'_, D>,
    tensors: &[Real],
    matrix: &mut SymmetricMatrix,
) where
    Dim<D>: DimOps<D>,
{
    let n2 = D * D;
    let (reference, constraints) = (pot.reference, pot.constraints);
    let dofs = &constraints.dofs;
    let masses = reference.node_masses();
    let spec = reference.spec();
    // A node coupled to j lies within S − 1 nodes of it along every axis (they share a
    // particle's stencil of S nodes per axis), so a column's blocks are found by their grid
    // offset from j in a table of (2S − 1)^D entries instead of a search per contribution.
    let support = reference.kernel().support();
    let span = 2 * support - 1;
    let stencil: Vec<[usize; D]> = (0..support.pow(D as u32))
        .map(|s| std::array::from_fn(|a| s / support.pow(a as u32) % support))
        .collect();
    matrix.refill_block_columns(|column| {
        let e = column.block();
        let j = dofs.node(e);
        let node_j = spec.multi_index(reference.grid_index(j));
        let mut position = [u16::MAX; MAX_TABLE];
        for k in 0..column.num_blocks() {
            let node_i = spec.multi_index(reference.grid_index(dofs.node(column.block_row(k))));
            let mut idx = 0;
            for a in (0..D).rev() {
                idx = idx * span + (node_i[a] - node_j[a] + support as i64 - 1) as usize;
            }
            position[idx] = k as u16;
        }
        for &(p, kj) in reference.incidence(j) {
            let (p, kj) = (p as usize, kj as usize);
            let a = &tensors[p * tensor_len(D)..(p + 1) * tensor_len(D)];
            let gj = reference.slot(p, kj).1;
            // c[row][b] = Σ_δ A[row][(b, δ)] ∇W_j,δ
            let mut c = [[0.0; 3]; 9];
            for (row, cr) in c.iter_mut().enumerate().take(n2) {
                for b in 0..D {
                    cr[b] = (0..D).map(|d| a[row * n2 + b * D + d] * gj[d]).sum();
                }
            }
            let (nodes, _, grads) = reference.slots(p);
            for (s, (&i, gi)) in nodes.iter().zip(grads).enumerate() {
                if i == NONE {
                    continue;
                }
                // Position of node i's block in e's column (0 for e itself), if it has
                // equations and lies at or below e.
                let mut idx = 0;
                for a in (0..D).rev() {
                    idx = idx * span + stencil[s][a] + support - 1 - stencil[kj][a];
                }
                let k = position[idx];
                if k == u16::MAX {
                    continue;
                }
                let k = k as usize;
                for b in (0..D).filter(|&b| constraints.is_free(j, b)) {
                    for a in 0..D {
                        if (k == 0 && a < b) || !constraints.is_free(i as usize, a) {
                            continue;
                        }
                        let v: Real = (0..D).map(|beta| gi[beta] * c[a * D + beta][b]).sum();
                        column.add(k, a, b, v);
                    }
                }
            }
        }
        for b in 0..D {
            if constraints.is_free(j, b) {
                column.add(0, b, b, masses[j] * pot.inertia);
            } else {
                column.set(0, b, b, 1.0);
            }
        }
    });
}
