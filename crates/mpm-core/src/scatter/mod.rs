//! Deterministic parallel particle-to-grid scatter with any set of node channels.
//!
//! [`Blocks`] bins particles by the grid block (`B^D` cells, `B` = 16 in 2D and 8 in 3D) that
//! holds the first node of their kernel stencil: a counting sort, stable in particle index.
//! [`Blocks::scatter`] then lets every non-empty block scatter its particles, in index order,
//! into a private buffer covering the block's nodes plus the stencil overhang; blocks run in
//! parallel. The buffers are then added to the grid in slabs of `B` node layers along the last
//! axis, slabs in parallel, each node receiving its contributions in ascending block order (the
//! order of a serial pass over the blocks). Every node therefore receives its contributions in an
//! order fixed by the particle positions alone, so the sums are bitwise identical for any thread
//! count. No atomics on floats are involved.
//!
//! What is scattered is chosen by the caller: a tuple of one to six per-node arrays (the
//! *channels*), each of any [`NodeValue`] type (`Real`, `Vector<D>`, counters, …). The first
//! channel is the *gate*: it is always scattered, and a buffer node whose gate value is still
//! zero ([`NodeValue::zero`]) is taken to have received nothing and is not added to the grid, so it
//! should be a sum of non-negative weights such as a mass or a volume. The other channels may be
//! `Option<&mut Vec<T>>`; `None` skips the channel (its block buffers stay empty).
//!
//! ```
//! use mpm_core::scatter::{BlockBuffers, Blocks};
//! use mpm_core::{GridSpec, Kernel, NodeLayout, Real, Stencil, Vector};
//!
//! let spec = GridSpec::<2>::new(Vector::<2>::zeros(), 0.1, [21, 21]);
//! let (x, m, v) = (
//!     vec![Vector::<2>::new(0.52, 0.31)],
//!     vec![2.0],
//!     vec![Vector::<2>::new(1.0, 0.0)],
//! );
//! let mut blocks = Blocks::default();
//! blocks.sort(&spec, Kernel::Quadratic, &x);
//! // The sparse grid: only the blocks the particles reach are stored.
//! let mut layout = NodeLayout::default();
//! layout.begin(&spec);
//! blocks.mark(&mut layout);
//! layout.finish();
//! let mut buffers = BlockBuffers::default();
//! let (mut mass, mut momentum) = (Vec::<Real>::new(), Vec::<Vector<2>>::new());
//! blocks.scatter(&mut buffers, &layout, (&mut mass, &mut momentum), |p, window, (mb, pb)| {
//!     Stencil::new(Kernel::Quadratic, &spec, &x[p]).for_each(|node, w, _| {
//!         let k = window.local(&node);
//!         mb[k] += w * m[p];
//!         pb[k] += v[p] * (w * m[p]);
//!     });
//! });
//! assert!((mass.iter().sum::<Real>() - 2.0).abs() < 1e-14);
//! assert!((momentum.iter().sum::<Vector<2>>().x - 2.0).abs() < 1e-14);
//! let node = layout.index(&[5, 3]).unwrap(); // the node nearest to the particle
//! assert!(mass[node] > 0.5);
//! ```

use crate::grid::{GridSpec, NodeLayout};
use crate::kernel::Kernel;
use crate::math::{for_each_index, Vector};
use rayon::prelude::*;

mod channels;

pub use channels::{BlockStorage, Channels, NodeValue, Output};

/// The nodes a block's buffer covers: a box of `width^D` nodes starting at grid node `origin`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BlockWindow<const D: usize> {
    origin: [i64; D],
    width: usize,
}

impl<const D: usize> BlockWindow<D> {
    /// First grid node (multi-index) of the window.
    pub fn origin(&self) -> [i64; D] {
        self.origin
    }

    /// Nodes per axis.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Number of nodes, `width^D`.
    pub fn len(&self) -> usize {
        self.width.pow(D as u32)
    }

    /// Whether the window has no nodes (never for a window a scatter passes to its closure).
    pub fn is_empty(&self) -> bool {
        self.width == 0
    }

    /// Index steps of the block's buffers along each axis: node `n` is at
    /// `Σ_a (n_a − origin_a) strides[a]` ([`Self::local`]).
    #[inline]
    pub fn strides(&self) -> [usize; D] {
        std::array::from_fn(|a| self.width.pow(a as u32))
    }

    /// Index into the block's buffers of grid node `node`, which must lie in the window (every
    /// node of the stencil of a particle binned in this block does).
    #[inline]
    pub fn local(&self, node: &[i64; D]) -> usize {
        let mut idx = 0;
        let mut stride = 1;
        for a in 0..D {
            idx += (node[a] - self.origin[a]) as usize * stride;
            stride *= self.width;
        }
        idx
    }

    /// Grid multi-index of buffer index `k` (the inverse of [`local`](Self::local)).
    #[inline]
    pub fn node(&self, mut k: usize) -> [i64; D] {
        let mut node = [0i64; D];
        for a in 0..D {
            node[a] = self.origin[a] + (k % self.width) as i64;
            k /= self.width;
        }
        node
    }
}

/// Per-block buffers of one channel set, reused from scatter to scatter. Several channel sets
/// with the same storage type can share one `BlockBuffers`.
#[derive(Clone, Debug)]
pub struct BlockBuffers<S> {
    blocks: Vec<S>,
    used: usize,
}

impl<S> Default for BlockBuffers<S> {
    fn default() -> Self {
        Self {
            blocks: Vec::new(),
            used: 0,
        }
    }
}

impl<S: BlockStorage> BlockBuffers<S> {
    /// Bytes held by the buffers of the last scatter (lengths, not capacities).
    pub fn bytes(&self) -> usize {
        self.blocks[..self.used].iter().map(S::bytes).sum()
    }

    /// The buffers of the `r`-th non-empty block of the last scatter or window load (the index
    /// [`Blocks::window_of`] gives).
    #[inline]
    pub fn get(&self, r: usize) -> &S {
        &self.blocks[r]
    }
}

/// Particle binning by grid block, reused from step to step.
#[derive(Clone, Debug)]
pub struct Blocks<const D: usize> {
    /// Grid and kernel of the last sort.
    grid: Option<(GridSpec<D>, Kernel)>,
    dims: [usize; D],
    /// Per particle: its block id while sorting, then its range (index into `ranges`);
    /// `u32::MAX`: not binned.
    range_of: Vec<u32>,
    /// Per run of particles (one per thread), per block: particle count, then a cursor.
    counts: Vec<Vec<u32>>,
    /// Per block: its index in `ranges`, `u32::MAX` when empty.
    rank: Vec<u32>,
    /// Binned particle indices, sorted by block.
    order: Vec<u32>,
    /// Non-empty blocks: (block id, start, end) ranges into `order`, ascending in block id.
    ranges: Vec<(usize, usize, usize)>,
    /// First node of each non-empty block (the origin of its window), in the order of `ranges`.
    origins: Vec<[i64; D]>,
}

impl<const D: usize> Default for Blocks<D> {
    fn default() -> Self {
        Self {
            grid: None,
            dims: [0; D],
            range_of: Vec::new(),
            counts: Vec::new(),
            rank: Vec::new(),
            order: Vec::new(),
            ranges: Vec::new(),
            origins: Vec::new(),
        }
    }
}

impl<const D: usize> Blocks<D> {
    /// Block edge length in cells (16 in 2D, 8 in 3D): large enough to amortise the overhang,
    /// small enough for load balance; the blocks of the sparse grid ([`NodeLayout::BLOCK`]).
    pub const BLOCK_CELLS: usize = NodeLayout::<D>::BLOCK;

    /// How many particles ahead in its block's order [`Self::scatter_prefetching`] announces a
    /// particle: about the memory latency over the time one particle takes (3D P2G, 1 thread,
    /// `p2g/3d_256k`: 26.1 ms without hints, 24.6 ms 8 ahead, 24.3 ms 16 ahead).
    pub const PREFETCH_AHEAD: usize = 16;

    /// Bins every particle at positions `x` (m) for scatters with `kernel` onto `spec`. Every
    /// position must have its stencil inside the grid.
    pub fn sort(&mut self, spec: &GridSpec<D>, kernel: Kernel, x: &[Vector<D>]) {
        self.sort_where(spec, kernel, x, |_| true);
    }

    /// Bins the particles `p` at positions `x` (m) with `keep(p)`; the others take part in no
    /// scatter. Every kept position must have its stencil inside the grid. Particle and block
    /// indices are stored as `u32`: fewer than 2³² − 1 of each (checked in debug builds).
    pub fn sort_where(
        &mut self,
        spec: &GridSpec<D>,
        kernel: Kernel,
        x: &[Vector<D>],
        keep: impl Fn(usize) -> bool + Sync,
    ) {
        let b = Self::BLOCK_CELLS;
        self.grid = Some((*spec, kernel));
        self.dims = std::array::from_fn(|a| spec.size[a].div_ceil(b));
        let nblocks: usize = self.dims.iter().product();
        debug_assert!(nblocks < u32::MAX as usize && x.len() < u32::MAX as usize);
        let inv_dx = 1.0 / spec.dx;
        let dims = self.dims;
        // A stable counting sort in parallel: the particles are cut into one run per thread;
        // each run bins its particles and counts them per block, the runs' counts give each
        // (block, run) pair its slice of `order`, and each run fills its slices in index order.
        // The result is that of a serial pass for any number of runs.
        let n = x.len();
        let run_len = n.div_ceil(rayon::current_num_threads()).max(1);
        let runs = n.div_ceil(run_len);
        self.counts.resize_with(runs, Vec::new);
        self.counts.truncate(runs);
        self.range_of.resize(n, 0);
        self.range_of
            .par_chunks_mut(run_len)
            .zip(self.counts.par_iter_mut())
            .enumerate()
            .for_each(|(c, (ids, counts))| {
                counts.clear();
                counts.resize(nblocks, 0);
                // Local copies: read through the closure's captures, they were reloaded from
                // memory for every particle, after each store of an id.
                let (origin, inv_dx, dims) = (spec.origin, inv_dx, dims);
                let margin = kernel.lower_margin();
                // Counted by runs of equal blocks (consecutive particles mostly share one):
                // one addition per run instead of a chain of increments of the same counter.
                let mut count = |(id, len): (u32, u32)| {
                    if id != u32::MAX {
                        counts[id as usize] += len;
                    }
                };
                let mut run = (u32::MAX, 0);
                let first = c * run_len;
                for ((p, slot), xp) in (first..).zip(ids.iter_mut()).zip(&x[first..]) {
                    let id = if keep(p) {
                        let (mut id, mut stride) = (0, 1);
                        for a in 0..D {
                            let xh = (xp[a] - origin[a]) * inv_dx;
                            let base = Kernel::clamped_base_node(margin, xh);
                            // The constant itself, not the copy `b` the closure would
                            // capture: rayon calls the closure out of line, where `b` is a
                            // load and the division an integer `div` (2 per particle in 2D).
                            id += (base / Self::BLOCK_CELLS).min(dims[a] - 1) * stride;
                            stride *= dims[a];
                        }
                        id as u32
                    } else {
                        u32::MAX
                    };
                    *slot = id;
                    if id == run.0 {
                        run.1 += 1;
                    } else {
                        count(run);
                        run = (id, 1);
                    }
                }
                count(run);
            });
        // Serial over the blocks: the non-empty ones become ranges; each run's count becomes
        // its cursor, the position of its block's particles within the range (relative).
        self.ranges.clear();
        self.rank.clear();
        self.rank.resize(nblocks, u32::MAX);
        let mut start = 0;
        for id in 0..nblocks {
            let mut total = 0;
            for counts in &self.counts {
                total += counts[id] as usize;
            }
            if total > 0 {
                self.rank[id] = self.ranges.len() as u32;
                self.ranges.push((id, start, start + total));
                start += total;
            }
        }
        self.order.clear();
        self.order.resize(start, 0);
        let mut slices: Vec<Vec<&mut [u32]>> = (0..runs)
            .map(|_| Vec::with_capacity(self.ranges.len()))
            .collect();
        let mut rest = self.order.as_mut_slice();
        for &(id, _, _) in &self.ranges {
            for (counts, slices) in self.counts.iter_mut().zip(&mut slices) {
                let (head, tail) = std::mem::take(&mut rest).split_at_mut(counts[id] as usize);
                slices.push(head);
                rest = tail;
                counts[id] = 0;
            }
        }
        let rank = &self.rank;
        self.range_of
            .par_chunks_mut(run_len)
            .zip(self.counts.par_iter_mut())
            .zip(slices.into_par_iter())
            .enumerate()
            .for_each(|(c, ((ids, cursor), mut slices))| {
                // By runs of equal blocks again: each run is copied into its block's slice at
                // the cursor, which then moves past it.
                let mut p = c * run_len;
                for same in ids.chunk_by_mut(|a, b| a == b) {
                    let (id, len) = (same[0], same.len());
                    if id != u32::MAX {
                        let r = rank[id as usize];
                        let k = cursor[id as usize] as usize;
                        let to = &mut slices[r as usize][k..k + len];
                        for (slot, q) in to.iter_mut().zip(p..) {
                            *slot = q as u32;
                        }
                        cursor[id as usize] += len as u32;
                        same.fill(r);
                    }
                    p += len;
                }
            });
        self.origins.clear();
        self.origins.extend(
            self.ranges
                .iter()
                .map(|r| block_origin(r.0, &dims, b as i64)),
        );
    }

    /// The binned particles sorted by block, in index order within a block.
    pub fn order(&self) -> &[u32] {
        &self.order
    }

    /// Number of non-empty blocks.
    pub fn block_count(&self) -> usize {
        self.ranges.len()
    }

    /// Bytes held by the binning (lengths, not capacities): `(per-particle arrays, per-grid
    /// arrays)`. Add [`BlockBuffers::bytes`] for the buffers.
    pub fn bytes(&self) -> (usize, usize) {
        let u = std::mem::size_of::<usize>();
        let per_particle = (self.range_of.len() + self.order.len()) * std::mem::size_of::<u32>();
        let grid = (self.counts.iter().map(Vec::len).sum::<usize>() + self.rank.len())
            * std::mem::size_of::<u32>()
            + self.ranges.len() * 3 * u
            + self.origins.len() * std::mem::size_of::<[i64; D]>();
        (per_particle, grid)
    }

    /// Nodes per axis of a block's window for the kernel of the last sort.
    fn width(&self, kernel: Kernel) -> usize {
        Self::BLOCK_CELLS + kernel.support() - 1
    }

    /// The window of the `r`-th non-empty block (the order of [`Self::block_count`]).
    fn window(&self, r: usize, width: usize) -> BlockWindow<D> {
        BlockWindow {
            origin: self.origins[r],
            width,
        }
    }

    /// Marks in `layout` every grid block that the windows of the non-empty blocks reach: the
    /// block itself and, for the stencil overhang, its upper neighbours. Call between
    /// [`NodeLayout::begin`] and [`NodeLayout::finish`]; several binnings (phases) may mark
    /// one layout.
    ///
    /// # Panics
    /// Before the first [`sort`](Self::sort).
    pub fn mark(&self, layout: &mut NodeLayout<D>) {
        assert!(self.grid.is_some(), "Blocks::sort before Blocks::mark");
        for &(id, _, _) in &self.ranges {
            // The binning's blocks are the layout's: the same grid and block size.
            let c = layout.block_coords(id);
            for e in 0..1usize << D {
                layout.mark(std::array::from_fn(|a| c[a] + ((e >> a) & 1) as i64));
            }
        }
    }

    /// Scatters every binned particle: `f(p, window, storage)` adds particle `p`'s contributions
    /// to its block's buffers `storage` at the indices `window.local(&node)`. Blocks run in
    /// parallel, each over its particles in index order; then every channel array of `out` is
    /// sized to `layout`'s nodes, zeroed, and each grid block of `layout` receives, in
    /// parallel, the buffers that reach it in ascending block order (buffer nodes whose gate is
    /// zero are skipped). `layout` must hold every block [`Self::mark`] marks.
    ///
    /// # Panics
    /// Before the first [`sort`](Self::sort).
    pub fn scatter<C, F>(
        &self,
        buffers: &mut BlockBuffers<C::Storage>,
        layout: &NodeLayout<D>,
        out: C,
        f: F,
    ) where
        C: Channels,
        F: Fn(usize, &BlockWindow<D>, &mut C::Storage) + Sync,
    {
        self.scatter_prefetching(buffers, layout, out, |_| {}, f);
    }

    /// [`Self::scatter`], calling `ahead(q)` before each particle's `f` with the particle `q`
    /// [`Self::PREFETCH_AHEAD`] places later in the same block's order, if there is one, so
    /// that `ahead` can ask for `q`'s data ([`crate::prefetch::read`]) while the particles
    /// before it are scattered. `ahead` changes no result: it is for hints only.
    pub fn scatter_prefetching<C, F, A>(
        &self,
        buffers: &mut BlockBuffers<C::Storage>,
        layout: &NodeLayout<D>,
        mut out: C,
        ahead: A,
        f: F,
    ) where
        C: Channels,
        F: Fn(usize, &BlockWindow<D>, &mut C::Storage) + Sync,
        A: Fn(usize) + Sync,
    {
        let (_, kernel) = self.grid.expect("Blocks::sort before Blocks::scatter");
        let width = self.width(kernel);
        let len = width.pow(D as u32);
        let enabled = out.enabled();
        if buffers.blocks.len() < self.ranges.len() {
            buffers
                .blocks
                .resize_with(self.ranges.len(), Default::default);
        }
        buffers.used = self.ranges.len();
        let order = &self.order;
        self.ranges
            .par_iter()
            .zip(buffers.blocks.par_iter_mut())
            .enumerate()
            .for_each(|(r, (&(_, start, end), buf))| {
                let window = self.window(r, width);
                buf.reset(enabled, len);
                let ids = &order[start..end];
                for (k, &p) in ids.iter().enumerate() {
                    if let Some(&q) = ids.get(k + Self::PREFETCH_AHEAD) {
                        ahead(q as usize);
                    }
                    f(p as usize, &window, buf);
                }
            });
        // Each grid block receives from the windows of the blocks at offsets 0 and −1 along
        // every axis (their own nodes and their overhang), in ascending block id, so every node
        // sums its contributions in block order, as a serial pass over the blocks would.
        let b = Self::BLOCK_CELLS;
        let blocks = &buffers.blocks[..self.ranges.len()];
        let mut slabs = out.slabs(layout.len(), NodeLayout::<D>::BLOCK_NODES);
        slabs.par_iter_mut().enumerate().for_each(|(s, slab)| {
            C::zero_slab(slab);
            let grid_block = layout.block_coords(layout.active()[s] as usize);
            let mut sources = [(0usize, 0usize, 0usize); 8];
            let mut count = 0;
            for e in 0..1usize << D {
                let below = std::array::from_fn(|a| grid_block[a] - ((e >> a) & 1) as i64);
                let Some(id) = layout.block_id(&below) else {
                    continue;
                };
                if let Ok(r) = self.ranges.binary_search_by_key(&id, |r| r.0) {
                    sources[count] = (id, r, e);
                    count += 1;
                }
            }
            sources[..count].sort_unstable();
            for &(_, r, e) in &sources[..count] {
                let buf = &blocks[r];
                // Along each axis: the window's own nodes 0..B land on the grid block's 0..B;
                // the overhang B..width of the block below lands on 0..width − B.
                let lo: [usize; D] = std::array::from_fn(|a| b * ((e >> a) & 1));
                let ext: [usize; D] =
                    std::array::from_fn(|a| if (e >> a) & 1 == 0 { b } else { width - b });
                for_each_row(&ext, |row| {
                    let (mut k, mut n, mut ks, mut ns) = (lo[0], row[0], 1, 1);
                    for a in 1..D {
                        ks *= width;
                        ns *= b;
                        k += (lo[a] + row[a]) * ks;
                        n += row[a] * ns;
                    }
                    for i in 0..ext[0] {
                        if buf.received(k + i) {
                            C::add(slab, n + i, buf, k + i);
                        }
                    }
                });
            }
        });
    }

    /// Copies the grid values `values` (one per node of `layout`) into channel `channel` of
    /// every block's buffers, sized to the block's window (zero at nodes `layout` does not
    /// store), so that a gather reads a particle's stencil from its block's window as a
    /// scatter writes it: see [`Self::window_of`]. `layout` must hold every block
    /// [`Self::mark`] marks.
    ///
    /// # Panics
    /// Before the first [`sort`](Self::sort).
    pub fn load_windows<S, T>(
        &self,
        buffers: &mut BlockBuffers<S>,
        layout: &NodeLayout<D>,
        values: &[T],
        channel: impl Fn(&mut S) -> &mut Vec<T> + Sync,
    ) where
        S: BlockStorage,
        T: NodeValue,
    {
        let (_, kernel) = self.grid.expect("Blocks::sort before Blocks::load_windows");
        let (width, b) = (self.width(kernel), Self::BLOCK_CELLS);
        if buffers.blocks.len() < self.ranges.len() {
            buffers
                .blocks
                .resize_with(self.ranges.len(), Default::default);
        }
        buffers.used = buffers.used.max(self.ranges.len());
        buffers.blocks[..self.ranges.len()]
            .par_iter_mut()
            .enumerate()
            .for_each(|(r, buf)| {
                let window = self.window(r, width);
                let out = channel(buf);
                out.clear();
                out.resize(width.pow(D as u32), T::zero());
                let ext = [width; D];
                for_each_row(&ext, |row| {
                    let mut node = window.origin;
                    for a in 1..D {
                        node[a] += row[a] as i64;
                    }
                    let k = window.local(&node);
                    // The row crosses one block boundary along the first axis.
                    for (from, to) in [(0, b), (b, width)] {
                        let mut start = node;
                        start[0] += from as i64;
                        if let Some(i) = layout.index(&start) {
                            out[k + from..k + to].copy_from_slice(&values[i..i + to - from]);
                        }
                    }
                });
            });
    }

    /// The binned particle `p`'s block: its index among the non-empty blocks (the buffers'
    /// order) and its window, or `None` when `p` was not binned.
    ///
    /// # Panics
    /// Before the first [`sort`](Self::sort).
    #[inline]
    pub fn window_of(&self, p: usize) -> Option<(usize, BlockWindow<D>)> {
        let (_, kernel) = self.grid.expect("Blocks::sort before Blocks::window_of");
        let r = *self.range_of.get(p)?;
        (r != u32::MAX).then(|| (r as usize, self.window(r as usize, self.width(kernel))))
    }
}

/// Calls `f(row)` for every row of the box `0..ext[0] × … × 0..ext[D−1]` along the first axis:
/// `row[0]` is 0 and `row[a]`, `a ≥ 1`, runs over `0..ext[a]` (rows are disjoint, so their
/// order does not matter).
#[inline]
fn for_each_row<const D: usize>(ext: &[usize; D], mut f: impl FnMut(&[usize; D])) {
    let mut rows = *ext;
    rows[0] = 1;
    for_each_index(&[0; D], &rows, |k| f(&k.map(|c| c as usize)));
}

fn block_origin<const D: usize>(mut id: usize, dims: &[usize; D], b: i64) -> [i64; D] {
    let mut o = [0i64; D];
    for a in 0..D {
        o[a] = (id % dims[a]) as i64 * b;
        id /= dims[a];
    }
    o
}

#[cfg(test)]
mod tests;
