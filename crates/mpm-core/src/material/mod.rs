//! Constitutive models.
//!
//! A [`Material`] is either a solid (a hyperelastic [`ElasticModel`] plus optional
//! [`Plasticity`]) or a weakly compressible fluid ([`FluidMaterial`]: Tait equation of state with
//! Newtonian viscosity). Solvers ask a material for the Kirchhoff stress `τ = J σ`, the energy
//! density and the wave speed that bounds the explicit time step.

mod elastic;
mod fluid;
mod modulation;
mod plasticity;

pub use elastic::{ElasticModel, Hyperelastic, Lame};
pub use fluid::{FluidMaterial, Tait};
pub use modulation::{Interaction, Parameter, Scaling};
pub use plasticity::{DruckerPrager, PlasticState, Plasticity, Snow};

use crate::math::{Dim, DimOps, Matrix, Real};
use serde::{Deserialize, Serialize};

/// An elastic or elasto-plastic solid.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SolidMaterial {
    /// Reference density ρ₀ (kg/m^D; kg/m³ in 3D, kg/m² in 2D).
    pub density: Real,
    /// Hyperelastic energy density.
    pub elastic: ElasticModel,
    /// Plastic flow rule (none by default).
    #[serde(default)]
    pub plasticity: Plasticity,
}

/// A material assigned to particles.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Material {
    /// Solid: particles carry a full deformation gradient F (and plastic state if plastic).
    Solid(SolidMaterial),
    /// Weakly compressible fluid: particles carry only J = det F.
    Fluid(FluidMaterial),
}

impl Material {
    /// A compressible Neo-Hookean solid of density `density` (kg/m^D), Young's modulus `young`
    /// (Pa) and Poisson's ratio `poisson`, without plasticity.
    pub fn neo_hookean(density: Real, young: Real, poisson: Real) -> Self {
        Material::Solid(SolidMaterial {
            density,
            elastic: ElasticModel::NeoHookean(Lame::from_young_poisson(young, poisson)),
            plasticity: Plasticity::None,
        })
    }

    /// A Newtonian fluid of rest density `density` (kg/m^D), Tait bulk modulus `bulk_modulus`
    /// (Pa) with exponent 7, and dynamic viscosity `viscosity` (Pa·s). The incompressible DIQ
    /// fluid reads only the density and the viscosity.
    pub fn fluid(density: Real, bulk_modulus: Real, viscosity: Real) -> Self {
        Material::Fluid(FluidMaterial {
            density,
            eos: Tait {
                bulk_modulus,
                gamma: 7.0,
            },
            viscosity,
        })
    }

    /// Reference (rest) density (kg/m^D).
    pub fn density(&self) -> Real {
        match self {
            Material::Solid(s) => s.density,
            Material::Fluid(f) => f.density,
        }
    }

    /// Whether particles of this material need the deformation gradient column.
    pub fn needs_deformation_gradient(&self) -> bool {
        matches!(self, Material::Solid(_))
    }

    /// Whether particles of this material need the plastic-state column.
    pub fn needs_plastic_state(&self) -> bool {
        matches!(self, Material::Solid(s) if !matches!(s.plasticity, Plasticity::None))
    }

    /// Whether the model is defined for inverted or degenerate elements (J ≤ 0); guard checks
    /// reject J ≤ 0 for models where it is not.
    pub fn defined_for_inverted(&self) -> bool {
        match self {
            Material::Solid(s) => s.elastic.defined_for_inverted(),
            Material::Fluid(_) => false,
        }
    }

    /// Dynamic viscosity μ (Pa·s) used by the viscous time-step limit; zero for solids.
    pub fn viscosity(&self) -> Real {
        match self {
            Material::Solid(_) => 0.0,
            Material::Fluid(f) => f.viscosity,
        }
    }
}

impl SolidMaterial {
    /// Kirchhoff stress `τ = P(F) Fᵀ` (Pa) with the plastic hardening of `state` applied.
    #[inline]
    pub fn kirchhoff<const D: usize>(&self, f: &Matrix<D>, state: &PlasticState) -> Matrix<D>
    where
        Dim<D>: DimOps<D>,
    {
        self.hardened(state).kirchhoff(f)
    }

    /// Elastic energy density ψ(F) (J/m^D) with hardening applied.
    pub fn energy_density<const D: usize>(&self, f: &Matrix<D>, state: &PlasticState) -> Real
    where
        Dim<D>: DimOps<D>,
    {
        self.hardened(state).psi(f)
    }

    /// P-wave speed `√((λ + 2μ)/ρ)` (m/s) in the current configuration, with hardening and the
    /// density change `ρ = ρ₀/J` (J clamped below at 0.1 so the bound stays finite).
    ///
    /// Inline for the same reason as [`FluidMaterial::sound_speed`], for solid particles.
    #[inline]
    pub fn wave_speed(&self, j: Real, state: &PlasticState) -> Real {
        let lame = self.hardened(state).lame();
        ((lame.lambda + 2.0 * lame.mu) * j.max(0.1) / self.density).sqrt()
    }

    /// The elastic model with the plastic hardening factor of `state` applied to both Lamé
    /// parameters.
    #[inline]
    pub fn hardened(&self, state: &PlasticState) -> ElasticModel {
        let s = self.plasticity.hardening_scale(state);
        if s == 1.0 {
            self.elastic
        } else {
            self.elastic.scaled(s)
        }
    }

    /// Applies the plastic return mapping to the trial elastic deformation gradient `f_trial`
    /// from plastic state `state`; returns the elastic part kept by the particle and the new
    /// state.
    ///
    /// It takes and returns values, out of line, so that no reference into a caller's
    /// per-particle record escapes to the call. When explicit G2P passed `&mut u.plastic` and
    /// `&f_trial` of its per-particle update record, the record's fields and the trial F went
    /// through the stack on the way to the guard check for every particle, plastic or not, some
    /// stored by halves and read whole, which the CPU cannot forward. By value, less of the
    /// record goes through memory (1 thread, interleaved runs): `g2p/2d_256k` 9.56 → 8.82 ms,
    /// `g2p/3d_256k` 25.09 → 24.48 ms, the same bits.
    #[inline(never)]
    pub fn return_mapping<const D: usize>(
        &self,
        f_trial: Matrix<D>,
        mut state: PlasticState,
    ) -> (Matrix<D>, PlasticState)
    where
        Dim<D>: DimOps<D>,
    {
        let f = self.plasticity.project(&f_trial, &mut state, &self.elastic);
        (f, state)
    }
}
