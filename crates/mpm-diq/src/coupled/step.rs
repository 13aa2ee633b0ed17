//! One attempt at a coupled step: the fluid predictor and the solid's elastic predictor, the
//! coupled projection iterated with the elastic solve ([`CouplingIteration`]), the solid's G2P
//! and the fluid's G2P over its quadrature points with the position correction, and the commit
//! of an accepted attempt.

use super::interface::FluidPoints;

use super::params::{lift, CoupledError, InterfaceQuadrature};
use super::DiqCoupled;
use crate::fluid::{Attempt, Bins, NodeFields, Points};
use crate::pressure::{Constraints, PressureInfo, PressureSystem, UnknownKind};
use mpm_core::{Dim, DimOps, Failure, Matrix, Real, SolveInfo, Solver, Stage, StageTimes, Vector};
use mpm_linalg::Anderson;
use mpm_tlmpm::{Predicted, Transferred};
use rayon::prelude::*;

/// One attempt's results, committed when the whole attempt is accepted.
pub(super) struct Pending<const D: usize> {
    /// The solid's G2P, waiting for its commit.
    solid: Transferred,
    fluid: Option<Attempt<D>>,
    pub(super) solid_pressure: Vec<Real>,
    pub(super) solves: Vec<SolveInfo>,
    pub(super) interface_points: usize,
    pub(super) contact_pairs: Option<usize>,
}

impl<const D: usize> DiqCoupled<D>
where
    Dim<D>: DimOps<D>,
{
    /// One attempt at a step of `dt` (s); the state is untouched until [`Self::commit`].
    pub(super) fn attempt(&mut self, dt: Real) -> Result<Pending<D>, Failure<CoupledError>> {
        let mut times = std::mem::take(&mut self.times);
        let r = self.attempt_timed(dt, &mut times);
        self.times = times;
        r
    }

    pub(super) fn attempt_timed(
        &mut self,
        dt: Real,
        times: &mut StageTimes,
    ) -> Result<Pending<D>, Failure<CoupledError>> {
        let (iq, points) = times.time(crate::stages::COUPLING, || {
            let iq = self.interface_points();
            let points = self.fluid_points(&iq);
            (iq, points)
        });
        let (bins, mut nodes) = self
            .fluid
            .predictor_for(points.points(), dt, times)
            .map_err(lift)?;
        let predicted = self.solid.elastic_predictor(dt).map_err(lift)?;
        let contact = predicted.contact();
        let v_solid = self.solid.node_velocities(&predicted);
        let (rows, inv_mass, u, volumes) = times.time(crate::stages::COUPLING, || {
            self.coupled_rows((&points, &iq), &nodes, &bins, &v_solid, dt)
        });
        let mut system = std::mem::take(&mut self.projection);
        let solved = self.project_iterated(&predicted, (&rows, &inv_mass), u, &mut system, times);
        self.projection = system;
        let (lambda, u, info, passes) = solved?;
        let nf = nodes.velocity.len();
        let projected = self.solid.set_node_velocities(predicted, &u[nf..]);
        let transferred = self.solid.transfer_back(projected).map_err(lift)?;
        nodes.velocity.copy_from_slice(&u[..nf]);
        let fluid = if self.has_fluid() {
            let fields = self.fluid.cell_fields(&rows, &lambda, &u, &volumes);
            let mut correction = std::mem::take(&mut self.correction);
            let r = self.fluid_back(&points, (&nodes, &bins), fields, dt, &mut correction, times);
            self.correction = correction;
            Some(r?)
        } else {
            None
        };
        let mut solid_pressure = vec![0.0; self.solid_pressure.len()];
        for (k, kind) in rows.kinds().iter().enumerate() {
            if *kind == UnknownKind::SolidPressure {
                let (_, members) = self
                    .solid_cells
                    .iter()
                    .find(|(c, _)| *c == rows.anchors()[k])
                    .expect("every solid row is a solid cell");
                for &p in members {
                    solid_pressure[p] = lambda[k];
                }
            }
        }
        self.plastic_pressure_correction(&transferred, &mut solid_pressure);
        let mut solves = vec![
            SolveInfo {
                name: "coupled_pressure",
                iterations: info.iterations,
                residual: info.relative_residual,
            },
            passes,
        ];
        solves.extend(nodes.viscous);
        if let Some(f) = &fluid {
            solves.extend(f.solves.iter().copied());
        }
        Ok(Pending {
            solid: transferred,
            fluid,
            solid_pressure,
            solves,
            interface_points: iq.particle.len(),
            contact_pairs: contact.map(|c| c.pairs),
        })
    }

    /// Plastic particles (`docs/diq-coupling.md`, "Plastic solids"): the return mapping scaled the elastic
    /// volume ratio by `r = det F_E / det F_E^trial`, so the remapped `J_E = 1 − P/λ^v` becomes
    /// `r J_E`, i.e. `P ← λ^v − r (λ^v − P)`. Elastic particles are left as they are.
    pub(super) fn plastic_pressure_correction(
        &self,
        at: &Transferred,
        solid_pressure: &mut [Real],
    ) {
        let Some(factors) = self.solid.plastic_volume_factors(at) else {
            return;
        };
        for (p, pressure) in solid_pressure.iter_mut().enumerate() {
            if self.plastic[p] {
                let lv = self.lambda_v[p];
                *pressure = lv - factors[p] * (lv - *pressure);
            }
        }
    }

    /// The coupled projection of the predictor velocities `u` (fluid nodes, then the solid's
    /// reference nodes; m/s) with the rows `rows`, iterated with the solid's elastic solve (see
    /// [`CouplingIteration`]). Returns the pressures and the velocities of the last projection,
    /// its solver report, and the iteration's report (`coupling_passes`: projections, and the
    /// last strain mismatch as its residual).
    #[allow(clippy::type_complexity)]
    pub(super) fn project_iterated(
        &mut self,
        predicted: &Predicted,
        (rows, inv_mass): (&Constraints<D>, &[Real]),
        u: Vec<Vector<D>>,
        system: &mut PressureSystem<D>,
        times: &mut StageTimes,
    ) -> Result<(Vec<Real>, Vec<Vector<D>>, PressureInfo, SolveInfo), Failure<CoupledError>> {
        let stage = crate::stages::COUPLING;
        let dt = predicted.dt();
        let fluid = &self.fluid;
        times
            .time(stage, || {
                fluid.assemble_onto(rows, inv_mass, dt, system, stage)
            })
            .map_err(lift)?;
        let nf = u.len() - self.solid.reference().node_masses().len();
        let inv_solid = &inv_mass[nf..];
        let dx = Solver::spec(&self.fluid).dx;
        let it = self.solid_params.coupling;
        let mut force = vec![Vector::<D>::zeros(); inv_solid.len()];
        let mut relax = Anderson::<Vector<D>>::default();
        let mut passes = 0;
        loop {
            passes += 1;
            // Ṽ = V*(f) − Δt M⁻¹ f: the elastic velocities without the lumped response to f.
            let v_star = self.solid.node_velocities(predicted);
            let mut v = u[..nf].to_vec();
            v.extend(
                v_star
                    .iter()
                    .zip(&force)
                    .zip(inv_solid)
                    .map(|((v, f), &w)| v - f * (dt * w)),
            );
            let tilde = v[nf..].to_vec();
            let (lambda, info) = times
                .time(stage, || {
                    fluid.project_assembled(rows, inv_mass, dt, &mut v, system, stage)
                })
                .map_err(lift)?;
            let mismatch = v[nf..]
                .iter()
                .zip(&v_star)
                .map(|(a, b)| (a - b).norm())
                .fold(0.0, Real::max)
                * dt
                / dx;
            if mismatch <= it.strain_tolerance || passes >= it.max_passes.max(1) {
                let report = SolveInfo {
                    name: "coupling_passes",
                    iterations: passes as u32,
                    residual: mismatch,
                };
                return Ok((lambda, v, info, report));
            }
            // f' = M (V − Ṽ)/Δt, zero on fixed nodes (M⁻¹ = 0).
            let target: Vec<Vector<D>> = v[nf..]
                .iter()
                .zip(&tilde)
                .zip(inv_solid)
                .map(|((a, b), &w)| {
                    if w > 0.0 {
                        (a - b) / (dt * w)
                    } else {
                        Vector::<D>::zeros()
                    }
                })
                .collect();
            let delta = relax.step(&force, &target);
            for (f, d) in force.iter_mut().zip(&delta) {
                *f += d;
            }
            self.solid
                .resolve_with_node_forces(predicted, &delta)
                .map_err(lift)?;
        }
    }

    /// The current volume `J_p V⁰_p` of the solid particles inside the fluid's wall box,
    /// spread to the fluid grid's nodes with the B1 weights (m^D per node).
    pub(super) fn solid_node_volume(&self) -> Vec<Real> {
        let sp = self.solid.particles();
        let domain = self.fluid.domain();
        let inside: Vec<usize> = (0..sp.len())
            .filter(|&q| domain.locate(&sp.x[q]).is_some())
            .collect();
        let x: Vec<Vector<D>> = inside.iter().map(|&q| sp.x[q]).collect();
        let volume: Vec<Real> = inside
            .iter()
            .map(|&q| Dim::<D>::det(&sp.def_grad_of(q)).max(0.0) * sp.volume0[q])
            .collect();
        let (zero_v, zero_c) = (
            vec![Vector::<D>::zeros(); x.len()],
            vec![Matrix::<D>::zeros(); x.len()],
        );
        let points = Points {
            x: &x,
            v: &zero_v,
            affine: &zero_c,
            mass: &volume,
            volume: &volume,
        };
        let bins = self.fluid.bin(&x);
        self.fluid.transfer(points, &bins, false).volume
    }

    /// Fluid G2P over the quadrature points: each fluid particle takes the mean of the
    /// velocities and affine matrices at itself and at the interface points it shared its
    /// mass with (the transpose of the split in [`FluidPoints`], so momentum is conserved),
    /// moves by it and is clamped; then the position correction, when on.
    pub(super) fn fluid_back(
        &self,
        points: &FluidPoints<D>,
        (nodes, bins): (&NodeFields<D>, &Bins),
        (pressure_of_cell, divergence_of_cell): (Vec<Real>, Vec<Real>),
        dt: Real,
        correction: &mut PressureSystem<D>,
        times: &mut StageTimes,
    ) -> Result<Attempt<D>, Failure<CoupledError>> {
        let fp = Solver::particles(&self.fluid);
        let n = fp.len();
        let (_, v_all, c_all) = times
            .time(Stage::G2P, || self.fluid.g2p(&points.x, nodes, dt))
            .map_err(lift)?;
        let domain = self.fluid.domain();
        let (dx, t_end) = (domain.spec.dx, self.time + dt);
        let moved: Vec<(Vector<D>, Vector<D>, Matrix<D>)> = (0..n)
            .into_par_iter()
            .map(|p| {
                let shared = &points.shared[points.shared_start[p]..points.shared_start[p + 1]];
                let (mut v, mut c) = (v_all[p], c_all[p]);
                for &k in shared {
                    v += v_all[n + k];
                    c += c_all[n + k];
                }
                let s = 1.0 / (shared.len() + 1) as Real;
                let (v, c) = (v * s, c * s);
                let mut x = fp.x[p] + v * dt;
                domain.clamp(&mut x, t_end, crate::fluid::CLAMP_MARGIN * dx);
                (x, v, c)
            })
            .collect();
        let mut x: Vec<Vector<D>> = moved.iter().map(|m| m.0).collect();
        let mut solves = Vec::new();
        if self.params.position_correction {
            if let Some(c) = times
                .time(crate::stages::POSITION_CORRECTION, || {
                    // With the node rows the fluid ends at the cell staircase, which the
                    // solid volume spread to nodes overlaps: counted, it marks the fluid
                    // cells along a resting solid as overfull every step, and the pushes
                    // grew a neutrally buoyant block's round-off flow exponentially (water
                    // kinetic energy 3e-7 J at 0.5 s, 1.9 J at 3 s; 2e-5 J without).
                    let occupied = match self.solid_params.interface {
                        InterfaceQuadrature::SolidParticles => self.solid_node_volume(),
                        InterfaceQuadrature::FluidNodes => Vec::new(),
                    };
                    self.fluid
                        .correct_positions(&mut x, dt, correction, &occupied)
                })
                .map_err(lift)?
            {
                solves.push(SolveInfo {
                    name: "position_correction",
                    iterations: c.iterations,
                    residual: c.relative_residual,
                });
            }
        }
        Ok(Attempt {
            x,
            v: moved.iter().map(|m| m.1).collect(),
            affine: moved.iter().map(|m| m.2).collect(),
            pressure: bins.cell[..n]
                .iter()
                .map(|&c| pressure_of_cell[c])
                .collect(),
            divergence: bins.cell[..n]
                .iter()
                .map(|&c| divergence_of_cell[c])
                .collect(),
            solves,
            events: Vec::new(),
        })
    }

    /// Writes an accepted attempt into the state and the scene-ordered particles.
    pub(super) fn commit(
        &mut self,
        pending: Pending<D>,
        dt: Real,
    ) -> Result<bool, Failure<CoupledError>> {
        let updated = self.solid.commit_step(pending.solid).map_err(lift)?;
        if let Some(f) = pending.fluid {
            self.fluid.accept(f, dt);
        }
        self.solid_pressure = pending.solid_pressure;
        if updated {
            // A-ULMPM moved the reference: its cells hold other particles, and the volume term
            // of Eq. 37 starts again from J^(r,n) = 1, i.e. P^s = 0. A plastic particle's J_E
            // does not change with the reference, nor does its pressure.
            self.bin_solid_cells();
            for (pressure, _) in self
                .solid_pressure
                .iter_mut()
                .zip(&self.plastic)
                .filter(|(_, &plastic)| !plastic)
            {
                *pressure = 0.0;
            }
        }
        self.time += dt;
        self.steps += 1;
        self.push_fluid_out_of_solids();
        self.gather_particles();
        Ok(updated)
    }
}
