//! Deterministic parallel scatter.
//!
//! Particles are binned by the grid block (`B^D` cells) that holds the first node of their stencil.
//! Each non-empty block scatters its particles, in index order, into a private buffer covering
//! the block's nodes plus the stencil overhang; blocks run in parallel. Buffers are then added to
//! the grid serially in block order. Every node therefore receives its contributions in an order
//! fixed by the particle positions alone, so results are bitwise identical for any thread count.
//! No atomics on floats are involved.

use mpm_core::{GridSpec, Kernel, Real, Vector};
use rayon::prelude::*;

/// Where a scatter adds its block buffers: one scalar and one vector channel, and optionally a
/// second of each. Channel `mass` must be a sum of non-negative weights: nodes where it is zero
/// received nothing and are skipped. Every given array is zeroed and sized to the grid first.
pub(crate) struct Sums<'a, const D: usize> {
    /// Scalar channel (node mass for P2G).
    pub mass: &'a mut Vec<Real>,
    /// Vector channel (node momentum for P2G).
    pub momentum: &'a mut Vec<Vector<D>>,
    /// Optional second vector channel (FLIP's plain momentum for P2G).
    pub momentum0: Option<&'a mut Vec<Vector<D>>>,
    /// Optional second scalar channel.
    pub extra: Option<&'a mut Vec<Real>>,
}

/// A block's private node storage.
#[derive(Clone, Debug)]
pub(crate) struct BlockBuffer<const D: usize> {
    origin: [i64; D],
    width: usize,
    pub mass: Vec<Real>,
    pub momentum: Vec<Vector<D>>,
    /// Momentum without stress or affine terms (FLIP's old grid velocity), when requested.
    pub momentum0: Vec<Vector<D>>,
    /// The optional second scalar channel, when requested.
    pub extra: Vec<Real>,
}

impl<const D: usize> Default for BlockBuffer<D> {
    fn default() -> Self {
        Self {
            origin: [0; D],
            width: 0,
            mass: Vec::new(),
            momentum: Vec::new(),
            momentum0: Vec::new(),
            extra: Vec::new(),
        }
    }
}

impl<const D: usize> BlockBuffer<D> {
    fn reset(&mut self, origin: [i64; D], width: usize, with_momentum0: bool, with_extra: bool) {
        let n = width.pow(D as u32);
        self.origin = origin;
        self.width = width;
        self.mass.clear();
        self.mass.resize(n, 0.0);
        self.momentum.clear();
        self.momentum.resize(n, Vector::<D>::zeros());
        self.momentum0.clear();
        if with_momentum0 {
            self.momentum0.resize(n, Vector::<D>::zeros());
        }
        self.extra.clear();
        if with_extra {
            self.extra.resize(n, 0.0);
        }
    }

    /// Local index of the grid node `node`, which must lie in the block's footprint.
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
}

/// Particle binning and block buffers, reused from step to step.
#[derive(Clone, Debug)]
pub(crate) struct Blocks<const D: usize> {
    block_cells: usize,
    dims: [usize; D],
    block_of: Vec<usize>,
    counts: Vec<usize>,
    /// Particle indices sorted by block (stable: index order within a block).
    pub order: Vec<usize>,
    /// Non-empty blocks: (block id, start, end) ranges into `order`.
    ranges: Vec<(usize, usize, usize)>,
    buffers: Vec<BlockBuffer<D>>,
}

impl<const D: usize> Default for Blocks<D> {
    fn default() -> Self {
        Self {
            block_cells: 0,
            dims: [0; D],
            block_of: Vec::new(),
            counts: Vec::new(),
            order: Vec::new(),
            ranges: Vec::new(),
            buffers: Vec::new(),
        }
    }
}

impl<const D: usize> Blocks<D> {
    /// Block edge length in cells: large enough to amortise the overhang, small enough for
    /// load balance.
    fn block_cells() -> usize {
        if D == 2 {
            16
        } else {
            8
        }
    }

    /// Bins particles at `x` by block; with `only = Some((phase, k))`, only the particles with
    /// `phase[p] == k`. Positions must have their stencil inside the grid.
    pub fn sort(
        &mut self,
        spec: &GridSpec<D>,
        kernel: Kernel,
        x: &[Vector<D>],
        only: Option<(&[u32], u32)>,
    ) {
        let b = Self::block_cells();
        self.block_cells = b;
        self.dims = std::array::from_fn(|a| spec.size[a].div_ceil(b));
        let nblocks: usize = self.dims.iter().product();
        let inv_dx = 1.0 / spec.dx;
        let dims = self.dims;
        x.par_iter()
            .enumerate()
            .map(|(p, xp)| {
                if only.is_some_and(|(phase, k)| phase[p] != k) {
                    return usize::MAX;
                }
                let mut id = 0;
                let mut stride = 1;
                for a in 0..D {
                    let base = kernel.base_node((xp[a] - spec.origin[a]) * inv_dx).max(0) as usize;
                    id += (base / b).min(dims[a] - 1) * stride;
                    stride *= dims[a];
                }
                id
            })
            .collect_into_vec(&mut self.block_of);
        self.counts.clear();
        self.counts.resize(nblocks + 1, 0);
        for &id in self.block_of.iter().filter(|&&id| id != usize::MAX) {
            self.counts[id + 1] += 1;
        }
        self.ranges.clear();
        for id in 0..nblocks {
            let (start, n) = (self.counts[id], self.counts[id + 1]);
            if n > 0 {
                self.ranges.push((id, start, start + n));
            }
            self.counts[id + 1] = start + n;
        }
        self.order.clear();
        self.order.resize(self.counts[nblocks], 0);
        for (p, &id) in self.block_of.iter().enumerate() {
            if id == usize::MAX {
                continue;
            }
            self.order[self.counts[id]] = p;
            self.counts[id] += 1;
        }
    }

    /// Bytes held by the binning and the block buffers (lengths, not capacities):
    /// `(per-particle arrays, per-grid arrays)`.
    pub fn bytes(&self) -> (usize, usize) {
        let u = std::mem::size_of::<usize>();
        let per_particle = (self.block_of.len() + self.order.len()) * u;
        let buffers: usize = self.buffers[..self.ranges.len()]
            .iter()
            .map(|b| {
                (b.mass.len() + b.extra.len()) * std::mem::size_of::<Real>()
                    + (b.momentum.len() + b.momentum0.len()) * std::mem::size_of::<Vector<D>>()
            })
            .sum();
        let grid = self.counts.len() * u + self.ranges.len() * 3 * u + buffers;
        (per_particle, grid)
    }

    /// Scatters every binned particle with `f(particle, buffer)` into its block's buffer, blocks
    /// in parallel, then adds the buffers to `out` in block order.
    pub fn scatter<F>(&mut self, spec: &GridSpec<D>, kernel: Kernel, out: Sums<'_, D>, f: F)
    where
        F: Fn(usize, &mut BlockBuffer<D>) + Sync,
    {
        let Sums {
            mass,
            momentum,
            mut momentum0,
            mut extra,
        } = out;
        let width = self.block_cells + kernel.support() - 1;
        let (with0, with_extra) = (momentum0.is_some(), extra.is_some());
        if self.buffers.len() < self.ranges.len() {
            self.buffers
                .resize_with(self.ranges.len(), Default::default);
        }
        let (b, dims, order) = (self.block_cells as i64, self.dims, &self.order);
        self.ranges
            .par_iter()
            .zip(self.buffers.par_iter_mut())
            .for_each(|(&(id, start, end), buf)| {
                let origin = block_origin(id, &dims, b);
                buf.reset(origin, width, with0, with_extra);
                for &p in &order[start..end] {
                    f(p, buf);
                }
            });
        let n = spec.num_nodes();
        mass.clear();
        mass.resize(n, 0.0);
        momentum.clear();
        momentum.resize(n, Vector::<D>::zeros());
        if let Some(m0) = momentum0.as_deref_mut() {
            m0.clear();
            m0.resize(n, Vector::<D>::zeros());
        }
        if let Some(e) = extra.as_deref_mut() {
            e.clear();
            e.resize(n, 0.0);
        }
        for buf in &self.buffers[..self.ranges.len()] {
            for k in 0..buf.mass.len() {
                if buf.mass[k] == 0.0 {
                    continue;
                }
                let mut node = [0i64; D];
                let mut r = k;
                for a in 0..D {
                    node[a] = buf.origin[a] + (r % width) as i64;
                    r /= width;
                }
                let Some(i) = spec.linear_index(&node) else {
                    continue;
                };
                mass[i] += buf.mass[k];
                momentum[i] += buf.momentum[k];
                if let Some(m0) = momentum0.as_deref_mut() {
                    m0[i] += buf.momentum0[k];
                }
                if let Some(e) = extra.as_deref_mut() {
                    e[i] += buf.extra[k];
                }
            }
        }
    }
}

fn block_origin<const D: usize>(mut id: usize, dims: &[usize; D], b: i64) -> [i64; D] {
    let mut o = [0i64; D];
    for a in 0..D {
        o[a] = (id % dims[a]) as i64 * b;
        id /= dims[a];
    }
    o
}
