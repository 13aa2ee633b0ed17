//! Implicit TLMPM: backward Euler or Newmark average acceleration on the reference grid, solved
//! by Newton's method.
//!
//! **Backward Euler** ([`TimeScheme::BackwardEuler`], the default) minimises
//! `E(u) = Σ_i m_i/(2Δt²) ‖u_i − Δt v̂_i‖² + Σ_p V⁰_p ψ(F_p(u)) − Σ_i f^ext_i · u_i` over the
//! node displacements `u = x^{n+1} − x^n = Δt v^{n+1}`; it is first order and damps every mode
//! with `ωΔt ≳ 1` (a cantilever's first swing is 3–12% low at 10× the explicit step).
//!
//! **Newmark average acceleration** ([`TimeScheme::Newmark`], β = 1/4, γ = 1/2) is second order
//! and, for linear problems, conserves the discrete energy `½ vᵀMv + ½ uᵀKu` for any Δt. Its
//! relations `x^{n+1} = x^n + Δt v^n + Δt²/4 (a^n + a^{n+1})` and
//! `v^{n+1} = v^n + Δt/2 (a^n + a^{n+1})` give, with `u = x^{n+1} − x^n`,
//! `a^{n+1} = 4(u − Δt v^n)/Δt² − a^n` and `v^{n+1} = 2u/Δt − v^n`. Equilibrium at the end of
//! the step, `M a^{n+1} = f^ext + f(x^n + u)` with `f` the internal force of Eq. 3, is then
//! `4M/Δt² (u − û) − f^ext − f(x^n + u) = 0` with `û = Δt v^n + Δt²/4 a^n`: the gradient of
//! the potential above with the inertia coefficient `4/Δt²` instead of `1/Δt²` and the prediction
//! `û` instead of `Δt v̂`. It stays a minimisation with the SPD Hessian `4M/Δt² + K`, so the
//! line search, the SPD projection and both linear solvers apply unchanged.
//!
//! *Where `a^n` comes from.* It is not stored: each step evaluates it from the start-of-step
//! state by equilibrium, `a_i^n = (f_i(x^n) + f^ext_i)/m_i`, from the particles' `F^n` (the
//! internal force of `u = 0`) and this step's external forces. After a converged Newmark step this
//! equals the stored-acceleration recurrence up to Newton's tolerance (the recurrence *is* that
//! equilibrium), and the first step starts from the equilibrium `a⁰` as usual. The reasons:
//! with the APIC, PIC and FLIP transfers the grid is rebuilt from the particles every step, so
//! node accelerations would have to be transferred as a further particle column; recomputing
//! them keeps the checkpoint state exactly that of backward Euler (particle columns plus, with
//! [`crate::Transfer::Persistent`], the node velocities), so resuming stays bitwise with nothing
//! new to save; and it costs one internal-force evaluation per step (a Newton iteration costs a
//! factorisation). The external force therefore enters at its start-of-step value in both
//! halves, as backward Euler uses it. The end-of-step node velocities `v^{n+1} = 2u/Δt − v̂`
//! (prescribed components: their prescribed velocity) go to G2P for `v_p` and `C_p`; positions
//! and `F_p` follow `u`. The DIQ coupling stages ([`ImplicitTlmpm::elastic_predictor`] and the
//! others) use backward-Euler semantics (`v = u/Δt`).

use crate::assembly::{assemble, hessian_pattern};
use crate::contact::ContactStats;
use crate::core::{split_law, step_info, Core, Failure, NewtonTimes, TlmpmState};
use crate::error::StepError;
use crate::newton::{minimize, Forces, Indefinite, NewtonInfo, NewtonWork, Objective};
use crate::params::{ImplicitParams, LinearSolver, TimeScheme, TlmpmParams};
use crate::potential::{deformation, internal_force, tensor_len, Potential};
use crate::reference::{Constraints, ReferenceConfig};
use mpm_core::solver::{on_pool, SolveInfo, StageTime, StepInfo};
use mpm_core::{
    Diagnostics, Dim, DimOps, GridSpec, Location, Material, Matrix, Particles, Real, SetupError,
    Stage, StagePlan, StageTimes, Vector, Violation,
};
use mpm_linalg::{
    conjugate_gradient, CgError, CgParams, CgWorkspace, CholeskyError, InitialGuess, Jacobi,
    OnIterationCap, SparseCholesky, SymmetricMatrix,
};
use std::time::Instant;

/// The assembled Newton system for the Cholesky solver: the matrix (pattern and values), the
/// right-hand side and the factorisation whose symbolic part was computed once.
#[derive(Debug)]
struct SparseSystem {
    matrix: SymmetricMatrix,
    cholesky: SparseCholesky,
    rhs: Vec<Real>,
}

/// Scratch memory used by the potential's evaluations and the linear solvers.
#[derive(Debug, Default)]
struct ObjectiveWork<const D: usize> {
    def_grad: Vec<Matrix<D>>,
    stress: Vec<Matrix<D>>,
    stress_scale: Vec<Real>,
    particle: Vec<Real>,
    magnitude: Vec<[Real; 4]>,
    tensors: Vec<Real>,
    sparse: Option<SparseSystem>,
    jacobi: Jacobi<Vector<D>>,
    rhs: Vec<Vector<D>>,
    cg: CgWorkspace<Vector<D>>,
    /// Whether `sparse` holds the numeric Cholesky factor of a tangent of the current attempt.
    factored: bool,
    /// Chord iterations: directions reuse that factor instead of a new tangent.
    frozen: bool,
}

/// Scratch memory of the implicit solver, reused by every step.
#[derive(Debug, Default)]
struct Workspace<const D: usize> {
    target: Vec<Vector<D>>,
    /// The alternative initial guess `Δt v̂` (m), constraints applied.
    coast: Vec<Vector<D>>,
    /// Residual `∇E` (N) at the state of the last `ImplicitTlmpm::linearize`.
    #[cfg(feature = "bench")]
    probe_residual: Vec<Vector<D>>,
    /// Time step (s) of the last `ImplicitTlmpm::linearize`.
    #[cfg(feature = "bench")]
    probe_dt: Real,
    newton: NewtonWork<D>,
    objective: ObjectiveWork<D>,
}

/// Implicit total-Lagrangian MPM (diq-mpm §3.1): the elastic grid update is a backward-Euler
/// step, found by minimising the incremental potential (see [`crate`] docs) with Newton's method.
#[derive(Debug)]
pub struct ImplicitTlmpm<const D: usize> {
    core: Core<D>,
    implicit: ImplicitParams,
    stats: StageTimes,
    newton_times: NewtonTimes,
    ws: Workspace<D>,
    /// The Newton solve and the contact stage of the last accepted step.
    last: (NewtonInfo, Option<ContactStats>),
}

impl<const D: usize> ImplicitTlmpm<D>
where
    Dim<D>: DimOps<D>,
{
    /// Builds a solver. The particles' current positions become the reference configuration:
    /// their weights, gradients, node masses, the sparsity pattern and (for the Cholesky solver)
    /// the symbolic factorisation are computed here, once. Particles need the deformation-gradient
    /// column, materials must be elastic solids, and every stencil must fit in the grid `spec`.
    pub fn new(
        spec: GridSpec<D>,
        params: TlmpmParams<D>,
        implicit: ImplicitParams,
        materials: Vec<Material>,
        particles: Particles<D>,
    ) -> Result<Self, SetupError> {
        let t = Instant::now();
        if let Some((name, value)) = params.step.damping.first_on() {
            return Err(SetupError::InvalidParameter {
                name,
                value,
                reason: "applies to explicit TLMPM only (the implicit step has no damping term)",
            });
        }
        let core = Core::new(spec, params, materials, particles)?;
        let mut solver = Self {
            core,
            implicit,
            stats: StageTimes::default(),
            newton_times: NewtonTimes::default(),
            ws: Workspace::default(),
            last: (NewtonInfo::default(), None),
        };
        if implicit.linear == LinearSolver::Cholesky {
            solver.analyse().map_err(|e| SetupError::InvalidParameter {
                name: crate::parameters::LINEAR_SOLVER,
                value: Real::NAN,
                reason: match e {
                    CholeskyError::Backend(_) => "symbolic Cholesky analysis failed",
                    _ => "invalid sparsity pattern",
                },
            })?;
        }
        solver.stats.add(crate::stages::REFERENCE, t.elapsed());
        Ok(solver)
    }

    /// Builds the sparsity pattern and the symbolic factorisation (once, and again after each
    /// A-ULMPM reference update).
    fn analyse(&mut self) -> Result<(), CholeskyError> {
        if self.ws.objective.sparse.is_some() {
            return Ok(());
        }
        let pattern = hessian_pattern(&self.core.reference, &self.core.constraints)?;
        let cholesky = SparseCholesky::new(&pattern)?;
        self.ws.objective.sparse = Some(SparseSystem {
            rhs: vec![0.0; pattern.dim()],
            matrix: SymmetricMatrix::new(pattern),
            cholesky,
        });
        Ok(())
    }

    /// [`mpm_core::Solver::step`] on the calling thread: on a failed guard check or Newton
    /// failure the step is retried with dt/2 when the policy allows it; otherwise the error
    /// names the step and what failed. A failed step leaves the particles untouched.
    fn advance_step(&mut self) -> Result<StepInfo, StepError> {
        let start = self.core.start();
        if self.implicit.linear == LinearSolver::Cholesky {
            self.analyse()
                .map_err(|e| start.error(Failure::Solve(Stage::SOLVE, linear_error(e)), 0.0, 0))?;
        }
        let core = &self.core;
        let dt0 = self
            .stats
            .time(Stage::TIME_STEP, || core.choose_dt(false))
            .map_err(|f| start.error(f, 0.0, 0))?;
        let (ws, stats, times, implicit) = (
            &mut self.ws,
            &mut self.stats,
            &mut self.newton_times,
            self.implicit,
        );
        let ((newton, contact), dt, retries) = self.core.run_step(dt0, |core, dt| {
            advance(core, ws, stats, times, &implicit, dt)
        })?;
        let core = &mut self.core;
        let reference_updated = self
            .stats
            .time(crate::stages::REFERENCE_UPDATE, || core.reference_update())
            .map_err(|f| start.error(f, dt, retries))?;
        if reference_updated {
            self.ws.objective.sparse = None;
        }
        let solve = SolveInfo {
            name: "newton",
            iterations: newton.iterations,
            residual: newton.residuals.last().copied().unwrap_or(0.0),
        };
        let history = ("newton", newton.residuals.clone());
        self.last = (newton, contact);
        Ok(step_info(
            (dt, retries, self.core.time),
            (vec![solve], vec![history]),
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
        self.ws.objective.sparse = None;
        Ok(())
    }

    /// Newton and linear-solver parameters.
    pub fn implicit_params(&self) -> &ImplicitParams {
        &self.implicit
    }

    /// Wall time accumulated per stage.
    pub fn stats(&self) -> &StageTimes {
        &self.stats
    }

    /// Wall time inside Newton's method, by kind of work (part of stage `solve`).
    pub fn newton_times(&self) -> &NewtonTimes {
        &self.newton_times
    }

    /// The stages each step runs, in order, for this solver's parameters (only those it
    /// uses).
    pub fn stage_plan(&self) -> StagePlan {
        let n = &self.implicit.newton;
        self.core.plan(
            format!(
                "Newton on the {} incremental potential: {:?} linear solver, at most \
                 {} iterations, rel_tol {:e}, abs_tol {:e} N, SPD projection {:?}",
                match self.implicit.scheme {
                    TimeScheme::BackwardEuler => "backward-Euler",
                    TimeScheme::Newmark => "Newmark average-acceleration",
                },
                self.implicit.linear,
                n.max_iterations,
                n.rel_tol,
                n.abs_tol,
                n.projection
            ),
            "dx / max|v|",
        )
    }

    /// Number of unknowns of the Newton system (free scalar components, partly fixed nodes
    /// counting all `D`).
    pub fn num_equations(&self) -> usize {
        self.core.constraints.dofs.len() * D
    }

    /// The step bound (s) of the adaptive policy before `dt_max`, `cfl · Δx / max_p |v_p|`.
    pub fn stable_dt(&self) -> Real {
        self.core.stable_dt(false)
    }
}

/// Sets the inertial prediction `û` (m) into `target` and Newton's initial guess into
/// `core.displacement` for a step of `dt` (s), after P2G, external forces and contact. Backward
/// Euler: `û_i = Δt v̂_i`, guess `Δt (v̂_i + Δt f^ext_i/m_i)` (the explicit predictor without
/// internal forces). Newmark: `û_i = Δt v̂_i + Δt²/4 a_i^n` and the constant-acceleration guess
/// `Δt v̂_i + Δt²/2 a_i^n` with `a_i^n = (f_i(x^n) + f^ext_i)/m_i`, the internal force from the
/// weighted stresses at the start-of-step F (written into `stress`). Prescribed components get
/// their prescribed motion.
fn start_step<const D: usize>(
    core: &mut Core<D>,
    target: &mut Vec<Vector<D>>,
    stress: &mut Vec<Matrix<D>>,
    scheme: TimeScheme,
    dt: Real,
) where
    Dim<D>: DimOps<D>,
{
    let (vh, external, constraints) = (&core.grid_velocity, &core.external, &core.constraints);
    let masses = core.reference.node_masses();
    let displacement = &mut core.displacement;
    target.clear();
    displacement.clear();
    match scheme {
        TimeScheme::BackwardEuler => {
            target.extend(vh.iter().map(|v| v * dt));
            displacement.extend((0..masses.len()).map(|i| {
                let free = (vh[i] + external[i] * (dt / masses[i])) * dt;
                constraints.displacement(i, free, dt)
            }));
        }
        TimeScheme::Newmark => {
            let (law, def_grad) = split_law(&core.models, &core.particles, core.adaptive.as_ref());
            stress.resize(def_grad.len(), Matrix::<D>::zeros());
            law.weighted_stresses(def_grad, stress);
            for (i, &m) in masses.iter().enumerate() {
                let a = (internal_force(&core.reference, stress, i).0 + external[i]) / m;
                let v = vh[i] * dt;
                target.push(v + a * (0.25 * dt * dt));
                displacement.push(constraints.displacement(i, v + a * (0.5 * dt * dt), dt));
            }
        }
    }
}

/// The end-of-step node velocities of `scheme` into `core.end_velocity` (m/s), from the solved
/// displacements of a step of `dt` (s): Newmark `v_i = 2u_i/Δt − v̂_i` (the prescribed velocity on
/// prescribed components); empty for backward Euler, whose G2P uses `u/Δt`.
fn end_velocities<const D: usize>(core: &mut Core<D>, scheme: TimeScheme, dt: Real) {
    core.end_velocity.clear();
    if scheme == TimeScheme::Newmark {
        let (c, u, vh) = (&core.constraints, &core.displacement, &core.grid_velocity);
        core.end_velocity
            .extend((0..u.len()).map(|i| c.displacement(i, u[i] * 2.0 - vh[i] * dt, dt) / dt));
    }
}

fn linear_error(e: CholeskyError) -> crate::error::NewtonError {
    crate::error::NewtonError::LinearSolver {
        iteration: 0,
        message: e.to_string(),
    }
}

/// One attempt at a step of size `dt`: the stage plan.
fn advance<const D: usize>(
    core: &mut Core<D>,
    ws: &mut Workspace<D>,
    stats: &mut StageTimes,
    times: &mut NewtonTimes,
    implicit: &ImplicitParams,
    dt: Real,
) -> Result<(NewtonInfo, Option<ContactStats>), Failure>
where
    Dim<D>: DimOps<D>,
{
    let (newton, contact) = predict(core, ws, stats, times, implicit, dt)?;
    stats.time(Stage::G2P, || core.grid_to_particles(dt))?;
    stats.time(Stage::COMMIT, || core.commit(dt));
    Ok((newton, contact))
}

/// The stages of an attempt up to the elastic solve: P2G, external forces, contact, Newton.
fn predict<const D: usize>(
    core: &mut Core<D>,
    ws: &mut Workspace<D>,
    stats: &mut StageTimes,
    times: &mut NewtonTimes,
    implicit: &ImplicitParams,
    dt: Real,
) -> Result<(NewtonInfo, Option<ContactStats>), Failure>
where
    Dim<D>: DimOps<D>,
{
    stats.time(Stage::P2G, || core.momentum_to_grid());
    stats.time(crate::stages::EXTERNAL_FORCES, || core.external_forces());
    let trapezoidal = implicit.scheme == TimeScheme::Newmark && core.contact.is_some();
    let base = trapezoidal.then(|| core.external.clone());
    let contact = stats.time(crate::stages::CONTACT, || core.contact(dt));
    let mut newton = stats.time(Stage::SOLVE, || {
        solve_grid(core, ws, times, implicit, dt, None)
    })?;
    if let Some(base) = base {
        let touching = contact.is_some_and(|c| c.touching());
        newton = stats.time(Stage::SOLVE, || {
            newmark_contact::end_of_step_contact(
                core,
                ws,
                times,
                implicit,
                dt,
                (&base, newton, touching),
            )
        })?;
    }
    Ok((newton, contact))
}

/// Most chord iterations of [`ImplicitTlmpm::resolve_with_node_forces`] before it falls back to
/// Newton's method.
const CHORD_ITERATIONS: u32 = 8;

/// Stage: Newton on the incremental potential of the time scheme for the node displacements,
/// from the scheme's predictor or, when given, from the displacements `warm` (m).
fn solve_grid<const D: usize>(
    core: &mut Core<D>,
    ws: &mut Workspace<D>,
    times: &mut NewtonTimes,
    implicit: &ImplicitParams,
    dt: Real,
    warm: Option<&[Vector<D>]>,
) -> Result<NewtonInfo, Failure>
where
    Dim<D>: DimOps<D>,
{
    // A warm start re-solves the same step under other forces: the inertial prediction stays
    // (Newmark's `a^n` is that of the start-of-step forces) and Newton starts from `warm`.
    match warm {
        None => start_step(
            core,
            &mut ws.target,
            &mut ws.objective.stress,
            implicit.scheme,
            dt,
        ),
        Some(w) => core.displacement.copy_from_slice(w),
    }
    let Core {
        reference,
        constraints,
        models,
        particles,
        external,
        displacement,
        adaptive,
        grid_velocity,
        ..
    } = core;
    let (law, def_grad) = split_law(models, particles, adaptive.as_ref());
    let mut problem = Problem {
        pot: Potential {
            reference,
            constraints,
            law,
            def_grad,
            target: &ws.target,
            external,
            inertia: implicit.scheme.inertia(dt),
        },
        linear: implicit.linear,
        ws: &mut ws.objective,
        times,
        deformed: None,
    };
    // Newton starts from the scheme's predictor or, when it has the lower incremental potential,
    // from the motion at the current velocities (`Δt v̂`): the predictor leaves out the internal
    // forces, so under a load they already balance it overshoots by `Δt² f^ext/m` per step.
    let predicted = problem.energy(displacement);
    if warm.is_none() {
        ws.coast.clear();
        ws.coast.extend(
            (grid_velocity.iter().enumerate())
                .map(|(i, v)| constraints.displacement(i, v * dt, dt)),
        );
        if let Some(coast) = problem.energy(&ws.coast) {
            if predicted.is_none_or(|p| coast.0 < p.0) {
                displacement.clone_from(&ws.coast);
            }
        }
    }
    if predicted.is_none() && problem.energy(displacement).is_none() {
        // Neither start is valid (an inverted element): start from rest on the free components.
        for (i, u) in displacement.iter_mut().enumerate() {
            *u = constraints.displacement(i, Vector::<D>::zeros(), dt);
        }
        if problem.energy(displacement).is_none() {
            return Err(Failure::Guard(Stage::SOLVE, problem.first_bad_particle()));
        }
    }
    let info = minimize(&mut problem, &implicit.newton, displacement, &mut ws.newton)
        .map_err(|e| Failure::Solve(Stage::SOLVE, e))?;
    core.check_displacements()?;
    end_velocities(core, implicit.scheme, dt);
    Ok(info)
}

/// The Newton direction `d = −H⁻¹ r` (m) with the Cholesky factor held by `sys`, on the free
/// components of the active nodes (`r`: the residual, N).
fn solve_factored<const D: usize>(
    sys: &mut SparseSystem,
    constraints: &Constraints<D>,
    r: &[Vector<D>],
    d: &mut [Vector<D>],
) -> Result<(), String> {
    let nodes = constraints.dofs.nodes();
    for (e, &j) in nodes.iter().enumerate() {
        for a in 0..D {
            sys.rhs[e * D + a] = -r[j][a];
        }
    }
    sys.cholesky
        .solve_in_place(&mut sys.rhs)
        .map_err(|e| e.to_string())?;
    d.iter_mut().for_each(|x| *x = Vector::<D>::zeros());
    for (e, &j) in nodes.iter().enumerate() {
        let x = Vector::<D>::from_fn(|a, _| sys.rhs[e * D + a]);
        d[j] = x.component_mul(&constraints.mask[j]);
    }
    Ok(())
}

/// The incremental potential of one step with the scratch memory and linear solver that
/// evaluate it.
struct Problem<'a, const D: usize> {
    pot: Potential<'a, D>,
    linear: LinearSolver,
    ws: &'a mut ObjectiveWork<D>,
    times: &'a mut NewtonTimes,
    /// The displacements `ws.def_grad` was last computed from in this solve: Newton evaluates
    /// the energy, the gradient and the tangent at the same point in turn.
    deformed: Option<Vec<Vector<D>>>,
}

impl<const D: usize> Problem<'_, D>
where
    Dim<D>: DimOps<D>,
{
    /// The lowest particle whose energy density is not finite at the last evaluated F.
    fn first_bad_particle(&self) -> (Location, Violation, Real) {
        let f = &self.ws.def_grad;
        for (p, fp) in f.iter().enumerate() {
            let j = Dim::<D>::det(&self.pot.law.elastic(p, fp));
            if !self.pot.law.energy(p, fp).is_finite() {
                return if j <= 0.0 {
                    (Location::Particle(p), Violation::InvertedElement, j)
                } else {
                    (
                        Location::Particle(p),
                        Violation::NonFinite("energy density"),
                        j,
                    )
                };
            }
        }
        (
            Location::Global,
            Violation::NonFinite("incremental potential"),
            Real::NAN,
        )
    }

    fn update_deformation(&mut self, u: &[Vector<D>]) {
        if self.deformed.as_deref() == Some(u) {
            return;
        }
        let key = self.deformed.get_or_insert_with(Vec::new);
        key.clear();
        key.extend_from_slice(u);
        let n = self.pot.reference.num_particles();
        self.ws.def_grad.resize(n, Matrix::<D>::zeros());
        deformation(
            self.pot.reference,
            self.pot.def_grad,
            u,
            &mut self.ws.def_grad,
        );
    }
}

impl<const D: usize> Objective<D> for Problem<'_, D>
where
    Dim<D>: DimOps<D>,
{
    fn chord_direction(&mut self, r: &[Vector<D>], d: &mut [Vector<D>]) -> Option<()> {
        if !self.ws.factored {
            return None;
        }
        let t = Instant::now();
        let sys = self.ws.sparse.as_mut()?;
        solve_factored(sys, self.pot.constraints, r, d).ok()?;
        self.times.linear_solve += t.elapsed();
        Some(())
    }

    fn energy(&mut self, u: &[Vector<D>]) -> Option<(Real, Real)> {
        let t = Instant::now();
        self.update_deformation(u);
        self.ws.particle.resize(self.ws.def_grad.len(), 0.0);
        let e = self.pot.energy(u, &self.ws.def_grad, &mut self.ws.particle);
        self.times.energy += t.elapsed();
        e
    }

    fn gradient(&mut self, u: &[Vector<D>], out: &mut [Vector<D>]) -> Forces {
        let t = Instant::now();
        self.update_deformation(u);
        let n = self.ws.def_grad.len();
        self.ws.stress.resize(n, Matrix::<D>::zeros());
        self.pot
            .law
            .weighted_stresses(&self.ws.def_grad, &mut self.ws.stress);
        self.ws.stress_scale.resize(n, 0.0);
        self.pot
            .law
            .stress_scales(&self.ws.def_grad, &mut self.ws.stress_scale);
        self.ws.magnitude.resize(u.len(), [0.0; 4]);
        let forces = self.pot.gradient(
            u,
            (&self.ws.stress, &self.ws.stress_scale),
            out,
            &mut self.ws.magnitude,
        );
        self.times.gradient += t.elapsed();
        forces
    }

    fn direction(
        &mut self,
        u: &[Vector<D>],
        r: &[Vector<D>],
        d: &mut [Vector<D>],
        project: bool,
        exact: bool,
    ) -> Result<Result<u32, Indefinite>, String> {
        if self.ws.frozen {
            return self
                .chord_direction(r, d)
                .map(|()| Ok(0))
                .ok_or_else(|| "no factor to reuse".into());
        }
        let t = Instant::now();
        self.update_deformation(u);
        let np = self.ws.def_grad.len();
        self.ws.tensors.resize(np * tensor_len(D), 0.0);
        self.pot
            .tensors(&self.ws.def_grad, project, &mut self.ws.tensors);
        self.times.tangent += t.elapsed();
        let ObjectiveWork {
            stress,
            tensors,
            sparse,
            jacobi,
            rhs,
            cg,
            factored,
            ..
        } = &mut *self.ws;
        let pot = &self.pot;
        match self.linear {
            LinearSolver::Cholesky => {
                let Some(sys) = sparse.as_mut() else {
                    return Err("sparse system not analysed".into());
                };
                let t = Instant::now();
                assemble(pot, tensors, &mut sys.matrix);
                self.times.assembly += t.elapsed();
                let t = Instant::now();
                // f32 first unless asked for f64; an f32 failure (ill conditioning) retries
                // in f64 before the tangent counts as indefinite.
                let single = !exact && sys.cholesky.factorize_single(&sys.matrix).is_ok();
                let factor = if single {
                    Ok(())
                } else {
                    sys.cholesky.factorize(&sys.matrix)
                };
                self.times.factorization += t.elapsed();
                *factored = factor.is_ok();
                match factor {
                    Ok(()) => {}
                    Err(CholeskyError::NotPositiveDefinite { .. }) => return Ok(Err(Indefinite)),
                    Err(e) => return Err(e.to_string()),
                }
                let t = Instant::now();
                solve_factored(sys, pot.constraints, r, d)?;
                self.times.linear_solve += t.elapsed();
                Ok(Ok(0))
            }
            LinearSolver::Cg {
                max_iterations,
                rel_tol,
            } => {
                let t = Instant::now();
                let inv_diag = jacobi.inverse_diagonal_mut();
                inv_diag.resize(u.len(), Vector::<D>::zeros());
                pot.inverse_diagonal(tensors, inv_diag);
                rhs.clear();
                rhs.extend(r.iter().map(|x| -x));
                stress.resize(np, Matrix::<D>::zeros());
                // Inexact Newton: a capped iterate from zero is still a descent direction.
                let params = CgParams {
                    max_iterations,
                    rel_tol,
                    abs_tol: 0.0,
                    keep_history: false,
                    initial_guess: InitialGuess::Zero,
                    on_cap: OnIterationCap::Accept,
                };
                let mut hessian =
                    |x: &[Vector<D>], y: &mut [Vector<D>]| pot.apply_hessian(tensors, x, stress, y);
                let outcome = conjugate_gradient(&mut hessian, jacobi, rhs, d, &params, cg);
                self.times.linear_solve += t.elapsed();
                match outcome {
                    Ok(info) => Ok(Ok(info.iterations)),
                    Err(CgError::NegativeCurvature { .. } | CgError::NonFinite { .. }) => {
                        Ok(Err(Indefinite))
                    }
                    Err(e) => Err(e.to_string()),
                }
            }
        }
    }
}

crate::core::solver_seam!(
    ImplicitTlmpm,
    |s: &Self| match s.implicit.scheme {
        TimeScheme::BackwardEuler => "implicit TLMPM (backward Euler, Newton)",
        TimeScheme::Newmark => "implicit TLMPM (Newmark average acceleration, Newton)",
    },
    "dx / max|v| (backward Euler has no wave-speed limit)",
    false
);

impl<const D: usize> ImplicitTlmpm<D>
where
    Dim<D>: DimOps<D>,
{
    /// The same set-up around `particles` (a new reference configuration).
    fn rebuild(&self, particles: Particles<D>) -> Result<Self, SetupError> {
        Self::new(
            *self.core.reference.spec(),
            self.core.params.clone(),
            self.implicit,
            self.core.materials.clone(),
            particles,
        )
    }

    /// The step of the solver seam, on a thread of the rayon pool ([`on_pool`]).
    fn seam_step(&mut self) -> Result<StepInfo, mpm_core::StepError> {
        on_pool(|| self.advance_step()).map_err(|e| e.erase("Newton"))
    }

    /// The Newton solve of the last accepted step (iterations, residual history, line-search
    /// halvings, …); the default (no iterations) before the first step.
    pub fn last_newton(&self) -> &NewtonInfo {
        &self.last.0
    }

    /// What the contact stage of the last accepted step found (`None` when contact is off or
    /// before the first step).
    pub fn last_contact(&self) -> Option<ContactStats> {
        self.last.1
    }

    /// Stage times, with the Newton breakdown under `solve`.
    fn seam_stage_times(&self) -> Vec<StageTime> {
        let mut rows = self.stats.rows(&self.stage_plan());
        let n = &self.newton_times;
        if let Some(solve) = rows.iter_mut().find(|r| r.stage == Stage::SOLVE) {
            solve.parts = vec![
                ("energy", n.energy.as_secs_f64()),
                ("gradient", n.gradient.as_secs_f64()),
                ("tangent", n.tangent.as_secs_f64()),
                ("assembly", n.assembly.as_secs_f64()),
                ("factorization", n.factorization.as_secs_f64()),
                ("linear solve", n.linear_solve.as_secs_f64()),
            ];
        }
        rows
    }
}

#[cfg(test)]
pub(crate) mod tests;

#[cfg(test)]
mod scheme_tests;

mod coupling;
mod newmark_contact;
#[cfg(feature = "bench")]
mod probe;

pub use coupling::{Predicted, Projected, Transferred};
