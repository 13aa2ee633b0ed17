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
            (ps, ids.to_vec(), d.traffic().arrived)
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
