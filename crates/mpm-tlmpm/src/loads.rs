//! Applied loads: nodal loads ([`NodalLoad`]) and surface tractions ([`SurfaceTraction`]) on the
//! reference grid, both dead loads (fixed direction and magnitude, optionally ramped from zero)
//! added to the external nodal forces of every step, and loads on particles ([`ParticleLoad`]),
//! shared by the particles in a box as per-particle forces.
//!
//! **Nodal loads.** The total force is shared equally by the selected active nodes of the
//! reference grid, so the nodes receive exactly `force` between them (to round-off).
//!
//! **Surface tractions** (first Piola, i.e. per unit *reference* area). At set-up, the particles
//! in the traction's box whose material ends within the box are found: a particle `p` with
//! spacing `h_p = (V⁰_p)^{1/D}` is a surface particle when one of the `2D` lattice neighbour
//! positions `X_p ± h_p e_a` has no particle within `0.75 h_p` (no material there). Each surface
//! particle carries the share `A_p = h_p^{D−1}` of the surface (m² in 3D, m in 2D), i.e. the
//! force `t A_p`, spread to the nodes with its weights, `f_i += W_i(X_p) t A_p`. The weights sum
//! to one, so the grid receives `t Σ_p A_p` exactly (to round-off); `Σ_p A_p` is the measure of
//! the loaded face as the lattice resolves it: exact for a face on a lattice plane sampled
//! without jitter (one layer of `A/h^{D−1}` particles), within one spacing `h` per face edge
//! otherwise. The load reaches the body at the particles, `h/2` inside the true face, and is
//! smeared over the kernel's support: a quadrature of `∫ N_i t dA` that is first order in `h`
//! near the face and exact for the total force. The neighbour
//! test is exact for an unjittered lattice and holds for jitter up to 0.25 of the spacing;
//! Poisson-disk samples have no lattice, and a face loaded on them gets an approximate layer.

use crate::reference::ReferenceConfig;
use mpm_core::neighbors::CellList;
use mpm_core::quasistatic::{gravity_at, GravityRamp};
use mpm_core::{Particles, Real, SetupError, Vector};

/// A total force (N; N/m in 2D) on the particles initially in the box `[min, max]` (m,
/// inclusive), shared in proportion to their mass, so the particles receive exactly `force`
/// between them (to round-off) and a uniform body accelerates uniformly. Applied as
/// per-particle forces (`TotalLagrangian::particle_forces_mut`), held over every step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParticleLoad<const D: usize> {
    /// Lower corner (m).
    pub min: Vector<D>,
    /// Upper corner (m).
    pub max: Vector<D>,
    /// Total force (N; N/m in 2D).
    pub force: Vector<D>,
}

/// A [`ParticleLoad`] whose box holds no particle (or only massless ones).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("no particle lies in the load's box")]
pub struct EmptyLoad;

impl<const D: usize> ParticleLoad<D> {
    /// Adds each particle's share of the load to `forces` (N, one per particle).
    pub fn distribute(
        &self,
        particles: &Particles<D>,
        forces: &mut [Vector<D>],
    ) -> Result<(), EmptyLoad> {
        let (lo, hi) = (self.min, self.max);
        let inside = |x: &Vector<D>| (0..D).all(|a| x[a] >= lo[a] && x[a] <= hi[a]);
        let mass: Real = particles
            .x
            .iter()
            .zip(&particles.mass)
            .filter(|(x, _)| inside(x))
            .map(|(_, m)| m)
            .sum();
        if mass <= 0.0 {
            return Err(EmptyLoad);
        }
        for ((f, x), m) in forces.iter_mut().zip(&particles.x).zip(&particles.mass) {
            if inside(x) {
                *f += self.force * (m / mass);
            }
        }
        Ok(())
    }
}

/// Which reference-grid nodes a nodal load acts on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NodeSelection<const D: usize> {
    /// The active node nearest to this reference point (m); ties go to the lowest node index.
    Point(Vector<D>),
    /// Every active node whose reference position lies in `[min, max]` (m; inclusive, with a
    /// tolerance of 10⁻⁹ Δx).
    Box {
        /// Lower corner (m).
        min: Vector<D>,
        /// Upper corner (m).
        max: Vector<D>,
    },
}

/// A force on nodes of the reference grid: `force` (N; N/m in 2D, per unit thickness) in all,
/// shared equally by the selected active nodes, times the ramp factor `min(t/T, 1)` when
/// ramped. After an A-ULMPM reference update the load acts on the nodes of the new reference
/// grid that the selection picks (as [`crate::FixedRegion`]s do).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodalLoad<const D: usize> {
    /// The loaded nodes.
    pub nodes: NodeSelection<D>,
    /// Total force (N; N/m in 2D).
    pub force: Vector<D>,
    /// Linear ramp from zero at t = 0 to the full force at t = T; `None` for a step load.
    pub ramp: Option<GravityRamp>,
}

/// A traction (Pa; per unit reference area, in 2D per unit thickness) on the surface of the
/// bodies inside the box `[min, max]` (m, reference configuration), applied through the surface
/// particles there (module docs), times the ramp factor when ramped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceTraction<const D: usize> {
    /// Lower corner (m).
    pub min: Vector<D>,
    /// Upper corner (m).
    pub max: Vector<D>,
    /// Traction vector t (Pa).
    pub traction: Vector<D>,
    /// Linear ramp from zero at t = 0; `None` for a step load.
    pub ramp: Option<GravityRamp>,
}

/// Whether `x` lies in `[min, max]` widened by `tol` (m).
fn in_box<const D: usize>(x: &Vector<D>, min: &Vector<D>, max: &Vector<D>, tol: Real) -> bool {
    (0..D).all(|a| x[a] >= min[a] - tol && x[a] <= max[a] + tol)
}

/// The active nodes `selection` picks on `reference`, ascending.
pub(crate) fn selected_nodes<const D: usize>(
    selection: &NodeSelection<D>,
    reference: &ReferenceConfig<D>,
) -> Vec<usize> {
    let xs = reference.node_positions();
    match selection {
        NodeSelection::Point(p) => {
            let nearest = (0..xs.len()).min_by(|&i, &j| {
                (xs[i] - p)
                    .norm_squared()
                    .total_cmp(&(xs[j] - p).norm_squared())
            });
            nearest.into_iter().collect()
        }
        NodeSelection::Box { min, max } => {
            let tol = 1e-9 * reference.spec().dx;
            (0..xs.len())
                .filter(|&i| in_box(&xs[i], min, max, tol))
                .collect()
        }
    }
}

/// The surface particles of a traction's box and their surface shares `A_p` (m^{D−1}), in
/// ascending particle order (module docs).
fn surface_particles<const D: usize>(
    traction: &SurfaceTraction<D>,
    x: &[Vector<D>],
    volume0: &[Real],
    cells: &CellList<D>,
) -> Vec<(usize, Real)> {
    let mut out = Vec::new();
    for (p, xp) in x.iter().enumerate() {
        if !in_box(xp, &traction.min, &traction.max, 0.0) {
            continue;
        }
        let h = volume0[p].powf(1.0 / D as Real);
        let radius = 0.75 * h;
        let free = (0..2 * D).any(|k| {
            let mut probe = *xp;
            probe[k / 2] += if k % 2 == 0 { h } else { -h };
            let mut occupied = false;
            cells.for_each_candidate_near(&probe, |q| {
                occupied |= q != p && (x[q] - probe).norm() < radius;
            });
            !occupied
        });
        if free {
            out.push((p, h.powi(D as i32 - 1)));
        }
    }
    out
}

/// The applied loads resolved on the particles: for each traction its surface particles and
/// their shares.
#[derive(Clone, Debug, Default)]
pub(crate) struct AppliedLoads {
    /// Per traction: `(particle, A_p in m^{D−1})`, particles ascending.
    surface: Vec<Vec<(usize, Real)>>,
}

impl AppliedLoads {
    /// Checks the loads and finds the tractions' surface particles among the particles at their
    /// reference positions `x` (m) with volumes `volume0` (m^D). A load with a non-finite value,
    /// a ramp that is not a positive finite time, a nodal load that selects no active node or a
    /// traction that finds no surface particle is an [`SetupError::InvalidSetting`] named
    /// `nodal load i` or `traction i`.
    pub fn new<const D: usize>(
        nodal: &[NodalLoad<D>],
        tractions: &[SurfaceTraction<D>],
        reference: &ReferenceConfig<D>,
        volume0: &[Real],
    ) -> Result<Self, SetupError> {
        let invalid = |setting: String, reason: &str| SetupError::InvalidSetting {
            setting,
            reason: reason.to_string(),
        };
        let finite = |v: &Vector<D>| v.iter().all(|c| c.is_finite());
        let ramp_ok =
            |r: &Option<GravityRamp>| r.is_none_or(|r| r.duration > 0.0 && r.duration.is_finite());
        for (i, l) in nodal.iter().enumerate() {
            let name = crate::settings::nodal_load(i);
            let corners_ok = match &l.nodes {
                NodeSelection::Point(p) => finite(p),
                NodeSelection::Box { min, max } => finite(min) && finite(max),
            };
            if !(corners_ok && finite(&l.force) && ramp_ok(&l.ramp)) {
                return Err(invalid(
                    name,
                    "needs finite values and a positive ramp time",
                ));
            }
            if selected_nodes(&l.nodes, reference).is_empty() {
                return Err(invalid(
                    name,
                    "selects no active node of the reference grid",
                ));
            }
        }
        let x = reference.positions();
        let mut cells = CellList::default();
        if !tractions.is_empty() {
            let h_max = volume0
                .iter()
                .fold(0.0, |m: Real, v| m.max(v.powf(1.0 / D as Real)));
            cells.build(x, h_max);
        }
        let mut surface = Vec::with_capacity(tractions.len());
        for (k, t) in tractions.iter().enumerate() {
            let name = crate::settings::traction(k);
            if !(finite(&t.min) && finite(&t.max) && finite(&t.traction) && ramp_ok(&t.ramp)) {
                return Err(invalid(
                    name,
                    "needs finite values and a positive ramp time",
                ));
            }
            let s = surface_particles(t, x, volume0, &cells);
            if s.is_empty() {
                return Err(invalid(
                    name,
                    "finds no surface particle: no body's surface lies in its box",
                ));
            }
            surface.push(s);
        }
        Ok(Self { surface })
    }

    /// Number of surface particles of all tractions.
    pub fn surface_particles(&self) -> usize {
        self.surface.iter().map(Vec::len).sum()
    }

    /// Adds the loads at time `t` (s) to the nodal forces `external` (N), in a fixed order.
    pub fn add<const D: usize>(
        &self,
        nodal: &[NodalLoad<D>],
        tractions: &[SurfaceTraction<D>],
        reference: &ReferenceConfig<D>,
        t: Real,
        external: &mut [Vector<D>],
    ) {
        for l in nodal {
            let nodes = selected_nodes(&l.nodes, reference);
            let share = gravity_at(&l.force, l.ramp.as_ref(), t) / nodes.len().max(1) as Real;
            for i in nodes {
                external[i] += share;
            }
        }
        for (tr, surface) in tractions.iter().zip(&self.surface) {
            let traction = gravity_at(&tr.traction, tr.ramp.as_ref(), t);
            for &(p, area) in surface {
                let f = traction * area;
                for (i, w, _) in reference.stencil(p) {
                    external[i] += f * w;
                }
            }
        }
    }
}
