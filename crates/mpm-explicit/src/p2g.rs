//! Particle-to-grid transfer (multigrid paper Eqs. 5–7): mass, momentum and the fused MLS stress
//! term `Q_p = −Δt V⁰_p τ_p M_p⁻¹ + m_p C_p`.

use crate::blocks::{Blocks, Sums};
use crate::materials::MaterialView;
use crate::params::{BodyForce, Transfer};
use mpm_core::prefetch;
use mpm_core::{
    AxisStencil, Dim, DimOps, GridNodes, GridSpec, Kernel, Material, Matrix, NodeLayout, Particles,
    Real, Stencil, Vector,
};

/// Kirchhoff stress τ = J σ (Pa) of particle `p` with material table entry `materials[..]`.
pub fn kirchhoff<const D: usize>(
    particles: &Particles<D>,
    materials: &[Material],
    p: usize,
) -> Matrix<D>
where
    Dim<D>: DimOps<D>,
{
    stress(particles, &materials[particles.material[p] as usize], p)
}

/// Kirchhoff stress τ = J σ (Pa) of particle `p` behaving as `material`.
#[inline(always)]
pub(crate) fn stress<const D: usize>(
    particles: &Particles<D>,
    material: &Material,
    p: usize,
) -> Matrix<D>
where
    Dim<D>: DimOps<D>,
{
    match material {
        Material::Solid(s) => s.kirchhoff(&particles.def_grad_of(p), &particles.plastic_of(p)),
        Material::Fluid(fl) => fl.kirchhoff(particles.jacobian_of(p), &particles.affine[p]),
    }
}

/// The per-node "gradient" used by MLS transfers: `w M⁻¹ (x_i − x_p)` for quadratic and cubic
/// kernels, the true kernel gradient for the linear kernel (see [`Kernel::mls_inertia_inv`]).
#[inline]
pub(crate) fn mls_gradient<const D: usize>(
    minv: Option<Real>,
    w: Real,
    grad: &Vector<D>,
    offset: &Vector<D>,
) -> Vector<D> {
    match minv {
        Some(minv) => offset * (w * minv),
        None => *grad,
    }
}

/// What P2G reads besides the particles' binning and the grid.
pub(crate) struct P2gInputs<'a, const D: usize> {
    pub spec: &'a GridSpec<D>,
    /// The sparse grid's stored nodes.
    pub layout: &'a NodeLayout<D>,
    pub kernel: Kernel,
    pub transfer: Transfer,
    pub particles: &'a Particles<D>,
    pub materials: &'a MaterialView<'a>,
    pub body_force: Option<&'a BodyForce<D>>,
    /// Start time `t` (s) and length `dt` (s) of the step.
    pub step: (Real, Real),
}

/// What one particle scatters.
struct Impulse<const D: usize> {
    /// Mass m (kg).
    m: Real,
    /// Momentum m v (kg·m/s).
    mv: Vector<D>,
    /// Momentum with the body-force impulse of the step (kg·m/s).
    mv_forced: Vector<D>,
    /// APIC affine momentum m C (kg/s); zero for the other transfers.
    affine: Matrix<D>,
    /// Stress impulse `−Δt V⁰ τ` (N·m·s in 3D).
    stress: Matrix<D>,
}

impl<const D: usize> P2gInputs<'_, D>
where
    Dim<D>: DimOps<D>,
{
    /// Asks for the columns [`Self::impulse`] and the stencil will read of particle `q`, in 3D
    /// only. P2G reads its particles in binned order, so their data comes in runs of a block
    /// row; announcing each particle some places ahead lets the loads of the next run start
    /// early. Measured (medians of interleaved runs): `p2g/3d_256k` 25.4 →
    /// 24.7 ms on 1 thread, 13.56 → 12.87 ms on 2. In 2D, with half the bytes per particle, the
    /// hints cost more than they saved (`p2g/2d_256k` 10.1 → 11.6 ms, 1 thread), so there are
    /// none.
    #[inline(always)]
    fn prefetch(&self, q: usize) {
        if D != 3 {
            return;
        }
        let ps = self.particles;
        prefetch::read(&ps.x[q]);
        prefetch::read(&ps.v[q]);
        prefetch::read(&ps.affine[q]);
        if let Some(f) = &ps.def_grad {
            prefetch::read(&f[q]);
        }
        prefetch::read(&ps.mass[q]);
        prefetch::read(&ps.volume0[q]);
    }

    #[inline(always)]
    fn impulse(&self, p: usize) -> Impulse<D> {
        let ps = self.particles;
        let (t, dt) = self.step;
        let m = ps.mass[p];
        let stress = stress(ps, &self.materials.get(ps, p), p) * (-dt * ps.volume0[p]);
        let affine = match self.transfer {
            Transfer::Apic => ps.affine[p] * m,
            Transfer::Pic | Transfer::Flip { .. } => Matrix::<D>::zeros(),
        };
        let mv = ps.v[p] * m;
        let mv_forced = match self.body_force {
            Some(b) => mv + (b.0)(p, &ps.x[p], t) * (m * dt),
            None => mv,
        };
        Impulse {
            m,
            mv,
            mv_forced,
            affine,
            stress,
        }
    }

    /// Scatters mass and momentum (with the MLS stress impulse and the body-force impulse of the
    /// step) to `grid`. `momentum0`, when given (FLIP, damping), receives the momentum
    /// transferred without forces: `Σ w m v`, plus the affine part `Σ w m C d` under APIC.
    pub fn p2g(
        &self,
        blocks: &mut Blocks<D>,
        grid: &mut GridNodes<D>,
        momentum0: Option<&mut Vec<Vector<D>>>,
    ) {
        // The grid update overwrites every velocity; only the length matters here.
        grid.velocity
            .resize(self.layout.len(), Vector::<D>::zeros());
        let out = Sums {
            mass: &mut grid.mass,
            momentum: Some(&mut grid.momentum),
            momentum0,
            extra: None,
        };
        let with0 = out.momentum0.is_some();
        match (
            self.kernel,
            self.kernel.mls_inertia_inv(self.spec.dx),
            with0,
        ) {
            (Kernel::Quadratic, Some(minv), false) => self.p2g_rows::<3, false>(blocks, out, minv),
            (Kernel::Quadratic, Some(minv), true) => self.p2g_rows::<3, true>(blocks, out, minv),
            (Kernel::Cubic, Some(minv), false) => self.p2g_rows::<4, false>(blocks, out, minv),
            (Kernel::Cubic, Some(minv), true) => self.p2g_rows::<4, true>(blocks, out, minv),
            _ => self.p2g_nodes(blocks, out),
        }
    }

    /// P2G for the quadratic and cubic kernels: with `g = w M⁻¹ d` the stress and affine terms
    /// fuse into one matrix `Q = m C − Δt V⁰ M⁻¹ τ` (multigrid paper Eq. 7), and each node
    /// receives `w (m v + Q d)`; the stencil is walked by rows along the first axis, whose
    /// nodes are consecutive in the block buffer. `WITH0`: `out` has the forceless momentum
    /// channel (FLIP, damping).
    fn p2g_rows<const S: usize, const WITH0: bool>(
        &self,
        blocks: &mut Blocks<D>,
        out: Sums<'_, D>,
        minv: Real,
    ) {
        debug_assert_eq!(out.momentum0.is_some(), WITH0);
        let inv_dx = 1.0 / self.spec.dx;
        blocks.scatter_prefetching(
            self.layout,
            out,
            |q| self.prefetch(q),
            |p, window, (mass, momentum, momentum0, _)| {
                // The stencil first: its chain (floor, weights) then runs while the impulse's
                // (stress, logarithm) is computed; in the other order the processor reaches the
                // stencil only after the stress (P2G 3-10 % longer in 2D, 2-3 % in 3D).
                let x = &self.particles.x[p];
                let st = AxisStencil::<D, S>::new(self.kernel, self.spec, inv_dx, x);
                let im = self.impulse(p);
                let q = im.affine + im.stress * minv;
                let first = window.local(&st.base);
                st.for_each_row(first, &window.strides(), |k0, wr, dr| {
                    let row = im.mv_forced + q * dr;
                    let (mass, momentum) = (&mut mass[k0..k0 + S], &mut momentum[k0..k0 + S]);
                    for i in 0..S {
                        let (w, d0) = (st.w[0][i] * wr, st.d[0][i]);
                        mass[i] += w * im.m;
                        momentum[i] += (row + q.column(0) * d0) * w;
                    }
                    if WITH0 {
                        let row0 = im.mv + im.affine * dr;
                        for i in 0..S {
                            let (w, d0) = (st.w[0][i] * wr, st.d[0][i]);
                            momentum0[k0 + i] += (row0 + im.affine.column(0) * d0) * w;
                        }
                    }
                });
            },
        );
    }

    /// P2G over the general stencil: the linear kernel, whose MLS gradient is the kernel
    /// gradient.
    fn p2g_nodes(&self, blocks: &mut Blocks<D>, out: Sums<'_, D>) {
        let (spec, kernel) = (self.spec, self.kernel);
        let minv = kernel.mls_inertia_inv(spec.dx);
        let with0 = out.momentum0.is_some();
        blocks.scatter(
            self.layout,
            out,
            |p, window, (mass, momentum, momentum0, _)| {
                let im = self.impulse(p);
                let xp = self.particles.x[p];
                Stencil::new(kernel, spec, &xp).for_each(|node, w, grad| {
                    let d = spec.node_position(&node) - xp;
                    let g = mls_gradient(minv, w, &grad, &d);
                    let k = window.local(&node);
                    mass[k] += w * im.m;
                    momentum[k] += (im.mv_forced + im.affine * d) * w + im.stress * g;
                    if with0 {
                        momentum0[k] += (im.mv + im.affine * d) * w;
                    }
                });
            },
        );
    }
}

/// Scatters particle masses only (for volume re-estimation).
pub(crate) fn p2g_mass<const D: usize>(
    spec: &GridSpec<D>,
    layout: &NodeLayout<D>,
    kernel: Kernel,
    particles: &Particles<D>,
    blocks: &mut Blocks<D>,
    grid: &mut GridNodes<D>,
) {
    let out = Sums {
        mass: &mut grid.mass,
        momentum: None,
        momentum0: None,
        extra: None,
    };
    blocks.scatter(layout, out, |p, window, (mass, ..)| {
        let m = particles.mass[p];
        Stencil::new(kernel, spec, &particles.x[p]).for_each(|node, w, _| {
            mass[window.local(&node)] += w * m;
        });
    });
}
