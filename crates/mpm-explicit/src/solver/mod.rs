//! The explicit MLS-MPM solver on one background grid: its set-up, workspace, step driver and
//! accessors. The stage methods (sort, volumes, diffusion, P2G, grid update, coupling, G2P,
//! commit) are in `stages`, the `Solver` implementation with checkpoint and restore in `seam`.

#[cfg(feature = "bench")]
mod probe;
#[cfg(feature = "bench")]
pub use probe::PreparedG2p;
mod seam;
mod stages;

use crate::blocks::Blocks;
use crate::coupling::{self, GeometryNeeds, PhaseGeometry};
use crate::g2p::{Extra, Moving};
use crate::materials::MaterialView;
use crate::mixing::MixingWork;
use crate::params::{ExplicitParams, Transfer, VolumeUpdate};
use mpm_core::boundary::Boundaries;
use mpm_core::material::Parameter;
use mpm_core::mirror::MirrorWalls;
use mpm_core::solver::nan_max;
use mpm_core::timestep::{choose_dt, stable_dt};
use mpm_core::{
    retry_halving, Alone, Diagnostics, Dim, DimOps, Failure, GridNodes, GridSpec, Location,
    Material, NodeLayout, OnInstability, Particles, Peers, Real, SetupError, Stage, StagePlan,
    StageTimes, StepError, StepInfo, StepStart, TimeStepPolicy, Vector, Violation,
};
use rayon::prelude::*;
use std::convert::Infallible;
use std::ops::Mul;
use std::time::Instant;

/// Scratch memory of a solver's workspace (bytes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ScratchBytes {
    /// Arrays with one entry per particle: block binning, the multi-grid state gathered by G2P
    /// and, when the policy retries steps, the saved copy of the columns G2P rewrites.
    pub particles: usize,
    /// Arrays that scale with the grid: dense nodes, FLIP velocities, block counts and buffers.
    pub grid: usize,
}

/// Scratch memory reused by every step. The per-phase vectors have one entry per phase.
#[derive(Clone, Debug, Default)]
struct Workspace<const D: usize> {
    /// The sparse grid: the node blocks every phase's particles reach this step, shared by the
    /// phase grids so that they couple node by node.
    layout: NodeLayout<D>,
    blocks: Vec<Blocks<D>>,
    grids: Vec<GridNodes<D>>,
    velocity_old: Vec<Vec<Vector<D>>>,
    geometry: Vec<PhaseGeometry<D>>,
    /// The columns G2P rewrites, saved before each attempt when the policy retries steps.
    backup: Moving<D>,
    extras: Vec<Extra>,
    mixing: MixingWork<D>,
}

impl<const D: usize> Workspace<D> {
    fn new(phases: usize) -> Self {
        Self {
            blocks: vec![Blocks::default(); phases],
            grids: vec![GridNodes::default(); phases],
            velocity_old: vec![Vec::new(); phases],
            geometry: vec![PhaseGeometry::default(); phases],
            ..Self::default()
        }
    }
}

/// Explicit MLS-MPM on a single grid.
#[derive(Clone, Debug)]
///
/// The set-up (grid, parameters, materials, boundaries) and the particles are checked once in
/// [`ExplicitSolver::new`] and stay private, so they cannot be changed behind the checks.
pub struct ExplicitSolver<const D: usize> {
    spec: GridSpec<D>,
    params: ExplicitParams<D>,
    materials: Vec<Material>,
    boundaries: Boundaries<D>,
    particles: Particles<D>,
    /// Simulation time (s).
    time: Real,
    /// Number of accepted steps.
    steps: u64,
    stats: StageTimes,
    plan: StagePlan,
    /// `max_p(|v_p| + c_p)` (m/s) of the current particles, kept by the last accepted step's
    /// G2P for the next adaptive dt; `None` when it must be recomputed (fixed dt, multi-grid
    /// particle state that changes materials after G2P, any other change of the particles).
    signal: Option<Real>,
    geometry_needs: Vec<GeometryNeeds>,
    /// The mirrored ghost layers of the domain walls, when the walls use them.
    mirror: Option<MirrorWalls<D>>,
    ws: Workspace<D>,
}

impl<const D: usize> ExplicitSolver<D>
where
    Dim<D>: DimOps<D>,
{
    /// Builds a solver, checking that parameters are in range, that every particle refers to an
    /// existing material whose columns exist, and that every particle's stencil fits in the grid.
    pub fn new(
        spec: GridSpec<D>,
        params: ExplicitParams<D>,
        materials: Vec<Material>,
        boundaries: Boundaries<D>,
        particles: Particles<D>,
    ) -> Result<Self, SetupError> {
        crate::validate::validate(&spec, &params, &materials, &particles)?;
        let mirror = match &boundaries.walls {
            Some(w) => MirrorWalls::new(&spec, w).map_err(|reason| SetupError::InvalidSetting {
                setting: crate::settings::WALLS.into(),
                reason,
            })?,
            None => None,
        };
        let phases = params.phases.count as usize;
        let mut s = Self {
            mirror,
            geometry_needs: coupling::geometry_needs(phases, &params.phases.couplings),
            ws: Workspace::new(phases),
            spec,
            params,
            materials,
            boundaries,
            particles,
            time: 0.0,
            steps: 0,
            stats: StageTimes::default(),
            plan: StagePlan::default(),
            signal: None,
        };
        s.plan = crate::plan::decide(&s, &s.geometry_needs);
        Ok(s)
    }

    /// Grid geometry.
    pub fn spec(&self) -> &GridSpec<D> {
        &self.spec
    }

    /// Solver parameters.
    pub fn params(&self) -> &ExplicitParams<D> {
        &self.params
    }

    /// Material table, indexed by the particles' material column.
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }

    /// Grid boundary conditions.
    pub fn boundaries(&self) -> &Boundaries<D> {
        &self.boundaries
    }

    /// Particle state.
    pub fn particles(&self) -> &Particles<D> {
        &self.particles
    }

    /// Particle velocities (m/s), writable: the next step transfers them to the grid.
    pub fn velocities_mut(&mut self) -> &mut [Vector<D>] {
        &mut self.particles.v
    }

    /// Simulation time (s).
    pub fn time(&self) -> Real {
        self.time
    }

    /// Number of accepted steps.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Wall time accumulated per stage.
    pub fn stats(&self) -> &StageTimes {
        &self.stats
    }

    /// The same set-up around `particles` at `time` (s) after `steps` steps: the particles are
    /// checked against the grid and materials as in [`ExplicitSolver::new`].
    fn with_particles(
        &self,
        particles: Particles<D>,
        time: Real,
        steps: u64,
    ) -> Result<Self, SetupError> {
        let mut s = Self::new(
            self.spec,
            self.params.clone(),
            self.materials.clone(),
            self.boundaries.clone(),
            particles,
        )?;
        s.time = time;
        s.steps = steps;
        Ok(s)
    }

    /// Number of phases (grids).
    pub fn phase_count(&self) -> usize {
        self.ws.grids.len()
    }

    /// Whether the phase grids are coupled (more than one phase): the multi-grid path.
    pub(crate) fn multigrid(&self) -> bool {
        self.phase_count() > 1
    }

    /// Whether G2P computes multi-grid particle state (φ_eff, concentration, dissolution).
    pub(crate) fn has_extra_state(&self) -> bool {
        self.params.porous.is_some()
            || self.params.mixing.is_some()
            || self.params.dissolution.is_some()
    }

    /// [`Solver::step`](mpm_core::Solver::step) on the calling thread, with the shared step
    /// machinery.
    fn advance_step(&mut self) -> Result<StepInfo, StepError<Infallible>> {
        self.step_among(self.particles.len(), &mut Alone)
    }

    /// One step of a process that holds part of a run: the first `active` particles are this
    /// process's own, the rest halo copies of its peers' particles near its own, which take
    /// part in every transfer to the grid but are neither advanced nor checked by G2P (their
    /// state after the step is meaningless; the driver replaces them). The time step and the
    /// outcome of each attempt are agreed with `peers`; with [`Alone`] and every particle
    /// active this is [`Solver::step`](mpm_core::Solver::step) on the calling thread. A
    /// failure names a particle by the index `peers` maps it to.
    pub fn step_among<P: Peers<Infallible>>(
        &mut self,
        active: usize,
        peers: &mut P,
    ) -> Result<StepInfo, StepError<Infallible>> {
        let start = StepStart {
            step: self.steps,
            time: self.time,
        };
        let t = Instant::now();
        let dt0 = self.choose_dt().map_err(Failure::guard(Stage::TIME_STEP));
        let dt0 = peers.agree_dt(dt0);
        self.stats.add(Stage::TIME_STEP, t.elapsed());
        let dt0 = dt0.map_err(|f| start.error(f, 0.0, 0))?;
        let policy = self.params.step.on_instability;
        let attempt = |dt| self.attempt(dt, active, peers);
        let (_, dt, retries) = retry_halving(policy, start, dt0, attempt)?;
        self.time += dt;
        self.steps += 1;
        Ok(StepInfo {
            dt,
            retries,
            time: self.time,
            solves: Vec::new(),
            events: Vec::new(),
            residual_histories: Vec::new(),
        })
    }

    /// Replaces the particles between steps (a distributed driver's exchange of halo copies
    /// and migrating particles), checking them as [`ExplicitSolver::new`] does. Time, step
    /// count and the largest signal speed of the particles the last step advanced are kept:
    /// with peers, the time step is agreed over every process's particles.
    pub fn replace_particles(&mut self, particles: Particles<D>) -> Result<(), SetupError> {
        crate::validate::validate(&self.spec, &self.params, &self.materials, &particles)?;
        self.particles = particles;
        Ok(())
    }

    /// Keeps the first `n` particles (a distributed driver drops its halo copies after a
    /// step, also after a failed one; a subset needs no new checks).
    pub fn truncate_particles(&mut self, n: usize) {
        self.particles.truncate(n);
    }

    /// Moves the particles out, leaving none (for editing them in place before
    /// [`Self::replace_particles`] hands them back).
    pub fn take_particles(&mut self) -> Particles<D> {
        let empty = Particles::new(self.particles.columns());
        std::mem::replace(&mut self.particles, empty)
    }

    /// The step under the time-step policy, or why none can be taken.
    fn choose_dt(&self) -> Result<Real, (Location, Violation, Real)> {
        let stable = match self.params.step.time_step {
            // A fixed step does not use the bound; the guard checks still catch bad states.
            TimeStepPolicy::Fixed { .. } => Real::INFINITY,
            TimeStepPolicy::Adaptive { .. } => match self.signal {
                Some(signal) => self.stable_dt_for(signal),
                None => self.stable_dt(),
            },
        };
        choose_dt(&self.params.step.time_step, stable)
    }

    /// One attempt at a step of size `dt`: the stage plan. G2P updates the particles in place;
    /// when the policy retries failed steps, their moving columns are saved first and put back
    /// on failure, so a retry starts from the same state.
    fn attempt<P: Peers<Infallible>>(
        &mut self,
        dt: Real,
        active: usize,
        peers: &mut P,
    ) -> Result<(), Failure<Infallible>> {
        let retries = matches!(self.params.step.on_instability, OnInstability::Retry { .. });
        self.signal = None;
        if retries {
            self.ws.backup.save(&self.particles);
        }
        let r = self.stages(dt, active);
        let r = peers.agree(r);
        if r.is_err() && retries {
            self.ws.backup.restore(&mut self.particles);
        }
        r
    }

    /// The stages of one attempt at a step of size `dt`; G2P advances the first `active`
    /// particles.
    fn stages(&mut self, dt: Real, active: usize) -> Result<(), Failure<Infallible>> {
        self.sort_particles();
        if self.params.volume == VolumeUpdate::Reestimate {
            self.reestimate_volumes();
        }
        if self.params.mixing.is_some() {
            self.diffuse(dt);
        }
        self.particle_to_grid(dt);
        self.update_grid(dt)
            .map_err(Failure::guard(Stage::GRID_UPDATE))?;
        if self.multigrid() {
            self.couple_phases(dt)
                .map_err(Failure::guard(crate::stages::COUPLING))?;
        }
        let signal = self
            .grid_to_particle(dt, active)
            .map_err(Failure::guard(Stage::G2P))?;
        if self.has_extra_state() {
            self.commit_extra();
        } else if matches!(self.params.step.time_step, TimeStepPolicy::Adaptive { .. }) {
            self.signal = Some(signal);
        }
        Ok(())
    }

    /// P2G alone (binning, then the transfer) on the current state for a step of `dt` (s),
    /// leaving the particles unchanged: for benchmarks and for inspecting the grid.
    pub fn transfer_to_grid(&mut self, dt: Real) {
        self.sort_particles();
        self.particle_to_grid(dt);
    }

    /// Re-estimates fluid volumes (`J_p = m_p/(ρ_p V⁰_p)`) from the grid density at the current
    /// positions, as the volume stage of a step does with [`VolumeUpdate::Reestimate`].
    pub fn reestimate_volumes_now(&mut self) {
        self.signal = None;
        self.sort_particles();
        self.reestimate_volumes();
    }

    /// The stable explicit step bound (s) for the current state, before `dt_max`:
    /// `min(C·Δx / max_p(|v_p| + c_p), Δx²/(2Dν))`. With a fixed dt, `C` is 1.
    pub fn stable_dt(&self) -> Real {
        let max_signal = (0..self.particles.len())
            .into_par_iter()
            .map(|p| self.particles.v[p].norm() + self.wave_speed(p))
            .reduce(|| 0.0, nan_max);
        self.stable_dt_for(max_signal)
    }

    /// [`Self::stable_dt`] for a given largest signal speed `max_p(|v_p| + c_p)` (m/s).
    fn stable_dt_for(&self, max_signal: Real) -> Real {
        let cfl = match self.params.step.time_step {
            TimeStepPolicy::Adaptive { cfl, .. } => cfl,
            TimeStepPolicy::Fixed { .. } => 1.0,
        };
        stable_dt(cfl, self.spec.dx, max_signal, self.max_diffusivity(), D)
    }

    /// The largest kinematic viscosity or concentration diffusivity (m²/s) any particle can have:
    /// porous interactions may raise viscosity up to their largest factor, mixing blends viscosity
    /// and density between its two fluids.
    fn max_diffusivity(&self) -> Real {
        let interactions = self
            .params
            .porous
            .as_ref()
            .map_or(&[][..], |p| &p.interactions);
        let factor = |k: usize| {
            interactions
                .iter()
                .filter(|it| it.material as usize == k && it.parameter == Parameter::Viscosity)
                .map(|it| it.scaling.factor(0.0).max(it.scaling.factor(1.0)))
                .fold(1.0, Real::mul)
        };
        let mut nu = (0..self.materials.len())
            .map(|k| {
                let m = &self.materials[k];
                m.viscosity() * factor(k) / m.density()
            })
            .fold(0.0, Real::max);
        if let Some(mix) = &self.params.mixing {
            let [a, b] = mix.fluids.map(|k| &self.materials[k as usize]);
            let mu = (a.viscosity() * factor(mix.fluids[0] as usize))
                .max(b.viscosity() * factor(mix.fluids[1] as usize));
            nu = nu
                .max(mu / a.density().min(b.density()))
                .max(mix.diffusivity);
        }
        nu
    }

    /// Elastic P-wave or sound speed (m/s) of particle `p` in its current state.
    fn wave_speed(&self, p: usize) -> Real {
        let ps = &self.particles;
        match material_view(&self.materials, &self.params)
            .get(ps, p)
            .as_ref()
        {
            Material::Solid(s) => {
                s.wave_speed(Dim::<D>::det(&ps.def_grad_of(p)), &ps.plastic_of(p))
            }
            Material::Fluid(f) => f.sound_speed(ps.jacobian_of(p)),
        }
    }

    /// Bytes of scratch memory the workspace holds after the last step (lengths, not
    /// capacities), split into what scales with the particle count and what scales with the grid.
    pub fn scratch_bytes(&self) -> ScratchBytes {
        let ws = &self.ws;
        let vec = std::mem::size_of::<Vector<D>>();
        let mut bytes = ScratchBytes {
            particles: ws.backup.bytes() + ws.extras.len() * std::mem::size_of::<Extra>(),
            grid: ws.mixing.bytes() + ws.layout.bytes(),
        };
        for k in 0..self.phase_count() {
            let (block_particles, block_grid) = ws.blocks[k].bytes();
            let grid = &ws.grids[k];
            bytes.particles += block_particles;
            bytes.grid += block_grid
                + ws.geometry[k].bytes()
                + grid.mass.len() * std::mem::size_of::<Real>()
                + (grid.momentum.len() + grid.velocity.len() + ws.velocity_old[k].len()) * vec;
        }
        bytes
    }

    /// Grid node data of phase 0 after the last P2G and grid update, in the order of
    /// [`Self::grid_layout`].
    pub fn grid(&self) -> &GridNodes<D> {
        &self.ws.grids[0]
    }

    /// Grid node data of phase `k` after the last P2G, grid update and coupling, in the order
    /// of [`Self::grid_layout`].
    pub fn phase_grid(&self, k: usize) -> Option<&GridNodes<D>> {
        self.ws.grids.get(k)
    }

    /// The sparse grid of the last step: which node blocks are stored (the blocks the
    /// particles' stencils reach) and where each node is in the arrays of [`Self::grid`].
    pub fn grid_layout(&self) -> &NodeLayout<D> {
        &self.ws.layout
    }

    /// Mass, momenta and energies of the particles. Angular momentum includes the affine spin
    /// under APIC with a quadratic or cubic kernel.
    pub fn diagnostics(&self) -> Diagnostics<D> {
        let inertia = match self.params.transfer {
            Transfer::Apic => self
                .params
                .kernel
                .mls_inertia_inv(self.spec.dx)
                .map(|m| 1.0 / m),
            _ => None,
        };
        Diagnostics::compute(
            &self.particles,
            &self.materials,
            inertia,
            &self.params.step.gravity,
        )
    }
}

/// The per-particle material resolver of a scene.
fn material_view<'a, const D: usize>(
    materials: &'a [Material],
    params: &'a ExplicitParams<D>,
) -> MaterialView<'a> {
    MaterialView::new(materials, params.porous.as_ref(), params.mixing.as_ref())
}
