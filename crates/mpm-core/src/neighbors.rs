//! Cell-list neighbour search among points (particles in the current configuration).
//!
//! [`CellList::build`] covers the bounding box of the points with a uniform grid of cubic cells
//! and sorts the points by cell (a counting sort, stable in point index). A query visits the
//! points of the `3^D` cells around a cell, cell by cell in a fixed order and by ascending index
//! within a cell, so anything accumulated over the visits is reproducible bit for bit and does
//! not depend on the thread count of the caller. With cells at least as large as the search
//! radius, every point within the radius of a query point is among the visited candidates.
//!
//! Memory is bounded whatever the spread of the points: the cells grow beyond the requested size
//! when there would be more than [`CellList::MAX_CELLS_PER_AXIS`] per axis, or more than
//! `max(MIN_CELL_BUDGET, CELLS_PER_POINT · n)` in all for `n` points. Far-flung points then cost
//! extra candidates, never memory.
//!
//! ```
//! use mpm_core::neighbors::CellList;
//! use mpm_core::Vector;
//!
//! let x = vec![
//!     Vector::<2>::new(0.0, 0.0),
//!     Vector::<2>::new(0.05, 0.0),
//!     Vector::<2>::new(0.5, 0.5),
//! ];
//! let mut cells = CellList::default();
//! cells.build(&x, 0.1);
//! let mut near = Vec::new();
//! cells.for_each_within(&x, 0, 0.1, |q, _, dist| near.push((q, dist)));
//! assert_eq!(near, vec![(1, 0.05)]);
//! ```

use crate::math::{Real, Vector};
use rayon::prelude::*;

/// Points binned by cell, with the buffers reused from build to build.
#[derive(Clone, Debug, Default)]
pub struct CellList<const D: usize> {
    grid: CellGrid<D>,
    /// Cell of every point.
    cell_of: Vec<usize>,
    /// Points of cell `c`: `order[start[c]..start[c + 1]]`.
    start: Vec<usize>,
    /// Point indices sorted by cell, ascending within a cell.
    order: Vec<usize>,
}

impl<const D: usize> CellList<D> {
    /// Largest number of cells along one axis.
    pub const MAX_CELLS_PER_AXIS: usize = 1 << 12;
    /// Cells always allowed in all, whatever the number of points.
    pub const MIN_CELL_BUDGET: usize = 1 << 20;
    /// Cells allowed per point beyond [`MIN_CELL_BUDGET`](Self::MIN_CELL_BUDGET).
    pub const CELLS_PER_POINT: usize = 64;

    /// Bins the points `x` (m) into cells of edge `cell` (m; raised to a tiny positive length if
    /// it is not positive, and beyond it only by the memory bounds of the module).
    pub fn build(&mut self, x: &[Vector<D>], cell: Real) {
        let budget = Self::MIN_CELL_BUDGET.max(Self::CELLS_PER_POINT.saturating_mul(x.len()));
        self.grid = CellGrid::covering(x, cell, budget);
        let grid = &self.grid;
        x.par_iter()
            .map(|xp| grid.cell(xp))
            .collect_into_vec(&mut self.cell_of);
        let count = grid.count();
        let start = &mut self.start;
        start.clear();
        start.resize(count + 1, 0);
        for &c in &self.cell_of {
            start[c + 1] += 1;
        }
        for c in 0..count {
            start[c + 1] += start[c];
        }
        // Fill with start[c] as the cursor of cell c, which leaves it at the start of c + 1;
        // then shift back.
        self.order.clear();
        self.order.resize(x.len(), 0);
        for (p, &c) in self.cell_of.iter().enumerate() {
            self.order[start[c]] = p;
            start[c] += 1;
        }
        for c in (1..=count).rev() {
            start[c] = start[c - 1];
        }
        start[0] = 0;
    }

    /// Edge length of the cells (m): the `cell` given to [`build`](Self::build) unless a memory
    /// bound made it larger.
    pub fn cell_size(&self) -> Real {
        self.grid.h
    }

    /// Number of cells.
    pub fn cell_count(&self) -> usize {
        self.grid.count()
    }

    /// Number of points binned.
    pub fn len(&self) -> usize {
        self.cell_of.len()
    }

    /// Whether no point is binned.
    pub fn is_empty(&self) -> bool {
        self.cell_of.is_empty()
    }

    /// Calls `f(q)` for every candidate neighbour `q` of point `p`: the points of the `3^D`
    /// cells around `p`'s cell (clipped to the grid), `p` itself included, cell by cell in a
    /// fixed order and by ascending index within a cell. Every point within
    /// [`cell_size`](Self::cell_size) of `p` is visited (up to round-off at exactly that
    /// distance).
    pub fn for_each_candidate(&self, p: usize, f: impl FnMut(usize)) {
        self.visit(self.cell_of[p], f);
    }

    /// Like [`for_each_candidate`](Self::for_each_candidate) for an arbitrary position `x` (m),
    /// inside the points' bounding box or not.
    pub fn for_each_candidate_near(&self, x: &Vector<D>, f: impl FnMut(usize)) {
        self.visit(self.grid.cell(x), f);
    }

    /// Calls `f(q, x_q − x_p, ‖x_q − x_p‖)` for every point `q ≠ p` with
    /// `‖x_q − x_p‖ ≤ radius` (m), in the order of
    /// [`for_each_candidate`](Self::for_each_candidate). `x` must be the positions of the last
    /// build.
    ///
    /// # Panics
    /// If `radius` exceeds [`cell_size`](Self::cell_size).
    pub fn for_each_within(
        &self,
        x: &[Vector<D>],
        p: usize,
        radius: Real,
        mut f: impl FnMut(usize, Vector<D>, Real),
    ) {
        assert!(
            radius <= self.grid.h,
            "search radius {radius} m exceeds the cell size {} m",
            self.grid.h
        );
        let xp = x[p];
        self.for_each_candidate(p, |q| {
            if q == p {
                return;
            }
            let d = x[q] - xp;
            let dist = d.norm();
            if dist <= radius {
                f(q, d, dist);
            }
        });
    }

    /// Bytes held (lengths, not capacities).
    pub fn bytes(&self) -> usize {
        (self.cell_of.len() + self.start.len() + self.order.len()) * std::mem::size_of::<usize>()
    }

    fn visit(&self, cell: usize, mut f: impl FnMut(usize)) {
        self.grid.for_neighbour_cells(cell, |c| {
            for &q in &self.order[self.start[c]..self.start[c + 1]] {
                f(q);
            }
        });
    }
}

/// A uniform grid of cells over the bounding box of the points.
#[derive(Clone, Copy, Debug)]
struct CellGrid<const D: usize> {
    origin: Vector<D>,
    h: Real,
    dims: [usize; D],
}

impl<const D: usize> Default for CellGrid<D> {
    fn default() -> Self {
        Self {
            origin: Vector::<D>::zeros(),
            h: 0.0,
            dims: [1; D],
        }
    }
}

impl<const D: usize> CellGrid<D> {
    /// Cells of edge `h` (m; at least a tiny positive length) covering every position, at most
    /// `MAX_CELLS_PER_AXIS` per axis and `budget` in all.
    fn covering(x: &[Vector<D>], h: Real, budget: usize) -> Self {
        let mut lo = Vector::<D>::from_element(Real::INFINITY);
        let mut hi = Vector::<D>::from_element(Real::NEG_INFINITY);
        for xp in x {
            lo = lo.inf(xp);
            hi = hi.sup(xp);
        }
        if x.is_empty() {
            lo = Vector::<D>::zeros();
            hi = Vector::<D>::zeros();
        }
        let extent = (hi - lo).max();
        let mut h = h
            .max(extent / CellList::<D>::MAX_CELLS_PER_AXIS as Real)
            .max(Real::MIN_POSITIVE);
        let dims_for =
            |h: Real| -> [usize; D] { std::array::from_fn(|a| ((hi[a] - lo[a]) / h) as usize + 1) };
        let count = |dims: &[usize; D]| dims.iter().fold(1usize, |n, &d| n.saturating_mul(d));
        let mut dims = dims_for(h);
        let excess = count(&dims) as Real / budget as Real;
        if excess > 1.0 {
            h *= excess.powf(1.0 / D as Real);
            dims = dims_for(h);
            while count(&dims) > budget {
                h *= 1.125;
                dims = dims_for(h);
            }
        }
        Self {
            origin: lo,
            h,
            dims,
        }
    }

    fn count(&self) -> usize {
        self.dims.iter().product()
    }

    fn coords(&self, x: &Vector<D>) -> [usize; D] {
        std::array::from_fn(|a| {
            (((x[a] - self.origin[a]) / self.h).max(0.0) as usize).min(self.dims[a] - 1)
        })
    }

    fn cell(&self, x: &Vector<D>) -> usize {
        self.linear(&self.coords(x))
    }

    fn linear(&self, c: &[usize; D]) -> usize {
        let mut idx = 0;
        let mut stride = 1;
        for a in 0..D {
            idx += c[a] * stride;
            stride *= self.dims[a];
        }
        idx
    }

    /// Calls `f` for the cell `cell` and its neighbours (3^D block clipped to the grid), in a
    /// fixed order.
    fn for_neighbour_cells(&self, cell: usize, mut f: impl FnMut(usize)) {
        let mut c = [0usize; D];
        let mut r = cell;
        for a in 0..D {
            c[a] = r % self.dims[a];
            r /= self.dims[a];
        }
        for k in 0..3usize.pow(D as u32) {
            let mut m = k;
            let mut nb = [0usize; D];
            let mut inside = true;
            for a in 0..D {
                let off = (m % 3) as i64 - 1;
                m /= 3;
                let v = c[a] as i64 + off;
                inside &= v >= 0 && v < self.dims[a] as i64;
                nb[a] = v.max(0) as usize;
            }
            if inside {
                f(self.linear(&nb));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::Lcg;

    fn points<const D: usize>(n: usize, seed: u64) -> Vec<Vector<D>> {
        let mut r = Lcg(seed);
        (0..n)
            .map(|_| Vector::<D>::from_fn(|_, _| r.next()))
            .collect()
    }

    /// Pairs `(p, q)`, `p < q`, with `‖x_q − x_p‖ ≤ radius`, by testing all of them.
    fn brute_force<const D: usize>(x: &[Vector<D>], radius: Real) -> Vec<(usize, usize)> {
        let mut pairs = Vec::new();
        for p in 0..x.len() {
            for q in p + 1..x.len() {
                if (x[q] - x[p]).norm() <= radius {
                    pairs.push((p, q));
                }
            }
        }
        pairs
    }

    /// The same pairs from the cell list, each seen from both ends.
    fn searched<const D: usize>(
        cells: &CellList<D>,
        x: &[Vector<D>],
        radius: Real,
    ) -> Vec<(usize, usize)> {
        let mut pairs = Vec::new();
        let mut mirrored = Vec::new();
        for p in 0..x.len() {
            let mut found = Vec::new();
            cells.for_each_within(x, p, radius, |q, d, dist| {
                assert_eq!(d, x[q] - x[p]);
                assert_eq!(dist, d.norm());
                found.push(q);
            });
            let mut sorted = found.clone();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(sorted.len(), found.len(), "each neighbour once");
            pairs.extend(sorted.iter().filter(|&&q| q > p).map(|&q| (p, q)));
            mirrored.extend(sorted.iter().filter(|&&q| q < p).map(|&q| (q, p)));
        }
        mirrored.sort_unstable();
        assert_eq!(pairs, mirrored, "symmetric");
        pairs
    }

    fn matches_brute_force<const D: usize>() {
        let x = points::<D>(1500, 21 + D as u64);
        let mut cells = CellList::default();
        let mut counts = Vec::new();
        for radius in [0.012, 0.03, 0.11, 0.4, 1.5] {
            cells.build(&x, radius);
            assert_eq!(cells.cell_size(), radius, "no memory bound applies");
            assert_eq!(cells.len(), x.len());
            let pairs = searched(&cells, &x, radius);
            assert_eq!(pairs, brute_force(&x, radius), "D = {D}, radius {radius}");
            counts.push(pairs.len());
        }
        // From a handful of pairs to all of them (the diagonal of the unit cube is ≤ √3).
        assert!(counts[1] > 20 && counts[1] < counts[2], "{counts:?}");
        if D == 2 {
            assert_eq!(counts[4], 1500 * 1499 / 2);
        }
        // Candidates of a point: each once, the point itself among them, ascending per cell.
        let mut seen = Vec::new();
        cells.build(&x, 0.11);
        cells.for_each_candidate(7, |q| seen.push(q));
        assert!(seen.contains(&7));
        let mut sorted = seen.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), seen.len());
        let mut near = Vec::new();
        cells.for_each_candidate_near(&x[7], |q| near.push(q));
        assert_eq!(near, seen);
    }

    #[test]
    fn cell_list_finds_exactly_the_brute_force_pairs() {
        matches_brute_force::<2>();
        matches_brute_force::<3>();
    }

    fn far_flung<const D: usize>() {
        let mut x = points::<D>(1000, 5);
        let radius = 0.01;
        let mut cells = CellList::default();
        // Two points far out along the diagonal: the per-axis bound alone would allow 4097^D
        // cells.
        x[10] = Vector::<D>::from_element(1e9);
        x[20] = Vector::<D>::from_element(-1e9);
        cells.build(&x, radius);
        let budget = CellList::<D>::MIN_CELL_BUDGET;
        assert!(cells.cell_count() <= budget, "{} cells", cells.cell_count());
        assert!(
            cells.cell_count() > budget / 8,
            "{} cells",
            cells.cell_count()
        );
        assert!(cells.bytes() <= (budget + 1 + 2 * 1000) * std::mem::size_of::<usize>());
        assert_eq!(searched(&cells, &x, radius), brute_force(&x, radius));
        // One point far out along an axis: the per-axis bound holds the cells, 4097 along x and
        // one along the others.
        x[10] = x[11];
        x[20] = x[21];
        x[20][0] = -3e12;
        cells.build(&x, radius);
        assert!(cells.cell_count() <= CellList::<D>::MAX_CELLS_PER_AXIS + 1);
        assert!(cells.cell_count() >= CellList::<D>::MAX_CELLS_PER_AXIS);
        assert!(cells.cell_size() >= 3e12 / 4096.0);
        assert_eq!(searched(&cells, &x, radius), brute_force(&x, radius));
    }

    #[test]
    fn far_flung_points_do_not_blow_up_memory() {
        far_flung::<2>();
        far_flung::<3>();
    }

    #[test]
    fn empty_and_coincident_points() {
        let mut cells = CellList::<3>::default();
        cells.build(&[], 0.1);
        assert!(cells.is_empty());
        assert_eq!(cells.cell_count(), 1);
        let mut visited = 0;
        cells.for_each_candidate_near(&Vector::<3>::zeros(), |_| visited += 1);
        assert_eq!(visited, 0);
        let x = vec![Vector::<3>::new(1.0, 2.0, 3.0); 4];
        cells.build(&x, 0.0);
        assert_eq!(cells.cell_count(), 1);
        let mut found = Vec::new();
        cells.for_each_within(&x, 2, 0.0, |q, _, dist| found.push((q, dist)));
        assert_eq!(found, vec![(0, 0.0), (1, 0.0), (3, 0.0)]);
    }
}
