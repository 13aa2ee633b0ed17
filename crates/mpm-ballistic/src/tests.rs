//! Exact flight, bounce heights, energy bookkeeping, rest after endless bounces, restart.

use crate::{fly, Ballistic, BallisticParams, DISSIPATED_ENERGY};
use approx::assert_relative_eq;
use mpm_core::prelude::*;

const G: f64 = -9.81;

/// One 1 kg particle at `x0` (m) with velocity `v0` (m/s) in the unit box.
fn one(x0: [f64; 2], v0: [f64; 2], e: f64, dt: Option<f64>) -> Ballistic<2> {
    let spec = GridSpec::<2>::covering(Vector::<2>::zeros(), Vector::<2>::new(1.0, 1.0), 0.1);
    let mut particles = Particles::<2>::new(Columns::default());
    particles.push(mpm_core::ParticleInit {
        x: Vector::<2>::from(x0),
        v: Vector::<2>::from(v0),
        mass: 1.0,
        volume0: 1e-3,
        material: 0,
        affine: Matrix::<2>::zeros(),
    });
    let mut params = BallisticParams {
        restitution: e,
        ..BallisticParams::default()
    };
    if let Some(dt) = dt {
        params.step.time_step = TimeStepPolicy::Fixed { dt };
    }
    let materials = vec![Material::fluid(1000.0, 2e5, 0.0)];
    Ballistic::new(spec, params, materials, particles).expect("a valid set-up")
}

#[test]
fn flight_before_the_first_hit_is_the_parabola() {
    let (x0, v0) = (0.3, 2.0);
    let mut s = one([0.5, x0], [0.0, v0], 1.0, Some(0.01));
    s.run_until(0.2).unwrap();
    let t = s.time();
    let exact = x0 + v0 * t + 0.5 * G * t * t;
    assert_relative_eq!(s.particles().x[0].y, exact, max_relative = 1e-14);
    assert_relative_eq!(s.particles().v[0].y, v0 + G * t, max_relative = 1e-14);
}

#[test]
fn an_elastic_bounce_returns_to_the_release_height_and_keeps_the_energy() {
    // Released at rest from h = 0.8 m: back at h after the period 2 √(2h/|g|), for a step that
    // does not divide the period.
    let h = 0.8;
    let period = 2.0 * (2.0 * h / -G).sqrt();
    let mut s = one([0.5, h], [0.0, 0.0], 1.0, Some(0.0137));
    let e0 = s.diagnostics().total_energy();
    let mut worst: f64 = 0.0;
    for k in 1..=5 {
        let (mut x, mut v) = (h, 0.0);
        let lost = fly(&mut x, &mut v, (G, 0.0, 1.0, 1.0), 1.0, k as f64 * period);
        assert_relative_eq!(x, h, max_relative = 1e-12);
        assert!(
            v.abs() < 1e-12 && lost == 0.0,
            "after {k} periods: v = {v}, lost {lost}"
        );
    }
    while s.time() < 5.0 * period {
        s.step().unwrap();
        worst = worst.max((s.diagnostics().total_energy() - e0).abs() / e0);
    }
    assert!(
        worst < 1e-13,
        "relative energy drift {worst:e} over five bounces"
    );
}

#[test]
fn a_bounce_with_restitution_reaches_e_squared_of_the_height_and_books_the_loss() {
    let (h, e) = (0.8, 0.5);
    let (mut x, mut v) = (h, 0.0);
    // First hit at t1 = √(2h/|g|) at speed √(2|g|h), then up to e² h at t1 + e v1/|g|.
    let t1 = (2.0 * h / -G).sqrt();
    let v1 = (2.0 * -G * h).sqrt();
    let lost = fly(&mut x, &mut v, (G, 0.0, 1.0, e), 2.0, t1 + e * v1 / -G);
    assert_relative_eq!(x, e * e * h, max_relative = 1e-12);
    assert!(v.abs() < 1e-12, "at the apex v = {v}");
    assert_relative_eq!(lost, 2.0 * -G * h * (1.0 - e * e), max_relative = 1e-12);

    // Through the solver: kinetic + potential + dissipated stays constant, and the term is
    // reported under its declared name.
    let mut s = one([0.5, h], [0.3, 0.0], e, None);
    let e0 = s.diagnostics().total_energy();
    s.run_until(1.5).unwrap();
    let d = s.diagnostics();
    assert!(
        d.energy(DISSIPATED_ENERGY) > 0.5 * -G * h,
        "dissipated {}",
        d.energy(DISSIPATED_ENERGY)
    );
    assert_relative_eq!(d.total_energy(), e0, max_relative = 1e-12);
}

#[test]
fn endless_bounces_end_at_rest_with_all_the_energy_dissipated() {
    // With e = 0.5 the hops stop after 3 t1 (a geometric series); the particle then rests.
    let h = 0.5;
    let (mut x, mut v) = (h, 0.0);
    let lost = fly(&mut x, &mut v, (G, 0.0, 1.0, 0.5), 1.0, 10.0);
    assert_eq!((x, v), (0.0, 0.0));
    assert_relative_eq!(lost, -G * h, max_relative = 1e-9);
}

#[test]
fn a_restored_checkpoint_continues_bitwise() {
    let mut a = one([0.2, 0.7], [1.3, 0.4], 0.8, None);
    a.run_until(0.5).unwrap();
    let saved = a.checkpoint();
    a.run_until(2.0).unwrap();
    let mut b = one([0.9, 0.1], [0.0, 0.0], 0.8, None);
    b.restore(&saved).unwrap();
    b.run_until(2.0).unwrap();
    assert_eq!(a.particles(), b.particles());
    assert_eq!(a.steps(), b.steps());
    assert_eq!(a.dissipated().to_bits(), b.dissipated().to_bits());
}

#[test]
fn a_restitution_outside_zero_to_one_is_refused() {
    let spec = GridSpec::<2>::covering(Vector::<2>::zeros(), Vector::<2>::new(1.0, 1.0), 0.1);
    let params = BallisticParams {
        restitution: 1.5,
        ..BallisticParams::default()
    };
    let err = Ballistic::new(spec, params, Vec::new(), Particles::new(Columns::default()));
    assert!(
        matches!(err, Err(mpm_core::SetupError::InvalidParameter { name, value, .. })
            if name == crate::parameters::RESTITUTION && value == 1.5),
        "{err:?}"
    );
}
