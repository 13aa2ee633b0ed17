//! Grid update: velocities from momenta, gravity, boundary conditions, and the grid guard check.

use crate::blocks::GridRef;
use mpm_core::boundary::Boundaries;
use mpm_core::quasistatic::Damping;
use mpm_core::{GridNodes, GridSpec, Location, NodeLayout, Real, Vector, Violation};
use rayon::prelude::*;

/// The accelerations and damping of a grid update.
#[derive(Clone, Copy, Debug)]
pub(crate) struct NodeForces<const D: usize> {
    /// Gravity at the start of the step (m/s²), ramped where the scene ramps it.
    pub gravity: Vector<D>,
    /// Damping of the unbalanced nodal forces; `None` when off.
    pub damping: Option<Damping>,
}

/// Computes node velocities `v_i = p_i/m_i + Δt g`, applies `boundaries` at time `t` when given
/// (multi-grid runs apply them after the coupling stage, see [`apply_boundaries`]), and turns
/// `momentum0` (the momentum P2G transferred without forces) into the pre-update velocities in
/// place. With damping, `momentum0` must be given: the unbalanced force is
/// `f_i = (p_i − p⁰_i)/Δt + m_i g` and the velocity `Damping::velocity` of `p⁰_i/m_i` and `f_i`.
/// Node arrays are in the order of the grid's layout. Returns the first stored node with a
/// non-finite velocity, named by its index on the full grid.
pub(crate) fn update<const D: usize>(
    GridRef { spec, layout, .. }: GridRef<'_, D>,
    grid: &mut GridNodes<D>,
    momentum0: Option<&mut Vec<Vector<D>>>,
    boundaries: Option<&Boundaries<D>>,
    forces: &NodeForces<D>,
    t: Real,
    dt: Real,
) -> Result<(), (Location, Violation, Real)> {
    let GridNodes {
        mass,
        momentum,
        velocity,
    } = grid;
    let gravity = forces.gravity;
    let walls = |i: usize, v: &mut Vector<D>| {
        if let Some(b) = boundaries.filter(|b| !b.is_empty()) {
            b.apply(spec, t, &layout.node(i), v);
        }
    };
    let nodes = velocity
        .par_iter_mut()
        .zip(momentum.par_iter())
        .zip(mass.par_iter())
        .enumerate();
    match momentum0 {
        None => nodes.for_each(|(i, ((v, p), &m))| {
            if m > 0.0 {
                *v = p / m + gravity * dt;
                walls(i, v);
            } else {
                *v = Vector::<D>::zeros();
            }
        }),
        Some(m0) => nodes
            .zip(m0.par_iter_mut())
            .for_each(|((i, ((v, p), &m)), p0)| {
                if m > 0.0 {
                    *v = match &forces.damping {
                        Some(d) => {
                            let f = (p - *p0) / dt + gravity * m;
                            d.velocity(&(*p0 / m), &f, m, dt)
                        }
                        None => p / m + gravity * dt,
                    };
                    *p0 /= m;
                    walls(i, v);
                } else {
                    *v = Vector::<D>::zeros();
                }
            }),
    }
    check_finite(spec, layout, velocity)
}

/// Applies `boundaries` at time `t` to the velocities of the nodes that have mass, then checks
/// them as [`update`] does.
pub(crate) fn apply_boundaries<const D: usize>(
    spec: &GridSpec<D>,
    layout: &NodeLayout<D>,
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
            .for_each(|(i, (v, _))| boundaries.apply(spec, t, &layout.node(i), v));
    }
    check_finite(spec, layout, &grid.velocity)
}

/// The first stored node (lowest storage index) with a non-finite velocity, if any, named by
/// its index on the full grid.
fn check_finite<const D: usize>(
    spec: &GridSpec<D>,
    layout: &NodeLayout<D>,
    velocity: &[Vector<D>],
) -> Result<(), (Location, Violation, Real)> {
    // Chunks scanned in parallel and the lowest failing index kept: the same node as a
    // `position_first` over the nodes, without its per-node bookkeeping (an atomic load and
    // copies of the folder's state per node, ~5 % of a 2D step).
    const CHUNK: usize = 4096;
    let first_bad = velocity
        .par_chunks(CHUNK)
        .enumerate()
        .filter_map(|(c, chunk)| {
            let bad = chunk.iter().position(|v| !v.iter().all(|c| c.is_finite()));
            bad.map(|j| c * CHUNK + j)
        })
        .min();
    match first_bad {
        Some(i) => Err((
            Location::Node(spec.linear_index(&layout.node(i)).unwrap_or(usize::MAX)),
            Violation::NonFinite("grid velocity"),
            velocity[i].norm(),
        )),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The check names the lowest stored node with a non-finite velocity, wherever the bad
    /// nodes fall among the scan's chunks, and passes a finite grid.
    #[test]
    fn check_finite_names_the_first_bad_node() {
        let spec = GridSpec::<2>::new(Vector::<2>::zeros(), 0.1, [100, 100]);
        let layout = NodeLayout::dense(&spec);
        let good = vec![Vector::<2>::new(1.0, -2.0); layout.len()];
        assert!(check_finite(&spec, &layout, &good).is_ok());
        for bad in [[9000, 4096, 4095], [0, 12000, 3], [8191, 8192, 9999]] {
            let mut v = good.clone();
            v[bad[0]].x = Real::NAN;
            v[bad[1]].y = Real::INFINITY;
            v[bad[2]].x = Real::NEG_INFINITY;
            let first = *bad.iter().min().unwrap();
            let (location, violation, _) = check_finite(&spec, &layout, &v).unwrap_err();
            let node = spec.linear_index(&layout.node(first)).unwrap();
            assert_eq!(location, Location::Node(node));
            assert_eq!(violation, Violation::NonFinite("grid velocity"));
        }
    }
}
