//! State and stages shared by the implicit and the explicit TLMPM solvers: the [`Core`] both
//! hold and its stage methods. The solver seam they share (the `solver_seam!` and
//! `shared_accessors!` macros, [`TotalLagrangian`], [`build`]) is in `seam`, the state beyond
//! the particle columns and checkpoint/restore of the core in `state`.

mod seam;
mod state;

pub use seam::{build, TotalLagrangian};
pub(crate) use seam::{shared_accessors, solver_seam, step_info};
pub use state::TlmpmState;
pub(crate) use state::{misfit, state_from};

use crate::adaptive::Adaptive;
use crate::contact::{ContactRadius, ContactStage, ContactStats};
use crate::error::{NewtonError, StepError};
use crate::loads::AppliedLoads;
use crate::parameters::{
    CONTACT_RADIUS, FLIP_BLEND, GRID_DX, MATERIAL_KIND, MATERIAL_PLASTICITY, PARTICLE_MASS,
    PARTICLE_VOLUME0, REFERENCE_UPDATE_EPSILON, REFERENCE_UPDATE_ETA,
};
use crate::params::{TlmpmParams, Transfer};
use crate::potential::Constitutive;
use crate::reference::{Constraints, ReferenceConfig};
use crate::transfer::{self, FlipBlend, Update};
use mpm_core::material::{ElasticModel, Lame, Plasticity};
use mpm_core::parameters::GRAVITY;
use mpm_core::quasistatic::gravity_at;
use mpm_core::solver::nan_max;
use mpm_core::timestep::{choose_dt, stable_dt};
use mpm_core::{
    retry_halving, Diagnostics, Dim, DimOps, GridSpec, Location, Material, Matrix, Particles, Real,
    SetupError, Stage, StagePlan, StepStart, TimeStepPolicy, Vector, Violation,
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

    /// The stage plan of one step, only the stages these parameters use; `solve` describes the
    /// grid solve (Newton, or the explicit update) and `bound` the time-step bound.
    pub fn plan(&self, solve: String, bound: &str) -> StagePlan {
        let p = &self.params;
        let mut plan = StagePlan::default();
        plan.push(
            crate::stages::REFERENCE,
            "at set-up: weights, gradients, connectivity and node masses of the reference \
             configuration",
        );
        plan.push(Stage::TIME_STEP, p.step.time_step.describe(bound));
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
            crate::stages::EXTERNAL_FORCES,
            format!(
                "gravity {:?} m/s^2{}{}{}",
                p.step.gravity.as_slice(),
                p.step.gravity_ramp.map_or(String::new(), |r| format!(
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
                crate::stages::CONTACT,
                format!(
                    "Eq. 4 particle pairs, radius {:?}; {} wall/collider obstacle(s), \
                     frictionless penalty",
                    c.radius,
                    c.obstacles.len()
                ),
            );
        }
        plan.push(Stage::SOLVE, solve);
        plan.push(
            Stage::G2P,
            if self.adaptive.is_some() && Adaptive::<D>::needs_base(&self.materials) {
                "F update, plastic return mapping, guard checks"
            } else {
                "F update, guard checks"
            },
        );
        plan.push(Stage::COMMIT, "write checked updates");
        if let Some(r) = &p.reference_update {
            plan.push(
                crate::stages::REFERENCE_UPDATE,
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
            &self.params.step.gravity,
            self.params.step.gravity_ramp.as_ref(),
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

    /// The contact forces at the end-of-step positions of the last G2P ([`Self::updates`],
    /// scratch) for a step of `dt` (s), added to the external nodal forces; `None` when contact
    /// is off.
    pub fn contact_at_step_end(&mut self, dt: Real) -> Option<ContactStats> {
        let (stage, params) = (self.contact.as_mut()?, self.params.contact.as_ref()?);
        let x: Vec<Vector<D>> = self.updates.iter().map(|u| u.x).collect();
        Some(stage.apply(
            &self.reference,
            (&x, &self.particles.mass),
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
                Stage::SOLVE,
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
                crate::stages::REFERENCE_UPDATE,
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
        let cfl = match self.params.step.time_step {
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
        let stable = match self.params.step.time_step {
            TimeStepPolicy::Fixed { .. } => Real::INFINITY,
            TimeStepPolicy::Adaptive { .. } => self.stable_dt(wave),
        };
        choose_dt(&self.params.step.time_step, stable)
            .map_err(|e| Failure::Guard(Stage::TIME_STEP, e))
    }

    /// Runs `attempt` with `dt0` (s), halving dt after a failure as the policy allows
    /// ([`retry_halving`]); advances time and the step count on success. Returns the attempt's
    /// result, the accepted dt (s) and the number of retries.
    pub fn run_step<T>(
        &mut self,
        dt0: Real,
        mut attempt: impl FnMut(&mut Self, Real) -> Result<T, Failure>,
    ) -> Result<(T, Real, u32), StepError> {
        let (policy, start) = (self.params.step.on_instability, self.start());
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
        let mut d = Diagnostics::compute(
            &self.particles,
            &self.materials,
            None,
            &self.params.step.gravity,
        );
        if let (Some(stage), Some(params)) = (&self.contact, &self.params.contact) {
            let dt = match self.params.step.time_step {
                TimeStepPolicy::Fixed { dt } => dt,
                TimeStepPolicy::Adaptive { dt_max, .. } => stable().min(dt_max),
            };
            let energy = stage.energy(
                &self.reference,
                (&self.particles.x, &self.particles.mass),
                &params.obstacles,
                dt,
            );
            d = d.with_energy(crate::contact::CONTACT_ENERGY, energy);
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
        return invalid(GRID_DX, spec.dx, "must be positive and finite");
    }
    params.step.time_step.validate()?;
    if params.step.gravity.iter().any(|g| !g.is_finite()) {
        return invalid(GRAVITY, Real::NAN, "must be finite");
    }
    if let Some((name, value, reason)) = params.step.damping.invalid() {
        return invalid(name, value, reason);
    }
    if let Transfer::Flip { blend } = params.transfer {
        if !(0.0..=1.0).contains(&blend) {
            return invalid(FLIP_BLEND, blend, "must lie in [0, 1]");
        }
    }
    if let Some((name, value, reason)) = params.step.gravity_ramp.and_then(|r| r.invalid()) {
        return invalid(name, value, reason);
    }
    if let Some(c) = &params.contact {
        if let ContactRadius::Fixed(r) = c.radius {
            if !(r > 0.0 && r.is_finite()) {
                return invalid(CONTACT_RADIUS, r, "must be positive and finite");
            }
        }
    }
    if let Some(u) = &params.reference_update {
        if u.epsilon.is_nan() || u.epsilon < 0.0 {
            return invalid(REFERENCE_UPDATE_EPSILON, u.epsilon, "must be at least 0");
        }
        if !(0.0..=1.0).contains(&u.eta) {
            return invalid(REFERENCE_UPDATE_ETA, u.eta, "must lie in [0, 1]");
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
                    MATERIAL_PLASTICITY,
                    k as Real,
                    "plastic solids need A-ULMPM reference updates (reference_update)",
                );
            }
            Material::Fluid(_) => {
                return invalid(MATERIAL_KIND, k as Real, "TLMPM supports solids only");
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
            return invalid(PARTICLE_MASS, m, "must be positive and finite");
        }
        if !(v > 0.0 && v.is_finite()) {
            return invalid(PARTICLE_VOLUME0, v, "must be positive and finite");
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
