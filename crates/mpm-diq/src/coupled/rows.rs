//! The rows of the coupled pressure-only system (Eq. 35): the solid-pressure rows per reference
//! cell, the interface rows (at the quadrature points, or at the fluid's boundary nodes) and
//! the whole system over the fluid node velocities and the solid's reference node velocities.
//! The derivation is in `docs/diq-coupling.md`.

use super::interface::FluidPoints;

use super::interface::InterfacePoints;
use super::params::{lift, CoupledError, InterfaceQuadrature};
use super::DiqCoupled;
use crate::fluid::{Bins, NodeFields};
use crate::pressure::{Constraints, UnknownKind};
use crate::Domain;
use mpm_core::neighbors::CellList;
use mpm_core::{Dim, DimOps, Failure, Matrix, Real, StageTimes, Vector};
use rayon::prelude::*;

impl<const D: usize> DiqCoupled<D>
where
    Dim<D>: DimOps<D>,
{
    /// Appends the solid-pressure rows (`G^sᵀ`, compliance and offset for a step of `dt`) on
    /// the velocity slots from `offset`.
    pub(super) fn push_solid_rows(&self, rows: &mut Constraints<D>, offset: usize, dt: Real) {
        let sp = self.solid.particles();
        let reference = self.solid.reference();
        let jac = self.solid_jacobian();
        // With A-ULMPM (§5.4, Eq. 37) the volume term is measured from the current reference:
        // F^(r,n), its reference gradients and the reference volumes V^r = V⁰ det F^(0,r).
        // Plastic particles carry Ψ^v(J_E) on V⁰ instead (`docs/diq-coupling.md`, "Plastic solids").
        let rel = self.solid.relative_def_grads();
        let mut volume = self.solid.reference_volumes();
        for ((v, v0), _) in volume
            .iter_mut()
            .zip(&sp.volume0)
            .zip(&self.plastic)
            .filter(|(_, &plastic)| plastic)
        {
            *v = *v0;
        }
        type Row<const D: usize> = (Vec<(usize, Vector<D>)>, Real, Real);
        let built: Vec<Row<D>> = self
            .solid_cells
            .par_iter()
            .map(|(_, members)| {
                let mut entries = Vec::new();
                let (mut s, mut sp_n) = (0.0, 0.0);
                for &p in members {
                    let f = rel.map_or_else(|| sp.def_grad_of(p), |g| g[p]);
                    let finv_t =
                        Dim::<D>::inverse(&f).map_or(Matrix::<D>::zeros(), |i| i.transpose());
                    let scale = volume[p] * jac[p];
                    for (i, _, g) in reference.stencil(p) {
                        entries.push((offset + i, -(finv_t * g) * scale));
                    }
                    let c = volume[p] / self.lambda_v[p];
                    s += c;
                    sp_n += c * self.solid_pressure[p];
                }
                (entries, s, sp_n)
            })
            .collect();
        for ((cell, _), (entries, s, sp_n)) in self.solid_cells.iter().zip(built) {
            rows.push_row(UnknownKind::SolidPressure, *cell, entries, -sp_n / dt);
            *rows.diagonal_mut().last_mut().expect("pushed") = s / dt;
        }
    }

    /// Appends the interface rows `[−H^s, H^f]` of the points `iq`, one per current fluid cell
    /// holding points, solid slots from `offset`. `fluid_mass` (kg) is the fluid node mass:
    /// the fluid weights `w_c(x_q)` of a point are renormalised over its corners that carry
    /// fluid mass (a point whose corners carry none is skipped), so that `Σ_c H^f_{j,c}` equals
    /// `Σ_i H^s_{j,i}` over the nodes that can move: the interface impulse on the fluid is then
    /// exactly opposite to the one on the solid and total momentum is conserved. With the plain
    /// weights, the share of the impulse on corners without fluid is lost (measured: 25 % of
    /// the momentum of a block hitting a blob of water within 60 steps).
    pub(super) fn push_interface_rows(
        &self,
        rows: &mut Constraints<D>,
        offset: usize,
        iq: &InterfacePoints<D>,
        fluid_mass: &[Real],
    ) {
        let domain: &Domain<D> = self.fluid.domain();
        let dx = domain.spec.dx;
        let sp = self.solid.particles();
        let reference = self.solid.reference();
        let mut keyed: Vec<(usize, usize, [usize; D], [Real; D])> = iq
            .particle
            .iter()
            .enumerate()
            .filter_map(|(k, &q)| {
                let (m, f) = domain.locate(&sp.x[q])?;
                Some((domain.nearest_node(&sp.x[q]), k, m, f))
            })
            .collect();
        keyed.sort_unstable_by_key(|e| (e.0, e.1));
        let mut w = [0.0; 8];
        let mut g = [Vector::<D>::zeros(); 8];
        for group in keyed.chunk_by(|a, b| a.0 == b.0) {
            let mut entries = Vec::new();
            for &(_, k, m, f) in group {
                let (q, an) = (iq.particle[k], iq.normal[k] * iq.area[k]);
                crate::domain::corner_weights(&f, dx, &mut w, &mut g);
                let corners = Domain::<D>::CORNERS;
                let wet: Real = (0..corners)
                    .filter(|&j| fluid_mass[domain.corner_node(&m, j)] > 0.0)
                    .map(|j| w[j])
                    .sum();
                if wet.is_nan() || wet <= 0.0 {
                    continue;
                }
                for (j, wj) in w.iter().enumerate().take(corners) {
                    let c = domain.corner_node(&m, j);
                    if fluid_mass[c] > 0.0 {
                        entries.push((c, an * (*wj / wet)));
                    }
                }
                for (i, wi, _) in reference.stencil(q) {
                    entries.push((offset + i, -an * wi));
                }
            }
            if !entries.is_empty() {
                rows.push_row(UnknownKind::Interface, group[0].0, entries, 0.0);
            }
        }
    }

    /// Appends the interface rows of [`InterfaceQuadrature::FluidNodes`] (see there), solid
    /// slots from `offset`, after the fluid rows of `rows`.
    pub(super) fn push_node_interface_rows(&self, rows: &mut Constraints<D>, offset: usize) {
        let domain: &Domain<D> = self.fluid.domain();
        let dx = domain.spec.dx;
        let sp = self.solid.particles();
        let reference = self.solid.reference();
        let mut b = vec![Vector::<D>::zeros(); domain.spec.num_nodes()];
        for k in 0..rows.num_fluid() {
            let (nodes, coeffs) = rows.row(k);
            for (&i, c) in nodes.iter().zip(coeffs) {
                b[i] += c;
            }
        }
        let mut solids = CellList::default();
        solids.build(&sp.x, dx);
        let held = self.held_axes(domain);
        // A component below this is round-off of the sum over equal cells (m² in 3D).
        let tol = 1e-9 * dx.powi(D as i32 - 1);
        // The solid particles in a node's B1 support, weighted by its tent (reused buffer).
        let mut near: Vec<(usize, Real)> = Vec::new();
        for (i, bi) in b.iter().enumerate() {
            if bi.iter().all(|c| c.abs() <= tol) {
                continue;
            }
            let xi = domain.spec.node_position(&domain.spec.multi_index(i));
            near.clear();
            solids.for_each_candidate_near(&xi, |q| {
                let w: Real = (0..D)
                    .map(|a| (1.0 - (sp.x[q][a] - xi[a]).abs() / dx).max(0.0))
                    .product();
                if w > 0.0 {
                    near.push((q, w));
                }
            });
            if near.is_empty() {
                continue;
            }
            near.sort_unstable_by_key(|e| e.0);
            let total: Real = near.iter().map(|e| e.1).sum();
            let axes = held(i);
            for a in (0..D).filter(|&a| bi[a].abs() > tol && axes[a]) {
                let mut part = Vector::<D>::zeros();
                part[a] = bi[a];
                let solid = near.iter().flat_map(|&(q, w)| {
                    reference
                        .stencil(q)
                        .map(move |(j, wj, _)| (offset + j, -part * (wj * w / total)))
                });
                rows.push_row(
                    UnknownKind::Interface,
                    i,
                    std::iter::once((i, part)).chain(solid),
                    0.0,
                );
            }
        }
    }

    /// Which axes the node rows hold at each node: those along which the solid's outward
    /// normal at the node has at least half its largest component. The normal is
    /// `n_i = Σ_c θ_c ∇w_i(x_c)` over the `2^D` cells around node `i`, `θ_c` the cell's solid
    /// volume fraction (reference volumes of the solid particles in it, capped at 1): along a
    /// face of the cell staircase only the normal axis (the fluid slips along the face), at a
    /// convex or concave corner every axis (where one normal row cannot balance a hydrostatic
    /// pressure, `docs/diq.md`); a stray solid particle in a fluid cell tilts `n_i` too little
    /// to add an axis. A node with no solid volume around it holds every axis.
    pub(super) fn held_axes<'s>(
        &'s self,
        domain: &'s Domain<D>,
    ) -> impl Fn(usize) -> [bool; D] + 's {
        let sp = self.solid.particles();
        let cell_volume = domain.spec.cell_volume();
        let mut fraction = vec![0.0; domain.num_cells()];
        for q in 0..sp.len() {
            if let Some((m, _)) = domain.locate(&sp.x[q]) {
                fraction[domain.cell_index(&m)] += sp.volume0[q] / cell_volume;
            }
        }
        let mut w = [0.0; 8];
        let mut g = [Vector::<D>::zeros(); 8];
        crate::domain::corner_weights(&[0.5; D], domain.spec.dx, &mut w, &mut g);
        move |i| {
            let node = domain.spec.multi_index(i);
            let mut n = Vector::<D>::zeros();
            'corner: for (j, gj) in g.iter().enumerate().take(Domain::<D>::CORNERS) {
                let mut cell = [0usize; D];
                for a in 0..D {
                    let k = node[a] - ((j >> a) & 1) as i64;
                    if k < 0 || k >= domain.cell_dims[a] as i64 {
                        continue 'corner;
                    }
                    cell[a] = k as usize;
                }
                n += gj * fraction[domain.cell_index(&cell)].min(1.0);
            }
            let largest = n.amax();
            std::array::from_fn(|a| largest == 0.0 || n[a].abs() >= 0.5 * largest)
        }
    }

    /// The coupled system of a step of `dt` at fluid node fields `nodes` (after the predictor)
    /// and the solid's `V*`: the rows, the inverse masses and the velocities `u* = (v*, V*)`,
    /// plus the fluid volume of each fluid row and the interface points.
    #[allow(clippy::type_complexity)]
    pub(super) fn coupled_rows(
        &self,
        (points, iq): (&FluidPoints<D>, &InterfacePoints<D>),
        nodes: &NodeFields<D>,
        bins: &Bins,
        v_solid: &[Vector<D>],
        dt: Real,
    ) -> (Constraints<D>, Vec<Real>, Vec<Vector<D>>, Vec<Real>) {
        let (mut rows, volumes) =
            self.fluid
                .constraints((&points.x, &points.volume), bins, &nodes.mass, self.time);
        rows.set_pin_gauge(false);
        let offset = rows.append_nodes(v_solid.len());
        self.push_solid_rows(&mut rows, offset, dt);
        match self.solid_params.interface {
            InterfaceQuadrature::SolidParticles => {
                self.push_interface_rows(&mut rows, offset, iq, &nodes.mass)
            }
            InterfaceQuadrature::FluidNodes => self.push_node_interface_rows(&mut rows, offset),
        }
        let masses = self.solid.reference().node_masses();
        let mut inv_mass = nodes.inv_mass.clone();
        inv_mass.extend(masses.iter().enumerate().map(|(i, &m)| {
            if self.solid.node_is_fixed(i) || m <= 0.0 {
                0.0
            } else {
                1.0 / m
            }
        }));
        let mut u = nodes.velocity.clone();
        u.extend_from_slice(v_solid);
        (rows, inv_mass, u, volumes)
    }

    /// The coupled system of a step of `dt` (s) from the current state, for tests and
    /// benchmarks: the rows of `J` (fluid, wall, solid-pressure and interface rows, in that
    /// order), the inverse lumped masses of the velocity slots (fluid nodes, then the solid's
    /// reference nodes; 1/kg) and the right-hand side `J u* − c`. Runs the fluid predictor and
    /// the solid's elastic solve into scratch storage; the state does not advance.
    #[allow(clippy::type_complexity)]
    pub fn coupled_problem(
        &mut self,
        dt: Real,
    ) -> Result<(Constraints<D>, Vec<Real>, Vec<Real>), Failure<CoupledError>> {
        let mut times = StageTimes::default();
        let iq = self.interface_points();
        let points = self.fluid_points(&iq);
        let (bins, nodes) = self
            .fluid
            .predictor_for(points.points(), dt, &mut times)
            .map_err(lift)?;
        let predicted = self.solid.elastic_predictor(dt).map_err(lift)?;
        let v_solid = self.solid.node_velocities(&predicted);
        let (rows, inv_mass, u, _) = self.coupled_rows((&points, &iq), &nodes, &bins, &v_solid, dt);
        let rhs = rows.residual(&u);
        Ok((rows, inv_mass, rhs))
    }
}
