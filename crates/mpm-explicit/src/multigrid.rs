//! Parameters of multi-grid MLS-MPM (multigrid paper §4): phases and the couplings between their
//! grids, porous interaction, miscible mixing and dissolution. Equation numbers are the paper's.
//!
//! Every phase has its own grid arrays on the shared [`mpm_core::GridSpec`]; the phases' grids
//! interact only through the couplings listed here, node by node, after gravity and before the
//! boundary conditions. A scene with one phase and no couplings runs the single-grid path.

use mpm_core::material::Interaction;
use mpm_core::Real;
use serde::{Deserialize, Serialize};

/// The phases of a simulation and how their grids couple.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Phases {
    /// Number of phases (grids), at least 1. Particles carry a phase index when it is above 1.
    pub count: u32,
    /// Couplings between pairs of phases, applied in this order at every node.
    pub couplings: Vec<Coupling>,
}

impl Default for Phases {
    fn default() -> Self {
        Self {
            count: 1,
            couplings: Vec::new(),
        }
    }
}

/// The coupling between two phase grids `a` and `b`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Coupling {
    /// The two phases `[a, b]` (distinct). For Eq. 15, `b` is the fluid (pore-pressure) phase.
    pub phases: [u32; 2],
    /// How momentum is exchanged.
    pub kind: CouplingKind,
    /// Buoyancy penalty force (§4.3, Eqs. 31–32), if any; combines with any kind.
    pub buoyancy: Option<BuoyancyPenalty>,
    /// The non-dissipative pore-pressure buoyancy term of Eq. 15.
    pub pressure_buoyancy: PressureBuoyancy,
}

/// Momentum exchange between two phase grids at nodes where both have mass.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum CouplingKind {
    /// Single-grid coupling: both phases take the mass-weighted mean velocity
    /// `(m_a v_a + m_b v_b)/(m_a + m_b)`, as if their momenta were summed on one grid.
    Full,
    /// Drag (§4.1, Eq. 14) `f_a = c_E m_a m_b (v_b − v_a)`, `f_b = −f_a`, with `c_E` clamped per
    /// node to `c_E,max = 1/(Δt (m_a + m_b))` (Eq. 17), which is full coupling.
    Drag(Drag),
    /// Contact (§4.2, Eqs. 24–30).
    Contact(ContactCoupling),
}

/// The drag coefficient `c_E` of Eq. 14.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Drag {
    /// `c_E` given directly (1/(kg·s)); resolution dependent, since node masses scale with Δx^D.
    Coefficient(Real),
    /// `c_E` from the porous medium as in Tampubolon et al. 2017: the momentum exchange per unit
    /// volume is `n² ρ_w g/k · (v_w − v_s)`, with porosity `n`, the fluid's rest density `ρ_w`,
    /// `g = |gravity|` and hydraulic conductivity `k`. Over a node's volume `Δx^D` this is Eq. 14
    /// with `c_E = n² ρ_w g Δx^D / (k m_a m_b)`. Phase `b` is the fluid.
    Permeability {
        /// Porosity n ∈ (0, 1] (dimensionless).
        porosity: Real,
        /// Hydraulic conductivity k (m/s).
        conductivity: Real,
    },
}

/// Contact coupling of §4.2: the collision force of Eq. 24,
/// `f_col = (p_a m_b − p_b m_a)/((m_a + m_b) Δt)` (the force on `b`), split along the interface
/// normal of Eqs. 26–27 into a normal part scaled by β and a tangential part limited by friction δ
/// (Eqs. 25, 28–30).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContactCoupling {
    /// Normal share β ∈ [0, 1] (dimensionless); 1 stops the approach completely.
    pub normal_share: Real,
    /// Tangential force rule.
    pub friction: Friction,
    /// When the force applies.
    pub activation: Activation,
}

/// Tangential part `f_t` of the contact force, from `f̄_t = f_col − f_n` (Eq. 29).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Friction {
    /// Coulomb cone (Eq. 30): `f̄_t` if `‖f̄_t‖ ≤ δ‖f_n‖`, else `δ‖f_n‖ f̄_t/‖f̄_t‖`.
    Coulomb(Real),
    /// The simple variant `f_t = δ f̄_t`.
    Proportional(Real),
}

/// When the contact force applies. Serialised in snake case (`"on_approach"`, `"always"`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Activation {
    /// Only where the phases approach each other along the normal (a collision), as in Yan et
    /// al. 2018.
    OnApproach,
    /// At every node where both phases have mass (with β = 1 and proportional δ = 1 this is full
    /// coupling).
    Always,
}

/// Buoyancy penalty of §4.3: `f_b = c_b max(ρ_b m_a/ρ_0a, ρ_a m_b/ρ_0b) g` (Eq. 32) with node
/// densities `ρ = m/Δx^D` and node rest densities from Eq. 31; it pushes the phase with the higher
/// rest density along gravity and the other against it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BuoyancyPenalty {
    /// Strength c_b ≥ 0 (dimensionless).
    pub strength: Real,
}

/// The pore-pressure buoyancy term of Eq. 15 (off by default).
///
/// Eq. 15 as printed is not dimensionally consistent; it is read here as the solid's share of the
/// fluid's nodal pressure force: `f = φ_a,i Σ_{p∈b} V_p p_p M_p⁻¹ w_ip (x_i − x_p)` with
/// `φ_a,i = m_a,i/(m_a,i + m_b,i)`, added to phase `a` and subtracted from the fluid phase `b`.
/// It is non-dissipative and, as the paper warns, easily makes a simulation unstable; it also
/// costs one more scatter of the fluid phase.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum PressureBuoyancy {
    /// Not applied.
    #[default]
    Off,
    /// Applied (unstable in many set-ups).
    On,
}

/// Porous interaction (§4.1): the volume fraction φ (Eqs. 19–20), the effective fraction φ_eff
/// stored on particles, and the material parameters that follow φ_eff.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Porous {
    /// How φ_eff follows φ.
    pub update: EffectiveFraction,
    /// Parameter changes driven by φ_eff.
    pub interactions: Vec<Interaction>,
}

/// Update rule of the effective volume fraction φ_eff from the previous value and the current
/// volume fraction φ_p = Σ_i w_ip φ_i, where φ_i = 1 at nodes where the particle's phase and
/// another phase both have mass (Eqs. 19–20).
///
/// Serialised as a table tagged by `phi_eff` with the rule in snake case and its parameters
/// beside it (`phi_eff = "relax"`, `rate = 5.0`), as scenes write it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "phi_eff", rename_all = "snake_case")]
pub enum EffectiveFraction {
    /// φ_eff = φ (Tampubolon et al. 2017).
    Current,
    /// Eq. 21: φ_eff ← max(φ_eff, φ); the solid never dries.
    Max,
    /// Eq. 22: φ_eff ← (1 − α) φ_eff + α φ with α = min(1, rate·Δt); slow wetting and drying.
    /// The paper's α = Δt is `rate = 1` per second.
    Relax {
        /// Relaxation rate (1/s).
        rate: Real,
    },
    /// Eq. 36: φ_eff ← max(φ_eff, (1 − α) φ_eff + α φ) with α = min(1, rate·Δt); slow wetting,
    /// no drying.
    MaxRelax {
        /// Relaxation rate (1/s).
        rate: Real,
    },
}

impl EffectiveFraction {
    /// The new φ_eff from the old one and the current φ over a step of `dt` (s).
    pub fn update(&self, phi_eff: Real, phi: Real, dt: Real) -> Real {
        let relax = |rate: Real| {
            let a = (rate * dt).min(1.0);
            (1.0 - a) * phi_eff + a * phi
        };
        match *self {
            EffectiveFraction::Current => phi,
            EffectiveFraction::Max => phi_eff.max(phi),
            EffectiveFraction::Relax { rate } => relax(rate),
            EffectiveFraction::MaxRelax { rate } => phi_eff.max(relax(rate)),
        }
    }
}

/// Miscible mixing of two fluids of one phase by concentration diffusion (§4.4, Eq. 33). Each
/// particle of either fluid carries the volume fraction α of the second fluid; its rest density,
/// mass (`m = V⁰ ρ₀(α)`), viscosity and equation of state are blended linearly in α.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Mixing {
    /// Material indices of the two fluids; α is the fraction of the second.
    pub fluids: [u32; 2],
    /// Diffusion coefficient k_d (m²/s); may be 0 (mixing of properties without diffusion).
    pub diffusivity: Real,
    /// Discretisation of the Laplacian.
    pub scheme: DiffusionScheme,
}

/// Discretisation of `∇²α` on the grid. Serialised in snake case (`"kernel_gradient"`,
/// `"mls_difference"`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DiffusionScheme {
    /// Galerkin form with kernel gradients ∇w (Yan et al. 2018, recommended by the paper's §6):
    /// `α_i = Σ_p w_ip V_p α_p / V_i`, `∇α_p = Σ_i α_i ∇w_ip`,
    /// `r_i = −k_d Σ_p V_p ∇w_ip·∇α_p`, `α_p += Δt Σ_i w_ip r_i/V_i`. Conserves `Σ_p V_p α_p` to
    /// round-off and converges to the diffusion equation.
    #[default]
    KernelGradient,
    /// The paper's MLS form (Eqs. 34–35), without kernel gradients: the node gradient
    /// `∇α_i = M⁻¹ Σ_p V_p w_ip (α_p − α_i)(x_p − x_i)/V_i` and `∇²α_p = Σ_i M⁻¹ w_ip ∇α_i·(x_i − x_p)`.
    /// Eq. 34 as printed normalises the node gradient to unit length, which is not a gradient
    /// (and is not zero for constant α); the differences `α_p − α_i` used here make it exact for
    /// constant and linear α. Not conservative; quadratic or cubic kernels only.
    MlsDifference,
}

/// Dissolution of a solid into a fluid (§4.5, after Yan et al. 2018). Particles of the `solid`
/// material keep their dissolution progress ξ ∈ [0, 1] in the concentration column and advance it
/// by `dξ/dt = rate · φ_p · (1 − c̄_p)`, where φ_p is the fraction of the particle's stencil where
/// the fluid phase has mass (Eqs. 19–20) and c̄_p the dissolved concentration of the surrounding
/// fluid (saturated fluid dissolves nothing). At ξ = 1 the particle becomes a particle of the
/// `into` fluid in the fluid phase with concentration 1 at rest (J = 1, `V⁰ = m/ρ_into`). A porous
/// solid, penetrated by the fluid, has φ_p > 0 inside and so dissolves faster; the dissolved
/// concentration diffuses through [`Mixing`], whose second fluid must be `into`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Dissolution {
    /// Material index of the dissolving solid.
    pub solid: u32,
    /// Material index of the fluid it becomes (the second fluid of the mixing).
    pub into: u32,
    /// The phase of the solvent fluid.
    pub fluid_phase: u32,
    /// Dissolution rate (1/s): full contact with fresh fluid dissolves a particle in 1/rate s.
    pub rate: Real,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn effective_fraction_rules() {
        let dt = 0.25;
        assert_eq!(EffectiveFraction::Current.update(0.8, 0.2, dt), 0.2);
        assert_eq!(EffectiveFraction::Max.update(0.8, 0.2, dt), 0.8);
        assert_eq!(EffectiveFraction::Max.update(0.1, 0.2, dt), 0.2);
        // Eq. 22 with α = rate·dt = 0.5.
        let relax = EffectiveFraction::Relax { rate: 2.0 };
        assert_eq!(relax.update(0.8, 0.2, dt), 0.5);
        assert_eq!(relax.update(0.2, 0.8, dt), 0.5);
        // Eq. 36 wets slowly and never dries.
        let wet = EffectiveFraction::MaxRelax { rate: 2.0 };
        assert_eq!(wet.update(0.2, 0.8, dt), 0.5);
        assert_eq!(wet.update(0.8, 0.2, dt), 0.8);
        // α is capped at 1: a huge rate follows φ at once.
        assert_eq!(
            EffectiveFraction::Relax { rate: 1e9 }.update(0.8, 0.2, dt),
            0.2
        );
    }
}
