//! A 2D cantilever sagging under its own weight, with implicit (backward Euler) TLMPM: a 1 m ×
//! 0.1 m beam clamped at x = 0, E = 10⁸ Pa. Backward Euler damps the swing, so the tip settles
//! near the static Euler–Bernoulli deflection `δ = 3 ρ g L⁴ / (2 E h²)`, which it prints beside.
//!
//! Run with `cargo run --release -p mpm-tlmpm --example cantilever`.

use mpm_core::prelude::*;
use mpm_tlmpm::{FixedRegion, ImplicitParams, ImplicitTlmpm, TlmpmParams};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (length, height, rho, young, g) = (1.0, 0.1, 1000.0, 1e8, 9.81);
    // The reference grid (m): 4 cells through the thickness, room below for the sag.
    let spec = GridSpec::<2>::covering(
        Vector::<2>::new(-0.1, -0.3),
        Vector::<2>::new(1.2, 0.4),
        0.025,
    );
    let materials = vec![Material::neo_hookean(rho, young, 0.3)];
    let beam = Body::new(Shape::cuboid([0.0, 0.0], [length, height]), 0).lattice(2);
    let particles = ParticlesBuilder::new(&spec, &materials)
        .with(&beam)?
        .build();
    let tip = (0..particles.len())
        .max_by(|&a, &b| particles.x[a].x.total_cmp(&particles.x[b].x))
        .expect("a beam has particles");
    let y0 = particles.x[tip].y;
    let params = TlmpmParams {
        step: StepControl {
            gravity: Vector::<2>::new(0.0, -g),
            time_step: TimeStepPolicy::Fixed { dt: 5e-3 },
            ..StepControl::default()
        },
        // Every grid node at X ≤ 0 held at rest.
        fixed: vec![FixedRegion::clamp(
            Vector::<2>::new(-1.0, -1.0),
            Vector::<2>::new(0.0, 1.0),
        )],
        ..TlmpmParams::default()
    };
    let mut solver = ImplicitTlmpm::new(
        spec,
        params,
        ImplicitParams::default(),
        materials,
        particles,
    )?;

    println!(
        "cantilever: {} particles, dt = 5 ms (implicit)",
        solver.particles().len()
    );
    let mut newton = 0;
    for k in 1..=10 {
        let run = mpm_core::run_until_with(&mut solver, 0.1 * k as f64, |s, _| {
            newton += s.last_newton().iterations;
        })?;
        let sag = y0 - solver.particles().x[tip].y;
        println!(
            "t = {:.1} s: tip sag {sag:.5} m ({} steps)",
            solver.time(),
            run.steps
        );
    }
    let static_sag = 1.5 * rho * g * length.powi(4) / (young * height * height);
    let steps = solver.steps() as f64;
    println!(
        "Euler–Bernoulli static sag {static_sag:.5} m; {:.2} Newton iterations per step",
        f64::from(newton) / steps
    );
    Ok(())
}
