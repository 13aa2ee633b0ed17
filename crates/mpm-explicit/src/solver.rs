//! The explicit MLS-MPM solver on one background grid.

use crate::blocks::Blocks;
use crate::coupling::{self, GeometryNeeds, PhaseGeometry};
use crate::g2p::{self, Extra, ExtraContext, G2pContext, Update};
use crate::grid_update;
use crate::materials::MaterialView;
use crate::mixing::{self, MixingWork};
use crate::multigrid::{
    CouplingKind, DiffusionScheme, Drag, EffectiveFraction, Friction, PressureBuoyancy,
};
use crate::p2g;
use crate::params::{ExplicitParams, Transfer, VolumeUpdate};
use mpm_core::boundary::Boundaries;
use mpm_core::material::Parameter;
use mpm_core::timestep::{choose_dt, stable_dt};
use mpm_core::volume::density_at;
use mpm_core::{
    Diagnostics, Dim, DimOps, GridNodes, GridSpec, Instability, Location, Material, OnInstability,
    Particles, Real, SetupError, Stage, TimeStepPolicy, Vector, Violation,
};
use rayon::prelude::*;
use std::ops::Mul;
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
    /// Coupling between phase grids (multi-grid only), with its normal and rest-density scatter.
    pub coupling: Duration,
    /// Concentration diffusion (miscible mixing only).
    pub diffusion: Duration,
    /// Grid-to-particle transfer and checks.
    pub g2p: Duration,
    /// Writing accepted particle updates.
    pub commit: Duration,
}

impl StageTimes {
    /// `(stage name, seconds)` for every stage, in execution order.
    pub fn table(&self) -> [(&'static str, f64); 9] {
        [
            ("time_step", self.time_step.as_secs_f64()),
            ("sort", self.sort.as_secs_f64()),
            ("volume", self.volume.as_secs_f64()),
            ("diffusion", self.diffusion.as_secs_f64()),
            ("p2g", self.p2g.as_secs_f64()),
            ("grid_update", self.grid_update.as_secs_f64()),
            ("coupling", self.coupling.as_secs_f64()),
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

/// Scratch memory reused by every step. The per-phase vectors have one entry per phase.
#[derive(Clone, Debug, Default)]
struct Workspace<const D: usize> {
    blocks: Vec<Blocks<D>>,
    grids: Vec<GridNodes<D>>,
    velocity_old: Vec<Vec<Vector<D>>>,
    geometry: Vec<PhaseGeometry<D>>,
    updates: Vec<Update<D>>,
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
    geometry_needs: Vec<GeometryNeeds>,
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
        let phases = params.phases.count as usize;
        Ok(Self {
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
        })
    }

    /// Number of phases (grids).
    pub fn phase_count(&self) -> usize {
        self.ws.grids.len()
    }

    /// Whether the phase grids are coupled (more than one phase): the multi-grid path.
    fn multigrid(&self) -> bool {
        self.phase_count() > 1
    }

    /// Whether G2P computes multi-grid particle state (φ_eff, concentration, dissolution).
    fn has_extra_state(&self) -> bool {
        self.params.porous.is_some()
            || self.params.mixing.is_some()
            || self.params.dissolution.is_some()
    }

    /// The stages a step runs, in order, with the phases and couplings they involve; stages the
    /// scene does not need are left out (DESIGN §5).
    pub fn stage_plan(&self) -> Vec<String> {
        let p = &self.params;
        let mut plan = vec!["time_step".to_string(), "sort".to_string()];
        if p.volume == VolumeUpdate::Reestimate {
            plan.push("volume re-estimation".into());
        }
        if let Some(m) = &p.mixing {
            let scheme = match m.scheme {
                DiffusionScheme::KernelGradient => "kernel gradient",
                DiffusionScheme::MlsDifference => "MLS difference, Eqs. 34-35",
            };
            plan.push(format!(
                "diffusion of materials {} and {} (k_d = {} m^2/s, {scheme})",
                m.fluids[0], m.fluids[1], m.diffusivity
            ));
        }
        plan.push(format!("p2g ({} grid(s))", self.phase_count()));
        plan.push("grid velocities and gravity".into());
        for (k, n) in self.geometry_needs.iter().enumerate() {
            if n.geometry {
                let extra = if n.pressure {
                    " and pore pressure (Eq. 15)"
                } else {
                    ""
                };
                plan.push(format!(
                    "phase {k}: normals and rest density (Eqs. 26, 31){extra}"
                ));
            }
        }
        for c in &p.phases.couplings {
            let [a, b] = c.phases;
            let kind = match c.kind {
                CouplingKind::Full => "full (single-grid)".to_string(),
                CouplingKind::Drag(d) => format!("drag {d:?} (Eqs. 14, 17)"),
                CouplingKind::Contact(cc) => format!(
                    "contact beta = {}, {:?}, {:?} (Eqs. 24-30)",
                    cc.normal_share, cc.friction, cc.activation
                ),
            };
            plan.push(format!("coupling {a}-{b}: {kind}"));
            if let Some(bp) = c.buoyancy {
                plan.push(format!(
                    "coupling {a}-{b}: buoyancy penalty c_b = {} (Eq. 32)",
                    bp.strength
                ));
            }
            if c.pressure_buoyancy == PressureBuoyancy::On {
                plan.push(format!(
                    "coupling {a}-{b}: pore-pressure buoyancy (Eq. 15, unstable)"
                ));
            }
        }
        plan.push("boundaries".into());
        plan.push("g2p".into());
        if let Some(po) = &p.porous {
            plan.push(format!(
                "volume fraction (Eqs. 19-20), phi_eff {:?}, {} interaction(s)",
                po.update,
                po.interactions.len()
            ));
        }
        if let Some(d) = &p.dissolution {
            plan.push(format!(
                "dissolution of material {} into {} (rate {} 1/s)",
                d.solid, d.into, d.rate
            ));
        }
        plan.push("commit".into());
        plan
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
        if self.params.mixing.is_some() {
            self.diffuse(dt);
        }
        self.particle_to_grid(dt);
        self.update_grid(dt).map_err(|e| (Stage::GridUpdate, e))?;
        if self.multigrid() {
            self.couple_phases(dt).map_err(|e| (Stage::GridUpdate, e))?;
        }
        self.grid_to_particle(dt).map_err(|e| (Stage::G2P, e))?;
        self.commit();
        Ok(())
    }

    /// Stage: bins each phase's particles into grid blocks for the deterministic parallel
    /// scatter.
    pub fn sort_particles(&mut self) {
        let t = Instant::now();
        let phase = self.particles.phase.as_deref();
        for (k, blocks) in self.ws.blocks.iter_mut().enumerate() {
            let only = phase.map(|ph| (ph, k as u32));
            blocks.sort(&self.spec, self.params.kernel, &self.particles.x, only);
        }
        self.stats.sort += t.elapsed();
    }

    /// Stage (optional): re-estimates fluid volumes from the grid density.
    pub fn reestimate_volumes(&mut self) {
        let t = Instant::now();
        let (spec, kernel) = (&self.spec, self.params.kernel);
        for (blocks, grid) in self.ws.blocks.iter_mut().zip(self.ws.grids.iter_mut()) {
            p2g::p2g_mass(spec, kernel, &self.particles, blocks, grid);
        }
        let Particles {
            x,
            mass,
            volume0,
            material,
            jacobian,
            phase,
            ..
        } = &mut self.particles;
        if let Some(jac) = jacobian {
            let (grids, materials) = (&self.ws.grids, &self.materials);
            let phase = phase.as_deref();
            jac.par_iter_mut().enumerate().for_each(|(p, j)| {
                if matches!(materials[material[p] as usize], Material::Fluid(_)) {
                    let grid_mass = &grids[phase.map_or(0, |k| k[p] as usize)].mass;
                    *j = mass[p] / (density_at(spec, kernel, grid_mass, &x[p]) * volume0[p]);
                }
            });
        }
        self.stats.volume += t.elapsed();
    }

    /// Stage (mixing only): diffuses the concentration of the mixing fluids over a step of
    /// `dt` (s) into scratch storage, committed with the step. Requires [`Self::sort_particles`].
    pub fn diffuse(&mut self, dt: Real) {
        let Some(mix) = &self.params.mixing else {
            return;
        };
        let t = Instant::now();
        let phase = self.mixing_phase();
        mixing::diffuse(
            &self.spec,
            self.params.kernel,
            mix,
            &self.particles,
            &mut self.ws.blocks[phase],
            &mut self.ws.mixing,
            dt,
        );
        self.stats.diffusion += t.elapsed();
    }

    /// The phase of the mixing fluids (all in one phase, checked at setup).
    fn mixing_phase(&self) -> usize {
        let fluids = self.params.mixing.map_or([u32::MAX; 2], |m| m.fluids);
        (0..self.particles.len())
            .find(|&p| fluids.contains(&self.particles.material[p]))
            .map_or(0, |p| self.particles.phase_of(p) as usize)
    }

    /// Stage: P2G of every phase onto its own grid, with the fused MLS stress impulse for a step
    /// of `dt` (s). Requires [`Self::sort_particles`] first.
    pub fn particle_to_grid(&mut self, dt: Real) {
        let t = Instant::now();
        let flip = matches!(self.params.transfer, Transfer::Flip { .. });
        let view = material_view(&self.materials, &self.params);
        let ws = &mut self.ws;
        for ((blocks, grid), v0) in ws
            .blocks
            .iter_mut()
            .zip(ws.grids.iter_mut())
            .zip(ws.velocity_old.iter_mut())
        {
            p2g::p2g(
                &self.spec,
                self.params.kernel,
                self.params.transfer,
                &self.particles,
                &view,
                blocks,
                grid,
                flip.then_some(v0),
                self.params.body_force.as_ref(),
                (self.time, dt),
            );
        }
        self.stats.p2g += t.elapsed();
    }

    /// Stage: grid velocities and gravity for every phase; boundaries too on a single grid
    /// (multi-grid runs apply them after the coupling stage).
    pub fn update_grid(&mut self, dt: Real) -> Result<(), (Location, Violation, Real)> {
        let t = Instant::now();
        let flip = matches!(self.params.transfer, Transfer::Flip { .. });
        let boundaries = (!self.multigrid()).then_some(&self.boundaries);
        let mut r = Ok(());
        for (grid, v0) in self
            .ws
            .grids
            .iter_mut()
            .zip(self.ws.velocity_old.iter_mut())
        {
            r = r.and(grid_update::update(
                &self.spec,
                grid,
                flip.then_some(v0),
                boundaries,
                &self.params.gravity,
                self.time,
                dt,
            ));
        }
        self.stats.grid_update += t.elapsed();
        r
    }

    /// Stage (multi-grid only): scatters the normals and rest densities the couplings need,
    /// applies every coupling in order, then the boundaries of every phase.
    pub fn couple_phases(&mut self, dt: Real) -> Result<(), (Location, Violation, Real)> {
        let t = Instant::now();
        let view = material_view(&self.materials, &self.params);
        let ws = &mut self.ws;
        for (k, needs) in self.geometry_needs.iter().enumerate() {
            if needs.geometry {
                coupling::scatter_geometry(
                    &self.spec,
                    self.params.kernel,
                    &self.particles,
                    &view,
                    &mut ws.blocks[k],
                    &mut ws.geometry[k],
                    needs.pressure,
                );
            }
        }
        for c in &self.params.phases.couplings {
            coupling::couple(
                &self.spec,
                c,
                &mut ws.grids,
                &ws.geometry,
                &self.params.gravity,
                dt,
            );
        }
        let mut r = Ok(());
        for grid in ws.grids.iter_mut() {
            r = r.and(grid_update::apply_boundaries(
                &self.spec,
                grid,
                &self.boundaries,
                self.time,
            ));
        }
        self.stats.coupling += t.elapsed();
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
            materials: material_view(&self.materials, &self.params),
            soft_walls: self.params.soft_walls,
        };
        let r = ctx.gather(
            &self.particles,
            &self.ws.grids,
            flip.then_some(self.ws.velocity_old.as_slice()),
            &mut self.ws.updates,
            dt,
        );
        if r.is_ok() && self.has_extra_state() {
            let mixing_ran = self.params.mixing.is_some();
            let extra = ExtraContext {
                porous: self.params.porous.as_ref(),
                dissolution: self.params.dissolution.as_ref(),
                node_concentration: &self.ws.mixing.concentration,
                alpha: mixing_ran.then_some(self.ws.mixing.alpha.as_slice()),
            };
            ctx.gather_extra(
                &self.particles,
                &self.ws.grids,
                &extra,
                &mut self.ws.extras,
                dt,
            );
        }
        self.stats.g2p += t.elapsed();
        r
    }

    /// Stage: writes the checked G2P results into the particles.
    pub fn commit(&mut self) {
        let t = Instant::now();
        g2p::commit(&mut self.particles, &self.ws.updates);
        if self.has_extra_state() {
            g2p::commit_extra(
                &mut self.particles,
                &self.ws.extras,
                &self.materials,
                self.params.mixing.as_ref(),
                self.params.dissolution.as_ref(),
            );
        }
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
            particles: ws.updates.len() * std::mem::size_of::<Update<D>>()
                + ws.extras.len() * std::mem::size_of::<Extra>(),
            grid: ws.mixing.bytes(),
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

    /// Grid node data of phase 0 after the last P2G and grid update.
    pub fn grid(&self) -> &GridNodes<D> {
        &self.ws.grids[0]
    }

    /// Grid node data of phase `k` after the last P2G, grid update and coupling.
    pub fn phase_grid(&self, k: usize) -> Option<&GridNodes<D>> {
        self.ws.grids.get(k)
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

/// The per-particle material resolver of a scene.
fn material_view<'a, const D: usize>(
    materials: &'a [Material],
    params: &'a ExplicitParams<D>,
) -> MaterialView<'a> {
    MaterialView::new(materials, params.porous.as_ref(), params.mixing.as_ref())
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
    params.time_step.validate()?;
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
    validate_multigrid(params, materials, particles)?;
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

/// Checks the phases, couplings, porous interaction, mixing and dissolution against the
/// materials and particle columns.
fn validate_multigrid<const D: usize>(
    params: &ExplicitParams<D>,
    materials: &[Material],
    particles: &Particles<D>,
) -> Result<(), SetupError> {
    let fail = |setting: &str, reason: String| {
        Err(SetupError::InvalidSetting {
            setting: setting.to_string(),
            reason,
        })
    };
    let count = params.phases.count;
    let columns = particles.columns();
    if count == 0 {
        return fail("phases", "there must be at least one phase".into());
    }
    if count > 1 && !columns.phase {
        return fail(
            "phases",
            format!("{count} phases need the particle column `phase`"),
        );
    }
    if let Some(p) = (0..particles.len()).find(|&p| particles.phase_of(p) >= count) {
        return fail(
            "phases",
            format!(
                "particle {p} is in phase {}, but only {count} exist",
                particles.phase_of(p)
            ),
        );
    }
    let nonneg = |x: Real| x >= 0.0 && x.is_finite();
    for (n, c) in params.phases.couplings.iter().enumerate() {
        let name = format!("coupling {n}");
        let [a, b] = c.phases;
        if a == b || a >= count || b >= count {
            return fail(
                &name,
                format!("phases {a} and {b} must be distinct and below {count}"),
            );
        }
        let ok = match c.kind {
            CouplingKind::Full => true,
            CouplingKind::Drag(Drag::Coefficient(k)) => k >= 0.0,
            CouplingKind::Drag(Drag::Permeability {
                porosity,
                conductivity,
            }) => porosity > 0.0 && porosity <= 1.0 && conductivity > 0.0,
            CouplingKind::Contact(cc) => {
                let delta = match cc.friction {
                    Friction::Coulomb(d) | Friction::Proportional(d) => d,
                };
                (0.0..=1.0).contains(&cc.normal_share) && delta >= 0.0
            }
        };
        if !ok {
            return fail(
                &name,
                "drag coefficient, porosity (0, 1], conductivity > 0, normal share [0, 1] and \
                 friction >= 0 are required"
                    .into(),
            );
        }
        if c.buoyancy.is_some_and(|bp| !nonneg(bp.strength)) {
            return fail(&name, "the buoyancy strength c_b must be >= 0".into());
        }
    }
    if let Some(porous) = &params.porous {
        if count < 2 {
            return fail(
                "porous",
                "porous interaction needs at least two phases".into(),
            );
        }
        if !columns.volume_fraction {
            return fail("porous", "needs the particle column `phi_eff`".into());
        }
        if let EffectiveFraction::Relax { rate } | EffectiveFraction::MaxRelax { rate } =
            porous.update
        {
            if !nonneg(rate) {
                return fail("porous", format!("relaxation rate {rate} must be >= 0"));
            }
        }
        for it in &porous.interactions {
            let Some(m) = materials.get(it.material as usize) else {
                return fail("porous", format!("unknown material {}", it.material));
            };
            if !it.parameter.applies_to(m) {
                return fail(
                    "porous",
                    format!(
                        "material {} has no parameter {:?}",
                        it.material, it.parameter
                    ),
                );
            }
            if !(it.scaling.exponent > 0.0
                && it.scaling.offset.is_finite()
                && it.scaling.slope.is_finite())
            {
                return fail(
                    "porous",
                    "scaling needs exponent > 0 and finite offset and slope".into(),
                );
            }
        }
    }
    if let Some(mix) = &params.mixing {
        for k in mix.fluids {
            if !matches!(materials.get(k as usize), Some(Material::Fluid(_))) {
                return fail("mixing", format!("material {k} is not a fluid"));
            }
        }
        if mix.fluids[0] == mix.fluids[1] {
            return fail("mixing", "the two fluids must differ".into());
        }
        if !columns.concentration {
            return fail("mixing", "needs the particle column `concentration`".into());
        }
        if !nonneg(mix.diffusivity) {
            return fail(
                "mixing",
                format!("diffusivity {} must be >= 0", mix.diffusivity),
            );
        }
        if mix.scheme == DiffusionScheme::MlsDifference
            && params.kernel.mls_inertia_inv(1.0).is_none()
        {
            return fail(
                "mixing",
                "the MLS difference scheme needs a quadratic or cubic kernel".into(),
            );
        }
        let mut phases = (0..particles.len())
            .filter(|&p| mix.fluids.contains(&particles.material[p]))
            .map(|p| particles.phase_of(p));
        if let Some(first) = phases.next() {
            if phases.any(|k| k != first) {
                return fail(
                    "mixing",
                    "all particles of the two fluids must be in one phase".into(),
                );
            }
        }
    }
    if let Some(d) = &params.dissolution {
        if !matches!(materials.get(d.solid as usize), Some(Material::Solid(_))) {
            return fail(
                "dissolution",
                format!("material {} is not a solid", d.solid),
            );
        }
        if params.mixing.is_none_or(|m| m.fluids[1] != d.into) {
            return fail(
                "dissolution",
                format!("material {} must be the second fluid of the mixing", d.into),
            );
        }
        if d.fluid_phase >= count || !nonneg(d.rate) {
            return fail(
                "dissolution",
                "needs an existing fluid phase and a rate >= 0".into(),
            );
        }
        if !columns.concentration {
            return fail(
                "dissolution",
                "needs the particle column `concentration`".into(),
            );
        }
        let fluids = params.mixing.map_or([u32::MAX; 2], |m| m.fluids);
        if let Some(p) = (0..particles.len()).find(|&p| fluids.contains(&particles.material[p])) {
            if particles.phase_of(p) != d.fluid_phase {
                return fail(
                    "dissolution",
                    format!(
                        "the mixing fluids must be in the solvent phase {}",
                        d.fluid_phase
                    ),
                );
            }
        }
    }
    Ok(())
}
