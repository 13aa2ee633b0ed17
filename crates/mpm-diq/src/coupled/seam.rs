//! The coupled solver behind the solver seam: step, checkpoint and restore (the solids'
//! reference configuration and A-ULMPM columns, the pressures), outputs and monitors.

use super::params::{
    ATTR_REFERENCE_UPDATES, BASE_F, DIVERGENCE, PRESSURE, REFERENCE_X, RELATIVE_F,
};
use super::DiqCoupled;
use mpm_core::columns::{self, Column};
use mpm_core::solver::{on_pool, DtBound, FieldInfo, RestoreError, StageTime};
use mpm_core::{
    Diagnostics, Dim, DimOps, GridSpec, Material, Matrix, Monitor, Particles, Real, Region, Solver,
    SolverState, StagePlan, StepError, StepInfo, Vector,
};
use mpm_tlmpm::TlmpmState;

impl<const D: usize> Solver<D> for DiqCoupled<D>
where
    Dim<D>: DimOps<D>,
{
    fn name(&self) -> &'static str {
        "DIQ-MPM: incompressible fluid and mixed TLMPM solids"
    }

    fn spec(&self) -> &GridSpec<D> {
        Solver::spec(&self.fluid)
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
        self.bound()
    }

    fn dt_bound(&self) -> DtBound {
        crate::fluid::displacement_bound_doc()
    }

    fn region(&self) -> Region<D> {
        Solver::region(&self.fluid)
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

    /// Advances one step; a failed solve is a [`StepError::Solve`] with the
    /// [`CoupledError`](super::CoupledError)'s message. The step runs on a thread of the rayon pool ([`on_pool`]).
    fn step(&mut self) -> Result<StepInfo, StepError> {
        on_pool(|| self.advance_step()).map_err(|e| e.erase("coupled"))
    }

    fn stage_times(&self) -> Vec<StageTime> {
        let solid = self.solid.stats();
        let mut rows = self.times.rows(&self.plan);
        for r in &mut rows {
            r.seconds += solid.get(r.stage).as_secs_f64();
        }
        rows
    }

    fn checkpoint(&self) -> SolverState {
        let mut state = SolverState::of_particles(&self.particles, self.time, self.steps);
        let mut reference = self.particles.x.clone();
        for (k, &p) in self.solid_index.iter().enumerate() {
            reference[p] = self.solid.reference().positions()[k];
        }
        state
            .columns
            .push(Column::vectors(REFERENCE_X, "m", &reference));
        let solid = self.solid.state();
        let scene_order = |m: &[Matrix<D>]| {
            let mut out = vec![Matrix::<D>::identity(); self.particles.len()];
            for (k, &p) in self.solid_index.iter().enumerate() {
                out[p] = m[k];
            }
            out
        };
        if let Some(g) = &solid.relative_def_grad {
            state
                .columns
                .push(Column::matrices(RELATIVE_F, "1", &scene_order(g)));
        }
        if let Some(b) = &solid.base_def_grad {
            state
                .columns
                .push(Column::matrices(BASE_F, "1", &scene_order(b)));
        }
        state.attrs.push((
            ATTR_REFERENCE_UPDATES.to_string(),
            solid.reference_updates as f64,
        ));
        state
            .columns
            .push(Column::scalars(PRESSURE, "Pa", &self.scene_pressure()));
        state
            .columns
            .push(Column::scalars(DIVERGENCE, "1/s", &self.scene_divergence()));
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
        let (pressure, divergence) = (scalar(PRESSURE)?, scalar(DIVERGENCE)?);
        let reference: Vec<Vector<D>> = columns::f64_values(&state.columns, REFERENCE_X, &[n, D])?
            .ok_or_else(|| RestoreError(format!("checkpoint has no field `{REFERENCE_X}`")))?
            .chunks_exact(D)
            .map(Vector::<D>::from_column_slice)
            .collect();
        let is_fluid = |p: usize| {
            matches!(
                self.materials[particles.material[p] as usize],
                Material::Fluid(_)
            )
        };
        let solids: Vec<usize> = (0..n).filter(|&p| !is_fluid(p)).collect();
        let mats = |name: &str| -> Result<Option<Vec<Matrix<D>>>, RestoreError> {
            Ok(columns::f64_values(&state.columns, name, &[n, D, D])?
                .map(columns::to_matrices::<D>)
                .map(|m| solids.iter().map(|&p| m[p]).collect()))
        };
        let solid_state = TlmpmState {
            time: state.time,
            steps: state.steps,
            reference_positions: solids.iter().map(|&p| reference[p]).collect(),
            relative_def_grad: mats(RELATIVE_F)?,
            base_def_grad: mats(BASE_F)?,
            reference_updates: state.attr(ATTR_REFERENCE_UPDATES).map_or(0, |v| v as u64),
            node_velocities: None,
        };
        let mut s = Self::build(
            *Solver::spec(&self.fluid),
            self.params.clone(),
            self.solid_params.clone(),
            self.materials.clone(),
            self.boundaries.clone(),
            particles,
            Some(solid_state),
            state.time,
        )
        .map_err(|e| RestoreError(format!("does not fit this scene: {e}")))?;
        let fluid_p: Vec<Real> = s.fluid_index.iter().map(|&p| pressure[p]).collect();
        let fluid_d: Vec<Real> = s.fluid_index.iter().map(|&p| divergence[p]).collect();
        s.fluid.set_state(state.time, state.steps, fluid_p, fluid_d);
        s.solid_pressure = s.solid_index.iter().map(|&p| pressure[p]).collect();
        *self = s;
        Ok(())
    }

    fn monitors(&self) -> Vec<Monitor> {
        if self.has_fluid() {
            self.fluid.monitors()
        } else {
            Vec::new()
        }
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
        self.scene_pressure()
    }

    fn output(&self, name: &str) -> Vec<Column> {
        match name {
            "pressure" => vec![Column::scalars("pressure", "Pa", &self.scene_pressure())],
            crate::fields::DIVERGENCE => vec![Column::scalars(
                crate::fields::DIVERGENCE,
                "1/s",
                &self.scene_divergence(),
            )],
            _ => columns::particle_column(&self.particles, name),
        }
    }
}
