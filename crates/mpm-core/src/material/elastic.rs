//! Hyperelastic energy densities ψ(F), first Piola–Kirchhoff stresses P(F) and their
//! differentials dP(F)[δF].

use crate::math::{Dim, DimOps, Matrix, Real};
use serde::{Deserialize, Serialize};

/// Lamé parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Lame {
    /// Shear modulus μ (Pa).
    pub mu: Real,
    /// First Lamé parameter λ (Pa).
    pub lambda: Real,
}

impl Lame {
    /// From Young's modulus `e` (Pa) and Poisson's ratio `nu` (−1 < ν < 0.5).
    pub fn from_young_poisson(e: Real, nu: Real) -> Self {
        Self {
            mu: e / (2.0 * (1.0 + nu)),
            lambda: e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
        }
    }
}

/// The narrow interface every hyperelastic model offers on a deformation gradient F.
pub trait Hyperelastic<const D: usize> {
    /// Energy density ψ(F) (J/m^D, i.e. Pa).
    fn psi(&self, f: &Matrix<D>) -> Real;
    /// First Piola–Kirchhoff stress P = ∂ψ/∂F (Pa).
    fn pk1(&self, f: &Matrix<D>) -> Matrix<D>;
    /// Differential dP(F)[δF] (Pa per unit δF).
    fn dpk1(&self, f: &Matrix<D>, df: &Matrix<D>) -> Matrix<D>;
}

/// The hyperelastic models, picked by name.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case")]
pub enum ElasticModel {
    /// Compressible Neo-Hookean: ψ = μ/2 (tr FᵀF − D) − μ ln J + λ/2 (ln J)². Undefined for J ≤ 0.
    NeoHookean(Lame),
    /// Fixed-corotated (Stomakhin et al. 2012): ψ = μ ‖F − R‖² + λ/2 (J − 1)².
    FixedCorotated(Lame),
    /// St. Venant–Kirchhoff on the Hencky (logarithmic) strain ε = ln Σ:
    /// ψ = μ tr(ε²) + λ/2 (tr ε)². Undefined for J ≤ 0.
    Hencky(Lame),
    /// Small-strain linear elasticity: ψ = μ ε:ε + λ/2 (tr ε)², ε = (F + Fᵀ)/2 − I.
    LinearElastic(Lame),
    /// Stable Neo-Hookean (Smith et al. 2018), finite for J ≤ 0.
    StableNeoHookean(Lame),
}

impl ElasticModel {
    /// The model's Lamé parameters.
    pub fn lame(&self) -> Lame {
        todo!()
    }

    /// The same model with both Lamé parameters multiplied by `s`.
    pub fn scaled(&self, s: Real) -> Self {
        todo!("{s}")
    }

    /// Whether ψ, P and dP are finite for J ≤ 0.
    pub fn defined_for_inverted(&self) -> bool {
        todo!()
    }
}

impl<const D: usize> Hyperelastic<D> for ElasticModel
where
    Dim<D>: DimOps<D>,
{
    fn psi(&self, f: &Matrix<D>) -> Real {
        todo!("{f}")
    }
    fn pk1(&self, f: &Matrix<D>) -> Matrix<D> {
        todo!("{f}")
    }
    fn dpk1(&self, f: &Matrix<D>, df: &Matrix<D>) -> Matrix<D> {
        todo!("{f}{df}")
    }
}
