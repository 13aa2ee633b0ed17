//! Conserved quantities and energies of a particle system.

use crate::material::{Hyperelastic, Material};
use crate::math::{Angular, Dim, DimOps, Real, Vector};
use crate::particles::Particles;
use serde::Serialize;

/// Totals over all particles.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Diagnostics<const D: usize> {
    /// Total mass (kg).
    pub mass: Real,
    /// Total linear momentum (kg·m/s).
    #[serde(skip)]
    pub momentum: Vector<D>,
    /// Total angular momentum about the origin (kg·m²/s), including the APIC affine spin.
    pub angular_momentum: Angular,
    /// Kinetic energy ½ Σ m |v|² (J).
    pub kinetic_energy: Real,
    /// Stored elastic energy Σ V⁰ ψ(F_E) of solids plus Σ V⁰ ψ(J) of fluids (J).
    pub elastic_energy: Real,
    /// Gravitational potential energy −Σ m g·x (J), zero when `gravity` is zero.
    pub potential_energy: Real,
    /// Potential energy of penalty contact springs (J): zero from [`Diagnostics::compute`];
    /// solvers with penalty contact (TLMPM's Eq. 4) set it.
    pub contact_energy: Real,
}

impl<const D: usize> Diagnostics<D> {
    /// Computes the totals. `inertia` is the constant MLS/APIC inertia `D_p = 1/M_p⁻¹` (m²) when
    /// particles carry affine velocity fields whose spin counts as angular momentum (APIC with a
    /// quadratic or cubic kernel), else `None`. Sums run serially in particle order, so results
    /// do not depend on the thread count.
    pub fn compute(
        particles: &Particles<D>,
        materials: &[Material],
        inertia: Option<Real>,
        gravity: &Vector<D>,
    ) -> Self
    where
        Dim<D>: DimOps<D>,
    {
        let mut d = Self {
            mass: 0.0,
            momentum: Vector::<D>::zeros(),
            angular_momentum: Angular::zeros(),
            kinetic_energy: 0.0,
            elastic_energy: 0.0,
            potential_energy: 0.0,
            contact_energy: 0.0,
        };
        for p in 0..particles.len() {
            let (m, x, v) = (particles.mass[p], particles.x[p], particles.v[p]);
            d.mass += m;
            d.momentum += v * m;
            d.angular_momentum += Dim::<D>::cross(&x, &v) * m;
            if let Some(inertia) = inertia {
                d.angular_momentum += Dim::<D>::axial(&particles.affine[p]) * (m * inertia);
            }
            d.kinetic_energy += 0.5 * m * v.norm_squared();
            d.potential_energy -= m * gravity.dot(&x);
            d.elastic_energy += particles.volume0[p]
                * match &materials[particles.material[p] as usize] {
                    Material::Solid(s) => match (&particles.def_grad, &particles.plastic) {
                        (Some(f), Some(st)) => s.energy_density(&f[p], &st[p]),
                        (Some(f), None) => s.elastic.psi(&f[p]),
                        _ => 0.0,
                    },
                    Material::Fluid(fl) => particles
                        .jacobian
                        .as_ref()
                        .map_or(0.0, |j| fl.energy_density(j[p])),
                };
        }
        d
    }

    /// Total mechanical energy: kinetic + elastic + potential + contact (J).
    pub fn total_energy(&self) -> Real {
        self.kinetic_energy + self.elastic_energy + self.potential_energy + self.contact_energy
    }
}
