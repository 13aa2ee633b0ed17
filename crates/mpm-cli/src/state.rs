//! A solver's named columns ([`mpm_core::Column`], which are `mpm-io`'s fields) in and out of
//! files: the snapshot fields a scene asks for, and the state read from a checkpoint for
//! `--resume`. The solver decides what its columns hold.

use mpm_core::{Column, Dim, DimOps, Solver, SolverState};
use mpm_io::Snapshot;

/// Unit system written to every file.
pub const UNITS: &str = "SI (m, s, kg, Pa); in 2D volumes are areas (m^2)";

/// The snapshot columns named in `names` (as resolved by the scene), in that order; names the
/// solver does not have are skipped.
pub fn snapshot_columns<const D: usize>(solver: &dyn Solver<D>, names: &[String]) -> Vec<Column>
where
    Dim<D>: DimOps<D>,
{
    names.iter().flat_map(|n| solver.output(n)).collect()
}

/// The solver state stored in checkpoint `ck`.
pub fn checkpoint_state(ck: &Snapshot) -> SolverState {
    SolverState {
        time: ck.header.time,
        steps: ck.header.step,
        columns: ck.fields.clone(),
        attrs: ck.header.attrs.clone(),
    }
}

/// The first non-finite value in `columns`: `(column, particle, value)`.
pub fn first_non_finite(columns: &[Column]) -> Option<(String, usize, f64)> {
    columns.iter().find_map(|c| {
        let (p, v) = c.first_non_finite()?;
        Some((c.name.clone(), p, v))
    })
}
