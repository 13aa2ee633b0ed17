//! Newton's method on large-deformation steps, linear solvers, guards and retries.

mod common;

use common::{block, fmt_residuals, grid_around, momentum, neo_hookean, Lcg};
use mpm_core::Solver as _;
use mpm_core::{
    Dim, DimOps, Instability, Matrix, OnInstability, Real, Stage, StepControl, StepError,
    TimeStepPolicy, Vector, Violation,
};
use mpm_tlmpm::{
    fitted_order, ExplicitTlmpm, ImplicitParams, ImplicitTlmpm, LinearSolver, NewtonError,
    NewtonParams, SpdProjection, TlmpmParams,
};

/// A soft Neo-Hookean block `[0.3, 0.7]^D` (Δx = 0.1, 2 particles per cell per axis) with the
/// affine initial velocity `v = A (X − c)`.
fn soft_block<const D: usize>(
    a: Matrix<D>,
    (e, dt): (Real, Real),
    implicit: ImplicitParams,
) -> ImplicitTlmpm<D>
where
    Dim<D>: DimOps<D>,
{
    let bounds = (
        Vector::<D>::from_element(0.3),
        Vector::<D>::from_element(0.7),
    );
    let c = Vector::<D>::from_element(0.5);
    let particles = block(&grid_around(bounds, 0.1, 3), bounds, 0.05, 1000.0, |x| {
        a * (x - c)
    });
    let params = TlmpmParams {
        step: StepControl {
            time_step: TimeStepPolicy::Fixed { dt },
            ..StepControl::default()
        },
        ..TlmpmParams::default()
    };
    ImplicitTlmpm::new(
        grid_around(bounds, 0.1, 3),
        params,
        implicit,
        vec![neo_hookean(e, 0.3, 1000.0)],
        particles,
    )
    .unwrap()
}

/// The residuals of the quadratic regime: from the last one above `1e-2 · r₀` down to the last
/// one above ten times the final tolerance (below that, rounding errors dominate).
fn quadratic_regime(residuals: &[Real], tolerance: Real) -> &[Real] {
    let r0 = residuals[0];
    let start = residuals.iter().rposition(|&r| r > 1e-2 * r0).unwrap_or(0);
    let end = residuals
        .iter()
        .rposition(|&r| r > 10.0 * tolerance)
        .unwrap_or(0);
    &residuals[start..=end.max(start + 2).min(residuals.len() - 1)]
}

fn check_quadratic<const D: usize>(a: Matrix<D>)
where
    Dim<D>: DimOps<D>,
{
    let implicit = ImplicitParams {
        newton: NewtonParams {
            abs_tol: 0.0,
            rel_tol: 1e-14,
            projection: SpdProjection::Never,
            // Pure Newton: every direction from a fresh f64 factorisation.
            chord: false,
            single_precision: false,
            ..NewtonParams::default()
        },
        linear: LinearSolver::Cholesky,
        ..ImplicitParams::default()
    };
    let mut solver = soft_block::<D>(a, (1e3, 0.1), implicit);
    solver.step().unwrap();
    let info = solver.last_newton().clone();
    let f = solver.particles().def_grad.as_ref().unwrap();
    let stretch = f
        .iter()
        .map(|f| Dim::<D>::svd(f).sigma)
        .fold((Real::MAX, 0.0f64), |(lo, hi), s| {
            (lo.min(s[D - 1]), hi.max(s[0]))
        });
    let r = &info.residuals;
    let regime = quadratic_regime(r, info.tolerance);
    let order = fitted_order(regime).unwrap();
    println!(
        "{D}D: principal stretches in [{:.3}, {:.3}], {} iterations, {} halvings, residuals {}, \
         fitted order {order:.3} over {}",
        stretch.0,
        stretch.1,
        info.iterations,
        info.halvings,
        fmt_residuals(r),
        fmt_residuals(regime)
    );
    assert!(stretch.0 < 0.8 && stretch.1 > 1.25, "large deformation");
    assert!(order >= 1.8, "order {order}");
    assert!(r.last().unwrap() / r[0] < 1e-10);
}

/// The velocity gradient (1/s) of the 2D large-deformation step.
fn large_2d() -> Matrix<2> {
    Matrix::<2>::new(6.0, 3.0, -1.0, -5.0)
}

/// The velocity gradient (1/s) of the 3D large-deformation step.
fn large_3d() -> Matrix<3> {
    Matrix::<3>::new(
        6.0, 3.0, 0.0, //
        -1.0, -5.0, 2.0, //
        0.5, 0.0, 4.0,
    )
}

#[test]
fn newton_converges_quadratically_on_a_large_deformation_step_2d() {
    check_quadratic::<2>(large_2d());
}

#[test]
fn newton_converges_quadratically_on_a_large_deformation_step_3d() {
    check_quadratic::<3>(large_3d());
}

/// The large-deformation step of [`check_quadratic`] with the defaults (chord iterations and
/// single-precision factorisations) against pure Newton: both meet the same tolerance and end
/// at the same positions, to well within what that tolerance allows.
fn check_chord_matches_newton<const D: usize>(a: Matrix<D>)
where
    Dim<D>: DimOps<D>,
{
    let run = |chord: bool| {
        let implicit = ImplicitParams {
            newton: NewtonParams {
                chord,
                single_precision: chord,
                ..NewtonParams::default()
            },
            ..ImplicitParams::default()
        };
        let mut solver = soft_block::<D>(a, (1e3, 0.1), implicit);
        solver.step().unwrap();
        (solver.last_newton().clone(), solver.particles().x.clone())
    };
    let (newton, x_newton) = run(false);
    let (chord, x_chord) = run(true);
    println!(
        "{D}D: Newton {} iterations, residuals {}; chord/f32 {} iterations ({} chord), residuals {}",
        newton.iterations,
        fmt_residuals(&newton.residuals),
        chord.iterations,
        chord.chord_iterations,
        fmt_residuals(&chord.residuals)
    );
    assert_eq!(newton.chord_iterations, 0);
    assert!(chord.chord_iterations > 0, "no chord iteration was taken");
    assert!(*chord.residuals.last().unwrap() <= chord.tolerance);
    let moved = x_newton
        .iter()
        .zip(&x_chord)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, Real::max);
    // Both stop at rel_tol 1e-8 of the initial residual; the step moves particles by ~0.1 m.
    assert!(moved < 1e-8, "positions differ by {moved:e} m");
}

#[test]
fn chord_and_single_precision_reach_newtons_solution_2d() {
    check_chord_matches_newton::<2>(large_2d());
}

#[test]
fn chord_and_single_precision_reach_newtons_solution_3d() {
    check_chord_matches_newton::<3>(large_3d());
}

#[test]
fn cholesky_and_cg_give_the_same_step() {
    let a = Matrix::<2>::new(3.0, 1.0, -1.0, -2.0);
    let tight = NewtonParams {
        abs_tol: 0.0,
        rel_tol: 1e-12,
        ..NewtonParams::default()
    };
    let mut chol = soft_block::<2>(
        a,
        (1e4, 0.02),
        ImplicitParams {
            newton: tight,
            linear: LinearSolver::Cholesky,
            ..ImplicitParams::default()
        },
    );
    let mut cg = soft_block::<2>(
        a,
        (1e4, 0.02),
        ImplicitParams {
            newton: tight,
            linear: LinearSolver::Cg {
                max_iterations: 500,
                rel_tol: 1e-10,
            },
            ..ImplicitParams::default()
        },
    );
    for _ in 0..3 {
        chol.step().unwrap();
        cg.step().unwrap();
        assert!(cg.last_newton().linear_iterations > 0);
    }
    let scale: Real = chol
        .particles()
        .x
        .iter()
        .zip(chol.reference().positions())
        .map(|(x, x0)| (x - x0).norm())
        .fold(0.0, Real::max);
    let diff: Real = chol
        .particles()
        .x
        .iter()
        .zip(&cg.particles().x)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, Real::max);
    println!("max displacement {scale:.3e} m, Cholesky vs CG {diff:.3e} m");
    assert!(diff < 1e-9 * scale.max(1e-3));
}

#[test]
fn linear_momentum_is_conserved_without_gravity_or_boundaries() {
    let bounds = (
        Vector::<3>::from_element(0.3),
        Vector::<3>::from_element(0.7),
    );
    let mut rng = Lcg(3);
    for linear in [
        LinearSolver::Cholesky,
        LinearSolver::Cg {
            max_iterations: 300,
            rel_tol: 1e-8,
        },
    ] {
        let particles = block(&grid_around(bounds, 0.1, 3), bounds, 0.05, 1000.0, |_| {
            rng.vector::<3>(0.5)
        });
        let implicit = ImplicitParams {
            newton: NewtonParams {
                rel_tol: 1e-10,
                ..NewtonParams::default()
            },
            linear,
            ..ImplicitParams::default()
        };
        let params = TlmpmParams {
            step: StepControl {
                time_step: TimeStepPolicy::Fixed { dt: 0.02 },
                ..StepControl::default()
            },
            ..TlmpmParams::default()
        };
        let mut solver = ImplicitTlmpm::new(
            grid_around(bounds, 0.1, 3),
            params.clone(),
            implicit,
            vec![neo_hookean(1e4, 0.3, 1000.0)],
            particles.clone(),
        )
        .unwrap();
        let scale: Real = particles
            .v
            .iter()
            .zip(&particles.mass)
            .map(|(v, m)| v.norm() * m)
            .sum();
        let p0 = momentum(&particles);
        for _ in 0..5 {
            solver.step().unwrap();
        }
        let drift = (momentum(solver.particles()) - p0).norm() / scale;
        let mut explicit = ExplicitTlmpm::new(
            grid_around(bounds, 0.1, 3),
            TlmpmParams {
                step: StepControl {
                    time_step: TimeStepPolicy::Fixed { dt: 1e-3 },
                    ..params.step
                },
                ..params
            },
            vec![neo_hookean(1e4, 0.3, 1000.0)],
            particles,
        )
        .unwrap();
        for _ in 0..100 {
            explicit.step().unwrap();
        }
        let drift_explicit = (momentum(explicit.particles()) - p0).norm() / scale;
        println!("{linear:?}: implicit momentum drift {drift:.2e}, explicit {drift_explicit:.2e} (relative to Σ m|v|)");
        assert!(drift < 1e-9, "{drift:e}");
        assert!(drift_explicit < 1e-12, "{drift_explicit:e}");
    }
}

#[test]
fn guards_and_retries() {
    // The uniaxial converging field v_x = −k (X − c)_x with k Δt = 1.5 inverts every particle in
    // one explicit step; the implicit line search never accepts an inverted state.
    let bounds = (
        Vector::<2>::from_element(0.3),
        Vector::<2>::from_element(0.7),
    );
    let c = Vector::<2>::from_element(0.5);
    let particles = block(&grid_around(bounds, 0.1, 3), bounds, 0.05, 1000.0, |x| {
        Vector::<2>::new(-150.0 * (x.x - c.x), 0.0)
    });
    let grid = grid_around(bounds, 0.1, 3);
    let materials = vec![neo_hookean(1e4, 0.3, 1000.0)];
    let abort = TlmpmParams {
        step: StepControl {
            time_step: TimeStepPolicy::Fixed { dt: 0.01 },
            ..StepControl::default()
        },
        ..TlmpmParams::default()
    };
    let mut explicit =
        ExplicitTlmpm::new(grid, abort.clone(), materials.clone(), particles.clone()).unwrap();
    let err = explicit.step().unwrap_err();
    println!("{err}");
    assert!(matches!(
        err,
        StepError::Instability(Instability {
            stage: Stage::G2P,
            violation: Violation::InvertedElement,
            retries: 0,
            ..
        })
    ));
    assert_eq!(
        explicit.particles(),
        &particles,
        "a failed step changes nothing"
    );
    let retry = TlmpmParams {
        step: StepControl {
            on_instability: OnInstability::Retry { max_retries: 4 },
            ..abort.step
        },
        ..abort.clone()
    };
    let mut explicit =
        ExplicitTlmpm::new(grid, retry, materials.clone(), particles.clone()).unwrap();
    let info = explicit.step().unwrap();
    println!(
        "explicit retried {} times, dt = {:.3e} s",
        info.retries, info.dt
    );
    assert!(info.retries >= 1 && info.dt <= 0.005);

    let mut implicit = ImplicitTlmpm::new(
        grid,
        abort.clone(),
        ImplicitParams::default(),
        materials.clone(),
        particles.clone(),
    )
    .unwrap();
    implicit.step().unwrap();
    let newton = implicit.last_newton();
    let min_j = implicit
        .particles()
        .def_grad
        .as_ref()
        .unwrap()
        .iter()
        .map(|f| f.determinant())
        .fold(Real::MAX, Real::min);
    println!(
        "implicit: {} iterations, {} halvings, min J {min_j:.3}",
        newton.iterations, newton.halvings
    );
    assert!(min_j > 0.0);

    // A Newton iteration cap that cannot be met is a typed error, and dt/2 retries make the
    // step easy enough to meet it.
    let mut capped = ImplicitTlmpm::new(
        grid,
        abort.clone(),
        ImplicitParams {
            newton: NewtonParams {
                max_iterations: 1,
                ..NewtonParams::default()
            },
            linear: LinearSolver::Cholesky,
            ..ImplicitParams::default()
        },
        materials.clone(),
        particles.clone(),
    )
    .unwrap();
    let err = capped.step().unwrap_err();
    println!("{err}");
    match &err {
        StepError::Solve {
            stage: Stage::SOLVE,
            source,
            ..
        } => assert!(
            matches!(
                source.cause::<NewtonError>(),
                Some(NewtonError::NotConverged { iterations: 1, .. })
            ),
            "{source}"
        ),
        other => panic!("expected a Newton failure, got {other}"),
    }
    let mut retried = ImplicitTlmpm::new(
        grid,
        TlmpmParams {
            step: StepControl {
                on_instability: OnInstability::Retry { max_retries: 8 },
                ..abort.step
            },
            ..abort
        },
        ImplicitParams {
            newton: NewtonParams {
                max_iterations: 2,
                ..NewtonParams::default()
            },
            linear: LinearSolver::Cholesky,
            ..ImplicitParams::default()
        },
        materials,
        particles,
    )
    .unwrap();
    let info = retried.step().unwrap();
    println!(
        "implicit with 2 Newton iterations: {} retries, dt = {:.3e} s, residuals {}",
        info.retries,
        info.dt,
        fmt_residuals(&retried.last_newton().residuals)
    );
    assert!(info.retries >= 1 && retried.last_newton().iterations <= 2);
}

#[test]
fn a_gigapascal_block_falls_under_gravity_without_a_newton_failure() {
    // E = 1e9 Pa: at rest the stresses vanish but their rounding errors do not; the internal
    // forces carry ~1e-8 N of noise no iteration removes, above the 1e-10 N absolute tolerance.
    // The round-off floor counts the stiffness (Constitutive::stress_scales); before it, the
    // first step failed with NotConverged at residual 1.8e-8 N.
    let bounds = (
        Vector::<2>::from_element(0.3),
        Vector::<2>::from_element(0.7),
    );
    let params = TlmpmParams {
        step: StepControl {
            time_step: TimeStepPolicy::Fixed { dt: 5e-3 },
            gravity: Vector::<2>::new(0.0, -9.81),
            ..StepControl::default()
        },
        ..TlmpmParams::default()
    };
    let mut s = ImplicitTlmpm::new(
        grid_around(bounds, 0.1, 3),
        params,
        ImplicitParams::default(),
        vec![neo_hookean(1e9, 0.3, 1000.0)],
        block(&grid_around(bounds, 0.1, 3), bounds, 0.05, 1000.0, |_| {
            Vector::<2>::zeros()
        }),
    )
    .unwrap();
    for _ in 0..10 {
        s.step().unwrap();
    }
    // A free rigid fall: every particle at −g t, and no strain above round-off.
    let t = 10.0 * 5e-3;
    let p = mpm_core::Solver::particles(&s);
    for (q, v) in p.v.iter().enumerate() {
        assert!((v.y + 9.81 * t).abs() < 1e-9, "particle {q}: vy = {}", v.y);
        let f = p.def_grad.as_ref().expect("F")[q];
        assert!((f.transpose() * f - Matrix::<2>::identity()).norm() < 1e-9);
    }
}
