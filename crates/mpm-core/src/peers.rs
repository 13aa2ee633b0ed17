//! The seam for a run split between processes: the decisions of a step that every process
//! holding part of the particles must share.
//!
//! A solver step makes two such decisions, the time step and whether an attempt failed. A
//! process alone ([`Alone`]) takes its own; a distributed driver implements [`Peers`] with
//! collective reductions, so that every process takes the step the whole run would take in
//! one process: the smallest dt any process chose (the step bound is a decreasing function of
//! the largest signal speed, so the minimum over processes of each process's bound is the
//! bound of the whole set, exactly), and a failure as soon as any process failed, the same
//! one on every process.

use crate::math::Real;
use crate::solver::Failure;

/// The decisions of one step that the processes sharing a run agree on. `E` is the solver's
/// own solve error.
pub trait Peers<E> {
    /// The time step (s) every process takes, from this process's choice (or its failure to
    /// choose one).
    fn agree_dt(&mut self, local: Result<Real, Failure<E>>) -> Result<Real, Failure<E>>;

    /// The outcome of an attempt, the same on every process: a failure when any process
    /// failed. A failure names a particle by its index in the whole run.
    fn agree(&mut self, local: Result<(), Failure<E>>) -> Result<(), Failure<E>>;
}

/// A process that holds the whole run: every decision is its own.
#[derive(Clone, Copy, Debug, Default)]
pub struct Alone;

impl<E> Peers<E> for Alone {
    fn agree_dt(&mut self, local: Result<Real, Failure<E>>) -> Result<Real, Failure<E>> {
        local
    }

    fn agree(&mut self, local: Result<(), Failure<E>>) -> Result<(), Failure<E>> {
        local
    }
}
