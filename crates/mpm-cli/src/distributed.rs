//! Runs on several processes (cargo feature `mpi`; docs/distributed.md). `mpirun -n N mpm-cli
//! run scene.toml` starts N processes; each runs the same loop on its part of the particles
//! (`mpm_dist::DistributedExplicit` behind the solver seam) and writes its own piece of every
//! snapshot, `snap_NNNNNN_pRRRR.h5`; rank 0 writes `run.xmf` (each step a spatial collection
//! of the pieces), `summary.json` and every message. Without the feature, or on one process,
//! everything here is the single-process behaviour.

use mpm_core::{Dim, DimOps, SetupError, Solver};
#[cfg(feature = "mpi")]
use mpm_dist::Comm;
use mpm_explicit::ExplicitSolver;

/// Steps between repartitions of a distributed run.
pub const REPARTITION_STEPS: u64 = 50;

#[cfg(feature = "mpi")]
static WORLD: std::sync::OnceLock<mpm_dist::MpiComm> = std::sync::OnceLock::new();

/// Keeps MPI initialised while it lives (nothing to keep without the feature).
#[derive(Debug)]
pub struct Session {
    #[cfg(feature = "mpi")]
    _mpi: Option<mpm_dist::MpiSession>,
}

/// Initialises MPI when built with the `mpi` feature (a process started without `mpirun` is a
/// run of one rank); a no-op otherwise.
pub fn init() -> Session {
    #[cfg(feature = "mpi")]
    {
        let mpi = mpm_dist::MpiComm::init().map(|(session, comm)| {
            let _ = WORLD.set(comm);
            session
        });
        Session { _mpi: mpi }
    }
    #[cfg(not(feature = "mpi"))]
    Session {}
}

/// This process's rank (0 on one process).
pub fn rank() -> usize {
    #[cfg(feature = "mpi")]
    if let Some(c) = WORLD.get() {
        return c.rank();
    }
    0
}

/// Number of ranks (1 on one process).
pub fn ranks() -> usize {
    #[cfg(feature = "mpi")]
    if let Some(c) = WORLD.get() {
        return c.size();
    }
    1
}

/// Whether this process prints and writes the run's shared files (rank 0).
pub fn root() -> bool {
    rank() == 0
}

/// Waits until every rank has arrived (nothing on one process).
pub fn barrier() {
    #[cfg(feature = "mpi")]
    if let Some(c) = WORLD.get().filter(|c| c.size() > 1) {
        c.all_gather(Vec::new());
    }
}

/// The output field of the particles' global ids, written to every piece of a distributed run.
pub const ID: &str = "id";

/// Every rank's `n`, in rank order (collective on several ranks; `[n]` on one process).
pub fn gather_counts(n: usize) -> Vec<usize> {
    #[cfg(feature = "mpi")]
    if let Some(c) = WORLD.get().filter(|c| c.size() > 1) {
        let all = c.all_gather((n as u64).to_le_bytes().to_vec());
        return all
            .iter()
            .map(|m| u64::from_le_bytes(m[..8].try_into().expect("8 bytes")) as usize)
            .collect();
    }
    vec![n]
}

/// Whether any rank has `flag` set (collective on several ranks).
pub fn any(flag: bool) -> bool {
    #[cfg(feature = "mpi")]
    if let Some(c) = WORLD.get().filter(|c| c.size() > 1) {
        return c.all_gather(vec![u8::from(flag)]).iter().any(|m| m[0] == 1);
    }
    flag
}

/// On several ranks, ends the whole job with exit code `code` (a rank that fails alone would
/// leave the others waiting forever); returns on one process.
pub fn end_job(code: u8) {
    #[cfg(feature = "mpi")]
    if let Some(c) = WORLD.get().filter(|c| c.size() > 1) {
        c.abort(i32::from(code));
    }
    let _ = code;
}

/// The explicit solver of this process: on several ranks, its part of the distributed run.
pub fn explicit<const D: usize>(solver: ExplicitSolver<D>) -> Result<Box<dyn Solver<D>>, SetupError>
where
    Dim<D>: DimOps<D>,
{
    #[cfg(feature = "mpi")]
    if let Some(c) = WORLD.get().filter(|c| c.size() > 1) {
        let run = mpm_dist::DistributedExplicit::new(*c, solver, REPARTITION_STEPS)?;
        return Ok(Box::new(run));
    }
    Ok(Box::new(solver))
}

/// File name of this rank's piece of snapshot `frame` (the plain name on one process).
pub fn snapshot_piece(frame: u64, rank: usize) -> String {
    if ranks() == 1 {
        crate::run::snapshot_name(frame)
    } else {
        format!("snap_{frame:06}_p{rank:04}.h5")
    }
}
