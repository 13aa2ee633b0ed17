//! The explicit solver behind the solver seam ([`Solver`]), with checkpoint and restore: its
//! particles are its whole state.

use super::ExplicitSolver;
use mpm_core::solver::{DtBound, RestoreError, StageTime};
use mpm_core::{
    columns, on_pool, Diagnostics, Dim, DimOps, GridSpec, Material, Particles, Real, Region,
    Solver, SolverState, StagePlan, StepError, StepInfo,
};

/// The explicit solver behind the solver seam; its particles are its whole state.
impl<const D: usize> Solver<D> for ExplicitSolver<D>
where
    Dim<D>: DimOps<D>,
{
    fn name(&self) -> &'static str {
        "explicit MLS-MPM"
    }

    fn spec(&self) -> &GridSpec<D> {
        &self.spec
    }

    fn particles(&self) -> &Particles<D> {
        &self.particles
    }

    fn materials(&self) -> &[Material] {
        &self.materials
    }

    fn time(&self) -> Real {
        self.time
    }

    fn steps(&self) -> u64 {
        self.steps
    }

    fn stable_dt(&self) -> Real {
        ExplicitSolver::stable_dt(self)
    }

    fn dt_bound(&self) -> DtBound {
        DtBound {
            description: "min(dx / max(|v| + c), viscous limit)",
            limits_fixed_dt: true,
        }
    }

    fn diagnostics(&self) -> Diagnostics<D> {
        ExplicitSolver::diagnostics(self)
    }

    fn region(&self) -> Region<D> {
        Region {
            interior: mpm_core::sampling::interior(&self.spec, self.params.kernel),
            walls: self.boundaries.walls.map(|w| w.planes(&self.spec)),
        }
    }

    fn plan(&self) -> StagePlan {
        self.plan.clone()
    }

    /// Advances one step. On a failed guard check the step is retried with dt/2 when the policy
    /// allows it; otherwise an [`mpm_core::Instability`] names the step, stage, particle or
    /// node and value (this solver has no iterative solve that could fail). G2P writes the particles in
    /// place, so after a failed step under [`OnInstability::Abort`] they hold the failed step's
    /// partial result (time and the step count do not advance); under
    /// [`OnInstability::Retry`] the saved state is put back before each retry. The step runs on
    /// a thread of the rayon pool ([`on_pool`]).
    ///
    /// [`OnInstability::Abort`]: mpm_core::OnInstability::Abort
    /// [`OnInstability::Retry`]: mpm_core::OnInstability::Retry
    fn step(&mut self) -> Result<StepInfo, StepError> {
        on_pool(|| self.advance_step()).map_err(|e| match e {
            StepError::Instability(i) => StepError::Instability(i),
            StepError::Solve { source, .. } => match source {},
        })
    }

    fn stage_times(&self) -> Vec<StageTime> {
        self.stats.rows(&self.plan)
    }

    fn checkpoint(&self) -> SolverState {
        SolverState::of_particles(&self.particles, self.time, self.steps)
    }

    fn restore(&mut self, state: &SolverState) -> Result<(), RestoreError> {
        let particles =
            columns::particles_from_columns(&state.columns, &self.particles, self.materials.len())?;
        *self = self
            .with_particles(particles, state.time, state.steps)
            .map_err(|e| RestoreError(format!("does not fit this scene: {e}")))?;
        Ok(())
    }
}
