//! Background grid geometry and dense node storage.

use crate::kernel::Kernel;
use crate::math::{Real, Vector};

/// Geometry of a background grid: `size[a]` nodes along axis `a`, spaced `dx` apart, node 0 at
/// `origin`. Every phase of a multi-grid simulation shares one `GridSpec`, so grids couple node by
/// node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridSpec<const D: usize> {
    /// Position of node 0 (m).
    pub origin: Vector<D>,
    /// Node spacing Δx (m).
    pub dx: Real,
    /// Number of nodes per axis.
    pub size: [usize; D],
}

impl<const D: usize> GridSpec<D> {
    /// A grid with `size` nodes per axis, spacing `dx` (m), first node at `origin` (m).
    pub fn new(origin: Vector<D>, dx: Real, size: [usize; D]) -> Self {
        Self { origin, dx, size }
    }

    /// The grid whose nodes cover the box `[min, max]` (m) with spacing `dx` (m); `max` is rounded
    /// up to a whole number of cells.
    pub fn covering(min: Vector<D>, max: Vector<D>, dx: Real) -> Self {
        let size = std::array::from_fn(|a| ((max[a] - min[a]) / dx - 1e-9).ceil() as usize + 1);
        Self::new(min, dx, size)
    }

    /// Total number of nodes.
    pub fn num_nodes(&self) -> usize {
        self.size.iter().product()
    }

    /// Cell volume Δx^D (m^D).
    pub fn cell_volume(&self) -> Real {
        self.dx.powi(D as i32)
    }

    /// Position (m) of the node with multi-index `node`.
    pub fn node_position(&self, node: &[i64; D]) -> Vector<D> {
        Vector::<D>::from_fn(|a, _| self.origin[a] + node[a] as Real * self.dx)
    }

    /// Upper corner of the grid (m): the position of the last node.
    pub fn max_corner(&self) -> Vector<D> {
        Vector::<D>::from_fn(|a, _| self.origin[a] + (self.size[a] - 1) as Real * self.dx)
    }

    /// Linear index of a node (first axis fastest), or `None` outside the grid.
    #[inline]
    pub fn linear_index(&self, node: &[i64; D]) -> Option<usize> {
        let mut idx = 0usize;
        let mut stride = 1usize;
        for a in 0..D {
            let n = node[a];
            if n < 0 || n as usize >= self.size[a] {
                return None;
            }
            idx += n as usize * stride;
            stride *= self.size[a];
        }
        Some(idx)
    }

    /// Multi-index of the node with linear index `idx`.
    pub fn multi_index(&self, mut idx: usize) -> [i64; D] {
        let mut m = [0i64; D];
        for a in 0..D {
            m[a] = (idx % self.size[a]) as i64;
            idx /= self.size[a];
        }
        m
    }

    /// Whether a particle at `x` (m) has its whole `kernel` stencil inside the grid.
    pub fn contains_stencil(&self, kernel: Kernel, x: &Vector<D>) -> bool {
        (0..D).all(|a| {
            let xh = (x[a] - self.origin[a]) / self.dx;
            let lo = kernel.lower_margin();
            let hi = (self.size[a] - kernel.support()) as Real + lo + 1.0;
            xh.is_finite() && xh >= lo && xh < hi
        })
    }
}

/// Dense per-node storage of one grid (one phase).
#[derive(Clone, Debug, Default)]
pub struct GridNodes<const D: usize> {
    /// Node mass (kg).
    pub mass: Vec<Real>,
    /// Node momentum (kg·m/s); after the grid update, unused.
    pub momentum: Vec<Vector<D>>,
    /// Node velocity (m/s) after the grid update.
    pub velocity: Vec<Vector<D>>,
}

impl<const D: usize> GridNodes<D> {
    /// Zeroed storage for `spec` (reuses existing allocations).
    pub fn reset(&mut self, spec: &GridSpec<D>) {
        let n = spec.num_nodes();
        self.mass.clear();
        self.mass.resize(n, 0.0);
        self.momentum.clear();
        self.momentum.resize(n, Vector::<D>::zeros());
        self.velocity.clear();
        self.velocity.resize(n, Vector::<D>::zeros());
    }

    /// Total mass on the grid (kg).
    pub fn total_mass(&self) -> Real {
        self.mass.iter().sum()
    }

    /// Total momentum on the grid (kg·m/s).
    pub fn total_momentum(&self) -> Vector<D> {
        self.momentum.iter().sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_round_trip_and_stencil_containment() {
        let spec =
            GridSpec::<3>::covering(Vector::<3>::zeros(), Vector::<3>::new(1.0, 0.5, 0.25), 0.05);
        assert_eq!(spec.size, [21, 11, 6]);
        for idx in [0, 7, 100, spec.num_nodes() - 1] {
            assert_eq!(spec.linear_index(&spec.multi_index(idx)), Some(idx));
        }
        assert_eq!(spec.linear_index(&[-1, 0, 0]), None);
        assert!(spec.contains_stencil(Kernel::Quadratic, &Vector::<3>::new(0.5, 0.25, 0.125)));
        assert!(!spec.contains_stencil(Kernel::Quadratic, &Vector::<3>::new(0.01, 0.25, 0.125)));
        assert!(!spec.contains_stencil(Kernel::Cubic, &Vector::<3>::new(0.5, 0.25, 0.249)));
    }
}
