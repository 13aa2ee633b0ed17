//! Explicit TLMPM: symplectic Euler on the reference grid, for comparison and cheap cases.

use crate::contact::ContactStats;
use crate::core::{split_law, step_info, Core, Failure, TlmpmState};
use crate::error::StepError;
use crate::params::TlmpmParams;
use crate::potential::internal_force;
use crate::reference::ReferenceConfig;
use mpm_core::solver::{on_pool, StageTime, StepInfo};
use mpm_core::{
    Diagnostics, Dim, DimOps, GridSpec, Material, Matrix, Particles, Real, SetupError, Stage,
    StagePlan, StageTimes, Vector,
};
use rayon::prelude::*;
use std::time::Instant;

/// Explicit total-Lagrangian MPM: P2G of momentum to the reference grid, the internal force of
/// Eq. 3 at `F^n`, the symplectic Euler update `v_i^{n+1} = v̂_i + Δt (f_i + f^ext_i)/m_i`, then
/// G2P with `F^{n+1} = F^n + Δt Σ_i v_i^{n+1} ⊗ ∇^X W_i(X_p)`. Stable for
/// `Δt ≲ Δx / c` with `c` the P-wave speed. Contact forces (Eq. 4, evaluated at `x^n`) join the
/// external forces; their stiffness `m/Δt²` gives `ω Δt ≈ 1` per contact, inside the symplectic
/// Euler bound of 2 for any Δt.
#[derive(Clone, Debug)]
pub struct ExplicitTlmpm<const D: usize> {
    core: Core<D>,
    stats: StageTimes,
    stress: Vec<Matrix<D>>,
    /// What the contact stage of the last accepted step found.
    last_contact: Option<ContactStats>,
}

impl<const D: usize> ExplicitTlmpm<D>
where
    Dim<D>: DimOps<D>,
{
    /// Builds a solver; the particles' current positions become the reference configuration,
    /// whose weights and gradients are cached here. See [`crate::ImplicitTlmpm::new`] for the
    /// requirements.
    pub fn new(
        spec: GridSpec<D>,
        params: TlmpmParams<D>,
        materials: Vec<Material>,
        particles: Particles<D>,
    ) -> Result<Self, SetupError> {
        let t = Instant::now();
        let core = Core::new(spec, params, materials, particles)?;
        let mut stats = StageTimes::default();
        stats.add(crate::stages::REFERENCE, t.elapsed());
        Ok(Self {
            core,
            stats,
            stress: Vec::new(),
            last_contact: None,
        })
    }

    /// [`mpm_core::Solver::step`] on the calling thread: retries with dt/2 on a failed guard
    /// check when the policy allows; a failed step leaves the particles untouched.
    fn advance_step(&mut self) -> Result<StepInfo, StepError> {
        let start = self.core.start();
        let core = &self.core;
        let dt0 = self
            .stats
            .time(Stage::TIME_STEP, || core.choose_dt(true))
            .map_err(|f| start.error(f, 0.0, 0))?;
        let (stress, stats) = (&mut self.stress, &mut self.stats);
        let (contact, dt, retries) = self
            .core
            .run_step(dt0, |core, dt| advance(core, stress, stats, dt))?;
        let core = &mut self.core;
        let reference_updated = self
            .stats
            .time(crate::stages::REFERENCE_UPDATE, || core.reference_update())
            .map_err(|f| start.error(f, dt, retries))?;
        self.last_contact = contact;
        Ok(step_info(
            (dt, retries, self.core.time),
            (Vec::new(), Vec::new()),
            contact,
            reference_updated,
        ))
    }

    crate::core::shared_accessors!();

    /// Continues from a checkpoint: the solver must have been built from the checkpoint's
    /// particles with the original parameters; `state` (from [`Self::state`]) restores the
    /// reference configuration, the A-ULMPM columns, the time and the step count.
    pub fn restore(&mut self, state: TlmpmState<D>) -> Result<(), SetupError> {
        self.core.restore(state)?;
        Ok(())
    }

    /// The stages each step runs, in order, for this solver's parameters (only those it
    /// uses).
    pub fn stage_plan(&self) -> StagePlan {
        self.core.plan(
            "internal forces (Eq. 3) and symplectic Euler node update".into(),
            "dx / max(|v| + c)",
        )
    }

    /// Wall time accumulated per stage.
    pub fn stats(&self) -> &StageTimes {
        &self.stats
    }

    /// The stable step bound (s) before `dt_max`, `cfl · Δx / max_p (|v_p| + c_p)` (cfl = 1
    /// with a fixed step, so a fixed dt above this value deserves a warning).
    pub fn stable_dt(&self) -> Real {
        self.core.stable_dt(true)
    }
}

/// One attempt at a step of size `dt`: the stage plan.
fn advance<const D: usize>(
    core: &mut Core<D>,
    stress: &mut Vec<Matrix<D>>,
    stats: &mut StageTimes,
    dt: Real,
) -> Result<Option<ContactStats>, Failure>
where
    Dim<D>: DimOps<D>,
{
    stats.time(Stage::P2G, || core.momentum_to_grid());
    stats.time(crate::stages::EXTERNAL_FORCES, || core.external_forces());
    let contact = stats.time(crate::stages::CONTACT, || core.contact(dt));
    stats.time(Stage::SOLVE, || {
        update_grid(core, stress, dt);
        core.check_displacements()
    })?;
    stats.time(Stage::G2P, || core.grid_to_particles(dt))?;
    stats.time(Stage::COMMIT, || core.commit(dt));
    Ok(contact)
}

/// Stage: internal forces (Eq. 3) at `F^n` and the symplectic Euler node update (damped where
/// the parameters damp it), stored as displacements `u_i = Δt v_i^{n+1}` (m).
fn update_grid<const D: usize>(core: &mut Core<D>, stress: &mut Vec<Matrix<D>>, dt: Real)
where
    Dim<D>: DimOps<D>,
{
    let Core {
        reference,
        constraints,
        models,
        particles,
        grid_velocity,
        external,
        displacement,
        adaptive,
        params,
        ..
    } = core;
    stress.resize(particles.len(), Matrix::<D>::zeros());
    let (law, rel) = split_law(models, particles, adaptive.as_ref());
    law.weighted_stresses(rel, stress);
    let masses = reference.node_masses();
    displacement.resize(masses.len(), Vector::<D>::zeros());
    let stress = &*stress;
    let damping = (!params.step.damping.is_off()).then_some(params.step.damping);
    displacement.par_iter_mut().enumerate().for_each(|(i, u)| {
        let (f, _) = internal_force(reference, stress, i);
        let v = match &damping {
            Some(d) => d.velocity(&grid_velocity[i], &(f + external[i]), masses[i], dt),
            None => grid_velocity[i] + (f + external[i]) * (dt / masses[i]),
        };
        *u = constraints.displacement(i, v * dt, dt);
    });
}

crate::core::solver_seam!(
    ExplicitTlmpm,
    |_: &Self| "explicit TLMPM (symplectic Euler)",
    "dx / max(|v| + c)",
    true
);

impl<const D: usize> ExplicitTlmpm<D>
where
    Dim<D>: DimOps<D>,
{
    /// The same set-up around `particles` (a new reference configuration).
    fn rebuild(&self, particles: Particles<D>) -> Result<Self, SetupError> {
        Self::new(
            *self.core.reference.spec(),
            self.core.params.clone(),
            self.core.materials.clone(),
            particles,
        )
    }

    /// The step of the solver seam, on a thread of the rayon pool ([`on_pool`]).
    fn seam_step(&mut self) -> Result<StepInfo, mpm_core::StepError> {
        on_pool(|| self.advance_step()).map_err(|e| e.erase("Newton"))
    }

    /// What the contact stage of the last accepted step found (`None` when contact is off or
    /// before the first step).
    pub fn last_contact(&self) -> Option<ContactStats> {
        self.last_contact
    }

    /// Stage times.
    fn seam_stage_times(&self) -> Vec<StageTime> {
        self.stats.rows(&self.stage_plan())
    }
}
