//! Sparsity pattern and assembly of the Newton matrix `M/Δt² + K` on the free degrees of freedom.
//!
//! Equations exist for the *equation nodes*, active nodes with at least one free component;
//! nodes whose components are all prescribed are eliminated. Equation `e·D + a` is component `a`
//! of equation node `e`. A prescribed component of a partly fixed node keeps its row and column
//! as a unit diagonal with zero coupling and zero right-hand side, which is the same as
//! eliminating it. The lower triangle is stored in compressed columns: column `(e, b)` holds the
//! rows `(e, a ≥ b)` of the diagonal block followed by all `D` rows of each neighbour equation
//! node `e' > e` (nodes that share a particle), neighbours ascending. The pattern depends only on
//! the reference connectivity, so it is built once.

use crate::par::for_each_segment;
use crate::potential::{tensor_len, Potential};
use crate::reference::{Constraints, ReferenceConfig, NONE};
use mpm_core::{Dim, DimOps, Real};

/// The lower-triangular block pattern of the Newton matrix.
#[derive(Clone, Debug)]
pub(crate) struct HessianPattern {
    /// Offsets of each equation node's neighbour list in `nbrs`.
    nbr_ptr: Vec<usize>,
    /// Neighbour equation nodes `e' ≥ e`, ascending (the first is `e` itself).
    nbrs: Vec<u32>,
    /// Offset of each equation node's `D` columns in the value array.
    node_ptr: Vec<usize>,
}

impl HessianPattern {
    /// Builds the pattern and the compressed-column arrays `(col_ptr, row_idx)` of the lower
    /// triangle.
    pub fn new<const D: usize>(
        reference: &ReferenceConfig<D>,
        constraints: &Constraints<D>,
    ) -> (Self, Vec<usize>, Vec<usize>) {
        let n_eq = constraints.node_of_eq.len();
        let mut nbr_ptr = Vec::with_capacity(n_eq + 1);
        let mut nbrs = Vec::new();
        nbr_ptr.push(0);
        let mut tmp = Vec::new();
        for (e, &j) in constraints.node_of_eq.iter().enumerate() {
            tmp.clear();
            for &(p, _) in reference.incidence(j as usize) {
                for &i in reference.slots(p as usize).0 {
                    if i != NONE {
                        let ei = constraints.eq_of_node[i as usize];
                        if ei != NONE && ei as usize >= e {
                            tmp.push(ei);
                        }
                    }
                }
            }
            tmp.sort_unstable();
            tmp.dedup();
            nbrs.extend_from_slice(&tmp);
            nbr_ptr.push(nbrs.len());
        }
        let mut col_ptr = Vec::with_capacity(n_eq * D + 1);
        let mut row_idx = Vec::new();
        let mut node_ptr = Vec::with_capacity(n_eq + 1);
        col_ptr.push(0);
        for e in 0..n_eq {
            node_ptr.push(row_idx.len());
            let nb = &nbrs[nbr_ptr[e]..nbr_ptr[e + 1]];
            for b in 0..D {
                row_idx.extend((b..D).map(|a| e * D + a));
                for &i in &nb[1..] {
                    row_idx.extend((0..D).map(|a| i as usize * D + a));
                }
                col_ptr.push(row_idx.len());
            }
        }
        node_ptr.push(row_idx.len());
        (
            Self {
                nbr_ptr,
                nbrs,
                node_ptr,
            },
            col_ptr,
            row_idx,
        )
    }

    /// Number of stored (lower-triangle) entries.
    pub fn nnz(&self) -> usize {
        self.node_ptr.last().copied().unwrap_or(0)
    }

    /// Fills `values` (length [`Self::nnz`]) with the lower triangle of `M/Δt² + K` from the
    /// per-particle tensors. Each equation node's columns are gathered by one task, particles in
    /// ascending order, so the values do not depend on the thread count.
    pub fn assemble<const D: usize>(
        &self,
        pot: &Potential<'_, D>,
        tensors: &[Real],
        values: &mut [Real],
    ) where
        Dim<D>: DimOps<D>,
    {
        let n2 = D * D;
        let (reference, constraints) = (pot.reference, pot.constraints);
        let masses = reference.node_masses();
        for_each_segment(values, &self.node_ptr, &|e, seg: &mut [Real]| {
            seg.fill(0.0);
            let j = constraints.node_of_eq[e] as usize;
            let nb = &self.nbrs[self.nbr_ptr[e]..self.nbr_ptr[e + 1]];
            let mut col_off = [0usize; 3];
            for b in 1..D {
                col_off[b] = col_off[b - 1] + (D - (b - 1)) + (nb.len() - 1) * D;
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
                for (&i, gi) in nodes.iter().zip(grads) {
                    if i == NONE {
                        continue;
                    }
                    let ei = constraints.eq_of_node[i as usize];
                    if ei == NONE || (ei as usize) < e {
                        continue;
                    }
                    let same = ei as usize == e;
                    // Position of node i among e's neighbours (0 for e itself).
                    let Ok(k) = nb.binary_search(&ei) else {
                        continue;
                    };
                    for b in (0..D).filter(|&b| constraints.is_free(j, b)) {
                        for a in 0..D {
                            if (same && a < b) || !constraints.is_free(i as usize, a) {
                                continue;
                            }
                            let v: Real = (0..D).map(|beta| gi[beta] * c[a * D + beta][b]).sum();
                            let row = if same {
                                a - b
                            } else {
                                (D - b) + (k - 1) * D + a
                            };
                            seg[col_off[b] + row] += v;
                        }
                    }
                }
            }
            for b in 0..D {
                if constraints.is_free(j, b) {
                    seg[col_off[b]] += masses[j] * pot.inv_dt2;
                } else {
                    seg[col_off[b]] = 1.0;
                }
            }
        });
    }
}

/// `y = A x` for a symmetric matrix stored as its lower triangle in compressed columns.
#[cfg(test)]
pub(crate) fn symmetric_product(
    col_ptr: &[usize],
    row_idx: &[usize],
    values: &[Real],
    x: &[Real],
) -> Vec<Real> {
    let mut y = vec![0.0; x.len()];
    for c in 0..x.len() {
        for k in col_ptr[c]..col_ptr[c + 1] {
            let r = row_idx[k];
            y[r] += values[k] * x[c];
            if r != c {
                y[c] += values[k] * x[r];
            }
        }
    }
    y
}
