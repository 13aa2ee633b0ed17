//! The diffusion stage of miscible mixing (multigrid paper §4.4, Eq. 33): `Dα/Dt = k_d ∇²α` for
//! the concentration α of the particles of a [`Mixing`] pair, on their phase's grid. The stage
//! also leaves the node concentration `α_i` for the dissolution rule of §4.5.
//!
//! Node quantities are volume weighted with `V⁰_p`: `V_i = Σ_p w_ip V⁰_p` and
//! `α_i = Σ_p w_ip V⁰_p α_p / V_i`, so the kernel-gradient scheme conserves `Σ_p V⁰_p α_p`, the
//! volume of the second fluid (and with it the mass `Σ_p V⁰_p ρ₀(α_p)`).

use crate::blocks::{Blocks, GridRef, Sums};
use crate::multigrid::{DiffusionScheme, Mixing};
use mpm_core::{Particles, Real, Stencil, Vector};
use rayon::prelude::*;

/// Scratch memory of the diffusion stage.
#[derive(Clone, Debug, Default)]
pub(crate) struct MixingWork<const D: usize> {
    volume: Vec<Real>,
    amount: Vec<Real>,
    moment: Vec<Vector<D>>,
    spread: Vec<Vector<D>>,
    gradient: Vec<Vector<D>>,
    /// Node concentration α_i of the mixing phase (dimensionless; 0 where no mixing particle).
    pub concentration: Vec<Real>,
    /// The concentration of every particle after the step (unchanged for non-mixing particles).
    pub alpha: Vec<Real>,
}

impl<const D: usize> MixingWork<D> {
    /// Bytes held (lengths, not capacities).
    pub fn bytes(&self) -> usize {
        let (r, v) = (
            std::mem::size_of::<Real>(),
            std::mem::size_of::<Vector<D>>(),
        );
        (self.volume.len() + self.amount.len() + self.concentration.len() + self.alpha.len()) * r
            + (self.moment.len() + self.spread.len() + self.gradient.len()) * v
    }
}

/// One explicit diffusion step of `dt` (s) for the mixing particles binned in `blocks`; the new
/// concentrations go to `work.alpha`, the particles are not modified. Node arrays are in the
/// order of the grid's layout.
pub(crate) fn diffuse<const D: usize>(
    GridRef {
        spec,
        layout,
        kernel,
    }: GridRef<'_, D>,
    mixing: &Mixing,
    particles: &Particles<D>,
    blocks: &mut Blocks<D>,
    work: &mut MixingWork<D>,
    dt: Real,
) {
    let mixes = |p: usize| mixing.fluids.contains(&particles.material[p]);
    let alpha = |p: usize| particles.concentration_of(p);
    let mls = mixing.scheme == DiffusionScheme::MlsDifference;
    let MixingWork {
        volume,
        amount,
        moment,
        spread,
        gradient,
        concentration,
        alpha: alpha_new,
    } = work;
    let sums = Sums {
        mass: volume,
        momentum: mls.then_some(&mut *moment),
        momentum0: mls.then_some(spread),
        extra: Some(amount),
    };
    blocks.scatter(layout, sums, |p, window, (vol, mom, spr, amt)| {
        if !mixes(p) {
            return;
        }
        let (xp, v, a) = (particles.x[p], particles.volume0[p], alpha(p));
        Stencil::new(kernel, spec, &xp).for_each(|node, w, _| {
            let k = window.local(&node);
            vol[k] += w * v;
            amt[k] += w * v * a;
            if mls {
                let d = xp - spec.node_position(&node);
                mom[k] += d * (w * v * a);
                spr[k] += d * (w * v);
            }
        });
    });
    concentration.clear();
    concentration.extend(
        volume
            .iter()
            .zip(amount.iter())
            .map(|(&v, &q)| if v > 0.0 { q / v } else { 0.0 }),
    );
    let k_d = mixing.diffusivity;
    let n = particles.len();
    match mixing.scheme {
        DiffusionScheme::MlsDifference => {
            let minv = kernel
                .mls_inertia_inv(spec.dx)
                .expect("the MLS diffusion scheme is checked at setup to have M⁻¹");
            // ∇α_i = M⁻¹ Σ_p V w (α_p − α_i)(x_p − x_i)/V_i, stored in `moment`.
            moment
                .par_iter_mut()
                .zip(spread.par_iter())
                .zip(volume.par_iter().zip(concentration.par_iter()))
                .for_each(|((g, s), (&v, &c))| {
                    *g = if v > 0.0 {
                        (*g - s * c) * (minv / v)
                    } else {
                        Vector::<D>::zeros()
                    };
                });
            let grad_node = &*moment;
            (0..n)
                .into_par_iter()
                .map(|p| {
                    if !mixes(p) {
                        return alpha(p);
                    }
                    let xp = particles.x[p];
                    let mut lap = 0.0;
                    Stencil::new(kernel, spec, &xp).for_each(|node, w, _| {
                        if let Some(i) = layout.index(&node) {
                            lap += minv * w * grad_node[i].dot(&(spec.node_position(&node) - xp));
                        }
                    });
                    alpha(p) + dt * k_d * lap
                })
                .collect_into_vec(alpha_new);
        }
        DiffusionScheme::KernelGradient => {
            let c = &*concentration;
            (0..n)
                .into_par_iter()
                .map(|p| {
                    let mut g = Vector::<D>::zeros();
                    if mixes(p) {
                        Stencil::new(kernel, spec, &particles.x[p]).for_each(|node, _, grad| {
                            if let Some(i) = layout.index(&node) {
                                g += grad * c[i];
                            }
                        });
                    }
                    g
                })
                .collect_into_vec(gradient);
            // r_i = −k_d Σ_p V_p ∇w_ip·∇α_p, in `amount`; V_i again in `volume`.
            let grad_p = &*gradient;
            let sums = Sums {
                mass: volume,
                momentum: None,
                momentum0: None,
                extra: Some(amount),
            };
            blocks.scatter(layout, sums, |p, window, (vol, _, _, rate)| {
                if !mixes(p) {
                    return;
                }
                let (xp, v) = (particles.x[p], particles.volume0[p]);
                Stencil::new(kernel, spec, &xp).for_each(|node, w, grad| {
                    let k = window.local(&node);
                    vol[k] += w * v;
                    rate[k] -= k_d * v * grad.dot(&grad_p[p]);
                });
            });
            let (rate, volume) = (&*amount, &*volume);
            (0..n)
                .into_par_iter()
                .map(|p| {
                    if !mixes(p) {
                        return alpha(p);
                    }
                    let mut d = 0.0;
                    Stencil::new(kernel, spec, &particles.x[p]).for_each(|node, w, _| {
                        if let Some(i) = layout.index(&node).filter(|&i| volume[i] > 0.0) {
                            d += w * rate[i] / volume[i];
                        }
                    });
                    alpha(p) + dt * d
                })
                .collect_into_vec(alpha_new);
        }
    }
}
