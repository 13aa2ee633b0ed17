//! Weakly compressible Newtonian fluid.

use crate::math::{Matrix, Real};
use serde::{Deserialize, Serialize};

/// Tait equation of state `p = (K/γ) (J^{−γ} − 1)`, i.e. `p = B((ρ/ρ₀)^γ − 1)` with `B = K/γ`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Tait {
    /// Bulk modulus K at rest (Pa).
    pub bulk_modulus: Real,
    /// Exponent γ (dimensionless, 7 for water).
    pub gamma: Real,
}

/// A weakly compressible fluid with Newtonian viscosity.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FluidMaterial {
    /// Rest density ρ₀ (kg/m^D).
    pub density: Real,
    /// Equation of state.
    pub eos: Tait,
    /// Dynamic viscosity μ (Pa·s).
    #[serde(default)]
    pub viscosity: Real,
}

impl FluidMaterial {
    /// Pressure p(J) (Pa).
    pub fn pressure(&self, j: Real) -> Real {
        todo!("{j}")
    }

    /// Sound speed `c = √(dp/dρ)` (m/s) at volume ratio `j`.
    pub fn sound_speed(&self, j: Real) -> Real {
        todo!("{j}")
    }

    /// Kirchhoff stress `τ = J σ` with `σ = −p I + μ (∇v + ∇vᵀ)` (Pa), given J and the velocity
    /// gradient ∇v (1/s).
    pub fn kirchhoff<const D: usize>(&self, j: Real, grad_v: &Matrix<D>) -> Matrix<D> {
        todo!("{j}{grad_v}")
    }
}
