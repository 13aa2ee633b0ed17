//! The volume-preserving position correction of [`DiqFluid`] (Kugelstadt et al. 2019's
//! implicit density projection on the MPM grid) and the grid volume fractions it drives to
//! one, with the fluid volume they give.

use super::{DiqFluid, NodeFields, Points, CLAMP_MARGIN};
use crate::domain::{corner_weights, Domain};
use crate::pressure::{PressureError, PressureInfo, PressureSystem};
use mpm_core::{Dim, DimOps, Failure, Matrix, Real, Vector};
use rayon::prelude::*;

impl<const D: usize> DiqFluid<D>
where
    Dim<D>: DimOps<D>,
{
    /// The position correction: where the grid volume fraction `θ` of a fluid cell exceeds 1,
    /// find the node displacement `d` of least mass-weighted norm with `∫_cell ∇·d = θ − 1`
    /// (times the cell's fluid volume) and no flux through walls, by the same SPD system with
    /// the right-hand side of the density error (Kugelstadt et al. 2019's implicit density
    /// projection, on the MPM grid), and move particles by `d` interpolated.
    ///
    /// `occupied` (m^D per node, or empty) is volume that other material (the coupled solids)
    /// holds at each node: it counts in `θ`, so fluid is pushed out of cells a solid fills.
    pub(crate) fn correct_positions(
        &self,
        x: &mut [Vector<D>],
        dt: Real,
        system: &mut PressureSystem<D>,
        occupied: &[Real],
    ) -> Result<Option<PressureInfo>, Failure<PressureError>> {
        let bins = self.bin(x);
        let zero_v = vec![Vector::<D>::zeros(); x.len()];
        let zero_c = vec![Matrix::<D>::zeros(); x.len()];
        let points = Points {
            x,
            v: &zero_v,
            affine: &zero_c,
            mass: &self.particles.mass,
            volume: &self.particles.volume0,
        };
        let mut nodes = self.transfer(points, &bins, false);
        for (v, o) in nodes.volume.iter_mut().zip(occupied) {
            *v += o;
        }
        let theta = self.node_fraction(&nodes);
        let t_end = self.time + dt;
        let (mut rows, volumes) =
            self.constraints((x, &self.particles.volume0), &bins, &nodes.mass, t_end);
        let nf = rows.num_fluid();
        let mut any = false;
        for k in 0..nf {
            let th = self.cell_fraction(&theta, rows.anchors()[k]);
            let excess = (th - 1.0).max(0.0);
            any |= excess > 0.0;
            rows.offsets_mut()[k] = -volumes[k] * excess;
        }
        for o in rows.offsets_mut()[nf..].iter_mut() {
            *o = 0.0;
        }
        if !any {
            return Ok(None);
        }
        let mut d = vec![Vector::<D>::zeros(); nodes.mass.len()];
        let (_, info) = self.solve_onto(
            &rows,
            &nodes.inv_mass,
            dt,
            &mut d,
            system,
            crate::stages::POSITION_CORRECTION,
        )?;
        let dx = self.domain.spec.dx;
        x.par_iter_mut().for_each(|xp| {
            let (m, f) = self.domain.locate(xp).expect("inside");
            let mut w = [0.0; 8];
            let mut g = [Vector::<D>::zeros(); 8];
            corner_weights(&f, dx, &mut w, &mut g);
            let mut shift = Vector::<D>::zeros();
            for j in 0..Domain::<D>::CORNERS {
                shift += d[self.domain.corner_node(&m, j)] * w[j];
            }
            if shift.iter().all(|s| s.is_finite()) {
                *xp += shift;
                self.domain.clamp(xp, t_end, CLAMP_MARGIN * dx);
            }
        });
        Ok(Some(info))
    }

    /// The fluid volume (m^D) at the grid's resolution: `Σ_p V_p / max(θ_p, 1)`, where `θ_p` is
    /// the volume fraction of the particle's cell, the mean over its corners of the particle
    /// volume transferred to each node divided by the node's support volume inside the walls
    /// (the quantity the position correction drives to 1). Compressed cells (`θ > 1`) count for
    /// less, so the volume drops below `Σ V_p` when particles cluster; the half-empty cells of a
    /// free surface do not count as lost volume.
    pub fn fluid_volume(&self) -> Real {
        let ps = &self.particles;
        let bins = self.bin(&ps.x);
        let nodes = self.transfer(Points::of(ps), &bins, false);
        let theta = self.node_fraction(&nodes);
        (0..ps.len())
            .map(|p| ps.volume0[p] / self.cell_fraction(&theta, bins.cell[p]).max(1.0))
            .sum()
    }

    /// Node volume fraction `θ_n` (dimensionless).
    fn node_fraction(&self, nodes: &NodeFields<D>) -> Vec<Real> {
        let cell = self.domain.spec.cell_volume();
        nodes
            .volume
            .iter()
            .enumerate()
            .map(|(n, &v)| v / (cell * self.domain.support_fraction(n)))
            .collect()
    }

    /// Volume fraction of cell `c`: the mean of its corners' node fractions.
    fn cell_fraction(&self, theta: &[Real], c: usize) -> Real {
        let m = self.domain.cell_multi(c);
        (0..Domain::<D>::CORNERS)
            .map(|j| theta[self.domain.corner_node(&m, j)])
            .sum::<Real>()
            / Domain::<D>::CORNERS as Real
    }
}
