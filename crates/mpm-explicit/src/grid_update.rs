//! Grid update: velocities from momenta, gravity, boundary conditions, and the grid guard check.

use mpm_core::boundary::Boundaries;
use mpm_core::{GridNodes, GridSpec, Location, Real, Vector, Violation};
use rayon::prelude::*;

/// Computes node velocities `v_i = p_i/m_i + Δt g`, applies `boundaries` at time `t` when given
/// (multi-grid runs apply them after the coupling stage, see [`apply_boundaries`]), and, with
/// FLIP, turns `momentum0` into the pre-update velocities in place. Returns the first node
/// (lowest index) with a non-finite velocity.
pub(crate) fn update<const D: usize>(
    spec: &GridSpec<D>,
    grid: &mut GridNodes<D>,
    momentum0: Option<&mut Vec<Vector<D>>>,
    boundaries: Option<&Boundaries<D>>,
    gravity: &Vector<D>,
    t: Real,
    dt: Real,
) -> Result<(), (Location, Violation, Real)> {
    let GridNodes {
        mass,
        momentum,
        velocity,
    } = grid;
    velocity
        .par_iter_mut()
        .zip(momentum.par_iter())
        .zip(mass.par_iter())
        .enumerate()
        .for_each(|(i, ((v, p), &m))| {
            if m > 0.0 {
                *v = p / m + gravity * dt;
                if let Some(b) = boundaries.filter(|b| !b.is_empty()) {
                    b.apply(spec, t, &spec.multi_index(i), v);
                }
            } else {
                *v = Vector::<D>::zeros();
            }
        });
    if let Some(m0) = momentum0 {
        m0.par_iter_mut().zip(mass.par_iter()).for_each(|(p, &m)| {
            if m > 0.0 {
                *p /= m;
            }
        });
    }
    check_finite(velocity)
}

/// Applies `boundaries` at time `t` to the velocities of the nodes that have mass, then checks
/// them as [`update`] does.
pub(crate) fn apply_boundaries<const D: usize>(
    spec: &GridSpec<D>,
    grid: &mut GridNodes<D>,
    boundaries: &Boundaries<D>,
    t: Real,
) -> Result<(), (Location, Violation, Real)> {
    if !boundaries.is_empty() {
        let GridNodes { mass, velocity, .. } = grid;
        velocity
            .par_iter_mut()
            .zip(mass.par_iter())
            .enumerate()
            .filter(|(_, (_, &m))| m > 0.0)
            .for_each(|(i, (v, _))| boundaries.apply(spec, t, &spec.multi_index(i), v));
    }
    check_finite(&grid.velocity)
}

/// The first node (lowest index) with a non-finite velocity, if any.
fn check_finite<const D: usize>(velocity: &[Vector<D>]) -> Result<(), (Location, Violation, Real)> {
    match velocity
        .par_iter()
        .position_first(|v| !v.iter().all(|c| c.is_finite()))
    {
        Some(i) => Err((
            Location::Node(i),
            Violation::NonFinite("grid velocity"),
            velocity[i].norm(),
        )),
        None => Ok(()),
    }
}
