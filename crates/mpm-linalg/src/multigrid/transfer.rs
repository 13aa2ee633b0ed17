//! Moving between the levels of the multigrid hierarchy: the labels coarsened once (a
//! [`PoissonGrid`] at twice the spacing), the restriction of a fine residual to the coarse
//! right-hand side, and the multilinear prolongation of a coarse correction.

use super::{coords, CellLabel, Level, PoissonGrid};
use crate::dof::DofMap;

impl<const D: usize> PoissonGrid<D> {
    /// The labels coarsened once: `ceil(dims / 2)` cells per axis; a coarse cell is air if any
    /// of its children is, else fluid if any is, else solid (children outside the grid take the
    /// exterior label).
    pub(super) fn coarsened(&self) -> Self {
        let cdims: [usize; D] = std::array::from_fn(|a| self.dims[a].div_ceil(2));
        let n: usize = cdims.iter().product();
        let mut labels = Vec::with_capacity(n);
        for c in 0..n {
            let xc = coords(c, &cdims);
            let (mut air, mut fluid) = (false, false);
            for child in 0..(1usize << D) {
                let mut inside = true;
                let mut f = 0;
                for a in (0..D).rev() {
                    let xa = 2 * xc[a] + ((child >> a) & 1);
                    inside &= xa < self.dims[a];
                    f = f * self.dims[a] + xa;
                }
                let label = if inside {
                    self.labels[f]
                } else {
                    self.exterior
                };
                air |= label == CellLabel::Air;
                fluid |= label == CellLabel::Fluid;
            }
            labels.push(if air {
                CellLabel::Air
            } else if fluid {
                CellLabel::Fluid
            } else {
                CellLabel::Solid
            });
        }
        let unknowns = DofMap::from_predicate(n, |c| labels[c] == CellLabel::Fluid);
        Self {
            dims: cdims,
            labels,
            exterior: self.exterior,
            coefficient: self.coefficient / 4.0,
            unknowns,
        }
    }
}

/// Restriction of the fine residual (`fine.t`) to the coarse right-hand side: per axis the
/// weights 1/8, 3/8, 3/8, 1/8 over fine cells `2I − 1 … 2I + 2` (`Pᵀ / 2^D`), zero on inactive
/// coarse cells.
pub(super) fn restrict<const D: usize>(fine: &Level<D>, coarse: &mut Level<D>) {
    const W: [f64; 4] = [0.125, 0.375, 0.375, 0.125];
    let cp = &coarse.padded;
    let (r, fs) = (&fine.t, &fine.padded.strides);
    let inv = &coarse.inv;
    cp.par_for_each_line(&mut coarse.b, |c0, line| {
        // Stored coarse coordinates of the line's first cell → its first fine child window.
        let mut rest = c0;
        let mut fine0 = 0;
        for a in (0..D).rev() {
            let xa = rest / cp.strides[a];
            rest %= cp.strides[a];
            fine0 += (2 * xa - 2) * fs[a];
        }
        for (k, out) in line.iter_mut().enumerate() {
            if inv[c0 + k] == 0.0 {
                *out = 0.0;
                continue;
            }
            let start = fine0 + 2 * k;
            let mut sum = 0.0;
            for m in 0..(1usize << (2 * D)) {
                let mut w = 1.0;
                let mut f = start;
                for a in 0..D {
                    let o = (m >> (2 * a)) & 3;
                    w *= W[o];
                    f += o * fs[a];
                }
                sum += w * r[f];
            }
            *out = sum;
        }
    });
}

/// Per stored fine coordinate along one axis: the stored coarse parent, the other coarse
/// neighbour, for multilinear interpolation with weights 3/4 and 1/4.
pub(super) fn prolongation_table(fine_dims: usize) -> Vec<(usize, usize)> {
    (0..fine_dims + 2)
        .map(|pf| {
            if pf == 0 || pf > fine_dims {
                return (0, 0);
            }
            let f = pf - 1;
            let parent = f / 2 + 1;
            let other = if f % 2 == 0 { parent - 1 } else { parent + 1 };
            (parent, other)
        })
        .collect()
}

/// `fine.x += P coarse.x` on active fine cells: multilinear interpolation between cell centres.
pub(super) fn prolong_add<const D: usize>(
    coarse: &Level<D>,
    fine: &mut Level<D>,
    tables: &[Vec<(usize, usize)>; D],
) {
    let fp = &fine.padded;
    let (e, cs) = (&coarse.x, &coarse.padded.strides);
    let inv = &fine.inv;
    fp.par_for_each_line(&mut fine.x, |c0, line| {
        // Coarse offsets from the axes above 0 (fixed along the line).
        let mut rest = c0;
        let mut upper = [(0usize, 0usize); D];
        for a in (1..D).rev() {
            let xa = rest / fp.strides[a];
            rest %= fp.strides[a];
            let (p, o) = tables[a][xa];
            upper[a] = (p * cs[a], o * cs[a]);
        }
        for (k, out) in line.iter_mut().enumerate() {
            if inv[c0 + k] == 0.0 {
                continue;
            }
            upper[0] = tables[0][1 + k];
            let mut sum = 0.0;
            for m in 0..(1usize << D) {
                let mut w = 1.0;
                let mut idx = 0;
                for a in 0..D {
                    let (p, o) = upper[a];
                    if (m >> a) & 1 == 1 {
                        idx += o;
                        w *= 0.25;
                    } else {
                        idx += p;
                        w *= 0.75;
                    }
                }
                sum += w * e[idx];
            }
            *out += sum;
        }
    });
}
