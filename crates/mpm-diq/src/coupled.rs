//! DIQ-MPM part 2 (diq-mpm §4.2–4.7, §5): the incompressible fluid of [`DiqFluid`] coupled to
//! mixed total-Lagrangian solids through one sparse SPD pressure-only system.
//!
//! # The step (§5.1)
//!
//! 1. **Time step.** `dt (|v|max + |g| dt) = cfl Δx` over fluid *and* solid particles, capped by
//!    `dt_max` (Table 1's `Δt_step`).
//! 2. **Fluid predictor** (when there is fluid): sort, APIC P2G to B1 nodes, `v* = v + Δt g`.
//! 3. **Solid elastic solve:** the implicit Newton TLMPM of `mpm-tlmpm` (P2G on the reference
//!    grid, gravity, the penalty contact of Eq. 4 with other solid particles and with walls and
//!    colliders, Newton on the backward-Euler incremental potential of the elastic energy
//!    `Ψ^s`), driven through [`ImplicitTlmpm::elastic_predictor`]: node velocities `V*`.
//! 4. **Dual interface quadrature** (§4.6, §5.2, stage `coupling`): see [`Self`] below.
//! 5. **Coupled projection** (§4.7, stage `coupling`): one SPD system for the solid pressures
//!    `P^s`, fluid pressures `p`, wall pressures `y` and interface pressures `h`, iterated with
//!    the elastic solve of step 3 until the solid's projected velocity is its elastic response
//!    ([`CouplingIteration`]; one pass is the paper's split).
//! 6. **G2P** for both (the solid's F update and guards in `mpm-tlmpm`), the fluid's position
//!    correction, then commit and (A-ULMPM) the reference update.
//!
//! # Discretisation
//!
//! - **Mixed solid** (§4.2, §4.5). The volume energy `Ψ^v = λ^v (J − 1)²/2` with `λ^v = λ/2`
//!   (half the solid's first Lamé parameter) is carried by a pressure `P^s` constant on each cell
//!   of the *reference* grid that holds solid particles (B0 in the initial configuration). With
//!   particle quadrature over the particles `p` of reference cell `j`:
//!   - `G^s_{iα,j} = −Σ_p V⁰_p J_p (F_p⁻ᵀ ∇^X W_i(X_p))_α` (Eq. 29; `W_i` the solid's B-spline
//!     on the reference grid, `F_p` at the start of the step),
//!   - `S^s_j = Σ_p V⁰_p / λ^v_p` (Eq. 28, lumped),
//!   - `M^s_i` the lumped reference node masses of `mpm-tlmpm` (Eq. 28).
//!
//!   After the solve the cell pressure goes back to its particles (`W^0`) and
//!   `J_p = 1 − P_p/λ^v_p` is recomputed from it (the remapping after Eq. 30); this `J_p` is the
//!   one in `G^s`.
//! - **Interface** (§4.6, Eqs. 32–34, 36). The current interface quadrature (IQ) points are the
//!   solid particles with a fluid particle within `0.5 Δx`. Point `q` has the normal
//!   `n_q = −∇m/‖∇m‖`, `∇m(x_q) = Σ_r m_r ∇N(‖x_q − x_r‖)` over the solid particles `r` with
//!   the cubic B-spline `N` of support `2Δx` (Eq. 36), and the area `A_q` of the cross-section
//!   of a sphere (3D; a disc in 2D, whose "area" is its diameter) of volume `J_q V⁰_q`,
//!   `J_q = det F_q`. One interface pressure `h` lives on each current-grid cell that holds IQ
//!   points (`w^0` of the fluid grid), and
//!   - `H^s_{j,iα} = Σ_{q in j} A_q W_i(X_q) n_{q,α}` (Eq. 33, pulled back: `X_q` is the
//!     particle's reference position, so the solid side is integrated on the reference grid),
//!   - `H^f_{j,cα} = Σ_{q in j} A_q w_c(x_q) n_{q,α}` (Eq. 34, on the fluid's B1 nodes).
//!
//! # The pressure-only system (Eq. 35 from Eqs. 26–27)
//!
//! Stack the velocities `u = (V^s, v^f)` with the lumped mass `M = diag(M^s, M^f)` and the
//! pressures `λ = (P^s, p, y, h)`. Eq. 26's momentum rows read
//! `M (u − u*)/Δt + Jᵀ λ = 0` with the constraint operator (rows over `u`)
//!
//! ```text
//!        V^s     v^f
//! P^s  [ G^sᵀ     0   ]
//! p    [  0     G^fᵀ  ]
//! y    [  0      B    ]
//! h    [ −H^s    H^f  ]
//! ```
//!
//! (its transpose gives exactly the columns `G^s, −H^sᵀ` of the solid row and `G^f, Bᵀ, H^fᵀ` of
//! the fluid row of Eq. 26), and the constraint rows read `J u − C λ = c` with
//! `C = diag(S^s/Δt, 0, 0, 0)` and `c = (−S^s P^{s,n}/Δt, 0, b, 0)` (Eq. 26's second row is
//! `G^sᵀ V − S^s P/Δt = −S^s P^n/Δt`, Eq. 27). Eliminating `u = u* − Δt M⁻¹ Jᵀ λ` (lumped
//! masses make `M⁻¹` diagonal) gives
//!
//! `(Δt J M⁻¹ Jᵀ + C) λ = J u* − c`,
//!
//! which is Eq. 35 block by block:
//! `A11 = S^s/Δt + Δt G^sᵀ M^s⁻¹ G^s`, `A14 = −Δt G^sᵀ M^s⁻¹ H^sᵀ`, `A22`, `A23`, `A33` as in
//! part 1, `A24 = Δt G^fᵀ M^f⁻¹ H^fᵀ`, `A34 = Δt B M^f⁻¹ H^fᵀ`,
//! `A44 = Δt (H^s M^s⁻¹ H^sᵀ + H^f M^f⁻¹ H^fᵀ)`, and right-hand sides
//! `G^sᵀ V* + S^s P^n/Δt`, `G^fᵀ v*`, `B v* − b`, `H^f v* − H^s V*`.
//!
//! - **Misprint.** The paper prints `A11 = S^s/Δt + Δt G^{fT} M^{s−1} G^s`: the fluid gradient
//!   cannot multiply the solid mass (the shapes do not even match); the Schur complement has
//!   `G^{sT}`. The paper's right-hand sides also carry `V^{s,n}`/`v^{f,n}` where the
//!   intermediate `V^{s,*}`, `v^{f,*}` of the split belong, and opposite signs from its sign
//!   convention for `G`; the form above is the one derived here and tested.
//! - **SPD.** `Δt J M⁻¹ Jᵀ` is symmetric positive semi-definite and `C ≥ 0`, so `A` is SPD when
//!   `Jᵀ` restricted to the non-solid rows has full column rank (as in part 1) — the solid
//!   rows are made definite by `S^s/Δt > 0`. Fixed solid nodes are infinitely heavy
//!   (`M⁻¹ = 0`). A test assembles the matrix, compares it entry by entry with the dense
//!   `Δt J M⁻¹ Jᵀ + C`, checks its symmetry and its smallest eigenvalue.
//! - **Momentum.** Every row of `J` except the wall rows sums to zero over the nodes (partition
//!   of unity of `w`, `W` and their gradients; an interface row is `A n` on each side), so
//!   without walls the projection conserves total momentum; tested to round-off with G2P.
//!
//! # A-ULMPM solids (§5.4, Eqs. 37–38)
//!
//! With [`mpm_tlmpm::ReferenceUpdate`] the solid's reference configuration `r` moves to the
//! current one when the trigger fires after an accepted step. The volume term is measured from
//! it, `Ψ^v(J^(r,n))` (Eq. 37): the solid-pressure rows use the kinematic `F^(r,n)` in place
//! of `F`, the reference gradients of the current reference grid, and the reference volumes
//! `V^r = V⁰ det F^(0,r)` in `G^s` and `S^s`; after an update `J^(r,n) = 1`, so `P^s` starts
//! again from 0 and the solid cells are re-binned. The interface rows need nothing new: `H^s`
//! is integrated at the particles' positions in the current reference with its weights, which
//! is Eq. 38's map back. Checkpoints carry `F^(r,n)` and `F^(0,r)` ([`RELATIVE_F`],
//! [`BASE_F`]) and the update count.
//!
//! # Plastic solids (Table 1's soil; not in the paper's equations)
//!
//! A-ULMPM's plastic solids (snow's clamped stretches, Drucker–Prager sand) keep
//! `F_E = F^(r,n) B` with the base `B` moved by every return mapping ([`mpm_tlmpm`]'s
//! `adaptive` module). Eq. 37 as printed measures the volume term from `J^(r,n) = det F^(r,n)`
//! on `V^r = V⁰ det B`; with plastic flow that is inconsistent twice over: `B` (so `V^r`)
//! changes every step, and the plastic part of a step's volume change never leaves `P^s` (a
//! sand grain pulled apart would keep the tension `−λ^v ΔJ` until the next reference update).
//! The volume energy that belongs to an elasto-plastic solid is the elastic one,
//! `Σ_p V⁰_p Ψ^v(J_E,p)` with `J_E = det F_E`, and that is what plastic particles carry:
//!
//! - `G^s` and `S^s` use `V⁰_p` for the volume and the remapped `J_p = J_E,p` (since
//!   `∂J_E/∂F^(r,n) = J_E F^(r,n)⁻ᵀ` with `B` frozen over the step, `G^s` keeps its form with
//!   `V⁰ J_E` in place of `V^r J^(r,n)`, the same number for an elastic particle);
//! - after G2P the return mapping has scaled `J_E` by `r = det F_E / det F_E^trial =
//!   det B^new / det B`; the remap follows, `1 − P/λ^v ← r (1 − P/λ^v)`, i.e.
//!   `P ← λ^v − r (λ^v − P)` (so a grain whose elastic volume is reset to 1 has `P = 0`);
//! - a reference update leaves `F_E` and so `P^s` unchanged (no reset to 0).
//!
//! Elastic particles follow Eq. 37 as before, bitwise.

use crate::fluid::{Attempt, Bins, DiqFluid, DiqParams, NodeFields, Points};
use crate::pressure::{Constraints, PressureError, PressureInfo, PressureSystem, UnknownKind};
use crate::Domain;
use mpm_core::boundary::Boundaries;
use mpm_core::columns::{self, Column};
use mpm_core::material::Plasticity;
use mpm_core::neighbors::CellList;
use mpm_core::solver::{on_pool, DtBound, FieldInfo, RestoreError, StageTime};
use mpm_core::timestep::choose_dt;
use mpm_core::{
    retry_halving, Diagnostics, Dim, DimOps, Failure, GridSpec, Material, Matrix, Monitor,
    Particles, Real, SetupError, SolveInfo, Solver, SolverState, Stage, StagePlan, StageTimes,
    StepError, StepInfo, StepStart, Vector,
};
use mpm_tlmpm::{ImplicitParams, ImplicitTlmpm, NewtonError, TlmpmParams, TlmpmState};
use rayon::prelude::*;
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

fn lift<E: Into<CoupledError>>(f: Failure<E>) -> Failure<CoupledError> {
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
const ATTR_REFERENCE_UPDATES: &str = "diq_reference_updates";

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
    /// regions, contact (Eq. 4, with obstacles for walls and colliders) and A-ULMPM. Their time
    /// step, gravity and instability policy are replaced by the coupled solver's.
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
/// Anderson acceleration of the map `f → f'` (see `Anderson` in the source). The iteration stops
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

/// The interface quadrature of one step (§4.6).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct InterfacePoints<const D: usize> {
    /// Solid particle (index among the solids) of each point, ascending.
    pub particle: Vec<usize>,
    /// Outward unit normal `n_q` of the solid (Eq. 36).
    pub normal: Vec<Vector<D>>,
    /// Area `A_q` (m² in 3D, m in 2D).
    pub area: Vec<Real>,
    /// The fluid particles within the search radius of each point (ascending), as CSR:
    /// `fluid[fluid_start[k]..fluid_start[k + 1]]` for point `k`.
    pub fluid: Vec<usize>,
    /// CSR offsets into `fluid`, one more than there are points.
    pub fluid_start: Vec<usize>,
}

/// The fluid quadrature points of one step: the fluid particles, each keeping the share
/// `1/(k+1)` of its mass, momentum and volume when it has `k` interface points within reach,
/// followed by the interface points, which carry the other shares (IQ-MPM's extension of the
/// fluid domain to the interface, §4.6: "current IQ points are added to the fluid domain").
#[derive(Clone, Debug, Default)]
struct FluidPoints<const D: usize> {
    x: Vec<Vector<D>>,
    v: Vec<Vector<D>>,
    affine: Vec<Matrix<D>>,
    mass: Vec<Real>,
    volume: Vec<Real>,
    /// Interface points (indices into [`InterfacePoints`]) each fluid particle shares with, as
    /// CSR over the fluid particles.
    shared: Vec<usize>,
    shared_start: Vec<usize>,
}

impl<const D: usize> FluidPoints<D> {
    fn points(&self) -> Points<'_, D> {
        Points {
            x: &self.x,
            v: &self.v,
            affine: &self.affine,
            mass: &self.mass,
            volume: &self.volume,
        }
    }
}

/// One attempt's results, committed when the whole attempt is accepted.
struct Pending<const D: usize> {
    fluid: Option<Attempt<D>>,
    solid_pressure: Vec<Real>,
    solves: Vec<SolveInfo>,
    interface_points: usize,
    contact_pairs: Option<usize>,
}

/// DIQ-MPM: the incompressible fluid and mixed TLMPM solids in one step, coupled through one
/// SPD pressure-only system (see the module docs). Either part may be empty: a solids-only
/// scene has no fluid stage, and a fluid-only scene should use [`DiqFluid`] itself.
#[derive(Debug)]
pub struct DiqCoupled<const D: usize> {
    fluid: DiqFluid<D>,
    solid: ImplicitTlmpm<D>,
    /// Particles of the scene in its order (solids carry F; fluids F = I).
    particles: Particles<D>,
    materials: Vec<Material>,
    /// Scene index of each fluid particle, then of each solid particle.
    fluid_index: Vec<usize>,
    solid_index: Vec<usize>,
    /// `λ^v = λ/2` of each solid particle (Pa).
    lambda_v: Vec<Real>,
    /// Whether each solid particle's material is plastic: its volume term is measured from the
    /// elastic volume ratio `J_E` (module docs, "Plastic solids").
    plastic: Vec<bool>,
    /// Mixed pressure `P^s` of each solid particle (Pa).
    solid_pressure: Vec<Real>,
    /// Reference cell of each solid particle and the particles of each cell, in order.
    solid_cells: Vec<(usize, Vec<usize>)>,
    projection: PressureSystem<D>,
    correction: PressureSystem<D>,
    boundaries: Boundaries<D>,
    params: DiqParams<D>,
    solid_params: SolidParams<D>,
    time: Real,
    steps: u64,
    plan: StagePlan,
    times: StageTimes,
}

/// The particles `index` of `ps` with material indices renumbered by `material`.
fn subset<const D: usize>(
    ps: &Particles<D>,
    index: &[usize],
    material: &[u32],
    solid: bool,
) -> Particles<D> {
    let mut columns = ps.columns();
    columns.deformation_gradient = solid;
    columns.jacobian = false;
    columns.plastic &= solid;
    let mut out = Particles::new(columns);
    for &p in index {
        out.push(mpm_core::ParticleInit {
            x: ps.x[p],
            v: ps.v[p],
            mass: ps.mass[p],
            volume0: ps.volume0[p],
            material: material[ps.material[p] as usize],
            affine: ps.affine[p],
        });
        let k = out.len() - 1;
        if let (Some(f), true) = (&mut out.def_grad, solid) {
            f[k] = ps.def_grad_of(p);
        }
        if let (Some(s), Some(src)) = (&mut out.plastic, &ps.plastic) {
            s[k] = src[p];
        }
    }
    out
}

impl<const D: usize> DiqCoupled<D>
where
    Dim<D>: DimOps<D>,
{
    /// Builds the solver from the scene's particles and materials: fluid materials go to the
    /// incompressible fluid, elastic solid materials to the mixed TLMPM (λ > 0 required, i.e.
    /// Poisson's ratio above 0). Walls and colliders must be free slip for the fluid; solids
    /// meet them through the penalty contact of `solid.tlmpm.contact`.
    pub fn new(
        spec: GridSpec<D>,
        params: DiqParams<D>,
        solid: SolidParams<D>,
        materials: Vec<Material>,
        boundaries: Boundaries<D>,
        particles: Particles<D>,
    ) -> Result<Self, SetupError> {
        Self::build(
            spec, params, solid, materials, boundaries, particles, None, 0.0,
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn build(
        spec: GridSpec<D>,
        params: DiqParams<D>,
        solid_params: SolidParams<D>,
        materials: Vec<Material>,
        boundaries: Boundaries<D>,
        mut particles: Particles<D>,
        restart: Option<TlmpmState<D>>,
        time: Real,
    ) -> Result<Self, SetupError> {
        let is_fluid: Vec<bool> = materials
            .iter()
            .map(|m| matches!(m, Material::Fluid(_)))
            .collect();
        let (mut fluid_mats, mut solid_mats) = (Vec::new(), Vec::new());
        let renumber: Vec<u32> = materials
            .iter()
            .map(|m| {
                let list = if matches!(m, Material::Fluid(_)) {
                    &mut fluid_mats
                } else {
                    &mut solid_mats
                };
                list.push(m.clone());
                (list.len() - 1) as u32
            })
            .collect();
        for (i, &m) in particles.material.iter().enumerate() {
            if m as usize >= materials.len() {
                return Err(SetupError::UnknownMaterial {
                    index: i,
                    material: m,
                    count: materials.len(),
                });
            }
        }
        let (fluid_index, solid_index): (Vec<usize>, Vec<usize>) =
            (0..particles.len()).partition(|&p| is_fluid[particles.material[p] as usize]);
        if solid_index.is_empty() {
            return Err(SetupError::InvalidSetting {
                setting: "materials".into(),
                reason: "the coupled DIQ solver needs a solid; a fluid alone runs on the DIQ \
                         fluid solver"
                    .into(),
            });
        }
        let mut lambda_v = Vec::with_capacity(solid_index.len());
        let mut plastic = Vec::with_capacity(solid_index.len());
        for &p in &solid_index {
            let lambda = match &materials[particles.material[p] as usize] {
                Material::Solid(s) => {
                    plastic.push(!matches!(s.plasticity, Plasticity::None));
                    s.elastic.lame().lambda
                }
                Material::Fluid(_) => unreachable!("partitioned above"),
            };
            if !(lambda > 0.0 && lambda.is_finite()) {
                return Err(SetupError::InvalidParameter {
                    name: "lambda",
                    value: lambda,
                    reason: "the mixed solid needs a positive first Lamé parameter (Poisson's \
                             ratio above 0): λ^v = λ/2 is its pressure stiffness",
                });
            }
            lambda_v.push(0.5 * lambda);
        }
        let fluid_ps = subset(&particles, &fluid_index, &renumber, false);
        let solid_ps = subset(&particles, &solid_index, &renumber, true);
        let fluid = DiqFluid::at_time(
            spec,
            params.clone(),
            fluid_mats,
            boundaries.clone(),
            fluid_ps,
            time,
        )?;
        let mut tl = solid_params.tlmpm.clone();
        tl.time_step = params.time_step;
        tl.gravity = params.gravity;
        tl.on_instability = params.on_instability;
        let mut solid = ImplicitTlmpm::new(spec, tl, solid_params.implicit, solid_mats, solid_ps)?;
        let mut steps = 0;
        if let Some(state) = restart {
            // The reference configuration of a resumed run is the saved one, not the current
            // positions (and, with A-ULMPM, the saved F^(r,n) and F^(0,r)).
            steps = state.steps;
            solid.restore(state)?;
        }
        if particles.def_grad.is_none() {
            particles.def_grad = Some(vec![Matrix::<D>::identity(); particles.len()]);
        }
        particles.jacobian = None;
        let n_solid = solid_index.len();
        let mut s = Self {
            fluid,
            solid,
            particles,
            materials,
            fluid_index,
            solid_index,
            lambda_v,
            plastic,
            solid_pressure: vec![0.0; n_solid],
            solid_cells: Vec::new(),
            projection: PressureSystem::new(),
            correction: PressureSystem::new(),
            boundaries,
            params,
            solid_params,
            time,
            steps,
            plan: StagePlan::default(),
            times: StageTimes::default(),
        };
        s.bin_solid_cells();
        s.plan = s.make_plan();
        Ok(s)
    }

    /// Groups the solid particles by the reference-grid cell of their reference position.
    fn bin_solid_cells(&mut self) {
        let spec = *Solver::spec(&self.fluid);
        let cells: [usize; D] = std::array::from_fn(|a| spec.size[a].saturating_sub(1).max(1));
        let x = self.solid.reference().positions();
        let mut keyed: Vec<(usize, usize)> = x
            .iter()
            .enumerate()
            .map(|(p, x)| {
                let mut c = 0;
                for a in (0..D).rev() {
                    let k = ((x[a] - spec.origin[a]) / spec.dx).floor();
                    let k = (k.max(0.0) as usize).min(cells[a] - 1);
                    c = c * cells[a] + k;
                }
                (c, p)
            })
            .collect();
        keyed.sort_unstable();
        self.solid_cells = keyed
            .chunk_by(|a, b| a.0 == b.0)
            .map(|g| (g[0].0, g.iter().map(|&(_, p)| p).collect()))
            .collect();
    }

    fn has_fluid(&self) -> bool {
        !self.fluid_index.is_empty()
    }

    fn make_plan(&self) -> StagePlan {
        let mut plan = StagePlan::default();
        let fluid = self.has_fluid();
        plan.push(
            Stage::Reference,
            "at set-up: the solids' reference weights, gradients and node masses",
        );
        plan.push(
            Stage::TimeStep,
            self.params
                .time_step
                .describe("Δx / max(|v| + |g| dt) over fluid and solid particles"),
        );
        if fluid {
            plan.push(Stage::Sort, "bin fluid particles by cell");
        }
        plan.push(
            Stage::P2G,
            if fluid {
                "fluid: APIC to linear B-spline (B1) nodes; solid: momentum to the reference grid"
            } else {
                "solid: momentum to the reference grid"
            },
        );
        if fluid {
            plan.push(
                Stage::GridUpdate,
                format!("fluid {}", self.fluid.predictor_plan()),
            );
        }
        plan.push(Stage::ExternalForces, "solid: gravity");
        if let Some(c) = &self.solid_params.tlmpm.contact {
            plan.push(
                Stage::Contact,
                format!(
                    "solid: Eq. 4 particle pairs, radius {:?}; {} wall/collider obstacle(s)",
                    c.radius,
                    c.obstacles.len()
                ),
            );
        }
        plan.push(
            Stage::Solve,
            "solid: Newton elastic solve on the backward-Euler potential of Ψ^s (V*)",
        );
        plan.push(
            Stage::Coupling,
            format!(
                "{}coupled pressure-only system (Eq. 35) by {}",
                match (fluid, self.solid_params.interface) {
                    (false, _) => "solid pressures: ",
                    (true, InterfaceQuadrature::SolidParticles) => {
                        "interface quadrature points and normals (Eq. 36), "
                    }
                    (true, InterfaceQuadrature::FluidNodes) => {
                        "interface rows at the fluid's boundary nodes (not in the paper), "
                    }
                },
                self.params.pressure.method.describe()
            ),
        );
        plan.push(
            Stage::G2P,
            if fluid {
                "solid: F update and guards; fluid: APIC G2P, advection, clamping"
            } else {
                "solid: F update and guards"
            },
        );
        if fluid && self.params.position_correction {
            plan.push(
                Stage::PositionCorrection,
                "fluid: volume-preserving position correction",
            );
        }
        plan.push(
            Stage::Commit,
            if self.plastic.contains(&true) {
                "write checked updates; P^s to particles, J^s remapped, plastic P^s scaled with \
                 the return mapping's det F_E / det F_E^trial"
            } else {
                "write checked updates; P^s to particles, J^s remapped"
            },
        );
        if let Some(r) = &self.solid_params.tlmpm.reference_update {
            plan.push(
                Stage::ReferenceUpdate,
                format!("A-ULMPM trigger: epsilon = {}, eta = {}", r.epsilon, r.eta),
            );
        }
        plan
    }

    /// The remapped volume ratio `J_p = 1 − P_p/λ^v_p` of each solid particle.
    pub fn solid_jacobian(&self) -> Vec<Real> {
        self.solid_pressure
            .iter()
            .zip(&self.lambda_v)
            .map(|(p, l)| 1.0 - p / l)
            .collect()
    }

    /// The mixed pressure `P^s` of each solid particle (Pa), in solid order.
    pub fn solid_pressure(&self) -> &[Real] {
        &self.solid_pressure
    }

    /// Scene indices of the solid particles, in solid order.
    pub fn solid_indices(&self) -> &[usize] {
        &self.solid_index
    }

    /// Scene indices of the fluid particles, in fluid order.
    pub fn fluid_indices(&self) -> &[usize] {
        &self.fluid_index
    }

    /// The fluid part.
    pub fn fluid(&self) -> &DiqFluid<D> {
        &self.fluid
    }

    /// The solid part.
    pub fn solid(&self) -> &ImplicitTlmpm<D> {
        &self.solid
    }

    /// The last assembled coupled system, for tests and benchmarks.
    pub fn system(&self) -> &PressureSystem<D> {
        &self.projection
    }

    /// The interface quadrature points at the current positions (§4.6, Eq. 36). Solid
    /// particles outside the fluid's wall box are none: the fluid cannot reach them (a solid
    /// without wall obstacles may leave the box, and the fluid grid has no cells there).
    pub fn interface_points(&self) -> InterfacePoints<D> {
        let dx = Solver::spec(&self.fluid).dx;
        let xf = &Solver::particles(&self.fluid).x;
        let sp = self.solid.particles();
        let mut out = InterfacePoints::default();
        if xf.is_empty() || self.solid_params.interface == InterfaceQuadrature::FluidNodes {
            return out;
        }
        // The search radius 0.5 Δx is the lattice spacing at 2 particles per cell and axis
        // (the paper's 8 per cell in 3D), so it is widened by a relative 1e-9: neighbours of
        // the initial lattices sit at exactly that distance.
        let radius = self.solid_params.interface_radius * dx * (1.0 + 1e-9);
        let mut fluid_cells = CellList::default();
        fluid_cells.build(xf, radius);
        let mut solid_cells = CellList::default();
        solid_cells.build(&sp.x, 2.0 * dx);
        let r2 = radius * radius;
        let found: Vec<Option<(Vector<D>, Real, Vec<usize>)>> = (0..sp.len())
            .into_par_iter()
            .map(|q| {
                let xq = sp.x[q];
                self.fluid.domain().locate(&xq)?;
                let mut near = Vec::new();
                fluid_cells.for_each_candidate_near(&xq, |f| {
                    if (xf[f] - xq).norm_squared() <= r2 {
                        near.push(f);
                    }
                });
                if near.is_empty() {
                    return None;
                }
                near.sort_unstable();
                let normal = self.solid_normal(&solid_cells, q)?;
                let j = Dim::<D>::det(&sp.def_grad_of(q)).max(0.0);
                Some((normal, cross_section::<D>(j * sp.volume0[q]), near))
            })
            .collect();
        out.fluid_start.push(0);
        for (q, f) in found.into_iter().enumerate() {
            if let Some((n, a, near)) = f {
                out.particle.push(q);
                out.normal.push(n);
                out.area.push(a);
                out.fluid.extend(near);
                out.fluid_start.push(out.fluid.len());
            }
        }
        out
    }

    /// The fluid quadrature points of a step with interface points `iq` (see [`FluidPoints`]).
    fn fluid_points(&self, iq: &InterfacePoints<D>) -> FluidPoints<D> {
        let fp = Solver::particles(&self.fluid);
        let n = fp.len();
        // Interface points of each fluid particle (CSR, points ascending).
        let mut start = vec![0usize; n + 1];
        for &f in &iq.fluid {
            start[f + 1] += 1;
        }
        for p in 0..n {
            start[p + 1] += start[p];
        }
        let mut fill = start.clone();
        let mut shared = vec![0usize; iq.fluid.len()];
        for k in 0..iq.particle.len() {
            for &f in &iq.fluid[iq.fluid_start[k]..iq.fluid_start[k + 1]] {
                shared[fill[f]] = k;
                fill[f] += 1;
            }
        }
        let share = |p: usize| 1.0 / (start[p + 1] - start[p] + 1) as Real;
        let sp = self.solid.particles();
        let mut pts = FluidPoints {
            x: fp.x.clone(),
            v: fp.v.clone(),
            affine: fp.affine.clone(),
            mass: (0..n).map(|p| fp.mass[p] * share(p)).collect(),
            volume: (0..n).map(|p| fp.volume0[p] * share(p)).collect(),
            shared,
            shared_start: start.clone(),
        };
        for k in 0..iq.particle.len() {
            let (mut m, mut vol, mut mv) = (0.0, 0.0, Vector::<D>::zeros());
            for &f in &iq.fluid[iq.fluid_start[k]..iq.fluid_start[k + 1]] {
                let (mf, s) = (fp.mass[f] * share(f), share(f));
                m += mf;
                vol += fp.volume0[f] * s;
                mv += fp.v[f] * mf;
            }
            pts.x.push(sp.x[iq.particle[k]]);
            pts.v.push(mv / m);
            pts.affine.push(Matrix::<D>::zeros());
            pts.mass.push(m);
            pts.volume.push(vol);
        }
        pts
    }

    /// Appends the solid-pressure rows (`G^sᵀ`, compliance and offset for a step of `dt`) on
    /// the velocity slots from `offset`.
    fn push_solid_rows(&self, rows: &mut Constraints<D>, offset: usize, dt: Real) {
        let sp = self.solid.particles();
        let reference = self.solid.reference();
        let jac = self.solid_jacobian();
        // With A-ULMPM (§5.4, Eq. 37) the volume term is measured from the current reference:
        // F^(r,n), its reference gradients and the reference volumes V^r = V⁰ det F^(0,r).
        // Plastic particles carry Ψ^v(J_E) on V⁰ instead (module docs, "Plastic solids").
        let rel = self.solid.relative_def_grads();
        let mut volume = self.solid.reference_volumes();
        for ((v, v0), _) in volume
            .iter_mut()
            .zip(&sp.volume0)
            .zip(&self.plastic)
            .filter(|(_, &plastic)| plastic)
        {
            *v = *v0;
        }
        type Row<const D: usize> = (Vec<(usize, Vector<D>)>, Real, Real);
        let built: Vec<Row<D>> = self
            .solid_cells
            .par_iter()
            .map(|(_, members)| {
                let mut entries = Vec::new();
                let (mut s, mut sp_n) = (0.0, 0.0);
                for &p in members {
                    let f = rel.map_or_else(|| sp.def_grad_of(p), |g| g[p]);
                    let finv_t =
                        Dim::<D>::inverse(&f).map_or(Matrix::<D>::zeros(), |i| i.transpose());
                    let scale = volume[p] * jac[p];
                    for (i, _, g) in reference.stencil(p) {
                        entries.push((offset + i, -(finv_t * g) * scale));
                    }
                    let c = volume[p] / self.lambda_v[p];
                    s += c;
                    sp_n += c * self.solid_pressure[p];
                }
                (entries, s, sp_n)
            })
            .collect();
        for ((cell, _), (entries, s, sp_n)) in self.solid_cells.iter().zip(built) {
            rows.push_row(UnknownKind::SolidPressure, *cell, entries, -sp_n / dt);
            *rows.diagonal.last_mut().expect("pushed") = s / dt;
        }
    }

    /// Appends the interface rows `[−H^s, H^f]` of the points `iq`, one per current fluid cell
    /// holding points, solid slots from `offset`. `fluid_mass` (kg) is the fluid node mass:
    /// the fluid weights `w_c(x_q)` of a point are renormalised over its corners that carry
    /// fluid mass (a point whose corners carry none is skipped), so that `Σ_c H^f_{j,c}` equals
    /// `Σ_i H^s_{j,i}` over the nodes that can move: the interface impulse on the fluid is then
    /// exactly opposite to the one on the solid and total momentum is conserved. With the plain
    /// weights, the share of the impulse on corners without fluid is lost (measured: 25 % of
    /// the momentum of a block hitting a blob of water within 60 steps).
    fn push_interface_rows(
        &self,
        rows: &mut Constraints<D>,
        offset: usize,
        iq: &InterfacePoints<D>,
        fluid_mass: &[Real],
    ) {
        let domain: &Domain<D> = self.fluid.domain();
        let dx = domain.spec.dx;
        let sp = self.solid.particles();
        let reference = self.solid.reference();
        let mut keyed: Vec<(usize, usize, [usize; D], [Real; D])> = iq
            .particle
            .iter()
            .enumerate()
            .filter_map(|(k, &q)| {
                let (m, f) = domain.locate(&sp.x[q])?;
                Some((domain.nearest_node(&sp.x[q]), k, m, f))
            })
            .collect();
        keyed.sort_unstable_by_key(|e| (e.0, e.1));
        let mut w = [0.0; 8];
        let mut g = [Vector::<D>::zeros(); 8];
        for group in keyed.chunk_by(|a, b| a.0 == b.0) {
            let mut entries = Vec::new();
            for &(_, k, m, f) in group {
                let (q, an) = (iq.particle[k], iq.normal[k] * iq.area[k]);
                crate::domain::corner_weights(&f, dx, &mut w, &mut g);
                let corners = Domain::<D>::CORNERS;
                let wet: Real = (0..corners)
                    .filter(|&j| fluid_mass[domain.corner_node(&m, j)] > 0.0)
                    .map(|j| w[j])
                    .sum();
                if wet.is_nan() || wet <= 0.0 {
                    continue;
                }
                for (j, wj) in w.iter().enumerate().take(corners) {
                    let c = domain.corner_node(&m, j);
                    if fluid_mass[c] > 0.0 {
                        entries.push((c, an * (*wj / wet)));
                    }
                }
                for (i, wi, _) in reference.stencil(q) {
                    entries.push((offset + i, -an * wi));
                }
            }
            if !entries.is_empty() {
                rows.push_row(UnknownKind::Interface, group[0].0, entries, 0.0);
            }
        }
    }

    /// Appends the interface rows of [`InterfaceQuadrature::FluidNodes`] (see there), solid
    /// slots from `offset`, after the fluid rows of `rows`.
    fn push_node_interface_rows(&self, rows: &mut Constraints<D>, offset: usize) {
        let domain: &Domain<D> = self.fluid.domain();
        let dx = domain.spec.dx;
        let sp = self.solid.particles();
        let reference = self.solid.reference();
        let mut b = vec![Vector::<D>::zeros(); domain.spec.num_nodes()];
        for k in 0..rows.num_fluid() {
            let (nodes, coeffs) = rows.row(k);
            for (&i, c) in nodes.iter().zip(coeffs) {
                b[i] += c;
            }
        }
        let mut solids = CellList::default();
        solids.build(&sp.x, dx);
        let held = self.held_axes(domain);
        // A component below this is round-off of the sum over equal cells (m² in 3D).
        let tol = 1e-9 * dx.powi(D as i32 - 1);
        // The solid particles in a node's B1 support, weighted by its tent (reused buffer).
        let mut near: Vec<(usize, Real)> = Vec::new();
        for (i, bi) in b.iter().enumerate() {
            if bi.iter().all(|c| c.abs() <= tol) {
                continue;
            }
            let xi = domain.spec.node_position(&domain.spec.multi_index(i));
            near.clear();
            solids.for_each_candidate_near(&xi, |q| {
                let w: Real = (0..D)
                    .map(|a| (1.0 - (sp.x[q][a] - xi[a]).abs() / dx).max(0.0))
                    .product();
                if w > 0.0 {
                    near.push((q, w));
                }
            });
            if near.is_empty() {
                continue;
            }
            near.sort_unstable_by_key(|e| e.0);
            let total: Real = near.iter().map(|e| e.1).sum();
            let axes = held(i);
            for a in (0..D).filter(|&a| bi[a].abs() > tol && axes[a]) {
                let mut part = Vector::<D>::zeros();
                part[a] = bi[a];
                let solid = near.iter().flat_map(|&(q, w)| {
                    reference
                        .stencil(q)
                        .map(move |(j, wj, _)| (offset + j, -part * (wj * w / total)))
                });
                rows.push_row(
                    UnknownKind::Interface,
                    i,
                    std::iter::once((i, part)).chain(solid),
                    0.0,
                );
            }
        }
    }

    /// Which axes the node rows hold at each node: those along which the solid's outward
    /// normal at the node has at least half its largest component. The normal is
    /// `n_i = Σ_c θ_c ∇w_i(x_c)` over the `2^D` cells around node `i`, `θ_c` the cell's solid
    /// volume fraction (reference volumes of the solid particles in it, capped at 1): along a
    /// face of the cell staircase only the normal axis (the fluid slips along the face), at a
    /// convex or concave corner every axis (where one normal row cannot balance a hydrostatic
    /// pressure, `docs/diq.md`); a stray solid particle in a fluid cell tilts `n_i` too little
    /// to add an axis. A node with no solid volume around it holds every axis.
    fn held_axes<'s>(&'s self, domain: &'s Domain<D>) -> impl Fn(usize) -> [bool; D] + 's {
        let sp = self.solid.particles();
        let cell_volume = domain.spec.cell_volume();
        let mut fraction = vec![0.0; domain.num_cells()];
        for q in 0..sp.len() {
            if let Some((m, _)) = domain.locate(&sp.x[q]) {
                fraction[domain.cell_index(&m)] += sp.volume0[q] / cell_volume;
            }
        }
        let mut w = [0.0; 8];
        let mut g = [Vector::<D>::zeros(); 8];
        crate::domain::corner_weights(&[0.5; D], domain.spec.dx, &mut w, &mut g);
        move |i| {
            let node = domain.spec.multi_index(i);
            let mut n = Vector::<D>::zeros();
            'corner: for (j, gj) in g.iter().enumerate().take(Domain::<D>::CORNERS) {
                let mut cell = [0usize; D];
                for a in 0..D {
                    let k = node[a] - ((j >> a) & 1) as i64;
                    if k < 0 || k >= domain.cell_dims[a] as i64 {
                        continue 'corner;
                    }
                    cell[a] = k as usize;
                }
                n += gj * fraction[domain.cell_index(&cell)].min(1.0);
            }
            let largest = n.amax();
            std::array::from_fn(|a| largest == 0.0 || n[a].abs() >= 0.5 * largest)
        }
    }

    /// The coupled system of a step of `dt` at fluid node fields `nodes` (after the predictor)
    /// and the solid's `V*`: the rows, the inverse masses and the velocities `u* = (v*, V*)`,
    /// plus the fluid volume of each fluid row and the interface points.
    #[allow(clippy::type_complexity)]
    fn coupled_rows(
        &self,
        (points, iq): (&FluidPoints<D>, &InterfacePoints<D>),
        nodes: &NodeFields<D>,
        bins: &Bins,
        v_solid: &[Vector<D>],
        dt: Real,
    ) -> (Constraints<D>, Vec<Real>, Vec<Vector<D>>, Vec<Real>) {
        let (mut rows, volumes) =
            self.fluid
                .constraints((&points.x, &points.volume), bins, &nodes.mass, self.time);
        rows.pin_gauge = false;
        let offset = rows.append_nodes(v_solid.len());
        self.push_solid_rows(&mut rows, offset, dt);
        match self.solid_params.interface {
            InterfaceQuadrature::SolidParticles => {
                self.push_interface_rows(&mut rows, offset, iq, &nodes.mass)
            }
            InterfaceQuadrature::FluidNodes => self.push_node_interface_rows(&mut rows, offset),
        }
        let masses = self.solid.reference().node_masses();
        let mut inv_mass = nodes.inv_mass.clone();
        inv_mass.extend(masses.iter().enumerate().map(|(i, &m)| {
            if self.solid.node_is_fixed(i) || m <= 0.0 {
                0.0
            } else {
                1.0 / m
            }
        }));
        let mut u = nodes.velocity.clone();
        u.extend_from_slice(v_solid);
        (rows, inv_mass, u, volumes)
    }

    /// The coupled system of a step of `dt` (s) from the current state, for tests and
    /// benchmarks: the rows of `J` (fluid, wall, solid-pressure and interface rows, in that
    /// order), the inverse lumped masses of the velocity slots (fluid nodes, then the solid's
    /// reference nodes; 1/kg) and the right-hand side `J u* − c`. Runs the fluid predictor and
    /// the solid's elastic solve into scratch storage; the state does not advance.
    #[allow(clippy::type_complexity)]
    pub fn coupled_problem(
        &mut self,
        dt: Real,
    ) -> Result<(Constraints<D>, Vec<Real>, Vec<Real>), Failure<CoupledError>> {
        let mut times = StageTimes::default();
        let iq = self.interface_points();
        let points = self.fluid_points(&iq);
        let (bins, nodes) = self
            .fluid
            .predictor_for(points.points(), dt, &mut times)
            .map_err(lift)?;
        self.solid.elastic_predictor(dt).map_err(lift)?;
        let v_solid = self.solid.node_velocities(dt);
        let (rows, inv_mass, u, _) = self.coupled_rows((&points, &iq), &nodes, &bins, &v_solid, dt);
        let rhs = rows.residual(&u);
        Ok((rows, inv_mass, rhs))
    }

    /// One attempt at a step of `dt` (s); the state is untouched until [`Self::commit`].
    fn attempt(&mut self, dt: Real) -> Result<Pending<D>, Failure<CoupledError>> {
        let mut times = std::mem::take(&mut self.times);
        let r = self.attempt_timed(dt, &mut times);
        self.times = times;
        r
    }

    fn attempt_timed(
        &mut self,
        dt: Real,
        times: &mut StageTimes,
    ) -> Result<Pending<D>, Failure<CoupledError>> {
        let (iq, points) = times.time(Stage::Coupling, || {
            let iq = self.interface_points();
            let points = self.fluid_points(&iq);
            (iq, points)
        });
        let (bins, mut nodes) = self
            .fluid
            .predictor_for(points.points(), dt, times)
            .map_err(lift)?;
        let contact = self.solid.elastic_predictor(dt).map_err(lift)?;
        let v_solid = self.solid.node_velocities(dt);
        let (rows, inv_mass, u, volumes) = times.time(Stage::Coupling, || {
            self.coupled_rows((&points, &iq), &nodes, &bins, &v_solid, dt)
        });
        let mut system = std::mem::take(&mut self.projection);
        let solved = self.project_iterated(&rows, &inv_mass, u, dt, &mut system, times);
        self.projection = system;
        let (lambda, u, info, passes) = solved?;
        let nf = nodes.velocity.len();
        self.solid.set_node_velocities(&u[nf..], dt);
        self.solid.transfer_back(dt).map_err(lift)?;
        nodes.velocity.copy_from_slice(&u[..nf]);
        let fluid = if self.has_fluid() {
            let fields = self.fluid.cell_fields(&rows, &lambda, &u, &volumes);
            let mut correction = std::mem::take(&mut self.correction);
            let r = self.fluid_back(&points, (&nodes, &bins), fields, dt, &mut correction, times);
            self.correction = correction;
            Some(r?)
        } else {
            None
        };
        let mut solid_pressure = vec![0.0; self.solid_pressure.len()];
        for (k, kind) in rows.kinds.iter().enumerate() {
            if *kind == UnknownKind::SolidPressure {
                let (_, members) = self
                    .solid_cells
                    .iter()
                    .find(|(c, _)| *c == rows.anchors[k])
                    .expect("every solid row is a solid cell");
                for &p in members {
                    solid_pressure[p] = lambda[k];
                }
            }
        }
        self.plastic_pressure_correction(&mut solid_pressure);
        let mut solves = vec![
            SolveInfo {
                name: "coupled_pressure",
                iterations: info.iterations,
                residual: info.relative_residual,
            },
            passes,
        ];
        solves.extend(nodes.viscous);
        if let Some(f) = &fluid {
            solves.extend(f.solves.iter().copied());
        }
        Ok(Pending {
            fluid,
            solid_pressure,
            solves,
            interface_points: iq.particle.len(),
            contact_pairs: contact.map(|c| c.pairs),
        })
    }

    /// Plastic particles (module docs, "Plastic solids"): the return mapping scaled the elastic
    /// volume ratio by `r = det F_E / det F_E^trial`, so the remapped `J_E = 1 − P/λ^v` becomes
    /// `r J_E`, i.e. `P ← λ^v − r (λ^v − P)`. Elastic particles are left as they are.
    fn plastic_pressure_correction(&self, solid_pressure: &mut [Real]) {
        let Some(factors) = self.solid.plastic_volume_factors() else {
            return;
        };
        for (p, pressure) in solid_pressure.iter_mut().enumerate() {
            if self.plastic[p] {
                let lv = self.lambda_v[p];
                *pressure = lv - factors[p] * (lv - *pressure);
            }
        }
    }

    /// The coupled projection of the predictor velocities `u` (fluid nodes, then the solid's
    /// reference nodes; m/s) with the rows `rows`, iterated with the solid's elastic solve (see
    /// [`CouplingIteration`]). Returns the pressures and the velocities of the last projection,
    /// its solver report, and the iteration's report (`coupling_passes`: projections, and the
    /// last strain mismatch as its residual).
    #[allow(clippy::type_complexity)]
    fn project_iterated(
        &mut self,
        rows: &Constraints<D>,
        inv_mass: &[Real],
        u: Vec<Vector<D>>,
        dt: Real,
        system: &mut PressureSystem<D>,
        times: &mut StageTimes,
    ) -> Result<(Vec<Real>, Vec<Vector<D>>, PressureInfo, SolveInfo), Failure<CoupledError>> {
        let stage = Stage::Coupling;
        let fluid = &self.fluid;
        times
            .time(stage, || {
                fluid.assemble_onto(rows, inv_mass, dt, system, stage)
            })
            .map_err(lift)?;
        let nf = u.len() - self.solid.reference().node_masses().len();
        let inv_solid = &inv_mass[nf..];
        let dx = Solver::spec(&self.fluid).dx;
        let it = self.solid_params.coupling;
        let mut force = vec![Vector::<D>::zeros(); inv_solid.len()];
        let mut relax = Anderson::default();
        let mut passes = 0;
        loop {
            passes += 1;
            // Ṽ = V*(f) − Δt M⁻¹ f: the elastic velocities without the lumped response to f.
            let v_star = self.solid.node_velocities(dt);
            let mut v = u[..nf].to_vec();
            v.extend(
                v_star
                    .iter()
                    .zip(&force)
                    .zip(inv_solid)
                    .map(|((v, f), &w)| v - f * (dt * w)),
            );
            let tilde = v[nf..].to_vec();
            let (lambda, info) = times
                .time(stage, || {
                    fluid.project_assembled(rows, inv_mass, dt, &mut v, system, stage)
                })
                .map_err(lift)?;
            let mismatch = v[nf..]
                .iter()
                .zip(&v_star)
                .map(|(a, b)| (a - b).norm())
                .fold(0.0, Real::max)
                * dt
                / dx;
            if mismatch <= it.strain_tolerance || passes >= it.max_passes.max(1) {
                let report = SolveInfo {
                    name: "coupling_passes",
                    iterations: passes as u32,
                    residual: mismatch,
                };
                return Ok((lambda, v, info, report));
            }
            // f' = M (V − Ṽ)/Δt, zero on fixed nodes (M⁻¹ = 0).
            let target: Vec<Vector<D>> = v[nf..]
                .iter()
                .zip(&tilde)
                .zip(inv_solid)
                .map(|((a, b), &w)| {
                    if w > 0.0 {
                        (a - b) / (dt * w)
                    } else {
                        Vector::<D>::zeros()
                    }
                })
                .collect();
            let delta = relax.step(&force, &target);
            for (f, d) in force.iter_mut().zip(&delta) {
                *f += d;
            }
            self.solid
                .resolve_with_node_forces(dt, &delta)
                .map_err(lift)?;
        }
    }

    /// The current volume `J_p V⁰_p` of the solid particles inside the fluid's wall box,
    /// spread to the fluid grid's nodes with the B1 weights (m^D per node).
    fn solid_node_volume(&self) -> Vec<Real> {
        let sp = self.solid.particles();
        let domain = self.fluid.domain();
        let inside: Vec<usize> = (0..sp.len())
            .filter(|&q| domain.locate(&sp.x[q]).is_some())
            .collect();
        let x: Vec<Vector<D>> = inside.iter().map(|&q| sp.x[q]).collect();
        let volume: Vec<Real> = inside
            .iter()
            .map(|&q| Dim::<D>::det(&sp.def_grad_of(q)).max(0.0) * sp.volume0[q])
            .collect();
        let (zero_v, zero_c) = (
            vec![Vector::<D>::zeros(); x.len()],
            vec![Matrix::<D>::zeros(); x.len()],
        );
        let points = Points {
            x: &x,
            v: &zero_v,
            affine: &zero_c,
            mass: &volume,
            volume: &volume,
        };
        let bins = self.fluid.bin(&x);
        self.fluid.transfer(points, &bins, false).volume
    }

    /// Fluid G2P over the quadrature points: each fluid particle takes the mean of the
    /// velocities and affine matrices at itself and at the interface points it shared its
    /// mass with (the transpose of the split in [`FluidPoints`], so momentum is conserved),
    /// moves by it and is clamped; then the position correction, when on.
    fn fluid_back(
        &self,
        points: &FluidPoints<D>,
        (nodes, bins): (&NodeFields<D>, &Bins),
        (pressure_of_cell, divergence_of_cell): (Vec<Real>, Vec<Real>),
        dt: Real,
        correction: &mut PressureSystem<D>,
        times: &mut StageTimes,
    ) -> Result<Attempt<D>, Failure<CoupledError>> {
        let fp = Solver::particles(&self.fluid);
        let n = fp.len();
        let (_, v_all, c_all) = times
            .time(Stage::G2P, || self.fluid.g2p(&points.x, nodes, dt))
            .map_err(lift)?;
        let domain = self.fluid.domain();
        let (dx, t_end) = (domain.spec.dx, self.time + dt);
        let moved: Vec<(Vector<D>, Vector<D>, Matrix<D>)> = (0..n)
            .into_par_iter()
            .map(|p| {
                let shared = &points.shared[points.shared_start[p]..points.shared_start[p + 1]];
                let (mut v, mut c) = (v_all[p], c_all[p]);
                for &k in shared {
                    v += v_all[n + k];
                    c += c_all[n + k];
                }
                let s = 1.0 / (shared.len() + 1) as Real;
                let (v, c) = (v * s, c * s);
                let mut x = fp.x[p] + v * dt;
                domain.clamp(&mut x, t_end, crate::fluid::CLAMP_MARGIN * dx);
                (x, v, c)
            })
            .collect();
        let mut x: Vec<Vector<D>> = moved.iter().map(|m| m.0).collect();
        let mut solves = Vec::new();
        if self.params.position_correction {
            if let Some(c) = times
                .time(Stage::PositionCorrection, || {
                    // With the node rows the fluid ends at the cell staircase, which the
                    // solid volume spread to nodes overlaps: counted, it marks the fluid
                    // cells along a resting solid as overfull every step, and the pushes
                    // grew a neutrally buoyant block's round-off flow exponentially (water
                    // kinetic energy 3e-7 J at 0.5 s, 1.9 J at 3 s; 2e-5 J without).
                    let occupied = match self.solid_params.interface {
                        InterfaceQuadrature::SolidParticles => self.solid_node_volume(),
                        InterfaceQuadrature::FluidNodes => Vec::new(),
                    };
                    self.fluid
                        .correct_positions(&mut x, dt, correction, &occupied)
                })
                .map_err(lift)?
            {
                solves.push(SolveInfo {
                    name: "position_correction",
                    iterations: c.iterations,
                    residual: c.relative_residual,
                });
            }
        }
        Ok(Attempt {
            x,
            v: moved.iter().map(|m| m.1).collect(),
            affine: moved.iter().map(|m| m.2).collect(),
            pressure: bins.cell[..n]
                .iter()
                .map(|&c| pressure_of_cell[c])
                .collect(),
            divergence: bins.cell[..n]
                .iter()
                .map(|&c| divergence_of_cell[c])
                .collect(),
            solves,
            events: Vec::new(),
        })
    }

    /// Writes an accepted attempt into the state and the scene-ordered particles.
    fn commit(&mut self, pending: Pending<D>, dt: Real) -> Result<bool, Failure<CoupledError>> {
        let updated = self.solid.commit_step(dt).map_err(lift)?;
        if let Some(f) = pending.fluid {
            self.fluid.accept(f, dt);
        }
        self.solid_pressure = pending.solid_pressure;
        if updated {
            // A-ULMPM moved the reference: its cells hold other particles, and the volume term
            // of Eq. 37 starts again from J^(r,n) = 1, i.e. P^s = 0. A plastic particle's J_E
            // does not change with the reference, nor does its pressure.
            self.bin_solid_cells();
            for (pressure, _) in self
                .solid_pressure
                .iter_mut()
                .zip(&self.plastic)
                .filter(|(_, &plastic)| !plastic)
            {
                *pressure = 0.0;
            }
        }
        self.time += dt;
        self.steps += 1;
        self.push_fluid_out_of_solids();
        self.gather_particles();
        Ok(updated)
    }

    /// The outward normal `−∇m/‖∇m‖` of Eq. 36 at solid particle `q`, with `cells` binning the
    /// solid positions in cells of 2Δx; `None` where the mass gradient vanishes.
    fn solid_normal(&self, cells: &CellList<D>, q: usize) -> Option<Vector<D>> {
        let dx = Solver::spec(&self.fluid).dx;
        let sp = self.solid.particles();
        let mut grad = Vector::<D>::zeros();
        cells.for_each_within(&sp.x, q, 2.0 * dx, |r, d, dist| {
            // d = x_r − x_q; ∇_x N(‖x − x_r‖) at x_q = N'(dist) (x_q − x_r)/dist.
            if dist > 0.0 {
                grad -= d * (sp.mass[r] * cubic_derivative(dist / dx) / (dx * dist));
            }
        });
        let norm = grad.norm();
        (norm > 0.0).then(|| -grad / norm)
    }

    /// [`Self::solid_normal`] at every solid particle, zero where it does not exist.
    fn solid_normals(&self, cells: &CellList<D>) -> Vec<Vector<D>> {
        (0..self.solid.particles().len())
            .into_par_iter()
            .map(|q| {
                self.solid_normal(cells, q)
                    .unwrap_or_else(Vector::<D>::zeros)
            })
            .collect()
    }

    /// IQ-MPM's particle position clamping (which §5.1 follows): a fluid particle within
    /// 0.6 Δx of a solid particle `q` and behind it, `(x − x_q)·n_q < 0`, is inside the solid; it
    /// moves along the normal of its nearest solid particle in steps of Δx/10, at most 20, until
    /// it is not. The interface rows constrain normal velocities only on average over a node's
    /// piece of interface, so without this the B1 velocity field carries fluid particles into
    /// the solid: measured on a slab resting on water across a 2D tank, the fluid rose 0.19 m
    /// into the 0.25 m slab within 1 s and the slab sank 2 cm.
    fn push_fluid_out_of_solids(&mut self) {
        if !self.has_fluid() {
            return;
        }
        let dx = Solver::spec(&self.fluid).dx;
        let sp = self.solid.particles();
        let mut cells = CellList::default();
        cells.build(&sp.x, 2.0 * dx);
        let normals = self.solid_normals(&cells);
        let reach2 = (0.6 * dx) * (0.6 * dx);
        let inside = |x: &Vector<D>| {
            let (mut bad, mut nearest, mut best) = (false, usize::MAX, Real::INFINITY);
            cells.for_each_candidate_near(x, |q| {
                let d = x - sp.x[q];
                let r2 = d.norm_squared();
                if r2 <= reach2 {
                    bad |= d.dot(&normals[q]) < 0.0;
                    if r2 < best {
                        (best, nearest) = (r2, q);
                    }
                }
            });
            bad.then_some(nearest)
        };
        let domain = self.fluid.domain().clone();
        let t = self.time;
        self.fluid.positions_mut().par_iter_mut().for_each(|x| {
            let Some(q) = inside(x) else {
                return;
            };
            let n = normals[q];
            for _ in 0..20 {
                *x += n * (0.1 * dx);
                if inside(x).is_none() {
                    break;
                }
            }
            domain.clamp(x, t, crate::fluid::CLAMP_MARGIN * dx);
        });
    }

    /// Copies the parts' particles into the scene-ordered set.
    fn gather_particles(&mut self) {
        let fp = Solver::particles(&self.fluid);
        let sp = self.solid.particles();
        let ps = &mut self.particles;
        for (k, &p) in self.fluid_index.iter().enumerate() {
            ps.x[p] = fp.x[k];
            ps.v[p] = fp.v[k];
            ps.affine[p] = fp.affine[k];
        }
        let f = ps.def_grad.as_mut().expect("set at build");
        for (k, &p) in self.solid_index.iter().enumerate() {
            ps.x[p] = sp.x[k];
            ps.v[p] = sp.v[k];
            ps.affine[p] = sp.affine[k];
            f[p] = sp.def_grad_of(k);
            if let (Some(dst), Some(src)) = (&mut ps.plastic, &sp.plastic) {
                dst[p] = src[k];
            }
        }
    }

    /// The step bound (s): no particle, fluid or solid, moves more than `cfl Δx`.
    fn bound(&self) -> Real {
        let vmax = self
            .particles
            .v
            .iter()
            .fold(0.0, |m: Real, v| mpm_core::solver::nan_max(m, v.norm()));
        self.fluid.displacement_bound(vmax)
    }

    /// [`Solver::step`] on the calling thread, with the solve errors typed.
    fn advance_step(&mut self) -> Result<StepInfo, StepError<CoupledError>> {
        let start = StepStart {
            step: self.steps,
            time: self.time,
        };
        let t0 = std::time::Instant::now();
        let stable = self.bound();
        self.times.add(Stage::TimeStep, t0.elapsed());
        let dt0 = choose_dt(&self.params.time_step, stable)
            .map_err(|e| start.error(Failure::Guard(Stage::TimeStep, e), 0.0, 0))?;
        let (pending, dt, retries) = retry_halving(self.params.on_instability, start, dt0, |dt| {
            self.attempt(dt)
        })?;
        let (solves, iq) = (pending.solves.clone(), pending.interface_points);
        let pairs = pending.contact_pairs;
        let updated = self
            .commit(pending, dt)
            .map_err(|f| start.error(f, dt, retries))?;
        let mut events = vec![("interface_points", iq as u64)];
        if let Some(n) = pairs {
            events.push(("contact_pairs", n as u64));
        }
        if updated {
            events.push(("reference_updates", 1));
        }
        Ok(StepInfo {
            dt,
            retries,
            time: self.time,
            solves,
            events,
            residual_histories: Vec::new(),
        })
    }

    /// Per-particle pressure in scene order (Pa).
    fn scene_pressure(&self) -> Vec<Real> {
        let mut out = vec![0.0; self.particles.len()];
        for (k, &p) in self.fluid_index.iter().enumerate() {
            out[p] = self.fluid.particle_pressure()[k];
        }
        for (k, &p) in self.solid_index.iter().enumerate() {
            out[p] = self.solid_pressure[k];
        }
        out
    }

    /// Per-particle fluid divergence in scene order (1/s; 0 on solids).
    fn scene_divergence(&self) -> Vec<Real> {
        let mut out = vec![0.0; self.particles.len()];
        for (k, &p) in self.fluid_index.iter().enumerate() {
            out[p] = self.fluid.particle_divergence()[k];
        }
        out
    }
}

/// Anderson acceleration of a fixed-point iteration `f ← T(f)` (Walker & Ni 2011, type II,
/// no damping): with the residuals `r = T(f) − f` of the last [`Self::DEPTH`] + 1 passes, the
/// next iterate is `T(f_k) − ΔG γ` with `γ` minimising `‖r_k − ΔR γ‖₂` (`ΔR`, `ΔG` the
/// differences of successive residuals and images). On an affine map this is GMRES on its
/// fixed-point equation, so it converges where the plain iteration or a scalar relaxation
/// crawls: a stiff solid's interface modes contract by only `1 − m_node/m_body` per plain pass.
#[derive(Clone, Debug, Default)]
struct Anderson<const D: usize> {
    /// The last iterates' residuals `r` and images `g = T(f)`, oldest first.
    history: Vec<(Vec<Vector<D>>, Vec<Vector<D>>)>,
}

impl<const D: usize> Anderson<D> {
    /// Differences kept (the depth `m`).
    const DEPTH: usize = 5;

    /// The update `f_{k+1} − f_k` from the current iterate `current` and its image `target`.
    fn step(&mut self, current: &[Vector<D>], target: &[Vector<D>]) -> Vec<Vector<D>> {
        let r: Vec<Vector<D>> = target.iter().zip(current).map(|(t, c)| t - c).collect();
        self.history.push((r.clone(), target.to_vec()));
        if self.history.len() > Self::DEPTH + 1 {
            self.history.remove(0);
        }
        let m = self.history.len() - 1;
        let diff = |k: usize, image: bool| -> Vec<Vector<D>> {
            let (a, b) = (&self.history[k], &self.history[k + 1]);
            let (a, b) = if image { (&a.1, &b.1) } else { (&a.0, &b.0) };
            b.iter().zip(a).map(|(b, a)| b - a).collect()
        };
        let dr: Vec<Vec<Vector<D>>> = (0..m).map(|k| diff(k, false)).collect();
        let dot = |a: &[Vector<D>], b: &[Vector<D>]| -> Real {
            a.iter().zip(b).map(|(a, b)| a.dot(b)).sum()
        };
        // Normal equations of the small least-squares problem, slightly regularised.
        let mut normal = nalgebra::DMatrix::<Real>::zeros(m, m);
        let mut rhs = nalgebra::DVector::<Real>::zeros(m);
        for a in 0..m {
            for b in 0..m {
                normal[(a, b)] = dot(&dr[a], &dr[b]);
            }
            rhs[a] = dot(&dr[a], &r);
        }
        let ridge = 1e-12 * normal.trace().max(Real::MIN_POSITIVE);
        for a in 0..m {
            normal[(a, a)] += ridge;
        }
        let gamma = normal
            .cholesky()
            .map(|c| c.solve(&rhs))
            .unwrap_or_else(|| nalgebra::DVector::zeros(m));
        let mut next = target.to_vec();
        for k in 0..m {
            let dg = diff(k, true);
            for (f, d) in next.iter_mut().zip(&dg) {
                *f -= d * gamma[k];
            }
        }
        next.iter().zip(current).map(|(n, c)| n - c).collect()
    }
}

/// `dN/dq` of the cubic B-spline of support 2 (in units of Δx), unnormalised.
fn cubic_derivative(q: Real) -> Real {
    if q < 1.0 {
        -2.0 * q + 1.5 * q * q
    } else if q < 2.0 {
        -0.5 * (2.0 - q) * (2.0 - q)
    } else {
        0.0
    }
}

/// The cross-section of a sphere (3D) or disc (2D) of volume `v` (m^D): `π r²` (m²), or the
/// diameter `2r` (m) in 2D.
fn cross_section<const D: usize>(v: Real) -> Real {
    use std::f64::consts::PI;
    if D == 3 {
        let r = (3.0 * v / (4.0 * PI)).cbrt();
        PI * r * r
    } else {
        2.0 * (v / PI).sqrt()
    }
}

impl<const D: usize> Solver<D> for DiqCoupled<D>
where
    Dim<D>: DimOps<D>,
{
    fn name(&self) -> &'static str {
        "DIQ-MPM: incompressible fluid and mixed TLMPM solids"
    }

    fn spec(&self) -> &GridSpec<D> {
        Solver::spec(&self.fluid)
    }

    fn particles(&self) -> &Particles<D> {
        &self.particles
    }

    fn materials(&self) -> &[Material] {
        &self.materials
    }

    fn time(&self) -> Real {
        self.time
    }

    fn steps(&self) -> u64 {
        self.steps
    }

    fn stable_dt(&self) -> Real {
        self.bound()
    }

    fn dt_bound(&self) -> DtBound {
        crate::fluid::displacement_bound_doc()
    }

    fn diagnostics(&self) -> Diagnostics<D> {
        Diagnostics::compute(&self.particles, &self.materials, None, &self.params.gravity)
    }

    fn plan(&self) -> StagePlan {
        self.plan.clone()
    }

    /// Advances one step; a failed solve is a [`StepError::Solve`] with the
    /// [`CoupledError`]'s message. The step runs on a thread of the rayon pool ([`on_pool`]).
    fn step(&mut self) -> Result<StepInfo, StepError> {
        on_pool(|| self.advance_step()).map_err(|e| e.erase("coupled"))
    }

    fn stage_times(&self) -> Vec<StageTime> {
        let solid = self.solid.stats();
        let mut rows = self.times.rows(&self.plan);
        for r in &mut rows {
            r.seconds += solid.get(r.stage).as_secs_f64();
        }
        rows
    }

    fn checkpoint(&self) -> SolverState {
        let mut state = SolverState::of_particles(&self.particles, self.time, self.steps);
        let mut reference = self.particles.x.clone();
        for (k, &p) in self.solid_index.iter().enumerate() {
            reference[p] = self.solid.reference().positions()[k];
        }
        state
            .columns
            .push(Column::vectors(REFERENCE_X, "m", &reference));
        let solid = self.solid.state();
        let scene_order = |m: &[Matrix<D>]| {
            let mut out = vec![Matrix::<D>::identity(); self.particles.len()];
            for (k, &p) in self.solid_index.iter().enumerate() {
                out[p] = m[k];
            }
            out
        };
        if let Some(g) = &solid.relative_def_grad {
            state
                .columns
                .push(Column::matrices(RELATIVE_F, "1", &scene_order(g)));
        }
        if let Some(b) = &solid.base_def_grad {
            state
                .columns
                .push(Column::matrices(BASE_F, "1", &scene_order(b)));
        }
        state.attrs.push((
            ATTR_REFERENCE_UPDATES.to_string(),
            solid.reference_updates as f64,
        ));
        state
            .columns
            .push(Column::scalars(PRESSURE, "Pa", &self.scene_pressure()));
        state
            .columns
            .push(Column::scalars(DIVERGENCE, "1/s", &self.scene_divergence()));
        state
    }

    fn restore(&mut self, state: &SolverState) -> Result<(), RestoreError> {
        let particles =
            columns::particles_from_columns(&state.columns, &self.particles, self.materials.len())?;
        let n = particles.len();
        let scalar = |name: &str| -> Result<Vec<Real>, RestoreError> {
            columns::f64_values(&state.columns, name, &[n])?
                .map(<[Real]>::to_vec)
                .ok_or_else(|| RestoreError(format!("checkpoint has no field `{name}`")))
        };
        let (pressure, divergence) = (scalar(PRESSURE)?, scalar(DIVERGENCE)?);
        let reference: Vec<Vector<D>> = columns::f64_values(&state.columns, REFERENCE_X, &[n, D])?
            .ok_or_else(|| RestoreError(format!("checkpoint has no field `{REFERENCE_X}`")))?
            .chunks_exact(D)
            .map(Vector::<D>::from_column_slice)
            .collect();
        let is_fluid = |p: usize| {
            matches!(
                self.materials[particles.material[p] as usize],
                Material::Fluid(_)
            )
        };
        let solids: Vec<usize> = (0..n).filter(|&p| !is_fluid(p)).collect();
        let mats = |name: &str| -> Result<Option<Vec<Matrix<D>>>, RestoreError> {
            Ok(columns::f64_values(&state.columns, name, &[n, D, D])?
                .map(columns::to_matrices::<D>)
                .map(|m| solids.iter().map(|&p| m[p]).collect()))
        };
        let solid_state = TlmpmState {
            time: state.time,
            steps: state.steps,
            reference_positions: solids.iter().map(|&p| reference[p]).collect(),
            relative_def_grad: mats(RELATIVE_F)?,
            base_def_grad: mats(BASE_F)?,
            reference_updates: state.attr(ATTR_REFERENCE_UPDATES).map_or(0, |v| v as u64),
            node_velocities: None,
        };
        let mut s = Self::build(
            *Solver::spec(&self.fluid),
            self.params.clone(),
            self.solid_params.clone(),
            self.materials.clone(),
            self.boundaries.clone(),
            particles,
            Some(solid_state),
            state.time,
        )
        .map_err(|e| RestoreError(format!("does not fit this scene: {e}")))?;
        let fluid_p: Vec<Real> = s.fluid_index.iter().map(|&p| pressure[p]).collect();
        let fluid_d: Vec<Real> = s.fluid_index.iter().map(|&p| divergence[p]).collect();
        s.fluid.set_state(state.time, state.steps, fluid_p, fluid_d);
        s.solid_pressure = s.solid_index.iter().map(|&p| pressure[p]).collect();
        *self = s;
        Ok(())
    }

    fn monitors(&self) -> Vec<Monitor> {
        if self.has_fluid() {
            self.fluid.monitors()
        } else {
            Vec::new()
        }
    }

    fn output_fields(&self) -> Vec<FieldInfo> {
        let mut fields =
            mpm_core::solver::particle_field_infos::<D>(&self.particles.columns().names());
        fields.push(FieldInfo {
            name: "pressure",
            unit: "Pa",
            components: 1,
            derived: true,
        });
        fields.push(FieldInfo {
            name: "divergence",
            unit: "1/s",
            components: 1,
            derived: true,
        });
        fields
    }

    fn pressure(&self) -> Vec<Real> {
        self.scene_pressure()
    }

    fn output(&self, name: &str) -> Vec<Column> {
        match name {
            "pressure" => vec![Column::scalars("pressure", "Pa", &self.scene_pressure())],
            "divergence" => vec![Column::scalars(
                "divergence",
                "1/s",
                &self.scene_divergence(),
            )],
            _ => columns::particle_column(&self.particles, name),
        }
    }
}

#[cfg(test)]
mod anderson_tests {
    use super::Anderson;
    use mpm_core::{Real, Vector};

    /// An affine contraction `T(f) = A f + b` on three 2-vectors, `A` diagonal with the rates of
    /// a stiff solid's slow interface modes (0.99) down to 0; its fixed point is `b/(1 − a)`.
    fn map(f: &[Vector<2>]) -> Vec<Vector<2>> {
        let a = [0.99, 0.9, 0.5, 0.2, 0.1, 0.0];
        (0..3)
            .map(|k| Vector::<2>::from_fn(|c, _| a[2 * k + c] * f[k][c] + 1.0))
            .collect()
    }

    fn error(f: &[Vector<2>]) -> Real {
        let a = [0.99, 0.9, 0.5, 0.2, 0.1, 0.0];
        (0..6)
            .map(|i| (f[i / 2][i % 2] - 1.0 / (1.0 - a[i])).abs())
            .fold(0.0, Real::max)
    }

    #[test]
    fn anderson_solves_an_affine_fixed_point_where_the_plain_iteration_crawls() {
        let (mut plain, mut fast) = (vec![Vector::<2>::zeros(); 3], vec![Vector::<2>::zeros(); 3]);
        let mut acc = Anderson::<2>::default();
        for _ in 0..10 {
            plain = map(&plain);
            let delta = acc.step(&fast, &map(&fast));
            for (f, d) in fast.iter_mut().zip(&delta) {
                *f += d;
            }
        }
        // On an affine map Anderson behaves like GMRES: ten passes resolve the six rates; the
        // plain iteration is still 90 % short on the 0.99 mode (error 0.99¹⁰ · 100 = 90).
        assert!(error(&fast) < 1e-8, "Anderson: {:e}", error(&fast));
        assert!(error(&plain) > 80.0, "plain: {:e}", error(&plain));
    }
}
