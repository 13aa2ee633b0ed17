//! `[grid]`: the domain, the node spacing and the interpolation kernel.

use super::{count_text, Checker};
use mpm_core::Kernel;
use serde::{Deserialize, Serialize};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawGrid {
    min: Vec<f64>,
    max: Vec<f64>,
    dx: f64,
    kernel: Option<Kernel>,
}

/// `[grid]`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Grid {
    /// Lower corner (m).
    pub min: Vec<f64>,
    /// Upper corner (m), rounded up to whole cells by the solver.
    pub max: Vec<f64>,
    /// Node spacing (m).
    pub dx: f64,
    /// Interpolation kernel.
    pub kernel: Kernel,
}

/// Largest number of grid nodes a scene may ask for from a solver whose grid is dense (memory
/// guard against typos).
pub const MAX_GRID_NODES: f64 = 64e6;

/// Largest number of node blocks of the domain (16² nodes in 2D, 8³ in 3D) a scene may ask for
/// from a solver with a sparse grid (the explicit solver): it stores only the blocks material
/// reaches, but keeps about 12 bytes per block of the domain and phase (memory guard against
/// typos).
pub const MAX_GRID_BLOCKS: f64 = 64e6;

/// Node blocks per axis of a sparse grid in dimension `d` (`mpm_core::NodeLayout::BLOCK`).
pub fn block_nodes(d: usize) -> usize {
    if d == 2 {
        mpm_core::NodeLayout::<2>::BLOCK
    } else {
        mpm_core::NodeLayout::<3>::BLOCK
    }
}

/// Resolves `[grid]` in dimension `d`; `sparse`: the solver stores only the node blocks
/// material reaches, so the limit counts the domain's blocks rather than its nodes.
pub(super) fn resolve_grid(c: &mut Checker<'_>, g: &RawGrid, d: usize, sparse: bool) -> Grid {
    let min = c.vector("grid.min", &g.min, d);
    let max = c.vector("grid.max", &g.max, d);
    let dx = c.positive("grid.dx", g.dx);
    if min.len() == d && max.len() == d {
        for a in 0..d {
            if min[a].is_finite() && max[a].is_finite() && max[a] <= min[a] {
                c.err(
                    &format!("grid.max[{a}]"),
                    format!("must exceed grid.min[{a}] = {}", min[a]),
                );
            }
        }
        if dx > 0.0 && dx.is_finite() {
            let per_axis = |a: usize| ((max[a] - min[a]) / dx).abs().ceil() + 1.0;
            let nodes: f64 = (0..d).map(per_axis).product();
            let b = block_nodes(d) as f64;
            let blocks: f64 = (0..d).map(|a| (per_axis(a) / b).ceil()).product();
            if sparse && (blocks > MAX_GRID_BLOCKS || blocks.is_nan()) {
                c.err(
                    "grid.dx",
                    format!(
                        "the grid would have {} blocks of {}{} nodes (limit {}): increase dx \
                         or shrink the domain",
                        count_text(blocks),
                        b,
                        if d == 2 { "²" } else { "³" },
                        count_text(MAX_GRID_BLOCKS)
                    ),
                );
            } else if !sparse && (nodes > MAX_GRID_NODES || nodes.is_nan()) {
                c.err(
                    "grid.dx",
                    format!(
                        "the grid would have {} nodes (limit {}): increase dx or shrink the \
                         domain",
                        count_text(nodes),
                        count_text(MAX_GRID_NODES)
                    ),
                );
            }
        }
    }
    Grid {
        min,
        max,
        dx,
        kernel: g.kernel.unwrap_or(Kernel::Quadratic),
    }
}
