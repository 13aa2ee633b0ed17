//! Parameters of the TLMPM solvers.

use crate::contact::{ContactRadius, Obstacle};
use crate::loads::{NodalLoad, SurfaceTraction};
use mpm_core::{Kernel, Real, StepControl, Vector};
use serde::{Deserialize, Serialize};

/// Particle–grid velocity transfer on the reference grid.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Transfer {
    /// APIC on the reference grid: particles carry `C_p = ∇^X V` (1/s), the velocity gradient
    /// with respect to reference coordinates, and transfer `m_p (v_p + C_p (X_i − X_p))`. Affine
    /// velocity fields of the reference coordinates survive a round trip exactly.
    #[default]
    Apic,
    /// PIC: only `m_p v_p` is transferred (dissipative).
    Pic,
    /// FLIP/PIC blend, the explicit solver's convention (`mpm_explicit::Transfer::Flip`): P2G
    /// transfers `m_p v_p` only (as PIC), and G2P sets
    /// `v_p ← α (v_p + Σ_i W_ip (v_i^{n+1} − v̂_i)) + (1 − α) Σ_i W_ip v_i^{n+1}` (m/s), with
    /// `v̂_i` the node velocities after P2G and `v_i^{n+1}` those after the grid solve. Positions,
    /// `F_p` and `C_p = ∇^X V` (1/s, stored but not transferred) follow the node displacements
    /// as with the other transfers. `α = 0` is PIC; `α = 1` carries each particle's own
    /// velocity plus the grid's velocity increment, so velocity fields the grid cannot represent
    /// survive (FLIP's noise is the price).
    Flip {
        /// FLIP fraction α ∈ [0, 1] (dimensionless; 0.95–0.99 typical).
        blend: Real,
    },
    /// Node velocities persist from step to step and P2G (APIC form) runs only on the first
    /// step or after the particle velocities were changed from outside. The reference grid is
    /// Lagrangian, so this is a B-spline finite-element method with particle quadrature: it has
    /// no transfer dissipation, which APIC and PIC incur on every round trip for velocity fields
    /// that are not affine, for example next to prescribed nodes, in an amount set by the number
    /// of steps rather than by dt.
    Persistent,
}

/// A Dirichlet condition: every active grid node whose *reference* position lies in the box
/// `[min, max]` (inclusive, with a tolerance of 10⁻⁹ Δx) has the components flagged in `axes`
/// prescribed to move at `velocity`. Nodes are fixed in the reference configuration, so a
/// clamped end stays clamped however far the body deforms.
///
/// B-splines of degree above one do not interpolate, so where the displacement is actually
/// held depends on which nodes are fixed. With the quadratic kernel, fixing every node at
/// `X ≤ X₀` on a grid with a node at `X₀` leaves `u(X₀) = c₁/8` from the first free node, so
/// the clamp is soft by O(Δx). On a grid offset by half a cell, fixing the nodes at
/// `X ≤ X₀ + Δx/2` makes displacement and slope vanish at `X₀` exactly; the validation case
/// `cantilever_tip_load` clamps that way.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixedRegion<const D: usize> {
    /// Lower corner of the box in the reference configuration (m).
    pub min: Vector<D>,
    /// Upper corner of the box in the reference configuration (m).
    pub max: Vector<D>,
    /// Which velocity components are prescribed (all for a clamp, one for a roller).
    pub axes: [bool; D],
    /// Prescribed velocity (m/s); only the flagged components are used.
    pub velocity: Vector<D>,
}

impl<const D: usize> FixedRegion<D> {
    /// A clamp: all components of the nodes in `[min, max]` (m) held at rest.
    pub fn clamp(min: Vector<D>, max: Vector<D>) -> Self {
        Self {
            min,
            max,
            axes: [true; D],
            velocity: Vector::<D>::zeros(),
        }
    }
}

/// A clamp that holds exactly on a plane of the reference grid: every
/// displacement component vanishes on the plane `X_axis = position`, the material lying on the
/// side `above` (`X_axis > position`) or below it. The plane must lie on a node layer or midway
/// between two; both hold the clamp exactly and give the same answer (a 2D cantilever's first
/// swing to 0.03 %).
///
/// It works on the basis, not on nodes: along `axis` the B-spline factor of each node on the
/// material side becomes `N(X − X_k) − N(X̄ − X_k)`, `X̄ = 2 position − X` the mirror image, and
/// nodes on or beyond the plane drop out (`Stencil::reflect_odd`). On an aligned plane the
/// image of every node beyond the plane is a node, so this is the fold `N_k − N_mirror(k)`: the
/// displacement is odd across the plane, every basis function vanishes on it, and `u = Σ c_k φ_k`
/// is zero there whatever the coefficients, at second order (`mms_1d_tlmpm`: 1.87–1.99).
/// Elsewhere the same formula still vanishes on the plane, but the nodes beyond it, whose images
/// are not nodes, drop out of the odd extension and the closure is first order (measured 0.97,
/// with the plane 0.3 cell off the nodes; the 2D cantilever 5 % softer at 4 cells through the
/// thickness), so such planes are refused: shift `grid.min` instead. Node clamps
/// ([`FixedRegion`]) leave `u(X₀) = c₁/8` with a node at `X₀` (O(Δx) too soft). Every particle
/// must lie strictly on the material side, and two planes on one axis at least a stencil width
/// apart.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ClampPlane {
    /// Axis of the plane's normal (0 = x, 1 = y, 2 = z).
    pub axis: usize,
    /// Position of the plane along `axis` in the reference configuration (m): inside the grid,
    /// on a node layer or midway between two.
    pub position: Real,
    /// Whether the material lies above the plane (`X_axis > position`); else below.
    pub above: bool,
}

/// Parameters shared by the implicit and the explicit TLMPM solvers.
#[derive(Clone, Debug, PartialEq)]
pub struct TlmpmParams<const D: usize> {
    /// B-spline kernel of the reference grid (quadratic by default).
    pub kernel: Kernel,
    /// Particle–grid velocity transfer.
    pub transfer: Transfer,
    /// Gravity, time step, damping and the reaction to instability (a failed guard check or a
    /// failed Newton solve). Damping of the unbalanced nodal forces is for explicit TLMPM only;
    /// the implicit solver rejects it, since it has no incremental potential. The implicit
    /// solver's adaptive bound is `cfl · Δx / max_p |v_p|` (no wave-speed limit); the explicit
    /// solver's is `cfl · Δx / max_p (|v_p| + c_p)`.
    pub step: StepControl<D>,
    /// Dirichlet regions on the reference grid. After an A-ULMPM reference update they apply to
    /// the nodes of the new reference grid.
    pub fixed: Vec<FixedRegion<D>>,
    /// Particle–particle and particle–obstacle penalty contact (diq-mpm §3.2, Eq. 4); `None`
    /// runs no contact stage.
    pub contact: Option<ContactParams<D>>,
    /// Exact clamps on grid planes (none by default); they hold after A-ULMPM reference updates
    /// too.
    pub clamp_planes: Vec<ClampPlane>,
    /// Forces on reference-grid nodes (none by default).
    pub nodal_loads: Vec<NodalLoad<D>>,
    /// Surface tractions through the surface particles (none by default).
    pub tractions: Vec<SurfaceTraction<D>>,
    /// A-ULMPM adaptive reference updates (diq-mpm §5.4); `None` keeps the initial reference
    /// configuration for the whole run (plain TLMPM, elastic solids only).
    pub reference_update: Option<ReferenceUpdate>,
}

/// The contact stage: per-particle penalty forces of Eq. 4 from the current positions, applied
/// as external nodal forces `f^c_i = Σ_p W_i(X_p) f^c_p` (N) through the reference weights.
#[derive(Clone, Debug, PartialEq)]
pub struct ContactParams<const D: usize> {
    /// Effective contact radius of each particle (§5.3 uses `Fixed(0.5 Δx)`).
    pub radius: ContactRadius,
    /// Obstacles of infinite mass (domain walls, colliders).
    pub obstacles: Vec<Obstacle<D>>,
}

/// A-ULMPM trigger (Su et al. 2021; diq-mpm §5.4): after a step, a particle is *marked* when
/// `δJ_p = |det F_p^{(r,n)} − 1| ≥ epsilon`, and the reference configuration is moved to the
/// current one when at least one particle is marked and the marked fraction is `≥ eta`.
/// `epsilon = ∞` never updates (TLMPM); `epsilon = 0, eta = 0` updates after every step
/// (updated-Lagrangian MPM on a re-built grid). The paper uses `epsilon = eta = 0.01`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReferenceUpdate {
    /// Volume-change threshold ε on `|J^{(r,n)} − 1|` (dimensionless, ≥ 0).
    pub epsilon: Real,
    /// Fraction η of marked particles that triggers an update (dimensionless, in [0, 1]).
    pub eta: Real,
}

impl<const D: usize> Default for TlmpmParams<D> {
    fn default() -> Self {
        Self {
            kernel: Kernel::Quadratic,
            transfer: Transfer::Apic,
            step: StepControl::default(),
            fixed: Vec::new(),
            contact: None,
            clamp_planes: Vec::new(),
            nodal_loads: Vec::new(),
            tractions: Vec::new(),
            reference_update: None,
        }
    }
}

/// When the per-particle elasticity tensor `∂P/∂F` (a `D² × D²` matrix) is projected onto the
/// positive semi-definite cone by clamping its negative eigenvalues to zero.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SpdProjection {
    /// Never: the exact (consistent) tangent; an indefinite system is an error.
    Never,
    /// Always: a positive definite tangent every iteration (linear convergence near the
    /// solution when the exact tensor is indefinite there).
    Always,
    /// Use the exact tangent, and redo an iteration with the projected one when the exact
    /// system is not positive definite (Cholesky meets a non-positive pivot, CG meets negative
    /// curvature, or the direction is not a descent direction). Keeps quadratic convergence
    /// where the exact tangent is SPD.
    #[default]
    OnFailure,
}

/// Backtracking line search on the incremental potential.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LineSearch {
    /// Maximum number of step halvings per Newton iteration.
    pub max_halvings: u32,
    /// Armijo sufficient-decrease constant `c` in `E(u + αd) ≤ E(u) + c α ∇E·d` (dimensionless).
    pub armijo: Real,
}

impl Default for LineSearch {
    fn default() -> Self {
        Self {
            max_halvings: 20,
            armijo: 1e-4,
        }
    }
}

/// Newton's method on the backward-Euler incremental potential.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NewtonParams {
    /// Maximum number of Newton iterations per step.
    pub max_iterations: u32,
    /// Absolute tolerance on the residual norm `‖∇E‖₂` (N).
    pub abs_tol: Real,
    /// Relative tolerance (dimensionless): a solve has converged once the residual
    /// `‖∇E‖₂ = ‖f_inertial − f_int − f_ext‖₂` is at most `abs_tol + rel_tol · f` with the force
    /// scale `f = max(‖f_inertial‖₂, ‖f_int‖₂, ‖f_ext‖₂)` of the same iterate: the forces are
    /// balanced to this fraction of the largest force that acts. (Measured against the
    /// forces, not the step's first residual, which a poor initial guess can make a million
    /// times the load.)
    pub rel_tol: Real,
    /// Round-off floor (dimensionless): the iteration also stops once `‖∇E‖₂` falls below this
    /// fraction of the rounding scale `‖Σ |force terms|‖₂` (inertia, external and internal
    /// forces summed in magnitude per node, the stiffness terms included), where the residual
    /// is dominated by rounding errors.
    pub roundoff: Real,
    /// Line search.
    pub line_search: LineSearch,
    /// Positive-definiteness treatment of the tangent.
    pub projection: SpdProjection,
    /// Chord iterations (Cholesky solver only): once an iteration has cut the residual by at
    /// least [`NewtonParams::CHORD_CONTRACTION`], the next direction reuses the factor of the
    /// last tangent (one triangular solve, no new tangent, assembly or factorisation), as long
    /// as each such iteration keeps that contraction; otherwise, or when its line search
    /// fails, a fresh tangent is factorised. The stopping test is the same, so the solution
    /// meets the same tolerance; convergence becomes linear where it was quadratic. `false`
    /// gives pure Newton.
    pub chord: bool,
    /// Single-precision factorisations (Cholesky solver only): a fresh tangent is factorised in
    /// f32 (about half the time of f64 in the 2D benchmark), its direction correct to about
    /// `κ · 6e-8`, which the iteration corrects like a chord step. After an iteration that
    /// fails [`NewtonParams::CHORD_CONTRACTION`], or when the f32 factorisation fails, the rest
    /// of the solve factorises in f64. The stopping test is the same. `false` keeps every
    /// factorisation in f64 (with `chord = false`: Newton's quadratic convergence).
    pub single_precision: bool,
}

impl NewtonParams {
    /// The residual ratio `‖∇E_{k+1}‖/‖∇E_k‖` an iteration must reach for the next one to be a
    /// chord iteration (dimensionless). A chord iteration costs about a sixth of a fresh one
    /// in the 2D benchmark (`benches/README.md`), so it pays while it gains a digit.
    pub const CHORD_CONTRACTION: Real = 0.1;
}

impl Default for NewtonParams {
    fn default() -> Self {
        Self {
            max_iterations: 30,
            abs_tol: 1e-10,
            rel_tol: 1e-8,
            roundoff: 1e-13,
            line_search: LineSearch::default(),
            projection: SpdProjection::OnFailure,
            chord: true,
            single_precision: true,
        }
    }
}

/// Linear solver for the Newton system `H d = −∇E`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "solver", rename_all = "snake_case")]
pub enum LinearSolver {
    /// Sparse Cholesky (faer): the symbolic analysis (fill-reducing ordering and elimination
    /// tree) is computed once from the fixed reference connectivity, the numeric factorisation
    /// every Newton iteration.
    #[default]
    Cholesky,
    /// Matrix-free conjugate gradients with a Jacobi preconditioner, started from zero.
    Cg {
        /// Iteration cap per Newton iteration.
        max_iterations: u32,
        /// Relative tolerance on the preconditioned-CG residual `‖H d + ∇E‖₂ / ‖∇E‖₂`
        /// (dimensionless).
        rel_tol: Real,
    },
}

impl LinearSolver {
    /// Default iteration cap of [`LinearSolver::Cg`] per Newton iteration.
    pub const CG_MAX_ITERATIONS: u32 = 1000;
    /// Default relative tolerance of [`LinearSolver::Cg`] (dimensionless).
    pub const CG_REL_TOL: Real = 1e-6;
}

/// Time integrator of the implicit solver; both are solved by Newton's method on an incremental
/// potential over the node displacements `u = x^{n+1} − x^n` (see the `implicit` module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TimeScheme {
    /// Backward Euler, first order: `M (v^{n+1} − v^n) = Δt f(x^{n+1})`, `u = Δt v^{n+1}`.
    /// Unconditionally stable, and it damps every mode with `ωΔt ≳ 1`.
    #[default]
    BackwardEuler,
    /// Newmark average acceleration (β = 1/4, γ = 1/2), second order and without numerical
    /// damping for linear problems: `u = Δt/2 (v^n + v^{n+1})`,
    /// `M (v^{n+1} − v^n) = Δt/2 (f(x^n) + f(x^{n+1}))`, with `M a^n = f(x^n)` evaluated from
    /// the start-of-step state instead of stored.
    Newmark,
}

impl TimeScheme {
    /// The name used in scene files and reports.
    pub fn name(self) -> &'static str {
        match self {
            TimeScheme::BackwardEuler => "backward_euler",
            TimeScheme::Newmark => "newmark",
        }
    }

    /// The coefficient `c/Δt²` (1/s²) of the incremental potential's inertia term
    /// `Σ_i c m_i/(2Δt²) ‖u_i − û_i‖²`: c = 1 for backward Euler, 4 for Newmark.
    pub fn inertia(self, dt: Real) -> Real {
        match self {
            TimeScheme::BackwardEuler => 1.0 / (dt * dt),
            TimeScheme::Newmark => 4.0 / (dt * dt),
        }
    }
}

/// Parameters of the implicit solver only.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ImplicitParams {
    /// Newton's method.
    pub newton: NewtonParams,
    /// Linear solver.
    pub linear: LinearSolver,
    /// Time integrator (backward Euler by default).
    pub scheme: TimeScheme,
}
