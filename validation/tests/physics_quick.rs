//! The quick subset of the validation (DESIGN §8): each case at small sizes, asserting the physics.
//! Bounds were measured (numbers in the comments) and given a margin.

use mpm_validation::cases::{bar, disk, hydrostatic, mms};
use mpm_validation::report::{decreases_under_refinement, Outcome};
use mpm_validation::stability::{bar_run, disk_run};

#[test]
fn mms_2d_error_falls_under_refinement() {
    let cfg = mms::MmsConfig::default();
    let runs: Vec<_> = [8, 16, 32]
        .iter()
        .map(|&n| mms::run::<2>(&cfg, n).unwrap())
        .collect();
    let errors: Vec<f64> = runs.iter().map(|r| r.error).collect();
    assert!(decreases_under_refinement(&runs), "errors {errors:?}");
    // Measured 1.55e-3, 7.54e-4, 3.80e-4 (m): first order, each halving ≈ 0.5.
    for w in errors.windows(2) {
        assert!(w[1] < 0.6 * w[0], "errors {errors:?}");
    }
    assert!(errors[2] < 5e-4, "errors {errors:?}");
}

#[test]
fn bar_period_error_is_small() {
    let run = bar::run(&bar::BarConfig::default(), 32).unwrap();
    let pe = run.extra["period_error"];
    // Measured 0.57% period error and 7.0% v_cm error at Δx = 1/32.
    assert!(pe < 0.01, "period error {pe}");
    assert!(run.error < 0.1, "v_cm error {}", run.error);
    assert_eq!(run.extra["zero_crossings"], 4.0);
}

#[test]
fn spinning_disk_conserves_angular_momentum() {
    // Δx = 1/16 (dyadic) measured 1.2e-14, Δx = 1/24 measured 4.3e-12 over one revolution.
    for n in [16, 24] {
        let run = disk::run(&disk::DiskConfig::default(), n).unwrap();
        assert!(
            run.error < disk::DRIFT_TOLERANCE,
            "1/{n}: drift {:e}",
            run.error
        );
        assert!(run.extra["energy_drift_max"] < 0.01);
    }
}

/// The bottom pressure extrapolated from the column's interior converges (measured relative
/// errors 1.2e-3 at Δx = 1/24, 3.8e-4 at 1/128), the near-floor particle rows keep their
/// kernel-truncation error (≈ +9% of ρ₀gH in the first cell, reported, not hidden), and the
/// column stays at rest.
#[test]
fn hydrostatic_bottom_pressure_error_falls() {
    let cfg = hydrostatic::HydroConfig::default();
    let runs: Vec<_> = [24, 128]
        .iter()
        .map(|&n| hydrostatic::run(&cfg, n).unwrap())
        .collect();
    let errors: Vec<f64> = runs.iter().map(|r| r.error).collect();
    assert!(hydrostatic::falls_overall(&runs), "errors {errors:?}");
    assert!(errors[1] < 5e-4, "errors {errors:?}");
    for r in &runs {
        let row0 = r.extra["row0_error_signed"];
        assert!(row0 > 0.05 && row0 < 0.12, "near-floor row error {row0}");
        assert!(r.extra["max_speed_second_half_m_s"] < 0.05);
    }
}

#[test]
fn stability_subset_never_blows_up() {
    let bar_base = bar::BarConfig {
        periods: 3.0,
        ..bar::BarConfig::default()
    };
    let disk_base = disk::DiskConfig {
        length: disk::Length::WaveCrossings(20.0),
        ..disk::DiskConfig::default()
    };
    let mut outcomes = Vec::new();
    for youngs in [1e4, 1e9] {
        let cfg = bar::BarConfig { youngs, ..bar_base };
        outcomes.push((format!("bar E={youngs:e}"), bar_run(&cfg, 16).unwrap()));
        let cfg = disk::DiskConfig {
            youngs,
            ..disk_base
        };
        outcomes.push((format!("disk E={youngs:e}"), disk_run(&cfg, 16).unwrap()));
    }
    for cfl in [0.1, 1.2] {
        let cfg = bar::BarConfig { cfl, ..bar_base };
        outcomes.push((format!("bar cfl={cfl}"), bar_run(&cfg, 16).unwrap()));
        let cfg = disk::DiskConfig { cfl, ..disk_base };
        outcomes.push((format!("disk cfl={cfl}"), disk_run(&cfg, 16).unwrap()));
    }
    for (name, (outcome, detail)) in &outcomes {
        assert_ne!(*outcome, Outcome::BlewUp, "{name}: {detail}");
        // All of these were measured stable.
        assert_eq!(*outcome, Outcome::Stable, "{name}: {detail}");
    }
    // Far beyond the explicit limit the solver stops with an Instability instead of running on.
    let cfg = bar::BarConfig {
        cfl: 2.0,
        ..bar_base
    };
    let (outcome, detail) = bar_run(&cfg, 16).unwrap();
    assert_eq!(outcome, Outcome::Stopped, "{detail}");
    assert!(detail.contains("instability at step"), "{detail}");
}
