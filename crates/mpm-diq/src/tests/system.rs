//! The assembled pressure system and its solvers: the dense Schur complement, the divergence
//! left by each solver, the free surface and the pinned gauge, solve errors, pattern reuse and
//! the residual history.

use super::*;
use crate::pressure::{PressureParams, PressureSystem, UnknownKind};
use mpm_core::StepError;

#[test]
fn assembled_matrix_is_symmetric_positive_and_equals_dense_schur_complement() {
    // A swirling 2D blob with a free surface: dense J M⁻¹ Jᵀ against the assembled matrix.
    let dx = 1.0 / 12.0;
    let spec = grid([12, 12], dx);
    let fluid = DiqFluid::new(
        spec,
        params::<2>(1e-2, false),
        vec![water()],
        walls(),
        block(&spec, [0.0, 0.0], [0.5, 0.5], |x| {
            Vector::<2>::new(-(x[1] - 0.25), x[0] - 0.25)
        }),
    )
    .unwrap();
    let ps = fluid.particles();
    let bins = fluid.bin(&ps.x);
    let nodes = fluid.transfer(crate::fluid::Points::of(ps), &bins, true);
    let (rows, _) = fluid.constraints((&ps.x, &ps.volume0), &bins, &nodes.mass, 0.0);
    assert!(rows.kinds().contains(&UnknownKind::Wall));
    assert!(
        !rows.pin_gauge(),
        "a blob with air above has a free surface"
    );
    let dt = 1e-3;
    let mut system = PressureSystem::<2>::new();
    system
        .assemble(
            &rows,
            &nodes.inv_mass,
            dt,
            &PressureParams::default(),
            &fluid.solid_cell(),
        )
        .unwrap();
    let a = system.matrix().unwrap().to_dense();
    let n = rows.len();
    // Dense J (n × 2·nodes).
    let nn = nodes.mass.len();
    let mut j = nalgebra::DMatrix::<Real>::zeros(n, 2 * nn);
    for k in 0..n {
        let (nodes_k, coeffs) = rows.row(k);
        for (node, r) in nodes_k.iter().zip(coeffs) {
            for a in 0..2 {
                j[(k, 2 * node + a)] += r[a];
            }
        }
    }
    let minv = nalgebra::DMatrix::<Real>::from_diagonal(&nalgebra::DVector::from_iterator(
        2 * nn,
        (0..2 * nn).map(|i| nodes.inv_mass[i / 2]),
    ));
    let dense = &j * minv * j.transpose() * dt;
    let scale = dense.amax();
    assert!(
        (&a - &dense).amax() <= 1e-12 * scale,
        "assembled ≠ Δt J M⁻¹ Jᵀ"
    );
    assert!(
        (&a - a.transpose()).amax() <= 1e-14 * scale,
        "not symmetric"
    );
    // Positive on random vectors, and definite: the smallest eigenvalue is positive.
    let mut seed = 7u64;
    for _ in 0..20 {
        let x = nalgebra::DVector::<Real>::from_fn(n, |_, _| {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
            (seed >> 11) as Real / (1u64 << 53) as Real - 0.5
        });
        assert!((x.transpose() * &a * &x)[(0, 0)] > 0.0);
    }
    let eig = nalgebra::SymmetricEigen::new(a.clone()).eigenvalues;
    assert!(
        eig.min() > 1e-10 * eig.max(),
        "min eigenvalue {}",
        eig.min()
    );
}

#[test]
fn projection_leaves_divergence_at_solver_tolerance() {
    for method in [
        PressureMethod::Jacobi,
        PressureMethod::IncompleteCholesky,
        PressureMethod::Multigrid,
        PressureMethod::Cholesky,
    ] {
        let dx = 1.0 / 24.0;
        let mut p = params::<2>(1e-3, false);
        p.pressure.method = method;
        let u = 1.0;
        let spec = grid([24, 24], dx);
        let mut fluid = DiqFluid::new(
            spec,
            p,
            vec![water()],
            walls(),
            block(&spec, [0.0, 0.0], [0.5, 0.5], move |x| {
                Vector::<2>::new(u * (x[1] * 7.0).sin(), u * (x[0] * 5.0).cos())
            }),
        )
        .unwrap();
        for _ in 0..3 {
            let info = fluid.step().unwrap();
            assert!(info.solves[0].residual <= 1e-8, "{method:?}");
        }
        // The cell divergence relative to the flow's own scale U/Δx.
        let worst = fluid
            .particle_divergence()
            .iter()
            .fold(0.0, |m: Real, d| m.max(d.abs()));
        assert!(
            worst * dx / u < 1e-6,
            "{method:?}: divergence {worst:e} 1/s"
        );
    }
}

#[test]
fn free_surface_pressure_vanishes_and_enclosed_fluid_is_pinned() {
    let mut fluid = column(16, 0.5, PressureMethod::Multigrid);
    fluid.step().unwrap();
    // Top cell pressure is at most ρ g Δx (the surface cell's own depth), bottom ≈ ρ g h.
    let dx = 1.0 / 16.0;
    let ps = fluid.particles();
    let top =
        ps.x.iter()
            .zip(fluid.particle_pressure())
            .filter(|(x, _)| x[1] > 0.5 - dx)
            .fold(0.0, |m: Real, (_, p)| m.max(p.abs()));
    assert!(top <= RHO * 9.81 * dx, "surface cell pressure {top} Pa");
    // A box filled to the walls: no free surface, the gauge is pinned.
    let spec = grid([8, 8], 0.125);
    let full = DiqFluid::new(
        spec,
        params::<2>(1e-3, false),
        vec![water()],
        walls(),
        block(&spec, [0.0, 0.0], [1.0, 1.0], |_| Vector::<2>::zeros()),
    )
    .unwrap();
    let ps = full.particles();
    let bins = full.bin(&ps.x);
    let nodes = full.transfer(crate::fluid::Points::of(ps), &bins, false);
    let (rows, _) = full.constraints((&ps.x, &ps.volume0), &bins, &nodes.mass, 0.0);
    assert!(rows.pin_gauge());
    let ps = fluid.particles();
    let bins = fluid.bin(&ps.x);
    let nodes = fluid.transfer(crate::fluid::Points::of(ps), &bins, false);
    assert!(!fluid
        .constraints((&ps.x, &ps.volume0), &bins, &nodes.mass, 0.0)
        .0
        .pin_gauge());
}

#[test]
fn capped_cg_is_a_typed_solve_error() {
    let dx = 1.0 / 16.0;
    let mut p = params::<2>(1e-3, false);
    p.pressure.max_iterations = 1;
    p.pressure.method = PressureMethod::Jacobi;
    let spec = grid([16, 16], dx);
    let mut fluid = DiqFluid::new(
        spec,
        p,
        vec![water()],
        walls(),
        block(&spec, [0.0, 0.0], [0.5, 0.5], |_| Vector::<2>::zeros()),
    )
    .unwrap();
    let x0 = fluid.particles().x.clone();
    match fluid.step() {
        Err(StepError::Solve { stage, source, .. }) => {
            assert_eq!(stage, mpm_core::Stage::SOLVE);
            assert!(source.to_string().contains("did not converge"), "{source}");
        }
        other => panic!("expected a solve error, got {other:?}"),
    }
    assert_eq!(fluid.particles().x, x0, "a failed step changes nothing");
}

#[test]
fn pattern_is_reused_while_the_fluid_cells_do_not_change() {
    // A column at rest keeps its cells: every step after the first reuses the pattern.
    let mut fluid = column(16, 0.5, PressureMethod::IncompleteCholesky);
    let first = fluid.step().unwrap();
    assert!(!first.events.contains(&("pressure_pattern_reused", 1)));
    for _ in 0..3 {
        let info = fluid.step().unwrap();
        assert!(info.events.contains(&("pressure_pattern_reused", 1)));
    }
}

#[test]
fn cg_keeps_a_decreasing_residual_history_when_asked() {
    let mut fluid = column(16, 0.5, PressureMethod::Jacobi);
    let (rows, inv_mass, rhs) = fluid.projection_problem(1e-3);
    let params = PressureParams {
        method: PressureMethod::Jacobi,
        keep_history: true,
        ..PressureParams::default()
    };
    let mut system = PressureSystem::<2>::new();
    system
        .assemble(&rows, &inv_mass, 1e-3, &params, &fluid.solid_cells())
        .unwrap();
    let mut lambda = Vec::new();
    let info = system.solve(&rhs, &mut lambda, &params).unwrap();
    assert_eq!(info.history.len(), info.iterations as usize + 1);
    let first = info.history[0];
    let last = *info.history.last().unwrap();
    assert!(last <= 1e-8 * first && (last / first - info.relative_residual).abs() < 1e-12);
    // The same system again: the pattern is reused.
    system
        .assemble(&rows, &inv_mass, 1e-3, &params, &fluid.solid_cells())
        .unwrap();
    let again = system.solve(&rhs, &mut lambda, &params).unwrap();
    assert!(again.pattern_reused && !info.pattern_reused);
    fluid.step().unwrap();
}
