//! Scenes shared by the in-process rank tests and the MPI check (`examples/mpi_check.rs`).
// Each user compiles this module and uses only some of its items.
#![allow(dead_code)]

use mpm_core::boundary::{Boundaries, WallTreatment};
use mpm_core::columns::particle_columns;
use mpm_core::prelude::*;
use mpm_core::{ColumnData, Dim, DimOps};
use mpm_explicit::{
    Activation, ContactCoupling, Coupling, CouplingKind, ExplicitParams, ExplicitSolver, Friction,
    Phases, PressureBuoyancy, VolumeUpdate,
};

/// Every column of `ps` as bit patterns, by column name.
pub fn bits<const D: usize>(ps: &Particles<D>) -> Vec<(String, Vec<u64>)> {
    particle_columns(ps)
        .into_iter()
        .map(|c| {
            let v = match c.data {
                ColumnData::F64 { values, .. } => values.iter().map(|v| v.to_bits()).collect(),
                ColumnData::U32 { values, .. } => values.iter().map(|&v| v as u64).collect(),
            };
            (c.name, v)
        })
        .collect()
}

/// `make()` after `steps` steps in one process.
pub fn serial<const D: usize>(make: impl Fn() -> ExplicitSolver<D>, steps: u64) -> ExplicitSolver<D>
where
    Dim<D>: DimOps<D>,
{
    let mut s = make();
    for _ in 0..steps {
        s.step().expect("the one-process run is stable");
    }
    s
}

/// Parameters with gravity 9.81 m/s² down along axis 1.
fn falling<const D: usize>() -> ExplicitParams<D> {
    let mut gravity = Vector::<D>::zeros();
    gravity[1] = -9.81;
    ExplicitParams {
        step: StepControl {
            gravity,
            ..StepControl::default()
        },
        ..ExplicitParams::default()
    }
}

/// The solver in a box with slip walls of 3 node layers.
fn in_box<const D: usize>(
    spec: GridSpec<D>,
    params: ExplicitParams<D>,
    materials: Vec<Material>,
    particles: Particles<D>,
) -> ExplicitSolver<D>
where
    Dim<D>: DimOps<D>,
{
    ExplicitSolver::new(
        spec,
        params,
        materials,
        Boundaries::slip_walls(3),
        particles,
    )
    .unwrap()
}

fn unit_square() -> GridSpec<2> {
    GridSpec::<2>::covering(Vector::<2>::zeros(), Vector::<2>::new(1.0, 1.0), 1.0 / 64.0)
}

/// The 2D dam break: a 0.4 m × 0.6 m water column collapsing in a 1 m box with slip walls
/// (3,900 particles), with the given wall treatment and volume update.
pub fn dam_break(treatment: WallTreatment, volume: VolumeUpdate) -> ExplicitSolver<2> {
    let spec = unit_square();
    let materials = vec![Material::fluid(1000.0, 2e5, 1e-3)];
    let column = Body::new(Shape::cuboid([0.05, 0.05], [0.45, 0.65]), 0).lattice(2);
    let particles = ParticlesBuilder::new(&spec, &materials)
        .with(&column)
        .unwrap()
        .build();
    let params = ExplicitParams {
        volume,
        ..falling()
    };
    let mut walls = Boundaries::slip_walls(3);
    if let Some(w) = &mut walls.walls {
        w.treatment = treatment;
    }
    ExplicitSolver::new(spec, params, materials, walls, particles).unwrap()
}

/// A jelly disk (radius 0.3 m) spinning at 12 rad/s about its centre, without gravity: every
/// particle off the axis moves, the rim by 0.36 m per 0.1 s, across the blocks of every rank.
pub fn rotating_disk() -> ExplicitSolver<2> {
    let spec = unit_square();
    let materials = vec![Material::neo_hookean(1000.0, 2e5, 0.3)];
    let w = 12.0;
    let shape = Shape::Sphere {
        center: Vector::<2>::new(0.5, 0.5),
        radius: 0.3,
    };
    let disk = Body::new(shape, 0)
        .lattice(2)
        .velocity_field(move |x: &Vector<2>| {
            let r = x - Vector::<2>::new(0.5, 0.5);
            let spin = Matrix::<2>::new(0.0, -w, w, 0.0);
            (spin * r, spin)
        });
    let particles = ParticlesBuilder::new(&spec, &materials)
        .with(&disk)
        .unwrap()
        .build();
    in_box(spec, ExplicitParams::default(), materials, particles)
}

/// A jelly cube of side `side` (m) thrown down and sideways in a 3D box of `cells` cells per
/// metre, 8 particles per cell.
pub fn cube_3d(side: Real, cells: usize) -> ExplicitSolver<3> {
    let dx = 1.0 / cells as Real;
    let spec = GridSpec::<3>::covering(Vector::<3>::zeros(), Vector::<3>::repeat(1.0), dx);
    let materials = vec![Material::neo_hookean(1000.0, 1e5, 0.3)];
    let lo = [0.5 - side / 2.0, 0.12, 0.5 - side / 2.0];
    let hi = [0.5 + side / 2.0, 0.12 + side, 0.5 + side / 2.0];
    let cube = Body::new(Shape::cuboid(lo, hi), 0)
        .lattice(2)
        .lattice_cells(Vector::<3>::from(lo), dx)
        .velocity(Vector::<3>::new(0.5, -1.0, 0.2));
    let particles = ParticlesBuilder::new(&spec, &materials)
        .with(&cube)
        .unwrap()
        .build();
    in_box(spec, falling(), materials, particles)
}

/// A jelly block (phase 0) thrown into a water pool (phase 1), coupled by frictional contact
/// on two grids.
pub fn jelly_into_water() -> ExplicitSolver<2> {
    let spec = unit_square();
    let materials = vec![
        Material::neo_hookean(400.0, 2e4, 0.3),
        Material::fluid(1000.0, 2e4, 0.0),
    ];
    let jelly = Body::new(Shape::cuboid([0.35, 0.45], [0.6, 0.65]), 0)
        .lattice(2)
        .velocity(Vector::<2>::new(0.3, -0.5));
    let pool = Body::new(Shape::cuboid([0.05, 0.05], [0.95, 0.35]), 1)
        .lattice(2)
        .extra(ParticleExtra {
            phase: 1,
            ..ParticleExtra::default()
        });
    let columns = Columns {
        phase: true,
        ..Columns::for_materials(&materials)
    };
    let particles = ParticlesBuilder::with_columns(&spec, &materials, columns)
        .with(&jelly)
        .unwrap()
        .with(&pool)
        .unwrap()
        .build();
    let params = ExplicitParams {
        phases: Phases {
            count: 2,
            couplings: vec![Coupling {
                phases: [0, 1],
                kind: CouplingKind::Contact(ContactCoupling {
                    normal_share: 1.0,
                    friction: Friction::Proportional(0.3),
                    activation: Activation::Always,
                }),
                buoyancy: None,
                pressure_buoyancy: PressureBuoyancy::Off,
            }],
        },
        ..falling()
    };
    in_box(spec, params, materials, particles)
}
