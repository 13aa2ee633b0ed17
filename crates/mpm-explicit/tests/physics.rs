//! Physics checks of the single-grid explicit MLS-MPM step.

mod common;

use approx::assert_relative_eq;
use common::{fill_box, jelly, particles_for, water, with_threads};
use mpm_core::boundary::{Boundaries, Contact, ContactKind, DomainWalls};
use mpm_core::{
    run_until_with, ColumnData, Dim, DimOps, GridSpec, Kernel, Matrix, OnInstability, Real, Solver,
    Stage, StepControl, StepError, TimeStepPolicy, Vector, Violation,
};
use mpm_explicit::{ExplicitParams, ExplicitSolver, SoftWalls, Transfer, VolumeUpdate};

fn spec<const D: usize>(n: usize) -> GridSpec<D> {
    GridSpec::new(Vector::<D>::zeros(), 1.0 / (n - 1) as Real, [n; D])
}

/// A solid block rotating about the box centre, slightly pre-stretched so the stress is non-zero.
fn spinning_block<const D: usize>(kernel: Kernel, transfer: Transfer) -> ExplicitSolver<D>
where
    Dim<D>: DimOps<D>,
{
    spinning_block_in::<D>(kernel, transfer, Vector::<D>::zeros())
}

/// [`spinning_block`] under `gravity` (m/s²).
fn spinning_block_in<const D: usize>(
    kernel: Kernel,
    transfer: Transfer,
    gravity: Vector<D>,
) -> ExplicitSolver<D>
where
    Dim<D>: DimOps<D>,
{
    let spec = spec::<D>(33);
    let materials = vec![jelly(1e5, 0.3, 1000.0)];
    let mut particles = particles_for::<D>(&materials);
    let centre = Vector::<D>::from_element(0.5);
    let omega = 2.0;
    let spin = Matrix::<D>::from_fn(|a, b| match (a, b) {
        (0, 1) => -omega,
        (1, 0) => omega,
        _ => 0.0,
    });
    fill_box(
        &mut particles,
        &spec,
        (
            Vector::<D>::from_element(0.3),
            Vector::<D>::from_element(0.7),
        ),
        2,
        (0, 1000.0),
        move |x| (spin * (x - centre), spin),
    );
    for f in particles.def_grad.as_mut().unwrap() {
        f[(0, 0)] = 1.02;
    }
    let params = ExplicitParams {
        kernel,
        transfer,
        step: StepControl {
            gravity,
            time_step: TimeStepPolicy::Fixed { dt: 2e-4 },
            ..StepControl::default()
        },
        ..ExplicitParams::default()
    };
    ExplicitSolver::new(spec, params, materials, Boundaries::default(), particles).unwrap()
}

fn p2g_conserves_mass_and_momentum<const D: usize>()
where
    Dim<D>: DimOps<D>,
{
    for kernel in [Kernel::Linear, Kernel::Quadratic, Kernel::Cubic] {
        let mut s = spinning_block::<D>(kernel, Transfer::Apic);
        // Give every particle a distinct velocity so the check is not trivially symmetric.
        for (p, v) in s.velocities_mut().iter_mut().enumerate() {
            v[0] += 0.01 * (p % 7) as Real;
        }
        let before = s.diagnostics();
        s.transfer_to_grid(2e-4);
        let (gm, gp) = (s.grid().total_mass(), s.grid().total_momentum());
        assert_relative_eq!(gm, before.mass, max_relative = 1e-13);
        // The stress impulse sums to zero over the nodes: only the transferred momentum stays.
        let scale = before.mass * before.momentum.norm().max(1.0);
        assert!(
            (gp - before.momentum).norm() < 1e-13 * scale,
            "{kernel:?}: {}",
            (gp - before.momentum).norm()
        );
    }
}

#[test]
fn p2g_conserves_mass_and_linear_momentum_2d_3d() {
    p2g_conserves_mass_and_momentum::<2>();
    p2g_conserves_mass_and_momentum::<3>();
}

fn apic_conserves_angular_momentum<const D: usize>()
where
    Dim<D>: DimOps<D>,
{
    for kernel in [Kernel::Quadratic, Kernel::Cubic] {
        let mut s = spinning_block::<D>(kernel, Transfer::Apic);
        let l0 = s.diagnostics().angular_momentum;
        let p0 = s.diagnostics().momentum;
        for _ in 0..50 {
            s.step().unwrap();
        }
        let d = s.diagnostics();
        let drift = (d.angular_momentum - l0).norm() / l0.norm();
        assert!(
            drift < 1e-12,
            "{D}D {kernel:?}: relative angular momentum drift {drift:e}"
        );
        assert!(
            (d.momentum - p0).norm() < 1e-12 * d.mass,
            "{D}D linear momentum drift"
        );
    }
    // PIC loses angular momentum: the check above is not vacuous.
    let mut s = spinning_block::<D>(Kernel::Quadratic, Transfer::Pic);
    let l0 = s.diagnostics().angular_momentum.norm();
    for _ in 0..50 {
        s.step().unwrap();
    }
    assert!(s.diagnostics().angular_momentum.norm() < 0.999 * l0);
}

#[test]
fn mls_apic_conserves_angular_momentum_2d_3d() {
    apic_conserves_angular_momentum::<2>();
    apic_conserves_angular_momentum::<3>();
}

/// Free fall: the centre of mass follows x₀ + ½ g t² exactly, whatever the internal stress.
#[test]
fn free_fall_centre_of_mass_is_exact() {
    let mut s = spinning_block_in::<2>(
        Kernel::Quadratic,
        Transfer::Apic,
        Vector::<2>::new(0.0, -9.81),
    );
    let com = |s: &ExplicitSolver<2>| {
        let d = s.diagnostics();
        s.particles()
            .x
            .iter()
            .zip(&s.particles().mass)
            .map(|(x, m)| x * *m)
            .sum::<Vector<2>>()
            / d.mass
    };
    let (c0, v0) = (com(&s), s.diagnostics().momentum / s.diagnostics().mass);
    let n = 40;
    for _ in 0..n {
        s.step().unwrap();
    }
    // Symplectic Euler: x_n = x₀ + n dt v₀ + g dt² n(n+1)/2.
    let dt = 2e-4;
    let expected = c0
        + v0 * (n as Real * dt)
        + s.params().step.gravity * (dt * dt * (n * (n + 1)) as Real / 2.0);
    assert!(
        (com(&s) - expected).norm() < 1e-13,
        "{:e}",
        (com(&s) - expected).norm()
    );
}

/// A fluid column collapsing in a closed box (dam break) dissipates energy: total energy never
/// rises above its initial value, and mass is exactly conserved.
#[test]
fn dam_break_energy_does_not_grow() {
    let spec = spec::<2>(65);
    let materials = vec![water(2e5, 1e-3)];
    let mut particles = particles_for::<2>(&materials);
    fill_box(
        &mut particles,
        &spec,
        (Vector::<2>::new(0.05, 0.05), Vector::<2>::new(0.4, 0.6)),
        2,
        (0, 1000.0),
        |_| (Vector::<2>::zeros(), Matrix::<2>::zeros()),
    );
    let params = ExplicitParams {
        step: StepControl {
            gravity: Vector::<2>::new(0.0, -9.81),
            time_step: TimeStepPolicy::Adaptive {
                cfl: 0.4,
                dt_max: 1e-3,
                dt_min: 1e-9,
            },
            ..StepControl::default()
        },
        ..ExplicitParams::default()
    };
    let walls = Boundaries {
        walls: Some(DomainWalls {
            contact: Contact {
                kind: ContactKind::Separate,
                friction: 0.0,
            },
            thickness: 3,
            treatment: Default::default(),
        }),
        colliders: vec![],
    };
    let mut s = ExplicitSolver::new(spec, params, materials, walls, particles).unwrap();
    let d0 = s.diagnostics();
    let mut max_e = d0.total_energy();
    run_until_with(&mut s, 0.3, |s, _| {
        max_e = max_e.max(s.diagnostics().total_energy());
    })
    .unwrap();
    let d = s.diagnostics();
    assert_eq!(d.mass, d0.mass);
    // The column has slumped: kinetic energy was gained from potential energy.
    assert!(
        d.potential_energy
            < d0.potential_energy - 0.05 * (d0.potential_energy - 0.0).abs().max(1.0)
    );
    assert!(
        max_e <= d0.total_energy() * (1.0 + 1e-3) + 1e-9,
        "energy grew: {max_e} > {}",
        d0.total_energy()
    );
}

/// Serial and parallel runs are bitwise identical.
#[test]
fn serial_and_parallel_steps_are_bitwise_equal() {
    let run = |threads: usize| {
        with_threads(threads, || {
            let spec = spec::<2>(65);
            let materials = vec![jelly(1e5, 0.3, 500.0), water(1e5, 1e-2)];
            let mut particles = particles_for::<2>(&materials);
            fill_box(
                &mut particles,
                &spec,
                (Vector::<2>::new(0.1, 0.1), Vector::<2>::new(0.5, 0.4)),
                2,
                (1, 1000.0),
                |_| (Vector::<2>::zeros(), Matrix::<2>::zeros()),
            );
            fill_box(
                &mut particles,
                &spec,
                (Vector::<2>::new(0.55, 0.3), Vector::<2>::new(0.75, 0.5)),
                3,
                (0, 500.0),
                |_| (Vector::<2>::new(-1.0, 0.0), Matrix::<2>::zeros()),
            );
            let params = ExplicitParams {
                step: StepControl {
                    gravity: Vector::<2>::new(0.0, -9.81),
                    ..StepControl::default()
                },
                ..ExplicitParams::default()
            };
            let walls = Boundaries {
                walls: Some(DomainWalls {
                    contact: Contact::default(),
                    thickness: 3,
                    treatment: Default::default(),
                }),
                colliders: vec![],
            };
            let mut s = ExplicitSolver::new(spec, params, materials, walls, particles).unwrap();
            for _ in 0..30 {
                s.step().unwrap();
            }
            s.particles().clone()
        })
    };
    let (a, b) = (run(1), run(4));
    let bits = |v: &[Vector<2>]| {
        v.iter()
            .flat_map(|x| x.iter().map(|c| c.to_bits()))
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&a.x), bits(&b.x));
    assert_eq!(bits(&a.v), bits(&b.v));
    assert!(a == b, "particle state differs between 1 and 4 threads");
}

/// A step that moves a particle more than one cell is rejected (abort) without touching the
/// particles, and succeeds after one dt/2 retry under the retry policy.
#[test]
fn instability_abort_and_retry() {
    let build = |policy, step: Real| {
        let spec = spec::<2>(33);
        let materials = vec![jelly(1e4, 0.3, 1000.0)];
        let mut particles = particles_for::<2>(&materials);
        let dx = spec.dx;
        let dt = 1e-3;
        // |v| dt = 1.5 Δx.
        let v = 1.5 * dx / dt;
        fill_box(
            &mut particles,
            &spec,
            (Vector::<2>::new(0.4, 0.4), Vector::<2>::new(0.5, 0.5)),
            2,
            (0, 1000.0),
            move |_| (Vector::<2>::new(v, 0.0), Matrix::<2>::zeros()),
        );
        let params = ExplicitParams {
            step: StepControl {
                time_step: TimeStepPolicy::Fixed { dt: step },
                on_instability: policy,
                ..StepControl::default()
            },
            ..ExplicitParams::default()
        };
        ExplicitSolver::new(spec, params, materials, Boundaries::default(), particles).unwrap()
    };
    let mut s = build(OnInstability::Abort, 1e-3);
    let err = match s.step().unwrap_err() {
        StepError::Instability(i) => i,
        other => panic!("expected an instability, got {other}"),
    };
    assert_eq!(err.stage, Stage::G2P);
    assert_eq!(err.violation, Violation::CflExceeded);
    assert!(matches!(err.location, mpm_core::Location::Particle(_)));
    assert_eq!(err.step, 0);
    assert_eq!(s.steps(), 0);
    assert!(err.to_string().contains("step 0") && err.to_string().contains("g2p"));

    // A retry starts from the saved state: the retried step is bitwise the step of dt/2.
    let mut s = build(OnInstability::Retry { max_retries: 3 }, 1e-3);
    let info = s.step().unwrap();
    assert_eq!(info.retries, 1);
    assert_relative_eq!(info.dt, 5e-4);
    let mut half = build(OnInstability::Abort, 5e-4);
    half.step().unwrap();
    assert!(
        *s.particles() == *half.particles(),
        "the retried step must start from the state before the failed attempt"
    );
}

/// Per-step volume re-estimation keeps a fluid at rest at J = 1 in its interior.
#[test]
fn volume_reestimation_recovers_rest_volume() {
    let spec = spec::<2>(33);
    let materials = vec![water(1e5, 0.0)];
    let mut particles = particles_for::<2>(&materials);
    fill_box(
        &mut particles,
        &spec,
        (Vector::<2>::new(0.25, 0.25), Vector::<2>::new(0.75, 0.75)),
        2,
        (0, 1000.0),
        |_| (Vector::<2>::zeros(), Matrix::<2>::zeros()),
    );
    for j in particles.jacobian.as_mut().unwrap() {
        *j = 1.3; // deliberately wrong
    }
    let params = ExplicitParams {
        volume: VolumeUpdate::Reestimate,
        step: StepControl {
            time_step: TimeStepPolicy::Fixed { dt: 1e-6 },
            ..StepControl::default()
        },
        ..ExplicitParams::default()
    };
    let mut s =
        ExplicitSolver::new(spec, params, materials, Boundaries::default(), particles).unwrap();
    s.reestimate_volumes_now();
    for (x, j) in s
        .particles()
        .x
        .iter()
        .zip(s.particles().jacobian.as_ref().unwrap())
    {
        if (x - Vector::<2>::from_element(0.5)).amax() < 0.15 {
            assert_relative_eq!(*j, 1.0, max_relative = 1e-12);
        }
    }
}

/// Predictive softened walls slow a particle heading for the wall so that its predicted
/// position stays at the soft wall.
#[test]
fn soft_walls_stop_particles_before_the_wall() {
    let spec = spec::<2>(33);
    let materials = vec![water(1e4, 0.0)];
    let mut particles = particles_for::<2>(&materials);
    fill_box(
        &mut particles,
        &spec,
        (Vector::<2>::new(0.1, 0.45), Vector::<2>::new(0.15, 0.55)),
        2,
        (0, 1000.0),
        |_| (Vector::<2>::new(-2.0, 0.0), Matrix::<2>::zeros()),
    );
    let sw = SoftWalls {
        margin: 0.1,
        lookahead: 0.02,
    };
    let params = ExplicitParams {
        step: StepControl {
            time_step: TimeStepPolicy::Fixed { dt: 1e-4 },
            ..StepControl::default()
        },
        soft_walls: Some(sw),
        ..ExplicitParams::default()
    };
    let mut s =
        ExplicitSolver::new(spec, params, materials, Boundaries::default(), particles).unwrap();
    s.step().unwrap();
    for (x, v) in s.particles().x.iter().zip(&s.particles().v) {
        // x_new = x_old + dt v, and x_old + τ v ≥ margin after softening.
        let x_old = x - v * 1e-4;
        assert!(x_old.x + sw.lookahead * v.x >= sw.margin - 1e-12);
    }
}

/// FLIP blending is far less dissipative than PIC on a spinning, vibrating block (total
/// mechanical energy), and both conserve linear momentum.
#[test]
fn flip_dissipates_less_than_pic() {
    let run = |transfer| {
        let mut s = spinning_block::<2>(Kernel::Quadratic, transfer);
        let (e0, p0) = (s.diagnostics().total_energy(), s.diagnostics().momentum);
        for _ in 0..100 {
            s.step().unwrap();
        }
        let d = s.diagnostics();
        assert!((d.momentum - p0).norm() < 1e-12 * d.mass);
        d.total_energy() / e0
    };
    let (pic, flip) = (run(Transfer::Pic), run(Transfer::Flip { blend: 0.99 }));
    // Measured: PIC keeps 0.12 of its energy after 100 steps, FLIP 0.94.
    assert!(pic < 0.5, "PIC kept {pic} of its energy");
    assert!(flip > 0.9, "FLIP kept only {flip} of its energy");
}

/// Every output field the solver lists comes out of `Solver::output` with its unit and
/// `components` values per particle (the plastic state as three scalar columns).
#[test]
fn output_fields_match_the_written_columns() {
    let s = spinning_block::<3>(Kernel::Quadratic, Transfer::Apic);
    let n = s.particles().len();
    let fields = Solver::output_fields(&s);
    let names: Vec<&str> = fields.iter().map(|f| f.name).collect();
    assert_eq!(
        names,
        ["x", "v", "mass", "volume0", "material", "affine", "F", "pressure"]
    );
    for f in &fields {
        let cols = Solver::output(&s, f.name);
        assert_eq!(cols.len(), 1, "{}", f.name);
        assert_eq!(cols[0].unit, f.unit, "{}", f.name);
        let len = match &cols[0].data {
            ColumnData::F64 { values, .. } => values.len(),
            ColumnData::U32 { values, .. } => values.len(),
        };
        assert_eq!(len, n * f.components, "{}", f.name);
    }
    // The pressure of the stretched jelly (F_00 = 1.02) is the mean stress, negative in tension.
    let p = Solver::pressure(&s);
    assert!(p.iter().all(|&p| p < 0.0 && p.is_finite()), "{:?}", &p[..3]);
    assert!(Solver::output(&s, "no_such_field").is_empty());
}

/// Under an adaptive dt the step uses the largest signal speed `max_p(|v_p| + c_p)` that the
/// previous step's G2P kept: every dt equals, to the bit, the bound a scan of the particles
/// gives before the step (`stable_dt`), while the jelly speeds up and hits the water.
#[test]
fn adaptive_dt_from_g2p_equals_the_particle_scan() {
    let spec = spec::<2>(33);
    let materials = vec![water(1e5, 1e-3), jelly(1e5, 0.3, 1200.0)];
    let mut particles = particles_for::<2>(&materials);
    let still = |_: &Vector<2>| (Vector::<2>::zeros(), Matrix::<2>::zeros());
    fill_box(
        &mut particles,
        &spec,
        (Vector::<2>::new(0.1, 0.1), Vector::<2>::new(0.9, 0.3)),
        2,
        (0, 1000.0),
        still,
    );
    fill_box(
        &mut particles,
        &spec,
        (Vector::<2>::new(0.4, 0.45), Vector::<2>::new(0.6, 0.6)),
        2,
        (1, 1200.0),
        |_| (Vector::<2>::new(0.0, -3.0), Matrix::<2>::zeros()),
    );
    let params = ExplicitParams {
        step: StepControl {
            gravity: Vector::<2>::new(0.0, -9.81),
            time_step: TimeStepPolicy::Adaptive {
                cfl: 0.4,
                dt_max: 1.0,
                dt_min: 1e-9,
            },
            ..StepControl::default()
        },
        ..ExplicitParams::default()
    };
    let walls = Boundaries {
        walls: Some(DomainWalls {
            thickness: 3,
            treatment: Default::default(),
            contact: Contact {
                kind: ContactKind::Slip,
                friction: 0.0,
            },
        }),
        ..Boundaries::default()
    };
    let mut s = ExplicitSolver::new(spec, params, materials, walls, particles).unwrap();
    let mut dts = Vec::new();
    for _ in 0..150 {
        let scan = s.stable_dt();
        let info = s.step().unwrap();
        assert_eq!(info.dt.to_bits(), scan.to_bits(), "step {}", s.steps());
        dts.push(info.dt);
    }
    // The bound moved: the run is not a constant-dt run in disguise.
    let (lo, hi) = dts
        .iter()
        .fold((Real::INFINITY, 0.0), |(lo, hi): (Real, Real), &d| {
            (lo.min(d), hi.max(d))
        });
    assert!(hi > lo * 1.001, "dt stayed within [{lo}, {hi}]");
}
