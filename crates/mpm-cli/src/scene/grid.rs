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

/// Largest number of grid nodes a scene may ask for (memory guard against typos).
pub const MAX_GRID_NODES: f64 = 64e6;

/// Resolves `[grid]` in dimension `d`.
pub(super) fn resolve_grid(c: &mut Checker<'_>, g: &RawGrid, d: usize) -> Grid {
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
            let nodes: f64 = (0..d)
                .map(|a| ((max[a] - min[a]) / dx).abs().ceil() + 1.0)
                .product();
            if nodes > MAX_GRID_NODES || nodes.is_nan() {
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
