//! Conserved quantities and energies of a particle system.

use crate::material::{Hyperelastic, Material};
use crate::math::{Angular, Dim, DimOps, Real, Vector};
use crate::particles::Particles;
use serde::Serialize;

/// Totals over all particles, and the energy terms a solver adds of its own.
#[derive(Clone, Debug, PartialEq, Serialize)]
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
    /// Energy terms only some solvers have, by name (J): none from [`Diagnostics::compute`];
    /// a solver declares its own with [`Diagnostics::with_energy`] (TLMPM's penalty contact
    /// adds the potential of its springs as `contact`). They count in [`Self::total_energy`].
    pub other_energies: Vec<(&'static str, Real)>,
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
            other_energies: Vec::new(),
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

    /// The same totals with the energy term `name` (J) added (or replaced).
    pub fn with_energy(mut self, name: &'static str, value: Real) -> Self {
        match self.other_energies.iter_mut().find(|(n, _)| *n == name) {
            Some((_, v)) => *v = value,
            None => self.other_energies.push((name, value)),
        }
        self
    }

    /// The energy term `name` (J); zero when the solver has none.
    pub fn energy(&self, name: &str) -> Real {
        self.other_energies
            .iter()
            .find(|(n, _)| *n == name)
            .map_or(0.0, |(_, v)| *v)
    }

    /// Total mechanical energy: kinetic + elastic + potential + the solver's own terms (J).
    pub fn total_energy(&self) -> Real {
        self.other_energies.iter().fold(
            self.kinetic_energy + self.elastic_energy + self.potential_energy,
            |e, (_, v)| e + v,
        )
    }
}
