//! Criterion benchmark of the pressure solve (DESIGN §9): the 3D 7-point Poisson problem on
//! `n³` cell-centred unknowns with a Dirichlet boundary (diagonal 6, off-diagonal −1, no
//! scaling), right-hand side standard normal (fixed seed), `x₀ = 0`, stopped at
//! `‖b − A x‖ ≤ 10⁻⁶ ‖b‖` — the problem of the python anchors (`shared/perf/poisson_bench.py`).
//!
//! - `pressure/mgpcg_3d_{64,128}`: set-up (labelled grid, matrix-free operator, multigrid
//!   hierarchy) plus the multigrid-preconditioned CG solve, timed together.
//!
//! Before the criterion groups, the binary prints to stderr one timed solve per preconditioner
//! (identity, Jacobi, IC(0), multigrid) at n = 32, 64 and 128: set-up + solve seconds, iterations and
//! the true final relative residual. Run with `cargo bench -p mpm-benches --bench pressure`.

use criterion::{Criterion, SamplingMode};
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
/// residual.
fn solve(n: usize, method: Method, b: &[f64]) -> (u32, f64) {
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

fn main() {
    let mut criterion = Criterion::default().configure_from_args();
    bench_pressure(&mut criterion);
    criterion.final_summary();
}
