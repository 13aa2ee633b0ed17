//! The names a program that sets up and runs a simulation needs most, for `use
//! mpm_core::prelude::*;`: the [`Solver`] interface (its `step` and `run_until`), bodies and
//! the particle builder, grids, materials, boundaries, step control (gravity, time-step
//! policy, reaction to instability) and step results.

pub use crate::boundary::{Boundaries, Collider, ColliderShape, Contact, ContactKind, DomainWalls};
pub use crate::diagnostics::Diagnostics;
pub use crate::grid::GridSpec;
pub use crate::kernel::Kernel;
pub use crate::material::Material;
pub use crate::math::{Angular, Matrix, Real, Vector};
pub use crate::particles::{Columns, ParticleExtra, Particles};
pub use crate::sampling::{Body, BodyError, ParticlesBuilder, Sampling, Shape};
pub use crate::solver::{RunInfo, Solver, StepError, StepInfo};
pub use crate::step_control::StepControl;
pub use crate::timestep::{OnInstability, TimeStepPolicy};
