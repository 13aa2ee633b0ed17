//! Total-Lagrangian MPM (TLMPM, diq-mpm §3): implicit (backward Euler or Newmark average
//! acceleration, [`TimeScheme`]; Newton) and explicit (symplectic Euler) solvers whose grid is the
//! *reference* configuration.
//!
//! All stresses, forces and time integration are computed on the initial grid, so particles
//! never cross cells: the B-spline weights `W_i(X_p)` and reference gradients `∇^X W_i(X_p)` are
//! computed once ([`ReferenceConfig`]), together with the node masses, the node–particle
//! connectivity, the sparsity pattern of the Newton matrix and its symbolic Cholesky
//! factorisation (`mpm_linalg::SparseCholesky`).
//!
//! The internal force is Eq. 3, `f_i = −Σ_p V⁰_p P(F_p) ∇^X W_i(X_p)`. The deformation gradient
//! is updated in incremental form, `F_p^{n+1} = F_p^n + Σ_i u_i ⊗ ∇^X W_i(X_p)` with the node
//! displacements `u_i = Δt v_i^{n+1}` (diq-mpm §5.1 step 5). The particles then carry the whole
//! state (x, v, F, `C = ∇^X V`) and the grid is scratch rebuilt by P2G every step, which keeps
//! checkpoints to particle columns, lets contact forces (Eq. 4) enter as nodal forces, and leaves
//! room for A-ULMPM reference updates (§5.4), which reset `X` and restart `F` from the new
//! reference. Since `F_p` is affine in `u`, the backward-Euler incremental potential
//!
//! `E(u) = Σ_i m_i/(2Δt²) ‖u_i − Δt v̂_i‖² + Σ_p V⁰_p ψ(F_p(u)) − Σ_i f^ext_i · u_i`
//!
//! (the brief's `E(x)` with `x_i = x_i^n + u_i`; Newmark changes only the inertia coefficient and
//! the prediction, see the `implicit` module) has an exact, consistent Hessian built from
//! mpm-core's `dP(F)[δF]`; Newton's method ([`NewtonParams`]) minimises it with a capped
//! backtracking line search and either a sparse Cholesky or a Jacobi-preconditioned CG solve
//! ([`LinearSolver`]), both from mpm-linalg.
//!
//! A step is a short list of named stages, each timed in [`mpm_core::StageTimes`]:
//! momentum to the reference grid (P2G) → external forces → contact → grid solve (Newton, or the
//! explicit update) → G2P with the F update, plastic return mapping and guard checks → commit →
//! reference update. Every parallel loop writes per-particle or per-node results and every sum
//! runs in a fixed order, so results are bitwise identical for any number of rayon threads.
//!
//! **Contact** ([`ContactParams`], optional). The per-particle penalty forces of Eq. 4 are
//! evaluated from the positions at the start of the step, `f^c_p = f^c(x^n)`, and enter as
//! external nodal forces through the reference weights, `f^c_i = Σ_p W_i(X_p) f^c_p` (§3.2). In
//! the implicit solver they are therefore *explicit*: a constant term `−f^c · u` of the
//! incremental potential, with no contribution to the tangent, so the Newton matrix, its
//! sparsity pattern and its symbolic factorisation stay those of the elastic problem. The
//! consequence: contact is detected one step late (a pair approaching at `v_rel` overlaps by up
//! to `v_rel Δt` before it is pushed back, so `v_rel Δt` must stay well below `r_p + r_q`), and
//! backward Euler's unconditional stability does not extend to contact. The penalty stiffness
//! `μ_pq/Δt²` of Eq. 4 gives `ω Δt = 1` per contact, inside the symplectic-Euler bound of 2 for
//! any Δt, so contact does not bound the step; energy is not guaranteed to decrease through a
//! collision, and in practice the transfers dissipate part of it (APIC, PIC and FLIP;
//! [`Transfer::Persistent`] keeps node velocities and little is lost). The diagnostics count
//! the springs' potential `½ μ_pq δ²/Δt²` in the energy.
//!
//! **A-ULMPM** ([`ReferenceUpdate`], optional; §5.4). After an accepted step, when enough
//! particles changed volume since the reference configuration, the reference moves to the current
//! positions and everything cached is rebuilt; plastic solids (snow, sand) are supported in this
//! mode. See the `adaptive` module for the two deformation gradients and how the incremental F
//! update composes with the plastic return mapping and the reference update.
//!
//! Units are SI (m, s, kg, Pa); in 2D volumes are areas (m²) and densities kg/m².
//!
//! A beam clamped at one end sags under its own weight; implicit steps of 10 ms, far above the
//! elastic wave bound, through the [`mpm_core::Solver`] interface:
//!
//! ```
//! use mpm_core::prelude::*;
//! use mpm_tlmpm::{FixedRegion, ImplicitParams, ImplicitTlmpm, TlmpmParams};
//!
//! let spec = GridSpec::<2>::covering(Vector::<2>::new(-0.1, -0.3), Vector::<2>::new(1.2, 0.4), 0.05);
//! let materials = vec![Material::neo_hookean(1000.0, 1e8, 0.3)];
//! let beam = Body::new(Shape::cuboid([0.0, 0.0], [1.0, 0.1]), 0);
//! let particles = ParticlesBuilder::new(&spec, &materials).with(&beam).unwrap().build();
//! let params = TlmpmParams {
//!     step: StepControl {
//!         gravity: Vector::<2>::new(0.0, -9.81),
//!         time_step: TimeStepPolicy::Fixed { dt: 0.01 },
//!         ..StepControl::default()
//!     },
//!     fixed: vec![FixedRegion::clamp(Vector::<2>::new(-1.0, -1.0), Vector::<2>::new(0.0, 1.0))],
//!     ..TlmpmParams::default()
//! };
//! let tip = particles.x.iter().enumerate().max_by(|a, b| a.1.x.total_cmp(&b.1.x)).unwrap().0;
//! let y0 = particles.x[tip].y;
//! let mut beam = ImplicitTlmpm::new(spec, params, ImplicitParams::default(), materials, particles)
//!     .unwrap();
//! let info = beam.step().unwrap();
//! assert_eq!(info.solves[0].name, "newton");
//! beam.run_until(0.2).unwrap();
//! // The tip sags by centimetres (the static Euler–Bernoulli sag is 3ρgL⁴/(2Eh²) = 1.5 cm,
//! // and the beam swings about it); the clamp holds the root.
//! let sag = y0 - beam.particles().x[tip].y;
//! assert!(sag > 0.002 && sag < 0.04, "{sag}");
//! assert!(beam.particles().x.iter().all(|x| x.x > -1e-3));
//! ```

mod adaptive;
mod assembly;
mod contact;
mod core;
mod error;
mod explicit;
mod implicit;
mod loads;
mod newton;
pub mod parameters;
mod params;
mod potential;
mod reference;
pub mod settings;
pub mod stages;
mod transfer;

pub use crate::core::{build, NewtonTimes, TlmpmState, TotalLagrangian};
pub use contact::{
    ContactInput, ContactRadius, ContactStats, Obstacle, ParticleContact, CONTACT_ENERGY,
};
pub use error::{NewtonError, StepError};
pub use explicit::ExplicitTlmpm;
pub use implicit::{ImplicitTlmpm, Predicted, Projected, Transferred};
pub use loads::{EmptyLoad, NodalLoad, NodeSelection, ParticleLoad, SurfaceTraction};
pub use mpm_linalg::CholeskyError;
pub use newton::{fitted_order, NewtonInfo};
pub use params::{
    ClampPlane, ContactParams, FixedRegion, ImplicitParams, LineSearch, LinearSolver, NewtonParams,
    ReferenceUpdate, SpdProjection, TimeScheme, TlmpmParams, Transfer,
};
pub use reference::ReferenceConfig;
