//! Criterion benchmarks of the implicit TLMPM Newton system (DESIGN §9): for one Newton
//! linearisation of a 2D Neo-Hookean block (`ImplicitTlmpm::linearize`, untimed),
//!
//! - `tlmpm_assembly`: assembling the sparse matrix `M/Δt² + K` from the per-particle tensors;
//! - `tlmpm_factorization`: the numeric sparse Cholesky factorisation (symbolic part reused);
//! - `tlmpm_solve`: the two triangular solves for the Newton direction;
//! - `tlmpm_step`: a full implicit step (Newton to convergence), the scene evolving.
//!
//! Sizes: 32² and 64² cells of 2 × 2 particles (4 096 and 16 384 particles). Throughput is
//! particles per second. Run with `cargo bench -p mpm-benches --bench tlmpm`.

use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, Criterion, SamplingMode, Throughput};
use mpm_benches::jelly;
use mpm_core::{Columns, GridSpec, Matrix, ParticleInit, Particles, Real, TimeStepPolicy, Vector};
use mpm_tlmpm::{ImplicitParams, ImplicitTlmpm, TlmpmParams};
use std::hint::black_box;
use std::time::Duration;

/// Time step of the benchmark scenes (s).
const DT: Real = 1e-3;

fn configure(group: &mut BenchmarkGroup<'_, WallTime>) {
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
}

/// A jelly block of `cells`² cells (Δx = 1/128 m, 2 × 2 particles per cell) spinning and
/// stretching about its centre under gravity, on a grid with 3 spare cells per side.
fn scene(cells: usize) -> ImplicitTlmpm<2> {
    let dx = 1.0 / 128.0;
    let h = dx / 2.0;
    let n = 2 * cells;
    let centre = Vector::<2>::from_element(0.5 * cells as Real * dx);
    let mut particles = Particles::new(Columns {
        deformation_gradient: true,
        ..Columns::default()
    });
    let rho = jelly().density();
    for k in 0..n * n {
        let x = Vector::<2>::new(((k % n) as Real + 0.5) * h, ((k / n) as Real + 0.5) * h);
        let d = x - centre;
        particles.push(ParticleInit {
            x,
            v: Vector::<2>::new(0.5 * d.x - 2.0 * d.y, 0.5 * d.y + 2.0 * d.x),
            mass: rho * h * h,
            volume0: h * h,
            material: 0,
            affine: Matrix::<2>::zeros(),
        });
    }
    let margin = Vector::<2>::from_element(3.0 * dx);
    let grid = GridSpec::covering(-margin, centre * 2.0 + margin, dx);
    let params = TlmpmParams {
        gravity: Vector::<2>::new(0.0, -9.81),
        time_step: TimeStepPolicy::Fixed { dt: DT },
        ..TlmpmParams::default()
    };
    ImplicitTlmpm::new(
        grid,
        params,
        ImplicitParams::default(),
        vec![jelly()],
        particles,
    )
    .expect("benchmark scene")
}

fn benches(c: &mut Criterion) {
    eprintln!("rayon threads: {}", rayon::current_num_threads());
    for cells in [32, 64] {
        let name = format!("2d_{}k", (4 * cells * cells) / 1024);
        let mut solver = scene(cells);
        // Advance a few steps so the block is deformed, then linearise once.
        for _ in 0..3 {
            solver.step().expect("step");
        }
        solver.linearize(DT).expect("linearize");
        let np = solver.particles().len() as u64;
        eprintln!(
            "{name}: {np} particles, {} equations",
            solver.num_equations()
        );
        let mut group = c.benchmark_group("tlmpm_assembly");
        configure(&mut group);
        group.throughput(Throughput::Elements(np));
        group.bench_function(&name, |b| b.iter(|| solver.assemble_tangent().unwrap()));
        group.finish();
        let mut group = c.benchmark_group("tlmpm_factorization");
        configure(&mut group);
        group.throughput(Throughput::Elements(np));
        group.bench_function(&name, |b| b.iter(|| solver.factorize_tangent().unwrap()));
        group.finish();
        let mut group = c.benchmark_group("tlmpm_solve");
        configure(&mut group);
        group.throughput(Throughput::Elements(np));
        group.bench_function(&name, |b| {
            b.iter(|| black_box(solver.solve_tangent().unwrap()))
        });
        group.finish();
        let mut group = c.benchmark_group("tlmpm_step");
        configure(&mut group);
        group.throughput(Throughput::Elements(np));
        let mut iterations = (0u64, 0u64);
        group.bench_function(&name, |b| {
            b.iter(|| {
                let info = solver.step().expect("step");
                iterations.0 += 1;
                iterations.1 += u64::from(info.newton.iterations);
            })
        });
        group.finish();
        eprintln!(
            "{name}: {:.2} Newton iterations per step over {} steps",
            iterations.1 as f64 / iterations.0.max(1) as f64,
            iterations.0
        );
    }
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    benches(&mut c);
    c.final_summary();
}
