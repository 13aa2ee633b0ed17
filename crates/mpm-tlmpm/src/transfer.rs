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
/// is left out with [`Transfer::Pic`] and [`Transfer::Flip`].
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
                Transfer::Pic | Transfer::Flip { .. } => v[p],
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

/// The FLIP part of G2P ([`Transfer::Flip`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct FlipBlend<'a, const D: usize> {
    /// FLIP fraction α ∈ [0, 1] (dimensionless).
    pub alpha: Real,
    /// Node velocities after P2G, v̂_i (m/s).
    pub grid_velocity: &'a [Vector<D>],
    /// Particle velocities at the start of the step, v_p^n (m/s).
    pub v: &'a [Vector<D>],
}

/// G2P from node displacements `u_i` (m) and end-of-step node velocities `v_i` (m/s):
/// `x_p += Σ W_ip u_i`, `v_p = Σ W_ip v_i`, `F_p = F_p^n + Σ u_i ⊗ ∇^X W_ip` (the same sum as
/// the Newton solve's `F(u)`) and `C_p = Σ v_i ⊗ ∇^X W_ip`. The velocities are `v_i = u_i/Δt`
/// (backward Euler, explicit) when `velocity` is `None`. With `flip`, the velocity is the blend
/// `α (v_p^n + Σ W_ip (v_i − v̂_i)) + (1 − α) Σ W_ip v_i` instead.
pub(crate) fn grid_to_particles<const D: usize>(
    reference: &ReferenceConfig<D>,
    (u, velocity): (&[Vector<D>], Option<&[Vector<D>]>),
    dt: Real,
    (x, def_grad): (&[Vector<D>], &[Matrix<D>]),
    flip: Option<FlipBlend<'_, D>>,
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
    if let Some(v) = velocity {
        return grid_to_particles_with(reference, (u, v), (x, def_grad), flip, out);
    }
    let inv_dt = 1.0 / dt;
    out.par_iter_mut().enumerate().for_each(|(p, up)| {
        let (nodes, weights, grads) = reference.slots(p);
        let mut du = Vector::<D>::zeros();
        let mut dv = Vector::<D>::zeros();
        let mut grad_u = Matrix::<D>::zeros();
        let mut f = def_grad[p];
        for ((&i, &w), g) in nodes.iter().zip(weights).zip(grads) {
            if i != NONE {
                let ui = u[i as usize];
                du += ui * w;
                if let Some(fb) = &flip {
                    dv += (ui * inv_dt - fb.grid_velocity[i as usize]) * w;
                }
                let outer = ui * g.transpose();
                grad_u += outer;
                f += outer;
            }
        }
        let v_pic = du * inv_dt;
        *up = Update {
            x: x[p] + du,
            v: match &flip {
                Some(fb) => (fb.v[p] + dv) * fb.alpha + v_pic * (1.0 - fb.alpha),
                None => v_pic,
            },
            affine: grad_u * inv_dt,
            def_grad: f,
        };
    });
}

/// [`grid_to_particles`] with given end-of-step node velocities `v` (m/s).
fn grid_to_particles_with<const D: usize>(
    reference: &ReferenceConfig<D>,
    (u, v): (&[Vector<D>], &[Vector<D>]),
    (x, def_grad): (&[Vector<D>], &[Matrix<D>]),
    flip: Option<FlipBlend<'_, D>>,
    out: &mut Vec<Update<D>>,
) {
    out.par_iter_mut().enumerate().for_each(|(p, up)| {
        let (nodes, weights, grads) = reference.slots(p);
        let (mut du, mut vp, mut dv) = (
            Vector::<D>::zeros(),
            Vector::<D>::zeros(),
            Vector::<D>::zeros(),
        );
        let (mut grad_v, mut f) = (Matrix::<D>::zeros(), def_grad[p]);
        for ((&i, &w), g) in nodes.iter().zip(weights).zip(grads) {
            if i != NONE {
                let (ui, vi) = (u[i as usize], v[i as usize]);
                du += ui * w;
                vp += vi * w;
                if let Some(fb) = &flip {
                    dv += (vi - fb.grid_velocity[i as usize]) * w;
                }
                grad_v += vi * g.transpose();
                f += ui * g.transpose();
            }
        }
        *up = Update {
            x: x[p] + du,
            v: match &flip {
                Some(fb) => (fb.v[p] + dv) * fb.alpha + vp * (1.0 - fb.alpha),
                None => vp,
            },
            affine: grad_v,
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

#[cfg(test)]
mod tests {
    use super::*;
    use mpm_core::{GridSpec, Kernel};

    /// A jittered lattice of 64 particles in `[0.3, 0.7]²` on a quadratic-B-spline grid of
    /// spacing 0.1 m, pseudo-random particle and node velocities, and node displacements
    /// `u_i = Δt (v̂_i + a_i)` for node increments `a_i` (m/s) from `increment`.
    struct Setup {
        reference: ReferenceConfig<2>,
        x: Vec<Vector<2>>,
        v: Vec<Vector<2>>,
        grid_velocity: Vec<Vector<2>>,
        u: Vec<Vector<2>>,
        dt: Real,
    }

    fn setup(increment: impl Fn(usize) -> Vector<2>) -> Setup {
        let mut s: u64 = 11;
        let mut next = move || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as Real / (1u64 << 53) as Real - 0.5
        };
        let x: Vec<Vector<2>> = (0..64)
            .map(|k| {
                let (i, j) = ((k % 8) as Real, (k / 8) as Real);
                Vector::<2>::new(0.325 + 0.05 * i, 0.325 + 0.05 * j)
                    + Vector::<2>::new(0.01 * next(), 0.01 * next())
            })
            .collect();
        let mass = vec![1.5; x.len()];
        let spec = GridSpec::<2>::new(Vector::<2>::zeros(), 0.1, [12; 2]);
        let reference = ReferenceConfig::new(spec, Kernel::Quadratic, &[], &x, &mass).unwrap();
        let v = (0..x.len())
            .map(|_| Vector::<2>::new(next(), next()))
            .collect();
        let grid_velocity: Vec<Vector<2>> = (0..reference.num_nodes())
            .map(|_| Vector::<2>::new(next(), next()))
            .collect();
        let dt = 1e-3;
        let u = grid_velocity
            .iter()
            .enumerate()
            .map(|(i, vh)| (vh + increment(i)) * dt)
            .collect();
        Setup {
            reference,
            x,
            v,
            grid_velocity,
            u,
            dt,
        }
    }

    fn g2p(s: &Setup, alpha: Option<Real>) -> Vec<Update<2>> {
        let f = vec![Matrix::<2>::identity(); s.x.len()];
        let flip = alpha.map(|alpha| FlipBlend {
            alpha,
            grid_velocity: &s.grid_velocity,
            v: &s.v,
        });
        let mut out = Vec::new();
        grid_to_particles(&s.reference, (&s.u, None), s.dt, (&s.x, &f), flip, &mut out);
        out
    }

    #[test]
    fn flip_blend_zero_is_pic_bitwise() {
        let s = setup(|i| Vector::<2>::new(0.1 * i as Real, -0.2));
        let (pic, flip) = (g2p(&s, None), g2p(&s, Some(0.0)));
        for (a, b) in pic.iter().zip(&flip) {
            assert_eq!(a.v, b.v);
            assert_eq!(a.x, b.x);
            assert_eq!(a.affine, b.affine);
            assert_eq!(a.def_grad, b.def_grad);
        }
    }

    #[test]
    fn flip_blend_one_adds_the_grid_velocity_increment() {
        // A uniform increment a reaches every particle whole, whatever v_p and v̂: the weights
        // sum to one. The PIC velocity instead forgets v_p.
        let a = Vector::<2>::new(0.75, -1.25);
        let s = setup(|_| a);
        let flip = g2p(&s, Some(1.0));
        let pic = g2p(&s, None);
        for (p, (f, q)) in flip.iter().zip(&pic).enumerate() {
            let err = (f.v - (s.v[p] + a)).norm();
            assert!(err < 1e-12, "particle {p}: |v − (v_p + a)| = {err:e} m/s");
            assert!((q.v - (s.v[p] + a)).norm() > 1e-3);
            // Positions and F follow the node displacements, not the blended velocity.
            assert_eq!((f.x, f.def_grad), (q.x, q.def_grad));
        }
        // A blend α is the same linear combination of the two (to rounding).
        let half = g2p(&s, Some(0.3));
        for ((h, f), q) in half.iter().zip(&flip).zip(&pic) {
            assert!((h.v - (f.v * 0.3 + q.v * 0.7)).norm() < 1e-12);
        }
    }
}
