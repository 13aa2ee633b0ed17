//! The solver seam both TLMPM solvers share: the [`TotalLagrangian`] trait and [`build`], the
//! `solver_seam!` macro (their [`Solver`] and [`TotalLagrangian`] implementations), the
//! `shared_accessors!` macro (their common inherent accessors) and [`step_info`].

use crate::contact::ContactStats;
use crate::params::{ImplicitParams, TlmpmParams};
use crate::reference::ReferenceConfig;
use crate::{ExplicitTlmpm, ImplicitTlmpm};
use mpm_core::solver::{SolveInfo, StepInfo};
use mpm_core::{Dim, DimOps, GridSpec, Material, Particles, Real, SetupError, Solver, Vector};

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

            fn region(&self) -> mpm_core::Region<D> {
                let spec = self.core.reference.spec();
                let obstacles = self.core.params.contact.iter().flat_map(|c| &c.obstacles);
                let walls = obstacles.into_iter().find_map(|o| match o {
                    crate::Obstacle::Walls { min, max } => Some((*min, *max)),
                    _ => None,
                });
                mpm_core::Region {
                    interior: mpm_core::sampling::interior(spec, self.core.params.kernel),
                    walls,
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

/// The accessors both solvers expose over their shared [`Core`](super::Core); expanded inside
/// each solver's `impl` block (the solver must have a `core: Core<D>` field).
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
