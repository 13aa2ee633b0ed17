//! The coupled solver's parameters and names: the solve errors, the checkpoint columns, where
//! the interface rows are integrated, the solid side's parameters and the partitioned coupling
//! iteration.

use crate::pressure::PressureError;
use mpm_core::{Failure, Real};
use mpm_tlmpm::{ImplicitParams, NewtonError, TlmpmParams};
use thiserror::Error;

/// Why a coupled solve failed.
#[derive(Clone, Debug, PartialEq, Error)]
pub enum CoupledError {
    /// The solid's Newton elastic solve failed.
    #[error("elastic solve: {0}")]
    Newton(#[from] NewtonError),
    /// The coupled (or the fluid-only) pressure solve failed.
    #[error("{0}")]
    Pressure(#[from] PressureError),
}

/// A stage failure with its solve error turned into a [`CoupledError`].
pub(super) fn lift<E: Into<CoupledError>>(f: Failure<E>) -> Failure<CoupledError> {
    match f {
        Failure::Guard(s, g) => Failure::Guard(s, g),
        Failure::Solve(s, e) => Failure::Solve(s, e.into()),
    }
}

/// Name of the checkpoint column of the solid particles' reference positions (m; the current
/// position for fluid particles, which have none).
pub const REFERENCE_X: &str = "diq_reference_x";
/// Name of the checkpoint column of the particle pressure (Pa): the fluid cell pressure for
/// fluid particles, `P^s` for solid particles.
pub const PRESSURE: &str = "diq_pressure";
/// Name of the checkpoint column of the fluid cell divergence (1/s; 0 for solid particles).
pub const DIVERGENCE: &str = "diq_divergence";
/// Name of the checkpoint column of the A-ULMPM deformation gradients `F^(r,n)` (identity for
/// fluid particles); written only with A-ULMPM solids.
pub const RELATIVE_F: &str = "diq_relative_F";
/// Name of the checkpoint column of the A-ULMPM base deformation gradients `F^(0,r)` (identity
/// for fluid particles); written once a reference update or plastic flow has made it differ
/// from the identity.
pub const BASE_F: &str = "diq_base_F";
/// Name of the checkpoint attribute of the number of A-ULMPM reference updates.
pub(super) const ATTR_REFERENCE_UPDATES: &str = "diq_reference_updates";

/// Where the interface rows of the coupled projection are integrated (scene key
/// `[diq] interface`: `"solid_particles"` or `"fluid_nodes"`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InterfaceQuadrature {
    /// The paper's dual interface quadrature (§4.6, Eqs. 33–34, 36): the solid particles near
    /// fluid particles are the quadrature points, with Eq. 36's normals and their disc or
    /// sphere cross-sections; the fluid's side is spread over the `2^D` B1 nodes of each point,
    /// and fluid particles share their mass and volume with the points (IQ-MPM's extension of
    /// the fluid domain). Water at rest beside a solid is not a discrete equilibrium with it
    /// (`docs/diq.md`: a clamped block in still water sets the water moving, a neutrally
    /// buoyant one sinks).
    #[default]
    SolidParticles,
    /// Well-balanced rows at the fluid's boundary nodes (not in the paper). The fluid keeps its
    /// particles' mass and volume. The fluid rows' coefficients summed at a node give the
    /// discrete boundary vector `b_i = −Σ_c V_c ∇w_i(x_c)` (the `∫_Γ w_i n dA` that closes
    /// `G^f`; zero at a node surrounded by fluid cells of equal volume). At each node with a
    /// solid particle in its B1 support, the axis components `b_{i,a} e_a` the node holds get
    /// their own interface pressure, with the row `b_{i,a} (v_{i,a} − V_a)`: `V` is the solid's
    /// velocity at the node, the mean of its interpolated velocities at the solid particles `q`
    /// in that support (`W_j(X_q)` of Eq. 33) weighted by the node's tent `w_i(x_q)` (symmetric,
    /// and exact for rigid translations). A node holds the axes along which the solid's
    /// outward normal there, from the solid volume fractions of its `2^D` cells, has at least
    /// half its largest component (`held_axes`): on a face of the cell staircase only the normal
    /// axis, so the fluid slips along the face, also where a free surface or unequal cell
    /// volumes give `b_i` a tangential part; at convex and concave corners every axis, which
    /// balances a hydrostatic pressure there (one normal force cannot, `docs/diq.md`). A
    /// hydrostatic pressure beside a clamped solid then balances gravity at every node exactly
    /// (tested to round-off), which the paper's quadrature cannot (one normal force per point,
    /// spread over nodes whose `G^f` forces differ).
    ///
    /// Measured (`docs/diq.md`): blocks of 0.25–0.75 the density of 50 Pa·s water settle
    /// within 0.40 cell of their draft at Δx = 1/32–1/64 m (validation case
    /// `floating_block_diq`); a water film slides down a wall at 0.988–1.000 of free slide
    /// (`free_slip_wall`, Δx = 1/32–1/64 m; the paper's rows 0.9995–1.0000); the fluid is held
    /// at the corner nodes of the staircase. The position correction does
    /// not count the solids' volume here (the fluid ends at the cell staircase, which that
    /// volume overlaps), and it is best switched off (`docs/diq.md`). A step costs up to 3
    /// times the paper's at Δx = 1/64 m, mostly in coupled CG iterations (86 per step against
    /// 48 under IC(0); `docs/diq.md`).
    FluidNodes,
}

/// The solid side of the coupled solver: how the mixed TLMPM solids are integrated.
#[derive(Clone, Debug, PartialEq)]
pub struct SolidParams<const D: usize> {
    /// Search radius of the interface quadrature points, as a fraction of Δx (§4.6: 0.5).
    pub interface_radius: Real,
    /// Where the interface rows are integrated.
    pub interface: InterfaceQuadrature,
    /// TLMPM parameters: kernel (the paper's B2 is `Kernel::Quadratic`), transfer, fixed
    /// regions, contact (Eq. 4, with obstacles for walls and colliders) and A-ULMPM. Their step
    /// control (`step`: time step, gravity, instability policy) is replaced by the coupled
    /// solver's; a gravity ramp or damping here is rejected, as DIQ has neither.
    pub tlmpm: TlmpmParams<D>,
    /// Newton and linear-solver parameters of the elastic solve.
    pub implicit: ImplicitParams,
    /// The partitioned iteration between the elastic solve and the projection.
    pub coupling: CouplingIteration,
}

impl<const D: usize> Default for SolidParams<D> {
    fn default() -> Self {
        Self {
            interface_radius: 0.5,
            interface: InterfaceQuadrature::default(),
            tlmpm: TlmpmParams::default(),
            implicit: ImplicitParams::default(),
            coupling: CouplingIteration::default(),
        }
    }
}

/// The partitioned iteration of the coupled step between the solid's elastic solve and the
/// projection.
///
/// The projection sees the solid through its lumped node masses only (Eq. 35), not through its
/// stiffness, so the impulse it gives an interface node moves that node alone: the solid's
/// velocity after one projection is not an elastic response, and a stiff solid hit by water
/// takes up a strain of about `|Δv| Δt/Δx` in one step, with an elastic energy that grows with
/// E (a 1 GPa block dropped into water gained 6.6 times the system's energy in 0.6 s). The
/// iteration removes that splitting error. With `f` the force of the projection on the solid
/// nodes (zero at first) and `V*(f)` the elastic solve with `f` added to its external forces,
/// each pass projects `Ṽ = V*(f) − Δt M⁻¹ f` (the elastic velocities without the lumped response
/// to `f`, so the projection sees the same predictor as without the iteration) and takes the
/// force it applies, `f' = M (V − Ṽ)/Δt = −J_sᵀλ`; at the fixed point `f' = f` the projected
/// velocity `V` equals the elastic solve's `V*(f)`: the solid's motion is its elastic response
/// to the fluid and volume pressures, as in a monolithic solve. The force is updated by
/// Anderson acceleration of the map `f → f'` ([`mpm_linalg::Anderson`]). The iteration stops
/// when the strain mismatch `max_i |V_i − V*_i| Δt/Δx` is at most `strain_tolerance`, or after
/// `max_passes` projections (the step then goes on with the last projection, which is the
/// paper's splitting with a smaller error). `max_passes = 1` is the paper's one-pass split.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CouplingIteration {
    /// Most projections per step (at least 1).
    pub max_passes: usize,
    /// Largest accepted strain mismatch between the projected and the elastic solid velocity
    /// (dimensionless: velocity × Δt/Δx).
    pub strain_tolerance: Real,
}

impl Default for CouplingIteration {
    fn default() -> Self {
        Self {
            max_passes: 50,
            strain_tolerance: 1e-5,
        }
    }
}
