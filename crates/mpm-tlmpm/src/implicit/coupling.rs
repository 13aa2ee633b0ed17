//! The coupling stages of [`ImplicitTlmpm`], for a solver that adds its own projection between
//! the elastic solve and G2P (DIQ-MPM §4.3's operator splitting). Each stage takes the token of
//! the stage before it, so the order is enforced by types: [`ImplicitTlmpm::elastic_predictor`]
//! gives a [`Predicted`] (node velocities `V*`, re-solves with extra node forces);
//! [`ImplicitTlmpm::set_node_velocities`] consumes it for a [`Projected`];
//! [`ImplicitTlmpm::transfer_back`] consumes that for a [`Transferred`] (G2P into scratch);
//! [`ImplicitTlmpm::commit_step`] consumes that once the whole coupled attempt is accepted.
//! Tokens cannot be made outside this crate or copied, and each carries the attempt's `dt`.

use super::{linear_error, predict, solve_grid, ImplicitTlmpm, CHORD_ITERATIONS};
use crate::contact::ContactStats;
use crate::params::LinearSolver;
use crate::NewtonError;
use mpm_core::{Dim, DimOps, Failure, Real, Stage, Vector};

/// The elastic predictor of an attempt ran: the node velocities `V*` of
/// [`ImplicitTlmpm::node_velocities`] are the elastic solve's.
#[derive(Debug)]
pub struct Predicted {
    dt: Real,
    contact: Option<ContactStats>,
}

impl Predicted {
    /// The attempt's time step (s).
    pub fn dt(&self) -> Real {
        self.dt
    }

    /// What the attempt's contact stage found (`None` when contact is off).
    pub fn contact(&self) -> Option<ContactStats> {
        self.contact
    }
}

/// The node velocities of an attempt were set by the coupling's projection.
#[derive(Debug)]
pub struct Projected {
    dt: Real,
}

/// The attempt's G2P ran into scratch storage: the particles are not modified until
/// [`ImplicitTlmpm::commit_step`].
#[derive(Debug)]
pub struct Transferred {
    dt: Real,
}

impl<const D: usize> ImplicitTlmpm<D>
where
    Dim<D>: DimOps<D>,
{
    /// Stage 1 of a coupled attempt of `dt` (s): P2G, external forces, contact and the Newton
    /// elastic solve, which leave the intermediate node velocities `V* = u/Δt`. Nothing is
    /// committed; a failure leaves the particles untouched.
    pub fn elastic_predictor(&mut self, dt: Real) -> Result<Predicted, Failure<NewtonError>> {
        if self.implicit.linear == LinearSolver::Cholesky {
            self.analyse()
                .map_err(|e| Failure::Solve(Stage::SOLVE, linear_error(e)))?;
        }
        self.ws.objective.factored = false;
        let (core, ws, stats, times) = (
            &mut self.core,
            &mut self.ws,
            &mut self.stats,
            &mut self.newton_times,
        );
        let contact = predict(core, ws, stats, times, &self.implicit, dt)?.1;
        Ok(Predicted { dt, contact })
    }

    /// Stage 1b: adds `delta` (N, one per active node) to the external node forces of the
    /// attempt and solves the elastic step again, starting Newton from the last solution, so
    /// that [`Self::node_velocities`] become the elastic response to the forces a coupling
    /// projection applies (the partitioned iteration of DIQ-MPM's coupled step).
    ///
    /// With the Cholesky solver the re-solve first runs chord iterations: Newton's iteration
    /// with the factor of the attempt's last tangent kept (a triangular solve per iteration, no
    /// new tangent or factorisation), to the same tolerance, at most 8 times. The change between
    /// passes is a force increment, linear in the potential, so the old tangent is close and the
    /// chord converges in a few iterations; when it does not, the full Newton re-solve runs from
    /// the same start.
    pub fn resolve_with_node_forces(
        &mut self,
        at: &Predicted,
        delta: &[Vector<D>],
    ) -> Result<(), Failure<NewtonError>> {
        for (f, d) in self.core.external.iter_mut().zip(delta) {
            *f += d;
        }
        let warm = self.core.displacement.clone();
        let (core, ws, times) = (&mut self.core, &mut self.ws, &mut self.newton_times);
        let chord = ws.objective.factored;
        let implicit = self.implicit;
        let dt = at.dt;
        self.stats.time(Stage::SOLVE, || {
            if chord {
                let mut params = implicit;
                params.newton.max_iterations = params.newton.max_iterations.min(CHORD_ITERATIONS);
                ws.objective.frozen = true;
                let r = solve_grid(core, ws, times, &params, dt, Some(&warm));
                ws.objective.frozen = false;
                if r.is_ok() {
                    return Ok(());
                }
            }
            solve_grid(core, ws, times, &implicit, dt, Some(&warm)).map(|_| ())
        })
    }

    /// The node velocities of the attempt (m/s), `u_i/Δt` per active node.
    pub fn node_velocities(&self, at: &Predicted) -> Vec<Vector<D>> {
        self.core.displacement.iter().map(|u| u / at.dt).collect()
    }

    /// Stage 2: replaces the node velocities of the attempt (m/s; one per active node) by `v`,
    /// keeping the prescribed components of fixed nodes.
    pub fn set_node_velocities(&mut self, at: Predicted, v: &[Vector<D>]) -> Projected {
        let c = &self.core.constraints;
        for (i, (u, vi)) in self.core.displacement.iter_mut().zip(v).enumerate() {
            *u = c.displacement(i, vi * at.dt, at.dt);
        }
        Projected { dt: at.dt }
    }

    /// Whether active node `i` has a prescribed (fixed) component, so that a coupling
    /// projection must treat it as infinitely heavy.
    pub fn node_is_fixed(&self, i: usize) -> bool {
        (0..D).any(|a| !self.core.constraints.is_free(i, a))
    }

    /// Stage 3: G2P from the node velocities with the deformation update and the guard checks,
    /// into scratch storage (the particles are not modified yet).
    pub fn transfer_back(&mut self, at: Projected) -> Result<Transferred, Failure<NewtonError>> {
        let core = &mut self.core;
        self.stats
            .time(Stage::G2P, || core.grid_to_particles(at.dt))?;
        Ok(Transferred { dt: at.dt })
    }

    /// A-ULMPM, after [`Self::transfer_back`]: the factor by which each particle's plastic
    /// return mapping changed its elastic volume, `det F_E / det F_E^trial` (1 for elastic
    /// particles); `None` without reference updates.
    pub fn plastic_volume_factors(&self, _at: &Transferred) -> Option<Vec<Real>> {
        self.core
            .adaptive
            .as_ref()
            .map(|a| a.plastic_volume_factors())
    }

    /// Stage 4, once the whole coupled attempt is accepted: writes the G2P results into the
    /// particles, advances time and the step count, and runs the A-ULMPM reference update when
    /// it is on. Returns whether the reference moved.
    pub fn commit_step(&mut self, at: Transferred) -> Result<bool, Failure<NewtonError>> {
        let core = &mut self.core;
        self.stats.time(Stage::COMMIT, || core.commit(at.dt));
        core.time += at.dt;
        core.steps += 1;
        let updated = self
            .stats
            .time(crate::stages::REFERENCE_UPDATE, || core.reference_update())?;
        if updated {
            self.ws.objective.sparse = None;
        }
        Ok(updated)
    }
}
