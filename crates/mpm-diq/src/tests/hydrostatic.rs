//! Water at rest: the 2D and 3D hydrostatic columns, the instability of the particle
//! quadrature of `G^f`, and still water around a submerged box collider.

use super::*;

#[test]
fn hydrostatic_column_stays_at_rest_with_linear_pressure() {
    let (n, h, g) = (32, 0.5, 9.81);
    let mut fluid = column(n, h, PressureMethod::IncompleteCholesky);
    let mut t = 0.0;
    while t < 1.0 - 1e-12 {
        let info = fluid.step().unwrap();
        t = info.time;
        assert_eq!(info.solves[0].name, "pressure");
        assert!(info.solves[0].residual <= 1e-8);
    }
    let ps = fluid.particles();
    let vmax = ps.v.iter().map(|v| v.norm()).fold(0.0, Real::max);
    assert!(vmax < 1e-6 * (g * h).sqrt(), "spurious velocity {vmax:e}");
    // Pressure of each particle's cell against ρ g (h − y_cell) below the surface cell.
    let dx = 1.0 / n as Real;
    let mut worst: Real = 0.0;
    for (x, p) in ps.x.iter().zip(fluid.particle_pressure()) {
        let yc = ((x[1] / dx).floor() + 0.5) * dx;
        if yc < h - dx {
            worst = worst.max((p - RHO * g * (h - yc)).abs());
        }
    }
    assert!(worst < 0.02 * RHO * g * h, "hydrostatic error {worst} Pa");
}

#[test]
fn three_dimensional_column_is_hydrostatic() {
    let n = 8;
    let dx = 1.0 / n as Real;
    let h = 0.5;
    let spec = grid([n, n, n], dx);
    let mut fluid = DiqFluid::new(
        spec,
        params::<3>(2e-2, true),
        vec![water()],
        walls(),
        block(&spec, [0.0, 0.0, 0.0], [1.0, 1.0, h], |_| {
            Vector::<3>::zeros()
        }),
    )
    .unwrap();
    for _ in 0..20 {
        fluid.step().unwrap();
    }
    let vmax = fluid
        .particles()
        .v
        .iter()
        .map(|v| v.norm())
        .fold(0.0, Real::max);
    assert!(
        vmax < 1e-6 * (9.81 * h).sqrt(),
        "spurious velocity {vmax:e}"
    );
    let bottom = fluid
        .particles()
        .x
        .iter()
        .zip(fluid.particle_pressure())
        .filter(|(x, _)| x[2] < dx)
        .map(|(_, p)| *p)
        .fold(0.0, Real::max);
    let exact = RHO * 9.81 * (h - 0.5 * dx);
    assert!((bottom - exact).abs() < 0.02 * exact, "{bottom} vs {exact}");
}

#[test]
fn particle_quadrature_of_the_gradient_destabilises_a_column_at_rest() {
    // The reason for the cell-centre default: with G^f by particle quadrature, round-off in a
    // column at rest grows exponentially (about 57 s⁻¹ at Δx = 1/32 m), while the cell-centre
    // rule keeps it at rest (see `hydrostatic_column_stays_at_rest_with_linear_pressure`).
    let n = 32;
    let dx = 1.0 / n as Real;
    let mut p = params::<2>(1e-2, false);
    p.gradient_quadrature = crate::GradientQuadrature::Particles;
    let spec = grid([n, n], dx);
    let mut fluid = DiqFluid::new(
        spec,
        p,
        vec![water()],
        walls(),
        block(&spec, [0.0, 0.0], [1.0, 0.5], |_| Vector::<2>::zeros()),
    )
    .unwrap();
    while fluid.time() < 0.6 {
        fluid.step().unwrap();
    }
    let vmax = fluid
        .particles()
        .v
        .iter()
        .map(|v| v.norm())
        .fold(0.0, Real::max);
    assert!(vmax > 1e-3, "max speed {vmax:e} m/s after 0.6 s");
}

#[test]
fn water_at_rest_stays_at_rest_around_a_submerged_box_collider() {
    // A fixed box whose faces lie on cell faces, 0.125 m under the surface of 0.5 m of water
    // (Δx = 1/32 m). Two defects made this water flow: samples exactly h/2 from a face fell
    // out of the quadrature band by round-off, and each corner node had one boundary pressure
    // for two faces. Before: 3.3 m/s after 1 s; after, round-off.
    use mpm_core::boundary::{Collider, ColliderShape};
    let n = 32;
    let dx = 1.0 / n as Real;
    let (lo, hi) = (
        Vector::<2>::new(0.375, 0.125),
        Vector::<2>::new(0.625, 0.375),
    );
    let mut b = walls::<2>();
    b.colliders.push(Collider {
        shape: ColliderShape::Box { min: lo, max: hi },
        contact: Contact::default(),
        velocity: Vector::<2>::zeros(),
    });
    let spec = grid([n, n], dx);
    // The water outside the box.
    let water_body = body(&spec, [0.0, 0.0], [1.0, 0.5])
        .keep(move |x| !(0..2).all(|a| x[a] > lo[a] && x[a] < hi[a]));
    let ps = particles(&spec, &water_body);
    let mut f = DiqFluid::new(spec, params::<2>(5e-3, true), vec![water()], b, ps).unwrap();
    while f.time() < 0.5 {
        f.step().unwrap();
    }
    let vmax = f
        .particles()
        .v
        .iter()
        .map(|v| v.norm())
        .fold(0.0, Real::max);
    // 1e-6·√(g H) = 2.2e-6 m/s, the bound of the hydrostatic validation case.
    assert!(vmax < 2.2e-6, "max |v| = {vmax:e} m/s after 0.5 s");
}
