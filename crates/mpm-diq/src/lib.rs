//! DIQ-MPM (`diq-mpm` in docs/references.md, §4–5): the incompressible MPM fluid
//! ([`DiqFluid`]), the sparse SPD pressure-only system ([`pressure`]) and the coupling of the
//! fluid to mixed total-Lagrangian solids by dual interface quadrature ([`DiqCoupled`]).
//!
//! A fluid step: APIC P2G of mass and momentum to linear B-spline (B1) nodes; the predictor
//! `v* = v + Δt g` (and an implicit viscous solve for a viscous material); the projection onto
//! divergence-free velocities through one SPD system for the cell pressures (B0: one per cell
//! holding fluid, `p = 0` elsewhere, the free surface) and the free-slip wall and collider
//! pressures (one per wall node, which keeps the wall trace full rank); APIC G2P with the
//! positions clamped into the walls; and the volume-preserving position correction. The
//! design, its decisions (the `Q1–P0` pair, where the wall pressures live, the cell-centre
//! quadrature of `G^f`, the paper's misprints) and the measured evidence are in `docs/diq.md`;
//! the derivation of the coupled system in `docs/diq-coupling.md`.
//!
//! A column of water collapses for 0.1 s; the projection keeps it divergence-free and the
//! position correction keeps its volume:
//!
//! ```
//! use mpm_core::prelude::*;
//! use mpm_diq::{DiqFluid, DiqParams};
//!
//! let dx = 1.0 / 32.0;
//! let spec = GridSpec::<2>::covering(Vector::<2>::zeros(), Vector::<2>::new(1.0, 1.0), dx);
//! let materials = vec![Material::fluid(1000.0, 2e6, 0.0)];
//! let column = Body::new(Shape::cuboid([dx, dx], [0.3 + dx, 0.5 + dx]), 0);
//! let particles = ParticlesBuilder::new(&spec, &materials)
//!     .kernel(Kernel::Linear)
//!     .with(&column)
//!     .unwrap()
//!     .build();
//! let params = DiqParams::default();
//! let walls = Boundaries::slip_walls(1);
//! let mut water = DiqFluid::new(spec, params, materials, walls, particles).unwrap();
//! let volume = water.fluid_volume();
//! let run = water.run_until(0.1).unwrap();
//! assert!(run.steps > 0);
//! assert!((water.fluid_volume() / volume - 1.0).abs() < 1e-2);
//! // The front has started to run out along the floor.
//! let front = water.particles().x.iter().map(|x| x.x).fold(0.0, f64::max);
//! assert!(front > 0.3 + dx);
//! ```

pub mod coupled;
pub mod domain;
pub mod fluid;
pub mod parameters;
pub mod pressure;
pub mod settings;
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
pub mod stages;

/// The output fields DIQ computes beyond the particle columns and `pressure` (a scene may name
/// them in `output.fields`).
pub mod fields {
    /// Velocity divergence per particle after the projection (1/s): that of its cell.
    pub const DIVERGENCE: &str = "divergence";
    /// Every DIQ-only output field.
    pub const ALL: &[&str] = &[DIVERGENCE];
}
#[cfg(test)]
mod tests;
