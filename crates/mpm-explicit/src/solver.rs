//! The explicit MLS-MPM solver on one background grid.

use crate::blocks::Blocks;
use crate::g2p::{self, G2pContext, Update};
use crate::grid_update;
use crate::p2g;
use crate::params::{ExplicitParams, Transfer, VolumeUpdate};
use mpm_core::boundary::Boundaries;
use mpm_core::timestep::{choose_dt, stable_dt};
use mpm_core::volume::density_at;
use mpm_core::{
    Diagnostics, Dim, DimOps, GridNodes, GridSpec, Instability, Location, Material, OnInstability,
    Particles, Real, SetupError, Stage, TimeStepPolicy, Vector, Violation,
};
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// Wall-clock time spent in each stage, accumulated over all steps.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StageTimes {
    /// Time-step selection.
    pub time_step: Duration,
    /// Binning particles into blocks.
    pub sort: Duration,
    /// Volume re-estimation (only with [`VolumeUpdate::Reestimate`]).
    pub volume: Duration,
    /// Particle-to-grid transfer.
    pub p2g: Duration,
    /// Grid velocity update and boundaries.
    pub grid_update: Duration,
    /// Grid-to-particle transfer and checks.
    pub g2p: Duration,
    /// Writing accepted particle updates.
    pub commit: Duration,
}

impl StageTimes {
    /// `(stage name, seconds)` for every stage, in execution order.
    pub fn table(&self) -> [(&'static str, f64); 7] {
        [
            ("time_step", self.time_step.as_secs_f64()),
            ("sort", self.sort.as_secs_f64()),
            ("volume", self.volume.as_secs_f64()),
            ("p2g", self.p2g.as_secs_f64()),
            ("grid_update", self.grid_update.as_secs_f64()),
            ("g2p", self.g2p.as_secs_f64()),
            ("commit", self.commit.as_secs_f64()),
        ]
    }
}

/// Scratch memory of a solver's workspace (bytes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ScratchBytes {
    /// Arrays with one entry per particle: block binning and the G2P result buffer.
    pub particles: usize,
    /// Arrays that scale with the grid: dense nodes, FLIP velocities, block counts and buffers.
    pub grid: usize,
}

/// What one accepted step did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepInfo {
    /// The accepted time step (s).
    pub dt: Real,
    /// Number of dt/2 retries before it was accepted.
    pub retries: u32,
    /// Simulation time after the step (s).
    pub time: Real,
}

/// Scratch memory reused by every step.
#[derive(Clone, Debug, Default)]
struct Workspace<const D: usize> {
    blocks: Blocks<D>,
    grid: GridNodes<D>,
    velocity_old: Vec<Vector<D>>,
    updates: Vec<Update<D>>,
}

/// Explicit MLS-MPM on a single grid.
#[derive(Clone, Debug)]
pub struct ExplicitSolver<const D: usize> {
    /// Grid geometry.
    pub spec: GridSpec<D>,
    /// Solver parameters.
    pub params: ExplicitParams<D>,
    /// Material table, indexed by `particles.material`.
    pub materials: Vec<Material>,
    /// Grid boundary conditions.
    pub boundaries: Boundaries<D>,
    /// Particle state.
    pub particles: Particles<D>,
    /// Simulation time (s).
    pub time: Real,
    /// Number of accepted steps.
    pub steps: u64,
    /// Accumulated stage timings.
    pub stats: StageTimes,
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
        validate(&spec, &params, &materials, &particles)?;
        Ok(Self {
            spec,
            params,
            materials,
            boundaries,
            particles,
            time: 0.0,
            steps: 0,
            stats: StageTimes::default(),
            ws: Workspace::default(),
        })
    }

    /// Advances one step. On a failed guard check the step is retried with dt/2 when the policy
    /// allows it; otherwise an [`Instability`] names the step, stage, particle or node and value.
    /// A failed step leaves the particle state untouched.
    pub fn step(&mut self) -> Result<StepInfo, Instability> {
        let t0 = Instant::now();
        let stable = match self.params.time_step {
            // A fixed step does not use the bound; the guard checks still catch bad states.
            TimeStepPolicy::Fixed { .. } => Real::INFINITY,
            TimeStepPolicy::Adaptive { .. } => self.stable_dt(),
        };
        let dt0 = choose_dt(&self.params.time_step, stable)
            .map_err(|e| self.instability(Stage::TimeStep, 0.0, e, 0))?;
        self.stats.time_step += t0.elapsed();
        let max_retries = match self.params.on_instability {
            OnInstability::Abort => 0,
            OnInstability::Retry { max_retries } => max_retries,
        };
        let (mut dt, mut retries) = (dt0, 0);
        loop {
            match self.advance(dt) {
                Ok(()) => break,
                Err((stage, e)) if retries == max_retries => {
                    return Err(self.instability(stage, dt, e, retries));
                }
                Err(_) => (dt, retries) = (0.5 * dt, retries + 1),
            }
        }
        self.time += dt;
        self.steps += 1;
        Ok(StepInfo {
            dt,
            retries,
            time: self.time,
        })
    }

    /// One attempt at a step of size `dt`: the stage plan.
    fn advance(&mut self, dt: Real) -> Result<(), (Stage, (Location, Violation, Real))> {
        self.sort_particles();
        if self.params.volume == VolumeUpdate::Reestimate {
            self.reestimate_volumes();
        }
        self.particle_to_grid(dt);
        self.update_grid(dt).map_err(|e| (Stage::GridUpdate, e))?;
        self.grid_to_particle(dt).map_err(|e| (Stage::G2P, e))?;
        self.commit();
        Ok(())
    }

    /// Stage: bins particles into grid blocks for the deterministic parallel scatter.
    pub fn sort_particles(&mut self) {
        let t = Instant::now();
        self.ws
            .blocks
            .sort(&self.spec, self.params.kernel, &self.particles.x);
        self.stats.sort += t.elapsed();
    }

    /// Stage (optional): re-estimates fluid volumes from the grid density.
    pub fn reestimate_volumes(&mut self) {
        let t = Instant::now();
        let (spec, kernel) = (&self.spec, self.params.kernel);
        p2g::p2g_mass(
            spec,
            kernel,
            &self.particles,
            &mut self.ws.blocks,
            &mut self.ws.grid,
        );
        let Particles {
            x,
            mass,
            volume0,
            material,
            jacobian,
            ..
        } = &mut self.particles;
        if let Some(jac) = jacobian {
            let (grid_mass, materials) = (&self.ws.grid.mass, &self.materials);
            jac.par_iter_mut().enumerate().for_each(|(p, j)| {
                if matches!(materials[material[p] as usize], Material::Fluid(_)) {
                    *j = mass[p] / (density_at(spec, kernel, grid_mass, &x[p]) * volume0[p]);
                }
            });
        }
        self.stats.volume += t.elapsed();
    }

    /// Stage: P2G with the fused MLS stress impulse for a step of `dt` (s). Requires
    /// [`Self::sort_particles`] first.
    pub fn particle_to_grid(&mut self, dt: Real) {
        let t = Instant::now();
        let flip = matches!(self.params.transfer, Transfer::Flip { .. });
        p2g::p2g(
            &self.spec,
            self.params.kernel,
            self.params.transfer,
            &self.particles,
            &self.materials,
            &mut self.ws.blocks,
            &mut self.ws.grid,
            flip.then_some(&mut self.ws.velocity_old),
            self.params.body_force.as_ref(),
            (self.time, dt),
        );
        self.stats.p2g += t.elapsed();
    }

    /// Stage: grid velocities, gravity and boundaries.
    pub fn update_grid(&mut self, dt: Real) -> Result<(), (Location, Violation, Real)> {
        let t = Instant::now();
        let flip = matches!(self.params.transfer, Transfer::Flip { .. });
        let r = grid_update::update(
            &self.spec,
            &mut self.ws.grid,
            flip.then_some(&mut self.ws.velocity_old),
            &self.boundaries,
            &self.params.gravity,
            self.time,
            dt,
        );
        self.stats.grid_update += t.elapsed();
        r
    }

    /// Stage: G2P into scratch storage with guard checks (particles are not modified).
    pub fn grid_to_particle(&mut self, dt: Real) -> Result<(), (Location, Violation, Real)> {
        let t = Instant::now();
        let flip = matches!(self.params.transfer, Transfer::Flip { .. });
        let ctx = G2pContext {
            spec: &self.spec,
            kernel: self.params.kernel,
            transfer: self.params.transfer,
            materials: &self.materials,
            soft_walls: self.params.soft_walls,
        };
        let r = ctx.gather(
            &self.particles,
            &self.ws.grid,
            flip.then_some(self.ws.velocity_old.as_slice()),
            &mut self.ws.updates,
            dt,
        );
        self.stats.g2p += t.elapsed();
        r
    }

    /// Stage: writes the checked G2P results into the particles.
    pub fn commit(&mut self) {
        let t = Instant::now();
        g2p::commit(&mut self.particles, &self.ws.updates);
        self.stats.commit += t.elapsed();
    }

    /// The stable explicit step bound (s) for the current state, before `dt_max`:
    /// `min(C·Δx / max_p(|v_p| + c_p), Δx²/(2Dν))`. With a fixed dt, `C` is 1.
    pub fn stable_dt(&self) -> Real {
        let cfl = match self.params.time_step {
            TimeStepPolicy::Adaptive { cfl, .. } => cfl,
            TimeStepPolicy::Fixed { .. } => 1.0,
        };
        let max_signal = (0..self.particles.len())
            .into_par_iter()
            .map(|p| self.particles.v[p].norm() + self.wave_speed(p))
            .reduce(|| 0.0, nan_max);
        let max_nu = self
            .materials
            .iter()
            .map(|m| m.viscosity() / m.density())
            .fold(0.0, Real::max);
        stable_dt(cfl, self.spec.dx, max_signal, max_nu, D)
    }

    /// Elastic P-wave or sound speed (m/s) of particle `p` in its current state.
    fn wave_speed(&self, p: usize) -> Real {
        let ps = &self.particles;
        match &self.materials[ps.material[p] as usize] {
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
        let (block_particles, block_grid) = ws.blocks.bytes();
        let vec = std::mem::size_of::<Vector<D>>();
        ScratchBytes {
            particles: block_particles + ws.updates.len() * std::mem::size_of::<Update<D>>(),
            grid: block_grid
                + ws.grid.mass.len() * std::mem::size_of::<Real>()
                + (ws.grid.momentum.len() + ws.grid.velocity.len() + ws.velocity_old.len()) * vec,
        }
    }

    /// Grid node data after the last P2G and grid update.
    pub fn grid(&self) -> &GridNodes<D> {
        &self.ws.grid
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
            &self.params.gravity,
        )
    }

    fn instability(
        &self,
        stage: Stage,
        dt: Real,
        (location, violation, value): (Location, Violation, Real),
        retries: u32,
    ) -> Instability {
        Instability {
            step: self.steps,
            time: self.time,
            dt,
            stage,
            location,
            violation,
            value,
            retries,
        }
    }
}

/// `max` that propagates NaN, so a NaN speed is noticed instead of ignored.
fn nan_max(a: Real, b: Real) -> Real {
    if a.is_nan() || b.is_nan() {
        Real::NAN
    } else {
        a.max(b)
    }
}

fn validate<const D: usize>(
    spec: &GridSpec<D>,
    params: &ExplicitParams<D>,
    materials: &[Material],
    particles: &Particles<D>,
) -> Result<(), SetupError> {
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
    if let Some(&n) = spec.size.iter().find(|&&n| n < params.kernel.support() + 1) {
        return invalid("grid.size", n as Real, "too few nodes for the kernel");
    }
    match params.time_step {
        TimeStepPolicy::Fixed { dt } if !(dt > 0.0 && dt.is_finite()) => {
            return invalid("dt", dt, "must be positive and finite");
        }
        TimeStepPolicy::Adaptive {
            cfl,
            dt_max,
            dt_min,
        } => {
            if !(cfl > 0.0 && cfl.is_finite()) {
                return invalid("cfl", cfl, "must be positive and finite");
            }
            if !(dt_max > 0.0 && dt_max >= dt_min) {
                return invalid("dt_max", dt_max, "must be positive and at least dt_min");
            }
        }
        TimeStepPolicy::Fixed { .. } => {}
    }
    if let Transfer::Flip { blend } = params.transfer {
        if !(0.0..=1.0).contains(&blend) {
            return invalid("flip blend", blend, "must lie in [0, 1]");
        }
    }
    if let Some(sw) = params.soft_walls {
        if !(sw.lookahead > 0.0 && sw.margin >= 0.0) {
            return invalid("soft_walls.lookahead", sw.lookahead, "must be positive");
        }
    }
    let columns = particles.columns();
    for (k, m) in materials.iter().enumerate() {
        let used = particles.material.iter().any(|&i| i as usize == k);
        let missing = if !used {
            None
        } else if m.needs_deformation_gradient() && !columns.deformation_gradient {
            Some("F")
        } else if matches!(m, Material::Fluid(_)) && !columns.jacobian {
            Some("J")
        } else if m.needs_plastic_state() && !columns.plastic {
            Some("plastic")
        } else {
            None
        };
        if let Some(column) = missing {
            return Err(SetupError::MissingColumn {
                material: k,
                column,
            });
        }
    }
    for p in 0..particles.len() {
        let material = particles.material[p];
        if material as usize >= materials.len() {
            return Err(SetupError::UnknownMaterial {
                index: p,
                material,
                count: materials.len(),
            });
        }
        if !spec.contains_stencil(params.kernel, &particles.x[p]) {
            return Err(SetupError::ParticleOutsideGrid {
                index: p,
                position: format!("{:?}", particles.x[p].as_slice()),
            });
        }
    }
    Ok(())
}
