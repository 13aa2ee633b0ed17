//! Background grid geometry, the sparse block layout of node storage, and node storage.

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

    /// Whether a particle at `x` (m) has its whole `kernel` stencil inside the grid. For one
    /// position: it finds the range's bounds on every call, where a loop over particles should
    /// build [`Self::stencil_range`] once.
    #[inline]
    pub fn contains_stencil(&self, kernel: Kernel, x: &Vector<D>) -> bool {
        self.stencil_range(kernel).contains(self, x)
    }

    /// The positions at which a particle has its whole `kernel` stencil inside the grid, as
    /// bounds on the offset from the origin (m), for testing many particles with
    /// [`StencilRange::contains`].
    pub fn stencil_range(&self, kernel: Kernel) -> StencilRange<D> {
        let lo = kernel.lower_margin();
        let hi = |a: usize| (self.size[a] - kernel.support()) as Real + lo + 1.0;
        StencilRange {
            lo: first_offset_reaching(lo, self.dx),
            hi: std::array::from_fn(|a| first_offset_reaching(hi(a), self.dx)),
        }
    }
}

/// The smallest offset `t` (m) whose grid-unit coordinate, the rounded quotient `t / dx`,
/// is at least `q`. Division by `dx > 0` rounds monotonically, so `t / dx >= q` holds exactly
/// for the offsets from this one up: comparing offsets with it decides what comparing the
/// quotients with `q` decides, without a division per test. Found by bisection over the
/// doubles in their order (at most 64 divisions, whatever `q` and `dx`); for a `dx` that is not
/// finite and positive, or a `q` that is not finite (no grid a solver accepts), the product
/// `q dx` is returned instead.
fn first_offset_reaching(q: Real, dx: Real) -> Real {
    if !(dx > 0.0 && dx.is_finite() && q.is_finite()) {
        return q * dx;
    }
    let reaches = |t: Real| t / dx >= q;
    // −∞ does not reach the finite q, +∞ does; keep that bracket and halve it.
    let (mut below, mut at) = (ordered(Real::NEG_INFINITY), ordered(Real::INFINITY));
    while at - below > 1 {
        let mid = below + (at - below) / 2;
        if reaches(from_ordered(mid)) {
            at = mid;
        } else {
            below = mid;
        }
    }
    from_ordered(at)
}

/// The position of the non-NaN double `t` in the order of the doubles, as an integer that
/// grows with `t` (−0 just below +0).
fn ordered(t: Real) -> i128 {
    let bits = t.to_bits() as i64;
    i128::from(bits ^ ((bits >> 63) & i64::MAX))
}

/// The double at position `k` of [`ordered`].
fn from_ordered(k: i128) -> Real {
    let k = k as i64;
    Real::from_bits((k ^ ((k >> 63) & i64::MAX)) as u64)
}

/// Where a particle has its whole stencil inside a grid: `lo ≤ x̂_a < hi[a]` along every axis,
/// `x̂ = (x − origin)/dx` in grid units ([`GridSpec::stencil_range`]), with `lo` the kernel's
/// lower margin and `hi[a]` the exclusive bound of axis `a`. Held as the offsets
/// `x_a − origin_a` (m) at which those bounds are first reached, so a test divides nothing and
/// decides exactly as the quotients would.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StencilRange<const D: usize> {
    /// Smallest offset from the grid origin (m) whose grid-unit coordinate reaches `lo`.
    lo: Real,
    /// Smallest offset from the grid origin along each axis (m) whose grid-unit coordinate
    /// reaches `hi[a]` (excluded).
    hi: [Real; D],
}

impl<const D: usize> StencilRange<D> {
    /// Whether a particle at `x` (m) of grid `spec` (the grid of this range) has its whole
    /// stencil inside the grid; false for non-finite positions (an infinite offset lies beyond
    /// one of the finite bounds, and NaN compares false).
    #[inline]
    pub fn contains(&self, spec: &GridSpec<D>, x: &Vector<D>) -> bool {
        (0..D).all(|a| {
            let t = x[a] - spec.origin[a];
            t >= self.lo && t < self.hi[a]
        })
    }
}

/// Which nodes of a grid are stored, and where: the sparse grid.
///
/// The grid is cut into blocks of `B^D` nodes ([`Self::BLOCK`] = `B` = 16 in 2D, 8 in 3D,
/// the cell blocks of [`crate::scatter::Blocks`]); only the *active* blocks are stored, one
/// after another in ascending block id (block coordinates first-axis fastest), each block's
/// nodes first-axis fastest. Storage and every pass over the nodes therefore grow with the
/// blocks that hold material, not with the domain: a cube of material in a 512³ domain costs
/// what it costs in a 64³ one. A solver marks the blocks its scatters and gathers reach
/// ([`Self::begin`], [`Self::mark`], [`Self::finish`]) before each step's transfers; node
/// arrays (a [`GridNodes`]) then have [`Self::len`] entries, and [`Self::index`] and
/// [`Self::node`] translate between a node's multi-index and its storage index. Nodes of an
/// active block that lie beyond the grid's last node are stored but never receive anything.
#[derive(Clone, Debug)]
pub struct NodeLayout<const D: usize> {
    /// Nodes per axis of the grid.
    size: [usize; D],
    /// Blocks per axis.
    dims: [usize; D],
    /// Storage slot of each block of the grid ([`Self::INACTIVE`] for blocks not stored); while
    /// marking, [`Self::MARKED`] for the marked ones.
    slot: Vec<u32>,
    /// The active block ids: ascending after [`Self::finish`] (slot `s` holds block
    /// `active[s]`), in marking order before.
    active: Vec<u32>,
    /// First node of the block in each slot, set by [`Self::finish`].
    origins: Vec<[i64; D]>,
}

impl<const D: usize> Default for NodeLayout<D> {
    fn default() -> Self {
        Self {
            size: [0; D],
            dims: [0; D],
            slot: Vec::new(),
            active: Vec::new(),
            origins: Vec::new(),
        }
    }
}

impl<const D: usize> NodeLayout<D> {
    /// Block edge length in nodes (16 in 2D, 8 in 3D).
    pub const BLOCK: usize = if D == 2 { 16 } else { 8 };
    /// Nodes per block, `BLOCK^D`.
    pub const BLOCK_NODES: usize = Self::BLOCK.pow(D as u32);
    const INACTIVE: u32 = u32::MAX;
    const MARKED: u32 = u32::MAX - 1;

    /// Every block of `spec` active: the dense grid in block order.
    pub fn dense(spec: &GridSpec<D>) -> Self {
        let mut layout = Self::default();
        layout.begin(spec);
        for id in 0..layout.slot.len() {
            layout.mark(layout.block_coords(id));
        }
        layout.finish();
        layout
    }

    /// Starts a new layout for `spec` with no active block (reuses the allocations).
    pub fn begin(&mut self, spec: &GridSpec<D>) {
        self.size = spec.size;
        self.dims = std::array::from_fn(|a| spec.size[a].div_ceil(Self::BLOCK));
        let blocks: usize = self.dims.iter().product();
        debug_assert!(blocks < Self::MARKED as usize);
        self.slot.clear();
        self.slot.resize(blocks, Self::INACTIVE);
        self.active.clear();
    }

    /// Blocks per axis.
    pub fn dims(&self) -> [usize; D] {
        self.dims
    }

    /// Marks the block with block coordinates `coords` active; coordinates beyond the grid
    /// (negative or past the last block) are ignored.
    #[inline]
    pub fn mark(&mut self, coords: [i64; D]) {
        let Some(id) = self.block_id(&coords) else {
            return;
        };
        if self.slot[id] == Self::INACTIVE {
            self.slot[id] = Self::MARKED;
            self.active.push(id as u32);
        }
    }

    /// The blocks marked so far, in marking order (ascending block id after [`Self::finish`]).
    pub fn active(&self) -> &[u32] {
        &self.active
    }

    /// Ends the marking: the marked blocks get storage slots in ascending block id.
    pub fn finish(&mut self) {
        self.active.sort_unstable();
        self.origins.clear();
        for (s, &id) in self.active.iter().enumerate() {
            self.slot[id as usize] = s as u32;
            let c = self.block_coords(id as usize);
            self.origins
                .push(std::array::from_fn(|a| c[a] * Self::BLOCK as i64));
        }
    }

    /// Block coordinates of block `id`.
    #[inline]
    pub fn block_coords(&self, mut id: usize) -> [i64; D] {
        let mut c = [0i64; D];
        for a in 0..D {
            c[a] = (id % self.dims[a]) as i64;
            id /= self.dims[a];
        }
        c
    }

    /// Id of the block with block coordinates `coords` (first axis fastest), or `None` beyond
    /// the grid; the inverse of [`Self::block_coords`].
    #[inline]
    pub fn block_id(&self, coords: &[i64; D]) -> Option<usize> {
        let mut id = 0usize;
        let mut stride = 1usize;
        for a in 0..D {
            let c = coords[a];
            if c < 0 || c as usize >= self.dims[a] {
                return None;
            }
            id += c as usize * stride;
            stride *= self.dims[a];
        }
        Some(id)
    }

    /// Storage slot of the block with coordinates `coords`, if it is active.
    #[inline]
    pub fn slot_of(&self, coords: &[i64; D]) -> Option<usize> {
        match self.slot[self.block_id(coords)?] {
            s if s < Self::MARKED => Some(s as usize),
            _ => None,
        }
    }

    /// Number of stored nodes: active blocks × [`Self::BLOCK_NODES`].
    pub fn len(&self) -> usize {
        self.active.len() * Self::BLOCK_NODES
    }

    /// Whether no node is stored.
    pub fn is_empty(&self) -> bool {
        self.active.is_empty()
    }

    /// First node (multi-index) of the block in storage slot `slot` (after [`Self::finish`]).
    #[inline]
    pub fn slot_origin(&self, slot: usize) -> [i64; D] {
        self.origins[slot]
    }

    /// Storage index of the grid node `node`, or `None` when it lies outside the grid or in an
    /// inactive block.
    #[inline]
    pub fn index(&self, node: &[i64; D]) -> Option<usize> {
        let b = Self::BLOCK as i64;
        let mut coords = [0i64; D];
        let mut local = 0usize;
        let mut stride = 1usize;
        for a in 0..D {
            let n = node[a];
            if n < 0 || n as usize >= self.size[a] {
                return None;
            }
            coords[a] = n / b;
            local += (n % b) as usize * stride;
            stride *= Self::BLOCK;
        }
        Some(self.slot_of(&coords)? * Self::BLOCK_NODES + local)
    }

    /// Multi-index of the node at storage index `i`.
    #[inline]
    pub fn node(&self, i: usize) -> [i64; D] {
        let mut node = self.slot_origin(i / Self::BLOCK_NODES);
        let mut local = i % Self::BLOCK_NODES;
        for n in node.iter_mut() {
            *n += (local % Self::BLOCK) as i64;
            local /= Self::BLOCK;
        }
        node
    }

    /// Bytes held (lengths, not capacities).
    pub fn bytes(&self) -> usize {
        (self.slot.len() + self.active.len()) * std::mem::size_of::<u32>()
            + self.origins.len() * std::mem::size_of::<[i64; D]>()
    }
}

/// Per-node storage of one grid (one phase), in the order of a [`NodeLayout`].
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
    /// Zeroed storage for the nodes of `layout` (reuses existing allocations).
    pub fn reset(&mut self, layout: &NodeLayout<D>) {
        let n = layout.len();
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

    /// The offset bounds decide as the grid-unit quotients they replace: for several cell
    /// sizes and origins, every kernel, and positions at, next to and around each bound as
    /// well as spread over the grid and beyond it, and non-finite ones; and the order of the
    /// doubles that the bisection finding the bounds walks agrees with the standard library's
    /// neighbours.
    #[test]
    fn stencil_range_decides_as_the_quotient_test() {
        use crate::test_util::Lcg;
        let quotient = |spec: &GridSpec<2>, kernel: Kernel, x: &Vector<2>| {
            let lo = kernel.lower_margin();
            (0..2).all(|a| {
                let hi = (spec.size[a] - kernel.support()) as Real + lo + 1.0;
                let xh = (x[a] - spec.origin[a]) / spec.dx;
                xh.is_finite() && xh >= lo && xh < hi
            })
        };
        let mut rng = Lcg(7);
        let (mut tested, mut inside, mut at_bounds) = (0, 0, 0);
        // 1e20: the linear kernel's bound 0 sits among offsets whose quotients underflow to
        // −0, which a walk by single ulps would take about 1e20 steps to cross.
        for dx in [0.1, 1.0 / 64.0, 0.03, 1e-3, 0.7, 3.3, 1e20] {
            for origin in [0.0, -0.35, 1.0 / 3.0, 12.5] {
                let spec = GridSpec::<2>::new(Vector::<2>::new(origin, -origin), dx, [37, 20]);
                for kernel in [Kernel::Linear, Kernel::Quadratic, Kernel::Cubic] {
                    let range = spec.stencil_range(kernel);
                    let mut check = |x: Vector<2>| {
                        let same = range.contains(&spec, &x) == quotient(&spec, kernel, &x);
                        assert!(same, "{x:?} dx {dx} origin {origin} {kernel:?}");
                        tested += 1;
                        inside += usize::from(range.contains(&spec, &x));
                    };
                    for a in 0..2 {
                        let mid = spec.origin[1 - a] + 5.0 * dx;
                        for bound in [range.lo, range.hi[a]] {
                            // Positions one ulp apart around the bound.
                            let mut xa = spec.origin[a] + bound;
                            for _ in 0..4 {
                                xa = xa.next_down();
                            }
                            for _ in 0..9 {
                                let mut x = Vector::<2>::repeat(mid);
                                x[a] = xa;
                                check(x);
                                at_bounds += 1;
                                xa = xa.next_up();
                            }
                        }
                    }
                    for _ in 0..2000 {
                        let x = Vector::<2>::from_fn(|a, _| {
                            spec.origin[a] + (rng.next() * 1.2 - 0.1) * spec.size[a] as Real * dx
                        });
                        check(x);
                    }
                    for v in [Real::NAN, Real::INFINITY, Real::NEG_INFINITY, 1e308, -1e308] {
                        check(Vector::<2>::new(v, spec.origin[1] + 5.0 * dx));
                        check(Vector::<2>::new(spec.origin[0] + 5.0 * dx, v));
                    }
                }
            }
        }
        assert_eq!(at_bounds, 7 * 4 * 3 * 2 * 2 * 9);
        // The order of the doubles that the bisection walks: adjacent doubles at adjacent
        // positions, and back again bit for bit.
        for t in [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.1,
            -3.7e-5,
            2.5e300,
            Real::from_bits(1),
            Real::MAX,
            Real::INFINITY,
            Real::NEG_INFINITY,
        ] {
            assert_eq!(from_ordered(ordered(t)).to_bits(), t.to_bits(), "{t}");
            // (−0 and +0 hold two positions, so the zeros' neighbours are one further.)
            if t.is_finite() && t != 0.0 {
                assert_eq!(ordered(t.next_up()), ordered(t) + 1, "{t}");
                assert_eq!(ordered(t.next_down()), ordered(t) - 1, "{t}");
            }
        }
        // A grid no solver accepts still gives an answer (nothing inside) instead of a hang.
        let nan = GridSpec::<2>::new(Vector::<2>::zeros(), Real::NAN, [37, 20]);
        assert!(!nan
            .stencil_range(Kernel::Quadratic)
            .contains(&nan, &Vector::<2>::repeat(1.0)));
        // Both outcomes occur often: the comparison is not vacuous.
        assert!(
            inside > tested / 4 && inside < tested * 3 / 4,
            "{inside} of {tested}"
        );
    }

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
