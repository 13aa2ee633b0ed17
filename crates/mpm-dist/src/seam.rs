//! A distributed explicit run behind the solver seam ([`Solver`]), so that a driver written for
//! one process runs it unchanged on every rank. Between steps each rank holds its own
//! particles only; they are what [`Solver::particles`] and the output fields give, with the
//! field `id` (the particles' global ids) to put the ranks' pieces back together.
//!
//! [`Solver::diagnostics`] and [`Solver::stable_dt`] are collective: every rank must call them
//! at the same points. Diagnostics are each rank's sums (in particle order, as one process
//! sums) added in rank order: deterministic for a rank count, and within rounding (relative
//! `N ε` for `N` particles) of the one-process sums.

use crate::comm::Comm;
use crate::explicit::DistributedExplicit;
use mpm_core::solver::{DtBound, FieldInfo, RestoreError, StageTime};
use mpm_core::{
    Column, Diagnostics, Dim, DimOps, GridSpec, Material, Monitor, Particles, Real, Solver,
    SolverState, StagePlan, StepError, StepInfo,
};

/// The output field of the particles' global ids.
pub const ID: &str = "id";

impl<const D: usize, C: Comm + std::fmt::Debug + Send> Solver<D> for DistributedExplicit<D, C>
where
    Dim<D>: DimOps<D>,
{
    fn name(&self) -> &'static str {
        self.solver().name()
    }

    fn spec(&self) -> &GridSpec<D> {
        self.solver().spec()
    }

    fn particles(&self) -> &Particles<D> {
        self.solver().particles()
    }

    fn materials(&self) -> &[Material] {
        self.solver().materials()
    }

    fn time(&self) -> Real {
        DistributedExplicit::time(self)
    }

    fn steps(&self) -> u64 {
        DistributedExplicit::steps(self)
    }

    /// The bound over all ranks' particles (collective).
    fn stable_dt(&self) -> Real {
        self.reduce(&[self.solver().stable_dt()], Real::min)[0]
    }

    fn dt_bound(&self) -> DtBound {
        Solver::dt_bound(self.solver())
    }

    fn region(&self) -> mpm_core::Region<D> {
        Solver::region(self.solver())
    }

    /// The sums over all ranks' particles (collective; see the module docs).
    fn diagnostics(&self) -> Diagnostics<D> {
        let mut d = self.solver().diagnostics();
        let mut values = vec![d.mass];
        values.extend(d.momentum.iter());
        values.extend(d.angular_momentum.iter());
        values.extend([d.kinetic_energy, d.elastic_energy, d.potential_energy]);
        values.extend(d.other_energies.iter().map(|(_, v)| *v));
        let sum = self.reduce(&values, |a, b| a + b);
        let mut it = sum.into_iter();
        let mut next = || it.next().expect("every rank sends the same values");
        d.mass = next();
        d.momentum.iter_mut().for_each(|m| *m = next());
        d.angular_momentum.iter_mut().for_each(|m| *m = next());
        d.kinetic_energy = next();
        d.elastic_energy = next();
        d.potential_energy = next();
        d.other_energies.iter_mut().for_each(|(_, v)| *v = next());
        d
    }

    fn plan(&self) -> StagePlan {
        Solver::plan(self.solver())
    }

    fn step(&mut self) -> Result<StepInfo, StepError> {
        DistributedExplicit::step(self).map_err(|e| e.erase(self.solver().name()))
    }

    fn stage_times(&self) -> Vec<StageTime> {
        Solver::stage_times(self.solver())
    }

    /// This rank's particles with their ids.
    fn checkpoint(&self) -> SolverState {
        let mut state = Solver::checkpoint(self.solver());
        state.columns.push(self.ids_column());
        state
    }

    fn restore(&mut self, _state: &SolverState) -> Result<(), RestoreError> {
        Err(RestoreError(
            "a run on several ranks cannot resume from a checkpoint yet".into(),
        ))
    }

    fn monitors(&self) -> Vec<Monitor> {
        Solver::monitors(self.solver())
    }

    fn output_fields(&self) -> Vec<FieldInfo> {
        let mut fields = Solver::output_fields(self.solver());
        fields.push(FieldInfo {
            name: ID,
            unit: "1",
            components: 1,
            derived: true,
        });
        fields
    }

    fn pressure(&self) -> Vec<Real> {
        Solver::pressure(self.solver())
    }

    fn output(&self, name: &str) -> Vec<Column> {
        match name {
            ID => vec![self.ids_column()],
            _ => Solver::output(self.solver(), name),
        }
    }
}

impl<const D: usize, C: Comm> DistributedExplicit<D, C>
where
    Dim<D>: DimOps<D>,
{
    /// `values` summed (or otherwise combined by `f`) over the ranks, in rank order
    /// (collective).
    fn reduce(&self, values: &[Real], f: fn(Real, Real) -> Real) -> Vec<Real> {
        let bytes = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let all = self.comm().all_gather(bytes);
        let parse = |b: &Vec<u8>| -> Vec<Real> {
            b.chunks_exact(8)
                .map(|c| Real::from_le_bytes(c.try_into().expect("8 bytes")))
                .collect()
        };
        let mut out = parse(&all[0]);
        for b in &all[1..] {
            for (o, v) in out.iter_mut().zip(parse(b)) {
                *o = f(*o, v);
            }
        }
        out
    }

    /// The global ids of this rank's particles as a column (u32).
    fn ids_column(&self) -> Column {
        let (_, ids) = self.own_particles();
        let ids: Vec<u32> = ids
            .iter()
            .map(|&i| u32::try_from(i).expect("fewer than 2^32 particles"))
            .collect();
        Column::indices(ID, &ids)
    }
}
