//! Criterion benchmarks of the implicit TLMPM Newton system (DESIGN §9): for one Newton
//! linearisation of a 2D Neo-Hookean block (`ImplicitTlmpm::linearize`, untimed),
//!
//! - `tlmpm_assembly`: assembling the sparse matrix `M/Δt² + K` from the per-particle tensors;
//! - `tlmpm_factorization`: the numeric sparse Cholesky factorisation (symbolic part reused);
//! - `tlmpm_solve`: the two triangular solves for the Newton direction;
//! - `tlmpm_factorization_single`, `tlmpm_solve_single`: the same two in f32;
//! - `tlmpm_step`: a full implicit step (Newton to convergence), the scene evolving;
//! - `tlmpm_step_pure_newton`: the same with `chord` and `single_precision` off (every Newton
//!   direction from a fresh f64 factorisation), for a comparison in the same run.
//!
//! Sizes: 32² and 64² cells of 2 × 2 particles (4 096 and 16 384 particles). Throughput is
//! particles per second. Run with `cargo bench -p mpm-benches --bench tlmpm`.

use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, Criterion, SamplingMode, Throughput};
use mpm_benches::jelly;
use mpm_core::solver::StageTime;
use mpm_core::{
    Body, Columns, GridSpec, Matrix, ParticlesBuilder, Real, Shape, Solver, StepControl,
    TimeStepPolicy, Vector,
};
use mpm_tlmpm::{ImplicitParams, ImplicitTlmpm, NewtonParams, TlmpmParams};
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
/// stretching about its centre under gravity, on a grid with 3 spare cells per side, solved
/// with `newton`.
fn scene(cells: usize, newton: NewtonParams) -> ImplicitTlmpm<2> {
    let dx = 1.0 / 128.0;
    let h = dx / 2.0;
    let n = 2 * cells;
    let centre = Vector::<2>::from_element(0.5 * cells as Real * dx);
    let margin = Vector::<2>::from_element(3.0 * dx);
    let grid = GridSpec::covering(-margin, centre * 2.0 + margin, dx);
    let materials = vec![jelly()];
    // n × n particles at (k + ½) h from the origin, spinning and stretching about the centre
    // (the affine columns start at zero).
    let block = Body::new(Shape::cuboid([0.0, 0.0], [n as Real * h, n as Real * h]), 0)
        .lattice(1)
        .lattice_cells(Vector::<2>::zeros(), h)
        .velocity_field(move |x| {
            let d = x - centre;
            (
                Vector::<2>::new(0.5 * d.x - 2.0 * d.y, 0.5 * d.y + 2.0 * d.x),
                Matrix::<2>::zeros(),
            )
        });
    let columns = Columns {
        deformation_gradient: true,
        ..Columns::default()
    };
    let particles = ParticlesBuilder::with_columns(&grid, &materials, columns)
        .with(&block)
        .expect("the block lies inside the grid")
        .build();
    let params = TlmpmParams {
        step: StepControl {
            gravity: Vector::<2>::new(0.0, -9.81),
            time_step: TimeStepPolicy::Fixed { dt: DT },
            ..StepControl::default()
        },
        ..TlmpmParams::default()
    };
    ImplicitTlmpm::new(
        grid,
        params,
        ImplicitParams {
            newton,
            ..ImplicitParams::default()
        },
        materials,
        particles,
    )
    .expect("benchmark scene")
}

fn benches(c: &mut Criterion) {
    eprintln!("rayon threads: {}", rayon::current_num_threads());
    for cells in [32, 64] {
        let name = format!("2d_{}k", (4 * cells * cells) / 1024);
        let mut solver = scene(cells, NewtonParams::default());
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
        for (suffix, single) in [("", false), ("_single", true)] {
            let mut group = c.benchmark_group(format!("tlmpm_factorization{suffix}"));
            configure(&mut group);
            group.throughput(Throughput::Elements(np));
            group.bench_function(&name, |b| {
                b.iter(|| solver.factorize_tangent(single).unwrap())
            });
            group.finish();
            // The solves run in the precision of the factor just computed.
            solver.factorize_tangent(single).unwrap();
            let mut group = c.benchmark_group(format!("tlmpm_solve{suffix}"));
            configure(&mut group);
            group.throughput(Throughput::Elements(np));
            group.bench_function(&name, |b| {
                b.iter(|| black_box(solver.solve_tangent().unwrap()))
            });
            group.finish();
        }
        let mut group = c.benchmark_group("tlmpm_step");
        configure(&mut group);
        group.throughput(Throughput::Elements(np));
        let mut iterations = (0u64, 0u64, 0u64);
        let before = Solver::stage_times(&solver);
        group.bench_function(&name, |b| {
            b.iter(|| {
                solver.step().expect("step");
                let newton = solver.last_newton();
                iterations.0 += 1;
                iterations.1 += u64::from(newton.iterations);
                iterations.2 += u64::from(newton.chord_iterations);
            })
        });
        group.finish();
        eprintln!(
            "{name}: {:.2} Newton iterations per step ({:.2} of them chord iterations) over {} steps",
            iterations.1 as f64 / iterations.0.max(1) as f64,
            iterations.2 as f64 / iterations.0.max(1) as f64,
            iterations.0
        );
        if iterations.0 > 0 {
            eprintln!(
                "{name}: step time by stage (Newton parts under solve): {}",
                shares(&before, &Solver::stage_times(&solver))
            );
        }
        // The same scene with pure Newton (every direction from a fresh f64 factorisation),
        // as every step ran before chord iterations and single-precision factors.
        let mut pure = scene(
            cells,
            NewtonParams {
                chord: false,
                single_precision: false,
                ..NewtonParams::default()
            },
        );
        for _ in 0..3 {
            pure.step().expect("step");
        }
        let mut group = c.benchmark_group("tlmpm_step_pure_newton");
        configure(&mut group);
        group.throughput(Throughput::Elements(np));
        group.bench_function(&name, |b| b.iter(|| black_box(pure.step().expect("step"))));
        group.finish();
    }
}

/// The share of each stage, and of each part of a stage, in the time spent between the two
/// readings `before` and `after` of the accumulated stage times.
fn shares(before: &[StageTime], after: &[StageTime]) -> String {
    let delta = |a: &StageTime| {
        let b = before.iter().find(|b| b.stage == a.stage);
        let parts: Vec<(&str, f64)> = a
            .parts
            .iter()
            .map(|(name, s)| {
                let old = b
                    .and_then(|b| b.parts.iter().find(|p| p.0 == *name))
                    .map_or(0.0, |p| p.1);
                (*name, s - old)
            })
            .collect();
        (a.stage, a.seconds - b.map_or(0.0, |b| b.seconds), parts)
    };
    let rows: Vec<_> = after.iter().map(delta).collect();
    let total: f64 = rows.iter().map(|r| r.1).sum();
    rows.iter()
        .map(|(stage, s, parts)| {
            let inner = parts
                .iter()
                .map(|(n, p)| format!("{n} {:.1}%", 100.0 * p / total))
                .collect::<Vec<_>>()
                .join(", ");
            if inner.is_empty() {
                format!("{stage} {:.1}%", 100.0 * s / total)
            } else {
                format!("{stage} {:.1}% [{inner}]", 100.0 * s / total)
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    benches(&mut c);
    c.final_summary();
}
