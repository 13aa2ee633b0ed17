//! Newmark with contact: the contact forces of a step taken at its end, by re-solving the step
//! until they agree with its end positions.

use super::{solve_grid, Workspace};
use crate::core::{Core, Failure, NewtonTimes};
use crate::newton::NewtonInfo;
use crate::params::ImplicitParams;
use mpm_core::{Dim, DimOps, Real, Vector};

/// Most passes of [`end_of_step_contact`].
const CONTACT_PASSES: usize = 30;

/// Relative change of the node displacements (of their largest) below which
/// [`end_of_step_contact`] stops (dimensionless).
const CONTACT_TOLERANCE: Real = 1e-10;

/// Newmark with contact: the contact forces of the step are those at its end, as Newmark
/// treats every force (`M a^{n+1} = f(x^{n+1})`; `a^n` already holds the start-of-step contact
/// forces), so that the work of a penalty spring over the step, `(f^n + f^{n+1})/2 · Δx`, is
/// its energy change and contact neither creates nor destroys energy. With the start-of-step
/// forces alone (the backward-Euler treatment) a spring pushes with its smaller force while it is
/// compressed and its larger one while it relaxes, and the two-disk collision gained 348 % of
/// its energy. The end positions depend on the forces, so the step is solved again from its
/// last solution with the contact forces at its end positions (`base`: the external forces
/// without contact), until the displacements change by less than [`CONTACT_TOLERANCE`] of the
/// largest, at most [`CONTACT_PASSES`] times (in the two-disk collision of the validation case
/// `two_disks_energy`, 7 to 10 passes mostly, 30 in one step of 330). A step without contact
/// at its start (`touching`) or its end is solved once. Returns the last solve's `NewtonInfo`
/// with the iterations of every pass.
pub(super) fn end_of_step_contact<const D: usize>(
    core: &mut Core<D>,
    ws: &mut Workspace<D>,
    times: &mut NewtonTimes,
    implicit: &ImplicitParams,
    dt: Real,
    (base, first, touching): (&[Vector<D>], NewtonInfo, bool),
) -> Result<NewtonInfo, Failure>
where
    Dim<D>: DimOps<D>,
{
    let mut total = first;
    for _ in 0..CONTACT_PASSES {
        core.grid_to_particles(dt)?;
        core.external.copy_from_slice(base);
        let end = core.contact_at_step_end(dt);
        if !touching && !end.is_some_and(|c| c.touching()) {
            break;
        }
        let previous = core.displacement.clone();
        let info = solve_grid(core, ws, times, implicit, dt, Some(&previous))?;
        let iterations = total.iterations + info.iterations;
        let halvings = total.halvings + info.halvings;
        total = NewtonInfo {
            iterations,
            halvings,
            ..info
        };
        let size = core
            .displacement
            .iter()
            .map(|u| u.amax())
            .fold(0.0, Real::max);
        let change = (core.displacement.iter().zip(&previous))
            .map(|(u, p)| (u - p).amax())
            .fold(0.0, Real::max);
        if change <= CONTACT_TOLERANCE * size {
            break;
        }
    }
    Ok(total)
}
