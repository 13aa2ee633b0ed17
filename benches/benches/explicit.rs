//! Criterion benchmarks of the explicit MLS-MPM hot paths (DESIGN §9).
//!
//! Groups, each for 2D and 3D at about 64k and 256k particles (scenes in `mpm_benches`):
//!
//! - `p2g`: binning plus the transfer (`transfer_to_grid`), repeated on the same state;
//! - `g2p`: G2P plus the commit (`PreparedG2p::run`); each iteration first runs an untimed sort, P2G and
//!   grid update so the gather always reads a grid that matches the particles;
//! - `step`: a full `Solver::step` of the explicit solver, the scene evolving from iteration to iteration;
//!   `step/domain512_3d_256k` is `step/3d_256k`'s cube in a 512³-cell domain (the sparse grid
//!   stores only the blocks the cube reaches, so it should take the time of the 64³ domain).
//!
//! Throughput is reported in particles per second. After the `step` runs the accumulated stage
//! timings of the solver are printed to stderr. Run with `cargo bench -p mpm-benches`.

use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, Criterion, SamplingMode, Throughput};
use mpm_benches::{memory, scene_2d, scene_3d, scene_3d_in, Size, SPARSE_DOMAIN_CELLS};
use mpm_core::{Dim, DimOps, Solver, TimeStepPolicy};
use mpm_explicit::ExplicitSolver;
use std::hint::black_box;
use std::time::{Duration, Instant};

/// Applies the common, deliberately short, sampling settings to a group.
fn configure(group: &mut BenchmarkGroup<'_, WallTime>) {
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(2))
        .measurement_time(Duration::from_secs(5));
}

/// The fixed time step of a benchmark scene (s).
fn fixed_dt<const D: usize>(solver: &ExplicitSolver<D>) -> f64
where
    Dim<D>: DimOps<D>,
{
    match solver.params().step.time_step {
        TimeStepPolicy::Fixed { dt } => dt,
        TimeStepPolicy::Adaptive { .. } => unreachable!("benchmark scenes use a fixed dt"),
    }
}

/// The scenes in benchmark order: (name, dimension, size).
fn scenes() -> impl Iterator<Item = (String, usize, Size)> {
    [2, 3]
        .into_iter()
        .flat_map(|d| Size::ALL.map(|s| (format!("{d}d_{}", s.label()), d, s)))
}

fn bench_p2g_on<const D: usize>(
    group: &mut BenchmarkGroup<'_, WallTime>,
    name: &str,
    mut solver: ExplicitSolver<D>,
) where
    Dim<D>: DimOps<D>,
{
    let dt = fixed_dt(&solver);
    group.throughput(Throughput::Elements(solver.particles().len() as u64));
    group.bench_function(name, |b| {
        b.iter(|| {
            solver.transfer_to_grid(black_box(dt));
        })
    });
    black_box(solver.grid().total_mass());
}

fn bench_g2p_on<const D: usize>(
    group: &mut BenchmarkGroup<'_, WallTime>,
    name: &str,
    mut solver: ExplicitSolver<D>,
) where
    Dim<D>: DimOps<D>,
{
    let dt = fixed_dt(&solver);
    group.throughput(Throughput::Elements(solver.particles().len() as u64));
    group.bench_function(name, |b| {
        b.iter_custom(|iters| {
            let mut timed = Duration::ZERO;
            for _ in 0..iters {
                let prepared = match solver.prepare_g2p(dt) {
                    Ok(p) => p,
                    Err(e) => panic!("{name}: grid update failed: {e}"),
                };
                let t = Instant::now();
                if let Err(e) = prepared.run() {
                    panic!("{name}: G2P guard check failed: {e:?}");
                }
                timed += t.elapsed();
            }
            timed
        })
    });
}

fn bench_step_on<const D: usize>(
    group: &mut BenchmarkGroup<'_, WallTime>,
    name: &str,
    mut solver: ExplicitSolver<D>,
) where
    Dim<D>: DimOps<D>,
{
    let n = solver.particles().len();
    group.throughput(Throughput::Elements(n as u64));
    group.bench_function(name, |b| {
        b.iter(|| match solver.step() {
            Ok(info) => black_box(info),
            Err(e) => panic!("{name}: step failed: {e}"),
        })
    });
    if solver.steps() == 0 {
        return; // Filtered out by the command line.
    }
    let rows = Solver::stage_times(&solver);
    let total: f64 = rows.iter().map(|r| r.seconds).sum();
    let stages = rows
        .iter()
        .map(|r| format!("{} {:.1}%", r.stage, 100.0 * r.seconds / total))
        .collect::<Vec<_>>()
        .join(", ");
    let mem = memory(&solver);
    eprintln!(
        "{name}: {n} particles, dt = {:.3e} s, {} steps ({:.4} s simulated); stages: {stages}; \
         memory: {} B/particle particles + {} B/particle scratch + {:.1} B/particle grid = {:.1} B/particle",
        fixed_dt(&solver),
        solver.steps(),
        solver.time(),
        mem.particle_bytes,
        mem.scratch_bytes,
        mem.grid_bytes as f64 / n as f64,
        mem.total_per_particle(),
    );
}

/// Runs `bench` for every scene of [`scenes`], building each solver fresh; with `sparse`, also
/// on the 256k cube in the [`SPARSE_DOMAIN_CELLS`]³ domain (`domain512_3d_256k`; the name
/// keeps the filter `step/3d_256k` from matching it).
fn for_each_scene(
    c: &mut Criterion,
    group_name: &str,
    bench2: fn(&mut BenchmarkGroup<'_, WallTime>, &str, ExplicitSolver<2>),
    bench3: fn(&mut BenchmarkGroup<'_, WallTime>, &str, ExplicitSolver<3>),
    sparse: bool,
) {
    let mut group = c.benchmark_group(group_name);
    configure(&mut group);
    for (name, dim, size) in scenes() {
        if dim == 2 {
            bench2(&mut group, &name, scene_2d(size));
        } else {
            bench3(&mut group, &name, scene_3d(size));
        }
    }
    if sparse {
        let name = format!("domain{SPARSE_DOMAIN_CELLS}_3d_256k");
        bench3(
            &mut group,
            &name,
            scene_3d_in(Size::K256, SPARSE_DOMAIN_CELLS),
        );
    }
    group.finish();
}

fn p2g(c: &mut Criterion) {
    eprintln!("rayon threads: {}", rayon::current_num_threads());
    for_each_scene(c, "p2g", bench_p2g_on::<2>, bench_p2g_on::<3>, false);
}

fn g2p(c: &mut Criterion) {
    for_each_scene(c, "g2p", bench_g2p_on::<2>, bench_g2p_on::<3>, false);
}

fn step(c: &mut Criterion) {
    for_each_scene(c, "step", bench_step_on::<2>, bench_step_on::<3>, true);
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    p2g(&mut c);
    g2p(&mut c);
    step(&mut c);
    c.final_summary();
}
