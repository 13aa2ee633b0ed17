//! State and stages shared by the implicit and the explicit TLMPM solvers.

use crate::adaptive::Adaptive;
use crate::contact::{ContactRadius, ContactStage, ContactStats};
use crate::error::{NewtonError, StepError};
use crate::loads::AppliedLoads;
use crate::params::{ImplicitParams, TlmpmParams, Transfer};
use crate::potential::Constitutive;
use crate::reference::{Constraints, ReferenceConfig};
use crate::transfer::{self, FlipBlend, Update};
use crate::{ExplicitTlmpm, ImplicitTlmpm};
use mpm_core::material::{ElasticModel, Lame, Plasticity};
use mpm_core::quasistatic::gravity_at;
use mpm_core::solver::{nan_max, RestoreError, SolveInfo, SolverState, StepInfo};
use mpm_core::timestep::{choose_dt, stable_dt};
use mpm_core::{
    columns, retry_halving, Column, ColumnData, Diagnostics, Dim, DimOps, GridSpec, Location,
    Material, Matrix, Particles, Real, SetupError, Solver, Stage, StagePlan, StepStart,
    TimeStepPolicy, Vector, Violation,
};
use rayon::prelude::*;
use serde::Serialize;
use std::time::Duration;

/// Why one attempt at a step failed: a guard check, or Newton's method.
pub(crate) type Failure = mpm_core::Failure<NewtonError>;

/// Wall-clock time spent inside Newton's method, by kind of work, accumulated over all steps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct NewtonTimes {
    /// Energy evaluations (initial guess and line search).
    pub energy: Duration,
    /// Gradient evaluations (stresses and the internal-force gather).
    pub gradient: Duration,
    /// Per-particle elasticity tensors `∂P/∂F` and their SPD projection.
    pub tangent: Duration,
    /// Sparse matrix assembly (Cholesky solver only).
    pub assembly: Duration,
    /// Numeric Cholesky factorisation (the symbolic one is done once, at set-up).
    pub factorization: Duration,
    /// Triangular solves or CG iterations.
    pub linear_solve: Duration,
}

/// The solver state beyond the particle columns: what a checkpoint must hold, besides the
/// particles, for a resumed run to continue bitwise identically.
#[derive(Clone, Debug, PartialEq)]
pub struct TlmpmState<const D: usize> {
    /// Simulation time (s).
    pub time: Real,
    /// Accepted steps.
    pub steps: u64,
    /// Reference positions X_p (m): the initial positions, or those of the last A-ULMPM
    /// reference update.
    pub reference_positions: Vec<Vector<D>>,
    /// A-ULMPM only: `G_p = F_p^{(r,n)}`, the deformation gradients since the reference
    /// configuration (dimensionless).
    pub relative_def_grad: Option<Vec<Matrix<D>>>,
    /// A-ULMPM only: `B_p = F_p^{(0,r)}`, the base deformation gradients (dimensionless);
    /// `None` while they are the identity.
    pub base_def_grad: Option<Vec<Matrix<D>>>,
    /// Number of A-ULMPM reference updates so far.
    pub reference_updates: u64,
    /// [`Transfer::Persistent`] only: the node velocities of the last accepted step (m/s), one
    /// per active node of the reference grid in its numbering; `None` when the next step starts
    /// with a P2G transfer (before the first step, after a reference update or a change of the
    /// particle velocities).
    pub node_velocities: Option<Vec<Vector<D>>>,
}

/// What both TLMPM integrators offer beyond the [`Solver`] interface: applied per-particle
/// forces and the reference configuration.
pub trait TotalLagrangian<const D: usize>: Solver<D>
where
    Dim<D>: DimOps<D>,
{
    /// Applied per-particle forces f_p (N), allocated as zeros on first use; they enter as nodal
    /// forces `Σ_p W_i(X_p) f_p` and persist until changed.
    fn particle_forces_mut(&mut self) -> &mut [Vector<D>];

    /// The reference configuration (its grid, positions, weights).
    fn reference(&self) -> &ReferenceConfig<D>;
}

/// Builds the implicit solver when `implicit` is given, else the explicit one (see
/// [`crate::ImplicitTlmpm::new`] for the requirements).
pub fn build<const D: usize>(
    spec: GridSpec<D>,
    params: TlmpmParams<D>,
    implicit: Option<ImplicitParams>,
    materials: Vec<Material>,
    particles: Particles<D>,
) -> Result<Box<dyn TotalLagrangian<D>>, SetupError>
where
    Dim<D>: DimOps<D>,
{
    Ok(match implicit {
        Some(ip) => Box::new(ImplicitTlmpm::new(spec, params, ip, materials, particles)?),
        None => Box::new(ExplicitTlmpm::new(spec, params, materials, particles)?),
    })
}

/// Checkpoint column of the reference positions.
const REFERENCE_X: &str = "tlmpm_reference_x";
/// Checkpoint column of the A-ULMPM deformation gradients since the reference configuration.
const RELATIVE_F: &str = "tlmpm_relative_F";
/// Checkpoint column of the A-ULMPM base deformation gradients.
const BASE_F: &str = "tlmpm_base_F";
/// Checkpoint column of the persistent node velocities (one row per active reference node).
const NODE_V: &str = "tlmpm_node_v";
/// Checkpoint attribute of the number of A-ULMPM reference updates.
const ATTR_REFERENCE_UPDATES: &str = "tlmpm_reference_updates";

/// A set-up error met while restoring, as a restore error.
pub(crate) fn misfit(e: SetupError) -> RestoreError {
    RestoreError(format!("does not fit this scene: {e}"))
}

/// The [`TlmpmState`] stored in `state` for `n` particles.
pub(crate) fn state_from<const D: usize>(
    state: &SolverState,
    n: usize,
) -> Result<TlmpmState<D>, RestoreError> {
    let cols = &state.columns;
    let reference_positions = columns::f64_values(cols, REFERENCE_X, &[n, D])?
        .ok_or_else(|| format!("checkpoint has no field `{REFERENCE_X}` (not a TLMPM run?)"))?;
    let mats = |name| -> Result<Option<Vec<Matrix<D>>>, String> {
        Ok(columns::f64_values(cols, name, &[n, D, D])?.map(columns::to_matrices::<D>))
    };
    let node_velocities = match columns::find(cols, NODE_V).map(|c| &c.data) {
        None => None,
        Some(ColumnData::F64 { values, shape }) if shape.len() == 2 && shape[1] == D => {
            Some(columns::to_vectors::<D>(values))
        }
        Some(_) => return Err(format!("column `{NODE_V}` is not an [N, {D}] f64 column").into()),
    };
    Ok(TlmpmState {
        time: state.time,
        steps: state.steps,
        reference_positions: columns::to_vectors::<D>(reference_positions),
        relative_def_grad: mats(RELATIVE_F)?,
        base_def_grad: mats(BASE_F)?,
        reference_updates: state.attr(ATTR_REFERENCE_UPDATES).map_or(0, |v| v as u64),
        node_velocities,
    })
}

/// The [`Solver`] and [`TotalLagrangian`] implementations both TLMPM solvers share, for a
/// solver type with a `core: Core<D>` field and the inherent methods `stage_plan`, `stable_dt`,
/// `seam_step` (the step as a [`mpm_core::StepInfo`]), `seam_stage_times` and `rebuild` (the same
/// set-up around other particles); `$name` maps the solver to its name.
macro_rules! solver_seam {
    ($ty:ident, $name:expr, $bound:expr, $limits_fixed_dt:expr) => {
        impl<const D: usize> mpm_core::Solver<D> for $ty<D>
        where
            Dim<D>: DimOps<D>,
        {
            fn name(&self) -> &'static str {
                ($name)(self)
            }

            fn spec(&self) -> &GridSpec<D> {
                self.core.reference.spec()
            }

            fn particles(&self) -> &Particles<D> {
                &self.core.particles
            }

            fn materials(&self) -> &[Material] {
                &self.core.materials
            }

            fn time(&self) -> Real {
                self.core.time
            }

            fn steps(&self) -> u64 {
                self.core.steps
            }

            fn stable_dt(&self) -> Real {
                $ty::stable_dt(self)
            }

            fn dt_bound(&self) -> mpm_core::solver::DtBound {
                mpm_core::solver::DtBound {
                    description: $bound,
                    limits_fixed_dt: $limits_fixed_dt,
                }
            }

            fn diagnostics(&self) -> Diagnostics<D> {
                self.core.diagnostics(|| $ty::stable_dt(self))
            }

            fn plan(&self) -> mpm_core::StagePlan {
                self.stage_plan()
            }

            fn step(&mut self) -> Result<mpm_core::StepInfo, mpm_core::StepError> {
                self.seam_step()
            }

            fn stage_times(&self) -> Vec<mpm_core::solver::StageTime> {
                self.seam_stage_times()
            }

            fn checkpoint(&self) -> mpm_core::SolverState {
                self.core.checkpoint()
            }

            fn restore(
                &mut self,
                state: &mpm_core::SolverState,
            ) -> Result<(), mpm_core::solver::RestoreError> {
                let particles = self.core.particles_from(state)?;
                let mut new = self.rebuild(particles).map_err(crate::core::misfit)?;
                new.core
                    .particle_forces
                    .clone_from(&self.core.particle_forces);
                let n = new.core.particles.len();
                // The solver's own restore: the implicit one also drops the sparsity pattern
                // built around the checkpoint's current positions.
                new.restore(crate::core::state_from(state, n)?)
                    .map_err(crate::core::misfit)?;
                *self = new;
                Ok(())
            }
        }

        impl<const D: usize> crate::core::TotalLagrangian<D> for $ty<D>
        where
            Dim<D>: DimOps<D>,
        {
            fn particle_forces_mut(&mut self) -> &mut [Vector<D>] {
                self.core.particle_forces_mut()
            }

            fn reference(&self) -> &ReferenceConfig<D> {
                &self.core.reference
            }
        }
    };
}
pub(crate) use solver_seam;

/// The step result of either solver as a [`mpm_core::StepInfo`], from its solves and their
/// residual histories.
pub(crate) fn step_info(
    (dt, retries, time): (Real, u32, Real),
    (solves, residual_histories): (Vec<SolveInfo>, Vec<(&'static str, Vec<Real>)>),
    contact: Option<ContactStats>,
    reference_updated: bool,
) -> StepInfo {
    let mut events = Vec::new();
    if let Some(c) = contact {
        events.push(("contact_pairs", c.pairs as u64));
    }
    if reference_updated {
        events.push(("reference_updates", 1));
    }
    StepInfo {
        dt,
        retries,
        time,
        solves,
        events,
        residual_histories,
    }
}

/// The accessors both solvers expose over their shared [`Core`]; expanded inside each solver's
/// `impl` block (the solver must have a `core: Core<D>` field).
macro_rules! shared_accessors {
    () => {
        /// Number of A-ULMPM reference updates so far (0 without
        /// [`TlmpmParams::reference_update`]); the implicit solver also rebuilt the sparsity
        /// pattern and the symbolic factorisation at each.
        pub fn reference_updates(&self) -> u64 {
            self.core.reference_updates()
        }

        /// The solver parameters.
        pub fn params(&self) -> &TlmpmParams<D> {
            &self.core.params
        }

        /// The material table.
        pub fn materials(&self) -> &[Material] {
            &self.core.materials
        }

        /// Particle state. The affine column holds `C_p = ∇^X V` (1/s), the velocity gradient
        /// with respect to reference coordinates.
        pub fn particles(&self) -> &Particles<D> {
            &self.core.particles
        }

        /// Particle velocities (m/s), e.g. to set an initial velocity field. The next step
        /// starts with a P2G transfer of them, also with [`crate::Transfer::Persistent`].
        pub fn velocities_mut(&mut self) -> &mut [Vector<D>] {
            self.core.node_velocity.clear();
            &mut self.core.particles.v
        }

        /// The applied particle forces (N); empty when none were set.
        pub fn particle_forces(&self) -> &[Vector<D>] {
            &self.core.particle_forces
        }

        /// Applied forces on the particles (N), zero until set. They enter every later step as
        /// external nodal forces `Σ_p W_i(X_p) f_p` held over the step (a tip load, a
        /// manufactured body force `m_p b(X_p, t)`), without touching the particle velocities,
        /// so they also work with [`crate::Transfer::Persistent`].
        pub fn particle_forces_mut(&mut self) -> &mut [Vector<D>] {
            self.core.particle_forces_mut()
        }

        /// The solver state beyond the particle columns, for a checkpoint.
        pub fn state(&self) -> TlmpmState<D> {
            self.core.state()
        }

        /// The cached reference configuration.
        pub fn reference(&self) -> &ReferenceConfig<D> {
            &self.core.reference
        }

        /// A-ULMPM: the kinematic deformation gradients `F^(r,n)` from the current reference
        /// configuration to the current one (one per particle); `None` without
        /// [`TlmpmParams::reference_update`], where the reference is the initial configuration
        /// and `F^(r,n)` is the particles' `F`.
        pub fn relative_def_grads(&self) -> Option<&[Matrix<D>]> {
            self.core.adaptive.as_ref().map(|a| a.rel.as_slice())
        }

        /// The particle volumes in the current reference configuration (m^D):
        /// `V⁰ det F^(0,r)` with A-ULMPM's base `F^(0,r)`, else `V⁰`.
        pub fn reference_volumes(&self) -> Vec<Real> {
            let v0 = &self.core.particles.volume0;
            match self.core.adaptive.as_ref().and_then(|a| a.base.as_ref()) {
                Some(base) => v0
                    .iter()
                    .zip(base)
                    .map(|(v, b)| v * Dim::<D>::det(b))
                    .collect(),
                None => v0.clone(),
            }
        }

        /// Simulation time (s).
        pub fn time(&self) -> Real {
            self.core.time
        }

        /// Number of accepted steps.
        pub fn steps(&self) -> u64 {
            self.core.steps
        }

        /// Mass, momenta and energies of the particles, and with contact on the contact
        /// potential of its penalty springs (J).
        pub fn diagnostics(&self) -> Diagnostics<D> {
            self.core.diagnostics(|| self.stable_dt())
        }
    };
}
pub(crate) use shared_accessors;

/// Particle state, cached reference data and grid scratch shared by both solvers.
#[derive(Clone, Debug)]
pub(crate) struct Core<const D: usize> {
    pub params: TlmpmParams<D>,
    pub materials: Vec<Material>,
    /// Elastic model per material (a placeholder for materials no particle uses).
    pub models: Vec<ElasticModel>,
    pub particles: Particles<D>,
    pub reference: ReferenceConfig<D>,
    pub constraints: Constraints<D>,
    pub time: Real,
    pub steps: u64,
    /// Node velocities after P2G, v̂ (m/s).
    pub grid_velocity: Vec<Vector<D>>,
    /// Node velocities of the last accepted step (m/s), kept with [`Transfer::Persistent`];
    /// empty when P2G must run.
    pub node_velocity: Vec<Vector<D>>,
    /// External nodal forces (N).
    pub external: Vec<Vector<D>>,
    /// Applied per-particle forces f_p (N), e.g. a tip load; empty when there are none.
    pub particle_forces: Vec<Vector<D>>,
    /// The nodal loads and the tractions' surface particles of the parameters.
    pub loads: AppliedLoads,
    /// Node displacements of the step, u = x^{n+1} − x^n (m); `Δt v^{n+1}` except with Newmark.
    pub displacement: Vec<Vector<D>>,
    /// End-of-step node velocities v^{n+1} (m/s) of a scheme where they are not `u/Δt`
    /// (Newmark: `2u/Δt − v̂`); empty otherwise. Scratch of the current attempt, not state.
    pub end_velocity: Vec<Vector<D>>,
    /// G2P results awaiting the guard checks.
    pub updates: Vec<Update<D>>,
    /// The contact stage, when contact is on.
    pub contact: Option<ContactStage<D>>,
    /// A-ULMPM state, when reference updates are on.
    pub adaptive: Option<Adaptive<D>>,
}

impl<const D: usize> Core<D>
where
    Dim<D>: DimOps<D>,
{
    /// Validates the set-up and caches the reference configuration (particle positions now).
    pub fn new(
        spec: GridSpec<D>,
        params: TlmpmParams<D>,
        materials: Vec<Material>,
        particles: Particles<D>,
    ) -> Result<Self, SetupError> {
        let models = validate(&spec, &params, &materials, &particles)?;
        let reference = ReferenceConfig::new(
            spec,
            params.kernel,
            &params.clamp_planes,
            &particles.x,
            &particles.mass,
        )?;
        let constraints = Constraints::new(&reference, &params.fixed);
        let loads = AppliedLoads::new(
            &params.nodal_loads,
            &params.tractions,
            &reference,
            &particles.volume0,
        )?;
        let contact = params
            .contact
            .as_ref()
            .map(|c| ContactStage::new(c.radius, &particles.volume0));
        let adaptive = params.reference_update.map(|trigger| {
            let mut a = Adaptive::new(
                trigger,
                particles.def_grad.as_deref().unwrap_or(&[]),
                &materials,
                &particles.material,
                particles.plastic.as_deref(),
            );
            if Adaptive::<D>::needs_base(&materials) {
                a.base = Some(vec![Matrix::<D>::identity(); particles.len()]);
            }
            a
        });
        Ok(Self {
            params,
            materials,
            models,
            particles,
            reference,
            constraints,
            time: 0.0,
            steps: 0,
            grid_velocity: Vec::new(),
            node_velocity: Vec::new(),
            external: Vec::new(),
            particle_forces: Vec::new(),
            loads,
            displacement: Vec::new(),
            end_velocity: Vec::new(),
            updates: Vec::new(),
            contact,
            adaptive,
        })
    }

    /// The state beyond the particle columns (see [`TlmpmState`]).
    pub fn state(&self) -> TlmpmState<D> {
        let a = self.adaptive.as_ref();
        TlmpmState {
            time: self.time,
            steps: self.steps,
            reference_positions: self.reference.positions().to_vec(),
            relative_def_grad: a.map(|a| a.rel.clone()),
            base_def_grad: a.and_then(|a| a.base.clone()),
            reference_updates: a.map_or(0, |a| a.updates),
            node_velocities: (!self.node_velocity.is_empty()).then(|| self.node_velocity.clone()),
        }
    }

    /// The whole state as named columns: the particle columns, the reference positions, the
    /// A-ULMPM deformation gradients and the persistent node velocities where they exist, and
    /// the count of reference updates.
    pub fn checkpoint(&self) -> SolverState {
        let st = self.state();
        let mut out = SolverState::of_particles(&self.particles, self.time, self.steps);
        out.columns
            .push(Column::vectors(REFERENCE_X, "m", &st.reference_positions));
        if let Some(g) = &st.relative_def_grad {
            out.columns.push(Column::matrices(RELATIVE_F, "1", g));
        }
        if let Some(b) = &st.base_def_grad {
            out.columns.push(Column::matrices(BASE_F, "1", b));
        }
        if let Some(v) = &st.node_velocities {
            out.columns.push(Column::vectors(NODE_V, "m/s", v));
        }
        out.attrs.push((
            ATTR_REFERENCE_UPDATES.to_string(),
            st.reference_updates as f64,
        ));
        out
    }

    /// The particles stored in `state`, checked against this set-up's columns and materials.
    pub fn particles_from(&self, state: &SolverState) -> Result<Particles<D>, RestoreError> {
        Ok(columns::particles_from_columns(
            &state.columns,
            &self.particles,
            self.materials.len(),
        )?)
    }

    /// Restores a state saved by [`Core::state`] for the current particles: rebuilds the
    /// reference configuration at `state.reference_positions` and the Dirichlet numbering,
    /// and sets the A-ULMPM columns and the persistent node velocities (without them the next
    /// step starts with a P2G transfer).
    pub fn restore(&mut self, state: TlmpmState<D>) -> Result<(), SetupError> {
        let n = self.particles.len();
        let mismatch = |name: &'static str, len: usize| SetupError::InvalidParameter {
            name,
            value: len as Real,
            reason: "must have one entry per particle",
        };
        if state.reference_positions.len() != n {
            return Err(mismatch(
                "reference_positions",
                state.reference_positions.len(),
            ));
        }
        match (&mut self.adaptive, state.relative_def_grad) {
            (Some(a), Some(rel)) => {
                if rel.len() != n {
                    return Err(mismatch("relative_def_grad", rel.len()));
                }
                if let Some(b) = state.base_def_grad.as_ref().filter(|b| b.len() != n) {
                    return Err(mismatch("base_def_grad", b.len()));
                }
                a.rel = rel;
                a.base = state.base_def_grad;
                a.updates = state.reference_updates;
                a.refresh_hardening(
                    &self.materials,
                    &self.particles.material,
                    self.particles.plastic.as_deref(),
                );
            }
            (None, None) => {}
            _ => {
                return Err(SetupError::InvalidSetting {
                    setting: "reference_update".into(),
                    reason: "the saved state and the solver disagree on A-ULMPM".into(),
                })
            }
        }
        self.reference = ReferenceConfig::new(
            *self.reference.spec(),
            self.reference.kernel(),
            self.reference.clamp_planes(),
            &state.reference_positions,
            &self.particles.mass,
        )?;
        self.constraints = Constraints::new(&self.reference, &self.params.fixed);
        self.node_velocity.clear();
        if let Some(v) = state.node_velocities {
            if self.params.transfer != Transfer::Persistent {
                return Err(SetupError::InvalidSetting {
                    setting: "transfer".into(),
                    reason: "the saved state has persistent node velocities, the solver's \
                             transfer is not persistent"
                        .into(),
                });
            }
            if v.len() != self.reference.num_nodes() {
                return Err(SetupError::InvalidParameter {
                    name: "node_velocities",
                    value: v.len() as Real,
                    reason: "must have one entry per active node of the reference grid",
                });
            }
            self.node_velocity = v;
        }
        self.time = state.time;
        self.steps = state.steps;
        Ok(())
    }

    /// The stage plan of one step, only the stages these parameters use; `solve` describes the
    /// grid solve (Newton, or the explicit update) and `bound` the time-step bound.
    pub fn plan(&self, solve: String, bound: &str) -> StagePlan {
        let p = &self.params;
        let mut plan = StagePlan::default();
        plan.push(
            Stage::Reference,
            "at set-up: weights, gradients, connectivity and node masses of the reference \
             configuration",
        );
        plan.push(Stage::TimeStep, p.time_step.describe(bound));
        plan.push(
            Stage::P2G,
            format!(
                "{} transfer on the reference grid ({} fixed region(s)){}",
                match p.transfer {
                    Transfer::Apic => "APIC".to_string(),
                    Transfer::Pic => "PIC".to_string(),
                    Transfer::Flip { blend } => format!("FLIP/PIC blend {blend}"),
                    Transfer::Persistent => "PERSISTENT".to_string(),
                },
                p.fixed.len(),
                if p.transfer == Transfer::Persistent {
                    "; first step only, node velocities persist"
                } else {
                    ""
                }
            ),
        );
        plan.push(
            Stage::ExternalForces,
            format!(
                "gravity {:?} m/s^2{}{}{}",
                p.gravity.as_slice(),
                p.gravity_ramp.map_or(String::new(), |r| format!(
                    " ramped from 0 over {} s",
                    r.duration
                )),
                if self.particle_forces.is_empty() {
                    ""
                } else {
                    "; applied particle forces"
                },
                if p.nodal_loads.is_empty() && p.tractions.is_empty() {
                    String::new()
                } else {
                    format!(
                        "; {} nodal load(s), {} traction(s) on {} surface particle(s)",
                        p.nodal_loads.len(),
                        p.tractions.len(),
                        self.loads.surface_particles()
                    )
                }
            ),
        );
        if let Some(c) = &p.contact {
            plan.push(
                Stage::Contact,
                format!(
                    "Eq. 4 particle pairs, radius {:?}; {} wall/collider obstacle(s), \
                     frictionless penalty",
                    c.radius,
                    c.obstacles.len()
                ),
            );
        }
        plan.push(Stage::Solve, solve);
        plan.push(
            Stage::G2P,
            if self.adaptive.is_some() && Adaptive::<D>::needs_base(&self.materials) {
                "F update, plastic return mapping, guard checks"
            } else {
                "F update, guard checks"
            },
        );
        plan.push(Stage::Commit, "write checked updates");
        if let Some(r) = &p.reference_update {
            plan.push(
                Stage::ReferenceUpdate,
                format!("A-ULMPM trigger: epsilon = {}, eta = {}", r.epsilon, r.eta),
            );
        }
        plan
    }

    /// Elastic deformation gradients `F_E` at the start of the step.
    pub fn def_grad(&self) -> &[Matrix<D>] {
        self.particles.def_grad.as_deref().unwrap_or(&[])
    }

    /// Number of A-ULMPM reference updates so far.
    pub fn reference_updates(&self) -> u64 {
        self.adaptive.as_ref().map_or(0, |a| a.updates)
    }

    /// Stage: momentum to the reference grid (with [`Transfer::Persistent`], the node
    /// velocities of the last step when they exist).
    pub fn momentum_to_grid(&mut self) {
        if self.params.transfer == Transfer::Persistent && !self.node_velocity.is_empty() {
            self.grid_velocity.clone_from(&self.node_velocity);
            return;
        }
        let ps = &self.particles;
        transfer::momentum_to_grid(
            &self.reference,
            self.params.transfer,
            (&ps.v, &ps.affine, &ps.mass),
            &mut self.grid_velocity,
        );
    }

    /// Stage: external nodal forces `f^ext_i = m_i g + Σ_p W_i(X_p) f_p` (N), gravity (ramped
    /// where the parameters ramp it, at the start of the step) plus the applied particle forces,
    /// plus the nodal loads and tractions (ramped likewise).
    pub fn external_forces(&mut self) {
        let g = gravity_at(
            &self.params.gravity,
            self.params.gravity_ramp.as_ref(),
            self.time,
        );
        self.external.clear();
        self.external
            .extend(self.reference.node_masses().iter().map(|&m| g * m));
        if !self.particle_forces.is_empty() {
            self.reference
                .spread_forces(&self.particle_forces, &mut self.external);
        }
        self.loads.add(
            &self.params.nodal_loads,
            &self.params.tractions,
            &self.reference,
            self.time,
            &mut self.external,
        );
    }

    /// Applied per-particle forces (N), allocated as zeros on first use.
    pub fn particle_forces_mut(&mut self) -> &mut [Vector<D>] {
        if self.particle_forces.is_empty() {
            self.particle_forces = vec![Vector::<D>::zeros(); self.particles.len()];
        }
        &mut self.particle_forces
    }

    /// Stage: particle contact forces (Eq. 4) at the current positions for a step of `dt` (s),
    /// added to the external nodal forces; `None` when contact is off.
    pub fn contact(&mut self, dt: Real) -> Option<ContactStats> {
        let (stage, params) = (self.contact.as_mut()?, self.params.contact.as_ref()?);
        Some(stage.apply(
            &self.reference,
            (&self.particles.x, &self.particles.mass),
            &params.obstacles,
            dt,
            &mut self.external,
        ))
    }

    /// Guard check on the node displacements: all finite.
    pub fn check_displacements(&self) -> Result<(), Failure> {
        match self
            .displacement
            .par_iter()
            .position_first(|u| u.iter().any(|c| !c.is_finite()))
        {
            Some(i) => Err(Failure::Guard(
                Stage::Solve,
                (
                    Location::Node(self.reference.grid_index(i)),
                    Violation::NonFinite("grid velocity"),
                    self.displacement[i]
                        .iter()
                        .copied()
                        .find(|c| !c.is_finite())
                        .unwrap_or(Real::NAN),
                ),
            )),
            None => Ok(()),
        }
    }

    /// Stage: G2P into scratch storage, then the guard checks, then (A-ULMPM) the elastic
    /// deformation gradients and plastic return mapping (particles are not modified).
    pub fn grid_to_particles(&mut self, dt: Real) -> Result<(), Failure> {
        let rel = split_law(&self.models, &self.particles, self.adaptive.as_ref()).1;
        let flip = match self.params.transfer {
            Transfer::Flip { blend } => Some(FlipBlend {
                alpha: blend,
                grid_velocity: &self.grid_velocity,
                v: &self.particles.v,
            }),
            _ => None,
        };
        transfer::grid_to_particles(
            &self.reference,
            (
                &self.displacement,
                (!self.end_velocity.is_empty()).then_some(&self.end_velocity[..]),
            ),
            dt,
            (&self.particles.x, rel),
            flip,
            &mut self.updates,
        );
        let (materials, material) = (&self.materials, &self.particles.material);
        transfer::check_updates(&self.updates, |p| {
            materials[material[p] as usize].defined_for_inverted()
        })
        .map_err(Failure::guard(Stage::G2P))?;
        if let Some(a) = &mut self.adaptive {
            a.plastic_update(
                &self.updates,
                materials,
                material,
                self.particles.plastic.as_deref(),
            )
            .map_err(Failure::guard(Stage::G2P))?;
        }
        Ok(())
    }

    /// Stage (A-ULMPM, after an accepted step): when the trigger fires, moves the reference
    /// configuration to the current positions (see [`crate::adaptive`]). Returns whether it did.
    pub fn reference_update(&mut self) -> Result<bool, Failure> {
        let Some(a) = &mut self.adaptive else {
            return Ok(false);
        };
        if !a.marked().1 {
            return Ok(false);
        }
        let ps = &mut self.particles;
        let reference = ReferenceConfig::new(
            *self.reference.spec(),
            self.reference.kernel(),
            self.reference.clamp_planes(),
            &ps.x,
            &ps.mass,
        )
        .map_err(|e| {
            let p = match e {
                SetupError::ParticleOutsideGrid { index, .. } => Location::Particle(index),
                _ => Location::Global,
            };
            Failure::Guard(
                Stage::ReferenceUpdate,
                (p, Violation::LeftDomain, Real::NAN),
            )
        })?;
        ps.affine.par_iter_mut().zip(&a.rel).for_each(|(c, g)| {
            *c = Dim::<D>::inverse(g).map_or(Matrix::<D>::zeros(), |gi| *c * gi)
        });
        a.base = Some(self.particles.def_grad.clone().unwrap_or_default());
        a.rel.fill(Matrix::<D>::identity());
        a.updates += 1;
        self.constraints = Constraints::new(&reference, &self.params.fixed);
        self.reference = reference;
        self.node_velocity.clear();
        Ok(true)
    }

    /// Stage: writes the checked G2P results of a step of `dt` (s) into the particles (and the
    /// node velocities into the persistent grid state when kept).
    pub fn commit(&mut self, dt: Real) {
        if self.params.transfer == Transfer::Persistent {
            self.node_velocity.clear();
            if self.end_velocity.is_empty() {
                self.node_velocity
                    .extend(self.displacement.iter().map(|u| u / dt));
            } else {
                self.node_velocity.extend_from_slice(&self.end_velocity);
            }
        }
        let Particles {
            x,
            v,
            affine,
            def_grad,
            plastic,
            ..
        } = &mut self.particles;
        let f = def_grad.as_deref_mut().unwrap_or(&mut []);
        for (p, u) in self.updates.iter().enumerate() {
            x[p] = u.x;
            v[p] = u.v;
            affine[p] = u.affine;
        }
        match &mut self.adaptive {
            None => {
                for (fp, u) in f.iter_mut().zip(&self.updates) {
                    *fp = u.def_grad;
                }
            }
            Some(a) => {
                let plastic = plastic.as_deref_mut().unwrap_or(&mut []);
                for (p, (u, (fe, b, state))) in self.updates.iter().zip(&a.pending).enumerate() {
                    a.rel[p] = u.def_grad;
                    f[p] = *fe;
                    if let Some(base) = &mut a.base {
                        base[p] = *b;
                    }
                    if let Some(s) = plastic.get_mut(p) {
                        *s = *state;
                    }
                }
                a.refresh_hardening(
                    &self.materials,
                    &self.particles.material,
                    self.particles.plastic.as_deref(),
                );
            }
        }
    }

    /// The stable step bound (s) before `dt_max`: `cfl · Δx / max_p (|v_p| + c_p)` with the
    /// P-wave speed `c_p` when `wave`, else `cfl · Δx / max_p |v_p|`. With a fixed dt, cfl = 1.
    pub fn stable_dt(&self, wave: bool) -> Real {
        let cfl = match self.params.time_step {
            TimeStepPolicy::Adaptive { cfl, .. } => cfl,
            TimeStepPolicy::Fixed { .. } => 1.0,
        };
        let ps = &self.particles;
        let f = self.def_grad();
        let max_signal = (0..ps.len())
            .into_par_iter()
            .map(|p| {
                let c = match (&self.materials[ps.material[p] as usize], wave) {
                    (Material::Solid(s), true) => {
                        s.wave_speed(Dim::<D>::det(&f[p]), &Default::default())
                    }
                    _ => 0.0,
                };
                ps.v[p].norm() + c
            })
            .reduce(|| 0.0, nan_max);
        stable_dt(cfl, self.reference.spec().dx, max_signal, 0.0, D)
    }

    /// Chooses the step under the policy.
    pub fn choose_dt(&self, wave: bool) -> Result<Real, Failure> {
        let stable = match self.params.time_step {
            TimeStepPolicy::Fixed { .. } => Real::INFINITY,
            TimeStepPolicy::Adaptive { .. } => self.stable_dt(wave),
        };
        choose_dt(&self.params.time_step, stable).map_err(|e| Failure::Guard(Stage::TimeStep, e))
    }

    /// Runs `attempt` with `dt0` (s), halving dt after a failure as the policy allows
    /// ([`retry_halving`]); advances time and the step count on success. Returns the attempt's
    /// result, the accepted dt (s) and the number of retries.
    pub fn run_step<T>(
        &mut self,
        dt0: Real,
        mut attempt: impl FnMut(&mut Self, Real) -> Result<T, Failure>,
    ) -> Result<(T, Real, u32), StepError> {
        let (policy, start) = (self.params.on_instability, self.start());
        let r = retry_halving(policy, start, dt0, |dt| attempt(self, dt))?;
        self.time += r.1;
        self.steps += 1;
        Ok(r)
    }

    /// The start of the current step, for error reports.
    pub fn start(&self) -> StepStart {
        StepStart {
            step: self.steps,
            time: self.time,
        }
    }

    /// Mass, momenta and energies of the particles (the affine field is a reference-space
    /// gradient, so it adds no spin term), with contact on also the contact potential of Eq. 4's
    /// springs at the current positions (J), whose stiffness `μ_pq/Δt²` is that of the next
    /// step: the fixed Δt, or `min(stable(), dt_max)` with `stable` the solver's adaptive bound
    /// (s).
    pub fn diagnostics(&self, stable: impl FnOnce() -> Real) -> Diagnostics<D> {
        let mut d =
            Diagnostics::compute(&self.particles, &self.materials, None, &self.params.gravity);
        if let (Some(stage), Some(params)) = (&self.contact, &self.params.contact) {
            let dt = match self.params.time_step {
                TimeStepPolicy::Fixed { dt } => dt,
                TimeStepPolicy::Adaptive { dt_max, .. } => stable().min(dt_max),
            };
            d.contact_energy = stage.energy(
                &self.reference,
                (&self.particles.x, &self.particles.mass),
                &params.obstacles,
                dt,
            );
        }
        d
    }
}

/// The constitutive law of `particles` and their deformation gradients since the reference
/// configuration (the A-ULMPM `G` column, else the particles' F).
pub(crate) fn split_law<'a, const D: usize>(
    models: &'a [ElasticModel],
    particles: &'a Particles<D>,
    adaptive: Option<&'a Adaptive<D>>,
) -> (Constitutive<'a, D>, &'a [Matrix<D>]) {
    let law = Constitutive {
        models,
        material: &particles.material,
        volume0: &particles.volume0,
        base: adaptive.and_then(|a| a.base.as_deref()),
        hardening: adaptive.and_then(|a| a.hardening.as_deref()),
    };
    let rel = match adaptive {
        Some(a) => &a.rel[..],
        None => particles.def_grad.as_deref().unwrap_or(&[]),
    };
    (law, rel)
}

/// Checks parameters, materials and columns; returns the elastic model of every material.
fn validate<const D: usize>(
    spec: &GridSpec<D>,
    params: &TlmpmParams<D>,
    materials: &[Material],
    particles: &Particles<D>,
) -> Result<Vec<ElasticModel>, SetupError> {
    let invalid = |name, value, reason| {
        Err(SetupError::InvalidParameter {
            name,
            value,
            reason,
        })
    };
    if !(spec.dx > 0.0 && spec.dx.is_finite()) {
        return invalid("grid.dx", spec.dx, "must be positive and finite");
    }
    params.time_step.validate()?;
    if params.gravity.iter().any(|g| !g.is_finite()) {
        return invalid("gravity", Real::NAN, "must be finite");
    }
    if let Some((name, value, reason)) = params.damping.invalid() {
        return invalid(name, value, reason);
    }
    if let Transfer::Flip { blend } = params.transfer {
        if !(0.0..=1.0).contains(&blend) {
            return invalid("flip blend", blend, "must lie in [0, 1]");
        }
    }
    if let Some(r) = params.gravity_ramp {
        if !(r.duration > 0.0 && r.duration.is_finite()) {
            return invalid("gravity ramp", r.duration, "must be a positive finite time");
        }
    }
    if let Some(c) = &params.contact {
        if let ContactRadius::Fixed(r) = c.radius {
            if !(r > 0.0 && r.is_finite()) {
                return invalid("contact.radius", r, "must be positive and finite");
            }
        }
    }
    if let Some(u) = &params.reference_update {
        if u.epsilon.is_nan() || u.epsilon < 0.0 {
            return invalid("reference_update.epsilon", u.epsilon, "must be at least 0");
        }
        if !(0.0..=1.0).contains(&u.eta) {
            return invalid("reference_update.eta", u.eta, "must lie in [0, 1]");
        }
    }
    let placeholder = ElasticModel::LinearElastic(Lame {
        mu: 0.0,
        lambda: 0.0,
    });
    let mut models = Vec::with_capacity(materials.len());
    for (k, m) in materials.iter().enumerate() {
        let used = particles.material.iter().any(|&i| i as usize == k);
        match m {
            Material::Solid(s)
                if matches!(s.plasticity, Plasticity::None)
                    || params.reference_update.is_some() =>
            {
                models.push(s.elastic);
            }
            _ if !used => models.push(placeholder),
            Material::Solid(_) => {
                return invalid(
                    "material.plasticity",
                    k as Real,
                    "plastic solids need A-ULMPM reference updates (reference_update)",
                );
            }
            Material::Fluid(_) => {
                return invalid("material.kind", k as Real, "TLMPM supports solids only");
            }
        }
        if used && particles.def_grad.is_none() {
            return Err(SetupError::MissingColumn {
                material: k,
                column: "F",
            });
        }
        if used && m.needs_plastic_state() && particles.plastic.is_none() {
            return Err(SetupError::MissingColumn {
                material: k,
                column: "plastic",
            });
        }
    }
    for (p, &material) in particles.material.iter().enumerate() {
        let (m, v) = (particles.mass[p], particles.volume0[p]);
        if !(m > 0.0 && m.is_finite()) {
            return invalid("particle.mass", m, "must be positive and finite");
        }
        if !(v > 0.0 && v.is_finite()) {
            return invalid("particle.volume0", v, "must be positive and finite");
        }
        if material as usize >= materials.len() {
            return Err(SetupError::UnknownMaterial {
                index: p,
                material,
                count: materials.len(),
            });
        }
    }
    Ok(models)
}
