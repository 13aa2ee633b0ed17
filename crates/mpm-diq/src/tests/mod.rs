//! Tests of the DIQ fluid: the assembled system, hydrostatics, divergence, volume, determinism.
//!
//! This module holds the shared set-ups (water, walls, grids, bodies, the bitwise check); the
//! tests live in submodules by theme:
//! - `system`: the assembled pressure system, its solvers and the projection;
//! - `hydrostatic`: water at rest in 2D and 3D, with and without a collider;
//! - `dam_break`: the volume drift, the step bound, determinism and resume, a moving collider;
//! - `viscosity`: the implicit viscous solve;
//! - `setup`: the step control DIQ rejects (a gravity ramp, damping) and its serialised keys.

mod dam_break;
mod hydrostatic;
mod setup;
mod system;
mod viscosity;

use crate::fluid::{DiqFluid, DiqParams};
use crate::pressure::PressureMethod;
use mpm_core::boundary::{Boundaries, Contact, DomainWalls};
use mpm_core::material::{FluidMaterial, Tait};
use mpm_core::{
    Body, Columns, GridSpec, Material, Matrix, Particles, ParticlesBuilder, Real, Shape, Solver,
    StepControl, TimeStepPolicy, Vector,
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

/// The box `[lo, hi]` of water (material 0, density [`RHO`]) on the lattice of 2 particles per
/// cell and axis of the grid `spec` aligned with `lo`: the points `lo + (k + ½) Δx/2`, axis 0
/// fastest; at rest.
fn body<const D: usize>(spec: &GridSpec<D>, lo: [Real; D], hi: [Real; D]) -> Body<D> {
    Body::new(Shape::cuboid(lo, hi), 0)
        .lattice(2)
        .lattice_cells(Vector::<D>::from(lo), spec.dx)
        .density(RHO)
}

/// The particles of `body` on the grid `spec`.
fn particles<const D: usize>(spec: &GridSpec<D>, body: &Body<D>) -> Particles<D> {
    // The body carries its density, so no material table is needed.
    ParticlesBuilder::with_columns(spec, &[], Columns::default())
        .with(body)
        .expect("the body lies inside the grid")
        .build()
}

/// The particles of [`body`] over `[lo, hi]` on `spec` with velocity `v(x)`.
fn block<const D: usize>(
    spec: &GridSpec<D>,
    lo: [Real; D],
    hi: [Real; D],
    v: impl Fn(&Vector<D>) -> Vector<D> + Send + Sync + 'static,
) -> Particles<D> {
    let body = body(spec, lo, hi).velocity_field(move |x| (v(x), Matrix::<D>::zeros()));
    particles(spec, &body)
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
        step: StepControl {
            time_step: TimeStepPolicy::Adaptive {
                cfl: 0.4,
                dt_max,
                dt_min: 1e-9,
            },
            ..DiqParams::default().step
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
    let spec = grid([n, n], dx);
    DiqFluid::new(
        spec,
        p,
        vec![water()],
        walls(),
        block(&spec, [0.0, 0.0], [1.0, h], |_| Vector::<2>::zeros()),
    )
    .unwrap()
}

/// 2D dam break: a 0.4 × 0.6 m block in the corner of a 1 m box.
fn dam_break(n: usize, correction: bool) -> DiqFluid<2> {
    let dx = 1.0 / n as Real;
    let spec = grid([n, n], dx);
    DiqFluid::new(
        spec,
        params::<2>(1e-2, correction),
        vec![water()],
        walls(),
        block(&spec, [0.0, 0.0], [0.4, 0.6], |_| Vector::<2>::zeros()),
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
