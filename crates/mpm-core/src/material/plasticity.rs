//! Plastic flow rules applied as return mappings on the trial elastic deformation gradient.

use super::ElasticModel;
use crate::math::{Dim, DimOps, Matrix, Real};
use serde::{Deserialize, Serialize};

/// Per-particle plastic state. The default is the virgin state.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlasticState {
    /// Snow: plastic volume ratio J_P = det F_P (dimensionless, 1 when virgin).
    pub jp: Real,
    /// Sand: accumulated plastic strain q, the hardening variable of Klár et al. 2016.
    pub q: Real,
    /// Sand: volume-correction scalar v_c (log of volume gained by the tip projection,
    /// Tampubolon et al. 2017); 0 when virgin.
    pub vc: Real,
}

impl Default for PlasticState {
    fn default() -> Self {
        Self {
            jp: 1.0,
            q: 0.0,
            vc: 0.0,
        }
    }
}

/// Snow plasticity (Stomakhin et al. 2013).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Snow {
    /// Critical compression θ_c (dimensionless, e.g. 2.5e-2).
    pub theta_c: Real,
    /// Critical stretch θ_s (dimensionless, e.g. 7.5e-3).
    pub theta_s: Real,
    /// Hardening coefficient ξ (dimensionless, e.g. 10).
    pub hardening: Real,
}

/// Drucker–Prager sand plasticity (Klár et al. 2016) with volume correction.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DruckerPrager {
    /// Hardening parameters h₀..h₃ of the friction angle φ_F = h₀ + (h₁ q − h₃) e^{−h₂ q}
    /// (degrees for h₀, h₁, h₃; h₂ dimensionless). Klár et al. use (35, 9, 0.2, 10).
    pub h: [Real; 4],
    /// Cohesion c (dimensionless fraction of the tip shift, ≥ 0).
    pub cohesion: Real,
    /// Whether the volume correction of Tampubolon et al. 2017 is applied.
    pub volume_correction: bool,
}

/// Plastic flow rules.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case")]
pub enum Plasticity {
    /// Purely elastic.
    #[default]
    None,
    /// Snow: singular values clamped to [1 − θ_c, 1 + θ_s], hardening e^{ξ(1 − J_P)}.
    Snow(Snow),
    /// Drucker–Prager sand.
    DruckerPrager(DruckerPrager),
}

impl Plasticity {
    /// Multiplier applied to both Lamé parameters for the current state (1 when no hardening).
    pub fn hardening_scale(&self, state: &PlasticState) -> Real {
        todo!("{state:?}")
    }

    /// Return mapping: projects the trial elastic deformation gradient onto the admissible set,
    /// updates `state`, and returns the new elastic deformation gradient.
    pub fn project<const D: usize>(
        &self,
        f_trial: &Matrix<D>,
        state: &mut PlasticState,
        elastic: &ElasticModel,
    ) -> Matrix<D>
    where
        Dim<D>: DimOps<D>,
    {
        todo!("{f_trial}{state:?}{elastic:?}")
    }
}
