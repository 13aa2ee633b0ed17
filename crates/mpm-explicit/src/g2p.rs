//! Grid-to-particle transfer (multigrid paper Eqs. 8–10): velocity, affine field, deformation
//! update with plasticity, fluid J, advection, and the particle guard checks.
//!
//! Results go to a scratch buffer first and are committed only when every particle passes its
//! checks, so a failed step leaves the particles exactly as they were (a dt/2 retry needs no
//! backup copy).

use crate::materials::MaterialView;
use crate::multigrid::{Dissolution, Mixing, Porous};
use crate::p2g::mls_gradient;
use crate::params::{SoftWalls, Transfer};
use mpm_core::material::PlasticState;
use mpm_core::{
    Dim, DimOps, GridNodes, GridSpec, Kernel, Location, Material, Matrix, Particles, Real, Stencil,
    Vector, Violation,
};
use rayon::prelude::*;

/// The new state of one particle, before commit.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Update<const D: usize> {
    x: Vector<D>,
    v: Vector<D>,
    c: Matrix<D>,
    f: Matrix<D>,
    j: Real,
    plastic: PlasticState,
    fault: Option<(Violation, Real)>,
}

impl<const D: usize> Default for Update<D> {
    fn default() -> Self {
        Self {
            x: Vector::<D>::zeros(),
            v: Vector::<D>::zeros(),
            c: Matrix::<D>::zeros(),
            f: Matrix::<D>::identity(),
            j: 1.0,
            plastic: PlasticState::default(),
            fault: None,
        }
    }
}

/// What G2P needs besides particles and grid.
pub(crate) struct G2pContext<'a, const D: usize> {
    pub spec: &'a GridSpec<D>,
    pub kernel: Kernel,
    pub transfer: Transfer,
    pub materials: MaterialView<'a>,
    pub soft_walls: Option<SoftWalls>,
}

/// The multi-grid state of one particle after the step, before commit.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Extra {
    phi_eff: Real,
    concentration: Real,
    dissolve: bool,
}

/// What the multi-grid particle update needs: porous interaction, dissolution, and the
/// concentrations of the diffusion stage.
pub(crate) struct ExtraContext<'a> {
    pub porous: Option<&'a Porous>,
    pub dissolution: Option<&'a Dissolution>,
    /// Node concentration of the mixing phase (empty without mixing).
    pub node_concentration: &'a [Real],
    /// Particle concentrations after diffusion, if the diffusion stage ran.
    pub alpha: Option<&'a [Real]>,
}

impl<const D: usize> G2pContext<'_, D>
where
    Dim<D>: DimOps<D>,
{
    /// Gathers from the grid into `updates` and runs the guard checks. Returns the first
    /// (lowest-index) failing particle.
    /// `grids` and, with FLIP, `velocity_old` have one entry per phase.
    pub fn gather(
        &self,
        particles: &Particles<D>,
        grids: &[GridNodes<D>],
        velocity_old: Option<&[Vec<Vector<D>>]>,
        updates: &mut Vec<Update<D>>,
        dt: Real,
    ) -> Result<(), (Location, Violation, Real)> {
        updates.resize(particles.len(), Update::default());
        updates.par_iter_mut().enumerate().for_each(|(p, u)| {
            let k = particles.phase_of(p) as usize;
            let v0 = velocity_old.map(|v| v[k].as_slice());
            *u = self.particle(particles, &grids[k], v0, p, dt)
        });
        match updates.par_iter().position_first(|u| u.fault.is_some()) {
            Some(p) => {
                let (violation, value) = updates[p].fault.unwrap_or((Violation::LeftDomain, 0.0));
                Err((Location::Particle(p), violation, value))
            }
            None => Ok(()),
        }
    }

    fn particle(
        &self,
        particles: &Particles<D>,
        grid: &GridNodes<D>,
        velocity_old: Option<&[Vector<D>]>,
        p: usize,
        dt: Real,
    ) -> Update<D> {
        let spec = self.spec;
        let minv = self.kernel.mls_inertia_inv(spec.dx);
        let xp = particles.x[p];
        let (mut v_pic, mut dv, mut c) = (
            Vector::<D>::zeros(),
            Vector::<D>::zeros(),
            Matrix::<D>::zeros(),
        );
        Stencil::new(self.kernel, spec, &xp).for_each(|node, w, grad| {
            let Some(i) = spec.linear_index(&node) else {
                return;
            };
            let vi = grid.velocity[i];
            let d = spec.node_position(&node) - xp;
            v_pic += vi * w;
            c += vi * mls_gradient(minv, w, &grad, &d).transpose();
            if let Some(v0) = velocity_old {
                dv += (vi - v0[i]) * w;
            }
        });
        let mut v = match self.transfer {
            Transfer::Flip { blend } => (particles.v[p] + dv) * blend + v_pic * (1.0 - blend),
            Transfer::Apic | Transfer::Pic => v_pic,
        };
        if let Some(sw) = self.soft_walls {
            soften(spec, &sw, &xp, &mut v);
        }
        let mut u = Update {
            x: xp + v * dt,
            v,
            c,
            ..Update::default()
        };
        let material = self.materials.get(particles, p);
        let grad_step = Matrix::<D>::identity() + c * dt;
        match material.as_ref() {
            Material::Solid(s) => {
                let f_trial = grad_step * particles.def_grad_of(p);
                u.f = match &particles.plastic {
                    Some(states) => {
                        u.plastic = states[p];
                        s.return_mapping(&f_trial, &mut u.plastic)
                    }
                    None => f_trial,
                };
                u.j = Dim::<D>::det(&u.f);
            }
            Material::Fluid(_) => {
                u.j = (1.0 + dt * c.trace()) * particles.jacobian_of(p);
                if let Some(f) = &particles.def_grad {
                    u.f = f[p];
                }
            }
        }
        u.fault = check(spec, self.kernel, &material, &u, dt);
        u
    }

    /// The multi-grid particle state after the step: volume fraction φ_p (Eqs. 19–20) and the
    /// effective fraction φ_eff, the diffused concentration, and the dissolution progress.
    pub fn gather_extra(
        &self,
        particles: &Particles<D>,
        grids: &[GridNodes<D>],
        ctx: &ExtraContext<'_>,
        extras: &mut Vec<Extra>,
        dt: Real,
    ) {
        (0..particles.len())
            .into_par_iter()
            .map(|p| self.extra(particles, grids, ctx, p, dt))
            .collect_into_vec(extras);
    }

    fn extra(
        &self,
        particles: &Particles<D>,
        grids: &[GridNodes<D>],
        ctx: &ExtraContext<'_>,
        p: usize,
        dt: Real,
    ) -> Extra {
        let spec = self.spec;
        let k = particles.phase_of(p) as usize;
        let dissolving = ctx.dissolution.filter(|d| d.solid == particles.material[p]);
        let (mut phi, mut wet, mut c_bar) = (0.0, 0.0, 0.0);
        Stencil::new(self.kernel, spec, &particles.x[p]).for_each(|node, w, _| {
            let Some(i) = spec.linear_index(&node) else {
                return;
            };
            if ctx.porous.is_some()
                && grids[k].mass[i] > 0.0
                && grids
                    .iter()
                    .enumerate()
                    .any(|(j, g)| j != k && g.mass[i] > 0.0)
            {
                phi += w;
            }
            if let Some(d) = dissolving {
                if grids[d.fluid_phase as usize].mass[i] > 0.0 {
                    wet += w;
                }
                c_bar += w * ctx.node_concentration.get(i).copied().unwrap_or(0.0);
            }
        });
        let mut e = Extra {
            phi_eff: particles.volume_fraction_of(p),
            concentration: ctx
                .alpha
                .map_or_else(|| particles.concentration_of(p), |a| a[p]),
            dissolve: false,
        };
        // Σ w = 1 holds to round-off only: keep fractions in [0, 1].
        if let Some(porous) = ctx.porous {
            e.phi_eff = porous.update.update(e.phi_eff, phi.min(1.0), dt);
        }
        if let Some(d) = dissolving {
            let fresh = (1.0 - c_bar).clamp(0.0, 1.0);
            e.concentration = (e.concentration + dt * d.rate * wet.min(1.0) * fresh).min(1.0);
            e.dissolve = e.concentration >= 1.0;
        }
        e
    }
}

/// Predictive softened walls: pushes the velocity back when `x + τ v` is within `margin` of the
/// grid box.
fn soften<const D: usize>(spec: &GridSpec<D>, sw: &SoftWalls, x: &Vector<D>, v: &mut Vector<D>) {
    let (lo, hi) = (spec.origin, spec.max_corner());
    for a in 0..D {
        let predicted = x[a] + sw.lookahead * v[a];
        let (wall_lo, wall_hi) = (lo[a] + sw.margin, hi[a] - sw.margin);
        if predicted < wall_lo {
            v[a] += (wall_lo - predicted) / sw.lookahead;
        } else if predicted > wall_hi {
            v[a] += (wall_hi - predicted) / sw.lookahead;
        }
    }
}

/// Guard checks on one particle's new state (DESIGN §6).
fn check<const D: usize>(
    spec: &GridSpec<D>,
    kernel: Kernel,
    material: &Material,
    u: &Update<D>,
    dt: Real,
) -> Option<(Violation, Real)> {
    let finite = |m: &[Real]| m.iter().all(|c| c.is_finite());
    if !finite(u.v.as_slice()) {
        return Some((Violation::NonFinite("velocity"), u.v.norm()));
    }
    if !finite(u.x.as_slice()) {
        return Some((Violation::NonFinite("position"), u.x.norm()));
    }
    if !finite(u.f.as_slice()) || !u.j.is_finite() {
        return Some((Violation::NonFinite("deformation"), u.j));
    }
    if u.j <= 0.0 && !material.defined_for_inverted() {
        return Some((Violation::InvertedElement, u.j));
    }
    if !spec.contains_stencil(kernel, &u.x) {
        return Some((Violation::LeftDomain, u.x.norm()));
    }
    let speed = u.v.norm();
    if speed * dt > spec.dx {
        return Some((Violation::CflExceeded, speed));
    }
    None
}

/// Writes the accepted multi-grid state: φ_eff, concentration and the mass of mixing particles
/// (`m = V⁰ ρ₀(α)`), and turns fully dissolved particles into fluid particles (see
/// [`Dissolution`]).
pub(crate) fn commit_extra<const D: usize>(
    particles: &mut Particles<D>,
    extras: &[Extra],
    materials: &[Material],
    mixing: Option<&Mixing>,
    dissolution: Option<&Dissolution>,
) {
    if let Some(f) = &mut particles.volume_fraction {
        f.par_iter_mut()
            .zip(extras)
            .for_each(|(f, e)| *f = e.phi_eff);
    }
    if let Some(c) = &mut particles.concentration {
        c.par_iter_mut()
            .zip(extras)
            .for_each(|(c, e)| *c = e.concentration);
    }
    if let Some(mix) = mixing {
        let view = MaterialView::new(materials, None, Some(mix));
        let masses: Vec<Option<Real>> = (0..particles.len())
            .into_par_iter()
            .map(|p| {
                mix.fluids
                    .contains(&particles.material[p])
                    .then(|| particles.volume0[p] * view.rest_density(particles, p))
            })
            .collect();
        for (m, new) in particles.mass.iter_mut().zip(masses) {
            if let Some(new) = new {
                *m = new;
            }
        }
    }
    if let Some(d) = dissolution {
        let rho = materials[d.into as usize].density();
        for p in (0..particles.len()).filter(|&p| extras[p].dissolve) {
            particles.material[p] = d.into;
            if let Some(k) = &mut particles.phase {
                k[p] = d.fluid_phase;
            }
            if let Some(c) = &mut particles.concentration {
                c[p] = 1.0;
            }
            if let Some(j) = &mut particles.jacobian {
                j[p] = 1.0;
            }
            if let Some(f) = &mut particles.def_grad {
                f[p] = Matrix::<D>::identity();
            }
            if let Some(s) = &mut particles.plastic {
                s[p] = PlasticState::default();
            }
            particles.volume0[p] = particles.mass[p] / rho;
        }
    }
}

/// Writes the accepted updates into the particle columns.
pub(crate) fn commit<const D: usize>(particles: &mut Particles<D>, updates: &[Update<D>]) {
    let Particles {
        x,
        v,
        affine,
        def_grad,
        jacobian,
        plastic,
        ..
    } = particles;
    rayon::join(
        || {
            x.par_iter_mut().zip(updates).for_each(|(x, u)| *x = u.x);
            v.par_iter_mut().zip(updates).for_each(|(v, u)| *v = u.v);
        },
        || {
            affine
                .par_iter_mut()
                .zip(updates)
                .for_each(|(c, u)| *c = u.c);
            if let Some(f) = def_grad {
                f.par_iter_mut().zip(updates).for_each(|(f, u)| *f = u.f);
            }
            if let Some(j) = jacobian {
                j.par_iter_mut().zip(updates).for_each(|(j, u)| *j = u.j);
            }
            if let Some(s) = plastic {
                s.par_iter_mut()
                    .zip(updates)
                    .for_each(|(s, u)| *s = u.plastic);
            }
        },
    );
}
