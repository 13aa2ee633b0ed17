//! The pressure projection of [`DiqFluid`]: the rows of `J = [G^fᵀ; B]` (fluid cells, then
//! boundary pressures on walls and colliders), the assembly and solve of the pressure-only
//! system, and the per-cell pressure and divergence it leaves.

use super::{Bins, DiqFluid, GradientQuadrature, NodeFields, Points};
use crate::domain::{corner_weights, Domain, WallSample};
use crate::pressure::{Constraints, PressureError, PressureInfo, PressureSystem, UnknownKind};
use mpm_core::{Dim, DimOps, Failure, Real, Stage, Vector};
use rayon::prelude::*;

impl<const D: usize> DiqFluid<D>
where
    Dim<D>: DimOps<D>,
{
    /// The pressure system a step of `dt` (s) would solve from the current state, for
    /// benchmarks: the rows of `J`, the inverse lumped node masses (1/kg, 0 without mass) and
    /// the right-hand side `J v* − b` (m³/s in 3D). Assemble it with
    /// [`PressureSystem::assemble`] (scale `dt`) and [`Self::solid_cells`].
    pub fn projection_problem(&self, dt: Real) -> (Constraints<D>, Vec<Real>, Vec<Real>) {
        let ps = &self.particles;
        let bins = self.bin(&ps.x);
        let mut nodes = self.transfer(Points::of(ps), &bins, true);
        // A non-finite state would have failed the last step's guards.
        let _ = self.predict(&mut nodes, dt);
        let (rows, _) = self.constraints((&ps.x, &ps.volume0), &bins, &nodes.mass, self.time);
        let rhs = rows.residual(&nodes.velocity);
        (rows, nodes.inv_mass, rhs)
    }

    /// Which cells are walls, for the multigrid preconditioner of [`PressureSystem::assemble`].
    pub fn solid_cells(&self) -> impl Fn(usize) -> bool + '_ {
        self.solid_cell()
    }

    /// The rows of `J = [G^fᵀ; B]` at positions `x`: a fluid row per cell holding particles
    /// (in cell order), then a boundary row per node with mass whose piece of wall or collider
    /// surface (its node-centred B0 box) holds quadrature points in fluid cells, per wall face
    /// or collider. The points have positions `x` and volumes `volume`. Returns the rows and,
    /// per fluid row, the fluid volume in its cell (m^D).
    pub(crate) fn constraints(
        &self,
        (x, volume): (&[Vector<D>], &[Real]),
        bins: &Bins,
        mass: &[Real],
        t: Real,
    ) -> (Constraints<D>, Vec<Real>) {
        let corners = Domain::<D>::CORNERS;
        let dx = self.domain.spec.dx;
        let fluid_cells: Vec<usize> = (0..self.domain.num_cells())
            .filter(|&c| bins.start[c + 1] > bins.start[c])
            .collect();
        let fluid_rows: Vec<(Vec<Vector<D>>, Real)> = fluid_cells
            .par_iter()
            .map(|&c| {
                let mut r = vec![Vector::<D>::zeros(); corners];
                let mut vol = 0.0;
                let mut w = [0.0; 8];
                let mut g = [Vector::<D>::zeros(); 8];
                let particles = self.params.gradient_quadrature == GradientQuadrature::Particles;
                for &p in bins.of(c) {
                    let vp = volume[p];
                    vol += vp;
                    if particles {
                        let (_, f) = self.domain.locate(&x[p]).expect("inside");
                        corner_weights(&f, dx, &mut w, &mut g);
                        for j in 0..corners {
                            r[j] -= g[j] * vp;
                        }
                    }
                }
                if !particles {
                    corner_weights(&[0.5; D], dx, &mut w, &mut g);
                    for j in 0..corners {
                        r[j] = -g[j] * vol;
                    }
                }
                (r, vol)
            })
            .collect();
        let mut rows = Constraints::new(self.domain.cell_dims);
        let mut volumes = Vec::with_capacity(fluid_cells.len());
        for (&c, (r, vol)) in fluid_cells.iter().zip(fluid_rows) {
            let m = self.domain.cell_multi(c);
            rows.push_row(
                UnknownKind::Fluid,
                c,
                r.into_iter()
                    .enumerate()
                    .map(|(j, v)| (self.domain.corner_node(&m, j), v)),
                0.0,
            );
            volumes.push(vol);
        }
        // Boundary samples in fluid cells: the static wall points and the collider points.
        let per_cell: Vec<Vec<WallSample<D>>> = fluid_cells
            .par_iter()
            .map(|&c| {
                let (start, list) = &self.wall_by_cell;
                let mut out: Vec<WallSample<D>> = list[start[c]..start[c + 1]]
                    .iter()
                    .map(|&i| self.wall_points[i])
                    .collect();
                self.domain
                    .collider_points(&self.domain.cell_multi(c), t, &mut out);
                out
            })
            .collect();
        let mut samples: Vec<WallSample<D>> = per_cell.into_iter().flatten().collect();
        samples.sort_by_key(|s| (s.node, s.face));
        let mut w = [0.0; 8];
        let mut g = [Vector::<D>::zeros(); 8];
        for group in samples.chunk_by(|a, b| (a.node, a.face) == (b.node, b.face)) {
            let anchor = group[0].node;
            if mass[anchor] <= 0.0 {
                continue;
            }
            let mut entries = Vec::with_capacity(group.len() * corners);
            let mut b = 0.0;
            for s in group {
                let q = &s.point;
                let f: [Real; D] = std::array::from_fn(|a| {
                    ((q.x[a] - self.domain.spec.origin[a]) / dx - s.cell[a] as Real).clamp(0.0, 1.0)
                });
                corner_weights(&f, dx, &mut w, &mut g);
                for j in 0..corners {
                    entries.push((
                        self.domain.corner_node(&s.cell, j),
                        q.normal * (q.area * w[j]),
                    ));
                }
                b += q.area * q.normal_velocity;
            }
            rows.push_row(UnknownKind::Wall, anchor, entries, b);
        }
        rows.set_pin_gauge(!self.has_free_surface(&fluid_cells, bins));
        (rows, volumes)
    }

    /// Whether some fluid cell shares a node with an empty cell inside the walls (where
    /// `p = 0`), so that the pressure is unique.
    fn has_free_surface(&self, fluid_cells: &[usize], bins: &Bins) -> bool {
        fluid_cells.iter().any(|&c| {
            self.domain
                .neighbour_cells(self.domain.cell_multi(c))
                .any(|nm| {
                    let nc = self.domain.cell_index(&nm);
                    (self.domain.cell_inside(&nm) || !self.domain.walls) && bins.of(nc).is_empty()
                })
        })
    }

    pub(crate) fn solid_cell(&self) -> impl Fn(usize) -> bool + '_ {
        move |c| self.domain.walls && !self.domain.cell_inside(&self.domain.cell_multi(c))
    }

    /// The pressure projection: assemble and solve `A λ = J v* − b`, then `v = v* − dt M⁻¹ Jᵀ λ`.
    /// Returns the pressure and the discrete divergence per cell and the solve's summary.
    #[allow(clippy::type_complexity)]
    pub(super) fn project(
        &self,
        nodes: &mut NodeFields<D>,
        bins: &Bins,
        dt: Real,
        system: &mut PressureSystem<D>,
    ) -> Result<((Vec<Real>, Vec<Real>), PressureInfo), Failure<PressureError>> {
        let ps = &self.particles;
        let (rows, volumes) = self.constraints((&ps.x, &ps.volume0), bins, &nodes.mass, self.time);
        let (lambda, info) = self.solve_onto(
            &rows,
            &nodes.inv_mass,
            dt,
            &mut nodes.velocity,
            system,
            Stage::SOLVE,
        )?;
        Ok((
            self.cell_fields(&rows, &lambda, &nodes.velocity, &volumes),
            info,
        ))
    }

    /// The solved pressure (Pa) and the discrete divergence `−G^fᵀ v / V` (1/s) of every cell
    /// (0 in cells without fluid), from the fluid rows of `rows`, the solution `lambda` and the
    /// projected node velocities `v` (m/s).
    pub(crate) fn cell_fields(
        &self,
        rows: &Constraints<D>,
        lambda: &[Real],
        v: &[Vector<D>],
        volumes: &[Real],
    ) -> (Vec<Real>, Vec<Real>) {
        let after = rows.residual(v);
        let mut pressure = vec![0.0; self.domain.num_cells()];
        let mut divergence = vec![0.0; self.domain.num_cells()];
        for k in 0..rows.num_fluid() {
            pressure[rows.anchors()[k]] = lambda[k];
            divergence[rows.anchors()[k]] = -after[k] / volumes[k];
        }
        (pressure, divergence)
    }

    /// Moves the node field `v` (velocities in m/s; for the position correction, displacements
    /// over dt) onto the constraints `J v = b` of `rows`: assembles `A = dt J M⁻¹ Jᵀ`, solves
    /// `A λ = J v − b` and sets `v ← v − dt M⁻¹ Jᵀ λ`. Returns λ (Pa) and the solve's summary;
    /// a failure is reported in `stage`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn solve_onto(
        &self,
        rows: &Constraints<D>,
        inv_mass: &[Real],
        dt: Real,
        v: &mut [Vector<D>],
        system: &mut PressureSystem<D>,
        stage: Stage,
    ) -> Result<(Vec<Real>, PressureInfo), Failure<PressureError>> {
        self.assemble_onto(rows, inv_mass, dt, system, stage)?;
        self.project_assembled(rows, inv_mass, dt, v, system, stage)
    }

    /// Assembles `Δt J M⁻¹ Jᵀ + C` of `rows` and `inv_mass` (1/kg) into `system` and sets up
    /// its preconditioner, for any number of [`Self::project_assembled`] solves.
    pub(crate) fn assemble_onto(
        &self,
        rows: &Constraints<D>,
        inv_mass: &[Real],
        dt: Real,
        system: &mut PressureSystem<D>,
        stage: Stage,
    ) -> Result<(), Failure<PressureError>> {
        let params = &self.params.pressure;
        system
            .assemble(rows, inv_mass, dt, params, &self.solid_cell())
            .map_err(|e| Failure::Solve(stage, e))
    }

    /// Projects the velocities `v` (m/s) with the system [`Self::assemble_onto`] left in
    /// `system`: solves for the pressures and applies `v ← v − Δt M⁻¹ Jᵀ λ`.
    pub(crate) fn project_assembled(
        &self,
        rows: &Constraints<D>,
        inv_mass: &[Real],
        dt: Real,
        v: &mut [Vector<D>],
        system: &mut PressureSystem<D>,
        stage: Stage,
    ) -> Result<(Vec<Real>, PressureInfo), Failure<PressureError>> {
        let rhs = rows.residual(v);
        let mut lambda = Vec::new();
        let info = system
            .solve(&rhs, &mut lambda, &self.params.pressure)
            .map_err(|e| Failure::Solve(stage, e))?;
        rows.apply_transpose(&lambda, inv_mass, dt, v);
        Ok((lambda, info))
    }
}
