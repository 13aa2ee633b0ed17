//! Transfers between particles and the reference grid, with the cached weights.
//!
//! P2G is a gather: each active node sums over its particles in ascending order. G2P writes one
//! update per particle into scratch storage; the guard checks then scan the updates in particle
//! order, so the reported particle is the lowest failing index for any thread count.

use crate::params::Transfer;
use crate::reference::{ReferenceConfig, NONE};
use mpm_core::{Dim, DimOps, Location, Matrix, Real, Vector, Violation};
use rayon::prelude::*;

/// Node velocities `v̂_i = Σ_p W_ip m_p (v_p + C_p (X_i − X_p)) / m_i` (m/s); the affine term
/// is left out with [`Transfer::Pic`].
pub(crate) fn momentum_to_grid<const D: usize>(
    reference: &ReferenceConfig<D>,
    transfer: Transfer,
    (v, affine, mass): (&[Vector<D>], &[Matrix<D>], &[Real]),
    out: &mut Vec<Vector<D>>,
) {
    out.resize(reference.num_nodes(), Vector::<D>::zeros());
    let (xp, xi, mi) = (
        reference.positions(),
        reference.node_positions(),
        reference.node_masses(),
    );
    out.par_iter_mut().enumerate().for_each(|(i, vi)| {
        let mut momentum = Vector::<D>::zeros();
        for &(p, k) in reference.incidence(i) {
            let p = p as usize;
            let w = reference.slot(p, k as usize).0;
            let vp = match transfer {
                Transfer::Apic | Transfer::Persistent => v[p] + affine[p] * (xi[i] - xp[p]),
                Transfer::Pic => v[p],
            };
            momentum += vp * (w * mass[p]);
        }
        *vi = momentum / mi[i];
    });
}

/// One particle's new state.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Update<const D: usize> {
    /// Position (m).
    pub x: Vector<D>,
    /// Velocity (m/s).
    pub v: Vector<D>,
    /// Reference velocity gradient `∇^X V` (1/s).
    pub affine: Matrix<D>,
    /// Deformation gradient.
    pub def_grad: Matrix<D>,
}

/// G2P from node displacements `u_i = Δt v_i` (m): `x_p += Σ W_ip u_i`, `v_p = Σ W_ip u_i/Δt`,
/// `F_p = F_p^n + Σ u_i ⊗ ∇^X W_ip` (the same sum as the Newton solve's `F(u)`) and
/// `C_p = Σ u_i ⊗ ∇^X W_ip / Δt`.
pub(crate) fn grid_to_particles<const D: usize>(
    reference: &ReferenceConfig<D>,
    u: &[Vector<D>],
    dt: Real,
    (x, def_grad): (&[Vector<D>], &[Matrix<D>]),
    out: &mut Vec<Update<D>>,
) {
    let n = reference.num_particles();
    out.resize(
        n,
        Update {
            x: Vector::<D>::zeros(),
            v: Vector::<D>::zeros(),
            affine: Matrix::<D>::zeros(),
            def_grad: Matrix::<D>::zeros(),
        },
    );
    let inv_dt = 1.0 / dt;
    out.par_iter_mut().enumerate().for_each(|(p, up)| {
        let (nodes, weights, grads) = reference.slots(p);
        let mut du = Vector::<D>::zeros();
        let mut grad_u = Matrix::<D>::zeros();
        let mut f = def_grad[p];
        for ((&i, &w), g) in nodes.iter().zip(weights).zip(grads) {
            if i != NONE {
                let ui = u[i as usize];
                du += ui * w;
                let outer = ui * g.transpose();
                grad_u += outer;
                f += outer;
            }
        }
        *up = Update {
            x: x[p] + du,
            v: du * inv_dt,
            affine: grad_u * inv_dt,
            def_grad: f,
        };
    });
}

/// Guard checks on G2P results: non-finite state, and `J ≤ 0` for particles whose model is
/// undefined there (`inverted_ok(p)` false). Returns the lowest failing particle.
pub(crate) fn check_updates<const D: usize>(
    updates: &[Update<D>],
    inverted_ok: impl Fn(usize) -> bool + Sync,
) -> Result<(), (Location, Violation, Real)>
where
    Dim<D>: DimOps<D>,
{
    let failure = |p: usize| -> Option<(Location, Violation, Real)> {
        let u = &updates[p];
        let at = Location::Particle(p);
        if let Some(x) = u.x.iter().find(|x| !x.is_finite()) {
            return Some((at, Violation::NonFinite("position"), *x));
        }
        if let Some(v) = u.v.iter().find(|v| !v.is_finite()) {
            return Some((at, Violation::NonFinite("velocity"), *v));
        }
        if let Some(f) = u.def_grad.iter().find(|f| !f.is_finite()) {
            return Some((at, Violation::NonFinite("deformation gradient"), *f));
        }
        let j = Dim::<D>::det(&u.def_grad);
        (j <= 0.0 && !inverted_ok(p)).then_some((at, Violation::InvertedElement, j))
    };
    match (0..updates.len())
        .into_par_iter()
        .filter_map(failure)
        .find_first(|_| true)
    {
        Some(f) => Err(f),
        None => Ok(()),
    }
}
