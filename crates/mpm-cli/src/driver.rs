//! The solver a scene runs, behind one interface for `run`, `check` and checkpoints:
//! explicit MLS-MPM (`mpm-explicit`) or total-Lagrangian MPM (`mpm-tlmpm`, implicit or
//! explicit).

use crate::error::CliError;
use crate::state::{matrices, vectors};
use mpm_core::{Diagnostics, Dim, DimOps, GridSpec, Material, Matrix, Particles, Vector};
use mpm_explicit::ExplicitSolver;
use mpm_io::{Data, Field, Snapshot};
use mpm_tlmpm::{ExplicitTlmpm, ImplicitTlmpm, StepError, TlmpmState};

/// Checkpoint field of the TLMPM reference positions.
const REFERENCE_X: &str = "tlmpm_reference_x";
/// Checkpoint field of the A-ULMPM deformation gradients since the reference configuration.
const RELATIVE_F: &str = "tlmpm_relative_F";
/// Checkpoint field of the A-ULMPM base deformation gradients.
const BASE_F: &str = "tlmpm_base_F";
/// Checkpoint attribute of the number of A-ULMPM reference updates.
const ATTR_REFERENCE_UPDATES: &str = "tlmpm_reference_updates";

/// What one accepted step did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepReport {
    /// The accepted time step (s).
    pub dt: f64,
    /// dt/2 retries before it was accepted.
    pub retries: u32,
    /// Newton iterations of the accepted attempt (implicit TLMPM only).
    pub newton_iterations: Option<u32>,
}

/// A scene's solver.
#[derive(Debug)]
pub enum Driver<const D: usize> {
    /// Explicit MLS-MPM.
    Explicit(Box<ExplicitSolver<D>>),
    /// Implicit (Newton) TLMPM.
    ImplicitTlmpm(Box<ImplicitTlmpm<D>>),
    /// Explicit TLMPM.
    ExplicitTlmpm(Box<ExplicitTlmpm<D>>),
}

impl<const D: usize> Driver<D>
where
    Dim<D>: DimOps<D>,
{
    /// The name written to `summary.json` and printed by `check`.
    pub fn name(&self) -> &'static str {
        match self {
            Driver::Explicit(_) => "explicit MLS-MPM",
            Driver::ImplicitTlmpm(_) => "implicit TLMPM (backward Euler, Newton)",
            Driver::ExplicitTlmpm(_) => "explicit TLMPM (symplectic Euler)",
        }
    }

    /// The particles.
    pub fn particles(&self) -> &Particles<D> {
        match self {
            Driver::Explicit(s) => &s.particles,
            Driver::ImplicitTlmpm(s) => s.particles(),
            Driver::ExplicitTlmpm(s) => s.particles(),
        }
    }

    /// The material table.
    pub fn materials(&self) -> &[Material] {
        match self {
            Driver::Explicit(s) => &s.materials,
            Driver::ImplicitTlmpm(s) => s.materials(),
            Driver::ExplicitTlmpm(s) => s.materials(),
        }
    }

    /// The background grid (for TLMPM: the grid of the reference configuration).
    pub fn spec(&self) -> &GridSpec<D> {
        match self {
            Driver::Explicit(s) => &s.spec,
            Driver::ImplicitTlmpm(s) => s.reference().spec(),
            Driver::ExplicitTlmpm(s) => s.reference().spec(),
        }
    }

    /// Simulation time (s).
    pub fn time(&self) -> f64 {
        match self {
            Driver::Explicit(s) => s.time,
            Driver::ImplicitTlmpm(s) => s.time(),
            Driver::ExplicitTlmpm(s) => s.time(),
        }
    }

    /// Accepted steps.
    pub fn steps(&self) -> u64 {
        match self {
            Driver::Explicit(s) => s.steps,
            Driver::ImplicitTlmpm(s) => s.steps(),
            Driver::ExplicitTlmpm(s) => s.steps(),
        }
    }

    /// The stable step bound at the current state (s); for implicit TLMPM the advective bound
    /// `Δx / max |v|` (no wave-speed limit).
    pub fn stable_dt(&self) -> f64 {
        match self {
            Driver::Explicit(s) => s.stable_dt(),
            Driver::ImplicitTlmpm(s) => s.stable_dt(),
            Driver::ExplicitTlmpm(s) => s.stable_dt(),
        }
    }

    /// Mass, momenta and energies.
    pub fn diagnostics(&self) -> Diagnostics<D> {
        match self {
            Driver::Explicit(s) => s.diagnostics(),
            Driver::ImplicitTlmpm(s) => s.diagnostics(),
            Driver::ExplicitTlmpm(s) => s.diagnostics(),
        }
    }

    /// The stages each step runs.
    pub fn stage_plan(&self) -> Vec<String> {
        match self {
            Driver::Explicit(s) => s.stage_plan(),
            Driver::ImplicitTlmpm(s) => s.stage_plan(),
            Driver::ExplicitTlmpm(s) => s.stage_plan(),
        }
    }

    /// `(stage, seconds)` accumulated over all steps, in execution order; implicit TLMPM adds
    /// the breakdown of the Newton solve as `newton: …` rows (part of `solve`).
    pub fn stage_table(&self) -> Vec<(&'static str, f64)> {
        match self {
            Driver::Explicit(s) => s.stats.table().to_vec(),
            Driver::ExplicitTlmpm(s) => s.stats.table().to_vec(),
            Driver::ImplicitTlmpm(s) => {
                let mut t = s.stats.table().to_vec();
                let n = &s.stats.newton;
                t.extend([
                    ("newton: energy", n.energy.as_secs_f64()),
                    ("newton: gradient", n.gradient.as_secs_f64()),
                    ("newton: tangent", n.tangent.as_secs_f64()),
                    ("newton: assembly", n.assembly.as_secs_f64()),
                    ("newton: factorization", n.factorization.as_secs_f64()),
                    ("newton: linear solve", n.linear_solve.as_secs_f64()),
                ]);
                t
            }
        }
    }

    /// Rows of [`Self::stage_table`] that are a breakdown of another row, not stages.
    pub fn is_breakdown(name: &str) -> bool {
        name.starts_with("newton: ")
    }

    /// Advances one step; a failed guard check or Newton solve is an instability (exit 3).
    pub fn step(&mut self) -> Result<StepReport, CliError> {
        let unstable = |e: String| CliError::Instability(format!("error: numerical {e}"));
        match self {
            Driver::Explicit(s) => s
                .step()
                .map(|i| StepReport {
                    dt: i.dt,
                    retries: i.retries,
                    newton_iterations: None,
                })
                .map_err(|e| unstable(e.to_string())),
            Driver::ImplicitTlmpm(s) => s
                .step()
                .map(|i| StepReport {
                    dt: i.dt,
                    retries: i.retries,
                    newton_iterations: Some(i.newton.iterations),
                })
                .map_err(|e| unstable(step_error(&e))),
            Driver::ExplicitTlmpm(s) => s
                .step()
                .map(|i| StepReport {
                    dt: i.dt,
                    retries: i.retries,
                    newton_iterations: None,
                })
                .map_err(|e| unstable(step_error(&e))),
        }
    }

    /// The checkpoint payload beyond the particle columns: fields and attributes.
    pub fn checkpoint_extra(&self) -> (Vec<Field>, Vec<(String, f64)>) {
        let state = match self {
            Driver::Explicit(_) => return (Vec::new(), Vec::new()),
            Driver::ImplicitTlmpm(s) => s.state(),
            Driver::ExplicitTlmpm(s) => s.state(),
        };
        let mut fields = vec![vectors(REFERENCE_X, "m", &state.reference_positions)];
        if let Some(g) = &state.relative_def_grad {
            fields.push(matrices(RELATIVE_F, "1", g));
        }
        if let Some(b) = &state.base_def_grad {
            fields.push(matrices(BASE_F, "1", b));
        }
        let attrs = vec![(
            ATTR_REFERENCE_UPDATES.to_string(),
            state.reference_updates as f64,
        )];
        (fields, attrs)
    }

    /// Rebuilds the solver, with the same grid, parameters and materials, around the particles
    /// restored from checkpoint `ck`, and continues at its time and step.
    pub fn resume(&mut self, particles: Particles<D>, ck: &Snapshot) -> Result<(), String> {
        let (time, steps) = (ck.header.time, ck.header.step);
        let fit = |e: mpm_core::SetupError| format!("does not fit this scene: {e}");
        match self {
            Driver::Explicit(s) => {
                let mut new = ExplicitSolver::new(
                    s.spec,
                    s.params.clone(),
                    s.materials.clone(),
                    s.boundaries.clone(),
                    particles,
                )
                .map_err(fit)?;
                new.time = time;
                new.steps = steps;
                **s = new;
            }
            Driver::ImplicitTlmpm(s) => {
                let state = tlmpm_state(ck, particles.len(), time, steps)?;
                let mut new = ImplicitTlmpm::new(
                    *s.reference().spec(),
                    s.params().clone(),
                    s.implicit,
                    s.materials().to_vec(),
                    particles,
                )
                .map_err(fit)?;
                if !s.particle_forces().is_empty() {
                    new.particle_forces_mut()
                        .copy_from_slice(s.particle_forces());
                }
                new.restore(state).map_err(fit)?;
                **s = new;
            }
            Driver::ExplicitTlmpm(s) => {
                let state = tlmpm_state(ck, particles.len(), time, steps)?;
                let mut new = ExplicitTlmpm::new(
                    *s.reference().spec(),
                    s.params().clone(),
                    s.materials().to_vec(),
                    particles,
                )
                .map_err(fit)?;
                if !s.particle_forces().is_empty() {
                    new.particle_forces_mut()
                        .copy_from_slice(s.particle_forces());
                }
                new.restore(state).map_err(fit)?;
                **s = new;
            }
        }
        Ok(())
    }
}

/// The message of a failed TLMPM step.
fn step_error(e: &StepError) -> String {
    match e {
        StepError::Instability(i) => i.to_string(),
        StepError::Newton { .. } => format!("instability: Newton failed at {e}"),
    }
}

/// The TLMPM state stored in checkpoint `ck` for `n` particles.
fn tlmpm_state<const D: usize>(
    ck: &Snapshot,
    n: usize,
    time: f64,
    steps: u64,
) -> Result<TlmpmState<D>, String> {
    let values = |name: &str, per: usize| -> Result<Option<&[f64]>, String> {
        match ck.field(name).map(|f| &f.data) {
            None => Ok(None),
            Some(Data::F64 { values, shape })
                if shape.first() == Some(&n) && values.len() == n * per =>
            {
                Ok(Some(values))
            }
            Some(_) => Err(format!(
                "checkpoint field `{name}` does not have {n} rows of {per} f64 values"
            )),
        }
    };
    let reference_positions = values(REFERENCE_X, D)?
        .ok_or_else(|| format!("checkpoint has no field `{REFERENCE_X}` (not a TLMPM run?)"))?
        .chunks_exact(D)
        .map(Vector::<D>::from_column_slice)
        .collect();
    let mats = |v: &[f64]| -> Vec<Matrix<D>> {
        v.chunks_exact(D * D)
            .map(|c| Matrix::<D>::from_fn(|i, j| c[i * D + j]))
            .collect()
    };
    let reference_updates = ck
        .header
        .attrs
        .iter()
        .find(|(k, _)| k == ATTR_REFERENCE_UPDATES)
        .map_or(0, |(_, v)| *v as u64);
    Ok(TlmpmState {
        time,
        steps,
        reference_positions,
        relative_def_grad: values(RELATIVE_F, D * D)?.map(mats),
        base_def_grad: values(BASE_F, D * D)?.map(mats),
        reference_updates,
    })
}
