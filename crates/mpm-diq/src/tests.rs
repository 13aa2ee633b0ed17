//! Tests of the DIQ fluid: the assembled system, hydrostatics, divergence, volume, determinism.

use crate::fluid::{DiqFluid, DiqParams};
use crate::pressure::{PressureMethod, PressureParams, PressureSystem, UnknownKind};
use mpm_core::boundary::{Boundaries, Contact, DomainWalls};
use mpm_core::material::{FluidMaterial, Tait};
use mpm_core::{
    Columns, GridSpec, Material, ParticleInit, Particles, Real, Solver, StepError, TimeStepPolicy,
    Vector,
};

const RHO: Real = 1000.0;

fn water() -> Material {
    Material::Fluid(FluidMaterial {
        density: RHO,
        eos: Tait {
            bulk_modulus: 2e6,
            gamma: 7.0,
        },
        viscosity: 0.0,
    })
}

/// `per_axis^D` particles per cell on a lattice filling the box `[lo, hi]`, velocity `v(x)`.
fn block<const D: usize>(
    lo: [Real; D],
    hi: [Real; D],
    dx: Real,
    per_axis: usize,
    v: impl Fn(&Vector<D>) -> Vector<D>,
) -> Particles<D> {
    let h = dx / per_axis as Real;
    let counts: [usize; D] = std::array::from_fn(|a| ((hi[a] - lo[a]) / h).round() as usize);
    let total: usize = counts.iter().product();
    let mut ps = Particles::new(Columns::default());
    for i in 0..total {
        let mut rest = i;
        let x = Vector::<D>::from_fn(|a, _| {
            let k = rest % counts[a];
            rest /= counts[a];
            lo[a] + (k as Real + 0.5) * h
        });
        ps.push(ParticleInit {
            x,
            v: v(&x),
            mass: RHO * h.powi(D as i32),
            volume0: h.powi(D as i32),
            material: 0,
            affine: mpm_core::Matrix::<D>::zeros(),
        });
    }
    ps
}

fn walls<const D: usize>() -> Boundaries<D> {
    Boundaries {
        walls: Some(DomainWalls {
            contact: Contact::default(),
            thickness: 1,
            treatment: Default::default(),
        }),
        colliders: Vec::new(),
    }
}

/// A grid of `cells` cells of `dx` per axis inside the walls (one wall layer outside).
fn grid<const D: usize>(cells: [usize; D], dx: Real) -> GridSpec<D> {
    GridSpec::new(
        Vector::<D>::from_element(-dx),
        dx,
        std::array::from_fn(|a| cells[a] + 3),
    )
}

fn params<const D: usize>(dt_max: Real, correction: bool) -> DiqParams<D> {
    DiqParams {
        time_step: TimeStepPolicy::Adaptive {
            cfl: 0.4,
            dt_max,
            dt_min: 1e-9,
        },
        position_correction: correction,
        ..DiqParams::default()
    }
}

/// A 2D column of height `h` filling the width of a 1 m box, at rest.
fn column(n: usize, h: Real, method: PressureMethod) -> DiqFluid<2> {
    let dx = 1.0 / n as Real;
    let mut p = params::<2>(1e-2, true);
    p.pressure.method = method;
    DiqFluid::new(
        grid([n, n], dx),
        p,
        vec![water()],
        walls(),
        block([0.0, 0.0], [1.0, h], dx, 2, |_| Vector::<2>::zeros()),
    )
    .unwrap()
}

/// Runs `f` on a pool of `threads` rayon threads.
pub(crate) fn with_threads<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool")
        .install(f)
}
#[test]
fn assembled_matrix_is_symmetric_positive_and_equals_dense_schur_complement() {
    // A swirling 2D blob with a free surface: dense J M⁻¹ Jᵀ against the assembled matrix.
    let dx = 1.0 / 12.0;
    let fluid = DiqFluid::new(
        grid([12, 12], dx),
        params::<2>(1e-2, false),
        vec![water()],
        walls(),
        block([0.0, 0.0], [0.5, 0.5], dx, 2, |x| {
            Vector::<2>::new(-(x[1] - 0.25), x[0] - 0.25)
        }),
    )
    .unwrap();
    let ps = fluid.particles();
    let bins = fluid.bin(&ps.x);
    let nodes = fluid.transfer(crate::fluid::Points::of(ps), &bins, true);
    let (rows, _) = fluid.constraints((&ps.x, &ps.volume0), &bins, &nodes.mass, 0.0);
    assert!(rows.kinds.contains(&UnknownKind::Wall));
    assert!(!rows.pin_gauge, "a blob with air above has a free surface");
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
        let mut fluid = DiqFluid::new(
            grid([24, 24], dx),
            p,
            vec![water()],
            walls(),
            block([0.0, 0.0], [0.5, 0.5], dx, 2, |x| {
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
    let full = DiqFluid::new(
        grid([8, 8], 0.125),
        params::<2>(1e-3, false),
        vec![water()],
        walls(),
        block([0.0, 0.0], [1.0, 1.0], 0.125, 2, |_| Vector::<2>::zeros()),
    )
    .unwrap();
    let ps = full.particles();
    let bins = full.bin(&ps.x);
    let nodes = full.transfer(crate::fluid::Points::of(ps), &bins, false);
    let (rows, _) = full.constraints((&ps.x, &ps.volume0), &bins, &nodes.mass, 0.0);
    assert!(rows.pin_gauge);
    let ps = fluid.particles();
    let bins = fluid.bin(&ps.x);
    let nodes = fluid.transfer(crate::fluid::Points::of(ps), &bins, false);
    assert!(
        !fluid
            .constraints((&ps.x, &ps.volume0), &bins, &nodes.mass, 0.0)
            .0
            .pin_gauge
    );
}

#[test]
fn capped_cg_is_a_typed_solve_error() {
    let dx = 1.0 / 16.0;
    let mut p = params::<2>(1e-3, false);
    p.pressure.max_iterations = 1;
    p.pressure.method = PressureMethod::Jacobi;
    let mut fluid = DiqFluid::new(
        grid([16, 16], dx),
        p,
        vec![water()],
        walls(),
        block([0.0, 0.0], [0.5, 0.5], dx, 2, |_| Vector::<2>::zeros()),
    )
    .unwrap();
    let x0 = fluid.particles().x.clone();
    match fluid.step() {
        Err(StepError::Solve { stage, source, .. }) => {
            assert_eq!(stage, mpm_core::Stage::Solve);
            assert!(source.to_string().contains("did not converge"), "{source}");
        }
        other => panic!("expected a solve error, got {other:?}"),
    }
    assert_eq!(fluid.particles().x, x0, "a failed step changes nothing");
}

/// 2D dam break: a 0.4 × 0.6 m block in the corner of a 1 m box.
fn dam_break(n: usize, correction: bool) -> DiqFluid<2> {
    let dx = 1.0 / n as Real;
    DiqFluid::new(
        grid([n, n], dx),
        params::<2>(1e-2, correction),
        vec![water()],
        walls(),
        block([0.0, 0.0], [0.4, 0.6], dx, 2, |_| Vector::<2>::zeros()),
    )
    .unwrap()
}

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

/// Runs `make()` for `2 × steps` steps on 1 and on 2 threads, and again resumed from the
/// checkpoint after `steps`: the three final checkpoints must be bitwise equal.
fn assert_bitwise_across_threads_and_resume(make: impl Fn() -> DiqFluid<2> + Sync, steps: usize) {
    let run = |threads: usize| {
        with_threads(threads, || {
            let mut f = make();
            for _ in 0..steps {
                f.step().unwrap();
            }
            let state = f.checkpoint();
            for _ in 0..steps {
                f.step().unwrap();
            }
            (state, f.checkpoint())
        })
    };
    let (mid1, end1) = run(1);
    let (_, end2) = run(2);
    assert_eq!(end1, end2, "1 vs 2 threads");
    let mut resumed = make();
    resumed.restore(&mid1).unwrap();
    for _ in 0..steps {
        resumed.step().unwrap();
    }
    assert_eq!(resumed.checkpoint(), end1, "resume from checkpoint");
}

#[test]
fn bitwise_identical_across_threads_and_resume() {
    assert_bitwise_across_threads_and_resume(|| dam_break(24, true), 15);
}

#[test]
fn three_dimensional_column_is_hydrostatic() {
    let n = 8;
    let dx = 1.0 / n as Real;
    let h = 0.5;
    let mut fluid = DiqFluid::new(
        grid([n, n, n], dx),
        params::<3>(2e-2, true),
        vec![water()],
        walls(),
        block([0.0, 0.0, 0.0], [1.0, 1.0, h], dx, 2, |_| {
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
fn fixed_dt_above_the_bound_stops_or_is_retried_at_half_steps() {
    let dx = 1.0 / 16.0;
    let make = |policy| {
        let mut p = params::<2>(1e-2, false);
        p.time_step = TimeStepPolicy::Fixed { dt: 0.15 };
        p.on_instability = policy;
        DiqFluid::new(
            grid([16, 16], dx),
            p,
            vec![water()],
            walls(),
            block([0.0, 0.0], [0.4, 0.6], dx, 2, |_| Vector::<2>::zeros()),
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
fn particle_quadrature_of_the_gradient_destabilises_a_column_at_rest() {
    // The reason for the cell-centre default: with G^f by particle quadrature, round-off in a
    // column at rest grows exponentially (about 57 s⁻¹ at Δx = 1/32 m), while the cell-centre
    // rule keeps it at rest (see `hydrostatic_column_stays_at_rest_with_linear_pressure`).
    let n = 32;
    let dx = 1.0 / n as Real;
    let mut p = params::<2>(1e-2, false);
    p.gradient_quadrature = crate::GradientQuadrature::Particles;
    let mut fluid = DiqFluid::new(
        grid([n, n], dx),
        p,
        vec![water()],
        walls(),
        block([0.0, 0.0], [1.0, 0.5], dx, 2, |_| Vector::<2>::zeros()),
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
        DiqFluid::new(
            grid([24, 24], dx),
            params::<2>(1e-2, true),
            vec![water()],
            b,
            block([0.0, 0.0], [1.0, 0.2], dx, 2, |_| Vector::<2>::zeros()),
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
    let all = block([0.0, 0.0], [1.0, 0.5], dx, 2, |_| Vector::<2>::zeros());
    let mut ps = Particles::new(Columns::default());
    for (p, x) in all.x.iter().enumerate() {
        if !(0..2).all(|a| x[a] > lo[a] && x[a] < hi[a]) {
            ps.push(ParticleInit {
                x: *x,
                v: all.v[p],
                mass: all.mass[p],
                volume0: all.volume0[p],
                material: 0,
                affine: mpm_core::Matrix::<2>::zeros(),
            });
        }
    }
    let mut f = DiqFluid::new(
        grid([n, n], dx),
        params::<2>(5e-3, true),
        vec![water()],
        b,
        ps,
    )
    .unwrap();
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

/// Water of density [`RHO`] with dynamic viscosity `mu` (Pa·s).
fn viscous_water(mu: Real) -> Material {
    match water() {
        Material::Fluid(mut f) => {
            f.viscosity = mu;
            Material::Fluid(f)
        }
        Material::Solid(_) => unreachable!("water is a fluid"),
    }
}

/// Thickness of the shear layer (m).
const LAYER: Real = 0.25;

/// A 1 × 0.25 m layer of water with free surfaces all round (no walls, no gravity), in the
/// shear mode `v_x = A cos(π (y − y₀)/H)` with A = 0.1 m/s, whose viscous decay rate is
/// `ν (π/H)²`: the mode satisfies the traction-free condition `∂v_x/∂y = 0` on both faces.
fn shear_layer(mu: Real, n: usize) -> DiqFluid<2> {
    let dx = 1.0 / n as Real;
    let mut p = params::<2>(2e-3, false);
    p.gravity = Vector::<2>::zeros();
    p.pressure.rel_tol = 1e-12;
    let y0 = 0.25;
    DiqFluid::new(
        GridSpec::new(Vector::<2>::zeros(), dx, [3 * n / 2 + 1, n + 1]),
        p,
        vec![viscous_water(mu)],
        Boundaries::default(),
        block([0.25, y0], [1.25, y0 + LAYER], dx, 2, |x| {
            Vector::<2>::new(0.1 * (std::f64::consts::PI * (x.y - y0) / LAYER).cos(), 0.0)
        }),
    )
    .unwrap()
}

/// The shear mode's amplitude (m/s) over the middle third of the layer, away from its ends.
fn shear_amplitude(f: &DiqFluid<2>) -> Real {
    let p = f.particles();
    let (mut num, mut den) = (0.0, 0.0);
    for q in 0..p.len() {
        if (0.6..0.9).contains(&p.x[q].x) {
            let c = (std::f64::consts::PI * (p.x[q].y - 0.25) / LAYER).cos();
            num += p.mass[q] * p.v[q].x * c;
            den += p.mass[q] * c * c;
        }
    }
    num / den
}

#[test]
fn a_viscous_shear_mode_decays_at_the_analytic_rate() {
    let (mu, t_end) = (10.0, 0.25);
    let expected = mu / RHO * (std::f64::consts::PI / LAYER).powi(2);
    let rate = |mu: Real, n: usize| {
        let mut f = shear_layer(mu, n);
        let a0 = shear_amplitude(&f);
        while f.time() < t_end - 1e-12 {
            f.step().unwrap();
        }
        -(shear_amplitude(&f) / a0).ln() / f.time()
    };
    // ν (π/H)² = 1.58 1/s: the amplitude falls to 67 % in 0.25 s. The transfers (APIC on
    // linear B-splines) damp the mode too, at a rate that falls with Δx² (measured 0.116 1/s at
    // Δx = 1/32 m, 0.029 at 1/64); beyond it the decay is the viscosity's to 1.5 % (rates 1.671
    // and 1.599 1/s).
    let (viscous32, inviscid32) = (rate(mu, 32), rate(0.0, 32));
    let (viscous64, inviscid64) = (rate(mu, 64), rate(0.0, 64));
    for (n, v, i) in [(32, viscous32, inviscid32), (64, viscous64, inviscid64)] {
        assert!(
            ((v - i) / expected - 1.0).abs() < 0.025,
            "1/{n}: decay rate {v} 1/s, {i} 1/s without viscosity, analytic {expected} 1/s"
        );
    }
    assert!((viscous64 / expected - 1.0).abs() < 0.02);
    assert!(
        inviscid64 > 0.0 && inviscid64 < inviscid32 / 3.0,
        "the transfers' own damping {inviscid32} → {inviscid64} 1/s does not fall with Δx²"
    );
}

/// A 0.5 × 0.3 m blob of water of viscosity `mu` swirling without walls or gravity.
fn swirl(mu: Real) -> DiqFluid<2> {
    let n = 24;
    let dx = 1.0 / n as Real;
    let mut p = params::<2>(5e-3, false);
    p.gravity = Vector::<2>::zeros();
    p.pressure.rel_tol = 1e-12;
    DiqFluid::new(
        GridSpec::new(Vector::<2>::zeros(), dx, [n + 1, n + 1]),
        p,
        vec![viscous_water(mu)],
        Boundaries::default(),
        block([0.25, 0.35], [0.75, 0.65], dx, 2, |x| {
            Vector::<2>::new(0.3 + (6.0 * x.y).sin(), (5.0 * x.x).cos() - 0.2)
        }),
    )
    .unwrap()
}

#[test]
fn viscosity_keeps_momentum_and_only_removes_energy() {
    let momentum = |f: &DiqFluid<2>| {
        let p = f.particles();
        (0..p.len()).map(|q| p.v[q] * p.mass[q]).sum::<Vector<2>>()
    };
    let energy = |f: &DiqFluid<2>| {
        let p = f.particles();
        (0..p.len())
            .map(|q| 0.5 * p.mass[q] * p.v[q].norm_squared())
            .sum::<Real>()
    };
    let mut inviscid = swirl(0.0);
    let mut viscous = swirl(50.0);
    let p0 = momentum(&viscous);
    let mut last = energy(&viscous);
    for _ in 0..20 {
        inviscid.step().unwrap();
        let info = viscous.step().unwrap();
        let solve = info.solves.iter().find(|s| s.name == "viscosity").unwrap();
        assert!(solve.iterations > 0 && solve.residual <= 1e-12);
        let e = energy(&viscous);
        assert!(e < last, "kinetic energy rose from {last} to {e} J/m");
        last = e;
    }
    let drift = (momentum(&viscous) - p0).norm() / p0.norm();
    assert!(drift < 1e-10, "momentum drift {drift}");
    // ν = 0.05 m²/s on swirls of wavenumber 5–6 1/m over 0.1 s: e^(−2 ν k² t) ≈ 0.70–0.78 of
    // the energy is left (measured 0.80 of the inviscid run's, whose own ends move too).
    assert!(
        last < 0.85 * energy(&inviscid),
        "viscous {last} J/m against inviscid {} J/m",
        energy(&inviscid)
    );
    // Pay only for what the scene needs: the viscous solve is planned for viscous water only.
    let mentions = |f: &DiqFluid<2>| {
        f.plan()
            .stages
            .iter()
            .any(|s| s.detail.contains("viscosity"))
    };
    assert!(mentions(&viscous) && !mentions(&inviscid));
}

#[test]
fn viscous_runs_are_bitwise_across_threads_and_resume() {
    assert_bitwise_across_threads_and_resume(|| swirl(50.0), 5);
}

#[test]
fn viscosity_keeps_momentum_and_removes_energy_in_3d() {
    // A 0.25 m cube of water with a shearing swirl, no walls or gravity, Δx = 1/16 m.
    let n = 16;
    let dx = 1.0 / n as Real;
    let mut p = params::<3>(5e-3, false);
    p.gravity = Vector::<3>::zeros();
    p.pressure.rel_tol = 1e-12;
    let cube = |mu: Real| {
        DiqFluid::new(
            GridSpec::new(Vector::<3>::zeros(), dx, [n + 1, n + 1, n + 1]),
            p.clone(),
            vec![viscous_water(mu)],
            Boundaries::default(),
            block([0.375; 3], [0.625; 3], dx, 2, |x| {
                Vector::<3>::new(
                    (6.0 * x.y).sin() + 0.2,
                    (5.0 * x.z).cos(),
                    (4.0 * x.x).sin(),
                )
            }),
        )
        .unwrap()
    };
    let totals = |f: &DiqFluid<3>| {
        let p = f.particles();
        let momentum = (0..p.len()).map(|q| p.v[q] * p.mass[q]).sum::<Vector<3>>();
        let energy = (0..p.len())
            .map(|q| 0.5 * p.mass[q] * p.v[q].norm_squared())
            .sum::<Real>();
        (momentum, energy)
    };
    let (mut f, mut inviscid) = (cube(50.0), cube(0.0));
    let (p0, mut last) = totals(&f);
    for _ in 0..10 {
        inviscid.step().unwrap();
        let info = f.step().unwrap();
        assert!(info.solves.iter().any(|s| s.name == "viscosity"));
        let (_, e) = totals(&f);
        assert!(e < last, "kinetic energy rose from {last} to {e} J");
        last = e;
    }
    let drift = (totals(&f).0 - p0).norm() / p0.norm();
    assert!(drift < 1e-10, "momentum drift {drift}");
    // The sine modes (k = 4–6 1/m) keep e^(−2 ν k² t) = 0.85–0.93 of their energy over the
    // 0.05 s; the uniform part does not decay: measured 0.959 of the inviscid run's energy.
    let ratio = last / totals(&inviscid).1;
    assert!(ratio < 0.97, "viscous over inviscid energy {ratio}");
}
