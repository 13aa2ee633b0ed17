//! A run split over 1–4 in-process ranks is bitwise the one-process run: positions,
//! velocities and every other column of every particle, after many steps in which particles
//! cross rank boundaries.

mod scenes;

use mpm_core::boundary::WallTreatment;
use mpm_core::prelude::*;
use mpm_core::{Dim, DimOps};
use mpm_dist::{run_ranks, DistributedExplicit};
use mpm_explicit::{ExplicitSolver, VolumeUpdate};
use scenes::{bits, cube_3d, dam_break, jelly_into_water, rotating_disk, serial};

/// Runs `make()` for `steps` steps in one process and on 1–4 ranks (1 thread each), and
/// asserts that time and the particles, sorted by id, are bitwise equal; returns how many
/// particles changed rank in the run on 4 ranks.
fn assert_rank_independent<const D: usize>(
    make: impl Fn() -> ExplicitSolver<D> + Sync,
    steps: u64,
) -> u64
where
    Dim<D>: DimOps<D>,
{
    let serial = serial(&make, steps);
    let want = bits(serial.particles());
    let mut arrived = 0;
    for ranks in 1..=4 {
        let parts = run_ranks(ranks, 1, |comm| {
            let mut d = DistributedExplicit::new(comm, make(), 7).unwrap();
            for _ in 0..steps {
                d.step().expect("the distributed run is stable");
            }
            assert_eq!(d.time().to_bits(), serial.time().to_bits());
            let (ps, ids) = d.own_particles();
            (ps.clone(), ids.to_vec(), d.traffic().arrived)
        });
        let mut all = Particles::new(serial.particles().columns());
        let mut ids = Vec::new();
        for (ps, part_ids, moved) in parts {
            all.append(&ps);
            ids.extend(part_ids);
            if ranks == 4 {
                arrived += moved;
            }
        }
        let mut order: Vec<usize> = (0..ids.len()).collect();
        order.sort_by_key(|&k| ids[k]);
        let sorted: Vec<u64> = order.iter().map(|&k| ids[k]).collect();
        assert_eq!(
            sorted,
            (0..serial.particles().len() as u64).collect::<Vec<_>>()
        );
        let got = bits(&all.select(&order));
        for ((name, w), (_, g)) in want.iter().zip(&got) {
            let differ = w.iter().zip(g).filter(|(a, b)| a != b).count();
            assert_eq!(
                differ, 0,
                "{ranks} ranks: column {name} differs in {differ} values"
            );
        }
    }
    arrived
}

#[test]
fn dam_break_is_bitwise_the_serial_run_on_any_rank_count() {
    let moved = assert_rank_independent(
        || dam_break(WallTreatment::Nodes, VolumeUpdate::default()),
        150,
    );
    assert!(moved > 0, "no particle changed rank");
}

#[test]
fn mirrored_walls_and_volume_reestimation_reach_two_stencils() {
    assert_rank_independent(
        || dam_break(WallTreatment::Mirror, VolumeUpdate::Reestimate),
        100,
    );
}

#[test]
fn rotating_disk_migrates_and_stays_bitwise() {
    let moved = assert_rank_independent(rotating_disk, 200);
    assert!(moved > 1000, "only {moved} particles changed rank");
}

#[test]
fn falling_cube_3d_is_bitwise_the_serial_run() {
    assert_rank_independent(|| cube_3d(0.4, 32), 40);
}

#[test]
fn multigrid_contact_is_bitwise_the_serial_run() {
    assert_rank_independent(jelly_into_water, 120);
}

/// Through the solver seam: `run_until` on every rank, diagnostics summed over ranks (equal to
/// one process's on 1 rank, within rounding on more), and the `id` output field.
#[test]
fn the_solver_seam_runs_and_sums_over_ranks() {
    let make = || dam_break(WallTreatment::Nodes, VolumeUpdate::default());
    let mut one = make();
    one.run_until(0.05).unwrap();
    let want = one.diagnostics();
    for ranks in 1..=3 {
        let got = run_ranks(ranks, 1, |comm| {
            let mut d = DistributedExplicit::new(comm, make(), 7).unwrap();
            let run: &mut dyn Solver<2> = &mut d;
            run.run_until(0.05).unwrap();
            let ids = run.output(mpm_dist::ID);
            let n = run.particles().len();
            (run.diagnostics(), ids, n, run.time())
        });
        let mut seen = Vec::new();
        for (diag, ids, n, time) in got {
            assert_eq!(time.to_bits(), one.time().to_bits());
            let close = |a: Real, b: Real| (a - b).abs() <= 1e-12 * b.abs().max(1e-3);
            assert!(close(diag.mass, want.mass), "{ranks} ranks: mass");
            assert!(close(diag.kinetic_energy, want.kinetic_energy));
            assert!(close(diag.elastic_energy, want.elastic_energy));
            assert!(close(diag.potential_energy, want.potential_energy));
            assert!(close(diag.momentum.y, want.momentum.y));
            if ranks == 1 {
                assert_eq!(diag, want, "one rank sums as one process");
            }
            match &ids[0].data {
                mpm_core::ColumnData::U32 { values, .. } => {
                    assert_eq!(values.len(), n);
                    seen.extend(values.iter().copied());
                }
                other => panic!("ids are u32: {other:?}"),
            }
        }
        seen.sort_unstable();
        assert_eq!(seen, (0..one.particles().len() as u32).collect::<Vec<_>>());
    }
}
