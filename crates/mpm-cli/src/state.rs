//! A solver's named columns ([`mpm_core::Column`]) as `mpm-io` fields and back: the snapshot
//! fields a scene asks for, the whole solver state for a checkpoint, and the state read from a
//! checkpoint for `--resume`. The solver decides what its columns hold; this module only moves
//! them between the two representations.

use mpm_core::{Column, Dim, DimOps, Solver, SolverState};
use mpm_io::{Field, Snapshot};

/// Unit system written to every file.
pub const UNITS: &str = "SI (m, s, kg, Pa); in 2D volumes are areas (m^2)";

/// A column as an `mpm-io` field: the same type ([`mpm_io::Field`] is [`mpm_core::Column`]).
pub fn to_field(c: Column) -> Field {
    c
}

/// An `mpm-io` field as a column.
pub fn to_column(f: &Field) -> Column {
    f.clone()
}

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
        columns: ck.fields.iter().map(to_column).collect(),
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
