//! Backward Euler against Newmark average acceleration on a linear problem: energy and order.

use super::ImplicitTlmpm;
use crate::params::{FixedRegion, ImplicitParams, TimeScheme, TlmpmParams, Transfer};
use mpm_core::material::{ElasticModel, Lame, SolidMaterial};
use mpm_core::Solver as _;
use mpm_core::{
    Columns, GridSpec, Material, Matrix, ParticleInit, Particles, Real, StepControl,
    TimeStepPolicy, Vector,
};
use std::f64::consts::PI;

/// Bar length L (m), spacing Δx (m), Young's modulus E (Pa), density ρ (kg/m²), velocity
/// amplitude v₀ (m/s).
const LEN: Real = 1.0;
const DX: Real = 1.0 / 16.0;
const YOUNGS: Real = 1e4;
const RHO: Real = 100.0;
const V0: Real = 0.01;

/// First axial period of the fixed–free bar, `4L/c` with `c = √(E/ρ)` = 10 m/s (s).
const PERIOD: Real = 4.0 * LEN / 10.0;

/// A 2D fixed–free bar `[0, L] × [0, 2Δx]`, linear elastic with ν = 0 (so the problem is exactly
/// linear: F is affine in the node displacements and ψ quadratic in F), clamped at X = 0,
/// started in `v_x = v₀ sin(π X/2L)`, with the persistent transfer (the nodes carry the state,
/// so the discrete system is `M ü + K u = 0` exactly) and a fixed step `dt` (s).
fn bar(scheme: TimeScheme, dt: Real) -> ImplicitTlmpm<2> {
    bar_of(
        scheme,
        dt,
        ElasticModel::LinearElastic(Lame::from_young_poisson(YOUNGS, 0.0)),
    )
}

/// [`bar`] with the elastic model `elastic`.
fn bar_of(scheme: TimeScheme, dt: Real, elastic: ElasticModel) -> ImplicitTlmpm<2> {
    let mut particles = Particles::new(Columns {
        deformation_gradient: true,
        ..Columns::default()
    });
    let h = DX / 2.0;
    for i in 0..(LEN / h).round() as usize {
        for j in 0..4 {
            let x = Vector::<2>::new((i as Real + 0.5) * h, (j as Real + 0.5) * h);
            particles.push(ParticleInit {
                x,
                v: Vector::<2>::new(V0 * (PI * x.x / (2.0 * LEN)).sin(), 0.0),
                mass: RHO * h * h,
                volume0: h * h,
                material: 0,
                affine: Matrix::<2>::zeros(),
            });
        }
    }
    let spec = GridSpec::covering(
        Vector::<2>::from_element(-3.0 * DX),
        Vector::<2>::new(LEN + 3.0 * DX, 5.0 * DX),
        DX,
    );
    let params = TlmpmParams {
        transfer: Transfer::Persistent,
        step: StepControl {
            time_step: TimeStepPolicy::Fixed { dt },
            ..StepControl::default()
        },
        fixed: vec![FixedRegion::clamp(
            Vector::<2>::from_element(-10.0),
            Vector::<2>::new(0.0, 10.0),
        )],
        ..TlmpmParams::default()
    };
    let material = Material::Solid(SolidMaterial {
        density: RHO,
        elastic,
        plasticity: Default::default(),
    });
    let implicit = ImplicitParams {
        scheme,
        ..ImplicitParams::default()
    };
    ImplicitTlmpm::new(spec, params, implicit, vec![material], particles).unwrap()
}

/// The discrete energy `½ Σ_i m_i |v_i|² + Σ_p V⁰_p ψ(F_p)` (J) from the persistent node
/// velocities and the particles' deformation gradients.
fn node_energy(s: &ImplicitTlmpm<2>) -> Real {
    let masses = s.core.reference.node_masses();
    let kinetic: Real = (s.core.node_velocity.iter().zip(masses))
        .map(|(v, m)| 0.5 * m * v.norm_squared())
        .sum();
    kinetic + s.diagnostics().elastic_energy
}

/// Mean x-displacement (m) of the particles in the last column (the free end).
fn tip(s: &ImplicitTlmpm<2>) -> Real {
    let (x, x0) = (&s.particles().x, s.core.reference.positions());
    let end: Vec<usize> = (0..x.len()).filter(|&p| x0[p].x > LEN - DX / 2.0).collect();
    end.iter().map(|&p| x[p].x - x0[p].x).sum::<Real>() / end.len() as Real
}

/// Runs `steps` steps of `dt` (s) and returns the tip displacement after each (m) and the node
/// energy at the end over that after the first step.
fn run(scheme: TimeScheme, dt: Real, steps: usize) -> (Vec<Real>, Real) {
    let mut s = bar(scheme, dt);
    s.step().unwrap();
    let e1 = node_energy(&s);
    let mut tips = vec![tip(&s)];
    for _ in 1..steps {
        s.step().unwrap();
        tips.push(tip(&s));
    }
    (tips, node_energy(&s) / e1)
}

#[test]
fn newmark_conserves_the_energy_of_a_linear_bar_where_backward_euler_loses_it() {
    // Ten steps per period (dt = 6.4 Δx/c, far beyond the explicit limit), 20 periods.
    let (dt, steps) = (PERIOD / 10.0, 200);
    let newmark = run(TimeScheme::Newmark, dt, steps).1;
    let euler = run(TimeScheme::BackwardEuler, dt, steps).1;
    println!(
        "energy ratio after 20 periods: Newmark 1 {:+.3e}, backward Euler {euler:.3e}",
        newmark - 1.0
    );
    assert!(
        (newmark - 1.0).abs() < 1e-8,
        "Newmark energy ratio {newmark}"
    );
    // Backward Euler multiplies the mode-1 energy by (1 + (ωΔt)²)⁻¹ per step, 1.8e-29 over the
    // 199 steps (measured: 3e-21 for all modes together).
    assert!(euler < 1e-10, "backward Euler energy ratio {euler}");
}

#[test]
fn tip_displacement_converges_at_second_order_with_newmark_and_first_with_backward_euler() {
    // Largest tip error over half a period against a run with 16× smaller steps than the
    // finest, for 80, 160 and 320 steps per period: there the fastest grid mode has ωΔt < 2, so
    // the whole discrete spectrum is in the asymptotic range (not so with 20 steps per period).
    // Measured rates: Newmark 1.80, 1.91; backward Euler 0.93, 0.98.
    let half = |scheme, n: usize| run(scheme, PERIOD / n as Real, n / 2).0;
    for (scheme, lo, hi) in [
        (TimeScheme::Newmark, 1.75, 2.2),
        (TimeScheme::BackwardEuler, 0.8, 1.2),
    ] {
        let fine = 320 * 16;
        let reference = half(scheme, fine);
        let errors: Vec<Real> = [80, 160, 320]
            .iter()
            .map(|&n| {
                let stride = fine / n;
                (half(scheme, n).iter().enumerate())
                    .map(|(j, w)| (w - reference[(j + 1) * stride - 1]).abs())
                    .fold(0.0, Real::max)
            })
            .collect();
        let rates: Vec<Real> = errors.windows(2).map(|e| (e[0] / e[1]).log2()).collect();
        println!("{scheme:?}: tip errors {errors:?} m, rates {rates:?}");
        for r in rates {
            assert!((lo..=hi).contains(&r), "{scheme:?} rate {r}");
        }
    }
}

#[test]
fn chord_resolve_lands_on_newtons_solution_without_a_new_factorisation() {
    // The coupling pass of DIQ-MPM re-solves the step with a force increment. Its chord
    // iterations keep the last Cholesky factor; on a Neo-Hookean bar (ν = 0.3) pulled by
    // 4 N along its axis, spread over its nodes (about 0.3 % strain at the clamp), they must
    // reach the full Newton re-solve's velocities to a small fraction of the change the force
    // makes, without factorising. (At 40 N, 3 % strain, the chord converges at about 0.4 per
    // iteration and falls back to Newton after its 8 iterations.)
    let dt = 0.02;
    let nh = ElasticModel::NeoHookean(Lame::from_young_poisson(YOUNGS, 0.3));
    let mut chord = bar_of(TimeScheme::BackwardEuler, dt, nh);
    let mut newton = bar_of(TimeScheme::BackwardEuler, dt, nh);
    let at_chord = chord.elastic_predictor(dt).unwrap();
    let at_newton = newton.elastic_predictor(dt).unwrap();
    let start = newton.node_velocities(&at_newton);
    let delta = vec![Vector::<2>::new(4.0 / start.len() as Real, 0.0); start.len()];
    let factorised = chord.newton_times.factorization;
    chord.resolve_with_node_forces(&at_chord, &delta).unwrap();
    assert_eq!(
        chord.newton_times.factorization, factorised,
        "the chord iterations must not factorise (they fell back to Newton)"
    );
    newton.ws.objective.factored = false;
    newton.resolve_with_node_forces(&at_newton, &delta).unwrap();
    let (vc, vn) = (
        chord.node_velocities(&at_chord),
        newton.node_velocities(&at_newton),
    );
    let change = vn
        .iter()
        .zip(&start)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, Real::max);
    let gap = vc
        .iter()
        .zip(&vn)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, Real::max);
    assert!(change > 1e-3, "the force must move the bar: {change} m/s");
    assert!(
        gap <= 1e-6 * change,
        "chord and Newton differ by {gap} m/s for a change of {change} m/s"
    );
}
