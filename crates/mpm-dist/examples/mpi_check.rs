//! The MPI checks of `mpm-dist`, run under `mpirun` (`make mpi-test`):
//!
//! - `mpi_check identity`: on every scene of `tests/scenes` and the 64,000-particle jelly cube
//!   of the `step/3d_64k` benchmark, the run on this job's ranks is bitwise the one-process
//!   run (every rank also runs the one-process run and compares its own particles, by id);
//!   exit code 1 on any difference.
//! - `mpi_check time STEPS`: wall time of STEPS steps of the `step/3d_256k` benchmark scene
//!   (after 3 warm-up steps), with the particles per rank and the bytes each rank sent per
//!   step, for the scaling figures in `docs/distributed.md` (a measurement, not a test).

#[path = "../tests/scenes/mod.rs"]
mod scenes;

use mpm_core::boundary::WallTreatment;
use mpm_core::{Dim, DimOps, Solver};
use mpm_dist::{Comm, DistributedExplicit, MpiComm};
use mpm_explicit::{ExplicitSolver, VolumeUpdate};
use scenes::bits;
use std::process::ExitCode;
use std::time::Instant;

/// Reduces `x` over ranks with `f` (in rank order).
fn reduce(comm: &MpiComm, x: f64, f: fn(f64, f64) -> f64) -> f64 {
    comm.all_gather(x.to_le_bytes().to_vec())
        .iter()
        .map(|b| f64::from_le_bytes(b[..8].try_into().expect("8 bytes")))
        .reduce(f)
        .expect("at least one rank")
}

/// Runs `make()` `steps` steps on one process and on the job's ranks; returns the number of
/// values (over all ranks) that differ, and prints a line on rank 0.
fn identity<const D: usize>(
    comm: &MpiComm,
    name: &str,
    make: impl Fn() -> ExplicitSolver<D>,
    steps: u64,
) -> u64
where
    Dim<D>: DimOps<D>,
{
    let serial = scenes::serial(&make, steps);
    let want = bits(serial.particles());
    let mut d = DistributedExplicit::new(*comm, make(), 10).expect("a valid scene");
    for _ in 0..steps {
        d.step().expect("the distributed run is stable");
    }
    let (ps, ids) = d.own_particles();
    let got = bits(ps);
    let mut differ = u64::from(d.time().to_bits() != serial.time().to_bits());
    for ((_, w), (_, g)) in want.iter().zip(&got) {
        let per = w.len() / serial.particles().len();
        for (k, &id) in ids.iter().enumerate() {
            let id = id as usize;
            differ += (0..per)
                .filter(|&c| w[id * per + c] != g[k * per + c])
                .count() as u64;
        }
    }
    let owned = reduce(comm, ps.len() as f64, |a, b| a + b);
    let differ = reduce(comm, differ as f64, |a, b| a + b) as u64;
    let arrived = reduce(comm, d.traffic().arrived as f64, |a, b| a + b);
    if comm.rank() == 0 {
        let verdict = if differ == 0 && owned as usize == serial.particles().len() {
            "bitwise identical"
        } else {
            "DIFFERENT"
        };
        println!(
            "{name}: {} particles, {steps} steps on {} ranks: {verdict} to one process \
             ({differ} values differ; {arrived} particles changed rank, the first placement included)",
            serial.particles().len(),
            comm.size()
        );
    }
    differ + u64::from(owned as usize != serial.particles().len())
}

fn time(comm: &MpiComm, steps: u64) {
    if comm.size() == 1 {
        let mut plain = mpm_benches::scene_3d(mpm_benches::Size::K256);
        for _ in 0..3 {
            plain.step().expect("the benchmark scene is stable");
        }
        let t = Instant::now();
        for _ in 0..steps {
            plain.step().expect("the benchmark scene is stable");
        }
        println!(
            "step/3d_256k scene, ExplicitSolver alone x {} threads: {:.2} ms per step",
            rayon::current_num_threads(),
            1e3 * t.elapsed().as_secs_f64() / steps as f64
        );
    }
    let mut d = DistributedExplicit::new(*comm, mpm_benches::scene_3d(mpm_benches::Size::K256), 0)
        .expect("the benchmark scene is valid");
    for _ in 0..3 {
        d.step().expect("the benchmark scene is stable");
    }
    let (sent, exchanging) = (d.traffic().bytes_sent, d.traffic().time);
    let t = Instant::now();
    for _ in 0..steps {
        d.step().expect("the benchmark scene is stable");
    }
    let wall = reduce(comm, t.elapsed().as_secs_f64(), f64::max);
    let bytes = (d.traffic().bytes_sent - sent) as f64 / steps as f64;
    let exchange = (d.traffic().time - exchanging).as_secs_f64() / steps as f64;
    let line = format!(
        "rank {}: {} own particles, {} halo copies, {:.0} bytes sent and {:.2} ms in \
         exchanges per step",
        comm.rank(),
        d.solver().particles().len(),
        d.halo_len(),
        bytes,
        1e3 * exchange
    );
    let lines = comm.all_gather(line.into_bytes());
    if comm.rank() == 0 {
        println!(
            "step/3d_256k scene, {} ranks x {} threads: {:.2} ms per step ({steps} steps)",
            comm.size(),
            rayon::current_num_threads(),
            1e3 * wall / steps as f64
        );
        for l in lines {
            println!("  {}", String::from_utf8_lossy(&l));
        }
    }
}

fn main() -> ExitCode {
    let Some((_session, comm)) = MpiComm::init() else {
        eprintln!("error: MPI could not be initialised with the serialized threading level");
        return ExitCode::FAILURE;
    };
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("identity") => {
            let differ = identity(
                &comm,
                "dam break 2D",
                || scenes::dam_break(WallTreatment::Nodes, VolumeUpdate::default()),
                150,
            ) + identity(
                &comm,
                "dam break 2D, mirrored walls, re-estimated volumes",
                || scenes::dam_break(WallTreatment::Mirror, VolumeUpdate::Reestimate),
                100,
            ) + identity(&comm, "rotating disk 2D", scenes::rotating_disk, 200)
                + identity(
                    &comm,
                    "jelly into water, two grids",
                    scenes::jelly_into_water,
                    120,
                )
                + identity(
                    &comm,
                    "jelly cube 3D (step/3d_64k scene)",
                    || mpm_benches::scene_3d(mpm_benches::Size::K64),
                    30,
                );
            if differ == 0 {
                ExitCode::SUCCESS
            } else {
                ExitCode::FAILURE
            }
        }
        Some("time") => {
            let steps = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(20);
            time(&comm, steps);
            ExitCode::SUCCESS
        }
        _ => {
            eprintln!("usage: mpirun -n N mpi_check identity | time [STEPS]");
            ExitCode::from(2)
        }
    }
}
