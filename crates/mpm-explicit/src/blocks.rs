//! The explicit solver's use of the deterministic block scatter of [`mpm_core::scatter`]: one
//! binning per phase and one set of block buffers shared by every scatter of that phase (P2G,
//! the mass scatter, the coupling geometry, mixing), with up to four channels. For G2P the
//! same buffers hold each block's window of grid velocities ([`Blocks::load_velocities`]), so
//! a particle gathers from the few kilobytes of its block's window, whatever the layout of the
//! sparse grid.

use mpm_core::scatter::{self, BlockBuffers, BlockWindow};
use mpm_core::{GridSpec, Kernel, NodeLayout, Real, Vector};

/// The grid a stage works on: its geometry, the step's sparse layout and the kernel.
#[derive(Clone, Copy)]
pub(crate) struct GridRef<'a, const D: usize> {
    pub spec: &'a GridSpec<D>,
    pub layout: &'a NodeLayout<D>,
    pub kernel: Kernel,
}

/// Block storage of the explicit scatters: two scalar and two vector channels, in the order
/// `(scalar gate, vector, vector, scalar)`.
pub(crate) type Storage<const D: usize> = (Vec<Real>, Vec<Vector<D>>, Vec<Vector<D>>, Vec<Real>);

/// Where a scatter adds its block buffers. Channel `mass` must be a sum of non-negative weights:
/// nodes where it is zero received nothing and are skipped. Every given array is zeroed and
/// sized to the grid first; absent channels are not touched.
pub(crate) struct Sums<'a, const D: usize> {
    /// Scalar gate channel (node mass for P2G).
    pub mass: &'a mut Vec<Real>,
    /// Vector channel (node momentum for P2G).
    pub momentum: Option<&'a mut Vec<Vector<D>>>,
    /// Second vector channel (FLIP's plain momentum for P2G).
    pub momentum0: Option<&'a mut Vec<Vector<D>>>,
    /// Second scalar channel.
    pub extra: Option<&'a mut Vec<Real>>,
}

/// One phase's particle binning and block buffers, reused from step to step.
#[derive(Clone, Debug, Default)]
pub(crate) struct Blocks<const D: usize> {
    binning: scatter::Blocks<D>,
    buffers: BlockBuffers<Storage<D>>,
}

impl<const D: usize> Blocks<D> {
    /// Bins particles at `x` by block; with `only = Some((phase, k))`, only the particles with
    /// `phase[p] == k`. Positions must have their stencil inside the grid.
    pub fn sort(
        &mut self,
        spec: &GridSpec<D>,
        kernel: Kernel,
        x: &[Vector<D>],
        only: Option<(&[u32], u32)>,
    ) {
        match only {
            None => self.binning.sort(spec, kernel, x),
            Some((phase, k)) => self.binning.sort_where(spec, kernel, x, |p| phase[p] == k),
        }
    }

    /// Bytes held by the binning and the block buffers (lengths, not capacities):
    /// `(per-particle arrays, per-grid arrays)`.
    pub fn bytes(&self) -> (usize, usize) {
        let (particles, grid) = self.binning.bytes();
        (particles, grid + self.buffers.bytes())
    }

    /// Marks the grid blocks this phase's scatters and gathers reach in `layout`.
    pub fn mark(&self, layout: &mut NodeLayout<D>) {
        self.binning.mark(layout);
    }

    /// Scatters every binned particle with `f(particle, window, buffers)` into its block's
    /// buffers, blocks in parallel, then adds the buffers to `out` (in the order of `layout`)
    /// in block order.
    pub fn scatter<F>(&mut self, layout: &NodeLayout<D>, out: Sums<'_, D>, f: F)
    where
        F: Fn(usize, &BlockWindow<D>, &mut Storage<D>) + Sync,
    {
        self.scatter_prefetching(layout, out, |_| {}, f);
    }

    /// [`Self::scatter`] with `ahead(q)` called for the particle `q` some places ahead in the
    /// block's order, to prefetch its data ([`scatter::Blocks::scatter_prefetching`]).
    pub fn scatter_prefetching<F, A>(
        &mut self,
        layout: &NodeLayout<D>,
        out: Sums<'_, D>,
        ahead: A,
        f: F,
    ) where
        F: Fn(usize, &BlockWindow<D>, &mut Storage<D>) + Sync,
        A: Fn(usize) + Sync,
    {
        let channels = (out.mass, out.momentum, out.momentum0, out.extra);
        self.binning
            .scatter_prefetching(&mut self.buffers, layout, channels, ahead, f);
    }

    /// Loads the grid velocities `velocity` (m/s) and, for FLIP, the velocities before the
    /// update `old` (m/s), both in the order of `layout`, into every block's window (the vector
    /// channels of its buffers) for [`Self::velocities`].
    pub fn load_velocities(
        &mut self,
        layout: &NodeLayout<D>,
        velocity: &[Vector<D>],
        old: Option<&[Vector<D>]>,
    ) {
        let binning = &self.binning;
        binning.load_windows(&mut self.buffers, layout, velocity, |s| &mut s.1);
        if let Some(old) = old {
            binning.load_windows(&mut self.buffers, layout, old, |s| &mut s.2);
        }
    }

    /// The window of particle `p`'s block with its velocities and, when they were loaded, the
    /// old velocities (empty otherwise), as [`Self::load_velocities`] left them; `None` when
    /// `p` is not binned in this phase.
    #[inline]
    pub fn velocities(&self, p: usize) -> Option<Window<'_, D>> {
        let (r, window) = self.binning.window_of(p)?;
        let buf = self.buffers.get(r);
        Some(Window {
            window,
            velocity: &buf.1,
            old: &buf.2,
        })
    }
}

/// A block's window of node velocities for G2P.
pub(crate) struct Window<'a, const D: usize> {
    /// The nodes the window covers.
    pub window: BlockWindow<D>,
    /// Node velocities (m/s), indexed by `window.local`.
    pub velocity: &'a [Vector<D>],
    /// Node velocities before the grid update (m/s), FLIP only; empty otherwise.
    pub old: &'a [Vector<D>],
}
