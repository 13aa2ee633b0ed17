//! DIQ-MPM (`diq-mpm` in docs/references.md, §4–5): the incompressible MPM fluid
//! ([`DiqFluid`]), the sparse SPD pressure-only system ([`pressure`]) and the coupling of the
//! fluid to mixed total-Lagrangian solids by dual interface quadrature ([`DiqCoupled`], see
//! [`coupled`] for the derivation of Eq. 35 and what is measured of it).
//!
//! # The fluid step (§5.1, fluid stages)
//!
//! 1. **P2G.** APIC transfer of mass and momentum to the nodes of linear B-splines (B1): the
//!    lumped mass `M^f_c = Σ_p m_p w_c(x_p)` (Eq. 30 by particle quadrature) and
//!    `(M v)_c = Σ_p w_c(x_p) m_p (v_p + C_p (x_c − x_p))`.
//! 2. **Predictor.** `v* = v + Δt g` (gravity is the only body force; the fluid is inviscid).
//! 3. **Pressure projection.** Pressures are constant per cell (B0): one fluid pressure `p` per
//!    cell holding fluid particles, and one boundary pressure `y` per fluid cell holding wall or
//!    collider quadrature points. `G^f_{cα,i} = −Σ_{p in cell i} V_p ∂_α w_c(x_p)` (Eq. 30 by
//!    particle quadrature), `B_{cα,i} = Σ_q A_q w_c(x_q) n_α` over boundary points `q` in cell
//!    `i`. The pressure-only system is the fluid block of Eq. 35, built and solved by
//!    [`pressure::PressureSystem`]; velocities are recovered from the momentum equation
//!    `v = v* − Δt M⁻¹ (G^f p + Bᵀ y)`.
//! 4. **G2P.** `v_p = Σ w_c v_c`, `C_p = Σ v_c ∇w_cᵀ` (for linear B-splines the APIC affine
//!    matrix is the velocity gradient, as `D_p` is not constant), `x_p += Δt v_p`; positions are
//!    then clamped into the wall box and out of colliders.
//! 5. **Position correction** (optional, on by default): see
//!    [`fluid::DiqFluid`]'s `correct_positions`. Where the grid volume fraction of a cell exceeds
//!    one, the same SPD operator with the density error as right-hand side gives the
//!    least-squares displacement that restores it (Kugelstadt et al. 2019's implicit density
//!    projection, on the MPM grid), and particles move by it.
//!
//! # Boundary conditions
//!
//! - **Free surface.** A cell holds a pressure unknown only if it holds a fluid particle;
//!   elsewhere `p = 0`. The boundary integral of the weak form (Eq. 22 integrated by parts)
//!   vanishes there because `p = 0`, and the velocity of nodes shared with empty cells is
//!   constrained only by the fluid cells around it. Tested: the pressure of a column at rest
//!   falls to zero at the surface cell, and a fluid without any empty neighbour cell is
//!   detected as enclosed (its pressure is then determined up to a constant, which is pinned).
//! - **Walls and colliders: free slip, `v·n = v_b·n`** (Eq. 25), enforced weakly through the
//!   boundary pressure `y` (Eq. 26's fifth row). Domain walls are the planes through node layer
//!   `thickness` of each face, with two Gauss–Legendre points per cell edge per tangential axis;
//!   collider surfaces are sampled per fluid cell (see [`domain::Domain::collider_points`]). The
//!   constraint is bilateral, as in the paper.
//! - **`G^f` quadrature.** See [`fluid::GradientQuadrature`]: the default integrates each cell's
//!   fluid volume at the cell centre, because the paper's particle quadrature makes a fluid at
//!   rest unstable (measured there).
//! - **Where `y` lives.** The boundary pressure is constant on the piece of boundary around
//!   each node (the node-centred B0 box, one `y` per wall node with mass and per wall face or
//!   collider), not per cell. With one `y` per *cell* face, `B` has one row fewer than the
//!   normal velocities of the wall's B1 trace, and the zigzag `v·n = +u, −u, +u, …` along a wall
//!   satisfies `B v = 0`: gravity then pumps velocity into that mode at the corners (a column at
//!   rest gained 1 m/s within a second in our test). With node-centred `y`, `B` restricted to the
//!   wall trace is a positive diagonally dominant (mass-like) matrix, so `B v = 0` forces
//!   `v·n = 0` at every wall node, and the column stays at rest.
//!
//! # Why the B1B0 pair
//!
//! Velocity on multilinear nodes and pressure constant per cell is the `Q1–P0` pair. Its
//! discrete inf-sup condition (Brezzi–Babuška) `inf_p sup_v (pᵀ G^fᵀ v)/(‖p‖ ‖v‖_M) ≥ β > 0`
//! holds on every fixed grid as soon as `G^f` has full column rank, which is the case when the
//! fluid touches a free surface or the pressure level is pinned: then `A22 + …` is SPD and the
//! pressure is unique. `Q1–P0` is not *uniformly* stable: `β` decreases like `Δx` and, in a
//! closed box, checkerboard modes are nearly in the kernel of `G^f`. The paper (following
//! IQ-MPM) uses the pair because it gives the sparsest system (each pressure couples only with
//! the `3^D` cells sharing a node) and because the velocity projection, which is what moves the
//! fluid, does not depend on `β`: the divergence constraint is met to the solver tolerance in
//! any case (tested). What `β` controls is pressure noise. The tests check that the assembled
//! system with a free surface is definite (its smallest eigenvalue is positive, so `J` has full
//! row rank) and measure the hydrostatic pressure error; the discrete inf-sup constant itself is
//! not measured.
//!
//! # Misprints in the paper, and the choices made
//!
//! - Eq. 35 writes `A11 = S^s/Δt + Δt G^{fT} M^{s−1} G^s`; the solid block must use the solid
//!   gradient on both sides, `Δt G^{sT} M^{s−1} G^s` (the Schur complement of Eq. 26's first
//!   two rows). [`coupled`] implements that and a test checks the assembled matrix against
//!   the dense `Δt J M⁻¹ Jᵀ + C`.
//! - Eq. 30's `G^f` carries the minus sign of the integration by parts, so the momentum row of
//!   Eq. 26 reads `M v/Δt + G p + Bᵀ y = M v*/Δt`, and the recovered velocity is
//!   `v* − Δt M⁻¹(G p + Bᵀ y)` as implemented.
//! - Eq. 23 writes the fluid test function `t^s`; it is the fluid pressure's test function
//!   `t^f`.

pub mod coupled;
pub mod domain;
pub mod fluid;
pub mod pressure;
pub mod viscosity;

pub use coupled::{
    CoupledError, CouplingIteration, DiqCoupled, InterfacePoints, InterfaceQuadrature, SolidParams,
};
pub use domain::{Domain, WallPoint, WallSample};
pub use fluid::{DiqFluid, DiqParams, GradientQuadrature};
pub use pressure::{
    Constraints, PressureError, PressureInfo, PressureMethod, PressureParams, PressureSystem,
    UnknownKind,
};

#[cfg(test)]
mod coupled_tests;
#[cfg(test)]
mod tests;
