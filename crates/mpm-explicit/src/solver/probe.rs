//! Benchmark-only entry points (cargo feature `bench`): the stages of a step before G2P, and a
//! handle that runs G2P alone, so that a benchmark can time G2P without the rest of the step.

use super::ExplicitSolver;
use mpm_core::solver::{Failure, StepStart};
use mpm_core::{Dim, DimOps, Location, Real, Stage, StepError, Violation};
use std::convert::Infallible;

impl<const D: usize> ExplicitSolver<D>
where
    Dim<D>: DimOps<D>,
{
    /// Runs every stage before G2P for a step of `dt` (s) and returns a handle whose
    /// [`PreparedG2p::run`] performs G2P and the commit: for benchmarks that time G2P alone.
    pub fn prepare_g2p(&mut self, dt: Real) -> Result<PreparedG2p<'_, D>, StepError<Infallible>> {
        let start = StepStart {
            step: self.steps,
            time: self.time,
        };
        self.transfer_to_grid(dt);
        self.update_grid(dt)
            .map_err(|e| start.error(Failure::Guard(Stage::GRID_UPDATE, e), dt, 0))?;
        if self.multigrid() {
            self.couple_phases(dt)
                .map_err(|e| start.error(Failure::Guard(crate::stages::COUPLING, e), dt, 0))?;
        }
        Ok(PreparedG2p { solver: self, dt })
    }
}

/// A solver with every stage before G2P done for one step (see
/// [`ExplicitSolver::prepare_g2p`]).
pub struct PreparedG2p<'a, const D: usize> {
    solver: &'a mut ExplicitSolver<D>,
    dt: Real,
}

impl<const D: usize> PreparedG2p<'_, D>
where
    Dim<D>: DimOps<D>,
{
    /// G2P in place with its guard checks, then the multi-grid state; when a check fails the
    /// particles hold the partial result. Time and the step count do not advance.
    pub fn run(self) -> Result<(), (Location, Violation, Real)> {
        self.solver.signal = None;
        let all = self.solver.particles.len();
        self.solver.grid_to_particle(self.dt, all)?;
        if self.solver.has_extra_state() {
            self.solver.commit_extra();
        }
        Ok(())
    }
}
