//! Core types of the `mpm` workspace: maths, interpolation kernels, grids, particles,
//! constitutive models, plasticity, boundaries, sampling, time-step control, guard checks and
//! diagnostics, and the solvers' shared building blocks: the deterministic block scatter
//! (`scatter`) and the cell-list neighbour search (`neighbors`). Solvers (`mpm-explicit`,
//! `mpm-tlmpm`, `mpm-diq`) build on these.
//!
//! Units are SI throughout (m, s, kg, Pa); in 2D "volume" means area (m²) and densities are per
//! unit area (kg/m²).
//!
//! A program sets up a scene through this crate and hands it to a solver crate: bodies sampled
//! into particles by [`ParticlesBuilder`], a grid, materials and boundaries; every solver then
//! runs behind the one [`Solver`] interface (`step`, `run_until`, diagnostics, checkpoints).
//! `use mpm_core::prelude::*;` brings the names in.
//!
//! ```
//! use mpm_core::prelude::*;
//!
//! // A 0.2 m disk of jelly in a 1 m × 1 m grid of 5 cm cells, 2 × 2 particles per cell.
//! let spec = GridSpec::<2>::covering(Vector::<2>::zeros(), Vector::<2>::new(1.0, 1.0), 0.05);
//! let materials = [Material::neo_hookean(1000.0, 1e5, 0.3)];
//! let disk = Body::new(Shape::Sphere { center: Vector::<2>::new(0.5, 0.5), radius: 0.2 }, 0)
//!     .velocity(Vector::<2>::new(1.0, 0.0));
//! let particles = ParticlesBuilder::new(&spec, &materials).with(&disk).unwrap().build();
//! // The lattice resolves the disk's area π r² to within a particle spacing around it.
//! let area: f64 = particles.volume0.iter().sum();
//! assert!((area - std::f64::consts::PI * 0.04).abs() < 0.025 * 2.0 * std::f64::consts::PI * 0.2);
//! assert!(particles.v.iter().all(|v| v.x == 1.0));
//! ```

pub mod boundary;
pub mod columns;
pub mod error;
pub mod geostatic;
pub mod grid;
pub mod kernel;
pub mod material;
pub mod math;
pub mod mirror;
pub mod neighbors;
pub mod parameters;
pub mod particles;
pub mod peers;
pub mod prefetch;
pub mod prelude;
pub mod quasistatic;
pub mod sampling;
pub mod scatter;
pub mod solver;
pub mod step_control;

pub use error::{Instability, Location, Parameter, SetupError, Stage, Violation};
pub use grid::{GridNodes, GridSpec, NodeLayout, StencilRange};
pub use kernel::{AxisStencil, Kernel, Stencil};
pub use material::Material;
pub use math::{Angular, Dim, DimOps, Matrix, Real, Vector};
pub use particles::{Columns, ParticleExtra, ParticleInit, Particles};
pub use peers::{Alone, Peers};
pub use sampling::{Body, ParticlesBuilder, Sampling, Shape};
pub mod diagnostics;
pub mod timestep;
pub mod volume;

#[cfg(test)]
mod test_util;

pub use columns::{Column, ColumnData};
pub use diagnostics::Diagnostics;
pub use solver::{
    on_pool, reached, retry_halving, run_until_with, Failure, Monitor, PlannedStage, Region,
    RunInfo, SolveInfo, Solver, SolverState, StagePlan, StageTimes, StepError, StepInfo, StepStart,
};
pub use step_control::StepControl;
pub use timestep::{OnInstability, TimeStepPolicy};
