//! The [`Solver`] implementation of [`Ballistic`]: the step as named stages, checkpoint and
//! restore (with the dissipated energy), the dissipated energy term and the `speed` field.

use crate::{bounds, fly, stages, Ballistic, DISSIPATED_ENERGY};
use mpm_core::columns::{self, Column};
use mpm_core::solver::{DtBound, FieldInfo, RestoreError, StageTime};
use mpm_core::{
    Diagnostics, Dim, DimOps, GridSpec, Instability, Location, Material, Particles, Real, Solver,
    SolverState, Stage, StagePlan, StepError, StepInfo, TimeStepPolicy, Violation,
};

/// The checkpoint attribute holding the dissipated energy (J).
const DISSIPATED_ATTR: &str = "ballistic_dissipated";

impl<const D: usize> Ballistic<D>
where
    Dim<D>: DimOps<D>,
{
    /// The step (s) the policy gives at the current state.
    fn time_step(&self) -> Real {
        match self.params.step.time_step {
            TimeStepPolicy::Fixed { dt } => dt,
            TimeStepPolicy::Adaptive { cfl, dt_max, .. } => (cfl * self.stable_dt()).min(dt_max),
        }
    }

    /// Flies every particle for `dt` (s), in particle order; returns the energy (J) dissipated.
    fn flight(&mut self, dt: Real) -> Real {
        let (lo, hi) = bounds(&self.spec);
        let (g, e) = (self.params.step.gravity, self.params.restitution);
        let p = &mut self.particles;
        let mut lost = 0.0;
        for i in 0..p.len() {
            for a in 0..D {
                let walls = (g[a], lo[a], hi[a], e);
                lost += fly(&mut p.x[i][a], &mut p.v[i][a], walls, p.mass[i], dt);
            }
        }
        lost
    }

    /// The first particle whose position is not finite, as an instability of step `dt`.
    fn guard(&self, dt: Real) -> Result<(), Instability> {
        let bad = self.particles.x.iter().enumerate();
        match bad
            .flat_map(|(i, x)| x.iter().map(move |&c| (i, c)))
            .find(|(_, c)| !c.is_finite())
        {
            None => Ok(()),
            Some((p, value)) => Err(Instability {
                step: self.steps,
                time: self.time,
                dt,
                stage: stages::FLIGHT,
                location: Location::Particle(p),
                violation: Violation::NonFinite("position"),
                value,
                retries: 0,
            }),
        }
    }
}

impl<const D: usize> Solver<D> for Ballistic<D>
where
    Dim<D>: DimOps<D>,
{
    fn name(&self) -> &'static str {
        "ballistic particles"
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

    /// `Δx / max_p |v_p|`: the time in which the fastest particle crosses one cell (the flight
    /// is exact for any step; the bound only keeps the output smooth).
    fn stable_dt(&self) -> Real {
        let vmax = self
            .particles
            .v
            .iter()
            .map(|v| v.norm())
            .fold(0.0, Real::max);
        self.spec.dx / vmax.max(Real::MIN_POSITIVE)
    }

    fn region(&self) -> mpm_core::Region<D> {
        let walls = crate::bounds(&self.spec);
        mpm_core::Region {
            interior: walls,
            walls: Some(walls),
        }
    }

    fn dt_bound(&self) -> DtBound {
        DtBound {
            description: "dx / max |v|",
            limits_fixed_dt: false,
        }
    }

    fn diagnostics(&self) -> Diagnostics<D> {
        Diagnostics::compute(
            &self.particles,
            &self.materials,
            None,
            &self.params.step.gravity,
        )
        .with_energy(DISSIPATED_ENERGY, self.dissipated)
    }

    fn plan(&self) -> StagePlan {
        self.plan.clone()
    }

    fn step(&mut self) -> Result<StepInfo, StepError> {
        let mut times = std::mem::take(&mut self.times);
        let dt = times.time(Stage::TIME_STEP, || self.time_step());
        let lost = times.time(stages::FLIGHT, || self.flight(dt));
        self.times = times;
        self.guard(dt)?;
        self.dissipated += lost;
        self.time += dt;
        self.steps += 1;
        Ok(StepInfo {
            dt,
            retries: 0,
            time: self.time,
            solves: Vec::new(),
            events: Vec::new(),
            residual_histories: Vec::new(),
        })
    }

    fn stage_times(&self) -> Vec<StageTime> {
        self.times.rows(&self.plan)
    }

    fn checkpoint(&self) -> SolverState {
        let mut state = SolverState::of_particles(&self.particles, self.time, self.steps);
        state
            .attrs
            .push((DISSIPATED_ATTR.to_string(), self.dissipated));
        state
    }

    fn restore(&mut self, state: &SolverState) -> Result<(), RestoreError> {
        let particles =
            columns::particles_from_columns(&state.columns, &self.particles, self.materials.len())?;
        let dissipated = state.attr(DISSIPATED_ATTR).ok_or_else(|| {
            RestoreError(format!("checkpoint has no attribute `{DISSIPATED_ATTR}`"))
        })?;
        self.particles = particles;
        self.dissipated = dissipated;
        self.time = state.time;
        self.steps = state.steps;
        Ok(())
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
            name: crate::fields::SPEED,
            unit: "m/s",
            components: 1,
            derived: true,
        });
        fields
    }

    fn output(&self, name: &str) -> Vec<Column> {
        match name {
            crate::fields::SPEED => {
                let speed: Vec<Real> = self.particles.v.iter().map(|v| v.norm()).collect();
                vec![Column::scalars(crate::fields::SPEED, "m/s", &speed)]
            }
            "pressure" => vec![Column::scalars("pressure", "Pa", &self.pressure())],
            _ => columns::particle_column(&self.particles, name),
        }
    }
}
