//! Particle-to-grid transfer (multigrid paper Eqs. 5–7): mass, momentum and the fused MLS stress
//! term `Q_p = −Δt V⁰_p τ_p M_p⁻¹ + m_p C_p`.

use crate::blocks::{Blocks, Sums};
use crate::materials::MaterialView;
use crate::params::{BodyForce, Transfer};
use mpm_core::{
    Dim, DimOps, GridNodes, GridSpec, Kernel, Material, Matrix, Particles, Real, Stencil, Vector,
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

/// Scatters mass and momentum (with the MLS stress impulse and the body-force impulse of the
/// step from `t` to `t + dt`) to `grid`. `momentum0`, when given (FLIP, damping), receives the
/// momentum transferred without forces: `Σ w m v`, plus the affine part `Σ w m C d` under APIC.
#[allow(clippy::too_many_arguments)]
pub(crate) fn p2g<const D: usize>(
    spec: &GridSpec<D>,
    kernel: Kernel,
    transfer: Transfer,
    particles: &Particles<D>,
    materials: &MaterialView<'_>,
    blocks: &mut Blocks<D>,
    grid: &mut GridNodes<D>,
    momentum0: Option<&mut Vec<Vector<D>>>,
    body_force: Option<&BodyForce<D>>,
    (t, dt): (Real, Real),
) where
    Dim<D>: DimOps<D>,
{
    let minv = kernel.mls_inertia_inv(spec.dx);
    let apic = matches!(transfer, Transfer::Apic);
    let with0 = momentum0.is_some();
    // The grid update overwrites every velocity; only the length matters here.
    grid.velocity.resize(spec.num_nodes(), Vector::<D>::zeros());
    let out = Sums {
        mass: &mut grid.mass,
        momentum: Some(&mut grid.momentum),
        momentum0,
        extra: None,
    };
    blocks.scatter(out, |p, window, (mass, momentum, momentum0, _)| {
        let (xp, vp, m) = (particles.x[p], particles.v[p], particles.mass[p]);
        let stress =
            stress(particles, &materials.get(particles, p), p) * (-dt * particles.volume0[p]);
        let affine = if apic {
            particles.affine[p] * m
        } else {
            Matrix::<D>::zeros()
        };
        let mut mv = vp * m;
        if let Some(b) = body_force {
            mv += (b.0)(p, &xp, t) * (m * dt);
        }
        Stencil::new(kernel, spec, &xp).for_each(|node, w, grad| {
            let d = spec.node_position(&node) - xp;
            let g = mls_gradient(minv, w, &grad, &d);
            let k = window.local(&node);
            mass[k] += w * m;
            momentum[k] += (mv + affine * d) * w + stress * g;
            if with0 {
                momentum0[k] += if apic {
                    (vp * m + affine * d) * w
                } else {
                    vp * (m * w)
                };
            }
        });
    });
}

/// Scatters particle masses only (for volume re-estimation).
pub(crate) fn p2g_mass<const D: usize>(
    spec: &GridSpec<D>,
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
    blocks.scatter(out, |p, window, (mass, ..)| {
        let m = particles.mass[p];
        Stencil::new(kernel, spec, &particles.x[p]).for_each(|node, w, _| {
            mass[window.local(&node)] += w * m;
        });
    });
}
