//! Nodal loads and surface tractions: the momentum they put into a free body, step by step,
//! and the static elongation of a bar pulled by end tractions.

mod common;

use common::{block, grid_around, momentum, solid};
use mpm_core::material::{ElasticModel, Lame};
use mpm_core::quasistatic::GravityRamp;
use mpm_core::Solver as _;
use mpm_core::{Particles, Real, StepControl, TimeStepPolicy, Vector};
use mpm_tlmpm::{
    ExplicitTlmpm, FixedRegion, ImplicitParams, ImplicitTlmpm, LinearSolver, NewtonParams,
    NodalLoad, NodeSelection, SurfaceTraction, TlmpmParams,
};

type V2 = Vector<2>;

/// Linear elasticity with ν = 0: uniaxial stress with modulus E and no lateral contraction.
fn uniaxial(e: Real, rho: Real) -> mpm_core::Material {
    solid(
        ElasticModel::LinearElastic(Lame::from_young_poisson(e, 0.0)),
        rho,
    )
}

/// Newton solved to round-off, with the sparse Cholesky solve.
fn tight() -> ImplicitParams {
    ImplicitParams {
        newton: NewtonParams {
            rel_tol: 1e-13,
            abs_tol: 1e-14,
            ..NewtonParams::default()
        },
        linear: LinearSolver::Cholesky,
        ..ImplicitParams::default()
    }
}

/// A free 0.5 m × 0.1 m block (no gravity, no contact, no fixed node) with a nodal load on
/// the nodes around its right end (ramped over five steps when `ramped`), another on the node
/// nearest a point at its left end, and a traction on its right face, run ten steps. Returns the largest relative error of a step's momentum gain
/// against the total applied force times dt, and the particles at the end.
/// The traction's total is `t · H` exactly: the face x = 0.5 m lies on a lattice plane, so
/// its one layer of H/h surface particles carries h each.
fn loaded_free_block(implicit: bool, ramped: bool) -> (Real, Particles<2>) {
    let (dx, rho, e) = (0.05, 1000.0, 1e5);
    let (len, height) = (0.5, 0.1);
    let bounds = (V2::zeros(), V2::new(len, height));
    let dt = 1e-3;
    let force = V2::new(0.0, -30.0);
    let pull = V2::new(-5.0, 0.0);
    let traction = V2::new(2000.0, 500.0);
    let ramp = ramped.then_some(GravityRamp { duration: 5.0 * dt });
    let params = TlmpmParams {
        step: StepControl {
            time_step: TimeStepPolicy::Fixed { dt },
            ..StepControl::default()
        },
        nodal_loads: vec![
            NodalLoad {
                nodes: NodeSelection::Box {
                    min: V2::new(len - 0.01, -1.0),
                    max: V2::new(1.0, 1.0),
                },
                force,
                ramp,
            },
            NodalLoad {
                nodes: NodeSelection::Point(V2::new(0.01, 0.04)),
                force: pull,
                ramp: None,
            },
        ],
        tractions: vec![SurfaceTraction {
            min: V2::new(len - 0.02, -1.0),
            max: V2::new(1.0, 1.0),
            traction,
            ramp: None,
        }],
        ..TlmpmParams::default()
    };
    let particles = block(&grid_around(bounds, dx, 3), bounds, dx / 2.0, rho, |_| {
        V2::zeros()
    });
    let spec = grid_around(bounds, dx, 3);
    let materials = vec![uniaxial(e, rho)];
    let total = |t: Real| {
        let f = ramp.map_or(1.0, |r| (t / r.duration).min(1.0));
        force * f + pull + traction * height
    };
    let mut worst: Real = 0.0;
    let mut record = |p0: V2, p1: V2, t: Real| {
        let gain = (p1 - p0) / dt;
        worst = worst.max((gain - total(t)).norm() / total(1.0).norm());
    };
    let end = if implicit {
        let mut s = ImplicitTlmpm::new(spec, params, tight(), materials, particles).unwrap();
        for _ in 0..10 {
            let (p0, t) = (momentum(s.particles()), s.time());
            s.step().unwrap();
            record(p0, momentum(s.particles()), t);
        }
        s.particles().clone()
    } else {
        let mut s = ExplicitTlmpm::new(spec, params, materials, particles).unwrap();
        for _ in 0..10 {
            let (p0, t) = (momentum(s.particles()), s.time());
            s.step().unwrap();
            record(p0, momentum(s.particles()), t);
        }
        s.particles().clone()
    };
    (worst, end)
}

/// The momentum gain of every step is the total applied force times dt: exactly (to
/// round-off) with the explicit integrator, to Newton's tolerance with the implicit one.
#[test]
fn momentum_gains_the_applied_force_times_dt_in_a_free_body() {
    for implicit in [false, true] {
        for ramped in [false, true] {
            let (worst, _) = loaded_free_block(implicit, ramped);
            // Measured: below 10⁻¹⁴ for both integrators (Newton's residual, solved to
            // round-off here, bounds the implicit one).
            let tol = if implicit { 1e-11 } else { 1e-12 };
            assert!(
                worst < tol,
                "implicit = {implicit}, ramped = {ramped}: relative error {worst:e}"
            );
        }
    }
}

#[test]
fn loaded_results_are_bitwise_identical_for_1_and_4_threads() {
    let run = |threads: usize, implicit: bool| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| loaded_free_block(implicit, true).1)
    };
    for implicit in [false, true] {
        let one = run(1, implicit);
        assert!(
            one.v.iter().any(|v| v.norm() > 0.0),
            "the loads moved the block"
        );
        assert_eq!(one, run(4, implicit), "implicit: {implicit}");
    }
}

/// A 1 m × 0.1 m bar (E = 10⁷ Pa, ν = 0) pulled by tractions ±σ = ±10⁴ Pa on its end faces,
/// implicit TLMPM with dt = 10 s (quasi-static backward Euler). Uniaxial stress σ everywhere:
/// the strain is σ/E = 10⁻³ and the bar lengthens by σL/E = 1 mm, measured from the particle
/// columns next to the two ends (h/2 inside the faces).
/// The relative error of the bar's elongation at grid spacing `dx` (m).
fn bar_elongation_error(dx: Real) -> Real {
    let (rho, e, sigma) = (1000.0, 1e7, 1e4);
    let (len, height) = (1.0, 0.1);
    let bounds = (V2::zeros(), V2::new(len, height));
    let h = dx / 2.0;
    let end = |lo: Real, hi: Real, sign: Real| SurfaceTraction {
        min: V2::new(lo, -1.0),
        max: V2::new(hi, 1.0),
        traction: V2::new(sign * sigma, 0.0),
        ramp: None,
    };
    // The rigid modes, which only the tiny inertia term m/dt² would hold, are removed without
    // touching the exact solution: no node moves laterally (ν = 0), and the nodes on the
    // symmetry plane X = L/2 stay put along the bar.
    let all = V2::from_element(10.0);
    let roller = |min: V2, max: V2, axis: usize| FixedRegion {
        min,
        max,
        axes: [axis == 0, axis == 1],
        velocity: V2::zeros(),
    };
    let params = TlmpmParams {
        step: StepControl {
            time_step: TimeStepPolicy::Fixed { dt: 10.0 },
            ..StepControl::default()
        },
        fixed: vec![
            roller(-all, all, 1),
            roller(V2::new(0.5 * len, -10.0), V2::new(0.5 * len, 10.0), 0),
        ],
        tractions: vec![end(-1.0, 0.5 * h, -1.0), end(len - 0.5 * h, 2.0, 1.0)],
        ..TlmpmParams::default()
    };
    let particles = block(&grid_around(bounds, dx, 3), bounds, h, rho, |_| V2::zeros());
    let mut s = ImplicitTlmpm::new(
        grid_around(bounds, dx, 3),
        params,
        tight(),
        vec![uniaxial(e, rho)],
        particles,
    )
    .unwrap();
    for _ in 0..3 {
        s.step().unwrap();
    }
    let x = &s.particles().x;
    let x0 = s.reference().positions();
    let mean = |pick: &dyn Fn(Real) -> bool, of: &dyn Fn(usize) -> Real| {
        let ids: Vec<usize> = (0..x0.len()).filter(|&p| pick(x0[p][0])).collect();
        ids.iter().map(|&p| of(p)).sum::<Real>() / ids.len() as Real
    };
    let left = |x: Real| x < h;
    let right = |x: Real| x > len - h;
    let span0 = mean(&right, &|p| x0[p][0]) - mean(&left, &|p| x0[p][0]);
    let span = mean(&right, &|p| x[p][0]) - mean(&left, &|p| x[p][0]);
    // The whole bar's elongation, from the end columns h/2 inside the faces at uniform strain.
    let elongation = (span - span0) * len / span0;
    let exact = sigma * len / e;
    (elongation - exact).abs() / exact
}

#[test]
fn a_bar_under_end_tractions_lengthens_by_sigma_l_over_e() {
    let coarse = bar_elongation_error(0.05);
    let fine = bar_elongation_error(0.025);
    // Measured: 0.96 % at dx = 0.05 m and 0.47 % at dx = 0.025 m, first order in the
    // spacing (the load reaches the body at particles h/2 inside the faces, smeared over the
    // kernel's support).
    assert!(coarse < 0.012, "elongation error {coarse:e} at dx = 0.05 m");
    assert!(fine < 0.006, "elongation error {fine:e} at dx = 0.025 m");
    assert!(fine < 0.6 * coarse, "no convergence: {coarse:e} → {fine:e}");
}
