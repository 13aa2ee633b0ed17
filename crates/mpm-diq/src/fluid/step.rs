//! One step of [`DiqFluid`]: the adaptive step bound, an attempt (sort, P2G, predictor and
//! implicit viscosity, projection, G2P, position correction) that leaves the state untouched,
//! its commit, and the retrying step loop.

use super::{Bins, DiqFluid, NodeFields, Points};
use crate::pressure::{PressureError, PressureInfo, PressureSystem};
use crate::viscosity::Viscous;
use mpm_core::timestep::choose_dt;
use mpm_core::{
    retry_halving, Dim, DimOps, Failure, Location, Matrix, Real, SolveInfo, Stage, StageTimes,
    StepError, StepInfo, StepStart, TimeStepPolicy, Vector, Violation,
};

/// The outcome of one attempt, committed when accepted.
pub(crate) struct Attempt<const D: usize> {
    pub(crate) x: Vec<Vector<D>>,
    pub(crate) v: Vec<Vector<D>>,
    pub(crate) affine: Vec<Matrix<D>>,
    pub(crate) pressure: Vec<Real>,
    pub(crate) divergence: Vec<Real>,
    pub(crate) solves: Vec<SolveInfo>,
    pub(crate) events: Vec<(&'static str, u64)>,
}

impl<const D: usize> DiqFluid<D>
where
    Dim<D>: DimOps<D>,
{
    /// The stable step (s) for the adaptive policy's displacement bound.
    pub(super) fn displacement_dt(&self, fraction: Real) -> Real {
        let vmax = self
            .particles
            .v
            .iter()
            .fold(0.0, |m: Real, v| mpm_core::solver::nan_max(m, v.norm()));
        self.bound_for(vmax, fraction)
    }

    /// The adaptive step bound (s) for particles of largest speed `vmax` (m/s): the `dt` with
    /// `dt (vmax + |g| dt) = cfl Δx`.
    pub(crate) fn displacement_bound(&self, vmax: Real) -> Real {
        self.bound_for(vmax, self.cfl())
    }

    fn bound_for(&self, vmax: Real, fraction: Real) -> Real {
        let g = self.params.step.gravity.norm();
        let c = fraction * self.domain.spec.dx;
        if vmax.is_nan() {
            return Real::NAN;
        }
        let denom = vmax + (vmax * vmax + 4.0 * g * c).sqrt();
        if denom > 0.0 {
            2.0 * c / denom
        } else {
            Real::INFINITY
        }
    }

    pub(super) fn cfl(&self) -> Real {
        match self.params.step.time_step {
            TimeStepPolicy::Adaptive { cfl, .. } => cfl,
            TimeStepPolicy::Fixed { .. } => 0.4,
        }
    }

    /// One attempt at a step of `dt` (s), leaving the solver state untouched.
    fn attempt(
        &self,
        dt: Real,
        projection: &mut PressureSystem<D>,
        correction: &mut PressureSystem<D>,
        times: &mut StageTimes,
    ) -> Result<Attempt<D>, Failure<PressureError>> {
        let (bins, mut nodes) = self.predictor(dt, times)?;
        let (fields, info) = times.time(Stage::SOLVE, || {
            self.project(&mut nodes, &bins, dt, projection)
        })?;
        self.finish(&nodes, &bins, fields, &info, dt, correction, times)
    }

    /// The stages of an attempt before the projection: sort, P2G and the predictor `v*`.
    pub(crate) fn predictor(
        &self,
        dt: Real,
        times: &mut StageTimes,
    ) -> Result<(Bins, NodeFields<D>), Failure<PressureError>> {
        self.predictor_for(Points::of(&self.particles), dt, times)
    }

    /// [`Self::predictor`] over `points` instead of the particles.
    pub(crate) fn predictor_for(
        &self,
        points: Points<'_, D>,
        dt: Real,
        times: &mut StageTimes,
    ) -> Result<(Bins, NodeFields<D>), Failure<PressureError>> {
        let bins = times.time(Stage::SORT, || self.bin(points.x));
        let mut nodes = times.time(Stage::P2G, || self.transfer(points, &bins, true));
        times.time(Stage::GRID_UPDATE, || self.predict(&mut nodes, dt))?;
        nodes.viscous = times.time(Stage::GRID_UPDATE, || self.viscous(&bins, &mut nodes, dt))?;
        Ok((bins, nodes))
    }

    /// `v* = v + dt g` on nodes with mass; guards non-finite node velocities.
    pub(super) fn predict(
        &self,
        nodes: &mut NodeFields<D>,
        dt: Real,
    ) -> Result<(), Failure<PressureError>> {
        let g = self.params.step.gravity;
        for (n, (v, &im)) in nodes.velocity.iter_mut().zip(&nodes.inv_mass).enumerate() {
            if im > 0.0 {
                *v = *v * im + g * dt;
                if !v.iter().all(|c| c.is_finite()) {
                    return Err(Failure::Guard(
                        Stage::GRID_UPDATE,
                        (
                            Location::Node(n),
                            Violation::NonFinite("node velocity"),
                            v.norm(),
                        ),
                    ));
                }
            } else {
                *v = Vector::<D>::zeros();
            }
        }
        Ok(())
    }

    /// The implicit viscous solve on the predictor `nodes.velocity`, over the particles' own
    /// positions and volumes (the first entries of what `bins` sorted); `None` for an inviscid
    /// fluid.
    fn viscous(
        &self,
        bins: &Bins,
        nodes: &mut NodeFields<D>,
        dt: Real,
    ) -> Result<Option<SolveInfo>, Failure<PressureError>> {
        let ps = &self.particles;
        let Some(system) = Viscous::new(
            &self.domain,
            bins,
            (&ps.x, &ps.volume0, &self.viscosity),
            &nodes.mass,
            dt,
        ) else {
            return Ok(None);
        };
        let p = &self.params.pressure;
        system
            .solve(&mut nodes.velocity, (p.rel_tol, p.max_iterations))
            .map(Some)
            .map_err(|e| Failure::Solve(Stage::GRID_UPDATE, e))
    }

    /// The stages of an attempt after the projection: G2P and the position correction, with
    /// the per-cell pressure and divergence `fields` of the projection mapped to particles.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn finish(
        &self,
        nodes: &NodeFields<D>,
        bins: &Bins,
        (pressure_of_cell, divergence_of_cell): (Vec<Real>, Vec<Real>),
        info: &PressureInfo,
        dt: Real,
        correction: &mut PressureSystem<D>,
        times: &mut StageTimes,
    ) -> Result<Attempt<D>, Failure<PressureError>> {
        let (mut x, v, affine) =
            times.time(Stage::G2P, || self.g2p(&self.particles.x, nodes, dt))?;
        let mut solves = vec![SolveInfo {
            name: "pressure",
            iterations: info.iterations,
            residual: info.relative_residual,
        }];
        solves.extend(nodes.viscous);
        let mut events = vec![("pressure_unknowns", info.unknowns as u64)];
        if info.pattern_reused {
            events.push(("pressure_pattern_reused", 1));
        }
        if self.params.position_correction {
            if let Some(c) = times.time(crate::stages::POSITION_CORRECTION, || {
                self.correct_positions(&mut x, dt, correction, &[])
            })? {
                solves.push(SolveInfo {
                    name: "position_correction",
                    iterations: c.iterations,
                    residual: c.relative_residual,
                });
            }
        }
        let pressure = bins.cell.iter().map(|&c| pressure_of_cell[c]).collect();
        let divergence = bins.cell.iter().map(|&c| divergence_of_cell[c]).collect();
        Ok(Attempt {
            x,
            v,
            affine,
            pressure,
            divergence,
            solves,
            events,
        })
    }

    /// Writes an accepted attempt of `dt` (s) into the state.
    pub(crate) fn accept(
        &mut self,
        a: Attempt<D>,
        dt: Real,
    ) -> (Vec<SolveInfo>, Vec<(&'static str, u64)>) {
        self.particles.x = a.x;
        self.particles.v = a.v;
        self.particles.affine = a.affine;
        self.pressure = a.pressure;
        self.divergence = a.divergence;
        self.time += dt;
        self.steps += 1;
        (a.solves, a.events)
    }

    /// [`Solver::step`](mpm_core::Solver::step) on the calling thread, with the pressure-solve
    /// error typed.
    pub(super) fn advance_step(&mut self) -> Result<StepInfo, StepError<PressureError>> {
        let start = StepStart {
            step: self.steps,
            time: self.time,
        };
        let t0 = std::time::Instant::now();
        let stable = self.displacement_dt(self.cfl());
        self.times.add(Stage::TIME_STEP, t0.elapsed());
        let dt0 = choose_dt(&self.params.step.time_step, stable).map_err(|e| {
            start.error(Failure::<PressureError>::Guard(Stage::TIME_STEP, e), 0.0, 0)
        })?;
        let mut projection = std::mem::take(&mut self.projection);
        let mut correction = std::mem::take(&mut self.correction);
        let mut times = std::mem::take(&mut self.times);
        let result = retry_halving(self.params.step.on_instability, start, dt0, |dt| {
            self.attempt(dt, &mut projection, &mut correction, &mut times)
        });
        self.projection = projection;
        self.correction = correction;
        self.times = times;
        let (a, dt, retries) = result?;
        let (solves, events) = self.accept(a, dt);
        Ok(StepInfo {
            dt,
            retries,
            time: self.time,
            solves,
            events,
            residual_histories: Vec::new(),
        })
    }
}
