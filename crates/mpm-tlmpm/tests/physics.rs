//! Physics of the TLMPM solvers against analytic answers, and determinism.

mod common;

use common::{block, grid_around, solid, Lcg};
use mpm_core::material::{ElasticModel, Lame};
use mpm_core::quasistatic::{Damping, GravityRamp};
use mpm_core::Solver as _;
use mpm_core::{Dim, DimOps, Material, Particles, Real, StepControl, TimeStepPolicy, Vector};
use mpm_tlmpm::{
    ExplicitTlmpm, FixedRegion, ImplicitParams, ImplicitTlmpm, LinearSolver, NewtonParams,
    TimeScheme, TlmpmParams, Transfer,
};
use std::f64::consts::PI;

/// Linear elasticity with ν = 0 (λ = 0, μ = E/2): uniaxial stress has modulus E and no lateral
/// contraction in 2D and 3D, so a bar or column is exactly one-dimensional.
fn uniaxial(e: Real, rho: Real) -> Material {
    solid(
        ElasticModel::LinearElastic(Lame::from_young_poisson(e, 0.0)),
        rho,
    )
}

/// Either solver, stepped the same way.
enum Solver<const D: usize> {
    Explicit(Box<ExplicitTlmpm<D>>),
    Implicit(Box<ImplicitTlmpm<D>>),
}

impl<const D: usize> Solver<D>
where
    Dim<D>: DimOps<D>,
{
    fn new(
        implicit: Option<ImplicitParams>,
        (grid, params): (mpm_core::GridSpec<D>, TlmpmParams<D>),
        materials: Vec<Material>,
        particles: Particles<D>,
    ) -> Self {
        match implicit {
            Some(ip) => Self::Implicit(Box::new(
                ImplicitTlmpm::new(grid, params, ip, materials, particles).unwrap(),
            )),
            None => Self::Explicit(Box::new(
                ExplicitTlmpm::new(grid, params, materials, particles).unwrap(),
            )),
        }
    }

    fn step(&mut self) {
        match self {
            Self::Explicit(s) => {
                s.step().unwrap();
            }
            Self::Implicit(s) => {
                s.step().unwrap();
            }
        }
    }

    fn particles(&self) -> &Particles<D> {
        match self {
            Self::Explicit(s) => s.particles(),
            Self::Implicit(s) => s.particles(),
        }
    }

    fn time(&self) -> Real {
        match self {
            Self::Explicit(s) => s.time(),
            Self::Implicit(s) => s.time(),
        }
    }
}

/// A fixed-free bar of length L = 1 m along x (cross-section two cells, Δx = 1/32 m), clamped
/// at X = 0, started in its first axial mode `v_x = v₀ sin(π X / 2L)`. Returns the measured
/// period (s) from the zero crossings of the total x-momentum, `∝ cos(ω t)`, at `T/4` and `3T/4`,
/// and the theoretical period `4L/c`, `c = √(E/ρ)`.
fn bar_period<const D: usize>(implicit: Option<ImplicitParams>, dt: Real) -> (Real, Real)
where
    Dim<D>: DimOps<D>,
{
    let (len, dx, e, rho, v0) = (1.0, 1.0 / 32.0, 1e4, 100.0, 0.01);
    let mut hi = Vector::<D>::from_element(2.0 * dx);
    hi[0] = len;
    let bounds = (Vector::<D>::zeros(), hi);
    let particles = block(&grid_around(bounds, dx, 3), bounds, dx / 2.0, rho, |x| {
        let mut v = Vector::<D>::zeros();
        v[0] = v0 * (PI * x[0] / (2.0 * len)).sin();
        v
    });
    let mut clamp_hi = Vector::<D>::from_element(10.0);
    clamp_hi[0] = 0.0;
    let params = TlmpmParams {
        step: StepControl {
            time_step: TimeStepPolicy::Fixed { dt },
            ..StepControl::default()
        },
        fixed: vec![FixedRegion::clamp(
            Vector::<D>::from_element(-10.0),
            clamp_hi,
        )],
        ..TlmpmParams::default()
    };
    let mut solver = Solver::new(
        implicit,
        (grid_around(bounds, dx, 3), params),
        vec![uniaxial(e, rho)],
        particles,
    );
    let theory = 4.0 * len / (e / rho).sqrt();
    let momentum = |s: &Solver<D>| -> Real {
        let p = s.particles();
        p.v.iter().zip(&p.mass).map(|(v, m)| v[0] * m).sum()
    };
    let mut crossings = Vec::new();
    let (mut t_prev, mut p_prev) = (0.0, momentum(&solver));
    while crossings.len() < 2 && solver.time() < 1.2 * theory {
        solver.step();
        let (t, p) = (solver.time(), momentum(&solver));
        if p.signum() != p_prev.signum() {
            crossings.push(t_prev + (t - t_prev) * p_prev / (p_prev - p));
        }
        (t_prev, p_prev) = (t, p);
    }
    assert_eq!(crossings.len(), 2, "two zero crossings within 1.2 periods");
    (2.0 * (crossings[1] - crossings[0]), theory)
}

fn check_bar<const D: usize>(implicit: Option<ImplicitParams>, dt: Real) -> Real
where
    Dim<D>: DimOps<D>,
{
    let (period, theory) = bar_period::<D>(implicit, dt);
    let err = (period - theory).abs() / theory;
    println!(
        "{D}D {}: period {period:.5} s, theory {theory:.5} s, error {:.2}%",
        if implicit.is_some() {
            "implicit"
        } else {
            "explicit"
        },
        100.0 * err
    );
    err
}

#[test]
fn bar_vibration_period_explicit() {
    // c = 10 m/s, Δx = 1/32 m: dt = 0.3 Δx / c.
    assert!(check_bar::<2>(None, 0.3 / 320.0) < 0.03);
    assert!(check_bar::<3>(None, 0.3 / 320.0) < 0.03);
}

#[test]
fn bar_vibration_period_implicit() {
    // T = 0.4 s: 200 steps per period, three times the explicit CFL step.
    let implicit = Some(ImplicitParams::default());
    assert!(check_bar::<2>(implicit, 0.002) < 0.03);
    assert!(check_bar::<3>(implicit, 0.002) < 0.03);
}

/// A column `[0, W]^{D−1} × [0, L]` (L = 1 m, Δx = L/16) hanging under gravity from its clamped
/// top (nodes with Y ≥ L), solved with steps much longer than its vibration period so that the
/// backward-Euler step lands on the static state. Linear elasticity with ν = 0 gives
/// `u_y(Y) = −ρ g (L² − Y²)/(2E)`. Returns the largest error of the particle displacements
/// relative to the tip value `ρ g L²/(2E)`.
fn hanging_column<const D: usize>() -> Real
where
    Dim<D>: DimOps<D>,
{
    let (len, width, dx, e, rho, g) = (1.0, 0.25, 1.0 / 16.0, 1e7, 1000.0, 9.81);
    let up = D - 1;
    let mut hi = Vector::<D>::from_element(width);
    hi[up] = len;
    let bounds = (Vector::<D>::zeros(), hi);
    let particles = block(&grid_around(bounds, dx, 3), bounds, dx / 2.0, rho, |_| {
        Vector::<D>::zeros()
    });
    let mut gravity = Vector::<D>::zeros();
    gravity[up] = -g;
    let mut clamp_lo = Vector::<D>::from_element(-10.0);
    clamp_lo[up] = len;
    let params = TlmpmParams {
        step: StepControl {
            gravity,
            time_step: TimeStepPolicy::Fixed { dt: 10.0 },
            ..StepControl::default()
        },
        fixed: vec![FixedRegion::clamp(
            clamp_lo,
            Vector::<D>::from_element(10.0),
        )],
        ..TlmpmParams::default()
    };
    let implicit = ImplicitParams {
        newton: NewtonParams {
            rel_tol: 1e-12,
            ..NewtonParams::default()
        },
        linear: LinearSolver::Cholesky,
        ..ImplicitParams::default()
    };
    let mut solver = ImplicitTlmpm::new(
        grid_around(bounds, dx, 3),
        params,
        implicit,
        vec![uniaxial(e, rho)],
        particles,
    )
    .unwrap();
    for _ in 0..3 {
        solver.step().unwrap();
    }
    let tip = rho * g * len * len / (2.0 * e);
    let p = solver.particles();
    let mut worst: Real = 0.0;
    let mut bottom = 0.0;
    for (x, x0) in p.x.iter().zip(solver.reference().positions()) {
        let y = x0[up];
        let exact = -rho * g * (len * len - y * y) / (2.0 * e);
        worst = worst.max(((x[up] - y) - exact).abs() / tip);
        if y < dx / 2.0 {
            bottom = x[up] - y;
        }
        // No lateral motion: ν = 0.
        assert!((0..up).all(|a| (x[a] - x0[a]).abs() < 1e-6 * tip));
    }
    let speed = p.v.iter().map(|v| v.norm()).fold(0.0, Real::max);
    println!(
        "{D}D hanging column: tip displacement {bottom:.4e} m (theory −{tip:.4e} m), worst \
         particle error {:.2}% of the tip value, max speed {speed:.2e} m/s",
        100.0 * worst
    );
    assert!(speed * 10.0 < 1e-3 * tip, "static");
    worst
}

#[test]
fn hanging_column_reaches_the_static_stretch() {
    assert!(hanging_column::<2>() < 0.05);
    assert!(hanging_column::<3>() < 0.05);
}

/// A spinning, stretching Neo-Hookean block under gravity with one clamped corner region, with
/// per-particle velocity noise of amplitude `noise` (m/s).
fn spinning_block<const D: usize>(
    seed: u64,
    noise: Real,
) -> (mpm_core::GridSpec<D>, TlmpmParams<D>, Particles<D>)
where
    Dim<D>: DimOps<D>,
{
    let bounds = (
        Vector::<D>::from_element(0.3),
        Vector::<D>::from_element(0.7),
    );
    let c = Vector::<D>::from_element(0.5);
    let mut rng = Lcg(seed);
    let particles = block(&grid_around(bounds, 0.1, 3), bounds, 0.05, 1000.0, |x| {
        let d = x - c;
        let mut v = d * 0.5;
        v[0] -= 2.0 * d[1];
        v[1] += 2.0 * d[0];
        v + rng.vector::<D>(noise)
    });
    let mut gravity = Vector::<D>::zeros();
    gravity[D - 1] = -9.81;
    let params = TlmpmParams {
        step: StepControl {
            gravity,
            ..StepControl::default()
        },
        fixed: vec![FixedRegion::clamp(
            Vector::<D>::from_element(0.0),
            Vector::<D>::from_element(0.3),
        )],
        ..TlmpmParams::default()
    };
    (grid_around(bounds, 0.1, 3), params, particles)
}

#[test]
fn explicit_and_implicit_agree_for_a_small_time_step() {
    // A smooth velocity field: per-particle noise below the grid resolution would be damped by
    // each P2G/G2P round trip, i.e. by an amount set by the number of steps.
    let (grid, params, particles) = spinning_block::<2>(1, 0.0);
    let materials = vec![common::neo_hookean(1e5, 0.3, 1000.0)];
    let end = 0.05;
    let run = |implicit: Option<ImplicitParams>, transfer: Transfer, dt: Real| -> Particles<2> {
        let params = TlmpmParams {
            step: StepControl {
                time_step: TimeStepPolicy::Fixed { dt },
                ..params.step
            },
            transfer,
            ..params.clone()
        };
        let mut s = Solver::new(
            implicit,
            (grid, params),
            materials.clone(),
            particles.clone(),
        );
        for _ in 0..(end / dt).round() as usize {
            s.step();
        }
        s.particles().clone()
    };
    let reference = particles.x.clone();
    let gap = |a: &Particles<2>, b: &Particles<2>| -> Real {
        a.x.iter()
            .zip(&b.x)
            .map(|(x, y)| (x - y).norm())
            .fold(0.0, Real::max)
    };
    let implicit = Some(ImplicitParams::default());
    let mut drift = [0.0; 2];
    for (k, transfer) in [Transfer::Apic, Transfer::Persistent]
        .into_iter()
        .enumerate()
    {
        let (e1, i1) = (run(None, transfer, 1e-4), run(implicit, transfer, 1e-4));
        let (e4, i4) = (run(None, transfer, 4e-4), run(implicit, transfer, 4e-4));
        let scale =
            e1.x.iter()
                .zip(&reference)
                .map(|(x, x0)| (x - x0).norm())
                .fold(0.0, Real::max);
        let (fine, coarse) = (gap(&e1, &i1) / scale, gap(&e4, &i4) / scale);
        drift[k] = gap(&e1, &e4) / scale;
        println!(
            "{transfer:?}: max displacement {scale:.3e} m; explicit vs implicit gap / displacement \
             at dt = 1e-4 s: {fine:.2e}, at 4e-4 s: {coarse:.2e} (ratio {:.2}); explicit \
             dt = 1e-4 vs 4e-4 s: {:.2e}",
            coarse / fine,
            drift[k]
        );
        assert!(fine < 5e-3);
        // Both integrators are first order in dt: the gap shrinks linearly with dt.
        assert!((2.5..6.0).contains(&(coarse / fine)));
    }
    // Next to the clamped nodes, APIC round trips damp the motion once per step; with
    // persistent node velocities the solution converges in dt.
    assert!(drift[1] < 1e-2 && drift[0] > 10.0 * drift[1]);
}

fn run_threads<const D: usize>(threads: usize, which: usize) -> Particles<D>
where
    Dim<D>: DimOps<D>,
{
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let (grid, params, particles) = spinning_block::<D>(7, 0.05);
        let params = TlmpmParams {
            step: StepControl {
                time_step: TimeStepPolicy::Fixed {
                    dt: if matches!(which, 0 | 4) { 5e-4 } else { 5e-3 },
                },
                ..params.step
            },
            transfer: match which {
                3 | 7 => Transfer::Persistent,
                4 | 5 => Transfer::Flip { blend: 0.97 },
                _ => Transfer::Apic,
            },
            ..params
        };
        let materials = vec![common::neo_hookean(1e5, 0.3, 1000.0)];
        let implicit = match which {
            0 | 4 => None,
            1 | 3 | 5 => Some(ImplicitParams::default()),
            6 | 7 => Some(ImplicitParams {
                scheme: TimeScheme::Newmark,
                ..ImplicitParams::default()
            }),
            _ => Some(ImplicitParams {
                linear: LinearSolver::Cg {
                    max_iterations: 200,
                    rel_tol: 1e-8,
                },
                ..ImplicitParams::default()
            }),
        };
        let mut s = Solver::new(implicit, (grid, params), materials, particles);
        for _ in 0..5 {
            s.step();
        }
        s.particles().clone()
    })
}

#[test]
fn results_are_bitwise_identical_for_1_and_4_threads() {
    // 0: explicit, 1: implicit Cholesky, 2: implicit CG, 3: implicit with persistent node
    // velocities, 4 and 5: explicit and implicit with the FLIP blend, 6 and 7: Newmark with APIC
    // and with persistent node velocities.
    for which in 0..8 {
        let (one, four) = (run_threads::<3>(1, which), run_threads::<3>(4, which));
        assert_eq!(one, four, "solver variant {which}");
        let (one, four) = (run_threads::<2>(1, which), run_threads::<2>(4, which));
        assert_eq!(one, four, "solver variant {which} (2D)");
    }
}

/// A column `[0, W] × [0, L]` clamped at its top and pulled down by a total force `F` spread
/// over the particles of its bottom row, solved with one long backward-Euler step per load
/// state: linear elasticity with ν = 0 gives the uniform stretch `u(Y) = −F (L − Y)/(E W)`
/// above the loaded row. The same column under gravity given as the particle forces `m_p g`
/// must match the run with `TlmpmParams::gravity`. Returns (worst stretch error relative to
/// the tip value, worst gravity mismatch relative to the tip displacement).
fn loaded_column() -> (Real, Real) {
    let (len, width, dx, e, rho, force) = (1.0, 0.25, 1.0 / 16.0, 1e7, 1000.0, 2.0e3);
    let h = dx / 2.0;
    let bounds = (Vector::<2>::zeros(), Vector::<2>::new(width, len));
    let params = |gravity: Real| TlmpmParams {
        step: StepControl {
            gravity: Vector::<2>::new(0.0, -gravity),
            time_step: TimeStepPolicy::Fixed { dt: 10.0 },
            ..StepControl::default()
        },
        fixed: vec![FixedRegion::clamp(
            Vector::<2>::new(-10.0, len),
            Vector::<2>::from_element(10.0),
        )],
        ..TlmpmParams::default()
    };
    let solver = |gravity: Real| {
        ImplicitTlmpm::new(
            grid_around(bounds, dx, 3),
            params(gravity),
            ImplicitParams {
                newton: NewtonParams {
                    rel_tol: 1e-12,
                    ..NewtonParams::default()
                },
                linear: LinearSolver::Cholesky,
                ..ImplicitParams::default()
            },
            vec![uniaxial(e, rho)],
            block(&grid_around(bounds, dx, 3), bounds, h, rho, |_| {
                Vector::<2>::zeros()
            }),
        )
        .unwrap()
    };
    // Tip load on the bottom row (Y = h/2).
    let mut loaded = solver(0.0);
    let bottom: Vec<bool> = loaded
        .reference()
        .positions()
        .iter()
        .map(|x| x.y < h)
        .collect();
    let per = force / bottom.iter().filter(|&&b| b).count() as Real;
    for (f, &b) in loaded.particle_forces_mut().iter_mut().zip(&bottom) {
        f.y = if b { -per } else { 0.0 };
    }
    for _ in 0..3 {
        loaded.step().unwrap();
    }
    let tip = force * (len - h / 2.0) / (e * width);
    let stretch = loaded
        .particles()
        .x
        .iter()
        .zip(loaded.reference().positions())
        .map(|(x, x0)| {
            let exact = -force * (len - x0.y.max(h / 2.0)) / (e * width);
            ((x.y - x0.y) - exact).abs() / tip
        })
        .fold(0.0, Real::max);
    // Gravity as particle forces against the gravity parameter.
    let g = 9.81;
    let mut by_param = solver(g);
    let mut by_force = solver(0.0);
    let masses = by_force.particles().mass.clone();
    for (f, m) in by_force.particle_forces_mut().iter_mut().zip(&masses) {
        f.y = -m * g;
    }
    for _ in 0..3 {
        by_param.step().unwrap();
        by_force.step().unwrap();
    }
    let sag = rho * g * len * len / (2.0 * e);
    let mismatch = by_param
        .particles()
        .x
        .iter()
        .zip(&by_force.particles().x)
        .map(|(a, b)| (a - b).norm() / sag)
        .fold(0.0, Real::max);
    let lowest = by_force
        .particles()
        .x
        .iter()
        .zip(by_force.reference().positions())
        .map(|(x, x0)| x0.y - x.y)
        .fold(0.0, Real::max);
    println!(
        "loaded column: tip {tip:.4e} m, worst stretch error {:.3}% of it; gravity as particle \
         forces: sag {lowest:.4e} m (theory {sag:.4e} m), {mismatch:.2e} of it from the run \
         with the gravity parameter",
        100.0 * stretch
    );
    assert!(
        (lowest / sag - 1.0).abs() < 0.05,
        "sag {lowest} against {sag}"
    );
    (stretch, mismatch)
}

#[test]
fn particle_forces_give_the_static_stretch_and_match_gravity() {
    let (stretch, mismatch) = loaded_column();
    assert!(stretch < 0.03, "stretch error {stretch}");
    assert!(mismatch < 1e-9, "gravity mismatch {mismatch}");
}

/// The 2D hanging column of [`hanging_column`] solved by explicit TLMPM from rest under
/// `damping`, with gravity ramped over 0.005 s (an eighth of the column's period 4L/c =
/// 0.04 s), for 2 s. Returns the largest particle displacement error relative to the tip value
/// and the largest particle speed (m/s) at the end.
fn damped_hanging_column(damping: Damping) -> (Real, Real) {
    let (len, width, dx, e, rho, g) = (1.0, 0.25, 1.0 / 16.0, 1e7, 1000.0, 9.81);
    let bounds = (Vector::<2>::zeros(), Vector::<2>::new(width, len));
    let particles = block(&grid_around(bounds, dx, 3), bounds, dx / 2.0, rho, |_| {
        Vector::<2>::zeros()
    });
    let params = TlmpmParams {
        step: StepControl {
            gravity: Vector::<2>::new(0.0, -g),
            gravity_ramp: Some(GravityRamp { duration: 0.005 }),
            damping,
            time_step: TimeStepPolicy::Adaptive {
                cfl: 0.5,
                dt_max: 1.0,
                dt_min: 1e-12,
            },
            ..StepControl::default()
        },
        fixed: vec![FixedRegion::clamp(
            Vector::<2>::new(-10.0, len),
            Vector::<2>::from_element(10.0),
        )],
        ..TlmpmParams::default()
    };
    let mut solver = ExplicitTlmpm::new(
        grid_around(bounds, dx, 3),
        params,
        vec![uniaxial(e, rho)],
        particles,
    )
    .unwrap();
    solver.run_until(2.0).unwrap();
    let tip = rho * g * len * len / (2.0 * e);
    let p = solver.particles();
    let worst =
        p.x.iter()
            .zip(solver.reference().positions())
            .map(|(x, x0)| {
                let exact = -rho * g * (len * len - x0.y * x0.y) / (2.0 * e);
                ((x.y - x0.y) - exact).abs() / tip
            })
            .fold(0.0, Real::max);
    let speed = p.v.iter().map(|v| v.norm()).fold(0.0, Real::max);
    println!(
        "explicit TLMPM hanging column, {damping:?}: worst error {:.2}% of the tip value, max \
         speed {speed:.2e} m/s",
        100.0 * worst
    );
    (worst, speed)
}

#[test]
fn explicit_tlmpm_with_damping_settles_the_hanging_column() {
    // Undamped, the column keeps vibrating about the static state.
    let (_, free_speed) = damped_hanging_column(Damping::default());
    assert!(free_speed > 1e-2, "{free_speed}");
    for damping in [
        Damping {
            local: 0.1,
            viscous: 0.0,
        },
        Damping {
            local: 0.0,
            viscous: 20.0,
        },
    ] {
        let (error, speed) = damped_hanging_column(damping);
        assert!(error < 0.05, "{damping:?}: {error}");
        assert!(speed < 1e-3 * free_speed, "{damping:?}: {speed}");
    }
}

#[test]
fn the_implicit_solver_rejects_damping() {
    let bounds = (Vector::<2>::zeros(), Vector::<2>::new(0.25, 0.25));
    let params = TlmpmParams {
        step: StepControl {
            damping: Damping {
                local: 0.05,
                viscous: 0.0,
            },
            ..StepControl::default()
        },
        ..TlmpmParams::default()
    };
    let err = ImplicitTlmpm::new(
        grid_around(bounds, 1.0 / 16.0, 3),
        params,
        ImplicitParams::default(),
        vec![uniaxial(1e7, 1000.0)],
        block(
            &grid_around(bounds, 1.0 / 16.0, 3),
            bounds,
            1.0 / 32.0,
            1000.0,
            |_| Vector::<2>::zeros(),
        ),
    )
    .expect_err("rejected");
    assert!(
        matches!(err, mpm_core::SetupError::InvalidParameter { name: mpm_core::parameters::LOCAL_DAMPING, value, .. } if value == 0.05),
        "{err}"
    );
}

/// The spinning block of [`spinning_block`] (no clamp) for `steps` steps with `transfer`: the
/// particles and the kinetic energy at the end (J).
fn spin(implicit: bool, transfer: Transfer, steps: usize) -> (Particles<2>, Real) {
    let (grid, params, particles) = spinning_block::<2>(3, 0.0);
    let params = TlmpmParams {
        transfer,
        step: StepControl {
            gravity: Vector::<2>::zeros(),
            time_step: TimeStepPolicy::Fixed {
                dt: if implicit { 5e-3 } else { 5e-4 },
            },
            ..params.step
        },
        fixed: Vec::new(),
        ..params
    };
    let materials = vec![common::neo_hookean(1e5, 0.3, 1000.0)];
    let mut s = Solver::new(
        implicit.then(ImplicitParams::default),
        (grid, params),
        materials,
        particles,
    );
    for _ in 0..steps {
        s.step();
    }
    let p = s.particles().clone();
    let ke =
        p.v.iter()
            .zip(&p.mass)
            .map(|(v, m)| 0.5 * m * v.norm_squared())
            .sum();
    (p, ke)
}

#[test]
fn flip_blend_zero_is_pic_and_flip_keeps_more_kinetic_energy() {
    for implicit in [false, true] {
        let steps = if implicit { 20 } else { 200 };
        let (pic, ke_pic) = spin(implicit, Transfer::Pic, steps);
        let (flip0, _) = spin(implicit, Transfer::Flip { blend: 0.0 }, steps);
        assert_eq!(pic, flip0, "implicit: {implicit}: FLIP with α = 0 is PIC");
        // The block spins at 2 rad/s and expands at 0.5 1/s: PIC loses the part of the
        // velocity field the grid cannot hold at every step; FLIP keeps it.
        let (_, ke_flip) = spin(implicit, Transfer::Flip { blend: 0.99 }, steps);
        let (_, ke0) = spin(implicit, Transfer::Pic, 0);
        println!(
            "implicit {implicit}: KE/KE0 after {steps} steps: PIC {:.4}, FLIP 0.99 {:.4}",
            ke_pic / ke0,
            ke_flip / ke0
        );
        assert!(ke_flip > 0.3 * ke0 && ke_pic < 0.01 * ke0);
    }
}
