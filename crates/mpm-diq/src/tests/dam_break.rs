//! Flows: the dam break's volume drift with and without the position correction, the fixed
//! step above the bound, bitwise determinism across threads and resume, and a moving collider.

use super::*;
use mpm_core::StepError;

#[test]
fn position_correction_bounds_volume_drift() {
    let run = |correction| {
        let mut f = dam_break(32, correction);
        let v0 = f.fluid_volume();
        let mut worst: Real = 0.0;
        while f.time() < 0.6 {
            f.step().unwrap();
            let d = f.fluid_volume() / v0 - 1.0;
            worst = worst.max(d.abs());
        }
        worst
    };
    let with = run(true);
    let without = run(false);
    assert!(with <= 0.01, "drift with correction {with}");
    assert!(with < without, "correction {with} vs none {without}");
}

#[test]
fn fixed_dt_above_the_bound_stops_or_is_retried_at_half_steps() {
    let dx = 1.0 / 16.0;
    let make = |policy| {
        let mut p = params::<2>(1e-2, false);
        p.step.time_step = TimeStepPolicy::Fixed { dt: 0.15 };
        p.step.on_instability = policy;
        let spec = grid([16, 16], dx);
        DiqFluid::new(
            spec,
            p,
            vec![water()],
            walls(),
            block(&spec, [0.0, 0.0], [0.4, 0.6], |_| Vector::<2>::zeros()),
        )
        .unwrap()
    };
    // g dt² = 0.22 m > Δx: the first step moves particles more than a cell.
    match make(mpm_core::OnInstability::Abort).step() {
        Err(StepError::Instability(i)) => {
            assert_eq!(i.violation, mpm_core::Violation::CflExceeded);
            assert_eq!(i.stage, mpm_core::Stage::G2P);
        }
        other => panic!("expected a CFL instability, got {other:?}"),
    }
    let mut retry = make(mpm_core::OnInstability::Retry { max_retries: 4 });
    let info = retry.step().unwrap();
    assert!(info.retries >= 1 && info.dt < 0.15, "{info:?}");
    let moved = retry
        .particles()
        .v
        .iter()
        .map(|v| v.norm() * info.dt)
        .fold(0.0, Real::max);
    assert!(moved <= dx, "moved {moved} m in one accepted step");
}

#[test]
fn bitwise_identical_across_threads_and_resume() {
    assert_bitwise_across_threads_and_resume(|| dam_break(24, true), 15);
}

#[test]
fn a_moving_collider_pushes_the_fluid_and_resumes_bitwise() {
    use mpm_core::boundary::{Collider, ColliderShape};
    let dx = 1.0 / 24.0;
    let make = || {
        let mut b = walls::<2>();
        b.colliders.push(Collider {
            shape: ColliderShape::Sphere {
                center: Vector::<2>::new(0.75, 0.35),
                radius: 0.1,
            },
            contact: Contact::default(),
            velocity: Vector::<2>::new(-1.0, -0.5),
        });
        let spec = grid([24, 24], dx);
        DiqFluid::new(
            spec,
            params::<2>(1e-2, true),
            vec![water()],
            b,
            block(&spec, [0.0, 0.0], [1.0, 0.2], |_| Vector::<2>::zeros()),
        )
        .unwrap()
    };
    let mut f = make();
    for _ in 0..15 {
        f.step().unwrap();
    }
    let mid = f.checkpoint();
    while f.time() < 0.3 {
        f.step().unwrap();
    }
    // The disk has entered the water: no particle inside it, and the divergence stays at the
    // solver tolerance.
    let t = f.time();
    let centre = Vector::<2>::new(0.75 - t, 0.35 - 0.5 * t);
    let inside = f
        .particles()
        .x
        .iter()
        .filter(|x| (*x - centre).norm() < 0.1 - 1e-9)
        .count();
    assert_eq!(inside, 0, "particles inside the moving disk at t = {t}");
    let worst = f
        .particle_divergence()
        .iter()
        .fold(0.0, |m: Real, d| m.max(d.abs()));
    assert!(worst * dx < 1e-6, "divergence {worst:e} 1/s");
    let mut resumed = make();
    resumed.restore(&mid).unwrap();
    while resumed.time() < 0.3 {
        resumed.step().unwrap();
    }
    assert_eq!(resumed.checkpoint(), f.checkpoint());
}
