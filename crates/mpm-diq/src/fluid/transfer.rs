//! The particle–grid transfers of [`DiqFluid`]: binning particles by cell, APIC P2G to the
//! linear B-spline (B1) nodes by node gather, and APIC G2P with advection and clamping.

use super::{DiqFluid, CLAMP_MARGIN};
use crate::domain::{corner_weights, Domain};
use crate::pressure::PressureError;
use mpm_core::{
    Dim, DimOps, Failure, Location, Matrix, Particles, Real, SolveInfo, Stage, Vector, Violation,
};
use rayon::prelude::*;

/// Particles binned by cell: `order[start[c]..start[c+1]]` are the particles of cell `c`, in
/// index order.
#[derive(Clone, Debug, Default)]
pub(crate) struct Bins {
    pub(super) start: Vec<usize>,
    order: Vec<usize>,
    /// Cell of each particle.
    pub(crate) cell: Vec<usize>,
}

impl Bins {
    pub(crate) fn of(&self, c: usize) -> &[usize] {
        &self.order[self.start[c]..self.start[c + 1]]
    }
}

/// Node fields of one transfer.
#[derive(Clone, Debug, Default)]
pub(crate) struct NodeFields<const D: usize> {
    pub(crate) mass: Vec<Real>,
    /// Momentum, then velocity (m/s).
    pub(crate) velocity: Vec<Vector<D>>,
    /// Particle volume transferred to the node (m^D).
    pub(crate) volume: Vec<Real>,
    pub(crate) inv_mass: Vec<Real>,
    /// What the implicit viscosity's solve did, when a particle is viscous.
    pub(crate) viscous: Option<SolveInfo>,
}

/// The points a fluid transfer integrates over: the fluid particles, or (coupled solver) the
/// particles with part of their mass moved onto nearby interface points.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Points<'a, const D: usize> {
    /// Positions (m).
    pub(crate) x: &'a [Vector<D>],
    /// Velocities (m/s).
    pub(crate) v: &'a [Vector<D>],
    /// APIC affine matrices (1/s).
    pub(crate) affine: &'a [Matrix<D>],
    /// Masses (kg).
    pub(crate) mass: &'a [Real],
    /// Volumes (m^D).
    pub(crate) volume: &'a [Real],
}

impl<'a, const D: usize> Points<'a, D> {
    /// The particles themselves.
    pub(crate) fn of(ps: &'a Particles<D>) -> Self {
        Self {
            x: &ps.x,
            v: &ps.v,
            affine: &ps.affine,
            mass: &ps.mass,
            volume: &ps.volume0,
        }
    }
}

impl<const D: usize> DiqFluid<D>
where
    Dim<D>: DimOps<D>,
{
    /// Bins positions by cell (stable counting sort).
    pub(crate) fn bin(&self, x: &[Vector<D>]) -> Bins {
        let cell: Vec<usize> = x
            .par_iter()
            .map(|x| {
                let (m, _) = self.domain.locate(x).expect("particles are clamped inside");
                self.domain.cell_index(&m)
            })
            .collect();
        let nc = self.domain.num_cells();
        let mut start = vec![0usize; nc + 1];
        for &c in &cell {
            start[c + 1] += 1;
        }
        for c in 0..nc {
            start[c + 1] += start[c];
        }
        let mut fill = start.clone();
        let mut order = vec![0usize; x.len()];
        for (p, &c) in cell.iter().enumerate() {
            order[fill[c]] = p;
            fill[c] += 1;
        }
        Bins { start, order, cell }
    }

    /// APIC P2G by node gather: each node sums, in a fixed order, over the particles of the
    /// `2^D` cells around it. With `momentum` false only mass and volume are transferred.
    pub(crate) fn transfer(
        &self,
        Points {
            x,
            v,
            affine,
            mass,
            volume,
        }: Points<'_, D>,
        bins: &Bins,
        momentum: bool,
    ) -> NodeFields<D> {
        let spec = &self.domain.spec;
        let nn = spec.num_nodes();
        let corners = Domain::<D>::CORNERS;
        let rows: Vec<(Real, Vector<D>, Real)> = (0..nn)
            .into_par_iter()
            .map(|n| {
                let node = spec.multi_index(n);
                let xn = spec.node_position(&node);
                let (mut m, mut mv, mut vol) = (0.0, Vector::<D>::zeros(), 0.0);
                for j in 0..corners {
                    let mut cm = [0usize; D];
                    let mut ok = true;
                    for a in 0..D {
                        let k = node[a] - ((j >> a) & 1) as i64;
                        if k < 0 || k >= self.domain.cell_dims[a] as i64 {
                            ok = false;
                            break;
                        }
                        cm[a] = k as usize;
                    }
                    if !ok {
                        continue;
                    }
                    for &p in bins.of(self.domain.cell_index(&cm)) {
                        let (_, f) = self.domain.locate(&x[p]).expect("inside");
                        let mut w = 1.0;
                        for a in 0..D {
                            w *= if (j >> a) & 1 == 1 { f[a] } else { 1.0 - f[a] };
                        }
                        let pm = mass[p];
                        m += w * pm;
                        vol += w * volume[p];
                        if momentum {
                            mv += (v[p] + affine[p] * (xn - x[p])) * (w * pm);
                        }
                    }
                }
                (m, mv, vol)
            })
            .collect();
        let mut out = NodeFields::default();
        out.mass = rows.iter().map(|r| r.0).collect();
        out.velocity = rows.iter().map(|r| r.1).collect();
        out.volume = rows.iter().map(|r| r.2).collect();
        out.inv_mass = out
            .mass
            .iter()
            .map(|&m| if m > 0.0 { 1.0 / m } else { 0.0 })
            .collect();
        out
    }

    /// APIC G2P at positions `x`, advection and clamping. Guards non-finite values and a
    /// displacement above Δx.
    #[allow(clippy::type_complexity)]
    pub(crate) fn g2p(
        &self,
        x: &[Vector<D>],
        nodes: &NodeFields<D>,
        dt: Real,
    ) -> Result<(Vec<Vector<D>>, Vec<Vector<D>>, Vec<Matrix<D>>), Failure<PressureError>> {
        let dx = self.domain.spec.dx;
        let t_end = self.time + dt;
        let out: Vec<(Vector<D>, Vector<D>, Matrix<D>)> = x
            .par_iter()
            .map(|x| {
                let (m, f) = self.domain.locate(x).expect("inside");
                let mut w = [0.0; 8];
                let mut g = [Vector::<D>::zeros(); 8];
                corner_weights(&f, dx, &mut w, &mut g);
                let mut v = Vector::<D>::zeros();
                let mut c = Matrix::<D>::zeros();
                for j in 0..Domain::<D>::CORNERS {
                    let vn = nodes.velocity[self.domain.corner_node(&m, j)];
                    v += vn * w[j];
                    c += vn * g[j].transpose();
                }
                let mut xn = x + v * dt;
                if xn.iter().all(|c| c.is_finite()) {
                    self.domain.clamp(&mut xn, t_end, CLAMP_MARGIN * dx);
                }
                (xn, v, c)
            })
            .collect();
        for (p, (_, v, _)) in out.iter().enumerate() {
            let speed = v.norm();
            if !speed.is_finite() {
                return Err(Failure::Guard(
                    Stage::G2P,
                    (
                        Location::Particle(p),
                        Violation::NonFinite("velocity"),
                        speed,
                    ),
                ));
            }
            if speed * dt > dx {
                return Err(Failure::Guard(
                    Stage::G2P,
                    (
                        Location::Particle(p),
                        Violation::CflExceeded,
                        speed * dt / dx,
                    ),
                ));
            }
        }
        let mut x = Vec::with_capacity(out.len());
        let mut v = Vec::with_capacity(out.len());
        let mut c = Vec::with_capacity(out.len());
        for (a, b, m) in out {
            x.push(a);
            v.push(b);
            c.push(m);
        }
        Ok((x, v, c))
    }
}
