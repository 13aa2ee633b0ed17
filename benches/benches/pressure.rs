//! Criterion benchmark of the pressure solve (DESIGN §9): the 3D 7-point Poisson problem on
//! `n³` cell-centred unknowns with a Dirichlet boundary (diagonal 6, off-diagonal −1, no
//! scaling), right-hand side standard normal (fixed seed), `x₀ = 0`, stopped at
//! `‖b − A x‖ ≤ 10⁻⁶ ‖b‖` — the problem of the python anchors (`shared/perf/poisson_bench.py`).
//!
//! - `pressure/mgpcg_3d_{64,128}`: set-up (labelled grid, matrix-free operator, multigrid
//!   hierarchy) plus the multigrid-preconditioned CG solve, timed together.
//!
//! - `pressure/dam_break_3d_{Jacobi,IncompleteCholesky,Multigrid}`: the fluid pressure system
//!   (B0 fluid and wall pressures, Eq. 35's fluid blocks) of a 3D dam break with 120 000
//!   particles after 40 steps: assembly (pattern included), preconditioner set-up and CG to
//!   `‖b − A x‖ ≤ 10⁻⁶ ‖b‖`, timed together.
//!
//! - `pressure/coupled_floating_2d_{Jacobi,IncompleteCholesky}`: the coupled DIQ system
//!   (Eq. 35: fluid, wall, solid and interface pressures) of an elastic block floating in a 2D
//!   tank of 460² cells, over 100 000 unknowns: assembly, preconditioner set-up and CG, timed
//!   together.
//!
//! Before the criterion groups, the binary prints to stderr one timed solve per preconditioner
//! (identity, Jacobi, IC(0), multigrid) at n = 32, 64 and 128: set-up + solve seconds, iterations and
//! the true final relative residual. Run with `cargo bench -p mpm-benches --bench pressure`.

use criterion::{Criterion, SamplingMode};
use mpm_core::boundary::{Boundaries, Contact, DomainWalls};
use mpm_core::material::{ElasticModel, FluidMaterial, Lame, SolidMaterial, Tait};
use mpm_core::{
    on_pool, Body, Columns, GridSpec, Material, ParticlesBuilder, Shape, Solver, Vector,
};
use mpm_diq::{
    Constraints, DiqCoupled, DiqFluid, DiqParams, PressureMethod, PressureParams, PressureSystem,
    SolidParams, UnknownKind,
};
use mpm_linalg::{
    conjugate_gradient, CgParams, CgWorkspace, Identity, IncompleteCholesky, Jacobi,
    LinearOperator, MultigridPreconditioner, PoissonGrid, PoissonOperator, Preconditioner,
};
use std::hint::black_box;
use std::time::{Duration, Instant};

/// Relative residual target.
const RTOL: f64 = 1e-6;

/// `n` standard-normal numbers from a fixed seed (splitmix64 and Box–Muller).
fn standard_normal(n: usize) -> Vec<f64> {
    let mut state: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut next = || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        // Uniform in (0, 1].
        ((z >> 11) as f64 + 1.0) / (1u64 << 53) as f64
    };
    let mut out = Vec::with_capacity(n + 1);
    while out.len() < n {
        let (u, v) = (next(), next());
        let r = (-2.0 * u.ln()).sqrt();
        let t = std::f64::consts::TAU * v;
        out.push(r * t.cos());
        out.push(r * t.sin());
    }
    out.truncate(n);
    out
}

/// The preconditioners compared.
#[derive(Clone, Copy, Debug)]
enum Method {
    Identity,
    Jacobi,
    /// IC(0) on the assembled matrix (assembly and factorisation are set-up).
    Ic0,
    Multigrid,
}

/// Set-up and CG solve of the `n³` problem; returns the iterations and the true final relative
/// residual. Runs on a pool thread, as the solvers' pressure solves do (they are called inside a
/// step, see `mpm_core::on_pool`): from the benchmark's main thread each of CG's parallel vector
/// operations would otherwise start with a hand-over to the pool.
fn solve(n: usize, method: Method, b: &[f64]) -> (u32, f64) {
    on_pool(|| solve_here(n, method, b))
}

/// [`solve`] on the calling thread.
fn solve_here(n: usize, method: Method, b: &[f64]) -> (u32, f64) {
    let grid = PoissonGrid::<3>::dirichlet_box([n, n, n]).expect("valid grid");
    let mut op = PoissonOperator::new(&grid);
    let mut precond: Box<dyn Preconditioner<f64>> = match method {
        Method::Identity => Box::new(Identity),
        Method::Jacobi => Box::new(Jacobi::from_inverse_diagonal(vec![1.0 / 6.0; b.len()])),
        Method::Ic0 => Box::new(
            IncompleteCholesky::new(&grid.assemble().expect("assembles")).expect("IC(0) exists"),
        ),
        Method::Multigrid => Box::new(MultigridPreconditioner::new(&grid)),
    };
    let mut x = vec![0.0; b.len()];
    let params = CgParams {
        rel_tol: RTOL,
        max_iterations: 5000,
        ..CgParams::default()
    };
    let info = conjugate_gradient(
        &mut op,
        precond.as_mut(),
        b,
        &mut x,
        &params,
        &mut CgWorkspace::new(),
    )
    .expect("CG converges");
    let mut ax = vec![0.0; b.len()];
    op.apply(&x, &mut ax);
    let (mut r2, mut b2) = (0.0, 0.0);
    for (ax, b) in ax.iter().zip(b) {
        r2 += (b - ax) * (b - ax);
        b2 += b * b;
    }
    (info.iterations, (r2 / b2).sqrt())
}

fn comparison_table() {
    eprintln!("rayon threads: {}", rayon::current_num_threads());
    eprintln!("| n | preconditioner | set-up + solve (s) | iterations | true rel. residual |");
    eprintln!("|---|---|---|---|---|");
    for n in [32, 64, 128] {
        let b = standard_normal(n * n * n);
        for method in [
            Method::Identity,
            Method::Jacobi,
            Method::Ic0,
            Method::Multigrid,
        ] {
            let start = Instant::now();
            let (iterations, relres) = solve(n, method, &b);
            let seconds = start.elapsed().as_secs_f64();
            eprintln!("| {n} | {method:?} | {seconds:.3} | {iterations} | {relres:.2e} |");
        }
    }
}

fn bench_pressure(c: &mut Criterion) {
    if std::env::var_os("PRESSURE_SKIP_TABLE").is_none() {
        comparison_table();
    }
    let mut group = c.benchmark_group("pressure");
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(5));
    for n in [64, 128] {
        let b = standard_normal(n * n * n);
        let (iterations, relres) = solve(n, Method::Multigrid, &b);
        eprintln!("mgpcg_3d_{n}: {iterations} iterations, true relative residual {relres:.2e}");
        group.bench_function(format!("mgpcg_3d_{n}"), |bench| {
            bench.iter(|| black_box(solve(n, Method::Multigrid, black_box(&b))));
        });
    }
    group.finish();
}

/// The box `[lo, hi]` (m) of material `material` (its density from the material table) on the
/// lattice of spacing `h` (m) aligned with `lo`: points `lo + (k + ½) h`, axis 0 fastest.
fn lattice<const D: usize>(lo: [f64; D], hi: [f64; D], h: f64, material: u32) -> Body<D> {
    Body::new(Shape::cuboid(lo, hi), material)
        .lattice(1)
        .lattice_cells(Vector::<D>::from(lo), h)
}

/// The 3D dam break of the fluid-system benchmark: a 0.4 × 0.5 × 0.6 m water column in a
/// 1 × 0.5 × 1 m box with free-slip walls, Δx = 1/50 m, 2³ particles per cell (120 000
/// particles), advanced `steps` steps so that the flow moves; returns the solver.
fn dam_break_3d(steps: usize) -> DiqFluid<3> {
    let n = 50;
    let dx = 1.0 / n as f64;
    let spec = GridSpec::new(
        Vector::<3>::from_element(-dx),
        dx,
        [n + 3, n / 2 + 3, n + 3],
    );
    let water = Material::Fluid(FluidMaterial {
        density: 1000.0,
        eos: Tait {
            bulk_modulus: 2e6,
            gamma: 7.0,
        },
        viscosity: 0.0,
    });
    let walls = Boundaries {
        walls: Some(DomainWalls {
            contact: Contact::default(),
            thickness: 1,
            treatment: Default::default(),
        }),
        colliders: Vec::new(),
    };
    let materials = vec![water];
    // (k + ½) h from the origin, h = Δx/2; no volume ratio column (DIQ's fluid is incompressible).
    let column = lattice([0.0; 3], [0.4, 0.5, 0.6], dx / 2.0, 0);
    let ps = ParticlesBuilder::with_columns(&spec, &materials, Columns::default())
        .with(&column)
        .expect("the column lies inside the grid")
        .build();
    let mut fluid =
        DiqFluid::new(spec, DiqParams::default(), materials, walls, ps).expect("valid set-up");
    for _ in 0..steps {
        fluid.step().expect("stable step");
    }
    fluid
}

/// Assembles and solves the dam break's pressure system with `method`; returns the iterations
/// and the relative residual.
fn solve_fluid(
    fluid: &DiqFluid<3>,
    problem: &(Constraints<3>, Vec<f64>, Vec<f64>),
    dt: f64,
    method: PressureMethod,
) -> (u32, f64) {
    let (rows, inv_mass, rhs) = problem;
    let params = PressureParams {
        method,
        rel_tol: RTOL,
        ..PressureParams::default()
    };
    let mut system = PressureSystem::<3>::new();
    system
        .assemble(rows, inv_mass, dt, &params, &fluid.solid_cells())
        .expect("assembled");
    let mut lambda = Vec::new();
    let info = system.solve(rhs, &mut lambda, &params).expect("solved");
    (info.iterations, info.relative_residual)
}

fn bench_fluid(c: &mut Criterion) {
    let steps = 40;
    let fluid = dam_break_3d(steps);
    let dt = fluid.stable_dt().min(1e-3);
    let problem = fluid.projection_problem(dt);
    eprintln!(
        "dam break 3D: {} particles, {} unknowns, t = {:.3} s after {steps} steps, dt = {dt:.3e} s",
        fluid.particles().len(),
        problem.0.len(),
        fluid.time()
    );
    eprintln!("| method | assemble + set-up + solve (s) | iterations | rel. residual |");
    eprintln!("|---|---|---|---|");
    for method in [
        PressureMethod::Jacobi,
        PressureMethod::IncompleteCholesky,
        PressureMethod::Multigrid,
    ] {
        let start = Instant::now();
        let (iterations, relres) = solve_fluid(&fluid, &problem, dt, method);
        let seconds = start.elapsed().as_secs_f64();
        eprintln!("| {method:?} | {seconds:.3} | {iterations} | {relres:.2e} |");
    }
    let mut group = c.benchmark_group("pressure");
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(5));
    for method in [
        PressureMethod::Jacobi,
        PressureMethod::IncompleteCholesky,
        PressureMethod::Multigrid,
    ] {
        group.bench_function(format!("dam_break_3d_{method:?}"), |bench| {
            bench.iter(|| black_box(solve_fluid(&fluid, &problem, dt, method)));
        });
    }
    group.finish();
}

/// A 2D tank of `n × n` cells half full of water with an elastic block (ρ = 500 kg/m², E = 1e5
/// Pa, ν = 0.3) of a tenth of the width floating at its draft: the coupled solver's set-up.
fn floating_block_2d(n: usize) -> DiqCoupled<2> {
    let dx = 1.0 / n as f64;
    let h = dx / 2.0;
    let (x0, x1, bottom, top) = (0.45, 0.55, 0.45, 0.55);
    let materials = vec![
        Material::Fluid(FluidMaterial {
            density: 1000.0,
            eos: Tait {
                bulk_modulus: 2e6,
                gamma: 7.0,
            },
            viscosity: 0.0,
        }),
        Material::Solid(SolidMaterial {
            density: 500.0,
            elastic: ElasticModel::NeoHookean(Lame::from_young_poisson(1e5, 0.3)),
            plasticity: Default::default(),
        }),
    ];
    let walls = Boundaries {
        walls: Some(DomainWalls {
            contact: Contact::default(),
            thickness: 1,
            treatment: Default::default(),
        }),
        colliders: Vec::new(),
    };
    let spec = GridSpec::new(Vector::<2>::from_element(-dx), dx, [n + 3, n + 3]);
    // The water (material 0) less the block's place, then the block (material 1).
    let water = lattice([0.0, 0.0], [1.0, 0.5], h, 0)
        .keep(move |x| !(x[0] > x0 && x[0] < x1 && x[1] > bottom));
    let block = lattice([x0, bottom], [x1, top], h, 1);
    let columns = Columns {
        deformation_gradient: true,
        ..Columns::default()
    };
    let mut ps = ParticlesBuilder::with_columns(&spec, &materials, columns);
    for body in [&water, &block] {
        ps.add(body).expect("the tank lies inside the grid");
    }
    let ps = ps.build();
    DiqCoupled::new(
        spec,
        DiqParams::default(),
        SolidParams::default(),
        materials,
        walls,
        ps,
    )
    .expect("valid set-up")
}

/// Assembles and solves the coupled system with `method`; returns iterations and residual.
fn solve_coupled(
    problem: &(Constraints<2>, Vec<f64>, Vec<f64>),
    dt: f64,
    method: PressureMethod,
) -> (u32, f64) {
    let (rows, inv_mass, rhs) = problem;
    let params = PressureParams {
        method,
        rel_tol: RTOL,
        ..PressureParams::default()
    };
    let mut system = PressureSystem::<2>::new();
    system
        .assemble(rows, inv_mass, dt, &params, &|_| false)
        .expect("assembled");
    let mut lambda = Vec::new();
    let info = system.solve(rhs, &mut lambda, &params).expect("solved");
    (info.iterations, info.relative_residual)
}

fn bench_coupled(c: &mut Criterion) {
    let mut coupled = floating_block_2d(460);
    let dt = 1e-3;
    let problem = coupled.coupled_problem(dt).expect("elastic solve");
    let count = |k: UnknownKind| problem.0.kinds().iter().filter(|&&x| x == k).count();
    eprintln!(
        "floating block 2D: {} particles, {} unknowns ({} fluid, {} wall, {} solid, {} interface)",
        coupled.particles().len(),
        problem.0.len(),
        count(UnknownKind::Fluid),
        count(UnknownKind::Wall),
        count(UnknownKind::SolidPressure),
        count(UnknownKind::Interface),
    );
    eprintln!("| method | assemble + set-up + solve (s) | iterations | rel. residual |");
    eprintln!("|---|---|---|---|");
    let methods = [PressureMethod::Jacobi, PressureMethod::IncompleteCholesky];
    for method in methods {
        let start = Instant::now();
        let (iterations, relres) = solve_coupled(&problem, dt, method);
        let seconds = start.elapsed().as_secs_f64();
        eprintln!("| {method:?} | {seconds:.3} | {iterations} | {relres:.2e} |");
    }
    let mut group = c.benchmark_group("pressure");
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(5));
    for method in methods {
        group.bench_function(format!("coupled_floating_2d_{method:?}"), |bench| {
            bench.iter(|| black_box(solve_coupled(&problem, dt, method)));
        });
    }
    group.finish();
}

fn main() {
    let mut criterion = Criterion::default().configure_from_args();
    bench_pressure(&mut criterion);
    bench_fluid(&mut criterion);
    bench_coupled(&mut criterion);
    criterion.final_summary();
}
