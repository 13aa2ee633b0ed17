//! Core types of the `mpm` workspace: maths, interpolation kernels, grids, particles,
//! constitutive models, plasticity, boundaries, sampling, time-step control, guard checks and
//! diagnostics, and the solvers' shared building blocks: the deterministic block scatter
//! (`scatter`) and the cell-list neighbour search (`neighbors`). Solvers (`mpm-explicit`,
//! `mpm-tlmpm`, `mpm-diq`) build on these.
//!
//! Units are SI throughout (m, s, kg, Pa); in 2D "volume" means area (m²) and densities are per
//! unit area (kg/m²).

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
pub mod particles;
pub mod prefetch;
pub mod prelude;
pub mod quasistatic;
pub mod sampling;
pub mod scatter;
pub mod solver;

pub use error::{Instability, Location, SetupError, Stage, Violation};
pub use grid::{GridNodes, GridSpec, NodeLayout, StencilRange};
pub use kernel::{AxisStencil, Kernel, Stencil};
pub use material::Material;
pub use math::{Angular, Dim, DimOps, Matrix, Real, Vector};
pub use particles::{Columns, ParticleExtra, ParticleInit, Particles};
pub use sampling::{Body, ParticlesBuilder, Sampling, Shape};
pub mod diagnostics;
pub mod timestep;
pub mod volume;

#[cfg(test)]
mod test_util;

pub use columns::{Column, ColumnData};
pub use diagnostics::Diagnostics;
pub use solver::{
    on_pool, reached, retry_halving, run_until_with, Failure, Monitor, PlannedStage, RunInfo,
    SolveInfo, Solver, SolverState, StagePlan, StageTimes, StepError, StepInfo, StepStart,
};
pub use timestep::{OnInstability, TimeStepPolicy};
