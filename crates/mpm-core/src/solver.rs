//! The solver seam: the [`Solver`] interface that the CLI, the validation crate and the
//! benchmarks drive, and the step machinery every solver shares (stage plans and timings, the
//! retry-at-dt/2 loop, typed step results and errors).
//!
//! A solver decides its [`StagePlan`] from its set-up, before the first step: the stages each
//! step runs, in order, each with a detail line (DESIGN §5). The plan's stage ids are the ids
//! under which [`StageTimes`] records wall time, so the timing table lists exactly the stages
//! that run. A step returns a [`StepInfo`] (dt, retries, the iterative solves it ran) or a
//! [`StepError`]: a failed guard check ([`Instability`]) or a solve that did not converge,
//! after the dt/2 retries [`retry_halving`] allowed.

use crate::columns::{self, Column};
use crate::diagnostics::Diagnostics;
use crate::error::{Instability, Location, Stage, Violation};
use crate::grid::GridSpec;
use crate::material::Material;
use crate::math::{Dim, DimOps, Real, Vector};
use crate::particles::Particles;
use crate::timestep::OnInstability;
use std::fmt;
use std::sync::Arc;
use std::time::{Duration, Instant};
use thiserror::Error;

/// One stage of a plan: which stage, and what it does in this set-up.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PlannedStage {
    /// The stage id (also its timing id).
    pub stage: Stage,
    /// What the stage does in this set-up (for `mpm-cli check`).
    pub detail: String,
}

/// The stages each step of a solver runs, in order; stages a set-up does not need are absent.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct StagePlan {
    /// The stages, in execution order.
    pub stages: Vec<PlannedStage>,
}

impl StagePlan {
    /// Appends `stage` with `detail`.
    pub fn push(&mut self, stage: Stage, detail: impl Into<String>) {
        self.stages.push(PlannedStage {
            stage,
            detail: detail.into(),
        });
    }

    /// Whether the plan runs `stage`.
    pub fn contains(&self, stage: Stage) -> bool {
        self.stages.iter().any(|s| s.stage == stage)
    }

    /// The stage ids, in order.
    pub fn ids(&self) -> Vec<Stage> {
        self.stages.iter().map(|s| s.stage).collect()
    }
}

/// Wall time spent in each stage, accumulated over all steps.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StageTimes {
    times: Vec<(Stage, Duration)>,
}

impl StageTimes {
    /// Adds `d` to `stage`.
    pub fn add(&mut self, stage: Stage, d: Duration) {
        match self.times.iter_mut().find(|(s, _)| *s == stage) {
            Some((_, t)) => *t += d,
            None => self.times.push((stage, d)),
        }
    }

    /// Runs `f`, adding its wall time to `stage`.
    pub fn time<T>(&mut self, stage: Stage, f: impl FnOnce() -> T) -> T {
        let t = Instant::now();
        let r = f();
        self.add(stage, t.elapsed());
        r
    }

    /// Time accumulated in `stage`.
    pub fn get(&self, stage: Stage) -> Duration {
        self.times
            .iter()
            .find(|(s, _)| *s == stage)
            .map_or(Duration::ZERO, |(_, t)| *t)
    }

    /// One row per stage of `plan`, in plan order (a stage planned twice is listed once).
    pub fn rows(&self, plan: &StagePlan) -> Vec<StageTime> {
        let mut rows: Vec<StageTime> = Vec::with_capacity(plan.stages.len());
        for s in &plan.stages {
            if !rows.iter().any(|r| r.stage == s.stage) {
                rows.push(StageTime {
                    stage: s.stage,
                    seconds: self.get(s.stage).as_secs_f64(),
                    parts: Vec::new(),
                });
            }
        }
        rows
    }
}

/// Wall time of one stage over a run, with an optional breakdown (e.g. the parts of a Newton
/// solve); the parts are contained in `seconds`.
#[derive(Clone, Debug, PartialEq)]
pub struct StageTime {
    /// The stage.
    pub stage: Stage,
    /// Seconds spent in it (s).
    pub seconds: f64,
    /// `(part, seconds)` breakdown of `seconds`; empty when there is none.
    pub parts: Vec<(&'static str, f64)>,
}

/// What one iterative solve inside a step did (Newton, conjugate gradients, ...).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolveInfo {
    /// Which solve, e.g. `newton` or `pressure_cg`: the key under which the CLI reports it.
    pub name: &'static str,
    /// Iterations of the accepted attempt.
    pub iterations: u32,
    /// Final residual norm of the accepted attempt (in the solve's own unit).
    pub residual: Real,
}

/// What one accepted step did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepInfo {
    /// The accepted time step (s).
    pub dt: Real,
    /// Number of dt/2 retries before it was accepted.
    pub retries: u32,
    /// Simulation time after the step (s).
    pub time: Real,
    /// The iterative solves of the accepted attempt, in order; empty for explicit solvers.
    pub solves: Vec<SolveInfo>,
    /// Counts of events in the accepted attempt, e.g. `("contact_pairs", 12)`.
    pub events: Vec<(&'static str, u64)>,
    /// Residual-norm histories of the accepted attempt's solves that keep one, by solve name:
    /// the initial residual first, then one per iteration (each in its solve's own unit). Empty
    /// for solvers that do not report them.
    pub residual_histories: Vec<(&'static str, Vec<Real>)>,
}

/// Why one attempt at a step failed; `E` is the solver's own error for a failed solve.
#[derive(Clone, Debug, PartialEq)]
pub enum Failure<E> {
    /// A guard check failed in `stage`: where, what, and the offending value.
    Guard(Stage, (Location, Violation, Real)),
    /// A solve failed in `stage`.
    Solve(Stage, E),
}

impl<E> Failure<E> {
    /// A guard failure in `stage`, for `map_err` on a check's result.
    pub fn guard(stage: Stage) -> impl Fn((Location, Violation, Real)) -> Self {
        move |e| Failure::Guard(stage, e)
    }
}

/// Why a step failed, after the retries the policy allowed.
#[derive(Clone, Debug, PartialEq, Error)]
pub enum StepError<E: std::error::Error + 'static = SolveError> {
    /// A guard check failed (non-finite values, J ≤ 0 where the model is undefined, a time step
    /// below its minimum, ...).
    #[error(transparent)]
    Instability(#[from] Instability),
    /// A solve failed.
    #[error(
        "step {step} (t = {time:.6e} s, dt = {dt:.3e} s, after {retries} dt/2 retries), stage \
         {stage}: {source}"
    )]
    Solve {
        /// Step number (0-based).
        step: u64,
        /// Simulation time at the start of the step (s).
        time: Real,
        /// Time step of the failing attempt (s).
        dt: Real,
        /// dt/2 retries made.
        retries: u32,
        /// The stage that failed.
        stage: Stage,
        /// The failure.
        #[source]
        source: E,
    },
}

impl<E: std::error::Error + Send + Sync + 'static> StepError<E> {
    /// The same error with the solve failure turned into a [`SolveError`] named `solver`,
    /// which keeps the typed failure for [`SolveError::cause`].
    pub fn erase(self, solver: &'static str) -> StepError {
        match self {
            StepError::Instability(i) => StepError::Instability(i),
            StepError::Solve {
                step,
                time,
                dt,
                retries,
                stage,
                source,
            } => StepError::Solve {
                step,
                time,
                dt,
                retries,
                stage,
                source: SolveError {
                    solver,
                    message: source.to_string(),
                    cause: Some(Arc::new(source)),
                },
            },
        }
    }
}

/// A failed solve, solver-independent: which solve and what it reported, with the solver's
/// own typed error for [`SolveError::cause`].
#[derive(Clone, Debug, Error)]
#[error("{solver} failed: {message}")]
pub struct SolveError {
    /// Which solve, e.g. `Newton`.
    pub solver: &'static str,
    /// What it reported.
    pub message: String,
    cause: Option<Arc<dyn std::error::Error + Send + Sync>>,
}

impl SolveError {
    /// A failure of `solver` reported as `message`, without a typed cause.
    pub fn new(solver: &'static str, message: impl Into<String>) -> Self {
        Self {
            solver,
            message: message.into(),
            cause: None,
        }
    }

    /// The solver's own error, when it is an `E` (e.g. `mpm_tlmpm::NewtonError`).
    pub fn cause<E: std::error::Error + 'static>(&self) -> Option<&E> {
        self.cause.as_deref()?.downcast_ref::<E>()
    }
}

/// Equal when the solve and the message are: the typed causes are compared through their
/// messages.
impl PartialEq for SolveError {
    fn eq(&self, other: &Self) -> bool {
        self.solver == other.solver && self.message == other.message
    }
}

impl Eq for SolveError {}

/// Where in a run a step starts: the step number and the time, for error reports.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepStart {
    /// Step number (0-based).
    pub step: u64,
    /// Simulation time at the start of the step (s).
    pub time: Real,
}

impl StepStart {
    /// The public error for `failure` of an attempt with `dt` (s) after `retries` halvings.
    pub fn error<E: std::error::Error + 'static>(
        self,
        failure: Failure<E>,
        dt: Real,
        retries: u32,
    ) -> StepError<E> {
        match failure {
            Failure::Guard(stage, (location, violation, value)) => {
                StepError::Instability(Instability {
                    step: self.step,
                    time: self.time,
                    dt,
                    stage,
                    location,
                    violation,
                    value,
                    retries,
                })
            }
            Failure::Solve(stage, source) => StepError::Solve {
                step: self.step,
                time: self.time,
                dt,
                retries,
                stage,
                source,
            },
        }
    }
}

/// Runs `attempt(dt)` from `dt0` (s), halving dt after each failure as `policy` allows (the
/// attempt must leave the solver state untouched when it fails). Returns the attempt's value,
/// the accepted dt (s) and the number of retries, or the error of the last failed attempt.
/// Advancing time and the step count is left to the caller.
pub fn retry_halving<T, E: std::error::Error + 'static>(
    policy: OnInstability,
    start: StepStart,
    dt0: Real,
    mut attempt: impl FnMut(Real) -> Result<T, Failure<E>>,
) -> Result<(T, Real, u32), StepError<E>> {
    let max_retries = match policy {
        OnInstability::Abort => 0,
        OnInstability::Retry { max_retries } => max_retries,
    };
    let (mut dt, mut retries) = (dt0, 0);
    loop {
        match attempt(dt) {
            Ok(v) => return Ok((v, dt, retries)),
            Err(f) if retries >= max_retries => return Err(start.error(f, dt, retries)),
            Err(_) => (dt, retries) = (0.5 * dt, retries + 1),
        }
    }
}

/// Runs `op` on a thread of the current rayon pool (the global one unless called from inside
/// another) and returns its value. Called from a thread of a pool, `op` runs right there.
///
/// Each solver's step entry point runs its step through this function. A step enters many
/// parallel regions (sorting, transfers, grid passes, each vector operation of a conjugate
/// gradient iteration); entered from a thread outside the pool, such as a program's main
/// thread, every region hands its work to a pool thread and puts the caller to sleep until it
/// is done, two thread wake-ups per region (system calls and context switches, on a VM often an
/// interrupt to another virtual CPU). From a pool thread a region starts at once on the
/// calling thread. Work is split and summed the same way in either case, so results do not
/// change. Measured on 2 threads: `tlmpm_step/2d_16k`
/// 28.4 → 24.5 ms; the CLI's `diq_dam_break_2d` scene, whose pressure solves run many short
/// parallel vector operations, 13.0–13.4 → 6.0–6.2 s, with the CLI's whole run on the pool too.
///
/// The step then runs on the stack of a pool thread, the standard library's default for
/// spawned threads (2 MiB unless `RUST_MIN_STACK` says otherwise), like every parallel closure
/// and every test of the solvers already does.
pub fn on_pool<R: Send>(op: impl FnOnce() -> R + Send) -> R {
    rayon::scope(|_| op())
}

/// `max` that propagates NaN, so a NaN speed is noticed instead of ignored.
pub fn nan_max(a: Real, b: Real) -> Real {
    if a.is_nan() || b.is_nan() {
        Real::NAN
    } else {
        a.max(b)
    }
}

/// A solver's whole state as named columns: the particle columns plus whatever else the solver
/// needs (e.g. TLMPM reference positions), and scalar attributes. Restoring it continues the run
/// bitwise identically.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SolverState {
    /// Simulation time (s).
    pub time: Real,
    /// Accepted steps.
    pub steps: u64,
    /// Named columns: the particle columns, then the solver's own.
    pub columns: Vec<Column>,
    /// Named scalar attributes of the solver (e.g. a count of reference updates).
    pub attrs: Vec<(String, f64)>,
}

impl SolverState {
    /// The state of a solver whose particles are its whole state.
    pub fn of_particles<const D: usize>(particles: &Particles<D>, time: Real, steps: u64) -> Self {
        Self {
            time,
            steps,
            columns: columns::particle_columns(particles),
            attrs: Vec::new(),
        }
    }

    /// Attribute `name`, if present.
    pub fn attr(&self, name: &str) -> Option<f64> {
        self.attrs.iter().find(|(k, _)| k == name).map(|(_, v)| *v)
    }
}

/// Why a saved state does not fit a solver.
#[derive(Clone, Debug, PartialEq, Eq, Error)]
#[error("{0}")]
pub struct RestoreError(pub String);

impl From<String> for RestoreError {
    fn from(s: String) -> Self {
        Self(s)
    }
}

/// An output field a solver can write per particle.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FieldInfo {
    /// Name (as in the scene's `output.fields` and the written dataset).
    pub name: &'static str,
    /// Unit (`1` for dimensionless).
    pub unit: &'static str,
    /// Values per particle: 1 (scalar), D (vector) or D·D (matrix).
    pub components: usize,
    /// Whether it is derived (computed for output) rather than a stored column.
    pub derived: bool,
}

/// How a solver limits its time step, for `mpm-cli check` and the fixed-dt warning.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DtBound {
    /// The bound in words, e.g. `min(dx / max(|v| + c), viscous limit)`.
    pub description: &'static str,
    /// Whether a fixed dt above the bound is unstable (false for implicit integrators).
    pub limits_fixed_dt: bool,
}

/// A named scalar of the state that a run tracks over time, e.g. the fluid volume.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Monitor {
    /// Name, e.g. `fluid_volume`.
    pub name: &'static str,
    /// Unit, e.g. `m^3`.
    pub unit: &'static str,
    /// Value, in `unit`.
    pub value: Real,
}

/// Where a solver's particles may be (m): the box they must lie in, and the wall planes of the
/// grid box when it has walls.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Region<const D: usize> {
    /// Lower and upper corners of the box particles must lie in (m): where the solver's
    /// interpolation stencil fits in the grid, or the box inside the walls.
    pub interior: (Vector<D>, Vector<D>),
    /// Lower and upper wall plane per axis (m), when the grid box has walls.
    pub walls: Option<(Vector<D>, Vector<D>)>,
}

/// One solver, as the CLI, the validation crate and the benchmarks drive it. `D` is the
/// dimension (2 or 3). `Send`, so that a driver can run it on a pool thread ([`on_pool`]).
pub trait Solver<const D: usize>: fmt::Debug + Send
where
    Dim<D>: DimOps<D>,
{
    /// A human-readable name, e.g. `explicit MLS-MPM`.
    fn name(&self) -> &'static str;

    /// The background grid (for total-Lagrangian solvers, that of the reference configuration).
    fn spec(&self) -> &GridSpec<D>;

    /// The particles.
    fn particles(&self) -> &Particles<D>;

    /// The material table, indexed by the particles' material column.
    fn materials(&self) -> &[Material];

    /// Simulation time (s).
    fn time(&self) -> Real;

    /// Accepted steps.
    fn steps(&self) -> u64;

    /// The stable step bound (s) at the current state, before `dt_max`.
    fn stable_dt(&self) -> Real;

    /// What limits the time step.
    fn dt_bound(&self) -> DtBound;

    /// Where the particles may be: the interior and the walls.
    fn region(&self) -> Region<D>;

    /// Mass, momenta and energies.
    fn diagnostics(&self) -> Diagnostics<D>;

    /// The stages each step runs, decided by the set-up.
    fn plan(&self) -> StagePlan;

    /// Advances one step. After a failed step, time and the step count have not advanced; a
    /// retry under [`OnInstability::Retry`] starts from the state before the failed attempt.
    /// Under [`OnInstability::Abort`] a solver may leave its particles holding the failed
    /// step's partial result (the explicit solver updates them in place): read nothing but
    /// the error after an aborted step.
    fn step(&mut self) -> Result<StepInfo, StepError>;

    /// Steps until the time reaches `t_end` (s), as [`run_until_with`] without an observer.
    fn run_until(&mut self, t_end: Real) -> Result<RunInfo, StepError> {
        run_until_with(self, t_end, |_, _| {})
    }

    /// Wall time per planned stage, in plan order.
    fn stage_times(&self) -> Vec<StageTime>;

    /// The whole state, for a checkpoint.
    fn checkpoint(&self) -> SolverState;

    /// Restores a state saved by [`Solver::checkpoint`] (possibly by another process with the
    /// same set-up), checking that it fits this set-up.
    fn restore(&mut self, state: &SolverState) -> Result<(), RestoreError>;

    /// Scalars of the current state worth tracking over a run (the CLI records their initial,
    /// final, minimum and maximum values in `summary.json`); none by default.
    fn monitors(&self) -> Vec<Monitor> {
        Vec::new()
    }

    /// The per-particle fields this solver can write.
    fn output_fields(&self) -> Vec<FieldInfo> {
        let mut fields = particle_field_infos::<D>(&self.particles().columns().names());
        fields.push(FieldInfo {
            name: "pressure",
            unit: "Pa",
            components: 1,
            derived: true,
        });
        fields
    }

    /// Pressure (Pa) per particle; by default from the material laws
    /// ([`columns::material_pressure`]).
    fn pressure(&self) -> Vec<Real> {
        columns::material_pressure(self.particles(), self.materials())
    }

    /// The columns of output field `name` (empty when this solver has no such field); `plastic`
    /// gives three columns.
    fn output(&self, name: &str) -> Vec<Column> {
        match name {
            "pressure" => vec![Column::scalars("pressure", "Pa", &self.pressure())],
            _ => columns::particle_column(self.particles(), name),
        }
    }
}

/// What a run of steps did ([`run_until_with`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RunInfo {
    /// Accepted steps.
    pub steps: u64,
    /// dt/2 retries over all steps.
    pub retries: u32,
    /// Smallest and largest accepted dt (s); zero when no step was taken.
    pub dt_range: (Real, Real),
    /// Wall time spent in the steps (the observer's time not counted).
    pub wall: Duration,
}

/// Whether `time` (s) has reached `t_end` (s), allowing round-off of 10⁻¹² relative (so that
/// 300 steps of 10⁻³ s reach 0.3 s whichever way their sum rounds).
pub fn reached(time: Real, t_end: Real) -> bool {
    time >= t_end - 1e-12 * t_end.abs().max(1.0)
}

/// Steps `solver` until its time has [`reached`] `t_end` (s), calling `observe` with the solver
/// and the step's [`StepInfo`] after each accepted step; returns at the first failed step with
/// its error. A solver already at `t_end` takes no step.
pub fn run_until_with<const D: usize, S>(
    solver: &mut S,
    t_end: Real,
    mut observe: impl FnMut(&S, &StepInfo),
) -> Result<RunInfo, StepError>
where
    S: Solver<D> + ?Sized,
    Dim<D>: DimOps<D>,
{
    let mut run = RunInfo::default();
    while !reached(solver.time(), t_end) {
        let t = Instant::now();
        let info = solver.step()?;
        run.wall += t.elapsed();
        run.dt_range = if run.steps == 0 {
            (info.dt, info.dt)
        } else {
            (run.dt_range.0.min(info.dt), run.dt_range.1.max(info.dt))
        };
        run.steps += 1;
        run.retries += info.retries;
        observe(solver, &info);
    }
    Ok(run)
}

/// [`FieldInfo`] of the particle columns `names` (as [`crate::Columns::names`] lists them).
pub fn particle_field_infos<const D: usize>(names: &[&'static str]) -> Vec<FieldInfo> {
    names
        .iter()
        .map(|&name| {
            let (unit, components) = match name {
                "x" => ("m", D),
                "v" => ("m/s", D),
                "mass" => ("kg", 1),
                "volume0" => (if D == 2 { "m^2" } else { "m^3" }, 1),
                "affine" => ("1/s", D * D),
                "F" => ("1", D * D),
                "plastic" => ("1", 3),
                _ => ("1", 1),
            };
            FieldInfo {
                name,
                unit,
                components,
                derived: false,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Error, PartialEq)]
    #[error("diverged")]
    struct Diverged;

    fn start() -> StepStart {
        StepStart { step: 7, time: 0.5 }
    }

    /// From a thread outside any pool (the test's), `on_pool` runs its work on a thread of the
    /// global pool and returns its value; from a thread of a pool, on that very thread.
    #[test]
    fn on_pool_runs_on_a_pool_thread() {
        assert_eq!(rayon::current_thread_index(), None);
        let (index, value) = on_pool(|| (rayon::current_thread_index(), 6 * 7));
        assert!(index.is_some());
        assert_eq!(value, 42);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .expect("a pool of 2 threads");
        pool.install(|| {
            let caller = (rayon::current_thread_index(), std::thread::current().id());
            let inner = on_pool(|| (rayon::current_thread_index(), std::thread::current().id()));
            assert!(caller.0.is_some());
            assert_eq!(inner, caller);
        });
    }

    #[test]
    fn retry_halves_dt_until_accepted() {
        let mut tried = Vec::new();
        let r = retry_halving::<_, Diverged>(
            OnInstability::Retry { max_retries: 5 },
            start(),
            1.0,
            |dt| {
                tried.push(dt);
                if dt > 0.2 {
                    Err(Failure::Solve(Stage::SOLVE, Diverged))
                } else {
                    Ok(dt * 10.0)
                }
            },
        );
        assert_eq!(r, Ok((1.25, 0.125, 3)));
        assert_eq!(tried, vec![1.0, 0.5, 0.25, 0.125]);
    }

    #[test]
    fn retry_cap_reports_the_last_attempt() {
        let mut attempts = 0;
        let e = retry_halving::<(), Diverged>(
            OnInstability::Retry { max_retries: 2 },
            start(),
            1.0,
            |_| {
                attempts += 1;
                Err(Failure::Guard(
                    Stage::G2P,
                    (Location::Particle(3), Violation::InvertedElement, -0.5),
                ))
            },
        )
        .unwrap_err();
        assert_eq!(attempts, 3);
        match e {
            StepError::Instability(i) => {
                assert_eq!((i.step, i.time, i.dt, i.retries), (7, 0.5, 0.25, 2));
                assert_eq!(i.stage, Stage::G2P);
                assert_eq!(i.location, Location::Particle(3));
                assert_eq!(i.value, -0.5);
            }
            other => panic!("expected an instability, got {other:?}"),
        }
        // Abort: one attempt, no retry; a solve failure keeps its stage and source.
        let e = retry_halving::<(), Diverged>(OnInstability::Abort, start(), 0.1, |_| {
            Err(Failure::Solve(Stage::SOLVE, Diverged))
        })
        .unwrap_err()
        .erase("Newton");
        let text = e.to_string();
        assert!(
            text.contains("stage solve: Newton failed: diverged"),
            "{text}"
        );
        assert!(
            text.contains("dt = 1.000e-1 s, after 0 dt/2 retries"),
            "{text}"
        );
    }

    #[test]
    fn timings_follow_the_plan() {
        let mut plan = StagePlan::default();
        plan.push(Stage::TIME_STEP, "adaptive");
        plan.push(Stage::P2G, "APIC");
        plan.push(Stage::P2G, "second phase");
        let mut t = StageTimes::default();
        t.add(Stage::P2G, Duration::from_millis(30));
        t.add(Stage::P2G, Duration::from_millis(20));
        t.add(Stage::new("coupling"), Duration::from_millis(5)); // not planned: not listed
        let rows = t.rows(&plan);
        assert_eq!(
            rows.iter().map(|r| r.stage).collect::<Vec<_>>(),
            vec![Stage::TIME_STEP, Stage::P2G]
        );
        assert!((rows[1].seconds - 0.05).abs() < 1e-12);
        assert_eq!(rows[0].seconds, 0.0);
    }

    #[test]
    fn nan_max_propagates_nan() {
        assert_eq!(nan_max(1.0, 2.0), 2.0);
        assert!(nan_max(Real::NAN, 2.0).is_nan());
        assert!(nan_max(3.0, Real::NAN).is_nan());
        // A solver's own stage is equal to every stage of the same name.
        assert_eq!(Stage::new("g2p"), Stage::G2P);
        assert_eq!(Stage::new("contact").to_string(), "contact");
    }
}
