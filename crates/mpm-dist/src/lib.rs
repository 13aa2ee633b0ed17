//! One explicit MLS-MPM run on several processes, with results bitwise identical to one
//! process for any number of ranks.
//!
//! - [`partition`]: grid blocks along a Morton curve cut into ranges of equal particle count;
//! - [`comm`]: the transport ([`Comm`]), with an in-process implementation over threads;
//! - [`wire`]: what ranks send each other (particles with global ids, step outcomes);
//! - [`explicit`]: the driver ([`DistributedExplicit`]) and why its result is exact; it also
//!   implements `mpm_core::Solver` (collective diagnostics, the output field [`ID`]).
//!
//! With the `mpi` feature, `MpiComm` carries the same collectives over MPI (rsmpi); without
//! it nothing links an MPI library.

pub mod comm;
pub mod explicit;
#[cfg(feature = "mpi")]
mod mpi_comm;
pub mod partition;
mod seam;
pub mod wire;

pub use comm::{run_ranks, Comm, ThreadComm};
pub use explicit::{DistributedExplicit, Traffic};
#[cfg(feature = "mpi")]
pub use mpi_comm::{MpiComm, MpiSession};
pub use partition::Partition;
pub use seam::ID;
