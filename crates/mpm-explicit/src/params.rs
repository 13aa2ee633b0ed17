//! Parameters of the explicit MLS-MPM solver.

use crate::multigrid::{Dissolution, Mixing, Phases, Porous};
use mpm_core::{Kernel, Real, StepControl, Vector};
use serde::{Deserialize, Serialize};

/// Particle–grid velocity transfer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "scheme", rename_all = "snake_case")]
pub enum Transfer {
    /// MLS/APIC: particles carry an affine field C that is transferred with the momentum. Conserves
    /// angular momentum with quadratic and cubic kernels.
    #[default]
    Apic,
    /// PIC: only the particle velocity is transferred (strongly dissipative).
    Pic,
    /// FLIP/PIC blend: `v ← α (v_p + Σ w Δv_i) + (1 − α) Σ w v_i`, no affine transfer.
    Flip {
        /// FLIP fraction α ∈ [0, 1] (dimensionless; 0.95–0.99 typical).
        blend: Real,
    },
}

/// How the current particle volume of fluids is obtained.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VolumeUpdate {
    /// Integrate `J ← (1 + Δt tr C) J` (classic MPM).
    #[default]
    Deformation,
    /// Re-estimate every step from the grid density, `J = m_p/(ρ_p V⁰_p)` with
    /// `ρ_p = Σ_i w_ip m_i/Δx^D` (incremental MLS-MPM tutorial, "evolving volume"). Costs one
    /// extra mass scatter and gather per step; affects fluid particles only.
    Reestimate,
}

/// Predictive softened walls (incremental MLS-MPM tutorial): after G2P, a particle whose
/// predicted position `x + τ v` lies closer than `margin` to a face of the grid box has its velocity
/// nudged by `(wall − (x + τ v))/τ` along that axis, so fast particles slow down before they reach
/// the wall instead of tunnelling into it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SoftWalls {
    /// Distance of the soft wall from each face of the grid box (m).
    pub margin: Real,
    /// Look-ahead time τ (s).
    pub lookahead: Real,
}

/// Everything that configures an explicit solver apart from its particles, materials and
/// boundaries.
#[derive(Clone, Debug)]
pub struct ExplicitParams<const D: usize> {
    /// Interpolation kernel.
    pub kernel: Kernel,
    /// Velocity transfer scheme.
    pub transfer: Transfer,
    /// Gravity, time step, damping and the reaction to instability. The adaptive bound is
    /// `cfl · Δx / max_p (|v_p| + c_p)`, capped by the viscous limit; damping acts on the
    /// nodal forces in the grid update.
    pub step: StepControl<D>,
    /// Fluid volume update.
    pub volume: VolumeUpdate,
    /// Predictive softened walls, if any.
    pub soft_walls: Option<SoftWalls>,
    /// Prescribed body force in addition to gravity, if any.
    pub body_force: Option<BodyForce<D>>,
    /// Phases and the couplings between their grids (one phase by default).
    pub phases: Phases,
    /// Porous interaction (volume fraction, φ_eff, parameter changes), if any.
    pub porous: Option<Porous>,
    /// Miscible mixing by concentration diffusion, if any.
    pub mixing: Option<Mixing>,
    /// Dissolution of a solid into a fluid, if any.
    pub dissolution: Option<Dissolution>,
}

impl<const D: usize> Default for ExplicitParams<D> {
    fn default() -> Self {
        Self {
            kernel: Kernel::Quadratic,
            transfer: Transfer::Apic,
            step: StepControl::default(),
            volume: VolumeUpdate::Deformation,
            soft_walls: None,
            body_force: None,
            phases: Phases::default(),
            porous: None,
            mixing: None,
            dissolution: None,
        }
    }
}

/// A prescribed body-force field `b(p, x, t)` (m/s², i.e. force per unit mass) evaluated for
/// particle `p` at its position `x` (m) at the start of the step `t` (s). Used for manufactured
/// solutions and other analytic loads; gravity has its own parameter.
#[derive(Clone)]
pub struct BodyForce<const D: usize>(pub std::sync::Arc<BodyForceFn<D>>);

/// The closure behind a [`BodyForce`]: `(particle, position, time) → acceleration`.
pub type BodyForceFn<const D: usize> = dyn Fn(usize, &Vector<D>, Real) -> Vector<D> + Send + Sync;

impl<const D: usize> std::fmt::Debug for BodyForce<D> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("BodyForce(..)")
    }
}
