//! [`Comm`] over MPI (rsmpi): the world communicator of an MPI job.

use crate::comm::Comm;
use mpi::datatype::{Partition, PartitionMut};
use mpi::environment::Universe;
use mpi::topology::SimpleCommunicator;
use mpi::traits::{Communicator, CommunicatorCollectives};
use mpi::Count;

/// The ranks of an MPI job (`MPI_COMM_WORLD`), as a handle that any thread may hold (each
/// collective looks the world communicator up); calls must still come from one thread at a
/// time, as the "serialized" level MPI was initialised with requires.
#[derive(Clone, Copy, Debug)]
pub struct MpiComm {
    rank: usize,
    size: usize,
}

/// MPI for the life of the process: finalised when dropped, after every collective.
pub struct MpiSession {
    _universe: Universe,
}

impl std::fmt::Debug for MpiSession {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("MpiSession")
    }
}

impl MpiComm {
    /// Initialises MPI with the "serialized" threading level: any one thread at a time calls
    /// MPI (a driver may step on a rayon pool thread; the pool's threads compute in between
    /// and never call MPI). Keep the session for as long as MPI is used. `None` when MPI was
    /// initialised already or offers less than that level.
    pub fn init() -> Option<(MpiSession, Self)> {
        let (universe, level) = mpi::initialize_with_threading(mpi::Threading::Serialized)?;
        if level < mpi::Threading::Serialized {
            return None;
        }
        let world = universe.world();
        let comm = Self {
            rank: world.rank() as usize,
            size: world.size() as usize,
        };
        Some((
            MpiSession {
                _universe: universe,
            },
            comm,
        ))
    }

    /// Ends every process of the job with exit code `code` (`MPI_Abort`): what a rank that
    /// fails alone must do, since the others would wait for it forever.
    pub fn abort(&self, code: i32) -> ! {
        Self::world().abort(code)
    }

    fn world() -> SimpleCommunicator {
        SimpleCommunicator::world()
    }
}

/// Displacements of consecutive runs of `counts`.
fn displacements(counts: &[Count]) -> Vec<Count> {
    counts
        .iter()
        .scan(0, |at, &c| {
            let d = *at;
            *at += c;
            Some(d)
        })
        .collect()
}

impl Comm for MpiComm {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.size
    }

    fn exchange(&self, out: Vec<Vec<u8>>) -> Vec<Vec<u8>> {
        assert_eq!(out.len(), self.size(), "one message per rank");
        let send_counts: Vec<Count> = out
            .iter()
            .map(|m| Count::try_from(m.len()).expect("a message below 2 GiB"))
            .collect();
        let mut recv_counts = vec![0 as Count; self.size()];
        Self::world().all_to_all_into(&send_counts[..], &mut recv_counts[..]);
        // One byte beyond the messages, never sent: an empty buffer's address would be Rust's
        // dangling 0x1, which Open MPI reads as MPI_IN_PLACE.
        let mut flat: Vec<u8> = out.concat();
        flat.push(0);
        let send_displs = displacements(&send_counts);
        let recv_displs = displacements(&recv_counts);
        let total: usize = recv_counts.iter().map(|&c| c as usize).sum();
        let mut buf = vec![0u8; total + 1];
        {
            let send = Partition::new(&flat[..], &send_counts[..], &send_displs[..]);
            let mut recv = PartitionMut::new(&mut buf[..], &recv_counts[..], &recv_displs[..]);
            Self::world().all_to_all_varcount_into(&send, &mut recv);
        }
        recv_counts
            .iter()
            .zip(&recv_displs)
            .map(|(&c, &d)| buf[d as usize..(d + c) as usize].to_vec())
            .collect()
    }
}
