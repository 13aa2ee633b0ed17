//! The [`Solver`] implementation of [`DiqFluid`]: the step on the rayon pool, checkpoint and
//! restore (with the per-particle pressure and divergence), monitors and output fields.

use super::DiqFluid;
use mpm_core::columns::{self, Column};
use mpm_core::solver::{on_pool, DtBound, FieldInfo, RestoreError, StageTime};
use mpm_core::{
    Diagnostics, Dim, DimOps, GridSpec, Material, Monitor, Particles, Real, Region, Solver,
    SolverState, StagePlan, StepError, StepInfo,
};

impl<const D: usize> Solver<D> for DiqFluid<D>
where
    Dim<D>: DimOps<D>,
{
    fn name(&self) -> &'static str {
        "DIQ-MPM incompressible fluid"
    }

    fn spec(&self) -> &GridSpec<D> {
        &self.domain.spec
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
        self.displacement_dt(self.cfl())
    }

    fn dt_bound(&self) -> DtBound {
        crate::fluid::displacement_bound_doc()
    }

    fn region(&self) -> Region<D> {
        self.domain.region()
    }

    fn diagnostics(&self) -> Diagnostics<D> {
        Diagnostics::compute(
            &self.particles,
            &self.materials,
            None,
            &self.params.step.gravity,
        )
    }

    fn plan(&self) -> StagePlan {
        self.plan.clone()
    }

    /// Advances one step; a failed pressure solve is a [`StepError::Solve`] with the
    /// [`PressureError`](crate::pressure::PressureError)'s message. The step runs on a thread of
    /// the rayon pool ([`on_pool`]).
    fn step(&mut self) -> Result<StepInfo, StepError> {
        on_pool(|| self.advance_step()).map_err(|e| e.erase("pressure"))
    }

    fn stage_times(&self) -> Vec<StageTime> {
        self.times.rows(&self.plan)
    }

    fn checkpoint(&self) -> SolverState {
        let mut state = SolverState::of_particles(&self.particles, self.time, self.steps);
        state
            .columns
            .push(Column::scalars("diq_pressure", "Pa", &self.pressure));
        state
            .columns
            .push(Column::scalars("diq_divergence", "1/s", &self.divergence));
        state
    }

    fn restore(&mut self, state: &SolverState) -> Result<(), RestoreError> {
        let particles =
            columns::particles_from_columns(&state.columns, &self.particles, self.materials.len())?;
        let n = particles.len();
        let scalar = |name: &str| -> Result<Vec<Real>, RestoreError> {
            columns::f64_values(&state.columns, name, &[n])?
                .map(<[Real]>::to_vec)
                .ok_or_else(|| RestoreError(format!("checkpoint has no field `{name}`")))
        };
        let (pressure, divergence) = (scalar("diq_pressure")?, scalar("diq_divergence")?);
        let mut s = Self::at_time(
            self.domain.spec,
            self.params.clone(),
            self.materials.clone(),
            self.boundaries.clone(),
            particles,
            state.time,
        )
        .map_err(|e| RestoreError(format!("does not fit this scene: {e}")))?;
        s.time = state.time;
        s.steps = state.steps;
        s.pressure = pressure;
        s.divergence = divergence;
        *self = s;
        Ok(())
    }

    fn monitors(&self) -> Vec<Monitor> {
        vec![Monitor {
            name: "fluid_volume",
            unit: if D == 2 { "m^2" } else { "m^3" },
            value: self.fluid_volume(),
        }]
    }

    fn output_fields(&self) -> Vec<FieldInfo> {
        let mut fields =
            mpm_core::solver::particle_field_infos::<D>(&self.particles.columns().names());
        fields.push(FieldInfo {
            name: "pressure",
            unit: "Pa",
            components: 1,
            derived: true,
        });
        fields.push(FieldInfo {
            name: crate::fields::DIVERGENCE,
            unit: "1/s",
            components: 1,
            derived: true,
        });
        fields
    }

    fn pressure(&self) -> Vec<Real> {
        self.pressure.clone()
    }

    fn output(&self, name: &str) -> Vec<Column> {
        match name {
            "pressure" => vec![Column::scalars("pressure", "Pa", &self.pressure)],
            crate::fields::DIVERGENCE => vec![Column::scalars(
                crate::fields::DIVERGENCE,
                "1/s",
                &self.divergence,
            )],
            _ => columns::particle_column(&self.particles, name),
        }
    }
}
