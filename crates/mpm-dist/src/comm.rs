//! The transport between the processes of a run: a communicator with the two collectives the
//! distributed driver needs, an all-to-all of byte messages and an all-gather, and an
//! in-process implementation over threads (each "rank" a thread with its own rayon pool) that
//! the tests use and that needs no MPI library.

use std::sync::{Arc, Barrier, Mutex};

/// The processes ("ranks") of one run and the collectives between them. Every rank must call
/// every collective, in the same order.
pub trait Comm {
    /// This process's rank, `0..size`.
    fn rank(&self) -> usize;

    /// Number of ranks.
    fn size(&self) -> usize;

    /// Sends `out[r]` to every rank `r` (`out` has [`Comm::size`] entries, empty ones allowed)
    /// and returns the message each rank sent to this one, in rank order.
    fn exchange(&self, out: Vec<Vec<u8>>) -> Vec<Vec<u8>>;

    /// Every rank's `bytes`, in rank order.
    fn all_gather(&self, bytes: Vec<u8>) -> Vec<Vec<u8>> {
        self.exchange(vec![bytes; self.size()])
    }
}

/// A rank of an in-process group: the ranks are threads that share mailboxes.
#[derive(Debug)]
pub struct ThreadComm {
    rank: usize,
    shared: Arc<Shared>,
}

#[derive(Debug)]
struct Shared {
    size: usize,
    /// `boxes[from][to]`: the message in flight from rank `from` to rank `to`.
    boxes: Mutex<Vec<Vec<Vec<u8>>>>,
    barrier: Barrier,
}

impl ThreadComm {
    /// The `size` ranks of a new group, rank 0 first.
    pub fn group(size: usize) -> Vec<ThreadComm> {
        let shared = Arc::new(Shared {
            size,
            boxes: Mutex::new(vec![vec![Vec::new(); size]; size]),
            barrier: Barrier::new(size),
        });
        (0..size)
            .map(|rank| ThreadComm {
                rank,
                shared: Arc::clone(&shared),
            })
            .collect()
    }
}

impl Comm for ThreadComm {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.shared.size
    }

    fn exchange(&self, out: Vec<Vec<u8>>) -> Vec<Vec<u8>> {
        assert_eq!(out.len(), self.size(), "one message per rank");
        let lock = || self.shared.boxes.lock().unwrap_or_else(|e| e.into_inner());
        lock()[self.rank] = out;
        self.shared.barrier.wait();
        let received = {
            let mut boxes = lock();
            (0..self.size())
                .map(|from| std::mem::take(&mut boxes[from][self.rank]))
                .collect()
        };
        // Nobody writes the next round's messages before everyone has read this round's.
        self.shared.barrier.wait();
        received
    }
}

/// Runs `f` on `ranks` in-process ranks, each a thread with a rayon pool of
/// `threads_per_rank` threads, and returns their results in rank order.
///
/// # Panics
/// When a rank panics (the others may then wait forever, so tests should not rely on it).
pub fn run_ranks<T: Send>(
    ranks: usize,
    threads_per_rank: usize,
    f: impl Fn(ThreadComm) -> T + Sync,
) -> Vec<T> {
    std::thread::scope(|s| {
        let handles: Vec<_> = ThreadComm::group(ranks)
            .into_iter()
            .map(|comm| {
                let f = &f;
                s.spawn(move || {
                    let pool = rayon::ThreadPoolBuilder::new()
                        .num_threads(threads_per_rank)
                        .build()
                        .expect("a rayon pool for one rank");
                    pool.install(|| f(comm))
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("a rank panicked"))
            .collect()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exchange_delivers_each_message_to_its_rank() {
        let got = run_ranks(3, 1, |c| {
            let out = (0..c.size())
                .map(|to| vec![c.rank() as u8, to as u8])
                .collect();
            let a = c.exchange(out);
            let b = c.all_gather(vec![10 + c.rank() as u8]);
            (a, b)
        });
        for (me, (a, b)) in got.iter().enumerate() {
            for from in 0..3 {
                assert_eq!(a[from], vec![from as u8, me as u8]);
                assert_eq!(b[from], vec![10 + from as u8]);
            }
        }
    }
}
