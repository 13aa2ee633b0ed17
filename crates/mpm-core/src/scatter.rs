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
use crate::math::{for_each_index, Real, Vector};
use nalgebra::SMatrix;
use rayon::prelude::*;
use std::ops::AddAssign;

/// A per-node quantity that can be scattered: summed with `+=` from [`zero`](Self::zero), in
/// the units of whatever the caller scatters. Implemented for `Real` (and `f32`), the integer
/// types and fixed-size matrices of `Real` (`Vector<D>`, `Matrix<D>`); implement it for a custom
/// per-node type to scatter that.
pub trait NodeValue: Copy + PartialEq + AddAssign + Send + Sync {
    /// The additive identity.
    fn zero() -> Self;
}

macro_rules! node_value {
    ($($t:ty),*) => {
        $(impl NodeValue for $t {
            #[inline]
            fn zero() -> Self {
                0 as $t
            }
        })*
    };
}

node_value!(f64, f32, u8, u16, u32, u64, usize, i8, i16, i32, i64, isize);

/// Every fixed-size matrix of `Real`: `Vector<D>`, `Matrix<D>`, …
impl<const R: usize, const C: usize> NodeValue for SMatrix<Real, R, C> {
    #[inline]
    fn zero() -> Self {
        Self::zeros()
    }
}

/// One output channel of a scatter: a per-node array, resized to the grid's node count and
/// zeroed before the sums are added, or nothing.
pub trait Output {
    /// The per-node value.
    type Value: NodeValue;
    /// The array the sums go to, or `None` when this channel is not scattered.
    fn array(&mut self) -> Option<&mut Vec<Self::Value>>;
    /// Whether this channel is scattered.
    fn enabled(&self) -> bool;
}

impl<T: NodeValue> Output for &mut Vec<T> {
    type Value = T;
    fn array(&mut self) -> Option<&mut Vec<T>> {
        Some(&mut **self)
    }
    fn enabled(&self) -> bool {
        true
    }
}

impl<T: NodeValue> Output for Option<&mut Vec<T>> {
    type Value = T;
    fn array(&mut self) -> Option<&mut Vec<T>> {
        self.as_deref_mut()
    }
    fn enabled(&self) -> bool {
        self.is_some()
    }
}

/// The private node storage of one block: a tuple of `Vec<T>`, one per channel, each of
/// `window.len()` entries while its channel is scattered and empty otherwise.
pub trait BlockStorage: Default + Send + Sync {
    /// Zeroes every channel whose bit is set in `enabled` (bit `c` for channel `c`; the gate,
    /// channel 0, is always enabled) to `len` nodes and empties the others.
    fn reset(&mut self, enabled: u32, len: usize);
    /// Whether local node `k` received anything: its gate value is not zero.
    fn received(&self, k: usize) -> bool;
    /// Bytes held (lengths, not capacities).
    fn bytes(&self) -> usize;
}

/// A set of output channels scattered together: a tuple `(&mut Vec<T0>, O1, O2, …)` of up to six
/// channels whose first one, the gate, is always present and the others are any [`Output`].
pub trait Channels {
    /// The matching block storage, `(Vec<T0>, Vec<T1>, …)`.
    type Storage: BlockStorage;
    /// Consecutive nodes of every scattered output array, written by one task.
    type Slab<'s>: Send
    where
        Self: 's;
    /// Bit `c` set: channel `c` is scattered.
    fn enabled(&self) -> u32;
    /// Sizes every scattered output array to `num_nodes` and splits it into slabs of
    /// `slab_len` nodes (the last may be shorter); the values are stale until
    /// [`Self::zero_slab`].
    fn slabs(&mut self, num_nodes: usize, slab_len: usize) -> Vec<Self::Slab<'_>>;
    /// Zeroes every array of a slab.
    fn zero_slab<'s>(slab: &mut Self::Slab<'s>)
    where
        Self: 's;
    /// Adds local node `k` of `block` to node `node` of the slab in every scattered output.
    fn add<'s>(slab: &mut Self::Slab<'s>, node: usize, block: &Self::Storage, k: usize)
    where
        Self: 's;
}

macro_rules! channel_tuple {
    ($($i:tt $T:ident $O:ident),*) => {
        impl<T0: NodeValue, $($T: NodeValue),*> BlockStorage for (Vec<T0>, $(Vec<$T>,)*) {
            fn reset(&mut self, _enabled: u32, len: usize) {
                self.0.clear();
                self.0.resize(len, T0::zero());
                $(
                    self.$i.clear();
                    if _enabled & (1 << $i) != 0 {
                        self.$i.resize(len, $T::zero());
                    }
                )*
            }

            #[inline]
            fn received(&self, k: usize) -> bool {
                self.0[k] != T0::zero()
            }

            fn bytes(&self) -> usize {
                self.0.len() * std::mem::size_of::<T0>()
                    $(+ self.$i.len() * std::mem::size_of::<$T>())*
            }
        }

        impl<'a, T0: NodeValue, $($O: Output),*> Channels for (&'a mut Vec<T0>, $($O,)*) {
            type Storage = (Vec<T0>, $(Vec<$O::Value>,)*);

            fn enabled(&self) -> u32 {
                1 $(| (u32::from(self.$i.enabled()) << $i))*
            }

            type Slab<'s> = (&'s mut [T0], $(Option<&'s mut [$O::Value]>,)*) where Self: 's;

            fn slabs(&mut self, num_nodes: usize, slab_len: usize) -> Vec<Self::Slab<'_>> {
                self.0.resize(num_nodes, T0::zero());
                $(
                    if let Some(out) = self.$i.array() {
                        out.resize(num_nodes, NodeValue::zero());
                    }
                )*
                let mut parts = (
                    self.0.chunks_mut(slab_len),
                    $(self.$i.array().map(|out| out.chunks_mut(slab_len)),)*
                );
                (0..num_nodes.div_ceil(slab_len))
                    .filter_map(|_| {
                        Some((
                            parts.0.next()?,
                            $(match parts.$i.as_mut() {
                                Some(it) => Some(it.next()?),
                                None => None,
                            },)*
                        ))
                    })
                    .collect()
            }

            fn zero_slab<'s>(slab: &mut Self::Slab<'s>) where Self: 's {
                slab.0.fill(T0::zero());
                $(
                    if let Some(out) = slab.$i.as_deref_mut() {
                        out.fill(NodeValue::zero());
                    }
                )*
            }

            #[inline]
            fn add<'s>(slab: &mut Self::Slab<'s>, node: usize, block: &Self::Storage, k: usize)
            where
                Self: 's,
            {
                slab.0[node] += block.0[k];
                $(
                    if let Some(out) = slab.$i.as_deref_mut() {
                        out[node] += block.$i[k];
                    }
                )*
            }
        }
    };
}

channel_tuple!();
channel_tuple!(1 T1 O1);
channel_tuple!(1 T1 O1, 2 T2 O2);
channel_tuple!(1 T1 O1, 2 T2 O2, 3 T3 O3);
channel_tuple!(1 T1 O1, 2 T2 O2, 3 T3 O3, 4 T4 O4);
channel_tuple!(1 T1 O1, 2 T2 O2, 3 T3 O3, 4 T4 O4, 5 T5 O5);

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
mod tests {
    use super::*;
    use crate::test_util::Lcg;
    use crate::{Real, Stencil};

    /// Particles: positions (m), masses (kg), velocities (m/s).
    struct Cloud<const D: usize> {
        x: Vec<Vector<D>>,
        m: Vec<Real>,
        v: Vec<Vector<D>>,
    }

    /// `n` particles uniform in grid units `[2, size − 3]` (every kernel's stencil inside).
    fn cloud<const D: usize>(spec: &GridSpec<D>, n: usize, seed: u64) -> Cloud<D> {
        let mut r = Lcg(seed);
        let x = (0..n)
            .map(|_| {
                Vector::<D>::from_fn(|a, _| {
                    let span = (spec.size[a] - 5) as Real;
                    spec.origin[a] + (2.0 + span * r.next()) * spec.dx
                })
            })
            .collect();
        let m = (0..n).map(|_| 0.5 + r.next()).collect();
        let v = (0..n)
            .map(|_| Vector::<D>::from_fn(|_, _| 4.0 * r.next() - 2.0))
            .collect();
        Cloud { x, m, v }
    }

    type Sums<const D: usize> = (Vec<Real>, Vec<Vector<D>>);

    /// The sparse layout of the blocks `blocks` reaches.
    fn layout_of<const D: usize>(spec: &GridSpec<D>, blocks: &Blocks<D>) -> NodeLayout<D> {
        let mut layout = NodeLayout::default();
        layout.begin(spec);
        blocks.mark(&mut layout);
        layout.finish();
        layout
    }

    /// Values stored in `layout`'s order spread onto the dense grid (zero where not stored).
    fn to_dense<const D: usize, T: NodeValue>(
        spec: &GridSpec<D>,
        layout: &NodeLayout<D>,
        values: &[T],
    ) -> Vec<T> {
        assert_eq!(values.len(), layout.len());
        (0..spec.num_nodes())
            .map(|i| {
                layout
                    .index(&spec.multi_index(i))
                    .map_or(T::zero(), |k| values[k])
            })
            .collect()
    }

    /// Block scatter of `Σ w m` and `Σ w m v`, spread onto the dense grid.
    fn block_scatter<const D: usize>(
        blocks: &Blocks<D>,
        buffers: &mut BlockBuffers<Sums<D>>,
        spec: &GridSpec<D>,
        kernel: Kernel,
        c: &Cloud<D>,
    ) -> Sums<D> {
        let layout = layout_of(spec, blocks);
        let (mut mass, mut momentum) = (Vec::new(), Vec::new());
        blocks.scatter(
            buffers,
            &layout,
            (&mut mass, &mut momentum),
            |p, window, (mb, pb)| {
                Stencil::new(kernel, spec, &c.x[p]).for_each(|node, w, _| {
                    let k = window.local(&node);
                    mb[k] += w * c.m[p];
                    pb[k] += c.v[p] * (w * c.m[p]);
                });
            },
        );
        (
            to_dense(spec, &layout, &mass),
            to_dense(spec, &layout, &momentum),
        )
    }

    /// The plain serial scatter in particle order, straight into the grid.
    fn serial_scatter<const D: usize>(
        spec: &GridSpec<D>,
        kernel: Kernel,
        c: &Cloud<D>,
        keep: impl Fn(usize) -> bool,
    ) -> Sums<D> {
        let mut mass = vec![0.0; spec.num_nodes()];
        let mut momentum = vec![Vector::<D>::zeros(); spec.num_nodes()];
        for p in (0..c.x.len()).filter(|&p| keep(p)) {
            Stencil::new(kernel, spec, &c.x[p]).for_each(|node, w, _| {
                let i = spec.linear_index(&node).unwrap();
                mass[i] += w * c.m[p];
                momentum[i] += c.v[p] * (w * c.m[p]);
            });
        }
        (mass, momentum)
    }

    fn with_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(f)
    }

    fn bits<const D: usize>((mass, momentum): &Sums<D>) -> Vec<u64> {
        let mut b: Vec<u64> = mass.iter().map(|m| m.to_bits()).collect();
        b.extend(momentum.iter().flat_map(|p| p.iter().map(|c| c.to_bits())));
        b
    }

    fn spec_2d() -> GridSpec<2> {
        GridSpec::new(Vector::<2>::new(-0.3, 0.1), 0.01, [100, 70])
    }

    fn spec_3d() -> GridSpec<3> {
        GridSpec::new(Vector::<3>::new(0.2, -0.1, 0.0), 0.02, [30, 26, 20])
    }

    fn conserves_and_ignores_threads<const D: usize>(spec: GridSpec<D>, kernel: Kernel) {
        let c = cloud(&spec, 4000, 3 + D as u64);
        let run = |threads: usize| {
            with_threads(threads, || {
                let mut blocks = Blocks::default();
                blocks.sort(&spec, kernel, &c.x);
                assert!(
                    blocks.block_count() >= 20,
                    "D = {D}: {} blocks",
                    blocks.block_count()
                );
                assert_eq!(blocks.order().len(), c.x.len());
                let mut buffers = BlockBuffers::default();
                let first = block_scatter(&blocks, &mut buffers, &spec, kernel, &c);
                // Reused buffers give the same sums.
                assert_eq!(
                    bits(&first),
                    bits(&block_scatter(&blocks, &mut buffers, &spec, kernel, &c))
                );
                first
            })
        };
        let (one, two) = (run(1), run(2));
        assert_eq!(
            bits(&one),
            bits(&two),
            "{kernel:?} D = {D}: 1 and 2 threads"
        );
        let total_m: Real = c.m.iter().sum();
        let total_p: Vector<D> = c.v.iter().zip(&c.m).map(|(v, m)| v * *m).sum();
        let grid_m: Real = one.0.iter().sum();
        let grid_p: Vector<D> = one.1.iter().sum();
        assert!(
            (grid_m - total_m).abs() <= 1e-12 * total_m,
            "mass {grid_m} vs {total_m}"
        );
        assert!(
            (grid_p - total_p).norm() <= 1e-12 * total_m,
            "momentum {grid_p} vs {total_p}"
        );
        // Node by node the same sums as the serial scatter, up to summation order.
        let serial = serial_scatter(&spec, kernel, &c, |_| true);
        for i in 0..spec.num_nodes() {
            assert!((one.0[i] - serial.0[i]).abs() <= 1e-13 * (1.0 + serial.0[i]));
            assert!((one.1[i] - serial.1[i]).norm() <= 1e-13 * (1.0 + serial.0[i]));
        }
    }

    #[test]
    fn scatter_conserves_totals_and_is_bitwise_thread_count_independent() {
        for kernel in [Kernel::Linear, Kernel::Quadratic, Kernel::Cubic] {
            conserves_and_ignores_threads(spec_2d(), kernel);
            conserves_and_ignores_threads(spec_3d(), kernel);
        }
    }

    /// Positions on a 1/8-cell lattice, dyadic masses and velocities: every product and sum is
    /// exact, so any summation order gives the same bits as the plain serial scatter.
    fn dyadic_matches_serial<const D: usize>(size: [usize; D]) {
        let spec = GridSpec::new(Vector::<D>::zeros(), 0.125, size);
        let mut r = Lcg(11);
        let n = 3000;
        let c = Cloud {
            x: (0..n)
                .map(|_| {
                    Vector::<D>::from_fn(|a, _| {
                        let eighths = 16 + (r.next() * (8 * (size[a] - 5)) as Real) as usize;
                        eighths as Real / 8.0 * spec.dx
                    })
                })
                .collect(),
            m: (0..n)
                .map(|_| (1 + (r.next() * 16.0) as u32) as Real / 16.0)
                .collect(),
            v: (0..n)
                .map(|_| Vector::<D>::from_fn(|_, _| ((r.next() * 16.0) as i32 - 8) as Real / 4.0))
                .collect(),
        };
        let serial = serial_scatter(&spec, Kernel::Quadratic, &c, |_| true);
        for threads in [1, 2] {
            let sums = with_threads(threads, || {
                let mut blocks = Blocks::default();
                blocks.sort(&spec, Kernel::Quadratic, &c.x);
                block_scatter(
                    &blocks,
                    &mut BlockBuffers::default(),
                    &spec,
                    Kernel::Quadratic,
                    &c,
                )
            });
            assert_eq!(bits(&sums), bits(&serial), "D = {D}, {threads} threads");
        }
        // The sums are exact: Σ_i m_i = Σ_p m_p to the last bit.
        let total: Real = c.m.iter().sum();
        assert_eq!(serial.0.iter().sum::<Real>(), total);
    }

    #[test]
    fn exact_scatter_equals_the_plain_serial_scatter_bitwise() {
        dyadic_matches_serial([70, 50]);
        dyadic_matches_serial([30, 22, 20]);
    }

    /// The prefetching scatter announces, before each particle of a block, the particle
    /// `PREFETCH_AHEAD` places later in that block's order (none near the block's end, none
    /// from another block), and its sums are bitwise those of the plain scatter, on 1 and 2
    /// threads.
    #[test]
    fn prefetching_scatter_announces_each_blocks_later_particles() {
        #[derive(Clone, Copy, Debug, PartialEq)]
        enum Event {
            Ahead(usize),
            Scatter(usize),
        }
        let (spec, kernel) = (spec_3d(), Kernel::Quadratic);
        let c = cloud(&spec, 3000, 11);
        let mut blocks = Blocks::default();
        blocks.sort(&spec, kernel, &c.x);
        let plain = block_scatter(&blocks, &mut BlockBuffers::default(), &spec, kernel, &c);
        let layout = layout_of(&spec, &blocks);
        let ahead = Blocks::<3>::PREFETCH_AHEAD;
        for threads in [1, 2] {
            let log = std::sync::Mutex::new(Vec::new());
            let (mut mass, mut momentum) = (Vec::new(), Vec::new());
            with_threads(threads, || {
                blocks.scatter_prefetching(
                    &mut BlockBuffers::default(),
                    &layout,
                    (&mut mass, &mut momentum),
                    |q| log.lock().unwrap().push(Event::Ahead(q)),
                    |p, window, (mb, pb)| {
                        log.lock().unwrap().push(Event::Scatter(p));
                        Stencil::new(kernel, &spec, &c.x[p]).for_each(|node, w, _| {
                            let k = window.local(&node);
                            mb[k] += w * c.m[p];
                            pb[k] += c.v[p] * (w * c.m[p]);
                        });
                    },
                )
            });
            let dense = (
                to_dense(&spec, &layout, &mass),
                to_dense(&spec, &layout, &momentum),
            );
            assert_eq!(bits(&dense), bits(&plain));
            // Each block's events, in the order they happened, are exactly the expected ones.
            let log = log.into_inner().unwrap();
            let block_of = |e: &Event| {
                let (Event::Ahead(p) | Event::Scatter(p)) = *e;
                blocks
                    .ranges
                    .iter()
                    .position(|&(_, s, e)| blocks.order[s..e].contains(&(p as u32)))
            };
            let mut long = 0;
            for (b, &(_, start, end)) in blocks.ranges.iter().enumerate() {
                let ids: Vec<usize> = blocks.order[start..end]
                    .iter()
                    .map(|&p| p as usize)
                    .collect();
                let mut expected = Vec::new();
                for k in 0..ids.len() {
                    if k + ahead < ids.len() {
                        expected.push(Event::Ahead(ids[k + ahead]));
                    }
                    expected.push(Event::Scatter(ids[k]));
                }
                let seen: Vec<Event> = log
                    .iter()
                    .filter(|e| block_of(e) == Some(b))
                    .copied()
                    .collect();
                assert_eq!(seen, expected, "block {b}");
                long += usize::from(ids.len() > ahead);
            }
            assert_eq!(
                log.len(),
                2 * 3000
                    - blocks
                        .ranges
                        .iter()
                        .map(|&(_, s, e)| (e - s).min(ahead))
                        .sum::<usize>()
            );
            // The cloud has blocks both longer and shorter than the look-ahead.
            assert!(
                long > 0 && long < blocks.ranges.len(),
                "{long} of {}",
                blocks.ranges.len()
            );
        }
    }

    #[test]
    fn channel_sets_compose() {
        let spec = spec_2d();
        let kernel = Kernel::Quadratic;
        let c = cloud(&spec, 3000, 5);
        let mut blocks = Blocks::default();
        blocks.sort(&spec, kernel, &c.x);
        let mut buffers = BlockBuffers::default();
        let both = block_scatter(&blocks, &mut buffers, &spec, kernel, &c);
        let window_len = (Blocks::<2>::BLOCK_CELLS + 2).pow(2);
        let per_block = window_len * (8 + 16);
        assert_eq!(buffers.bytes(), blocks.block_count() * per_block);
        let layout = layout_of(&spec, &blocks);
        let (mut mass, mut momentum) = (Vec::new(), Vec::new());
        blocks.scatter(
            &mut BlockBuffers::default(),
            &layout,
            (&mut mass,),
            |p, window, (mb,)| {
                Stencil::new(kernel, &spec, &c.x[p]).for_each(|node, w, _| {
                    mb[window.local(&node)] += w * c.m[p];
                });
            },
        );
        blocks.scatter(
            &mut BlockBuffers::default(),
            &layout,
            (&mut momentum,),
            |p, window, (pb,)| {
                Stencil::new(kernel, &spec, &c.x[p]).for_each(|node, w, _| {
                    pb[window.local(&node)] += c.v[p] * (w * c.m[p]);
                });
            },
        );
        let separate = (
            to_dense(&spec, &layout, &mass),
            to_dense(&spec, &layout, &momentum),
        );
        assert_eq!(bits(&both), bits(&separate));

        // Three channels of other types, one of them switched off: a u32 count of the
        // particle–node pairs and an absent channel, which leaves its block buffers empty.
        let (mut mass, mut count) = (Vec::<Real>::new(), Vec::<u32>::new());
        let mut buffers3 = BlockBuffers::default();
        let off: Option<&mut Vec<Vector<2>>> = None;
        blocks.scatter(
            &mut buffers3,
            &layout,
            (&mut mass, off, Some(&mut count)),
            |p, window, (mb, unused, nb)| {
                assert!(unused.is_empty());
                Stencil::new(kernel, &spec, &c.x[p]).for_each(|node, w, _| {
                    let k = window.local(&node);
                    mb[k] += w * c.m[p];
                    nb[k] += 1;
                });
            },
        );
        assert_eq!(mass.len(), layout.len());
        assert!(to_dense(&spec, &layout, &mass)
            .iter()
            .zip(&both.0)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
        assert_eq!(count.iter().sum::<u32>(), 3000 * 9);
        assert_eq!(
            buffers3.bytes(),
            blocks.block_count() * window_len * (8 + 4)
        );
    }

    /// The parallel counting sort gives, for any number of threads (runs), the serial stable
    /// sort: each kept particle once, in its own block's range, ascending within a range.
    #[test]
    fn sort_is_stable_and_the_same_for_any_thread_count() {
        let spec = spec_2d();
        let kernel = Kernel::Quadratic;
        let c = cloud(&spec, 5000, 21);
        let keep = |p: usize| p % 7 != 3;
        let sorted = |threads: usize| {
            with_threads(threads, || {
                let mut blocks = Blocks::default();
                blocks.sort_where(&spec, kernel, &c.x, keep);
                blocks
            })
        };
        let one = sorted(1);
        let kept: Vec<u32> = (0..5000u32).filter(|&p| keep(p as usize)).collect();
        let mut seen = one.order().to_vec();
        seen.sort_unstable();
        assert_eq!(seen, kept);
        for (r, &(id, start, end)) in one.ranges.iter().enumerate() {
            let run = &one.order()[start..end];
            assert!(
                run.windows(2).all(|w| w[0] < w[1]),
                "block {id} not ascending"
            );
            for &p in run {
                let (rank, window) = one.window_of(p as usize).unwrap();
                assert_eq!(rank, r);
                let base = Stencil::new(kernel, &spec, &c.x[p as usize]).base;
                let b = Blocks::<2>::BLOCK_CELLS as i64;
                assert!((0..2).all(|a| (0..b).contains(&(base[a] - window.origin()[a]))));
            }
        }
        assert!(one.window_of(3).is_none());
        for threads in [2, 3, 8] {
            let other = sorted(threads);
            assert_eq!(other.order(), one.order(), "{threads} threads");
            assert_eq!(other.ranges, one.ranges, "{threads} threads");
            assert_eq!(other.range_of, one.range_of, "{threads} threads");
        }
    }

    #[test]
    fn sort_where_scatters_only_the_kept_particles() {
        let spec = spec_3d();
        let kernel = Kernel::Cubic;
        let c = cloud(&spec, 2000, 9);
        let keep = |p: usize| p % 3 == 1;
        let mut blocks = Blocks::default();
        blocks.sort_where(&spec, kernel, &c.x, keep);
        assert_eq!(blocks.order().len(), (0..2000).filter(|&p| keep(p)).count());
        assert!(blocks.order().iter().all(|&p| keep(p as usize)));
        let sums = block_scatter(&blocks, &mut BlockBuffers::default(), &spec, kernel, &c);
        let serial = serial_scatter(&spec, kernel, &c, keep);
        let kept: Real = (0..2000).filter(|&p| keep(p)).map(|p| c.m[p]).sum();
        assert!((sums.0.iter().sum::<Real>() - kept).abs() <= 1e-12 * kept);
        for i in 0..spec.num_nodes() {
            assert!((sums.0[i] - serial.0[i]).abs() <= 1e-13 * (1.0 + serial.0[i]));
            assert_eq!(sums.0[i] == 0.0, serial.0[i] == 0.0);
        }
    }

    /// A cloud in one corner of a large grid: the layout stores only the blocks it reaches,
    /// the scatter still equals the plain serial one, and the windows loaded back from the
    /// sparse storage give every particle its stencil's node values.
    fn sparse_corner<const D: usize>(size: [usize; D], kernel: Kernel) {
        let spec = GridSpec::new(Vector::<D>::zeros(), 0.1, size);
        // Particles in grid units [2, 13]: the first two blocks along each axis (and their
        // overhang into the third in 3D).
        let mut r = Lcg(17);
        let n = 1500;
        let c = Cloud {
            x: (0..n)
                .map(|_| Vector::<D>::from_fn(|_, _| (2.0 + 11.0 * r.next()) * spec.dx))
                .collect(),
            m: (0..n).map(|_| 0.5 + r.next()).collect(),
            v: (0..n)
                .map(|_| Vector::<D>::from_fn(|_, _| r.next() - 0.5))
                .collect(),
        };
        let mut blocks = Blocks::default();
        blocks.sort(&spec, kernel, &c.x);
        let layout = layout_of(&spec, &blocks);
        // At most the first three blocks along each axis (two with particles, one overhang).
        assert!(layout.active().len() <= 3usize.pow(D as u32));
        assert_eq!(
            layout.len(),
            layout.active().len() * NodeLayout::<D>::BLOCK_NODES
        );
        assert!(layout.len() * 8 < spec.num_nodes(), "the layout is sparse");
        // Storage index and multi-index are inverse.
        for i in (0..layout.len()).step_by(7) {
            let node = layout.node(i);
            if (0..D).all(|a| (node[a] as usize) < size[a]) {
                assert_eq!(layout.index(&node), Some(i));
            }
        }
        assert_eq!(layout.index(&[size[0] as i64 - 1; D]), None);
        let mut buffers = BlockBuffers::default();
        let sums = block_scatter(&blocks, &mut buffers, &spec, kernel, &c);
        let serial = serial_scatter(&spec, kernel, &c, |_| true);
        for i in 0..spec.num_nodes() {
            assert!((sums.0[i] - serial.0[i]).abs() <= 1e-13 * (1.0 + serial.0[i]));
            assert!((sums.1[i] - serial.1[i]).norm() <= 1e-13 * (1.0 + serial.0[i]));
        }
        // Node values (here m_i + 1 at stored nodes) read back through the windows.
        let mut stored_values = vec![0.0; layout.len()];
        for (k, v) in stored_values.iter_mut().enumerate() {
            let node = layout.node(k);
            if let Some(i) = spec.linear_index(&node) {
                *v = serial.0[i] + 1.0;
            }
        }
        blocks.load_windows(&mut buffers, &layout, &stored_values, |s| &mut s.0);
        for p in 0..n {
            let (r, window) = blocks.window_of(p).unwrap();
            let values = &buffers.get(r).0;
            Stencil::new(kernel, &spec, &c.x[p]).for_each(|node, _, _| {
                let i = spec.linear_index(&node).unwrap();
                assert_eq!(values[window.local(&node)], serial.0[i] + 1.0);
            });
        }
    }

    #[test]
    fn sparse_layout_stores_only_the_reached_blocks_and_windows_read_them_back() {
        for kernel in [Kernel::Linear, Kernel::Quadratic, Kernel::Cubic] {
            sparse_corner([200, 150], kernel);
            sparse_corner([90, 80, 70], kernel);
        }
        // The dense layout stores every block.
        let spec = GridSpec::<3>::new(Vector::<3>::zeros(), 0.1, [17, 9, 8]);
        let dense = NodeLayout::dense(&spec);
        assert_eq!(dense.active().len(), 3 * 2);
        for i in 0..spec.num_nodes() {
            let node = spec.multi_index(i);
            assert_eq!(dense.node(dense.index(&node).unwrap()), node);
        }
    }
}
