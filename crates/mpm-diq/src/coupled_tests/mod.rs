//! Tests of the coupled solver: Eq. 35's matrix, momentum, buoyancy, determinism and resume.
//!
//! This module holds the shared set-ups (materials, grids, bodies, the floating block, the
//! bitwise check); the tests live in submodules by theme:
//! - `system`: Eq. 35's matrix, momentum conservation, a solids-only plan, solid–solid contact;
//! - `floating`: solids in still water (clamped, buoyant, floating, sinking, a film on a wall);
//! - `stiff`: blocks dropped into the tank;
//! - `aulmpm`: A-ULMPM and plastic solids.

mod aulmpm;
mod floating;
mod stiff;
mod system;

use crate::coupled::{DiqCoupled, InterfaceQuadrature, SolidParams};
use crate::fluid::DiqParams;
use crate::pressure::{PressureParams, PressureSystem, UnknownKind};
use mpm_core::boundary::{Boundaries, Contact, DomainWalls};
use mpm_core::material::{ElasticModel, FluidMaterial, Lame, SolidMaterial, Tait};
use mpm_core::{
    Body, Columns, GridSpec, Material, Particles, ParticlesBuilder, Real, Shape, Solver,
    StepControl, TimeStepPolicy, Vector,
};

const RHO_F: Real = 1000.0;

fn materials(rho_s: Real, young: Real) -> Vec<Material> {
    vec![
        Material::Fluid(FluidMaterial {
            density: RHO_F,
            eos: Tait {
                bulk_modulus: 2e6,
                gamma: 7.0,
            },
            viscosity: 0.0,
        }),
        Material::Solid(SolidMaterial {
            density: rho_s,
            elastic: ElasticModel::NeoHookean(Lame::from_young_poisson(young, 0.3)),
            plasticity: Default::default(),
        }),
    ]
}

/// The unit tank at `n` cells per metre with one wall layer outside it: origin at −Δx, `n + 3`
/// nodes per axis.
fn tank(n: usize) -> GridSpec<2> {
    let dx = 1.0 / n as Real;
    GridSpec::new(Vector::<2>::from_element(-dx), dx, [n + 3, n + 3])
}

/// The unit square at `n` cells per metre without walls: origin at 0, `n + 1` nodes per axis.
fn open_grid(n: usize) -> GridSpec<2> {
    let dx = 1.0 / n as Real;
    GridSpec::new(Vector::<2>::zeros(), dx, [n + 1, n + 1])
}

/// The box `[lo, hi]` of material `material` with density `rho` (kg/m^D), on the lattice of 2
/// particles per cell and axis of the grid `spec` aligned with `lo`: the points
/// `lo + (k + ½) Δx/2`, axis 0 fastest; at rest.
fn lattice<const D: usize>(
    spec: &GridSpec<D>,
    (lo, hi): ([Real; D], [Real; D]),
    (material, rho): (u32, Real),
) -> Body<D> {
    Body::new(Shape::cuboid(lo, hi), material)
        .lattice(2)
        .lattice_cells(Vector::<D>::from(lo), spec.dx)
        .density(rho)
}

/// The particles of `bodies` on the grid `spec`, in order, with the columns `columns`.
fn particles_of<const D: usize>(
    spec: &GridSpec<D>,
    columns: Columns,
    bodies: &[Body<D>],
) -> Particles<D> {
    // The bodies carry their densities, so no material table is needed.
    let mut builder = ParticlesBuilder::with_columns(spec, &[], columns);
    for body in bodies {
        builder.add(body).expect("the body lies inside the grid");
    }
    builder.build()
}

fn params<const D: usize>(dt_max: Real, gravity: bool) -> DiqParams<D> {
    let mut p = DiqParams::<D> {
        step: StepControl {
            time_step: TimeStepPolicy::Adaptive {
                cfl: 0.4,
                dt_max,
                dt_min: 1e-9,
            },
            ..DiqParams::default().step
        },
        pressure: PressureParams {
            rel_tol: 1e-10,
            ..PressureParams::default()
        },
        ..DiqParams::default()
    };
    if !gravity {
        p.step.gravity = Vector::<D>::zeros();
    }
    p
}

fn walls<const D: usize>(on: bool) -> Boundaries<D> {
    Boundaries {
        walls: on.then_some(DomainWalls {
            contact: Contact::default(),
            thickness: 1,
            treatment: Default::default(),
        }),
        colliders: Vec::new(),
    }
}

fn columns() -> Columns {
    Columns {
        deformation_gradient: true,
        ..Columns::default()
    }
}

/// A 1 m × 1 m tank of `n` cells per axis with water up to `depth` and a square elastic block
/// of side `side` and density `rho_s` whose bottom sits at `bottom`, centred in x.
fn floating(
    n: usize,
    rho_s: Real,
    depth: Real,
    side: Real,
    bottom: Real,
    corr: bool,
) -> DiqCoupled<2> {
    let dx = 1.0 / n as Real;
    let (x0, x1) = (0.5 - side / 2.0, 0.5 + side / 2.0);
    let inside = move |x: &Vector<2>| {
        x[0] > x0 - 0.25 * dx && x[0] < x1 + 0.25 * dx && x[1] > bottom - 0.25 * dx
    };
    let spec = tank(n);
    let water = lattice(&spec, ([0.0, 0.0], [1.0, depth]), (0, RHO_F)).keep(move |x| !inside(x));
    let block = lattice(&spec, ([x0, bottom], [x1, bottom + side]), (1, rho_s));
    let ps = particles_of(&spec, columns(), &[water, block]);
    DiqCoupled::new(
        spec,
        DiqParams {
            position_correction: corr,
            ..params(5e-3, true)
        },
        SolidParams::default(),
        materials(rho_s, 1e5),
        walls(true),
        ps,
    )
    .unwrap()
}

/// Eq. 4 penalty contact of the solid with the unit tank's walls (as `mpm-cli` gives a scene's
/// walls to its solids).
fn tank_walls() -> Option<mpm_tlmpm::ContactParams<2>> {
    Some(mpm_tlmpm::ContactParams {
        radius: mpm_tlmpm::ContactRadius::FromVolume,
        obstacles: vec![mpm_tlmpm::Obstacle::Walls {
            min: Vector::<2>::zeros(),
            max: Vector::<2>::from_element(1.0),
        }],
    })
}

/// Runs `make()` for `2 · steps` steps with 1 and with 2 threads, and resumed from the
/// checkpoint after `steps` steps; asserts that the three end states are bitwise identical and
/// returns the resumed solver.
fn assert_bitwise_across_threads_and_resume(
    make: impl Fn() -> DiqCoupled<2> + Sync,
    steps: u64,
) -> DiqCoupled<2> {
    let run = |threads: usize| {
        crate::tests::with_threads(threads, || {
            let mut s = make();
            for _ in 0..steps {
                s.step().unwrap();
            }
            let mid = s.checkpoint();
            for _ in 0..steps {
                s.step().unwrap();
            }
            (mid, s.checkpoint())
        })
    };
    let (mid1, end1) = run(1);
    let (_, end2) = run(2);
    assert_eq!(end1, end2, "1 vs 2 threads");
    let mut resumed = make();
    resumed.restore(&mid1).unwrap();
    assert_eq!(resumed.steps(), steps);
    for _ in 0..steps {
        resumed.step().unwrap();
    }
    assert_eq!(resumed.checkpoint(), end1, "resume from checkpoint");
    resumed
}
