//! Explicit MLS-MPM (Hu et al. 2018) as used by the multi-grid coupling paper §3.1: P2G with the
//! fused MLS stress term, grid update with gravity and boundaries, G2P with APIC (default), PIC or
//! FLIP blending, plasticity return mapping and fluid J update, then advection.
//!
//! A step is a short list of named stages (see [`mpm_core::Solver::step`]): sort → (volume
//! re-estimation) → P2G → grid update → G2P with guard checks → commit. P2G is parallel and
//! deterministic: results are bitwise identical for any number of rayon threads.
//!
//! With several phases (multigrid paper §4, see [`multigrid`]) every phase scatters to its own
//! grid and a coupling stage (drag, contact, buoyancy penalty) runs between the grid update and
//! the boundaries; optional stages diffuse concentrations (miscible mixing) and update φ_eff and
//! dissolution progress. A single-phase scene runs none of them.
//!
//! A jelly block dropped on the floor of a box, stepped 0.1 s through the [`mpm_core::Solver`]
//! interface:
//!
//! ```
//! use mpm_core::prelude::*;
//! use mpm_explicit::{ExplicitParams, ExplicitSolver};
//!
//! let spec = GridSpec::<2>::covering(Vector::<2>::zeros(), Vector::<2>::new(1.0, 1.0), 1.0 / 32.0);
//! let materials = vec![Material::neo_hookean(1000.0, 1e5, 0.3)];
//! let block = Body::new(Shape::cuboid([0.3, 0.3], [0.5, 0.5]), 0);
//! let particles = ParticlesBuilder::new(&spec, &materials).with(&block).unwrap().build();
//! let step = StepControl { gravity: Vector::<2>::new(0.0, -9.81), ..Default::default() };
//! let params = ExplicitParams { step, ..Default::default() };
//! let mut solver =
//!     ExplicitSolver::new(spec, params, materials, Boundaries::slip_walls(3), particles).unwrap();
//! let mass = solver.diagnostics().mass;
//! let run = solver.run_until(0.1).unwrap();
//! assert!(run.steps > 10 && solver.time() >= 0.1 - 1e-12);
//! // 0.1 s of free fall (the block is 0.3 m above the floor): it falls at g t = 0.98 m/s.
//! let d = solver.diagnostics();
//! assert!((d.momentum.y / d.mass + 0.981).abs() < 0.02);
//! assert_eq!(d.mass, mass);
//! ```

mod advice;
mod blocks;
mod coupling;
mod g2p;
mod grid_update;
mod materials;
mod mixing;
pub mod multigrid;
mod p2g;
pub mod parameters;
mod params;
mod plan;
pub mod settings;
mod solver;
pub mod stages;
mod validate;

pub use advice::{too_compressible, TooCompressible};
pub use multigrid::{
    Activation, BuoyancyPenalty, ContactCoupling, Coupling, CouplingKind, DiffusionScheme,
    Dissolution, Drag, EffectiveFraction, Friction, Mixing, Phases, Porous, PressureBuoyancy,
};
pub use p2g::kirchhoff;
pub use params::{BodyForce, ExplicitParams, SoftWalls, Transfer, VolumeUpdate};
#[cfg(feature = "bench")]
pub use solver::PreparedG2p;
pub use solver::{ExplicitSolver, ScratchBytes};
