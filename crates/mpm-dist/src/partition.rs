//! The decomposition: grid blocks ordered along a Morton (Z-order) curve, cut into contiguous
//! ranges of about equal particle count, one range per rank. A particle belongs to the rank
//! that owns its block, the block that holds the first node of its kernel stencil (the block
//! `mpm_core::scatter::Blocks` bins it in).

use mpm_core::{GridSpec, Kernel, NodeLayout, Real, Vector};

/// Block edge length in nodes (16 in 2D, 8 in 3D), as in [`NodeLayout::BLOCK`].
pub const fn block_nodes<const D: usize>() -> i64 {
    NodeLayout::<D>::BLOCK as i64
}

/// Where particles sit on the grid: the first node of a particle's kernel stencil and the
/// block that holds it (the block the scatter bins the particle in), with the grid's constants
/// computed once.
#[derive(Clone, Copy, Debug)]
pub struct Locator<const D: usize> {
    origin: Vector<D>,
    inv_dx: Real,
    margin: Real,
    /// The last block per axis.
    last: [i64; D],
}

impl<const D: usize> Locator<D> {
    /// The locator for `spec` and `kernel`.
    pub fn new(spec: &GridSpec<D>, kernel: Kernel) -> Self {
        let b = block_nodes::<D>() as usize;
        Self {
            origin: spec.origin,
            inv_dx: 1.0 / spec.dx,
            margin: kernel.lower_margin(),
            last: std::array::from_fn(|a| spec.size[a].div_ceil(b) as i64 - 1),
        }
    }

    /// The first stencil node of a particle at `x` (m), clamped to the grid's low side as the
    /// scatter's binning does.
    #[inline]
    pub fn base(&self, x: &Vector<D>) -> [i64; D] {
        std::array::from_fn(|a| {
            Kernel::clamped_base_node(self.margin, (x[a] - self.origin[a]) * self.inv_dx) as i64
        })
    }

    /// Block coordinates of the block that holds node `node`, clamped to the grid's blocks.
    #[inline]
    pub fn block_of_node(&self, node: &[i64; D]) -> [i64; D] {
        std::array::from_fn(|a| {
            node[a]
                .div_euclid(block_nodes::<D>())
                .clamp(0, self.last[a])
        })
    }

    /// Blocks per axis.
    pub fn blocks(&self) -> [i64; D] {
        self.last.map(|l| l + 1)
    }
}

/// Calls `f` for every multi-index of the box `lo..=hi` (inclusive on every axis).
pub fn for_each_in_box<const D: usize>(lo: &[i64; D], hi: &[i64; D], mut f: impl FnMut([i64; D])) {
    if (0..D).any(|a| lo[a] > hi[a]) {
        return;
    }
    let mut k = *lo;
    loop {
        f(k);
        let mut a = 0;
        while a < D {
            if k[a] < hi[a] {
                k[a] += 1;
                break;
            }
            k[a] = lo[a];
            a += 1;
        }
        if a == D {
            return;
        }
    }
}

/// The position of block `coords` on the Morton curve: the bits of the coordinates
/// interleaved, first axis lowest (32 bits per axis in 2D, 21 in 3D).
pub fn morton<const D: usize>(coords: &[i64; D]) -> u64 {
    let bits = 64 / D;
    let mut key = 0u64;
    for b in 0..bits {
        for a in 0..D {
            key |= ((coords[a] as u64 >> b) & 1) << (b * D + a);
        }
    }
    key
}

/// Which rank owns which Morton keys: rank `r` owns `cuts[r]..cuts[r + 1]`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Partition {
    cuts: Vec<u64>,
}

impl Partition {
    /// Everything on rank 0 of `ranks`.
    pub fn on_first(ranks: usize) -> Self {
        let mut cuts = vec![u64::MAX; ranks + 1];
        cuts[0] = 0;
        Self { cuts }
    }

    /// Cuts the blocks `weights` (Morton key and particle count, ascending in key, keys
    /// unique) into `ranks` contiguous ranges: block `i` goes to rank
    /// `⌊W_i · ranks / W⌋`, where `W_i` is the count before it and `W` the total, so every
    /// rank's count is within one block's of `W / ranks`. The same weights give the same cut
    /// on every rank.
    pub fn balance(weights: &[(u64, u64)], ranks: usize) -> Self {
        let total: u128 = weights.iter().map(|&(_, w)| w as u128).sum();
        if total == 0 {
            return Self::on_first(ranks);
        }
        let mut cuts = vec![u64::MAX; ranks + 1];
        cuts[0] = 0;
        let mut before = 0u128;
        let mut next = 1;
        for &(key, w) in weights {
            let rank = (before * ranks as u128 / total) as usize;
            while next <= rank.min(ranks - 1) {
                cuts[next] = key;
                next += 1;
            }
            before += w as u128;
        }
        Self { cuts }
    }

    /// The rank that owns Morton key `key`.
    pub fn owner(&self, key: u64) -> usize {
        self.cuts.partition_point(|&c| c <= key) - 1
    }

    /// Number of ranks.
    pub fn ranks(&self) -> usize {
        self.cuts.len() - 1
    }
}

/// The owner of every block in a box of blocks around this rank's particles, for lookups
/// without the Morton key, and for each block the owners of its `3^D` neighbours (itself
/// included), for the halo test of its particles.
#[derive(Clone, Debug)]
pub struct OwnerMap<const D: usize> {
    lo: [i64; D],
    dims: [usize; D],
    owner: Vec<u32>,
    /// `3^D` entries per block: the owner of the neighbour at offset `δ ∈ {−1, 0, 1}^D`
    /// (entry `Σ_a (δ_a + 1) 3^a`), `u32::MAX` beyond the grid.
    neighbours: Vec<u32>,
}

impl<const D: usize> Default for OwnerMap<D> {
    /// A map that covers no block.
    fn default() -> Self {
        Self {
            lo: [0; D],
            dims: [0; D],
            owner: Vec::new(),
            neighbours: Vec::new(),
        }
    }
}

/// Entries per block of [`OwnerMap`]'s neighbour table, `3^D`.
pub const fn neighbourhood<const D: usize>() -> usize {
    3usize.pow(D as u32)
}

impl<const D: usize> OwnerMap<D> {
    /// The owners (under `partition`) of the blocks from `lo` to `hi` (inclusive, clamped to
    /// the grid's `blocks` per axis) and of their neighbours.
    pub fn new(partition: &Partition, (lo, hi): ([i64; D], [i64; D]), blocks: [i64; D]) -> Self {
        let lo: [i64; D] = std::array::from_fn(|a| lo[a].max(0));
        let hi: [i64; D] = std::array::from_fn(|a| hi[a].min(blocks[a] - 1));
        if (0..D).any(|a| lo[a] > hi[a]) {
            return Self::default();
        }
        let dims: [usize; D] = std::array::from_fn(|a| (hi[a] - lo[a] + 1) as usize);
        let n: usize = dims.iter().product();
        let mut map = Self {
            lo,
            dims,
            owner: Vec::with_capacity(n),
            neighbours: Vec::with_capacity(n * neighbourhood::<D>()),
        };
        for_each_in_box(&lo, &hi, |b| {
            map.owner.push(partition.owner(morton(&b)) as u32)
        });
        let owner_of = |b: &[i64; D]| -> u32 {
            if (0..D).any(|a| b[a] < 0 || b[a] >= blocks[a]) {
                u32::MAX
            } else {
                partition.owner(morton(b)) as u32
            }
        };
        let mut table = Vec::with_capacity(n * neighbourhood::<D>());
        for_each_in_box(&lo, &hi, |b| {
            for_each_in_box(&[-1; D], &[1; D], |d| {
                let nb: [i64; D] = std::array::from_fn(|a| b[a] + d[a]);
                table.push(map.get(&nb).map_or_else(|| owner_of(&nb), |r| r as u32));
            });
        });
        map.neighbours = table;
        map
    }

    /// Storage index of `block`, if the map covers it.
    #[inline]
    pub fn index(&self, block: &[i64; D]) -> Option<usize> {
        let mut idx = 0;
        let mut stride = 1;
        for a in 0..D {
            let c = block[a] - self.lo[a];
            if c < 0 || c as usize >= self.dims[a] {
                return None;
            }
            idx += c as usize * stride;
            stride *= self.dims[a];
        }
        Some(idx)
    }

    /// The owner of `block`, if the map covers it.
    #[inline]
    pub fn get(&self, block: &[i64; D]) -> Option<usize> {
        self.index(block).map(|i| self.owner[i] as usize)
    }

    /// The owners of the `3^D` neighbours of the block at storage index `i`
    /// (`u32::MAX` beyond the grid).
    #[inline]
    pub fn neighbours(&self, i: usize) -> &[u32] {
        let n = neighbourhood::<D>();
        &self.neighbours[i * n..(i + 1) * n]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mpm_core::scatter::Blocks;

    #[test]
    fn morton_interleaves_axes() {
        assert_eq!(morton(&[1i64, 0]), 1);
        assert_eq!(morton(&[0i64, 1]), 2);
        assert_eq!(morton(&[3i64, 3]), 15);
        assert_eq!(morton(&[0i64, 0, 1]), 4);
        assert_eq!(morton(&[2i64, 0, 0]), 8);
    }

    #[test]
    fn owner_map_agrees_with_the_partition() {
        let weights: Vec<(u64, u64)> = (0..64u64).map(|k| (k, 1 + k % 3)).collect();
        let p = Partition::balance(&weights, 3);
        let map = OwnerMap::<2>::new(&p, ([-2, 1], [9, 7]), [8, 8]);
        for_each_in_box(&[0i64, 1], &[7, 7], |b| {
            assert_eq!(map.get(&b), Some(p.owner(morton(&b))));
            let i = map.index(&b).unwrap();
            let mut k = 0;
            for_each_in_box(&[-1i64, -1], &[1, 1], |d| {
                let n = [b[0] + d[0], b[1] + d[1]];
                let want = if n.iter().all(|&c| (0..8).contains(&c)) {
                    p.owner(morton(&n)) as u32
                } else {
                    u32::MAX
                };
                assert_eq!(map.neighbours(i)[k], want, "{b:?} + {d:?}");
                k += 1;
            });
        });
        assert_eq!(map.get(&[0, 0]), None);
    }

    #[test]
    fn box_visits_each_index_once() {
        let mut seen = Vec::new();
        for_each_in_box(&[-1i64, 2], &[1, 3], |k| seen.push(k));
        assert_eq!(seen.len(), 6);
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen.len(), 6);
        let mut none = 0;
        for_each_in_box(&[1i64, 0], &[0, 0], |_| none += 1);
        assert_eq!(none, 0);
    }

    #[test]
    fn balance_cuts_within_one_block_of_equal_shares() {
        let weights: Vec<(u64, u64)> = (0..40).map(|k| (3 * k, 1 + (k * 7) % 5)).collect();
        let total: u64 = weights.iter().map(|w| w.1).sum();
        for ranks in 1..=5 {
            let p = Partition::balance(&weights, ranks);
            let mut count = vec![0u64; ranks];
            for &(key, w) in &weights {
                count[p.owner(key)] += w;
            }
            assert_eq!(count.iter().sum::<u64>(), total);
            for c in count {
                assert!(c.abs_diff(total / ranks as u64) <= 5, "{ranks} ranks: {c}");
            }
            // Ownership is monotone along the curve: contiguous ranges.
            let owners: Vec<usize> = weights.iter().map(|w| p.owner(w.0)).collect();
            assert!(owners.windows(2).all(|o| o[0] <= o[1]));
        }
    }

    #[test]
    fn base_node_block_matches_the_scatter_binning() {
        let spec = GridSpec::<2>::new(Vector::<2>::zeros(), 0.01, [70, 45]);
        let x: Vec<Vector<2>> = (0..500)
            .map(|k| {
                let t = k as Real * 0.618;
                Vector::<2>::new(0.03 + 0.63 * t.fract(), 0.03 + 0.38 * (t * 1.3).fract())
            })
            .collect();
        for kernel in [Kernel::Linear, Kernel::Quadratic, Kernel::Cubic] {
            let mut blocks = Blocks::default();
            blocks.sort(&spec, kernel, &x);
            let at = Locator::new(&spec, kernel);
            for (p, xp) in x.iter().enumerate() {
                let (_, window) = blocks.window_of(p).unwrap();
                let b = at.block_of_node(&at.base(xp));
                let origin = window.origin();
                assert_eq!(
                    [origin[0] / 16, origin[1] / 16],
                    b,
                    "{kernel:?} particle {p}"
                );
            }
        }
    }
}
