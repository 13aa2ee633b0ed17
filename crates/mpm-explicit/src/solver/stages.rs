//! The stages of an [`ExplicitSolver`] step: particle binning and the sparse grid layout,
//! volume re-estimation, concentration diffusion, P2G, the grid update, phase coupling, G2P and
//! the commit of the multi-grid state, and the mirrored-wall ghost helpers they use.

use super::{material_view, ExplicitSolver, Workspace};
use crate::blocks::GridRef;
use crate::coupling;
use crate::g2p::{self, ExtraContext, G2pContext};
use crate::grid_update::{self, NodeForces};
use crate::mixing;
use crate::p2g;
use crate::params::Transfer;
use mpm_core::mirror::MirrorWalls;
use mpm_core::quasistatic::gravity_at;
use mpm_core::volume::density_at;
use mpm_core::{
    Dim, DimOps, GridNodes, Location, Material, NodeLayout, Particles, Real, Stage, TimeStepPolicy,
    Vector, Violation,
};
use rayon::prelude::*;
use std::time::Instant;

impl<const D: usize> ExplicitSolver<D>
where
    Dim<D>: DimOps<D>,
{
    /// Stage: bins each phase's particles into grid blocks for the deterministic parallel
    /// scatter, and lays out the sparse grid: the blocks the phases reach, and with mirrored
    /// walls the blocks of their ghosts' mirrors.
    pub(super) fn sort_particles(&mut self) {
        let t = Instant::now();
        let phase = self.particles.phase.as_deref();
        let ws = &mut self.ws;
        ws.layout.begin(&self.spec);
        for (k, blocks) in ws.blocks.iter_mut().enumerate() {
            let only = phase.map(|ph| (ph, k as u32));
            blocks.sort(&self.spec, self.params.kernel, &self.particles.x, only);
            blocks.mark(&mut ws.layout);
        }
        if let Some(m) = &self.mirror {
            m.mark(&mut ws.layout);
        }
        ws.layout.finish();
        self.stats.add(Stage::SORT, t.elapsed());
    }

    /// Stage (optional): re-estimates fluid volumes from the grid density.
    pub(super) fn reestimate_volumes(&mut self) {
        let t = Instant::now();
        let (spec, kernel) = (&self.spec, self.params.kernel);
        let layout = &self.ws.layout;
        for (blocks, grid) in self.ws.blocks.iter_mut().zip(self.ws.grids.iter_mut()) {
            p2g::p2g_mass(spec, layout, kernel, &self.particles, blocks, grid);
            if let Some(m) = &self.mirror {
                m.mirror_mass(layout, &mut grid.mass);
            }
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
                    *j =
                        mass[p] / (density_at(spec, kernel, layout, grid_mass, &x[p]) * volume0[p]);
                }
            });
        }
        self.stats.add(crate::stages::VOLUME, t.elapsed());
    }

    /// Stage (mixing only): diffuses the concentration of the mixing fluids over a step of
    /// `dt` (s) into scratch storage, committed with the step. Requires [`Self::sort_particles`].
    pub(super) fn diffuse(&mut self, dt: Real) {
        let Some(mix) = &self.params.mixing else {
            return;
        };
        let t = Instant::now();
        let phase = self.mixing_phase();
        let grid = GridRef {
            spec: &self.spec,
            layout: &self.ws.layout,
            kernel: self.params.kernel,
        };
        mixing::diffuse(
            grid,
            mix,
            &self.particles,
            &mut self.ws.blocks[phase],
            &mut self.ws.mixing,
            dt,
        );
        self.stats.add(crate::stages::DIFFUSION, t.elapsed());
    }

    /// The phase of the mixing fluids (all in one phase, checked at setup).
    fn mixing_phase(&self) -> usize {
        let fluids = self.params.mixing.map_or([u32::MAX; 2], |m| m.fluids);
        (0..self.particles.len())
            .find(|&p| fluids.contains(&self.particles.material[p]))
            .map_or(0, |p| self.particles.phase_of(p) as usize)
    }

    /// Whether P2G also transfers the momentum without forces (FLIP's old velocities, the
    /// damping's velocity before the update).
    fn needs_momentum0(&self) -> bool {
        matches!(self.params.transfer, Transfer::Flip { .. }) || !self.params.step.damping.is_off()
    }

    /// Stage: P2G of every phase onto its own grid, with the fused MLS stress impulse for a step
    /// of `dt` (s). Requires [`Self::sort_particles`] first.
    pub(super) fn particle_to_grid(&mut self, dt: Real) {
        let t = Instant::now();
        let with0 = self.needs_momentum0();
        let view = material_view(&self.materials, &self.params);
        let Workspace {
            layout,
            blocks,
            grids,
            velocity_old,
            ..
        } = &mut self.ws;
        let inputs = p2g::P2gInputs {
            spec: &self.spec,
            layout,
            kernel: self.params.kernel,
            transfer: self.params.transfer,
            particles: &self.particles,
            materials: &view,
            body_force: self.params.body_force.as_ref(),
            step: (self.time, dt),
        };
        for ((blocks, grid), v0) in blocks
            .iter_mut()
            .zip(grids.iter_mut())
            .zip(velocity_old.iter_mut())
        {
            inputs.p2g(blocks, grid, with0.then_some(v0));
        }
        self.stats.add(Stage::P2G, t.elapsed());
    }

    /// Gravity (m/s²) at the start of the step, ramped where the parameters ramp it.
    fn gravity(&self) -> Vector<D> {
        gravity_at(
            &self.params.step.gravity,
            self.params.step.gravity_ramp.as_ref(),
            self.time,
        )
    }

    /// Stage: grid velocities, gravity and damping for every phase; boundaries too on a single
    /// grid (multi-grid runs apply them after the coupling stage).
    pub(super) fn update_grid(&mut self, dt: Real) -> Result<(), (Location, Violation, Real)> {
        let t = Instant::now();
        let with0 = self.needs_momentum0();
        let forces = NodeForces {
            gravity: self.gravity(),
            damping: (!self.params.step.damping.is_off()).then_some(self.params.step.damping),
        };
        let boundaries = (!self.multigrid()).then_some(&self.boundaries);
        let mut r = Ok(());
        let layout = &self.ws.layout;
        for (grid, v0) in self
            .ws
            .grids
            .iter_mut()
            .zip(self.ws.velocity_old.iter_mut())
        {
            if let Some(m) = &self.mirror {
                fold_ghosts(m, layout, grid, with0.then_some(v0), forces.gravity * dt);
            }
            let at = GridRef {
                spec: &self.spec,
                layout,
                kernel: self.params.kernel,
            };
            r = r.and(grid_update::update(
                at,
                grid,
                with0.then_some(v0),
                boundaries,
                &forces,
                self.time,
                dt,
            ));
            if let (Some(m), Some(_)) = (&self.mirror, boundaries) {
                fill_ghosts(m, layout, grid, with0.then_some(v0));
            }
        }
        self.stats.add(Stage::GRID_UPDATE, t.elapsed());
        r
    }

    /// Stage (multi-grid only): scatters the normals and rest densities the couplings need,
    /// applies every coupling in order, then the boundaries of every phase.
    pub(super) fn couple_phases(&mut self, dt: Real) -> Result<(), (Location, Violation, Real)> {
        let t = Instant::now();
        let view = material_view(&self.materials, &self.params);
        let gravity = self.gravity();
        let with0 = self.needs_momentum0();
        let ws = &mut self.ws;
        for (k, needs) in self.geometry_needs.iter().enumerate() {
            if needs.geometry {
                coupling::scatter_geometry(
                    GridRef {
                        spec: &self.spec,
                        layout: &ws.layout,
                        kernel: self.params.kernel,
                    },
                    &self.particles,
                    &view,
                    &mut ws.blocks[k],
                    &mut ws.geometry[k],
                    needs.pressure,
                );
            }
        }
        for c in &self.params.phases.couplings {
            coupling::couple(&self.spec, c, &mut ws.grids, &ws.geometry, &gravity, dt);
        }
        let mut r = Ok(());
        for (grid, v0) in ws.grids.iter_mut().zip(ws.velocity_old.iter_mut()) {
            r = r.and(grid_update::apply_boundaries(
                &self.spec,
                &ws.layout,
                grid,
                &self.boundaries,
                self.time,
            ));
            if let Some(m) = &self.mirror {
                fill_ghosts(m, &ws.layout, grid, with0.then_some(v0));
            }
        }
        self.stats.add(crate::stages::COUPLING, t.elapsed());
        r
    }

    /// Stage: G2P with guard checks, writing the particles in place. The multi-grid particle
    /// state is gathered first, from the positions at the start of the step, into scratch.
    /// Advances the first `active` particles only. Returns the new state's largest signal
    /// speed (m/s) under an adaptive dt, else 0.
    pub(super) fn grid_to_particle(
        &mut self,
        dt: Real,
        active: usize,
    ) -> Result<Real, (Location, Violation, Real)> {
        let t = Instant::now();
        let flip = matches!(self.params.transfer, Transfer::Flip { .. });
        let ws = &mut self.ws;
        for ((blocks, grid), v0) in ws.blocks.iter_mut().zip(&ws.grids).zip(&ws.velocity_old) {
            blocks.load_velocities(&ws.layout, &grid.velocity, flip.then_some(v0.as_slice()));
        }
        let ctx = G2pContext {
            spec: &self.spec,
            layout: &self.ws.layout,
            kernel: self.params.kernel,
            transfer: self.params.transfer,
            materials: material_view(&self.materials, &self.params),
            soft_walls: self.params.soft_walls,
            signal_speed: matches!(self.params.step.time_step, TimeStepPolicy::Adaptive { .. }),
        };
        if self.has_extra_state() {
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
        let r = ctx.advance(
            &mut self.particles,
            &self.ws.blocks,
            &self.ws.grids,
            flip.then_some(self.ws.velocity_old.as_slice()),
            dt,
            active,
        );
        self.stats.add(Stage::G2P, t.elapsed());
        r
    }

    /// Stage (multi-grid state only): writes the gathered volume fractions, concentrations and
    /// dissolution into the particles once G2P has passed its checks.
    pub(super) fn commit_extra(&mut self) {
        let t = Instant::now();
        g2p::commit_extra(
            &mut self.particles,
            &self.ws.extras,
            &self.materials,
            self.params.mixing.as_ref(),
            self.params.dissolution.as_ref(),
        );
        self.stats.add(Stage::COMMIT, t.elapsed());
    }
}

/// Folds the mirrored ghost layers of `grid` (and of the momentum without forces `momentum0`)
/// into their mirror nodes after P2G; `gravity_impulse` is `Δt g` (m/s).
fn fold_ghosts<const D: usize>(
    mirror: &MirrorWalls<D>,
    layout: &NodeLayout<D>,
    grid: &mut GridNodes<D>,
    momentum0: Option<&mut Vec<Vector<D>>>,
    gravity_impulse: Vector<D>,
) {
    let mut channels = vec![(grid.momentum.as_mut_slice(), Some(gravity_impulse))];
    if let Some(p0) = momentum0 {
        channels.push((p0.as_mut_slice(), None));
    }
    mirror.fold(layout, &mut grid.mass, &mut channels);
}

/// Gives the ghost nodes of `grid` (and the pre-update velocities `velocity0`) the reflected
/// velocities of their mirror nodes after the boundaries.
fn fill_ghosts<const D: usize>(
    mirror: &MirrorWalls<D>,
    layout: &NodeLayout<D>,
    grid: &mut GridNodes<D>,
    velocity0: Option<&mut Vec<Vector<D>>>,
) {
    mirror.fill(layout, &mut grid.velocity);
    if let Some(v0) = velocity0 {
        mirror.fill(layout, v0);
    }
}
